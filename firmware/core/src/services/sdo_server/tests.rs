//! SDO server tests: exact frames in, exact frames out, at exact virtual
//! times, then nothing else. Frames are written as candump-style hex; CCT
//! numbers refer to the CiA conformance test cases (cia-notes.md, appendix A).
#![allow(clippy::arithmetic_side_effects)]

use super::*;
use crate::od::{Attr, DataType, DeviceInfo, Dictionary, DictionaryAccess, Entry, Limits, NO_LIMITS};
use std::collections::VecDeque;
use std::vec::Vec;

mod block;
mod errors;
mod expedited;
mod segmented;

// ---------------------------------------------------------------------------
// A small dictionary, laid out as od-gen lays out generated ones
// ---------------------------------------------------------------------------

const RO: Attr = Attr::READ;
const WO: Attr = Attr::WRITE;
const RW: Attr = Attr(Attr::READ.0 | Attr::WRITE.0);
const CONST: Attr = Attr(Attr::READ.0 | Attr::IN_ROM.0);
const LONG_LEN: usize = 120;
const IMAGE_LEN: usize = 157;

static ENTRIES: [Entry; 15] = [
    Entry::new(0x1000, 0, DataType::Unsigned32, CONST, 4, 0),
    Entry::new(0x1001, 0, DataType::Unsigned8, RO, 1, 0),
    Entry::new(0x1008, 0, DataType::VisibleString, CONST, 6, 4),
    Entry::new(0x1017, 0, DataType::Unsigned16, RW, 2, 1),
    Entry::new(0x2000, 0, DataType::Integer16, RW, 2, 3),
    Entry::new(0x2001, 0, DataType::Unsigned8, RW, 1, 5),
    Entry::new(0x2002, 0, DataType::Unsigned8, WO, 1, 6),
    Entry::new(0x2003, 0, DataType::Unsigned24, RW, 3, 7),
    Entry::new(0x2004, 0, DataType::Unsigned32, RW, 4, 10),
    Entry::new(0x2005, 0, DataType::Unsigned64, RW, 8, 14),
    Entry::new(0x2010, 0, DataType::VisibleString, RW, LONG_LEN as u8, 22),
    Entry::new(0x2011, 0, DataType::OctetString, RW, 10, 142),
    Entry::new(0x2012, 0, DataType::Domain, RW, 0, 152),
    Entry::new(0x2020, 0, DataType::Unsigned8, RO, 1, 152),
    Entry::new(0x2020, 1, DataType::Unsigned32, RW, 4, 153),
];
static LIMITS: [Limits; 1] = [Limits { low: -100i64 as u64, high: 100 }];
/// 0x2000 (the fifth entry) is limited to -100..=100.
static LIMIT_ROWS: [u8; 15] = {
    let mut rows = [NO_LIMITS; 15];
    rows[4] = 0;
    rows
};
static ROM: [u8; 10] = [0x92, 0x01, 0x02, 0x00, b'd', b'e', b'v', b'i', b'c', b'e'];

/// The 120-byte default of 0x2010: "ABC…XYZABC…", no NUL.
const fn long(first: u8) -> [u8; LONG_LEN] {
    let mut s = [0u8; LONG_LEN];
    let mut i = 0;
    while i < LONG_LEN {
        s[i] = first + (i % 26) as u8;
        i += 1;
    }
    s
}
const LONG: [u8; LONG_LEN] = long(b'A');

const fn defaults() -> [u8; IMAGE_LEN] {
    let mut d = [0u8; IMAGE_LEN];
    (d[1], d[2]) = (0xE8, 0x03); // 0x1017 = 1000 ms
    d[3] = 5; // 0x2000 = 5
    d[5] = 0x11; // 0x2001
    (d[7], d[8], d[9]) = (1, 2, 3); // 0x2003
    (d[10], d[11], d[12], d[13]) = (1, 2, 3, 4); // 0x2004
    let mut i = 0;
    while i < LONG_LEN {
        d[22 + i] = LONG[i];
        i += 1;
    }
    while i < LONG_LEN + 10 {
        d[22 + i] = (i - LONG_LEN) as u8; // 0x2011 = 00 01 … 09
        i += 1;
    }
    d[152] = 1; // 0x2020:0
    d
}
static DEFAULTS: [u8; IMAGE_LEN] = defaults();

