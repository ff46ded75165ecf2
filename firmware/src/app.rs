//! Glue between a board and the core, the same on every board: what the
//! interrupts and tasks share ([`SHARED`]), the CANopen task that owns the
//! node, and the application slot.
//!
//! The CANopen task is embassy-net's runner in miniature (style guide
//! §2.4): it owns the node, and waits on `select(received frame,
//! application request, controller event or room to send, Timer::at(deadline))`;
//! whatever woke it, it hands the node the frames or the request, then runs
//! a [`Runner::step`]. Interrupts only move frames through channels and
//! count controller events ([`ControllerStatus`]); the application only
//! sends [`Request`]s and reads the NMT states from a queue. No lock is
//! held while the node works.

use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, Ordering};

use canopen_core::abort::AbortCode;
use canopen_core::frame::CanFrame;
use canopen_core::services::nmt::State;
use canopen_core::time::Instant;
use embassy_futures::select::{Either4, select4};
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use embassy_sync::mutex::Mutex as AsyncMutex;
use embassy_sync::signal::Signal;
use embassy_time::Timer;

pub use crate::can_node::CanNode;
pub use crate::runner::{Controller, ControllerStatus, Reply, Request, Runner, StateQueue, Value};

/// Frames the receive channel buffers between the driver and the CANopen task.
pub const RX_QUEUE: usize = 16;
/// NMT states the application's queue holds: every frame of a full
/// receive channel can be an NMT command, and a reset is two states
/// (Initialising, then the state after the boot-up).
pub const STATE_QUEUE: usize = 2 * RX_QUEUE + 2;

defmt::timestamp!("{=u64:us}", embassy_time::Instant::now().as_ticks());

/// Everything the board's interrupts, the CANopen task and the application share.
pub struct Shared {
    /// Frames received from the bus, oldest first.
    pub rx: Channel<CriticalSectionRawMutex, CanFrame, RX_QUEUE>,
    /// What the controller's interrupts counted (each report also [`Shared::wake`]s the task).
    pub controller: ControllerStatus,
    requests: Channel<CriticalSectionRawMutex, Request, 1>,
    replies: Channel<CriticalSectionRawMutex, Reply, 1>,
    /// One request at a time, so each caller gets its own reply.
    caller: AsyncMutex<CriticalSectionRawMutex, ()>,
    states: Mutex<CriticalSectionRawMutex, RefCell<StateQueue<STATE_QUEUE>>>,
    state_changed: Signal<CriticalSectionRawMutex, ()>,
    wake: Signal<CriticalSectionRawMutex, ()>,
    rejected: AtomicU32,
}

/// The one [`Shared`] of an image.
pub static SHARED: Shared = Shared {
    rx: Channel::new(),
    controller: ControllerStatus::new(),
    requests: Channel::new(),
    replies: Channel::new(),
    caller: AsyncMutex::new(()),
    states: Mutex::new(RefCell::new(StateQueue::new())),
    state_changed: Signal::new(),
    wake: Signal::new(),
    rejected: AtomicU32::new(0),
};

impl Shared {
    /// Wakes the CANopen task: the controller reported an event
    /// ([`Shared::controller`]) or has room for frames again.
    pub fn wake(&self) {
        self.wake.signal(());
    }

    /// A received frame was lost (controller FIFO or [`Shared::rx`] full).
    pub fn rx_overrun(&self) {
        self.controller.rx_overrun();
        self.wake();
    }

    /// The board's software acceptance filter dropped a frame.
    pub fn rejected(&self) {
        self.rejected.fetch_add(1, Ordering::Relaxed);
    }

    /// Frames the software acceptance filter dropped so far (for logs).
    pub fn rejected_frames(&self) -> u32 {
        self.rejected.load(Ordering::Relaxed)
    }

    /// Sends `request` to the CANopen task, which runs at once (it
    /// preempts thread mode), and returns its answer.
    pub async fn call(&self, request: Request) -> Reply {
        let _one_at_a_time = self.caller.lock().await;
        self.requests.send(request).await;
        self.replies.receive().await
    }

