//! Bus-level benchmarks on virtual time, and the deterministic checks
//! behind them (docs/benchmarks-bus.md):
//!
//! - SDO block upload of 64 KiB from one node at 1 Mbit/s, blksize 127,
//!   with CRC: payload bits per virtual second, as a share of the wire's
//!   limit for block segments (7 payload bytes per segment frame) and of
//!   the raw bit rate. Virtual time is exact, so the test asserts the
//!   share (≥ 95 %).
//! - 127 interop nodes at 1 Mbit/s: heartbeat every 100 ms, each node
//!   consuming the next one's with 250 ms, and one cyclic TPDO per node
//!   driven by the SYNC that node 1 produces every 20 ms (TPDO2, type 1:
//!   every SYNC). The test runs 2 s and checks every frame count and the
//!   bus load; the `#[ignore]`d `bench_*` tests run the full figures and
//!   print them. `cargo xtask bench` runs those in release mode and measures
//!   their wall time from outside: no test reads a clock.
//!
//! Lines starting with `bench:` are figures; a `bench-mark: <name>` line
//! marks an instant for `cargo xtask bench` to time.

mod common;

use canopen_core::abort::AbortCode;
use canopen_core::node::{Application, Ctx, NoApplication};
use canopen_core::time::{Duration, Instant};
use common::net::{Net, NodeHandle, us};
use embedded_can::Frame;
use hal_host::bus::{BitRate, frame_bits};
use hal_host::fixtures::interop::od::{Node, Ram};
use hal_host::master::UploadMode;
use hal_host::storage::MemStorage;

// ---- SDO block upload throughput ------------------------------------------------

/// A DOMAIN the interop dictionary lacks: 0x2F00 sub 0, `len` bytes of a
/// fixed pseudo-random pattern (so the stuff bits are those of real data).
struct Domain {
    len: usize,
}

const DOMAIN: u16 = 0x2F00;

fn pattern(i: usize) -> u8 {
    // The top byte of a multiplicative hash (Knuth's constant).
    ((i as u32).wrapping_add(1).wrapping_mul(0x9E37_79B1) >> 24) as u8
}

impl Application for Domain {
    fn upload_size(&mut self, _ctx: &mut Ctx<'_>, index: u16, sub: u8) -> Option<Result<usize, AbortCode>> {
        (index == DOMAIN).then_some(if sub == 0 { Ok(self.len) } else { Err(AbortCode::NoSubIndex) })
    }

    fn read(&mut self, _ctx: &mut Ctx<'_>, index: u16, _sub: u8, offset: usize, buf: &mut [u8]) -> Option<Result<usize, AbortCode>> {
        if index != DOMAIN {
            return None;
        }
        let n = buf.len().min(self.len.saturating_sub(offset));
        for (i, b) in buf.iter_mut().take(n).enumerate() {
            *b = pattern(offset + i);
        }
        Some(Ok(n))
    }
}

/// What one block upload achieved.
#[derive(Debug)]
struct Throughput {
    payload: usize,
    /// From queuing the initiate request to the EOF of the client's end frame.
    elapsed: Duration,
    segments: usize,
    /// Bits of all segment frames on the wire, intermission included.
    segment_bits: u64,
    /// Frames of the transfer other than segments (initiate, start, acks, end).
    other_frames: usize,
    rate: BitRate,
}

impl Throughput {
    /// Payload bits per second.
    fn achieved(&self) -> f64 {
        self.payload as f64 * 8.0 / (self.elapsed.as_micros() as f64 * 1e-6)
    }

    /// The wire's limit: 7 payload bytes per segment frame, back to back.
    fn limit(&self) -> f64 {
        let mean_segment_s = self.segment_bits as f64 / self.segments as f64 / f64::from(self.rate.bps());
        56.0 / mean_segment_s
    }

    fn share(&self) -> f64 {
        self.achieved() / self.limit()
    }

    fn raw_share(&self) -> f64 {
        self.achieved() / f64::from(self.rate.bps())
    }
}

