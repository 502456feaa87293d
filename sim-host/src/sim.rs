//! The deterministic simulation, native or image mode (design.md sections 3, 5 and 7).
//!
//! In native mode the boards' own code (each board crate's I/O shell and logic) runs on the
//! host at each board's rate and seeded phase, asynchronously. In image mode each board is
//! its real image on an emulated 68020 ([`crate::emu`]) advanced by cycles at 16.7 MHz
//! against the plant's clock, leaving reset at a seeded skew of up to
//! [`RESET_SKEW_US`]; the boards are interleaved in slices of [`IMAGE_SLICE_CYCLES`] so that
//! no writer stalls mid-record for longer than the hardware would, and each runs as fast as
//! its code lets it (its loop period is measured, not set). Boards meet only in a simulated global
//! RAM laid out by `vme-map`, the same bytes the images see. Their private I/O goes through
//! the same register protocol and the same device models as image mode. The plant integrates
//! at a fixed step, and the collision oracle checks the arm's true outline against every
//! obstacle at every step.
//!
//! Order within one plant step `[t, t + dt)`: the devices see the plant's state at `t` (the
//! encoders extrapolate it to each access); every board due before `t + dt` runs, in order of
//! its activation time (ties by board index); then the plant advances with the amplifier
//! commands the DACs hold (sampled every `dt`, well inside the amplifier's 106 us lag); then
//! the collision oracle runs. A seed fixes every random choice, so a run is bit-identical.

use crate::devices::{IdOnly, MotorSample, SensingIo, ServoIo};
use crate::emu::{Device, EmuBoard, RunState, Stop, CPU_HZ};
use crate::image::{Image, ImageError};
use crate::optics::{Camera, OpticsConfig};
use crate::plant::{Plant, DEFAULT_DT_S};
use arm::geometry::{Disk, Pose};
use regs::IoBus;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;
use vme_map::{ArrayBus, BoardId, FaultCode, FaultRecord, GlobalBus, GLOBAL_RAM_SIZE};

/// SplitMix64: a small, fast, seedable generator; the simulation's only source of randomness.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator for `seed`.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// How an obstacle moves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Motion {
    /// It stays where it is.
    Static,
    /// Constant velocity.
    Line {
        /// Velocity x.
        vx_m_s: f64,
        /// Velocity y.
        vy_m_s: f64,
    },
    /// Around a circle through its start point, centred at (`cx_m`, `cy_m`).
    Circle {
        /// Centre x.
        cx_m: f64,
        /// Centre y.
        cy_m: f64,
        /// Seconds per revolution (negative: clockwise).
        period_s: f64,
    },
}

/// The beacon (object-table slot) of a scenario's obstacle `k`: the five obstacle beacons,
/// then the instructional robot's.
pub fn obstacle_beacon(k: usize) -> usize {
    use vme_map::records::beacon_index::{INSTRUCTIONAL, OBSTACLE0};
    if k < 5 {
        OBSTACLE0 + k
    } else {
        INSTRUCTIONAL
    }
}

/// A disk obstacle with its scripted motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Obstacle {
    /// Where it is at t = 0 (and its radius).
    pub start: Disk,
    /// How it moves.
    pub motion: Motion,
}

impl Obstacle {
    /// Where it is at `t_s`.
    pub fn at(&self, t_s: f64) -> Disk {
        let d = self.start;
        match self.motion {
            Motion::Static => d,
            Motion::Line { vx_m_s, vy_m_s } => Disk {
                x_m: d.x_m + vx_m_s * t_s,
                y_m: d.y_m + vy_m_s * t_s,
                ..d
            },
            Motion::Circle {
                cx_m,
                cy_m,
                period_s,
            } => {
                let (dx, dy) = (d.x_m - cx_m, d.y_m - cy_m);
                let a = std::f64::consts::TAU * t_s / period_s;
                let (s, c) = a.sin_cos();
                Disk {
                    x_m: cx_m + dx * c - dy * s,
                    y_m: cy_m + dx * s + dy * c,
                    ..d
                }
            }
        }
    }
}

/// The wand (the goal) along a piecewise-linear path of (t, x, y) points.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WandPath {
    /// Points in time order; before the first and after the last the wand rests.
    pub points: Vec<(f64, f64, f64)>,
}

impl WandPath {
    /// Where the wand is at `t_s`, if there is a wand.
    pub fn at(&self, t_s: f64) -> Option<(f64, f64)> {
        let p = &self.points;
        let first = p.first()?;
        if t_s <= first.0 {
            return Some((first.1, first.2));
        }
        for w in p.windows(2) {
            let (a, b) = (w[0], w[1]);
            if t_s <= b.0 {
                let f = if b.0 > a.0 {
                    (t_s - a.0) / (b.0 - a.0)
                } else {
                    1.0
                };
                return Some((a.1 + f * (b.1 - a.1), a.2 + f * (b.2 - a.2)));
            }
        }
        let last = p.last()?;
        Some((last.1, last.2))
    }
}

