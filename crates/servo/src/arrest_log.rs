//! The arrest points of the servo's last passes (thesis ch. III and V: the arrest point is
//! where the arm stops under full braking from where it is now).
//!
//! When the reflex dies, the servo notices only when its subgoal has not changed for
//! [`crate::STALE_S`] (or stayed torn), and meanwhile it drives on toward the last subgoal. To
//! stop within the arrest distance it published *when the subgoals stopped*, it holds at the
//! arrest point of that moment, looked up here by the time since the last fresh subgoal.

/// Passes kept: 128, 43 ms at 3 kHz and 171 ms at the image's 750 Hz, beyond the 20 ms
/// staleness limit either way.
pub const PASSES: usize = 128;

/// A ring of (pass period, arrest point) of the last [`PASSES`] passes.
#[derive(Clone, Copy, Debug)]
pub struct ArrestLog {
    /// Pass periods, Q24 s (a 16-bit timer's longest period, 32.8 ms, times [`PASSES`]
    /// stays far inside 32 bits).
    dt_q24: [i32; PASSES],
    arrest_q16: [[i32; 2]; PASSES],
    n: u32,
    /// Entries kept, up to [`PASSES`].
    kept: u32,
}

impl Default for ArrestLog {
    fn default() -> Self {
        Self::new()
    }
}

impl ArrestLog {
    /// Nothing logged.
    pub const fn new() -> Self {
        Self {
            dt_q24: [0; PASSES],
            arrest_q16: [[0; 2]; PASSES],
            n: 0,
            kept: 0,
        }
    }

    /// Logs a pass's arrest point, `dt_q32` (Q32 s) after the previous pass. Not inlined: an
    /// array indexed through a reference in a function of its own (docs/toolchain.md).
    #[inline(never)]
    pub fn push(&mut self, dt_q32: i32, arrest_q16: [i32; 2]) {
        let i = (self.n as usize) & (PASSES - 1);
        self.dt_q24[i] = dt_q32 >> 8;
        self.arrest_q16[i] = arrest_q16;
        self.n = self.n.wrapping_add(1);
        // Up to PASSES without a compare (a compare and a branch drew a condition-code
        // clobber from LLVM's M68k backend here; docs/toolchain.md).
        self.kept = self.kept + 1 - (self.kept >> 7);
    }

    /// The arrest point of the newest pass at least `age_q32` (Q32 s) before the newest; the
    /// oldest kept if none is that old; `fallback` if nothing was logged. A fixed number of
    /// iterations and sign masks, no data-dependent exit (docs/toolchain.md).
    #[inline(never)]
    pub fn at_age(&self, age_q32: i32, fallback: [i32; 2]) -> [i32; 2] {
        let kept = self.kept as i32;
        let age_q24 = age_q32 >> 8;
        let (mut a0, mut a1) = (fallback[0], fallback[1]);
        let mut found = 0i32;
        let mut cum = 0i32;
        let mut k = 0i32;
        while k < PASSES as i32 {
            let i = (self.n.wrapping_sub(1).wrapping_sub(k as u32) as usize) & (PASSES - 1);
            let valid = (k - kept) >> 31;
            let old_enough = !((cum - age_q24) >> 31);
            let take = valid & !found;
            a0 ^= (a0 ^ self.arrest_q16[i][0]) & take;
            a1 ^= (a1 ^ self.arrest_q16[i][1]) & take;
            found |= valid & old_enough;
            cum += self.dt_q24[i];
            k += 1;
        }
        [a0, a1]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_arrest_point_of_the_last_fresh_subgoal() {
        let mut log = ArrestLog::new();
        assert_eq!(log.at_age(1 << 20, [5, 6]), [5, 6], "nothing logged");
        let ms = 16_777 << 8; // 1 ms in Q32 s, to the log's Q24
        for k in 0..300 {
            log.push(ms, [k, -k]);
        }
        assert_eq!(log.at_age(0, [0, 0]), [299, -299]);
        assert_eq!(log.at_age(20 * ms, [0, 0]), [279, -279]);
        assert_eq!(log.at_age(20 * ms + ms / 2, [0, 0]), [278, -278]);
        // Older than the ring: the oldest kept.
        assert_eq!(log.at_age(400 * ms, [0, 0]), [172, -172]);
    }
}
