//! The image: start-up, the measurements and their report.
// cortex-m-rt's HardFault handler must be an `unsafe fn`; no unsafe block here.
#![allow(unsafe_code)]

use canopen_core::node::Application;
use canopen_core::time::{Duration, Instant};
use canopen_icount::worst::CASES;
use canopen_icount::{Answer, Dut, Kind, Mismatch, cia402};
use core::hint::black_box;
use cortex_m_rt::{ExceptionFrame, entry, exception};
use cortex_m_semihosting::{debug, hprintln};
use firmware::can_node::CanNode;
use firmware::devices::ec5000;

use crate::clock::{Clock, Tally};
use crate::isr::{self, Rx};

/// Frames of each kind per run (the host bench's default N).
const FRAMES: u64 = 1_000;
/// Runs of each worst-case frame, each on a freshly prepared node.
const RUNS: u32 = 50;
/// SLCAN lines (and bxCAN frames) timed.
const LINES: u32 = 200;

#[entry]
fn main() -> ! {
    let status = match run() {
        Ok(()) => {
            hprintln!("icount-qemu ok");
            debug::EXIT_SUCCESS
        }
        Err(e) => {
            hprintln!("icount-qemu FAILED {}", e);
            debug::EXIT_FAILURE
        }
    };
    exit(status)
}

/// What went wrong, for the report.
enum Failure {
    /// The clock or a receive path did not do what the bench requires.
    Bench(&'static str),
    /// The node's answer to a frame was not the expected one.
    Answer(Mismatch),
}

impl core::fmt::Display for Failure {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Failure::Bench(what) => f.write_str(what),
            Failure::Answer(m) => {
                write!(
                    f,
                    "{}: the node sent {} frame(s), first {:02X?}, last {:02X?}",
                    m.step, m.answer.count, m.answer.first, m.answer.last
                )
            }
        }
    }
}

impl From<Mismatch> for Failure {
    fn from(m: Mismatch) -> Self {
        Failure::Answer(m)
    }
}

impl From<&'static str> for Failure {
    fn from(what: &'static str) -> Self {
        Failure::Bench(what)
    }
}

fn run() -> Result<(), Failure> {
    let core = cortex_m::Peripherals::take().ok_or("peripherals taken")?;
    let (mut clock, calibration) = Clock::start(core.SYST)?;
    hprintln!(
        "icount-qemu calibration instructions={} ticks={} per_tick={} overhead={:.2} check_known={} check_measured={:.2}",
        calibration.instructions,
        calibration.ticks,
        clock.per_tick(),
        clock.overhead(),
        calibration.check_known,
        calibration.check_measured
    );
    for kind in Kind::ALL {
        per_frame(&mut clock, kind)?;
    }
    per_frame_cia402(&mut clock, "cia402", ec5000::App::NEW, false)?;
    per_frame_cia402(&mut clock, "cia402-echo", cia402::Echo, true)?;
    for case in &CASES {
        worst_case(&mut clock, case)?;
    }
    receive_paths(&mut clock)
}

/// The node as the firmware's CANopen task sees it; `black_box` keeps the
/// calls indirect, as they are there.
fn as_can_node(node: &mut Dut) -> &mut dyn CanNode {
    black_box(node as &mut dyn CanNode)
}

/// [`FRAMES`] frames of `kind`, one per millisecond, each: `on_frame`,
/// `process`, `transmit` until the queue is empty; reported per frame
/// (`transmit`: all its calls for the frame).
fn per_frame(clock: &mut Clock, kind: Kind) -> Result<(), Failure> {
    let mut now = Instant::from_micros(1_000);
    let mut dut = kind.setup(now)?;
    let node = as_can_node(&mut dut);
    let (mut rx, mut process, mut tx) = (Tally::default(), Tally::default(), Tally::default());
    let (mut sent, mut last) = (0u64, None);
    for i in 0..FRAMES {
        now += Duration::from_millis(1);
        let (now, frame) = black_box((now, kind.frame(i)));
        if let Some(frame) = frame {
            clock.time(&mut rx, || node.on_frame(now, &frame));
        }
        black_box(clock.time(&mut process, || node.process(now)));
        // Each call a span of its own: the loop around them is the bench's.
        while let Some(frame) = clock.time(&mut tx, || node.transmit()) {
            sent += 1;
            last = Some(black_box(frame));
        }
    }
    kind.check(FRAMES, sent, last)?;
    hprintln!(
        "icount-qemu kind={} frames={} on_frame={:.1} process={:.1} transmit={:.1} transmit_calls={} sent={}",
        kind.name(),
        FRAMES,
        clock.per_span(&rx),
        clock.per_span(&process),
        clock.per_span(&tx) * tx.spans() as f64 / FRAMES as f64,
        tx.spans(),
        sent
    );
    Ok(())
}

