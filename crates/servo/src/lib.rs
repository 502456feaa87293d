//! The servo board's logic (thesis ch. III and Appendix A): per link a Luenberger velocity
//! observer and the sliding-mode near time-optimal control law III.36, both links in one
//! `step`; the arrest point the reflexes need (ch. V); torque-to-DAC scaling. Beyond the
//! thesis (module [`params`], docs/servo.md): an on-line inertia estimate for the switching
//! curve, a notch at the first resonance, and friction compensation near the goal.
//!
//! Everything runs in fixed point: angles and velocities in Q16 (`_q16`: units of 2^-16 rad,
//! rad/s, N m) in `i32`, every wide product through [`fx::mul_shr`] (MULS.L in assembly on the
//! 68020). The constants are derived at compile
//! time from `crates/arm` (module [`params`]). Integer arithmetic gives the same bits on the
//! host and the 68020, so native and image runs agree exactly, and it avoids the toolchain's
//! miscompiled soft float (docs/toolchain.md).
//!
//! Law III.36 (thesis lines ~760-800):
//!
//! ```text
//! s~ = theta_err + omega |omega| I / (2 u^)
//! u  = -umax sat{ (u^/umax) [ sat(omega/omega_sat) + eps sat(s~/s_sat) ] }
//! ```
//!
//! Nothing here touches hardware: the board passes the latched encoder counts, the timer and
//! the subgoal in, and writes the DAC codes that come out.
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]

pub mod arrest_log;
pub mod consts;
pub use fx;
pub mod params;

use fx::{div_shl, mul_shr, sqrt_q16};
use params::{LinkConst, TIMER_TICK_Q40};

/// One fixed-point unit (1.0 in Q16).
pub const ONE_Q16: i32 = 1 << 16;

/// 2^16 / 10^6 in Q32, rounded: [`urad_to_q16`]'s multiplier (also `__servo_pass`'s).
pub const URAD_TO_Q16_Q32: i32 = 281_474_977;

/// Micro-radians to Q16 radians (x 2^16 / 10^6 as a Q32 multiplier, rounded).
#[inline]
pub fn urad_to_q16(urad: i32) -> i32 {
    mul_shr(urad, URAD_TO_Q16_Q32, 32)
}

/// Q16 radians to micro-radians (x 10^6 / 2^16, rounded: `mul_shr(q, 10^6, 16)`).
///
/// 10^6 / 2^16 is 15625 / 1024 = 15 + 265 / 1024, so within +-2^22 (64 rad, or rad/s) the
/// result is `15 q + (265 q + 512) >> 10` exactly, in shifts and adds: the published state's
/// six conversions were a `__fx_mul_shr16` call each (~120 cycles on the 68020). Outside
/// that range the product.
#[inline]
pub fn q16_to_urad(q: i32) -> i32 {
    if (q as u32).wrapping_add(1 << 22) < 1 << 23 {
        // (`black_box`: otherwise LLVM folds the shifts and adds back into a MULS.L, 45
        // cycles on the 68020; 112 cycles a pass over the six conversions.)
        let q8 = core::hint::black_box(q << 8);
        let q3 = q << 3;
        let q4 = q << 4;
        (q4 - q) + ((q8 + q3 + q + 512) >> 10)
    } else {
        mul_shr(q, 1_000_000, 16)
    }
}

/// The regime law III.36 is in, for tests and traces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Regime {
    /// The command is at +-umax (far from the switching curve, or accelerating).
    Saturated = 0,
    /// Inside the boundary layer of the switching curve (|s~| < s_sat), not near the goal.
    Sliding = 1,
    /// Near the goal: every term below saturation, the law acts like PD (K, b).
    Linear = 2,
}

/// omega |omega| c for a Q32 constant `c`: through Q24 so small speeds keep precision.
fn signed_square(omega_q16: i32, c_q32: i32) -> i32 {
    let wc_q24 = mul_shr(omega_q16, c_q32, 24);
    mul_shr(wc_q24, omega_q16.saturating_abs(), 24)
}

/// Law III.36 for one link: the torque (Q16 N m) for a position error and velocity, with
/// the switching curve's I / (2 u^) given as `brake_q32` (Q32 s^2/rad).
#[inline(never)]
pub fn law(k: &LinkConst, brake_q32: i32, err_q16: i32, omega_q16: i32) -> (i32, Regime) {
    let s = err_q16.saturating_add(signed_square(omega_q16, brake_q32)); // Q16 rad
    let x1 = mul_shr(omega_q16, k.inv_omega_sat_q16, 16).clamp(-ONE_Q16, ONE_Q16);
    let x2 = mul_shr(s, k.inv_s_sat_q16, 16).clamp(-ONE_Q16, ONE_Q16);
    let arg = mul_shr(k.uhat_over_umax_q16, x1 + mul_shr(k.eps_q16, x2, 16), 16);
    let sat = arg.clamp(-ONE_Q16, ONE_Q16);
    let regime = if sat != arg {
        Regime::Saturated
    } else if x1.abs() < ONE_Q16
        && x2.abs() < ONE_Q16
        && err_q16.saturating_abs() < k.linear_band_q16
    {
        Regime::Linear
    } else {
        Regime::Sliding
    };
    (-mul_shr(k.umax_q16, sat, 16), regime)
}

/// The proximate form of law III.36 that the board runs (beyond the thesis; Workman's
/// proximate time-optimal servo, 1987): the command is
///
/// ```text
/// u = -umax sat{ b (omega - f(theta_err)) / umax }
/// f(e) = -(K/b) e                              |e| <= y_l   (the PD's no-overshoot line)
/// f(e) = -sign(e) (sqrt(2 A |e|) - c)          |e| >  y_l   (the braking curve, offset)
/// A = u^ / I,   c = 2A b / (4K),   y_l = 2A (b / 2K)^2
/// ```
///
/// Far from the goal it is III.36: full torque until the switching curve of braking at u^,
/// then sliding down it. III.36 as printed lets its command fall below u^ once the speed is
/// under omega_sat, so the link falls behind the curve and overshoots near the goal (the
/// thesis's 1.7 mrad, more with a stiffer near-goal loop); here the curve is offset by c and
/// joins the near-goal PD's line with the same slope, so the link arrives on the line along
/// which the critically damped PD does not overshoot. K and b are III.36's near-goal gains
/// (u^ eps / s_sat, u^ / omega_sat); `two_a_q16` is 2 u^ / I with the estimated inertia.
#[inline(never)]
pub fn proximate_law(k: &LinkConst, two_a_q16: i32, err_q16: i32, omega_q16: i32) -> (i32, Regime) {
    let (yl, c) = curve_offsets(k, two_a_q16);
    proximate_law_with(k, two_a_q16, yl, c, err_q16, omega_q16)
}

/// The proximate law's y_l and c (Q16) for 2 u^ / I = `two_a_q16`; [`InertiaEstimate`]
/// keeps them beside its `two_a_q16`. (The constants' prior curve has them computed at
/// compile time in [`params::LinkConst`].)
fn curve_offsets(k: &LinkConst, two_a_q16: i32) -> (i32, i32) {
    (
        mul_shr(two_a_q16, k.yl_per_two_a_q32, 32),
        mul_shr(two_a_q16, k.c_per_two_a_q32, 32),
    )
}

