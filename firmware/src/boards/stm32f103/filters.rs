//! bxCAN acceptance filter banks from the node's identifier list
//! (`Node::acceptance`), RM0008 §24.7.4 and §24.9.4.
//!
//! The STM32F103 has 14 banks. A bank in 16-bit list mode holds four
//! standard identifiers, each with its RTR bit and IDE = 0 (so 29-bit
//! frames never pass), which makes a data frame and a remote frame on one
//! COB-ID two entries, exactly as the list has them. The core lists at most
//! [`ACCEPTANCE_CAPACITY`] identifiers, which always fit in list banks, so
//! no mask bank for a range (such as the heartbeat producers 0x701–0x77F)
//! is ever needed; a node that consumes more than that gets an incomplete
//! list, and then one 32-bit mask bank passes every standard frame. No
//! identifier the node needs is ever dropped.

use canopen_core::node::{ACCEPTANCE_CAPACITY, AcceptedId};

/// Filter banks of the STM32F103's single bxCAN.
pub const BANKS: usize = 14;
/// Identifiers a 16-bit list bank holds.
const PER_LIST_BANK: usize = 4;

const _: () = assert!(ACCEPTANCE_CAPACITY <= BANKS * PER_LIST_BANK, "a complete list must fit in list banks");

/// Whether `ids` (`AcceptanceList::ids`, `complete` from
/// `AcceptanceList::is_complete`) go into list banks; if not, one 32-bit
/// mask bank passes every standard frame (identifier 0, mask IDE only).
pub fn fits(ids: &[AcceptedId], complete: bool) -> bool {
    complete && ids.len() <= BANKS * PER_LIST_BANK
}

/// The list banks for `ids`, in order: up to four identifiers each.
pub fn list_banks(ids: &[AcceptedId]) -> core::slice::Chunks<'_, AcceptedId> {
    ids.chunks(PER_LIST_BANK)
}

/// The four entries of a 16-bit list bank holding `bank` (one to four
/// identifiers): a short bank repeats its last one, since an unused slot
/// (identifier 0) would pass NMT's 0x000. `can::set_filters` hands them to
/// bxcan's `ListEntry16` (STDID[10:0] RTR IDE EXID[17:15], IDE = 0, so
/// 29-bit frames never pass).
pub fn list_entries(bank: &[AcceptedId]) -> [AcceptedId; PER_LIST_BANK] {
    let mut entries = [AcceptedId::default(); PER_LIST_BANK];
    let mut last = AcceptedId::default();
    for (i, entry) in entries.iter_mut().enumerate() {
        if let Some(&id) = bank.get(i) {
            last = id;
        }
        *entry = last;
    }
    entries
}

#[cfg(test)]
mod tests {
    extern crate std;

    use std::vec::Vec;

    use super::*;

    fn data(cob_id: u16) -> AcceptedId {
        AcceptedId { cob_id, rtr: false }
    }

    fn remote(cob_id: u16) -> AcceptedId {
        AcceptedId { cob_id, rtr: true }
    }

    /// Every bank's entries for `ids`, as `can::set_filters` programs them (`None`: the mask bank).
    fn banks(ids: &[AcceptedId], complete: bool) -> Option<Vec<[AcceptedId; 4]>> {
        fits(ids, complete).then(|| list_banks(ids).map(list_entries).collect())
    }

    #[test]
    fn the_interop_node_takes_two_list_banks() {
        // NMT, SYNC, TIME, RPDO1, RPDO2, SDO, guarding RTR, LSS (tests/tests/acceptance.rs).
        let ids = [data(0x000), data(0x080), data(0x100), data(0x205), data(0x305), data(0x605), remote(0x705), data(0x7E5)];
        let expected = [[data(0x000), data(0x080), data(0x100), data(0x205)], [data(0x305), data(0x605), remote(0x705), data(0x7E5)]];
        assert_eq!(banks(&ids, true), Some(expected.to_vec()));
    }

    #[test]
    fn a_short_bank_repeats_its_last_entry() {
        let ids = [data(0x000), data(0x080), data(0x605), remote(0x705), data(0x7E5), data(0x7E6)];
        let expected = [[data(0x000), data(0x080), data(0x605), remote(0x705)], [data(0x7E5), data(0x7E6), data(0x7E6), data(0x7E6)]];
        assert_eq!(banks(&ids, true), Some(expected.to_vec()));
        assert_eq!(banks(&[remote(0x73F)], true), Some(std::vec![[remote(0x73F); 4]]));
    }

    #[test]
    fn fifty_six_identifiers_fill_every_bank() {
        let ids: Vec<AcceptedId> = (0x181..0x181 + 56).map(data).collect();
        let banks = banks(&ids, true).expect("list banks");
        assert_eq!(banks.len(), BANKS);
        assert_eq!(banks.concat(), ids);
    }

    #[test]
    fn what_cannot_be_listed_passes_every_standard_frame() {
        assert_eq!(banks(&[data(0x000)], false), None, "the node's list overflowed");
        let ids: Vec<AcceptedId> = (0x181..0x181 + 57).map(data).collect();
        assert_eq!(banks(&ids, true), None);
        assert_eq!(banks(&[], true), Some(std::vec![]), "an empty list passes nothing");
    }
}