/// The board rates of the standard system, native mode: main-loop period per board.
pub const DEFAULT_PERIODS_S: [(BoardId, f64); 5] = [
    (BoardId::Sensing, 250e-6), // one beacon per pass: 8 beacons at 500 Hz (thesis ch. II.3)
    (BoardId::Cspace0, 1e-3),
    (BoardId::Servo, 1.0 / 3000.0),
    (BoardId::Reflex, 1e-3),
    (BoardId::Planner, 1e-3),
];

/// Everything a run is made from (a scenario file supplies it).
#[derive(Clone, Debug, PartialEq)]
pub struct Config {
    /// Fixes every random choice.
    pub seed: u64,
    /// Simulated seconds.
    pub duration_s: f64,
    /// Plant step.
    pub dt_s: f64,
    /// Start angles (absolute, rad), at rest.
    pub start_rad: [f64; 2],
    /// Obstacles (beacons 0..=4 and the instructional robot, beacon 7).
    pub obstacles: Vec<Obstacle>,
    /// The wand's path (beacon 6).
    pub wand: WandPath,
    /// Boards and their main-loop periods.
    pub boards: Vec<(BoardId, f64)>,
    /// Faults to inject.
    pub faults: Vec<Fault>,
    /// The optical sensor.
    pub optics: OpticsConfig,
    /// The calibration table the host writes before the boards boot.
    pub calibration: Calibration,
    /// The planner's rules (the thesis's line-of-sight leave can be asked for, fig. VI.2).
    pub planner: planner::Config,
}

/// Where the sensing board's calibration table comes from at power-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Calibration {
    /// None: the sensing board publishes no valid position until the host writes one (the
    /// state the calibration procedure starts from).
    None,
    /// The table the thesis's scan would record with a noiseless sensor at the calibration
    /// temperature, sampled from the optical model on the same 36 x 36 grid and inverted by
    /// the same code (`sim-host calibrate` runs the real procedure; see docs/sensing.md).
    Model,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            seed: 1,
            duration_s: 1.0,
            dt_s: DEFAULT_DT_S,
            start_rad: [0.0, 0.0],
            obstacles: Vec::new(),
            wand: WandPath::default(),
            boards: DEFAULT_PERIODS_S.to_vec(),
            faults: Vec::new(),
            optics: OpticsConfig::default(),
            calibration: Calibration::Model,
            planner: planner::Config::DEFAULT,
        }
    }
}

/// A fault injected at a time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fault {
    /// When.
    pub at_s: f64,
    /// Which board.
    pub board: BoardId,
    /// What.
    pub kind: FaultKind,
}

/// Kinds of injected faults.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaultKind {
    /// The board stops running (its heartbeat freezes).
    Halt,
    /// The board takes a bus error (the host's fault-injection command).
    BusError,
    /// The board runs on but its heartbeat word stays at the value it had (a stuck
    /// heartbeat: what readers must treat as a dead board).
    FreezeHeartbeat,
    /// The board stops in the middle of publishing its main record: it halts, and the
    /// record is left with half its words written and its sequence odd (the sensing
    /// board's object table, the servo's state, the reflex's subgoal, the planner's goal;
    /// a C-space board has no record of its own and only halts).
    Tear,
}

/// The longest an image board's reset release trails power-up (seeded per board).
pub const RESET_SKEW_US: f64 = 20.0;

/// How far (CPU cycles, 3 us at 16.7 MHz) one image board runs before the next takes its
/// turn within a plant step. The boards run in parallel on the real bus; a slice much longer
/// than a record write would let a reader meet a record torn for its whole slice, every
/// retry failing, where on the bus the writer would have finished meanwhile (at 10 us the
/// reflex image recorded torn records and fig. VI.5 missed its goal; 3 us costs 9% of the
/// real-time factor, docs/performance.md).
pub const IMAGE_SLICE_CYCLES: u64 = 50;

/// A board's code: its crate run natively, or its image on an emulated 68020.
enum Code {
    Native(Native),
    Image(Box<EmuBoard>),
}

/// One board's code, run natively.
enum Native {
    Sensing(Box<board_sensing::Board>),
    Cspace(Box<board_cspace::Board<Box<cspace::worklist::Scratch>>>),
    Servo(Box<board_servo::Board>),
    Reflex(Box<board_reflex::Board>),
    Planner(Box<board_planner::Board>),
}

