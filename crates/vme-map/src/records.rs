//! The records of every data flow of design.md section 5, one writer each.
//!
//! Units are in the field names: `_urad` micro-radians of absolute joint angle (thesis
//! ch. II: link angles are absolute, so the links are decoupled), `_urad_s` micro-radians
//! per second, `_um` micrometres in the sensor's task-space frame, `_mnm` milli-newton-metres,
//! `_us` microseconds of the producer's clock.

use crate::record;

/// Number of LED beacons the sensing board strobes (thesis ch. II.3).
pub const BEACONS: usize = 8;

record! {
    /// One beacon's published position (written by the sensing board).
    pub struct Beacon {
        /// Position x in the task-space frame.
        pub x_um: i32,
        /// Position y in the task-space frame.
        pub y_um: i32,
        /// Time of the strobe the position comes from, sensing board clock.
        pub t_us: u32,
        /// Validity and quality flags ([`beacon_flags`]).
        pub flags: u32,
    }
}

const _: () = assert!(ObjectTable::FIELDS.len() as u32 == ObjectTable::WORDS);

/// Bits of [`Beacon::flags`].
pub mod beacon_flags {
    /// The position is valid (sum signal in range, not saturated).
    pub const VALID: u32 = 1 << 0;
    /// The beacon was occluded (sum signal near zero).
    pub const OCCLUDED: u32 = 1 << 1;
    /// An A/D input saturated.
    pub const SATURATED: u32 = 1 << 2;
    /// Drift / intensity correction was applied.
    pub const CORRECTED: u32 = 1 << 3;
}

/// Beacon assignment (thesis ch. II.3: 5 obstacles, robot tip, wand, instructional robot).
pub mod beacon_index {
    /// First of the five obstacle beacons (0..=4).
    pub const OBSTACLE0: usize = 0;
    /// The robot's tip LED.
    pub const TIP: usize = 5;
    /// The hand-held wand: the goal.
    pub const WAND: usize = 6;
    /// The small instructional (stepper) robot, a moving obstacle.
    pub const INSTRUCTIONAL: usize = 7;
}

use crate::record::Record;

/// The object position table written by the sensing board: a frame counter followed by the
/// eight beacons. Encoded by hand because it nests [`Beacon`]s.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ObjectTable {
    /// Number of complete strobe frames published.
    pub frame: u32,
    /// The beacons in strobe order.
    pub beacons: [Beacon; BEACONS],
}

impl Record for ObjectTable {
    const WORDS: u32 = 1 + BEACONS as u32 * Beacon::WORDS;
    const FIELDS: &'static [&'static str] = &[
        "frame", "b0.x_um", "b0.y_um", "b0.t_us", "b0.flags", "b1.x_um", "b1.y_um", "b1.t_us",
        "b1.flags", "b2.x_um", "b2.y_um", "b2.t_us", "b2.flags", "b3.x_um", "b3.y_um", "b3.t_us",
        "b3.flags", "b4.x_um", "b4.y_um", "b4.t_us", "b4.flags", "b5.x_um", "b5.y_um", "b5.t_us",
        "b5.flags", "b6.x_um", "b6.y_um", "b6.t_us", "b6.flags", "b7.x_um", "b7.y_um", "b7.t_us",
        "b7.flags",
    ];
    fn encode(&self, put: &mut dyn FnMut(u32, u32)) {
        put(0, self.frame);
        for (b, beacon) in self.beacons.iter().enumerate() {
            let base = 1 + b as u32 * Beacon::WORDS;
            beacon.encode(&mut |i, w| put(base + i, w));
        }
    }
    fn decode(get: &mut dyn FnMut(u32) -> u32) -> Self {
        let mut t = ObjectTable {
            frame: get(0),
            ..Default::default()
        };
        for (b, beacon) in t.beacons.iter_mut().enumerate() {
            let base = 1 + b as u32 * Beacon::WORDS;
            *beacon = Beacon::decode(&mut |i| get(base + i));
        }
        t
    }
}

record! {
    /// The servo's published state (written by the servo board, read by reflex and planner).
    pub struct ServoState {
        /// Link 1 absolute angle.
        pub theta1_urad: i32,
        /// Link 2 absolute angle.
        pub theta2_urad: i32,
        /// Link 1 observed velocity.
        pub omega1_urad_s: i32,
        /// Link 2 observed velocity.
        pub omega2_urad_s: i32,
        /// Link 1 arrest point: where it stops under full braking (thesis ch. V).
        pub arrest1_urad: i32,
        /// Link 2 arrest point.
        pub arrest2_urad: i32,
        /// Link 1 commanded torque.
        pub torque1_mnm: i32,
        /// Link 2 commanded torque.
        pub torque2_mnm: i32,
        /// Servo board time of the sample.
        pub t_us: u32,
        /// Servo loop counter.
        pub loops: u32,
    }
}

record! {
    /// The reflex's subgoal for the servo (written by the reflex board).
    pub struct ReflexSubgoal {
        /// Link 1 setpoint.
        pub goal1_urad: i32,
        /// Link 2 setpoint.
        pub goal2_urad: i32,
        /// Reflex flags (stalled, escaping, goal source).
        pub flags: u32,
        /// Reflex cycle counter.
        pub cycle: u32,
    }
}

record! {
    /// The planner's goal for the reflex (written by the planner board).
    pub struct PlannerGoal {
        /// Link 1 goal.
        pub goal1_urad: i32,
        /// Link 2 goal.
        pub goal2_urad: i32,
        /// Planner mode (free, wall-follow, unreachable).
        pub mode: u32,
        /// Why the planner is in that mode (e.g. the reason a goal is unreachable).
        pub reason: u32,
        /// Planner cycle counter.
        pub cycle: u32,
    }
}

record! {
    /// Commands from the host workstation (written by the host only).
    pub struct HostCommand {
        /// Command code (0 = none, run, stop, fault injection).
        pub command: u32,
        /// Command argument.
        pub arg0: u32,
        /// Command argument.
        pub arg1: u32,
        /// Host command counter; boards act on each value once.
        pub serial: u32,
    }
}

/// Number of entries in the C-space work list.
pub const WORK_ENTRIES: usize = 16;

record! {
    /// One transform job of the C-space work list (thesis line 1225: a circular list and a
    /// semaphore shared by several C-space boards). The `claim` word is only ever changed
    /// with [`crate::GlobalBus::cas_u32`]; the rest of the entry has exactly one writer, the
    /// board whose claim succeeded.
    pub struct WorkEntry {
        /// 0 = free, otherwise 1 + index of the claiming board.
        pub claim: u32,
        /// Beacon whose obstacle this job transforms.
        pub beacon: u32,
        /// New obstacle centre x.
        pub x_um: i32,
        /// New obstacle centre y.
        pub y_um: i32,
        /// Obstacle radius.
        pub r_um: i32,
        /// Job state (queued, drawing, done).
        pub state: u32,
        /// Generation of the object table the job was made from.
        pub generation: u32,
        /// Reserved, zero.
        pub reserved: u32,
    }
}

/// Codes of [`HostCommand::command`].
pub mod host_cmd {
    /// No command.
    pub const NONE: u32 = 0;
    /// Diagnostic: board `arg0` reads an undecoded private-I/O address, taking a bus error.
    pub const INJECT_BUS_ERROR: u32 = 0x10;
    /// Diagnostic: board `arg0` panics.
    pub const INJECT_PANIC: u32 = 0x11;
}
