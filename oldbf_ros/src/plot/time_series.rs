//! Stacked time-series panels (B_l, B_r, v, ω over time; paper Fig. 5-6).

use super::*;

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

pub(super) struct TimeSeriesFigure<'p, 'a> {
    title: &'p str,
    t_s: &'p [f64],
    panels: &'p [TimePanel<'a>],
    size: (u32, u32),
}

/// Range of the finite values with a 5 % margin; a constant (or single)
/// value gives ±1 around it; no finite value gives `fallback`.
pub(super) fn auto_range(values: impl Iterator<Item = f64>, fallback: (f64, f64)) -> (f64, f64) {
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
pub(super) fn widen(v: f64) -> (f64, f64) {
    let d = 1f64.max(v.abs() * 1e-9);
    (v - d, v + d)
}

/// A caller's fixed range, made usable: ordered, finite, non-degenerate.
pub(super) fn sanitize_range(r: (f64, f64)) -> Option<(f64, f64)> {
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
pub(super) fn series_runs(t: &[f64], v: &[f64], clip: (f64, f64)) -> Vec<Vec<(f64, f64)>> {
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
pub(super) fn emptiest_corner(pts: &[(f64, f64)], x: (f64, f64), y: (f64, f64)) -> SeriesLabelPosition {
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
