//! The shared work list (thesis line ~1225, proposed there and built here): a circular list
//! of the moving obstacles with the position each one's image was last drawn at, and a
//! cursor the C-space boards advance with `CAS.L`. A board takes the next entry, claims it
//! with `CAS.L`, and if the obstacle moved draws its new image and erases the old one (by
//! their difference, [`crate::raster::pair`]: every increment first), then records the new
//! position and releases the entry. So N boards share the transforms evenly
//! whatever moves, and a board that stops only slows the map down.
//!
//! Moving obstacles (those the sensing board flags moving) are drawn swept ("blurred", lines
//! ~1236-1242) over [`LOOKAHEAD_MS`] along their measured velocity: the image covers wherever
//! the obstacle can be until the next refresh, and where it already is while the sensing
//! board's filter still reports where it was. An obstacle whose beacon turns invalid keeps
//! its last image.

use crate::raster::{self, PairWork, RunLog};
use crate::{images, BusCanvas, Disk, Error, Flags, Images, Op, Stripe, POLAR_MARGIN_UM};
use vme_map::layout::{work_entry, WORK_CURSOR};
use vme_map::record::Record;
use vme_map::records::{beacon_flags, Beacon, ObjectTable, WorkEntry};
use vme_map::GlobalBus;

/// The beacons whose obstacles the C-space boards transform (thesis ch. II.3: five obstacles
/// and the instructional robot), entry `i` for beacon `OBSTACLE_BEACONS[i]`.
pub const OBSTACLE_BEACONS: [u32; 6] = [0, 1, 2, 3, 4, 7];
/// Radius the boards give an obstacle whose radius the host did not write: the thesis's
/// 2-inch cylinders (ch. IV section 5).
pub const OBSTACLE_R_UM: i32 = 25_400;

/// The radius of entry `i`'s obstacle: the host's word in `OBSTACLE_RADII`, or
/// [`OBSTACLE_R_UM`] where it wrote none.
#[inline(never)]
pub fn radius(g: &mut (impl GlobalBus + ?Sized), i: u32) -> i32 {
    let r = g.read_u32(vme_map::layout::OBSTACLE_RADII + 4 * i) as i32;
    // Sign arithmetic, no select (docs/toolchain.md): d = -1 when r == 0.
    let d = ((r | r.wrapping_neg()) >> 31) ^ -1;
    r | (OBSTACLE_R_UM & d)
}
/// How far ahead a moving obstacle's image is swept: the sensing board's filter delay
/// (positions of obstacles moving at 0.1-0.3 m/s lag the truth by 50-75 ms, measured by the
/// reflex campaign's moving scenes) plus the map's refresh and the reflex's reaction.
pub const LOOKAHEAD_MS: i32 = 120;
/// A move smaller than this (and an unchanged sweep) is not redrawn.
pub const MOVE_UM: i32 = 500;
/// Longest sweep drawn, per axis (an obstacle faster than 2.5 m/s is drawn as if at 2.5 m/s
/// and the board records a fault).
pub const MAX_SWEEP_MM: i32 = 100;
/// Most disks a sweep is covered with.
pub const MAX_COVER: usize = 8;

/// Bit of [`WorkEntry::state`]: an image is drawn at the entry's position.
pub const DRAWN: u32 = 1;
/// [`WorkEntry::state`] counts the redraws in its bits 8..32.
pub const JOB_SHIFT: u32 = 8;
/// Bits 1-4 of [`WorkEntry::state`]: the fold the image was drawn with ([`fold_of`]),
/// outward along +x, -x, +y, -y.
pub const FOLD_MASK: u32 = 0x1E;
/// How far from the shoulder the arm's outline reaches (the tip's disk, 0.515 m; a test
/// checks it against `arm::geometry`): a disk of radius r whose centre lies farther than
/// this plus r cannot touch the arm, wherever the sensing board reads it.
pub const REACH_UM: i32 = 515_000;
/// The longest fold drawn along one axis ([`folded`]).
pub const FOLD_MAX_UM: i32 = 200_000;
/// Past a corner of the calibrated square, the fold along each axis (there readings are
/// within 9 mm of the truth, some of them a little inward: measured by the test below).
pub const FOLD_CORNER_UM: i32 = 20_000;
/// Across the fold: how far a beacon may lie off the fold's axis beyond what the folded
/// disk already covers.
pub const FOLD_SIDE_UM: i32 = 30_000;

/// The fold of a beacon read at (`x_um`, `y_um`) with `flags`, against the calibrated
/// square `area_um` (x min, x max, y min, y max: the calibration table's header): for a
/// reading the sensing board flags `EXTRAPOLATED`, the sides of the square it lies
/// beyond, as [`FOLD_MASK`] bits; 0 otherwise. Masks from signs, no compare (their flags
/// were clobbered on the 68k; docs/toolchain.md class 1).
#[inline(never)]
pub fn fold_of(x_um: i32, y_um: i32, flags: u32, area_um: &[i32; 4]) -> u32 {
    let ext = (flags >> beacon_flags::EXTRAPOLATED.trailing_zeros()) & 1;
    let beyond = |d: i32| ((d >> 31) & 1) as u32;
    let bits = (beyond(area_um[1] - x_um) << 1)
        | (beyond(x_um - area_um[0]) << 2)
        | (beyond(area_um[3] - y_um) << 3)
        | (beyond(y_um - area_um[2]) << 4);
    bits & ext.wrapping_neg()
}

