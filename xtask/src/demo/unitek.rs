//! `cargo xtask demo --device unitek-ds [--connect HOST:PORT]`: the UNITEK DS
//! servo image in QEMU (or `vnode --device unitek-ds`), driven the way the
//! manual's examples drive it (Ex. 11 and 12), with the live trace of every
//! frame decoded by register name (docs/devices/unitek-ds.md).
//!
//! The drive is no CANopen node: the script first shows it stays silent to
//! NMT and SDO, then reads, enables, runs at 10 % speed with a cyclic read of
//! the position, homes, positions with an event-driven STATUS, and disables.
//! Every step is checked; a failed check fails the demo.

use std::process::Child;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use embedded_can::Frame;
use firmware::devices::unitek_ds::od;
use firmware::devices::unitek_ds::wire::Reply;
use hal_host::decode::{Decoder, ObjectNames};
use hal_host::live::{Direction, LiveMaster, LoggedFrame};
use hal_host::slcan_client::SlcanClient;

use super::{Style, WAIT, in_qemu, send_exit, trace_line};

/// The drive's identifiers (registers 0x68 and 0x69 at their defaults).
const RX: u16 = 0x201;
const TX: u16 = 0x181;
/// The longest wait for motion: QEMU's instruction-counted clock runs the
/// 1 kHz drive ticks 2-15 times slower than real time, depending on the host's load.
const SLOW_WAIT: Duration = Duration::from_secs(30);
/// Increments per 100 ms at 10 % speed: 3277 Num of Nmax 3600 rpm, 65536 per revolution.
const INC_PER_100_MS: f64 = 3277.0 * 3600.0 * 65536.0 / 60.0 / 32767.0 / 10.0;

/// Plays the script against QEMU (no address) or a running node.
pub fn demo(connect: Option<&str>, wall: Instant) -> Result<(), String> {
    let Some(addr) = connect else {
        return in_qemu("unitek-ds", |addr, child| {
            Session::start(addr, true).and_then(|mut s| {
                let script = s.script();
                let exit = s.exit_qemu(child);
                let summary = s.summary(wall);
                script.and(exit).and(summary)
            })
        });
    };
    let mut s = Session::start(addr, false)?;
    let script = s.script();
    let summary = s.summary(wall);
    script.and(summary)
}

struct Session {
    m: LiveMaster,
    qemu: bool,
    style: Style,
    checks: u32,
    failures: Vec<String>,
}

impl Session {
    fn start(addr: &str, qemu: bool) -> Result<Session, String> {
        let mut decoder = Decoder::new(Some(ObjectNames::new(&od::DICTIONARY, &od::NAMES)));
        decoder.add_unitek(RX, TX);
        let style = Style { on: std::io::IsTerminal::is_terminal(&std::io::stdout()) };
        let observer = Box::new(move |l: &LoggedFrame| println!("{}", trace_line(l, &decoder.decode(&l.frame), style)));
        let client = SlcanClient::connect(addr, Duration::from_secs(10)).map_err(|e| format!("{addr}: {e}"))?;
        let m = LiveMaster::open(client, observer, Duration::from_secs(5)).map_err(|e| format!("opening the SLCAN channel: {e}"))?;
        let header = format!(
            "{:>8}  {:<2}  {:>8}  {:<3}  {:<23}  meaning (registers named from the unitek-ds EDS)",
            "time s", "", "COB-ID", "len", "data"
        );
        println!("{}", style.paint("1", &header));
        Ok(Session { m, qemu, style, checks: 0, failures: Vec::new() })
    }

    fn step(&self, title: &str) {
        println!("{}", self.style.paint("1;34", &format!("-- {title}")));
    }

    fn check(&mut self, ok: bool, what: &str) {
        self.checks += 1;
        println!("   {} {what}", if ok { self.style.paint("32", "ok") } else { self.style.paint("1;31", "FAILED") });
        if !ok {
            self.failures.push(what.to_owned());
        }
    }

