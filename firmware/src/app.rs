//! Glue between a board and the core, the same on every board: the shared
//! node, the CANopen task and the application slot.
//!
//! The CANopen task is embassy-net's runner in miniature (style guide §2.4):
//! wait on `select(rx.receive(), board event, Timer::at(deadline))`, feed the
//! core, run its timers, then let the board drain the transmit queue. The
//! board only moves frames and reports controller events (RX overrun, bus-off
//! recovered); which EMCY codes those become is decided here, not in the
//! board.

use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, Ordering};

use canopen_core::frame::CanFrame;
use canopen_core::node::{Application, Node};
use canopen_core::od::{ObjectDictionary, OdError};
use canopen_core::services::nmt::State;
use canopen_core::storage::Storage;
use canopen_core::time::{Duration, Instant};
use canopen_core::wire::emcy::code;
use embassy_futures::select::{Either3, select3};
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use embassy_sync::signal::Signal;
use embassy_time::Timer;

/// Frames the receive channel buffers between the driver and the CANopen task.
pub const RX_QUEUE: usize = 16;

/// How long a transient controller error (RX overrun, bus-off recovered)
/// stays active without recurring before it is cleared ("error reset").
pub const TRANSIENT_ERROR_HOLD: Duration = Duration::from_secs(1);

/// 0x1000 Device type (CiA 301 §7.5.2.1), read by the application slot.
const DEVICE_TYPE: u16 = 0x1000;

defmt::timestamp!("{=u64:us}", embassy_time::Instant::now().as_ticks());

/// What a board and the application slot need from a node, whatever its
/// dictionary: a [`Node`] behind a trait object, so the tasks below are not
/// generic (embassy tasks cannot be).
pub trait CanNode: Send {
    /// [`Node::on_frame`].
    fn on_frame(&mut self, now: Instant, frame: &CanFrame);
    /// [`Node::process`].
    fn process(&mut self, now: Instant) -> Option<Instant>;
    /// [`Node::transmit`].
    fn transmit(&mut self) -> Option<CanFrame>;
    /// [`Node::requeue`].
    fn requeue(&mut self, frame: CanFrame);
    /// [`Node::raise_error`].
    fn raise_error(&mut self, code: u16, info: [u8; 5]);
    /// [`Node::clear_error`].
    fn clear_error(&mut self, code: u16);
    /// [`Node::state`].
    fn state(&self) -> State;
    /// [`Node::node_id`].
    fn node_id(&self) -> u8;
    /// Reads an object as an SDO upload would; returns its length in `buf`.
    fn read(&self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, OdError>;
    /// Writes an object as an SDO download would (access, length and limits checked).
    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), OdError>;
}

impl<O, A, S, const R: usize, const T: usize, const HB: usize> CanNode for Node<O, A, S, R, T, HB>
where
    O: ObjectDictionary + Send,
    A: Application + Send,
    S: Storage + Send,
{
    fn on_frame(&mut self, now: Instant, frame: &CanFrame) {
        Node::on_frame(self, now, frame);
    }

    fn process(&mut self, now: Instant) -> Option<Instant> {
        Node::process(self, now)
    }

    fn transmit(&mut self) -> Option<CanFrame> {
        Node::transmit(self)
    }

    fn requeue(&mut self, frame: CanFrame) {
        Node::requeue(self, frame);
    }

    fn raise_error(&mut self, code: u16, info: [u8; 5]) {
        Node::raise_error(self, code, info);
    }

    fn clear_error(&mut self, code: u16) {
        Node::clear_error(self, code);
    }

    fn state(&self) -> State {
        Node::state(self)
    }

    fn node_id(&self) -> u8 {
        Node::node_id(self)
    }

    fn read(&self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, OdError> {
        let od = self.od();
        let value = od.dictionary().read(od.image(), index, sub)?;
        let n = value.len().min(buf.len());
        buf.get_mut(..n).ok_or(OdError::TooLong)?.copy_from_slice(value.get(..n).ok_or(OdError::TooLong)?);
        Ok(n)
    }

    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), OdError> {
        let od = self.od_mut();
        od.dictionary().write(od.image_mut(), index, sub, data)
    }
}

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
}

/// The one [`Shared`] of an image.
pub static SHARED: Shared = Shared {
    node: Mutex::new(RefCell::new(None)),
    rx: Channel::new(),
    state: Signal::new(),
    events: Signal::new(),
    rx_overruns: AtomicU32::new(0),
    bus_off_recoveries: AtomicU32::new(0),
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

/// The CANopen task: feeds received frames and board events to the node,
/// runs its timers, and calls `kick_tx` whenever the transmit queue may hold
/// frames for the controller.
pub async fn run_canopen(shared: &'static Shared, kick_tx: fn()) -> ! {
    let mut overrun = TransientError::new(code::CAN_OVERRUN);
    let mut bus_off = TransientError::new(code::BUS_OFF_RECOVERED);
    let mut last_state = None;
    loop {
        let now = now();
        let step = shared.with_node(|node| {
            overrun.update(shared.rx_overruns.load(Ordering::Relaxed), now, node);
            bus_off.update(shared.bus_off_recoveries.load(Ordering::Relaxed), now, node);
            (node.process(now), node.state())
        });
        let (deadline, state) = step.unwrap_or((None, State::Initialising));
        kick_tx();
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

/// The application slot: where a device profile will run beside the CANopen
/// task, reading and writing the dictionary through the node. For now it
/// reports the node's identity and follows its NMT state.
pub async fn run_application(shared: &'static Shared) -> ! {
    let mut buf = [0u8; 4];
    let identity = shared.with_node(|node| (node.node_id(), node.read(DEVICE_TYPE, 0, &mut buf).is_ok()));
    if let Some((node_id, true)) = identity {
        defmt::info!("node {=u8}: device type {=u32:#010x}", node_id, u32::from_le_bytes(buf));
    }
    loop {
        let state = shared.state.wait().await;
        defmt::info!("NMT state {=u8:#04x}", state.reported().code());
    }
}
