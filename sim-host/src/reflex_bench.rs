//! `sim-host bench reflex` (issue 8): what the reflex costs.
//!
//! * The real reflex image on the emulated 68020 at 16.7 MHz, its whole main loop (records
//!   read, health checked, window tested, subgoal published) against global RAM the host
//!   keeps fresh (servo state, C-space heartbeat, object frames), in the cases of thesis
//!   ch. V section 7: at rest; after 42 ms of full acceleration of both links (fig. V.5,
//!   11.5 and 40.3 rad/s: the thesis's 214 pixels in 4.4 ms); at the thesis's expected top
//!   speeds (29 and 55 rad/s, arrest region 32 x 32 pixels: the 146 kHz it needed), held
//!   and with the angles advancing; among obstacles, static and with one redrawn every
//!   10 ms (the known columns read again); and escaping, with the map still (the escape
//!   keeps its plan) and with an obstacle redrawn every 10 ms (it plans again). Free space
//!   is the worst case for the window (thesis: the window is largest there). With `--top N`
//!   each case's N costliest functions follow it, with their cycles and calls a pass, and
//!   those of its longest pass alone (what a pass over the 1 ms deadline spends).
//! * A free 3 rad move of link 1 with the reflex against the servo alone in the same plant
//!   (native mode): the reflex must not slow the arm.

use crate::boot::{FunctionCycles, System};
use crate::sim::{Config, Sim};
use std::fmt::Write as _;
use std::path::Path;
use vme_map::records::{beacon_flags, Beacon, ObjectTable, ServoState};
use vme_map::{BoardId, BoardSlot, GlobalBus};

/// One image case.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageCase {
    /// What it shows.
    pub name: &'static str,
    /// Main-loop passes measured.
    pub passes: u64,
    /// Mean cycles per pass (heartbeat to heartbeat, each timed to the cycle).
    pub cycles_per_pass: f64,
    /// The longest pass, cycles.
    pub worst_cycles: u64,
    /// Passes longer than 1 ms (the 1 kHz subgoal rate's deadline missed).
    pub over_1ms: u64,
    /// Mean pixel words read per pass.
    pub tests_per_pass: f64,
    /// Mean pixels vouched for per pass without a read (columns whose generation has not
    /// moved since the reflex read them: `reflex::window::Known`).
    pub known_per_pass: f64,
    /// With a profile asked for: the `top` functions by the cycles spent in their own code
    /// over the measured passes (short names), costliest first, as cycles and calls per
    /// pass.
    pub top: Vec<(String, f64, f64)>,
    /// With a profile asked for: the `top` functions of the longest pass alone (cycles and
    /// calls in that pass), to see what a pass over the 1 ms deadline spends.
    pub worst_top: Vec<(String, f64, f64)>,
}

impl ImageCase {
    /// Subgoals per second at 16.7 MHz.
    pub fn rate_hz(&self) -> f64 {
        crate::emu::CPU_HZ as f64 / self.cycles_per_pass
    }
    /// Subgoals per second at 16.7 MHz were every pass as long as the longest.
    pub fn worst_rate_hz(&self) -> f64 {
        crate::emu::CPU_HZ as f64 / self.worst_cycles.max(1) as f64
    }
    /// Pixels checked per second at 16.7 MHz, read or vouched for (the thesis's 48,000
    /// tests, each a pixel read).
    pub fn pixels_per_s(&self) -> f64 {
        (self.tests_per_pass + self.known_per_pass) * self.rate_hz()
    }
    /// Pixel words read per second at 16.7 MHz.
    pub fn reads_per_s(&self) -> f64 {
        self.tests_per_pass * self.rate_hz()
    }
}