/// Uploads `len` bytes of 0x2F00 from node 5 with `blksize` and CRC.
fn block_upload(len: usize, blksize: u8) -> Throughput {
    const ID: u8 = 5;
    let rate = BitRate::MBIT_1;
    let mut net = Net::new("block_upload_throughput", rate);
    let m = net.add_master();
    let node = net.add_node(Node::new(Ram::new(ID), Domain { len }, MemStorage::new(4096), ID, us(0)));
    net.run_until(us(1000));
    let (start, before) = (net.now(), net.bus().stats());
    let value = net.sdo_upload(m, ID, DOMAIN, 0, UploadMode::Block { blksize, pst: 0, crc: true }).expect("the upload");
    assert_eq!(value.len(), len);
    assert!(value.iter().enumerate().all(|(i, &b)| b == pattern(i)), "the value arrived intact");
    let frames = net.bus().trace().iter().filter(|e| e.time > start).copied().collect::<Vec<_>>();
    let end = frames.last().expect("frames").time;
    // The node's frames are the initiate response, the segments and the end request.
    let from_node: Vec<_> = frames.iter().filter(|e| e.port == node.port).collect();
    let segments = &from_node[1..from_node.len() - 1];
    assert!(segments.iter().all(|e| e.frame.data().len() == 8 && e.frame.data()[0] & 0x7F != 0));
    assert_eq!(segments.len(), len.div_ceil(7));
    assert_eq!(net.bus().stats().error_frames, 0);
    // The wire never idled: busy from the request to the last intermission.
    net.run_until(end + Duration::from_micros(3));
    let busy = net.bus().stats().busy_ns - before.busy_ns;
    assert_eq!(busy, (end.saturating_duration_since(start).as_micros() + 3) * 1000, "the bus idled during the transfer");
    Throughput {
        payload: len,
        elapsed: end.saturating_duration_since(start),
        segments: segments.len(),
        segment_bits: segments.iter().map(|e| u64::from(frame_bits(&e.frame).total())).sum(),
        other_frames: frames.len() - segments.len(),
        rate,
    }
}

fn print_throughput(t: &Throughput) {
    println!("bench: block upload: {} bytes, blksize 127, CRC, {} bit/s", t.payload, t.rate.bps());
    println!("bench:   virtual time {} µs, {} segment frames, {} other frames", t.elapsed.as_micros(), t.segments, t.other_frames);
    println!("bench:   mean segment frame {:.2} bits (stuff bits and intermission included)", t.segment_bits as f64 / t.segments as f64);
    println!("bench:   achieved {:.0} bit/s of payload", t.achieved());
    println!("bench:   wire limit {:.0} bit/s (7 bytes per segment frame): share {:.2} %", t.limit(), t.share() * 100.0);
    println!("bench:   share of the raw bit rate {:.2} %", t.raw_share() * 100.0);
}

#[test]
fn block_upload_of_64_kib_reaches_95_percent_of_the_wire_limit() {
    let t = block_upload(64 * 1024, 127);
    // 9363 segments in 74 sub-blocks: initiate, its answer, start, 74 acks,
    // end request and end response.
    assert_eq!((t.segments, t.other_frames), (9363, 3 + 74 + 2));
    assert!(t.share() >= 0.95, "{t:?}: share {}", t.share());
    // Everything but the acks and the protocol frames is segments back to
    // back: the share is segment time over elapsed time.
    let busy_share = t.segment_bits as f64 / t.elapsed.as_micros() as f64;
    assert!((t.share() - busy_share * (t.payload as f64 / 7.0 / t.segments as f64)).abs() < 1e-9);
}

#[test]
#[ignore = "benchmark: `cargo xtask bench`"]
fn bench_block_upload_64_kib() {
    println!("bench-mark: start");
    let t = block_upload(64 * 1024, 127);
    println!("bench-mark: end");
    print_throughput(&t);
}

// ---- 127 nodes -------------------------------------------------------------------

type Interop = Node<NoApplication, MemStorage>;

/// SYNC period of node 1 (0x1006), µs.
const SYNC_PERIOD_US: u32 = 20_000;
/// Heartbeat producer time (0x1017), ms.
const HEARTBEAT_MS: u16 = 100;
/// Heartbeat consumer time for the next node (0x1016 sub 1), ms.
const CONSUMER_MS: u32 = 250;