impl Native {
    fn new(id: BoardId, planner: planner::Config) -> Self {
        match id {
            BoardId::Sensing => Native::Sensing(Box::new(board_sensing::Board::new())),
            BoardId::Servo => Native::Servo(Box::new(board_servo::Board::new())),
            BoardId::Reflex => Native::Reflex(Box::new(board_reflex::Board::new())),
            BoardId::Planner => {
                Native::Planner(Box::new(board_planner::Board::with_config(planner)))
            }
            c => Native::Cspace(Box::new(board_cspace::Board::new(
                c,
                Box::new(cspace::worklist::Scratch::new()),
            ))),
        }
    }
    fn boot(&mut self, g: &mut dyn GlobalBus, io: &mut impl IoBus) {
        match self {
            Native::Sensing(b) => b.boot(g, io),
            Native::Cspace(b) => b.boot(g, io),
            Native::Servo(b) => b.boot(g, io),
            Native::Reflex(b) => b.boot(g, io),
            Native::Planner(b) => b.boot(g, io),
        }
    }
    fn poll(&mut self, g: &mut dyn GlobalBus, io: &mut impl IoBus) {
        match self {
            Native::Sensing(b) => b.poll(&mut &mut *g, io),
            Native::Cspace(b) => b.poll(&mut &mut *g, io),
            Native::Servo(b) => b.poll(g, io),
            Native::Reflex(b) => b.poll(&mut &mut *g, io),
            Native::Planner(b) => b.poll(&mut &mut *g, io),
        };
    }
}

/// Register access for a native board: the device at the board's current time. An access
/// the device does not decode is remembered as the board's bus error.
struct NativeIo<'a> {
    dev: &'a mut dyn Device,
    now: u64,
    bus_error: &'a mut Option<u32>,
}

impl IoBus for NativeIo<'_> {
    fn read16(&mut self, off: u32) -> u16 {
        self.dev.read16(off, self.now).unwrap_or_else(|| {
            self.bus_error.get_or_insert(off);
            0xFFFF
        })
    }
    fn write16(&mut self, off: u32, val: u16) {
        if !self.dev.write16(off, val, self.now) {
            self.bus_error.get_or_insert(off);
        }
    }
}

/// A board in the schedule.
struct Slot {
    id: BoardId,
    code: Code,
    own_io: Option<IdOnly>,
    period_s: f64,
    next_s: f64,
    polls: u64,
    halted: bool,
    /// A heartbeat held at this value (fault injection).
    frozen_beat: Option<u32>,
}

/// Loop statistics of one board.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoardStats {
    /// The board.
    pub board: BoardId,
    /// Main-loop passes run.
    pub polls: u64,
    /// Configured period (native mode); the loop-period budget the board's issue sets
    /// (image mode, where the period is the code's own).
    pub period_s: f64,
    /// Whether it was halted by a fault.
    pub halted: bool,
    /// Image mode: (min, mean, max) main-loop period in microseconds at 16.7 MHz, from the
    /// cycles at which the image wrote its heartbeat.
    pub loop_us: Option<(f64, f64, f64)>,
    /// Image mode: main-loop periods measured, and how many of them were longer than a
    /// millisecond at 16.7 MHz (for the reflex, its 1 kHz deadline missed).
    pub loop_over_1ms: Option<(u64, u64)>,
    /// Image mode: the stack's high-water mark (bytes).
    pub stack_bytes: Option<u32>,
}

/// Collision figures from the oracle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Collisions {
    /// Plant steps with the arm touching or overlapping an obstacle.
    pub steps: u64,
    /// Separate contacts (a step in contact after one that was not).
    pub events: u64,
    /// Smallest clearance seen (m; negative = penetration).
    pub min_clearance_m: f64,
}

/// The whole simulated system.
pub struct Sim {
    /// What the run is made from.
    pub cfg: Config,
    /// Global RAM (8 MiB), `vme-map` layout.
    pub global: Vec<u8>,
    /// The arm.
    pub plant: Plant,
    /// The servo board's devices.
    pub servo_io: ServoIo,
    /// The sensing board's devices.
    pub sensing_io: SensingIo<Camera>,
    slots: Vec<Slot>,
    faults: Vec<Fault>,
    /// Plant steps done.
    pub steps: u64,
    /// Collision figures so far.
    pub collisions: Collisions,
    in_contact: bool,
    /// Smallest clearance between the arm and any obstacle at the current time (m).
    clearance_m: f64,
    /// Obstacle disks at the current time (computed once per step, used by the oracle at
    /// the end of a step and by the beacons at the start of the next).
    disks: Vec<Disk>,
    /// A GDB remote-protocol server on one image board (`--gdb`).
    debugger: Option<crate::gdb::Server>,
}

