//! The sensing board's logic (thesis ch. II section 3, lines ~404-470): the strobe of the
//! eight LED beacons, 250 us each, one A/D conversion of the x, y and sum signals at the end
//! of each pulse, and from the samples the table of object positions in global RAM.
//!
//! Per strobe slot the board calls [`Sensing::slot`] when the 2 MHz timer says a slot has
//! passed (it reads the finished conversion, starts the next one on the beacon lit during
//! the slot, and lights the next beacon at the level [`Slot::level_ma`] gives), then
//! [`Sensing::step`] with the sample. `step`:
//!
//! 1. validity from the sum signal (below [`OCCLUDED_BELOW_CODES`]: occluded) and the
//!    converters' over-range bits (saturated); an invalid sample empties the beacon's filter
//!    and the beacon is published invalid at once (within one strobe frame);
//! 2. removes the previous beacon's residue from the 40 us analog filter (the sample is
//!    taken 6.25 time constants after the switch: 0.2 % of the step is left);
//! 3. LED current feedback (the thesis's proposed fix, ch. II.3.5): each beacon's drive is
//!    adjusted so its sum signal stays at the reference level the table was made at, so
//!    every LED, whatever its efficiency, driver or place, conforms to the one table;
//! 4. the adaptive running average ([`filter`]);
//! 5. drift correction learnt from the robot's tip ([`drift`]), then the calibration
//!    table's inverse grid ([`cal`]) to micrometres;
//! 6. the beacon's record: position, strobe time, validity and quality flags.
//!
//! Nothing here touches hardware: the board wires the registers and global RAM to it.
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]

pub mod cal;
pub mod drift;
pub mod filter;
#[cfg(test)]
mod tests;

use cal::{CalWords, Checker, Reason};
use drift::Drift;
use filter::Filter;
use vme_map::records::{
    beacon_flags as bf, beacon_index, sensing_options as opt, Beacon, ObjectTable, RawBeacon,
    RawTable, SensingConfig, BEACONS,
};

/// Default sum level the LED current feedback holds, codes above 0 V (4.0 V: reachable at
/// the driver's 1000 mA by a weak LED in a corner of the field).
pub const DEFAULT_S_REF_CODES: i32 = 819;
/// A sum signal below this many codes (1.0 V) means no beacon light: occluded.
pub const OCCLUDED_BELOW_CODES: i32 = 205;
/// Least and most LED drive current the feedback sets, mA.
pub const LEVEL_MIN_MA: i32 = 50;
/// See [`LEVEL_MIN_MA`] (the driver's maximum).
pub const LEVEL_MAX_MA: i32 = regs::sensing::LED_LEVEL_MAX_MA as i32;
/// Slots start on a fixed grid of [`SLOT_TICKS`]: a pass that finds the next grid point less
/// than this many ticks ahead starts the slot (the timer reads of successive 250 us passes
/// differ by a tick either way). A late slot leaves the next ones shorter, so the frame
/// rate holds while the average slot fits; a slot [`CATCH_UP_SLOTS`] late resets the grid.
pub const SLOT_EARLY_TICKS: u16 = 10;
/// Slots a pass may run behind its grid and still catch up (the slots after it start as
/// soon as their beacon has been lit [`MIN_LIT_TICKS`], until one finds its grid point ahead
/// again): 1 ms. The tip's drift learning, once every `drift::LEARN_EVERY_FRAMES` frames,
/// takes almost two slots' time in one slot; with the grid restarted by a slot's lateness,
/// as before, each learning lost that time for good (the rate at rest was 487 Hz with an
/// average slot inside its budget). Beyond this, the grid restarts from the pass.
pub const CATCH_UP_SLOTS: u16 = 4;
/// The least time a beacon is lit, timer ticks (152 us, where the crosstalk table starts:
/// the analog filter's residue of the beacon before is 2% and corrected): a slot catching
/// up waits for it after the one before.
pub const MIN_LIT_TICKS: u16 = 304;
/// Tip beacon: the arm counts as resting while both joint angles stay within this of where
/// they were when the rest began (0.5 mrad: a quarter of a millimetre at the tip). Angles,
/// not the observer's velocities, which jitter by several mrad/s at rest.
pub const REST_URAD: i32 = 500;
/// Tip samples the arm must have rested for before the tip's filtered position is used as a
/// drift reference: the long window and a margin.
pub const REST_SAMPLES: u16 = filter::LONG as u16 + 8;
/// Tip samples without a new servo loop count after which the servo state is stale.
pub const SERVO_STALE_SAMPLES: u16 = 4;
/// Positions this far outside the calibrated area are flagged extrapolated, micrometres.
pub const AREA_MARGIN_UM: i32 = 5_000;

const _: () = assert!(regs::sensing::FILTER_TAU_US == 40 && regs::sensing::TIMER_HZ == 2_000_000);
/// a / (1 - a) in Q16 with a = exp(-T / 40 us) the analog filter's residue after T ticks of
/// 0.5 us, for T = 304 + 16 k (a slot after a late one is lit for less than 250 us).
const CROSSTALK_Q16: [i32; 32] = [
    1500, 1223, 998, 815, 665, 544, 445, 364, 297, 243, 199, 163, 133, 109, 89, 73, 60, 49, 40, 33,
    27, 22, 18, 15, 12, 10, 8, 7, 5, 4, 4, 3,
];
/// Timer ticks of one slot (250 us at 2 MHz).
pub const SLOT_TICKS: u16 = 500;

/// One conversion as the board read it. `repr(C)`: `__sense_process` reads it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct AdcSample {
    /// X code, offset binary 0..=4095.
    pub x: u16,
    /// Y code.
    pub y: u16,
    /// Sum code.
    pub sum: u16,
    /// Any converter input was beyond its range.
    pub over: bool,
}

