//! The boards' private I/O at register level (design.md section 7, "Devices"), behind the
//! register tables of `crates/regs`. An access to an offset a board's table does not list, or
//! in a direction it does not allow, is not decoded: the CPU takes a bus error.
//!
//! * [`ServoIo`]: two 16-bit quadrature counters on the motors with a common latch; the 2 MHz
//!   16-bit free-running counter; two 12-bit DACs (+-10 V) into the amplifiers, gated by the
//!   amplifier enables; current-limit status.
//! * [`SensingIo`]: the LED strobe driver and the A/D converters (x, y, sum), with conversion
//!   time, busy and end-of-conversion flags, 12-bit offset-binary codes and over-range flags,
//!   fed by an [`Optics`] model (the seam for the sensing issue's optical model).
//! * [`IdOnly`]: the boards with no private I/O but their board-ID switch.
//!
//! Device time is CPU cycles at [`CPU_HZ`] in both simulator modes.

use crate::emu::{Device, CPU_HZ};
use regs::sensing::LedCtrl;
use regs::servo::AmpCtrl;
use regs::{decodes, Register};
use vme_map::BoardId;

/// Seconds at CPU cycle `now`.
pub fn seconds(now: u64) -> f64 {
    now as f64 / CPU_HZ as f64
}

/// The 2 MHz counter's value at CPU cycle `now`.
pub fn timer_at(now: u64) -> u16 {
    (now as u128 * regs::servo::TIMER_HZ as u128 / CPU_HZ as u128) as u16
}

/// The board-ID switch setting of a board.
pub fn switch_of(board: BoardId) -> u16 {
    match board {
        BoardId::Cspace1 => 1,
        BoardId::Cspace2 => 2,
        _ => 0,
    }
}

/// The private I/O of a board with none but its board-ID switch.
pub struct IdOnly {
    switch: u16,
}

static ID_ONLY: [Register; 1] = [Register {
    name: "BOARD_ID",
    offset: regs::BOARD_ID,
    access: regs::Access::R,
}];

impl IdOnly {
    /// The switch of `board`.
    pub fn new(board: BoardId) -> Self {
        Self {
            switch: switch_of(board),
        }
    }
}

impl Device for IdOnly {
    fn read16(&mut self, off: u32, _now: u64) -> Option<u16> {
        decodes(&ID_ONLY, off, false).then_some(self.switch)
    }
    fn write16(&mut self, _off: u32, _val: u16, _now: u64) -> bool {
        false
    }
}

/// The board-ID switch as a board's own register access (for native boards run outside
/// the scheduler: a read the switch does not decode returns all ones, a write is dropped).
impl regs::IoBus for IdOnly {
    fn read16(&mut self, off: u32) -> u16 {
        Device::read16(self, off, 0).unwrap_or(0xFFFF)
    }
    fn write16(&mut self, _off: u32, _val: u16) {}
}

/// What the servo board's I/O sees of one motor: its angle (referred to the link) and
/// velocity at time `t_s`, from which the counter extrapolates to the access time.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MotorSample {
    /// Motor angle referred to the link.
    pub angle_rad: f64,
    /// Motor velocity referred to the link.
    pub rate_rad_s: f64,
    /// When sampled.
    pub t_s: f64,
}

/// The servo board's private I/O.
pub struct ServoIo {
    /// Motor states, updated by the simulator every plant step.
    pub motors: [MotorSample; 2],
    /// Amplifier current-limit flags, updated by the simulator.
    pub limit: [bool; 2],
    rad_per_count: [f64; 2],
    offset_counts: [i64; 2],
    latched: [u16; 2],
    dac: [i16; 2],
    amp: AmpCtrl,
    /// Cycle of the last AMP_CTRL write (the watchdog's retrigger).
    fed_at: Option<u64>,
    /// The image's busy cycles a control pass, metered from the accesses it makes here.
    pub passes: crate::servo_bench::PassClock,
}

impl ServoIo {
    /// The servo I/O with encoders reading 0 at the motors' angles `zero_rad`.
    pub fn new(zero_rad: [f64; 2]) -> Self {
        let rpc = [arm::LINK1.rad_per_count(), arm::LINK2.rad_per_count()];
        let mut io = Self {
            motors: [MotorSample::default(); 2],
            limit: [false; 2],
            rad_per_count: rpc,
            offset_counts: [0; 2],
            latched: [0; 2],
            dac: [0; 2],
            amp: AmpCtrl::empty(),
            fed_at: None,
            passes: Default::default(),
        };
        for i in 0..2 {
            io.offset_counts[i] = (zero_rad[i] / rpc[i]).floor() as i64;
        }
        io
    }

