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
    // The board's state is in `.data`, its first value copied with the rest at reset (one
    // aligned copy): built on the stack, its arrays (the evasion's, the escape's, the
    // known columns) were set and copied from value to value, some 70,000 cycles before
    // the first heartbeat.
    static mut BOARD: Board = Board::new();
    // SAFETY: `main` runs once and is the only code that touches BOARD.
    let board = unsafe { &mut *core::ptr::addr_of_mut!(BOARD) };
    board.boot(&mut g, &mut io);
    loop {
        board.poll(&mut g, &mut io);
    }
}

/// The probes' loop: answers `n` questions of `I` words each from `asks` with `f`, `O`
/// words an answer into `out`. Inlined, so each probe stays in its own section.
///
/// # Safety
/// `asks` holds `I` times `n` words and `out` has room for `O` times `n`, word aligned.
#[inline(always)]
unsafe fn each<const I: usize, const O: usize>(
    asks: *const i32,
    n: u32,
    out: *mut i32,
    mut f: impl FnMut(&[i32; I], &mut [i32; O]),
) -> i32 {
    let mut i = 0;
    while i < n as usize {
        // SAFETY: by the caller.
        let (w, o) = unsafe {
            (
                &*(asks.add(I * i) as *const [i32; I]),
                &mut *(out.add(O * i) as *mut [i32; O]),
            )
        };
        f(w, o);
        i += 1;
    }
    0
}

/// Test probe (never called by the board): runs a fresh reflex over `n` passes of scripted
/// inputs (`reflex::script::IN_WORDS` words each) against the C-space map in global RAM and
/// writes `reflex::script::OUT_WORDS` words per pass to `out`. The system tests compare it
/// with the host.
#[no_mangle]
#[link_section = ".text.probe.reflex_run"]
pub extern "C" fn reflex_probe_run(inputs: *const u32, n: u32, out: *mut i32) -> i32 {
    use reflex::script::{IN_WORDS, OUT_WORDS};
    // In .bss and written here: a `Reflex::new()` initializer put the whole reflex in
    // .data, copied at every reset for a probe only the tests call.
    static mut REFLEX: core::mem::MaybeUninit<reflex::Reflex> = core::mem::MaybeUninit::uninit();
    // SAFETY: the probe is the only code that touches REFLEX, and runs once per call.
    let r = unsafe {
        (*core::ptr::addr_of_mut!(REFLEX)).write(reflex::Reflex::new(reflex::Config::DEFAULT))
    };
    // SAFETY: the probe runs on the reflex image, where global RAM is mapped.
    let mut g = unsafe { MmioGlobal::new() };
    let mut i = 0;
    while i < n {
        // SAFETY: the caller passes IN_WORDS n input words and room for OUT_WORDS n outputs,
        // word aligned.
        let (w, o) = unsafe {
            (
                &*(inputs.add(IN_WORDS * i as usize) as *const [u32; IN_WORDS]),
                &mut *(out.add(OUT_WORDS * i as usize) as *mut [i32; OUT_WORDS]),
            )
        };
        reflex::script::scripted_pass(r, w, &mut reflex::window::BusMap(&mut g), o);
        i += 1;
    }
    0
}

/// Test probe (never called by the board): plans `n` escapes
/// (`reflex::script::ESCAPE_IN_WORDS` words each) on the C-space map in global RAM and
/// writes `reflex::script::ESCAPE_OUT_WORDS` words per plan to `out`. The system tests
/// compare it with the host.
#[no_mangle]
#[link_section = ".text.probe.reflex_escape"]
pub extern "C" fn reflex_probe_escape(asks: *const i32, n: u32, out: *mut i32) -> i32 {
    use reflex::script::{ESCAPE_IN_WORDS, ESCAPE_OUT_WORDS};
    static mut SCRATCH: reflex::escape::Scratch = reflex::escape::Scratch::new();
    // SAFETY: the probe is the only code that touches SCRATCH, and runs once per call.
    let s = unsafe { &mut *core::ptr::addr_of_mut!(SCRATCH) };
    // SAFETY: the probe runs on the reflex image, where global RAM is mapped.
    let mut g = unsafe { MmioGlobal::new() };
    // SAFETY: the caller passes the words of n questions and room for n answers.
    unsafe {
        each::<ESCAPE_IN_WORDS, ESCAPE_OUT_WORDS>(asks, n, out, |w, o| {
            reflex::script::scripted_escape(s, w, &mut reflex::window::BusMap(&mut g), o)
        })
    }
}

#[no_mangle]
#[link_section = ".text.probe.reflex_evade"]
pub extern "C" fn reflex_probe_evade(asks: *const i32, n: u32, out: *mut i32) -> i32 {
    use reflex::script::{EVADE_IN_WORDS, EVADE_OUT_WORDS};
    static mut SCRATCH: reflex::evade::Scratch = reflex::evade::Scratch::new();
    static mut OBS: [reflex::ObstacleView; reflex::OBSTACLES] =
        [reflex::ObstacleView::NONE; reflex::OBSTACLES];
    let s = unsafe { &mut *core::ptr::addr_of_mut!(SCRATCH) };
    let obs = unsafe { &mut *core::ptr::addr_of_mut!(OBS) };
    // SAFETY: the caller passes the words of n questions and room for n answers.
    unsafe {
        each::<EVADE_IN_WORDS, EVADE_OUT_WORDS>(asks, n, out, |w, o| {
            reflex::script::scripted_evade(s, w, obs, o)
        })
    }
}

