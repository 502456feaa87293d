//! The servo's one wide operation: `mul_shr(a, b, sh)` = round((a b) >> sh), saturated to
//! `i32`, for Q-format products.
//!
//! On the 68020 it is `__fx_mul_shr` in the runtime's assembly (`crates/rt/asm/rt.S`): MULS.L
//! gives the 64-bit product in two registers. Compiled 64-bit code is avoided because
//! LLVM's M68k backend miscompiles its compare sequences (docs/toolchain.md). On the host it
//! is the same arithmetic in `i64`; a system test runs both on the same inputs and requires
//! identical bits.

/// round((a * b) / 2^sh) saturated to `i32`; `sh` in 1..=32.
#[inline]
pub fn mul_shr(a: i32, b: i32, sh: u32) -> i32 {
    debug_assert!((1..=32).contains(&sh));
    #[cfg(target_arch = "m68k")]
    {
        extern "C" {
            fn __fx_mul_shr(a: i32, b: i32, sh: u32) -> i32;
        }
        // SAFETY: a pure function in the runtime's assembly, linked into every image.
        unsafe { __fx_mul_shr(a, b, sh) }
    }
    #[cfg(not(target_arch = "m68k"))]
    {
        host_mul_shr(a, b, sh)
    }
}

/// The host implementation (also the reference the image's assembly is tested against).
pub fn host_mul_shr(a: i32, b: i32, sh: u32) -> i32 {
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
