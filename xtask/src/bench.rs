//! `cargo xtask bench`: the bus-level benchmarks (docs/benchmarks-bus.md).
//!
//! The benchmarks are the `#[ignore]`d `bench_*` tests of
//! `tests/tests/bus_bench.rs`; they run on virtual time and print their
//! figures on lines starting with `bench:`. This command builds them in
//! release mode, runs each alone, and measures the wall time here, between
//! the `bench-mark: start` and `bench-mark: end` lines the test prints
//! around its simulation (so the tests themselves never read a clock).

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The benchmark tests, in the order they run.
const BENCHES: &[&str] = &["bench_block_upload_64_kib", "bench_127_nodes_60_s"];

pub fn bench() -> Result<(), String> {
    let exe = build()?;
    for name in BENCHES {
        run(&exe, name)?;
    }
    Ok(())
}

/// Builds the `bus_bench` test binary in release mode and returns its path.
fn build() -> Result<PathBuf, String> {
    let args = ["test", "--release", "-p", "canopen-tests", "--test", "bus_bench", "--no-run", "--message-format=json"];
    eprintln!("+ cargo {}", args.join(" "));
    let out =
        Command::new("cargo").args(args).current_dir(super::root()).stderr(Stdio::inherit()).output().map_err(|e| format!("cargo: {e}"))?;
    if !out.status.success() {
        return Err(format!("building the benchmarks failed ({})", out.status));
    }
    // The artifact message of a test target names its executable.
    const KEY: &str = "\"executable\":\"";
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter(|l| l.contains("bus_bench"))
        .find_map(|l| {
            let rest = &l[l.find(KEY)? + KEY.len()..];
            Some(PathBuf::from(&rest[..rest.find('"')?]))
        })
        .ok_or_else(|| "cargo named no bus_bench executable".to_owned())
}

/// Runs one benchmark test, echoes its figures and adds the wall times.
fn run(exe: &PathBuf, name: &str) -> Result<(), String> {
    eprintln!("+ {} --ignored --exact {name} --nocapture", exe.display());
    let started = Instant::now();
    let mut child = Command::new(exe)
        .args(["--ignored", "--exact", name, "--nocapture", "--test-threads=1"])
        .stdout(Stdio::piped())
        .spawn()
        .map_err(|e| format!("{}: {e}", exe.display()))?;
    let stdout = child.stdout.take().ok_or("no stdout")?;
    let (mut start, mut end) = (None::<Duration>, None::<Duration>);
    for line in BufReader::new(stdout).lines() {
        let line = line.map_err(|e| e.to_string())?;
        let at = started.elapsed();
        // libtest may print "test <name> ... " in front of the first line.
        let mark = line.find("bench-mark: ").map(|i| line[i + "bench-mark: ".len()..].trim());
        match (mark, line.find("bench:")) {
            (Some("start"), _) => start = Some(at),
            (Some("end"), _) => end = Some(at),
            (None, Some(i)) => println!("{}", &line[i..]),
            _ => {}
        }
    }
    let status = child.wait().map_err(|e| e.to_string())?;
    let total = started.elapsed();
    if !status.success() {
        return Err(format!("benchmark {name} failed ({status})"));
    }
    let (Some(start), Some(end)) = (start, end) else { return Err(format!("benchmark {name} printed no bench-mark lines")) };
    println!(
        "bench:   wall time {:.3} s for the simulation ({:.3} s for the whole test process, setup included), release build",
        end.saturating_sub(start).as_secs_f64(),
        total.as_secs_f64()
    );
    Ok(())
}