/// [`proximate_law`] with its y_l and c for `two_a_q16` given (as [`InertiaEstimate`] keeps
/// them).
fn proximate_law_with(
    k: &LinkConst,
    two_a_q16: i32,
    yl: i32,
    c: i32,
    err_q16: i32,
    omega_q16: i32,
) -> (i32, Regime) {
    let d = err_q16.saturating_abs();
    let linear = d <= yl;
    let f = if linear {
        -mul_shr(err_q16, k.slope_q16, 16)
    } else {
        let v = sqrt_q16(mul_shr(two_a_q16, d, 16)) - c;
        if err_q16 > 0 {
            -v
        } else {
            v
        }
    };
    let arg = mul_shr(k.b_q16, f.saturating_sub(omega_q16), 16);
    let u = arg.clamp(-k.umax_q16, k.umax_q16);
    let regime = if u != arg {
        Regime::Saturated
    } else if linear {
        Regime::Linear
    } else {
        Regime::Sliding
    };
    (u, regime)
}

/// Where a link stops when the law brakes from (`theta`, `omega`): the arrest point of
/// thesis ch. V, theta + omega |omega| I / (2 u), with `brake_q32` = I / (2 u).
///
/// The thesis takes u = umax; the servo publishes it with the u^ its switching curve
/// actually brakes at (and the estimated inertia), which lies a little further out and is
/// where the arm really stops when it holds, so the reflex's region is never too small.
#[inline(never)]
pub fn arrest_point(brake_q32: i32, theta_q16: i32, omega_q16: i32) -> i32 {
    theta_q16.saturating_add(signed_square(omega_q16, brake_q32))
}

/// Which way a link turns for friction's purposes: 1 or -1 above [`LinkConst::moving_q16`],
/// 0 below it (at rest).
fn turning(k: &LinkConst, omega_q16: i32) -> i32 {
    if omega_q16 > k.moving_q16 {
        1
    } else if omega_q16 < -k.moving_q16 {
        -1
    } else {
        0
    }
}

/// Near-goal corrections (beyond the thesis), applied to the law's torque `u_q16`:
///
/// * at rest within the dead band of the goal ([`params::DEADBAND_COUNTS`]), only the law's
///   damping acts:
///   the link rests where friction holds it instead of hunting between counts (a position
///   gain stiff enough to be fast moves the link a whole count against its breakaway
///   friction, and would limit-cycle across the goal);
/// * Coulomb friction compensation: while the link moves, the friction torque in the
///   direction of motion; at rest outside the dead band, the friction torque in the
///   direction the law pushes (a smooth sign over 0.1 N m so tiny commands do not chatter).
///
/// Both are off for constants without a dead band (the thesis's law).
#[inline(never)]
pub fn near_goal(k: &LinkConst, u_q16: i32, err_q16: i32, omega_q16: i32) -> i32 {
    if k.deadband_q16 == 0 {
        return u_q16;
    }
    let dir_q16 = match turning(k, omega_q16) {
        0 if err_q16.saturating_abs() <= k.deadband_q16 => {
            return -mul_shr(k.b_q16, omega_q16, 16);
        }
        // u / 0.1 N m, clamped to +-1.
        0 => mul_shr(u_q16, 10 * ONE_Q16, 16).clamp(-ONE_Q16, ONE_Q16),
        d if d > 0 => ONE_Q16,
        _ => -ONE_Q16,
    };
    u_q16
        .saturating_add(mul_shr(k.friction_comp_q16, dir_q16, 16))
        .clamp(-k.umax_q16, k.umax_q16)
}

/// The notch at a link's first resonance, on the commanded torque (beyond the thesis), in
/// Q11 N m: its data are i16 and its coefficients Q13 i16 ([`params::LinkConst::notch_q13`]),
/// so that the 68020 filters with 16-bit and 32-bit products and no range checks.
/// `repr(C)`: `__servo_control2` keeps it ([`layout`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct Notch {
    x1: i32,
    x2: i32,
    y1: i32,
    y2: i32,
}

impl Notch {
    /// Filters one torque sample, Q16 N m within +-umax, into Q11 N m (the input rounded to
    /// Q11 when the link has no notch). The sum cannot overflow: the input is within +-umax
    /// (below 16 N m, 2^15 in Q11), the output is clamped to an i16, and the coefficients'
    /// magnitudes sum below 2^15 (both asserted in [`params`]).
    #[inline(never)]
    pub fn filter(&mut self, k: &LinkConst, x_q16: i32) -> i32 {
        let [b0, a1, a2] = k.notch_q13;
        let x = (x_q16 + 16) >> 5;
        if b0 == 0 {
            return x;
        }
        let y = ((b0 * (x + self.x2) + a1 * (self.x1 - self.y1) - a2 * self.y2 + (1 << 12)) >> 13)
            .clamp(-32767, 32767);
        self.x2 = self.x1;
        self.x1 = x;
        self.y2 = self.y1;
        self.y1 = y;
        y
    }
}

/// The on-line inertia estimate of one link (beyond the thesis): while the law accelerates
/// the link at full torque, the impulse applied over the velocity gained is the inertia
/// (friction makes it a little larger, the safe side for braking). It sets the switching
/// curve's I / (2 u^). `repr(C)`: `__servo_control2` keeps it ([`layout`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C, align(4))]
pub struct InertiaEstimate {
    /// The switching curve's I / (2 u^), Q32 s^2/rad.
    pub brake_q32: i32,
    /// The braking curve's 2 u^ / I, Q16 rad/s^2 (for [`proximate_law`]).
    pub two_a_q16: i32,
    /// The last accepted inertia, Q32 kg m^2 (0 until one is accepted).
    pub inertia_q32: i32,
    impulse_q16: i32,
    omega0_q16: i32,
    /// The proximate law's y_l and c for `two_a_q16`, Q16 (recomputed with it).
    yl_q16: i32,
    c_q16: i32,
    active: bool,
}

impl InertiaEstimate {
    /// The nominal curve of link constants `k`.
    pub const fn new(k: &LinkConst) -> Self {
        Self {
            brake_q32: k.brake_q32,
            two_a_q16: k.two_a_q16,
            inertia_q32: 0,
            impulse_q16: 0,
            omega0_q16: 0,
            yl_q16: k.yl_q16,
            c_q16: k.c_q16,
            active: false,
        }
    }