    /// Reads an object of up to 8 bytes.
    pub async fn read(&self, index: u16, sub: u8) -> Result<Value, AbortCode> {
        match self.call(Request::Read { index, sub }).await {
            Reply::Value(value) => Ok(value),
            Reply::Refused(code) => Err(code),
            Reply::Done | Reply::NotTriggered => Err(AbortCode::General),
        }
    }

    /// Writes an object of up to 8 bytes as the device ([`Request::Write`]).
    pub async fn write(&self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        let Some(value) = Value::new(data) else { return Err(AbortCode::LengthTooHigh) };
        match self.call(Request::Write { index, sub, value }).await {
            Reply::Done => Ok(()),
            Reply::Refused(code) => Err(code),
            Reply::Value(_) | Reply::NotTriggered => Err(AbortCode::General),
        }
    }

    /// Sends event-driven TPDO `n` (0-based) now, inhibit time permitting;
    /// false if it is not valid or of another type.
    pub async fn trigger_tpdo(&self, n: u16) -> bool {
        self.call(Request::TriggerTpdo(n)).await == Reply::Done
    }

    /// Raises an application error (EMCY, error register, 0x1003).
    pub async fn raise_error(&self, code: u16, info: [u8; 5]) {
        self.call(Request::RaiseError { code, info }).await;
    }

    /// Clears an application error.
    pub async fn clear_error(&self, code: u16) {
        self.call(Request::ClearError(code)).await;
    }

    /// The next NMT state the node entered, in order: none is lost unless
    /// more than [`STATE_QUEUE`] wait (see [`StateQueue`]).
    pub async fn next_state(&self) -> State {
        loop {
            if let Some(state) = self.states.lock(|q| q.borrow_mut().pop()) {
                return state;
            }
            self.state_changed.wait().await;
        }
    }

    /// NMT states the application's queue had no room for.
    pub fn lost_states(&self) -> u32 {
        self.states.lock(|q| q.borrow().lost())
    }
}

/// The application's NMT state queue as the CANopen task fills it.
struct States(&'static Shared);

impl crate::runner::StateSink for States {
    fn entered(&mut self, state: State) {
        self.0.states.lock(|q| q.borrow_mut().entered(state));
        self.0.state_changed.signal(());
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

/// What an image's start-up hands its board.
pub struct Started {
    /// The node, for the CANopen task ([`run_canopen`]).
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

/// The CANopen task: owns `node`; whatever wakes it (a received frame, an
/// application request, a controller event or room to send, the node's
/// deadline) it hands the node, then runs a [`Runner::step`].
pub async fn run_canopen(shared: &'static Shared, node: &'static mut dyn CanNode, controller: &mut impl Controller) -> ! {
    let mut runner = Runner::new();
    let mut states = States(shared);
    loop {
        let now = now();
        runner.controller_events(node, now, &shared.controller);
        let deadline = runner.step(node, now, controller, &mut states);
        let timer = Timer::at(deadline.map_or(embassy_time::Instant::MAX, to_embassy));
        match select4(shared.rx.receive(), shared.requests.receive(), shared.wake.wait(), timer).await {
            Either4::First(frame) => {
                let now = self::now();
                runner.on_frame(node, now, &frame, &mut states);
                // Whatever else arrived meanwhile, before the next step.
                while let Ok(frame) = shared.rx.try_receive() {
                    runner.on_frame(node, now, &frame, &mut states);
                }
            }
            Either4::Second(request) => {
                let reply = runner.on_request(node, request);
                // The caller holds `caller` until it took this: there is room.
                let _ = shared.replies.try_send(reply);
            }
            Either4::Third(()) | Either4::Fourth(()) => {}
        }
    }
}

/// The application slot, one task per image ([`crate::image!`] spawns it):
/// where a device profile runs beside the CANopen task, reading and
/// writing objects and triggering TPDOs through [`Shared`]'s requests and
/// following the NMT state through [`Shared::next_state`]. Today it
/// reports the device type (0x1000) and each NMT state the node enters.
pub async fn run_application(shared: &'static Shared) -> ! {
    if let Ok(value) = shared.read(0x1000, 0).await {
        defmt::info!("device type {=[u8]:02x}", value.as_bytes());
    }
    loop {
        let state = shared.next_state().await;
        defmt::info!("NMT state {=u8:#04x} ({=u32} lost)", state.reported().code(), shared.lost_states());
    }
}