impl Sim {
    /// Powers the system up in native mode: global RAM cleared with its header, every board
    /// booted at a seeded phase within its period, the arm at rest at its start angles.
    pub fn new(cfg: Config) -> Self {
        Self::build(cfg, None).expect("native mode loads no image")
    }

    /// Powers the system up in image mode: every board is `<images>/<board>.elf` (as
    /// `cargo xtask images` writes them) on an emulated 68020, leaving reset at a seeded
    /// skew; global RAM, the arm and the devices as in [`Self::new`].
    pub fn with_images(cfg: Config, images: &Path) -> Result<Self, ImageError> {
        let all: Vec<BoardId> = cfg.boards.iter().map(|b| b.0).collect();
        Self::build(cfg, Some((images, &all)))
    }

    /// Native mode without `images`, image mode ([`Self::with_images`]) with them.
    pub fn in_mode(cfg: Config, images: Option<&Path>) -> Result<Self, ImageError> {
        match images {
            Some(dir) => Self::with_images(cfg, dir),
            None => Ok(Self::new(cfg)),
        }
    }

    /// Mixed mode: the boards in `which` as their images (as [`Self::with_images`]), the
    /// others native. To find which board's image behaves unlike its crate.
    pub fn with_some_images(
        cfg: Config,
        images: &Path,
        which: &[BoardId],
    ) -> Result<Self, ImageError> {
        Self::build(cfg, Some((images, which)))
    }

    fn build(cfg: Config, images: Option<(&Path, &[BoardId])>) -> Result<Self, ImageError> {
        let mut rng = Rng::new(cfg.seed);
        let mut global = vec![0u8; GLOBAL_RAM_SIZE as usize];
        vme_map::init_header(&mut ArrayBus::new(&mut global));
        // The host knows its obstacles' sizes (the thesis's were cylinders of known size);
        // the C-space boards draw each with its own radius.
        for (k, o) in cfg.obstacles.iter().enumerate().take(6) {
            let r_um = (o.start.r_m * 1e6).ceil() as u32;
            ArrayBus::new(&mut global)
                .write_u32(vme_map::layout::OBSTACLE_RADII + 4 * k as u32, r_um);
        }
        let plant = Plant::new(cfg.start_rad, cfg.dt_s);
        // The counters are zeroed with the arm at angle 0 before power-up, so they read the
        // start pose (the servo takes its first latch as absolute: crates/servo).
        let servo_io = ServoIo::new([0.0, 0.0]);
        let camera = Camera::new(cfg.optics.clone(), cfg.seed);
        if cfg.calibration == Calibration::Model {
            let table = crate::sensing_cal::model_table(&camera);
            crate::sensing_cal::write_table(&mut ArrayBus::new(&mut global), &table, 1);
        }
        let sensing_io = SensingIo::new(camera);
        let mut slots = Vec::new();
        for &(id, period_s) in &cfg.boards {
            let phase = rng.next_f64();
            let own_io =
                (!matches!(id, BoardId::Servo | BoardId::Sensing)).then(|| IdOnly::new(id));
            let code = match images.filter(|(_, which)| which.contains(&id)) {
                None => Code::Native(Native::new(id, cfg.planner)),
                Some((dir, _)) => {
                    let path = dir.join(format!("{}.elf", crate::boot::image_name(id)));
                    let image = Image::load(&path)?;
                    let mut b =
                        EmuBoard::new(id, &image, crate::devices::standalone(id), &mut global);
                    b.t0 = (phase * RESET_SKEW_US * 1e-6 * CPU_HZ as f64) as u64;
                    Code::Image(Box::new(b))
                }
            };
            slots.push(Slot {
                id,
                code,
                own_io,
                period_s,
                next_s: phase * period_s,
                polls: 0,
                halted: false,
                frozen_beat: None,
            });
        }
        let mut faults = cfg.faults.clone();
        faults.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
        let mut sim = Sim {
            cfg,
            global,
            plant,
            servo_io,
            sensing_io,
            slots,
            faults,
            steps: 0,
            collisions: Collisions {
                steps: 0,
                events: 0,
                min_clearance_m: f64::INFINITY,
            },
            in_contact: false,
            clearance_m: f64::INFINITY,
            disks: Vec::new(),
            debugger: None,
        };
        sim.disks = sim.cfg.obstacles.iter().map(|o| o.at(0.0)).collect();
        sim.clearance_m = sim.nearest_clearance();
        sim.sync_devices();
        for i in 0..sim.slots.len() {
            sim.with_board(i, 0, |code, g, io| code.boot(g, io));
        }
        Ok(sim)
    }

