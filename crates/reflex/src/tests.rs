//! The reflex stepped alone against hand-made maps (figs. V.6-V.10), its fail-safes, the
//! wand's inverse kinematics, and a closed loop with an ideal time-optimal servo over random
//! obstacles that must never be entered.

use super::*;
use health::{EntryView, HealthInput};
use proptest::prelude::*;
use window::SliceMap;

const RAD: f64 = 1e6;

/// A 128 x 128 map with its stripes (the escape's tests use it too).
pub(crate) struct TestMap {
    pub(crate) words: Vec<u32>,
    pub(crate) stripes: Vec<u32>,
}

impl TestMap {
    pub(crate) fn new() -> Self {
        Self {
            words: vec![0; 128 * 128],
            stripes: vec![0; 128],
        }
    }
    /// Marks pixel (i1, i2) (wrapping).
    pub(crate) fn mark(&mut self, i1: i32, i2: i32) {
        self.words[((i2 & 127) * 128 + (i1 & 127)) as usize] = 0x0100_0000;
    }
    /// Clears pixel (i1, i2) (wrapping).
    pub(crate) fn clear_px(&mut self, i1: i32, i2: i32) {
        self.words[((i2 & 127) * 128 + (i1 & 127)) as usize] = 0;
    }
    /// Whether pixel (i1, i2) is marked (wrapping).
    pub(crate) fn marked(&self, i1: i32, i2: i32) -> bool {
        self.words[((i2 & 127) * 128 + (i1 & 127)) as usize] != 0
            || self.stripes[(i1 & 127) as usize] != 0
    }
    /// Marks pixels i1 in a..=b, i2 in c..=d (wrapping).
    pub(crate) fn block(&mut self, a: i32, b: i32, c: i32, d: i32) {
        for i1 in a..=b {
            for i2 in c..=d {
                self.mark(i1, i2);
            }
        }
    }
    fn occupied(&self, t1_rad: f64, t2_rad: f64) -> bool {
        let p = |t: f64| (t / (2.0 * std::f64::consts::PI) * 128.0).floor() as i32;
        self.marked(p(t1_rad), p(t2_rad))
    }
    pub(crate) fn map(&self) -> SliceMap<'_> {
        SliceMap {
            words: &self.words,
            stripes: &self.stripes,
        }
    }
}

/// Inputs that are all fresh at pass `k`.
fn healthy(k: u32) -> HealthInput {
    HealthInput {
        cspace_heartbeats: [k, 0, 0],
        objects_frame: k,
        objects_torn: false,
        entries: [EntryView::default(); health::ENTRIES],
        fresh: (1 << health::ENTRIES) - 1,
    }
}

fn servo_at(theta: [f64; 2], omega: [f64; 2], k: u32) -> ServoView {
    let arrest = |i: usize| {
        let a = BRAKE_U_S2[i] as f64 * 2.0 * std::f64::consts::PI / 32768.0;
        theta[i] + omega[i] * omega[i].abs() / (2.0 * a)
    };
    ServoView {
        theta_urad: [(theta[0] * RAD) as i32, (theta[1] * RAD) as i32],
        omega_urad_s: [(omega[0] * RAD) as i32, (omega[1] * RAD) as i32],
        arrest_urad: [(arrest(0) * RAD) as i32, (arrest(1) * RAD) as i32],
        t_us: 1000 * k,
        loops: 3 * k,
    }
}

fn planner(goal: [f64; 2], k: u32) -> GoalInput {
    GoalInput::Planner {
        goal_urad: [(goal[0] * RAD) as i32, (goal[1] * RAD) as i32],
        cycle: k,
    }
}

/// Pass `k`'s inputs for an arm resting at (0, 0) with the planner's goal (1, 1) rad and
/// `health` (the fail-safe tests).
fn resting_at_origin(k: u32, health: HealthInput) -> Input {
    Input {
        servo: Some(servo_at([0.0, 0.0], [0.0, 0.0], k)),
        goal: planner([1.0, 1.0], k),
        health,
        obstacles_moving: false,
    }
}

/// Runs `n` passes at rest at `theta` toward `goal`; returns the last output.
fn at_rest(m: &TestMap, theta: [f64; 2], goal: [f64; 2], n: u32) -> Output {
    let mut r = Reflex::default();
    let mut out = Output::default();
    for k in 1..=n {
        let inp = Input {
            servo: Some(servo_at(theta, [0.0; 2], k)),
            goal: planner(goal, k),
            health: healthy(k),
            obstacles_moving: false,
        };
        out = r.step(&inp, &mut m.map());
    }
    out
}

fn sub(o: &Output) -> [f64; 2] {
    let s = o.subgoal_urad.unwrap();
    [s[0] as f64 / RAD, s[1] as f64 / RAD]
}

const PIX: f64 = 2.0 * std::f64::consts::PI / 128.0;

#[test]
fn a_goal_inside_the_window_is_the_subgoal() {
    // Fig. V.6.
    let m = TestMap::new();
    let o = at_rest(&m, [1.0, 1.0], [1.2, 0.8], 3);
    assert_eq!(o.subgoal_urad, Some([1_200_000, 800_000]));
    assert_ne!(o.flags & flags::AT_GOAL, 0);
}

#[test]
fn a_far_goal_gives_a_subgoal_at_the_window_edge() {
    // Fig. V.7: no obstacle, goal beyond the window: the subgoal at the window's far side,
    // well beyond the arrest point (here the arm itself) so the servo accelerates.
    let m = TestMap::new();
    let o = at_rest(&m, [0.5, 0.5], [2.5, -1.0], 3);
    let s = sub(&o);
    assert!(s[0] > 0.5 + 6.0 * PIX && s[0] < 2.5, "{s:?}");
    assert!(s[1] < 0.5 - 6.0 * PIX && s[1] > -1.0, "{s:?}");
    assert_eq!(
        o.flags & (flags::AT_GOAL | flags::BLOCKED1 | flags::BLOCKED2),
        0
    );
}

#[test]
fn a_wall_along_one_axis_stops_that_axis_only() {
    // Fig. V.8: a wall across theta1 three pixels ahead; theta2 still reaches its goal.
    let mut m = TestMap::new();
    let p = (1.0 / PIX).floor() as i32;
    m.block(p + 3, p + 5, 0, 127);
    let o = at_rest(&m, [1.0, 1.0], [2.0, 1.2], 3);
    let s = sub(&o);
    assert_ne!(o.flags & flags::BLOCKED1, 0);
    assert!(s[0] < (p + 3) as f64 * PIX && s[0] > 1.0, "{s:?}");
    assert_eq!(s[1], 1.2);
    assert!(!m.occupied(s[0], s[1]));
}

