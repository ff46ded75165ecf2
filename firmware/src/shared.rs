//! What the board's interrupts, the CANopen task and the application share
//! ([`Shared`]), the application's one [`Requests`] handle, and the
//! CANopen task's loop ([`serve`]) with its clock and timer as parameters:
//! `app` runs it on embassy-time, the unit tests below on the host with a
//! timer that never fires, so they show that a request alone wakes the task.
//!
//! The task owns the node; interrupts only move frames through
//! [`Shared::rx`] and count controller events ([`ControllerStatus`]); the
//! application only sends [`Request`]s and reads the NMT states from a
//! queue. No lock is held while the node works.

use core::cell::RefCell;
use core::future::Future;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use canopen_core::abort::AbortCode;
use canopen_core::frame::CanFrame;
use canopen_core::services::nmt::NmtState;
use canopen_core::time::Instant;
use canopen_core::wire::emcy::EmcyCode;
use embassy_futures::select::{Either3, select3};
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use embassy_sync::signal::Signal;

use crate::can_node::CanNode;
use crate::runner::{Controller, ControllerStatus, Reply, Request, Runner, StateQueue, StateSink, Value};

/// Frames the receive channel buffers between the driver and the CANopen task.
pub const RX_QUEUE: usize = 16;
/// NMT states the application's queue holds: every frame of a full
/// receive channel can be an NMT command, and a reset is two states
/// (Initialising, then the state after the boot-up).
pub const STATE_QUEUE: usize = 2 * RX_QUEUE + 2;

/// Everything the board's interrupts, the CANopen task and the application share.
pub struct Shared {
    /// Frames received from the bus, oldest first.
    pub rx: Channel<CriticalSectionRawMutex, CanFrame, RX_QUEUE>,
    /// What the controller's interrupts counted (each report also [`Shared::wake`]s the task).
    pub controller: ControllerStatus,
    /// The request of the one [`Requests`] handle, until the task takes it.
    request: Signal<CriticalSectionRawMutex, Request>,
    reply: Signal<CriticalSectionRawMutex, Reply>,
    requests_taken: AtomicBool,
    states: Mutex<CriticalSectionRawMutex, RefCell<StateQueue<STATE_QUEUE>>>,
    state_changed: Signal<CriticalSectionRawMutex, ()>,
    wake: Signal<CriticalSectionRawMutex, ()>,
    rejected: AtomicU32,
    /// An error the board raised at start-up, to clear (0x1_0000 | code; 0: none).
    board_clear: AtomicU32,
}

impl Default for Shared {
    fn default() -> Self {
        Self::new()
    }
}

impl Shared {
    /// Nothing received, requested or counted yet.
    pub const fn new() -> Self {
        Shared {
            rx: Channel::new(),
            controller: ControllerStatus::new(),
            request: Signal::new(),
            reply: Signal::new(),
            requests_taken: AtomicBool::new(false),
            states: Mutex::new(RefCell::new(StateQueue::new())),
            state_changed: Signal::new(),
            wake: Signal::new(),
            rejected: AtomicU32::new(0),
            board_clear: AtomicU32::new(0),
        }
    }

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

    /// Clears an error the board raised on the node before the task ran
    /// (the STM32's reset cause), at the task's next wake-up: the board's
    /// own way, beside the application's [`Requests`].
    pub fn clear_board_error(&self, code: EmcyCode) {
        self.board_clear.store(0x1_0000 | u32::from(code.value()), Ordering::Relaxed);
        self.wake();
    }

    /// The handle through which the application asks the node: the first
    /// call gets it, every later one `None`. One handle, borrowed mutably
    /// per request, so requests never overlap and no lock is needed.
    pub fn requests(&self) -> Option<Requests<'_>> {
        (!self.requests_taken.swap(true, Ordering::Relaxed)).then_some(Requests { shared: self })
    }

    /// The next NMT state the node entered, in order: none is lost unless
    /// more than [`STATE_QUEUE`] wait (see [`StateQueue`]).
    pub async fn next_state(&self) -> NmtState {
        loop {
            // `try_borrow_mut`: `borrow_mut`'s panic message pulls `core::fmt` into the images.
            if let Some(state) = self.states.lock(|q| q.try_borrow_mut().ok()?.pop()) {
                return state;
            }
            self.state_changed.wait().await;
        }
    }
}