/// The servo state as the sensing board needs it (for the tip's true position).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ServoView {
    /// Absolute joint angles.
    pub theta_urad: [i32; 2],
    /// The servo's loop counter (advances while the servo runs).
    pub loops: u32,
}

/// How to run, from the host's [`SensingConfig`] record. `repr(C)`: `__sense_process`
/// reads it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct Config {
    /// `sensing_options` bits.
    pub options: u32,
    /// Sum level for the current feedback, codes.
    pub s_ref_codes: i32,
    /// Fixed drive when the feedback is off, mA.
    pub level_ma: i32,
}

impl Default for Config {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl Config {
    /// Everything on, the default sum reference and the thesis's 560 mA when the feedback
    /// is off: what the board runs with until the host publishes a configuration.
    pub const DEFAULT: Config = Config {
        options: opt::DEFAULT,
        s_ref_codes: DEFAULT_S_REF_CODES,
        level_ma: regs::sensing::LED_LEVEL_RESET_MA as i32,
    };

    /// The configuration a host record asks for (implausible values replaced by defaults).
    pub fn from_record(r: &SensingConfig) -> Self {
        let d = Self::default();
        let s = r.s_ref_codes as i32;
        let l = r.level_ma as i32;
        Self {
            options: r.options,
            s_ref_codes: if (OCCLUDED_BELOW_CODES * 2..2048).contains(&s) {
                s
            } else {
                d.s_ref_codes
            },
            level_ma: if (LEVEL_MIN_MA..=LEVEL_MAX_MA).contains(&l) {
                l
            } else {
                d.level_ma
            },
        }
    }
    fn has(&self, bit: u32) -> bool {
        self.options & bit != 0
    }
}

/// What the board does at a slot boundary.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Slot {
    /// Start a conversion (a beacon has been lit for the whole slot).
    pub start: bool,
    /// Light this beacon next.
    pub next: u8,
    /// At this drive current, mA.
    pub level_ma: u16,
    /// The beacon whose finished conversion `step` will process, if any: the board reads the
    /// servo state for the tip and the host's configuration for beacon 0.
    pub processing: Option<u8>,
}

/// Something the board records as a fault ([`Output::event`] carries it as
/// [`Event::code`]: plain integers, merged without branches; see `merge`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Event {
    /// A converter input saturated on this beacon.
    Saturated(u8),
    /// The calibration table was refused.
    BadCalibration(Reason),
    /// The servo state stopped advancing: the drift reference is held.
    StaleServo,
    /// The drift estimate reached its bounds: implausible, held.
    DriftBound,
}

impl Event {
    /// The event as a word: kind in bits 0..8 (1..=4), detail in bits 8..16.
    pub const fn code(self) -> u32 {
        match self {
            Event::Saturated(b) => 1 | (b as u32) << 8,
            Event::BadCalibration(r) => 2 | (r as u32) << 8,
            Event::StaleServo => 3,
            Event::DriftBound => 4,
        }
    }
    /// The event a word encodes (0: none).
    pub const fn from_code(c: u32) -> Option<Self> {
        let d = (c >> 8) as u8;
        match c & 0xFF {
            1 => Some(Event::Saturated(d)),
            2 => Some(Event::BadCalibration(match d {
                0 => Reason::Missing,
                1 => Reason::Format,
                2 => Reason::Pitch,
                3 => Reason::Node,
                _ => Reason::Checksum,
            })),
            3 => Some(Event::StaleServo),
            4 => Some(Event::DriftBound),
            _ => None,
        }
    }
}

/// `new` if it is an event (non-zero), else `old`: by masks, no compare (the M68k backend
/// clobbered the condition codes of `if ev.is_some()` here; docs/toolchain.md class 1).
#[inline(always)]
fn merge(old: u32, new: u32) -> u32 {
    let mask = ((new | new.wrapping_neg()) as i32 >> 31) as u32;
    (new & mask) | (old & !mask)
}

/// Inputs of one step.
#[derive(Clone, Copy, Debug, Default)]
pub struct Input {
    /// The conversion read at this slot boundary, if one had finished.
    pub sample: Option<AdcSample>,
    /// The servo state (read when the tip is processed), if readable.
    pub servo: Option<ServoView>,
    /// The host's configuration, if it has published one (read when beacon 0 is processed).
    pub config: Option<Config>,
}

/// What one step did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Output {
    /// The beacon whose record changed.
    pub beacon: Option<u8>,
    /// A fault to record: an [`Event::code`], 0 for none.
    pub event: u32,
    /// The beacon's words (and the frame words after beacon 7) are already in global RAM:
    /// the common slot's assembly published them ([`CalWords::tables`]). When false, the
    /// board publishes them with [`Sensing::publish`].
    pub published: bool,
}

impl Output {
    /// The fault to record, if any.
    pub fn event(&self) -> Option<Event> {
        Event::from_code(self.event)
    }
}

/// A conversion in flight: strobe time (us), ticks it was lit for, beacon. `repr(C)`:
/// `__sense_process` reads it at the offsets [`layout`] asserts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
struct Conversion {
    t_us: u32,
    lit_ticks: u16,
    beacon: Ix,
}

/// A beacon's index, 0..=7, as a type with a niche: `Option<Conversion>` is then two words
/// and `Option<Ix>` one byte, and the slot's copies of them are word moves on the 68020
/// (with a `u8` they were 12 and 2 bytes, shuffled a field at a time).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
enum Ix {
    B0,
    B1,
    B2,
    B3,
    B4,
    B5,
    B6,
    B7,
}

impl Ix {
    /// The beacon lit after this one.
    #[inline(always)]
    fn next(self) -> Self {
        const ALL: [Ix; BEACONS] = [
            Ix::B0,
            Ix::B1,
            Ix::B2,
            Ix::B3,
            Ix::B4,
            Ix::B5,
            Ix::B6,
            Ix::B7,
        ];
        ALL[(self as usize + 1) & 7]
    }
}

