//! Run-time correction of thermal drift (beyond the thesis, which had to recalibrate after
//! hours of warm-up; ch. II.3.4: offsets up to 18 mm).
//!
//! Drift is an offset and a gain change of each divided position signal. The robot's tip
//! carries a beacon at a position the encoders give to a few micrometres, so whenever the
//! arm rests, the tip's filtered signals can be compared with the signals the calibration
//! scan recorded at that position (the forward grid). Per axis the model is
//! `measured = expected + o + g * expected` (signals in Q5 codes about mid-scale, where the
//! optical axis is); `o` and `g` are learnt by normalised least-mean-squares with steps
//! 1/32 (offset) and 1/32 of the signal's full scale squared (gain), from one tip
//! observation every [`LEARN_EVERY_FRAMES`] strobe frames at rest (16 ms): a time constant
//! of 32 observations, 0.5 s of rest, for the offset. Thermal drift changes over minutes, so
//! the estimate follows it with room to spare; its own noise averages over the same 0.5 s
//! (each observation is the filter's 256-sample mean: consecutive frames' are nearly the
//! same). Learning from every frame, with steps 1/256, cost the 68020 a quarter of the
//! slot budget at rest (sin and cos of both links, the forward grid, the step: about 7,900
//! cycles a frame). Every beacon's signals are corrected before the inverse grid.
//!
//! Offset alone is observable from one resting place; the gain needs rests at different
//! places, which a working arm provides (the bench tours a few).

/// Strobe frames between the tip observations the estimate learns from while the arm
/// rests (the step sizes below are scaled to it: a power of two, [`LEARN_SHIFT`]).
pub const LEARN_EVERY_FRAMES: u32 = 1 << LEARN_SHIFT;
/// log2 of [`LEARN_EVERY_FRAMES`].
pub const LEARN_SHIFT: u32 = 3;

/// Largest offset accepted, Q5 codes (256 codes, about 50 mm): beyond it the estimate is
/// implausible and held.
pub const MAX_OFFSET_Q5: i32 = 256 << 5;
/// Largest gain error accepted, Q24 (5 %).
pub const MAX_GAIN_Q24: i32 = (1 << 24) / 20;

/// The drift estimate of both axes. `repr(C)`: `__sense_locate` (the runtime's assembly)
/// reads the offsets and the correction's factors at the offsets [`layout`] asserts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct Drift {
    /// Offsets, Q5 codes times 256 (the LMS accumulator).
    pub o_q13: [i32; 2],
    /// Gain errors, Q24.
    pub g_q24: [i32; 2],
    /// Observations used.
    pub observations: u32,
    /// The correction's factors, 1 / (1 + g) in Q14, set with the gains ([`Self::with`]):
    /// one product an axis where the correction runs (every beacon, every slot), the
    /// division once an observation.
    pub k_q14: [i32; 2],
}

impl Default for Drift {
    fn default() -> Self {
        Self::new()
    }
}

impl Drift {
    /// No drift learnt: offsets and gains 0.
    pub const fn new() -> Self {
        Self {
            o_q13: [0; 2],
            g_q24: [0; 2],
            observations: 0,
            k_q14: [1 << 14; 2],
        }
    }

    /// An estimate of offsets `o_q13` and gain errors `g_q24` (within +-[`MAX_GAIN_Q24`])
    /// from `observations`, with its correction factors.
    pub fn with(o_q13: [i32; 2], g_q24: [i32; 2], observations: u32) -> Self {
        Self {
            o_q13,
            g_q24,
            observations,
            k_q14: [factor_q14(g_q24[0]), factor_q14(g_q24[1])],
        }
    }

    /// The offsets, Q5 codes.
    pub fn offset_q5(&self) -> [i32; 2] {
        [self.o_q13[0] >> 8, self.o_q13[1] >> 8]
    }

