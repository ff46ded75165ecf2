//! Time beyond 32 bits. The services keep their deadlines as 32-bit
//! microseconds since the node's epoch, which the node moves forward every
//! 35.8 minutes at most (`canopen_core::time`); the board's clock is a
//! 64-bit `Instant`, whose low 32 bits wrap every 71.6 minutes. These
//! cases start the virtual clock just before 2^32 µs and 2^33 µs, where a
//! clock cut to 32 bits wraps, and run timers longer than 32-bit
//! microseconds hold or than one epoch lasts:
//! - life guarding with a life time of 2 hours (0x100C 60,000 ms × 0x100D
//!   120; CiA 301 §7.2.8.3.1): EMCY 0x8130 exactly one life time after the
//!   last guarding request, not a microsecond before;
//! - the SYNC producer with a period of 60 minutes (0x1006 = 3.6 × 10^9
//!   µs; §7.2.5): each SYNC exactly one period after the previous one;
//! - the synchronous window (0x1007) of 50 minutes: a synchronous RPDO
//!   49 minutes after the SYNC is taken at the next SYNC, one 51 minutes
//!   after it is discarded (§7.2.5, "synchronous window length");
//! - a node running for hours (heartbeat consumer, SYNC consumer with a
//!   synchronous TPDO, an event-timer TPDO, node guarding) sends what CiA
//!   301 requires at the times it requires, across several wraps and
//!   epoch moves, frame for frame the same as a node started at 0.

mod common;

use canopen_core::node::{NoApplication, Node};
use canopen_core::time::Instant;
use common::{Bench, F};
use hal_host::fixtures::interop::od as interop;
use hal_host::storage::MemStorage;

const ID: u8 = 5;
const EC: u16 = 0x700 + ID as u16;
const EMCY: u16 = 0x80 + ID as u16;
const SECOND: u64 = 1_000_000;
const MINUTE: u64 = 60 * SECOND;
const HOUR: u64 = 60 * MINUTE;
/// 2^32 µs: where a clock cut to 32 bits wraps (71.6 minutes).
const WRAP: u64 = 1 << 32;

type Interop = Bench<interop::Ram, NoApplication, MemStorage, 4, 4, 4>;

fn us(t: u64) -> Instant {
    Instant::from_micros(t)
}

/// The interop node (node 5), powered on at `start` µs, past its boot-up.
fn node_at(start: u64) -> Interop {
    let node = Node::new(interop::Ram::new(ID), NoApplication, MemStorage::new(4096), ID, us(start));
    let mut b: Interop = Bench { node, now: us(start) };
    assert_eq!(b.at(us(start)), [(EC, vec![0x00])]);
    b
}

/// Every deadline up to `end` in order, as a board's timer calls the node,
/// and besides them a call every `every` µs (a board may call early).
fn run(b: &mut Interop, end: u64, every: u64) -> Vec<(u64, F)> {
    let mut out = Vec::new();
    while b.now.as_micros() < end {
        let step = (b.now.as_micros() + every).min(end);
        out.extend(b.run_until(us(step)).into_iter().map(|(t, f)| (t.as_micros(), f)));
    }
    out
}

/// EMCY 0x8130 (life guard or heartbeat error), register 0x11, for `node` (0: life guarding).
fn life_guard_emcy(node: u8) -> F {
    (EMCY, vec![0x30, 0x81, 0x11, node, 0, 0, 0, 0])
}

#[test]
fn a_life_time_of_two_hours_expires_exactly_across_wraps() {
    // The last request at 2^32 − 10 min, at 2^33 − 1 h and at 2^31 − 1 µs:
    // the life time ends past a wrap of the 32-bit clock, and past several epoch moves.
    for t0 in [WRAP - 10 * MINUTE, 2 * WRAP - HOUR, (1 << 31) - 1, 10 * SECOND] {
        let mut b = node_at(t0 - 5 * SECOND);
        assert_eq!(b.sdo_download(ID, 0x100C, 0, &60_000u16.to_le_bytes()), Ok(()));
        assert_eq!(b.sdo_download(ID, 0x100D, 0, &[120]), Ok(()));
        assert_eq!(run(&mut b, t0, 7 * MINUTE), []);
        assert_eq!(b.rtr(us(t0), EC), [(EC, vec![0x7F])], "pre-operational, toggle 0");
        let expiry = t0 + 2 * HOUR;
        assert_eq!(run(&mut b, expiry - 1, 7 * MINUTE), [], "from {t0} µs: not a microsecond early");
        assert_eq!(run(&mut b, expiry + HOUR, 7 * MINUTE), [(expiry, life_guard_emcy(0))], "from {t0} µs: once, at the life time");
        // The master resumes: the error ends, and the next life time counts from this request.
        assert_eq!(b.rtr(us(expiry + HOUR), EC), [(EMCY, vec![0; 8]), (EC, vec![0xFF])]);
        let again = expiry + 3 * HOUR;
        assert_eq!(run(&mut b, again + 1, 11 * MINUTE), [(again, life_guard_emcy(0))], "from {t0} µs: the second life time");
    }
}

