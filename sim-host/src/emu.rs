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

use crate::boot::FunctionCycles;
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

/// A boxed device is a device: lets a wrapper (a meter) take any board's I/O as it is kept.
impl<T: Device + ?Sized> Device for Box<T> {
    fn read16(&mut self, off: u32, now: u64) -> Option<u16> {
        (**self).read16(off, now)
    }
    fn write16(&mut self, off: u32, val: u16, now: u64) -> bool {
        (**self).write16(off, val, now)
    }
}

/// What a meter of an image's busy time counted (`sensing_bench::SlotMeter` a strobe slot a
/// pass, `servo_bench::PassClock` a control pass): shared between the meter, which the
/// board's I/O owns, and the caller.
#[derive(Debug, Default)]
pub struct BusyStats {
    /// Cycles of the passes' work, without the waits for the timer.
    pub busy_cycles: std::sync::atomic::AtomicU64,
    /// Passes counted.
    pub passes: std::sync::atomic::AtomicU64,
    /// The longest pass counted, cycles.
    pub max_cycles: std::sync::atomic::AtomicU64,
}

impl BusyStats {
    /// Counts one pass of `cycles` busy cycles.
    pub fn add(&self, cycles: u64) {
        use std::sync::atomic::Ordering::Relaxed;
        self.busy_cycles.fetch_add(cycles, Relaxed);
        self.passes.fetch_add(1, Relaxed);
        self.max_cycles.fetch_max(cycles, Relaxed);
    }

    /// The longest pass counted so far, cycles.
    pub fn max(&self) -> u64 {
        self.max_cycles.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// (busy cycles, passes) so far.
    pub fn get(&self) -> (u64, u64) {
        use std::sync::atomic::Ordering::Relaxed;
        (self.busy_cycles.load(Relaxed), self.passes.load(Relaxed))
    }
}

/// For the meters' tests: a device that decodes every register and reads 0.
#[cfg(test)]
pub struct NullDevice;

#[cfg(test)]
impl Device for NullDevice {
    fn read16(&mut self, _off: u32, _now: u64) -> Option<u16> {
        Some(0)
    }
    fn write16(&mut self, _off: u32, _val: u16, _now: u64) -> bool {
        true
    }
}

/// The bus one emulated board sees while it runs.
pub struct BoardBus<'a> {
    /// Local RAM (1 MiB).
    pub ram: &'a mut [u8],
    /// Global RAM (8 MiB), shared.
    pub global: &'a mut [u8],
    /// Private I/O.
    pub io: &'a mut dyn Device,
    /// Cycle of the system clock at the start of the current instruction (what the devices
    /// see as the time).
    pub now: u64,
    /// Global-RAM address of the board's heartbeat: a long written there ends a main-loop
    /// pass (the shell's `end`), timed into `beats`.
    pub beat_addr: u32,
    /// Main-loop pass timing.
    pub beats: &'a mut LoopStats,
    /// The CPU's instruction cache.
    pub icache: &'a mut ICache,
}

/// Whether new boards model the instruction cache ([`ICache::model`]); `sim-host --icache`.
static MODEL_ICACHE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Sets whether boards created from now on model the 68020's instruction cache
/// ([`ICache`]) or take every instruction at the manual's cache-case time (the default).
pub fn set_icache_model(on: bool) {
    MODEL_ICACHE.store(on, std::sync::atomic::Ordering::Relaxed);
}

/// How the images' instructions are timed, for reports: the setting of
/// [`set_icache_model`].
pub fn timing_name() -> &'static str {
    if MODEL_ICACHE.load(std::sync::atomic::Ordering::Relaxed) {
        "modelled 256-byte instruction cache (--icache)"
    } else {
        "cache case for every instruction (without --icache)"
    }
}

