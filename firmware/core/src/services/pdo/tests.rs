//! PDO tests on a small hand-built dictionary: exact payloads at exact
//! times, grouped by transmission type, then RPDOs, the synchronous window,
//! and the SDO downloads of the parameter records (the CiA 301 mapping
//! procedure with every abort code). Case numbers refer to the CiA 310
//! conformance test tool (docs: /work/shared/notes/cia-notes.md appendix A).

use super::*;
use crate::od::{Attr, DataType, DeviceInfo, Entry, Limits, NO_LIMITS};
use crate::wire::emcy::code;

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

const fn e(index: u16, sub: u8, data_type: DataType, attr: Attr, len: u16, offset: u16) -> Entry {
    Entry::new(index, sub, data_type, attr, len, offset, NO_LIMITS)
}

const fn map_count(index: u16, offset: u16) -> Entry {
    Entry::new(index, 0, DataType::Unsigned8, RW, 1, offset, 0)
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
    rom: &ROM,
    defaults: &DEFAULTS,
    comm_len: 142,
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

struct Node {
    pdos: Pdos<2, 2>,
    image: [u8; RAM],
    bus: Bus,
}

fn ms(t: u64) -> Instant {
    Instant::from_micros(t * 1000)
}

fn us(t: u64) -> Instant {
    Instant::from_micros(t)
}

fn sync_at(at: Instant, counter: Option<u8>) -> SyncEvent {
    SyncEvent { at, counter, window_end: None }
}

impl Node {
    /// Configured from the defaults, not yet Operational.
    fn new() -> Node {
        let mut pdos = Pdos::default();
        assert_eq!(pdos.configure(&DICT, &DEFAULTS), Ok(()));
        Node { pdos, image: DEFAULTS, bus: Bus::default() }
    }

    /// Configured and Operational at `t`.
    fn operational(t: Instant) -> Node {
        let mut node = Node::new();
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

    fn poll(&mut self, t: Instant) -> Option<Instant> {
        self.pdos.poll(t, &self.image, &mut self.bus)
    }

    fn sync(&mut self, sync: SyncEvent) {
        self.pdos.on_sync(&sync, &mut self.image, &mut self.bus);
    }

    fn rx(&mut self, t: Instant, cob_id: u16, data: &[u8]) -> bool {
        self.pdos.on_frame(t, cob_id, data, &mut self.image, &mut self.bus)
    }

    fn rtr(&mut self, t: Instant, cob_id: u16) -> bool {
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

// ---- Configuration -------------------------------------------------------------

#[test]
fn configure_caches_the_records_and_resolves_the_mappings() {
    let node = Node::new();
    let r1 = node.pdos.rpdo(0).unwrap();
    assert_eq!((r1.cob_id(), r1.params().transmission_type, r1.mapping().map(Mapping::len)), (Some(0x201), 255, Some(3)));
    assert_eq!(
        r1.mapping().unwrap().slots(),
        &[Slot { source: map::Source::Ram(143), len: 2 }, Slot { source: map::Source::Ram(142), len: 1 }]
    );
    // Valid, but nothing mapped: disabled.
    let r2 = node.pdos.rpdo(1).unwrap();
    assert_eq!((r2.params().valid(), r2.cob_id(), r2.mapping().map(Mapping::len)), (true, None, Some(0)));
    assert_eq!(node.pdos.tpdo(0).unwrap().cob_id(), Some(0x181));
    assert_eq!(node.pdos.tpdo(1).unwrap().cob_id(), None, "invalid");
    assert!(node.pdos.rpdo(2).is_none());
    assert!(!node.pdos.is_operational());
}

#[test]
fn a_mapping_that_does_not_resolve_silences_its_pdo() {
    let mut image = DEFAULTS;
    image[77..81].copy_from_slice(&0x2003_0010u32.to_le_bytes());
    let mut pdos: Pdos<2, 2> = Pdos::default();
    assert_eq!(pdos.configure(&DICT, &image), Err(MappingError { index: 0x1A00, code: AbortCode::NotMappable }));
    assert_eq!(pdos.tpdo(0).unwrap().cob_id(), None);
    assert_eq!(pdos.rpdo(0).unwrap().cob_id(), Some(0x201), "the others are configured");
    pdos.enter_operational(ms(0));
    let mut bus = Bus::default();
    assert_eq!(pdos.poll(ms(0), &image, &mut bus), None);
    assert!(bus.frames.is_empty());
}

#[test]
fn nothing_runs_outside_operational() {
    let mut node = Node::new();
    assert!(!node.rx(ms(0), 0x201, &[1, 2, 3]));
    assert!(!node.rtr(ms(0), 0x181));
    node.sync(sync_at(ms(0), None));
    assert_eq!((node.poll(ms(0)), node.pdos.deadline()), (None, None));
    node.pdos.enter_operational(ms(1));
    node.pdos.stop();
    assert_eq!(node.poll(ms(2)), None);
    assert!(!node.rx(ms(2), 0x201, &[1, 2, 3]));
    tx!(node, []);
    assert_eq!(node.get(0x2000, 0), [0]);
}

#[test]
fn reset_communication_restores_the_defaults() {
    let mut node = Node::operational(ms(0));
    node.remap_tpdo(0, &[0x2004_0040], 0x182, 1);
    assert_eq!(node.pdos.tpdo(0).unwrap().cob_id(), Some(0x182));
    DICT.reset_communication(&mut node.image, 1);
    assert_eq!(node.pdos.configure(&DICT, &node.image), Ok(()));
    assert_eq!(node.pdos.tpdo(0).unwrap().cob_id(), Some(0x181));
    assert_eq!(node.pdos.tpdo(0).unwrap().mapping().map(Mapping::len), Some(5));
    assert!(!node.pdos.is_operational());
}

// ---- TPDO types 254/255: event-driven --------------------------------------------

#[test]
fn event_driven_tpdo_sends_on_entering_operational_and_on_each_change() {
    let mut node = Node::operational(ms(0));
    node.set(0x2002, 0, &0x0403_0201u32.to_le_bytes());
    node.set(0x2000, 0, &[0x05]);
    assert_eq!(node.pdos.deadline(), Some(Instant::ZERO), "due at once");
    assert_eq!(node.poll(ms(0)), None);
    tx!(node, [(0x181, [1, 2, 3, 4, 5])]);
    assert_eq!(node.poll(ms(1)), None);
    tx!(node, []);
    node.set(0x2000, 0, &[0x06]);
    node.poll(ms(2));
    tx!(node, [(0x181, [1, 2, 3, 4, 6])]);
    node.poll(ms(3));
    tx!(node, []);
}

#[test]
fn inhibit_time_delays_an_event_and_sends_the_latest_data() {
    let mut node = Node::new();
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.sdo(0x1800, 3, &100u16.to_le_bytes()), Ok(()), "10 ms");
    assert_eq!(node.sdo32(0x1800, 1, 0x181), Ok(()));
    node.pdos.enter_operational(ms(0));
    assert_eq!(node.poll(ms(0)), None);
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    node.set(0x2000, 0, &[1]);
    assert_eq!(node.poll(ms(1)), Some(ms(10)));
    node.set(0x2000, 0, &[2]);
    assert_eq!(node.poll(us(9_999)), Some(ms(10)));
    tx!(node, []);
    assert_eq!(node.poll(ms(10)), None);
    tx!(node, [(0x181, [0, 0, 0, 0, 2])]);
    // A change undone within the inhibit time sends nothing.
    node.set(0x2000, 0, &[3]);
    node.poll(ms(12));
    node.set(0x2000, 0, &[2]);
    node.poll(ms(20));
    tx!(node, []);
}

#[test]
fn event_timer_sends_periodically_and_restarts_with_each_transmission() {
    let mut node = Node::new();
    assert_eq!(node.sdo(0x1800, 5, &100u16.to_le_bytes()), Ok(()), "writable while valid");
    node.pdos.enter_operational(ms(0));
    assert_eq!(node.poll(ms(0)), Some(ms(100)));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    assert_eq!(node.poll(ms(99)), Some(ms(100)));
    tx!(node, []);
    assert_eq!(node.poll(ms(100)), Some(ms(200)));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    node.set(0x2000, 0, &[9]);
    assert_eq!(node.poll(ms(130)), Some(ms(230)));
    tx!(node, [(0x181, [0, 0, 0, 0, 9])]);
    // A new event timer starts at the next poll.
    assert_eq!(node.sdo(0x1800, 5, &50u16.to_le_bytes()), Ok(()));
    assert_eq!(node.pdos.deadline(), Some(Instant::ZERO));
    assert_eq!(node.poll(ms(140)), Some(ms(190)));
    assert_eq!(node.poll(ms(190)), Some(ms(240)));
    tx!(node, [(0x181, [0, 0, 0, 0, 9])]);
}

#[test]
fn an_event_timer_expiring_in_the_inhibit_time_waits_for_its_end() {
    let mut node = Node::new();
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.sdo(0x1800, 3, &500u16.to_le_bytes()), Ok(()), "50 ms");
    assert_eq!(node.sdo(0x1800, 5, &20u16.to_le_bytes()), Ok(()));
    assert_eq!(node.sdo32(0x1800, 1, 0x181), Ok(()));
    node.pdos.enter_operational(ms(0));
    assert_eq!(node.poll(ms(0)), Some(ms(20)));
    assert_eq!(node.poll(ms(20)), Some(ms(50)), "pending until the inhibit time ends");
    assert_eq!(node.poll(ms(50)), Some(ms(70)));
    assert_eq!(node.poll(ms(70)), Some(ms(100)));
    assert_eq!(node.poll(ms(100)), Some(ms(120)));
    assert_eq!(node.frames().len(), 3, "at 0, 50 and 100 ms");
}

#[test]
fn without_change_detection_only_the_timer_and_the_application_send() {
    let mut node = Node::operational(ms(0));
    node.pdos.set_change_detection(0, false);
    assert!(!node.pdos.tpdo(0).unwrap().change_detection());
    node.poll(ms(0));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    node.set(0x2000, 0, &[1]);
    assert_eq!(node.poll(ms(1)), None);
    tx!(node, []);
    assert!(node.pdos.trigger(0));
    assert_eq!(node.pdos.deadline(), Some(Instant::ZERO));
    node.poll(ms(2));
    tx!(node, [(0x181, [0, 0, 0, 0, 1])]);
    assert!(!node.pdos.trigger(1), "TPDO2 is not valid");
    assert!(!node.pdos.trigger(5));
}

#[test]
fn a_refused_frame_is_retried_at_the_next_poll() {
    let mut node = Node::operational(ms(0));
    node.bus.refuse = true;
    assert_eq!(node.poll(ms(0)), None, "no deadline: no spinning on a full queue");
    node.bus.refuse = false;
    node.poll(ms(1));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
}

#[test]
fn rtr_on_an_event_driven_tpdo_sends_the_current_data() {
    // CiA 310 case 3.3.
    let mut node = Node::operational(ms(0));
    node.poll(ms(0));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    assert!(node.rtr(ms(5), 0x181));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    assert!(!node.rtr(ms(5), 0x182), "not a TPDO");
    // COB-ID bit 30: no RTR.
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.sdo32(0x1800, 1, 0x4000_0181), Ok(()));
    node.poll(ms(6));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    assert!(!node.rtr(ms(7), 0x181));
    tx!(node, []);
}

// ---- TPDO type 0: synchronous acyclic ---------------------------------------------

#[test]
fn acyclic_synchronous_tpdo_sends_on_the_sync_after_an_event() {
    // CiA 310 cases 3.7, 3.13.
    let mut node = Node::operational(ms(0));
    node.remap_tpdo(1, &[0x2000_0008], 0x281, 0);
    node.poll(ms(0));
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    node.sync(sync_at(ms(10), None));
    tx!(node, [(0x281, [0])]);
    node.sync(sync_at(ms(20), None));
    tx!(node, []);
    node.set(0x2000, 0, &[7]);
    node.poll(ms(25));
    tx!(node, [(0x181, [0, 0, 0, 0, 7])]);
    node.sync(sync_at(ms(30), None));
    tx!(node, [(0x281, [7])]);
    assert!(node.pdos.trigger(1));
    node.poll(ms(31));
    tx!(node, []);
    node.sync(sync_at(ms(40), None));
    tx!(node, [(0x281, [7])]);
    node.sync(sync_at(ms(50), None));
    tx!(node, []);
}

// ---- TPDO types 1..=240: synchronous cyclic ---------------------------------------

#[test]
fn cyclic_synchronous_tpdo_sends_every_nth_sync() {
    // CiA 310 cases 3.6, 3.12, 6.3.
    let mut node = Node::operational(ms(0));
    node.remap_tpdo(1, &[0x2000_0008], 0x281, 3);
    assert_eq!(node.sdo(0x1801, 5, &10u16.to_le_bytes()), Ok(()), "no effect on a synchronous PDO");
    let mut sent = Vec::new();
    for i in 1..=7u8 {
        node.set(0x2000, 0, &[i]);
        node.sync(sync_at(ms(u64::from(i) * 10), None));
        assert_eq!(node.poll(ms(u64::from(i) * 10 + 5)), None);
        sent.extend(node.frames().into_iter().filter(|(id, _)| *id == 0x281));
    }
    assert_eq!(sent, vec![(0x281, vec![3]), (0x281, vec![6])]);
    assert!(!node.pdos.trigger(1), "type 3 has no application event");
    assert!(!node.rtr(ms(100), 0x281), "nor RTR");
}

#[test]
fn sync_start_value_makes_the_matching_sync_the_first() {
    // CiA 310 cases 3.8, 3.14: 0x1019 > 0 and sub 6 = 5.
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo(0x1801, 6, &[5]), Ok(()));
    node.remap_tpdo(1, &[0x2000_0008], 0x281, 2);
    let mut sent = Vec::new();
    for (i, counter) in [3u8, 4, 5, 6, 7, 8, 9, 10, 1, 2].into_iter().enumerate() {
        node.set(0x2000, 0, &[counter]);
        node.sync(sync_at(ms(i as u64), Some(counter)));
        sent.extend(node.frames().into_iter().filter(|(id, _)| *id == 0x281).map(|(_, d)| d[0]));
    }
    assert_eq!(sent, [6, 8, 10, 2]);
    // Type 1: the start SYNC itself sends.
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo(0x1801, 6, &[5]), Ok(()));
    node.remap_tpdo(1, &[0x2000_0008], 0x281, 1);
    node.frames();
    for counter in [3u8, 4, 5, 6] {
        node.set(0x2000, 0, &[counter]);
        node.sync(sync_at(ms(1), Some(counter)));
    }
    tx!(node, [(0x281, [5]), (0x281, [6])]);
}

