//! Powering the system up in image mode (design.md sections 4 and 7): the host clears
//! global RAM and writes its header, every board's image is loaded and the boards leave
//! reset together; then they run asynchronously, each on its own emulated 68020, meeting
//! only in global RAM.

use crate::emu::{EmuBoard, RunState, CPU_HZ};
use crate::image::{Image, ImageError};
use std::path::{Path, PathBuf};
use vme_map::log::{read_entries, Kind};
use vme_map::{ArrayBus, BoardId, BoardSlot, FaultRecord, GlobalBus, StatusWord, GLOBAL_RAM_SIZE};

/// Where `cargo xtask images` writes the images.
pub fn default_images_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/images")
}

/// The image file a board runs: the three C-space boards share one image and tell
/// themselves apart by their board-ID switch.
pub fn image_name(board: BoardId) -> &'static str {
    match board {
        BoardId::Cspace0 | BoardId::Cspace1 | BoardId::Cspace2 => "cspace",
        b => b.name(),
    }
}

/// Parses a board name as used on the command line (`cspace` means `cspace0`).
pub fn parse_board(name: &str) -> Option<BoardId> {
    if name == "cspace" {
        return Some(BoardId::Cspace0);
    }
    BoardId::ALL.into_iter().find(|b| b.name() == name)
}

/// The five boards of the standard system (one C-space board).
pub const FIVE: [BoardId; 5] = [
    BoardId::Sensing,
    BoardId::Cspace0,
    BoardId::Servo,
    BoardId::Reflex,
    BoardId::Planner,
];

/// Cycles each board runs before the next takes its turn: 100 us at 16.7 MHz. The boards
/// are asynchronous; this only bounds how far apart their clocks drift.
pub const SLICE_CYCLES: u64 = 1670;

/// The boards in image mode and the global RAM they share.
pub struct System {
    /// Global RAM, 8 MiB.
    pub global: Vec<u8>,
    /// The boards, in the order given.
    pub boards: Vec<EmuBoard>,
    /// The system clock in CPU cycles since power-up: every board has run at least this far.
    pub now: u64,
}

impl System {
    /// Loads `<dir>/<image>.elf` for each board, writes the global RAM header and the
    /// sensing calibration table, and resets every board.
    pub fn power_up(dir: &Path, boards: &[BoardId]) -> Result<System, ImageError> {
        let mut global = vec![0u8; GLOBAL_RAM_SIZE as usize];
        vme_map::init_header(&mut ArrayBus::new(&mut global));
        // The host downloads the sensing board's calibration table, as at every power-up
        // (here the optical model's; `sim-host bench sensing` runs the scan).
        let camera = crate::optics::Camera::new(crate::optics::OpticsConfig::default(), 1);
        let table = crate::sensing_cal::model_table(&camera);
        crate::sensing_cal::write_table(&mut ArrayBus::new(&mut global), &table, 1);
        let mut out = Vec::new();
        for &b in boards {
            let image = Image::load(&dir.join(format!("{}.elf", image_name(b))))?;
            out.push(EmuBoard::new(
                b,
                &image,
                crate::devices::standalone(b),
                &mut global,
            ));
        }
        Ok(System {
            global,
            boards: out,
            now: 0,
        })
    }

