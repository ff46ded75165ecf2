//! The CiA 402 row: an RPDO carrying controlword + target velocity
//! (EC5000 RPDO3: 0x6040, 0x60FF) through the state machine to the TPDO
//! with statusword + actual velocity (TPDO3: 0x6041, 0x606C), on the
//! EC5000's dictionary with its own application (the profile and the axis
//! model, as its images run them).
//!
//! The controlword alternates between 0x0006 and 0x0007 (transitions 3 and
//! 6, Ready to switch on ↔ Switched on), so every frame changes the state
//! and the statusword TPDO leaves in the same `process`. TPDO3 is made
//! event-driven without inhibit time (it is synchronous on the EC5000) and
//! TPDO1/TPDO2, which also map 0x6041, are switched off, so each RPDO gets
//! exactly one answer.
//!
//! [`Echo`] runs the same frames with an application that only copies the
//! controlword into the statusword: the difference between the two is the
//! profile's own part.

use canopen_core::frame::CanFrame;
use canopen_core::node::{Application, Ctx, Source};
use canopen_core::time::Instant;
use firmware::boards::qemu::ram_storage::RamStorage;
use firmware::boards::region_size;
use firmware::devices::ec5000;

use crate::{Answer, Mismatch, frame};

/// The EC5000 node-id in the bench.
pub const NODE_ID: u8 = 5;
const SDO_RX: u16 = 0x600 + NODE_ID as u16;
const SDO_TX: u16 = 0x580 + NODE_ID as u16;
/// RPDO3 (0x6040, 0x60FF).
pub const RPDO3: u16 = 0x400 + NODE_ID as u16;
/// TPDO3 (0x6041, 0x606C).
pub const TPDO3: u16 = 0x380 + NODE_ID as u16;

/// The QEMU board's RAM storage, sized for the EC5000's dictionary.
pub type Storage = RamStorage<{ region_size(ec5000::od::RAM_SIZE) }>;
/// The EC5000 node with `A`.
pub type Node<A> = ec5000::od::Node<A, Storage>;

/// The baseline application: 0x6040 copied into 0x6041, nothing else.
#[derive(Debug, Default)]
pub struct Echo;

impl Application for Echo {
    fn written(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, _by: Source) {
        if (index, sub) == (0x6040, 0)
            && let Ok(&[a, b]) = ctx.read(0x6040, 0)
        {
            let _ = ctx.set_value(0x6041, 0, &[a, b]);
        }
    }
}

fn sdo_write(node: &mut Node<impl Application>, now: Instant, index: u16, sub: u8, value: u32, len: u8) -> Result<(), Mismatch> {
    let [lo, hi] = index.to_le_bytes();
    let [a, b, c, d] = value.to_le_bytes();
    let cmd = 0x23 | (4u8.saturating_sub(len) << 2);
    let answer = exchange_any(node, now, &frame(SDO_RX, &[cmd, lo, hi, sub, a, b, c, d]));
    answer.expect("SDO download", 1, Some((SDO_TX, &[0x60, lo, hi, sub, 0, 0, 0, 0])))
}

/// [`crate::exchange`] for an EC5000 node.
pub fn exchange_any<A: Application>(node: &mut Node<A>, now: Instant, f: &CanFrame) -> Answer {
    node.on_frame(now, f);
    node.process(now);
    let mut answer = Answer::default();
    while let Some(out) = node.transmit() {
        answer.count += 1;
        answer.first = answer.first.or(Some(out));
        answer.last = Some(out);
    }
    answer
}

/// The EC5000 with `app` in Operational, TPDO3 event-driven, TPDO1/2 off,
/// Switched on (the state after frame 1 of [`frame_of`]).
pub fn setup<A: Application + 'static>(app: A, now: Instant) -> Result<Node<A>, Mismatch> {
    let echo = core::any::TypeId::of::<A>() == core::any::TypeId::of::<Echo>();
    let mut node = Node::new(ec5000::od::Ram::new(NODE_ID), app, Storage::default(), NODE_ID, now);
    node.process(now);
    while node.transmit().is_some() {}
    let id = u32::from(NODE_ID);
    for (n, cob) in [(0u16, 0x180), (1, 0x280)] {
        sdo_write(&mut node, now, 0x1800 + n, 1, 0x8000_0000 | (cob + id), 4)?;
    }
    sdo_write(&mut node, now, 0x1802, 1, 0x8000_0000 | (0x380 + id), 4)?;
    sdo_write(&mut node, now, 0x1802, 2, 255, 1)?;
    sdo_write(&mut node, now, 0x1802, 3, 0, 2)?;
    sdo_write(&mut node, now, 0x1802, 1, 0x380 + id, 4)?;
    exchange_any(&mut node, now, &frame(0x000, &[0x01, NODE_ID]));
    // Shutdown, then switch on: Switched on.
    for i in 0..2 {
        exchange_any(&mut node, now, &frame_of(i)).expect("enable", 1, Some((TPDO3, &expected(echo, i))))?;
    }
    Ok(node)
}

/// RPDO3 of iteration `i`: controlword 0x0006 (even) or 0x0007 (odd), target velocity `i`.
pub fn frame_of(i: u64) -> CanFrame {
    let [a, b, c, d] = (i as u32).to_le_bytes();
    frame(RPDO3, &[if i.is_multiple_of(2) { 0x06 } else { 0x07 }, 0x00, a, b, c, d])
}

/// The TPDO3 data after frame `i`: Ready to switch on (0x0231) or Switched
/// on (0x0233) with the profile; the controlword itself with [`Echo`];
/// actual velocity 0 (the drive function is off).
pub fn expected(echo: bool, i: u64) -> [u8; 6] {
    let word: u16 = match (echo, i % 2) {
        (true, 0) => 0x0006,
        (true, _) => 0x0007,
        (false, 0) => 0x0231,
        (false, _) => 0x0233,
    };
    let [lo, hi] = word.to_le_bytes();
    [lo, hi, 0, 0, 0, 0]
}

/// One answer per frame of `0..n`, the last one the statusword of frame `n − 1`.
pub fn check(echo: bool, n: u64, sent: u64, last: Option<CanFrame>) -> Result<(), Mismatch> {
    let want = CanFrame::standard(TPDO3, &expected(echo, n.wrapping_sub(1)));
    if sent == n && (n == 0 || last == want) {
        Ok(())
    } else {
        Err(Mismatch { step: "cia402", answer: Answer { count: usize::try_from(sent).unwrap_or(usize::MAX), first: None, last } })
    }
}
