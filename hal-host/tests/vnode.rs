//! `vnode` as a program: the built binary on an ephemeral port, driven
//! over raw SLCAN lines by several masters at once, under bursts, with a
//! master that does not read, with its stdout closed or never drained, and
//! its command line.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, ChildStderr, ChildStdout, Command, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

const WAIT: Duration = Duration::from_secs(10);
/// The longest a burst test waits for the next of the frames it expects: a
/// loaded machine makes vnode slow, but never silent for this long while
/// frames are on their way; then one was lost.
const STALL: Duration = Duration::from_secs(20);
/// SDO upload request 0x1000:00 to node 5, and ec5000's answer.
const UPLOAD_1000: &str = "t60584000100000000000";
const DEVICE_TYPE: &str = "t58584300100092014200";
/// SDO upload request 0x1018:01 (vendor-id) to node 5: the answer starts so.
const UPLOAD_1018_1: &str = "t60584018100100000000";
const VENDOR_ID_PREFIX: &str = "t5858431810";

/// A running vnode, killed when dropped.
struct Vnode {
    child: Child,
    port: u16,
    stdout: Option<BufReader<ChildStdout>>,
}

impl Vnode {
    fn start(args: &[&str]) -> Vnode {
        let mut child = Command::new(env!("CARGO_BIN_EXE_vnode"))
            .args(["--device", "ec5000", "--node-id", "5", "--listen", "127.0.0.1:0"])
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("vnode starts");
        let mut stdout = BufReader::new(child.stdout.take().expect("stdout is piped"));
        let mut line = String::new();
        stdout.read_line(&mut line).expect("vnode prints its port");
        let port = line.trim().rsplit(':').next().and_then(|p| p.parse().ok()).unwrap_or_else(|| panic!("no port in {line:?}"));
        Vnode { child, port, stdout: Some(stdout) }
    }

    fn connect(&self) -> Master {
        Master::connect(self.port)
    }

    fn pid(&self) -> u32 {
        self.child.id()
    }

    fn alive(&mut self) -> bool {
        self.child.try_wait().expect("wait works").is_none()
    }

    /// Stops vnode and returns what it said on stderr.
    fn stop(mut self) -> String {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let mut err = String::new();
        let stderr: Option<ChildStderr> = self.child.stderr.take();
        if let Some(mut e) = stderr {
            let _ = e.read_to_string(&mut err);
        }
        err
    }
}

impl Drop for Vnode {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A master on its own SLCAN connection, its lines read by a thread.
struct Master {
    stream: TcpStream,
    lines: Receiver<String>,
}

impl Master {
    fn connect(port: u16) -> Master {
        let stream = TcpStream::connect(("127.0.0.1", port)).expect("vnode accepts");
        let mut reader = stream.try_clone().expect("clone");
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            let (mut buf, mut line) = ([0u8; 65536], Vec::new());
            while let Ok(n @ 1..) = reader.read(&mut buf) {
                for &b in &buf[..n] {
                    if b == b'\r' || b == 0x07 {
                        let text = if b == 0x07 { "BEL".to_owned() } else { String::from_utf8_lossy(&line).into_owned() };
                        line.clear();
                        if tx.send(text).is_err() {
                            return;
                        }
                    } else {
                        line.push(b);
                    }
                }
            }
        });
        let mut m = Master { stream, lines };
        m.send("S8\rO\r");
        assert_eq!((m.next(), m.next()), (Some(String::new()), Some(String::new())));
        m
    }

    fn send(&mut self, text: &str) {
        self.stream.write_all(text.as_bytes()).expect("vnode reads");
    }

    fn next(&self) -> Option<String> {
        self.lines.recv_timeout(WAIT).ok()
    }

    /// Every line until none came for `quiet`.
    fn collect(&self, quiet: Duration) -> Vec<String> {
        let mut out = Vec::new();
        loop {
            match self.lines.recv_timeout(quiet) {
                Ok(l) => out.push(l),
                Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => return out,
            }
        }
    }

    /// Every line until `done` holds for them (or none came for [`STALL`]),
    /// then every line until none came for `quiet`: a loaded machine may
    /// stall the node longer than any quiet period, and take any time for
    /// a burst, so the wait ends on what arrived, or on silence, and the
    /// quiet period only looks for extra frames.
    fn collect_until(&self, done: impl Fn(&[String]) -> bool, quiet: Duration) -> Vec<String> {
        let mut out = Vec::new();
        while !done(&out) {
            match self.lines.recv_timeout(STALL) {
                Ok(l) => out.push(l),
                Err(_) => return out,
            }
        }
        out.extend(self.collect(quiet));
        out
    }

    /// Every line that comes within `time`.
    fn during(&self, time: Duration) -> Vec<String> {
        let deadline = Instant::now() + time;
        let mut out = Vec::new();
        while let Ok(l) = self.lines.recv_timeout(deadline.saturating_duration_since(Instant::now())) {
            out.push(l);
        }
        out
    }

    /// The first line that `pred` accepts, within [`WAIT`].
    fn wait_for(&self, pred: impl Fn(&str) -> bool) -> Option<String> {
        let deadline = Instant::now() + WAIT;
        while let Ok(l) = self.lines.recv_timeout(deadline.saturating_duration_since(Instant::now())) {
            if pred(&l) {
                return Some(l);
            }
        }
        None
    }

    /// One SDO round: request, then its answer.
    fn upload(&mut self, request: &str, answer_prefix: &str) -> Option<String> {
        self.send(&format!("{request}\r"));
        self.wait_for(|l| l.starts_with(answer_prefix))
    }
}

