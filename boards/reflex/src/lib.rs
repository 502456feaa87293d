//! The reflex board: wires global RAM to the reflex control of `crates/reflex` (thesis ch. V).
//! Each main-loop pass reads the servo's state, the goal (the planner's record, or the wand's
//! beacon when no planner publishes), the freshness of the map and of the obstacle positions,
//! tests the lookahead window in the C-space map, and publishes the reflex subgoal for the
//! servo and the pass's status. The same code runs in the image (`src/main.rs`, volatile
//! MMIO) and in the simulator's native mode.
//!
//! Fail-safe (`crates/reflex`, module `health`): a stale or torn map, stale obstacle
//! positions, a stale or torn servo state or a planner that stopped make the reflex hold the
//! arm at its arrest point and record the fault (state `Degraded`).
#![no_std]
#![deny(missing_docs)]

use board_shell::Shell;
use cspace::worklist::{self, OBSTACLE_BEACONS};
use reflex::health::{EntryView, HealthInput, Problem, ENTRIES};
use reflex::window::{BusMap, Map};
use reflex::{Fault, GoalInput, Input, Reflex, ServoView};
use regs::IoBus;
use vme_map::layout::CSPACE_SIDE;
use vme_map::record::Record;
use vme_map::records::{
    beacon_flags, beacon_index, ObjectTable, PlannerGoal, ReflexStatus, ReflexSubgoal, ServoState,
};
use vme_map::{BoardId, BoardSlot, BoardState, FaultCode, GlobalBus};

/// Words of the servo state record.
const SERVO_WORDS: usize = ServoState::WORDS as usize;
/// Words of the object table.
const OBJECT_WORDS: usize = ObjectTable::WORDS as usize;
/// Words of the planner's goal record.
const PLANNER_WORDS: usize = PlannerGoal::WORDS as usize;

/// The reflex board's state between main-loop passes.
///
/// The records it reads are kept as raw words in the board (read with
/// `SeqLock::read_raw`, generic over the bus: decoding them through the records' dynamic
/// closures cost 50,000 cycles a pass on the 68020) and read through references (a
/// 136-byte table in an `Option` on the stack was misread on the 68k, docs/toolchain.md).
/// `repr(C)`, the small fields first and the reflex last: the compiled code reaches a field
/// more than 127 bytes in through an index register it loads first (docs/toolchain.md).
#[repr(C)]
pub struct Board {
    cycle: u32,
    /// The work-list entry read last.
    entry: u32,
    /// Whether this pass's read of the object table was whole.
    objects_ok: bool,
    /// The reflex's outputs, written in place each pass.
    out: reflex::Output,
    shell: Shell,
    /// The reflex's inputs, updated in place each pass.
    input: Input,
    /// The servo state's words.
    servo_w: [u32; SERVO_WORDS],
    /// The planner goal's words.
    planner_w: [u32; PLANNER_WORDS],
    /// The object table's words as last read: frame, then x, y, t_us, flags per beacon.
    objects_w: [u32; OBJECT_WORDS],
    /// The obstacles as sensed, for the evasion: built on the passes that ask
    /// ([`SensedMap`]).
    views: [reflex::ObstacleView; reflex::OBSTACLES],
    /// What the tracks' last sampling pass sensed, made into views one a pass after.
    kept: Kept,
    reflex: Reflex,
}

/// The sensed obstacles as a pass of the reflex's tracks kept them (`Map::keep_obstacles`):
/// the object table's words, whether it was read whole, and the radii. A view is made of
/// them on a later pass (`Map::kept_view`) as [`view`] would have made it on that pass
/// (the calibrated square of a reading beyond it is read then: the calibration's, fixed
/// while the boards run).
struct Kept {
    objects: [u32; OBJECT_WORDS],
    ok: bool,
    radii_um: [i32; reflex::OBSTACLES],
}

impl Default for Board {
    fn default() -> Self {
        Self::new()
    }
}

/// Word `w` (0 x, 1 y, 2 t_us, 3 flags) of beacon `b` in the object table's words.
#[inline(always)]
fn beacon_word(t: &[u32; OBJECT_WORDS], b: usize, w: usize) -> u32 {
    t[1 + 4 * b + w]
}

/// Whether beacon `b` of an object table read whole (`ok`) is flagged valid.
#[inline(always)]
fn beacon_valid(t: &[u32; OBJECT_WORDS], b: usize, ok: bool) -> bool {
    ok && beacon_word(t, b, 3) & beacon_flags::VALID != 0
}

