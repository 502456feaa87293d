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
#[derive(Clone, Debug)]
pub struct SimBench {
    /// Simulated seconds per repetition.
    pub simulated_s: f64,
    /// Wall-clock seconds of each repetition, sorted.
    pub walls_s: Vec<f64>,
    /// Plant steps.
    pub steps: u64,
    /// Board main-loop passes.
    pub polls: u64,
}

impl fmt::Display for SimBench {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "bench sim: five boards native, 6 moving obstacles, moving wand, plant step 50 us, one thread")?;
        let w = &self.walls_s;
        let (best, median, worst) = (w[0], w[w.len() / 2], w[w.len() - 1]);
        let rtf = |wall: f64| self.simulated_s / wall;
        writeln!(
            f,
            "  simulated        {:.1} s per repetition, {} repetitions",
            self.simulated_s,
            w.len()
        )?;
        writeln!(
            f,
            "  wall clock       best {best:.3} s, median {median:.3} s, worst {worst:.3} s"
        )?;
        writeln!(
            f,
            "  plant steps      {} ({:.2} us each at the median, board passes included)",
            self.steps,
            median * 1e6 / self.steps as f64
        )?;
        writeln!(f, "  board passes     {}", self.polls)?;
        write!(
            f,
            "  real-time factor median {:.1}x (best {:.1}x, worst {:.1}x; target >= 50x)",
            rtf(median),
            rtf(best),
            rtf(worst)
        )
    }
}

/// Runs the standard load for `seconds` of simulated time, `reps` times (host machines are
/// noisy: the report gives the spread).
pub fn sim(seconds: f64, reps: usize) -> SimBench {
    let mut walls_s = Vec::new();
    let mut last = None;
    for _ in 0..reps.max(1) {
        let mut s = Sim::new(standard_world(seconds, 1));
        let start = Instant::now();
        while !s.done() {
            s.step();
        }
        walls_s.push(start.elapsed().as_secs_f64());
        last = Some(s);
    }
    walls_s.sort_by(f64::total_cmp);
    let s = last.expect("at least one repetition");
    SimBench {
        simulated_s: s.t_s(),
        walls_s,
        steps: s.steps,
        polls: s.board_stats().iter().map(|b| b.polls).sum(),
    }
}
