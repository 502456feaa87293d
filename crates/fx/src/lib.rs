//! The firmware's wide operations, for Q-format arithmetic in `i32`:
//! `mul_shr(a, b, sh)` = round((a b) >> sh) and `div_shl(n, d, sh)` = (n 2^sh) / d, both
//! saturated to `i32`.
//!
//! On the 68020 they are `__fx_mul_shr` and `__fx_div` in the runtime's assembly
//! (`crates/rt/asm/rt.S`): MULS.L gives the 64-bit product in two registers, DIVS.L divides
//! a 64-bit dividend. Compiled 64-bit code is avoided because
//! LLVM's M68k backend miscompiles its compare sequences (docs/toolchain.md). On the host it
//! is the same arithmetic in `i64`; a system test runs both on the same inputs and requires
//! identical bits.
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]

pub mod trig;

/// round((a * b) / 2^sh) saturated to `i32`; `sh` in 1..=32.
#[inline(always)]
pub fn mul_shr(a: i32, b: i32, sh: u32) -> i32 {
    debug_assert!((1..=32).contains(&sh));
    #[cfg(target_arch = "m68k")]
    {
        extern "C" {
            fn __fx_mul_shr(a: i32, b: i32, sh: u32) -> i32;
            fn __fx_mul_shr8(a: i32, b: i32) -> i32;
            fn __fx_mul_shr16(a: i32, b: i32) -> i32;
            fn __fx_mul_shr17(a: i32, b: i32) -> i32;
            fn __fx_mul_shr24(a: i32, b: i32) -> i32;
            fn __fx_mul_shr32(a: i32, b: i32) -> i32;
        }
        // SAFETY: pure functions in the runtime's assembly, linked into every image. The
        // shift is a constant wherever this is inlined, so the match folds to one call;
        // the fixed-shift routines skip the variable shift (half the cycles).
        unsafe {
            match sh {
                8 => __fx_mul_shr8(a, b),
                16 => __fx_mul_shr16(a, b),
                17 => __fx_mul_shr17(a, b),
                24 => __fx_mul_shr24(a, b),
                32 => __fx_mul_shr32(a, b),
                _ => __fx_mul_shr(a, b, sh),
            }
        }
    }
    #[cfg(not(target_arch = "m68k"))]
    {
        host_mul_shr(a, b, sh)
    }
}

/// floor((a * b) / 2^24), the low 32 bits (the caller keeps the result within `i32`): one
/// 64-bit `MULS.L` on the 68020 (`__fx_mul_floor_shr24`; compiled, an `i64` product is a
/// `__muldi3` call).
#[inline(always)]
pub fn mul_floor_shr24(a: i32, b: i32) -> i32 {
    #[cfg(target_arch = "m68k")]
    {
        extern "C" {
            fn __fx_mul_floor_shr24(a: i32, b: i32) -> i32;
        }
        // SAFETY: a pure function in the runtime's assembly, linked into every image.
        unsafe { __fx_mul_floor_shr24(a, b) }
    }
    #[cfg(not(target_arch = "m68k"))]
    {
        host_mul_floor_shr24(a, b)
    }
}

/// The host implementation of [`mul_floor_shr24`] (the reference the image's is tested
/// against).
pub const fn host_mul_floor_shr24(a: i32, b: i32) -> i32 {
    ((a as i64 * b as i64) >> 24) as i32
}

/// (num * 2^sh) / den truncated toward zero, saturated to `i32`; `sh` in 0..=31. A zero
/// `den` saturates toward the sign of `num` (`i32::MAX` for 0).
#[inline]
pub fn div_shl(num: i32, den: i32, sh: u32) -> i32 {
    debug_assert!(sh <= 31);
    #[cfg(target_arch = "m68k")]
    {
        extern "C" {
            fn __fx_div(num: i32, den: i32, sh: u32) -> i32;
        }
        // SAFETY: a pure function in the runtime's assembly, linked into every image.
        unsafe { __fx_div(num, den, sh) }
    }
    #[cfg(not(target_arch = "m68k"))]
    {
        host_div_shl(num, den, sh)
    }
}

