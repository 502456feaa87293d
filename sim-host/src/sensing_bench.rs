//! `sim-host bench sensing`: the sensing board against the truth (issue 6; thesis ch. II.3.4
//! for the baseline: +-3 mm of noise, up to 18 mm of thermal drift and 15 mm from LED
//! intensity differences).
//!
//! Each case runs the sensing and servo boards natively on the optical model: the thesis's
//! calibration scan (the host servoes the tip over the 36 x 36 grid), then, for the drift
//! cases, the camera warms up to full drift and the arm rests at a few places (as a working
//! arm does) so the drift reference can learn, then a survey: beacons 0-4, 6 and 7 placed at
//! random points of the calibrated square (seeded), 7 at a time, each published position
//! compared with the truth once the filter has settled.

use crate::optics::OpticsConfig;
use crate::sensing_cal::{self, hold_at, ScanPlan, ScanStats};
use crate::sim::{Calibration, Config, Motion, Obstacle, Rng, Sim, WandPath};
use arm::geometry::Disk;
use vme_map::records::{beacon_flags as bf, sensing_options as opt, SensingConfig};
use vme_map::BoardId;

/// Beacons the survey places (all but the tip).
pub const SURVEY_BEACONS: [usize; 7] = [0, 1, 2, 3, 4, 6, 7];

/// One case of the bench.
#[derive(Clone, Debug)]
pub struct Case {
    /// Name in the table.
    pub name: &'static str,
    /// The sensor.
    pub optics: OpticsConfig,
    /// Firmware options (`sensing_options`).
    pub options: u32,
    /// Warmth during the survey (the scan is at 0).
    pub warmth: f64,
}

/// The error figures of a survey, millimetres.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Errors {
    /// Published valid positions compared.
    pub samples: usize,
    /// Root mean square.
    pub rms_mm: f64,
    /// 95th percentile.
    pub p95_mm: f64,
    /// Largest.
    pub max_mm: f64,
    /// Published invalid while the beacon was in view (should be 0).
    pub invalid: usize,
    /// Per placed point: (true x, true y, mean error x, mean error y), metres.
    pub points: Vec<[f64; 4]>,
}

impl Errors {
    fn from(errs: &mut [f64], invalid: usize, points: Vec<[f64; 4]>) -> Self {
        errs.sort_by(f64::total_cmp);
        let n = errs.len();
        let rms = (errs.iter().map(|e| e * e).sum::<f64>() / n.max(1) as f64).sqrt();
        Self {
            samples: n,
            rms_mm: rms,
            p95_mm: if n > 0 {
                errs[(n * 95 / 100).min(n - 1)]
            } else {
                0.0
            },
            max_mm: errs.last().copied().unwrap_or(0.0),
            invalid,
            points,
        }
    }
}

/// A simulation of the sensing and servo boards with the host in place of the reflex.
pub fn system(optics: OpticsConfig, calibration: Calibration, seed: u64) -> Sim {
    // The encoders count from the power-up pose, which the servo takes as angle 0 (the
    // simulator's convention): the arm starts stretched out along x.
    let cfg = Config {
        seed,
        duration_s: f64::INFINITY,
        start_rad: [0.0, 0.0],
        boards: vec![(BoardId::Sensing, 250e-6), (BoardId::Servo, 1.0 / 3000.0)],
        optics,
        calibration,
        // Seven beacons parked in view until the survey places them.
        obstacles: (0..6)
            .map(|k| Obstacle {
                start: Disk {
                    x_m: -0.3 + 0.1 * k as f64,
                    y_m: -0.3,
                    r_m: 0.001,
                },
                motion: Motion::Static,
            })
            .collect(),
        wand: WandPath {
            points: vec![(0.0, 0.3, -0.3)],
        },
        ..Config::default()
    };
    Sim::new(cfg)
}

