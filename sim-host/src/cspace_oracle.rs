//! The exact oracle for the C-space map (issue: conservative by construction, and proven
//! so): for a disk and a pixel, does the pixel hold a configuration in which the arm's exact
//! outline (`crates/arm`) touches the disk?
//!
//! Branch and bound on the pixel's square of (theta1, theta2): the clearance at a point is
//! exact; over a square of half-size h it cannot fall by more than 0.52 m x h, since no point
//! of link 1 is further than 0.276 m from the shoulder and no point of link 2 further than
//! 0.25 m + 0.265 m (elbow plus link 2's reach) from it in absolute angles. A square whose
//! centre clears the disk by more than that is free; a point at or below zero clearance is a
//! collision; otherwise the square is split, down to 1/64 of a pixel (then "unknown").

use arm::geometry::{Disk as ArmDisk, Pose};
use cspace::{Disk, Memory, Op};
use std::f64::consts::TAU;

/// Bound on how fast the clearance changes with the angles, metres per radian (see module).
pub const LIPSCHITZ_M_PER_RAD: f64 = 0.52;
/// Pixel size, radians.
pub const PIXEL_RAD: f64 = TAU / 128.0;
const MAX_DEPTH: u32 = 6;

/// What a pixel holds for one disk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Some configuration in the pixel touches the disk.
    Collides,
    /// No configuration in the pixel touches it (proven).
    Free,
    /// Undecided at the finest split.
    Unknown,
}

/// The arm at every pixel centre, computed once (the trigonometry dominates the oracle).
fn centre_poses() -> &'static [Pose] {
    static P: std::sync::OnceLock<Vec<Pose>> = std::sync::OnceLock::new();
    P.get_or_init(|| {
        (0..128 * 128)
            .map(|i| {
                let (i1, i2) = (i % 128, i / 128);
                Pose::new((i1 as f64 + 0.5) * PIXEL_RAD, (i2 as f64 + 0.5) * PIXEL_RAD)
            })
            .collect()
    })
}

fn square(d: &ArmDisk, t1: f64, t2: f64, h: f64, depth: u32) -> Verdict {
    square_at(d, Pose::new(t1, t2), t1, t2, h, depth)
}

fn square_at(d: &ArmDisk, pose: Pose, t1: f64, t2: f64, h: f64, depth: u32) -> Verdict {
    let c = pose.clearance_m(d);
    if c <= 0.0 {
        return Verdict::Collides;
    }
    if c > LIPSCHITZ_M_PER_RAD * h {
        return Verdict::Free;
    }
    if depth == MAX_DEPTH {
        return Verdict::Unknown;
    }
    let q = h / 2.0;
    let mut all_free = true;
    for (a, b) in [(-q, -q), (q, -q), (-q, q), (q, q)] {
        match square(d, t1 + a, t2 + b, q, depth + 1) {
            Verdict::Collides => return Verdict::Collides,
            Verdict::Unknown => all_free = false,
            Verdict::Free => {}
        }
    }
    if all_free {
        Verdict::Free
    } else {
        Verdict::Unknown
    }
}

/// The verdict for pixel (`i1`, `i2`) and `disk`.
pub fn pixel(disk: &Disk, i1: u32, i2: u32) -> Verdict {
    let d = ArmDisk {
        x_m: disk.x_um as f64 * 1e-6,
        y_m: disk.y_um as f64 * 1e-6,
        r_m: disk.r_um as f64 * 1e-6,
    };
    let t1 = (i1 as f64 + 0.5) * PIXEL_RAD;
    let t2 = (i2 as f64 + 0.5) * PIXEL_RAD;
    let pose = centre_poses()[(i2 * 128 + i1) as usize];
    square_at(&d, pose, t1, t2, PIXEL_RAD / 2.0, 0)
}

/// One disk checked against the oracle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Check {
    /// Pixels that hold a collision but are free in the map (must be 0).
    pub false_free: u32,
    /// Pixels marked in the map that the oracle proves free.
    pub false_occupied: u32,
    /// Pixels that hold a collision (the exact image, in pixels).
    pub exact: u32,
    /// Pixels the oracle could not decide.
    pub unknown: u32,
}

impl Check {
    /// Adds another disk's counts.
    pub fn add(&mut self, o: &Check) {
        self.false_free += o.false_free;
        self.false_occupied += o.false_occupied;
        self.exact += o.exact;
        self.unknown += o.unknown;
    }
}

