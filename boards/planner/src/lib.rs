//! The planner board: wires global RAM to the local planner of `crates/planner` (thesis
//! ch. VI). Each main-loop pass reads the servo's state, the reflex's flags and the wand's
//! beacon, refreshes a slice of its bitmap of the C-space map, runs a planner cycle and
//! publishes the request for the reflex (`PLANNER_GOAL`) with the mode and, when the goal
//! cannot be reached, why. The same code runs in the image (`src/main.rs`, volatile MMIO)
//! and in the simulator's native mode.
//!
//! Fail-safe: a torn servo state repeats the last request (mode `HOLD`); the reflex holds
//! the arm itself if this board stops publishing (its planner-stale check), so a halted
//! planner leaves the arm stopped and safe.
#![no_std]
#![deny(missing_docs)]

use board_shell::Shell;
use planner::{Input, Planner};
use reflex::window::BusMap;
use reflex::ServoView;
use regs::IoBus;
use vme_map::record::Record;
use vme_map::records::{beacon_flags, beacon_index, ObjectTable, ReflexSubgoal, ServoState};
use vme_map::{BoardId, BoardState, GlobalBus};

/// Words of the servo state record.
const SERVO_WORDS: usize = ServoState::WORDS as usize;
/// Words of the object table.
const OBJECT_WORDS: usize = ObjectTable::WORDS as usize;
/// Words of the reflex subgoal record.
const SUBGOAL_WORDS: usize = ReflexSubgoal::WORDS as usize;

/// The planner board's state between main-loop passes. The records are read raw into the
/// board (as on the reflex board: no records decoded on the stack, docs/toolchain.md).
pub struct Board {
    shell: Shell,
    planner: Planner,
    cycle: u32,
    /// Main-loop passes.
    passes: u32,
    servo_w: [u32; SERVO_WORDS],
    objects_w: [u32; OBJECT_WORDS],
    subgoal_w: [u32; SUBGOAL_WORDS],
    input: Input,
}

impl Default for Board {
    fn default() -> Self {
        Self::new()
    }
}

impl Board {
    /// A fresh board.
    pub const fn new() -> Self {
        Self::with_config(planner::Config::DEFAULT)
    }

    /// A fresh board whose planner has `cfg` (the simulator's scenarios can ask for the
    /// thesis's line-of-sight rule, `planner::Leave`).
    pub const fn with_config(cfg: planner::Config) -> Self {
        Self {
            shell: Shell::new(BoardId::Planner),
            planner: Planner::with_config(cfg),
            cycle: 0,
            passes: 0,
            servo_w: [0; SERVO_WORDS],
            objects_w: [0; OBJECT_WORDS],
            subgoal_w: [0; SUBGOAL_WORDS],
            input: Input {
                servo: None,
                reflex_flags: None,
                wand_um: None,
            },
        }
    }

    /// The board's identity.
    pub const fn id(&self) -> BoardId {
        self.shell.id()
    }

    /// The planner logic, for benches and tests to read its counters.
    pub fn planner(&self) -> &Planner {
        &self.planner
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
        let servo = match vme_map::SERVO_STATE.read_raw(g, &mut self.servo_w) {
            // The servo has not published yet: nothing to do.
            Ok(0) => return self.shell.end(g, BoardState::Running),
            Ok(_) => Some(ServoView::from_words(&self.servo_w)),
            Err(_) => None,
        };
        let flags = match vme_map::REFLEX_SUBGOAL.read_raw(g, &mut self.subgoal_w) {
            Ok(0) | Err(_) => None,
            Ok(_) => Some(self.subgoal_w[2]),
        };
        // The wand every sixteenth pass: it moves little in 16 ms, and the 33-word table is a
        // tenth of a pass to read.
        self.passes = self.passes.wrapping_add(1);
        if self.passes & 15 == 1 {
            let ok = vme_map::OBJECTS.read_raw(g, &mut self.objects_w).is_ok();
            self.input.wand_um = wand(&self.objects_w, ok);
        }
        let inp = &mut self.input;
        inp.servo = servo;
        inp.reflex_flags = flags;
        let out = self.planner.step(&self.input, &mut BusMap(&mut *g));
        if out.publish {
            self.cycle = self.cycle.wrapping_add(1);
            publish(
                g,
                &[
                    out.request_urad[0] as u32,
                    out.request_urad[1] as u32,
                    out.mode,
                    out.reason,
                    self.cycle,
                ],
            );
        }
        self.shell.end(g, BoardState::Running)
    }
}

/// Publishes the planner's goal record (`PlannerGoal`'s words).
#[inline(never)]
fn publish<G: GlobalBus>(g: &mut G, w: &[u32; vme_map::records::PlannerGoal::WORDS as usize]) {
    vme_map::PLANNER_GOAL.publish_raw(g, w);
}

/// The wand's position, if the table read whole and the wand is valid.
#[inline(never)]
fn wand(t: &[u32; OBJECT_WORDS], ok: bool) -> Option<[i32; 2]> {
    let b = 1 + 4 * beacon_index::WAND;
    if ok && t[b + 3] & beacon_flags::VALID != 0 {
        Some([t[b] as i32, t[b + 1] as i32])
    } else {
        None
    }
}

/// The board's safe state: no outputs but global RAM. Also the image's safe-stop hook after a fault.
pub fn safe(io: &mut impl IoBus) {
    let _ = io;
}
