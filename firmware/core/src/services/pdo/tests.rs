//! PDO tests on a small hand-built dictionary: exact payloads at exact
//! times. This file holds the dictionary and the harness; the tests are in
//! `tests/`, by topic: `configuration`, `tpdo` (by transmission type, and
//! the mapped sources), `rpdo` (and the synchronous window) and
//! `parameters` (the SDO downloads of the parameter records: the CiA 301
//! mapping procedure with every abort code). Case numbers refer to the CiA
//! 310 conformance test tool (docs: /work/shared/notes/cia-notes.md
//! appendix A).

use super::*;
use crate::od::{Attr, DataType, DeviceInfo, Entry, Limits, NO_LIMITS};
use crate::wire::emcy::EmcyCode;

// ---- The dictionary ------------------------------------------------------------

const RO: Attr = Attr::READ;
const RW: Attr = Attr(Attr::READ.0 | Attr::WRITE.0);
const CONST: Attr = Attr(Attr::READ.0 | Attr::IN_ROM.0);
/// `rw`, mappable both ways.
const RW_PDO: Attr = Attr(RW.0 | Attr::MAP_RPDO.0 | Attr::MAP_TPDO.0);
/// `rww`: RPDO only.
const RWW: Attr = Attr(RW.0 | Attr::MAP_RPDO.0);
/// `ro` + PDOMapping: TPDO only.
const RO_T: Attr = Attr(RO.0 | Attr::MAP_TPDO.0);
/// `const` + PDOMapping.
const CONST_T: Attr = Attr(CONST.0 | Attr::MAP_TPDO.0);

const fn e(index: u16, sub: u8, data_type: DataType, attr: Attr, len: u8, offset: u16) -> Entry {
    Entry::new(index, sub, data_type, attr, len, offset)
}

/// A mapping's sub 0, limited to 0..=8 ([`LIMIT_ROWS`]).
const fn map_count(index: u16, offset: u16) -> Entry {
    Entry::new(index, 0, DataType::Unsigned8, RW, 1, offset)
}

const fn map(index: u16, sub: u8, offset: u16) -> Entry {
    e(index, sub, DataType::Unsigned32, RW, 4, offset)
}

use DataType::{Domain, Integer16, OctetString, Unsigned8, Unsigned16, Unsigned32, Unsigned64};

const RAM: usize = 176;

static ENTRIES: [Entry; 60] = [
    // RPDO1: writable COB-ID, inhibit time and event timer.
    e(0x1400, 0, Unsigned8, CONST, 1, 0),
    e(0x1400, 1, Unsigned32, RW, 4, 0),
    e(0x1400, 2, Unsigned8, RW, 1, 4),
    e(0x1400, 3, Unsigned16, RW, 2, 5),
    e(0x1400, 5, Unsigned16, RW, 2, 7),
    // RPDO2: read-only COB-ID and no sub 3/5, as the ec5000's RPDOs.
    e(0x1401, 0, Unsigned8, CONST, 1, 1),
    e(0x1401, 1, Unsigned32, RO, 4, 9),
    e(0x1401, 2, Unsigned8, RW, 1, 13),
    map_count(0x1600, 14),
    map(0x1600, 1, 15),
    map(0x1600, 2, 19),
    map(0x1600, 3, 23),
    map(0x1600, 4, 27),
    map(0x1600, 5, 31),
    map(0x1600, 6, 35),
    map(0x1600, 7, 39),
    map(0x1600, 8, 43),
    // RPDO2's record holds two entries only.
    map_count(0x1601, 47),
    map(0x1601, 1, 48),
    map(0x1601, 2, 52),
    e(0x1800, 0, Unsigned8, CONST, 1, 2),
    e(0x1800, 1, Unsigned32, RW, 4, 56),
    e(0x1800, 2, Unsigned8, RW, 1, 60),
    e(0x1800, 3, Unsigned16, RW, 2, 61),
    e(0x1800, 5, Unsigned16, RW, 2, 63),
    e(0x1800, 6, Unsigned8, RW, 1, 65),
    e(0x1801, 0, Unsigned8, CONST, 1, 3),
    e(0x1801, 1, Unsigned32, RW, 4, 66),
    e(0x1801, 2, Unsigned8, RW, 1, 70),
    e(0x1801, 3, Unsigned16, RW, 2, 71),
    e(0x1801, 5, Unsigned16, RW, 2, 73),
    e(0x1801, 6, Unsigned8, RW, 1, 75),
    map_count(0x1A00, 76),
    map(0x1A00, 1, 77),
    map(0x1A00, 2, 81),
    map(0x1A00, 3, 85),
    map(0x1A00, 4, 89),
    map(0x1A00, 5, 93),
    map(0x1A00, 6, 97),
    map(0x1A00, 7, 101),
    map(0x1A00, 8, 105),
    map_count(0x1A01, 109),
    map(0x1A01, 1, 110),
    map(0x1A01, 2, 114),
    map(0x1A01, 3, 118),
    map(0x1A01, 4, 122),
    map(0x1A01, 5, 126),
    map(0x1A01, 6, 130),
    map(0x1A01, 7, 134),
    map(0x1A01, 8, 138),
    // Application objects.
    e(0x2000, 0, Unsigned8, RW_PDO, 1, 142),
    e(0x2001, 0, Unsigned16, RWW, 2, 143),
    e(0x2002, 0, Unsigned32, RO_T, 4, 145),
    e(0x2003, 0, Unsigned16, RW, 2, 149),
    e(0x2004, 0, Unsigned64, RW_PDO, 8, 151),
    e(0x2005, 0, Unsigned32, CONST_T, 4, 4),
    e(0x2006, 0, OctetString, RW_PDO, 10, 159),
    e(0x2007, 0, Domain, RW_PDO, 0, 169),
    e(0x2008, 1, Integer16, RW_PDO, 2, 169),
    e(0x2008, 2, Unsigned32, RW_PDO, 4, 171),
];

