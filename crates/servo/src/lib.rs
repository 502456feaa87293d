//! The servo board's logic (thesis ch. III and Appendix A): per link a Luenberger velocity
//! observer and the sliding-mode near time-optimal control law III.36, both links in one
//! `step`; the arrest point the reflexes need (ch. V); torque-to-DAC scaling.
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

pub mod consts;
pub mod fx;
pub mod params;

use fx::mul_shr;
use params::{LinkConst, LINKS, TIMER_TICK_Q40};

/// One fixed-point unit (1.0 in Q16).
pub const ONE_Q16: i32 = 1 << 16;

/// Micro-radians to Q16 radians (x 2^16 / 10^6 as a Q32 multiplier, rounded).
pub fn urad_to_q16(urad: i32) -> i32 {
    mul_shr(urad, 281_474_977, 32)
}

/// Q16 radians to micro-radians (x 10^6 / 2^16, rounded).
pub fn q16_to_urad(q: i32) -> i32 {
    mul_shr(q, 1_000_000, 16)
}

/// The regime law III.36 is in, for tests and traces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Regime {
    /// The command is at +-umax (far from the switching curve, or accelerating).
    Saturated,
    /// Inside the boundary layer of the switching curve (|s~| < s_sat), not near the goal.
    Sliding,
    /// Near the goal: every term below saturation, the law acts like PD (K, b).
    Linear,
}

/// omega |omega| c for a Q32 constant `c`: through Q24 so small speeds keep precision.
fn signed_square(omega_q16: i32, c_q32: i32) -> i32 {
    let wc_q24 = mul_shr(omega_q16, c_q32, 24);
    mul_shr(wc_q24, omega_q16.saturating_abs(), 24)
}

/// Law III.36 for one link: the torque (Q16 N m) for a position error and velocity.
#[inline(never)]
pub fn law(k: &LinkConst, err_q16: i32, omega_q16: i32) -> (i32, Regime) {
    let s = err_q16.saturating_add(signed_square(omega_q16, k.brake_q32)); // Q16 rad
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

/// Where a link stops under full braking from (`theta`, `omega`): the arrest point of
/// thesis ch. V, theta + omega |omega| / (2 umax / I).
#[inline(never)]
pub fn arrest_point(k: &LinkConst, theta_q16: i32, omega_q16: i32) -> i32 {
    theta_q16.saturating_add(signed_square(omega_q16, k.arrest_q32))
}

/// The DAC code for a torque (Q16 N m) on a link: never beyond the 12-bit range, and the
/// range itself is umax.
#[inline(never)]
pub fn dac_code(k: &LinkConst, torque_q16: i32) -> i16 {
    mul_shr(torque_q16, k.dac_per_nm_q16, 32).clamp(params::DAC_MIN as i32, params::DAC_MAX as i32)
        as i16
}

/// Largest plausible difference between measurement and estimate: 0.01 rad (Q16), some
/// fifty link-1 counts, far beyond what a link can move unobserved in one loop.
pub const MAX_INNOVATION_Q16: i32 = 655;
/// Longest period the observer integrates over in one update: 10 ms (Q32 s).
pub const MAX_DT_Q32: i32 = 42_949_673;

/// The Luenberger observer of one link (Appendix A): position and velocity estimates driven
/// by the measured position and the commanded torque.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Observer {
    /// Estimated angle, Q16 rad.
    pub theta_q16: i32,
    /// Estimated velocity, Q16 rad/s.
    pub omega_q16: i32,
}

impl Observer {
    /// Advances by `dt_q32` seconds (Q32) with measurement `y_q16` and the torque `u_q16` that
    /// was applied over the interval.
    ///
    /// An innovation beyond [`MAX_INNOVATION_Q16`] is implausible (an encoder glitch or a
    /// restart): the observer re-locks onto the measurement at rest instead of integrating
    /// it. The period is bounded by [`MAX_DT_Q32`].
    #[inline(never)]
    pub fn update(&mut self, k: &LinkConst, y_q16: i32, u_q16: i32, dt_q32: i32) {
        let e = y_q16.saturating_sub(self.theta_q16);
        if e.saturating_abs() > MAX_INNOVATION_Q16 {
            *self = Observer {
                theta_q16: y_q16,
                omega_q16: 0,
            };
            return;
        }
        let dt = dt_q32.min(MAX_DT_Q32);
        let dtheta = self.omega_q16 + mul_shr(k.k1_q16, e, 16); // Q16 rad/s
        let accel = mul_shr(u_q16, k.inv_inertia_q16, 16) + mul_shr(k.k2_q8, e, 8); // Q16 rad/s^2
        self.theta_q16 = self.theta_q16.saturating_add(mul_shr(dtheta, dt, 32));
        // Physical bound: no link turns faster than its motors' speed limit (x2 margin).
        self.omega_q16 = self
            .omega_q16
            .saturating_add(mul_shr(accel, dt, 32))
            .clamp(-k.omega_limit_q16, k.omega_limit_q16);
    }
}

/// What the board read this pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Input {
    /// Latched 16-bit encoder counts of both motors.
    pub enc: [u16; 2],
    /// The 2 MHz free-running 16-bit timer.
    pub timer: u16,
    /// The reflex subgoal, if a whole record could be read.
    pub subgoal: Option<Subgoal>,
}

/// A subgoal as published by the reflex board.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Subgoal {
    /// Goal angles, micro-radians (absolute).
    pub goal_urad: [i32; 2],
    /// The reflex's cycle counter: it must keep changing.
    pub cycle: u32,
}

