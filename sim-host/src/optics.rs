//! The optical sensor (thesis ch. II.3.2 and 3.4): a lateral-effect photodiode behind a
//! wide-angle lens 1.6 m above the plane of the beacons, its sum/difference amplifiers, the
//! analog divider, the 40 us output filters, and the LEDs with their current driver. The
//! sensing board's converters sample it through [`crate::devices::SensingIo`].
//!
//! What it models, each switchable in [`OpticsConfig`] and seeded:
//!
//! * Geometry: pinhole projection onto the detector; the 0.7 m x 0.7 m square of the
//!   thesis's calibration scan fills the detector (normalised coordinate +-1 at +-0.35 m).
//! * Distortion: barrel distortion of the wide-angle lens ([`LENS_K1`]) and the detector's
//!   compression towards its edges and cross-axis pincushion ([`DETECTOR_A`],
//!   [`DETECTOR_B`]); line spacing is widest in the centre and about 0.6x at the edge, the
//!   shape of fig. II.7.
//! * Field of view: a beacon whose spot leaves the detector (beyond about 0.38 m from the
//!   axis) loses its light over [`SPOT_WIDTH`]; far out it reads as occluded.
//! * Intensity: LED power falls as cos^4 of the view angle; each LED's efficiency and the
//!   unregulated driver's current differ per beacon. Offsets in the difference channels
//!   ([`DIFF_OFFSET`]) make the divided position signals depend on intensity, as the thesis
//!   found (up to 15 mm between LEDs).
//! * Ambient light: a constant offset on the sum and difference signals.
//! * Noise: white noise on the difference signals, [`OpticsConfig::noise_mm`] of position
//!   per sample at the reference sum level (the thesis's +-3 mm after its 32-sample average
//!   is 1 mm rms: 5.7 mm rms per sample); it scales as 1/sum.
//! * Thermal drift: an offset and gain change of the divider outputs, proportional to a
//!   warmth in 0..=1 that follows the warm-up ([`OpticsConfig::drift`]); at 1 it moves
//!   positions by up to about 18 mm.
//! * The 40 us first-order filters on all three outputs: a sample taken 250 us after the
//!   driver switched still holds e^-6.25 of the previous beacon's signal.
//! * Faults: an occluded beacon (no light reaches the detector: the sum falls to the ambient
//!   level) and a saturated converter input (the channels driven beyond +10 V), each over a
//!   time window.

use crate::devices::{Analog, Drive, Optics};
use crate::sim::Rng;

/// Height of the lens above the plane of the beacons (thesis: 1.6 m).
pub const HEIGHT_M: f64 = 1.6;
/// Half the side of the square the detector sees (thesis: 0.7 m x 0.7 m).
pub const FIELD_HALF_M: f64 = 0.35;
/// Lens radial distortion: r_d = r (1 + K1 r^2), r the tangent of the view angle.
pub const LENS_K1: f64 = -1.0;
/// Detector edge compression: xi (1 - A xi^2).
pub const DETECTOR_A: f64 = 0.10;
/// Detector cross-axis pincushion: (1 + B eta^2).
pub const DETECTOR_B: f64 = 0.06;
/// Divider output volts per unit of normalised detector position: the detector's edge with
/// every offset and full drift stays inside the converters' +-10 V.
pub const V_PER_XI: f64 = 8.0;
/// Sum signal of a nominal LED at 560 mA straight below the lens, volts.
pub const SUM_NOMINAL_V: f64 = 6.0;
/// Nominal pulse current (thesis: 560 mA).
pub const NOMINAL_MA: f64 = 560.0;
/// Offsets of the x and y difference channels, in volts of sum: what makes the divided
/// signal depend on intensity.
pub const DIFF_OFFSET: [f64; 2] = [0.27, -0.22];
/// Offset of the sum channel, volts.
pub const SUM_OFFSET_V: f64 = 0.02;
/// Ambient light on the sum signal, volts.
pub const AMBIENT_SUM_V: f64 = 0.08;
/// Ambient light on the x and y difference signals, volts of sum.
pub const AMBIENT_DIFF_V: [f64; 2] = [0.02, 0.01];
/// Thermal drift at warmth 1: offsets of the x and y outputs, volts.
pub const DRIFT_OFFSET_V: [f64; 2] = [0.20, -0.17];
/// Thermal drift at warmth 1: gain changes of the x and y outputs.
pub const DRIFT_GAIN: [f64; 2] = [0.012, -0.011];
/// Thermal drift at warmth 1: gain change of the sum channel.
pub const DRIFT_SUM_GAIN: f64 = -0.05;
/// Where the detector ends, in normalised coordinates: beyond, the light spot leaves the
/// detector (the calibrated square reaches +-1).
pub const DETECTOR_EDGE: f64 = 1.10;
/// Width of the blurred spot's edge, normalised: the light on the detector falls from all
/// to none over this distance about [`DETECTOR_EDGE`].
pub const SPOT_WIDTH: f64 = 0.08;

