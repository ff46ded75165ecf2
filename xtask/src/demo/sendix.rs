//! `cargo xtask demo --device sendix [--connect HOST:PORT]`: the Kübler
//! Sendix encoder image (CiA 406) in QEMU, driven the way a PLC reads an
//! encoder, with the live decoded trace: identity, the position and speed
//! of the image's turning shaft by SDO, the §5.7.2 scaling and a preset,
//! TPDO1 on the cyclic timer 0x6200, TPDO2 on SYNC, TPDO3 with the speed,
//! the mapping locked in Operational; then a summary.
//!
//! Without `--connect` it builds `sendix-qemu` and ends QEMU with the exit
//! frame (exit code 0); with `--connect` it drives a running node
//! (`vnode --device sendix --node-id 63`) and leaves it running. Every step
//! checks the node's answer, so the demo fails if the encoder does not
//! behave as its manual says.

use std::sync::Mutex;
use std::time::{Duration, Instant};

use canopen_core::od::Dictionary;
use canopen_core::wire::pdo_mapping::MappingEntry;
use embedded_can::Frame;
use firmware::devices::sendix;
use hal_host::decode::{Decoder, EXIT_ID, ObjectNames};
use hal_host::live::{Direction, LiveMaster, LoggedFrame};
use hal_host::master::SdoClientError;
use hal_host::slcan_client::SlcanClient;

use super::{BOOT_WAIT_CONNECTED, Style, WAIT, describe, no_boot_up, trace_line};

const DICT: &Dictionary = &sendix::od::DICTIONARY;
/// The encoder's node-id when nothing is configured (manual quick start).
const NODE: u8 = 0x3F;
/// Cyclic timer 0x6200 the demo sets (TPDO1 period), in ms.
const CYCLE_MS: u16 = 100;
/// TPDO3 (speed) event timer the demo sets, in ms.
const SPEED_MS: u16 = 500;
/// The image's shaft: 30 rpm (firmware::devices::sendix::Shaft).
const RPM: i32 = 30;

/// `cargo xtask demo --device sendix`.
pub fn demo(connect: Option<String>, wall: Instant) -> Result<(), String> {
    let Some(addr) = connect else { return with_qemu(wall) };
    let mut run = Run::start(&addr, false)?;
    let script = run.script();
    script.and(run.summary(None, wall))
}

fn with_qemu(wall: Instant) -> Result<(), String> {
    super::qemu::in_qemu("sendix", |addr, child| {
        Run::start(addr, true).and_then(|mut run| {
            let script = run.script();
            let exit = run.exit_qemu(child);
            let summary = run.summary(exit.as_ref().ok().copied(), wall);
            script.and(exit.map(|_| ())).and(summary)
        })
    })
}

/// The demo in progress.
struct Run {
    m: LiveMaster,
    qemu: bool,
    style: Style,
    checks: u32,
    failures: Vec<String>,
}

/// How far position `b` is ahead of `a` on the clockwise shaft (modulo 2^32).
fn ahead(a: u32, b: u32) -> u32 {
    b.wrapping_sub(a)
}

fn le_u32(v: &[u8]) -> u32 {
    let mut b = [0u8; 4];
    for (d, s) in b.iter_mut().zip(v) {
        *d = *s;
    }
    u32::from_le_bytes(b)
}

impl Run {
    fn start(addr: &str, qemu: bool) -> Result<Run, String> {
        let mut image = vec![0u8; DICT.defaults.len];
        DICT.reset_application(&mut image, NODE);
        DICT.reset_communication(&mut image, NODE);
        let mut decoder = Decoder::new(Some(ObjectNames::new(DICT, &sendix::od::NAMES)));
        for n in 0..3u16 {
            let count = DICT.read_u32(&image, 0x1A00 + n, 0).unwrap_or(0) as u8;
            let mapping: Vec<MappingEntry> =
                (1..=count).filter_map(|s| DICT.read_u32(&image, 0x1A00 + n, s)).map(MappingEntry::from_u32).collect();
            let cob_id = (DICT.read_u32(&image, 0x1800 + n, 1).unwrap_or(0) & 0x7FF) as u16;
            decoder.add_pdo(cob_id, &format!("TPDO{} node {NODE}", n + 1), &mapping);
        }
        let style = Style { on: std::io::IsTerminal::is_terminal(&std::io::stdout()) };
        let observer = Box::new(move |l: &LoggedFrame| println!("{}", trace_line(l, &decoder.decode(&l.frame), style)));
        let client = SlcanClient::connect(addr, Duration::from_secs(10)).map_err(|e| format!("{addr}: {e}"))?;
        let m = LiveMaster::open(client, observer, Duration::from_secs(5)).map_err(|e| format!("opening the SLCAN channel: {e}"))?;
        let header = format!(
            "{:>8}  {:<2}  {:>8}  {:<3}  {:<23}  meaning (node {NODE}, names from the sendix EDS)",
            "time s", "", "COB-ID", "len", "data"
        );
        println!("{}", style.paint("1", &header));
        Ok(Run { m, qemu, style, checks: 0, failures: Vec::new() })
    }

