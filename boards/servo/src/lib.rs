//! The servo board: wires the encoders, the 2 MHz timer, the DACs and the amplifier enables
//! to the observers and law III.36 of `crates/servo` (thesis ch. III), and publishes the
//! servo state (angles, velocities, arrest points, torques) for the reflex and planner. The
//! same code runs in the image (`src/main.rs`, volatile MMIO) and in the simulator's native
//! mode (device models behind [`IoBus`]).
//!
//! Fail-safe: the goal is the reflex subgoal only while that record is whole, fresh and
//! plausible; otherwise the servo holds at its arrest point, records the fault in its status
//! slot (state `Degraded`) and never commands beyond umax (`crates/servo`).
#![no_std]
#![deny(missing_docs)]

use board_shell::Shell;
use regs::servo::{AmpCtrl, ServoIo};
use regs::IoBus;
use servo::{q16_to_urad, Hold, Input, Output, Servo, Subgoal};
use vme_map::record::Record;
use vme_map::records::{ReflexSubgoal, ServoState};
use vme_map::{BoardId, BoardState, FaultCode, GlobalBus};

/// The servo board's state between main-loop passes.
pub struct Board {
    shell: Shell,
    pass: PassState,
}

/// What a main-loop pass reads and updates besides the shell. `repr(C)`, the servo's state
/// last (docs/toolchain.md, "Field order is a cost"): the image's `__servo_board_pass`
/// (`crates/rt/asm/servo.S`) works on it at the offsets [`layout`] asserts.
#[repr(C)]
struct PassState {
    /// 2 MHz timer ticks since start-up (the published time).
    ticks: u64,
    /// Passes since start-up.
    loops: u32,
    /// The subgoal last read whole (meaningful once `has_sub`).
    last_sub: Subgoal,
    /// Whether a subgoal was ever read whole.
    has_sub: bool,
    /// Passes in a row the subgoal record read torn.
    torn: u8,
    /// The servo's output of the last pass (written in place: `Servo::step_into`).
    out: Output,
    /// The state of the last pass that computed the arrest points, published on the next:
    /// angles, speeds, arrest points and torques (Q16, as in `Output`), its time (us) and
    /// pass count. One pass computes the arrest points, the next publishes them with the
    /// angles they were computed from (a record whose arrest points lagged its angles by a
    /// pass kept an arm braked at a wall flipping between two counts; fig. V.9).
    snap: [i32; 8],
    snap_t_us: u32,
    snap_loops: u32,
    servo: Servo,
}

/// The addresses the image's board pass (`__servo_board_pass`) reads and writes: the
/// private I/O registers it uses and the two global RAM records (each the address of the
/// record's sequence word). The image's are [`Ports::MMIO`]; the test probe points them at
/// ordinary RAM.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct Ports {
    /// `regs::servo::ENC_CTRL`.
    pub latch: u32,
    /// `regs::servo::ENC0`.
    pub enc0: u32,
    /// `regs::servo::ENC1`.
    pub enc1: u32,
    /// `regs::servo::TIMER`.
    pub timer: u32,
    /// `regs::servo::DAC0`.
    pub dac0: u32,
    /// `regs::servo::DAC1`.
    pub dac1: u32,
    /// `regs::servo::AMP_CTRL`.
    pub amp: u32,
    /// `vme_map::REFLEX_SUBGOAL`, read.
    pub subgoal: u32,
    /// `vme_map::SERVO_STATE`, published.
    pub state: u32,
}

impl Ports {
    /// The ports with the private I/O at `io` and global RAM at `global` (base addresses).
    pub const fn at(io: u32, global: u32) -> Self {
        use regs::servo::{AMP_CTRL, DAC0, DAC1, ENC0, ENC1, ENC_CTRL, TIMER};
        Self {
            latch: io + ENC_CTRL,
            enc0: io + ENC0,
            enc1: io + ENC1,
            timer: io + TIMER,
            dac0: io + DAC0,
            dac1: io + DAC1,
            amp: io + AMP_CTRL,
            subgoal: global + vme_map::REFLEX_SUBGOAL.offset(),
            state: global + vme_map::SERVO_STATE.offset(),
        }
    }

    /// The board's own: its private I/O and the VME window as the 68020 sees them.
    pub const MMIO: Self = Self::at(regs::PRIVATE_IO_BASE, vme_map::GLOBAL_RAM_BASE);
}

/// Passes in a row the subgoal record may read torn (the reflex caught mid-publish) before
/// that is a fault; meanwhile the last whole subgoal stands, its age still counting toward
/// the servo's staleness limit. At 750-3,000 passes a second this is 3-11 ms: far longer
/// than a publication takes (and than the emulator's 100 us time slices, during which a
/// writer caught mid-publish stands still), far shorter than the 20 ms staleness limit.
pub const TORN_PASSES: u8 = 8;

impl Default for Board {
    fn default() -> Self {
        Self::new()
    }
}

