//! `cargo xtask icount [N]`: instructions per handled frame, on the host
//! and on thumbv7m, for the same node and frames (`bench/icount`'s library).
//!
//! - x86_64: runs `bench/icount` under `valgrind --tool=callgrind` with N
//!   and 2N frames of each kind and reports (I(2N) − I(N)) / N, in all and
//!   for `on_frame`, `process` and `transmit` apart (`--toggle-collect`).
//! - thumbv7m: builds `bench/icount-qemu` (release profile), runs it in
//!   `qemu-system-arm -M lm3s6965evb -icount shift=0` under a hard timeout
//!   and parses its semihosting report: per frame beside the host figures,
//!   the worst single frame, and the receive interrupts' own part.

use super::target_dir;
use crate::{TARGET, ensure_target, root, run};
use std::collections::BTreeMap;
use std::io::Read;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The kinds both benches measure: name, what the frame is.
const KINDS: [(&str, &str); 7] = [
    ("rpdo", "RPDO (8 bytes, 4 objects)"),
    ("sdo-upload", "expedited SDO upload (0x1018 sub 1)"),
    ("sdo-download", "expedited SDO download (0x2003, u32, mapped in TPDO1)"),
    ("sync", "SYNC, 4 synchronous TPDOs"),
    ("idle", "idle (`process` with nothing due, an empty `transmit`)"),
    ("cia402", "EC5000 RPDO 0x6040 + 0x60FF → CiA 402 state machine → TPDO 0x6041 + 0x606C"),
    ("cia402-echo", "the same frames, an application copying 0x6040 to 0x6041 (baseline)"),
];

/// CANopenNode v4 for the same node, frames and state on thumbv7m (`-Os`,
/// one full 1 ms tick per frame: `../shared/notes/perf-review.md` §0.1), and
/// the aim for this stack (issue 12): kind, CANopenNode, aim.
const CANOPENNODE: [(&str, f64, f64); 5] = [
    ("rpdo", 1121.2, 560.0),
    ("sdo-upload", 1206.2, 600.0),
    ("sdo-download", 1171.2, 700.0),
    ("sync", 2005.3, 1000.0),
    ("idle", 729.2, 120.0),
];

/// The CiA 402 profile's own part of the `cia402` row (the row minus its
/// baseline) may cost at most this many thumbv7m instructions per frame.
const CIA402_BUDGET: f64 = 1_000.0;

/// The image finishes in well under a second; a hang must not stall the task.
const QEMU_TIMEOUT: Duration = Duration::from_secs(120);

/// Instructions valgrind counted for one run (all, or inside `toggle`).
fn callgrind(bin: &str, kind: &str, n: u64, toggle: Option<&str>) -> Result<u64, String> {
    let mut args = vec!["--tool=callgrind".to_string(), "--callgrind-out-file=/dev/null".to_string()];
    if let Some(f) = toggle {
        args.push(format!("--toggle-collect=*{f}*"));
    }
    args.extend([bin.to_string(), kind.to_string(), n.to_string()]);
    let out = Command::new("valgrind")
        .args(&args)
        .current_dir(root())
        .output()
        .map_err(|e| format!("valgrind: {e} (install it with `apt-get install valgrind`)"))?;
    let stderr = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        return Err(format!("`valgrind {}` failed ({}):\n{stderr}", args.join(" "), out.status));
    }
    stderr
        .lines()
        .find_map(|l| l.split_once("Collected :").and_then(|(_, v)| v.trim().parse().ok()))
        .ok_or_else(|| format!("no `Collected :` line from callgrind:\n{stderr}"))
}

/// The host figures of one kind, instructions per frame.
struct HostRow {
    on_frame: u64,
    process: u64,
    transmit: u64,
}