static LIMITS: [Limits; 1] = [Limits { low: 0, high: 8 }];
/// Row 0 for the mappings' sub 0 (`map_count`), no limits elsewhere.
static LIMIT_ROWS: [u8; 60] = {
    let mut rows = [NO_LIMITS; 60];
    let mut i = 0;
    while i < ENTRIES.len() {
        let e = ENTRIES[i];
        if e.sub == 0 && matches!(e.index, 0x1600..=0x17FF | 0x1A00..=0x1BFF) {
            rows[i] = 0;
        }
        i += 1;
    }
    rows
};
static ROM: [u8; 8] = [5, 2, 6, 6, 0x78, 0x56, 0x34, 0x12];

const fn put(mut d: [u8; RAM], offset: usize, value: u32, len: usize) -> [u8; RAM] {
    let bytes = value.to_le_bytes();
    let mut i = 0;
    while i < len {
        d[offset + i] = bytes[i];
        i += 1;
    }
    d
}

/// Node-ID 1. RPDO1 0x201 event-driven: 0x2001 (16) + 0x2000 (8). RPDO2
/// 0x301 synchronous, nothing mapped. TPDO1 0x181 event-driven: 0x2002 (32)
/// + 0x2000 (8). TPDO2 0x281 invalid, type 1, nothing mapped.
static DEFAULTS: [u8; RAM] = {
    let d = [0u8; RAM];
    let d = put(d, 0, 0x201, 4);
    let d = put(d, 4, 255, 1);
    let d = put(d, 9, 0x301, 4);
    let d = put(d, 13, 1, 1);
    let d = put(d, 14, 2, 1);
    let d = put(d, 15, 0x2001_0010, 4);
    let d = put(d, 19, 0x2000_0008, 4);
    let d = put(d, 56, 0x181, 4);
    let d = put(d, 60, 255, 1);
    let d = put(d, 66, 0x8000_0281, 4);
    let d = put(d, 70, 1, 1);
    let d = put(d, 76, 2, 1);
    let d = put(d, 77, 0x2002_0020, 4);
    put(d, 81, 0x2000_0008, 4)
};

static DICT: Dictionary = Dictionary {
    entries: &ENTRIES,
    limits: &LIMITS,
    limit_rows: &LIMIT_ROWS,
    rom: &ROM,
    defaults: crate::od::Defaults::dense(&DEFAULTS),
    comm_len: 142,
    stored_len: RAM,
    comm_rest: 0,
    node_id_relative: &[],
    layout_id: crate::od::layout_id(&ENTRIES),
    device: DeviceInfo {
        baud_rates: 0x1FF,
        lss_supported: false,
        granularity: 8,
        simple_boot_up_slave: true,
        dynamic_channels: false,
        group_messaging: false,
    },
};

// ---- The harness ---------------------------------------------------------------

#[derive(Default)]
struct Bus {
    frames: Vec<(u16, Vec<u8>)>,
    events: Vec<PdoEvent>,
    refuse: bool,
}

impl PdoTx for Bus {
    fn send(&mut self, cob_id: u16, data: &[u8]) -> bool {
        if !self.refuse {
            self.frames.push((cob_id, data.to_vec()));
        }
        !self.refuse
    }

