//! Zero Motion Hold on the EC5000 (M-L101, L141, L264-275; D52): the roller
//! has no brake, so at standstill it holds its position with the power stage
//! on (Operation enabled: halt, a target below the minimum speed, a stop) or
//! freewheels with it off (the controlword switched it off), checked in
//! virtual time with a load on the roller.

mod common;

use common::ec5000::*;
use common::ms;

/// TPDO1 (0x6041, 0x6061 = pv, 0x1001, 25 °C, 0x6077) and TPDO2 (0x6041, 0x6064).
fn tpdo1(statusword: u16, torque: i16) -> Vec<u8> {
    let ([s0, s1], [t0, t1]) = (statusword.to_le_bytes(), torque.to_le_bytes());
    vec![s0, s1, 3, 0, 25, 0, t0, t1]
}
fn tpdo2(statusword: u16, mm: i32) -> Vec<u8> {
    let ([s0, s1], [p0, p1, p2, p3]) = (statusword.to_le_bytes(), mm.to_le_bytes());
    vec![s0, s1, p0, p1, p2, p3]
}

/// Operation enabled at rest in pv, and Switched on.
const HOLDING: u16 = 0x1637;
const SWITCHED_ON: u16 = 0x0233;

#[test]
fn l267_l274_zero_motion_hold_holds_under_load_and_the_switched_off_roller_freewheels() {
    let mut b = enabled();
    // Goods pull the roller forwards with 150 ‰ of the rated torque (friction
    // alone holds 125 ‰). With the power stage on, the position loop holds it:
    // the torque answers the load, the position does not move.
    roller(&mut b).axis.set_load(150);
    assert_eq!(frames(&mut b, 700, 1000), [(1, TPDO1, tpdo1(HOLDING, -150))]);
    assert_eq!((value(&mut b, 0x6064, 0), value(&mut b, 0x606C, 0)), (0, 0), "held in place");
    // "Im Stillstand im Leerlauf": the controlword switches the power stage
    // off (transition 5, Switched on): the roller freewheels and the load turns
    // it, 25 ‰ net = 54.5 mm/s² (27 mm in the first second).
    b.rx(ms(1700), RPDO3, &[0x07, 0, 0, 0, 0, 0]);
    assert_eq!(
        frames(&mut b, 1700, 1000),
        [
            (1, TPDO1, tpdo1(SWITCHED_ON, -150)),
            (1, TPDO2, tpdo2(SWITCHED_ON, 0)),
            (101, TPDO1, tpdo1(SWITCHED_ON, 0)),
            (136, TPDO2, tpdo2(SWITCHED_ON, 1)),
            (236, TPDO2, tpdo2(SWITCHED_ON, 2)),
            (336, TPDO2, tpdo2(SWITCHED_ON, 3)),
            (436, TPDO2, tpdo2(SWITCHED_ON, 5)),
            (536, TPDO2, tpdo2(SWITCHED_ON, 8)),
            (636, TPDO2, tpdo2(SWITCHED_ON, 11)),
            (736, TPDO2, tpdo2(SWITCHED_ON, 15)),
            (836, TPDO2, tpdo2(SWITCHED_ON, 19)),
            (936, TPDO2, tpdo2(SWITCHED_ON, 24)),
        ]
    );
    assert_eq!((value(&mut b, 0x6064, 0), value(&mut b, 0x606C, 0)), (27, 54));
    // Enable operation again: the roller is caught and held where it is now.
    b.rx(ms(2700), RPDO3, &[0x0F, 0, 0, 0, 0, 0]);
    b.run_until(ms(3700));
    let (held, speed) = (value(&mut b, 0x6064, 0), value(&mut b, 0x606C, 0));
    b.run_until(ms(5700));
    assert_eq!((value(&mut b, 0x6064, 0), value(&mut b, 0x606C, 0)), (held, speed), "held from then on");
    assert_eq!(speed, 0);
    assert!((27..=29).contains(&held), "caught within the 30 ms it takes to brake from 54 mm/s: {held}");
}