    /// The encoder count of motor `i` at CPU cycle `now` (unwrapped).
    pub fn counts(&self, i: usize, now: u64) -> i64 {
        let m = self.motors[i];
        let a = m.angle_rad + m.rate_rad_s * (seconds(now) - m.t_s);
        (a / self.rad_per_count[i]).floor() as i64 - self.offset_counts[i]
    }

    /// The amplifier command volts: the DAC output while enabled, 0 V otherwise.
    pub fn amp_volts(&self) -> [f64; 2] {
        let en = [
            self.amp.contains(AmpCtrl::ENABLE0),
            self.amp.contains(AmpCtrl::ENABLE1),
        ];
        let full = regs::servo::DAC_FULL_SCALE_MV as f64 / 1000.0;
        [0, 1].map(|i| {
            if en[i] {
                self.dac[i] as f64 * full / 2048.0
            } else {
                0.0
            }
        })
    }
}

impl ServoIo {
    /// What the amplifiers and brakes do at CPU cycle `now`: the command volts (0 V while
    /// disabled or once the watchdog has run out) and which brakes are engaged (a link's
    /// brake is released only while its amplifier is enabled and the watchdog is fed).
    pub fn outputs(&self, now: u64) -> ([f64; 2], [bool; 2]) {
        let limit = regs::servo::AMP_WATCHDOG_US as u64 * crate::emu::CPU_HZ / 1_000_000;
        let fed = self.fed_at.is_some_and(|t| now.saturating_sub(t) <= limit);
        if !fed {
            return ([0.0; 2], [true; 2]);
        }
        let v = self.amp_volts();
        (
            v,
            [
                !self.amp.contains(AmpCtrl::ENABLE0),
                !self.amp.contains(AmpCtrl::ENABLE1),
            ],
        )
    }
}

impl Device for ServoIo {
    fn read16(&mut self, off: u32, now: u64) -> Option<u16> {
        use regs::servo::*;
        if !decodes(&REGISTERS, off, false) {
            return None;
        }
        self.passes.read(off, now);
        Some(match off {
            regs::BOARD_ID => 0,
            ENC0 => self.latched[0],
            ENC1 => self.latched[1],
            TIMER => timer_at(now),
            AMP_CTRL => self.amp.bits(),
            AMP_STATUS => {
                let mut s = AmpStatus::empty();
                s.set(AmpStatus::LIMIT0, self.limit[0]);
                s.set(AmpStatus::LIMIT1, self.limit[1]);
                s.bits()
            }
            _ => 0,
        })
    }

    fn write16(&mut self, off: u32, val: u16, now: u64) -> bool {
        use regs::servo::*;
        if !decodes(&REGISTERS, off, true) {
            return false;
        }
        self.passes.write(off);
        match off {
            ENC_CTRL => {
                let c = EncCtrl::from_bits_truncate(val);
                for (i, reset) in [(0, EncCtrl::RESET0), (1, EncCtrl::RESET1)] {
                    if c.contains(reset) {
                        self.offset_counts[i] += self.counts(i, now);
                    }
                }
                if c.contains(EncCtrl::LATCH) {
                    // Both counters in the same clock; 16-bit counters wrap.
                    self.latched = [self.counts(0, now) as u16, self.counts(1, now) as u16];
                }
            }
            DAC0 => self.dac[0] = dac_code(val),
            DAC1 => self.dac[1] = dac_code(val),
            AMP_CTRL => {
                self.amp = AmpCtrl::from_bits_truncate(val);
                self.fed_at = Some(now);
            }
            _ => {}
        }
        true
    }
}

/// The analog front end's output for the selected beacon: what the A/D converters sample.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Analog {
    /// X position signal, volts (the converter spans -10..+10 V).
    pub x_v: f64,
    /// Y position signal, volts.
    pub y_v: f64,
    /// Sum (intensity) signal, volts.
    pub sum_v: f64,
    /// LED drive current read-back, mA.
    pub led_ma: f64,
}

/// What the LED driver is set to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Drive {
    /// Selected beacon, 0..=7.
    pub beacon: u8,
    /// Whether the selected beacon's LED is on.
    pub on: bool,
    /// Drive current set point, mA.
    pub level_ma: u16,
}

/// The optical sensor seen from the sensing board's converters (lateral-effect photodiode,
/// lens, analog sum/difference/divide and filters; `crate::optics` has the model).
pub trait Optics {
    /// The LED driver changed to `d` at `t_s`: the analog chain starts settling towards the
    /// new beacon.
    fn drive(&mut self, _d: Drive, _t_s: f64) {}
    /// The analog signals at time `t_s` under drive `d`.
    fn sample(&mut self, d: Drive, t_s: f64) -> Analog;
}