/// Publishes the firmware options.
pub fn configure(sim: &mut Sim, options: u32) {
    let rec = SensingConfig {
        options,
        s_ref_codes: sensing::DEFAULT_S_REF_CODES as u32,
        level_ma: regs::sensing::LED_LEVEL_RESET_MA as u32,
        serial: 1,
    };
    vme_map::SENSING_CONFIG.publish(&mut sim.bus(), &rec);
}

/// Places beacon `b` at `p` (metres) in the simulation.
pub fn place(sim: &mut Sim, b: usize, p: [f64; 2]) {
    match b {
        6 => sim.cfg.wand.points = vec![(0.0, p[0], p[1])],
        _ => {
            let k = if b == 7 { 5 } else { b };
            sim.cfg.obstacles[k].start.x_m = p[0];
            sim.cfg.obstacles[k].start.y_m = p[1];
        }
    }
}

/// The survey: `n` random points in the calibrated square, 7 at a time, settle until the
/// filter holds only samples of the new place (0.6 s), then
/// compare every published position for 0.1 s. The arm rests at `rest` throughout.
pub fn survey(sim: &mut Sim, n: usize, seed: u64, rest: [f64; 2], cycle: &mut u32) -> Errors {
    let mut rng = Rng::new(seed ^ 0x5EA5_1A6E);
    let half = -sensing_cal::ORIGIN_M;
    let mut errs = Vec::new();
    let mut invalid = 0;
    let mut points = Vec::new();
    for chunk in 0..n.div_ceil(SURVEY_BEACONS.len()) {
        let mut placed = Vec::new();
        for (k, &b) in SURVEY_BEACONS.iter().enumerate() {
            if chunk * SURVEY_BEACONS.len() + k >= n {
                break;
            }
            let p = [
                (2.0 * rng.next_f64() - 1.0) * half,
                (2.0 * rng.next_f64() - 1.0) * half,
            ];
            place(sim, b, p);
            placed.push((b, p, [0.0f64; 2], 0usize));
        }
        hold_at(
            sim,
            rest,
            sensing::filter::LONG as f64 * 0.002 + 0.08,
            cycle,
        );
        for _ in 0..50 {
            hold_at(sim, rest, 0.002, cycle);
            let t = vme_map::OBJECTS.read(&mut sim.bus()).expect("whole").0;
            for (b, p, sum, cnt) in placed.iter_mut() {
                let r = t.beacons[*b];
                if r.flags & bf::VALID == 0 {
                    invalid += 1;
                    continue;
                }
                let e = [r.x_um as f64 * 1e-6 - p[0], r.y_um as f64 * 1e-6 - p[1]];
                errs.push(e[0].hypot(e[1]) * 1e3);
                sum[0] += e[0];
                sum[1] += e[1];
                *cnt += 1;
            }
        }
        for (_, p, sum, cnt) in placed {
            let c = cnt.max(1) as f64;
            points.push([p[0], p[1], sum[0] / c, sum[1] / c]);
        }
    }
    Errors::from(&mut errs, invalid, points)
}

/// Rest places of the arm's tour before a drift survey (tip positions, m).
pub const TOUR: [[f64; 2]; 5] = [
    [0.0, 0.3],
    [0.3, 0.3],
    [-0.3, -0.3],
    [0.3, -0.3],
    [-0.3, 0.3],
];

/// What one case measured.
#[derive(Clone, Debug)]
pub struct CaseResult {
    /// The case.
    pub case: Case,
    /// The calibration scan's cost.
    pub scan: ScanStats,
    /// The survey.
    pub errors: Errors,
    /// The scan's signals (for the fig. II.7 picture).
    pub scan_signals_q5: Vec<[f64; 2]>,
}

