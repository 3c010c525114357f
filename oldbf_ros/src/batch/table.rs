//! The comparison as text (for the terminal) and as CSV (for the paper).
//!
//! Why both: the text table is for reading (aligned, rates with counts,
//! three decimals); the CSV keeps every figure at full precision, one column
//! per field of [`ControllerStats`], units in the column names.

use super::{controller_name, BatchReport, ControllerStats, WorldOutcome};
use std::fmt::Write as _;

/// `–` for a missing value, else `v` with `decimals`.
fn opt(v: Option<f64>, decimals: usize) -> String {
    v.map_or("–".to_string(), |x| format!("{x:.decimals$}"))
}

fn rate(r: f64, count: usize, total: usize) -> String {
    format!("{r:.2} ({count}/{total})")
}

/// The header of the text table, two lines per column (name, unit).
const TEXT_HEADER: [(&str, &str); 16] = [
    ("controller", ""),
    ("worlds", ""),
    ("collision", "rate"),
    ("closing", "(worlds)"),
    ("passive", "(worlds)"),
    ("min clear. (m)", "median / p5"),
    ("goal", "rate"),
    ("goal in", "budget"),
    ("time to", "goal (s)"),
    ("stalled", "mean (s)"),
    ("TV v / ω", "per s"),
    ("rev. Δv / Δω", "% steps"),
    ("CBF viol. logged", "all / feasible"),
    ("braking viol.", "all / feasible"),
    ("infeasible", "steps"),
    ("step (µs)", "mean / p99"),
];

fn text_cells(r: &ControllerStats) -> [String; 16] {
    [
        controller_name(r.controller),
        r.worlds.to_string(),
        rate(r.collision_rate, r.worlds_with_collision, r.worlds),
        format!("{} ({})", r.closing_contacts_total, r.worlds_with_closing_contact),
        format!("{} ({})", r.passive_contacts_total, r.worlds_with_passive_contact),
        format!(
            "{} / {}",
            opt(r.min_clearance_median_m, 3),
            opt(r.min_clearance_p5_m, 3)
        ),
        rate(r.goal_rate_with_path, r.worlds_reached_with_path, r.worlds_with_path),
        match (r.goal_within_budget_rate_with_path, r.worlds_within_budget_with_path) {
            (Some(x), Some(n)) => rate(x, n, r.worlds_with_path),
            _ => "–".to_string(),
        },
        opt(r.mean_time_to_goal_s, 1),
        opt(r.mean_stalled_s, 1),
        format!(
            "{} / {} ({} / {})",
            opt(r.mean_variation_v_per_s, 3),
            opt(r.mean_variation_omega_per_s, 3),
            opt(r.mean_upstream_variation_v_per_s, 3),
            opt(r.mean_upstream_variation_omega_per_s, 3)
        ),
        format!(
            "{:.2} / {:.2}",
            100.0 * r.v_reversal_rate,
            100.0 * r.omega_reversal_rate
        ),
        format!("{} / {}", r.cbf_violations_total, r.cbf_violations_feasible_total),
        format!(
            "{} / {}",
            r.braking_violations_total, r.braking_violations_feasible_total
        ),
        r.infeasible_steps_total.to_string(),
        format!("{} / {}", opt(r.mean_step_us, 1), opt(r.p99_step_us, 1)),
    ]
}

