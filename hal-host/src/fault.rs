//! Fault injection on the virtual [`Bus`].
//!
//! - **Drop** ([`FaultAction::Drop`]): the frame goes over the wire and the
//!   sender gets its tx-complete note, but no port receives it and it is
//!   left out of the trace: a lost response, from the receivers' side.
//! - **Corrupt** ([`FaultAction::Corrupt`]): the receivers find a CRC error;
//!   after the ACK delimiter an error frame (6-bit flag, 8-bit delimiter,
//!   3-bit intermission) follows, nobody receives the frame, and the sender
//!   retransmits it automatically, as CAN controllers do. Each error adds 8 to
//!   the sender's TEC, so a frame corrupted on every attempt puts its sender
//!   bus-off after 32 tries.
//! - **Delay** ([`Bus::set_tx_delay`]): frames a port queues from then on
//!   wait that long before they may enter arbitration (order kept).
//! - **Error frames** ([`Bus::inject_error_frame`]): at a given instant;
//!   a frame on the wire at that instant is destroyed and retransmitted, an
//!   error frame on an idle bus just occupies it, and one due during an
//!   intermission or another error frame waits for the bus to be idle.
//! - **Bus-off** ([`Bus::set_bus_off`]): the port neither sends nor receives
//!   (its transmit FIFO is kept) until it has seen 128 sequences of 11
//!   recessive bits at its bit rate (ISO 11898-1 §12.1.4.2); then it is
//!   error-active with both counters at zero. A frame it has on the wire
//!   when it goes bus-off is still completed.
//!
//! Rules select frames by a [`Trigger`]: the n-th transmission attempt from
//! now on (retransmissions count), the sender, the identifier, or any
//! predicate. The first rule that matches decides; a rule applies a limited
//! or unlimited number of times.

#[cfg(test)]
mod tests;

use crate::bus::{Bus, BusError, PortId};
use canopen_core::frame::CanFrame;
use canopen_core::time::{Duration, Instant};

/// A frame filter: given the sender and the frame, whether a rule applies.
pub type Predicate = Box<dyn FnMut(PortId, &CanFrame) -> bool + Send>;

/// Which frames a fault rule hits.
pub enum Trigger {
    /// The n-th transmission attempt after the rule is added (1 = the next
    /// one to start; retransmissions count; 0 never matches).
    Nth(u64),
    /// Every frame sent by this port.
    Sender(PortId),
    /// Every frame with this raw identifier (11 or 29 bits).
    RawId(u32),
    /// Every frame for which the predicate, given sender and frame, is true.
    Matching(Predicate),
}

impl core::fmt::Debug for Trigger {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Trigger::Nth(n) => write!(f, "Nth({n})"),
            Trigger::Sender(p) => write!(f, "Sender({p:?})"),
            Trigger::RawId(id) => write!(f, "RawId({id:#x})"),
            Trigger::Matching(_) => f.write_str("Matching(..)"),
        }
    }
}

/// What a fault rule does to the frames it hits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaultAction {
    /// Sent, but received by nobody.
    Drop,
    /// Destroyed by an error frame and retransmitted.
    Corrupt,
}

/// A handle to remove a rule with [`Bus::remove_fault`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FaultId(u64);

/// What becomes of one transmission attempt.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Outcome {
    Deliver,
    Drop,
    Corrupt,
}

enum Selector {
    /// The attempt with this absolute number.
    Attempt(u64),
    Sender(PortId),
    RawId(u32),
    Matching(Predicate),
}

struct Rule {
    id: FaultId,
    selector: Selector,
    action: FaultAction,
    /// Applications left; `None` = unlimited.
    remaining: Option<u64>,
}

/// The fault rules and pending error frames of one bus.
#[derive(Default)]
pub(crate) struct Faults {
    rules: Vec<Rule>,
    next_id: u64,
    /// Instants (ns) of error frames still to inject, ascending.
    injections: Vec<u64>,
}

impl Faults {
    /// Applies the first matching rule to attempt number `attempt`.
    pub(crate) fn decide(&mut self, attempt: u64, port: PortId, frame: &CanFrame) -> Outcome {
        let hit = self.rules.iter_mut().position(|r| match &mut r.selector {
            Selector::Attempt(n) => *n == attempt,
            Selector::Sender(p) => *p == port,
            Selector::RawId(id) => *id == frame.raw_id(),
            Selector::Matching(pred) => pred(port, frame),
        });
        let Some(i) = hit else { return Outcome::Deliver };
        let Some(rule) = self.rules.get_mut(i) else { return Outcome::Deliver };
        let action = rule.action;
        let spent = match (&rule.selector, &mut rule.remaining) {
            (Selector::Attempt(_), _) => true,
            (_, Some(left)) => {
                *left = left.saturating_sub(1);
                *left == 0
            }
            (_, None) => false,
        };
        if spent {
            self.rules.remove(i);
        }
        match action {
            FaultAction::Drop => Outcome::Drop,
            FaultAction::Corrupt => Outcome::Corrupt,
        }
    }

