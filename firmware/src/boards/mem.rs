//! `memcpy` for the images: a word or byte loop of a few dozen bytes in
//! place of `compiler_builtins`' 744-byte one. The compiler calls the ARM
//! EABI names (`__aeabi_memcpy`, `…4`, `…8`), which `compiler_builtins`
//! defines weakly, so these definitions win at link time. The core copies
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
