//! Glue between a board and the core, the same on every board: the shared
//! node, the CANopen task and the application slot.
//!
//! The CANopen task is embassy-net's runner in miniature (style guide §2.4):
//! wait on `select(rx.receive(), board event, Timer::at(deadline))`, feed the
//! core, run its timers, then let the board drain the transmit queue. The
//! board only moves frames, reports controller events (RX overrun, bus-off
//! recovered) and applies what the node asks of its controller through
//! [`Controller`] (acceptance filter, LSS bit rate); which EMCY codes the
//! events become is decided here, not in the board.

use core::any::Any;
use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, Ordering};

use canopen_core::frame::CanFrame;
use canopen_core::node::{AcceptanceList, BitRateControl};
use canopen_core::services::nmt::State;
use canopen_core::time::{Duration, Instant};
use canopen_core::wire::emcy::code;
use embassy_futures::select::{Either3, select3};
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use embassy_sync::signal::Signal;
use embassy_time::Timer;

pub use crate::can_node::{CanNode, od_mut};

/// Frames the receive channel buffers between the driver and the CANopen task.
pub const RX_QUEUE: usize = 16;

/// How long a transient controller error (RX overrun, bus-off recovered)
/// stays active without recurring before it is cleared ("error reset").
pub const TRANSIENT_ERROR_HOLD: Duration = Duration::from_secs(1);

defmt::timestamp!("{=u64:us}", embassy_time::Instant::now().as_ticks());

/// Everything the board's interrupts and tasks share with the CANopen task.
pub struct Shared {
    node: Mutex<CriticalSectionRawMutex, RefCell<Option<&'static mut dyn CanNode>>>,
    /// Frames received from the bus, oldest first.
    pub rx: Channel<CriticalSectionRawMutex, CanFrame, RX_QUEUE>,
    /// The NMT state, each time it changes (for the application slot).
    pub state: Signal<CriticalSectionRawMutex, State>,
    events: Signal<CriticalSectionRawMutex, ()>,
    rx_overruns: AtomicU32,
    bus_off_recoveries: AtomicU32,
    rejected: AtomicU32,
}

/// The one [`Shared`] of an image.
pub static SHARED: Shared = Shared {
    node: Mutex::new(RefCell::new(None)),
    rx: Channel::new(),
    state: Signal::new(),
    events: Signal::new(),
    rx_overruns: AtomicU32::new(0),
    bus_off_recoveries: AtomicU32::new(0),
    rejected: AtomicU32::new(0),
};

impl Shared {
    /// Hands the node to the tasks (once, before they start).
    pub fn install(&self, node: &'static mut dyn CanNode) {
        self.node.lock(|cell| {
            if let Ok(mut slot) = cell.try_borrow_mut() {
                *slot = Some(node);
            }
        });
    }

    /// Runs `f` on the node inside a critical section; `None` before
    /// [`Shared::install`] (or if called re-entrantly).
    pub fn with_node<R>(&self, f: impl FnOnce(&mut dyn CanNode) -> R) -> Option<R> {
        self.node.lock(|cell| {
            let mut node = cell.try_borrow_mut().ok()?;
            let node: &mut dyn CanNode = node.as_deref_mut()?;
            Some(f(node))
        })
    }

    /// Runs `f` on the node's dictionary as the device's generated type
    /// `O` ([`od_mut`]); `None` if the node runs another dictionary (or as
    /// [`Shared::with_node`]).
    pub fn with_od<O: Any, R>(&self, f: impl FnOnce(&mut O) -> R) -> Option<R> {
        self.with_node(|node| od_mut::<O>(node).map(f)).flatten()
    }

    /// The board's software acceptance filter dropped a frame.
    pub fn rejected(&self) {
        self.rejected.fetch_add(1, Ordering::Relaxed);
    }

    /// Frames the software acceptance filter dropped so far (for logs).
    pub fn rejected_frames(&self) -> u32 {
        self.rejected.load(Ordering::Relaxed)
    }

    /// A received frame was lost (controller FIFO or [`Shared::rx`] full).
    pub fn rx_overrun(&self) {
        self.rx_overruns.fetch_add(1, Ordering::Relaxed);
        self.events.signal(());
    }

    /// The controller left bus-off and takes part in bus traffic again.
    pub fn bus_off_recovered(&self) {
        self.bus_off_recoveries.fetch_add(1, Ordering::Relaxed);
        self.events.signal(());
    }

    /// Frames lost so far (for logs and tests).
    pub fn rx_overruns(&self) -> u32 {
        self.rx_overruns.load(Ordering::Relaxed)
    }
}

// embassy-time counts microseconds (its default tick rate), as the core
// does, so instants convert without arithmetic.
const _: () = assert!(embassy_time::TICK_HZ == 1_000_000, "embassy-time ticks must be microseconds");

/// The time as the core sees it.
pub fn now() -> Instant {
    Instant::from_micros(embassy_time::Instant::now().as_ticks())
}

fn to_embassy(t: Instant) -> embassy_time::Instant {
    embassy_time::Instant::from_ticks(t.as_micros())
}

/// Converts between the frame types of the core and of a driver (both
/// `embedded_can::Frame`); `None` only if `G` cannot carry the frame.
pub fn convert_frame<F: embedded_can::Frame, G: embedded_can::Frame>(frame: &F) -> Option<G> {
    if frame.is_remote_frame() { G::new_remote(frame.id(), frame.dlc()) } else { G::new(frame.id(), frame.data()) }
}

