//! `vnode`: one device node running in real time on a virtual bus served
//! as SLCAN over TCP, so python-can (`interface="slcan"`,
//! `channel="socket://127.0.0.1:PORT"`) and python-canopen can drive it.
//!
//! ```text
//! vnode --device ec5000 --node-id 5 --listen 127.0.0.1:4557 [--storage FILE] [--trace [FILE]]
//! vnode --eds FILE --node-id 5 [...]
//! vnode --list
//! ```
//!
//! `--eds` runs any EDS or DCF with the CiA 301/305 services and no device
//! hooks: the file is read and checked by od-gen when vnode starts, and its
//! errors come out as `file:line: error: ...` (exit status 1).
//!
//! Every client is an adapter on the same bus ([`SlcanServer`]): it sees
//! the node's frames and the other clients' frames. The node handles each
//! frame it receives and hands out what that queued before it takes the
//! next. The first line on stdout names the port; everything else vnode
//! has to say (clients coming and going, frames dropped for a client that
//! does not read, bit-rate switches) goes to stderr, at most once a second
//! per subject, and a closed stdout or stderr never stops the node.

use std::collections::BTreeMap;
use std::io::Write;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::mpsc::{RecvTimeoutError, TrySendError};
use std::time::{Duration as StdDuration, SystemTime, UNIX_EPOCH};

use canopen_core::node::{Application, NoApplication, Node, SDO_SERVERS};
use canopen_core::od::{Dictionary, ObjectDictionary};
use canopen_core::storage::Storage;
use canopen_core::time::Instant;
use clap::Parser;
use firmware::devices::{self, agile, bmaxx4400, ec5000, sendix, unitek_ds};
use hal_host::bus::BitRate;
use hal_host::slcan::{ServerOptions, SlcanServer};
use hal_host::storage::{FileStorage, MemStorage};
use hal_host::trace::BackgroundLog;
use od_gen::runtime::RuntimeRam;

/// Bytes per storage region: room for the largest device image.
const REGION: usize = 4096;
/// Trace lines that may wait for the trace writer before lines are dropped.
const TRACE_QUEUE: usize = 4096;
/// How often vnode looks at its clients and its trace to report on them.
const REPORT_EVERY: StdDuration = StdDuration::from_secs(1);
/// The interface name in trace lines.
const TRACE_IFACE: &str = "can0";
/// The node-id of a node that LSS has yet to configure (CiA 305).
const UNCONFIGURED: u8 = 255;
/// How long a reset the node was asked for (NMT reset node or reset
/// communication, a restart through an object, an LSS switch that resets)
/// keeps it off the bus before it runs and sends its boot-up, as a board
/// restarting does. Without it the boot-up came 10-300 us after the NMT
/// command, and python-canopen's `send_command(0x81)` then
/// `wait_for_bootup()`, which only sees a boot-up that arrives once it waits,
/// missed it about one time in three.
const RESTART_TIME: StdDuration = StdDuration::from_millis(20);
/// The device names `--device` takes: the firmware's devices and the interop test fixture.
const DEVICES: [&str; 6] = ["ec5000", "unitek-ds", "sendix", "bmaxx4400", "agile", "interop"];

/// One CANopen device node on a virtual bus, served as SLCAN over TCP.
#[derive(Parser)]
#[command(
    name = "vnode",
    version,
    after_help = "Every SLCAN client is an adapter on the same bus. The first line on stdout names the port."
)]
struct Cli {
    /// The device to run (`--list` names them).
    #[arg(long, value_name = "NAME", required_unless_present_any = ["list", "eds"], value_parser = DEVICES)]
    device: Option<String>,
    /// Run the dictionary of this EDS or DCF, without device hooks, instead of a device.
    #[arg(long, value_name = "FILE", conflicts_with = "device")]
    eds: Option<PathBuf>,
    /// The node-id: 1..=127, or 255 for an LSS-unconfigured node (decimal or 0x-hex).
    #[arg(long, value_name = "N", required_unless_present = "list", value_parser = node_id)]
    node_id: Option<u8>,
    /// Where to serve SLCAN over TCP (port 0: a free port).
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:0", value_parser = listen_addr)]
    listen: String,
    /// The identity serial number (0x1018:4, LSS), decimal or 0x-hex.
    #[arg(long, value_name = "N", value_parser = serial)]
    serial: Option<u32>,
    /// Keep the node's stored parameters in FILE (created if missing).
    #[arg(long, value_name = "FILE")]
    storage: Option<PathBuf>,
    /// Log every frame on the bus in candump's log format to FILE (no FILE, or `-`: stdout).
    #[arg(long, value_name = "FILE", num_args = 0..=1, default_missing_value = "-")]
    trace: Option<PathBuf>,
    /// The bus's bit rate in kbit/s, until LSS switches it (a rate stored in the node comes first).
    #[arg(long, value_name = "KBIT", default_value_t = 1000, value_parser = bitrate_kbit)]
    bitrate: u32,
    /// List the devices and exit.
    #[arg(long, exclusive = true)]
    list: bool,
}

