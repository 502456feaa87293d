//! The arm's outline in the plane and its exact clearance to disk obstacles (thesis ch. II
//! fig. II.3 and the region radii of ch. IV, lines 1036-1042).
//!
//! Angles are absolute (referenced to ground, thesis ch. II): link 1 points along `theta1`
//! from the shoulder at the origin, link 2 along `theta2` from the elbow. The outline is a
//! union of rectangles and disks fixed in a link's frame (`s` along the link, `t` across):
//!
//! | part | shape | extent |
//! |---|---|---|
//! | shoulder hub | disk about the shoulder | r = 3.8 cm (region I: every configuration) |
//! | link 1 body | rectangle | s = 0..27.5 cm, 3.8 cm wide |
//! | link 2 front | rectangle | s = 0..25 cm from the elbow, 1.9 cm tube |
//! | link 2 tip | disk | centre 25 cm from the elbow, r = 1.5 cm (reach 51.5 cm) |
//! | link 2 tail | rectangle | s = -13..0 cm, 1.9 cm tube |
//! | counterweight | disk | centre -11.75 cm, r = 1.25 cm (tail reach 13 cm: 12-38 cm band) |
//!
//! The C-space issue derives the exact outline used for the transforms from this one; the
//! simulator's collision oracle uses this one, exactly.

/// Shoulder-to-elbow length.
pub const L1_M: f64 = 0.25;
/// Elbow-to-tip-centre length.
pub const L2_M: f64 = 0.25;

/// One part of the outline, in its link's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Part {
    /// A disk centred at `s_m` along the link.
    Disk {
        /// Centre along the link from the link's joint.
        s_m: f64,
        /// Radius.
        r_m: f64,
    },
    /// A rectangle from `s0_m` to `s1_m` along the link, `half_width_m` either side.
    Rect {
        /// Start along the link.
        s0_m: f64,
        /// End along the link.
        s1_m: f64,
        /// Half the width across the link.
        half_width_m: f64,
    },
}

/// Which body a part belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(usize)]
pub enum Body {
    /// Fixed to ground at the shoulder.
    Ground,
    /// Link 1 (frame at the shoulder, along theta1).
    Link1,
    /// Link 2 (frame at the elbow, along theta2).
    Link2,
}

/// The arm's outline.
pub const OUTLINE: [(Body, Part); 6] = [
    (
        Body::Ground,
        Part::Disk {
            s_m: 0.0,
            r_m: 0.038,
        },
    ),
    (
        Body::Link1,
        Part::Rect {
            s0_m: 0.0,
            s1_m: 0.275,
            half_width_m: 0.019,
        },
    ),
    (
        Body::Link2,
        Part::Rect {
            s0_m: 0.0,
            s1_m: L2_M,
            half_width_m: 0.0095,
        },
    ),
    (
        Body::Link2,
        Part::Disk {
            s_m: L2_M,
            r_m: 0.015,
        },
    ),
    (
        Body::Link2,
        Part::Rect {
            s0_m: -0.13,
            s1_m: 0.0,
            half_width_m: 0.0095,
        },
    ),
    (
        Body::Link2,
        Part::Disk {
            s_m: -0.1175,
            r_m: 0.0125,
        },
    ),
];

impl Part {
    /// Distance from the point (`along_m`, `across_m`), given in the part's link frame, to
    /// the part (0 inside it).
    pub fn distance_m(&self, along_m: f64, across_m: f64) -> f64 {
        match *self {
            Part::Disk { s_m, r_m } => (libm::hypot(along_m - s_m, across_m) - r_m).max(0.0),
            Part::Rect {
                s0_m,
                s1_m,
                half_width_m,
            } => {
                let ds = if along_m < s0_m {
                    s0_m - along_m
                } else if along_m > s1_m {
                    along_m - s1_m
                } else {
                    0.0
                };
                let dt = (libm::fabs(across_m) - half_width_m).max(0.0);
                libm::hypot(ds, dt)
            }
        }
    }

    /// Where the part starts along its link (its smallest `s`).
    pub fn s_min_m(&self) -> f64 {
        match *self {
            Part::Disk { s_m, r_m } => s_m - r_m,
            Part::Rect { s0_m, .. } => s0_m,
        }
    }
}

/// The C-space obstacle type a part of the outline makes (thesis ch. IV section 3, fig. IV.7).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageType {
    /// The shoulder hub: a disk touching it collides in every configuration (region I).
    Ground,
    /// Link 1: a stripe of theta1, whatever theta2 (regions I-III).
    Link1,
    /// Link 2 in front of the elbow, tip included (regions I-V).
    Link2Front,
    /// Link 2's tail behind the elbow with the counterweight (regions III-IV).
    Link2Rear,
}

impl ImageType {
    /// The type of `part` of `body`: link 2's parts split at the elbow.
    pub fn of(body: Body, part: &Part) -> Self {
        match body {
            Body::Ground => ImageType::Ground,
            Body::Link1 => ImageType::Link1,
            Body::Link2 if part.s_min_m() >= 0.0 => ImageType::Link2Front,
            Body::Link2 => ImageType::Link2Rear,
        }
    }
}

/// Distance from a point at (`along_m`, `across_m`) in the frame of the body that parts of
/// type `ty` belong to, to the nearest of those parts (infinite if there are none).
pub fn type_distance_m(ty: ImageType, along_m: f64, across_m: f64) -> f64 {
    let mut best = f64::INFINITY;
    for (body, part) in OUTLINE {
        if ImageType::of(body, &part) == ty {
            best = best.min(part.distance_m(along_m, across_m));
        }
    }
    best
}