    /// Whether any board runs as its image.
    pub fn image_mode(&self) -> bool {
        self.slots.iter().any(|s| matches!(s.code, Code::Image(_)))
    }

    /// The image board whose long passes are profiled (`EmuBoard::long_passes`), with its
    /// main-loop periods measured and the profile.
    pub fn long_passes(&self) -> Option<(BoardId, u64, &crate::emu::LongPasses)> {
        self.slots.iter().find_map(|s| match &s.code {
            Code::Image(b) => b.long_passes.as_deref().map(|l| (s.id, b.beats.periods, l)),
            Code::Native(_) => None,
        })
    }

    /// The emulated board `id` (image mode), to step or inspect in tests and the debugger.
    /// Stepping it on its own moves its clock ahead of the plant's; the simulation lets the
    /// plant catch up before it runs the board again.
    pub fn emu_board(&mut self, id: BoardId) -> Option<&mut EmuBoard> {
        self.slots
            .iter_mut()
            .find(|s| s.id == id)
            .and_then(|s| match &mut s.code {
                Code::Image(b) => Some(&mut **b),
                Code::Native(_) => None,
            })
    }

    /// Executes `n` instructions of image board `id` alone, with its own devices and the
    /// shared global RAM (the plant and the other boards wait). Returns the cycles taken, or
    /// `None` if `id` is not an image board of this simulation.
    pub fn step_instructions(&mut self, id: BoardId, n: u64) -> Option<u64> {
        let i = self.slots.iter().position(|s| s.id == id)?;
        let (dev, code) = Self::parts(&mut self.slots[i], &mut self.servo_io, &mut self.sensing_io);
        let Code::Image(b) = code else {
            return None;
        };
        let mut c = 0;
        for _ in 0..n {
            c += b.step_with(&mut self.global, Some(&mut *dev));
        }
        Some(c)
    }

    /// Serves the GDB remote protocol for image board `server.board()` on `server`'s
    /// connection: the simulation starts stopped, before the board's first instruction.
    pub fn attach_debugger(&mut self, server: crate::gdb::Server) {
        self.debugger = Some(server);
    }

    /// Ends a debugging session: GDB, if still attached, is told the program exited.
    pub fn detach_debugger(&mut self) {
        self.debugger = None;
    }

