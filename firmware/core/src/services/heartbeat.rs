//! Error control: heartbeat producer (0x1017), heartbeat consumer (0x1016)
//! and node/life guarding (0x100C, 0x100D). CiA 301 v4.2 §7.2.8.3.2.
//!
//! Heartbeat and guarding exclude each other: with a producer heartbeat
//! time other than 0 the node does not answer guarding requests.

use crate::time::{At, Far, NEVER, at, at_by, later, ms_span, shift, shift_opt};
use crate::wire::nmt::NmtStateCode;

/// The heartbeat producer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Producer {
    /// The period in µs (0: off).
    period: u32,
    /// When the next heartbeat is due, while `period` is not 0 (a plain
    /// time, not an `Option`: the period says whether it runs).
    next: At,
}

impl Producer {
    /// A producer that is off until [`Producer::configure`].
    pub const fn new() -> Self {
        Producer { period: 0, next: 0 }
    }

    /// Sets the period from 0x1017 (ms; 0 = off) and restarts it from `now`.
    pub fn configure(&mut self, period_ms: u16, now: At) {
        self.period = ms_span(period_ms);
        self.next = later(now, self.period);
    }

    /// Restarts the period from `now` (the boot-up: the first heartbeat
    /// one period after it), as [`Producer::configure`] with the period it has.
    pub fn restart(&mut self, now: At) {
        self.next = later(now, self.period);
    }

    /// Whether the producer runs (guarding is then off).
    pub fn active(&self) -> bool {
        self.period != 0
    }

    /// Returns true when a heartbeat is due at `now` and schedules the next one.
    pub fn poll(&mut self, now: At) -> bool {
        if self.period == 0 || now < self.next {
            return false;
        }
        // Keep the grid: a late poll does not shift later heartbeats.
        let mut next = later(self.next, self.period);
        if next <= now {
            next = later(now, self.period);
        }
        self.next = next;
        true
    }

    /// When the next heartbeat is due.
    pub fn deadline(&self) -> At {
        if self.period == 0 { NEVER } else { self.next }
    }

    /// The epoch moved by `by` µs.
    pub(crate) fn shift(&mut self, by: u64) {
        // Off, `next` is never read: shifted all the same.
        shift(&mut self.next, at_by(by));
    }
}

/// One monitored node of 0x1016.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Monitor {
    node_id: u8,
    /// The consumer heartbeat time in µs.
    time: u32,
    /// Deadline once armed by the first heartbeat.
    deadline: Option<At>,
    /// The last state reported, valid once `heard`. Not an `Option`: its
    /// `None` would not be all zero bits ([`crate::node`]).
    state: NmtStateCode,
    heard: bool,
    /// It missed its heartbeat and has not been heard of since.
    timed_out: bool,
}

impl Monitor {
    /// An entry that monitors nothing.
    const OFF: Monitor = Monitor { node_id: 0, time: 0, deadline: None, state: NmtStateCode::BootUp, heard: false, timed_out: false };
}

/// A heartbeat consumer event.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConsumerEvent {
    /// A monitored node missed its heartbeat (EMCY 0x8130, then 0x1029).
    Timeout {
        /// The silent node.
        node_id: u8,
    },
}

/// The heartbeat consumer for up to `N` producers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Consumer<const N: usize> {
    monitors: [Monitor; N],
}

impl<const N: usize> Default for Consumer<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Consumer<N> {
    /// A consumer that monitors nothing until [`Consumer::configure`].
    pub const fn new() -> Self {
        Consumer { monitors: [Monitor::OFF; N] }
    }

    /// Sets entry `i` (0-based) from its 0x1016 value: node-id in bits 16..23,
    /// time in ms in bits 0..15. A zero node-id or time disables it; the
    /// entry waits for the first heartbeat again.
    pub fn configure(&mut self, i: usize, value: u32) {
        if let Some(m) = self.monitors.get_mut(i) {
            let node_id = (value >> 16) as u8;
            let ms = value as u16;
            *m = Monitor { node_id: if ms == 0 { 0 } else { node_id }, time: ms_span(ms), ..Monitor::OFF };
        }
    }

