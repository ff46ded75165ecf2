//! Host support for running canopen-core nodes on a PC.
//!
//! - [`clock`]: the virtual clock tests advance; a node never sees wall time.
//! - [`bus`]: a virtual CAN bus on virtual time: arbitration, exact frame
//!   lengths (stuff bits included) at each port's bit rate, per-port FIFOs.
//! - [`fault`]: fault injection on that bus: dropped and corrupted frames,
//!   delays, error frames, bus-off.
//! - [`trace`]: every frame on the bus as a `candump -L` log, written in
//!   place or by a thread that never holds up the caller.
//! - [`storage`]: flash-like [`canopen_core::storage::Storage`] in memory or
//!   in a file, with power cuts at any erase/write step.
//! - [`slcan`]: the Lawicel SLCAN adapter (on the firmware's no_std codec,
//!   `firmware::slcan`) and a TCP server speaking it, so python-can's
//!   `slcan` interface can drive a node running in real time; every client
//!   is an adapter on one paced bus (the `vnode` binary).
//! - [`master`]: a small CANopen master for tests (NMT, SDO client with
//!   block transfers, PDO codec, heartbeat monitor), sans-IO like the node,
//!   with a driver that runs SDO transfers on the virtual bus.
//! - [`slcan_client`]: the host side of SLCAN over TCP (the QEMU board's
//!   UART, or [`slcan::SlcanServer`]).
//! - [`live`]: the test master in real time over an [`slcan_client`]
//!   connection, with a log of every frame.
//! - [`decode`]: what a frame means, as a line of text for a live trace.
#![forbid(unsafe_code)]

pub mod bus;
pub mod clock;
pub mod decode;
pub mod fault;
pub mod fixtures;
pub mod live;
pub mod master;
pub mod slcan;
pub mod slcan_client;
pub mod storage;
pub mod trace;