static DICT: Dictionary = Dictionary {
    entries: &ENTRIES,
    limits: &LIMITS,
    limit_rows: &LIMIT_ROWS,
    rom: &ROM,
    defaults: crate::od::Defaults::dense(&DEFAULTS),
    comm_len: 3,
    stored_len: IMAGE_LEN,
    comm_rest: 0,
    node_id_relative: &[],
    layout_id: crate::od::layout_id(&ENTRIES),
    device: DeviceInfo {
        baud_rates: 0x1FF,
        lss_supported: false,
        granularity: 8,
        simple_boot_up_slave: false,
        dynamic_channels: false,
        group_messaging: false,
    },
};

/// The dictionary plus application hooks that refuse with a chosen code.
struct App<'a> {
    od: DictionaryAccess<'a>,
    read_error: Option<AbortCode>,
    write_error: Option<AbortCode>,
}

impl ObjectAccess for App<'_> {
    fn upload_size(&mut self, index: u16, sub: u8) -> Result<usize, AbortCode> {
        self.od.upload_size(index, sub)
    }
    fn read(&mut self, index: u16, sub: u8, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode> {
        self.read_error.map_or_else(|| self.od.read(index, sub, offset, buf), Err)
    }
    fn download_check(&mut self, index: u16, sub: u8, size: Option<usize>) -> Result<(), AbortCode> {
        self.od.download_check(index, sub, size)
    }
    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        self.write_error.map_or_else(|| self.od.write(index, sub, data), Err)
    }
}

// ---------------------------------------------------------------------------
// The harness: a TX queue with limited room, frames as hex, virtual time
// ---------------------------------------------------------------------------

struct Bus {
    frames: VecDeque<[u8; 8]>,
    room: usize,
}

impl SdoTx for Bus {
    fn send(&mut self, data: [u8; 8]) -> bool {
        if self.room == 0 {
            return false;
        }
        self.room -= 1;
        self.frames.push_back(data);
        true
    }
}

struct Test<const N: usize> {
    server: SdoServer<N>,
    image: [u8; IMAGE_LEN],
    bus: Bus,
    read_error: Option<AbortCode>,
    write_error: Option<AbortCode>,
}

fn ms(t: u32) -> At {
    t * 1000
}

fn hex(s: &str) -> Vec<u8> {
    s.split_whitespace().map(|b| u8::from_str_radix(b, 16).unwrap()).collect()
}

fn show(f: &[u8]) -> String {
    f.iter().map(|b| format!("{b:02X}")).collect::<Vec<_>>().join(" ")
}

/// A frame of byte 0 and up to 7 data bytes, zero-filled.
fn frame(b0: u8, data: &[u8]) -> [u8; 8] {
    let mut f = [0u8; 8];
    f[0] = b0;
    f[1..1 + data.len()].copy_from_slice(data);
    f
}

/// Reference CRC by long division: the message and 16 zero bits divided by
/// 0x11021 one bit at a time (a different algorithm from the server's).
fn reference_crc(data: &[u8]) -> u16 {
    let mut reg: u32 = 0;
    for bit in data.iter().flat_map(|b| (0..8).rev().map(move |i| (b >> i) & 1)).chain([0; 16]) {
        reg = (reg << 1) | u32::from(bit);
        if reg & 0x1_0000 != 0 {
            reg ^= 0x1_1021;
        }
    }
    reg as u16
}

impl<const N: usize> Test<N> {
    fn new() -> Self {
        Test {
            server: SdoServer::new(),
            image: DEFAULTS,
            bus: Bus { frames: VecDeque::new(), room: usize::MAX },
            read_error: None,
            write_error: None,
        }
    }

