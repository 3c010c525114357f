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
static FONT_BYTES: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

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

mod distribution;
mod time_series;
mod trajectory;
pub use distribution::{plot_distributions, Distribution};
pub use time_series::{plot_time_series, Series, TimePanel};
pub use trajectory::{plot_trajectory, BodyOutline, TrajectoryPlot};
#[cfg(test)]
use {time_series::*, trajectory::*};

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
            body: None,
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
    fn a_polygon_body_is_drawn_posed_with_its_safety_outline() {
        ensure_fonts().unwrap();
        let dir = TempDir::new("traj_polygon");
        // A 0.6 x 0.4 m rectangle grown by 0.1 m: every outline point is 0.1 m
        // from the rectangle (on an edge's offset or an arc about a corner).
        let rect = [v(0.3, 0.2), v(-0.3, 0.2), v(-0.3, -0.2), v(0.3, -0.2)];
        let hull = crate::sim::body::convex_hull(&rect);
        assert_eq!(hull.len(), 4);
        let outline = grown_outline(&hull, 0.1);
        for q in &outline {
            let dx = (q.x.abs() - 0.3).max(0.0);
            let dy = (q.y.abs() - 0.2).max(0.0);
            assert!(((dx * dx + dy * dy).sqrt() - 0.1).abs() < 1e-9, "{q:?}");
        }
        // A notch (a concave vertex) is inside the hull and left out of it.
        let notched = [v(0.3, 0.2), v(0.0, 0.1), v(-0.3, 0.2), v(-0.3, -0.2), v(0.3, -0.2)];
        assert_eq!(crate::sim::body::convex_hull(&notched).len(), 4);
        let path: Vec<Vec2> = (0..40).map(|i| v(0.1 * i as f64, 0.0)).collect();
        let headings: Vec<f64> = (0..40).map(|i| 0.02 * i as f64).collect();
        let plot = TrajectoryPlot {
            title: "polygon",
            robot_path: &path,
            robot_label: "robot path",
            other_paths: &[],
            reference_path: &[],
            walls: &[],
            circles: &[],
            mover_paths: &[],
            safety_radius_m: 0.46,
            body_radius_m: 0.36,
            collisions: &[],
            goal: None,
            body: Some(BodyOutline {
                polygon_m: &rect,
                headings_rad: &headings,
                grow_m: 0.1,
            }),
        };
        let stem = dir.0.join("polygon");
        plot_trajectory(&stem, &plot).unwrap();
        let svg = check_outputs(&stem, None);
        assert!(
            svg.contains("safety outline (footprint + 0.10 m)"),
            "no outline in the legend"
        );
        assert!(!svg.contains("safety perimeter"), "the disc perimeter is drawn too");
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
                body: None,
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
            body: None,
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
