//! The CiA 402 profile on dictionaries other than the EC5000's, through a
//! test application that runs it over any device's generated dictionary:
//! vl on the Agile's (0x6042-0x604A), option codes, software limits,
//! homing on a limit switch and the drive's following-error fault on the
//! b maXX 4400's. The devices' own manual-specific behaviour is not here.

mod common;

use canopen_core::abort::AbortCode;
use canopen_core::axis::{Axis, AxisParams, Injected};
use canopen_core::node::{Application, Ctx, NmtEvent, Source};
use canopen_core::od::ObjectDictionary;
use canopen_core::profiles::cia402::{Cia402, Config};
use canopen_core::time::Instant;
use common::{Bench, ms, ok_write};
use firmware::devices::{agile, bmaxx4400};
use hal_host::storage::MemStorage;

/// The profile alone on a device's dictionary.
struct Profile {
    drive: Cia402<Axis>,
    config: Config,
    axis: AxisParams,
}

impl Application for Profile {
    fn check_write(&mut self, _ctx: &Ctx<'_>, index: u16, _sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        self.drive.check_write(index, data)
    }
    fn written(&mut self, ctx: &mut Ctx<'_>, index: u16, _sub: u8, _by: Source) {
        self.drive.written(ctx, &self.config, index);
    }
    fn sample(&mut self, ctx: &mut Ctx<'_>) {
        self.drive.sample(ctx);
    }
    fn poll(&mut self, ctx: &mut Ctx<'_>) -> Option<Instant> {
        self.drive.poll(ctx, &self.config)
    }
    fn on_nmt(&mut self, ctx: &mut Ctx<'_>, event: NmtEvent) {
        if event == NmtEvent::ResetApplication {
            self.drive.drive.configure(self.axis);
        }
        self.drive.on_nmt(ctx, &self.config, event);
    }
}

const CONFIG: Config = Config {
    increments_per_rev: 4096,
    leaving_operational_aborts: false,
    position_window: 10,
    velocity_window: 10,
    homing_speeds: (0, 0),
    velocity_unit: None,
};

const AXIS: AxisParams = AxisParams {
    increments_per_rev: 4096,
    max_acceleration: 1_000_000,
    max_velocity: 200_000,
    position_gain: 50,
    friction_permille: 0,
    ambient_c: 25,
    rise_at_rated_c: 60,
    thermal_tau_s: 60,
    warning_c: 95,
    fault_c: 110,
    dc_link_mv: 48_000,
    following_limit: 5_000,
    limits: (-5_000, 5_000),
    home_switch: None,
};

fn boot<O: ObjectDictionary, const R: usize, const T: usize, const HB: usize>(
    od: O,
    id: u8,
    config: Config,
) -> Bench<O, Profile, MemStorage, R, T, HB> {
    let app = Profile { drive: Cia402::new(Axis::NEW), config, axis: AXIS };
    let mut b = Bench::new(od, app, MemStorage::new(8192), id);
    b.at(ms(0));
    b.now = ms(10);
    b.nmt(0x01, id);
    b
}

fn u16_of(v: Vec<u8>) -> u16 {
    u16::from_le_bytes([v[0], v[1]])
}

fn i16_of(v: Vec<u8>) -> i16 {
    i16::from_le_bytes([v[0], v[1]])
}

fn i32_of(v: Vec<u8>) -> i32 {
    i32::from_le_bytes([v[0], v[1], v[2], v[3]])
}

// ---- vl on the Agile's dictionary ------------------------------------------------------

type Agile = Bench<agile::od::Ram, Profile, MemStorage, 4, 4, 0>;

/// Enabled through RPDO1 (0x6040, 0x6042) at 100 ms steps; vl is the only mode.
fn agile_enabled() -> Agile {
    let mut b: Agile = boot(agile::od::Ram::new(1), 1, CONFIG);
    for (t, cw) in [(100, 0x06u8), (200, 0x07), (300, 0x0F)] {
        b.run_until(ms(t));
        b.rx(ms(t), 0x201, &[cw, 0, 0, 0]);
    }
    b.run_until(ms(400));
    assert_eq!(u16_of(b.sdo_upload(1, 0x6041, 0).unwrap()) & 0x6F, 0x27);
    b
}

