//! The part of every board's main loop that is not the board's logic (design.md section 3):
//! boot against the global RAM header, one heartbeat per pass, and the host's diagnostic
//! commands. Each board binary wraps its logic's `step` between [`Shell::begin`] and
//! [`Shell::end`].
#![no_std]
#![deny(missing_docs)]

use regs::IoBus;
use vme_map::{BoardId, BoardState, GlobalBus, HostAction, Lifecycle};

/// The shell of one board.
pub struct Shell {
    life: Lifecycle,
}

impl Shell {
    /// The shell of board `id`.
    pub const fn new(id: BoardId) -> Self {
        Self {
            life: Lifecycle::new(id),
        }
    }

    /// The board's identity.
    pub const fn id(&self) -> BoardId {
        self.life.id()
    }

    /// The lifecycle, for recording input faults.
    pub fn life(&mut self) -> &mut Lifecycle {
        &mut self.life
    }

    /// Waits until global RAM carries this layout's header (recording the mismatch once),
    /// then marks the board booting. `poll_wait` is called between attempts.
    pub fn boot(&mut self, g: &mut dyn GlobalBus, mut poll_wait: impl FnMut()) {
        while !self.life.boot(g) {
            poll_wait();
        }
    }

    /// Start of a main-loop pass: carries out a diagnostic command from the host, if any.
    pub fn begin<G: GlobalBus + ?Sized>(&mut self, g: &mut G, io: &mut impl IoBus) {
        match self.life.poll_host(g) {
            Some(HostAction::InjectBusError) => {
                // Never returns on hardware: the read takes a bus error.
                let v = io.read16(regs::UNDECODED_PROBE);
                core::hint::black_box(v);
            }
            Some(HostAction::InjectPanic) => panic!("host-injected panic"),
            None => {}
        }
    }

    /// End of a main-loop pass: heartbeat + 1 with `state`. Returns the heartbeat.
    pub fn end<G: GlobalBus + ?Sized>(&mut self, g: &mut G, state: BoardState) -> u32 {
        self.life.beat(g, state)
    }
}
