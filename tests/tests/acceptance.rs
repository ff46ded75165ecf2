//! The identifiers a node consumes (`Node::acceptance`, what the boards'
//! acceptance filters pass): the exact list of the interop node and of an
//! LSS device, how PDO, SDO server, heartbeat consumer and LSS node-id
//! changes move it and its generation, and a property test: for thousands
//! of random frames, one whose (COB-ID, RTR) is not on the list changes
//! nothing (a twin node that never saw it sends the same frames and holds
//! the same dictionary, then and afterwards).

mod common;

use canopen_core::frame::CanFrame;
use canopen_core::node::NoApplication;
use canopen_core::od::ObjectDictionary;
use canopen_core::storage::Storage;
use canopen_core::time::Duration;
use common::{Bench, ms};
use firmware::devices::{ec5000, sendix};
use hal_host::fixtures::interop::od::Ram;
use hal_host::storage::MemStorage;

type Interop = Bench<Ram, NoApplication, MemStorage, 4, 4, 4>;
type Ec5000 = Bench<ec5000::od::Ram, NoApplication, MemStorage, 4, 4, 1>;
type Sendix = Bench<sendix::od::Ram, NoApplication, MemStorage, 0, 3, 0>;

const ID: u8 = 5;

fn interop() -> Interop {
    let mut b = Bench::new(Ram::new(ID), NoApplication, MemStorage::new(2048), ID);
    b.at(ms(0));
    b
}

/// The node's list, sorted (the node keeps its own order).
fn list<O: ObjectDictionary, S: Storage, const R: usize, const T: usize, const HB: usize>(
    b: &Bench<O, NoApplication, S, R, T, HB>,
) -> Vec<(u16, bool)> {
    let mut ids: Vec<(u16, bool)> = b.node.acceptance().ids().iter().map(|a| (a.cob_id, a.rtr)).collect();
    ids.sort();
    ids
}

fn generation<O: ObjectDictionary, S: Storage, const R: usize, const T: usize, const HB: usize>(
    b: &Bench<O, NoApplication, S, R, T, HB>,
) -> u32 {
    b.node.acceptance().generation()
}

/// The interop node as it powers on: NMT, SYNC 0x80, TIME 0x100 (0x1012
/// bit 31), RPDO1 and RPDO2 (RPDO3/4 not valid), the default SDO server,
/// the guarding RTR and LSS; TPDO1/2 forbid RTR (bit 30), TPDO3/4 are off.
const INTEROP_DEFAULT: [(u16, bool); 8] =
    [(0x000, false), (0x080, false), (0x100, false), (0x205, false), (0x305, false), (0x605, false), (0x705, true), (0x7E5, false)];

// ---- Exact lists -------------------------------------------------------------------

#[test]
fn the_interop_node_lists_exactly_what_it_consumes() {
    let b = interop();
    assert_eq!(list(&b), INTEROP_DEFAULT);
    assert!(b.node.acceptance().is_complete());
}

#[test]
fn pdo_cob_id_changes_move_the_list_and_its_generation() {
    let mut b = interop();
    let g = generation(&b);
    // RPDO1 off, TPDO1 answers RTRs (bit 30 cleared), TPDO3 on without RTR.
    assert_eq!(b.sdo_download(ID, 0x1400, 1, &0x8000_0205u32.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1800, 1, &0x0000_0185u32.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1802, 1, &0x4000_0385u32.to_le_bytes()), Ok(()));
    let mut expected = INTEROP_DEFAULT.to_vec();
    expected.retain(|&e| e != (0x205, false));
    expected.push((0x185, true));
    expected.sort();
    assert_eq!(list(&b), expected, "TPDO3 has no mapping: still off, and bit 30 forbids RTR anyway");
    assert_eq!(generation(&b), g.wrapping_add(2), "one generation per download that changed the list");
    // RPDO1 moves to 0x2AA while invalid, then becomes valid there.
    assert_eq!(b.sdo_download(ID, 0x1400, 1, &0x8000_02AAu32.to_le_bytes()), Ok(()));
    assert_eq!(generation(&b), g.wrapping_add(2), "still invalid: nothing consumed changed");
    assert_eq!(b.sdo_download(ID, 0x1400, 1, &0x0000_02AAu32.to_le_bytes()), Ok(()));
    assert!(list(&b).contains(&(0x2AA, false)));
    assert_eq!(generation(&b), g.wrapping_add(3));
}

