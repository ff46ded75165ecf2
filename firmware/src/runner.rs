//! The CANopen task's work, without the waiting: what it does with a
//! received frame, an application [`Request`] and what the controller
//! reported, and the [`Runner::step`] after each (the node's timers, the
//! controller's set-up, the transmit queue, NMT state events). Plain Rust,
//! so host tests run it on a node; `app` (MCU builds only) adds the
//! channels, the timer and the `select` around it.
//!
//! The task owns the node, as embassy-net's runner owns its stack: nothing
//! else touches it. Interrupts only move frames and count controller
//! events ([`ControllerStatus`]); the application asks through requests
//! and learns the NMT state from a [`StateQueue`].

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use canopen_core::abort::AbortCode;
use canopen_core::frame::CanFrame;
use canopen_core::node::{AcceptanceList, BitRateControl, ControllerEvent};
use canopen_core::services::nmt::NmtState;
use canopen_core::time::Instant;
use canopen_core::wire::emcy::EmcyCode;

use crate::can_node::CanNode;

/// Bytes of an object value a request carries: the most a PDO maps.
pub const VALUE_LEN: usize = 8;

/// An object's value, up to [`VALUE_LEN`] bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Value {
    bytes: [u8; VALUE_LEN],
    len: u8,
}

impl Value {
    /// `data` as a value; `None` if longer than [`VALUE_LEN`].
    pub fn new(data: &[u8]) -> Option<Value> {
        if data.len() > VALUE_LEN {
            return None;
        }
        let mut bytes = [0; VALUE_LEN];
        // Not `copy_from_slice`: its length check pulls `core::fmt` into the images.
        for (to, from) in bytes.iter_mut().zip(data) {
            *to = *from;
        }
        Some(Value { bytes, len: data.len() as u8 })
    }

    /// The bytes, little-endian as in the dictionary.
    pub fn as_bytes(&self) -> &[u8] {
        self.bytes.get(..usize::from(self.len)).unwrap_or(&[])
    }
}

/// What the application asks of the node. Each one wakes the CANopen task
/// and is answered with a [`Reply`] in the same step, whose frames (a
/// triggered TPDO, an EMCY) leave at once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Request {
    /// Read an object (up to [`VALUE_LEN`] bytes).
    Read {
        /// Index.
        index: u16,
        /// Sub-index.
        sub: u8,
    },
    /// Write an object as the device: no access check (read-only means
    /// read-only for the bus), a shorter value is zero-filled
    /// (`Dictionary::write_unchecked`). Change-of-state TPDOs see it in
    /// this step; communication objects written so bypass their services.
    Write {
        /// Index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// The new value.
        value: Value,
    },
    /// An application event for TPDO `n` (0-based; transmission types 0,
    /// 254, 255): `Node::trigger_tpdo`.
    TriggerTpdo(u16),
    /// Raise an application error: EMCY, error register, 0x1003.
    RaiseError {
        /// Error code (CiA 301 table 21 or the device profile's).
        code: EmcyCode,
        /// Manufacturer-specific error field.
        info: [u8; 5],
    },
    /// Clear an application error; the last one cleared sends "error reset".
    ClearError(EmcyCode),
}

/// The node's answer to a [`Request`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reply {
    /// The value read.
    Value(Value),
    /// Written, triggered, raised or cleared.
    Done,
    /// A read or write refused, with the abort code an SDO client would get.
    Refused(AbortCode),
    /// The TPDO is not valid or not of a type an application event sends.
    NotTriggered,
}

/// What the CANopen task needs from the board's CAN controller (or SLCAN
/// link), besides the LSS bit-rate switch.
pub trait Controller: BitRateControl {
    /// Takes frames from the node's queue (`CanNode::transmit`) while the
    /// controller has room for them, handing back (`CanNode::requeue`) one
    /// it could not take. The task calls it after every step.
    fn send(&mut self, node: &mut dyn CanNode);
    /// The node consumes another set of identifiers (and once at start):
    /// program the acceptance filter for `list`.
    fn set_acceptance(&mut self, list: &AcceptanceList);
}

/// Where the NMT states the node enters go: the application's queue.
pub trait StateSink {
    /// The node is now in `state`.
    fn entered(&mut self, state: NmtState);
}

