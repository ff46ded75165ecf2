//! CiA 402 motion on the EC5000 with the axis model, in virtual time:
//! position, velocity and statusword as the master reads them (mm, mm/s;
//! gear 18:1, feed 157 mm).

mod common;

use canopen_core::axis::Injected;
use common::{Bench, ms, ok_write};
use firmware::devices::ec5000;
use hal_host::storage::MemStorage;

const ID: u8 = 5;
const RPDO1: u16 = 0x205; // 0x6040, 0x6060, 0x6081
const RPDO2: u16 = 0x305; // 0x6040, 0x607A
const RPDO3: u16 = 0x405; // 0x6040, 0x60FF

type Ec5000 = Bench<ec5000::od::Ram, ec5000::App, MemStorage, 4, 4, 1>;

fn i32_of(v: &[u8]) -> i32 {
    i32::from_le_bytes([v[0], v[1], v[2], v[3]])
}

struct Drive {
    b: Ec5000,
}

impl Drive {
    /// Operational, ramps 0x6083 = 500 mm/s², 0x6084 = 1000 mm/s², enabled
    /// in `mode` with profile velocity 200 mm/s at t = 1 s.
    fn enabled(mode: u8) -> Drive {
        let mut b = Bench::new(ec5000::od::Ram::new(ID), ec5000::App::NEW, MemStorage::new(4096), ID);
        b.at(ms(0));
        b.now = ms(10);
        b.nmt(0x01, ID);
        assert_eq!(b.sdo_write(ID, 0x6083, 0, &500u32.to_le_bytes()), ok_write(0x6083, 0));
        assert_eq!(b.sdo_write(ID, 0x6084, 0, &1000u32.to_le_bytes()), ok_write(0x6084, 0));
        let mut d = Drive { b };
        for (t, cw) in [(200, 0x06u8), (400, 0x07), (600, 0x0F)] {
            d.b.run_until(ms(t));
            d.b.rx(ms(t), RPDO1, &[cw, 0, mode, 200, 0, 0, 0]);
        }
        d.b.run_until(ms(1000));
        assert_eq!(d.statusword() & 0x6F, 0x27, "Operation enabled");
        d
    }

    fn at(&mut self, t: u64) {
        self.b.run_until(ms(t));
    }

    fn read_i32(&mut self, index: u16) -> i32 {
        i32_of(&self.b.sdo_upload(ID, index, 0).expect("readable"))
    }

    fn position(&mut self) -> i32 {
        self.read_i32(0x6064)
    }

    fn velocity(&mut self) -> i32 {
        self.read_i32(0x606C)
    }

    fn demand_velocity(&mut self) -> i32 {
        self.read_i32(0x606B)
    }

    fn statusword(&mut self) -> u16 {
        let v = self.b.sdo_upload(ID, 0x6041, 0).expect("0x6041");
        u16::from_le_bytes([v[0], v[1]])
    }

    fn velocity_command(&mut self, t: u64, cw: u16, v: i32) {
        self.b.run_until(ms(t));
        let [a, b] = cw.to_le_bytes();
        let [c, d, e, f] = v.to_le_bytes();
        self.b.rx(ms(t), RPDO3, &[a, b, c, d, e, f]);
    }

    fn set_point(&mut self, t: u64, cw: u16, target: i32) {
        self.b.run_until(ms(t));
        let [a, b] = cw.to_le_bytes();
        let [c, d, e, f] = target.to_le_bytes();
        self.b.rx(ms(t), RPDO2, &[a, b, c, d, e, f]);
    }
}

