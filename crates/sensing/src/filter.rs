//! The per-beacon position filter (thesis ch. II.3.3: "a running average of the 32 most
//! recent signals"), made adaptive: a beacon that rests gets the average of every sample
//! since it came to rest, up to [`LONG`] (a third of the thesis filter's noise once full),
//! and a beacon that moves gets the thesis's [`SHORT`]-sample average (the same 31 ms lag).
//!
//! Movement is detected when the short mean leaves the mean since rest by more than
//! [`MOVE_Q5`] (28 codes: 6 standard deviations of their difference at the model's noise;
//! in codes, so the same everywhere in the field); the long window then restarts from the
//! short one and grows again, and is published once no movement has been found for
//! [`MOVING_HOLD`] samples (until then the short window is). Means use a table of
//! reciprocals, not divisions (the 68020's slot budget). A beacon that creeps so slowly
//! that it is not found moving again within [`MOVING_HOLD`] samples can show up to
//! [`MOVE_Q5`] of extra lag (about 5 mm at the centre) between detections.

/// Largest window, samples (512 ms at 500 Hz per beacon).
pub const LONG: usize = 256;
/// The short window: the thesis's 32 samples (64 ms, 31 ms lag).
pub const SHORT: usize = 32;
/// Fewest samples behind a published valid position (16 ms after (re)acquisition).
pub const MIN_VALID: u16 = 8;
/// Samples the moving flag is held after the last movement found (0.26 s at 500 Hz). The
/// movement check fires again only once the short mean has left the mean since the last
/// detection by the threshold, so a beacon in steady motion is found moving only every so
/// often; held for [`SHORT`] samples alone, the flag lapsed in between, the beacon was
/// published from the long window up to 12 mm behind and the C-space board drew it unswept
/// (docs/reflex.md). Measured by `sim-host campaign reflex --moving 500 --seed 1`: scenes
/// with collisions 45 at 32 samples, 31 at 64, 27 at 96, 128, 192 and 256. While the flag
/// is up the estimate is the short window's (since 2026-11-27; before, the window since
/// the last detection once it held more than [`SHORT`] samples).
pub const MOVING_HOLD: u16 = 128;
/// Where `moved` starts in a fresh or reset filter: flagged moving for its first
/// [`SHORT`] samples.
const MOVED_FRESH: u16 = MOVING_HOLD - SHORT as u16;
/// The movement threshold on |mean(short) - mean(since rest)|, Q5 codes.
pub const MOVE_Q5: i32 = 28 << 5;

const _: () = assert!(LONG == 256, "the ring index is a u8");

/// 2^16 / n for n = 0..=256 (0 for n = 0): means of any window without a division (the
/// 68020's budget is 4,175 cycles a slot).
pub const RECIP_Q16: [i32; LONG + 1] = recips();

const fn recips() -> [i32; LONG + 1] {
    let mut t = [0; LONG + 1];
    let mut n = 1;
    while n <= LONG {
        t[n] = (1 << 16) / n as i32;
        n += 1;
    }
    t
}

/// One axis of one beacon. `repr(C)`: the 68020's `__sense_filter` (the runtime's assembly)
/// reads it at the offsets [`layout`] asserts.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct Axis {
    ring: [i16; LONG],
    /// Sum of the last `SHORT` samples (fewer while filling), Q2.
    short: i32,
    /// Sum of the last `since` samples, Q2.
    since: i32,
}

impl Axis {
    const fn new() -> Self {
        Self {
            ring: [0; LONG],
            short: 0,
            since: 0,
        }
    }
}

/// What the filter made of its samples. `repr(C)`: `__sense_filter` writes it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct Estimate {
    /// Position signal, Q5 codes.
    pub q5: [i32; 2],
    /// Samples averaged (saturating at 255).
    pub samples: u16,
    /// The beacon moved within the last [`MOVING_HOLD`] samples (a fresh filter: its first
    /// [`SHORT`]).
    pub moving: bool,
    /// Fewer samples than the window in use can hold.
    pub filling: bool,
}

/// The filter of one beacon: two axes sharing a ring index and counts. `repr(C)`:
/// `__sense_filter` updates it.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct Filter {
    axes: [Axis; 2],
    next: u8,
    count: u16,
    since: u16,
    moved: u16,
}

impl Default for Filter {
    fn default() -> Self {
        Self::new()
    }
}

impl Filter {
    /// An empty filter.
    pub const fn new() -> Self {
        Self {
            axes: [Axis::new(), Axis::new()],
            next: 0,
            count: 0,
            since: 0,
            moved: MOVED_FRESH,
        }
    }