/// The disk the C-space boards draw for an obstacle of radius `r_um` read at (`x_um`,
/// `y_um`) with the fold `bits`: [`folded`], its radius grown first by the sensing board's
/// tolerance (`beacon_flags::TOLERANCE_UM`, 3 mm), so that the image holds the obstacle
/// wherever the reading may have put it. The reflex's evasion takes the same disk.
/// Inlined, as [`folded`]'s test: a reading with no fold costs no call (the reflex asks
/// for every obstacle on every pass among moving ones).
#[inline(always)]
pub fn drawn_disk(x_um: i32, y_um: i32, r_um: i32, bits: u32) -> Disk {
    folded(x_um, y_um, r_um + beacon_flags::TOLERANCE_UM, bits)
}

/// The disk that covers an obstacle of radius `r_um` read at (`x_um`, `y_um`) wherever the
/// fold `bits` ([`fold_of`]) may have put it. Beyond one side of the calibrated square the
/// detector's edge folds the spot back: a beacon the arm can touch reads up to ~140 mm
/// short along that axis (`tests/tests/sensing.rs` measures the optical model and holds
/// this disk to it), so the fold runs outward from the reading to where the obstacle could
/// no longer touch the arm ([`REACH_UM`] + r, at most [`FOLD_MAX_UM`]); past a corner,
/// [`FOLD_CORNER_UM`] along both axes. A disk centred half-way along the fold, its radius
/// grown by half the fold's length and [`FOLD_SIDE_UM`], covers the fold grown by the
/// radius and the side (triangle inequality). With no fold, the disk as read.
#[inline(always)]
pub fn folded(x_um: i32, y_um: i32, r_um: i32, bits: u32) -> Disk {
    // Most readings are inside the square: the disk as read, without the call and the
    // products of the fold (the reflex asks for every obstacle on every pass among moving
    // ones).
    if bits & FOLD_MASK == 0 {
        return Disk { x_um, y_um, r_um };
    }
    fold_out(x_um, y_um, r_um, bits)
}

/// [`folded`] for a reading with a fold.
#[inline(never)]
fn fold_out(x_um: i32, y_um: i32, r_um: i32, bits: u32) -> Disk {
    // Direction along x and y, and whether folded at all / past a corner, from a table: the
    // masks this was written with first compiled to selects whose flags a register copy
    // clobbered (docs/toolchain.md, class 1).
    let [dx, dy, any, corner] = FOLD_DIRS[((bits & FOLD_MASK) >> 1) as usize];
    let (dx, dy, any, corner) = (dx as i32, dy as i32, any as i32, corner as i32);
    // Along the one folded axis: from the reading out to the reach, within the limits.
    let at = x_um.abs() * (dx * dx) + y_um.abs() * (1 - dx * dx);
    let f = REACH_UM + r_um - at;
    let f = f & !(f >> 31);
    let over = (FOLD_MAX_UM - f) >> 31;
    let f = f ^ ((f ^ FOLD_MAX_UM) & over);
    let half = (f >> 1) * (1 - corner) + (FOLD_CORNER_UM / 2) * corner;
    // Half the fold's length: `half`, or half x sqrt 2 past a corner (425 / 1024 above
    // sqrt 2 - 1).
    let half_len = half + ((half * 425) >> 10) * corner;
    Disk {
        x_um: x_um + dx * half,
        y_um: y_um + dy * half,
        r_um: r_um + (half_len + FOLD_SIDE_UM + 1) * any,
    }
}

/// Per fold (the [`FOLD_MASK`] bits shifted down): the direction along x and y (-1, 0,
/// +1), 1 if folded at all, 1 if past a corner. Opposite sides together cannot happen; they
/// fold along neither.
const FOLD_DIRS: [[i8; 4]; 16] = {
    let mut t = [[0i8; 4]; 16];
    let mut k = 0;
    while k < 16 {
        let dx = (k & 1) as i8 - ((k >> 1) & 1) as i8;
        let dy = ((k >> 2) & 1) as i8 - ((k >> 3) & 1) as i8;
        t[k] = [
            dx,
            dy,
            (dx != 0 || dy != 0) as i8,
            (dx != 0 && dy != 0) as i8,
        ];
        k += 1;
    }
    t
};

/// The calibrated square (x min, x max, y min, y max, micrometres) from the sensing
/// calibration table's header in global RAM: what [`fold_of`] measures a reading against.
#[inline(never)]
pub fn calibrated_area(g: &mut (impl GlobalBus + ?Sized)) -> [i32; 4] {
    let at = |k: u32| vme_map::layout::SENSING_CAL + 4 * (vme_map::records::cal::W_AREA + k);
    [
        g.read_u32(at(0)) as i32,
        g.read_u32(at(1)) as i32,
        g.read_u32(at(2)) as i32,
        g.read_u32(at(3)) as i32,
    ]
}

