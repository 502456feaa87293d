//! `sim-host bench`: measurements of the simulator itself.

use crate::sim::{Config, Motion, Obstacle, Sim, WandPath};
use arm::geometry::Disk;
use std::fmt;
use std::time::Instant;

/// The standard load: all five boards, five obstacles moving (two on lines, three on
/// circles) plus the instructional robot, and a moving wand.
pub fn standard_world(seconds: f64, seed: u64) -> Config {
    let circle = |x, y, cx, cy, p| Obstacle {
        start: Disk {
            x_m: x,
            y_m: y,
            r_m: 0.025,
        },
        motion: Motion::Circle {
            cx_m: cx,
            cy_m: cy,
            period_s: p,
        },
    };
    Config {
        seed,
        duration_s: seconds,
        obstacles: vec![
            circle(0.35, 0.0, 0.30, 0.0, 7.0),
            circle(-0.30, 0.20, -0.30, 0.25, 5.0),
            circle(0.10, -0.40, 0.15, -0.40, 9.0),
            Obstacle {
                start: Disk {
                    x_m: -0.45,
                    y_m: -0.1,
                    r_m: 0.02,
                },
                motion: Motion::Line {
                    vx_m_s: 0.01,
                    vy_m_s: 0.0,
                },
            },
            Obstacle {
                start: Disk {
                    x_m: 0.0,
                    y_m: 0.45,
                    r_m: 0.03,
                },
                motion: Motion::Line {
                    vx_m_s: 0.0,
                    vy_m_s: -0.005,
                },
            },
            circle(0.20, 0.35, 0.0, 0.0, 30.0),
        ],
        wand: WandPath {
            points: vec![
                (0.0, 0.40, 0.10),
                (seconds / 2.0, 0.10, 0.40),
                (seconds, -0.30, 0.20),
            ],
        },
        ..Default::default()
    }
}

/// The result of `bench sim`.
#[derive(Clone, Copy, Debug)]
pub struct SimBench {
    /// Simulated seconds.
    pub simulated_s: f64,
    /// Wall-clock seconds.
    pub wall_s: f64,
    /// Plant steps.
    pub steps: u64,
    /// Board main-loop passes.
    pub polls: u64,
}

impl fmt::Display for SimBench {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "bench sim: five boards native, 6 moving obstacles, moving wand, plant step 50 us, one thread")?;
        writeln!(f, "  simulated        {:.1} s", self.simulated_s)?;
        writeln!(f, "  wall clock       {:.3} s", self.wall_s)?;
        writeln!(
            f,
            "  plant steps      {} ({:.2} us each, board passes included)",
            self.steps,
            self.wall_s * 1e6 / self.steps as f64
        )?;
        writeln!(f, "  board passes     {}", self.polls)?;
        write!(
            f,
            "  real-time factor {:.1}x (target >= 50x)",
            self.simulated_s / self.wall_s
        )
    }
}

/// Runs the standard load for `seconds` of simulated time.
pub fn sim(seconds: f64) -> SimBench {
    let mut s = Sim::new(standard_world(seconds, 1));
    let start = Instant::now();
    while !s.done() {
        s.step();
    }
    let wall_s = start.elapsed().as_secs_f64();
    SimBench {
        simulated_s: s.t_s(),
        wall_s,
        steps: s.steps,
        polls: s.board_stats().iter().map(|b| b.polls).sum(),
    }
}
