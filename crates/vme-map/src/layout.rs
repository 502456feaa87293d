//! Offsets of every region of global RAM, asserted at compile time (design.md section 4).
//!
//! Offsets are explicit numbers, as a hardware memory map is: moving a region is a
//! deliberate change of [`LAYOUT_VERSION`]. The `const` assertions below fail the build if a
//! region overlaps the next, is misaligned, or leaves global RAM. [`LAYOUT`] lists the regions
//! for `docs/memory-map.md`; a test fails if the document and this table disagree.

use crate::board::{BoardId, BoardState, FaultCode, FaultRecord, StatusWord};
use crate::bus::GlobalBus;
use crate::record::{Record, SeqLock};
use crate::records::{
    cal, HostCommand, ObjectTable, PlannerGoal, RawTable, ReflexStatus, ReflexSubgoal,
    SensingConfig, SensingDrift, ServoState, WorkEntry, WORK_ENTRIES,
};
use crate::GLOBAL_RAM_SIZE;

/// Value of the header's magic word: ASCII "NW87" (Newman 1987).
pub const MAGIC: u32 = 0x4E57_3837;
/// Version of this layout; bumped by every incompatible change.
pub const LAYOUT_VERSION: u32 = 5;

/// Header: magic word (written by the host at power-up).
pub const HEADER_MAGIC: u32 = 0x0000;
/// Header: layout version (written by the host at power-up).
pub const HEADER_VERSION: u32 = 0x0004;
/// Header: bytes of global RAM in use (written by the host at power-up).
pub const HEADER_SIZE: u32 = 0x0008;
/// Header: host power-up counter (written by the host).
pub const HEADER_BOOTS: u32 = 0x000C;
/// Bytes reserved for the header.
pub const HEADER_BYTES: u32 = 0x0100;

/// First board slot.
pub const BOARD_SLOTS: u32 = 0x0100;
/// Bytes per board slot.
pub const BOARD_SLOT_STRIDE: u32 = 0x0040;
/// Number of board slots reserved (one spare beyond [`BoardId::COUNT`]).
pub const BOARD_SLOT_COUNT: u32 = 8;

/// The global RAM slot of one board: heartbeat, status word, fault record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BoardSlot {
    base: u32,
}

impl BoardSlot {
    /// The slot of `board`.
    pub const fn of(board: BoardId) -> Self {
        Self {
            base: BOARD_SLOTS + board.index() * BOARD_SLOT_STRIDE,
        }
    }
    /// Offset of the heartbeat word: bumped once per main-loop pass.
    pub const fn heartbeat(self) -> u32 {
        self.base
    }
    /// Offset of the [`crate::StatusWord`].
    pub const fn status(self) -> u32 {
        self.base + 4
    }
    /// The fault record's sequence-locked slot.
    pub const fn fault(self) -> SeqLock<FaultRecord> {
        SeqLock::at(self.base + 8)
    }

    /// Advances the heartbeat by one and returns the new count. Only the slot's board calls it.
    pub fn beat<G: GlobalBus + ?Sized>(self, bus: &mut G) -> u32 {
        let hb = bus.read_u32(self.heartbeat()).wrapping_add(1);
        bus.write_u32(self.heartbeat(), hb);
        hb
    }

    /// Reads the status word.
    pub fn status_word<G: GlobalBus + ?Sized>(self, bus: &mut G) -> StatusWord {
        StatusWord(bus.read_u32(self.status()))
    }

    /// Sets the board's state, keeping its fault code and count.
    pub fn set_state<G: GlobalBus + ?Sized>(self, bus: &mut G, state: BoardState) {
        let w = bus.read_u32(self.status());
        bus.write_u32(self.status(), (w & !0xFF) | state as u32);
    }

    /// Records a fault: the fault record first, then the status word with `state`, the fault
    /// code and the incremented fault count, so a reader that sees the new status finds the
    /// matching details.
    pub fn record_fault(self, bus: &mut dyn GlobalBus, state: BoardState, rec: &FaultRecord) {
        self.fault().publish(bus, rec);
        let old = StatusWord(bus.read_u32(self.status()));
        let code = FaultCode::from_u8(rec.code as u8).unwrap_or(FaultCode::UnexpectedException);
        let w = StatusWord::new(state, code, old.faults().saturating_add(1));
        bus.write_u32(self.status(), w.0);
    }
}

