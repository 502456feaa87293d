//! The planner's campaign (issue 9, thesis ch. VI): random static scenes run with all five
//! boards, each judged by an oracle on the same C-space map.
//!
//! **The oracle.** The map the C-space board has drawn once the boards are up (1 s) is read
//! from global RAM; a cell is blocked when a marked pixel lies within one pixel of it (the
//! planner's own clearance, `crates/planner`). A* on the 8-connected torus (no corner cut
//! between two blocked cells, so it connects exactly what the planner's 4-connected moves
//! do) finds the shortest path in radians from the arm's start cell to the nearest cell of
//! either of the goal's poses. A scene is solvable when there is one; marginal when there is
//! a way only through unmarked pixels closer than that (the reflex lets the arm there, the
//! planner does not lead it: reached or reported, both fine); otherwise unsolvable: both
//! poses' pixels are marked (the goal is inside an obstacle) or free but enclosed. The time estimate
//! follows the path, shortened to the fewest straight pieces the blocked cells allow, at the
//! arm's acceleration limits (umax / I per link, `crates/arm`): along a piece the tangential
//! acceleration is the most both links allow in its direction; at a corner the speed is
//! limited so that each link's change of velocity fits its acceleration over a pixel; rest at
//! both ends. It is a lower bound the real arm cannot quite reach (the servo brakes at less
//! than umax, and the reflex slows it near walls).
//!
//! **A scene.** 1-5 disks of radius 15-45 mm (the C-space database holds images up to 51 mm),
//! 0.10-0.50 m from the shoulder with their centres inside the camera's calibrated square
//! (as the reflex campaign's [`crate::campaign::Place::Sensed`]: beyond it the sensing board
//! flags a reading `EXTRAPOLATED` and the C-space boards draw it over its whole fold, and
//! until 2026-11-27 47% of these disks stood there); the arm at rest
//! in free space (at least 10 mm from every disk); the wand held still at a random point of
//! the sensing board's calibrated square that the tip can reach. Outcomes: the tip within
//! 1 cm of the wand (reached), the planner's record saying the goal is unreachable
//! (reported), or neither by the end (undecided: a loop or too slow). Time to goal counts
//! from the planner's first request of the goal.

use crate::run::marked_pixels;
use crate::sim::{Config, Obstacle, Rng, Sim, WandPath};
use arm::geometry::{tip, Disk, Pose};
use serde::Serialize;
use std::collections::BinaryHeap;
use std::f64::consts::{PI, TAU};
use std::fmt::Write as _;
use std::path::Path;
use vme_map::records::planner_mode;

/// Simulated seconds a scene may take at most.
pub const DURATION_S: f64 = 10.0;
/// When the oracle reads the map: once it has settled (at 0.3-0.4 s the C-space board still
/// draws some obstacles swept, as moving, while the sensing board's filters settle: planner
/// campaign seed 1 scene 297 was enclosed then and not from 0.6 s on).
pub const ORACLE_AT_S: f64 = 1.0;
/// An unreachable report must stand this long to count (the planner takes it back if a
/// later fill finds a way, e.g. once an obstacle's swept start-up image is redrawn).
pub const REPORT_HOLD_S: f64 = 1.0;
/// Radians per pixel.
const PIX_RAD: f64 = TAU / 128.0;

/// What the oracle says of a scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Class {
    /// A path exists with the planner's clearance (a pixel from anything marked).
    Solvable,
    /// A path exists only closer than a pixel to an obstacle.
    Marginal,
    /// Both goal poses are blocked.
    GoalInObstacle,
    /// The goal is free but cut off from the arm.
    Enclosed,
}

/// The oracle's view of a map: blocked cells.
pub struct Oracle {
    blocked: Vec<bool>,
    marked: Vec<bool>,
    /// Search the marked pixels instead of the blocked cells.
    loose: bool,
}

#[inline]
fn idx(c: [i32; 2]) -> usize {
    ((c[1] & 127) * 128 + (c[0] & 127)) as usize
}

