//! A scenario run and its run directory (design.md section 7, "Output").
//!
//! * `trace.csv`: one row per trace interval: time, joint angles and velocities (link side),
//!   motor angles (what the encoders see), torques and currents, the smallest clearance to
//!   any obstacle, the published records (servo state, reflex subgoal, planner goal) and
//!   every board's heartbeat. Deterministic: the same scenario and seed give the same bytes.
//! * `summary.json`: the run's figures.
//! * `joints.png`, `task.png`, `cspace.png`: pictures of the run (module `plots`).
//! * `report.html`: the animated task space and C-space map, the plots and the figures
//!   (module `report`).

use crate::plots::Sample;
use crate::scenario::Scenario;
use crate::sim::Sim;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;
use vme_map::{BoardId, BoardSlot, GlobalBus};

/// How a run is carried out.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Trace interval in plant steps.
    pub trace_every: u64,
    /// No progress bar.
    pub quiet: bool,
    /// Image mode: the directory holding the board images (`<board>.elf`); native mode
    /// when `None`.
    pub images: Option<PathBuf>,
    /// Image mode: only these boards as images, the others native (all when empty).
    pub image_boards: Vec<BoardId>,
    /// Image mode: serve the GDB remote protocol for this board on this TCP port of
    /// 127.0.0.1 (0: any free port), waiting for GDB before the run starts.
    pub gdb: Option<(BoardId, u16)>,
    /// Serve the live monitor on this TCP port of 127.0.0.1 (0: any free port) and pace the
    /// run to real time.
    pub monitor: Option<u16>,
    /// Image mode: profile this board's main-loop passes longer than its budget
    /// ([`LongPassesSummary`]).
    pub long_passes: Option<BoardId>,
}

/// Functions listed in [`LongPassesSummary::functions`].
pub const LONG_PASS_FUNCTIONS: usize = 15;

/// Image mode, asked for with [`RunOptions::long_passes`]: where one board's main-loop
/// passes longer than its budget spend their cycles.
#[derive(Serialize, Clone, Debug, PartialEq)]
pub struct LongPassesSummary {
    /// The board.
    pub board: String,
    /// A pass is long above this (microseconds at 16.7 MHz: the board's budget).
    pub over_us: f64,
    /// Main-loop periods measured.
    pub periods: u64,
    /// Long ones among them.
    pub passes: u64,
    /// The costliest functions over the long passes (demangled, short): cycles in their
    /// own code and calls, each per long pass.
    pub functions: Vec<(String, f64, f64)>,
    /// The longest pass (microseconds at 16.7 MHz).
    pub longest_us: f64,
    /// The longest pass's costliest functions: cycles and calls.
    pub longest_functions: Vec<(String, f64, f64)>,
}

/// Report and monitor frames are taken this often (simulated seconds).
pub const FRAME_EVERY_S: f64 = 0.05;

/// What a run produced.
pub struct RunOutput {
    /// `trace.csv`'s text.
    pub trace: String,
    /// `summary.json`'s figures.
    pub summary: Summary,
    /// Plot samples, one per trace row.
    pub samples: Vec<Sample>,
    /// Report frames, one per [`FRAME_EVERY_S`].
    pub frames: Vec<crate::report::Frame>,
    /// The simulation as it ended.
    pub sim: Sim,
}

impl Default for RunOptions {
    fn default() -> Self {
        Self {
            trace_every: 20,
            quiet: false,
            images: None,
            image_boards: Vec::new(),
            gdb: None,
            monitor: None,
            long_passes: None,
        }
    }
}

/// Image mode: the servo image's control passes, metered at its registers
/// (`servo_bench::PassClock`: from the timer read that ends the wait for the period to the
/// next wait's first), in cycles of the 16.7 MHz 68020.
#[derive(Serialize, Clone, Debug, PartialEq)]
pub struct ServoBusy {
    /// Passes metered.
    pub passes: u64,
    /// Mean busy cycles a pass.
    pub mean_cycles: f64,
    /// The longest pass.
    pub max_cycles: u64,
    /// Passes longer than 5,566 cycles (3 kHz).
    pub over_3khz: u64,
}