    /// The device a slot's board reaches as its private I/O, and the board's code.
    fn parts<'a>(
        slot: &'a mut Slot,
        servo_io: &'a mut ServoIo,
        sensing_io: &'a mut SensingIo<Camera>,
    ) -> (&'a mut dyn Device, &'a mut Code) {
        let Slot {
            id, code, own_io, ..
        } = slot;
        let dev: &mut dyn Device = match id {
            BoardId::Servo => servo_io,
            BoardId::Sensing => sensing_io,
            _ => own_io
                .as_mut()
                .expect("boards without their own I/O have the ID switch"),
        };
        (dev, code)
    }

    /// Simulated time.
    pub fn t_s(&self) -> f64 {
        self.steps as f64 * self.cfg.dt_s
    }

    /// Where the sensing board's clock (microseconds from its first strobe slot) started, in
    /// simulated microseconds: its first pass. Native mode only (an image's first pass is
    /// wherever its code reaches it): `None` in image mode.
    pub fn sensing_clock_offset_us(&self) -> Option<f64> {
        self.slots
            .iter()
            .find(|s| s.id == BoardId::Sensing)
            .filter(|s| matches!(s.code, Code::Native(_)))
            .map(|s| (s.next_s - s.polls as f64 * s.period_s) * 1e6)
    }

    /// Global RAM as the host sees it.
    pub fn bus(&mut self) -> ArrayBus<'_> {
        ArrayBus::new(&mut self.global)
    }

    /// Runs `f` on board `i`'s code with its global RAM and private I/O at cycle `now`,
    /// turning an undecoded access or a panic into the fault the image would record.
    fn with_board(
        &mut self,
        i: usize,
        now: u64,
        f: impl FnOnce(&mut Native, &mut dyn GlobalBus, &mut NativeIo),
    ) {
        let mut bus_error = None;
        let (dev, code) = Self::parts(&mut self.slots[i], &mut self.servo_io, &mut self.sensing_io);
        let Code::Native(code) = code else {
            return; // an image boots itself from reset
        };
        let mut io = NativeIo {
            dev,
            now,
            bus_error: &mut bus_error,
        };
        let mut g = ArrayBus::new(&mut self.global);
        let r = catch_unwind(AssertUnwindSafe(|| f(code, &mut g, &mut io)));
        let slot = &mut self.slots[i];
        let mut g = ArrayBus::new(&mut self.global);
        let hb = g.read_u32(vme_map::BoardSlot::of(slot.id).heartbeat());
        if let Err(p) = r {
            let msg = p
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| p.downcast_ref::<String>().cloned());
            let text = format!(
                "panic: {}",
                msg.unwrap_or_else(|| "(formatted message)".into())
            );
            vme_map::log::LogWriter::new(slot.id).text(&mut g, hb, text.as_bytes());
            let rec = FaultRecord {
                code: FaultCode::Panic as u32,
                heartbeat: hb,
                ..Default::default()
            };
            rt::record_safe_stop(&mut g, slot.id, &rec);
            slot.halted = true;
        } else if let Some(off) = bus_error {
            let rec = FaultRecord {
                code: FaultCode::BusError as u32,
                vector: 2,
                fault_addr: regs::PRIVATE_IO_BASE + off,
                heartbeat: hb,
                ..Default::default()
            };
            rt::record_safe_stop(&mut g, slot.id, &rec);
            slot.halted = true;
        }
    }

    /// Gives the devices the plant's state and the world's beacons at the current time.
    fn sync_devices(&mut self) {
        let t = self.t_s();
        for (i, l) in self.plant.links.iter().enumerate() {
            self.servo_io.motors[i] = MotorSample {
                angle_rad: l.state.motor_rad,
                rate_rad_s: l.state.motor_rad_s,
                t_s: t,
            };
            self.servo_io.limit[i] = l.state.current_a.abs() >= arm::AMP.current_limit_a * 0.999;
        }
        let b = &mut self.sensing_io.optics.beacons;
        *b = [None; 8];
        for (k, d) in self.disks.iter().enumerate() {
            b[obstacle_beacon(k)] = Some((d.x_m, d.y_m));
        }
        let [t1, t2] = self.plant.angles_rad();
        b[5] = Some(arm::geometry::tip(t1, t2));
        b[6] = self.cfg.wand.at(t);
    }

    /// Advances one plant step.
    pub fn step(&mut self) {
        let t0 = self.t_s();
        let t1 = t0 + self.cfg.dt_s;
        self.sync_devices();
        while self.faults.first().is_some_and(|f| f.at_s < t1) {
            let f = self.faults.remove(0);
            self.inject(f);
        }
        // Every native board due in this step, in order of activation time (ties: slot
        // order); then the image boards, interleaved, up to the step's end.
        loop {
            let next = self
                .slots
                .iter()
                .enumerate()
                .filter(|(_, s)| !s.halted && s.next_s < t1 && matches!(s.code, Code::Native(_)))
                .min_by(|a, b| a.1.next_s.total_cmp(&b.1.next_s).then(a.0.cmp(&b.0)))
                .map(|(i, _)| i);
            let Some(i) = next else { break };
            let when = self.slots[i].next_s;
            let now = (when * CPU_HZ as f64) as u64;
            self.with_board(i, now, |code, g, io| code.poll(g, io));
            self.hold_frozen_beat(i);
            let s = &mut self.slots[i];
            s.polls += 1;
            s.next_s = when + s.period_s;
        }
        self.run_images(t1);
        let (volts, brakes) = self.servo_io.outputs((t1 * CPU_HZ as f64) as u64);
        for (l, b) in self.plant.links.iter_mut().zip(brakes) {
            l.brake = b;
        }
        self.plant.step(volts);
        self.steps += 1;
        self.check_collisions();
    }

    /// Runs every image board up to the system clock at `t1_s`, interleaved in slices;
    /// serves the debugger when its board stops.
    fn run_images(&mut self, t1_s: f64) {
        if !self.image_mode() {
            return;
        }
        let end = (t1_s * CPU_HZ as f64).round() as u64;
        let mut clock = (self.t_s() * CPU_HZ as f64).round() as u64;
        let dbg_board = self.debugger.as_ref().map(|d| d.board());
        if let Some(d) = self.debugger.as_mut() {
            d.poll_interrupt();
        }
        while clock < end {
            clock = (clock + IMAGE_SLICE_CYCLES).min(end);
            for i in 0..self.slots.len() {
                if self.slots[i].halted {
                    continue;
                }
                let debugged = dbg_board == Some(self.slots[i].id);
                loop {
                    let (dev, code) =
                        Self::parts(&mut self.slots[i], &mut self.servo_io, &mut self.sensing_io);
                    let Code::Image(b) = code else { break };
                    if clock <= b.t0 {
                        break;
                    }
                    let until = clock - b.t0;
                    let stop = match self.debugger.as_mut().filter(|_| debugged) {
                        Some(d) if d.wants_stop() => Stop::Breakpoint,
                        Some(d) => b.run_until(&mut self.global, Some(dev), until, d.breakpoints()),
                        None => b.run_until(&mut self.global, Some(dev), until, &[]),
                    };
                    let halted = b.state == RunState::Halted;
                    if debugged && (stop == Stop::Breakpoint || halted) {
                        if let Some(d) = self.debugger.as_mut() {
                            let (dev, code) = Self::parts(
                                &mut self.slots[i],
                                &mut self.servo_io,
                                &mut self.sensing_io,
                            );
                            let Code::Image(b) = code else { break };
                            if !d.serve(b, &mut self.global, dev) {
                                self.debugger = None; // detached: run on freely
                            }
                            if b.state == RunState::Running {
                                continue;
                            }
                        }
                    }
                    if halted {
                        self.slots[i].halted = true;
                    }
                    self.hold_frozen_beat(i);
                    break;
                }
            }
        }
    }

    fn inject(&mut self, f: Fault) {
        let Some(i) = self.slots.iter().position(|s| s.id == f.board) else {
            return;
        };
        match f.kind {
            FaultKind::Halt => self.slots[i].halted = true,
            FaultKind::FreezeHeartbeat => {
                let hb = self
                    .bus()
                    .read_u32(vme_map::BoardSlot::of(f.board).heartbeat());
                self.slots[i].frozen_beat = Some(hb);
            }
            FaultKind::Tear => {
                self.slots[i].halted = true;
                let g = &mut self.bus();
                match f.board {
                    BoardId::Sensing => tear(g, &vme_map::OBJECTS),
                    BoardId::Servo => tear(g, &vme_map::SERVO_STATE),
                    BoardId::Reflex => tear(g, &vme_map::REFLEX_SUBGOAL),
                    BoardId::Planner => tear(g, &vme_map::PLANNER_GOAL),
                    _ => {}
                }
            }
            FaultKind::BusError => {
                vme_map::post_host_command(
                    &mut self.bus(),
                    vme_map::records::host_cmd::INJECT_BUS_ERROR,
                    f.board,
                );
            }
        }
    }

    /// Puts a frozen heartbeat back after board `i` ran.
    fn hold_frozen_beat(&mut self, i: usize) {
        if let Some(hb) = self.slots[i].frozen_beat {
            let off = vme_map::BoardSlot::of(self.slots[i].id).heartbeat();
            self.bus().write_u32(off, hb);
        }
    }

    /// The smallest clearance between the arm's pose and the cached obstacle disks.
    fn nearest_clearance(&self) -> f64 {
        let [a1, a2] = self.plant.angles_rad();
        let pose = Pose::new(a1, a2);
        self.disks
            .iter()
            .map(|d| pose.clearance_m(d))
            .fold(f64::INFINITY, f64::min)
    }

    fn check_collisions(&mut self) {
        let t = self.t_s();
        for (d, o) in self.disks.iter_mut().zip(&self.cfg.obstacles) {
            *d = o.at(t);
        }
        let c = self.nearest_clearance();
        self.clearance_m = c;
        self.collisions.min_clearance_m = self.collisions.min_clearance_m.min(c);
        let contact = c <= 0.0;
        if contact {
            self.collisions.steps += 1;
            if !self.in_contact {
                self.collisions.events += 1;
            }
        }
        self.in_contact = contact;
    }

    /// Smallest clearance between the arm and any obstacle now (m; infinite without
    /// obstacles), as the collision oracle computed it.
    pub fn clearance_m(&self) -> f64 {
        self.clearance_m
    }

    /// Whether the run's duration is over.
    pub fn done(&self) -> bool {
        self.t_s() >= self.cfg.duration_s - 1e-12
    }

    /// Loop statistics of every board.
    pub fn board_stats(&self) -> Vec<BoardStats> {
        self.slots
            .iter()
            .map(|s| match &s.code {
                Code::Native(_) => BoardStats {
                    board: s.id,
                    polls: s.polls,
                    period_s: s.period_s,
                    halted: s.halted,
                    loop_us: None,
                    loop_over_1ms: None,
                    stack_bytes: None,
                },
                Code::Image(b) => BoardStats {
                    board: s.id,
                    polls: b.beats.periods + b.beats.last_beat.is_some() as u64,
                    period_s: s.period_s,
                    halted: s.halted,
                    loop_us: b.beats.period_us(),
                    loop_over_1ms: Some((b.beats.periods, b.beats.over_1ms)),
                    stack_bytes: b.stack_high_water(),
                },
            })
            .collect()
    }
}

