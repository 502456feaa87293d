//! The calibration table in use (thesis ch. II.3.3): checking it, and the two lookups.
//!
//! The host writes the table (format: `vme_map::records::cal`) into global RAM; the board
//! reads words of it through [`CalWords`]. A table is used only after [`Checker`] has read
//! every word, found the header as the format says, every inverse node within
//! +-`MAX_NODE_UM` and the checksum right; it is checked again from the start whenever its
//! magic or generation word changes. The check runs [`CHECK_WORDS`] words per strobe slot
//! so a slot stays within its time.
//!
//! * [`position_um`]: signals (Q5 codes) to task-space micrometres, by bilinear interpolation
//!   in the inverse grid (64 codes per cell: index and fraction are shifts, no division).
//! * [`signals_q5`]: task-space micrometres to the signals the scan recorded there, by
//!   bilinear interpolation in the forward grid (for the drift reference).

use vme_map::records::cal;

/// Word access to the table.
pub trait CalWords {
    /// Word `i` of the table.
    fn word(&mut self, i: u32) -> u32;
    /// The address of word 0 where the table is memory-mapped (the 68020's global RAM), for
    /// the assembly lookup; `None` (the default) where it is not, and the Rust reads words.
    fn base(&mut self) -> Option<*const u32> {
        None
    }
    /// The sequence words of the object table and of the raw signal table where global RAM
    /// is memory-mapped (the 68020), for the common slot's assembly to publish the processed
    /// beacon itself (`Output::published`); `None` (the default) where it is not, and the
    /// board publishes ([`crate::Sensing::publish`]).
    fn tables(&mut self) -> Option<[*mut u32; 2]> {
        None
    }
}

/// The calibration table in global RAM (at `vme_map::SENSING_CAL`), and the tables the
/// board publishes, on any bus: the board's wiring and the image-against-host script.
pub struct GlobalCal<'a, G: vme_map::GlobalBus>(pub &'a mut G);

impl<G: vme_map::GlobalBus> CalWords for GlobalCal<'_, G> {
    #[inline(always)]
    fn word(&mut self, i: u32) -> u32 {
        self.0.read_u32(vme_map::SENSING_CAL + 4 * i)
    }
    #[inline(always)]
    fn base(&mut self) -> Option<*const u32> {
        self.0.word_ptr(vme_map::SENSING_CAL)
    }
    #[inline(always)]
    fn tables(&mut self) -> Option<[*mut u32; 2]> {
        // Addresses in the VME window (integers made pointers): written only by the
        // assembly, under the tables' sequence locks, as `SeqLock::publish_words` does.
        let o = self.0.word_ptr(vme_map::OBJECTS.offset())?;
        let r = self.0.word_ptr(vme_map::SENSING_RAW.offset())?;
        Some([o as *mut u32, r as *mut u32])
    }
}

/// Words checked per strobe slot (about 2,500 cycles on the 68020; the whole table in
/// 0.17 s).
pub const CHECK_WORDS: u32 = 16;

/// Header values the lookups need, taken when the check passes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Header {
    /// Sum level of the scan, codes (0: fixed LED current).
    pub s_ref_codes: i32,
    /// Forward grid origin, micrometres.
    pub x0_um: i32,
    /// Forward grid origin, micrometres.
    pub y0_um: i32,
    /// Forward grid pitch, micrometres.
    pub pitch_um: i32,
    /// Calibrated area: x min, x max, y min, y max, micrometres.
    pub area_um: [i32; 4],
}

/// Where the check of the table stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum State {
    /// Reading words; `at` is the next.
    Checking {
        /// Next word to read.
        at: u32,
        /// Checksum so far.
        sum: u32,
    },
    /// Checked and in use.
    Good(Header),
    /// Refused; the reason.
    Bad(Reason),
}

/// Why a table was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reason {
    /// No table (magic word wrong): never written, or being rewritten.
    Missing,
    /// Version, size or grid sizes not those of this firmware's format.
    Format,
    /// The forward pitch is not positive.
    Pitch,
    /// An inverse node beyond `MAX_NODE_UM`.
    Node,
    /// The checksum does not match.
    Checksum,
}