pub fn icount(n: u64) -> Result<(), String> {
    let n = n.max(1);
    run("cargo", &["build", "--quiet", "--release", "-p", "canopen-icount"])?;
    let bin = target_dir().join("release/canopen-icount");
    let bin = bin.to_str().ok_or("non-UTF-8 path")?;
    let per_frame = |kind: &str, toggle: Option<&str>| -> Result<(u64, u64), String> {
        let once = callgrind(bin, kind, n, toggle)?;
        let twice = callgrind(bin, kind, 2 * n, toggle)?;
        let per = twice.saturating_sub(once) as f64 / n as f64;
        Ok((per.round() as u64, once.saturating_sub(per.round() as u64 * n)))
    };
    println!("\nx86_64 instructions per handled frame (callgrind, (I(2N) - I(N)) / N with N = {n}; release profile):\n");
    println!("| frame | per frame | on_frame | process | transmit (all calls) | start-up (not per frame) |");
    println!("|---|---:|---:|---:|---:|---:|");
    let mut host = Vec::new();
    for (kind, what) in KINDS {
        eprintln!("xtask icount: {kind}");
        let (total, startup) = per_frame(kind, None)?;
        let (on_frame, _) = per_frame(kind, Some("icount_on_frame"))?;
        let (process, _) = per_frame(kind, Some("icount_process"))?;
        let (transmit, _) = per_frame(kind, Some("icount_transmit"))?;
        println!("| {what} | {total} | {on_frame} | {process} | {transmit} | {startup} |");
        host.push(HostRow { on_frame, process, transmit });
    }

    eprintln!("xtask icount: thumbv7m in QEMU");
    let (version, out) = run_qemu_image()?;
    let report = parse_report(&out)?;
    print_thumbv7m(&version, &report, &host);
    print_against_canopennode(&report);
    cia402_share(&report)
}

/// The thumbv7m rows beside CANopenNode's, with the ratio and the aim.
fn print_against_canopennode(r: &QemuReport) {
    println!("\nthumbv7m against CANopenNode v4 (-Os, one full 1 ms tick per frame; perf-review.md §0.1):\n");
    println!("| frame | this stack | CANopenNode | ratio | aim | met |");
    println!("|---|---:|---:|---:|---:|---|");
    for (kind, c, aim) in CANOPENNODE {
        let Some(k) = r.kinds.iter().find(|k| k.name == kind) else { continue };
        let what = KINDS.iter().find(|(n, _)| *n == kind).map_or(kind, |(_, w)| *w);
        let ours = k.total();
        println!("| {what} | {ours:.0} | {c:.0} | {:.2} | ≤ {aim:.0} | {} |", ours / c, if ours <= aim { "yes" } else { "no" });
    }
}

/// The profile's part of the CiA 402 row on thumbv7m, against [`CIA402_BUDGET`].
fn cia402_share(r: &QemuReport) -> Result<(), String> {
    let total = |name: &str| r.kinds.iter().find(|k| k.name == name).map(QemuKind::total).ok_or(format!("no `{name}` row from the image"));
    let (profile, echo) = (total("cia402")?, total("cia402-echo")?);
    let share = profile - echo;
    println!(
        "\nCiA 402 profile's part (cia402 − cia402-echo) on thumbv7m: {profile:.0} − {echo:.0} = {share:.0} instructions per frame (budget {CIA402_BUDGET:.0}); \
         the whole path (RPDO → state machine → TPDO) {profile:.0}, aim {CIA402_BUDGET:.0}"
    );
    if share > CIA402_BUDGET { Err(format!("the CiA 402 path costs {share:.0} instructions, over {CIA402_BUDGET:.0}")) } else { Ok(()) }
}

/// Builds `bench/icount-qemu` and runs it; returns QEMU's version and the image's stdout.
fn run_qemu_image() -> Result<(String, String), String> {
    let version = Command::new("qemu-system-arm")
        .arg("--version")
        .output()
        .map_err(|e| format!("qemu-system-arm: {e} (install it: apt-get install -y --no-install-recommends qemu-system-arm)"))?;
    let version = String::from_utf8_lossy(&version.stdout).lines().next().unwrap_or("").to_string();
    ensure_target()?;
    run("cargo", &["build", "--quiet", "--release", "-p", "canopen-icount-qemu", "--target", TARGET])?;
    let elf = target_dir().join(TARGET).join("release/canopen-icount-qemu");
    let mut child = Command::new("qemu-system-arm")
        .args(["-M", "lm3s6965evb", "-cpu", "cortex-m3", "-display", "none", "-monitor", "none", "-serial", "null"])
        .args(["-semihosting-config", "enable=on,target=native"])
        // 1 instruction = 1 ns of virtual time, never waiting for the host clock.
        .args(["-icount", "shift=0,align=off,sleep=off"])
        .arg("-kernel")
        .arg(&elf)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .map_err(|e| format!("qemu-system-arm: {e}"))?;
    let mut stdout = child.stdout.take().ok_or("no stdout from QEMU")?;
    let reader = std::thread::spawn(move || {
        let mut text = String::new();
        stdout.read_to_string(&mut text).map(|_| text)
    });
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            break status;
        }
        if start.elapsed() > QEMU_TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("{} killed after {} s", elf.display(), QEMU_TIMEOUT.as_secs()));
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let out = reader.join().map_err(|_| "QEMU output reader panicked")?.map_err(|e| e.to_string())?;
    if !status.success() {
        return Err(format!("{} failed ({status}):\n{out}", elf.display()));
    }
    Ok((version, out))
}