#[test]
fn l273_halt_stops_into_zero_motion_hold_under_load_and_resumes() {
    let mut b = enabled();
    roller(&mut b).axis.set_load(-1000);
    pv(&mut b, 1000, 0x0F, 100);
    b.run_until(ms(2000));
    assert_eq!(value(&mut b, 0x606C, 0), 100, "the drive carries a load of the rated torque against the motion");
    // Halt (bit 8): down the ramp to Zero Motion Hold, bit 10 once it stands.
    pv(&mut b, 2000, 0x010F, 100);
    b.run_until(ms(2200));
    let held = value(&mut b, 0x6064, 0);
    assert_eq!((value(&mut b, 0x606C, 0), statusword(&mut b) & 0x0400), (0, 0x0400));
    b.run_until(ms(4200));
    assert_eq!((value(&mut b, 0x6064, 0), value(&mut b, 0x6077, 0)), (held, 1000), "held against the load");
    // Halt off: the roller runs on.
    pv(&mut b, 4200, 0x0F, 100);
    b.run_until(ms(5200));
    assert_eq!(value(&mut b, 0x606C, 0), 100);
}

#[test]
fn l266_a_target_below_the_minimum_speed_stops_the_roller() {
    let mut b = enabled();
    // 10 mm/s is below the motor's 100 min⁻¹ (14.5 mm/s at the roller): no
    // motion, the demand stays 0; bit 12 (speed 0) stays, bit 10 (target
    // reached) does not come.
    pv(&mut b, 1000, 0x0F, 10);
    assert_eq!(frames(&mut b, 1000, 1000), [(1, TPDO1, tpdo1(0x1237, 0)), (1, TPDO2, tpdo2(0x1237, 0))]);
    assert_eq!([0x6064, 0x606B, 0x606C].map(|i| value(&mut b, i, 0)), [0, 0, 0]);
    // 15 mm/s is above it: the roller turns.
    pv(&mut b, 2000, 0x0F, 15);
    b.run_until(ms(3000));
    assert_eq!([0x6064, 0x606B, 0x606C].map(|i| value(&mut b, i, 0)), [15, 15, 15]);
}

#[test]
fn l267_below_the_minimum_speed_the_position_of_that_moment_is_held() {
    let mut b = enabled();
    // A slow deceleration (0x6084 = 100 mm/s²) from 100 mm/s to 0: TPDO3 on
    // SYNC every 50 ms shows the ramp, which ends at 14.5 mm/s, not at 0.
    b.sdo_download(ID, 0x6084, 0, &100u32.to_le_bytes()).expect("0x6084");
    pv(&mut b, 1000, 0x0F, 100);
    pv(&mut b, 2000, 0x0F, 0);
    let mut seen = Vec::new();
    for t in (2700..=3000).step_by(50) {
        b.run_until(ms(t));
        for (id, data) in b.rx(ms(t), 0x080, &[]) {
            assert_eq!(id, TPDO3);
            seen.push((t, u16::from_le_bytes([data[0], data[1]]), i32::from_le_bytes([data[2], data[3], data[4], data[5]])));
        }
    }
    assert_eq!(
        seen,
        [
            (2700, 0x0237, 30),
            (2750, 0x0237, 25),
            (2800, 0x0237, 20),
            (2850, 0x0237, 15),
            // Standing: target reached (0 mm/s) and speed = 0 (bit 12: 0x606C reads
            // within the threshold 0, docs/devices/ec5000.md D42).
            (2900, 0x1637, 0),
            (2950, 0x1637, 0),
            (3000, 0x1637, 0)
        ]
    );
    let held = value(&mut b, 0x6064, 0);
    b.run_until(ms(4000));
    assert_eq!(value(&mut b, 0x6064, 0), held, "held from then on");
}

#[test]
fn l267_the_demand_drops_from_the_minimum_speed_to_0_in_one_tick() {
    let mut b = enabled();
    b.sdo_download(ID, 0x6084, 0, &100u32.to_le_bytes()).expect("0x6084");
    pv(&mut b, 1000, 0x0F, 100);
    pv(&mut b, 2000, 0x0F, 0);
    // 0x606B (whole mm/s) every millisecond from 2850 ms: the demand falls by
    // 0.1 mm/s per millisecond to 14.5 mm/s (100 min⁻¹ at the motor), then to 0
    // at once, where the ramp would have taken 145 ms more.
    let mut demand = Vec::new();
    for t in 2850..2860 {
        b.run_until(ms(t));
        demand.push(value(&mut b, 0x606B, 0));
    }
    assert_eq!(demand, [15, 15, 15, 15, 15, 0, 0, 0, 0, 0]);
}
