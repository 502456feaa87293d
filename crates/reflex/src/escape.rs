//! The escape (thesis fig. V.10, extended): where an arm whose neighbourhood an obstacle
//! covers goes, and its first step there, planned over a local bitmap of the map.
//!
//! The thesis's escape searched outward for the nearest free pixel and headed straight for
//! it. Among moving obstacles that is not enough: the nearest free pixel is often a crack
//! between two images whose way out runs along the crack, and a straight line to the nearest
//! free block may cross an obstacle (the reflex campaign's moving scenes: every contact was
//! an arm escaping across marked pixels). So the escape floods the free pixels reachable
//! from the arm (4-connected, so each step moves one link and the rectangle the servo may
//! sweep between two pixels is the two pixels), and heads for the most open of them:
//!
//! 1. fewest marked pixels crossed (none unless the arm's own pixel is marked and obstacles
//!    move; then one ring of marks at a time);
//! 2. then the largest clearance (free pixels each side, up to what the caller asks);
//! 3. then the fewest steps, then nearest the goal.
//!
//! The step is the arm's neighbour on a shortest way there within the flooded pixels. The
//! target of the previous pass is kept while it stays as good (no dithering between ways
//! out of equal worth).
//!
//! Everything is bit-parallel over a 32 x 32 window centred on the arm (a row is a `u32`):
//! clearance by erosion, the flood by dilation, a layer a step. The window's arrays live in
//! [`Scratch`], which the caller keeps (docs/toolchain.md, class 6: no local arrays indexed
//! in loops).

use crate::masks::{self, abs, lt, max, min, pick};
use crate::window::Map;

/// Rows and columns of the local window (one `u32` a row).
pub const WIN: usize = 32;
/// The arm's pixel's place in the window along each axis.
pub const HALF: i32 = 16;
/// Clearance levels kept (0: the pixel alone is free; c: its (2c + 1)^2 block is).
pub const LEVELS: usize = 5;
/// Most rings of marked pixels an escape crosses.
pub const MAX_CROSS: u32 = 6;
/// Most flood steps (pixels along the way).
pub const MAX_STEPS: u32 = 64;

/// The escape's working bitmaps (bit `k` of row `r`: pixel (arm1 - 16 + k, arm2 - 16 + r)).
#[derive(Clone, Debug)]
pub struct Scratch {
    /// `free[c]`: pixels whose (2c + 1)^2 block is free (outside the window counts as
    /// marked).
    free: [[u32; WIN]; LEVELS],
    /// Pixels reached so far, row `r` at index `r + 1` (rows -1 and `WIN` stay empty, so a
    /// step needs no bounds tests: docs/toolchain.md class 1).
    reach: [u32; WIN + 2],
    /// A step's new pixels (the backward flood's reach in [`first_step`]), rows as `reach`.
    next: [u32; WIN + 2],
    /// The candidates of the best kind found (rows `cand_lo ..= cand_hi`).
    cand: [u32; WIN],
    cand_lo: usize,
    cand_hi: usize,
    /// Rows `reach` spans.
    lo: i32,
    hi: i32,
    /// Rows the last step's new pixels (`next`) may lie in.
    next_lo: usize,
    next_hi: usize,
    /// The last step's new pixels, or-ed over rows (0: it did not grow).
    grew: u32,
    /// The target (window pixel; results go through here, not returned: class 7).
    t: [i32; 2],
    /// The step (window pixel).
    step: [i32; 2],
    /// The generations of the window's columns (`Map::column_gen`) when it was last
    /// loaded, window column `k` at index `k`.
    gens: [u32; WIN],
    /// The map's epoch ([`Map::epoch`]) read just before `gens` were.
    gens_epoch: u32,
    /// The window columns whose generations moved at their last read, window column `k`
    /// at bit `k`: those [`replan`] reads again when the ask is the plan's.
    moved: u32,
    /// The last plan's ask and result, kept while neither the ask nor a column of the
    /// window changes (then the plan is the same: it depends on nothing else).
    memo_ask: Ask,
    memo: Option<Plan>,
    /// `memo_ask` and `memo` hold a plan (-1), on a map with generations.
    memo_valid: i32,
    /// Pixels whose words the kept plans stood for without a read, since
    /// [`Scratch::take_vouched`].
    vouched: u32,
}

impl Default for Scratch {
    fn default() -> Self {
        Self::new()
    }
}

impl Scratch {
    /// Empty bitmaps.
    pub const fn new() -> Self {
        Self {
            free: [[0; WIN]; LEVELS],
            reach: [0; WIN + 2],
            next: [0; WIN + 2],
            cand: [0; WIN],
            cand_lo: 0,
            cand_hi: 0,
            lo: 0,
            hi: 0,
            next_lo: 0,
            next_hi: 0,
            grew: 0,
            t: [0; 2],
            step: [0; 2],
            gens: [0; WIN],
            gens_epoch: 0,
            moved: 0,
            memo_ask: Ask {
                at_px: [0; 2],
                toward_px: [0; 2],
                clear_px: 0,
                cross: false,
                prev_px: None,
            },
            memo: None,
            memo_valid: 0,
            vouched: 0,
        }
    }

