//! A stored set the node refuses for its layout: see [`refused`].

use super::{HEADER, MAGIC, VERSION, payload_crc, read_header};
use crate::od::Dictionary;
use crate::storage::Storage;

/// Whether the parameters last saved are lost because their set belongs to
/// another dictionary layout (a firmware update changed the dictionary: the
/// set's layout id or length differ, so a reset refuses it and the node
/// runs on its defaults, as after 0x1011 "load"). True when no region holds
/// a set header of `dict` and one holds a complete set of another layout:
/// its CRC over its own length holds, so a header a power cut left half
/// written is not taken for one. The next 0x1010 "save" or 0x1011 "load"
/// writes a set of this layout and ends it. A device reports it as its
/// manual says (the EC5000: EMCY 0x6310 "loss of parameters"); the node
/// itself does not, and links none of this unless a device asks
/// ([`crate::node::Ctx::stored_set_refused`]). Reads the two headers, and
/// the payload of a set of another layout once.
pub fn refused(dict: &Dictionary, storage: &mut dyn Storage) -> bool {
    if (0..2).any(|region| read_header(storage, region, dict).is_some()) {
        return false;
    }
    (0..2).any(|region| {
        let mut h = [0u8; HEADER];
        if storage.read(region, 0, &mut h).is_err() {
            return false;
        }
        let [m0, m1, m2, m3, v0, v1, _, _, _, _, _, _, _, _, _, _, n0, n1, _, _, c0, c1, c2, c3] = h;
        let len = usize::from(u16::from_le_bytes([n0, n1]));
        u32::from_le_bytes([m0, m1, m2, m3]) == MAGIC
            && u16::from_le_bytes([v0, v1]) == VERSION
            && HEADER.saturating_add(len) <= storage.region_size()
            && payload_crc(storage, region, len) == Ok(u32::from_le_bytes([c0, c1, c2, c3]))
    })
}
