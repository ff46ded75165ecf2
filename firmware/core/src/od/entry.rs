//! Entry metadata: what the flash table says about one (index, sub-index).

use super::types::DataType;

/// Access and placement attributes of an entry, as a bit set.
///
/// The EDS `AccessType` (CiA 306 §4.6.3) is folded into these bits by od-gen:
/// `ro` = READ, `wo` = WRITE, `rw` = READ|WRITE, `rwr`/`rww` add the PDO
/// direction, and `const` = READ|IN_ROM.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct Attr(pub u8);

impl Attr {
    /// An SDO may upload the value.
    pub const READ: Attr = Attr(1 << 0);
    /// An SDO may download the value.
    pub const WRITE: Attr = Attr(1 << 1);
    /// The value is a constant in flash and takes no RAM.
    pub const IN_ROM: Attr = Attr(1 << 2);
    /// The entry may be mapped into a TPDO (process input: `ro`, `rwr`, `rw`, `const`).
    pub const MAP_TPDO: Attr = Attr(1 << 3);
    /// The entry may be mapped into an RPDO (process output: `wo`, `rww`, `rw`).
    pub const MAP_RPDO: Attr = Attr(1 << 4);
    /// The default is `$NODEID` plus the stored value; it is resolved at reset communication.
    pub const NODE_ID: Attr = Attr(1 << 5);
    /// The object is a manufacturer parameter (0x2000–0x5FFF): store scope 4.
    /// Set by [`Entry::new`] from the index, with [`Attr::APPLICATION`], so
    /// that the store's walks over all entries take an entry's scope from
    /// the byte they load anyway, not from its index.
    pub const MANUFACTURER: Attr = Attr(1 << 6);
    /// The object is an application (profile) parameter (0x6000 and up):
    /// store scope 3. Neither scope bit: the communication area (below 0x2000).
    pub const APPLICATION: Attr = Attr(1 << 7);
    /// The two scope bits, which [`super::layout_id`] leaves out of its hash.
    pub const SCOPE: Attr = Attr(Attr::MANUFACTURER.0 | Attr::APPLICATION.0);

    /// The scope bits of the object at `index`.
    pub const fn scope_of(index: u16) -> Attr {
        match index {
            0x0000..=0x1FFF => Attr(0),
            0x2000..=0x5FFF => Attr::MANUFACTURER,
            _ => Attr::APPLICATION,
        }
    }

    /// Whether every bit of `other` is set.
    pub const fn contains(self, other: Attr) -> bool {
        self.0 & other.0 == other.0
    }

    /// The union of two sets.
    pub const fn union(self, other: Attr) -> Attr {
        Attr(self.0 | other.0)
    }
}

/// Inclusive value limits, stored as raw 64-bit patterns: sign-extended for
/// signed types, zero-extended for unsigned ones, IEEE bits for REAL32/REAL64
/// (a REAL32 limit is widened to f64 bits).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Limits {
    /// Lowest allowed value.
    pub low: u64,
    /// Highest allowed value.
    pub high: u64,
}

/// The row in [`super::Dictionary::limit_rows`] of an entry without limits.
pub const NO_LIMITS: u8 = u8::MAX;

/// One sub-object of the dictionary.
///
/// 8 bytes in flash, packed (Cortex-M3 loads the unaligned half-words
/// directly): the largest dictionary has about 380 entries. Two bytes came
/// out of the 10 it had: the limits row, which only a download's check
/// reads, is in a table parallel to the entries
/// ([`super::Dictionary::limit_rows`]) that a dictionary without limits
/// leaves empty, and the length is one byte (od-gen refuses a string of
/// more than 255 bytes: no device or corpus file has one longer than 200).
/// ds301: 1,720 → 1,376 B. Tables of entries are sorted by (index,
/// sub-index) so that lookup is a binary search.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(C, packed)]
pub struct Entry {
    /// Object index.
    pub index: u16,
    /// Sub-index.
    pub sub: u8,
    /// Data type.
    pub data_type: DataType,
    /// Access and placement, and the store's scope in bits 6–7, which
    /// [`Entry::new`] sets from the index: build entries with it (od-gen
    /// does), a struct literal with other scope bits puts the value in the
    /// wrong part of the store and of the resets.
    pub attr: Attr,
    /// Size of the value in bytes (the capacity for strings, at most 255; 0 for DOMAIN).
    pub len: u8,
    /// Byte offset of the value in the RAM image, or in the ROM blob if [`Attr::IN_ROM`].
    pub offset: u16,
}

impl Entry {
    /// An entry; generated tables use this to stay one line per entry. The
    /// scope bits of `attr` are set from `index` ([`Attr::scope_of`]).
    pub const fn new(index: u16, sub: u8, data_type: DataType, attr: Attr, len: u8, offset: u16) -> Entry {
        let attr = Attr((attr.0 & !Attr::SCOPE.0) | Attr::scope_of(index).0);
        Entry { index, sub, data_type, attr, len, offset }
    }

    /// Whether the object is in the communication area (0x1000–0x1FFF, and
    /// the data types below it): no scope bit set.
    pub const fn communication(&self) -> bool {
        self.attr.0 & Attr::SCOPE.0 == 0
    }

    /// The 24-bit key the tables are sorted by.
    pub const fn key(&self) -> u32 {
        ((self.index as u32) << 8) | self.sub as u32
    }

    /// Whether an SDO may read it.
    pub const fn readable(&self) -> bool {
        self.attr.contains(Attr::READ)
    }

    /// Whether an SDO may write it.
    pub const fn writable(&self) -> bool {
        self.attr.contains(Attr::WRITE)
    }

    /// Whether the value lives in flash.
    pub const fn in_rom(&self) -> bool {
        self.attr.contains(Attr::IN_ROM)
    }

    /// Byte range of the value in its image (RAM or ROM).
    // A u16 and a u8: the sum fits a usize.
    #[allow(clippy::arithmetic_side_effects)]
    pub const fn range(&self) -> core::ops::Range<usize> {
        self.offset as usize..self.offset as usize + self.len as usize
    }
}

/// An entry a caller found once with [`super::Dictionary::locate`] and
/// keeps: its position in the dictionary's table plus one, so that the
/// all-zero [`EntryRef::NONE`] stands for an object the dictionary lacks
/// (and a value holding it can be all zero bits, [`crate::node`]). A profile
/// reads and writes its objects on every frame; this spares the binary
/// search each time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EntryRef(pub(super) u16);

impl EntryRef {
    /// No entry.
    pub const NONE: EntryRef = EntryRef(0);

    /// Whether the dictionary has the entry.
    pub const fn is_some(self) -> bool {
        self.0 != 0
    }
}
