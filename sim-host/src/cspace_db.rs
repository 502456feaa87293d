//! Builds the C-space image database (`crates/cspace/src/tables.rs`) from the arm's exact
//! outline in `crates/arm` (thesis ch. IV section 5; docs/cspace.md).
//!
//! For a disk of radius R on the x axis at radius r, with the elbow E at angle theta1, the
//! disk's centre P is at distance rho and bearing beta from E. Link 2's front parts reach it
//! for theta2 within delta(rho) of beta, its rear parts within delta(rho) of beta + pi; link 1
//! reaches it for theta1 within w(r) of 0. delta and w are found from the outline's exact
//! distance function (scan and bisection; the scan also checks that the reaching directions
//! form one interval, which the stored form relies on).
//!
//! The stored images are chains of [`cspace::db::CHAIN`] vertices sampled on the exact upper
//! chain. Then, for every bracket of radii, the images that `crates/cspace` itself
//! interpolates (the same integer code the boards run) are compared with the exact images at
//! radii through the bracket, and every vertex (and half-width) that falls short is grown
//! until none does.

use arm::geometry::{type_distance_m, ImageType, Part, L1_M, OUTLINE};
use cspace::db::{ChainSample, ChainTable, StripeSample, CHAIN};
use std::f64::consts::{PI, TAU};
use std::fmt::Write as _;

/// Disk radii the families are built for, millimetres: a 2 mm pin (the thesis's point
/// obstacles), quarter-inch steps to the thesis's 2-inch obstacles (25.4 mm + the polar
/// margin) and on to 51 mm, halved between 13 and 38.5 mm (16.25, 22.75, 29.25, 32.5,
/// 35.5 and 45 since 2026-11-27: the C-space boards grow every obstacle by the sensing
/// board's 3 mm tolerance, and without them a disk is drawn up to 6.5 mm larger again, a
/// 2-inch one up to 12.5), two larger ones that cover swept (moving) obstacles, and three
/// for the disks that cover a reading beyond the calibrated square with its fold
/// (`cspace::worklist::folded`: up to 150 mm for the campaign's 35 mm disks, swept).
pub const FAMILY_RADII_MM: [f64; 17] = [
    1.0, 6.5, 13.0, 16.25, 19.5, 22.75, 26.0, 29.25, 32.5, 35.5, 38.5, 45.0, 51.0, 76.5, 102.0,
    153.0, 204.0,
];
/// Where the generated tables live, from the workspace root.
pub const TABLES_PATH: &str = "crates/cspace/src/tables.rs";
/// Spacing of the stored radii, metres.
pub const SPACING_M: f64 = 0.008;
/// Radii at which each bracket is checked (besides its ends).
const CHECK_RADII: usize = 8;
/// theta1 samples per checked image.
const CHECK_THETA: usize = 256;

/// Units per radian.
const U_PER_RAD: f64 = cspace::UNITS_PER_REV as f64 / TAU;

/// The exact images of one obstacle type for disks of radius `disk_m`.
#[derive(Clone, Copy, Debug)]
pub struct Exact {
    /// The obstacle type.
    pub ty: ImageType,
    /// Disk radius, metres.
    pub disk_m: f64,
}

impl Exact {
    fn axis(&self) -> f64 {
        if self.ty == ImageType::Link2Rear {
            PI
        } else {
            0.0
        }
    }

    fn touches(&self, rho: f64, phi: f64) -> bool {
        let a = self.axis() + phi;
        type_distance_m(self.ty, rho * a.cos(), rho * a.sin()) <= self.disk_m
    }

    /// Half-width of the reaching directions around the type's axis for a disk centre at
    /// distance `rho` from the joint: `None` if none reach it, `PI` if all do. The directions
    /// need not form one interval (a rectangle's corner can reach further out than its end on
    /// the axis): this is the outermost reaching direction, so [-delta, delta] about the axis
    /// holds them all. Closed form per part (see [`touch_range`]).
    pub fn half_width(&self, rho: f64) -> Option<f64> {
        let mut best: Option<f64> = None;
        for (body, part) in OUTLINE {
            if ImageType::of(body, &part) != self.ty {
                continue;
            }
            if let Some((lo, hi)) = touch_range(&part, self.disk_m, rho) {
                let d = if self.ty == ImageType::Link2Rear {
                    PI - lo
                } else {
                    hi
                };
                best = Some(best.map_or(d, |b: f64| b.max(d)));
            }
        }
        best
    }