#[test]
fn sync_start_value_is_ignored_without_a_sync_counter() {
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo(0x1801, 6, &[5]), Ok(()));
    node.remap_tpdo(1, &[0x2000_0008], 0x281, 2);
    node.frames();
    for i in 1..=4 {
        node.sync(sync_at(ms(i), None));
    }
    tx!(node, [(0x281, [0]), (0x281, [0])]);
}

// ---- TPDO types 252/253: RTR only -------------------------------------------------

#[test]
fn rtr_only_synchronous_tpdo_sends_the_sample_of_the_last_sync() {
    // CiA 310 case 3.15.
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()), "TPDO1 quiet");
    node.remap_tpdo(1, &[0x2000_0008], 0x281, 252);
    node.set(0x2000, 0, &[1]);
    assert!(node.rtr(ms(1), 0x281), "no sample yet: the current data");
    tx!(node, [(0x281, [1])]);
    node.set(0x2000, 0, &[2]);
    node.sync(sync_at(ms(10), None));
    tx!(node, []);
    node.set(0x2000, 0, &[3]);
    assert_eq!(node.poll(ms(11)), None);
    assert!(node.rtr(ms(12), 0x281));
    tx!(node, [(0x281, [2])]);
}

#[test]
fn rtr_only_event_driven_tpdo_sends_fresh_data_on_each_rtr() {
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()), "TPDO1 quiet");
    node.remap_tpdo(1, &[0x2000_0008, 0x2008_0110], 0x281, 253);
    node.set(0x2008, 1, &(-2i16).to_le_bytes());
    node.sync(sync_at(ms(1), None));
    assert_eq!(node.poll(ms(2)), None);
    tx!(node, []);
    assert!(node.rtr(ms(3), 0x281));
    node.set(0x2000, 0, &[4]);
    assert!(node.rtr(ms(4), 0x281));
    tx!(node, [(0x281, [0, 0xFE, 0xFF]), (0x281, [4, 0xFE, 0xFF])]);
}