/// The disks that cover an obstacle of radius `r_um` swept from (`x`, `y`) by
/// (`dx_mm`, `dy_mm`): by IV.1, a disk of radius r + d/2 centred on a piece of the path of
/// length d covers the obstacle anywhere along that piece. The piece length is chosen so the
/// covering disks use the database's next family up.
pub fn cover(
    x_um: i32,
    y_um: i32,
    dx_mm: i32,
    dy_mm: i32,
    r_um: i32,
) -> ([Disk; MAX_COVER], usize) {
    let mut out = [Disk { x_um, y_um, r_um }; MAX_COVER];
    if dx_mm == 0 && dy_mm == 0 {
        return (out, 1);
    }
    let (dx, dy) = (dx_mm * 1000, dy_mm * 1000);
    // Path length, rounded up (integer square root of the squared length in mm).
    let len_mm = fx::isqrt_u32((dx_mm * dx_mm + dy_mm * dy_mm) as u32) as i32 + 1;
    // The smallest family whose pieces need at most MAX_COVER disks.
    let mut n = MAX_COVER as i32;
    for f in crate::db::FAMILIES {
        let slack_um = f.disk_r_um - POLAR_MARGIN_UM - r_um;
        if slack_um > 0 {
            let k = fx::div(len_mm * 1000 + 2 * slack_um - 1, 2 * slack_um);
            if k <= MAX_COVER as i32 {
                n = k.max(1);
                break;
            }
        }
    }
    let half_piece_um = fx::div(len_mm * 1000 + 2 * n - 1, 2 * n);
    for (i, d) in out.iter_mut().take(n as usize).enumerate() {
        // Centre of piece i: (2i + 1) / (2n) along the path.
        let num = 2 * i as i32 + 1;
        *d = Disk {
            x_um: x_um + fx::div(dx, 2 * n) * num,
            y_um: y_um + fx::div(dy, 2 * n) * num,
            r_um: r_um + half_piece_um + 1,
        };
    }
    (out, n as usize)
}

/// The sweep (mm over [`LOOKAHEAD_MS`]) of an obstacle now at (`x`, `y`) at time `t_us`,
/// from the velocity since the entry's drawn sample (none if nothing is drawn; the same
/// sample gives a zero move); clamped to [`MAX_SWEEP_MM`] (then the flag is set). Written
/// without selects: compiled, they clobbered the condition codes on the 68k
/// (docs/toolchain.md).
#[inline(never)]
fn sweep(e: &WorkEntry, x: i32, y: i32, t_us: u32) -> (i32, i32, bool) {
    let drawn = (e.state & DRAWN) as i32;
    // Elapsed time in 64 us units, never zero (one unit of bias, a few per cent at most
    // at the sensing board's 2 ms frames).
    let dt64 = (t_us.wrapping_sub(e.generation) >> 6) as i32 + 1;
    // um over the look-ahead: dx * (LOOKAHEAD_MS * 1000 / 64) / dt64; |dx| < 2^20 um keeps
    // the product in 32 bits.
    let k = LOOKAHEAD_MS * 1000 / 64;
    let sx = fx::div(fx::div((x - e.x_um) * k, dt64), 1000) * drawn;
    let sy = fx::div(fx::div((y - e.y_um) * k, dt64), 1000) * drawn;
    let (cx, cy) = (clamp_mm(sx), clamp_mm(sy));
    (cx, cy, ((cx ^ sx) | (cy ^ sy)) != 0)
}

#[inline(never)]
fn clamp_mm(v: i32) -> i32 {
    v.clamp(-MAX_SWEEP_MM, MAX_SWEEP_MM)
}

/// The sweep to draw: a quarter of the new estimate `now` and three quarters of the sweep
/// drawn last (`was`), rounded away from zero. A redraw follows a move of half a
/// millimetre, a few milliseconds at the campaign's 0.1-0.3 m/s, so one estimate's
/// direction carries the sensing board's position noise (0.3-0.7 mm at rest) over that
/// short baseline: drawn raw, an obstacle's swept image swung from side to side between
/// redraws, flickering marks onto free pixels and leaving pixels it had to cover unmarked
/// (the reflex campaign's moving scenes, seed 1: 22 scenes had a colliding pixel next to
/// the arm unmarked, 3 with the smoothing). The average over the last few redraws (~4,
/// 10-20 ms) follows the quasi-static obstacles' slow turns.
#[inline(never)]
fn smooth(was: (i32, i32), now: (i32, i32)) -> (i32, i32) {
    let f = |o: i32, n: i32| {
        let t = 3 * o + n;
        // Up for t >= 0 (+3 then floor), down for t < 0 (floor).
        (t + (3 & !(t >> 31))) >> 2
    };
    (f(was.0, now.0), f(was.1, now.1))
}

fn sweep_of(e: &WorkEntry) -> (i32, i32) {
    unpack_sweep(e.reserved)
}

/// The sweep packed in an entry's last word: mm over [`LOOKAHEAD_MS`], x in the high half,
/// y in the low, each signed.
fn unpack_sweep(w: u32) -> (i32, i32) {
    ((w as i32) >> 16, (w as i32) << 16 >> 16)
}

/// Word of [`WorkEntry`] that holds the sweep drawn.
const SWEEP_WORD: u32 = vme_map::record::word_index(WorkEntry::FIELDS, "reserved");

