//! The sensing board's private I/O (thesis ch. II.3: LED strobe driver, the analog
//! sum/difference/divide chain and its A/D converters).
//!
//! * LEDs: [`LED_SELECT`] picks one of the 8 beacons; [`LedCtrl::ENABLE`] in [`LED_CTRL`]
//!   turns the selected beacon's LED on. [`LED_CURRENT`] reads back the drive current
//!   (the feedback the thesis proposed against intensity differences), in mA.
//!   [`LED_LEVEL`] sets the drive current for the selected beacon's next pulses, mA
//!   (0..=[`LED_LEVEL_MAX_MA`], [`LED_LEVEL_RESET_MA`] after reset: the thesis's 560 mA).
//! * Timer: [`TIMER`] counts at 2 MHz and wraps modulo 2^16, like the servo board's.
//! * The position and sum signals pass a first-order analog filter of [`FILTER_TAU_US`]
//!   before the converters; a track-and-hold captures all three at the start of conversion.
//! * A/D: writing [`AdcCtrl::START`] to [`ADC_CTRL`] starts simultaneous 12-bit conversions of
//!   the x and y position signals and the sum (intensity) signal. [`AdcStatus::BUSY`] is set
//!   for the conversion time, then [`AdcStatus::EOC`] until the next start. Data registers are
//!   offset binary 0..=4095 (2048 = centre); an input beyond the converter's range reads as
//!   0 or 4095 and sets its `OVER_*` bit.

use crate::{Access, IoBus, Register};
use bitflags::bitflags;

/// Beacon select (0..=7), write-only.
pub const LED_SELECT: u32 = 0x10;
/// LED control, read-write.
pub const LED_CTRL: u32 = 0x12;
/// LED drive current read-back in mA, read-only.
pub const LED_CURRENT: u32 = 0x14;
/// LED drive current set point in mA, read-write.
pub const LED_LEVEL: u32 = 0x16;
/// 2 MHz free-running counter, read-only.
pub const TIMER: u32 = 0x30;
/// Counts per second of [`TIMER`] (the same counter as the servo board's).
pub const TIMER_HZ: u32 = crate::servo::TIMER_HZ;
/// Largest LED drive current the driver delivers, mA.
pub const LED_LEVEL_MAX_MA: u16 = 1000;
/// LED drive current after reset, mA (the thesis's pulse current).
pub const LED_LEVEL_RESET_MA: u16 = 560;
/// Time constant of the analog filters in front of the converters, microseconds (thesis
/// ch. II.3.2).
pub const FILTER_TAU_US: u32 = 40;
/// A/D conversion time, microseconds (a 12-bit successive-approximation converter).
pub const ADC_CONVERSION_US: u32 = 25;

/// A/D control, write-only.
pub const ADC_CTRL: u32 = 0x20;
/// A/D status, read-only.
pub const ADC_STATUS: u32 = 0x22;
/// X position conversion, read-only.
pub const ADC_X: u32 = 0x24;
/// Y position conversion, read-only.
pub const ADC_Y: u32 = 0x26;
/// Sum (intensity) conversion, read-only.
pub const ADC_SUM: u32 = 0x28;

/// Largest A/D code.
pub const ADC_MAX: u16 = 4095;

/// The sensing board's register table.
pub const REGISTERS: [Register; 11] = [
    Register {
        name: "BOARD_ID",
        offset: crate::BOARD_ID,
        access: Access::R,
    },
    Register {
        name: "LED_SELECT",
        offset: LED_SELECT,
        access: Access::W,
    },
    Register {
        name: "LED_CTRL",
        offset: LED_CTRL,
        access: Access::RW,
    },
    Register {
        name: "LED_CURRENT",
        offset: LED_CURRENT,
        access: Access::R,
    },
    Register {
        name: "LED_LEVEL",
        offset: LED_LEVEL,
        access: Access::RW,
    },
    Register {
        name: "ADC_CTRL",
        offset: ADC_CTRL,
        access: Access::W,
    },
    Register {
        name: "ADC_STATUS",
        offset: ADC_STATUS,
        access: Access::R,
    },
    Register {
        name: "ADC_X",
        offset: ADC_X,
        access: Access::R,
    },
    Register {
        name: "ADC_Y",
        offset: ADC_Y,
        access: Access::R,
    },
    Register {
        name: "ADC_SUM",
        offset: ADC_SUM,
        access: Access::R,
    },
    Register {
        name: "TIMER",
        offset: TIMER,
        access: Access::R,
    },
];