#[test]
fn vl_ramps_with_delta_speed_over_delta_time_and_reports_min_1() {
    let mut b = agile_enabled();
    assert_eq!(b.sdo_upload(1, 0x6061, 0), Ok(vec![2]), "vl shown though 0x6060 is write-only");
    // 0x6048: 1500 min⁻¹ per 1 s; 0x6049: 3000 min⁻¹ per 1 s.
    assert_eq!(b.sdo_write(1, 0x6048, 1, &1500u32.to_le_bytes()), ok_write(0x6048, 1));
    assert_eq!(b.sdo_write(1, 0x6049, 1, &3000u32.to_le_bytes()), ok_write(0x6049, 1));
    b.rx(ms(400), 0x201, &[0x0F, 0, 0xDC, 0x05]); // 1500 min⁻¹
    b.run_until(ms(900));
    assert_eq!(i16_of(b.sdo_upload(1, 0x6043, 0).unwrap()), 750, "vl velocity demand after 0.5 s");
    b.run_until(ms(1500));
    assert_eq!(i16_of(b.sdo_upload(1, 0x6044, 0).unwrap()), 1500, "vl velocity actual value");
    b.rx(ms(1500), 0x201, &[0x0F, 0, 0, 0]);
    b.run_until(ms(1750));
    assert_eq!(i16_of(b.sdo_upload(1, 0x6043, 0).unwrap()), 750, "slower at 3000 min⁻¹/s");
}

#[test]
fn vl_min_and_max_amount_limit_the_target_with_bit_11() {
    let mut b = agile_enabled();
    assert_eq!(b.sdo_write(1, 0x6046, 1, &100u32.to_le_bytes()), ok_write(0x6046, 1));
    assert_eq!(b.sdo_write(1, 0x6046, 2, &1000u32.to_le_bytes()), ok_write(0x6046, 2));
    assert_eq!(b.sdo_write(1, 0x6048, 1, &30000u32.to_le_bytes()), ok_write(0x6048, 1));
    assert_eq!(b.sdo_write(1, 0x6049, 1, &30000u32.to_le_bytes()), ok_write(0x6049, 1));
    b.rx(ms(400), 0x201, &[0x0F, 0, 0xCE, 0xFF]); // −50 → −100
    b.run_until(ms(600));
    assert_eq!(i16_of(b.sdo_upload(1, 0x6043, 0).unwrap()), -100);
    assert_eq!(u16_of(b.sdo_upload(1, 0x6041, 0).unwrap()) & 0x0800, 0x0800, "internal limit");
    b.rx(ms(600), 0x201, &[0x0F, 0, 0xDC, 0x05]); // 1500 → 1000
    b.run_until(ms(900));
    assert_eq!(i16_of(b.sdo_upload(1, 0x6043, 0).unwrap()), 1000);
    b.rx(ms(900), 0x201, &[0x0F, 0, 0xF4, 0x01]); // 500: in range
    assert_eq!(u16_of(b.sdo_upload(1, 0x6041, 0).unwrap()) & 0x0800, 0);
}

// ---- the b maXX 4400's dictionary -----------------------------------------------------

type Bmaxx = Bench<bmaxx4400::od::Ram, Profile, MemStorage, 4, 4, 0>;

/// One increment per user unit (feed 0x6092 = 65536 per revolution, 65536 inc/rev).
const BMAXX: Config = Config { increments_per_rev: 65_536, ..CONFIG };

