//! Sine and cosine of angles in micro-radians by integer CORDIC (rotation mode): 21 rounds
//! of shifts and adds, no multiply, no table larger than 21 words. For the forward
//! kinematics the firmware needs without floating point (the 68020 images have no FPU code).

/// atan(2^-i) in micro-radians, i = 0..21.
const ATAN_URAD: [i32; 21] = [
    785398, 463648, 244979, 124355, 62419, 31240, 15624, 7812, 3906, 1953, 977, 488, 244, 122, 61,
    31, 15, 8, 4, 2, 1,
];

/// 1 / (CORDIC gain) in Q30: the start vector that makes the rotated vector unit length.
pub const INV_GAIN_Q30: i32 = 652_032_874;

/// Pi in micro-radians.
pub const PI_URAD: i32 = 3_141_593;

/// Bound on the error of [`sin_cos_q30`] in Q30 units for angles within +-20 rad (checked by
/// tests): under 7.5e-6, the micro-radian resolution of the table and of pi (0.002 mm at
/// the tip). Each further whole turn adds up to 0.4 micro-radians ([`PI_URAD`] is rounded).
pub const SIN_COS_ERR_Q30: i32 = 8_000;

/// The 21 CORDIC rounds on (`x`, `y`) with angle accumulator `z`, each rotating by
/// atan(2^-i) one way or the other as the mask `dir` (-1 or 0, evaluated each round) says.
/// Sign arithmetic, no select; unrolled: the M68k backend put a register copy between the
/// loop's compare and its branch when this was a loop (docs/toolchain.md class 1). Rotation
/// mode ([`sin_cos_q30`]) steers by `z`, vectoring mode ([`atan2_urad`]) by `y`.
macro_rules! cordic_rounds {
    ($x:ident, $y:ident, $z:ident, $dir:expr) => {
        cordic_rounds!(@ $x, $y, $z, $dir; 0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20)
    };
    (@ $x:ident, $y:ident, $z:ident, $dir:expr; $($i:literal)*) => {$(
        let m = $dir;
        let dx = (($y >> $i) ^ m) - m;
        let dy = (($x >> $i) ^ m) - m;
        $x -= dx;
        #[allow(unused_assignments)]
        {
            $y += dy;
            $z -= (ATAN_URAD[$i] ^ m) - m;
        }
    )*};
}

/// `(sin, cos)` of `theta_urad` in Q30. Any angle: it is reduced to (-pi, pi] first.
pub fn sin_cos_q30(theta_urad: i32) -> (i32, i32) {
    let (mut z, flip) = reduce(theta_urad);
    let (mut x, mut y) = (INV_GAIN_Q30, 0i32);
    // m = 0 rotates positive (z >= 0), -1 negative.
    cordic_rounds!(x, y, z, z >> 31);
    ((y ^ flip) - flip, (x ^ flip) - flip)
}

/// The angle reduced to [-pi/2, pi/2] and -1 if that took a half turn (the results' signs
/// flip), else 0. Sign arithmetic throughout, no branch on a compare: the M68k backend
/// clobbered the condition codes of this reduction's compares (docs/toolchain.md).
#[inline(never)]
fn reduce(theta_urad: i32) -> (i32, i32) {
    // Whole turns: into (-2 pi, 2 pi) by division, then (-pi, pi] by one step each way.
    let turn = 2 * PI_URAD;
    let mut z = theta_urad - crate::div(theta_urad, turn) * turn;
    let above = (PI_URAD - z) >> 31; // -1 when z > pi
    z -= turn & above;
    let below = (z + PI_URAD) >> 31; // -1 when z < -pi
    z += turn & below;
    // A half turn into [-pi/2, pi/2].
    let half = PI_URAD / 2;
    let over = (half - z) >> 31; // -1 when z > pi/2
    let under = (z + half) >> 31; // -1 when z < -pi/2
    z += (PI_URAD & under) - (PI_URAD & over);
    (z, over | under)
}

/// Bound on the error of [`atan2_urad`] in micro-radians for vectors of length 2^10 or more
/// (checked by tests): the table's rounding over 21 rounds plus the last round's step.
pub const ATAN2_ERR_URAD: i32 = 16;

