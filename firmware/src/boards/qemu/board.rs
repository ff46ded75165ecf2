//! Start-up and tasks of the QEMU board.
#![allow(unsafe_code)]

use core::cell::RefCell;
use core::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use cortex_m::interrupt::InterruptNumber;
use cortex_m::peripheral::NVIC;

use canopen_core::frame::CanFrame;
use canopen_core::node::{AcceptanceList, BitRateControl};
use canopen_core::time::Instant;
use cortex_m_rt::{ExceptionFrame, exception};
use cortex_m_semihosting::{debug, hio};
use critical_section::Mutex;
use defmt_semihosting as _;
use embassy_executor::{InterruptExecutor, SpawnError, SpawnToken, raw};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::{Channel as FrameChannel, TrySendError};
use embassy_sync::signal::Signal;
use embedded_can::Frame;
use lm3s6965::{Interrupt, interrupt};
use static_cell::StaticCell;

use super::ram_storage::RamStorage;
use super::slcan::reply;
use super::uart;
use crate::app::{self, CanNode, Controller, SHARED, Started};
use crate::boards::{stack, systick};
use crate::slcan::{self, BEL, ChannelState, Command, Decoder, FRAME_LINE};

/// Nothing to configure: the emulated bus has no bit rate.
#[derive(Clone, Copy, Debug)]
pub struct Config {}

impl Config {
    /// The only configuration.
    pub const DEFAULT: Config = Config {};
}

/// RAM standing in for flash.
pub type Storage<const REGION: usize> = RamStorage<REGION>;

/// What the storage gets at start-up: nothing (RAM).
pub use super::ram_storage::StorageHandle;

/// The storage before start-up, for the image's node built in a `const`.
pub const fn unattached_storage<const REGION: usize>() -> Storage<REGION> {
    RamStorage::new()
}

/// QEMU's lm3s6965evb clocks the core (and SysTick) at 12 MHz.
const CORE_HZ: u32 = 12_000_000;
/// The CANopen task's executor runs in the handler of GPIO port A, which
/// this board does not use otherwise.
const EXECUTOR_IRQ: Interrupt = Interrupt::GPIOA;
/// Its priority: above thread mode, below UART0 and SysTick (0, the
/// default). lm3s6965 implements 3 priority bits, the top of the byte.
const EXECUTOR_PRIORITY: u8 = 1 << 5;

static CANOPEN_EXECUTOR: InterruptExecutor = InterruptExecutor::new();
/// The thread-mode executor of the SLCAN transmitter and the application
/// task. Its own idle loop ([`run`]) sleeps with `WFI`: embassy's thread
/// executor idles with `WFE`, which QEMU runs as a yield, so the guest never
/// slept and its instruction-counted clock lagged the wall clock 1.35–3
/// times. A wake-up pends [`THREAD_IRQ`], whose handler sets [`THREAD_WOKEN`].
static THREAD_EXECUTOR: StaticCell<raw::Executor> = StaticCell::new();
/// Pended by the thread executor's pender (embassy's `__pender` pends the
/// interrupt whose number is the executor's context); unused otherwise.
const THREAD_IRQ: Interrupt = Interrupt::GPIOB;
/// Set by [`THREAD_IRQ`]'s handler: a thread-mode task was woken.
static THREAD_WOKEN: AtomicBool = AtomicBool::new(false);
/// Raised after every step of the CANopen task: the node may have run
/// (room in the receive channel again) and [`TX`] may hold frames.
static TX_READY: Signal<CriticalSectionRawMutex, ()> = Signal::new();
/// Frames the SLCAN transmitter writes out, filled by the CANopen task
/// from the node's queue while the channel is open.
static TX: FrameChannel<CriticalSectionRawMutex, CanFrame, TX_LINES> = FrameChannel::new();
/// Frames the CANopen task hands the SLCAN transmitter at a time.
const TX_LINES: usize = 4;
/// The node's identifier list as the CANopen task last published it, for
/// the UART0 handler's acceptance check ([`accepted`]).
static FILTER: Mutex<RefCell<AcceptanceList>> = Mutex::new(RefCell::new(AcceptanceList::new()));
/// Stack used until the node was built and powered on ([`stack::high_water`]).
static STARTUP_STACK: AtomicUsize = AtomicUsize::new(0);

