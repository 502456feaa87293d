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
    /// No good calibration table: the position is not in task space (never valid).
    pub const UNCALIBRATED: u32 = 1 << 4;
    /// The position lies outside the calibrated area (extrapolated from the table).
    pub const EXTRAPOLATED: u32 = 1 << 5;
    /// The filter holds fewer samples than its window (just (re)acquired).
    pub const FILLING: u32 = 1 << 6;
    /// The object is moving: the short (thesis, 32-sample) window is in use.
    pub const MOVING: u32 = 1 << 7;
    /// Bits 8..16: samples in the filter behind the position (saturating at 255).
    pub const SAMPLES_SHIFT: u32 = 8;
    /// Mask of the sample count after shifting by [`SAMPLES_SHIFT`].
    pub const SAMPLES_MASK: u32 = 0xFF;
    /// How far a valid position that is not [`EXTRAPOLATED`] may lie from its beacon,
    /// micrometres: the sensing board's promise to the boards that read it (held by
    /// `tests/tests/sensing.rs` over 3,360 places within the arm's reach, 2.3-2.7 mm at
    /// most there; `sim-host bench sensing`'s survey, 2.6 mm at most). The C-space boards
    /// grow every obstacle by it, so that the map holds the obstacle where it is, not only
    /// where it was read.
    pub const TOLERANCE_UM: i32 = 3_000;
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