/// A/D conversion time (a 12-bit successive-approximation converter of the period, 25 us).
pub const ADC_CONVERSION_S: f64 = regs::sensing::ADC_CONVERSION_US as f64 * 1e-6;
/// A/D input span: -10..+10 V.
pub const ADC_SPAN_V: f64 = 10.0;
/// Volts per A/D code (4096 codes over the span; exact in binary).
pub const ADC_V_PER_CODE: f64 = ADC_SPAN_V / 2048.0;

/// The sensing board's private I/O.
pub struct SensingIo<O: Optics> {
    /// The optical model behind the converters.
    pub optics: O,
    select: u8,
    led: LedCtrl,
    level_ma: u16,
    started: Option<u64>,
    /// What the track-and-hold captured at the last start.
    held: Analog,
    /// The result of the conversion before the current one, once one has completed.
    previous: Option<Analog>,
}

impl<O: Optics> SensingIo<O> {
    /// The sensing I/O over `optics`.
    pub fn new(optics: O) -> Self {
        Self {
            optics,
            select: 0,
            led: LedCtrl::empty(),
            level_ma: regs::sensing::LED_LEVEL_RESET_MA,
            started: None,
            held: Analog::default(),
            previous: None,
        }
    }

    /// The LED driver's state.
    pub fn drive_state(&self) -> Drive {
        Drive {
            beacon: self.select,
            on: self.led.contains(LedCtrl::ENABLE),
            level_ma: self.level_ma,
        }
    }

    fn done(&self, now: u64) -> bool {
        self.started
            .is_some_and(|t| seconds(now) - seconds(t) >= ADC_CONVERSION_S)
    }

    /// What the data registers hold at `now`: the last completed conversion.
    fn result(&self, now: u64) -> Option<Analog> {
        if self.done(now) {
            Some(self.held)
        } else {
            self.previous
        }
    }
}

/// The 12-bit offset-binary code of `v` and whether it was beyond the span.
pub fn adc_code(v: f64) -> (u16, bool) {
    let c = ((v + ADC_SPAN_V) / (2.0 * ADC_SPAN_V) * 4096.0).floor();
    if c < 0.0 {
        (0, true)
    } else if c > 4095.0 {
        (4095, true)
    } else {
        (c as u16, false)
    }
}

impl<O: Optics> Device for SensingIo<O> {
    fn read16(&mut self, off: u32, now: u64) -> Option<u16> {
        use regs::sensing::*;
        if !decodes(&REGISTERS, off, false) {
            return None;
        }
        let done = self.done(now);
        Some(match off {
            regs::BOARD_ID => 0,
            LED_CTRL => self.led.bits(),
            LED_LEVEL => self.level_ma,
            TIMER => timer_at(now),
            LED_CURRENT => {
                let d = self.drive_state();
                self.optics
                    .sample(d, seconds(now))
                    .led_ma
                    .round()
                    .clamp(0.0, 65535.0) as u16
            }
            ADC_STATUS => {
                let mut s = AdcStatus::empty();
                if self.started.is_some() && !done {
                    s |= AdcStatus::BUSY;
                }
                if done {
                    s |= AdcStatus::EOC;
                    s.set(AdcStatus::OVER_X, adc_code(self.held.x_v).1);
                    s.set(AdcStatus::OVER_Y, adc_code(self.held.y_v).1);
                    s.set(AdcStatus::OVER_SUM, adc_code(self.held.sum_v).1);
                }
                s.bits()
            }
            // Data registers read the last completed conversion (0 before the first).
            ADC_X | ADC_Y | ADC_SUM => self.result(now).map_or(0, |a| {
                let v = match off {
                    ADC_X => a.x_v,
                    ADC_Y => a.y_v,
                    _ => a.sum_v,
                };
                adc_code(v).0
            }),
            _ => 0,
        })
    }

    fn write16(&mut self, off: u32, val: u16, now: u64) -> bool {
        use regs::sensing::*;
        if !decodes(&REGISTERS, off, true) {
            return false;
        }
        let before = self.drive_state();
        match off {
            LED_SELECT => self.select = (val & 7) as u8,
            LED_CTRL => self.led = LedCtrl::from_bits_truncate(val),
            LED_LEVEL => self.level_ma = val.min(LED_LEVEL_MAX_MA),
            ADC_CTRL if AdcCtrl::from_bits_truncate(val).contains(AdcCtrl::START) => {
                // Track-and-hold at the start of conversion; the previous result stays
                // readable until this one completes.
                self.previous = self.result(now);
                let d = self.drive_state();
                self.held = self.optics.sample(d, seconds(now));
                self.started = Some(now);
            }
            _ => {}
        }
        let after = self.drive_state();
        if after != before {
            self.optics.drive(after, seconds(now));
        }
        true
    }
}

