//! Conservative rasterisation onto the torus (thesis ch. IV section 6, lines ~1180-1210).
//!
//! A pixel is marked when the closed image touches it at all. For an x-monotone image the
//! theta2 extent over a column's strip is exact: between the chains' values at the strip's
//! two edges and at the vertices inside it. The chains are evaluated one unit outward so the
//! division's truncation never lets an edge in. Rows and columns wrap modulo 128.
//!
//! Edge normals: rows touched by the upper chain count +theta2 (and -theta1 or +theta1 as
//! the chain rises or falls), rows touched by the lower chain -theta2 (and +theta1 or
//! -theta1), an image's first and last columns -theta1 and +theta1; rows inside count all
//! four directions.
//!
//! A moved image is updated by its difference from the old one ([`pair`]: new before old,
//! lines 1199-1210, the decrements kept in a [`RunLog`] until every increment is done); the
//! columns' extents and the walk over two images' columns are the runtime's assembly on
//! the 68020 (`__cspace_columns`, `__cspace_walk`) and the Rust here on the host.

use crate::counters::{self, Flags, ALL, M1, M2, P1, P2};
use crate::{Shape, Stripe, UNITS_PER_PIXEL};
use core::mem::MaybeUninit;
use vme_map::layout::{cspace_counter, raise_column_gen, CSPACE_SIDE, CSPACE_STRIPES};
use vme_map::GlobalBus;

/// Whether an update draws or erases.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Op {
    /// Increment the counters (a new image).
    Draw,
    /// Decrement them (the image drawn from the old position, recomputed).
    Erase,
}

/// Where the counters live: the map in global RAM on the board, a slice on the host.
pub trait Canvas {
    /// Applies `op` to the counters `mask` of map pixel (`i1`, `i2`), both in `0..128`.
    fn pixel(&mut self, i1: u32, i2: u32, mask: u32, op: Op) -> Flags;
    /// Applies `op` to the counters `mask` of stripe-layer column `i1` in `0..128`.
    fn stripe(&mut self, i1: u32, mask: u32, op: Op) -> Flags;
    /// Applies `op` down column `i1` from row `i2` (wrapping modulo 128) as the five runs
    /// of `pieces`, (rows, counters) pairs in order: a whole column of an image.
    fn column(&mut self, i1: u32, i2: u32, pieces: &[u32; 10], op: Op) -> Flags {
        let mut f = Flags::default();
        let mut row = i2;
        let mut p = 0;
        while p < 5 {
            f.merge(self.run(i1, row & WRAP, pieces[2 * p], pieces[2 * p + 1], op));
            row = row.wrapping_add(pieces[2 * p]);
            p += 1;
        }
        f
    }
    /// Applies `op` to the counters `mask` of the `rows` pixels of column `i1` from row
    /// `i2` up, rows wrapping modulo 128 (`rows` at most 128): a run of an image's column.
    fn run(&mut self, i1: u32, i2: u32, rows: u32, mask: u32, op: Op) -> Flags {
        let mut f = Flags::default();
        let mut j = 0;
        while j < rows {
            f.merge(self.pixel(i1, i2.wrapping_add(j) & WRAP, mask, op));
            j += 1;
        }
        f
    }
}

#[inline(always)]
fn update(word: u32, mask: u32, op: Op) -> (u32, Flags) {
    match op {
        Op::Draw => counters::increment(word, mask),
        Op::Erase => counters::decrement(word, mask),
    }
}

/// The map and stripe layer as host memory: `map[i2 * 128 + i1]`, `stripes[i1]`.
pub struct SliceCanvas<'a> {
    /// 128 x 128 counter words, theta1 fastest (as in global RAM).
    pub map: &'a mut [u32],
    /// 128 counter words.
    pub stripes: &'a mut [u32],
}

impl Canvas for SliceCanvas<'_> {
    fn pixel(&mut self, i1: u32, i2: u32, mask: u32, op: Op) -> Flags {
        let w = &mut self.map[(i2 * CSPACE_SIDE + i1) as usize];
        let (v, f) = update(*w, mask, op);
        *w = v;
        f
    }
    fn stripe(&mut self, i1: u32, mask: u32, op: Op) -> Flags {
        let w = &mut self.stripes[i1 as usize];
        let (v, f) = update(*w, mask, op);
        *w = v;
        f
    }
}

/// The map and stripe layer in global RAM (`vme_map::layout::CSPACE_MAP`, `CSPACE_STRIPES`).
pub struct BusCanvas<'a, B: GlobalBus + ?Sized>(pub &'a mut B);

impl<B: GlobalBus + ?Sized> BusCanvas<'_, B> {
    /// [`Canvas::run`] from pixel `done` of the run on, that pixel first, byte by byte
    /// (apart from the plain path: fewer values live there, fewer spills on the 68020).
    #[inline(never)]
    fn run_from(&mut self, i1: u32, i2: u32, rows: u32, mask: u32, op: Op, done: u32) -> Flags {
        let mut f = Flags::default();
        let down = op == Op::Erase;
        let col = cspace_counter(i1, 0, 0);
        let mut done = done;
        loop {
            f.merge(self.word(i1, i2.wrapping_add(done) & WRAP, mask, op));
            done += 1;
            done += self
                .0
                .count_run(col, i2.wrapping_add(done) & WRAP, rows - done, mask, down);
            if done >= rows {
                raise_column_gen(self.0, i1);
                return f;
            }
        }
    }

    /// Pixel (`i1`, `i2`)'s word updated, the column's generation not yet raised.
    #[inline(always)]
    fn word(&mut self, i1: u32, i2: u32, mask: u32, op: Op) -> Flags {
        let a = cspace_counter(i1, i2, 0);
        let (v, f) = update(self.0.read_u32(a), mask, op);
        self.0.write_u32(a, v);
        f
    }
}

/// Every write raises the written column's generation after it
/// (`vme_map::layout::CSPACE_GENS`: the reflex reads again only columns whose generation
/// moved).
impl<B: GlobalBus + ?Sized> Canvas for BusCanvas<'_, B> {
    #[inline]
    fn pixel(&mut self, i1: u32, i2: u32, mask: u32, op: Op) -> Flags {
        let f = self.word(i1, i2, mask, op);
        raise_column_gen(self.0, i1);
        f
    }
    #[inline]
    fn stripe(&mut self, i1: u32, mask: u32, op: Op) -> Flags {
        let a = CSPACE_STRIPES + 4 * i1;
        let (v, f) = update(self.0.read_u32(a), mask, op);
        self.0.write_u32(a, v);
        raise_column_gen(self.0, i1);
        f
    }
    /// The run in one [`GlobalBus::count_run`] call (the runtime's assembly on the 68020);
    /// a pixel it stops at takes the byte-by-byte update and the run goes on after it. One
    /// raise of the generation, after the run. Most of a small move's differences are runs
    /// of a row or two (a 1 mm move at 200 mm: 72 runs of one row), where a column of one
    /// piece ([`BusCanvas::column`]) cost ten times the pixel's update.
    #[inline(always)]
    fn run(&mut self, i1: u32, i2: u32, rows: u32, mask: u32, op: Op) -> Flags {
        let col = cspace_counter(i1, 0, 0);
        let done = self.0.count_run(col, i2, rows, mask, op == Op::Erase);
        if done < rows {
            return self.run_from(i1, i2, rows, mask, op, done);
        }
        raise_column_gen(self.0, i1);
        Flags::default()
    }
    /// The whole column in one [`GlobalBus::count_column`] call (the runtime's assembly on
    /// the 68020); a pixel it stops at takes the byte-by-byte update and the column goes on
    /// after it. One raise of the generation, after the whole column.
    #[inline(never)]
    fn column(&mut self, i1: u32, i2: u32, pieces: &[u32; 10], op: Op) -> Flags {
        let mut f = Flags::default();
        let down = op == Op::Erase;
        let total = pieces[0] + pieces[2] + pieces[4] + pieces[6] + pieces[8];
        let col = cspace_counter(i1, 0, 0);
        let mut done = 0;
        loop {
            done = self.0.count_column(col, i2 & WRAP, pieces, done, down);
            if done >= total {
                raise_column_gen(self.0, i1);
                return f;
            }
            f.merge(self.word(i1, i2.wrapping_add(done) & WRAP, mask_at(pieces, done), op));
            done += 1;
        }
    }
}