    /// Removes the drift from measured signals.
    pub fn correct(&self, v_q5: [i32; 2]) -> [i32; 2] {
        [
            correct_axis(v_q5[0], self.o_q13[0], self.k_q14[0]),
            correct_axis(v_q5[1], self.o_q13[1], self.k_q14[1]),
        ]
    }

    /// Learns from one observation: the tip's measured signals and the signals the scan
    /// recorded at its true position. Returns 1 if the estimate hit its bounds
    /// (implausible: held at the bound), else 0 (an integer, not a `bool`: the 68k backend
    /// clobbered the flags of a branch on it; docs/toolchain.md class 1).
    pub fn observe(&mut self, measured_q5: [i32; 2], expected_q5: [i32; 2]) -> u32 {
        self.observations = self.observations.saturating_add(1);
        let a = observe_axis(
            &mut self.o_q13[0],
            &mut self.g_q24[0],
            measured_q5[0],
            expected_q5[0],
        );
        let b = observe_axis(
            &mut self.o_q13[1],
            &mut self.g_q24[1],
            measured_q5[1],
            expected_q5[1],
        );
        self.k_q14 = [factor_q14(self.g_q24[0]), factor_q14(self.g_q24[1])];
        a | b
    }
}

/// 1 / (1 + g) in Q14 for a gain error `g_q24` within +-[`MAX_GAIN_Q24`] (1 + g in Q14
/// between 15,565 and 17,203), rounded (`fx::div`: no compiled divide in firmware).
fn factor_q14(g_q24: i32) -> i32 {
    let one_plus_g_q14 = (1 << 14) + (g_q24 >> 10);
    fx::div((1 << 28) + (one_plus_g_q14 >> 1), one_plus_g_q14)
}

/// (v - o) / (1 + g) as (v - o) k >> 14, k = 1 / (1 + g) in Q14 (rounding k moves a signal
/// by under 2.3 Q5 codes; the second-order series this replaces needed two products). The
/// product fits 32 bits for the converter's signals (|v - o| < 2^17, k < 17,300); beyond,
/// it wraps, as the 68020's `MULS.L` does.
#[inline(always)]
fn correct_axis(v: i32, o_q13: i32, k_q14: i32) -> i32 {
    (v - (o_q13 >> 8)).wrapping_mul(k_q14) >> 14
}

/// One axis's LMS step; 1 if a bound clipped it, else 0.
#[inline(never)]
fn observe_axis(o_q13: &mut i32, g_q24: &mut i32, measured: i32, expected: i32) -> u32 {
    let r = measured - expected - (*o_q13 >> 8) - fx::mul_shr(*g_q24, expected, 24);
    // Offset step: r / 32 in Q5 is r << 3 in Q13.
    let o = *o_q13 + (r << LEARN_SHIFT);
    // Gain step: r * e / 2^11 in Q24 = (1/32) * r * e / (2^15)^2, 2^15 the Q5 half scale.
    let g = *g_q24 + fx::mul_shr(r, expected, 14 - LEARN_SHIFT);
    let lim_o = MAX_OFFSET_Q5 << 8;
    let oc = o.clamp(-lim_o, lim_o);
    let gc = g.clamp(-MAX_GAIN_Q24, MAX_GAIN_Q24);
    *o_q13 = oc;
    *g_q24 = gc;
    // Non-zero differences to 1 by sign arithmetic.
    let d = (oc ^ o) | (gc ^ g);
    ((d | d.wrapping_neg()) as u32) >> 31
}

/// Byte offsets of [`Drift`]'s fields, as `__sense_locate` in `crates/rt/asm/rt.S` has them.
pub mod layout {
    use super::Drift;
    use core::mem::offset_of;
    /// `o_q13` (two words).
    pub const O_Q13: usize = 0;
    /// `k_q14` (two words).
    pub const K_Q14: usize = 20;
    const _: () = assert!(offset_of!(Drift, o_q13) == O_Q13);
    const _: () = assert!(offset_of!(Drift, k_q14) == K_Q14);
}