/// One board's figures in the summary.
#[derive(Serialize, Clone, Debug, PartialEq)]
pub struct BoardSummary {
    /// Board name.
    pub board: String,
    /// Native mode: the configured main-loop period. Image mode: the budget, the period
    /// the board's issue asks for (its native period), against which `budget_share` is
    /// measured.
    pub period_us: f64,
    /// Image mode: shortest main-loop period measured on the emulated 68020 at 16.7 MHz.
    pub loop_min_us: Option<f64>,
    /// Image mode: mean main-loop period.
    pub loop_mean_us: Option<f64>,
    /// Image mode: longest main-loop period.
    pub loop_max_us: Option<f64>,
    /// Image mode: mean period over the budget (`period_us`); above 1, the board runs
    /// slower than its issue asks.
    pub budget_share: Option<f64>,
    /// Image mode: the stack's high-water mark (bytes).
    pub stack_bytes: Option<u32>,
    /// Image mode: main-loop periods measured (heartbeat to heartbeat).
    pub loop_periods: Option<u64>,
    /// Image mode: of those, the periods longer than 1 ms at 16.7 MHz (the reflex's 1 kHz
    /// subgoal deadline, issue 8, missed pass by pass).
    pub loop_over_1ms: Option<u64>,
    /// Main-loop passes run.
    pub polls: u64,
    /// Passes per simulated second.
    pub rate_hz: f64,
    /// Heartbeat at the end.
    pub heartbeat: u32,
    /// State at the end.
    pub state: String,
    /// Last fault recorded.
    pub fault: String,
}

/// The run's figures (`summary.json`).
#[derive(Serialize, Clone, Debug, PartialEq)]
pub struct Summary {
    /// Scenario name.
    pub scenario: String,
    /// `native` (the boards' crates on the host) or `image` (the images on emulated
    /// 68020s).
    pub mode: String,
    /// Seed.
    pub seed: u64,
    /// Simulated seconds.
    pub duration_s: f64,
    /// Plant step.
    pub plant_dt_us: f64,
    /// Plant steps.
    pub plant_steps: u64,
    /// Wall-clock seconds the run took.
    pub wall_s: f64,
    /// Simulated seconds per wall-clock second.
    pub real_time_factor: f64,
    /// Plant steps in contact with an obstacle (exact outline, every step).
    pub collision_steps: u64,
    /// Separate contacts.
    pub collisions: u64,
    /// Smallest clearance to any obstacle (m); null without obstacles.
    pub min_clearance_m: Option<f64>,
    /// Tip distance to the wand at the end (m); null without a wand.
    pub final_goal_error_m: Option<f64>,
    /// Whether the tip ended within 1 cm of the wand; null without a wand.
    pub goal_reached: Option<bool>,
    /// Per-board loop figures.
    pub boards: Vec<BoardSummary>,
    /// Image mode with the servo as an image: its passes' busy cycles; null otherwise.
    pub servo_busy: Option<ServoBusy>,
    /// Image mode, when asked for: where one board's long passes went.
    pub long_passes: Option<LongPassesSummary>,
    /// Per obstacle (in the scenario's order), the simulated milliseconds in which the
    /// sensing board published its position flagged `EXTRAPOLATED`: read beyond the
    /// camera's calibrated square, where it can be up to 139 mm short of the obstacle and
    /// the C-space map does not cover the obstacle conservatively (docs/sensing.md).
    pub obstacles_extrapolated_ms: Vec<u64>,
    /// The same for the wand (the goal when no planner runs, the planner's goal
    /// otherwise): milliseconds the goal came from a position read beyond the square.
    pub wand_extrapolated_ms: u64,
}

/// A run's milliseconds of positions read beyond the camera's square ([`Summary`]'s
/// `obstacles_extrapolated_ms` and `wand_extrapolated_ms`).
struct Extrapolated {
    obstacles_ms: Vec<u64>,
    wand_ms: u64,
}

