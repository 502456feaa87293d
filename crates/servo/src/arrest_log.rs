//! The arrest points of the last passes (thesis ch. III and V: the arrest point is where the
//! arm stops under full braking from where it is now), for a hold at the arrest point of the
//! moment an input went quiet rather than of the moment its silence was noticed.
//!
//! The servo: when the reflex dies, the servo notices only when its subgoal has not changed
//! for [`crate::STALE_S`] (or stayed torn), and meanwhile it drives on toward the last
//! subgoal; it holds at the arrest point of the last fresh subgoal, its own clock (the sum of
//! its pass periods, Q24 s) as the time. The reflex (`reflex`, thesis ch. V section 2): a
//! board that dies goes quiet, and the reflex can tell it from a slow one only after the
//! input's staleness limit (20-50 ms); it holds at the arrest point of the moment the input
//! went quiet, the servo's published time (us) as the time. (The arm then comes back along
//! the way it went; docs/reliability.md.)

/// Passes kept: 128, 43 ms of the servo at 3 kHz and 171 ms at the image's 750 Hz, beyond
/// the staleness limits (20 ms servo, at most 50 ms reflex) at either board's pass rate.
pub const PASSES: usize = 128;

/// A ring of (time, arrest point) of the last [`PASSES`] passes. Times are in any unit, a
/// wrapping `u32` clock; ages within the ring must stay below 2^31 of it.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct ArrestLog {
    n: u32,
    /// Entries kept, up to [`PASSES`].
    kept: u32,
    t: [u32; PASSES],
    arrest: [[i32; 2]; PASSES],
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
            t: [0; PASSES],
            arrest: [[0; 2]; PASSES],
            n: 0,
            kept: 0,
        }
    }

    /// Byte offsets of the fields, for `__servo_pass` (`servo::layout` asserts the values
    /// it uses).
    pub const N_OFFSET: usize = core::mem::offset_of!(ArrestLog, n);
    /// See [`ArrestLog::N_OFFSET`].
    pub const KEPT_OFFSET: usize = core::mem::offset_of!(ArrestLog, kept);
    /// See [`ArrestLog::N_OFFSET`].
    pub const T_OFFSET: usize = core::mem::offset_of!(ArrestLog, t);
    /// See [`ArrestLog::N_OFFSET`].
    pub const ARREST_OFFSET: usize = core::mem::offset_of!(ArrestLog, arrest);

    /// The time of the newest entry (0 when nothing was logged).
    pub fn newest_t(&self) -> u32 {
        self.t[(self.n.wrapping_sub(1) as usize) & (PASSES - 1)]
    }

    /// The ring as it lies in memory: the pass count, the entries kept, their times and
    /// arrest points (for the tests that lay a log out for the image's `__servo_at_age`).
    pub fn raw(&self) -> (u32, u32, &[u32; PASSES], &[[i32; 2]; PASSES]) {
        (self.n, self.kept, &self.t, &self.arrest)
    }

    /// Logs a pass's arrest point at time `t`. Not inlined: an array indexed through a
    /// reference in a function of its own (docs/toolchain.md, class 6).
    #[inline(never)]
    pub fn push(&mut self, t: u32, arrest: [i32; 2]) {
        let i = (self.n as usize) & (PASSES - 1);
        self.t[i] = t;
        self.arrest[i] = arrest;
        self.n = self.n.wrapping_add(1);
        // Up to PASSES without a compare (a compare and a branch drew a condition-code
        // clobber from LLVM's M68k backend; docs/toolchain.md).
        self.kept = self.kept + 1 - (self.kept >> 7);
    }

    /// The arrest point of the newest pass at least `age` before `now`; the oldest kept if
    /// none is that old; `fallback` if nothing was logged. On the 68020 one call of
    /// `__servo_at_age` (crates/rt/asm/servo.S: from the newest back to the first old
    /// enough, ~20 cycles an entry; this loop compiled took ~27,000 cycles, a hold's first
    /// pass over again), bit for bit the same (`the_arrest_log_look_up_matches_the_host`).
    pub fn at_age(&self, now: u32, age: u32, fallback: [i32; 2]) -> [i32; 2] {
        #[cfg(target_arch = "m68k")]
        {
            extern "C" {
                fn __servo_at_age(
                    log: *const ArrestLog,
                    now: u32,
                    age: u32,
                    fallback: *const [i32; 2],
                    out: *mut [i32; 2],
                );
            }
            let mut out = [0; 2];
            // SAFETY: the routine reads the log at the offsets `servo::layout` asserts and
            // `fallback`, and writes `out`.
            unsafe { __servo_at_age(self, now, age, &fallback, &mut out) };
            out
        }
        #[cfg(not(target_arch = "m68k"))]
        self.at_age_rust(now, age, fallback)
    }

    /// [`ArrestLog::at_age`] in Rust (the host's, and the reference for the image's): a
    /// fixed number of iterations and sign masks, no data-dependent exit (docs/toolchain.md).
    #[cfg_attr(target_arch = "m68k", allow(dead_code))]
    fn at_age_rust(&self, now: u32, age: u32, fallback: [i32; 2]) -> [i32; 2] {
        let kept = self.kept as i32;
        let (mut a0, mut a1) = (fallback[0], fallback[1]);
        let mut found = 0i32;
        let mut k = 0i32;
        while k < PASSES as i32 {
            let i = (self.n.wrapping_sub(1).wrapping_sub(k as u32) as usize) & (PASSES - 1);
            // All ones when entry k is kept, and when it is at least `age` old.
            let valid = (k - kept) >> 31;
            let old_enough = !((now.wrapping_sub(self.t[i]) as i32 - age as i32) >> 31);
            // The newest old enough, else the oldest kept (each valid entry overwrites until
            // one old enough is found).
            let take = valid & !found;
            a0 ^= (a0 ^ self.arrest[i][0]) & take;
            a1 ^= (a1 ^ self.arrest[i][1]) & take;
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
        assert_eq!(log.newest_t(), 299_000);
        // Newest pass at least 30 ms before t = 299 ms: t = 269 ms.
        assert_eq!(log.at_age(299_000, 30_000, [0, 0]), [269, -269]);
        assert_eq!(log.at_age(299_000, 0, [0, 0]), [299, -299]);
        assert_eq!(log.at_age(299_500, 30_000, [0, 0]), [269, -269]);
        assert_eq!(log.at_age(299_000, 30_500, [0, 0]), [268, -268]);
        // Older than the ring: the oldest kept.
        assert_eq!(log.at_age(299_000, 500_000, [0, 0]), [172, -172]);
        // Across the clock's wrap.
        let mut log = ArrestLog::new();
        for k in 0..50u32 {
            log.push((u32::MAX - 20_000).wrapping_add(1000 * k), [k as i32, 0]);
        }
        let now = (u32::MAX - 20_000).wrapping_add(49_000);
        assert_eq!(log.at_age(now, 10_000, [0, 0]), [39, 0]);
    }

    /// The servo's use: a clock that is the sum of the pass periods, ages from the newest.
    #[test]
    fn the_arrest_point_of_the_last_fresh_subgoal_by_pass_periods() {
        let mut log = ArrestLog::new();
        let ms = 16_777; // 1 ms in Q24 s
        for k in 0..300 {
            log.push(log.newest_t().wrapping_add(ms), [k, -k]);
        }
        let now = log.newest_t();
        assert_eq!(log.at_age(now, 0, [0, 0]), [299, -299]);
        assert_eq!(log.at_age(now, 20 * ms, [0, 0]), [279, -279]);
        assert_eq!(log.at_age(now, 20 * ms + ms / 2, [0, 0]), [278, -278]);
        assert_eq!(log.at_age(now, 400 * ms, [0, 0]), [172, -172]);
    }
}