    /// Global RAM as a [`GlobalBus`], as the host reads and writes it.
    pub fn bus(&mut self) -> ArrayBus<'_> {
        ArrayBus::new(&mut self.global)
    }

    /// Runs every board for `cycles` CPU cycles, interleaved in slices.
    pub fn run_cycles(&mut self, cycles: u64) {
        let end = self.now + cycles;
        while self.now < end {
            let target = (self.now + SLICE_CYCLES).min(end);
            for b in &mut self.boards {
                if b.cycles < target {
                    b.run(&mut self.global, target - b.cycles);
                }
            }
            self.now = target;
        }
    }

    /// Runs every board for `ms` milliseconds of emulated time.
    pub fn run_ms(&mut self, ms: f64) {
        self.run_cycles((ms * CPU_HZ as f64 / 1000.0) as u64);
    }

    /// Steps board `i` alone, one instruction at a time, until its first heartbeat (within
    /// one second of emulated time); returns its cycle count then, `None` if it never beat.
    pub fn run_to_first_heartbeat(&mut self, i: usize) -> Option<u64> {
        let off = BoardSlot::of(self.boards[i].id).heartbeat();
        let b = &mut self.boards[i];
        while b.cycles < CPU_HZ && b.state == RunState::Running {
            b.step(&mut self.global);
            if ArrayBus::new(&mut self.global).read_u32(off) != 0 {
                return Some(b.cycles);
            }
        }
        None
    }

    /// The board's heartbeat.
    pub fn heartbeat(&mut self, id: BoardId) -> u32 {
        self.bus().read_u32(BoardSlot::of(id).heartbeat())
    }

    /// The board's status word.
    pub fn status(&mut self, id: BoardId) -> StatusWord {
        BoardSlot::of(id).status_word(&mut self.bus())
    }

    /// The board's last fault record, if it has recorded one.
    pub fn fault(&mut self, id: BoardId) -> Option<FaultRecord> {
        let st = self.status(id);
        if st.faults() == 0 {
            return None;
        }
        BoardSlot::of(id)
            .fault()
            .read(&mut self.bus())
            .ok()
            .map(|(r, _)| r)
    }

    /// The text of the board's log ring, entries joined, one line per message.
    pub fn log_text(&mut self, id: BoardId) -> String {
        let mut out = String::new();
        read_entries(&mut self.bus(), id, 0, &mut |e| match e.kind {
            Kind::Text => out.push_str(&String::from_utf8_lossy(&e.payload[..e.len])),
            Kind::TextEnd => {
                out.push_str(&String::from_utf8_lossy(&e.payload[..e.len]));
                out.push('\n');
            }
            Kind::Event => out.push_str(&format!("event {:#x}\n", e.arg)),
        });
        out
    }

    /// Publishes a host command (the host is the command record's only writer).
    pub fn host_command(&mut self, command: u32, board: BoardId) {
        vme_map::post_host_command(&mut self.bus(), command, board);
    }

    /// The board with identity `id`.
    pub fn board(&mut self, id: BoardId) -> Option<&mut EmuBoard> {
        self.boards.iter_mut().find(|b| b.id == id)
    }
}

/// What `sim-host boot` reports for one board.
#[derive(Clone, Debug)]
pub struct BootReport {
    /// The board.
    pub board: BoardId,
    /// Cycles from reset to the first heartbeat (`None` if it never beat).
    pub cycles_to_first_heartbeat: Option<u64>,
    /// Heartbeat at the end of the run.
    pub heartbeat: u32,
    /// Main-loop passes per second of emulated time after the first heartbeat.
    pub loops_per_s: f64,
    /// Status at the end.
    pub status: StatusWord,
    /// Whether the CPU still runs.
    pub running: bool,
}

/// Boots `boards` from the images in `dir`, measures each one's cycles from reset to its
/// first heartbeat, then runs the whole system for `run_ms` and reports.
pub fn boot(dir: &Path, boards: &[BoardId], run_ms: f64) -> Result<Vec<BootReport>, ImageError> {
    let mut sys = System::power_up(dir, boards)?;
    let first: Vec<Option<u64>> = (0..sys.boards.len())
        .map(|i| sys.run_to_first_heartbeat(i))
        .collect();
    // Bring every board to the same clock, then run together.
    let start = sys.boards.iter().map(|b| b.cycles).max().unwrap_or(0);
    sys.run_cycles(start);
    let hb0: Vec<u32> = boards.iter().map(|&b| sys.heartbeat(b)).collect();
    sys.run_ms(run_ms);
    let mut out = Vec::new();
    for (i, &b) in boards.iter().enumerate() {
        let hb = sys.heartbeat(b);
        let status = sys.status(b);
        out.push(BootReport {
            board: b,
            cycles_to_first_heartbeat: first[i],
            heartbeat: hb,
            loops_per_s: (hb.wrapping_sub(hb0[i])) as f64 / (run_ms / 1000.0),
            status,
            running: sys.boards[i].state == RunState::Running,
        });
    }
    Ok(out)
}

/// Main-loop passes per heartbeat: one for every board but the sensing board, which beats
/// once per strobe frame of [`board_sensing::SLOTS_PER_BEAT`] slots. Loop periods and rates
/// measured from heartbeats are per this many passes.
pub fn passes_per_beat(board: BoardId) -> u32 {
    match board {
        BoardId::Sensing => board_sensing::SLOTS_PER_BEAT,
        _ => 1,
    }
}