/// What a run of the 127-node bus did in its measured span.
#[derive(Debug, Default)]
struct BusRun {
    span: Duration,
    frames: u64,
    load: f64,
    syncs: u64,
    tpdos: u64,
    heartbeats: u64,
    emcys: u64,
    other: u64,
    overflows: u32,
    calls: common::net::Calls,
    /// Every frame the master received, as (EOF, COB-ID, byte 0), if asked for.
    log: Vec<(Instant, u16, u8)>,
}

/// 127 interop nodes and a master, configured over SDO and started, after
/// `warm_up` (the TPDO1 that each node sends once on entering Operational
/// are over by then).
fn bus_of_127(warm_up: Duration) -> (Net, hal_host::bus::PortId, Vec<NodeHandle>) {
    let mut net = Net::untraced("bus_of_127_nodes", BitRate::MBIT_1);
    let m = net.add_master();
    let nodes: Vec<_> =
        (1..=127u8).map(|id| net.add_node(Interop::new(Ram::new(id), NoApplication, MemStorage::new(4096), id, us(0)))).collect();
    net.run_until(us(20_000));
    for id in 1..=127u8 {
        let next = u32::from(id % 127 + 1);
        net.configure(m, id, 0x1016, 1, &(next << 16 | CONSUMER_MS).to_le_bytes());
        net.configure(m, id, 0x1017, 0, &HEARTBEAT_MS.to_le_bytes());
    }
    net.configure(m, 1, 0x1005, 0, &0x4000_0080u32.to_le_bytes());
    net.configure(m, 1, 0x1006, 0, &SYNC_PERIOD_US.to_le_bytes());
    net.send(m, 0x000, &[0x01, 0x00]);
    net.run_for(warm_up);
    assert!(nodes.iter().all(|&n| net.node::<Interop>(n).state() == canopen_core::services::nmt::NmtState::Operational));
    while net.bus().recv(m).is_some() {}
    (net, m, nodes)
}

/// Runs the started bus for `span`, counting (and with `log`, keeping) what the master port receives.
fn run_127(net: &mut Net, m: hal_host::bus::PortId, nodes: &[NodeHandle], span: Duration, log: bool) -> BusRun {
    let (t0, s0, c0) = (net.now(), net.bus().stats(), net.calls());
    let mut run = BusRun { span, ..BusRun::default() };
    // One virtual second at a time, emptying the master's receive queue.
    let mut t = t0;
    while t < t0 + span {
        t = (t + Duration::from_secs(1)).min(t0 + span);
        net.run_until(t);
        while let Some((at, f)) = net.bus().recv(m) {
            let cob_id = f.cob_id().unwrap_or(0);
            match cob_id {
                0x080 => run.syncs += 1,
                0x281..=0x2FF => run.tpdos += 1,
                0x701..=0x77F => run.heartbeats += 1,
                0x081..=0x0FF => run.emcys += 1,
                _ => run.other += 1,
            }
            if log {
                run.log.push((at, cob_id, f.data().first().copied().unwrap_or(0)));
            }
        }
    }
    let s = net.bus().stats();
    run.frames = s.frames - s0.frames;
    run.load = s.load_since(&s0);
    let c = net.calls();
    run.calls = common::net::Calls { on_frame: c.on_frame - c0.on_frame, used: c.used - c0.used, process: c.process - c0.process };
    run.overflows = nodes.iter().map(|&n| net.node::<Interop>(n).tx_overflows()).sum();
    run
}

fn print_bus_run(r: &BusRun) {
    println!(
        "bench: 127 nodes at 1 Mbit/s, heartbeat {HEARTBEAT_MS} ms, SYNC every {SYNC_PERIOD_US} µs from node 1, TPDO2 (8 bytes) of every node on every SYNC"
    );
    println!(
        "bench:   virtual time {} s: {} frames ({} SYNC, {} TPDO, {} heartbeats, {} EMCY, {} other)",
        r.span.as_micros() as f64 / 1e6,
        r.frames,
        r.syncs,
        r.tpdos,
        r.heartbeats,
        r.emcys,
        r.other
    );
    let per_second = r.frames as f64 / (r.span.as_micros() as f64 * 1e-6);
    println!("bench:   bus load {:.2} %, {per_second:.0} frames per virtual second, TX queue overflows {}", r.load * 100.0, r.overflows);
    let c = r.calls;
    println!("bench:   node calls: on_frame {} ({} used, the rest counted as ignored), process {}", c.on_frame, c.used, c.process);
}