/// The sensing board's state. `repr(C)`, at the offsets [`layout`] asserts (the same on the
/// host and the 68020: no field needs padding): the small fields first, the 9 KiB of filter
/// rings last. LLVM's M68k backend folds only small displacements into an instruction; a
/// field 8 KiB in cost a register load and an indexed access each time (docs/toolchain.md).
#[repr(C)]
pub struct Sensing {
    config: Config,
    /// The raw codes of the last processed sample (for the crosstalk correction).
    prev_raw: [i32; 2],
    levels: [u16; BEACONS],
    /// The beacon lit after the last processed sample's (8 before any sample: none is).
    prev_next: u8,
    started: bool,
    last_timer: u16,
    slot_timer: u16,
    lit: Option<Ix>,
    servo_stale: bool,
    half_tick: u32,
    now_us: u32,
    converting: Option<Conversion>,
    sampled: Option<Conversion>,
    rest: u16,
    servo_same: u16,
    /// Frames at rest since the drift estimate last learnt (`drift::LEARN_EVERY_FRAMES`).
    learn_age: u32,
    servo_loops: u32,
    rest_theta: [i32; 2],
    /// The drift estimate.
    pub drift: Drift,
    /// The object table to publish.
    pub objects: ObjectTable,
    /// The raw signal table to publish.
    pub raw: RawTable,
    filters: [Filter; BEACONS],
    /// The calibration table check (last: its enum's padding is not the same on both).
    pub checker: Checker,
}

impl Default for Sensing {
    fn default() -> Self {
        Self::new()
    }
}

impl Sensing {
    /// A board just booted: nothing lit, no table, filters empty.
    pub const fn new() -> Self {
        Self {
            started: false,
            last_timer: 0,
            slot_timer: 0,
            half_tick: 0,
            now_us: 0,
            lit: None,
            converting: None,
            sampled: None,
            prev_next: 8,
            prev_raw: [0; 2],
            levels: [regs::sensing::LED_LEVEL_RESET_MA; BEACONS],
            filters: [Filter::new(); BEACONS],
            config: Config::DEFAULT,
            checker: Checker::new(),
            drift: Drift::new(),
            rest: 0,
            rest_theta: [0; 2],
            servo_loops: 0,
            servo_same: 0,
            servo_stale: false,
            learn_age: 0,
            objects: ObjectTable {
                frame: 0,
                beacons: [Beacon {
                    x_um: 0,
                    y_um: 0,
                    t_us: 0,
                    flags: bf::UNCALIBRATED,
                }; BEACONS],
            },
            raw: RawTable {
                frame: 0,
                beacons: [RawBeacon {
                    x_q5: 0,
                    y_q5: 0,
                    sum_codes: 0,
                    level_ma: 0,
                }; BEACONS],
            },
        }
    }

    /// Microseconds since the first slot, from the 2 MHz timer (wraps after 71 minutes).
    pub fn now_us(&self) -> u32 {
        self.now_us
    }

    /// At timer value `timer`: if a slot is due, what to do now (see [`SLOT_EARLY_TICKS`]).
    /// Inlined into the board's loop: called, with the test for the beacon's least lit time,
    /// it cost 216 cycles a slot on the 68020.
    #[inline(always)]
    pub fn slot(&mut self, timer: u16) -> Option<Slot> {
        let due = self.slot_timer.wrapping_add(SLOT_TICKS);
        let ahead = due.wrapping_sub(timer);
        // `ahead` in (EARLY, 32768): the grid point is still ahead; beyond: it has passed.
        // One unsigned compare, masked by `started` (the compare chain this replaces drew a
        // condition-code clobber on the 68k; docs/toolchain.md class 1).
        let waiting =
            (ahead.wrapping_sub(SLOT_EARLY_TICKS + 1) < 0x8000 - SLOT_EARLY_TICKS - 1) as u16;
        // A slot catching up still lights its beacon for MIN_LIT_TICKS.
        let lit_ticks = timer.wrapping_sub(self.last_timer);
        let short = (lit_ticks < MIN_LIT_TICKS) as u16;
        if (waiting | short) & (self.started as u16) != 0 {
            return None;
        }
        if self.started {
            let ticks = lit_ticks as u32 + self.half_tick;
            self.now_us = self.now_us.wrapping_add(ticks >> 1);
            self.half_tick = ticks & 1;
        }
        self.slot_timer = next_grid(due, timer, self.started);
        self.started = true;
        self.last_timer = timer;
        // The conversion started at the last boundary has finished: it is processed now.
        self.sampled = self.converting;
        self.converting = self.lit.map(|b| Conversion {
            beacon: b,
            t_us: self.now_us,
            lit_ticks,
        });
        let next = self.lit.map_or(Ix::B0, Ix::next);
        self.lit = Some(next);
        Some(Slot {
            start: self.converting.is_some(),
            next: next as u8,
            level_ma: self.levels[next as usize],
            processing: self.sampled.map(|c| c.beacon as u8),
        })
    }

    /// Processes the sample read at this slot boundary; updates [`Self::objects`] and
    /// [`Self::raw`]. `cal` reads the calibration table.
    pub fn step(&mut self, input: &Input, cal: &mut impl CalWords) -> Output {
        let mut out = Output::default();
        if let Some(r) = self.checker.step(cal) {
            out.event = Event::BadCalibration(r).code();
        }
        if let Some(c) = input.config {
            self.config = c;
        }
        // By reference: the sample is not copied (the 68020's slot budget).
        let (Some(conv), Some(s)) = (self.sampled.take(), &input.sample) else {
            return out;
        };
        let (ev, published) = self.process(conv, s, input.servo, cal);
        out.beacon = Some(conv.beacon as u8);
        out.event = merge(out.event, ev);
        out.published = published;
        out
    }