/// The readable comparison: a title line, the aligned table (one row per
/// controller) and a legend of the columns.
pub fn text(report: &BatchReport) -> String {
    let mut rows: Vec<[String; 16]> = vec![
        TEXT_HEADER.map(|(name, _)| name.to_string()),
        TEXT_HEADER.map(|(_, unit)| unit.to_string()),
    ];
    rows.extend(report.rows.iter().map(text_cells));
    let widths: Vec<usize> = (0..TEXT_HEADER.len())
        .map(|c| rows.iter().map(|r| r[c].chars().count()).max().unwrap_or(0))
        .collect();
    let mut out = String::new();
    let _ = writeln!(
        out,
        "batch {} ({}) | {} worlds | seed {} | {} thread{} | {:.1} s",
        report.name,
        report.template,
        report.worlds,
        report.seed,
        report.threads,
        if report.threads == 1 { "" } else { "s" },
        report.wall_time_s
    );
    for (i, row) in rows.iter().enumerate() {
        let mut line = String::new();
        for (c, cell) in row.iter().enumerate() {
            let pad = widths[c] - cell.chars().count();
            if c == 0 {
                let _ = write!(line, "{cell}{}", " ".repeat(pad));
            } else {
                let _ = write!(line, "  {}{cell}", " ".repeat(pad));
            }
        }
        let _ = writeln!(out, "{}", line.trim_end());
        if i == 1 {
            let total: usize = widths.iter().sum::<usize>() + 2 * (widths.len() - 1);
            let _ = writeln!(out, "{}", "-".repeat(total));
        }
    }
    for line in [
        "collision rate: worlds with >= 1 contact (worlds with / worlds).",
        "closing: contacts the robot drove into (its speed towards the touched point > 0.02 m/s at the",
        "  onset); passive: the others (at rest, turning or moving away); contacts (worlds with any).",
        "min clear.: each world's least body-to-obstacle distance; median and 5th percentile over worlds.",
        "goal rate: over the worlds where a path keeps r + d_safe from the static obstacles (reached / those).",
        "goal in budget: of those, reached within time_budget_factor x line length / v_nom (– without a budget).",
        "time to goal: mean over the worlds reached. stalled: |v| < 0.02 m/s before the goal, mean over worlds.",
        "TV v / ω: total variation of the command (sum of |dv|, |domega|) per second, mean over worlds;",
        "  in brackets the same of the upstream command (a tracking controller's varies with the deviation).",
        "rev. dv / domega: sign reversals of the command's change (both steps above 0.02 m/s, omega_max/6).",
        "CBF viol.: steps where h(k+1) >= (1 - gamma) h(k) failed for the sent command (from the scan);",
        "  feasible: of those, steps the filter did not mark infeasible. braking viol.: steps whose command",
        "  could not brake to rest without a predicted closing contact (ALGORITHM.md 5b), all / feasible.",
        "step: the safety path's compute per control step (scan to command, less the way-round work the",
        "  simulator does in step and the node does in a thread of its own) over every step of every world,",
        "  in the thread's CPU time (time the OS ran other work is not counted).",
    ] {
        let _ = writeln!(out, "{line}");
    }
    out
}

/// Column names of [`csv`], in order (the fields of [`ControllerStats`]).
pub const CSV_COLUMNS: [&str; 54] = [
    "controller",
    "worlds",
    "worlds_with_collision",
    "collision_rate",
    "collisions_total",
    "closing_contacts_total",
    "worlds_with_closing_contact",
    "passive_contacts_total",
    "worlds_with_passive_contact",
    "min_clearance_min_m",
    "min_clearance_p5_m",
    "min_clearance_median_m",
    "worlds_reached",
    "goal_rate",
    "worlds_with_path",
    "worlds_reached_with_path",
    "goal_rate_with_path",
    "worlds_within_budget_with_path",
    "goal_within_budget_rate_with_path",
    "mean_time_to_goal_s",
    "mean_path_length_m",
    "mean_max_tracking_error_m",
    "cbf_violations_total",
    "worlds_with_cbf_violation",
    "true_cbf_violations_total",
    "worlds_with_true_cbf_violation",
    "cbf_violations_feasible_total",
    "braking_violations_total",
    "braking_violations_feasible_total",
    "infeasible_steps_total",
    "driven_blind_steps_total",
    "blind_steps_total",
    "mean_variation_v_per_s",
    "mean_variation_omega_per_s",
    "mean_upstream_variation_v_per_s",
    "mean_upstream_variation_omega_per_s",
    "omega_reversal_rate",
    "v_reversal_rate",
    "window_exceeded_total",
    "state_switches_per_min",
    "above_upstream_steps_total",
    "above_upstream_escape_steps_total",
    "reverse_escape_steps_total",
    "reverse_evade_steps_total",
    "reverse_other_steps_total",
    "v_sign_changes_total",
    "moving_track_step_rate",
    "evade_steps_total",
    "mean_stalled_s",
    "steps_total",
    "mean_step_us",
    "p99_step_us",
    "max_step_us",
    "template",
];

/// A CSV number: full precision, empty when missing.
fn num(v: Option<f64>) -> String {
    v.map_or(String::new(), |x| x.to_string())
}