#[test]
fn a_sync_period_of_an_hour_keeps_its_grid_across_wraps() {
    const PERIOD: u64 = HOUR;
    for start in [WRAP - 10 * MINUTE, 2 * WRAP - 2 * MINUTE, 0] {
        let mut b = node_at(start);
        assert_eq!(b.sdo_download(ID, 0x1006, 0, &(PERIOD as u32).to_le_bytes()), Ok(()));
        // Bit 30: the node produces the SYNC; its first comes one period after this.
        assert_eq!(b.sdo_download(ID, 0x1005, 0, &0x4000_0080u32.to_le_bytes()), Ok(()));
        let sent = run(&mut b, start + 4 * PERIOD, 13 * MINUTE);
        let want: Vec<(u64, F)> = (1..=4).map(|k| (start + k * PERIOD, (0x080, vec![]))).collect();
        assert_eq!(sent, want, "from {start} µs");
    }
}

#[test]
fn a_synchronous_window_of_fifty_minutes_closes_exactly_across_wraps() {
    for sync in [WRAP - 20 * MINUTE, 2 * WRAP - 49 * MINUTE, MINUTE] {
        let mut b = node_at(sync - SECOND);
        // 0x1007: 50 minutes; RPDO1 (0x205, 0x2100 sub 1 to 4) synchronous (type 1); Operational.
        assert_eq!(b.sdo_download(ID, 0x1007, 0, &(50 * MINUTE as u32).to_le_bytes()), Ok(()));
        assert_eq!(b.sdo_download(ID, 0x1400, 1, &0x8000_0205u32.to_le_bytes()), Ok(()));
        assert_eq!(b.sdo_download(ID, 0x1400, 2, &[1]), Ok(()));
        assert_eq!(b.sdo_download(ID, 0x1400, 1, &0x205u32.to_le_bytes()), Ok(()));
        b.nmt(0x01, ID);
        let _ = run(&mut b, sync, 17 * MINUTE);
        let rpdo1 = |value: u8| [value, 0, 0, 0, 0, 0, 0, 0];
        assert_eq!(b.sdo_upload(ID, 0x2100, 1), Ok(vec![0, 0]));
        // A SYNC, then an RPDO inside the window: taken at the next SYNC.
        let _ = b.rx(us(sync), 0x080, &[]);
        let _ = run(&mut b, sync + 49 * MINUTE, 17 * MINUTE);
        let _ = b.rx(us(sync + 49 * MINUTE), 0x205, &rpdo1(7));
        assert_eq!(b.sdo_upload(ID, 0x2100, 1), Ok(vec![0, 0]), "from {sync} µs: waits for the SYNC");
        let next = sync + 60 * MINUTE;
        let _ = run(&mut b, next, 17 * MINUTE);
        let _ = b.rx(us(next), 0x080, &[]);
        assert_eq!(b.sdo_upload(ID, 0x2100, 1), Ok(vec![7, 0]), "from {sync} µs: inside the window");
        // The window ends 50 minutes after the SYNC, to the microsecond.
        let _ = run(&mut b, next + 50 * MINUTE, 17 * MINUTE);
        let _ = b.rx(us(next + 50 * MINUTE), 0x205, &rpdo1(8));
        let _ = b.rx(us(next + 50 * MINUTE + 1), 0x205, &rpdo1(9));
        let _ = run(&mut b, next + 70 * MINUTE, 17 * MINUTE);
        let _ = b.rx(us(next + 70 * MINUTE), 0x080, &[]);
        assert_eq!(b.sdo_upload(ID, 0x2100, 1), Ok(vec![8, 0]), "from {sync} µs: the last microsecond is inside, the next outside");
    }
}

