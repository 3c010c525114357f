//! Figures for the CLI's `--out DIR`: a top-view trajectory plot (paper
//! Fig. 4-like) and stacked time-series panels. Each figure is written twice,
//! as `<stem>.png` (BitMapBackend) and `<stem>.svg` (SVGBackend).
//!
//! Text is laid out and rasterised with `ab_glyph` from a font embedded in the
//! binary (`assets/DejaVuSans.ttf`, license in
//! `assets/DejaVuSans-LICENSE.txt`), so no system font library
//! (fontconfig/freetype) is needed. The SVG output names the family
//! `sans-serif`; the viewer substitutes its own sans-serif face.
//!
//! Robustness rules: NaN and ±inf samples are gaps (the line is broken there),
//! never coordinates; empty inputs give an empty but valid figure.

use crate::algo::geometry::Vec2;
use anyhow::{anyhow, Context, Result};
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{register_font, FontStyle};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// DejaVu Sans (Bitstream Vera license + Arev license, see
/// `assets/DejaVuSans-LICENSE.txt`).
static FONT_BYTES: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// Family name all our text uses; it is also plotters' default family for
/// tick labels and legends.
const FONT: &str = "sans-serif";

const TITLE_PX: u32 = 26;
const LABEL_PX: u32 = 16;
const DESC_PX: u32 = 18;
const LEGEND_PX: u32 = 16;

/// Tableau-10: distinct, colour-blind-friendly enough, readable on white.
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

const ROBOT_COLOR: RGBColor = PALETTE[0];
/// Black (dashed), so that the palette's second colour can be a compared path.
const REFERENCE_COLOR: RGBColor = RGBColor(0, 0, 0);
const GOAL_COLOR: RGBColor = PALETTE[2];
const COLLISION_COLOR: RGBColor = PALETTE[3];
const MOVER_COLOR: RGBColor = PALETTE[4];
const SAFETY_COLOR: RGBColor = PALETTE[9];
/// Colours of compared paths (`TrajectoryPlot::other_paths`): the same as
/// the second, third… series of a time-series plot, so one controller has one
/// colour in every figure of a comparison.
const OTHER_PATH_COLORS: [RGBColor; 4] = [PALETTE[1], PALETTE[2], PALETTE[3], PALETTE[5]];
const WALL_COLOR: RGBColor = RGBColor(60, 60, 60);
const OBSTACLE_COLOR: RGBColor = RGBColor(110, 110, 110);

/// Registers the embedded font with plotters once per process. Registered
/// under the generic family names so plotters' defaults (tick labels, legend)
/// find it too; bold/italic requests fall back to this regular face.
fn ensure_fonts() -> Result<()> {
    static REGISTERED: OnceLock<std::result::Result<(), FontRejected>> = OnceLock::new();
    let registered = REGISTERED.get_or_init(|| {
        for family in ["sans-serif", "serif", "monospace"] {
            register_font(family, FontStyle::Normal, FONT_BYTES).map_err(|_| FontRejected)?;
        }
        Ok(())
    });
    Ok((*registered)?)
}

/// plotters refused the embedded font (its own error carries nothing and is
/// not an `Error`). Remembered once per process, hence `Copy`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("embedded font DejaVuSans.ttf was rejected")]
struct FontRejected;

/// plotters' error types are generic over the backend; flatten them to text.
fn pe<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("plotting failed: {e}")
}

/// `<stem>.<ext>` without replacing anything that looks like an extension in
/// the stem (`run.v2` → `run.v2.png`).
fn with_ext(stem: &Path, ext: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// A figure that can draw itself on any plotters backend.
trait Figure {
    fn size(&self) -> (u32, u32);
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>;
}

fn render_both<F: Figure>(stem: &Path, fig: &F) -> Result<()> {
    ensure_fonts()?;
    if let Some(dir) = stem.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating plot directory {}", dir.display()))?;
    }
    let size = fig.size();

    let png = with_ext(stem, "png");
    {
        let root = BitMapBackend::new(&png, size).into_drawing_area();
        fig.draw(&root)
            .and_then(|()| root.present().map_err(pe))
            .with_context(|| format!("writing {}", png.display()))?;
    }

    let svg = with_ext(stem, "svg");
    {
        let root = SVGBackend::new(&svg, size).into_drawing_area();
        fig.draw(&root)
            .and_then(|()| root.present().map_err(pe))
            .with_context(|| format!("writing {}", svg.display()))?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// Shared helpers
// ---------------------------------------------------------------------------

/// Coordinates beyond this (m) are treated like non-finite ones: no robot
/// world is that large, and plotting them would overflow the axis span.
const COORD_LIMIT_M: f64 = 1e9;

/// Axis ranges are confined to ±this so that their span stays finite
/// (plotters' tick search does not terminate on an infinite span).
const AXIS_LIMIT: f64 = 1e300;

fn finite2(p: &Vec2) -> bool {
    p.x.abs() <= COORD_LIMIT_M && p.y.abs() <= COORD_LIMIT_M
}

/// Splits a polyline at non-finite points into runs of finite points.
fn finite_runs(points: &[Vec2]) -> Vec<Vec<(f64, f64)>> {
    let mut runs = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    for p in points {
        if finite2(p) {
            cur.push((p.x, p.y));
        } else if !cur.is_empty() {
            runs.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        runs.push(cur);
    }
    runs
}

/// Closed polygon approximating a circle (data coordinates).
fn circle_points(c: Vec2, r: f64, n: usize) -> Vec<(f64, f64)> {
    (0..=n)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            (c.x + r * a.cos(), c.y + r * a.sin())
        })
        .collect()
}

fn valid_circle(c: &Vec2, r: f64) -> bool {
    finite2(c) && r.is_finite() && r > 0.0
}

/// Axis-aligned bounds accumulated from finite values only.
#[derive(Debug, Clone, Copy)]
struct Bounds {
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
}

impl Bounds {
    fn empty() -> Self {
        Self {
            x0: f64::INFINITY,
            x1: f64::NEG_INFINITY,
            y0: f64::INFINITY,
            y1: f64::NEG_INFINITY,
        }
    }

    fn is_empty(&self) -> bool {
        self.x0 > self.x1 || self.y0 > self.y1
    }

    fn add(&mut self, p: Vec2, pad: f64) {
        let pad = if pad.is_finite() { pad.max(0.0) } else { 0.0 };
        if finite2(&p) {
            self.x0 = self.x0.min(p.x - pad);
            self.x1 = self.x1.max(p.x + pad);
            self.y0 = self.y0.min(p.y - pad);
            self.y1 = self.y1.max(p.y + pad);
        }
    }
}

/// Scientific-notation tick labels for ranges whose plain digits would not
/// fit the label area (|v| ≥ 1e5 or all |v| < 1e-3); `None` keeps plotters'
/// default formatting.
fn sci_formatter(lo: f64, hi: f64) -> Option<impl Fn(&f64) -> String> {
    let m = lo.abs().max(hi.abs());
    let span = (hi - lo).abs();
    let extreme = m >= 1e5 || (m > 0.0 && m < 1e-3);
    if !extreme || !span.is_finite() || span <= 0.0 {
        return None;
    }
    // Enough digits to tell neighbouring ticks apart.
    let prec = (((m / span).log10().ceil() as i64) + 1).clamp(1, 15) as usize;
    Some(move |v: &f64| {
        if *v == 0.0 {
            "0".to_string()
        } else {
            format!("{v:.prec$e}")
        }
    })
}

// ---------------------------------------------------------------------------
// Trajectory plot
// ---------------------------------------------------------------------------

/// Data for the trajectory plot (paper Fig. 4-like top view).
pub struct TrajectoryPlot<'a> {
    pub title: &'a str,
    /// Robot centre over time (m, world frame).
    pub robot_path: &'a [Vec2],
    /// Its legend entry, e.g. "robot path" or the controller's name.
    pub robot_label: &'a str,
    /// Further paths to compare with it (label, centre over time), each in
    /// its own colour, without safety perimeter or body.
    pub other_paths: &'a [(String, Vec<Vec2>)],
    /// Reference trajectory (m); may be empty.
    pub reference_path: &'a [Vec2],
    /// Static segments.
    pub walls: &'a [(Vec2, Vec2)],
    /// Static circles (centre, radius m).
    pub circles: &'a [(Vec2, f64)],
    /// Each moving obstacle's centre track over the run and its radius.
    pub mover_paths: &'a [(Vec<Vec2>, f64)],
    /// r + d_safe: drawn around the robot at regular intervals along the path.
    pub safety_radius_m: f64,
    /// Physical robot radius: the robot disc is drawn at start and end.
    pub body_radius_m: f64,
    /// Robot positions where a collision began: red crosses.
    pub collisions: &'a [Vec2],
    /// Goal marker.
    pub goal: Option<Vec2>,
}

