//! `sim-host bench servo`: step responses of the servo in the simulated plant (friction,
//! resonance, amplifier, encoder and DAC quantisation), against the thesis's baselines in the
//! same run (thesis ch. III, figs. III.3-III.10).
//!
//! Controllers run at a fixed period against the plant: they read the encoders (motor side,
//! quantised) and the 2 MHz timer as the board would, and their DAC codes drive the
//! amplifiers from the next plant step on. Settling is judged on the true link angle: the
//! first time after which the link stays within 2 encoder counts of the goal to the end.

use crate::plant::{LinkModel, Plant, DEFAULT_DT_S};
use servo::params::{LINK1_LAW, LINK2_LAW, LINKS};
use servo::{Input, Observer, Servo, Subgoal};

/// Which controller drives the arm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Controller {
    /// Law III.36 with its observers (`crates/servo`): the servo board's own code.
    SlidingMode,
    /// PD on the same observer, `k` N m/rad and `b` N m s/rad, clamped at umax.
    Pd {
        /// Stiffness.
        k: f64,
        /// Damping.
        b: f64,
    },
}

impl Controller {
    /// A short name for tables.
    pub fn name(&self) -> String {
        match self {
            Controller::SlidingMode => "sliding mode (III.36)".into(),
            Controller::Pd { k, b } => format!("PD K={k} b={b}"),
        }
    }
}

/// The thesis's saturated PD (the law's near-goal gains, figs. III.7-III.8).
pub const SATURATED_PD: Controller = Controller::Pd { k: 185.0, b: 5.9 };
/// The thesis's best unsaturated PD (figs. III.9-III.10).
pub const BEST_LINEAR_PD: Controller = Controller::Pd { k: 4.33, b: 0.90 };

/// One step experiment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    /// Link moved (0 or 1); the other holds at 0.
    pub link: usize,
    /// Step size, rad.
    pub size_rad: f64,
    /// Plant inertia as a multiple of the nominal (the controller is not told).
    pub inertia_scale: f64,
    /// Controller period, s.
    pub period_s: f64,
    /// Simulated time, s.
    pub duration_s: f64,
}

/// One sample of a response.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Point {
    /// Time.
    pub t_s: f64,
    /// Link angle of the moved link.
    pub theta_rad: f64,
    /// Link velocity.
    pub omega_rad_s: f64,
    /// Torque at the link.
    pub torque_nm: f64,
}

/// What a step response measured.
#[derive(Clone, Debug, PartialEq)]
pub struct Response {
    /// Time to enter and stay within 2 counts of the goal; `None` if it never did.
    pub settle_s: Option<f64>,
    /// Largest excursion beyond the goal, rad.
    pub overshoot_rad: f64,
    /// Largest speed, rad/s.
    pub peak_speed_rad_s: f64,
    /// Largest torque magnitude, N m.
    pub peak_torque_nm: f64,
    /// DAC sign changes per second over the last 100 ms (chatter at rest).
    pub chatter_hz: f64,
    /// RMS torque over the last 100 ms, N m.
    pub rest_torque_rms_nm: f64,
    /// Error at the end, rad.
    pub final_error_rad: f64,
    /// The trajectory, every 0.5 ms.
    pub trace: Vec<Point>,
}

/// Bang-bang time for a move of `d` rad accelerating at `accel_nm` and braking at `brake_nm`
/// of torque with inertia `i`.
pub fn bang_bang_s(d: f64, i: f64, accel_nm: f64, brake_nm: f64) -> f64 {
    let (a1, a2) = (accel_nm / i, brake_nm / i);
    let v = (2.0 * d.abs() * a1 * a2 / (a1 + a2)).sqrt();
    v / a1 + v / a2
}