/// Adds a millisecond to each obstacle of `sim` whose published position is flagged
/// `EXTRAPOLATED`, and to the wand when its is (an unreadable table counts nothing).
fn count_extrapolated(sim: &mut Sim, ex: &mut Extrapolated) {
    let bf = vme_map::records::beacon_flags::EXTRAPOLATED;
    if let Ok((t, _)) = vme_map::OBJECTS.read(&mut sim.bus()) {
        for (k, n) in ex.obstacles_ms.iter_mut().enumerate() {
            let f = t.beacons[crate::sim::obstacle_beacon(k)].flags;
            *n += u64::from(f & bf != 0);
        }
        let f = t.beacons[vme_map::records::beacon_index::WAND].flags;
        ex.wand_ms += u64::from(f & bf != 0);
    }
}

/// The trace's header line.
pub fn trace_header(sim: &Sim) -> String {
    let mut h = String::from(
        "t_s,theta1_rad,theta2_rad,omega1_rad_s,omega2_rad_s,motor1_rad,motor2_rad,torque1_nm,torque2_nm,current1_a,current2_a,clearance_m,\
servo_theta1_urad,servo_theta2_urad,servo_arrest1_urad,servo_arrest2_urad,reflex_goal1_urad,reflex_goal2_urad,reflex_flags,planner_goal1_urad,planner_goal2_urad,planner_mode,planner_reason",
    );
    for s in sim.board_stats() {
        let _ = write!(h, ",hb_{}", s.board.name());
    }
    h.push('\n');
    h
}

/// The records last read whole, for trace rows that meet one mid-publish (in image mode
/// the boards run between the host's reads and a record can be half written then).
#[derive(Clone, Copy, Debug, Default)]
pub struct LastRecords {
    servo: vme_map::records::ServoState,
    reflex: vme_map::records::ReflexSubgoal,
    planner: vme_map::records::PlannerGoal,
}

/// One trace row at the simulation's current time; a record read torn repeats its last
/// whole value from `last`.
pub fn trace_row(sim: &mut Sim, last: &mut LastRecords, out: &mut String) {
    let t = sim.t_s();
    let l = &sim.plant.links;
    let (a, b) = (l[0].state, l[1].state);
    let clearance = sim.clearance_m();
    let (tq1, tq2) = (l[0].motor_torque_nm(), l[1].motor_torque_nm());
    let _ = write!(
        out,
        "{t},{},{},{},{},{},{},{tq1},{tq2},{},{},{}",
        a.link_rad,
        b.link_rad,
        a.link_rad_s,
        b.link_rad_s,
        a.motor_rad,
        b.motor_rad,
        a.current_a,
        b.current_a,
        if clearance.is_finite() {
            clearance.to_string()
        } else {
            String::new()
        }
    );
    let stats = sim.board_stats();
    let mut g = sim.bus();
    if let Ok((r, _)) = vme_map::SERVO_STATE.read(&mut g) {
        last.servo = r;
    }
    if let Ok((r, _)) = vme_map::REFLEX_SUBGOAL.read(&mut g) {
        last.reflex = r;
    }
    if let Ok((r, _)) = vme_map::PLANNER_GOAL.read(&mut g) {
        last.planner = r;
    }
    let (servo, reflex, planner) = (last.servo, last.reflex, last.planner);
    let _ = write!(
        out,
        ",{},{},{},{},{},{},{:#x},{},{},{:#x},{}",
        servo.theta1_urad,
        servo.theta2_urad,
        servo.arrest1_urad,
        servo.arrest2_urad,
        reflex.goal1_urad,
        reflex.goal2_urad,
        reflex.flags,
        planner.goal1_urad,
        planner.goal2_urad,
        planner.mode,
        planner.reason
    );
    for s in stats {
        let _ = write!(out, ",{}", g.read_u32(BoardSlot::of(s.board).heartbeat()));
    }
    out.push('\n');
}