// ---- Mapped sources ----------------------------------------------------------------

#[test]
fn a_tpdo_carries_constants_and_64_bit_values() {
    let mut node = Node::operational(ms(0));
    node.set(0x2004, 0, &0x0807_0605_0403_0201u64.to_le_bytes());
    node.remap_tpdo(1, &[0x2004_0040], 0x281, 254);
    node.remap_tpdo(0, &[0x2005_0020, 0x2000_0008], 0x181, 254);
    node.poll(ms(0));
    let mut frames = node.frames();
    frames.sort();
    assert_eq!(frames, vec![(0x181, vec![0x78, 0x56, 0x34, 0x12, 0]), (0x281, vec![1, 2, 3, 4, 5, 6, 7, 8])]);
}

// ---- RPDOs ----------------------------------------------------------------------------

#[test]
fn event_driven_rpdo_writes_at_once() {
    let mut node = Node::operational(ms(0));
    assert!(node.rx(ms(1), 0x201, &[0x34, 0x12, 0x56]));
    assert_eq!((node.get(0x2001, 0), node.get(0x2000, 0)), (vec![0x34, 0x12], vec![0x56]));
    assert_eq!(node.events(), [PdoEvent::Received(0)]);
    assert!(!node.rx(ms(1), 0x301, &[1]), "RPDO2 maps nothing: disabled");
    assert!(!node.rx(ms(1), 0x202, &[1, 2, 3]));
    assert_eq!(node.events(), []);
}