    /// Pixels a kept plan stood for without reading them (the window's words and stripes,
    /// every column's generation unchanged) since the last call.
    pub fn take_vouched(&mut self) -> u32 {
        core::mem::take(&mut self.vouched)
    }

    /// The window's pixels as last read or kept (bit set: free), row `r` at index `r`.
    #[cfg(test)]
    pub(crate) fn window(&self) -> &[u32; WIN] {
        &self.free[0]
    }
}

/// An escape: where to and the first step (unwrapped pixels, as the arm's).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Plan {
    /// The pixel heading for.
    pub target_px: [i32; 2],
    /// The arm's neighbour (or its own pixel) to head for this pass.
    pub step_px: [i32; 2],
    /// The target's clearance (free pixels each side).
    pub clear_px: i32,
    /// Rings of marked pixels crossed on the way.
    pub crossed: u32,
}

/// What to plan.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Ask {
    /// The arm's pixel.
    pub at_px: [i32; 2],
    /// The goal's pixel (ties go toward it).
    pub toward_px: [i32; 2],
    /// Clearance wanted (free pixels each side; more is not better), at most `LEVELS - 1`.
    pub clear_px: i32,
    /// Marked pixels may be crossed (obstacles move: one may have come onto the arm).
    pub cross: bool,
    /// The previous pass's target, kept while it is as good as the best.
    pub prev_px: Option<[i32; 2]>,
}

/// Plans an escape (module docs). `None` when no free pixel is within reach (the arm holds).
/// Adds the pixel words read to `tests`.
pub fn plan<M: Map + ?Sized>(
    m: &mut M,
    s: &mut Scratch,
    ask: &Ask,
    tests: &mut u32,
) -> Option<Plan> {
    *plan_kept(m, s, ask, tests)
}

/// [`plan`], the answer left in `s` (a kept plan returned by value was a `memcpy` call of
/// every escape pass on the 68020).
#[inline(never)]
pub fn plan_kept<'s, M: Map + ?Sized>(
    m: &mut M,
    s: &'s mut Scratch,
    ask: &Ask,
    tests: &mut u32,
) -> &'s Option<Plan> {
    // The window's column generations are read before its words: a column written after
    // this read has a newer generation at the next plan, which then loads it again.
    let same = same_window(m, s, ask);
    if same != 0 {
        s.vouched += WORDS;
        return &s.memo;
    }
    replan(m, s, ask, tests);
    &s.memo
}

/// [`plan_kept`] when the ask or a column of the window changed: the window read again and
/// planned anew into `s`'s memo, unless the ask is the memo's and the window's pixels are
/// as they were.
#[inline(never)]
fn replan<M: Map + ?Sized>(m: &mut M, s: &mut Scratch, ask: &Ask, tests: &mut u32) {
    // Columns of the window were written since the plan (an obstacle redrawn): the plan
    // depends on the ask and the window's pixels alone, so the same pixels read again give
    // it again (a plan anew floods the window: up to ~180,000 cycles on the 68020). Only
    // the columns written are read again (a 1 mm redraw of the disk the arm is in moves
    // 5-6 of the 32; the whole window, 33 calls of 32 words, took ~17,500 cycles).
    if s.memo_valid != 0 && *ask == s.memo_ask {
        if reload(m, s, ask.at_px, s.moved, tests) == 0 {
            return;
        }
    } else {
        load(m, s, ask.at_px, tests);
    }
    let p = plan_anew(s, ask);
    s.memo_ask = *ask;
    s.memo = p;
    s.memo_valid = -(m.has_gens() as i32);
}

/// Whether `ask` is the last plan's and no column of its window has been written since
/// (-1), reading the window's generations into `s.gens` unless the map's epoch says no
/// column at all was written since they were read (on a map without generations: never,
/// 0).
#[inline(never)]
fn same_window<M: Map + ?Sized>(m: &mut M, s: &mut Scratch, ask: &Ask) -> i32 {
    if !m.has_gens() {
        return 0;
    }
    let same_ask = -((*ask == s.memo_ask) as i32) & s.memo_valid;
    // The epoch before the generations: while it stays, no column was written since the
    // pass that read `s.gens` (up to a write in progress, seen the next pass as for the
    // generations), and the ask's window is the memo's (~600 cycles of an escape's pass on
    // the 68020 in `__reflex_gens_moved`).
    let e = m.epoch();
    let d = e ^ s.gens_epoch;
    let unwritten = masks::zero(d);
    if same_ask & unwritten != 0 {
        return -1;
    }
    s.gens_epoch = e;
    // The window's first column, in 0..128 (the arm's pixel is unwrapped).
    let c0 = ((ask.at_px[0] - HALF) & 127) as u32;
    s.moved = gens_moved(m, c0, &mut s.gens);
    masks::zero(s.moved) & same_ask
}