#[test]
fn walls_along_both_axes_stop_both() {
    // Fig. V.9: an obstacle ahead on the diagonal: growth stops on both axes.
    let mut m = TestMap::new();
    let p = (1.0 / PIX).floor() as i32;
    m.block(p + 3, p + 10, p - 20, p + 10);
    m.block(p - 20, p + 10, p + 3, p + 10);
    let o = at_rest(&m, [1.0, 1.0], [1.5, 1.5], 3);
    let s = sub(&o);
    assert_ne!(o.flags & flags::BLOCKED1, 0);
    assert_ne!(o.flags & flags::BLOCKED2, 0);
    assert!(
        s[0] < (p + 3) as f64 * PIX && s[1] < (p + 3) as f64 * PIX,
        "{s:?}"
    );
}

#[test]
fn an_arm_inside_an_obstacle_escapes_to_the_nearest_free_place() {
    // Fig. V.10: the obstacle moved over the arm (the sensing board flags it moving); it
    // heads for the nearest free pixel, a step of at most ESCAPE_STEP_U a pass, and gets
    // out.
    let mut m = TestMap::new();
    let p = (1.0 / PIX).floor() as i32;
    m.block(p - 2, p + 6, p - 6, p + 6);
    let mut r = Reflex::default();
    let mut th = [1.0, 1.0];
    let mut escaped = false;
    for k in 1..=40 {
        let inp = Input {
            servo: Some(servo_at(th, [0.0; 2], k)),
            goal: planner([2.0, 1.0], k),
            health: healthy(k),
            obstacles_moving: true,
        };
        let o = r.step(&inp, &mut m.map());
        let s = sub(&o);
        if o.flags & flags::ESCAPING != 0 {
            escaped = true;
            // The nearest way out is through the near (-theta1) side: 3 pixels, not 6.
            assert!(s[0] <= th[0] + 1e-6, "pass {k}: {s:?} from {th:?}");
            let step = ESCAPE_STEP_U as f64 * PIX / PIX_U as f64 + 1e-3;
            assert!((s[0] - th[0]).abs() <= step && (s[1] - th[1]).abs() <= step);
        }
        // The arm goes where it is told (at rest at the subgoal by the next pass).
        th = s;
    }
    assert!(escaped);
    assert!(!m.occupied(th[0], th[1]), "ended inside at {th:?}");
}

/// One pass's map (as the board hands it) whose obstacles' views are built on the pass's
/// first ask: the passes that built them go to `built`, those that kept them for the tracks
/// to `kept` (what they kept in `store`, across passes as the board keeps it). Its one
/// obstacle comes at the tip of an arm at (1, 1) rad from 60 mm further out, at 0.3 m/s.
struct ViewsMap<'a> {
    map: SliceMap<'a>,
    pass: u32,
    asked: bool,
    built: &'a mut Vec<u32>,
    kept: &'a mut Vec<u32>,
    store: &'a mut ObstacleView,
    views: [ObstacleView; OBSTACLES],
}

/// [`ViewsMap`]'s obstacle on pass `pass`.
fn coming(pass: u32) -> ObstacleView {
    // Both links along 1 rad (the angles are absolute): the tip 0.5 m out.
    let (ux, uy) = (1f64.cos(), 1f64.sin());
    let (x, y) = (0.5 * ux, 0.5 * uy);
    ObstacleView {
        valid: true,
        x_um: ((x + 0.06 * ux) * 1e6) as i32,
        y_um: ((y + 0.06 * uy) * 1e6) as i32,
        r_um: 15_000,
        vx_um_s: (-0.3 * ux * 1e6) as i32,
        vy_um_s: (-0.3 * uy * 1e6) as i32,
        t_us: 1000 * pass,
    }
}

impl Map for ViewsMap<'_> {
    fn obstacle_views(&mut self) -> &[ObstacleView; OBSTACLES] {
        if !self.asked {
            self.asked = true;
            self.built.push(self.pass);
            self.views[0] = coming(self.pass);
        }
        &self.views
    }
    fn keep_obstacles(&mut self) {
        self.kept.push(self.pass);
        *self.store = coming(self.pass);
    }
    fn kept_view(&mut self, i: usize, o: &mut ObstacleView) {
        *o = if i == 0 {
            *self.store
        } else {
            ObstacleView::NONE
        };
    }
    fn row_or(&mut self, i2: u32, i1: u32, n: u32) -> u32 {
        self.map.row_or(i2, i1, n)
    }
    fn col_or(&mut self, i1: u32, i2: u32, n: u32) -> u32 {
        self.map.col_or(i1, i2, n)
    }
    fn stripes_or(&mut self, i1: u32, n: u32) -> u32 {
        self.map.stripes_or(i1, n)
    }
}

/// Runs 40 passes of an arm at rest at (1, 1) rad among moving obstacles on map `m`;
/// returns each pass's flags, the passes that built the obstacles' views and those that
/// kept them for the tracks.
fn views_built(m: &TestMap) -> (Vec<u32>, Vec<u32>, Vec<u32>) {
    let mut r = Reflex::default();
    let (mut flags_k, mut built, mut kept) = (Vec::new(), Vec::new(), Vec::new());
    let mut store = ObstacleView::NONE;
    for k in 1..=40 {
        let inp = Input {
            servo: Some(servo_at([1.0, 1.0], [0.0; 2], k)),
            goal: planner([2.0, 1.0], k),
            health: healthy(k),
            obstacles_moving: true,
        };
        let mut map = ViewsMap {
            map: m.map(),
            pass: k,
            asked: false,
            built: &mut built,
            kept: &mut kept,
            store: &mut store,
            views: [ObstacleView::NONE; OBSTACLES],
        };
        let mut out = Output::default();
        r.step_into(&inp, &mut map, &mut out);
        flags_k.push(out.flags);
    }
    (flags_k, built, kept)
}

