//! The trajectory plot: a top view of the world, the robots' paths and the
//! safety perimeter (paper Fig. 4-like).

use super::*;
use crate::sim::body::convex_hull;

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
    /// A polygon footprint: drawn instead of the discs (the body at start and
    /// end, the safety outline along the path), posed with the headings.
    pub body: Option<BodyOutline<'a>>,
}

/// A polygon robot as the trajectory plot draws it.
pub struct BodyOutline<'a> {
    /// The footprint (m, robot frame).
    pub polygon_m: &'a [Vec2],
    /// The robot's heading at each point of `robot_path` (rad).
    pub headings_rad: &'a [f64],
    /// How far the safety outline lies beyond the polygon (m): its padding
    /// plus d_safe. Drawn around the polygon's convex hull (for a concave
    /// footprint, a little outside the true outline).
    pub grow_m: f64,
}

/// `vertices` (robot frame) posed at `centre` with `heading_rad`, closed.
fn posed(vertices: &[Vec2], centre: Vec2, heading_rad: f64) -> Vec<(f64, f64)> {
    let (s, c) = heading_rad.sin_cos();
    let mut out: Vec<(f64, f64)> = vertices
        .iter()
        .map(|v| (centre.x + c * v.x - s * v.y, centre.y + s * v.x + c * v.y))
        .collect();
    if let Some(&first) = out.first() {
        out.push(first);
    }
    out
}

/// The outline of the convex `hull` (counter-clockwise) grown by `grow_m`:
/// each edge moved out along its normal, joined by arcs about the vertices.
pub(super) fn grown_outline(hull: &[Vec2], grow_m: f64) -> Vec<Vec2> {
    let n = hull.len();
    if n == 0 || grow_m <= 0.0 {
        return hull.to_vec();
    }
    let normal_angle = |i: usize| {
        let (a, b) = (hull[i], hull[(i + 1) % n]);
        (b.y - a.y).atan2(b.x - a.x) - std::f64::consts::FRAC_PI_2
    };
    let mut out = Vec::new();
    for (i, vertex) in hull.iter().enumerate() {
        // The arc at vertex i, from the normal of the edge before to the edge after.
        let from = normal_angle((i + n - 1) % n);
        let mut to = normal_angle(i);
        while to < from {
            to += std::f64::consts::TAU;
        }
        let steps = (((to - from) / 0.2).ceil() as usize).max(1);
        for k in 0..=steps {
            let a = from + (to - from) * k as f64 / steps as f64;
            out.push(vertex + Vec2::new(a.cos(), a.sin()) * grow_m);
        }
    }
    out
}

/// Writes `<stem>.png` and `<stem>.svg`: a top view with equal aspect ratio
/// (1 m in x = 1 m in y), legend, axes "x (m)" / "y (m)".
pub fn plot_trajectory(stem: &Path, plot: &TrajectoryPlot<'_>) -> Result<()> {
    render_both(stem, &TrajectoryFigure::new(plot))
}

/// Layout of the trajectory figure (pixels): chart on the left, legend strip
/// on the right (outside the data, so it never hides the path).
pub(super) const TRAJ_CHART_WIDTH: u32 = 900;
pub(super) const TRAJ_LEGEND_WIDTH: u32 = 300;
pub(super) const TRAJ_MARGIN: u32 = 15;
pub(super) const TRAJ_X_LABEL_AREA: u32 = 60;
pub(super) const TRAJ_Y_LABEL_AREA: u32 = 75;
/// Title strip height estimate, used only to choose the image height.
pub(super) const TRAJ_TITLE_STRIP: u32 = 45;
/// Target number of safety-perimeter circles along the path.
pub(super) const SAFETY_CIRCLES: usize = 20;

pub(super) struct TrajectoryFigure<'p, 'a> {
    plot: &'p TrajectoryPlot<'a>,
    /// Data bounds with margin (before the isotropic expansion).
    pub(super) bounds: Bounds,
    size: (u32, u32),
}

impl<'p, 'a> TrajectoryFigure<'p, 'a> {
    pub(super) fn new(plot: &'p TrajectoryPlot<'a>) -> Self {
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
pub(super) fn trajectory_bounds(p: &TrajectoryPlot<'_>) -> Bounds {
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
pub(super) fn isotropic(b: Bounds, pw: u32, ph: u32) -> Bounds {
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
pub(super) enum Swatch {
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
pub(super) fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[(String, Swatch)],
) -> Result<()> {
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
pub(super) fn draw_trajectory<DB: DrawingBackend>(
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

    // A polygon body: its safety outline every N samples, posed with the heading.
    let finite_path: Vec<Vec2> = p.robot_path.iter().copied().filter(finite2).collect();
    let body = p
        .body
        .as_ref()
        .filter(|b| b.polygon_m.len() >= 3 && b.headings_rad.len() == p.robot_path.len());
    let posed_at = |i: usize, vertices: &[Vec2]| {
        let (c, h) = (p.robot_path[i], body.map_or(0.0, |b| b.headings_rad[i]));
        (finite2(&c) && h.is_finite()).then(|| posed(vertices, c, h))
    };
    if let Some(b) = body {
        let outline = grown_outline(&convex_hull(b.polygon_m), b.grow_m.max(0.0));
        let n = p.robot_path.len();
        let step = n.div_ceil(SAFETY_CIRCLES).max(1);
        let mut at: Vec<usize> = (0..n).step_by(step).collect();
        if n > 0 && at.last() != Some(&(n - 1)) {
            at.push(n - 1);
        }
        let s: ShapeStyle = SAFETY_COLOR.mix(0.6).into();
        chart
            .draw_series(
                at.iter()
                    .filter_map(|&i| posed_at(i, &outline))
                    .map(|o| PathElement::new(o, s)),
            )
            .map_err(pe)?;
        legend.push((
            format!("safety outline (footprint + {:.2} m)", b.grow_m),
            Swatch::Disc {
                fill: None,
                edge: s,
                dashed: false,
            },
        ));
    }
    // Safety perimeter r + d_safe every N samples (~SAFETY_CIRCLES circles).
    let sr = p.safety_radius_m;
    if body.is_none() && !finite_path.is_empty() && sr.is_finite() && sr > 0.0 {
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

    // Robot body at start and end: the polygon posed, or the disc.
    let br = p.body_radius_m;
    let ends: Vec<Vec<(f64, f64)>> = match body {
        Some(b) => [0, p.robot_path.len().saturating_sub(1)]
            .into_iter()
            .filter_map(|i| posed_at(i, b.polygon_m))
            .collect(),
        None if !finite_path.is_empty() && br.is_finite() && br > 0.0 => {
            [finite_path[0], finite_path[finite_path.len() - 1]]
                .iter()
                .map(|c| circle_points(*c, br, N))
                .collect()
        }
        None => Vec::new(),
    };
    if !ends.is_empty() {
        let fill = ROBOT_COLOR.mix(0.3).filled();
        let edge = ROBOT_COLOR.stroke_width(2);
        chart
            .draw_series(ends.iter().map(|o| Polygon::new(o.clone(), fill)))
            .map_err(pe)?;
        chart
            .draw_series(ends.iter().map(|o| PathElement::new(o.clone(), edge)))
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