/// Runs one case: scan, warm up and tour, survey.
pub fn run_case(
    case: &Case,
    plan: ScanPlan,
    survey_points: usize,
    seed: u64,
) -> Result<CaseResult, String> {
    let mut sim = system(case.optics.clone(), Calibration::None, seed);
    configure(&mut sim, case.options);
    let (scan, stats) = sensing_cal::calibrate(&mut sim, plan)?;
    let table = sensing_cal::build_table(&scan);
    sensing_cal::write_table(&mut sim.bus(), &table, 1);
    sim.sensing_io.optics.extra_warmth = case.warmth;
    let mut cycle = 1_000_000;
    for p in TOUR {
        let goal = sensing_cal::ik(p[0], p[1]).expect("reachable");
        hold_at(&mut sim, goal, 1.0, &mut cycle);
    }
    let rest = sensing_cal::ik(TOUR[0][0], TOUR[0][1]).expect("reachable");
    hold_at(&mut sim, rest, 1.0, &mut cycle);
    let errors = survey(&mut sim, survey_points, seed, rest, &mut cycle);
    Ok(CaseResult {
        case: case.clone(),
        scan: stats,
        errors,
        scan_signals_q5: scan.signals_q5,
    })
}

/// The bench's cases.
pub fn cases() -> Vec<Case> {
    let thesis = 0;
    let errors_off = OpticsConfig {
        intensity: false,
        ..OpticsConfig::default()
    };
    vec![
        Case {
            name: "thesis firmware, no drift or intensity errors",
            optics: errors_off.clone(),
            options: thesis,
            warmth: 0.0,
        },
        Case {
            name: "thesis firmware, drift errors only",
            optics: errors_off.clone(),
            options: thesis,
            warmth: 1.0,
        },
        Case {
            name: "thesis firmware, intensity errors only",
            optics: OpticsConfig::default(),
            options: thesis,
            warmth: 0.0,
        },
        Case {
            name: "thesis firmware, drift + intensity errors",
            optics: OpticsConfig::default(),
            options: thesis,
            warmth: 1.0,
        },
        Case {
            name: "ours, no drift or intensity errors",
            optics: errors_off,
            options: opt::DEFAULT,
            warmth: 0.0,
        },
        Case {
            name: "ours, drift + intensity errors",
            optics: OpticsConfig::default(),
            options: opt::DEFAULT,
            warmth: 1.0,
        },
    ]
}

/// How much of the bench to run.
#[derive(Clone, Copy, Debug)]
pub struct Size {
    /// The calibration scan.
    pub plan: ScanPlan,
    /// Survey points per case.
    pub survey_points: usize,
}

impl Size {
    /// The full bench: the thesis's 1296-point scan, 700 survey points per case.
    pub fn full() -> Self {
        Self {
            plan: ScanPlan::default(),
            survey_points: 700,
        }
    }
    /// A quick look: every 5th grid point (8 x 8), 70 survey points.
    pub fn quick() -> Self {
        Self {
            plan: ScanPlan {
                stride: 5,
                frames: 32,
            },
            survey_points: 70,
        }
    }
}

/// Update rate and latency of the native firmware: beacon positions published per second
/// (distinct strobe times), the delay from a sample's strobe to its publication, and the
/// time for a 20 mm step of a beacon to show half in the published position, with the
/// thesis's filter and with ours.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timing {
    /// Positions published per beacon per second.
    pub rate_hz: f64,
    /// Strobe to publication, worst seen, microseconds.
    pub publish_us: f64,
    /// Half of a 20 mm step visible after, ms: the thesis's filter.
    pub step_thesis_ms: f64,
    /// The same with ours.
    pub step_ours_ms: f64,
}

