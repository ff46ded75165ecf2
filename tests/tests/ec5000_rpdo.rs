//! The EC5000's RPDO hook (its fixed mappings kept at each RPDO's first
//! frame, the controlword straight to the profile) does what the default
//! `rpdo_written` does, which asks the node for every mapped object and
//! offers each to `rpdo_value`, then to `written`: the same frames at the
//! same times and the same values, whatever the RPDOs carry (a controlword
//! repeated, only the target velocity changed, a mode change with a
//! set-point bit, a fault reset), in every mode the roller runs.

mod common;

use canopen_core::node::Application;
use canopen_core::od::ObjectDictionary;
use canopen_core::time::Instant;
use common::ec5000::{ID, RPDO1, RPDO2, RPDO3, TPDO1, TPDO2, TPDO3};
use common::{Bench, F, ms};
use firmware::devices::ec5000;
use hal_host::storage::MemStorage;

/// The EC5000's application with the default `rpdo_written`: every other
/// hook forwarded.
struct Asked(ec5000::App);

common::ec5000::ec5000_forwarding!(Asked {
    const POLL_WHEN_DUE: bool = ec5000::App::POLL_WHEN_DUE;
    fn rpdo_value(&mut self, ctx: &mut canopen_core::node::Ctx<'_>, at: canopen_core::od::EntryRef, value: u32, len: u8) -> bool {
        self.0.rpdo_value(ctx, at, value, len)
    }
});

type Roller<A> = Bench<ec5000::od::Ram, A, MemStorage, 4, 4, 1>;

fn roller<A: Application>(app: A) -> Roller<A> {
    Bench::new(ec5000::od::Ram::new(ID), app, MemStorage::new(4096), ID)
}

/// What the RPDOs write and the profile shows: 0x6040, 0x6041, 0x6060,
/// 0x6061, 0x6064, 0x606C, 0x607A, 0x6081, 0x60FF, 0x603F, 0x1001.
fn shown<A: Application>(b: &Roller<A>) -> Vec<Vec<u8>> {
    let od = b.node.od();
    [0x6040, 0x6041, 0x6060, 0x6061, 0x6064, 0x606C, 0x607A, 0x6081, 0x60FF, 0x603F, 0x1001]
        .into_iter()
        .map(|index| od.dictionary().read(od.image(), index, 0).map(<[u8]>::to_vec).unwrap_or_default())
        .collect()
}

/// xorshift64: the same steps at every run.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    fn pick<T: Copy>(&mut self, from: &[T]) -> T {
        from[(self.next() % from.len() as u64) as usize]
    }
}

/// A frame at a time [µs]: the start, then `n` random RPDOs with the
/// controlwords that move the state machine (shutdown, switch on, enable,
/// quick stop, disable voltage, fault reset, halt, new set-point), modes 0
/// (no change), pp, pv and homing, small and large set-points, each RPDO
/// repeated as it was now and then; SYNCs between them.
fn scenario(seed: u64, n: usize) -> Vec<(u64, u16, Vec<u8>)> {
    // The enabling commands more often than the others, so that every state is reached.
    const CONTROLWORDS: [u16; 16] = [0x06, 0x06, 0x07, 0x07, 0x0F, 0x0F, 0x0F, 0x0F, 0x1F, 0x3F, 0x5F, 0x0B, 0x02, 0x00, 0x80, 0x10F];
    let mut rng = Rng(seed);
    let mut steps = vec![(10_000, 0x000, vec![0x01, ID])];
    let mut t = 20_000;
    let mut last: Option<(u16, Vec<u8>)> = None;
    for _ in 0..n {
        t += 200 + rng.next() % 40_000;
        let frame = match (rng.next() % 8, &last) {
            (0, Some(repeat)) => repeat.clone(),
            (1, _) => (0x080, vec![]),
            (k, _) => {
                let [c0, c1] = rng.pick(&CONTROLWORDS).to_le_bytes();
                let value = rng.pick(&[0i32, 1, 50, -50, 437, -10_000, 100_000, i32::MAX]).to_le_bytes();
                match k % 3 {
                    0 => (RPDO1, [&[c0, c1, rng.pick(&[0u8, 1, 3, 6, 3, 3])][..], &value].concat()),
                    1 => (RPDO2, [&[c0, c1][..], &value].concat()),
                    _ => (RPDO3, [&[c0, c1][..], &value].concat()),
                }
            }
        };
        if frame.0 != 0x080 {
            last = Some(frame.clone());
        }
        steps.push((t, frame.0, frame.1));
    }
    steps
}