    fn process(
        &mut self,
        conv: Conversion,
        s: &AdcSample,
        servo: Option<ServoView>,
        cal: &mut impl CalWords,
    ) -> (u32, bool) {
        // On the 68020 the common slot (a well-lit, unsaturated sample with a checked table
        // mapped in global RAM) is one call of the runtime's assembly, bit-identical to the
        // Rust below (`tests/tests/sensing.rs` compares the image with the host slot by
        // slot); the rest takes the Rust, and so does a table whose steps do not fit the
        // assembly's 16 x 16-bit products (`Checker::word_steps_mask`: a null grid).
        #[cfg(target_arch = "m68k")]
        if let (Some(base), Some(h)) = (cal.base(), self.checker.header_ref()) {
            extern "C" {
                fn __sense_process(
                    s: *mut u8,
                    conv: *const Conversion,
                    sample: *const AdcSample,
                    inv: *const u32,
                    area_um: *const i32,
                    out: *mut filter::Estimate,
                    tables: *const Tables,
                    publish: *const *mut u32,
                ) -> u32;
            }
            let area = h.area_um.as_ptr();
            // Written by the routine when it returns 1, read only then: not zeroed first (27
            // cycles a slot).
            let mut e = core::mem::MaybeUninit::<filter::Estimate>::uninit();
            let publish = cal.tables();
            // SAFETY: the routine reads and writes only `*self` and `e` at the offsets
            // `layout` asserts, reads `conv`, `s`, the area, the tables, and the inverse
            // grid's cell at the clamped signals (`base` maps the whole table: the checker
            // read every word), and writes the beacon's words and the frame words of the
            // object and raw tables behind their sequence words (`publish`, when not null;
            // `layout` asserts the tables' shape). It changes nothing when it returns 2.
            let r = unsafe {
                __sense_process(
                    self as *mut Sensing as *mut u8,
                    &conv,
                    s,
                    (base.add(vme_map::records::cal::INV as usize) as usize
                        & self.checker.word_steps_mask()) as *const u32,
                    area,
                    e.as_mut_ptr(),
                    &TABLES,
                    publish.as_ref().map_or(core::ptr::null(), |p| p.as_ptr()),
                )
            };
            if r != 2 {
                let ev = if conv.beacon as usize & 7 == beacon_index::TIP {
                    // SAFETY: 1 says the routine wrote the whole estimate.
                    let e = (r == 1).then(|| unsafe { e.assume_init() });
                    self.reference(e, servo, cal)
                } else {
                    0
                };
                return (ev, publish.is_some());
            }
        }
        // The table's steps, while they are unchecked (`Checker::step_steps`): until then
        // the assembly is given no grid and every slot comes here.
        self.checker.step_steps(cal);
        let b = conv.beacon as usize & 7;
        let raw = [s.x as i32 - 2048, s.y as i32 - 2048];
        let sum = s.sum as i32 - 2048;
        let (prev_next, prev_raw) = (self.prev_next, self.prev_raw);
        self.prev_next = conv.beacon.next() as u8;
        self.prev_raw = raw;
        let mut event = 0;
        let mut flags = 0;
        let cfg = self.config;
        let mut e = filter::Estimate::default();
        let mut valid = false;
        if sum < OCCLUDED_BELOW_CODES {
            self.filters[b].reset();
            flags |= bf::OCCLUDED;
            // Start again from the nominal drive when the beacon reappears (a level the
            // feedback had lowered could otherwise keep it below the threshold).
            self.levels[b] = regs::sensing::LED_LEVEL_RESET_MA;
        } else if s.over {
            self.filters[b].reset();
            flags |= bf::SATURATED;
            // Too bright, or a faulty input: drive less (the feedback brings it back).
            self.levels[b] = (self.levels[b] as i32 >> 1).max(LEVEL_MIN_MA) as u16;
            event = Event::Saturated(conv.beacon as u8).code();
        } else {
            let mut q2 = [raw[0] << 2, raw[1] << 2];
            // Only when on and the previous sample was of the beacon lit just before: masks,
            // not branches (their compares' flags were clobbered on the 68k;
            // docs/toolchain.md class 1).
            let d = (prev_next ^ conv.beacon as u8) as i32;
            let on = (cfg.has(opt::CROSSTALK) as i32).wrapping_neg();
            let consecutive = !((d | d.wrapping_neg()) >> 31) & on;
            crosstalk_q2(&mut q2, &raw, &prev_raw, conv.lit_ticks, consecutive);
            valid = self.filters[b].push_estimate(q2, cfg.has(opt::ADAPTIVE_FILTER), &mut e);
            // The feedback's level, or the fixed one when it is off: a mask, not a branch
            // (its compare's flags were clobbered on the 68k; docs/toolchain.md class 1).
            let fb = feedback_ma(self.levels[b] as i32, sum, cfg.s_ref_codes);
            let on = (cfg.has(opt::CURRENT_FEEDBACK) as i32).wrapping_neg();
            self.levels[b] = ((fb & on) | (cfg.level_ma & !on)) as u16;
        }
        let est = valid.then_some(e);
        let rb = &mut self.raw.beacons[b];
        rb.sum_codes = sum;
        // Through a compiler barrier: LLVM's M68k backend applied this widening's mask to
        // another register and stored the level with garbage above it (docs/toolchain.md,
        // class 12).
        rb.level_ma = core::hint::black_box(self.levels[b]) as u32;
        if let Some(e) = est {
            rb.x_q5 = e.q5[0];
            rb.y_q5 = e.q5[1];
        }
        let header = self.checker.header_ref();
        let beacon = &mut self.objects.beacons[b];
        beacon.t_us = conv.t_us;
        match (est, header) {
            (Some(e), Some(h)) => {
                // Masks, not branches (a branch on these flags had its compare's flags
                // clobbered on the 68k; docs/toolchain.md class 1).
                let correct =
                    cfg.has(opt::DRIFT_REFERENCE) as u32 & (self.drift.observations != 0) as u32;
                let (p, out) = locate_um(cal, e.q5, &self.drift, correct, &h.area_um);
                beacon.x_um = p[0];
                beacon.y_um = p[1];
                flags |= bf::VALID
                    | (bf::CORRECTED & correct.wrapping_neg())
                    | (bf::EXTRAPOLATED & out.wrapping_neg())
                    | (bf::MOVING & (e.moving as u32).wrapping_neg())
                    | (bf::FILLING & (e.filling as u32).wrapping_neg());
                flags |= (e.samples as u32) << bf::SAMPLES_SHIFT;
            }
            (None, h) => {
                // Filling when nothing else was found: a mask, not a branch (its compare's
                // flags were clobbered on the 68k; docs/toolchain.md class 1).
                let none = ((flags == 0) as u32).wrapping_neg();
                flags |=
                    none & (bf::FILLING | (self.filters[b].count() as u32) << bf::SAMPLES_SHIFT);
                if h.is_none() {
                    flags |= bf::UNCALIBRATED;
                }
            }
            (Some(e), None) => {
                flags |= bf::UNCALIBRATED | (e.samples as u32) << bf::SAMPLES_SHIFT;
            }
        }
        beacon.flags = flags;
        if b == beacon_index::TIP {
            event = merge(self.reference(est, servo, cal), event);
        }
        if b == BEACONS - 1 {
            self.objects.frame = self.objects.frame.wrapping_add(1);
            self.raw.frame = self.objects.frame;
        }
        (event, false)
    }

