//! The C-space board's logic (thesis ch. IV): disk obstacles in task space to their images
//! in the toroidal 128 x 128 configuration-space map of absolute joint angles, drawn into
//! per-pixel edge-direction counters and erased again, conservatively.
//!
//! * [`polar`]: the obstacle's centre in polar coordinates (ch. IV section 5: the image at
//!   (r, alpha) is the image at (r, 0) shifted by alpha along the diagonal).
//! * [`db`]: the image database by radius, vertex interpolation, odd symmetry (section 5).
//! * [`Shape`], [`raster`]: the interpolated image to pixels: every pixel that the image
//!   touches is marked, its interior included (section 6; beyond the thesis, which marked the
//!   boundary only, so that no pixel holding a colliding configuration is ever free).
//! * [`counters`]: the gray levels, four edge-normal counters per pixel (section 6).
//! * Link-1 images are stripes of theta1 whatever theta2 (section 3: a link-i obstacle needs
//!   only an i-dimensional map), so they go to a 128-entry stripe layer beside the map: pixel
//!   (i1, i2) is occupied when its map word or stripe word `i1` is not zero.
//! * [`worklist`]: the jobs shared among N C-space boards through global RAM (line 1225),
//!   draw-new-before-erase-old, swept images of moving obstacles.
//!
//! Angles are in angle units of 2 pi / 32768 (the thesis's encoder units of ch. IV, 0.011
//! degree), 256 per pixel. Nothing here touches hardware: the board hands in a [`Canvas`].
//!
//! No compiled division: every `/` goes through [`fx::div`] (the M68k backend's DIVS.L
//! clobbers %d0; docs/toolchain.md), and `cargo xtask images` refuses an image that has one.
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]

pub mod counters;
pub mod db;
pub mod polar;
pub mod raster;
pub mod worklist;
#[rustfmt::skip]
mod tables;

pub use counters::Flags;
pub use raster::{BusCanvas, Canvas, Memory, Op, SliceCanvas};

use db::{ChainTable, Family, StripeSample, CHAIN, FAMILIES};

/// Angle units per revolution (2^15, thesis ch. IV's encoder units).
pub const UNITS_PER_REV: i32 = 32768;
/// Half a revolution in angle units.
pub const HALF_REV: i32 = UNITS_PER_REV / 2;
/// Angle units per map pixel (128 pixels per revolution).
pub const UNITS_PER_PIXEL: i32 = 256;
/// Pixels per map axis.
pub const SIDE: u32 = vme_map::layout::CSPACE_SIDE;
/// Added to every disk's radius before its images are chosen: covers the polar conversion's
/// error ([`polar::RADIUS_ERR_UM`], [`polar::ANGLE_ERR_UM_PER_M`] and the angle's rounding
/// to units at the arm's 0.52 m reach).
pub const POLAR_MARGIN_UM: i32 = 100;

/// A disk obstacle in task space (the shoulder at the origin, x along theta = 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Disk {
    /// Centre x, micrometres.
    pub x_um: i32,
    /// Centre y, micrometres.
    pub y_um: i32,
    /// Radius, micrometres.
    pub r_um: i32,
}

/// Why a disk has no images.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Error {
    /// Larger than the largest disk the database holds images for.
    TooLarge,
    /// A negative radius.
    BadRadius,
}

/// An interpolated link-2 image, shifted to the disk's polar angle: an x-monotone polygon in
/// unwrapped angle units (the raster wraps it onto the torus). (`repr(C)`: the runtime's
/// assembly reads it, `__cspace_columns`.)
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct Shape {
    /// theta1 of the vertices, increasing.
    pub theta1_u: [i32; CHAIN],
    /// Upper chain: theta2 at each vertex.
    pub upper_u: [i32; CHAIN],
    /// Lower chain: theta2 at each vertex.
    pub lower_u: [i32; CHAIN],
    /// The image runs all the way round in theta1 (no ends).
    pub wraps: bool,
}

/// A link-1 stripe: theta1 from `lo_u` to `hi_u` (unwrapped), whatever theta2.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stripe {
    /// Low edge, angle units.
    pub lo_u: i32,
    /// High edge, angle units.
    pub hi_u: i32,
    /// Every theta1 (region I, or a stripe wider than a revolution).
    pub full: bool,
}