/// Draws `disk` alone on a clear map, checks every pixel against the oracle, then erases it
/// and requires the map clear again.
pub fn check_disk(disk: &Disk) -> Result<Check, cspace::Error> {
    let im = cspace::images(disk)?;
    let mut m = Memory::default();
    let f = cspace::apply(&im, &mut m.canvas(), Op::Draw);
    assert_eq!(f, cspace::Flags::default(), "one disk cannot saturate");
    let mut c = Check::default();
    for i2 in 0..128 {
        for i1 in 0..128 {
            let v = pixel(disk, i1, i2);
            match (m.occupied(i1, i2), v) {
                (false, Verdict::Collides) => {
                    c.false_free += 1;
                    c.exact += 1
                }
                (true, Verdict::Collides) => c.exact += 1,
                (true, Verdict::Free) => c.false_occupied += 1,
                (_, Verdict::Unknown) => c.unknown += 1,
                (false, Verdict::Free) => {}
            }
        }
    }
    cspace::apply(&im, &mut m.canvas(), Op::Erase);
    assert!(m.is_clear(), "erase leaves the map clear");
    Ok(c)
}

/// The picture cells of `disks` drawn together (see [`crate::plots::cspace_map`]).
pub fn cells(disks: &[Disk]) -> Result<Vec<crate::plots::MapCell>, cspace::Error> {
    use crate::plots::MapCell;
    let mut m = Memory::default();
    for d in disks {
        cspace::apply(&cspace::images(d)?, &mut m.canvas(), Op::Draw);
    }
    let mut v = Vec::with_capacity(128 * 128);
    for i2 in 0..128 {
        for i1 in 0..128 {
            let hit = disks
                .iter()
                .map(|d| pixel(d, i1, i2))
                .fold(Verdict::Free, |a, b| match (a, b) {
                    (Verdict::Collides, _) | (_, Verdict::Collides) => Verdict::Collides,
                    (Verdict::Unknown, _) | (_, Verdict::Unknown) => Verdict::Unknown,
                    _ => Verdict::Free,
                });
            v.push(match (m.occupied(i1, i2), hit) {
                (true, Verdict::Free) => MapCell::FalseOccupied,
                (true, _) => MapCell::Exact,
                (false, Verdict::Collides) => MapCell::FalseFree,
                (false, _) => MapCell::Free,
            });
        }
    }
    Ok(v)
}

/// One figure of `docs/cspace/`: file name, title, disks (x mm, y mm, radius mm).
pub type Figure = (&'static str, &'static str, &'static [(f64, f64, f64)]);

/// The thesis's C-space figures: point obstacles (its 2 mm pin) at 45, 40, 35, 28.5, 20 and
/// 10 cm on the x axis (figs. IV.1-IV.6), 2-inch obstacles at 33 cm and 0 and 45 degrees
/// (fig. IV.9), at 30 cm (fig. IV.10) and at three radii on the x axis (fig. IV.11).
pub const FIGURES: [Figure; 9] = [
    (
        "fig_iv_1_point_45cm.png",
        "Point obstacle at 45 cm (thesis fig. IV.1)",
        &[(450.0, 0.0, 1.0)],
    ),
    (
        "fig_iv_2_point_40cm.png",
        "Point obstacle at 40 cm (thesis fig. IV.2)",
        &[(400.0, 0.0, 1.0)],
    ),
    (
        "fig_iv_3_point_35cm.png",
        "Point obstacle at 35 cm (thesis fig. IV.3)",
        &[(350.0, 0.0, 1.0)],
    ),
    (
        "fig_iv_4_point_28_5cm.png",
        "Point obstacle at 28.5 cm (thesis fig. IV.4)",
        &[(285.0, 0.0, 1.0)],
    ),
    (
        "fig_iv_5_point_20cm.png",
        "Point obstacle at 20 cm (thesis fig. IV.5)",
        &[(200.0, 0.0, 1.0)],
    ),
    (
        "fig_iv_6_point_10cm.png",
        "Point obstacle at 10 cm (thesis fig. IV.6)",
        &[(100.0, 0.0, 1.0)],
    ),
    (
        "fig_iv_9_2in_33cm_0_45deg.png",
        "2-inch obstacles at 33 cm, 0 and 45 degrees (thesis fig. IV.9)",
        &[(330.0, 0.0, 25.4), (233.345, 233.345, 25.4)],
    ),
    (
        "fig_iv_10_2in_30cm.png",
        "2-inch obstacle at 30 cm (thesis fig. IV.10)",
        &[(300.0, 0.0, 25.4)],
    ),
    (
        "fig_iv_11_2in_on_x_axis.png",
        "2-inch obstacles at 35, 40 and 45 cm on the x axis (thesis fig. IV.11)",
        &[(350.0, 0.0, 25.4), (400.0, 0.0, 25.4), (450.0, 0.0, 25.4)],
    ),
];

/// Writes the [`FIGURES`] into `dir`; returns (file, exact pixels, false-occupied pixels).
pub fn figures(dir: &std::path::Path) -> Result<Vec<(String, u32, u32)>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut out = Vec::new();
    for (file, title, ds) in FIGURES {
        let disks: Vec<Disk> = ds
            .iter()
            .map(|&(x, y, r)| Disk {
                x_um: (x * 1e3).round() as i32,
                y_um: (y * 1e3).round() as i32,
                r_um: (r * 1e3).round() as i32,
            })
            .collect();
        let cells = cells(&disks).map_err(|e| format!("{file}: {e:?}"))?;
        crate::plots::cspace_map(&dir.join(file), title, &cells)?;
        use crate::plots::MapCell;
        let n = |k: MapCell| cells.iter().filter(|&&c| c == k).count() as u32;
        out.push((
            file.to_string(),
            n(MapCell::Exact) + n(MapCell::FalseFree),
            n(MapCell::FalseOccupied),
        ));
    }
    Ok(out)
}

