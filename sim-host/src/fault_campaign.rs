//! The fault campaign (`sim-host campaign faults`, docs/reliability.md): every scenario of
//! `sim-host/scenarios/faults/` (each board halted, its heartbeat frozen, its record torn, a
//! bus error in it; the goal or an obstacle beacon occluded or its A/D input saturated) run
//! with the collision oracle at every plant step, natively or as images. For each: the
//! collisions (the target is none), what the system did (which layer held the arm, the faults
//! the boards recorded in global RAM), the time from the fault to the arm at rest, and whether
//! it stopped within the arrest distance the servo had published when the fault struck.

use crate::scenario::Scenario;
use crate::sim::Sim;
use serde::Serialize;
use std::path::{Path, PathBuf};
use vme_map::records::reflex_flags;
use vme_map::{BoardId, BoardSlot};

/// Below this joint speed (rad/s) the arm counts as at rest.
pub const REST_RAD_S: f64 = 0.05;

/// Allowance on the arrest distance (rad): the servo's arrest point is computed from its
/// observer's estimate one loop before the fault, and the brakes or the hold take a few
/// milliseconds to act.
pub const ARREST_TOLERANCE_RAD: f64 = 0.02;

/// What one fault scenario showed.
#[derive(Serialize, Clone, Debug, PartialEq)]
pub struct FaultResult {
    /// Scenario file name.
    pub scenario: String,
    /// Scenario title.
    pub name: String,
    /// When the fault struck (s): when the scenario injects it, or for a bus error when its
    /// board took it (the host posts it as a command the board takes at its next poll).
    pub fault_s: f64,
    /// When the scenario injected the fault (s).
    pub injected_s: f64,
    /// Separate contacts (must be 0).
    pub collisions: u64,
    /// Smallest clearance (m).
    pub min_clearance_m: f64,
    /// Joint speeds when the fault struck (rad/s).
    pub speed_at_fault_rad_s: [f64; 2],
    /// Seconds from the fault until the arm was at rest for good; `None` if it was still
    /// moving at the end (the system carried on).
    pub time_to_rest_s: Option<f64>,
    /// Seconds from the fault until a layer took hold of the arm for good (the reflex's
    /// hold, the servo's hold, or the watchdog's brakes, the last time one began before the
    /// end); `None` if none held at the end.
    pub time_to_hold_s: Option<f64>,
    /// Each joint's travel from where the arm was when the fault struck over the distance
    /// to the arrest point the servo had published then (<= 1 is inside, with
    /// [`ARREST_TOLERANCE_RAD`]); `None` when no layer had to hold.
    pub travel_over_arrest_at_fault: Option<[f64; 2]>,
    /// The same from where the arm was when the hold began (the layers hold at the arrest
    /// point of the fault's moment, so the arm comes back: above 1 here is that way back).
    pub travel_over_arrest: Option<[f64; 2]>,
    /// Whether the stop was within the arrest distance published when the fault struck
    /// (`None`: no hold).
    pub within_arrest: Option<bool>,
    /// Which layer held the arm at the end.
    pub held_by: String,
    /// Boards not running cleanly at the end: `board: state fault`.
    pub faults: Vec<String>,
    /// Tip distance to the wand at the end (m).
    pub goal_error_m: Option<f64>,
}

/// The fault scenarios, sorted by file name.
pub fn scenarios(dir: &Path) -> Result<Vec<(PathBuf, Scenario)>, String> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| format!("{}: {e}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    v.sort();
    v.into_iter()
        .map(|p| {
            Scenario::load(&p)
                .map(|s| (p, s))
                .map_err(|e| e.to_string())
        })
        .collect()
}

/// The committed fault scenarios' directory.
pub fn default_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/faults")
}

/// When the scenario's fault strikes: its first `[[fault]]` or the start of its first
/// occlusion or saturation window.
fn fault_time(sc: &Scenario) -> f64 {
    let c = &sc.config;
    c.faults
        .iter()
        .map(|f| f.at_s)
        .chain(c.optics.occluded.iter().map(|w| w.from_s))
        .chain(c.optics.saturated.iter().map(|w| w.from_s))
        .fold(f64::INFINITY, f64::min)
}

