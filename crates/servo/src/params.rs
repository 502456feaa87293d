//! The law's parameters (thesis ch. III) and their fixed-point form.
//!
//! Two parameter sets are kept, both run by the same code:
//!
//! * [`THESIS`]: law III.36 exactly as the thesis ran it. Link 1 uses the thesis's values:
//!   u^ = 10.5, umax = 13 N m, eps = 4, omega_sat = 1.8 rad/s, s_sat = 0.23 rad. Near the goal
//!   the law acts like PD with stiffness K = u^ eps / s_sat (182.6 N m/rad) and damping
//!   b = u^ / omega_sat (5.83 N m s): with I = 0.047 kg m^2 that is 9.9 Hz with zeta = 0.995,
//!   the "10 Hz critically damped" of the thesis. Link 2 is derived the same way: umax is its
//!   torque limit (3.25 N m), u^/umax and eps are link 1's (0.808, 4), and omega_sat and s_sat
//!   give the same near-goal behaviour on link 2's inertia:
//!
//!   ```text
//!   wn = sqrt(K1 / I1)            b = 2 zeta wn I2      K = wn^2 I2
//!   omega_sat = u^ / b            s_sat = u^ eps / K
//!   ```
//!
//!   with wn and zeta link 1's, which gives omega_sat = 6.04 rad/s and s_sat = 0.772 rad.
//!
//! * [`TUNED`] (what the board runs): law III.36's structure with five changes, each
//!   measured by `sim-host bench servo` (docs/servo.md has the numbers):
//!   1. the proximate form of the switching curve ([`crate::proximate_law`]): near the goal
//!      the curve is offset to join the near-goal PD's no-overshoot line, where III.36 as
//!      printed lets the braking torque fall below u^ and the link overshoot;
//!   2. the inertia in the curve is measured on line from the velocity gained under full
//!      torque ([`crate::InertiaEstimate`]; [`PRIOR_INERTIA_SCALE`] x nominal until then), so
//!      u^ can be [`TUNED_UHAT_FRACTION`] of umax instead of the thesis's 0.81, which was
//!      margin for an inertia it did not know;
//!   3. a notch at the link's first resonance (212 Hz, 125 Hz) on the commanded torque: with
//!      the band's 0.02 damping ratio, law III.36 at 3 kHz otherwise excites it into a limit
//!      cycle through the motor-side (collocated) encoder;
//!   4. a stiffer near-goal loop, [`TUNED_NEAR_HZ`] critically damped, which the faster loop
//!      and the notch allow;
//!   5. near the goal ([`crate::near_goal`]) Coulomb friction compensation, a friction-aware
//!      observer, and a dead band of [`DEADBAND_COUNTS`] at rest: friction otherwise holds the link
//!      counts short, and a stiff position gain hunts across the goal.
//!
//! The observer's gains are the thesis's continuous ones (K1 = 900 /s, K2 = 400000 /s^2: 100 Hz,
//! zeta 0.71) mapped to the loop period [`T_NOMINAL_S`] by placing the discrete poles at
//! z = e^(sT) of the continuous ones, then expressed as rates so the observer can integrate
//! over the period the timer actually measures.

use crate::consts::{cos, exp, round, sin, sqrt, Q16, Q32};
use arm::{Link, KT_NM_PER_A, LINK1, LINK2};

/// Law III.36 parameters of one link, SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LawParams {
    /// Torque limit, N m.
    pub umax_nm: f64,
    /// Braking torque the switching curve assumes, N m.
    pub uhat_nm: f64,
    /// Weight of the switching-function term.
    pub eps: f64,
    /// Velocity saturation, rad/s.
    pub omega_sat_rad_s: f64,
    /// Switching-function saturation, rad.
    pub s_sat_rad: f64,
    /// Estimate the inertia on line for the switching curve (else the nominal one).
    pub adaptive: bool,
    /// Quality factor of the notch at the link's resonance; 0 = no notch.
    pub notch_q: f64,
    /// Coulomb friction compensation near the goal, N m; 0 = none.
    pub friction_comp_nm: f64,
    /// Run the proximate form of the law ([`crate::proximate_law`]) instead of III.36 as
    /// printed ([`crate::law`]); the parameters mean the same in both.
    pub proximate: bool,
}