/// The angle of the vector (`x`, `y`) in micro-radians, in (-pi, pi], and its length
/// times the CORDIC gain 1.6468 (the length itself is `mag * INV_GAIN_Q30 >> 30`, within
/// 2e-5 of it), by
/// integer CORDIC in vectoring mode: 21 rounds of shifts and adds. `x` and `y` must lie
/// within +-2^29 (the gain must not overflow); (0, 0) has no angle (the result is some
/// angle of length 0). For the inverse
/// kinematics the firmware needs without floating point.
pub fn atan2_urad(y: i32, x: i32) -> (i32, i32) {
    // Into the right half plane by a quarter turn: (x, y) -> (y, -x) adds pi/2 when y > 0,
    // (-y, x) subtracts it otherwise. Sign arithmetic, no select (docs/toolchain.md).
    let left = x >> 31; // -1 when x < 0
    let up = !(y >> 31) & left; // -1 when x < 0 and y >= 0
    let down = (y >> 31) & left; // -1 when x < 0 and y < 0
    let (mut x, mut y, mut z) = (
        (x & !left) | (y & up) | (-y & down),
        (y & !left) | (-x & up) | (x & down),
        ((PI_URAD / 2) & up) - ((PI_URAD / 2) & down),
    );
    // m = -1 rotates clockwise (y >= 0), 0 counter-clockwise: drives y to 0.
    cordic_rounds!(x, y, z, !(y >> 31));
    // The last rounds may leave z just beyond +-pi for vectors on the negative x axis.
    let over = (PI_URAD - z) >> 31;
    z -= (2 * PI_URAD) & over;
    (z, x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn check(theta_urad: i32) {
        let (s, c) = sin_cos_q30(theta_urad);
        let t = theta_urad as f64 * 1e-6;
        let q = (1u64 << 30) as f64;
        let es = (s as f64 - t.sin() * q).abs();
        let ec = (c as f64 - t.cos() * q).abs();
        assert!(
            es <= SIN_COS_ERR_Q30 as f64 && ec <= SIN_COS_ERR_Q30 as f64,
            "theta {theta_urad} urad: sin err {es}, cos err {ec}"
        );
    }

    #[test]
    fn quadrant_edges_and_whole_turns() {
        for t in [
            0,
            1,
            -1,
            PI_URAD / 2,
            -PI_URAD / 2,
            PI_URAD,
            -PI_URAD,
            PI_URAD + 1,
            7 * PI_URAD,
            -9 * PI_URAD / 2,
        ] {
            check(t);
        }
        // The extremes reduce without overflow to a unit vector.
        for t in [i32::MAX, i32::MIN, i32::MIN + 1] {
            let (s, c) = sin_cos_q30(t);
            let r = ((s as f64).hypot(c as f64) / (1u64 << 30) as f64 - 1.0).abs();
            assert!(r < 1e-5, "{t}: |(sin, cos)| off by {r}");
        }
    }

    proptest! {
        #[test]
        fn matches_f64(theta in -20_000_000i32..20_000_000) {
            check(theta);
        }
    }

    fn check_atan2(y: i32, x: i32) {
        let (a, m) = atan2_urad(y, x);
        let want = (y as f64).atan2(x as f64) * 1e6;
        let mut e = (a as f64 - want).abs();
        if e > 3e6 {
            e = (e - 2e6 * core::f64::consts::PI).abs();
        }
        assert!(
            e <= ATAN2_ERR_URAD as f64,
            "atan2({y}, {x}) = {a}, want {want:.1}"
        );
        let len = (m as f64) * INV_GAIN_Q30 as f64 / (1u64 << 30) as f64;
        let r = (x as f64).hypot(y as f64);
        assert!(
            (len - r).abs() <= 4.0 + r * 2e-5,
            "|({x}, {y})| = {len}, want {r}"
        );
        assert!(
            a > -PI_URAD && a <= PI_URAD,
            "atan2({y}, {x}) = {a} outside (-pi, pi]"
        );
    }

    #[test]
    fn atan2_axes_and_diagonals() {
        let k = 300_000;
        for (y, x) in [
            (0, k),
            (k, 0),
            (0, -k),
            (-k, 0),
            (k, k),
            (-k, -k),
            (k, -k),
            (-k, k),
            (1, -k),
            (-1, -k),
        ] {
            check_atan2(y, x);
        }
    }

    proptest! {
        #[test]
        fn atan2_matches_f64(y in -(1i32 << 29)..(1 << 29), x in -(1i32 << 29)..(1 << 29)) {
            prop_assume!((x as f64).hypot(y as f64) >= 1024.0);
            check_atan2(y, x);
        }
    }
}
