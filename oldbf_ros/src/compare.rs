//! `oldbf compare`: one scenario, several controllers, side by side (the
//! paper's Fig. 9: circle tracking, DCBF vs OLDBF).
//!
//! Every controller runs the same scenario with the same seed (same world,
//! same sensor noise, same nominal command law). For robot 0 of the
//! scenario the comparison reports, per controller, the safety and tracking
//! figures, and plots the paths over one another, the tracking error over
//! time and the commands over time.
//!
//! Two tracking errors are shown. The *distance to the reference point* is
//! the one the nominal tracking law acts on; its reference is governed (it
//! waits for a robot held back by the filter, see `ReferenceProgress`), so it
//! stays bounded while the robot is stuck. The *distance to the reference
//! path* (the nearest point of the whole reference curve) says how far the
//! robot strayed from the intended path, whatever the timing.

use crate::algo::geometry::Vec2;
use crate::algo::reference::ReferenceTrajectory;
use crate::plot::{plot_time_series, plot_trajectory, Series, TimePanel, TrajectoryPlot};
use crate::sim::figures::RunFigures;
use crate::sim::fleet::FleetError;
use crate::sim::run::{run_scenario, Controller, RunResult, RunSummary, StepRow};
use crate::sim::scenario::Scenario;
use anyhow::Context;
use rayon::prelude::*;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;

/// One controller's run in a comparison.
#[derive(Debug, Clone)]
pub struct ComparedRun {
    pub controller: Controller,
    pub result: RunResult,
    /// Per step of robot 0: distance to the whole reference path (m); empty
    /// without a reference.
    pub path_error_m: Vec<f64>,
}

/// Per-controller figures (robot 0), as printed and written to comparison.json.
#[derive(Debug, Clone, Serialize)]
pub struct ComparedFigures {
    pub controller: Controller,
    /// Robot 0's figures.
    #[serde(flatten)]
    pub robot: RunFigures,
    /// Distance to the reference path: max and mean (m).
    pub max_path_error_m: Option<f64>,
    pub mean_path_error_m: Option<f64>,
    /// The whole run (mean_step_us: the pipeline's time per step).
    pub summary: RunSummary,
}

/// Runs `scenario` once per controller (in parallel), same seed.
pub fn run_comparison(
    scenario: &Scenario,
    controllers: &[Controller],
    seed: u64,
) -> Result<Vec<ComparedRun>, FleetError> {
    let reference = scenario.agents.first().and_then(|a| a.reference);
    controllers
        .par_iter()
        .map(|&controller| {
            let result = run_scenario(scenario, controller, seed)?;
            let path_error_m = match &reference {
                Some(r) => {
                    let curve = sample_path(r, 0.005);
                    result.robots[0]
                        .rows
                        .iter()
                        .map(|row| distance_to_polyline(Vec2::new(row.x_m, row.y_m), &curve))
                        .collect()
                }
                None => Vec::new(),
            };
            Ok(ComparedRun {
                controller,
                result,
                path_error_m,
            })
        })
        .collect()
}

/// The reference curve as a polyline with vertices about `spacing_m` apart.
fn sample_path(r: &ReferenceTrajectory, spacing_m: f64) -> Vec<Vec2> {
    let length = r.v_mps.abs() * r.duration_s;
    let n = ((length / spacing_m).ceil() as usize).clamp(1, 1_000_000);
    (0..=n)
        .map(|i| r.pose_at(r.duration_s * i as f64 / n as f64).position())
        .collect()
}

/// Least distance from `p` to the polyline through `vertices` (m).
fn distance_to_polyline(p: Vec2, vertices: &[Vec2]) -> f64 {
    if vertices.len() == 1 {
        return (p - vertices[0]).norm();
    }
    vertices
        .windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            let ab = b - a;
            let len2 = ab.norm_squared();
            let s = if len2 > 0.0 {
                ((p - a).dot(&ab) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (p - (a + ab * s)).norm()
        })
        .fold(f64::INFINITY, f64::min)
}

