//! The distribution plot of a batch comparison: one dot per world per controller.

use super::time_series::auto_range;
use super::*;

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

pub(super) struct DistributionFigure<'p, 'a> {
    title: &'p str,
    y_label: &'p str,
    groups: &'p [Distribution<'a>],
    marks: &'p [(f64, &'p str)],
    size: (u32, u32),
}

/// Sideways offset of the k-th dot of a group, in (−0.2, 0.2) (golden-ratio
/// sequence: deterministic and evenly spread).
pub(super) fn dot_offset(k: usize) -> f64 {
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
