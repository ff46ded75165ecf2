//! bxCAN mailbox words (RM0008 §24.9.3): a frame as the four registers of a
//! transmit mailbox (TIxR, TDTxR, TDLxR, TDHxR) and back from those of a
//! receive FIFO (RIxR, RDTxR, RDLxR, RDHxR), and the transmit rule the
//! board runs the controller with.
//!
//! The board writes and reads the mailboxes itself instead of through
//! `bxcan`'s `transmit`/`receive`:
//! - **Transmit**: the controller runs in TX FIFO mode (MCR.TXFP = 1), so
//!   the three mailboxes leave in the order they were filled. The node's
//!   queue already hands out frames in priority order, so a burst (the
//!   TPDOs after a SYNC, a block upload) fills every free mailbox at once
//!   and leaves back to back, and frames with one identifier never change
//!   order. bxcan 0.8's `transmit` sends one frame per TX-empty interrupt
//!   in a burst: it refuses a frame that is not of higher priority than
//!   every pending one.
//! - **Receive**: a DLC above 8 (legal on classic CAN, meaning 8 bytes)
//!   carries 8 bytes; bxcan keeps the raw DLC in its frame, and reading that
//!   frame's data then panics.

use canopen_core::frame::CanFrame;
use embedded_can::{ExtendedId, Frame, Id, StandardId};

/// TIxR/RIxR: identifier extension (29-bit identifier).
const IDE: u32 = 1 << 2;
/// TIxR/RIxR: remote transmission request.
const RTR: u32 = 1 << 1;
/// TIxR: transmit mailbox request.
pub const TXRQ: u32 = 1;

/// The four words of a transmit mailbox for `frame`, TIxR without TXRQ
/// (set it last, once the other three are written).
pub fn transmit_words(frame: &CanFrame) -> [u32; 4] {
    let id = if frame.is_extended_id() { (frame.raw_id() << 3) | IDE } else { frame.raw_id() << 21 };
    let rtr = if frame.is_remote_frame() { RTR } else { 0 };
    let mut data = [0u8; 8];
    for (d, s) in data.iter_mut().zip(frame.data()) {
        *d = *s;
    }
    let [a, b, c, d, e, f, g, h] = data;
    [id | rtr, frame.dlc() as u32, u32::from_le_bytes([a, b, c, d]), u32::from_le_bytes([e, f, g, h])]
}

/// The frame in a receive FIFO's output mailbox (RIxR, RDTxR, RDLxR,
/// RDHxR). A DLC above 8 means 8 bytes (ISO 11898-1). `None` never happens
/// (every identifier the registers hold is valid); the caller counts it as
/// a lost frame.
pub fn received(rir: u32, rdtr: u32, rdlr: u32, rdhr: u32) -> Option<CanFrame> {
    let id: Id = if rir & IDE != 0 { ExtendedId::new(rir >> 3)?.into() } else { StandardId::new((rir >> 21) as u16)?.into() };
    let dlc = ((rdtr & 0xF) as usize).min(8);
    if rir & RTR != 0 {
        return CanFrame::new_remote(id, dlc);
    }
    let [a, b, c, d] = rdlr.to_le_bytes();
    let [e, f, g, h] = rdhr.to_le_bytes();
    let bytes = [a, b, c, d, e, f, g, h];
    CanFrame::new(id, bytes.get(..dlc)?)
}

/// The transmit mailboxes, as [`fill`] uses them.
pub trait Mailboxes {
    /// An empty mailbox (TSR.TMEx; TSR.CODE names one), if any.
    fn empty(&self) -> Option<usize>;
    /// Writes `words` ([`transmit_words`]) into mailbox `i` and requests
    /// its transmission (TXRQ last).
    fn request(&mut self, i: usize, words: [u32; 4]);
}