    /// Publishes beacon `b`'s words of the object table and of the raw signal table, and
    /// after beacon 7 both frame words, each under its table's sequence lock: only the
    /// processed beacon's words change in a slot. From where the words lie (a copy of each
    /// record first cost 130 cycles a slot on the 68020). What the board does after a step
    /// whose [`Output::published`] is false.
    #[inline(always)]
    pub fn publish<G: vme_map::GlobalBus>(&self, g: &mut G, b: u8) {
        let i = b as usize & 7;
        let o = &self.objects.beacons[i];
        let base = 1 + 4 * i as u32;
        vme_map::OBJECTS.publish_words(g, base, &[o.x_um as u32, o.y_um as u32, o.t_us, o.flags]);
        let r = &self.raw.beacons[i];
        vme_map::SENSING_RAW.publish_words(
            g,
            base,
            &[r.x_q5 as u32, r.y_q5 as u32, r.sum_codes as u32, r.level_ma],
        );
        if i == BEACONS - 1 {
            vme_map::OBJECTS.publish_words(g, 0, &[self.objects.frame]);
            vme_map::SENSING_RAW.publish_words(g, 0, &[self.raw.frame]);
        }
    }

    /// The tip as the drift reference: learns from it while the arm rests, one observation
    /// every `drift::LEARN_EVERY_FRAMES` frames. Called once a frame, so not inlined
    /// (inlined into `step`, its saturating adds drew condition-code clobbers;
    /// docs/toolchain.md class 1).
    #[inline(never)]
    fn reference(
        &mut self,
        est: Option<filter::Estimate>,
        servo: Option<ServoView>,
        cal: &mut impl CalWords,
    ) -> u32 {
        let mut event = 0;
        let fresh = match servo {
            Some(v) if v.loops != self.servo_loops => {
                self.servo_loops = v.loops;
                self.servo_same = 0;
                true
            }
            _ => {
                self.servo_same = self.servo_same.saturating_add(1);
                self.servo_same < SERVO_STALE_SAMPLES
            }
        };
        if !fresh {
            if !self.servo_stale && self.servo_loops != 0 {
                event = Event::StaleServo.code();
            }
            self.servo_stale = true;
            self.rest = 0;
            return event;
        }
        self.servo_stale = false;
        let (Some(v), Some(e)) = (servo, est) else {
            self.rest = 0;
            return 0;
        };
        let d = [
            v.theta_urad[0] - self.rest_theta[0],
            v.theta_urad[1] - self.rest_theta[1],
        ];
        if d[0].abs() < REST_URAD && d[1].abs() < REST_URAD {
            self.rest = self.rest.saturating_add(1);
        } else {
            self.rest = 0;
            self.rest_theta = v.theta_urad;
        }
        if self.rest < REST_SAMPLES
            || (e.samples as usize) < filter::LONG.min(255)
            || !self.config.has(opt::DRIFT_REFERENCE)
        {
            return 0;
        }
        // One observation every few frames (drift::LEARN_EVERY_FRAMES): the steps are sized
        // for it.
        self.learn_age += 1;
        if self.learn_age < drift::LEARN_EVERY_FRAMES {
            return 0;
        }
        self.learn_age = 0;
        let Some(h) = self.checker.header() else {
            return 0;
        };
        let Some(expected) = cal::signals_q5(cal, &h, tip_um(v.theta_urad)) else {
            return 0;
        };
        // 0 when the estimate stayed inside its bounds, else the event: a shift, no branch.
        const _: () = assert!(Event::DriftBound.code() == 1 << 2);
        self.drift.observe(e.q5, expected) << 2
    }
}

/// The constant tables the common slot's assembly reads (`__sense_process`): one pointer
/// for both.
#[repr(C)]
struct Tables {
    /// [`filter::RECIP_Q16`].
    recip_q16: [i32; filter::LONG + 1],
    /// [`CROSSTALK_Q16`].
    crosstalk_q16: [i32; 32],
    /// [`FEEDBACK_RECIP`].
    feedback_recip: [u32; 2048],
}

