//! The bounded transmit queue: frames leave in CAN priority order (lowest
//! identifier first), and frames with the same identifier leave in the order
//! they were queued, as SDO block segments must. A full queue refuses the
//! frame and counts it; the node turns that into EMCY 0x8110.

use crate::frame::CanFrame;

/// A priority queue of at most `N` frames (a power of two, at most 32).
///
/// The frames lie in a ring in the order they leave, the next one at
/// `head`: a pop takes the head, and a push is one insertion step from the
/// tail, with nothing to move when the new frame leaves last (a burst of one
/// identifier, TPDOs queued in identifier order, an answer into an empty
/// queue). An earlier version kept the frames in fixed slots with a ring of
/// slot indices and an occupancy bitmap beside them: every push and pop went
/// through both (about 15 thumbv7m instructions a frame more); before that
/// the queue scanned every slot for the lowest (priority, sequence number).
/// Ties need no sequence number: a frame is inserted behind every queued
/// frame of its priority ([`TxQueue::push`]) or ahead of them
/// ([`TxQueue::push_front`]).
///
/// A new queue is all zero bits ([`crate::node`]).
#[derive(Clone, Debug)]
// The counters first, then the arrays: thumbv7m reaches them with 2-byte loads (offsets under 128).
#[repr(C)]
pub struct TxQueue<const N: usize> {
    /// Always below N.
    head: usize,
    len: usize,
    overflows: u32,
    /// The priority of the frame in `slots[i]`, beside it, so that the insertion compares words.
    keys: [u32; N],
    /// The queued frames in the order they leave: `slots[(head + j) % N]` for `j` in `0..len`.
    slots: [CanFrame; N],
}

impl<const N: usize> Default for TxQueue<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> TxQueue<N> {
    /// Ring positions wrap with a mask.
    const FITS: () = assert!(N <= 32 && N.is_power_of_two(), "a TxQueue holds a power of two frames, at most 32");
    /// Ring positions are modulo N.
    const MASK: usize = N - 1;

    /// An empty queue.
    pub const fn new() -> Self {
        let () = Self::FITS;
        TxQueue { slots: [CanFrame::EMPTY; N], keys: [0; N], head: 0, len: 0, overflows: 0 }
    }

    /// Queues a frame behind every queued frame of its priority; false (and
    /// one more overflow) when full.
    // In line: a call of the out-of-line insertion.
    #[inline(always)]
    pub fn push(&mut self, frame: CanFrame) -> bool {
        self.insert(frame, false)
    }

    /// Counts a frame refused before it reached the queue (a sender's share was used up).
    pub fn count_overflow(&mut self) {
        self.overflows = self.overflows.saturating_add(1);
    }

    /// Puts back a frame the controller handed back, ahead of every queued
    /// frame with its identifier (bxCAN mailbox pre-emption).
    pub fn push_front(&mut self, frame: CanFrame) -> bool {
        self.insert(frame, true)
    }

    /// Queues a data frame on the 11-bit `cob_id` (above 0x7FF: refused,
    /// not counted) whose first `len` (at most 8) of `data` are sent,
    /// behind every queued frame of its priority; false (and one more
    /// overflow) when full. The frame is written straight into its slot:
    /// no `CanFrame` built by slice copy and moved.
    // Out of line: the event-driven TPDOs' paths share it.
    #[inline(never)]
    pub fn push_data(&mut self, cob_id: u16, data: &[u8; 8], len: u8) -> bool {
        if cob_id > 0x7FF || len > 8 {
            return false;
        }
        let key = u32::from(cob_id) << 21;
        // Into an empty queue (an event-driven TPDO, mostly): the head, without the reservation's call.
        let slot = if self.len == 0 { self.place(self.head & Self::MASK, key) } else { self.reserve(key, false) };
        slot.map(|f| *f.standard_data(cob_id, len) = *data).is_some()
    }

