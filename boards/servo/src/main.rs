//! The servo board image: runtime entry and the main loop over volatile MMIO, paced by the
//! 2 MHz timer at `servo::params::IMAGE_HZ` (the rate its constants are designed for) on a
//! fixed schedule.
#![no_std]
#![no_main]

use board_servo::{Board, Ports};
use regs::servo::ServoIo;
use regs::MmioIo;
use servo::params::{IMAGE_HZ, TUNED_AT_IMAGE_HZ};
use vme_map::bus::MmioGlobal;

rt::entry!(vme_map::BoardId::Servo, main, safe_stop);

/// Timer ticks per pass at `IMAGE_HZ` or a little faster (the tick count rounded down: 666
/// at 3 kHz, 3,003 passes a second).
const PERIOD_TICKS: u16 = (regs::servo::TIMER_HZ as f64 / IMAGE_HZ) as u16;

fn main() -> ! {
    // SAFETY: this image runs on a board that maps global RAM and its private I/O.
    let (mut g, mut io) = unsafe { (MmioGlobal::new(), MmioIo::new()) };
    // The board's state (with its 1.5 KiB arrest log) is built at compile time into .data,
    // which the runtime copies at reset, instead of on the stack here (built and moved at
    // ~30 cycles a byte: 2.8 ms more before the first heartbeat).
    static mut BOARD: Board = Board::with_links(&TUNED_AT_IMAGE_HZ);
    // SAFETY: main runs once and is the only code that touches BOARD (the safe-stop hook
    // uses only the private I/O).
    let board = unsafe { &mut *core::ptr::addr_of_mut!(BOARD) };
    board.boot(&mut g, &mut io);
    let mut start = ServoIo::new(&mut io).timer();
    loop {
        board.poll_ports(&mut g, &mut io, &Ports::MMIO);
        // Wait for the period's end, counted from the last pass's own start time on the
        // schedule, not from when it began: a pass that overran (the rare ones the Rust
        // runs) starts the next at once, and the passes after make the overrun up, so the
        // rate holds; more than four periods behind (start-up, a long stall), the schedule
        // starts again from now rather than catching up in a burst.
        loop {
            let now = ServoIo::new(&mut io).timer();
            if now.wrapping_sub(start) >= PERIOD_TICKS {
                start = start.wrapping_add(PERIOD_TICKS);
                if now.wrapping_sub(start) >= 4 * PERIOD_TICKS {
                    start = now;
                }
                break;
            }
        }
    }
}

fn safe_stop() {
    // SAFETY: called by the runtime on this board, where the private I/O is mapped.
    board_servo::safe(&mut unsafe { MmioIo::new() });
}

/// Test probe (never called by the board): runs a fresh servo with the image's constants
/// over `n` passes of scripted inputs (`inputs`: six words per pass: encoder 1, encoder 2,
/// timer, link-1 goal, link-2 goal in micro-radians, the reflex cycle, `u32::MAX` for no
/// subgoal) and writes the output's `Output::probe_words` per pass to `out`.
/// The system tests compare it with the host.
#[no_mangle]
#[link_section = ".text.probe.servo_run"]
pub extern "C" fn servo_probe_run(inputs: *const u32, n: u32, out: *mut i32) -> i32 {
    let mut s = servo::Servo::with_links(&TUNED_AT_IMAGE_HZ);
    let mut o = servo::Output::IDLE;
    for i in 0..n as usize {
        // SAFETY: the caller passes 6 n input words and room for PROBE_WORDS n words.
        let w = |k: usize| unsafe { inputs.add(6 * i + k).read() };
        let cycle = w(5);
        let input = servo::Input {
            enc: [w(0) as u16, w(1) as u16],
            timer: w(2) as u16,
            subgoal: (cycle != u32::MAX).then(|| servo::Subgoal {
                goal_urad: [w(3) as i32, w(4) as i32],
                cycle,
            }),
        };
        // Both entry points: `step` (a returned output) on even passes, `step_into` (the
        // board's, written in place) on odd ones.
        if i % 2 == 0 {
            o = s.step(&input);
        } else {
            s.step_into(&input, &mut o);
        }
        let words = o.probe_words();
        for (k, v) in words.iter().enumerate() {
            // SAFETY: as above.
            unsafe { out.add(servo::Output::PROBE_WORDS * i + k).write(*v) };
        }
    }
    0
}