/// Leaves `lock`'s record half written with an odd sequence, as a writer that died
/// mid-publish would (the last whole record's first half rewritten).
fn tear<R: vme_map::record::Record + Default>(
    g: &mut ArrayBus,
    lock: &vme_map::record::SeqLock<R>,
) {
    let rec = lock.read(g).map(|r| r.0).unwrap_or_default();
    lock.publish_torn(g, &rec);
}

#[cfg(test)]
mod tests {
    use super::*;
    use vme_map::BoardState;

    #[test]
    fn boards_run_at_their_rates_and_beat() {
        let mut sim = Sim::new(Config {
            duration_s: 0.1,
            ..Default::default()
        });
        while !sim.done() {
            sim.step();
        }
        for s in sim.board_stats() {
            let want = 0.1 / s.period_s;
            assert!(
                (s.polls as f64 - want).abs() <= 1.0,
                "{:?}: {} polls, want {want}",
                s.board,
                s.polls
            );
            let hb = sim
                .bus()
                .read_u32(vme_map::BoardSlot::of(s.board).heartbeat());
            // One beat a pass; the sensing board's pass is a strobe slot and it beats once a
            // frame of eight.
            let per_beat = crate::boot::passes_per_beat(s.board) as u64;
            assert_eq!(hb as u64, s.polls / per_beat, "{:?}", s.board);
            let st = vme_map::BoardSlot::of(s.board).status_word(&mut sim.bus());
            assert_eq!(st.state(), Some(BoardState::Running));
        }
    }