impl Oracle {
    /// The blocked cells of a map (`marked[i2 * 128 + i1]`): a marked pixel within one.
    pub fn new(marked: &[bool]) -> Self {
        let mut blocked = vec![false; 128 * 128];
        for i2 in 0..128 {
            for i1 in 0..128 {
                let mut b = false;
                for d2 in -1..=1 {
                    for d1 in -1..=1 {
                        b |= marked[idx([i1 + d1, i2 + d2])];
                    }
                }
                blocked[idx([i1, i2])] = b;
            }
        }
        Self {
            blocked,
            marked: marked.to_vec(),
            loose: false,
        }
    }

    /// The same map searched through every unmarked pixel (closer than a pixel to the
    /// obstacles, where the reflex lets the arm go but the planner does not lead it).
    pub fn loose(mut self) -> Self {
        self.loose = true;
        self
    }

    /// Whether cell `c` is blocked (marked, for a loose oracle).
    pub fn blocked(&self, c: [i32; 2]) -> bool {
        if self.loose {
            self.marked[idx(c)]
        } else {
            self.blocked[idx(c)]
        }
    }

    /// The shortest path (unwrapped cells, from `start`) to the nearest of `goals`, on the
    /// 8-connected torus without cutting corners.
    pub fn astar(&self, start: [i32; 2], goals: &[[i32; 2]]) -> Option<Vec<[i32; 2]>> {
        // The arm may stand closer than a pixel to an obstacle: it starts from the free
        // cells within two of it (as the planner's fill does).
        let mut starts = Vec::new();
        for d2 in -2i32..=2 {
            for d1 in -2i32..=2 {
                let c = [start[0] + d1, start[1] + d2];
                if !self.blocked(c) && (d1 == 0 && d2 == 0 || self.blocked(start)) {
                    starts.push((c, ((d1 * d1 + d2 * d2) as f64).sqrt()));
                }
            }
        }
        if starts.is_empty() {
            return None;
        }
        let targets: Vec<[i32; 2]> = goals
            .iter()
            .copied()
            .filter(|g| !self.blocked(*g))
            .collect();
        if targets.is_empty() {
            return None;
        }
        let wrapd = |a: i32, b: i32| {
            let d = (a - b).rem_euclid(128);
            d.min(128 - d) as f64
        };
        let h = |c: [i32; 2]| {
            targets
                .iter()
                .map(|g| {
                    let (x, y) = (wrapd(c[0], g[0]), wrapd(c[1], g[1]));
                    x.max(y) + (2f64.sqrt() - 1.0) * x.min(y)
                })
                .fold(f64::INFINITY, f64::min)
        };
        #[derive(PartialEq)]
        struct Node(f64, [i32; 2]);
        impl Eq for Node {}
        impl PartialOrd for Node {
            fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
                Some(self.cmp(o))
            }
        }
        impl Ord for Node {
            fn cmp(&self, o: &Self) -> std::cmp::Ordering {
                o.0.total_cmp(&self.0)
            }
        }
        let mut g = vec![f64::INFINITY; 128 * 128];
        let mut parent: Vec<Option<[i32; 2]>> = vec![None; 128 * 128];
        let mut open = BinaryHeap::new();
        for &(c, g0) in &starts {
            g[idx(c)] = g0;
            open.push(Node(g0 + h(c), c));
        }
        while let Some(Node(_, c)) = open.pop() {
            if targets.iter().any(|t| idx(*t) == idx(c)) {
                let mut path = vec![c];
                let mut k = c;
                while let Some(p) = parent[idx(k)] {
                    path.push(p);
                    k = p;
                }
                path.reverse();
                return Some(path);
            }
            for d2 in -1..=1 {
                for d1 in -1..=1 {
                    if d1 == 0 && d2 == 0 {
                        continue;
                    }
                    let n = [c[0] + d1, c[1] + d2];
                    if self.blocked(n) {
                        continue;
                    }
                    if d1 != 0
                        && d2 != 0
                        && (self.blocked([c[0] + d1, c[1]]) || self.blocked([c[0], c[1] + d2]))
                    {
                        continue;
                    }
                    let cost = g[idx(c)] + if d1 != 0 && d2 != 0 { 2f64.sqrt() } else { 1.0 };
                    if cost < g[idx(n)] {
                        g[idx(n)] = cost;
                        parent[idx(n)] = Some(c);
                        open.push(Node(cost + h(n), n));
                    }
                }
            }
        }
        None
    }

    /// Whether the straight segment between two cell centres crosses only free cells.
    fn segment_free(&self, a: [i32; 2], b: [i32; 2]) -> bool {
        let (dx, dy) = ((b[0] - a[0]) as f64, (b[1] - a[1]) as f64);
        let n = (4.0 * dx.abs().max(dy.abs())).ceil().max(1.0) as i32;
        (0..=n).all(|k| {
            let f = k as f64 / n as f64;
            let x = a[0] as f64 + 0.5 + f * dx;
            let y = a[1] as f64 + 0.5 + f * dy;
            !self.blocked([x.floor() as i32, y.floor() as i32])
        })
    }

    /// The path with its corners cut where the blocked cells allow (fewest straight
    /// pieces, greedily): the waypoints.
    pub fn shorten(&self, path: &[[i32; 2]]) -> Vec<[i32; 2]> {
        let mut out = vec![path[0]];
        let mut i = 0;
        while i + 1 < path.len() {
            let mut j = path.len() - 1;
            while j > i + 1 && !self.segment_free(path[i], path[j]) {
                j -= 1;
            }
            out.push(path[j]);
            i = j;
        }
        out
    }
}

