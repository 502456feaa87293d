//! One board as its real image on an emulated 68020 (design.md section 7, "image mode").
//!
//! The CPU is the `m68k` crate's core set to [`CpuType::M68020`], advanced by cycles at
//! [`CPU_HZ`]. Its bus ([`BoardBus`]) decodes the board's address map (design.md section 4):
//!
//! | range | target |
//! |---|---|
//! | `0x0000_0000..0x0010_0000` | the board's 1 MiB local RAM |
//! | `0x00F0_0000..0x00F1_0000` | the board's private I/O ([`Device`]); undecoded registers bus-fault |
//! | `0x0100_0000..0x0180_0000` | global RAM, shared with the other boards and the host |
//! | anything else | bus error |
//!
//! No 68881 is fitted: the images use software floating point, and a coprocessor instruction
//! takes the line-F exception (vector 11).
//!
//! Traps the core surfaces instead of taking (illegal instruction, A-line, F-line, TRAP,
//! BKPT) are taken as the hardware would, through the image's vector table.

use crate::image::{Image, LOCAL_RAM_SIZE};
use m68k::core::memory::{BusFault, BusFaultKind};
use m68k::{AddressBus, CpuCore, CpuType, CycleBatchExit};
use regs::{PRIVATE_IO_BASE, PRIVATE_IO_SIZE};
use vme_map::{BoardId, GLOBAL_RAM_BASE, GLOBAL_RAM_SIZE};

/// Clock of the emulated 68020s (thesis ch. II: 16.7 MHz boards).
pub const CPU_HZ: u64 = 16_700_000;

/// A board's private I/O at register level. Offsets are from [`PRIVATE_IO_BASE`].
pub trait Device {
    /// Reads the 16-bit register at `off` at CPU cycle `now`; `None` if no register is
    /// decoded there for reading (the access takes a bus error).
    fn read16(&mut self, off: u32, now: u64) -> Option<u16>;
    /// Writes the 16-bit register at `off` at CPU cycle `now`; `false` if no register is
    /// decoded there for writing (the access takes a bus error).
    fn write16(&mut self, off: u32, val: u16, now: u64) -> bool;
}

/// The bus one emulated board sees while it runs.
pub struct BoardBus<'a> {
    /// Local RAM (1 MiB).
    pub ram: &'a mut [u8],
    /// Global RAM (8 MiB), shared.
    pub global: &'a mut [u8],
    /// Private I/O.
    pub io: &'a mut dyn Device,
    /// CPU cycle at the start of the current instruction.
    pub now: u64,
}

fn fault(address: u32) -> BusFault {
    BusFault {
        kind: BusFaultKind::BusError,
        address,
    }
}

impl BoardBus<'_> {
    fn mem(&mut self, addr: u32, len: u32) -> Option<&mut [u8]> {
        if addr.checked_add(len)? <= LOCAL_RAM_SIZE {
            return Some(&mut self.ram[addr as usize..(addr + len) as usize]);
        }
        let g = addr.checked_sub(GLOBAL_RAM_BASE)?;
        if g.checked_add(len)? <= GLOBAL_RAM_SIZE {
            return Some(&mut self.global[g as usize..(g + len) as usize]);
        }
        None
    }

    fn io_off(addr: u32) -> Option<u32> {
        let off = addr.checked_sub(PRIVATE_IO_BASE)?;
        (off < PRIVATE_IO_SIZE).then_some(off)
    }

    fn io_read16(&mut self, addr: u32) -> Result<u16, BusFault> {
        let off = Self::io_off(addr)
            .filter(|o| o % 2 == 0)
            .ok_or(fault(addr))?;
        self.io.read16(off, self.now).ok_or(fault(addr))
    }

    fn io_write16(&mut self, addr: u32, val: u16) -> Result<(), BusFault> {
        let off = Self::io_off(addr)
            .filter(|o| o % 2 == 0)
            .ok_or(fault(addr))?;
        if self.io.write16(off, val, self.now) {
            Ok(())
        } else {
            Err(fault(addr))
        }
    }
}

