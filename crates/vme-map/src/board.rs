//! Board identities, heartbeats, status words and fault records (design.md section 4).
//!
//! Every board owns one [`crate::layout::BoardSlot`]: a heartbeat counter it bumps once per
//! main-loop pass, a [`StatusWord`] (state and last fault code) and a [`FaultRecord`] with the
//! details of the last fault. Consumers judge a producer by the age of its heartbeat and by
//! its state, and fall back to their safe behaviour (thesis ch. VI, layering guidelines).

use crate::record;

/// The boards of the system. The numeric value is the index of the board's slot and log
/// ring. Up to three C-space boards share the transforms (thesis line 1225).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum BoardId {
    /// Optical sensing: LED strobes, A/D, positions (thesis ch. II.3).
    Sensing = 0,
    /// Sliding-mode servo of both links (thesis ch. III).
    Servo = 1,
    /// Reflexes: arrest-region lookahead and subgoals (thesis ch. V).
    Reflex = 2,
    /// Local planner (thesis ch. VI).
    Planner = 3,
    /// First C-space transform board (thesis ch. IV).
    Cspace0 = 4,
    /// Second C-space transform board.
    Cspace1 = 5,
    /// Third C-space transform board.
    Cspace2 = 6,
}

impl BoardId {
    /// Number of board slots in global RAM.
    pub const COUNT: usize = 7;
    /// All boards in slot order.
    pub const ALL: [BoardId; Self::COUNT] = [
        BoardId::Sensing,
        BoardId::Servo,
        BoardId::Reflex,
        BoardId::Planner,
        BoardId::Cspace0,
        BoardId::Cspace1,
        BoardId::Cspace2,
    ];

    /// The board for a slot index, if there is one.
    pub const fn from_index(i: u32) -> Option<Self> {
        if (i as usize) < Self::COUNT {
            Some(Self::ALL[i as usize])
        } else {
            None
        }
    }

    /// The slot index.
    pub const fn index(self) -> u32 {
        self as u32
    }

    /// The C-space board with instance number `n` (0..=2), as set by the board-ID switch.
    pub const fn cspace(n: u32) -> Option<Self> {
        match n {
            0 => Some(BoardId::Cspace0),
            1 => Some(BoardId::Cspace1),
            2 => Some(BoardId::Cspace2),
            _ => None,
        }
    }

    /// A short lower-case name, as used on the command line and in reports.
    pub const fn name(self) -> &'static str {
        match self {
            BoardId::Sensing => "sensing",
            BoardId::Servo => "servo",
            BoardId::Reflex => "reflex",
            BoardId::Planner => "planner",
            BoardId::Cspace0 => "cspace0",
            BoardId::Cspace1 => "cspace1",
            BoardId::Cspace2 => "cspace2",
        }
    }
}

/// What a board is doing, the low byte of its [`StatusWord`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum BoardState {
    /// Slot never written (global RAM is cleared at power-up).
    Off = 0,
    /// Reset done, initialising.
    Booting = 1,
    /// Main loop running.
    Running = 2,
    /// The board detected implausible inputs and is in its safe behaviour, still looping.
    Degraded = 3,
    /// A CPU exception or panic stopped the board after it put its outputs in the safe state.
    SafeStop = 4,
}

impl BoardState {
    /// The state for its code; unknown codes are `None` (a corrupt slot).
    pub const fn from_u8(v: u8) -> Option<Self> {
        match v {
            0 => Some(Self::Off),
            1 => Some(Self::Booting),
            2 => Some(Self::Running),
            3 => Some(Self::Degraded),
            4 => Some(Self::SafeStop),
            _ => None,
        }
    }
}

/// Why a board left normal running, the second byte of its [`StatusWord`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum FaultCode {
    /// No fault recorded.
    None = 0,
    /// CPU bus error (vector 2): an access to an unmapped or faulting address.
    BusError = 1,
    /// CPU address error (vector 3): a misaligned instruction fetch.
    AddressError = 2,
    /// Illegal instruction (vectors 4, 10, 11).
    IllegalInstruction = 3,
    /// Integer divide by zero (vector 5).
    ZeroDivide = 4,
    /// Any other exception or interrupt that has no handler.
    UnexpectedException = 5,
    /// A Rust panic; the message is in the board's log ring.
    Panic = 6,
    /// A record this board reads was torn beyond retry.
    TornRecord = 7,
    /// A producer's heartbeat stopped advancing.
    StaleHeartbeat = 8,
    /// An input was outside its physical range.
    OutOfRange = 9,
    /// An A/D converter input saturated.
    AdcSaturated = 10,
    /// The global RAM header did not carry the expected magic and layout version.
    LayoutMismatch = 11,
    /// A C-space map counter saturated (it stays set) or an erase found one at zero.
    MapCounter = 12,
    /// An obstacle could not be transformed into C-space (larger than the image database
    /// holds): its old image stays.
    Untransformable = 13,
    /// The sensing calibration table is missing, corrupt or implausible: positions are
    /// published without the valid flag until a good one is written.
    BadCalibration = 14,
}