/// The time to follow waypoints `w` (radians), at rest at both ends (module docs).
pub fn time_estimate(w: &[[f64; 2]]) -> f64 {
    let acc = [arm::LINK1.max_accel_rad_s2(), arm::LINK2.max_accel_rad_s2()];
    let n = w.len();
    if n < 2 {
        return 0.0;
    }
    let seg: Vec<(f64, [f64; 2], f64)> = w
        .windows(2)
        .map(|p| {
            let d = [p[1][0] - p[0][0], p[1][1] - p[0][1]];
            let l = d[0].hypot(d[1]);
            let u = if l > 0.0 {
                [d[0] / l, d[1] / l]
            } else {
                [0.0, 0.0]
            };
            let a = (0..2)
                .map(|i| {
                    if u[i].abs() > 1e-9 {
                        acc[i] / u[i].abs()
                    } else {
                        f64::INFINITY
                    }
                })
                .fold(f64::INFINITY, f64::min);
            (l, u, a)
        })
        .collect();
    // Speed limits at the waypoints: rest at the ends, cornering in between.
    let mut v = vec![0.0; n];
    for k in 1..n - 1 {
        let (u0, u1) = (seg[k - 1].1, seg[k].1);
        v[k] = (0..2)
            .map(|i| {
                let du = (u1[i] - u0[i]).abs();
                if du > 1e-9 {
                    (acc[i] * PIX_RAD / du).sqrt()
                } else {
                    f64::INFINITY
                }
            })
            .fold(f64::INFINITY, f64::min);
    }
    // Forward and backward passes: reachable speeds.
    for k in 1..n {
        let (l, _, a) = seg[k - 1];
        v[k] = v[k].min((v[k - 1] * v[k - 1] + 2.0 * a * l).sqrt());
    }
    for k in (0..n - 1).rev() {
        let (l, _, a) = seg[k];
        v[k] = v[k].min((v[k + 1] * v[k + 1] + 2.0 * a * l).sqrt());
    }
    seg.iter()
        .enumerate()
        .map(|(k, &(l, _, a))| {
            let (v0, v1) = (v[k], v[k + 1]);
            let vp = ((2.0 * a * l + v0 * v0 + v1 * v1) / 2.0).sqrt();
            (vp - v0) / a + (vp - v1) / a
        })
        .sum()
}

/// One random scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// Its index in the campaign.
    pub index: u64,
    /// The run's configuration.
    pub config: Config,
}

