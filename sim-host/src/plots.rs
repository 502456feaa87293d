//! PNG pictures of a run: the joint trajectories (like thesis figs. III.3-III.6) and the
//! task-space picture (arm at start and end, tip path, obstacle paths, wand path).
//!
//! Text is drawn with DejaVu Sans from Debian's `fonts-dejavu-core` (installed by `.ci/setup`).

use crate::sim::Config;
use arm::geometry::{Body, Part, OUTLINE};
use plotters::prelude::*;
use std::path::Path;

/// Where the plots' font comes from.
pub const FONT_PATH: &str = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

/// One sample of the arm for the plots.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// Time.
    pub t_s: f64,
    /// Link angles.
    pub theta_rad: [f64; 2],
    /// Link velocities.
    pub omega_rad_s: [f64; 2],
    /// Motor torques at the links.
    pub torque_nm: [f64; 2],
    /// The reflex subgoal published (absolute angles; `None` before the first).
    pub subgoal_rad: Option<[f64; 2]>,
    /// The reflex's flags word.
    pub reflex_flags: u32,
}

fn font() -> Result<(), String> {
    static ONCE: std::sync::OnceLock<Result<(), String>> = std::sync::OnceLock::new();
    ONCE.get_or_init(|| {
        let bytes = std::fs::read(FONT_PATH)
            .map_err(|e| format!("{FONT_PATH}: {e} (install Debian's fonts-dejavu-core)"))?;
        let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
        plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
            .map_err(|_| format!("{FONT_PATH}: not a usable font"))
    })
    .clone()
}

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

/// Draws the series legend the same way on every chart.
fn legend<'a, DB: DrawingBackend + 'a>(
    c: &mut ChartContext<
        'a,
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
) -> Result<(), String> {
    c.configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(err)
}

fn range(vals: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in vals {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return 0.0..1.0;
    }
    let pad = ((hi - lo) * 0.05).max(1e-3);
    (lo - pad)..(hi + pad)
}

/// Picks one plotted quantity of link `i` from a sample.
type Quantity = fn(&Sample, usize) -> f64;

/// Writes `joints.png`: angles, velocities and torques of both links against time.
pub fn joints(path: &Path, title: &str, s: &[Sample]) -> Result<(), String> {
    font()?;
    let root = BitMapBackend::new(path, (1000, 900)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let root = root.titled(title, ("sans-serif", 22)).map_err(err)?;
    let panes = root.split_evenly((3, 1));
    let t_end = s.last().map_or(1.0, |x| x.t_s).max(1e-6);
    let rows: [(&str, Quantity); 3] = [
        ("angle (rad)", |x, i| x.theta_rad[i]),
        ("velocity (rad/s)", |x, i| x.omega_rad_s[i]),
        ("torque (N m)", |x, i| x.torque_nm[i]),
    ];
    for (pane, (label, f)) in panes.iter().zip(rows) {
        let y = range(s.iter().flat_map(|x| [f(x, 0), f(x, 1)]));
        let mut c = ChartBuilder::on(pane)
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..t_end, y)
            .map_err(err)?;
        c.configure_mesh()
            .x_desc("time (s)")
            .y_desc(label)
            .draw()
            .map_err(err)?;
        for (i, color) in [(0usize, BLUE), (1, RED)] {
            c.draw_series(LineSeries::new(s.iter().map(|x| (x.t_s, f(x, i))), color))
                .map_err(err)?
                .label(format!("link {}", i + 1))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
        }
        legend(&mut c)?;
    }
    root.present().map_err(err)
}

