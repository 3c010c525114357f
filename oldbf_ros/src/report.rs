//! What a run leaves behind: the readable summary, the per-step CSV and the
//! plots (trajectory with the safety perimeter; B_l and B_r over time; v and
//! ω over time: the paper's Figs. 4-6).

use crate::algo::select::Critic;
use crate::plot::{plot_time_series, plot_trajectory, Series, TimePanel, TrajectoryPlot};
use crate::sim::figures::MotionQuality;
use crate::sim::run::{RunResult, RunSummary, StepRow};
use crate::sim::scenario::Scenario;
use anyhow::Context;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

/// The two lines of motion figures ([`MotionQuality`]) of a run or of many
/// summed: the command's variation against the upstream's, its reversals,
/// state switches and steps outside the window, the time stalled when
/// given; then what the layer added to the upstream command.
pub fn motion_lines(m: &MotionQuality, stalled_s: Option<f64>) -> String {
    let stalled = stalled_s.map_or(String::new(), |t| format!(" | stalled {t:.1} s"));
    format!(
        "  motion: variation v {:.3} m/s per s, ω {:.3} rad/s per s (upstream {:.3}, {:.3}) | reversals Δv {} ({:.2} %), \
         Δω {} ({:.2} %) | state switches {:.1}/min | outside the window {}{stalled}\n  \
         added to the upstream: faster {} steps (escape {}) | reversing {} (escape {}, evasion {}, other {}) | v sign changes {} | \
         moving tracks on {:.1} % of steps\n",
        m.variation_v_per_s(),
        m.variation_omega_per_s(),
        m.upstream_variation_v_per_s(),
        m.upstream_variation_omega_per_s(),
        m.v_reversals,
        100.0 * m.per_step(m.v_reversals),
        m.omega_reversals,
        100.0 * m.per_step(m.omega_reversals),
        m.per_minute(m.state_switches),
        m.window_exceeded,
        m.above_upstream_steps,
        m.above_upstream_escape_steps,
        m.reverse_unasked_steps(),
        m.reverse_escape_steps,
        m.reverse_evade_steps,
        m.reverse_other_steps,
        m.v_sign_changes,
        100.0 * m.per_step(m.moving_track_steps)
    )
}

/// A human-readable summary (several lines).
pub fn summary_text(s: &RunSummary) -> String {
    let opt = |v: Option<f64>, unit: &str| v.map_or("n/a".to_string(), |x| format!("{x:.3} {unit}"));
    let mut out = String::new();
    let _ = writeln!(
        out,
        "scenario {} | controller {:?} | seed {}",
        s.scenario, s.controller, s.seed
    );
    let _ = writeln!(
        out,
        "  {} steps, {:.1} s simulated | goal {} | path {:.2} m",
        s.steps,
        s.sim_time_s,
        match s.figures.time_to_goal_s {
            Some(t) => format!("reached at {t:.1} s"),
            None => "not reached".to_string(),
        },
        s.figures.path_length_m
    );
    let _ = writeln!(
        out,
        "  collisions {} (closing {}, passive {}) | min clearance {:.3} m | CBF violations {} (logged), {} (exact geometry)",
        s.figures.collisions,
        s.figures.closing_contacts,
        s.figures.passive_contacts,
        s.figures.min_clearance_m,
        s.figures.cbf_violations,
        s.figures.true_cbf_violations
    );
    let inf = s.figures.infeasible_steps;
    let _ = writeln!(
        out,
        "  braking violations {} | infeasible {} steps (unsafe set {}, approaching {}, no passive command {}) | blind: stopped {}, driven {} steps",
        s.figures.braking_violations,
        inf.total(),
        inf.unsafe_set,
        inf.approaching,
        inf.no_passive_command,
        s.figures.blind_steps,
        s.figures.driven_blind_steps
    );
    out.push_str(&motion_lines(&s.figures.motion, Some(s.figures.stalled_s)));
    let _ = writeln!(
        out,
        "  tracking error max {} mean {} | filter changed {} steps",
        opt(s.figures.max_tracking_error_m, "m"),
        opt(s.figures.mean_tracking_error_m, "m"),
        s.figures.filter_changed_steps
    );
    let c = s.figures.steps_by_state;
    let _ = writeln!(
        out,
        "  states: forward {} avoid {} both_sides {} stop {} escape {} evade {} follow {}",
        c.forward, c.avoid, c.both_sides, c.stop, c.escape, c.evade, c.follow
    );
    let _ = write!(
        out,
        "  safety path {:.1} µs/step mean, {:.1} µs max (CPU time; the way round planned in step left out)",
        s.mean_step_us, s.max_step_us
    );
    if s.robots.len() > 1 {
        for r in &s.robots {
            let _ = write!(
                out,
                "\n  robot {}: goal {} | collisions {} (closing {}) | min clearance {:.3} m | CBF violations {} / {} | path {:.2} m",
                r.name,
                r.figures.time_to_goal_s
                    .map_or("not reached".to_string(), |t| format!("reached at {t:.1} s")),
                r.figures.collisions,
                r.figures.closing_contacts,
                r.figures.min_clearance_m,
                r.figures.cbf_violations,
                r.figures.true_cbf_violations,
                r.figures.path_length_m
            );
        }
    }
    out
}