/// The counters of pixel `k` of a column given as `pieces` (see [`Canvas::column`]).
#[inline(never)]
fn mask_at(pieces: &[u32; 10], k: u32) -> u32 {
    let mut left = k;
    let mut p = 0;
    while p < 4 && left >= pieces[2 * p] {
        left -= pieces[2 * p];
        p += 1;
    }
    pieces[2 * p + 1]
}

/// A whole map and stripe layer in memory, for host-side tools and tests (64.5 KiB; the
/// boards use [`BusCanvas`] on global RAM instead).
#[derive(Clone)]
pub struct Memory {
    /// 128 x 128 counter words, theta1 fastest (as in global RAM).
    pub map: [u32; (CSPACE_SIDE * CSPACE_SIDE) as usize],
    /// 128 stripe words.
    pub stripes: [u32; CSPACE_SIDE as usize],
}

impl Default for Memory {
    fn default() -> Self {
        Self {
            map: [0; (CSPACE_SIDE * CSPACE_SIDE) as usize],
            stripes: [0; CSPACE_SIDE as usize],
        }
    }
}

impl Memory {
    /// A canvas over this map.
    pub fn canvas(&mut self) -> SliceCanvas<'_> {
        SliceCanvas {
            map: &mut self.map,
            stripes: &mut self.stripes,
        }
    }
    /// Whether pixel (`i1`, `i2`) is occupied (its word or its column's stripe word).
    pub fn occupied(&self, i1: u32, i2: u32) -> bool {
        self.map[(i2 * CSPACE_SIDE + i1) as usize] != 0 || self.stripes[i1 as usize] != 0
    }
    /// Whether every counter is zero.
    pub fn is_clear(&self) -> bool {
        self.map.iter().chain(&self.stripes).all(|&w| w == 0)
    }
}

const WRAP: u32 = CSPACE_SIDE - 1;

/// Floor division by the pixel size (arithmetic shift: rounds toward minus infinity).
#[inline(always)]
fn pix(u: i32) -> i32 {
    u >> 8
}

/// Draws or erases a link-1 stripe on the stripe layer.
#[inline(never)]
pub fn stripe<C: Canvas>(s: &Stripe, canvas: &mut C, op: Op) -> Flags {
    let mut f = Flags::default();
    if s.full || s.hi_u - s.lo_u >= crate::UNITS_PER_REV - UNITS_PER_PIXEL {
        for c in 0..CSPACE_SIDE {
            f.merge(canvas.stripe(c, ALL, op));
        }
        return f;
    }
    let (c0, c1) = (pix(s.lo_u - 1), pix(s.hi_u + 1));
    for c in c0..c1 + 1 {
        let mut m = ALL;
        if c == c0 {
            m = M1 | P2 | M2;
        }
        if c == c1 {
            m = if c == c0 { ALL } else { P1 | P2 | M2 };
        }
        f.merge(canvas.stripe(c as u32 & WRAP, m, op));
    }
    f
}

/// The value of a chain at `t` on segment `k` (t between the segment's ends), one unit
/// outward (`up`: toward +theta2).
#[inline]
fn eval(t1: &[i32], v: &[i32], k: usize, t: i32, up: bool) -> i32 {
    let (ta, tb) = (t1[k], t1[k + 1]);
    let (va, vb) = (v[k], v[k + 1]);
    let x = if tb == ta {
        if up {
            va.max(vb)
        } else {
            va.min(vb)
        }
    } else {
        va + fx::div((vb - va) * (t - ta), tb - ta)
    };
    if up {
        x + 1
    } else {
        x - 1
    }
}

/// `rising` if `b > a`, `falling` if `b < a`, else 0, from the signs of the difference
/// without a compare (the compiled selects clobbered the condition codes on the 68k;
/// docs/toolchain.md). Chain values are within a few revolutions, so `b - a` cannot
/// overflow.
#[inline(never)]
fn slope_mask(a: i32, b: i32, rising: u32, falling: u32) -> u32 {
    let d = b - a;
    let up = ((-d) >> 31) as u32; // all ones when d > 0
    let down = (d >> 31) as u32; // all ones when d < 0
    (rising & up) | (falling & down)
}

/// One column of an image: which pixels to update with which counters. (`repr(C)`: the
/// runtime's assembly writes it, `__cspace_columns`.)
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct Column {
    /// Map column, 0..128.
    col: u32,
    /// First row (unwrapped).
    first: i32,
    /// Rows to update, at most 128 (128: the whole column, every counter).
    rows: u32,
    /// Rows from `first` that the lower chain crosses.
    lower_rows: u32,
    /// Offset from `first` of the first row the upper chain crosses.
    upper_from: u32,
    /// Counters of lower-chain rows.
    lower_mask: u32,
    /// Counters of upper-chain rows.
    upper_mask: u32,
    /// Added to boundary rows: the image's first or last column.
    ends: u32,
}

/// Not a column: no rows (a [`Cursor`] set to it is one empty run).
const NO_COLUMN: Column = Column {
    col: 0,
    first: END,
    rows: 0,
    lower_rows: 0,
    upper_from: 0,
    lower_mask: 0,
    upper_mask: 0,
    ends: 0,
};

/// Whether two columns of one map column paint different counters: they differ in a
/// field, and are not both full (a full column gives every row of the map column all four
/// counters once, from whatever first row: near the elbow's circle an image's middle
/// columns span more than a revolution of theta2 in both positions of a small move, and
/// were erased and drawn again whole because their first rows moved). (A function of its
/// own, with or-ed differences and the fullness as a mask: the compiled field-by-field
/// compare clobbered the condition codes on the 68k, docs/toolchain.md.)
#[inline(never)]
fn differ(a: &Column, b: &Column) -> bool {
    // Rows are at most 128 (`CSPACE_SIDE`): bit 7 of both is set only when both are full.
    const _: () = assert!(CSPACE_SIDE == 128);
    let not_both_full = ((a.rows & b.rows) >> 7).wrapping_sub(1);
    (((a.col ^ b.col)
        | (a.first ^ b.first) as u32
        | (a.rows ^ b.rows)
        | (a.lower_rows ^ b.lower_rows)
        | (a.upper_from ^ b.upper_from)
        | (a.lower_mask ^ b.lower_mask)
        | (a.upper_mask ^ b.upper_mask)
        | (a.ends ^ b.ends))
        & not_both_full)
        != 0
}

/// Both chains' values at a strip edge, kept for the next column: a column's left edge is
/// the last one's right edge, on the same segment unless a vertex lies on it, so most
/// columns evaluate (and divide) at one edge instead of two.
#[derive(Clone, Copy)]
struct Edge {
    /// Where (angle units).
    t: i32,
    /// On which segment.
    k: usize,
    /// The upper chain's value there, one unit outward.
    upper: i32,
    /// The lower chain's value there, one unit outward.
    lower: i32,
}

impl Edge {
    /// No edge yet.
    const NONE: Edge = Edge {
        t: i32::MIN,
        k: usize::MAX,
        upper: 0,
        lower: 0,
    };
}