/// Writes `<stem>.png` and `<stem>.svg`: a top view with equal aspect ratio
/// (1 m in x = 1 m in y), legend, axes "x (m)" / "y (m)".
pub fn plot_trajectory(stem: &Path, plot: &TrajectoryPlot<'_>) -> Result<()> {
    render_both(stem, &TrajectoryFigure::new(plot))
}

/// Layout of the trajectory figure (pixels): chart on the left, legend strip
/// on the right (outside the data, so it never hides the path).
const TRAJ_CHART_WIDTH: u32 = 900;
const TRAJ_LEGEND_WIDTH: u32 = 300;
const TRAJ_MARGIN: u32 = 15;
const TRAJ_X_LABEL_AREA: u32 = 60;
const TRAJ_Y_LABEL_AREA: u32 = 75;
/// Title strip height estimate, used only to choose the image height.
const TRAJ_TITLE_STRIP: u32 = 45;
/// Target number of safety-perimeter circles along the path.
const SAFETY_CIRCLES: usize = 20;

struct TrajectoryFigure<'p, 'a> {
    plot: &'p TrajectoryPlot<'a>,
    /// Data bounds with margin (before the isotropic expansion).
    bounds: Bounds,
    size: (u32, u32),
}

impl<'p, 'a> TrajectoryFigure<'p, 'a> {
    fn new(plot: &'p TrajectoryPlot<'a>) -> Self {
        let bounds = trajectory_bounds(plot);
        // Height so that the data's aspect ratio roughly fills the chart;
        // the exact isotropy is then made by widening one axis range.
        let plot_w = TRAJ_CHART_WIDTH - 2 * TRAJ_MARGIN - TRAJ_Y_LABEL_AREA;
        let overhead_h = TRAJ_TITLE_STRIP + 2 * TRAJ_MARGIN + TRAJ_X_LABEL_AREA;
        let aspect = (bounds.y1 - bounds.y0) / (bounds.x1 - bounds.x0);
        let h = overhead_h as f64 + plot_w as f64 * aspect;
        let h = if h.is_finite() { h } else { 1000.0 };
        let height = h.round().clamp(500.0, 1300.0) as u32;
        Self {
            plot,
            bounds,
            size: (TRAJ_CHART_WIDTH + TRAJ_LEGEND_WIDTH, height),
        }
    }
}

/// Data bounds of everything drawn, with a margin; never degenerate.
fn trajectory_bounds(p: &TrajectoryPlot<'_>) -> Bounds {
    let mut b = Bounds::empty();
    let safety = p.safety_radius_m.max(p.body_radius_m);
    for q in p.robot_path {
        b.add(*q, safety);
    }
    for q in p.reference_path {
        b.add(*q, 0.0);
    }
    for q in p.other_paths.iter().flat_map(|(_, path)| path) {
        b.add(*q, p.body_radius_m);
    }
    for (a, c) in p.walls {
        if finite2(a) && finite2(c) {
            b.add(*a, 0.0);
            b.add(*c, 0.0);
        }
    }
    for (c, r) in p.circles {
        if valid_circle(c, *r) {
            b.add(*c, *r);
        }
    }
    for (track, r) in p.mover_paths {
        for q in track {
            b.add(*q, *r);
        }
    }
    for q in p.collisions {
        b.add(*q, 0.0);
    }
    if let Some(g) = p.goal {
        b.add(g, 0.0);
    }
    if b.is_empty() {
        return Bounds {
            x0: -1.0,
            x1: 1.0,
            y0: -1.0,
            y1: 1.0,
        };
    }
    // At least 1 m of span in each direction, then a margin.
    let (cx, cy) = (0.5 * (b.x0 + b.x1), 0.5 * (b.y0 + b.y1));
    let sx = (b.x1 - b.x0).max(1.0);
    let sy = (b.y1 - b.y0).max(1.0);
    let m = 0.05 * sx.max(sy) + 0.2;
    Bounds {
        x0: cx - 0.5 * sx - m,
        x1: cx + 0.5 * sx + m,
        y0: cy - 0.5 * sy - m,
        y1: cy + 0.5 * sy + m,
    }
}

/// Expands `b` in one direction so that a `pw × ph` pixel plotting area shows
/// it with equal metres per pixel in x and y (centre kept).
fn isotropic(b: Bounds, pw: u32, ph: u32) -> Bounds {
    let (pw, ph) = (pw.max(1) as f64, ph.max(1) as f64);
    let (sx, sy) = (b.x1 - b.x0, b.y1 - b.y0);
    // Metres per pixel: the larger requirement wins.
    let mpp = (sx / pw).max(sy / ph);
    let (cx, cy) = (0.5 * (b.x0 + b.x1), 0.5 * (b.y0 + b.y1));
    let (hx, hy) = (0.5 * mpp * pw, 0.5 * mpp * ph);
    Bounds {
        x0: cx - hx,
        x1: cx + hx,
        y0: cy - hy,
        y1: cy + hy,
    }
}

/// What a legend entry shows left of its label.
#[derive(Clone, Copy)]
enum Swatch {
    Line(ShapeStyle),
    Dashed(ShapeStyle),
    /// Disc with optional fill and an outline (dashed or solid).
    Disc {
        fill: Option<ShapeStyle>,
        edge: ShapeStyle,
        dashed: bool,
    },
    Cross(ShapeStyle),
    Goal,
}

