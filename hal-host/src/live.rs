//! The test master in real time: the sans-IO pieces of [`crate::master`]
//! driven over an [`SlcanClient`], against a node that runs on its own
//! clock (a QEMU image, `vnode`, or hardware behind an SLCAN adapter).
//!
//! [`LiveMaster`] logs every frame in both directions with the wall time
//! since it started and hands each one to an observer as it happens (the
//! demo prints its trace from there). SDO transfers are the master's
//! [`SdoTransfer`] state machines; this file only moves their frames and
//! feeds them the time, which is wall time in microseconds since the start
//! ([`LiveMaster::now`]). The transfer's own timeout bounds every wait.

use crate::master::{DownloadMode, SdoClient, SdoClientError, SdoTransfer, UploadMode};
use crate::slcan_client::{AdapterEvent, SlcanClient};
use canopen_core::frame::CanFrame;
use canopen_core::time::Instant as CoreInstant;
use embedded_can::Frame;
use std::io;
use std::time::{Duration, Instant};

/// Which way a frame went.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// From the master to the bus.
    Sent,
    /// From the bus to the master.
    Received,
}

/// One frame of the log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LoggedFrame {
    /// Wall time since the master started.
    pub at: Duration,
    /// Which way it went.
    pub direction: Direction,
    /// The frame.
    pub frame: CanFrame,
}

/// What the adapter said besides frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AdapterCounts {
    /// `z`/`Z` answers: frames the adapter accepted for transmission.
    pub acks: u64,
    /// BEL answers: commands it refused.
    pub refused: u64,
    /// Lines that were neither frames nor answers.
    pub garbage: u64,
}

/// A master on an SLCAN connection; see the [module docs](self).
pub struct LiveMaster {
    client: SlcanClient,
    start: Instant,
    log: Vec<LoggedFrame>,
    counts: AdapterCounts,
    observer: Box<dyn FnMut(&LoggedFrame)>,
}

impl core::fmt::Debug for LiveMaster {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("LiveMaster").field("frames", &self.log.len()).field("counts", &self.counts).finish_non_exhaustive()
    }
}

impl LiveMaster {
    /// Opens the adapter's channel; time starts now. Frames that arrived
    /// while the channel opened are logged first.
    pub fn open(mut client: SlcanClient, observer: Box<dyn FnMut(&LoggedFrame)>, timeout: Duration) -> io::Result<LiveMaster> {
        let start = Instant::now();
        let early = client.open(timeout)?;
        let mut m = LiveMaster { client, start, log: Vec::new(), counts: AdapterCounts::default(), observer };
        for (at, frame) in early {
            m.record(at, Direction::Received, frame);
        }
        Ok(m)
    }

    /// Wall time since the start.
    pub fn elapsed(&self) -> Duration {
        self.start.elapsed()
    }

    /// The same, as the master's state machines count time.
    pub fn now(&self) -> CoreInstant {
        CoreInstant::from_micros(self.elapsed().as_micros() as u64)
    }

    /// Every frame so far, in the order the master saw them.
    pub fn log(&self) -> &[LoggedFrame] {
        &self.log
    }

    /// The adapter's answers so far.
    pub fn counts(&self) -> AdapterCounts {
        self.counts
    }

    fn record(&mut self, at: Instant, direction: Direction, frame: CanFrame) {
        // A frame that arrived while a send was being logged is logged after
        // it: its time is clamped so the log's times never go back (the
        // log is in the order the master saw the frames).
        let last = self.log.last().map_or(Duration::ZERO, |l| l.at);
        let entry = LoggedFrame { at: at.saturating_duration_since(self.start).max(last), direction, frame };
        (self.observer)(&entry);
        self.log.push(entry);
    }

    /// Sends a frame.
    pub fn send(&mut self, frame: CanFrame) -> io::Result<()> {
        self.client.send(&frame)?;
        self.record(Instant::now(), Direction::Sent, frame);
        Ok(())
    }

    /// Sends a data frame with an 11-bit COB-ID.
    pub fn send_std(&mut self, cob_id: u16, data: &[u8]) -> io::Result<()> {
        let frame = CanFrame::standard(cob_id, data).ok_or_else(|| {
            io::Error::new(io::ErrorKind::InvalidInput, format!("no frame with COB-ID {cob_id:#x} and {} bytes", data.len()))
        })?;
        self.send(frame)
    }

