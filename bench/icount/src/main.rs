//! `canopen-icount KIND N`: a node on the interop test dictionary, brought to
//! Operational, handles N frames of one kind, one per millisecond of virtual
//! time. `cargo xtask icount` runs it under callgrind with N and 2N and
//! divides the difference by N: instructions per handled frame, without the
//! start-up. Each iteration is [`on_frame`], [`process`] and [`transmit`]
//! until the queue is empty, each in a function of its own so that
//! `--toggle-collect` can count them apart.
//!
//! Kinds:
//! - `rpdo`: RPDO1 (8 bytes into 0x2100 sub 1..4), asynchronous (0xFF);
//! - `sdo-upload`: an expedited SDO upload of 0x1018 sub 1 (answered);
//! - `sync`: a SYNC with four synchronous TPDOs (type 1, 7 + 8 + 8 + 8 bytes).
//!
//! Every answer is checked, so a broken configuration fails instead of
//! measuring nothing.

use canopen_core::frame::CanFrame;
use canopen_core::node::NoApplication;
use canopen_core::time::{Duration, Instant};
use embedded_can::Frame;
use hal_host::fixtures::interop::od::{Node, Ram};
use hal_host::storage::MemStorage;
use std::hint::black_box;
use std::process::ExitCode;

const NODE_ID: u8 = 5;
const SDO_RX: u16 = 0x600 + NODE_ID as u16;
const SDO_TX: u16 = 0x580 + NODE_ID as u16;

type Dut = Node<NoApplication, MemStorage>;

/// The frame kinds this bench knows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Rpdo,
    SdoUpload,
    Sync,
}

impl Kind {
    fn parse(s: &str) -> Option<Kind> {
        Some(match s {
            "rpdo" => Kind::Rpdo,
            "sdo-upload" => Kind::SdoUpload,
            "sync" => Kind::Sync,
            _ => return None,
        })
    }

    /// The frame of iteration `i`.
    fn frame(self, i: u64) -> CanFrame {
        let f = match self {
            Kind::Rpdo => CanFrame::standard(0x200 + u16::from(NODE_ID), &i.to_le_bytes()),
            Kind::SdoUpload => CanFrame::standard(SDO_RX, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]),
            Kind::Sync => CanFrame::standard(0x080, &[]),
        };
        f.expect("valid frame")
    }

    /// Frames the node sends for each one it handles.
    fn answers(self) -> usize {
        match self {
            Kind::Rpdo => 0,
            Kind::SdoUpload => 1,
            Kind::Sync => 4,
        }
    }
}

#[inline(never)]
fn icount_on_frame(node: &mut Dut, now: Instant, frame: &CanFrame) {
    node.on_frame(now, frame);
}

#[inline(never)]
fn icount_process(node: &mut Dut, now: Instant) -> Option<Instant> {
    node.process(now)
}

#[inline(never)]
fn icount_transmit(node: &mut Dut) -> Option<CanFrame> {
    node.transmit()
}

/// Delivers a frame and returns what the node answers.
fn exchange(node: &mut Dut, now: Instant, frame: &CanFrame) -> Vec<CanFrame> {
    node.on_frame(now, frame);
    node.process(now);
    std::iter::from_fn(|| node.transmit()).collect()
}

/// An expedited SDO download that must succeed.
fn sdo_write(node: &mut Dut, now: Instant, index: u16, sub: u8, value: u32, len: u8) -> Result<(), String> {
    let [lo, hi] = index.to_le_bytes();
    let [a, b, c, d] = value.to_le_bytes();
    let cmd = 0x23 | ((4 - len) << 2);
    let req = CanFrame::standard(SDO_RX, &[cmd, lo, hi, sub, a, b, c, d]).ok_or("bad request")?;
    let out = exchange(node, now, &req);
    match out.as_slice() {
        [f] if f.cob_id() == Some(SDO_TX) && f.data() == [0x60, lo, hi, sub, 0, 0, 0, 0] => Ok(()),
        _ => Err(format!("download of {value:#X} to {index:04X}sub{sub} answered {out:02X?}")),
    }
}