/// The servo state of an arm at `theta` turning at `omega` (rad, rad/s), its arrest point
/// from the reflex's own braking model.
fn servo_state(theta: [f64; 2], omega: [f64; 2], t_us: u32, loops: u32) -> ServoState {
    let acc = [
        arm::LINK1.max_accel_rad_s2() * 0.96 / 1.25,
        arm::LINK2.max_accel_rad_s2() * 0.96 / 1.25,
    ];
    let a = |i: usize| theta[i] + omega[i] * omega[i].abs() / (2.0 * acc[i]);
    let u = |x: f64| (x * 1e6).round() as i32;
    ServoState {
        theta1_urad: u(theta[0]),
        theta2_urad: u(theta[1]),
        omega1_urad_s: u(omega[0]),
        omega2_urad_s: u(omega[1]),
        arrest1_urad: u(a(0)),
        arrest2_urad: u(a(1)),
        t_us,
        loops,
        ..Default::default()
    }
}

/// What the host keeps writing for the reflex image while a case runs: the servo state of
/// an arm held at `theta` turning at `omega`, the object table with a new frame, the
/// C-space board's heartbeat.
pub struct Feed {
    theta: [f64; 2],
    omega: [f64; 2],
    table: ObjectTable,
    k: u32,
}

impl Feed {
    /// The free-space case at rest, with the wand far from the arm (what `sim-host profile
    /// reflex` runs).
    pub fn at_rest() -> Self {
        let mut table = ObjectTable::default();
        table.beacons[vme_map::records::beacon_index::WAND] = Beacon {
            x_um: -300_000,
            y_um: 200_000,
            t_us: 0,
            flags: beacon_flags::VALID,
        };
        Feed {
            theta: [0.3, 0.4],
            omega: [0.0; 2],
            table,
            k: 0,
        }
    }

    /// One 0.25 ms update.
    pub fn apply(&mut self, g: &mut dyn GlobalBus) {
        let k = self.k;
        self.k += 1;
        let s = servo_state(self.theta, self.omega, k * 250, 1 + k);
        vme_map::SERVO_STATE.publish(g, &s);
        self.table.frame = k;
        vme_map::OBJECTS.publish(g, &self.table);
        g.write_u32(BoardSlot::of(BoardId::Cspace0).heartbeat(), 1 + k);
    }
}

/// What a case holds the reflex image's inputs at.
struct Spec {
    name: &'static str,
    /// Link angles, rad.
    theta: [f64; 2],
    /// Link speeds, rad/s.
    omega: [f64; 2],
    /// Obstacle disks (x, y, r in mm) drawn in the map.
    disks: &'static [(i32, i32, i32)],
    /// The sensing board flags the obstacles moving.
    moving: bool,
    /// The arm really moves: its angles advance at `omega` between the host's updates
    /// (otherwise every pass sees the same state).
    advance: bool,
    /// Every this many ms one of the obstacles is moved 1 mm (back and forth, in turn) as a
    /// C-space job moves it (`cspace::worklist::move_disk`), raising the generations of
    /// the columns whose marks changed (0: the map never changes).
    redraw_ms: u32,
}

