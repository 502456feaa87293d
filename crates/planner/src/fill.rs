//! Reachability (beyond the thesis, which had no test for an unreachable goal but cycling,
//! ch. VI section 4): the set of pixels the arm can reach from where it is through pixels
//! the map does not mark, found by a fill of the torus in bitmap rows, a few rows per
//! planner cycle, and started again when it settles. Each row takes what its neighbours
//! above and below reached, keeps its free pixels, and spreads along its free runs; passes
//! go down then up the map until one changes nothing. A settled fill is the whole connected
//! free region around the arm (4-connected): a goal outside it cannot be reached while the
//! map stays as it is. The fill uses the marked pixels, not the planner's wider blocked
//! cells ([`crate::grid`]): the reflex lets the arm closer to a wall than the planner's
//! clearance, so the arm can be where a fill of the blocked cells would not reach, and an
//! unreachable verdict must hold for the arm wherever it is.

use crate::grid::{spread, Grid, Row, SIDE, WORDS};

/// Fill rows worked per turn (every other planner cycle), at most.
pub const ROWS_PER_CYCLE: u32 = 3;
/// Rows looked at per planner cycle (at most).
pub const SCAN_PER_CYCLE: u32 = 32;
/// Rows of the bitmap cleared per planner cycle before a fill starts.
pub const CLEAR_PER_CYCLE: u32 = 8;
/// Passes after which an unsettled fill is abandoned (and started again): a free region
/// needs one pass per turn of its most winding path; 128 x 128 random disks need < 10.
pub const MAX_PASSES: u32 = 256;

/// Farthest (Chebyshev) a fill looks for unmarked pixels to start from around the arm.
pub const SEED_PX: i32 = 4;

/// The fill's state.
#[derive(Clone, Debug)]
pub struct Fill {
    /// Three bitmaps: the fill in progress and the last settled fill of each kind, by
    /// index (handing a settled fill over swaps indices, not 2 KiB of rows).
    bufs: [[Row; 128]; 3],
    /// The fill in progress.
    work_i: usize,
    /// The last settled fills: through the marked pixels, through the blocked cells.
    row: u32,
    pass: u32,
    changed: u32,
    /// Fills settled so far.
    settled: u32,
    /// Seed cells of the fill in progress.
    seeds: u32,
    /// Where the fill in progress starts.
    from: [i32; 2],
    /// The next row of the work bitmap to clear (128: cleared, 129: seeded too).
    clear_row: u32,
    /// Rows that need work (bit `r & 31` of word `r >> 5`).
    dirty: Row,
    /// Whether the fill in progress goes through the planner's blocked cells (1) or the
    /// marked pixels (0).
    clear: u32,
    /// Whether a fill of each kind has settled (marked, blocked).
    has_last: [bool; 2],
    last_i: [usize; 2],
}

impl Default for Fill {
    fn default() -> Self {
        Self::new()
    }
}

#[inline(always)]
fn bit(rows: &[Row; 128], c: [i32; 2]) -> u32 {
    let i1 = (c[0] & (SIDE - 1)) as u32;
    let i2 = (c[1] & (SIDE - 1)) as usize;
    (rows[i2][(i1 >> 5) as usize] >> (i1 & 31)) & 1
}

impl Fill {
    /// No fill yet.
    pub const fn new() -> Self {
        Self {
            bufs: [[[0; WORDS]; 128]; 3],
            work_i: 0,
            row: 0,
            pass: 0,
            changed: 0,
            settled: 0,
            seeds: 0,
            from: [0; 2],
            clear_row: 129,
            dirty: [0; WORDS],
            clear: 0,
            has_last: [false; 2],
            last_i: [1, 2],
        }
    }

    /// Fills settled so far.
    pub fn settled(&self) -> u32 {
        self.settled
    }

    /// 1 when the last settled fill through the marked pixels reached cell `c`, 0 when it
    /// did not, 2 when no such fill has settled yet.
    pub fn reached(&self, c: [i32; 2]) -> u32 {
        if !self.has_last[0] {
            return 2;
        }
        bit(&self.bufs[self.last_i[0]], c)
    }

