//! Reflex control (thesis ch. V): the arm may go wherever it likes as long as it can always
//! stop in known free space.
//!
//! Each pass takes the servo's published state (angles, velocities, arrest points: the
//! points each link stops at under full braking, V.5) and the goal, and publishes a
//! subgoal for the servo that is safe by construction:
//!
//! * **Invariant.** The servo drives each link independently toward its setpoint without
//!   overshoot (law III.36), so from state (theta, omega) with arrest point a and setpoint g
//!   link i stays within hull(theta_i, a_i, g_i). Until the servo picks up a new setpoint g',
//!   it still follows the previous one g, so the arm stays inside the rectangle
//!   hull(theta, a, g, g') (per axis). The reflex only publishes g' when that rectangle, grown
//!   by margins for everything the model leaves out (latency of the published state and of
//!   the subgoal, the arrest point's own advance at 2 omega (V.6), inertia error, servo
//!   overshoot, obstacles moving up to [`Config::border_px_s`] meanwhile), holds only free
//!   pixels. g' = g always qualifies while the obstacles stand still, so there is always a
//!   safe choice. The subgoal itself keeps as far inside the tested window as obstacles
//!   could advance while the arm stops.
//! * **Lookahead window** (figs. V.4, V.5): that base rectangle is tested whole each pass
//!   (which also finds obstacles that moved into the arrest region, the thesis's backward
//!   search, and around the arm, its "myopic" search), then grown toward the goal one column
//!   and one row at a time, alternately, to a depth that follows speed; each axis stops at
//!   the first obstacle wall ([`window`]).
//! * **Reflex subgoal** (V.6-V.9): the point of the window nearest the goal, kept its margins
//!   inside. Far from obstacles it runs ahead of the arrest point and the servo accelerates
//!   as if the goal itself were set; near one, it stops at the wall and the servo brakes
//!   along that axis only (V.11: one binding axis per obstacle), while the other axis goes on.
//! * **Braking.** If margins grown with speed reach an obstacle, the subgoal is kept within
//!   the arrest region itself: the servo brakes, the margins shrink, growth resumes.
//! * **Escape** (fig. V.10, extended in [`escape`]). If an obstacle covers the arm's
//!   neighbourhood or its arrest region (it moved in, or the arm started inside), the arm
//!   heads for the most open free place it can reach without crossing marked pixels (across
//!   the fewest, when an obstacle that moves has come onto it), a step at a time along the
//!   way there.
//! * **Stall.** At rest, short of the goal, with the subgoal stuck for [`STALL_US`]: flagged
//!   for the planner (ch. VI).
//! * **Fail-safe** ([`health`]): a stale, torn or lagging map, stale obstacle positions, a
//!   stale servo state or a goal source that stopped make the reflex hold the arm at the
//!   arrest point it had when the problem began, and record the fault.
//!
//! Angles: micro-radians at the interfaces (the servo's units); angle units of 2 pi / 32768
//! (256 per map pixel, `crates/cspace`) inside. Nothing here touches hardware: the board
//! hands in a [`window::Map`].
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]

/// The arrest points of the last passes, to hold at the one of the moment an input went
/// quiet (the servo's log, keyed here by the servo's published time, us).
pub use servo::arrest_log;
pub mod escape;
pub mod evade;
pub mod goal;
pub mod health;
pub mod masks;
pub mod script;
pub mod window;

use health::{HealthInput, Monitor, Problem};
use window::{Grow, Grown, Map, Span};

/// Pixels per map axis.
pub const SIDE: u32 = 128;
/// Angle units per map pixel.
pub const PIX_U: i32 = 256;

/// Angle units to micro-radians, Q16.
const U_TO_URAD_Q16: i32 = 12_566_371;
/// 2^32 / 10^6, rounded up: times microseconds, Q32 seconds (never short).
const US_TO_S_Q32: i32 = 4295;

/// 32768 / (2 pi 10^6) in Q24.
const URAD_TO_U_Q24: i32 = 87_496;

/// Micro-radians to angle units (floored; within one unit of exact): one 64-bit product
/// (`fx::mul_floor_shr24`, a `MULS.L` on the 68020; this runs ten times a pass). (Two
/// 32-bit products of the angle's halves before: the same values within 16 turns, 187
/// cycles a call against ~110.)
#[inline(always)]
pub fn urad_to_u(a_urad: i32) -> i32 {
    fx::mul_floor_shr24(a_urad, URAD_TO_U_Q24)
}

/// Angle units to micro-radians (rounded).
pub fn u_to_urad(a_u: i32) -> i32 {
    fx::mul_shr(a_u, U_TO_URAD_Q16, 16)
}

/// A quarter pixel in micro-radians, as [`u_to_urad`] gives it (a call a pass before).
const QUARTER_PX_URAD: i32 = fx::host_mul_shr(PIX_U / 4, U_TO_URAD_Q16, 16);

/// Angles in micro-radians and their angle units (`urad_to_u`), kept while the angles
/// stay: the goal and the previous subgoal mostly do, and each conversion is a 64-bit
/// product called on the 68020 (~100 cycles).
#[derive(Clone, Copy, Debug)]
struct Units {
    urad: [i32; 2],
    u: [i32; 2],
}

impl Units {
    /// Angle 0 in both units.
    const ZERO: Units = Units {
        urad: [0, 0],
        u: [0, 0],
    };

    /// `a_urad` in angle units, converted only if it changed since the last call.
    #[inline(always)]
    fn of(&mut self, a_urad: &[i32; 2]) -> [i32; 2] {
        if (a_urad[0] ^ self.urad[0]) | (a_urad[1] ^ self.urad[1]) != 0 {
            self.urad = *a_urad;
            self.u = [urad_to_u(a_urad[0]), urad_to_u(a_urad[1])];
        }
        self.u
    }
}

/// Fixed margin around every rectangle, angle units (a quarter pixel, 12 mrad): servo
/// overshoot (<= 0.5 mrad, issue 5), observer error, rounding.
pub const MARGIN_U: i32 = 64;
/// Extra margin beyond the arrest point, as a fraction 1 / 2^n of the braking distance:
/// the servo's inertia estimate may be off (issue 5 tests +-20%).
pub const ARREST_SLACK_SHIFT: u32 = 2;
/// Window depth beyond the base rectangle at rest, pixels (thesis: 6 along theta1, 8 along
/// theta2); speed adds twice the arrest point's advance per pass.
pub const DEPTH_PX: i32 = 8;
/// Most pixel words read while growing the window per pass.
pub const GROW_BUDGET: u32 = 1024;
/// Farthest an escape subgoal lies from the arm, each axis, angle units (1.5 pixels; the
/// escape's step is at most [`escape::STEP_PX`] pixels away).
pub const ESCAPE_STEP_U: i32 = 384;
/// Free pixels around an escape target, each side, that the escape looks for (more among
/// moving obstacles; at most [`escape::LEVELS`] - 1).
pub const ESCAPE_CLEAR_PX: i32 = 1;
/// Among moving obstacles: the time the arm needs to react to one (the map's refresh and
/// the servo's first move), over which the arm keeps the distance an obstacle border covers
/// at [`Config::border_px_s`].
pub const REACT_US: i32 = 100_000;
/// At rest, short of the goal, the subgoal stuck this long: stalled.
pub const STALL_US: u32 = 200_000;
/// An arm stuck this long with its own margins on an obstacle backs off to clearance (twice
/// [`STALL_US`]: the stall is flagged first).
pub const FROZEN_US: u32 = 2 * STALL_US;
/// Below this speed (both links) the arm counts as at rest, micro-radians per second.
pub const REST_URAD_S: i32 = 50_000;
/// The goal counts as reached within this distance (each axis), micro-radians (2 encoder
/// counts of link 2).
pub const AT_GOAL_URAD: i32 = 1_600;
/// A servo state that did not change over this many passes is stale.
pub const SERVO_STALE_PASSES: u32 = 20;
/// The wand's goal is recomputed when the wand moves by more than this (each axis),
/// micrometres: about the sensing board's accuracy (issue 6: 0.9 mm rms; a resting wand's
/// position jitters by 1-3 mm peak to peak, so noise moves the goal now and then).
pub const WAND_MOVE_UM: i32 = 1_000;
/// A planner goal record unchanged for this long is stale: the reflex stops advancing.
pub const PLANNER_STALE_US: u32 = 50_000;