/// Boots the image: `make_node` hands the node's storage its
/// [`StorageHandle`] and powers the node on at the given time; then the
/// CANopen task runs on the interrupt executor and owns the node, the SLCAN
/// transmitter and the image's `application` task run in thread mode.
pub fn run<A>(
    _config: Config,
    make_node: impl FnOnce(StorageHandle, Instant) -> Started,
    application: Result<SpawnToken<A>, SpawnError>,
) -> ! {
    stack::paint();
    let Some(mut core) = cortex_m::Peripherals::take() else { fail() };
    systick::init(core.SYST, CORE_HZ);
    let node = Started::build(make_node, || (), app::now()).node;
    STARTUP_STACK.store(stack::high_water(), Ordering::Relaxed);
    // What building the node took is free again: painted anew, the exit
    // frame reports what the running image needs.
    stack::paint();
    uart::init();
    // SAFETY: set before the executor starts (as `InterruptExecutor::start`
    // requires); no priority-based critical section depends on it.
    unsafe { core.NVIC.set_priority(EXECUTOR_IRQ, EXECUTOR_PRIORITY) };
    CANOPEN_EXECUTOR.start(EXECUTOR_IRQ).spawn(spawned(canopen(node)));
    let thread = THREAD_EXECUTOR.init(raw::Executor::new(usize::from(THREAD_IRQ.number()) as *mut ()));
    let spawner = thread.spawner();
    spawner.spawn(spawned(slcan_tx()));
    spawner.spawn(spawned(application));
    // SAFETY: its handler only sets a flag; the lowest priority (the reset
    // value 0 would put it above the CANopen executor, which is harmless
    // for a flag, but it never needs to preempt anything).
    unsafe {
        core.NVIC.set_priority(THREAD_IRQ, 7 << 5);
        NVIC::unmask(THREAD_IRQ);
    }
    loop {
        THREAD_WOKEN.store(false, Ordering::SeqCst);
        // SAFETY: polled only here, from thread mode, never re-entered.
        unsafe { thread.poll() };
        // A wake-up during the poll set the flag: poll again. Otherwise
        // sleep; with interrupts masked, a wake-up after the check still
        // ends the WFI (a pending interrupt does), and its handler runs
        // once they are unmasked.
        cortex_m::interrupt::free(|_| {
            if !THREAD_WOKEN.load(Ordering::SeqCst) {
                cortex_m::asm::wfi();
            }
        });
    }
}

fn spawned<T>(token: Result<T, SpawnError>) -> T {
    token.unwrap_or_else(|_| fail())
}

/// The SLCAN link as the CANopen task drives it. It has no bit timing, so
/// that setting only shows in the log; it filters in software
/// ([`accepted`]) with the list the task publishes here.
struct SlcanLink;

impl BitRateControl for SlcanLink {
    fn set_bit_rate(&mut self, index: u8) {
        defmt::info!("LSS: bit rate index {=u8} (an SLCAN link has no bit timing)", index);
    }
}

impl Controller for SlcanLink {
    /// While the channel is open, fills [`TX`] from the node's queue (while
    /// it is closed, frames wait in the node's queue, as on a bus nobody
    /// acknowledges); then lets the transmitter run.
    fn send(&mut self, node: &mut dyn CanNode) {
        while OPEN.load(Ordering::Relaxed) && !TX.is_full() {
            let Some(frame) = node.transmit() else { break };
            if let Err(TrySendError::Full(frame)) = TX.try_send(frame) {
                node.requeue(frame);
                break;
            }
        }
        TX_READY.signal(());
    }

    fn set_acceptance(&mut self, list: &AcceptanceList) {
        critical_section::with(|cs| {
            if let Ok(mut filter) = FILTER.borrow(cs).try_borrow_mut() {
                filter.clone_from(list);
            }
        });
        defmt::info!("acceptance filter: {=usize} identifiers, generation {=u32}", list.ids().len(), list.generation());
    }
}

#[embassy_executor::task]
async fn canopen(node: &'static mut dyn CanNode) -> ! {
    app::run_canopen(&SHARED, node, &mut SlcanLink).await
}

/// The software acceptance filter, what bxCAN's banks do on the STM32: an
/// 11-bit frame the node lists (`Node::acceptance`, as published in
/// [`FILTER`]), nothing else.
fn accepted(cs: critical_section::CriticalSection, frame: &CanFrame) -> bool {
    let Some(cob_id) = frame.cob_id() else { return false };
    FILTER.borrow(cs).try_borrow().is_ok_and(|filter| filter.accepts(cob_id, frame.is_remote_frame()))
}