/// A controller error with no lasting state of its own: raised when its
/// counter moves, cleared once it stayed quiet for [`TRANSIENT_ERROR_HOLD`].
struct TransientError {
    code: u16,
    seen: u32,
    clear_at: Option<Instant>,
}

impl TransientError {
    const fn new(code: u16) -> Self {
        TransientError { code, seen: 0, clear_at: None }
    }

    fn update(&mut self, count: u32, now: Instant, node: &mut dyn CanNode) {
        if count != self.seen {
            self.seen = count;
            // Manufacturer-specific field: how many times it happened so far.
            let [a, b, c, d] = count.to_le_bytes();
            node.raise_error(self.code, [a, b, c, d, 0]);
            self.clear_at = Some(now + TRANSIENT_ERROR_HOLD);
        } else if self.clear_at.is_some_and(|t| t <= now) {
            node.clear_error(self.code);
            self.clear_at = None;
        }
    }
}

/// What an image's start-up hands its board.
pub struct Started {
    /// The node, for [`Shared::install`].
    pub node: &'static mut dyn CanNode,
    /// The bit rate (CiA 305 table index) the device's own stored
    /// parameters give, if it has such (a bit rate LSS stored comes first:
    /// [`CanNode::bit_rate`]).
    pub bit_rate: Option<u8>,
}

impl Started {
    /// Runs an image's `make_node` (which powers on the node built in its
    /// `static`) with the storage handle `handle` makes, in a stack frame of
    /// its own. What the power-on takes from the stack is free again once
    /// this returns, before the board starts its executors, whose frames
    /// then sit on top of the board's `run` for good.
    #[inline(never)]
    pub fn build<H>(make_node: impl FnOnce(H, Instant) -> Started, handle: impl FnOnce() -> H, now: Instant) -> Started {
        make_node(handle(), now)
    }
}

/// What the CANopen task needs from the board's CAN controller (or SLCAN
/// link), besides the LSS bit-rate switch.
pub trait Controller: BitRateControl {
    /// The node's transmit queue may hold frames for the controller.
    fn kick_tx(&mut self);
    /// The node consumes another set of identifiers (and once at start):
    /// program the acceptance filter for `list`.
    fn set_acceptance(&mut self, list: &AcceptanceList);
}

/// The CANopen task: feeds received frames and board events to the node,
/// runs its timers, hands the controller a bit-rate switch when the node's
/// LSS delay says so and a new acceptance list when its generation moves,
/// and kicks the transmitter whenever the queue may hold frames.
pub async fn run_canopen(shared: &'static Shared, controller: &mut impl Controller) -> ! {
    let mut overrun = TransientError::new(code::CAN_OVERRUN);
    let mut bus_off = TransientError::new(code::BUS_OFF_RECOVERED);
    let mut last_state = None;
    let mut applied = None;
    loop {
        let now = now();
        let step = shared.with_node(|node| {
            overrun.update(shared.rx_overruns.load(Ordering::Relaxed), now, node);
            bus_off.update(shared.bus_off_recoveries.load(Ordering::Relaxed), now, node);
            let deadline = node.process(now);
            if let Some(index) = node.take_bit_rate_change() {
                controller.set_bit_rate(index);
            }
            // Every frame that can move the list passes through here next.
            let list = node.acceptance();
            if applied != Some(list.generation()) {
                applied = Some(list.generation());
                controller.set_acceptance(list);
            }
            (deadline, node.state())
        });
        let (deadline, state) = step.unwrap_or((None, State::Initialising));
        controller.kick_tx();
        if last_state != Some(state) {
            last_state = Some(state);
            shared.state.signal(state);
        }
        let wake = [deadline, overrun.clear_at, bus_off.clear_at].into_iter().flatten().min();
        let timer = Timer::at(wake.map_or(embassy_time::Instant::MAX, to_embassy));
        if let Either3::First(frame) = select3(shared.rx.receive(), shared.events.wait(), timer).await {
            let now = self::now();
            shared.with_node(|node| node.on_frame(now, &frame));
            // Whatever else arrived meanwhile, one frame per critical section.
            while let Ok(frame) = shared.rx.try_receive() {
                shared.with_node(|node| node.on_frame(now, &frame));
            }
        }
    }
}

/// The application slot, one task per image ([`crate::image!`] spawns it
/// with the device's dictionary type `O`): where a device profile runs
/// beside the CANopen task, reading and writing the dictionary through the
/// generated accessors ([`Shared::with_od`]) and waking the event-driven
/// TPDOs it changed ([`CanNode::trigger_tpdo`]). Today it reports the
/// device type, read through `device_type` (the generated accessor of
/// 0x1000), and follows the NMT state.
pub async fn run_application<O: Any>(shared: &'static Shared, device_type: fn(&O) -> u32) -> ! {
    let identity = shared.with_node(|node| (node.node_id(), od_mut::<O>(node).map(|od| device_type(od))));
    if let Some((node_id, Some(device_type))) = identity {
        defmt::info!("node {=u8}: device type {=u32:#010x}", node_id, device_type);
    }
    loop {
        let state = shared.state.wait().await;
        defmt::info!("NMT state {=u8:#04x}", state.reported().code());
    }
}
