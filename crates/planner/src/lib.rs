//! Local planning (thesis ch. VI): a Bug-style planner in C-space that leads the reflex
//! around obstacles it cannot get past alone, and says so when the goal cannot be reached.
//!
//! * **Free mode** (ch. VI section 5): the goal itself is the request to the reflex, which
//!   with the servo executes the thesis's "M-path" (time-optimal motion, deflected by the
//!   reflexes). When the reflex flags a stall (`reflex_flags::STALLED`: at rest, short of the
//!   goal, nowhere safe toward it), the arm's cell is a **hit point** H and the planner turns
//!   to wall following.
//! * **Wall following** (section 4, algorithm step 2): a virtual bug traces the boundary of
//!   the blocked cells ([`grid`]) with the wall on one side, two cells ahead of the arm; its
//!   cell is the request. It ends when (a) the bug meets the **M-line** from H to the goal
//!   closer to the goal than H (a leave point), the line pivoting about H as the goal moves;
//!   (b) the **real trajectory** to the goal is clear ([`sight`]; the thesis's first unbuilt
//!   fix, which ends the looping of fig. VI.2); (c) the bug reaches the goal. A bug that
//!   finds no wall (the map changed) looks for it in the direction it was last felt, a few
//!   cells, and otherwise hands back to free mode (the wall-lost search).
//! * **Hit point glued to the wall** (the second unbuilt fix): every cycle, H is moved along
//!   the M-line to the last free cell before the wall, so that moving obstacles and sensor
//!   noise do not leave it in free space (never revisited) or inside the obstacle.
//! * **Approaches** on the torus (section 4): a bug back at its hit point without a leave
//!   point tries the other way round, then the goal's other pose (elbow the other way) if it
//!   is as reachable, then the goal's other images (reached by turning a link the other way):
//!   sixteen approaches in all. Before the arm commits to a way round, two scouts run both
//!   ways along the wall on the bitmap ([`wall`]); an image no way round leads to is skipped.
//! * **Reachability** ([`fill`], beyond the thesis): a fill of the unmarked pixels from the
//!   arm settles every ~0.1 s; a goal whose poses (elbow either way) are outside it in two
//!   fills running is unreachable: the planner holds the arm where it is and says why (goal
//!   inside an obstacle or enclosed). The same fill picks the pose to go for. Together with the
//!   approaches and a time limit on wall following, no goal makes the planner loop forever.
//!
//! The Bug rule that makes it converge: a leave point by the M-line must be nearer the goal
//! than the hit point, and the M-path from it approaches the goal on both axes (the servo
//! does not overshoot), so successive hit points come strictly nearer the goal. A leave by
//! the clear trajectory needs no such rule while it is right; if the arm stalls again no
//! nearer than before, trajectory leaves must from then on be nearer too.
//!
//! Angles: micro-radians at the interfaces, angle units (2 pi / 32768) and unwrapped pixel
//! cells (256 units) inside. Nothing here touches hardware: the board hands in a
//! [`reflex::window::Map`].
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]

pub mod escape;
pub mod fill;
pub mod grid;
pub mod sight;
#[cfg(test)]
mod tests;
pub mod wall;

use escape::Escape;
use fill::Fill;
use grid::Grid;
use reflex::goal::{self, TURN_URAD};
use reflex::window::Map;
use reflex::{masks, u_to_urad, urad_to_u, ServoView};
use sight::{Sight, Verdict};
use wall::{d2, step_of, toward, Event, Tracer};

use vme_map::records::reflex_flags as rf;
pub use vme_map::records::{planner_mode as mode, planner_reason as reason};

/// Angle units per pixel.
pub const PIX_U: i32 = 256;
/// The bug leads the arm by at most this many cells (Chebyshev).
pub const LEAD_PX: i32 = 2;
/// After a mode change, the reflex's flags are not acted on for this long (its stall flag
/// belongs to the previous request).
pub const SETTLE_US: u32 = 60_000;
/// In free mode, no cell of progress toward the goal for this long is a stall too (the
/// reflex's own stall flag needs the arm at rest, which an arm that backs off from a
/// flickering wall edge and returns never is).
pub const PROGRESS_US: u32 = 300_000;
/// Free mode: blocked at walls on every axis short of the goal, and slow, this long: a
/// stall.
pub const BLOCKED_US: u32 = 60_000;
/// Slower than this (both links) counts as held, micro-radians per second.
pub const SLOW_URAD_S: i32 = 300_000;
/// Wall following longer than this without leaving: the next approach.
pub const WALL_LIMIT_US: u32 = 20_000_000;
/// Steps each scout takes per planner cycle.
pub const SCOUT_STEPS_PER_CYCLE: u32 = 4;
/// Steps after which a scout that has found nothing stops (a success that took this long).
pub const SCOUT_MAX: u32 = 2048;
/// Cells the wall-lost search looks ahead.
pub const SEARCH_PX: i32 = 4;
/// Cells a stalled arm's search for the wall looks ahead toward the goal.
pub const HIT_SEARCH_PX: i32 = 8;
/// Cells the hit point may slide along the M-line per cycle to stay on the wall.
pub const GLUE_PX: i32 = 4;
/// The wand must move this far (either axis, micrometres) for the goal to be recomputed.
pub const WAND_MOVE_UM: i32 = reflex::WAND_MOVE_UM;
/// Approaches before the goal is given up as unreachable (two ways round, for each of the
/// goal's two poses, at each of four images on the torus).
pub const APPROACHES: u32 = 16;
/// Settled fills in a row that must agree the goal is out of reach.
pub const UNREACHABLE_FILLS: u32 = 2;