/// The divider and amplifiers clip here (beyond the converters' +-10 V).
pub const RAIL_V: f64 = 11.0;
/// Time constant of the output filters.
pub const FILTER_TAU_S: f64 = regs::sensing::FILTER_TAU_US as f64 * 1e-6;
/// Spread of the LEDs' efficiencies (uniform, +-).
pub const LED_EFFICIENCY_SPREAD: f64 = 0.20;
/// Spread of the unregulated driver's current per beacon (uniform, +-).
pub const DRIVER_SPREAD: f64 = 0.15;
/// Noise of the sum signal, volts rms.
pub const SUM_NOISE_V: f64 = 0.01;
/// The sum level the noise figure refers to, volts (the sensing firmware's default
/// reference: [`sensing::DEFAULT_S_REF_CODES`]).
pub const NOISE_REF_SUM_V: f64 =
    sensing::DEFAULT_S_REF_CODES as f64 * crate::devices::ADC_V_PER_CODE;

/// A time window of a fault on one beacon.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeaconWindow {
    /// The beacon, 0..=7.
    pub beacon: u8,
    /// From (s).
    pub from_s: f64,
    /// Until (s).
    pub until_s: f64,
}

impl BeaconWindow {
    fn covers(&self, beacon: u8, t_s: f64) -> bool {
        self.beacon == beacon && t_s >= self.from_s && t_s < self.until_s
    }
}

/// What the optical model includes. [`Default`] is the realistic sensor at the temperature
/// it was calibrated at: everything on but drift and faults.
#[derive(Clone, Debug, PartialEq)]
pub struct OpticsConfig {
    /// Lens and detector nonlinearity.
    pub distortion: bool,
    /// Noise per sample, millimetres rms at the reference sum (0 = none).
    pub noise_mm: f64,
    /// LED efficiency and driver current differences between beacons.
    pub intensity: bool,
    /// Ambient light offsets.
    pub ambient: bool,
    /// Thermal drift: warmth at t = 0, warmth it tends to, and the warm-up time constant
    /// (s; 0 = stays at the start warmth).
    pub drift: (f64, f64, f64),
    /// Beacons hidden from the lens.
    pub occluded: Vec<BeaconWindow>,
    /// Beacons whose converter inputs are driven beyond range.
    pub saturated: Vec<BeaconWindow>,
}

impl Default for OpticsConfig {
    fn default() -> Self {
        Self {
            distortion: true,
            noise_mm: 5.66,
            intensity: true,
            ambient: true,
            drift: (0.0, 0.0, 0.0),
            occluded: Vec::new(),
            saturated: Vec::new(),
        }
    }
}

impl OpticsConfig {
    /// A perfect sensor: linear, noiseless, no offsets, all LEDs alike.
    pub fn ideal() -> Self {
        Self {
            distortion: false,
            noise_mm: 0.0,
            intensity: false,
            ambient: false,
            ..Self::default()
        }
    }

    /// The warmth at `t_s`.
    pub fn warmth(&self, t_s: f64) -> f64 {
        let (w0, w1, tau) = self.drift;
        if tau > 0.0 {
            w1 + (w0 - w1) * (-t_s / tau).exp()
        } else {
            w0
        }
    }
}

/// The camera and beacons.
pub struct Camera {
    /// What the model includes.
    pub cfg: OpticsConfig,
    /// Beacon positions in the plane (m); `None`: no such beacon.
    pub beacons: [Option<(f64, f64)>; 8],
    /// Per-beacon LED efficiency (1 = nominal).
    pub efficiency: [f64; 8],
    /// Per-beacon driver current factor (1 = the set point).
    pub driver: [f64; 8],
    /// Extra warmth added to the configured warm-up (the benches heat the camera directly).
    pub extra_warmth: f64,
    rng: Rng,
    drive: Drive,
    /// Filter outputs (x, y, sum) and their inputs since `t_s`.
    out: [f64; 3],
    input: [f64; 3],
    t_s: f64,
}