/// The images of one disk.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Images {
    /// The link-1 stripe (or the whole map, region I).
    pub stripe: Option<Stripe>,
    /// The link-2 front image.
    pub front: Option<Shape>,
    /// The link-2 rear image.
    pub rear: Option<Shape>,
}

/// Linear interpolation with a Q16 fraction: `a + (b - a) f`, rounded down (the database's
/// enclosure check runs this same code).
fn lerp(a: i32, b: i32, f_q16: i32) -> i32 {
    a + (((b - a) * f_q16) >> 16)
}

/// The bracket of `r_um` in sorted radii: index `i` and the Q16 fraction between `i` and
/// `i + 1`; `None` outside.
fn bracket(radii: impl Iterator<Item = i32>, r_um: i32) -> Option<(usize, i32)> {
    let mut prev: Option<i32> = None;
    for (i, r1) in radii.enumerate() {
        if let Some(r0) = prev {
            if r_um <= r1 {
                // Spacing below 2^15 um (the generator checks), so the shift stays in i32.
                return Some((i - 1, fx::div_shl(r_um - r0, r1 - r0, 16)));
            }
        } else if r_um < r1 {
            return None;
        } else if r_um == r1 {
            return Some((0, 0));
        }
        prev = Some(r1);
    }
    None
}

/// The image of `table` for a disk at radius `r_um`, shifted by `alpha_u` along the
/// diagonal; `None` when the radius is outside the table.
pub fn chain_shape(table: &ChainTable, r_um: i32, alpha_u: i32) -> Option<Shape> {
    let s = table.samples;
    let (i, f) = bracket(s.iter().map(|c| c.r_um), r_um)?;
    let (a, b) = (&s[i], s.get(i + 1).unwrap_or(&s[i]));
    let mut shape = Shape {
        theta1_u: [0; CHAIN],
        upper_u: [0; CHAIN],
        lower_u: [0; CHAIN],
        wraps: false,
    };
    fill(&mut shape, a, b, f, table.center2_u, alpha_u);
    Some(shape)
}

/// Interpolates between samples `a` and `b` at Q16 fraction `f` into `shape`, shifted by
/// `alpha_u`. (A function of its own that writes through a reference: the 68k backend drops
/// the index register when a function indexes an array on its own stack frame,
/// llvm/llvm-project#200984; docs/toolchain.md.)
#[inline(never)]
fn fill(shape: &mut Shape, a: &db::ChainSample, b: &db::ChainSample, f: i32, c2: i32, alpha: i32) {
    let half = lerp(a.half1_u, b.half1_u, f).min(HALF_REV);
    shape.wraps = half >= HALF_REV;
    // On the 68020 the loops below are `__cspace_fill` in the runtime's assembly (the
    // compiled ones spent ~10,000 cycles an image); the system tests compare the image's
    // vertices with these.
    #[cfg(target_arch = "m68k")]
    {
        extern "C" {
            #[allow(clippy::too_many_arguments)]
            fn __cspace_fill(
                out: *mut Shape,
                ua: *const i32,
                ub: *const i32,
                f_q16: i32,
                half: i32,
                c2: i32,
                alpha: i32,
                fraction_q15: *const i32,
            );
        }
        // SAFETY: `shape` is a repr(C) Shape (its layout asserted in `raster`); the samples'
        // chains and the fractions are CHAIN words each, only read.
        unsafe {
            __cspace_fill(
                shape,
                a.upper_u.as_ptr(),
                b.upper_u.as_ptr(),
                f,
                half,
                c2,
                alpha,
                db::FRACTION_Q15.as_ptr(),
            )
        }
    }
    #[cfg(not(target_arch = "m68k"))]
    fill_host(shape, a, b, f, half, c2, alpha);
}

