//! Stack use, measured: the free stack (from the end of static RAM,
//! cortex-m-rt's `_stack_end`, up to the current stack pointer) is painted
//! with a pattern; the deepest word no longer holding it marks the most
//! stack any code used since. The QEMU board paints at reset and again once
//! the node is built; the exit frame reports both figures (`board::exit`),
//! which the QEMU smoke test checks. The STM32 board paints at reset and
//! logs the figure whenever it grew (docs/hardware-test.md).
#![allow(unsafe_code)]

use core::ptr;

/// What painted stack holds until code uses it.
const PAINT: u32 = 0x5AC4_57AC;
/// Bytes left unpainted below the stack pointer [`paint`] reads: the
/// compiler may push that function's own frame after the read (shrink-wrapping).
const SLACK: usize = 64;

unsafe extern "C" {
    /// The lowest address the stack may grow to (cortex-m-rt's `link.x`: the end of `.uninit`).
    static _stack_end: u32;
    /// The initial stack pointer (cortex-m-rt's `link.x`: the top of RAM).
    static _stack_start: u32;
}

/// Bottom and top of the stack region.
fn region() -> (usize, usize) {
    // Only the symbols' addresses are taken; their "values" are never read.
    (ptr::addr_of!(_stack_end) as usize, ptr::addr_of!(_stack_start) as usize)
}

/// Paints the stack below the caller's frame. An interrupt taken meanwhile
/// pushes its frame below the stack pointer, where the paint it overwrites
/// is painted again when the loop resumes (or, past the loop, counts as used).
#[inline(never)]
pub fn paint() {
    let (bottom, _) = region();
    // Nothing lives below the stack pointer but this function's own frame
    // (within SLACK), and it makes no call while it paints.
    let end = (cortex_m::register::msp::read() as usize).saturating_sub(SLACK);
    let mut at = bottom;
    while at + 4 <= end {
        // SAFETY: `at` is word-aligned (`_stack_end` is, link.x asserts it)
        // and lies between the end of static RAM and below this function's
        // frame, memory no Rust object occupies.
        unsafe { ptr::write_volatile(at as *mut u32, PAINT) };
        at += 4;
    }
}

/// Bytes of stack used at most since [`paint`]: from the top of RAM down to
/// the deepest word that lost its paint.
pub fn high_water() -> usize {
    let (bottom, top) = region();
    let mut at = bottom;
    // SAFETY: as in `paint`, word-aligned addresses inside the stack region;
    // reading a word the running code also uses is a plain load.
    while at < top && unsafe { ptr::read_volatile(at as *const u32) } == PAINT {
        at += 4;
    }
    top - at
}

/// Bytes between the end of static RAM and the top of RAM.
pub fn size() -> usize {
    let (bottom, top) = region();
    top - bottom
}
