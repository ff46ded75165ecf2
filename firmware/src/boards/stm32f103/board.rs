//! Start-up and tasks of the STM32F103C8 board.
#![allow(unsafe_code)]

use canopen_core::node::{AcceptanceList, BitRateControl};
use canopen_core::services::store;
use canopen_core::time::Instant;
use canopen_core::wire::emcy::EmcyCode;
use cortex_m::peripheral::{DCB, DWT, NVIC, SCB};
use cortex_m_rt::{ExceptionFrame, exception};
use defmt_rtt as _;
use embassy_executor::{Executor, InterruptExecutor, SpawnError, SpawnToken};
use embassy_time::Timer;
use static_cell::StaticCell;
use stm32f1xx_hal::flash::{FlashExt, FlashSize, SectorSize};
use stm32f1xx_hal::gpio::GpioExt;
use stm32f1xx_hal::pac::{self, Interrupt, interrupt};
use stm32f1xx_hal::prelude::*;
use stm32f1xx_hal::rcc;
use stm32f1xx_hal::watchdog::IndependentWatchdog;

use super::bit_timing;
use super::can;
use super::flash::Flash;
use super::flash_storage::{FlashStorage, HalfWordFlash, Layout};
use super::reset_cause::{self, ResetCause};
use crate::app::{self, CanNode, Controller, SHARED, Started};
use crate::boards::{stack, systick};

/// What differs between images on this board.
#[derive(Clone, Copy, Debug)]
pub struct Config {
    /// CAN bit rate in kbit/s (one of the CiA 305 rates the device
    /// supports) when neither LSS nor the device's own start-up settings give one.
    pub bit_rate_kbps: u32,
    /// The EMCY code of a restart the firmware did not ask for (watchdog,
    /// panic, HardFault), see [`ResetCause::emcy`].
    pub restart_emcy: EmcyCode,
}

impl Config {
    /// 250 kbit/s; CiA 301's 0x6100 "internal software" for a restart.
    pub const DEFAULT: Config = Config { bit_rate_kbps: 250, restart_emcy: EmcyCode::INTERNAL_SOFTWARE };
}

/// Two regions of flash pages, each holding a set of `REGION` bytes.
pub type Storage<const REGION: usize> = FlashStorage<Flash<REGION>>;

/// What the storage needs at start-up: the constrained FLASH peripheral.
pub type StorageHandle = stm32f1xx_hal::flash::Parts;

/// The storage before start-up, for the image's node built in a `const`.
pub const fn unattached_storage<const REGION: usize>() -> Storage<REGION> {
    FlashStorage::new(Flash::<REGION>::UNATTACHED)
}

impl<const REGION: usize> Storage<REGION> {
    /// Hands the storage its flash controller (before the node's power-on)
    /// and logs the sets it holds.
    pub fn attach(&mut self, mut handle: StorageHandle) {
        log_stored_sets(&mut handle, self.flash().layout());
        self.flash_mut().attach(handle);
    }
}

/// The Blue Pill's crystal.
const HSE_HZ: u32 = 8_000_000;
/// Core clock (the STM32F103 maximum).
const SYSCLK_HZ: u32 = 72_000_000;
/// APB1, which clocks bxCAN (36 MHz is its maximum).
const PCLK1_HZ: u32 = 36_000_000;
/// BTR per CiA 305 bit-rate index at [`PCLK1_HZ`] (what `rcc::Config`
/// below gets exactly: SYSCLK / 2), computed at compile time.
const BTR: [Option<u32>; 9] = bit_timing::table(PCLK1_HZ);
/// Priority of the CAN interrupts. STM32F1 implements 4 priority bits, the
/// top of the byte: this is level 1, below SysTick (level 0). They only
/// move frames and count events, so they may preempt the CANopen task and
/// empty bxCAN's 3-frame FIFO while the node works.
const CAN_PRIORITY: u8 = 1 << 4;
/// Priority of the CANopen task's executor: level 2, below the CAN
/// interrupts and above thread mode (the application slot).
const EXECUTOR_PRIORITY: u8 = 2 << 4;
/// The CANopen executor runs in the tamper interrupt's handler; the tamper
/// pin is not used.
const EXECUTOR_IRQ: Interrupt = Interrupt::TAMPER;
/// The CAN interrupts.
const CAN_IRQS: [Interrupt; 3] = [Interrupt::USB_HP_CAN_TX, Interrupt::USB_LP_CAN_RX0, Interrupt::CAN_SCE];