/// The column `c` (unwrapped) of image `s` whose theta1 columns run `c0..=c1`; `k` is the
/// chain segment holding the strip's left edge, advanced as the columns go, and `edge` the
/// last column's right edge.
#[inline(never)]
fn column(s: &Shape, c: i32, c0: i32, c1: i32, k: &mut usize, edge: &mut Edge, out: &mut Column) {
    let t = &s.theta1_u;
    let n = t.len();
    let a = (c * UNITS_PER_PIXEL).max(t[0]);
    let b = (c * UNITS_PER_PIXEL + UNITS_PER_PIXEL).min(t[n - 1]);
    // Extremes of both chains over [a, b]: at its ends and at the vertices inside.
    while *k + 2 < n && t[*k + 1] <= a {
        *k += 1;
    }
    let (ua, la) = if edge.t == a && edge.k == *k {
        (edge.upper, edge.lower)
    } else {
        (
            eval(t, &s.upper_u, *k, a, true),
            eval(t, &s.lower_u, *k, a, false),
        )
    };
    let (mut umax, mut umin, mut lmax, mut lmin) = (ua, ua, la, la);
    let mut j = *k;
    while j + 2 < n && t[j + 1] < b {
        j += 1;
        let (u, l) = (s.upper_u[j] + 1, s.lower_u[j] - 1);
        umax = umax.max(u);
        umin = umin.min(u);
        lmax = lmax.max(l);
        lmin = lmin.min(l);
    }
    let (ub, lb) = (
        eval(t, &s.upper_u, j, b, true),
        eval(t, &s.lower_u, j, b, false),
    );
    *edge = Edge {
        t: b,
        k: j,
        upper: ub,
        lower: lb,
    };
    umax = umax.max(ub);
    umin = umin.min(ub);
    lmax = lmax.max(lb);
    lmin = lmin.min(lb);
    let first = pix(lmin);
    let span = pix(umax) - first + 1;
    let ends = if s.wraps {
        0
    } else if c == c0 {
        M1
    } else if c == c1 {
        P1
    } else {
        0
    };
    *out = Column {
        col: c as u32 & WRAP,
        first,
        rows: span.clamp(1, CSPACE_SIDE as i32) as u32,
        lower_rows: (pix(lmax) - first + 1).max(0) as u32,
        upper_from: (pix(umin) - first).max(0) as u32,
        lower_mask: M2 | slope_mask(la, lb, P1, M1),
        upper_mask: P2 | slope_mask(ua, ub, M1, P1),
        ends,
    };
}

/// Updates the pixels of one column as five runs of rows (some empty) with one set of
/// counters each, in one [`Canvas::column`] call (see [`pieces`]).
#[inline(never)]
fn paint<C: Canvas>(canvas: &mut C, k: &Column, op: Op, buf: &mut [u32; 10]) -> Flags {
    pieces(k, buf);
    canvas.column(k.col, k.first as u32, buf, op)
}

/// The rows of one column as five runs (some empty) with one set of counters each, from
/// its first row: the rows only the lower chain crosses, the rows both chains cross (below
/// the interior), the interior with all four counters, the rows both cross (above it), the
/// rows only the upper chain crosses. Every row gets its edge counters plus the image's end
/// counters, or all four inside; a full column is all interior. The bounds are taken
/// without branches on compares (sign arithmetic: every count is below 2^8): the selects
/// the compiler made of the plain form clobbered the condition codes on the 68k
/// (docs/toolchain.md). Written through `out`: a returned array goes through the 68k
/// backend's broken struct-return convention (see [`counters::increment`]).
#[inline(never)]
fn pieces(k: &Column, out: &mut [u32; 10]) {
    let rows = k.rows as i32;
    // All ones when the whole column is taken (every counter of every row).
    let full = ((CSPACE_SIDE as i32 - 1 - rows) >> 31) as u32;
    let keep = !(full as i32);
    // Interior run [lo, hi): after the lower boundary rows, before the upper ones.
    let lo = (k.lower_rows as i32).min(rows) & keep;
    let hi = ((k.upper_from as i32).max(lo).min(rows) & keep) | (rows & full as i32);
    // Rows below `lo` are lower-chain rows, and upper-chain rows too from `upper_from`;
    // rows from `hi` are upper-chain rows, and lower-chain rows too below `lower_rows`.
    let upper_from = (k.upper_from as i32).min(lo);
    let lower_to = (k.lower_rows as i32).max(hi).min(rows) & keep | (rows & full as i32);
    let both = k.lower_mask | k.upper_mask | k.ends;
    // The five runs' lengths (every bound is within 0..=rows and they increase).
    *out = [
        upper_from as u32,
        k.lower_mask | k.ends,
        (lo - upper_from) as u32,
        both,
        (hi - lo) as u32,
        ALL,
        (lower_to - hi) as u32,
        both,
        (rows - lower_to) as u32,
        k.upper_mask | k.ends,
    ];
}

/// Draws or erases a link-2 image on the map. (Not inlined: its callers hold the image on
/// their stack frame, and the 68k backend drops the index register when a function indexes
/// its own frame's arrays, llvm/llvm-project#200984.)
#[inline(never)]
pub fn shape<C: Canvas>(s: &Shape, canvas: &mut C, op: Op) -> Flags {
    let mut f = Flags::default();
    let (c0, c1) = shape_columns(s);
    let mut k = 0usize; // segment holding the strip's left edge
    let mut edge = Edge::NONE;
    let mut buf = [0u32; 10];
    let mut col = NO_COLUMN;
    for c in c0..c1 + 1 {
        column(s, c, c0, c1, &mut k, &mut edge, &mut col);
        f.merge(paint(canvas, &col, op, &mut buf));
    }
    f
}

// The layouts `__cspace_columns` in the runtime's assembly reads and writes.
const _: () = assert!(core::mem::offset_of!(Shape, upper_u) == 132);
const _: () = assert!(core::mem::offset_of!(Shape, lower_u) == 264);
const _: () = assert!(core::mem::offset_of!(Shape, wraps) == 396);
const _: () = assert!(core::mem::size_of::<Column>() == 32);

/// Most columns an image spans: 129 for one all the way round (its first column twice, as
/// the strip's two ends), fewer for any other (less than a revolution of theta1, plus one
/// column either side).
pub const MAX_COLUMNS: usize = 130;

/// Every column `c0..=c1` of image `s` into `out[c - c0]`: what [`column`] gives for each
/// in turn. On the 68020 it is `__cspace_columns` in the runtime's assembly (the compiled
/// column spent ~1,100 cycles, its divisions included); the system tests compare the image
/// with this host code bit for bit.
#[inline(never)]
fn all_columns(s: &Shape, c0: i32, c1: i32, out: &mut [MaybeUninit<Column>; MAX_COLUMNS]) {
    debug_assert!(c1 - c0 < MAX_COLUMNS as i32);
    #[cfg(target_arch = "m68k")]
    {
        extern "C" {
            fn __cspace_columns(s: *const Shape, c0: i32, c1: i32, out: *mut Column);
        }
        // SAFETY: `columns` gives at most MAX_COLUMNS columns; the routine reads `s` and
        // writes `c1 - c0 + 1` records into `out`.
        unsafe { __cspace_columns(s, c0, c1, out.as_mut_ptr().cast()) }
    }
    #[cfg(not(target_arch = "m68k"))]
    {
        let mut k = 0usize;
        let mut edge = Edge::NONE;
        let mut col = NO_COLUMN;
        for c in c0..c1 + 1 {
            column(s, c, c0, c1, &mut k, &mut edge, &mut col);
            out[(c - c0) as usize].write(col);
        }
    }
}

