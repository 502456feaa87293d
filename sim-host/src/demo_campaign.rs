//! The demo's campaign (`sim-host campaign demo --scenes N`): the main demo
//! (`scenarios/demo.toml`) with seeds 1..=N (the seed moves every board's phase, the sensor's
//! noise and drift), each checked by the collision oracle at every plant step; for every seed
//! that does not end at the wand, the reason the system gives in global RAM (the planner's
//! mode and reason, the reflex's flags, the boards' faults) and whether the arm was still on
//! its way.

use crate::scenario::Scenario;
use crate::sim::Sim;
use serde::Serialize;
use std::path::{Path, PathBuf};
use vme_map::records::{planner_mode, planner_reason, reflex_flags};
use vme_map::BoardSlot;

/// One seed's outcome.
#[derive(Serialize, Clone, Debug, PartialEq)]
pub struct SeedResult {
    /// The seed.
    pub seed: u64,
    /// Separate contacts.
    pub collisions: u64,
    /// Smallest clearance (m).
    pub min_clearance_m: f64,
    /// Tip distance to the wand at the end (m).
    pub goal_error_m: f64,
    /// Within 1 cm of the wand at the end.
    pub reached: bool,
    /// Why not, as the system reports it (empty when reached).
    pub why: String,
}

/// The campaign's summary.
#[derive(Serialize, Debug)]
pub struct Summary {
    /// `native` or `image`.
    pub mode: String,
    /// Seeds run.
    pub seeds: u64,
    /// Seeds that ended at the wand.
    pub reached: u64,
    /// Seeds with a collision (target 0).
    pub with_collisions: u64,
    /// Smallest clearance over all seeds (m).
    pub min_clearance_m: f64,
    /// Every seed.
    pub results: Vec<SeedResult>,
}

/// The demo scenario's file.
pub fn scenario_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/demo.toml")
}

/// Runs the demo with `seed`.
pub fn run_seed(sc: &Scenario, seed: u64, images: Option<&Path>) -> Result<SeedResult, String> {
    let mut cfg = sc.config.clone();
    cfg.seed = seed;
    let mut sim = Sim::in_mode(cfg, images).map_err(|e| e.to_string())?;
    while !sim.done() {
        sim.step();
    }
    let t = sim.t_s();
    let q = sim.plant.angles_rad();
    let (tx, ty) = arm::geometry::tip(q[0], q[1]);
    let goal_error_m = sim
        .cfg
        .wand
        .at(t)
        .map_or(f64::INFINITY, |(x, y)| (tx - x).hypot(ty - y));
    let reached = goal_error_m <= 0.01;
    let moving = sim
        .plant
        .links
        .iter()
        .any(|l| l.state.link_rad_s.abs() >= 0.05);
    let boards: Vec<_> = sim.cfg.boards.iter().map(|b| b.0).collect();
    let mut g = sim.bus();
    let mut why = Vec::new();
    if !reached {
        why.push(format!("{:.0} mm from the wand", goal_error_m * 1e3));
        if moving {
            why.push("still on its way at the end".into());
        }
        if let Ok((p, _)) = vme_map::PLANNER_GOAL.read(&mut g) {
            let mode = match p.mode & 0xFF {
                planner_mode::IDLE => "idle",
                planner_mode::FREE => "free",
                planner_mode::WALL => "wall-following",
                planner_mode::UNREACHABLE => "goal unreachable",
                _ => "?",
            };
            let reason = match p.reason {
                planner_reason::GOAL_IN_OBSTACLE => ": goal inside an obstacle",
                planner_reason::ENCLOSED => ": goal enclosed",
                planner_reason::CYCLED => ": cycled",
                _ => "",
            };
            why.push(format!("planner {mode}{reason}"));
        }
        if let Ok((r, _)) = vme_map::REFLEX_SUBGOAL.read(&mut g) {
            for (bit, name) in [
                (reflex_flags::STALLED, "reflex stalled"),
                (reflex_flags::TRAPPED, "reflex trapped"),
                (reflex_flags::HOLD, "reflex holding"),
                (reflex_flags::ESCAPING, "reflex escaping"),
                (reflex_flags::EVADING, "reflex evading"),
            ] {
                if r.flags & bit != 0 {
                    why.push(name.into());
                }
            }
        }
        for b in boards {
            let st = BoardSlot::of(b).status_word(&mut g);
            if st.fault() != Some(vme_map::FaultCode::None) {
                why.push(format!("{} fault {:?}", b.name(), st.fault()));
            }
        }
    }
    Ok(SeedResult {
        seed,
        collisions: sim.collisions.events,
        min_clearance_m: sim.collisions.min_clearance_m,
        goal_error_m,
        reached,
        why: why.join(", "),
    })
}

/// Runs seeds 1..=n.
pub fn run(n: u64, images: Option<&Path>, threads: usize) -> Result<Summary, String> {
    let sc = Scenario::load(&scenario_path()).map_err(|e| e.to_string())?;
    let results =
        crate::campaign::in_parallel(n, threads, &|| {}, |i| run_seed(&sc, i + 1, images));
    let results = results.into_iter().collect::<Result<Vec<_>, _>>()?;
    Ok(Summary {
        mode: if images.is_some() { "image" } else { "native" }.into(),
        seeds: n,
        reached: results.iter().filter(|r| r.reached).count() as u64,
        with_collisions: results.iter().filter(|r| r.collisions > 0).count() as u64,
        min_clearance_m: results
            .iter()
            .map(|r| r.min_clearance_m)
            .fold(f64::INFINITY, f64::min),
        results,
    })
}
