//! The planner board image: runtime entry and the main loop over volatile MMIO.
#![no_std]
#![no_main]

use board_planner::Board;
use regs::MmioIo;
use vme_map::bus::MmioGlobal;

rt::entry!(vme_map::BoardId::Planner, main, safe_stop);

fn main() -> ! {
    // SAFETY: this image runs on a board that maps global RAM and its private I/O.
    let (mut g, mut io) = unsafe { (MmioGlobal::new(), MmioIo::new()) };
    // The board's 14 KiB of state is built at compile time into .data, which the runtime
    // copies at reset, instead of on the stack here (built field by field, then moved three
    // times: 9 ms at 16.7 MHz before the first heartbeat).
    static mut BOARD: Board = Board::new();
    // SAFETY: main runs once and is the only code that touches BOARD (the safe-stop hook
    // uses only the private I/O).
    let board = unsafe { &mut *core::ptr::addr_of_mut!(BOARD) };
    board.boot(&mut g, &mut io);
    loop {
        board.poll(&mut g, &mut io);
    }
}

fn safe_stop() {
    // SAFETY: called by the runtime on this board, where the private I/O is mapped.
    board_planner::safe(&mut unsafe { MmioIo::new() });
}