/// The plot sample at the simulation's current time.
pub fn sample(sim: &mut Sim) -> Sample {
    let l = &sim.plant.links;
    let (theta_rad, omega_rad_s, torque_nm) = (
        [l[0].state.link_rad, l[1].state.link_rad],
        [l[0].state.link_rad_s, l[1].state.link_rad_s],
        [l[0].motor_torque_nm(), l[1].motor_torque_nm()],
    );
    let sub = match vme_map::REFLEX_SUBGOAL.read(&mut sim.bus()) {
        Ok((r, seq)) if seq != 0 => Some(r),
        _ => None,
    };
    Sample {
        t_s: sim.t_s(),
        theta_rad,
        omega_rad_s,
        torque_nm,
        subgoal_rad: sub.map(|r| [r.goal1_urad as f64 * 1e-6, r.goal2_urad as f64 * 1e-6]),
        reflex_flags: sub.map_or(0, |r| r.flags),
    }
}

/// The C-space map in global RAM now: which pixels are marked (`[i2 * 128 + i1]`).
pub fn marked_pixels(sim: &mut Sim) -> Vec<bool> {
    marked_in(&mut sim.bus())
}

/// The goal the reflex is using (absolute rad), from its status record in global RAM `g`;
/// `None` before it has published one or when the record reads torn.
pub fn reflex_goal(g: &mut impl GlobalBus) -> Option<[f64; 2]> {
    match vme_map::REFLEX_STATUS.read(g) {
        Ok((r, seq)) if seq != 0 => Some([r.goal1_urad as f64 * 1e-6, r.goal2_urad as f64 * 1e-6]),
        _ => None,
    }
}

/// The C-space map in global RAM `g`: which pixels are marked (`[i2 * 128 + i1]`).
pub fn marked_in(g: &mut impl GlobalBus) -> Vec<bool> {
    let mut v = Vec::with_capacity(128 * 128);
    for i2 in 0..128 {
        for i1 in 0..128 {
            v.push(pixel_marked(g, i1, i2));
        }
    }
    v
}

/// Whether the C-space map in global RAM `g` marks pixel (`i1`, `i2`) (each taken modulo
/// 128): its word's first counter or its column's stripe word is not zero.
pub fn pixel_marked(g: &mut (impl GlobalBus + ?Sized), i1: u32, i2: u32) -> bool {
    use vme_map::layout::{cspace_counter, CSPACE_COUNTERS, CSPACE_SIDE, CSPACE_STRIPES};
    g.read_u32(cspace_counter(i1, i2, 0)) != 0
        || g.read_u32(CSPACE_STRIPES + CSPACE_COUNTERS * (i1 % CSPACE_SIDE)) != 0
}

/// The pixels that hold a configuration colliding with one of `disks` (the exact oracle).
pub fn exact_pixels(disks: &[arm::geometry::Disk]) -> Vec<bool> {
    let mut v = Vec::with_capacity(128 * 128);
    for i2 in 0..128 {
        for i1 in 0..128 {
            v.push(disks.iter().any(|d| {
                let c = cspace::Disk {
                    x_um: (d.x_m * 1e6).round() as i32,
                    y_um: (d.y_m * 1e6).round() as i32,
                    r_um: (d.r_m * 1e6).round() as i32,
                };
                crate::cspace_oracle::pixel(&c, i1, i2) == crate::cspace_oracle::Verdict::Collides
            }));
        }
    }
    v
}

/// Runs `scenario`; returns the trace text and the summary.
pub fn run(scenario: &Scenario, opts: &RunOptions) -> Result<(String, Summary), String> {
    let o = run_sampled(scenario, opts)?;
    Ok((o.trace, o.summary))
}

