//! Task-space positions to the polar coordinates the database is indexed by (thesis ch. IV
//! section 5, lines ~1123-1150: the image of a disk at (r, alpha) is the image at (r, 0)
//! shifted by alpha along the diagonal). Integer CORDIC in vectoring mode: 20 rounds of
//! shifts and adds, no multiply but the final gain, no floating point on the 68020.

use crate::UNITS_PER_REV;

/// atan(2^-i) in 2^-8 angle units (2^23 per revolution), i = 0..20.
const ATAN: [i32; 20] = [
    1048576, 619011, 327068, 166025, 83335, 41708, 20859, 10430, 5215, 2608, 1304, 652, 326, 163,
    81, 41, 20, 10, 5, 3,
];

/// Largest coordinate accepted, micrometres (8 m): keeps the scaled CORDIC inside `i32`.
pub const MAX_COORD_UM: i32 = 8_000_000;

/// Bound on the error of [`polar`]: radius within this many micrometres, and the position
/// implied by the angle within this many micrometres per metre of radius (checked by tests).
pub const RADIUS_ERR_UM: i32 = 8;
/// See [`RADIUS_ERR_UM`]: angle error, in micrometres of arc per metre of radius.
pub const ANGLE_ERR_UM_PER_M: i32 = 8;

/// The point turned into the right half-plane and the angle it was turned by (2^-8 units):
/// half a revolution for x < 0. (A function of its own: inlined, its selects on one compare
/// compiled to a condition-code clobber on the 68k; docs/toolchain.md.)
#[inline(never)]
fn right_half(x: i32, y: i32) -> (i32, i32, i32) {
    if x >= 0 {
        (x, y, 0)
    } else if y >= 0 {
        (-x, -y, 1 << 22)
    } else {
        (-x, -y, -(1 << 22))
    }
}

/// The radius (micrometres) and polar angle (angle units, 32768 per revolution, in
/// `-16384..16384`) of the point (`x_um`, `y_um`). Coordinates are clamped to
/// +-[`MAX_COORD_UM`].
pub fn polar(x_um: i32, y_um: i32) -> (i32, i32) {
    let (mut x, mut y, mut z) = right_half(
        x_um.clamp(-MAX_COORD_UM, MAX_COORD_UM) << 4,
        y_um.clamp(-MAX_COORD_UM, MAX_COORD_UM) << 4,
    );
    for (i, a) in ATAN.iter().enumerate() {
        let (dx, dy) = (y >> i, x >> i);
        if y > 0 {
            x += dx;
            y -= dy;
            z += a;
        } else {
            x -= dx;
            y += dy;
            z -= a;
        }
    }
    // x = 16 K r with the CORDIC gain K = 1.6467603; r = x * 2^20 / (16 K) / 2^20 in two
    // 32-bit products (39797 = 2^16 / K, rounded).
    let ux = x as u32;
    let r = ((ux >> 10) * 39797 + (((ux & 1023) * 39797) >> 10) + 512) >> 10;
    let mut alpha = (z + 128) >> 8;
    if alpha >= UNITS_PER_REV / 2 {
        alpha -= UNITS_PER_REV;
    } else if alpha < -UNITS_PER_REV / 2 {
        alpha += UNITS_PER_REV;
    }
    (r as i32, alpha)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn matches_the_exact_polar_coordinates(x in -2_000_000i32..2_000_000, y in -2_000_000i32..2_000_000) {
            let (r, a) = polar(x, y);
            let re = ((x as f64).powi(2) + (y as f64).powi(2)).sqrt();
            prop_assert!((r as f64 - re).abs() <= RADIUS_ERR_UM as f64, "r {} exact {}", r, re);
            if re > 1000.0 {
                let ae = (y as f64).atan2(x as f64);
                let mut d = a as f64 * core::f64::consts::TAU / UNITS_PER_REV as f64 - ae;
                d = (d + core::f64::consts::PI).rem_euclid(core::f64::consts::TAU) - core::f64::consts::PI;
                // Arc error at radius re, in micrometres per metre.
                prop_assert!(d.abs() * 1e6 <= ANGLE_ERR_UM_PER_M as f64 * 1.0 + 1e6 * core::f64::consts::PI / UNITS_PER_REV as f64,
                    "angle error {} rad at ({}, {})", d, x, y);
            }
        }
    }

    #[test]
    fn axes() {
        let (r, a) = polar(450_000, 0);
        assert!((r - 450_000).abs() <= 2 && a == 0, "{r} {a}");
        let (r, a) = polar(0, 300_000);
        assert!((r - 300_000).abs() <= 2 && a == 8192, "{r} {a}");
        let (r, a) = polar(-100_000, 0);
        assert!(
            (r - 100_000).abs() <= 2 && (a == 16384 - 32768 || a == -16384),
            "{r} {a}"
        );
    }
}