    fn rx_bytes(&mut self, at: At, data: &[u8]) {
        let Test { server, image, bus, read_error, write_error } = self;
        let mut od = App { od: DictionaryAccess { dictionary: &DICT, image }, read_error: *read_error, write_error: *write_error };
        server.on_request(at, data, &mut od, bus);
    }

    fn rx(&mut self, at: At, f: &str) {
        self.rx_bytes(at, &hex(f));
    }

    /// One exchange: `request` in at `at`, exactly `response` out, nothing else.
    #[track_caller]
    fn x(&mut self, at: At, request: &str, response: &str) {
        self.rx(at, request);
        self.tx(response);
        self.none();
    }

    fn poll(&mut self, at: At) -> Option<At> {
        let Test { server, image, bus, read_error, write_error } = self;
        let mut od = App { od: DictionaryAccess { dictionary: &DICT, image }, read_error: *read_error, write_error: *write_error };
        server.poll(at, &mut od, bus)
    }

    #[track_caller]
    fn tx_bytes(&mut self, want: &[u8]) {
        assert_eq!(self.bus.frames.pop_front().map(|f| show(&f)), Some(show(want)));
    }

    #[track_caller]
    fn tx(&mut self, want: &str) {
        self.tx_bytes(&hex(want));
    }

    /// Nothing else was sent.
    #[track_caller]
    fn none(&mut self) {
        let rest: Vec<String> = self.bus.frames.drain(..).map(|f| show(&f)).collect();
        assert!(rest.is_empty(), "unexpected frames: {rest:?}");
    }

    /// Nothing else was sent and the server is idle at `at`.
    #[track_caller]
    fn done(&mut self, at: At) {
        self.none();
        assert_eq!(self.poll(at), None);
        self.none();
        assert!(self.server.is_idle());
    }

    fn value(&self, index: u16, sub: u8) -> Vec<u8> {
        DICT.read(&self.image, index, sub).unwrap().to_vec()
    }
}

type Sdo = Test<128>;

#[test]
fn a_further_server_costs_its_protocol_state_only() {
    // The download buffer is shared (SdoServers); one server's state stays small.
    assert!(core::mem::size_of::<Channel>() <= 80, "{}", core::mem::size_of::<Channel>());
    assert_eq!(core::mem::size_of::<SdoServers<896, 4>>(), 896 + 4 * core::mem::size_of::<Channel>());
}

#[test]
fn servers_are_all_idle_only_without_a_transfer_or_a_waiting_response() {
    // What `Node::process` relies on to skip polling the servers.
    let mut servers = SdoServers::<128, 2>::new();
    let mut image = DEFAULTS;
    let mut bus = Bus { frames: VecDeque::new(), room: usize::MAX };
    assert!(servers.all_idle());
    // A segmented upload on the second server: busy until its timeout abort.
    {
        let mut od = App { od: DictionaryAccess { dictionary: &DICT, image: &mut image }, read_error: None, write_error: None };
        servers.on_request(1, ms(0), &hex("40 10 20 00 00 00 00 00"), &mut od, &mut bus);
    }
    assert_eq!(bus.frames.pop_front().map(|f| show(&f)), Some(show(&hex("41 10 20 00 78 00 00 00"))));
    assert!(!servers.all_idle());
    assert!(servers.is_idle(0));
    // With no room in the queue the abort waits in the server, which stays busy.
    bus.room = 0;
    {
        let mut od = App { od: DictionaryAccess { dictionary: &DICT, image: &mut image }, read_error: None, write_error: None };
        assert_eq!(servers.poll(1, ms(1000), &mut od, &mut bus), Some(ms(1000)));
    }
    assert!(!servers.all_idle());
    bus.room = 1;
    {
        let mut od = App { od: DictionaryAccess { dictionary: &DICT, image: &mut image }, read_error: None, write_error: None };
        assert_eq!(servers.poll(1, ms(1000), &mut od, &mut bus), None);
    }
    assert_eq!(bus.frames.pop_front().map(|f| show(&f)), Some(show(&hex("80 10 20 00 00 00 04 05"))));
    assert!(servers.all_idle());
}