    /// Accounts for one pass: `accelerating` when the torque `applied_q16` is full and pushes
    /// the way the link turns; `prev_applied_q16` is the torque that acted over the `dt_q32`
    /// that just ended.
    #[inline(never)]
    pub fn observe(
        &mut self,
        k: &LinkConst,
        accelerating: bool,
        prev_applied_q16: i32,
        omega_q16: i32,
        dt_q32: i32,
    ) {
        if k.adapt_min_dw_q16 == 0 || !accelerating {
            self.active = false;
            return;
        }
        if !self.active {
            self.active = true;
            self.impulse_q16 = 0;
            self.omega0_q16 = omega_q16;
            return;
        }
        // Plain arithmetic (saturating forms compiled to condition-code clobbers on the 68k,
        // docs/toolchain.md): the velocities are clamped by the observer to twice the speed
        // limit (< 2^26 in Q16) and the impulse grows by at most umax x 10 ms per pass and
        // is restarted on every new acceleration; a full-torque phase is far shorter than
        // the 2^31 / (umax x 3 kHz) passes it would take to overflow.
        self.impulse_q16 += mul_shr(prev_applied_q16, dt_q32.min(MAX_DT_Q32), 32);
        let dw = omega_q16 - self.omega0_q16;
        if dw.abs() < k.adapt_min_dw_q16 {
            return;
        }
        // (impulse 2^16 2 2^31) / (dw 2^16) = I in Q32.
        let i = div_shl(self.impulse_q16 * 2, dw, 31);
        if i >= k.inertia_lo_q32 && i <= k.inertia_hi_q32 {
            self.inertia_q32 = i;
            self.brake_q32 = mul_shr(i, k.inv_two_uhat_q24, 24);
            // (u^ 2^16 2^31) / (I 2^30) = 2 u^ / I in Q16.
            self.two_a_q16 = div_shl(k.uhat_q16, i >> 2, 31);
            (self.yl_q16, self.c_q16) = curve_offsets(k, self.two_a_q16);
        }
    }
}

/// Whether DAC code `code` is full torque in the direction the link turns (`omega_q16`).
/// (Branches, not `signum`: the product form compiled to a condition-code clobber on the
/// 68k in `Servo::step`; docs/toolchain.md.)
#[inline(never)]
fn pushes_at_full_torque(code: i16, omega_q16: i32) -> bool {
    if omega_q16 > 0 {
        code >= params::DAC_MAX
    } else if omega_q16 < 0 {
        code <= -params::DAC_MAX
    } else {
        false
    }
}

/// The DAC code for a torque (Q16 N m) on a link: never beyond the 12-bit range, and the
/// range itself is umax. (The law's own is [`dac_code_q11`]; the bench's baseline
/// controllers use this one.)
#[inline(never)]
pub fn dac_code(k: &LinkConst, torque_q16: i32) -> i16 {
    mul_shr(torque_q16, k.dac_per_nm_q16, 32).clamp(params::DAC_MIN as i32, params::DAC_MAX as i32)
        as i16
}

/// The law's DAC code for its torque in Q11 N m (within i16, as [`Notch::filter`] gives
/// it): round(torque x codes per N m), within the 12-bit range; one `MULS.W` on the 68020.
#[inline(never)]
pub fn dac_code_q11(k: &LinkConst, torque_q11: i32) -> i16 {
    ((torque_q11 * k.dac_per_nm_q5 + (1 << 15)) >> 16)
        .clamp(params::DAC_MIN as i32, params::DAC_MAX as i32) as i16
}

/// Largest plausible difference between measurement and estimate beyond the distance the
/// link can travel in the period: 0.01 rad (Q16), some fifty link-1 counts.
pub const MAX_INNOVATION_Q16: i32 = 655;
/// Longest period the observer integrates over in one update: 10 ms (Q32 s).
pub const MAX_DT_Q32: i32 = 42_949_673;
/// Time after start-up before the observers count as locked (30 ms, Q32 s): some six
/// time constants of their 100 Hz, zeta 0.71 error dynamics.
pub const OBSERVER_SETTLE_Q32: i32 = 128_849_019;

/// The Luenberger observer of one link (Appendix A): position and velocity estimates driven
/// by the measured position and the commanded torque.
///
/// The position estimate is kept in Q24 (2^-24 rad): in Q16 a velocity estimate below one
/// LSB per period (0.005 rad/s at 3 kHz) moves the estimate by nothing, so a link at rest
/// could keep a phantom velocity that the law then damps against, holding torque forever.
/// `repr(C)`: `__servo_observe2` updates it ([`layout`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct Observer {
    theta_q24: i32,
    /// Estimated velocity, Q16 rad/s.
    pub omega_q16: i32,
}

impl Observer {
    /// An observer locked onto angle `theta_q16` at rest.
    pub const fn at(theta_q16: i32) -> Self {
        Self {
            theta_q24: theta_q16 << 8,
            omega_q16: 0,
        }
    }

    /// Estimated angle, Q16 rad.
    pub fn theta_q16(&self) -> i32 {
        mul_shr(self.theta_q24, 1, 8)
    }

    /// Advances by `dt_q32` seconds (Q32) with measurement `y_q16` and the torque `u_q16` that
    /// was applied over the interval.
    ///
    /// An innovation beyond what the link can travel in the period plus
    /// [`MAX_INNOVATION_Q16`] is implausible (an encoder glitch): the observer re-locks onto
    /// the measurement at rest instead of integrating it. The period is bounded by
    /// [`MAX_DT_Q32`].
    #[inline(never)]
    pub fn update(&mut self, k: &LinkConst, y_q16: i32, u_q16: i32, dt_q32: i32) {
        let e = y_q16.saturating_mul(256).saturating_sub(self.theta_q24); // Q24 rad
        let dt = dt_q32.min(MAX_DT_Q32);
        // Implausible: further than the link can move in the period at twice its speed
        // limit, plus 0.01 rad. (A fixed bound would keep re-locking, at rest, an observer
        // started while the link was already turning fast.)
        let bound = mul_shr(k.omega_limit_q16, dt, 32).saturating_add(MAX_INNOVATION_Q16);
        if e.saturating_abs() > bound.saturating_mul(256) {
            *self = Observer::at(y_q16);
            return;
        }
        // The torque that accelerates the link: the commanded one less the friction the law
        // compensates for (when it does). Without this, a link held by friction while the
        // law pushes makes the observer see a velocity that is not there, which cancels
        // part of the law's position term and leaves the link stuck counts from the goal.
        let f = k.friction_comp_q16;
        let friction = match turning(k, self.omega_q16) {
            0 => u_q16.clamp(-f, f),
            d if d > 0 => f,
            _ => -f,
        };
        let net = u_q16.saturating_sub(friction);
        let dtheta = self.omega_q16.saturating_add(mul_shr(k.k1_q16, e, 24)); // Q16 rad/s
        let accel = mul_shr(net, k.inv_inertia_q16, 16).saturating_add(mul_shr(k.k2_q8, e, 16)); // Q16 rad/s^2
        self.theta_q24 = self.theta_q24.saturating_add(mul_shr(dtheta, dt, 24));
        // Physical bound: no link turns faster than its motors' speed limit (x2 margin).
        self.omega_q16 = self
            .omega_q16
            .saturating_add(mul_shr(accel, dt, 32))
            .clamp(-k.omega_limit_q16, k.omega_limit_q16);
    }
}

/// The regime the assembly's code `r` stands for (0 saturated, 1 sliding, 2 linear).
#[cfg(target_arch = "m68k")]
#[inline(always)]
fn regime_of(r: u32) -> Regime {
    match r {
        0 => Regime::Saturated,
        1 => Regime::Sliding,
        _ => Regime::Linear,
    }
}

/// One link's control state between passes: the inertia estimate, the notch and the torque
/// last commanded. `repr(C)`: `__servo_control2` keeps it on the 68020 ([`layout`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C, align(4))]
pub struct LinkState {
    /// The inertia estimate and the switching curve it sets.
    pub est: InertiaEstimate,
    /// The notch on the command.
    pub notch: Notch,
    /// The torque the amplifier produces for the last DAC code, Q16 N m.
    pub torque_q16: i32,
}