/// Every column of image `s`, in order from its first, as the eight words of a [`Column`]
/// (`col`, `first`, `rows`, `lower_rows`, `upper_from`, `lower_mask`, `upper_mask`,
/// `ends`) handed to `f`: the host's [`all_columns`], which `__cspace_columns` on the
/// 68020 must match, for the system tests to compare the image's routine with. Returns the
/// columns' range (unwrapped, inclusive).
#[cfg(not(target_arch = "m68k"))]
pub fn each_column(s: &Shape, mut f: impl FnMut([u32; 8])) -> (i32, i32) {
    let (c0, c1) = shape_columns(s);
    let mut cols = [const { MaybeUninit::uninit() }; MAX_COLUMNS];
    all_columns(s, c0, c1, &mut cols);
    for k in &cols[..(c1 - c0 + 1) as usize] {
        // SAFETY: `all_columns` wrote the range's columns.
        let k = unsafe { k.assume_init_ref() };
        f([
            k.col,
            k.first as u32,
            k.rows,
            k.lower_rows,
            k.upper_from,
            k.lower_mask,
            k.upper_mask,
            k.ends,
        ]);
    }
    (c0, c1)
}

/// A [`Column`] from its eight words (see [`each_column`]).
#[cfg(not(target_arch = "m68k"))]
fn column_of(w: &[u32; 8]) -> Column {
    Column {
        col: w[0],
        first: w[1] as i32,
        rows: w[2],
        lower_rows: w[3],
        upper_from: w[4],
        lower_mask: w[5],
        upper_mask: w[6],
        ends: w[7],
    }
}

/// The host's walk of a pair (what `__cspace_walk` on the 68020 must match in effect): the
/// old image's columns `old` over columns `oc` and the new one's `new` over `nc` (ranges
/// unwrapped, inclusive, each column as the eight words of [`each_column`]), each record
/// handed to `f` as five words (kind | map column << 8, row, rows, up, down; see [`Rec`]).
/// Returns the records' count, or [`MAX_RECS`] + 1 when they did not fit. For the system
/// tests, with [`apply_record`].
#[cfg(not(target_arch = "m68k"))]
pub fn walk_words(
    old: &[[u32; 8]],
    oc: (i32, i32),
    new: &[[u32; 8]],
    nc: (i32, i32),
    mut f: impl FnMut([u32; 5]),
) -> usize {
    let mut w = PairWork::new();
    for (side, (cols, range)) in [(old, oc), (new, nc)].into_iter().enumerate() {
        assert_eq!(
            cols.len() as i32,
            range.1 - range.0 + 1,
            "one column a map column"
        );
        for (j, k) in cols.iter().enumerate() {
            w.cols[side][j].write(column_of(k));
        }
    }
    let n = walk(&mut w, oc, nc);
    for r in &w.recs[..n.min(MAX_RECS)] {
        // SAFETY: `walk` wrote the first `n` records.
        let r = unsafe { r.assume_init() };
        f([r.kind_col, r.row as u32, r.rows, r.up, r.down]);
    }
    n
}

/// Applies record `rec` of a walk of `old` and `new` (as [`walk_words`] hands them, or as
/// `__cspace_walk` writes them) to `canvas`, as the pair applies it in one go: a run's up
/// counters drawn and its down counters erased, a column only the new image has drawn, a
/// column only the old one has erased.
#[cfg(not(target_arch = "m68k"))]
pub fn apply_record<C: Canvas>(
    canvas: &mut C,
    rec: [u32; 5],
    old: &[[u32; 8]],
    new: &[[u32; 8]],
) -> Flags {
    let mut buf = [0; 10];
    let [kind_col, row, rows, up, down] = rec;
    match kind_col & 0xFF {
        REC_RUN => {
            let col = kind_col >> 8 & WRAP;
            let mut f = canvas.run(col, row, rows, up, Op::Draw);
            f.merge(canvas.run(col, row, rows, down, Op::Erase));
            f
        }
        REC_NEW => paint(canvas, &column_of(&new[row as usize]), Op::Draw, &mut buf),
        _ => paint(canvas, &column_of(&old[row as usize]), Op::Erase, &mut buf),
    }
}

/// Words a [`RunLog`] holds: 16 KiB, a worst-case job's decrements several times over (a
/// 2-inch obstacle's two link-2 images are some 200 columns of three words when they must
/// be erased whole; a small move leaves a few runs a column, one word each).
pub const LOG_WORDS: usize = 4096;

/// Bit of a [`RunLog`] word that starts a whole column (three words) instead of a run.
const WHOLE: u32 = 1 << 31;

/// The counters of `mask` (a sum of [`P1`], [`M1`], [`P2`], [`M2`]) as a nibble, +theta1
/// in bit 3 down to -theta2 in bit 0.
#[inline(always)]
fn nibble(mask: u32) -> u32 {
    (mask >> 21 & 8) | (mask >> 14 & 4) | (mask >> 7 & 2) | (mask & 1)
}

/// The counters of a `nibble`.
#[inline(always)]
fn unnibble(n: u32) -> u32 {
    (n & 8) << 21 | (n & 4) << 14 | (n & 2) << 7 | (n & 1)
}

/// The decrements of a differential update ([`pair`]), kept from its first half, which
/// computes both images' columns, for its second. A run of rows is one word: the column in
/// bits 24-30, the first row (wrapped) in bits 16-22, the rows (1-128) in bits 8-15 and the
/// counters as a `nibble` in bits 0-3. A whole column to erase is three words: `WHOLE`
/// with the column in bits 24-30, its rows, lower-chain rows and first upper-chain row in
/// bits 16-23, 8-15 and 0-7; its first row; and its lower-chain, upper-chain and end
/// counters as nibbles in bits 0-3, 4-7 and 8-11.
pub struct RunLog {
    /// Written below `len` (left uninitialised: zeroing it cost the board 0.1 M cycles at
    /// power-up, past its first heartbeat's deadline).
    words: [MaybeUninit<u32>; LOG_WORDS],
    len: usize,
}

impl Default for RunLog {
    fn default() -> Self {
        Self::new()
    }
}

impl RunLog {
    /// An empty log.
    pub const fn new() -> Self {
        Self {
            words: [const { MaybeUninit::uninit() }; LOG_WORDS],
            len: 0,
        }
    }
    /// Makes `*p` an empty log without writing its words ([`crate::worklist::Scratch::init`]).
    ///
    /// # Safety
    /// `p` is valid for writes of a `RunLog`.
    pub(crate) unsafe fn init(p: *mut RunLog) {
        // SAFETY: by the caller; the words are `MaybeUninit`.
        unsafe { core::ptr::addr_of_mut!((*p).len).write(0) }
    }
    /// Words held.
    pub fn len(&self) -> usize {
        self.len
    }
    /// Whether it holds nothing.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
    /// Forgets every word from the `n`-th on.
    pub fn truncate(&mut self, n: usize) {
        self.len = self.len.min(n);
    }
    /// Adds a run (`rows` of column `col` from row `row`, counters `mask`); false when the
    /// log is full (nothing added).
    pub(crate) fn push(&mut self, col: u32, row: i32, rows: u32, mask: u32) -> bool {
        if self.len >= LOG_WORDS {
            return false;
        }
        self.words[self.len].write(
            (col & WRAP) << 24 | (row as u32 & WRAP) << 16 | (rows & 0xFF) << 8 | nibble(mask),
        );
        self.len += 1;
        true
    }
    /// Adds a whole column; false when the log is full (nothing added).
    fn push_column(&mut self, k: &Column) -> bool {
        if self.len + 3 > LOG_WORDS {
            return false;
        }
        self.words[self.len].write(
            WHOLE
                | (k.col & WRAP) << 24
                | (k.rows & 0xFF) << 16
                | (k.lower_rows & 0xFF) << 8
                | (k.upper_from & 0xFF),
        );
        self.words[self.len + 1].write(k.first as u32);
        self.words[self.len + 2]
            .write(nibble(k.lower_mask) | nibble(k.upper_mask) << 4 | nibble(k.ends) << 8);
        self.len += 3;
        true
    }
    /// Decrements everything held (the second half of the updates that logged it).
    #[inline(never)]
    pub fn erase<C: Canvas>(&self, canvas: &mut C) -> Flags {
        let mut f = Flags::default();
        // A whole column's pieces.
        let mut whole = [0u32; 10];
        // SAFETY: every word below `len` was written by `push` or `push_column`.
        let word = |i: usize| unsafe { self.words[i].assume_init() };
        let mut i = 0;
        while i < self.len {
            let w = word(i);
            if w & WHOLE != 0 {
                let m = word(i + 2);
                let k = Column {
                    col: w >> 24 & WRAP,
                    first: word(i + 1) as i32,
                    rows: w >> 16 & 0xFF,
                    lower_rows: w >> 8 & 0xFF,
                    upper_from: w & 0xFF,
                    lower_mask: unnibble(m & 15),
                    upper_mask: unnibble(m >> 4 & 15),
                    ends: unnibble(m >> 8 & 15),
                };
                f.merge(paint(canvas, &k, Op::Erase, &mut whole));
                i += 3;
            } else {
                f.merge(erase_run(canvas, w));
                i += 1;
            }
        }
        f
    }
}