impl AddressBus for BoardBus<'_> {
    fn read_byte(&mut self, a: u32) -> u8 {
        self.try_read_byte(a).unwrap_or(0xFF)
    }
    fn read_word(&mut self, a: u32) -> u16 {
        self.try_read_word(a).unwrap_or(0xFFFF)
    }
    fn read_long(&mut self, a: u32) -> u32 {
        self.try_read_long(a).unwrap_or(0xFFFF_FFFF)
    }
    fn write_byte(&mut self, a: u32, v: u8) {
        let _ = self.try_write_byte(a, v);
    }
    fn write_word(&mut self, a: u32, v: u16) {
        let _ = self.try_write_word(a, v);
    }
    fn write_long(&mut self, a: u32, v: u32) {
        let _ = self.try_write_long(a, v);
    }

    fn try_read_byte(&mut self, a: u32) -> Result<u8, BusFault> {
        if let Some(m) = self.mem(a, 1) {
            return Ok(m[0]);
        }
        // A byte of a 16-bit register: the upper byte at the even address.
        let w = self.io_read16(a & !1)?;
        Ok(if a & 1 == 0 { (w >> 8) as u8 } else { w as u8 })
    }
    fn try_read_word(&mut self, a: u32) -> Result<u16, BusFault> {
        if let Some(m) = self.mem(a, 2) {
            return Ok(u16::from_be_bytes([m[0], m[1]]));
        }
        self.io_read16(a)
    }
    fn try_read_long(&mut self, a: u32) -> Result<u32, BusFault> {
        if let Some(m) = self.mem(a, 4) {
            return Ok(u32::from_be_bytes([m[0], m[1], m[2], m[3]]));
        }
        // The 16-bit I/O port: dynamic bus sizing splits a long into two word cycles.
        let hi = self.io_read16(a)?;
        let lo = self.io_read16(a.wrapping_add(2))?;
        Ok((hi as u32) << 16 | lo as u32)
    }
    fn try_write_byte(&mut self, a: u32, v: u8) -> Result<(), BusFault> {
        if let Some(m) = self.mem(a, 1) {
            m[0] = v;
            return Ok(());
        }
        // Registers are written 16 bits at a time; a byte write is not decoded.
        Err(fault(a))
    }
    fn try_write_word(&mut self, a: u32, v: u16) -> Result<(), BusFault> {
        if let Some(m) = self.mem(a, 2) {
            m.copy_from_slice(&v.to_be_bytes());
            return Ok(());
        }
        self.io_write16(a, v)
    }
    fn try_write_long(&mut self, a: u32, v: u32) -> Result<(), BusFault> {
        if let Some(m) = self.mem(a, 4) {
            m.copy_from_slice(&v.to_be_bytes());
            return Ok(());
        }
        self.io_write16(a, (v >> 16) as u16)?;
        self.io_write16(a.wrapping_add(2), v as u16)
    }
}

/// Whether an emulated board is still executing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RunState {
    /// Executing instructions.
    Running,
    /// The CPU executed `STOP` with no interrupt that can wake it: the runtime's halt after
    /// a fault, or a double fault.
    Halted,
}

/// One board: its image on an emulated 68020, its local RAM and its private I/O.
pub struct EmuBoard {
    /// Which board this is (which global RAM slot it owns).
    pub id: BoardId,
    /// The CPU core.
    pub cpu: CpuCore,
    /// Local RAM.
    pub ram: Vec<u8>,
    /// Private I/O devices.
    pub io: Box<dyn Device>,
    /// CPU cycles executed since reset.
    pub cycles: u64,
    /// Instructions executed since reset.
    pub instructions: u64,
    /// Whether it still runs.
    pub state: RunState,
}

impl EmuBoard {
    /// Loads `image` into a fresh board's local RAM and resets the CPU (which fetches the
    /// initial stack pointer and PC from the image's vector table).
    pub fn new(id: BoardId, image: &Image, io: Box<dyn Device>, global: &mut [u8]) -> Self {
        let mut cpu = CpuCore::new();
        cpu.set_cpu_type(CpuType::M68020);
        // The images use software floating point (rustc emits no 68881 code; design.md
        // section 6), so the boards are modelled without a coprocessor: a stray 68881
        // instruction takes the line-F exception instead of running on absent hardware.
        cpu.fpu_present = false;
        let mut b = Self {
            id,
            cpu,
            ram: image.to_ram(),
            io,
            cycles: 0,
            instructions: 0,
            state: RunState::Running,
        };
        let mut bus = BoardBus {
            ram: &mut b.ram,
            global,
            io: &mut *b.io,
            now: 0,
        };
        b.cpu.reset(&mut bus);
        b
    }