/// NMT states in the order the node entered them, for the application:
/// a ring of `N`. Full, the newest entry is replaced and the loss counted,
/// so the last state the application reads is always the node's.
#[derive(Clone, Debug)]
pub struct StateQueue<const N: usize> {
    states: [NmtState; N],
    head: usize,
    len: usize,
    lost: u32,
}

impl<const N: usize> Default for StateQueue<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> StateQueue<N> {
    /// An empty queue.
    pub const fn new() -> Self {
        StateQueue { states: [NmtState::Initialising; N], head: 0, len: 0, lost: 0 }
    }

    /// The oldest state not taken yet.
    pub fn pop(&mut self) -> Option<NmtState> {
        if self.len == 0 {
            return None;
        }
        let state = self.states.get(self.head).copied();
        self.head = (self.head + 1) % N;
        self.len -= 1;
        state
    }

    /// States replaced because the queue was full.
    pub fn lost(&self) -> u32 {
        self.lost
    }
}

impl<const N: usize> StateSink for StateQueue<N> {
    fn entered(&mut self, state: NmtState) {
        let at = if self.len < N {
            self.len += 1;
            (self.head + self.len - 1) % N
        } else {
            self.lost = self.lost.wrapping_add(1);
            (self.head + N - 1) % N
        };
        if let Some(slot) = self.states.get_mut(at) {
            *slot = state;
        }
    }
}

/// What the controller's interrupts report, as counters and a level that
/// they update and the CANopen task reads ([`Runner::controller_events`]):
/// nothing is lost if the task runs late, several losses become one event.
#[derive(Debug, Default)]
pub struct ControllerStatus {
    lost: AtomicU32,
    recoveries: AtomicU32,
    passive: AtomicBool,
}

impl ControllerStatus {
    /// No event yet.
    pub const fn new() -> Self {
        ControllerStatus { lost: AtomicU32::new(0), recoveries: AtomicU32::new(0), passive: AtomicBool::new(false) }
    }

    /// A received frame was lost (controller FIFO or the task's queue full).
    pub fn rx_overrun(&self) {
        self.lost.fetch_add(1, Ordering::Relaxed);
    }

    /// The controller recovered from bus-off.
    pub fn bus_off_recovered(&self) {
        self.recoveries.fetch_add(1, Ordering::Relaxed);
    }

    /// The controller is error passive (`true`) or error active again.
    pub fn set_error_passive(&self, passive: bool) {
        self.passive.store(passive, Ordering::Relaxed);
    }

    /// Received frames lost since start (for logs).
    pub fn rx_overruns(&self) -> u32 {
        self.lost.load(Ordering::Relaxed)
    }
}

/// What the task last passed on of a [`ControllerStatus`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Reported {
    lost: u32,
    recoveries: u32,
    passive: bool,
}

/// The CANopen task's state between steps.
#[derive(Debug, Default)]
pub struct Runner {
    state: Option<NmtState>,
    acceptance: Option<u32>,
    reported: Reported,
}

impl Runner {
    /// Before the first step.
    pub const fn new() -> Self {
        Runner { state: None, acceptance: None, reported: Reported { lost: 0, recoveries: 0, passive: false } }
    }

    /// Hands `node` a received frame. The state is checked after each
    /// frame, so every NMT command the frames carry is an event of its own.
    pub fn on_frame(&mut self, node: &mut dyn CanNode, now: Instant, frame: &CanFrame, states: &mut impl StateSink) {
        node.on_frame(now, frame);
        self.watch_state(node, states);
    }

    /// Carries out an application request.
    pub fn on_request(&mut self, node: &mut dyn CanNode, request: Request) -> Reply {
        match request {
            Request::Read { index, sub } => {
                let mut buf = [0; VALUE_LEN];
                match node.read(index, sub, &mut buf) {
                    Ok(n) => Value::new(buf.get(..n).unwrap_or(&[])).map_or(Reply::Refused(AbortCode::LengthTooHigh), Reply::Value),
                    Err(code) => Reply::Refused(code),
                }
            }
            Request::Write { index, sub, value } => match node.write(index, sub, value.as_bytes()) {
                Ok(()) => Reply::Done,
                Err(code) => Reply::Refused(code),
            },
            Request::TriggerTpdo(n) => {
                if node.trigger_tpdo(usize::from(n)) {
                    Reply::Done
                } else {
                    Reply::NotTriggered
                }
            }
            Request::RaiseError { code, info } => {
                node.raise_error(code, info);
                Reply::Done
            }
            Request::ClearError(code) => {
                node.clear_error(code);
                Reply::Done
            }
        }
    }