/// The sweep drawn for entry `i`'s obstacle, mm over [`LOOKAHEAD_MS`] (x, y): its velocity
/// as the C-space boards estimate it, for the reflex's evasion (`reflex::evade`). One
/// word, written whole by the board that drew the entry.
pub fn drawn_sweep_mm(g: &mut (impl GlobalBus + ?Sized), i: u32) -> (i32, i32) {
    unpack_sweep(g.read_u32(work_entry(i) + 4 * SWEEP_WORD))
}

/// A job's working memory, kept by the board between jobs (92 KiB: not on the stack, and
/// the 68k backend mis-indexes arrays on a function's own frame, llvm/llvm-project#200984).
pub struct Scratch {
    /// The decrements of the job's first half ([`raster::pair`]).
    log: RunLog,
    pair: PairWork,
    /// The images of the new and the old cover disk being paired.
    new: Images,
    old: Images,
    /// Per cover disk: the old link-1 stripe, erased in the second half.
    old_stripes: [Option<Stripe>; MAX_COVER],
    /// Per cover disk and link-2 image (front, rear): its decrements are in the log.
    logged: [bool; 2 * MAX_COVER],
    /// The images of the last [`KEPT_IMAGES`] new cover disks, for the jobs that have them
    /// as their old ones.
    kept: [KeptImages; KEPT_IMAGES],
    /// The slot the next disk not already kept goes to (round robin).
    next_kept: usize,
}

/// Cover disks whose images a board keeps: a job's new disks are the next job's old ones
/// on the same entry (six obstacles, most of them one disk each).
pub const KEPT_IMAGES: usize = 8;

/// A disk's images kept from the job that computed them: a function of the disk alone, so
/// a job whose old disk is kept copies them instead of interpolating them again (~25,000
/// cycles of a 2-inch obstacle's job at 200 mm on the 68020).
struct KeptImages {
    /// Whether `disk` and `images` hold a disk's images (else unwritten memory).
    valid: bool,
    disk: core::mem::MaybeUninit<Disk>,
    images: core::mem::MaybeUninit<Images>,
}

impl KeptImages {
    const EMPTY: KeptImages = KeptImages {
        valid: false,
        disk: core::mem::MaybeUninit::uninit(),
        images: core::mem::MaybeUninit::uninit(),
    };
}

impl Scratch {
    /// Empty working memory.
    pub const fn new() -> Self {
        const NO: Images = Images {
            stripe: None,
            front: None,
            rear: None,
        };
        Self {
            log: RunLog::new(),
            pair: PairWork::new(),
            new: NO,
            old: NO,
            old_stripes: [None; MAX_COVER],
            logged: [false; 2 * MAX_COVER],
            kept: [const { KeptImages::EMPTY }; KEPT_IMAGES],
            next_kept: 0,
        }
    }
    /// How many link-2 images' columns the jobs took from those kept from earlier jobs
    /// instead of computing them (wrapping; [`raster::PairWork::hits`]).
    pub fn kept_hits(&self) -> u32 {
        self.pair.hits()
    }
    /// Initialises `slot` in place and returns it: every field a job reads before it writes
    /// it, and not the large work areas ([`RunLog`], [`PairWork`]'s columns, records and
    /// kept columns, the kept disks' images), which stay as they were. For a board's memory
    /// outside `.bss` (the image's `.uninit` section: zeroing or copying it, 33 KiB then, at
    /// power-up delayed its first heartbeat).
    pub fn init(slot: &mut core::mem::MaybeUninit<Scratch>) -> &mut Scratch {
        use core::ptr::addr_of_mut;
        const NO: Images = Images {
            stripe: None,
            front: None,
            rear: None,
        };
        let p = slot.as_mut_ptr();
        // SAFETY: every field that is not (made of) `MaybeUninit` is written here before
        // the reference is made: the log's and the pair work's own fields, the images, the
        // stripes, the flags and the kept images' flags.
        unsafe {
            RunLog::init(addr_of_mut!((*p).log));
            PairWork::init(addr_of_mut!((*p).pair));
            addr_of_mut!((*p).new).write(NO);
            addr_of_mut!((*p).old).write(NO);
            addr_of_mut!((*p).old_stripes).write([None; MAX_COVER]);
            addr_of_mut!((*p).logged).write([false; 2 * MAX_COVER]);
            addr_of_mut!((*p).next_kept).write(0);
            let mut i = 0;
            while i < KEPT_IMAGES {
                addr_of_mut!((*p).kept[i].valid).write(false);
                i += 1;
            }
            slot.assume_init_mut()
        }
    }
}

impl Default for Scratch {
    fn default() -> Self {
        Self::new()
    }
}

/// The images of cover disk `i` of `disks` (or none past `n`) into `out`.
fn images_of(disks: &([Disk; MAX_COVER], usize), i: usize, out: &mut Images) {
    *out = Images::default();
    if i < disks.1 {
        if let Ok(im) = images(&disks.0[i]) {
            *out = im;
        }
    }
}

impl Scratch {
    /// The slot keeping disk `d`'s images, or [`KEPT_IMAGES`] when none does.
    #[inline(never)]
    fn kept_slot(&self, d: &Disk) -> usize {
        raster::find_slot(KEPT_IMAGES, |i| {
            let k = &self.kept[i];
            // SAFETY: a valid slot's disk was written with its flag.
            k.valid && same_disk(unsafe { k.disk.assume_init_ref() }, d)
        })
    }