impl LinkState {
    /// A link that has commanded nothing yet, with constants `k`.
    pub const fn new(k: &LinkConst) -> Self {
        Self {
            est: InertiaEstimate::new(k),
            notch: Notch {
                x1: 0,
                x2: 0,
                y1: 0,
                y2: 0,
            },
            torque_q16: 0,
        }
    }

    /// Updates observer `obs` with the measured angle `y_q16` over `dt_q32` (the torque last
    /// commanded acted over it): [`Observer::update`]; returns the arrest point from
    /// `y_q16` and the new velocity estimate ([`arrest_point`]). On the 68020,
    /// [`Servo::step`] runs this for both links in one call of `__servo_observe2`.
    pub fn observe(&self, k: &LinkConst, obs: &mut Observer, y_q16: i32, dt_q32: i32) -> i32 {
        obs.update(k, y_q16, self.torque_q16, dt_q32);
        arrest_point(self.est.brake_q32, y_q16, obs.omega_q16)
    }

    /// One pass of the law for position error `err_q16` and velocity `omega_q16`: the law
    /// ([`proximate_law`] or [`law`]), [`near_goal`], the notch, the DAC code; then the
    /// inertia estimate (while `settled`, the observers locked) and the torque the code
    /// makes (`torque_q16`, for the observer's next update). Returns the code and the
    /// regime. On the 68020, [`Servo::step`] runs this for both links in one call of
    /// `__servo_control2` (for the proximate law).
    pub fn control(
        &mut self,
        k: &LinkConst,
        err_q16: i32,
        omega_q16: i32,
        dt_q32: i32,
        settled: bool,
    ) -> (i16, Regime) {
        let (u, r) = if k.proximate {
            proximate_law_with(
                k,
                self.est.two_a_q16,
                self.est.yl_q16,
                self.est.c_q16,
                err_q16,
                omega_q16,
            )
        } else {
            law(k, self.est.brake_q32, err_q16, omega_q16)
        };
        let u = self.notch.filter(k, near_goal(k, u, err_q16, omega_q16));
        let code = dac_code_q11(k, u);
        // The torque the amplifier will actually produce, for the observer's next update.
        let applied = code as i32 * k.nm_per_dac_q16;
        // Full torque the way the link turns (the code at the DAC's end of range).
        let full = settled && pushes_at_full_torque(code, omega_q16);
        self.est
            .observe(k, full, self.torque_q16, omega_q16, dt_q32);
        self.torque_q16 = applied;
        (code, r)
    }
}

/// Byte offsets of the structures the servo image's assembly (`__servo_observe2`,
/// `__servo_control2` in `crates/rt/asm/servo.S`) reads and writes; the assembly names the
/// same numbers.
pub mod layout {
    use super::{InertiaEstimate, LinkConst, LinkState, Notch, Observer};
    use core::mem::{offset_of, size_of};
    const _: () = assert!(offset_of!(LinkConst, rad_per_count_q32) == 0);
    const _: () = assert!(offset_of!(LinkConst, inv_inertia_q16) == 4);
    const _: () = assert!(offset_of!(LinkConst, umax_q16) == 8);
    const _: () = assert!(offset_of!(LinkConst, inv_two_uhat_q24) == 32);
    const _: () = assert!(offset_of!(LinkConst, inertia_lo_q32) == 36);
    const _: () = assert!(offset_of!(LinkConst, inertia_hi_q32) == 40);
    const _: () = assert!(offset_of!(LinkConst, adapt_min_dw_q16) == 44);
    const _: () = assert!(offset_of!(LinkConst, notch_q13) == 48);
    const _: () = assert!(offset_of!(LinkConst, friction_comp_q16) == 60);
    const _: () = assert!(offset_of!(LinkConst, deadband_q16) == 64);
    const _: () = assert!(offset_of!(LinkConst, moving_q16) == 68);
    const _: () = assert!(offset_of!(LinkConst, dac_per_nm_q16) == 72);
    const _: () = assert!(offset_of!(LinkConst, nm_per_dac_q16) == 76);
    const _: () = assert!(offset_of!(LinkConst, k1_q16) == 80);
    const _: () = assert!(offset_of!(LinkConst, k2_q8) == 84);
    const _: () = assert!(offset_of!(LinkConst, omega_limit_q16) == 88);
    const _: () = assert!(offset_of!(LinkConst, uhat_q16) == 96);
    const _: () = assert!(offset_of!(LinkConst, b_q16) == 100);
    const _: () = assert!(offset_of!(LinkConst, slope_q16) == 104);
    const _: () = assert!(offset_of!(LinkConst, c_per_two_a_q32) == 108);
    const _: () = assert!(offset_of!(LinkConst, yl_per_two_a_q32) == 112);
    const _: () = assert!(offset_of!(LinkConst, dac_per_nm_q5) == 128);
    const _: () = assert!(offset_of!(LinkConst, sat_arg_q16) == 132);
    const _: () = assert!(offset_of!(LinkConst, proximate) == 136);
    /// Bytes of one link's constants (`repr(C, align(4))`: the same on the 68020, where an
    /// `i32` aligns to 2, as on the host).
    pub const LINK_CONST_BYTES: usize = 140;
    const _: () = assert!(size_of::<LinkConst>() == LINK_CONST_BYTES);
    const _: () = assert!(offset_of!(Observer, theta_q24) == 0);
    const _: () = assert!(offset_of!(Observer, omega_q16) == 4);
    /// Bytes of one observer.
    pub const OBSERVER_BYTES: usize = 8;
    const _: () = assert!(size_of::<Observer>() == OBSERVER_BYTES);
    const _: () = assert!(offset_of!(InertiaEstimate, brake_q32) == 0);
    const _: () = assert!(offset_of!(InertiaEstimate, two_a_q16) == 4);
    const _: () = assert!(offset_of!(InertiaEstimate, inertia_q32) == 8);
    const _: () = assert!(offset_of!(InertiaEstimate, impulse_q16) == 12);
    const _: () = assert!(offset_of!(InertiaEstimate, omega0_q16) == 16);
    const _: () = assert!(offset_of!(InertiaEstimate, yl_q16) == 20);
    const _: () = assert!(offset_of!(InertiaEstimate, c_q16) == 24);
    const _: () = assert!(offset_of!(InertiaEstimate, active) == 28);
    const _: () = assert!(size_of::<InertiaEstimate>() == 32);
    const _: () = assert!(offset_of!(Notch, x1) == 0);
    const _: () = assert!(offset_of!(Notch, x2) == 4);
    const _: () = assert!(offset_of!(Notch, y1) == 8);
    const _: () = assert!(offset_of!(Notch, y2) == 12);
    const _: () = assert!(offset_of!(LinkState, est) == 0);
    const _: () = assert!(offset_of!(LinkState, notch) == 32);
    const _: () = assert!(offset_of!(LinkState, torque_q16) == 48);
    /// Bytes of one link's control state.
    pub const LINK_STATE_BYTES: usize = 52;
    const _: () = assert!(size_of::<LinkState>() == LINK_STATE_BYTES);
    // `Output` as the image lays it out, and the values `__servo_pass` writes into its
    // enums: no hold (`Option<Hold>`'s `None`, a niche) and the regimes.
    #[cfg(target_arch = "m68k")]
    const _: () = {
        use super::Output;
        assert!(offset_of!(Output, dac) == 0);
        assert!(offset_of!(Output, enable) == 4);
        assert!(offset_of!(Output, theta_q16) == 6);
        assert!(offset_of!(Output, omega_q16) == 14);
        assert!(offset_of!(Output, arrest_q16) == 22);
        assert!(offset_of!(Output, torque_q16) == 30);
        assert!(offset_of!(Output, goal_q16) == 38);
        assert!(offset_of!(Output, period_ticks) == 46);
        assert!(offset_of!(Output, hold) == 48);
        assert!(offset_of!(Output, new_fault) == 49);
        assert!(offset_of!(Output, regime) == 50);
        assert!(offset_of!(Output, arrest_new) == 52);
    };
    const _: () = assert!(size_of::<Option<super::Hold>>() == 1);
    // SAFETY: `Option<Hold>` is one byte (asserted above); reading `None`'s byte. (Where
    // the niche goes is the compiler's choice: the pinned nightly puts it at 255, stable
    // 1.95 at 4; this assert is what keeps the routine's `HOLD_NONE` honest.)
    const _: () = assert!(unsafe { core::mem::transmute::<Option<super::Hold>, u8>(None) } == 255);
    const _: () = assert!(super::Hold::Stale as u8 == 1);
    const _: () = assert!(super::Hold::OutOfRange as u8 == 3);
    const _: () = assert!(super::Regime::Saturated as u8 == 0);
    const _: () = assert!(super::Regime::Sliding as u8 == 1);
    const _: () = assert!(super::Regime::Linear as u8 == 2);
    // The constants `__servo_pass` holds as `.equ`s.
    const _: () = assert!(crate::params::TIMER_TICK_Q40 == 549_756);
    const _: () = assert!(super::STALE_Q32 == 85_899_346);
    const _: () = assert!(super::OBSERVER_SETTLE_Q32 == 128_849_019);
    const _: () = assert!(super::MAX_DT_Q32 == 42_949_673);
    const _: () = assert!(super::MAX_INNOVATION_Q16 == 655);
    const _: () = assert!(super::ANGLE_LIMIT_URAD == 25_000_000);
    const _: () = assert!(super::URAD_TO_Q16_Q32 == 281_474_977);
    // `Servo` and its arrest log as the image lays them out (an `i32` aligns to 2 on the
    // 68020, and a pointer is 4 bytes): `__servo_pass` uses these offsets.
    #[cfg(target_arch = "m68k")]
    const _: () = {
        use super::arrest_log::{ArrestLog, PASSES};
        use super::{Input, Servo, Subgoal};
        assert!(offset_of!(Input, enc) == 0 && offset_of!(Input, timer) == 4);
        assert!(offset_of!(Subgoal, goal_urad) == 0 && offset_of!(Subgoal, cycle) == 8);
        assert!(size_of::<Subgoal>() == 12);
        assert!(offset_of!(Servo, started) == 0);
        assert!(offset_of!(Servo, last_enc) == 2);
        assert!(offset_of!(Servo, counts) == 6);
        assert!(offset_of!(Servo, last_timer) == 14);
        assert!(offset_of!(Servo, links) == 16);
        assert!(offset_of!(Servo, obs) == 20);
        assert!(offset_of!(Servo, law) == 36);
        assert!(offset_of!(Servo, last_cycle) == 140);
        assert!(offset_of!(Servo, has_cycle) == 144);
        assert!(offset_of!(Servo, since_cycle_q32) == 146);
        assert!(offset_of!(Servo, since_start_q32) == 150);
        assert!(offset_of!(Servo, hold_goal_q16) == 154);
        assert!(offset_of!(Servo, has_hold_goal) == 162);
        assert!(offset_of!(Servo, hold) == 163);
        assert!(offset_of!(Servo, goal_memo_urad) == 164);
        assert!(offset_of!(Servo, goal_memo_q16) == 172);
        assert!(offset_of!(Servo, arrest_q16) == 180);
        assert!(offset_of!(Servo, clock_q24) == 188);
        assert!(offset_of!(Servo, arrest_due) == 192);
        assert!(offset_of!(Servo, log) == 194);
        assert!(ArrestLog::N_OFFSET == 0 && ArrestLog::KEPT_OFFSET == 4);
        assert!(ArrestLog::T_OFFSET == 8 && ArrestLog::ARREST_OFFSET == 8 + 4 * PASSES);
        assert!(PASSES == 128);
    };