/// The application's way to the node ([`Shared::requests`]): each request
/// wakes the CANopen task, which (on the MCU) preempts thread mode, carries
/// it out, steps (so a triggered TPDO or an EMCY leaves at once) and replies.
pub struct Requests<'a> {
    shared: &'a Shared,
}

impl Requests<'_> {
    /// Sends `request` to the CANopen task and returns its answer.
    pub async fn call(&mut self, request: Request) -> Reply {
        // A reply left by a call that was dropped before it took it.
        self.shared.reply.reset();
        self.shared.request.signal(request);
        self.shared.wake();
        self.shared.reply.wait().await
    }

    /// Reads an object of up to 8 bytes.
    pub async fn read(&mut self, index: u16, sub: u8) -> Result<Value, AbortCode> {
        match self.call(Request::Read { index, sub }).await {
            Reply::Value(value) => Ok(value),
            Reply::Refused(code) => Err(code),
            Reply::Done | Reply::NotTriggered => Err(AbortCode::General),
        }
    }

    /// Writes an object of up to 8 bytes as the device ([`Request::Write`]).
    pub async fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        let Some(value) = Value::new(data) else { return Err(AbortCode::LengthTooHigh) };
        match self.call(Request::Write { index, sub, value }).await {
            Reply::Done => Ok(()),
            Reply::Refused(code) => Err(code),
            Reply::Value(_) | Reply::NotTriggered => Err(AbortCode::General),
        }
    }

    /// Sends event-driven TPDO `n` (0-based) now, inhibit time permitting;
    /// false if it is not valid or of another type.
    pub async fn trigger_tpdo(&mut self, n: u16) -> bool {
        self.call(Request::TriggerTpdo(n)).await == Reply::Done
    }

    /// Raises an application error (EMCY, error register, 0x1003).
    pub async fn raise_error(&mut self, code: EmcyCode, info: [u8; 5]) {
        self.call(Request::RaiseError { code, info }).await;
    }

    /// Clears an application error.
    pub async fn clear_error(&mut self, code: EmcyCode) {
        self.call(Request::ClearError(code)).await;
    }
}

/// The application's NMT state queue as the CANopen task fills it.
struct States<'a>(&'a Shared);

impl StateSink for States<'_> {
    fn entered(&mut self, state: NmtState) {
        let lost = self.0.states.lock(|q| {
            let mut q = q.try_borrow_mut().ok()?;
            let before = q.lost();
            q.entered(state);
            (q.lost() != before).then(|| q.lost())
        });
        #[cfg(target_os = "none")]
        if let Some(lost) = lost {
            defmt::warn!("NMT state queue full: {=u32} states lost so far", lost);
        }
        #[cfg(not(target_os = "none"))]
        let _ = lost;
        self.0.state_changed.signal(());
    }
}