/// The one copy of [`Tables`] (a static: the assembly takes its address).
#[cfg_attr(not(target_arch = "m68k"), allow(dead_code))]
static TABLES: Tables = Tables {
    recip_q16: filter::RECIP_Q16,
    crosstalk_q16: CROSSTALK_Q16,
    feedback_recip: FEEDBACK_RECIP,
};

/// Exact reciprocals for the LED feedback's division in the common slot's assembly:
/// `FEEDBACK_RECIP[d]` = floor(2^32 / d) + 1, so that floor(n m / 2^32) = floor(n / d) for
/// every n < 2^21 and d < 2^11 (Granlund and Montgomery's bound: m d - 2^32 <= d < 2^11 =
/// 2^(32 - 21)). [`feedback_ma`]'s dividend is level x s_ref < 2^10 x 2^11 and its divisor a
/// sum of 12-bit codes above 0 V, below 2^11: one 64-bit `MULU.L` (40 cycles) and a table
/// read in place of a `DIVS.L` (92), bit-identical to the division.
pub const FEEDBACK_RECIP: [u32; 2048] = feedback_recips();

const fn feedback_recips() -> [u32; 2048] {
    let mut t = [0; 2048];
    let mut d = 1;
    while d < 2048 {
        t[d] = ((1u64 << 32) / d as u64 + 1) as u32;
        d += 1;
    }
    t
}

/// Byte offsets of the fields `__sense_process` (`crates/rt/asm/rt.S`) uses, as its `.set`
/// lines name them: checked here at compile time, on the host and the 68020 alike.
pub mod layout {
    use super::{AdcSample, Config, Conversion, Sensing, Tables};
    use core::mem::{offset_of, size_of};
    use vme_map::records::{Beacon, ObjectTable, RawBeacon, RawTable};
    const _: () = assert!(offset_of!(Sensing, filters) == 380);
    const _: () = assert!(size_of::<super::Filter>() == super::filter::layout::FILTER_BYTES);
    const _: () = assert!(offset_of!(Sensing, objects) == 116);
    const _: () = assert!(offset_of!(ObjectTable, frame) == 0);
    const _: () = assert!(offset_of!(ObjectTable, beacons) == 4);
    const _: () = assert!(size_of::<Beacon>() == 16);
    const _: () = assert!(offset_of!(Beacon, x_um) == 0);
    const _: () = assert!(offset_of!(Beacon, y_um) == 4);
    const _: () = assert!(offset_of!(Beacon, t_us) == 8);
    const _: () = assert!(offset_of!(Beacon, flags) == 12);
    const _: () = assert!(offset_of!(Sensing, raw) == 248);
    const _: () = assert!(offset_of!(RawTable, frame) == 0);
    const _: () = assert!(offset_of!(RawTable, beacons) == 4);
    const _: () = assert!(size_of::<RawBeacon>() == 16);
    const _: () = assert!(offset_of!(RawBeacon, x_q5) == 0);
    const _: () = assert!(offset_of!(RawBeacon, y_q5) == 4);
    const _: () = assert!(offset_of!(RawBeacon, sum_codes) == 8);
    const _: () = assert!(offset_of!(RawBeacon, level_ma) == 12);
    const _: () = assert!(offset_of!(Sensing, drift) == 88);
    const _: () = assert!(offset_of!(super::Drift, observations) == 16);
    const _: () = assert!(offset_of!(Sensing, config) == 0);
    const _: () = assert!(offset_of!(Config, options) == 0);
    const _: () = assert!(offset_of!(Config, s_ref_codes) == 4);
    const _: () = assert!(offset_of!(Config, level_ma) == 8);
    const _: () = assert!(offset_of!(Sensing, prev_raw) == 12);
    const _: () = assert!(offset_of!(Sensing, levels) == 20);
    const _: () = assert!(offset_of!(Sensing, prev_next) == 36);
    const _: () = assert!(offset_of!(Conversion, t_us) == 0);
    const _: () = assert!(offset_of!(Conversion, lit_ticks) == 4);
    const _: () = assert!(offset_of!(Conversion, beacon) == 6);
    const _: () = assert!(size_of::<super::Ix>() == 1 && super::Ix::B7 as u8 == 7);
    const _: () = assert!(offset_of!(AdcSample, x) == 0);
    const _: () = assert!(offset_of!(AdcSample, y) == 2);
    const _: () = assert!(offset_of!(AdcSample, sum) == 4);
    const _: () = assert!(offset_of!(AdcSample, over) == 6);
    const _: () = assert!(offset_of!(Tables, recip_q16) == 0);
    const _: () = assert!(offset_of!(Tables, crosstalk_q16) == 1028);
    const _: () = assert!(offset_of!(Tables, feedback_recip) == 1156);
    // The published tables: a sequence word, the frame word, then four words a beacon in
    // the order of the records in `Sensing` (copied as they lie).
    use vme_map::record::Record;
    const _: () = assert!(ObjectTable::WORDS == 1 + 4 * super::BEACONS as u32);
    const _: () = assert!(RawTable::WORDS == 1 + 4 * super::BEACONS as u32);
    // The flag and option bits the assembly sets and tests.
    use vme_map::records::{beacon_flags as bf, sensing_options as opt};
    const _: () = assert!(bf::VALID == 1 && bf::CORRECTED == 8 && bf::EXTRAPOLATED == 32);
    const _: () = assert!(bf::FILLING == 64 && bf::MOVING == 128 && bf::SAMPLES_SHIFT == 8);
    const _: () = assert!(opt::CURRENT_FEEDBACK == 1 && opt::DRIFT_REFERENCE == 2);
    const _: () = assert!(opt::ADAPTIVE_FILTER == 4 && opt::CROSSTALK == 8);
    const _: () = assert!(super::OCCLUDED_BELOW_CODES == 205);
    const _: () = assert!(super::LEVEL_MIN_MA == 50 && super::LEVEL_MAX_MA == 1000);
    // The 16 x 16-bit products: the crosstalk factors and the default reference fit a word
    // (`Config::from_record` keeps s_ref in OCCLUDED_BELOW_CODES * 2..2048).
    const _: () = {
        let mut i = 0;
        while i < super::CROSSTALK_Q16.len() {
            assert!(super::CROSSTALK_Q16[i] >= 0 && super::CROSSTALK_Q16[i] <= 1500);
            i += 1;
        }
    };
    const _: () = assert!(super::DEFAULT_S_REF_CODES >= 410 && super::DEFAULT_S_REF_CODES < 2048);
}