#[test]
fn pv_ramps_up_with_0x6083_and_down_with_0x6084() {
    let mut d = Drive::enabled(3);
    d.velocity_command(1000, 0x0F, 100);
    d.at(1100);
    assert_eq!(d.demand_velocity(), 50, "500 mm/s² for 100 ms");
    assert_eq!(d.statusword() & 0x1400, 0, "neither target reached nor speed zero");
    d.at(1400);
    assert_eq!((d.demand_velocity(), d.velocity()), (100, 100));
    assert_eq!(d.statusword() & 0x1400, 0x0400, "target reached");
    d.velocity_command(1400, 0x0F, 0);
    d.at(1450);
    assert_eq!(d.demand_velocity(), 50, "1000 mm/s² for 50 ms");
    d.at(1700);
    assert_eq!(d.velocity(), 0);
    assert_eq!(d.statusword() & 0x1400, 0x1400, "target reached, speed zero");
    // 0.2 s up (10 mm), 0.2 s at 100 mm/s (20 mm), 0.1 s down (5 mm): 35 mm.
    assert!((34..=36).contains(&d.position()), "{}", d.position());
}

#[test]
fn pv_halt_stops_and_release_resumes() {
    let mut d = Drive::enabled(3);
    d.velocity_command(1000, 0x0F, 100);
    d.velocity_command(1400, 0x010F, 100);
    d.at(1550);
    assert_eq!(d.velocity(), 0, "halt: slow down ramp 1000 mm/s²");
    assert_eq!(d.statusword() & 0x0400, 0x0400, "halted and standing: target reached");
    d.velocity_command(1550, 0x0F, 100);
    d.at(1900);
    assert_eq!(d.velocity(), 100);
}

#[test]
fn quick_stop_brakes_with_the_quick_stop_deceleration_then_switch_on_disabled() {
    let mut d = Drive::enabled(3);
    // 0x6085 is not in the EC5000 dictionary: the quick stop ramp is the
    // drive's limit, 1,024,000 inc/s² = 2180.6 mm/s² (D42).
    d.velocity_command(1000, 0x0F, 200);
    d.at(1500);
    assert_eq!(d.velocity(), 200);
    d.velocity_command(1500, 0x0B, 200);
    assert_eq!(d.statusword() & 0x6F, 0x07, "Quick stop active");
    d.at(1550);
    // 200 − 2180.6 × 0.05 = 91 mm/s
    assert!((89..=93).contains(&d.demand_velocity()), "{}", d.demand_velocity());
    d.at(1700);
    assert_eq!(d.velocity(), 0);
    assert_eq!(d.statusword() & 0x4F, 0x40, "transition 12 once stopped: Switch on disabled");
}

#[test]
fn pp_absolute_then_relative_with_the_set_point_handshake() {
    let mut d = Drive::enabled(1);
    d.set_point(1000, 0x1F, 100);
    assert_eq!(d.statusword() & 0x1400, 0x1000, "set-point acknowledge, not reached");
    d.set_point(1010, 0x0F, 100);
    assert_eq!(d.statusword() & 0x1000, 0, "acknowledge follows bit 4 down");
    d.at(2500);
    assert_eq!(d.position(), 100);
    assert_eq!(d.statusword() & 0x0400, 0x0400, "target reached");
    // Relative (bit 6): 50 mm beyond the last target.
    d.set_point(2500, 0x5F, 50);
    d.set_point(2510, 0x4F, 50);
    d.at(3000);
    assert_eq!(d.statusword() & 0x0400, 0, "moving");
    d.at(4000);
    assert_eq!(d.position(), 150);
    assert_eq!(d.statusword() & 0x0400, 0x0400);
}

#[test]
fn pp_change_immediately_takes_the_new_target_at_once() {
    let mut d = Drive::enabled(1);
    d.set_point(1000, 0x1F, 1000);
    d.set_point(1010, 0x0F, 1000);
    d.at(1500);
    assert!(d.velocity() > 0);
    // Bit 5: go to −20 now; the axis brakes and reverses.
    d.set_point(1500, 0x3F, -20);
    d.set_point(1510, 0x2F, -20);
    d.at(4000);
    assert_eq!(d.position(), -20);
    assert_eq!(d.statusword() & 0x0400, 0x0400);
}

