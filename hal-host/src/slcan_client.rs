//! The host side of SLCAN over TCP: what a PLC-like tool does with a serial
//! CAN adapter that is reachable on a TCP port (the QEMU board's UART, or
//! [`crate::slcan::SlcanServer`] in front of `vnode`).
//!
//! [`SlcanClient::connect`] opens the TCP connection; a reader thread splits
//! the adapter's bytes into [`AdapterEvent`]s, each stamped with the wall
//! time it arrived, so the caller can wait with a timeout and never blocks
//! on a silent adapter. [`SlcanClient::open`] sends `O` and waits for its
//! CR; [`SlcanClient::send`] writes one `t`/`T`/`r`/`R` line (the adapter
//! answers `z`/`Z`, reported as [`AdapterEvent::TxAck`]).
//!
//! Frame lines from the adapter are decoded with the crate's SLCAN codec
//! ([`crate::slcan::decode`], the firmware's); a trailing 4-digit timestamp (`Z1`)
//! is accepted and dropped. Answers are a bare CR ([`AdapterEvent::Ok`]),
//! BEL ([`AdapterEvent::Error`], which has no CR), `z`/`Z`, or a text line
//! such as `V1013` ([`AdapterEvent::Text`]).

use crate::slcan::{BEL, CR, Command, FRAME_LINE, MAX_LINE, decode, encode};
use canopen_core::frame::CanFrame;
use std::io::{self, Read, Write};
use std::net::{Shutdown, TcpStream, ToSocketAddrs};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// One thing the adapter said.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum AdapterEvent {
    /// A frame received from the bus.
    Frame(CanFrame),
    /// `z`/`Z`: a frame the client sent was accepted for transmission.
    TxAck,
    /// A bare CR: a command succeeded.
    Ok,
    /// BEL: a command was refused.
    Error,
    /// Any other line (version, serial number, status flags), without its CR.
    Text(String),
    /// A line that is neither a frame nor an answer (the bytes, without CR).
    Garbage(Vec<u8>),
}

/// Splits adapter → host bytes into [`AdapterEvent`]s.
#[derive(Clone, Debug, Default)]
pub struct AdapterDecoder {
    line: Vec<u8>,
}

impl AdapterDecoder {
    /// A decoder at the start of a line.
    pub fn new() -> Self {
        AdapterDecoder::default()
    }

    /// Takes a chunk of bytes; returns the events it completed, in order.
    pub fn push(&mut self, bytes: &[u8]) -> Vec<AdapterEvent> {
        let mut events = Vec::new();
        for &b in bytes {
            match b {
                BEL => events.push(AdapterEvent::Error),
                CR | b'\n' => {
                    let line = std::mem::take(&mut self.line);
                    // LF after CR, as some adapters send, is not an answer of its own.
                    if b == CR || !line.is_empty() {
                        events.push(classify(&line));
                    }
                }
                // A line longer than any valid one is garbage; keep its start only.
                _ if self.line.len() < 2 * MAX_LINE => self.line.push(b),
                _ => {}
            }
        }
        events
    }
}

fn classify(line: &[u8]) -> AdapterEvent {
    match line {
        [] => AdapterEvent::Ok,
        [b'z'] | [b'Z'] => AdapterEvent::TxAck,
        [b't' | b'T' | b'r' | b'R', ..] => {
            let frame = decode_frame_line(line);
            frame.map_or_else(|| AdapterEvent::Garbage(line.to_vec()), AdapterEvent::Frame)
        }
        _ if line.iter().all(|b| b.is_ascii_graphic()) => AdapterEvent::Text(String::from_utf8_lossy(line).into_owned()),
        _ => AdapterEvent::Garbage(line.to_vec()),
    }
}

/// A frame line, with or without the 4 hex digits of a `Z1` timestamp.
fn decode_frame_line(line: &[u8]) -> Option<CanFrame> {
    let as_frame = |l: &[u8]| match decode(l) {
        Ok(Command::Transmit(frame)) => Some(frame),
        _ => None,
    };
    as_frame(line).or_else(|| line.len().checked_sub(4).and_then(|n| line.get(..n)).and_then(as_frame))
}