#[test]
fn a_bus_of_127_nodes_carries_every_heartbeat_and_every_pdo() {
    let (mut net, m, nodes) = bus_of_127(Duration::from_millis(200));
    let r = run_127(&mut net, m, &nodes, Duration::from_secs(2), true);
    assert_eq!((r.emcys, r.other, r.overflows), (0, 0, 0), "no consumer timed out, nothing else was sent, nothing overflowed");
    // Each SYNC is followed by the 127 TPDO2 before the next SYNC, in
    // identifier order (they are queued at the same instant, so arbitration
    // sorts them), except where a node's heartbeat was already waiting in
    // its mailboxes: they are used in FIFO order (as the style guide asks
    // for SDO block segments), so that TPDO follows its heartbeat, after
    // every other TPDO. A SYNC is at most one frame late (it waits for the
    // frame on the wire when it falls due).
    let syncs: Vec<usize> = r.log.iter().enumerate().filter(|(_, f)| f.1 == 0x080).map(|(i, _)| i).collect();
    assert_eq!(syncs.len(), 100);
    let mut behind_heartbeat = 0;
    for w in syncs.windows(2) {
        let burst = &r.log[w[0]..w[1]];
        let mut tpdos: Vec<u16> = burst.iter().map(|f| f.1).filter(|c| (0x281..=0x2FF).contains(c)).collect();
        for (i, f) in burst.iter().enumerate().skip(2) {
            if (0x281..=0x2FF).contains(&f.1)
                && f.1 < burst[..i].iter().map(|g| g.1).filter(|c| (0x281..=0x2FF).contains(c)).max().unwrap_or(0)
            {
                assert_eq!(burst[i - 1].1, f.1 - 0x280 + 0x700, "an out-of-order TPDO comes right after its node's heartbeat");
                behind_heartbeat += 1;
            }
        }
        tpdos.sort_unstable();
        assert_eq!(tpdos, (0x281..=0x2FF).collect::<Vec<u16>>());
        let gap = r.log[w[1]].0.saturating_duration_since(r.log[w[0]].0).as_micros();
        assert!(gap.abs_diff(20_000) <= 135, "SYNC interval {gap} µs");
    }
    // Every node's heartbeat (Operational) every 100 ms, give or take the
    // length of a SYNC burst.
    for id in 1..=127u16 {
        let beats: Vec<_> = r.log.iter().filter(|f| f.1 == 0x700 + id).collect();
        assert!(beats.iter().all(|f| f.2 == 0x05));
        assert!((19..=21).contains(&beats.len()), "node {id}: {} heartbeats", beats.len());
        for w in beats.windows(2) {
            let gap = w[1].0.saturating_duration_since(w[0].0).as_micros();
            assert!(gap.abs_diff(100_000) <= 17_000, "node {id}: heartbeat interval {gap} µs");
        }
    }
    assert!(behind_heartbeat > 0 && behind_heartbeat < 2540, "{behind_heartbeat}");
    // 127 TPDO2 of about 120 bits per 20 ms, 1270 heartbeats of about 56 bits per second.
    assert!((0.80..0.90).contains(&r.load), "{r:?}");
}

#[test]
#[ignore = "benchmark: `cargo xtask bench`"]
fn bench_127_nodes_60_s() {
    // CANOPEN_BENCH_SECONDS shortens the run for a profiler.
    let seconds = std::env::var("CANOPEN_BENCH_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(60);
    let (mut net, m, nodes) = bus_of_127(Duration::from_millis(200));
    println!("bench-mark: start");
    let r = run_127(&mut net, m, &nodes, Duration::from_secs(seconds), false);
    println!("bench-mark: end");
    print_bus_run(&r);
    assert_eq!((r.emcys, r.other, r.overflows), (0, 0, 0));
}
