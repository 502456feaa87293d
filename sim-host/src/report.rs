//! The run's report (`report.html`), what a person opens first (design.md section 7,
//! "Output"): an animation of the task space (arm, obstacles, wand) beside the C-space map as
//! it evolved in global RAM with the arm's configuration and the reflex's goal on it (what the
//! thesis's host workstation showed live, ch. VI), the joint plots, and a table of the run's
//! figures. One self-contained file: the frames are embedded as JSON, the map of each frame as
//! base64 of its 128 x 128 bits; the arm is drawn from `arm::geometry::OUTLINE`.

use crate::run::Summary;
use crate::scenario::Scenario;
use crate::sim::Sim;
use base64::Engine as _;
use serde::Serialize;
use std::path::Path;

/// One frame of the animation.
#[derive(Serialize, Clone, Debug, PartialEq)]
pub struct Frame {
    /// Simulated time.
    pub t: f64,
    /// True joint angles (absolute, rad).
    pub q: [f64; 2],
    /// Obstacle disks where they are (x, y, r in m).
    pub disks: Vec<[f64; 3]>,
    /// The wand (m), if it is out.
    pub wand: Option<[f64; 2]>,
    /// The reflex's goal (rad), if it has published one.
    pub goal: Option<[f64; 2]>,
    /// The C-space map in global RAM: 128 x 128 bits, row `i2`, bit `i1` (LSB first),
    /// base64.
    pub map: String,
}

/// Takes a frame of the simulation now.
pub fn frame(sim: &mut Sim) -> Frame {
    let t = sim.t_s();
    let bits = pack(&crate::run::marked_pixels(sim));
    let goal = crate::run::reflex_goal(&mut sim.bus());
    Frame {
        t,
        q: sim.plant.angles_rad(),
        disks: sim
            .cfg
            .obstacles
            .iter()
            .map(|o| {
                let d = o.at(t);
                [d.x_m, d.y_m, d.r_m]
            })
            .collect(),
        wand: sim.cfg.wand.at(t).map(|(x, y)| [x, y]),
        goal,
        map: base64::engine::general_purpose::STANDARD.encode(&bits),
    }
}

/// The map's pixels (`[i2 * 128 + i1]`) packed 8 to a byte, least significant bit first.
pub fn pack(marked: &[bool]) -> Vec<u8> {
    let mut bits = vec![0u8; marked.len().div_ceil(8)];
    for (k, &m) in marked.iter().enumerate() {
        if m {
            bits[k / 8] |= 1 << (k % 8);
        }
    }
    bits
}

/// The arm's outline as the page's JSON.
pub fn outline_json() -> String {
    serde_json::to_string(&outline()).expect("outline serializes")
}

/// The arm's outline for the page: (body 0 = ground, 1 = link 1, 2 = link 2, kind, numbers).
#[derive(Serialize)]
struct OutlinePart {
    body: u8,
    disk: bool,
    /// Disk: centre along the link and radius. Rectangle: start, end, half width.
    v: Vec<f64>,
}

fn outline() -> Vec<OutlinePart> {
    use arm::geometry::{Body, Part, OUTLINE};
    OUTLINE
        .iter()
        .map(|(b, p)| OutlinePart {
            body: match b {
                Body::Ground => 0,
                Body::Link1 => 1,
                Body::Link2 => 2,
            },
            disk: matches!(p, Part::Disk { .. }),
            v: match *p {
                Part::Disk { s_m, r_m } => vec![s_m, r_m],
                Part::Rect {
                    s0_m,
                    s1_m,
                    half_width_m,
                } => vec![s0_m, s1_m, half_width_m],
            },
        })
        .collect()
}

#[derive(Serialize)]
struct Data<'a> {
    live: bool,
    name: &'a str,
    description: &'a str,
    l1: f64,
    outline: Vec<OutlinePart>,
    summary: &'a Summary,
    frames: &'a [Frame],
}

/// Writes `report.html` into `dir` (beside the run's PNGs, which it shows).
pub fn write(
    dir: &Path,
    scenario: &Scenario,
    summary: &Summary,
    frames: &[Frame],
) -> Result<(), String> {
    let data = Data {
        live: false,
        name: &scenario.name,
        description: &scenario.description,
        l1: arm::geometry::L1_M,
        outline: outline(),
        summary,
        frames,
    };
    let json = serde_json::to_string(&data).map_err(|e| e.to_string())?;
    // `</` cannot end the script element early when escaped.
    let json = json.replace("</", "<\\/");
    let html = PAGE.replace("/*DATA*/null", &json);
    let p = dir.join("report.html");
    std::fs::write(&p, html).map_err(|e| format!("{}: {e}", p.display()))
}

/// The page: `/*DATA*/null` is replaced with the run's data. The same drawing code serves
/// the live monitor (`crate::monitor`), which feeds it frames from global RAM instead.
pub const PAGE: &str = include_str!("report.html");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::{run_to_dir, RunOptions};

    #[test]
    fn a_run_directory_has_a_report_with_its_frames_and_figures() {
        let text = "name = \"r\"\nduration_s = 0.3\n[[obstacle]]\nx_m = 0.3\ny_m = 0.3\nr_m = 0.02\n[wand]\npath = [[0.0, 0.3, -0.2]]\n";
        let sc = Scenario::parse(Path::new("r.toml"), text).unwrap();
        let dir = std::env::temp_dir().join("sim-host-report-test");
        let s = run_to_dir(
            &sc,
            &dir,
            &RunOptions {
                quiet: true,
                ..Default::default()
            },
        )
        .unwrap();
        let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
        assert!(html.contains("<canvas id=\"task\""));
        let start = html.find("const DATA = ").unwrap() + "const DATA = ".len();
        let end = html[start..].find(";\n").unwrap() + start;
        let v: serde_json::Value = serde_json::from_str(&html[start..end]).unwrap();
        let frames = v["frames"].as_array().unwrap();
        // One frame every 50 ms, both ends included.
        assert_eq!(frames.len(), 7);
        assert_eq!(v["summary"]["plant_steps"], s.plant_steps);
        // The figures table lists the obstacles read beyond the camera's square from it.
        assert!(v["summary"]["obstacles_extrapolated_ms"].is_array());
        assert!(html.contains("obstacles_extrapolated_ms"));
        let map = base64::engine::general_purpose::STANDARD
            .decode(frames[6]["map"].as_str().unwrap())
            .unwrap();
        assert_eq!(map.len(), 2048);
        assert!(map.iter().any(|&b| b != 0), "the obstacle is in the map");
        assert_eq!(v["outline"].as_array().unwrap().len(), 6);
    }
}