    /// The same for the last settled fill through the planner's blocked cells.
    pub fn reached_clear(&self, c: [i32; 2]) -> u32 {
        if !self.has_last[1] {
            return 2;
        }
        bit(&self.bufs[self.last_i[1]], c)
    }

    /// Whether the fill in progress (or the one that just settled) went through the
    /// blocked cells.
    pub fn is_clear(&self) -> bool {
        self.clear != 0
    }

    /// Starts a fill from the arm's pixel `from`, or if the map marks it (its margins
    /// reach over the arm), from the nearest ring of unmarked pixels within [`SEED_PX`]
    /// (a wider start could jump a thin wall); through the planner's blocked cells when
    /// `through_blocked`. A fill without seed pixels gives no verdict.
    #[inline(never)]
    pub fn start(&mut self, g: &Grid, from: [i32; 2], through_blocked: bool) {
        let _ = g;
        self.clear = through_blocked as u32;
        self.from = from;
        // The bitmap is cleared a slice per call of `work` before the seeds go in (all at
        // once it was 33,000 cycles on the 68020).
        self.clear_row = 0;
        self.seeds = 0;
        self.row = 0;
        self.pass = 0;
        // The first pass runs whole even if it changes nothing (it did the seeds).
        self.changed = 1;
    }

    /// Clears the next slice of the work bitmap; once it is all clear, seeds the fill.
    #[inline(never)]
    fn prepare(&mut self, g: &Grid) {
        if self.clear_row < 128 {
            let end = self.clear_row + CLEAR_PER_CYCLE;
            clear_rows(&mut self.bufs[self.work_i], self.clear_row, end);
            self.clear_row = end;
            return;
        }
        // Cleared: the seeds, in a call of their own.
        self.clear_row = 129;
        let from = self.from;
        let mut r = 0;
        let mut seeds = 0;
        while r <= SEED_PX && seeds == 0 {
            seeds = self.seed(g, from, r);
            r += 1;
        }
        self.seeds = seeds;
        // The seed rows and their neighbours need work first.
        self.dirty = [0; WORDS];
        let mut d = -(SEED_PX + 1);
        while d <= SEED_PX + 1 {
            mark(&mut self.dirty, ((from[1] + d) & (SIDE - 1)) as u32, 1);
            d += 1;
        }
    }

    /// Seeds the free cells at Chebyshev distance `r` from `from`; returns how many.
    #[inline(never)]
    fn seed(&mut self, g: &Grid, from: [i32; 2], r: i32) -> u32 {
        let mut n = 0;
        // All ones when the fill goes through the blocked cells.
        let through = self.clear.wrapping_neg();
        let mut d2 = -r;
        while d2 <= r {
            // The ring at distance r only (the rings inside had no free pixel).
            let edge = (d2 == -r || d2 == r) as i32;
            let step = edge + (1 - edge) * (2 * r).max(1);
            let i2 = ((from[1] + d2) & (SIDE - 1)) as u32;
            n += seed_row(
                &mut self.bufs[self.work_i][i2 as usize],
                g.marked_row(i2),
                g.blocked_row(i2),
                through,
                from[0] - r,
                from[0] + r,
                step,
            );
            d2 += 1;
        }
        n
    }

    /// Works up to `rows` rows of the fill that need it (a row needs work when a neighbour
    /// changed since it was last done), looking at no more than [`SCAN_PER_CYCLE`] rows.
    /// Returns 1 when the fill settled (a whole pass found no row to do) or gave up in this
    /// call: the caller starts the next one.
    #[inline(never)]
    pub fn work(&mut self, g: &Grid, rows: u32) -> u32 {
        if self.clear_row <= 128 {
            self.prepare(g);
            return 0;
        }
        let mut n = 0;
        let mut scanned = 0;
        while n < rows && scanned < SCAN_PER_CYCLE {
            // Down on even passes, up on odd ones.
            let r = if self.pass & 1 == 0 {
                self.row
            } else {
                127 - self.row
            };
            let w = (r >> 5) as usize;
            let bit = 1u32 << (r & 31);
            // A word of rows with nothing to do is passed over whole (both directions stay
            // within a word's 32 rows until they cross a multiple of 32).
            let skip = if self.dirty[w] == 0 {
                31 - (self.row & 31)
            } else {
                0
            };
            self.row += skip;
            scanned += skip;
            if self.dirty[w] & bit != 0 {
                self.dirty[w] &= !bit;
                let changed = self.update_row(g, r);
                self.changed |= changed & 1;
                // The rows above and below take what this one reached; a row that could
                // spread further along itself is visited again.
                mark(&mut self.dirty, (r + 127) & 127, changed & 1);
                mark(&mut self.dirty, (r + 1) & 127, changed & 1);
                mark(&mut self.dirty, r, changed >> 1);
                n += 1;
            }
            scanned += 1;
            self.row += 1;
            if self.row == 128 {
                self.row = 0;
                self.pass += 1;
                if self.changed == 0 {
                    // A fill with no seed (the arm deep in blocked cells) says nothing.
                    if self.seeds != 0 {
                        let k = self.clear as usize;
                        core::mem::swap(&mut self.last_i[k], &mut self.work_i);
                        self.has_last[k] = true;
                        self.settled += 1;
                    }
                    return 1;
                }
                if self.pass >= MAX_PASSES {
                    return 1;
                }
                self.changed = 0;
            }
        }
        0
    }

