//! The node and the frame sequences both instruction-count benches replay:
//! the host bench (`canopen-icount`, x86_64 under callgrind) and the
//! thumbv7m image (`bench/icount-qemu`, under QEMU `-icount`), so that their
//! figures describe the same work.
//!
//! The node is the interop test dictionary (`tests/eds/interop.eds`, 4 RPDO
//! / 4 TPDO), node-id [`NODE_ID`], no application, and the QEMU board's RAM
//! storage. The sequences:
//! - [`Kind`]: frames measured N at a time (RPDO, expedited SDO upload and
//!   download, SYNC with four TPDOs, and idle: no frame);
//! - [`worst::CASES`]: expensive single frames, for the worst case of what
//!   the CANopen task does for one received frame.
//!
//! Every answer is checked ([`Mismatch`]), so a broken configuration fails
//! instead of measuring nothing.
#![no_std]

pub mod cia402;
pub mod worst;

/// The interop test node's dictionary, generated from `tests/eds/interop.eds`.
pub mod od {
    include!(concat!(env!("OUT_DIR"), "/interop.rs"));
}

use canopen_core::frame::CanFrame;
use canopen_core::node::NoApplication;
use canopen_core::od::ObjectDictionary;
use canopen_core::time::Instant;
use embedded_can::Frame;
use firmware::boards::qemu::ram_storage::RamStorage;
use firmware::boards::region_size;

/// The node-id of the node under test.
pub const NODE_ID: u8 = 5;
/// COB-ID of its default SDO server's requests.
pub const SDO_RX: u16 = 0x600 + NODE_ID as u16;
/// COB-ID of its default SDO server's responses.
pub const SDO_TX: u16 = 0x580 + NODE_ID as u16;
/// COB-ID of its boot-up and heartbeat frames.
pub const HEARTBEAT: u16 = 0x700 + NODE_ID as u16;

/// The storage of the QEMU images, sized for the interop dictionary.
pub type Storage = RamStorage<{ region_size(od::RAM_SIZE) }>;
/// The node under test.
pub type Dut = od::Node<NoApplication, Storage>;

/// A node answered otherwise than a sequence expects.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mismatch {
    /// What was being done.
    pub step: &'static str,
    /// What the node sent.
    pub answer: Answer,
}

/// What the node sent after a frame: how many frames, the first and the last.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Answer {
    /// Frames sent.
    pub count: usize,
    /// The first of them.
    pub first: Option<CanFrame>,
    /// The last of them.
    pub last: Option<CanFrame>,
}

impl Answer {
    /// Empties the node's transmit queue.
    pub fn drain(node: &mut Dut) -> Answer {
        let mut answer = Answer::default();
        while let Some(frame) = node.transmit() {
            answer.count += 1;
            answer.first = answer.first.or(Some(frame));
            answer.last = Some(frame);
        }
        answer
    }

    /// Requires exactly `count` frames, the first of them `first` (COB-ID, data) if given.
    pub fn expect(self, step: &'static str, count: usize, first: Option<(u16, &[u8])>) -> Result<(), Mismatch> {
        let first_ok = first.is_none_or(|(cob, data)| self.first.is_some_and(|f| f.cob_id() == Some(cob) && f.data() == data));
        if self.count == count && first_ok { Ok(()) } else { Err(Mismatch { step, answer: self }) }
    }
}

/// Delivers a frame, runs the node's timers (a reset to its end, a stage
/// per call) and collects what it sends.
pub fn exchange(node: &mut Dut, now: Instant, frame: &CanFrame) -> Answer {
    node.on_frame(now, frame);
    node.process(now);
    while node.resetting() || node.storing() {
        node.process(now);
    }
    Answer::drain(node)
}

/// A standard frame; every caller passes a COB-ID below 0x800 and at most 8 bytes.
pub fn frame(cob: u16, data: &[u8]) -> CanFrame {
    CanFrame::standard(cob, data).expect("an 11-bit COB-ID and at most 8 bytes")
}

/// An SDO request to the node, in one 8-byte frame.
pub fn sdo(data: [u8; 8]) -> CanFrame {
    frame(SDO_RX, &data)
}