#[test]
fn rpdo_length_errors() {
    let mut node = Node::operational(ms(0));
    // Shorter than mapped: not processed, EMCY 0x8210 once.
    assert!(node.rx(ms(1), 0x201, &[1, 2]));
    assert!(node.rx(ms(2), 0x201, &[]));
    assert_eq!(node.get(0x2001, 0), [0, 0]);
    assert_eq!(node.events(), [PdoEvent::Error { rpdo: 0, code: code::PDO_LENGTH }]);
    // The right length ends it.
    assert!(node.rx(ms(3), 0x201, &[1, 2, 3]));
    assert_eq!(node.events(), [PdoEvent::ErrorCleared { rpdo: 0, code: 0x8210 }, PdoEvent::Received(0)]);
    // Longer: the mapped bytes are processed, EMCY 0x8220.
    assert!(node.rx(ms(4), 0x201, &[4, 5, 6, 7, 8, 9, 10, 11]));
    assert_eq!(node.get(0x2001, 0), [4, 5]);
    assert_eq!(node.get(0x2000, 0), [6]);
    assert!(node.rx(ms(5), 0x201, &[4, 5, 6, 7]));
    assert!(node.rx(ms(6), 0x201, &[7]));
    assert!(node.rx(ms(7), 0x201, &[1, 2, 3]));
    assert_eq!(
        node.events(),
        [
            PdoEvent::Error { rpdo: 0, code: code::PDO_LENGTH_EXCEEDED },
            PdoEvent::Received(0),
            PdoEvent::Received(0),
            PdoEvent::ErrorCleared { rpdo: 0, code: 0x8220 },
            PdoEvent::Error { rpdo: 0, code: 0x8210 },
            PdoEvent::ErrorCleared { rpdo: 0, code: 0x8210 },
            PdoEvent::Received(0),
        ]
    );
}

#[test]
fn synchronous_rpdo_is_written_on_the_next_sync() {
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo(0x1400, 2, &[1]), Ok(()), "the type may change while valid");
    assert!(node.rx(ms(1), 0x201, &[1, 0, 2]));
    assert!(node.rx(ms(2), 0x201, &[3, 0, 4]));
    assert!(node.pdos.rpdo(0).unwrap().has_buffered());
    assert_eq!((node.get(0x2000, 0), node.events()), (vec![0], vec![]));
    node.sync(sync_at(ms(10), None));
    assert_eq!((node.get(0x2001, 0), node.get(0x2000, 0)), (vec![3, 0], vec![4]), "the last one");
    assert_eq!(node.events(), [PdoEvent::Received(0)]);
    node.sync(sync_at(ms(20), None));
    assert_eq!(node.events(), []);
}