impl Camera {
    /// The camera with `cfg`; LED differences and noise drawn from `seed`.
    pub fn new(cfg: OpticsConfig, seed: u64) -> Self {
        let mut rng = Rng::new(seed ^ 0x0B71_C5E5_5EED_0001);
        let mut efficiency = [1.0; 8];
        let mut driver = [1.0; 8];
        for b in 0..8 {
            let e = (2.0 * rng.next_f64() - 1.0) * LED_EFFICIENCY_SPREAD;
            let d = (2.0 * rng.next_f64() - 1.0) * DRIVER_SPREAD;
            if cfg.intensity {
                efficiency[b] = 1.0 + e;
                driver[b] = 1.0 + d;
            }
        }
        let mut c = Self {
            cfg,
            beacons: [None; 8],
            efficiency,
            driver,
            extra_warmth: 0.0,
            rng,
            drive: Drive {
                beacon: 0,
                on: false,
                level_ma: regs::sensing::LED_LEVEL_RESET_MA,
            },
            out: [0.0; 3],
            input: [0.0; 3],
            t_s: 0.0,
        };
        c.input = c.settled(c.drive, 0.0);
        c.out = c.input;
        c
    }

    /// Normalised detector position (xi, eta) of a beacon at (`x_m`, `y_m`): +-1 at the
    /// edges of the calibrated square.
    pub fn detector(&self, x_m: f64, y_m: f64) -> (f64, f64) {
        let (u, v) = (x_m / HEIGHT_M, y_m / HEIGHT_M);
        let edge = FIELD_HALF_M / HEIGHT_M;
        if !self.cfg.distortion {
            return (u / edge, v / edge);
        }
        let k = 1.0 + LENS_K1 * (u * u + v * v);
        let (xi, eta) = (u * k / edge, v * k / edge);
        (
            xi * (1.0 - DETECTOR_A * xi * xi) * (1.0 + DETECTOR_B * eta * eta),
            eta * (1.0 - DETECTOR_A * eta * eta) * (1.0 + DETECTOR_B * xi * xi),
        )
    }

    /// Light of beacon `b` at (`x_m`, `y_m`), whose spot is at detector position (`xi`,
    /// `eta`), as a sum signal, volts, at drive `ma`: cos^4 of the view angle, and only the
    /// part of the spot that falls on the detector.
    fn led_sum_v(&self, b: usize, x_m: f64, y_m: f64, (xi, eta): (f64, f64), ma: f64) -> f64 {
        let cos2 = HEIGHT_M * HEIGHT_M / (HEIGHT_M * HEIGHT_M + x_m * x_m + y_m * y_m);
        let on = |c: f64| ((DETECTOR_EDGE - c.abs()) / SPOT_WIDTH + 0.5).clamp(0.0, 1.0);
        SUM_NOMINAL_V * self.efficiency[b] * self.current_ma(b, ma) / NOMINAL_MA
            * cos2
            * cos2
            * on(xi)
            * on(eta)
    }

    /// The current the driver delivers to beacon `b` for set point `ma`.
    pub fn current_ma(&self, b: usize, ma: f64) -> f64 {
        (ma * self.driver[b]).min(regs::sensing::LED_LEVEL_MAX_MA as f64 * self.driver[b])
    }

    /// The warmth at `t_s`.
    pub fn warmth(&self, t_s: f64) -> f64 {
        self.cfg.warmth(t_s) + self.extra_warmth
    }

    /// The noise-free divider outputs (x, y) for a beacon at (`x_m`, `y_m`) whose light
    /// gives sum signal `s_led_v`, at warmth `w`.
    pub fn divided(&self, x_m: f64, y_m: f64, s_led_v: f64, w: f64) -> (f64, f64) {
        self.divided_at(self.detector(x_m, y_m), s_led_v, w)
    }