/// Link 1 as the thesis ran it.
pub const LINK1_THESIS: LawParams = LawParams {
    umax_nm: 13.0,
    uhat_nm: 10.5,
    eps: 4.0,
    omega_sat_rad_s: 1.8,
    s_sat_rad: 0.23,
    adaptive: false,
    notch_q: 0.0,
    friction_comp_nm: 0.0,
    proximate: false,
};

/// Link 2 derived from [`LINK1_THESIS`] (module docs).
pub const LINK2_THESIS: LawParams = derive(&LINK1_THESIS, &LINK1, &LINK2);

/// The same law on link `to`: umax its torque limit, u^/umax and eps as `p`, omega_sat and
/// s_sat chosen so the near-goal PD has `p`'s natural frequency and damping ratio on `to`'s
/// inertia; friction compensation in proportion to `to`'s friction.
pub const fn derive(p: &LawParams, from: &Link, to: &Link) -> LawParams {
    let k_from = p.uhat_nm * p.eps / p.s_sat_rad;
    let b_from = p.uhat_nm / p.omega_sat_rad_s;
    let wn = sqrt(k_from / from.inertia_kgm2);
    let zeta = b_from / (2.0 * sqrt(k_from * from.inertia_kgm2));
    let umax = to.torque_limit_nm;
    let uhat = umax * p.uhat_nm / p.umax_nm;
    let b = 2.0 * zeta * wn * to.inertia_kgm2;
    let k = wn * wn * to.inertia_kgm2;
    LawParams {
        umax_nm: umax,
        uhat_nm: uhat,
        eps: p.eps,
        omega_sat_rad_s: uhat / b,
        s_sat_rad: uhat * p.eps / k,
        adaptive: p.adaptive,
        notch_q: p.notch_q,
        friction_comp_nm: p.friction_comp_nm * to.coulomb_nm / from.coulomb_nm,
        proximate: p.proximate,
    }
}

/// The inertia an adaptive law assumes before it has measured one, x nominal: the largest
/// the bench tests against (+20%) with a margin.
pub const PRIOR_INERTIA_SCALE: f64 = 1.25;

/// Half-width of the goal's dead band at rest, encoder counts: the encoder reads up to a
/// count below the true angle, so a link resting within one measured count of the goal is
/// within two true counts (the settling criterion).
pub const DEADBAND_COUNTS: f64 = 1.0;

/// u^ / umax of the tuned law: 4% of the torque is left to hold the link on the curve.
pub const TUNED_UHAT_FRACTION: f64 = 0.96;
/// Natural frequency of the tuned law near the goal per link, Hz (critically damped): the
/// stiffest that neither limit-cycles at rest nor rings the band on arrival, from the
/// bench's sweep (docs/servo.md). Link 2's softer 125 Hz band needs the lower one.
pub const TUNED_NEAR_HZ: [f64; 2] = [45.0, 20.0];

/// Link 1 of the tuned law (module docs).
pub const LINK1_TUNED: LawParams = tuned(&LINK1, TUNED_UHAT_FRACTION, TUNED_NEAR_HZ[0], 4.0);

/// Link 2 of the tuned law: as link 1's but for link 2's torque, inertia and friction, and
/// a softer near-goal loop for its softer band.
pub const LINK2_TUNED: LawParams = tuned(&LINK2, TUNED_UHAT_FRACTION, TUNED_NEAR_HZ[1], 4.0);

/// The tuned law on link `l` with braking torque `uhat_fraction` x umax, critically damped
/// at `near_hz` near the goal, switching-function weight `eps` (also for the bench's sweeps).
pub const fn tuned(l: &Link, uhat_fraction: f64, near_hz: f64, eps: f64) -> LawParams {
    let umax = l.torque_limit_nm;
    let uhat = uhat_fraction * umax;
    let wn = core::f64::consts::TAU * near_hz;
    let k = wn * wn * l.inertia_kgm2;
    let b = 2.0 * wn * l.inertia_kgm2;
    LawParams {
        umax_nm: umax,
        uhat_nm: uhat,
        eps,
        omega_sat_rad_s: uhat / b,
        s_sat_rad: uhat * eps / k,
        adaptive: true,
        notch_q: 0.7,
        friction_comp_nm: 0.8 * l.coulomb_nm,
        proximate: true,
    }
}