/// Test probe (never called by the board): `n` known-columns steps
/// (`reflex::script::KNOWN_IN_WORDS` words each) on the map in global RAM, through one
/// `Known` kept from call to call; writes `reflex::script::KNOWN_OUT_WORDS` words per step
/// to `out`. The system tests compare it with the host.
#[no_mangle]
#[link_section = ".text.probe.reflex_known"]
pub extern "C" fn reflex_probe_known(steps: *const i32, n: u32, out: *mut i32) -> i32 {
    use reflex::script::{KNOWN_IN_WORDS, KNOWN_OUT_WORDS};
    static mut KNOWN: reflex::window::Known = reflex::window::Known::new();
    // SAFETY: the probe is the only code that touches KNOWN.
    let k = unsafe { &mut *core::ptr::addr_of_mut!(KNOWN) };
    // SAFETY: the probe runs on the reflex image, where global RAM is mapped.
    let mut g = unsafe { MmioGlobal::new() };
    // SAFETY: the caller passes the words of n questions and room for n answers.
    unsafe {
        each::<KNOWN_IN_WORDS, KNOWN_OUT_WORDS>(steps, n, out, |w, o| {
            reflex::script::scripted_known(k, &mut g, w, o)
        })
    }
}

fn safe_stop() {
    // SAFETY: called by the runtime on this board, where the private I/O is mapped.
    board_reflex::safe(&mut unsafe { MmioIo::new() });
}

/// Test probe (never called by the board): `n` axis questions
/// (`reflex::script::PREPARE_IN_WORDS` words each) through the reflex's `prepare` (the
/// runtime's `__reflex_prepare`); writes `reflex::script::PREPARE_OUT_WORDS` words per
/// answer to `out`. The system tests compare it with the host.
#[no_mangle]
#[link_section = ".text.probe.reflex_prepare"]
pub extern "C" fn reflex_probe_prepare(asks: *const i32, n: u32, out: *mut i32) -> i32 {
    use reflex::script::{PREPARE_IN_WORDS, PREPARE_OUT_WORDS};
    // SAFETY: the caller passes the words of n questions and room for n answers.
    unsafe {
        each::<PREPARE_IN_WORDS, PREPARE_OUT_WORDS>(asks, n, out, reflex::script::scripted_prepare)
    }
}

/// Test probe (never called by the board): `n` stall questions
/// (`reflex::script::STALL_IN_WORDS` words each) through `reflex::stall_flags` (the
/// runtime's `__reflex_stall`); writes `reflex::script::STALL_OUT_WORDS` words per answer
/// to `out`. The system tests compare it with the host.
#[no_mangle]
#[link_section = ".text.probe.reflex_stall"]
pub extern "C" fn reflex_probe_stall(asks: *const i32, n: u32, out: *mut i32) -> i32 {
    use reflex::script::{STALL_IN_WORDS, STALL_OUT_WORDS};
    // SAFETY: the caller passes the words of n questions and room for n answers.
    unsafe { each::<STALL_IN_WORDS, STALL_OUT_WORDS>(asks, n, out, reflex::script::scripted_stall) }
}

/// Test probe (never called by the board): `n` goal-clamp questions
/// (`reflex::script::CLAMP_IN_WORDS` words each) through `reflex::clamp_into` (the
/// runtime's `__reflex_clamp_into`); writes one word per answer to `out`. The system tests
/// compare it with the host.
#[no_mangle]
#[link_section = ".text.probe.reflex_clamp"]
pub extern "C" fn reflex_probe_clamp(asks: *const i32, n: u32, out: *mut i32) -> i32 {
    use reflex::script::CLAMP_IN_WORDS;
    // SAFETY: the caller passes the words of n questions and room for n answers.
    unsafe { each::<CLAMP_IN_WORDS, 1>(asks, n, out, reflex::script::scripted_clamp) }
}

/// Test probe (never called by the board): `n` steps of one health monitor's entry readings
/// (`reflex::script::HEALTH_IN_WORDS` words each; one monitor kept from call to call) through
/// `reflex::health::Monitor::entry` (the runtime's `__reflex_health_entry`); writes
/// `reflex::script::HEALTH_OUT_WORDS` words per step to `out`. The system tests compare it
/// with the host.
#[no_mangle]
#[link_section = ".text.probe.reflex_health"]
pub extern "C" fn reflex_probe_health(steps: *const i32, n: u32, out: *mut i32) -> i32 {
    use reflex::script::{HEALTH_IN_WORDS, HEALTH_OUT_WORDS};
    static mut MONITOR: reflex::health::Monitor = reflex::health::Monitor::new();
    // SAFETY: the probe is the only code that touches MONITOR.
    let m = unsafe { &mut *core::ptr::addr_of_mut!(MONITOR) };
    // SAFETY: the caller passes the words of n questions and room for n answers.
    unsafe {
        each::<HEALTH_IN_WORDS, HEALTH_OUT_WORDS>(steps, n, out, |w, o| {
            reflex::script::scripted_health_entry(m, w, o)
        })
    }
}