/// Where this slot sits on the grid: `due` if it is less than [`CATCH_UP_SLOTS`] late (and
/// the grid has started), else `timer` (the grid restarts). By masks: the select this was
/// compiled to clobbered its compare's flags on the 68k (docs/toolchain.md class 1).
#[inline(always)]
fn next_grid(due: u16, timer: u16, started: bool) -> u16 {
    let late = timer.wrapping_sub(due) as i32;
    let on =
        ((late - (CATCH_UP_SLOTS * SLOT_TICKS) as i32) >> 31) & (started as i32).wrapping_neg();
    ((due as i32 & on) | (timer as i32 & !on)) as u16
}

/// One strobe slot from eight scripted words, for the image-against-host test (the image's
/// probe and the host run this same function): `w` = timer; x, y and sum codes; flags (bit
/// 0: a sample was read, bit 1: it was over range, bit 2: a servo state was read, bit 3: a
/// configuration was read, with the options in bits 8..12 and the fixed drive 50 + bits
/// 12..22 mA); link 1 and link 2 angles (micro-radians); the servo's loop count. Writes to
/// `out`: the next beacon, its drive level, the processed beacon (8: none), the event code,
/// and the processed beacon's x_um, y_um, flags, raw x_q5, raw y_q5, timestamp, sum codes
/// and recorded level, then the frame words of the object and raw tables, then their
/// sequence words (all -1 when no slot was due): [`SCRIPT_OUT_WORDS`] words. The step reads
/// the calibration table from global RAM `g` and the beacon is published there as the board
/// does (by the step's assembly on the 68020, else [`Sensing::publish`]); the words written
/// out are read back from the published tables.
pub fn scripted_slot<G: vme_map::GlobalBus>(
    s: &mut Sensing,
    w: &[u32; 8],
    g: &mut G,
    out: &mut [i32; SCRIPT_OUT_WORDS],
) {
    *out = [-1; SCRIPT_OUT_WORDS];
    let Some(slot) = s.slot(w[0] as u16) else {
        return;
    };
    let f = w[4];
    let sample = (f & 1 != 0).then(|| AdcSample {
        x: w[1] as u16,
        y: w[2] as u16,
        sum: w[3] as u16,
        over: f & 2 != 0,
    });
    let servo = (f & 4 != 0).then(|| ServoView {
        theta_urad: [w[5] as i32, w[6] as i32],
        loops: w[7],
    });
    let config = (f & 8 != 0).then(|| Config {
        options: (f >> 8) & 0xF,
        s_ref_codes: DEFAULT_S_REF_CODES,
        level_ma: 50 + ((f >> 12) & 0x3FF) as i32,
    });
    let input = Input {
        sample,
        servo,
        config,
    };
    let o = s.step(&input, &mut cal::GlobalCal(g));
    if let (Some(b), false) = (o.beacon, o.published) {
        s.publish(g, b);
    }
    let b = o.beacon.map_or(8, |b| b as usize);
    let (obj, raw) = (vme_map::OBJECTS, vme_map::SENSING_RAW);
    let mut word = |off: u32| g.read_u32(off) as i32;
    *out = [
        slot.next as i32,
        slot.level_ma as i32,
        b as i32,
        o.event as i32,
        0,
        0,
        0,
        0,
        0,
        0,
        0,
        0,
        word(obj.word_offset(0)),
        word(raw.word_offset(0)),
        word(obj.offset()),
        word(raw.offset()),
    ];
    if b < BEACONS {
        // The beacon's words as published (past the frame word): x, y, t, flags; raw x, y,
        // sum, level.
        let first = 1 + 4 * b as u32;
        let (o, r) = (
            |k| obj.word_offset(first + k),
            |k| raw.word_offset(first + k),
        );
        out[4] = word(o(0));
        out[5] = word(o(1));
        out[6] = word(o(3));
        out[7] = word(r(0));
        out[8] = word(r(1));
        out[9] = word(o(2));
        out[10] = word(r(2));
        out[11] = word(r(3));
    }
}

/// Words [`scripted_slot`] writes per slot.
pub const SCRIPT_OUT_WORDS: usize = 16;

/// The task-space position (micrometres) of filtered signals `v_q5`: the drift removed
/// when `correct` is 1 ([`Drift::correct`]; 0: not), then the inverse grid ([`cal::position_um`]);
/// with 1 when it lies outside the calibrated area `area_um` (with [`AREA_MARGIN_UM`]), else
/// 0. On the 68020, with the table in mapped global RAM, one call of `__sense_locate` (the
/// runtime's assembly, bit-identical: `tests/tests/firmware_functions.rs`).
#[inline(always)]
pub fn locate_um(
    cal: &mut impl CalWords,
    v_q5: [i32; 2],
    drift: &Drift,
    correct: u32,
    area_um: &[i32; 4],
) -> ([i32; 2], u32) {
    #[cfg(target_arch = "m68k")]
    if let Some(base) = cal.base() {
        extern "C" {
            fn __sense_locate(
                inv: *const u32,
                vx_q5: i32,
                vy_q5: i32,
                drift: *const Drift,
                area_um: *const i32,
                out: *mut [i32; 2],
            ) -> u32;
        }
        let mut p = [0; 2];
        // SAFETY: `base` maps the whole table (the checker read every word), so the inverse
        // grid's cell at the clamped signals is readable; the drift pointer is null (no
        // correction: masked, not selected) or a `repr(C)` Drift; the routine writes only
        // `p`.
        let out = unsafe {
            __sense_locate(
                base.add(vme_map::records::cal::INV as usize),
                v_q5[0],
                v_q5[1],
                (drift as *const Drift as usize & (correct as usize).wrapping_neg())
                    as *const Drift,
                area_um.as_ptr(),
                &mut p,
            )
        };
        return (p, out);
    }
    let v = if correct != 0 {
        drift.correct(v_q5)
    } else {
        v_q5
    };
    let p = cal::position_um(cal, v);
    (p, outside(p, area_um) as u32)
}