/// The adapter side of SLCAN: the UART0 handler decodes host lines,
/// answers them and passes frames to the CANopen task; this task writes
/// out the frames the CANopen task put into [`TX`], and wakes it when it
/// made room.
#[embassy_executor::task]
async fn slcan_tx() -> ! {
    loop {
        TX_READY.wait().await;
        // The node has run since the handler paused: there may be room again.
        uart::resume_rx();
        let mut sent = false;
        while OPEN.load(Ordering::Relaxed) {
            let Ok(frame) = TX.try_receive() else { break };
            // On the stack, not in the task's state: no await while it lives.
            let mut line = [0u8; FRAME_LINE];
            let n = slcan::encode(&frame, None, &mut line);
            // One whole line: the handler's answers must not land inside it.
            critical_section::with(|_| uart::write_all(line.get(..n).unwrap_or(&[])));
            sent = true;
        }
        if sent {
            SHARED.wake();
        }
    }
}

/// The SLCAN adapter state the UART0 handler keeps.
struct Adapter {
    decoder: Decoder,
    channel: ChannelState,
}

static ADAPTER: Mutex<RefCell<Adapter>> = Mutex::new(RefCell::new(Adapter { decoder: Decoder::new(), channel: ChannelState::Closed }));
/// Whether the channel is open (or listen-only), for [`slcan_tx`].
static OPEN: AtomicBool = AtomicBool::new(false);

impl Adapter {
    fn on_byte(&mut self, cs: critical_section::CriticalSection, byte: u8) {
        let Some(result) = self.decoder.push(byte) else { return };
        let Ok(command) = result else {
            uart::write_all(&[BEL]);
            return;
        };
        let (next, answer) = reply(self.channel, &command);
        if next != self.channel {
            self.channel = next;
            OPEN.store(next != ChannelState::Closed, Ordering::Relaxed);
            // Open now: the CANopen task fills `TX` from the node's queue.
            SHARED.wake();
        }
        if let Command::Transmit(frame) = command
            && answer != [BEL]
        {
            if let Some(status) = super::exit_request(&frame) {
                exit(status);
            }
            if !accepted(cs, &frame) {
                SHARED.rejected();
            } else if SHARED.rx.try_send(frame).is_err() {
                // Cannot happen: the handler reads only while the channel has room.
                SHARED.rx_overrun();
            }
        }
        uart::write_all(answer);
    }
}

#[interrupt]
fn UART0() {
    critical_section::with(|cs| {
        let Ok(mut adapter) = ADAPTER.borrow(cs).try_borrow_mut() else { return };
        while !SHARED.rx.is_full() {
            let Some(byte) = uart::read_byte() else { break };
            adapter.on_byte(cs, byte);
        }
        if SHARED.rx.is_full() {
            // Resumed by `slcan_tx` once the CANopen task has run.
            uart::pause_rx();
        }
    });
    uart::clear_rx_interrupt();
}

/// Ends the QEMU run with exit code 0 (`status` 0) or 1, after reporting
/// the stack used (at start-up, and since): in the defmt log, and as a text
/// line on QEMU's stderr (semihosting), which a test reads without a defmt
/// decoder.
fn exit(status: u8) -> ! {
    defmt::info!(
        "exit frame: status {=u8}, {=u32} frames lost, {=u32} rejected by the filter",
        status,
        SHARED.controller.rx_overruns(),
        SHARED.rejected_frames()
    );
    let (startup, running, size) = (STARTUP_STACK.load(Ordering::Relaxed), stack::high_water(), stack::size());
    defmt::info!("stack: start-up {=usize} bytes, running {=usize} bytes of {=usize}", startup, running, size);
    if let Ok(mut stderr) = hio::hstderr() {
        let mut line = [0u8; super::EXIT_REPORT_LEN];
        let report = super::ExitReport {
            startup_stack: startup,
            running_stack: running,
            stack_size: size,
            rejected: SHARED.rejected_frames() as usize,
            lost: SHARED.controller.rx_overruns() as usize,
        };
        let n = super::exit_report(&mut line, &report);
        let _ = stderr.write_all(line.get(..n).unwrap_or(&[]));
    }
    debug::exit(if status == 0 { debug::EXIT_SUCCESS } else { debug::EXIT_FAILURE });
    fail()
}

/// Ends the QEMU run with exit code 1.
fn fail() -> ! {
    loop {
        debug::exit(debug::EXIT_FAILURE);
    }
}

#[interrupt]
fn GPIOB() {
    THREAD_WOKEN.store(true, Ordering::SeqCst);
}

#[interrupt]
fn GPIOA() {
    // SAFETY: this is the handler of the interrupt the executor was started
    // on, and nothing else calls `on_interrupt`.
    unsafe { CANOPEN_EXECUTOR.on_interrupt() }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    match info.location() {
        Some(at) => defmt::error!("panic at {=str}:{=u32}", at.file(), at.line()),
        None => defmt::error!("panic"),
    }
    fail()
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    defmt::error!("HardFault at pc {=u32:#010x}", frame.pc());
    fail()
}
