//! The sensing board's calibration table on the host side (thesis ch. II.3.3, lines
//! ~440-446): the scan's data (signals against true positions on the 36 x 36, 2 cm grid),
//! its numerical inversion to true positions against signals, and the table's words in
//! global RAM (format: `vme_map::records::cal`, documented in docs/sensing.md).
//!
//! [`calibrate`] is the thesis's procedure on the simulated robot: the host plays the reflex
//! board, servoes the arm's tip to each grid point in a boustrophedon, waits for it to rest
//! and for the sensing board's filter to fill, and records the tip beacon's raw signals and
//! the tip position from the encoders. [`model_scan`] is the same data from the optical model
//! without noise (the simulator's default table, so a scenario need not run the procedure).

use crate::optics::Camera;
use crate::sim::Sim;
use vme_map::records::{beacon_index, cal, ReflexSubgoal, ServoState};
use vme_map::{ArrayBus, GlobalBus};

/// Points per side of the scan.
pub const N: usize = cal::FWD_N as usize;
/// Grid pitch (thesis: 2 cm).
pub const PITCH_M: f64 = 0.02;
/// First grid coordinate: the 0.7 m square is centred under the lens, on the arm's base.
pub const ORIGIN_M: f64 = -0.35;
/// Q5 codes per volt of a converter input.
pub const Q5_PER_V: f64 = 32.0 / crate::devices::ADC_V_PER_CODE;

/// A scan: the signals (Q5 codes about mid-scale) at each grid point, row by row (y outer).
#[derive(Clone, Debug, PartialEq)]
pub struct Scan {
    /// Sum level the LED current feedback held during the scan, codes (0: fixed current).
    pub s_ref_codes: u32,
    /// Signals at grid point (i, j) at index j * N + i.
    pub signals_q5: Vec<[f64; 2]>,
    /// True positions (m) the signals were recorded at (the grid point or, for a real scan,
    /// where the encoders put the tip).
    pub truth_m: Vec<[f64; 2]>,
}

/// Grid point (i, j), metres.
pub fn grid_m(i: usize, j: usize) -> [f64; 2] {
    [ORIGIN_M + PITCH_M * i as f64, ORIGIN_M + PITCH_M * j as f64]
}

/// The noise-free scan of the optical model at warmth 0 with the LED current feedback
/// holding the firmware's default sum level.
pub fn model_scan(camera: &Camera) -> Scan {
    let s_ref_codes = sensing::DEFAULT_S_REF_CODES as u32;
    let s_ref_v = s_ref_codes as f64 * crate::devices::ADC_V_PER_CODE;
    // The light that makes the measured sum equal the reference.
    let zero = camera.sum_v(0.0, 0.0);
    let s_led = s_ref_v - zero;
    let mut signals_q5 = Vec::with_capacity(N * N);
    let mut truth_m = Vec::with_capacity(N * N);
    for j in 0..N {
        for i in 0..N {
            let [x, y] = grid_m(i, j);
            let (xv, yv) = camera.divided(x, y, s_led, 0.0);
            // The converters truncate: the mean code of a noisy signal is half a code low.
            signals_q5.push([xv * Q5_PER_V - 16.0, yv * Q5_PER_V - 16.0]);
            truth_m.push([x, y]);
        }
    }
    Scan {
        s_ref_codes,
        signals_q5,
        truth_m,
    }
}

/// The table of the noise-free model scan.
pub fn model_table(camera: &Camera) -> Vec<u32> {
    build_table(&model_scan(camera))
}