/// Which columns of the `WIN` from `c0` (wrapping) were written since their generations
/// were saved in `saved`: bit `k` for column `c0 + k`, zero when none was, and `saved`
/// then holds the generations now. On the 68020 `__reflex_gens_moved` in the runtime's
/// assembly, a `CMPM.L` loop over the generations in global RAM that copies them only when
/// one differs (the compiled loop, a `column_gen` read a column, spent ~2,600 cycles of an
/// escape's pass); `the_reflex_images_window_generations_match_the_host` holds it to what
/// this code answers.
#[inline(never)]
fn gens_moved<M: Map + ?Sized>(m: &mut M, c0: u32, saved: &mut [u32; WIN]) -> u32 {
    #[cfg(target_arch = "m68k")]
    if let Some(gens) = m.gens_ptr() {
        extern "C" {
            fn __reflex_gens_moved(gens: *const u32, c0: u32, saved: *mut u32, n: u32) -> u32;
        }
        // SAFETY: `gens` points at the 128 generation words and the routine reads those
        // (wrapping modulo 128); `saved` holds WIN words, which it reads and writes.
        return unsafe { __reflex_gens_moved(gens, c0, saved.as_mut_ptr(), WIN as u32) };
    }
    let mut moved = 0;
    let mut k = 0;
    while k < WIN {
        let g = m.column_gen((c0 + k as u32) & 127);
        moved |= ((g != saved[k]) as u32) << k;
        saved[k] = g;
        k += 1;
    }
    moved
}

/// [`plan`] from the window's pixels (`free[0]`, loaded).
#[inline(never)]
fn plan_anew(s: &mut Scratch, ask: &Ask) -> Option<Plan> {
    let clear = ask.clear_px.clamp(0, LEVELS as i32 - 1);
    let mut c = 1;
    while c <= clear {
        erode(s, c as usize);
        c += 1;
    }
    let k = flood(s, clear, ask.cross);
    if k.best < 0 {
        return None;
    }
    let origin = [ask.at_px[0] - HALF, ask.at_px[1] - HALF];
    // The previous target while it is among the best kind (reached, as clear).
    let kept = ask.prev_px.is_some_and(|p| {
        let (x, y) = (p[0] - origin[0], p[1] - origin[1]);
        let inside = (0..WIN as i32).contains(&x) && (0..WIN as i32).contains(&y);
        let keep = inside && keeps(s, x as usize, y as usize, k.best as usize);
        s.t = [x, y];
        keep
    });
    if !kept {
        nearest(
            s,
            [ask.toward_px[0] - origin[0], ask.toward_px[1] - origin[1]],
        );
    }
    first_step(s);
    Some(Plan {
        target_px: [origin[0] + s.t[0], origin[1] + s.t[1]],
        step_px: [origin[0] + s.step[0], origin[1] + s.step[1]],
        clear_px: k.best,
        crossed: k.crossed,
    })
}

/// Reads the window around `at` into `free[0]`.
#[inline(never)]
fn load<M: Map + ?Sized>(m: &mut M, s: &mut Scratch, at: [i32; 2], tests: &mut u32) {
    let c0 = ((at[0] - HALF) & 127) as u32;
    let stripes = m.stripe_run(c0);
    let mut r = 0;
    while r < WIN {
        let row = ((at[1] - HALF + r as i32) & 127) as u32;
        s.free[0][r] = !(m.row_run(row, c0) | stripes);
        r += 1;
    }
    *tests += WORDS;
}

/// Columns written above which [`reload`] reads the window whole. On the 68020 a column
/// read and put into the rows costs ~1,900 cycles (`__vme_nonzero_bits_strided`,
/// `__reflex_put_column`), the whole window ~38,000 when its rows straddle two map words
/// (66 `__vme_nonzero_bits` calls), about half that when they do not; a redraw of a disk
/// that spans the window wrote 27 of its columns in `moving_obstacles.toml` as images.
pub const RELOAD_MAX_COLS: u32 = 20;

