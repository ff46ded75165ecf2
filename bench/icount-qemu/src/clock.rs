//! Instruction counts from SysTick under `qemu-system-arm -icount
//! shift=0,align=off,sleep=off`, where the virtual clock advances exactly
//! 1 ns per guest instruction.
//!
//! QEMU derives the lm3s6965's system clock, which SysTick counts with
//! CLKSOURCE = processor clock, from the RCC register: 200 MHz / (SYSDIV + 1).
//! With SYSDIV = 0 a tick is 5 ns, i.e. 5 instructions. [`Clock::start`] does
//! not trust that: it times a straight-line block of a known number of
//! instructions and takes the instructions per tick from it (it must be a
//! whole number).
//!
//! A single reading is only exact to a tick. Before each timed span a
//! pseudo-random delay of 2 to 32 instructions moves the span's start across
//! the tick, so the quantisation averages out over many spans; the two
//! SysTick reads themselves (the span of nothing, measured the same way) are
//! subtracted.
#![allow(unsafe_code)]

use core::arch::asm;
use core::hint::black_box;
use core::sync::atomic::{Ordering, compiler_fence};

use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;

/// The lm3s6965's run-mode clock configuration register (datasheet §6.4, RCC).
const RCC: usize = 0x400F_E060;
/// RCC: the system clock divisor (SYSDIV, bits 26:23) and its enable (USESYSDIV, bit 22).
const RCC_SYSDIV: u32 = 0xF << 23;
const RCC_USESYSDIV: u32 = 1 << 22;
/// SysTick's counter is 24 bits wide.
const SYSTICK_MASK: u32 = 0x00FF_FFFF;
/// Instructions per pass of [`straight_line`]: 100 `nop`, `subs`, `bne`.
const BLOCK: u64 = 102;
/// Passes of the calibration block: the difference of two runs leaves out
/// everything but 1000 passes.
const CALIBRATION_PASSES: (u32, u32) = (1_000, 2_000);
/// Spans timed to find the cost of the SysTick reads, and for the self-check.
const SPANS: u32 = 1_000;
/// Passes of [`straight_line`] in the self-check.
const CHECK_PASSES: u32 = 10;

/// The ticks of many spans of one kind of work.
#[derive(Clone, Copy, Debug, Default)]
pub struct Tally {
    ticks: u64,
    spans: u64,
}

impl Tally {
    /// Spans timed.
    pub fn spans(&self) -> u64 {
        self.spans
    }

    #[inline(always)]
    fn add(&mut self, ticks: u32) {
        // `black_box` makes the sum now: left to the optimizer, this
        // arithmetic could sink into the next span, between its reads.
        *self = black_box(Tally { ticks: self.ticks + u64::from(ticks), spans: self.spans + 1 });
    }
}

/// SysTick as an instruction counter.
pub struct Clock {
    /// Instructions per SysTick tick.
    per_tick: u32,
    /// Instructions a span of nothing counts (the reads themselves).
    overhead: f64,
    /// State of the delay generator.
    seed: u32,
}

/// The calibration: instructions run and ticks counted.
pub struct Calibration {
    /// Instructions of the straight-line block.
    pub instructions: u64,
    /// Ticks SysTick counted for them.
    pub ticks: u32,
    /// The self-check: instructions a span of [`CHECK_PASSES`] blocks
    /// measured, on average, against [`Calibration::check_known`].
    pub check_measured: f64,
    /// The instructions of those blocks.
    pub check_known: u64,
}

impl Clock {
    /// Runs SysTick at the highest rate QEMU offers and calibrates it.
    pub fn start(mut syst: SYST) -> Result<(Clock, Calibration), &'static str> {
        // SAFETY: RCC is the lm3s6965's 32-bit clock configuration register;
        // nothing else in this image touches it, and QEMU only recomputes
        // the system clock from it.
        unsafe {
            let rcc = core::ptr::read_volatile(RCC as *const u32);
            core::ptr::write_volatile(RCC as *mut u32, (rcc & !RCC_SYSDIV) | RCC_USESYSDIV);
        }
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(SYSTICK_MASK);
        syst.clear_current();
        syst.disable_interrupt();
        syst.enable_counter();

