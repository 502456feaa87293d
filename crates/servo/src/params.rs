//! The law's parameters (thesis ch. III) and their fixed-point form.
//!
//! Link 1 uses the thesis's values: u^ = 10.5, umax = 13 N m, eps = 4, omega_sat = 1.8 rad/s,
//! s_sat = 0.23 rad. Near the goal law III.36 acts like PD with stiffness K = u^ eps / s_sat
//! (182.6 N m/rad) and damping b = u^ / omega_sat (5.83 N m s): with I = 0.047 kg m^2 that is
//! 9.9 Hz with zeta = 0.995, the "10 Hz critically damped" of the thesis.
//!
//! Link 2 is derived the same way: umax is its torque limit (3.25 N m), u^/umax and eps are
//! link 1's (0.808, 4), and omega_sat and s_sat give the same near-goal behaviour, 9.9 Hz
//! critically damped, on link 2's inertia:
//!
//! ```text
//! wn = sqrt(K1 / I1)            b = 2 wn I2      K = wn^2 I2
//! omega_sat = u^ / b            s_sat = u^ eps / K
//! ```
//!
//! which gives omega_sat = 6.02 rad/s and s_sat = 0.772 rad.
//!
//! The observer's gains are the thesis's continuous ones (K1 = 900 /s, K2 = 400000 /s^2: 100 Hz,
//! zeta 0.71) mapped to the loop period [`T_NOMINAL_S`] by placing the discrete poles at
//! z = e^(sT) of the continuous ones, then expressed as rates so the observer can integrate
//! over the period the timer actually measures.

use crate::consts::{cos, exp, round, sqrt, Q16, Q32};
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
}

/// Link 1: the thesis's values.
pub const LINK1_LAW: LawParams = LawParams {
    umax_nm: 13.0,
    uhat_nm: 10.5,
    eps: 4.0,
    omega_sat_rad_s: 1.8,
    s_sat_rad: 0.23,
};

const fn link2_law() -> LawParams {
    let l1 = LINK1_LAW;
    let k1 = l1.uhat_nm * l1.eps / l1.s_sat_rad;
    let wn = sqrt(k1 / LINK1.inertia_kgm2);
    let umax = LINK2.torque_limit_nm;
    let uhat = umax * l1.uhat_nm / l1.umax_nm;
    let b = 2.0 * wn * LINK2.inertia_kgm2;
    let k = wn * wn * LINK2.inertia_kgm2;
    LawParams {
        umax_nm: umax,
        uhat_nm: uhat,
        eps: l1.eps,
        omega_sat_rad_s: uhat / b,
        s_sat_rad: uhat * l1.eps / k,
    }
}

/// Link 2: derived from link 1's (module docs).
pub const LINK2_LAW: LawParams = link2_law();

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

/// The fixed-point constants of one link.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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
    /// I / (2 u^), Q32 s^2/rad: the switching curve.
    pub brake_q32: i32,
    /// I / (2 umax), Q32 s^2/rad: the arrest point.
    pub arrest_q32: i32,
    /// DAC codes per N m, Q16.
    pub dac_per_nm_q16: i32,
    /// N m per DAC code, Q16.
    pub nm_per_dac_q16: i32,
    /// Observer gain K1 at the nominal period, Q16 1/s.
    pub k1_q16: i32,
    /// Observer gain K2 at the nominal period, Q8 1/s^2.
    pub k2_q8: i32,
    /// Velocity bound for the observer: twice the motor speed limit, Q16 rad/s.
    pub omega_limit_q16: i32,
    /// Position errors below which the law counts as near the goal: s_sat, Q16 rad.
    pub linear_band_q16: i32,
}

/// A constant as `i32`; a value that does not fit fails the build.
const fn fit(x: i64) -> i32 {
    assert!(
        x >= i32::MIN as i64 && x <= i32::MAX as i64,
        "fixed-point constant out of i32 range"
    );
    x as i32
}

/// Converts a link's parameters to fixed point.
pub const fn link_const(l: &Link, p: &LawParams) -> LinkConst {
    let (k1, k2) = observer_gains(T_NOMINAL_S);
    let nm_per_volt = KT_NM_PER_A * l.gear_ratio * arm::AMP.transconductance_a_per_v;
    let nm_per_code = nm_per_volt * DAC_FS_V / 2048.0;
    LinkConst {
        rad_per_count_q32: fit(round(
            Q32 * core::f64::consts::TAU / l.counts_per_rev as f64,
        )),
        inv_inertia_q16: fit(round(Q16 / l.inertia_kgm2)),
        umax_q16: fit(round(Q16 * p.umax_nm)),
        uhat_over_umax_q16: fit(round(Q16 * p.uhat_nm / p.umax_nm)),
        inv_omega_sat_q16: fit(round(Q16 / p.omega_sat_rad_s)),
        eps_q16: fit(round(Q16 * p.eps)),
        inv_s_sat_q16: fit(round(Q16 / p.s_sat_rad)),
        brake_q32: fit(round(Q32 * l.inertia_kgm2 / (2.0 * p.uhat_nm))),
        arrest_q32: fit(round(Q32 * l.inertia_kgm2 / (2.0 * p.umax_nm))),
        dac_per_nm_q16: fit(round(Q16 / nm_per_code)),
        nm_per_dac_q16: fit(round(Q16 * nm_per_code)),
        k1_q16: fit(round(Q16 * k1)),
        k2_q8: fit(round(256.0 * k2)),
        omega_limit_q16: fit(round(Q16 * 2.0 * l.max_speed_rad_s)),
        linear_band_q16: fit(round(Q16 * p.s_sat_rad)),
    }
}

/// Both links' constants.
pub const LINKS: [LinkConst; 2] = [
    link_const(&LINK1, &LINK1_LAW),
    link_const(&LINK2, &LINK2_LAW),
];