fn csv_value(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.6}")
    } else {
        format!("{v}")
    }
}

/// Writes one row per control step.
pub fn write_steps_csv(path: &Path, rows: &[StepRow]) -> anyhow::Result<()> {
    let file = std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?;
    let mut w = std::io::BufWriter::new(file);
    writeln!(
        w,
        "t_s,x_m,y_m,theta_rad,ref_x_m,ref_y_m,v_nominal_mps,omega_nominal_radps,v_doaa_mps,omega_doaa_radps,\
         v_cmd_mps,omega_cmd_radps,\
         v_actual_mps,omega_actual_radps,b_left,b_right,d_left_m,d_right_m,h_m,h_next_pred_m,h_true_m,\
         clearance_true_m,state,filter_changed,condition_held,braking_held,infeasible,unknown_beams,held_beams,\
         driven_blind,in_collision,moving_tracks,threats,min_ttc_s,step_us,planner_us,tier,added_motion,route_event,no_route,{}",
        Critic::ALL.map(|c| format!("cost_{}", c.name())).join(",")
    )?;
    for r in rows {
        let nums = [
            r.t_s,
            r.x_m,
            r.y_m,
            r.theta_rad,
            r.ref_x_m,
            r.ref_y_m,
            r.v_nominal_mps,
            r.omega_nominal_radps,
            r.v_doaa_mps,
            r.omega_doaa_radps,
            r.v_cmd_mps,
            r.omega_cmd_radps,
            r.v_actual_mps,
            r.omega_actual_radps,
            r.b_left,
            r.b_right,
            r.d_left_m,
            r.d_right_m,
            r.h_m,
            r.h_next_pred_m,
            r.h_true_m,
            r.clearance_true_m,
        ];
        let mut line = nums.iter().map(|v| csv_value(*v)).collect::<Vec<_>>().join(",");
        let _ = write!(
            line,
            ",{},{},{},{},{},{},{},{},{},{},{},{},{:.2},{:.2}",
            r.state.as_str(),
            r.filter_changed as u8,
            r.condition_held as u8,
            r.braking_held as u8,
            r.infeasible,
            r.unknown_beams,
            r.held_beams,
            r.driven_blind as u8,
            r.in_collision as u8,
            r.moving_tracks,
            r.threats,
            csv_value(r.min_ttc_s),
            r.step_us,
            r.planner_us
        );
        let _ = write!(
            line,
            ",{},{},{},{}",
            r.tier,
            u8::from(r.added_motion),
            r.route_event,
            u8::from(r.no_route)
        );
        for c in r.costs.0 {
            let _ = write!(line, ",{}", csv_value(c));
        }
        writeln!(w, "{line}")?;
    }
    w.flush()?;
    Ok(())
}