/// Scene `index` of a campaign with seed `seed`.
pub fn scene(seed: u64, index: u64) -> Scene {
    let mut rng = Rng::new(
        seed.wrapping_mul(0xA076_1D64_78BD_642F) ^ index.wrapping_mul(0xE703_7ED1_A0B4_28DB),
    );
    let mut u = |lo: f64, hi: f64| lo + (hi - lo) * rng.next_f64();
    loop {
        let n = 1 + (u(0.0, 5.0) as usize).min(4);
        let obstacles: Vec<Obstacle> = (0..n)
            .map(|_| {
                let (d, a) = loop {
                    let (d, a) = (u(0.10, 0.50), u(-PI, PI));
                    if crate::campaign::in_view(d, a) {
                        break (d, a);
                    }
                };
                Obstacle {
                    start: Disk {
                        x_m: d * a.cos(),
                        y_m: d * a.sin(),
                        r_m: u(0.015, 0.045),
                    },
                    motion: crate::sim::Motion::Static,
                }
            })
            .collect();
        let start = (0..200).find_map(|_| {
            let s = [u(-PI, PI), u(-PI, PI)];
            let p = Pose::new(s[0], s[1]);
            obstacles
                .iter()
                .all(|o| p.clearance_m(&o.start) >= 0.010)
                .then_some(s)
        });
        let Some(start_rad) = start else { continue };
        // The wand somewhere in the calibrated square the tip reaches, not inside a disk.
        let wand = (0..200).find_map(|_| {
            let (x, y) = (u(-0.33, 0.33), u(-0.33, 0.33));
            let r = x.hypot(y);
            let clear = obstacles
                .iter()
                .all(|o| (x - o.start.x_m).hypot(y - o.start.y_m) > o.start.r_m + 0.005);
            (r > 0.05 && r < 0.49 && clear).then_some((x, y))
        });
        let Some((wx, wy)) = wand else { continue };
        let config = Config {
            seed: seed ^ index.rotate_left(17),
            duration_s: DURATION_S,
            start_rad,
            obstacles,
            wand: WandPath {
                points: vec![(0.0, wx, wy)],
            },
            ..Config::default()
        };
        return Scene { index, config };
    }
}

/// The goal's two poses for a wand at (`x`, `y`) within reach (absolute angles): the
/// calibration's inverse kinematics, and the same with the angles swapped (the links are
/// equally long, so swapping them puts the tip at the same place, elbow the other way).
pub fn poses(x: f64, y: f64) -> [[f64; 2]; 2] {
    let p = crate::sensing_cal::ik(x, y).expect("the wand is within the arm's reach");
    [p, [p[1], p[0]]]
}

/// The pixel of angles `a` (unwrapped).
fn cell(a: [f64; 2]) -> [i32; 2] {
    [
        (a[0] / PIX_RAD).floor() as i32,
        (a[1] / PIX_RAD).floor() as i32,
    ]
}

/// The centre of pixel `c`, rad.
fn centre(c: &[i32; 2]) -> [f64; 2] {
    [(c[0] as f64 + 0.5) * PIX_RAD, (c[1] as f64 + 0.5) * PIX_RAD]
}

/// What one scene did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SceneResult {
    /// Its index.
    pub index: u64,
    /// The oracle's class.
    pub class: Class,
    /// Length of the oracle's path, rad (solvable scenes).
    pub oracle_path_rad: Option<f64>,
    /// The oracle's time estimate, s (solvable scenes).
    pub estimate_s: Option<f64>,
    /// The oracle's path (cell centres, radians, unwrapped) for the pictures.
    #[serde(skip)]
    pub oracle_path: Vec<[f64; 2]>,
    /// The map the oracle read (`[i2 * 128 + i1]`), kept only when the run was asked for
    /// a picture's samples.
    #[serde(skip)]
    pub marked: Vec<bool>,
    /// Separate contacts between the arm and a disk.
    pub collisions: u64,
    /// Smallest clearance, m.
    pub min_clearance_m: f64,
    /// Time from the planner's first request to the tip within 1 cm of the wand, s.
    pub goal_time_s: Option<f64>,
    /// Time from the planner's first request to its record saying unreachable (for at least
    /// [`REPORT_HOLD_S`] from then), s, and the reason code.
    pub unreachable: Option<(f64, u32)>,
    /// Wall-following episodes.
    pub walls: u32,
    /// Highest approach the planner tried (0: the first).
    pub approach: u32,
    /// Simulated seconds run.
    pub ran_s: f64,
}

