//! 64-bit division for the images: a shift-and-subtract loop of about a
//! hundred bytes in place of `compiler_builtins`' 1,030 (`u64_div_rem`
//! 866, `__divmoddi4` 116, `__udivmoddi4` 48). The Cortex-M3 divides 32
//! bits in hardware but not 64, so `u64`/`i64` `/` and `%` become calls of
//! `__aeabi_uldivmod`/`__aeabi_ldivmod`; `compiler_builtins` defines those
//! as small stubs around `__udivmoddi4`/`__divmoddi4`, all of them weakly,
//! so the definitions here win at link time. Only devices whose own
//! arithmetic is 64-bit link them (the Sendix encoder's scaling, the
//! UNITEK servo's unit conversions); the CANopen core divides no `u64`.
//!
//! Two values that fit 32 bits take the hardware's `udiv`; a divisor
//! below 2^16 (an encoder resolution) four of them, one per 16-bit digit;
//! any other divisor one shift-and-subtract step per quotient bit above
//! its leading one (about 20 for microseconds over 10^6, some 300
//! instructions where the library's routine takes a few dozen).

/// `n / d` and `n % d`; `(u64::MAX, n)` for `d == 0` (Rust checks for
/// zero before it divides, so only a C caller could pass it).
pub(crate) fn udivmod(n: u64, d: u64) -> (u64, u64) {
    if d == 0 {
        return (u64::MAX, n);
    }
    if (n | d) >> 32 == 0 {
        let (n, d) = (n as u32, d as u32);
        return (u64::from(n / d), u64::from(n % d));
    }
    if d >> 16 == 0 {
        // A divisor below 2^16 (an encoder resolution): the high word by
        // the hardware, then the low word a 16-bit digit at a time; each
        // remainder is below `d`, so each partial dividend fits 32 bits
        // and each digit's quotient 16 bits.
        let (d, high, low) = (d as u32, (n >> 32) as u32, n as u32);
        let (q_high, r) = (high / d, high % d);
        let partial = (r << 16) | (low >> 16);
        let (q_mid, r) = (partial / d, partial % d);
        let partial = (r << 16) | (low & 0xFFFF);
        let (q_low, r) = (partial / d, partial % d);
        return ((u64::from(q_high) << 32) | u64::from((q_mid << 16) | q_low), u64::from(r));
    }
    if d > n {
        return (0, n);
    }
    // Align the divisor's leading one with the dividend's, then take one
    // quotient bit per shift back.
    let shift = d.leading_zeros() - n.leading_zeros();
    let (mut d, mut r, mut q) = (d << shift, n, 0u64);
    for _ in 0..=shift {
        q <<= 1;
        if r >= d {
            r -= d;
            q |= 1;
        }
        d >>= 1;
    }
    (q, r)
}

/// Signed `n / d` and `n % d`, both rounded toward zero as Rust's are: the
/// quotient negative when the signs differ, the remainder with `n`'s sign.
pub(crate) fn divmod(n: i64, d: i64) -> (i64, i64) {
    let (q, r) = udivmod(n.unsigned_abs(), d.unsigned_abs());
    let q = if (n < 0) != (d < 0) { (q as i64).wrapping_neg() } else { q as i64 };
    let r = if n < 0 { (r as i64).wrapping_neg() } else { r as i64 };
    (q, r)
}

/// The C `__udivmoddi4` that `__aeabi_uldivmod` calls.
///
/// # Safety
/// `rem` null or valid for a `u64` write.
#[cfg(target_os = "none")]
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn __udivmoddi4(n: u64, d: u64, rem: *mut u64) -> u64 {
    let (q, r) = udivmod(n, d);
    if !rem.is_null() {
        // SAFETY: not null, so valid for a write (the caller's contract).
        unsafe { rem.write(r) };
    }
    q
}

/// The C `__divmoddi4` that `__aeabi_ldivmod` calls.
///
/// # Safety
/// `rem` null or valid for an `i64` write.
#[cfg(target_os = "none")]
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn __divmoddi4(n: i64, d: i64, rem: *mut i64) -> i64 {
    let (q, r) = divmod(n, d);
    if !rem.is_null() {
        // SAFETY: not null, so valid for a write (the caller's contract).
        unsafe { rem.write(r) };
    }
    q
}

#[cfg(test)]
mod tests {
    use super::{divmod, udivmod};

    /// Values at the edges (powers of two and their neighbours, 32-bit
    /// limits) and a pseudo-random spread, against the compiler's division.
    fn samples() -> impl Iterator<Item = u64> {
        let edges = (0..64).flat_map(|s| {
            let p = 1u64 << s;
            [p - 1, p, p + 1]
        });
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        let spread = core::iter::from_fn(move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            Some(x >> (x % 64))
        });
        edges.chain([0, u64::MAX, u64::from(u32::MAX), 360_000_000, 1_000_000]).chain(spread.take(400))
    }

    #[test]
    fn unsigned_matches_the_compiler() {
        for n in samples() {
            for d in samples().filter(|&d| d != 0) {
                assert_eq!(udivmod(n, d), (n / d, n % d), "{n} / {d}");
            }
        }
    }

    #[test]
    fn signed_rounds_toward_zero() {
        for n in samples() {
            for d in samples().filter(|&d| d != 0) {
                for (n, d) in [(n as i64, d as i64), (n as i64, (d as i64).wrapping_neg())] {
                    if d == 0 || (n == i64::MIN && d == -1) {
                        continue;
                    }
                    assert_eq!(divmod(n, d), (n / d, n % d), "{n} / {d}");
                }
            }
        }
    }

    #[test]
    fn by_zero_is_defined() {
        assert_eq!(udivmod(7, 0), (u64::MAX, 7));
    }
}