/// One cycle's inputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Input {
    /// The servo's state, `None` if it read torn.
    pub servo: Option<ServoView>,
    /// The reflex's flags (`ReflexSubgoal::flags`), `None` if unread.
    pub reflex_flags: Option<u32>,
    /// The wand, micrometres, `None` when its beacon is not valid.
    pub wand_um: Option<[i32; 2]>,
}

/// One cycle's outputs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Output {
    /// The request for the reflex (absolute angles).
    pub request_urad: [i32; 2],
    /// [`mode`] code, with the approach in bits 8-15.
    pub mode: u32,
    /// [`reason`] code.
    pub reason: u32,
    /// Whether to publish (false until the first servo state).
    pub publish: bool,
}

/// What the planner is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    /// No goal yet.
    Idle,
    /// Requesting the goal.
    Free,
    /// Following a wall.
    Wall,
    /// Holding: the goal cannot be reached.
    Unreachable(u32),
}

/// How wall following may end early for the goal (thesis ch. VI section 4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Leave {
    /// Ours: when the servo's real path to the goal is clear ([`sight`]), and after a
    /// non-converging stall only nearer the goal than the hit point.
    Trajectory,
    /// The thesis's as built: when the straight line of sight to the goal is clear, from
    /// anywhere; the bug turns one way round every wall (right, reversed only on the next
    /// approach after cycling round to its hit point), without scouts. Loops where the
    /// released arm's real path returns to the wall (fig. VI.2, `fig_vi_2_loop.toml`); kept
    /// to show it.
    LineOfSight,
}

/// Tunable behaviour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// The early-leave rule.
    pub leave: Leave,
}

impl Config {
    /// Ours.
    pub const DEFAULT: Config = Config {
        leave: Leave::Trajectory,
    };
}

/// The planner's state between cycles.
#[derive(Clone, Debug)]
pub struct Planner {
    cfg: Config,
    grid: Grid,
    fill: Fill,
    sight: Sight,
    mode: Mode,
    now_us: u32,
    mode_since_us: u32,
    /// The wand position the goal was last computed from.
    wand_um: [i32; 2],
    /// The goal's two poses (wrapped), valid when `has_goal`.
    poses: [[i32; 2]; 2],
    /// Their cells ([`cell_of`], kept: asked for every cycle).
    pose_cells: [[i32; 2]; 2],
    has_goal: bool,
    /// Which pose is the goal.
    pose: usize,
    /// The pose the approaches start from (the better, or the nearer of equals).
    base_pose: usize,
    /// Goal image offsets in turns per axis (the approach), and the angles they are
    /// relative to.
    image: [i32; 2],
    anchor_urad: [i32; 2],
    approach: u32,
    /// Hit point and its squared distance to the goal (cells).
    hit: [i32; 2],
    hit_d2: i32,
    /// Squared distance of the last hit point to the goal, for the convergence check.
    last_hit_d2: i32,
    /// Trajectory leaves must be nearer than the hit point too.
    strict_sight: bool,
    /// The bug that leads the arm along the wall.
    tracer: Tracer,
    /// The scouts that run both ways round the wall ahead of it, and what they found.
    scout_left: Tracer,
    scout_right: Tracer,
    scout_result: [i32; 2],
    scouting: bool,
    /// The search for a free cell to start wall following from, when the arm stalled in
    /// blocked cells ([`escape`]), and whether it is running (the arm held meanwhile).
    escape: Escape,
    escaping: bool,
    /// Searches for a way out of blocked cells started so far.
    escapes: u32,
    /// The wall's direction from the hit point.
    wall_dir: u32,
    /// Where the arm is held: where it was when the goal became unreachable, or while the
    /// way out of a pocket of blocked cells is searched.
    hold_urad: [i32; 2],
    unreachable_fills: u32,
    /// Settled fills in a row that reached the goal.
    reachable_fills: u32,
    last_request: [i32; 2],
    /// Free mode: the nearest the arm came to the goal (squared cells), and when.
    best_d2: i32,
    best_since_us: u32,
    /// Free mode: the time of the last stall check (a fault hold stops the progress clock
    /// for the time since).
    stall_pass_us: u32,
    /// Free mode: since when the arm has been held at walls.
    held_since_us: u32,
    /// A fill has been started.
    filling: bool,
    /// Which background job this cycle does (map rows or the fill).
    tick: u32,
    /// The hit point's walk along the M-line ([`Planner::glue`]) and what it found.
    walk: [i32; 2],
    found: [i32; 2],
}

impl Default for Planner {
    fn default() -> Self {
        Self::new()
    }
}

#[inline(always)]
fn add(a: [i32; 2], b: [i32; 2]) -> [i32; 2] {
    [a[0] + b[0], a[1] + b[1]]
}

#[inline(always)]
fn cheb(a: [i32; 2], b: [i32; 2]) -> i32 {
    (a[0] - b[0]).abs().max((a[1] - b[1]).abs())
}

