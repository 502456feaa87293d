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