/// Draws `entries` top-down in `area` (pixel coordinates of the area).
fn draw_legend<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, entries: &[(String, Swatch)]) -> Result<()> {
    if entries.is_empty() {
        return Ok(());
    }
    const ROW: i32 = 28;
    const X0: i32 = 8;
    let top = 12;
    let (w, _) = area.dim_in_pixel();
    let h = ROW * entries.len() as i32 + 12;
    area.draw(&Rectangle::new(
        [(0, top - 6), (w as i32 - 10, top - 6 + h)],
        BLACK.mix(0.5).stroke_width(1),
    ))
    .map_err(pe)?;
    let text = TextStyle::from((FONT, LEGEND_PX).into_font())
        .color(&BLACK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    for (i, (label, swatch)) in entries.iter().enumerate() {
        let y = top + ROW / 2 + ROW * i as i32;
        let (xa, xb, xc) = (X0, X0 + 26, X0 + 13);
        match *swatch {
            Swatch::Line(s) => area.draw(&PathElement::new(vec![(xa, y), (xb, y)], s)).map_err(pe)?,
            Swatch::Dashed(s) => {
                for (a, b) in [(xa, xa + 7), (xa + 11, xa + 18), (xa + 22, xb)] {
                    area.draw(&PathElement::new(vec![(a, y), (b, y)], s)).map_err(pe)?;
                }
            }
            Swatch::Disc { fill, edge, dashed } => {
                if let Some(f) = fill {
                    area.draw(&Circle::new((xc, y), 9, f)).map_err(pe)?;
                }
                if dashed {
                    let pts: Vec<(i32, i32)> = (0..=24)
                        .map(|k| {
                            let a = std::f64::consts::TAU * k as f64 / 24.0;
                            (xc + (9.0 * a.cos()).round() as i32, y + (9.0 * a.sin()).round() as i32)
                        })
                        .collect();
                    for seg in pts.windows(2).step_by(2) {
                        area.draw(&PathElement::new(seg.to_vec(), edge)).map_err(pe)?;
                    }
                } else {
                    area.draw(&Circle::new((xc, y), 9, edge)).map_err(pe)?;
                }
            }
            Swatch::Cross(s) => area.draw(&Cross::new((xc, y), 7, s)).map_err(pe)?,
            Swatch::Goal => {
                area.draw(&Circle::new((xc, y), 8, GOAL_COLOR.filled())).map_err(pe)?;
                area.draw(&Circle::new((xc, y), 8, BLACK.stroke_width(2))).map_err(pe)?;
                area.draw(&Circle::new((xc, y), 2, WHITE.filled())).map_err(pe)?;
            }
        }
        area.draw_text(label, &text, (xb + 12, y)).map_err(pe)?;
    }
    Ok(())
}

impl Figure for TrajectoryFigure<'_, '_> {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        draw_trajectory(root, self.plot, self.bounds).map(|_| ())
    }
}

/// Draws the trajectory figure; returns the plotted ranges and the plotting
/// area size in pixels (for the isotropy test).
fn draw_trajectory<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    p: &TrajectoryPlot<'_>,
    bounds: Bounds,
) -> Result<(Bounds, (u32, u32))> {
    root.fill(&WHITE).map_err(pe)?;
    let area = root.titled(p.title, (FONT, TITLE_PX)).map_err(pe)?;
    let (chart_area, legend_area) = area.split_horizontally(TRAJ_CHART_WIDTH);
    let legend_area = legend_area.margin(TRAJ_MARGIN, 0, 0, 0);

    let mut builder = ChartBuilder::on(&chart_area);
    builder
        .margin(TRAJ_MARGIN)
        .x_label_area_size(TRAJ_X_LABEL_AREA)
        .y_label_area_size(TRAJ_Y_LABEL_AREA);
    // Probe the plotting-area size (building draws nothing without a
    // caption), then choose ranges with equal metres per pixel.
    let (pw, ph) = builder
        .build_cartesian_2d(0f64..1f64, 0f64..1f64)
        .map_err(pe)?
        .plotting_area()
        .dim_in_pixel();
    let r = isotropic(bounds, pw, ph);
    let mut chart = builder.build_cartesian_2d(r.x0..r.x1, r.y0..r.y1).map_err(pe)?;

    {
        let xf = sci_formatter(r.x0, r.x1);
        let yf = sci_formatter(r.y0, r.y1);
        let mut mesh = chart.configure_mesh();
        mesh.x_desc("x (m)")
            .y_desc("y (m)")
            .label_style((FONT, LABEL_PX))
            .axis_desc_style((FONT, DESC_PX))
            .bold_line_style(BLACK.mix(0.12))
            .light_line_style(BLACK.mix(0.04));
        if let Some(f) = &xf {
            mesh.x_label_formatter(f);
        }
        if let Some(f) = &yf {
            mesh.y_label_formatter(f);
        }
        mesh.draw().map_err(pe)?;
    }

    let mut legend: Vec<(String, Swatch)> = Vec::new();
    const N: usize = 72; // polygon vertices per circle

    // Walls.
    let walls: Vec<_> = p.walls.iter().filter(|(a, b)| finite2(a) && finite2(b)).collect();
    if !walls.is_empty() {
        let s = WALL_COLOR.stroke_width(3);
        chart
            .draw_series(
                walls
                    .iter()
                    .map(|(a, b)| PathElement::new(vec![(a.x, a.y), (b.x, b.y)], s)),
            )
            .map_err(pe)?;
        legend.push(("walls".into(), Swatch::Line(s)));
    }

    // Static circles.
    let circles: Vec<_> = p.circles.iter().filter(|(c, r)| valid_circle(c, *r)).collect();
    if !circles.is_empty() {
        let fill = OBSTACLE_COLOR.mix(0.45).filled();
        let edge = OBSTACLE_COLOR.stroke_width(2);
        chart
            .draw_series(
                circles
                    .iter()
                    .map(|(c, r)| Polygon::new(circle_points(*c, *r, N), fill)),
            )
            .map_err(pe)?;
        chart
            .draw_series(
                circles
                    .iter()
                    .map(|(c, r)| PathElement::new(circle_points(*c, *r, N), edge)),
            )
            .map_err(pe)?;
        legend.push((
            "static obstacles".into(),
            Swatch::Disc {
                fill: Some(fill),
                edge,
                dashed: false,
            },
        ));
    }

    // Moving obstacles: faint track, dashed outline at the start, filled disc
    // at the end.
    let track_style = MOVER_COLOR.mix(0.45).stroke_width(2);
    let mover_edge = MOVER_COLOR.stroke_width(2);
    let mover_fill = MOVER_COLOR.mix(0.35).filled();
    let (mut any_track, mut any_disc) = (false, false);
    for (track, r) in p.mover_paths {
        for run in finite_runs(track) {
            chart.draw_series(LineSeries::new(run, track_style)).map_err(pe)?;
            any_track = true;
        }
        if !(r.is_finite() && *r > 0.0) {
            continue;
        }
        if let Some(s) = track.iter().find(|q| finite2(q)) {
            chart
                .draw_series(std::iter::once(DashedPathElement::new(
                    circle_points(*s, *r, N),
                    6,
                    4,
                    mover_edge,
                )))
                .map_err(pe)?;
            any_disc = true;
        }
        if let Some(e) = track.iter().rev().find(|q| finite2(q)) {
            chart
                .draw_series([Polygon::new(circle_points(*e, *r, N), mover_fill)])
                .map_err(pe)?;
            chart
                .draw_series([PathElement::new(circle_points(*e, *r, N), mover_edge)])
                .map_err(pe)?;
        }
    }
    if any_track {
        legend.push(("moving obstacle track".into(), Swatch::Line(track_style)));
    }
    if any_disc {
        legend.push((
            "moving obstacle at start".into(),
            Swatch::Disc {
                fill: None,
                edge: mover_edge,
                dashed: true,
            },
        ));
        legend.push((
            "moving obstacle at end".into(),
            Swatch::Disc {
                fill: Some(mover_fill),
                edge: mover_edge,
                dashed: false,
            },
        ));
    }

    // Reference trajectory, dashed.
    let ref_style = REFERENCE_COLOR.stroke_width(2);
    let ref_runs = finite_runs(p.reference_path);
    for run in &ref_runs {
        chart
            .draw_series(DashedLineSeries::new(run.iter().copied(), 10, 6, ref_style))
            .map_err(pe)?;
    }
    if !ref_runs.is_empty() {
        legend.push(("reference".into(), Swatch::Dashed(ref_style)));
    }

    // Safety perimeter r + d_safe every N samples (~SAFETY_CIRCLES circles).
    let finite_path: Vec<Vec2> = p.robot_path.iter().copied().filter(finite2).collect();
    let sr = p.safety_radius_m;
    if !finite_path.is_empty() && sr.is_finite() && sr > 0.0 {
        let step = finite_path.len().div_ceil(SAFETY_CIRCLES).max(1);
        let mut centres: Vec<Vec2> = finite_path.iter().copied().step_by(step).collect();
        if let Some(last) = finite_path.last() {
            if centres.last() != Some(last) {
                centres.push(*last);
            }
        }
        let s: ShapeStyle = SAFETY_COLOR.mix(0.6).into();
        chart
            .draw_series(centres.iter().map(|c| PathElement::new(circle_points(*c, sr, N), s)))
            .map_err(pe)?;
        legend.push((
            format!("safety perimeter ({sr:.2} m)"),
            Swatch::Disc {
                fill: None,
                edge: s,
                dashed: false,
            },
        ));
    }

    // Robot path.
    let path_style = ROBOT_COLOR.stroke_width(3);
    let path_runs = finite_runs(p.robot_path);
    for run in &path_runs {
        chart
            .draw_series(LineSeries::new(run.iter().copied(), path_style))
            .map_err(pe)?;
    }
    if !path_runs.is_empty() {
        legend.push((p.robot_label.to_string(), Swatch::Line(path_style)));
    }

    // Compared paths, in colours the figure does not otherwise use.
    for (k, (label, path)) in p.other_paths.iter().enumerate() {
        let style = OTHER_PATH_COLORS[k % OTHER_PATH_COLORS.len()].stroke_width(3);
        for run in finite_runs(path) {
            chart.draw_series(LineSeries::new(run, style)).map_err(pe)?;
        }
        legend.push((label.clone(), Swatch::Line(style)));
    }

    // Robot body at start and end.
    let br = p.body_radius_m;
    if !finite_path.is_empty() && br.is_finite() && br > 0.0 {
        let ends = [finite_path[0], finite_path[finite_path.len() - 1]];
        let fill = ROBOT_COLOR.mix(0.3).filled();
        let edge = ROBOT_COLOR.stroke_width(2);
        chart
            .draw_series(ends.iter().map(|c| Polygon::new(circle_points(*c, br, N), fill)))
            .map_err(pe)?;
        chart
            .draw_series(ends.iter().map(|c| PathElement::new(circle_points(*c, br, N), edge)))
            .map_err(pe)?;
        legend.push((
            "robot body (start, end)".into(),
            Swatch::Disc {
                fill: Some(fill),
                edge,
                dashed: false,
            },
        ));
    }

    // Collisions.
    let hits: Vec<_> = p.collisions.iter().filter(|q| finite2(q)).collect();
    if !hits.is_empty() {
        let s = COLLISION_COLOR.stroke_width(3);
        chart
            .draw_series(hits.iter().map(|q| Cross::new((q.x, q.y), 9, s)))
            .map_err(pe)?;
        legend.push((format!("collision ({})", hits.len()), Swatch::Cross(s)));
    }

    // Goal.
    if let Some(g) = p.goal.filter(finite2) {
        chart
            .draw_series(std::iter::once(
                EmptyElement::at((g.x, g.y))
                    + Circle::new((0, 0), 10, GOAL_COLOR.filled())
                    + Circle::new((0, 0), 10, BLACK.stroke_width(2))
                    + Circle::new((0, 0), 3, WHITE.filled()),
            ))
            .map_err(pe)?;
        legend.push(("goal".into(), Swatch::Goal));
    }

    draw_legend(&legend_area, &legend)?;
    Ok((r, chart.plotting_area().dim_in_pixel()))
}