/// A hold for an input that went quiet looks up the arrest point this much earlier than the
/// input's limit: its last change can precede the limit by a pass of its board and of ours.
pub const LOG_MARGIN_US: u32 = 5_000;

/// How long before a problem is noticed its input went quiet, by [`Problem`] (a table, not a
/// match: the compares drew a condition-code clobber; docs/toolchain.md). A lagging image
/// is a slow board, not a dead one: 0, the arrest point now.
const QUIET_AGE_US: [u32; 4] = {
    let mut t = [0; 4];
    t[Problem::MapStale as usize] = health::MAP_STALE_US + LOG_MARGIN_US;
    t[Problem::MapLag as usize] = 0;
    t[Problem::MapTorn as usize] = health::MAP_TORN_US + LOG_MARGIN_US;
    t[Problem::ObjectsStale as usize] = health::OBJECTS_STALE_US + LOG_MARGIN_US;
    t
};

/// Bits of the published flags word (`ReflexSubgoal::flags`), defined with the record.
pub use vme_map::records::reflex_flags as flags;

/// The servo's published state, as the reflex uses it. `repr(C)`: the runtime's
/// `__reflex_prepare` reads it (offsets asserted below [`Axis`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct ServoView {
    /// Absolute angles.
    pub theta_urad: [i32; 2],
    /// Velocities.
    pub omega_urad_s: [i32; 2],
    /// Arrest points.
    pub arrest_urad: [i32; 2],
    /// Servo clock of the sample.
    pub t_us: u32,
    /// Servo loop counter.
    pub loops: u32,
}

impl ServoView {
    /// The view of the servo state record's words (`vme_map::records::ServoState`, read
    /// raw by the boards).
    #[inline(never)]
    pub fn from_words(
        w: &[u32; <vme_map::records::ServoState as vme_map::record::Record>::WORDS as usize],
    ) -> Self {
        let mut v = ServoView::ZERO;
        v.set(w);
        v
    }

    /// The fields from the servo state record's words (the one mapping of them).
    #[inline(always)]
    fn set(
        &mut self,
        w: &[u32; <vme_map::records::ServoState as vme_map::record::Record>::WORDS as usize],
    ) {
        self.theta_urad = [w[0] as i32, w[1] as i32];
        self.omega_urad_s = [w[2] as i32, w[3] as i32];
        self.arrest_urad = [w[4] as i32, w[5] as i32];
        self.t_us = w[8];
        self.loops = w[9];
    }

    /// `slot` set to the view of the servo state's words `w` in place (a view returned by
    /// value and moved into the `Option` cost the 68020 a `memcpy` a pass).
    #[inline(never)]
    pub fn fill(
        slot: &mut Option<ServoView>,
        w: &[u32; <vme_map::records::ServoState as vme_map::record::Record>::WORDS as usize],
    ) {
        slot.get_or_insert(ServoView::ZERO).set(w);
    }

    /// All zero (the slot [`ServoView::fill`] starts from).
    pub const ZERO: ServoView = ServoView {
        theta_urad: [0; 2],
        omega_urad_s: [0; 2],
        arrest_urad: [0; 2],
        t_us: 0,
        loops: 0,
    };
}

/// Where the goal comes from this pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GoalInput {
    /// The planner's goal record (absolute angles) and its cycle counter.
    Planner {
        /// The goal.
        goal_urad: [i32; 2],
        /// The planner's cycle counter (must keep changing).
        cycle: u32,
    },
    /// No planner: the wand's sensed position.
    Wand {
        /// x, micrometres.
        x_um: i32,
        /// y, micrometres.
        y_um: i32,
    },
    /// Nothing new (no planner, wand not in view): keep the last goal.
    None,
}

/// One pass's inputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Input {
    /// The servo state, `None` if it read torn.
    pub servo: Option<ServoView>,
    /// The goal.
    pub goal: GoalInput,
    /// The freshness readings.
    pub health: HealthInput,
    /// Some obstacle is moving (the sensing board's flag on a valid obstacle beacon).
    pub obstacles_moving: bool,
}

/// Obstacle slots the reflex is given: one per obstacle beacon of the sensing board, slot
/// `i` for C-space work-list entry `i` (the board checks the count against
/// `cspace::worklist::OBSTACLE_BEACONS`).
pub const OBSTACLES: usize = 6;

/// Every obstacle slot empty: what a map with no sensed obstacles hands the evasion
/// ([`window::Map::obstacle_views`]).
pub static NO_OBSTACLES: [ObstacleView; OBSTACLES] = [ObstacleView::NONE; OBSTACLES];

/// One obstacle as the sensing board publishes it and the C-space boards draw it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ObstacleView {
    /// Whether the slot holds a sensed obstacle.
    pub valid: bool,
    /// Centre x, micrometres (the sensing board's latest position).
    pub x_um: i32,
    /// Centre y, micrometres.
    pub y_um: i32,
    /// Radius, micrometres.
    pub r_um: i32,
    /// Velocity x, micrometres per second (the C-space board's sweep estimate).
    pub vx_um_s: i32,
    /// Velocity y, micrometres per second.
    pub vy_um_s: i32,
    /// The sensing board's time of the position, microseconds.
    pub t_us: u32,
}

impl ObstacleView {
    /// An empty slot.
    pub const NONE: ObstacleView = ObstacleView {
        valid: false,
        x_um: 0,
        y_um: 0,
        r_um: 0,
        vx_um_s: 0,
        vy_um_s: 0,
        t_us: 0,
    };
}

/// Why the reflex holds the arm.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    /// The servo state stopped changing.
    ServoStale,
    /// The servo state read torn beyond retry, pass after pass.
    ServoTorn,
    /// The planner's goal stopped changing.
    PlannerStale,
    /// A problem with the map or the obstacle positions.
    Input(Problem),
}

/// One pass's outputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Output {
    /// Publish this subgoal (absolute angles); `None` before the first servo state.
    pub subgoal_urad: Option<[i32; 2]>,
    /// [`flags`] bits.
    pub flags: u32,
    /// The goal in use (absolute angles, nearest the arm on the torus for the wand's).
    pub goal_urad: [i32; 2],
    /// The window tested: pixel spans along theta1 and theta2.
    pub window: [(i32, i32); 2],
    /// Pixel words read this pass.
    pub tests: u32,
    /// Pixels vouched for this pass without a read: rows of columns read free in earlier
    /// passes whose generations have not moved (`window::Known`).
    pub known: u32,
    /// Servo-clock time since the previous pass.
    pub dt_us: u32,
    /// A fault that started this pass (to record once).
    pub new_fault: Option<Fault>,
}

impl Default for Output {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Output {
    /// No subgoal, nothing tested, no fault (a constant: the boards build theirs in
    /// `const fn`s; [`Output::default`] is this).
    pub const EMPTY: Output = Output {
        subgoal_urad: None,
        flags: 0,
        goal_urad: [0; 2],
        window: [(0, 0); 2],
        tests: 0,
        known: 0,
        dt_us: 0,
        new_fault: None,
    };

    /// Back to [`Output::EMPTY`], field by field (an assignment of the whole value
    /// compiled to a `memset` call on the 68020; a test holds the two together).
    #[inline(always)]
    pub fn clear(&mut self) {
        self.subgoal_urad = None;
        self.flags = 0;
        self.goal_urad = [0; 2];
        self.window = [(0, 0); 2];
        self.tests = 0;
        self.known = 0;
        self.dt_us = 0;
        self.new_fault = None;
    }
}

/// Tunable behaviour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// Fastest a C-space obstacle border may move toward the arm, pixels per second (thesis
    /// line ~1597: 30 for quasi-static obstacles).
    pub border_px_s: i32,
}

impl Config {
    /// The thesis's quasi-static bound.
    pub const DEFAULT: Config = Config { border_px_s: 30 };
}