/// The loop period the observer gains are derived for (the servo's target rate, 3 kHz).
pub const T_NOMINAL_S: f64 = 1.0 / 3000.0;
/// The thesis's continuous observer gains (Appendix A).
pub const OBSERVER_K1: f64 = 900.0;
/// The thesis's continuous observer gains (Appendix A).
pub const OBSERVER_K2: f64 = 400_000.0;

/// Discrete observer gains (as rates, 1/s and 1/s^2) for period `t`: the error dynamics of
/// the update in [`crate::Observer::update`] have poles at e^(sT) of s^2 + K1 s + K2.
pub const fn observer_gains(t: f64) -> (f64, f64) {
    let wn = sqrt(OBSERVER_K2);
    let zeta = OBSERVER_K1 / (2.0 * wn);
    let r = exp(-zeta * wn * t);
    let c = cos(wn * sqrt(1.0 - zeta * zeta) * t);
    let tk1 = 2.0 - 2.0 * r * c;
    let t2k2 = 1.0 + r * r - 2.0 * r * c;
    (tk1 / t, t2k2 / (t * t))
}

/// Largest DAC code (from `regs`: 12-bit two's complement).
pub const DAC_MAX: i16 = regs::servo::DAC_MAX;
/// Smallest DAC code.
pub const DAC_MIN: i16 = regs::servo::DAC_MIN;
/// Volts of DAC full scale (code 2048).
const DAC_FS_V: f64 = regs::servo::DAC_FULL_SCALE_MV as f64 / 1000.0;

/// Seconds per 2 MHz timer tick in Q40 (2^40 / 2e6).
pub const TIMER_TICK_Q40: i32 = fit(round(Q32 * 256.0 / regs::servo::TIMER_HZ as f64));

/// The fixed-point constants of one link. `repr(C)`: the servo image's assembly
/// (`__servo_observe2`, `__servo_control2` in `crates/rt/asm/servo.S`) reads them at the offsets
/// [`crate::layout`] asserts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C, align(4))]
pub struct LinkConst {
    /// Radians per encoder count, Q32.
    pub rad_per_count_q32: i32,
    /// 1 / inertia, Q16 (1/(kg m^2)).
    pub inv_inertia_q16: i32,
    /// umax, Q16 N m.
    pub umax_q16: i32,
    /// u^ / umax, Q16.
    pub uhat_over_umax_q16: i32,
    /// 1 / omega_sat, Q16 s/rad.
    pub inv_omega_sat_q16: i32,
    /// eps, Q16.
    pub eps_q16: i32,
    /// 1 / s_sat, Q16 1/rad.
    pub inv_s_sat_q16: i32,
    /// I / (2 u^), Q32 s^2/rad: the switching curve (for an adaptive law, with the prior
    /// inertia [`PRIOR_INERTIA_SCALE`] x nominal until it is measured).
    pub brake_q32: i32,
    /// 1 / (2 u^), Q24 1/(N m): turns an inertia estimate into the switching curve.
    pub inv_two_uhat_q24: i32,
    /// Smallest plausible inertia estimate, Q32 kg m^2 (0.7 x nominal).
    pub inertia_lo_q32: i32,
    /// Largest plausible inertia estimate, Q32 kg m^2 (1.5 x nominal).
    pub inertia_hi_q32: i32,
    /// Velocity gained under full torque before the inertia is estimated (15 ms of it), Q16
    /// rad/s; 0 = no estimation.
    pub adapt_min_dw_q16: i32,
    /// Notch coefficients (b0, a1, a2), Q13, each within i16: on torques in Q11 N m,
    /// y = (b0 (x + x2) + a1 (x1 - y1) - a2 y2) >> 13 (b2 = b0, b1 = a1 for a notch; the
    /// 68020 multiplies with `MULS.W` and 32-bit `MULS.L`); b0 = 0 = no notch (a notch's b0
    /// is 1 / (1 + alpha)).
    pub notch_q13: [i32; 3],
    /// Coulomb friction compensation, Q16 N m.
    pub friction_comp_q16: i32,
    /// The dead band of the goal ([`DEADBAND_COUNTS`]; 0 = none, the thesis's law), Q16 rad: at rest
    /// within it only damping acts ([`crate::near_goal`]).
    pub deadband_q16: i32,
    /// Speeds above which the link counts as moving for friction compensation, Q16 rad/s.
    pub moving_q16: i32,
    /// DAC codes per N m, Q16.
    pub dac_per_nm_q16: i32,
    /// N m per DAC code, Q16; within i16 (the 68020 multiplies it with `MULS.W`).
    pub nm_per_dac_q16: i32,
    /// Observer gain K1 at the nominal period, Q16 1/s.
    pub k1_q16: i32,
    /// Observer gain K2 at the nominal period, Q8 1/s^2.
    pub k2_q8: i32,
    /// Velocity bound for the observer: twice the motor speed limit, Q16 rad/s.
    pub omega_limit_q16: i32,
    /// Position errors below which the law counts as near the goal: s_sat, Q16 rad.
    pub linear_band_q16: i32,
    /// u^, Q16 N m.
    pub uhat_q16: i32,
    /// Velocity gain of the proximate law near the goal, b = u^ / omega_sat, Q16 N m s/rad.
    pub b_q16: i32,
    /// K / b = (u^ eps / s_sat) / b, the slope of the proximate law's linear region, Q16 1/s.
    pub slope_q16: i32,
    /// b / (4 K), s, Q32: times 2 u^ / I, the speed offset c of the proximate curve.
    pub c_per_two_a_q32: i32,
    /// (b / (2 K))^2, s^2, Q32: times 2 u^ / I, the half-width y_l of the linear region.
    pub yl_per_two_a_q32: i32,
    /// 2 u^ / I, Q16 rad/s^2 (for an adaptive law, with the prior inertia).
    pub two_a_q16: i32,
    /// The proximate law's y_l and c for `two_a_q16` (`mul_shr` of it by `yl_per_two_a_q32`
    /// and `c_per_two_a_q32`, shift 32), Q16: where [`crate::InertiaEstimate`] starts.
    /// Computed here, at compile time: the host's 64-bit multiply must not run on the
    /// 68020 (docs/toolchain.md).
    pub yl_q16: i32,
    /// See `yl_q16`.
    pub c_q16: i32,
    /// DAC codes per N m, Q5, within i16: the law's code from its torque in Q11
    /// ([`crate::dac_code_q11`], one `MULS.W` on the 68020).
    pub dac_per_nm_q5: i32,
    /// The least a, Q16 rad/s, with b a beyond umax and -b a beyond -umax
    /// (`mul_shr(b_q16, +-a, 16)`, and so for every larger a): a speed error f - omega at
    /// least this far out saturates the proximate law whatever its exact value (the image
    /// then skips the square root; crates/rt/asm/servo.S).
    pub sat_arg_q16: i32,
    /// Run [`crate::proximate_law`] (else [`crate::law`]).
    pub proximate: bool,
}