/// Where one board's CPU time goes: cycles per function of its image.
#[derive(Clone, Debug, PartialEq)]
pub struct Profile {
    /// Emulated cycles profiled.
    pub cycles: u64,
    /// Main-loop passes (heartbeats) in that time.
    pub loops: u64,
    /// (function, cycles spent in it, not counting its callees), most first.
    pub functions: Vec<(String, u64)>,
    /// (instruction address, cycles spent on it, times executed, its function's short
    /// name), most cycles first: for reading beside `m68k-linux-gnu-objdump -d` of the image.
    pub addresses: Vec<(u32, u64, u64, String)>,
    /// The sensing board's (busy cycles, strobe slots) in the profiled time
    /// (`sensing_bench::SlotMeter`), or the servo's (busy cycles, passes)
    /// (`servo_bench::PassClock`): their work without the wait for the timer.
    pub busy: Option<(u64, u64)>,
}

/// What `profile` publishes to the servo board as the reflex's subgoal.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ServoFeed {
    /// The subgoal's angles, urad.
    pub goal_urad: [i32; 2],
    /// Milliseconds into the profile after which the subgoal's cycle stops changing.
    pub freeze_after_ms: Option<f64>,
}

/// Quarter-milliseconds of host feeds before `profile` starts counting.
const WARM_UP_QUARTERS: u32 = 800;

