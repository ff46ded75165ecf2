//! Worst-case stack of a firmware image, from its machine code (no
//! nightly, no extra tool: the disassembly `objdump` prints).
//!
//! - Each function's frame is what its instructions take from `sp`:
//!   `push`/`stmdb sp!`/`str rX, [sp, #-4]!` and `sub sp, …`, all of them
//!   added up (a function that saves registers on two paths counts both).
//! - Calls are the direct `bl`/`blx`/`b` to a function's first instruction
//!   (tail calls counted as calls). An indirect call (`blx rN`, `bx rN`, a
//!   vtable or an embassy task's poll) may reach any function whose address
//!   the image takes: a `.word` in the code, a `movw`/`movt` pair, or a
//!   word of `.rodata`/`.data`. A call back into a function already on the
//!   path (recursion through such an edge) adds nothing.
//! - Thread mode starts at `Reset`, in two phases. Start-up builds the node
//!   (`canopen_firmware::app::Started::build`, which returns before the executors
//!   start) with only SysTick running; afterwards every interrupt is on.
//!   Each interrupt priority level adds its deepest handler plus the 32-byte
//!   exception frame the core stacks (36 with alignment padding), since a
//!   handler preempts only lower levels.
//!
//! An estimate, not a proof: every indirect call is taken to reach the
//! deepest address-taken function (far more than any really does), but the
//! cycles that makes are cut (see [`Walker`]), and code the image reaches
//! only through an address built at run time would be missed. The QEMU
//! smoke test checks the stack it measures against it.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::Path;
use std::process::Command;

/// Bytes the core pushes when it takes an exception (8 words), plus the
/// alignment word it may add (CCR.STKALIGN).
const EXCEPTION_FRAME: u64 = 36;
/// The start-up phase: the function that builds the node (demangled name).
const STARTUP: &str = "canopen_firmware::app::Started::build";
/// The only interrupt enabled during start-up.
const STARTUP_HANDLER: &str = "SysTick";

/// One function of the image.
#[derive(Debug, Default)]
struct Function {
    name: String,
    frame: u64,
    /// Start addresses of the functions it calls directly.
    calls: BTreeSet<u64>,
    /// It calls through a register.
    indirect: bool,
}

/// The figures for one image, in bytes.
#[derive(Clone, Debug)]
pub struct Estimate {
    /// Start-up: the deepest path from `Reset`, the node's construction
    /// included, plus SysTick's handler.
    pub startup: u64,
    /// Deepest thread-mode path from `Reset` once the executors run.
    pub thread: u64,
    /// Deepest handler per priority level (with its exception frame), highest priority last.
    pub levels: Vec<(u8, u64)>,
    /// The larger of start-up and thread mode plus every level preempting it.
    pub worst: u64,
    /// The function with the largest frame, and that frame.
    pub largest: (String, u64),
}

impl Estimate {
    /// Thread mode plus every level preempting it: the stack once the executors run.
    pub fn running(&self) -> u64 {
        self.thread + self.levels.iter().map(|(_, d)| d).sum::<u64>()
    }
}

/// Interrupt handlers per priority level of each board (`boards/*/board.rs`,
/// `boards/systick.rs`; 0 is the highest priority, and the default).
pub fn handlers(board: &str) -> &'static [(&'static str, u8)] {
    match board {
        "qemu" => &[("SysTick", 0), ("UART0", 0), ("GPIOA", 1)],
        "stm32f103" => &[("SysTick", 0), ("USB_HP_CAN_TX", 1), ("USB_LP_CAN_RX0", 1), ("CAN_SCE", 1), ("TAMPER", 2)],
        _ => &[],
    }
}

/// Disassembles `elf` with GNU objdump from binutils-arm-none-eabi, else LLVM's.
fn disassemble(elf: &Path) -> Result<String, String> {
    for tool in ["arm-none-eabi-objdump", "llvm-objdump"] {
        if let Ok(out) = Command::new(tool).args(["-d", "-C", "--no-show-raw-insn"]).arg(elf).output()
            && out.status.success()
        {
            return Ok(String::from_utf8_lossy(&out.stdout).into_owned());
        }
    }
    Err("no objdump: `apt-get install binutils-arm-none-eabi` (or llvm)".into())
}

/// The words of the sections holding constants and initialised data.
fn data_words(elf: &Path) -> Vec<u64> {
    let mut words = Vec::new();
    for tool in ["arm-none-eabi-objdump", "llvm-objdump"] {
        let Ok(out) = Command::new(tool).args(["-s", "-j", ".rodata", "-j", ".data"]).arg(elf).output() else { continue };
        if !out.status.success() {
            continue;
        }
        for line in String::from_utf8_lossy(&out.stdout).lines() {
            // " 800a3d8 01020304 05060708 ...  ascii": little-endian words after the address.
            let mut fields = line.split_whitespace();
            if fields.next().is_none_or(|a| u64::from_str_radix(a, 16).is_err()) {
                continue;
            }
            for field in fields.take(4) {
                if field.len() != 8 {
                    break;
                }
                let Ok(be) = u32::from_str_radix(field, 16) else { break };
                words.push(u64::from(be.swap_bytes()));
            }
        }
        break;
    }
    words
}