/// The table checker.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Checker {
    /// Where the check stands.
    pub state: State,
    magic: u32,
    generation: u32,
    /// Not 0 when the table in use has a step between neighbouring inverse nodes that does
    /// not fit an i16 (kept out of [`State`] and [`Header`]: growing those drew miscompiles
    /// of the M68k backend in the board's step).
    wide: u32,
    /// The next word of the table in use whose steps are to be checked
    /// ([`Self::step_steps`]).
    steps_at: u32,
    /// [`Self::word_steps_mask`], set when the last steps are checked.
    word_mask: usize,
    /// `steps_at`'s place in its row of the inverse grid (kept, not divided out: a compiled
    /// `%` on the 68020 is a library call, and divides are suspect, docs/toolchain.md class 5).
    steps_in_row: u32,
}

impl Default for Checker {
    fn default() -> Self {
        Self::new()
    }
}

impl Checker {
    /// Nothing checked yet.
    pub const fn new() -> Self {
        Self {
            state: State::Checking { at: 0, sum: 0 },
            magic: 0,
            generation: 0,
            wide: 0,
            steps_at: cal::INV,
            word_mask: 0,
            steps_in_row: 0,
        }
    }

    /// The header of the table in use, if one is.
    pub fn header(&self) -> Option<Header> {
        self.header_ref().copied()
    }

    /// [`Self::header`] without the copy (the slot's budget: the header is ten words).
    pub fn header_ref(&self) -> Option<&Header> {
        match &self.state {
            State::Good(h) => Some(h),
            _ => None,
        }
    }

    /// All ones when every step between neighbouring inverse nodes of the table (along a
    /// row or a column, either component) fits an i16 (-32768..=[`MAX_WORD_STEP_UM`] um),
    /// else 0: the lookup's products then fit 16 x 16 bits, as the common slot's assembly
    /// takes them (it is given a null grid, and leaves the slot to the Rust, for a table with
    /// a wider step). A mask, not a flag: a test of a flag here drew a condition-code clobber
    /// on the 68k (docs/toolchain.md class 1).
    #[inline(always)]
    pub fn word_steps_mask(&self) -> usize {
        self.word_mask
    }

    /// One slot's share of the check of the steps between neighbouring inverse nodes of the
    /// table in use ([`Self::word_steps_mask`]), once it is accepted and until every step is
    /// checked. The sensing logic calls it in the slots the Rust processes: until the steps
    /// are checked that is every slot (with the checksum, the extra reads slowed the check
    /// so that the first positions came later; once they are, the common slot no longer
    /// pays even the test).
    pub fn step_steps(&mut self, t: &mut impl CalWords) {
        if matches!(self.state, State::Good(_)) && self.steps_at < cal::WORDS {
            let end = (self.steps_at + CHECK_WORDS).min(cal::WORDS);
            self.wide |= check_steps(t, self.steps_at, end, &mut self.steps_in_row);
            self.steps_at = end;
            // 0 - 1 (all ones) when done with no wide step, else 0 (pending: 1 - 1).
            let any = self.wide | (cal::WORDS - end);
            self.word_mask = (((any | any.wrapping_neg()) >> 31) as usize).wrapping_sub(1);
        }
    }

    /// One slot's share of the check. Returns `Some(reason)` when a table is refused.
    pub fn step(&mut self, t: &mut impl CalWords) -> Option<Reason> {
        let magic = t.word(cal::W_MAGIC);
        let generation = t.word(cal::W_GENERATION);
        if magic != self.magic || generation != self.generation {
            self.magic = magic;
            self.generation = generation;
            self.state = State::Checking { at: 0, sum: 0 };
            self.wide = 0;
            self.steps_at = cal::INV;
            self.word_mask = 0;
            self.steps_in_row = 0;
        }
        let State::Checking { at, sum } = self.state else {
            return None;
        };
        if at == 0 {
            if let Some(r) = header_fault(t) {
                self.state = State::Bad(r);
                return Some(r);
            }
        }
        let end = (at + CHECK_WORDS).min(cal::WORDS);
        let (sum, bad_node) = check_words(t, at, end, sum);
        if bad_node {
            self.state = State::Bad(Reason::Node);
            return Some(Reason::Node);
        }
        if end < cal::WORDS {
            self.state = State::Checking { at: end, sum };
            return None;
        }
        if sum != t.word(cal::W_CHECKSUM) {
            self.state = State::Bad(Reason::Checksum);
            return Some(Reason::Checksum);
        }
        self.state = State::Good(Header {
            s_ref_codes: t.word(cal::W_S_REF) as i32,
            x0_um: t.word(cal::W_FWD_X0) as i32,
            y0_um: t.word(cal::W_FWD_Y0) as i32,
            pitch_um: t.word(cal::W_FWD_PITCH) as i32,
            area_um: [
                t.word(cal::W_AREA) as i32,
                t.word(cal::W_AREA + 1) as i32,
                t.word(cal::W_AREA + 2) as i32,
                t.word(cal::W_AREA + 3) as i32,
            ],
        });
        None
    }
}

