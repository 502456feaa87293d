//! The planner board: the I/O shell that wires its private registers and global RAM to its
//! logic (thesis ch. VI (local planning); design.md section 3). The logic's `step` arrives with issue 9;
//! until then the board boots, checks the global RAM header and publishes its heartbeat and
//! status. The same code runs in the image (`src/main.rs`, volatile MMIO) and in the
//! simulator's native mode (device models behind [`IoBus`]).
#![no_std]
#![deny(missing_docs)]

use board_shell::Shell;
use regs::IoBus;
use vme_map::{BoardId, BoardState, GlobalBus};

/// The planner board's state between main-loop passes.
pub struct Board {
    shell: Shell,
}

impl Default for Board {
    fn default() -> Self {
        Self::new()
    }
}

impl Board {
    /// A fresh board.
    pub const fn new() -> Self {
        Self {
            shell: Shell::new(BoardId::Planner),
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

    /// One pass of the main loop. Returns the new heartbeat.
    pub fn poll(&mut self, g: &mut dyn GlobalBus, io: &mut impl IoBus) -> u32 {
        self.shell.begin(g, io);
        self.shell.end(g, BoardState::Running)
    }
}

/// The board's safe state: no outputs but global RAM. Also the image's safe-stop hook after a fault.
pub fn safe(io: &mut impl IoBus) {
    let _ = io;
}