/// The first number in `text` (hex with `0x`, or as objdump prints branch targets: bare hex).
fn hex_target(operands: &str) -> Option<u64> {
    let token = operands.split_whitespace().next()?;
    u64::from_str_radix(token.trim_start_matches("0x"), 16).ok()
}

/// The registers in `{r4, r5, lr}`.
fn register_count(operands: &str) -> u64 {
    let Some(list) = operands.split('{').nth(1).and_then(|s| s.split('}').next()) else { return 0 };
    list.split(',').map(|r| r.trim()).filter(|r| !r.is_empty()).count() as u64
}

/// The immediate of `#123` (or `#0x7b`).
fn immediate(operands: &str) -> Option<u64> {
    let imm = operands.split('#').nth(1)?.split(|c: char| c.is_whitespace() || c == ']' || c == '@').next()?;
    match imm.strip_prefix("0x") {
        Some(hex) => u64::from_str_radix(hex, 16).ok(),
        None => imm.parse().ok(),
    }
}

/// Bytes one instruction takes from the stack.
fn stack_taken(mnemonic: &str, operands: &str) -> u64 {
    let ops = operands.replace(' ', "");
    match mnemonic {
        "push" | "push.w" => 4 * register_count(operands),
        "stmdb" | "stmdb.w" | "stmfd" if ops.starts_with("sp!") => 4 * register_count(operands),
        "str" | "str.w" if ops.contains("[sp,#-4]!") => 4,
        "sub" | "sub.w" | "subw" | "subs" if ops.starts_with("sp,") => immediate(operands).unwrap_or(0),
        _ => 0,
    }
}

/// Reads the functions of an objdump disassembly, and the addresses its code takes.
fn parse(listing: &str) -> (BTreeMap<u64, Function>, BTreeSet<u64>) {
    let mut functions = BTreeMap::new();
    let mut taken = BTreeSet::new();
    let mut current: Option<(u64, Function)> = None;
    // The last `movw` per register, for a following `movt`.
    let mut low: HashMap<String, u64> = HashMap::new();
    for line in listing.lines() {
        let trimmed = line.trim();
        // "08004f06 <name>:" opens a function.
        if let Some((addr, rest)) = trimmed.split_once(" <")
            && let (Ok(addr), Some(name)) = (u64::from_str_radix(addr, 16), rest.strip_suffix(">:"))
        {
            if let Some((start, f)) = current.take() {
                functions.insert(start, f);
            }
            current = Some((addr, Function { name: name.to_owned(), ..Function::default() }));
            low.clear();
            continue;
        }
        let Some((_, insn)) = trimmed.split_once(':') else { continue };
        let insn = insn.trim();
        let (mnemonic, operands) = insn.split_once(char::is_whitespace).unwrap_or((insn, ""));
        let operands = operands.trim();
        let Some((_, f)) = current.as_mut() else { continue };
        f.frame += stack_taken(mnemonic, operands);
        let first = operands.split(',').next().unwrap_or("").trim();
        match mnemonic {
            ".word" => {
                if let Some(w) = hex_target(operands) {
                    taken.insert(w);
                }
            }
            "movw" => {
                if let Some(v) = immediate(operands) {
                    low.insert(first.to_owned(), v);
                }
            }
            "movt" => {
                if let (Some(hi), Some(lo)) = (immediate(operands), low.get(first)) {
                    taken.insert(hi << 16 | lo);
                }
            }
            "bl" | "blx" | "b" | "b.w" | "b.n" => match hex_target(operands) {
                Some(target) => {
                    f.calls.insert(target);
                }
                None if mnemonic == "blx" => f.indirect = true,
                None => {}
            },
            "bx" if first != "lr" => f.indirect = true,
            _ => {}
        }
    }
    if let Some((start, f)) = current {
        functions.insert(start, f);
    }
    (functions, taken)
}

/// Depth-first worst path. A call back into a function already on the
/// path adds nothing, and each function's depth is worked out once, on the
/// first path that reaches it (so a cycle the indirect calls make is cut
/// where that path entered it).
struct Walker<'a> {
    functions: &'a BTreeMap<u64, Function>,
    /// Address-taken functions (indirect call targets).
    pointers: Vec<u64>,
    memo: HashMap<u64, u64>,
    on_path: BTreeSet<u64>,
    /// A function left out (as if it took no stack).
    skip: Option<u64>,
}

