//! The identifiers the node consumes, for a CAN controller's acceptance
//! filter: NMT, SYNC (0x1005), TIME (0x1012), each SDO server's
//! client→server COB-ID (0x1200–0x127F), each valid RPDO, the remote frame
//! of each TPDO that allows one (0x1800–0x19FF), node guarding, each
//! heartbeat consumer's producer (0x1016) and LSS (CiA 305).
//!
//! The list is rebuilt where those objects take effect (reset
//! communication, an SDO download to one of those objects) from the services' own state, so it
//! holds exactly what [`Node::on_frame`] reacts to: a frame whose
//! (COB-ID, remote) pair is not on it changes nothing in the node but its
//! receive counters. It does not follow the NMT state (a Stopped node still
//! lists its SDO and PDO identifiers), so an NMT command never makes a
//! controller reprogram its filter. [`AcceptanceList::generation`] moves
//! only when the list itself changed.
//!
//! A dictionary built without [`Services::acceptance`](crate::od::Services::acceptance)
//! keeps no list: [`Node::acceptance`] is then one that is not complete, and
//! rebuilding it does nothing.

use crate::od::ObjectDictionary;
use crate::services::lss::UNCONFIGURED;
use crate::storage::Storage;
use crate::wire::lss::MASTER_COB_ID as LSS_MASTER_COB_ID;
use crate::wire::nmt::{NMT_COB_ID, error_control_cob_id};

use super::{Application, Node};

/// Identifiers an [`AcceptanceList`] holds. With the counts of any device
/// here (4 SDO servers, 4 + 4 PDOs, 4 heartbeat consumers: 21) there is
/// room to spare; a node with more is listed as "accept everything".
pub const ACCEPTANCE_CAPACITY: usize = 32;

/// One identifier the node reacts to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct AcceptedId {
    /// The 11-bit CAN-ID.
    pub cob_id: u16,
    /// A remote frame (RTR) rather than a data frame.
    pub rtr: bool,
}

/// The identifiers a node reacts to, each once. At most 32 entries, so a
/// linear search is as fast as any and smaller than sorting.
#[derive(Clone, Debug)]
// The count and the flags before the identifiers: shorter offsets on thumbv7m.
#[repr(C)]
pub struct AcceptanceList {
    len: usize,
    generation: u32,
    /// More identifiers than fit, or no list kept (without
    /// [`Services::acceptance`](crate::od::Services::acceptance), set at
    /// power-on): the list is not complete. Not `complete`, so that a new
    /// list is all zero bits ([`crate::node`]).
    pub(super) overflowed: bool,
    /// A rebuild in place ([`Node::refresh_acceptance`]) wrote an
    /// identifier other than the one its slot held.
    changed: bool,
    ids: [AcceptedId; ACCEPTANCE_CAPACITY],
}

/// Two lists are equal when they list the same identifiers in the same
/// order, are both complete or not, and are of the same generation (the
/// slots past the end, which a rebuild in place leaves as they were, do
/// not count).
impl PartialEq for AcceptanceList {
    fn eq(&self, other: &Self) -> bool {
        self.ids() == other.ids() && self.overflowed == other.overflowed && self.generation == other.generation
    }
}

impl Eq for AcceptanceList {}

impl Default for AcceptanceList {
    fn default() -> Self {
        Self::new()
    }
}

impl AcceptanceList {
    /// An empty list (complete: nothing to accept).
    pub const fn new() -> Self {
        AcceptanceList {
            ids: [AcceptedId { cob_id: 0, rtr: false }; ACCEPTANCE_CAPACITY],
            len: 0,
            overflowed: false,
            generation: 0,
            changed: false,
        }
    }

    /// The identifiers, each once, in the order the node lists them (the
    /// same order for the same configuration).
    pub fn ids(&self) -> &[AcceptedId] {
        self.ids.get(..self.len).unwrap_or(&[])
    }

    /// False when the node consumes more identifiers than the list holds:
    /// then a filter must pass every 11-bit frame.
    pub fn is_complete(&self) -> bool {
        !self.overflowed
    }

    /// Changes (wrapping) each time the list does; a board reprograms its
    /// filter when this differs from the generation it applied.
    pub fn generation(&self) -> u32 {
        self.generation
    }

    /// Whether a filter built from this list passes an 11-bit frame.
    pub fn accepts(&self, cob_id: u16, rtr: bool) -> bool {
        self.overflowed || self.ids().contains(&AcceptedId { cob_id, rtr })
    }