/// Powers up the simulation of `scenario` in the mode `opts` asks for (and waits for GDB if
/// asked).
pub fn power_up(scenario: &Scenario, opts: &RunOptions) -> Result<Sim, String> {
    let mut sim = match &opts.images {
        None => {
            if opts.gdb.is_some() {
                return Err("--gdb needs image mode (--mode image)".into());
            }
            Sim::new(scenario.config.clone())
        }
        Some(dir) => if opts.image_boards.is_empty() {
            Sim::with_images(scenario.config.clone(), dir)
        } else {
            Sim::with_some_images(scenario.config.clone(), dir, &opts.image_boards)
        }
        .map_err(|e| format!("{e} (build the images with `cargo xtask images`)"))?,
    };
    if let Some(board) = opts.long_passes {
        let dir = opts
            .images
            .as_ref()
            .ok_or("--long-passes needs image mode (--mode image)")?;
        let period_s = scenario
            .config
            .boards
            .iter()
            .find(|(id, _)| *id == board)
            .map(|(_, p)| *p);
        let (Some(period_s), true) = (period_s, sim.emu_board(board).is_some()) else {
            return Err(format!(
                "--long-passes: board {} does not run as an image in this scenario",
                board.name()
            ));
        };
        let path = dir.join(format!("{}.elf", crate::boot::image_name(board)));
        let image = crate::image::Image::load(&path).map_err(|e| format!("--long-passes: {e}"))?;
        let budget_s = period_s * crate::boot::passes_per_beat(board) as f64;
        let over = (budget_s * crate::emu::CPU_HZ as f64).round() as u64;
        if let Some(b) = sim.emu_board(board) {
            b.long_passes = Some(Box::new(crate::emu::LongPasses::new(&image, over)));
        }
    }
    if let Some((board, port)) = opts.gdb {
        if sim.emu_board(board).is_none() {
            return Err(format!("--gdb: no board {} in this scenario", board.name()));
        }
        let server = crate::gdb::Server::listen(board, port, |p| {
            eprintln!(
                "sim-host: waiting for GDB on 127.0.0.1:{p} for board {} (gdb-multiarch {}.elf -ex 'maint set dwarf unwinders off' -ex 'target remote :{p}')",
                board.name(),
                crate::boot::image_name(board)
            )
        })
        .map_err(|e| format!("--gdb: port {port}: {e}"))?;
        sim.attach_debugger(server);
    }
    Ok(sim)
}

/// Runs `scenario`; returns the trace text, the summary, the plot samples, the report's
/// frames and the simulation as it ended.
pub fn run_sampled(scenario: &Scenario, opts: &RunOptions) -> Result<RunOutput, String> {
    let mut sim = power_up(scenario, opts)?;
    let mut monitor = match opts.monitor {
        Some(port) => {
            let m = crate::monitor::Monitor::start(port, &scenario.name, &scenario.description)?;
            eprintln!(
                "sim-host: live monitor on http://127.0.0.1:{}/ (the run is paced to real time)",
                m.port()
            );
            Some(m)
        }
        None => None,
    };
    let frame_every = ((FRAME_EVERY_S / scenario.config.dt_s).round() as u64).max(1);
    let mut frames = vec![crate::report::frame(&mut sim)];
    let total = (scenario.config.duration_s / scenario.config.dt_s).round() as u64;
    // The bar appears only once a run has taken more than a second of wall time.
    let bar = indicatif::ProgressBar::with_draw_target(
        Some(total),
        indicatif::ProgressDrawTarget::hidden(),
    );
    let mut shown = false;
    let mut trace = trace_header(&sim);
    let start = Instant::now();
    let mut samples = vec![sample(&mut sim)];
    let mut last = LastRecords::default();
    trace_row(&mut sim, &mut last, &mut trace);
    let ms_every = ((1e-3 / scenario.config.dt_s).round() as u64).max(1);
    let mut extrapolated = Extrapolated {
        obstacles_ms: vec![0; scenario.config.obstacles.len().min(6)],
        wand_ms: 0,
    };
    while !sim.done() {
        sim.step();
        if sim.steps.is_multiple_of(ms_every) {
            count_extrapolated(&mut sim, &mut extrapolated);
        }
        if sim.steps.is_multiple_of(opts.trace_every) {
            trace_row(&mut sim, &mut last, &mut trace);
            samples.push(sample(&mut sim));
        }
        if sim.steps.is_multiple_of(frame_every) {
            frames.push(crate::report::frame(&mut sim));
            if let Some(m) = monitor.as_mut() {
                m.publish(&mut sim);
                // Real time: the simulation may not run ahead of the wall clock.
                let ahead = sim.t_s() - start.elapsed().as_secs_f64();
                if ahead > 0.0 {
                    std::thread::sleep(std::time::Duration::from_secs_f64(ahead));
                }
            }
        }
        if sim.steps.is_multiple_of(2000) {
            if !opts.quiet && !shown && start.elapsed().as_secs_f64() > 1.0 {
                bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
                shown = true;
            }
            bar.set_position(sim.steps);
        }
    }
    bar.finish_and_clear();
    let wall_s = start.elapsed().as_secs_f64();
    sim.detach_debugger();
    let summary = summarize(scenario, &mut sim, wall_s, extrapolated);
    Ok(RunOutput {
        trace,
        summary,
        samples,
        frames,
        sim,
    })
}