/// Smallest plausible braking acceleration per link, angle units / s^2: u^ (the servo's
/// fraction of umax) over the inertia with the servo's prior error (1.25 x).
pub const BRAKE_U_S2: [i32; 2] = [brake_u_s2(&arm::LINK1), brake_u_s2(&arm::LINK2)];

const fn brake_u_s2(l: &arm::Link) -> i32 {
    let acc = l.torque_limit_nm * servo::params::TUNED_UHAT_FRACTION
        / (l.inertia_kgm2 * servo::params::PRIOR_INERTIA_SCALE);
    (acc * 32768.0 / (2.0 * core::f64::consts::PI)) as i32
}

/// [`REST_URAD_S`] in angle units per second (rounded up).
const REST_U_S: i32 =
    (REST_URAD_S as f64 * 32768.0 / (2.0 * core::f64::consts::PI * 1e6)) as i32 + 1;

/// 10^6 / [`BRAKE_U_S2`], Q24: microseconds to stop per (angle unit / s) of speed.
const STOP_US_PER_U_S_Q24: [i32; 2] = [
    (16_777_216.0 * 1e6 / BRAKE_U_S2[0] as f64) as i32,
    (16_777_216.0 * 1e6 / BRAKE_U_S2[1] as f64) as i32,
];

/// [`Reflex`]'s `free_px` before any pass had the arm's neighbourhood free: no arm pixel
/// is near it, and differences with it do not overflow.
const NEVER_PX: i32 = 1 << 28;

/// The reflex's state between passes. `repr(C)`, the fields every pass touches first: the
/// 68020's compiled code reaches a field more than 127 bytes from the struct through an
/// index register it loads first (docs/toolchain.md).
#[derive(Clone, Debug)]
#[repr(C)]
pub struct Reflex {
    /// Passes stepped.
    pass: u32,
    torn: u32,
    now_us: u32,
    last_t_us: u32,
    last_loops: u32,
    same_loops: u32,
    /// The last three intervals between the servo states read (us, at most 2^30).
    recent_dt_us: [i32; 3],
    /// The subgoal last published (absolute, micro-radians).
    last: Option<[i32; 2]>,
    /// The goal in use.
    goal: Option<[i32; 2]>,
    /// The goal in angle units.
    goal_units: Units,
    /// The previous subgoal in angle units.
    prev_units: Units,
    /// What a moving obstacle's border covers in [`REACT_US`], angle units (from the
    /// configuration, once: a product a pass before).
    react_u: i32,
    hold: Option<Fault>,
    healthy_once: bool,
    /// The planner is quiet: `planner_hold_at` is the goal.
    planner_holding: bool,
    /// The arm's pixel (unwrapped) on the last pass its own neighbourhood was free
    /// ([`NEVER_PX`] before the first).
    free_px: [i32; 2],
    /// An obstacle's image came onto the arm: the arm, on or next to [`Reflex::free_px`],
    /// has its own pixel marked; the escape may cross marked pixels until the arm's
    /// neighbourhood is free again (-1: yes, 0: no).
    came: i32,
    /// The escape target of the previous pass (unwrapped pixels).
    escape_to: Option<[i32; 2]>,
    hold_at: [i32; 2],
    /// The goal while the planner is quiet ([`Reflex::planner_hold`]): the arrest point of
    /// its last fresh goal. Apart from `hold_at`: a bad map or servo state meanwhile holds
    /// where the arm is then (it may have escaped from that point).
    planner_hold_at: [i32; 2],
    started_us: u32,
    planner_cycle: Option<u32>,
    planner_since_us: u32,
    /// The stall clock ([`stall_flags`]).
    stall: StallClock,
    /// Since when the arm has rested braking on an obstacle in its base rectangle, pass
    /// after pass (the clock for [`FROZEN_US`] that the goal's changes do not restart), and
    /// the pass that last did: any other pass in between (moving, clear, a hold) restarts it.
    braked_since_us: u32,
    braked_pass: u32,
    /// The evasion's last way (each link's speed multiple, `evade::WAY_MULT`), kept one
    /// sample longer.
    evade_dir: [i32; 2],
    /// The wand position the goal was last computed from.
    wand_um: [i32; 2],
    cfg: Config,
    monitor: Monitor,
    /// The evasion's prediction.
    evasion: evade::Scratch,
    /// The obstacles' positions over the last ~150 ms, for their velocities.
    tracks: evade::Tracks,
    /// The obstacles with the tracks' velocities, for the evasion.
    tracked: [ObstacleView; OBSTACLES],
    /// The escape's bitmaps.
    scratch: escape::Scratch,
    /// The runs of rows read free in earlier passes, by column (`window::Known`).
    known: window::Known,
    /// The arrest points of the last passes: a hold for an input that went quiet holds at
    /// the arrest point of the moment it did.
    log: arrest_log::ArrestLog,
}

impl Default for Reflex {
    fn default() -> Self {
        Self::new(Config::DEFAULT)
    }
}

impl Reflex {
    /// A reflex that has seen nothing yet.
    pub const fn new(cfg: Config) -> Self {
        Self {
            cfg,
            monitor: Monitor::new(),
            last: None,
            goal: None,
            hold: None,
            hold_at: [0; 2],
            planner_hold_at: [0; 2],
            planner_holding: false,
            last_loops: 0,
            same_loops: 0,
            torn: 0,
            last_t_us: 0,
            recent_dt_us: [0; 3],
            now_us: 0,
            started_us: 0,
            healthy_once: false,
            planner_cycle: None,
            planner_since_us: 0,
            stall: StallClock {
                ref_urad: [0; 2],
                since_us: 0,
            },
            braked_since_us: 0,
            braked_pass: 0,
            pass: 0,
            escape_to: None,
            free_px: [NEVER_PX; 2],
            came: 0,
            evade_dir: [0, 0],
            evasion: evade::Scratch::new(),
            tracks: evade::Tracks::new(),
            tracked: [ObstacleView::NONE; OBSTACLES],
            scratch: escape::Scratch::new(),
            known: window::Known::new(),
            react_u: fx::host_mul_shr(cfg.border_px_s * PIX_U, REACT_US * US_TO_S_Q32, 32),
            wand_um: [0; 2],
            goal_units: Units::ZERO,
            prev_units: Units::ZERO,
            log: arrest_log::ArrestLog::new(),
        }
    }

    /// Whether the arm is held because of a fault (recorded when it began), the planner's
    /// silence included (there the reflexes stay on).
    pub fn holding(&self) -> bool {
        self.hold.is_some() || self.planner_holding
    }

    /// One pass: reads the inputs and the map, returns the subgoal to publish.
    pub fn step<M: Map + ?Sized>(&mut self, inp: &Input, map: &mut M) -> Output {
        let mut out = Output::default();
        self.step_into(inp, map, &mut out);
        out
    }