    pub(super) fn insert(&mut self, cob_id: u16, rtr: bool) {
        let id = AcceptedId { cob_id, rtr };
        if self.ids().contains(&id) {
            return;
        }
        match self.ids.get_mut(self.len) {
            Some(slot) => {
                self.changed |= *slot != id;
                *slot = id;
                // `get_mut` found the slot: `len` is below the list's length.
                #[allow(clippy::arithmetic_side_effects)]
                {
                    self.len += 1;
                }
            }
            None => self.overflowed = true,
        }
    }
}

impl<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize, const SDO: usize>
    Node<O, A, S, R, T, HB, SDO>
{
    /// The identifiers the node reacts to (see the [module docs](self)).
    /// Without [`Services::acceptance`](crate::od::Services::acceptance)
    /// the node keeps no list and this is one that is not complete: a
    /// filter built from it passes every frame.
    pub fn acceptance(&self) -> &AcceptanceList {
        &self.acceptance
    }

    /// Rebuilds the list from the services; a new list gets the next
    /// generation. In place (no second list to build, copy and compare):
    /// the identifiers come in the same order for the same configuration,
    /// so the list changed if a slot got another identifier or the length
    /// or completeness moved.
    pub(super) fn refresh_acceptance(&mut self) {
        if !O::SERVICES.acceptance {
            return;
        }
        let (len, overflowed) = (self.acceptance.len, self.acceptance.overflowed);
        let list = &mut self.acceptance;
        (list.len, list.overflowed, list.changed) = (0, false, false);
        if self.lss_supported() && self.app.canopen() {
            self.acceptance.insert(LSS_MASTER_COB_ID, false);
        }
        // An unconfigured node takes part in LSS only; a device that switched CANopen off, in nothing.
        if self.hook.node_id != UNCONFIGURED && self.app.canopen() {
            self.acceptance.insert(NMT_COB_ID, false);
            self.acceptance.insert(error_control_cob_id(self.hook.node_id), true);
            self.acceptance.insert(self.comm.sync.cob_id(), false);
            if let Some(time) = self.comm.time_cob_id {
                self.acceptance.insert(time, false);
            }
            for (rx, _) in self.sdo_cob_ids.iter().flatten() {
                self.acceptance.insert(*rx, false);
            }
            for n in 0..R {
                if let Some(id) = self.comm.pdos.rpdo(n).and_then(|r| r.cob_id()) {
                    self.acceptance.insert(id, false);
                }
            }
            for n in 0..T {
                if let Some(id) = self.comm.pdos.tpdo(n).filter(|t| t.params().rtr_allowed()).and_then(|t| t.cob_id()) {
                    self.acceptance.insert(id, true);
                }
            }
            // The consumers as 0x1016 configured them (reset communication,
            // or the SDO download that wrote an entry).
            for producer in self.comm.consumers.producers() {
                // The node's own 0x700 + id is node guarding, never a heartbeat it consumes.
                if (1..=127).contains(&producer) && producer != self.hook.node_id {
                    self.acceptance.insert(error_control_cob_id(producer), false);
                }
            }
        }
        self.app.claim_ids(self.od.dictionary(), self.od.image(), &mut super::Claims { list: &mut self.acceptance });
        let list = &mut self.acceptance;
        if list.changed || list.len != len || list.overflowed != overflowed {
            list.generation = list.generation.wrapping_add(1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ids(list: &AcceptanceList) -> std::vec::Vec<(u16, bool)> {
        list.ids().iter().map(|a| (a.cob_id, a.rtr)).collect()
    }

    #[test]
    fn insert_keeps_each_identifier_once_in_order() {
        let mut list = AcceptanceList::default();
        for (id, rtr) in [(0x705, false), (0x000, false), (0x705, true), (0x181, true), (0x705, false)] {
            list.insert(id, rtr);
        }
        assert_eq!(ids(&list), [(0x705, false), (0x000, false), (0x705, true), (0x181, true)]);
        assert!(list.accepts(0x705, true));
        assert!(!list.accepts(0x181, false));
    }

    #[test]
    fn lists_compare_by_their_identifiers_not_the_slots_past_the_end() {
        let (mut a, mut b) = (AcceptanceList::default(), AcceptanceList::default());
        a.insert(0x181, false);
        a.insert(0x201, false);
        a.len = 1;
        b.insert(0x181, false);
        assert_eq!(a, b);
        b.insert(0x202, false);
        assert_ne!(a, b);
    }

    #[test]
    fn a_full_list_is_incomplete_and_accepts_everything() {
        let mut list = AcceptanceList::default();
        for id in 0..ACCEPTANCE_CAPACITY as u16 {
            list.insert(id, false);
        }
        assert!(list.is_complete());
        assert!(!list.accepts(0x7FF, false));
        list.insert(0x7FF, false);
        assert!(!list.is_complete());
        assert_eq!(list.ids().len(), ACCEPTANCE_CAPACITY);
        assert!(list.accepts(0x7FF, true));
    }
}
