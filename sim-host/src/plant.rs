//! The arm plant (thesis ch. II; design.md section 7): per link, a PWM transconductance
//! amplifier driving a motor that turns the link through a steel band.
//!
//! * Amplifier: command volts x 1 A/V, clamped to the current limit, through a first-order
//!   lag at the 1.5 kHz bandwidth (solved exactly over each step).
//! * Two-mass model of the first resonance: the motor side (rotor, reflected) and the link
//!   side joined by the band's stiffness `k`, with `k` and the band damping chosen so the
//!   relative mode rings at the link's resonance with damping ratio `resonance_zeta`.
//! * Friction acts on the motor side (the thesis attributes it to the brushes): Coulomb plus
//!   viscous while moving; a motor at rest stays at rest while the torque on it is below
//!   breakaway.
//! * Integration: classic Runge-Kutta 4 at a fixed step (default 50 us) with the friction
//!   direction frozen over the step; a step in which the motor's velocity changes sign and
//!   the torque cannot break it away ends with the motor stopped. Measured errors (tests
//!   below): a rigid link under constant torque is exact to rounding (the solution is a
//!   quadratic; < 1e-6 relative asserted); the resonance rings within 1e-3 of its damped
//!   frequency; RK4's numerical damping of link 1's 212 Hz mode at 50 us loses 2.4e-5 of
//!   the energy per second, an equivalent damping ratio of ~1e-8 against the physical 0.02.
//!
//! The encoders are on the motors, so what the servo measures is the motor-side angle.

use arm::{Link, AMP, KT_NM_PER_A};
use std::f64::consts::TAU;

/// Default plant step.
pub const DEFAULT_DT_S: f64 = 50e-6;

/// How a link is modelled; the defaults are the full model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkModel {
    /// The link's parameters (from `crates/arm`).
    pub params: Link,
    /// Multiplies the inertia (plant-model error studies: 0.8, 1.2).
    pub inertia_scale: f64,
    /// Two-mass resonance on; off = one rigid inertia.
    pub resonance: bool,
    /// Friction on.
    pub friction: bool,
    /// Amplifier lag on; off = current follows the command at once.
    pub amp_lag: bool,
}

impl LinkModel {
    /// The full model of `params`.
    pub fn full(params: Link) -> Self {
        Self {
            params,
            inertia_scale: 1.0,
            resonance: true,
            friction: true,
            amp_lag: true,
        }
    }
    /// A pure inertia: no resonance, no friction, ideal amplifier.
    pub fn ideal(params: Link) -> Self {
        Self {
            params,
            inertia_scale: 1.0,
            resonance: false,
            friction: false,
            amp_lag: false,
        }
    }
    fn inertia(&self) -> f64 {
        self.params.inertia_kgm2 * self.inertia_scale
    }
    /// Motor-side and link-side inertias of the two-mass model.
    fn masses(&self) -> (f64, f64) {
        let j = self.inertia();
        (
            j * self.params.motor_fraction,
            j * (1.0 - self.params.motor_fraction),
        )
    }
    /// Band stiffness and damping giving the resonance.
    fn band(&self) -> (f64, f64) {
        let (jm, jl) = self.masses();
        let red = jm * jl / (jm + jl);
        let w = TAU * self.params.resonance_hz;
        (w * w * red, 2.0 * self.params.resonance_zeta * w * red)
    }
}

/// The state of one link.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LinkState {
    /// Motor-side angle, referred to the link (what the encoder sees).
    pub motor_rad: f64,
    /// Motor-side velocity, referred to the link.
    pub motor_rad_s: f64,
    /// Link angle (absolute).
    pub link_rad: f64,
    /// Link velocity.
    pub link_rad_s: f64,
    /// Amplifier output current.
    pub current_a: f64,
    /// The motor is held by static friction.
    pub stuck: bool,
}

impl LinkState {
    /// At rest at `angle_rad`.
    pub fn at(angle_rad: f64) -> Self {
        Self {
            motor_rad: angle_rad,
            link_rad: angle_rad,
            stuck: true,
            ..Default::default()
        }
    }
}

/// One link: its model and state.
#[derive(Clone, Debug)]
pub struct LinkPlant {
    /// The model.
    pub model: LinkModel,
    /// The state.
    pub state: LinkState,
    /// The joint's brake is engaged: [`arm::Link::brake_nm`] of friction added to the
    /// Coulomb and breakaway friction (set by the simulation from the servo board's
    /// watchdog, `regs::servo::AMP_WATCHDOG_US`).
    pub brake: bool,
}