    /// Checks [`Exact::half_width`] against a dense scan of the exact distance function for
    /// distances up to `rho_max`: every reaching direction lies within it. Panics otherwise.
    pub fn check_half_width(&self, rho_max: f64) {
        for i in 0..=400 {
            let rho = rho_max * i as f64 / 400.0;
            let d = self.half_width(rho);
            for j in 0..=2000 {
                let phi = PI * j as f64 / 2000.0;
                if self.touches(rho, phi) {
                    assert!(
                        d.is_some_and(|d| phi <= d + 1e-9),
                        "{:?}: a direction at rho {rho}, phi {phi} reaches beyond {d:?}",
                        self.ty
                    );
                }
            }
        }
    }

    /// The furthest distance from the joint at which the type reaches a disk: the furthest
    /// point of its parts plus the disk's radius.
    pub fn reach(&self) -> f64 {
        let mut far: f64 = 0.0;
        for (body, part) in OUTLINE {
            if ImageType::of(body, &part) != self.ty {
                continue;
            }
            far = far.max(match part {
                Part::Disk { s_m, r_m } => s_m.abs() + r_m,
                Part::Rect {
                    s0_m,
                    s1_m,
                    half_width_m,
                } => s0_m.abs().max(s1_m.abs()).hypot(half_width_m),
            });
        }
        far + self.disk_m
    }

    /// Half the theta1 extent of the link-2 image of a disk at radius `r` (`PI`: all the way
    /// round; `None`: no image).
    pub fn half1(&self, r: f64) -> Option<f64> {
        let reach = self.reach();
        let c = (r * r + L1_M * L1_M - reach * reach) / (2.0 * r * L1_M);
        if c > 1.0 {
            None
        } else if c <= -1.0 {
            Some(PI)
        } else {
            Some(c.acos())
        }
    }

    /// The exact upper chain of the link-2 image at theta1 for a disk at radius `r` (inside
    /// or outside the elbow's circle by `inner`): theta2 in radians, unwrapped.
    pub fn upper(&self, r: f64, inner: bool, theta1: f64) -> Option<f64> {
        let (dx, dy) = (r - L1_M * theta1.cos(), -L1_M * theta1.sin());
        let rho = dx.hypot(dy);
        let mut beta = dy.atan2(dx);
        if inner && beta < 0.0 {
            beta += TAU;
        }
        self.half_width(rho).map(|d| beta + self.axis() + d)
    }

    /// theta2 of the centre of odd symmetry.
    pub fn center2(&self, inner: bool) -> f64 {
        (if inner { PI } else { 0.0 }) + self.axis()
    }
}

fn units(rad: f64) -> i32 {
    (rad * U_PER_RAD).ceil() as i32
}

fn radii(from: f64, to: f64) -> Vec<f64> {
    let n = ((to - from) / SPACING_M).ceil().max(1.0) as usize;
    (0..=n)
        .map(|i| from + (to - from) * i as f64 / n as f64)
        .collect()
}

fn um(m: f64) -> i32 {
    (m * 1e6).round() as i32
}

/// The exact chain sample of a disk at `r` (evaluated at `r_eval`, the side of the elbow's
/// circle the table is for).
fn sample(e: &Exact, r: f64, r_eval: f64, inner: bool) -> ChainSample {
    let half = e.half1(r_eval).unwrap_or(0.0);
    let mut upper = [0i32; CHAIN];
    for (k, u) in upper.iter_mut().enumerate() {
        let t = half * cspace::db::FRACTION_Q15[k] as f64 / 32768.0;
        *u = units(e.upper(r_eval, inner, t).unwrap_or(e.center2(inner)));
    }
    ChainSample {
        r_um: um(r),
        half1_u: units(half).min(cspace::HALF_REV),
        upper_u: upper,
    }
}

/// Nudges `r` off the elbow's circle to the table's side (the bearing is undefined on it).
fn off_elbow(r: f64, inner: bool) -> f64 {
    let eps = 1e-7;
    if inner {
        r.min(L1_M - eps)
    } else {
        r.max(L1_M + eps)
    }
}