fn step_half_ms(options: u32, seed: u64) -> f64 {
    let mut sim = system(OpticsConfig::default(), Calibration::Model, seed);
    configure(&mut sim, options);
    let mut cycle = 0;
    let rest = sensing_cal::ik(0.0, 0.3).expect("reachable");
    place(&mut sim, 0, [0.0, -0.1]);
    hold_at(&mut sim, rest, 1.0, &mut cycle);
    // Relative to where it was published before the step (the model's table is made for
    // the current feedback: without it the position is offset).
    let x0 = vme_map::OBJECTS
        .read(&mut sim.bus())
        .expect("whole")
        .0
        .beacons[0]
        .x_um;
    place(&mut sim, 0, [0.02, -0.1]);
    let t0 = sim.t_s();
    for _ in 0..400 {
        hold_at(&mut sim, rest, 250e-6, &mut cycle);
        let t = vme_map::OBJECTS.read(&mut sim.bus()).expect("whole").0;
        if t.beacons[0].x_um - x0 > 10_000 {
            return (sim.t_s() - t0) * 1e3;
        }
    }
    f64::NAN
}

/// Measures [`Timing`].
pub fn timing(seed: u64) -> Timing {
    let mut sim = system(OpticsConfig::default(), Calibration::Model, seed);
    let mut cycle = 0;
    let rest = sensing_cal::ik(0.0, 0.3).expect("reachable");
    hold_at(&mut sim, rest, 0.5, &mut cycle);
    let mut seen = std::collections::HashSet::new();
    let mut worst: f64 = 0.0;
    // The record published before the measurement starts is not timed.
    seen.insert(
        vme_map::OBJECTS
            .read(&mut sim.bus())
            .expect("whole")
            .0
            .beacons[3]
            .t_us,
    );
    let t_start = sim.t_s();
    while sim.t_s() - t_start < 1.0 {
        hold_at(&mut sim, rest, 50e-6, &mut cycle);
        let t = vme_map::OBJECTS.read(&mut sim.bus()).expect("whole").0;
        let b = t.beacons[3];
        if seen.insert(b.t_us) {
            // The board's clock counts from its first slot; the host polls every 50 us.
            let published_at_us = sim.t_s() * 1e6;
            let strobe_us = b.t_us as f64
                + sim
                    .sensing_clock_offset_us()
                    .expect("the sensing bench runs native");
            worst = worst.max(published_at_us - strobe_us);
        }
    }
    Timing {
        rate_hz: seen.len() as f64 / (sim.t_s() - t_start),
        publish_us: worst,
        step_thesis_ms: step_half_ms(0, seed),
        step_ours_ms: step_half_ms(opt::DEFAULT, seed),
    }
}

/// The sensing image on the emulated 68020 at 16.7 MHz with eight beacons in view.
#[derive(Clone, Copy, Debug)]
pub struct ImageRate {
    /// Strobe frames per second: each beacon's rate.
    pub frames_hz: f64,
    /// Average cycles from one slot to the next (at most the budget once the board keeps
    /// the strobe's pace: it then waits for the timer).
    pub slot_cycles: f64,
    /// Average cycles of a slot's work, without the wait ([`SlotMeter`]).
    pub busy_cycles: f64,
}

/// The arm's angles (micro-radians, absolute, elbow left) that put the tip at
/// `LIT_BEACONS[TIP]`, where [`lit_camera`] shows the tip's beacon.
fn resting_tip_urad() -> [i32; 2] {
    let [x, y] = LIT_BEACONS[vme_map::records::beacon_index::TIP];
    let (l1, l2) = (arm::geometry::L1_M, arm::geometry::L2_M);
    let r2 = x * x + y * y;
    let phi = y.atan2(x);
    let a = ((r2 + l1 * l1 - l2 * l2) / (2.0 * l1 * r2.sqrt())).acos();
    let t1 = phi + a;
    let (ex, ey) = (x - l1 * t1.cos(), y - l1 * t1.sin());
    [
        (t1 * 1e6).round() as i32,
        (ey.atan2(ex) * 1e6).round() as i32,
    ]
}

/// The host as a servo board holding the arm at rest with the tip at its lit beacon
/// (`resting_tip_urad`): one servo state record a call (call it every 0.25 ms).
#[derive(Debug)]
pub struct RestingServo {
    theta_urad: [i32; 2],
    loops: u32,
}

