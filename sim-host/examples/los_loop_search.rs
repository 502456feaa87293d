//! The search that found fig. VI.2's scene (`sim-host/scenarios/fig_vi_2_loop.toml`,
//! docs/planner.md): random scenes of one or two disks 0.33-0.45 m from the shoulder (no
//! link-1 stripe), random start and goal poses clear of them, the goal's tip in the
//! calibrated square; each is run with the thesis's leave rule as built and, where that
//! loops (three or more wall-following episodes, goal neither reached nor reported
//! unreachable in 8 s, no contact, a solvable scene), with ours. Scenes where ours reaches
//! the goal with at most two episodes are written as scenario pairs to `OUT`, replayed from
//! their files and printed.
//!
//! `cargo run --release -p sim-host --example los_loop_search -- SEED DRAWS OUT`
use arm::geometry::{tip, Disk, Pose};
use sim_host::planner_campaign::{run_scene, Class, Scene};
use sim_host::scenario::Scenario;
use sim_host::sim::{Config, Motion, Obstacle, Rng, WandPath};
use std::path::PathBuf;

/// The obstacles' polar angles are drawn from +-this (rad): the range the scene in the
/// repository was found with.
const HALF_TURN: f64 = 314.0 / 100.0;

fn main() {
    let mut args = std::env::args().skip(1);
    let usage = "usage: los_loop_search SEED DRAWS OUT";
    let seed: u64 = args.next().and_then(|s| s.parse().ok()).expect(usage);
    let draws: u64 = args.next().and_then(|s| s.parse().ok()).expect(usage);
    let out = PathBuf::from(args.next().expect(usage));
    std::fs::create_dir_all(&out).expect("the output directory");
    let mut rng = Rng::new(seed);
    let (mut ran, mut found) = (0, 0);
    for i in 0..draws {
        let mut u = |lo: f64, hi: f64| lo + (hi - lo) * rng.next_f64();
        let n = if u(0.0, 1.0) < 0.5 { 1 } else { 2 };
        let obstacles: Vec<Disk> = (0..n)
            .map(|_| {
                // The ranges as the search ran (angles to +-3.14).
                let (d, a) = (u(0.33, 0.45), u(-HALF_TURN, HALF_TURN));
                Disk {
                    x_m: d * a.cos(),
                    y_m: d * a.sin(),
                    r_m: u(0.02, 0.045),
                }
            })
            .collect();
        let s = [u(-3.1, 3.1), u(-3.1, 3.1)];
        let t = [u(-3.1, 3.1), u(-3.1, 3.1)];
        let (ps, pt) = (Pose::new(s[0], s[1]), Pose::new(t[0], t[1]));
        if !obstacles
            .iter()
            .all(|o| ps.clearance_m(o) > 0.02 && pt.clearance_m(o) > 0.02)
        {
            continue;
        }
        let (x, y) = tip(t[0], t[1]);
        if x.hypot(y) < 0.06 || x.abs() > 0.33 || y.abs() > 0.33 {
            continue;
        }
        let config = Config {
            seed: 2,
            duration_s: 8.0,
            start_rad: s,
            obstacles: obstacles
                .iter()
                .map(|d| Obstacle {
                    start: *d,
                    motion: Motion::Static,
                })
                .collect(),
            wand: WandPath {
                points: vec![(0.0, x, y)],
            },
            ..Config::default()
        };
        // Both runs from the scenario text, as `sim-host run` replays them.
        let ours = sim_host::campaign::scenario_text_titled("fig. VI.2 candidate", &config);
        let thesis = format!("{ours}\n[planner]\nleave = \"line_of_sight\"\n");
        let path = out.join(format!("seed{seed}-draw{i}.toml"));
        let run = |text: &str| {
            let sc = Scenario::parse(&path, text).expect("a valid scenario");
            run_scene(
                &Scene {
                    index: i,
                    config: sc.config,
                },
                None,
            )
        };
        ran += 1;
        let a = run(&thesis);
        let loops = a.class == Class::Solvable
            && a.walls >= 3
            && a.goal_time_s.is_none()
            && a.unreachable.is_none()
            && a.collisions == 0;
        if !loops {
            continue;
        }
        let b = run(&ours);
        if b.walls > 2 || b.goal_time_s.is_none() || b.collisions > 0 {
            continue;
        }
        found += 1;
        std::fs::write(&path, &ours).expect("writable");
        std::fs::write(out.join(format!("seed{seed}-draw{i}-los.toml")), &thesis)
            .expect("writable");
        println!(
            "draw {i}: thesis's rule {} wall episodes, goal not reached; ours {} episodes, goal in {:.2} s: {}",
            a.walls,
            b.walls,
            b.goal_time_s.unwrap_or(0.0),
            path.display()
        );
    }
    println!("{found} of {ran} scenes run ({draws} draws)");
}