#[test]
fn configure_forgets_raised_errors_but_keeps_change_detection() {
    let mut node = Node::operational(ms(0));
    node.pdos.set_change_detection(0, false);
    assert!(node.rx(ms(1), 0x201, &[1]));
    assert_eq!(node.events(), [PdoEvent::Error { rpdo: 0, code: 0x8210 }]);
    assert_eq!(node.pdos.configure(&DICT, &node.image), Ok(()));
    node.pdos.enter_operational(ms(2));
    assert!(node.rx(ms(3), 0x201, &[1, 2, 3]));
    assert_eq!(node.events(), [PdoEvent::Received(0)], "no 0x8210 to clear after reset communication");
    assert!(!node.pdos.tpdo(0).unwrap().change_detection());
}

#[test]
fn rpdo_timeout_is_armed_by_the_first_rpdo() {
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo(0x1400, 5, &50u16.to_le_bytes()), Ok(()));
    assert_eq!(node.poll(ms(1000)), None, "not armed before the first RPDO");
    node.frames();
    assert!(node.rx(ms(1000), 0x201, &[0, 0, 0]));
    node.events();
    assert_eq!(node.pdos.deadline(), Some(ms(1050)));
    assert!(node.rx(ms(1020), 0x201, &[0, 0, 0]));
    assert_eq!(node.poll(ms(1069)), Some(ms(1070)));
    node.events();
    assert_eq!(node.poll(ms(1070)), None);
    assert_eq!(node.events(), [PdoEvent::Error { rpdo: 0, code: code::RPDO_TIMEOUT }]);
    assert_eq!(node.poll(ms(2000)), None);
    assert_eq!(node.events(), [], "raised once");
    assert!(node.rx(ms(2100), 0x201, &[0, 0, 0]));
    assert_eq!(node.events(), [PdoEvent::ErrorCleared { rpdo: 0, code: 0x8250 }, PdoEvent::Received(0)]);
    assert_eq!(node.pdos.deadline(), Some(ms(2150)));
    // A too-short RPDO does not count as received.
    assert!(node.rx(ms(2140), 0x201, &[0]));
    assert_eq!(node.pdos.deadline(), Some(ms(2150)));
}

#[test]
fn dummy_entries_skip_bytes_of_an_rpdo() {
    // CiA 310 case 3.33.
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo32(0x1400, 1, 0x8000_0201), Ok(()));
    assert_eq!(node.sdo(0x1600, 0, &[0]), Ok(()));
    for (sub, entry) in [(1, 0x2000_0008u32), (2, 0x0006_0010), (3, 0x0001_0008), (4, 0x2001_0010)] {
        assert_eq!(node.sdo32(0x1600, sub, entry), Ok(()));
    }
    assert_eq!(node.sdo(0x1600, 0, &[4]), Ok(()));
    assert_eq!(node.sdo32(0x1400, 1, 0x201), Ok(()));
    assert!(node.rx(ms(1), 0x201, &[0xAA, 0xFF, 0xFF, 0xFF, 0x34, 0x12]));
    assert_eq!((node.get(0x2000, 0), node.get(0x2001, 0)), (vec![0xAA], vec![0x34, 0x12]));
}

// ---- The synchronous window (0x1007) ---------------------------------------------------

#[test]
fn synchronous_rpdos_after_the_window_are_discarded() {
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo(0x1400, 2, &[0]), Ok(()));
    let window = |at| SyncEvent { at, counter: None, window_end: Some(at + Duration::from_millis(2)) };
    node.sync(window(ms(10)));
    assert!(node.rx(ms(12), 0x201, &[1, 0, 1]), "inside the window");
    node.sync(window(ms(20)));
    assert_eq!(node.get(0x2000, 0), [1]);
    assert!(node.rx(us(22_001), 0x201, &[2, 0, 2]), "after it");
    node.sync(window(ms(30)));
    assert_eq!(node.get(0x2000, 0), [1]);
    assert_eq!(node.events(), [PdoEvent::Received(0)]);
}

#[test]
fn a_refused_synchronous_tpdo_is_retried_only_inside_the_window() {
    let mut node = Node::operational(ms(0));
    node.remap_tpdo(1, &[0x2000_0008], 0x281, 1);
    node.poll(ms(0));
    node.frames();
    let window = |at| SyncEvent { at, counter: None, window_end: Some(at + Duration::from_millis(2)) };
    node.bus.refuse = true;
    node.sync(window(ms(10)));
    node.bus.refuse = false;
    assert_eq!(node.poll(ms(11)), None);
    tx!(node, [(0x281, [0])]);
    node.bus.refuse = true;
    node.sync(window(ms(20)));
    node.bus.refuse = false;
    node.poll(us(22_001));
    node.poll(ms(25));
    tx!(node, []);
}

// ---- The mapping procedure (SDO) ------------------------------------------------------