/// The state of the world at the end of a run, for the C-space picture.
pub struct End {
    /// Marked map pixels.
    pub marked: Vec<bool>,
    /// Exact image of the obstacles where they are at the end.
    pub exact: Vec<bool>,
    /// The goal the reflex was using.
    pub goal: Option<[f64; 2]>,
}

impl End {
    /// Reads the end state off `sim`.
    pub fn of(sim: &mut Sim) -> Self {
        let t = sim.t_s();
        let disks: Vec<_> = sim.cfg.obstacles.iter().map(|o| o.at(t)).collect();
        let goal = reflex_goal(&mut sim.bus());
        End {
            marked: marked_pixels(sim),
            exact: exact_pixels(&disks),
            goal,
        }
    }
}

fn summarize(scenario: &Scenario, sim: &mut Sim, wall_s: f64, ex: Extrapolated) -> Summary {
    let t = sim.t_s();
    let goal_err = sim.cfg.wand.at(t).map(|(x, y)| {
        let [a, b] = sim.plant.angles_rad();
        let (tx, ty) = arm::geometry::tip(a, b);
        (tx - x).hypot(ty - y)
    });
    let stats = sim.board_stats();
    let mut g = sim.bus();
    let boards = stats
        .iter()
        .map(|s| {
            let slot = BoardSlot::of(s.board);
            let st = slot.status_word(&mut g);
            let (lo, mean, hi) = match s.loop_us {
                Some((a, b, c)) => (Some(a), Some(b), Some(c)),
                None => (None, None, None),
            };
            // Image mode measures the loop between heartbeats: its budget is that many passes.
            let per_beat = match s.loop_us {
                Some(_) => crate::boot::passes_per_beat(s.board),
                None => 1,
            };
            let budget_us = s.period_s * 1e6 * per_beat as f64;
            BoardSummary {
                board: s.board.name().into(),
                period_us: budget_us,
                loop_min_us: lo,
                loop_mean_us: mean,
                loop_max_us: hi,
                budget_share: mean.map(|m| m / budget_us),
                stack_bytes: s.stack_bytes,
                loop_periods: s.loop_over_1ms.map(|o| o.0),
                loop_over_1ms: s.loop_over_1ms.map(|o| o.1),
                polls: s.polls,
                rate_hz: s.polls as f64 / t,
                heartbeat: g.read_u32(slot.heartbeat()),
                state: st.state().map_or("corrupt".into(), |x| format!("{x:?}")),
                fault: st.fault().map_or("corrupt".into(), |x| format!("{x:?}")),
            }
        })
        .collect();
    let servo_busy = sim.emu_board(BoardId::Servo).is_some().then(|| {
        let p = &sim.servo_io.passes;
        let (busy, passes) = p.stats.get();
        ServoBusy {
            passes,
            mean_cycles: busy as f64 / passes.max(1) as f64,
            max_cycles: p.stats.max(),
            over_3khz: p.over_budget,
        }
    });
    let long_passes = sim.long_passes().map(|(board, periods, l)| {
        let us = |c: u64| c as f64 * 1e6 / crate::emu::CPU_HZ as f64;
        LongPassesSummary {
            board: board.name().into(),
            over_us: us(l.over_cycles),
            periods,
            passes: l.passes,
            functions: l
                .long
                .costliest(LONG_PASS_FUNCTIONS, l.passes.max(1) as f64),
            longest_us: us(l.longest_cycles),
            longest_functions: l.longest.costliest(LONG_PASS_FUNCTIONS, 1.0),
        }
    });
    let c = sim.collisions;
    Summary {
        scenario: scenario.name.clone(),
        mode: if sim.image_mode() { "image" } else { "native" }.into(),
        seed: sim.cfg.seed,
        duration_s: t,
        plant_dt_us: sim.cfg.dt_s * 1e6,
        plant_steps: sim.steps,
        wall_s,
        real_time_factor: t / wall_s.max(1e-9),
        collision_steps: c.steps,
        collisions: c.events,
        min_clearance_m: c.min_clearance_m.is_finite().then_some(c.min_clearance_m),
        final_goal_error_m: goal_err,
        goal_reached: goal_err.map(|e| e <= 0.01),
        boards,
        servo_busy,
        long_passes,
        obstacles_extrapolated_ms: ex.obstacles_ms,
        wand_extrapolated_ms: ex.wand_ms,
    }
}