#[test]
fn the_obstacles_views_are_built_only_on_the_passes_that_read_them() {
    // Escaping from a block the map drew over the arm: nothing reads the views; the tracks'
    // samples are kept every TRACK_PASS_US (8 passes of 1 ms), none in between.
    let mut m = TestMap::new();
    let p = (1.0 / PIX).floor() as i32;
    m.block(p - 2, p + 6, p - 6, p + 6);
    let (fl, built, kept) = views_built(&m);
    assert!(
        fl.iter().skip(1).all(|f| f & flags::ESCAPING != 0),
        "{fl:x?}"
    );
    let step = evade::TRACK_PASS_US / 1000;
    let due: Vec<u32> = (1..=40u32).filter(|k| k.is_multiple_of(step)).collect();
    assert_eq!(built, Vec::<u32>::new());
    assert_eq!(kept, due);
    // Trapped (every pixel marked, nowhere to escape to): the evasion reads them every
    // pass, and they are built once a pass; the samples are kept as before.
    let mut m = TestMap::new();
    m.block(0, 127, 0, 127);
    let (fl, built, kept) = views_built(&m);
    let trapped: Vec<u32> = (1..=40u32)
        .filter(|k| fl[*k as usize - 1] & flags::TRAPPED != 0)
        .collect();
    assert!(trapped.len() > 30, "{fl:x?}");
    assert_eq!(built, trapped);
    assert_eq!(kept, due);
    // And the evasion takes the arm out of the way of the disk the views bring on.
    assert!(fl.iter().any(|f| f & flags::EVADING != 0), "{fl:x?}");
}

#[test]
fn an_arm_the_map_covers_among_resting_obstacles_holds_instead_of_crossing() {
    // The same block over the arm, but nothing moves: the arm is where it got through free
    // space (or started), so it holds (trapped) rather than cross marked pixels.
    let mut m = TestMap::new();
    let p = (1.0 / PIX).floor() as i32;
    m.block(p - 2, p + 6, p - 6, p + 6);
    let mut r = Reflex::default();
    let th = [1.0, 1.0];
    let mut held = 0;
    for k in 1..=40 {
        let inp = Input {
            servo: Some(servo_at(th, [0.0; 2], k)),
            goal: planner([2.0, 1.0], k),
            health: healthy(k),
            obstacles_moving: false,
        };
        let o = r.step(&inp, &mut m.map());
        if o.flags & flags::WAITING != 0 {
            continue;
        }
        held += 1;
        assert_eq!(o.flags & flags::ESCAPING, 0, "pass {k}");
        assert_ne!(
            o.flags & flags::TRAPPED,
            0,
            "pass {k}: flags {:#x}",
            o.flags
        );
        let s = sub(&o);
        assert!(
            (s[0] - th[0]).abs() < 1e-3 && (s[1] - th[1]).abs() < 1e-3,
            "pass {k}: {s:?}"
        );
    }
    assert!(held > 20, "{held} passes past start-up");
}

#[test]
fn a_stuck_arm_is_flagged_stalled() {
    let mut m = TestMap::new();
    let p = (1.0 / PIX).floor() as i32;
    m.block(p + 2, p + 5, 0, 127);
    let early = at_rest(&m, [1.0, 1.0], [2.0, 1.0], 100);
    assert_eq!(early.flags & flags::STALLED, 0);
    let o = at_rest(&m, [1.0, 1.0], [2.0, 1.0], 300);
    assert_ne!(o.flags & flags::STALLED, 0);
}

#[test]
fn a_stale_map_holds_the_arm_at_the_arrest_point_it_had_when_the_map_went_quiet() {
    let m = TestMap::new();
    let mut r = Reflex::default();
    let mut faults = Vec::new();
    let mut last = None;
    for k in 1..=200u32 {
        let mut h = healthy(k);
        if k > 50 {
            h.cspace_heartbeats = [50, 0, 0];
        }
        let sv = servo_at([1.0 + 0.02 * k as f64 / 100.0, 0.0], [20.0, 0.0], k);
        let o = r.step(
            &Input {
                servo: Some(sv),
                goal: planner([3.0, 0.0], k),
                health: h,
                obstacles_moving: false,
            },
            &mut m.map(),
        );
        if let Some(f) = o.new_fault {
            faults.push((k, f));
            // The arrest point of the moment the map went quiet: the pass MAP_STALE_US +
            // LOG_MARGIN_US (35 passes) before the one that noticed.
            let k0 = k - 35;
            last =
                Some(servo_at([1.0 + 0.02 * k0 as f64 / 100.0, 0.0], [20.0, 0.0], k0).arrest_urad);
        }
        if k > 85 {
            assert_ne!(o.flags & flags::HOLD, 0, "pass {k}");
            assert_eq!(o.subgoal_urad, last, "pass {k}");
        }
    }
    assert_eq!(faults.len(), 1, "{faults:?}");
    assert!(matches!(
        faults[0].1,
        Fault::Input(health::Problem::MapStale)
    ));
    assert!((80..=83).contains(&faults[0].0), "{faults:?}");
}

#[test]
fn a_torn_map_update_and_a_lagging_image_hold_the_arm() {
    let m = TestMap::new();
    for (what, want) in [
        (0, health::Problem::MapTorn),
        (1, health::Problem::MapLag),
        (2, health::Problem::ObjectsStale),
    ] {
        let mut r = Reflex::default();
        let mut got = None;
        for k in 1..=300u32 {
            let mut h = healthy(k);
            if k > 10 {
                match what {
                    0 => {
                        h.entries[2] = EntryView {
                            claim: 2,
                            state: 7,
                            ..Default::default()
                        }
                    }
                    1 => {
                        h.entries[4] = EntryView {
                            tracked: true,
                            lag_um: 40_000,
                            ..Default::default()
                        }
                    }
                    _ => h.objects_frame = 10,
                }
            }
            let o = r.step(&resting_at_origin(k, h), &mut m.map());
            if let Some(Fault::Input(p)) = o.new_fault {
                got.get_or_insert((k, p));
            }
        }
        let (k, p) = got.unwrap_or_else(|| panic!("case {what}: no fault"));
        assert_eq!(p, want);
        assert!(k < 130, "case {what}: fault at pass {k}");
    }
}