/// Boots `board` alone (the sensing board with eight beacons in view, run 0.6 s first to
/// finish its table check), waits for its first heartbeat, then executes `ms` milliseconds of
/// emulated time one instruction at a time, charging each instruction's cycles to the
/// function (nearest symbol at or below the PC) it belongs to.
///
/// The servo board gets what it gets in the running system: a reflex subgoal (`subgoal`; the
/// arm's resting angles, 0 and 0, keep it at rest) published about every 0.25 ms (not in
/// step with the board's loop) with a new cycle,
/// from power-up on (without it every pass is a hold waiting for a first subgoal); with
/// `subgoal.freeze_after_ms`, the cycle stops changing that long into the profile, as when
/// the reflex dies: 20 ms later the servo holds.
///
/// `resting` (the sensing board): the host also publishes a servo state every 0.25 ms with
/// the arm resting, its tip at the tip's lit beacon (`sensing_bench::RestingServo`), from
/// power-up on: the board learns the drift from the tip and corrects every beacon.
pub fn profile(
    dir: &Path,
    board: BoardId,
    ms: f64,
    resting: bool,
    subgoal: ServoFeed,
) -> Result<Profile, ImageError> {
    let image = Image::load(&dir.join(format!("{}.elf", image_name(board))))?;
    let mut per = FunctionCycles::new(&image);
    let mut sys = System::power_up(dir, &[board])?;
    let mut meter = None;
    let mut servo_feed = crate::sensing_bench::RestingServo::default();
    if board == BoardId::Sensing {
        // Eight beacons in view, and past the calibration table's check: the steady state.
        let (io, m) = crate::sensing_bench::metered_lit_camera(1);
        sys.boards[0].io = io;
        meter = Some(m);
        // 1.2 s with a resting arm: the drift reference starts learning after 0.53 s of
        // rest and a full filter window.
        let ms = if resting { 1200.0 } else { 600.0 };
        crate::sensing_bench::run_fed(&mut sys, ms, resting.then_some(&mut servo_feed));
    }
    if board == BoardId::Servo {
        // The servo's busy cycles a pass, beside its paced loop rate.
        let io = crate::devices::ServoIo::new([0.0; 2]);
        meter = Some(io.passes.stats.clone());
        sys.boards[0].io = Box::new(io);
    }
    // What the host publishes every 0.25 ms for the board to find fresh. The reflex: a
    // servo, positions and a map (the free-space case at rest of `sim-host bench reflex`).
    // The planner: an arm at rest, the wand in view, a reflex (planner_bench's records).
    // The servo: a reflex subgoal with a new cycle (from 1: cycle 0 is "never published").
    // The resting sensing board: the servo state of the resting arm.
    let mut feed = (board == BoardId::Reflex).then(crate::reflex_bench::Feed::at_rest);
    let planner = board == BoardId::Planner;
    let servo = board == BoardId::Servo;
    let warm_up = feed.is_some() || planner || servo;
    let mut k = 0;
    // The feed's count at which the subgoal's cycle stops changing (the warm-up's 800
    // quarter-milliseconds, then the profile's own).
    let freeze_k = subgoal
        .freeze_after_ms
        .map_or(u32::MAX, |ms| WARM_UP_QUARTERS + (ms * 4.0) as u32);
    let mut feed_quarter = |g: &mut [u8]| {
        if resting {
            servo_feed.publish(&mut ArrayBus::new(g));
        }
        if let Some(f) = feed.as_mut() {
            f.apply(&mut ArrayBus::new(g));
        }
        if planner {
            crate::planner_bench::feed(g, [-1.0, 0.5], k, 0, (200, 250));
        }
        if servo {
            let rec = vme_map::records::ReflexSubgoal {
                goal1_urad: subgoal.goal_urad[0],
                goal2_urad: subgoal.goal_urad[1],
                flags: 0,
                cycle: k.min(freeze_k) + 1,
            };
            vme_map::REFLEX_SUBGOAL.publish(&mut ArrayBus::new(g), &rec);
        }
        k += 1;
    };
    let quarter_ms = CPU_HZ / 4000;
    if warm_up {
        for _ in 0..WARM_UP_QUARTERS {
            feed_quarter(&mut sys.global);
            sys.run_cycles(quarter_ms);
        }
    }
    sys.run_to_first_heartbeat(0);
    let hb0 = sys.heartbeat(board);
    let busy0 = meter.as_ref().map(|m| m.get());
    let b = &mut sys.boards[0];
    let start = b.cycles;
    let end = start + (ms * CPU_HZ as f64 / 1000.0) as u64;
    let mut next_feed = start + quarter_ms;
    // Feeds at fixed instants can lock onto the few cycles in which the servo board reads
    // the subgoal record when its paced pass is a multiple of the feed period (at 2,000 Hz
    // exactly two, 8,350 cycles: 55% of the passes at rest read the record torn in one
    // build). The reflex publishes on its own clock: the intervals between the servo's
    // feeds vary by up to +-1/8 ms about 0.25 ms (a fixed LCG: the same every run).
    let mut lcg: u32 = 1;
    let mut wander = || {
        lcg = lcg.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (lcg >> 8) as u64 % (quarter_ms / 4)
    };
    let mut at: std::collections::HashMap<u32, (u64, u64)> = Default::default();
    while b.cycles < end && b.state == RunState::Running {
        let pc = b.cpu.pc;
        let c = b.step(&mut sys.global);
        per.charge(pc, c);
        let e = at.entry(pc).or_default();
        e.0 += c;
        e.1 += 1;
        if b.cycles >= next_feed {
            next_feed += quarter_ms;
            feed_quarter(&mut sys.global);
            if servo {
                // The next interval: 0.25 ms, -1/8 ms to +1/8 ms.
                next_feed = next_feed + wander() - quarter_ms / 8;
            }
        }
    }
    let cycles = b.cycles - start;
    let loops = sys.heartbeat(board).wrapping_sub(hb0) as u64;
    let functions = per.top();
    let mut addresses: Vec<(u32, u64, u64, String)> = at
        .into_iter()
        .map(|(a, (c, n))| (a, c, n, demangle_short(per.name_of(a))))
        .collect();
    addresses.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    Ok(Profile {
        cycles,
        loops,
        functions,
        addresses,
        busy: meter.zip(busy0).map(|(m, b0)| {
            let b1 = m.get();
            (b1.0 - b0.0, b1.1 - b0.1)
        }),
    })
}

/// Cycles charged to an image's functions: each instruction's to the nearest symbol at or
/// below its PC (`sim-host profile`, and the worst passes of `sim-host bench planner`).
pub struct FunctionCycles {
    syms: Vec<(u32, String)>,
    cycles: Vec<u64>,
    /// Instructions executed at each function's first address: its calls (and any branch
    /// back to its start).
    entries: Vec<u64>,
}