/// Runs one fault scenario (images from `images` when given).
pub fn run_one(path: &Path, sc: &Scenario, images: Option<&Path>) -> Result<FaultResult, String> {
    let mut sim = Sim::in_mode(sc.config.clone(), images).map_err(|e| e.to_string())?;
    let posted_s = fault_time(sc);
    // A bus error is posted to its board as a host command, which the board takes at its
    // next poll (after the job under way: an image's C-space job runs tens of
    // milliseconds); the layer fails when it takes it, and the run is measured from there.
    let taker = sc
        .config
        .faults
        .iter()
        .find(|f| f.kind == crate::sim::FaultKind::BusError && f.at_s == posted_s)
        .map(|f| f.board);
    let mut fault_s = posted_s;
    let mut struck = taker.is_none();
    // The arm and the servo's last whole arrest point as the fault strikes (the fault may
    // tear the servo's record).
    let mut at_fault: Option<([f64; 2], [f64; 2], [f64; 2])> = None; // theta, arrest, speed
    let mut last_servo = None;
    let mut at_hold: Option<([f64; 2], [f64; 2], f64)> = None; // theta, arrest, time
    let mut was_held = false;
    let mut was_reflex_hold = false;
    let mut last_moving_s = fault_s;
    let servo_faults0 = BoardSlot::of(BoardId::Servo)
        .status_word(&mut sim.bus())
        .faults();
    while !sim.done() {
        if !struck && sim.t_s() >= posted_s {
            let b = taker.expect("only a bus error waits to be taken");
            let st = BoardSlot::of(b).status_word(&mut sim.bus());
            if st.fault() == Some(vme_map::FaultCode::BusError) {
                struck = true;
                fault_s = sim.t_s();
                last_moving_s = fault_s;
            }
        }
        if struck && at_fault.is_none() && sim.t_s() + sim.cfg.dt_s > fault_s {
            let l = &sim.plant.links;
            let w = [l[0].state.link_rad_s, l[1].state.link_rad_s];
            at_fault = last_servo.map(|a| (sim.plant.angles_rad(), a, w));
        }
        sim.step();
        let l = &sim.plant.links;
        let w = [l[0].state.link_rad_s, l[1].state.link_rad_s];
        let t = sim.t_s();
        if struck && t > fault_s && w.iter().any(|v| v.abs() >= REST_RAD_S) {
            last_moving_s = t;
        }
        if let Ok((s, seq)) = vme_map::SERVO_STATE.read(&mut sim.bus()) {
            if seq != 0 {
                last_servo = Some([s.arrest1_urad as f64 * 1e-6, s.arrest2_urad as f64 * 1e-6]);
            }
        }
        if struck && t > fault_s {
            let now = (t * crate::emu::CPU_HZ as f64) as u64;
            let braked = sim.servo_io.outputs(now).1.iter().all(|&b| b);
            let mut g = sim.bus();
            // A record the host meets mid-publish (image mode) leaves the flag as it was.
            let reflex_hold = match vme_map::REFLEX_SUBGOAL.read(&mut g) {
                Ok((r, _)) => r.flags & reflex_flags::HOLD != 0,
                Err(_) => was_reflex_hold,
            };
            was_reflex_hold = reflex_hold;
            let servo = BoardSlot::of(BoardId::Servo).status_word(&mut g);
            let servo_hold = servo.faults() != servo_faults0
                && servo.state() == Some(vme_map::BoardState::Degraded);
            let held = braked || reflex_hold || servo_hold;
            // The hold that lasts to the end began at its last rising edge.
            if held && !was_held {
                at_hold = last_servo.map(|a| (sim.plant.angles_rad(), a, t));
            }
            if !held {
                at_hold = None;
            }
            was_held = held;
        }
    }
    if !struck {
        return Err(format!(
            "{}: the bus error posted at {posted_s} s was never taken",
            path.display()
        ));
    }
    let (theta0, arrest, speed) =
        at_fault.ok_or("the servo published no state before the fault struck")?;
    let end = sim.t_s();
    let l = &sim.plant.links;
    let moving_at_end = [l[0].state.link_rad_s, l[1].state.link_rad_s]
        .iter()
        .any(|v| v.abs() >= REST_RAD_S);
    // At rest for good, and not merely arrived at the goal the system carried on to.
    let theta = sim.plant.angles_rad();
    let goal_error_m = sim.cfg.wand.at(end).map(|(x, y)| {
        let (tx, ty) = arm::geometry::tip(theta[0], theta[1]);
        (tx - x).hypot(ty - y)
    });
    let stopped = !moving_at_end && goal_error_m.is_none_or(|e| e > 0.01);
    let ratio = |from: [f64; 2], arrest: [f64; 2]| {
        [0, 1].map(|i| {
            let d = (theta[i] - from[i]).abs();
            let a = (arrest[i] - from[i]).abs() + ARREST_TOLERANCE_RAD;
            d / a
        })
    };
    let held = at_hold.filter(|_| stopped);
    let travel = held.map(|(from, a, _)| ratio(from, a));
    let travel_at_fault = held.map(|_| ratio(theta0, arrest));
    let (_, brakes) = sim
        .servo_io
        .outputs((end * crate::emu::CPU_HZ as f64) as u64);
    let mut g = sim.bus();
    let reflex = vme_map::REFLEX_SUBGOAL.read(&mut g).ok().map(|r| r.0.flags);
    let mut faults = Vec::new();
    for b in sim_boards(&sc.config) {
        let st = BoardSlot::of(b).status_word(&mut g);
        let state = st.state().map_or("corrupt".into(), |s| format!("{s:?}"));
        let fault = st.fault().map_or("corrupt".into(), |f| format!("{f:?}"));
        if state != "Running" || fault != "None" {
            faults.push(format!("{}: {state} {fault}", b.name()));
        }
    }
    let servo_state = BoardSlot::of(BoardId::Servo).status_word(&mut g);
    let held_by = if brakes.iter().all(|&b| b) {
        "brakes (servo watchdog)".to_string()
    } else if reflex.is_some_and(|f| f & reflex_flags::HOLD != 0) {
        "reflex (hold at the arrest point)".to_string()
    } else if servo_state
        .fault()
        .is_some_and(|f| f != vme_map::FaultCode::None)
    {
        "servo (hold at the arrest point)".to_string()
    } else if stopped && faults.is_empty() {
        // No layer holds and no board recorded a fault: the arm is short of the goal
        // because the reflex keeps it off an obstacle (a moving one may stand between), as
        // it would without the fault; where it happens to be at the run's end decides
        // nothing about the fault.
        "none needed (carried on; at rest short of the goal, kept off an obstacle)".to_string()
    } else if stopped {
        "reflex and servo (stopped short of an obstacle or the goal)".to_string()
    } else {
        "none needed (carried on)".to_string()
    };
    Ok(FaultResult {
        scenario: path
            .file_stem()
            .map_or(String::new(), |s| s.to_string_lossy().into_owned()),
        name: sc.name.clone(),
        fault_s,
        injected_s: posted_s,
        collisions: sim.collisions.events,
        min_clearance_m: sim.collisions.min_clearance_m,
        speed_at_fault_rad_s: speed,
        time_to_rest_s: (!moving_at_end).then_some(last_moving_s - fault_s),
        time_to_hold_s: at_hold.map(|h| h.2 - fault_s),
        travel_over_arrest: travel,
        travel_over_arrest_at_fault: travel_at_fault,
        within_arrest: travel_at_fault.map(|r| r.iter().all(|&x| x <= 1.0)),
        held_by,
        faults,
        goal_error_m,
    })
}

