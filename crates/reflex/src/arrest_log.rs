//! The arrest points of the last passes (thesis ch. V section 2: the arrest point is where
//! the arm stops under full braking from where it is now).
//!
//! A board that dies goes quiet: the reflex can tell it from a slow one only when its input
//! has not moved for the input's staleness limit (20-50 ms, sized for the images' real loop
//! rates), and meanwhile the arm moves on under the last commands. To stop within the arrest
//! distance the servo published *when the input failed*, not when its silence was noticed,
//! the reflex holds at the arrest point of that moment, looked up here. (The arm then comes
//! back along the way it went; docs/reliability.md.)

use crate::masks;

/// Passes kept: at least the longest staleness limit (50 ms) at the fastest pass rate.
pub const PASSES: usize = 128;

/// A ring of (servo time, arrest point) of the last [`PASSES`] passes.
#[derive(Clone, Copy, Debug)]
pub struct ArrestLog {
    t_us: [u32; PASSES],
    arrest_urad: [[i32; 2]; PASSES],
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
            t_us: [0; PASSES],
            arrest_urad: [[0; 2]; PASSES],
            n: 0,
            kept: 0,
        }
    }

    /// Logs this pass's arrest point at servo time `t_us`. Not inlined: an array indexed
    /// through a reference in a function of its own (docs/toolchain.md, class 6).
    #[inline(never)]
    pub fn push(&mut self, t_us: u32, arrest_urad: [i32; 2]) {
        let i = (self.n as usize) & (PASSES - 1);
        self.t_us[i] = t_us;
        self.arrest_urad[i] = arrest_urad;
        self.n = self.n.wrapping_add(1);
        // Up to PASSES without a compare (a compare and a branch drew a condition-code
        // clobber from LLVM's M68k backend; docs/toolchain.md).
        self.kept = self.kept + 1 - (self.kept >> 7);
    }

    /// The arrest point of the newest pass at least `age_us` before `now_us`; the oldest
    /// kept if none is that old; `fallback` if nothing was logged. A fixed number of
    /// iterations and sign masks, no data-dependent exit (docs/toolchain.md).
    #[inline(never)]
    pub fn at_age(&self, now_us: u32, age_us: u32, fallback: [i32; 2]) -> [i32; 2] {
        let kept = self.kept as i32;
        let (mut a0, mut a1) = (fallback[0], fallback[1]);
        let mut found = 0i32;
        let mut k = 0i32;
        while k < PASSES as i32 {
            let i = (self.n.wrapping_sub(1).wrapping_sub(k as u32) as usize) & (PASSES - 1);
            let valid = masks::lt(k, kept);
            let age = now_us.wrapping_sub(self.t_us[i]) as i32;
            let old_enough = !masks::lt(age, age_us as i32);
            // The newest old enough, else the oldest kept (each valid entry overwrites until
            // one old enough is found).
            let take = valid & !found;
            a0 = masks::pick(take, self.arrest_urad[i][0], a0);
            a1 = masks::pick(take, self.arrest_urad[i][1], a1);
            found |= valid & old_enough;
            k += 1;
        }
        [a0, a1]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_arrest_point_of_the_moment_an_input_went_quiet() {
        let mut log = ArrestLog::new();
        assert_eq!(log.at_age(1000, 30, [7, 8]), [7, 8], "nothing logged");
        for k in 0..300u32 {
            log.push(1000 * k, [k as i32, -(k as i32)]);
        }
        // Newest pass at least 30 ms before t = 299 ms: t = 269 ms.
        assert_eq!(log.at_age(299_000, 30_000, [0, 0]), [269, -269]);
        assert_eq!(log.at_age(299_000, 0, [0, 0]), [299, -299]);
        assert_eq!(log.at_age(299_500, 30_000, [0, 0]), [269, -269]);
        // Older than the ring: the oldest kept.
        assert_eq!(log.at_age(299_000, 500_000, [0, 0]), [172, -172]);
        // Across the servo clock's wrap.
        let mut log = ArrestLog::new();
        for k in 0..50u32 {
            log.push((u32::MAX - 20_000).wrapping_add(1000 * k), [k as i32, 0]);
        }
        let now = (u32::MAX - 20_000).wrapping_add(49_000);
        assert_eq!(log.at_age(now, 10_000, [0, 0]), [39, 0]);
    }
}