/// The largest disk radius the random checks draw: the thesis's 2-inch obstacles.
pub const MAX_RANDOM_R_UM: i32 = 25_400;
/// Centres are drawn uniformly over a disk of this radius: the arm's reach (0.515 m) plus
/// the largest disk, and a little beyond (region VI, no image).
pub const RANDOM_REACH_UM: f64 = 560_000.0;

/// The `i`-th random disk of `seed`: centre uniform over the reach, radius uniform in
/// 0..=[`MAX_RANDOM_R_UM`].
pub fn random_disk(seed: u64, i: u64) -> Disk {
    let mut g = crate::sim::Rng::new(seed ^ i.wrapping_mul(0xA24B_AED4_963E_E407));
    let (a, b, c) = (g.next_f64(), g.next_f64(), g.next_f64());
    let rho = RANDOM_REACH_UM * a.sqrt();
    let phi = std::f64::consts::TAU * b;
    Disk {
        x_um: (rho * phi.cos()).round() as i32,
        y_um: (rho * phi.sin()).round() as i32,
        r_um: (c * MAX_RANDOM_R_UM as f64).round() as i32,
    }
}

/// The result of checking many random disks.
#[derive(Clone, Copy, Debug, Default)]
pub struct Survey {
    /// Disks checked.
    pub disks: u64,
    /// Summed counts.
    pub total: Check,
    /// Disks with at least one false-free pixel.
    pub disks_with_false_free: u64,
    /// The first such disk.
    pub first_false_free: Option<Disk>,
    /// The largest false-occupied / exact ratio of a single disk with an image of at least
    /// 100 pixels, and that disk.
    pub worst_ratio: (f64, Option<Disk>),
}

/// Checks disks `0..n` of `seed` on all the host's cores; `progress` is called with the
/// number done so far.
pub fn survey(seed: u64, n: u64, progress: &(dyn Fn(u64) + Sync)) -> Survey {
    let threads = std::thread::available_parallelism().map_or(1, |p| p.get()) as u64;
    let done = std::sync::atomic::AtomicU64::new(0);
    let parts: Vec<Survey> = std::thread::scope(|s| {
        let hs: Vec<_> = (0..threads)
            .map(|t| {
                let done = &done;
                s.spawn(move || {
                    let mut sv = Survey::default();
                    let mut i = t;
                    while i < n {
                        let d = random_disk(seed, i);
                        let c = check_disk(&d).expect("random disks are within the database");
                        sv.disks += 1;
                        sv.total.add(&c);
                        if c.false_free > 0 {
                            sv.disks_with_false_free += 1;
                            sv.first_false_free.get_or_insert(d);
                        }
                        if c.exact >= 100 {
                            let r = c.false_occupied as f64 / c.exact as f64;
                            if r > sv.worst_ratio.0 {
                                sv.worst_ratio = (r, Some(d));
                            }
                        }
                        let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                        if t == 0 {
                            progress(k);
                        }
                        i += threads;
                    }
                    sv
                })
            })
            .collect();
        hs.into_iter()
            .map(|h| h.join().expect("survey thread"))
            .collect()
    });
    let mut out = Survey::default();
    for p in parts {
        out.disks += p.disks;
        out.total.add(&p.total);
        out.disks_with_false_free += p.disks_with_false_free;
        if out.first_false_free.is_none() {
            out.first_false_free = p.first_false_free;
        }
        if p.worst_ratio.0 > out.worst_ratio.0 {
            out.worst_ratio = p.worst_ratio;
        }
    }
    out
}

/// Draws obstacle disks (x, y, r in millimetres) into the C-space map of global RAM `g` with
/// the C-space boards' own logic: the map the benches and image tests hand the reflex and
/// planner images.
pub fn draw_disks_mm(
    g: &mut dyn vme_map::GlobalBus,
    disks: &[(i32, i32, i32)],
) -> Result<(), cspace::Error> {
    for &(x, y, r) in disks {
        let d = Disk {
            x_um: x * 1000,
            y_um: y * 1000,
            r_um: r * 1000,
        };
        cspace::apply(&cspace::images(&d)?, &mut cspace::BusCanvas(g), Op::Draw);
    }
    Ok(())
}
