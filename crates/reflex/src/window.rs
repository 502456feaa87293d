//! The lookahead window over the toroidal C-space map (thesis ch. V sections 6-7, figs. V.4,
//! V.5): rectangles of pixels tested for obstacles, rows and columns added toward the goal
//! one at a time, alternating axes, each stopped by the first obstacle wall it meets.
//!
//! Pixel (`i1`, `i2`) covers theta1 in [i1, i1 + 1) and theta2 in [i2, i2 + 1) pixels of
//! 2 pi / 128 (absolute joint angles, `crates/cspace`); it is occupied when its word of
//! edge-direction counters or the stripe word of its column is not zero. The C-space board
//! marks every pixel an obstacle's image touches, interior included, so a free pixel holds
//! no colliding configuration (issue 7's property tests). Any counter counts: the thesis
//! tested only the faces whose normals face the motion; testing all of them is cheaper on a
//! word-wide bus and can only stop the arm earlier.
//!
//! Pixel ranges here are unwrapped (any `i32`, the map index is the value mod 128) and
//! inclusive; a range of 128 pixels or more is the whole axis.
//!
//! What earlier passes read is kept ([`Known`]): each column's run of free rows while the
//! column's generation stays, and the whole window a pass proved free while the map's
//! epoch stays (no column written since). The thesis tested only the arrest region's
//! leading borders each pass (section 7) and trusted the rest to the passes before; with
//! the epoch a pass reads only the pixels of its rectangles outside the window trusted,
//! and after a pass whose window grew unblocked it takes the window the steps would grow
//! at once when that rectangle is free ([`fast_grow`]): at top speed a column and a row to
//! read, where the steps tested every column and row of the window again.

use crate::masks::{lt, zero};
use crate::SIDE;

/// Read access to the C-space map, as wide as the hardware allows. `row_or` and `col_or`
/// never wrap: the callers split ranges at the torus edge.
pub trait Map {
    /// The obstacles as sensed, for the evasion ([`crate::evade`]): each slot's `valid`,
    /// and the rest of the valid slots (an invalid slot's other words are read by nobody).
    /// The reflex asks among moving obstacles only, on the passes that read them (the
    /// trapped passes; the tracks' samples are kept, [`Map::keep_obstacles`]): a map
    /// handed to one pass builds them on its first call. Built by the board every pass
    /// among moving obstacles, the six views cost the reflex image ~2,700 cycles of every
    /// escape pass, where nothing read them seven passes in eight. The default (a map with
    /// no sensed obstacles: unit tests, scripted passes) has none.
    fn obstacle_views(&mut self) -> &[crate::ObstacleView; crate::OBSTACLES] {
        &crate::NO_OBSTACLES
    }
    /// Keeps what this pass sensed of the obstacles, for [`Map::kept_view`] on the passes
    /// after (the tracks' samples, [`crate::evade::Tracks`]: a sampling pass keeps them,
    /// and they are made into views one a pass). The default (no sensed obstacles) keeps
    /// nothing.
    fn keep_obstacles(&mut self) {}
    /// Obstacle `i` as the last [`Map::keep_obstacles`] kept it, into `o`: `valid`, and for
    /// a valid slot its position, radius and time as [`Map::obstacle_views`] would have
    /// built them on that pass (the velocity is left as it was: the tracks do not read it).
    fn kept_view(&mut self, i: usize, o: &mut crate::ObstacleView) {
        let _ = i;
        o.valid = false;
    }
    /// The bitwise or of the words of pixels `i1 .. i1 + n` in row `i2` (`i1 + n <= 128`).
    fn row_or(&mut self, i2: u32, i1: u32, n: u32) -> u32;
    /// The bitwise or of the words of pixels `i2 .. i2 + n` in column `i1` (`i2 + n <= 128`).
    fn col_or(&mut self, i1: u32, i2: u32, n: u32) -> u32;
    /// The bitwise or of stripe words `i1 .. i1 + n` (`i1 + n <= 128`).
    fn stripes_or(&mut self, i1: u32, n: u32) -> u32;
    /// How many of rows `i2 .. i2 + nb` (`i2 + nb <= 128`), from the first, are free over
    /// pixels `a0 .. a0 + n0` and `a1 .. a1 + n1` (each run within the row); rows past the
    /// first that is not are not read. The default reads row by row through
    /// [`Map::row_or`].
    fn free_rows(&mut self, i2: u32, nb: u32, a0: u32, n0: u32, a1: u32, n1: u32) -> u32 {
        let mut k = 0;
        while k < nb {
            if row_or2(self, i2 + k, a0, n0, a1, n1) != 0 {
                return k;
            }
            k += 1;
        }
        nb
    }
    /// Bit `k` set when pixel (`i1 + k`, `i2`) is marked, `k` < 32 (`i1` a multiple of 32):
    /// one word of a row of the planner's bitmap (`crates/planner`). The default reads
    /// pixel by pixel through [`Map::row_or`].
    fn row_bits(&mut self, i2: u32, i1: u32) -> u32 {
        bits_of(|k| self.row_or(i2, i1 + k, 1))
    }
    /// Bit `k` set when pixel (`i1 + k` mod 128, `i2`) is marked, `k` < 32, any `i1` < 128:
    /// a row of the escape's window (`crate::escape`). The default joins two aligned
    /// [`Map::row_bits`] words.
    fn row_run(&mut self, i2: u32, i1: u32) -> u32 {
        let w0 = i1 & !31;
        join(
            self.row_bits(i2, w0),
            self.row_bits(i2, (w0 + 32) & (SIDE - 1)),
            i1 & 31,
        )
    }
    /// Bit `k` set when stripe `i1 + k` mod 128 is marked, `k` < 32, any `i1` < 128.
    fn stripe_run(&mut self, i1: u32) -> u32 {
        let w0 = i1 & !31;
        join(
            self.stripe_bits(w0),
            self.stripe_bits((w0 + 32) & (SIDE - 1)),
            i1 & 31,
        )
    }
    /// Bit `k` set when pixel (`i1`, `i2 + k` mod 128) is marked, `k` < 32, any `i2` < 128
    /// (the stripe word is not read): a column of the escape's window (`crate::escape`),
    /// read again alone when its generation moved. The default reads pixel by pixel
    /// through [`Map::col_or`].
    fn col_bits(&mut self, i1: u32, i2: u32) -> u32 {
        bits_of(|k| self.col_or(i1, (i2 + k) & (SIDE - 1), 1))
    }
    /// How many of rows `i2 .. i2 + n` (`i2 + n <= 128`) of column `i1`, from the first,
    /// are free (its map words zero; the stripe word is not read). The default reads
    /// through [`Map::free_rows`].
    fn col_run(&mut self, i1: u32, i2: u32, n: u32) -> u32 {
        self.free_rows(i2, n, i1, 1, i1, 0)
    }
    /// The address of the 128 generation words where the map is memory-mapped (the
    /// image), for the runtime's assembly; `None` elsewhere.
    fn gens_ptr(&mut self) -> Option<*const u32> {
        None
    }
    /// Whether the map has column generations ([`Map::column_gen`]); without them
    /// [`Known`] reads every pixel every time.
    fn has_gens(&self) -> bool {
        false
    }
    /// Column `i1`'s generation (`vme_map::layout::CSPACE_GENS`): raised after every write
    /// to the column, so a column whose generation has not moved since it was read holds
    /// what it held then. Meaningful only when [`Map::has_gens`].
    fn column_gen(&mut self, i1: u32) -> u32 {
        let _ = i1;
        0
    }
    /// The map's epoch (`vme_map::layout::CSPACE_EPOCH`): raised after every raise of a
    /// column's generation, so while it stays no column was written. Meaningful only when
    /// [`Map::has_gens`].
    fn epoch(&mut self) -> u32 {
        0
    }
    /// Bit `k` set when stripe `i1 + k` is marked, `k` < 32 (`i1` a multiple of 32).
    fn stripe_bits(&mut self, i1: u32) -> u32 {
        bits_of(|k| self.stripes_or(i1 + k, 1))
    }
}