    /// One pass, its outputs written to `out` (the board keeps them in place: an `Output`
    /// returned by value cost the 68020 a `memset` and a `memcpy` a pass); the obstacles
    /// as sensed come from `map` ([`Map::obstacle_views`]) when the pass needs them.
    #[inline(never)]
    pub fn step_into<M: Map + ?Sized>(&mut self, inp: &Input, map: &mut M, out: &mut Output) {
        out.clear();
        self.pass = self.pass.wrapping_add(1);
        let Some(sv) = &inp.servo else {
            self.torn += 1;
            if self.torn > SERVO_STALE_PASSES {
                let at = self.last.unwrap_or(self.hold_at);
                return self.hold_output(Fault::ServoTorn, at, out);
            }
            out.subgoal_urad = self.last;
            out.flags = self.hold.map_or(0, |_| flags::HOLD);
            return;
        };
        self.torn = 0;
        let first = self.last.is_none();
        if first {
            self.last_t_us = sv.t_us;
            self.started_us = sv.t_us;
            self.now_us = sv.t_us;
            self.last_loops = sv.loops;
            self.last = Some(sv.arrest_urad);
            self.hold_at = sv.arrest_urad;
            self.stall = StallClock {
                ref_urad: sv.arrest_urad,
                since_us: sv.t_us,
            };
        }
        if sv.loops == self.last_loops && !first {
            self.same_loops += 1;
        } else {
            self.same_loops = 0;
        }
        self.last_loops = sv.loops;
        if self.same_loops > SERVO_STALE_PASSES {
            return self.hold_output(Fault::ServoStale, sv.arrest_urad, out);
        }
        let dt_us = sv.t_us.wrapping_sub(self.last_t_us);
        self.last_t_us = sv.t_us;
        self.now_us = sv.t_us;
        out.dt_us = dt_us;
        // The pass time the latency margins assume: the longest of the last four intervals
        // between the servo states read. The servo publishes every other pass of its own,
        // so the intervals one pass sees alternate (0.67 and 1.33 ms at 1 kHz against the
        // servo's 1.5 kHz of states) and margins that followed them put an arm braked at a
        // wall between two subgoals a count apart, pass after pass (fig. V.9).
        let d = dt_us.min(1 << 30) as i32;
        let [d1, d2, d3] = self.recent_dt_us;
        let pass_us = masks::max(masks::max(d, d1), masks::max(d2, d3));
        self.recent_dt_us = [d, d1, d2];

        // The inputs must be good; until they first are, the arm holds without a fault.
        let problem = self.monitor.observe(&inp.health, self.now_us);
        if problem.is_none() && !self.healthy_once && self.monitor.behind() {
            out.subgoal_urad = Some(self.hold_point());
            out.flags = flags::WAITING;
            return;
        }
        if let Some(p) = problem {
            if self.healthy_once || self.now_us.wrapping_sub(self.started_us) > health::STARTUP_US {
                // An input that went quiet failed its limit ago: hold where the arm could
                // have stopped then. A lagging image is a slow board, not a dead one: now.
                let age = QUIET_AGE_US[p as usize];
                let at = self.log.at_age(self.now_us, age, sv.arrest_urad);
                return self.hold_output(Fault::Input(p), at, out);
            }
            out.subgoal_urad = Some(self.hold_point());
            out.flags = flags::WAITING;
            return;
        }
        self.healthy_once = true;

        // The goal.
        let near = self.goal.unwrap_or(sv.theta_urad);
        let mut planner_stale = false;
        match inp.goal {
            GoalInput::Planner { goal_urad, cycle } => {
                if self.planner_cycle != Some(cycle) {
                    self.planner_cycle = Some(cycle);
                    self.planner_since_us = self.now_us;
                }
                planner_stale = self.now_us.wrapping_sub(self.planner_since_us) > PLANNER_STALE_US;
                if !planner_stale {
                    self.goal = Some(goal_urad);
                }
                out.flags |= flags::FROM_PLANNER;
            }
            GoalInput::Wand { x_um, y_um } => {
                // The inverse kinematics (a fifth of a pass on the 68020) only when the wand
                // moved by more than [`WAND_MOVE_UM`] (its published position jitters by 1-3 mm
                // at rest, so noise recomputes it now and then; the planner restarts its
                // approaches only when its goal jumps by more than a cell, docs/planner.md).
                let [px, py] = self.wand_um;
                if self.goal.is_none()
                    || masks::abs(x_um - px) > WAND_MOVE_UM
                    || masks::abs(y_um - py) > WAND_MOVE_UM
                {
                    self.wand_um = [x_um, y_um];
                    let poses = goal::inverse(x_um, y_um);
                    self.goal = Some(goal::choose(poses, near));
                }
                out.flags |= flags::FROM_WAND;
            }
            // The planner's record reads torn: keep its last goal while that is fresh; a
            // record left torn (a planner that died mid-write) goes stale like a frozen one.
            GoalInput::None => {
                planner_stale = self.planner_cycle.is_some()
                    && self.now_us.wrapping_sub(self.planner_since_us) > PLANNER_STALE_US;
            }
        }
        let goal = if planner_stale {
            // A planner gone quiet stops the arm's advance, not its reflexes: the goal
            // becomes the arrest point of the planner's last fresh goal, and the window, the
            // escape and the evasion go on keeping the arm off obstacles that move onto it
            // (the map, positions and servo state are good). Held outright, an arm stood
            // still while a circling disk walked into it (`moving_obstacles.toml`, its
            // planner halted at 2 s).
            self.planner_hold(sv.arrest_urad, out)
        } else {
            // Back from a hold: start from where the arm was held.
            if self.hold.take().is_some() {
                self.last = Some(self.hold_at);
            }
            self.planner_holding = false;
            self.goal.unwrap_or(self.last.unwrap_or(sv.arrest_urad))
        };
        // Logged only on passes that got this far (a pass that holds needs no log).
        self.log.push(sv.t_us, sv.arrest_urad);
        out.goal_urad = goal;
        if inp.obstacles_moving {
            if self.tracks.due(self.now_us) {
                self.tracks.update(self.now_us, map);
            } else {
                self.tracks.settle_one(map);
            }
        }
        self.window(sv, goal, pass_us, inp, map, out);
    }

    /// Holds at the arrest point the arm had when the fault began (`arrest_urad` then);
    /// records the fault once.
    #[inline(never)]
    fn hold_output(&mut self, why: Fault, arrest_urad: [i32; 2], out: &mut Output) {
        if self.hold != Some(why) {
            if self.hold.is_none() {
                self.hold_at = arrest_urad;
            }
            self.hold = Some(why);
            out.new_fault = Some(why);
        }
        self.last = Some(self.hold_at);
        out.subgoal_urad = Some(self.hold_at);
        out.flags = flags::HOLD;
        out.goal_urad = self.goal.unwrap_or(self.hold_at);
    }

    /// The planner gone quiet ([`PLANNER_STALE_US`]): records the fault once, keeps the
    /// arrest point the arm had when the planner's last fresh goal came (from the log: its
    /// oldest if it does not reach back, the arm's now, `arrest_urad`, if empty) as the goal
    /// (returned)
    /// until the planner is back, and flags the hold; the pass goes on through the window,
    /// unlike [`Reflex::hold_output`]'s. The log is searched on the first such pass only.
    #[inline(never)]
    fn planner_hold(&mut self, arrest_urad: [i32; 2], out: &mut Output) -> [i32; 2] {
        // Back from a hold (a bad map or servo state meanwhile): on from where the arm was
        // held.
        if self.hold.take().is_some() {
            self.last = Some(self.hold_at);
        }
        if !self.planner_holding {
            out.new_fault = Some(Fault::PlannerStale);
            let age = self.now_us.wrapping_sub(self.planner_since_us);
            self.planner_hold_at = self.log.at_age(self.now_us, age, arrest_urad);
            self.planner_holding = true;
        }
        out.flags |= flags::HOLD;
        self.planner_hold_at
    }

    /// While the inputs are not yet good after power-up: the arrest point of the first pass.
    fn hold_point(&self) -> [i32; 2] {
        self.last.unwrap_or(self.hold_at)
    }