impl Default for RestingServo {
    fn default() -> Self {
        Self {
            theta_urad: resting_tip_urad(),
            loops: 0,
        }
    }
}

impl RestingServo {
    /// Publishes the next servo state.
    pub fn publish(&mut self, bus: &mut dyn vme_map::GlobalBus) {
        let theta = self.theta_urad;
        self.loops = self.loops.wrapping_add(1);
        let st = vme_map::records::ServoState {
            theta1_urad: theta[0],
            theta2_urad: theta[1],
            omega1_urad_s: 0,
            omega2_urad_s: 0,
            arrest1_urad: theta[0],
            arrest2_urad: theta[1],
            torque1_mnm: 0,
            torque2_mnm: 0,
            t_us: self.loops.wrapping_mul(250),
            loops: self.loops,
        };
        vme_map::SERVO_STATE.publish(bus, &st);
    }
}

/// Runs `sys` for `ms` emulated milliseconds in quarter-millisecond steps, publishing
/// `servo`'s next state before each step when there is one.
pub fn run_fed(sys: &mut crate::boot::System, ms: f64, mut servo: Option<&mut RestingServo>) {
    for _ in 0..(ms * 4.0).round() as u32 {
        if let Some(s) = servo.as_deref_mut() {
            s.publish(&mut sys.bus());
        }
        sys.run_cycles(crate::emu::CPU_HZ / 4000);
    }
}

/// Measures [`ImageRate`] over one emulated second, after 1.2 s of start-up (the table's
/// check done). With `servo`, the host publishes a servo state every 0.25 ms with the arm
/// resting where the tip's beacon is: the board then learns the drift from the tip once a
/// frame and corrects every beacon (the running system's steady state at rest); without,
/// no servo state: no learning, no correction.
pub fn image_rate(dir: &std::path::Path, servo: bool) -> Result<ImageRate, String> {
    let mut sys =
        crate::boot::System::power_up(dir, &[BoardId::Sensing]).map_err(|e| e.to_string())?;
    let (io, meter) = metered_lit_camera(1);
    sys.boards[0].io = io;
    let mut feed = servo.then(RestingServo::default);
    run_fed(&mut sys, 1200.0, feed.as_mut());
    let m0 = meter.get();
    // The object table's frame count and the board's heartbeat (one beat a strobe frame).
    let count = |sys: &mut crate::boot::System| -> Result<(u32, u32), String> {
        let frame = vme_map::OBJECTS
            .read(&mut sys.bus())
            .map_err(|_| "torn")?
            .0
            .frame;
        Ok((frame, sys.heartbeat(BoardId::Sensing)))
    };
    let (f0, h0) = count(&mut sys)?;
    run_fed(&mut sys, 1000.0, feed.as_mut());
    let (f1, h1) = count(&mut sys)?;
    let m1 = meter.get();
    let slots = crate::boot::passes_per_beat(BoardId::Sensing) as f64 * h1.wrapping_sub(h0) as f64;
    Ok(ImageRate {
        frames_hz: f1.wrapping_sub(f0) as f64,
        slot_cycles: crate::emu::CPU_HZ as f64 / slots.max(1.0),
        busy_cycles: (m1.0 - m0.0) as f64 / (m1.1 - m0.1).max(1) as f64,
    })
}