// ---------------------------------------------------------------------------
// Time series
// ---------------------------------------------------------------------------

/// One line in a time-series panel.
pub struct Series<'a> {
    pub label: &'a str,
    pub values: &'a [f64],
}

/// A stack of time-series panels sharing the x axis (time).
pub struct TimePanel<'a> {
    pub y_label: &'a str,
    pub series: Vec<Series<'a>>,
    /// `None`: automatic from the finite values with a 5 % margin. Values
    /// outside the range are clipped to its edge.
    pub y_range: Option<(f64, f64)>,
}

/// Writes `<stem>.png` and `<stem>.svg`: panels stacked vertically sharing
/// x = "t (s)", each with its own legend. NaN and ±inf are gaps; samples
/// beyond the shorter of `t_s` and a series' values are ignored.
pub fn plot_time_series(stem: &Path, title: &str, t_s: &[f64], panels: &[TimePanel<'_>]) -> Result<()> {
    let n = panels.len().max(1) as u32;
    let height = if n <= 2 { 800 } else { 80 + 300 * n };
    render_both(
        stem,
        &TimeSeriesFigure {
            title,
            t_s,
            panels,
            size: (1200, height),
        },
    )
}

struct TimeSeriesFigure<'p, 'a> {
    title: &'p str,
    t_s: &'p [f64],
    panels: &'p [TimePanel<'a>],
    size: (u32, u32),
}

/// Range of the finite values with a 5 % margin; a constant (or single)
/// value gives ±1 around it; no finite value gives `fallback`.
fn auto_range(values: impl Iterator<Item = f64>, fallback: (f64, f64)) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return fallback;
    }
    let (lo, hi) = (lo.max(-AXIS_LIMIT), hi.min(AXIS_LIMIT));
    let span = hi - lo;
    if span <= 0.0 {
        return widen(lo);
    }
    (lo - 0.05 * span, hi + 0.05 * span)
}

/// ±1 around a constant value (more where ±1 is below the value's float
/// resolution, so the range never collapses).
fn widen(v: f64) -> (f64, f64) {
    let d = 1f64.max(v.abs() * 1e-9);
    (v - d, v + d)
}

/// A caller's fixed range, made usable: ordered, finite, non-degenerate.
fn sanitize_range(r: (f64, f64)) -> Option<(f64, f64)> {
    let (a, b) = r;
    if !(a.is_finite() && b.is_finite()) {
        return None;
    }
    let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
    let (lo, hi) = (lo.clamp(-AXIS_LIMIT, AXIS_LIMIT), hi.clamp(-AXIS_LIMIT, AXIS_LIMIT));
    if lo == hi {
        Some(widen(lo))
    } else {
        Some((lo, hi))
    }
}