    /// The images of old cover disk `i` of `disks` (none past `n`) into `self.old`: copied
    /// when kept, else computed. Returns the slot that kept them ([`KEPT_IMAGES`]: none).
    #[inline(never)]
    fn old_images(&mut self, disks: &([Disk; MAX_COVER], usize), i: usize) -> usize {
        if i < disks.1 {
            let slot = self.kept_slot(&disks.0[i]);
            if slot < KEPT_IMAGES {
                // SAFETY: a valid slot's images were written with its flag.
                self.old = unsafe { self.kept[slot].images.assume_init() };
                return slot;
            }
        }
        images_of(disks, i, &mut self.old);
        KEPT_IMAGES
    }

    /// Keeps `self.new`, the images of new cover disk `i` of `disks` (when it has some), in
    /// `slot` (the old disk's, which it replaces), or the next slot round when `slot` is
    /// [`KEPT_IMAGES`].
    #[inline(never)]
    fn keep_new(&mut self, disks: &([Disk; MAX_COVER], usize), i: usize, slot: usize) {
        if i >= disks.1 {
            return;
        }
        let slot = raster::kept_target(slot, &mut self.next_kept, KEPT_IMAGES);
        let k = &mut self.kept[slot];
        k.disk.write(disks.0[i]);
        k.images.write(self.new);
        k.valid = true;
    }
}

/// Whether disks `a` and `b` are the same, by their words' differences or-ed (a compiled
/// field-by-field compare feeds the 68k's branch through register copies,
/// docs/toolchain.md class 1).
#[inline(never)]
fn same_disk(a: &Disk, b: &Disk) -> bool {
    ((a.x_um ^ b.x_um) | (a.y_um ^ b.y_um) | (a.r_um ^ b.r_um)) == 0
}

/// Moves the images of disk `old` (drawn) to those of disk `new` in global RAM as a job
/// does (`update` with one cover disk each): the probe the system tests run on the image
/// against the host's draw-then-erase.
pub fn move_disk<B: GlobalBus + ?Sized>(
    g: &mut B,
    old: &Disk,
    new: &Disk,
    sc: &mut Scratch,
) -> Result<(Flags, Option<Error>), Error> {
    update(
        g,
        &([*new; MAX_COVER], 1),
        &([*old; MAX_COVER], 1),
        sc,
        Progress::new(0, 0),
    )
}

/// Moves an obstacle's images from the cover disks `old` to `new` (thesis lines 1199-1210:
/// new before old). Cover disk `i` of the new position is paired with disk `i` of the old
/// (the same part of the obstacle, moved a little), and each pair's link-2 images are
/// updated differentially ([`raster::pair`]): every increment of every pair first, then
/// every decrement, so the new images are whole before anything of the old ones goes and
/// no void opens. Link-1 stripes are drawn and erased whole (a few words each).
///
/// Fails before touching the map when the new disks have no images; when the old ones have
/// none (never drawn so) the new images are drawn and the error returned with them.
fn update<B: GlobalBus + ?Sized>(
    g: &mut B,
    new: &([Disk; MAX_COVER], usize),
    old: &([Disk; MAX_COVER], usize),
    sc: &mut Scratch,
    progress: Progress,
) -> Result<(Flags, Option<Error>), Error> {
    // Every cover disk of a position has the same radius: one check covers them all.
    crate::family(new.0[0].r_um)?;
    let (old, old_err) = match crate::family(old.0[0].r_um) {
        Err(e) if old.1 > 0 => ((old.0, 0), Some(e)),
        _ => (*old, None),
    };
    let mut f = Flags::default();
    let mut canvas = JobCanvas {
        bus: BusCanvas(&mut *g),
        progress,
        writes: 0,
    };
    let pairs = new.1.max(old.1);
    sc.log.truncate(0);
    for i in 0..pairs {
        images_of(new, i, &mut sc.new);
        let slot = sc.old_images(&old, i);
        sc.keep_new(new, i, slot);
        canvas.mark();
        if let Some(s) = &sc.new.stripe {
            f.merge(raster::stripe(s, &mut canvas, Op::Draw));
        }
        sc.old_stripes[i] = sc.old.stripe;
        let (fl, ok) = raster::pair(
            &mut sc.old.front,
            &sc.new.front,
            &mut canvas,
            Some(&mut sc.log),
            &mut sc.pair,
        );
        f.merge(fl);
        sc.logged[2 * i] = ok;
        canvas.mark();
        let (fl, ok) = raster::pair(
            &mut sc.old.rear,
            &sc.new.rear,
            &mut canvas,
            Some(&mut sc.log),
            &mut sc.pair,
        );
        f.merge(fl);
        sc.logged[2 * i + 1] = ok;
        canvas.mark();
    }
    // Second half: the old images go.
    f.merge(sc.log.erase(&mut canvas));
    canvas.mark();
    for i in 0..pairs {
        if let Some(s) = &sc.old_stripes[i] {
            f.merge(raster::stripe(s, &mut canvas, Op::Erase));
        }
        if sc.logged[2 * i] && sc.logged[2 * i + 1] {
            continue;
        }
        // The log was full: this pair's decrements are computed again.
        images_of(new, i, &mut sc.new);
        images_of(&old, i, &mut sc.old);
        if !sc.logged[2 * i] {
            let (fl, _) = raster::pair(
                &mut sc.old.front,
                &sc.new.front,
                &mut canvas,
                None,
                &mut sc.pair,
            );
            f.merge(fl);
        }
        if !sc.logged[2 * i + 1] {
            let (fl, _) = raster::pair(
                &mut sc.old.rear,
                &sc.new.rear,
                &mut canvas,
                None,
                &mut sc.pair,
            );
            f.merge(fl);
        }
        canvas.mark();
    }
    Ok((f, old_err))
}

