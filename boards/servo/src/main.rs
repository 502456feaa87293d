//! The servo board image: runtime entry and the main loop over volatile MMIO, paced by the
//! 2 MHz timer at `servo::params::IMAGE_HZ` (the rate its constants are designed for).
#![no_std]
#![no_main]

use board_servo::Board;
use regs::servo::ServoIo;
use regs::MmioIo;
use servo::params::{IMAGE_HZ, TUNED_AT_IMAGE_HZ};
use vme_map::bus::MmioGlobal;

rt::entry!(vme_map::BoardId::Servo, main, safe_stop);

/// Timer ticks per pass at `IMAGE_HZ`.
const PERIOD_TICKS: u16 = (regs::servo::TIMER_HZ as f64 / IMAGE_HZ + 0.5) as u16;

fn main() -> ! {
    // SAFETY: this image runs on a board that maps global RAM and its private I/O.
    let (mut g, mut io) = unsafe { (MmioGlobal::new(), MmioIo::new()) };
    let mut board = Board::with_links(&TUNED_AT_IMAGE_HZ);
    board.boot(&mut g, &mut io);
    let mut start = ServoIo::new(&mut io).timer();
    loop {
        board.poll(&mut g, &mut io);
        // Wait out the rest of the period (a pass that overran starts the next at once).
        loop {
            let now = ServoIo::new(&mut io).timer();
            if now.wrapping_sub(start) >= PERIOD_TICKS {
                start = now;
                break;
            }
        }
    }
}

fn safe_stop() {
    // SAFETY: called by the runtime on this board, where the private I/O is mapped.
    board_servo::safe(&mut unsafe { MmioIo::new() });
}
