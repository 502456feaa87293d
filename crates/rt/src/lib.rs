//! The 68020 runtime of every board image (design.md section 8; the boards of thesis
//! ch. II "Computing", lines ~480-503, which ran without an operating system).
//!
//! * A 256-entry vector table at address 0: the initial stack pointer, the reset entry, and a
//!   common handler for every other vector.
//! * Reset: interrupts masked, the stack at the top of local RAM (vector 0), the instruction
//!   cache cleared and enabled (`CACR = CI | EI`; User's Manual section 6), `.data` copied
//!   from its load address, `.bss` cleared, then the board's `main` (declared with `entry!`,
//!   on the target).
//! * Exceptions (bus error, address error, illegal instruction, zero divide, spurious and
//!   unexpected interrupts, anything else): the stacked frame is decoded ([`decode_frame`]), the
//!   fault (vector, PC, SR, fault address) is recorded in the board's slot in global RAM, the
//!   board's safe-stop hook puts its outputs in the safe state, and the CPU halts with `STOP`
//!   and all interrupts masked. The status word then reads `SafeStop`.
//! * Panics: the message goes to the board's log ring, then the same safe stop.
//! * A `critical-section` implementation that raises the SR interrupt mask to 7.
//! * `memcpy` and friends in assembly, in place of compiler-builtins' miscompiled ones.
//!
//! All assembly is in `asm/rt.S`, assembled by GNU as (docs/toolchain.md says why).
//!
//! Only [`decode_frame`] and the fault bookkeeping build on the host (so they are unit tested
//! there); the assembly and handlers exist only for `target_arch = "m68k"`.
#![no_std]
#![deny(missing_docs)]

use vme_map::{BoardId, FaultCode, FaultRecord};

/// Decodes a 68020 exception stack frame into a fault record.
///
/// `frame` holds the 16-bit words from the stack pointer at exception entry: SR, PC (two
/// words), format/vector word, then the format-specific words. For the bus-cycle fault
/// frames (formats $A and $B) the data fault address is the long at byte offset $10 when the
/// special status word's DF bit is set, and otherwise the stage-B fetch address at $24
/// (long frames only).
pub fn decode_frame(frame: &[u16], heartbeat: u32) -> FaultRecord {
    let sr = frame[0] as u32;
    let pc = (frame[1] as u32) << 16 | frame[2] as u32;
    let fv = frame[3];
    let format = fv >> 12;
    let vector = ((fv & 0x0FFF) >> 2) as u32;
    let long_at = |byte: usize| (frame[byte / 2] as u32) << 16 | frame[byte / 2 + 1] as u32;
    let fault_addr = match format {
        0xA | 0xB if frame.len() >= 0x14 / 2 => {
            let ssw = frame[0x0A / 2];
            if ssw & 0x0100 != 0 {
                long_at(0x10)
            } else if format == 0xB && frame.len() >= 0x28 / 2 {
                long_at(0x24)
            } else {
                0
            }
        }
        _ => 0,
    };
    FaultRecord {
        code: FaultCode::from_vector(vector) as u32,
        vector,
        pc,
        sr,
        fault_addr,
        heartbeat,
        detail: format as u32,
    }
}

/// Bytes of a 68020 exception frame, by format code (MC68020 User's Manual, section 6.4).
pub const fn frame_bytes(format: u16) -> usize {
    match format {
        0x0 | 0x1 => 8,
        0x2 => 12,
        0x9 => 20,
        0xA => 32,
        0xB => 92,
        _ => 8,
    }
}

/// Records `rec` in `board`'s slot and marks the board safe-stopped. Used by the exception
/// and panic handlers; exposed so the host can check the bookkeeping without a CPU.
pub fn record_safe_stop(bus: &mut dyn vme_map::GlobalBus, board: BoardId, rec: &FaultRecord) {
    vme_map::BoardSlot::of(board).record_fault(bus, vme_map::BoardState::SafeStop, rec);
}

#[cfg(target_arch = "m68k")]
mod target;
#[cfg(target_arch = "m68k")]
pub use target::*;

#[cfg(test)]
mod tests {
    use super::*;
    use vme_map::{ArrayBus, BoardSlot, BoardState, GlobalBus};

    #[test]
    fn decodes_a_long_bus_fault_frame() {
        let mut f = [0u16; 46];
        f[0] = 0x2704; // SR
        f[1] = 0x0000;
        f[2] = 0x1234; // PC
        f[3] = 0xB000 | (2 << 2); // format B, vector 2
        f[5] = 0x0100 | 0x0040 | 0x0020; // SSW: DF, read, word
        f[8] = 0x00F0;
        f[9] = 0x8000; // fault address 0x00F08000
        let r = decode_frame(&f, 9);
        assert_eq!(r.vector, 2);
        assert_eq!(r.code, FaultCode::BusError as u32);
        assert_eq!(r.pc, 0x1234);
        assert_eq!(r.sr, 0x2704);
        assert_eq!(r.fault_addr, 0x00F0_8000);
        assert_eq!(r.heartbeat, 9);
        assert_eq!(r.detail, 0xB);
    }

    #[test]
    fn decodes_a_fetch_fault_and_a_short_frame() {
        let mut f = [0u16; 46];
        f[3] = 0xB000 | (2 << 2);
        f[5] = 0x5000; // FB|RB, no DF
        f[0x24 / 2] = 0x0003;
        f[0x24 / 2 + 1] = 0x0000;
        assert_eq!(decode_frame(&f, 0).fault_addr, 0x0003_0000);
        let g = [0x2000, 0x0000, 0x0400, 5 << 2]; // format 0, zero divide
        let r = decode_frame(&g, 0);
        assert_eq!(
            (r.vector, r.code, r.fault_addr),
            (5, FaultCode::ZeroDivide as u32, 0)
        );
        let s = [0x2000, 0, 0x0400, 24 << 2]; // spurious interrupt
        assert_eq!(
            decode_frame(&s, 0).code,
            FaultCode::UnexpectedException as u32
        );
    }

    #[test]
    fn safe_stop_is_recorded_in_the_slot() {
        let mut mem = [0u8; 0x800];
        let mut bus = ArrayBus::new(&mut mem);
        let f = [0x2000, 0x0000, 0x0400, 4 << 2];
        record_safe_stop(&mut bus, BoardId::Reflex, &decode_frame(&f, 3));
        let slot = BoardSlot::of(BoardId::Reflex);
        let st = slot.status_word(&mut bus);
        assert_eq!(st.state(), Some(BoardState::SafeStop));
        assert_eq!(st.fault(), Some(FaultCode::IllegalInstruction));
        assert_eq!(st.faults(), 1);
        let (rec, _) = slot.fault().read(&mut bus).unwrap();
        assert_eq!((rec.vector, rec.pc), (4, 0x400));
        // Other boards' slots untouched.
        assert_eq!(bus.read_u32(BoardSlot::of(BoardId::Servo).status()), 0);
    }
}
