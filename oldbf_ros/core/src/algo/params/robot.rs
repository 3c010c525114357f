//! The robot: control limits and rates, and its footprint.

use crate::algo::footprint::{passing_half_width_m, PaddedPolygon, Polygon, PolygonError};
use crate::algo::geometry::Vec2;
use serde::{Deserialize, Serialize};

/// Control loop and input box.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControlParams {
    /// Control loop rate (Hz); the DTCBF step is Δt = 1 / rate_hz.
    pub rate_hz: f64,
    /// Nominal forward speed when neither a reference nor an upstream command is given (m/s).
    pub v_nom_mps: f64,
    /// Largest forward speed ever commanded (m/s).
    pub v_max_mps: f64,
    /// Largest yaw rate ever commanded (rad/s); the paper's hardware limit is 0.3.
    pub omega_max_radps: f64,
    /// Whether the filter may command negative linear speed (backing up). It
    /// does so only on scans that cover the robot's rear (a 360° LiDAR): a
    /// robot never backs into what it cannot see.
    pub allow_reverse: bool,
    /// Largest reverse speed when `allow_reverse` (m/s, given as a positive number).
    pub v_reverse_max_mps: f64,
    /// The base's linear acceleration limit (m/s²): how fast |v| may grow
    /// from the command last sent (the dynamic window, §5c).
    pub accel_mps2: f64,
    /// The base's linear deceleration (m/s²): how fast |v| may fall in the
    /// window, and what the braking check (§5b) assumes the robot can always
    /// brake at. One number for both, so the filter never sends a command
    /// the braking check did not assume.
    pub decel_mps2: f64,
    /// The base's angular acceleration limit (rad/s²): how fast ω may change
    /// from the command last sent, either way.
    pub angular_accel_radps2: f64,
}

impl Default for ControlParams {
    fn default() -> Self {
        Self {
            rate_hz: 10.0,
            v_nom_mps: 0.15,
            v_max_mps: 0.22,
            omega_max_radps: 0.3,
            allow_reverse: true,
            v_reverse_max_mps: 0.15,
            accel_mps2: 0.5,
            decel_mps2: 1.0,
            angular_accel_radps2: 1.0,
        }
    }
}

impl ControlParams {
    /// Control period Δt (s).
    pub fn dt_s(&self) -> f64 {
        1.0 / self.rate_hz
    }
}

/// Robot footprint: r = max(l1, l2) + b/2 (paper III.A) unless overridden.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FootprintParams {
    /// l1: first semi-axis of the robot (m).
    pub semi_axis_1_m: f64,
    /// l2: second semi-axis of the robot (m).
    pub semi_axis_2_m: f64,
    /// b: the robot's overall dimension in the paper's formula (m).
    pub overall_dimension_m: f64,
    /// If set, used as r instead of the formula (m). Absent rather than null in
    /// YAML: ROS parameters travel over XML-RPC, which has no null.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius_override_m: Option<f64>,
    /// The footprint as a simple polygon in the robot frame, `[[x, y], ...]`
    /// (m; costmap_2d's `footprint`), convex or not; empty: the circle above.
    /// h, the barriers, the one-step condition, the clearance critic and the
    /// braking check take it exactly; what still uses a circle (the mover
    /// predictions and critic, the way round) uses its circumscribed circle
    /// about the robot's origin, [`Self::radius_m`].
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub polygon_m: Vec<[f64; 2]>,
    /// Grows the footprint (polygon or circle) by this much all round (m;
    /// costmap_2d's `footprint_padding`).
    pub padding_m: f64,
}

impl Default for FootprintParams {
    fn default() -> Self {
        // TurtleBot3 burger: 178 mm long, 138 mm wide.
        Self {
            semi_axis_1_m: 0.089,
            semi_axis_2_m: 0.069,
            overall_dimension_m: 0.178,
            radius_override_m: None,
            polygon_m: Vec::new(),
            padding_m: 0.0,
        }
    }
}

impl FootprintParams {
    /// Robot radius r (m): the circle every check keeps clear. With a
    /// polygon, the padded polygon's circumscribed radius about the origin
    /// (the farthest vertex); else the paper's formula or the override, plus
    /// the padding.
    pub fn radius_m(&self) -> f64 {
        if self.polygon_m.is_empty() {
            self.radius_override_m
                .unwrap_or_else(|| self.semi_axis_1_m.max(self.semi_axis_2_m) + self.overall_dimension_m / 2.0)
                + self.padding_m
        } else {
            self.polygon_m
                .iter()
                .map(|&[x, y]| x * x + y * y)
                .fold(0.0, f64::max)
                .sqrt()
                + self.padding_m
        }
    }

    /// How far the body reaches to either side of its origin along its
    /// narrowest way, padding included (m): the polygon's
    /// [`Polygon::passing_half_width_m`], or r for the circle. What a
    /// doorway or a gap must leave it, beyond d_safe, on each side.
    pub fn passing_half_width_m(&self) -> f64 {
        if self.polygon_m.is_empty() {
            return self.radius_m();
        }
        // From the vertices as given: the way round asks on every scan.
        passing_half_width_m(self.polygon_m.iter().map(|&[x, y]| Vec2::new(x, y))) + self.padding_m
    }

    /// The padded polygon, if one is given and valid.
    pub fn polygon(&self) -> Option<Result<PaddedPolygon, PolygonError>> {
        if self.polygon_m.is_empty() {
            return None;
        }
        let v: Vec<Vec2> = self.polygon_m.iter().map(|&[x, y]| Vec2::new(x, y)).collect();
        Some(Polygon::new(&v).map(|polygon| PaddedPolygon {
            polygon,
            padding_m: self.padding_m,
        }))
    }
}
