//! `vnode`: one device node running in real time, its CAN side served as
//! SLCAN over TCP, so python-can (`interface="slcan"`,
//! `channel="socket://127.0.0.1:PORT"`) and python-canopen can drive it.
//!
//! ```text
//! vnode --device ec5000 --node-id 5 --listen 127.0.0.1:4557 [--storage FILE]
//! vnode --list
//! ```

use std::process::ExitCode;
use std::sync::mpsc::RecvTimeoutError;
use std::time::Duration as StdDuration;

use canopen_core::node::{Application, NoApplication, Node};
use canopen_core::od::ObjectDictionary;
use canopen_core::storage::Storage;
use canopen_core::time::Instant;
use firmware::devices::{self, agile, bmaxx4400, ec5000, sendix, unitek_ds};
use hal_host::slcan::SlcanServer;
use hal_host::storage::{FileStorage, MemStorage};
use hal_host::trace::format_frame;

const USAGE: &str = "usage: vnode --device NAME --node-id N --listen ADDR [--serial N] [--storage FILE] [--trace]\n       vnode --list\n(--node-id 255: an LSS-unconfigured node)";

/// Bytes per storage region: room for the largest device image.
const REGION: usize = 4096;

struct Options {
    device: String,
    node_id: u8,
    listen: String,
    storage: Option<String>,
    serial: Option<u32>,
    trace: bool,
}