/// A number in decimal or `0x`/`0X` hex, as `--serial` and `--node-id` take it.
fn number(s: &str) -> Result<u64, std::num::ParseIntError> {
    match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(hex) => u64::from_str_radix(hex, 16),
        None => s.parse(),
    }
}

fn node_id(s: &str) -> Result<u8, String> {
    match number(s).map(u8::try_from) {
        Ok(Ok(id @ (1..=127 | 255))) => Ok(id),
        _ => Err("must be 1..=127, or 255 for an unconfigured node".into()),
    }
}

/// A `HOST:PORT` that names an address: one that does not is a usage
/// error (exit 2), one that names an address vnode cannot bind is not (1).
fn listen_addr(s: &str) -> Result<String, String> {
    use std::net::ToSocketAddrs;
    match s.to_socket_addrs().map(|mut addrs| addrs.next()) {
        Ok(Some(_)) => Ok(s.to_owned()),
        Ok(None) => Err("names no address".into()),
        Err(e) => Err(format!("not HOST:PORT, e.g. 127.0.0.1:4557 ({e})")),
    }
}

fn serial(s: &str) -> Result<u32, String> {
    let too_big = |_| "not a 32-bit number (over 0xFFFFFFFF)".to_owned();
    number(s).map_err(|e| format!("not a 32-bit number ({e})")).and_then(|v| u32::try_from(v).map_err(too_big))
}

fn bitrate_kbit(s: &str) -> Result<u32, String> {
    const RATES: [u32; 9] = [10, 20, 50, 100, 125, 250, 500, 800, 1000];
    s.parse().ok().filter(|k| RATES.contains(k)).ok_or_else(|| format!("must be one of {RATES:?}"))
}

/// Writes a line to stderr; a closed stderr is not vnode's problem.
fn note(msg: std::fmt::Arguments<'_>) {
    let _ = writeln!(std::io::stderr().lock(), "vnode: {msg}");
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let (Some(device), Some(id)) = (cli.device.clone().or_else(|| cli.eds.as_ref().map(|_| String::new())), cli.node_id) else {
        let mut out = std::io::stdout().lock();
        for d in &devices::ALL {
            let _ = writeln!(out, "{:<10} {}", d.name, d.description);
        }
        let _ = writeln!(out, "interop    test fixture, not a device: tests/eds/interop.eds (every SDO transfer size, 4+4 PDOs)");
        return ExitCode::SUCCESS;
    };
    let storage: Box<dyn Storage> = match &cli.storage {
        Some(path) => match FileStorage::open(path, REGION) {
            Ok(s) => Box::new(s),
            Err(e) => {
                note(format_args!("{}: {e}", path.display()));
                return ExitCode::FAILURE;
            }
        },
        None => Box::new(MemStorage::new(REGION)),
    };
    let result = match device.as_str() {
        "" => match cli.eds.as_deref().map(load_eds) {
            Some(Ok(dictionary)) => serve_eds(dictionary, id, storage, &cli),
            Some(Err((diagnostics, status))) => {
                let _ = write!(std::io::stderr().lock(), "{diagnostics}");
                return status;
            }
            None => Err("no device".into()),
        },
        "ec5000" => serve::<
            _,
            _,
            { ec5000::od::RPDO_COUNT },
            { ec5000::od::TPDO_COUNT },
            { ec5000::od::HB_CONSUMER_COUNT },
            { ec5000::od::SDO_SERVERS },
        >(ec5000::od::Ram::new(id), ec5000::App::NEW, storage, &cli),
        "unitek-ds" => serve::<
            _,
            _,
            { unitek_ds::od::RPDO_COUNT },
            { unitek_ds::od::TPDO_COUNT },
            { unitek_ds::od::HB_CONSUMER_COUNT },
            { unitek_ds::od::SDO_SERVERS },
        >(unitek_ds::od::Ram::new(id), unitek_ds::App::NEW, storage, &cli),
        "sendix" => serve::<
            _,
            _,
            { sendix::od::RPDO_COUNT },
            { sendix::od::TPDO_COUNT },
            { sendix::od::HB_CONSUMER_COUNT },
            { sendix::od::SDO_SERVERS },
        >(sendix::od::Ram::new(id), sendix::App::NEW, storage, &cli),
        "bmaxx4400" => serve::<
            _,
            _,
            { bmaxx4400::od::RPDO_COUNT },
            { bmaxx4400::od::TPDO_COUNT },
            { bmaxx4400::od::HB_CONSUMER_COUNT },
            { bmaxx4400::od::SDO_SERVERS },
        >(bmaxx4400::od::Ram::new(id), bmaxx4400::App::NEW, storage, &cli),
        "agile" => {
            serve::<_, _, { agile::od::RPDO_COUNT }, { agile::od::TPDO_COUNT }, { agile::od::HB_CONSUMER_COUNT }, { agile::od::SDO_SERVERS }>(
                agile::od::Ram::new(id),
                agile::App::NEW,
                storage,
                &cli,
            )
        }
        _ => {
            use hal_host::fixtures::interop::od as fx;
            serve::<_, _, { fx::RPDO_COUNT }, { fx::TPDO_COUNT }, { fx::HB_CONSUMER_COUNT }, { fx::SDO_SERVERS }>(
                fx::Ram::new(id),
                NoApplication,
                storage,
                &cli,
            )
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            note(format_args!("{e}"));
            ExitCode::FAILURE
        }
    }
}