    /// The next received frame, waiting until `deadline` (`None` then).
    /// Answers of the adapter are counted on the way.
    pub fn recv_until(&mut self, deadline: Instant) -> io::Result<Option<CanFrame>> {
        loop {
            let Some((at, event)) = self.client.recv_until(deadline)? else { return Ok(None) };
            match event {
                AdapterEvent::Frame(frame) => {
                    self.record(at, Direction::Received, frame);
                    return Ok(Some(frame));
                }
                AdapterEvent::TxAck => self.counts.acks += 1,
                AdapterEvent::Error => self.counts.refused += 1,
                AdapterEvent::Garbage(_) => self.counts.garbage += 1,
                AdapterEvent::Ok | AdapterEvent::Text(_) => {}
            }
        }
    }

    /// Where the log ends now: a mark for [`wait_for`](Self::wait_for).
    pub fn mark(&self) -> usize {
        self.log.len()
    }

    /// The first received frame from log position `since` on that `pred`
    /// accepts: one already logged (during an SDO transfer, say), or one
    /// arriving within `timeout`. Every frame on the way is logged; `None`
    /// when the time is up.
    pub fn wait_for(&mut self, since: usize, timeout: Duration, mut pred: impl FnMut(&CanFrame) -> bool) -> io::Result<Option<CanFrame>> {
        let logged = self.log.get(since..).unwrap_or(&[]).iter().find(|l| l.direction == Direction::Received && pred(&l.frame));
        if let Some(l) = logged {
            return Ok(Some(l.frame));
        }
        let deadline = Instant::now() + timeout;
        while let Some(frame) = self.recv_until(deadline)? {
            if pred(&frame) {
                return Ok(Some(frame));
            }
        }
        Ok(None)
    }

    /// Logs whatever arrives during `time`.
    pub fn idle(&mut self, time: Duration) -> io::Result<()> {
        let deadline = Instant::now() + time;
        while self.recv_until(deadline)?.is_some() {}
        Ok(())
    }

    /// Runs `transfer` until it ends: the uploaded value (empty for a
    /// download) or the transfer's error. An `Err` only if the connection failed.
    pub fn run_transfer(&mut self, mut transfer: SdoTransfer) -> io::Result<Result<Vec<u8>, SdoClientError>> {
        let (request, response) = (transfer.request_cob_id(), transfer.response_cob_id());
        loop {
            while let Some(data) = transfer.pop_tx() {
                self.send_std(request, &data)?;
                transfer.on_sent(self.now());
            }
            let Some(deadline) = transfer.process(self.now()) else {
                // An abort frame of the client's own goes out before the result.
                while let Some(data) = transfer.pop_tx() {
                    self.send_std(request, &data)?;
                }
                return Ok(transfer.into_result().unwrap_or_else(|| Ok(Vec::new())));
            };
            let wait = Duration::from_micros(deadline.as_micros().saturating_sub(self.now().as_micros()));
            if let Some(frame) = self.recv_until(Instant::now() + wait)?
                && frame.cob_id() == Some(response)
                && !frame.is_remote_frame()
            {
                transfer.on_frame(self.now(), frame.data());
            }
        }
    }

    /// Reads (index, sub) from node `node_id`'s default SDO server.
    pub fn sdo_upload(&mut self, node_id: u8, index: u16, sub: u8) -> io::Result<Result<Vec<u8>, SdoClientError>> {
        let transfer = SdoClient::new(node_id).upload(self.now(), index, sub, UploadMode::ExpeditedOrSegmented);
        self.run_transfer(transfer)
    }

    /// Writes `data` to (index, sub) on node `node_id`'s default SDO server
    /// (expedited up to 4 bytes, segmented above).
    pub fn sdo_download(&mut self, node_id: u8, index: u16, sub: u8, data: &[u8]) -> io::Result<Result<(), SdoClientError>> {
        let transfer = SdoClient::new(node_id).download(self.now(), index, sub, data, DownloadMode::Auto);
        Ok(self.run_transfer(transfer)?.map(|_| ()))
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests;