/// Bit `k` set when `word(k)` is nonzero, `k` < 32: [`Map`]'s pixel-by-pixel defaults as a
/// word of bits.
fn bits_of(mut word: impl FnMut(u32) -> u32) -> u32 {
    let mut bits = 0;
    let mut k = 0;
    while k < 32 {
        let w = word(k);
        bits |= ((w | w.wrapping_neg()) >> 31) << k;
        k += 1;
    }
    bits
}

/// The C-space map in global RAM (`vme_map::layout`), read a word per pixel: what the
/// reflex and planner boards hand their logic.
pub struct BusMap<'a, G: vme_map::GlobalBus>(pub &'a mut G);

impl<G: vme_map::GlobalBus> Map for BusMap<'_, G> {
    fn has_gens(&self) -> bool {
        true
    }
    fn column_gen(&mut self, i1: u32) -> u32 {
        self.0.read_u32(vme_map::layout::cspace_gen(i1))
    }
    fn epoch(&mut self) -> u32 {
        self.0.read_u32(vme_map::layout::CSPACE_EPOCH)
    }
    fn col_run(&mut self, i1: u32, i2: u32, n: u32) -> u32 {
        use vme_map::layout::{cspace_counter, CSPACE_COUNTERS, CSPACE_SIDE};
        self.0
            .zero_run(cspace_counter(i1, i2, 0), n, CSPACE_SIDE * CSPACE_COUNTERS)
    }
    fn gens_ptr(&mut self) -> Option<*const u32> {
        self.0.word_ptr(vme_map::layout::CSPACE_GENS)
    }
    fn row_or(&mut self, i2: u32, i1: u32, n: u32) -> u32 {
        self.0
            .or_words(vme_map::layout::cspace_counter(i1, i2, 0), n, 4)
    }
    fn col_or(&mut self, i1: u32, i2: u32, n: u32) -> u32 {
        self.0.or_words(
            vme_map::layout::cspace_counter(i1, i2, 0),
            n,
            4 * vme_map::layout::CSPACE_SIDE,
        )
    }
    fn stripes_or(&mut self, i1: u32, n: u32) -> u32 {
        self.0
            .or_words(vme_map::layout::CSPACE_STRIPES + 4 * i1, n, 4)
    }
    fn free_rows(&mut self, i2: u32, nb: u32, a0: u32, n0: u32, a1: u32, n1: u32) -> u32 {
        use vme_map::layout::{cspace_counter, CSPACE_COUNTERS, CSPACE_SIDE};
        self.0.free_rows(
            cspace_counter(a0, i2, 0),
            n0,
            cspace_counter(a1, i2, 0),
            n1,
            nb,
            CSPACE_SIDE * CSPACE_COUNTERS,
        )
    }
    fn row_bits(&mut self, i2: u32, i1: u32) -> u32 {
        self.0
            .nonzero_bits(vme_map::layout::cspace_counter(i1, i2, 0))
    }
    fn stripe_bits(&mut self, i1: u32) -> u32 {
        self.0
            .nonzero_bits(vme_map::layout::CSPACE_STRIPES + 4 * i1)
    }
    // 32 words from any pixel: one call of 32 words when the run does not wrap (the
    // aligned pair of the default reads 64).
    fn row_run(&mut self, i2: u32, i1: u32) -> u32 {
        if i1 <= SIDE - 32 {
            return self
                .0
                .nonzero_bits(vme_map::layout::cspace_counter(i1, i2, 0));
        }
        let w0 = i1 & !31;
        join(self.row_bits(i2, w0), self.row_bits(i2, 0), i1 & 31)
    }
    fn stripe_run(&mut self, i1: u32) -> u32 {
        if i1 <= SIDE - 32 {
            return self
                .0
                .nonzero_bits(vme_map::layout::CSPACE_STRIPES + 4 * i1);
        }
        let w0 = i1 & !31;
        join(self.stripe_bits(w0), self.stripe_bits(0), i1 & 31)
    }
    // Rows `i2 ..` to the map's last, then from row 0: a word of the column every 512
    // bytes, one call a run.
    fn col_bits(&mut self, i1: u32, i2: u32) -> u32 {
        use vme_map::layout::{cspace_counter, CSPACE_SIDE};
        const STRIDE: u32 = 4 * CSPACE_SIDE;
        let n0 = SIDE - i2;
        if n0 >= 32 {
            return self
                .0
                .nonzero_bits_strided(cspace_counter(i1, i2, 0), 32, STRIDE);
        }
        let a = self
            .0
            .nonzero_bits_strided(cspace_counter(i1, i2, 0), n0, STRIDE);
        let b = self
            .0
            .nonzero_bits_strided(cspace_counter(i1, 0, 0), 32 - n0, STRIDE);
        a | (b << n0)
    }
}

/// The bitwise or of row `i2`'s words over the runs (`a0`, `n0`) and (`a1`, `n1`) (the
/// second empty when `n1` is 0): a span's row as [`Span::runs`] splits it at the seam.
#[inline(always)]
fn row_or2<M: Map + ?Sized>(m: &mut M, i2: u32, a0: u32, n0: u32, a1: u32, n1: u32) -> u32 {
    let mut acc = m.row_or(i2, a0, n0);
    if n1 > 0 {
        acc |= m.row_or(i2, a1, n1);
    }
    acc
}

/// Bits `sh ..` of `a` followed by `b`'s low bits: a 32-pixel run starting `sh` pixels into
/// aligned word `a` (never a shift by 32).
#[inline(always)]
fn join(a: u32, b: u32, sh: u32) -> u32 {
    (a >> sh) | ((b << 1) << (31 - sh))
}

/// A map held in plain slices: 128 x 128 words (row `i2` after row `i2 - 1`) and 128
/// stripe words. For tests and the host's tools.
pub struct SliceMap<'a> {
    /// The pixel words, index `i2 * 128 + i1`.
    pub words: &'a [u32],
    /// The stripe words, index `i1`.
    pub stripes: &'a [u32],
}

impl Map for SliceMap<'_> {
    fn row_or(&mut self, i2: u32, i1: u32, n: u32) -> u32 {
        let b = (i2 * SIDE + i1) as usize;
        self.words[b..b + n as usize].iter().fold(0, |a, w| a | w)
    }
    fn col_or(&mut self, i1: u32, i2: u32, n: u32) -> u32 {
        (i2..i2 + n).fold(0, |a, r| a | self.words[(r * SIDE + i1) as usize])
    }
    fn stripes_or(&mut self, i1: u32, n: u32) -> u32 {
        self.stripes[i1 as usize..(i1 + n) as usize]
            .iter()
            .fold(0, |a, w| a | w)
    }
}

/// An inclusive range of unwrapped pixel indices along one axis. `repr(C)`: the runtime's
/// `__reflex_prepare` writes spans.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct Span {
    /// First pixel.
    pub lo: i32,
    /// Last pixel (>= `lo`).
    pub hi: i32,
}

impl Span {
    /// The pixels an angle interval [`lo_u`, `hi_u`] (angle units, 256 per pixel) touches.
    pub fn of_units(lo_u: i32, hi_u: i32) -> Self {
        Self {
            lo: lo_u >> 8,
            hi: hi_u >> 8,
        }
    }