/// Writes the header the host writes at power-up: magic, layout version, size in use.
pub fn init_header(bus: &mut dyn GlobalBus) {
    bus.write_u32(HEADER_VERSION, LAYOUT_VERSION);
    bus.write_u32(HEADER_SIZE, LAYOUT_END);
    let boots = bus.read_u32(HEADER_BOOTS);
    bus.write_u32(HEADER_BOOTS, boots.wrapping_add(1));
    bus.write_u32(HEADER_MAGIC, MAGIC);
}

/// Posts a host command for `board` (the host is the command record's only writer): the
/// next serial number, so the board acts on it once. Returns that serial.
pub fn post_host_command(bus: &mut dyn GlobalBus, command: u32, board: BoardId) -> u32 {
    let serial = HOST_COMMAND
        .read(bus)
        .map(|(c, _)| c.serial)
        .unwrap_or(0)
        .wrapping_add(1);
    let cmd = HostCommand {
        command,
        arg0: board.index(),
        arg1: 0,
        serial,
    };
    HOST_COMMAND.publish(bus, &cmd);
    serial
}

/// Whether global RAM carries this layout's header: boards refuse to run on any other.
pub fn header_ok(bus: &mut dyn GlobalBus) -> bool {
    bus.read_u32(HEADER_MAGIC) == MAGIC && bus.read_u32(HEADER_VERSION) == LAYOUT_VERSION
}

/// Object position table (writer: sensing).
pub const OBJECTS: SeqLock<ObjectTable> = SeqLock::at(0x0400);
/// Servo state and arrest points (writer: servo).
pub const SERVO_STATE: SeqLock<ServoState> = SeqLock::at(0x0580);
/// Reflex subgoal for the servo (writer: reflex).
pub const REFLEX_SUBGOAL: SeqLock<ReflexSubgoal> = SeqLock::at(0x05C0);
/// Planner goal for the reflex (writer: planner).
pub const PLANNER_GOAL: SeqLock<PlannerGoal> = SeqLock::at(0x0600);
/// Host commands (writer: host).
pub const HOST_COMMAND: SeqLock<HostCommand> = SeqLock::at(0x0640);
/// How the sensing board runs (written by the host).
pub const SENSING_CONFIG: SeqLock<SensingConfig> = SeqLock::at(0x0660);
/// The sensing board's drift estimate.
pub const SENSING_DRIFT: SeqLock<SensingDrift> = SeqLock::at(0x0678);
/// The sensing board's raw signal table (what calibration records).
pub const SENSING_RAW: SeqLock<RawTable> = SeqLock::at(0x0690);
/// What the reflex's last pass did (writer: reflex).
pub const REFLEX_STATUS: SeqLock<ReflexStatus> = SeqLock::at(0x0720);
/// Obstacle radii the host knows (the thesis's obstacles were cylinders of known size):
/// one word per C-space work-list entry, micrometres, 0 = the default 2-inch cylinder
/// (writer: host; single words, no lock).
pub const OBSTACLE_RADII: u32 = 0x0740;
/// Words of [`OBSTACLE_RADII`].
pub const OBSTACLE_RADII_WORDS: u32 = WORK_ENTRIES as u32;

/// C-space work list: the cursor (thesis line 1225's semaphore), the next entry to transform;
/// changed only with `CAS.L` by the C-space boards (`crates/cspace`, module `worklist`).
pub const WORK_CURSOR: u32 = 0x0800;
/// C-space work list: first entry (claim words: CAS by C-space boards).
pub const WORK_LIST: u32 = 0x0810;
/// Bytes per work-list entry.
pub const WORK_ENTRY_BYTES: u32 = 4 * WorkEntry::WORDS;

/// Offset of work-list entry `i`.
pub const fn work_entry(i: u32) -> u32 {
    WORK_LIST + i * WORK_ENTRY_BYTES
}

