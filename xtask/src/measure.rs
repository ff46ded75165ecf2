//! `cargo xtask size` and `cargo xtask icount`: what the stack costs in
//! flash and RAM on the MCU, and in instructions per frame on the host and
//! on thumbv7m.
//!
//! - `size`: builds `bench/size` (a node's main loop, with the board behind C
//!   callbacks) as a fat-LTO staticlib for thumbv7m, once per dictionary,
//!   links each with rust-lld `--gc-sections` (the `#[used]` entry tables are
//!   the roots), and reports `.text`/`.rodata`/`.data`/`.bss`, where `.text`
//!   comes from (by the DWARF line table, so inlined code counts where it was
//!   written) and the largest symbols.
//! - `icount [N]`: [`icount`] (its own module): `bench/icount` under
//!   callgrind on the host, `bench/icount-qemu` in QEMU with `-icount`.

mod icount;

pub use icount::icount;

use super::{TARGET, ensure_target, root, run};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The images `size` builds: name, `bench/size` feature, what it is.
const IMAGES: &[(&str, &str, &str)] = &[
    ("core", "interop", "every service, interop test dictionary (4 RPDO / 4 TPDO, tests/eds/interop.eds)"),
    ("ds301", "ds301", "CANopenNode's CiA 301 profile + 0x100C/0x100D (4 RPDO / 4 TPDO, 8 heartbeat consumers)"),
    ("ds301-lean", "ds301-lean", "CANopenNode's CiA 301 profile, CANopenNode's default services (no block SDO, guarding, storage)"),
    ("ec5000", "ec5000", "device"),
    ("unitek-ds", "unitek-ds", "device"),
    ("sendix", "sendix", "device"),
    ("bmaxx4400", "bmaxx4400", "device"),
    ("agile", "agile", "device"),
];