/// Runs one step experiment.
pub fn run(ctrl: Controller, s: Step) -> Response {
    let mut plant = Plant::new([0.0, 0.0], DEFAULT_DT_S);
    for (l, p) in plant.links.iter_mut().zip([arm::LINK1, arm::LINK2]) {
        l.model = LinkModel {
            inertia_scale: s.inertia_scale,
            ..LinkModel::full(p)
        };
    }
    let goal = if s.link == 0 {
        [s.size_rad, 0.0]
    } else {
        [0.0, s.size_rad]
    };
    let count = [arm::LINK1.rad_per_count(), arm::LINK2.rad_per_count()];
    let mut servo = Servo::new();
    let mut obs = [Observer::default(); 2];
    let mut pd_torque = [0i32; 2];
    let mut volts = [0.0; 2];
    let mut next_ctrl = 0.0;
    let mut last_ticks: u64 = 0;
    let mut cycle = 0u32;
    let mut trace = Vec::new();
    let mut dac_hist: Vec<(f64, i16)> = Vec::new();
    let steps = (s.duration_s / DEFAULT_DT_S).round() as u64;
    for n in 0..steps {
        let t = n as f64 * DEFAULT_DT_S;
        if t + 1e-12 >= next_ctrl {
            next_ctrl += s.period_s;
            let ticks = (t * 2e6).round() as u64;
            let enc = [0, 1].map(|i| {
                let m = plant.links[i].state.motor_rad;
                (m / count[i]).floor() as i64 as u16
            });
            let dac = match ctrl {
                Controller::SlidingMode => {
                    cycle += 1;
                    let sub = Subgoal {
                        goal_urad: [
                            (goal[0] * 1e6).round() as i32,
                            (goal[1] * 1e6).round() as i32,
                        ],
                        cycle,
                    };
                    servo
                        .step(&Input {
                            enc,
                            timer: ticks as u16,
                            subgoal: Some(sub),
                        })
                        .dac
                }
                Controller::Pd { k, b } => {
                    let dt_q32 = servo::fx::mul_shr(
                        (ticks - last_ticks) as i32,
                        servo::params::TIMER_TICK_Q40,
                        8,
                    );
                    [0, 1].map(|i| {
                        let lc = &LINKS[i];
                        let counts = enc[i] as i16 as i32; // steps here stay within +-1 counter wrap
                        let y = servo::fx::mul_shr(counts, lc.rad_per_count_q32, 16);
                        if n == 0 {
                            obs[i] = Observer {
                                theta_q16: y,
                                omega_q16: 0,
                            };
                        } else {
                            obs[i].update(lc, y, pd_torque[i], dt_q32);
                        }
                        let th = obs[i].theta_q16 as f64 / 65536.0;
                        let w = obs[i].omega_q16 as f64 / 65536.0;
                        let umax = [LINK1_LAW.umax_nm, LINK2_LAW.umax_nm][i];
                        // Link 2's gains scale with its inertia, so both links get the same dynamics.
                        let scale = if i == 0 {
                            1.0
                        } else {
                            arm::LINK2.inertia_kgm2 / arm::LINK1.inertia_kgm2
                        };
                        let u =
                            (-(k * scale) * (th - goal[i]) - (b * scale) * w).clamp(-umax, umax);
                        let code = servo::dac_code(lc, (u * 65536.0) as i32);
                        pd_torque[i] = code as i32 * lc.nm_per_dac_q16;
                        code
                    })
                }
            };
            last_ticks = ticks;
            volts = dac.map(|c| c as f64 * 10.0 / 2048.0);
            dac_hist.push((t, dac[s.link]));
        }
        plant.step(volts);
        if n % 10 == 0 {
            let l = &plant.links[s.link];
            trace.push(Point {
                t_s: plant.t_s,
                theta_rad: l.state.link_rad,
                omega_rad_s: l.state.link_rad_s,
                torque_nm: l.motor_torque_nm(),
            });
        }
    }
    measure(
        &trace,
        &dac_hist,
        goal[s.link],
        s.size_rad.signum(),
        count[s.link],
        s.duration_s,
    )
}