    /// Pixels in the span, at most the whole axis.
    #[inline(always)]
    pub fn len(self) -> u32 {
        ((self.hi - self.lo + 1) as u32).min(SIDE)
    }

    /// Whether the span has no pixels (never, for a well-formed span).
    pub fn is_empty(self) -> bool {
        self.hi < self.lo
    }

    /// The span as at most two runs of map indices that do not wrap: (start, count) each,
    /// the second of count 0 when one suffices.
    #[inline(always)]
    pub fn runs(self) -> [(u32, u32); 2] {
        let n = self.len();
        let start = (self.lo as u32) & (SIDE - 1);
        let first = n.min(SIDE - start);
        [(start, first), (0, n - first)]
    }
}

/// Whether every pixel of `s1` x `s2` is free. Adds the words read to `tests`.
///
/// The runs are handled one by one, never as a local array iterated (docs/toolchain.md,
/// class 6).
#[inline(never)]
pub fn rect_free<M: Map + ?Sized>(m: &mut M, s1: Span, s2: Span, tests: &mut u32) -> bool {
    let [(a0, n0), (a1, n1)] = s1.runs();
    let [(b0, m0), (b1, m1)] = s2.runs();
    let mut acc = m.stripes_or(a0, n0);
    if n1 > 0 {
        acc |= m.stripes_or(a1, n1);
    }
    *tests += n0 + n1;
    if acc != 0 {
        return false;
    }
    rows_free(m, b0, m0, a0, n0, a1, n1, tests) && rows_free(m, b1, m1, a0, n0, a1, n1, tests)
}

/// What the reflex learnt of each column in earlier passes: a run of rows read free (the
/// column's stripe word zero) and the column's generation ([`Map::column_gen`]) read
/// before them. While the generation stays, the run needs no read: the thesis tested only
/// the arrest region's leading borders each pass (ch. V section 7), trusting the rest to
/// the passes before; here the generations say which columns an obstacle's redraw touched
/// since, so the trust is earned. `repr(C)`: the runtime's `__reflex_known_hits` reads it.
#[derive(Clone, Debug)]
#[repr(C)]
pub struct Known {
    /// The generation each column's run was read at.
    gen: [u32; SIDE as usize],
    /// First row of each column's run (map index).
    start: [u8; SIDE as usize],
    /// Rows in each column's run: 0 (nothing known) to 127, wrapping past row 127, or
    /// [`WHOLE`].
    len: [u8; SIDE as usize],
    /// Pixels vouched for without a read since [`Known::take_vouched`].
    vouched: u32,
    /// A row of each column read marked at its generation, or [`NO_MARK`]: a rectangle
    /// over it is not free without a read (an arm escaping from an obstacle asks for its
    /// own marked column every pass, ~500 cycles of reads a column on the 68020).
    mark: [u8; SIDE as usize],
    /// A window proved free (every pixel, stripe words included, read free or vouched for)
    /// in the pass that began at map epoch `free_epoch` ([`Known::proved_free`]).
    free: [Span; 2],
    /// The map's epoch ([`Map::epoch`]) at the start of the pass that proved `free`.
    free_epoch: u32,
    /// -1 once `free` holds a window, else 0.
    free_set: i32,
    /// Nonzero when the window in `free` grew unblocked along both axes ([`fast_grow`] is
    /// tried only after such a pass).
    free_whole: u32,
    /// The map's epoch at the start of this pass ([`Known::begin`]).
    epoch: u32,
    /// -1 when this pass may trust `free` (the map's epoch has not moved since it was
    /// proved), else 0.
    free_ok: i32,
    /// Rectangles ([`rect_free_known`]'s `s1`, `s2`) read blocked, a pixel or stripe word
    /// marked, in passes that began at map epoch `blocked_epoch`, or [`NO_RECT`]. While
    /// the epoch stays they are blocked still: an arm escaping from an obstacle asks its
    /// blocked rectangles again every pass (~1,100 cycles each on the 68020 through the
    /// known columns).
    blocked: [[Span; 2]; 2],
    /// The map's epoch at the start of the passes that read `blocked` ([`Known::begin`]).
    blocked_epoch: u32,
    /// The slot of `blocked` the next rectangle read blocked goes to (the older).
    blocked_next: u32,
    /// Zero from a rectangle kept ([`Known::note_blocked`]) until a window is
    /// proved free ([`Known::proved_free`]: the arm is clear, and the rectangles it asked
    /// before are not asked again), else nonzero: only a pass after one that kept a
    /// rectangle compares with them (a pass in free space pays no compare).
    blocked_none: u32,
    /// Zero when this pass may answer from `blocked` (the epoch read by [`Known::begin`]
    /// is `blocked_epoch`); nonzero until the first `begin`, so a `Known` never begun (the
    /// probes' scripts) never does; the reflex begins every pass.
    blocked_moved: u32,
}

/// A rectangle no question asks ([`Known::blocked`]'s empty slot): spans start within a
/// few turns of zero.
const NO_RECT: [Span; 2] = [Span {
    lo: i32::MIN,
    hi: i32::MIN,
}; 2];

/// Nonzero when rectangle `b` is not `s1` x `s2` (as spans: the same pixels from another
/// turn differ).
#[inline(always)]
fn differ(b: &[Span; 2], s1: Span, s2: Span) -> u32 {
    ((b[0].lo ^ s1.lo) | (b[0].hi ^ s1.hi) | (b[1].lo ^ s2.lo) | (b[1].hi ^ s2.hi)) as u32
}

/// [`Known::mark`]'s value for a column with no row known marked.
const NO_MARK: u8 = u8::MAX;

/// A run of the whole column: wider than any run of rows asked plus its offset from the
/// run's start (at most 127 + 128), so it holds every one.
const WHOLE: u8 = 255;

/// [`Known::next`]'s answer for a column that is not free: past any column.
const BLOCKED: u32 = u32::MAX;

// The layout `__reflex_known_hits` in the runtime's assembly reads.
const _: () = assert!(core::mem::offset_of!(Known, start) == 512);
const _: () = assert!(core::mem::offset_of!(Known, len) == 640);

impl Default for Known {
    fn default() -> Self {
        Self::new()
    }
}

impl Known {
    /// Nothing known.
    pub const fn new() -> Self {
        Self {
            gen: [0; SIDE as usize],
            start: [0; SIDE as usize],
            len: [0; SIDE as usize],
            vouched: 0,
            mark: [NO_MARK; SIDE as usize],
            free: [Span { lo: 0, hi: 0 }; 2],
            free_epoch: 0,
            free_set: 0,
            free_whole: 0,
            epoch: 0,
            free_ok: 0,
            blocked: [NO_RECT; 2],
            blocked_epoch: 0,
            blocked_next: 0,
            blocked_none: 1,
            blocked_moved: 1,
        }
    }

    /// Starts a pass, before any of its reads of the map: reads the map's epoch, and trusts
    /// the window proved free in an earlier pass while the epoch has not moved since (no
    /// column written meanwhile). The thesis tested only the arrest region's leading
    /// borders each pass (ch. V section 7) and trusted the rest to the passes before; the
    /// epoch makes that trust earned. Without generations nothing is trusted.
    #[inline(always)]
    pub fn begin<M: Map + ?Sized>(&mut self, m: &mut M) {
        if !m.has_gens() {
            self.free_ok = 0;
            return;
        }
        let e = m.epoch();
        self.epoch = e;
        self.free_ok = self.free_set & zero(e ^ self.free_epoch);
        self.blocked_moved = e ^ self.blocked_epoch;
    }

    /// Whether this pass may answer from [`Known::blocked`] (`begin`'s epoch is theirs and
    /// one is held).
    #[inline(always)]
    fn blocked_ok(&self) -> bool {
        (self.blocked_moved | self.blocked_none) == 0
    }