static CANOPEN_EXECUTOR: InterruptExecutor = InterruptExecutor::new();
static THREAD_EXECUTOR: StaticCell<Executor> = StaticCell::new();

/// The independent watchdog's timeout. It must cover the longest time the
/// CANopen executor may not run: a parameter store (about 120 ms at worst
/// with interrupts masked, docs/firmware.md "Storage") is the longest. The
/// LSI clocking it runs at 30–60 kHz, so the HAL's 40 kHz-based 1 s is
/// 0.67–1.3 s.
const WATCHDOG_MS: u32 = 1000;
/// How often the CANopen executor feeds the watchdog.
const FEED_MS: u64 = 250;
/// How long the crystal may take to start (datasheet: 2 ms typical).
const HSE_TIMEOUT_MS: u32 = 100;
/// The clock the core runs on before the PLL: HSI, 8 MHz.
const HSI_HZ: u32 = 8_000_000;

/// Boots the image: watchdog, clocks, time, then `make_node` hands the
/// node's storage the flash controller and powers the node on, and the CAN
/// controller starts at the node's bit rate: the one LSS stored, else the
/// device's start-up one, else `config.bit_rate_kbps`.
/// The CANopen task and the watchdog feeder run on the interrupt executor,
/// the image's `application` task in thread mode.
pub fn run<A>(
    config: Config,
    make_node: impl FnOnce(StorageHandle, Instant) -> Started,
    application: Result<SpawnToken<A>, SpawnError>,
) -> ! {
    stack::paint();
    let (Some(dp), Some(mut core)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else {
        defmt::panic!("peripherals taken twice")
    };
    let (cause, flags) = reset_cause::take(&dp.RCC);
    defmt::info!("reset: {} (RCC_CSR flags {=u8:#04x})", cause, flags);
    // First, so that every later wait ends in a reset at worst. A probe
    // halting the core stops it too.
    let mut watchdog = IndependentWatchdog::new(dp.IWDG);
    watchdog.stop_on_debug(&dp.DBGMCU, true);
    watchdog.start(WATCHDOG_MS.millis());
    // The cycle counter bounds the waits for hardware (crystal, bxCAN INAK).
    core.DCB.enable_trace();
    core.DWT.enable_cycle_counter();
    start_crystal(&dp.RCC);

    let mut flash = dp.FLASH.constrain();
    let clocks = rcc::Config::hse(HSE_HZ.Hz()).sysclk(SYSCLK_HZ.Hz()).pclk1(PCLK1_HZ.Hz());
    let mut rcc = dp.RCC.freeze(clocks, &mut flash.acr);
    defmt::info!("clock: HSE {=u32} Hz, SYSCLK {=u32} Hz, PCLK1 {=u32} Hz", HSE_HZ, rcc.clocks.sysclk().raw(), rcc.clocks.pclk1().raw());
    // The BTR table is computed for PCLK1_HZ.
    defmt::assert_eq!(rcc.clocks.pclk1().raw(), PCLK1_HZ);
    systick::init(core.SYST, rcc.clocks.sysclk().raw());
    let started = Started::build(make_node, || flash, app::now());
    // Why the last reset happened: an EMCY the node sends after its boot-up
    // (it waits for the call after the one that queues the boot-up).
    if let Some((code, info)) = cause.emcy(flags, config.restart_emcy) {
        started.node.raise_error(code, info);
        defmt::warn!("EMCY {=u16:#06x}: reset by {}", code.value(), cause);
    }
    let node_id = started.node.node_id();
    let lss = started.node.bit_rate();
    let index = lss.or(started.bit_rate).or_else(|| bit_timing::cia305_index(config.bit_rate_kbps));

    let btr = |index: Option<u8>| index.and_then(|i| BTR.get(usize::from(i)).copied().flatten().map(|btr| (i, btr)));
    // A stored index the board has no timing for (a reserved one) must not
    // keep the node off the bus: the image's own rate instead.
    let (index, btr) = match (btr(index), btr(bit_timing::cia305_index(config.bit_rate_kbps))) {
        (Some(found), _) => found,
        (None, Some(fallback)) => {
            defmt::error!("no bit timing for index {=u8}: {=u32} kbit/s instead", index.unwrap_or(0xFF), config.bit_rate_kbps);
            fallback
        }
        (None, None) => defmt::panic!("no bit timing for {=u32} kbit/s", config.bit_rate_kbps),
    };
    let gpioa = dp.GPIOA.split(&mut rcc);
    can::start(dp.CAN.can(dp.USB, (gpioa.pa12, gpioa.pa11), &mut rcc), btr);
    let source = if lss.is_some() {
        "LSS stored"
    } else if started.bit_rate.is_some() {
        "device start-up"
    } else {
        "image"
    };
    defmt::info!("node-id {=u8}, CAN bit rate index {=u8} ({=str}), BTR {=u32:#010x}", node_id, index, source, btr);

    for (irq, priority) in CAN_IRQS.map(|irq| (irq, CAN_PRIORITY)).into_iter().chain([(EXECUTOR_IRQ, EXECUTOR_PRIORITY)]) {
        // SAFETY: priorities are set before the interrupts are unmasked and
        // the executor starts; no critical section relies on priorities.
        unsafe { core.NVIC.set_priority(irq, priority) };
    }
    for irq in CAN_IRQS {
        // SAFETY: the handlers in `can` are linked in and find the
        // controller set up by `can::start`.
        unsafe { NVIC::unmask(irq) };
    }
    let spawner = CANOPEN_EXECUTOR.start(EXECUTOR_IRQ);
    spawner.spawn(spawned(canopen(started.node)));
    spawner.spawn(spawned(feed_watchdog(watchdog, cause.emcy(flags, config.restart_emcy).map(|(code, _)| code))));
    THREAD_EXECUTOR.init(Executor::new()).run(|spawner| {
        spawner.spawn(spawned(application));
    })
}

/// Starts the crystal and waits for it at most [`HSE_TIMEOUT_MS`]. One that
/// does not start leaves the chip here, logged, until the watchdog resets
/// it for another try (the HAL's own wait would hang silently); the reset
/// that finally starts it reports EMCY 0x5000.
fn start_crystal(rcc: &pac::RCC) {
    rcc.cr().modify(|_, w| w.hseon().set_bit());
    let start = DWT::cycle_count();
    while rcc.cr().read().hserdy().bit_is_clear() {
        if DWT::cycle_count().wrapping_sub(start) > HSE_TIMEOUT_MS * (HSI_HZ / 1000) {
            defmt::error!("HSE: the 8 MHz crystal did not start in {=u32} ms; off the bus until the watchdog resets", HSE_TIMEOUT_MS);
            reset_cause::leave(ResetCause::Crystal);
            loop {
                cortex_m::asm::wfi();
            }
        }
    }
}

/// Logs the stored parameter sets the node will look at (header only: the
/// node checks the CRC when it loads).
fn log_stored_sets(flash: &mut stm32f1xx_hal::flash::Parts, layout: Layout) {
    let writer = flash.writer(SectorSize::Sz1K, FlashSize::Sz64K);
    for region in 0..2u32 {
        let at = layout.base + region * layout.stride;
        let header = writer.read(at, 16).ok().and_then(|h| h.try_into().ok()).map(|h: [u8; 16]| h);
        match header {
            Some([m0, m1, m2, m3, _, _, _, _, _, _, _, _, s0, s1, s2, s3]) if u32::from_le_bytes([m0, m1, m2, m3]) == store::MAGIC => {
                defmt::info!("storage: parameter set in region {=u32}, sequence {=u32}", region, u32::from_le_bytes([s0, s1, s2, s3]));
            }
            _ => defmt::info!("storage: region {=u32} holds no parameter set", region),
        }
    }
}

fn spawned<T>(token: Result<T, SpawnError>) -> T {
    match token {
        Ok(token) => token,
        Err(_) => defmt::panic!("task spawned twice"),
    }
}

/// bxCAN as the CANopen task drives it.
struct Bxcan;

impl BitRateControl for Bxcan {
    fn set_bit_rate(&mut self, index: u8) {
        // The LSS slave accepts only the indices the EDS lists, all in the table.
        let Some(btr) = BTR.get(usize::from(index)).copied().flatten() else { return };
        match can::set_bit_timing(btr, SYSCLK_HZ / 1000 * can::INIT_TIMEOUT_MS) {
            Ok(()) => defmt::info!("LSS: CAN now at bit rate index {=u8}, BTR {=u32:#010x}", index, btr),
            Err(()) => defmt::error!(
                "LSS: bxCAN did not enter initialisation mode in {=u32} ms (bus not idle): bit rate unchanged",
                can::INIT_TIMEOUT_MS
            ),
        }
    }
}

impl Controller for Bxcan {
    fn send(&mut self, node: &mut dyn CanNode) {
        can::send(node);
    }

    fn set_acceptance(&mut self, list: &AcceptanceList) {
        can::set_filters(list.ids(), list.is_complete());
    }
}

#[embassy_executor::task]
async fn canopen(node: &'static mut dyn CanNode) -> ! {
    app::run_canopen(&SHARED, node, &mut Bxcan).await
}

/// Feeds the watchdog every [`FEED_MS`] from the CANopen task's executor:
/// while the CANopen task runs in a loop or hangs with interrupts masked,
/// the executor never gets here and the watchdog resets the chip. Once the
/// node has sent its boot-up, the EMCY `run` raised for the cause of the
/// last reset is cleared again a second later (the 0x1003 entry stays).
#[embassy_executor::task]
async fn feed_watchdog(mut watchdog: IndependentWatchdog, reset_emcy: Option<EmcyCode>) -> ! {
    // Raised on the node at start-up (`run`); cleared a second after the boot-up.
    let mut clear = reset_emcy.map(|code| (code, 4u8));
    let mut stack_used = 0;
    let mut tick = 0u32;
    loop {
        watchdog.feed();
        // The stack's high-water mark, when it grew (checked every 10 s: a scan of the free RAM).
        if tick.is_multiple_of(40) {
            let used = stack::high_water();
            if used > stack_used {
                stack_used = used;
                defmt::info!("stack: {=usize} of {=usize} bytes used at most", used, stack::size());
            }
        }
        tick = tick.wrapping_add(1);
        if let Some((code, ticks)) = clear {
            clear = if ticks == 0 {
                SHARED.clear_board_error(code);
                None
            } else {
                Some((code, ticks - 1))
            };
        }
        // Not `Timer::after`: its `Instant + Duration` brings core::fmt's str formatting (648 B).
        let next = embassy_time::Instant::now().as_ticks().saturating_add(FEED_MS * 1000);
        Timer::at(embassy_time::Instant::from_ticks(next)).await;
    }
}

#[interrupt]
fn TAMPER() {
    // SAFETY: this is the handler of the interrupt the executor was started
    // on, and nothing else calls `on_interrupt`.
    unsafe { CANOPEN_EXECUTOR.on_interrupt() }
}

/// Logs where it happened (without pulling `core::fmt` into the image the
/// way panic-probe's message printing does), then resets the chip, which
/// reports the panic after its boot-up. With a debugger attached it stops
/// with `udf` instead, as panic-probe does, so the probe shows the fault.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    match info.location() {
        Some(at) => defmt::error!("panic at {=str}:{=u32}", at.file(), at.line()),
        None => defmt::error!("panic"),
    }
    fatal(ResetCause::Panic)
}

/// A HardFault (a panic's `udf` under a debugger ends here too): logs the
/// PC and resets, as a panic does.
#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    defmt::error!("HardFault at pc {=u32:#010x}", frame.pc());
    fatal(ResetCause::HardFault)
}

fn fatal(cause: ResetCause) -> ! {
    // A probe halts here and shows the log; DHCSR.C_DEBUGEN stays set until
    // the next power-on, so a board reset after a debug session also stops.
    while DCB::is_debugger_attached() {
        cortex_m::asm::bkpt();
    }
    reset_cause::leave(cause);
    SCB::sys_reset()
}
