//! Rust code for one dictionary: flash tables, one RAM struct, typed accessors.
//!
//! The output has this order (style guide §2.5): index constants, sizing
//! constants, entry tables, the `Ram` struct, its accessors. It is
//! rustfmt-clean, warning-free and has no trait object per entry.
//!
//! `layout` places every entry (offsets in the RAM image and in flash,
//! the limits table, the `$NODEID`-relative entries); `names` makes the
//! Rust names; `emit` writes the module, `tables` its flash tables (each
//! row with its object as a comment) and `accessors` the typed accessors
//! of `Ram`.

mod accessors;
mod emit;
mod layout;
pub use layout::NEVER_STORED;
mod names;
mod tables;
pub(crate) use tables::{default_runs, run_pairs};

use canopen_core::od::{DataType, Number, Services};

use crate::model::{Eds, SubObject};

pub use emit::generate_with;
pub use layout::LayoutError;
pub(crate) use layout::layout;
pub use names::snake;

/// Generates the module for `eds`. `source` is the file name quoted in comments.
pub fn generate(eds: &Eds, source: &str) -> Result<String, LayoutError> {
    generate_with(eds, source, services(eds))
}

/// Bytes of the RAM image of the module [`generate`] makes for `eds` (its `RAM_SIZE`).
pub fn ram_size(eds: &Eds) -> Result<usize, LayoutError> {
    Ok(layout(eds)?.ram.len())
}

/// Bytes of that image a stored parameter set holds (its `STORED_SIZE`):
/// the values at its front a reset loads, and those of [`Eds::kept`].
pub fn stored_size(eds: &Eds) -> Result<usize, LayoutError> {
    Ok(layout(eds)?.stored_len)
}

/// Values longer than this (or a DOMAIN) make block transfer worth linking:
/// below it a segmented transfer takes a handful of frames.
pub const BLOCK_THRESHOLD: usize = 64;

/// The optional services a node on `eds` links, from its objects: LSS if
/// `LSS_Supported`, block SDO if a value is a DOMAIN or longer than
/// [`BLOCK_THRESHOLD`] bytes, guarding with 0x100C and 0x100D (or without
/// a heartbeat producer 0x1017: CiA 301 asks for one error control
/// protocol, so such a node keeps answering guarding requests), TIME with
/// 0x1012, storage with 0x1010 or 0x1011 (or LSS, which stores its
/// configuration; a device that stores by a command of its own says so
/// with `Application::STORES`), and the acceptance list always (the
/// boards that build a device's image program their filter from it).
pub fn services(eds: &Eds) -> Services {
    let has = |i: u16| eds.objects.get(&i).is_some_and(|o| !o.opaque);
    let large = eds
        .objects
        .values()
        .filter(|o| !o.opaque)
        .flat_map(|o| o.subs.values())
        .any(|s| s.data_type == Some(DataType::Domain) || (s.data_type.is_some() && s.size() > BLOCK_THRESHOLD));
    Services {
        lss: eds.device.lss_supported,
        block_sdo: large,
        guarding: (has(0x100C) && has(0x100D)) || !has(0x1017),
        time: has(0x1012),
        storage: has(0x1010) || has(0x1011) || eds.device.lss_supported,
        acceptance: true,
    }
}

/// The value as the doc generator prints it.
pub fn show_value(s: &SubObject) -> String {
    let Some(t) = s.data_type else { return String::new() };
    let v = match t {
        DataType::VisibleString => format!("\"{}\"", String::from_utf8_lossy(&s.value)),
        DataType::Domain => String::new(),
        _ if t.size().is_none() || matches!(t, DataType::TimeOfDay | DataType::TimeDifference) => {
            s.value.iter().map(|b| format!("{b:02X}")).collect::<Vec<_>>().join(" ")
        }
        _ => match Number::decode(t, &s.value) {
            Some(Number::Unsigned(v)) if v > 9 => format!("0x{v:X}"),
            Some(Number::Unsigned(v)) => v.to_string(),
            Some(Number::Signed(v)) => v.to_string(),
            Some(Number::Real(v)) => format!("{v}"),
            None => String::new(),
        },
    };
    if s.node_id { format!("$NODEID+{v}") } else { v }
}
