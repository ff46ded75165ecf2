//! The bounded transmit queue: frames leave in CAN priority order (lowest
//! identifier first), and frames with the same identifier leave in the order
//! they were queued, as SDO block segments must. A full queue refuses the
//! frame and counts it; the node turns that into EMCY 0x8110.

use crate::frame::CanFrame;

/// A priority queue of at most `N` frames.
#[derive(Clone, Debug)]
pub struct TxQueue<const N: usize> {
    slots: [Option<(u32, i64, CanFrame)>; N],
    len: usize,
    next_seq: i64,
    front_seq: i64,
    overflows: u32,
}

impl<const N: usize> Default for TxQueue<N> {
    fn default() -> Self {
        TxQueue { slots: [None; N], len: 0, next_seq: 0, front_seq: -1, overflows: 0 }
    }
}

impl<const N: usize> TxQueue<N> {
    /// Queues a frame; false (and one more overflow) when full.
    // Out of line: every service that sends had a copy (128 bytes more).
    #[inline(never)]
    pub fn push(&mut self, frame: CanFrame) -> bool {
        let seq = self.next_seq;
        if self.insert(frame, seq) {
            self.next_seq += 1;
            true
        } else {
            self.overflows = self.overflows.saturating_add(1);
            false
        }
    }

    /// Puts back a frame the controller handed back, ahead of every queued
    /// frame with its identifier (bxCAN mailbox pre-emption).
    pub fn push_front(&mut self, frame: CanFrame) -> bool {
        let seq = self.front_seq;
        let ok = self.insert(frame, seq);
        if ok {
            self.front_seq -= 1;
        } else {
            self.overflows = self.overflows.saturating_add(1);
        }
        ok
    }

    fn insert(&mut self, frame: CanFrame, seq: i64) -> bool {
        let Some(slot) = self.slots.iter_mut().find(|s| s.is_none()) else { return false };
        *slot = Some((frame.priority(), seq, frame));
        self.len += 1;
        true
    }

    fn best(&self) -> Option<usize> {
        if self.len == 0 {
            return None;
        }
        self.slots.iter().enumerate().filter_map(|(i, s)| s.map(|(p, q, _)| (p, q, i))).min().map(|(_, _, i)| i)
    }

    /// The frame that goes next, without removing it.
    pub fn peek(&self) -> Option<&CanFrame> {
        self.best().and_then(|i| self.slots.get(i)).and_then(|s| s.as_ref()).map(|(_, _, f)| f)
    }

    /// Removes the frame that goes next.
    pub fn pop(&mut self) -> Option<CanFrame> {
        let i = self.best()?;
        let (_, _, f) = self.slots.get_mut(i)?.take()?;
        self.len -= 1;
        Some(f)
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
        self.slots = [None; N];
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