/// Reads again into `free[0]` the columns of the window around `at` whose bit is set in
/// `cols` (window column `k` at bit `k`), as [`load`] would read them; the others are left
/// as they are (more than [`RELOAD_MAX_COLS`] set: the whole window read again). Nonzero
/// when a pixel changed.
#[inline(never)]
fn reload<M: Map + ?Sized>(
    m: &mut M,
    s: &mut Scratch,
    at: [i32; 2],
    cols: u32,
    tests: &mut u32,
) -> u32 {
    if cols.count_ones() > RELOAD_MAX_COLS {
        let was = s.free[0];
        load(m, s, at, tests);
        let mut changed = 0;
        let mut r = 0;
        while r < WIN {
            changed |= was[r] ^ s.free[0][r];
            r += 1;
        }
        return changed;
    }
    let c0 = ((at[0] - HALF) & 127) as u32;
    let r0 = ((at[1] - HALF) & 127) as u32;
    let mut left = cols;
    let mut k = 0;
    let mut changed = 0;
    while left != 0 {
        if left & 1 != 0 {
            let c = (c0 + k) & 127;
            // A marked stripe marks the whole column (its pixels need no read).
            let marked = if m.stripes_or(c, 1) != 0 {
                u32::MAX
            } else {
                m.col_bits(c, r0)
            };
            changed |= put_column(&mut s.free[0], marked, 1 << k);
            *tests += WIN as u32 + 1;
        }
        left >>= 1;
        k += 1;
    }
    changed
}

/// Column `bit` (a single bit) of the window's rows (bit set: free) from `marked` (bit `r`
/// for row `r`): cleared in row `r` where `marked` has it, set where not. Returns `bit`
/// when a row's bit changed, else 0. On the 68020 `__reflex_put_column` in the runtime's
/// assembly, an unrolled `LSR.L` / `SUBX.L` run (the compiled loop spent ~2,800 cycles a
/// column); `the_reflex_images_column_puts_match_the_host` holds it to this code.
#[inline(never)]
pub fn put_column(rows: &mut [u32; WIN], marked: u32, bit: u32) -> u32 {
    #[cfg(target_arch = "m68k")]
    {
        extern "C" {
            fn __reflex_put_column(rows: *mut u32, marked: u32, bit: u32) -> u32;
        }
        // SAFETY: `rows` holds the WIN (32) words the routine reads and writes.
        unsafe { __reflex_put_column(rows.as_mut_ptr(), marked, bit) }
    }
    #[cfg(not(target_arch = "m68k"))]
    {
        let mut changed = 0;
        let mut r = 0;
        while r < WIN {
            let new = (rows[r] | bit) ^ (((marked >> r) & 1).wrapping_neg() & bit);
            changed |= rows[r] ^ new;
            rows[r] = new;
            r += 1;
        }
        changed
    }
}

/// Words a window's load reads: its rows' pixels and its columns' stripes.
const WORDS: u32 = 32 * (WIN as u32 + 1);

/// A row's pixels whose left and right neighbours are free too (beyond the window: marked).
#[inline(always)]
fn h(x: u32) -> u32 {
    x & (x << 1) & (x >> 1)
}

/// `free[c]` from `free[c - 1]`: the 3 x 3 erosion.
#[inline(never)]
fn erode(s: &mut Scratch, c: usize) {
    let mut above = 0;
    let mut here = h(s.free[c - 1][0]);
    let mut r = 0;
    while r < WIN - 1 {
        let below = h(s.free[c - 1][r + 1]);
        s.free[c][r] = above & here & below;
        above = here;
        here = below;
        r += 1;
    }
    s.free[c][WIN - 1] = 0;
}

/// What the flood found: the best clearance reached (-1: nothing free) and the marks crossed.
struct Found {
    best: i32,
    crossed: u32,
}

/// Floods from the arm's pixel (module docs), leaving the pixels reached in `reach` and the
/// candidates of the best kind in `cand`. Each step touches only the rows the reach spans
/// and one more each way (`lo`, `hi`), and stops as soon as a pixel of the clearance
/// wanted is reached.
#[inline(never)]
fn flood(s: &mut Scratch, clear: i32, cross: bool) -> Found {
    let mut r = 0;
    while r < WIN + 2 {
        s.reach[r] = 0;
        s.next[r] = 0;
        r += 1;
    }
    let h = HALF as usize;
    s.reach[h + 1] = 1 << HALF;
    s.next[h + 1] = 1 << HALF;
    s.lo = HALF;
    s.hi = HALF;
    s.next_lo = h;
    s.next_hi = h;
    let mut found = Found {
        best: -1,
        crossed: 0,
    };
    // The arm's own pixel (layer 0, stashed in `next`) is a candidate when free.
    let mut better = level_any(s, 0);
    let mut crossed = 0;
    let mut steps = 0;
    loop {
        if better != 0 {
            // Some new pixel beats the best: which level, and the candidates.
            found.best = best_level(s, found.best, clear);
            found.crossed = crossed;
            take_candidates(s, found.best as usize);
        }
        if found.best >= clear || steps >= MAX_STEPS {
            break;
        }
        better = step(s, true, found.best);
        if s.grew == 0 {
            if found.best >= 0 || !cross || crossed >= MAX_CROSS {
                break;
            }
            // A ring of marked pixels.
            better = step(s, false, found.best);
            crossed += 1;
            if s.grew == 0 {
                break;
            }
        }
        steps += 1;
    }
    found
}