/// Runs `scenario` and writes `trace.csv`, `summary.json`, `joints.png`, `task.png`,
/// `cspace.png` and `report.html` into `out`.
pub fn run_to_dir(scenario: &Scenario, out: &Path, opts: &RunOptions) -> Result<Summary, String> {
    let io = |e: std::io::Error| format!("{}: {e}", out.display());
    std::fs::create_dir_all(out).map_err(io)?;
    let RunOutput {
        trace,
        summary,
        samples,
        frames,
        mut sim,
    } = run_sampled(scenario, opts)?;
    // The exact image of the obstacles is costly (an oracle verdict per pixel): only for
    // the picture.
    let end = End::of(&mut sim);
    std::fs::write(out.join("trace.csv"), trace).map_err(io)?;
    let json = serde_json::to_string_pretty(&summary).expect("summary serializes");
    std::fs::write(out.join("summary.json"), json + "\n").map_err(io)?;
    crate::plots::joints(
        &out.join("joints.png"),
        &format!("{}: joints", scenario.name),
        &samples,
    )?;
    crate::plots::task(
        &out.join("task.png"),
        &format!("{}: task space", scenario.name),
        &scenario.config,
        &samples,
    )?;
    crate::plots::cspace_path(
        &out.join("cspace.png"),
        &format!("{}: C-space", scenario.name),
        &crate::plots::PathPicture {
            marked: &end.marked,
            exact: &end.exact,
            goal: end.goal,
            oracle: &[],
        },
        &samples,
    )?;
    crate::report::write(out, scenario, &summary, &frames)?;
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::hash::{DefaultHasher, Hash, Hasher};

    fn scenario(seed: u64) -> Scenario {
        let text = format!(
            "name = \"det\"\nduration_s = 0.2\nseed = {seed}\n[[obstacle]]\nx_m = 0.3\ny_m = 0.3\nr_m = 0.02\nmotion = \"line\"\nvx_m_s = -0.1\nvy_m_s = 0.0\n[wand]\npath = [[0.0, 0.4, 0.1]]\n"
        );
        Scenario::parse(Path::new("det.toml"), &text).unwrap()
    }

    fn hash(s: &str) -> u64 {
        let mut h = DefaultHasher::new();
        s.hash(&mut h);
        h.finish()
    }

    #[test]
    fn the_same_seed_gives_a_bit_identical_trace() {
        let opts = RunOptions {
            trace_every: 1,
            quiet: true,
            ..Default::default()
        };
        let (a, _) = run(&scenario(5), &opts).unwrap();
        let (b, _) = run(&scenario(5), &opts).unwrap();
        assert_eq!(hash(&a), hash(&b));
        assert_eq!(a, b);
        // Another seed changes the boards' phases, which the heartbeat columns show.
        let (c, _) = run(&scenario(6), &opts).unwrap();
        assert_ne!(hash(&a), hash(&c));
        assert_eq!(a.lines().count(), 1 + 1 + 4000);
    }

    #[test]
    fn the_summary_reports_the_run() {
        let (_, s) = run(
            &scenario(1),
            &RunOptions {
                quiet: true,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(s.plant_steps, 4000);
        assert_eq!(s.boards.len(), 5);
        assert!(s.boards.iter().all(|b| b.state == "Running"));
        assert_eq!(
            s.goal_reached,
            Some(false),
            "no servo logic yet: the arm stays at rest"
        );
        assert!(s.min_clearance_m.is_some());
    }
}
