//! The planner board (issue 9): its image against the native board pass for pass, the
//! campaign's targets on a fixed seed, and the integrated runs of figs. VI.3-VI.5.

use sim_host::planner_bench;
use sim_host::planner_campaign::{self, Class};
use system_tests::images_dir;
use vme_map::records::{planner_mode, reflex_flags as rf};

/// The image and the native board publish the same planner record after every pass, in
/// free space, while following a wall, with a goal inside an obstacle and with an arm
/// stalled within the planner's clearance of a wall; each case reaches the mode it is about,
/// and the last searches for the way out of the blocked cells (`planner::escape`).
#[test]
fn the_planner_image_matches_the_native_board_pass_for_pass() {
    let want = [
        1 << planner_mode::FREE,
        1 << planner_mode::WALL,
        1 << planner_mode::UNREACHABLE,
        1 << planner_mode::WALL,
    ];
    let cases = planner_bench::cases();
    assert_eq!(cases.len(), want.len());
    for (i, (case, mode)) in cases.iter().zip(want).enumerate() {
        let r = planner_bench::run(&images_dir(), case).unwrap();
        assert_eq!(r.mismatch, None, "{}", case.name);
        assert_ne!(r.modes & mode, 0, "{}: modes {:#x}", case.name, r.modes);
        if i == 3 {
            assert!(r.escapes > 0, "{}: no search for the way out", case.name);
        }
    }
}

/// 750 scenes of the campaign (seed 1; 513 of them solvable, with the disks inside the
/// camera's calibrated square since 2026-11-27: 700 drew 481) with all five boards: no
/// collision, at least 99% of the solvable scenes reached, every unsolvable one reported (or
/// its goal pixel's margin reached), no scene left undecided but the marginal ones.
#[test]
fn the_planner_campaign_reaches_the_solvable_goals_and_reports_the_rest() {
    let (s, results) = planner_campaign::campaign(1, 750, 2, &|| {});
    assert_eq!(s.scenes_with_collisions, 0, "{:?}", s.collision_scenes);
    assert!(s.solvable >= 500, "{} solvable", s.solvable);
    assert!(
        s.solvable_reached as f64 >= 0.99 * s.solvable as f64,
        "{} of {} reached; missed {:?}",
        s.solvable_reached,
        s.solvable,
        s.missed_scenes
    );
    assert!(
        s.unsolvable[0] > 0 && s.unsolvable[1] > 0,
        "{:?}",
        s.unsolvable
    );
    for r in results
        .iter()
        .filter(|r| matches!(r.class, Class::GoalInObstacle | Class::Enclosed))
    {
        assert!(
            r.unreachable.is_some() || r.goal_time_s.is_some(),
            "unsolvable scene {} neither reported nor reached",
            r.index
        );
    }
    assert!(
        s.scenes_with_walls > 10,
        "{} needed the planner",
        s.scenes_with_walls
    );
}

/// What a figure's run did: reflex flags or-ed, planner modes seen, goal reached, contacts.
fn run_figure(file: &str) -> (u32, u32, bool, u64) {
    let (f, m, reached, hits, _) = run_figure_walls(file);
    (f, m, reached, hits)
}

/// [`run_figure`] and the wall-following episodes the planner began.
fn run_figure_walls(file: &str) -> (u32, u32, bool, u64, u32) {
    run_figure_seeded(file, None)
}