/// Writes one chart of several named series against time (the servo bench's figures, like
/// thesis figs. III.3-III.6 with the baselines overlaid); `y` fixes the vertical range
/// (otherwise it fits the data).
pub fn overlay(
    path: &Path,
    title: &str,
    y_label: &str,
    series: &[(String, Vec<(f64, f64)>)],
    y: Option<std::ops::Range<f64>>,
) -> Result<(), String> {
    font()?;
    let root = BitMapBackend::new(path, (1000, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let x = range(series.iter().flat_map(|(_, v)| v.iter().map(|p| p.0)));
    let y = y.unwrap_or_else(|| range(series.iter().flat_map(|(_, v)| v.iter().map(|p| p.1))));
    let mut c = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 22))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(60)
        .build_cartesian_2d(x, y.clone())
        .map_err(err)?;
    c.configure_mesh()
        .x_desc("time (s)")
        .y_desc(y_label)
        .draw()
        .map_err(err)?;
    let colors = [BLUE, RED, GREEN, MAGENTA, CYAN, BLACK, BLACK];
    for (k, (name, v)) in series.iter().enumerate() {
        let color = colors[k % colors.len()];
        // Points outside a fixed range are clipped to its edge rather than drawn off the chart.
        let pts = v.iter().map(|&(t, yv)| (t, yv.clamp(y.start, y.end)));
        c.draw_series(LineSeries::new(pts, color))
            .map_err(err)?
            .label(name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
    }
    legend(&mut c)?;
    root.present().map_err(err)
}

/// The outline of the arm at `theta` as polygons in the plane.
fn outline(theta: [f64; 2]) -> Vec<Vec<(f64, f64)>> {
    let (e, _) = (arm::geometry::elbow(theta[0]), ());
    let mut out = Vec::new();
    for (body, part) in OUTLINE {
        let (ox, oy, a) = match body {
            Body::Ground => (0.0, 0.0, 0.0),
            Body::Link1 => (0.0, 0.0, theta[0]),
            Body::Link2 => (e.0, e.1, theta[1]),
        };
        let (c, s) = (a.cos(), a.sin());
        let pt = |u: f64, v: f64| (ox + u * c - v * s, oy + u * s + v * c);
        let poly = match part {
            Part::Disk { s_m, r_m } => (0..=24)
                .map(|k| {
                    let w = k as f64 * std::f64::consts::TAU / 24.0;
                    pt(s_m + r_m * w.cos(), r_m * w.sin())
                })
                .collect(),
            Part::Rect {
                s0_m,
                s1_m,
                half_width_m: h,
            } => vec![
                pt(s0_m, -h),
                pt(s1_m, -h),
                pt(s1_m, h),
                pt(s0_m, h),
                pt(s0_m, -h),
            ],
        };
        out.push(poly);
    }
    out
}

/// Writes `task.png`: the workspace seen from above.
pub fn task(path: &Path, title: &str, cfg: &Config, s: &[Sample]) -> Result<(), String> {
    font()?;
    let root = BitMapBackend::new(path, (900, 900)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let root = root.titled(title, ("sans-serif", 22)).map_err(err)?;
    let mut c = ChartBuilder::on(&root)
        .margin(15)
        .x_label_area_size(35)
        .y_label_area_size(50)
        .build_cartesian_2d(-0.6..0.6, -0.6..0.6)
        .map_err(err)?;
    c.configure_mesh()
        .x_desc("x (m)")
        .y_desc("y (m)")
        .draw()
        .map_err(err)?;
    let t_end = s.last().map_or(0.0, |x| x.t_s);
    // Obstacles: their path, and the disk at the start (light) and at the end (dark).
    for o in &cfg.obstacles {
        let n = 100;
        let trail: Vec<(f64, f64)> = (0..=n)
            .map(|k| o.at(t_end * k as f64 / n as f64))
            .map(|d| (d.x_m, d.y_m))
            .collect();
        c.draw_series(LineSeries::new(trail, BLACK.mix(0.3)))
            .map_err(err)?;
        for (t, alpha) in [(0.0, 0.25), (t_end, 0.7)] {
            let d = o.at(t);
            let ring: Vec<(f64, f64)> = (0..=32)
                .map(|k| {
                    let w = k as f64 * std::f64::consts::TAU / 32.0;
                    (d.x_m + d.r_m * w.cos(), d.y_m + d.r_m * w.sin())
                })
                .collect();
            c.draw_series(std::iter::once(Polygon::new(
                ring,
                BLACK.mix(alpha).filled(),
            )))
            .map_err(err)?;
        }
    }
    // The wand's path.
    if !cfg.wand.points.is_empty() {
        let w: Vec<(f64, f64)> = (0..=100)
            .filter_map(|k| cfg.wand.at(t_end * k as f64 / 100.0))
            .collect();
        c.draw_series(LineSeries::new(w.clone(), GREEN.stroke_width(2)))
            .map_err(err)?
            .label("wand (goal)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], GREEN));
        if let Some(&end) = w.last() {
            c.draw_series(std::iter::once(Cross::new(end, 8, GREEN.stroke_width(3))))
                .map_err(err)?;
        }
    }
    // The arm at the start (light) and at the end (solid), and the tip's path.
    let tips: Vec<(f64, f64)> = s
        .iter()
        .map(|x| arm::geometry::tip(x.theta_rad[0], x.theta_rad[1]))
        .collect();
    c.draw_series(LineSeries::new(tips, RED))
        .map_err(err)?
        .label("tip path")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
    for (sample, style) in [(s.first(), BLUE.mix(0.3)), (s.last(), BLUE.mix(0.9))] {
        if let Some(x) = sample {
            for poly in outline(x.theta_rad) {
                c.draw_series(std::iter::once(PathElement::new(
                    poly,
                    style.stroke_width(2),
                )))
                .map_err(err)?;
            }
        }
    }
    legend(&mut c)?;
    root.present().map_err(err)
}

/// What one pixel of a C-space picture shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapCell {
    /// Free in the map and in the exact image.
    Free,
    /// Marked in the map and holding a collision.
    Exact,
    /// Marked in the map, proven free (the map's conservative margin).
    FalseOccupied,
    /// Free in the map but holding a collision (must never appear).
    FalseFree,
}

/// Writes a C-space picture of 128 x 128 pixels (`cells[i2 * 128 + i1]`), theta1 across and
/// theta2 up, both from -pi to pi as in the thesis's figures IV.1-IV.14: on the left the
/// exact image (pixels that hold a colliding configuration), on the right the map with its
/// conservative margin.
pub fn cspace_map(path: &Path, title: &str, cells: &[MapCell]) -> Result<(), String> {
    font()?;
    let root = BitMapBackend::new(path, (1240, 680)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let root = root.titled(title, ("sans-serif", 20)).map_err(err)?;
    let (left, right) = root.split_horizontally(620);
    let exact = |m: MapCell| match m {
        MapCell::Exact | MapCell::FalseFree => Some(RGBColor(40, 40, 40)),
        _ => None,
    };
    let map = |m: MapCell| match m {
        MapCell::Free => None,
        MapCell::Exact => Some(RGBColor(40, 40, 40)),
        MapCell::FalseOccupied => Some(RGBColor(150, 180, 230)),
        MapCell::FalseFree => Some(RGBColor(230, 20, 20)),
    };
    panel(
        &left,
        "exact image",
        cells,
        &exact,
        &[("collides", RGBColor(40, 40, 40))],
    )?;
    panel(
        &right,
        "map",
        cells,
        &map,
        &[
            ("marked, collides", RGBColor(40, 40, 40)),
            ("marked, free (margin)", RGBColor(150, 180, 230)),
            ("false free", RGBColor(230, 20, 20)),
        ],
    )?;
    root.present().map_err(err)
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

/// A chart over a C-space map's area.
type TorusChart<'a, 'b> = ChartContext<
    'a,
    BitMapBackend<'b>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// A C-space chart on `area`: theta1 across, theta2 (`y_desc`) up, both -pi..pi as in the
/// thesis's figures, with `caption` at its size and `margin`.
fn torus_chart<'a, 'b>(
    area: &'a Area<'b>,
    caption: (&str, u32),
    margin: u32,
    y_desc: &str,
) -> Result<TorusChart<'a, 'b>, String> {
    use std::f64::consts::PI;
    let mut c = ChartBuilder::on(area)
        .caption(caption.0, ("sans-serif", caption.1))
        .margin(margin)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(-PI..PI, -PI..PI)
        .map_err(err)?;
    c.configure_mesh()
        .disable_mesh()
        .x_desc("theta1 (rad)")
        .y_desc(y_desc)
        .draw()
        .map_err(err)?;
    Ok(c)
}

/// Draws every map pixel `colour` gives a colour (pixel `k` = i2 x 128 + i1 covers
/// [i, i + 1) pixels of 2 pi / 128 on each axis, shown in -pi..pi) and a legend entry per
/// key.
fn draw_pixels(
    c: &mut TorusChart<'_, '_>,
    colour: impl Fn(usize) -> Option<RGBColor>,
    keys: &[(&str, RGBColor)],
) -> Result<(), String> {
    use std::f64::consts::{PI, TAU};
    let px = TAU / 128.0;
    let at = |i: usize| (i as f64 * px + PI).rem_euclid(TAU) - PI;
    let mut rects = Vec::new();
    for i2 in 0..128usize {
        for i1 in 0..128usize {
            if let Some(col) = colour(i2 * 128 + i1) {
                let (x, y) = (at(i1), at(i2));
                rects.push(Rectangle::new([(x, y), (x + px, y + px)], col.filled()));
            }
        }
    }
    c.draw_series(rects).map_err(err)?;
    for &(label, col) in keys {
        c.draw_series(std::iter::empty::<Rectangle<(f64, f64)>>())
            .map_err(err)?
            .label(label)
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 10, y + 5)], col.filled()));
    }
    Ok(())
}