/// A constant as `i32`; a value that does not fit fails the build.
const fn fit(x: i64) -> i32 {
    assert!(
        x >= i32::MIN as i64 && x <= i32::MAX as i64,
        "fixed-point constant out of i32 range"
    );
    x as i32
}

/// [`fit`] for a constant the 68020 multiplies with `MULS.W` (16 x 16 bits): the torque
/// per DAC code, times a code within the DAC's 12 bits (crates/rt/asm/servo.S).
const fn fit_i16(x: i64) -> i32 {
    assert!(
        x >= i16::MIN as i64 && x <= i16::MAX as i64,
        "fixed-point constant out of i16 range"
    );
    x as i32
}

/// Converts a link's parameters to fixed point for the nominal loop period.
pub const fn link_const(l: &Link, p: &LawParams) -> LinkConst {
    link_const_at(l, p, T_NOMINAL_S)
}

/// Converts a link's parameters to fixed point with the observer gains and notch designed
/// for loop period `period_s` (the bench runs the thesis's law at the thesis's 760 Hz).
pub const fn link_const_at(l: &Link, p: &LawParams, period_s: f64) -> LinkConst {
    let (k1, k2) = observer_gains(period_s);
    let nm_per_volt = KT_NM_PER_A * l.gear_ratio * arm::AMP.transconductance_a_per_v;
    let nm_per_code = nm_per_volt * DAC_FS_V / 2048.0;
    // The near-goal PD gains both forms of the law share.
    let b = p.uhat_nm / p.omega_sat_rad_s;
    let kp = p.uhat_nm * p.eps / p.s_sat_rad;
    // Until the inertia is measured, an adaptive law brakes as if it were the heaviest
    // expected (a payload), so that its first move cannot overshoot.
    let prior = if p.adaptive { PRIOR_INERTIA_SCALE } else { 1.0 };
    let c_per_two_a_q32 = fit(round(Q32 * b / (4.0 * kp)));
    let yl_per_two_a_q32 = fit(round(Q32 * (b / (2.0 * kp)) * (b / (2.0 * kp))));
    let two_a_q16 = fit(round(Q16 * 2.0 * p.uhat_nm / (prior * l.inertia_kgm2)));
    let (b_q16, umax_q16) = (fit(round(Q16 * b)), fit(round(Q16 * p.umax_nm)));
    // The image's near-goal corrections (crates/rt/asm/servo.S) take mul_shr(u, 10, 16) as
    // 10 u, exact for |u| <= umax only below this, and +-friction as never overflowing.
    // Its observer takes an innovation within MAX_INNOVATION_Q16 as plausible without the
    // bound's product, true for a speed limit >= 0.
    assert!(Q16 * p.umax_nm < (i32::MAX / 10) as f64 && p.friction_comp_nm >= 0.0);
    assert!(l.max_speed_rad_s >= 0.0);
    // The notch and the DAC code work on torques within +-umax in Q11, an i16 (`MULS.W`).
    assert!(2048.0 * p.umax_nm < 32767.0);
    LinkConst {
        rad_per_count_q32: fit(round(
            Q32 * core::f64::consts::TAU / l.counts_per_rev as f64,
        )),
        inv_inertia_q16: fit(round(Q16 / l.inertia_kgm2)),
        umax_q16,
        uhat_over_umax_q16: fit(round(Q16 * p.uhat_nm / p.umax_nm)),
        inv_omega_sat_q16: fit(round(Q16 / p.omega_sat_rad_s)),
        eps_q16: fit(round(Q16 * p.eps)),
        inv_s_sat_q16: fit(round(Q16 / p.s_sat_rad)),
        brake_q32: fit(round(Q32 * prior * l.inertia_kgm2 / (2.0 * p.uhat_nm))),
        inv_two_uhat_q24: fit(round(Q16 * 256.0 / (2.0 * p.uhat_nm))),
        inertia_lo_q32: fit(round(Q32 * 0.7 * l.inertia_kgm2)),
        inertia_hi_q32: fit(round(Q32 * 1.5 * l.inertia_kgm2)),
        adapt_min_dw_q16: if p.adaptive {
            fit(round(Q16 * 0.015 * p.umax_nm / l.inertia_kgm2))
        } else {
            0
        },
        notch_q13: notch(l.resonance_hz, p.notch_q, period_s),
        friction_comp_q16: fit(round(Q16 * p.friction_comp_nm)),
        deadband_q16: if p.friction_comp_nm > 0.0 {
            fit(round(
                Q16 * DEADBAND_COUNTS * core::f64::consts::TAU / l.counts_per_rev as f64,
            ))
        } else {
            0
        },
        moving_q16: fit(round(Q16 * 0.05)),
        dac_per_nm_q16: fit(round(Q16 / nm_per_code)),
        nm_per_dac_q16: fit_i16(round(Q16 * nm_per_code)),
        k1_q16: fit(round(Q16 * k1)),
        k2_q8: fit(round(256.0 * k2)),
        omega_limit_q16: fit(round(Q16 * 2.0 * l.max_speed_rad_s)),
        linear_band_q16: fit(round(Q16 * p.s_sat_rad)),
        uhat_q16: fit(round(Q16 * p.uhat_nm)),
        b_q16,
        slope_q16: fit(round(Q16 * kp / b)),
        c_per_two_a_q32,
        yl_per_two_a_q32,
        two_a_q16,
        yl_q16: fx::host_mul_shr(two_a_q16, yl_per_two_a_q32, 32),
        c_q16: fx::host_mul_shr(two_a_q16, c_per_two_a_q32, 32),
        dac_per_nm_q5: fit_i16(round(32.0 / nm_per_code)),
        sat_arg_q16: sat_arg(b_q16, umax_q16),
        proximate: p.proximate,
    }
}