/// [`run_figure_walls`] with the simulation's seed (its noise) replaced by `seed`.
fn run_figure_seeded(file: &str, seed: Option<u64>) -> (u32, u32, bool, u64, u32) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../sim-host/scenarios")
        .join(file);
    let mut sc = sim_host::scenario::Scenario::load(&path).unwrap();
    if let Some(seed) = seed {
        sc.config.seed = seed;
    }
    let (wx, wy) = sc.config.wand.at(sc.config.duration_s).unwrap();
    let mut sim = sim_host::sim::Sim::new(sc.config);
    let (mut flags, mut modes, mut walls, mut was_wall) = (0, 0, 0, false);
    while !sim.done() {
        sim.step();
        if sim.steps.is_multiple_of(20) {
            flags |= vme_map::REFLEX_SUBGOAL
                .read(&mut sim.bus())
                .map_or(0, |r| r.0.flags);
            let mode = vme_map::PLANNER_GOAL
                .read(&mut sim.bus())
                .map_or(0, |r| r.0.mode & 0x1F);
            modes |= 1 << mode;
            let wall = mode == planner_mode::WALL;
            walls += (wall && !was_wall) as u32;
            was_wall = wall;
        }
    }
    let [a, b] = sim.plant.angles_rad();
    let (x, y) = arm::geometry::tip(a, b);
    (
        flags,
        modes,
        (x - wx).hypot(y - wy) < 0.01,
        sim.collisions.events,
        walls,
    )
}

/// Fig. VI.2: with the thesis's leave rule (a clear straight line of sight releases the arm)
/// the released arm's real path runs back into the wall it left, and the planner loops
/// there for the whole run; with ours (the servo's real path must be clear) the same scene
/// is two wall-following episodes to the goal. Over nine noise seeds ours always reaches the
/// goal so, and the thesis's rule loops for the whole run under several of them (the loop
/// is not one seed's accident; under others the noise shakes the arm out, sooner or later).
#[test]
fn line_of_sight_loops_in_fig_vi_2_and_the_real_trajectory_does_not() {
    let (_, _, reached, hits, walls) = run_figure_walls("fig_vi_2_loop.toml");
    assert!(!reached, "the thesis's rule reached the goal");
    assert_eq!(hits, 0);
    assert!(walls >= 10, "{walls} wall-following episodes: no loop");
    let (_, _, reached, hits, walls) = run_figure_walls("fig_vi_2_trajectory.toml");
    assert!(
        reached && hits == 0,
        "ours: reached {reached}, {hits} contacts"
    );
    assert!(walls <= 2, "{walls} wall-following episodes");
    let mut loops = 0;
    for seed in 1..=9 {
        let (_, _, reached, hits, walls) =
            run_figure_seeded("fig_vi_2_trajectory.toml", Some(seed));
        assert!(
            reached && hits == 0 && walls <= 2,
            "ours, seed {seed}: reached {reached}, {hits} contacts, {walls} episodes"
        );
        let (_, _, reached, hits, walls) = run_figure_seeded("fig_vi_2_loop.toml", Some(seed));
        assert_eq!(hits, 0, "the thesis's rule, seed {seed}");
        loops += (!reached && walls >= 10) as u32;
    }
    assert!(
        loops >= 3,
        "the thesis's rule looped under {loops} of 9 seeds"
    );
}

/// Figs. VI.3-VI.5: free motion with neither layer stepping in; the reflexes diverting the
/// arm without the planner; the planner following the wall. Each reaches the goal.
#[test]
fn the_integrated_runs_of_chapter_vi_behave_as_in_the_thesis() {
    let wall = 1 << planner_mode::WALL;
    let (f, m, reached, hits) = run_figure("fig_vi_3_free.toml");
    assert!(reached && hits == 0);
    assert_eq!(
        f & (rf::BLOCKED1 | rf::BLOCKED2 | rf::BRAKING | rf::ESCAPING),
        0,
        "{f:#x}"
    );
    assert_eq!(m & wall, 0);
    let (f, m, reached, hits) = run_figure("fig_vi_4_reflex.toml");
    assert!(reached && hits == 0);
    assert_ne!(
        f & (rf::BLOCKED1 | rf::BLOCKED2),
        0,
        "the reflexes deflect: {f:#x}"
    );
    assert_eq!(m & wall, 0, "without the planner");
    let (_, m, reached, hits) = run_figure("fig_vi_5_planner.toml");
    assert!(reached && hits == 0);
    assert_ne!(m & wall, 0, "the planner follows the wall");
}
