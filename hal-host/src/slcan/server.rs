//! SLCAN over TCP: every client is an adapter on one shared bus.
//!
//! Each connection gets its own [`SlcanAdapter`] (channel state, bit rate,
//! timestamps) and two threads: a reader that answers its commands and
//! offers the frames it sends to the wire, and a writer that sends it its
//! answers and the frames it receives. The wire ([`super::wire`]) carries
//! one frame at a time at the bus's bit rate and hands each to every
//! receiver: the application ([`SlcanChannels::from_client`]) and the
//! clients with an open channel, except the sender (python-can's `slcan`
//! interface does not expect its own frames back). The application's
//! frames ([`SlcanChannels::to_client`]) go to every client.
//!
//! Memory is bounded per client: a client that does not read loses the
//! newest frames once [`ServerOptions::client_queue_bytes`] are waiting for
//! it; they are counted ([`ClientStatus::dropped`]) and raise the data
//! overrun flag its `F` command reports. Its own command answers wait
//! instead, which throttles only that client. While no client is connected
//! the node's frames are put on the wire and forgotten. At most
//! [`ServerOptions::max_clients`] are served at once; further connections
//! are closed at once and counted.

use super::credit::Credit;
use super::outbox::Outbox;
use super::wire::{self, WireEvent};
use super::{ChannelState, SlcanAdapter};
use crate::bus::BitRate;
use canopen_core::frame::CanFrame;
use std::io::{self, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, SendError, Sender, TrySendError};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Lawicel status flag bit 3: data overrun (a received frame was lost).
const DATA_OVERRUN: u8 = 0x08;
/// How long a writer waits on a client that does not read before it looks
/// whether the connection is being closed.
const WRITE_POLL: Duration = Duration::from_millis(200);

/// How the server's bus and clients behave.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ServerOptions {
    /// The bus's bit rate: each frame holds the wire for its exact length
    /// (stuff bits included) at this rate.
    pub bit_rate: BitRate,
    /// Bytes of received frames that may wait for one client (at most 26
    /// per frame) before its newest frames are dropped.
    pub client_queue_bytes: usize,
    /// Frames one client may have on their way to the wire before its
    /// reader stops reading (and TCP holds the client back).
    pub client_tx_frames: usize,
    /// Frames the application may have on their way to the wire before
    /// [`FrameSender::send`] waits and [`FrameSender::try_send`] says full.
    pub app_tx_frames: usize,
    /// Clients served at once.
    pub max_clients: usize,
    /// Frames that may wait for the application before the wire waits.
    pub app_queue_frames: usize,
}

impl Default for ServerOptions {
    /// 1 Mbit/s; 64 KiB (about 2,900 frames) per client; 16 frames of
    /// transmit buffer per client, as an adapter's FIFO, and 64 for the
    /// application; 32 clients; 256 frames waiting for the application.
    fn default() -> Self {
        ServerOptions {
            bit_rate: BitRate::MBIT_1,
            client_queue_bytes: 64 * 1024,
            client_tx_frames: 16,
            app_tx_frames: 64,
            max_clients: 32,
            app_queue_frames: 256,
        }
    }
}

/// The application's side of an [`SlcanServer`].
#[derive(Debug)]
pub struct SlcanChannels {
    /// Frames the clients put on the bus, in bus order and at bus pace.
    pub from_client: Receiver<CanFrame>,
    /// Frames the application puts on the bus, for every client.
    pub to_client: FrameSender,
}

/// Puts the application's frames on the server's bus, at most
/// [`ServerOptions::app_tx_frames`] waiting for the wire at once (as a
/// controller has so many transmit buffers).
#[derive(Clone, Debug)]
pub struct FrameSender {
    events: Sender<WireEvent>,
    hub: Arc<Hub>,
}

