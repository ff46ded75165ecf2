//! Heartbeat monitor: the master's heartbeat consumer. CiA 301 v4.2
//! §7.2.8.3.2.1 (heartbeat protocol) and §7.2.8.3.3 (boot-up); state codes
//! table 57 ([`canopen_core::wire::nmt::NmtStateCode`]).
//!
//! Every frame on 0x700 + node-ID with one data byte tells the node's NMT
//! state. The monitor keeps the last state and time of every node it has
//! heard, and for each node given a consumer time with
//! [`watch`](HeartbeatMonitor::watch) it reports a timeout once that time
//! has gone by since the last heartbeat. As in the core's consumer,
//! monitoring starts with the first heartbeat, and a boot-up message stops
//! it until the next heartbeat (the producer restarted).

use canopen_core::time::{Duration, Instant};
use canopen_core::wire::nmt::ERROR_CONTROL_BASE;
pub use canopen_core::wire::nmt::NmtStateCode;
use std::collections::{BTreeMap, VecDeque};

/// Something the monitor noticed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeartbeatEvent {
    /// A boot-up message (state 0x00).
    BootUp {
        /// The node.
        node_id: u8,
        /// When it arrived.
        at: Instant,
    },
    /// A heartbeat with another state than the node's last one (or its
    /// first heartbeat, or the first one after a timeout).
    StateChanged {
        /// The node.
        node_id: u8,
        /// The state known before (`None` if none was, or after a timeout).
        previous: Option<NmtStateCode>,
        /// The state the heartbeat reports.
        state: NmtStateCode,
        /// When it arrived.
        at: Instant,
    },
    /// No heartbeat within the node's consumer time.
    Timeout {
        /// The node.
        node_id: u8,
        /// When its last heartbeat arrived.
        last: Instant,
        /// The deadline that passed (last heartbeat + consumer time).
        at: Instant,
    },
}

/// What the monitor knows of one node.
#[derive(Clone, Copy, Debug, Default)]
struct Entry {
    state: Option<NmtStateCode>,
    last: Option<Instant>,
    timeout: Option<Duration>,
    deadline: Option<Instant>,
    timed_out: bool,
}

/// Tracks heartbeats of any number of nodes; see the [module docs](self).
#[derive(Clone, Debug, Default)]
pub struct HeartbeatMonitor {
    nodes: BTreeMap<u8, Entry>,
    events: VecDeque<HeartbeatEvent>,
    malformed: u32,
}

impl HeartbeatMonitor {
    /// A monitor that knows no node and watches none.
    pub fn new() -> Self {
        HeartbeatMonitor::default()
    }

    /// Reports a timeout when `node_id` has sent no heartbeat for `timeout`
    /// (its heartbeat consumer time). Starts with the node's next heartbeat.
    pub fn watch(&mut self, node_id: u8, timeout: Duration) {
        let e = self.nodes.entry(node_id).or_default();
        e.timeout = Some(timeout);
        e.deadline = None;
    }

    /// Stops timeout monitoring of `node_id` (its state is still tracked).
    pub fn unwatch(&mut self, node_id: u8) {
        if let Some(e) = self.nodes.get_mut(&node_id) {
            e.timeout = None;
            e.deadline = None;
        }
    }

    /// Feeds a received frame; returns whether it was an error-control frame
    /// (COB-ID 0x701–0x77F). One that is not one data byte with a state code
    /// of table 57 is counted in [`malformed`](Self::malformed) and ignored.
    pub fn on_frame(&mut self, now: Instant, cob_id: u16, data: &[u8]) -> bool {
        let Some(node_id) = cob_id.checked_sub(ERROR_CONTROL_BASE).and_then(|id| u8::try_from(id).ok()).filter(|id| (1..=127).contains(id))
        else {
            return false;
        };
        let state = match *data {
            [code] => NmtStateCode::from_code(code),
            _ => None,
        };
        let Some(state) = state else {
            self.malformed = self.malformed.saturating_add(1);
            return true;
        };
        let e = self.nodes.entry(node_id).or_default();
        let previous = e.state;
        e.state = Some(state);
        e.last = Some(now);
        e.timed_out = false;
        e.deadline = match (state, e.timeout) {
            (NmtStateCode::BootUp, _) | (_, None) => None,
            (_, Some(t)) => Some(now + t),
        };
        if state == NmtStateCode::BootUp {
            self.events.push_back(HeartbeatEvent::BootUp { node_id, at: now });
        } else if previous != Some(state) {
            self.events.push_back(HeartbeatEvent::StateChanged { node_id, previous, state, at: now });
        }
        true
    }

