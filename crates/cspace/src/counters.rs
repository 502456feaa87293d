//! The per-pixel counters of the gray-level map (thesis ch. IV section 6, lines ~1199-1210):
//! four one-byte counters in a big-endian word, one per outward edge-normal direction. Drawing
//! an image increments, erasing decrements. Four counters are updated at once with one 32-bit
//! add when no byte can carry (every byte below 128); otherwise byte by byte, and a counter
//! that would pass [`SATURATED`] stays there for good ("sticky": it is never decremented
//! again, so an over-drawn pixel can only stay occupied) and the update reports it.

use vme_map::layout::{counter_fast, counter_plain};

/// Counter byte of the +theta1 edge normal (most significant byte).
pub const P1: u32 = 0x0100_0000;
/// Counter byte of the -theta1 edge normal.
pub const M1: u32 = 0x0001_0000;
/// Counter byte of the +theta2 edge normal.
pub const P2: u32 = 0x0000_0100;
/// Counter byte of the -theta2 edge normal (least significant byte).
pub const M2: u32 = 0x0000_0001;
/// All four counters: a pixel inside an image, repelled every way.
pub const ALL: u32 = P1 | M1 | P2 | M2;
/// A counter at this value is saturated and sticky.
pub const SATURATED: u8 = 255;

/// What an update did besides counting.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Flags {
    /// A counter reached or stayed at [`SATURATED`] (it will never be decremented).
    pub saturated: bool,
    /// A decrement found a counter at zero (erasing an image never drawn): left at zero.
    pub underflow: bool,
}

impl Flags {
    /// Both kinds of event, merged.
    pub fn merge(&mut self, o: Flags) {
        self.saturated |= o.saturated;
        self.underflow |= o.underflow;
    }
}

/// Adds one to each counter of `word` selected by `mask` (a sum of [`P1`], [`M1`], [`P2`],
/// [`M2`]). (Always inlined: called, its struct return went through the 68k backend's
/// broken convention that pops a stack word the caller never pushed, overwriting the
/// caller's last local; docs/toolchain.md.)
#[inline(always)]
pub fn increment(word: u32, mask: u32) -> (u32, Flags) {
    if counter_fast(word, mask, false) {
        return (counter_plain(word, mask, false), Flags::default());
    }
    slow(word, mask, true)
}

/// Takes one from each counter of `word` selected by `mask`. (Always inlined: see
/// [`increment`].)
#[inline(always)]
pub fn decrement(word: u32, mask: u32) -> (u32, Flags) {
    // Every byte below 128 and every selected byte at least 1: no borrow crosses a byte.
    if counter_fast(word, mask, true) {
        return (counter_plain(word, mask, true), Flags::default());
    }
    slow(word, mask, false)
}

fn slow(word: u32, mask: u32, up: bool) -> (u32, Flags) {
    let mut f = Flags::default();
    let out = slow_into(word, mask, up, &mut f);
    (out, f)
}

/// The byte-by-byte update; flags through `f` (no struct return: see [`increment`]).
#[inline(never)]
fn slow_into(word: u32, mask: u32, up: bool, f: &mut Flags) -> u32 {
    let mut out = 0u32;
    for shift in [24u32, 16, 8, 0] {
        let mut b = (word >> shift) as u8;
        if (mask >> shift) & 1 != 0 {
            if b == SATURATED {
                f.saturated = true;
            } else if up {
                b += 1;
                if b == SATURATED {
                    f.saturated = true;
                }
            } else if b == 0 {
                f.underflow = true;
            } else {
                b -= 1;
            }
        }
        out |= (b as u32) << shift;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn bytes(w: u32) -> [u8; 4] {
        w.to_be_bytes()
    }

    proptest! {
        #[test]
        fn fast_and_slow_paths_agree_with_bytewise_counting(word: u32, sel in 0u32..16, up: bool) {
            let mask = (0..4).filter(|i| sel >> i & 1 != 0).map(|i| 1u32 << (8 * i)).sum::<u32>();
            let (w, f) = if up { increment(word, mask) } else { decrement(word, mask) };
            let (a, b) = (bytes(word), bytes(w));
            let m = bytes(mask);
            let mut sat = false;
            let mut under = false;
            for i in 0..4 {
                let want = if m[i] == 0 {
                    a[i]
                } else if a[i] == SATURATED {
                    sat = true;
                    a[i]
                } else if up {
                    sat |= a[i] + 1 == SATURATED;
                    a[i] + 1
                } else if a[i] == 0 {
                    under = true;
                    0
                } else {
                    a[i] - 1
                };
                prop_assert_eq!(b[i], want, "byte {}", i);
            }
            prop_assert_eq!(f, Flags { saturated: sat, underflow: under });
        }
    }

    #[test]
    fn saturation_is_sticky_and_flagged() {
        let (w, f) = increment(0x0000_00FE, M2);
        assert_eq!((w, f.saturated), (0x0000_00FF, true));
        let (w2, f2) = decrement(w, M2);
        assert_eq!(
            (w2, f2.saturated),
            (0xFF, true),
            "a saturated counter is never decremented"
        );
        let (w3, f3) = decrement(0, P1);
        assert_eq!((w3, f3.underflow), (0, true));
    }
}
