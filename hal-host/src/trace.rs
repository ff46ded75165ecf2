//! A trace of the frames on the bus, in the log format of can-utils'
//! `candump -L` (read back by `canplayer`, `log2asc`, python-can's
//! `CanutilsLogReader`):
//!
//! ```text
//! (0000000012.345678) vcan0 601#4000100000000000
//! (0000000012.346012) vcan0 701#R
//! (0000000012.346100) vcan0 12345678#01
//! ```
//!
//! Seconds have 10 digits and microseconds 6; standard identifiers have 3
//! hex digits and extended ones 8; data is upper-case hex. A remote frame
//! is `#R`, followed by its DLC when that is not zero (`701#R1`), as
//! can-utils' `sprint_canframe` prints it. A frame's time is the end of its
//! EOF, when the receivers accept it.

use crate::bus::{Bus, PortId};
use canopen_core::frame::CanFrame;
use canopen_core::time::Instant;
use embedded_can::Frame;
use std::fmt::Write as _;
use std::io;
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

/// One frame seen on the bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TraceEntry {
    /// When its EOF ended.
    pub time: Instant,
    /// Who sent it.
    pub port: PortId,
    /// The frame.
    pub frame: CanFrame,
}

/// The frame part of a candump line: `601#4000100000000000`, `701#R`.
pub fn format_frame(frame: &CanFrame) -> String {
    let mut s = String::with_capacity(26);
    // Writing to a String cannot fail.
    let _ = if frame.is_extended_id() { write!(s, "{:08X}#", frame.raw_id()) } else { write!(s, "{:03X}#", frame.raw_id()) };
    if frame.is_remote_frame() {
        s.push('R');
        if frame.dlc() != 0 {
            let _ = write!(s, "{:X}", frame.dlc());
        }
    } else {
        for b in frame.data() {
            let _ = write!(s, "{b:02X}");
        }
    }
    s
}

/// A whole candump line without the newline:
/// `(0000000012.345678) vcan0 601#4000100000000000`.
pub fn format_line(time: Instant, iface: &str, frame: &CanFrame) -> String {
    let us = time.as_micros();
    format!("({:010}.{:06}) {iface} {}", us / 1_000_000, us % 1_000_000, format_frame(frame))
}

/// Writes candump lines to any [`io::Write`].
#[derive(Debug)]
pub struct CandumpWriter<W: io::Write> {
    out: W,
    iface: String,
}

impl<W: io::Write> CandumpWriter<W> {
    /// A writer labelling every line with interface name `iface` (`vcan0`).
    pub fn new(out: W, iface: &str) -> Self {
        CandumpWriter { out, iface: iface.to_owned() }
    }

    /// Writes one line.
    pub fn write_frame(&mut self, time: Instant, frame: &CanFrame) -> io::Result<()> {
        writeln!(self.out, "{}", format_line(time, &self.iface, frame))
    }

    /// Writes one line per entry.
    pub fn write_entries(&mut self, entries: &[TraceEntry]) -> io::Result<()> {
        entries.iter().try_for_each(|e| self.write_frame(e.time, &e.frame))
    }

    /// Writes everything `bus` has recorded so far (see [`Bus::enable_trace`]).
    pub fn write_bus_trace(&mut self, bus: &Bus) -> io::Result<()> {
        self.write_entries(bus.trace())
    }

    /// Flushes and returns the inner writer.
    pub fn into_inner(mut self) -> io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}

/// A candump log written by its own thread, so a slow or stuck output
/// (an undrained pipe, a full disk) never holds up the caller: lines wait
/// in a queue of fixed length, and when it is full the newest are dropped
/// and counted. A write error stops the log (its lines count as dropped
/// from then on) and is kept for [`error`](Self::error).
#[derive(Debug)]
pub struct BackgroundLog {
    lines: Option<SyncSender<(Instant, CanFrame)>>,
    dropped: u64,
    error: Arc<Mutex<Option<String>>>,
    thread: Option<JoinHandle<()>>,
}