fn panel(
    area: &Area<'_>,
    caption: &str,
    cells: &[MapCell],
    colour: &dyn Fn(MapCell) -> Option<RGBColor>,
    keys: &[(&str, RGBColor)],
) -> Result<(), String> {
    let mut c = torus_chart(area, (caption, 16), 10, "theta2 (rad)")?;
    draw_pixels(&mut c, |k| colour(cells[k]), keys)?;
    // Top left: the images sit in the middle of the map.
    c.configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(err)
}

/// What the C-space path picture shows besides the arm's path.
pub struct PathPicture<'a> {
    /// Pixels marked in the map (`[i2 * 128 + i1]`).
    pub marked: &'a [bool],
    /// Pixels that hold a colliding configuration (the exact image), same indexing.
    pub exact: &'a [bool],
    /// The goal (absolute angles), if any.
    pub goal: Option<[f64; 2]>,
    /// An oracle's path to overlay (absolute angles), or none.
    pub oracle: &'a [[f64; 2]],
}

/// Writes a C-space picture of a run (like thesis figs. V.6-V.10 and VI.3-VI.5): the map at
/// the end (marked pixels light, those holding a collision dark), the arm's path in joint
/// space, the reflex subgoals it was given (dots; escapes and stops in other colours), its
/// start and end, and the goal. Angles are shown in -pi..pi (the torus cut open).
pub fn cspace_path(
    path: &Path,
    title: &str,
    pic: &PathPicture,
    s: &[Sample],
) -> Result<(), String> {
    use std::f64::consts::{PI, TAU};
    use vme_map::records::reflex_flags as rf;
    font()?;
    let root = BitMapBackend::new(path, (760, 760)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let mut c = torus_chart(&root, (title, 18), 12, "theta2 (rad, absolute)")?;
    let (dark, light) = (RGBColor(60, 60, 60), RGBColor(170, 190, 225));
    draw_pixels(
        &mut c,
        |k| {
            if pic.exact[k] {
                Some(dark)
            } else if pic.marked[k] {
                Some(light)
            } else {
                None
            }
        },
        &[("map: collides", dark), ("map: margin", light)],
    )?;
    let wrap = |a: f64| (a + PI).rem_euclid(TAU) - PI;
    // The path, cut where it wraps around the torus.
    let mut pieces: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
    let mut last: Option<(f64, f64)> = None;
    for q in s {
        let p = (wrap(q.theta_rad[0]), wrap(q.theta_rad[1]));
        if let Some(l) = last {
            if (p.0 - l.0).abs() > PI || (p.1 - l.1).abs() > PI {
                pieces.push(Vec::new());
            }
        }
        pieces.last_mut().expect("one piece").push(p);
        last = Some(p);
    }
    for (k, piece) in pieces.into_iter().enumerate() {
        let series = c
            .draw_series(LineSeries::new(piece, RED.stroke_width(2)))
            .map_err(err)?;
        if k == 0 {
            series
                .label("arm")
                .legend(|(x, y)| PathElement::new([(x, y), (x + 14, y)], RED.stroke_width(2)));
        }
    }
    if !pic.oracle.is_empty() {
        let mut pieces: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
        let mut last: Option<(f64, f64)> = None;
        for q in pic.oracle {
            let p = (wrap(q[0]), wrap(q[1]));
            if let Some(l) = last {
                if (p.0 - l.0).abs() > PI || (p.1 - l.1).abs() > PI {
                    pieces.push(Vec::new());
                }
            }
            pieces.last_mut().expect("one piece").push(p);
            last = Some(p);
        }
        let col = RGBColor(0, 150, 60);
        for (k, piece) in pieces.into_iter().enumerate() {
            let series = c
                .draw_series(LineSeries::new(piece, col.stroke_width(2)))
                .map_err(err)?;
            if k == 0 {
                series.label("oracle (A*)").legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 14, y)], col.stroke_width(2))
                });
            }
        }
    }
    let dots = |want: u32, none: u32| {
        s.iter()
            .filter(move |q| q.reflex_flags & want == want && q.reflex_flags & none == 0)
            .filter_map(|q| q.subgoal_rad)
            .map(|g| (wrap(g[0]), wrap(g[1])))
            .collect::<Vec<_>>()
    };
    for (label, want, none, col) in [
        (
            "subgoal",
            0,
            rf::ESCAPING | rf::BRAKING | rf::HOLD,
            RGBColor(30, 110, 220),
        ),
        ("subgoal, braking", rf::BRAKING, 0, RGBColor(240, 150, 0)),
        ("subgoal, escaping", rf::ESCAPING, 0, RGBColor(160, 0, 160)),
        ("hold (fault)", rf::HOLD, 0, RGBColor(0, 0, 0)),
    ] {
        let pts = dots(want, none);
        if pts.is_empty() {
            continue;
        }
        c.draw_series(pts.into_iter().map(|p| Circle::new(p, 2, col.filled())))
            .map_err(err)?
            .label(label)
            .legend(move |(x, y)| Circle::new((x + 5, y), 3, col.filled()));
    }
    if let (Some(a), Some(b)) = (s.first(), s.last()) {
        for (label, q, col) in [("start", a, GREEN), ("end", b, BLACK)] {
            let p = (wrap(q.theta_rad[0]), wrap(q.theta_rad[1]));
            c.draw_series([TriangleMarker::new(p, 8, col.filled())])
                .map_err(err)?
                .label(label)
                .legend(move |(x, y)| TriangleMarker::new((x + 5, y), 6, col.filled()));
        }
    }
    if let Some(g) = pic.goal {
        let p = (wrap(g[0]), wrap(g[1]));
        c.draw_series([Cross::new(p, 8, BLUE.stroke_width(3))])
            .map_err(err)?
            .label("goal")
            .legend(|(x, y)| Cross::new((x + 5, y), 5, BLUE.stroke_width(2)));
    }
    c.configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(err)?;
    root.present().map_err(err)
}

