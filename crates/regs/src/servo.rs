//! The servo board's private I/O (thesis ch. II: encoder counters, two DACs driving the PWM
//! current amplifiers, a 2 MHz 16-bit free-running counter).
//!
//! * Encoders: two 16-bit up/down quadrature counters (2048 lines x4 per motor revolution).
//!   Writing [`EncCtrl::LATCH`] to [`ENC_CTRL`] copies both counters into [`ENC0`]/[`ENC1`] in
//!   the same clock, so the two links are sampled together. Counters wrap modulo 2^16;
//!   firmware extends them by differencing successive latches.
//! * Timer: [`TIMER`] counts at 2 MHz and wraps modulo 2^16 (every 32.768 ms).
//! * DACs: [`DAC0`]/[`DAC1`] take a 12-bit two's-complement code in bits 0-11 (-2048..=2047
//!   for -10 V..+10 V x 2047/2048); the amplifier converts 1 A per volt. Outputs are driven only
//!   while the matching [`AmpCtrl`] enable bit is set; at reset both are off.
//! * Watchdog and brakes: every write of [`AMP_CTRL`] retriggers a hardware monostable of
//!   [`AMP_WATCHDOG_US`]. When it runs out (the servo's loop stopped) both enables drop and
//!   the joints' spring-applied brakes engage; the brakes are released only while the
//!   amplifiers are enabled and the watchdog is fed (so at reset, and whenever the firmware
//!   disables the amplifiers, the arm is braked). The safety net under the servo board
//!   (docs/reliability.md).

use crate::{Access, IoBus, Register};
use bitflags::bitflags;

/// Time after the last [`AMP_CTRL`] write at which the watchdog disables the amplifiers and
/// engages the brakes (microseconds). The servo writes [`AMP_CTRL`] every pass: its longest
/// image pass is under 2 ms (docs/performance.md).
pub const AMP_WATCHDOG_US: u32 = 2_500;

/// Encoder control (write): latch and reset strobes.
pub const ENC_CTRL: u32 = 0x10;
/// Latched count of encoder 0 (link 1 motor), read-only.
pub const ENC0: u32 = 0x14;
/// Latched count of encoder 1 (link 2 motor), read-only.
pub const ENC1: u32 = 0x16;
/// 2 MHz free-running 16-bit counter, read-only.
pub const TIMER: u32 = 0x20;
/// DAC 0 (link 1 amplifier), write-only.
pub const DAC0: u32 = 0x30;
/// DAC 1 (link 2 amplifier), write-only.
pub const DAC1: u32 = 0x32;
/// Amplifier enables, read-write.
pub const AMP_CTRL: u32 = 0x34;
/// Amplifier status, read-only.
pub const AMP_STATUS: u32 = 0x36;

/// Timer frequency.
pub const TIMER_HZ: u32 = 2_000_000;
/// Largest DAC code.
pub const DAC_MAX: i16 = 2047;
/// Smallest DAC code.
pub const DAC_MIN: i16 = -2048;
/// DAC full scale in millivolts (code 2048 would be this).
pub const DAC_FULL_SCALE_MV: i32 = 10_000;

/// The servo board's register table.
pub const REGISTERS: [Register; 9] = [
    Register {
        name: "BOARD_ID",
        offset: crate::BOARD_ID,
        access: Access::R,
    },
    Register {
        name: "ENC_CTRL",
        offset: ENC_CTRL,
        access: Access::W,
    },
    Register {
        name: "ENC0",
        offset: ENC0,
        access: Access::R,
    },
    Register {
        name: "ENC1",
        offset: ENC1,
        access: Access::R,
    },
    Register {
        name: "TIMER",
        offset: TIMER,
        access: Access::R,
    },
    Register {
        name: "DAC0",
        offset: DAC0,
        access: Access::W,
    },
    Register {
        name: "DAC1",
        offset: DAC1,
        access: Access::W,
    },
    Register {
        name: "AMP_CTRL",
        offset: AMP_CTRL,
        access: Access::RW,
    },
    Register {
        name: "AMP_STATUS",
        offset: AMP_STATUS,
        access: Access::R,
    },
];

bitflags! {
    /// Bits of [`ENC_CTRL`].
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub struct EncCtrl: u16 {
        /// Latch both counters into ENC0/ENC1.
        const LATCH = 1 << 0;
        /// Clear counter 0.
        const RESET0 = 1 << 1;
        /// Clear counter 1.
        const RESET1 = 1 << 2;
    }
}

bitflags! {
    /// Bits of [`AMP_CTRL`].
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub struct AmpCtrl: u16 {
        /// Amplifier 0 follows DAC0.
        const ENABLE0 = 1 << 0;
        /// Amplifier 1 follows DAC1.
        const ENABLE1 = 1 << 1;
    }
}

bitflags! {
    /// Bits of [`AMP_STATUS`].
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub struct AmpStatus: u16 {
        /// Amplifier 0 is in current limit.
        const LIMIT0 = 1 << 0;
        /// Amplifier 1 is in current limit.
        const LIMIT1 = 1 << 1;
    }
}

/// Typed access to the servo board's registers over any [`IoBus`].
pub struct ServoIo<B: IoBus> {
    bus: B,
}

impl<B: IoBus> ServoIo<B> {
    /// Wraps the board's private I/O bus.
    pub fn new(bus: B) -> Self {
        Self { bus }
    }
    /// The underlying bus.
    pub fn bus(&mut self) -> &mut B {
        &mut self.bus
    }
    /// Latches both encoders together and returns their raw 16-bit counts.
    pub fn latch_encoders(&mut self) -> [u16; 2] {
        self.bus.write16(ENC_CTRL, EncCtrl::LATCH.bits());
        [self.bus.read16(ENC0), self.bus.read16(ENC1)]
    }
    /// Reads the 2 MHz timer.
    pub fn timer(&mut self) -> u16 {
        self.bus.read16(TIMER)
    }
    /// Writes a DAC code (clamped to the 12-bit range) for link `link` (0 or 1).
    pub fn set_dac(&mut self, link: usize, code: i16) {
        let c = code.clamp(DAC_MIN, DAC_MAX) as u16 & 0x0FFF;
        self.bus.write16(if link == 0 { DAC0 } else { DAC1 }, c);
    }
    /// Sets the amplifier enables.
    pub fn set_amps(&mut self, ctrl: AmpCtrl) {
        self.bus.write16(AMP_CTRL, ctrl.bits());
    }
    /// Reads the amplifier status.
    pub fn amp_status(&mut self) -> AmpStatus {
        AmpStatus::from_bits_truncate(self.bus.read16(AMP_STATUS))
    }
    /// The safe state: both DACs at zero and both amplifiers disabled.
    pub fn safe(&mut self) {
        self.set_dac(0, 0);
        self.set_dac(1, 0);
        self.set_amps(AmpCtrl::empty());
    }
}

/// Sign-extends a 12-bit DAC register value to its code.
pub const fn dac_code(reg: u16) -> i16 {
    ((reg << 4) as i16) >> 4
}
