//! The experimental arm of thesis ch. II (lines ~272-380, 819-830): two links, dynamically
//! decoupled, each a pure inertia in absolute joint angles, driven through steel bands by
//! motors mounted to ground. Every crate that needs a number about the arm takes it from
//! here.
//!
//! * [`LINK1`], [`LINK2`]: inertia, transmission, torque limit, friction, first resonance,
//!   encoder resolution, speed limit.
//! * [`AMP`]: the PWM transconductance amplifiers.
//! * [`geometry`]: the arm's outline in the plane and exact distance to disk obstacles.
#![no_std]
#![deny(missing_docs)]

pub mod geometry;

/// One link with its motor and transmission, all figures referred to the link (joint) side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Link {
    /// Total inertia at the link, motor rotor reflected through the transmission included.
    pub inertia_kgm2: f64,
    /// Fraction of [`Link::inertia_kgm2`] on the motor side of the band (rotor, reflected):
    /// the two masses of the first-resonance model.
    pub motor_fraction: f64,
    /// Motor revolutions per link revolution (4:1 steel band for link 1, 1:1 for link 2).
    pub gear_ratio: f64,
    /// Torque at the link at the amplifier's current limit.
    pub torque_limit_nm: f64,
    /// Kinetic (Coulomb) friction at the link, from the motor brushes.
    pub coulomb_nm: f64,
    /// Breakaway (static) friction at the link: a link at rest stays at rest below it.
    pub breakaway_nm: f64,
    /// Viscous friction at the link.
    pub viscous_nms: f64,
    /// First structural resonance of the link (thesis fig. II.5, II.6).
    pub resonance_hz: f64,
    /// Damping ratio of that resonance (not measured in the thesis; a light 2%).
    pub resonance_zeta: f64,
    /// Encoder counts per link revolution (2048 lines x 4 per motor revolution x ratio).
    pub counts_per_rev: u32,
    /// Link speed at the motors' 3000 rpm limit.
    pub max_speed_rad_s: f64,
    /// Torque at the link of the joint's spring-applied brake, engaged when the servo
    /// board's watchdog disables the amplifiers (`regs::servo::AMP_WATCHDOG_US`): twice the
    /// torque limit (holding brakes are rated above the motor's peak torque), so that a
    /// link the dead servo left accelerating for the watchdog's time still stops within the
    /// arrest distance the servo last published (docs/reliability.md).
    pub brake_nm: f64,
}

/// Motor torque constant, N m per A (PMI JR16M4CH): link 1's 13 N m limit through the 4:1
/// band at the 10 A amplifier current limit.
pub const KT_NM_PER_A: f64 = 0.325;

/// Encoder lines per motor revolution (quadrature: 4 counts per line).
pub const ENCODER_LINES: u32 = 2048;

/// Link 1: 0.047 kg m^2 (thesis-notes ch. II; ~275-290 rad/s^2 at 13 N m), 4:1 band,
/// motor rotor ~1/60 of the link inertia before reflection (x16 through 4:1: ~20%),
/// friction 0.30 N m, first resonance 212 Hz.
pub const LINK1: Link = Link {
    inertia_kgm2: 0.047,
    motor_fraction: 0.20,
    gear_ratio: 4.0,
    torque_limit_nm: AMP.current_limit_a * KT_NM_PER_A * 4.0,
    coulomb_nm: 0.30,
    breakaway_nm: 0.30,
    viscous_nms: 0.002,
    resonance_hz: 212.0,
    resonance_zeta: 0.02,
    counts_per_rev: ENCODER_LINES * 4 * 4,
    max_speed_rad_s: 3000.0 * core::f64::consts::TAU / 60.0 / 4.0,
    brake_nm: 2.0 * AMP.current_limit_a * KT_NM_PER_A * 4.0,
};

/// Link 2: 0.0035 kg m^2 of which the rotor is 17% (thesis line ~330), 1:1 band, friction
/// 0.085 N m, first resonance 125 Hz (a conservative underestimate, measured with the
/// accelerometer's mass on the tip).
pub const LINK2: Link = Link {
    inertia_kgm2: 0.0035,
    motor_fraction: 0.17,
    gear_ratio: 1.0,
    torque_limit_nm: AMP.current_limit_a * KT_NM_PER_A,
    coulomb_nm: 0.085,
    breakaway_nm: 0.085,
    viscous_nms: 0.0002,
    resonance_hz: 125.0,
    resonance_zeta: 0.02,
    counts_per_rev: ENCODER_LINES * 4,
    max_speed_rad_s: 3000.0 * core::f64::consts::TAU / 60.0,
    brake_nm: 2.0 * AMP.current_limit_a * KT_NM_PER_A,
};

/// Both links, index 0 = link 1.
pub const LINKS: [Link; 2] = [LINK1, LINK2];

/// A PWM current amplifier in transconductance mode (PMI CX-90/125, thesis line ~360).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Amp {
    /// Output current per input volt.
    pub transconductance_a_per_v: f64,
    /// Current limit the amplifiers were set to (the motors' safe continuous current).
    pub current_limit_a: f64,
    /// Small-signal bandwidth (thesis fig. II.4: flat to about 1.5 kHz).
    pub bandwidth_hz: f64,
    /// PWM switching frequency.
    pub switching_hz: f64,
}

/// The amplifiers of both links.
pub const AMP: Amp = Amp {
    transconductance_a_per_v: 1.0,
    current_limit_a: 10.0,
    bandwidth_hz: 1500.0,
    switching_hz: 6000.0,
};

impl Link {
    /// Peak acceleration at the torque limit, rad/s^2.
    pub fn max_accel_rad_s2(&self) -> f64 {
        self.torque_limit_nm / self.inertia_kgm2
    }
    /// One encoder count in radians of link angle.
    pub fn rad_per_count(&self) -> f64 {
        core::f64::consts::TAU / self.counts_per_rev as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_match_the_thesis() {
        assert!((LINK1.torque_limit_nm - 13.0).abs() < 1e-9);
        let a1 = LINK1.max_accel_rad_s2();
        assert!((270.0..=295.0).contains(&a1), "link 1 accel {a1}");
        let a2 = LINK2.max_accel_rad_s2();
        assert!((900.0..=1000.0).contains(&a2), "link 2 accel {a2}");
        assert_eq!(LINK1.counts_per_rev, 32768);
        assert_eq!(LINK2.counts_per_rev, 8192);
        assert!((LINK1.max_speed_rad_s - 78.5).abs() < 0.1);
        assert!((LINK2.max_speed_rad_s - 314.2).abs() < 0.1);
    }
}