/// The CiA 402 row ([`cia402`]): [`FRAMES`] RPDOs through the EC5000's
/// application (or the baseline `echo`), measured as [`per_frame`] does.
/// Out of line: its node (the EC5000's, about 6 KiB) must not stay on the
/// stack of [`run`] while the other measurements build theirs.
#[inline(never)]
fn per_frame_cia402<A: Application + Send + 'static>(clock: &mut Clock, name: &str, app: A, echo: bool) -> Result<(), Failure> {
    let mut now = Instant::from_micros(1_000);
    let mut dut = cia402::setup(app, now)?;
    let node = black_box(&mut dut as &mut dyn CanNode);
    let (mut rx, mut process, mut tx) = (Tally::default(), Tally::default(), Tally::default());
    let (mut sent, mut last) = (0u64, None);
    for i in 0..FRAMES {
        now += Duration::from_millis(1);
        let (now, frame) = black_box((now, cia402::frame_of(i)));
        clock.time(&mut rx, || node.on_frame(now, &frame));
        black_box(clock.time(&mut process, || node.process(now)));
        while let Some(frame) = clock.time(&mut tx, || node.transmit()) {
            sent += 1;
            last = Some(black_box(frame));
        }
    }
    cia402::check(echo, FRAMES, sent, last)?;
    hprintln!(
        "icount-qemu kind={} frames={} on_frame={:.1} process={:.1} transmit={:.1} transmit_calls={} sent={}",
        name,
        FRAMES,
        clock.per_span(&rx),
        clock.per_span(&process),
        clock.per_span(&tx) * tx.spans() as f64 / FRAMES as f64,
        tx.spans(),
        sent
    );
    Ok(())
}

/// Process calls a frame may take (a reset or a store takes a stage per call).
const CALLS: usize = 16;

/// One expensive frame, [`RUNS`] times on a freshly prepared node:
/// `on_frame`, then `process` until the node has no reset or store in
/// progress (a stage per call). Reports the sum and the longest single call.
fn worst_case(clock: &mut Clock, case: &canopen_icount::worst::Case) -> Result<(), Failure> {
    let now = black_box(Instant::from_micros(1_000));
    let (mut rx, mut calls, mut sent) = (Tally::default(), [Tally::default(); CALLS], 0);
    let mut used = 0;
    for _ in 0..RUNS {
        let (mut dut, frame) = black_box(case.prepare(now)?);
        let node = as_can_node(&mut dut);
        clock.time(&mut rx, || node.on_frame(now, &frame));
        let mut k = 0;
        loop {
            let tally = calls.get_mut(k).ok_or(Failure::Bench("a reset took more process calls than the bench counts"))?;
            let node = as_can_node(&mut dut);
            black_box(clock.time(tally, || node.process(now)));
            k += 1;
            if !dut.resetting() && !dut.storing() {
                break;
            }
        }
        used = k;
        let answer = Answer::drain(&mut dut);
        sent = answer.count;
        case.check(&mut dut, now, answer)?;
    }
    let rx = clock.per_span(&rx);
    let (mut process, mut longest) = (0.0, rx);
    for (k, tally) in calls.iter().take(used).enumerate() {
        let call = clock.per_span(tally);
        process += call;
        longest = f64::max(longest, call);
        if used > 1 {
            hprintln!("icount-qemu stage={}/{} process={:.1}", case.name, k + 1, call);
        }
    }
    hprintln!(
        "icount-qemu worst={} on_frame={:.1} process={:.1} total={:.1} longest={:.1} calls={} sent={} runs={}",
        case.name,
        rx,
        process,
        rx + process,
        longest,
        used,
        sent,
        RUNS
    );
    Ok(())
}

/// The receive interrupts' part for one frame (see [`isr`]).
fn receive_paths(clock: &mut Clock) -> Result<(), Failure> {
    static RX: Rx = Rx::new();
    // An expedited SDO upload request, 8 data bytes: the longest standard-frame line.
    let frame = canopen_icount::sdo([0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]);
    let line = b"t60584018100100000000\r";
    let (mut bytes, mut cr, mut bxcan) = (Tally::default(), Tally::default(), Tally::default());
    for _ in 0..LINES {
        isr::slcan_line(clock, &mut bytes, &mut cr, &RX, line, &frame)?;
        isr::bxcan_frame(clock, &mut bxcan, &RX, &frame)?;
    }
    let all = (clock.per_span(&bytes) * (line.len() - 1) as f64) + clock.per_span(&cr);
    hprintln!("icount-qemu isr=slcan-uart0 bytes={} line={:.1} last_byte={:.1}", line.len(), all, clock.per_span(&cr));
    hprintln!("icount-qemu isr=bxcan-fifo0 frame={:.1}", clock.per_span(&bxcan));
    Ok(())
}

/// Ends the QEMU run.
fn exit(status: debug::ExitStatus) -> ! {
    loop {
        debug::exit(status);
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    hprintln!("icount-qemu FAILED panic: {}", info);
    exit(debug::EXIT_FAILURE)
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    hprintln!("icount-qemu FAILED HardFault at pc {:#010x}", frame.pc());
    exit(debug::EXIT_FAILURE)
}