#[test]
fn pp_buffered_set_point_stops_at_the_first_target_without_bit_9() {
    let mut d = Drive::enabled(1);
    d.set_point(1000, 0x1F, 60);
    d.set_point(1010, 0x0F, 60);
    // The second set-point waits in the buffer.
    d.set_point(1100, 0x1F, 120);
    assert_eq!(d.statusword() & 0x1000, 0x1000);
    d.set_point(1110, 0x0F, 120);
    assert_eq!(d.statusword() & 0x1000, 0x1000, "buffer full: acknowledge stays");
    let mut slowest_near_60 = i32::MAX;
    for t in (1120..4000).step_by(5) {
        d.at(t);
        if (55..=65).contains(&d.read_i32(0x6062)) {
            slowest_near_60 = slowest_near_60.min(d.demand_velocity());
        }
    }
    assert!(slowest_near_60 <= 3, "the trajectory stops at the first target: {slowest_near_60} mm/s");
    assert_eq!(d.position(), 120);
    assert_eq!(d.statusword() & 0x1400, 0x0400, "done, acknowledge cleared");
}

#[test]
fn pp_change_of_set_point_bit_9_passes_the_first_target_without_stopping() {
    let mut d = Drive::enabled(1);
    d.set_point(1000, 0x1F, 60);
    d.set_point(1010, 0x0F, 60);
    d.set_point(1100, 0x021F, 120);
    d.set_point(1110, 0x020F, 120);
    let mut min_speed_after_start = i32::MAX;
    for t in (1300..2000).step_by(5) {
        d.at(t);
        if d.position() < 110 {
            min_speed_after_start = min_speed_after_start.min(d.velocity());
        }
    }
    assert!(min_speed_after_start > 50, "no stop at 60 mm: {min_speed_after_start}");
    d.at(3000);
    assert_eq!(d.position(), 120);
}

#[test]
fn homing_37_makes_the_current_position_home() {
    let mut d = Drive::enabled(3);
    d.velocity_command(1000, 0x0F, 100);
    d.velocity_command(1300, 0x0F, 0);
    d.at(1600);
    assert_ne!(d.position(), 0);
    d.b.rx(ms(1600), RPDO1, &[0x0F, 0, 6, 200, 0, 0, 0]);
    assert_eq!(d.b.sdo_upload(ID, 0x6061, 0), Ok(vec![6]));
    d.b.rx(ms(1610), RPDO1, &[0x1F, 0, 6, 200, 0, 0, 0]);
    d.at(1620);
    assert_eq!(d.position(), 0, "0x607C is not in the dictionary: home offset 0");
    assert_eq!(d.statusword() & 0x3400, 0x1400, "homing attained, target reached");
}

#[test]
fn a_drive_fault_runs_the_fault_reaction_and_fault_reset_recovers() {
    let mut d = Drive::enabled(3);
    d.velocity_command(1000, 0x0F, 100);
    d.at(1400);
    d.b.node.app_mut().drive.drive.axis.inject(Injected::OverTemperature);
    let out = d.b.run_until(ms(1450));
    // The EC5000 warns first (0xFFA8 at 140 °C, D48, and the limiter 0xFFAA, D53), then faults: EMCY 0x4310
    // with error register 0x89 (generic, temperature, and the warning's manufacturer bit)
    // and the temperature in bytes 3-4 (D54).
    let emcy: Vec<_> = out.iter().filter(|(_, (id, _))| *id == 0x085).map(|(_, (_, d))| d.clone()).collect();
    assert_eq!(
        emcy,
        [vec![0xA8, 0xFF, 0x81, 140, 0, 0, 0, 0], vec![0xAA, 0xFF, 0x81, 140, 0, 0, 0, 0], vec![0x10, 0x43, 0x89, 140, 0, 0, 0, 0]]
    );
    assert_eq!(d.statusword() & 0x4F, 0x08, "Fault (the over-temperature switches the power stage off)");
    assert_eq!(d.statusword() & 0x0080, 0x0080, "warning: above 95 °C");
    d.b.node.app_mut().drive.drive.axis.remove(Injected::OverTemperature);
    d.velocity_command(1500, 0x00, 0);
    d.velocity_command(1600, 0x80, 0);
    assert_eq!(d.statusword() & 0x4F, 0x40, "15: Switch on disabled");
}