    /// The node-ids of the producers monitored (entries with a time).
    pub fn producers(&self) -> impl Iterator<Item = u8> + '_ {
        self.monitors.iter().map(|m| m.node_id).filter(|&id| id != 0)
    }

    /// Checks a new 0x1016 entry: CiA 301 forbids two entries for one node
    /// with non-zero times (abort 0x06040043 in the node).
    pub fn conflicts(&self, i: usize, value: u32) -> bool {
        let node_id = (value >> 16) as u8;
        node_id != 0 && value as u16 != 0 && self.monitors.iter().enumerate().any(|(j, m)| j != i && m.node_id == node_id && m.time != 0)
    }

    /// A heartbeat (or boot-up) from `node_id` arrived at `now`. Returns
    /// true if that node had timed out: it is back.
    pub fn on_heartbeat(&mut self, node_id: u8, state: NmtStateCode, now: At) -> bool {
        let mut back = false;
        if node_id == 0 {
            return false;
        }
        for m in self.monitors.iter_mut().filter(|m| m.node_id == node_id) {
            // A boot-up message means the producer restarted: monitoring starts over.
            m.deadline = if state == NmtStateCode::BootUp { None } else { Some(later(now, m.time)) };
            m.state = state;
            m.heard = true;
            back |= core::mem::take(&mut m.timed_out);
        }
        back
    }

    /// Reports the first expired monitor and disarms it until its next heartbeat.
    pub fn poll(&mut self, now: At) -> Option<ConsumerEvent> {
        let m = self.monitors.iter_mut().find(|m| m.deadline.is_some_and(|d| now >= d))?;
        m.deadline = None;
        m.timed_out = true;
        Some(ConsumerEvent::Timeout { node_id: m.node_id })
    }

    /// [`Consumer::poll`], or, when no monitor expired, the earliest
    /// deadline ([`Consumer::deadline`]).
    // For a long list one walk, which finds the expired monitor and folds
    // the deadlines (a poll and then the deadline took two: 58 bytes more
    // for 8 monitors); a short one is unrolled, where the two walks are
    // smaller (a device with 3 monitors: 36 bytes).
    pub fn expire(&mut self, now: At) -> Result<ConsumerEvent, At> {
        if N <= 4 {
            return self.poll(now).ok_or_else(|| self.deadline());
        }
        let mut deadline = NEVER;
        for m in &mut self.monitors {
            if let Some(d) = m.deadline {
                if now >= d {
                    m.deadline = None;
                    m.timed_out = true;
                    return Ok(ConsumerEvent::Timeout { node_id: m.node_id });
                }
                deadline = deadline.min(d);
            }
        }
        Err(deadline)
    }

    /// Whether a monitored node is silent since its heartbeat event.
    pub fn any_timed_out(&self) -> bool {
        self.monitors.iter().any(|m| m.timed_out)
    }

    /// The earliest heartbeat deadline.
    pub fn deadline(&self) -> At {
        self.monitors.iter().fold(NEVER, |d, m| d.min(at(m.deadline)))
    }

    /// The epoch moved by `by` µs.
    pub(crate) fn shift(&mut self, by: u64) {
        let by = at_by(by);
        for m in &mut self.monitors {
            shift_opt(&mut m.deadline, by);
        }
    }

    /// The last state `node_id` reported.
    pub fn state_of(&self, node_id: u8) -> Option<NmtStateCode> {
        self.monitors.iter().find(|m| m.node_id == node_id).and_then(|m| m.heard.then_some(m.state))
    }
}

/// Node guarding (the node answers RTRs) and life guarding (the node
/// watches that the master keeps asking).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Guarding {
    toggle: bool,
    /// 0x100C, the guard time in ms, and 0x100D, the life time factor: the
    /// life time is their product (0: no life guarding). Kept apart, so
    /// that a download of either applies its own value.
    guard_time_ms: u16,
    factor: u8,
    /// When life guarding expires: up to 4.6 hours ahead.
    deadline: Option<Far>,
    /// Life guarding expired, and no guarding request came since.
    expired: bool,
}

impl Guarding {
    /// Guarding with no life time until [`Guarding::set_guard_time`] and
    /// [`Guarding::set_life_time_factor`]; life guarding starts with the
    /// first guarding request.
    pub const fn new() -> Self {
        Guarding { toggle: false, guard_time_ms: 0, factor: 0, deadline: None, expired: false }
    }

    /// 0x100C, the guard time in ms (the life time is 0x100C × 0x100D).
    pub fn set_guard_time(&mut self, ms: u16) {
        self.guard_time_ms = ms;
        self.deadline = None;
    }

    /// 0x100D, the life time factor.
    pub fn set_life_time_factor(&mut self, factor: u8) {
        self.factor = factor;
        self.deadline = None;
    }

    /// Restarts the toggle bit at 0 (reset communication).
    pub fn reset(&mut self) {
        self.toggle = false;
        self.deadline = None;
        self.expired = false;
    }

    /// Stops life guarding until the next guarding request (the toggle bit
    /// stays): heartbeat production took over.
    pub fn disarm(&mut self) {
        self.deadline = None;
    }

    /// A guarding RTR arrived: returns the response byte (state | toggle).
    pub fn on_request(&mut self, state: NmtStateCode, now: At) -> u8 {
        let byte = state.code() | if self.toggle { 0x80 } else { 0 };
        self.toggle = !self.toggle;
        // A u16 times a u8 times 1000 fits a u64.
        #[allow(clippy::arithmetic_side_effects)]
        let lifetime = u64::from(self.guard_time_ms) * u64::from(self.factor) * 1000;
        self.deadline = (lifetime != 0).then(|| Far::after(now, lifetime));
        self.expired = false;
        byte
    }

    /// Whether life guarding expired and the master has not asked since.
    pub fn is_expired(&self) -> bool {
        self.expired
    }