    /// Forgets every sample (after an invalid one: occlusion or saturation). The ring keeps
    /// its old words: the counts say none of them is in a window.
    pub fn reset(&mut self) {
        for a in self.axes.iter_mut() {
            a.short = 0;
            a.since = 0;
        }
        self.count = 0;
        self.since = 0;
        self.moved = MOVED_FRESH;
    }

    /// The filter as the 68020 holds it in memory (`repr(C)`, big-endian): for the tests
    /// that run `__sense_filter` on the emulated CPU against this code.
    pub fn to_be_bytes(&self) -> [u8; layout::FILTER_BYTES] {
        use core::mem::{offset_of, size_of};
        let mut b = [0u8; layout::FILTER_BYTES];
        let mut put = |at: usize, bytes: &[u8]| b[at..at + bytes.len()].copy_from_slice(bytes);
        for (k, a) in self.axes.iter().enumerate() {
            let o = offset_of!(Filter, axes) + k * size_of::<Axis>();
            for (i, v) in a.ring.iter().enumerate() {
                put(o + offset_of!(Axis, ring) + 2 * i, &v.to_be_bytes());
            }
            put(o + offset_of!(Axis, short), &a.short.to_be_bytes());
            put(o + offset_of!(Axis, since), &a.since.to_be_bytes());
        }
        put(offset_of!(Filter, next), &[self.next]);
        put(offset_of!(Filter, count), &self.count.to_be_bytes());
        put(offset_of!(Filter, since), &self.since.to_be_bytes());
        put(offset_of!(Filter, moved), &self.moved.to_be_bytes());
        b
    }

    /// Samples held (up to [`LONG`]).
    pub fn count(&self) -> u16 {
        self.count
    }

    /// Adds one sample, Q2 codes per axis; with `adaptive`, checks for movement.
    pub fn push(&mut self, q2: [i32; 2], adaptive: bool) {
        // Masks, not branches: all ones when the window was full before this sample.
        let full_short = (SHORT as i32 - 1 - self.count as i32) >> 31;
        let full_since = (LONG as i32 - 1 - self.since as i32) >> 31;
        push_axis(&mut self.axes[0], self.next, q2[0], full_short, full_since);
        push_axis(&mut self.axes[1], self.next, q2[1], full_short, full_since);
        self.next = self.next.wrapping_add(1);
        if (self.count as usize) < LONG {
            self.count += 1;
        }
        if (self.since as usize) < LONG {
            self.since += 1;
        }
        self.moved = self.moved.saturating_add(1);
        if adaptive && self.since as usize > SHORT {
            let n = self.since as i32;
            let moved = moved_axis(&self.axes[0], n) | moved_axis(&self.axes[1], n);
            // Restart the long window from the short one (by mask: docs/toolchain.md
            // class 1).
            let m = (moved as i32).wrapping_neg();
            for a in self.axes.iter_mut() {
                a.since = (a.short & m) | (a.since & !m);
            }
            let m16 = m as u16;
            self.since = (SHORT as u16 & m16) | (self.since & !m16);
            self.moved &= !m16;
        }
    }

    /// [`Self::push`] then [`Self::estimate`], into `out`; false (and `out` untouched) with
    /// fewer than [`MIN_VALID`] samples. One call of `__sense_filter` on the 68020 (the
    /// runtime's assembly, bit-identical: the compiled pair cost 1,500 cycles of the
    /// 4,175-cycle slot, the assembly about 400), these two functions on the host.
    #[inline]
    pub fn push_estimate(&mut self, q2: [i32; 2], adaptive: bool, out: &mut Estimate) -> bool {
        #[cfg(target_arch = "m68k")]
        {
            extern "C" {
                fn __sense_filter(
                    f: *mut Filter,
                    qx: i32,
                    qy: i32,
                    adaptive: u32,
                    out: *mut Estimate,
                    recip_q16: *const i32,
                ) -> u32;
            }
            // SAFETY: the routine reads and writes only `*self` and `*out` at the offsets
            // `layout` asserts, and reads the 257 words of the reciprocal table.
            unsafe {
                __sense_filter(self, q2[0], q2[1], adaptive as u32, out, RECIP_Q16.as_ptr()) != 0
            }
        }
        #[cfg(not(target_arch = "m68k"))]
        {
            self.push(q2, adaptive);
            match self.estimate(adaptive) {
                Some(e) => {
                    *out = e;
                    true
                }
                None => false,
            }
        }
    }