impl Walker<'_> {
    fn new(functions: &BTreeMap<u64, Function>, pointers: Vec<u64>, skip: Option<u64>) -> Walker<'_> {
        Walker { functions, pointers, memo: HashMap::new(), on_path: BTreeSet::new(), skip }
    }

    /// The deepest path from `at`.
    fn depth(&mut self, at: u64) -> u64 {
        if let Some(&d) = self.memo.get(&at) {
            return d;
        }
        let Some(f) = self.functions.get(&at) else { return 0 };
        if self.skip == Some(at) || !self.on_path.insert(at) {
            return 0;
        }
        let mut callees: Vec<u64> = f.calls.iter().copied().filter(|c| *c != at && self.functions.contains_key(c)).collect();
        if f.indirect {
            callees.extend(self.pointers.iter().copied());
        }
        let deepest = callees.into_iter().map(|c| self.depth(c)).max().unwrap_or(0);
        self.on_path.remove(&at);
        let d = f.frame + deepest;
        self.memo.insert(at, d);
        d
    }
}

/// Estimates the stack `elf` needs on `board`.
pub fn estimate(elf: &Path, board: &str) -> Result<Estimate, String> {
    let (functions, mut taken) = parse(&disassemble(elf)?);
    taken.extend(data_words(elf));
    // Thumb function pointers have bit 0 set; code addresses in `.word`s may not.
    let pointers: Vec<u64> =
        taken.iter().map(|w| w & !1).filter(|a| functions.contains_key(a)).collect::<BTreeSet<_>>().into_iter().collect();
    let by_name: HashMap<&str, u64> = functions.iter().map(|(a, f)| (f.name.as_str(), *a)).collect();
    let find = |name: &str| by_name.get(name).copied().ok_or_else(|| format!("{}: no function {name}", elf.display()));
    let reset = find("Reset")?;
    // A generic function: one instance per image (its demangled name may carry a suffix).
    let build = functions
        .iter()
        .find(|(_, f)| f.name.starts_with(STARTUP))
        .map(|(a, _)| *a)
        .ok_or_else(|| format!("{}: no function {STARTUP}", elf.display()))?;
    let mut walker = Walker::new(&functions, pointers.clone(), None);
    let startup = walker.depth(reset) + walker.depth(find(STARTUP_HANDLER)?) + EXCEPTION_FRAME;
    let mut levels: BTreeMap<u8, u64> = BTreeMap::new();
    for (name, level) in handlers(board) {
        let d = walker.depth(find(name)?) + EXCEPTION_FRAME;
        let slot = levels.entry(*level).or_default();
        *slot = (*slot).max(d);
    }
    let levels: Vec<(u8, u64)> = levels.into_iter().rev().collect();
    let mut running = Walker::new(&functions, pointers, Some(build));
    let thread = running.depth(reset);
    let largest = functions.values().max_by_key(|f| f.frame).map(|f| (f.name.clone(), f.frame)).unwrap_or_default();
    let mut estimate = Estimate { startup, thread, levels, worst: 0, largest };
    estimate.worst = startup.max(estimate.running());
    Ok(estimate)
}

#[cfg(test)]
mod tests {
    use super::*;

    const LISTING: &str = "
00000100 <Reset>:
     100:\tpush\t{r7, lr}
     102:\tbl\t200 <main>
     106:\tpop\t{r7, pc}

00000200 <main>:
     200:\tpush\t{r4, r5, r6, r7, lr}
     202:\tsub.w\tsp, sp, #1024\t@ 0x400
     206:\tmovw\tr1, #769\t@ 0x301
     20a:\tmovt\tr1, #0
     20e:\tblx\tr1
     210:\tb.w\t400 <leaf>

00000300 <pointed>:
     300:\tstmdb\tsp!, {r8, r9, sl, fp}
     304:\tsub\tsp, #16
     306:\tbl\t200 <main>
     30a:\tbx\tlr

00000400 <leaf>:
     400:\tstr.w\tr4, [sp, #-4]!
     404:\tsubs\tr0, #1
     406:\tbx\tlr

00000500 <SysTick>:
     500:\tpush\t{r7, lr}
     502:\tbl\t400 <leaf>
";

    #[test]
    fn frames_calls_and_pointers_come_from_the_listing() {
        let (functions, taken) = parse(LISTING);
        let frames: Vec<(&str, u64)> = functions.values().map(|f| (f.name.as_str(), f.frame)).collect();
        assert_eq!(frames, [("Reset", 8), ("main", 1044), ("pointed", 32), ("leaf", 4), ("SysTick", 8)]);
        assert!(functions[&0x200].indirect);
        assert_eq!(functions[&0x200].calls, BTreeSet::from([0x400]));
        assert_eq!(taken, BTreeSet::from([0x301]));
    }

    #[test]
    fn indirect_calls_take_the_deepest_pointer_and_recursion_is_cut() {
        let (functions, _) = parse(LISTING);
        let mut walker = Walker::new(&functions, vec![0x300], None);
        // Reset 8 + main 1044 + pointed 32 (its call back into main adds nothing).
        assert_eq!(walker.depth(0x100), 8 + 1044 + 32);
        assert_eq!(walker.depth(0x500), 8 + 4);
        // Leaving `pointed` out: Reset 8 + main 1044 + leaf 4.
        let mut walker = Walker::new(&functions, vec![0x300], Some(0x300));
        assert_eq!(walker.depth(0x100), 8 + 1044 + 4);
    }
}