type X = [f64; 4]; // motor angle, motor velocity, link angle, link velocity

impl LinkPlant {
    /// A link at rest at `angle_rad`.
    pub fn new(model: LinkModel, angle_rad: f64) -> Self {
        Self {
            model,
            state: LinkState::at(angle_rad),
            brake: false,
        }
    }

    /// Torque at the link from the amplifier current.
    pub fn motor_torque_nm(&self) -> f64 {
        self.state.current_a * KT_NM_PER_A * self.model.params.gear_ratio
    }

    /// Torque on the motor side other than friction, for state `x` and drive `tau`.
    fn drive(&self, x: &X, tau: f64) -> f64 {
        if self.model.resonance {
            let (k, c) = self.model.band();
            tau - k * (x[0] - x[2]) - c * (x[1] - x[3])
        } else {
            tau
        }
    }

    fn deriv(&self, x: &X, tau: f64, fric_dir: f64, held: bool) -> X {
        let p = &self.model.params;
        let brake = if self.brake { p.brake_nm } else { 0.0 };
        let friction = |v: f64| {
            if self.model.friction {
                fric_dir * (p.coulomb_nm + brake) + p.viscous_nms * v
            } else {
                fric_dir * brake
            }
        };
        if !self.model.resonance {
            let a = if held {
                0.0
            } else {
                (tau - friction(x[1])) / self.model.inertia()
            };
            return [x[1], a, x[1], a];
        }
        let (jm, jl) = self.model.masses();
        let (k, c) = self.model.band();
        let spring = k * (x[0] - x[2]) + c * (x[1] - x[3]);
        let am = if held {
            0.0
        } else {
            (tau - spring - friction(x[1])) / jm
        };
        [x[1], am, x[3], spring / jl]
    }

    /// Advances by `dt_s` with amplifier command `volts`.
    pub fn step(&mut self, volts: f64, dt_s: f64) {
        let lim = AMP.current_limit_a;
        let i_cmd = (volts * AMP.transconductance_a_per_v).clamp(-lim, lim);
        let i0 = self.state.current_a;
        // Exact first-order response over the step; the torque uses the step's mean current.
        let (i1, i_mean) = if self.model.amp_lag {
            let tau_s = 1.0 / (TAU * AMP.bandwidth_hz);
            let e = (-dt_s / tau_s).exp();
            let i1 = i_cmd + (i0 - i_cmd) * e;
            (i1, i_cmd + (i0 - i_cmd) * tau_s / dt_s * (1.0 - e))
        } else {
            (i_cmd, i_cmd)
        };
        self.state.current_a = i1;
        let tau = i_mean * KT_NM_PER_A * self.model.params.gear_ratio;
        let s = self.state;
        let x: X = [s.motor_rad, s.motor_rad_s, s.link_rad, s.link_rad_s];
        let p = self.model.params;

        // Static friction (and the brake): does the motor break away this step?
        let breakaway = p.breakaway_nm + if self.brake { p.brake_nm } else { 0.0 };
        let sticks = self.model.friction || self.brake;
        let mut held = false;
        let mut dir = s.motor_rad_s.signum();
        if sticks && (s.stuck || s.motor_rad_s == 0.0) {
            let f = self.drive(&x, tau);
            if f.abs() <= breakaway {
                held = true;
                dir = 0.0;
            } else {
                dir = f.signum();
            }
        }
        let xn = rk4(|y| self.deriv(y, tau, dir, held), &x, dt_s);
        let mut n = LinkState {
            motor_rad: xn[0],
            motor_rad_s: xn[1],
            link_rad: xn[2],
            link_rad_s: xn[3],
            current_a: i1,
            stuck: held,
        };
        if held {
            n.motor_rad = s.motor_rad;
            n.motor_rad_s = 0.0;
            if !self.model.resonance {
                n.link_rad = s.link_rad;
                n.link_rad_s = 0.0;
            }
        } else if sticks && dir != 0.0 && n.motor_rad_s.signum() != dir {
            // The velocity reached zero inside the step: stop unless the torque breaks away.
            let f = self.drive(&xn, tau);
            if f.abs() <= breakaway {
                n.motor_rad_s = 0.0;
                n.stuck = true;
                if !self.model.resonance {
                    n.link_rad_s = 0.0;
                }
            }
        }
        self.state = n;
    }
}