/// Builds and grows one link-2 table from `from` to `to` metres.
pub fn chain_table(e: &Exact, from: f64, to: f64, inner: bool) -> (ChainTable, u32) {
    let rs = radii(from, to);
    let mut samples: Vec<ChainSample> = rs
        .iter()
        .map(|&r| sample(e, r, off_elbow(r, inner), inner))
        .collect();
    let center2_u = (e.center2(inner) * U_PER_RAD).round() as i32;
    let mut grown = 0u32;
    loop {
        let table = ChainTable {
            center2_u,
            samples: Box::leak(samples.clone().into_boxed_slice()),
        };
        let mut changed = false;
        for i in 0..samples.len() - 1 {
            // The largest shortfall per segment (and in theta1 extent) over the bracket.
            let mut short_k = [0i32; CHAIN - 1];
            let mut short_half = 0i32;
            for j in 0..=CHECK_RADII + 1 {
                let r_um = samples[i].r_um
                    + ((samples[i + 1].r_um - samples[i].r_um) as i64 * j as i64
                        / (CHECK_RADII as i64 + 1)) as i32;
                let r = off_elbow(r_um as f64 * 1e-6, inner);
                let Some(half) = e.half1(r) else { continue };
                let shape = cspace::chain_shape(&table, r_um, 0).expect("radius in the table");
                let need = units(half).min(cspace::HALF_REV);
                let have = shape.theta1_u[CHAIN - 1];
                short_half = short_half.max(need - have);
                for m in 0..=CHECK_THETA {
                    let t = -half + 2.0 * half * m as f64 / CHECK_THETA as f64;
                    let Some(hi) = e.upper(r, inner, t) else {
                        continue;
                    };
                    let tu = (t * U_PER_RAD)
                        .clamp(shape.theta1_u[0] as f64, shape.theta1_u[CHAIN - 1] as f64);
                    let k = (0..CHAIN - 1)
                        .find(|&k| tu <= shape.theta1_u[k + 1] as f64)
                        .unwrap_or(CHAIN - 2);
                    let (ta, tb) = (shape.theta1_u[k] as f64, shape.theta1_u[k + 1] as f64);
                    let (va, vb) = (shape.upper_u[k] as f64, shape.upper_u[k + 1] as f64);
                    let poly = if tb > ta {
                        va + (vb - va) * ((tu - ta) / (tb - ta)).clamp(0.0, 1.0)
                    } else {
                        va.max(vb)
                    };
                    let short = hi * U_PER_RAD - poly;
                    if short > 0.0 {
                        short_k[k] = short_k[k].max(short.ceil() as i32 + 1);
                    }
                }
            }
            if short_half > 0 {
                for s in [i, i + 1] {
                    samples[s].half1_u =
                        (samples[s].half1_u + short_half + 1).min(cspace::HALF_REV);
                }
                changed = true;
                continue;
            }
            for (k, &d) in short_k.iter().enumerate() {
                if d > 0 {
                    for s in [i, i + 1] {
                        samples[s].upper_u[k] += d;
                        samples[s].upper_u[k + 1] += d;
                    }
                    changed = true;
                    grown += 1;
                }
            }
        }
        if !changed {
            for w in samples.windows(2) {
                assert!(
                    w[1].r_um - w[0].r_um < 32768,
                    "radius spacing fits the Q16 lerp"
                );
                for k in 0..CHAIN {
                    assert!((w[1].upper_u[k] - w[0].upper_u[k]).abs() < 32768);
                }
            }
            return (table, grown);
        }
    }
}

/// The exact half-width of the link-1 stripe for a disk at radius `r`.
pub fn stripe_exact(disk_m: f64, r: f64) -> Option<f64> {
    Exact {
        ty: ImageType::Link1,
        disk_m,
    }
    .half_width(r)
}

/// Builds and grows the link-1 stripe table.
pub fn stripe_table(disk_m: f64, from: f64, to: f64) -> Vec<StripeSample> {
    let mut s: Vec<StripeSample> = radii(from, to)
        .iter()
        .map(|&r| StripeSample {
            r_um: um(r),
            half1_u: units(stripe_exact(disk_m, r).unwrap_or(0.0)).min(cspace::HALF_REV),
        })
        .collect();
    loop {
        let mut changed = false;
        for i in 0..s.len() - 1 {
            for j in 0..=4 * CHECK_RADII {
                let r_um =
                    s[i].r_um + (s[i + 1].r_um - s[i].r_um) * j as i32 / (4 * CHECK_RADII as i32);
                let Some(w) = stripe_exact(disk_m, r_um as f64 * 1e-6) else {
                    continue;
                };
                let have = cspace::stripe_half(&s, r_um).expect("in the table");
                let need = units(w).min(cspace::HALF_REV);
                if have < need {
                    let d = need - have + 1;
                    s[i].half1_u = (s[i].half1_u + d).min(cspace::HALF_REV);
                    s[i + 1].half1_u = (s[i + 1].half1_u + d).min(cspace::HALF_REV);
                    changed = true;
                }
            }
        }
        if !changed {
            return s;
        }
    }
}