/// Bilinear interpolation of the forward grid at fractional grid coordinates (u, v),
/// extrapolating linearly beyond the edges; with the Jacobian d(signal)/d(u, v).
fn forward(sig: &[[f64; 2]], u: f64, v: f64) -> ([f64; 2], [[f64; 2]; 2]) {
    let i = (u.floor() as isize).clamp(0, N as isize - 2) as usize;
    let j = (v.floor() as isize).clamp(0, N as isize - 2) as usize;
    let (fu, fv) = (u - i as f64, v - j as f64);
    let p = |a: usize, b: usize| sig[b * N + a];
    let (s00, s10, s01, s11) = (p(i, j), p(i + 1, j), p(i, j + 1), p(i + 1, j + 1));
    let mut f = [0.0; 2];
    let mut jac = [[0.0; 2]; 2];
    for k in 0..2 {
        f[k] = s00[k] * (1.0 - fu) * (1.0 - fv)
            + s10[k] * fu * (1.0 - fv)
            + s01[k] * (1.0 - fu) * fv
            + s11[k] * fu * fv;
        jac[k][0] = (s10[k] - s00[k]) * (1.0 - fv) + (s11[k] - s01[k]) * fv;
        jac[k][1] = (s01[k] - s00[k]) * (1.0 - fu) + (s11[k] - s10[k]) * fu;
    }
    (f, jac)
}

/// The grid coordinates (u, v) where the interpolated forward map gives signals `c`
/// (Newton's method from the grid point whose signals are nearest), and the remaining error
/// in Q5 codes.
pub fn invert(scan: &Scan, c: [f64; 2]) -> ([f64; 2], f64) {
    let sig = &scan.signals_q5;
    let nearest = (0..N * N)
        .min_by(|&a, &b| {
            let d = |k: usize| (sig[k][0] - c[0]).hypot(sig[k][1] - c[1]);
            d(a).total_cmp(&d(b))
        })
        .expect("a scan has points");
    newton(scan, c, [(nearest % N) as f64, (nearest / N) as f64])
}

/// Newton's method for [`invert`] from grid coordinates `start`.
fn newton(scan: &Scan, c: [f64; 2], start: [f64; 2]) -> ([f64; 2], f64) {
    let sig = &scan.signals_q5;
    let [mut u, mut v] = start;
    let mut err = f64::INFINITY;
    for _ in 0..60 {
        let (f, j) = forward(sig, u, v);
        let (r0, r1) = (f[0] - c[0], f[1] - c[1]);
        err = r0.hypot(r1);
        if err < 1e-6 {
            break;
        }
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        if det.abs() < 1e-12 {
            break;
        }
        let du = (j[1][1] * r0 - j[0][1] * r1) / det;
        let dv = (-j[1][0] * r0 + j[0][0] * r1) / det;
        // Damped: never more than 8 cells a step.
        let s = (8.0 / du.hypot(dv)).min(1.0);
        u -= du * s;
        v -= dv * s;
    }
    ([u, v], err)
}

/// The table's words for a scan (generation and checksum filled in by [`write_table`]).
pub fn build_table(scan: &Scan) -> Vec<u32> {
    assert_eq!(scan.signals_q5.len(), N * N, "a scan has {} points", N * N);
    let mut w = vec![0u32; cal::WORDS as usize];
    let um = |m: f64| (m * 1e6).round() as i32 as u32;
    w[cal::W_MAGIC as usize] = cal::MAGIC;
    w[cal::W_VERSION as usize] = cal::VERSION;
    w[cal::W_WORDS as usize] = cal::WORDS;
    w[cal::W_S_REF as usize] = scan.s_ref_codes;
    w[cal::W_FWD_N as usize] = cal::FWD_N;
    w[cal::W_FWD_X0 as usize] = um(ORIGIN_M);
    w[cal::W_FWD_Y0 as usize] = um(ORIGIN_M);
    w[cal::W_FWD_PITCH as usize] = um(PITCH_M);
    w[cal::W_INV_N as usize] = cal::INV_N;
    let far = ORIGIN_M + PITCH_M * (N - 1) as f64;
    for (k, v) in [ORIGIN_M, far, ORIGIN_M, far].into_iter().enumerate() {
        w[(cal::W_AREA + k as u32) as usize] = um(v);
    }
    for (k, s) in scan.signals_q5.iter().enumerate() {
        w[cal::FWD as usize + 2 * k] = s[0].round() as i32 as u32;
        w[cal::FWD as usize + 2 * k + 1] = s[1].round() as i32 as u32;
    }
    // The scan's true positions need not be the grid's (a real arm stops within a count or
    // two): the inverse maps to grid coordinates, then to positions through the recorded
    // truths.
    let n = cal::INV_N as usize;
    let mut prev: Option<[f64; 2]> = None;
    for j in 0..n {
        for i in 0..n {
            let c = [
                ((i as f64) * 64.0 - 2048.0) * 32.0,
                ((j as f64) * 64.0 - 2048.0) * 32.0,
            ];
            // From the nearest scanned signal; from the neighbouring node's solution where
            // that does not converge. (Neighbour-first found, for the thesis firmware's
            // full scan, a second solution where the linear extrapolations beyond the grid's
            // edges fold over the scanned area: interior nodes 0.9 m wrong.)
            let near = invert(scan, c);
            let from_prev = prev.filter(|_| near.1 >= 1e-3).map(|p| newton(scan, c, p));
            let ([u, v], _) = match from_prev {
                Some((uv, e)) if e < near.1 => (uv, e),
                _ => near,
            };
            prev = Some([u, v]);
            let p = truth_at(scan, u, v);
            let lim = cal::MAX_NODE_UM as f64;
            let k = cal::INV as usize + 2 * (j * n + i);
            w[k] = (p[0] * 1e6).clamp(-lim, lim).round() as i32 as u32;
            w[k + 1] = (p[1] * 1e6).clamp(-lim, lim).round() as i32 as u32;
        }
    }
    w
}

