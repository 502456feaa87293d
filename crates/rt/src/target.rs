//! The target-only half of the runtime: assembly, handlers, panic, critical section.

use core::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use vme_map::bus::MmioGlobal;
use vme_map::{BoardId, BoardSlot, FaultCode, FaultRecord, GlobalBus};

// The vector table, reset, exception entry, SR access and memory routines are in
// `asm/rt.S`, assembled by GNU as from the build script.

static BOARD: AtomicU8 = AtomicU8::new(BoardId::Sensing as u8);
static IN_FAULT: AtomicBool = AtomicBool::new(false);

/// The board whose slot faults are recorded in (set by [`entry!`] and [`set_board`]).
pub fn board() -> BoardId {
    BoardId::from_index(BOARD.load(Ordering::Relaxed) as u32).unwrap_or(BoardId::Sensing)
}

/// Sets the board identity used for fault records; C-space images call it after reading
/// their instance number from the board-ID switch.
pub fn set_board(id: BoardId) {
    BOARD.store(id as u8, Ordering::Relaxed);
}

/// Halts the CPU for good: all interrupts masked, `STOP` until reset.
pub fn halt() -> ! {
    // SAFETY: STOP with the mask at 7 only waits for a reset.
    unsafe { __rt_halt() }
}

extern "C" {
    fn __rt_halt() -> !;
}

extern "Rust" {
    fn __rt_main() -> !;
    fn __rt_safe_stop();
}

#[no_mangle]
extern "C" fn __rt_start() -> ! {
    // SAFETY: defined by the board's `entry!`.
    unsafe { __rt_main() }
}

/// Common end of every fault: safe outputs, record, halt. A fault while handling a fault
/// only halts.
fn safe_stop(rec: &FaultRecord) -> ! {
    // A plain load and store, not `swap`: interrupts are masked here, and LLVM's M68k backend
    // miscompiles the compare-and-swap loop `swap` expands to (a register copy placed between
    // the compare and the branch clobbers the condition codes; llvm/llvm-project#152816,
    // #213564). docs/toolchain.md has the details.
    if IN_FAULT.load(Ordering::Relaxed) {
        halt();
    }
    IN_FAULT.store(true, Ordering::Relaxed);
    // SAFETY: the board's hook only writes its own private I/O.
    unsafe { __rt_safe_stop() };
    // SAFETY: every board maps global RAM at GLOBAL_RAM_BASE.
    let mut g = unsafe { MmioGlobal::new() };
    crate::record_safe_stop(&mut g, board(), rec);
    halt()
}

#[no_mangle]
extern "C" fn __rt_exception(frame: *const u16) -> ! {
    // SAFETY: `frame` is the supervisor stack pointer at entry; the 68020 pushed at least
    // the frame size of the format in word 3.
    let fv = unsafe { frame.add(3).read() };
    let len = crate::frame_bytes(fv >> 12) / 2;
    let words = unsafe { core::slice::from_raw_parts(frame, len) };
    // SAFETY: global RAM is mapped on every board.
    let mut g = unsafe { MmioGlobal::new() };
    let hb = g.read_u32(BoardSlot::of(board()).heartbeat());
    let rec = crate::decode_frame(words, hb);
    safe_stop(&rec)
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    // SAFETY: global RAM is mapped on every board.
    let mut g = unsafe { MmioGlobal::new() };
    let hb = g.read_u32(BoardSlot::of(board()).heartbeat());
    let line = info.location().map(|l| l.line()).unwrap_or(0);
    if !IN_FAULT.load(Ordering::Relaxed) {
        // No `core::fmt` and no local buffer here: LLVM's M68k backend miscompiles both
        // (docs/toolchain.md). The message is logged when it is a plain string, with the
        // location appended, streamed straight into the log ring.
        let mut t = vme_map::log::TextStream::for_board(board(), &mut g, hb);
        t.push(&mut g, b"panic: ");
        t.push(
            &mut g,
            info.message()
                .as_str()
                .unwrap_or("(formatted message)")
                .as_bytes(),
        );
        if let Some(l) = info.location() {
            t.push(&mut g, b" at ");
            t.push(&mut g, l.file().as_bytes());
            t.push(&mut g, b":");
            t.push_decimal(&mut g, l.line());
        }
        t.finish(&mut g);
    }
    safe_stop(&FaultRecord {
        code: FaultCode::Panic as u32,
        heartbeat: hb,
        detail: line,
        ..Default::default()
    })
}

/// Declares the board's entry point, its identity and its safe-stop hook.
///
/// `$main` is `fn() -> !`; `$safe` is `fn()` and must only put the board's outputs in their
/// safe state (it runs inside the fault handler with interrupts masked).
#[macro_export]
macro_rules! entry {
    ($board:expr, $main:path, $safe:path) => {
        #[export_name = "__rt_main"]
        fn __rt_main_impl() -> ! {
            $crate::set_board($board);
            let f: fn() -> ! = $main;
            f()
        }
        #[export_name = "__rt_safe_stop"]
        fn __rt_safe_stop_impl() {
            let f: fn() = $safe;
            f()
        }
    };
}

struct SrMask;
critical_section::set_impl!(SrMask);

// SAFETY: the boards are single-CPU; masking interrupts at level 7 excludes every handler,
// and the saved SR restores exactly the previous mask.
unsafe impl critical_section::Impl for SrMask {
    unsafe fn acquire() -> u16 {
        __rt_sr_mask_all() as u16
    }
    unsafe fn release(sr: u16) {
        __rt_sr_restore(sr as u32)
    }
}

extern "C" {
    /// Returns the SR and raises the interrupt mask to 7.
    fn __rt_sr_mask_all() -> u32;
    /// Sets the SR to `sr` (only the value `__rt_sr_mask_all` returned).
    fn __rt_sr_restore(sr: u32);
}