/// One generated family, with how many vertex growths its check needed.
pub struct Built {
    /// Disk radius, metres.
    pub disk_m: f64,
    /// Centre radius within which the shoulder hub is touched (everything collides).
    pub full_within_m: f64,
    /// Link-1 stripes.
    pub stripe: Vec<StripeSample>,
    /// Link-2 front tables (inner, outer).
    pub front: Vec<ChainTable>,
    /// Link-2 rear tables (inner, outer).
    pub rear: Vec<ChainTable>,
    /// Vertex growths the enclosure check made.
    pub grown: u32,
}

/// Builds the family for disks of radius `disk_m`.
pub fn family(disk_m: f64) -> Built {
    let hub = Exact {
        ty: ImageType::Ground,
        disk_m,
    }
    .reach();
    let mut grown = 0;
    let mut two = |ty: ImageType| {
        let e = Exact { ty, disk_m };
        let reach = e.reach();
        e.check_half_width(reach);
        let lo = (L1_M - reach).max(hub);
        let mut v = Vec::new();
        if lo < L1_M {
            let (t, g) = chain_table(&e, lo, L1_M, true);
            grown += g;
            v.push(t);
        }
        let (t, g) = chain_table(&e, L1_M, L1_M + reach, false);
        grown += g;
        v.push(t);
        v
    };
    let front = two(ImageType::Link2Front);
    let rear = two(ImageType::Link2Rear);
    let l1 = Exact {
        ty: ImageType::Link1,
        disk_m,
    };
    l1.check_half_width(l1.reach());
    let stripe = stripe_table(disk_m, hub, l1.reach());
    Built {
        disk_m,
        full_within_m: hub,
        stripe,
        front,
        rear,
        grown,
    }
}

/// All families, built in parallel on the host's cores.
pub fn build() -> Vec<Built> {
    std::thread::scope(|s| {
        let hs: Vec<_> = FAMILY_RADII_MM
            .iter()
            .map(|&mm| s.spawn(move || family(mm * 1e-3)))
            .collect();
        hs.into_iter()
            .map(|h| h.join().expect("generator thread"))
            .collect()
    })
}

/// The text of `crates/cspace/src/tables.rs` for `families`.
pub fn render(families: &[Built]) -> String {
    let mut o = String::new();
    o.push_str("//! Generated by `cargo run -p sim-host -- cspace-db --write` from `crates/arm`'s outline; do not edit.\n");
    o.push_str("//! A test fails when this file is not what the generator writes.\n");
    o.push_str("use crate::db::{ChainSample, ChainTable, Family, StripeSample};\n\n");
    for (fi, f) in families.iter().enumerate() {
        let _ = writeln!(
            o,
            "static STRIPE_{fi}: [StripeSample; {}] = [",
            f.stripe.len()
        );
        for s in &f.stripe {
            let _ = writeln!(
                o,
                "    StripeSample {{ r_um: {}, half1_u: {} }},",
                s.r_um, s.half1_u
            );
        }
        o.push_str("];\n");
        for (name, tables) in [("FRONT", &f.front), ("REAR", &f.rear)] {
            for (ti, t) in tables.iter().enumerate() {
                let _ = writeln!(
                    o,
                    "static {name}_{fi}_{ti}: [ChainSample; {}] = [",
                    t.samples.len()
                );
                for s in t.samples {
                    let _ = writeln!(
                        o,
                        "    ChainSample {{ r_um: {}, half1_u: {}, upper_u: {:?} }},",
                        s.r_um, s.half1_u, s.upper_u
                    );
                }
                o.push_str("];\n");
            }
            let _ = write!(o, "static {name}_{fi}: [ChainTable; {}] = [", tables.len());
            for (ti, t) in tables.iter().enumerate() {
                let _ = write!(
                    o,
                    "ChainTable {{ center2_u: {}, samples: &{name}_{fi}_{ti} }}, ",
                    t.center2_u
                );
            }
            o.push_str("];\n");
        }
    }
    o.push_str("\n/// The database families, by increasing disk radius.\npub static FAMILIES: &[Family] = &[\n");
    for (fi, f) in families.iter().enumerate() {
        let _ = writeln!(
            o,
            "    Family {{ disk_r_um: {}, full_within_um: {}, stripe: &STRIPE_{fi}, front: &FRONT_{fi}, rear: &REAR_{fi} }},",
            um(f.disk_m),
            (f.full_within_m * 1e6).ceil() as i32,
        );
    }
    o.push_str("];\n");
    o
}