/// Columns written between two progress marks of a job: at most some 8 x 3,000 cycles
/// (a whole column each), 1.5 ms.
const MARK_EVERY: u32 = 8;
const _: () = assert!(MARK_EVERY.is_power_of_two());

/// The canvas of a job in a claimed work-list entry: the bus's, with the job's progress
/// marked every [`MARK_EVERY`] columns written (a single link-2 image of a moving obstacle's
/// swept disk took more than the reflex's 20 ms as images, where marks only between images
/// left the entry looking abandoned: `moving_obstacles.toml` as images held the arm 22
/// times in its first 2 s).
struct JobCanvas<'a, B: GlobalBus + ?Sized> {
    bus: BusCanvas<'a, B>,
    progress: Progress,
    writes: u32,
}

impl<B: GlobalBus + ?Sized> JobCanvas<'_, B> {
    /// One more mark (not inlined: the job's loop drew a condition-code clobber with the
    /// marks inline, refused by `cargo xtask images`).
    #[inline(never)]
    fn mark(&mut self) {
        self.progress.mark(self.bus.0);
    }

    /// One more column written: every [`MARK_EVERY`]th advances the mark.
    #[inline(always)]
    fn tick(&mut self) {
        self.writes = self.writes.wrapping_add(1);
        if self.writes & (MARK_EVERY - 1) == 0 {
            self.progress.mark(self.bus.0);
        }
    }
}

impl<B: GlobalBus + ?Sized> raster::Canvas for JobCanvas<'_, B> {
    fn pixel(&mut self, i1: u32, i2: u32, mask: u32, op: Op) -> Flags {
        self.bus.pixel(i1, i2, mask, op)
    }
    fn stripe(&mut self, i1: u32, mask: u32, op: Op) -> Flags {
        self.bus.stripe(i1, mask, op)
    }
    /// A run of a pair's differences, counted as a column written. Inlined, with
    /// [`raster::BusCanvas`]'s run, into the pair's application (a frame a layer cost more
    /// than the one-row runs' updates; the image against the host stays identical).
    #[inline(always)]
    fn run(&mut self, i1: u32, i2: u32, rows: u32, mask: u32, op: Op) -> Flags {
        let f = self.bus.run(i1, i2, rows, mask, op);
        self.tick();
        f
    }
    /// Every whole column a job writes comes here, every run of a pair's differences to
    /// [`JobCanvas::run`] (the stripes' words are a few per image).
    /// Not `#[inline(always)]`: inlined into its callers (1% faster) the image misdrew the
    /// work list (`bench cspace`'s image-against-host check, table 4).
    fn column(&mut self, i1: u32, i2: u32, pieces: &[u32; 10], op: Op) -> Flags {
        let f = self.bus.column(i1, i2, pieces, op);
        self.tick();
        f
    }
}

/// A job's progress marks in its claimed entry's `claim` word (`WorkEntry::claim`): the
/// board's number in bits 0-7, the cursor's count when the job took the entry in bits
/// 20-31 ([`TAG_CURSOR`]), and a count in bits 8-19 advanced once a cover disk's images
/// are made, after each link-2 image, after the erase, and every [`MARK_EVERY`] columns
/// written between ([`JobCanvas`]). A job can outlast the reflex's limit for an entry
/// claimed and unchanged (`reflex::health::MAP_TORN_US`, 20 ms; the bench's worst job is
/// 46 ms): the marks tell it a board is at work there, as a board that died mid-job leaves
/// them still.
struct Progress {
    claim: u32,
    tag: u32,
    n: u32,
}

/// The cursor's count in a claim, bits 20-31: consecutive jobs on an entry claim it with
/// different words, so the reflex, reading an entry every few milliseconds, never takes two
/// jobs for one that stood still (with the count alone a job that made no mark, then the
/// next one on the entry, read the same `1`, and a 3-board run as images held the arm on
/// a `TornRecord`).
const TAG_CURSOR: u32 = 0xFFF;
/// The marks' count in a claim, bits 8-19.
const TAG_MARKS: u32 = 0xFFF;

impl Progress {
    /// Marks in the `claim` word at `claim`, claimed with `tag` (the board's number 1-3 and
    /// the cursor's count, [`TAG_CURSOR`]); `tag` 0 marks nothing (a move with no work-list
    /// entry, [`move_disk`]).
    fn new(claim: u32, tag: u32) -> Self {
        Self { claim, tag, n: 0 }
    }

