//! Power-on and the NMT resets. Reset application restores the
//! application part of the dictionary (defaults, then the stored set) and
//! goes on with reset communication, which restores the communication part
//! and reconfigures every service from the image. Power-on is both, after
//! the stored LSS configuration.

use crate::id::CobId;
use crate::od::ObjectDictionary;
use crate::services::lss::UNCONFIGURED;
use crate::services::nmt::Nmt;
use crate::services::pdo::ALL_TPDOS;
use crate::services::store::{self, Part, StoredSet};
use crate::storage::Storage;
use crate::time::Instant;

use super::{Application, NmtEvent, Node};

/// First SDO server parameter object.
const SDO_SERVER_PARAMETER: u16 = 0x1200;

impl<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize, const SDO: usize>
    Node<O, A, S, R, T, HB, SDO>
{
    /// Powers on a node from [`Node::unpowered`], where it lies, with
    /// `node_id` as its default node-id: loads the stored parameters (an
    /// LSS configuration overrides `node_id`), resets application and
    /// communication, and queues the boot-up message for the first
    /// [`Node::process`]. Once per node; a running node restarts through
    /// NMT reset node instead.
    pub fn power_on(&mut self, node_id: u8, now: Instant) {
        self.node_id = node_id;
        // The TPDOs compare their data at their first chance, whatever the image held before.
        self.touched = ALL_TPDOS;
        // One check of the stored sets serves the LSS configuration and both parts of the reset.
        let stored = self.newest_stored();
        self.load_lss_configuration(stored);
        self.reset_application_from(stored, now);
    }

    /// Whether the node loads stored sets: the dictionary's 0x1010/0x1011
    /// (`Services::storage`) or the device's own store command (`Application::STORES`).
    const LOADS_STORED: bool = O::SERVICES.storage || A::STORES;

    /// The newest valid stored set; none on a node without storage, which
    /// then links no store code.
    fn newest_stored(&mut self) -> Option<StoredSet> {
        if Self::LOADS_STORED { store::newest(self.od.dictionary(), &mut self.storage) } else { None }
    }

    pub(super) fn reset_application(&mut self, now: Instant) {
        let stored = self.newest_stored();
        self.reset_application_from(stored, now);
    }

    /// Reset application (and then communication) with the newest stored set already found.
    pub(super) fn reset_application_from(&mut self, stored: Option<StoredSet>, now: Instant) {
        let dict = self.od.dictionary();
        let image = self.od.image_mut();
        dict.reset_application(image, self.node_id);
        if let Some(set) = stored.as_ref().filter(|_| Self::LOADS_STORED) {
            set.load(dict, image, self.node_id, &mut self.storage, Part::Application);
        }
        self.with_app(now, |app, ctx| app.on_nmt(ctx, NmtEvent::ResetApplication));
        self.reset_communication_from(stored, now);
    }

    pub(super) fn reset_communication(&mut self, now: Instant) {
        let stored = self.newest_stored();
        self.reset_communication_from(stored, now);
    }

    /// Reset communication with the newest stored set already found.
    pub(super) fn reset_communication_from(&mut self, stored: Option<StoredSet>, now: Instant) {
        self.stale = true;
        self.touched = ALL_TPDOS;
        // CiA 305: a node-id configured by LSS becomes active here.
        if let Some(lss) = self.lss_mut() {
            self.node_id = lss.reset_communication();
        }
        let dict = self.od.dictionary();
        let image = self.od.image_mut();
        dict.reset_communication(image, self.node_id);
        if let Some(set) = stored.as_ref().filter(|_| Self::LOADS_STORED) {
            set.load(dict, image, self.node_id, &mut self.storage, Part::Communication);
        }
        if let Some(serial) = self.serial {
            let _ = dict.write_unchecked(image, 0x1018, 4, &serial.to_le_bytes());
        }
        self.comm.configure(dict, image, self.node_id, now);
        if A::OPTIONS.tpdo_254_timer_only {
            self.comm.pdos.set_timer_only_254(true);
        }
        self.controller.reset();
        if A::OPTIONS.tpdo_255_timer_only_with_timer {
            self.comm.pdos.set_timer_only_255_with_timer(true);
        }
        self.refresh_lss();
        self.sdo.reset_all();
        self.configure_sdo();
        self.refresh_acceptance();
        self.nmt = Nmt::new();
        // An unconfigured node (0xFF) sends no boot-up and takes part in LSS only.
        self.boot_pending = self.node_id != UNCONFIGURED && self.app.canopen();
        self.start_pending = false;
        self.with_app(now, |app, ctx| app.on_nmt(ctx, NmtEvent::ResetCommunication));
    }

    /// Reads the SDO server parameters 0x1200 + i sub 1 and 2 (reset
    /// communication, or after an SDO wrote one). A server whose COB-IDs
    /// changed drops its transfer. The default server exists even without
    /// 0x1200 (pre-defined connection set); a further one needs its object.
    pub(super) fn configure_sdo(&mut self) {
        let dict = self.od.dictionary();
        let image = self.od.image();
        for (i, slot) in self.sdo_cob_ids.iter_mut().enumerate() {
            // 128 servers at most: 0x1280 and up are SDO client parameters.
            let Some(index) = u16::try_from(i).ok().filter(|&i| i < 0x80).map(|i| SDO_SERVER_PARAMETER + i) else { break };
            let (default_rx, default_tx) =
                if i == 0 { (Some(0x600 + u32::from(self.node_id)), Some(0x580 + u32::from(self.node_id))) } else { (None, None) };
            let rx = dict.read_u32(image, index, 1).or(default_rx);
            let tx = dict.read_u32(image, index, 2).or(default_tx);
            let new = match (rx.map(CobId), tx.map(CobId)) {
                (Some(rx), Some(tx)) if rx.is_valid() && tx.is_valid() => Some((rx.can_id(), tx.can_id())),
                _ => None,
            };
            if *slot != new {
                self.sdo.reset(i);
                *slot = new;
            }
        }
    }
}