/// Decrements the run logged as word `w` ([`RunLog::push`]). Not inlined: with the canvas's
/// run inlined, [`RunLog::erase`]'s loop branched on a register copy's flags (`cargo xtask
/// images` refused it; docs/toolchain.md, class 1).
#[inline(never)]
fn erase_run<C: Canvas>(canvas: &mut C, w: u32) -> Flags {
    canvas.run(
        w >> 24,
        w >> 16 & WRAP,
        w >> 8 & 0xFF,
        unnibble(w & 15),
        Op::Erase,
    )
}

/// Past every row of every column (rows are unwrapped, within a few revolutions).
const END: i32 = 1 << 24;

/// The smaller of two values within +-2^30, by sign arithmetic, in a function of its own:
/// inlined, the compiler turned it (and every other form of it) back into a select that
/// clobbered the condition codes on the 68k (docs/toolchain.md).
#[inline(never)]
fn min_i(a: i32, b: i32) -> i32 {
    let d = a - b;
    b + (d & (d >> 31))
}

/// A column's rows as seven runs (see [`pieces`]): nothing below the column, its five runs,
/// nothing above it. Run `j` ends (unwrapped, exclusive) at `ends[j]` with counters
/// `masks[j]`; the last ends at [`END`]. Runs may be empty. `p` is the run being walked.
struct Cursor {
    ends: [i32; 7],
    masks: [u32; 7],
    p: usize,
}

impl Cursor {
    /// No column yet.
    const NONE: Cursor = Cursor {
        ends: [END; 7],
        masks: [0; 7],
        p: 0,
    };
    /// At the first row of column `k`'s seven runs.
    fn set(&mut self, k: &Column, pieces_buf: &mut [u32; 10]) {
        pieces(k, pieces_buf);
        let mut at = k.first;
        self.ends[0] = at;
        self.masks[0] = 0;
        for j in 0..5 {
            at += pieces_buf[2 * j] as i32;
            self.ends[j + 1] = at;
            self.masks[j + 1] = pieces_buf[2 * j + 1];
        }
        self.ends[6] = END;
        self.masks[6] = 0;
        self.p = 0;
    }
    /// Moves on to the run that holds row `r` (below [`END`]).
    #[inline(always)]
    fn advance(&mut self, r: i32) {
        while self.ends[self.p] <= r {
            self.p += 1;
        }
    }
}

/// What a [`pair`] works in: both images' columns, the records of their walk, the two
/// cursors the host's walk uses, and the columns of the last [`KEPT`] new images (70 KiB;
/// given by the caller so that they are not arrays on `pair`'s own stack frame, which the
/// 68k backend indexes wrongly, llvm/llvm-project#200984).
pub struct PairWork {
    /// The old and the new image's columns, written by each pair before it reads them
    /// (left uninitialised: see [`RunLog`]).
    cols: [[MaybeUninit<Column>; MAX_COLUMNS]; 2],
    /// The walk's records, written before they are read (uninitialised, as `cols`).
    recs: [MaybeUninit<Rec>; MAX_RECS],
    cur: [Cursor; 2],
    buf: [u32; 10],
    /// New images' columns, kept for the pair that has them as its old image.
    kept: [Kept; KEPT],
    /// The slot the next image not already kept goes to (round robin).
    next: usize,
    /// Pairs whose old image's columns were kept (wrapping).
    hits: u32,
}

/// Images whose columns a [`PairWork`] keeps: a job's new images are the next job's old
/// ones on the same work-list entry, and a board serves up to six obstacles of two link-2
/// images each.
pub const KEPT: usize = 12;

/// An image's columns kept from the pair that computed them: columns are a function of the
/// image alone, so a pair whose old image is one kept copies them instead of computing them
/// again (about 40,000 of a 2-inch obstacle's ~440,000 cycles at 200 mm).
struct Kept {
    /// Whether the rest holds an image (else it is unwritten memory).
    valid: bool,
    /// The image.
    shape: MaybeUninit<Shape>,
    /// Its columns' range (unwrapped, inclusive) and the columns from its first.
    range: MaybeUninit<(i32, i32)>,
    cols: [MaybeUninit<Column>; MAX_COLUMNS],
}

impl Kept {
    const EMPTY: Kept = Kept {
        valid: false,
        shape: MaybeUninit::uninit(),
        range: MaybeUninit::uninit(),
        cols: [const { MaybeUninit::uninit() }; MAX_COLUMNS],
    };
}

/// The first of slots `0..n` for which `hit` holds, or `n`: the lookup of what a
/// [`PairWork`] or a job's `worklist::Scratch` keeps.
#[inline(always)]
pub(crate) fn find_slot(n: usize, mut hit: impl FnMut(usize) -> bool) -> usize {
    let mut i = 0;
    while i < n {
        if hit(i) {
            return i;
        }
        i += 1;
    }
    n
}

/// Where a new thing to keep goes among `n` slots: `slot` when it is one (the old thing's,
/// which the new one replaces), else the round robin's `next`, advanced.
#[inline(always)]
pub(crate) fn kept_target(slot: usize, next: &mut usize, n: usize) -> usize {
    if slot < n {
        return slot;
    }
    let v = *next;
    *next = (v + 1) % n;
    v
}

/// Whether images `a` and `b` are the same. On the 68020 `__cspace_same_shape` in the
/// runtime's assembly, a `CMPM.L` loop over the vertices (the derived compare went through
/// a byte-wise `memcmp`, 26,000 cycles of a job at 200 mm, and a compiled word loop had
/// its exit branch test a register copy's flags, docs/toolchain.md class 1).
#[inline(never)]
fn same_shape(a: &Shape, b: &Shape) -> bool {
    #[cfg(target_arch = "m68k")]
    {
        extern "C" {
            fn __cspace_same_shape(a: *const Shape, b: *const Shape) -> u32;
        }
        // SAFETY: both point at whole shapes; the routine only reads them.
        unsafe { __cspace_same_shape(a, b) != 0 }
    }
    #[cfg(not(target_arch = "m68k"))]
    {
        a == b
    }
}

/// Copies columns `src` into `dst` (as long): on the 68020 the runtime's `MOVE.L` loop
/// (`__vme_read_words`, a plain word copy; `memcpy` spent ~2.5 cycles a byte).
#[inline(never)]
fn copy_columns(dst: &mut [MaybeUninit<Column>], src: &[MaybeUninit<Column>]) {
    debug_assert_eq!(dst.len(), src.len());
    #[cfg(target_arch = "m68k")]
    {
        extern "C" {
            fn __vme_read_words(src: *const u32, dst: *mut u32, n: u32);
        }
        const WORDS: usize = core::mem::size_of::<Column>() / 4;
        // SAFETY: both slices hold `src.len()` columns of `WORDS` words each (`Column` is
        // `repr(C)` of u32 and i32 fields, so 4-aligned); the routine copies them in order.
        unsafe {
            __vme_read_words(
                src.as_ptr().cast(),
                dst.as_mut_ptr().cast(),
                (src.len() * WORDS) as u32,
            )
        }
    }
    #[cfg(not(target_arch = "m68k"))]
    dst.copy_from_slice(src);
}