/// The MC68020's on-chip instruction cache (User's Manual section 6): 64 long words,
/// direct-mapped by address bits 2-7, tagged by bits 8-31 and the function code's
/// supervisor bit, filled a long word at a time on a miss; enabled, frozen and cleared
/// through CACR (`EI`, `FI`, `CI`, `CEI` with CAAR). The core takes an instruction's
/// "cache case" time from the manual's tables when every word of it was fetched from the
/// cache, its "worst case" time otherwise. Without [`ICache::model`] the bus says "cached"
/// for every instruction (the crate's default, and every figure measured before
/// 2026-11-26's seventh session): as if all code ran from a cache of any size, an upper
/// bound on the speed (docs/performance.md).
#[derive(Clone, Debug)]
pub struct ICache {
    /// Model the cache; otherwise every instruction counts as fetched from it.
    pub model: bool,
    /// Tag (address bits 8-31, supervisor bit 0) plus 2 of each entry; 0: invalid.
    lines: [u32; 64],
    /// CACR.EI.
    enabled: bool,
    /// CACR.FI: hits are served, misses do not fill.
    frozen: bool,
    /// Every instruction-stream fetch of the current instruction hit.
    all_hit: bool,
    /// The last instruction-stream fetch hit.
    last_hit: bool,
    /// The CACR value last applied.
    cacr: u32,
    /// Fetches that hit and that missed since reset (a miss with the cache off counts).
    pub hits: u64,
    /// See `hits`.
    pub misses: u64,
}

impl Default for ICache {
    fn default() -> Self {
        Self {
            model: MODEL_ICACHE.load(std::sync::atomic::Ordering::Relaxed),
            lines: [0; 64],
            enabled: false,
            frozen: false,
            all_hit: false,
            last_hit: false,
            cacr: 0,
            hits: 0,
            misses: 0,
        }
    }
}

impl ICache {
    /// An instruction-stream fetch of the long word holding `a` (supervisor program space:
    /// the images run in supervisor mode).
    fn fetch(&mut self, a: u32) {
        let i = ((a >> 2) & 63) as usize;
        let tag = (a & !0xFF) | 2;
        let hit = self.enabled && self.lines[i] == tag;
        if self.enabled && !hit && !self.frozen {
            self.lines[i] = tag;
        }
        self.last_hit = hit;
        self.all_hit &= hit;
        if hit {
            self.hits += 1;
        } else {
            self.misses += 1;
        }
    }

    /// A write to CACR (`strobes`: its clear bits, CAAR for `CEI`).
    fn control(&mut self, cacr: u32, caar: u32, strobes: u32) {
        use m68k::core::cpu::{CACR_CEI, CACR_CI, CACR_EI, CACR_FI};
        self.cacr = cacr;
        self.enabled = cacr & CACR_EI != 0;
        self.frozen = cacr & CACR_FI != 0;
        if strobes & CACR_CI != 0 {
            self.lines = [0; 64];
        }
        if strobes & CACR_CEI != 0 {
            self.lines[((caar >> 2) & 63) as usize] = 0;
        }
    }
}

/// Where an emulated board's long main-loop passes go (`sim-host run --long-passes`): every
/// instruction charged to its function, a pass's charges kept when the pass (heartbeat to
/// heartbeat) took longer than `over_cycles`.
pub struct LongPasses {
    /// A pass is long above this many cycles.
    pub over_cycles: u64,
    /// The pass under way.
    pass: FunctionCycles,
    /// The long passes' charges, summed.
    pub long: FunctionCycles,
    /// Long passes seen.
    pub passes: u64,
    /// The longest pass's charges, and its cycles.
    pub longest: FunctionCycles,
    /// The longest pass's cycles (0 before one ends).
    pub longest_cycles: u64,
    /// Where the next instruction starts (the PC after the last one).
    next_pc: u32,
}

impl LongPasses {
    /// Nothing charged yet, to `image`'s functions.
    pub fn new(image: &Image, over_cycles: u64) -> Self {
        Self {
            over_cycles,
            pass: FunctionCycles::new(image),
            long: FunctionCycles::new(image),
            passes: 0,
            longest: FunctionCycles::new(image),
            longest_cycles: 0,
            next_pc: 0,
        }
    }

    /// Charges the instruction that just took `c` cycles and left the PC at `pc`; `beat`
    /// is the period it ended, when it wrote the heartbeat.
    fn charge(&mut self, pc: u32, c: u64, beat: Option<u64>) {
        self.pass.charge(self.next_pc, c);
        self.next_pc = pc;
        if let Some(period) = beat {
            if period > self.over_cycles {
                self.long.add(&self.pass);
                self.passes += 1;
            }
            if period > self.longest_cycles {
                self.longest.clear();
                self.longest.add(&self.pass);
                self.longest_cycles = period;
            }
            self.pass.clear();
        }
    }
}