/// The comparison as CSV: a header ([`CSV_COLUMNS`]) and one row per controller.
pub fn csv(report: &BatchReport) -> String {
    let mut out = CSV_COLUMNS.join(",");
    out.push('\n');
    for r in &report.rows {
        let cells = [
            controller_name(r.controller),
            r.worlds.to_string(),
            r.worlds_with_collision.to_string(),
            r.collision_rate.to_string(),
            r.collisions_total.to_string(),
            r.closing_contacts_total.to_string(),
            r.worlds_with_closing_contact.to_string(),
            r.passive_contacts_total.to_string(),
            r.worlds_with_passive_contact.to_string(),
            num(r.min_clearance_min_m),
            num(r.min_clearance_p5_m),
            num(r.min_clearance_median_m),
            r.worlds_reached.to_string(),
            r.goal_rate.to_string(),
            r.worlds_with_path.to_string(),
            r.worlds_reached_with_path.to_string(),
            r.goal_rate_with_path.to_string(),
            r.worlds_within_budget_with_path
                .map_or(String::new(), |n| n.to_string()),
            num(r.goal_within_budget_rate_with_path),
            num(r.mean_time_to_goal_s),
            num(r.mean_path_length_m),
            num(r.mean_max_tracking_error_m),
            r.cbf_violations_total.to_string(),
            r.worlds_with_cbf_violation.to_string(),
            r.true_cbf_violations_total.to_string(),
            r.worlds_with_true_cbf_violation.to_string(),
            r.cbf_violations_feasible_total.to_string(),
            r.braking_violations_total.to_string(),
            r.braking_violations_feasible_total.to_string(),
            r.infeasible_steps_total.to_string(),
            r.driven_blind_steps_total.to_string(),
            r.blind_steps_total.to_string(),
            num(r.mean_variation_v_per_s),
            num(r.mean_variation_omega_per_s),
            num(r.mean_upstream_variation_v_per_s),
            num(r.mean_upstream_variation_omega_per_s),
            r.omega_reversal_rate.to_string(),
            r.v_reversal_rate.to_string(),
            r.window_exceeded_total.to_string(),
            r.state_switches_per_min.to_string(),
            r.above_upstream_steps_total.to_string(),
            r.above_upstream_escape_steps_total.to_string(),
            r.reverse_escape_steps_total.to_string(),
            r.reverse_evade_steps_total.to_string(),
            r.reverse_other_steps_total.to_string(),
            r.v_sign_changes_total.to_string(),
            r.moving_track_step_rate.to_string(),
            r.evade_steps_total.to_string(),
            num(r.mean_stalled_s),
            r.steps_total.to_string(),
            num(r.mean_step_us),
            num(r.p99_step_us),
            num(r.max_step_us),
            report.name.clone(),
        ];
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    out
}

/// Every (world, controller) outcome as CSV, one row each.
pub fn per_world_csv(outcomes: &[WorldOutcome]) -> String {
    let mut out = String::from(
        "world,controller,sensor_seed,path_exists,label,steps,collisions,closing_contacts,passive_contacts,min_clearance_m,\
         reached_goal,time_to_goal_s,time_budget_s,goal_within_budget,path_length_m,max_tracking_error_m,cbf_violations,true_cbf_violations,\
         cbf_violations_feasible,braking_violations,braking_violations_feasible,infeasible_steps,\
         driven_blind_steps,blind_steps,variation_v_per_s,variation_omega_per_s,upstream_variation_v_per_s,upstream_variation_omega_per_s,\
         omega_reversals,v_reversals,\
         window_exceeded,state_switches,above_upstream_steps,above_upstream_escape_steps,reverse_escape_steps,reverse_evade_steps,\
         reverse_other_steps,v_sign_changes,moving_track_steps,evade_steps,stalled_s,mean_step_us\n",
    );
    for o in outcomes {
        let m = &o.figures.motion;
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            o.world,
            controller_name(o.controller),
            o.sensor_seed,
            o.path_exists,
            o.label,
            o.steps,
            o.figures.collisions,
            o.figures.closing_contacts,
            o.figures.passive_contacts,
            o.figures.min_clearance_m,
            o.figures.reached_goal,
            num(o.figures.time_to_goal_s),
            num(o.time_budget_s),
            o.goal_within_budget.map_or(String::new(), |b| b.to_string()),
            o.figures.path_length_m,
            num(o.figures.max_tracking_error_m),
            o.figures.cbf_violations,
            o.figures.true_cbf_violations,
            o.figures.cbf_violations_feasible,
            o.figures.braking_violations,
            o.figures.braking_violations_feasible,
            o.figures.infeasible_steps.total(),
            o.figures.driven_blind_steps,
            o.figures.blind_steps,
            m.variation_v_per_s(),
            m.variation_omega_per_s(),
            m.upstream_variation_v_per_s(),
            m.upstream_variation_omega_per_s(),
            m.omega_reversals,
            m.v_reversals,
            m.window_exceeded,
            m.state_switches,
            m.above_upstream_steps,
            m.above_upstream_escape_steps,
            m.reverse_escape_steps,
            m.reverse_evade_steps,
            m.reverse_other_steps,
            m.v_sign_changes,
            m.moving_track_steps,
            m.evade_steps,
            o.figures.stalled_s,
            o.mean_step_us
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::run::Controller;

    fn report() -> BatchReport {
        let row = |controller, collisions| ControllerStats {
            controller,
            worlds: 4,
            worlds_with_collision: collisions,
            collision_rate: collisions as f64 / 4.0,
            collisions_total: collisions,
            closing_contacts_total: collisions / 2,
            worlds_with_closing_contact: collisions / 2,
            passive_contacts_total: collisions - collisions / 2,
            worlds_with_passive_contact: collisions - collisions / 2,
            min_clearance_min_m: Some(-0.0125),
            min_clearance_p5_m: Some(0.01),
            min_clearance_median_m: Some(0.2),
            worlds_reached: 3,
            goal_rate: 0.75,
            worlds_with_path: 4,
            worlds_reached_with_path: 3,
            goal_rate_with_path: 0.75,
            worlds_within_budget_with_path: Some(2),
            goal_within_budget_rate_with_path: Some(0.5),
            mean_time_to_goal_s: None,
            mean_path_length_m: Some(6.5),
            mean_max_tracking_error_m: Some(0.5),
            cbf_violations_total: 7,
            worlds_with_cbf_violation: 2,
            true_cbf_violations_total: 1,
            worlds_with_true_cbf_violation: 1,
            cbf_violations_feasible_total: 0,
            braking_violations_total: 3,
            braking_violations_feasible_total: 0,
            infeasible_steps_total: 5,
            driven_blind_steps_total: 0,
            blind_steps_total: 0,
            mean_variation_v_per_s: Some(0.0125),
            mean_variation_omega_per_s: Some(0.25),
            mean_upstream_variation_v_per_s: Some(0.01),
            mean_upstream_variation_omega_per_s: Some(0.02),
            omega_reversal_rate: 0.0125,
            v_reversal_rate: 0.0,
            window_exceeded_total: 0,
            state_switches_per_min: 3.0,
            above_upstream_steps_total: 0,
            above_upstream_escape_steps_total: 0,
            reverse_escape_steps_total: 1,
            reverse_evade_steps_total: 0,
            reverse_other_steps_total: 0,
            v_sign_changes_total: 1,
            moving_track_step_rate: 0.0,
            evade_steps_total: 0,
            mean_stalled_s: Some(2.5),
            steps_total: 4000,
            mean_step_us: Some(6.25),
            p99_step_us: Some(40.0),
            max_step_us: Some(80.0),
        };
        BatchReport {
            template: "t.yaml".into(),
            name: "t".into(),
            seed: 1,
            worlds: 4,
            controllers: vec![Controller::Oldbf, Controller::None],
            threads: 2,
            wall_time_s: 1.0,
            rows: vec![row(Controller::Oldbf, 0), row(Controller::None, 3)],
            per_world: vec![],
        }
    }

    #[test]
    fn text_table_has_one_aligned_row_per_controller() {
        let t = text(&report());
        let lines: Vec<&str> = t.lines().collect();
        assert!(lines[0].starts_with("batch t (t.yaml) | 4 worlds | seed 1"), "{t}");
        let oldbf = lines.iter().find(|l| l.starts_with("oldbf")).expect("oldbf row");
        let none = lines.iter().find(|l| l.starts_with("none")).expect("none row");
        assert_eq!(oldbf.chars().count(), none.chars().count(), "{t}");
        assert!(oldbf.contains("0.00 (0/4)") && none.contains("0.75 (3/4)"), "{t}");
        assert!(oldbf.contains("0.50 (2/4)"), "goal within budget: {t}");
        // none: 3 contacts, 1 closing in 1 world, 2 passive in 2.
        assert!(none.contains("1 (1)") && none.contains("2 (2)"), "{t}");
        assert!(oldbf.contains("0.200 / 0.010") && oldbf.contains("6.2 / 40.0"), "{t}");
        assert!(
            oldbf.contains("0.013 / 0.250")
                && oldbf.contains("0.00 / 1.25")
                && oldbf.contains("7 / 0")
                && oldbf.contains("3 / 0"),
            "{t}"
        );
        // A missing mean time to goal is a dash, not NaN.
        assert!(oldbf.contains('–') && !t.contains("NaN"), "{t}");
    }

    #[test]
    fn csv_columns_are_the_json_fields() {
        let r = report();
        let c = csv(&r);
        let mut lines = c.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!(header, CSV_COLUMNS);
        let json = serde_json::to_value(&r.rows[0]).unwrap();
        let mut fields: Vec<&str> = json.as_object().unwrap().keys().map(String::as_str).collect();
        fields.push("template");
        let (mut a, mut b) = (header.clone(), fields);
        a.sort_unstable();
        b.sort_unstable();
        assert_eq!(a, b, "CSV columns and JSON fields differ");
        let row: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!(row.len(), CSV_COLUMNS.len());
        assert_eq!(row[0], "oldbf");
        assert_eq!(row[9], "-0.0125");
        assert_eq!((row[17], row[18]), ("2", "0.5"), "goal within budget");
        assert_eq!(row[19], "", "a missing value is an empty cell");
        assert_eq!(lines.count(), 1);
    }
}