/// Runs one scene; with `samples`, also the path and the map for a picture.
pub fn run_scene(s: &Scene, mut samples: Option<&mut Vec<crate::plots::Sample>>) -> SceneResult {
    let mut sim = Sim::new(s.config.clone());
    let per_ms = (1e-3 / sim.cfg.dt_s).round() as u64;
    let (wx, wy) = sim.cfg.wand.at(0.0).expect("a wand");
    let mut class = None;
    let mut oracle_path_rad = None;
    let mut estimate_s = None;
    let mut oracle_path = Vec::new();
    let mut marked = Vec::new();
    let mut first_request = None;
    let mut goal_time_s = None;
    let mut unreachable = None;
    let mut report: Option<(f64, u32)> = None;
    let (mut walls, mut approach, mut prev_mode) = (0, 0, 0);
    while !sim.done() {
        sim.step();
        if !sim.steps.is_multiple_of(per_ms) {
            continue;
        }
        let t = sim.t_s();
        if class.is_none() && t >= ORACLE_AT_S {
            let m = marked_pixels(&mut sim);
            let o = Oracle::new(&m);
            if samples.is_some() {
                marked = m;
            }
            let start = cell(s.config.start_rad);
            let p = poses(wx, wy);
            let goals = [cell(p[0]), cell(p[1])];
            match o.astar(start, &goals) {
                Some(path) => {
                    // From the start pose itself to the goal pose itself.
                    let mut w: Vec<[f64; 2]> = o.shorten(&path).iter().map(centre).collect();
                    w[0] = s.config.start_rad;
                    let last = *path.last().expect("a path");
                    let gp = if idx(last) == idx(goals[0]) {
                        p[0]
                    } else {
                        p[1]
                    };
                    let end = w.len() - 1;
                    let near = |a: f64, to: f64| to + (a - to + PI).rem_euclid(TAU) - PI;
                    w[end] = [near(gp[0], w[end][0]), near(gp[1], w[end][1])];
                    oracle_path_rad = Some(
                        w.windows(2)
                            .map(|q| (q[1][0] - q[0][0]).hypot(q[1][1] - q[0][1]))
                            .sum(),
                    );
                    estimate_s = Some(time_estimate(&w));
                    oracle_path = path.iter().map(centre).collect();
                    class = Some(Class::Solvable);
                }
                None => {
                    let loose = o.loose();
                    class = Some(if loose.astar(start, &goals).is_some() {
                        Class::Marginal
                    } else if loose.blocked(goals[0]) && loose.blocked(goals[1]) {
                        Class::GoalInObstacle
                    } else {
                        Class::Enclosed
                    });
                }
            }
        }
        let rec = vme_map::PLANNER_GOAL.read(&mut sim.bus()).ok().map(|r| r.0);
        if let Some(r) = rec {
            let m = r.mode & 0xFF;
            if first_request.is_none() && m == planner_mode::FREE {
                first_request = Some(t);
            }
            if m == planner_mode::WALL && prev_mode != planner_mode::WALL {
                walls += 1;
            }
            prev_mode = m;
            approach = approach.max((r.mode >> 8) & 0xFF);
            if m == planner_mode::UNREACHABLE {
                report.get_or_insert((t - first_request.unwrap_or(0.0), r.reason));
            } else {
                report = None;
            }
            // A report that stands for REPORT_HOLD_S is the planner's verdict.
            if let Some((u, why)) = report {
                if unreachable.is_none() && t - first_request.unwrap_or(0.0) >= u + REPORT_HOLD_S {
                    unreachable = Some((u, why));
                }
            }
        }
        if let Some(v) = samples.as_deref_mut() {
            v.push(crate::run::sample(&mut sim));
        }
        let [a, b] = sim.plant.angles_rad();
        let (x, y) = tip(a, b);
        if goal_time_s.is_none() && (x - wx).hypot(y - wy) <= 0.01 {
            goal_time_s = Some(t - first_request.unwrap_or(0.0));
        }
        // Done once decided and the oracle has spoken (a reached goal is held a moment
        // more for the collision check).
        let decided = goal_time_s.is_some_and(|g| t - first_request.unwrap_or(0.0) > g + 0.2)
            || unreachable.is_some();
        if decided && class.is_some() {
            break;
        }
    }
    SceneResult {
        index: s.index,
        class: class.unwrap_or(Class::Enclosed),
        oracle_path_rad,
        estimate_s,
        oracle_path,
        marked,
        collisions: sim.collisions.events,
        min_clearance_m: sim.collisions.min_clearance_m,
        goal_time_s,
        unreachable,
        walls,
        approach,
        ran_s: sim.t_s(),
    }
}