fn bmaxx_enabled(mode: u8) -> Bmaxx {
    let mut b: Bmaxx = boot(bmaxx4400::od::Ram::new(2), 2, BMAXX);
    for (index, value) in [(0x6081u16, 20_000u32), (0x6083, 100_000), (0x6084, 100_000), (0x6085, 400_000)] {
        assert_eq!(b.sdo_write(2, index, 0, &value.to_le_bytes()), ok_write(index, 0));
    }
    // RPDO2: 0x6040 + 0x6060.
    for (t, cw) in [(100, 0x06u8), (200, 0x07), (300, 0x0F)] {
        b.run_until(ms(t));
        b.rx(ms(t), 0x302, &[cw, 0, mode]);
    }
    b.run_until(ms(400));
    assert_eq!(statusword(&mut b) & 0x6F, 0x27);
    b
}

fn statusword(b: &mut Bmaxx) -> u16 {
    u16_of(b.sdo_upload(2, 0x6041, 0).unwrap())
}

/// RPDO3: 0x6040 + 0x607A.
fn set_point(b: &mut Bmaxx, t: u64, cw: u16, target: i32) {
    b.run_until(ms(t));
    let [x, y] = cw.to_le_bytes();
    let [p, q, r, s] = target.to_le_bytes();
    b.rx(ms(t), 0x402, &[x, y, p, q, r, s]);
}

#[test]
fn modes_follow_the_dictionary_when_0x6502_is_missing() {
    let mut b = bmaxx_enabled(1);
    assert_eq!(b.sdo_upload(2, 0x6061, 0), Ok(vec![1]));
    for mode in [2u8, 3, 6, 1] {
        b.rx(ms(400), 0x302, &[0x0F, 0, mode]);
        assert_eq!(b.sdo_upload(2, 0x6061, 0), Ok(vec![mode]));
    }
    // Torque (4) has no 0x6071 in this dictionary: refused, the mode stays.
    assert_eq!(b.sdo_write(2, 0x6060, 0, &[4]), common::abort(0x6060, 0, 0x0609_0030));
    assert_eq!(b.sdo_upload(2, 0x6061, 0), Ok(vec![1]));
}

#[test]
fn software_position_limits_clip_the_target_with_bit_11() {
    let mut b = bmaxx_enabled(1);
    assert_eq!(b.sdo_write(2, 0x607D, 1, &(-1000i32).to_le_bytes()), ok_write(0x607D, 1));
    assert_eq!(b.sdo_write(2, 0x607D, 2, &1000i32.to_le_bytes()), ok_write(0x607D, 2));
    set_point(&mut b, 400, 0x1F, 4000);
    assert_eq!(statusword(&mut b) & 0x1800, 0x1800, "acknowledged, internal limit");
    set_point(&mut b, 410, 0x0F, 4000);
    b.run_until(ms(1000));
    assert_eq!(i32_of(b.sdo_upload(2, 0x6064, 0).unwrap()), 1000);
}

#[test]
fn quick_stop_option_6_holds_in_quick_stop_active_and_transition_16_returns() {
    let mut b = bmaxx_enabled(3);
    assert_eq!(b.sdo_write(2, 0x605A, 0, &6i16.to_le_bytes()), ok_write(0x605A, 0));
    // RPDO4: 0x6040 + 0x60FF, 20,000 inc/s.
    b.rx(ms(400), 0x502, &[0x0F, 0, 0x20, 0x4E, 0, 0]);
    b.run_until(ms(700));
    b.rx(ms(700), 0x502, &[0x0B, 0, 0x20, 0x4E, 0, 0]);
    // Quick stop ramp 0x6085 = 400,000 inc/s²: 50 ms from 20,000 inc/s.
    b.run_until(ms(725));
    let v = i32_of(b.sdo_upload(2, 0x606B, 0).unwrap());
    assert!((9_500..=10_500).contains(&v), "{v}");
    b.run_until(ms(800));
    assert_eq!(statusword(&mut b) & 0x6F | 0x0400, 0x0407, "holds in Quick stop active, standing");
    b.rx(ms(800), 0x502, &[0x0F, 0, 0x20, 0x4E, 0, 0]);
    assert_eq!(statusword(&mut b) & 0x6F, 0x27, "16: Operation enabled");
}