    /// Passes on what `status` counted since the last call.
    pub fn controller_events(&mut self, node: &mut dyn CanNode, now: Instant, status: &ControllerStatus) {
        let lost = status.lost.load(Ordering::Relaxed);
        let recoveries = status.recoveries.load(Ordering::Relaxed);
        let passive = status.passive.load(Ordering::Relaxed);
        if lost != self.reported.lost {
            node.controller_event(ControllerEvent::RxOverrun { lost: lost.wrapping_sub(self.reported.lost) }, now);
        }
        if passive != self.reported.passive {
            node.controller_event(if passive { ControllerEvent::ErrorPassive } else { ControllerEvent::ErrorActive }, now);
        }
        // Several recoveries before the task ran are one: the error is raised once and held from now.
        if recoveries != self.reported.recoveries {
            node.controller_event(ControllerEvent::BusOffRecovered, now);
        }
        self.reported = Reported { lost, recoveries, passive };
    }

    /// Runs the node's timers, hands the controller what the node asks of
    /// it (a bit-rate switch at the end of LSS's first switch delay, a new
    /// identifier list when its generation moved) and the frames it has
    /// room for; returns when to step again.
    pub fn step(
        &mut self,
        node: &mut dyn CanNode,
        now: Instant,
        controller: &mut impl Controller,
        states: &mut impl StateSink,
    ) -> Option<Instant> {
        // A reset runs a stage per `process` call (each call bounded); the
        // frames that come meanwhile wait in the receive channel until it
        // is done, so they meet the node after its boot-up, as a master
        // that sends right after an NMT reset expects.
        let mut deadline = node.process(now);
        while node.resetting() {
            deadline = node.process(now);
        }
        if let Some(index) = node.take_bit_rate_change() {
            controller.set_bit_rate(index);
        }
        // Every frame and request that can move the list is followed by a step.
        let list = node.acceptance();
        if self.acceptance != Some(list.generation()) {
            self.acceptance = Some(list.generation());
            controller.set_acceptance(list);
        }
        self.watch_state(node, states);
        controller.send(node);
        deadline
    }

    fn watch_state(&mut self, node: &dyn CanNode, states: &mut impl StateSink) {
        let state = node.state();
        if self.state != Some(state) {
            self.state = Some(state);
            states.entered(state);
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use std::vec::Vec;

    use super::*;

    #[test]
    fn values_up_to_eight_bytes() {
        assert_eq!(Value::new(&[1, 2, 3]).map(|v| v.as_bytes().to_vec()), Some(std::vec![1, 2, 3]));
        assert!(Value::new(&[0; 8]).is_some());
        assert_eq!(Value::new(&[0; 9]), None);
    }

    #[test]
    fn the_state_queue_keeps_the_order_and_the_newest() {
        let mut q = StateQueue::<3>::new();
        assert_eq!(q.pop(), None);
        for s in [NmtState::Operational, NmtState::Stopped, NmtState::Operational] {
            q.entered(s);
        }
        // Full: the newest entry is replaced, and the loss counted.
        q.entered(NmtState::PreOperational);
        assert_eq!(q.lost(), 1);
        let states: Vec<NmtState> = core::iter::from_fn(|| q.pop()).collect();
        assert_eq!(states, [NmtState::Operational, NmtState::Stopped, NmtState::PreOperational]);
        // Wraps around.
        for s in [NmtState::Stopped, NmtState::Operational] {
            q.entered(s);
        }
        assert_eq!(core::iter::from_fn(|| q.pop()).collect::<Vec<_>>(), [NmtState::Stopped, NmtState::Operational]);
        assert_eq!(q.lost(), 1);
    }
}
