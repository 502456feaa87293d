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

/// The servo board's state between main-loop passes. `repr(C)`, the servo's state last
/// (docs/toolchain.md, "Field order is a cost").
#[repr(C)]
pub struct Board {
    shell: Shell,
    ticks: u64,
    loops: u32,
    /// The subgoal last read whole.
    last_sub: Option<Subgoal>,
    /// Passes in a row the subgoal record read torn.
    torn: u8,
    /// The servo's output of the last pass (written in place: `Servo::step_into`).
    out: Output,
    servo: Servo,
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
            servo: Servo::with_links(links),
            ticks: 0,
            loops: 0,
            last_sub: None,
            torn: 0,
            out: Output::IDLE,
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

    /// One pass of the main loop: sample, control, drive, publish. Returns the heartbeat.
    /// Generic over the bus: on the 68020 the global RAM's accesses are then inlined
    /// volatile moves, not dynamic calls.
    pub fn poll<G: GlobalBus + ?Sized>(&mut self, g: &mut G, io: &mut impl IoBus) -> u32 {
        self.shell.begin(g, io);
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
                self.last_sub = Some(Subgoal {
                    goal_urad: [r.goal1_urad, r.goal2_urad],
                    cycle: r.cycle,
                });
                self.last_sub
            }
            Err(_) => {
                self.torn = self.torn.saturating_add(1);
                if self.torn < TORN_PASSES {
                    self.last_sub
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
        // Q16 N m to mN m in 32 bits: torques are within umax (13 N m, < 2^20 in Q16), so the
        // product stays below 2^31 (an i64 product here cost a __muldi3 call per pass).
        let mnm = |q: i32| (q * 1000) >> 16;
        let state = ServoState {
            theta1_urad: q16_to_urad(out.theta_q16[0]),
            theta2_urad: q16_to_urad(out.theta_q16[1]),
            omega1_urad_s: q16_to_urad(out.omega_q16[0]),
            omega2_urad_s: q16_to_urad(out.omega_q16[1]),
            arrest1_urad: q16_to_urad(out.arrest_q16[0]),
            arrest2_urad: q16_to_urad(out.arrest_q16[1]),
            torque1_mnm: mnm(out.torque_q16[0]),
            torque2_mnm: mnm(out.torque_q16[1]),
            t_us: (self.ticks >> 1) as u32,
            loops: self.loops,
        };
        vme_map::SERVO_STATE.publish_raw(g, &state.to_words());
        if let Some(why) = out.new_fault {
            let code = match why {
                Hold::Stale | Hold::NoSubgoal => FaultCode::StaleHeartbeat,
                Hold::Torn => FaultCode::TornRecord,
                Hold::OutOfRange => FaultCode::OutOfRange,
            };
            // (Rare: through a dynamic bus, `&mut G` being one whatever G is.)
            let mut bus = &mut *g;
            self.shell
                .life()
                .degraded(&mut bus, code, vme_map::REFLEX_SUBGOAL.offset());
        }
        let st = match out.hold {
            Some(Hold::NoSubgoal) | None => BoardState::Running,
            Some(_) => BoardState::Degraded,
        };
        self.shell.end(g, st)
    }
}

/// The board's safe state: both DACs at zero, both amplifiers disabled. Also the image's
/// safe-stop hook after a fault.
pub fn safe(io: &mut impl IoBus) {
    regs::servo::ServoIo::new(io).safe();
}
