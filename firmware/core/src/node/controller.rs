//! What the CAN controller reports and the EMCY it becomes (CiA 301 v4.2
//! table 21): received frames lost (0x8110), error passive (0x8120) and
//! the recovery from bus-off (0x8140). The board only reports; the codes,
//! the error register and when an error clears are decided here, so host
//! tests see the exact frames.
//!
//! Error passive is a state: active while the controller says so. A lost
//! frame and a bus-off recovery are events with no lasting state: each
//! stays active, and so in the error register, until it has not recurred
//! for [`TRANSIENT_ERROR_HOLD`]; a repeat meanwhile sends nothing new (the
//! error is active already) but holds it longer. Clearing the last active
//! error sends "error reset" (0x0000), as for every error of the node.

use crate::od::ObjectDictionary;
use crate::storage::Storage;
use crate::time::{Duration, Instant, earliest};
use crate::wire::emcy::EmcyCode;

use crate::services::emcy::EmcyProducer;

use super::{Application, EMCY_SLOTS, Node};

type EmcyQueue = EmcyProducer<EMCY_SLOTS, EMCY_SLOTS>;

/// How long a frame loss or a bus-off recovery stays active without
/// recurring before it is cleared ("error reset").
pub const TRANSIENT_ERROR_HOLD: Duration = Duration::from_secs(1);

/// What a board's CAN controller (or its driver) reports to the node
/// ([`Node::controller_event`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ControllerEvent {
    /// `lost` received frames were lost since the last report: the
    /// controller's receive FIFO or the board's queue to the node was full.
    RxOverrun {
        /// Frames lost since the last report (0 reports nothing).
        lost: u32,
    },
    /// An error counter passed 127: the controller is error passive.
    ErrorPassive,
    /// Both error counters are below 128 again: error active.
    ErrorActive,
    /// The controller recovered from bus-off and takes part in bus traffic again.
    BusOffRecovered,
}

/// The controller's errors as the node keeps them. All zero bits when
/// none is active ([`crate::node`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct ControllerErrors {
    /// Received frames lost since power-on (wrapping).
    lost: u32,
    /// Bus-off recoveries since power-on (wrapping).
    recoveries: u32,
    /// When the frame loss clears, if it is active.
    overrun_clears_at: Option<Instant>,
    /// When the bus-off recovery clears, if it is active.
    bus_off_clears_at: Option<Instant>,
    /// The earlier of the two: [`ControllerErrors::poll`] compares only this.
    clears_at: Option<Instant>,
    passive: bool,
    /// Error passive is to be raised again once the boot-up has left.
    raise_passive: bool,
    /// A bus-off recovery the device has not heard of yet (`Node::process` tells it).
    pub(super) bus_off_unheard: bool,
}

impl ControllerErrors {
    pub(super) const fn new() -> Self {
        ControllerErrors {
            lost: 0,
            recoveries: 0,
            overrun_clears_at: None,
            bus_off_clears_at: None,
            clears_at: None,
            passive: false,
            raise_passive: false,
            bus_off_unheard: false,
        }
    }

    fn on_event(&mut self, event: ControllerEvent, now: Instant, emcy: &mut EmcyQueue) {
        match event {
            ControllerEvent::RxOverrun { lost: 0 } => {}
            ControllerEvent::RxOverrun { lost } => {
                self.lost = self.lost.wrapping_add(lost);
                // Manufacturer-specific field: frames lost so far.
                emcy.raise(EmcyCode::CAN_OVERRUN, count(self.lost));
                self.overrun_clears_at = Some(now + TRANSIENT_ERROR_HOLD);
            }
            ControllerEvent::BusOffRecovered => {
                self.recoveries = self.recoveries.wrapping_add(1);
                emcy.raise(EmcyCode::RECOVERED_FROM_BUS_OFF, count(self.recoveries));
                self.bus_off_clears_at = Some(now + TRANSIENT_ERROR_HOLD);
            }
            ControllerEvent::ErrorPassive if !self.passive => {
                self.passive = true;
                emcy.raise(EmcyCode::CAN_ERROR_PASSIVE, [0; 5]);
            }
            ControllerEvent::ErrorActive if self.passive => {
                self.passive = false;
                emcy.clear(EmcyCode::CAN_ERROR_PASSIVE);
            }
            ControllerEvent::ErrorPassive | ControllerEvent::ErrorActive => {}
        }
        self.clears_at = earliest(self.overrun_clears_at, self.bus_off_clears_at);
    }

    /// Clears what stayed quiet long enough; the next deadline, if any.
    /// `booted`: the boot-up left in an earlier call (the transmit queue
    /// sends by identifier, and nothing may precede the boot-up). Every
    /// `Node::process` asks, so the common answer takes one compare.
    #[inline(always)]
    pub(super) fn poll(&mut self, now: Instant, booted: bool, emcy: &mut EmcyQueue) -> Option<Instant> {
        if self.raise_passive || self.clears_at.is_some_and(|t| t <= now) { self.poll_due(now, booted, emcy) } else { self.clears_at }
    }

    #[inline(never)]
    fn poll_due(&mut self, now: Instant, booted: bool, emcy: &mut EmcyQueue) -> Option<Instant> {
        if self.raise_passive {
            if !booted {
                return Some(now);
            }
            self.raise_passive = false;
            emcy.raise(EmcyCode::CAN_ERROR_PASSIVE, [0; 5]);
        }
        for (clears_at, error) in
            [(&mut self.overrun_clears_at, EmcyCode::CAN_OVERRUN), (&mut self.bus_off_clears_at, EmcyCode::RECOVERED_FROM_BUS_OFF)]
        {
            if clears_at.is_some_and(|t| t <= now) {
                *clears_at = None;
                emcy.clear(error);
            }
        }
        self.clears_at = earliest(self.overrun_clears_at, self.bus_off_clears_at);
        self.clears_at
    }

    /// Reset communication forgot every active error: a controller still
    /// error passive is an error still present, so it is raised again after
    /// the boot-up. Frame losses and recoveries before the reset are over.
    pub(super) fn reset(&mut self) {
        self.overrun_clears_at = None;
        self.bus_off_clears_at = None;
        self.clears_at = None;
        self.raise_passive = self.passive;
    }
}

fn count(n: u32) -> [u8; 5] {
    let [a, b, c, d] = n.to_le_bytes();
    [a, b, c, d, 0]
}

impl<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize, const SDO: usize>
    Node<O, A, S, R, T, HB, SDO>
{
    /// Takes what the CAN controller reports: the EMCY and the error
    /// register follow (see the [module docs](self)); the messages leave at
    /// the next [`Node::process`], whose deadline then includes the clearing.
    pub fn controller_event(&mut self, event: ControllerEvent, now: Instant) {
        self.stale = true;
        self.controller.on_event(event, now, &mut self.comm.emcy);
        // The device hears of it (its 0x6007 or 0x1029 reaction) in the next
        // `process`, on the path its other hooks already take.
        self.controller.bus_off_unheard |= event == ControllerEvent::BusOffRecovered;
    }
}