/// Both rollers through `steps`, with a `process` every millisecond
/// between them: the same frames and values after each. Returns the
/// RPDOs, the TPDOs, and the states and speeds shown (statusword bits 0-6
/// and 0x606C ≠ 0 seen).
fn same_on_the_bus(steps: &[(u64, u16, Vec<u8>)]) -> (usize, usize, Vec<u8>, bool) {
    let mut fixed = roller(ec5000::App::NEW);
    let mut asked = roller(Asked(ec5000::App::NEW));
    assert_eq!(fixed.at(ms(0)), asked.at(ms(0)), "boot-up");
    let (mut tpdos, mut rpdos, mut now, mut states, mut moved) = (0, 0, 0, Vec::new(), false);
    let mut seen = |frames: &[F], values: Vec<Vec<u8>>| {
        tpdos += frames.iter().filter(|(id, _)| [TPDO1, TPDO2, TPDO3].contains(id)).count();
        let state = values[1][0] & 0x6F;
        if !states.contains(&state) {
            states.push(state);
        }
        moved |= values[5] != [0; 4];
    };
    for (t, id, data) in steps {
        while now + 1000 < *t {
            now += 1000;
            let a = fixed.at(Instant::from_micros(now));
            assert_eq!(a, asked.at(Instant::from_micros(now)), "frames at {now} µs");
            seen(&a, shown(&fixed));
        }
        let a: Vec<F> = fixed.rx(Instant::from_micros(*t), *id, data);
        let b: Vec<F> = asked.rx(Instant::from_micros(*t), *id, data);
        assert_eq!(a, b, "frames after {id:03X} {data:02X?} at {t} µs");
        assert_eq!(shown(&fixed), shown(&asked), "values after {id:03X} {data:02X?} at {t} µs");
        seen(&a, shown(&fixed));
        rpdos += usize::from([RPDO1, RPDO2, RPDO3].contains(id));
        now = *t;
    }
    states.sort_unstable();
    (rpdos, tpdos, states, moved)
}

#[test]
fn random_rpdos_reach_the_profile_as_through_the_default_rpdo_hook() {
    for seed in [1, 0x5EED, 0xC0FFEE, 402] {
        let (rpdos, tpdos, states, moved) = same_on_the_bus(&scenario(seed, 300));
        assert!(rpdos > 200 && tpdos > 100 && moved, "seed {seed}: {rpdos} RPDOs, {tpdos} TPDOs, moved {moved}");
        // Switch on disabled, Ready to switch on, Switched on, Operation enabled, Quick stop active.
        for state in [0x40, 0x21, 0x23, 0x27, 0x07] {
            assert!(states.contains(&state), "seed {seed}: state {state:02X} not reached ({states:02X?})");
        }
    }
}

#[test]
fn an_rpdo_repeated_unchanged_and_one_changing_only_the_target_velocity_act_as_through_the_default_hook() {
    let pv = |cw: u8, v: i32| [&[cw, 0][..], &v.to_le_bytes()].concat();
    let steps = vec![
        (10_000, 0x000, vec![0x01, ID]),
        (100_000, RPDO1, vec![0x06, 0, 3, 0, 0, 0, 0]),
        (200_000, RPDO3, pv(0x06, 0)),
        // The same frame again: nothing the RPDO maps changes.
        (250_000, RPDO3, pv(0x06, 0)),
        (300_000, RPDO3, pv(0x07, 0)),
        (400_000, RPDO3, pv(0x0F, 0)),
        // Only the target velocity changes, the controlword stays.
        (500_000, RPDO3, pv(0x0F, 200)),
        (600_000, RPDO3, pv(0x0F, 200)),
        (700_000, RPDO3, pv(0x0F, -120)),
        (900_000, RPDO3, pv(0x0F, -120)),
        (1_000_000, RPDO3, pv(0x07, -120)),
    ];
    same_on_the_bus(&steps);
    // And the roller does move: 0x606C follows the last target before the switch-off.
    let mut b = roller(ec5000::App::NEW);
    b.at(ms(0));
    for (t, id, data) in &steps[..9] {
        b.rx(Instant::from_micros(*t), *id, data);
    }
    b.run_until(ms(990));
    let v = b.node.od().dictionary().read(b.node.od().image(), 0x606C, 0).expect("0x606C").to_vec();
    assert_eq!(i32::from_le_bytes(v.try_into().expect("4 bytes")), -120, "velocity actual value [mm/s]");
}
