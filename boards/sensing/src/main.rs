//! The sensing board image: runtime entry and the main loop over volatile MMIO.
#![no_std]
#![no_main]

use board_sensing::Board;
use regs::MmioIo;
use vme_map::bus::MmioGlobal;

rt::entry!(vme_map::BoardId::Sensing, main, safe_stop);

fn main() -> ! {
    // SAFETY: this image runs on a board that maps global RAM and its private I/O.
    let (mut g, mut io) = unsafe { (MmioGlobal::new(), MmioIo::new()) };
    // The board's state (9 KiB of filter rings) lives in a static initialised by the loader:
    // built on the stack it cost 160,000 cycles of byte copies before the first slot.
    static mut BOARD: Board = Board::new();
    // SAFETY: `main` runs once and is the only code that touches BOARD.
    let board = unsafe { &mut *core::ptr::addr_of_mut!(BOARD) };
    board.boot(&mut g, &mut io);
    loop {
        board.poll(&mut g, &mut io);
    }
}

/// Test probe (never called by the board): runs a fresh sensing logic over `n` strobe slots
/// of scripted inputs, eight words each, with the calibration table in global RAM (and the
/// object and raw tables published there), and writes `sensing::SCRIPT_OUT_WORDS` words per
/// slot to `out` (`sensing::scripted_slot` has the format). The system tests compare it with
/// the host.
#[no_mangle]
#[link_section = ".text.probe.sensing_run"]
pub extern "C" fn sensing_probe_run(inputs: *const u32, n: u32, out: *mut i32) -> i32 {
    let mut s = sensing::Sensing::new();
    // SAFETY: the probe runs on the sensing image, where global RAM is mapped.
    let mut g = unsafe { MmioGlobal::new() };
    let mut i = 0;
    while i < n {
        // SAFETY: the caller passes 8 n input words and room for `SCRIPT_OUT_WORDS` n output
        // words.
        unsafe {
            probe_slot(
                &mut s,
                &mut g,
                inputs.add(8 * i as usize),
                out.add(sensing::SCRIPT_OUT_WORDS * i as usize),
            )
        };
        i += 1;
    }
    0
}

/// One slot of [`sensing_probe_run`]: eight input words at `w`, `SCRIPT_OUT_WORDS` output
/// words at `o`.
///
/// # Safety
/// `w` must point at 8 readable words and `o` at `sensing::SCRIPT_OUT_WORDS` writable ones.
#[inline(never)]
#[link_section = ".text.probe.sensing_slot"]
unsafe fn probe_slot(s: &mut sensing::Sensing, g: &mut MmioGlobal, w: *const u32, o: *mut i32) {
    // SAFETY: the caller's contract; u32 and i32 arrays are word aligned like the buffers.
    let (w, o) = unsafe {
        (
            &*(w as *const [u32; 8]),
            &mut *(o as *mut [i32; sensing::SCRIPT_OUT_WORDS]),
        )
    };
    sensing::scripted_slot(s, w, g, o);
}

fn safe_stop() {
    // SAFETY: called by the runtime on this board, where the private I/O is mapped.
    board_sensing::safe(&mut unsafe { MmioIo::new() });
}
