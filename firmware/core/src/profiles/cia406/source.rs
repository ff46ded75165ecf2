//! Where the position comes from: a sensor behind the [`PositionSource`]
//! trait. A board counts quadrature edges in a timer ([`QuadratureCounter`]
//! on its [`CounterRegister`]) or reads a magnetic sensor; the host, the QEMU
//! and the bench images turn a [`SimulatedShaft`]; tests set a
//! [`ManualShaft`] step by step.

use crate::time::Instant;

/// Why a sensor gave no position.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SensorFault {
    /// The reading is not valid (0x6503 bit 0 "position error").
    Position,
    /// The sensor did not answer in time (0x6503 bit 15 "device error").
    Sync,
    /// The multi-turn counter failed: the turns are not known (a position
    /// error; the Sendix reports it as EMCY 0x5051, manual §5.8.1).
    Multiturn,
}

/// A multi-turn position sensor.
///
/// A quadrature counter fits as: the hardware timer counts edges (16 bit),
/// `count` reads it and extends the wrapping difference since the last
/// read into a 64-bit count (`range` 0); an absolute sensor returns its
/// single-turn steps plus its turn counter × steps per revolution, with
/// `range` = steps per revolution × revolutions.
pub trait PositionSource {
    /// The raw step count at `now`, `0..range()` (0: wraps at 2^64), in
    /// sensor steps: 0x6501 steps per revolution, clockwise counting up.
    fn count(&mut self, now: Instant) -> Result<u64, SensorFault>;

    /// Where the physical counter wraps to 0 (0: at 2^64). The profile
    /// follows the movement across the wrap, so the position does not
    /// jump whatever the measuring range.
    fn range(&self) -> u64;
}

/// A shaft that turns on its own: `STEPS_PER_S` (negative: counter-clockwise),
/// `JITTER` steps of noise either way (about a mean `JITTER` steps on), a physical counter of `WRAP_TURNS`
/// revolutions of `RESOLUTION` steps (0: 2^64 steps). The count is a pure
/// function of time, so the state is all zero bits ([`crate::node`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SimulatedShaft<const STEPS_PER_S: i32, const JITTER: u16, const RESOLUTION: u32, const WRAP_TURNS: u32>;

impl<const V: i32, const J: u16, const R: u32, const W: u32> SimulatedShaft<V, J, R, W> {
    /// The shaft at rest at 0 at time 0.
    pub const NEW: Self = SimulatedShaft;
}

impl<const V: i32, const J: u16, const R: u32, const W: u32> PositionSource for SimulatedShaft<V, J, R, W> {
    // `rest` < 10^6 times an i32 fits; 2J + 1 ≤ 2^17 is not 0.
    #[allow(clippy::arithmetic_side_effects)]
    fn count(&mut self, now: Instant) -> Result<u64, SensorFault> {
        // Whole seconds and the rest apart: no 128-bit product.
        let us = now.as_micros();
        let (secs, rest) = ((us / 1_000_000) as i64, (us % 1_000_000) as i64);
        let moved = secs.wrapping_mul(i64::from(V)).wrapping_add(rest * i64::from(V) / 1_000_000);
        // Noise that does not drift: a hash of the millisecond, 0..=2J steps (±J about
        // a shaft J steps on), so a shaft at rest at 0 does not wrap back to the top of its range.
        let ms = now.as_micros() / 1000;
        let hash = ms.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 32;
        let noise = (hash % (2 * u64::from(J) + 1)) as i64;
        let count = moved.wrapping_add(noise);
        let range = self.range();
        Ok(if range == 0 { count as u64 } else { count.rem_euclid(range.min(i64::MAX as u64) as i64) as u64 })
    }

    // Two u32s: the product fits a u64.
    #[allow(clippy::arithmetic_side_effects)]
    fn range(&self) -> u64 {
        u64::from(R) * u64::from(W)
    }
}

/// A shaft moved by hand (tests, demos): its count is what was last set.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ManualShaft {
    count: u64,
    range: u64,
    fault: Option<SensorFault>,
}

impl ManualShaft {
    /// At 0, wrapping at 2^64, no fault.
    pub const NEW: ManualShaft = ManualShaft { count: 0, range: 0, fault: None };

    /// A physical counter that wraps at `range` steps (0: 2^64).
    pub const fn with_range(range: u64) -> ManualShaft {
        ManualShaft { count: 0, range, fault: None }
    }

    /// Sets the raw count (taken modulo the range).
    // The range is not 0 where it divides.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn set(&mut self, count: u64) {
        self.count = if self.range == 0 { count } else { count % self.range };
    }

    /// Turns the shaft by `steps` (negative: counter-clockwise), wrapping
    /// the physical counter as the sensor would.
    // The range is not 0 where it divides, and a remainder is below it.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn turn(&mut self, steps: i64) {
        let r = self.range;
        self.count = if r == 0 {
            self.count.wrapping_add(steps as u64)
        } else if steps >= 0 {
            add_mod(self.count % r, steps as u64 % r, r)
        } else {
            add_mod(self.count % r, r - steps.unsigned_abs() % r, r)
        };
    }

    /// The raw count now.
    pub fn get(&self) -> u64 {
        self.count
    }

    /// Makes the sensor fail (or work again with `None`).
    pub fn set_fault(&mut self, fault: Option<SensorFault>) {
        self.fault = fault;
    }
}