fn count(lines: &[String], what: &str) -> usize {
    lines.iter().filter(|l| l.starts_with(what)).count()
}

#[test]
fn back_to_back_sdo_requests_are_all_answered() {
    let vnode = Vnode::start(&[]);
    let mut m = vnode.connect();
    m.collect(Duration::from_millis(100));
    const N: usize = 2000;
    m.send(&format!("{UPLOAD_1000}\r").repeat(N));
    let lines = m.collect_until(|l| count(l, DEVICE_TYPE) >= N, Duration::from_millis(300));
    assert_eq!(count(&lines, "z"), N, "every request acknowledged");
    assert_eq!(count(&lines, DEVICE_TYPE), N, "every request answered");
}

#[test]
fn a_reset_takes_a_boards_restart_time_and_the_answer_before_it_goes_out_first() {
    let vnode = Vnode::start(&[]);
    let mut m = vnode.connect();
    m.collect(Duration::from_millis(100));
    // python-canopen's `send_command` then `wait_for_bootup` only sees a
    // boot-up that comes once it waits: 20 ms is a board's restart, never
    // the 10-300 us a reset in stages takes on a PC.
    for command in ["t00028105", "t00028205"] {
        let sent = Instant::now();
        m.send(&format!("{command}\r"));
        assert_eq!(m.wait_for(|l| l == "t705100").as_deref(), Some("t705100"), "{command}: boot-up");
        assert!(sent.elapsed() >= Duration::from_millis(20), "{command}: boot-up after {:?}", sent.elapsed());
    }
    // 0x1F51:01 = 1 restarts the EC5000: its SDO answer first (a boot-up
    // before it would be skipped here and missed below), the boot-up 20 ms later.
    let sent = Instant::now();
    m.send("t60582F511F0101000000\r");
    assert_eq!(m.wait_for(|l| l.starts_with("t585")).as_deref(), Some("t585860511F0100000000"));
    assert_eq!(m.wait_for(|l| l == "t705100").as_deref(), Some("t705100"));
    assert!(sent.elapsed() >= Duration::from_millis(20), "boot-up after {:?}", sent.elapsed());
}

/// Spins every core until `stop` is set.
fn busy_cores(stop: &std::sync::Arc<std::sync::atomic::AtomicBool>) -> Vec<std::thread::JoinHandle<()>> {
    let cores = std::thread::available_parallelism().map_or(2, usize::from);
    (0..2 * cores)
        .map(|_| {
            let stop = std::sync::Arc::clone(stop);
            std::thread::spawn(move || {
                while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                    std::hint::spin_loop();
                }
            })
        })
        .collect()
}