/// `a % b` for `b` > 0 (0 for `b` = 0): one `DIVUL.L` on the 68020 (`__fx_rem_u32` in the
/// runtime's assembly) where the compiler calls a software division of some 600 cycles.
#[inline]
pub fn rem_u32(a: u32, b: u32) -> u32 {
    #[cfg(target_arch = "m68k")]
    {
        extern "C" {
            fn __fx_rem_u32(a: u32, b: u32) -> u32;
        }
        // SAFETY: a pure function in the runtime's assembly, linked into every image.
        unsafe { __fx_rem_u32(a, b) }
    }
    #[cfg(not(target_arch = "m68k"))]
    {
        a.checked_rem(b).unwrap_or(0)
    }
}

/// The host implementation of [`div_shl`] (the reference the image's assembly is tested
/// against).
pub fn host_div_shl(num: i32, den: i32, sh: u32) -> i32 {
    if den == 0 {
        return if num >= 0 { i32::MAX } else { i32::MIN };
    }
    let q = ((num as i64) << sh) / den as i64;
    q.clamp(i32::MIN as i64, i32::MAX as i64) as i32
}

/// The host implementation (also the reference the image's assembly is tested against, and
/// the form for constants computed at compile time).
pub const fn host_mul_shr(a: i32, b: i32, sh: u32) -> i32 {
    let p = a as i64 * b as i64 + (1i64 << (sh - 1));
    let r = p >> sh;
    if r > i32::MAX as i64 {
        i32::MAX
    } else if r < i32::MIN as i64 {
        i32::MIN
    } else {
        r as i32
    }
}

/// floor(sqrt(n)) by the digit-by-digit method: 16 rounds of shifts, adds and compares in
/// 32 bits (no multiply or divide), as `__fx_sqrt_q16` does them.
pub fn isqrt_u32(n: u32) -> u32 {
    let mut x = n;
    let mut r = 0u32;
    let mut bit = 1u32 << 30;
    while bit != 0 {
        if x >= r + bit {
            x -= r + bit;
            r = (r >> 1) + bit;
        } else {
            r >>= 1;
        }
        bit >>= 2;
    }
    r
}

/// The square root of a non-negative Q16 value, in Q16 (negative input gives 0). Exact to
/// the last bit below 1.0, and to 2^-(leading zeros / 2) relative above it: the input is
/// shifted left by the largest even amount that fits before the root is taken.
///
/// On the 68020 it is `__fx_sqrt_q16` in the runtime's assembly (the compiled loop carried a
/// condition-code clobber, docs/toolchain.md).
#[inline]
pub fn sqrt_q16(x_q16: i32) -> i32 {
    #[cfg(target_arch = "m68k")]
    {
        extern "C" {
            fn __fx_sqrt_q16(x: i32) -> i32;
        }
        // SAFETY: a pure function in the runtime's assembly, linked into every image.
        unsafe { __fx_sqrt_q16(x_q16) }
    }
    #[cfg(not(target_arch = "m68k"))]
    {
        host_sqrt_q16(x_q16)
    }
}

/// The host implementation of [`sqrt_q16`] (the reference the image's assembly is tested
/// against).
pub fn host_sqrt_q16(x_q16: i32) -> i32 {
    if x_q16 <= 0 {
        return 0;
    }
    let x = x_q16 as u32;
    let s = (x.leading_zeros() & !1).min(16);
    (isqrt_u32(x << s) << ((16 - s) / 2)) as i32
}