#[test]
fn the_cia301_mapping_procedure() {
    // CiA 310 cases 3.22, 3.24.
    let mut node = Node::operational(ms(0));
    node.poll(ms(0));
    node.frames();
    // While the PDO is valid, the mapping is locked.
    assert_eq!(node.sdo(0x1A00, 0, &[0]), Err(AbortCode::UnsupportedAccess));
    assert_eq!(node.sdo32(0x1A00, 1, 0x2004_0040), Err(AbortCode::UnsupportedAccess));
    // 1. Invalidate. 2. Disable the mapping. 3. Write the entries. 4. Enable. 5. Validate.
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.poll(ms(1)), None);
    tx!(node, []);
    assert_eq!(node.sdo32(0x1A00, 1, 0x2004_0040), Err(AbortCode::UnsupportedAccess), "sub 0 is not 0");
    assert_eq!(node.sdo(0x1A00, 0, &[0]), Ok(()));
    assert_eq!(node.sdo32(0x1A00, 1, 0x2008_0220), Ok(()));
    assert_eq!(node.sdo32(0x1A00, 2, 0x2008_0110), Ok(()));
    assert_eq!(node.sdo(0x1A00, 0, &[2]), Ok(()));
    assert_eq!(node.sdo32(0x1800, 1, 0x181), Ok(()));
    node.set(0x2008, 2, &[1, 2, 3, 4]);
    node.set(0x2008, 1, &[5, 6]);
    node.poll(ms(2));
    tx!(node, [(0x181, [1, 2, 3, 4, 5, 6])]);
    assert_eq!(node.get(0x1A00, 0), [2]);
    assert_eq!(node.get(0x1A00, 1), 0x2008_0220u32.to_le_bytes());
}

#[test]
fn mapping_entry_downloads_and_their_abort_codes() {
    // CiA 310 cases 3.25–3.32.
    let mut node = Node::new();
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.sdo32(0x1400, 1, 0x8000_0201), Ok(()));
    assert_eq!(node.sdo(0x1A00, 0, &[0]), Ok(()));
    assert_eq!(node.sdo(0x1600, 0, &[0]), Ok(()));
    let before = node.image;
    let cases: [(u16, u32, AbortCode); 14] = [
        (0x1A00, 0x3000_0008, AbortCode::NoObject),
        (0x1A00, 0x2008_0310, AbortCode::NoSubIndex),
        (0x1A00, 0x2003_0010, AbortCode::NotMappable),           // PDOMapping=0 (3.32)
        (0x1600, 0x2003_0010, AbortCode::NotMappable),           // (3.29)
        (0x1A00, 0x2001_0010, AbortCode::NotMappable),           // rww into a TPDO (3.31)
        (0x1600, 0x2002_0020, AbortCode::NotMappable),           // ro into an RPDO (3.28)
        (0x1600, 0x2005_0020, AbortCode::NotMappable),           // a constant into an RPDO
        (0x1A00, 0x2007_0000, AbortCode::NotMappable),           // DOMAIN
        (0x1A00, 0x0005_0008, AbortCode::NotMappable),           // dummy in a TPDO
        (0x1A00, 0x2001_0008, AbortCode::NotMappable),           // direction before length
        (0x1A00, 0x2002_0010, AbortCode::ParameterIncompatible), // 16 of 32 bits
        (0x1A00, 0x2000_0004, AbortCode::ParameterIncompatible), // bit mapping
        (0x1600, 0x0006_0008, AbortCode::ParameterIncompatible), // dummy of the wrong size
        (0x1A00, 0x2006_0050, AbortCode::PdoTooLong),            // 80 bits (3.26)
    ];
    for (index, entry, code) in cases {
        assert_eq!(node.sdo32(index, 1, entry), Err(code), "{index:#06X} ← {entry:#010X}");
    }
    assert_eq!(node.image, before, "nothing written");
    // Too many bytes in all (3.26) and too many objects (3.25).
    assert_eq!(node.sdo32(0x1A00, 1, 0x2004_0040), Ok(()));
    assert_eq!(node.sdo32(0x1A00, 2, 0x2000_0008), Ok(()));
    assert_eq!(node.sdo(0x1A00, 0, &[2]), Err(AbortCode::PdoTooLong));
    assert_eq!(node.sdo(0x1A00, 0, &[9]), Err(AbortCode::PdoTooLong));
    assert_eq!(node.sdo(0x1601, 0, &[3]), Err(AbortCode::PdoTooLong), "the record has 2 entries");
    assert_eq!(node.get(0x1A00, 0), [0]);
    assert_eq!(node.sdo(0x1A00, 0, &[1]), Ok(()));
    // Length and existence checks of the download itself.
    assert_eq!(node.sdo(0x1A00, 1, &[0, 0]), Err(AbortCode::LengthTooLow));
    assert_eq!(node.sdo(0x1A00, 0, &[1, 0]), Err(AbortCode::LengthTooHigh));
    assert_eq!(node.sdo32(0x1A00, 9, 0), Err(AbortCode::NoSubIndex));
    assert_eq!(node.sdo(0x1800, 0, &[6]), Err(AbortCode::ReadOnly));
}

#[test]
fn enabling_a_mapping_checks_the_stored_entries() {
    let mut node = Node::new();
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.sdo(0x1A00, 0, &[0]), Ok(()));
    node.set(0x1A00, 1, &0x3000_0008u32.to_le_bytes()); // as a bad stored parameter set could hold
    assert_eq!(node.sdo(0x1A00, 0, &[1]), Err(AbortCode::NoObject));
    assert_eq!(node.sdo32(0x1A00, 1, 0), Ok(()), "clearing an entry is always possible");
    assert_eq!(node.sdo(0x1A00, 0, &[1]), Err(AbortCode::NoObject), "index 0 does not exist");
}

