//! Compile-time arithmetic: the law's constants are computed from `crates/arm` in `f64`
//! at compile time and stored as integers, so the image carries no floating point (the
//! toolchain's soft float is miscompiled; docs/toolchain.md).

/// e^x by its Taylor series (|x| < 2 is plenty here), for const contexts.
pub const fn exp(x: f64) -> f64 {
    let mut sum = 1.0;
    let mut term = 1.0;
    let mut n = 1.0;
    while n < 40.0 {
        term = term * x / n;
        sum += term;
        n += 1.0;
    }
    sum
}

/// cos x by its Taylor series (|x| < 2), for const contexts.
pub const fn cos(x: f64) -> f64 {
    let mut sum = 1.0;
    let mut term = 1.0;
    let mut n = 1.0;
    while n < 40.0 {
        term = -term * x * x / ((2.0 * n - 1.0) * (2.0 * n));
        sum += term;
        n += 1.0;
    }
    sum
}

/// sin x by its Taylor series (|x| < 2), for const contexts.
pub const fn sin(x: f64) -> f64 {
    let mut sum = x;
    let mut term = x;
    let mut n = 1.0;
    while n < 40.0 {
        term = -term * x * x / ((2.0 * n) * (2.0 * n + 1.0));
        sum += term;
        n += 1.0;
    }
    sum
}

/// sqrt by Newton's method, for const contexts (x > 0).
pub const fn sqrt(x: f64) -> f64 {
    let mut r = if x > 1.0 { x } else { 1.0 };
    let mut i = 0;
    while i < 100 {
        r = 0.5 * (r + x / r);
        i += 1;
    }
    r
}

/// Rounds to the nearest integer, for const contexts.
pub const fn round(x: f64) -> i64 {
    if x >= 0.0 {
        (x + 0.5) as i64
    } else {
        (x - 0.5) as i64
    }
}

/// 2^16 as f64.
pub const Q16: f64 = 65536.0;
/// 2^32 as f64.
pub const Q32: f64 = 4_294_967_296.0;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn const_math_matches_std() {
        for x in [-1.5, -0.3, 0.0, 0.2, 1.0, 1.9] {
            assert!((exp(x) - f64::exp(x)).abs() < 1e-14 * f64::exp(x).max(1.0));
            assert!((cos(x) - f64::cos(x)).abs() < 1e-14);
            assert!((sin(x) - f64::sin(x)).abs() < 1e-14);
        }
        for x in [1e-6, 0.5, 2.0, 400000.0] {
            assert!((sqrt(x) - f64::sqrt(x)).abs() < 1e-12 * f64::sqrt(x).max(1.0));
        }
        assert_eq!((round(2.5), round(-2.5), round(0.49)), (3, -3, 0));
    }
}
