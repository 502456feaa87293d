//! The cspace board: the I/O shell that wires its private registers and global RAM to its
//! logic (thesis ch. IV (configuration-space transforms); design.md section 3). The logic's `step` arrives with issue 7;
//! until then the board boots, checks the global RAM header and publishes its heartbeat and
//! status. The same code runs in the image (`src/main.rs`, volatile MMIO) and in the
//! simulator's native mode (device models behind [`IoBus`]).
#![no_std]
#![deny(missing_docs)]

use board_shell::Shell;
use regs::IoBus;
use vme_map::{BoardId, BoardState, GlobalBus};

/// The cspace board's state between main-loop passes.
pub struct Board {
    shell: Shell,
}

impl Board {
    /// The board's identity from its board-ID switch (0..=2 selects the C-space slot).
    pub fn identify(io: &mut impl IoBus) -> Option<BoardId> {
        BoardId::cspace(io.read16(regs::BOARD_ID) as u32)
    }

    /// A fresh board with identity `id` (see [`Board::identify`]).
    pub const fn new(id: BoardId) -> Self {
        Self {
            shell: Shell::new(id),
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