/// The cell of an angle pair.
#[inline(always)]
pub fn cell_of(a_urad: [i32; 2]) -> [i32; 2] {
    [urad_to_u(a_urad[0]) >> 8, urad_to_u(a_urad[1]) >> 8]
}

/// The centre of a cell, micro-radians.
#[inline(always)]
pub fn centre_urad(c: [i32; 2]) -> [i32; 2] {
    [
        u_to_urad(c[0] * PIX_U + PIX_U / 2),
        u_to_urad(c[1] * PIX_U + PIX_U / 2),
    ]
}

impl Planner {
    /// A fresh planner.
    pub const fn new() -> Self {
        Self::with_config(Config::DEFAULT)
    }

    /// A fresh planner with `cfg`.
    pub const fn with_config(cfg: Config) -> Self {
        Self {
            cfg,
            grid: Grid::new(),
            fill: Fill::new(),
            sight: Sight::new(),
            mode: Mode::Idle,
            now_us: 0,
            mode_since_us: 0,
            wand_um: [0; 2],
            poses: [[0; 2]; 2],
            pose_cells: [[0; 2]; 2],
            has_goal: false,
            pose: 0,
            base_pose: 0,
            image: [0; 2],
            anchor_urad: [0; 2],
            approach: 0,
            hit: [0; 2],
            hit_d2: 0,
            last_hit_d2: i32::MAX,
            strict_sight: false,
            tracer: Tracer::IDLE,
            scout_left: Tracer::IDLE,
            scout_right: Tracer::IDLE,
            scout_result: [0; 2],
            scouting: false,
            escape: Escape::new(),
            escaping: false,
            escapes: 0,
            wall_dir: 0,
            hold_urad: [0; 2],
            unreachable_fills: 0,
            reachable_fills: 0,
            last_request: [0; 2],
            best_d2: i32::MAX,
            best_since_us: 0,
            stall_pass_us: 0,
            held_since_us: 0,
            filling: false,
            tick: 0,
            walk: [0; 2],
            found: [0; 2],
        }
    }

    /// How many times the arm stalled in blocked cells and the planner searched for the
    /// way out ([`escape`]): for benches and tests.
    pub fn escapes(&self) -> u32 {
        self.escapes
    }

    /// The goal in use: the chosen pose at the approach's image (absolute micro-radians).
    pub fn goal_urad(&self) -> Option<[i32; 2]> {
        self.has_goal.then(|| self.target())
    }

    /// The goal in use (valid once there is one): the chosen pose at the approach's image.
    /// Returned by value, not as an `Option` (a struct returned through a pointer broke on
    /// the 68k: docs/toolchain.md, class 7).
    #[inline(never)]
    fn target(&self) -> [i32; 2] {
        let p = self.poses[self.pose];
        [
            goal::nearest(p[0], self.anchor_urad[0]) + self.image[0] * TURN_URAD,
            goal::nearest(p[1], self.anchor_urad[1]) + self.image[1] * TURN_URAD,
        ]
    }

    fn set_mode(&mut self, m: Mode) {
        self.mode = m;
        self.escaping = false;
        self.mode_since_us = self.now_us;
        self.best_d2 = i32::MAX;
        self.best_since_us = self.now_us;
        self.stall_pass_us = self.now_us;
    }

    /// One planner cycle.
    #[inline(never)]
    pub fn step<M: Map + ?Sized>(&mut self, inp: &Input, map: &mut M) -> Output {
        let mut out = Output {
            request_urad: self.last_request,
            mode: mode::HOLD,
            reason: reason::NONE,
            publish: false,
        };
        // The background work takes turns, a cycle each: reading the map into the bitmap,
        // then the reachability fill (together they were more than a 1 ms cycle on the
        // 68020).
        self.tick ^= 1;
        if self.tick != 0 {
            self.grid.refresh(map, grid::ROWS_PER_CYCLE);
        }
        let Some(sv) = inp.servo else {
            // Keep publishing the last request: the reflex holds if the record stops.
            out.publish = self.has_goal;
            out.reason = reason::SERVO;
            return out;
        };
        self.now_us = sv.t_us;
        let arm = cell_of(sv.theta_urad);
        out.publish = true;

        // The reachability fill, always running.
        // Fills alternate: through the marked pixels (the verdict), then through the
        // blocked cells (which pose the planner can lead the arm to).
        let before = self.fill.settled();
        if self.tick == 0 && self.fill.work(&self.grid, fill::ROWS_PER_CYCLE) != 0 {
            let clear = self.fill.is_clear();
            if self.fill.settled() != before && !clear {
                self.judge(sv.theta_urad);
            }
            self.fill.start(&self.grid, arm, !clear);
        } else if !self.filling {
            // The first fill, once the whole map has been read.
            if self.grid.sweeps() > 0 {
                self.fill.start(&self.grid, arm, false);
                self.filling = true;
            }
        }

        // The goal.
        if let Some(w) = inp.wand_um {
            let moved = (w[0] - self.wand_um[0]).abs() > WAND_MOVE_UM
                || (w[1] - self.wand_um[1]).abs() > WAND_MOVE_UM;
            if !self.has_goal || moved {
                self.new_goal(w, sv.theta_urad);
            }
        }
        if !self.has_goal || self.grid.sweeps() == 0 {
            self.last_request = sv.arrest_urad;
            out.request_urad = sv.arrest_urad;
            out.mode = mode::IDLE;
            out.reason = reason::NO_GOAL;
            return out;
        }
        if self.mode == Mode::Idle {
            self.start_approach(0, sv.theta_urad);
        }
        let goal_urad = self.target();
        let goal_c = cell_of(goal_urad);
        let flags = inp.reflex_flags.unwrap_or(0);

        match self.mode {
            Mode::Idle => {}
            Mode::Unreachable(_) => {}
            Mode::Free => {
                if self.free_stall(arm, goal_c, flags, &sv.omega_urad_s) != 0 {
                    self.hit_wall(arm, goal_c, sv.theta_urad);
                }
            }
            Mode::Wall => self.follow(arm, goal_c, sv),
        }

        let (req, m, why) = match self.mode {
            Mode::Idle | Mode::Free => (goal_urad, mode::FREE, reason::NONE),
            Mode::Wall if self.escaping => (self.hold_urad, mode::WALL, reason::NONE),
            Mode::Wall => (centre_urad(self.tracer.bug), mode::WALL, reason::NONE),
            Mode::Unreachable(r) => (self.hold_urad, mode::UNREACHABLE, r),
        };
        self.last_request = req;
        out.request_urad = req;
        out.mode = m | (self.approach << 8);
        out.reason = why;
        out
    }

