//! The `odometry:` section: the wheels' measurement noise behind the
//! odometry covariance (docs/CAN.md, "Odometry covariance"), and its rules.

use crate::odometry::WheelNoise;
use oldbf::config::{Checker, Interval};
use serde::{Deserialize, Serialize};

/// Per-wheel noise of the wheel measurements.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OdometryConfig {
    /// Variance of the left wheel's rolled distance per metre it rolls (m²/m).
    pub left_travel_variance_m2_per_m: f64,
    /// The same for the right wheel (m²/m).
    pub right_travel_variance_m2_per_m: f64,
    /// Standard deviation of the left wheel's measured speed at the wheel (rad/s).
    pub left_speed_sigma_radps: f64,
    /// The same for the right wheel (rad/s).
    pub right_speed_sigma_radps: f64,
}

/// Zero would claim a perfect measurement (filters then trust odometry
/// over every other sensor, or reject it); the upper ends are far beyond
/// any wheel that still measures something.
const TRAVEL_VARIANCE: Interval = Interval::open_closed(0.0, 1.0).unit("m²/m");
const SPEED_SIGMA: Interval = Interval::open_closed(0.0, 100.0).unit("rad/s");

impl OdometryConfig {
    /// The model's parameters.
    pub fn noise(&self) -> WheelNoise {
        WheelNoise {
            left_travel_variance_m2_per_m: self.left_travel_variance_m2_per_m,
            right_travel_variance_m2_per_m: self.right_travel_variance_m2_per_m,
            left_speed_sigma_radps: self.left_speed_sigma_radps,
            right_speed_sigma_radps: self.right_speed_sigma_radps,
        }
    }

    pub(super) fn check(&self, c: &mut Checker) {
        c.range(
            "odometry.left_travel_variance_m2_per_m",
            self.left_travel_variance_m2_per_m,
            TRAVEL_VARIANCE,
        );
        c.range(
            "odometry.right_travel_variance_m2_per_m",
            self.right_travel_variance_m2_per_m,
            TRAVEL_VARIANCE,
        );
        c.range(
            "odometry.left_speed_sigma_radps",
            self.left_speed_sigma_radps,
            SPEED_SIGMA,
        );
        c.range(
            "odometry.right_speed_sigma_radps",
            self.right_speed_sigma_radps,
            SPEED_SIGMA,
        );
    }
}