#[test]
fn a_node_the_os_runs_late_loses_no_answer() {
    let vnode = Vnode::start(&[]);
    let mut m = vnode.connect();
    m.collect(Duration::from_millis(100));
    // The node's thread (vnode's main thread) runs only when nothing else
    // wants a core, and every core is busy for a while: the wire and the
    // connection's threads go on, the node gets hardly any time.
    let idle = Command::new("chrt").args(["--idle", "--pid", "0", &vnode.pid().to_string()]).status();
    assert!(idle.as_ref().is_ok_and(|s| s.success()), "chrt (util-linux) makes vnode's main thread SCHED_IDLE: {idle:?}");
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let spinners = busy_cores(&stop);
    const N: usize = 2000;
    m.send(&format!("{UPLOAD_1000}\r").repeat(N));
    std::thread::sleep(Duration::from_secs(2));
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    spinners.into_iter().for_each(|s| s.join().unwrap());
    // Back to a normal thread: the rest may take its time, but on a machine
    // busy with other work an idle-class node would hardly ever run.
    let normal = Command::new("chrt").args(["--other", "--pid", "0", &vnode.pid().to_string()]).status();
    assert!(normal.as_ref().is_ok_and(|s| s.success()), "chrt --other: {normal:?}");
    // TCP held the master back while the node was behind: slow, but no
    // request and no answer lost, and so nothing to signal either.
    let lines = m.collect_until(|l| count(l, DEVICE_TYPE) >= N, Duration::from_millis(300));
    assert_eq!(count(&lines, "z"), N, "every request acknowledged");
    assert_eq!(count(&lines, DEVICE_TYPE), N, "every request answered");
    assert_eq!(count(&lines, "t085"), 0, "no EMCY");
}

#[test]
fn a_burst_takes_the_time_the_wire_needs_at_the_bit_rate() {
    use hal_host::bus::{BitRate, frame_time_ns};
    let vnode = Vnode::start(&["--bitrate", "125"]);
    let mut m = vnode.connect();
    m.collect(Duration::from_millis(100));
    const N: u32 = 200;
    let frame = |id, data: [u8; 8]| canopen_core::frame::CanFrame::standard(id, &data).unwrap();
    let request = frame(0x605, [0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]);
    let answer = frame(0x585, [0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x42, 0x00]);
    let round = Duration::from_nanos(frame_time_ns(&request, BitRate::KBIT_125) + frame_time_ns(&answer, BitRate::KBIT_125));
    let start = Instant::now();
    m.send(&format!("{UPLOAD_1000}\r").repeat(N as usize));
    for i in 0..N {
        assert!(m.wait_for(|l| l == DEVICE_TYPE).is_some(), "answer {i}");
    }
    let took = start.elapsed();
    // About 2 ms per round at 125 kbit/s; the last answer cannot come
    // before the wire has carried every request and every answer.
    assert!(took >= round * N - Duration::from_millis(1), "{N} rounds in {took:?}, the wire needs {:?}", round * N);
    // Not much slower either (the margin is for a loaded machine).
    assert!(took < round * N * 2 + Duration::from_secs(2), "{N} rounds in {took:?}, the wire needs {:?}", round * N);
}

#[test]
fn every_sync_of_a_burst_gives_its_tpdo() {
    let vnode = Vnode::start(&[]);
    let mut m = vnode.connect();
    m.send("t00020105\r"); // NMT start node 5: TPDO3 (0x385) is synchronous, type 1
    m.collect(Duration::from_millis(200));
    m.send(&"t0800\r".repeat(200));
    let lines = m.collect_until(|l| count(l, "t385") >= 200, Duration::from_millis(300));
    assert_eq!(count(&lines, "t385"), 200);
    assert_eq!(count(&lines, "t085"), 0, "no EMCY (a lost frame would raise 0x8110)");
}

#[test]
fn masters_share_the_bus() {
    let vnode = Vnode::start(&[]);
    let mut a = vnode.connect();
    let mut b = vnode.connect();
    // Both hear the answer to A's request, and B hears A's request as well.
    // vnode prints its port before its first `process`, so on a loaded
    // machine a master may connect before the boot-up is on the wire and
    // hear it: it is no part of what is checked here.
    let boot_up = |f: &String| f.as_str() != "t705100";
    assert_eq!(a.upload(UPLOAD_1000, "t585").as_deref(), Some(DEVICE_TYPE));
    let b_next = || std::iter::from_fn(|| b.next()).find(boot_up);
    assert_eq!(b_next().as_deref(), Some(UPLOAD_1000));
    assert_eq!(b_next().as_deref(), Some(DEVICE_TYPE));
    let vendor = b.upload(UPLOAD_1018_1, VENDOR_ID_PREFIX).expect("B's answer");
    let heard: Vec<String> = a.collect(Duration::from_millis(200)).into_iter().filter(boot_up).collect();
    assert_eq!(heard, [UPLOAD_1018_1, &vendor]);
    let echoed: Vec<String> = b.collect(Duration::from_millis(100)).into_iter().filter(boot_up).collect();
    assert_eq!(echoed, Vec::<String>::new(), "B got its request back");
    // A master that connected and stays silent locks nobody out.
    let _idle = TcpStream::connect(("127.0.0.1", vnode.port)).unwrap();
    let mut c = vnode.connect();
    assert_eq!(c.upload(UPLOAD_1000, "t585").as_deref(), Some(DEVICE_TYPE));
}