/// Runs of (t, v) with finite t and v, v clamped to `clip`.
fn series_runs(t: &[f64], v: &[f64], clip: (f64, f64)) -> Vec<Vec<(f64, f64)>> {
    let mut runs = Vec::new();
    let mut cur = Vec::new();
    for (&t, &v) in t.iter().zip(v) {
        if t.is_finite() && v.is_finite() {
            cur.push((t, v.clamp(clip.0, clip.1)));
        } else if !cur.is_empty() {
            runs.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        runs.push(cur);
    }
    runs
}

/// The upper/lower left/right legend corner covering the fewest samples
/// (ties prefer upper right, then upper left).
fn emptiest_corner(pts: &[(f64, f64)], x: (f64, f64), y: (f64, f64)) -> SeriesLabelPosition {
    // A legend covers roughly the outer 30 % in x and 40 % in y.
    let (wx, wy) = (0.3 * (x.1 - x.0), 0.4 * (y.1 - y.0));
    let mut n = [0usize; 4]; // UR, UL, LR, LL
    for &(px, py) in pts {
        let (l, r) = (px <= x.0 + wx, px >= x.1 - wx);
        let (t, b) = (py >= y.1 - wy, py <= y.0 + wy);
        n[0] += usize::from(t && r);
        n[1] += usize::from(t && l);
        n[2] += usize::from(b && r);
        n[3] += usize::from(b && l);
    }
    let best = (0..4).min_by_key(|&i| n[i]).unwrap_or(0);
    [
        SeriesLabelPosition::UpperRight,
        SeriesLabelPosition::UpperLeft,
        SeriesLabelPosition::LowerRight,
        SeriesLabelPosition::LowerLeft,
    ][best]
        .clone()
}

impl Figure for TimeSeriesFigure<'_, '_> {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        root.fill(&WHITE).map_err(pe)?;
        let area = root.titled(self.title, (FONT, TITLE_PX)).map_err(pe)?;

        let (x0, x1) = auto_range(self.t_s.iter().copied(), (0.0, 1.0));
        // Time axis: no 5 % padding, the data fills the width.
        let (x0, x1) = {
            let (lo, hi) = self
                .t_s
                .iter()
                .copied()
                .filter(|t| t.is_finite())
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), t| (l.min(t), h.max(t)));
            let (lo, hi) = (lo.max(-AXIS_LIMIT), hi.min(AXIS_LIMIT));
            if lo < hi {
                (lo, hi)
            } else {
                (x0, x1)
            }
        };

        if self.panels.is_empty() {
            let mut chart = ChartBuilder::on(&area)
                .margin(10)
                .margin_right(25)
                .x_label_area_size(55)
                .y_label_area_size(90)
                .build_cartesian_2d(x0..x1, 0f64..1f64)
                .map_err(pe)?;
            chart
                .configure_mesh()
                .x_desc("t (s)")
                .label_style((FONT, LABEL_PX))
                .axis_desc_style((FONT, DESC_PX))
                .draw()
                .map_err(pe)?;
            return Ok(());
        }

        let areas = area.split_evenly((self.panels.len(), 1));
        let last = self.panels.len() - 1;
        for (i, (panel, a)) in self.panels.iter().zip(&areas).enumerate() {
            let clip = panel.y_range.and_then(sanitize_range);
            let (y0, y1) = clip.unwrap_or_else(|| {
                auto_range(
                    panel.series.iter().flat_map(|s| {
                        let n = s.values.len().min(self.t_s.len());
                        // Only values that will be drawn count (finite t).
                        s.values[..n]
                            .iter()
                            .zip(self.t_s)
                            .filter(|(_, t)| t.is_finite())
                            .map(|(v, _)| *v)
                    }),
                    (-1.0, 1.0),
                )
            });
            let clip = clip.unwrap_or((y0, y1));

            let mut chart = ChartBuilder::on(a)
                .margin(8)
                .margin_right(25)
                .x_label_area_size(if i == last { 55 } else { 30 })
                .y_label_area_size(90)
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(pe)?;
            {
                let xf = sci_formatter(x0, x1);
                let yf = sci_formatter(y0, y1);
                let mut mesh = chart.configure_mesh();
                if let Some(f) = &xf {
                    mesh.x_label_formatter(f);
                }
                if let Some(f) = &yf {
                    mesh.y_label_formatter(f);
                }
                mesh.y_desc(panel.y_label)
                    .label_style((FONT, LABEL_PX))
                    .axis_desc_style((FONT, DESC_PX))
                    .bold_line_style(BLACK.mix(0.12))
                    .light_line_style(BLACK.mix(0.04))
                    .x_labels(12)
                    .y_labels(6);
                if i == last {
                    mesh.x_desc("t (s)");
                }
                mesh.draw().map_err(pe)?;
            }

            let mut any_label = false;
            let mut drawn: Vec<(f64, f64)> = Vec::new();
            for (k, s) in panel.series.iter().enumerate() {
                let color = PALETTE[k % PALETTE.len()];
                let style = color.stroke_width(2);
                let runs = series_runs(self.t_s, s.values, clip);
                drawn.extend(runs.iter().flatten().copied());
                // The first (possibly empty) run carries the legend entry so a
                // series without any finite value is still listed.
                let first = runs.first().cloned().unwrap_or_default();
                let anno = chart.draw_series(LineSeries::new(first, style)).map_err(pe)?;
                if !s.label.is_empty() {
                    anno.label(s.label)
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 22, y)], style));
                    any_label = true;
                }
                for run in runs.iter().skip(1) {
                    chart
                        .draw_series(LineSeries::new(run.iter().copied(), style))
                        .map_err(pe)?;
                }
                // Isolated samples between gaps would otherwise be invisible.
                chart
                    .draw_series(
                        runs.iter()
                            .filter(|r| r.len() == 1)
                            .map(|r| Circle::new(r[0], 3, color.filled())),
                    )
                    .map_err(pe)?;
            }
            if any_label {
                chart
                    .configure_series_labels()
                    .position(emptiest_corner(&drawn, (x0, x1), (y0, y1)))
                    .margin(10)
                    .legend_area_size(30)
                    .label_font((FONT, LEGEND_PX))
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK.mix(0.5))
                    .draw()
                    .map_err(pe)?;
            }
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------
// Distribution plot (batch comparison)
// ---------------------------------------------------------------------------

/// One group of a distribution plot: a label and its values.
pub struct Distribution<'a> {
    pub label: &'a str,
    pub values: &'a [f64],
}

/// Writes `<stem>.png` and `<stem>.svg`: one box per group, side by side
/// (box from the 25th to the 75th percentile, a bar at the median, whiskers
/// to the least and the largest value, percentiles as in
/// [`crate::batch::stats`]), every value drawn as a dot spread sideways so
/// equal values stay visible, and a dashed line at each of `marks`
/// (value, label), e.g. (0, "contact"). Non-finite values are left out.
pub fn plot_distributions(
    stem: &Path,
    title: &str,
    y_label: &str,
    groups: &[Distribution<'_>],
    marks: &[(f64, &str)],
) -> Result<()> {
    let width = (300 + 220 * groups.len() as u32).clamp(700, 2400);
    render_both(
        stem,
        &DistributionFigure {
            title,
            y_label,
            groups,
            marks,
            size: (width, 700),
        },
    )
}

struct DistributionFigure<'p, 'a> {
    title: &'p str,
    y_label: &'p str,
    groups: &'p [Distribution<'a>],
    marks: &'p [(f64, &'p str)],
    size: (u32, u32),
}

/// Sideways offset of the k-th dot of a group, in (−0.2, 0.2) (golden-ratio
/// sequence: deterministic and evenly spread).
fn dot_offset(k: usize) -> f64 {
    0.4 * ((k as f64 * 0.618_033_988_75).fract() - 0.5)
}