    fn step(&self, title: &str) {
        println!("{}", self.style.paint("1;34", &format!("-- {title}")));
    }

    fn check(&mut self, ok: bool, what: &str) {
        self.checks += 1;
        let mark = if ok { self.style.paint("32", "ok") } else { self.style.paint("1;31", "FAILED") };
        println!("   {mark} {what}");
        if !ok {
            self.failures.push(what.to_owned());
        }
    }

    fn io<T>(r: std::io::Result<T>) -> Result<T, String> {
        r.map_err(|e| format!("SLCAN connection: {e}"))
    }

    fn upload(&mut self, index: u16, sub: u8) -> Result<Result<Vec<u8>, SdoClientError>, String> {
        Self::io(self.m.sdo_upload(NODE, index, sub))
    }

    fn read_u32(&mut self, index: u16, sub: u8) -> Result<u32, String> {
        match self.upload(index, sub)? {
            Ok(v) => Ok(le_u32(&v)),
            Err(e) => {
                self.check(false, &format!("0x{index:04X}:{sub:02X} read: {}", describe(&e)));
                Ok(0)
            }
        }
    }

    fn download(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), String> {
        let r = Self::io(self.m.sdo_download(NODE, index, sub, data))?;
        let why = r.map_or_else(|e| format!(": {}", describe(&e)), |()| String::new());
        self.check(why.is_empty(), &format!("SDO download 0x{index:04X}:{sub:02X} accepted{why}"));
        Ok(())
    }

    fn frames_since(&self, since: usize, cob_id: u16) -> Vec<Vec<u8>> {
        let log = self.m.log().get(since..).unwrap_or(&[]);
        log.iter()
            .filter(|l| l.direction == Direction::Received && l.frame.cob_id() == Some(cob_id))
            .map(|l| l.frame.data().to_vec())
            .collect()
    }

    fn wait_frames(&mut self, since: usize, cob_id: u16, n: usize) -> Result<Vec<Vec<u8>>, String> {
        let deadline = Instant::now() + WAIT;
        while self.frames_since(since, cob_id).len() < n && Instant::now() < deadline {
            Self::io(self.m.recv_until(deadline))?;
        }
        Ok(self.frames_since(since, cob_id))
    }