/// Fills every empty mailbox with the next frames of `next` (the node's
/// queue, which takes a frame out only when a mailbox is free for it);
/// returns how many frames it handed over. In TX FIFO mode they leave in
/// this order.
pub fn fill(mailboxes: &mut impl Mailboxes, mut next: impl FnMut() -> Option<CanFrame>) -> usize {
    let mut sent = 0;
    while let Some(i) = mailboxes.empty() {
        let Some(frame) = next() else { break };
        mailboxes.request(i, transmit_words(&frame));
        sent += 1;
    }
    sent
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    fn std(id: u16, data: &[u8]) -> CanFrame {
        CanFrame::standard(id, data).unwrap()
    }

    #[test]
    fn words_round_trip_through_a_fifo() {
        let ext = CanFrame::extended(0x1234_5678, &[1, 2, 3]).unwrap();
        for f in [std(0x181, &[1, 2, 3, 4, 5, 6, 7, 8]), std(0x7FF, &[]), CanFrame::remote(0x701, 1).unwrap(), ext] {
            let [tir, tdtr, tdlr, tdhr] = transmit_words(&f);
            assert_eq!(tir & TXRQ, 0);
            assert_eq!(received(tir, tdtr, tdlr, tdhr), Some(f));
        }
        // RM0008 layout: STID in bits 31:21, RTR bit 1, DLC in TDTR bits 3:0, byte 0 in TDLR bits 7:0.
        assert_eq!(transmit_words(&std(0x181, &[0xAA, 0xBB, 0, 0, 0, 0, 0, 0x77])), [0x181 << 21, 8, 0xBBAA, 0x7700_0000]);
        assert_eq!(transmit_words(&CanFrame::remote(0x701, 1).unwrap())[0], (0x701 << 21) | RTR);
    }

    #[test]
    fn a_dlc_above_8_carries_8_bytes() {
        let f = received(0x181 << 21, 0xF, 0x0403_0201, 0x0807_0605).unwrap();
        assert_eq!(embedded_can::Frame::data(&f), &[1, 2, 3, 4, 5, 6, 7, 8]);
        assert_eq!(embedded_can::Frame::dlc(&f), 8);
    }

    /// The bxCAN transmit rules (RM0008 §24.7.1): three mailboxes; with
    /// TXFP = 1 the pending mailbox requested first leaves first, with
    /// TXFP = 0 the one with the highest priority identifier (lowest id,
    /// then lowest mailbox number).
    struct Model {
        fifo: bool,
        boxes: [Option<(u64, [u32; 4])>; 3],
        order: u64,
        requests: usize,
    }

    impl Model {
        fn new(fifo: bool) -> Model {
            Model { fifo, boxes: [None; 3], order: 0, requests: 0 }
        }

        /// The bus takes the next frame.
        fn transmit(&mut self) -> Option<CanFrame> {
            let fifo = self.fifo;
            let key = |(i, b): (usize, &Option<(u64, [u32; 4])>)| b.map(|(o, w)| (if fifo { o } else { u64::from(w[0] >> 21) }, i));
            let (_, i) = self.boxes.iter().enumerate().filter_map(key).min()?;
            let (_, [tir, tdtr, tdlr, tdhr]) = self.boxes[i].take()?;
            received(tir, tdtr, tdlr, tdhr)
        }
    }

    impl Mailboxes for Model {
        fn empty(&self) -> Option<usize> {
            self.boxes.iter().position(Option::is_none)
        }

        fn request(&mut self, i: usize, words: [u32; 4]) {
            assert!(self.boxes[i].is_none(), "mailbox {i} is not empty");
            self.order += 1;
            self.requests += 1;
            self.boxes[i] = Some((self.order, words));
        }
    }

    /// Runs `queue` (in the node's pop order) through the mailboxes: one
    /// `fill` per TX-empty interrupt, the bus taking one frame in between.
    /// Returns the bus order and the number of `fill` calls that handed over frames.
    fn run(model: &mut Model, queue: &[CanFrame]) -> (Vec<CanFrame>, usize) {
        let mut pending = queue.iter().copied();
        let mut bus = Vec::new();
        let mut rounds = 0;
        loop {
            if fill(model, || pending.next()) > 0 {
                rounds += 1;
            }
            match model.transmit() {
                Some(f) => bus.push(f),
                None => break,
            }
        }
        (bus, rounds)
    }

    #[test]
    fn a_burst_fills_every_mailbox_and_leaves_in_queue_order() {
        // The node's queue after a SYNC: four TPDOs, then two SDO segments on one identifier.
        let queue = [std(0x181, &[1]), std(0x281, &[2]), std(0x381, &[3]), std(0x481, &[4]), std(0x581, &[5]), std(0x581, &[6])];
        let mut model = Model::new(true);
        let (bus, rounds) = run(&mut model, &queue);
        assert_eq!(bus, queue);
        // Three frames at once, then one per TX-empty: 4 fills instead of 6.
        assert_eq!(rounds, 4);
        assert_eq!(model.requests, 6);
    }

    #[test]
    fn frames_with_one_identifier_never_change_order() {
        // A higher-priority frame popped later waits behind two equal-id frames already in mailboxes.
        let queue = [std(0x581, &[1]), std(0x581, &[2]), std(0x581, &[3]), std(0x181, &[9])];
        let (bus, _) = run(&mut Model::new(true), &queue);
        let sdo: Vec<_> = bus.iter().filter(|f| f.cob_id() == Some(0x581)).map(|f| embedded_can::Frame::data(f)[0]).collect();
        assert_eq!(sdo, [1, 2, 3]);
        // Without FIFO mode the controller picks by identifier, and for equal
        // identifiers by mailbox number, which is not the request order once
        // a lower mailbox frees up first.
        let mut model = Model::new(false);
        fill(&mut model, || None);
        model.boxes[1] = Some((1, transmit_words(&std(0x581, &[1]))));
        model.boxes[0] = Some((2, transmit_words(&std(0x581, &[2]))));
        assert_eq!(model.transmit().map(|f| embedded_can::Frame::data(&f)[0]), Some(2));
    }
}
