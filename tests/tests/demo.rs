//! The main demo (`sim-host demo`) and its 100-seed campaign (`sim-host campaign demo`).

use sim_host::demo_campaign::run;

#[test]
fn the_demo_reaches_the_wand_in_every_seed_or_says_why_not_and_never_collides() {
    let s = run(100, None, 2).unwrap();
    assert_eq!(s.seeds, 100);
    assert_eq!(
        s.with_collisions,
        0,
        "{:?}",
        s.results
            .iter()
            .filter(|r| r.collisions > 0)
            .collect::<Vec<_>>()
    );
    for r in &s.results {
        if r.reached {
            assert!(
                r.goal_error_m <= 0.01 && r.why.is_empty(),
                "seed {}",
                r.seed
            );
        } else {
            // How far, and at least one cause read from global RAM or the arm's state.
            let causes = r.why.split(", ").count();
            assert!(
                r.why.contains("mm from the wand") && causes >= 2,
                "seed {}: {:?}",
                r.seed,
                r.why
            );
        }
    }
    println!(
        "demo: {} of 100 seeds reached the wand, smallest clearance {:.1} mm",
        s.reached,
        s.min_clearance_m * 1e3
    );
}