    /// Writes the words `w` big-endian from byte 0 on.
    fn words<const N: usize>(w: &[i32]) -> [u8; N] {
        let mut b = [0u8; N];
        for (i, v) in w.iter().enumerate() {
            b[4 * i..4 * i + 4].copy_from_slice(&v.to_be_bytes());
        }
        b
    }

    /// `k` as the 68020 holds it (big-endian, these offsets): for the tests that load it
    /// into the emulated CPU's memory.
    pub fn link_const_be(k: &LinkConst) -> [u8; LINK_CONST_BYTES] {
        let mut b: [u8; LINK_CONST_BYTES] = words(&[
            k.rad_per_count_q32,
            k.inv_inertia_q16,
            k.umax_q16,
            k.uhat_over_umax_q16,
            k.inv_omega_sat_q16,
            k.eps_q16,
            k.inv_s_sat_q16,
            k.brake_q32,
            k.inv_two_uhat_q24,
            k.inertia_lo_q32,
            k.inertia_hi_q32,
            k.adapt_min_dw_q16,
            k.notch_q13[0],
            k.notch_q13[1],
            k.notch_q13[2],
            k.friction_comp_q16,
            k.deadband_q16,
            k.moving_q16,
            k.dac_per_nm_q16,
            k.nm_per_dac_q16,
            k.k1_q16,
            k.k2_q8,
            k.omega_limit_q16,
            k.linear_band_q16,
            k.uhat_q16,
            k.b_q16,
            k.slope_q16,
            k.c_per_two_a_q32,
            k.yl_per_two_a_q32,
            k.two_a_q16,
            k.yl_q16,
            k.c_q16,
            k.dac_per_nm_q5,
            k.sat_arg_q16,
        ]);
        b[offset_of!(LinkConst, proximate)] = k.proximate as u8;
        b
    }

    /// `o` as the 68020 holds it (for the tests).
    pub fn observer_be(o: &Observer) -> [u8; OBSERVER_BYTES] {
        words(&[o.theta_q24, o.omega_q16])
    }

    /// `s` as the 68020 holds it (for the tests).
    pub fn link_state_be(s: &LinkState) -> [u8; LINK_STATE_BYTES] {
        let e = &s.est;
        let n = &s.notch;
        let mut b: [u8; LINK_STATE_BYTES] = words(&[
            e.brake_q32,
            e.two_a_q16,
            e.inertia_q32,
            e.impulse_q16,
            e.omega0_q16,
            e.yl_q16,
            e.c_q16,
            0,
            n.x1,
            n.x2,
            n.y1,
            n.y2,
            s.torque_q16,
        ]);
        b[offset_of!(InertiaEstimate, active)] = e.active as u8;
        b
    }
}

