//! The dictionary for `canopen-core` at run time, for host tools that load
//! an EDS when they start (`vnode --eds`) rather than compiling it in.
//!
//! It holds the same tables a generated module holds in statics, built by
//! the same layout, so a dictionary behaves alike loaded or generated.

use canopen_core::od::{self, DeviceInfo, Dictionary, Entry, Limits};

use crate::codegen::{LayoutError, layout};
use crate::model::Eds;

/// The flash tables of a dictionary, owned.
#[derive(Clone, Debug)]
pub struct Tables {
    /// Entries sorted by (index, sub-index).
    pub entries: Vec<Entry>,
    /// Limits referenced by `limit_rows`.
    pub limits: Vec<Limits>,
    /// Each entry's row in `limits` (`NO_LIMITS` for none), parallel to
    /// `entries`; empty without limits.
    pub limit_rows: Vec<u8>,
    /// Values of `const` entries.
    pub rom: Vec<u8>,
    /// The RAM image from the defaults, `$NODEID` not yet added.
    pub defaults: Vec<u8>,
    /// Length of the RAM prefix that holds the stored values of 0x1000–0x1FFF.
    pub comm_len: usize,
    /// Length of the stored prefix of the RAM image.
    pub stored_len: usize,
    /// Length of the other values of 0x1000–0x1FFF, after the stored prefix.
    pub comm_rest: usize,
    /// Positions in `entries` of the `$NODEID`-relative entries.
    pub node_id_relative: Vec<u16>,
    /// Device facts from `[DeviceInfo]`.
    pub device: DeviceInfo,
}

impl Tables {
    /// Lays out a validated EDS as [`crate::codegen::generate`] does.
    pub fn new(eds: &Eds) -> Result<Tables, LayoutError> {
        let l = layout(eds)?;
        let f = &eds.device;
        Ok(Tables {
            // `layout` checked that offsets and positions fit in 16 bits, lengths in 8.
            entries: l
                .entries
                .iter()
                .map(|e| Entry::new(e.obj.index, e.sub.sub, e.data_type, e.attr, e.len as u8, e.offset as u16))
                .collect(),
            limit_rows: if l.limits.is_empty() { Vec::new() } else { l.entries.iter().map(|e| e.limits).collect() },
            limits: l.limits.iter().map(|&(low, high)| Limits { low, high }).collect(),
            rom: l.rom,
            defaults: l.ram,
            comm_len: l.comm_len,
            stored_len: l.stored_len,
            comm_rest: l.comm_rest,
            node_id_relative: l.node_id_relative.iter().map(|&p| p as u16).collect(),
            device: DeviceInfo {
                baud_rates: f.baud_rates,
                lss_supported: f.lss_supported,
                granularity: f.granularity,
                simple_boot_up_slave: f.simple_boot_up_slave,
                dynamic_channels: f.dynamic_channels,
                group_messaging: f.group_messaging,
            },
        })
    }

    /// The core's [`Dictionary`], which wants `'static` tables: the tables
    /// are leaked, once per process, as a generated module's statics live
    /// for the whole program.
    pub fn leak(self) -> &'static Dictionary {
        let entries: &'static [Entry] = self.entries.leak();
        Box::leak(Box::new(Dictionary {
            entries,
            limits: self.limits.leak(),
            limit_rows: self.limit_rows.leak(),
            rom: self.rom.leak(),
            defaults: {
                // As the generated module holds them: the runs that are not zero.
                let runs = crate::codegen::default_runs(&self.defaults);
                let bytes: Vec<u8> =
                    runs.iter().flat_map(|&(off, len)| self.defaults.get(off..off + len).unwrap_or_default().iter().copied()).collect();
                od::Defaults { len: self.defaults.len(), runs: crate::codegen::run_pairs(&runs).leak(), bytes: bytes.leak() }
            },
            comm_len: self.comm_len,
            stored_len: self.stored_len,
            comm_rest: self.comm_rest,
            node_id_relative: self.node_id_relative.leak(),
            device: self.device,
            layout_id: od::layout_id(entries),
        }))
    }
}

/// A dictionary loaded at run time with its RAM image: what a generated
/// `Ram` is for a compiled-in one.
#[derive(Clone, Debug)]
pub struct RuntimeRam {
    dictionary: &'static Dictionary,
    image: Vec<u8>,
}

impl RuntimeRam {
    /// The power-on values, with `$NODEID` defaults resolved for `node_id`.
    pub fn new(dictionary: &'static Dictionary, node_id: u8) -> RuntimeRam {
        let mut image = vec![0; dictionary.defaults.len];
        dictionary.reset_application(&mut image, node_id);
        dictionary.reset_communication(&mut image, node_id);
        RuntimeRam { dictionary, image }
    }
}

impl od::ObjectDictionary for RuntimeRam {
    fn dictionary(&self) -> &'static Dictionary {
        self.dictionary
    }
    fn image(&self) -> &[u8] {
        &self.image
    }
    fn image_mut(&mut self) -> &mut [u8] {
        &mut self.image
    }
}
