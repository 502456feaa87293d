//! The fault campaign (`sim-host campaign faults`): every committed fault scenario, native,
//! with the collision oracle at every plant step.

use sim_host::fault_campaign::{default_dir, run};

#[test]
fn every_fault_is_survived_without_a_collision_by_the_layer_below_it() {
    let s = run(&default_dir(), None, 2).unwrap();
    assert_eq!(s.scenarios, 23);
    for r in &s.results {
        assert_eq!(r.collisions, 0, "{}", r.scenario);
        // The fault strikes mid-move, at speed.
        assert!(r.speed_at_fault_rad_s[1].abs() > 5.0, "{}", r.scenario);
        let layer = |want: &str| {
            assert!(
                r.held_by.starts_with(want),
                "{}: held by {}, want {want}",
                r.scenario,
                r.held_by
            )
        };
        let board = r.scenario.rsplit('_').next().unwrap();
        // A bus error strikes when its board takes the host's command, at its next poll
        // (natively within 2 ms: the boards poll it once a frame or job); every other fault
        // when injected.
        let late_s = r.fault_s - r.injected_s;
        if r.scenario.starts_with("bus_error") {
            assert!(
                (0.0..=0.002).contains(&late_s),
                "{}: taken {late_s} s late",
                r.scenario
            );
        } else {
            assert_eq!(late_s, 0.0, "{}", r.scenario);
        }
        match (r.scenario.split('_').next().unwrap(), board) {
            // A board that stops or dies mid-publish: the layer below holds the arm within
            // the arrest distance the servo published when the fault struck.
            ("halt" | "bus" | "tear", "servo") => layer("brakes"),
            ("halt" | "bus" | "tear", "reflex") => layer("servo"),
            ("halt" | "bus" | "tear", _) => layer("reflex"),
            // A frozen heartbeat on a board whose records stay fresh: the consumers watch
            // the records' own counters and carry on; the C-space map's freshness is its
            // heartbeat, so a frozen one makes the reflex hold.
            ("freeze", "cspace0") => layer("reflex"),
            ("freeze", _) => layer("none"),
            // An occluded or saturated beacon is published invalid; the goal's last valid
            // position stands (the arm goes on), an obstacle's last position stays in the map.
            ("occlude" | "saturate", _) => {}
            (k, _) => panic!("unknown fault scenario kind {k}"),
        }
        if r.held_by.starts_with("brakes")
            || r.held_by.starts_with("servo")
            || r.held_by.starts_with("reflex (hold")
        {
            assert_eq!(
                r.within_arrest,
                Some(true),
                "{}: {:?}",
                r.scenario,
                r.travel_over_arrest
            );
            let rec = r.faults.join("; ");
            assert!(
                !rec.is_empty(),
                "{}: a fault is recorded in global RAM",
                r.scenario
            );
        }
    }
    // Boards slower than the plant's step take their bus error steps after it is posted,
    // and are measured from there.
    assert!(s
        .results
        .iter()
        .any(|r| r.scenario.starts_with("bus_error") && r.fault_s > r.injected_s));
    assert_eq!(s.with_collisions, 0);
    assert_eq!(s.beyond_arrest, 0);
}