impl Figure for DistributionFigure<'_, '_> {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        use crate::batch::stats::percentile_of_sorted;
        root.fill(&WHITE).map_err(pe)?;
        let area = root.titled(self.title, (FONT, TITLE_PX)).map_err(pe)?;
        let sorted: Vec<Vec<f64>> = self
            .groups
            .iter()
            .map(|g| {
                let mut v: Vec<f64> = g
                    .values
                    .iter()
                    .copied()
                    .filter(|x| x.is_finite() && x.abs() <= AXIS_LIMIT)
                    .collect();
                v.sort_by(f64::total_cmp);
                v
            })
            .collect();
        let marks: Vec<(f64, &str)> = self
            .marks
            .iter()
            .copied()
            .filter(|(v, _)| v.is_finite() && v.abs() <= AXIS_LIMIT)
            .collect();
        let (y0, y1) = auto_range(
            sorted.iter().flatten().copied().chain(marks.iter().map(|m| m.0)),
            (0.0, 1.0),
        );
        let n = self.groups.len().max(1);
        let (x0, x1) = (-0.5, n as f64 - 0.5);
        let labels: Vec<&str> = self.groups.iter().map(|g| g.label).collect();
        let x_label = |x: &f64| {
            let i = x.round();
            if (x - i).abs() < 1e-9 && i >= 0.0 && (i as usize) < labels.len() {
                labels[i as usize].to_string()
            } else {
                String::new()
            }
        };
        let mut chart = ChartBuilder::on(&area)
            .margin(10)
            .margin_right(25)
            .x_label_area_size(50)
            .y_label_area_size(90)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(pe)?;
        {
            let yf = sci_formatter(y0, y1);
            let mut mesh = chart.configure_mesh();
            if let Some(f) = &yf {
                mesh.y_label_formatter(f);
            }
            mesh.x_label_formatter(&x_label)
                .x_labels(2 * n + 1)
                .disable_x_mesh()
                .y_desc(self.y_label)
                .label_style((FONT, LABEL_PX))
                .axis_desc_style((FONT, DESC_PX))
                .bold_line_style(BLACK.mix(0.12))
                .light_line_style(BLACK.mix(0.04))
                .y_labels(8)
                .draw()
                .map_err(pe)?;
        }
        for (value, label) in &marks {
            let style = BLACK.mix(0.6).stroke_width(1);
            chart
                .draw_series(std::iter::once(DashedPathElement::new(
                    vec![(x0, *value), (x1, *value)],
                    6,
                    4,
                    style,
                )))
                .map_err(pe)?;
            let text = TextStyle::from((FONT, LEGEND_PX).into_font())
                .color(&BLACK)
                .pos(Pos::new(HPos::Right, VPos::Bottom));
            chart
                .draw_series(std::iter::once(Text::new(label.to_string(), (x1, *value), text)))
                .map_err(pe)?;
        }
        for (i, values) in sorted.iter().enumerate() {
            let color = PALETTE[i % PALETTE.len()];
            let x = i as f64;
            let q = |p: f64| percentile_of_sorted(values, p);
            if let (Some(lo), Some(q1), Some(med), Some(q3), Some(hi)) = (q(0.0), q(25.0), q(50.0), q(75.0), q(100.0)) {
                let edge = color.stroke_width(2);
                chart
                    .draw_series([
                        Rectangle::new([(x - 0.25, q1), (x + 0.25, q3)], color.mix(0.2).filled()),
                        Rectangle::new([(x - 0.25, q1), (x + 0.25, q3)], edge),
                    ])
                    .map_err(pe)?;
                chart
                    .draw_series([
                        PathElement::new(vec![(x - 0.25, med), (x + 0.25, med)], color.stroke_width(4)),
                        PathElement::new(vec![(x, q3), (x, hi)], edge),
                        PathElement::new(vec![(x, q1), (x, lo)], edge),
                        PathElement::new(vec![(x - 0.1, hi), (x + 0.1, hi)], edge),
                        PathElement::new(vec![(x - 0.1, lo), (x + 0.1, lo)], edge),
                    ])
                    .map_err(pe)?;
            }
            chart
                .draw_series(
                    values
                        .iter()
                        .enumerate()
                        .map(|(k, v)| Circle::new((x + dot_offset(k), *v), 3, color.mix(0.7).filled())),
                )
                .map_err(pe)?;
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------
// Tests
// ---------------------------------------------------------------------------

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;
    use std::io::Read;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// A fresh directory per test; removed on drop unless
    /// `OLDBF_KEEP_PLOTS` is set (to look at the images).
    struct TempDir(PathBuf);

    impl TempDir {
        fn new(name: &str) -> Self {
            static N: AtomicUsize = AtomicUsize::new(0);
            let nanos = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.subsec_nanos())
                .unwrap_or(0);
            let dir = std::env::temp_dir().join(format!(
                "oldbf_plot_{name}_{}_{}_{nanos}",
                std::process::id(),
                N.fetch_add(1, Ordering::Relaxed)
            ));
            std::fs::create_dir_all(&dir).unwrap();
            Self(dir)
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            if std::env::var_os("OLDBF_KEEP_PLOTS").is_some() {
                eprintln!("plots kept in {}", self.0.display());
            } else {
                let _ = std::fs::remove_dir_all(&self.0);
            }
        }
    }

    /// Minimal PNG decoder (8-bit, non-interlaced, grey/RGB/RGBA) on top of
    /// flate2, so the test needs no image crate. Returns (w, h, packed RGB).
    fn decode_png(bytes: &[u8]) -> (u32, u32, Vec<u32>) {
        assert!(bytes.len() > 8, "PNG too short");
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
        let mut pos = 8;
        let (mut w, mut h, mut bpp) = (0u32, 0u32, 0usize);
        let mut idat = Vec::new();
        while pos + 12 <= bytes.len() {
            let len = u32::from_be_bytes(bytes[pos..pos + 4].try_into().unwrap()) as usize;
            let ty = &bytes[pos + 4..pos + 8];
            let data = &bytes[pos + 8..pos + 8 + len];
            match ty {
                b"IHDR" => {
                    w = u32::from_be_bytes(data[0..4].try_into().unwrap());
                    h = u32::from_be_bytes(data[4..8].try_into().unwrap());
                    assert_eq!(data[8], 8, "bit depth");
                    assert_eq!(data[12], 0, "interlace");
                    bpp = match data[9] {
                        0 => 1,
                        2 => 3,
                        4 => 2,
                        6 => 4,
                        c => panic!("unsupported colour type {c}"),
                    };
                }
                b"IDAT" => idat.extend_from_slice(data),
                b"IEND" => break,
                _ => {}
            }
            pos += 12 + len;
        }
        assert!(w > 0 && h > 0 && bpp > 0, "no IHDR");
        let mut raw = Vec::new();
        flate2::read::ZlibDecoder::new(&idat[..]).read_to_end(&mut raw).unwrap();
        let stride = w as usize * bpp;
        assert_eq!(raw.len(), (stride + 1) * h as usize, "IDAT size");
        let mut img = vec![0u8; stride * h as usize];
        for y in 0..h as usize {
            let filter = raw[y * (stride + 1)];
            let src = &raw[y * (stride + 1) + 1..(y + 1) * (stride + 1)];
            for x in 0..stride {
                let a = if x >= bpp { img[y * stride + x - bpp] } else { 0 };
                let b = if y > 0 { img[(y - 1) * stride + x] } else { 0 };
                let c = if x >= bpp && y > 0 {
                    img[(y - 1) * stride + x - bpp]
                } else {
                    0
                };
                let pred = match filter {
                    0 => 0,
                    1 => a,
                    2 => b,
                    3 => ((a as u16 + b as u16) / 2) as u8,
                    4 => {
                        let p = a as i16 + b as i16 - c as i16;
                        let (pa, pb, pc) = ((p - a as i16).abs(), (p - b as i16).abs(), (p - c as i16).abs());
                        if pa <= pb && pa <= pc {
                            a
                        } else if pb <= pc {
                            b
                        } else {
                            c
                        }
                    }
                    f => panic!("bad filter {f}"),
                };
                img[y * stride + x] = src[x].wrapping_add(pred);
            }
        }
        let px = img
            .chunks_exact(bpp)
            .map(|p| match bpp {
                1 | 2 => u32::from(p[0]) * 0x010101,
                _ => (u32::from(p[0]) << 16) | (u32::from(p[1]) << 8) | u32::from(p[2]),
            })
            .collect();
        (w, h, px)
    }