/// C-space map: 128 x 128 pixels of 4 edge-direction counter bytes (writers: C-space boards):
/// a big-endian word per pixel, bytes +theta1, -theta1, +theta2, -theta2 outward normal
/// (`crates/cspace`, module `counters`).
pub const CSPACE_MAP: u32 = 0x0001_0000;
/// Pixels per C-space axis (thesis ch. IV: ~0.05 rad per pixel).
pub const CSPACE_SIDE: u32 = 128;
/// Counter bytes per C-space pixel (one per edge direction).
pub const CSPACE_COUNTERS: u32 = 4;
/// Bytes of the C-space map.
pub const CSPACE_MAP_BYTES: u32 = CSPACE_SIDE * CSPACE_SIDE * CSPACE_COUNTERS;

/// The high bit of every counter byte of a C-space map word.
pub const COUNTER_HIGH: u32 = 0x8080_8080;

/// Whether adding `mask` to the counter word `w` (`down`: subtracting it) is one plain
/// 32-bit add or subtract, `mask` selecting counters by their bytes' low bits: every byte
/// below 128 (none saturated or near it) and, going down, every selected byte at least 1,
/// so no carry or borrow crosses a byte. Otherwise the word needs the byte-by-byte update
/// of `crates/cspace` (module `counters`).
#[inline(always)]
pub const fn counter_fast(w: u32, mask: u32, down: bool) -> bool {
    w & COUNTER_HIGH == 0
        && (!down || ((w | COUNTER_HIGH).wrapping_sub(mask)) & COUNTER_HIGH == COUNTER_HIGH)
}

/// Counter word `w` with `mask` added (`down`: subtracted) as one plain word operation: the
/// update [`counter_fast`] allows.
#[inline(always)]
pub const fn counter_plain(w: u32, mask: u32, down: bool) -> u32 {
    if down {
        w.wrapping_sub(mask)
    } else {
        w.wrapping_add(mask)
    }
}

/// Offset of the counter `dir` (0..4) of pixel (`i1`, `i2`), `i1` along theta1.
pub const fn cspace_counter(i1: u32, i2: u32, dir: u32) -> u32 {
    CSPACE_MAP + ((i2 % CSPACE_SIDE) * CSPACE_SIDE + (i1 % CSPACE_SIDE)) * CSPACE_COUNTERS + dir
}

/// C-space stripe layer: 128 counter words, one per theta1 column, in the map's word format
/// (writers: C-space boards). Link-1 images do not depend on theta2 (thesis ch. IV section 3),
/// so they are kept once per column: pixel (i1, i2) is occupied when its map word or stripe
/// word `i1` is not zero.
pub const CSPACE_STRIPES: u32 = 0x0000_0C00;
/// Bytes of the stripe layer.
pub const CSPACE_STRIPES_BYTES: u32 = CSPACE_SIDE * CSPACE_COUNTERS;

/// C-space column generations: one word per theta1 column (writers: C-space boards, each
/// raise with `CAS.L`). Every write to a column's map words or its stripe word is followed
/// by one raise of the column's word ([`raise_column_gen`]), so a reader that read the
/// word, then the column, and later finds the word unchanged knows the column unchanged
/// since (up to a write in progress, whose raise has not come yet). The reflex keeps what
/// it read of each column and reads again only the columns whose word moved.
pub const CSPACE_GENS: u32 = 0x0000_0E00;
/// Bytes of [`CSPACE_GENS`].
pub const CSPACE_GENS_BYTES: u32 = CSPACE_SIDE * 4;

/// Offset of column `i1`'s generation word.
#[inline(always)]
pub const fn cspace_gen(i1: u32) -> u32 {
    CSPACE_GENS + 4 * (i1 % CSPACE_SIDE)
}

/// The C-space map's epoch: one word (writers: C-space boards, each raise with `CAS.L`),
/// raised after every raise of a column's generation ([`raise_column_gen`]), so a reader
/// that finds it where it was at an earlier read knows that no column was written in
/// between (up to a write in progress). The reflex trusts the window it proved free in an
/// earlier pass while the epoch stays (thesis ch. V section 7: each pass tests only the
/// leading borders).
pub const CSPACE_EPOCH: u32 = CSPACE_GENS + CSPACE_GENS_BYTES;

