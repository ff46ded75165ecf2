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
//! error is active already) but holds it longer. The EMCY producer keeps
//! the holds with its active errors ([`EmcyProducer::raise_held`]).
//! Clearing the last active error sends "error reset" (0x0000), as for
//! every error of the node.
//!
//! The codes are CiA 301's unless the device's manual has its own
//! ([`CanEmcyCodes`], [`super::Application::CAN_EMCY`]); a device may also
//! name a code for frames that break the CANopen protocol (an NMT command or
//! a heartbeat message the node cannot parse), transient as a frame loss.

use crate::od::ObjectDictionary;
use crate::storage::Storage;
use crate::time::{At, Duration, Instant, NEVER, later, span};
use crate::wire::emcy::EmcyCode;

use crate::services::emcy::{EmcyProducer, register};

use super::{Application, EMCY_SLOTS, Node};

type EmcyQueue = EmcyProducer<EMCY_SLOTS, EMCY_SLOTS>;

/// How long a frame loss or a bus-off recovery stays active without
/// recurring before it is cleared ("error reset").
pub const TRANSIENT_ERROR_HOLD: Duration = Duration::from_secs(1);

/// The EMCY codes of the controller's errors. Each is raised with the
/// communication bit of the error register (CiA 301: "overrun, error
/// state"), also where a device's code is manufacturer-specific.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CanEmcyCodes {
    /// Frames lost: received (the controller or the board's queue) or not
    /// sent (the node's transmit queue full).
    pub overrun: EmcyCode,
    /// The controller is error passive.
    pub error_passive: EmcyCode,
    /// The controller recovered from bus-off.
    pub bus_off_recovered: EmcyCode,
    /// A frame that breaks the protocol (an NMT command or heartbeat
    /// message of the wrong length or with an unknown value), if the device
    /// reports it; such frames are counted and ignored either way.
    pub protocol: Option<EmcyCode>,
    /// An RPDO longer than its mapping (its mapped bytes are processed).
    pub rpdo_too_long: EmcyCode,
}

impl CanEmcyCodes {
    /// CiA 301's codes: 0x8110, 0x8120, 0x8140 and 0x8220; a broken frame only counted.
    pub const CIA301: CanEmcyCodes = CanEmcyCodes {
        overrun: EmcyCode::CAN_OVERRUN,
        error_passive: EmcyCode::CAN_ERROR_PASSIVE,
        bus_off_recovered: EmcyCode::RECOVERED_FROM_BUS_OFF,
        protocol: None,
        rpdo_too_long: EmcyCode::PDO_LENGTH_EXCEEDED,
    };
}

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
    passive: bool,
    /// Error passive is to be raised again once the boot-up has left.
    raise_passive: bool,
    /// A bus-off recovery the device has not heard of yet (`Node::process` tells it).
    pub(super) bus_off_unheard: bool,
}

impl ControllerErrors {
    pub(super) const fn new() -> Self {
        ControllerErrors { lost: 0, recoveries: 0, passive: false, raise_passive: false, bus_off_unheard: false }
    }

    fn on_event<A: Application>(&mut self, event: ControllerEvent, now: At, emcy: &mut EmcyQueue) {
        let codes = A::CAN_EMCY;
        match event {
            ControllerEvent::RxOverrun { lost: 0 } => {}
            ControllerEvent::RxOverrun { lost } => {
                self.lost = self.lost.wrapping_add(lost);
                // Manufacturer-specific field: frames lost so far.
                raise_held(emcy, codes.overrun, count(self.lost), now);
            }
            ControllerEvent::BusOffRecovered => {
                self.recoveries = self.recoveries.wrapping_add(1);
                raise_held(emcy, codes.bus_off_recovered, count(self.recoveries), now);
            }
            ControllerEvent::ErrorPassive if !self.passive => {
                self.passive = true;
                raise(emcy, codes.error_passive);
            }
            ControllerEvent::ErrorActive if self.passive => {
                self.passive = false;
                emcy.clear(codes.error_passive);
            }
            ControllerEvent::ErrorPassive | ControllerEvent::ErrorActive => {}
        }
    }

    /// A frame that breaks the protocol, if the device reports those:
    /// raised (once) and held like a frame loss.
    pub(super) fn protocol_error(now: At, emcy: &mut EmcyQueue, code: EmcyCode) {
        raise_held(emcy, code, [0; 5], now);
    }

    /// Raises error passive again after a reset, once the boot-up left;
    /// then clears the held errors whose hold ended (the EMCY producer's
    /// [`EmcyProducer::expire`]). The next deadline, if any. `booted`: the
    /// boot-up left in an earlier call (the transmit queue sends by
    /// identifier, and nothing may precede the boot-up).
    #[inline(always)]
    pub(super) fn poll<A: Application>(&mut self, now: At, booted: bool, emcy: &mut EmcyQueue) -> At {
        let mut due = NEVER;
        if self.raise_passive {
            due = self.raise_passive_again::<A>(now, booted, emcy);
        }
        emcy.expire(now).min(due)
    }

    // Cold: only the call after a reset of a node whose controller is error passive.
    #[cold]
    fn raise_passive_again<A: Application>(&mut self, now: At, booted: bool, emcy: &mut EmcyQueue) -> At {
        if !booted {
            return now;
        }
        self.raise_passive = false;
        raise(emcy, A::CAN_EMCY.error_passive);
        NEVER
    }

    /// Reset communication forgot every active error (the EMCY producer's
    /// holds with them): a controller still error passive is an error still
    /// present, so it is raised again after the boot-up. Frame losses and
    /// recoveries before the reset are over.
    pub(super) fn reset(&mut self) {
        self.raise_passive = self.passive;
    }
}

/// Raises a controller error with the communication bit (see [`CanEmcyCodes`]).
fn raise(emcy: &mut EmcyQueue, code: EmcyCode) {
    emcy.raise_with(code, register::COMMUNICATION, [0; 5]);
}

/// Raises a transient controller error with the communication bit, held
/// for [`TRANSIENT_ERROR_HOLD`] from `now`.
fn raise_held(emcy: &mut EmcyQueue, code: EmcyCode, info: [u8; 5], now: At) {
    emcy.raise_held(code, register::COMMUNICATION, info, later(now, span(TRANSIENT_ERROR_HOLD)));
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
        let now = self.tick(now);
        self.stale = true;
        self.controller.on_event::<A>(event, now, &mut self.comm.emcy);
        // The device hears of it (its 0x6007 or 0x1029 reaction) in the next
        // `process`, on the path its other hooks already take.
        self.controller.bus_off_unheard |= event == ControllerEvent::BusOffRecovered;
    }
}