/// Maps TPDO `n` (0-based) to `objects` and makes it synchronous (type 1).
fn sync_tpdo(node: &mut Dut, now: Instant, n: u16, objects: &[u32]) -> Result<(), String> {
    let cob = 0x180 + 0x100 * u32::from(n) + u32::from(NODE_ID);
    let (comm, map) = (0x1800 + n, 0x1A00 + n);
    sdo_write(node, now, comm, 1, 0xC000_0000 | cob, 4)?;
    sdo_write(node, now, map, 0, 0, 1)?;
    for (sub, &object) in (1..).zip(objects) {
        sdo_write(node, now, map, sub, object, 4)?;
    }
    sdo_write(node, now, map, 0, objects.len() as u32, 1)?;
    sdo_write(node, now, comm, 2, 1, 1)?;
    sdo_write(node, now, comm, 1, 0x4000_0000 | cob, 4)
}

/// A node in Operational, configured for `kind`, at `now`.
fn setup(kind: Kind, now: Instant) -> Result<Dut, String> {
    let mut node = Dut::new(Ram::new(NODE_ID), NoApplication, MemStorage::new(4096), NODE_ID, now);
    node.process(now);
    let boot: Vec<CanFrame> = std::iter::from_fn(|| node.transmit()).collect();
    if boot.len() != 1 {
        return Err(format!("expected the boot-up frame, got {boot:02X?}"));
    }
    if kind == Kind::Sync {
        sync_tpdo(&mut node, now, 0, &[0x2000_0008, 0x2001_0010, 0x2003_0020])?;
        sync_tpdo(&mut node, now, 1, &[0x2004_0020, 0x2007_0020])?;
        sync_tpdo(&mut node, now, 2, &[0x2100_0110, 0x2100_0210, 0x2100_0310, 0x2100_0410])?;
        sync_tpdo(&mut node, now, 3, &[0x2100_0510, 0x2100_0610, 0x2100_0710, 0x2100_0810])?;
    }
    let start = CanFrame::standard(0x000, &[0x01, NODE_ID]).ok_or("bad frame")?;
    let out = exchange(&mut node, now, &start);
    // Entering Operational may send the asynchronous TPDO1 once.
    if out.iter().any(|f| f.cob_id() == Some(SDO_TX)) {
        return Err(format!("unexpected answer to NMT start: {out:02X?}"));
    }
    Ok(node)
}

fn run(kind: Kind, n: u64) -> Result<(), String> {
    let mut now = Instant::from_micros(1_000);
    let mut node = setup(kind, now)?;
    let mut sent = 0usize;
    let mut last = None;
    for i in 0..n {
        now += Duration::from_millis(1);
        let frame = kind.frame(i);
        icount_on_frame(&mut node, now, &frame);
        black_box(icount_process(&mut node, now));
        while let Some(f) = icount_transmit(&mut node) {
            sent += 1;
            last = Some(f);
        }
    }
    let expected = kind.answers() * usize::try_from(n).map_err(|e| e.to_string())?;
    if sent != expected {
        return Err(format!("{kind:?}: the node sent {sent} frames for {n} handled, expected {expected}"));
    }
    if kind == Kind::SdoUpload {
        // 0x1018 sub 1, vendor-ID 0 (tests/eds/interop.eds).
        let want = CanFrame::standard(SDO_TX, &[0x43, 0x18, 0x10, 0x01, 0, 0, 0, 0]);
        if n > 0 && last != want {
            return Err(format!("SDO upload answered {last:02X?}"));
        }
    }
    let c = node.counters();
    println!("{kind:?}: {n} frames handled, {sent} sent; counters rx {} tx {} malformed {} ignored {}", c.rx, c.tx, c.malformed, c.ignored);
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let parsed = match args.as_slice() {
        [kind, n] => Kind::parse(kind).zip(n.parse::<u64>().ok()),
        _ => None,
    };
    let Some((kind, n)) = parsed else {
        eprintln!("usage: canopen-icount rpdo|sdo-upload|sync N");
        return ExitCode::FAILURE;
    };
    match run(kind, n) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("canopen-icount: {e}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bench still configures the node and gets the answers it counts
    /// (`cargo xtask icount` would otherwise fail only when run).
    #[test]
    fn every_kind_runs() {
        for kind in [Kind::Rpdo, Kind::SdoUpload, Kind::Sync] {
            run(kind, 10).unwrap();
        }
    }
}