/// Runs the bench's cases in parallel (one thread per case), the timing and the image
/// rate; prints the table and writes the pictures to `out`.
pub fn report(out: &std::path::Path, size: Size, seed: u64) -> Result<String, String> {
    use std::fmt::Write;
    let cases = cases();
    let results: Vec<Result<CaseResult, String>> = std::thread::scope(|s| {
        let hs: Vec<_> = cases
            .iter()
            .map(|c| s.spawn(move || run_case(c, size.plan, size.survey_points, seed)))
            .collect();
        hs.into_iter()
            .map(|h| h.join().unwrap_or_else(|_| Err("a case panicked".into())))
            .collect()
    });
    let mut r = String::new();
    let _ = writeln!(
        r,
        "bench sensing: seed {seed}, scan every {} grid point(s) ({} frames a point), {} survey points a case",
        size.plan.stride, size.plan.frames, size.survey_points
    );
    let _ = writeln!(
        r,
        "{:<48} {:>8} {:>8} {:>8} {:>8} {:>8} {:>9}",
        "case", "rms mm", "p95 mm", "max mm", "samples", "invalid", "scan s"
    );
    let mut all = Vec::new();
    for res in results {
        let c = res?;
        let e = &c.errors;
        let _ = writeln!(
            r,
            "{:<48} {:>8.2} {:>8.2} {:>8.2} {:>8} {:>8} {:>9.0}",
            c.case.name, e.rms_mm, e.p95_mm, e.max_mm, e.samples, e.invalid, c.scan.seconds
        );
        all.push(c);
    }
    let ours = all
        .iter()
        .find(|c| c.case.options == opt::DEFAULT && c.case.warmth > 0.0);
    if let Some(c) = ours {
        let ok = c.errors.rms_mm <= 1.5 && c.errors.max_mm <= 4.0;
        let verdict = if size.plan.stride != 1 {
            "not judged (a coarse scan interpolated: run without --quick)"
        } else if ok {
            "met"
        } else {
            "MISSED"
        };
        let _ = writeln!(
            r,
            "target (drift + intensity on): rms <= 1.5 mm, max <= 4 mm: {verdict}"
        );
    }
    let t = timing(seed);
    let _ = writeln!(
        r,
        "native: {:.1} positions/s per beacon (target 500), strobe to publication <= {:.0} us, \
         a 20 mm step half shown after {:.1} ms (thesis filter) / {:.1} ms (ours)",
        t.rate_hz, t.publish_us, t.step_thesis_ms, t.step_ours_ms
    );
    let dir = crate::boot::default_images_dir();
    match image_rate(&dir, false).and_then(|a| Ok((a, image_rate(&dir, true)?))) {
        Ok((a, b)) => {
            for (m, case) in [
                (a, "no servo state (no drift learnt or corrected)"),
                (
                    b,
                    "the arm resting, the drift learnt from the tip and corrected",
                ),
            ] {
                let hz = m.frames_hz;
                let _ = writeln!(
                    r,
                    "image (emulated 68020 at 16.7 MHz, timing: {}), {case}: {hz:.0} frames/s = {hz:.0} Hz per beacon (target 500: {}), {:.0} cycles a slot (budget 4175), of them busy {:.0} ({:.1}%: the rest waits for the timer)",
                    crate::emu::timing_name(),
                    if hz >= 499.0 { "met" } else { "MISSED" },
                    m.slot_cycles,
                    m.busy_cycles,
                    100.0 * m.busy_cycles / m.slot_cycles,
                );
            }
        }
        Err(e) => {
            let _ = writeln!(
                r,
                "image: not measured ({e}; build it with cargo xtask images)"
            );
        }
    }
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let png = out.join("sensing-errors.png");
    crate::plots::sensing_errors(&png, &all)?;
    let _ = writeln!(r, "wrote {}", png.display());
    Ok(r)
}

/// Where [`lit_camera`] puts the eight beacons (m).
pub const LIT_BEACONS: [[f64; 2]; 8] = [
    [-0.2, -0.2],
    [0.1, -0.25],
    [0.3, 0.0],
    [0.0, 0.0],
    [-0.3, 0.3],
    [0.2, 0.25],
    [-0.1, 0.15],
    [0.25, -0.05],
];