/// Main-loop pass timing of an emulated board, from the system-clock cycles at which it
/// wrote its heartbeat: the loop period as the real board would run it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LoopStats {
    /// Cycle of the last heartbeat write.
    pub last_beat: Option<u64>,
    /// Periods measured (heartbeat to heartbeat).
    pub periods: u64,
    /// Shortest period (cycles).
    pub min_cycles: u64,
    /// Longest period (cycles).
    pub max_cycles: u64,
    /// Sum of the periods (cycles).
    pub sum_cycles: u64,
    /// Periods longer than a millisecond at [`CPU_HZ`] (the reflex's 1 kHz deadline
    /// missed).
    pub over_1ms: u64,
    /// The period the last heartbeat ended (0 for the first heartbeat, which ends none),
    /// until taken (by [`LongPasses`]).
    pub ended: Option<u64>,
}

impl LoopStats {
    fn beat(&mut self, now: u64) {
        self.ended = Some(0);
        if let Some(last) = self.last_beat {
            let p = now - last;
            self.ended = Some(p);
            if self.periods == 0 {
                self.min_cycles = p;
            }
            self.min_cycles = self.min_cycles.min(p);
            self.max_cycles = self.max_cycles.max(p);
            self.sum_cycles += p;
            self.over_1ms += (p > CPU_HZ / 1000) as u64;
            self.periods += 1;
        }
        self.last_beat = Some(now);
    }

    /// (min, mean, max) loop period in microseconds at [`CPU_HZ`]; `None` before two
    /// heartbeats.
    pub fn period_us(&self) -> Option<(f64, f64, f64)> {
        let us = |c: f64| c * 1e6 / CPU_HZ as f64;
        (self.periods > 0).then(|| {
            (
                us(self.min_cycles as f64),
                us(self.sum_cycles as f64 / self.periods as f64),
                us(self.max_cycles as f64),
            )
        })
    }
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
    fn try_read_immediate_word(&mut self, a: u32) -> Result<u16, BusFault> {
        self.icache.fetch(a);
        self.try_read_word(a)
    }
    fn try_read_immediate_long(&mut self, a: u32) -> Result<u32, BusFault> {
        self.icache.fetch(a);
        if a & 3 != 0 {
            self.icache.fetch(a.wrapping_add(2));
        }
        self.try_read_long(a)
    }
    fn read_immediate_word(&mut self, a: u32) -> u16 {
        self.try_read_immediate_word(a).unwrap_or(0xFFFF)
    }
    fn read_immediate_long(&mut self, a: u32) -> u32 {
        self.try_read_immediate_long(a).unwrap_or(0xFFFF_FFFF)
    }
    fn begin_instruction_fetches(&mut self) {
        self.icache.all_hit = true;
    }
    fn last_fetch_was_cached(&self) -> bool {
        self.icache.last_hit || !self.icache.model
    }
    fn instruction_fetches_were_cached(&self) -> bool {
        self.icache.all_hit || !self.icache.model
    }
    fn cache_control(&mut self, cacr: u32, caar: u32, strobes: u32) -> bool {
        self.icache.control(cacr, caar, strobes);
        true
    }
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
        if a == self.beat_addr {
            self.beats.beat(self.now);
        }
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
    /// Private I/O devices (a simulation can lend the board its own instead: [`Self::run_until`]).
    pub io: Box<dyn Device>,
    /// CPU cycles executed since reset.
    pub cycles: u64,
    /// Instructions executed since reset.
    pub instructions: u64,
    /// Whether it still runs.
    pub state: RunState,
    /// The system clock (cycles) at which this board left reset: the devices see
    /// `t0 + cycles` as the time.
    pub t0: u64,
    /// Main-loop pass timing (heartbeat writes).
    pub beats: LoopStats,
    /// The CPU's instruction cache.
    pub icache: ICache,
    /// The top of the stack (the image's `_stack_top`), if the image names it.
    pub stack_top: Option<u32>,
    /// The lowest stack pointer seen after an instruction since reset (the stack's
    /// high-water mark; local RAM is left as loaded, so nothing the firmware reads changes).
    pub lowest_sp: u32,
    /// Where the long main-loop passes go, when asked for ([`LongPasses`]).
    pub long_passes: Option<Box<LongPasses>>,
}