/// Reads and checks an EDS as od-gen does (tolerant: warnings are shown,
/// errors stop vnode) and builds the core's dictionary from it. `Err` holds
/// the diagnostics, one `file:line: severity: message` per line, and the
/// exit status: 1 for a file with errors, 2 for one that cannot be read
/// (a wrong `--eds`, as od-gen has it).
fn load_eds(path: &std::path::Path) -> Result<&'static Dictionary, (String, ExitCode)> {
    let bytes = std::fs::read(path).map_err(|e| (format!("{}: error: {e}\n", path.display()), ExitCode::from(2)))?;
    let file = path.display().to_string();
    let (eds, diagnostics) = od_gen::load(&file, &bytes, od_gen::Options::default());
    if diagnostics.has_errors() {
        return Err((diagnostics.to_string(), ExitCode::FAILURE));
    }
    let _ = write!(std::io::stderr().lock(), "{diagnostics}");
    let tables = od_gen::runtime::Tables::new(&eds).map_err(|e| (format!("{file}: error: {}\n", e.0), ExitCode::FAILURE))?;
    Ok(tables.leak())
}

/// Runs a dictionary loaded at run time. The PDO and heartbeat-consumer
/// counts are compile-time parameters of the node, so it gets the smallest
/// of a few sizes that holds every PDO number and consumer the file has; a
/// PDO number without a record is an invalid PDO, as on a generated node.
fn serve_eds(dictionary: &'static Dictionary, id: u8, storage: Box<dyn Storage>, cli: &Cli) -> Result<(), String> {
    let extent = |first: u16, last: u16| {
        dictionary
            .entries
            .iter()
            .filter(|e| (first..=last).contains(&{ e.index }))
            .map(|e| usize::from(e.index - first) + 1)
            .max()
            .unwrap_or(0)
    };
    let pdos = extent(0x1400, 0x15FF).max(extent(0x1800, 0x19FF));
    // The SDO server count is no parameter here: servers past it stay off.
    if extent(0x1200, 0x127F) > SDO_SERVERS {
        note(format_args!(
            "{}: vnode serves the SDO servers 0x1200–0x{:04X}; those above stay off",
            cli.eds.as_deref().unwrap_or(std::path::Path::new("")).display(),
            0x11FF + SDO_SERVERS
        ));
    }
    let od = RuntimeRam::new(dictionary, id);
    match pdos {
        0..=4 => serve::<_, _, 4, 4, 127, SDO_SERVERS>(od, NoApplication, storage, cli),
        5..=16 => serve::<_, _, 16, 16, 127, SDO_SERVERS>(od, NoApplication, storage, cli),
        17..=64 => serve::<_, _, 64, 64, 127, SDO_SERVERS>(od, NoApplication, storage, cli),
        _ => serve::<_, _, 512, 512, 127, SDO_SERVERS>(od, NoApplication, storage, cli),
    }
}

/// Adapts the boxed storage to the node's `Storage` parameter.
struct Boxed(Box<dyn Storage>);