    /// One row: what the rows above and below reached, its own free cells, spread along
    /// the row ([`spread`]'s few steps). Returns bit 0 set if the row changed, bit 1 if it
    /// would spread further.
    #[inline(never)]
    fn update_row(&mut self, g: &Grid, r: u32) -> u32 {
        let up = ((r + 127) & 127) as usize;
        let dn = ((r + 1) & 127) as usize;
        let b = if self.clear != 0 {
            g.blocked_row(r)
        } else {
            g.marked_row(r)
        };
        let free: Row = [!b[0], !b[1], !b[2], !b[3]];
        let mut n: Row = [0; WORDS];
        merge(
            &mut n,
            &self.bufs[self.work_i][r as usize],
            &self.bufs[self.work_i][up],
            &self.bufs[self.work_i][dn],
        );
        let more = spread(&mut n, &free);
        let old = &mut self.bufs[self.work_i][r as usize];
        let diff = (n[0] ^ old[0]) | (n[1] ^ old[1]) | (n[2] ^ old[2]) | (n[3] ^ old[3]);
        old[0] = n[0];
        old[1] = n[1];
        old[2] = n[2];
        old[3] = n[3];
        ((diff != 0) as u32) | (more << 1)
    }
}

/// Seeds the free cells of one row among columns `c0, c0 + step, ..` up to `c1` (unwrapped):
/// free where neither `marked` nor (with `through` all ones) `blocked` has the bit. Returns
/// how many. The rows come by reference, the bits with word operations (a cell through
/// the grid's accessors cost some 330 cycles on the 68020).
#[inline(never)]
fn seed_row(
    work: &mut Row,
    marked: &Row,
    blocked: &Row,
    through: u32,
    c0: i32,
    c1: i32,
    step: i32,
) -> u32 {
    let mut n = 0;
    let mut c = c0;
    while c <= c1 {
        let i1 = (c & (SIDE - 1)) as u32;
        let w = (i1 >> 5) as usize;
        let bit = 1u32 << (i1 & 31);
        let free = !(marked[w] | (blocked[w] & through)) & bit;
        work[w] |= free;
        n += free >> (i1 & 31);
        c += step;
    }
    n
}

/// Sets row `r`'s bit in `dirty` when `on` is 1.
#[inline(always)]
fn mark(dirty: &mut Row, r: u32, on: u32) {
    dirty[(r >> 5) as usize] |= on << (r & 31);
}

/// `n` = `a` | `b` | `c`.
#[inline(never)]
fn merge(n: &mut Row, a: &Row, b: &Row, c: &Row) {
    n[0] = a[0] | b[0] | c[0];
    n[1] = a[1] | b[1] | c[1];
    n[2] = a[2] | b[2] | c[2];
    n[3] = a[3] | b[3] | c[3];
}

/// Clears rows `from .. to` of a bitmap.
#[inline(never)]
fn clear_rows(rows: &mut [Row; 128], from: u32, to: u32) {
    let mut r = from as usize;
    while r < to as usize {
        let row = &mut rows[r];
        row[0] = 0;
        row[1] = 0;
        row[2] = 0;
        row[3] = 0;
        r += 1;
    }
}