/// What the board read this pass. `repr(C)`: the image's `__servo_pass` reads the
/// encoder latches and the timer at its head.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct Input {
    /// Latched 16-bit encoder counts of both motors.
    pub enc: [u16; 2],
    /// The 2 MHz free-running 16-bit timer.
    pub timer: u16,
    /// The reflex subgoal, if a whole record could be read.
    pub subgoal: Option<Subgoal>,
}

/// A subgoal as published by the reflex board. `repr(C)`: the servo image's board pass
/// (`__servo_board_pass`) reads a record into one and hands it to `__servo_pass`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct Subgoal {
    /// Goal angles, micro-radians (absolute).
    pub goal_urad: [i32; 2],
    /// The reflex's cycle counter: it must keep changing.
    pub cycle: u32,
}

/// Why the servo is holding at its arrest point instead of following the subgoal.
/// `repr(u8)`: the image's `__servo_pass` writes the values (`servo::layout` asserts them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Hold {
    /// No subgoal has arrived yet (start-up, or no reflex board): hold quietly.
    NoSubgoal,
    /// The subgoal stopped changing for longer than [`STALE_S`].
    Stale,
    /// The subgoal record was torn beyond retry.
    Torn,
    /// The subgoal is outside the arm's angle range.
    OutOfRange,
}

/// A subgoal older than this is stale: the reflex runs at 1 kHz or more.
pub const STALE_S: f64 = 0.02;
/// [`STALE_S`] in Q32 seconds, fixed at compile time (no floating point in the image).
const STALE_Q32: i32 = consts::round(STALE_S * consts::Q32) as i32;
/// Largest plausible absolute angle (the encoders' unwrap range is +-4 revolutions).
pub const ANGLE_LIMIT_URAD: i32 = 25_000_000;

/// What the servo computed this pass. `repr(C)`: `__servo_pass` writes it on the 68020
/// ([`layout`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct Output {
    /// DAC codes for both amplifiers.
    pub dac: [i16; 2],
    /// Whether the amplifiers may be enabled (false on the first pass: no time base yet).
    pub enable: bool,
    /// Measured angles, Q16 rad.
    pub theta_q16: [i32; 2],
    /// Observed velocities, Q16 rad/s.
    pub omega_q16: [i32; 2],
    /// Arrest points, Q16 rad.
    pub arrest_q16: [i32; 2],
    /// Commanded torques, Q16 N m.
    pub torque_q16: [i32; 2],
    /// The goal being servoed to, Q16 rad.
    pub goal_q16: [i32; 2],
    /// Loop period measured from the timer, in 2 MHz ticks.
    pub period_ticks: u16,
    /// Set while holding instead of following the subgoal.
    pub hold: Option<Hold>,
    /// Set on the pass the servo starts holding for a fault (not for `NoSubgoal`).
    pub new_fault: Option<Hold>,
    /// The law's regime per link.
    pub regime: [Regime; 2],
    /// Set on the passes that computed `arrest_q16` (every other pass; the others carry
    /// the last): the board publishes its state on the others, so that no pass does both.
    pub arrest_new: bool,
}

impl Output {
    /// Words of [`Output::probe_words`].
    pub const PROBE_WORDS: usize = 16;

    /// The output as the words the servo image's test probe writes a pass (and the system
    /// test compares with the host's): both DAC codes, both velocities, angles, arrest
    /// points, goals and torques (Q16), the period in ticks, the hold and the new fault (0
    /// none, else 1 + [`Hold`]), `regime 1 << 8 | regime 2 | enable << 16 | arrest_new << 17`.
    pub fn probe_words(&self) -> [i32; Self::PROBE_WORDS] {
        let hold = |h: Option<Hold>| h.map_or(0, |h| 1 + h as i32);
        [
            self.dac[0] as i32,
            self.dac[1] as i32,
            self.omega_q16[0],
            self.omega_q16[1],
            self.theta_q16[0],
            self.theta_q16[1],
            self.arrest_q16[0],
            self.arrest_q16[1],
            self.goal_q16[0],
            self.goal_q16[1],
            self.torque_q16[0],
            self.torque_q16[1],
            self.period_ticks as i32,
            hold(self.hold),
            hold(self.new_fault),
            (self.regime[0] as i32) << 8
                | self.regime[1] as i32
                | (self.enable as i32) << 16
                | (self.arrest_new as i32) << 17,
        ]
    }

    /// An output before any pass: nothing commanded, amplifiers off, angles 0.
    pub const IDLE: Output = Output {
        dac: [0; 2],
        enable: false,
        theta_q16: [0; 2],
        omega_q16: [0; 2],
        arrest_q16: [0; 2],
        torque_q16: [0; 2],
        goal_q16: [0; 2],
        period_ticks: 0,
        hold: None,
        new_fault: None,
        regime: [Regime::Linear; 2],
        arrest_new: false,
    };
}

/// The servo of both links. `repr(C)` with the arrest log last: LLVM's M68k backend reached
/// fields behind the log's 1.5 KiB by loading the offset into a register and indexing with
/// it (docs/toolchain.md, "Field order is a cost").
#[derive(Clone, Debug)]
#[repr(C)]
pub struct Servo {
    started: bool,
    last_enc: [u16; 2],
    counts: [i32; 2],
    last_timer: u16,
    links: &'static [LinkConst; 2],
    obs: [Observer; 2],
    law: [LinkState; 2],
    /// The reflex cycle of the last subgoal (meaningful once `has_cycle`).
    last_cycle: u32,
    /// Whether a subgoal has arrived since start-up. (Two plain fields, not an
    /// `Option<u32>`: the image's `__servo_pass` reads and writes them.)
    has_cycle: bool,
    since_cycle_q32: i32,
    since_start_q32: i32,
    /// The goal of a hold, once chosen (meaningful while `has_hold_goal`). (Two plain
    /// fields, not an `Option<[i32; 2]>`: the image's `__servo_pass` tests the flag.)
    hold_goal_q16: [i32; 2],
    has_hold_goal: bool,
    hold: Option<Hold>,
    /// The last subgoal converted ([`Servo::goal_q16`]): its angles in urad and in Q16.
    goal_memo_urad: [i32; 2],
    goal_memo_q16: [i32; 2],
    /// The arrest points, Q16 rad, computed and logged every other pass (`arrest_due`; the
    /// passes between carry them): the board publishes its state on those between, so the
    /// two halve each other's cost in the image's pass (docs/servo.md).
    arrest_q16: [i32; 2],
    /// The log's clock: the sum of the pass periods, Q24 s.
    clock_q24: u32,
    /// Whether this pass computes and logs the arrest points.
    arrest_due: bool,
    /// The arrest points of the last passes: a hold for a subgoal that stopped coming holds
    /// at the arrest point of the moment it stopped.
    log: arrest_log::ArrestLog,
}

impl Default for Servo {
    fn default() -> Self {
        Self::new()
    }
}

impl Servo {
    /// A servo that has seen nothing yet, running the tuned law ([`params::TUNED`]).
    pub const fn new() -> Self {
        Self::with_links(&params::TUNED)
    }