/// The true position at fractional grid coordinates, interpolating the recorded truths
/// (linear beyond the edges).
fn truth_at(scan: &Scan, u: f64, v: f64) -> [f64; 2] {
    forward(&scan.truth_m, u, v).0
}

/// Writes `table` into global RAM with generation `generation` and its checksum: the
/// magic word last, so a board never checks a half-written table as whole.
pub fn write_table(bus: &mut dyn GlobalBus, table: &[u32], generation: u32) {
    let mut w = table.to_vec();
    w[cal::W_GENERATION as usize] = generation;
    w[cal::W_CHECKSUM as usize] = sensing::cal::checksum(&w);
    bus.write_u32(vme_map::SENSING_CAL, 0);
    for (i, &x) in w.iter().enumerate().skip(1) {
        bus.write_u32(vme_map::SENSING_CAL + 4 * i as u32, x);
    }
    bus.write_u32(vme_map::SENSING_CAL, w[0]);
}

/// Joint angles (absolute, rad) that put the tip at (`x`, `y`), elbow to the left of the
/// line from the base (the branch the scan keeps throughout).
pub fn ik(x: f64, y: f64) -> Option<[f64; 2]> {
    let (l1, l2) = (arm::geometry::L1_M, arm::geometry::L2_M);
    let r = x.hypot(y);
    if r > l1 + l2 || r < (l1 - l2).abs() {
        return None;
    }
    let phi = y.atan2(x);
    let a = ((l1 * l1 + r * r - l2 * l2) / (2.0 * l1 * r))
        .clamp(-1.0, 1.0)
        .acos();
    let t1 = phi + a;
    let (ex, ey) = arm::geometry::elbow(t1);
    let t2 = (y - ey).atan2(x - ex);
    Some([t1, t2])
}

/// How the scan runs.
#[derive(Clone, Copy, Debug)]
pub struct ScanPlan {
    /// Take every `stride`-th grid point per axis and fill between them by interpolation
    /// (1 = the thesis's full 1296-point scan; tests use coarser ones).
    pub stride: usize,
    /// Samples of the tip's filtered signal averaged at each point, after the filter has
    /// filled with resting samples.
    pub frames: usize,
}

impl Default for ScanPlan {
    fn default() -> Self {
        Self {
            stride: 1,
            frames: 256,
        }
    }
}

/// What the scan cost.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScanStats {
    /// Grid points visited.
    pub points: usize,
    /// Simulated seconds.
    pub seconds: f64,
    /// Largest distance between a grid point and where the encoders put the tip, m.
    pub worst_stop_m: f64,
}