/// What is wrong with the header, if anything.
#[inline(never)]
fn header_fault(t: &mut impl CalWords) -> Option<Reason> {
    if t.word(cal::W_MAGIC) != cal::MAGIC {
        return Some(Reason::Missing);
    }
    if t.word(cal::W_VERSION) != cal::VERSION
        || t.word(cal::W_WORDS) != cal::WORDS
        || t.word(cal::W_FWD_N) != cal::FWD_N
        || t.word(cal::W_INV_N) != cal::INV_N
    {
        return Some(Reason::Format);
    }
    if t.word(cal::W_FWD_PITCH) as i32 <= 0 {
        return Some(Reason::Pitch);
    }
    None
}

/// The widest step up between neighbouring inverse nodes for [`Checker::word_steps_mask`]
/// (down: -32768 um; an i16 either way). The model camera's table steps at most 21.9 mm.
pub const MAX_WORD_STEP_UM: i32 = i16::MAX as i32;

/// Runs the checksum over words `from..to` (skipping the checksum word) and checks inverse
/// nodes' range. Returns the checksum and whether a node was out of range.
#[inline(never)]
fn check_words(t: &mut impl CalWords, from: u32, to: u32, mut sum: u32) -> (u32, bool) {
    let mut bad = false;
    let mut i = from;
    while i < to {
        let w = t.word(i);
        if i != cal::W_CHECKSUM {
            sum = cal::checksum_step(sum, w);
        }
        if i >= cal::INV {
            let v = w as i32;
            bad |= !(-cal::MAX_NODE_UM..=cal::MAX_NODE_UM).contains(&v);
        }
        i += 1;
    }
    (sum, bad)
}

/// Checks the steps of inverse-grid words `from..to` (at or after `cal::INV`; `from` is
/// word `*in_row` of its row of (x, y) pairs, and `to` is on return) from the node before
/// in the row and the node above. Returns not 0 when one does not fit an i16
/// (-32768..=[`MAX_WORD_STEP_UM`]).
#[inline(never)]
fn check_steps(t: &mut impl CalWords, from: u32, to: u32, in_row_at: &mut u32) -> u32 {
    const ROW: u32 = 2 * cal::INV_N;
    let mut wide = 0;
    let mut in_row = *in_row_at;
    let mut i = from;
    while i < to {
        let v = t.word(i) as i32;
        if in_row >= 2 {
            wide |= wide_step(v, t.word(i - 2));
        }
        if i >= cal::INV + ROW {
            wide |= wide_step(v, t.word(i - ROW));
        }
        in_row += 1;
        if in_row == ROW {
            in_row = 0;
        }
        i += 1;
    }
    *in_row_at = in_row;
    wide
}

/// Not 0 when the step from its neighbour's word `n` to node value `v` does not fit an i16
/// (-32768..=[`MAX_WORD_STEP_UM`]). By arithmetic, not a compare: the range test drew a
/// condition-code clobber on the 68k (docs/toolchain.md class 1).
#[inline(always)]
fn wide_step(v: i32, n: u32) -> u32 {
    (v.wrapping_sub(n as i32).wrapping_add(-(i16::MIN as i32)) as u32) >> 16
}

/// The checksum of a whole table (the host writes it with this).
pub fn checksum(words: &[u32]) -> u32 {
    let mut sum = 0;
    for (i, &w) in words.iter().enumerate() {
        if i as u32 != cal::W_CHECKSUM {
            sum = cal::checksum_step(sum, w);
        }
    }
    sum
}