/// One 4-connected step of `reach` (into free pixels only with `free_only`), in place over
/// rows `lo - 1 ..= hi + 1` (then the band), the new pixels stashed in `next`. Returns
/// nonzero when a new pixel is clearer than `best` (level `best + 1`, below `LEVELS`: the
/// flood steps only while `best` is short of the clearance wanted; [`best_level`] finds how
/// much); sets `grew`.
#[inline(never)]
fn step(s: &mut Scratch, free_only: bool, best: i32) -> u32 {
    let any_pixel = !(free_only as u32).wrapping_neg();
    let lo = max(s.lo - 1, 0);
    let hi = min(s.hi + 1, WIN as i32 - 1);
    #[cfg(target_arch = "m68k")]
    let better = {
        extern "C" {
            fn __reflex_flood_step(
                reach: *mut u32,
                next: *mut u32,
                free0: *const u32,
                lvl: *const u32,
                n: u32,
                any: u32,
                grew: *mut u32,
            ) -> u32;
        }
        let l = lo as usize;
        let mut grew = 0;
        // SAFETY: rows lo ..= hi lie within the window (0 ..= WIN - 1): the routine reads
        // `reach` at indices lo ..= hi + 2 (< WIN + 2) and writes lo + 1 ..= hi + 1, writes
        // `next` at lo + 1 ..= hi + 1 and reads `free[0]` and `free[best + 1]` at lo ..= hi.
        let better = unsafe {
            __reflex_flood_step(
                s.reach.as_mut_ptr().add(l),
                s.next.as_mut_ptr().add(l + 1),
                s.free[0].as_ptr().add(l),
                s.free[(best + 1) as usize].as_ptr().add(l),
                (hi - lo + 1) as u32,
                any_pixel,
                &mut grew,
            )
        };
        s.grew = grew;
        better
    };
    #[cfg(not(target_arch = "m68k"))]
    let better = step_rows(s, lo, hi, any_pixel, best);
    // The band grows a row each way a step (a row more than the reach may span: no
    // compares in the loop, docs/toolchain.md class 1).
    s.lo = lo;
    s.hi = hi;
    s.next_lo = lo as usize;
    s.next_hi = hi as usize;
    better
}

/// [`step`]'s rows `lo ..= hi` (on the 68020 `__reflex_flood_step` in the runtime's
/// assembly, which `the_reflex_images_escapes_match_the_host` holds to this code through
/// the plans): the new reach, its new pixels in `next`, `grew`; nonzero when a new pixel
/// has clearance `best + 1`.
#[cfg(not(target_arch = "m68k"))]
fn step_rows(s: &mut Scratch, lo: i32, hi: i32, any_pixel: u32, best: i32) -> u32 {
    // The level a new pixel must reach to beat `best`.
    let lvl = &s.free[(best + 1) as usize];
    let mut above = s.reach[lo as usize];
    let mut grew = 0;
    let mut better = 0;
    let mut r = lo as usize;
    while r <= hi as usize {
        let here = s.reach[r + 1];
        let below = s.reach[r + 2];
        let d = here | (here << 1) | (here >> 1) | above | below;
        let n = here | (d & (s.free[0][r] | any_pixel));
        let layer = n & !here;
        s.next[r + 1] = layer;
        s.reach[r + 1] = n;
        above = here;
        grew |= layer;
        better |= layer & lvl[r];
        r += 1;
    }
    s.grew = grew;
    better
}

/// Whether a pixel of the last step's new pixels (`next`, band `next_lo ..= next_hi`) has
/// clearance `c`: nonzero when one does.
#[inline(never)]
fn level_any(s: &Scratch, c: usize) -> u32 {
    let mut any = 0;
    let mut r = s.next_lo;
    while r <= s.next_hi {
        any |= s.next[r + 1] & s.free[c][r];
        r += 1;
    }
    any
}

/// The highest clearance (up to `clear`) among the last step's new pixels, known to beat
/// `best`.
#[inline(never)]
fn best_level(s: &Scratch, best: i32, clear: i32) -> i32 {
    let mut c = clear;
    while c > best + 1 {
        if level_any(s, c as usize) != 0 {
            return c;
        }
        c -= 1;
    }
    best + 1
}

/// `cand` = the last step's new pixels (`next`, band `next_lo ..= next_hi`, which becomes
/// `cand`'s band) of clearance `c`.
#[inline(never)]
fn take_candidates(s: &mut Scratch, c: usize) {
    s.cand_lo = s.next_lo;
    s.cand_hi = s.next_hi;
    let mut r = s.next_lo;
    while r <= s.next_hi {
        s.cand[r] = s.next[r + 1] & s.free[c][r];
        r += 1;
    }
}

/// Whether window pixel (`x`, `y`) was reached and is as clear as `best`.
#[inline(never)]
fn keeps(s: &Scratch, x: usize, y: usize, best: usize) -> bool {
    (s.reach[y + 1] & s.free[best][y]) >> x & 1 != 0
}

