//! The cspace board: wires global RAM to the C-space transforms of `crates/cspace` (thesis
//! ch. IV). Each main-loop pass reads the sensing board's object table, takes the next job
//! of the shared work list (several C-space boards share the jobs, thesis line 1225), and if
//! that obstacle moved draws its new image into the map and erases the old one. The same code
//! runs in the image (`src/main.rs`, volatile MMIO) and in the simulator's native mode.
//!
//! Fail-safe: a torn object table is skipped (no image changes: the old ones stay, which is
//! the safe side); a saturated or underflowed map counter and an obstacle the database cannot
//! transform are recorded as faults (state `Degraded`), and the images in place stay.
#![no_std]
#![deny(missing_docs)]

use board_shell::Shell;
use core::borrow::BorrowMut;
use cspace::worklist::OBJECT_WORDS;
use cspace::worklist::{self, Outcome};
use regs::IoBus;
use vme_map::{BoardId, BoardState, FaultCode, GlobalBus};

/// The cspace board's state between main-loop passes; `S` holds the jobs' work memory (the
/// image's in its `.uninit` section, the simulator's boxed).
pub struct Board<S: BorrowMut<worklist::Scratch>> {
    shell: Shell,
    last: Outcome,
    fault: Option<FaultCode>,
    /// Passes in a row that found the object table torn.
    torn: u8,
    /// The object table's words as last read (one copy loop instead of a call a word; only
    /// the job's beacon is decoded).
    objects_w: [u32; OBJECT_WORDS],
    /// The jobs' working memory (the differential update's columns and log of decrements).
    scratch: S,
}

/// Passes in a row the object table may read torn before that is a fault. A skipped pass
/// costs about a hundred cycles, so this spans several hundred microseconds: far longer than
/// a publication takes (and than the emulator's 100 us time slices, during which a writer
/// caught mid-publish stands still), far shorter than a dead writer goes unnoticed.
pub const TORN_PASSES: u8 = 64;

/// The board's identity from its board-ID switch (0..=2 selects the C-space slot).
pub fn identify(io: &mut impl IoBus) -> Option<BoardId> {
    BoardId::cspace(io.read16(regs::BOARD_ID) as u32)
}

impl<S: BorrowMut<worklist::Scratch>> Board<S> {
    /// A fresh board with identity `id` (see [`identify`]) and work memory `scratch`.
    pub const fn new(id: BoardId, scratch: S) -> Self {
        Self {
            shell: Shell::new(id),
            last: Outcome {
                entry: 0,
                busy: false,
                redrawn: false,
                clamped: false,
                flags: cspace::Flags {
                    saturated: false,
                    underflow: false,
                },
                error: None,
            },
            fault: None,
            torn: 0,
            objects_w: [0; OBJECT_WORDS],
            scratch,
        }
    }

    /// The board's identity.
    pub const fn id(&self) -> BoardId {
        self.shell.id()
    }

    /// What the last pass did.
    pub fn last(&self) -> Outcome {
        self.last
    }

    /// Puts the outputs in their safe state and waits for the global RAM header.
    pub fn boot(&mut self, g: &mut dyn GlobalBus, io: &mut impl IoBus) {
        safe(io);
        self.shell.boot(g, || {});
    }

    /// One pass of the main loop: one work-list job. Returns the new heartbeat. Generic over
    /// the bus so the image's map accesses are inlined volatile words.
    pub fn poll<G: GlobalBus>(&mut self, g: &mut G, io: &mut impl IoBus) -> u32 {
        self.shell.begin(g, io);
        let me = 1 + (self.id().index() - BoardId::Cspace0.index());
        let (fault, at) = match vme_map::OBJECTS.read_raw(g, &mut self.objects_w) {
            Ok(_) => {
                let out = worklist::step_words(g, me, &self.objects_w, self.scratch.borrow_mut());
                self.last = out;
                let at = vme_map::layout::work_entry(out.entry);
                if out.flags.saturated || out.flags.underflow {
                    (Some(FaultCode::MapCounter), at)
                } else if out.error.is_some() {
                    (Some(FaultCode::Untransformable), at)
                } else if out.clamped {
                    (Some(FaultCode::OutOfRange), at)
                } else {
                    (None, at)
                }
            }
            // The sensing board republishes the table every 250 us: a read that meets it
            // mid-write on every retry is skipped; only a table torn for TORN_PASSES
            // passes in a row (a writer that died mid-write) is a fault.
            Err(_) => {
                self.torn = self.torn.saturating_add(1);
                if self.torn < TORN_PASSES {
                    let state = if self.fault.is_some() {
                        BoardState::Degraded
                    } else {
                        BoardState::Running
                    };
                    return self.shell.end(g, state);
                }
                (Some(FaultCode::TornRecord), vme_map::OBJECTS.offset())
            }
        };
        if fault != Some(FaultCode::TornRecord) {
            self.torn = 0;
        }
        // A fault is recorded when it starts (or changes), not on every pass it lasts.
        if fault.is_some() && fault != self.fault {
            if let Some(code) = fault {
                self.shell.life().degraded(g, code, at);
            }
        }
        self.fault = fault;
        let state = if fault.is_some() {
            BoardState::Degraded
        } else {
            BoardState::Running
        };
        self.shell.end(g, state)
    }
}

/// The board's safe state: no outputs but global RAM. Also the image's safe-stop hook after a fault.
pub fn safe(io: &mut impl IoBus) {
    let _ = io;
}