fn measure(
    trace: &[Point],
    dac: &[(f64, i16)],
    goal: f64,
    dir: f64,
    count: f64,
    end: f64,
) -> Response {
    let tol = 2.0 * count;
    let mut settle = None;
    for p in trace.iter() {
        if (p.theta_rad - goal).abs() <= tol {
            settle.get_or_insert(p.t_s);
        } else {
            settle = None;
        }
    }
    let overshoot = trace
        .iter()
        .map(|p| (p.theta_rad - goal) * dir)
        .fold(0.0, f64::max);
    let peak_speed = trace
        .iter()
        .map(|p| p.omega_rad_s.abs())
        .fold(0.0, f64::max);
    let peak_torque = trace.iter().map(|p| p.torque_nm.abs()).fold(0.0, f64::max);
    let tail: Vec<&(f64, i16)> = dac.iter().filter(|(t, _)| *t >= end - 0.1).collect();
    let flips = tail
        .windows(2)
        .filter(|w| (w[0].1 > 0 && w[1].1 < 0) || (w[0].1 < 0 && w[1].1 > 0))
        .count();
    let rest: Vec<f64> = trace
        .iter()
        .filter(|p| p.t_s >= end - 0.1)
        .map(|p| p.torque_nm)
        .collect();
    let rms = (rest.iter().map(|u| u * u).sum::<f64>() / rest.len().max(1) as f64).sqrt();
    Response {
        settle_s: settle,
        overshoot_rad: overshoot,
        peak_speed_rad_s: peak_speed,
        peak_torque_nm: peak_torque,
        chatter_hz: flips as f64 / 0.1,
        rest_torque_rms_nm: rms,
        final_error_rad: trace.last().map_or(0.0, |p| p.theta_rad - goal),
        trace: trace.to_vec(),
    }
}

/// Prints the 3 rad step of link 1 for the servo and the baselines, with the ideal times.
pub fn report_step(period_s: f64) -> String {
    use std::fmt::Write;
    let mut o = String::new();
    let i = arm::LINK1.inertia_kgm2;
    let _ = writeln!(o, "bench servo: 3 rad step of link 1, full plant (friction, 212 Hz resonance, amplifier, quantisation), controller at {:.0} Hz", 1.0 / period_s);
    let _ = writeln!(
        o,
        "  ideal bang-bang: {:.4} s (13/13 N m), {:.4} s (13/10.5 N m)",
        bang_bang_s(3.0, i, 13.0, 13.0),
        bang_bang_s(3.0, i, 13.0, 10.5)
    );
    let _ = writeln!(
        o,
        "  {:<26} {:>12} {:>14} {:>12} {:>12} {:>14} {:>12}",
        "controller",
        "2 counts at",
        "overshoot mrad",
        "peak rad/s",
        "peak N m",
        "rest N m rms",
        "end err mrad"
    );
    for c in [Controller::SlidingMode, SATURATED_PD, BEST_LINEAR_PD] {
        let dur = if c == BEST_LINEAR_PD { 3.0 } else { 0.8 };
        let r = run(
            c,
            Step {
                link: 0,
                size_rad: 3.0,
                inertia_scale: 1.0,
                period_s,
                duration_s: dur,
            },
        );
        let settle = r
            .settle_s
            .map_or("never".to_string(), |t| format!("{t:.4} s"));
        let _ = writeln!(
            o,
            "  {:<26} {:>12} {:>14.2} {:>12.2} {:>12.2} {:>14.3} {:>12.2}",
            c.name(),
            settle,
            r.overshoot_rad * 1e3,
            r.peak_speed_rad_s,
            r.peak_torque_nm,
            r.rest_torque_rms_nm,
            r.final_error_rad * 1e3
        );
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ideal_bang_bang_times_match_the_thesis() {
        let i = arm::LINK1.inertia_kgm2;
        assert!((bang_bang_s(3.0, i, 13.0, 13.0) - 0.208).abs() < 0.001);
        assert!((bang_bang_s(3.0, i, 13.0, 10.5) - 0.2209).abs() < 0.001);
    }
}