impl FrameSender {
    /// Queues `frame` for the wire, waiting for room; fails only when the
    /// server is gone.
    pub fn send(&self, frame: CanFrame) -> Result<(), SendError<CanFrame>> {
        if !self.hub.app_credit.take() {
            return Err(SendError(frame));
        }
        self.events.send(WireEvent::Node(frame)).map_err(|_| SendError(frame))
    }

    /// Queues `frame` for the wire if there is room (`Full` while the wire
    /// is that far behind; `Disconnected` when the server is gone).
    pub fn try_send(&self, frame: CanFrame) -> Result<(), TrySendError<CanFrame>> {
        match self.hub.app_credit.try_take() {
            Some(true) => self.events.send(WireEvent::Node(frame)).map_err(|_| TrySendError::Disconnected(frame)),
            Some(false) => Err(TrySendError::Full(frame)),
            None => Err(TrySendError::Disconnected(frame)),
        }
    }
}

/// One connected client, as the server sees it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ClientStatus {
    /// Its address.
    pub peer: SocketAddr,
    /// Its channel state.
    pub state: ChannelState,
    /// The bit rate it chose with `S`, if any.
    pub bitrate: Option<BitRate>,
    /// Lines answered with BEL on this connection.
    pub errors: u64,
    /// Frames it did not get because it was too far behind.
    pub dropped: u64,
}

/// One connected client.
#[derive(Debug)]
pub(super) struct Client {
    id: u64,
    peer: SocketAddr,
    stream: TcpStream,
    adapter: Mutex<SlcanAdapter>,
    outbox: Outbox,
    credit: Credit,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A panic elsewhere cannot leave these states inconsistent: keep going.
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

impl Client {
    /// Which connection this is (unique for the server's lifetime).
    pub(super) fn id(&self) -> u64 {
        self.id
    }

    /// One of its frames has reached the wire.
    pub(super) fn credit_returned(&self) {
        self.credit.give_back();
    }

    /// Ends the connection: wakes its threads and makes them finish.
    fn close(&self) {
        self.credit.close();
        self.outbox.close();
        let _ = self.stream.shutdown(Shutdown::Read);
    }

    fn status(&self) -> ClientStatus {
        let a = lock(&self.adapter);
        ClientStatus { peer: self.peer, state: a.state(), bitrate: a.bitrate(), errors: a.errors(), dropped: self.outbox.dropped() }
    }
}

/// What the accept thread, the client threads and the wire share.
#[derive(Debug)]
pub(super) struct Hub {
    options: ServerOptions,
    bit_rate: AtomicU32,
    clients: Mutex<Vec<Arc<Client>>>,
    app_credit: Credit,
    refused: AtomicU64,
    start: Instant,
    stop: AtomicBool,
}

impl Hub {
    /// The bus's bit rate in bit/s.
    pub(super) fn bit_rate(&self) -> u32 {
        self.bit_rate.load(Ordering::Relaxed)
    }

    /// Whether the server is stopping.
    pub(super) fn stopping(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }

    /// One of the application's frames has reached the wire.
    pub(super) fn app_credit_returned(&self) {
        self.app_credit.give_back();
    }

    /// Hands a frame on the wire to every client with an open channel,
    /// except `sender`.
    pub(super) fn broadcast(&self, frame: &CanFrame, sender: Option<u64>) {
        let now_ms = self.start.elapsed().as_millis() as u64;
        for c in lock(&self.clients).iter().filter(|c| Some(c.id) != sender) {
            let mut adapter = lock(&c.adapter);
            if let Some(line) = adapter.encode_rx(frame, now_ms)
                && !c.outbox.push_frame(&line)
            {
                adapter.raise_status(DATA_OVERRUN);
            }
        }
    }
}

/// An SLCAN bus served on a TCP port: any number of clients (up to
/// [`ServerOptions::max_clients`]), each an adapter on the same bus as the
/// application. Dropping the server stops it and closes every connection.
pub struct SlcanServer {
    local_addr: SocketAddr,
    hub: Arc<Hub>,
    wire_events: Sender<WireEvent>,
    threads: Vec<JoinHandle<()>>,
}

impl core::fmt::Debug for SlcanServer {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("SlcanServer").field("local_addr", &self.local_addr).finish_non_exhaustive()
    }
}