    /// The estimate, or `None` with fewer than [`MIN_VALID`] samples: with `adaptive` and
    /// no movement found for [`MOVING_HOLD`] samples, the mean of every sample since the
    /// beacon last moved (up to [`LONG`]); else, or when that is fewer than 32, the
    /// thesis's 32 (fewer while filling).
    pub fn estimate(&self, adaptive: bool) -> Option<Estimate> {
        let n = self.count;
        if n < MIN_VALID {
            return None;
        }
        // The long window only once the beacon has rested for MOVING_HOLD samples: while
        // it moves, the window since the last detection grows between detections and its
        // mean falls behind by up to the threshold (a disk circling at 66 mm/s was
        // published 12 mm behind, flagged moving; docs/sensing.md).
        let moving = self.moved < MOVING_HOLD;
        let long = adaptive && self.since as usize > SHORT && !moving;
        let window = if long {
            self.since
        } else {
            n.min(SHORT as u16)
        };
        let q5 = if long {
            [
                since_mean(&self.axes[0], window as i32),
                since_mean(&self.axes[1], window as i32),
            ]
        } else {
            [
                short_mean(&self.axes[0], window as i32),
                short_mean(&self.axes[1], window as i32),
            ]
        };
        Some(Estimate {
            q5,
            samples: window.min(255),
            moving: adaptive && moving,
            filling: if adaptive {
                (window as usize) < LONG
            } else {
                (window as usize) < SHORT
            },
        })
    }
}

/// Byte offsets of the filter's fields, as the assembly (`__sense_filter` in
/// `crates/rt/asm/rt.S`) uses them: checked here at compile time.
pub mod layout {
    use super::{Axis, Estimate, Filter};
    use core::mem::{offset_of, size_of};
    const _: () = assert!(offset_of!(Axis, ring) == 0);
    const _: () = assert!(offset_of!(Axis, short) == 512);
    const _: () = assert!(offset_of!(Axis, since) == 516);
    const _: () = assert!(size_of::<Axis>() == 520);
    const _: () = assert!(offset_of!(Filter, axes) == 0);
    const _: () = assert!(offset_of!(Filter, next) == 1040);
    const _: () = assert!(offset_of!(Filter, count) == 1042);
    const _: () = assert!(offset_of!(Filter, since) == 1044);
    const _: () = assert!(offset_of!(Filter, moved) == 1046);
    /// Bytes of one filter.
    pub const FILTER_BYTES: usize = 1048;
    const _: () = assert!(size_of::<Filter>() == FILTER_BYTES);
    const _: () = assert!(offset_of!(Estimate, q5) == 0);
    const _: () = assert!(offset_of!(Estimate, samples) == 8);
    const _: () = assert!(offset_of!(Estimate, moving) == 10);
    const _: () = assert!(offset_of!(Estimate, filling) == 11);
    /// Bytes of one estimate.
    pub const ESTIMATE_BYTES: usize = 12;
    const _: () = assert!(size_of::<Estimate>() == ESTIMATE_BYTES);
}

/// One axis's update: both windows gain the sample and lose the one leaving them (masks
/// say whether they were full). (A function of its own: the ring is indexed through a
/// reference, not a local array; docs/toolchain.md class 6.)
#[inline(always)]
fn push_axis(a: &mut Axis, next: u8, v: i32, full_short: i32, full_since: i32) {
    let old_short = a.ring[next.wrapping_sub(SHORT as u8) as usize] as i32;
    let old_long = a.ring[next as usize] as i32;
    a.short += v - (old_short & full_short);
    a.since += v - (old_long & full_since);
    a.ring[next as usize] = v as i16;
}

/// The mean of the last `n` (<= 32) samples of an axis, Q5.
#[inline(always)]
fn short_mean(a: &Axis, n: i32) -> i32 {
    // A Q2 sum of 32 is Q7; fewer: the sum times 2^16 / n, shifted down first to stay
    // inside 32 bits (|sum| < 2^18).
    let full = ((SHORT as i32 - 1 - n) >> 31) & 1;
    let exact = a.short >> 2;
    let filling = ((a.short >> 2) * RECIP_Q16[n as usize]) >> 11;
    exact * full + filling * (1 - full)
}

/// The mean of the `n` samples since the last movement (32 < n <= 256), Q5: the Q2 sum
/// (|sum| < 2^21) shifted down 3, times 2^16 / n (< 2^11), shifted down 10.
#[inline(always)]
fn since_mean(a: &Axis, n: i32) -> i32 {
    ((a.since >> 3) * RECIP_Q16[n as usize]) >> 10
}

/// Whether the short mean left the mean since the last movement by more than the threshold.
#[inline(always)]
fn moved_axis(a: &Axis, n: i32) -> bool {
    let d = (a.short >> 2) - since_mean(a, n);
    let m = d >> 31;
    ((d ^ m) - m) > MOVE_Q5
}
