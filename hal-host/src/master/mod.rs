//! A small CANopen master for tests: NMT commands, an SDO client, a PDO
//! codec and a heartbeat monitor. CiA 301 v4.2 §7.2.8.3.1 (NMT module
//! control), §7.2.4 (SDO), §7.2.2 (PDO), §7.2.8.3.2 (heartbeat).
//!
//! Like the node, every part is sans-IO: a state machine fed with received
//! frames and the time, handing out the frames it wants sent, built on the
//! core's [`canopen_core::wire`] formats (the style guide's rule: the master
//! reuses `wire`; python-canopen is the independent check).
//!
//! - [`nmt`]: NMT command frames, addressed or broadcast.
//! - [`sdo_client`]: [`SdoClient`] and its [`SdoTransfer`]s: expedited,
//!   segmented and block upload and download, timeouts, aborts.
//! - [`pdo`]: packing and unpacking PDO payloads along a mapping.
//! - [`heartbeat`]: [`HeartbeatMonitor`], the last state and time of each node.
//!
//! The bus driver in this file ([`run_transfer`], [`sdo_upload`],
//! [`sdo_download`]) runs an SDO transfer on a port of a virtual [`Bus`].
//! The node under test is not on the bus by itself: a test harness moves
//! frames between the bus and the node. The harness implements [`Network`],
//! and the driver calls it whenever virtual time moves, so the node answers
//! at the exact instants a real one would.
#![deny(clippy::indexing_slicing, clippy::unwrap_used, clippy::expect_used, clippy::panic)]

pub mod heartbeat;
pub mod nmt;
pub mod pdo;
pub mod sdo_client;

#[cfg(test)]
mod tests;

pub use heartbeat::{HeartbeatEvent, HeartbeatMonitor};
pub use sdo_client::{DownloadMode, ProtocolError, RequestError, SdoClient, SdoClientError, SdoTransfer, UploadMode};

use crate::bus::{Bus, BusError, PortId};
use canopen_core::frame::CanFrame;
use canopen_core::time::{Duration, Instant};
use embedded_can::Frame;

/// Everything on the bus besides the master: the bus itself and the nodes
/// a test harness moves frames for.
pub trait Network {
    /// The bus the master's port is attached to.
    fn bus(&mut self) -> &mut Bus;

    /// Runs the nodes at `now` (the bus's time): hands them every frame the
    /// bus delivered to their ports, runs their timers, and queues what they
    /// send with [`Bus::send`]. Returns their earliest deadline; calling
    /// early must be harmless, as for `Node::process`.
    fn poll(&mut self, now: Instant) -> Option<Instant>;

    /// A frame the master's port received that the running transfer did not
    /// claim (heartbeats, EMCY, PDOs, stray SDO frames). Dropped by default.
    fn unclaimed(&mut self, at: Instant, frame: &CanFrame) {
        let _ = (at, frame);
    }
}

/// A bare bus is a network without nodes to drive (the master alone, or
/// with ports that only listen).
impl Network for Bus {
    fn bus(&mut self) -> &mut Bus {
        self
    }

    fn poll(&mut self, _now: Instant) -> Option<Instant> {
        None
    }
}

/// Why the master could not queue a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SendError {
    /// The bus refused it (the port is not on this bus).
    Bus(BusError),
    /// No CAN frame has this COB-ID (above 0x7FF) or this many data bytes (above 8).
    InvalidFrame {
        /// The COB-ID asked for.
        cob_id: u16,
        /// The number of data bytes asked for.
        len: usize,
    },
}

impl core::fmt::Display for SendError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SendError::Bus(e) => write!(f, "bus refused the frame: {e}"),
            SendError::InvalidFrame { cob_id, len } => write!(f, "no CAN frame with COB-ID {cob_id:#x} and {len} data bytes"),
        }
    }
}

impl std::error::Error for SendError {}

/// Queues a data frame on `port` at the bus's current time.
pub fn send(bus: &mut Bus, port: PortId, cob_id: u16, data: &[u8]) -> Result<(), SendError> {
    let frame = CanFrame::standard(cob_id, data).ok_or(SendError::InvalidFrame { cob_id, len: data.len() })?;
    bus.send(port, frame).map_err(SendError::Bus)
}

/// One microsecond: the least the driver moves time by, so that it always
/// makes progress even if a node keeps asking to be polled "now".
const TICK: Duration = Duration::from_micros(1);

/// Runs `transfer` on `port` until it ends, and returns its result (the
/// uploaded value; empty for a download).
///
/// Frames on the transfer's response COB-ID go to the transfer, every other
/// frame `port` receives to [`Network::unclaimed`]. Tx-complete notes of the
/// transfer's frames restart its timeout, so that a long sub-block at a low
/// bit rate does not eat into it. The driver returns once the transfer has
/// ended and its last frame (end response, abort) has reached the nodes and
/// they have been polled with it; the transfer's own timeout bounds the run,
/// so it cannot hang on a silent node.
pub fn run_transfer<N: Network + ?Sized>(net: &mut N, port: PortId, mut transfer: SdoTransfer) -> Result<Vec<u8>, SdoClientError> {
    let (request, response) = (transfer.request_cob_id(), transfer.response_cob_id());
    let mut ended_at = None;
    loop {
        let now = net.bus().now();
        while let Some((at, frame)) = net.bus().recv(port) {
            if frame.cob_id() == Some(response) && !frame.is_remote_frame() {
                transfer.on_frame(at, frame.data());
            } else {
                net.unclaimed(at, &frame);
            }
        }
        while let Some((at, frame)) = net.bus().tx_complete(port) {
            if frame.cob_id() == Some(request) {
                transfer.on_sent(at);
            }
        }
        let deadline = transfer.process(now);
        while let Some(data) = transfer.pop_tx() {
            send(net.bus(), port, request, &data).map_err(SdoClientError::Send)?;
        }
        let nodes = net.poll(now);
        if transfer.is_done() {
            // A port that cannot get its last frame out (bus-off) gets one
            // more timeout's worth of trying.
            let since = *ended_at.get_or_insert(now);
            if net.bus().tx_pending(port) == 0 || now >= since + transfer.client().timeout {
                return transfer.into_result().unwrap_or_else(|| Ok(Vec::new()));
            }
        }
        let next = [net.bus().next_event(), deadline, nodes].into_iter().flatten().min();
        let Some(next) = next else {
            // Only a finished transfer has no deadline, and nothing is left to send.
            return transfer.into_result().unwrap_or_else(|| Ok(Vec::new()));
        };
        net.bus().run_until(next.max(now + TICK));
    }
}

/// Reads (index, sub) from node `node_id`'s default SDO server (COB-IDs
/// 0x600/0x580 + node-ID) with the default [`SdoClient`] settings.
pub fn sdo_upload<N: Network + ?Sized>(
    net: &mut N,
    port: PortId,
    node_id: u8,
    index: u16,
    sub: u8,
    mode: UploadMode,
) -> Result<Vec<u8>, SdoClientError> {
    let transfer = SdoClient::new(node_id).upload(net.bus().now(), index, sub, mode);
    run_transfer(net, port, transfer)
}

/// Writes `data` to (index, sub) on node `node_id`'s default SDO server
/// with the default [`SdoClient`] settings.
pub fn sdo_download<N: Network + ?Sized>(
    net: &mut N,
    port: PortId,
    node_id: u8,
    index: u16,
    sub: u8,
    data: &[u8],
    mode: DownloadMode,
) -> Result<(), SdoClientError> {
    let transfer = SdoClient::new(node_id).download(net.bus().now(), index, sub, data, mode);
    run_transfer(net, port, transfer).map(|_| ())
}