/// A campaign's figures (`summary.json`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    /// Campaign seed.
    pub seed: u64,
    /// Scenes run.
    pub scenes: u64,
    /// Solvable scenes (by the oracle).
    pub solvable: u64,
    /// Solvable scenes whose goal was reached.
    pub solvable_reached: u64,
    /// Solvable scenes the planner reported unreachable (wrongly).
    pub solvable_reported_unreachable: u64,
    /// Solvable scenes neither reached nor reported by the end.
    pub solvable_undecided: u64,
    /// Marginal scenes (a way only closer than a pixel to an obstacle), and how many of
    /// them were reached, reported unreachable, undecided.
    pub marginal: [u64; 4],
    /// Unsolvable scenes (goal inside an obstacle, enclosed).
    pub unsolvable: [u64; 2],
    /// Unsolvable scenes the planner reported unreachable.
    pub unsolvable_reported: u64,
    /// Unsolvable scenes whose tip nevertheless came within 1 cm of the wand (the goal
    /// closer than a pixel to an obstacle, which the reflex allows).
    pub unsolvable_reached: u64,
    /// Longest time to report an unsolvable scene, s.
    pub report_time_max_s: f64,
    /// Scenes with collisions (must be 0) and their contacts.
    pub scenes_with_collisions: u64,
    /// Separate contacts over all scenes.
    pub collisions: u64,
    /// Smallest clearance over all scenes, m.
    pub min_clearance_m: f64,
    /// Median time to goal over reached solvable scenes, s.
    pub time_to_goal_median_s: f64,
    /// Median of the oracle's estimate over the same scenes, s.
    pub estimate_median_s: f64,
    /// Median over those scenes of time to goal / estimate.
    pub ratio_median: f64,
    /// The same over the reached scenes that needed wall following.
    pub walls_ratio_median: f64,
    /// Median time to goal over the reached scenes that needed wall following, s.
    pub walls_time_median_s: f64,
    /// Median estimate over the same scenes, s.
    pub walls_estimate_median_s: f64,
    /// Solvable scenes that needed wall following.
    pub scenes_with_walls: u64,
    /// Scenes where the planner went round to its hit point (a loop caught) and tried
    /// another approach.
    pub scenes_with_approach_changes: u64,
    /// Indices of scenes with collisions, and of solvable scenes not reached.
    pub collision_scenes: Vec<u64>,
    /// Indices of solvable scenes not reached.
    pub missed_scenes: Vec<u64>,
    /// Indices of unsolvable scenes neither reported nor reached.
    pub unreported_scenes: Vec<u64>,
    /// Wall-clock seconds.
    pub wall_s: f64,
}

