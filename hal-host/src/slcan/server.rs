//! SLCAN over TCP: one client at a time, bridged to two channels.
//!
//! The server thread accepts a client, resets the [`SlcanAdapter`] and reads
//! the client's bytes: answers go straight back, accepted frames go to
//! [`SlcanChannels::from_client`]. A second thread forwards what arrives on
//! [`SlcanChannels::to_client`] while the client's channel is open; frames
//! that arrive while no client has an open channel are discarded, as an
//! adapter with a closed channel would. When the client disconnects the
//! server waits for the next one. Dropping the [`SlcanServer`] stops it.

use super::{ChannelState, SlcanAdapter};
use canopen_core::frame::CanFrame;
use std::io::{self, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How often the forwarding thread checks whether its client has gone.
const POLL: Duration = Duration::from_millis(20);

/// The application's side of an [`SlcanServer`].
#[derive(Debug)]
pub struct SlcanChannels {
    /// Frames the client sent (each already acknowledged with `z`/`Z`).
    pub from_client: Receiver<CanFrame>,
    /// Frames to show the client as received from the bus.
    pub to_client: Sender<CanFrame>,
}

/// What the server's client has set up.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AdapterStatus {
    /// Whether a client is connected.
    pub connected: bool,
    /// Its channel state.
    pub state: ChannelState,
    /// The bit rate it chose with `S`, if any.
    pub bitrate: Option<crate::bus::BitRate>,
    /// Lines answered with BEL on this connection.
    pub errors: u64,
}

struct Shared {
    adapter: SlcanAdapter,
    /// The connected client's stream, for writing and for shutting it down.
    stream: Option<TcpStream>,
}

fn lock(shared: &Mutex<Shared>) -> MutexGuard<'_, Shared> {
    // A panic elsewhere cannot leave `Shared` inconsistent: keep going.
    shared.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// An SLCAN adapter served on a TCP port, one client at a time.
///
/// The server thread answers the client's commands and sends the frames it
/// accepted to [`SlcanChannels::from_client`]; a second thread forwards what
/// arrives on [`SlcanChannels::to_client`] while the client's channel is open
/// (frames arriving while it is not are discarded, as a closed adapter
/// would). When the client disconnects the server waits for the next one;
/// dropping the server stops it.
pub struct SlcanServer {
    local_addr: SocketAddr,
    stop: Arc<AtomicBool>,
    shared: Arc<Mutex<Shared>>,
    thread: Option<JoinHandle<()>>,
}

impl core::fmt::Debug for SlcanServer {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("SlcanServer").field("local_addr", &self.local_addr).finish_non_exhaustive()
    }
}

impl SlcanServer {
    /// Listens on `addr` (port 0 picks a free port; see
    /// [`local_addr`](Self::local_addr)) and starts serving.
    pub fn bind(addr: impl ToSocketAddrs) -> io::Result<(SlcanServer, SlcanChannels)> {
        let listener = TcpListener::bind(addr)?;
        let local_addr = listener.local_addr()?;
        let (from_client_tx, from_client) = mpsc::channel();
        let (to_client, to_client_rx) = mpsc::channel();
        let stop = Arc::new(AtomicBool::new(false));
        let shared = Arc::new(Mutex::new(Shared { adapter: SlcanAdapter::new(), stream: None }));
        let (stop2, shared2) = (Arc::clone(&stop), Arc::clone(&shared));
        let thread = std::thread::Builder::new()
            .name("slcan-server".into())
            .spawn(move || serve(listener, &stop2, &shared2, &from_client_tx, to_client_rx))?;
        let server = SlcanServer { local_addr, stop, shared, thread: Some(thread) };
        Ok((server, SlcanChannels { from_client, to_client }))
    }

    /// The address the server listens on.
    pub fn local_addr(&self) -> SocketAddr {
        self.local_addr
    }

    /// The state of the current client (if any).
    pub fn status(&self) -> AdapterStatus {
        let s = lock(&self.shared);
        AdapterStatus { connected: s.stream.is_some(), state: s.adapter.state(), bitrate: s.adapter.bitrate(), errors: s.adapter.errors() }
    }

    /// Disconnects the client and stops the server.
    pub fn shutdown(mut self) {
        self.stop_and_join();
    }

    fn stop_and_join(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(stream) = lock(&self.shared).stream.take() {
            let _ = stream.shutdown(Shutdown::Both);
        }
        // Wake the blocking accept; failure means it is not waiting.
        let _ = TcpStream::connect(self.local_addr);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for SlcanServer {
    fn drop(&mut self) {
        self.stop_and_join();
    }
}

fn serve(
    listener: TcpListener,
    stop: &AtomicBool,
    shared: &Arc<Mutex<Shared>>,
    from_client: &Sender<CanFrame>,
    to_client: Receiver<CanFrame>,
) {
    let mut to_client = Some(to_client);
    for conn in listener.incoming() {
        if stop.load(Ordering::SeqCst) {
            break;
        }
        let Ok(stream) = conn else { continue };
        let _ = stream.set_nodelay(true);
        let Ok(reader) = stream.try_clone() else { continue };
        {
            let mut s = lock(shared);
            s.adapter = SlcanAdapter::new();
            s.stream = Some(stream);
        }
        let done = Arc::new(AtomicBool::new(false));
        let forwarder = to_client.take().and_then(|rx| {
            // Frames queued while nobody listened are stale.
            while rx.try_recv().is_ok() {}
            let (shared, done) = (Arc::clone(shared), Arc::clone(&done));
            std::thread::Builder::new().name("slcan-forward".into()).spawn(move || forward(rx, &shared, &done)).ok()
        });
        read_client(reader, shared, from_client);
        done.store(true, Ordering::SeqCst);
        if let Some(stream) = lock(shared).stream.take() {
            let _ = stream.shutdown(Shutdown::Both);
        }
        to_client = forwarder.and_then(|t| t.join().ok());
    }
}

/// Reads the client until it disconnects.
fn read_client(mut reader: TcpStream, shared: &Mutex<Shared>, from_client: &Sender<CanFrame>) {
    let mut buf = [0u8; 512];
    let (mut reply, mut frames) = (Vec::new(), Vec::new());
    loop {
        let n = match reader.read(&mut buf) {
            Ok(0) => return,
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(_) => return,
        };
        {
            let mut s = lock(shared);
            s.adapter.receive(buf.get(..n).unwrap_or(&[]), &mut reply, &mut frames);
            if let Some(stream) = s.stream.as_mut()
                && stream.write_all(&reply).is_err()
            {
                return;
            }
        }
        reply.clear();
        for f in frames.drain(..) {
            // Nobody listening on the application side is not the client's problem.
            let _ = from_client.send(f);
        }
    }
}

/// Forwards frames to the client until `done`; hands the receiver back.
fn forward(rx: Receiver<CanFrame>, shared: &Mutex<Shared>, done: &AtomicBool) -> Receiver<CanFrame> {
    let start = Instant::now();
    while !done.load(Ordering::SeqCst) {
        match rx.recv_timeout(POLL) {
            Ok(frame) => {
                let mut s = lock(shared);
                let now_ms = start.elapsed().as_millis() as u64;
                if let (Some(line), Some(stream)) = (s.adapter.encode_rx(&frame, now_ms), s.stream.as_mut()) {
                    let _ = stream.write_all(&line);
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
    }
    rx
}