/// The directions phi in [0, pi] (from the link's axis) in which a point at distance `rho`
/// from the joint lies within `grow` of `part`: the smallest and largest, or `None`.
///
/// A disk part grown by `grow` is a disk; a rectangle grown by `grow` is the union of the
/// rectangle lengthened by `grow`, the rectangle widened by `grow`, and disks of radius
/// `grow` on its four corners. For a disk at distance c and angle gamma from the joint with
/// radius e, the circle of radius rho meets it where cos(phi - gamma) >= (rho^2 + c^2 - e^2) /
/// (2 rho c); for a rectangle [a, b] x [-h, h] where rho |sin phi| <= h and a <= rho cos phi <= b.
pub fn touch_range(part: &Part, grow: f64, rho: f64) -> Option<(f64, f64)> {
    let mut spans: Vec<(f64, f64)> = Vec::new();
    match *part {
        Part::Disk { s_m, r_m } => disk_span(s_m, 0.0, r_m + grow, rho, &mut spans),
        Part::Rect {
            s0_m,
            s1_m,
            half_width_m,
        } => {
            for (cx, cy) in [
                (s0_m, half_width_m),
                (s0_m, -half_width_m),
                (s1_m, half_width_m),
                (s1_m, -half_width_m),
            ] {
                disk_span(cx, cy, grow, rho, &mut spans);
            }
            rect_span(s0_m - grow, s1_m + grow, half_width_m, rho, &mut spans);
            rect_span(s0_m, s1_m, half_width_m + grow, rho, &mut spans);
        }
    }
    let mut acc: Option<(f64, f64)> = None;
    for (lo, hi) in spans {
        let (lo, hi) = (lo.max(0.0), hi.min(PI));
        if lo <= hi {
            acc = Some(acc.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
        }
    }
    acc
}

/// Directions in which the circle of radius `rho` meets the disk at (`cx`, `cy`), radius `e`.
fn disk_span(cx: f64, cy: f64, e: f64, rho: f64, out: &mut Vec<(f64, f64)>) {
    let c = cx.hypot(cy);
    if c < 1e-12 || rho < 1e-12 {
        if (c - rho).abs() <= e {
            out.push((0.0, PI));
        }
        return;
    }
    let k = (rho * rho + c * c - e * e) / (2.0 * rho * c);
    // Tangent circles (rho = c + e) can round to k just above 1: they still meet, in one
    // direction (the dense check in `check_half_width` finds that direction touching; it
    // stopped the generator at 32.5 and 45 mm disks).
    if k > 1.0 + 1e-9 {
        return;
    }
    let k = k.min(1.0);
    if k <= -1.0 {
        out.push((0.0, PI));
        return;
    }
    let (g, a) = (cy.atan2(cx), k.acos());
    for shift in [-TAU, 0.0, TAU] {
        out.push((g - a + shift, g + a + shift));
    }
}

/// Directions in [0, pi] in which the circle of radius `rho` lies in [a, b] x [-h, h].
fn rect_span(a: f64, b: f64, h: f64, rho: f64, out: &mut Vec<(f64, f64)>) {
    if rho < 1e-12 {
        if a <= 0.0 && 0.0 <= b {
            out.push((0.0, PI));
        }
        return;
    }
    let (cmax, cmin) = ((b / rho).min(1.0), (a / rho).max(-1.0));
    if cmax < cmin {
        return;
    }
    // cos phi in [a/rho, b/rho]: phi in [acos(b/rho), acos(a/rho)].
    let (p0, p1) = (cmax.acos(), cmin.acos());
    if h >= rho {
        out.push((p0, p1));
    } else {
        let ps = (h / rho).asin();
        out.push((p0, p1.min(ps)));
        out.push((p0.max(PI - ps), p1));
    }
}
