//! The communication services of a node and their configuration from the
//! communication area of the dictionary (0x1000–0x1FFF).

use crate::abort::AbortCode;
use crate::od::Dictionary;
use crate::services::emcy::EmcyProducer;
use crate::services::heartbeat::{Consumer, Guarding, Producer};
use crate::services::pdo::Pdos;
use crate::services::sync::SyncService;
use crate::time::Instant;
use crate::wire::emcy::Emcy;

/// Active errors and queued EMCY messages a node keeps.
pub const EMCY_SLOTS: usize = 8;

/// What 0x1029 sub 1 asks for on a communication error (CiA 301 §7.5.2.32).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorBehaviour {
    /// 0: enter Pre-operational (if Operational).
    PreOperational,
    /// 1: no state change.
    NoChange,
    /// 2: enter Stopped.
    Stopped,
}

/// The communication services and the identifiers they use.
#[derive(Clone, Debug)]
pub struct Comm<const R: usize, const T: usize, const HB: usize> {
    /// Heartbeat producer (0x1017).
    pub heartbeat: Producer,
    /// Heartbeat consumer (0x1016).
    pub consumers: Consumer<HB>,
    /// Node and life guarding (0x100C, 0x100D).
    pub guarding: Guarding,
    /// EMCY producer (0x1014, 0x1015) and the error register.
    pub emcy: EmcyProducer<EMCY_SLOTS, EMCY_SLOTS>,
    /// TIME consumer COB-ID, if 0x1012 bit 31 (consume) is set.
    pub time_cob_id: Option<u16>,
    /// SYNC consumer and producer (0x1005–0x1007, 0x1019).
    pub sync: SyncService,
    /// RPDOs and TPDOs (0x1400–0x1BFF).
    pub pdos: Pdos<R, T>,
    /// PDO mappings that did not resolve at the last reset communication.
    pub mapping_errors: u32,
}

impl<const R: usize, const T: usize, const HB: usize> Default for Comm<R, T, HB> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const R: usize, const T: usize, const HB: usize> Comm<R, T, HB> {
    /// The services before the first [`Comm::configure`]: all off, and all
    /// zero bits, so that a node built in a `const` lies in `.bss`.
    pub const fn new() -> Self {
        Comm {
            heartbeat: Producer::new(),
            consumers: Consumer::new(),
            guarding: Guarding::new(),
            emcy: EmcyProducer::new(),
            time_cob_id: None,
            sync: SyncService::UNCONFIGURED,
            pdos: Pdos::unconfigured(),
            mapping_errors: 0,
        }
    }

    /// Reads every communication parameter again (after reset communication).
    pub fn configure(&mut self, dict: &Dictionary, image: &[u8], node_id: u8, now: Instant) {
        self.emcy.reset();
        self.configure_emcy(dict, image);
        self.guarding.reset();
        for index in [0x100C, 0x1017, 0x1012] {
            self.reconfigure(index, dict, image, node_id, now);
        }
        self.sync.configure(dict, image);
        if self.pdos.configure(dict, image).is_err() {
            // That PDO stays disabled; the count is visible to tools and tests.
            self.mapping_errors = self.mapping_errors.saturating_add(1);
        }
        for i in 0..HB {
            let value = dict.read_u32(image, 0x1016, (i + 1) as u8).unwrap_or(0);
            self.consumers.configure(i, value);
        }
    }

    /// Applies 0x1014/0x1015.
    pub fn configure_emcy(&mut self, dict: &Dictionary, image: &[u8]) {
        // Without 0x1014 the pre-defined connection set applies, and 0x1015 defaults to 0.
        let cob = dict.read_u32(image, 0x1014, 0).unwrap_or(0x8000_0000);
        let inhibit = dict.read_u32(image, 0x1015, 0).unwrap_or(0) as u16;
        self.emcy.configure(cob, inhibit);
    }