/// Runs the reflex image for `ms` with the arm at `c.theta` turning at `c.omega` (held
/// there: each pass sees the same state, as the case is defined), `c`'s obstacles in the map
/// and the wand at `wand` (mm).
fn image_case(
    dir: &Path,
    c: &Spec,
    wand: (i32, i32),
    ms: f64,
    top: usize,
) -> Result<ImageCase, String> {
    let Spec {
        name,
        theta,
        omega,
        disks,
        moving,
        advance,
        redraw_ms,
    } = *c;
    let mut sys = System::power_up(dir, &[BoardId::Reflex]).map_err(|e| e.to_string())?;
    // Over every measured pass, and over the current pass.
    let mut per = if top > 0 {
        let image =
            crate::image::Image::load(&dir.join("reflex.elf")).map_err(|e| e.to_string())?;
        Some((FunctionCycles::new(&image), FunctionCycles::new(&image)))
    } else {
        None
    };
    let mut table = ObjectTable::default();
    {
        let mut g = sys.bus();
        for (i, &(x, y, r)) in disks.iter().enumerate() {
            crate::cspace_oracle::draw_disks_mm(&mut g, &[(x, y, r)])
                .map_err(|e| format!("{e:?}"))?;
            let b = cspace::worklist::OBSTACLE_BEACONS[i] as usize;
            table.beacons[b] = Beacon {
                x_um: x * 1000,
                y_um: y * 1000,
                t_us: 0,
                flags: beacon_flags::VALID
                    | (beacon_flags::MOVING & (moving as u32).wrapping_neg()),
            };
            // The entry as a C-space board leaves it after drawing the obstacle.
            let base = vme_map::layout::work_entry(i as u32);
            g.write_u32(base + 4, b as u32);
            g.write_u32(base + 8, (x * 1000) as u32);
            g.write_u32(base + 12, (y * 1000) as u32);
            g.write_u32(base + 16, (r * 1000) as u32);
            g.write_u32(base + 20, cspace::worklist::DRAWN | (1 << 8));
            g.write_u32(
                vme_map::layout::OBSTACLE_RADII + 4 * i as u32,
                (r * 1000) as u32,
            );
        }
        table.beacons[vme_map::records::beacon_index::WAND] = Beacon {
            x_um: wand.0 * 1000,
            y_um: wand.1 * 1000,
            t_us: 0,
            flags: beacon_flags::VALID,
        };
    }
    let step_ms = 0.25;
    let steps = (ms / step_ms) as u32;
    let (mut tests_sum, mut known_sum, mut samples) = (0f64, 0f64, 0u64);
    let redraw_every = (redraw_ms as f64 / step_ms) as u32;
    // A C-space board's working memory for the redraws.
    let mut job = Box::new(cspace::worklist::Scratch::new());
    let mut redraws = 0u32;
    // The longest whole pass's costliest functions (the first timed pass began before the
    // profile did).
    let mut worst_top = Vec::new();
    // Whether the passes are being timed yet (from the end of the warm-up).
    let mut timing = false;
    let mut feed = Feed {
        theta,
        omega,
        table,
        k: 0,
    };
    for k in 0..steps {
        if advance {
            for (th, w) in feed.theta.iter_mut().zip(omega) {
                *th = (*th + w * step_ms * 1e-3).rem_euclid(2.0 * std::f64::consts::PI);
            }
        }
        if redraw_every > 0 && k % redraw_every == redraw_every - 1 {
            // Obstacle `redraws % n` moves 1 mm along x, out on even turns and back on odd.
            let n = disks.len() as u32;
            let (i, turn) = ((redraws % n) as usize, redraws / n);
            let (x, y, r) = disks[i];
            let (from, to) = if turn % 2 == 0 {
                (x, x + 1)
            } else {
                (x + 1, x)
            };
            let disk = |x: i32| cspace::Disk {
                x_um: x * 1000,
                y_um: y * 1000,
                r_um: r * 1000,
            };
            // As a C-space job moves it (`worklist::move_disk`: new before old, thesis lines
            // 1199-1210, by the images' differences), raising the generations of the
            // columns whose marks changed.
            let mut g = sys.bus();
            match cspace::worklist::move_disk(&mut g, &disk(from), &disk(to), &mut job) {
                Ok((_, None)) => {}
                other => return Err(format!("{name}: the redraw failed: {other:?}")),
            }
            redraws += 1;
        }
        feed.apply(&mut sys.bus());
        match per.as_mut().filter(|_| timing) {
            // One instruction at a time, each charged to its function (the same cycles).
            Some((per, pass)) => {
                let end = sys.now + (step_ms * crate::emu::CPU_HZ as f64 / 1000.0) as u64;
                let b = &mut sys.boards[0];
                while b.cycles < end && b.state == crate::emu::RunState::Running {
                    let pc = b.cpu.pc;
                    let (periods, max) = (b.beats.periods, b.beats.max_cycles);
                    let c = b.step(&mut sys.global);
                    per.charge(pc, c);
                    pass.charge(pc, c);
                    if b.beats.periods != periods {
                        // A pass ended (its heartbeat written): the longest so far keeps
                        // its profile (the first, begun before the timing, is not whole).
                        if periods > 0 && b.beats.max_cycles != max {
                            worst_top = pass.costliest(top, 1.0);
                        }
                        pass.clear();
                    }
                }
                sys.now = end;
            }
            None => sys.run_ms(step_ms),
        }
        // Measure after the reflex has had half a second to get going.
        if k as f64 * step_ms >= 500.0 {
            if !timing {
                // The passes are timed from here: each heartbeat write's cycle
                // (`emu::LoopStats`), not the host's 0.25 ms steps.
                let b = &mut sys.boards[0].beats;
                *b = crate::emu::LoopStats {
                    last_beat: b.last_beat,
                    ..Default::default()
                };
                timing = true;
            }
            if let Ok((st, _)) = vme_map::REFLEX_STATUS.read(&mut sys.bus()) {
                tests_sum += st.tests as f64;
                known_sum += st.known as f64;
                samples += 1;
            }
        }
    }
    if !timing {
        return Err("the case is shorter than its warm-up".into());
    }
    let beats = sys.boards[0].beats;
    let passes = beats.periods;
    if passes == 0 {
        return Err(format!("{name}: no whole pass in the measured time"));
    }
    let st = sys.status(BoardId::Reflex);
    if st.state() != Some(vme_map::BoardState::Running) {
        return Err(format!(
            "{name}: the reflex image is {:?} ({:?}, record {:x?}), not running",
            st.state(),
            st.fault(),
            sys.fault(BoardId::Reflex)
        ));
    }
    let flags = vme_map::REFLEX_SUBGOAL
        .read(&mut sys.bus())
        .map(|r| r.0.flags)
        .unwrap_or(0);
    if flags & (vme_map::records::reflex_flags::HOLD | vme_map::records::reflex_flags::WAITING) != 0
    {
        return Err(format!("{name}: the reflex holds (flags {flags:#x})"));
    }
    Ok(ImageCase {
        name,
        passes,
        cycles_per_pass: beats.sum_cycles as f64 / passes as f64,
        worst_cycles: beats.max_cycles,
        over_1ms: beats.over_1ms,
        tests_per_pass: tests_sum / samples.max(1) as f64,
        known_per_pass: known_sum / samples.max(1) as f64,
        top: per.map_or_else(Vec::new, |(per, _)| per.costliest(top, passes as f64)),
        worst_top,
    })
}

