//! embassy-time driver on the Cortex-M SysTick: one interrupt per
//! millisecond advances a 64-bit microsecond counter (embassy-time's default
//! 1 MHz tick, the core's unit) and checks embassy-time-queue-utils' timer
//! queue. Timers therefore fire on the first millisecond boundary at or after
//! their deadline. SysTick is in every Cortex-M core and in QEMU, so both
//! boards share it. The STM32 board puts back the milliseconds a flash
//! operation with interrupts masked would lose ([`account_stall`]).

use core::cell::{Cell, RefCell};
use core::task::Waker;

use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::exception;
use critical_section::Mutex;
use embassy_time_driver::Driver;
use embassy_time_queue_utils::Queue;

struct SysTickDriver {
    ticks: Mutex<Cell<u64>>,
    queue: Mutex<RefCell<Queue>>,
}

impl Driver for SysTickDriver {
    fn now(&self) -> u64 {
        critical_section::with(|cs| self.ticks.borrow(cs).get())
    }

    fn schedule_wake(&self, at: u64, waker: &Waker) {
        critical_section::with(|cs| {
            // Never borrowed elsewhere inside this critical section.
            let Ok(mut queue) = self.queue.borrow(cs).try_borrow_mut() else { return };
            if queue.schedule_wake(at, waker) {
                // Wakes at once what is already due instead of a tick later.
                queue.next_expiration(self.ticks.borrow(cs).get());
            }
        });
    }
}

embassy_time_driver::time_driver_impl!(static DRIVER: SysTickDriver = SysTickDriver {
    ticks: Mutex::new(Cell::new(0)),
    queue: Mutex::new(RefCell::new(Queue::new())),
});

/// SysTick interrupts per second.
const INTERRUPT_HZ: u32 = 1_000;
/// embassy-time ticks per SysTick interrupt.
const TICKS_PER_INTERRUPT: u64 = embassy_time_driver::TICK_HZ / INTERRUPT_HZ as u64;

/// Core clock cycles per microsecond (set by [`init`]).
#[cfg(feature = "board-stm32f103")]
static CYCLES_PER_US: core::sync::atomic::AtomicU32 = core::sync::atomic::AtomicU32::new(1);

/// Starts the clock: SysTick counts the core clock `core_hz` and interrupts
/// once a millisecond.
pub fn init(mut syst: SYST, core_hz: u32) {
    #[cfg(feature = "board-stm32f103")]
    CYCLES_PER_US.store((core_hz / 1_000_000).max(1), core::sync::atomic::Ordering::Relaxed);
    let reload = core_hz / INTERRUPT_HZ;
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(reload.saturating_sub(1));
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
}

/// Puts back the time of a stall with interrupts masked (`cycles` core
/// cycles, measured with the cycle counter): SysTick's pending bit holds one
/// interrupt, so a masked window of n ms would lose n − 1 ms. The STM32's
/// flash erase and program (inside a parameter store, in a critical
/// section) are such stalls; the CPU is not asleep during them, so the cycle
/// counter counts them. The pending interrupt still adds its millisecond,
/// so a store leaves the clock at most about 1 ms ahead.
#[cfg(feature = "board-stm32f103")]
pub fn account_stall(cycles: u32) {
    let per_us = CYCLES_PER_US.load(core::sync::atomic::Ordering::Relaxed).max(1);
    critical_section::with(|cs| {
        let ticks = DRIVER.ticks.borrow(cs);
        ticks.set(ticks.get().wrapping_add(u64::from(cycles / per_us)));
    });
}

#[exception]
fn SysTick() {
    critical_section::with(|cs| {
        let ticks = DRIVER.ticks.borrow(cs);
        let now = ticks.get().wrapping_add(TICKS_PER_INTERRUPT);
        ticks.set(now);
        if let Ok(mut queue) = DRIVER.queue.borrow(cs).try_borrow_mut() {
            queue.next_expiration(now);
        }
    });
}