    /// The lookahead window and the subgoal (module docs).
    ///
    /// Written without local arrays indexed by a loop variable and without iterating a
    /// local array (docs/toolchain.md, class 6): per-axis work goes through [`Axis`] values
    /// handed by reference to non-inlined helpers, one call per axis.
    #[inline(never)]
    fn window<M: Map + ?Sized>(
        &mut self,
        sv: &ServoView,
        goal_urad: [i32; 2],
        pass_us: i32,
        inp: &Input,
        map: &mut M,
        out: &mut Output,
    ) {
        // The map's epoch before any of the pass's reads: while it stays, the window proved
        // free in an earlier pass needs no read (`Known::begin`).
        self.known.begin(map);
        let moving = inp.obstacles_moving;
        let mut prev = [0; 2];
        self.last_or(&sv.arrest_urad, &mut prev);
        // Latency: the state is up to a pass old when read, and the subgoal waits up to a
        // pass for the servo; twice the pass time plus half a millisecond, 1 ms passes at
        // least, 10 ms at most.
        let lat_us = 2 * masks::clamp(pass_us, 1000, 10_000) + 500;
        // Obstacles moving toward the arm: over the latency, the rectangle must hold them
        // off; for as long as the arm takes to stop, the subgoal keeps that far from any
        // wall (an obstacle that does come on is then met by the next pass's rectangle while
        // the arm can still brake or back off).
        let border_u_s = self.cfg.border_px_s * PIX_U;
        let lat_q32 = lat_us * US_TO_S_Q32;
        let obs_lat = fx::mul_shr(border_u_s, lat_q32, 32) + 1;
        // Among moving obstacles (the sensing board flags them) the arm also keeps the
        // distance they cover in the time it takes to react ([`REACT_US`]), and evades
        // once they come closer.
        let wide = self.react_u & -(moving as i32);
        // Built by `prepare` in place, spans and all (two `Axis::default()` filled after
        // cost two `memset` calls a pass on the 68020).
        let m = Margins {
            lat_q32,
            base: MARGIN_U + obs_lat + wide,
            own: MARGIN_U + wide,
        };
        let (goal_u, prev_u) = (self.goal_units.of(&goal_urad), self.prev_units.of(&prev));
        let a1 = prepare(0, sv, &prev, &prev_u, &goal_u, &m);
        let a2 = prepare(1, sv, &prev, &prev_u, &goal_u, &m);
        let obs_stop = stop_cover_u(border_u_s, a1.stop_us, a2.stop_us, lat_us);
        let clear_px = ESCAPE_CLEAR_PX + ((wide + PIX_U - 1) >> 8);
        let mut tests = 0;
        let keep = MARGIN_U + obs_stop + wide + PIX_U / 8;
        let mut sub = [0; 2];
        // The window the steps would grow, all at once when it is free (it holds the base),
        // after a pass whose window grew unblocked with the map unwritten since
        // (`window::fast_grow`); else the base, then the steps.
        let (g, s, t) = (&goal_urad, &mut sub, &mut tests);
        let free = (self.known.fast_grow_may()
            && self.base_window::<M, true>(map, &a1, &a2, keep, g, out, s, t))
            || (window::rect_free_known(map, &mut self.known, a1.base, a2.base, t)
                && self.base_window::<M, false>(map, &a1, &a2, keep, g, out, s, t));
        if !free {
            self.base_blocked(
                sv, &a1, &a2, &goal_urad, clear_px, moving, map, out, &mut sub, &mut tests,
            );
        }
        if out.flags & flags::ESCAPING == 0 {
            self.escape_to = None;
        }
        out.flags |= stall_flags(sv, &goal_urad, &sub, &mut self.stall, self.now_us);
        out.tests = tests;
        out.known = self.known.take_vouched();
        self.last = Some(sub);
        out.subgoal_urad = Some(sub);
    }

    /// The pass's window from a base rectangle: with `FAST` the window
    /// [`window::fast_grow`] takes at once, if it does (false when it does not), else the
    /// window grown from a base known free (`window::grow`); then the window kept as proved
    /// free (`Known::proved_free`), the goal clamped into it as the subgoal `sub`, the
    /// flags and the window into `out`, and true. Apart from
    /// [`Reflex::window`]: inlined there, branches of the rest tested the flags of a
    /// register copy (docs/toolchain.md, class 1).
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    fn base_window<M: Map + ?Sized, const FAST: bool>(
        &mut self,
        map: &mut M,
        a1: &Axis,
        a2: &Axis,
        keep: i32,
        goal_urad: &[i32; 2],
        out: &mut Output,
        sub: &mut [i32; 2],
        tests: &mut u32,
    ) -> bool {
        let g = growth(a1, a2, keep);
        let mut grown = Grown {
            window: [a1.base, a2.base],
            blocked: [false, false],
        };
        if FAST {
            if window::fast_grow(map, &mut self.known, &g, &mut grown, tests) == 0 {
                return false;
            }
        } else {
            window::grow(map, &mut self.known, &g, &mut grown, tests);
        }
        // Proved free: kept for the next passes, and the goal clamped into it.
        self.known.proved_free(&grown);
        let (w1, w2) = (grown.window[0], grown.window[1]);
        out.window = [(w1.lo, w1.hi), (w2.lo, w2.hi)];
        out.flags |= flags::BLOCKED1 & (grown.blocked[0] as u32).wrapping_neg();
        out.flags |= flags::BLOCKED2 & (grown.blocked[1] as u32).wrapping_neg();
        sub[0] = clamp_into(goal_urad[0], a1.goal, w1, keep);
        sub[1] = clamp_into(goal_urad[1], a2.goal, w2, keep);
        self.free_here(a1, a2);
        true
    }