impl PairWork {
    /// Makes `*p` usable without writing its columns, records and kept images
    /// ([`crate::worklist::Scratch::init`]).
    ///
    /// # Safety
    /// `p` is valid for writes of a `PairWork`.
    pub(crate) unsafe fn init(p: *mut PairWork) {
        use core::ptr::addr_of_mut;
        // SAFETY: by the caller; the columns, records and kept images but their flags are
        // `MaybeUninit`.
        unsafe {
            addr_of_mut!((*p).cur).write([Cursor::NONE, Cursor::NONE]);
            addr_of_mut!((*p).buf).write([0; 10]);
            addr_of_mut!((*p).next).write(0);
            addr_of_mut!((*p).hits).write(0);
            let mut i = 0;
            while i < KEPT {
                addr_of_mut!((*p).kept[i].valid).write(false);
                i += 1;
            }
        }
    }
    /// Empty.
    pub const fn new() -> Self {
        Self {
            cols: [[const { MaybeUninit::uninit() }; MAX_COLUMNS]; 2],
            recs: [const { MaybeUninit::uninit() }; MAX_RECS],
            cur: [Cursor::NONE, Cursor::NONE],
            buf: [0; 10],
            kept: [const { Kept::EMPTY }; KEPT],
            next: 0,
            hits: 0,
        }
    }

    /// How many pairs found their old image's columns kept (wrapping): for the benches and
    /// the tests.
    pub fn hits(&self) -> u32 {
        self.hits
    }

    /// The slot keeping image `s`, or [`KEPT`] when none does.
    #[inline(never)]
    fn kept_slot(&self, s: &Shape) -> usize {
        find_slot(KEPT, |i| {
            let k = &self.kept[i];
            // SAFETY: a valid slot's shape was written with its flag.
            k.valid && same_shape(unsafe { k.shape.assume_init_ref() }, s)
        })
    }

    /// Copies slot `i`'s columns into the old image's (`cols[0]`); returns their range.
    #[inline(never)]
    fn take_kept(&mut self, i: usize) -> (i32, i32) {
        let PairWork { cols, kept, .. } = self;
        let k = &kept[i];
        // SAFETY: a valid slot's range and columns were written with its flag.
        let range = unsafe { k.range.assume_init() };
        let n = (range.1 - range.0 + 1) as usize;
        copy_columns(&mut cols[0][..n], &k.cols[..n]);
        range
    }

    /// Keeps the new image `s` and its columns (`cols[1]`, range `nc`) in slot `i`, or in
    /// the next slot round when `i` is [`KEPT`].
    #[inline(never)]
    fn keep(&mut self, s: &Shape, nc: (i32, i32), i: usize) {
        let i = kept_target(i, &mut self.next, KEPT);
        let PairWork { cols, kept, .. } = self;
        let k = &mut kept[i];
        let n = (nc.1 - nc.0 + 1) as usize;
        copy_columns(&mut k.cols[..n], &cols[1][..n]);
        k.shape.write(*s);
        k.range.write(nc);
        k.valid = true;
    }
}

impl Default for PairWork {
    fn default() -> Self {
        Self::new()
    }
}

/// Whether column `c` is within `range` (inclusive), by sign arithmetic in a function of
/// its own: compiled inline, the compare's condition codes were clobbered by register
/// copies before the branch on the 68k (docs/toolchain.md).
#[inline(never)]
fn within(c: i32, range: (i32, i32)) -> bool {
    ((c - range.0) | (range.1 - c)) >> 31 == 0
}

/// Column `c` of an image whose columns `range` are in `cols` ([`NO_COLUMN`] outside);
/// the caller has written every column of `range`.
#[inline(never)]
fn column_at(cols: &[MaybeUninit<Column>; MAX_COLUMNS], range: (i32, i32), c: i32) -> &Column {
    if within(c, range) {
        // SAFETY: the pair wrote every column of `range` (`all_columns`) before reading.
        unsafe { cols[(c - range.0) as usize].assume_init_ref() }
    } else {
        &NO_COLUMN
    }
}

/// The unwrapped columns `c0..=c1` of image `s` (none: an empty range).
fn columns(s: &Option<Shape>) -> (i32, i32) {
    match s {
        Some(s) => shape_columns(s),
        None => (END, -END),
    }
}

/// The unwrapped columns `c0..=c1` of image `s`.
fn shape_columns(s: &Shape) -> (i32, i32) {
    let t = &s.theta1_u;
    if s.wraps {
        let c0 = pix(t[0]);
        (c0, c0 + CSPACE_SIDE as i32)
    } else {
        (pix(t[0] - 1), pix(t[t.len() - 1] + 1))
    }
}

/// Moves `old` by whole revolutions (the same pixels) so that it lies within half a
/// revolution of `new` along theta1: then their columns and rows pair up unwrapped.
fn align(old: &mut Shape, new: &Shape) {
    let mut d = 0;
    while old.theta1_u[0] + d - new.theta1_u[0] > crate::HALF_REV {
        d -= crate::UNITS_PER_REV;
    }
    while old.theta1_u[0] + d - new.theta1_u[0] < -crate::HALF_REV {
        d += crate::UNITS_PER_REV;
    }
    // Most moves need no turn (the loop below cost a job ~3,000 cycles an image for
    // nothing).
    if d == 0 {
        return;
    }
    for k in 0..old.theta1_u.len() {
        old.theta1_u[k] += d;
        old.upper_u[k] += d;
        old.lower_u[k] += d;
    }
}

/// Records a pair's walk holds: a small move gives a few runs a column where the images
/// differ, a move that parts them one whole column a column (an image spans at most 130).
/// A walk with more falls back to the host's walk, column by column (`walk_runs`). (24
/// in the unit tests, so that their moves take both ways.)
pub const MAX_RECS: usize = if cfg!(test) { 24 } else { 320 };

/// What a walk found in one map column: a run of rows whose counters differ
/// (`REC_RUN`: `row` the first, unwrapped, `rows` of them; `up` the counters the new image
/// adds there, `down` those the old one drops), or a column only one image has
/// (`REC_NEW`, `REC_OLD`: `row` its index in that image's columns).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct Rec {
    /// The kind in bits 0-7, the map column in bits 8-14.
    kind_col: u32,
    row: i32,
    rows: u32,
    up: u32,
    down: u32,
}

/// [`Rec`] kind: a run of rows where the images differ.
const REC_RUN: u32 = 0;
/// [`Rec`] kind: a column only the new image has.
const REC_NEW: u32 = 1;
/// [`Rec`] kind: a column only the old image has. (Unused on the 68020, whose walk is the
/// runtime's assembly.)
#[cfg_attr(target_arch = "m68k", allow(dead_code))]
const REC_OLD: u32 = 2;

const _: () = assert!(core::mem::size_of::<Rec>() == 20);