impl Board {
    /// A fresh board.
    pub const fn new() -> Self {
        Self {
            shell: Shell::new(BoardId::Reflex),
            reflex: Reflex::new(reflex::Config::DEFAULT),
            cycle: 0,
            servo_w: [0; SERVO_WORDS],
            objects_w: [0; OBJECT_WORDS],
            objects_ok: false,
            planner_w: [0; PLANNER_WORDS],
            input: Input {
                servo: None,
                goal: GoalInput::None,
                health: HealthInput {
                    cspace_heartbeats: [0; 3],
                    objects_frame: 0,
                    objects_torn: true,
                    entries: [EntryView::EMPTY; ENTRIES],
                    fresh: 0,
                },
                obstacles_moving: false,
            },
            views: reflex::NO_OBSTACLES,
            kept: Kept {
                objects: [0; OBJECT_WORDS],
                ok: false,
                radii_um: [0; reflex::OBSTACLES],
            },
            entry: 0,
            out: reflex::Output::EMPTY,
        }
    }

    /// The board's identity.
    pub const fn id(&self) -> BoardId {
        self.shell.id()
    }

    /// Puts the outputs in their safe state and waits for the global RAM header.
    pub fn boot(&mut self, g: &mut dyn GlobalBus, io: &mut impl IoBus) {
        safe(io);
        self.shell.boot(g, || {});
    }

    /// One pass of the main loop. Returns the new heartbeat. Generic over the bus so the
    /// image's record and map reads are inlined volatile words.
    pub fn poll<G: GlobalBus>(&mut self, g: &mut G, io: &mut impl IoBus) -> u32 {
        self.shell.begin(g, io);
        let servo_ok = match vme_map::SERVO_STATE.read_raw(g, &mut self.servo_w) {
            // The servo has not published yet: nothing to do.
            Ok(0) => return self.shell.end(g, BoardState::Running),
            Ok(_) => true,
            Err(_) => false,
        };
        // Straight into the board's copy: a torn read leaves it mixed, but then `objects_ok`
        // is false and nothing but the lag of entries that are not tracked looks at it.
        self.objects_ok = vme_map::OBJECTS.read_raw(g, &mut self.objects_w).is_ok();
        let ok = self.objects_ok;
        // Each arm writes the input's goal itself (a value built first and assigned was a
        // `memcpy` call a pass).
        match vme_map::PLANNER_GOAL.read_raw(g, &mut self.planner_w) {
            Ok(0) => wand(&mut self.input.goal, &self.objects_w, ok),
            Ok(_) => {
                self.input.goal = GoalInput::Planner {
                    goal_urad: [self.planner_w[0] as i32, self.planner_w[1] as i32],
                    cycle: self.planner_w[4],
                }
            }
            // The planner published once and now reads torn: keep the last goal.
            Err(_) => self.input.goal = GoalInput::None,
        }
        // The inputs are built in place in the board (copying them into a fresh value each
        // pass cost the 68020 thousands of cycles of memset and memcpy).
        let inp = &mut self.input;
        // Written in place (a value built first and assigned cost a `memcpy` call a pass).
        if servo_ok {
            ServoView::fill(&mut inp.servo, &self.servo_w);
        } else {
            inp.servo = None;
        }
        inp.health.objects_frame = self.objects_w[0];
        inp.health.objects_torn = !ok;
        // One work-list entry a pass, in turn (the health limits are 20-100 ms).
        // (A compare, not `%`: a division call on the 68020.)
        self.entry = if self.entry + 1 >= ENTRIES as u32 {
            0
        } else {
            self.entry + 1
        };
        fill_health(&mut inp.health, g, &self.objects_w, ok, self.entry);
        inp.health.fresh = 1 << self.entry;
        inp.obstacles_moving = ok && moving(&self.objects_w);
        // The obstacles' views are built when the reflex asks (among moving obstacles, on
        // the trapped passes), and kept on the tracks' sampling passes.
        let mut map = SensedMap {
            map: BusMap(&mut *g),
            objects: &self.objects_w,
            ok,
            views: &mut self.views,
            built: false,
            kept: &mut self.kept,
        };
        self.reflex.step_into(&self.input, &mut map, &mut self.out);
        let out = &self.out;
        if let Some(sub) = out.subgoal_urad {
            self.cycle = self.cycle.wrapping_add(1);
            let span = |s: (i32, i32)| {
                let n = (s.1 - s.0 + 1).clamp(1, CSPACE_SIDE as i32) as u32;
                (((s.0 as u32) & (CSPACE_SIDE - 1)) << 8) | (n & 0xFF)
            };
            publish(
                g,
                &[sub[0] as u32, sub[1] as u32, out.flags, self.cycle],
                &[
                    out.goal_urad[0] as u32,
                    out.goal_urad[1] as u32,
                    (span(out.window[0]) << 16) | span(out.window[1]),
                    out.tests,
                    out.known,
                    out.dt_us,
                ],
            );
        }
        if let Some(f) = out.new_fault {
            record_fault(&mut self.shell, g, f);
        }
        let state = if self.reflex.holding() {
            BoardState::Degraded
        } else {
            BoardState::Running
        };
        self.shell.end(g, state)
    }
}