#[test]
fn heartbeat_loss_with_0x6007_quick_stop() {
    let mut d = Drive::enabled(3);
    // Consume node 1's heartbeat, 100 ms; 0x6007 = 3 (quick stop).
    assert_eq!(d.b.sdo_write(ID, 0x1016, 1, &0x0001_0064u32.to_le_bytes()), ok_write(0x1016, 1));
    assert_eq!(d.b.sdo_write(ID, 0x6007, 0, &[3, 0]), ok_write(0x6007, 0));
    d.b.rx(ms(1000), 0x701, &[0x05]);
    d.velocity_command(1000, 0x0F, 100);
    d.b.rx(ms(1050), 0x701, &[0x05]);
    d.at(1140);
    assert_eq!(d.statusword() & 0x6F, 0x27, "still enabled");
    d.at(1160);
    assert_eq!(d.statusword() & 0x6F, 0x07, "heartbeat lost at 1150 ms: Quick stop active");
    d.at(1400);
    assert_eq!((d.velocity(), d.statusword() & 0x4F), (0, 0x40));
}

#[test]
fn unsupported_modes_are_refused_and_the_display_follows_the_mode() {
    let mut d = Drive::enabled(3);
    assert_eq!(d.b.sdo_write(ID, 0x6060, 0, &[2]), common::abort(0x6060, 0, 0x0609_0030), "vl is not in 0x6502");
    let out = d.b.rx(d.b.now, 0x605, &[0x2F, 0x60, 0x60, 0, 1, 0, 0, 0]);
    assert!(out.contains(&(0x585, ok_write(0x6060, 0))), "{out:x?}");
    assert_eq!(d.b.sdo_upload(ID, 0x6061, 0), Ok(vec![1]));
}

/// D71: 0 in 0x6060 is CiA 402's "no mode change". RPDO1 carries 0x6060
/// with the controlword, so a master that only switches states (python-canopen's
/// BaseNode402 sends its RPDO1 copy, mode 0 until a mode is set) keeps the mode.
#[test]
fn rpdo1_with_mode_0_switches_states_and_keeps_the_mode_d71() {
    let mut d = Drive::enabled(3);
    for (t, cw) in [(1000, 0x06u8), (1010, 0x07), (1020, 0x0F)] {
        d.b.rx(ms(t), RPDO1, &[cw, 0, 0, 0, 0, 0, 0]);
    }
    d.at(1030);
    assert_eq!(d.statusword() & 0x6F, 0x27, "Operation enabled");
    assert_eq!((d.b.sdo_upload(ID, 0x6061, 0), d.b.sdo_upload(ID, 0x6060, 0)), (Ok(vec![3]), Ok(vec![3])), "still pv");
    d.velocity_command(1030, 0x0F, 100);
    d.at(1500);
    assert_eq!(d.velocity(), 100, "pv runs");
    // By SDO the same: 0 leaves pp as it is.
    assert_eq!(d.b.sdo_write(ID, 0x6060, 0, &[1]), ok_write(0x6060, 0));
    assert_eq!(d.b.sdo_write(ID, 0x6060, 0, &[0]), ok_write(0x6060, 0));
    assert_eq!(d.b.sdo_upload(ID, 0x6061, 0), Ok(vec![1]));
}

#[test]
fn pp_profile_velocity_above_the_motor_limit_is_capped_and_lands_without_overshoot() {
    let mut d = Drive::enabled(1);
    // 0x6081 = 500 mm/s; the roller's motor tops out at 436 mm/s.
    d.b.rx(ms(1000), RPDO1, &[0x0F, 0, 1, 0xF4, 0x01, 0, 0]);
    d.set_point(1000, 0x1F, 300);
    d.set_point(1010, 0x0F, 300);
    let mut furthest = 0;
    for t in (1020..2500).step_by(5) {
        d.at(t);
        furthest = furthest.max(d.position());
        // The trajectory asks no more than the motor can give (0x606B).
        assert!(d.demand_velocity() <= 436, "{} mm/s demanded at {t} ms", d.demand_velocity());
    }
    assert_eq!((d.position(), furthest), (300, 300));
}