    /// Free mode: 1 when the arm stalled short of the goal cell `goal` (more than a cell
    /// away; the reflex's flag
    /// for the planner's goal, or no cell of progress for [`PROGRESS_US`]) once the mode
    /// has settled. Sign masks, not compares and branches (docs/toolchain.md).
    #[inline(never)]
    fn free_stall(
        &mut self,
        arm: [i32; 2],
        goal: [i32; 2],
        flags: u32,
        omega_urad_s: &[i32; 2],
    ) -> u32 {
        let d = d2(arm, goal);
        let better = masks::lt(d, self.best_d2);
        self.best_d2 = masks::pick(better, d, self.best_d2);
        // A pass the reflex held the arm on a bad input (`HOLD`: the arm at its arrest point)
        // is no evidence of a wall: the clock of time without progress stops for it (its
        // start moves on by the pass). As images the reflex holds on the C-space board's slow
        // passes a fifth of the time; an arm held short of the wall ran out that clock, found
        // no wall ahead and went on to the next approach (fig. VI.5 went round the wall's far
        // end). Restarting the clock instead kept an arm at the wall from ever stalling.
        let hold = (((flags >> rf::HOLD.trailing_zeros()) & 1) as i32).wrapping_neg();
        let pass_us = self.now_us.wrapping_sub(self.stall_pass_us);
        self.stall_pass_us = self.now_us;
        let paused = masks::pick(
            hold,
            self.best_since_us.wrapping_add(pass_us) as i32,
            self.best_since_us as i32,
        );
        self.best_since_us = masks::pick(better, self.now_us as i32, paused) as u32;
        let since_best = self.now_us.wrapping_sub(self.best_since_us) as i32;
        let since_mode = self.now_us.wrapping_sub(self.mode_since_us) as i32;
        let no_progress = masks::lt(PROGRESS_US as i32, since_best);
        let settled = masks::lt(SETTLE_US as i32, since_mode);
        let stalled = (((flags >> rf::STALLED.trailing_zeros())
            & (flags >> rf::FROM_PLANNER.trailing_zeros())
            & 1) as i32)
            .wrapping_neg();
        // Held at walls: every axis still short of the goal is blocked (the reflex's
        // flags) and the arm is slow, for BLOCKED_US: the stall, sooner than the reflex's
        // own flag (which waits for rest).
        let short = |i: usize| {
            let d = arm[i] - goal[i];
            (d | d.wrapping_neg()) >> 31
        };
        let b1 = (((flags >> rf::BLOCKED1.trailing_zeros()) & 1) as i32).wrapping_neg();
        let b2 = (((flags >> rf::BLOCKED2.trailing_zeros()) & 1) as i32).wrapping_neg();
        let held_axes = (!short(0) | b1) & (!short(1) | b2) & (b1 | b2);
        let slow = masks::lt(masks::abs(omega_urad_s[0]), SLOW_URAD_S)
            & masks::lt(masks::abs(omega_urad_s[1]), SLOW_URAD_S);
        let held = held_axes & slow;
        // A fault hold neither starts nor ends the time held: each restarted that clock, so an
        // arm at a wall waited out its approach (fig. VI.5 went round the other elbow).
        self.held_since_us =
            masks::pick(held | hold, self.held_since_us as i32, self.now_us as i32) as u32;
        let held_long = masks::lt(
            BLOCKED_US as i32,
            self.now_us.wrapping_sub(self.held_since_us) as i32,
        ) & held;
        // Short of the goal: further than the cells next to it. (An arm resting at the goal
        // one cell over, where the wand's noise put the goal cell, counted as stalled after
        // PROGRESS_US and set off round the other approaches, elbow flip and all.)
        // Nor at either of the goal's poses on any image of the torus (an arm at the goal
        // never sets off round an approach), unless the map marks that pose's pixel: an arm
        // stopped against an obstacle next to the goal's marked other pose, while going for
        // the free one, never stalled and waited there for ever (a case
        // `reaches_every_reachable_goal` found).
        let at = |c: [i32; 2]| {
            let w = |i: usize| masks::abs(((arm[i] - c[i] + 64) & 127) - 64);
            let inside = (self.grid.marked(c) as i32).wrapping_neg();
            masks::lt(1, w(0)) | masks::lt(1, w(1)) | inside
        };
        let away = masks::lt(2, d) & at(self.pose_cells[0]) & at(self.pose_cells[1]);
        (settled & (stalled | no_progress | held_long) & away & 1) as u32
    }

