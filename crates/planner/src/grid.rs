//! The planner's picture of the C-space map (thesis ch. VI section 5: the planner reads the
//! same map as the reflex): one bit per pixel, refreshed a few rows per cycle, and the same
//! grown by one pixel each way, which is what the planner calls blocked. A cell the planner
//! leads the arm through is then at least a pixel (2 pi / 128) from anything marked, which
//! the reflex's margins at the planner's speeds fit inside (`crates/reflex`).
//!
//! Rows are four words; bit `i1 & 31` of word `i1 >> 5` of row `i2` is pixel (`i1`, `i2`).
//! Cells are unwrapped pixel coordinates (any `i32`); the torus wraps them with `& 127`.

use reflex::window::Map;

/// Pixels per map axis.
pub const SIDE: i32 = 128;
/// Words per bitmap row.
pub const WORDS: usize = 4;
/// One bitmap row.
pub type Row = [u32; WORDS];

/// Map rows read per turn (every other planner cycle): a whole refresh every 128 cycles.
pub const ROWS_PER_CYCLE: u32 = 2;

/// The bitmaps.
#[derive(Clone, Debug)]
pub struct Grid {
    /// Marked pixels, the link-1 stripes folded in.
    occ: [Row; 128],
    /// Cells with a marked pixel in their 3 x 3 neighbourhood.
    blk: [Row; 128],
    /// The stripe layer as last read.
    stripes: Row,
    /// The next row to read.
    next_row: u32,
    /// Whole refreshes completed.
    sweeps: u32,
}

impl Default for Grid {
    fn default() -> Self {
        Self::new()
    }
}

/// Bit of cell `c` in a bitmap: (word index, bit mask).
#[inline(always)]
fn at(c: [i32; 2]) -> (usize, usize, u32) {
    let i1 = (c[0] & (SIDE - 1)) as u32;
    let i2 = (c[1] & (SIDE - 1)) as usize;
    (i2, (i1 >> 5) as usize, 1 << (i1 & 31))
}

impl Grid {
    /// Nothing read yet: everything free (the planner waits for [`Grid::sweeps`] >= 1).
    pub const fn new() -> Self {
        Self {
            occ: [[0; WORDS]; 128],
            blk: [[0; WORDS]; 128],
            stripes: [0; WORDS],
            next_row: 0,
            sweeps: 0,
        }
    }

    /// Whole refreshes of the bitmap completed.
    pub fn sweeps(&self) -> u32 {
        self.sweeps
    }

    /// Reads the next `rows` rows of the map (and the stripes at row 0) and regrows each
    /// and the blocked row above it.
    #[inline(never)]
    pub fn refresh<M: Map + ?Sized>(&mut self, map: &mut M, rows: u32) {
        let mut n = 0;
        while n < rows {
            let r = self.next_row;
            if r == 0 {
                read_stripes(&mut self.stripes, map);
            }
            read_row(&mut self.occ[r as usize], &self.stripes, map, r);
            // Row r - 1 now has both neighbours read this sweep; row r is grown too, from
            // the row below as last read (regrown when that is read: a marked pixel is
            // always blocked at once, its dilation into the row above a row later).
            self.grow_row((r + 127) & 127);
            self.grow_row(r);
            self.next_row = (r + 1) & 127;
            self.sweeps += (self.next_row == 0) as u32;
            n += 1;
        }
    }

    /// Recomputes blocked row `r` from marked rows `r - 1 ..= r + 1`.
    #[inline(never)]
    fn grow_row(&mut self, r: u32) {
        let up = ((r + 127) & 127) as usize;
        let dn = ((r + 1) & 127) as usize;
        dilate(
            &mut self.blk[r as usize],
            &self.occ[up],
            &self.occ[r as usize],
            &self.occ[dn],
        );
    }

    /// 1 when cell `c` is blocked (a marked pixel within one pixel), else 0.
    #[inline(always)]
    pub fn blocked(&self, c: [i32; 2]) -> u32 {
        let (r, w, m) = at(c);
        ((self.blk[r][w] & m) != 0) as u32
    }