impl Board {
    /// A fresh board running the law designed for 3 kHz (the native simulation's rate).
    pub const fn new() -> Self {
        Self::with_links(&servo::params::TUNED)
    }

    /// A fresh board running the law with constants `links`, which must be designed for the
    /// rate the board's loop runs at (the image: [`servo::params::TUNED_AT_IMAGE_HZ`]).
    pub const fn with_links(links: &'static [servo::params::LinkConst; 2]) -> Self {
        Self {
            shell: Shell::new(BoardId::Servo),
            pass: PassState {
                ticks: 0,
                loops: 0,
                last_sub: Subgoal {
                    goal_urad: [0; 2],
                    cycle: 0,
                },
                has_sub: false,
                torn: 0,
                out: Output::IDLE,
                snap: [0; 8],
                snap_t_us: 0,
                snap_loops: 0,
                servo: Servo::with_links(links),
            },
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

    /// One pass of the main loop: sample, control, drive, and publish the state (every other
    /// pass: the one before's, `PassState::snap`). Returns the heartbeat.
    /// Generic over the bus: on the 68020 the global RAM's accesses are then inlined
    /// volatile moves, not dynamic calls.
    pub fn poll<G: GlobalBus + ?Sized>(&mut self, g: &mut G, io: &mut impl IoBus) -> u32 {
        self.shell.begin(g, io);
        let st = self.pass.run(g, io);
        self.end(g, st)
    }

    /// The end of a pass: a new fault into the status slot, then the heartbeat.
    fn end<G: GlobalBus + ?Sized>(
        &mut self,
        g: &mut G,
        (st, fault): (BoardState, Option<FaultCode>),
    ) -> u32 {
        if let Some(code) = fault {
            // (Rare: through a dynamic bus, `&mut G` being one whatever G is.)
            let mut bus = &mut *g;
            self.shell
                .life()
                .degraded(&mut bus, code, vme_map::REFLEX_SUBGOAL.offset());
        }
        self.shell.end(g, st)
    }

    /// [`Board::poll`] as the image runs it: the common pass (a subgoal read whole within
    /// the record's four tries, the servo's common pass or a hold already under way: `Servo::step_into`)
    /// in one call of `__servo_board_pass`, which does what the Rust does, bit for bit
    /// (`the_servo_board_image_passes_like_the_host`), through the addresses `ports`; any
    /// other pass in the Rust. The routine decides before it changes anything but the
    /// encoder latch and the last subgoal read whole (which the Rust then reads again).
    #[cfg(target_arch = "m68k")]
    pub fn poll_ports<G: GlobalBus + ?Sized>(
        &mut self,
        g: &mut G,
        io: &mut impl IoBus,
        ports: &Ports,
    ) -> u32 {
        extern "C" {
            fn __servo_board_pass(p: *mut u8, ports: *const Ports) -> u32;
        }
        self.shell.begin(g, io);
        // SAFETY: the routine reads and writes the pass state at the offsets `layout`
        // asserts and the registers and records `ports` names (the caller's to map).
        let common =
            unsafe { __servo_board_pass((&mut self.pass as *mut PassState).cast(), ports) };
        let st = if common != 0 {
            self.pass.verdict()
        } else {
            self.pass.run(g, io)
        };
        self.end(g, st)
    }
}

impl PassState {
    /// One pass of the main loop between the shell's begin and end: sample, control,
    /// drive, publish. Returns the board's state for the heartbeat and a new fault.
    fn run<G: GlobalBus + ?Sized>(
        &mut self,
        g: &mut G,
        io: &mut impl IoBus,
    ) -> (BoardState, Option<FaultCode>) {
        let mut hw = ServoIo::new(&mut *io);
        let enc = hw.latch_encoders();
        let timer = hw.timer();
        let mut w = [0u32; <ReflexSubgoal as Record>::WORDS as usize];
        let subgoal = match vme_map::REFLEX_SUBGOAL.read_raw(g, &mut w) {
            // Sequence 0: the reflex has never published.
            Ok(0) => None,
            Ok(_) => {
                let r = ReflexSubgoal::from_words(&w);
                self.torn = 0;
                self.last_sub = Subgoal {
                    goal_urad: [r.goal1_urad, r.goal2_urad],
                    cycle: r.cycle,
                };
                self.has_sub = true;
                Some(self.last_sub)
            }
            Err(_) => {
                self.torn = self.torn.saturating_add(1);
                if self.torn < TORN_PASSES && self.has_sub {
                    Some(self.last_sub)
                } else {
                    None
                }
            }
        };
        self.servo.step_into(
            &Input {
                enc,
                timer,
                subgoal,
            },
            &mut self.out,
        );
        let out = &self.out;
        hw.set_dac(0, out.dac[0]);
        hw.set_dac(1, out.dac[1]);
        if out.enable {
            hw.set_amps(AmpCtrl::ENABLE0 | AmpCtrl::ENABLE1);
        }
        self.ticks += out.period_ticks as u64;
        self.loops = self.loops.wrapping_add(1);
        // The state every other pass: a pass that computed the arrest points keeps its
        // state, the next publishes it (no pass does both; docs/servo.md).
        if out.arrest_new {
            let [t, w, a, u] = [out.theta_q16, out.omega_q16, out.arrest_q16, out.torque_q16];
            self.snap = [t[0], t[1], w[0], w[1], a[0], a[1], u[0], u[1]];
            self.snap_t_us = (self.ticks >> 1) as u32;
            self.snap_loops = self.loops;
            return self.verdict();
        }
        let v = &self.snap;
        // Q16 N m to mN m in 32 bits: torques are within umax (13 N m, < 2^20 in Q16), so the
        // product stays below 2^31 (an i64 product here cost a __muldi3 call per pass).
        let mnm = |q: i32| (q * 1000) >> 16;
        let state = ServoState {
            theta1_urad: q16_to_urad(v[0]),
            theta2_urad: q16_to_urad(v[1]),
            omega1_urad_s: q16_to_urad(v[2]),
            omega2_urad_s: q16_to_urad(v[3]),
            arrest1_urad: q16_to_urad(v[4]),
            arrest2_urad: q16_to_urad(v[5]),
            torque1_mnm: mnm(v[6]),
            torque2_mnm: mnm(v[7]),
            t_us: self.snap_t_us,
            loops: self.snap_loops,
        };
        vme_map::SERVO_STATE.publish_raw(g, &state.to_words());
        self.verdict()
    }

    /// The pass's board state (degraded while holding for a fault) and new fault, from the
    /// servo's output.
    fn verdict(&self) -> (BoardState, Option<FaultCode>) {
        let out = &self.out;
        let fault = out.new_fault.map(|why| match why {
            Hold::Stale | Hold::NoSubgoal => FaultCode::StaleHeartbeat,
            Hold::Torn => FaultCode::TornRecord,
            Hold::OutOfRange => FaultCode::OutOfRange,
        });
        let st = match out.hold {
            Some(Hold::NoSubgoal) | None => BoardState::Running,
            Some(_) => BoardState::Degraded,
        };
        (st, fault)
    }
}

/// The board's safe state: both DACs at zero, both amplifiers disabled. Also the image's
/// safe-stop hook after a fault.
pub fn safe(io: &mut impl IoBus) {
    regs::servo::ServoIo::new(io).safe();
}

/// The layout `__servo_board_pass` (`crates/rt/asm/servo.S`) assumes, asserted on the
/// image's target: its `.equ`s name these numbers.
#[cfg(target_arch = "m68k")]
mod layout {
    use super::{PassState, Ports};
    use core::mem::offset_of;
    use regs::servo::{AmpCtrl, EncCtrl};
    const _: () = assert!(offset_of!(PassState, ticks) == 0);
    const _: () = assert!(offset_of!(PassState, loops) == 8);
    const _: () = assert!(offset_of!(PassState, last_sub) == 12);
    const _: () = assert!(offset_of!(PassState, has_sub) == 24);
    const _: () = assert!(offset_of!(PassState, torn) == 25);
    const _: () = assert!(offset_of!(PassState, out) == 26);
    const _: () = assert!(offset_of!(PassState, snap) == 80);
    const _: () = assert!(offset_of!(PassState, snap_t_us) == 112);
    const _: () = assert!(offset_of!(PassState, snap_loops) == 116);
    const _: () = assert!(offset_of!(PassState, servo) == 120);
    const _: () = assert!(offset_of!(Ports, latch) == 0);
    const _: () = assert!(offset_of!(Ports, enc0) == 4);
    const _: () = assert!(offset_of!(Ports, enc1) == 8);
    const _: () = assert!(offset_of!(Ports, timer) == 12);
    const _: () = assert!(offset_of!(Ports, dac0) == 16);
    const _: () = assert!(offset_of!(Ports, dac1) == 20);
    const _: () = assert!(offset_of!(Ports, amp) == 24);
    const _: () = assert!(offset_of!(Ports, subgoal) == 28);
    const _: () = assert!(offset_of!(Ports, state) == 32);
    // The values it writes: the latch command, both amplifiers enabled; and the records'
    // sizes (4 subgoal words: goals, flags, cycle; 10 state words).
    const _: () = assert!(EncCtrl::LATCH.bits() == 1);
    const _: () = assert!(AmpCtrl::ENABLE0.bits() | AmpCtrl::ENABLE1.bits() == 3);
    const _: () = assert!(<vme_map::records::ReflexSubgoal as vme_map::record::Record>::WORDS == 4);
    const _: () = assert!(<vme_map::records::ServoState as vme_map::record::Record>::WORDS == 10);
    // The subgoal record's tries (`SUB_TRIES`), as `SeqLock::read_raw` makes them.
    const _: () =
        assert!(vme_map::record::SeqLock::<vme_map::records::ReflexSubgoal>::RETRIES == 4);
}