    /// A new goal from the wand: its two poses; the pose the last fill reached (nearest the
    /// arm among equals), chosen again on every move; the approach starts over if the goal
    /// moved by more than a cell. (Keeping the pose through moves within a cell, the wand's
    /// noise, kept fig. VI.5 as images from flipping an approach on the goal's other elbow
    /// back, but cost the demo campaign a quarter of its goals: 62 of 100 natively against
    /// 87; docs/planner.md.)
    fn new_goal(&mut self, w: [i32; 2], theta: [i32; 2]) {
        let had = self.has_goal;
        let old = cell_of(self.target());
        self.wand_um = w;
        let poses = goal::inverse(w[0], w[1]);
        self.poses = poses;
        self.pose_cells = [cell_of(poses[0]), cell_of(poses[1])];
        self.has_goal = true;
        self.base_pose = self.pick_pose(theta);
        self.pose = self.base_pose;
        let jump = !had || cheb(old, cell_of(self.target())) > 1;
        if jump && self.mode != Mode::Idle {
            // Keep the approach's image offsets relative to where the arm is now.
            self.start_approach(0, theta);
        }
    }

    /// The pose to go for: one the last settled fill reached, else the nearest.
    fn pick_pose(&self, theta: [i32; 2]) -> usize {
        let first = (goal::second_nearer(self.poses, theta) & 1) as usize;
        self.better_pose(first)
    }

    /// Of the goal's poses, `first` unless the other scores better ([`Planner::score`]).
    /// The poses are indexed in `self`: a local copy indexed by the other pose's number
    /// lost its index on the 68k (docs/toolchain.md, class 6), so the image compared pose 0
    /// with itself and never switched poses where the native board did (found by the
    /// planner bench's "stalled within the clearance" case).
    #[inline(never)]
    fn better_pose(&self, first: usize) -> usize {
        // Indices masked (no bounds checks) and a sign mask, not a compare and branch: the
        // branch drew a condition-code clobber (docs/toolchain.md, class 1).
        let first = first & 1;
        let other = first ^ 1;
        let better = masks::lt(
            self.score(self.poses[first]) as i32,
            self.score(self.poses[other]) as i32,
        );
        masks::pick(better, other as i32, first as i32) as usize
    }

    /// How good a pose is to go for: reached through the marked pixels by the last fill (or
    /// no fill yet) counts 4, through the blocked cells 2, clear of the blocked cells 1.
    fn score(&self, pose: [i32; 2]) -> u32 {
        let c = cell_of(pose);
        let reached = (self.fill.reached(c) != 0) as u32;
        let clear = (self.fill.reached_clear(c) != 0) as u32;
        4 * reached + 2 * clear + (self.grid.blocked(c) ^ 1)
    }

    /// Approach `k`: the goal image and the way round (module docs).
    fn start_approach(&mut self, k: u32, theta: [i32; 2]) {
        self.approach = k;
        self.anchor_urad = theta;
        // Odd pairs of approaches go for the goal's other pose (elbow the other way).
        self.pose = self.base_pose ^ ((k >> 1) & 1) as usize;
        let p = self.poses[self.pose];
        let away = |i: usize| {
            let g = goal::nearest(p[i], theta[i]);
            if g >= theta[i] {
                -1
            } else {
                1
            }
        };
        let img = k >> 2;
        self.image = match img {
            0 => [0, 0],
            1 => [away(0), away(1)],
            2 => [0, away(1)],
            _ => [away(0), 0],
        };
        self.last_hit_d2 = i32::MAX;
        self.strict_sight = false;
        self.sight.stop();
        self.set_mode(Mode::Free);
    }

    /// The next approach, or unreachable when all were tried.
    fn next_approach(&mut self, theta: [i32; 2]) {
        let k = self.approach + 1;
        self.try_approach(k, theta);
    }

    /// Approach `k` or the first after it worth trying (the other pose only if it is as
    /// good), or unreachable when all were tried.
    fn try_approach(&mut self, mut k: u32, theta: [i32; 2]) {
        let other = 1 - self.base_pose;
        let worse = masks::lt(
            self.score(self.poses[other]) as i32,
            self.score(self.poses[self.base_pose]) as i32,
        );
        // An approach to the other pose when it is worse: on to the next image's first.
        let skip = worse & (((k >> 1) & 1) as i32).wrapping_neg();
        k = masks::pick(skip, ((k | 3) + 1) as i32, k as i32) as u32;
        if k >= APPROACHES {
            self.hold_urad = theta;
            self.set_mode(Mode::Unreachable(reason::CYCLED));
        } else {
            self.start_approach(k, theta);
        }
    }