    fn event(&mut self, event: PdoEvent) {
        self.events.push(event);
    }
}

/// The PDOs and their image and bus; timer-only types as `P` says.
struct Node<P = Cia301> {
    pdos: Pdos<2, 2, P>,
    image: [u8; RAM],
    bus: Bus,
}

fn ms(t: u32) -> At {
    t * 1000
}

fn us(t: u32) -> At {
    t
}

fn sync_at(at: At, counter: Option<u8>) -> SyncEvent {
    SyncEvent { at, counter, window_end: Far::NEVER }
}

impl Node {
    /// Configured from the defaults, not yet Operational.
    fn new() -> Node {
        Node::configured()
    }

    /// Configured and Operational at `t`.
    fn operational(t: At) -> Node {
        Node::started(t)
    }
}

impl<P: TpdoRules> Node<P> {
    /// [`Node::new`] with `P`.
    fn configured() -> Node<P> {
        let mut pdos = Pdos::default();
        assert_eq!(pdos.configure(&DICT, &DEFAULTS), Ok(()));
        Node { pdos, image: DEFAULTS, bus: Bus::default() }
    }

    /// [`Node::operational`] with `P`.
    fn started(t: At) -> Node<P> {
        let mut node = Node::configured();
        node.pdos.enter_operational(t);
        node
    }

    fn sdo(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        self.pdos.write_object(index, sub, data, &DICT, &mut self.image).expect("a PDO parameter")
    }

    fn sdo32(&mut self, index: u16, sub: u8, value: u32) -> Result<(), AbortCode> {
        self.sdo(index, sub, &value.to_le_bytes())
    }

    /// The application (or the device) changes an object, bypassing SDO access rules.
    fn set(&mut self, index: u16, sub: u8, data: &[u8]) {
        let entry = DICT.find(index, sub).unwrap();
        self.image[entry.range()].copy_from_slice(data);
    }

    fn get(&self, index: u16, sub: u8) -> Vec<u8> {
        DICT.value(&self.image, DICT.find(index, sub).unwrap()).to_vec()
    }

    fn poll(&mut self, t: At) -> Option<At> {
        self.pdos.poll(t, &self.image, &mut self.bus)
    }

    fn sync(&mut self, sync: SyncEvent) {
        self.pdos.on_sync(&sync, &mut self.image, &mut self.bus);
    }

    fn rx(&mut self, t: At, cob_id: u16, data: &[u8]) -> bool {
        self.pdos.on_frame(t, cob_id, data, &mut self.image, &mut self.bus)
    }

    fn rtr(&mut self, t: At, cob_id: u16) -> bool {
        self.pdos.on_rtr(t, cob_id, &self.image, &mut self.bus)
    }

    fn frames(&mut self) -> Vec<(u16, Vec<u8>)> {
        core::mem::take(&mut self.bus.frames)
    }

    fn events(&mut self) -> Vec<PdoEvent> {
        core::mem::take(&mut self.bus.events)
    }

    /// Remaps TPDO `n` with the CiA 301 procedure and gives it `cob_id` and `transmission_type`.
    fn remap_tpdo(&mut self, n: u16, entries: &[u32], cob_id: u32, transmission_type: u8) {
        let cob = u32::from_le_bytes(self.get(0x1800 + n, 1).try_into().unwrap());
        assert_eq!(self.sdo32(0x1800 + n, 1, cob | COB_ID_INVALID), Ok(()));
        assert_eq!(self.sdo(0x1A00 + n, 0, &[0]), Ok(()));
        for (sub, &entry) in (1u8..).zip(entries) {
            assert_eq!(self.sdo32(0x1A00 + n, sub, entry), Ok(()), "entry {entry:#010X}");
        }
        assert_eq!(self.sdo(0x1A00 + n, 0, &[entries.len() as u8]), Ok(()));
        assert_eq!(self.sdo(0x1800 + n, 2, &[transmission_type]), Ok(()));
        assert_eq!(self.sdo32(0x1800 + n, 1, cob_id), Ok(()));
    }
}

/// The frames sent since the last check, exactly, then nothing.
macro_rules! tx {
    ($node:expr, [$(($id:expr, [$($b:expr),* $(,)?])),* $(,)?]) => {
        assert_eq!($node.frames(), { let v: Vec<(u16, Vec<u8>)> = vec![$(($id, vec![$($b as u8),*])),*]; v })
    };
}

mod configuration;
mod parameters;
mod rpdo;
mod tpdo;
