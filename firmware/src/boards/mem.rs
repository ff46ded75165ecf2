//! `memcpy` and `memclr` for the images: word or byte loops of a few dozen
//! bytes in place of `compiler_builtins`' 744 + 556 bytes. The compiler
//! calls the ARM EABI names (`__aeabi_memcpy`, `__aeabi_memclr`, each with
//! `4` and `8` variants), which `compiler_builtins` defines weakly, so these
//! definitions win at link time. The core copies
//! CAN frames, PDO data and SDO segments, all a handful of bytes: the
//! large-copy paths of the optimised version never run.
#![allow(unsafe_code)]

use core::ptr::{read_volatile, write_volatile};

/// Copies `n` bytes from `src` to `dst`; whole words when both addresses
/// and `n` are word-aligned. A Rust function called by its mangled name:
/// the compiler would turn a call of a function named `memcpy` inside the
/// `__aeabi_memcpy` definitions back into `__aeabi_memcpy`, and the
/// volatile accesses keep it from seeing a copy loop here.
///
/// # Safety
/// The C contract: `src` readable and `dst` writable for `n` bytes, not
/// overlapping.
#[inline(never)]
unsafe fn copy(dst: *mut u8, src: *const u8, n: usize) {
    let mut i = 0;
    if (dst as usize | src as usize | n) & 3 == 0 {
        while i < n {
            // SAFETY: `i + 4 <= n` (n is a multiple of 4), both pointers
            // are word-aligned and valid for `n` bytes (the caller's contract).
            unsafe { write_volatile(dst.add(i).cast::<u32>(), read_volatile(src.add(i).cast::<u32>())) };
            i += 4;
        }
    } else {
        while i < n {
            // SAFETY: `i < n`, and both pointers are valid for `n` bytes (the caller's contract).
            unsafe { write_volatile(dst.add(i), read_volatile(src.add(i))) };
            i += 1;
        }
    }
}

/// The ARM EABI `memcpy` the compiler calls.
///
/// # Safety
/// As [`copy`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn __aeabi_memcpy(dst: *mut u8, src: *const u8, n: usize) {
    // SAFETY: the caller's contract is `copy`'s.
    unsafe { copy(dst, src, n) };
}

/// `__aeabi_memcpy` with word-aligned pointers.
///
/// # Safety
/// As [`copy`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn __aeabi_memcpy4(dst: *mut u8, src: *const u8, n: usize) {
    // SAFETY: the caller's contract is `copy`'s.
    unsafe { copy(dst, src, n) };
}

/// `__aeabi_memcpy` with double-word-aligned pointers.
///
/// # Safety
/// As [`copy`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn __aeabi_memcpy8(dst: *mut u8, src: *const u8, n: usize) {
    // SAFETY: the caller's contract is `copy`'s.
    unsafe { copy(dst, src, n) };
}

/// `memcpy` by its C name, for any caller that uses it.
///
/// # Safety
/// As [`copy`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn memcpy(dst: *mut u8, src: *const u8, n: usize) -> *mut u8 {
    // SAFETY: the caller's contract is `copy`'s.
    unsafe { copy(dst, src, n) };
    dst
}

/// Zeroes `n` bytes at `dst`; whole words when the address and `n` are
/// word-aligned. Volatile stores, for the reason given at [`copy`].
///
/// # Safety
/// `dst` writable for `n` bytes.
#[inline(never)]
unsafe fn zero(dst: *mut u8, n: usize) {
    let mut i = 0;
    if (dst as usize | n) & 3 == 0 {
        while i < n {
            // SAFETY: `i + 4 <= n`, `dst` word-aligned and valid for `n` bytes (the caller's contract).
            unsafe { write_volatile(dst.add(i).cast::<u32>(), 0) };
            i += 4;
        }
    } else {
        while i < n {
            // SAFETY: `i < n`, `dst` valid for `n` bytes (the caller's contract).
            unsafe { write_volatile(dst.add(i), 0) };
            i += 1;
        }
    }
}

/// The ARM EABI `memclr` the compiler calls (zeroing a large value).
///
/// # Safety
/// As [`zero`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn __aeabi_memclr(dst: *mut u8, n: usize) {
    // SAFETY: the caller's contract is `zero`'s.
    unsafe { zero(dst, n) };
}

/// `__aeabi_memclr` with a word-aligned pointer.
///
/// # Safety
/// As [`zero`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn __aeabi_memclr4(dst: *mut u8, n: usize) {
    // SAFETY: the caller's contract is `zero`'s.
    unsafe { zero(dst, n) };
}

/// `__aeabi_memclr` with a double-word-aligned pointer.
///
/// # Safety
/// As [`zero`].
#[unsafe(no_mangle)]
pub unsafe extern "C" fn __aeabi_memclr8(dst: *mut u8, n: usize) {
    // SAFETY: the caller's contract is `zero`'s.
    unsafe { zero(dst, n) };
}

/// Compares `n` bytes at `a` and `b`: the first difference (`a`'s byte
/// minus `b`'s), 0 if equal. A byte loop of a few dozen bytes in place of
/// `compiler_builtins`' 116-byte unrolled one: the core compares a stored
/// value (up to 8 bytes, or an SDO segment's 7) with the one written.
/// Volatile reads, for the reason given at [`copy`].
///
/// # Safety
/// `a` and `b` readable for `n` bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn memcmp(a: *const u8, b: *const u8, n: usize) -> i32 {
    let mut i = 0;
    while i < n {
        // SAFETY: `i < n`, and both pointers are readable for `n` bytes (the caller's contract).
        let (x, y) = unsafe { (read_volatile(a.add(i)), read_volatile(b.add(i))) };
        if x != y {
            return i32::from(x) - i32::from(y);
        }
        i += 1;
    }
    0
}