/// An expedited SDO download of the low `len` bytes of `value` (1 to 4),
/// which must succeed.
pub fn sdo_write(node: &mut Dut, now: Instant, index: u16, sub: u8, value: u32, len: u8) -> Result<(), Mismatch> {
    let [lo, hi] = index.to_le_bytes();
    let [a, b, c, d] = value.to_le_bytes();
    let cmd = 0x23 | (4u8.saturating_sub(len) << 2);
    exchange(node, now, &sdo([cmd, lo, hi, sub, a, b, c, d])).expect("SDO download", 1, Some((SDO_TX, &[0x60, lo, hi, sub, 0, 0, 0, 0])))
}

/// An object's value as an SDO upload would read it (`None` if unreadable).
pub fn read(node: &Dut, index: u16, sub: u8) -> Option<&[u8]> {
    let od = node.od();
    od.dictionary().read(od.image(), index, sub).ok()
}

/// A fresh node at `now` that has sent its boot-up frame (Pre-operational).
pub fn new_node(now: Instant) -> Result<Dut, Mismatch> {
    let mut node = Dut::new(od::Ram::new(NODE_ID), NoApplication, Storage::default(), NODE_ID, now);
    node.process(now);
    Answer::drain(&mut node).expect("boot-up", 1, Some((HEARTBEAT, &[0x00])))?;
    Ok(node)
}

/// NMT start (to Operational); the node may send its event-driven TPDOs, but no SDO answer.
pub fn start(node: &mut Dut, now: Instant) -> Result<(), Mismatch> {
    let answer = exchange(node, now, &frame(0x000, &[0x01, NODE_ID]));
    if answer.first.is_some_and(|f| f.cob_id() == Some(SDO_TX)) {
        return Err(Mismatch { step: "NMT start", answer });
    }
    Ok(())
}

/// Which PDO [`map_pdo`] configures.
#[derive(Clone, Copy, Debug)]
pub enum Pdo {
    /// RPDO `n` (0-based).
    Receive(u16),
    /// TPDO `n` (0-based), without RTR.
    Transmit(u16),
}

/// Maps a PDO to `objects` (CiA 301 mapping entries: index, sub-index,
/// bits) with transmission type `kind`, in the order CiA 301 §7.5.2.36
/// prescribes: invalidate, clear the count, write the entries, set the
/// count, set the type, validate.
pub fn map_pdo(node: &mut Dut, now: Instant, pdo: Pdo, objects: &[u32], kind: u8) -> Result<(), Mismatch> {
    let id = u32::from(NODE_ID);
    // Default COB-IDs (CiA 301 §7.3.5, pre-defined connection set); bit 30
    // set on a TPDO = no RTR allowed; bit 31 = not valid.
    let (comm, map, cob, flags) = match pdo {
        Pdo::Receive(n) => (0x1400 + n, 0x1600 + n, 0x200 + 0x100 * u32::from(n) + id, 0),
        Pdo::Transmit(n) => (0x1800 + n, 0x1A00 + n, 0x180 + 0x100 * u32::from(n) + id, 0x4000_0000),
    };
    sdo_write(node, now, comm, 1, 0x8000_0000 | flags | cob, 4)?;
    sdo_write(node, now, map, 0, 0, 1)?;
    for (sub, &object) in (1..).zip(objects) {
        sdo_write(node, now, map, sub, object, 4)?;
    }
    sdo_write(node, now, map, 0, objects.len() as u32, 1)?;
    sdo_write(node, now, comm, 2, u32::from(kind), 1)?;
    sdo_write(node, now, comm, 1, flags | cob, 4)
}