fn rk4(f: impl Fn(&X) -> X, x: &X, h: f64) -> X {
    let add = |a: &X, b: &X, s: f64| -> X {
        [
            a[0] + s * b[0],
            a[1] + s * b[1],
            a[2] + s * b[2],
            a[3] + s * b[3],
        ]
    };
    let k1 = f(x);
    let k2 = f(&add(x, &k1, h / 2.0));
    let k3 = f(&add(x, &k2, h / 2.0));
    let k4 = f(&add(x, &k3, h));
    let mut y = *x;
    for i in 0..4 {
        y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    y
}

/// Both links.
#[derive(Clone, Debug)]
pub struct Plant {
    /// Link 1 and link 2.
    pub links: [LinkPlant; 2],
    /// Fixed step.
    pub dt_s: f64,
    /// Time since start.
    pub t_s: f64,
}

impl Plant {
    /// The full model of both links at rest at `angles_rad`.
    pub fn new(angles_rad: [f64; 2], dt_s: f64) -> Self {
        Self {
            links: [
                LinkPlant::new(LinkModel::full(arm::LINK1), angles_rad[0]),
                LinkPlant::new(LinkModel::full(arm::LINK2), angles_rad[1]),
            ],
            dt_s,
            t_s: 0.0,
        }
    }

    /// Advances one step with amplifier commands `volts`.
    pub fn step(&mut self, volts: [f64; 2]) {
        for (l, v) in self.links.iter_mut().zip(volts) {
            l.step(v, self.dt_s);
        }
        self.t_s += self.dt_s;
    }

    /// Link angles.
    pub fn angles_rad(&self) -> [f64; 2] {
        [self.links[0].state.link_rad, self.links[1].state.link_rad]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pure_inertia_under_constant_torque_follows_a_t2_over_2() {
        let mut l = LinkPlant::new(LinkModel::ideal(arm::LINK1), 0.0);
        let volts = 4.0;
        let a = volts * KT_NM_PER_A * 4.0 / arm::LINK1.inertia_kgm2;
        let dt = DEFAULT_DT_S;
        for n in 1..=20_000u32 {
            l.step(volts, dt);
            let t = n as f64 * dt;
            let want = a * t * t / 2.0;
            let rel = (l.state.link_rad - want).abs() / want;
            assert!(
                rel < 1e-6,
                "t={t}: {} vs {want} (rel {rel:e})",
                l.state.link_rad
            );
        }
    }

    #[test]
    fn a_coasting_link_stops_when_coulomb_and_viscous_friction_say() {
        for p in [arm::LINK1, arm::LINK2] {
            let mut m = LinkModel::ideal(p);
            m.friction = true;
            let mut l = LinkPlant::new(m, 0.0);
            let w0 = 5.0;
            l.state.motor_rad_s = w0;
            l.state.link_rad_s = w0;
            l.state.stuck = false;
            let (j, b, fc) = (p.inertia_kgm2, p.viscous_nms, p.coulomb_nm);
            let t_stop = j / b * (1.0 + b * w0 / fc).ln();
            let dt = DEFAULT_DT_S;
            let mut t = 0.0;
            while l.state.motor_rad_s != 0.0 {
                l.step(0.0, dt);
                t += dt;
                assert!(t < 10.0);
            }
            assert!(
                (t - t_stop).abs() <= dt,
                "stopped at {t}, predicted {t_stop}"
            );
            // And it stays stopped: zero torque is below breakaway.
            let at = l.state.link_rad;
            for _ in 0..1000 {
                l.step(0.0, dt);
            }
            assert_eq!(l.state.link_rad, at);
        }
    }

    #[test]
    fn a_link_at_rest_stays_at_rest_below_breakaway() {
        let mut l = LinkPlant::new(LinkModel::full(arm::LINK1), 1.0);
        // 0.2 A x 0.325 x 4 = 0.26 N m < 0.30 N m breakaway.
        for _ in 0..20_000 {
            l.step(0.2, DEFAULT_DT_S);
        }
        assert_eq!(l.state.motor_rad, 1.0);
        assert!(
            (l.state.link_rad - 1.0).abs() < 1e-4,
            "only the band flexes: {}",
            l.state.link_rad
        );
        // 0.3 A: 0.39 N m breaks away.
        for _ in 0..2000 {
            l.step(0.3, DEFAULT_DT_S);
        }
        assert!(l.state.motor_rad > 1.0);
    }

    /// Frequency of the relative motor-link motion after an impulse, from zero crossings.
    fn ringing_hz(p: Link, dt: f64) -> f64 {
        let mut m = LinkModel::full(p);
        m.friction = false;
        m.amp_lag = false;
        let mut l = LinkPlant::new(m, 0.0);
        l.state.stuck = false;
        l.step(10.0, dt); // one-step torque impulse
        let mut prev = l.state.motor_rad - l.state.link_rad;
        let (mut first, mut last, mut n) = (None, 0.0, 0);
        let mut t = dt;
        for _ in 0..(0.2 / dt) as usize {
            l.step(0.0, dt);
            t += dt;
            let d = l.state.motor_rad - l.state.link_rad;
            if prev > 0.0 && d <= 0.0 {
                let tc = t - dt * d / (d - prev);
                if first.is_none() {
                    first = Some(tc);
                } else {
                    n += 1;
                }
                last = tc;
            }
            prev = d;
        }
        n as f64 / (last - first.unwrap())
    }

    #[test]
    fn the_impulse_response_rings_at_the_resonance() {
        for p in [arm::LINK1, arm::LINK2] {
            let f = ringing_hz(p, DEFAULT_DT_S);
            let damped = p.resonance_hz * (1.0 - p.resonance_zeta * p.resonance_zeta).sqrt();
            let rel = (f - p.resonance_hz).abs() / p.resonance_hz;
            assert!(rel < 0.02, "{f} Hz vs {} Hz", p.resonance_hz);
            // The integration error itself is far smaller: compare with the damped frequency.
            assert!((f - damped).abs() / damped < 1e-3, "{f} vs damped {damped}");
        }
    }

    #[test]
    fn rk4_numerical_damping_is_negligible_beside_the_physical_damping() {
        // Undamped two-mass oscillation: energy is conserved exactly by the true solution;
        // measure RK4's amplitude drift over 1 s at the default step.
        let mut p = arm::LINK1;
        p.resonance_zeta = 0.0;
        let mut m = LinkModel::full(p);
        m.friction = false;
        m.amp_lag = false;
        let mut l = LinkPlant::new(m, 0.0);
        l.state.stuck = false;
        l.state.motor_rad = 1e-3; // initial twist of the band
        let (k, _) = m.band();
        let (jm, jl) = m.masses();
        let energy = |s: &LinkState| {
            0.5 * k * (s.motor_rad - s.link_rad).powi(2)
                + 0.5 * jm * s.motor_rad_s.powi(2)
                + 0.5 * jl * s.link_rad_s.powi(2)
        };
        let e0 = energy(&l.state);
        for _ in 0..20_000 {
            l.step(0.0, DEFAULT_DT_S);
        }
        let drift = (energy(&l.state) - e0).abs() / e0;
        // Energy decays as exp(-2 zeta w t): the equivalent numerical damping ratio.
        let zeta_num = drift / (2.0 * TAU * p.resonance_hz * 1.0);
        assert!(
            zeta_num < 1e-3 * arm::LINK1.resonance_zeta,
            "numerical zeta {zeta_num:e} (energy drift {drift:e})"
        );
    }

    #[test]
    fn the_amplifier_limits_and_lags() {
        let mut l = LinkPlant::new(LinkModel::full(arm::LINK2), 0.0);
        l.step(20.0, DEFAULT_DT_S);
        assert!(l.state.current_a < AMP.current_limit_a);
        for _ in 0..100 {
            l.step(20.0, DEFAULT_DT_S);
        }
        assert!(
            (l.state.current_a - AMP.current_limit_a).abs() < 1e-9,
            "clamped at the limit"
        );
        // Time constant 1/(2 pi 1.5 kHz) = 106 us: after one step of 50 us, 1-exp(-0.47) = 37.5%.
        let mut l = LinkPlant::new(LinkModel::full(arm::LINK2), 0.0);
        l.step(1.0, DEFAULT_DT_S);
        let want = 1.0 - (-DEFAULT_DT_S * TAU * 1500.0).exp();
        assert!((l.state.current_a - want).abs() < 1e-12);
    }
}