/// The obstacles (x, y, r in mm) of the cluttered case.
const CLUTTER: [(i32, i32, i32); 4] = [
    (300, 300, 30),
    (-200, 350, 25),
    (150, -380, 35),
    (-350, -150, 25),
];

/// The image cases (module docs), each with its `top` costliest functions when `top > 0`.
pub fn image_cases(dir: &Path, top: usize) -> Result<Vec<ImageCase>, String> {
    // (name, angles, speeds, obstacles)
    // The arm's tip on the first clutter disk's centre (inside its image: the escape
    // crosses marks) and 15 mm off its edge (within a moving obstacle's reach: the escape
    // floods the free pixels around).
    let tip_at = |x_mm: i32, y_mm: i32| {
        crate::sensing_cal::ik(x_mm as f64 * 1e-3, y_mm as f64 * 1e-3).expect("within reach")
    };
    let (cx, cy, cr) = CLUTTER[0];
    let still = [0.0, 0.0];
    let cases = [
        Spec {
            name: "at rest, free space",
            theta: [0.3, 0.4],
            omega: still,
            disks: &[],
            moving: false,
            advance: false,
            redraw_ms: 0,
        },
        Spec {
            name: "fig. V.5: 42 ms of full acceleration (11.5, 40.3 rad/s)",
            theta: [0.3, 0.4],
            omega: [11.5, 40.3],
            disks: &[],
            moving: false,
            advance: false,
            redraw_ms: 0,
        },
        Spec {
            name: "top speed (29, 55 rad/s): arrest region 32 x 32 pixels",
            theta: [0.3, 0.4],
            omega: [29.0, 55.0],
            disks: &[],
            moving: false,
            advance: false,
            redraw_ms: 0,
        },
        Spec {
            name: "top speed, the arm moving through free space",
            theta: [0.3, 0.4],
            omega: [29.0, 55.0],
            disks: &[],
            moving: false,
            advance: true,
            redraw_ms: 0,
        },
        Spec {
            name: "among 4 obstacles, moving (5, 10 rad/s)",
            theta: [2.0, -0.5],
            omega: [5.0, 10.0],
            disks: &CLUTTER,
            moving: false,
            advance: false,
            redraw_ms: 0,
        },
        Spec {
            name: "among 4 obstacles, one redrawn every 10 ms (5, 10 rad/s)",
            theta: [2.0, -0.5],
            omega: [5.0, 10.0],
            disks: &CLUTTER,
            moving: false,
            advance: false,
            redraw_ms: 10,
        },
        Spec {
            name: "escaping: the arm inside a moving obstacle, at rest",
            theta: tip_at(cx, cy),
            omega: still,
            disks: &CLUTTER,
            moving: true,
            advance: false,
            redraw_ms: 0,
        },
        Spec {
            name: "escaping, inside, one obstacle redrawn every 10 ms",
            theta: tip_at(cx, cy),
            omega: still,
            disks: &CLUTTER,
            moving: true,
            advance: false,
            redraw_ms: 10,
        },
        Spec {
            name: "escaping: the arm 15 mm off a moving obstacle, at rest",
            theta: tip_at(cx, cy + cr + 15),
            omega: still,
            disks: &CLUTTER,
            moving: true,
            advance: false,
            redraw_ms: 0,
        },
    ];
    cases
        .iter()
        .map(|c| image_case(dir, c, (-300, 200), 900.0, top))
        .collect()
}

