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
    #[inline]
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
}

const WRAP: u32 = CSPACE_SIDE - 1;

/// Floor division by the pixel size (arithmetic shift: rounds toward minus infinity).
#[inline(always)]
fn pix(u: i32) -> i32 {
    u >> 8
}

/// Draws or erases a link-1 stripe on the stripe layer.
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

/// Draws or erases a link-2 image on the map.
pub fn shape<C: Canvas>(s: &Shape, canvas: &mut C, op: Op) -> Flags {
    let mut f = Flags::default();
    let t = &s.theta1_u;
    let (t_first, t_last) = (t[0] - 1, t[t.len() - 1] + 1);
    let (c0, c1) = if s.wraps {
        let c0 = pix(t[0]);
        (c0, c0 + CSPACE_SIDE as i32)
    } else {
        (pix(t_first), pix(t_last))
    };
    let n = t.len();
    let mut k = 0usize; // segment holding the strip's left edge
    for c in c0..c1 + 1 {
        let a = (c * UNITS_PER_PIXEL).max(t[0]);
        let b = (c * UNITS_PER_PIXEL + UNITS_PER_PIXEL).min(t[n - 1]);
        // Extremes of both chains over [a, b].
        while k + 2 < n && t[k + 1] <= a {
            k += 1;
        }
        let (ua, la) = (
            eval(t, &s.upper_u, k, a, true),
            eval(t, &s.lower_u, k, a, false),
        );
        let (mut umax, mut umin, mut lmax, mut lmin) = (ua, ua, la, la);
        let mut j = k;
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
        umax = umax.max(ub);
        umin = umin.min(ub);
        lmax = lmax.max(lb);
        lmin = lmin.min(lb);
        let first = pix(lmin);
        let last = pix(umax);
        let col = c as u32 & WRAP;
        if last - first + 1 >= CSPACE_SIDE as i32 {
            for r in 0..CSPACE_SIDE {
                f.merge(canvas.pixel(col, r, ALL, op));
            }
            continue;
        }
        let lower_to = pix(lmax);
        let upper_from = pix(umin);
        let upper_mask = P2 | slope_mask(ua, ub, M1, P1);
        let lower_mask = M2 | slope_mask(la, lb, P1, M1);
        let ends = if s.wraps {
            0
        } else if c == c0 {
            M1
        } else if c == c1 {
            P1
        } else {
            0
        };
        for r in first..last + 1 {
            let mut m = 0;
            if r <= lower_to {
                m |= lower_mask;
            }
            if r >= upper_from {
                m |= upper_mask;
            }
            let m = if m == 0 { ALL } else { m | ends };
            f.merge(canvas.pixel(col, r as u32 & WRAP, m, op));
        }
    }
    f
}