/// Raises column `i1`'s generation word by one with `CAS.L` ([`crate::GlobalBus::raise_u32`]:
/// any number of C-space boards may write a column; a plain read and write could lose a
/// raise to another board's and bring the word back to a value a reader saw), then the
/// map's epoch ([`CSPACE_EPOCH`]). Call after the column's words are written.
#[inline(always)]
pub fn raise_column_gen<G: crate::GlobalBus + ?Sized>(g: &mut G, i1: u32) {
    g.raise_u32_then(cspace_gen(i1), CSPACE_EPOCH);
}

/// First log ring.
pub const LOG_RINGS: u32 = 0x0002_0000;
/// Bytes per board's log ring.
pub const LOG_RING_STRIDE: u32 = 0x1000;
/// Entries per log ring.
pub const LOG_ENTRIES: u32 = 64;
/// Bytes per log entry.
pub const LOG_ENTRY_BYTES: u32 = 32;
/// Offset of the first entry within a ring (after the write-index word and padding).
pub const LOG_ENTRIES_OFFSET: u32 = 16;

/// Offset of `board`'s log ring.
pub const fn log_ring(board: BoardId) -> u32 {
    LOG_RINGS + board.index() * LOG_RING_STRIDE
}

/// The sensing board's calibration table, written by the host ([`cal`] has the format).
pub const SENSING_CAL: u32 = LOG_RINGS + BOARD_SLOT_COUNT * LOG_RING_STRIDE;
/// Bytes of [`SENSING_CAL`].
pub const SENSING_CAL_BYTES: u32 = 4 * cal::WORDS;

/// End of the used part of global RAM; the rest is free for later records.
pub const LAYOUT_END: u32 = SENSING_CAL + SENSING_CAL_BYTES;

/// Who writes a region.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Writer {
    /// The host workstation.
    Host,
    /// Exactly one board.
    Board(BoardId),
    /// Each board its own part (board slots, log rings).
    EachBoard,
    /// The C-space boards, by atomic claim (work list) or owned job (map).
    CspaceBoards,
}

/// One row of the memory map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    /// Name used in `docs/memory-map.md`.
    pub name: &'static str,
    /// Byte offset from [`crate::GLOBAL_RAM_BASE`].
    pub offset: u32,
    /// Bytes.
    pub size: u32,
    /// Who writes it.
    pub writer: Writer,
    /// Whether it is published under a sequence lock.
    pub seqlock: bool,
}

const fn seq<R: Record>(name: &'static str, s: SeqLock<R>, writer: Writer) -> Region {
    Region {
        name,
        offset: s.offset(),
        size: SeqLock::<R>::SIZE,
        writer,
        seqlock: true,
    }
}