/// Time for both links to come within 2 encoder counts of `goal` and stay (from `t0`).
fn settle_time(trace: &[(f64, [f64; 2])], goal: [f64; 2], t0: f64) -> Option<f64> {
    let tol = [
        2.0 * arm::LINK1.rad_per_count(),
        2.0 * arm::LINK2.rad_per_count(),
    ];
    let within = |th: &[f64; 2]| (0..2).all(|i| (th[i] - goal[i]).abs() <= tol[i]);
    let mut t_in = None;
    for (t, th) in trace {
        if within(th) {
            t_in.get_or_insert(*t);
        } else {
            t_in = None;
        }
    }
    t_in.map(|t| t - t0)
}

/// The free-move comparison, the thesis's step (link 1 by 3 rad, fig. III.3): the host
/// gives the goal (3, 0) rad as the planner would (so the goal is exact, not the wand's
/// noisy one), with the sensing, C-space, servo and reflex boards running; then the same
/// goal straight to the servo alone, from the moment the reflex first released the arm.
/// Returns (time with the reflex, time with the servo alone) to within 2 encoder counts of
/// the goal on both links, staying there.
pub fn free_move() -> Result<(f64, f64), String> {
    let goal = [3.0, 0.0];
    let base = Config {
        duration_s: 1.2,
        ..Config::default()
    };
    let mut cfg = base.clone();
    cfg.boards.retain(|(b, _)| *b != BoardId::Planner);
    let mut sim = Sim::new(cfg);
    let mut trace = Vec::new();
    let mut t0 = None;
    let per_ms = (1e-3 / sim.cfg.dt_s).round() as u64;
    let mut cycle = 0u32;
    while !sim.done() {
        if sim.steps.is_multiple_of(per_ms) {
            cycle += 1;
            let rec = vme_map::records::PlannerGoal {
                goal1_urad: (goal[0] * 1e6) as i32,
                goal2_urad: (goal[1] * 1e6) as i32,
                cycle,
                ..Default::default()
            };
            vme_map::PLANNER_GOAL.publish(&mut sim.bus(), &rec);
        }
        sim.step();
        let flags = vme_map::REFLEX_SUBGOAL
            .read(&mut sim.bus())
            .map(|r| r.0.flags)
            .unwrap_or(vme_map::records::reflex_flags::WAITING);
        if t0.is_none() && flags & vme_map::records::reflex_flags::WAITING == 0 {
            t0 = Some(sim.t_s());
        }
        trace.push((sim.t_s(), sim.plant.angles_rad()));
    }
    let t0 = t0.ok_or("the reflex never started")?;
    let with = settle_time(&trace, goal, t0).ok_or("with the reflex the arm did not settle")?;
    let mut cfg = base;
    cfg.boards.retain(|(b, _)| *b == BoardId::Servo);
    let mut sim = Sim::new(cfg);
    let mut cycle = 0;
    crate::sensing_cal::hold_at(&mut sim, [0.0, 0.0], t0, &mut cycle);
    let mut trace = Vec::new();
    while !sim.done() {
        let dt = sim.cfg.dt_s;
        crate::sensing_cal::hold_at(&mut sim, goal, dt, &mut cycle);
        trace.push((sim.t_s(), sim.plant.angles_rad()));
    }
    let alone = settle_time(&trace, goal, t0).ok_or("the servo alone did not settle")?;
    Ok((with, alone))
}