impl BackgroundLog {
    /// Starts the writer thread on `out`, labelling lines with `iface`,
    /// with room for `capacity` lines in the queue.
    pub fn spawn<W: io::Write + Send + 'static>(out: W, iface: &str, capacity: usize) -> io::Result<BackgroundLog> {
        let (lines, queue) = mpsc::sync_channel(capacity);
        let error = Arc::new(Mutex::new(None));
        let writer = CandumpWriter::new(io::BufWriter::new(out), iface);
        let failed = Arc::clone(&error);
        let thread = std::thread::Builder::new().name("candump-log".into()).spawn(move || {
            if let Err(e) = write_log(writer, &queue) {
                *failed.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = Some(e.to_string());
            }
        })?;
        Ok(BackgroundLog { lines: Some(lines), dropped: 0, error, thread: Some(thread) })
    }

    /// Queues one line; never waits.
    pub fn record(&mut self, time: Instant, frame: &CanFrame) {
        let queued = self.lines.as_ref().is_some_and(|l| match l.try_send((time, *frame)) {
            Ok(()) => true,
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => false,
        });
        if !queued {
            self.dropped += 1;
        }
    }

    /// Lines not written: the queue was full, or the output had failed.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Why the writer stopped, if it did.
    pub fn error(&self) -> Option<String> {
        self.error.lock().unwrap_or_else(std::sync::PoisonError::into_inner).clone()
    }

    /// Writes what is queued, flushes and stops the thread.
    pub fn finish(mut self) -> Option<String> {
        self.stop();
        self.error()
    }

    fn stop(&mut self) {
        self.lines = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for BackgroundLog {
    fn drop(&mut self) {
        self.stop();
    }
}

/// The writer thread: writes lines as they come, flushing whenever the
/// queue runs empty, until the sender is gone.
fn write_log<W: io::Write>(mut writer: CandumpWriter<W>, queue: &Receiver<(Instant, CanFrame)>) -> io::Result<()> {
    while let Ok((time, frame)) = queue.recv() {
        writer.write_frame(time, &frame)?;
        while let Ok((time, frame)) = queue.try_recv() {
            writer.write_frame(time, &frame)?;
        }
        writer.out.flush()?;
    }
    writer.into_inner().map(drop)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::BitRate;

    #[test]
    fn formats_exact_lines() {
        let t = Instant::from_micros(12_345_678);
        let sdo = CanFrame::standard(0x601, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]).unwrap();
        assert_eq!(format_line(t, "vcan0", &sdo), "(0000000012.345678) vcan0 601#4000100000000000");
        let rtr = CanFrame::remote(0x701, 0).unwrap();
        assert_eq!(format_line(Instant::ZERO, "can1", &rtr), "(0000000000.000000) can1 701#R");
        assert_eq!(format_frame(&CanFrame::remote(0x701, 1).unwrap()), "701#R1");
        assert_eq!(format_frame(&CanFrame::standard(0x80, &[]).unwrap()), "080#");
        assert_eq!(format_frame(&CanFrame::extended(0x1ABC_DEF0, &[0xAB, 1]).unwrap()), "1ABCDEF0#AB01");
        assert_eq!(format_frame(&CanFrame::extended(0x5, &[]).unwrap()), "00000005#");
        let far = Instant::from_micros(u64::MAX);
        assert_eq!(format_line(far, "x", &rtr), "(18446744073709.551615) x 701#R");
    }

    /// An output that blocks until told to go on, then fails or succeeds.
    struct Gate {
        entered: std::sync::mpsc::Sender<()>,
        open: std::sync::mpsc::Receiver<bool>,
        written: Arc<Mutex<Vec<u8>>>,
    }

    impl io::Write for Gate {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            let _ = self.entered.send(());
            match self.open.recv() {
                Ok(true) => {
                    self.written.lock().unwrap().extend_from_slice(buf);
                    Ok(buf.len())
                }
                _ => Err(io::Error::from(io::ErrorKind::BrokenPipe)),
            }
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn a_stuck_output_never_holds_up_the_log() {
        let (go, open) = std::sync::mpsc::channel();
        let (entered, writing) = std::sync::mpsc::channel();
        let written = Arc::new(Mutex::new(Vec::new()));
        let mut log = BackgroundLog::spawn(Gate { entered, open, written: Arc::clone(&written) }, "can0", 4).unwrap();
        let frame = CanFrame::standard(0x123, &[0xDE, 0xAD]).unwrap();
        let t = Instant::from_micros(1_700_000_000_123_456);
        // The writer takes the first line and blocks writing it; 4 more fit
        // in the queue, the rest are dropped at once.
        log.record(t, &frame);
        writing.recv().unwrap();
        for _ in 0..1000 {
            log.record(t, &frame);
        }
        assert_eq!(log.dropped(), 996);
        for _ in 0..3 {
            go.send(true).unwrap();
        }
        assert_eq!(log.finish(), None);
        let text = String::from_utf8(written.lock().unwrap().clone()).unwrap();
        assert_eq!(text, "(1700000000.123456) can0 123#DEAD\n".repeat(5));
    }

    #[test]
    fn a_failed_output_stops_the_log_and_says_why() {
        let (go, open) = std::sync::mpsc::channel();
        let (entered, _writing) = std::sync::mpsc::channel();
        let mut log = BackgroundLog::spawn(Gate { entered, open, written: Arc::default() }, "can0", 4).unwrap();
        drop(go);
        let frame = CanFrame::standard(0x80, &[]).unwrap();
        log.record(Instant::ZERO, &frame);
        let start = std::time::Instant::now();
        while log.error().is_none() {
            assert!(start.elapsed() < std::time::Duration::from_secs(10));
            std::thread::yield_now();
        }
        for _ in 0..10 {
            log.record(Instant::ZERO, &frame);
        }
        assert_eq!(log.dropped(), 10);
        assert!(log.finish().is_some_and(|e| e.contains("roken pipe")));
    }

    #[test]
    fn writes_the_bus_trace() {
        let mut bus = Bus::new(BitRate::MBIT_1);
        bus.enable_trace();
        let (a, b) = (bus.attach(), bus.attach());
        bus.send(a, CanFrame::standard(0x000, &[]).unwrap()).unwrap();
        bus.send(b, CanFrame::standard(0x702, &[0x05]).unwrap()).unwrap();
        bus.send(a, CanFrame::remote(0x701, 1).unwrap()).unwrap();
        bus.drop_where(|_, f| f.raw_id() == 0x702);
        bus.run_until(Instant::from_micros(1_000));
        let mut w = CandumpWriter::new(Vec::new(), "vcan0");
        w.write_bus_trace(&bus).unwrap();
        let text = String::from_utf8(w.into_inner().unwrap()).unwrap();
        // 0x000 without data is 53 bits; EOF ends 3 bits before that. The
        // remote frame 0x701 (51 bits) beats 0x702, starts at 53 µs and ends
        // EOF at 53 + 48 = 101 µs. The dropped 0x702 follows, not traced.
        assert_eq!(text, "(0000000000.000050) vcan0 000#\n(0000000000.000101) vcan0 701#R1\n");
        assert_eq!(bus.take_trace().len(), 2);
        assert!(bus.trace().is_empty());
    }
}