    /// Whether `s1` x `s2` is one of [`Known::blocked`] (-1 if so, else 0): asked only when
    /// [`Known::blocked_ok`].
    #[inline(always)]
    fn blocked_before(&self, s1: Span, s2: Span) -> i32 {
        let d0 = differ(&self.blocked[0], s1, s2);
        let d1 = differ(&self.blocked[1], s1, s2);
        zero(d0) | zero(d1)
    }

    /// Keeps `s1` x `s2`, just read blocked by [`rect_free_known`], for the passes after
    /// this one to answer without the known columns while the map's epoch stays
    /// ([`Known::blocked`]): over the older of the two kept; the other is forgotten if the
    /// epoch moved since it was read.
    #[inline(never)]
    fn note_blocked(&mut self, s1: Span, s2: Span) {
        if !self.blocked_ok() {
            self.blocked = [NO_RECT; 2];
        }
        self.blocked_none = 0;
        self.blocked_epoch = self.epoch;
        let j = (self.blocked_next & 1) as usize;
        self.blocked[j] = [s1, s2];
        self.blocked_next ^= 1;
    }

    /// Records grown window `w` as proved free in this pass: every pixel of it, and the
    /// stripe word of every column, read free or vouched for since [`Known::begin`].
    #[inline(always)]
    pub fn proved_free(&mut self, w: &Grown) {
        self.free = w.window;
        self.free_epoch = self.epoch;
        self.free_set = -1;
        self.free_whole = !(w.blocked[0] | w.blocked[1]) as u32;
        self.blocked_none = 1;
    }

    /// Whether [`fast_grow`] may take the window at once: a window this pass trusts
    /// ([`Known::begin`]) that grew unblocked.
    #[inline(always)]
    pub fn fast_grow_may(&self) -> bool {
        (self.free_ok as u32 & self.free_whole) != 0
    }

    /// The window this pass may trust as free ([`Known::begin`]), if any.
    #[inline(always)]
    fn trusted(&self) -> Option<[Span; 2]> {
        if self.free_ok != 0 {
            Some(self.free)
        } else {
            None
        }
    }

    /// Counts `n` more pixels vouched for without a read (by another user of the
    /// generations: the escape's kept plan).
    pub fn vouch(&mut self, n: u32) {
        self.vouched += n;
    }

    /// Pixels vouched for without a read since the last call.
    pub fn take_vouched(&mut self) -> u32 {
        core::mem::take(&mut self.vouched)
    }

    /// How many of columns `c .. c + n` (not wrapping), from `c`, the runs vouch for over
    /// rows `q .. q + rows` (wrapping): generation unchanged and the run holding the rows.
    /// On the 68020 `__reflex_known_hits` in the runtime's assembly (the compiled loop
    /// spent ~370 cycles a column on spills); the system tests compare it with this code.
    #[inline(always)]
    fn hits<M: Map + ?Sized>(&self, m: &mut M, c: u32, n: u32, q: u32, rows: u32) -> u32 {
        #[cfg(target_arch = "m68k")]
        if let Some(gens) = m.gens_ptr() {
            extern "C" {
                fn __reflex_known_hits(
                    gens: *const u32,
                    k: *const Known,
                    c: u32,
                    n: u32,
                    q: u32,
                    m: u32,
                ) -> u32;
            }
            // SAFETY: `gens` points at the 128 generation words; `c + n <= 128`; the
            // routine only reads.
            return unsafe { __reflex_known_hits(gens, self, c, n, q, rows) };
        }
        let mut h = 0;
        while h < n {
            let i = (c + h) as usize;
            let (s, l) = (self.start[i] as u32, self.len[i] as u32);
            if self.gen[i] != m.column_gen(c + h) || (q.wrapping_sub(s) & (SIDE - 1)) + rows > l {
                break;
            }
            h += 1;
        }
        h
    }

    /// Whether column `c` is free over rows `q .. q + rows` (wrapping), its generation `g`
    /// read before: what the run vouches for (forgotten if the generation moved), the rest
    /// read, the run grown by what that shows (or a new one started at `q` when it does not
    /// meet the old).
    #[inline(never)]
    fn column<M: Map + ?Sized>(
        &mut self,
        m: &mut M,
        c: u32,
        g: u32,
        q: u32,
        rows: u32,
        tests: &mut u32,
    ) -> bool {
        let i = c as usize;
        if self.gen[i] != g {
            self.gen[i] = g;
            self.len[i] = 0;
            self.mark[i] = NO_MARK;
        }
        // A row read marked at this generation among those asked. (Sign masks: compiled
        // compares left a register copy before their branch, docs/toolchain.md class 1.)
        let mk = self.mark[i] as i32;
        let asked = lt((mk - q as i32) & (SIDE as i32 - 1), rows as i32) & lt(mk, SIDE as i32);
        if asked != 0 {
            return false;
        }
        let (s, l) = (self.start[i] as u32, self.len[i] as u32);
        if l == 0 {
            *tests += 1;
            if m.stripes_or(c, 1) != 0 {
                self.mark[i] = q as u8;
                return false;
            }
        }
        let d = q.wrapping_sub(s) & (SIDE - 1);
        let known = if d < l { (l - d).min(rows) } else { 0 };
        self.vouched += known;
        if known == rows {
            return true;
        }
        // The rows past the run, in at most two pieces that do not wrap.
        let from = (q + known) & (SIDE - 1);
        let want = rows - known;
        let first = want.min(SIDE - from);
        let mut free = m.col_run(c, from, first);
        *tests += (free + 1).min(first);
        if free == first && want > first {
            let more = m.col_run(c, 0, want - first);
            *tests += (more + 1).min(want - first);
            free += more;
        }
        let (s, run) = if d <= l { (s, l + free) } else { (q, free) };
        self.start[i] = s as u8;
        self.len[i] = if run >= SIDE { WHOLE } else { run as u8 };
        // The row the run stopped at is marked, if it stopped; if not, none is known (a
        // mark from before lay outside these rows, and is only forgotten). In arithmetic: a
        // select here compiled to a branch whose flags the result's compare shared
        // (docs/toolchain.md, class 1).
        let stop = (from + free) & (SIDE - 1);
        let whole = (free ^ want).wrapping_sub(1) >> 31;
        self.mark[i] = (stop | (whole << 7)) as u8;
        free == want
    }

    /// Whether columns `a .. a + n` (not wrapping) are free over rows `q .. q + rows`.
    #[inline(never)]
    fn columns<M: Map + ?Sized>(
        &mut self,
        m: &mut M,
        a: u32,
        n: u32,
        q: u32,
        rows: u32,
        tests: &mut u32,
    ) -> bool {
        let mut c = a;
        let end = a + n;
        // `column` hands back the next column, or BLOCKED (a bool result tested after the
        // loop variable's copy branched on the copy's flags: docs/toolchain.md, class 1).
        while c < end {
            let h = self.hits(m, c, end - c, q, rows);
            self.vouched += h * rows;
            c = self.next(m, c + h, end, q, rows, tests);
        }
        c == end
    }

    /// Past column `c` if it is free over the rows (`end` if `c` is `end`), else
    /// [`BLOCKED`].
    #[inline(never)]
    fn next<M: Map + ?Sized>(
        &mut self,
        m: &mut M,
        c: u32,
        end: u32,
        q: u32,
        rows: u32,
        tests: &mut u32,
    ) -> u32 {
        if c >= end {
            return end;
        }
        let g = m.column_gen(c);
        if self.column(m, c, g, q, rows, tests) {
            c + 1
        } else {
            BLOCKED
        }
    }
}