/// A connection to an SLCAN adapter served on TCP; see the [module docs](self).
#[derive(Debug)]
pub struct SlcanClient {
    stream: TcpStream,
    events: Receiver<(Instant, AdapterEvent)>,
    reader: Option<JoinHandle<()>>,
}

impl SlcanClient {
    /// Connects to `addr`, retrying until `timeout` has passed (the adapter
    /// may still be starting, as QEMU does before it listens).
    pub fn connect(addr: impl ToSocketAddrs, timeout: Duration) -> io::Result<SlcanClient> {
        let start = Instant::now();
        let addrs: Vec<_> = addr.to_socket_addrs()?.collect();
        let stream = loop {
            let mut last = io::Error::new(io::ErrorKind::InvalidInput, "no address to connect to");
            let mut connected = None;
            for a in &addrs {
                match TcpStream::connect_timeout(a, timeout.max(Duration::from_millis(1))) {
                    Ok(s) => {
                        connected = Some(s);
                        break;
                    }
                    Err(e) => last = e,
                }
            }
            match connected {
                Some(s) => break s,
                None if start.elapsed() >= timeout => return Err(last),
                None => std::thread::sleep(Duration::from_millis(20)),
            }
        };
        stream.set_nodelay(true)?;
        let mut reader = stream.try_clone()?;
        let (tx, events) = mpsc::channel();
        let thread = std::thread::Builder::new().name("slcan-client".into()).spawn(move || {
            let mut decoder = AdapterDecoder::new();
            let mut buf = [0u8; 512];
            loop {
                let n = match reader.read(&mut buf) {
                    Ok(0) => return,
                    Ok(n) => n,
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                    Err(_) => return,
                };
                let now = Instant::now();
                for event in decoder.push(buf.get(..n).unwrap_or(&[])) {
                    if tx.send((now, event)).is_err() {
                        return;
                    }
                }
            }
        })?;
        Ok(SlcanClient { stream, events, reader: Some(thread) })
    }

    /// Sends a raw command line (CR is added).
    pub fn command(&mut self, line: &str) -> io::Result<()> {
        let mut bytes = Vec::with_capacity(line.len() + 1);
        bytes.extend_from_slice(line.as_bytes());
        bytes.push(CR);
        self.stream.write_all(&bytes)
    }

    /// Opens the channel (`O`) and waits up to `timeout` for the adapter's
    /// CR. Frames that arrive meanwhile are returned, so none is lost.
    pub fn open(&mut self, timeout: Duration) -> io::Result<Vec<(Instant, CanFrame)>> {
        self.command("O")?;
        let deadline = Instant::now() + timeout;
        let mut early = Vec::new();
        loop {
            match self.recv_until(deadline)? {
                Some((_, AdapterEvent::Ok)) => return Ok(early),
                Some((_, AdapterEvent::Error)) => return Err(io::Error::other("the adapter refused `O` (channel already open?)")),
                Some((at, AdapterEvent::Frame(f))) => early.push((at, f)),
                Some(_) => {}
                None => return Err(io::Error::new(io::ErrorKind::TimedOut, "no answer to `O`")),
            }
        }
    }

    /// Sends one frame; the adapter answers [`AdapterEvent::TxAck`].
    pub fn send(&mut self, frame: &CanFrame) -> io::Result<()> {
        let mut line = [0u8; FRAME_LINE];
        let n = encode(frame, None, &mut line);
        self.stream.write_all(line.get(..n).unwrap_or(&[]))
    }

    /// The next event, waiting until `deadline`; `None` when it passed.
    /// An error once the adapter has closed the connection.
    pub fn recv_until(&mut self, deadline: Instant) -> io::Result<Option<(Instant, AdapterEvent)>> {
        let wait = deadline.saturating_duration_since(Instant::now());
        match self.events.recv_timeout(wait) {
            Ok(event) => Ok(Some(event)),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => {
                Err(io::Error::new(io::ErrorKind::ConnectionAborted, "the adapter closed the connection"))
            }
        }
    }

    /// The next event if one is already there.
    pub fn try_recv(&mut self) -> Option<(Instant, AdapterEvent)> {
        self.events.try_recv().ok()
    }
}