/// Every region of global RAM in address order.
pub const LAYOUT: [Region; 19] = [
    Region {
        name: "header",
        offset: HEADER_MAGIC,
        size: HEADER_BYTES,
        writer: Writer::Host,
        seqlock: false,
    },
    Region {
        name: "board_slots",
        offset: BOARD_SLOTS,
        size: BOARD_SLOT_COUNT * BOARD_SLOT_STRIDE,
        writer: Writer::EachBoard,
        seqlock: false,
    },
    seq("objects", OBJECTS, Writer::Board(BoardId::Sensing)),
    seq("servo_state", SERVO_STATE, Writer::Board(BoardId::Servo)),
    seq(
        "reflex_subgoal",
        REFLEX_SUBGOAL,
        Writer::Board(BoardId::Reflex),
    ),
    seq(
        "planner_goal",
        PLANNER_GOAL,
        Writer::Board(BoardId::Planner),
    ),
    seq("host_command", HOST_COMMAND, Writer::Host),
    seq("sensing_config", SENSING_CONFIG, Writer::Host),
    seq(
        "sensing_drift",
        SENSING_DRIFT,
        Writer::Board(BoardId::Sensing),
    ),
    seq("sensing_raw", SENSING_RAW, Writer::Board(BoardId::Sensing)),
    seq(
        "reflex_status",
        REFLEX_STATUS,
        Writer::Board(BoardId::Reflex),
    ),
    Region {
        name: "obstacle_radii",
        offset: OBSTACLE_RADII,
        size: 4 * OBSTACLE_RADII_WORDS,
        writer: Writer::Host,
        seqlock: false,
    },
    Region {
        name: "work_list",
        offset: WORK_CURSOR,
        size: WORK_LIST - WORK_CURSOR + WORK_ENTRIES as u32 * WORK_ENTRY_BYTES,
        writer: Writer::CspaceBoards,
        seqlock: false,
    },
    Region {
        name: "cspace_stripes",
        offset: CSPACE_STRIPES,
        size: CSPACE_STRIPES_BYTES,
        writer: Writer::CspaceBoards,
        seqlock: false,
    },
    Region {
        name: "cspace_gens",
        offset: CSPACE_GENS,
        size: CSPACE_GENS_BYTES,
        writer: Writer::CspaceBoards,
        seqlock: false,
    },
    Region {
        name: "cspace_epoch",
        offset: CSPACE_EPOCH,
        size: 4,
        writer: Writer::CspaceBoards,
        seqlock: false,
    },
    Region {
        name: "cspace_map",
        offset: CSPACE_MAP,
        size: CSPACE_MAP_BYTES,
        writer: Writer::CspaceBoards,
        seqlock: false,
    },
    Region {
        name: "log_rings",
        offset: LOG_RINGS,
        size: BOARD_SLOT_COUNT * LOG_RING_STRIDE,
        writer: Writer::EachBoard,
        seqlock: false,
    },
    Region {
        name: "sensing_cal",
        offset: SENSING_CAL,
        size: SENSING_CAL_BYTES,
        writer: Writer::Host,
        seqlock: false,
    },
];

// ---- compile-time checks of the map ----

const fn check_layout() {
    let mut i = 0;
    while i < LAYOUT.len() {
        let r = LAYOUT[i];
        assert!(r.offset.is_multiple_of(4), "every region is word aligned");
        assert!(
            r.offset + r.size <= GLOBAL_RAM_SIZE,
            "every region lies in global RAM"
        );
        if i + 1 < LAYOUT.len() {
            assert!(
                r.offset + r.size <= LAYOUT[i + 1].offset,
                "regions do not overlap"
            );
        }
        i += 1;
    }
}
const _: () = check_layout();
const _: () = assert!(BoardId::COUNT as u32 <= BOARD_SLOT_COUNT);
// A board slot holds heartbeat, status and the fault record.
const _: () = assert!(8 + SeqLock::<FaultRecord>::SIZE <= BOARD_SLOT_STRIDE);
// The record sizes the offsets above were chosen for.
const _: () = assert!(SeqLock::<ObjectTable>::SIZE == 136);
const _: () = assert!(SeqLock::<ServoState>::SIZE == 44);
const _: () = assert!(SeqLock::<ReflexSubgoal>::SIZE == 20);
const _: () = assert!(SeqLock::<PlannerGoal>::SIZE == 24);
const _: () = assert!(SeqLock::<HostCommand>::SIZE == 20);
const _: () = assert!(SeqLock::<SensingConfig>::SIZE == 20);
const _: () = assert!(SeqLock::<SensingDrift>::SIZE == 24);
const _: () = assert!(SeqLock::<RawTable>::SIZE == 136);
const _: () = assert!(SeqLock::<ReflexStatus>::SIZE == 28);
const _: () = assert!(WORK_ENTRY_BYTES == 32);
const _: () = assert!(CSPACE_MAP_BYTES == 0x1_0000);
const _: () = assert!(LOG_ENTRIES_OFFSET + LOG_ENTRIES * LOG_ENTRY_BYTES <= LOG_RING_STRIDE);
const _: () =
    assert!(LAYOUT_END == LAYOUT[LAYOUT.len() - 1].offset + LAYOUT[LAYOUT.len() - 1].size);