/// `a / b` truncated toward zero, saturated to `i32` (`i32::MIN / -1` gives `i32::MAX`;
/// `b = 0` gives `i32::MAX` for `a >= 0`, else `i32::MIN`). Compiled `i32` division must not
/// be used in firmware: the M68k backend encodes the 32-bit DIVS.L/DIVU.L with the remainder
/// register fixed to %d0, which silently clobbers %d0 (llvm/llvm-project#224186;
/// docs/toolchain.md). This goes through `__fx_div` in the runtime's assembly instead.
#[inline]
pub fn div(a: i32, b: i32) -> i32 {
    div_shl(a, b, 0)
}

#[cfg(test)]
mod tests {
    #[test]
    fn div_truncates_and_saturates() {
        assert_eq!(div(7, 2), 3);
        assert_eq!(div(-7, 2), -3);
        assert_eq!(div(i32::MIN, -1), i32::MAX);
        assert_eq!(div(5, 0), i32::MAX);
        assert_eq!(div(-5, 0), i32::MIN);
    }

    use super::*;

    #[test]
    fn floor_multiply_floors_toward_minus_infinity() {
        assert_eq!(host_mul_floor_shr24(3, 1 << 23), 1); // 1.5
        assert_eq!(host_mul_floor_shr24(-3, 1 << 23), -2); // -1.5
        assert_eq!(host_mul_floor_shr24(-1, 1), -1);
        assert_eq!(host_mul_floor_shr24(i32::MAX, 1 << 24), i32::MAX);
        assert_eq!(host_mul_floor_shr24(i32::MIN, 87_496), -11_199_488);
    }

    #[test]
    fn rounds_and_saturates() {
        assert_eq!(host_mul_shr(3, 5, 1), 8); // 7.5 rounds up
        assert_eq!(host_mul_shr(-3, 5, 1), -7); // -7.5 rounds up (toward +inf)
        assert_eq!(host_mul_shr(1 << 16, 1 << 16, 16), 1 << 16);
        assert_eq!(host_mul_shr(i32::MAX, i32::MAX, 1), i32::MAX);
        assert_eq!(host_mul_shr(i32::MIN, i32::MAX, 1), i32::MIN);
        assert_eq!(host_mul_shr(i32::MIN, i32::MIN, 32), 1 << 30);
        assert_eq!(host_mul_shr(-1, 1, 32), 0);
    }

    #[test]
    fn divides_truncates_and_saturates() {
        assert_eq!(host_div_shl(7, 2, 0), 3);
        assert_eq!(host_div_shl(-7, 2, 0), -3); // toward zero
        assert_eq!(host_div_shl(1, 3, 16), 21845);
        assert_eq!(host_div_shl(i32::MIN, -1, 0), i32::MAX);
        assert_eq!(host_div_shl(1 << 20, 1, 16), i32::MAX);
        assert_eq!(host_div_shl(-(1 << 20), 1, 16), i32::MIN);
        assert_eq!(host_div_shl(0, 0, 5), i32::MAX);
        assert_eq!(host_div_shl(-1, 0, 5), i32::MIN);
    }

    #[test]
    fn square_roots() {
        for n in [
            0u32,
            1,
            2,
            3,
            4,
            15,
            16,
            17,
            65535,
            65536,
            1 << 30,
            u32::MAX,
        ] {
            let r = isqrt_u32(n) as u64;
            assert!(r * r <= n as u64 && (r + 1) * (r + 1) > n as u64, "{n}");
        }
        let q = |x: f64| (x * 65536.0).round() as i32;
        assert_eq!(sqrt_q16(q(4.0)), q(2.0));
        assert_eq!(sqrt_q16(q(0.25)), q(0.5));
        assert_eq!(sqrt_q16(-5), 0);
        for x in [1e-4, 0.01, 0.7, 1.0, 2.0, 123.4, 30000.0] {
            let got = sqrt_q16(q(x)) as f64 / 65536.0;
            let want = (q(x) as f64 / 65536.0).sqrt();
            assert!((got - want).abs() <= 1e-4 * want.max(1.0), "{x}: {got}");
        }
    }
}