    /// A servo running the law with the constants `links` (for example
    /// [`params::THESIS`], the thesis's own parameters).
    pub const fn with_links(links: &'static [LinkConst; 2]) -> Self {
        Self {
            started: false,
            last_enc: [0; 2],
            counts: [0; 2],
            last_timer: 0,
            links,
            obs: [Observer::at(0); 2],
            law: [LinkState::new(&links[0]), LinkState::new(&links[1])],
            last_cycle: 0,
            has_cycle: false,
            since_cycle_q32: 0,
            since_start_q32: 0,
            hold_goal_q16: [0; 2],
            has_hold_goal: false,
            hold: None,
            goal_memo_urad: [0; 2],
            goal_memo_q16: [0; 2],
            arrest_q16: [0; 2],
            clock_q24: 0,
            arrest_due: false,
            log: arrest_log::ArrestLog::new(),
        }
    }

    /// The observers' state.
    pub fn observers(&self) -> [Observer; 2] {
        self.obs
    }

    /// One pass of the servo loop.
    pub fn step(&mut self, input: &Input) -> Output {
        let mut out = Output::IDLE;
        self.step_into(input, &mut out);
        out
    }

    /// [`Servo::step`] with the output written to `out`: on the 68020 the common pass
    /// writes it in place (the board keeps it; a returned `Output` is copied once more).
    pub fn step_into(&mut self, input: &Input, out: &mut Output) {
        if !self.started {
            *out = self.first_step(input);
            return;
        }
        #[cfg(target_arch = "m68k")]
        if self.pass_in_asm(input, out) {
            return;
        }
        *out = self.step_rust(input);
    }

    /// A pass after the first in Rust (on the 68020: one that is not the common one).
    /// Not inlined: in [`Servo::step_into`] its registers and frame cost the image's common
    /// pass 65 cycles (`sim-host profile servo`: 7,410 inlined, 7,345 not).
    #[inline(never)]
    fn step_rust(&mut self, input: &Input) -> Output {
        // Extend the 16-bit counters.
        let c0 =
            self.counts[0].wrapping_add(input.enc[0].wrapping_sub(self.last_enc[0]) as i16 as i32);
        let c1 =
            self.counts[1].wrapping_add(input.enc[1].wrapping_sub(self.last_enc[1]) as i16 as i32);
        let (ticks, dt_q32) = self.take_counts(input, [c0, c1]);
        // The observers start at rest: until they have locked onto a link that was already
        // moving, the velocity they report is not the torque's doing.
        let settled = self.observers_settled(dt_q32);
        let (theta, arrest_now) = self.observe_both(dt_q32);
        let omega = [self.obs[0].omega_q16, self.obs[1].omega_q16];
        let arrest_new = self.log_arrest(dt_q32, arrest_now);
        let arrest = self.arrest_q16;
        // The goal: the subgoal while it is fresh and plausible, else hold at the arrest point.
        let (goal, new_fault) = self.choose_goal(input.subgoal, dt_q32, arrest, false);
        let err = [theta[0] - goal[0], theta[1] - goal[1]];
        let ([d0, d1], [r0, r1]) = self.control_both(err, omega, dt_q32, settled);
        let [l0, l1] = &self.law;
        Output {
            dac: [d0, d1],
            enable: true,
            theta_q16: theta,
            omega_q16: omega,
            arrest_q16: arrest,
            torque_q16: [l0.torque_q16, l1.torque_q16],
            goal_q16: goal,
            period_ticks: ticks,
            hold: self.hold,
            new_fault,
            regime: [r0, r1],
            arrest_new,
        }
    }

    /// The first pass: the first latch is taken as absolute (the counters are zeroed with
    /// the arm at angle 0 before power-up), the observers start at rest on it, and nothing
    /// is commanded (no time base yet).
    #[cold]
    #[inline(never)]
    fn first_step(&mut self, input: &Input) -> Output {
        let counts = [input.enc[0] as i16 as i32, input.enc[1] as i16 as i32];
        let (ticks, dt_q32) = self.take_counts(input, counts);
        let theta = [self.angle(0), self.angle(1)];
        self.started = true;
        self.obs = [Observer::at(theta[0]), Observer::at(theta[1])];
        // At rest: the arrest point is the angle (computed and logged on this pass).
        let arrest = theta;
        self.arrest_due = true;
        self.log_arrest(dt_q32, arrest);
        let (goal, new_fault) = self.choose_goal(input.subgoal, dt_q32, arrest, true);
        for (s, k) in self.law.iter_mut().zip(self.links) {
            s.est.observe(k, false, 0, 0, dt_q32);
            s.torque_q16 = 0;
        }
        Output {
            dac: [0; 2],
            enable: false,
            theta_q16: theta,
            omega_q16: [0; 2],
            arrest_q16: arrest,
            torque_q16: [0; 2],
            goal_q16: goal,
            period_ticks: ticks,
            hold: self.hold,
            new_fault,
            regime: [Regime::Linear; 2],
            arrest_new: true,
        }
    }

    /// The image's common pass in one call of `__servo_pass` (`crates/rt/asm/servo.S`): a
    /// subgoal read whole, the proximate law on both links, following the subgoal or holding
    /// at a hold goal chosen on an earlier pass (out of range, stale). Before it changes
    /// anything the routine checks that (started, both links proximate, the subgoal's range
    /// and age, a hold goal if it holds) and returns 0 if the pass is not that one (the
    /// first pass of a hold among them); the Rust of [`Servo::step`] then runs it. Does what
    /// the Rust does, bit for bit (`the_servo_image_steps_like_the_host`): the counts, the
    /// period, the observers, the arrest log, the hold and its fault, the goal and the law.
    #[cfg(target_arch = "m68k")]
    #[inline(always)]
    fn pass_in_asm(&mut self, input: &Input, out: *mut Output) -> bool {
        extern "C" {
            fn __servo_pass(s: *mut u8, io: *const u16, sub: *const Subgoal, out: *mut u8) -> u32;
        }
        let Some(sub) = &input.subgoal else {
            return false;
        };
        // SAFETY: the routine reads the three I/O halfwords at the head of `Input`
        // (`repr(C)`) and the subgoal, reads and updates `self` at the offsets `layout`
        // asserts, and writes every field of `out` when it returns 1 (and nothing of `self`
        // or `out` when it returns 0).
        unsafe {
            let me = (self as *mut Self).cast();
            let io = (input as *const Input).cast();
            __servo_pass(me, io, sub, out.cast()) != 0
        }
    }

    /// Both links' angles (from the extended counts) and, after their observers' update,
    /// their arrest points: one call of `__servo_observe2` on the 68020.
    #[inline(always)]
    fn observe_both(&mut self, dt_q32: i32) -> ([i32; 2], [i32; 2]) {
        #[cfg(target_arch = "m68k")]
        {
            extern "C" {
                fn __servo_observe2(
                    k: *const LinkConst,
                    obs: *mut Observer,
                    s: *const LinkState,
                    counts: *const i32,
                    dt_q32: i32,
                    out: *mut [i32; 4],
                );
            }
            let mut out = [0i32; 4];
            // SAFETY: the routine reads both links' constants, states and counts, updates
            // both observers and writes `out`, at the offsets `layout` asserts.
            unsafe {
                __servo_observe2(
                    self.links.as_ptr(),
                    self.obs.as_mut_ptr(),
                    self.law.as_ptr(),
                    self.counts.as_ptr(),
                    dt_q32,
                    &mut out,
                )
            };
            ([out[0], out[1]], [out[2], out[3]])
        }
        #[cfg(not(target_arch = "m68k"))]
        {
            let theta = [self.angle(0), self.angle(1)];
            let [l0, l1] = &self.law;
            let [o0, o1] = &mut self.obs;
            let arrest = [
                l0.observe(&self.links[0], o0, theta[0], dt_q32),
                l1.observe(&self.links[1], o1, theta[1], dt_q32),
            ];
            (theta, arrest)
        }
    }