/// The private I/O of `board` for image-mode boots with no world attached: the servo I/O
/// with motors at rest at 0, the sensing I/O with dark optics (no beacon lit).
pub fn standalone(board: BoardId) -> Box<dyn Device> {
    match board {
        BoardId::Servo => Box::new(ServoIo::new([0.0; 2])),
        BoardId::Sensing => Box::new(SensingIo::new(Dark)),
        b => Box::new(IdOnly::new(b)),
    }
}

/// Optics with nothing lit: every signal 0 V.
pub struct Dark;

impl Optics for Dark {
    fn sample(&mut self, _d: Drive, _t_s: f64) -> Analog {
        Analog::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use regs::sensing as sn;
    use regs::sensing::AdcStatus;
    use regs::servo as sv;
    use regs::servo::{AmpStatus, EncCtrl};

    const MS: u64 = CPU_HZ / 1000;

    #[test]
    fn undecoded_and_wrong_direction_accesses_are_refused() {
        let mut io = ServoIo::new([0.0; 2]);
        assert_eq!(io.read16(regs::UNDECODED_PROBE, 0), None);
        assert_eq!(io.read16(sv::DAC0, 0), None, "DACs are write-only");
        assert!(!io.write16(sv::TIMER, 1, 0), "the timer is read-only");
        assert!(io.write16(sv::AMP_CTRL, 3, 0));
        assert_eq!(io.read16(sv::AMP_CTRL, 0), Some(3));
        let mut planner = IdOnly::new(BoardId::Planner);
        assert_eq!(planner.read16(sv::TIMER, 0), None);
        assert_eq!(planner.read16(regs::BOARD_ID, 0), Some(0));
        assert_eq!(
            IdOnly::new(BoardId::Cspace2).read16(regs::BOARD_ID, 0),
            Some(2)
        );
        let mut s = SensingIo::new(Dark);
        assert_eq!(
            s.read16(sn::LED_SELECT, 0),
            None,
            "LED select is write-only"
        );
        assert!(!s.write16(sn::ADC_X, 0, 0));
    }

    #[test]
    fn the_timer_counts_at_2_mhz_and_wraps() {
        let mut io = ServoIo::new([0.0; 2]);
        let t = |io: &mut ServoIo, c| io.read16(sv::TIMER, c).unwrap();
        assert_eq!(t(&mut io, 0), 0);
        assert_eq!(t(&mut io, MS), 2000, "1 ms is 2000 counts");
        let wrap = (CPU_HZ * 65536).div_ceil(2_000_000);
        assert_eq!(t(&mut io, wrap), 0);
        assert_eq!(t(&mut io, wrap + MS), 2000);
    }

    #[test]
    fn encoders_latch_together_count_in_quadrature_and_wrap_at_16_bits() {
        let mut io = ServoIo::new([0.0; 2]);
        // Link 1: 32768 counts per link revolution; link 2: 8192.
        io.motors = [
            MotorSample {
                angle_rad: std::f64::consts::TAU / 4.0,
                rate_rad_s: 0.0,
                t_s: 0.0,
            },
            MotorSample {
                angle_rad: -std::f64::consts::TAU / 8.0,
                rate_rad_s: 0.0,
                t_s: 0.0,
            },
        ];
        // Nothing changes until the latch.
        assert_eq!(io.read16(sv::ENC0, 0), Some(0));
        assert!(io.write16(sv::ENC_CTRL, EncCtrl::LATCH.bits(), 0));
        assert_eq!(io.read16(sv::ENC0, 0), Some(8192));
        assert_eq!(io.read16(sv::ENC1, 0), Some((-1024i16) as u16));
        // Extrapolated to the access time: 1 rad/s for 1 ms on link 2 = 1.304 counts.
        io.motors[1] = MotorSample {
            angle_rad: 0.0,
            rate_rad_s: 1.0,
            t_s: 0.0,
        };
        io.write16(sv::ENC_CTRL, EncCtrl::LATCH.bits(), MS);
        assert_eq!(io.read16(sv::ENC1, 0), Some(1));
        // Two and a quarter link revolutions of link 1 = 73728 counts: wraps to 8192.
        io.motors[0].angle_rad = std::f64::consts::TAU * 2.25;
        io.write16(sv::ENC_CTRL, EncCtrl::LATCH.bits(), 0);
        assert_eq!(io.read16(sv::ENC0, 0), Some(8192));
        // Reset clears a counter.
        io.write16(sv::ENC_CTRL, (EncCtrl::RESET0 | EncCtrl::LATCH).bits(), 0);
        assert_eq!(io.read16(sv::ENC0, 0), Some(0));
    }

    #[test]
    fn dacs_drive_the_amplifiers_only_when_enabled() {
        let mut io = ServoIo::new([0.0; 2]);
        io.write16(sv::DAC0, 1024, 0);
        io.write16(sv::DAC1, (-2048i16 as u16) & 0x0FFF, 0);
        assert_eq!(io.amp_volts(), [0.0, 0.0], "amplifiers disabled at reset");
        io.write16(
            sv::AMP_CTRL,
            (AmpCtrl::ENABLE0 | AmpCtrl::ENABLE1).bits(),
            0,
        );
        assert_eq!(io.amp_volts(), [5.0, -10.0]);
        io.limit = [false, true];
        assert_eq!(io.read16(sv::AMP_STATUS, 0), Some(AmpStatus::LIMIT1.bits()));
    }

    struct Lit;
    impl Optics for Lit {
        fn sample(&mut self, d: Drive, _t: f64) -> Analog {
            if d.on {
                Analog {
                    x_v: d.beacon as f64,
                    y_v: -12.0,
                    sum_v: 5.0,
                    led_ma: d.level_ma as f64,
                }
            } else {
                Analog::default()
            }
        }
    }

    #[test]
    fn the_adc_converts_after_its_conversion_time_and_flags_over_range() {
        let mut s = SensingIo::new(Lit);
        let st = |s: &mut SensingIo<Lit>, now| {
            AdcStatus::from_bits_truncate(s.read16(sn::ADC_STATUS, now).unwrap())
        };
        assert!(st(&mut s, 0).is_empty(), "idle before the first start");
        s.write16(sn::LED_SELECT, 3, 0);
        s.write16(sn::LED_CTRL, LedCtrl::ENABLE.bits(), 0);
        assert_eq!(s.read16(sn::LED_CURRENT, 0), Some(560), "reset drive level");
        s.write16(sn::LED_LEVEL, 5000, 0);
        assert_eq!(
            s.read16(sn::LED_LEVEL, 0),
            Some(1000),
            "clamped to the driver's maximum"
        );
        s.write16(sn::LED_LEVEL, 500, 0);
        assert_eq!(s.read16(sn::LED_CURRENT, 0), Some(500));
        assert_eq!(
            s.read16(sn::TIMER, CPU_HZ / 1000),
            Some(2000),
            "2 MHz timer"
        );
        s.write16(sn::ADC_CTRL, regs::sensing::AdcCtrl::START.bits(), 100);
        let conv = (ADC_CONVERSION_S * CPU_HZ as f64).ceil() as u64;
        assert_eq!(st(&mut s, 100 + conv - 1), AdcStatus::BUSY);
        let done = st(&mut s, 100 + conv);
        assert!(done.contains(AdcStatus::EOC) && !done.contains(AdcStatus::BUSY));
        assert!(done.contains(AdcStatus::OVER_Y) && !done.contains(AdcStatus::OVER_X));
        assert_eq!(s.read16(sn::ADC_X, 100 + conv), Some(adc_code(3.0).0));
        assert_eq!(
            s.read16(sn::ADC_Y, 100 + conv),
            Some(0),
            "-12 V saturates at code 0"
        );
        // A second conversion: while it runs, the data registers keep the first result.
        s.write16(sn::LED_SELECT, 5, 100 + conv);
        s.write16(
            sn::ADC_CTRL,
            regs::sensing::AdcCtrl::START.bits(),
            100 + conv,
        );
        assert_eq!(st(&mut s, 100 + conv + 1), AdcStatus::BUSY);
        assert_eq!(s.read16(sn::ADC_X, 100 + conv + 1), Some(adc_code(3.0).0));
        assert_eq!(s.read16(sn::ADC_X, 100 + 2 * conv), Some(adc_code(5.0).0));
        // Before any conversion has completed the data registers read 0.
        let mut fresh = SensingIo::new(Lit);
        fresh.write16(sn::LED_CTRL, LedCtrl::ENABLE.bits(), 0);
        fresh.write16(sn::ADC_CTRL, regs::sensing::AdcCtrl::START.bits(), 0);
        assert_eq!(fresh.read16(sn::ADC_X, 1), Some(0));
        assert_eq!(adc_code(0.0).0, 2048);
        assert_eq!(adc_code(9.999).0, 4095);
        assert_eq!(adc_code(10.0), (4095, true));
    }
}