impl Storage for Boxed {
    fn region_size(&self) -> usize {
        self.0.region_size()
    }
    fn read(&mut self, region: u8, offset: usize, buf: &mut [u8]) -> Result<(), canopen_core::storage::StorageError> {
        self.0.read(region, offset, buf)
    }
    fn erase(&mut self, region: u8) -> Result<(), canopen_core::storage::StorageError> {
        self.0.erase(region)
    }
    fn write(&mut self, region: u8, offset: usize, data: &[u8]) -> Result<(), canopen_core::storage::StorageError> {
        self.0.write(region, offset, data)
    }
}

/// The node vnode runs: the device's dictionary with the device's own hooks
/// (`app`), as its image does, its storage, the node-id and serial number
/// from the command line.
fn new_node<O: ObjectDictionary, A: Application, const R: usize, const T: usize, const HB: usize, const SDO: usize>(
    od: O,
    app: A,
    storage: Box<dyn Storage>,
    cli: &Cli,
    now: Instant,
) -> Node<O, A, Boxed, R, T, HB, SDO> {
    let mut node = Node::new(od, app, Boxed(storage), cli.node_id.unwrap_or(255), now);
    if let Some(serial) = cli.serial {
        node.set_serial_number(serial);
    }
    node
}

/// Wall time since the Unix epoch, for trace lines.
fn wall_clock() -> Instant {
    Instant::from_micros(SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_micros() as u64))
}

fn open_trace(target: &std::path::Path) -> Result<BackgroundLog, String> {
    let out: Box<dyn Write + Send> = if target.as_os_str() == "-" {
        Box::new(std::io::stdout())
    } else {
        Box::new(std::fs::File::create(target).map_err(|e| format!("{}: {e}", target.display()))?)
    };
    BackgroundLog::spawn(out, TRACE_IFACE, TRACE_QUEUE).map_err(|e| format!("trace writer: {e}"))
}

