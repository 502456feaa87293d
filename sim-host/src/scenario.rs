//! Scenario files: TOML descriptions of a run (docs/scenarios.md has the format).
//!
//! Unknown keys, wrong types and impossible values are errors that name the file, the line
//! and the reason; nothing in a file is silently ignored.

use crate::optics::{BeaconWindow, OpticsConfig};
use crate::sim::{
    Calibration, Config, Fault, FaultKind, Motion, Obstacle, WandPath, DEFAULT_PERIODS_S,
};
use arm::geometry::Disk;
use serde::Deserialize;
use std::fmt;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// A scenario that could not be used.
#[derive(Debug, PartialEq)]
pub struct ScenarioError {
    /// The file.
    pub path: PathBuf,
    /// 1-based line (0 when the whole file is at fault).
    pub line: usize,
    /// Why.
    pub reason: String,
}

impl fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line > 0 {
            write!(f, "{}:{}: {}", self.path.display(), self.line, self.reason)
        } else {
            write!(f, "{}: {}", self.path.display(), self.reason)
        }
    }
}

impl std::error::Error for ScenarioError {}

/// A loaded scenario.
#[derive(Clone, Debug, PartialEq)]
pub struct Scenario {
    /// Its name.
    pub name: String,
    /// What it shows.
    pub description: String,
    /// The run it describes.
    pub config: Config,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    name: String,
    #[serde(default)]
    description: String,
    duration_s: Spanned<f64>,
    #[serde(default = "default_seed")]
    seed: u64,
    dt_us: Option<Spanned<f64>>,
    #[serde(default)]
    arm: ArmDe,
    #[serde(default)]
    obstacle: Vec<Spanned<ObstacleDe>>,
    wand: Option<WandDe>,
    #[serde(default)]
    boards: Vec<Spanned<BoardDe>>,
    #[serde(default)]
    fault: Vec<Spanned<FaultDe>>,
    optics: Option<Spanned<OpticsDe>>,
    planner: Option<PlannerDe>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PlannerDe {
    leave: Spanned<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OpticsDe {
    #[serde(default)]
    ideal: bool,
    distortion: Option<bool>,
    noise_mm: Option<Spanned<f64>>,
    intensity: Option<bool>,
    ambient: Option<bool>,
    drift: Option<Spanned<[f64; 3]>>,
    #[serde(default)]
    occluded: Vec<Spanned<WindowDe>>,
    #[serde(default)]
    saturated: Vec<Spanned<WindowDe>>,
    calibration: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct WindowDe {
    beacon: u8,
    from_s: f64,
    until_s: f64,
}

fn default_seed() -> u64 {
    1
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct ArmDe {
    start_rad: Option<Spanned<[f64; 2]>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ObstacleDe {
    x_m: Spanned<f64>,
    y_m: Spanned<f64>,
    r_m: Spanned<f64>,
    #[serde(default = "static_motion")]
    motion: String,
    vx_m_s: Option<f64>,
    vy_m_s: Option<f64>,
    cx_m: Option<f64>,
    cy_m: Option<f64>,
    period_s: Option<f64>,
}

fn static_motion() -> String {
    "static".into()
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct WandDe {
    path: Spanned<Vec<[f64; 3]>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BoardDe {
    name: String,
    rate_hz: Spanned<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FaultDe {
    at_s: Spanned<f64>,
    board: String,
    kind: String,
}

/// Most obstacles a scenario may have: the five obstacle beacons and the instructional robot.
pub const MAX_OBSTACLES: usize = 6;
/// Longest run a scenario may ask for.
pub const MAX_DURATION_S: f64 = 3600.0;

impl Scenario {
    /// Loads and checks a scenario file.
    pub fn load(path: &Path) -> Result<Scenario, ScenarioError> {
        let text = std::fs::read_to_string(path).map_err(|e| ScenarioError {
            path: path.to_owned(),
            line: 0,
            reason: format!("cannot read: {e}"),
        })?;
        Self::parse(path, &text)
    }

    /// Parses and checks scenario text; `path` names it in errors.
    pub fn parse(path: &Path, text: &str) -> Result<Scenario, ScenarioError> {
        let line_of = |pos: usize| text[..pos.min(text.len())].matches('\n').count() + 1;
        let err = |pos: usize, reason: String| ScenarioError {
            path: path.to_owned(),
            line: line_of(pos),
            reason,
        };
        let f: File = toml::from_str(text).map_err(|e| {
            let line = e.span().map(|s| line_of(s.start)).unwrap_or(0);
            ScenarioError {
                path: path.to_owned(),
                line,
                reason: e.message().trim().to_string(),
            }
        })?;

        let d = *f.duration_s.get_ref();
        if !(d > 0.0 && d <= MAX_DURATION_S) {
            return Err(err(
                f.duration_s.span().start,
                format!("duration_s must be in (0, {MAX_DURATION_S}], got {d}"),
            ));
        }
        let mut cfg = Config {
            seed: f.seed,
            duration_s: d,
            ..Default::default()
        };
        if let Some(dt) = &f.dt_us {
            let v = *dt.get_ref();
            if !(1.0..=50.0).contains(&v) {
                return Err(err(
                    dt.span().start,
                    format!("dt_us must be 1..=50 (the plant step), got {v}"),
                ));
            }
            cfg.dt_s = v * 1e-6;
        }
        if let Some(s) = &f.arm.start_rad {
            let a = *s.get_ref();
            if !a.iter().all(|x| x.is_finite() && x.abs() <= 100.0) {
                return Err(err(
                    s.span().start,
                    format!("start_rad must be two finite angles, got {a:?}"),
                ));
            }
            cfg.start_rad = a;
        }
        if f.obstacle.len() > MAX_OBSTACLES {
            return Err(err(f.obstacle[MAX_OBSTACLES].span().start, format!("at most {MAX_OBSTACLES} obstacles (5 obstacle beacons and the instructional robot)")));
        }
        for o in &f.obstacle {
            let at = o.span().start;
            let v = o.get_ref();
            let r = *v.r_m.get_ref();
            if !(r > 0.0 && r <= 1.0) {
                return Err(err(
                    v.r_m.span().start,
                    format!("obstacle r_m must be in (0, 1] m, got {r}"),
                ));
            }
            for c in [&v.x_m, &v.y_m] {
                let x = *c.get_ref();
                if !(x.is_finite() && x.abs() <= 10.0) {
                    return Err(err(
                        c.span().start,
                        format!("obstacle position must be finite and within 10 m, got {x}"),
                    ));
                }
            }
            let need = |k: Option<f64>, name: &str| {
                k.ok_or_else(|| err(at, format!("motion = \"{}\" needs {name}", v.motion)))
            };
            let unused = |keys: &[(&str, Option<f64>)]| -> Result<(), ScenarioError> {
                match keys.iter().find(|(_, k)| k.is_some()) {
                    Some((n, _)) => Err(err(
                        at,
                        format!("{n} does not apply to motion = \"{}\"", v.motion),
                    )),
                    None => Ok(()),
                }
            };
            let motion = match v.motion.as_str() {
                "static" => {
                    unused(&[
                        ("vx_m_s", v.vx_m_s),
                        ("vy_m_s", v.vy_m_s),
                        ("cx_m", v.cx_m),
                        ("cy_m", v.cy_m),
                        ("period_s", v.period_s),
                    ])?;
                    Motion::Static
                }
                "line" => {
                    unused(&[("cx_m", v.cx_m), ("cy_m", v.cy_m), ("period_s", v.period_s)])?;
                    Motion::Line {
                        vx_m_s: need(v.vx_m_s, "vx_m_s")?,
                        vy_m_s: need(v.vy_m_s, "vy_m_s")?,
                    }
                }
                "circle" => {
                    unused(&[("vx_m_s", v.vx_m_s), ("vy_m_s", v.vy_m_s)])?;
                    let period_s = need(v.period_s, "period_s")?;
                    if period_s == 0.0 || !period_s.is_finite() {
                        return Err(err(at, "period_s must be finite and non-zero".into()));
                    }
                    Motion::Circle {
                        cx_m: need(v.cx_m, "cx_m")?,
                        cy_m: need(v.cy_m, "cy_m")?,
                        period_s,
                    }
                }
                m => {
                    return Err(err(
                        at,
                        format!("unknown motion {m:?} (static, line, circle)"),
                    ))
                }
            };
            cfg.obstacles.push(Obstacle {
                start: Disk {
                    x_m: *v.x_m.get_ref(),
                    y_m: *v.y_m.get_ref(),
                    r_m: r,
                },
                motion,
            });
        }
        if let Some(w) = &f.wand {
            let p = w.path.get_ref();
            let at = w.path.span().start;
            if p.is_empty() {
                return Err(err(
                    at,
                    "wand path needs at least one [t_s, x_m, y_m] point".into(),
                ));
            }
            for (i, q) in p.iter().enumerate() {
                if !q.iter().all(|x| x.is_finite()) || q[0] < 0.0 {
                    return Err(err(
                        at,
                        format!("wand point {i} must be finite with t_s >= 0"),
                    ));
                }
                if i > 0 && q[0] <= p[i - 1][0] {
                    return Err(err(
                        at,
                        format!(
                            "wand point {i}: times must increase ({} after {})",
                            q[0],
                            p[i - 1][0]
                        ),
                    ));
                }
            }
            cfg.wand = WandPath {
                points: p.iter().map(|q| (q[0], q[1], q[2])).collect(),
            };
        }
        let board = |name: &str, at: usize| {
            crate::boot::parse_board(name).ok_or_else(|| {
                err(
                    at,
                    format!("unknown board {name:?} (sensing, cspace0..2, servo, reflex, planner)"),
                )
            })
        };
        if !f.boards.is_empty() {
            cfg.boards = Vec::new();
            for b in &f.boards {
                let at = b.span().start;
                let v = b.get_ref();
                let id = board(&v.name, at)?;
                let rate = *v.rate_hz.get_ref();
                if !(rate > 0.0 && rate <= 1e6) {
                    return Err(err(
                        v.rate_hz.span().start,
                        format!("rate_hz must be in (0, 1e6], got {rate}"),
                    ));
                }
                if cfg.boards.iter().any(|(i, _)| *i == id) {
                    return Err(err(at, format!("board {} listed twice", id.name())));
                }
                cfg.boards.push((id, 1.0 / rate));
            }
        } else {
            cfg.boards = DEFAULT_PERIODS_S.to_vec();
        }
        for x in &f.fault {
            let at = x.span().start;
            let v = x.get_ref();
            let id = board(&v.board, at)?;
            if !cfg.boards.iter().any(|(i, _)| *i == id) {
                return Err(err(
                    at,
                    format!(
                        "fault on board {} which this scenario does not run",
                        id.name()
                    ),
                ));
            }
            let when = *v.at_s.get_ref();
            if !(0.0..=d).contains(&when) {
                return Err(err(
                    v.at_s.span().start,
                    format!("fault at_s must be within the run (0..={d}), got {when}"),
                ));
            }
            let kind = match v.kind.as_str() {
                "halt" => FaultKind::Halt,
                "bus_error" => FaultKind::BusError,
                "freeze_heartbeat" => FaultKind::FreezeHeartbeat,
                "tear" => FaultKind::Tear,
                k => {
                    return Err(err(
                        at,
                        format!(
                            "unknown fault kind {k:?} (halt, bus_error, freeze_heartbeat, tear)"
                        ),
                    ))
                }
            };
            cfg.faults.push(Fault {
                at_s: when,
                board: id,
                kind,
            });
        }
        if let Some(o) = &f.optics {
            let v = o.get_ref();
            let mut c = if v.ideal {
                OpticsConfig::ideal()
            } else {
                OpticsConfig::default()
            };
            c.distortion = v.distortion.unwrap_or(c.distortion);
            c.intensity = v.intensity.unwrap_or(c.intensity);
            c.ambient = v.ambient.unwrap_or(c.ambient);
            if let Some(n) = &v.noise_mm {
                let x = *n.get_ref();
                if !(0.0..=100.0).contains(&x) {
                    return Err(err(
                        n.span().start,
                        format!("noise_mm must be in 0..=100, got {x}"),
                    ));
                }
                c.noise_mm = x;
            }
            if let Some(dr) = &v.drift {
                let [w0, w1, tau] = *dr.get_ref();
                if !(w0.is_finite()
                    && w1.is_finite()
                    && (0.0..=2.0).contains(&w0)
                    && (0.0..=2.0).contains(&w1)
                    && tau >= 0.0
                    && tau.is_finite())
                {
                    return Err(err(dr.span().start, format!("drift = [warmth at 0 s, warmth it tends to, time constant s]: warmths in 0..=2, time constant >= 0; got {:?}", dr.get_ref())));
                }
                c.drift = (w0, w1, tau);
            }
            for (list, out) in [
                (&v.occluded, &mut c.occluded),
                (&v.saturated, &mut c.saturated),
            ] {
                for w in list {
                    let x = w.get_ref();
                    if x.beacon > 7
                        || !(x.from_s >= 0.0 && x.until_s > x.from_s && x.until_s.is_finite())
                    {
                        return Err(err(w.span().start, format!("a beacon window needs beacon 0..=7 and 0 <= from_s < until_s, got beacon {} from {} until {}", x.beacon, x.from_s, x.until_s)));
                    }
                    out.push(BeaconWindow {
                        beacon: x.beacon,
                        from_s: x.from_s,
                        until_s: x.until_s,
                    });
                }
            }
            if let Some(k) = &v.calibration {
                cfg.calibration = match k.get_ref().as_str() {
                    "model" => Calibration::Model,
                    "none" => Calibration::None,
                    other => {
                        return Err(err(
                            k.span().start,
                            format!("unknown calibration {other:?} (model, none)"),
                        ))
                    }
                };
            }
            cfg.optics = c;
        }
        if let Some(p) = &f.planner {
            cfg.planner.leave = match p.leave.get_ref().as_str() {
                "trajectory" => planner::Leave::Trajectory,
                "line_of_sight" => planner::Leave::LineOfSight,
                other => {
                    return Err(err(
                        p.leave.span().start,
                        format!("unknown planner leave rule {other:?} (trajectory, line_of_sight)"),
                    ))
                }
            };
        }
        Ok(Scenario {
            name: f.name,
            description: f.description,
            config: cfg,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vme_map::BoardId;

    const GOOD: &str = r#"
name = "test"
duration_s = 0.5
seed = 7

[arm]
start_rad = [0.1, -0.2]

[[obstacle]]
x_m = 0.3
y_m = 0.2
r_m = 0.02
motion = "circle"
cx_m = 0.0
cy_m = 0.0
period_s = 10.0

[wand]
path = [[0.0, 0.3, 0.3], [0.5, 0.2, 0.35]]

[[boards]]
name = "servo"
rate_hz = 3000

[[fault]]
at_s = 0.25
board = "servo"
kind = "halt"

[optics]
noise_mm = 3.0
intensity = false
drift = [0.0, 1.0, 600.0]
occluded = [{ beacon = 2, from_s = 0.1, until_s = 0.2 }]
saturated = [{ beacon = 4, from_s = 0.3, until_s = 0.4 }]
calibration = "none"
"#;

    #[test]
    fn a_good_scenario_loads() {
        let s = Scenario::parse(Path::new("good.toml"), GOOD).unwrap();
        assert_eq!(s.config.seed, 7);
        assert_eq!(s.config.start_rad, [0.1, -0.2]);
        assert_eq!(s.config.boards, vec![(BoardId::Servo, 1.0 / 3000.0)]);
        assert_eq!(s.config.faults.len(), 1);
        assert!(matches!(
            s.config.obstacles[0].motion,
            Motion::Circle { .. }
        ));
        let o = &s.config.optics;
        assert_eq!(o.noise_mm, 3.0);
        assert!(
            !o.intensity && o.distortion && o.ambient,
            "unset keys keep the defaults"
        );
        assert_eq!(o.drift, (0.0, 1.0, 600.0));
        assert_eq!(o.occluded[0].beacon, 2);
        assert_eq!(o.saturated[0].until_s, 0.4);
        assert_eq!(s.config.calibration, Calibration::None);
    }

    #[test]
    fn bad_optics_name_their_line() {
        for (from, to, says) in [
            ("noise_mm = 3.0", "noise_mm = -1.0", "noise_mm must be"),
            (
                "drift = [0.0, 1.0, 600.0]",
                "drift = [0.0, 5.0, 600.0]",
                "warmths in 0..=2",
            ),
            (
                "beacon = 2, from_s = 0.1",
                "beacon = 9, from_s = 0.1",
                "beacon 0..=7",
            ),
            (
                "calibration = \"none\"",
                "calibration = \"guess\"",
                "unknown calibration",
            ),
            (
                "intensity = false",
                "intensty = false",
                "unknown field `intensty`",
            ),
        ] {
            let e = broken(from, to);
            assert!(
                e.starts_with(&format!("bad.toml:{}:", line_of(from))) && e.contains(says),
                "{e}"
            );
        }
    }

    fn broken(from: &str, to: &str) -> String {
        assert!(GOOD.contains(from), "{from}");
        Scenario::parse(Path::new("bad.toml"), &GOOD.replacen(from, to, 1))
            .unwrap_err()
            .to_string()
    }

    fn line_of(s: &str) -> usize {
        GOOD[..GOOD.find(s).unwrap()].matches('\n').count() + 1
    }

    #[test]
    fn broken_files_name_file_line_and_reason() {
        let e = broken("seed = 7", "seed = 7\nsede = 3");
        assert!(
            e.starts_with(&format!("bad.toml:{}:", line_of("seed = 7") + 1))
                && e.contains("unknown field `sede`"),
            "{e}"
        );
        let e = broken("duration_s = 0.5", "duration_s = \"long\"");
        assert!(
            e.starts_with("bad.toml:3:") && e.contains("invalid type"),
            "{e}"
        );
        let e = broken("duration_s = 0.5", "duration_s = -1.0");
        assert!(
            e.starts_with("bad.toml:3:") && e.contains("duration_s must be"),
            "{e}"
        );
        let e = broken("r_m = 0.02", "r_m = 0.0");
        assert!(
            e.starts_with(&format!("bad.toml:{}:", line_of("r_m = 0.02"))) && e.contains("r_m"),
            "{e}"
        );
        let e = broken("period_s = 10.0", "");
        assert!(e.contains("needs period_s"), "{e}");
        let e = broken("motion = \"circle\"", "motion = \"spiral\"");
        assert!(e.contains("unknown motion"), "{e}");
        let e = broken("[0.5, 0.2, 0.35]", "[0.0, 0.2, 0.35]");
        assert!(
            e.starts_with(&format!("bad.toml:{}:", line_of("path =")))
                && e.contains("times must increase"),
            "{e}"
        );
        let e = broken("board = \"servo\"", "board = \"elbow\"");
        assert!(e.contains("unknown board \"elbow\""), "{e}");
        let e = broken("board = \"servo\"", "board = \"reflex\"");
        assert!(e.contains("does not run"), "{e}");
        let e = broken("at_s = 0.25", "at_s = 9.0");
        assert!(
            e.starts_with(&format!("bad.toml:{}:", line_of("at_s")))
                && e.contains("within the run"),
            "{e}"
        );
        let e = broken("rate_hz = 3000", "rate_hz = 0");
        assert!(
            e.starts_with(&format!("bad.toml:{}:", line_of("rate_hz"))) && e.contains("rate_hz"),
            "{e}"
        );
        let e = broken("start_rad = [0.1, -0.2]", "start_rad = [0.1]");
        assert!(
            e.starts_with(&format!("bad.toml:{}:", line_of("start_rad"))),
            "{e}"
        );
        let e = Scenario::parse(Path::new("empty.toml"), "")
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing field `name`"), "{e}");
    }
}
