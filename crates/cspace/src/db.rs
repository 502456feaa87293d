//! The image database (thesis ch. IV section 5, lines ~1130-1172): per obstacle type, the
//! images of a disk on the positive x axis at a list of radii, interpolated linearly between
//! the two bracketing radii ("vertex interpolation").
//!
//! A link-2 image of a disk on the x axis is, in each theta1 column, one interval of theta2
//! (the directions in which the link reaches the disk), and it is odd-symmetric about its
//! centre (0, `center2_u`). So it is stored as its upper chain only: [`CHAIN`] vertices at
//! theta1 = -half .. +half evenly spaced; the lower chain is the upper one turned by half a
//! revolution about the centre. (The thesis stored 12-vertex polygons as 6 vertices; ours
//! have 2 x [`CHAIN`] and are x-monotone, which makes the raster exact.) A link-1 image is a
//! stripe of theta1, stored as its half-width.
//!
//! The tables (`tables.rs`) are generated from `crates/arm`'s outline by `sim-host cspace-db`,
//! which also checks that every interpolated image encloses the exact image at every radius
//! it is used for, growing vertices where needed; a test fails if the committed tables are
//! not what the generator writes.

/// Vertices of a stored upper chain (odd, so one sits on theta1 = 0).
pub const CHAIN: usize = 33;

/// Where the chain's vertices sit, as fractions of the half-width (Q15): -cos(pi k / 32),
/// the Chebyshev nodes. They crowd toward the image's ends, where the exact chain turns
/// like a square root (link 2 just reaching the disk) and evenly spaced vertices would need
/// large growth to enclose it.
pub const FRACTION_Q15: [i32; CHAIN] = [
    -32768, -32610, -32138, -31357, -30274, -28899, -27246, -25330, -23170, -20788, -18205, -15447,
    -12540, -9512, -6393, -3212, 0, 3212, 6393, 9512, 12540, 15447, 18205, 20788, 23170, 25330,
    27246, 28899, 30274, 31357, 32138, 32610, 32768,
];

/// One stored link-2 image: a disk on the x axis at `r_um`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChainSample {
    /// Radius of the disk's centre, micrometres.
    pub r_um: i32,
    /// Half the theta1 extent, angle units (`HALF_REV` = the image wraps all the way round).
    pub half1_u: i32,
    /// Upper chain, theta2 in angle units at theta1 = half1 x [`FRACTION_Q15`]`[k]`.
    pub upper_u: [i32; CHAIN],
}

/// A run of link-2 images interpolated among themselves (never across a table's ends: the
/// images are continuous only within a table, thesis lines ~1093-1103).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChainTable {
    /// theta2 of the centre of odd symmetry, angle units (0, or half a revolution for a disk
    /// inside the elbow's circle, where link 2 points back at it through theta1 = 0).
    pub center2_u: i32,
    /// The images, by increasing radius.
    pub samples: &'static [ChainSample],
}

/// One stored link-1 stripe.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StripeSample {
    /// Radius of the disk's centre, micrometres.
    pub r_um: i32,
    /// Half the stripe's theta1 width, angle units.
    pub half1_u: i32,
}

/// All images of one disk size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Family {
    /// The largest disk radius (after the polar margin) these images enclose, micrometres.
    pub disk_r_um: i32,
    /// A disk whose centre is within this radius touches the shoulder hub: every
    /// configuration collides (region I).
    pub full_within_um: i32,
    /// Link-1 stripes, by increasing radius (none beyond the last).
    pub stripe: &'static [StripeSample],
    /// Link-2 front images (tip included): inside and outside the elbow's circle.
    pub front: &'static [ChainTable],
    /// Link-2 rear images (tail and counterweight).
    pub rear: &'static [ChainTable],
}

pub use crate::tables::FAMILIES;