impl FaultCode {
    /// The fault for its code; unknown codes are `None`.
    pub const fn from_u8(v: u8) -> Option<Self> {
        use FaultCode::*;
        Some(match v {
            0 => None,
            1 => BusError,
            2 => AddressError,
            3 => IllegalInstruction,
            4 => ZeroDivide,
            5 => UnexpectedException,
            6 => Panic,
            7 => TornRecord,
            8 => StaleHeartbeat,
            9 => OutOfRange,
            10 => AdcSaturated,
            11 => LayoutMismatch,
            12 => MapCounter,
            13 => Untransformable,
            14 => BadCalibration,
            _ => return Option::None,
        })
    }

    /// The fault a CPU exception vector number maps to.
    pub const fn from_vector(vector: u32) -> Self {
        match vector {
            2 => FaultCode::BusError,
            3 => FaultCode::AddressError,
            4 | 10 | 11 => FaultCode::IllegalInstruction,
            5 => FaultCode::ZeroDivide,
            _ => FaultCode::UnexpectedException,
        }
    }
}

/// A board's status: a single aligned word, so it needs no lock.
///
/// Bits 0-7: [`BoardState`]; bits 8-15: last [`FaultCode`]; bits 16-31: number of faults
/// recorded since boot (saturating).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StatusWord(pub u32);

impl StatusWord {
    /// Packs a status word.
    pub const fn new(state: BoardState, fault: FaultCode, faults: u16) -> Self {
        Self(state as u32 | (fault as u32) << 8 | (faults as u32) << 16)
    }
    /// The state; `None` if the word is corrupt.
    pub const fn state(self) -> Option<BoardState> {
        BoardState::from_u8(self.0 as u8)
    }
    /// The last fault; `None` if the word is corrupt.
    pub const fn fault(self) -> Option<FaultCode> {
        FaultCode::from_u8((self.0 >> 8) as u8)
    }
    /// Number of faults recorded since boot.
    pub const fn faults(self) -> u16 {
        (self.0 >> 16) as u16
    }
}

record! {
    /// Details of the last fault a board recorded, published under a sequence lock.
    pub struct FaultRecord {
        /// The [`FaultCode`] as a number.
        pub code: u32,
        /// CPU exception vector number, 0 when the fault was not an exception.
        pub vector: u32,
        /// Program counter stacked by the exception (or the panic site's caller, 0 if unknown).
        pub pc: u32,
        /// Status register stacked by the exception.
        pub sr: u32,
        /// Faulting data address (bus error frames; 0 otherwise).
        pub fault_addr: u32,
        /// Heartbeat count when the fault happened.
        pub heartbeat: u32,
        /// Board-specific detail (e.g. which record was torn).
        pub detail: u32,
    }
}

/// What the host asked a board to do, decoded by [`Lifecycle::poll_host`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HostAction {
    /// Take a bus error by reading an undecoded private-I/O address (fault-injection test).
    InjectBusError,
    /// Panic (fault-injection test).
    InjectPanic,
}

/// The boot and heartbeat protocol every board follows, independent of its logic.
///
/// 1. [`Lifecycle::boot`]: state `Booting`; the global RAM header must carry this layout's
///    magic and version, or the board records [`FaultCode::LayoutMismatch`] and waits.
/// 2. [`Lifecycle::beat`] once per main-loop pass: heartbeat + 1, state `Running`.
pub struct Lifecycle {
    id: BoardId,
    slot: crate::layout::BoardSlot,
    last_serial: u32,
    mismatch_recorded: bool,
}

impl Lifecycle {
    /// The lifecycle of board `id`.
    pub const fn new(id: BoardId) -> Self {
        Self {
            id,
            slot: crate::layout::BoardSlot::of(id),
            last_serial: 0,
            mismatch_recorded: false,
        }
    }

    /// The board this lifecycle belongs to.
    pub const fn id(&self) -> BoardId {
        self.id
    }

    /// Marks the board booting and checks the header. Returns whether the board may run;
    /// call again until it does.
    pub fn boot(&mut self, bus: &mut dyn crate::GlobalBus) -> bool {
        if crate::layout::header_ok(bus) {
            self.slot.set_state(bus, BoardState::Booting);
            self.last_serial = crate::layout::HOST_COMMAND
                .read(bus)
                .map(|(c, _)| c.serial)
                .unwrap_or(0);
            return true;
        }
        if !self.mismatch_recorded {
            self.mismatch_recorded = true;
            let rec = FaultRecord {
                code: FaultCode::LayoutMismatch as u32,
                detail: bus.read_u32(crate::layout::HEADER_MAGIC),
                ..Default::default()
            };
            self.slot.record_fault(bus, BoardState::Degraded, &rec);
        }
        false
    }

    /// Ends one main-loop pass: heartbeat + 1 and state `state` (normally `Running`).
    /// Returns the new heartbeat.
    pub fn beat<G: crate::GlobalBus + ?Sized>(&mut self, bus: &mut G, state: BoardState) -> u32 {
        let hb = self.slot.beat(bus);
        let st = self.slot.status_word(bus);
        if st.state() != Some(state) {
            self.slot.set_state(bus, state);
        }
        hb
    }