/// The figures of each run.
pub fn figures(runs: &[ComparedRun]) -> Vec<ComparedFigures> {
    runs.iter()
        .map(|r| {
            let s = &r.result.summary;
            let robot = &r.result.robots[0].summary;
            let finite: Vec<f64> = r.path_error_m.iter().copied().filter(|e| e.is_finite()).collect();
            let (max_path, mean_path) = if finite.is_empty() {
                (None, None)
            } else {
                (
                    Some(finite.iter().copied().fold(0.0, f64::max)),
                    Some(finite.iter().sum::<f64>() / finite.len() as f64),
                )
            };
            ComparedFigures {
                controller: r.controller,
                robot: robot.figures.clone(),
                max_path_error_m: max_path,
                mean_path_error_m: mean_path,
                summary: s.clone(),
            }
        })
        .collect()
}

/// A fixed-width table, one row per controller.
pub fn comparison_text(scenario: &Scenario, seed: u64, figs: &[ComparedFigures]) -> String {
    let opt = |v: Option<f64>, digits: usize| v.map_or("–".to_string(), |x| format!("{x:.digits$}"));
    let mut out = String::new();
    let _ = writeln!(out, "scenario {} | seed {seed} | robot 0", scenario.spec.name);
    let _ = writeln!(
        out,
        "{:<10} {:>10} {:>12} {:>8} {:>9} {:>17} {:>18} {:>9}",
        "controller",
        "collisions",
        "min clr (m)",
        "goal (s)",
        "path (m)",
        "ref err max/mean",
        "path err max/mean",
        "µs/step"
    );
    for f in figs {
        let goal = match f.robot.time_to_goal_s {
            Some(t) => format!("{t:.1}"),
            None => "no".to_string(),
        };
        let _ = writeln!(
            out,
            "{:<10} {:>10} {:>12.3} {:>8} {:>9.2} {:>17} {:>18} {:>9.1}",
            format!("{:?}", f.controller).to_lowercase(),
            f.robot.collisions,
            f.robot.min_clearance_m,
            goal,
            f.robot.path_length_m,
            format!(
                "{} / {}",
                opt(f.robot.max_tracking_error_m, 2),
                opt(f.robot.mean_tracking_error_m, 2)
            ),
            format!("{} / {}", opt(f.max_path_error_m, 2), opt(f.mean_path_error_m, 2)),
            f.summary.mean_step_us
        );
    }
    out
}