/// Whether every pixel of `s1` x `s2` is free, as [`rect_free`], reading only what `k`
/// cannot vouch for (everything, on a map without generations): not free at once if it is
/// a rectangle read blocked in an earlier pass with the map unwritten since
/// ([`Known::note_blocked`]). Adds the words read to `tests`.
#[inline(never)]
pub fn rect_free_known<M: Map + ?Sized>(
    m: &mut M,
    k: &mut Known,
    s1: Span,
    s2: Span,
    tests: &mut u32,
) -> bool {
    if !m.has_gens() {
        return rect_free(m, s1, s2, tests);
    }
    if k.blocked_ok() && k.blocked_before(s1, s2) != 0 {
        return false;
    }
    let free = if k.free_ok != 0 {
        let f = k.free;
        rect_free_trusting(m, k, &f, s1, s2, tests)
    } else {
        columns_free(m, k, s1, s2, tests)
    };
    if !free {
        k.note_blocked(s1, s2);
    }
    free
}

/// [`rect_free_known`] through the known columns alone (`s1`, `s2` not empty).
#[inline(never)]
fn rect_free_columns<M: Map + ?Sized>(
    m: &mut M,
    k: &mut Known,
    s1: Span,
    s2: Span,
    tests: &mut u32,
) -> bool {
    columns_free(m, k, s1, s2, tests)
}

/// [`rect_free_columns`]'s body.
#[inline(always)]
fn columns_free<M: Map + ?Sized>(
    m: &mut M,
    k: &mut Known,
    s1: Span,
    s2: Span,
    tests: &mut u32,
) -> bool {
    let [(a0, n0), (a1, n1)] = s1.runs();
    let (q, rows) = ((s2.lo as u32) & (SIDE - 1), s2.len());
    k.columns(m, a0, n0, q, rows, tests) && k.columns(m, a1, n1, q, rows, tests)
}

/// The pixels of span `s` below span `f` and above it (unwrapped; each empty when its
/// `hi` is below its `lo`).
#[inline(always)]
fn outside(s: Span, f: Span) -> [Span; 2] {
    [
        Span {
            lo: s.lo,
            hi: s.hi.min(f.lo - 1),
        },
        Span {
            lo: s.lo.max(f.hi + 1),
            hi: s.hi,
        },
    ]
}

/// The pixels of span `s` within span `f` (empty when its `hi` is below its `lo`).
#[inline(always)]
fn within(s: Span, f: Span) -> Span {
    Span {
        lo: s.lo.max(f.lo),
        hi: s.hi.min(f.hi),
    }
}

/// Pixels in span `s`, 0 when it is empty.
#[inline(always)]
fn count(s: Span) -> u32 {
    if s.hi < s.lo {
        0
    } else {
        s.len()
    }
}

/// [`rect_free_known`] with window `f` trusted free ([`Known::begin`]): only the parts of
/// `s1` x `s2` outside it are tested (at most four rectangles), the rest vouched for.
#[inline(never)]
fn rect_free_trusting<M: Map + ?Sized>(
    m: &mut M,
    k: &mut Known,
    f: &[Span; 2],
    s1: Span,
    s2: Span,
    tests: &mut u32,
) -> bool {
    let [l1, r1] = outside(s1, f[0]);
    if count(l1) != 0 && !rect_free_columns(m, k, l1, s2, tests) {
        return false;
    }
    if count(r1) != 0 && !rect_free_columns(m, k, r1, s2, tests) {
        return false;
    }
    let mid1 = within(s1, f[0]);
    if count(mid1) == 0 {
        return true;
    }
    let [l2, r2] = outside(s2, f[1]);
    if count(l2) != 0 && !trusted_columns_free(m, k, mid1, l2, tests) {
        return false;
    }
    if count(r2) != 0 && !trusted_columns_free(m, k, mid1, r2, tests) {
        return false;
    }
    k.vouch(count(mid1) * count(within(s2, f[1])));
    true
}

/// Most rows of a piece read as rows rather than through the known columns: a word costs
/// the 68020 ~7.4 cycles in a row, a known column ~38 to vouch for.
const ROWS_READ: u32 = 4;

/// Whether columns `c` of a window trusted free (their stripe words vouched for with it)
/// are free over rows `r` outside it (both not empty): a few rows read as rows, more
/// through the known columns.
#[inline(never)]
fn trusted_columns_free<M: Map + ?Sized>(
    m: &mut M,
    k: &mut Known,
    c: Span,
    r: Span,
    tests: &mut u32,
) -> bool {
    let n = count(r);
    if n <= ROWS_READ {
        return rows_over::<M, true>(m, r.lo, n, c, tests) == n;
    }
    rect_free_columns(m, k, c, r, tests)
}

/// Whether column `i1` is free over `s2`, as [`col_free`], reading only what `k` cannot
/// vouch for.
#[inline(never)]
pub fn col_free_known<M: Map + ?Sized>(
    m: &mut M,
    k: &mut Known,
    i1: i32,
    s2: Span,
    tests: &mut u32,
) -> bool {
    if !m.has_gens() {
        return col_free(m, i1, s2, tests);
    }
    let c = Span { lo: i1, hi: i1 };
    if k.free_ok != 0 {
        let f = k.free;
        return rect_free_trusting(m, k, &f, c, s2, tests);
    }
    rect_free_columns(m, k, c, s2, tests)
}

/// Whether rows `b .. b + nb` are free over the runs (`a0`, `n0`) and (`a1`, `n1`).
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn rows_free<M: Map + ?Sized>(
    m: &mut M,
    b: u32,
    nb: u32,
    a0: u32,
    n0: u32,
    a1: u32,
    n1: u32,
    tests: &mut u32,
) -> bool {
    if nb == 0 {
        return true;
    }
    // The rows read: the free ones and the first that is not.
    let free = m.free_rows(b, nb, a0, n0, a1, n1);
    *tests += (n0 + n1) * (free + 1).min(nb);
    free == nb
}

/// Whether column `i1` is free over `s2`.
#[inline(never)]
pub fn col_free<M: Map + ?Sized>(m: &mut M, i1: i32, s2: Span, tests: &mut u32) -> bool {
    let c = (i1 as u32) & (SIDE - 1);
    let [(b0, m0), (b1, m1)] = s2.runs();
    *tests += 1 + m0 + m1;
    let mut acc = m.stripes_or(c, 1) | m.col_or(c, b0, m0);
    if m1 > 0 {
        acc |= m.col_or(c, b1, m1);
    }
    acc == 0
}

/// Whether row `i2`'s map words over `s1` are all zero. The stripe words of `s1` are not
/// read: `s1` is the growing window's extent along theta1, and each of its columns had its
/// stripe word read (or vouched for, [`Known`]) when it joined the window this pass, by
/// [`rect_free`] / [`rect_free_known`] or [`col_free`] / [`col_free_known`] (reading them
/// again for every row was half the words a growing window read).
///
/// With a window `k` trusts ([`Known::begin`]) only the pixels of the row outside it are
/// read.
#[inline(never)]
pub fn window_row_free<M: Map + ?Sized>(
    m: &mut M,
    k: &mut Known,
    i2: i32,
    s1: Span,
    tests: &mut u32,
) -> bool {
    if let Some(f) = k.trusted() {
        if f[1].lo <= i2 && i2 <= f[1].hi {
            let [l1, r1] = outside(s1, f[0]);
            k.vouch(count(within(s1, f[0])));
            let mut free = true;
            if count(l1) != 0 {
                free &= row_free(m, i2, l1, tests);
            }
            if count(r1) != 0 {
                free &= row_free(m, i2, r1, tests);
            }
            return free;
        }
    }
    row_free(m, i2, s1, tests)
}