    /// Records a fault found in the board's inputs (torn record, stale heartbeat, ...)
    /// and marks the board `Degraded`; the board keeps looping in its safe behaviour.
    pub fn degraded(&mut self, bus: &mut dyn crate::GlobalBus, code: FaultCode, detail: u32) {
        let hb = bus.read_u32(self.slot.heartbeat());
        let rec = FaultRecord {
            code: code as u32,
            heartbeat: hb,
            detail,
            ..Default::default()
        };
        self.slot.record_fault(bus, BoardState::Degraded, &rec);
    }

    /// Checks the host command record for a new command addressed to this board.
    ///
    /// Every pass reads only the command's serial word, outside the lock; a new serial (or
    /// one caught mid-write) is then read whole under the lock, and a torn read leaves
    /// the serial unconsumed, so the next pass tries again.
    pub fn poll_host<G: crate::GlobalBus + ?Sized>(&mut self, bus: &mut G) -> Option<HostAction> {
        use crate::records::{host_cmd, HostCommand};
        let cmd = crate::layout::HOST_COMMAND;
        if bus.read_u32(cmd.word_offset(HostCommand::SERIAL_WORD)) == self.last_serial {
            return None;
        }
        let mut w = [0u32; <HostCommand as crate::record::Record>::WORDS as usize];
        cmd.read_raw(bus, &mut w).ok()?;
        let cmd = HostCommand::from_words(&w);
        if cmd.serial == self.last_serial {
            return None;
        }
        self.last_serial = cmd.serial;
        if cmd.arg0 != self.id.index() {
            return None;
        }
        match cmd.command {
            host_cmd::INJECT_BUS_ERROR => Some(HostAction::InjectBusError),
            host_cmd::INJECT_PANIC => Some(HostAction::InjectPanic),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::{ArrayBus, GlobalBus};
    use crate::layout::{init_header, post_host_command, BoardSlot, HOST_COMMAND};
    use crate::records::host_cmd;

    #[test]
    fn boot_waits_for_the_header_and_records_the_mismatch_once() {
        let mut mem = [0u8; 0x1000];
        let mut bus = ArrayBus::new(&mut mem);
        let mut l = Lifecycle::new(BoardId::Planner);
        assert!(!l.boot(&mut bus));
        assert!(!l.boot(&mut bus));
        let st = BoardSlot::of(BoardId::Planner).status_word(&mut bus);
        assert_eq!(st.state(), Some(BoardState::Degraded));
        assert_eq!(st.fault(), Some(FaultCode::LayoutMismatch));
        assert_eq!(st.faults(), 1);
        init_header(&mut bus);
        assert!(l.boot(&mut bus));
        assert_eq!(l.beat(&mut bus, BoardState::Running), 1);
        assert_eq!(l.beat(&mut bus, BoardState::Running), 2);
        let st = BoardSlot::of(BoardId::Planner).status_word(&mut bus);
        assert_eq!(st.state(), Some(BoardState::Running));
    }

    #[test]
    fn host_commands_reach_only_their_board_once() {
        let mut mem = [0u8; 0x1000];
        let mut bus = ArrayBus::new(&mut mem);
        init_header(&mut bus);
        let mut servo = Lifecycle::new(BoardId::Servo);
        let mut reflex = Lifecycle::new(BoardId::Reflex);
        assert!(servo.boot(&mut bus) && reflex.boot(&mut bus));
        post_host_command(&mut bus, host_cmd::INJECT_PANIC, BoardId::Servo);
        assert_eq!(reflex.poll_host(&mut bus), None);
        assert_eq!(servo.poll_host(&mut bus), Some(HostAction::InjectPanic));
        assert_eq!(servo.poll_host(&mut bus), None);
    }

    /// A command caught mid-publish (its serial already new, the sequence odd) is not
    /// consumed: the board acts on it once the record is whole.
    #[test]
    fn a_host_command_caught_mid_write_is_taken_when_whole() {
        let mut mem = [0u8; 0x1000];
        let mut bus = ArrayBus::new(&mut mem);
        init_header(&mut bus);
        let mut servo = Lifecycle::new(BoardId::Servo);
        assert!(servo.boot(&mut bus));
        post_host_command(&mut bus, host_cmd::INJECT_BUS_ERROR, BoardId::Servo);
        let seq = bus.read_u32(HOST_COMMAND.offset());
        bus.write_u32(HOST_COMMAND.offset(), seq | 1);
        assert_eq!(servo.poll_host(&mut bus), None);
        assert_eq!(servo.poll_host(&mut bus), None);
        bus.write_u32(HOST_COMMAND.offset(), seq);
        assert_eq!(servo.poll_host(&mut bus), Some(HostAction::InjectBusError));
        assert_eq!(servo.poll_host(&mut bus), None);
    }
}