    fn io<T>(r: std::io::Result<T>) -> Result<T, String> {
        r.map_err(|e| format!("SLCAN connection: {e}"))
    }

    fn write(&mut self, data: &[u8]) -> Result<(), String> {
        Self::io(self.m.send_std(RX, data))
    }

    /// The reply with `regid` on the TX id from log position `since` on.
    fn reply(&mut self, since: usize, regid: u8) -> Result<Option<Reply>, String> {
        let f = Self::io(self.m.wait_for(since, WAIT, |f| f.cob_id() == Some(TX) && f.data().first() == Some(&regid)))?;
        Ok(f.and_then(|f| Reply::parse(f.data()).ok()))
    }

    /// READ once: the register's value.
    fn read(&mut self, regid: u8) -> Result<Option<u32>, String> {
        let mark = self.m.mark();
        self.write(&[0x3D, regid, 0x00])?;
        Ok(self.reply(mark, regid)?.map(|r| r.value))
    }

    fn expect(&mut self, regid: u8, value: u32, what: &str) -> Result<(), String> {
        let got = self.read(regid)?;
        self.check(got == Some(value), &format!("{what}: 0x{regid:02X} = {value} (read {got:?})"));
        Ok(())
    }

    /// Frames received from log position `since` on.
    fn received(&self, since: usize) -> Vec<LoggedFrame> {
        self.m.log().get(since..).unwrap_or(&[]).iter().filter(|l| l.direction == Direction::Received).cloned().collect()
    }

    fn script(&mut self) -> Result<(), String> {
        self.step("1. Not a CANopen node: no boot-up, NMT and SDO get nothing");
        let mark = if self.qemu { 0 } else { self.m.mark() };
        Self::io(self.m.send_std(0x000, &[0x81, 0x00]))?;
        Self::io(self.m.send_std(0x601, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]))?;
        Self::io(self.m.idle(Duration::from_millis(300)))?;
        let heard = self.received(mark).len();
        self.check(heard == 0, &format!("silent after power-on, NMT reset node and an SDO request ({heard} frames)"));

        self.step("2. Ready, RUN, firmware and Nmax (Ex. 11)");
        self.expect(0xE2, 1, "BTB (ready)")?;
        self.expect(0xE8, 1, "RUN input")?;
        self.expect(0x1B, 472, "firmware")?;
        self.expect(0xC8, 3600, "Nmax [rpm]")?;

        self.step("3. Enable (MODE 0x51 = 0) and 10 % speed (0x31 = 3277)");
        self.write(&[0x51, 0x00, 0x00])?;
        self.write(&[0x31, 0xCD, 0x0C])?;
        let status = self.read(0x40)?;
        self.check(status.is_some_and(|s| s & 1 != 0), &format!("STATUS bit 0 Ena ({status:08X?})"));

        self.step("4. POS_ACTUAL 0x6D every 100 ms (READ 3D 6D 64), then stop (3D 6D FF)");
        // At speed first (the ramp takes 10 ms): every period then is pure motion.
        Self::io(self.m.idle(Duration::from_millis(100)))?;
        let mark = self.m.mark();
        self.write(&[0x3D, 0x6D, 0x64])?;
        let deadline = Instant::now() + SLOW_WAIT;
        let positions = |s: &Session| -> Vec<i32> {
            s.received(mark)
                .iter()
                .filter_map(|l| Reply::parse(l.frame.data()).ok())
                .filter(|r| r.regid == 0x6D)
                .map(|r| r.value as i32)
                .collect()
        };
        while positions(self).len() < 6 && Instant::now() < deadline {
            Self::io(self.m.recv_until(deadline))?;
        }
        self.write(&[0x3D, 0x6D, 0xFF])?;
        let p = positions(self);
        let steps: Vec<f64> = p.windows(2).map(|w| f64::from(w[1].wrapping_sub(w[0])) / INC_PER_100_MS).collect();
        // The drive's own time: each 100 ms is 100 ms of motion, a 1 ms tick either way where
        // the board's wake-up falls between two ticks (vnode's host may wake later still).
        let tolerance = if self.qemu { 0.015 } else { 0.05 };
        self.check(steps.len() >= 5, &format!("{} cyclic frames", p.len()));
        self.check(
            steps.iter().all(|s| (s - 1.0).abs() <= tolerance),
            &format!("every period is 100 ms of motion at 10 % speed ({steps:.3?})"),
        );