    /// Checks both outputs of a figure; returns the SVG text.
    fn check_outputs(stem: &Path, expect_size: Option<(u32, u32)>) -> String {
        let png = with_ext(stem, "png");
        let svg = with_ext(stem, "svg");
        assert!(png.is_file(), "{} missing", png.display());
        assert!(svg.is_file(), "{} missing", svg.display());
        let bytes = std::fs::read(&png).unwrap();
        assert!(bytes.len() > 10_000, "PNG suspiciously small: {}", bytes.len());
        let (w, h, px) = decode_png(&bytes);
        if let Some(sz) = expect_size {
            assert_eq!((w, h), sz);
        }
        let distinct: HashSet<u32> = px.iter().copied().collect();
        assert!(distinct.len() > 5, "PNG looks blank: {} colours", distinct.len());
        // Not almost all white.
        let non_white = px.iter().filter(|&&p| p != 0xFFFFFF).count();
        assert!(non_white > px.len() / 200, "PNG nearly blank");
        let text = std::fs::read_to_string(&svg).unwrap();
        assert!(text.starts_with("<svg") || text.contains("<svg"), "not an SVG");
        assert!(!text.contains("NaN"), "NaN coordinate in SVG");
        assert!(
            !text.contains("\"inf") && !text.contains("\"-inf") && !text.contains(" inf"),
            "infinite coordinate in SVG"
        );
        text
    }

    fn v(x: f64, y: f64) -> Vec2 {
        Vec2::new(x, y)
    }

    #[test]
    fn trajectory_writes_png_and_svg_with_text() {
        let dir = TempDir::new("traj");
        let path: Vec<Vec2> = (0..200)
            .map(|i| {
                let s = i as f64 * 0.05;
                if i == 120 {
                    v(f64::NAN, 0.0)
                } else {
                    v(s, 0.8 * (0.6 * s).sin())
                }
            })
            .collect();
        let reference: Vec<Vec2> = (0..=100).map(|i| v(i as f64 * 0.1, 0.0)).collect();
        let walls = [(v(-0.5, -1.5), v(10.5, -1.5)), (v(-0.5, 2.0), v(10.5, 2.0))];
        let circles = [(v(4.0, 1.0), 0.4), (v(f64::INFINITY, 0.0), 1.0)];
        let movers = vec![((0..50).map(|i| v(8.0 - 0.05 * i as f64, -0.8)).collect::<Vec<_>>(), 0.3)];
        let plot = TrajectoryPlot {
            title: "Trajectory test title",
            robot_path: &path,
            robot_label: "robot path",
            other_paths: &[],
            reference_path: &reference,
            walls: &walls,
            circles: &circles,
            mover_paths: &movers,
            safety_radius_m: 0.45,
            body_radius_m: 0.3,
            collisions: &[v(5.0, 0.3)],
            goal: Some(v(10.0, 0.0)),
        };
        let stem = dir.0.join("trajectory");
        plot_trajectory(&stem, &plot).unwrap();
        let svg = check_outputs(&stem, None);
        assert!(svg.contains("Trajectory test title"));
        assert!(svg.contains("x (m)"));
        assert!(svg.contains("y (m)"));
        assert!(svg.contains("robot path"));
        assert!(svg.contains("safety perimeter"));
    }

    #[test]
    fn trajectory_axes_are_isotropic() {
        ensure_fonts().unwrap();
        let path: Vec<Vec2> = (0..50).map(|i| v(i as f64 * 0.4, 0.1 * i as f64)).collect();
        for (robot, reference) in [(&path[..], &[][..]), (&[][..], &path[..])] {
            let plot = TrajectoryPlot {
                title: "iso",
                robot_path: robot,
                robot_label: "robot path",
                other_paths: &[],
                reference_path: reference,
                walls: &[],
                circles: &[],
                mover_paths: &[],
                safety_radius_m: 0.5,
                body_radius_m: 0.3,
                collisions: &[],
                goal: None,
            };
            let fig = TrajectoryFigure::new(&plot);
            let (w, h) = fig.size();
            let mut buf = vec![0u8; (w * h * 3) as usize];
            let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            let (r, (pw, ph)) = draw_trajectory(&root, &plot, fig.bounds).unwrap();
            let sx = pw as f64 / (r.x1 - r.x0);
            let sy = ph as f64 / (r.y1 - r.y0);
            assert!((sx / sy - 1.0).abs() < 1e-9, "px/m x {sx} vs y {sy}");
            // All data inside the plotted ranges.
            for q in &path {
                assert!(q.x >= r.x0 && q.x <= r.x1 && q.y >= r.y0 && q.y <= r.y1);
            }
        }
    }

    #[test]
    fn trajectory_with_nothing_still_renders() {
        let dir = TempDir::new("traj_empty");
        let movers = vec![(vec![v(f64::NAN, f64::NAN)], 0.3), (vec![], 0.2)];
        let plot = TrajectoryPlot {
            title: "empty",
            robot_path: &[],
            robot_label: "robot path",
            other_paths: &[],
            reference_path: &[],
            walls: &[],
            circles: &[],
            mover_paths: &movers,
            safety_radius_m: f64::NAN,
            body_radius_m: -1.0,
            collisions: &[v(f64::NAN, 1.0), v(1e308, -1e308)],
            goal: Some(v(f64::INFINITY, 0.0)),
        };
        let stem = dir.0.join("empty");
        plot_trajectory(&stem, &plot).unwrap();
        let svg = check_outputs(&stem, None);
        assert!(svg.contains("x (m)"));
    }