#[test]
fn a_stale_servo_state_or_planner_holds_the_arm() {
    let m = TestMap::new();
    // Servo: the same loop counter pass after pass.
    let mut r = Reflex::default();
    let mut fault = None;
    for k in 1..=60u32 {
        let mut sv = servo_at([0.5, 0.5], [0.0, 0.0], k.min(10));
        sv.t_us = 1000 * k;
        let o = r.step(
            &Input {
                servo: Some(sv),
                goal: planner([1.0, 1.0], k),
                health: healthy(k),
                obstacles_moving: false,
            },
            &mut m.map(),
        );
        fault = fault.or(o.new_fault);
    }
    assert_eq!(fault, Some(Fault::ServoStale));
    // Planner: the same cycle counter for longer than PLANNER_STALE_US.
    let mut r = Reflex::default();
    let mut fault = None;
    for k in 1..=100u32 {
        let o = r.step(
            &Input {
                servo: Some(servo_at([0.5, 0.5], [0.0, 0.0], k)),
                goal: planner([1.0, 1.0], k.min(20)),
                health: healthy(k),
                obstacles_moving: false,
            },
            &mut m.map(),
        );
        fault = fault.or(o.new_fault);
        if k > 75 {
            assert_eq!(o.subgoal_urad, Some([500_000, 500_000]));
        }
    }
    assert_eq!(fault, Some(Fault::PlannerStale));
    // Planner: its record left torn (GoalInput::None) for longer than PLANNER_STALE_US.
    let mut r = Reflex::default();
    let mut fault = None;
    for k in 1..=100u32 {
        let goal = if k <= 20 {
            planner([1.0, 1.0], k)
        } else {
            GoalInput::None
        };
        let o = r.step(
            &Input {
                servo: Some(servo_at([0.5, 0.5], [0.0, 0.0], k)),
                goal,
                health: healthy(k),
                obstacles_moving: false,
            },
            &mut m.map(),
        );
        fault = fault.or(o.new_fault);
        if k > 75 {
            assert_eq!(o.subgoal_urad, Some([500_000, 500_000]), "held at pass {k}");
        }
    }
    assert_eq!(fault, Some(Fault::PlannerStale));
}

#[test]
fn nothing_is_published_before_the_servo_is_and_the_arm_holds_until_the_map_is_good() {
    let m = TestMap::new();
    let mut r = Reflex::default();
    let o = r.step(
        &Input {
            servo: None,
            goal: GoalInput::None,
            health: healthy(1),
            obstacles_moving: false,
        },
        &mut m.map(),
    );
    assert_eq!(o.subgoal_urad, None);
    // No C-space board yet: hold, without a fault during start-up.
    for k in 1..=100u32 {
        let mut h = healthy(k);
        h.cspace_heartbeats = [0; 3];
        let o = r.step(
            &Input {
                servo: Some(servo_at([0.3, 0.2], [0.0, 0.0], k)),
                goal: planner([1.0, 1.0], k),
                health: h,
                obstacles_moving: false,
            },
            &mut m.map(),
        );
        assert_eq!(o.subgoal_urad, Some([300_000, 200_000]));
        assert_eq!(o.new_fault, None);
    }
}

fn forward(p: [i32; 2]) -> (f64, f64) {
    arm::geometry::tip(p[0] as f64 / RAD, p[1] as f64 / RAD)
}

proptest! {
    #[test]
    fn the_wands_poses_put_the_tip_on_the_wand(x in -480_000i32..480_000, y in -480_000i32..480_000) {
        let r = (x as f64).hypot(y as f64);
        prop_assume!(r > 20_000.0 && r < 495_000.0);
        for p in goal::inverse(x, y) {
            let (tx, ty) = forward(p);
            let e = (tx * 1e6 - x as f64).hypot(ty * 1e6 - y as f64);
            prop_assert!(e < 60.0, "pose {p:?}: tip {e:.1} um off");
        }
    }

    #[test]
    fn the_chosen_pose_is_the_nearer_one_on_the_torus(a in -3_000_000i32..3_000_000, b in -3_000_000i32..3_000_000, t in -12_000_000i32..12_000_000) {
        let p = [[a, b], [b, a]];
        let near = [t, t / 2];
        let q = goal::choose(p, near);
        for i in 0..2 {
            prop_assert!((q[i] - near[i]).abs() <= fx::trig::PI_URAD);
            prop_assert_eq!(goal::wrap(q[i]), goal::wrap(q[i]));
        }
    }
}

/// An ideal time-optimal servo per link: full acceleration toward the setpoint until the
/// braking curve at u^ (the reflex's own braking model) is met, then braking along it; the
/// arrest point the real servo publishes. Speed limited to the motors' limit.
struct IdealArm {
    theta: [f64; 2],
    omega: [f64; 2],
    goal: [f64; 2],
}