fn sim_boards(c: &crate::sim::Config) -> Vec<BoardId> {
    c.boards.iter().map(|b| b.0).collect()
}

/// The campaign's summary.
#[derive(Serialize, Debug)]
pub struct Summary {
    /// `native` or `image`.
    pub mode: String,
    /// Scenarios run.
    pub scenarios: usize,
    /// Scenarios with a collision (target 0).
    pub with_collisions: usize,
    /// Stops beyond the arrest distance published when the fault struck (target 0).
    pub beyond_arrest: usize,
    /// Each scenario's result.
    pub results: Vec<FaultResult>,
}

/// Runs every fault scenario in `dir` on `threads` threads.
pub fn run(dir: &Path, images: Option<&Path>, threads: usize) -> Result<Summary, String> {
    let list = scenarios(dir)?;
    let results = crate::campaign::in_parallel(list.len() as u64, threads, &|| {}, |i| {
        let (p, s) = &list[i as usize];
        run_one(p, s, images)
    });
    let mut results = results.into_iter().collect::<Result<Vec<_>, _>>()?;
    results.sort_by(|a, b| a.scenario.cmp(&b.scenario));
    Ok(Summary {
        mode: if images.is_some() { "image" } else { "native" }.into(),
        scenarios: results.len(),
        with_collisions: results.iter().filter(|r| r.collisions > 0).count(),
        beyond_arrest: results
            .iter()
            .filter(|r| r.within_arrest == Some(false))
            .count(),
        results,
    })
}

/// The campaign's table (Markdown), as printed and in docs/reliability.md.
pub fn table(s: &Summary) -> String {
    let mut t = String::from(
        "| fault | collisions | min clearance mm | speed at fault rad/s | fault to hold ms | fault to rest s | travel / arrest distance from the fault (from the hold) | held by | faults recorded |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in &s.results {
        t.push_str(&format!(
            "| {} | {} | {:.1} | {:.1}, {:.1} | {} | {} | {} | {} | {} |\n",
            {
                let name = r.name.trim_start_matches("fault: ");
                let late_ms = (r.fault_s - r.injected_s) * 1e3;
                if late_ms >= 0.5 {
                    format!("{name} (taken {late_ms:.0} ms after it was posted)")
                } else {
                    name.to_string()
                }
            },
            r.collisions,
            r.min_clearance_m * 1e3,
            r.speed_at_fault_rad_s[0],
            r.speed_at_fault_rad_s[1],
            r.time_to_hold_s
                .map_or("-".into(), |x| format!("{:.0}", x * 1e3)),
            r.time_to_rest_s
                .map_or("moving".into(), |x| format!("{x:.3}")),
            match (r.travel_over_arrest_at_fault, r.travel_over_arrest) {
                (Some(a), Some(b)) =>
                    format!("{:.2}, {:.2} ({:.2}, {:.2})", a[0], a[1], b[0], b[1]),
                _ => "carried on".into(),
            },
            r.held_by,
            if r.faults.is_empty() {
                "none".into()
            } else {
                r.faults.join("; ")
            }
        ));
    }
    t
}