impl PositionSource for ManualShaft {
    fn count(&mut self, _now: Instant) -> Result<u64, SensorFault> {
        self.fault.map_or(Ok(self.count), Err)
    }

    fn range(&self) -> u64 {
        self.range
    }
}

/// A quadrature counter's register: a timer in encoder mode counting
/// edges up and down in 16 bits (the board implements it on its timer).
pub trait CounterRegister {
    /// The counter now.
    fn read(&mut self) -> u16;
}

/// A [`PositionSource`] on a 16-bit quadrature counter: each read extends
/// the wrapping difference since the last one into a 64-bit count (4 edges
/// per line: 0x6501 = 4 × lines). It must be read at least once per 32767
/// edges, which the profile's 2 ms sample does up to 16 M edges per second.
/// A relative counter starts at 0 at power-on; a device that must keep its
/// position over a power cycle needs an absolute sensor instead.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct QuadratureCounter<R> {
    /// The register.
    pub register: R,
    last: u16,
    count: u64,
    started: bool,
}

impl<R: CounterRegister> QuadratureCounter<R> {
    /// A counter at 0 (all zero bits but the register).
    pub const fn new(register: R) -> Self {
        QuadratureCounter { register, last: 0, count: 0, started: false }
    }
}

impl<R: CounterRegister> PositionSource for QuadratureCounter<R> {
    fn count(&mut self, _now: Instant) -> Result<u64, SensorFault> {
        let now = self.register.read();
        if self.started {
            self.count = self.count.wrapping_add(now.wrapping_sub(self.last) as i16 as i64 as u64);
        }
        self.started = true;
        self.last = now;
        Ok(self.count)
    }

    fn range(&self) -> u64 {
        0
    }
}

/// `(a + b) mod m` for `a` below `m` and `b` at most `m`, for any `m`
/// (their sum may pass 2^64).
// `b` ≤ `m`, and each branch's result is below `m`.
#[allow(clippy::arithmetic_side_effects)]
fn add_mod(a: u64, b: u64, m: u64) -> u64 {
    if a >= m - b { a - (m - b) } else { a + b }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_simulated_shaft_turns_and_wraps() {
        let mut s = SimulatedShaft::<1000, 0, 16, 4>::NEW;
        assert_eq!(s.count(Instant::from_micros(0)), Ok(0));
        assert_eq!(s.count(Instant::from_micros(10_000)), Ok(10));
        assert_eq!(s.count(Instant::from_micros(70_000)), Ok(70 % 64), "4 turns of 16 steps");
        let mut back = SimulatedShaft::<-1000, 0, 16, 4>::NEW;
        assert_eq!(back.count(Instant::from_micros(1_000)), Ok(63));
    }

    #[test]
    fn a_manual_shaft_wraps_at_a_range_past_2_to_the_63() {
        let mut s = ManualShaft::with_range(u64::MAX);
        s.set(u64::MAX - 3);
        s.turn(5);
        assert_eq!(s.get(), 2, "2^64 - 4 + 5 = 2^64 + 1, 2 past the range 2^64 - 1");
        s.turn(-3);
        assert_eq!(s.get(), u64::MAX - 1);
        let mut small = ManualShaft::with_range(10);
        small.set(8);
        small.turn(-10);
        assert_eq!(small.get(), 8, "a whole range back");
        small.turn(13);
        assert_eq!(small.get(), 1);
    }

    #[test]
    fn jitter_stays_within_its_bound_and_is_not_constant() {
        let mut s = SimulatedShaft::<0, 3, 0, 0>::NEW;
        let values: Vec<u64> = (0..200).map(|ms| s.count(Instant::from_micros(ms * 1000)).unwrap()).collect();
        assert!(values.iter().all(|&v| v <= 6), "{values:?}");
        assert!(values.iter().any(|&v| v != values[0]));
    }

    #[test]
    fn a_quadrature_counter_extends_its_16_bit_register() {
        struct Timer(u16);
        impl CounterRegister for Timer {
            fn read(&mut self) -> u16 {
                self.0
            }
        }
        let mut q = QuadratureCounter::new(Timer(0xFFF0));
        assert_eq!(q.count(Instant::ZERO), Ok(0), "counts from where the timer stands");
        q.register.0 = 0x0010;
        assert_eq!(q.count(Instant::ZERO), Ok(0x20), "across the timer's wrap");
        q.register.0 = 0xFFF0;
        assert_eq!(q.count(Instant::ZERO), Ok(0), "and back");
        q.register.0 = 0xFFE0;
        assert_eq!(q.count(Instant::ZERO), Ok(u64::MAX - 15), "below 0 wraps at 2^64 (range 0)");
    }

    #[test]
    fn a_manual_shaft_wraps_its_counter() {
        let mut s = ManualShaft::with_range(100);
        s.turn(-1);
        assert_eq!(s.get(), 99);
        s.set_fault(Some(SensorFault::Position));
        assert_eq!(s.count(Instant::ZERO), Err(SensorFault::Position));
    }
}