/// The candidate nearest `toward` (window coordinates, any distance; torus-wrapped).
/// Sign masks, not compares (docs/toolchain.md, class 1).
#[inline(never)]
fn nearest(s: &mut Scratch, toward: [i32; 2]) {
    let wrap = |d: i32| ((d + 64) & 127) - 64;
    let mut best_x = HALF;
    let mut best_y = HALF;
    let mut best_d = i32::MAX;
    let mut r = s.cand_lo;
    while r <= s.cand_hi {
        let mut bits = s.cand[r];
        let dy = abs(wrap(toward[1] - r as i32));
        while bits != 0 {
            let x = bits.trailing_zeros() as i32;
            bits &= bits - 1;
            let d = abs(wrap(toward[0] - x)) + dy;
            // Opaque, or LLVM turns the three picks back into compare-and-branch with
            // register copies between (the class 1 clobber).
            let better = core::hint::black_box(lt(d, best_d));
            best_d = pick(better, d, best_d);
            best_x = pick(better, x, best_x);
            best_y = pick(better, r as i32, best_y);
        }
        r += 1;
    }
    s.t = [best_x, best_y];
}

/// Pixels around the arm a step may reach, each way.
pub const STEP_PX: i32 = 2;

/// The step toward window pixel `t`: of the pixels within [`STEP_PX`] of the arm whose
/// rectangle with the arm's pixel was all reached (the servo may sweep that rectangle on the
/// way), one of those fewest steps from `t` within `reach`, the farthest from the arm among
/// them. Floods back from `t` in `next` until the flood meets such a pixel.
#[inline(never)]
fn first_step(s: &mut Scratch) {
    let t = s.t;
    s.step = t;
    if t == [HALF, HALF] {
        return;
    }
    let mut r = 0;
    while r < WIN + 2 {
        s.next[r] = 0;
        r += 1;
    }
    s.next[t[1] as usize + 1] = 1 << t[0];
    s.lo = t[1];
    s.hi = t[1];
    let mut steps = 0;
    while steps < 2 * MAX_STEPS {
        if near_pick(s) != 0 {
            return;
        }
        back_step(s);
        if s.grew == 0 {
            break;
        }
        steps += 1;
    }
}

/// Of the backward flood's pixels (`next`) within [`STEP_PX`] of the arm, the farthest
/// from it whose rectangle with the arm was all reached, into `step`. Nonzero when there
/// was one.
#[inline(never)]
fn near_pick(s: &mut Scratch) -> u32 {
    let lo = (HALF - STEP_PX) as usize;
    let n = 2 * STEP_PX as usize + 1;
    let mut best_x = s.step[0];
    let mut best_y = s.step[1];
    let mut best_far = -1;
    let mut dy = 0;
    while dy < n {
        let mut bits = (s.next[lo + dy + 1] >> lo) & ((1 << n) - 1);
        while bits != 0 {
            let dx = bits.trailing_zeros() as i32;
            bits &= bits - 1;
            let q = [lo as i32 + dx, (lo + dy) as i32];
            let far = max(abs(q[0] - HALF), abs(q[1] - HALF));
            let ok = core::hint::black_box(lt(best_far, far) & rect_reached(s, q));
            best_far = pick(ok, far, best_far);
            best_x = pick(ok, q[0], best_x);
            best_y = pick(ok, q[1], best_y);
        }
        dy += 1;
    }
    s.step = [best_x, best_y];
    (best_far + 1) as u32
}

/// One step of the backward flood in `next`, within `reach`, over rows `lo - 1 ..= hi + 1`;
/// sets `grew`.
#[inline(never)]
fn back_step(s: &mut Scratch) {
    let lo = max(s.lo - 1, 0);
    let hi = min(s.hi + 1, WIN as i32 - 1);
    let mut above = s.next[lo as usize];
    let mut grew = 0;
    let mut r = lo as usize;
    while r <= hi as usize {
        let here = s.next[r + 1];
        let below = s.next[r + 2];
        let n = here | ((here | (here << 1) | (here >> 1) | above | below) & s.reach[r + 1]);
        let new = n ^ here;
        s.next[r + 1] = n;
        above = here;
        grew |= new;
        r += 1;
    }
    s.lo = lo;
    s.hi = hi;
    s.grew = grew;
}

