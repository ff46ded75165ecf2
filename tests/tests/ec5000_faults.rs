//! The EC5000's fault codes (M §9, L1659-1745; D53, D54), raised by the axis
//! model's injected faults and the roller's own monitoring while it runs in
//! pv at 100 mm/s: the EMCY with its code, error register and manufacturer
//! bytes, the fault reaction, fault reset refused while the cause persists
//! (M §5.2, L602-610) and "error reset" once it is acknowledged.

mod common;

use canopen_core::axis::Injected;
use common::ec5000::*;
use common::ms;

/// Runs at 100 mm/s from 1000 ms; at 2000 ms `inject`s the fault: the EMCY
/// frames of the next second. Then, with the fault removed, a fault reset
/// (rising edge of bit 7) at 3010 ms: what it sends, and the statusword.
fn fault_and_reset(inject: Injected) -> (Emcys, Vec<F>, u16) {
    let mut b = enabled();
    pv(&mut b, 1000, 0x0F, 100);
    b.run_until(ms(2000));
    roller(&mut b).axis.inject(inject);
    let raised = emcy(&mut b, 2000, 1000);
    assert_eq!(statusword(&mut b) & 0x4F, 0x08, "{inject:?}: Fault");
    assert_eq!(pv(&mut b, 3000, 0x00, 0), [], "{inject:?}: no reset while the cause persists");
    assert_eq!(pv(&mut b, 3005, 0x80, 0), []);
    assert_eq!(statusword(&mut b) & 0x4F, 0x08, "{inject:?}: still Fault");
    roller(&mut b).axis.remove(inject);
    pv(&mut b, 3008, 0x00, 0);
    let reset = pv(&mut b, 3010, 0x80, 0);
    (raised, reset, statusword(&mut b))
}

use common::F;

/// EMCY frames with their time [ms].
type Emcys = Vec<(u64, Vec<u8>)>;

/// Fault reset: "error reset", then TPDO1 (error register 0 again: no error
/// is left) and TPDO2 with Switch on disabled.
fn reset_frames(position: u8) -> Vec<F> {
    vec![(EMCY, vec![0; 8]), (TPDO1, vec![0x50, 0x02, 3, 0, 25, 0, 0, 0]), (TPDO2, vec![0x50, 0x02, position, 0, 0, 0])]
}

#[test]
fn l1670_0x3210_supply_voltage_too_high() {
    // Error register 0x05 (generic, voltage); bytes 3-4 the DC link [mV]: 36,000.
    let (raised, reset, sw) = fault_and_reset(Injected::OverVoltage);
    assert_eq!(raised, [(1, vec![0x10, 0x32, 0x05, 0xA0, 0x8C, 0, 0, 0])]);
    assert_eq!((reset, sw), (reset_frames(116), 0x0250));
}

#[test]
fn l1672_0x3220_supply_voltage_too_low() {
    // The DC link collapsed: 0 mV; statusword bit 4 (voltage enabled) goes off.
    let (raised, reset, sw) = fault_and_reset(Injected::UnderVoltage);
    assert_eq!(raised, [(1, vec![0x20, 0x32, 0x05, 0, 0, 0, 0, 0])]);
    assert_eq!(reset[0], (EMCY, vec![0; 8]));
    assert_eq!(sw, 0x0250);
}

#[test]
fn l1674_0x4310_motor_temperature_too_high() {
    // The warnings 0xFFA8 (D48) and 0xFFAA (the limiter) first, then the fault with the temperature [°C].
    let (raised, reset, sw) = fault_and_reset(Injected::OverTemperature);
    assert_eq!(
        raised,
        [
            (0, vec![0xA8, 0xFF, 0x81, 140, 0, 0, 0, 0]),
            (0, vec![0xAA, 0xFF, 0x81, 140, 0, 0, 0, 0]),
            (1, vec![0x10, 0x43, 0x89, 140, 0, 0, 0, 0])
        ]
    );
    // The warning clears with the temperature (25 °C again) before the reset,
    // while the fault is active: "error reset" comes with the fault reset.
    assert_eq!((reset[0].clone(), sw), ((EMCY, vec![0; 8]), 0x0250));
}

#[test]
fn l1713_0xff15_over_current_regulator_output_is_the_power_stage_fault() {
    // The model's power stage fault (CiA 0x2320, not in the manual's table).
    let (raised, reset, sw) = fault_and_reset(Injected::PowerStage);
    assert_eq!(raised, [(1, vec![0x15, 0xFF, 0x81, 0, 0, 0, 0, 0])]);
    assert_eq!((reset, sw), (reset_frames(116), 0x0250));
}

