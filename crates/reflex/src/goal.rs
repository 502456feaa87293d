//! The goal in joint space: the planner's, or the wand's position turned into joint angles
//! (thesis ch. VI: the reflex follows the wand directly when no planner runs).
//!
//! The arm's links are equally long (`arm::geometry`, 0.25 m each), so the two poses that put
//! the tip at distance r and bearing phi from the shoulder are theta1 = phi -+ beta,
//! theta2 = phi +- beta (absolute angles) with cos beta = r / (2 L). Integer CORDIC
//! throughout (`fx::trig`): no floating point in the image.

use fx::trig::{atan2_urad, INV_GAIN_Q30, PI_URAD};

/// Link length, micrometres (both links).
pub const L_UM: i32 = (arm::geometry::L1_M * 1e6) as i32;
const _: () = assert!(arm::geometry::L1_M == arm::geometry::L2_M);

/// A full turn in micro-radians.
pub const TURN_URAD: i32 = 2 * PI_URAD;

/// The two joint-space poses (absolute angles, micro-radians in (-pi, pi]) that put the tip
/// at (`x_um`, `y_um`): elbow one way, then the other. A point beyond reach gives the
/// stretched pose toward it (both poses equal); the shoulder itself any folded pose.
pub fn inverse(x_um: i32, y_um: i32) -> [[i32; 2]; 2] {
    let (phi, mag) = atan2_urad(y_um, x_um);
    let r_um = fx::mul_shr(mag, INV_GAIN_Q30, 30);
    // cos beta in Q28, within [0, 1].
    let c = crate::masks::clamp(fx::div_shl(r_um, 2 * L_UM, 28), 0, 1 << 28);
    // sin beta = sqrt((1 - c)(1 + c)): two square roots of Q28 values are Q14 each.
    let s =
        fx::isqrt_u32(((1 << 28) - c) as u32) as i32 * fx::isqrt_u32(((1 << 28) + c) as u32) as i32;
    let (beta, _) = atan2_urad(s >> 2, c >> 2);
    [
        [wrap(phi - beta), wrap(phi + beta)],
        [wrap(phi + beta), wrap(phi - beta)],
    ]
}

/// `a` into (-pi, pi]. Sign arithmetic, no branch on a compare (docs/toolchain.md).
#[inline(never)]
pub fn wrap(a: i32) -> i32 {
    // Into (-2 pi, 2 pi) by division, then one step each way.
    let mut z = a - fx::div(a, TURN_URAD) * TURN_URAD;
    let above = (PI_URAD - z) >> 31; // -1 when z > pi
    z -= TURN_URAD & above;
    let below = (z + PI_URAD - 1) >> 31; // -1 when z <= -pi
    z + (TURN_URAD & below)
}

/// The angle equal to `a` modulo a turn that lies nearest `near`.
pub fn nearest(a: i32, near: i32) -> i32 {
    near + wrap(a - near)
}

/// -1 when the second of the poses `p` is nearer `near` on the torus than the first (the
/// larger of the two axis distances decides), else 0.
pub fn second_nearer(p: [[i32; 2]; 2], near: [i32; 2]) -> i32 {
    use crate::masks::{abs, max};
    let d = |q: [i32; 2]| max(abs(wrap(q[0] - near[0])), abs(wrap(q[1] - near[1])));
    (d(p[1]) - d(p[0])) >> 31
}

/// Of the two poses `p`, the one nearer `near` on the torus (the larger of the two axis
/// distances decides), expressed nearest `near` on each axis.
pub fn choose(p: [[i32; 2]; 2], near: [i32; 2]) -> [i32; 2] {
    use crate::masks::pick;
    // -1 when the second pose is nearer.
    let second = second_nearer(p, near);
    let q = [
        pick(second, p[1][0], p[0][0]),
        pick(second, p[1][1], p[0][1]),
    ];
    [nearest(q[0], near[0]), nearest(q[1], near[1])]
}
