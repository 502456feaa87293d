//! The cspace board image: runtime entry and the main loop over volatile MMIO.
#![no_std]
#![no_main]

use board_cspace::Board;
use core::mem::MaybeUninit;
use cspace::worklist::Scratch;
use regs::MmioIo;
use vme_map::bus::MmioGlobal;

rt::entry!(vme_map::BoardId::Cspace0, main, safe_stop);

fn main() -> ! {
    // SAFETY: this image runs on a board that maps global RAM and its private I/O.
    let (mut g, mut io) = unsafe { (MmioGlobal::new(), MmioIo::new()) };
    let Some(id) = board_cspace::identify(&mut io) else {
        panic!("board-ID switch out of range (C-space boards are 0..=2)");
    };
    rt::set_board(id);
    // The jobs' 92 KiB of work memory: outside .bss (not zeroed at reset) and off the
    // stack (a frame over 32 KiB got a LINK.W with its displacement wrapped, positive:
    // docs/toolchain.md).
    #[link_section = ".uninit.cspace_scratch"]
    static mut SCRATCH: MaybeUninit<Scratch> = MaybeUninit::uninit();
    // SAFETY: main runs once; nothing else names SCRATCH.
    let scratch = Scratch::init(unsafe { &mut *core::ptr::addr_of_mut!(SCRATCH) });
    let mut board = Board::new(id, scratch);
    board.boot(&mut g, &mut io);
    loop {
        board.poll(&mut g, &mut io);
    }
}

fn safe_stop() {
    // SAFETY: called by the runtime on this board, where the private I/O is mapped.
    board_cspace::safe(&mut unsafe { MmioIo::new() });
}

/// Test probe (never called by the board): the images of the disk (`x_um`, `y_um`,
/// `r_um`) as this image computes them, written to `out` as 205 words: stripe lo, hi, full;
/// then front and rear each as present, wraps, 33 theta1, 33 upper, 33 lower. Returns 0, or
/// -1 when the disk has no images (too large). The system tests compare it with the host.
#[no_mangle]
#[link_section = ".text.probe.cspace_images"]
pub extern "C" fn cspace_probe_images(x_um: i32, y_um: i32, r_um: i32, out: *mut i32) -> i32 {
    let Ok(im) = cspace::images(&cspace::Disk { x_um, y_um, r_um }) else {
        return -1;
    };
    // Written straight through `out`: a local array indexed in a loop is miscompiled on the
    // 68k (llvm/llvm-project#200984).
    // SAFETY: the caller passes a buffer of 205 words.
    let put = |i: usize, v: i32| unsafe { out.add(i).write(v) };
    for i in 0..205 {
        put(i, 0);
    }
    if let Some(s) = im.stripe {
        put(0, s.lo_u);
        put(1, s.hi_u);
        put(2, s.full as i32);
    }
    // Front and rear one at a time (no local array of them: see above).
    if let Some(s) = &im.front {
        put(3, 1);
        put(4, s.wraps as i32);
        probe_shape(s, out, 5);
    }
    if let Some(s) = &im.rear {
        put(104, 1);
        put(105, s.wraps as i32);
        probe_shape(s, out, 106);
    }
    0
}

/// Writes a shape's chains through `out` from word `at` (through a reference: see above).
#[inline(never)]
fn probe_shape(s: &cspace::Shape, out: *mut i32, at: usize) {
    for k in 0..33 {
        // SAFETY: within the caller's 205-word buffer.
        unsafe {
            out.add(at + k).write(s.theta1_u[k]);
            out.add(at + 33 + k).write(s.upper_u[k]);
            out.add(at + 66 + k).write(s.lower_u[k]);
        }
    }
}