/// Records the pass's new fault `f` in the board's slot (its code and the address of the
/// input that failed). Apart from the pass: inlined there, the branch on the fault tested a
/// register copy's flags (docs/toolchain.md, class 1).
#[inline(never)]
fn record_fault<G: GlobalBus>(shell: &mut Shell, g: &mut G, f: Fault) {
    let (code, at) = match f {
        Fault::ServoStale => (FaultCode::StaleHeartbeat, vme_map::SERVO_STATE.offset()),
        Fault::ServoTorn => (FaultCode::TornRecord, vme_map::SERVO_STATE.offset()),
        Fault::PlannerStale => (FaultCode::StaleHeartbeat, vme_map::PLANNER_GOAL.offset()),
        Fault::Input(Problem::MapStale) | Fault::Input(Problem::MapLag) => {
            (FaultCode::StaleHeartbeat, vme_map::layout::CSPACE_MAP)
        }
        Fault::Input(Problem::MapTorn) => (FaultCode::TornRecord, vme_map::layout::WORK_LIST),
        Fault::Input(Problem::ObjectsStale) => {
            (FaultCode::StaleHeartbeat, vme_map::OBJECTS.offset())
        }
    };
    shell.life().degraded(g, code, at);
}

/// Publishes the subgoal (`sub`: `ReflexSubgoal`'s words) and the pass's status (`status`:
/// `ReflexStatus`'s words).
#[inline(never)]
fn publish<G: GlobalBus>(
    g: &mut G,
    sub: &[u32; ReflexSubgoal::WORDS as usize],
    status: &[u32; ReflexStatus::WORDS as usize],
) {
    vme_map::REFLEX_SUBGOAL.publish_raw(g, sub);
    vme_map::REFLEX_STATUS.publish_raw(g, status);
}

/// The wand's position as the goal into `goal`, if the table is whole and the wand valid.
#[inline(never)]
fn wand(goal: &mut GoalInput, t: &[u32; OBJECT_WORDS], ok: bool) {
    let w = beacon_index::WAND;
    *goal = if beacon_valid(t, w, ok) {
        GoalInput::Wand {
            x_um: beacon_word(t, w, 0) as i32,
            y_um: beacon_word(t, w, 1) as i32,
        }
    } else {
        GoalInput::None
    };
}

/// Whether the sensing board flags any valid obstacle beacon as moving.
/// (The beacons named one by one: the loop over the table of indices cost the 68020 ~600
/// cycles a pass.)
#[inline(never)]
fn moving(t: &[u32; OBJECT_WORDS]) -> bool {
    const B: [usize; 6] = [
        OBSTACLE_BEACONS[0] as usize,
        OBSTACLE_BEACONS[1] as usize,
        OBSTACLE_BEACONS[2] as usize,
        OBSTACLE_BEACONS[3] as usize,
        OBSTACLE_BEACONS[4] as usize,
        OBSTACLE_BEACONS[5] as usize,
    ];
    // Flags words: the valid bit moved up to the moving bit's place, and both.
    let f = |b: usize| beacon_word(t, b, 3);
    let (f0, f1, f2) = (f(B[0]), f(B[1]), f(B[2]));
    let (f3, f4, f5) = (f(B[3]), f(B[4]), f(B[5]));
    let any = (f0 & (f0 << 7))
        | (f1 & (f1 << 7))
        | (f2 & (f2 << 7))
        | (f3 & (f3 << 7))
        | (f4 & (f4 << 7))
        | (f5 & (f5 << 7));
    any & beacon_flags::MOVING != 0
}

const _: () = assert!(reflex::OBSTACLES == OBSTACLE_BEACONS.len());