#[test]
fn a_master_that_does_not_read_blocks_nobody() {
    let vnode = Vnode::start(&[]);
    let mut sleeper = vnode.connect();
    // Heartbeat every 1 ms (0x1017 = 1), then never read again.
    sleeper.send("t60582B17100001000000\r");
    sleeper.send(&format!("{UPLOAD_1000}\r").repeat(500));
    let mut b = vnode.connect();
    let start = Instant::now();
    for round in 0..500 {
        assert!(b.upload(UPLOAD_1018_1, VENDOR_ID_PREFIX).is_some(), "round {round}");
    }
    assert!(start.elapsed() < WAIT, "500 rounds took {:?}", start.elapsed());
}

/// Resident memory of a process, in kB.
fn rss_kb(pid: u32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).expect("Linux /proc");
    status.lines().find_map(|l| l.strip_prefix("VmRSS:")).and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok()).expect("VmRSS")
}

#[test]
fn memory_stays_flat_without_a_client() {
    let vnode = Vnode::start(&[]);
    let mut m = vnode.connect();
    m.send("t60582B17100001000000\r"); // heartbeat every 1 ms
    assert_eq!(m.wait_for(|l| l.starts_with("t585")).as_deref(), Some("t58586017100000000000"));
    drop(m);
    std::thread::sleep(Duration::from_secs(1));
    let before = rss_kb(vnode.pid());
    // 5,000 heartbeats with nobody to take them.
    std::thread::sleep(Duration::from_secs(5));
    let after = rss_kb(vnode.pid());
    assert!(after < before + 64, "RSS {before} kB -> {after} kB with no client");
    // And a client that comes back gets the heartbeats, not a backlog.
    let m = vnode.connect();
    let lines = m.during(Duration::from_millis(100));
    assert!(lines.len() < 200 && count(&lines, "t705") == lines.len(), "{} lines", lines.len());
}

/// LSS: switch to configuration, configure bit timing index 4 (125 kbit/s), activate it now.
const LSS_ACTIVATE_125K: &str = "t7E580401000000000000\rt7E581300040000000000\rt7E581500000000000000\r";

#[test]
fn a_closed_stdout_stops_neither_the_node_nor_the_trace_of_its_work() {
    let mut vnode = Vnode::start(&["--trace"]);
    drop(vnode.stdout.take());
    let mut m = vnode.connect();
    m.send(LSS_ACTIVATE_125K);
    for _ in 0..50 {
        assert_eq!(m.upload(UPLOAD_1000, "t585").as_deref(), Some(DEVICE_TYPE));
    }
    assert!(vnode.alive());
    std::thread::sleep(Duration::from_millis(1100)); // one report period
    let err = vnode.stop();
    assert!(err.contains("bit rate switched to 125 kbit/s"), "{err}");
    assert!(err.contains("trace stopped: Broken pipe"), "{err}");
}

#[test]
fn an_undrained_trace_never_stalls_the_node() {
    // The 64 KiB pipe fills after about 800 rounds (two 40-byte lines
    // each), the trace queue of 4,096 lines after 2,000 more.
    let vnode = Vnode::start(&["--trace"]);
    let mut m = vnode.connect();
    for round in 0..3000 {
        assert_eq!(m.upload(UPLOAD_1000, "t585").as_deref(), Some(DEVICE_TYPE), "round {round}");
    }
    std::thread::sleep(Duration::from_millis(1100)); // one report period
    let err = vnode.stop();
    assert!(err.contains("trace: ") && err.contains("lines dropped"), "{err}");
}