/// Walks every map column of two images' columns (`cols[0]` the old image's, range `oc`;
/// `cols[1]` the new one's, range `nc`), writing what differs into `recs`: the number of
/// records, or `MAX_RECS + 1` when they did not fit. Columns the same in both give
/// nothing; a column both have gives the runs of rows where their counters differ (the
/// breakpoints of both merged); a column one has gives it whole. On the 68020 it is
/// `__cspace_walk` in the runtime's assembly (the compiled walk spent some 2,000 cycles on
/// a column whose runs differ); on the host the cursors below, which the system tests
/// compare it with through the map.
#[inline(never)]
fn walk(w: &mut PairWork, oc: (i32, i32), nc: (i32, i32)) -> usize {
    #[cfg(target_arch = "m68k")]
    {
        extern "C" {
            fn __cspace_walk(
                old: *const Column,
                oc0: i32,
                oc1: i32,
                new: *const Column,
                nc0: i32,
                nc1: i32,
                out: *mut Rec,
                cap: u32,
            ) -> u32;
        }
        // SAFETY: `cols` holds the columns of both ranges (written by `all_columns`; an
        // empty range is never read); at most `MAX_RECS` records are written.
        unsafe {
            __cspace_walk(
                w.cols[0].as_ptr().cast(),
                oc.0,
                oc.1,
                w.cols[1].as_ptr().cast(),
                nc.0,
                nc.1,
                w.recs.as_mut_ptr().cast(),
                MAX_RECS as u32,
            ) as usize
        }
    }
    #[cfg(not(target_arch = "m68k"))]
    {
        let mut n = 0;
        let lo = oc.0.min(nc.0);
        let hi = oc.1.max(nc.1);
        for c in lo..hi + 1 {
            let ok = if within(c, oc) {
                Some(*column_at(&w.cols[0], oc, c))
            } else {
                None
            };
            let nk = if within(c, nc) {
                Some(*column_at(&w.cols[1], nc, c))
            } else {
                None
            };
            match (ok, nk) {
                (None, None) => {}
                (Some(k), None) | (None, Some(k)) => {
                    let (kind, range) = if nk.is_some() {
                        (REC_NEW, nc)
                    } else {
                        (REC_OLD, oc)
                    };
                    if n >= MAX_RECS {
                        return MAX_RECS + 1;
                    }
                    w.recs[n].write(Rec {
                        kind_col: kind | k.col << 8,
                        row: c - range.0,
                        rows: 0,
                        up: 0,
                        down: 0,
                    });
                    n += 1;
                }
                (Some(o), Some(k)) => {
                    let o = revolved(&o, &k);
                    if !differ(&o, &k) {
                        continue;
                    }
                    if !near(&o, &k) {
                        if n + 2 > MAX_RECS {
                            return MAX_RECS + 1;
                        }
                        for (kind, at) in [(REC_NEW, c - nc.0), (REC_OLD, c - oc.0)] {
                            w.recs[n].write(Rec {
                                kind_col: kind | k.col << 8,
                                row: at,
                                rows: 0,
                                up: 0,
                                down: 0,
                            });
                            n += 1;
                        }
                        continue;
                    }
                    let PairWork { recs, cur, buf, .. } = &mut *w;
                    let mut full = false;
                    walk_runs(&o, &k, cur, buf, &mut |r, rows, up, down| {
                        if n >= MAX_RECS {
                            full = true;
                            return;
                        }
                        recs[n].write(Rec {
                            kind_col: REC_RUN | k.col << 8,
                            row: r,
                            rows,
                            up,
                            down,
                        });
                        n += 1;
                    });
                    if full {
                        return MAX_RECS + 1;
                    }
                }
            }
        }
        n
    }
}

/// How far (rows) a column's first or last row may move for the column to be updated by
/// its difference; one that moved further is drawn and erased whole (fewer, longer runs).
/// `WNEAR` in the runtime's `__cspace_walk`.
pub const NEAR_ROWS: i32 = 1;

/// A column whose ends moved further than [`NEAR_ROWS`] is still updated by its difference
/// when they moved together by at most its rows and the old one's over 2^`NEAR_SHIFT`
/// (long columns whose ends moved a little: their runs are shorter than both columns).
/// `WSHIFT` in the runtime's `__cspace_walk`.
pub const NEAR_SHIFT: u32 = 3;

/// Whether columns `o` and `k` (both there) are updated by their difference: within
/// [`NEAR_ROWS`] of each other at both ends, or within their rows over 2^[`NEAR_SHIFT`]
/// at both ends together.
fn near(o: &Column, k: &Column) -> bool {
    let d0 = (k.first - o.first).abs();
    let d1 = (k.first + k.rows as i32 - o.first - o.rows as i32).abs();
    (d0 <= NEAR_ROWS && d1 <= NEAR_ROWS) || d0 + d1 <= ((o.rows + k.rows) >> NEAR_SHIFT) as i32
}

/// Column `o` with its rows moved by the whole revolutions of theta2 (128 rows: the same
/// pixels) that bring its first row nearest `k`'s, when both have rows (`o` as it is
/// when either is [`NO_COLUMN`]): near the elbow's circle an image's columns can lie a
/// revolution apart in theta2 after a small move, and compared unwrapped they were erased
/// and drawn again whole. (Sign arithmetic, no compare: a function of its own for the
/// 68k, docs/toolchain.md.)
#[inline(never)]
fn revolved(o: &Column, k: &Column) -> Column {
    const _: () = assert!(CSPACE_SIDE == 128);
    // 1 when both have rows (1..=128: the negation's sign bit), else 0.
    let both = (o.rows.wrapping_neg() & k.rows.wrapping_neg()) >> 31;
    let turns = ((k.first - o.first + 64) >> 7) * both as i32;
    Column {
        first: o.first + (turns << 7),
        ..*o
    }
}

/// The runs of rows where columns `o` (old) and `k` (new) of one map column differ, as
/// (first row unwrapped, rows, counters the new adds, counters the old drops), from the
/// bottom up: the two columns' runs walked together by two cursors.
fn walk_runs(
    o: &Column,
    k: &Column,
    cur: &mut [Cursor; 2],
    buf: &mut [u32; 10],
    emit: &mut impl FnMut(i32, u32, u32, u32),
) {
    cur[0].set(o, buf);
    cur[1].set(k, buf);
    let mut r = -END;
    loop {
        let n = min_i(cur[0].ends[cur[0].p], cur[1].ends[cur[1].p]);
        let (mo, mn) = (cur[0].masks[cur[0].p], cur[1].masks[cur[1].p]);
        if (mo ^ mn) != 0 {
            emit(r, (n - r) as u32, mn & !mo, mo & !mn);
        }
        if n >= END {
            break;
        }
        r = n;
        cur[0].advance(r);
        cur[1].advance(r);
    }
}

/// Where a pair's differences go: with a log (the first half) the increments to the canvas
/// and the decrements to the log; without one (the second half) the decrements to the
/// canvas. `ok` turns false when the log fills up.
struct Apply<'a, C: Canvas> {
    canvas: &'a mut C,
    log: Option<&'a mut RunLog>,
    ok: bool,
    f: Flags,
}

impl<'a, C: Canvas> Apply<'a, C> {
    fn new(canvas: &'a mut C, log: Option<&'a mut RunLog>) -> Self {
        Self {
            canvas,
            log,
            ok: true,
            f: Flags::default(),
        }
    }
    /// `rows` rows of map column `col` from row `row` (unwrapped): `up` the counters the new
    /// image adds there, `down` those the old one drops.
    fn run(&mut self, col: u32, row: i32, rows: u32, up: u32, down: u32) {
        if let Some(l) = self.log.as_deref_mut() {
            if up != 0 {
                let fl = self.canvas.run(col, row as u32, rows, up, Op::Draw);
                self.f.merge(fl);
            }
            if down != 0 && self.ok {
                self.ok = l.push(col, row, rows, down);
            }
        } else if down != 0 {
            let fl = self.canvas.run(col, row as u32, rows, down, Op::Erase);
            self.f.merge(fl);
        }
    }
    /// A column only the new image has (or redrawn whole): drawn in the first half.
    fn new_column(&mut self, k: &Column, buf: &mut [u32; 10]) {
        if self.log.is_some() {
            let fl = paint(self.canvas, k, Op::Draw, buf);
            self.f.merge(fl);
        }
    }
    /// A column only the old image has (or erased whole): logged in the first half, erased
    /// in the second.
    fn old_column(&mut self, k: &Column, buf: &mut [u32; 10]) {
        if let Some(l) = self.log.as_deref_mut() {
            if self.ok {
                self.ok = l.push_column(k);
            }
        } else {
            let fl = paint(self.canvas, k, Op::Erase, buf);
            self.f.merge(fl);
        }
    }
    /// The flags and whether the log held everything; a pair whose words did not all fit
    /// loses those it had from `start` on.
    fn finish(self, start: usize) -> (Flags, bool) {
        if !self.ok {
            if let Some(l) = self.log {
                l.truncate(start);
            }
        }
        (self.f, self.ok)
    }
}

