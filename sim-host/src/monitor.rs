//! The live monitor: the thesis's host workstation showed task space and C-space while the
//! robot ran (ch. VI), reading only global RAM. `sim-host run <scenario> --monitor PORT`
//! serves a page on `http://127.0.0.1:PORT/` (the report's drawing code, `report.html`) and
//! paces the run to real time; the page polls `/frame.json`, a frame built from global RAM
//! alone: the arm from the servo's state record, obstacles and wand from the sensing board's
//! object table (radii from the host's obstacle table), the reflex's goal, the C-space map.

use crate::report::{Frame, PAGE};
use crate::sim::Sim;
use base64::Engine as _;
use std::sync::{Arc, Mutex};
use vme_map::records::beacon_flags;
use vme_map::{ArrayBus, GlobalBus};

/// A running monitor server.
pub struct Monitor {
    latest: Arc<Mutex<Option<String>>>,
    port: u16,
    last: [f64; 2],
}

/// The monitor page's data: live, the scenario's name, the arm's outline, no frames yet.
#[derive(serde::Serialize)]
struct Live<'a> {
    live: bool,
    name: &'a str,
    description: &'a str,
    l1: f64,
    outline: serde_json::Value,
    summary: Option<()>,
    frames: [(); 0],
}

impl Monitor {
    /// Serves the page for a run named `name` on `127.0.0.1:port` (0: any free port) from a
    /// thread of its own.
    pub fn start(port: u16, name: &str, description: &str) -> Result<Monitor, String> {
        let server = tiny_http::Server::http(("127.0.0.1", port))
            .map_err(|e| format!("--monitor: port {port}: {e}"))?;
        let port = server
            .server_addr()
            .to_ip()
            .map(|a| a.port())
            .ok_or("--monitor: not an IP socket")?;
        let outline = serde_json::from_str::<serde_json::Value>(&crate::report::outline_json())
            .map_err(|e| e.to_string())?;
        let data = serde_json::to_string(&Live {
            live: true,
            name,
            description,
            l1: arm::geometry::L1_M,
            outline,
            summary: None,
            frames: [],
        })
        .map_err(|e| e.to_string())?
        .replace("</", "<\\/");
        let page = PAGE.replace("/*DATA*/null", &data);
        let latest: Arc<Mutex<Option<String>>> = Arc::default();
        let shared = latest.clone();
        std::thread::spawn(move || {
            for req in server.incoming_requests() {
                let (body, ctype, code) = match req.url() {
                    "/" | "/index.html" => (page.clone(), "text/html; charset=utf-8", 200),
                    "/frame.json" => match shared.lock().expect("monitor lock").clone() {
                        Some(f) => (f, "application/json", 200),
                        None => ("no frame yet".into(), "text/plain", 404),
                    },
                    _ => ("not found".into(), "text/plain", 404),
                };
                let h = tiny_http::Header::from_bytes("Content-Type", ctype).expect("header");
                let _ = req.respond(
                    tiny_http::Response::from_string(body)
                        .with_header(h)
                        .with_status_code(code),
                );
            }
        });
        Ok(Monitor {
            latest,
            port,
            last: [0.0; 2],
        })
    }

    /// The port it serves on.
    pub fn port(&self) -> u16 {
        self.port
    }

    /// Publishes the frame global RAM shows now.
    pub fn publish(&mut self, sim: &mut Sim) {
        let t = sim.t_s();
        let f = live_frame(&mut sim.bus(), t, &mut self.last);
        let json = serde_json::to_string(&f).expect("frame serializes");
        *self.latest.lock().expect("monitor lock") = Some(json);
    }
}

/// A frame from global RAM alone, as the host workstation saw the robot. `last` is the
/// arm's last readable pose (kept when the servo's record is torn or never written).
pub fn live_frame(g: &mut ArrayBus, t: f64, last: &mut [f64; 2]) -> Frame {
    if let Ok((s, seq)) = vme_map::SERVO_STATE.read(g) {
        if seq != 0 {
            *last = [s.theta1_urad as f64 * 1e-6, s.theta2_urad as f64 * 1e-6];
        }
    }
    let mut disks = Vec::new();
    let mut wand = None;
    if let Ok((objects, _)) = vme_map::OBJECTS.read(g) {
        for (b, beacon) in objects.beacons.iter().enumerate() {
            if beacon.flags & beacon_flags::VALID == 0 {
                continue;
            }
            let (x, y) = (beacon.x_um as f64 * 1e-6, beacon.y_um as f64 * 1e-6);
            // Beacons 0-4 and 7 are obstacles (the host's radius table: 0-4, then 5 for the
            // instructional robot), 5 the arm's tip, 6 the wand.
            let k = match b {
                0..=4 => b as u32,
                7 => 5,
                6 => {
                    wand = Some([x, y]);
                    continue;
                }
                _ => continue,
            };
            let r_um = g.read_u32(vme_map::layout::OBSTACLE_RADII + 4 * k);
            if r_um != 0 {
                disks.push([x, y, r_um as f64 * 1e-6]);
            }
        }
    }
    let goal = crate::run::reflex_goal(g);
    let marked = crate::run::marked_in(g);
    Frame {
        t,
        q: *last,
        disks,
        wand,
        goal,
        map: base64::engine::general_purpose::STANDARD.encode(crate::report::pack(&marked)),
    }
}