impl Drop for SlcanClient {
    fn drop(&mut self) {
        // Ends the reader's blocking read.
        let _ = self.stream.shutdown(Shutdown::Both);
        if let Some(t) = self.reader.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;
    use crate::slcan::SlcanServer;

    fn std_frame(id: u16, data: &[u8]) -> CanFrame {
        CanFrame::standard(id, data).unwrap()
    }

    #[test]
    fn decoder_splits_answers_frames_and_text() {
        let mut d = AdapterDecoder::new();
        // Split anywhere: a frame line arrives in two chunks.
        assert_eq!(d.push(b"\r\x07z\rZ\rt77F"), [AdapterEvent::Ok, AdapterEvent::Error, AdapterEvent::TxAck, AdapterEvent::TxAck]);
        assert_eq!(d.push(b"105\r"), [AdapterEvent::Frame(std_frame(0x77F, &[0x05]))]);
        let ext = CanFrame::extended(0x1FFF_FFFF, b"EXIT").unwrap();
        assert_eq!(
            d.push(b"T1FFFFFFF445584954\rr7011\r"),
            [AdapterEvent::Frame(ext), AdapterEvent::Frame(CanFrame::remote(0x701, 1).unwrap())]
        );
        // A Z1 timestamp after the data is dropped; LF after CR is not an answer.
        assert_eq!(d.push(b"t1852AABB1234\r\n"), [AdapterEvent::Frame(std_frame(0x185, &[0xAA, 0xBB]))]);
        assert_eq!(
            d.push(b"V1013\rt12\r\x01\x02\r"),
            [AdapterEvent::Text("V1013".into()), AdapterEvent::Garbage(b"t12".to_vec()), AdapterEvent::Garbage(vec![1, 2])]
        );
    }

    #[test]
    fn decoder_bounds_an_endless_line() {
        let mut d = AdapterDecoder::new();
        assert_eq!(d.push(&[b'x'; 1000]), []);
        assert_eq!(d.push(b"\r"), [AdapterEvent::Text("x".repeat(2 * MAX_LINE))]);
    }

    /// Against the crate's own adapter: open, frames both ways, acks and a refused command.
    #[test]
    fn talks_to_an_slcan_server() {
        let (server, channels) = SlcanServer::bind("127.0.0.1:0").unwrap();
        let mut client = SlcanClient::connect(server.local_addr(), Duration::from_secs(5)).unwrap();
        let deadline = || Instant::now() + Duration::from_secs(5);
        // A frame before `O` is refused with BEL.
        client.send(&std_frame(0x000, &[0x01, 0x7F])).unwrap();
        assert_eq!(client.recv_until(deadline()).unwrap().unwrap().1, AdapterEvent::Error);
        assert_eq!(client.open(Duration::from_secs(5)).unwrap(), []);
        client.send(&std_frame(0x000, &[0x01, 0x7F])).unwrap();
        assert_eq!(client.recv_until(deadline()).unwrap().unwrap().1, AdapterEvent::TxAck);
        assert_eq!(channels.from_client.recv_timeout(Duration::from_secs(5)).unwrap(), std_frame(0x000, &[0x01, 0x7F]));
        channels.to_client.send(std_frame(0x77F, &[0x05])).unwrap();
        assert_eq!(client.recv_until(deadline()).unwrap().unwrap().1, AdapterEvent::Frame(std_frame(0x77F, &[0x05])));
        // `O` twice is refused.
        assert!(client.open(Duration::from_secs(5)).is_err());
        client.command("V").unwrap();
        assert_eq!(client.recv_until(deadline()).unwrap().unwrap().1, AdapterEvent::Text("V1013".into()));
        // Nothing more: the wait ends at its deadline.
        assert_eq!(client.recv_until(Instant::now() + Duration::from_millis(50)).unwrap(), None);
        assert!(client.try_recv().is_none());
        // The adapter going away is an error, not a hang.
        drop(server);
        assert!(client.recv_until(deadline()).is_err());
    }

    #[test]
    fn connect_gives_up_after_its_timeout() {
        // A port nobody listens on: bind one, note it, close it.
        let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
        let start = Instant::now();
        assert!(SlcanClient::connect(("127.0.0.1", port), Duration::from_millis(200)).is_err());
        assert!(start.elapsed() >= Duration::from_millis(200));
    }
}
