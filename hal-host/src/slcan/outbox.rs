//! The bytes waiting to be written to one SLCAN client, bounded.
//!
//! Two kinds of bytes go to a client: the answers to its own commands and
//! the frames it receives from the bus. Frames never wait: when the client
//! is [`LIMIT`](Outbox::new) bytes behind, a frame is dropped and counted,
//! as an adapter whose receive FIFO is full loses the newest frame. Answers
//! wait instead (the client's own reader thread blocks), which throttles a
//! client that sends without reading and nobody else.

use std::sync::{Condvar, Mutex, MutexGuard};

#[derive(Debug, Default)]
struct State {
    pending: Vec<u8>,
    closed: bool,
    dropped: u64,
}

/// A bounded byte queue with one writer thread taking from it.
#[derive(Debug)]
pub(super) struct Outbox {
    limit: usize,
    state: Mutex<State>,
    changed: Condvar,
}

impl Outbox {
    /// An open outbox that holds at most `limit` bytes of frames.
    pub(super) fn new(limit: usize) -> Self {
        Outbox { limit, state: Mutex::new(State::default()), changed: Condvar::new() }
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        // The state stays consistent across a panic elsewhere: keep going.
        self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Queues a received frame's line; `false` (and counted) when the
    /// client is too far behind or gone.
    pub(super) fn push_frame(&self, line: &[u8]) -> bool {
        let mut s = self.lock();
        if s.closed || s.pending.len() + line.len() > self.limit {
            s.dropped += 1;
            return false;
        }
        s.pending.extend_from_slice(line);
        self.changed.notify_all();
        true
    }

    /// Queues the answer to a command at once; `false` when the client is
    /// too far behind (then [`Outbox::push_reply`] waits) or gone.
    pub(super) fn try_push_reply(&self, reply: &[u8]) -> bool {
        let mut s = self.lock();
        if s.closed || s.pending.len() >= self.limit {
            return false;
        }
        s.pending.extend_from_slice(reply);
        self.changed.notify_all();
        true
    }

    /// Queues the answer to a command, waiting while the client is too far
    /// behind; `false` once the outbox is closed.
    pub(super) fn push_reply(&self, reply: &[u8]) -> bool {
        let mut s = self.lock();
        while !s.closed && s.pending.len() >= self.limit {
            s = self.changed.wait(s).unwrap_or_else(std::sync::PoisonError::into_inner);
        }
        if s.closed {
            return false;
        }
        s.pending.extend_from_slice(reply);
        self.changed.notify_all();
        true
    }

    /// Waits for bytes and moves them into `buf` (emptied first); `false`
    /// when the outbox is closed and empty.
    pub(super) fn take(&self, buf: &mut Vec<u8>) -> bool {
        buf.clear();
        let mut s = self.lock();
        while !s.closed && s.pending.is_empty() {
            s = self.changed.wait(s).unwrap_or_else(std::sync::PoisonError::into_inner);
        }
        if s.pending.is_empty() {
            return false;
        }
        std::mem::swap(&mut s.pending, buf);
        self.changed.notify_all();
        true
    }

    /// Closes the outbox: pushes fail from now on, waiters wake up, and the
    /// writer gets what is still pending, then `false`.
    pub(super) fn close(&self) {
        self.lock().closed = true;
        self.changed.notify_all();
    }

    /// Frames dropped so far.
    pub(super) fn dropped(&self) -> u64 {
        self.lock().dropped
    }
}

#[cfg(test)]
mod tests {
    use super::Outbox;
    use std::sync::Arc;
    use std::time::Duration;

    #[test]
    fn frames_past_the_limit_are_dropped_and_counted() {
        let o = Outbox::new(10);
        assert!(o.push_frame(b"t0800\r"));
        assert!(!o.push_frame(b"t0800\r"), "12 bytes do not fit in 10");
        assert!(o.push_frame(b"t08\r"));
        assert_eq!(o.dropped(), 1);
        let mut buf = Vec::new();
        assert!(o.take(&mut buf));
        assert_eq!(buf, b"t0800\rt08\r");
        assert!(o.push_frame(b"t0800\r"), "room again once the writer took the bytes");
        o.close();
        assert!(o.take(&mut buf), "what was pending still goes out");
        assert!(!o.take(&mut buf));
        assert!(!o.push_frame(b"x"));
        assert_eq!(o.dropped(), 2);
    }

    #[test]
    fn replies_wait_for_room_and_give_up_when_closed() {
        let o = Arc::new(Outbox::new(4));
        assert!(o.push_reply(b"\r\r\r\r"));
        let o2 = Arc::clone(&o);
        let waiter = std::thread::spawn(move || o2.push_reply(b"z\r"));
        std::thread::sleep(Duration::from_millis(50));
        assert!(!waiter.is_finished(), "the reply waits while the client is behind");
        let mut buf = Vec::new();
        assert!(o.take(&mut buf));
        assert!(waiter.join().unwrap());
        assert!(o.take(&mut buf));
        assert_eq!(buf, b"z\r");
        assert!(o.push_reply(b"\r\r\r\r"));
        let o2 = Arc::clone(&o);
        let waiter = std::thread::spawn(move || o2.push_reply(b"z\r"));
        o.close();
        assert!(!waiter.join().unwrap());
    }
}
