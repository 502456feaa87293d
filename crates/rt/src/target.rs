//! The target-only half of the runtime: assembly, handlers, panic, critical section.

use core::arch::{asm, global_asm};
use core::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use vme_map::bus::MmioGlobal;
use vme_map::{BoardId, BoardSlot, FaultCode, FaultRecord, GlobalBus};

// Vector table, reset and the common exception entry.
//
// LLVM's M68k assembler (LLVM 22) does not know every 68020 instruction and silently
// assembles `move.w #imm, %sr` as a move to %d0, so privileged and missing instructions are
// written as their encodings (MC68020 User's Manual) with the mnemonic in a comment.
// `sim-host`'s image tests disassemble the reset code with the emulator's disassembler to
// check them.
//
// Every vector but 0 (initial SSP) and 1 (reset PC) points at `_exception`: the 68020 stacks
// a format/vector word, so one entry can tell all exceptions apart.
global_asm!(
    r#"
    .section .vectors, "a"
    .globl __vectors
__vectors:
    .long _stack_top
    .long _reset
    .rept 254
    .long _exception
    .endr

    .section .text._reset, "ax"
    .globl _reset
_reset:
    .short 0x46fc, 0x2700    /* move.w #0x2700, %sr */
    lea _stack_top, %a0
    move.l %a0, %sp
    lea _sidata, %a0
    lea _sdata, %a1
    lea _edata, %a2
1:
    .short 0xb3ca            /* cmpa.l %a2, %a1 (not in LLVM's M68k assembler) */
    bcc 2f
    move.l (%a0)+, (%a1)+
    bra 1b
2:
    lea _sbss, %a1
    lea _ebss, %a2
3:
    .short 0xb3ca            /* cmpa.l %a2, %a1 (not in LLVM's M68k assembler) */
    bcc 4f
    .short 0x4299            /* clr.l (%a1)+ (not in LLVM's M68k assembler) */
    bra 3b
4:
    jsr __rt_start
5:
    bra 5b

    .section .text._exception, "ax"
    .globl _exception
_exception:
    .short 0x46fc, 0x2700    /* move.w #0x2700, %sr */
    move.l %sp, -(%sp)
    jsr __rt_exception
6:
    bra 6b

    .section .text.__rt_sr, "ax"
    .globl __rt_sr_mask_all
__rt_sr_mask_all:
    moveq #0, %d0
    .short 0x40c0            /* move.w %sr, %d0 */
    .short 0x007c, 0x0700    /* ori.w #0x0700, %sr */
    rts
    .globl __rt_sr_restore
__rt_sr_restore:
    move.l (4,%sp), %d0
    .short 0x46c0            /* move.w %d0, %sr */
    rts
"#
);

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
    loop {
        // SAFETY: STOP with the mask at 7 only waits for a reset (or NMI, which faults here).
        unsafe { asm!(".short 0x4e72, 0x2700 /* stop #0x2700 */", options(nomem, nostack)) };
    }
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
    if IN_FAULT.swap(true, Ordering::Relaxed) {
        halt();
    }
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
    use core::fmt::Write;
    // SAFETY: global RAM is mapped on every board.
    let mut g = unsafe { MmioGlobal::new() };
    let hb = g.read_u32(BoardSlot::of(board()).heartbeat());
    if !IN_FAULT.load(Ordering::Relaxed) {
        let mut w = vme_map::log::LogFmt::new(board(), &mut g, hb);
        let _ = write!(w, "panic: {}", info);
        w.finish();
    }
    let line = info.location().map(|l| l.line()).unwrap_or(0);
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
