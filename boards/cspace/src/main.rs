//! The cspace board image: runtime entry and the main loop over volatile MMIO.
#![no_std]
#![no_main]

use board_cspace::Board;
use regs::MmioIo;
use vme_map::bus::MmioGlobal;

rt::entry!(vme_map::BoardId::Cspace0, main, safe_stop);

fn main() -> ! {
    // SAFETY: this image runs on a board that maps global RAM and its private I/O.
    let (mut g, mut io) = unsafe { (MmioGlobal::new(), MmioIo::new()) };
    let Some(id) = Board::identify(&mut io) else {
        panic!("board-ID switch out of range (C-space boards are 0..=2)");
    };
    rt::set_board(id);
    let mut board = Board::new(id);
    board.boot(&mut g, &mut io);
    loop {
        board.poll(&mut g, &mut io);
    }
}

fn safe_stop() {
    // SAFETY: called by the runtime on this board, where the private I/O is mapped.
    board_cspace::safe(&mut unsafe { MmioIo::new() });
}
