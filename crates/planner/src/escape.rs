//! The way out of a pocket of blocked cells (beyond the thesis, whose planner started wall
//! following where the arm stalled, ch. VI section 4): the free cell nearest a stalled arm
//! that it can reach through unmarked pixels.
//!
//! The reflex lets the arm nearer a wall than the planner's clearance ([`crate::grid`]), so
//! the arm can stall in blocked cells, and at the bottom of a pocket of them: a gap of one
//! to three pixels between two obstacles, which the arm slid into along a wall on its way
//! to the goal. Wall following needs a free cell to start from. The planner's first search,
//! a ring of cells round the arm four cells out, found none from the bottom of an 11-cell
//! pocket, or one across the wall, and the approaches then cycled for ever (cases
//! `reaches_every_reachable_goal` found). This search is a wave through the unmarked pixels,
//! a pixel each way per wave (4-connected), so it finds the pocket's mouth and never crosses
//! a wall; the first wave that reaches free cells gives the one nearest the goal.
//!
//! A wave is worked a row at a time in place (the row above is kept as it was before this
//! wave), [`ROWS_PER_CYCLE`] rows a planner cycle, up to [`ESCAPE_PX`] waves: a search from
//! the bottom of a 60-cell pocket is a few thousand rows, more than a 1 ms cycle on the
//! 68020 at once. The rows live in the planner, not on the stack (docs/toolchain.md, class
//! 6), and results are fields, not returned structs (class 7).

use crate::grid::{Grid, Row, SIDE, WORDS};

/// Waves (steps through unmarked pixels) the search takes at most: the window's rows stay
/// distinct on the 128-row torus.
pub const ESCAPE_PX: i32 = 63;
/// Rows worked per planner cycle, at most.
pub const ROWS_PER_CYCLE: u32 = 32;

/// [`Escape::work`]'s answers.
pub mod status {
    /// Still searching.
    pub const RUNNING: u32 = 0;
    /// Found: the cell is [`super::Escape::found`].
    pub const FOUND: u32 = 1;
    /// No free cell within [`super::ESCAPE_PX`] steps.
    pub const NONE: u32 = 2;
}

/// The search's state.
#[derive(Clone, Debug)]
pub struct Escape {
    /// The wave, by torus row.
    rows: [Row; 128],
    /// Where the search started and the goal it prefers, unwrapped cells.
    from: [i32; 2],
    goal: [i32; 2],
    /// The wave being worked (its number: steps from `from`) and its next row's offset
    /// from `from`'s row.
    k: i32,
    j: i32,
    /// The row above the next one as it was before this wave.
    above: Row,
    /// Bits of free cells the wave being worked has reached (nonzero: stop after it).
    any: u32,
    /// Whether a search is running.
    active: u32,
    /// The cell found.
    found: [i32; 2],
}

impl Default for Escape {
    fn default() -> Self {
        Self::new()
    }
}

impl Escape {
    /// No search.
    pub const fn new() -> Self {
        Self {
            rows: [[0; WORDS]; 128],
            from: [0; 2],
            goal: [0; 2],
            k: 0,
            j: 0,
            above: [0; WORDS],
            any: 0,
            active: 0,
            found: [0; 2],
        }
    }

    /// The cell the last search found (valid after [`status::FOUND`]).
    pub fn found(&self) -> [i32; 2] {
        self.found
    }

    /// Starts a search from `from` (unwrapped cell) preferring cells nearest `goal`.
    #[inline(never)]
    pub fn start(&mut self, from: [i32; 2], goal: [i32; 2]) {
        clear(&mut self.rows);
        self.from = from;
        self.goal = goal;
        let x = (from[0] & (SIDE - 1)) as u32;
        let r = (from[1] & (SIDE - 1)) as usize;
        self.rows[r][(x >> 5) as usize] = 1 << (x & 31);
        self.k = 1;
        self.j = -1;
        self.above = [0; WORDS];
        self.any = 0;
        self.active = 1;
    }