    /// Reports every watched node whose deadline has come by `now`; returns
    /// the next deadline. Calling early is harmless.
    pub fn process(&mut self, now: Instant) -> Option<Instant> {
        for (&node_id, e) in self.nodes.iter_mut() {
            if let (Some(at), Some(last)) = (e.deadline, e.last)
                && now >= at
            {
                e.deadline = None;
                e.timed_out = true;
                e.state = None;
                self.events.push_back(HeartbeatEvent::Timeout { node_id, last, at });
            }
        }
        self.nodes.values().filter_map(|e| e.deadline).min()
    }

    /// Takes the oldest event.
    pub fn pop_event(&mut self) -> Option<HeartbeatEvent> {
        self.events.pop_front()
    }

    /// The last state `node_id` reported (`None` if unknown, or lost to a timeout).
    pub fn state(&self, node_id: u8) -> Option<NmtStateCode> {
        self.nodes.get(&node_id).and_then(|e| e.state)
    }

    /// When the last heartbeat or boot-up of `node_id` arrived.
    pub fn last_seen(&self, node_id: u8) -> Option<Instant> {
        self.nodes.get(&node_id).and_then(|e| e.last)
    }

    /// Whether `node_id` timed out and has not been heard since.
    pub fn is_timed_out(&self, node_id: u8) -> bool {
        self.nodes.get(&node_id).is_some_and(|e| e.timed_out)
    }

    /// Error-control frames ignored because of their length or state code.
    pub fn malformed(&self) -> u32 {
        self.malformed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(t: u64) -> Instant {
        Instant::from_micros(t * 1000)
    }

    #[test]
    fn tracks_states_and_reports_one_timeout_per_silence() {
        let mut m = HeartbeatMonitor::new();
        m.watch(5, Duration::from_millis(1000));
        // Boot-up does not start monitoring.
        assert!(m.on_frame(ms(0), 0x705, &[0x00]));
        assert_eq!(m.pop_event(), Some(HeartbeatEvent::BootUp { node_id: 5, at: ms(0) }));
        assert_eq!(m.process(ms(5000)), None);
        assert!(m.on_frame(ms(5100), 0x705, &[0x7F]));
        let pre_op = HeartbeatEvent::StateChanged {
            node_id: 5,
            previous: Some(NmtStateCode::BootUp),
            state: NmtStateCode::PreOperational,
            at: ms(5100),
        };
        assert_eq!(m.pop_event(), Some(pre_op));
        // The same state again: no event, the deadline moves.
        assert!(m.on_frame(ms(5600), 0x705, &[0x7F]));
        assert_eq!(m.pop_event(), None);
        assert_eq!(m.process(ms(6599)), Some(ms(6600)));
        assert_eq!(m.pop_event(), None);
        assert_eq!((m.state(5), m.last_seen(5), m.is_timed_out(5)), (Some(NmtStateCode::PreOperational), Some(ms(5600)), false));
        assert_eq!(m.process(ms(6600)), None);
        assert_eq!(m.pop_event(), Some(HeartbeatEvent::Timeout { node_id: 5, last: ms(5600), at: ms(6600) }));
        assert_eq!(m.process(ms(9000)), None);
        assert_eq!(m.pop_event(), None);
        assert_eq!((m.state(5), m.is_timed_out(5)), (None, true));
        // Heard again: monitoring resumes. The toggle bit (guarding) is ignored.
        assert!(m.on_frame(ms(9000), 0x705, &[0x85]));
        let op = HeartbeatEvent::StateChanged { node_id: 5, previous: None, state: NmtStateCode::Operational, at: ms(9000) };
        assert_eq!(m.pop_event(), Some(op));
        assert_eq!(m.process(ms(9000)), Some(ms(10_000)));
        assert!(!m.is_timed_out(5));
        m.unwatch(5);
        assert_eq!(m.process(ms(20_000)), None);
        assert_eq!(m.pop_event(), None);
    }

    #[test]
    fn unwatched_nodes_are_tracked_and_bad_frames_counted() {
        let mut m = HeartbeatMonitor::new();
        assert!(m.on_frame(ms(1), 0x77F, &[0x04]));
        assert_eq!(m.state(127), Some(NmtStateCode::Stopped));
        assert_eq!(m.process(ms(100_000)), None);
        for data in [&[][..], &[0x01], &[0x05, 0x00]] {
            assert!(m.on_frame(ms(2), 0x701, data));
        }
        assert_eq!((m.malformed(), m.state(1)), (3, None));
        // Not error control: node-ID 0, other services.
        for cob_id in [0x700, 0x780, 0x185, 0x000, 0x6FF] {
            assert!(!m.on_frame(ms(3), cob_id, &[0x05]));
        }
        assert_eq!(m.malformed(), 3);
    }
}