/// Whether `p` lies outside the calibrated area (with [`AREA_MARGIN_UM`]).
#[inline(always)]
fn outside(p: [i32; 2], area: &[i32; 4]) -> bool {
    // Each term is negative when the point lies beyond that side: one sign test, no
    // chain of compares (their flags were clobbered on the 68k; docs/toolchain.md class 1).
    let m = (p[0] - (area[0] - AREA_MARGIN_UM))
        | ((area[1] + AREA_MARGIN_UM) - p[0])
        | (p[1] - (area[2] - AREA_MARGIN_UM))
        | ((area[3] + AREA_MARGIN_UM) - p[1]);
    m < 0
}

/// Removes the previous beacon's residue in the analog filters from a sample (`q2`, Q2
/// codes; `raw` its codes, `prev` the previous beacon's): v + (v - v_prev) a / (1 - a), for
/// a sample lit `lit_ticks` after the switch; `mask` 0 leaves the sample as it is. Writes through a reference (no struct return:
/// docs/toolchain.md class 7).
#[inline(always)]
fn crosstalk_q2(q2: &mut [i32; 2], raw: &[i32; 2], prev: &[i32; 2], lit_ticks: u16, mask: i32) {
    let k = ((lit_ticks as i32 - 304 + 8) >> 4).clamp(0, CROSSTALK_Q16.len() as i32 - 1);
    let f = CROSSTALK_Q16[k as usize] & mask;
    q2[0] += ((raw[0] - prev[0]) * f) >> 14;
    q2[1] += ((raw[1] - prev[1]) * f) >> 14;
}

/// The next drive current: the current that gives the sum level `s_ref` if the sum is
/// proportional to the current, level x s_ref / sum, clamped to the driver's range. (The
/// linearised step level x (2 - sum / s_ref) it replaces sent a beacon more than twice too
/// bright at the reset current, one near the camera axis, to the minimum current, where it
/// read as occluded and was reset again: found by the reflex campaign, the beacon was never
/// valid.) level < 2^10 and s_ref < 2^11: the product fits in 32 bits. (A reciprocal table
/// in place of the division, within 1 mA of it, saved 90 cycles a slot but moved the fig.
/// VI.2 scene, whose loop is that sensitive, off its loop; the common slot's assembly uses
/// [`FEEDBACK_RECIP`], which is exact.) Not inlined: inlined, it moved a
/// condition-code clobber into `Sensing::step` (docs/toolchain.md class 1). On the 68020
/// one call of `__sense_feedback` (the runtime's assembly: a `MULS.L` and a `DIVS.L`,
/// bit-identical: `tests/tests/firmware_functions.rs`), where the compiled form called
/// `__fx_div`'s 64-bit division.
#[inline(never)]
pub fn feedback_ma(level: i32, sum: i32, s_ref: i32) -> i32 {
    #[cfg(target_arch = "m68k")]
    {
        extern "C" {
            fn __sense_feedback(level: i32, sum: i32, s_ref: i32) -> i32;
        }
        // SAFETY: a pure function in the runtime's assembly.
        unsafe { __sense_feedback(level, sum, s_ref) }
    }
    #[cfg(not(target_arch = "m68k"))]
    {
        host_feedback_ma(level, sum, s_ref)
    }
}

/// [`feedback_ma`] in Rust (the host's, and the reference of the 68020's).
#[cfg_attr(target_arch = "m68k", allow(dead_code))]
fn host_feedback_ma(level: i32, sum: i32, s_ref: i32) -> i32 {
    // Sign masks, not max/clamp: their compares' flags were clobbered on the 68k
    // (docs/toolchain.md class 1). -1 where the condition holds.
    let pick = |m: i32, a: i32, b: i32| b ^ ((a ^ b) & m);
    let sum = pick((sum - 1) >> 31, 1, sum);
    let v = fx::div(level * s_ref, sum);
    let v = pick((v - LEVEL_MIN_MA) >> 31, LEVEL_MIN_MA, v);
    pick((LEVEL_MAX_MA - v) >> 31, LEVEL_MAX_MA, v)
}

/// Link lengths in micrometres, from the arm's geometry (the one source).
const L_UM: [i32; 2] = [
    (arm::geometry::L1_M * 1e6 + 0.5) as i32,
    (arm::geometry::L2_M * 1e6 + 0.5) as i32,
];

/// The tip beacon's task-space position (micrometres) at absolute joint angles `theta`
/// (thesis ch. II: link angles are absolute).
pub fn tip_um(theta_urad: [i32; 2]) -> [i32; 2] {
    let (s1, c1) = fx::trig::sin_cos_q30(theta_urad[0]);
    let (s2, c2) = fx::trig::sin_cos_q30(theta_urad[1]);
    [
        fx::mul_shr(L_UM[0], c1, 30) + fx::mul_shr(L_UM[1], c2, 30),
        fx::mul_shr(L_UM[0], s1, 30) + fx::mul_shr(L_UM[1], s2, 30),
    ]
}