/// The host as the reflex board: runs plant steps for `seconds`, publishing the subgoal
/// `goal` (absolute joint angles, rad) every millisecond so the servo finds it fresh.
/// `cycle` is the subgoal's counter, kept by the caller across calls.
pub fn hold_at(sim: &mut Sim, goal: [f64; 2], seconds: f64, cycle: &mut u32) {
    let steps = (seconds / sim.cfg.dt_s).round() as usize;
    for k in 0..steps {
        if k % 20 == 0 {
            *cycle += 1;
            let rec = ReflexSubgoal {
                goal1_urad: (goal[0] * 1e6).round() as i32,
                goal2_urad: (goal[1] * 1e6).round() as i32,
                flags: 0,
                cycle: *cycle,
            };
            vme_map::REFLEX_SUBGOAL.publish(&mut sim.bus(), &rec);
        }
        sim.step();
    }
}

/// The servo's published state.
fn servo(sim: &mut Sim) -> Option<ServoState> {
    vme_map::SERVO_STATE.read(&mut sim.bus()).ok().map(|r| r.0)
}

/// The thesis's calibration scan on the running simulation `sim` (which must run the
/// sensing and servo boards). Returns the scan and its cost. Fails if the arm does not
/// settle at a point within 2 s.
pub fn calibrate(sim: &mut Sim, plan: ScanPlan) -> Result<(Scan, ScanStats), String> {
    let t0 = sim.t_s();
    let mut cycle = 0u32;
    let idx: Vec<usize> = {
        let mut v: Vec<usize> = (0..N).step_by(plan.stride).collect();
        if *v.last().expect("at least one point") != N - 1 {
            v.push(N - 1);
        }
        v
    };
    let mut measured = vec![None::<Visit>; N * N];
    let mut worst_stop_m = 0.0f64;
    let mut points = 0;
    for (row, &j) in idx.iter().enumerate() {
        let cols: Vec<usize> = if row % 2 == 0 {
            idx.clone()
        } else {
            idx.iter().rev().copied().collect()
        };
        for &i in &cols {
            let [x, y] = grid_m(i, j);
            let goal =
                ik(x, y).ok_or_else(|| format!("grid point ({x:.3}, {y:.3}) m is out of reach"))?;
            // Move and settle: near the goal and at rest. The truth is what the encoders say
            // (as in the thesis), so the stop need not be exact: within 50 counts (friction
            // can hold a link some counts off; the table uses the encoders' position).
            let count_rad = [arm::LINK1.rad_per_count(), arm::LINK2.rad_per_count()];
            let mut settled = false;
            let mut last = [f64::NAN; 2];
            for _ in 0..200 {
                hold_at(sim, goal, 0.01, &mut cycle);
                let s = servo(sim).ok_or("the servo publishes no state")?;
                let th = [s.theta1_urad as f64 * 1e-6, s.theta2_urad as f64 * 1e-6];
                let near = (th[0] - goal[0]).abs() < 50.0 * count_rad[0]
                    && (th[1] - goal[1]).abs() < 50.0 * count_rad[1];
                // At rest: the encoders moved under 2 counts in the last 10 ms.
                let still = (th[0] - last[0]).abs() < 2.0 * count_rad[0]
                    && (th[1] - last[1]).abs() < 2.0 * count_rad[1];
                last = th;
                if near && still {
                    settled = true;
                    break;
                }
            }
            if !settled {
                let s = servo(sim).ok_or("the servo publishes no state")?;
                return Err(format!(
                    "the arm did not settle at ({x:.3}, {y:.3}) m within 2 s: angles ({:.4}, {:.4}) rad for ({:.4}, {:.4}), speeds ({:.4}, {:.4}) rad/s",
                    s.theta1_urad as f64 * 1e-6,
                    s.theta2_urad as f64 * 1e-6,
                    goal[0],
                    goal[1],
                    s.omega1_urad_s as f64 * 1e-6,
                    s.omega2_urad_s as f64 * 1e-6
                ));
            }
            // Let the filter fill with resting samples, then average its output.
            hold_at(
                sim,
                goal,
                sensing::filter::LONG as f64 * 0.002 + 0.01,
                &mut cycle,
            );
            let mut acc = [0.0; 2];
            let mut truth = [0.0; 2];
            for _ in 0..plan.frames {
                hold_at(sim, goal, 0.002, &mut cycle);
                let raw = vme_map::SENSING_RAW
                    .read(&mut sim.bus())
                    .map_err(|_| "the raw table is torn")?
                    .0;
                let b = raw.beacons[beacon_index::TIP];
                acc[0] += b.x_q5 as f64;
                acc[1] += b.y_q5 as f64;
                let s = servo(sim).ok_or("the servo publishes no state")?;
                let (tx, ty) =
                    arm::geometry::tip(s.theta1_urad as f64 * 1e-6, s.theta2_urad as f64 * 1e-6);
                truth[0] += tx;
                truth[1] += ty;
            }
            let f = plan.frames as f64;
            let t = [truth[0] / f, truth[1] / f];
            worst_stop_m = worst_stop_m.max((t[0] - x).hypot(t[1] - y));
            measured[j * N + i] = Some(([acc[0] / f, acc[1] / f], t));
            points += 1;
        }
    }
    // Coarse plans: fill the skipped points by bilinear interpolation between visited ones.
    let mut signals_q5 = vec![[0.0; 2]; N * N];
    let mut truth_m = vec![[0.0; 2]; N * N];
    for j in 0..N {
        for i in 0..N {
            let (ia, ib, fi) = bracket(&idx, i);
            let (ja, jb, fj) = bracket(&idx, j);
            let g = |a: usize, b: usize| measured[b * N + a].expect("visited");
            let mix = |k: usize, which: fn(&Visit) -> [f64; 2]| {
                let v00 = which(&g(ia, ja))[k];
                let v10 = which(&g(ib, ja))[k];
                let v01 = which(&g(ia, jb))[k];
                let v11 = which(&g(ib, jb))[k];
                (v00 * (1.0 - fi) + v10 * fi) * (1.0 - fj) + (v01 * (1.0 - fi) + v11 * fi) * fj
            };
            signals_q5[j * N + i] = [mix(0, |m| m.0), mix(1, |m| m.0)];
            truth_m[j * N + i] = [mix(0, |m| m.1), mix(1, |m| m.1)];
        }
    }
    let cfg = vme_map::SENSING_CONFIG.read(&mut sim.bus()).ok();
    let s_ref_codes = match cfg {
        Some((c, seq)) if seq != 0 => sensing::Config::from_record(&c),
        _ => sensing::Config::default(),
    };
    let s_ref = if s_ref_codes.options & vme_map::records::sensing_options::CURRENT_FEEDBACK != 0 {
        s_ref_codes.s_ref_codes as u32
    } else {
        0
    };
    Ok((
        Scan {
            s_ref_codes: s_ref,
            signals_q5,
            truth_m,
        },
        ScanStats {
            points,
            seconds: sim.t_s() - t0,
            worst_stop_m,
        },
    ))
}

/// What the scan recorded at a grid point: signals (Q5) and true position (m).
type Visit = ([f64; 2], [f64; 2]);

/// The visited indices around `i` and the fraction between them.
fn bracket(idx: &[usize], i: usize) -> (usize, usize, f64) {
    let k = idx.iter().rposition(|&a| a <= i).expect("0 is visited");
    if idx[k] == i || k + 1 == idx.len() {
        return (idx[k], idx[k], 0.0);
    }
    let (a, b) = (idx[k], idx[k + 1]);
    (a, b, (i - a) as f64 / (b - a) as f64)
}

/// Reads the whole table back from global RAM (for tests and the bench).
pub fn read_table(bus: &mut ArrayBus) -> Vec<u32> {
    (0..cal::WORDS)
        .map(|i| bus.read_u32(vme_map::SENSING_CAL + 4 * i))
        .collect()
}