/// The sensing bench's picture (like thesis fig. II.7): on the left the calibration scan's
/// signal lines (tip x volts against y volts, one line per 2 cm row of the grid); in the
/// middle and on the right the survey's mean error at each point as an arrow, for the
/// thesis's firmware and ours, both with drift and LED intensity errors on.
pub fn sensing_errors(
    path: &Path,
    cases: &[crate::sensing_bench::CaseResult],
) -> Result<(), String> {
    use crate::sensing_cal::{N, Q5_PER_V};
    font()?;
    let root = BitMapBackend::new(path, (1800, 640)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let root = root
        .titled(
            "sensing: calibration scan and position errors",
            ("sans-serif", 22),
        )
        .map_err(err)?;
    let panels = root.split_evenly((1, 3));
    let scan = cases
        .iter()
        .find(|c| c.case.warmth > 0.0 && c.case.options != 0)
        .or(cases.first())
        .ok_or("no case")?;
    let mut c = ChartBuilder::on(&panels[0])
        .caption("scan: tip signals, 36 rows 2 cm apart", ("sans-serif", 16))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(-10.0..10.0, -10.0..10.0)
        .map_err(err)?;
    c.configure_mesh()
        .x_desc("x signal (V)")
        .y_desc("y signal (V)")
        .draw()
        .map_err(err)?;
    for j in 0..N {
        let row: Vec<(f64, f64)> = (0..N)
            .map(|i| {
                let s = scan.scan_signals_q5[j * N + i];
                (s[0] / Q5_PER_V, s[1] / Q5_PER_V)
            })
            .collect();
        c.draw_series(LineSeries::new(row, BLUE.stroke_width(1)))
            .map_err(err)?;
        let col: Vec<(f64, f64)> = (0..N)
            .map(|i| {
                let s = scan.scan_signals_q5[i * N + j];
                (s[0] / Q5_PER_V, s[1] / Q5_PER_V)
            })
            .collect();
        c.draw_series(LineSeries::new(col, BLUE.mix(0.3).stroke_width(1)))
            .map_err(err)?;
    }
    for (k, (want_thesis, scale)) in [(true, 2.0), (false, 20.0)].into_iter().enumerate() {
        let Some(case) = cases.iter().find(|c| {
            c.case.warmth > 0.0 && c.case.optics.intensity && (c.case.options == 0) == want_thesis
        }) else {
            continue;
        };
        let title = format!(
            "{}: error x{scale} (rms {:.1} mm, max {:.1} mm)",
            case.case.name, case.errors.rms_mm, case.errors.max_mm
        );
        let mut c = ChartBuilder::on(&panels[k + 1])
            .caption(title, ("sans-serif", 14))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(-0.4..0.4, -0.4..0.4)
            .map_err(err)?;
        c.configure_mesh()
            .x_desc("x (m)")
            .y_desc("y (m)")
            .draw()
            .map_err(err)?;
        for p in &case.errors.points {
            let from = (p[0], p[1]);
            let to = (p[0] + scale * p[2], p[1] + scale * p[3]);
            c.draw_series(LineSeries::new([from, to], RED.stroke_width(1)))
                .map_err(err)?;
            c.draw_series(std::iter::once(Circle::new(from, 1, BLACK.filled())))
                .map_err(err)?;
        }
    }
    root.present().map_err(err)
}
