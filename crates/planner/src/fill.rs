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

/// Fill rows per planner cycle.
pub const ROWS_PER_CYCLE: u32 = 16;
/// Passes after which an unsettled fill is abandoned (and started again): a free region
/// needs one pass per turn of its most winding path; 128 x 128 random disks need < 10.
pub const MAX_PASSES: u32 = 48;

/// Farthest (Chebyshev) a fill looks for unmarked pixels to start from around the arm.
pub const SEED_PX: i32 = 4;

/// The fill's state.
#[derive(Clone, Debug)]
pub struct Fill {
    reach: [Row; 128],
    row: u32,
    pass: u32,
    changed: u32,
    /// Fills settled so far.
    settled: u32,
    /// Seed cells of the fill in progress.
    seeds: u32,
    /// Whether the fill in progress goes through the planner's blocked cells (1) or the
    /// marked pixels (0).
    clear: u32,
    /// Whether a fill of each kind has settled (marked, blocked).
    has_last: [bool; 2],
    /// The last settled fill through the marked pixels.
    last: [Row; 128],
    /// The last settled fill through the planner's blocked cells (the arm kept a pixel from
    /// anything marked: where the planner can lead it).
    last_clear: [Row; 128],
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
            reach: [[0; WORDS]; 128],
            row: 0,
            pass: 0,
            changed: 0,
            settled: 0,
            seeds: 0,
            clear: 0,
            has_last: [false; 2],
            last: [[0; WORDS]; 128],
            last_clear: [[0; WORDS]; 128],
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
        bit(&self.last, c)
    }

    /// The same for the last settled fill through the planner's blocked cells.
    pub fn reached_clear(&self, c: [i32; 2]) -> u32 {
        if !self.has_last[1] {
            return 2;
        }
        bit(&self.last_clear, c)
    }

    /// Whether the fill in progress (or the one that just settled) went through the
    /// blocked cells.
    pub fn is_clear(&self) -> bool {
        self.clear != 0
    }

    /// Starts a fill from the arm's pixel `from`, or if the map marks it (its margins
    /// reach over the arm), from the nearest ring of unmarked pixels within [`SEED_PX`]
    /// (a wider start could jump a thin wall). Returns the number of seed pixels: a fill
    /// without any gives no verdict.
    #[inline(never)]
    pub fn start(&mut self, g: &Grid, from: [i32; 2], through_blocked: bool) -> u32 {
        clear(&mut self.reach);
        self.clear = through_blocked as u32;
        let mut r = 0;
        let mut seeds = 0;
        while r <= SEED_PX && seeds == 0 {
            seeds = self.seed(g, from, r);
            r += 1;
        }
        self.seeds = seeds;
        self.row = 0;
        self.pass = 0;
        self.changed = 0;
        seeds
    }

    /// Seeds the free cells within `r` of `from`; returns how many.
    #[inline(never)]
    fn seed(&mut self, g: &Grid, from: [i32; 2], r: i32) -> u32 {
        let mut n = 0;
        let mut d2 = -r;
        while d2 <= r {
            let mut d1 = -r;
            while d1 <= r {
                let c = [from[0] + d1, from[1] + d2];
                let free = (g.marked(c) | (g.blocked(c) & self.clear)) ^ 1;
                let i1 = (c[0] & (SIDE - 1)) as u32;
                let i2 = (c[1] & (SIDE - 1)) as usize;
                self.reach[i2][(i1 >> 5) as usize] |= free << (i1 & 31);
                n += free;
                d1 += 1;
            }
            d2 += 1;
        }
        n
    }

    /// Works `rows` rows of the fill. Returns 1 when the fill settled (or gave up) in
    /// this call: the caller starts the next one.
    #[inline(never)]
    pub fn work(&mut self, g: &Grid, rows: u32) -> u32 {
        let mut n = 0;
        while n < rows {
            // Down on even passes, up on odd ones.
            let r = if self.pass & 1 == 0 {
                self.row
            } else {
                127 - self.row
            };
            self.changed |= self.update_row(g, r);
            self.row += 1;
            if self.row == 128 {
                self.row = 0;
                self.pass += 1;
                if self.changed == 0 {
                    // A fill with no seed (the arm deep in blocked cells) says nothing.
                    if self.seeds != 0 {
                        if self.clear != 0 {
                            core::mem::swap(&mut self.reach, &mut self.last_clear);
                            self.has_last[1] = true;
                        } else {
                            core::mem::swap(&mut self.reach, &mut self.last);
                            self.has_last[0] = true;
                        }
                        self.settled += 1;
                    }
                    return 1;
                }
                if self.pass >= MAX_PASSES {
                    return 1;
                }
                self.changed = 0;
            }
            n += 1;
        }
        0
    }

    /// One row: what the rows above and below reached, its own free cells, spread along
    /// the row. Returns 1 if the row changed.
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
            &self.reach[r as usize],
            &self.reach[up],
            &self.reach[dn],
        );
        spread(&mut n, &free);
        let old = &mut self.reach[r as usize];
        let diff = (n[0] ^ old[0]) | (n[1] ^ old[1]) | (n[2] ^ old[2]) | (n[3] ^ old[3]);
        old[0] = n[0];
        old[1] = n[1];
        old[2] = n[2];
        old[3] = n[3];
        (diff != 0) as u32
    }
}

/// `n` = `a` | `b` | `c`.
#[inline(never)]
fn merge(n: &mut Row, a: &Row, b: &Row, c: &Row) {
    n[0] = a[0] | b[0] | c[0];
    n[1] = a[1] | b[1] | c[1];
    n[2] = a[2] | b[2] | c[2];
    n[3] = a[3] | b[3] | c[3];
}

/// Clears a bitmap.
#[inline(never)]
fn clear(rows: &mut [Row; 128]) {
    let mut r = 0;
    while r < 128 {
        rows[r] = [0; WORDS];
        r += 1;
    }
}