    /// The pass's subgoal `sub` when the base rectangle is not free (the rest of
    /// [`Reflex::window`]): brake, back off, escape or hold.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn base_blocked<M: Map + ?Sized>(
        &mut self,
        sv: &ServoView,
        a1: &Axis,
        a2: &Axis,
        goal_urad: &[i32; 2],
        clear_px: i32,
        moving: bool,
        map: &mut M,
        out: &mut Output,
        sub: &mut [i32; 2],
        tests: &mut u32,
    ) {
        // An obstacle within the arm's own neighbourhood (wider among moving obstacles)
        // must be evaded; short of that, brake. An arm that has stood still for
        // [`FROZEN_US`] (stalled, and flagged so, first) with its own margins on an
        // obstacle (it started there, braked into the band, or the map's edge moved by a
        // pixel) cannot brake any further: it backs off to clearance, or would stand
        // frozen for good (planner campaign seed 2 scene 4: an arm 15 mm from a disk
        // never moved).
        // The time at rest braking counts too: the stall clock restarts with every new
        // goal, and a planner that takes each stall for a wall and moves its request on
        // restarted it every 200 ms; an arm a pixel from a disk in a channel never moved
        // (planner campaign seed 1 scene 509: 36 wall-following episodes in 10 s, the
        // goal 0.3 rad off). Counted over consecutive passes only: a clock left running
        // through holds and start-up passes, which never get here, fired on the first
        // braking pass (fig. VI.5 as images backed off at once and ended at the goal's
        // other elbow).
        let at_rest = masks::abs(sv.omega_urad_s[0]) < REST_URAD_S
            && masks::abs(sv.omega_urad_s[1]) < REST_URAD_S;
        if at_rest {
            if self.braked_pass.wrapping_add(1) != self.pass {
                self.braked_since_us = self.now_us;
            }
            self.braked_pass = self.pass;
        }
        // Masks from signs (the compiled compares fed their branch through a register
        // copy once the evasion was added: docs/toolchain.md class 1); ages capped at
        // 2^30 us, far beyond the limit, so the signed compare is the unsigned one.
        let older = |since: u32| {
            masks::lt(
                FROZEN_US as i32,
                self.now_us.wrapping_sub(since).min(1 << 30) as i32,
            )
        };
        let frozen = at_rest && (older(self.stall.since_us) | older(self.braked_since_us)) != 0;
        let k = &mut self.known;
        let near = !window::rect_free_known(map, k, a1.own, a2.own, tests)
            || (frozen && !window::rect_free_known(map, k, a1.rest, a2.rest, tests));
        if !near && window::rect_free_known(map, k, a1.core, a2.core, tests) {
            // Brake: the subgoal between the arm and its arrest point, as near the goal
            // as that allows, so the arrest region only shrinks (a subgoal beyond the
            // arrest point would let the arm speed up into margins nobody tested).
            out.flags |= flags::BRAKING;
            out.window = [(a1.core.lo, a1.core.hi), (a2.core.lo, a2.core.hi)];
            sub[0] = a1.brake_toward(goal_urad[0]);
            sub[1] = a2.brake_toward(goal_urad[1]);
            self.escape_to = None;
            self.free_here(a1, a2);
        } else if !near {
            // The arrest region meets an obstacle but the arm is clear of it: brake as
            // hard as the servo can (its setpoint behind its arrest point saturates the
            // law), never ahead of the arm, so a braking subgoal stays put while the arm
            // slows.
            out.flags |= flags::BRAKING;
            out.window = [(a1.own.lo, a1.own.hi), (a2.own.lo, a2.own.hi)];
            sub[0] = a1.hard_brake();
            sub[1] = a2.hard_brake();
            self.escape_to = None;
            self.free_here(a1, a2);
        } else {
            let at = [a1.theta >> 8, a2.theta >> 8];
            out.window = [(at[0], at[0]), (at[1], at[1])];
            // The arm on or next to the pixel it last stood on with its neighbourhood
            // free (it got there through rectangles proven free): whatever is marked
            // there now came to the arm, moving or not (a disk creeping too slowly for
            // the sensing board's moving flag walked into an arm held trapped: the demo
            // with its obstacles in the camera's view). An arm that started in a sliver
            // never had its neighbourhood free, and still holds.
            let d0 = masks::abs(at[0].wrapping_sub(self.free_px[0]));
            let d1 = masks::abs(at[1].wrapping_sub(self.free_px[1]));
            self.came |= masks::lt(masks::max(d0, d1), 2);
            let cross = moving | (self.came != 0);
            match self.escape(
                map,
                at,
                [a1.goal >> 8, a2.goal >> 8],
                clear_px,
                cross,
                tests,
            ) {
                Some(q) => {
                    // Toward the target a step at a time, so the arm leaves at a speed
                    // the next passes can still correct (a full-speed dash to a target
                    // chosen once ran into obstacles that had moved meanwhile).
                    out.flags |= flags::ESCAPING;
                    sub[0] = escape_step(a1.theta, q[0]);
                    sub[1] = escape_step(a2.theta, q[1]);
                    self.evade_dir = [0, 0];
                }
                None => {
                    out.flags |= flags::TRAPPED;
                    *sub = sv.arrest_urad;
                    let theta_u = [a1.theta, a2.theta];
                    let mask = (moving as u32).wrapping_neg();
                    self.trapped(sv, &theta_u, mask, map, out, sub);
                }
            }
        }
    }

    /// The last subgoal into `out`, or `arrest_urad` before the first. Apart from
    /// [`Reflex::window`]: inlined there, its branch tested a register copy's flags
    /// (docs/toolchain.md, class 1).
    #[inline(never)]
    fn last_or(&self, arrest_urad: &[i32; 2], out: &mut [i32; 2]) {
        *out = self.last.unwrap_or(*arrest_urad);
    }

    /// The arm's own neighbourhood is free this pass: its pixel is where an image that is
    /// marked there later came to it ([`Reflex::came`]).
    #[inline(never)]
    fn free_here(&mut self, a1: &Axis, a2: &Axis) {
        self.free_px = [a1.theta >> 8, a2.theta >> 8];
        self.came = 0;
    }

    /// A trapped arm's subgoal `sub` (its arrest point on entry) among `moving` (mask)
    /// obstacles: the way that keeps off their predicted disks longest, then keeps the
    /// margin longest (`evade::best`; staying put if that does as well as any), a step of
    /// `evade::way_step_u` for its speed. Apart from [`Reflex::window`], and the flag a mask: the
    /// compiled branch on `moving` there tested a register copy's flags once the window
    /// read the known columns (docs/toolchain.md, class 1).
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    fn trapped<M: Map + ?Sized>(
        &mut self,
        sv: &ServoView,
        theta_u: &[i32; 2],
        moving: u32,
        map: &mut M,
        out: &mut Output,
        sub: &mut [i32; 2],
    ) {
        if moving == 0 {
            return;
        }
        self.tracks.apply(map, &mut self.tracked);
        evade::prepare(&mut self.evasion, &sv.theta_urad, &self.tracked);
        let mut b = [0; 3];
        evade::best(&mut self.evasion, &self.evade_dir, &mut b);
        self.evade_dir = [b[0], b[1]];
        if b[0] | b[1] != 0 {
            out.flags |= flags::EVADING;
            sub[0] = u_to_urad(theta_u[0] + evade::way_step_u(0, b[0]));
            sub[1] = u_to_urad(theta_u[1] + evade::way_step_u(1, b[1]));
        }
    }

    /// Where to escape to from pixel `at` ([`escape`]): the first step toward the most open
    /// free place reachable without crossing marked pixels (across them, fewest first, only
    /// among `moving` obstacles with the arm's own pixel marked: with every obstacle at
    /// rest, the arm got where it is through free space or started there, so it is safe
    /// where it stands, and a dash across the map's marks is not; planner campaign seed 1
    /// scene 618: an arm started 10 mm from a disk, in a one-pixel free sliver, crossed the
    /// disk), with `clear` free pixels each side at most, nearest `toward` among equals.
    #[inline(never)]
    fn escape<M: Map + ?Sized>(
        &mut self,
        map: &mut M,
        at: [i32; 2],
        toward: [i32; 2],
        clear: i32,
        moving: bool,
        tests: &mut u32,
    ) -> Option<[i32; 2]> {
        let ask = escape::Ask {
            at_px: at,
            toward_px: toward,
            clear_px: clear,
            cross: moving,
            prev_px: self.escape_to,
        };
        let p = escape::plan_kept(map, &mut self.scratch, &ask, tests);
        let (to, step) = (p.map(|p| p.target_px), p.map(|p| p.step_px));
        // A plan kept (its window unwritten) stood for the window's pixels.
        self.known.vouch(self.scratch.take_vouched());
        self.escape_to = to;
        step
    }
}

/// How far an obstacle's border moving at `border_u_s` (angle units a second) comes while
/// the arm stops (the slower axis's `stop1_us` or `stop2_us`) after the latency `lat_us`,
/// 400 ms at most, angle units. The bound in sign masks through an opaque value: LLVM made
/// a select of it whose branch tested the flags of a register copy (docs/toolchain.md,
/// class 1).
#[inline(always)]
fn stop_cover_u(border_u_s: i32, stop1_us: i32, stop2_us: i32, lat_us: i32) -> i32 {
    let t_us = masks::max(stop1_us, stop2_us) + lat_us;
    let over = core::hint::black_box(masks::lt(400_000, t_us));
    let t_stop_us = t_us + (over & (400_000 - t_us));
    fx::mul_shr(border_u_s, t_stop_us * US_TO_S_Q32, 32) + 1
}

/// How far the window may grow from the base rectangles of axes `a1` and `a2`: toward the
/// goal with `keep` about it, within the reach, within [`GROW_BUDGET`] words.
#[inline(always)]
fn growth(a1: &Axis, a2: &Axis, keep: i32) -> Grow {
    Grow {
        goal: [a1.goal_span(keep), a2.goal_span(keep)],
        reach: [a1.reach(), a2.reach()],
        budget: GROW_BUDGET,
    }
}

/// The stall clock: the subgoal the arm was last seen to move toward, and since when.
/// `repr(C)`: the runtime's `__reflex_stall` updates it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct StallClock {
    /// The subgoal when the clock last restarted, urad.
    pub ref_urad: [i32; 2],
    /// When it last restarted (the servo's clock, us).
    pub since_us: u32,
}

/// The constants and flag bits `__reflex_stall` takes from the Rust (one source for both).
#[repr(C)]
struct StallConst {
    quarter_urad: i32,
    rest_urad_s: i32,
    at_goal_urad: i32,
    stall_us: u32,
    at_goal: u32,
    arrived: u32,
    stalled: u32,
}

/// [`StallConst`]'s values.
#[cfg_attr(not(target_arch = "m68k"), allow(dead_code))]
static STALL_CONST: StallConst = StallConst {
    quarter_urad: QUARTER_PX_URAD,
    rest_urad_s: REST_URAD_S,
    at_goal_urad: AT_GOAL_URAD,
    stall_us: STALL_US,
    at_goal: flags::AT_GOAL,
    arrived: flags::ARRIVED,
    stalled: flags::STALLED,
};

/// The layouts `__reflex_stall` (crates/rt/asm/servo.S) uses.
mod stall_layout {
    use super::{StallClock, StallConst};
    use core::mem::offset_of;
    const _: () = assert!(offset_of!(StallClock, ref_urad) == 0);
    const _: () = assert!(offset_of!(StallClock, since_us) == 8);
    const _: () = assert!(offset_of!(StallConst, quarter_urad) == 0);
    const _: () = assert!(offset_of!(StallConst, rest_urad_s) == 4);
    const _: () = assert!(offset_of!(StallConst, at_goal_urad) == 8);
    const _: () = assert!(offset_of!(StallConst, stall_us) == 12);
    const _: () = assert!(offset_of!(StallConst, at_goal) == 16);
    const _: () = assert!(offset_of!(StallConst, arrived) == 20);
    const _: () = assert!(offset_of!(StallConst, stalled) == 24);
}

