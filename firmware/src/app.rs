//! Glue between a board and the core on the MCU, the same on every board:
//! the image's [`SHARED`], embassy-time for the CANopen task ([`serve`],
//! `crate::shared`) and the application slot.
//!
//! The CANopen task is embassy-net's runner in miniature (style guide
//! §2.4): it owns the node, and waits on `select(received frame, wake-up,
//! Timer::at(deadline))`, where a wake-up is an application request, a
//! controller event or room to send; whatever woke it, it hands the node
//! the frames or the request, then runs a `Runner::step`.

use canopen_core::time::Instant;
use embassy_time::Timer;

pub use crate::can_node::CanNode;
pub use crate::runner::Controller;
pub use crate::shared::{RX_QUEUE, Shared, serve};

defmt::timestamp!("{=u64:us}", embassy_time::Instant::now().as_ticks());

/// The one [`Shared`] of an image.
pub static SHARED: Shared = Shared::new();

// embassy-time counts microseconds (its default tick rate), as the core
// does, so instants convert without arithmetic.
const _: () = assert!(embassy_time::TICK_HZ == 1_000_000, "embassy-time ticks must be microseconds");

/// The time as the core sees it.
pub fn now() -> Instant {
    Instant::from_micros(embassy_time::Instant::now().as_ticks())
}

fn to_embassy(t: Instant) -> embassy_time::Instant {
    embassy_time::Instant::from_ticks(t.as_micros())
}

/// Converts between the frame types of the core and of a driver (both
/// `embedded_can::Frame`); `None` only if `G` cannot carry the frame.
pub fn convert_frame<F: embedded_can::Frame, G: embedded_can::Frame>(frame: &F) -> Option<G> {
    if frame.is_remote_frame() { G::new_remote(frame.id(), frame.dlc()) } else { G::new(frame.id(), frame.data()) }
}

/// What an image's start-up hands its board.
pub struct Started {
    /// The node, for the CANopen task ([`run_canopen`]).
    pub node: &'static mut dyn CanNode,
    /// The bit rate (CiA 305 table index) the device's own stored
    /// parameters give, if it has such (a bit rate LSS stored comes first:
    /// [`CanNode::bit_rate`]).
    pub bit_rate: Option<u8>,
}

impl Started {
    /// Runs an image's `make_node` (which powers on the node built in its
    /// `static`) with the storage handle `handle` makes, in a stack frame of
    /// its own. What the power-on takes from the stack is free again once
    /// this returns, before the board starts its executors, whose frames
    /// then sit on top of the board's `run` for good.
    #[inline(never)]
    pub fn build<H>(make_node: impl FnOnce(H, Instant) -> Started, handle: impl FnOnce() -> H, now: Instant) -> Started {
        make_node(handle(), now)
    }
}

/// The CANopen task on embassy-time: [`serve`] with the board's clock
/// and a timer at the node's deadline.
pub async fn run_canopen(shared: &'static Shared, node: &'static mut dyn CanNode, controller: &mut impl Controller) -> ! {
    serve(shared, node, controller, now, |deadline| Timer::at(deadline.map_or(embassy_time::Instant::MAX, to_embassy))).await
}

/// The application slot, one task per image ([`crate::image!`] spawns it):
/// where a device profile runs beside the CANopen task, reading and
/// writing objects and triggering TPDOs through `shared::Requests` and following
/// the NMT state through [`Shared::next_state`]. Today it reports the
/// device type (0x1000) and each NMT state the node enters.
pub async fn run_application(shared: &'static Shared) -> ! {
    if let Some(mut node) = shared.requests()
        && let Ok(value) = node.read(0x1000, 0).await
    {
        defmt::info!("device type {=[u8]:02x}", value.as_bytes());
    }
    loop {
        let state = shared.next_state().await;
        defmt::info!("NMT state {=u8:#04x}", state.reported().code());
    }
}