/// Runs `n` scenes with seed `seed` on `threads` threads (results in index order).
pub fn campaign(
    seed: u64,
    n: u64,
    threads: usize,
    progress: &(dyn Fn() + Sync),
) -> (Summary, Vec<SceneResult>) {
    let start = std::time::Instant::now();
    let mut results =
        crate::campaign::in_parallel(n, threads, progress, |i| run_scene(&scene(seed, i), None));
    results.sort_by_key(|r| r.index);
    let solv: Vec<&SceneResult> = results
        .iter()
        .filter(|r| r.class == Class::Solvable)
        .collect();
    let uns: Vec<&SceneResult> = results
        .iter()
        .filter(|r| matches!(r.class, Class::GoalInObstacle | Class::Enclosed))
        .collect();
    let marg: Vec<&SceneResult> = results
        .iter()
        .filter(|r| r.class == Class::Marginal)
        .collect();
    let reached: Vec<&SceneResult> = solv
        .iter()
        .copied()
        .filter(|r| r.goal_time_s.is_some())
        .collect();
    let walls: Vec<&SceneResult> = reached.iter().copied().filter(|r| r.walls > 0).collect();
    let [solvable_reached, solvable_reported_unreachable, solvable_undecided] = outcomes(&solv);
    let [m_reached, m_reported, m_undecided] = outcomes(&marg);
    let [time_to_goal_median_s, estimate_median_s, ratio_median] = medians(&reached);
    let [walls_time_median_s, walls_estimate_median_s, walls_ratio_median] = medians(&walls);
    let hits = crate::campaign::collision_figures(
        results
            .iter()
            .map(|r| (r.index, r.collisions, r.min_clearance_m)),
    );
    let summary = Summary {
        seed,
        scenes: n,
        solvable: solv.len() as u64,
        solvable_reached,
        solvable_reported_unreachable,
        solvable_undecided,
        marginal: [marg.len() as u64, m_reached, m_reported, m_undecided],
        unsolvable: [
            uns.iter()
                .filter(|r| r.class == Class::GoalInObstacle)
                .count() as u64,
            uns.iter().filter(|r| r.class == Class::Enclosed).count() as u64,
        ],
        unsolvable_reported: uns.iter().filter(|r| r.unreachable.is_some()).count() as u64,
        unsolvable_reached: uns
            .iter()
            .filter(|r| r.unreachable.is_none() && r.goal_time_s.is_some())
            .count() as u64,
        report_time_max_s: uns
            .iter()
            .filter_map(|r| r.unreachable.map(|u| u.0))
            .fold(0.0, f64::max),
        scenes_with_collisions: hits.scenes.len() as u64,
        collisions: hits.contacts,
        min_clearance_m: hits.min_clearance_m,
        time_to_goal_median_s,
        estimate_median_s,
        ratio_median,
        walls_ratio_median,
        walls_time_median_s,
        walls_estimate_median_s,
        scenes_with_walls: solv.iter().filter(|r| r.walls > 0).count() as u64,
        scenes_with_approach_changes: results.iter().filter(|r| r.approach > 0).count() as u64,
        collision_scenes: hits.scenes,
        missed_scenes: solv
            .iter()
            .filter(|r| r.goal_time_s.is_none())
            .map(|r| r.index)
            .collect(),
        unreported_scenes: uns
            .iter()
            .filter(|r| r.unreachable.is_none() && r.goal_time_s.is_none())
            .map(|r| r.index)
            .collect(),
        wall_s: start.elapsed().as_secs_f64(),
    };
    (summary, results)
}

/// How scenes ended: the goal reached; reported unreachable (and not reached); neither.
fn outcomes(rs: &[&SceneResult]) -> [u64; 3] {
    let count = |f: &dyn Fn(&SceneResult) -> bool| rs.iter().filter(|r| f(r)).count() as u64;
    [
        count(&|r| r.goal_time_s.is_some()),
        count(&|r| r.goal_time_s.is_none() && r.unreachable.is_some()),
        count(&|r| r.goal_time_s.is_none() && r.unreachable.is_none()),
    ]
}

/// Medians over reached scenes `rs` of the time to goal, the oracle's estimate and their
/// ratio (NaN for none).
fn medians(rs: &[&SceneResult]) -> [f64; 3] {
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
    };
    [
        median(rs.iter().filter_map(|r| r.goal_time_s).collect()),
        median(rs.iter().filter_map(|r| r.estimate_s).collect()),
        median(
            rs.iter()
                .filter_map(|r| Some(r.goal_time_s? / r.estimate_s?.max(1e-3)))
                .collect(),
        ),
    ]
}

/// A scenario file that replays scene `s` (`sim-host run`).
pub fn scenario_text(seed: u64, s: &Scene) -> String {
    crate::campaign::scenario_text_titled(
        &format!("planner campaign scene {} (campaign seed {seed})", s.index),
        &s.config,
    )
}