/// One kind on thumbv7m: instructions per frame.
#[derive(Debug, PartialEq)]
struct QemuKind {
    name: String,
    on_frame: f64,
    process: f64,
    transmit: f64,
    /// `transmit` calls per frame (the last returns `None`).
    calls_per_frame: f64,
}

impl QemuKind {
    fn total(&self) -> f64 {
        self.on_frame + self.process + self.transmit
    }
}

/// One expensive frame on thumbv7m: `on_frame` + `process`.
#[derive(Debug, PartialEq)]
struct QemuWorst {
    name: String,
    on_frame: f64,
    process: f64,
    total: f64,
    /// The longest single call (`on_frame` or one `process`: a reset takes a stage per call).
    longest: f64,
    /// `process` calls until the frame's work was done.
    calls: u64,
    sent: u64,
}

/// What `bench/icount-qemu` reports.
#[derive(Debug, PartialEq)]
struct QemuReport {
    calibration_instructions: u64,
    calibration_ticks: u64,
    per_tick: u64,
    overhead: f64,
    /// A straight-line block of known length, and what the image measured for it.
    check: (u64, f64),
    kinds: Vec<QemuKind>,
    worst: Vec<QemuWorst>,
    /// SLCAN line: bytes (= UART0 interrupts), all of them, the CR's.
    slcan: (u64, f64, f64),
    /// bxCAN FIFO 0 to the channel.
    bxcan: f64,
}

/// Parses the image's `icount-qemu ...` lines (other lines are ignored).
/// Fails on a `FAILED` line, without the final `ok`, or when a figure is missing.
fn parse_report(out: &str) -> Result<QemuReport, String> {
    let mut calibration = None;
    let (mut kinds, mut worst, mut slcan, mut bxcan, mut ok) = (Vec::new(), Vec::new(), None, None, false);
    for line in out.lines() {
        let Some(rest) = line.strip_prefix("icount-qemu ") else { continue };
        if rest.starts_with("FAILED") {
            return Err(format!("the image failed: {line}"));
        }
        if rest == "ok" {
            ok = true;
            continue;
        }
        let (tag, fields) = rest.split_once(' ').unwrap_or((rest, ""));
        let fields: BTreeMap<&str, &str> = fields.split_whitespace().filter_map(|f| f.split_once('=')).collect();
        let num = |key: &str| -> Result<f64, String> {
            fields.get(key).and_then(|v| v.parse::<f64>().ok()).ok_or_else(|| format!("no number `{key}` in: {line}"))
        };
        let int = |key: &str| -> Result<u64, String> {
            fields.get(key).and_then(|v| v.parse::<u64>().ok()).ok_or_else(|| format!("no integer `{key}` in: {line}"))
        };
        match tag.split_once('=') {
            None if tag == "calibration" => {
                calibration = Some((
                    int("instructions")?,
                    int("ticks")?,
                    int("per_tick")?,
                    num("overhead")?,
                    (int("check_known")?, num("check_measured")?),
                ));
            }
            Some(("kind", name)) => {
                let frames = int("frames")?.max(1) as f64;
                kinds.push(QemuKind {
                    name: name.to_string(),
                    on_frame: num("on_frame")?,
                    process: num("process")?,
                    transmit: num("transmit")?,
                    calls_per_frame: int("transmit_calls")? as f64 / frames,
                });
            }
            Some(("worst", name)) => worst.push(QemuWorst {
                name: name.to_string(),
                on_frame: num("on_frame")?,
                process: num("process")?,
                total: num("total")?,
                longest: num("longest")?,
                calls: int("calls")?,
                sent: int("sent")?,
            }),
            // Each `process` call of a frame that takes several (a reset's stages).
            Some(("stage", _)) => {}
            Some(("isr", "slcan-uart0")) => slcan = Some((int("bytes")?, num("line")?, num("last_byte")?)),
            Some(("isr", "bxcan-fifo0")) => bxcan = Some(num("frame")?),
            _ => return Err(format!("unknown report line: {line}")),
        }
    }
    if !ok {
        return Err(format!("the image did not finish (no `icount-qemu ok`):\n{out}"));
    }
    let (calibration_instructions, calibration_ticks, per_tick, overhead, check) = calibration.ok_or("no calibration line")?;
    for (kind, _) in KINDS {
        if !kinds.iter().any(|k| k.name == kind) {
            return Err(format!("no figures for `{kind}`"));
        }
    }
    if worst.is_empty() {
        return Err("no worst-case figures".into());
    }
    Ok(QemuReport {
        calibration_instructions,
        calibration_ticks,
        per_tick,
        overhead,
        check,
        kinds,
        worst,
        slcan: slcan.ok_or("no SLCAN receive figure")?,
        bxcan: bxcan.ok_or("no bxCAN receive figure")?,
    })
}