    /// Runs for at least `budget` cycles (whole instructions; the overshoot is counted) or
    /// until the CPU halts. Returns the cycles consumed.
    pub fn run(&mut self, global: &mut [u8], budget: u64) -> u64 {
        let start = self.cycles;
        while self.state == RunState::Running && self.cycles - start < budget {
            let left = (budget - (self.cycles - start)).min(i32::MAX as u64) as i32;
            let mut bus = BoardBus {
                ram: &mut self.ram,
                global: &mut *global,
                io: &mut *self.io,
                now: self.cycles,
            };
            let r = self
                .cpu
                .run_for_cycles_with_hook(&mut bus, left, |_, bus, c| {
                    bus.now += c as u64;
                    m68k::CycleBatchControl::Continue
                });
            self.cycles += r.cycles.max(0) as u64;
            self.instructions += r.instructions as u64;
            self.take_surfaced(r.exit, global);
        }
        self.cycles - start
    }

    /// Executes one instruction (or exception entry). Returns its cycles.
    pub fn step(&mut self, global: &mut [u8]) -> u64 {
        if self.state != RunState::Running {
            return 0;
        }
        let before = self.cycles;
        let mut bus = BoardBus {
            ram: &mut self.ram,
            global: &mut *global,
            io: &mut *self.io,
            now: self.cycles,
        };
        let r = self.cpu.run_for_cycles(&mut bus, 1);
        self.cycles += r.cycles.max(0) as u64;
        self.instructions += r.instructions as u64;
        self.take_surfaced(r.exit, global);
        self.cycles - before
    }

    /// Takes, as the hardware would, a trap the core surfaced without taking.
    fn take_surfaced(&mut self, exit: CycleBatchExit, global: &mut [u8]) {
        let mut bus = BoardBus {
            ram: &mut self.ram,
            global,
            io: &mut *self.io,
            now: self.cycles,
        };
        let c = match exit {
            CycleBatchExit::BudgetExhausted | CycleBatchExit::BoundaryRequested => 0,
            CycleBatchExit::Stopped => {
                // Nothing raises interrupts on these boards, so STOP never wakes.
                self.state = RunState::Halted;
                0
            }
            CycleBatchExit::AlineTrap { .. } => self.cpu.take_aline_exception(&mut bus),
            CycleBatchExit::FlineTrap { .. } => self.cpu.take_fline_exception(&mut bus),
            CycleBatchExit::TrapInstruction { trap_num } => {
                self.cpu.take_trap_exception(&mut bus, trap_num)
            }
            CycleBatchExit::Breakpoint { .. } => self.cpu.take_bkpt_exception(&mut bus),
            CycleBatchExit::IllegalInstruction { .. } => self.cpu.take_illegal_exception(&mut bus),
        };
        self.cycles += c.max(0) as u64;
    }

    /// Calls the C-ABI function at `addr` with 32-bit `args` on the board's own stack and
    /// runs it until it returns (or `max_cycles` pass, or the CPU halts). Returns d0 and the
    /// cycles the call took. For unit tests that step one firmware function at a time.
    pub fn call(
        &mut self,
        global: &mut [u8],
        addr: u32,
        args: &[u32],
        max_cycles: u64,
    ) -> Option<(u32, u64)> {
        /// Return address: the last word of local RAM, never code.
        const SENTINEL: u32 = LOCAL_RAM_SIZE - 2;
        let sp0 = self.cpu.dar[15];
        let mut sp = sp0 - 64; // leave the board's own frame alone
        for &a in args.iter().rev() {
            sp -= 4;
            self.ram[sp as usize..sp as usize + 4].copy_from_slice(&a.to_be_bytes());
        }
        sp -= 4;
        self.ram[sp as usize..sp as usize + 4].copy_from_slice(&SENTINEL.to_be_bytes());
        let saved = (self.cpu.pc, self.cpu.dar);
        self.cpu.dar[15] = sp;
        self.cpu.pc = addr;
        let start = self.cycles;
        while self.cpu.pc != SENTINEL {
            if self.state != RunState::Running || self.cycles - start > max_cycles {
                return None;
            }
            self.step(global);
        }
        let d0 = self.cpu.dar[0];
        (self.cpu.pc, self.cpu.dar) = saved;
        Some((d0, self.cycles - start))
    }

    /// Microseconds of emulated time since reset.
    pub fn micros(&self) -> f64 {
        self.cycles as f64 * 1e6 / CPU_HZ as f64
    }
}