    pub(crate) fn next_injection(&self) -> Option<u64> {
        self.injections.first().copied()
    }

    pub(crate) fn pop_injection(&mut self) {
        if !self.injections.is_empty() {
            self.injections.remove(0);
        }
    }
}

impl Bus {
    /// Adds a rule applying `action` to the frames `trigger` selects, at most
    /// `times` times (`None`: until removed; [`Trigger::Nth`] applies once).
    pub fn add_fault(&mut self, trigger: Trigger, action: FaultAction, times: Option<u64>) -> FaultId {
        let selector = match trigger {
            Trigger::Nth(0) => Selector::Attempt(0),
            Trigger::Nth(n) => Selector::Attempt(self.attempts.saturating_add(n)),
            Trigger::Sender(p) => Selector::Sender(p),
            Trigger::RawId(id) => Selector::RawId(id),
            Trigger::Matching(f) => Selector::Matching(f),
        };
        let id = FaultId(self.faults.next_id);
        self.faults.next_id += 1;
        if times != Some(0) {
            self.faults.rules.push(Rule { id, selector, action, remaining: times });
        }
        id
    }

    /// Drops the n-th transmission attempt from now on (1 = the next).
    pub fn drop_nth(&mut self, n: u64) -> FaultId {
        self.add_fault(Trigger::Nth(n), FaultAction::Drop, Some(1))
    }

    /// Drops every frame for which `pred(sender, frame)` holds, until removed.
    pub fn drop_where(&mut self, pred: impl FnMut(PortId, &CanFrame) -> bool + Send + 'static) -> FaultId {
        self.add_fault(Trigger::Matching(Box::new(pred)), FaultAction::Drop, None)
    }

    /// Corrupts the n-th transmission attempt from now on (1 = the next).
    pub fn corrupt_nth(&mut self, n: u64) -> FaultId {
        self.add_fault(Trigger::Nth(n), FaultAction::Corrupt, Some(1))
    }

    /// Corrupts every attempt for which `pred(sender, frame)` holds, until removed.
    pub fn corrupt_where(&mut self, pred: impl FnMut(PortId, &CanFrame) -> bool + Send + 'static) -> FaultId {
        self.add_fault(Trigger::Matching(Box::new(pred)), FaultAction::Corrupt, None)
    }

    /// Removes a rule; `false` if it was already spent or removed.
    pub fn remove_fault(&mut self, id: FaultId) -> bool {
        let before = self.faults.rules.len();
        self.faults.rules.retain(|r| r.id != id);
        self.faults.rules.len() != before
    }

    /// Removes every rule and every pending error frame.
    pub fn clear_faults(&mut self) {
        self.faults.rules.clear();
        self.faults.injections.clear();
    }

    /// Frames `port` queues from now on wait `delay` before arbitration.
    pub fn set_tx_delay(&mut self, port: PortId, delay: Duration) -> Result<(), BusError> {
        self.port_mut(port)?.delay_ns = delay.as_micros().saturating_mul(1_000);
        Ok(())
    }

    /// Puts an error frame on the bus at `at` (at the bus's default bit
    /// rate when idle, at the sender's when it destroys a frame). An `at`
    /// in the past means now.
    pub fn inject_error_frame(&mut self, at: Instant) {
        let ns = at.as_micros().saturating_mul(1_000).max(self.now_ns);
        let i = self.faults.injections.partition_point(|&x| x <= ns);
        self.faults.injections.insert(i, ns);
    }

    /// Puts `port` bus-off now; it recovers by itself after 128 × 11
    /// recessive bits.
    pub fn set_bus_off(&mut self, port: PortId) -> Result<(), BusError> {
        self.port_mut(port)?;
        self.enter_bus_off(port);
        Ok(())
    }

    /// Whether `port` is bus-off (`false` for an unknown port).
    pub fn is_bus_off(&self, port: PortId) -> bool {
        self.port(port).is_some_and(|p| p.bus_off.is_some())
    }
}