/// The CANopen task: owns `node`; whatever wakes it (a received frame, an
/// application request, a controller event or room to send, the node's
/// deadline as `timer` waits for it) it hands the node, then runs a
/// [`Runner::step`]. `now` is the clock.
pub async fn serve<T: Future<Output = ()>>(
    shared: &Shared,
    node: &mut dyn CanNode,
    controller: &mut impl Controller,
    now: impl Fn() -> Instant,
    timer: impl Fn(Option<Instant>) -> T,
) -> ! {
    let mut runner = Runner::new();
    let mut states = States(shared);
    loop {
        let at = now();
        runner.controller_events(node, at, &shared.controller);
        let deadline = runner.step(node, at, controller, &mut states);
        match select3(shared.rx.receive(), shared.wake.wait(), timer(deadline)).await {
            Either3::First(frame) => {
                let at = now();
                runner.on_frame(node, at, &frame, &mut states);
                // Whatever else arrived meanwhile, before the next step.
                while let Ok(frame) = shared.rx.try_receive() {
                    runner.on_frame(node, at, &frame, &mut states);
                }
            }
            Either3::Second(()) => {
                let clear = shared.board_clear.swap(0, Ordering::Relaxed);
                if clear != 0 {
                    node.clear_error(EmcyCode(clear as u16));
                }
                if let Some(request) = shared.request.try_take() {
                    shared.reply.signal(runner.on_request(node, request));
                }
            }
            Either3::Third(()) => {}
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use std::boxed::Box;
    use std::vec::Vec;

    use core::pin::pin;
    use core::task::{Context, Poll, Waker};

    use canopen_core::node::{AcceptanceList, BitRateControl, NoApplication};
    use embassy_futures::select::{Either, select};
    use embedded_can::Frame;

    use super::*;
    use crate::boards::qemu::ram_storage::RamStorage;
    use crate::boards::region_size;
    use crate::devices::sendix;

    type Node = sendix::od::Node<NoApplication, RamStorage<{ region_size(sendix::od::STORED_SIZE) }>>;

    const ID: u8 = 0x3F;

    /// Takes every frame the node sends.
    #[derive(Default)]
    struct Bus(Vec<(u16, Vec<u8>)>);

    impl BitRateControl for Bus {
        fn set_bit_rate(&mut self, _: u8) {}
    }

    impl Controller for Bus {
        fn send(&mut self, node: &mut dyn CanNode) {
            while let Some(f) = node.transmit() {
                self.0.push((f.cob_id().unwrap_or(0xFFFF), f.data().to_vec()));
            }
        }

        fn set_acceptance(&mut self, _: &AcceptanceList) {}
    }

    fn ms(t: u64) -> Instant {
        Instant::from_micros(t * 1000)
    }

    fn nmt(cs: u8) -> CanFrame {
        CanFrame::standard(0x000, &[cs, ID]).expect("NMT frame")
    }

    /// Runs the CANopen task with a timer that never fires beside `app`
    /// until `app` is done: only frames and requests can wake the task.
    /// Both are polled in turn, a bounded number of times.
    fn run<R>(shared: &Shared, node: &mut Node, bus: &mut Bus, app: impl Future<Output = R>) -> R {
        let task = serve(shared, node, bus, || ms(1), |_| core::future::pending::<()>());
        let mut both = pin!(select(task, app));
        let mut cx = Context::from_waker(Waker::noop());
        for _ in 0..100 {
            match both.as_mut().poll(&mut cx) {
                Poll::Ready(Either::First(never)) => match never {},
                Poll::Ready(Either::Second(result)) => return result,
                Poll::Pending => {}
            }
        }
        panic!("the application waits for ever: nothing woke the CANopen task");
    }

    fn sendix() -> Node {
        sendix::od::Node::new(sendix::od::Ram::new(ID), NoApplication, RamStorage::default(), ID, ms(0))
    }

    #[test]
    fn a_request_wakes_the_task_and_its_frame_leaves_without_a_timer() {
        let shared = Box::leak(Box::new(Shared::new()));
        let (mut node, mut bus) = (sendix(), Bus::default());
        let mut requests = shared.requests().expect("the one handle");
        assert!(shared.requests().is_none(), "only one");
        assert!(shared.rx.try_send(nmt(0x01)).is_ok());
        let triggered = run(shared, &mut node, &mut bus, async {
            // Operational once the task took the NMT frame.
            while shared.next_state().await != NmtState::Operational {}
            requests.trigger_tpdo(0).await
        });
        assert!(triggered);
        // Boot-up, TPDO1 and TPDO3 on entering Operational, then TPDO1 for the request.
        let cob_ids: Vec<u16> = bus.0.iter().map(|f| f.0).collect();
        assert_eq!(cob_ids, [0x73F, 0x1BF, 0x3BF, 0x1BF]);
        let position = run(shared, &mut node, &mut bus, requests.read(0x6004, 0));
        assert_eq!(position.map(|v| v.as_bytes().to_vec()), Ok(std::vec![0, 0, 0, 0]));
        assert_eq!(run(shared, &mut node, &mut bus, requests.write(0x2FFF, 0, &[1])), Err(AbortCode::NoObject));
    }

    #[test]
    fn every_nmt_state_reaches_the_application_in_order() {
        let shared = Box::leak(Box::new(Shared::new()));
        let (mut node, mut bus) = (sendix(), Bus::default());
        for cs in [0x01, 0x02, 0x01] {
            assert!(shared.rx.try_send(nmt(cs)).is_ok());
        }
        let states = run(shared, &mut node, &mut bus, async {
            let mut states = Vec::new();
            for _ in 0..4 {
                states.push(shared.next_state().await);
            }
            states
        });
        assert_eq!(states, [NmtState::PreOperational, NmtState::Operational, NmtState::Stopped, NmtState::Operational]);
    }
}