/// Q5 codes span the converter's codes about mid-scale: -2048..2048 codes.
const Q5_HALF_SPAN: i32 = 2048 << 5;
/// Inverse cells per side.
const INV_CELLS: i32 = cal::INV_N as i32 - 1;

/// The bilinear blend of four values with fractions in Q`sh`. The differences times the
/// fractions stay inside 32 bits for the table's value ranges.
#[inline(always)]
fn bilinear(v: &[i32; 4], fx_q: i32, fy_q: i32, sh: u32) -> i32 {
    let a = v[0] + (((v[1] - v[0]) * fx_q) >> sh);
    let b = v[2] + (((v[3] - v[2]) * fx_q) >> sh);
    a + (((b - a) * fy_q) >> sh)
}

/// Reads the (x, y) pairs at the four corners of a cell starting at word `base` with
/// `row` words per row into `xs`, `ys` (order: (0,0), (1,0), (0,1), (1,1)).
#[inline(always)]
fn corners(t: &mut impl CalWords, base: u32, row: u32, xs: &mut [i32; 4], ys: &mut [i32; 4]) {
    for k in 0..4u32 {
        let o = base + 2 * (k & 1) + row * (k >> 1);
        xs[k as usize] = t.word(o) as i32;
        ys[k as usize] = t.word(o + 1) as i32;
    }
}

/// Index and Q10 fraction of a Q5 signal in the inverse grid (clamped to the grid).
#[inline(always)]
fn inv_cell(v_q5: i32) -> (i32, i32) {
    // Clamped by sign masks, not compares (their flags were clobbered on the 68k;
    // docs/toolchain.md class 1).
    const TOP: i32 = (INV_CELLS << cal::INV_CELL_SHIFT_Q5) - 1;
    let u = v_q5 + Q5_HALF_SPAN;
    let u = u & !(u >> 31);
    let over = (TOP - u) >> 31;
    let u = (u & !over) | (TOP & over);
    (
        u >> cal::INV_CELL_SHIFT_Q5,
        (u & ((1 << cal::INV_CELL_SHIFT_Q5) - 1)) >> 1,
    )
}

/// The task-space position (micrometres) of signals `v_q5` through the inverse grid.
pub fn position_um(t: &mut impl CalWords, v_q5: [i32; 2]) -> [i32; 2] {
    let (i, fx_q10) = inv_cell(v_q5[0]);
    let (j, fy_q10) = inv_cell(v_q5[1]);
    let row = 2 * cal::INV_N;
    let base = cal::INV + (j as u32) * row + 2 * (i as u32);
    let mut xs = [0; 4];
    let mut ys = [0; 4];
    corners(t, base, row, &mut xs, &mut ys);
    [
        bilinear(&xs, fx_q10, fy_q10, 10),
        bilinear(&ys, fx_q10, fy_q10, 10),
    ]
}

/// Index and Q11 fraction of a coordinate along the forward grid, or `None` outside it.
#[inline(always)]
fn fwd_cell(p_um: i32, p0_um: i32, pitch_um: i32) -> Option<(i32, i32)> {
    let u = p_um - p0_um;
    if u < 0 || u >= (cal::FWD_N as i32 - 1) * pitch_um {
        return None;
    }
    let i = fx::div(u, pitch_um);
    let rem = u - i * pitch_um;
    Some((i, fx::div_shl(rem, pitch_um, 11)))
}

/// The signals (Q5 codes) the scan recorded at task-space position `p_um`, or `None`
/// outside the scanned grid.
pub fn signals_q5(t: &mut impl CalWords, h: &Header, p_um: [i32; 2]) -> Option<[i32; 2]> {
    let (i, fx_q11) = fwd_cell(p_um[0], h.x0_um, h.pitch_um)?;
    let (j, fy_q11) = fwd_cell(p_um[1], h.y0_um, h.pitch_um)?;
    let row = 2 * cal::FWD_N;
    let base = cal::FWD + (j as u32) * row + 2 * (i as u32);
    let mut xs = [0; 4];
    let mut ys = [0; 4];
    corners(t, base, row, &mut xs, &mut ys);
    Some([
        bilinear(&xs, fx_q11, fy_q11, 11),
        bilinear(&ys, fx_q11, fy_q11, 11),
    ])
}