    /// One more mark.
    #[inline(never)]
    fn mark<B: GlobalBus + ?Sized>(&mut self, g: &mut B) {
        self.n = self.n.wrapping_add(1) & TAG_MARKS;
        if self.tag != 0 {
            g.write_u32(self.claim, self.tag | (self.n << 8));
        }
    }
}

/// What one pass of [`step`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Outcome {
    /// The entry taken.
    pub entry: u32,
    /// Its claim was held by another board: nothing done.
    pub busy: bool,
    /// The obstacle was redrawn.
    pub redrawn: bool,
    /// Its sweep was longer than [`MAX_SWEEP_MM`] and was clamped.
    pub clamped: bool,
    /// Counter events of the draw and erase.
    pub flags: Flags,
    /// The obstacle could not be transformed (its old image, if any, stays).
    pub error: Option<Error>,
}

/// Words of the object table in global RAM (frame, then four per beacon).
pub const OBJECT_WORDS: usize = ObjectTable::WORDS as usize;

/// The beacon of entry `i`, decoded from the object table's words: a job needs one beacon,
/// not all eight. (A function of its own: inlined into `step`, the 68k build read beacon 0
/// for every entry; found by the image-against-host system test.)
#[inline(never)]
fn beacon_of(words: &[u32; OBJECT_WORDS], i: u32) -> Beacon {
    let base = 1 + OBSTACLE_BEACONS[i as usize] as usize * Beacon::WORDS as usize;
    Beacon::decode(&mut |k| words[base + k as usize])
}

/// Work-list entry `i` as it is in global RAM.
pub fn entry(g: &mut (impl GlobalBus + ?Sized), i: u32) -> WorkEntry {
    let base = work_entry(i);
    WorkEntry::decode(&mut |w| g.read_u32(base + 4 * w))
}

/// One job of C-space board `me` (1-based: 1 + its C-space index) with the object table
/// `objects` just read: takes the next entry from the shared cursor and brings its image up
/// to date.
pub fn step<B: GlobalBus + ?Sized>(
    g: &mut B,
    me: u32,
    objects: &ObjectTable,
    sc: &mut Scratch,
) -> Outcome {
    let mut words = [0u32; OBJECT_WORDS];
    objects.encode(&mut |k, v| words[k as usize] = v);
    step_words(g, me, &words, sc)
}

/// [`step`] with the object table as its words in global RAM (what a board reads under the
/// table's sequence lock): only the job's beacon is decoded.
pub fn step_words<B: GlobalBus + ?Sized>(
    g: &mut B,
    me: u32,
    objects: &[u32; OBJECT_WORDS],
    sc: &mut Scratch,
) -> Outcome {
    let c = take_cursor(g);
    let i = fx::rem_u32(c, OBSTACLE_BEACONS.len() as u32);
    let claim = work_entry(i);
    // The claim: the board's number and the cursor's count ([`Progress`]).
    let tag = me | ((c & TAG_CURSOR) << 20);
    if g.cas_u32(claim, 0, tag) != 0 {
        return Outcome {
            entry: i,
            busy: true,
            ..Default::default()
        };
    }
    let mut e = entry(g, i);
    let b = beacon_of(objects, i);
    let out = job(g, i, &b, &mut e, sc, tag);
    // Write the entry back with the claim still ours, then release it last.
    e.encode(&mut |w, v| {
        if w != 0 {
            g.write_u32(claim + 4 * w, v)
        }
    });
    g.write_u32(claim, 0);
    out
}

/// The semaphore: advances the shared cursor atomically and returns the count it took (the
/// entry is that modulo the number of entries).
#[inline(never)]
fn take_cursor<B: GlobalBus + ?Sized>(g: &mut B) -> u32 {
    let mut c = g.read_u32(WORK_CURSOR);
    loop {
        let found = g.cas_u32(WORK_CURSOR, c, c.wrapping_add(1));
        if found == c {
            return c;
        }
        c = found;
    }
}

/// Whether entry `e` must be redrawn for beacon sample `b` with fold `fold` ([`fold_of`]):
/// nothing drawn yet, a new fold, or a new sample that moved the obstacle (its sweep is
/// then redrawn too). The sample the
/// image was drawn from again changes nothing (passes run much faster than the sensing
/// board's frames, and must not undo the sweep). Written with bitwise ors of compares: the
/// short-circuit form compiled to a condition-code clobber on the 68k (docs/toolchain.md).
#[inline(never)]
fn needs_redraw(e: &WorkEntry, b: &Beacon, fold: u32) -> bool {
    let fresh = (b.t_us != e.generation) as u32;
    // A changed sweep counts only with a move beyond MOVE_UM: from the sensing board's
    // resting noise (0.3-0.7 mm) over one 2 ms frame the velocity estimate alone would
    // sweep 10 mm and redraw every frame. A stopped obstacle keeps its last (larger,
    // conservative) sweep until it moves again.
    let moved =
        ((b.x_um - e.x_um).abs() > MOVE_UM) as u32 | ((b.y_um - e.y_um).abs() > MOVE_UM) as u32;
    let undrawn = (e.state & DRAWN == 0) as u32;
    // A fold that changed (the reading crossed a side of the calibrated square) is redrawn
    // at once: the drawn disk may no longer cover the beacon.
    let refold = ((e.state & FOLD_MASK) != fold) as u32;
    (undrawn | (fresh & moved) | refold) != 0
}