    /// 1 when pixel `c` itself is marked, else 0.
    pub fn marked(&self, c: [i32; 2]) -> u32 {
        let (r, w, m) = at(c);
        ((self.occ[r][w] & m) != 0) as u32
    }

    /// Blocked row `r` (for the reachability fill).
    pub fn blocked_row(&self, r: u32) -> &Row {
        &self.blk[(r & 127) as usize]
    }

    /// Marked row `r` (for the reachability fill).
    pub fn marked_row(&self, r: u32) -> &Row {
        &self.occ[(r & 127) as usize]
    }
}

/// Reads the four words of the stripe layer.
#[inline(never)]
fn read_stripes<M: Map + ?Sized>(s: &mut Row, map: &mut M) {
    s[0] = map.stripe_bits(0);
    s[1] = map.stripe_bits(32);
    s[2] = map.stripe_bits(64);
    s[3] = map.stripe_bits(96);
}

/// Reads map row `r` into `o`, the stripes folded in.
#[inline(never)]
fn read_row<M: Map + ?Sized>(o: &mut Row, stripes: &Row, map: &mut M, r: u32) {
    o[0] = map.row_bits(r, 0) | stripes[0];
    o[1] = map.row_bits(r, 32) | stripes[1];
    o[2] = map.row_bits(r, 64) | stripes[2];
    o[3] = map.row_bits(r, 96) | stripes[3];
}

/// `dst` = (a | b | c) grown by one pixel each way along the row (the ring wraps).
#[inline(never)]
fn dilate(dst: &mut Row, a: &Row, b: &Row, c: &Row) {
    let v0 = a[0] | b[0] | c[0];
    let v1 = a[1] | b[1] | c[1];
    let v2 = a[2] | b[2] | c[2];
    let v3 = a[3] | b[3] | c[3];
    dst[0] = v0 | (v0 << 1) | (v3 >> 31) | (v0 >> 1) | (v1 << 31);
    dst[1] = v1 | (v1 << 1) | (v0 >> 31) | (v1 >> 1) | (v2 << 31);
    dst[2] = v2 | (v2 << 1) | (v1 >> 31) | (v2 >> 1) | (v3 << 31);
    dst[3] = v3 | (v3 << 1) | (v2 >> 31) | (v3 >> 1) | (v0 << 31);
}

/// Pixels a row spreads each way per visit of the fill, at most ([`spread`]).
pub const SPREAD_STEPS: u32 = 4;

/// `r` spread along its row through the free pixels `f` (bits set where free) by up to
/// [`SPREAD_STEPS`] pixels each way (the ring wraps). Returns 1 if it would spread further:
/// the fill visits the row again (a row spread to the end in one visit cost up to 64 steps,
/// 34,000 cycles on the 68020). The row lives in memory between steps, so the loop carries
/// no register copies (docs/toolchain.md, class 1).
#[inline(never)]
pub fn spread(r: &mut Row, f: &Row) -> u32 {
    r[0] &= f[0];
    r[1] &= f[1];
    r[2] &= f[2];
    r[3] &= f[3];
    let mut k = 0;
    let mut more = 1;
    while k < SPREAD_STEPS && more != 0 {
        more = (spread_once(r, f) != 0) as u32;
        k += 1;
    }
    more
}

/// One pixel of spreading each way; returns the bits that changed (0 when settled).
#[inline(never)]
fn spread_once(r: &mut Row, f: &Row) -> u32 {
    let (n0, n1, n2, n3) = (r[0], r[1], r[2], r[3]);
    let m0 = (n0 | (n0 << 1) | (n3 >> 31) | (n0 >> 1) | (n1 << 31)) & f[0];
    let m1 = (n1 | (n1 << 1) | (n0 >> 31) | (n1 >> 1) | (n2 << 31)) & f[1];
    let m2 = (n2 | (n2 << 1) | (n1 >> 31) | (n2 >> 1) | (n3 << 31)) & f[2];
    let m3 = (n3 | (n3 << 1) | (n2 >> 31) | (n3 >> 1) | (n0 << 31)) & f[3];
    r[0] = m0;
    r[1] = m1;
    r[2] = m2;
    r[3] = m3;
    (m0 ^ n0) | (m1 ^ n1) | (m2 ^ n2) | (m3 ^ n3)
}