#[test]
fn a_second_sdo_server_and_heartbeat_consumers_are_listed() {
    let mut b = interop();
    let g = generation(&b);
    assert_eq!(b.sdo_download(ID, 0x1201, 1, &0x0000_06A0u32.to_le_bytes()), Ok(()));
    assert_eq!(list(&b), INTEROP_DEFAULT, "server 2 needs both COB-IDs valid");
    assert_eq!(b.sdo_download(ID, 0x1201, 2, &0x0000_06B0u32.to_le_bytes()), Ok(()));
    // Node 0x20 at 100 ms; the node's own id and a zero time consume nothing.
    assert_eq!(b.sdo_download(ID, 0x1016, 1, &0x0020_0064u32.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1016, 2, &0x0005_0064u32.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1016, 3, &0x0021_0000u32.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1016, 4, &0x007F_00C8u32.to_le_bytes()), Ok(()));
    let mut expected = INTEROP_DEFAULT.to_vec();
    expected.extend([(0x6A0, false), (0x720, false), (0x77F, false)]);
    expected.sort();
    assert_eq!(list(&b), expected);
    assert_eq!(generation(&b), g.wrapping_add(3));
    // Something no filter cares about leaves the generation alone.
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &100u16.to_le_bytes()), Ok(()));
    assert_eq!(generation(&b), g.wrapping_add(3));
    // Reset communication: the defaults again, a new generation.
    b.nmt(0x82, ID);
    assert_eq!(list(&b), INTEROP_DEFAULT);
    assert_eq!(generation(&b), g.wrapping_add(4));
}