/// [`LinkConst::sat_arg_q16`] for the law's b and umax (Q16): the least a with
/// `mul_shr(b, a, 16) > umax` and `mul_shr(b, -a, 16) < -umax`, from just below the
/// estimate (umax + 1) / b up (both products only grow in |a|).
const fn sat_arg(b_q16: i32, umax_q16: i32) -> i32 {
    assert!(b_q16 > 0 && umax_q16 > 0);
    let mut a = (((umax_q16 as i64 + 1) << 16) / b_q16 as i64 - 2) as i32;
    if a < 1 {
        a = 1;
    }
    while !(fx::host_mul_shr(b_q16, a, 16) > umax_q16
        && fx::host_mul_shr(b_q16, -a, 16) < -umax_q16)
    {
        a += 1;
    }
    a
}

/// Notch biquad at `hz` with quality `q` for period `period_s` (bilinear design with
/// pre-warping, RBJ cookbook): (b0, a1, a2) in Q13, the coefficients' gain at DC exactly 1;
/// all zero for `q` <= 0 (no notch). Each fits an i16, and |b0| + |a1| + |a2| < 2^15 - 1, so that with x, x2 within +-umax and
/// x1, y1, y2 within i16 (Q11) the filter's sum stays below 2^16 (2^15 - 1) < 2^31.
const fn notch(hz: f64, q: f64, period_s: f64) -> [i32; 3] {
    if q <= 0.0 {
        return [0; 3];
    }
    let w0 = core::f64::consts::TAU * hz * period_s;
    let alpha = sin(w0) / (2.0 * q);
    let a0 = 1.0 + alpha;
    let q13 = 8192.0;
    // b0 = 1 / a0 = (1 + a2) / 2 exactly: with a2 rounded to an even number and b0 taken
    // from it, the quantized coefficients keep the gain at DC 1 (2 b0 + a1 = 1 + a1 + a2),
    // and the filter's rounding leaves a steady torque within one Q11 step (0.5 mN m; the
    // Q13 coefficients rounded independently were 0.1% off).
    let a2 = 2 * fit_i16(round(q13 * (1.0 - alpha) / a0 / 2.0));
    let c = [
        (8192 + a2) / 2,
        fit_i16(round(q13 * -2.0 * cos(w0) / a0)),
        a2,
    ];
    assert!(c[0].abs() + c[1].abs() + c[2].abs() < 32767);
    c
}