/// `n` when `state` has an image drawn, else 0. Not inlined, a mask not a branch: inlined
/// into `job`, its branch read flags a register copy had clobbered (docs/toolchain.md,
/// class 1).
#[inline(never)]
fn if_drawn(n: usize, state: u32) -> usize {
    n & ((state & DRAWN) as usize).wrapping_neg()
}

/// The work on claimed entry `i` (held in `e`, updated in place) for beacon sample `b`,
/// claimed with `tag` ([`Progress`]).
#[inline(never)]
fn job<B: GlobalBus + ?Sized>(
    g: &mut B,
    i: u32,
    b: &Beacon,
    e: &mut WorkEntry,
    sc: &mut Scratch,
    tag: u32,
) -> Outcome {
    let mut out = Outcome {
        entry: i,
        ..Default::default()
    };
    if b.flags & beacon_flags::VALID == 0 {
        return out;
    }
    let (sx, sy, clamped) = sweep(e, b.x_um, b.y_um, b.t_us);
    // Only an obstacle the sensing board sees moving is swept: a resting one's position
    // noise over a 2 ms frame would otherwise sweep it by millimetres each redraw.
    let moving = -(((b.flags & beacon_flags::MOVING) >> 7) as i32);
    let (sx, sy) = (sx & moving, sy & moving);
    let (sx, sy) = smooth(sweep_of(e), (sx, sy));
    out.clamped = clamped;
    // A reading beyond the calibrated square stands for a beacon anywhere along its fold.
    let fold = fold_of(b.x_um, b.y_um, b.flags, &calibrated_area(g));
    if !needs_redraw(e, b, fold) {
        return out;
    }
    // New image first, then the old one goes: no void ever opens. (The entry keeps the
    // obstacle's own radius; both disks are grown by the sensing board's tolerance.)
    let r_um = radius(g, i);
    let n = drawn_disk(b.x_um, b.y_um, r_um, fold);
    let new = cover(n.x_um, n.y_um, sx, sy, n.r_um);
    let (was_x, was_y) = sweep_of(e);
    let o = drawn_disk(e.x_um, e.y_um, e.r_um, e.state & FOLD_MASK);
    let mut old = cover(o.x_um, o.y_um, was_x, was_y, o.r_um);
    old.1 = if_drawn(old.1, e.state);
    match update(g, &new, &old, sc, Progress::new(work_entry(i), tag)) {
        Ok((f, err)) => {
            out.flags.merge(f);
            out.error = err;
            e.x_um = b.x_um;
            e.y_um = b.y_um;
            e.r_um = r_um;
            e.generation = b.t_us;
            e.reserved = ((sx as u32) << 16) | (sy as u32 & 0xFFFF);
            e.beacon = OBSTACLE_BEACONS[i as usize];
            e.state = ((e.state & !FOLD_MASK) | DRAWN | fold).wrapping_add(1 << JOB_SHIFT);
            out.redrawn = true;
        }
        Err(err) => out.error = Some(err),
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A job's new disks' images are found for the next job that has them as its old disks
    /// (and are those `images` computes), a disk differing in any word is not, and the
    /// round robin evicts a kept disk only once every slot has been taken since.
    #[test]
    fn old_disks_images_are_taken_from_the_kept_ones() {
        let mut sc = Box::new(Scratch::new());
        let disk = |x_um, r_um| Disk {
            x_um,
            y_um: -60_000,
            r_um,
        };
        let one = |d: Disk| {
            let mut v = [d; MAX_COVER];
            v[1] = disk(0, 0);
            (v, 1)
        };
        let (a, b) = (one(disk(200_000, 28_500)), one(disk(201_000, 28_500)));
        images_of(&b, 0, &mut sc.new);
        assert_eq!(sc.old_images(&a, 0), KEPT_IMAGES, "nothing kept yet");
        sc.keep_new(&b, 0, KEPT_IMAGES);
        assert_eq!(sc.old, images(&a.0[0]).unwrap());
        // The next job: b is its old disk.
        let slot = sc.old_images(&b, 0);
        assert!(slot < KEPT_IMAGES);
        assert_eq!(sc.old, images(&b.0[0]).unwrap());
        // Not for a disk one word away, nor past the disks given.
        for d in [
            disk(201_001, 28_500),
            Disk {
                y_um: -60_001,
                ..b.0[0]
            },
            disk(201_000, 28_501),
        ] {
            assert_eq!(sc.old_images(&one(d), 0), KEPT_IMAGES, "{d:?}");
        }
        assert_eq!(sc.old_images(&(b.0, 0), 0), KEPT_IMAGES);
        assert_eq!(sc.old, Images::default());
        // Others round: b's slot is taken only after every other one.
        for k in 0..KEPT_IMAGES as i32 {
            assert!(
                sc.kept_slot(&b.0[0]) < KEPT_IMAGES,
                "evicted after {k} others"
            );
            let c = one(disk(100_000 + 5_000 * k, 28_500));
            images_of(&c, 0, &mut sc.new);
            sc.keep_new(&c, 0, KEPT_IMAGES);
        }
        assert_eq!(sc.kept_slot(&b.0[0]), KEPT_IMAGES);
    }
}