/// The bench's report.
/// The bench's report; with `top > 0` each case is followed by its `top` costliest
/// functions (own code only, cycles per pass).
pub fn report(dir: &Path, top: usize) -> Result<String, String> {
    let mut r = String::new();
    let _ = writeln!(
        r,
        "bench reflex: the reflex image on the emulated 68020 at 16.7 MHz (whole main loop; timing: {})",
        crate::emu::timing_name()
    );
    let _ = writeln!(
        r,
        "{:<58} {:>7} {:>8} {:>8} {:>6} {:>7} {:>7} {:>8} {:>8} {:>11} {:>10}",
        "case",
        "passes",
        "cycles",
        "worst",
        "> 1 ms",
        "read",
        "known",
        "rate Hz",
        "worst Hz",
        "checked/s",
        "read/s"
    );
    for c in image_cases(dir, top)? {
        let _ = writeln!(
            r,
            "{:<58} {:>7} {:>8.0} {:>8} {:>5.1}% {:>7.1} {:>7.1} {:>8.0} {:>8.0} {:>11.0} {:>10.0}",
            c.name,
            c.passes,
            c.cycles_per_pass,
            c.worst_cycles,
            100.0 * c.over_1ms as f64 / c.passes as f64,
            c.tests_per_pass,
            c.known_per_pass,
            c.rate_hz(),
            c.worst_rate_hz(),
            c.pixels_per_s(),
            c.reads_per_s()
        );
        for (name, cycles, calls) in &c.top {
            let _ = writeln!(r, "    {cycles:>9.0}  {calls:>6.1}  {name}");
        }
        if !c.worst_top.is_empty() {
            let _ = writeln!(r, "  the longest pass ({} cycles):", c.worst_cycles);
            for (name, cycles, calls) in &c.worst_top {
                let _ = writeln!(r, "    {cycles:>9.0}  {calls:>6.0}  {name}");
            }
        }
    }
    let _ = writeln!(
        r,
        "cycles: mean pass, heartbeat to heartbeat; worst: the longest pass (worst Hz: every pass that long); > 1 ms: the passes longer than a millisecond (the 1 kHz deadline missed); read: pixel words read a pass; known: pixels vouched for without a read (columns whose generation has not moved since read, and the window an earlier pass proved free while the map's epoch has not moved); checked/s: both, per second"
    );
    let _ = writeln!(
        r,
        "thesis: 214 pixels in 4.4 ms (48,000 pixels/s, subgoals at 200-600 Hz); 146,000 pixels/s needed for full speed; targets: >= 300,000 pixels/s, >= 1 kHz"
    );
    let (with, alone) = free_move()?;
    let _ = writeln!(
        r,
        "free 3 rad move of link 1 (native; to within 2 counts on both links): servo alone {:.4} s, with the reflex {:.4} s: {:+.1}% (target <= +5%)",
        alone,
        with,
        100.0 * (with / alone - 1.0)
    );
    Ok(r)
}