/// The host's [`fill`] after the half-width: the chains, the vertices' theta1 and the
/// shift by `alpha` (the reference `__cspace_fill` is compared with).
#[cfg(not(target_arch = "m68k"))]
fn fill_host(
    shape: &mut Shape,
    a: &db::ChainSample,
    b: &db::ChainSample,
    f: i32,
    half: i32,
    c2: i32,
    alpha: i32,
) {
    for k in 0..CHAIN {
        shape.upper_u[k] = lerp(a.upper_u[k], b.upper_u[k], f);
    }
    // The positive half, mirrored (exclusive ranges: the 68k backend miscompiles the flag
    // of an inclusive range's end; docs/toolchain.md).
    for k in CHAIN / 2..CHAIN {
        // half <= 2^14 and |fraction| <= 2^15: the product fits in 32 bits.
        let t = (half * db::FRACTION_Q15[k]) >> 15;
        shape.theta1_u[k] = t;
        shape.theta1_u[CHAIN - 1 - k] = -t;
    }
    for k in 0..CHAIN {
        shape.lower_u[k] = 2 * c2 - shape.upper_u[CHAIN - 1 - k];
    }
    for k in 0..CHAIN {
        shape.theta1_u[k] += alpha;
        shape.upper_u[k] += alpha;
        shape.lower_u[k] += alpha;
    }
}

/// The link-1 stripe half-width for a disk at radius `r_um` (`None`: link 1 cannot reach).
pub fn stripe_half(stripe: &[StripeSample], r_um: i32) -> Option<i32> {
    let (i, f) = bracket(stripe.iter().map(|s| s.r_um), r_um)?;
    let (a, b) = (&stripe[i], stripe.get(i + 1).unwrap_or(&stripe[i]));
    Some(lerp(a.half1_u, b.half1_u, f))
}

/// The database family that encloses a disk of radius `r_um` (after [`POLAR_MARGIN_UM`]).
pub fn family(r_um: i32) -> Result<&'static Family, Error> {
    if r_um < 0 {
        return Err(Error::BadRadius);
    }
    FAMILIES
        .iter()
        .find(|f| f.disk_r_um >= r_um + POLAR_MARGIN_UM)
        .ok_or(Error::TooLarge)
}

/// The images of `disk`: conservative (every configuration in which the arm touches the disk
/// lies inside one of them).
pub fn images(disk: &Disk) -> Result<Images, Error> {
    let fam = family(disk.r_um)?;
    let (r, alpha) = polar::polar(disk.x_um, disk.y_um);
    if r <= fam.full_within_um {
        return Ok(Images {
            stripe: Some(Stripe {
                lo_u: 0,
                hi_u: UNITS_PER_REV,
                full: true,
            }),
            front: None,
            rear: None,
        });
    }
    let stripe = stripe_half(fam.stripe, r).map(|h| Stripe {
        lo_u: alpha - h,
        hi_u: alpha + h,
        full: h >= HALF_REV,
    });
    let mut im = Images {
        stripe,
        front: None,
        rear: None,
    };
    find_shape(fam.front, r, alpha, &mut im.front);
    find_shape(fam.rear, r, alpha, &mut im.rear);
    Ok(im)
}

/// The image of the first of `tables` that holds radius `r_um`, into `out`. (Written through
/// a reference: the 68k backend miscompiles aggregates built on a function's own frame,
/// llvm/llvm-project#200984.)
#[inline(never)]
fn find_shape(tables: &[ChainTable], r_um: i32, alpha_u: i32, out: &mut Option<Shape>) {
    for t in tables {
        if let Some(s) = chain_shape(t, r_um, alpha_u) {
            *out = Some(s);
            return;
        }
    }
}

/// Draws (`Op::Draw`) or erases (`Op::Erase`) `images` on `canvas`.
pub fn apply<C: Canvas>(images: &Images, canvas: &mut C, op: Op) -> Flags {
    let mut f = Flags::default();
    if let Some(s) = &images.stripe {
        f.merge(raster::stripe(s, canvas, op));
    }
    // One at a time, not through a local array of them (llvm/llvm-project#200984).
    if let Some(s) = &images.front {
        f.merge(raster::shape(s, canvas, op));
    }
    if let Some(s) = &images.rear {
        f.merge(raster::shape(s, canvas, op));
    }
    f
}

#[cfg(test)]
mod tests;