#[test]
fn trace_file_is_a_candump_log() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    let file = dir.join("vnode-trace.log");
    let vnode = Vnode::start(&["--trace", file.to_str().unwrap()]);
    let mut m = vnode.connect();
    assert_eq!(m.upload(UPLOAD_1000, "t585").as_deref(), Some(DEVICE_TYPE));
    // A node-guarding request: the EC5000 has no guarding (docs/devices/ec5000.md
    // D41), so it is traced and left unanswered.
    m.send("r7051\r");
    m.send("T1ABCDEF02BEEF\r");
    assert_eq!(m.wait_for(|l| l == "Z").as_deref(), Some("Z"));
    std::thread::sleep(Duration::from_millis(300));
    drop(vnode);
    let text = std::fs::read_to_string(&file).unwrap();
    let frames: Vec<&str> = text.lines().map(|l| l.split_once(") can0 ").map_or("?", |(_, f)| f)).collect();
    assert_eq!(frames, ["705#00", "605#4000100000000000", "585#4300100092014200", "705#R1", "1ABCDEF0#BEEF"], "{text}");
    for line in text.lines() {
        let secs: f64 = line[1..18].parse().unwrap();
        assert!(line.as_bytes()[18] == b')' && secs > 1.7e9, "{line}");
    }
}

#[test]
fn command_line_behaves_like_a_rust_tool() {
    let vnode = |args: &[&str]| Command::new(env!("CARGO_BIN_EXE_vnode")).args(args).output().expect("vnode runs");
    let help = vnode(&["--help"]);
    assert_eq!(help.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&help.stdout).contains("Usage: vnode [OPTIONS]"));
    let version = vnode(&["--version"]);
    assert_eq!(
        (version.status.code(), String::from_utf8_lossy(&version.stdout).trim()),
        (Some(0), concat!("vnode ", env!("CARGO_PKG_VERSION")))
    );
    for (args, says) in [
        (&["--device", "ec5000"][..], "--node-id <N>"),
        (&["--device", "ec5000", "--node-id", "128"], "invalid value '128' for '--node-id <N>'"),
        (&["--device", "ec5001", "--node-id", "5"], "invalid value 'ec5001' for '--device <NAME>'"),
        (&["--device", "ec5000", "--node-id", "5", "--bogus"], "unexpected argument '--bogus'"),
        (&["--list", "--device", "ec5000"], "cannot be used with"),
        (
            &["--device", "ec5000", "--node-id", "5", "--listen", "localhost"],
            "invalid value 'localhost' for '--listen <ADDR>': not HOST:PORT",
        ),
        (&["--device", "ec5000", "--node-id", "5", "--listen", "4557"], "invalid value '4557' for '--listen <ADDR>'"),
    ] {
        let o = vnode(args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.starts_with("error: ") && err.contains(says), "{args:?}: {err}");
    }
    // An address this machine does not have is no usage error.
    let o = vnode(&["--device", "ec5000", "--node-id", "5", "--listen", "192.0.2.1:0"]);
    assert_eq!(o.status.code(), Some(1), "{}", String::from_utf8_lossy(&o.stderr));
    // An EDS that cannot be read is a wrong `--eds`, as od-gen has it.
    let o = vnode(&["--eds", "no-such-file.eds", "--node-id", "5"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.starts_with("no-such-file.eds: error: "), "{err}");
}

/// A trace file vnode cannot create stops it before it names a port: a
/// harness that reads the port line must not connect to a node that is gone.
#[test]
fn an_unwritable_trace_file_fails_before_the_port_line() {
    let o = Command::new(env!("CARGO_BIN_EXE_vnode"))
        .args(["--device", "ec5000", "--node-id", "5", "--trace", "/nonexistent-dir/trace.log"])
        .output()
        .expect("vnode runs");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert_eq!(String::from_utf8_lossy(&o.stdout), "", "no port line");
    assert!(err.contains("/nonexistent-dir/trace.log: "), "{err}");
}