#[test]
fn shutdown_option_1_brakes_on_the_slow_down_ramp_before_transition_8() {
    let mut b = bmaxx_enabled(3);
    assert_eq!(b.sdo_write(2, 0x605B, 0, &1i16.to_le_bytes()), ok_write(0x605B, 0));
    b.rx(ms(400), 0x502, &[0x0F, 0, 0x20, 0x4E, 0, 0]);
    b.run_until(ms(700));
    b.rx(ms(700), 0x502, &[0x06, 0, 0x20, 0x4E, 0, 0]);
    // 0x6084 = 100,000 inc/s²: 200 ms to stop, Operation enabled until then.
    b.run_until(ms(850));
    assert_eq!(statusword(&mut b) & 0x6F, 0x27);
    // The demand stands at 900 ms; the state changes once the axis has
    // followed it to a standstill (0x606C = 0), within 0.1 s.
    b.run_until(ms(900));
    assert_eq!(statusword(&mut b) & 0x6F, 0x27);
    b.run_until(ms(1050));
    assert_eq!(statusword(&mut b) & 0x6F, 0x21, "8 once stopped: Ready to switch on");
    assert_eq!(i32_of(b.sdo_upload(2, 0x606C, 0).unwrap()), 0);
}

#[test]
fn homing_17_on_the_negative_limit_switch_sets_the_home_offset() {
    let mut b = bmaxx_enabled(6);
    for (index, sub, value) in
        [(0x6098u16, 0u8, vec![17u8]), (0x6099, 1, 20_000u32.to_le_bytes().to_vec()), (0x6099, 2, 2_000u32.to_le_bytes().to_vec())]
    {
        assert_eq!(b.sdo_write(2, index, sub, &value), ok_write(index, sub));
    }
    assert_eq!(b.sdo_write(2, 0x609A, 0, &200_000u32.to_le_bytes()), ok_write(0x609A, 0));
    assert_eq!(b.sdo_write(2, 0x607C, 0, &100i32.to_le_bytes()), ok_write(0x607C, 0));
    b.rx(ms(400), 0x302, &[0x1F, 0, 6]);
    b.run_until(ms(500));
    assert_eq!(statusword(&mut b) & 0x3400, 0, "homing in progress");
    assert!(i32_of(b.sdo_upload(2, 0x606C, 0).unwrap()) < 0, "searching the negative limit switch");
    b.run_until(ms(1500));
    assert_eq!(statusword(&mut b) & 0x3400, 0x1400, "homing attained");
    // Home is where the switch (at −5000 inc) released: the home offset, 100.
    let at = i32_of(b.sdo_upload(2, 0x6064, 0).unwrap());
    assert!((99..=102).contains(&at), "{at}");
}

#[test]
fn unsupported_homing_methods_are_refused_and_the_default_0_reports_homing_error() {
    let mut b = bmaxx_enabled(6);
    assert_eq!(b.sdo_write(2, 0x6098, 0, &[1]), common::abort(0x6098, 0, 0x0609_0030), "index pulse: not in the model");
    // 0x6098 = 0 (the dictionary's default): no homing method.
    b.rx(ms(400), 0x302, &[0x1F, 0, 6]);
    b.run_until(ms(420));
    assert_eq!(statusword(&mut b) & 0x3400, 0x2400, "error, velocity is zero");
    assert_eq!(b.node.app().drive.state(), canopen_core::profiles::cia402::fsa::PdsState::OperationEnabled);
}

#[test]
fn a_blocked_axis_faults_with_following_error_0x8611() {
    let mut b = bmaxx_enabled(1);
    b.node.app_mut().drive.drive.inject(Injected::Blocked);
    set_point(&mut b, 400, 0x1F, 50_000);
    let out = b.run_until(ms(1200));
    assert!(out.iter().any(|(_, f)| *f == (0x082, vec![0x11, 0x86, 0x11, 0, 0, 0, 0, 0])), "EMCY 0x8611: {out:x?}");
    // 0x605E = 0 (the dictionary's default): the drive function goes off at once.
    assert_eq!(statusword(&mut b) & 0x4F, 0x08, "Fault");
}