/// -1 when every pixel of the rectangle between the arm's pixel and window pixel `q` was
/// reached, else 0.
#[inline(never)]
fn rect_reached(s: &Scratch, q: [i32; 2]) -> i32 {
    let x0 = min(q[0], HALF);
    let x1 = max(q[0], HALF);
    let y0 = min(q[1], HALF) as usize;
    let y1 = max(q[1], HALF) as usize;
    let mask = ((2u32 << (x1 - x0)) - 1) << x0;
    let mut missing = 0;
    let mut y = y0;
    while y <= y1 {
        missing |= mask & !s.reach[y + 1];
        y += 1;
    }
    // -1 when nothing is missing.
    ((missing | missing.wrapping_neg()) >> 31) as i32 - 1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tests::TestMap;
    use proptest::prelude::*;

    /// Plans on `m` with fresh bitmaps.
    fn plan_on(m: &TestMap, ask: &Ask) -> Option<Plan> {
        let mut tests = 0;
        plan(&mut m.map(), &mut Scratch::new(), ask, &mut tests)
    }

    fn ask(at: [i32; 2], toward: [i32; 2], clear: i32, cross: bool) -> Ask {
        Ask {
            at_px: at,
            toward_px: toward,
            clear_px: clear,
            cross,
            prev_px: None,
        }
    }

    #[test]
    fn an_arm_in_the_open_stays_where_it_is() {
        let mut m = TestMap::new();
        m.block(40, 44, 40, 70);
        let p = plan_on(&m, &ask([60, 60], [100, 60], 4, true)).unwrap();
        assert_eq!(
            (p.target_px, p.step_px, p.clear_px, p.crossed),
            ([60, 60], [60, 60], 4, 0)
        );
    }

    #[test]
    fn an_arm_in_a_crack_follows_it_out_to_the_open() {
        // A solid mass with a one-pixel crack from the arm down to open space 8 pixels
        // below, and open space 3 pixels up-right beyond a wall (which no step crosses).
        let mut m = TestMap::new();
        m.block(40, 80, 50, 80);
        for i2 in 50..=60 {
            m.clear_px(60, i2);
        }
        let p = plan_on(&m, &ask([60, 60], [70, 70], 2, false)).unwrap();
        assert_eq!(p.crossed, 0);
        assert_eq!(p.clear_px, 2);
        // Out of the crack's mouth (row 49) and two pixels clear of the mass.
        assert!(p.target_px[1] <= 47, "{p:?}");
        // The step runs down the crack, within STEP_PX.
        assert_eq!(p.step_px[0], 60);
        assert!((58..60).contains(&p.step_px[1]), "{p:?}");
        for i2 in p.step_px[1]..=60 {
            assert!(!m.marked(60, i2));
        }
    }

    #[test]
    fn an_arm_inside_an_obstacle_crosses_the_thinnest_side_only_when_allowed() {
        // A band 9 pixels wide; the arm 2 pixels from its top, 6 from its bottom.
        let mut m = TestMap::new();
        m.block(0, 127, 50, 58);
        let inside = [64, 56];
        assert_eq!(plan_on(&m, &ask(inside, [64, 30], 1, false)), None);
        let p = plan_on(&m, &ask(inside, [64, 30], 1, true)).unwrap();
        // Out through the top (rows 57 and 58), though the goal lies below (6 rings).
        assert_eq!(p.crossed, 2, "{p:?}");
        assert!(p.target_px[1] >= 60 && p.target_px[0] == 64, "{p:?}");
        assert!(p.step_px[1] > inside[1] && p.step_px[0] == 64, "{p:?}");
    }

    #[test]
    fn the_window_wraps_at_the_torus_edges() {
        // The arm at pixel (1, 126) in a corridor that runs left across theta1's seam, then
        // up across theta2's into an open box; all else marked.
        let mut m = TestMap::new();
        m.block(-40, 40, 100, 150);
        let corridor = [
            (0, 126),
            (1, 126),
            (-1, 126),
            (-2, 126),
            (-2, 127),
            (-2, 128),
        ];
        for (a, b) in corridor {
            m.clear_px(a, b);
        }
        for i2 in 129..=133 {
            m.clear_px(-2, i2);
        }
        for i1 in -6..=-2 {
            for i2 in 134..=140 {
                m.clear_px(i1, i2);
            }
        }
        let p = plan_on(&m, &ask([1, 126], [1, 150], 1, false)).unwrap();
        assert_eq!((p.clear_px, p.crossed), (1, 0), "{p:?}");
        // In the box, in unwrapped pixels.
        assert!((-5..=-3).contains(&p.target_px[0]), "{p:?}");
        assert!((135..=139).contains(&p.target_px[1]), "{p:?}");
        // The first step along the corridor (left).
        assert_eq!(p.step_px[1], 126, "{p:?}");
        assert!(p.step_px[0] < 1, "{p:?}");
    }

    #[test]
    fn the_previous_target_is_kept_while_it_is_as_good() {
        // A free arm with marks left and right: pixels two up and two down are clear by 1.
        let mut m = TestMap::new();
        m.mark(59, 60);
        m.mark(61, 60);
        let mut a = ask([60, 60], [60, 40], 1, false);
        assert_eq!(plan_on(&m, &a).unwrap().target_px, [60, 58]);
        a.prev_px = Some([60, 62]);
        assert_eq!(plan_on(&m, &a).unwrap().target_px, [60, 62]);
        // Not clear any more: dropped.
        m.mark(61, 63);
        assert_eq!(plan_on(&m, &a).unwrap().target_px, [60, 58]);
    }

    /// Whether window pixel (`x`, `y`) of the window around `at` is inside it and free.
    fn window_free(m: &TestMap, at: [i32; 2], x: i32, y: i32) -> bool {
        let w = WIN as i32;
        (0..w).contains(&x) && (0..w).contains(&y) && !m.marked(at[0] - HALF + x, at[1] - HALF + y)
    }

    /// Steps from the window's centre to each window pixel (`u32::MAX`: not reached) through
    /// free pixels, 4-connected, at most MAX_STEPS.
    fn bfs(m: &TestMap, at: [i32; 2]) -> Vec<u32> {
        let free = |x: i32, y: i32| window_free(m, at, x, y);
        let mut dist = vec![u32::MAX; WIN * WIN];
        let mut q = std::collections::VecDeque::new();
        dist[HALF as usize * WIN + HALF as usize] = 0;
        q.push_back((HALF, HALF));
        while let Some((x, y)) = q.pop_front() {
            let d = dist[y as usize * WIN + x as usize];
            if d >= MAX_STEPS {
                continue;
            }
            for (nx, ny) in [(x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)] {
                if free(nx, ny) && dist[ny as usize * WIN + nx as usize] == u32::MAX {
                    dist[ny as usize * WIN + nx as usize] = d + 1;
                    q.push_back((nx, ny));
                }
            }
        }
        dist
    }

    /// The oracle: the best clearance among the pixels [`bfs`] reaches (a pixel's clearance
    /// its largest free block within the window, up to `clear`) and the fewest steps to it.
    fn oracle(m: &TestMap, at: [i32; 2], dist: &[u32], clear: i32) -> Option<(i32, u32)> {
        let w = WIN as i32;
        let free = |x: i32, y: i32| window_free(m, at, x, y);
        let mut best: Option<(i32, u32)> = None;
        for y in 0..w {
            for x in 0..w {
                let d = dist[y as usize * WIN + x as usize];
                if d == u32::MAX {
                    continue;
                }
                let c = (0..=clear)
                    .take_while(|&c| (-c..=c).all(|a| (-c..=c).all(|b| free(x + a, y + b))))
                    .last();
                if let Some(c) = c {
                    if best.is_none_or(|(bc, bd)| c > bc || (c == bc && d < bd)) {
                        best = Some((c, d));
                    }
                }
            }
        }
        best
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]
        /// From a free pixel among random blocks: the clearance the plan finds is the best
        /// the oracle reaches, at the fewest steps; the target is that clear; the step is
        /// within STEP_PX and the rectangle from the arm to it is free.
        #[test]
        fn a_free_arm_heads_for_the_clearest_reachable_pixel(
            blocks in proptest::collection::vec((0i32..128, 0i32..128, 0i32..6, 0i32..6), 5..60),
            at in (0i32..128, 0i32..128),
            toward in (0i32..128, 0i32..128),
            clear in 0i32..5,
        ) {
            let mut m = TestMap::new();
            for (a, c, w, h) in blocks {
                m.block(a, a + w, c, c + h);
            }
            let at = [at.0, at.1];
            prop_assume!(!m.marked(at[0], at[1]));
            let p = plan_on(&m, &ask(at, [toward.0, toward.1], clear, true)).unwrap();
            let dist = bfs(&m, at);
            let (best, d) = oracle(&m, at, &dist, clear).unwrap();
            prop_assert_eq!(p.clear_px, best);
            prop_assert_eq!(p.crossed, 0);
            let t = [p.target_px[0] - at[0] + HALF, p.target_px[1] - at[1] + HALF];
            let inside = (0..WIN as i32).contains(&t[0]) && (0..WIN as i32).contains(&t[1]);
            prop_assert!(inside, "target {:?} outside the window", p.target_px);
            let o = dist[t[1] as usize * WIN + t[0] as usize];
            prop_assert_eq!(o, d, "target {:?} not among the nearest", p.target_px);
            for a in -best..=best {
                for b in -best..=best {
                    prop_assert!(!m.marked(p.target_px[0] + a, p.target_px[1] + b));
                }
            }
            prop_assert!((p.step_px[0] - at[0]).abs() <= STEP_PX && (p.step_px[1] - at[1]).abs() <= STEP_PX);
            for x in at[0].min(p.step_px[0])..=at[0].max(p.step_px[0]) {
                for y in at[1].min(p.step_px[1])..=at[1].max(p.step_px[1]) {
                    prop_assert!(!m.marked(x, y), "step {:?} from {:?} sweeps ({}, {})", p.step_px, at, x, y);
                }
            }
        }
    }
}