#[test]
fn l1686_0x7121_motor_shaft_is_blocked() {
    let mut b = enabled();
    pv(&mut b, 1000, 0x0F, 100);
    b.run_until(ms(2000));
    // The shaft stops dead at 100 mm/s: the speed warning 0xFFD4 after 200 ms
    // below half the demand, 0x7121 after 500 ms standing (error register
    // 0xA1: generic, profile, and the warning's manufacturer bit).
    roller(&mut b).axis.inject(Injected::Blocked);
    assert_eq!(emcy(&mut b, 2000, 1000), [(201, vec![0xD4, 0xFF, 0x81, 0, 0, 0, 0, 0]), (500, vec![0x21, 0x71, 0xA1, 0, 0, 0, 0, 0])]);
    assert_eq!(statusword(&mut b) & 0x4F, 0x08, "Fault");
    // A block does not show at standstill: the reset is accepted (error
    // reset) and the next start faults again: 500 ms after the demand passes
    // the minimum speed (6.6 ms into the ramp).
    pv(&mut b, 3000, 0x00, 100);
    assert_eq!(pv(&mut b, 3010, 0x80, 100)[0], (EMCY, vec![0; 8]));
    for (t, cw) in [(3100, 0x06), (3200, 0x07), (3300, 0x0F)] {
        pv(&mut b, t, cw, 100);
    }
    assert_eq!(emcy(&mut b, 3300, 1000), [(207, vec![0xD4, 0xFF, 0x81, 0, 0, 0, 0, 0]), (506, vec![0x21, 0x71, 0xA1, 0, 0, 0, 0, 0])]);
    // Freed: reset, enable, and the roller runs.
    roller(&mut b).axis.remove(Injected::Blocked);
    for (t, cw) in [(4300, 0x00), (4310, 0x80), (4400, 0x06), (4500, 0x07), (4600, 0x0F)] {
        pv(&mut b, t, cw, 100);
    }
    b.run_until(ms(5600));
    assert_eq!((statusword(&mut b) & 0x6F, value(&mut b, 0x606C, 0)), (0x27, 100), "Operation enabled at 100 mm/s");
}

#[test]
fn l1745_0xffd4_then_l1719_0xff50_motor_speed_error_heavy_load() {
    let mut b = enabled();
    pv(&mut b, 1000, 0x0F, 100);
    b.run_until(ms(2000));
    // A load at the torque limit: the roller keeps its 100 mm/s but cannot
    // accelerate to 250. Below half the demand: warning after 200 ms, fault
    // after 2 s (error register 0x81: generic, manufacturer).
    roller(&mut b).axis.set_load(-3000);
    pv(&mut b, 2000, 0x0F, 250);
    assert_eq!(emcy(&mut b, 2000, 3000), [(246, vec![0xD4, 0xFF, 0x81, 0, 0, 0, 0, 0]), (2045, vec![0x50, 0xFF, 0x81, 0, 0, 0, 0, 0])]);
    assert_eq!(statusword(&mut b) & 0x4F, 0x08, "Fault");
    // The load is gone when the roller stands: fault reset works, error reset.
    roller(&mut b).axis.set_load(0);
    pv(&mut b, 5000, 0x00, 0);
    assert_eq!(pv(&mut b, 5010, 0x80, 0)[0], (EMCY, vec![0; 8]));
    assert_eq!(statusword(&mut b) & 0x4F, 0x40);
}