    #[test]
    fn time_series_handles_gaps_clipping_and_empty_series() {
        let dir = TempDir::new("ts");
        let t: Vec<f64> = (0..300).map(|i| i as f64 * 0.05).collect();
        let mut a: Vec<f64> = t.iter().map(|t| t.sin()).collect();
        a[50] = f64::NAN;
        a[51] = f64::INFINITY;
        a[100] = f64::NEG_INFINITY;
        a[102] = f64::NAN; // leaves an isolated sample at 101
        let b: Vec<f64> = t.iter().map(|t| 3.0 * (0.5 * t).cos()).collect(); // clipped
        let constant = vec![2.5; 300];
        let short = vec![1.0, f64::NAN, 0.5]; // shorter than t
        let all_nan = vec![f64::NAN; 300];
        let huge = vec![1e308, -1e308, 0.0, f64::MAX, f64::MIN];
        let panels = [
            TimePanel {
                y_label: "v (m/s)",
                series: vec![
                    Series {
                        label: "sine with gaps",
                        values: &a,
                    },
                    Series {
                        label: "clipped cosine",
                        values: &b,
                    },
                    Series {
                        label: "short",
                        values: &short,
                    },
                ],
                y_range: Some((-1.5, 1.5)),
            },
            TimePanel {
                y_label: "const",
                series: vec![
                    Series {
                        label: "constant",
                        values: &constant,
                    },
                    Series {
                        label: "no finite value",
                        values: &all_nan,
                    },
                    Series {
                        label: "empty",
                        values: &[],
                    },
                ],
                y_range: None,
            },
            TimePanel {
                y_label: "nothing",
                series: vec![],
                y_range: Some((f64::NAN, 1.0)),
            },
            TimePanel {
                y_label: "huge",
                series: vec![Series {
                    label: "",
                    values: &huge,
                }],
                y_range: None,
            },
        ];
        let stem = dir.0.join("series");
        plot_time_series(&stem, "Time series test title", &t, &panels).unwrap();
        let svg = check_outputs(&stem, Some((1200, 80 + 300 * 4)));
        assert!(svg.contains("Time series test title"));
        assert!(svg.contains("t (s)"));
        assert!(svg.contains("v (m/s)"));
        assert!(svg.contains("sine with gaps"));
        assert!(svg.contains("no finite value"));
    }

    #[test]
    fn time_series_degenerate_inputs() {
        let dir = TempDir::new("ts_degenerate");
        let stem = dir.0.join("no_panels");
        plot_time_series(&stem, "no panels", &[], &[]).unwrap();
        let svg = check_outputs(&stem, Some((1200, 800)));
        assert!(svg.contains("t (s)"));

        let stem = dir.0.join("bad_time");
        let t = [f64::NAN, 1.0, 1.0, f64::INFINITY];
        let vals = [1.0, 2.0, 3.0, 4.0];
        let panels = [TimePanel {
            y_label: "y",
            series: vec![Series {
                label: "s",
                values: &vals,
            }],
            y_range: Some((3.0, 3.0)),
        }];
        plot_time_series(&stem, "bad time", &t, &panels).unwrap();
        check_outputs(&stem, Some((1200, 800)));
    }

    #[test]
    fn time_series_6000_samples_is_fast() {
        let dir = TempDir::new("ts_perf");
        let t: Vec<f64> = (0..6000).map(|i| i as f64 * 0.01).collect();
        let s: Vec<Vec<f64>> = (0..3)
            .map(|k| t.iter().map(|t| (t * (k + 1) as f64).sin()).collect())
            .collect();
        let panels: Vec<TimePanel> = (0..3)
            .map(|_| TimePanel {
                y_label: "y",
                series: s.iter().map(|v| Series { label: "s", values: v }).collect(),
                y_range: None,
            })
            .collect();
        ensure_fonts().unwrap();
        let start = std::time::Instant::now();
        plot_time_series(&dir.0.join("perf"), "perf", &t, &panels).unwrap();
        let dt = start.elapsed();
        eprintln!("3 panels x 3 series x 6000 samples, PNG + SVG: {dt:?}");
        // Generous bound: the machine is shared; typical is far below.
        assert!(dt.as_secs_f64() < 3.0, "too slow: {dt:?}");
    }

    #[test]
    fn range_helpers() {
        assert_eq!(auto_range([2.0, 2.0].into_iter(), (0.0, 1.0)), (1.0, 3.0));
        assert_eq!(auto_range([f64::NAN].into_iter(), (0.0, 1.0)), (0.0, 1.0));
        let (lo, hi) = auto_range([0.0, 10.0, f64::INFINITY].into_iter(), (0.0, 1.0));
        assert!((lo + 0.5).abs() < 1e-12 && (hi - 10.5).abs() < 1e-12);
        assert_eq!(sanitize_range((2.0, 1.0)), Some((1.0, 2.0)));
        assert_eq!(sanitize_range((1.0, 1.0)), Some((0.0, 2.0)));
        assert_eq!(sanitize_range((f64::NEG_INFINITY, 1.0)), None);
        let (lo, hi) = auto_range([1e305, 1e305].into_iter(), (0.0, 1.0));
        assert!(lo < hi && (hi - lo).is_finite());
        let (lo, hi) = auto_range([f64::MAX, f64::MIN].into_iter(), (0.0, 1.0));
        assert!(lo < hi && (hi - lo).is_finite());
        let runs = series_runs(
            &[0.0, 1.0, 2.0, 3.0, 4.0],
            &[5.0, f64::NAN, -5.0, 0.5, 1.0],
            (-1.0, 1.0),
        );
        assert_eq!(runs, vec![vec![(0.0, 1.0)], vec![(2.0, -1.0), (3.0, 0.5), (4.0, 1.0)]]);
        let runs = finite_runs(&[v(0.0, 0.0), v(f64::NAN, 0.0), v(1.0, 1.0), v(2.0, 2.0)]);
        assert_eq!(runs, vec![vec![(0.0, 0.0)], vec![(1.0, 1.0), (2.0, 2.0)]]);
        let b = isotropic(
            Bounds {
                x0: 0.0,
                x1: 10.0,
                y0: 0.0,
                y1: 1.0,
            },
            800,
            400,
        );
        assert!(((b.x1 - b.x0) / 800.0 - (b.y1 - b.y0) / 400.0).abs() < 1e-12);
        assert!(b.x0 <= 0.0 && b.x1 >= 10.0 && b.y0 <= 0.0 && b.y1 >= 1.0);
        assert!(sci_formatter(0.0, 10.0).is_none());
        let f = sci_formatter(-1e300, 1e300).unwrap();
        assert_eq!(f(&1e300), "1.0e300");
        let f = sci_formatter(1e6, 1e6 + 10.0).unwrap();
        assert_ne!(f(&1_000_002.0), f(&1_000_004.0));
        assert_eq!(with_ext(Path::new("a/run.v2"), "png"), PathBuf::from("a/run.v2.png"));
    }

    #[test]
    fn distributions_draw_boxes_dots_and_marks() {
        let dir = TempDir::new("dist");
        let a: Vec<f64> = (0..40).map(|i| 0.1 + 0.01 * i as f64).collect();
        let b = [-0.05, 0.0, 0.02, f64::NAN, f64::INFINITY, 0.3];
        let stem = dir.0.join("min_clearance");
        plot_distributions(
            &stem,
            "Min clearance per world",
            "min clearance (m)",
            &[
                Distribution {
                    label: "oldbf",
                    values: &a,
                },
                Distribution {
                    label: "none",
                    values: &b,
                },
                Distribution {
                    label: "empty",
                    values: &[],
                },
            ],
            &[(0.0, "contact")],
        )
        .unwrap();
        let svg = check_outputs(&stem, None);
        for needle in [
            "Min clearance per world",
            "min clearance (m)",
            "oldbf",
            "none",
            "empty",
            "contact",
        ] {
            assert!(svg.contains(needle), "SVG lacks {needle}");
        }
        // 40 + 4 finite dots, drawn as SVG circles.
        assert!(
            svg.matches("<circle").count() >= 44,
            "{}",
            svg.matches("<circle").count()
        );
    }
}