/// A device without LSS cannot start unconfigured: nothing could ever give
/// it a node-id, so vnode says so instead of serving a node that never answers.
#[test]
fn an_unconfigured_node_needs_lss() {
    for device in ["agile", "bmaxx4400"] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_vnode"))
            .args(["--device", device, "--node-id", "255", "--listen", "127.0.0.1:0"])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("vnode runs");
        let end = Instant::now() + Duration::from_secs(5);
        let status = loop {
            match child.try_wait().expect("try_wait") {
                Some(status) => break status,
                None if Instant::now() > end => {
                    let _ = child.kill();
                    let _ = child.wait();
                    panic!("{device}: vnode served an unconfigured node without LSS");
                }
                None => std::thread::sleep(Duration::from_millis(10)),
            }
        };
        let mut err = String::new();
        child.stderr.take().expect("stderr").read_to_string(&mut err).expect("stderr");
        assert_eq!(status.code(), Some(1), "{device}: {err}");
        assert!(err.contains("has no LSS") && err.contains("1..=127"), "{device}: {err}");
    }
    // The EC5000 has LSS: it starts unconfigured and waits for LSS (tests/python/test_lss.py).
    let mut ec5000 = Command::new(env!("CARGO_BIN_EXE_vnode"))
        .args(["--device", "ec5000", "--node-id", "255", "--listen", "127.0.0.1:0"])
        .stdout(Stdio::piped())
        .spawn()
        .expect("vnode runs");
    let mut line = String::new();
    BufReader::new(ec5000.stdout.take().expect("stdout")).read_line(&mut line).expect("the port line");
    assert!(line.starts_with("vnode ec5000 node 255 listening on 127.0.0.1:"), "{line}");
    ec5000.kill().expect("kill");
    ec5000.wait().expect("wait");
}

/// An EDS with SDO servers past the four vnode runs says so on stderr and
/// still serves the others.
#[test]
fn sdo_servers_past_the_fourth_are_reported() {
    let dir = std::env::temp_dir().join(format!("vnode-sdo-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let eds = dir.join("sdo.eds");
    let mut text = String::from(
        "[DeviceInfo]\nVendorName=V\nNrOfRXPDO=0\nNrOfTXPDO=0\n[1000]\nParameterName=Device type\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0\n",
    );
    for (index, rx, tx) in [(0x1200, "$NODEID+0x600", "$NODEID+0x580"), (0x1205, "0x650", "0x5D0")] {
        text += &format!("[{index:04X}]\nParameterName=SDO server\nObjectType=0x9\nSubNumber=3\n");
        text += &format!("[{index:04X}sub0]\nParameterName=Highest\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=2\n");
        text += &format!("[{index:04X}sub1]\nParameterName=Rx\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue={rx}\n");
        text += &format!("[{index:04X}sub2]\nParameterName=Tx\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue={tx}\n");
    }
    std::fs::write(&eds, text).expect("write the EDS");
    let mut child = Command::new(env!("CARGO_BIN_EXE_vnode"))
        .args(["--eds", eds.to_str().expect("UTF-8"), "--node-id", "5"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("vnode runs");
    let mut line = String::new();
    BufReader::new(child.stdout.take().expect("stdout")).read_line(&mut line).expect("the port line");
    let _ = child.kill();
    let _ = child.wait();
    let mut err = String::new();
    child.stderr.take().expect("stderr").read_to_string(&mut err).expect("stderr");
    let _ = std::fs::remove_dir_all(&dir);
    assert!(line.contains("listening on"), "{line}{err}");
    assert!(err.contains("vnode serves the SDO servers 0x1200–0x1203; those above stay off"), "{err}");
}

/// `--node-id` takes hex as `--serial` does, `0x` or `0X` (a CANopen user
/// writes node-ids in hex as often as not); both still refuse what does not fit.
#[test]
fn node_id_and_serial_take_hex() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_vnode"))
        .args(["--device", "ec5000", "--node-id", "0x7F", "--serial", "0XABCD"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("vnode runs");
    let mut line = String::new();
    BufReader::new(child.stdout.take().expect("stdout")).read_line(&mut line).expect("the port line");
    let _ = child.kill();
    let _ = child.wait();
    assert!(line.starts_with("vnode ec5000 node 127 listening on "), "{line}");
    for (args, says) in [
        (&["--device", "ec5000", "--node-id", "0x80"][..], "invalid value '0x80' for '--node-id <N>'"),
        (&["--device", "ec5000", "--node-id", "5", "--serial", "0x100000000"], "not a 32-bit number"),
    ] {
        let o = Command::new(env!("CARGO_BIN_EXE_vnode")).args(args).output().expect("vnode runs");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
}