    /// [`LinkState::control`] of both links: one call of `__servo_control2` on the 68020
    /// (the proximate law's constants; the others run the Rust).
    #[inline(always)]
    fn control_both(
        &mut self,
        err: [i32; 2],
        omega: [i32; 2],
        dt_q32: i32,
        settled: bool,
    ) -> ([i16; 2], [Regime; 2]) {
        #[cfg(target_arch = "m68k")]
        if self.links[0].proximate && self.links[1].proximate {
            extern "C" {
                fn __servo_control2(
                    k: *const LinkConst,
                    s: *mut LinkState,
                    err: *const i32,
                    omega: *const i32,
                    dt_q32: i32,
                    settled: u32,
                    out: *mut [u32; 2],
                );
            }
            let mut out = [0u32; 2];
            // SAFETY: the routine reads both links' constants, errors and speeds, updates
            // both states and writes `out`, at the offsets `layout` asserts.
            unsafe {
                __servo_control2(
                    self.links.as_ptr(),
                    self.law.as_mut_ptr(),
                    err.as_ptr(),
                    omega.as_ptr(),
                    dt_q32,
                    settled as u32,
                    &mut out,
                )
            };
            return (
                [out[0] as u16 as i16, out[1] as u16 as i16],
                [regime_of(out[0] >> 16), regime_of(out[1] >> 16)],
            );
        }
        let [l0, l1] = &mut self.law;
        let (d0, r0) = l0.control(&self.links[0], err[0], omega[0], dt_q32, settled);
        let (d1, r1) = l1.control(&self.links[1], err[1], omega[1], dt_q32, settled);
        ([d0, d1], [r0, r1])
    }

    /// Keeps this pass's extended counts and encoder latches and the timer; returns the
    /// period in timer ticks and in Q32 seconds.
    #[inline(always)]
    fn take_counts(&mut self, input: &Input, counts: [i32; 2]) -> (u16, i32) {
        self.counts = counts;
        self.last_enc = input.enc;
        let ticks = input.timer.wrapping_sub(self.last_timer);
        self.last_timer = input.timer;
        (ticks, mul_shr(ticks as i32, TIMER_TICK_Q40, 8))
    }

    /// Link `i`'s angle from its extended count: the middle of the count (the link is
    /// somewhere in [n, n + 1) counts, so the count's floor is biased by half a count; with
    /// the goal's dead band of a count, the link parked up to two counts off the goal).
    #[inline(always)]
    fn angle(&self, i: usize) -> i32 {
        mul_shr(2 * self.counts[i] + 1, self.links[i].rad_per_count_q32, 17)
    }

    /// Advances the log's clock by the pass (Q24 s); on every other pass (`arrest_due`)
    /// keeps `arrest` as the arrest points and logs them. Returns whether this pass did.
    #[inline(always)]
    fn log_arrest(&mut self, dt_q32: i32, arrest: [i32; 2]) -> bool {
        self.clock_q24 = self.clock_q24.wrapping_add((dt_q32 >> 8) as u32);
        let due = self.arrest_due;
        if due {
            self.arrest_q16 = arrest;
            self.log.push(self.clock_q24, arrest);
        }
        self.arrest_due = !due;
        due
    }

    /// A subgoal's angles in Q16 ([`urad_to_q16`]), converted again only when they changed:
    /// at rest the reflex republishes the same goal every cycle, and the two conversions
    /// (`MULS.L` each) are ~130 of the image's cycles a pass. The image's `__servo_pass`
    /// keeps the same memo.
    fn goal_q16(&mut self, urad: [i32; 2]) -> [i32; 2] {
        if urad != self.goal_memo_urad {
            self.goal_memo_urad = urad;
            self.goal_memo_q16 = [urad_to_q16(urad[0]), urad_to_q16(urad[1])];
        }
        self.goal_memo_q16
    }

    /// Accounts for the time since start-up; true once the observers count as locked.
    #[inline(never)]
    fn observers_settled(&mut self, dt_q32: i32) -> bool {
        if self.since_start_q32 >= OBSERVER_SETTLE_Q32 {
            return true;
        }
        self.since_start_q32 += dt_q32.min(MAX_DT_Q32);
        false
    }

    #[inline(never)]
    fn choose_goal(
        &mut self,
        sub: Option<Subgoal>,
        dt_q32: i32,
        arrest: [i32; 2],
        first: bool,
    ) -> ([i32; 2], Option<Hold>) {
        let verdict = match sub {
            None if !self.has_cycle => Err(Hold::NoSubgoal),
            None => {
                self.since_cycle_q32 = self.since_cycle_q32.saturating_add(dt_q32);
                Err(Hold::Torn)
            }
            Some(s) => {
                if !self.has_cycle || self.last_cycle != s.cycle {
                    self.has_cycle = true;
                    self.last_cycle = s.cycle;
                    self.since_cycle_q32 = 0;
                } else if !first {
                    self.since_cycle_q32 = self.since_cycle_q32.saturating_add(dt_q32);
                }
                if s.goal_urad
                    .iter()
                    .any(|g| g.unsigned_abs() > ANGLE_LIMIT_URAD as u32)
                {
                    Err(Hold::OutOfRange)
                } else if self.since_cycle_q32 > STALE_Q32 {
                    Err(Hold::Stale)
                } else {
                    Ok(self.goal_q16(s.goal_urad))
                }
            }
        };
        match verdict {
            Ok(g) => {
                self.hold = None;
                self.has_hold_goal = false;
                (g, None)
            }
            Err(why) => {
                // Subgoals that stopped coming (stale, or torn since): the arrest point of
                // the last fresh one. A bad subgoal: the arrest point now.
                if !self.has_hold_goal {
                    // (No look-up for the others: a bad subgoal holds where the arm would
                    // stop now, and the first pass, waiting for a first subgoal, has no log.)
                    self.hold_goal_q16 = match why {
                        Hold::Stale | Hold::Torn => self.log.at_age(
                            self.clock_q24,
                            (self.since_cycle_q32 >> 8) as u32,
                            arrest,
                        ),
                        _ => arrest,
                    };
                    self.has_hold_goal = true;
                }
                let goal = self.hold_goal_q16;
                // A fault is new when the reason changes; waiting for a first subgoal is none.
                // (Written as a match: the boolean form compiled to CMP + SUBX, which reads a
                // stale X flag on the 68k; docs/toolchain.md.)
                let new = match why {
                    Hold::NoSubgoal => None,
                    w if self.hold == Some(w) => None,
                    w => Some(w),
                };
                self.hold = Some(why);
                (goal, new)
            }
        }
    }
}

#[cfg(test)]
mod tests;
