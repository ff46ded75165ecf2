//! The EC5000's timers run when due (D65): the node polls the roller at the
//! deadline it returned, after its hooks and after a fault is injected, not
//! at every `process`. What the bus sees does not change: the same frames
//! at the same times and the same monitoring values as the roller polled at
//! every `process`, and the monitoring keeps its 100 ms period whatever
//! the traffic.

mod common;

use canopen_core::axis::Injected;
use canopen_core::node::Application;
use canopen_core::od::ObjectDictionary;
use canopen_core::time::Instant;
use common::ec5000::{EMCY, ID, RPDO1, RPDO3, TPDO1, TPDO2, TPDO3};
use common::{Bench, F, ms};
use firmware::devices::ec5000;
use hal_host::storage::MemStorage;

/// The EC5000's application polled at every `process`, as before D65: every
/// hook forwarded, `POLL_WHEN_DUE` left at its default.
struct EveryProcess(ec5000::App);

common::ec5000::ec5000_forwarding!(EveryProcess {
    fn rpdo_written(&mut self, ctx: &mut canopen_core::node::Ctx<'_>, n: u8) {
        self.0.rpdo_written(ctx, n)
    }
});

type Roller<A> = Bench<ec5000::od::Ram, A, MemStorage, 4, 4, 1>;

fn roller<A: Application>(app: A) -> Roller<A> {
    Bench::new(ec5000::od::Ram::new(ID), app, MemStorage::new(4096), ID)
}

/// What the monitoring and the profile show: 0x2200 sub 1..9, 0x2211 sub
/// 1..3, 0x1001, 0x6041, 0x6064, 0x606C, 0x1003 sub 0.
fn shown<A: Application>(b: &Roller<A>) -> Vec<Vec<u8>> {
    let od = b.node.od();
    let objects = (1..=9).map(|sub| (0x2200, sub)).chain((1..=3).map(|sub| (0x2211, sub))).chain([
        (0x1001, 0),
        (0x6041, 0),
        (0x6064, 0),
        (0x606C, 0),
        (0x1003, 0),
    ]);
    objects.map(|(index, sub)| od.dictionary().read(od.image(), index, sub).map(<[u8]>::to_vec).unwrap_or_default()).collect()
}