/// Runs a tool, returning its stdout; fails on a non-zero exit.
fn tool(program: &Path, args: &[&str]) -> Result<String, String> {
    let out = Command::new(program).args(args).current_dir(root()).output().map_err(|e| format!("{}: {e}", program.display()))?;
    if !out.status.success() {
        return Err(format!(
            "`{} {}` failed ({}):\n{}",
            program.display(),
            args.join(" "),
            out.status,
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| root().join("target"), PathBuf::from)
}

/// The directory of rustup's llvm-tools, installing them if missing.
fn llvm_tools() -> Result<PathBuf, String> {
    let sysroot = tool(Path::new("rustc"), &["--print", "sysroot"])?;
    let host = tool(Path::new("rustc"), &["--print", "host-tuple"])?;
    let bin = Path::new(sysroot.trim()).join("lib/rustlib").join(host.trim()).join("bin");
    if !bin.join("llvm-size").exists() {
        run("rustup", &["component", "add", "llvm-tools"])?;
    }
    Ok(bin)
}

/// Sizes of one linked image.
#[derive(Default)]
struct Image {
    sections: BTreeMap<&'static str, u64>,
    /// `.text` bytes by where the source lives.
    text_by_origin: BTreeMap<String, u64>,
    /// (size, section kind, demangled name without hash).
    symbols: Vec<(u64, char, String)>,
}

impl Image {
    fn section(&self, name: &str) -> u64 {
        self.sections.get(name).copied().unwrap_or(0)
    }

    /// Bytes of symbols of `kind` (nm letter, lower case) whose name satisfies `f`.
    fn symbol_bytes(&self, kind: char, f: impl Fn(&str) -> bool) -> u64 {
        self.symbols.iter().filter(|(_, k, n)| k.eq_ignore_ascii_case(&kind) && f(n)).map(|(s, ..)| s).sum()
    }

    /// The dictionary's flash tables (the generated `od` module's statics).
    fn dictionary_rodata(&self) -> u64 {
        self.symbol_bytes('r', |n| (n.starts_with("canopen_size::") || n.starts_with("canopen_firmware::")) && n.contains("od::"))
    }

    /// `.text` from `origin`s starting with `prefix`.
    fn text_from(&self, prefix: &str) -> u64 {
        self.text_by_origin.iter().filter(|(k, _)| k.starts_with(prefix)).map(|(_, v)| v).sum()
    }
}

/// Which part of the source tree `file` (from the line table) belongs to.
fn origin(file: &str, root: &str) -> String {
    if let Some(rel) = file.strip_prefix(root).map(|r| r.trim_start_matches('/')) {
        if let Some(core) = rel.strip_prefix("firmware/core/src/") {
            let parts: Vec<&str> = core.split('/').collect();
            let module = match parts.as_slice() {
                ["services", svc, ..] => format!("services/{}", svc.trim_end_matches(".rs")),
                [dir, _, ..] => (*dir).to_string(),
                [file] => file.trim_end_matches(".rs").to_string(),
                [] => String::new(),
            };
            return format!("core/{module}");
        }
        if rel.starts_with("bench/size") {
            return "board loop (bench/size)".into();
        }
        if rel.starts_with("target/") {
            return "generated dictionary code".into();
        }
        return rel.to_string();
    }
    if let Some(i) = file.find("/library/core/src/") {
        let lib = &file[i + "/library/core/src/".len()..];
        let module = lib.split('/').next().unwrap_or(lib).trim_end_matches(".rs");
        return format!("rust libcore/{module}");
    }
    if file.contains("compiler_builtins") || file.contains("compiler-builtins") {
        return "compiler_builtins".into();
    }
    if let Some(i) = file.find("/registry/src/") {
        let krate = file[i..].split('/').nth(4).unwrap_or(file);
        return format!("crate {krate}");
    }
    file.to_string()
}

/// `.text` bytes per origin, from `llvm-objdump -d -l`: each instruction
/// (or literal-pool word) counts for the source line the table gives it.
fn text_by_origin(objdump: &Path, elf: &str, text_end: u64) -> Result<BTreeMap<String, u64>, String> {
    let listing = tool(objdump, &["-d", "-l", "--no-show-raw-insn", elf])?;
    let root = root().to_string_lossy().into_owned();
    let mut current = String::from("(no line info)");
    // Inside a compiler_builtins routine everything counts as compiler_builtins,
    // also the libcore code it inlines.
    let mut in_builtins = false;
    let mut marks: Vec<(u64, String)> = Vec::new();
    for line in listing.lines() {
        if let Some((_, sym)) = line.split_once(" <")
            && let Some(sym) = sym.strip_suffix(">:")
            && !line.starts_with(' ')
        {
            in_builtins = sym.contains("compiler_builtins") || sym.starts_with("__") || sym.starts_with("mem") || sym == "bcmp";
            continue;
        }
        if let Some(loc) = line.strip_prefix("; ") {
            if in_builtins {
                current = String::from("compiler_builtins");
            } else if let Some((file, _line)) = loc.rsplit_once(':')
                && file.starts_with('/')
            {
                current = origin(file, &root);
            } else if loc.ends_with("():") {
                // A new function: no source until a line-table row gives one.
                current = String::from("(no line info)");
            }
            continue;
        }
        let trimmed = line.trim_start();
        if line.starts_with(' ')
            && let Some((addr, _)) = trimmed.split_once(':')
            && let Ok(addr) = u64::from_str_radix(addr, 16)
        {
            marks.push((addr, current.clone()));
        }
    }
    marks.sort_by_key(|(a, _)| *a);
    let mut out = BTreeMap::new();
    for (i, (addr, origin)) in marks.iter().enumerate() {
        let next = marks.get(i + 1).map_or(text_end, |(a, _)| *a);
        *out.entry(origin.clone()).or_insert(0) += next.saturating_sub(*addr);
    }
    Ok(out)
}

/// A symbol as `llvm-nm -C` leaves a legacy Rust name, made readable:
/// the `$LT$`-style escapes decoded and the hash dropped.
fn readable(name: &str) -> String {
    let base = match name.rsplit_once("::h") {
        Some((base, hash)) if hash.len() == 16 && hash.bytes().all(|b| b.is_ascii_hexdigit()) => base,
        _ => name,
    };
    let mut out = base.strip_prefix('_').filter(|b| b.starts_with('$')).unwrap_or(base).to_string();
    for (from, to) in [
        ("$LT$", "<"),
        ("$GT$", ">"),
        ("$C$", ","),
        ("$u20$", " "),
        ("$RF$", "&"),
        ("$BP$", "*"),
        ("$u27$", "'"),
        ("$u5b$", "["),
        ("$u5d$", "]"),
        ("$u7b$", "{"),
        ("$u7d$", "}"),
        ("$u3b$", ";"),
        ("$u2b$", "+"),
        ("$u22$", "\""),
        ("..", "::"),
    ] {
        out = out.replace(from, to);
    }
    out
}

/// Builds, links and measures one image.
fn measure_image(tools: &Path, name: &str, feature: &str) -> Result<Image, String> {
    let features = format!("--features={feature}");
    run(
        "cargo",
        &[
            "rustc",
            "--quiet",
            "-p",
            "canopen-size",
            "--release",
            "--target",
            TARGET,
            "--no-default-features",
            &features,
            "--crate-type",
            "staticlib",
        ],
    )?;
    let lib = target_dir().join(TARGET).join("release/libcanopen_size.a");
    let out_dir = target_dir().join("size");
    std::fs::create_dir_all(&out_dir).map_err(|e| e.to_string())?;
    let elf = out_dir.join(format!("{name}.elf"));
    let (lib, elf) = (lib.to_string_lossy().into_owned(), elf.to_string_lossy().into_owned());
    tool(&tools.join("rust-lld"), &["-flavor", "gnu", "--gc-sections", "--entry=0", "--whole-archive", &lib, "-o", &elf])?;

    let mut image = Image::default();
    let mut text_end = 0;
    for line in tool(&tools.join("llvm-size"), &["-A", &elf])?.lines() {
        let cols: Vec<&str> = line.split_whitespace().collect();
        if let [section, size, addr] = cols.as_slice()
            && let (Ok(size), Ok(addr)) = (size.parse::<u64>(), addr.parse::<u64>())
        {
            let key = match *section {
                s if s.starts_with(".text") => ".text",
                s if s.starts_with(".rodata") => ".rodata",
                s if s.starts_with(".data") => ".data",
                s if s.starts_with(".bss") => ".bss",
                _ => continue,
            };
            *image.sections.entry(key).or_insert(0) += size;
            if key == ".text" {
                text_end = text_end.max(addr + size);
            }
        }
    }
    for line in tool(&tools.join("llvm-nm"), &["-S", "--size-sort", "-C", &elf])?.lines() {
        let mut cols = line.splitn(4, ' ');
        if let (Some(_), Some(size), Some(kind), Some(sym)) = (cols.next(), cols.next(), cols.next(), cols.next())
            && let (Ok(size), Some(kind)) = (u64::from_str_radix(size, 16), kind.chars().next())
        {
            image.symbols.push((size, kind.to_ascii_lowercase(), readable(sym)));
        }
    }
    image.symbols.sort_by(|a, b| b.0.cmp(&a.0).then_with(|| a.2.cmp(&b.2)));
    image.text_by_origin = text_by_origin(&tools.join("llvm-objdump"), &elf, text_end)?;
    Ok(image)
}

fn kib(bytes: u64) -> String {
    format!("{:.1} KiB", bytes as f64 / 1024.0)
}

pub fn size() -> Result<(), String> {
    ensure_target()?;
    let tools = llvm_tools()?;
    let mut images = Vec::new();
    for &(name, feature, what) in IMAGES {
        eprintln!("xtask size: {name} ({what})");
        images.push((name, measure_image(&tools, name, feature)?));
    }

    println!("\nthumbv7m-none-eabi, release profile (opt-level \"s\", fat LTO, codegen-units 1), linked with --gc-sections;");
    println!("a node in a static plus the main loop (bench/size), the board behind C callbacks. Bytes:\n");
    println!(
        "| image | .text | canopen-core (with the libcore it inlines) | compiler_builtins | board loop | .rodata | dictionary tables | .data | .bss (node) | flash (.text + .rodata + .data) |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (name, img) in &images {
        let (text, rodata, data, bss) = (img.section(".text"), img.section(".rodata"), img.section(".data"), img.section(".bss"));
        let (builtins, board) = (img.text_from("compiler_builtins"), img.text_from("board loop"));
        let node = img.symbol_bytes('b', |n| n.ends_with("::NODE"));
        println!(
            "| {name} | {text} | {} | {builtins} | {board} | {rodata} | {} | {data} | {bss} ({node}) | {} ({}) |",
            text.saturating_sub(builtins + board),
            img.dictionary_rodata(),
            text + rodata + data,
            kib(text + rodata + data)
        );
    }

    for (name, img) in &images {
        let text = img.section(".text").max(1);
        let mut origins: Vec<(&String, &u64)> = img.text_by_origin.iter().collect();
        origins.sort_by(|a, b| b.1.cmp(a.1).then_with(|| a.0.cmp(b.0)));
        let shown = if *name == "core" { origins.len() } else { 6 };
        println!("\n{name}: .text by source ({} total; line table, inlined code counted where it was written)", img.section(".text"));
        for (origin, bytes) in origins.iter().take(shown) {
            println!("  {:>6}  {:>4.1}%  {origin}", bytes, **bytes as f64 * 100.0 / text as f64);
        }
        if *name == "core" {
            println!("\n{name}: largest symbols (t = .text, r = .rodata, b = .bss)");
            for (size, kind, sym) in img.symbols.iter().take(20) {
                println!("  {size:>6}  {kind}  {sym}");
            }
        }
    }
    println!("\nAgainst CANopenNode v4 (Cortex-M3, GCC -Os, gc-sections, the same dictionary; ../shared/notes/perf-review.md §4.4):\n");
    println!("| image | flash | CANopenNode, same services | ratio |");
    println!("|---|---:|---:|---:|");
    for (name, img) in &images {
        let Some(&(_, c, what)) = CANOPENNODE.iter().find(|(n, _, _)| n == name) else { continue };
        let flash = img.section(".text") + img.section(".rodata") + img.section(".data");
        println!("| {name} | {flash} ({}) | {c} ({what}) | {:.2} |", kib(flash), flash as f64 / c as f64);
    }
    println!("\nELF files: {}", target_dir().join("size").display());
    Ok(())
}

/// CANopenNode's flash for the `ds301` images' services: image, bytes, configuration.
const CANOPENNODE: &[(&str, u64, &str)] =
    &[("ds301", 21_164, "block SDO, CRC16 and node guarding on"), ("ds301-lean", 18_680, "default configuration")];