impl IdealArm {
    fn acc(i: usize) -> f64 {
        arm::LINKS[i].max_accel_rad_s2()
    }
    fn brake(i: usize) -> f64 {
        BRAKE_U_S2[i] as f64 * 2.0 * std::f64::consts::PI / 32768.0
    }
    fn step(&mut self, dt: f64) {
        for i in 0..2 {
            let e = self.goal[i] - self.theta[i];
            let w = self.omega[i];
            let b = Self::brake(i);
            let stop = w * w.abs() / (2.0 * b);
            let u = if e.abs() < 1e-4 && w.abs() < 0.02 {
                self.omega[i] = 0.0;
                continue;
            } else if (e - stop) > 0.0 {
                Self::acc(i).min((e - stop) / (dt * dt) + 0.0)
            } else {
                -Self::acc(i).min((stop - e) / (dt * dt))
            };
            // Braking never exceeds the reflex's braking model.
            let u = if u * w < 0.0 { u.clamp(-b, b) } else { u };
            self.omega[i] = (w + u * dt).clamp(
                -arm::LINKS[i].max_speed_rad_s,
                arm::LINKS[i].max_speed_rad_s,
            );
            self.theta[i] += (w + self.omega[i]) / 2.0 * dt;
        }
    }
    fn view(&self, k: u32) -> ServoView {
        let arrest =
            |i: usize| self.theta[i] + self.omega[i] * self.omega[i].abs() / (2.0 * Self::brake(i));
        ServoView {
            theta_urad: [(self.theta[0] * RAD) as i32, (self.theta[1] * RAD) as i32],
            omega_urad_s: [(self.omega[0] * RAD) as i32, (self.omega[1] * RAD) as i32],
            arrest_urad: [(arrest(0) * RAD) as i32, (arrest(1) * RAD) as i32],
            t_us: 1000 * k,
            loops: k,
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn the_closed_loop_never_enters_an_obstacle(
        blocks in proptest::collection::vec((0i32..128, 0i32..128, 1i32..12, 1i32..12), 1..6),
        start in (0i32..128, 0i32..128),
        goal in (-6.0f64..6.0, -6.0f64..6.0),
    ) {
        let mut m = TestMap::new();
        for &(a, c, w, h) in &blocks {
            m.block(a, a + w, c, c + h);
        }
        let s = [(start.0 as f64 + 0.5) * PIX, (start.1 as f64 + 0.5) * PIX];
        prop_assume!(!m.occupied(s[0], s[1]));
        let mut r = Reflex::default();
        let mut a = IdealArm { theta: s, omega: [0.0; 2], goal: s };
        // 1 kHz reflex, the state read at the start of a pass, the subgoal taken up half a
        // millisecond later; 10 us plant steps; 3 s.
        for k in 1..=3000u32 {
            let o = r.step(
                &Input { servo: Some(a.view(k)), goal: planner([s[0] + goal.0, s[1] + goal.1], k), health: healthy(k), obstacles_moving: false },
                &mut m.map(),
            );
            for j in 0..100 {
                if j == 50 {
                    if let Some(g) = o.subgoal_urad {
                        a.goal = [g[0] as f64 / RAD, g[1] as f64 / RAD];
                    }
                }
                a.step(1e-5);
                prop_assert!(!m.occupied(a.theta[0], a.theta[1]), "pass {k}: arm at {:?} entered an obstacle", a.theta);
            }
        }
    }
}

proptest! {
    /// The one-product conversion gives what the split one (two 32-bit products of the
    /// angle's halves, used until 2026-11-25) gave, over +-16 turns, where that one held.
    #[test]
    fn angle_units_match_the_split_product_conversion(a in -100_000_000i32..100_000_000) {
        let hi = (a >> 12) * 87_496;
        let lo = ((a & 0xFFF) * 87_496) >> 12;
        prop_assert_eq!(urad_to_u(a), (hi + lo) >> 12);
    }

    #[test]
    fn angle_units_are_within_one_of_exact(a in -25_000_000i32..25_000_000) {
        let exact = a as f64 * 32768.0 / (2.0 * std::f64::consts::PI * 1e6);
        let u = urad_to_u(a) as f64;
        prop_assert!((u - exact.floor()).abs() <= 1.0, "{a}: {u} vs {exact}");
    }
}

#[test]
fn an_arm_resting_in_the_margin_backs_off_though_its_goal_keeps_changing() {
    // Planner campaign seed 1 scene 509: the arm at rest a little over a quarter pixel from
    // a wall, its own neighbourhood free but its base rectangle (with the margin for the
    // obstacles' motion) not: it brakes, at rest, for good. A planner that takes each stall
    // for a wall holds it for a moment (the goal at the arm) and moves its request on; that
    // restarted the stall clock, so the arm never backed off and never moved in 10 s.
    let mut m = TestMap::new();
    let p = (1.0 / PIX).floor() as i32;
    m.block(p - 6, p - 1, 0, 127);
    // 70 angle units into pixel p: the wall's edge is 70 units away.
    let th0 = [(p as f64 + 70.0 / 256.0) * PIX, 1.0];
    let mut r = Reflex::default();
    let mut th = th0;
    for k in 1..=1500u32 {
        // 200 ms toward a goal away from the wall, then 50 ms holding where the arm is.
        let goal = if k % 250 < 200 {
            [th0[0] + 0.5, 1.0]
        } else {
            th
        };
        let inp = Input {
            servo: Some(servo_at(th, [0.0; 2], k)),
            goal: planner(goal, k),
            health: healthy(k),
            obstacles_moving: false,
        };
        let o = r.step(&inp, &mut m.map());
        if o.flags & flags::WAITING != 0 {
            continue;
        }
        // The arm goes where it is told (at rest at the subgoal by the next pass).
        th = sub(&o);
        assert!(
            !m.occupied(th[0], th[1]),
            "pass {k}: entered the wall at {th:?}"
        );
    }
    assert!(
        th[0] > th0[0] + 0.25,
        "the arm stayed at {th:?} (from {th0:?})"
    );
}

/// A global RAM with the map's words written one by one and each written column's
/// generation raised after, as the C-space boards' canvas does.
struct Gram(Vec<u8>);

impl Gram {
    fn new() -> Self {
        Gram(vec![0; vme_map::layout::CSPACE_MAP as usize + 0x1_0000])
    }
    fn bus(&mut self) -> vme_map::ArrayBus<'_> {
        vme_map::ArrayBus::new(&mut self.0)
    }
    /// Writes pixel (`i1`, `i2`)'s word (`stripe`: column `i1`'s stripe word) and raises
    /// the column's generation.
    fn write(&mut self, i1: u32, i2: u32, stripe: bool, v: u32) {
        use vme_map::GlobalBus;
        let mut g = self.bus();
        let off = if stripe {
            vme_map::layout::CSPACE_STRIPES + 4 * i1
        } else {
            vme_map::layout::cspace_counter(i1, i2, 0)
        };
        g.write_u32(off, v);
        vme_map::layout::raise_column_gen(&mut g, i1);
    }
}

/// One step of the known-columns check: a write (pixel or stripe, set or cleared) or a
/// rectangle or column asked.
#[derive(Clone, Debug)]
enum KnownOp {
    Write {
        i1: u32,
        i2: u32,
        stripe: bool,
        set: bool,
    },
    Rect {
        lo1: i32,
        n1: i32,
        lo2: i32,
        n2: i32,
        /// Found free, the rectangle is then kept as the pass's proved window
        /// (`Known::proved_free`), which later passes trust while the map's epoch stays.
        prove: bool,
    },
    Col {
        i1: i32,
        lo2: i32,
        n2: i32,
    },
    /// The last rectangle asked again, in a pass of its own (what a reflex braking or
    /// escaping asks pass after pass: `Known`'s blocked rectangles).
    Again,
}

fn known_op() -> impl Strategy<Value = KnownOp> {
    prop_oneof![
        (
            0u32..128,
            0u32..128,
            prop::bool::weighted(0.1),
            any::<bool>()
        )
            .prop_map(|(i1, i2, stripe, set)| KnownOp::Write {
                i1,
                i2,
                stripe,
                set
            }),
        // Rectangles near one place (what the reflex asks pass after pass), across the
        // torus's edges, up to the whole axis.
        (-20i32..20, 1i32..40, -20i32..20, 1i32..140, any::<bool>()).prop_map(
            |(lo1, n1, lo2, n2, prove)| KnownOp::Rect {
                lo1,
                n1,
                lo2,
                n2,
                prove
            }
        ),
        (-20i32..20, -20i32..20, 1i32..140).prop_map(|(i1, lo2, n2)| KnownOp::Col { i1, lo2, n2 }),
        Just(KnownOp::Again),
    ]
}

/// Runs `ops` over a map holding `start`'s pixels, each question a pass of its own
/// (`Known::begin`): every answer of the known columns must be a full read's. With
/// `trust`, a free rectangle asked with `prove` is kept as the pass's proved window, which
/// later passes trust while the map's epoch stays; without, a free rectangle asked again
/// must read no word.
fn known_ops_answer_as_full_reads(
    ops: &[KnownOp],
    start: &[(u32, u32)],
    trust: bool,
) -> Result<(), TestCaseError> {
    let mut gram = Gram::new();
    for &(i1, i2) in start {
        gram.write(i1, i2, false, 1);
    }
    let mut k = window::Known::new();
    let mut last: Option<KnownOp> = None;
    for op in ops {
        let op = match (op, &last) {
            (KnownOp::Again, Some(r)) => r.clone(),
            (KnownOp::Rect { .. }, _) => {
                last = Some(op.clone());
                op.clone()
            }
            _ => op.clone(),
        };
        match op {
            KnownOp::Write {
                i1,
                i2,
                stripe,
                set,
            } => gram.write(i1, i2, stripe, set as u32),
            KnownOp::Again => {}
            KnownOp::Rect {
                lo1,
                n1,
                lo2,
                n2,
                prove,
            } => {
                let s1 = Span {
                    lo: lo1,
                    hi: lo1 + n1 - 1,
                };
                let s2 = Span {
                    lo: lo2,
                    hi: lo2 + n2 - 1,
                };
                let mut g = gram.bus();
                let mut m = window::BusMap(&mut g);
                k.begin(&mut m);
                let (mut t_full, mut t_known, mut t_again) = (0, 0, 0);
                let full = window::rect_free(&mut m, s1, s2, &mut t_full);
                let known = window::rect_free_known(&mut m, &mut k, s1, s2, &mut t_known);
                prop_assert_eq!(known, full, "{:?}", op);
                let again = window::rect_free_known(&mut m, &mut k, s1, s2, &mut t_again);
                prop_assert_eq!(again, full);
                if full && !trust {
                    prop_assert_eq!(t_again, 0, "a free rectangle asked again is read again");
                }
                if full && trust && prove {
                    k.proved_free(&window::Grown {
                        window: [s1, s2],
                        blocked: [false; 2],
                    });
                }
            }
            KnownOp::Col { i1, lo2, n2 } => {
                let s2 = Span {
                    lo: lo2,
                    hi: lo2 + n2 - 1,
                };
                let mut g = gram.bus();
                let mut m = window::BusMap(&mut g);
                k.begin(&mut m);
                let (mut t_full, mut t_known) = (0, 0);
                let full = window::col_free(&mut m, i1, s2, &mut t_full);
                let known = window::col_free_known(&mut m, &mut k, i1, s2, &mut t_known);
                prop_assert_eq!(known, full, "{:?}", op);
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    /// Whatever was written between the questions (each write followed by its column's
    /// raise), the rectangles and columns the known columns call free are exactly the
    /// ones a full read calls free; and a question asked again with nothing written reads
    /// no word.
    #[test]
    fn known_columns_answer_as_a_full_read(
        ops in proptest::collection::vec(known_op(), 1..120),
        start in proptest::collection::vec((0u32..128, 0u32..128), 0..40),
    ) {
        known_ops_answer_as_full_reads(&ops, &start, false)?;
    }

    /// The same with windows proved free in one pass trusted by the next while the map's
    /// epoch stays (`Known::begin`, `Known::proved_free`): a write anywhere, its column
    /// raised, ends the trust, so no answer outlives a write.
    #[test]
    fn trusted_windows_answer_as_a_full_read(
        ops in proptest::collection::vec(known_op(), 1..120),
        start in proptest::collection::vec((0u32..128, 0u32..128), 0..40),
    ) {
        known_ops_answer_as_full_reads(&ops, &start, true)?;
    }
}

/// One step of the kept-escape check: a pixel or stripe written (its column raised), or an
/// escape planned from near (60, 60).
#[derive(Clone, Debug)]
enum EscapeOp {
    Write {
        i1: u32,
        i2: u32,
        stripe: bool,
        set: bool,
    },
    Plan {
        at: [i32; 2],
        toward: [i32; 2],
        clear: i32,
        cross: bool,
    },
    /// A redraw across the window: one pixel in row `i2` of each of `n` columns from
    /// window column `from` (more than `escape::RELOAD_MAX_COLS`: the window read whole).
    Band {
        from: i32,
        n: i32,
        i2: u32,
        set: bool,
    },
}

/// The column the kept-escape check centres on: next to the map's seam, so the window
/// wraps and the arm's unwrapped pixel crosses zero.
const ESCAPE_AT: i32 = 3;

fn escape_op() -> impl Strategy<Value = EscapeOp> {
    prop_oneof![
        (
            -16i32..16,
            44u32..76,
            prop::bool::weighted(0.05),
            any::<bool>()
        )
            .prop_map(|(d1, i2, stripe, set)| EscapeOp::Write {
                i1: ((ESCAPE_AT + d1) & 127) as u32,
                i2,
                stripe,
                set
            }),
        (-18i32..0, 1i32..34, 44u32..76, any::<bool>())
            .prop_map(|(from, n, i2, set)| EscapeOp::Band { from, n, i2, set }),
        // Few places and clearances, so that asks repeat (the kept plan's case); the arm's
        // angle unwrapped by a turn either way too (the same pixels).
        (
            0i32..2,
            prop_oneof![6 => Just(0i32), 1 => Just(-1), 1 => Just(1)],
            0i32..2,
            any::<bool>()
        )
            .prop_map(|(a, turn, c, cross)| {
                EscapeOp::Plan {
                    at: [ESCAPE_AT + a + 128 * turn, 60],
                    toward: [ESCAPE_AT + 20, 40],
                    clear: 1 + 2 * c,
                    cross,
                }
            }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    /// The escape keeps its last plan while the ask and the window's columns stay; whatever
    /// was written between the plans, a kept plan is the one fresh bitmaps find, its window
    /// (read again only in the columns written) is the one they read, and an ask repeated
    /// with nothing written reads no word.
    #[test]
    fn a_kept_escape_plan_is_the_one_planned_afresh(
        start in proptest::collection::vec((-20i32..20, 40u32..80), 0..400),
        ops in proptest::collection::vec(escape_op(), 1..80),
    ) {
        let mut gram = Gram::new();
        for &(d1, i2) in &start {
            gram.write(((ESCAPE_AT + d1) & 127) as u32, i2, false, 1);
        }
        let mut kept = escape::Scratch::new();
        let mut prev = None;
        for op in &ops {
            match *op {
                EscapeOp::Write { i1, i2, stripe, set } => gram.write(i1, i2, stripe, set as u32),
                EscapeOp::Band { from, n, i2, set } => {
                    for d1 in from..from + n {
                        gram.write(((ESCAPE_AT + d1) & 127) as u32, i2, false, set as u32);
                    }
                }
                EscapeOp::Plan { at, toward, clear, cross } => {
                    let ask = escape::Ask { at_px: at, toward_px: toward, clear_px: clear, cross, prev_px: prev };
                    let mut g = gram.bus();
                    let mut m = window::BusMap(&mut g);
                    let (mut t_kept, mut t_fresh, mut t_again) = (0, 0, 0);
                    let p = escape::plan(&mut m, &mut kept, &ask, &mut t_kept);
                    let mut anew = escape::Scratch::new();
                    let fresh = escape::plan(&mut m, &mut anew, &ask, &mut t_fresh);
                    prop_assert_eq!(p, fresh, "{:?}", op);
                    // The window as the kept plan holds it (read again in part, or kept) is
                    // the map's.
                    prop_assert_eq!(kept.window(), anew.window(), "{:?}", op);
                    let again = escape::plan(&mut m, &mut kept, &ask, &mut t_again);
                    prop_assert_eq!(again, fresh);
                    prop_assert_eq!(t_again, 0, "an ask repeated with nothing written is read again");
                    prop_assert_eq!(kept.take_vouched(), if t_kept == 0 { 2 } else { 1 } * 32 * 33);
                    prev = p.map(|p| p.target_px);
                }
            }
        }
    }
}

/// A rectangle read blocked is answered blocked again, without the known columns, while
/// the map's epoch stays (`Known`'s blocked rectangles, two kept), and read again once it
/// moves. Seen through a write in progress: a mark cleared and its column's generation
/// raised, the epoch not yet, which the known columns see at once and the kept rectangles
/// only once the epoch is raised.
#[test]
fn a_blocked_rectangle_is_answered_again_while_the_map_stays() {
    use vme_map::{layout, GlobalBus};
    let mut gram = Gram::new();
    gram.write(15, 35, false, 1);
    let mut k = window::Known::new();
    let span = |lo, hi| Span { lo, hi };
    let (r1, r2, r3) = (
        [span(10, 19), span(30, 49)],
        [span(14, 16), span(34, 36)],
        [span(15, 15), span(0, 127)],
    );
    // Each question a pass of its own (`Known::begin`).
    let mut free = |gram: &mut Gram, r: [Span; 2]| {
        let mut g = gram.bus();
        let mut m = window::BusMap(&mut g);
        k.begin(&mut m);
        window::rect_free_known(&mut m, &mut k, r[0], r[1], &mut 0)
    };
    let raise = |gram: &mut Gram, off: u32| {
        let mut g = gram.bus();
        let v = g.read_u32(off);
        g.write_u32(off, v + 1);
    };
    assert!(!free(&mut gram, r1));
    assert!(!free(&mut gram, r2));
    // A third goes over the older of the two (r1).
    assert!(!free(&mut gram, r3));
    gram.bus().write_u32(layout::cspace_counter(15, 35, 0), 0);
    raise(&mut gram, layout::cspace_gen(15));
    assert!(!free(&mut gram, r2), "kept");
    assert!(!free(&mut gram, r3), "kept");
    assert!(free(&mut gram, r1), "not kept: read again");
    raise(&mut gram, layout::CSPACE_EPOCH);
    assert!(free(&mut gram, r2));
    assert!(free(&mut gram, r3));
    // Marked again (written in full): blocked, kept, and cleared in full: free.
    gram.write(15, 35, false, 1);
    assert!(!free(&mut gram, r2));
    assert!(!free(&mut gram, r3));
    gram.write(15, 35, false, 0);
    // A rectangle read blocked after the epoch moved is kept alone: r3, read blocked
    // before, is free now.
    gram.write(60, 60, false, 1);
    assert!(!free(&mut gram, [span(60, 60), span(60, 60)]));
    assert!(free(&mut gram, r2));
    assert!(free(&mut gram, r3));
}

/// A column written after it was read free is read again (its generation moved), and only
/// that column: the others are vouched for.
#[test]
fn a_written_column_is_read_again_and_only_it() {
    let mut gram = Gram::new();
    let mut k = window::Known::new();
    let (s1, s2) = (Span { lo: 10, hi: 19 }, Span { lo: 30, hi: 49 });
    let ask = |gram: &mut Gram, k: &mut window::Known| {
        let mut g = gram.bus();
        let mut tests = 0;
        let free = window::rect_free_known(&mut window::BusMap(&mut g), k, s1, s2, &mut tests);
        (free, tests, k.take_vouched())
    };
    // First time: every column's stripe and 20 rows.
    assert_eq!(ask(&mut gram, &mut k), (true, 10 * 21, 0));
    assert_eq!(ask(&mut gram, &mut k), (true, 0, 200));
    // A pixel outside the rectangle, in column 12: that column read again, still free.
    gram.write(12, 60, false, 1);
    assert_eq!(ask(&mut gram, &mut k), (true, 21, 180));
    // Inside it: not free; the columns before 15 vouched for, 15 read up to the mark.
    gram.write(15, 35, false, 1);
    assert_eq!(ask(&mut gram, &mut k), (false, 1 + 6, 5 * 20));
    // The mark cleared: free again, column 15 read again.
    gram.write(15, 35, false, 0);
    let (free, tests, _) = ask(&mut gram, &mut k);
    assert!(free && tests == 21, "{tests}");
    // A stripe word set in column 19: not free.
    gram.write(19, 0, true, 1);
    assert!(!ask(&mut gram, &mut k).0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    /// The kept conversions answer as a fresh one, whatever came before (repeated
    /// angles, one component changed, both).
    #[test]
    fn kept_units_answer_as_a_fresh_conversion(
        seq in proptest::collection::vec(
            prop_oneof![Just(0i32), -7_000_000i32..7_000_000, Just(1_234_567)],
            2..60,
        ),
    ) {
        let mut k = Units::ZERO;
        for w in seq.windows(2) {
            let a = [w[0], w[1]];
            prop_assert_eq!(k.of(&a), [urad_to_u(a[0]), urad_to_u(a[1])]);
            prop_assert_eq!(k.of(&a), [urad_to_u(a[0]), urad_to_u(a[1])]);
        }
    }
}

/// The stall's quarter pixel is the conversion's.
#[test]
fn the_quarter_pixel_constant_is_the_conversion() {
    assert_eq!(QUARTER_PX_URAD, u_to_urad(PIX_U / 4));
}

/// `Output::clear` writes every field back to `Output::EMPTY` (it lists the fields again,
/// to keep the 68020 from a `memset` call).
#[test]
fn a_cleared_output_is_the_empty_one() {
    let mut out = Output {
        subgoal_urad: Some([1, 2]),
        flags: 3,
        goal_urad: [4, 5],
        window: [(6, 7), (8, 9)],
        tests: 10,
        known: 11,
        dt_us: 12,
        new_fault: Some(Fault::ServoStale),
    };
    out.clear();
    assert_eq!(out, Output::EMPTY);
}

#[test]
fn an_image_that_comes_onto_a_resting_arm_is_escaped_though_nothing_is_flagged_moving() {
    // The arm rests in free space; then, with no obstacle flagged moving (a disk creeping
    // too slowly for the sensing board's flag), the map marks a block over it with free
    // space 3 pixels to -theta1. The map came to the arm, so it crosses out rather than
    // hold while the disk walks in (the demo with its obstacles in the camera's view).
    let mut m = TestMap::new();
    let p = (1.0 / PIX).floor() as i32;
    let mut r = Reflex::default();
    let mut th = [1.0, 1.0];
    let (mut escaped, mut trapped) = (0, 0);
    for k in 1..=80 {
        if k == 30 {
            m.block(p - 2, p + 6, p - 6, p + 6);
        }
        let inp = Input {
            servo: Some(servo_at(th, [0.0; 2], k)),
            goal: planner(th, k),
            health: healthy(k),
            obstacles_moving: false,
        };
        let o = r.step(&inp, &mut m.map());
        if k < 30 {
            assert_eq!(o.flags & (flags::ESCAPING | flags::TRAPPED), 0, "pass {k}");
        }
        escaped += (o.flags & flags::ESCAPING != 0) as u32;
        trapped += (o.flags & flags::TRAPPED != 0) as u32;
        th = sub(&o);
    }
    assert!(
        escaped > 0 && trapped == 0,
        "{escaped} escaping, {trapped} trapped"
    );
    assert!(!m.occupied(th[0], th[1]), "ended inside at {th:?}");
}

#[test]
fn a_quiet_planner_stops_the_arm_but_not_its_escape_from_an_obstacle_that_comes_on() {
    // The planner's cycle counter freezes at pass 20: the arm holds at its arrest point (at
    // rest at 1.0, 1.0), the fault recorded once. At pass 100 a moving obstacle's image
    // comes over the arm: it escapes (the reflexes stay on with the planner gone), still
    // flagged holding, and leaves the marked pixels. The map's heartbeat then stops for
    // 50 passes: that hold is where the arm was, not back at the planner's point inside
    // the obstacle. When the planner comes back, the holds end.
    let mut m = TestMap::new();
    let p = (1.0 / PIX).floor() as i32;
    let mut r = Reflex::default();
    let mut th = [1.0, 1.0];
    let (mut faults, mut escaped, mut map_held) = (0, false, 0);
    for k in 1..=300u32 {
        if k == 100 {
            m.block(p - 2, p + 6, p - 6, p + 6);
        }
        let cycle = if k < 260 { k.min(20) } else { k };
        let mut health = healthy(k);
        if (170..220).contains(&k) {
            health.cspace_heartbeats[0] = 170;
        }
        let inp = Input {
            servo: Some(servo_at(th, [0.0; 2], k)),
            goal: planner([1.0, 1.0], cycle),
            health,
            obstacles_moving: true,
        };
        let o = r.step(&inp, &mut m.map());
        faults += o.new_fault.is_some() as u32;
        let s = sub(&o);
        if (80..100).contains(&k) {
            assert_eq!(o.flags & flags::HOLD, flags::HOLD, "pass {k}");
            assert_eq!(s, [1.0, 1.0], "pass {k}");
            assert!(r.holding());
        }
        if (100..260).contains(&k) {
            assert_ne!(o.flags & flags::HOLD, 0, "pass {k}");
            escaped |= o.flags & flags::ESCAPING != 0;
        }
        if (170..220).contains(&k) && o.flags == flags::HOLD {
            map_held += 1;
            assert!(!m.occupied(s[0], s[1]), "pass {k}: held inside at {s:?}");
        }
        if k > 265 {
            assert_eq!(o.flags & flags::HOLD, 0, "pass {k}");
            assert!(!r.holding());
        }
        th = s;
    }
    // The planner's silence, then the map's.
    assert_eq!(faults, 2);
    assert!(escaped);
    assert!(map_held > 10, "{map_held} passes held for the map");
    assert!(!m.occupied(th[0], th[1]), "ended inside at {th:?}");
}

#[test]
fn a_long_cspace_job_that_marks_its_progress_is_neither_torn_nor_stale() {
    // From pass 11 to 110 (100 ms, over both the 20 ms torn and the 30 ms stale limits) no
    // C-space heartbeat moves and entry 2 stays claimed by board 1. With its claim word's
    // count advancing every 8 ms (the job's marks) the arm carries on; with the word
    // frozen the reflex holds for a torn map, as an abandoned job.
    let m = TestMap::new();
    for marks in [true, false] {
        let mut r = Reflex::default();
        let mut fault = None;
        for k in 1..=110u32 {
            let mut h = healthy(k);
            if k > 10 {
                h.cspace_heartbeats[0] = 10;
                let n = if marks { k / 8 } else { 1 };
                h.entries[2] = EntryView {
                    claim: 1 | (n << 8),
                    state: 7,
                    ..Default::default()
                };
            }
            let o = r.step(&resting_at_origin(k, h), &mut m.map());
            fault = fault.or(o.new_fault);
        }
        if marks {
            assert_eq!(fault, None);
        } else {
            assert_eq!(fault, Some(Fault::Input(health::Problem::MapTorn)));
        }
    }
}