    #[test]
    fn an_injected_bus_error_is_recorded_as_the_image_would() {
        let cfg = Config {
            duration_s: 0.02,
            faults: vec![Fault {
                at_s: 0.01,
                board: BoardId::Reflex,
                kind: FaultKind::BusError,
            }],
            ..Default::default()
        };
        let mut sim = Sim::new(cfg);
        while !sim.done() {
            sim.step();
        }
        let st = vme_map::BoardSlot::of(BoardId::Reflex).status_word(&mut sim.bus());
        assert_eq!(st.state(), Some(BoardState::SafeStop));
        assert_eq!(st.fault(), Some(FaultCode::BusError));
        let (rec, _) = vme_map::BoardSlot::of(BoardId::Reflex)
            .fault()
            .read(&mut sim.bus())
            .unwrap();
        assert_eq!(
            rec.fault_addr,
            regs::PRIVATE_IO_BASE + regs::UNDECODED_PROBE
        );
        assert!(sim
            .board_stats()
            .iter()
            .any(|s| s.board == BoardId::Reflex && s.halted));
    }

    #[test]
    fn the_oracle_counts_contacts_with_moving_obstacles() {
        // Arm straight along +x; a disk sweeps down through link 2 and out again.
        let o = Obstacle {
            start: Disk {
                x_m: 0.4,
                y_m: 0.1,
                r_m: 0.01,
            },
            motion: Motion::Line {
                vx_m_s: 0.0,
                vy_m_s: -1.0,
            },
        };
        let mut sim = Sim::new(Config {
            duration_s: 0.2,
            obstacles: vec![o],
            ..Default::default()
        });
        while !sim.done() {
            sim.step();
        }
        assert_eq!(sim.collisions.events, 1);
        // In contact while |y| <= 0.0095 + 0.01: 0.039 m at 1 m/s = 39 ms = 780 steps.
        let want = (2.0 * 0.0195 / 1.0 / DEFAULT_DT_S).round() as i64;
        assert!(
            (sim.collisions.steps as i64 - want).abs() <= 2,
            "{} steps, want {want}",
            sim.collisions.steps
        );
        // The centre passed inside link 2: clearance bottoms out at minus the radius.
        assert!((sim.collisions.min_clearance_m + 0.01).abs() < 1e-12);
    }

    #[test]
    fn obstacle_motion_and_wand_path() {
        let c = Obstacle {
            start: Disk {
                x_m: 1.0,
                y_m: 0.0,
                r_m: 0.1,
            },
            motion: Motion::Circle {
                cx_m: 0.0,
                cy_m: 0.0,
                period_s: 4.0,
            },
        };
        let d = c.at(1.0);
        assert!(d.x_m.abs() < 1e-12 && (d.y_m - 1.0).abs() < 1e-12);
        let w = WandPath {
            points: vec![(0.0, 0.0, 0.0), (1.0, 1.0, 2.0)],
        };
        assert_eq!(w.at(-1.0), Some((0.0, 0.0)));
        assert_eq!(w.at(0.5), Some((0.5, 1.0)));
        assert_eq!(w.at(9.0), Some((1.0, 2.0)));
        assert_eq!(WandPath::default().at(0.0), None);
    }
}
