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

/// One 32-bit mask bank's FR1 (identifier 0) and FR2 (mask: IDE only),
/// in the layout STDID[10:0] EXID[17:0] IDE RTR 0: every standard frame,
/// data or remote, passes; 29-bit frames do not.
pub const ALL_STANDARD: (u32, u32) = (0, 1 << 2);

/// Whether `ids` (`AcceptanceList::ids`, `complete` from
/// `AcceptanceList::is_complete`) go into list banks; if not, one bank
/// holds [`ALL_STANDARD`].
pub fn fits(ids: &[AcceptedId], complete: bool) -> bool {
    complete && ids.len() <= BANKS * PER_LIST_BANK
}

/// The list banks for `ids`, in order: up to four identifiers each.
pub fn list_banks(ids: &[AcceptedId]) -> core::slice::Chunks<'_, AcceptedId> {
    ids.chunks(PER_LIST_BANK)
}

/// FR1 and FR2 of a 16-bit list bank holding `bank` (one to four
/// identifiers; a short bank repeats its last one, since an unused slot of
/// 0 would pass NMT's 0x000). Each entry is STDID[10:0] RTR IDE EXID[17:15]
/// with IDE = 0, so 29-bit frames never pass.
pub fn list_bank(bank: &[AcceptedId]) -> (u32, u32) {
    let mut words = [0u32; PER_LIST_BANK];
    let mut last = 0;
    for (i, word) in words.iter_mut().enumerate() {
        if let Some(id) = bank.get(i) {
            last = (u32::from(id.cob_id & 0x7FF) << 5) | (u32::from(id.rtr) << 4);
        }
        *word = last;
    }
    let [a, b, c, d] = words;
    (b << 16 | a, d << 16 | c)
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

    /// Every bank's (FR1, FR2) for `ids`, as `can::set_filters` programs them.
    fn banks(ids: &[AcceptedId], complete: bool) -> Vec<(u32, u32)> {
        if fits(ids, complete) { list_banks(ids).map(list_bank).collect() } else { std::vec![ALL_STANDARD] }
    }

    #[test]
    fn the_interop_node_takes_two_list_banks() {
        // NMT, SYNC, TIME, RPDO1, RPDO2, SDO, guarding RTR, LSS (tests/tests/acceptance.rs).
        let ids = [data(0x000), data(0x080), data(0x100), data(0x205), data(0x305), data(0x605), remote(0x705), data(0x7E5)];
        // Entries are id << 5 | RTR << 4: 0x080 → 0x1000, 0x100 → 0x2000, 0x205 → 0x40A0,
        // 0x305 → 0x60A0, 0x605 → 0xC0A0, 0x705 RTR → 0xE0B0, 0x7E5 → 0xFCA0.
        assert_eq!(banks(&ids, true), [(0x1000_0000, 0x40A0_2000), (0xC0A0_60A0, 0xFCA0_E0B0)]);
    }

    #[test]
    fn a_short_bank_repeats_its_last_entry() {
        let ids = [data(0x000), data(0x080), data(0x605), remote(0x705), data(0x7E5), data(0x7E6)];
        assert_eq!(banks(&ids, true), [(0x1000_0000, 0xE0B0_C0A0), (0xFCC0_FCA0, 0xFCC0_FCC0)]);
        assert_eq!(banks(&[remote(0x73F)], true), [(0xE7F0_E7F0, 0xE7F0_E7F0)]);
    }

    #[test]
    fn fifty_six_identifiers_fill_every_bank() {
        let ids: Vec<AcceptedId> = (0x181..0x181 + 56).map(data).collect();
        let words = banks(&ids, true);
        assert_eq!(words.len(), BANKS);
        let entries: Vec<u32> = words.iter().flat_map(|&(fr1, fr2)| [fr1 & 0xFFFF, fr1 >> 16, fr2 & 0xFFFF, fr2 >> 16]).collect();
        assert_eq!(entries, ids.iter().map(|id| u32::from(id.cob_id) << 5).collect::<Vec<_>>());
    }

    #[test]
    fn what_cannot_be_listed_passes_every_standard_frame() {
        assert_eq!(ALL_STANDARD, (0, 0x4), "identifier 0, mask IDE only");
        assert_eq!(banks(&[data(0x000)], false), [ALL_STANDARD], "the node's list overflowed");
        let ids: Vec<AcceptedId> = (0x181..0x181 + 57).map(data).collect();
        assert_eq!(banks(&ids, true), [ALL_STANDARD]);
        assert_eq!(banks(&[], true), [], "an empty list passes nothing");
    }
}