/// Whether row `i2`'s map words over `s1` (not empty) are all zero.
#[inline(never)]
fn row_free<M: Map + ?Sized>(m: &mut M, i2: i32, s1: Span, tests: &mut u32) -> bool {
    let r = (i2 as u32) & (SIDE - 1);
    let [(a0, n0), (a1, n1)] = s1.runs();
    *tests += n0 + n1;
    row_or2(m, r, a0, n0, a1, n1) == 0
}

/// How far the window may grow along each axis, and where the goal lies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Grow {
    /// The goal's pixel range along each axis (the goal with its margin): growth along an
    /// axis stops once the window covers it.
    pub goal: [Span; 2],
    /// The farthest pixels the window may reach along each axis (the arrest region and the
    /// lookahead depth beyond it, each way).
    pub reach: [Span; 2],
    /// Most pixel words to read while growing (the base rectangle excluded).
    pub budget: u32,
}

/// What growing the window found (also its working state: the caller's value, indexed
/// through the reference; docs/toolchain.md, class 6).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Grown {
    /// The window: the base rectangle and every row and column added, all free.
    pub window: [Span; 2],
    /// Growth along the axis stopped at an obstacle wall.
    pub blocked: [bool; 2],
}

/// Where [`grow`] takes axis span `cur` toward goal span `g` within reach `r` when every
/// pixel on the way is free and the budget does not bind: up to the goal's far end (unless
/// the reach or the whole axis stops it first), then down to its near end, as [`step`] and
/// [`rows_run`] go.
#[inline(always)]
fn limit(g: Span, r: Span, cur: Span) -> Span {
    let mut w = cur;
    let side = SIDE as i32;
    if g.hi > w.hi {
        if w.hi + 1 > r.hi || w.hi + 1 < r.lo || w.hi - w.lo + 1 >= side {
            return w;
        }
        w.hi = g.hi.min(r.hi).min(w.lo + side - 1);
        if w.hi < g.hi {
            return w;
        }
    }
    if g.lo < w.lo {
        if w.lo - 1 > r.hi || w.lo - 1 < r.lo || w.hi - w.lo + 1 >= side {
            return w;
        }
        w.lo = g.lo.max(r.lo).max(w.hi - side + 1);
    }
    w
}

/// The window [`grow`] would reach from base `w.window` if nothing blocked it, taken at
/// once when that whole rectangle is free: after a pass whose window grew unblocked, with
/// the map's epoch unmoved ([`Known::begin`]), only its pixels outside that window are
/// read (at top speed the arm's window moves a pixel or two a pass: a column and a row to
/// read where the steps tested every column and row of it again). Returns 1 when taken
/// (`w` then holds the window, unblocked), 0 when the steps must decide (nothing trusted,
/// the last window blocked, more words to read than `grow.budget`, or a pixel marked).
/// The window is the steps' whenever their budget does not cut them short (then it is
/// larger, and as free).
#[inline(never)]
pub fn fast_grow<M: Map + ?Sized>(
    m: &mut M,
    k: &mut Known,
    grow: &Grow,
    w: &mut Grown,
    tests: &mut u32,
) -> u32 {
    if !k.fast_grow_may() {
        return 0;
    }
    let l0 = limit(grow.goal[0], grow.reach[0], w.window[0]);
    let l1 = limit(grow.goal[1], grow.reach[1], w.window[1]);
    let start = *tests;
    if !rect_free_known(m, k, l0, l1, tests) || *tests - start > grow.budget {
        return 0;
    }
    w.window = [l0, l1];
    1
}

/// Grows the free rectangle `w.window` (the base, on entry) toward `grow.goal`: one column
/// (axis 1), then one row (axis 2), alternately (fig. V.5's scans "1", "2", ...), each over
/// the window's current extent along the other axis, until each axis covers the goal, meets
/// an obstacle, reaches its reach, or the budget is spent. Columns go through `k`.
#[inline(never)]
pub fn grow<M: Map + ?Sized>(
    m: &mut M,
    k: &mut Known,
    grow: &Grow,
    w: &mut Grown,
    tests: &mut u32,
) {
    let start = *tests;
    // Bit `ax` set: that axis is done.
    let mut done = 0u32;
    let mut ax = 0usize;
    while done != 3 {
        if done & (1 << ax) == 0 {
            let used = *tests - start;
            if used >= grow.budget {
                return;
            }
            // Once the columns are done the rows' extent along theta1 stays: the rows left
            // go as one run (a step a row cost the 68020 ~400 cycles besides the reads).
            done |= if done == 1 {
                rows_run(m, k, grow, w, grow.budget - used, tests)
            } else {
                step(m, k, grow, w, ax, tests)
            } << ax;
        }
        ax ^= 1;
    }
}

/// The rows [`step`] would add one by one, toward the goal, once the columns are done:
/// as many as the goal, the reach, the axis and the budget left (`left` words) allow, read
/// as one run. Returns 1 when the rows are done (blocked, or nothing to add), as [`step`].
#[inline(never)]
fn rows_run<M: Map + ?Sized>(
    m: &mut M,
    k: &mut Known,
    grow: &Grow,
    w: &mut Grown,
    left: u32,
    tests: &mut u32,
) -> u32 {
    // The direction as a type: one branch on it (a second one, on the compare's flags
    // kept across a register copy, was miscompiled: docs/toolchain.md class 1).
    if grow.goal[1].hi > w.window[1].hi {
        rows_toward::<M, true>(m, k, grow, w, left, tests)
    } else {
        rows_toward::<M, false>(m, k, grow, w, left, tests)
    }
}

/// [`rows_run`] upward (`UP`) or downward.
#[inline(never)]
fn rows_toward<M: Map + ?Sized, const UP: bool>(
    m: &mut M,
    k: &mut Known,
    grow: &Grow,
    w: &mut Grown,
    left: u32,
    tests: &mut u32,
) -> u32 {
    let (g, r, cur) = (grow.goal[1], grow.reach[1], w.window[1]);
    // Rows toward the goal within the reach, and within the axis.
    let (to_goal, to_reach) = if UP {
        (g.hi - cur.hi, r.hi - cur.hi)
    } else {
        (cur.lo - g.lo, cur.lo - r.lo)
    };
    let in_axis = SIDE as i32 - (cur.hi - cur.lo + 1);
    let width = w.window[0].len();
    let mut n = to_goal.min(to_reach).min(in_axis);
    if n <= 0 {
        // Covered, at the reach or the axis full: done, as a step decides.
        return 1;
    }
    // Row `j` (from 0) is read while fewer than `left` words were read before it. Where
    // the budget binds (rarely), one row: the caller asks again while budget is left. (A
    // division here was miscompiled, llvm/llvm-project#224186, and costs a call.)
    if (n as u32 - 1) * width >= left {
        n = 1;
    }
    let n = n as u32;
    let s1 = w.window[0];
    // The first row toward the goal (unwrapped).
    let r0 = if UP { cur.hi + 1 } else { cur.lo - 1 };
    let free = match k.trusted() {
        // Rows from the first that lie in a window trusted free (`Known::begin`): only their
        // pixels outside it are read.
        Some(f) if f[1].lo <= r0 && r0 <= f[1].hi => {
            let n_in = (if UP {
                f[1].hi - cur.hi
            } else {
                cur.lo - f[1].lo
            } as u32)
                .min(n);
            let [l1, r1] = outside(s1, f[0]);
            let mut free_in = n_in;
            if count(l1) != 0 {
                free_in = free_in.min(rows_over::<M, UP>(m, r0, n_in, l1, tests));
            }
            if count(r1) != 0 {
                free_in = free_in.min(rows_over::<M, UP>(m, r0, n_in, r1, tests));
            }
            k.vouch(count(within(s1, f[0])) * free_in);
            if free_in < n_in || n_in == n {
                free_in
            } else {
                let next = if UP {
                    r0 + n_in as i32
                } else {
                    r0 - n_in as i32
                };
                n_in + rows_over::<M, UP>(m, next, n - n_in, s1, tests)
            }
        }
        _ => rows_over::<M, UP>(m, r0, n, s1, tests),
    };
    if UP {
        w.window[1].hi += free as i32;
    } else {
        w.window[1].lo -= free as i32;
    }
    if free < n {
        w.blocked[1] = true;
        return 1;
    }
    0
}