/// A link-2 image moved (`old` to `new`; either may be absent) as a differential update:
/// every pixel counter the new image sets and the old one does not is incremented, every
/// one the old sets and the new does not is decremented, the rest are left alone. After
/// both halves the map is what drawing `new` and erasing `old` would leave, but a small
/// move touches only the rows where the images' boundaries moved instead of every pixel of
/// both images twice (the interiors of a 2-inch obstacle's images are thousands of pixels).
/// Columns only one image has are drawn or erased whole.
///
/// With `log`, this is the first half: the increments go to the canvas and the decrements
/// to the log, for [`RunLog::erase`] once every first half of the job is done (new before
/// old: no void opens, thesis lines 1199-1210). Returns false when the log filled up (this
/// pair's words are then dropped and the caller runs the second half without a log).
/// Without `log`, this is the second half: the decrements go to the canvas. `old` is first
/// aligned to `new` (moved by whole revolutions: the same pixels).
#[inline(never)]
pub fn pair<C: Canvas>(
    old: &mut Option<Shape>,
    new: &Option<Shape>,
    canvas: &mut C,
    log: Option<&mut RunLog>,
    w: &mut PairWork,
) -> (Flags, bool) {
    // The old image's columns from the pair that drew it, when kept and not moved by
    // whole revolutions below.
    let mut slot = match old {
        Some(o) => w.kept_slot(o),
        None => KEPT,
    };
    if let (Some(o), Some(n)) = (old.as_mut(), new) {
        let was = o.theta1_u[0];
        align(o, n);
        if o.theta1_u[0] != was {
            slot = KEPT;
        }
    }
    let start = log.as_deref().map_or(0, RunLog::len);
    let (oc, nc) = (columns(old), columns(new));
    if let Some(s) = old {
        if slot < KEPT {
            let kept = w.take_kept(slot);
            debug_assert_eq!(kept, oc);
            w.hits = w.hits.wrapping_add(1);
        } else {
            all_columns(s, oc.0, oc.1, &mut w.cols[0]);
        }
    }
    if let Some(s) = new {
        all_columns(s, nc.0, nc.1, &mut w.cols[1]);
        // Kept for the next job on this entry (in the old image's slot, which it replaces);
        // the second half (no log) only computes again what the first had.
        if log.is_some() {
            w.keep(s, nc, slot);
        }
    }
    let n = walk(w, oc, nc);
    let mut a = Apply::new(canvas, log);
    if n > MAX_RECS {
        // Too many records: the columns one by one, each walked and applied at once.
        pair_slow(oc, nc, &mut a, w);
        return a.finish(start);
    }
    let mut i = 0;
    while i < n {
        // SAFETY: `walk` wrote the first `n` records.
        let r = unsafe { w.recs[i].assume_init() };
        i += 1;
        let kind = r.kind_col & 0xFF;
        if kind == REC_RUN {
            a.run(r.kind_col >> 8 & WRAP, r.row, r.rows, r.up, r.down);
        } else if kind == REC_NEW {
            // SAFETY: the walk's index is within the new image's columns.
            let k = unsafe { w.cols[1][r.row as usize].assume_init_ref() };
            a.new_column(k, &mut w.buf);
        } else {
            // SAFETY: the walk's index is within the old image's columns.
            let k = unsafe { w.cols[0][r.row as usize].assume_init_ref() };
            a.old_column(k, &mut w.buf);
        }
    }
    a.finish(start)
}

/// [`pair`] column by column when its records did not fit: each column walked by the
/// cursors and applied at once.
#[inline(never)]
fn pair_slow<C: Canvas>(oc: (i32, i32), nc: (i32, i32), a: &mut Apply<'_, C>, w: &mut PairWork) {
    let lo = min_i(oc.0, nc.0);
    let hi = -min_i(-oc.1, -nc.1);
    // An index loop counted up to the number of columns (a `lo..=hi` range compiled to a
    // select that clobbered the condition codes on the 68k).
    let count = hi - lo + 1;
    let mut i = 0;
    while i < count {
        let c = lo + i;
        i += 1;
        let PairWork { cols, cur, buf, .. } = &mut *w;
        let ncol = column_at(&cols[1], nc, c);
        let ocol = &revolved(column_at(&cols[0], oc, c), ncol);
        if !differ(ocol, ncol) {
            continue;
        }
        if ocol.rows == 0 || ncol.rows == 0 || !near(ocol, ncol) {
            if ncol.rows != 0 {
                a.new_column(ncol, buf);
            }
            if ocol.rows != 0 {
                a.old_column(ocol, buf);
            }
            continue;
        }
        let col = ncol.col;
        walk_runs(ocol, ncol, cur, buf, &mut |r, rows, up, down| {
            a.run(col, r, rows, up, down)
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{images, Disk, Memory};

    /// An obstacle moved step by step, a pair each step sharing one `PairWork`: from the
    /// second step on each pair's old image is found kept, its kept columns are those
    /// computed afresh, and twelve other images passing through the round robin meanwhile
    /// evict it only once they fill every slot.
    #[test]
    fn a_moved_images_columns_are_kept_for_its_next_move() {
        let mut w = PairWork::new();
        let mut h = Memory::default();
        let disk = |k: i32| Disk {
            x_um: 150_000 + 1_000 * k,
            y_um: 40_000,
            r_um: 28_500,
        };
        let mut was = images(&disk(0)).unwrap().front;
        for k in 1..6 {
            let now = images(&disk(k)).unwrap().front;
            let slot = w.kept_slot(was.as_ref().unwrap());
            assert_eq!(slot < KEPT, k > 1, "step {k}: kept slot {slot}");
            if slot < KEPT {
                let oc = columns(&was);
                let got = w.take_kept(slot);
                assert_eq!(got, oc);
                let mut fresh = PairWork::new();
                all_columns(was.as_ref().unwrap(), oc.0, oc.1, &mut fresh.cols[1]);
                for i in 0..(oc.1 - oc.0 + 1) as usize {
                    // SAFETY: both were written over the range.
                    let (a, b) =
                        unsafe { (w.cols[0][i].assume_init(), fresh.cols[1][i].assume_init()) };
                    assert_eq!(a, b, "step {k}, column {i}");
                }
            }
            let mut log = RunLog::new();
            pair(
                &mut was.clone(),
                &now,
                &mut h.canvas(),
                Some(&mut log),
                &mut w,
            );
            was = now;
        }
        // Other images fill the slots round: the last one kept survives eleven more, not
        // twelve.
        let last = was.unwrap();
        for k in 0..KEPT as i32 {
            let other = images(&disk(100 + 3 * k)).unwrap().front;
            let mut log = RunLog::new();
            assert!(w.kept_slot(&last) < KEPT, "evicted after {k} others");
            pair(&mut None, &other, &mut h.canvas(), Some(&mut log), &mut w);
        }
        assert_eq!(
            w.kept_slot(&last),
            KEPT,
            "still kept after every slot was taken"
        );
    }
}