    /// Applies a communication object after an SDO wrote it.
    pub fn reconfigure(&mut self, index: u16, dict: &Dictionary, image: &[u8], node_id: u8, now: Instant) {
        let _ = node_id;
        match index {
            0x1017 => {
                self.heartbeat.configure(dict.read_u32(image, 0x1017, 0).unwrap_or(0) as u16, now);
                if self.heartbeat.active() {
                    // Heartbeat replaces guarding (CiA 301 §7.2.8.3.2): no life guarding either.
                    self.guarding.disarm();
                }
            }
            0x100C | 0x100D => {
                let guard = dict.read_u32(image, 0x100C, 0).unwrap_or(0) as u16;
                let factor = dict.read_u32(image, 0x100D, 0).unwrap_or(0) as u8;
                self.guarding.configure(guard, factor);
            }
            0x1012 => {
                let v = dict.read_u32(image, 0x1012, 0).unwrap_or(0);
                self.time_cob_id = (v & 0x8000_0000 != 0).then_some((v & 0x7FF) as u16);
            }
            0x1015 => self.configure_emcy(dict, image),
            _ => {}
        }
    }

    /// What 0x1029 sub 1 says to do on a communication error.
    pub fn error_behaviour(dict: &Dictionary, image: &[u8]) -> ErrorBehaviour {
        match dict.read(image, 0x1029, 1) {
            Ok([1]) => ErrorBehaviour::NoChange,
            Ok([2]) => ErrorBehaviour::Stopped,
            _ => ErrorBehaviour::PreOperational,
        }
    }

    /// Records a sent EMCY: 0x1001 and, for an error, a new 0x1003 entry (newest at sub 1).
    pub fn record(&mut self, dict: &Dictionary, image: &mut [u8], e: &Emcy) {
        let _ = dict.write_unchecked(image, 0x1001, 0, &[e.register]);
        if e.code == 0 {
            return;
        }
        let Ok(count) = dict.find(0x1003, 0) else { return };
        let capacity = dict.entries.iter().filter(|x| x.index == 0x1003 && x.sub > 0).count().min(254) as u8;
        let used = dict.value(image, count).first().copied().unwrap_or(0).min(capacity);
        for sub in (2..=used.saturating_add(1).min(capacity)).rev() {
            if let Ok(prev) = dict.read(image, 0x1003, sub - 1) {
                let mut b = [0u8; 4];
                if let Some(dst) = b.get_mut(..prev.len().min(4)) {
                    dst.copy_from_slice(prev.get(..dst.len()).unwrap_or(&[]));
                }
                let _ = dict.write_unchecked(image, 0x1003, sub, &b);
            }
        }
        let [i0, i1, ..] = e.info;
        let value = u32::from(e.code) | (u32::from(u16::from_le_bytes([i0, i1])) << 16);
        let _ = dict.write_unchecked(image, 0x1003, 1, &value.to_le_bytes());
        let _ = dict.write_unchecked(image, 0x1003, 0, &[used.saturating_add(1).min(capacity)]);
    }

    /// 0x1003 sub 0 ← 0: the history is empty.
    pub fn clear_history(&mut self, dict: &Dictionary, image: &mut [u8]) {
        let _ = dict.write_unchecked(image, 0x1003, 0, &[0]);
        for sub in 1..=254u8 {
            if dict.write_unchecked(image, 0x1003, sub, &[0; 4]).is_err() {
                break;
            }
        }
    }

    /// A PDO communication or mapping parameter written by an SDO: the PDO
    /// service applies CiA 301's rules (a COB-ID changes only while invalid,
    /// mapping only through sub 0 = 0, ...).
    pub fn write_pdo(&mut self, index: u16, sub: u8, data: &[u8], dict: &Dictionary, image: &mut [u8]) -> Result<(), AbortCode> {
        match self.pdos.write_object(index, sub, data, dict, image) {
            Some(result) => result,
            None => dict.write(image, index, sub, data).map_err(Into::into),
        }
    }

    /// A SYNC parameter (0x1005–0x1007, 0x1019) written by an SDO.
    pub fn write_sync(&mut self, index: u16, sub: u8, data: &[u8], dict: &Dictionary, image: &mut [u8]) -> Result<(), AbortCode> {
        match self.sync.write_object(index, sub, data, dict, image) {
            Some(result) => result,
            None => dict.write(image, index, sub, data).map_err(Into::into),
        }
    }
}