/// One step of the scenario: a frame, a fault injected or removed, or nothing (a `process`).
enum Step {
    Frame(u16, &'static [u8]),
    Inject(Injected),
    Remove(Injected),
    Process,
}

/// `step` on the roller at `t` µs; the frames it sends.
fn apply<A: Application>(b: &mut Roller<A>, t: u64, step: &Step, axis: impl Fn(&mut A) -> &mut canopen_core::axis::Axis) -> Vec<F> {
    let now = Instant::from_micros(t);
    match step {
        Step::Frame(id, data) => b.rx(now, *id, data),
        Step::Inject(f) => {
            axis(b.node.app_mut()).inject(*f);
            b.at(now)
        }
        Step::Remove(f) => {
            axis(b.node.app_mut()).remove(*f);
            b.at(now)
        }
        Step::Process => b.at(now),
    }
}

/// The scenario [µs, step]: start, enable, a pv move, a low warning level
/// by SDO (EMCY 0xFFA8), an over-temperature fault injected and reset, a
/// quick stop, a blocked roller, SYNCs; frames also between the profile's
/// 1 ms ticks.
fn scenario() -> Vec<(u64, Step)> {
    let mut steps = vec![
        (10_000, Step::Frame(0x000, &[0x01, ID])),
        (100_000, Step::Frame(RPDO1, &[0x06, 0, 3, 0, 0, 0, 0])),
        (300_000, Step::Frame(RPDO1, &[0x07, 0, 3, 0, 0, 0, 0])),
        (500_000, Step::Frame(RPDO1, &[0x0F, 0, 3, 0, 0, 0, 0])),
        (600_500, Step::Frame(RPDO3, &[0x0F, 0, 100, 0, 0, 0])),
        // 0x4231 sub 1 = 25 °C: the warning at once (the roller is at 25 °C).
        (900_000, Step::Frame(0x600 + u16::from(ID), &[0x2B, 0x31, 0x42, 1, 25, 0, 0, 0])),
        (1_100_300, Step::Frame(0x600 + u16::from(ID), &[0x2B, 0x31, 0x42, 1, 95, 0, 0, 0])),
        (1_200_300, Step::Inject(Injected::OverTemperature)),
        (1_500_000, Step::Remove(Injected::OverTemperature)),
        (1_600_000, Step::Frame(RPDO1, &[0x80, 0, 3, 0, 0, 0, 0])),
        (1_700_000, Step::Frame(RPDO1, &[0x06, 0, 3, 0, 0, 0, 0])),
        (1_800_000, Step::Frame(RPDO1, &[0x0F, 0, 3, 0, 0, 0, 0])),
        (1_850_200, Step::Frame(RPDO3, &[0x0F, 0, 0x9C, 0xFF, 0xFF, 0xFF])),
        (2_000_700, Step::Frame(RPDO3, &[0x0B, 0, 0x9C, 0xFF, 0xFF, 0xFF])),
        (2_300_000, Step::Frame(RPDO3, &[0x06, 0, 0, 0, 0, 0])),
        (2_400_000, Step::Frame(RPDO3, &[0x0F, 0, 50, 0, 0, 0])),
        (2_500_400, Step::Inject(Injected::Blocked)),
    ];
    // A SYNC every 50 ms (TPDO3), half a tick after the profile's.
    steps.extend((0..70u64).map(|i| (600_000 + 500 + i * 50_000, Step::Frame(0x080, &[]))));
    // And a `process` every millisecond.
    steps.extend((0..=4000u64).map(|i| (i * 1000, Step::Process)));
    steps.sort_by_key(|(t, _)| *t);
    steps
}

#[test]
fn polled_when_due_the_bus_sees_what_it_saw_when_polled_at_every_process() {
    let mut due = roller(ec5000::App::NEW);
    let mut every = roller(EveryProcess(ec5000::App::NEW));
    let (mut sent, mut checked) = (0, 0);
    for (t, step) in scenario() {
        let a = apply(&mut due, t, &step, |app| &mut app.drive.drive.axis);
        let b = apply(&mut every, t, &step, |app| &mut app.0.drive.drive.axis);
        assert_eq!(a, b, "frames at {t} µs");
        assert_eq!(shown(&due), shown(&every), "values at {t} µs");
        sent += a.len();
        checked += 1;
    }
    // The scenario reaches what it is about: TPDOs, warnings and faults on the bus.
    let (mut emcy, mut tpdos) = (0, 0);
    let mut b = roller(ec5000::App::NEW);
    for (t, step) in scenario() {
        for (id, _) in apply(&mut b, t, &step, |app| &mut app.drive.drive.axis) {
            emcy += usize::from(id == EMCY);
            tpdos += usize::from([TPDO1, TPDO2, TPDO3].contains(&id));
        }
    }
    assert!(sent > 100 && checked > 4000 && emcy >= 6 && tpdos > 100, "{sent} frames, {emcy} EMCY, {tpdos} TPDOs");
}

/// 0x2200 sub 3 (uptime [s]) of the roller.
fn uptime<A: Application>(b: &Roller<A>) -> u32 {
    let od = b.node.od();
    let v = od.dictionary().read(od.image(), 0x2200, 3).expect("0x2200 sub 3");
    u32::from_le_bytes(v.try_into().expect("4 bytes"))
}

#[test]
fn driven_at_its_deadlines_the_monitoring_runs_every_100_ms_whatever_the_rpdos() {
    // `process` only at the deadlines it returns and at each frame: RPDOs
    // every 30 ms leave the monitoring's period as it is (the uptime counted
    // at 1 s, 2 s, 3 s after its first run at power-on), where the idle
    // profile's deadline, moved by every frame, once decided when it ran.
    let mut b = roller(ec5000::App::NEW);
    b.at(ms(0));
    b.rx(ms(10), 0x000, &[0x01, ID]);
    let (mut changes, mut last, mut frame) = (Vec::new(), uptime(&b), 40);
    while b.now < ms(3200) {
        let due = b.node.process(b.now).filter(|d| *d > b.now).unwrap_or(ms(frame));
        if due < ms(frame) {
            b.at(due);
        } else {
            b.rx(ms(frame), RPDO3, &[if frame % 60 == 0 { 0x06 } else { 0x07 }, 0, 0, 0, 0, 0]);
            frame += 30;
        }
        if uptime(&b) != last {
            last = uptime(&b);
            changes.push((last, b.now.as_micros()));
        }
    }
    assert_eq!(changes, vec![(1, 1_000_000), (2, 2_000_000), (3, 3_000_000)]);
}