/// Runs the device's dictionary with the device's own hooks (`app`), as its image does.
fn serve<O: ObjectDictionary, A: Application, const R: usize, const T: usize, const HB: usize, const SDO: usize>(
    od: O,
    app: A,
    storage: Box<dyn Storage>,
    cli: &Cli,
) -> Result<(), String> {
    // Without LSS nothing could give an unconfigured node its id: it would
    // never answer (CiA 305; the node-id 255 is LSS's "unconfigured").
    if cli.node_id == Some(UNCONFIGURED) && !(O::SERVICES.lss && od.dictionary().device.lss_supported) {
        return Err(format!(
            "--node-id {UNCONFIGURED} is an LSS-unconfigured node, and this device has no LSS (LSS_Supported=0): it would never answer; give 1..=127"
        ));
    }
    let start = std::time::Instant::now();
    let clock = || Instant::from_micros(start.elapsed().as_micros() as u64);
    let mut node: Node<O, A, Boxed, R, T, HB, SDO> = new_node(od, app, storage, cli, clock());
    // A bit rate the node keeps in its stored configuration is the bus's.
    let stored = node.bit_rate().and_then(BitRate::from_cia_index);
    let bit_rate = stored.or(BitRate::new(cli.bitrate * 1000)).unwrap_or(BitRate::MBIT_1);
    let options = ServerOptions { bit_rate, ..ServerOptions::default() };
    // The trace file first: a port line promises a node that runs.
    let mut trace = cli.trace.as_deref().map(open_trace).transpose()?;
    let (server, channels) = SlcanServer::bind_with(cli.listen.as_str(), options).map_err(|e| format!("{}: {e}", cli.listen))?;
    {
        // Test harnesses read this line to learn the port; they may close stdout afterwards.
        let mut out = std::io::stdout().lock();
        let device = match (&cli.device, &cli.eds) {
            (Some(device), _) => device.clone(),
            (None, Some(eds)) => eds.display().to_string(),
            (None, None) => String::new(),
        };
        let _ = writeln!(out, "vnode {device} node {} listening on {}", cli.node_id.unwrap_or(255), server.local_addr());
        let _ = out.flush();
    }
    let mut report = Reporter::default();
    // A frame the node sent that the wire had no room for yet.
    let mut held = None;
    // When a reset the node was asked for runs (RESTART_TIME after the request).
    let mut restart_at: Option<std::time::Instant> = None;
    loop {
        let now = clock();
        // What the node queued before the reset (the SDO answer to a restart
        // command) goes out first; frames that come meanwhile wait on the
        // wire's side, as on a board.
        let restarting =
            node.resetting() && std::time::Instant::now() < *restart_at.get_or_insert_with(|| std::time::Instant::now() + RESTART_TIME);
        let mut deadline = None;
        if !restarting {
            restart_at = None;
            // A reset runs a stage per call, all of them before the next frame.
            deadline = node.process(now);
            while node.resetting() {
                deadline = node.process(now);
            }
        }
        if let Some(index) = node.take_bit_rate_change() {
            match BitRate::from_cia_index(index) {
                Some(rate) => {
                    server.set_bit_rate(rate);
                    note(format_args!("bit rate switched to {} kbit/s (CiA 305 table index {index})", rate.bps() / 1000));
                }
                None => note(format_args!("LSS activate bit timing with table index {index}, which names no rate: bit rate unchanged")),
            }
        }
        // Everything the last frame or timer queued goes to the wire before
        // the next frame is taken, as long as the wire has room; what it has
        // no room for waits in the node's transmit queue, as on a board.
        while let Some(frame) = held.take().or_else(|| node.transmit()) {
            match channels.to_client.try_send(frame) {
                Ok(()) => {
                    if let Some(t) = trace.as_mut() {
                        t.record(wall_clock(), &frame);
                    }
                }
                Err(TrySendError::Full(frame)) => {
                    held = Some(frame);
                    break;
                }
                Err(TrySendError::Disconnected(_)) => return Ok(()),
            }
        }
        report.tick(&server, trace.as_ref());
        // Sleep until the next deadline or frame, at most 50 ms so reports
        // keep coming, and 1 ms while a frame waits for room on the wire.
        let longest = if held.is_some() { StdDuration::from_millis(1) } else { StdDuration::from_millis(50) };
        let wait = deadline.map_or(longest, |d| StdDuration::from_micros(d.as_micros().saturating_sub(clock().as_micros())).min(longest));
        // No frame is taken while one of the node's waits for the wire: on
        // a bus its answers go out between the requests (0x585 wins over
        // 0x605), so a node the OS ran late must not meet a backlog of
        // requests that no wire could have carried without its answers.
        // Taking them would fill its transmit queue, and an SDO server
        // replaces an unsent answer by the next one (its client has moved
        // on): answers lost without trace. The requests wait on the wire's
        // side instead, and TCP holds the clients back.
        if held.is_some() || restarting {
            let until_restart = restart_at.filter(|_| restarting).map(|t| t.saturating_duration_since(std::time::Instant::now()));
            std::thread::sleep(until_restart.map_or(wait, |r| r.min(wait)));
            continue;
        }
        match channels.from_client.recv_timeout(wait) {
            Ok(frame) => {
                if let Some(t) = trace.as_mut() {
                    t.record(wall_clock(), &frame);
                }
                node.on_frame(clock(), &frame);
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => return Ok(()),
        }
    }
}

/// What vnode last told about its clients and its trace.
#[derive(Default)]
struct Reporter {
    last: Option<std::time::Instant>,
    clients: BTreeMap<SocketAddr, u64>,
    refused: u64,
    trace_dropped: u64,
    trace_failed: bool,
}

impl Reporter {
    /// Reports, at most once per [`REPORT_EVERY`], clients that came or
    /// went, frames dropped for a client that does not read, refused
    /// connections and trace lines dropped.
    fn tick(&mut self, server: &SlcanServer, trace: Option<&BackgroundLog>) {
        if self.last.is_some_and(|t| t.elapsed() < REPORT_EVERY) {
            return;
        }
        self.last = Some(std::time::Instant::now());
        let now: BTreeMap<SocketAddr, u64> = server.clients().iter().map(|c| (c.peer, c.dropped)).collect();
        for (peer, &dropped) in &now {
            match self.clients.get(peer) {
                None => note(format_args!("client {peer} connected ({} connected)", now.len())),
                Some(&before) if dropped > before => note(format_args!(
                    "client {peer} is not reading: {} frames dropped ({dropped} in all; the newest are dropped once {} KiB wait)",
                    dropped - before,
                    server.options().client_queue_bytes / 1024
                )),
                Some(_) => {}
            }
        }
        for (peer, dropped) in &self.clients {
            if !now.contains_key(peer) {
                note(format_args!("client {peer} disconnected ({dropped} frames dropped for it)"));
            }
        }
        self.clients = now;
        if server.refused() > self.refused {
            self.refused = server.refused();
            note(format_args!("{} connections refused in all: too many clients", self.refused));
        }
        if let Some(t) = trace {
            if t.dropped() > self.trace_dropped {
                note(format_args!("trace: {} lines dropped in all (the trace output is behind)", t.dropped()));
                self.trace_dropped = t.dropped();
            }
            if let (Some(e), false) = (t.error(), self.trace_failed) {
                note(format_args!("trace stopped: {e}"));
                self.trace_failed = true;
            }
        }
    }
}
