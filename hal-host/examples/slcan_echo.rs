//! An SLCAN adapter on TCP that answers every frame a client sends: a
//! standard frame with id ≥ 0x80 comes back with id − 0x80 (0x601 → 0x581,
//! as an SDO server would answer), anything else comes back unchanged.
//!
//! `cargo run -p hal-host --example slcan_echo -- 127.0.0.1:4557`, then e.g.
//! `can.Bus(interface="slcan", channel="socket://127.0.0.1:4557", sleep_after_open=0)`.

use canopen_core::frame::CanFrame;
use embedded_can::Frame;
use hal_host::slcan::SlcanServer;
use std::io::Write;

fn main() -> std::io::Result<()> {
    let addr = std::env::args().nth(1).unwrap_or_else(|| "127.0.0.1:0".to_owned());
    let (server, channels) = SlcanServer::bind(addr.as_str())?;
    println!("listening on {}", server.local_addr());
    std::io::stdout().flush()?;
    for frame in channels.from_client.iter() {
        let answer = match frame.cob_id() {
            Some(id) if id >= 0x80 && !frame.is_remote_frame() => CanFrame::standard(id - 0x80, frame.data()).unwrap_or(frame),
            _ => frame,
        };
        println!("{} -> {}", hal_host::trace::format_frame(&frame), hal_host::trace::format_frame(&answer));
        if channels.to_client.send(answer).is_err() {
            break;
        }
    }
    Ok(())
}