/// A disk obstacle in the plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disk {
    /// Centre x.
    pub x_m: f64,
    /// Centre y.
    pub y_m: f64,
    /// Radius.
    pub r_m: f64,
}

/// Where the elbow is.
pub fn elbow(theta1_rad: f64) -> (f64, f64) {
    (L1_M * libm::cos(theta1_rad), L1_M * libm::sin(theta1_rad))
}

/// Where the tip centre is.
pub fn tip(theta1_rad: f64, theta2_rad: f64) -> (f64, f64) {
    let (ex, ey) = elbow(theta1_rad);
    (
        ex + L2_M * libm::cos(theta2_rad),
        ey + L2_M * libm::sin(theta2_rad),
    )
}

/// A frame in the plane: origin and direction cosines.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Frame {
    ox: f64,
    oy: f64,
    c: f64,
    s: f64,
}

impl Frame {
    /// Distance from `(px, py)` to `part` in this frame (0 inside).
    fn distance(&self, part: Part, px: f64, py: f64) -> f64 {
        let (dx, dy) = (px - self.ox, py - self.oy);
        part.distance_m(dx * self.c + dy * self.s, -dx * self.s + dy * self.c)
    }
}

/// The arm in one configuration, with its trigonometry done once, for checking many
/// obstacles (the simulator checks every obstacle at every plant step).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    frames: [Frame; 3],
}

impl Pose {
    /// The arm at absolute angles (`theta1_rad`, `theta2_rad`).
    pub fn new(theta1_rad: f64, theta2_rad: f64) -> Self {
        let (s1, c1) = (libm::sin(theta1_rad), libm::cos(theta1_rad));
        let (s2, c2) = (libm::sin(theta2_rad), libm::cos(theta2_rad));
        let (ex, ey) = (L1_M * c1, L1_M * s1);
        Self {
            frames: [
                Frame {
                    ox: 0.0,
                    oy: 0.0,
                    c: 1.0,
                    s: 0.0,
                },
                Frame {
                    ox: 0.0,
                    oy: 0.0,
                    c: c1,
                    s: s1,
                },
                Frame {
                    ox: ex,
                    oy: ey,
                    c: c2,
                    s: s2,
                },
            ],
        }
    }

    /// Clearance to `disk`: distance to the nearest part of the outline minus the disk's
    /// radius; zero or negative when they touch or overlap (a collision). It bottoms out at
    /// minus the radius once the disk's centre is inside the outline.
    pub fn clearance_m(&self, disk: &Disk) -> f64 {
        let mut best = f64::INFINITY;
        for (body, part) in OUTLINE {
            let f = &self.frames[body as usize];
            let d = f.distance(part, disk.x_m, disk.y_m) - disk.r_m;
            if d < best {
                best = d;
            }
        }
        best
    }
}

/// Clearance between the arm at (`theta1_rad`, `theta2_rad`) and `disk`: the distance
/// between the disk and the nearest part of the outline, negative or zero when they touch
/// or overlap (a collision).
pub fn clearance_m(theta1_rad: f64, theta2_rad: f64, disk: &Disk) -> f64 {
    Pose::new(theta1_rad, theta2_rad).clearance_m(disk)
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn kinematics_in_absolute_angles() {
        let (x, y) = tip(0.0, FRAC_PI_2);
        assert!((x - 0.25).abs() < 1e-12 && (y - 0.25).abs() < 1e-12);
        let (x, y) = tip(PI, PI);
        assert!((x + 0.5).abs() < 1e-12 && y.abs() < 1e-12);
    }

    #[test]
    fn reach_and_regions_match_chapter_iv() {
        // Beyond 51.5 cm nothing can be hit (region VI).
        let far = Disk {
            x_m: 0.516,
            y_m: 0.0,
            r_m: 0.0,
        };
        assert!(clearance_m(0.0, 0.0, &far) > 0.0);
        let edge = Disk {
            x_m: 0.514,
            y_m: 0.0,
            r_m: 0.0,
        };
        assert!(
            clearance_m(0.0, 0.0, &edge) <= 0.0,
            "the tip reaches 51.5 cm"
        );
        // Inside 3.8 cm everything collides (region I), whatever the angles.
        for k in 0..16 {
            let a = k as f64 * PI / 8.0;
            let near = Disk {
                x_m: 0.03 * libm::cos(a + 1.0),
                y_m: 0.03 * libm::sin(a + 1.0),
                r_m: 0.0,
            };
            assert!(clearance_m(a, -a, &near) <= 0.0);
        }
        // The tail reaches 13 cm behind the elbow: 38 cm from the shoulder when straight.
        let tail = Disk {
            x_m: 0.379,
            y_m: 0.0,
            r_m: 0.0,
        };
        assert!(clearance_m(0.0, PI, &tail) <= 0.0);
        assert!(
            clearance_m(
                0.0,
                PI,
                &Disk {
                    x_m: 0.381,
                    y_m: 0.0,
                    r_m: 0.0
                }
            ) > 0.0
        );
    }

    #[test]
    fn clearance_is_exact_for_a_disk_beside_link_2() {
        // Link 2 along +y from the elbow at (0.25, 0): a disk at 10 cm up, 5 cm to the side.
        let d = Disk {
            x_m: 0.30,
            y_m: 0.10,
            r_m: 0.01,
        };
        let c = clearance_m(0.0, FRAC_PI_2, &d);
        assert!((c - (0.05 - 0.0095 - 0.01)).abs() < 1e-12, "{c}");
    }
}