#[test]
fn writing_back_current_values_is_accepted() {
    // CiA 310 case 4.9: read every rw object and write it back.
    let mut node = Node::operational(ms(0));
    for (index, sub) in
        [(0x1A00, 0), (0x1A00, 1), (0x1A00, 8), (0x1800, 1), (0x1800, 2), (0x1800, 3), (0x1800, 6), (0x1600, 0), (0x1400, 1)]
    {
        let value = node.get(index, sub);
        assert_eq!(node.sdo(index, sub, &value), Ok(()), "{index:#06X} sub {sub}");
    }
    assert_eq!(node.pdos.tpdo(0).unwrap().cob_id(), Some(0x181));
}

#[test]
fn a_read_only_cob_id_lets_sub0_open_the_mapping() {
    // docs/devices/ec5000.md decision 13: RPDO2's COB-ID is ro and valid.
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo32(0x1401, 1, 0x8000_0301), Err(AbortCode::ReadOnly));
    assert_eq!(node.sdo32(0x1601, 1, 0x2000_0008), Ok(()));
    assert_eq!(node.sdo(0x1601, 0, &[1]), Ok(()));
    assert_eq!(node.pdos.rpdo(1).unwrap().cob_id(), Some(0x301));
    assert_eq!(node.sdo32(0x1601, 1, 0x2008_0110), Err(AbortCode::UnsupportedAccess), "sub 0 is not 0");
    assert!(node.rx(ms(1), 0x301, &[0x42]));
    node.sync(sync_at(ms(2), None));
    assert_eq!(node.get(0x2000, 0), [0x42]);
    assert_eq!(node.sdo(0x1601, 0, &[0]), Ok(()));
    assert!(!node.rx(ms(3), 0x301, &[0x43]), "disabled again");
}

// ---- Communication parameter downloads ------------------------------------------------

#[test]
fn cob_id_downloads() {
    let mut node = Node::operational(ms(0));
    let w = |node: &mut Node, v: u32| node.sdo32(0x1800, 1, v);
    assert_eq!(w(&mut node, 0x182), Err(AbortCode::InvalidValue), "the CAN-ID of a valid PDO");
    assert_eq!(w(&mut node, 0x8000_0182), Ok(()), "invalidate and move at once");
    assert_eq!(node.pdos.tpdo(0).unwrap().cob_id(), None);
    assert_eq!(w(&mut node, 0x2000_0182), Err(AbortCode::InvalidValue), "29-bit frame");
    assert_eq!(w(&mut node, 0x0004_0182), Err(AbortCode::InvalidValue), "bits 11..28");
    for restricted in [0x000u32, 0x07F, 0x101, 0x180, 0x5FF, 0x601, 0x6E0, 0x701, 0x7FF] {
        assert_eq!(w(&mut node, restricted), Err(AbortCode::InvalidValue), "{restricted:#X}");
    }
    assert_eq!(w(&mut node, 0x8000_0701), Ok(()), "an invalid COB-ID may hold anything");
    assert_eq!(w(&mut node, 0x4000_0182), Ok(()));
    assert_eq!(node.pdos.tpdo(0).unwrap().cob_id(), Some(0x182));
    assert!(!node.pdos.tpdo(0).unwrap().params().rtr_allowed());
    assert_eq!(node.get(0x1800, 1), 0x4000_0182u32.to_le_bytes());
    assert_eq!(node.sdo(0x1800, 1, &[0x82, 0x01]), Err(AbortCode::LengthTooLow));
}

#[test]
fn transmission_type_downloads() {
    let mut node = Node::new();
    for (index, tt, ok) in
        [(0x1800, 241, false), (0x1800, 251, false), (0x1800, 252, true), (0x1800, 253, true), (0x1800, 0, true), (0x1800, 240, true)]
    {
        assert_eq!(node.sdo(index, 2, &[tt]).is_ok(), ok, "TPDO type {tt}");
    }
    for (tt, ok) in [(241u8, false), (252, false), (253, false), (254, true), (0, true)] {
        assert_eq!(node.sdo(0x1400, 2, &[tt]).is_ok(), ok, "RPDO type {tt}");
    }
    assert_eq!(node.sdo(0x1400, 2, &[252]), Err(AbortCode::InvalidValue));
    // RTR-only types and COB-ID bit 30 exclude each other.
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.sdo32(0x1800, 1, 0x4000_0181), Ok(()), "type 240");
    assert_eq!(node.sdo(0x1800, 2, &[252]), Err(AbortCode::InvalidValue));
    assert_eq!(node.sdo(0x1800, 2, &[253]), Err(AbortCode::InvalidValue));
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.sdo(0x1800, 2, &[253]), Ok(()));
    assert_eq!(node.sdo32(0x1800, 1, 0x4000_0181), Err(AbortCode::InvalidValue));
}

#[test]
fn inhibit_time_and_sync_start_change_only_while_invalid() {
    let mut node = Node::new();
    assert_eq!(node.sdo(0x1800, 3, &10u16.to_le_bytes()), Err(AbortCode::InvalidValue));
    assert_eq!(node.sdo(0x1800, 6, &[5]), Err(AbortCode::InvalidValue));
    assert_eq!(node.sdo(0x1400, 3, &10u16.to_le_bytes()), Err(AbortCode::InvalidValue), "RPDO sub 3 too");
    assert_eq!(node.sdo32(0x1800, 1, 0x8000_0181), Ok(()));
    assert_eq!(node.sdo(0x1800, 3, &10u16.to_le_bytes()), Ok(()));
    assert_eq!(node.sdo(0x1800, 6, &[241]), Err(AbortCode::InvalidValue));
    assert_eq!(node.sdo(0x1800, 6, &[240]), Ok(()));
    assert_eq!(node.pdos.tpdo(0).unwrap().params().inhibit_time(), Duration::from_millis(1));
    assert_eq!(node.pdos.tpdo(0).unwrap().params().sync_start, 240);
    assert_eq!(node.sdo(0x1801, 4, &[0]), Err(AbortCode::NoSubIndex), "sub 4 is reserved");
}