/// Private I/O registers in RAM for [`servo_board_probe_run`]: plain halfwords at the
/// registers' offsets (a latch write latches nothing; the probe sets the encoders).
struct RamIo(*mut u16);

impl regs::IoBus for RamIo {
    fn read16(&mut self, off: u32) -> u16 {
        // SAFETY: the probe's register array covers every offset the board uses.
        unsafe { self.0.add(off as usize / 2).read_volatile() }
    }
    fn write16(&mut self, off: u32, val: u16) {
        // SAFETY: as above.
        unsafe { self.0.add(off as usize / 2).write_volatile(val) }
    }
}

/// Test probe (never called by the board): runs a fresh board with the image's constants,
/// as the image does (`Board::poll_ports`), over `n` passes of scripted inputs, its private
/// I/O in RAM and global RAM the board's own. Seven input words a pass: encoder 1,
/// encoder 2, timer, link-1 goal, link-2 goal (urad), the reflex cycle, and how the subgoal
/// record is left before the pass (0 published whole, 1 torn: its sequence odd, 2 as it
/// was). Writes 15 words a pass to `out`: the servo state record's sequence and ten words,
/// both DAC registers, the amplifier control register and the heartbeat. The system tests
/// run the host's `Board::poll` over the same and compare.
#[no_mangle]
#[link_section = ".text.probe.servo_board_run"]
pub extern "C" fn servo_board_probe_run(inputs: *const u32, n: u32, out: *mut u32) -> i32 {
    use regs::servo::{AMP_CTRL, DAC0, DAC1, ENC0, ENC1, TIMER};
    use vme_map::GlobalBus;
    static mut REGS: [u16; 32] = [0; 32];
    // (This probe is REGS's only user; only raw pointers to it are made.)
    let regs = core::ptr::addr_of_mut!(REGS).cast::<u16>();
    let ports = Ports::at(regs as u32, vme_map::GLOBAL_RAM_BASE);
    // SAFETY: the probe runs on the servo board, which maps global RAM.
    let mut g = unsafe { MmioGlobal::new() };
    let mut io = RamIo(regs);
    let mut board = Board::with_links(&TUNED_AT_IMAGE_HZ);
    let sub = vme_map::REFLEX_SUBGOAL.offset();
    let state = vme_map::SERVO_STATE.offset();
    for i in 0..n as usize {
        // SAFETY: the caller passes 7 n input words and room for 15 n output words.
        let w = |k: usize| unsafe { inputs.add(7 * i + k).read() };
        regs::IoBus::write16(&mut io, ENC0, w(0) as u16);
        regs::IoBus::write16(&mut io, ENC1, w(1) as u16);
        regs::IoBus::write16(&mut io, TIMER, w(2) as u16);
        match w(6) {
            0 => vme_map::REFLEX_SUBGOAL.publish_raw(&mut g, &[w(3), w(4), 0, w(5)]),
            1 => {
                let seq = g.read_u32(sub);
                g.write_u32(sub, seq | 1);
            }
            _ => {}
        }
        let hb = board.poll_ports(&mut g, &mut io, &ports);
        let mut o = [0u32; 15];
        for (k, v) in o.iter_mut().take(11).enumerate() {
            *v = g.read_u32(state + 4 * k as u32);
        }
        o[11] = regs::IoBus::read16(&mut io, DAC0) as u32;
        o[12] = regs::IoBus::read16(&mut io, DAC1) as u32;
        o[13] = regs::IoBus::read16(&mut io, AMP_CTRL) as u32;
        o[14] = hb;
        for (k, v) in o.iter().enumerate() {
            // SAFETY: as above.
            unsafe { out.add(15 * i + k).write(*v) };
        }
    }
    0
}
