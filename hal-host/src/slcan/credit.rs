//! Room on the wire for one sender: how many of its frames may wait for
//! the wire at once. A client's reader waits for room (TCP then holds the
//! client back); the application may wait or be told the wire is full.

use std::sync::{Condvar, Mutex, MutexGuard};

#[derive(Debug, Default)]
struct State {
    waiting: usize,
    closed: bool,
}

/// Frames of one sender on their way to the wire, at most `limit`.
#[derive(Debug)]
pub(super) struct Credit {
    limit: usize,
    state: Mutex<State>,
    changed: Condvar,
}

impl Credit {
    /// Room for `limit` frames.
    pub(super) fn new(limit: usize) -> Self {
        Credit { limit: limit.max(1), state: Mutex::new(State::default()), changed: Condvar::new() }
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        // A panic elsewhere cannot leave a count inconsistent: keep going.
        self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Takes room for one frame, waiting for it; `false` once closed.
    pub(super) fn take(&self) -> bool {
        let mut s = self.lock();
        while !s.closed && s.waiting >= self.limit {
            s = self.changed.wait(s).unwrap_or_else(std::sync::PoisonError::into_inner);
        }
        s.waiting += usize::from(!s.closed);
        !s.closed
    }

    /// Takes room for one frame if there is some: `None` once closed,
    /// `Some(false)` while the sender's frames fill its room.
    pub(super) fn try_take(&self) -> Option<bool> {
        let mut s = self.lock();
        if s.closed {
            return None;
        }
        let room = s.waiting < self.limit;
        s.waiting += usize::from(room);
        Some(room)
    }

    /// One of the sender's frames has reached the wire.
    pub(super) fn give_back(&self) {
        let mut s = self.lock();
        s.waiting = s.waiting.saturating_sub(1);
        self.changed.notify_all();
    }

    /// The sender is gone or the server stops: waiters wake up with `false`.
    pub(super) fn close(&self) {
        self.lock().closed = true;
        self.changed.notify_all();
    }

    /// Whether [`close`](Self::close) was called.
    pub(super) fn is_closed(&self) -> bool {
        self.lock().closed
    }
}

#[cfg(test)]
mod tests {
    use super::Credit;
    use std::sync::Arc;
    use std::time::Duration;

    #[test]
    fn room_is_taken_given_back_and_waited_for() {
        let c = Arc::new(Credit::new(2));
        assert_eq!((c.try_take(), c.try_take(), c.try_take()), (Some(true), Some(true), Some(false)));
        let c2 = Arc::clone(&c);
        let waiter = std::thread::spawn(move || c2.take());
        std::thread::sleep(Duration::from_millis(50));
        assert!(!waiter.is_finished(), "no room: the sender waits");
        c.give_back();
        assert!(waiter.join().unwrap());
        assert_eq!(c.try_take(), Some(false));
        let c2 = Arc::clone(&c);
        let waiter = std::thread::spawn(move || c2.take());
        c.close();
        assert!(!waiter.join().unwrap());
        assert_eq!(c.try_take(), None);
        assert!(c.is_closed());
    }
}