/// What CiA 301 requires of the long run below, from when the node went
/// Operational (`op`) to `end`: TPDO1 (type 255, event timer 500 ms) at
/// once and every 500 ms, TPDO2 (type 1) at each SYNC, a guarding answer
/// (Operational, the toggle alternating) to each request; nothing else
/// (the heartbeats of node 10 come within its consumer time, the guarding
/// requests within the life time).
/// `tpdo1` and `tpdo2`: their mapped objects' values, as read by SDO.
fn required(op: u64, end: u64, syncs: &[u64], requests: &[u64], tpdo1: &[u8], tpdo2: &[u8]) -> Vec<(u64, F)> {
    let mut want: Vec<(u64, F)> = Vec::new();
    let mut t = op;
    while t <= end {
        want.push((t, (0x185, tpdo1.to_vec())));
        t += 500_000;
    }
    want.extend(syncs.iter().map(|&t| (t, (0x285, tpdo2.to_vec()))));
    let mut toggle = 0;
    for &t in requests {
        want.push((t, (EC, vec![toggle | 0x05])));
        toggle ^= 0x80;
    }
    want.sort_by_key(|(t, f)| (*t, f.0));
    want
}

/// The long run from `start`: frames and times relative to `start`.
fn long_run(start: u64, hours: u64) -> Vec<(u64, F)> {
    let mut b = node_at(start);
    // Consumes node 10's heartbeat (1.5 s), TPDO1's event timer 500 ms, guarding 1 s × 3.
    assert_eq!(b.sdo_download(ID, 0x1016, 1, &((10u32 << 16) | 1500).to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1800, 5, &500u16.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x100C, 0, &1000u16.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x100D, 0, &[3]), Ok(()));
    // What TPDO1 (0x2000, 0x2001, 0x2003) and TPDO2 (0x2004, 0x2007) carry.
    let mut read = |objects: &[u16]| -> Vec<u8> { objects.iter().flat_map(|&i| b.sdo_upload(ID, i, 0).expect("readable")).collect() };
    let (tpdo1, tpdo2) = (read(&[0x2000, 0x2001, 0x2003]), read(&[0x2004, 0x2007]));
    let op = start + SECOND;
    let end = op + hours * HOUR;
    assert_eq!(run(&mut b, op, SECOND), []);
    let mut sent: Vec<(u64, F)> = b.rx(us(op), 0x000, &[0x01, ID]).into_iter().map(|f| (op, f)).collect();
    // The master: node 10's heartbeat every second, a SYNC every 700 ms, a guarding request every 2.3 s.
    let (mut syncs, mut requests) = (Vec::new(), Vec::new());
    let mut t = op;
    while t < end {
        t += 100_000;
        sent.extend(run(&mut b, t, HOUR));
        let k = (t - op) / 100_000;
        if k.is_multiple_of(10) {
            sent.extend(b.rx(us(t), 0x70A, &[0x05]).into_iter().map(|f| (t, f)));
        }
        if k.is_multiple_of(7) {
            syncs.push(t);
            sent.extend(b.rx(us(t), 0x080, &[]).into_iter().map(|f| (t, f)));
        }
        if k.is_multiple_of(23) {
            requests.push(t);
            sent.extend(b.rtr(us(t), EC).into_iter().map(|f| (t, f)));
        }
    }
    sent.sort_by_key(|(t, f)| (*t, f.0));
    let want = required(op, end, &syncs, &requests, &tpdo1, &tpdo2);
    let first = sent.iter().zip(&want).position(|(a, b)| a != b);
    assert_eq!((sent.len(), first), (want.len(), None), "from {start} µs: first difference {:?}", first.map(|i| (&sent[i], &want[i])));
    sent.into_iter().map(|(t, f)| (t - start, f)).collect()
}

#[test]
fn a_node_runs_for_hours_across_wraps_as_from_zero() {
    // For 2 hours from 2^32 − 10 min (the 32-bit clock wraps at 10 and 81.6
    // minutes) and from 2^33 − 3 min; the node's epoch moves at least three times.
    let reference = long_run(0, 2);
    assert!(reference.len() > 27_000, "{} frames", reference.len());
    for start in [WRAP - 10 * MINUTE, 2 * WRAP - 3 * MINUTE] {
        assert!(long_run(start, 2) == reference, "from {start} µs: not as from 0");
    }
}
