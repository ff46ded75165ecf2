//! The bounded transmit queue: frames leave in CAN priority order (lowest
//! identifier first), and frames with the same identifier leave in the order
//! they were queued, as SDO block segments must. A full queue refuses the
//! frame and counts it; the node turns that into EMCY 0x8110.

use crate::frame::CanFrame;

/// The sequence number of a free slot.
const FREE: i64 = 0;

/// A priority queue of at most `N` frames.
///
/// A new queue is all zero bits ([`crate::node`]): hence a slot is free
/// when its sequence number is 0 rather than being an `Option` (whose
/// `None` is not zero). Frames queued count up from
/// 1, frames put back ([`TxQueue::push_front`]) down from -1.
#[derive(Clone, Debug)]
pub struct TxQueue<const N: usize> {
    /// (priority, sequence number, frame); free where the sequence number is 0.
    slots: [(u32, i64, CanFrame); N],
    len: usize,
    /// The sequence number of the last frame queued.
    next_seq: i64,
    /// The sequence number of the last frame put back.
    front_seq: i64,
    overflows: u32,
}

impl<const N: usize> Default for TxQueue<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> TxQueue<N> {
    /// An empty queue.
    pub const fn new() -> Self {
        TxQueue { slots: [(0, FREE, CanFrame::EMPTY); N], len: 0, next_seq: 0, front_seq: 0, overflows: 0 }
    }

    /// Queues a frame; false (and one more overflow) when full.
    // Out of line: every service that sends had a copy (128 bytes more).
    #[inline(never)]
    pub fn push(&mut self, frame: CanFrame) -> bool {
        let seq = self.next_seq + 1;
        if self.insert(frame, seq) {
            self.next_seq = seq;
            true
        } else {
            self.overflows = self.overflows.saturating_add(1);
            false
        }
    }

    /// Counts a frame refused before it reached the queue (a sender's share was used up).
    pub fn count_overflow(&mut self) {
        self.overflows = self.overflows.saturating_add(1);
    }

    /// Puts back a frame the controller handed back, ahead of every queued
    /// frame with its identifier (bxCAN mailbox pre-emption).
    pub fn push_front(&mut self, frame: CanFrame) -> bool {
        let seq = self.front_seq - 1;
        let ok = self.insert(frame, seq);
        if ok {
            self.front_seq = seq;
        } else {
            self.overflows = self.overflows.saturating_add(1);
        }
        ok
    }

    fn insert(&mut self, frame: CanFrame, seq: i64) -> bool {
        let Some(slot) = self.slots.iter_mut().find(|(_, q, _)| *q == FREE) else { return false };
        *slot = (frame.priority(), seq, frame);
        self.len += 1;
        true
    }

    fn best(&self) -> Option<usize> {
        if self.len == 0 {
            return None;
        }
        self.slots.iter().enumerate().filter(|(_, (_, q, _))| *q != FREE).map(|(i, (p, q, _))| (p, q, i)).min().map(|(_, _, i)| i)
    }

    /// The frame that goes next, without removing it.
    pub fn peek(&self) -> Option<&CanFrame> {
        self.best().and_then(|i| self.slots.get(i)).map(|(_, _, f)| f)
    }

    /// Removes the frame that goes next.
    pub fn pop(&mut self) -> Option<CanFrame> {
        let i = self.best()?;
        let (_, seq, f) = self.slots.get_mut(i)?;
        *seq = FREE;
        self.len -= 1;
        Some(*f)
    }

    /// Frames queued.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether nothing is queued.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Free slots.
    pub fn free(&self) -> usize {
        N - self.len
    }

    /// Frames refused because the queue was full.
    pub fn overflows(&self) -> u32 {
        self.overflows
    }

    /// Drops every queued frame (the node goes silent, e.g. for an LSS bit-rate switch).
    pub fn clear(&mut self) {
        self.slots.iter_mut().for_each(|(_, seq, _)| *seq = FREE);
        self.len = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(id: u16, tag: u8) -> CanFrame {
        CanFrame::standard(id, &[tag]).unwrap()
    }

    #[test]
    fn priority_then_fifo() {
        let mut q = TxQueue::<4>::default();
        assert!(q.push(f(0x581, 1)));
        assert!(q.push(f(0x181, 2)));
        assert!(q.push(f(0x581, 3)));
        assert!(q.push(f(0x701, 4)));
        assert!(!q.push(f(0x080, 5)));
        assert_eq!(q.overflows(), 1);
        let order: Vec<u8> = core::iter::from_fn(|| q.pop()).map(|f| embedded_can::Frame::data(&f)[0]).collect();
        assert_eq!(order, [2, 1, 3, 4]);
        assert!(q.is_empty());
    }

    #[test]
    fn frames_of_one_identifier_keep_their_order_when_others_leave_between() {
        // Frames leave from any slot, and new ones fill the first free one.
        let mut q = TxQueue::<8>::new();
        for (id, tag) in [(0x581, 1), (0x181, 9), (0x581, 2), (0x581, 3), (0x201, 8), (0x581, 4)] {
            assert!(q.push(f(id, tag)));
        }
        let mut next = || q.pop().map(|f| embedded_can::Frame::data(&f)[0]);
        assert_eq!([next(), next()], [Some(9), Some(8)]);
        assert!(q.push(f(0x581, 5)));
        assert!(q.push_front(f(0x581, 0)));
        let order: Vec<u8> = core::iter::from_fn(|| q.pop()).map(|f| embedded_can::Frame::data(&f)[0]).collect();
        assert_eq!(order, [0, 1, 2, 3, 4, 5]);
    }

    #[test]
    fn a_returned_frame_goes_first_among_equals() {
        let mut q = TxQueue::<4>::default();
        q.push(f(0x581, 2));
        q.push(f(0x581, 3));
        q.push_front(f(0x581, 1));
        assert_eq!(q.peek().map(|f| embedded_can::Frame::data(f)[0]), Some(1));
        assert_eq!(q.len(), 3);
        assert_eq!(q.free(), 1);
        q.clear();
        assert_eq!(q.pop(), None);
    }
}