    /// True once when the master stopped guarding for a whole life time (EMCY 0x8130).
    pub fn poll(&mut self, now: At) -> bool {
        if self.deadline.is_some_and(|d| d.reached(now)) {
            self.deadline = None;
            self.expired = true;
            return true;
        }
        false
    }

    /// When life guarding expires (or earlier, for a life time beyond an [`At`]).
    pub fn deadline(&self) -> At {
        self.deadline.map_or(NEVER, Far::at)
    }

    /// The epoch moved by `by` µs.
    pub(crate) fn shift(&mut self, by: u64) {
        if let Some(d) = &mut self.deadline {
            d.shift(by);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::time::deadline_of;

    fn ms(n: u32) -> At {
        n * 1000
    }

    #[test]
    fn producer_keeps_its_period() {
        let mut p = Producer::default();
        p.configure(100, ms(0));
        assert!(!p.poll(ms(99)));
        assert!(p.poll(ms(100)));
        assert!(!p.poll(ms(150)));
        assert!(p.poll(ms(205)));
        assert_eq!(deadline_of(p.deadline()), Some(ms(300)));
        p.shift(u64::from(ms(250)));
        assert_eq!(deadline_of(p.deadline()), Some(ms(50)), "moved with the epoch");
        p.configure(0, ms(300));
        assert!(!p.active() && !p.poll(ms(1000)));
        assert_eq!(p.deadline(), NEVER, "off: no deadline");
        p.shift(u64::from(ms(5000)));
        assert!(!p.poll(ms(0)) && p.deadline() == NEVER, "off stays off across an epoch move");
        p.configure(10, ms(0));
        assert!(!p.poll(ms(9)) && p.poll(ms(10)));
    }

    #[test]
    fn consumer_is_armed_by_the_first_heartbeat() {
        let mut c = Consumer::<2>::default();
        c.configure(0, 0x0003_0064); // node 3, 100 ms
        assert_eq!(c.state_of(3), None, "not heard of yet");
        assert_eq!(c.poll(ms(1000)), None, "not armed before the first heartbeat");
        c.on_heartbeat(3, NmtStateCode::Operational, ms(1000));
        assert_eq!(c.poll(ms(1099)), None);
        assert_eq!(c.poll(ms(1100)), Some(ConsumerEvent::Timeout { node_id: 3 }));
        assert_eq!(c.poll(ms(5000)), None, "reported once");
        assert!(c.any_timed_out());
        assert!(c.on_heartbeat(3, NmtStateCode::Operational, ms(5500)), "back");
        assert!(!c.any_timed_out());
        c.on_heartbeat(3, NmtStateCode::BootUp, ms(6000));
        assert_eq!(deadline_of(c.deadline()), None);
        assert_eq!(c.state_of(3), Some(NmtStateCode::BootUp));
        assert!(c.conflicts(1, 0x0003_0010));
        assert!(!c.conflicts(1, 0x0003_0000));
        assert!(!c.conflicts(0, 0x0003_0010));
    }

    /// `expire` as a poll and then the deadline, for a short list (two
    /// walks) and a long one (one walk).
    fn expire_is_poll_then_deadline<const N: usize>() {
        let mut c = Consumer::<N>::default();
        let mut twin = Consumer::<N>::default();
        for (i, (node, ms)) in [(3u32, 100u32), (4, 50), (5, 70)].into_iter().enumerate() {
            c.configure(i, node << 16 | ms);
            twin.configure(i, node << 16 | ms);
        }
        for c in [&mut c, &mut twin] {
            c.on_heartbeat(3, NmtStateCode::Operational, ms(0));
            c.on_heartbeat(4, NmtStateCode::Operational, ms(10));
            c.on_heartbeat(5, NmtStateCode::Operational, ms(20));
        }
        for now in [ms(59), ms(60), ms(89), ms(95), ms(100), ms(1000)] {
            loop {
                let (polled, deadline) = (twin.poll(now), twin.deadline());
                let expired = c.expire(now);
                match polled {
                    Some(event) => assert_eq!(expired, Ok(event)),
                    None => {
                        assert_eq!(expired, Err(deadline));
                        break;
                    }
                }
            }
        }
        assert_eq!(c, twin);
        assert_eq!(c.expire(ms(2000)), Err(NEVER));
    }

    #[test]
    fn expire_is_a_poll_then_the_deadline() {
        expire_is_poll_then_deadline::<3>();
        expire_is_poll_then_deadline::<8>();
    }

    #[test]
    fn guarding_toggles_and_watches_the_life_time() {
        let mut g = Guarding::default();
        g.set_guard_time(100);
        g.set_life_time_factor(3);
        assert_eq!(g.on_request(NmtStateCode::PreOperational, ms(0)), 0x7F);
        assert_eq!(g.on_request(NmtStateCode::PreOperational, ms(100)), 0xFF);
        assert_eq!(g.on_request(NmtStateCode::Operational, ms(200)), 0x05);
        assert!(!g.poll(ms(499)));
        assert!(g.poll(ms(500)));
        assert!(!g.poll(ms(900)));
        g.reset();
        assert_eq!(g.on_request(NmtStateCode::Stopped, ms(1000)), 0x04);
    }
}