/// The four synchronous TPDOs (type 1) of [`Kind::Sync`]: 7, 8, 8 and 8 bytes.
pub fn map_sync_tpdos(node: &mut Dut, now: Instant) -> Result<(), Mismatch> {
    map_pdo(node, now, Pdo::Transmit(0), &[0x2000_0008, 0x2001_0010, 0x2003_0020], 1)?;
    map_pdo(node, now, Pdo::Transmit(1), &[0x2004_0020, 0x2007_0020], 1)?;
    map_pdo(node, now, Pdo::Transmit(2), &[0x2100_0110, 0x2100_0210, 0x2100_0310, 0x2100_0410], 1)?;
    map_pdo(node, now, Pdo::Transmit(3), &[0x2100_0510, 0x2100_0610, 0x2100_0710, 0x2100_0810], 1)
}

/// The frame kinds measured per frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// RPDO1, 8 bytes into 0x2100 sub 1..4, asynchronous (type 0xFF).
    Rpdo,
    /// An expedited SDO upload of 0x1018 sub 1 (one answer).
    SdoUpload,
    /// An expedited SDO download of 0x2003 (u32, mapped in the event-driven
    /// TPDO1) with its default value: the answer, and TPDO1's change
    /// detection, which finds no change.
    SdoDownload,
    /// A SYNC with four synchronous TPDOs (type 1; 7 + 8 + 8 + 8 bytes).
    Sync,
    /// No frame: `process` (and an empty `transmit`) with nothing due.
    Idle,
}

impl Kind {
    /// Every kind, in the order the benches report them.
    pub const ALL: [Kind; 5] = [Kind::Rpdo, Kind::SdoUpload, Kind::SdoDownload, Kind::Sync, Kind::Idle];

    /// The name on the command line and in reports.
    pub const fn name(self) -> &'static str {
        match self {
            Kind::Rpdo => "rpdo",
            Kind::SdoUpload => "sdo-upload",
            Kind::SdoDownload => "sdo-download",
            Kind::Sync => "sync",
            Kind::Idle => "idle",
        }
    }

    /// The kind named `s`.
    pub fn parse(s: &str) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.name() == s)
    }

    /// The frame of iteration `i` (none for [`Kind::Idle`]).
    pub fn frame(self, i: u64) -> Option<CanFrame> {
        match self {
            Kind::Rpdo => Some(frame(0x200 + u16::from(NODE_ID), &i.to_le_bytes())),
            Kind::SdoUpload => Some(sdo([0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0])),
            Kind::SdoDownload => Some(sdo([0x23, 0x03, 0x20, 0x00, 0x44, 0x44, 0x44, 0x44])),
            Kind::Sync => Some(frame(0x080, &[])),
            Kind::Idle => None,
        }
    }

    /// Frames the node sends for each one it handles.
    pub const fn answers(self) -> usize {
        match self {
            Kind::Rpdo | Kind::Idle => 0,
            Kind::SdoUpload | Kind::SdoDownload => 1,
            Kind::Sync => 4,
        }
    }

    /// A node in Operational, configured for this kind, at `now`.
    pub fn setup(self, now: Instant) -> Result<Dut, Mismatch> {
        let mut node = new_node(now)?;
        if self == Kind::Sync {
            map_sync_tpdos(&mut node, now)?;
        }
        start(&mut node, now)?;
        Ok(node)
    }

    /// Checks the last answer of a run of `n` frames (`sent` frames in all);
    /// `last` is the last frame the node sent.
    pub fn check(self, n: u64, sent: u64, last: Option<CanFrame>) -> Result<(), Mismatch> {
        let answer = Answer { count: usize::try_from(sent).unwrap_or(usize::MAX), first: None, last };
        let mismatch = Err(Mismatch { step: self.name(), answer });
        if Some(sent) != (self.answers() as u64).checked_mul(n) {
            return mismatch;
        }
        // 0x1018 sub 1, vendor-ID 0 (tests/eds/interop.eds).
        let want = CanFrame::standard(SDO_TX, &[0x43, 0x18, 0x10, 0x01, 0, 0, 0, 0]);
        if self == Kind::SdoUpload && n > 0 && last != want {
            return mismatch;
        }
        let want = CanFrame::standard(SDO_TX, &[0x60, 0x03, 0x20, 0x00, 0, 0, 0, 0]);
        if self == Kind::SdoDownload && n > 0 && last != want {
            return mismatch;
        }
        Ok(())
    }
}