impl SlcanServer {
    /// Listens on `addr` (port 0 picks a free port; see
    /// [`local_addr`](Self::local_addr)) with the default options.
    pub fn bind(addr: impl ToSocketAddrs) -> io::Result<(SlcanServer, SlcanChannels)> {
        SlcanServer::bind_with(addr, ServerOptions::default())
    }

    /// Listens on `addr` and starts serving.
    pub fn bind_with(addr: impl ToSocketAddrs, options: ServerOptions) -> io::Result<(SlcanServer, SlcanChannels)> {
        let listener = TcpListener::bind(addr)?;
        let local_addr = listener.local_addr()?;
        let (wire_events, events) = mpsc::channel();
        let (to_app, from_client) = mpsc::sync_channel(options.app_queue_frames);
        let hub = Arc::new(Hub {
            options,
            bit_rate: AtomicU32::new(options.bit_rate.bps()),
            clients: Mutex::new(Vec::new()),
            app_credit: Credit::new(options.app_tx_frames),
            refused: AtomicU64::new(0),
            start: Instant::now(),
            stop: AtomicBool::new(false),
        });
        let wire_hub = Arc::clone(&hub);
        let wire = std::thread::Builder::new().name("slcan-wire".into()).spawn(move || wire::run(&wire_hub, &events, &to_app))?;
        let (accept_hub, accept_events) = (Arc::clone(&hub), wire_events.clone());
        let accept = std::thread::Builder::new()
            .name("slcan-accept".into())
            .spawn(move || accept_clients(&listener, &accept_hub, &accept_events))?;
        let to_client = FrameSender { events: wire_events.clone(), hub: Arc::clone(&hub) };
        let server = SlcanServer { local_addr, hub, wire_events, threads: vec![wire, accept] };
        Ok((server, SlcanChannels { from_client, to_client }))
    }

    /// The address the server listens on.
    pub fn local_addr(&self) -> SocketAddr {
        self.local_addr
    }

    /// The connected clients, in the order they connected.
    pub fn clients(&self) -> Vec<ClientStatus> {
        lock(&self.hub.clients).iter().map(|c| c.status()).collect()
    }

    /// Connections closed at once because [`ServerOptions::max_clients`]
    /// were connected.
    pub fn refused(&self) -> u64 {
        self.hub.refused.load(Ordering::Relaxed)
    }

    /// The options it was started with.
    pub fn options(&self) -> ServerOptions {
        self.hub.options
    }

    /// The bus's bit rate.
    pub fn bit_rate(&self) -> BitRate {
        BitRate::new(self.hub.bit_rate()).unwrap_or(self.hub.options.bit_rate)
    }

    /// Switches the bus to `rate` (LSS activate bit timing), from the next
    /// frame on.
    pub fn set_bit_rate(&self, rate: BitRate) {
        self.hub.bit_rate.store(rate.bps(), Ordering::Relaxed);
    }

    /// Disconnects every client and stops the server.
    pub fn shutdown(mut self) {
        self.stop_and_join();
    }