/// How many of the `n` rows from unwrapped row `r0` upward (`UP`) or downward, from the
/// first, are free over the pixels of `s` (not empty); rows past the first that is not are
/// not read. Adds the words read to `tests`.
#[inline(never)]
fn rows_over<M: Map + ?Sized, const UP: bool>(
    m: &mut M,
    r0: i32,
    n: u32,
    s: Span,
    tests: &mut u32,
) -> u32 {
    let [(a0, n0), (a1, n1)] = s.runs();
    let free = if UP {
        // At most two runs of rows that do not wrap.
        let b = (r0 as u32) & (SIDE - 1);
        let first = n.min(SIDE - b);
        let mut f = m.free_rows(b, first, a0, n0, a1, n1);
        if f == first && n > first {
            f += m.free_rows(0, n - first, a0, n0, a1, n1);
        }
        f
    } else {
        let mut f = 0;
        while f < n {
            let b = ((r0 - f as i32) as u32) & (SIDE - 1);
            if row_or2(m, b, a0, n0, a1, n1) != 0 {
                break;
            }
            f += 1;
        }
        f
    };
    *tests += s.len() * (free + 1).min(n);
    free
}

/// One column (`ax` 0) or row (`ax` 1) toward the goal. Returns 1 when that axis is done.
#[inline(never)]
fn step<M: Map + ?Sized>(
    m: &mut M,
    k: &mut Known,
    grow: &Grow,
    w: &mut Grown,
    ax: usize,
    tests: &mut u32,
) -> u32 {
    let g = grow.goal[ax];
    let r = grow.reach[ax];
    let cur = w.window[ax];
    // Toward the goal: up if the goal's far end lies above the window, down if its near end
    // lies below; covered otherwise.
    let up = g.hi > cur.hi;
    if !up && g.lo >= cur.lo {
        return 1;
    }
    let next = if up { cur.hi + 1 } else { cur.lo - 1 };
    if next > r.hi || next < r.lo || cur.len() >= SIDE {
        return 1;
    }
    let other = w.window[ax ^ 1];
    let free = if ax == 0 {
        col_free_known(m, k, next, other, tests)
    } else {
        window_row_free(m, k, next, other, tests)
    };
    if !free {
        w.blocked[ax] = true;
        return 1;
    }
    if up {
        w.window[ax].hi = next;
    } else {
        w.window[ax].lo = next;
    }
    0
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// [`grow`] as it was: every row and column a [`step`] of its own.
    fn grow_stepwise<M: Map + ?Sized>(
        m: &mut M,
        k: &mut Known,
        grow: &Grow,
        w: &mut Grown,
        tests: &mut u32,
    ) {
        let start = *tests;
        let mut done = 0u32;
        let mut ax = 0usize;
        while done != 3 {
            if done & (1 << ax) == 0 {
                if *tests - start >= grow.budget {
                    return;
                }
                done |= step(m, k, grow, w, ax, tests) << ax;
            }
            ax ^= 1;
        }
    }

    fn span(lo: i32, n: i32) -> Span {
        Span { lo, hi: lo + n - 1 }
    }

    /// A marked row read in a column answers a later ask over it without a read while the
    /// column's generation stays, and is forgotten when a write raises it.
    #[test]
    fn a_marked_row_is_kept_until_its_column_is_written() {
        use vme_map::layout::{cspace_counter, raise_column_gen, CSPACE_MAP, CSPACE_MAP_BYTES};
        use vme_map::GlobalBus;
        let mut mem = vec![0u8; (CSPACE_MAP + CSPACE_MAP_BYTES) as usize];
        let mut g = vme_map::ArrayBus::new(&mut mem);
        let mut k = Known::new();
        let c = 127;
        let ask = |g: &mut vme_map::ArrayBus, k: &mut Known, lo: i32, n: i32| {
            let mut tests = 0;
            let s1 = Span { lo: c, hi: c };
            let free = rect_free_known(&mut BusMap(g), k, s1, span(lo, n), &mut tests);
            (free, tests)
        };
        let write = |g: &mut vme_map::ArrayBus, row: u32, w: u32| {
            g.write_u32(cspace_counter(c as u32, row, 0), w);
            raise_column_gen(g, c as u32);
        };
        write(&mut g, 10, 0x0100_0000);
        assert!(!ask(&mut g, &mut k, 5, 16).0);
        // Asked again, and over other rows holding row 10 (wrapping), it reads nothing.
        assert_eq!(ask(&mut g, &mut k, 5, 16), (false, 0));
        assert_eq!(ask(&mut g, &mut k, -100, 112), (false, 0));
        // Cleared: free again.
        write(&mut g, 10, 0);
        assert!(ask(&mut g, &mut k, 5, 16).0);
        // Marked again: rows beside it are read, and free.
        write(&mut g, 10, 0x0100_0000);
        assert!(!ask(&mut g, &mut k, 5, 16).0);
        assert!(ask(&mut g, &mut k, 11, 20).0);
        assert!(ask(&mut g, &mut k, 0, 10).0);
        // Marked across the seam: a run that wraps stops at it.
        write(&mut g, 2, 0x0001_0000);
        assert!(!ask(&mut g, &mut k, 120, 12).0);
        assert_eq!(ask(&mut g, &mut k, 126, 5), (false, 0));
        assert!(ask(&mut g, &mut k, 120, 10).0);
    }

    /// One pass's window over `g`'s map from base `b`: `fast_grow` first when `fast`, then
    /// the base and the steps; `None` when the base is not free. Returns the window and
    /// whether `fast_grow` took it.
    fn pass_window(
        g: &mut vme_map::ArrayBus,
        k: &mut Known,
        grow_to: &Grow,
        b: [Span; 2],
        fast: bool,
    ) -> (Option<Grown>, bool) {
        let mut m = BusMap(g);
        let mut tests = 0;
        let mut w = Grown {
            window: b,
            blocked: [false, false],
        };
        if fast && fast_grow(&mut m, k, grow_to, &mut w, &mut tests) != 0 {
            return (Some(w), true);
        }
        if !rect_free_known(&mut m, k, b[0], b[1], &mut tests) {
            return (None, false);
        }
        grow(&mut m, k, grow_to, &mut w, &mut tests);
        (Some(w), false)
    }

    /// Whether every span of `a` holds the matching span of `b`.
    fn holds(a: &Grown, b: &Grown) -> bool {
        (0..2).all(|i| a.window[i].lo <= b.window[i].lo && b.window[i].hi <= a.window[i].hi)
    }

    /// The rows a window grows by once its columns are done (`rows_run`), read only outside
    /// a window trusted free: the first row past the trusted window is read, across all of
    /// the window's columns, and a mark there stops the growth, upward and downward.
    #[test]
    fn rows_past_a_trusted_window_are_read() {
        use vme_map::layout::{cspace_counter, raise_column_gen, CSPACE_MAP, CSPACE_MAP_BYTES};
        use vme_map::GlobalBus;
        for (up, mark_row, goal) in [(true, 20, span(30, 5)), (false, -6, span(-20, 5))] {
            let mut mem = vec![0u8; (CSPACE_MAP + CSPACE_MAP_BYTES) as usize];
            let mut g = vme_map::ArrayBus::new(&mut mem);
            g.write_u32(cspace_counter(5, mark_row as u32 & 127, 0), 1);
            raise_column_gen(&mut g, 5);
            let mut k = Known::new();
            k.begin(&mut BusMap(&mut g));
            k.proved_free(&Grown {
                window: [span(0, 11), span(-5, 25)],
                blocked: [false, true],
            });
            k.begin(&mut BusMap(&mut g));
            assert!(k.trusted().is_some());
            let base = [span(2, 7), span(5, 11)];
            let grow_to = Grow {
                goal: [span(3, 3), goal],
                reach: [span(0, 11), span(-30, 80)],
                budget: 1024,
            };
            let mut w = Grown {
                window: base,
                blocked: [false, false],
            };
            let mut tests = 0;
            grow(&mut BusMap(&mut g), &mut k, &grow_to, &mut w, &mut tests);
            let edge = if up {
                w.window[1].hi + 1
            } else {
                w.window[1].lo - 1
            };
            assert_eq!((edge, w.blocked), (mark_row, [false, true]), "{w:?}");
            // The rows inside the trusted window were vouched for: only those past it read.
            assert_eq!(tests, 7, "{w:?}");
        }
    }

    /// A pass that trusts the window the last pass proved free (`Known::begin`, the map's
    /// epoch unmoved) grows the window the steps grow over a map read afresh: the window
    /// taken at once (`fast_grow`) and the steps over the trusted window alike, on random
    /// maps (each write's column raised), bases next to the last pass's, goals and reaches.
    /// With no budget the windows and blocked flags are equal; with the reflex's budget the
    /// trusting pass, reading fewer words, stops no earlier (its window holds the other's,
    /// and is equal where the budget did not cut the steps short).
    #[test]
    fn a_trusted_window_grows_as_the_steps() {
        use vme_map::layout::{cspace_counter, raise_column_gen, CSPACE_MAP, CSPACE_MAP_BYTES};
        use vme_map::GlobalBus;
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut rnd = |n: i32| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % n as u64) as i32
        };
        let (mut fast_taken, mut trusted, mut cut) = (0, 0, 0);
        for _ in 0..20_000 {
            let mut mem = vec![0u8; (CSPACE_MAP + CSPACE_MAP_BYTES) as usize];
            let mut g = vme_map::ArrayBus::new(&mut mem);
            let base0 = [
                span(rnd(280) - 140, 1 + rnd(40)),
                span(rnd(280) - 140, 1 + rnd(60)),
            ];
            // Marks about the base, where the windows grow.
            for _ in 0..rnd(12) {
                let i1 = (base0[0].lo + rnd(100) - 30) as u32 & 127;
                let i2 = (base0[1].lo + rnd(120) - 30) as u32 & 127;
                g.write_u32(cspace_counter(i1, i2, 0), 1);
                raise_column_gen(&mut g, i1);
            }
            let goal = [
                span(base0[0].lo + rnd(120) - 60, 1 + rnd(20)),
                span(base0[1].lo + rnd(120) - 60, 1 + rnd(20)),
            ];
            let (d1, d2) = (rnd(30), rnd(30));
            let grow_at = |b: [Span; 2], budget: u32| Grow {
                goal,
                reach: [
                    Span {
                        lo: b[0].lo - d1,
                        hi: b[0].hi + d2,
                    },
                    Span {
                        lo: b[1].lo - d2,
                        hi: b[1].hi + d1,
                    },
                ],
                budget,
            };
            // The last pass proves its window.
            let mut k = Known::new();
            k.begin(&mut BusMap(&mut g));
            if let (Some(w0), _) = pass_window(&mut g, &mut k, &grow_at(base0, 1024), base0, false)
            {
                k.proved_free(&w0);
            }
            // This pass: the base moved by a pixel or two, or grew or shrank by one.
            let b = [
                Span {
                    lo: base0[0].lo + rnd(5) - 2,
                    hi: base0[0].hi + rnd(3) - 1,
                },
                Span {
                    lo: base0[1].lo + rnd(5) - 2,
                    hi: base0[1].hi + rnd(3) - 1,
                },
            ];
            if b[0].hi < b[0].lo || b[1].hi < b[1].lo {
                continue;
            }
            for budget in [u32::MAX, 1024] {
                let gr = grow_at(b, budget);
                let mut kt = k.clone();
                kt.begin(&mut BusMap(&mut g));
                trusted += (kt.free_ok != 0) as u32;
                let (wt, fast) = pass_window(&mut g, &mut kt, &gr, b, true);
                let (wr, _) = pass_window(&mut g, &mut Known::new(), &gr, b, false);
                assert_eq!(wt.is_some(), wr.is_some(), "{b:?} {gr:?}");
                let (Some(wt), Some(wr)) = (wt, wr) else {
                    continue;
                };
                fast_taken += fast as u32;
                if budget == u32::MAX {
                    assert_eq!(wt, wr, "{b:?} {gr:?} fast {fast}");
                } else {
                    let (wu, _) =
                        pass_window(&mut g, &mut Known::new(), &grow_at(b, u32::MAX), b, false);
                    assert!(holds(&wt, &wr), "{wt:?} {wr:?}");
                    if Some(wr) == wu {
                        assert_eq!(wt, wr, "{b:?} {gr:?} fast {fast}");
                    } else {
                        cut += 1;
                    }
                }
            }
        }
        eprintln!("{fast_taken} taken at once, {trusted} trusting, {cut} cut by the budget");
        assert!(
            fast_taken > 5000 && trusted > 10_000,
            "{fast_taken} taken at once, {trusted} trusting, {cut} cut by the budget"
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        /// The rows left once the columns are done, read as one run, give the window, the
        /// blocked flags and the words read that a step a row gives: up and down, across
        /// the torus's seam, against walls, at the reach, with the axis full and within
        /// any budget.
        #[test]
        fn the_rows_run_grows_as_the_steps(
            marks in proptest::collection::vec((0usize..128, 0usize..128), 0..12),
            base in (-140i32..140, 1i32..40, -140i32..140, 1i32..130),
            goal in (-200i32..200, 1i32..30, -200i32..200, 1i32..30),
            reach in (0i32..40, 0i32..40, 0i32..90, 0i32..90),
            budget in prop_oneof![0u32..120, 0u32..1500],
        ) {
            let mut words = vec![0u32; 128 * 128];
            for &(i1, i2) in &marks {
                words[i2 * 128 + i1] = 1;
            }
            let stripes = vec![0u32; 128];
            let (b1, b2) = (span(base.0, base.1), span(base.2, base.3));
            let g = Grow {
                goal: [span(goal.0, goal.1), span(goal.2, goal.3)],
                reach: [
                    Span { lo: b1.lo - reach.0, hi: b1.hi + reach.1 },
                    Span { lo: b2.lo - reach.2, hi: b2.hi + reach.3 },
                ],
                budget,
            };
            let run = |stepwise: bool| {
                let mut m = SliceMap { words: &words, stripes: &stripes };
                let mut w = Grown { window: [b1, b2], blocked: [false, false] };
                let mut tests = 0;
                let mut k = Known::new();
                if stepwise {
                    grow_stepwise(&mut m, &mut k, &g, &mut w, &mut tests);
                } else {
                    grow(&mut m, &mut k, &g, &mut w, &mut tests);
                }
                (w, tests)
            };
            prop_assert_eq!(run(false), run(true));
        }
    }
}
