//! Branch-free integer helpers: the M68k backend clobbers the condition codes between a
//! compare and the branch or select that reads it (docs/toolchain.md, class 1), so the
//! reflex's small decisions are sign masks. Arguments must not overflow when subtracted
//! (angles and pixel indices here are far inside `i32`).

/// `a` where `m` is -1, `b` where `m` is 0.
#[inline(always)]
pub fn pick(m: i32, a: i32, b: i32) -> i32 {
    b ^ ((a ^ b) & m)
}

/// -1 when `a < b`, else 0.
#[inline(always)]
pub fn lt(a: i32, b: i32) -> i32 {
    (a - b) >> 31
}

/// The smaller of `a` and `b`.
#[inline(always)]
pub fn min(a: i32, b: i32) -> i32 {
    pick(lt(a, b), a, b)
}

/// The larger of `a` and `b`.
#[inline(always)]
pub fn max(a: i32, b: i32) -> i32 {
    pick(lt(a, b), b, a)
}

/// -1 when `d` is zero, else 0 (`d` a difference, as an exclusive or: -1 when unmoved).
#[inline(always)]
pub fn zero(d: u32) -> i32 {
    ((d | d.wrapping_neg()) as i32 >> 31) ^ -1
}

/// `|a|` (`a` > `i32::MIN`).
#[inline(always)]
pub fn abs(a: i32) -> i32 {
    let m = a >> 31;
    (a ^ m) - m
}

/// -1 when `x >= 0`, else 0. Not inlined: inlined, LLVM turned it into a compare, a select
/// and an `Spl` with a register copy between them (the clobber this module avoids).
#[inline(never)]
pub fn nonneg(x: i32) -> i32 {
    !x >> 31
}

/// `a` within [`lo`, `hi`] (`lo <= hi`).
#[inline(always)]
pub fn clamp(a: i32, lo: i32, hi: i32) -> i32 {
    min(max(a, lo), hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn they_match_the_branching_forms(a in -(1i32 << 29)..(1 << 29), b in -(1i32 << 29)..(1 << 29)) {
            prop_assert_eq!(min(a, b), a.min(b));
            prop_assert_eq!(max(a, b), a.max(b));
            prop_assert_eq!(abs(a), a.abs());
            prop_assert_eq!(lt(a, b), if a < b { -1 } else { 0 });
            prop_assert_eq!(pick(-1, a, b), a);
            prop_assert_eq!(nonneg(a), if a >= 0 { -1 } else { 0 });
            prop_assert_eq!(zero(a as u32), if a == 0 { -1 } else { 0 });
            prop_assert_eq!(zero(0), -1);
            prop_assert_eq!(pick(0, a, b), b);
            let (lo, hi) = (a.min(b), a.max(b));
            prop_assert_eq!(clamp(a / 2 + b / 3, lo, hi), (a / 2 + b / 3).clamp(lo, hi));
        }
    }
}