/// The stall, at-goal and arrived flags for subgoal `sub` at the servo's time `now_us`,
/// with the stall clock `clk`: at rest, short of the goal, the subgoal stuck for
/// [`STALL_US`] is a stall. On the 68020 one call of `__reflex_stall` (crates/rt/asm/servo.S),
/// bit for bit [`stall_flags_host`] (`the_reflex_images_stall_clocks_match_the_host`;
/// compiled, ~740 cycles a pass).
#[inline(always)]
pub fn stall_flags(
    sv: &ServoView,
    goal_urad: &[i32; 2],
    sub: &[i32; 2],
    clk: &mut StallClock,
    now_us: u32,
) -> u32 {
    #[cfg(target_arch = "m68k")]
    {
        extern "C" {
            fn __reflex_stall(
                sv: *const ServoView,
                goal: *const [i32; 2],
                sub: *const [i32; 2],
                clk: *mut StallClock,
                now_us: u32,
                c: *const StallConst,
            ) -> u32;
        }
        // SAFETY: the routine reads the inputs at the offsets asserted in `prep_layout`
        // and `stall_layout`, and writes `clk` only.
        unsafe { __reflex_stall(sv, goal_urad, sub, clk, now_us, &STALL_CONST) }
    }
    #[cfg(not(target_arch = "m68k"))]
    stall_flags_host(sv, goal_urad, sub, clk, now_us)
}

/// [`stall_flags`] in Rust (the host's, and the reference for the image's). Masks (-1 =
/// yes), not booleans (docs/toolchain.md).
#[cfg_attr(target_arch = "m68k", allow(dead_code))]
fn stall_flags_host(
    sv: &ServoView,
    goal_urad: &[i32; 2],
    sub: &[i32; 2],
    clk: &mut StallClock,
    now_us: u32,
) -> u32 {
    let quarter = QUARTER_PX_URAD;
    let d = |a: i32, b: i32| (a - b) | (b - a);
    // (a - b) | (b - a) is negative exactly when a != b.
    let off_goal = d(sub[0], goal_urad[0]) | d(sub[1], goal_urad[1]);
    let moving = masks::lt(REST_URAD_S - 1, masks::abs(sv.omega_urad_s[0]))
        | masks::lt(REST_URAD_S - 1, masks::abs(sv.omega_urad_s[1]));
    let far = masks::lt(AT_GOAL_URAD, masks::abs(sv.theta_urad[0] - goal_urad[0]))
        | masks::lt(AT_GOAL_URAD, masks::abs(sv.theta_urad[1] - goal_urad[1]));
    let moved = masks::lt(quarter, masks::abs(sub[0] - clk.ref_urad[0]))
        | masks::lt(quarter, masks::abs(sub[1] - clk.ref_urad[1]));
    let at_goal = masks::nonneg(off_goal);
    let mut f = flags::AT_GOAL & at_goal as u32;
    f |= flags::ARRIVED & !(moving | far) as u32;
    let reset = moved | at_goal | moving;
    let stuck_for = now_us.wrapping_sub(clk.since_us).min(1 << 30) as i32;
    f |= flags::STALLED & (!reset & masks::lt(STALL_US as i32, stuck_for)) as u32;
    clk.ref_urad[0] = masks::pick(reset, sub[0], clk.ref_urad[0]);
    clk.ref_urad[1] = masks::pick(reset, sub[1], clk.ref_urad[1]);
    clk.since_us = masks::pick(reset, now_us as i32, clk.since_us as i32) as u32;
    f
}

/// One axis of the window's arithmetic, angle units unless named otherwise. `repr(C)`:
/// the runtime's `__reflex_prepare` writes it (offsets asserted below).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
struct Axis {
    theta: i32,
    goal: i32,
    /// How far the arrest point may advance while the state and the subgoal are in transit.
    adv: i32,
    /// Time to stop from the current speed, microseconds.
    stop_us: i32,
    theta_urad: i32,
    arrest_urad: i32,
    prev_urad: i32,
    omega_urad_s: i32,
    base: Span,
    core: Span,
    own: Span,
    /// The arm itself with the base rectangle's margins (an arm at rest that this meets
    /// an obstacle cannot brake any further).
    rest: Span,
}

/// What every axis's spans are widened by, computed once for both axes: the latency, and
/// in angle units the fixed margin with the one for obstacles moving during the latency and
/// the one for moving obstacles' reaction time (0 when none moves). `repr(C)`:
/// `__reflex_prepare` reads it.
#[repr(C)]
struct Margins {
    /// The latency in Q32 seconds.
    lat_q32: i32,
    /// The base and rest rectangles' margin: fixed, obstacle motion, reaction.
    base: i32,
    /// The arm's own neighbourhood's margin: fixed and reaction.
    own: i32,
}

/// The constants `__reflex_prepare` takes from the Rust (one source for both): the
/// conversion to angle units, the rest speed and the stop times of [`prepare`], the margin
/// and the arrest slack's shift.
#[repr(C)]
struct PrepConst {
    urad_to_u_q24: i32,
    rest_u_s: i32,
    stop_us_per_u_s_q24: [i32; 2],
    margin_u: i32,
    arrest_slack_shift: u32,
}

/// [`PrepConst`]'s values.
#[cfg_attr(not(target_arch = "m68k"), allow(dead_code))]
static PREP_CONST: PrepConst = PrepConst {
    urad_to_u_q24: URAD_TO_U_Q24,
    rest_u_s: REST_U_S,
    stop_us_per_u_s_q24: STOP_US_PER_U_S_Q24,
    margin_u: MARGIN_U,
    arrest_slack_shift: ARREST_SLACK_SHIFT,
};

/// The layouts `__reflex_prepare` (crates/rt/asm/servo.S) uses.
mod prep_layout {
    use super::{Axis, Margins, PrepConst, ServoView};
    use crate::window::Span;
    use core::mem::{offset_of, size_of};
    const _: () = assert!(offset_of!(ServoView, theta_urad) == 0);
    const _: () = assert!(offset_of!(ServoView, omega_urad_s) == 8);
    const _: () = assert!(offset_of!(ServoView, arrest_urad) == 16);
    const _: () = assert!(offset_of!(Margins, lat_q32) == 0);
    const _: () = assert!(offset_of!(Margins, base) == 4);
    const _: () = assert!(offset_of!(Margins, own) == 8);
    const _: () = assert!(offset_of!(PrepConst, urad_to_u_q24) == 0);
    const _: () = assert!(offset_of!(PrepConst, rest_u_s) == 4);
    const _: () = assert!(offset_of!(PrepConst, stop_us_per_u_s_q24) == 8);
    const _: () = assert!(offset_of!(PrepConst, margin_u) == 16);
    const _: () = assert!(offset_of!(PrepConst, arrest_slack_shift) == 20);
    const _: () = assert!(offset_of!(Span, lo) == 0 && offset_of!(Span, hi) == 4);
    const _: () = assert!(offset_of!(Axis, theta) == 0);
    const _: () = assert!(offset_of!(Axis, goal) == 4);
    const _: () = assert!(offset_of!(Axis, adv) == 8);
    const _: () = assert!(offset_of!(Axis, stop_us) == 12);
    const _: () = assert!(offset_of!(Axis, theta_urad) == 16);
    const _: () = assert!(offset_of!(Axis, arrest_urad) == 20);
    const _: () = assert!(offset_of!(Axis, prev_urad) == 24);
    const _: () = assert!(offset_of!(Axis, omega_urad_s) == 28);
    const _: () = assert!(offset_of!(Axis, base) == 32);
    const _: () = assert!(offset_of!(Axis, core) == 40);
    const _: () = assert!(offset_of!(Axis, own) == 48);
    const _: () = assert!(offset_of!(Axis, rest) == 56);
    const _: () = assert!(size_of::<Axis>() == 64);
}

