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
/// of scripted inputs (`inputs`: eight words per slot: timer; x, y and sum codes; flags (bit
/// 0: a sample was read, bit 1: it was over range, bit 2: a servo state was read); link 1
/// and link 2 angles in micro-radians; the servo's loop count) with the calibration table
/// in global RAM, and writes nine words per slot to `out`: the next beacon, its drive level,
/// the processed beacon (8: none), the event code, and the processed beacon's x_um, y_um,
/// flags, raw x_q5 and raw y_q5. The system tests compare it with the host.
#[no_mangle]
#[link_section = ".text.probe.sensing_run"]
pub extern "C" fn sensing_probe_run(inputs: *const u32, n: u32, out: *mut i32) -> i32 {
    let mut s = sensing::Sensing::new();
    // SAFETY: the probe runs on the sensing image, where global RAM is mapped.
    let mut g = unsafe { MmioGlobal::new() };
    let mut i = 0;
    while i < n {
        // SAFETY: the caller passes 8 n input words and room for 9 n output words.
        unsafe {
            probe_slot(
                &mut s,
                &mut g,
                inputs.add(8 * i as usize),
                out.add(9 * i as usize),
            )
        };
        i += 1;
    }
    0
}

/// One slot of [`sensing_probe_run`]: eight input words at `w`, nine output words at `o`.
/// (A function of its own, without inner loops: the probe's loops drew condition-code
/// clobbers; docs/toolchain.md class 1.)
///
/// # Safety
/// `w` must point at 8 readable words and `o` at 9 writable ones.
#[inline(never)]
#[link_section = ".text.probe.sensing_slot"]
unsafe fn probe_slot(s: &mut sensing::Sensing, g: &mut MmioGlobal, w: *const u32, o: *mut i32) {
    let r = |k: usize| unsafe { w.add(k).read() };
    let mut put = [-1i32; 9];
    if let Some(slot) = s.slot(r(0) as u16) {
        let f = r(4);
        let sample = (f & 1 != 0).then(|| sensing::AdcSample {
            x: r(1) as u16,
            y: r(2) as u16,
            sum: r(3) as u16,
            over: f & 2 != 0,
        });
        let servo = (f & 4 != 0).then(|| sensing::ServoView {
            theta_urad: [r(5) as i32, r(6) as i32],
            omega_urad_s: [0, 0],
            loops: r(7),
        });
        let input = sensing::Input {
            sample,
            servo,
            config: None,
        };
        let out = s.step(&input, &mut board_sensing::GlobalCal(g));
        let b = out.beacon.map_or(8, |b| b as usize);
        put = [
            slot.next as i32,
            slot.level_ma as i32,
            b as i32,
            out.event as i32,
            0,
            0,
            0,
            0,
            0,
        ];
        if b < 8 {
            let rb = s.objects.beacons[b];
            let raw = s.raw.beacons[b];
            put[4] = rb.x_um;
            put[5] = rb.y_um;
            put[6] = rb.flags as i32;
            put[7] = raw.x_q5;
            put[8] = raw.y_q5;
        }
    }
    // SAFETY: the caller's contract.
    unsafe { core::ptr::copy_nonoverlapping(put.as_ptr(), o, 9) };
}

fn safe_stop() {
    // SAFETY: called by the runtime on this board, where the private I/O is mapped.
    board_sensing::safe(&mut unsafe { MmioIo::new() });
}