/// Writes `comparison.json`, `trajectories.{png,svg}` (paths overlaid),
/// `tracking_error.{png,svg}` and `commands.{png,svg}` into `dir`.
pub fn write_comparison(dir: &Path, scenario: &Scenario, seed: u64, runs: &[ComparedRun]) -> anyhow::Result<()> {
    anyhow::ensure!(!runs.is_empty(), "no controller to compare");
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let figs = figures(runs);
    std::fs::write(dir.join("comparison.json"), serde_json::to_string_pretty(&figs)?)?;

    let name = |c: Controller| format!("{c:?}").to_lowercase();
    let path_of = |rows: &[StepRow]| rows.iter().map(|r| Vec2::new(r.x_m, r.y_m)).collect::<Vec<_>>();
    let first = &runs[0].result;
    let robot_path = path_of(&first.robots[0].rows);
    let polygon = crate::report::body_polygon(scenario);
    let headings: Vec<f64> = first.robots[0].rows.iter().map(|r| r.theta_rad).collect();
    let others: Vec<(String, Vec<Vec2>)> = runs[1..]
        .iter()
        .map(|r| (name(r.controller), path_of(&r.result.robots[0].rows)))
        .collect();
    let reference_path = scenario
        .agents
        .first()
        .and_then(|a| a.reference)
        .map(|r| sample_path(&r, 0.02))
        .unwrap_or_default();
    let walls: Vec<_> = first.world.segments().iter().map(|s| (s.a, s.b)).collect();
    let circles: Vec<_> = first.world.circles().iter().map(|c| (c.center, c.radius_m)).collect();
    let collisions: Vec<_> = runs
        .iter()
        .flat_map(|r| r.result.robots[0].contacts.iter().map(|c| c.position))
        .collect();
    let labels: Vec<String> = runs.iter().map(|r| name(r.controller)).collect();
    let title = format!("{}: {} (seed {seed})", scenario.spec.name, labels.join(" vs "));
    plot_trajectory(
        &dir.join("trajectories"),
        &TrajectoryPlot {
            title: &title,
            robot_path: &robot_path,
            robot_label: &labels[0],
            other_paths: &others,
            reference_path: &reference_path,
            walls: &walls,
            circles: &circles,
            // Moving obstacles move the same way in every run (they do not react).
            mover_paths: &first.mover_tracks,
            safety_radius_m: scenario.params.robot_radius_m() + scenario.params.barrier.d_safe_m,
            body_radius_m: scenario.robot.body_radius_m,
            collisions: &collisions,
            goal: first.robots[0].goal,
            body: crate::report::body_outline(scenario, &polygon, &headings),
        },
    )?;

    // A common time axis: the longest run; shorter ones end in gaps.
    let dt = scenario.params.control.dt_s();
    let steps = runs.iter().map(|r| r.result.robots[0].rows.len()).max().unwrap_or(0);
    let t: Vec<f64> = (0..steps).map(|k| k as f64 * dt).collect();
    let padded = |values: Vec<f64>| {
        let mut v = values;
        v.resize(steps, f64::NAN);
        v
    };
    let column = |r: &ComparedRun, f: fn(&StepRow) -> f64| padded(r.result.robots[0].rows.iter().map(f).collect());
    let ref_err: Vec<Vec<f64>> = runs
        .iter()
        .map(|r| {
            column(r, |row| {
                ((row.x_m - row.ref_x_m).powi(2) + (row.y_m - row.ref_y_m).powi(2)).sqrt()
            })
        })
        .collect();
    let path_err: Vec<Vec<f64>> = runs.iter().map(|r| padded(r.path_error_m.clone())).collect();
    plot_time_series(
        &dir.join("tracking_error"),
        &format!("{title}: tracking error (paper Fig. 9)"),
        &t,
        &[
            TimePanel {
                y_label: "to reference point (m)",
                series: series(&labels, &ref_err),
                y_range: None,
            },
            TimePanel {
                y_label: "to reference path (m)",
                series: series(&labels, &path_err),
                y_range: None,
            },
        ],
    )?;

    let v: Vec<Vec<f64>> = runs.iter().map(|r| column(r, |row| row.v_cmd_mps)).collect();
    let w: Vec<Vec<f64>> = runs.iter().map(|r| column(r, |row| row.omega_cmd_radps)).collect();
    plot_time_series(
        &dir.join("commands"),
        &format!("{title}: commands sent"),
        &t,
        &[
            TimePanel {
                y_label: "v (m/s)",
                series: series(&labels, &v),
                y_range: None,
            },
            TimePanel {
                y_label: "ω (rad/s)",
                series: series(&labels, &w),
                y_range: None,
            },
        ],
    )?;
    Ok(())
}

/// One labelled series per controller.
fn series<'a>(labels: &'a [String], data: &'a [Vec<f64>]) -> Vec<Series<'a>> {
    labels
        .iter()
        .zip(data)
        .map(|(label, values)| Series { label, values })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::geometry::Pose2;

    #[test]
    fn distance_to_a_polyline_by_hand() {
        let l = [Vec2::new(0.0, 0.0), Vec2::new(2.0, 0.0), Vec2::new(2.0, 2.0)];
        assert!((distance_to_polyline(Vec2::new(1.0, 0.5), &l) - 0.5).abs() < 1e-12);
        assert!((distance_to_polyline(Vec2::new(3.0, 1.0), &l) - 1.0).abs() < 1e-12);
        assert!((distance_to_polyline(Vec2::new(-3.0, 4.0), &l) - 5.0).abs() < 1e-12);
        assert_eq!(distance_to_polyline(Vec2::new(1.0, 1.0), &l[..1]), 2f64.sqrt());
    }

    #[test]
    fn a_sampled_circle_is_within_the_chord_error_of_the_true_circle() {
        // Radius 1 m circle; with 5 mm chords the sagitta is 3e-6 m.
        let r = ReferenceTrajectory::circle(Pose2::new(0.0, -1.0, 0.0), 0.1, 0.1, 1.0);
        let curve = sample_path(&r, 0.005);
        for p in [Vec2::new(0.0, 0.0), Vec2::new(0.5, 0.0), Vec2::new(3.0, 0.0)] {
            let exact = (p.norm() - 1.0).abs();
            assert!((distance_to_polyline(p, &curve) - exact).abs() < 1e-5, "{p:?}");
        }
    }
}
