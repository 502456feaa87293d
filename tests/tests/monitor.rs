//! The live monitor: a page served by the simulator while a run goes on, reading only global
//! RAM, loaded in headless Chromium (Debian `chromium`, installed by `.ci/setup`).

use sim_host::monitor::Monitor;
use sim_host::scenario::Scenario;
use sim_host::sim::Sim;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// `name="value"` of the page's `<body>` in Chromium's DOM dump.
fn body_attr(dom: &str, name: &str) -> Option<f64> {
    let body = &dom[dom.find("<body")?..];
    let body = &body[..body.find('>')?];
    let at = body.find(&format!("{name}=\""))? + name.len() + 2;
    body[at..].split('"').next()?.parse().ok()
}

#[test]
fn the_monitor_page_draws_and_updates_while_a_run_goes_on() {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../sim-host/scenarios/fig_vi_5_planner.toml");
    let sc = Scenario::load(&p).unwrap();
    // Chromium's first start on a fresh or busy machine can take longer than the 4 s run
    // (the page then saw only the last frame): start it once on a blank page first.
    let _ = std::process::Command::new("chromium")
        .args(["--headless", "--no-sandbox", "--disable-gpu", "--dump-dom"])
        .arg("about:blank")
        .stdin(std::process::Stdio::null())
        .output();
    let mut monitor = Monitor::start(0, &sc.name, &sc.description).unwrap();
    let port = monitor.port();
    let run = std::thread::spawn(move || {
        // Paced to real time, one frame every 50 ms, as `sim-host run --monitor` does.
        let mut sim = Sim::new(sc.config);
        let start = Instant::now();
        while !sim.done() {
            sim.step();
            if sim.steps.is_multiple_of(1000) {
                monitor.publish(&mut sim);
                let ahead = sim.t_s() - start.elapsed().as_secs_f64();
                if ahead > 0.0 {
                    std::thread::sleep(Duration::from_secs_f64(ahead));
                }
            }
        }
        // Keep serving the last frame until the page has been read.
        std::thread::sleep(Duration::from_secs(30));
        drop(monitor);
    });
    std::thread::sleep(Duration::from_millis(300));
    let out = std::process::Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--dump-dom",
            "--virtual-time-budget=2500",
        ])
        .arg(format!("http://127.0.0.1:{port}/"))
        .stdin(std::process::Stdio::null())
        .output()
        .expect("chromium runs (.ci/setup installs it)");
    let dom = String::from_utf8_lossy(&out.stdout);
    assert!(dom.contains("fig. VI.5"), "the page names the run: {dom}");
    let frames = body_attr(&dom, "data-frames").expect("frame count");
    let drawn = body_attr(&dom, "data-drawn").expect("draw count");
    let t = body_attr(&dom, "data-t").expect("time shown");
    // The page polls every 100 ms: over the run's first seconds it drew many new frames,
    // each later in simulated time.
    assert!(
        frames >= 5.0 && drawn >= 5.0,
        "frames {frames}, drawn {drawn}"
    );
    assert!(t > 0.3, "the last frame drawn is at {t} s");
    drop(run);
}