impl FunctionCycles {
    /// Nothing charged yet, to `image`'s functions.
    pub fn new(image: &Image) -> Self {
        let mut syms: Vec<(u32, String)> = image
            .symbols
            .iter()
            .filter(|(n, _)| !n.is_empty() && !n.starts_with('.'))
            .map(|(n, a)| (*a, n.clone()))
            .collect();
        syms.sort();
        let cycles = vec![0; syms.len() + 1];
        let entries = vec![0; syms.len() + 1];
        Self {
            syms,
            cycles,
            entries,
        }
    }

    /// Index into `cycles` of the function holding `pc` (0: before the first symbol).
    fn slot(&self, pc: u32) -> usize {
        self.syms.partition_point(|(a, _)| *a <= pc)
    }

    /// The name of slot `i` (`?` before the first symbol).
    fn name(&self, i: usize) -> &str {
        match i {
            0 => "?",
            i => &self.syms[i - 1].1,
        }
    }

    /// Charges `c` cycles to the function holding `pc`.
    pub fn charge(&mut self, pc: u32, c: u64) {
        let i = self.slot(pc);
        self.cycles[i] += c;
        if i > 0 && self.syms[i - 1].0 == pc {
            self.entries[i] += 1;
        }
    }

    /// The name of the function holding `pc` (`?` before the first symbol).
    pub fn name_of(&self, pc: u32) -> &str {
        self.name(self.slot(pc))
    }

    /// The `top` costliest functions with short names ([`demangle_short`]), their cycles
    /// and calls divided by `passes` (per pass of a profile over that many).
    pub fn costliest(&self, top: usize, passes: f64) -> Vec<(String, f64, f64)> {
        self.top_calls()
            .into_iter()
            .take(top)
            .map(|(n, c, e)| (demangle_short(&n), c as f64 / passes, e as f64 / passes))
            .collect()
    }

    /// Adds `other`'s charges (to the same image's functions) to these.
    pub fn add(&mut self, other: &FunctionCycles) {
        for (a, b) in self.cycles.iter_mut().zip(&other.cycles) {
            *a += b;
        }
        for (a, b) in self.entries.iter_mut().zip(&other.entries) {
            *a += b;
        }
    }

    /// Forgets every charge.
    pub fn clear(&mut self) {
        self.cycles.iter_mut().for_each(|c| *c = 0);
        self.entries.iter_mut().for_each(|c| *c = 0);
    }

    /// The functions charged, costliest first (`?` before the first symbol).
    pub fn top(&self) -> Vec<(String, u64)> {
        let mut v: Vec<(String, u64)> = self
            .cycles
            .iter()
            .enumerate()
            .filter(|(_, &c)| c > 0)
            .map(|(i, &c)| (self.name(i).to_string(), c))
            .collect();
        v.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
        v
    }

    /// As [`FunctionCycles::top`], each function with its entries (instructions executed at
    /// its first address: its calls).
    pub fn top_calls(&self) -> Vec<(String, u64, u64)> {
        let mut v: Vec<(String, u64, u64)> = self
            .cycles
            .iter()
            .enumerate()
            .filter(|(_, &c)| c > 0)
            .map(|(i, &c)| (self.name(i).to_string(), c, self.entries[i]))
            .collect();
        v.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
        v
    }
}

/// A symbol's demangled path without its crate hashes and generic arguments, its last two
/// segments (`Fill::work`).
pub fn demangle_short(n: &str) -> String {
    let mut full = format!("{:#}", rustc_demangle::demangle(n));
    // `<planner::fill::Fill>::work`: the type in brackets is the path, not a generic.
    if let Some(rest) = full.strip_prefix('<') {
        if let Some(end) = rest.find(">::") {
            let ty = rest[..end].split(" as ").next().unwrap_or("").to_string();
            full = format!("{ty}::{}", &rest[end + 3..]);
        }
    }
    // Drop generic arguments, then keep the last two path segments.
    let mut plain = String::new();
    let mut depth = 0;
    for ch in full.chars() {
        match ch {
            '<' => depth += 1,
            '>' => depth -= 1,
            _ if depth == 0 => plain.push(ch),
            _ => {}
        }
    }
    let parts: Vec<&str> = plain.split("::").filter(|p| !p.is_empty()).collect();
    parts[parts.len().saturating_sub(2)..].join("::")
}
