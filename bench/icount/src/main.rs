//! `canopen-icount KIND N`: the node of the instruction-count benches (see
//! the library: interop dictionary, brought to Operational) handles N frames
//! of one kind, one per millisecond of virtual time. `cargo xtask icount`
//! runs it under callgrind with N and 2N and divides the difference by N:
//! instructions per handled frame, without the start-up. Each iteration is
//! [`on_frame`], [`process`] and [`transmit`] until the queue is empty, each
//! in a function of its own so that `--toggle-collect` can count them apart.
//! The thumbv7m image `bench/icount-qemu` replays the same sequences.
//!
//! Every answer is checked, so a broken configuration fails instead of
//! measuring nothing.
//!
//! [`on_frame`]: canopen_core::node::Node::on_frame
//! [`process`]: canopen_core::node::Node::process
//! [`transmit`]: canopen_core::node::Node::transmit

use canopen_core::frame::CanFrame;
use canopen_core::node::Application;
use canopen_core::time::{Duration, Instant};
use canopen_icount::{Kind, cia402};
use firmware::can_node::CanNode;
use firmware::devices::ec5000;
use std::hint::black_box;
use std::process::ExitCode;

#[inline(never)]
fn icount_on_frame<N: CanNode>(node: &mut N, now: Instant, frame: &CanFrame) {
    node.on_frame(now, frame);
}

#[inline(never)]
fn icount_process<N: CanNode>(node: &mut N, now: Instant) -> Option<Instant> {
    node.process(now)
}

#[inline(never)]
fn icount_transmit<N: CanNode>(node: &mut N) -> Option<CanFrame> {
    node.transmit()
}

fn run(kind: Kind, n: u64) -> Result<(), String> {
    let mut now = Instant::from_micros(1_000);
    let mut node = kind.setup(now).map_err(|e| format!("set-up: {e:02X?}"))?;
    let mut sent = 0u64;
    let mut last = None;
    for i in 0..n {
        now += Duration::from_millis(1);
        if let Some(frame) = kind.frame(i) {
            icount_on_frame(&mut node, now, &frame);
        }
        black_box(icount_process(&mut node, now));
        while let Some(f) = icount_transmit(&mut node) {
            sent += 1;
            last = Some(f);
        }
    }
    kind.check(n, sent, last).map_err(|e| format!("{n} frames: {e:02X?}, expected {} answers each", kind.answers()))?;
    let c = node.counters();
    println!("{kind:?}: {n} frames handled, {sent} sent; counters rx {} tx {} malformed {} ignored {}", c.rx, c.tx, c.malformed, c.ignored);
    Ok(())
}

/// The CiA 402 row ([`cia402`]): N RPDOs through the EC5000's application
/// (`echo` false) or the baseline that copies 0x6040 to 0x6041.
fn run_cia402<A: Application + Send + 'static>(app: A, echo: bool, n: u64) -> Result<(), String> {
    let mut now = Instant::from_micros(1_000);
    let mut node = cia402::setup(app, now).map_err(|e| format!("set-up: {e:02X?}"))?;
    let (mut sent, mut last) = (0u64, None);
    for i in 0..n {
        now += Duration::from_millis(1);
        let frame = cia402::frame_of(i);
        icount_on_frame(&mut node, now, &frame);
        black_box(icount_process(&mut node, now));
        while let Some(f) = icount_transmit(&mut node) {
            sent += 1;
            last = Some(f);
        }
    }
    cia402::check(echo, n, sent, last).map_err(|e| format!("{n} frames: {e:02X?}, expected one TPDO3 each"))?;
    println!("cia402 (echo {echo}): {n} frames handled, {sent} sent");
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.as_slice() {
        [kind, n] => match (kind.as_str(), n.parse::<u64>()) {
            ("cia402", Ok(n)) => Some(run_cia402(ec5000::App::NEW, false, n)),
            ("cia402-echo", Ok(n)) => Some(run_cia402(cia402::Echo, true, n)),
            (kind, Ok(n)) => Kind::parse(kind).map(|k| run(k, n)),
            _ => None,
        },
        _ => None,
    };
    let Some(result) = result else {
        eprintln!("usage: canopen-icount rpdo|sdo-upload|sdo-download|sync|idle|cia402|cia402-echo N");
        return ExitCode::FAILURE;
    };
    match result {
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
    use canopen_icount::worst::CASES;
    use canopen_icount::{Answer, exchange};

    /// The bench still configures the node and gets the answers it counts
    /// (`cargo xtask icount` would otherwise fail only when run).
    #[test]
    fn every_kind_runs() {
        for kind in Kind::ALL {
            run(kind, 10).unwrap();
        }
        run_cia402(ec5000::App::NEW, false, 10).unwrap();
        run_cia402(cia402::Echo, true, 10).unwrap();
    }

    /// The CiA 402 row's check rejects a node whose statusword does not follow.
    #[test]
    fn the_cia402_check_needs_the_state_machine() {
        assert!(cia402::check(false, 2, 2, CanFrame::standard(cia402::TPDO3, &[0x33, 0x02, 0, 0, 0, 0])).is_ok());
        assert!(cia402::check(false, 2, 2, CanFrame::standard(cia402::TPDO3, &[0x07, 0x00, 0, 0, 0, 0])).is_err());
        assert!(cia402::check(true, 2, 1, CanFrame::standard(cia402::TPDO3, &[0x07, 0x00, 0, 0, 0, 0])).is_err());
    }

    /// A run whose answers are not all there fails: the check counts them.
    #[test]
    fn a_missing_answer_fails_the_check() {
        assert!(Kind::Sync.check(10, 40, None).is_ok());
        assert!(Kind::Sync.check(10, 39, None).is_err());
        assert!(Kind::Rpdo.check(10, 1, None).is_err());
        let wrong = CanFrame::standard(0x585, &[0x43, 0x18, 0x10, 0x01, 1, 0, 0, 0]);
        assert!(Kind::SdoUpload.check(1, 1, wrong).is_err());
    }

    /// Every worst-case frame does its work on the host as on the MCU, and
    /// its check rejects a node that did not get the frame.
    #[test]
    fn every_worst_case_runs_and_checks() {
        let now = Instant::from_micros(1_000);
        for case in &CASES {
            let (mut node, frame) = case.prepare(now).unwrap_or_else(|e| panic!("{}: {e:02X?}", case.name));
            let nothing = Answer::drain(&mut node);
            let untouched = case.check(&mut node, now, nothing);
            assert!(untouched.is_err(), "{}: passes without the frame", case.name);
            let answer = exchange(&mut node, now, &frame);
            case.check(&mut node, now, answer).unwrap_or_else(|e| panic!("{}: {e:02X?}", case.name));
        }
    }
}
