//! Register maps of the boards' private I/O (design.md sections 1 and 4; thesis ch. II,
//! "Servo board private I/O" and the optical sensing electronics, thesis lines ~404-503).
//!
//! Every board's private I/O sits at [`PRIVATE_IO_BASE`]; all registers are 16 bits wide and
//! big-endian. Board code reaches them through an [`IoBus`] (volatile MMIO on the 68020,
//! the simulator's device models on the host) and the typed blocks [`servo::ServoIo`] and
//! [`sensing::SensingIo`]. `docs/registers.md` has the address table; a test keeps it in step
//! with [`servo::REGISTERS`] and [`sensing::REGISTERS`].
#![no_std]
#![deny(missing_docs)]
#![cfg_attr(target_arch = "m68k", feature(asm_experimental_arch))]

pub mod sensing;
pub mod servo;

/// Address of the private I/O block on every board's bus.
pub const PRIVATE_IO_BASE: u32 = 0x00F0_0000;
/// Bytes of address space decoded for private I/O; anything not listed in a board's register
/// table faults (bus error).
pub const PRIVATE_IO_SIZE: u32 = 0x0001_0000;

/// Board-ID switch (every board, read-only): the instance number set by the DIP switch,
/// which tells identical C-space images apart (0..=2).
pub const BOARD_ID: u32 = 0x00;

/// An address inside the private-I/O block that no board decodes: reading it takes a bus
/// error. The host's bus-error injection command makes a board read it.
pub const UNDECODED_PROBE: u32 = 0xFFFE;

/// 16-bit register access at byte offsets from [`PRIVATE_IO_BASE`].
pub trait IoBus {
    /// Reads the register at `off`.
    fn read16(&mut self, off: u32) -> u16;
    /// Writes the register at `off`.
    fn write16(&mut self, off: u32, val: u16);
}

impl<B: IoBus + ?Sized> IoBus for &mut B {
    fn read16(&mut self, off: u32) -> u16 {
        (**self).read16(off)
    }
    fn write16(&mut self, off: u32, val: u16) {
        (**self).write16(off, val)
    }
}

/// Direction of a register.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Read-only.
    R,
    /// Write-only.
    W,
    /// Read-write.
    RW,
}

/// One row of a register table, for documentation and for the simulator's address decoder.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Register {
    /// Register name used in `docs/registers.md`.
    pub name: &'static str,
    /// Byte offset from [`PRIVATE_IO_BASE`].
    pub offset: u32,
    /// Direction.
    pub access: Access,
}

/// Whether `off` is a register of `table` and may be accessed in direction `write`.
pub fn decodes(table: &[Register], off: u32, write: bool) -> bool {
    table.iter().any(|r| {
        r.offset == off
            && match r.access {
                Access::R => !write,
                Access::W => write,
                Access::RW => true,
            }
    })
}

/// Volatile access to the private I/O block. Only meaningful on the 68020 boards.
#[cfg(target_arch = "m68k")]
pub struct MmioIo(());

#[cfg(target_arch = "m68k")]
impl MmioIo {
    /// Creates the accessor.
    ///
    /// # Safety
    /// The caller must run on a board whose bus maps its private I/O at [`PRIVATE_IO_BASE`].
    pub const unsafe fn new() -> Self {
        Self(())
    }
}

#[cfg(target_arch = "m68k")]
impl IoBus for MmioIo {
    #[inline(always)]
    fn read16(&mut self, off: u32) -> u16 {
        // One MOVE.W, spelled out: LLVM's M68k backend selected a zero-extended 16-bit
        // volatile read from an absolute address as MOVE.L, reading two registers
        // (docs/toolchain.md, class 10). A call of an assembly routine did the same at about
        // 50 cycles a read; this is one instruction.
        let v: u16;
        // SAFETY: `new`'s contract; offsets come from this crate's tables. The instruction
        // reads the one register and writes only `v` (and the condition codes, which the
        // compiler takes as clobbered: no `preserves_flags`).
        unsafe {
            core::arch::asm!(
                "move.w ({a}), {v}",
                a = in(reg_addr) (PRIVATE_IO_BASE + off) as *const u16,
                v = out(reg_data) v,
                options(nostack, readonly),
            )
        };
        v
    }
    #[inline(always)]
    fn write16(&mut self, off: u32, val: u16) {
        // SAFETY: as above.
        unsafe { core::ptr::write_volatile((PRIVATE_IO_BASE + off) as *mut u16, val) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_table(table: &[Register]) {
        for (i, a) in table.iter().enumerate() {
            assert!(a.offset % 2 == 0, "{} is halfword aligned", a.name);
            assert!(a.offset < PRIVATE_IO_SIZE, "{} is in the block", a.name);
            for b in &table[i + 1..] {
                assert_ne!(a.offset, b.offset, "{} and {} overlap", a.name, b.name);
            }
        }
    }

    #[test]
    fn register_tables_are_aligned_and_disjoint() {
        check_table(&servo::REGISTERS);
        check_table(&sensing::REGISTERS);
    }

    #[test]
    fn decoding_respects_direction() {
        assert!(decodes(&servo::REGISTERS, servo::TIMER, false));
        assert!(!decodes(&servo::REGISTERS, servo::TIMER, true));
        assert!(decodes(&servo::REGISTERS, servo::DAC0, true));
        assert!(!decodes(&servo::REGISTERS, 0x7FFE, false));
    }
}
