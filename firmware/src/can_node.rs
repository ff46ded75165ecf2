//! A [`Node`] of any dictionary behind one trait object, [`CanNode`], so the
//! CANopen task is not generic (embassy tasks cannot be); code that knows
//! the device gets its own dictionary type back through [`od_mut`]. Plain
//! Rust, so host tests drive the same code the images run.

use core::any::Any;

use canopen_core::abort::AbortCode;
use canopen_core::frame::CanFrame;
use canopen_core::node::{AcceptanceList, Application, ControllerEvent, Node};
use canopen_core::od::ObjectDictionary;
use canopen_core::services::nmt::NmtState;
use canopen_core::storage::Storage;
use canopen_core::time::Instant;
use canopen_core::wire::emcy::EmcyCode;

/// What the CANopen task needs from a node, whatever its dictionary.
pub trait CanNode: Send {
    /// [`Node::on_frame`].
    fn on_frame(&mut self, now: Instant, frame: &CanFrame);
    /// [`Node::process`].
    fn process(&mut self, now: Instant) -> Option<Instant>;
    /// [`Node::resetting`].
    fn resetting(&self) -> bool;
    /// [`Node::transmit`].
    fn transmit(&mut self) -> Option<CanFrame>;
    /// [`Node::requeue`].
    fn requeue(&mut self, frame: CanFrame);
    /// [`Node::raise_error`].
    fn raise_error(&mut self, code: EmcyCode, info: [u8; 5]);
    /// [`Node::clear_error`].
    fn clear_error(&mut self, code: EmcyCode);
    /// [`Node::state`].
    fn state(&self) -> NmtState;
    /// [`Node::node_id`].
    fn node_id(&self) -> u8;
    /// [`Node::acceptance`]: what the board's acceptance filter passes.
    fn acceptance(&self) -> &AcceptanceList;
    /// [`Node::bit_rate`].
    fn bit_rate(&self) -> Option<u8>;
    /// [`Node::take_bit_rate_change`].
    fn take_bit_rate_change(&mut self) -> Option<u8>;
    /// [`Node::od_mut`] as [`Any`], for [`od_mut`].
    fn od_any_mut(&mut self) -> &mut dyn Any;
    /// [`Node::trigger_tpdo`].
    fn trigger_tpdo(&mut self, n: usize) -> bool;
    /// [`Node::controller_event`].
    fn controller_event(&mut self, event: ControllerEvent, now: Instant);
    /// Copies the value of (index, sub) into `buf`; its length, or why not
    /// (`buf` too short: [`AbortCode::LengthTooHigh`]).
    fn read(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, AbortCode>;
    /// Writes (index, sub) as the device does (`Dictionary::write_unchecked`:
    /// no access check, a shorter value zero-filled); change-of-state TPDOs
    /// compare at the next [`Node::process`].
    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode>;
}

impl<O, A, S, const R: usize, const T: usize, const HB: usize, const SDO: usize> CanNode for Node<O, A, S, R, T, HB, SDO>
where
    O: ObjectDictionary + Send + 'static,
    A: Application + Send,
    S: Storage + Send,
{
    fn on_frame(&mut self, now: Instant, frame: &CanFrame) {
        Node::on_frame(self, now, frame);
    }

    fn process(&mut self, now: Instant) -> Option<Instant> {
        Node::process(self, now)
    }

    fn resetting(&self) -> bool {
        Node::resetting(self)
    }

    fn transmit(&mut self) -> Option<CanFrame> {
        Node::transmit(self)
    }

    fn requeue(&mut self, frame: CanFrame) {
        Node::requeue(self, frame);
    }

    fn raise_error(&mut self, code: EmcyCode, info: [u8; 5]) {
        Node::raise_error(self, code, info);
    }

    fn clear_error(&mut self, code: EmcyCode) {
        Node::clear_error(self, code);
    }

    fn state(&self) -> NmtState {
        Node::state(self)
    }

    fn node_id(&self) -> u8 {
        Node::node_id(self)
    }

    fn acceptance(&self) -> &AcceptanceList {
        Node::acceptance(self)
    }

    fn bit_rate(&self) -> Option<u8> {
        Node::bit_rate(self)
    }

    fn take_bit_rate_change(&mut self) -> Option<u8> {
        Node::take_bit_rate_change(self)
    }

    fn od_any_mut(&mut self) -> &mut dyn Any {
        self.od_mut()
    }

    fn trigger_tpdo(&mut self, n: usize) -> bool {
        Node::trigger_tpdo(self, n)
    }

    fn controller_event(&mut self, event: ControllerEvent, now: Instant) {
        Node::controller_event(self, event, now);
    }

    fn read(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let od = self.od();
        let value = od.dictionary().read(od.image(), index, sub)?;
        if value.len() > buf.len() {
            return Err(AbortCode::LengthTooHigh);
        }
        // Not `copy_from_slice`: its length check pulls `core::fmt` into the images.
        for (to, from) in buf.iter_mut().zip(value) {
            *to = *from;
        }
        Ok(value.len())
    }

    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        let od = self.od_mut();
        od.dictionary().write_unchecked(od.image_mut(), index, sub, data)
    }
}

/// The node's dictionary as the device's generated type `O` (its `Ram`,
/// with the typed accessors), or `None` if the node runs another one.
/// Writes through it count as application changes: change-of-state TPDOs
/// compare their data at the next [`Node::process`].
pub fn od_mut<O: Any>(node: &mut dyn CanNode) -> Option<&mut O> {
    node.od_any_mut().downcast_mut()
}
