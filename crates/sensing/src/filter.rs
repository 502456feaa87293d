//! The per-beacon position filter (thesis ch. II.3.3: "a running average of the 32 most
//! recent signals"), made adaptive: a beacon that has rested for the whole of the last
//! [`LONG`] samples (0.5 s) gets their average, a third of the thesis filter's noise; any
//! other beacon gets the thesis's [`SHORT`]-sample average, with its 31 ms lag.
//!
//! Two windows, 32 and 256 samples, so the means are shifts (no division on the 68020).
//! Movement is detected when the short mean leaves the long one by more than [`MOVE_Q5`]
//! (28 codes: 6 standard deviations of their difference at the model's noise; in codes, so
//! the same everywhere in the field); the rest count restarts and the short window is used
//! until the long one again holds only samples since then. A beacon that creeps slower than
//! the threshold can show up to [`MOVE_Q5`] of extra lag (about 5 mm at the centre).

/// Largest window, samples (512 ms at 500 Hz per beacon).
pub const LONG: usize = 256;
/// The short window: the thesis's 32 samples (64 ms, 31 ms lag).
pub const SHORT: usize = 32;
/// Fewest samples behind a published valid position (16 ms after (re)acquisition).
pub const MIN_VALID: u16 = 8;
/// The movement threshold on |mean(short) - mean(since rest)|, Q5 codes.
pub const MOVE_Q5: i32 = 28 << 5;

const _: () = assert!(LONG == 256, "the ring index is a u8");

/// 2^16 / n for n = 0..=32 (0 for n = 0): the mean of a filling window without a division
/// (the 68020's budget is 4,175 cycles a slot).
const RECIP_Q16: [i32; 33] = recips();

const fn recips() -> [i32; 33] {
    let mut t = [0; 33];
    let mut n = 1;
    while n <= 32 {
        t[n] = (1 << 16) / n as i32;
        n += 1;
    }
    t
}

/// One axis of one beacon.
#[derive(Clone, Copy, Debug)]
pub struct Axis {
    ring: [i16; LONG],
    /// Sum of the last `SHORT` samples (fewer while filling), Q2.
    short: i32,
    /// Sum of the last `LONG` samples (fewer while filling), Q2.
    long: i32,
}

impl Axis {
    const fn new() -> Self {
        Self {
            ring: [0; LONG],
            short: 0,
            long: 0,
        }
    }
}

/// What the filter made of its samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Estimate {
    /// Position signal, Q5 codes.
    pub q5: [i32; 2],
    /// Samples averaged (saturating at 255).
    pub samples: u16,
    /// The beacon moved within the last [`LONG`] samples: the short window is in use.
    pub moving: bool,
    /// Fewer samples than the window in use can hold.
    pub filling: bool,
}

/// The filter of one beacon: two axes sharing a ring index and counts.
#[derive(Clone, Copy, Debug)]
pub struct Filter {
    axes: [Axis; 2],
    next: u8,
    count: u16,
    since: u16,
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
        }
    }

    /// Forgets every sample (after an invalid one: occlusion or saturation). The ring keeps
    /// its old words: the counts say none of them is in a window.
    pub fn reset(&mut self) {
        for a in self.axes.iter_mut() {
            a.short = 0;
            a.long = 0;
        }
        self.count = 0;
        self.since = 0;
    }

    /// Samples held (up to [`LONG`]).
    pub fn count(&self) -> u16 {
        self.count
    }

    /// Samples since the beacon last moved (up to [`LONG`]).
    pub fn since(&self) -> u16 {
        self.since
    }

    /// Adds one sample, Q2 codes per axis; with `adaptive`, checks for movement.
    pub fn push(&mut self, q2: [i32; 2], adaptive: bool) {
        let count = self.count as i32;
        // Masks, not branches: all ones when the window was full before this sample.
        let full_short = (SHORT as i32 - 1 - count) >> 31;
        let full_long = (LONG as i32 - 1 - count) >> 31;
        push_axis(&mut self.axes[0], self.next, q2[0], full_short, full_long);
        push_axis(&mut self.axes[1], self.next, q2[1], full_short, full_long);
        self.next = self.next.wrapping_add(1);
        if (self.count as usize) < LONG {
            self.count += 1;
        }
        if (self.since as usize) < LONG {
            self.since += 1;
        }
        if adaptive && self.count as usize == LONG {
            let moved = moved_axis(&self.axes[0]) | moved_axis(&self.axes[1]);
            // Start counting the rest again (by mask: docs/toolchain.md class 1).
            let m = (moved as u16).wrapping_neg();
            self.since &= !m;
        }
    }

    /// The estimate, or `None` with fewer than [`MIN_VALID`] samples: the long window for a
    /// beacon that has rested for all of it (with `adaptive`), else the thesis's 32 (fewer
    /// while filling).
    pub fn estimate(&self, adaptive: bool) -> Option<Estimate> {
        let n = self.count;
        if n < MIN_VALID {
            return None;
        }
        let long = adaptive && self.since as usize >= LONG;
        let window = if long {
            LONG as u16
        } else {
            n.min(SHORT as u16)
        };
        Some(Estimate {
            q5: [
                axis_mean(&self.axes[0], window as i32),
                axis_mean(&self.axes[1], window as i32),
            ],
            samples: window.min(255),
            moving: adaptive && !long && n as usize >= LONG,
            filling: if adaptive {
                !long && (n as usize) < LONG
            } else {
                (window as usize) < SHORT
            },
        })
    }
}

/// One axis's update: both windows gain the sample and lose the one leaving them (masks
/// say whether they were full). (A function of its own: the ring is indexed through a
/// reference, not a local array; docs/toolchain.md class 6.)
#[inline(never)]
fn push_axis(a: &mut Axis, next: u8, v: i32, full_short: i32, full_long: i32) {
    let old_short = a.ring[next.wrapping_sub(SHORT as u8) as usize] as i32;
    let old_long = a.ring[next as usize] as i32;
    a.short += v - (old_short & full_short);
    a.long += v - (old_long & full_long);
    a.ring[next as usize] = v as i16;
}

/// The mean of the last `n` samples of an axis, Q5 (`n` = 256, 32, or fewer than 32).
#[inline(never)]
fn axis_mean(a: &Axis, n: i32) -> i32 {
    if n == LONG as i32 {
        // A Q2 sum of 256 is Q10.
        return a.long >> 5;
    }
    if n == SHORT as i32 {
        // A Q2 sum of 32 is Q7.
        return a.short >> 2;
    }
    // Q2 sum times 2^16 / n, to Q5: the sum (< 2^18) shifted down first keeps the product
    // inside 32 bits.
    ((a.short >> 2) * RECIP_Q16[n as usize]) >> 11
}

/// Whether the short mean left the long one by more than the threshold.
#[inline(never)]
fn moved_axis(a: &Axis) -> bool {
    let d = (a.short >> 2) - (a.long >> 5);
    let m = d >> 31;
    ((d ^ m) - m) > MOVE_Q5
}