        self.step("5. Stop, home (0x78), event STATUS on Tol (0x51 = 0x10), one revolution (0x6E = 65536)");
        self.write(&[0x31, 0x00, 0x00])?;
        // Each step waits for the drive's answer, so no frame overtakes the drive's own time.
        let deadline = Instant::now() + SLOW_WAIT;
        while self.read(0x30)? != Some(0) && Instant::now() < deadline {}
        self.write(&[0x78, 0x01, 0x00])?;
        let status = self.read(0x40)?;
        self.check(status == Some(0x3181), &format!("homed at rest: STATUS 0x3181 = Ena, P-N, N-I, Cal, Tol ({status:08X?})"));
        self.write(&[0x51, 0x10, 0x00])?;
        let status = self.read(0x40)?;
        self.check(status == Some(0x3181), &format!("event mode on, still enabled ({status:08X?})"));
        let mark = self.m.mark();
        self.write(&[0x6E, 0x00, 0x00, 0x01, 0x00])?;
        let arrived =
            Self::io(self.m.wait_for(mark, SLOW_WAIT, |f| f.cob_id() == Some(TX) && f.data() == [0x40, 0x81, 0x31, 0x00, 0x00, 0x00]))?;
        let events: Vec<u32> = self
            .received(mark)
            .iter()
            .filter_map(|l| Reply::parse(l.frame.data()).ok())
            .filter(|r| r.regid == 0x40)
            .map(|r| r.value)
            .collect();
        self.check(
            arrived.is_some() && events == [0x1181, 0x3181],
            &format!("Tol falls (0x1181), then in position: 0x3181 as Ex. 10 prints it ({events:04X?})"),
        );
        let at = self.read(0x6D)?.map(|p| p as i32);
        self.check(at.is_some_and(|p| (p - 65536).abs() <= 100), &format!("POS_ACTUAL within POS_WINDOW 100 of 65536 ({at:?})"));

        self.step("6. Disable (MODE 0x51 = 4)");
        self.write(&[0x51, 0x04, 0x00])?;
        let status = self.read(0x40)?;
        self.check(status.is_some_and(|s| s & 1 == 0), &format!("STATUS bit 0 clear ({status:08X?})"));
        Ok(())
    }

    fn exit_qemu(&mut self, child: &Mutex<Child>) -> Result<(), String> {
        self.step("7. Exit frame: QEMU ends through semihosting");
        let code = send_exit(&mut self.m, child)?;
        self.check(code == Some(0), &format!("QEMU exit code {code:?}"));
        Ok(())
    }

    fn summary(&mut self, wall: Instant) -> Result<(), String> {
        self.step("Summary");
        let log = self.m.log();
        let sent = log.iter().filter(|l| l.direction == Direction::Sent).count();
        let replies = log.iter().filter(|l| l.direction == Direction::Received && l.frame.cob_id() == Some(TX)).count();
        let others = log.iter().filter(|l| l.direction == Direction::Received && l.frame.cob_id() != Some(TX)).count();
        println!("   frames sent by the master: {sent}; replies on 0x{TX:03X}: {replies}; other frames from the drive: {others}");
        println!("   wall time: {:.2} s", wall.elapsed().as_secs_f64());
        let failed = self.failures.len();
        println!("   checks: {} passed, {failed} failed", self.checks as usize - failed);
        if failed == 0 { Ok(()) } else { Err(format!("demo: {failed} check(s) failed:\n  {}", self.failures.join("\n  "))) }
    }
}