/// Why the servo is holding at its arrest point instead of following the subgoal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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
/// Largest plausible absolute angle (the encoders' unwrap range is +-4 revolutions).
pub const ANGLE_LIMIT_URAD: i32 = 25_000_000;

/// What the servo computed this pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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
}

/// The servo of both links.
#[derive(Clone, Debug)]
pub struct Servo {
    started: bool,
    last_enc: [u16; 2],
    counts: [i32; 2],
    last_timer: u16,
    obs: [Observer; 2],
    torque_q16: [i32; 2],
    last_cycle: Option<u32>,
    since_cycle_q32: i32,
    hold_goal_q16: Option<[i32; 2]>,
    hold: Option<Hold>,
}

impl Default for Servo {
    fn default() -> Self {
        Self::new()
    }
}

impl Servo {
    /// A servo that has seen nothing yet.
    pub const fn new() -> Self {
        Self {
            started: false,
            last_enc: [0; 2],
            counts: [0; 2],
            last_timer: 0,
            obs: [Observer {
                theta_q16: 0,
                omega_q16: 0,
            }; 2],
            torque_q16: [0; 2],
            last_cycle: None,
            since_cycle_q32: 0,
            hold_goal_q16: None,
            hold: None,
        }
    }

    /// The observers' state.
    pub fn observers(&self) -> [Observer; 2] {
        self.obs
    }

    /// One pass of the servo loop.
    pub fn step(&mut self, input: &Input) -> Output {
        // Extend the 16-bit counters; the first latch is taken as absolute (the counters are
        // zeroed with the arm at angle 0 before power-up).
        let mut theta = [0i32; 2];
        for i in 0..2 {
            if self.started {
                self.counts[i] = self.counts[i]
                    .wrapping_add(input.enc[i].wrapping_sub(self.last_enc[i]) as i16 as i32);
            } else {
                self.counts[i] = input.enc[i] as i16 as i32;
            }
            self.last_enc[i] = input.enc[i];
            theta[i] = mul_shr(self.counts[i], LINKS[i].rad_per_count_q32, 16);
        }
        let ticks = input.timer.wrapping_sub(self.last_timer);
        self.last_timer = input.timer;
        let dt_q32 = mul_shr(ticks as i32, TIMER_TICK_Q40, 8);
        let first = !self.started;
        if first {
            self.started = true;
            for (o, &t) in self.obs.iter_mut().zip(&theta) {
                *o = Observer {
                    theta_q16: t,
                    omega_q16: 0,
                };
            }
        } else {
            for i in 0..2 {
                self.obs[i].update(&LINKS[i], theta[i], self.torque_q16[i], dt_q32);
            }
        }
        let omega = [self.obs[0].omega_q16, self.obs[1].omega_q16];
        let arrest = [
            arrest_point(&LINKS[0], theta[0], omega[0]),
            arrest_point(&LINKS[1], theta[1], omega[1]),
        ];

        // The goal: the subgoal while it is fresh and plausible, else hold at the arrest point.
        let (goal, new_fault) = self.choose_goal(input.subgoal, dt_q32, arrest, first);

        let mut out = Output {
            dac: [0; 2],
            enable: !first,
            theta_q16: theta,
            omega_q16: omega,
            arrest_q16: arrest,
            torque_q16: [0; 2],
            goal_q16: goal,
            period_ticks: ticks,
            hold: self.hold,
            new_fault,
            regime: [Regime::Linear; 2],
        };
        for i in 0..2 {
            let (u, r) = if first {
                (0, Regime::Linear)
            } else {
                law(&LINKS[i], theta[i] - goal[i], omega[i])
            };
            let code = dac_code(&LINKS[i], u);
            // The torque the amplifier will actually produce, for the observer's next update.
            self.torque_q16[i] = code as i32 * LINKS[i].nm_per_dac_q16;
            out.dac[i] = code;
            out.torque_q16[i] = self.torque_q16[i];
            out.regime[i] = r;
        }
        out
    }

    #[inline(never)]
    fn choose_goal(
        &mut self,
        sub: Option<Subgoal>,
        dt_q32: i32,
        arrest: [i32; 2],
        first: bool,
    ) -> ([i32; 2], Option<Hold>) {
        let stale_q32 = consts::round(STALE_S * consts::Q32) as i32;
        let verdict = match sub {
            None if self.last_cycle.is_none() => Err(Hold::NoSubgoal),
            None => Err(Hold::Torn),
            Some(s) => {
                if self.last_cycle != Some(s.cycle) {
                    self.last_cycle = Some(s.cycle);
                    self.since_cycle_q32 = 0;
                } else if !first {
                    self.since_cycle_q32 = self.since_cycle_q32.saturating_add(dt_q32);
                }
                if s.goal_urad
                    .iter()
                    .any(|g| g.unsigned_abs() > ANGLE_LIMIT_URAD as u32)
                {
                    Err(Hold::OutOfRange)
                } else if self.since_cycle_q32 > stale_q32 {
                    Err(Hold::Stale)
                } else {
                    Ok([urad_to_q16(s.goal_urad[0]), urad_to_q16(s.goal_urad[1])])
                }
            }
        };
        match verdict {
            Ok(g) => {
                self.hold = None;
                self.hold_goal_q16 = None;
                (g, None)
            }
            Err(why) => {
                let goal = *self.hold_goal_q16.get_or_insert(arrest);
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