fn parse(args: &[String]) -> Result<Option<Options>, String> {
    let mut o = Options { device: String::new(), node_id: 0, listen: "127.0.0.1:0".into(), storage: None, serial: None, trace: false };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().cloned().ok_or_else(|| format!("{a} needs a value\n{USAGE}"));
        match a.as_str() {
            "--list" => return Ok(None),
            "--device" => o.device = value()?,
            "--node-id" => {
                let v = value()?;
                o.node_id = v.parse().map_err(|_| format!("--node-id {v}: not a number"))?;
            }
            "--listen" => o.listen = value()?,
            "--storage" => o.storage = Some(value()?),
            "--serial" => {
                let v = value()?;
                let parsed = match v.strip_prefix("0x") {
                    Some(hex) => u32::from_str_radix(hex, 16),
                    None => v.parse(),
                };
                o.serial = Some(parsed.map_err(|_| format!("--serial {v}: not a number"))?);
            }
            "--trace" => o.trace = true,
            other => return Err(format!("unknown argument {other}\n{USAGE}")),
        }
    }
    if o.device.is_empty() {
        return Err(USAGE.into());
    }
    if !(1..=127).contains(&o.node_id) && o.node_id != 255 {
        return Err(format!("--node-id must be 1..=127, or 255 for an unconfigured node\n{USAGE}"));
    }
    Ok(Some(o))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let opts = match parse(&args) {
        Ok(Some(o)) => o,
        Ok(None) => {
            for d in &devices::ALL {
                println!("{:<10} {}", d.name, d.description);
            }
            println!("interop    test fixture, not a device: tests/eds/interop.eds (every SDO transfer size, 4+4 PDOs)");
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    let storage: Box<dyn Storage> = match &opts.storage {
        Some(path) => match FileStorage::open(path, REGION) {
            Ok(s) => Box::new(s),
            Err(e) => {
                eprintln!("vnode: {path}: {e}");
                return ExitCode::FAILURE;
            }
        },
        None => Box::new(MemStorage::new(REGION)),
    };
    let id = opts.node_id;
    let result = match opts.device.as_str() {
        "ec5000" => serve::<_, _, { ec5000::od::RPDO_COUNT }, { ec5000::od::TPDO_COUNT }, { ec5000::od::HB_CONSUMER_COUNT }>(
            ec5000::od::Ram::new(id),
            ec5000::App::NEW,
            storage,
            &opts,
        ),
        "unitek-ds" => serve::<_, _, { unitek_ds::od::RPDO_COUNT }, { unitek_ds::od::TPDO_COUNT }, { unitek_ds::od::HB_CONSUMER_COUNT }>(
            unitek_ds::od::Ram::new(id),
            unitek_ds::App::NEW,
            storage,
            &opts,
        ),
        "sendix" => serve::<_, _, { sendix::od::RPDO_COUNT }, { sendix::od::TPDO_COUNT }, { sendix::od::HB_CONSUMER_COUNT }>(
            sendix::od::Ram::new(id),
            sendix::App::NEW,
            storage,
            &opts,
        ),
        "bmaxx4400" => serve::<_, _, { bmaxx4400::od::RPDO_COUNT }, { bmaxx4400::od::TPDO_COUNT }, { bmaxx4400::od::HB_CONSUMER_COUNT }>(
            bmaxx4400::od::Ram::new(id),
            bmaxx4400::App::NEW,
            storage,
            &opts,
        ),
        "interop" => {
            use hal_host::fixtures::interop::od as fx;
            serve::<_, _, { fx::RPDO_COUNT }, { fx::TPDO_COUNT }, { fx::HB_CONSUMER_COUNT }>(
                fx::Ram::new(id),
                NoApplication,
                storage,
                &opts,
            )
        }
        "agile" => serve::<_, _, { agile::od::RPDO_COUNT }, { agile::od::TPDO_COUNT }, { agile::od::HB_CONSUMER_COUNT }>(
            agile::od::Ram::new(id),
            agile::App::NEW,
            storage,
            &opts,
        ),
        other => Err(format!("unknown device {other}; `vnode --list` names them")),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("vnode: {e}");
            ExitCode::FAILURE
        }
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

/// Runs the device's dictionary with the device's own hooks (`app`), as its image does.
fn serve<O: ObjectDictionary, A: Application, const R: usize, const T: usize, const HB: usize>(
    od: O,
    app: A,
    storage: Box<dyn Storage>,
    opts: &Options,
) -> Result<(), String> {
    let (server, channels) = SlcanServer::bind(opts.listen.as_str()).map_err(|e| format!("{}: {e}", opts.listen))?;
    // Test harnesses read this line to learn the port.
    println!("vnode {} node {} listening on {}", opts.device, opts.node_id, server.local_addr());
    let start = std::time::Instant::now();
    let clock = || Instant::from_micros(start.elapsed().as_micros() as u64);
    let mut node: Node<O, A, Boxed, R, T, HB> = Node::new(od, app, Boxed(storage), opts.node_id, clock());
    if let Some(serial) = opts.serial {
        node.set_serial_number(serial);
    }
    loop {
        let now = clock();
        let deadline = node.process(now);
        if let Some(index) = node.take_bit_rate_change() {
            // SLCAN has no way to tell the client; the virtual wire carries every rate.
            println!("bit rate switched to CiA 305 table index {index}");
        }
        while let Some(frame) = node.transmit() {
            if opts.trace {
                println!("tx {}", format_frame(&frame));
            }
            if channels.to_client.send(frame).is_err() {
                return Ok(());
            }
        }
        // Sleep until the next deadline or frame, at most 50 ms so a dropped client is noticed.
        let wait = deadline.map_or(StdDuration::from_millis(50), |d| {
            StdDuration::from_micros(d.as_micros().saturating_sub(clock().as_micros())).min(StdDuration::from_millis(50))
        });
        match channels.from_client.recv_timeout(wait) {
            Ok(frame) => {
                if opts.trace {
                    println!("rx {}", format_frame(&frame));
                }
                node.on_frame(clock(), &frame);
                // Each frame is followed by `process`, as on a board: a reset
                // sends its boot-up before the next frame is looked at.
                while let Ok(frame) = channels.from_client.try_recv() {
                    node.process(clock());
                    node.on_frame(clock(), &frame);
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => return Ok(()),
        }
    }
}