fn print_thumbv7m(version: &str, r: &QemuReport, host: &[HostRow]) {
    println!(
        "\nthumbv7m (Cortex-M3) instructions per handled frame: {version}, lm3s6965evb, -icount shift=0 (1 instruction = 1 ns);\n\
         SysTick at SYSDIV 0, calibrated: {} instructions = {} ticks ({} per tick); the reads around a span, {:.2}, subtracted;\n\
         self-check: a straight-line block of {} instructions measured {:.2}:\n",
        r.calibration_instructions, r.calibration_ticks, r.per_tick, r.overhead, r.check.0, r.check.1
    );
    println!(
        "| frame | x86_64 on_frame + process + transmit | thumbv7m on_frame + process + transmit | on_frame | process | transmit (calls) |"
    );
    println!("|---|---:|---:|---:|---:|---:|");
    for ((kind, what), h) in KINDS.iter().zip(host) {
        let Some(k) = r.kinds.iter().find(|k| k.name == *kind) else { continue };
        println!(
            "| {what} | {} | {:.0} | {:.0} | {:.0} | {:.0} ({:.0}) |",
            h.on_frame + h.process + h.transmit,
            k.total(),
            k.on_frame,
            k.process,
            k.transmit,
            k.calls_per_frame
        );
    }
    let mut worst: Vec<&QemuWorst> = r.worst.iter().collect();
    worst.sort_by(|a, b| b.longest.total_cmp(&a.longest));
    println!(
        "\nthumbv7m, one expensive frame: on_frame, then process until no reset is in progress (a stage per call), averages over the runs:\n"
    );
    println!("| frame | longest call | on_frame + process | on_frame | process (calls) | frames queued |");
    println!("|---|---:|---:|---:|---:|---:|");
    for w in &worst {
        println!("| {} | {:.0} | {:.0} | {:.0} | {:.0} ({}) | {} |", w.name, w.longest, w.total, w.on_frame, w.process, w.calls, w.sent);
    }
    if let Some(max) = worst.first() {
        println!("\nworst single call: {} ({:.0} instructions)", max.name, max.longest);
    }
    let (bytes, line, cr) = r.slcan;
    println!(
        "receive interrupts, per frame, without register access: QEMU UART0 (SLCAN, {bytes} bytes = {bytes} interrupts) {line:.0} in all, \
         the CR's (decode + channel push) {cr:.0}; STM32 bxCAN FIFO 0 (conversion + channel push) {:.0}",
        r.bxcan
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "\
Timer with period zero, disabling
icount-qemu calibration instructions=102000 ticks=20400 per_tick=5 overhead=1.01 check_known=1020 check_measured=1019.81
icount-qemu kind=rpdo frames=1000 on_frame=447.0 process=1336.0 transmit=731.1 transmit_calls=1000 sent=0
icount-qemu kind=sdo-upload frames=1000 on_frame=3947.0 process=1336.0 transmit=1245.1 transmit_calls=2000 sent=1000
icount-qemu kind=sdo-download frames=1000 on_frame=900.0 process=300.0 transmit=80.0 transmit_calls=2000 sent=1000
icount-qemu kind=sync frames=1000 on_frame=2857.1 process=810.0 transmit=2933.0 transmit_calls=5000 sent=4000
icount-qemu kind=idle frames=1000 on_frame=0.0 process=100.0 transmit=19.0 transmit_calls=1000 sent=0
icount-qemu kind=cia402 frames=1000 on_frame=2465.0 process=1348.0 transmit=403.0 transmit_calls=2000 sent=1000
icount-qemu kind=cia402-echo frames=1000 on_frame=1709.0 process=1245.0 transmit=393.0 transmit_calls=2000 sent=1000
icount-qemu worst=store-0x1010 on_frame=186046.9 process=456.0 total=186502.9 longest=186046.9 calls=1 sent=1 runs=50
icount-qemu worst=nmt-reset-node on_frame=216777.1 process=1068.0 total=217845.1 longest=216777.1 calls=1 sent=1 runs=50
icount-qemu isr=slcan-uart0 bytes=22 line=2651.6 last_byte=823.0
icount-qemu isr=bxcan-fifo0 frame=206.8
icount-qemu ok
";

    #[test]
    fn parses_the_report() {
        let r = parse_report(GOOD).unwrap();
        assert_eq!((r.calibration_instructions, r.calibration_ticks, r.per_tick), (102_000, 20_400, 5));
        assert_eq!((r.overhead, r.check), (1.01, (1020, 1019.81)));
        assert_eq!(r.kinds.len(), 7);
        let sync = &r.kinds[3];
        assert_eq!(
            (sync.name.as_str(), sync.on_frame, sync.process, sync.transmit, sync.calls_per_frame),
            ("sync", 2857.1, 810.0, 2933.0, 5.0)
        );
        assert_eq!(sync.total(), 2857.1 + 810.0 + 2933.0);
        assert_eq!(
            r.worst[1],
            QemuWorst {
                name: "nmt-reset-node".into(),
                on_frame: 216_777.1,
                process: 1068.0,
                total: 217_845.1,
                longest: 216_777.1,
                calls: 1,
                sent: 1
            }
        );
        assert_eq!(r.slcan, (22, 2651.6, 823.0));
        assert_eq!(r.bxcan, 206.8);
    }

    #[test]
    fn the_cia402_share_is_checked_against_its_budget() {
        // 4216 − 3347 = 869 instructions: within 1,000.
        assert!(cia402_share(&parse_report(GOOD).unwrap()).is_ok());
        let slow = GOOD.replace("kind=cia402 frames=1000 on_frame=2465.0", "kind=cia402 frames=1000 on_frame=2700.0");
        assert!(cia402_share(&parse_report(&slow).unwrap()).unwrap_err().contains("over 1000"));
    }

    #[test]
    fn refuses_incomplete_or_failed_runs() {
        let without_ok = GOOD.replace("icount-qemu ok\n", "");
        assert!(parse_report(&without_ok).unwrap_err().contains("did not finish"));
        let failed = GOOD.replace("icount-qemu ok", "icount-qemu FAILED SYNC: the node sent 3 frame(s)");
        assert!(parse_report(&failed).unwrap_err().contains("FAILED"));
        let no_sync: String = GOOD.lines().filter(|l| !l.contains("kind=sync")).map(|l| format!("{l}\n")).collect();
        assert!(parse_report(&no_sync).unwrap_err().contains("sync"));
        let garbled = GOOD.replace("process=810.0", "process=lots");
        assert!(parse_report(&garbled).unwrap_err().contains("process"));
        let unknown = GOOD.replace("isr=bxcan-fifo0", "isr=mystery");
        assert!(parse_report(&unknown).unwrap_err().contains("unknown"));
    }
}
