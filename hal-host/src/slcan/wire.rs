//! The wire behind an [`SlcanServer`](super::SlcanServer): one thread puts
//! every frame on it in turn, the node's and each client's, holds it for
//! the frame's time at the bus's bit rate, then hands it to every receiver.
//!
//! One thread for the whole bus gives every observer the same order, as a
//! real bus does. Frames take the wire in the order they were offered
//! (first come, first served: no arbitration between waiting senders, so a
//! burst from one client cannot starve the node's answers).

use super::server::{Client, Hub};
use crate::bus::{BitRate, frame_time_ns};
use canopen_core::frame::CanFrame;
use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use std::time::{Duration, Instant};

/// How far the wire may run ahead of wall time before the thread sleeps:
/// the pacing is exact on average and at most this early for one frame,
/// without a sleep (and its scheduler overshoot) per frame.
pub(super) const SLACK: Duration = Duration::from_micros(500);

/// Something offered to the wire.
pub(super) enum WireEvent {
    /// A frame a client sent (its adapter already answered `z`/`Z`).
    Client(Arc<Client>, CanFrame),
    /// A frame the application (the node) sent.
    Node(CanFrame),
    /// The server is shutting down.
    Stop,
}

/// The wire's clock: when the frame on it ends.
#[derive(Clone, Copy, Debug)]
pub(super) struct Pacer {
    busy_until: Instant,
}

impl Pacer {
    /// An idle wire.
    pub(super) fn new(now: Instant) -> Self {
        Pacer { busy_until: now }
    }

    /// Puts a frame of `ns` nanoseconds on the wire at `now` (or when the
    /// one before ends) and returns how long to wait before it may be
    /// delivered, if the wire is more than [`SLACK`] ahead. The wait ends
    /// half the slack early, so a sleep that overshoots by less than that
    /// never leaves the wire idle: the rate stays exact on average.
    pub(super) fn occupy(&mut self, now: Instant, ns: u64) -> Option<Duration> {
        self.busy_until = self.busy_until.max(now) + Duration::from_nanos(ns);
        let ahead = self.busy_until.saturating_duration_since(now);
        (ahead > SLACK).then(|| ahead - SLACK / 2)
    }
}

/// How often the wire looks whether the server stops while it waits for
/// an application that is behind.
const APP_POLL: Duration = Duration::from_millis(1);

/// Runs the wire until [`WireEvent::Stop`]. Frames from clients go to the
/// application on `to_app` (the wire waits while the application is
/// behind) and to every other client; the node's frames go to every client.
///
/// While the wire waits for the application, the application's own frames
/// still go out (its transmit buffers do not wait for its receive queue):
/// an application that takes no frame while one of its own waits for the
/// wire then never waits for a wire that waits for it. Clients' frames
/// offered meanwhile keep their order behind the one being handed over.
pub(super) fn run(hub: &Hub, events: &Receiver<WireEvent>, to_app: &SyncSender<CanFrame>) {
    let mut wire = Wire { hub, pacer: Pacer::new(Instant::now()), later: VecDeque::new() };
    loop {
        let event = match wire.later.pop_front() {
            Some(event) => event,
            None => match events.recv() {
                Ok(event) => event,
                Err(_) => return,
            },
        };
        match event {
            WireEvent::Client(sender, frame) => {
                sender.credit_returned();
                wire.carry(&frame, Some(sender.id()));
                if !wire.hand_to_app(events, to_app, frame) {
                    return;
                }
            }
            WireEvent::Node(frame) => wire.carry_node(&frame),
            WireEvent::Stop => return,
        }
    }
}

/// The wire thread's state.
struct Wire<'a> {
    hub: &'a Hub,
    pacer: Pacer,
    /// Clients' frames offered while the application was behind, in order
    /// (at most [`ServerOptions::client_tx_frames`](super::ServerOptions)
    /// per client: their credit comes back only once they are carried).
    later: VecDeque<WireEvent>,
}

impl Wire<'_> {
    /// Holds the wire for the frame's time, then hands it to every client
    /// except `sender`.
    fn carry(&mut self, frame: &CanFrame, sender: Option<u64>) {
        let rate = BitRate::new(self.hub.bit_rate()).unwrap_or(BitRate::MBIT_1);
        if let Some(wait) = self.pacer.occupy(Instant::now(), frame_time_ns(frame, rate)) {
            std::thread::sleep(wait);
        }
        self.hub.broadcast(frame, sender);
    }

    fn carry_node(&mut self, frame: &CanFrame) {
        self.hub.app_credit_returned();
        self.carry(frame, None);
    }

    /// Gives the application a frame, waiting while it is behind unless the
    /// server stops (no application listening is not the clients' problem);
    /// meanwhile carries the application's own frames. False on
    /// [`WireEvent::Stop`].
    fn hand_to_app(&mut self, events: &Receiver<WireEvent>, to_app: &SyncSender<CanFrame>, mut frame: CanFrame) -> bool {
        loop {
            match to_app.try_send(frame) {
                Err(TrySendError::Full(f)) if !self.hub.stopping() => frame = f,
                _ => return true,
            }
            while let Ok(event) = events.try_recv() {
                match event {
                    WireEvent::Node(f) => self.carry_node(&f),
                    WireEvent::Stop => return false,
                    client => self.later.push_back(client),
                }
            }
            std::thread::sleep(APP_POLL);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{Pacer, SLACK};
    use std::time::{Duration, Instant};

    #[test]
    fn the_wire_runs_at_the_bit_rate_on_average() {
        let t0 = Instant::now();
        let mut p = Pacer::new(t0);
        // 100 µs frames offered all at once: the first few fit in the slack,
        // then each waits until its end.
        let waits: Vec<Option<Duration>> = (0..8).map(|_| p.occupy(t0, 100_000)).collect();
        assert_eq!(&waits[..5], &[None; 5]);
        assert_eq!(waits[5], Some(Duration::from_micros(600) - SLACK / 2));
        assert_eq!(waits[7], Some(Duration::from_micros(800) - SLACK / 2));
        // An idle wire starts the next frame now, not where the last one ended.
        let later = t0 + Duration::from_secs(1);
        assert_eq!(p.occupy(later, 100_000), None);
        assert_eq!(p.occupy(later, SLACK.as_nanos() as u64), Some(SLACK / 2 + Duration::from_micros(100)));
    }
}