/// Writes the pictures of scene `i`: the C-space path with the oracle's path.
pub fn picture(seed: u64, i: u64, out: &Path) -> Result<SceneResult, String> {
    let s = scene(seed, i);
    let mut samples = Vec::new();
    let r = run_scene(&s, Some(&mut samples));
    let disks: Vec<Disk> = s.config.obstacles.iter().map(|o| o.start).collect();
    let exact = crate::run::exact_pixels(&disks);
    let (wx, wy) = s.config.wand.at(0.0).expect("a wand");
    let p = poses(wx, wy);
    let end = samples.last().map_or(s.config.start_rad, |q| q.theta_rad);
    let d = |q: [f64; 2]| {
        let w = |a: f64| (a + PI).rem_euclid(TAU) - PI;
        w(q[0] - end[0]).abs().max(w(q[1] - end[1]).abs())
    };
    let goal = if d(p[0]) <= d(p[1]) { p[0] } else { p[1] };
    let outcome = match (r.goal_time_s, r.unreachable) {
        (Some(t), _) => format!("reached in {t:.2} s"),
        (None, Some((t, why))) => format!("reported unreachable ({why}) after {t:.2} s"),
        _ => "undecided".into(),
    };
    let est = r
        .estimate_s
        .map_or(String::new(), |e| format!(", oracle {e:.2} s"));
    crate::plots::cspace_path(
        &out.join(format!("scene-{i}.png")),
        &format!("planner scene {i}: {outcome}{est}"),
        &crate::plots::PathPicture {
            marked: &r.marked,
            exact: &exact,
            goal: Some(goal),
            oracle: &r.oracle_path,
        },
        &samples,
    )?;
    Ok(r)
}

/// Runs a campaign and writes `summary.json`, `scenes.csv`, a scenario file per scene with
/// a collision or a missed goal, and pictures of the first `pictures` scenes that needed
/// wall following.
pub fn run_to_dir(
    seed: u64,
    n: u64,
    threads: usize,
    pictures: usize,
    out: &Path,
    progress: &(dyn Fn() + Sync),
) -> Result<Summary, String> {
    let io = |e: std::io::Error| format!("{}: {e}", out.display());
    let (summary, results) = campaign(seed, n, threads, progress);
    crate::campaign::write_summary(out, &summary)?;
    let mut csv = String::from(
        "index,class,oracle_path_rad,estimate_s,goal_time_s,unreachable_s,reason,walls,approach,collisions,min_clearance_m,ran_s\n",
    );
    let opt = |v: Option<f64>| v.map_or(String::new(), |x| format!("{x:.4}"));
    for r in &results {
        let _ = writeln!(
            csv,
            "{},{:?},{},{},{},{},{},{},{},{},{:.4},{:.3}",
            r.index,
            r.class,
            opt(r.oracle_path_rad),
            opt(r.estimate_s),
            opt(r.goal_time_s),
            opt(r.unreachable.map(|u| u.0)),
            r.unreachable.map_or(String::new(), |u| u.1.to_string()),
            r.walls,
            r.approach,
            r.collisions,
            r.min_clearance_m,
            r.ran_s
        );
    }
    std::fs::write(out.join("scenes.csv"), csv).map_err(io)?;
    for &i in summary
        .collision_scenes
        .iter()
        .chain(&summary.missed_scenes)
        .chain(&summary.unreported_scenes)
    {
        std::fs::write(
            out.join(format!("scene-{i}.toml")),
            scenario_text(seed, &scene(seed, i)),
        )
        .map_err(io)?;
    }
    for r in results
        .iter()
        .filter(|r| r.walls > 0 || r.class != Class::Solvable)
        .take(pictures)
    {
        picture(seed, r.index, out)?;
    }
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every disk's centre is inside the calibrated square, where the sensing board places
    /// it to a few millimetres (beyond it, the C-space boards draw the reading over its
    /// fold), and the disks still spread over the square's whole reach.
    #[test]
    fn scenes_keep_their_disks_in_the_calibrated_square() {
        let inside = crate::optics::FIELD_HALF_M - crate::campaign::PLACE_MARGIN_M;
        let mut far = 0;
        for i in 0..300 {
            for o in &scene(5, i).config.obstacles {
                let d = o.start;
                assert!(
                    d.x_m.abs() <= inside && d.y_m.abs() <= inside,
                    "scene {i}: {d:?}"
                );
                far += (d.x_m.hypot(d.y_m) > 0.40) as u32;
            }
        }
        assert!(far > 20, "{far} disks beyond 0.40 m");
    }
}