/// A sensing board's private I/O with a meter of the image's busy time: each main-loop pass
/// that lit a beacon (wrote `LED_SELECT`) counts as a slot, busy from its timer read to the
/// next pass's. Passes that only read the timer and return (the board is early: waiting
/// for the slot's grid point) are idle. What the rate alone cannot show once the board
/// keeps the strobe's 250 us: the margin left in the slot.
pub struct SlotMeter<D> {
    inner: D,
    /// Busy cycles and slots counted so far (shared with the caller).
    pub stats: std::sync::Arc<crate::emu::BusyStats>,
    last_timer_read: Option<u64>,
    lit: bool,
}

impl<D: crate::emu::Device> SlotMeter<D> {
    /// Meters `inner`.
    pub fn new(inner: D) -> Self {
        Self {
            inner,
            stats: Default::default(),
            last_timer_read: None,
            lit: false,
        }
    }
}

impl<D: crate::emu::Device> crate::emu::Device for SlotMeter<D> {
    fn read16(&mut self, off: u32, now: u64) -> Option<u16> {
        if off == regs::sensing::TIMER {
            if let (Some(t), true) = (self.last_timer_read, self.lit) {
                self.stats.add(now - t);
            }
            self.last_timer_read = Some(now);
            self.lit = false;
        }
        self.inner.read16(off, now)
    }
    fn write16(&mut self, off: u32, val: u16, now: u64) -> bool {
        self.lit |= off == regs::sensing::LED_SELECT;
        self.inner.write16(off, val, now)
    }
}

/// [`lit_camera`] behind a [`SlotMeter`]: the device and its counts.
pub fn metered_lit_camera(
    seed: u64,
) -> (
    Box<dyn crate::emu::Device>,
    std::sync::Arc<crate::emu::BusyStats>,
) {
    let m = SlotMeter::new(lit_camera(seed));
    let stats = m.stats.clone();
    (Box::new(m), stats)
}

/// The sensing board's private I/O with the default optical model and all eight beacons
/// resting in view at [`LIT_BEACONS`] (for image-mode measurements of the board alone).
pub fn lit_camera(seed: u64) -> Box<dyn crate::emu::Device> {
    let mut cam = crate::optics::Camera::new(OpticsConfig::default(), seed);
    for (b, p) in LIT_BEACONS.iter().enumerate() {
        cam.beacons[b] = Some((p[0], p[1]));
    }
    Box::new(crate::devices::SensingIo::new(cam))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emu::{Device, NullDevice};
    use regs::sensing::{ADC_X, LED_SELECT, TIMER};

    /// The resting arm of the image-rate measurement holds the tip's beacon where the lit
    /// camera shows it (so the board's drift reference learns from it).
    #[test]
    fn the_resting_arm_puts_the_tip_at_its_lit_beacon() {
        let t = resting_tip_urad();
        let (x, y) = arm::geometry::tip(t[0] as f64 * 1e-6, t[1] as f64 * 1e-6);
        let [bx, by] = LIT_BEACONS[vme_map::records::beacon_index::TIP];
        assert!((x - bx).abs() < 1e-5 && (y - by).abs() < 1e-5, "{x} {y}");
    }

    /// Passes that lit a beacon count from their timer read to the next pass's; passes that
    /// only read the timer (waiting for the grid point) count nothing.
    #[test]
    fn the_slot_meter_counts_only_the_passes_that_strobe() {
        let mut m = SlotMeter::new(NullDevice);
        let stats = m.stats.clone();
        // A slot's pass at 100: reads, strobes, works until 4100.
        m.read16(TIMER, 100);
        m.read16(ADC_X, 150);
        m.write16(LED_SELECT, 3, 200);
        // Two idle polls, then the next slot's pass at 4300, busy until 8000.
        m.read16(TIMER, 4100);
        m.read16(TIMER, 4200);
        m.read16(TIMER, 4300);
        m.write16(LED_SELECT, 4, 4350);
        m.read16(TIMER, 8000);
        assert_eq!(stats.get(), (4000 + 3700, 2));
    }
}