        let mut clock = Clock { per_tick: 1, overhead: 0.0, seed: 0x1234_5678 };
        let ticks = |passes| black_box(clock.ticks(|| straight_line(passes)).0);
        let (short, long) = (ticks(CALIBRATION_PASSES.0), ticks(CALIBRATION_PASSES.1));
        let mut calibration = Calibration {
            instructions: BLOCK * u64::from(CALIBRATION_PASSES.1 - CALIBRATION_PASSES.0),
            ticks: long.saturating_sub(short),
            check_measured: 0.0,
            check_known: BLOCK * u64::from(CHECK_PASSES),
        };
        let ticks = u64::from(calibration.ticks.max(1));
        let per_tick = u32::try_from((calibration.instructions + ticks / 2) / ticks).unwrap_or(0);
        // Each reading is exact to one tick, so the difference of the two to two ticks.
        let error = (u64::from(per_tick) * u64::from(calibration.ticks)).abs_diff(calibration.instructions);
        if per_tick == 0 || error > 2 * u64::from(per_tick) {
            return Err("SysTick does not count a whole number of instructions per tick");
        }
        clock.per_tick = per_tick;
        clock.overhead = clock.average(|| ());
        // The whole method on a span of known length: one tick of error per
        // reading must average out to well under an instruction (the
        // `passes` register set-up may add one).
        calibration.check_measured = clock.average(|| straight_line(CHECK_PASSES));
        let known = calibration.check_known as f64;
        if !(known - 0.5..=known + 1.5).contains(&calibration.check_measured) {
            return Err("SysTick self-check: a straight-line block measured off by more than an instruction");
        }
        Ok((clock, calibration))
    }

    /// Instructions per tick.
    pub fn per_tick(&self) -> u32 {
        self.per_tick
    }

    /// Instructions of the two SysTick reads around a span.
    pub fn overhead(&self) -> f64 {
        self.overhead
    }

    /// Ticks between a SysTick read before `f` and one after it.
    #[inline(always)]
    fn ticks<R>(&self, f: impl FnOnce() -> R) -> (u32, R) {
        let start = SYST::get_current();
        // Keeps the compiler from moving `f`'s memory accesses out of the span.
        compiler_fence(Ordering::SeqCst);
        let result = f();
        compiler_fence(Ordering::SeqCst);
        let end = SYST::get_current();
        // SysTick counts down.
        (start.wrapping_sub(end) & SYSTICK_MASK, result)
    }

    /// Runs `f` as one span (after a [`Clock::delay`]) and adds its ticks to
    /// `tally`. The caller computes `f`'s inputs before (`black_box`), so
    /// that only `f` runs between the reads.
    #[inline(always)]
    pub fn time<R>(&mut self, tally: &mut Tally, f: impl FnOnce() -> R) -> R {
        self.delay();
        let (ticks, result) = self.ticks(f);
        tally.add(ticks);
        result
    }

    /// Instructions per span of `tally`, without the reads' own.
    pub fn per_span(&self, tally: &Tally) -> f64 {
        if tally.spans == 0 {
            return 0.0;
        }
        (tally.ticks * u64::from(self.per_tick)) as f64 / tally.spans.max(1) as f64 - self.overhead
    }

    /// Instructions of `f`, averaged over [`SPANS`] spans.
    fn average(&mut self, f: impl Fn()) -> f64 {
        let mut tally = Tally::default();
        for _ in 0..SPANS {
            self.time(&mut tally, &f);
        }
        self.per_span(&tally)
    }

    /// Waits 2 to 32 instructions, pseudo-randomly, to move the next span
    /// across the SysTick tick.
    pub fn delay(&mut self) {
        // Numerical Recipes' LCG; the top bits are the random ones.
        self.seed = self.seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        let passes = (self.seed >> 28) + 1;
        // SAFETY: a register-only loop (`subs` + `bne` per pass, passes >= 1).
        unsafe { asm!("2:", "subs {n}, #1", "bne 2b", n = inout(reg) passes => _, options(nomem, nostack)) };
    }
}

/// `passes` × [`BLOCK`] instructions and nothing else.
#[inline(always)]
fn straight_line(passes: u32) {
    // SAFETY: a register-only loop (`nop`s, `subs`, `bne`; passes >= 1).
    unsafe { asm!("2:", ".rept 100", "nop", ".endr", "subs {n}, #1", "bne 2b", n = inout(reg) passes => _, options(nomem, nostack)) };
}
