//! Every shipped scenario loads and runs; a run writes its directory.

use sim_host::run::{run_to_dir, RunOptions};
use sim_host::scenario::Scenario;
use std::path::Path;

#[test]
fn every_shipped_scenario_loads_and_runs_briefly() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../sim-host/scenarios");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_none_or(|x| x != "toml") {
            continue;
        }
        let mut s = Scenario::load(&p).unwrap_or_else(|e| panic!("{e}"));
        s.config.duration_s = s.config.duration_s.min(0.05);
        s.config.faults.retain(|f| f.at_s <= 0.05);
        let out = std::env::temp_dir().join(format!(
            "sim-host-test-{}",
            p.file_stem().unwrap().to_string_lossy()
        ));
        let summary = run_to_dir(
            &s,
            &out,
            &RunOptions {
                quiet: true,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(summary.plant_steps, 1000, "{}", p.display());
        assert!(out.join("trace.csv").exists() && out.join("summary.json").exists());
        for png in ["joints.png", "task.png"] {
            let bytes = std::fs::read(out.join(png)).unwrap();
            assert!(
                bytes.starts_with(b"\x89PNG\r\n\x1a\n") && bytes.len() > 10_000,
                "{png} is a picture"
            );
        }
        n += 1;
    }
    assert!(n >= 5, "found {n} scenarios");
}

/// A run counts, per obstacle, the milliseconds the sensing board read it beyond the
/// camera's calibrated square (flagged `EXTRAPOLATED`), so `sim-host run` can warn that the
/// map does not cover it: an obstacle 0.45 m out counts nearly every millisecond once the
/// filters have filled, one 0.25 m out none; and the same for a wand 0.42 m out.
#[test]
fn a_run_counts_the_milliseconds_an_obstacle_was_read_beyond_the_camera_square() {
    let text =
        "name = \"outside\"\nduration_s = 0.5\nseed = 1\n\n[arm]\nstart_rad = [1.5, 1.5]\n\n\
                [[obstacle]]\nx_m = 0.45\ny_m = -0.1\nr_m = 0.02\n\n\
                [[obstacle]]\nx_m = 0.25\ny_m = -0.1\nr_m = 0.02\n\n\
                [wand]\npath = [[0.0, -0.1, 0.42]]\n";
    let s = Scenario::parse(Path::new("outside.toml"), text).unwrap();
    let (_, summary) = sim_host::run::run(
        &s,
        &RunOptions {
            quiet: true,
            ..Default::default()
        },
    )
    .unwrap();
    let ms = &summary.obstacles_extrapolated_ms;
    assert_eq!(ms.len(), 2);
    assert!(ms[0] > 250 && ms[0] <= 500, "{ms:?}");
    assert_eq!(ms[1], 0, "{ms:?}");
    let w = summary.wand_extrapolated_ms;
    assert!(w > 250 && w <= 500, "wand {w}");
}