bitflags! {
    /// Bits of [`LED_CTRL`].
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub struct LedCtrl: u16 {
        /// The selected beacon's LED is on.
        const ENABLE = 1 << 0;
    }
}

bitflags! {
    /// Bits of [`ADC_CTRL`].
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub struct AdcCtrl: u16 {
        /// Start a conversion of all three channels.
        const START = 1 << 0;
    }
}

bitflags! {
    /// Bits of [`ADC_STATUS`].
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub struct AdcStatus: u16 {
        /// Conversion complete, data valid.
        const EOC = 1 << 0;
        /// Conversion in progress.
        const BUSY = 1 << 1;
        /// X input beyond the converter's range.
        const OVER_X = 1 << 2;
        /// Y input beyond the converter's range.
        const OVER_Y = 1 << 3;
        /// Sum input beyond the converter's range.
        const OVER_SUM = 1 << 4;
    }
}

/// One completed conversion.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sample {
    /// X code.
    pub x: u16,
    /// Y code.
    pub y: u16,
    /// Sum code.
    pub sum: u16,
    /// Status at completion (over-range bits).
    pub status: AdcStatus,
}

/// Typed access to the sensing board's registers over any [`IoBus`].
pub struct SensingIo<B: IoBus> {
    bus: B,
}

impl<B: IoBus> SensingIo<B> {
    /// Wraps the board's private I/O bus.
    pub fn new(bus: B) -> Self {
        Self { bus }
    }
    /// The underlying bus.
    pub fn bus(&mut self) -> &mut B {
        &mut self.bus
    }
    /// Selects beacon `n` (0..=7) and turns its LED on or off.
    pub fn strobe(&mut self, n: u16, on: bool) {
        self.bus.write16(LED_SELECT, n & 7);
        let c = if on {
            LedCtrl::ENABLE
        } else {
            LedCtrl::empty()
        };
        self.bus.write16(LED_CTRL, c.bits());
    }
    /// Sets the drive current for the selected beacon's pulses, mA (clamped by the driver
    /// to [`LED_LEVEL_MAX_MA`]).
    pub fn set_level_ma(&mut self, ma: u16) {
        self.bus.write16(LED_LEVEL, ma);
    }
    /// Reads the 2 MHz timer.
    pub fn timer(&mut self) -> u16 {
        self.bus.read16(TIMER)
    }
    /// Starts a conversion.
    pub fn start_conversion(&mut self) {
        self.bus.write16(ADC_CTRL, AdcCtrl::START.bits());
    }
    /// The A/D status.
    pub fn status(&mut self) -> AdcStatus {
        AdcStatus::from_bits_truncate(self.bus.read16(ADC_STATUS))
    }
    /// The conversion, if one has completed since the last start.
    pub fn sample(&mut self) -> Option<Sample> {
        let status = self.status();
        if !status.contains(AdcStatus::EOC) {
            return None;
        }
        Some(Sample {
            x: self.bus.read16(ADC_X) & ADC_MAX,
            y: self.bus.read16(ADC_Y) & ADC_MAX,
            sum: self.bus.read16(ADC_SUM) & ADC_MAX,
            status,
        })
    }
    /// The LED drive current in mA.
    pub fn led_current_ma(&mut self) -> u16 {
        self.bus.read16(LED_CURRENT)
    }
    /// The safe state: all LEDs off.
    pub fn safe(&mut self) {
        self.bus.write16(LED_CTRL, 0);
    }
}
