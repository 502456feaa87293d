//! The thesis's first unbuilt fix (ch. VI section 4, fig. VI.2): before wall following is
//! given up for the goal, look along the path the arm will really take, not along a straight
//! line of sight. The servo drives each link on its own, bang-bang, to its setpoint (law
//! III.36; the reflex stays transparent in free space), so from rest link i covers its
//! distance d_i in a time proportional to sqrt(d_i / a_i), and the faster link (link 2,
//! three times link 1's acceleration) finishes first: the path bends. The check samples that
//! path at twice the pixel pitch of its longer axis and fails at the first blocked cell. It
//! runs a slice of samples per planner cycle.

use crate::grid::Grid;

/// Samples checked per planner cycle.
pub const SAMPLES_PER_CYCLE: u32 = 8;

/// Relative time cost of a distance on each axis, Q8: the slower link's acceleration over
/// each link's (`reflex::BRAKE_U_S2`, the servo's braking acceleration, which is its
/// acceleration too).
const COST_Q8: [i32; 2] = cost_q8();

const fn cost_q8() -> [i32; 2] {
    let a = reflex::BRAKE_U_S2;
    let slow = if a[0] < a[1] { a[0] } else { a[1] };
    [
        ((slow as i64 * 256) / a[0] as i64) as i32,
        ((slow as i64 * 256) / a[1] as i64) as i32,
    ]
}

/// A check in progress.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sight {
    from_u: [i32; 2],
    to_u: [i32; 2],
    /// Each axis's speed-up of normalised time, Q8 (T / T_i >= 1).
    inv_r_q8: [i32; 2],
    /// Normalised time per sample, Q15.
    step_q15: i32,
    k: u32,
    n: u32,
    active: u32,
    /// The thesis's straight line of sight instead of the servo's path (fig. VI.2).
    straight: u32,
}

/// Where a check stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Still sampling.
    Running,
    /// The path meets a blocked cell.
    Blocked,
    /// The whole path is free.
    Clear,
    /// No check was started.
    Idle,
}

/// Position fraction of a bang-bang move at normalised time `t` (Q15, clamped to 1): 2 t^2
/// to half time, then 1 - 2 (1 - t)^2.
#[inline(always)]
fn profile_q15(t: i32) -> i32 {
    let t = t.clamp(0, 1 << 15);
    let first = (t * t) >> 14;
    let u = (1 << 15) - t;
    let second = (1 << 15) - ((u * u) >> 14);
    if t < (1 << 14) {
        first
    } else {
        second
    }
}

impl Sight {
    /// Idle.
    pub const fn new() -> Self {
        Self {
            from_u: [0; 2],
            to_u: [0; 2],
            inv_r_q8: [256; 2],
            step_q15: 0,
            k: 0,
            n: 0,
            active: 0,
            straight: 0,
        }
    }

    /// Starts checking the move from `from_u` to `to_u` (angle units, unwrapped): along the
    /// servo's path, or with `straight` along the straight line (the thesis's line of
    /// sight, kept to show fig. VI.2's looping).
    #[inline(never)]
    pub fn start(&mut self, from_u: [i32; 2], to_u: [i32; 2], straight: bool) {
        self.straight = straight as u32;
        self.from_u = from_u;
        self.to_u = to_u;
        let d1 = (to_u[0] - from_u[0]).abs();
        let d2 = (to_u[1] - from_u[1]).abs();
        // Time^2 is proportional to distance x cost.
        let w1 = (d1 >> 4) * COST_Q8[0] + 1;
        let w2 = (d2 >> 4) * COST_Q8[1] + 1;
        let wmax = w1.max(w2);
        // T / T_i = sqrt(wmax / w_i), Q8, at most 64.
        let r1 = fx::div_shl(wmax, w1, 16).min(1 << 28);
        let r2 = fx::div_shl(wmax, w2, 16).min(1 << 28);
        self.inv_r_q8 = [
            fx::isqrt_u32(r1 as u32) as i32,
            fx::isqrt_u32(r2 as u32) as i32,
        ];
        let px = (d1.max(d2) >> 8) + 1;
        self.n = (2 * px) as u32;
        self.step_q15 = fx::div(1 << 15, self.n as i32);
        self.k = 0;
        self.active = 1;
    }

    /// Stops the check.
    pub fn stop(&mut self) {
        self.active = 0;
    }

    /// Checks up to [`SAMPLES_PER_CYCLE`] more samples.
    #[inline(never)]
    pub fn work(&mut self, g: &Grid) -> Verdict {
        if self.active == 0 {
            return Verdict::Idle;
        }
        let mut s = 0;
        while s < SAMPLES_PER_CYCLE {
            self.k += 1;
            let t = (self.k as i32) * self.step_q15;
            let c = self.sample(t);
            if g.blocked(c) != 0 {
                self.active = 0;
                return Verdict::Blocked;
            }
            if self.k >= self.n {
                self.active = 0;
                return Verdict::Clear;
            }
            s += 1;
        }
        Verdict::Running
    }

    /// The cell the move is in at normalised time `t` (Q15).
    #[inline(never)]
    fn sample(&self, t: i32) -> [i32; 2] {
        let (f1, f2) = if self.straight != 0 {
            (t.clamp(0, 1 << 15), t.clamp(0, 1 << 15))
        } else {
            (
                profile_q15(fx::mul_shr(t, self.inv_r_q8[0], 8)),
                profile_q15(fx::mul_shr(t, self.inv_r_q8[1], 8)),
            )
        };
        let p1 = self.from_u[0] + fx::mul_shr(self.to_u[0] - self.from_u[0], f1, 15);
        let p2 = self.from_u[1] + fx::mul_shr(self.to_u[1] - self.from_u[1], f2, 15);
        [p1 >> 8, p2 >> 8]
    }
}