    fn script(&mut self) -> Result<(), String> {
        let boot_id = 0x700 + u16::from(NODE);
        self.step("1. Boot-up");
        if !self.qemu {
            Self::io(self.m.send_std(0x000, &[0x82, NODE]))?;
        }
        let wait = if self.qemu { WAIT } else { BOOT_WAIT_CONNECTED };
        let boot = Self::io(self.m.wait_for(0, wait, |f| f.cob_id() == Some(boot_id)))?;
        self.check(boot.is_some_and(|f| f.data() == [0x00]), &format!("node {NODE} announces its boot-up (0x{boot_id:03X} [00])"));
        if boot.is_none() {
            return Err(no_boot_up(NODE, !self.qemu));
        }

        self.step("2. Identity: device type of the M5868 column, the encoder's name (segmented upload)");
        let device_type = self.read_u32(0x1000, 0)?;
        self.check(device_type == 0x000B_0196, &format!("0x1000 = 0x{device_type:08X} (0x000B0196)"));
        let name = self.upload(0x1008, 0)?;
        self.check(name.as_deref() == Ok(b"Kuebler Sendix Encoder".as_slice()), "0x1008 = \"Kuebler Sendix Encoder\"");

        self.step(&format!("3. The shaft turns ({RPM} rpm): position 0x6004 and speed 0x6030 by SDO"));
        let first = self.read_u32(0x6004, 0)?;
        Self::io(self.m.idle(Duration::from_millis(300)))?;
        let second = self.read_u32(0x6004, 0)?;
        self.check(ahead(first, second) > 0 && ahead(first, second) < 1 << 24, &format!("the position moved forward: {first} -> {second}"));
        let speed = self.read_u32(0x6030, 1)? as i32;
        self.check((RPM - 1..=RPM + 1).contains(&speed), &format!("0x6030:01 = {speed} rpm"));

        self.step("4. Scaling as §5.7.2 (TMR 36000, MUR 3600), then a preset of 1000");
        self.download(0x6002, 0, &36000u32.to_le_bytes())?;
        self.download(0x6001, 0, &3600u32.to_le_bytes())?;
        self.download(0x6000, 0, &0x0004u16.to_le_bytes())?;
        let scaled = self.read_u32(0x6004, 0)?;
        self.check(scaled < 36000, &format!("the position is within the range: {scaled}"));
        let refused = Self::io(self.m.sdo_download(NODE, 0x6002, 0, &0x800u32.to_le_bytes()))?;
        self.check(
            matches!(refused, Err(SdoClientError::ServerAbort { code: 0x0604_0043, .. })),
            "TMR 0x800 < MUR refused with 0x06040043, the old TMR kept",
        );
        self.download(0x6003, 0, &1000u32.to_le_bytes())?;
        let preset = self.read_u32(0x6004, 0)?;
        self.check(ahead(1000, preset) < 3600, &format!("the position is the preset at once: {preset}"));

        self.step(&format!("5. NMT start: TPDO1 on the cyclic timer 0x6200 = {CYCLE_MS} ms, TPDO3 (speed) every {SPEED_MS} ms"));
        self.download(0x6200, 0, &CYCLE_MS.to_le_bytes())?;
        let timer = self.upload(0x1800, 5)?;
        self.check(timer.as_deref() == Ok(CYCLE_MS.to_le_bytes().as_slice()), "0x1800:05 is the same value");
        self.download(0x1802, 5, &SPEED_MS.to_le_bytes())?;
        let mark = self.m.mark();
        Self::io(self.m.send_std(0x000, &[0x01, NODE]))?;
        let tpdo1 = self.wait_frames(mark, 0x180 + u16::from(NODE), 4)?;
        let positions: Vec<u32> = tpdo1.iter().map(|d| le_u32(d)).collect();
        let forward = positions.windows(2).all(|w| w[0] < 36000 && w[1] < 36000 && ahead(w[0], w[1]) % 36000 < 3600);
        self.check(positions.len() >= 4 && forward, &format!("TPDO1 positions move on: {positions:?}"));
        let tpdo3 = self.wait_frames(mark, 0x380 + u16::from(NODE), 1)?;
        let v = tpdo3.first().map(|d| le_u32(d) as i32);
        self.check(v.is_some_and(|v| (RPM - 1..=RPM + 1).contains(&v)), &format!("TPDO3 speed {v:?} rpm"));

        self.step("6. SYNC: TPDO2 carries the position sampled at each SYNC");
        let mark = self.m.mark();
        for _ in 0..3 {
            Self::io(self.m.send_std(0x080, &[]))?;
            Self::io(self.m.idle(Duration::from_millis(100)))?;
        }
        let tpdo2 = self.wait_frames(mark, 0x280 + u16::from(NODE), 3)?;
        self.check(tpdo2.len() == 3, &format!("one TPDO2 per SYNC: {} for 3", tpdo2.len()));

        self.step("7. Mapping only in Pre-operational (§5.3.4.1)");
        let locked = Self::io(self.m.sdo_download(NODE, 0x1A00, 0, &[0]))?;
        self.check(matches!(locked, Err(SdoClientError::ServerAbort { code: 0x0800_0022, .. })), "0x1A00 in Operational: abort 0x08000022");
        let mark = self.m.mark();
        Self::io(self.m.send_std(0x000, &[0x80, NODE]))?;
        Self::io(self.m.idle(Duration::from_millis(u64::from(CYCLE_MS) * 3)))?;
        let after = self.frames_since(mark + 1, 0x180 + u16::from(NODE)).len();
        self.check(after <= 1, &format!("no TPDO1 in Pre-operational ({after} in flight at the switch)"));
        Ok(())
    }

    fn exit_qemu(&mut self, child: &Mutex<std::process::Child>) -> Result<i32, String> {
        self.step("8. Exit frame: QEMU ends through semihosting");
        let frame = canopen_core::frame::CanFrame::extended(EXIT_ID, b"EXIT\x00").ok_or("exit frame")?;
        Self::io(self.m.send(frame))?;
        let deadline = Instant::now() + Duration::from_secs(5);
        loop {
            let status = child.lock().unwrap_or_else(std::sync::PoisonError::into_inner).try_wait().map_err(|e| e.to_string())?;
            if let Some(status) = status {
                let code = status.code().unwrap_or(-1);
                self.check(code == 0, &format!("QEMU exit code {code}"));
                return Ok(code);
            }
            if Instant::now() > deadline {
                self.check(false, "QEMU exits within 5 s of the exit frame");
                return Ok(-1);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn summary(&mut self, qemu_exit: Option<i32>, wall: Instant) -> Result<(), String> {
        self.step("Summary");
        let log = self.m.log();
        let received = log.iter().filter(|l| l.direction == Direction::Received).count();
        let pdos = log
            .iter()
            .filter(|l| l.direction == Direction::Received && l.frame.cob_id().is_some_and(|c| (0x181..0x580).contains(&c)))
            .count();
        println!("   frames: {} sent by the PLC, {received} by the encoder ({pdos} PDOs)", log.len() - received);
        if let Some(code) = qemu_exit {
            println!("   QEMU exit code: {code}");
        }
        println!("   wall time: {:.2} s", wall.elapsed().as_secs_f64());
        let failed = self.failures.len();
        println!("   checks: {} passed, {failed} failed", self.checks as usize - failed);
        if failed == 0 { Ok(()) } else { Err(format!("demo: {failed} check(s) failed:\n  {}", self.failures.join("\n  "))) }
    }
}