/// Test probe (never called by the board): draws the images of the disk (`x_um`, `y_um`,
/// `r_um`) into the map and stripe layer in global RAM as this image rasterises them.
/// Returns 0, or -1 when the disk has no images.
#[no_mangle]
#[link_section = ".text.probe.cspace_draw"]
pub extern "C" fn cspace_probe_draw(x_um: i32, y_um: i32, r_um: i32) -> i32 {
    let Ok(im) = cspace::images(&cspace::Disk { x_um, y_um, r_um }) else {
        return -1;
    };
    // SAFETY: only ever called on an emulated board, where global RAM is mapped.
    let mut g = unsafe { MmioGlobal::new() };
    cspace::apply(&im, &mut cspace::BusCanvas(&mut g), cspace::Op::Draw);
    0
}

/// The probes' job memory (never the board's: `main` has its own), initialised by each
/// probe call.
#[link_section = ".uninit.cspace_probe_scratch"]
static mut PROBE_SCRATCH: MaybeUninit<Scratch> = MaybeUninit::uninit();

/// The move probes' work: the images of `d0` drawn into the map and stripe layer in global
/// RAM, then moved to `d1` and, given `d2`, on to it, as jobs of one board do
/// (`cspace::worklist::move_disk`: the differential update with this image's assembly).
/// Returns how many images' columns were taken from those kept, or -1 when a disk has no
/// images.
#[inline(never)]
fn probe_moves(d0: &cspace::Disk, d1: &cspace::Disk, d2: Option<&cspace::Disk>) -> i32 {
    let Ok(im) = cspace::images(d0) else {
        return -1;
    };
    // SAFETY: only ever called on an emulated board, where global RAM is mapped; the
    // probes are the only code that names PROBE_SCRATCH, one call at a time.
    let (mut g, sc) = unsafe {
        (
            MmioGlobal::new(),
            Scratch::init(&mut *core::ptr::addr_of_mut!(PROBE_SCRATCH)),
        )
    };
    cspace::apply(&im, &mut cspace::BusCanvas(&mut g), cspace::Op::Draw);
    if !matches!(
        cspace::worklist::move_disk(&mut g, d0, d1, sc),
        Ok((_, None))
    ) {
        return -1;
    }
    if let Some(d2) = d2 {
        if !matches!(
            cspace::worklist::move_disk(&mut g, d1, d2, sc),
            Ok((_, None))
        ) {
            return -1;
        }
    }
    sc.kept_hits() as i32
}

/// Test probe (never called by the board): draws the images of disk (`x0`, `y0`, `r0`),
/// then moves them to disk (`x1`, `y1`, `r1`) as a job does ([`probe_moves`]). Returns 0,
/// or -1 when a disk has no images.
#[no_mangle]
#[link_section = ".text.probe.cspace_move"]
pub extern "C" fn cspace_probe_move(x0: i32, y0: i32, r0: i32, x1: i32, y1: i32, r1: i32) -> i32 {
    let disk = |x_um, y_um, r_um| cspace::Disk { x_um, y_um, r_um };
    probe_moves(&disk(x0, y0, r0), &disk(x1, y1, r1), None).min(0)
}

/// Test probe (never called by the board): draws the images of disk (`x0`, `y0`, `r0`),
/// moves them to disk (`x1`, `y1`, `r1`) and on to (`x2`, `y2`, `r2`) as two jobs of one
/// board do ([`probe_moves`]: the second takes the first's new images' columns from those
/// it kept). Returns how many images' columns were kept and taken, or -1 when a disk has
/// no images.
#[no_mangle]
#[link_section = ".text.probe.cspace_move_twice"]
#[allow(clippy::too_many_arguments)]
pub extern "C" fn cspace_probe_move_twice(
    x0: i32,
    y0: i32,
    r0: i32,
    x1: i32,
    y1: i32,
    r1: i32,
    x2: i32,
    y2: i32,
    r2: i32,
) -> i32 {
    let disk = |x_um, y_um, r_um| cspace::Disk { x_um, y_um, r_um };
    probe_moves(
        &disk(x0, y0, r0),
        &disk(x1, y1, r1),
        Some(&disk(x2, y2, r2)),
    )
}