/// The obstacles for the evasion (`reflex::evade`): the sensing board's positions, the
/// host's radii (0: the default cylinder), a reading beyond the calibrated square as the
/// disk over its fold (`cspace::worklist::folded`, what the C-space boards draw), the
/// C-space boards' sweep estimates (the entry's last word: mm over the look-ahead, x and y
/// in 16 bits each) as velocities.
#[inline(never)]
fn obstacles<G: GlobalBus>(
    v: &mut [reflex::ObstacleView; reflex::OBSTACLES],
    g: &mut G,
    objects: &[u32; OBJECT_WORDS],
    ok: bool,
) {
    let mut i = 0;
    while i < reflex::OBSTACLES {
        let b = OBSTACLE_BEACONS[i] as usize;
        let valid = beacon_valid(objects, b, ok);
        v[i].valid = valid;
        // An invalid slot is read by nobody (the tracks start over on it, the evasion
        // skips it): its other words are left as they were (~1,200 cycles a slot a pass
        // on the 68020).
        if valid {
            view(&mut v[i], g, objects, i, b);
        }
        i += 1;
    }
}

/// One pass's C-space map in global RAM with the obstacles as sensed: the board's copy of
/// the object table (`ok`: it read whole), made into the evasion's `views` by [`obstacles`]
/// on the pass's first ask ([`Map::obstacle_views`]; `built` since), and into `kept` for
/// the tracks ([`Map::keep_obstacles`]). The map's reads are [`BusMap`]'s.
struct SensedMap<'a, G: GlobalBus> {
    map: BusMap<'a, G>,
    objects: &'a [u32; OBJECT_WORDS],
    ok: bool,
    views: &'a mut [reflex::ObstacleView; reflex::OBSTACLES],
    built: bool,
    kept: &'a mut Kept,
}

impl<G: GlobalBus> Map for SensedMap<'_, G> {
    #[inline(never)]
    fn obstacle_views(&mut self) -> &[reflex::ObstacleView; reflex::OBSTACLES] {
        if !self.built {
            obstacles(self.views, self.map.0, self.objects, self.ok);
            self.built = true;
        }
        self.views
    }
    #[inline(never)]
    fn keep_obstacles(&mut self) {
        self.kept.objects = *self.objects;
        self.kept.ok = self.ok;
        let mut i = 0;
        while i < reflex::OBSTACLES {
            self.kept.radii_um[i] = worklist::radius(self.map.0, i as u32);
            i += 1;
        }
    }
    #[inline(never)]
    fn kept_view(&mut self, i: usize, o: &mut reflex::ObstacleView) {
        let k = &*self.kept;
        let b = OBSTACLE_BEACONS[i] as usize;
        o.valid = beacon_valid(&k.objects, b, k.ok);
        if o.valid {
            position(o, self.map.0, &k.objects, k.radii_um[i], b);
        }
    }
    #[inline(always)]
    fn row_or(&mut self, i2: u32, i1: u32, n: u32) -> u32 {
        self.map.row_or(i2, i1, n)
    }
    #[inline(always)]
    fn col_or(&mut self, i1: u32, i2: u32, n: u32) -> u32 {
        self.map.col_or(i1, i2, n)
    }
    #[inline(always)]
    fn stripes_or(&mut self, i1: u32, n: u32) -> u32 {
        self.map.stripes_or(i1, n)
    }
    #[inline(always)]
    fn free_rows(&mut self, i2: u32, nb: u32, a0: u32, n0: u32, a1: u32, n1: u32) -> u32 {
        self.map.free_rows(i2, nb, a0, n0, a1, n1)
    }
    #[inline(always)]
    fn row_bits(&mut self, i2: u32, i1: u32) -> u32 {
        self.map.row_bits(i2, i1)
    }
    #[inline(always)]
    fn stripe_bits(&mut self, i1: u32) -> u32 {
        self.map.stripe_bits(i1)
    }
    #[inline(always)]
    fn row_run(&mut self, i2: u32, i1: u32) -> u32 {
        self.map.row_run(i2, i1)
    }
    #[inline(always)]
    fn stripe_run(&mut self, i1: u32) -> u32 {
        self.map.stripe_run(i1)
    }
    #[inline(always)]
    fn col_run(&mut self, i1: u32, i2: u32, n: u32) -> u32 {
        self.map.col_run(i1, i2, n)
    }
    #[inline(always)]
    fn col_bits(&mut self, i1: u32, i2: u32) -> u32 {
        self.map.col_bits(i1, i2)
    }
    #[inline(always)]
    fn gens_ptr(&mut self) -> Option<*const u32> {
        self.map.gens_ptr()
    }
    #[inline(always)]
    fn has_gens(&self) -> bool {
        self.map.has_gens()
    }
    #[inline(always)]
    fn column_gen(&mut self, i1: u32) -> u32 {
        self.map.column_gen(i1)
    }
    #[inline(always)]
    fn epoch(&mut self) -> u32 {
        self.map.epoch()
    }
}