#[test]
fn an_lss_node_id_takes_effect_in_the_list_at_reset_communication() {
    let mut b: Sendix = Bench::new(sendix::od::Ram::new(0x3F), NoApplication, MemStorage::new(2048), 0x3F);
    b.at(ms(0));
    // Sendix: no RPDOs, its TPDOs forbid RTR, TIME is not consumed.
    assert_eq!(list(&b), [(0x000, false), (0x080, false), (0x63F, false), (0x73F, true), (0x7E5, false)]);
    let lss = 0x7E5;
    b.rx(ms(1), lss, &[0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    b.rx(ms(2), lss, &[0x11, 0x2A, 0, 0, 0, 0, 0, 0]);
    b.rx(ms(3), lss, &[0x04, 0x00, 0, 0, 0, 0, 0, 0]);
    assert!(list(&b).contains(&(0x63F, false)), "still 0x3F until reset communication");
    let g = generation(&b);
    b.rx(ms(4), 0x000, &[0x82, 0x3F]);
    assert_eq!(list(&b), [(0x000, false), (0x080, false), (0x62A, false), (0x72A, true), (0x7E5, false)]);
    assert_eq!(generation(&b), g.wrapping_add(1));
}

#[test]
fn an_unconfigured_node_lists_lss_only() {
    let mut b: Ec5000 = Bench::new(ec5000::od::Ram::new(0xFF), NoApplication, MemStorage::new(2048), 0xFF);
    b.at(ms(0));
    assert_eq!(list(&b), [(0x7E5, false)]);
}

// ---- Frames not on the list change nothing ------------------------------------------

/// xorshift64: reproducible without a dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

/// A frame that could matter: a random identifier, or one next to (or on)
/// a listed one, data or remote, with random bytes; NMT commands and
/// heartbeats are mostly well-formed ones, resets rare, so the node stays
/// configured most of the run.
fn random_frame(rng: &mut Rng, listed: &[(u16, bool)], node_id: u8) -> CanFrame {
    let id = match (rng.below(3), listed.len() as u64) {
        (0, _) | (_, 0) => rng.below(0x800) as u16,
        (_, n) => {
            let (base, _) = listed[rng.below(n) as usize];
            (base + rng.below(3) as u16).saturating_sub(1).min(0x7FF)
        }
    };
    if rng.below(4) == 0 {
        return CanFrame::remote(id, rng.below(9) as usize).expect("valid remote frame");
    }
    if id == 0 {
        // Start, stop, pre-operational; one in 20 may also reset.
        let choices = if rng.below(20) == 0 { 7 } else { 5 };
        let cs = [0x01, 0x02, 0x80, 0x01, 0x80, 0x81, 0x82][rng.below(choices) as usize];
        let target = if rng.below(2) == 0 { 0 } else { node_id };
        return CanFrame::standard(0, &[cs, target]).expect("valid frame");
    }
    if (0x701..=0x77F).contains(&id) && rng.below(4) != 0 {
        // Heartbeats (boot-up, Stopped, Operational, Pre-operational) arm and feed the consumers.
        let state = [0x00, 0x04, 0x05, 0x7F][rng.below(4) as usize];
        return CanFrame::standard(id, &[state]).expect("valid frame");
    }
    let len = rng.below(9) as usize;
    let data: Vec<u8> = (0..len).map(|_| rng.next() as u8).collect();
    CanFrame::standard(id, &data).expect("valid frame")
}

/// Two nodes configured alike; each random frame goes to both when it is
/// on the list, else to the first only. Their output must match after
/// every step, and their dictionaries, state and transmit counters too.
fn unlisted_frames_change_nothing<O, const R: usize, const T: usize, const HB: usize>(
    make: impl Fn() -> Bench<O, NoApplication, MemStorage, R, T, HB>,
    configure: impl Fn(&mut Bench<O, NoApplication, MemStorage, R, T, HB>),
    seed: u64,
) where
    O: ObjectDictionary,
{
    let (mut a, mut b) = (make(), make());
    for n in [&mut a, &mut b] {
        n.at(ms(0));
        configure(n);
    }
    let mut rng = Rng(seed);
    let (mut now, mut unlisted, mut listed) = (a.now, 0u32, 0u32);
    for step in 0..4000 {
        now += Duration::from_micros(rng.below(20_000));
        let frame = random_frame(&mut rng, &list(&a), a.node.node_id());
        let cob_id = frame.cob_id().expect("11-bit");
        let on_list = a.node.acceptance().accepts(cob_id, embedded_can::Frame::is_remote_frame(&frame));
        assert_eq!(a.node.acceptance(), b.node.acceptance(), "step {step}");
        a.node.on_frame(now, &frame);
        if on_list {
            b.node.on_frame(now, &frame);
            listed += 1;
        } else {
            unlisted += 1;
        }
        let out_a = a.run_until(now);
        assert_eq!(out_a, b.run_until(now), "step {step}: {frame:?} (on the list: {on_list})");
        assert_eq!(a.node.od().image(), b.node.od().image(), "step {step}: {frame:?}");
        assert_eq!(a.node.state(), b.node.state(), "step {step}: {frame:?}");
        assert_eq!(a.node.node_id(), b.node.node_id(), "step {step}: {frame:?}");
        assert_eq!(a.node.counters().tx, b.node.counters().tx, "step {step}: {frame:?}");
    }
    // Both kinds were exercised in earnest.
    assert!(unlisted > 1000 && listed > 400, "unlisted {unlisted}, listed {listed}");
    // And the future is the same: every timer of the two runs alike.
    assert_eq!(a.run_until(now + Duration::from_secs(2)), b.run_until(now + Duration::from_secs(2)));
}

/// Operational, heartbeat 100 ms, consuming node 0x20 and 0x7F, a second
/// SDO server, TPDO1 answering RTRs, RPDO1 and RPDO2 on.
fn configure_interop(b: &mut Interop) {
    for (index, sub, value) in [
        (0x1017, 0, 100u32),
        (0x1016, 1, 0x0020_0064),
        (0x1016, 4, 0x007F_00C8),
        (0x1201, 1, 0x0000_06A0),
        (0x1201, 2, 0x0000_06B0),
        (0x1800, 1, 0x0000_0185),
    ] {
        let len = if index == 0x1017 { 2 } else { 4 };
        assert_eq!(b.sdo_download(ID, index, sub, &value.to_le_bytes()[..len]), Ok(()), "{index:#06x} sub {sub}");
    }
    b.nmt(0x01, 0);
}

#[test]
fn unlisted_frames_change_nothing_in_the_interop_node() {
    for seed in [0x9E37_79B9_7F4A_7C15, 0x0123_4567_89AB_CDEF] {
        unlisted_frames_change_nothing(interop, configure_interop, seed);
    }
}

#[test]
fn unlisted_frames_change_nothing_in_the_ec5000() {
    let make = || -> Ec5000 { Bench::new(ec5000::od::Ram::new(ID), NoApplication, MemStorage::new(2048), ID) };
    let configure = |b: &mut Ec5000| {
        assert_eq!(b.sdo_download(ID, 0x1016, 1, &0x0030_0064u32.to_le_bytes()), Ok(()));
        b.nmt(0x01, 0);
    };
    unlisted_frames_change_nothing(make, configure, 0x5DEE_CE66_D1CE_4E5B);
}

// ---- Without the list (`Services::acceptance` off) ---------------------------------

common::with_services! {
    /// The interop dictionary linked without the acceptance list, as the
    /// `ds301` and `ds301-lean` size references are (their board receives
    /// every frame).
    NoList(Ram) { acceptance: false }
}

#[test]
fn without_the_service_the_list_is_incomplete_and_passes_every_frame() {
    let mut b: Bench<_, _, _, 4, 4, 4> = Bench::new(NoList(Ram::new(ID)), NoApplication, MemStorage::new(2048), ID);
    b.at(ms(0));
    let passes_all = |b: &Bench<NoList, NoApplication, MemStorage, 4, 4, 4>| {
        let list = b.node.acceptance();
        assert!(!list.is_complete());
        assert_eq!(list.ids(), [], "nothing listed");
        assert_eq!(list.generation(), 0, "never rebuilt");
        assert!((0..0x800).all(|id| list.accepts(id, false) && list.accepts(id, true)), "every 11-bit frame passes");
    };
    passes_all(&b);
    // What moves the list of a node with the service moves nothing here, and the node still serves.
    assert_eq!(b.sdo_download(ID, 0x1400, 1, &0x8000_0205u32.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1016, 1, &0x0020_0064u32.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_upload(ID, 0x1400, 1), Ok(0x8000_0205u32.to_le_bytes().to_vec()));
    b.nmt(0x82, ID);
    passes_all(&b);
}