/// Why [`EmuBoard::run_until`] returned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// The board reached the cycle asked for.
    Reached,
    /// The CPU halted.
    Halted,
    /// The next instruction is at a breakpoint.
    Breakpoint,
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
            t0: 0,
            beats: LoopStats::default(),
            icache: ICache::default(),
            stack_top: image.symbol("_stack_top"),
            lowest_sp: u32::MAX,
            long_passes: None,
        };
        let mut bus = BoardBus {
            ram: &mut b.ram,
            global,
            io: &mut *b.io,
            now: 0,
            beat_addr: beat_addr(id),
            beats: &mut b.beats,
            icache: &mut b.icache,
        };
        b.cpu.reset(&mut bus);
        b.lowest_sp = b.cpu.dar[15];
        b
    }

    /// Runs for at least `budget` cycles (whole instructions; the overshoot is counted) or
    /// until the CPU halts. Returns the cycles consumed.
    pub fn run(&mut self, global: &mut [u8], budget: u64) -> u64 {
        let start = self.cycles;
        self.run_until(global, None, start + budget, &[]);
        self.cycles - start
    }

    /// Runs until the board's cycle count reaches `until` (whole instructions), the CPU
    /// halts, or the next instruction is at one of `breaks` (the instruction at the PC
    /// when called is executed even if it is one). `io` lends the board devices owned by
    /// a simulation instead of its own.
    pub fn run_until(
        &mut self,
        global: &mut [u8],
        mut io: Option<&mut dyn Device>,
        until: u64,
        breaks: &[u32],
    ) -> Stop {
        let beat_addr = beat_addr(self.id);
        while self.state == RunState::Running && self.cycles < until {
            let left = (until - self.cycles).min(i32::MAX as u64) as i32;
            let dev: &mut dyn Device = match io.as_deref_mut() {
                Some(d) => d,
                None => &mut *self.io,
            };
            let mut bus = BoardBus {
                ram: &mut self.ram,
                global: &mut *global,
                io: dev,
                now: self.t0 + self.cycles,
                beat_addr,
                beats: &mut self.beats,
                icache: &mut self.icache,
            };
            let sp = &mut self.lowest_sp;
            let mut long = self.long_passes.as_deref_mut();
            if let Some(l) = long.as_deref_mut() {
                l.next_pc = self.cpu.pc;
            }
            let r = self
                .cpu
                .run_for_cycles_with_hook(&mut bus, left, |cpu, bus, c| {
                    bus.now += c as u64;
                    if let Some(l) = long.as_deref_mut() {
                        l.charge(cpu.pc, c as u64, bus.beats.ended.take());
                    }
                    // A MOVEC to CACR: this entry point leaves the cache control to the
                    // host, which applies it before the next instruction's fetches.
                    if cpu.cacr != bus.icache.cacr || cpu.cacr_pending_ops != 0 {
                        bus.icache.control(cpu.cacr, cpu.caar, cpu.cacr_pending_ops);
                        cpu.cacr_pending_ops = 0;
                    }
                    *sp = (*sp).min(cpu.dar[15]);
                    if breaks.contains(&cpu.pc) {
                        m68k::CycleBatchControl::Return
                    } else {
                        m68k::CycleBatchControl::Continue
                    }
                });
            self.cycles += r.cycles.max(0) as u64;
            self.instructions += r.instructions as u64;
            bus.now = self.t0 + self.cycles;
            let (c, halted) = take_surfaced(&mut self.cpu, &mut bus, r.exit);
            self.cycles += c;
            if halted {
                self.state = RunState::Halted;
            }
            if breaks.contains(&self.cpu.pc) && self.cycles < until {
                return Stop::Breakpoint;
            }
        }
        if self.state == RunState::Halted {
            Stop::Halted
        } else {
            Stop::Reached
        }
    }

    /// Executes one instruction (or exception entry). Returns its cycles.
    pub fn step(&mut self, global: &mut [u8]) -> u64 {
        self.step_with(global, None)
    }

    /// [`Self::step`] with devices lent by a simulation (see [`Self::run_until`]).
    pub fn step_with(&mut self, global: &mut [u8], io: Option<&mut dyn Device>) -> u64 {
        let before = self.cycles;
        // A budget of one cycle runs exactly one whole instruction (or exception entry).
        self.run_until(global, io, before + 1, &[]);
        self.cycles - before
    }

    /// The deepest the stack has reached since reset, in bytes below `_stack_top` (the
    /// lowest stack pointer after any instruction; an exception frame counts), if the
    /// image names its stack top.
    pub fn stack_high_water(&self) -> Option<u32> {
        Some(self.stack_top?.saturating_sub(self.lowest_sp))
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

/// The global-RAM address of `id`'s heartbeat, as the board's CPU addresses it.
fn beat_addr(id: BoardId) -> u32 {
    GLOBAL_RAM_BASE + vme_map::BoardSlot::of(id).heartbeat()
}

/// Takes, as the hardware would, a trap the core surfaced without taking. Returns the
/// cycles of the exception entry and whether the CPU halted.
fn take_surfaced(cpu: &mut CpuCore, bus: &mut BoardBus, exit: CycleBatchExit) -> (u64, bool) {
    let c = match exit {
        CycleBatchExit::BudgetExhausted | CycleBatchExit::BoundaryRequested => 0,
        // Nothing raises interrupts on these boards, so STOP never wakes.
        CycleBatchExit::Stopped => return (0, true),
        CycleBatchExit::AlineTrap { .. } => cpu.take_aline_exception(bus),
        CycleBatchExit::FlineTrap { .. } => cpu.take_fline_exception(bus),
        CycleBatchExit::TrapInstruction { trap_num } => cpu.take_trap_exception(bus, trap_num),
        CycleBatchExit::Breakpoint { .. } => cpu.take_bkpt_exception(bus),
        CycleBatchExit::IllegalInstruction { .. } => cpu.take_illegal_exception(bus),
    };
    (c.max(0) as u64, false)
}

#[cfg(test)]
mod long_pass_tests {
    use super::*;
    use crate::image::{Image, Segment};

    /// A main loop at 0x400 whose passes alternate short (`quick`: 4 DBRA turns, then the
    /// heartbeat) and long (`slow`: 128 turns, then the heartbeat).
    fn alternating() -> Image {
        let mut code = vec![0u8; 0x400];
        code[0..4].copy_from_slice(&0x8000u32.to_be_bytes());
        code[4..8].copy_from_slice(&0x400u32.to_be_bytes());
        let beat = beat_addr(BoardId::Reflex);
        let (hi, lo) = ((beat >> 16) as u16, beat as u16);
        let words: [u16; 15] = [
            0x7203, // 0x400 quick: moveq #3, d1
            0x51C9, // dbra d1, *
            0xFFFE, 0x23C0, // move.l d0, (beat).l
            hi, lo, 0x727F, // 0x40c slow: moveq #127, d1
            0x51C9, // dbra d1, *
            0xFFFE, 0x23C0, // move.l d0, (beat).l
            hi, lo, 0x60EC, // bra.s quick (0x418 + 2 - 0x14)
            0x4E71, // nop
            0x4E71,
        ];
        for w in words {
            code.extend_from_slice(&w.to_be_bytes());
        }
        Image {
            path: "long-pass-test".into(),
            segments: vec![Segment {
                addr: 0,
                data: code,
            }],
            sizes: None,
            symbols: vec![("quick".into(), 0x400), ("slow".into(), 0x40c)],
        }
    }

    /// Only the passes above the threshold are summed, each instruction charged to the
    /// function it lies in; the longest pass is kept whole.
    #[test]
    fn only_the_long_passes_are_charged() {
        let image = alternating();
        let mut global = vec![0u8; GLOBAL_RAM_SIZE as usize];
        let mut b = EmuBoard::new(BoardId::Reflex, &image, Box::new(NullDevice), &mut global);
        b.long_passes = Some(Box::new(LongPasses::new(&image, 300)));
        b.run(&mut global, 40_000);
        let l = b.long_passes.as_deref().expect("kept");
        let periods = b.beats.periods;
        assert!(periods > 40, "{periods} passes");
        // Every other period is the slow one.
        assert!(
            l.passes.abs_diff(periods / 2) <= 1,
            "{} long of {periods}",
            l.passes
        );
        let top = l.long.top();
        assert_eq!(
            top.len(),
            1,
            "only `slow`'s code runs in a long pass: {top:?}"
        );
        assert_eq!(top[0].0, "slow");
        // 128 DBRA turns at 6-10 cycles, and what runs around them.
        let per = top[0].1 / l.passes;
        assert!((700..1_500).contains(&per), "{per} cycles a long pass");
        assert_eq!(l.longest.top()[0].1, l.longest_cycles);
        assert!(l.longest_cycles >= per && l.longest_cycles < per + 50);
    }
}

#[cfg(test)]
mod icache_tests {
    use super::*;
    use crate::image::{Image, Segment};

    /// A program at 0x400 (vectors: stack 0x8000, PC 0x400): `moveq #cacr, d0;
    /// movec d0, cacr; moveq #99, d1; loop: dbra d1, loop; stop #0x2700`.
    fn program(cacr: u8) -> Image {
        let mut code = vec![0u8; 0x400];
        code[0..4].copy_from_slice(&0x8000u32.to_be_bytes());
        code[4..8].copy_from_slice(&0x400u32.to_be_bytes());
        let words: [u16; 8] = [
            0x7000 | cacr as u16, // moveq #cacr, d0
            0x4E7B,               // movec d0, cacr
            0x0002,
            0x7263, // moveq #99, d1
            0x51C9, // dbra d1, *
            0xFFFE,
            0x4E72, // stop #0x2700
            0x2700,
        ];
        for w in words {
            code.extend_from_slice(&w.to_be_bytes());
        }
        Image {
            path: "icache-test".into(),
            segments: vec![Segment {
                addr: 0,
                data: code,
            }],
            sizes: None,
            symbols: vec![],
        }
    }

    /// Runs the program to its STOP, the cache modelled or not: (cycles, cache hits,
    /// misses).
    fn run_as(cacr: u8, model: bool) -> (u64, u64, u64) {
        let mut global = vec![0u8; 64];
        let mut b = EmuBoard::new(
            BoardId::Servo,
            &program(cacr),
            Box::new(NullDevice),
            &mut global,
        );
        b.icache.model = model;
        b.run(&mut global, 100_000);
        assert_eq!(b.state, RunState::Halted, "the program ends in STOP");
        (b.cycles, b.icache.hits, b.icache.misses)
    }

    fn run(cacr: u8) -> (u64, u64, u64) {
        run_as(cacr, true)
    }

    /// With the cache enabled (CACR CI | EI) the loop runs from it after its first pass, at
    /// the manual's cache-case times; left off (the reset state) every fetch misses and
    /// every instruction takes its worst-case time; frozen after a clear, nothing fills.
    #[test]
    fn the_instruction_cache_serves_a_loop_once_enabled() {
        let (on, hits_on, misses_on) = run(9);
        let (off, hits_off, misses_off) = run(0);
        let (frozen, hits_frozen, _) = run(0b1011);
        assert_eq!(hits_off, 0);
        assert_eq!(hits_frozen, 0, "a frozen, cleared cache never fills");
        // The 100 passes of the loop hit (two words, one long word), all but the first.
        assert!(
            hits_on >= 99 && misses_on <= 8,
            "{hits_on} hits, {misses_on} misses"
        );
        assert!(misses_off >= 100);
        // DBRA taken: 6-7 cycles cache case, 9-10 worst case (MC68020 UM table 8-9).
        assert!(off > on + 200, "cache on {on} cycles, off {off}");
        assert_eq!(frozen, off, "frozen and empty is as slow as off");
        // Not modelled (the default): every instruction at its cache-case time, the cache
        // on or off.
        let plain = run_as(0, false).0;
        assert!(
            plain < on && on - plain < 20,
            "{plain} against {on}: only the first misses"
        );
        assert_eq!(run_as(9, false).0, run_as(0, false).0);
    }
}