#[test]
fn l1676_0x4320_and_l1723_0xffa9_motor_temperature_too_low() {
    let mut b = enabled();
    // -20 °C: the warning 0xFFA9 with the temperature (0xFFEC), bit 7.
    roller(&mut b).axis.set_ambient(-20);
    assert_eq!(emcy(&mut b, 700, 300), [(0, vec![0xA9, 0xFF, 0x81, 0xEC, 0xFF, 0, 0, 0])]);
    assert_eq!(statusword(&mut b), 0x16B7);
    assert_eq!(value(&mut b, 0x2211, 1), 1, "temperature light yellow (D50)");
    // -30 °C: the fault 0x4320 (generic, temperature, manufacturer).
    roller(&mut b).axis.set_ambient(-30);
    assert_eq!(emcy(&mut b, 1000, 300), [(1, vec![0x20, 0x43, 0x89, 0xE2, 0xFF, 0, 0, 0])]);
    assert_eq!(statusword(&mut b), 0x0298, "Fault, warning");
    assert_eq!(value(&mut b, 0x2211, 1), 2, "red");
    // Still -30 °C: fault reset refused. At -25 °C it is accepted, and with the
    // warning still active no "error reset" goes out.
    pv(&mut b, 1300, 0x00, 0);
    assert_eq!(pv(&mut b, 1310, 0x80, 0), []);
    assert_eq!(statusword(&mut b), 0x0298);
    roller(&mut b).axis.set_ambient(-25);
    pv(&mut b, 1500, 0x00, 0);
    assert_eq!(pv(&mut b, 1510, 0x80, 0).iter().filter(|(id, _)| *id == EMCY).count(), 0);
    assert_eq!(statusword(&mut b), 0x02D0, "Switch on disabled, warning");
    // -18 °C = -20 + the 2 K of 0x4231 sub 2: the warning clears, error reset, bit 7 off.
    roller(&mut b).axis.set_ambient(-18);
    assert_eq!(emcy(&mut b, 1510, 300), [(0, vec![0; 8])]);
    assert_eq!(statusword(&mut b), 0x0250);
}

#[test]
fn l595_0x1003_holds_each_code_with_its_first_two_manufacturer_bytes() {
    // 0x1003 sub 1 = bytes 3-4 << 16 | code (M §5.1): the cold fault's -30 °C.
    let mut b = enabled();
    roller(&mut b).axis.set_ambient(-30);
    b.run_until(ms(1000));
    assert_eq!(b.sdo_upload(ID, 0x1003, 0), Ok(vec![2]));
    assert_eq!(b.sdo_upload(ID, 0x1003, 1), Ok(0xFFE2_4320u32.to_le_bytes().to_vec()));
    assert_eq!(b.sdo_upload(ID, 0x1003, 2), Ok(0xFFE2_FFA9u32.to_le_bytes().to_vec()));
}

#[test]
fn l1725_0xffaa_power_reduced_by_temperature_limiter() {
    let mut b = enabled();
    pv(&mut b, 1000, 0x0F, 300);
    b.run_until(ms(2000));
    assert_eq!(value(&mut b, 0x606C, 0), 300);
    // 100 °C: the warning 0xFFA8 (95 °C, D48) and the limiter 0xFFAA with the
    // temperature; the speed limit halves (218 mm/s), the power light turns yellow.
    roller(&mut b).axis.set_ambient(100);
    assert_eq!(emcy(&mut b, 2000, 1000), [(0, vec![0xA8, 0xFF, 0x81, 100, 0, 0, 0, 0]), (0, vec![0xAA, 0xFF, 0x81, 100, 0, 0, 0, 0])]);
    assert_eq!((value(&mut b, 0x606C, 0), value(&mut b, 0x2211, 2)), (218, 1));
    // 98 °C = 100 - the 2 K of 0x4231 sub 2: full speed again; 0xFFA8 stays, so no error reset.
    roller(&mut b).axis.set_ambient(98);
    assert_eq!(emcy(&mut b, 3000, 1000), []);
    assert_eq!((value(&mut b, 0x606C, 0), value(&mut b, 0x2211, 2)), (300, 0));
    roller(&mut b).axis.set_ambient(93);
    assert_eq!(emcy(&mut b, 4000, 1000), [(0, vec![0; 8])]);
}

#[test]
fn a_fault_while_the_drive_is_off_shows_in_the_statusword_at_once() {
    // Switch on disabled (the profile does not tick): the supply fails; the
    // EMCY and the TPDOs with Fault leave at the next poll. (TPDO1 samples
    // 0x1001 before the core records the EMCY in it: the register follows
    // after the inhibit time.)
    let mut b = enabled();
    pv(&mut b, 800, 0x00, 0);
    b.run_until(ms(1000));
    roller(&mut b).axis.inject(Injected::OverVoltage);
    assert_eq!(
        frames(&mut b, 1000, 300),
        [
            (0, EMCY, vec![0x10, 0x32, 0x05, 0xA0, 0x8C, 0, 0, 0]),
            (0, TPDO1, vec![0x18, 0x02, 3, 0, 25, 0, 0, 0]),
            (0, TPDO2, vec![0x18, 0x02, 0, 0, 0, 0]),
            (100, TPDO1, vec![0x18, 0x02, 3, 0x05, 25, 0, 0, 0]),
        ]
    );
}
