//! The reflex board image: runtime entry and the main loop over volatile MMIO.
#![no_std]
#![no_main]

use board_reflex::Board;
use regs::MmioIo;
use vme_map::bus::MmioGlobal;

rt::entry!(vme_map::BoardId::Reflex, main, safe_stop);

fn main() -> ! {
    // SAFETY: this image runs on a board that maps global RAM and its private I/O.
    let (mut g, mut io) = unsafe { (MmioGlobal::new(), MmioIo::new()) };
    let mut board = Board::new();
    board.boot(&mut g, &mut io);
    loop {
        board.poll(&mut g, &mut io);
    }
}

fn safe_stop() {
    // SAFETY: called by the runtime on this board, where the private I/O is mapped.
    board_reflex::safe(&mut unsafe { MmioIo::new() });
}