#[test]
fn other_objects_are_not_pdo_parameters() {
    let mut node = Node::new();
    for index in [0x1005, 0x13FF, 0x1402, 0x1602, 0x1802, 0x1A02, 0x1C00, 0x2000] {
        assert_eq!(node.pdos.write_object(index, 1, &[0; 4], &DICT, &mut node.image), None, "{index:#06X}");
    }
    // A PDO this node has, but the dictionary lacks.
    let mut big: Pdos<3, 3> = Pdos::default();
    assert_eq!(big.configure(&DICT, &DEFAULTS), Ok(()));
    assert_eq!(big.rpdo(2).unwrap().cob_id(), None);
    assert_eq!(big.write_object(0x1402, 1, &[0; 4], &DICT, &mut node.image), Some(Err(AbortCode::NoObject)));
}

#[test]
fn restricted_can_ids_follow_cia301() {
    let allowed = [0x080u16, 0x100, 0x181, 0x1FF, 0x200, 0x580, 0x600, 0x680, 0x6DF, 0x700];
    assert!(allowed.iter().all(|&id| !is_restricted_can_id(id)));
    let restricted = [0x000u16, 0x001, 0x07F, 0x101, 0x180, 0x581, 0x5FF, 0x601, 0x67F, 0x6E0, 0x6FF, 0x701, 0x77F, 0x780, 0x7FF];
    assert!(restricted.iter().all(|&id| is_restricted_can_id(id)));
}

#[test]
fn the_deadline_a_poll_settled_follows_every_later_change() {
    // `deadline` answers from the last poll until a PDO changes: each change must be seen.
    let mut node = Node::operational(ms(0));
    assert_eq!(node.sdo(0x1400, 5, &50u16.to_le_bytes()), Ok(()));
    node.poll(ms(1));
    node.frames();
    assert_eq!(node.poll(ms(2)), None);
    assert!(node.rx(ms(1000), 0x201, &[0, 0, 0]));
    node.events();
    assert_eq!(node.pdos.deadline(), Some(ms(1050)), "an RPDO arms its timer");
    assert_eq!(node.poll(ms(1010)), Some(ms(1050)));
    assert_eq!(node.sdo(0x1400, 5, &80u16.to_le_bytes()), Ok(()));
    assert_eq!(node.pdos.deadline(), None, "a new event timer waits for the next RPDO");
    assert_eq!(node.poll(ms(1020)), None);
    node.pdos.enter_operational(ms(1030));
    assert_eq!(node.pdos.deadline(), Some(Instant::ZERO), "event-driven TPDOs go out at once");
}

#[test]
fn an_rpdo_reaches_only_the_event_driven_tpdos_that_map_what_it_writes() {
    // RPDO1 writes 0x2001 and 0x2000; TPDO1 (event-driven) maps 0x2002 and 0x2000.
    let mut node = Node::operational(ms(0));
    assert_eq!(node.pdos.reached_by(0b1), 0b1);
    assert_eq!(node.pdos.reached_by(0), 0);
    // 0x2003 (offset 149, 2 bytes) is in no TPDO; 0x2002 (145, 4 bytes) in TPDO1, also its last byte.
    assert_eq!(node.pdos.tpdos_mapping(149, 2), 0);
    assert_eq!((node.pdos.tpdos_mapping(145, 4), node.pdos.tpdos_mapping(148, 1)), (0b1, 0b1));
    // TPDO1 no longer maps 0x2000: RPDO1 cannot change it.
    node.remap_tpdo(0, &[0x2002_0020], 0x181, 255);
    assert_eq!(node.pdos.reached_by(0b1), 0);
    // A synchronous TPDO does not look for changes: it reaches nothing either.
    node.remap_tpdo(0, &[0x2000_0008], 0x181, 1);
    assert_eq!((node.pdos.reached_by(0b1), node.pdos.tpdos_mapping(142, 1)), (0, 0));
    node.remap_tpdo(0, &[0x2000_0008], 0x181, 254);
    assert_eq!(node.pdos.reached_by(0b1), 0b1);
}

#[test]
fn a_poll_for_other_tpdos_leaves_a_changed_one_for_its_own_turn() {
    let mut node = Node::operational(ms(0));
    assert_eq!(node.poll(ms(0)), None);
    tx!(node, [(0x181, [0, 0, 0, 0, 0])]);
    node.set(0x2002, 0, &[1, 2, 3, 4]);
    // Told that only TPDO2 may have changed, TPDO1 does not look.
    node.pdos.poll_changed(ms(1), 0b10, &node.image, &mut node.bus);
    tx!(node, []);
    node.pdos.poll_changed(ms(2), 0b1, &node.image, &mut node.bus);
    tx!(node, [(0x181, [1, 2, 3, 4, 0])]);
}