    /// The next image of the goal (its first approach), or unreachable when all were
    /// tried.
    fn next_image(&mut self, theta: [i32; 2]) {
        let k = (self.approach | 1) + 1;
        self.try_approach(k, theta);
    }

    /// A settled fill: the goal reachable or not.
    fn judge(&mut self, theta: [i32; 2]) {
        if !self.has_goal {
            return;
        }
        let cells = self.pose_cells;
        let r0 = self.fill.reached(cells[0]);
        let r1 = self.fill.reached(cells[1]);
        if r0 == 1 || r1 == 1 {
            self.unreachable_fills = 0;
            self.reachable_fills = self.reachable_fills.saturating_add(1);
            let held = matches!(self.mode, Mode::Unreachable(_));
            // Go for a pose the fill reached, clear of blocked cells if one is (a goal
            // given up is taken up again only as below).
            let want = self.better_pose(self.base_pose);
            if want != self.base_pose {
                self.base_pose = want;
                if self.mode != Mode::Idle && !held {
                    let theta = self.anchor_urad;
                    self.start_approach(0, theta);
                }
            }
            // A goal given up after every approach (`CYCLED`) is taken up again only when
            // a fill finds a way to a pose with the planner's clearance: where the only way
            // passes within a pixel of an obstacle (the fill through the marked pixels gets
            // there, the planner's moves cannot), taking it up again went round every
            // approach again, for ever (a case `reaches_every_reachable_goal` found).
            // A goal found unreachable by the fills is taken up again when as many fills in
            // a row reach it as it took to give it up: a goal on an obstacle's noisy edge
            // (campaign seed 3 scene 691) flickered between given up and taken up again on
            // single fills, the arm never long enough at either to be reported.
            if let Mode::Unreachable(why) = self.mode {
                let clear = self.fill.reached_clear(cells[0]) == 1
                    || self.fill.reached_clear(cells[1]) == 1;
                let again = if why == reason::CYCLED {
                    clear
                } else {
                    self.reachable_fills >= UNREACHABLE_FILLS
                };
                if again {
                    let theta = self.hold_urad;
                    self.start_approach(0, theta);
                }
            }
            return;
        }
        self.reachable_fills = 0;
        self.unreachable_fills += 1;
        if self.unreachable_fills >= UNREACHABLE_FILLS {
            if let Mode::Unreachable(_) = self.mode {
                return;
            }
            let inside = self.grid.marked(cells[0]) & self.grid.marked(cells[1]);
            let why = if inside != 0 {
                reason::GOAL_IN_OBSTACLE
            } else {
                reason::ENCLOSED
            };
            self.hold_urad = theta;
            self.sight.stop();
            self.set_mode(Mode::Unreachable(why));
        }
    }

    /// The reflex stalled at `arm` short of `goal`: a hit point, wall following. An arm
    /// stalled in blocked cells is held while the way out is searched ([`escape`]); wall
    /// following starts from the free cell found.
    fn hit_wall(&mut self, arm: [i32; 2], goal: [i32; 2], theta: [i32; 2]) {
        if self.grid.blocked(arm) != 0 {
            self.escape.start(arm, goal);
            self.escapes = self.escapes.wrapping_add(1);
            self.hold_urad = theta;
            self.sight.stop();
            self.set_mode(Mode::Wall);
            self.escaping = true;
            return;
        }
        self.wall_from(arm, goal, theta);
    }

    /// Wall following from free cell `start` toward `goal`: the wall is looked for toward
    /// the goal, and the scouts run both ways round it.
    fn wall_from(&mut self, start: [i32; 2], goal: [i32; 2], theta: [i32; 2]) {
        let d = d2(start, goal);
        if d >= self.last_hit_d2 && self.cfg.leave == Leave::Trajectory {
            // No nearer than the last hit point: the M-path did not converge.
            if self.strict_sight {
                self.next_approach(theta);
                return;
            }
            self.strict_sight = true;
        }
        // The wall: the blocked neighbour toward the goal, probing a few cells ahead.
        self.walk = start;
        let w = find_wall(&self.grid, &mut self.walk, goal);
        let c = self.walk;
        if w >= 4 {
            // Stalled with no wall in sight (the goal within the planner's clearance of an
            // obstacle, where the reflex stops short): the next approach.
            self.next_approach(theta);
            return;
        }
        self.hit = c;
        self.hit_d2 = d2(c, goal);
        self.last_hit_d2 = self.hit_d2;
        self.wall_dir = w;
        // Scout both ways round before the arm commits (module docs). The thesis's planner
        // as built turns one way, right (positive rotation about the wall), and reverses
        // only on an approach after cycling round to its hit point.
        self.scout_left = Tracer::new(c, w, 1, c, goal);
        self.scout_right = Tracer::new(c, w, 3, c, goal);
        self.scout_result = [0; 2];
        let thesis = self.cfg.leave == Leave::LineOfSight;
        self.scouting = !thesis;
        let side = if thesis {
            3 - 2 * (self.approach & 1)
        } else {
            1
        };
        self.tracer = Tracer::new(c, w, side, c, goal);
        self.sight.stop();
        self.set_mode(Mode::Wall);
    }

