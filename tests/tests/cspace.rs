//! The C-space map against the exact oracle (issue 7): no pixel that holds a colliding
//! configuration is ever left free, and the committed database is what the generator builds
//! from the arm's outline.

use cspace::Disk;
use proptest::prelude::*;
use sim_host::cspace_oracle::{check_disk, pixel, random_disk, survey, Verdict};

#[test]
fn the_committed_database_is_what_the_generator_builds() {
    let text = sim_host::cspace_db::render(&sim_host::cspace_db::build());
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let committed = std::fs::read_to_string(root.join(sim_host::cspace_db::TABLES_PATH)).unwrap();
    assert!(
        text == committed,
        "crates/cspace/src/tables.rs is stale: cargo run -p sim-host -- cspace-db --write"
    );
}

#[test]
fn the_oracle_finds_collisions_and_proves_freedom() {
    // A pin at 45 cm on the x axis: the outstretched arm (pixel 0, 0) hits it; the arm
    // folded back (theta2 = pi) cannot.
    let d = Disk {
        x_um: 450_000,
        y_um: 0,
        r_um: 1_000,
    };
    assert_eq!(pixel(&d, 0, 0), Verdict::Collides);
    assert_eq!(pixel(&d, 0, 64), Verdict::Free);
    assert_eq!(pixel(&d, 64, 0), Verdict::Free);
}

#[test]
fn a_survey_of_random_disks_finds_no_false_free_pixel() {
    let s = survey(7, 200, &|_| {});
    assert_eq!(s.disks, 200);
    assert_eq!(
        s.total.false_free, 0,
        "first offender: {:?}",
        s.first_false_free
    );
    assert!(s.total.exact > 0 && s.total.false_occupied > 0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    #[test]
    fn no_pixel_holding_a_collision_is_free(seed: u64) {
        let d = random_disk(seed, 0);
        let c = check_disk(&d).unwrap();
        prop_assert_eq!(c.false_free, 0, "disk {:?}", d);
    }

    #[test]
    fn no_pixel_holding_a_collision_is_free_near_region_boundaries(
        r_mm in prop::sample::select(vec![38.0, 120.0, 250.0, 275.0, 380.0, 515.0]),
        dr_mm in -8.0f64..8.0,
        phi in -3.2f64..3.2,
        size_mm in 0.0f64..25.4,
    ) {
        let rho = (r_mm + dr_mm) * 1e3;
        let d = Disk {
            x_um: (rho * phi.cos()) as i32,
            y_um: (rho * phi.sin()) as i32,
            r_um: (size_mm * 1e3) as i32,
        };
        let c = check_disk(&d).unwrap();
        prop_assert_eq!(c.false_free, 0, "disk {:?}", d);
    }
}