/// The rate the servo image's main loop is paced at: 3 kHz, the native board's, since
/// 2026-11-26 (2,400 Hz before): its common pass takes 5,210 cycles at rest, 5,287
/// accelerating at full torque and 5,153 holding, of the 5,561 a period of 666 ticks of the
/// 2 MHz timer has at 16.7 MHz (`sim-host profile servo`, `--servo-goal-urad`), 5,294 on
/// average in fig. VI.5's image run (docs/servo.md).
pub const IMAGE_HZ: f64 = 3000.0;

/// Near-goal frequencies of the tuned law at [`IMAGE_HZ`], Hz (critically damped): at
/// 3 kHz the native board's own ([`TUNED_NEAR_HZ`]), so that the image runs the native law.
/// (At 2,400 Hz the image ran 42 / 18 Hz, at 1,500-2,000 Hz 40 / 17 Hz: with
/// [`TUNED_NEAR_HZ`] at 1,500 Hz fig. VI.5's image run ran into the reflex's escapes and
/// ended in the goal's other pose; docs/servo.md.)
pub const IMAGE_NEAR_HZ: [f64; 2] = TUNED_NEAR_HZ;

/// The tuned law with the observer gains, notch and near-goal loop designed for
/// [`IMAGE_HZ`]: what the servo image runs today.
pub static TUNED_AT_IMAGE_HZ: [LinkConst; 2] = [
    link_const_at(
        &LINK1,
        &tuned(&LINK1, TUNED_UHAT_FRACTION, IMAGE_NEAR_HZ[0], 4.0),
        1.0 / IMAGE_HZ,
    ),
    link_const_at(
        &LINK2,
        &tuned(&LINK2, TUNED_UHAT_FRACTION, IMAGE_NEAR_HZ[1], 4.0),
        1.0 / IMAGE_HZ,
    ),
];

/// The thesis's law: both links' constants.
pub static THESIS: [LinkConst; 2] = [
    link_const(&LINK1, &LINK1_THESIS),
    link_const(&LINK2, &LINK2_THESIS),
];

/// The tuned law the board runs: both links' constants.
pub static TUNED: [LinkConst; 2] = [
    link_const(&LINK1, &LINK1_TUNED),
    link_const(&LINK2, &LINK2_TUNED),
];

/// The constants the board runs (an alias of [`TUNED`] for code that needs per-link values
/// such as counts and DAC scaling, which both sets share).
pub static LINKS: &[LinkConst; 2] = &TUNED;