    /// Runs the scouts a slice further; when both are done, starts the bug the better way
    /// round, or gives up this image of the goal if neither way leads anywhere.
    fn scout(&mut self, goal: [i32; 2], theta: [i32; 2]) {
        let mut n = 0;
        while n < SCOUT_STEPS_PER_CYCLE {
            if self.scout_result[0] == 0 {
                let e = self
                    .scout_left
                    .step(&self.grid, self.hit, self.hit_d2, goal);
                self.scout_result[0] = verdict(e, self.scout_left.steps);
            }
            if self.scout_result[1] == 0 {
                let e = self
                    .scout_right
                    .step(&self.grid, self.hit, self.hit_d2, goal);
                self.scout_result[1] = verdict(e, self.scout_right.steps);
            }
            n += 1;
        }
        // Results: 0 still going, steps + 1 on success, FAIL on failure. Decided once both
        // are in; computed with sign masks, not compares and branches (docs/toolchain.md).
        let [l, r] = self.scout_result;
        let nz = |x: i32| (x | x.wrapping_neg()) >> 31;
        if nz(l) & nz(r) == 0 {
            return;
        }
        self.scouting = false;
        if l & r == FAIL {
            // Neither way round leaves this wall toward this image of the goal.
            self.next_image(theta);
            return;
        }
        // The way that succeeds in fewer steps (left on a tie); odd approaches take the
        // other (the thesis's reversal) unless it is known to fail.
        let right_better = (r - l) >> 31;
        let other = masks::pick(right_better, l, r);
        let flip = (self.approach as i32 & 1).wrapping_neg() & nz(other ^ FAIL);
        let right = right_better ^ flip;
        let side = (1 + (right & 2)) as u32;
        self.tracer = Tracer::new(self.hit, self.wall_dir, side, self.hit, goal);
    }

    /// One wall-following cycle.
    fn follow(&mut self, arm: [i32; 2], goal: [i32; 2], sv: ServoView) {
        if self.escaping {
            match self.escape.work(&self.grid) {
                escape::status::RUNNING => {}
                escape::status::FOUND => {
                    let start = self.escape.found();
                    self.wall_from(start, goal, sv.theta_urad);
                }
                // No free cell the arm can reach nearby: the next approach.
                _ => self.next_approach(sv.theta_urad),
            }
            return;
        }
        if self.scouting {
            // The arm waits at the hit point while the scouts run (the trajectory check
            // waits too: both in one cycle were over 50,000 cycles on the 68020).
            self.scout(goal, sv.theta_urad);
            return;
        }
        self.glue(goal);
        // The real trajectory from the arm to the goal, a slice per cycle.
        match self.sight.work(&self.grid) {
            Verdict::Clear => {
                let near = d2(arm, goal) < self.hit_d2;
                if !self.strict_sight || near || self.cfg.leave == Leave::LineOfSight {
                    self.sight.stop();
                    self.set_mode(Mode::Free);
                    return;
                }
                self.start_sight(sv);
            }
            // Started again on a cycle without the fill's turn (its square roots and
            // divides are a tenth of a cycle).
            Verdict::Blocked | Verdict::Idle => {
                if self.tick != 0 {
                    self.start_sight(sv);
                }
            }
            Verdict::Running => {}
        }
        if self.now_us.wrapping_sub(self.mode_since_us) > WALL_LIMIT_US {
            self.next_approach(sv.theta_urad);
            return;
        }
        // The bug moves on while the arm keeps up.
        if cheb(arm, self.tracer.bug) > LEAD_PX {
            return;
        }
        if self.tracer.bug == goal {
            self.set_mode(Mode::Free);
            return;
        }
        self.advance(goal, sv.theta_urad);
    }

    fn start_sight(&mut self, sv: ServoView) {
        if self.has_goal {
            let g = self.target();
            self.sight.start(
                [urad_to_u(sv.theta_urad[0]), urad_to_u(sv.theta_urad[1])],
                [urad_to_u(g[0]), urad_to_u(g[1])],
                self.cfg.leave == Leave::LineOfSight,
            );
        }
    }

    /// Moves the bug one cell along the wall and acts on what it found.
    fn advance(&mut self, goal: [i32; 2], theta: [i32; 2]) {
        match self.tracer.step(&self.grid, self.hit, self.hit_d2, goal) {
            Event::Moved | Event::Stuck => {}
            Event::Leave | Event::AtGoal => self.set_mode(Mode::Free),
            // Round the obstacle and back at the hit point: the next approach.
            Event::Cycle => self.next_approach(theta),
            // The map changed under the bug: look for the wall where it was felt.
            Event::Lost => {
                if !self.tracer.relocate(&self.grid, SEARCH_PX) {
                    self.set_mode(Mode::Free);
                }
            }
        }
    }