    /// Queues a data frame of `len` (at most 8) bytes on the 11-bit
    /// `cob_id` (above 0x7FF: refused, not counted), behind every queued
    /// frame of its priority, and hands out its 8 data bytes for the
    /// caller to fill, all 8 (they hold an older frame's bytes; those past
    /// `len` are not sent, and a TPDO zeroes them); `None` (and one more overflow) when full. A TPDO
    /// is built right there: no buffer on the stack, no copy (a SYNC's
    /// burst above all).
    // In line: the reservation is out of line, and a TPDO's SYNC path
    // calls it directly.
    #[inline(always)]
    pub fn reserve_data(&mut self, cob_id: u16, len: u8) -> Option<&mut [u8; 8]> {
        if cob_id > 0x7FF || len > 8 {
            return None;
        }
        // A standard data frame's priority: its identifier in the top 11 bits.
        Some(self.reserve(u32::from(cob_id) << 21, false)?.standard_data(cob_id, len))
    }

    // Out of line: the core of push and push_front.
    #[inline(never)]
    fn insert(&mut self, frame: CanFrame, ahead: bool) -> bool {
        self.reserve(frame.priority(), ahead).map(|slot| *slot = frame).is_some()
    }

    /// The place in the ring for a frame of priority `key` (behind its
    /// equals, or `ahead` of them), the frames that leave after it moved
    /// back by one; `None` (and one more overflow) when all N are used.
    // Out of line: one copy for every frame queued.
    #[inline(never)]
    fn reserve(&mut self, key: u32, ahead: bool) -> Option<&mut CanFrame> {
        if self.len >= N {
            self.overflows = self.overflows.saturating_add(1);
            return None;
        }
        let mut at = self.head.wrapping_add(self.len) & Self::MASK;
        // One insertion step from the tail: queued frames that leave after
        // the new one move back by one. It stays behind lower keys, and
        // behind its equals unless it goes `ahead` of them. No fast path for
        // the frame that leaves last (the loop's first compare stops there):
        // 44 B less, for about 7 thumbv7m instructions on such a frame (a
        // SYNC's TPDOs).
        while at != self.head {
            let before = at.wrapping_sub(1) & Self::MASK;
            let Some(&k) = self.keys.get(before) else { break };
            if k < key || (k == key && !ahead) {
                break;
            }
            if let Some(kk) = self.keys.get_mut(at) {
                *kk = k;
            }
            // Two disjoint borrows: a copy within one array would be a
            // `memmove` call (1.6 KB linked in).
            let pair = match at {
                0 => self.slots.split_at_mut_checked(Self::MASK).map(|(lo, hi)| (lo.first_mut(), hi.first())),
                _ => self.slots.split_at_mut_checked(at).map(|(lo, hi)| (hi.first_mut(), lo.last())),
            };
            if let Some((Some(to), Some(from))) = pair {
                *to = *from;
            }
            at = before;
        }
        self.place(at, key)
    }

    /// Takes ring place `at` (free) for a frame of priority `key`.
    #[inline(always)]
    fn place(&mut self, at: usize, key: u32) -> Option<&mut CanFrame> {
        // `len` < N: [`TxQueue::reserve`] checked it.
        #[allow(clippy::arithmetic_side_effects)]
        {
            self.len += 1;
        }
        *self.keys.get_mut(at)? = key;
        self.slots.get_mut(at)
    }

    /// The frame that goes next, without removing it.
    pub fn peek(&self) -> Option<&CanFrame> {
        if self.len == 0 {
            return None;
        }
        self.slots.get(self.head & Self::MASK)
    }