    fn stop_and_join(&mut self) {
        self.hub.stop.store(true, Ordering::SeqCst);
        self.hub.app_credit.close();
        for c in lock(&self.hub.clients).drain(..) {
            c.close();
            let _ = c.stream.shutdown(Shutdown::Both);
        }
        let _ = self.wire_events.send(WireEvent::Stop);
        // Wake the blocking accept; failure means it is not waiting.
        let _ = TcpStream::connect(self.local_addr);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

impl Drop for SlcanServer {
    fn drop(&mut self) {
        self.stop_and_join();
    }
}

fn accept_clients(listener: &TcpListener, hub: &Arc<Hub>, events: &Sender<WireEvent>) {
    let mut next_id = 0;
    for conn in listener.incoming() {
        if hub.stopping() {
            return;
        }
        let Ok(stream) = conn else { continue };
        if lock(&hub.clients).len() >= hub.options.max_clients {
            hub.refused.fetch_add(1, Ordering::Relaxed);
            continue;
        }
        let _ = stream.set_nodelay(true);
        let (Ok(peer), Ok(reader), Ok(writer)) = (stream.peer_addr(), stream.try_clone(), stream.try_clone()) else { continue };
        let _ = writer.set_write_timeout(Some(WRITE_POLL));
        next_id += 1;
        let client = Arc::new(Client {
            id: next_id,
            peer,
            stream,
            adapter: Mutex::new(SlcanAdapter::new()),
            outbox: Outbox::new(hub.options.client_queue_bytes),
            credit: Credit::new(hub.options.client_tx_frames),
        });
        lock(&hub.clients).push(Arc::clone(&client));
        let (client_hub, client_events) = (Arc::clone(hub), events.clone());
        let serving = Arc::clone(&client);
        let spawned = std::thread::Builder::new()
            .name(format!("slcan-client-{peer}"))
            .spawn(move || serve_client(&serving, reader, writer, &client_hub, &client_events));
        if spawned.is_err() {
            // Without its thread nobody serves the connection: close it.
            forget(hub, &client);
        }
    }
}

/// Takes a client off the bus and closes its connection.
fn forget(hub: &Hub, client: &Client) {
    lock(&hub.clients).retain(|c| c.id != client.id);
    client.close();
}

/// Serves one client until it disconnects (or the server stops).
fn serve_client(client: &Arc<Client>, reader: TcpStream, writer: TcpStream, hub: &Hub, events: &Sender<WireEvent>) {
    let writing = Arc::clone(client);
    let writer = std::thread::Builder::new().name(format!("slcan-write-{}", client.peer)).spawn(move || write_client(&writing, writer));
    if writer.is_ok() {
        read_client(client, reader, events);
    }
    forget(hub, client);
    if let Ok(w) = writer {
        let _ = w.join();
    }
    let _ = client.stream.shutdown(Shutdown::Both);
}

/// Reads the client's commands until it disconnects: answers go to its
/// outbox, accepted frames to the wire.
fn read_client(client: &Arc<Client>, mut reader: TcpStream, events: &Sender<WireEvent>) {
    let mut buf = [0u8; 512];
    let (mut reply, mut frames) = (Vec::new(), Vec::new());
    loop {
        let n = match reader.read(&mut buf) {
            Ok(0) => return,
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(_) => return,
        };
        let mut adapter = lock(&client.adapter);
        adapter.receive(buf.get(..n).unwrap_or(&[]), &mut reply, &mut frames);
        // Queued before the adapter is let go: a frame broadcast meanwhile
        // must not overtake the answer to the "O" that opened the channel
        // for it. Only a client far behind waits, without the lock.
        let queued = reply.is_empty() || client.outbox.try_push_reply(&reply);
        drop(adapter);
        if !queued && !client.outbox.push_reply(&reply) {
            return;
        }
        reply.clear();
        for f in frames.drain(..) {
            if !client.credit.take() || events.send(WireEvent::Client(Arc::clone(client), f)).is_err() {
                return;
            }
        }
    }
}

/// Writes the client's outbox to it until the outbox is closed and empty,
/// or the client is gone; a client that does not read is given up on only
/// once its connection is being closed.
fn write_client(client: &Client, mut stream: TcpStream) {
    let mut buf = Vec::new();
    while client.outbox.take(&mut buf) {
        let mut rest = buf.as_slice();
        while !rest.is_empty() {
            match stream.write(rest) {
                Ok(0) => return client.close(),
                Ok(n) => rest = rest.get(n..).unwrap_or(&[]),
                Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut | io::ErrorKind::Interrupted) => {
                    if client.credit.is_closed() {
                        return;
                    }
                }
                Err(_) => return client.close(),
            }
        }
    }
}