    /// [`Self::divided`] for a spot at detector position (`xi`, `eta`).
    fn divided_at(&self, (xi, eta): (f64, f64), s_led_v: f64, w: f64) -> (f64, f64) {
        let amb = if self.cfg.ambient { 1.0 } else { 0.0 };
        let s = self.undrifted_sum_v(s_led_v);
        let dx = s_led_v * xi + DIFF_OFFSET[0] + amb * AMBIENT_DIFF_V[0];
        let dy = s_led_v * eta + DIFF_OFFSET[1] + amb * AMBIENT_DIFF_V[1];
        let div = |d: f64, axis: usize| {
            let v = V_PER_XI * d / s;
            let v = v * (1.0 + w * DRIFT_GAIN[axis]) + w * DRIFT_OFFSET_V[axis];
            v.clamp(-RAIL_V, RAIL_V)
        };
        (div(dx, 0), div(dy, 1))
    }

    /// The sum the divider divides by: beacon light, ambient light and the channel offset.
    fn undrifted_sum_v(&self, s_led_v: f64) -> f64 {
        let amb = if self.cfg.ambient { 1.0 } else { 0.0 };
        s_led_v + amb * AMBIENT_SUM_V + SUM_OFFSET_V
    }

    /// The total sum signal for a beacon light `s_led_v` at warmth `w`.
    pub fn sum_v(&self, s_led_v: f64, w: f64) -> f64 {
        (self.undrifted_sum_v(s_led_v) * (1.0 + w * DRIFT_SUM_GAIN)).clamp(-RAIL_V, RAIL_V)
    }

    /// The settled (noise-free) outputs under drive `d` at `t_s`.
    fn settled(&self, d: Drive, t_s: f64) -> [f64; 3] {
        let b = d.beacon as usize & 7;
        let w = self.warmth(t_s);
        if self.cfg.saturated.iter().any(|f| f.covers(d.beacon, t_s)) && d.on {
            return [RAIL_V, RAIL_V, RAIL_V];
        }
        let hidden = self.cfg.occluded.iter().any(|f| f.covers(d.beacon, t_s));
        let (x, y) = self.beacons[b].unwrap_or((0.0, 0.0));
        let spot = self.detector(x, y);
        let s_led = match (d.on && !hidden, self.beacons[b]) {
            (true, Some(_)) => self.led_sum_v(b, x, y, spot, d.level_ma as f64),
            _ => 0.0,
        };
        let (xv, yv) = self.divided_at(spot, s_led, w);
        [xv, yv, self.sum_v(s_led, w)]
    }

    /// Moves the filters on to `t_s` with the inputs they have had since the last event,
    /// then takes the inputs of the current drive and beacon positions.
    fn advance(&mut self, t_s: f64) {
        let a = (-(t_s - self.t_s).max(0.0) / FILTER_TAU_S).exp();
        for k in 0..3 {
            self.out[k] = self.input[k] + (self.out[k] - self.input[k]) * a;
        }
        self.t_s = t_s;
        self.input = self.settled(self.drive, t_s);
    }

    fn gauss(&mut self) -> f64 {
        // Box-Muller on the simulation's generator.
        let u1 = self.rng.next_f64().max(1e-300);
        let u2 = self.rng.next_f64();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// Volts of divider output per metre at the centre of the field.
pub const V_PER_M_CENTRE: f64 = V_PER_XI / FIELD_HALF_M;

impl Optics for Camera {
    fn drive(&mut self, d: Drive, t_s: f64) {
        self.advance(t_s);
        self.drive = d;
        self.input = self.settled(d, t_s);
    }

    fn sample(&mut self, d: Drive, t_s: f64) -> Analog {
        self.drive = d;
        self.advance(t_s);
        let mut out = self.out;
        if self.cfg.noise_mm > 0.0 {
            // Noise on the difference signals, divided by the sum: the position noise
            // scales as 1/sum, `noise_mm` at the reference sum.
            let s = out[2].abs().max(0.05);
            let sigma_v = self.cfg.noise_mm * 1e-3 * V_PER_M_CENTRE * NOISE_REF_SUM_V / s;
            out[0] += sigma_v * self.gauss();
            out[1] += sigma_v * self.gauss();
            out[2] += SUM_NOISE_V * self.gauss();
        }
        let b = d.beacon as usize & 7;
        Analog {
            x_v: out[0].clamp(-RAIL_V, RAIL_V),
            y_v: out[1].clamp(-RAIL_V, RAIL_V),
            sum_v: out[2].clamp(-RAIL_V, RAIL_V),
            led_ma: if d.on {
                self.current_ma(b, d.level_ma as f64)
            } else {
                0.0
            },
        }
    }
}