/// Writes `steps.csv` (`steps_<robot>.csv` for each robot of a multi-robot
/// scenario), `summary.json`, `trajectory.{png,svg}`, `barriers.{png,svg}`
/// and `velocities.{png,svg}` into `dir`. The time plots show the first robot.
pub fn write_outputs(dir: &Path, scenario: &Scenario, result: &RunResult) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    for robot in &result.robots {
        let name = if result.robots.len() == 1 {
            "steps.csv".to_string()
        } else {
            format!("steps_{}.csv", robot.name)
        };
        write_steps_csv(&dir.join(name), &robot.rows)?;
    }
    std::fs::write(dir.join("summary.json"), serde_json::to_string_pretty(&result.summary)?)?;

    let first = &result.robots[0];
    let rows = &first.rows;
    let col = |f: fn(&StepRow) -> f64| rows.iter().map(f).collect::<Vec<f64>>();
    let t = col(|r| r.t_s);
    let path_of = |rows: &[StepRow]| {
        rows.iter()
            .map(|r| nalgebra::Vector2::new(r.x_m, r.y_m))
            .collect::<Vec<_>>()
    };
    let robot_path = path_of(rows);
    let polygon = body_polygon(scenario);
    let headings: Vec<f64> = rows.iter().map(|r| r.theta_rad).collect();
    let reference_path: Vec<_> = rows
        .iter()
        .filter(|r| r.ref_x_m.is_finite())
        .map(|r| nalgebra::Vector2::new(r.ref_x_m, r.ref_y_m))
        .collect();
    let walls: Vec<_> = result.world.segments().iter().map(|s| (s.a, s.b)).collect();
    let circles: Vec<_> = result.world.circles().iter().map(|c| (c.center, c.radius_m)).collect();
    // Other robots are drawn like moving obstacles: their track and their body.
    let mut movers = result.mover_tracks.clone();
    movers.extend(
        result.robots[1..]
            .iter()
            .map(|r| (path_of(&r.rows), scenario.robot.body_radius_m)),
    );
    let collisions: Vec<_> = result
        .robots
        .iter()
        .flat_map(|r| r.contacts.iter().map(|c| c.position))
        .collect();
    let title = if result.robots.len() == 1 {
        format!("{} ({:?})", scenario.spec.name, result.summary.controller)
    } else {
        format!(
            "{} ({:?}), robot {}",
            scenario.spec.name, result.summary.controller, first.name
        )
    };
    plot_trajectory(
        &dir.join("trajectory"),
        &TrajectoryPlot {
            title: &title,
            robot_path: &robot_path,
            robot_label: "robot path",
            other_paths: &[],
            reference_path: &reference_path,
            walls: &walls,
            circles: &circles,
            mover_paths: &movers,
            safety_radius_m: scenario.params.robot_radius_m() + scenario.params.barrier.d_safe_m,
            body_radius_m: scenario.robot.body_radius_m,
            collisions: &collisions,
            goal: first.goal,
            body: body_outline(scenario, &polygon, &headings),
        },
    )?;

    let (bl, br) = (col(|r| r.b_left), col(|r| r.b_right));
    let (dl, dr, h) = (col(|r| r.d_left_m), col(|r| r.d_right_m), col(|r| r.h_true_m));
    let bmax = bl
        .iter()
        .chain(&br)
        .filter(|v| v.is_finite())
        .fold(1.0f64, |a, &b| a.max(b));
    plot_time_series(
        &dir.join("barriers"),
        &format!("{title}: barrier values (paper Fig. 5, left)"),
        &t,
        &[
            TimePanel {
                y_label: "B",
                series: vec![
                    Series {
                        label: "B_l",
                        values: &bl,
                    },
                    Series {
                        label: "B_r",
                        values: &br,
                    },
                ],
                y_range: Some((0.0, bmax.min(10.0) * 1.05)),
            },
            TimePanel {
                y_label: "distance (m)",
                series: vec![
                    Series {
                        label: "d_l",
                        values: &dl,
                    },
                    Series {
                        label: "d_r",
                        values: &dr,
                    },
                    Series {
                        label: "h (exact)",
                        values: &h,
                    },
                ],
                y_range: Some((-0.1, 3.0)),
            },
        ],
    )?;

    let (v, w) = (col(|r| r.v_cmd_mps), col(|r| r.omega_cmd_radps));
    let (vn, wn) = (col(|r| r.v_nominal_mps), col(|r| r.omega_nominal_radps));
    plot_time_series(
        &dir.join("velocities"),
        &format!("{title}: commands (paper Figs. 5-6)"),
        &t,
        &[
            TimePanel {
                y_label: "v (m/s)",
                series: vec![
                    Series {
                        label: "v sent",
                        values: &v,
                    },
                    Series {
                        label: "v nominal",
                        values: &vn,
                    },
                ],
                y_range: None,
            },
            TimePanel {
                y_label: "ω (rad/s)",
                series: vec![
                    Series {
                        label: "ω sent",
                        values: &w,
                    },
                    Series {
                        label: "ω nominal",
                        values: &wn,
                    },
                ],
                y_range: None,
            },
        ],
    )?;
    Ok(())
}

/// The robot body's polygon for the plots (robot frame, m): the simulated
/// body's, else the filter's footprint; empty for a disc.
pub(crate) fn body_polygon(scenario: &Scenario) -> Vec<nalgebra::Vector2<f64>> {
    let fp = &scenario.params.footprint.polygon_m;
    scenario
        .spec
        .robot
        .body_polygon_vertices_m()
        .unwrap_or(fp)
        .iter()
        .map(|&[x, y]| nalgebra::Vector2::new(x, y))
        .collect()
}

/// The trajectory plot's polygon body, when there is one: `polygon` posed
/// with `headings`, its safety outline at the footprint's padding + d_safe.
pub(crate) fn body_outline<'a>(
    scenario: &Scenario,
    polygon: &'a [nalgebra::Vector2<f64>],
    headings: &'a [f64],
) -> Option<crate::plot::BodyOutline<'a>> {
    (polygon.len() >= 3).then_some(crate::plot::BodyOutline {
        polygon_m: polygon,
        headings_rad: headings,
        grow_m: scenario.params.footprint.padding_m + scenario.params.barrier.d_safe_m,
    })
}