/// Axis `i`'s state: its arithmetic, then its base rectangle, arrest region and own
/// neighbourhood. On the 68020 one call of `__reflex_prepare` (crates/rt/asm/servo.S),
/// bit for bit [`prepare_host`] (`the_reflex_images_axes_match_the_host`): compiled, the
/// two axes took ~3,200 cycles a pass with their product calls. Inlined: the routine
/// writes the caller's axis in place (a call of its own copied each axis once more).
#[inline(always)]
fn prepare(
    i: usize,
    sv: &ServoView,
    prev: &[i32; 2],
    prev_u: &[i32; 2],
    goal_u: &[i32; 2],
    m: &Margins,
) -> Axis {
    #[cfg(target_arch = "m68k")]
    {
        extern "C" {
            fn __reflex_prepare(
                i: u32,
                sv: *const ServoView,
                prev: *const [i32; 2],
                prev_u: *const [i32; 2],
                goal_u: *const [i32; 2],
                m: *const Margins,
                c: *const PrepConst,
                out: *mut Axis,
            );
        }
        let mut a = core::mem::MaybeUninit::<Axis>::uninit();
        // SAFETY: the routine reads the inputs at the offsets `prep_layout` asserts and
        // writes every field of `a`.
        unsafe {
            __reflex_prepare(
                i as u32,
                sv,
                prev,
                prev_u,
                goal_u,
                m,
                &PREP_CONST,
                a.as_mut_ptr(),
            );
            a.assume_init()
        }
    }
    #[cfg(not(target_arch = "m68k"))]
    prepare_host(i, sv, prev, prev_u, goal_u, m)
}

/// [`prepare`] in Rust: the host's, and the reference for the image's.
#[cfg_attr(target_arch = "m68k", allow(dead_code))]
fn prepare_host(
    i: usize,
    sv: &ServoView,
    prev: &[i32; 2],
    prev_u: &[i32; 2],
    goal_u: &[i32; 2],
    m: &Margins,
) -> Axis {
    let lat_q32 = m.lat_q32;
    let omega_urad_s = sv.omega_urad_s[i];
    let w = masks::abs(urad_to_u(omega_urad_s));
    // The arrest point advances at up to 2 omega (V.6) while the state is in transit.
    let reach_u = fx::mul_shr(w, lat_q32, 32) + 1;
    let adv = 2 * reach_u;
    let back = omega_urad_s >> 31;
    let theta = urad_to_u(sv.theta_urad[i]);
    let arrest = urad_to_u(sv.arrest_urad[i]);
    let g_prev = prev_u[i];
    // Where the arm stops at worst if it brakes after the latency: the arrest point
    // advanced by the latency (V.6) and by the servo's possible inertia error.
    let slack = masks::abs(arrest - theta) >> ARREST_SLACK_SHIFT;
    let ahead = adv + slack;
    let a_end = arrest + ((ahead ^ back) - back);
    let (lo, hi) = (masks::min(theta, a_end), masks::max(theta, a_end));
    // The arm heading for the previous subgoal stops there (the servo does not overshoot);
    // only an arrest point already beyond it (braking late, or a subgoal that moved back)
    // reaches further.
    let (glo, ghi) = (masks::min(theta, g_prev), masks::max(theta, g_prev));
    let tol = MARGIN_U >> 1;
    let outside = masks::lt(arrest, glo - tol) | masks::lt(ghi + tol, arrest);
    let blo = masks::min(glo, masks::pick(outside, lo, arrest));
    let bhi = masks::max(ghi, masks::pick(outside, hi, arrest));
    let mb = m.base;
    // The arm itself over the latency.
    let fwd = reach_u & !back;
    let bwd = reach_u & back;
    let mo = m.own;
    Axis {
        theta_urad: sv.theta_urad[i],
        arrest_urad: sv.arrest_urad[i],
        omega_urad_s,
        prev_urad: prev[i],
        theta,
        goal: goal_u[i],
        adv,
        // Below the rest threshold, the stop time of the threshold's speed: the margin
        // that follows it then stays put while the arm rests (an arm braked at a wall, its
        // speed jittering by a few mrad/s, otherwise moved its subgoal a count back and
        // forth with it; fig. V.9), and it is never below the true one.
        stop_us: fx::mul_shr(masks::max(w, REST_U_S), STOP_US_PER_U_S_Q24[i], 24),
        core: Span::of_units(lo - MARGIN_U, hi + MARGIN_U),
        base: Span::of_units(blo - mb, bhi + mb),
        rest: Span::of_units(theta - mb, theta + mb),
        own: Span::of_units(theta - bwd - mo, theta + fwd + mo),
    }
}

impl Axis {
    /// The goal with the margin it needs, in pixels.
    #[inline(always)]
    fn goal_span(&self, keep: i32) -> Span {
        Span::of_units(self.goal - keep, self.goal + keep)
    }

    /// The farthest the window may grow each way: the arrest region and the lookahead depth
    /// beyond it (the thesis's window plus twice what the arrest point may advance per pass).
    #[inline(always)]
    fn reach(&self) -> Span {
        let d = DEPTH_PX + 2 * ((self.adv + PIX_U - 1) >> 8);
        Span {
            lo: self.core.lo - d,
            hi: self.core.hi + d,
        }
    }

    /// The goal component clamped between the arm and its arrest point.
    #[inline(never)]
    fn brake_toward(&self, goal_urad: i32) -> i32 {
        let (t, a) = (self.theta_urad, self.arrest_urad);
        masks::clamp(goal_urad, masks::min(t, a), masks::max(t, a))
    }

    /// The arm's position, or the previous subgoal if that is already behind the arm.
    #[inline(never)]
    fn hard_brake(&self) -> i32 {
        let behind = ((self.prev_urad - self.theta_urad) ^ self.omega_urad_s) >> 31;
        masks::pick(behind, self.prev_urad, self.theta_urad)
    }
}

/// The escape's next subgoal component from the arm at `th` (angle units) toward the
/// middle of pixel `q`: at most [`ESCAPE_STEP_U`] away.
#[inline(never)]
fn escape_step(th: i32, q: i32) -> i32 {
    u_to_urad(th + masks::clamp(q * PIX_U + PIX_U / 2 - th, -ESCAPE_STEP_U, ESCAPE_STEP_U))
}

/// The goal's component `goal_urad` (`goal_u` in angle units) if it lies at least `keep`
/// inside the pixel span `s`, else the nearest point that does (the span's middle if it is
/// too narrow for that). On the 68020 one call of `__reflex_clamp_into`
/// (crates/rt/asm/servo.S), bit for bit [`clamp_into_host`]
/// (`the_reflex_images_goal_clamps_match_the_host`; compiled, ~280 cycles a call with its
/// conversion).
#[inline(always)]
pub fn clamp_into(goal_urad: i32, goal_u: i32, s: Span, keep: i32) -> i32 {
    #[cfg(target_arch = "m68k")]
    {
        extern "C" {
            fn __reflex_clamp_into(
                goal_urad: i32,
                goal_u: i32,
                lo_px: i32,
                hi_px: i32,
                keep: i32,
                u_to_urad_q16: i32,
            ) -> i32;
        }
        // SAFETY: a pure function in the runtime's assembly.
        unsafe { __reflex_clamp_into(goal_urad, goal_u, s.lo, s.hi, keep, U_TO_URAD_Q16) }
    }
    #[cfg(not(target_arch = "m68k"))]
    clamp_into_host(goal_urad, goal_u, s, keep)
}

/// [`clamp_into`] in Rust (the host's, and the reference for the image's).
#[cfg_attr(target_arch = "m68k", allow(dead_code))]
fn clamp_into_host(goal_urad: i32, goal_u: i32, s: Span, keep: i32) -> i32 {
    use masks::pick;
    let lo = s.lo * PIX_U + keep;
    let hi = (s.hi + 1) * PIX_U - 1 - keep;
    let narrow = (hi - lo) >> 31;
    let below = (goal_u - lo) >> 31;
    let above = (hi - goal_u) >> 31;
    let mid = ((s.lo + s.hi + 1) * PIX_U) >> 1;
    // The point chosen in angle units, converted once (three conversions, one kept, cost
    // the 68020 ~600 cycles a pass).
    let u = pick(narrow, mid, pick(below, lo, hi));
    pick(narrow | below | above, u_to_urad(u), goal_urad)
}

#[cfg(test)]
mod tests;
