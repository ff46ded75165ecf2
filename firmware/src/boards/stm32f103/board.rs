//! Start-up and tasks of the STM32F103C8 board.
#![allow(unsafe_code)]

use canopen_core::node::{AcceptanceList, BitRateControl};
use canopen_core::time::Instant;
use cortex_m::peripheral::NVIC;
use defmt_rtt as _;
use embassy_executor::{Executor, InterruptExecutor, SpawnError, SpawnToken};
use static_cell::StaticCell;
use stm32f1xx_hal::flash::FlashExt;
use stm32f1xx_hal::gpio::GpioExt;
use stm32f1xx_hal::pac::{self, Interrupt, interrupt};
use stm32f1xx_hal::prelude::*;
use stm32f1xx_hal::rcc;

use super::bit_timing;
use super::can;
use super::flash::Flash;
use super::flash_storage::FlashStorage;
use crate::app::{self, CanNode, Controller, SHARED, Started};
use crate::boards::systick;

/// What differs between images on this board.
#[derive(Clone, Copy, Debug)]
pub struct Config {
    /// CAN bit rate in kbit/s (one of the CiA 305 rates the device
    /// supports) when neither LSS nor the device's own start-up settings give one.
    pub bit_rate_kbps: u32,
}

impl Config {
    /// 250 kbit/s.
    pub const DEFAULT: Config = Config { bit_rate_kbps: 250 };
}

/// Two regions of flash pages.
pub type Storage<const REGION: usize> = FlashStorage<Flash, REGION>;

/// What the storage needs at start-up: the constrained FLASH peripheral.
pub type StorageHandle = stm32f1xx_hal::flash::Parts;

/// The storage before start-up, for the image's node built in a `const`.
pub const fn unattached_storage<const REGION: usize>() -> Storage<REGION> {
    FlashStorage::new(Flash::UNATTACHED)
}

impl<const REGION: usize> Storage<REGION> {
    /// Hands the storage its flash controller (before the node's power-on).
    pub fn attach(&mut self, handle: StorageHandle) {
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

/// Boots the image: clocks, time, then `make_node` hands the node's
/// storage the flash controller and powers the node on, and the CAN
/// controller starts at the node's bit rate: the one LSS stored, else the
/// device's start-up one, else `config.bit_rate_kbps`.
/// The CANopen task runs on the interrupt executor, the image's
/// `application` task in thread mode.
pub fn run<A>(
    config: Config,
    make_node: impl FnOnce(StorageHandle, Instant) -> Started,
    application: Result<SpawnToken<A>, SpawnError>,
) -> ! {
    let (Some(dp), Some(mut core)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else {
        defmt::panic!("peripherals taken twice")
    };
    let mut flash = dp.FLASH.constrain();
    let clocks = rcc::Config::hse(HSE_HZ.Hz()).sysclk(SYSCLK_HZ.Hz()).pclk1(PCLK1_HZ.Hz());
    let mut rcc = dp.RCC.freeze(clocks, &mut flash.acr);
    systick::init(core.SYST, rcc.clocks.sysclk().raw());
    let started = Started::build(make_node, || flash, app::now());
    let index = started.node.bit_rate().or(started.bit_rate).or_else(|| bit_timing::cia305_index(config.bit_rate_kbps));

    // 0xFF: no table index (logs only).
    let index = index.unwrap_or(0xFF);
    let Some(btr) = BTR.get(usize::from(index)).copied().flatten() else {
        defmt::panic!("no bit timing for {=u32} kbit/s (index {=u8})", config.bit_rate_kbps, index)
    };
    let gpioa = dp.GPIOA.split(&mut rcc);
    can::start(dp.CAN.can(dp.USB, (gpioa.pa12, gpioa.pa11), &mut rcc), btr);
    defmt::info!("CAN at bit rate index {=u8}, BTR {=u32:#010x}", index, btr);

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
    CANOPEN_EXECUTOR.start(EXECUTOR_IRQ).spawn(spawned(canopen(started.node)));
    THREAD_EXECUTOR.init(Executor::new()).run(|spawner| {
        spawner.spawn(spawned(application));
    })
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
        if let Some(btr) = BTR.get(usize::from(index)).copied().flatten() {
            can::set_bit_timing(btr);
            defmt::info!("LSS: CAN now at bit rate index {=u8}, BTR {=u32:#010x}", index, btr);
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

#[interrupt]
fn TAMPER() {
    // SAFETY: this is the handler of the interrupt the executor was started
    // on, and nothing else calls `on_interrupt`.
    unsafe { CANOPEN_EXECUTOR.on_interrupt() }
}

/// Logs where it happened and stops with `udf`, as panic-probe does (a
/// debug probe reports the HardFault), without pulling `core::fmt` into
/// the image the way panic-probe's message printing does.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    match info.location() {
        Some(at) => defmt::error!("panic at {=str}:{=u32}", at.file(), at.line()),
        None => defmt::error!("panic"),
    }
    cortex_m::asm::udf()
}