    /// Removes the frame that goes next.
    // In line: its one caller, `Node::transmit`, has checked that the queue is not empty.
    #[inline(always)]
    pub fn pop(&mut self) -> Option<CanFrame> {
        if self.len == 0 {
            return None;
        }
        let frame = self.slots.get(self.head & Self::MASK).copied();
        self.head = self.head.wrapping_add(1) & Self::MASK;
        // `len` != 0: checked above.
        #[allow(clippy::arithmetic_side_effects)]
        {
            self.len -= 1;
        }
        frame
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
    // `len` ≤ N: `insert` refuses a frame once N are queued.
    #[allow(clippy::arithmetic_side_effects)]
    pub fn free(&self) -> usize {
        N - self.len
    }

    /// Frames refused because the queue was full.
    pub fn overflows(&self) -> u32 {
        self.overflows
    }

    /// Drops every queued frame (the node goes silent, e.g. for an LSS bit-rate switch).
    pub fn clear(&mut self) {
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
        // Frames leave from the head while others of one identifier wait behind.
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

    #[test]
    fn a_frame_written_into_its_slot_takes_its_place_among_the_others() {
        let mut q = TxQueue::<4>::new();
        // Into the empty queue as into any other: refused, not counted.
        assert!(!q.push_data(0x800, &[0; 8], 1), "not an 11-bit identifier");
        assert!(!q.push_data(0x181, &[0; 8], 9), "more than 8 bytes");
        assert_eq!((q.len(), q.overflows()), (0, 0));
        assert!(q.push(f(0x281, 2)));
        assert_eq!(q.pop(), Some(f(0x281, 2)));
        assert!(q.push(f(0x581, 9)));
        // Bytes past the length are the caller's (zeros from a TPDO's build).
        assert!(q.push_data(0x181, &[1, 2, 3, 0, 0, 0, 0, 0], 3));
        assert!(q.push(f(0x181, 4)));
        assert!(!q.push_data(0x800, &[0; 8], 1), "not an 11-bit identifier");
        assert!(!q.push_data(0x181, &[0; 8], 9), "more than 8 bytes");
        assert_eq!(q.overflows(), 0);
        assert!(q.push_data(0x701, &[0; 8], 0));
        assert!(!q.push_data(0x080, &[0; 8], 1), "full");
        assert_eq!(q.overflows(), 1);
        let order: Vec<CanFrame> = core::iter::from_fn(|| q.pop()).collect();
        let built = CanFrame::standard(0x181, &[1, 2, 3]).unwrap();
        assert_eq!(order, [built, f(0x181, 4), f(0x581, 9), CanFrame::standard(0x701, &[]).unwrap()]);
    }

    #[test]
    fn matches_a_model_of_priority_then_queueing_order() {
        // The model: (priority, sequence) with sequence numbers counting up
        // for push and down for push_front, the lowest pair leaves first.
        let mut q = TxQueue::<8>::new();
        let mut model: Vec<(u32, i64, CanFrame)> = Vec::new();
        let (mut up, mut down) = (0i64, 0i64);
        let mut seed = 0x1234_5678u32;
        for step in 0..5000u32 {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            let id = [0x181, 0x281, 0x581, 0x581, 0x701, 0x080][(seed % 6) as usize];
            let frame = f(id, step as u8);
            match (seed >> 8) % 4 {
                0 => {
                    up += 1;
                    let ok = q.push(frame);
                    assert_eq!(ok, model.len() < 8);
                    if ok {
                        model.push((frame.priority(), up, frame));
                    }
                }
                1 => {
                    // The same frame, written into its slot.
                    up += 1;
                    let ok = q.push_data(id, &[step as u8, 0, 0, 0, 0, 0, 0, 0], 1);
                    assert_eq!(ok, model.len() < 8);
                    if ok {
                        model.push((frame.priority(), up, frame));
                    }
                }
                2 => {
                    down -= 1;
                    let ok = q.push_front(frame);
                    assert_eq!(ok, model.len() < 8);
                    if ok {
                        model.push((frame.priority(), down, frame));
                    }
                }
                _ => {
                    let best = model.iter().enumerate().min_by_key(|(_, (p, s, _))| (*p, *s)).map(|(i, _)| i);
                    let want = best.map(|i| model.remove(i).2);
                    assert_eq!(q.peek().copied(), want);
                    assert_eq!(q.pop(), want);
                }
            }
            assert_eq!((q.len(), q.free()), (model.len(), 8 - model.len()));
        }
    }
}