/// Defines a per-beacon table: a frame counter followed by [`BEACONS`] nested records, with
/// its [`Record`] impl (the `record!` macro handles flat records only).
macro_rules! beacon_table {
    ($(#[$meta:meta])* $name:ident of $item:ident, [$($field:literal),+ $(,)?]) => {
        $(#[$meta])*
        // In word order (`repr(C)`), as in global RAM: the sensing board's assembly
        // addresses its copy by offset (`sensing::layout`).
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
        #[repr(C)]
        pub struct $name {
            /// Number of complete strobe frames published.
            pub frame: u32,
            /// The beacons in strobe order.
            pub beacons: [$item; BEACONS],
        }

        impl Record for $name {
            const WORDS: u32 = 1 + BEACONS as u32 * $item::WORDS;
            const FIELDS: &'static [&'static str] = &[
                "frame",
                $(concat!("b0.", $field),)+ $(concat!("b1.", $field),)+
                $(concat!("b2.", $field),)+ $(concat!("b3.", $field),)+
                $(concat!("b4.", $field),)+ $(concat!("b5.", $field),)+
                $(concat!("b6.", $field),)+ $(concat!("b7.", $field),)+
            ];
            fn encode(&self, put: &mut dyn FnMut(u32, u32)) {
                put(0, self.frame);
                for (b, beacon) in self.beacons.iter().enumerate() {
                    let base = 1 + b as u32 * $item::WORDS;
                    beacon.encode(&mut |i, w| put(base + i, w));
                }
            }
            fn decode(get: &mut dyn FnMut(u32) -> u32) -> Self {
                let mut t = $name {
                    frame: get(0),
                    ..Default::default()
                };
                for (b, beacon) in t.beacons.iter_mut().enumerate() {
                    let base = 1 + b as u32 * $item::WORDS;
                    *beacon = $item::decode(&mut |i| get(base + i));
                }
                t
            }
        }
    };
}

beacon_table!(
    /// The object position table written by the sensing board: a frame counter followed by
    /// the eight beacons.
    ObjectTable of Beacon, ["x_um", "y_um", "t_us", "flags"]
);

record! {
    /// One beacon's signals before calibration (written by the sensing board): what the host's
    /// calibration procedure records (thesis ch. II.3: "voltages x and y vs actual x and y").
    pub struct RawBeacon {
        /// Filtered x signal, A/D codes about mid-scale (signed), Q5 (1/32 code), after the
        /// strobe crosstalk correction and before drift correction and the calibration table.
        pub x_q5: i32,
        /// Filtered y signal, as `x_q5`.
        pub y_q5: i32,
        /// Sum signal of the latest sample, codes above 0 V.
        pub sum_codes: i32,
        /// LED drive current set point used for the latest sample, mA.
        pub level_ma: u32,
    }
}

beacon_table!(
    /// The raw signal table written by the sensing board beside [`ObjectTable`].
    RawTable of RawBeacon, ["x_q5", "y_q5", "sum_codes", "level_ma"]
);

record! {
    /// The sensing board's run-time drift estimate (written by the sensing board): the
    /// per-axis offset and gain of the position signals against the calibration, learnt from
    /// the robot tip's beacon at positions known from the encoders.
    pub struct SensingDrift {
        /// X offset, Q5 codes.
        pub ox_q5: i32,
        /// Y offset, Q5 codes.
        pub oy_q5: i32,
        /// X gain error, Q24 (0 = none).
        pub gx_q24: i32,
        /// Y gain error, Q24.
        pub gy_q24: i32,
        /// Tip observations used so far.
        pub observations: u32,
    }
}

record! {
    /// How the sensing board runs (written by the host). Never published (sequence 0): the
    /// board uses [`sensing_options::DEFAULT`] and its default sum level.
    pub struct SensingConfig {
        /// [`sensing_options`] bits.
        pub options: u32,
        /// Sum signal the LED current feedback holds every beacon at, codes above 0 V.
        pub s_ref_codes: u32,
        /// LED drive current when the feedback is off, mA.
        pub level_ma: u32,
        /// Host counter.
        pub serial: u32,
    }
}

/// Bits of [`SensingConfig::options`].
pub mod sensing_options {
    /// Drive each LED so its sum signal stays at the reference (thesis ch. II.3.5's
    /// proposal): removes LED intensity differences.
    pub const CURRENT_FEEDBACK: u32 = 1 << 0;
    /// Correct thermal drift with the tip beacon as a reference at encoder-known positions.
    pub const DRIFT_REFERENCE: u32 = 1 << 1;
    /// Long average for resting beacons, the thesis's 32 samples for moving ones.
    pub const ADAPTIVE_FILTER: u32 = 1 << 2;
    /// Remove the previous beacon's residue in the 40 us analog filter.
    pub const CROSSTALK: u32 = 1 << 3;
    /// Everything on: the default.
    pub const DEFAULT: u32 = CURRENT_FEEDBACK | DRIFT_REFERENCE | ADAPTIVE_FILTER | CROSSTALK;
}

/// The calibration table's format (thesis ch. II.3.3: the table of signals against true
/// positions from the 36 x 36, 2 cm scan, inverted to true positions against signals). The
/// host writes it at [`crate::SENSING_CAL`]; the sensing board checks it before use and again
/// whenever its generation word changes. Words are big-endian like all of global RAM.
///
/// | word | content |
/// |---|---|
/// | 0 | [`cal::MAGIC`] |
/// | 1 | [`cal::VERSION`] |
/// | 2 | generation: changed by the host on every write |
/// | 3 | [`cal::WORDS`] |
/// | 4 | checksum: see [`cal::checksum_step`], over every word but this one |
/// | 5 | sum level of the scan, codes (0: fixed LED current) |
/// | 6 | [`cal::FWD_N`] |
/// | 7, 8 | forward grid origin x, y, micrometres |
/// | 9 | forward grid pitch, micrometres |
/// | 10 | [`cal::INV_N`] |
/// | 11..=14 | calibrated area x min, x max, y min, y max, micrometres |
/// | 15 | reserved, 0 |
/// | [`cal::FWD`].. | forward grid: `FWD_N`^2 (x_q5, y_q5) pairs, row by row (y outer) |
/// | [`cal::INV`].. | inverse grid: `INV_N`^2 (x_um, y_um) pairs over signal codes, row by row |
///
/// Inverse node (i, j) is at signal codes (-2048 + 64 i, -2048 + 64 j); its positions lie
/// within +-[`cal::MAX_NODE_UM`].
pub mod cal {
    /// "CAL1".
    pub const MAGIC: u32 = 0x4341_4C31;
    /// Format version.
    pub const VERSION: u32 = 1;
    /// Header words.
    pub const HEADER: u32 = 16;
    /// Forward grid side (36 points, 2 cm apart: the thesis's 1296-point scan).
    pub const FWD_N: u32 = 36;
    /// Inverse grid side: 64 cells of 64 codes over the converter's span.
    pub const INV_N: u32 = 65;
    /// Codes per inverse cell, as a shift of Q5 codes (64 codes = 2^11 Q5).
    pub const INV_CELL_SHIFT_Q5: u32 = 11;
    /// First word of the forward grid.
    pub const FWD: u32 = HEADER;
    /// First word of the inverse grid.
    pub const INV: u32 = FWD + 2 * FWD_N * FWD_N;
    /// Words in the table.
    pub const WORDS: u32 = INV + 2 * INV_N * INV_N;
    /// Largest inverse node coordinate (keeps the interpolation inside 32 bits).
    pub const MAX_NODE_UM: i32 = (1 << 20) - 1;
    /// Header word: magic.
    pub const W_MAGIC: u32 = 0;
    /// Header word: version.
    pub const W_VERSION: u32 = 1;
    /// Header word: generation.
    pub const W_GENERATION: u32 = 2;
    /// Header word: size in words.
    pub const W_WORDS: u32 = 3;
    /// Header word: checksum.
    pub const W_CHECKSUM: u32 = 4;
    /// Header word: sum level of the scan.
    pub const W_S_REF: u32 = 5;
    /// Header word: forward grid side.
    pub const W_FWD_N: u32 = 6;
    /// Header word: forward origin x.
    pub const W_FWD_X0: u32 = 7;
    /// Header word: forward origin y.
    pub const W_FWD_Y0: u32 = 8;
    /// Header word: forward pitch.
    pub const W_FWD_PITCH: u32 = 9;
    /// Header word: inverse grid side.
    pub const W_INV_N: u32 = 10;
    /// Header word: calibrated area, x min (then x max, y min, y max).
    pub const W_AREA: u32 = 11;

    /// One step of the table checksum: rotate left by one, then exclusive-or the word. The
    /// checksum starts at 0 and runs over words 0..[`WORDS`] in order, skipping
    /// [`W_CHECKSUM`]. (No multiply or divide: cheap on the 68020 and order-sensitive.)
    pub const fn checksum_step(c: u32, w: u32) -> u32 {
        c.rotate_left(1) ^ w
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

/// Bits of [`ReflexSubgoal::flags`] (thesis ch. V; `crates/reflex` sets them, the planner
/// and the host read them).
pub mod reflex_flags {
    /// The subgoal is the goal (both axes).
    pub const AT_GOAL: u32 = 1 << 0;
    /// Axis 1 stopped at an obstacle wall.
    pub const BLOCKED1: u32 = 1 << 1;
    /// Axis 2 stopped at an obstacle wall.
    pub const BLOCKED2: u32 = 1 << 2;
    /// Margins grown with speed reached an obstacle: braking within the arrest region.
    pub const BRAKING: u32 = 1 << 3;
    /// An obstacle covers the arm or its arrest region: heading for free space.
    pub const ESCAPING: u32 = 1 << 4;
    /// At rest short of the goal with nowhere safe to go toward it.
    pub const STALLED: u32 = 1 << 5;
    /// Covered by an obstacle with no free place within reach: holding.
    pub const TRAPPED: u32 = 1 << 6;
    /// Holding at the arrest point because an input is bad (a fault is recorded); with the
    /// planner gone quiet, that point is the goal and the reflexes stay on (the arm may
    /// escape or evade with this flag set).
    pub const HOLD: u32 = 1 << 7;
    /// The goal is the planner's.
    pub const FROM_PLANNER: u32 = 1 << 8;
    /// The goal is the wand's.
    pub const FROM_WAND: u32 = 1 << 9;
    /// The arm is at the goal and at rest.
    pub const ARRIVED: u32 = 1 << 10;
    /// Holding after power-up until the map and the positions are first good (no fault).
    pub const WAITING: u32 = 1 << 11;
    /// Among moving obstacles, the way chosen against their predicted positions
    /// (`reflex::evade`) rather than the map's escape or hold.
    pub const EVADING: u32 = 1 << 12;
}

/// Codes of the low byte of [`PlannerGoal::mode`] (thesis ch. VI; `crates/planner` sets
/// them; bits 8-15 hold the approach, 0-7).
pub mod planner_mode {
    /// No goal yet (the wand not seen): the request is the arm's arrest point.
    pub const IDLE: u32 = 0;
    /// Free mode: the request is the goal.
    pub const FREE: u32 = 1;
    /// Following an obstacle wall: the request is the next cell along it.
    pub const WALL: u32 = 2;
    /// The goal cannot be reached: holding where the arm was ([`super::PlannerGoal::reason`] says why).
    pub const UNREACHABLE: u32 = 3;
    /// No servo state this cycle: the last request again.
    pub const HOLD: u32 = 4;
}

/// Codes of [`PlannerGoal::reason`].
pub mod planner_reason {
    /// Nothing to report.
    pub const NONE: u32 = 0;
    /// Both of the goal's poses are in (or within a pixel of) an obstacle's C-space image.
    pub const GOAL_IN_OBSTACLE: u32 = 1;
    /// The goal is free but enclosed: outside the free region around the arm.
    pub const ENCLOSED: u32 = 2;
    /// Every approach went round its obstacle back to the hit point (or ran out of time).
    pub const CYCLED: u32 = 3;
    /// The wand has not been seen.
    pub const NO_GOAL: u32 = 4;
    /// The servo state read torn.
    pub const SERVO: u32 = 5;
}

record! {
    /// What the reflex's last pass did (written by the reflex board; for the host's monitor
    /// and the benches).
    pub struct ReflexStatus {
        /// Link 1 goal in use (absolute; the wand's is the pose nearest the arm).
        pub goal1_urad: i32,
        /// Link 2 goal in use.
        pub goal2_urad: i32,
        /// The window tested: bytes first theta1 pixel, theta1 pixels, first theta2 pixel,
        /// theta2 pixels (map indices, most significant byte first; 0 pixels = 256).
        pub window: u32,
        /// Pixel words read in the pass.
        pub tests: u32,
        /// Pixels the pass vouched for without reading them: rows of columns read free in
        /// an earlier pass whose generation word has not moved since
        /// (`layout::CSPACE_GENS`), and pixels of the window an earlier pass proved free
        /// while the map's epoch has not moved (`layout::CSPACE_EPOCH`).
        pub known: u32,
        /// Servo-clock time since the previous pass.
        pub dt_us: u32,
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

impl HostCommand {
    /// Which of the record's words is `serial` (boards poll that word alone).
    pub const SERIAL_WORD: u32 =
        crate::record::word_index(<Self as crate::record::Record>::FIELDS, "serial");
}

/// Number of entries in the C-space work list.
pub const WORK_ENTRIES: usize = 16;

record! {
    /// One transform job of the C-space work list (thesis line 1225: a circular list and a
    /// semaphore shared by several C-space boards). The `claim` word is taken only with
    /// [`crate::GlobalBus::cas_u32`] (from 0); while it is held, the entry, `claim`
    /// included, has exactly one writer, the board whose claim succeeded.
    pub struct WorkEntry {
        /// 0 = free, otherwise 1 + index of the claiming board in bits 0-7, a count the
        /// board advances as its job goes on in bits 8-19 (so a long job is told from an
        /// abandoned one), and the work cursor's count the job took the entry at in bits
        /// 20-31 (so two jobs on the entry are told apart).
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