    /// Keeps the hit point on the wall along the M-line (the second unbuilt fix).
    fn glue(&mut self, goal: [i32; 2]) {
        let h = self.hit;
        let inside = self.grid.blocked(h);
        if inside == 0 && self.grid.blocked(toward(h, goal)) != 0 {
            return;
        }
        // Inside the wall now: back away from the goal to the first free cell; in free
        // space: on toward the goal to the cell before the wall. The walk lives in the
        // planner, not in a register the loop carries (docs/toolchain.md, class 1).
        let m = (inside as i32).wrapping_neg();
        let target = [
            masks::pick(m, 2 * h[0] - goal[0], goal[0]),
            masks::pick(m, 2 * h[1] - goal[1], goal[1]),
        ];
        self.walk = h;
        let mut n = 0;
        while n < GLUE_PX {
            if glue_step(&self.grid, &mut self.walk, &mut self.found, target, inside) != 0 {
                let c = self.found;
                self.set_hit(c, goal);
                return;
            }
            n += 1;
        }
    }

    fn set_hit(&mut self, c: [i32; 2], goal: [i32; 2]) {
        self.hit = c;
        self.hit_d2 = d2(c, goal);
        self.last_hit_d2 = self.last_hit_d2.min(self.hit_d2);
    }
}

/// A scout's failure.
const FAIL: i32 = i32::MAX;

/// One step of the hit point's walk along the M-line (toward `target`): returns 1 when the
/// walk found its cell (put in `found`): the first free cell when it started `inside` the
/// wall, else the last free one before the wall.
#[inline(never)]
fn glue_step(
    g: &Grid,
    walk: &mut [i32; 2],
    found: &mut [i32; 2],
    target: [i32; 2],
    inside: u32,
) -> u32 {
    let next = toward(*walk, target);
    let b = g.blocked(next);
    let m = (inside as i32).wrapping_neg();
    found[0] = masks::pick(m, next[0], walk[0]);
    found[1] = masks::pick(m, next[1], walk[1]);
    *walk = next;
    b ^ inside
}

/// A scout's result after an event: 0 still going, its steps + 1 on success (a leave point,
/// the goal, the end of the wall, or [`SCOUT_MAX`] steps without an answer), [`FAIL`] on
/// failure (back at the hit point, or boxed in).
/// (Sign masks over the event's code, not a match: the match's bit tests drew a
/// condition-code clobber on the 68k, docs/toolchain.md.)
#[inline(never)]
fn verdict(e: Event, steps: u32) -> i32 {
    let code = e as u32;
    // Success: Leave, AtGoal, Lost; failure: Cycle, Stuck (wall::Event's order).
    const SUCCESS: u32 =
        (1 << Event::Leave as u32) | (1 << Event::AtGoal as u32) | (1 << Event::Lost as u32);
    const FAILURE: u32 = (1 << Event::Cycle as u32) | (1 << Event::Stuck as u32);
    let success = ((SUCCESS >> code) & 1) as i32;
    let failure = ((FAILURE >> code) & 1) as i32;
    let moved = ((1u32 << Event::Moved as u32 >> code) & 1) as i32;
    let over = ((SCOUT_MAX as i32 - 1 - steps as i32) >> 31) & 1;
    let done = (success | (moved & over)).wrapping_neg();
    masks::pick(
        done,
        steps as i32 + 1,
        masks::pick(failure.wrapping_neg(), FAIL, 0),
    )
}

/// The wall toward `goal` from free cell `c`, probing up to [`HIT_SEARCH_PX`] cells ahead:
/// the direction of the blocked neighbour (0-3), `c` moved to the cell next to it; 4 when
/// there is none. The cell lives behind a reference, not in a register the loop carries
/// (docs/toolchain.md, class 1: in the planner's step the loop drew a condition-code
/// clobber).
#[inline(never)]
fn find_wall(g: &Grid, c: &mut [i32; 2], goal: [i32; 2]) -> u32 {
    let mut n = 0;
    while n < HIT_SEARCH_PX {
        let dir = dir_toward(*c, goal);
        if g.blocked(add(*c, step_of(dir))) != 0 {
            return dir;
        }
        let o = dir_toward_other(*c, goal, dir);
        // `o` is 4 when there is no way along the other axis: masked, not compared.
        let along = ((o >> 2) ^ 1) & g.blocked(add(*c, step_of(o)));
        if along != 0 {
            return o;
        }
        *c = add(*c, step_of(dir));
        n += 1;
    }
    4
}

/// The direction from `c` toward `g` along the axis with more to go (sign masks).
#[inline(always)]
fn dir_toward(c: [i32; 2], g: [i32; 2]) -> u32 {
    let (x, y) = (g[0] - c[0], g[1] - c[1]);
    let ymajor = masks::lt(masks::abs(x), masks::abs(y));
    let dx = (x >> 31) & 2;
    let dy = 1 + ((y >> 31) & 2);
    masks::pick(ymajor, dy, dx) as u32
}

/// The direction toward `g` along the other axis than `dir`, or 4 if there is no way to go
/// along it (sign masks).
#[inline(always)]
fn dir_toward_other(c: [i32; 2], g: [i32; 2], dir: u32) -> u32 {
    let odd = (dir as i32 & 1).wrapping_neg();
    // Along theta2 when `dir` is along theta1, and the other way round.
    let v = masks::pick(odd, g[0] - c[0], g[1] - c[1]);
    let d = masks::pick(odd, (v >> 31) & 2, 1 + ((v >> 31) & 2));
    let nz = (v | v.wrapping_neg()) >> 31;
    masks::pick(nz, d, 4) as u32
}