/// Slot `i`'s view of valid beacon `b` (see [`obstacles`]).
#[inline(never)]
fn view<G: GlobalBus>(
    o: &mut reflex::ObstacleView,
    g: &mut G,
    objects: &[u32; OBJECT_WORDS],
    i: usize,
    b: usize,
) {
    let (sx, sy) = worklist::drawn_sweep_mm(g, i as u32);
    // mm over the look-ahead to um/s.
    const K: i32 = 1000 * 1000 / worklist::LOOKAHEAD_MS;
    let r_um = worklist::radius(g, i as u32);
    position(o, g, objects, r_um, b);
    o.vx_um_s = sx * K;
    o.vy_um_s = sy * K;
}

/// The position, radius and time of valid beacon `b` (radius `r_um` as the host set it)
/// into `o`: the disk the C-space boards draw.
#[inline(always)]
fn position<G: GlobalBus>(
    o: &mut reflex::ObstacleView,
    g: &mut G,
    objects: &[u32; OBJECT_WORDS],
    r_um: i32,
    b: usize,
) {
    let (x, y) = (
        beacon_word(objects, b, 0) as i32,
        beacon_word(objects, b, 1) as i32,
    );
    let flags = beacon_word(objects, b, 3);
    // The disk the C-space boards draw: a reading beyond the calibrated square (flagged
    // extrapolated) over its fold; only such a reading has one, so only it reads the
    // square and asks `fold_of` (~500 cycles a slot a pass otherwise).
    let fold = if flags & beacon_flags::EXTRAPOLATED != 0 {
        worklist::fold_of(x, y, flags, &worklist::calibrated_area(g))
    } else {
        0
    };
    let d = worklist::drawn_disk(x, y, r_um, fold);
    o.x_um = d.x_um;
    o.y_um = d.y_um;
    o.r_um = d.r_um;
    o.t_us = beacon_word(objects, b, 2);
}

/// The C-space heartbeats and work-list entry `i` into `h`, the entry against its obstacle's
/// sensed position in `objects`. Written through a reference in a non-inlined function: a
/// local array filled in a loop lost its index on the 68k (docs/toolchain.md, class 6).
#[inline(never)]
fn fill_health<G: GlobalBus>(
    h: &mut HealthInput,
    g: &mut G,
    objects: &[u32; OBJECT_WORDS],
    ok: bool,
    i: u32,
) {
    h.cspace_heartbeats[0] = g.read_u32(BoardSlot::of(BoardId::Cspace0).heartbeat());
    h.cspace_heartbeats[1] = g.read_u32(BoardSlot::of(BoardId::Cspace1).heartbeat());
    h.cspace_heartbeats[2] = g.read_u32(BoardSlot::of(BoardId::Cspace2).heartbeat());
    entry_view(&mut h.entries[i as usize], g, i, objects, ok);
}

/// Work-list entry `i` as the reflex's health monitor sees it: the words it needs, read
/// one by one (claim, x, y, state of `WorkEntry`).
#[inline(never)]
fn entry_view<G: GlobalBus>(
    v: &mut EntryView,
    g: &mut G,
    i: u32,
    objects: &[u32; OBJECT_WORDS],
    ok: bool,
) {
    let base = vme_map::layout::work_entry(i);
    let claim = g.read_u32(base);
    let (ex, ey) = (g.read_u32(base + 8) as i32, g.read_u32(base + 12) as i32);
    let state = g.read_u32(base + 20);
    let b = OBSTACLE_BEACONS[i as usize] as usize;
    let valid = beacon_valid(objects, b, ok);
    // The host wrote a radius for this entry: the obstacle exists, seen or not. One that
    // was never drawn leaves the map without it (an obstacle no sensor sees is not free
    // space).
    let exists = g.read_u32(vme_map::layout::OBSTACLE_RADII + 4 * i) != 0;
    let drawn = state & worklist::DRAWN != 0;
    let (bx, by) = (
        beacon_word(objects, b, 0) as i32,
        beacon_word(objects, b, 1) as i32,
    );
    let lag = (bx - ex).abs().max((by - ey).abs());
    v.claim = claim;
    v.state = state;
    v.tracked = valid && drawn;
    v.undrawn = (valid || exists) && !drawn;
    v.lag_um = lag;
}

/// The board's safe state: no outputs but global RAM. Also the image's safe-stop hook after a fault.
pub fn safe(io: &mut impl IoBus) {
    let _ = io;
}
