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

use crate::counters::{self, Flags, ALL, M1, M2, P1, P2};
use crate::{Shape, Stripe, UNITS_PER_PIXEL};
use vme_map::layout::{cspace_counter, CSPACE_SIDE, CSPACE_STRIPES};
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

impl<B: GlobalBus + ?Sized> Canvas for BusCanvas<'_, B> {
    #[inline(always)]
    fn pixel(&mut self, i1: u32, i2: u32, mask: u32, op: Op) -> Flags {
        let a = cspace_counter(i1, i2, 0);
        let (v, f) = update(self.0.read_u32(a), mask, op);
        self.0.write_u32(a, v);
        f
    }
    #[inline]
    fn stripe(&mut self, i1: u32, mask: u32, op: Op) -> Flags {
        let a = CSPACE_STRIPES + 4 * i1;
        let (v, f) = update(self.0.read_u32(a), mask, op);
        self.0.write_u32(a, v);
        f
    }
    /// The whole column in one [`GlobalBus::count_column`] call (the runtime's assembly on
    /// the 68020); a pixel it stops at takes the byte-by-byte update and the column goes on
    /// after it.
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
                return f;
            }
            f.merge(self.pixel(i1, i2.wrapping_add(done) & WRAP, mask_at(pieces, done), op));
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

/// One column of an image: which pixels to update with which counters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Column {
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
fn column(s: &Shape, c: i32, c0: i32, c1: i32, k: &mut usize, edge: &mut Edge) -> Column {
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
    Column {
        col: c as u32 & WRAP,
        first,
        rows: span.clamp(1, CSPACE_SIDE as i32) as u32,
        lower_rows: (pix(lmax) - first + 1).max(0) as u32,
        upper_from: (pix(umin) - first).max(0) as u32,
        lower_mask: M2 | slope_mask(la, lb, P1, M1),
        upper_mask: P2 | slope_mask(ua, ub, M1, P1),
        ends,
    }
}

/// Updates the pixels of one column as five runs of rows (some empty) with one set of
/// counters each, in one [`Canvas::column`] call: the rows only the lower chain crosses, the
/// rows both chains cross (below the interior), the interior with all four counters, the
/// rows both cross (above it), the rows only the upper chain crosses. Every row gets its
/// edge counters plus the image's end counters, or all four inside; a full column is all
/// interior. The bounds are taken without branches on compares (sign arithmetic: every
/// count is below 2^8): the selects the compiler made of the plain form clobbered the
/// condition codes on the 68k (docs/toolchain.md).
#[inline(never)]
fn paint<C: Canvas>(canvas: &mut C, k: &Column, op: Op) -> Flags {
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
    let pieces = [
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
    canvas.column(k.col, k.first as u32, &pieces, op)
}

/// Draws or erases a link-2 image on the map. (Not inlined: its callers hold the image on
/// their stack frame, and the 68k backend drops the index register when a function indexes
/// its own frame's arrays, llvm/llvm-project#200984.)
#[inline(never)]
pub fn shape<C: Canvas>(s: &Shape, canvas: &mut C, op: Op) -> Flags {
    let mut f = Flags::default();
    let t = &s.theta1_u;
    let (c0, c1) = if s.wraps {
        let c0 = pix(t[0]);
        (c0, c0 + CSPACE_SIDE as i32)
    } else {
        (pix(t[0] - 1), pix(t[t.len() - 1] + 1))
    };
    let mut k = 0usize; // segment holding the strip's left edge
    let mut edge = Edge::NONE;
    for c in c0..c1 + 1 {
        let col = column(s, c, c0, c1, &mut k, &mut edge);
        f.merge(paint(canvas, &col, op));
    }
    f
}