    /// Works the search up to [`ROWS_PER_CYCLE`] rows on `g`: [`status`] says how it
    /// stands.
    #[inline(never)]
    pub fn work(&mut self, g: &Grid) -> u32 {
        if self.active == 0 {
            return status::NONE;
        }
        let mut n = 0;
        while n < ROWS_PER_CYCLE {
            self.wave_row(g);
            n += 1;
            self.j += 1;
            if self.j > self.k {
                // The wave is done.
                if self.any != 0 {
                    self.pick(g);
                    self.active = 0;
                    return status::FOUND;
                }
                if self.k >= ESCAPE_PX {
                    self.active = 0;
                    return status::NONE;
                }
                self.k += 1;
                self.j = -self.k;
                self.above = [0; WORDS];
                // The row above the window is outside it (never reached).
            }
        }
        status::RUNNING
    }

    /// Works the row at offset `j` of wave `k`: what it and its neighbours reached
    /// before this wave, grown a pixel along the row, through its unmarked pixels.
    #[inline(never)]
    fn wave_row(&mut self, g: &Grid) {
        let r = ((self.from[1] + self.j) & (SIDE - 1)) as u32;
        let below = if self.j < self.k {
            self.rows[((r + 1) & 127) as usize]
        } else {
            [0; WORDS]
        };
        let occ = g.marked_row(r);
        let blk = g.blocked_row(r);
        let row = &mut self.rows[r as usize];
        let b = *row;
        let up = self.above;
        let n0 =
            (b[0] | (b[0] << 1) | (b[3] >> 31) | (b[0] >> 1) | (b[1] << 31) | up[0] | below[0])
                & !occ[0];
        let n1 =
            (b[1] | (b[1] << 1) | (b[0] >> 31) | (b[1] >> 1) | (b[2] << 31) | up[1] | below[1])
                & !occ[1];
        let n2 =
            (b[2] | (b[2] << 1) | (b[1] >> 31) | (b[2] >> 1) | (b[3] << 31) | up[2] | below[2])
                & !occ[2];
        let n3 =
            (b[3] | (b[3] << 1) | (b[2] >> 31) | (b[3] >> 1) | (b[0] << 31) | up[3] | below[3])
                & !occ[3];
        row[0] = n0;
        row[1] = n1;
        row[2] = n2;
        row[3] = n3;
        self.above = b;
        self.any |= (n0 & !blk[0]) | (n1 & !blk[1]) | (n2 & !blk[2]) | (n3 & !blk[3]);
    }

    /// Of the free cells the last wave reached, the one nearest the goal (the first found
    /// among equals) into `found`.
    #[inline(never)]
    fn pick(&mut self, g: &Grid) {
        let mut best = i32::MAX;
        let mut j = -self.k;
        while j <= self.k {
            let y = self.from[1] + j;
            let r = (y & (SIDE - 1)) as u32;
            let blk = g.blocked_row(r);
            let mut w = 0;
            while w < WORDS {
                let mut bits = self.rows[r as usize][w] & !blk[w];
                while bits != 0 {
                    let b = bits.trailing_zeros() as i32;
                    bits &= bits - 1;
                    let xw = w as i32 * 32 + b;
                    let x = self.from[0] + ((xw - self.from[0] + SIDE / 2) & (SIDE - 1)) - SIDE / 2;
                    let (dx, dy) = (x - self.goal[0], y - self.goal[1]);
                    let d = dx * dx + dy * dy;
                    if d < best {
                        best = d;
                        self.found = [x, y];
                    }
                }
                w += 1;
            }
            j += 1;
        }
    }
}

/// Clears every row of a bitmap with one `memset` of the whole (assigned, or row by row,
/// LLVM made each row a call of its own: 128 calls, 27,000 cycles on the 68020).
#[inline(never)]
fn clear(rows: &mut [Row; 128]) {
    // SAFETY: one whole, valid, exclusively borrowed bitmap; all-zero bits are a valid
    // value of `[Row; 128]`.
    unsafe { core::ptr::write_bytes(rows as *mut [Row; 128], 0, 1) }
}
