//! Moving obstacles (discs) and their motion laws.
//!
//! Why closed forms: every law here gives the position as a function of time
//! alone (`position_at(t)`), with no integrated state. A scenario is then
//! reproducible at any time step, two runs with different `dt` see the
//! obstacles in the same places, and a plot can sample the trajectory freely.
//!
//! Units: positions m (world frame), velocities m/s, times s. The YAML spec
//! types reject unknown keys; [`MovingObstacle::new`] rejects bad values with
//! a message naming the field.

use crate::algo::geometry::Vec2;
use serde::{Deserialize, Serialize};
use std::fmt;

/// A moving disc as written in a scenario file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MovingObstacleSpec {
    /// Disc radius (m), > 0.
    pub radius_m: f64,
    /// How the disc centre moves.
    pub motion: MotionSpec,
    /// Optional label for logs and plots.
    #[serde(default)]
    pub name: Option<String>,
}

/// Motion law of a moving obstacle's centre (YAML: `kind: constant_velocity`,
/// `waypoint_loop` or `bounce`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum MotionSpec {
    /// Holds still at `start` (m) until `start_time_s` (s), then moves with
    /// `velocity_mps` (m/s) forever.
    ConstantVelocity {
        start: [f64; 2],
        velocity_mps: [f64; 2],
        #[serde(default)]
        start_time_s: f64,
    },
    /// Moves at `speed_mps` (m/s, ≥ 0) along the closed polyline
    /// w0 → w1 → … → wn → w0 (m), repeating; at w0 at t = 0.
    WaypointLoop { waypoints: Vec<[f64; 2]>, speed_mps: f64 },
    /// Starts at `start` (m) with `velocity_mps` (m/s) and reflects
    /// elastically off the edges of the axis-aligned box
    /// [`region_min`, `region_max`] (m); the centre stays inside the box.
    Bounce {
        start: [f64; 2],
        velocity_mps: [f64; 2],
        region_min: [f64; 2],
        region_max: [f64; 2],
    },
}

/// The validated, ready-to-evaluate motion law (internal).
#[derive(Debug, Clone, PartialEq)]
enum Law {
    ConstantVelocity {
        start: Vec2,
        velocity_mps: Vec2,
        start_time_s: f64,
    },
    WaypointLoop {
        /// w0 … wn (m).
        points: Vec<Vec2>,
        /// `cum_m[i]` = path length from w0 to wi (m); `cum_m[0] = 0`.
        cum_m: Vec<f64>,
        /// Length of the closed loop (m), > 0.
        perimeter_m: f64,
        speed_mps: f64,
    },
    Bounce {
        start: Vec2,
        velocity_mps: Vec2,
        min: Vec2,
        max: Vec2,
    },
}

/// A moving disc whose centre follows a closed-form motion law.
#[derive(Debug, Clone, PartialEq)]
pub struct MovingObstacle {
    radius_m: f64,
    name: Option<String>,
    law: Law,
}

/// A point `[x, y]` of a motion law, as named in messages (`motion.start`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PointField {
    Start,
    VelocityMps,
    RegionMin,
    RegionMax,
    /// `motion.waypoints[i]`.
    Waypoint(usize),
}

impl fmt::Display for PointField {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Start => f.write_str("motion.start"),
            Self::VelocityMps => f.write_str("motion.velocity_mps"),
            Self::RegionMin => f.write_str("motion.region_min"),
            Self::RegionMax => f.write_str("motion.region_max"),
            Self::Waypoint(i) => write!(f, "motion.waypoints[{i}]"),
        }
    }
}

/// Why [`MovingObstacle::new`] rejected a spec, with the offending values as
/// data, so that a scenario error can name the field without parsing text.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MovingObstacleError {
    #[error("radius_m must be > 0 and finite (got {radius_m})")]
    Radius { radius_m: f64 },
    #[error("{field} must be finite (got {value:?})")]
    NotFinite { field: PointField, value: [f64; 2] },
    #[error("motion.start_time_s must be finite (got {start_time_s})")]
    StartTime { start_time_s: f64 },
    #[error("motion.speed_mps must be >= 0 and finite (got {speed_mps})")]
    Speed { speed_mps: f64 },
    /// The loop through the waypoints has no positive finite length.
    #[error(
        "motion.waypoints needs at least 2 distinct points (got {points} point(s), loop length {loop_length_m} m)"
    )]
    Waypoints { points: usize, loop_length_m: f64 },
    #[error("motion.region_min must be < motion.region_max on both axes (got {region_min:?}, {region_max:?})")]
    EmptyRegion { region_min: [f64; 2], region_max: [f64; 2] },
    #[error("motion.start {start:?} must lie inside the region [{region_min:?}, {region_max:?}]")]
    StartOutside {
        start: [f64; 2],
        region_min: [f64; 2],
        region_max: [f64; 2],
    },
}

impl MovingObstacleError {
    /// The field the error is about, relative to the obstacle (`radius_m`,
    /// `motion.start`); None when the message names the obstacle as a whole
    /// (a waypoint, the waypoint count, the start outside its region).
    pub fn field(&self) -> Option<String> {
        match self {
            Self::Radius { .. } => Some("radius_m".into()),
            Self::NotFinite {
                field: PointField::Waypoint(_),
                ..
            } => None,
            Self::NotFinite { field, .. } => Some(field.to_string()),
            Self::StartTime { .. } => Some("motion.start_time_s".into()),
            Self::Speed { .. } => Some("motion.speed_mps".into()),
            Self::EmptyRegion { .. } => Some("motion.region_min".into()),
            Self::Waypoints { .. } | Self::StartOutside { .. } => None,
        }
    }

    /// The message without [`Self::field`] (the whole message when that is None).
    pub fn detail(&self) -> String {
        match self {
            Self::Radius { radius_m } => format!("must be > 0 and finite (got {radius_m})"),
            Self::NotFinite {
                field: PointField::Waypoint(_),
                ..
            } => self.to_string(),
            Self::NotFinite { value, .. } => format!("must be finite (got {value:?})"),
            Self::StartTime { start_time_s } => format!("must be finite (got {start_time_s})"),
            Self::Speed { speed_mps } => format!("must be >= 0 and finite (got {speed_mps})"),
            Self::EmptyRegion { region_min, region_max } => {
                format!("must be < motion.region_max on both axes (got {region_min:?}, {region_max:?})")
            }
            Self::Waypoints { .. } | Self::StartOutside { .. } => self.to_string(),
        }
    }
}

fn finite2(v: [f64; 2], field: PointField) -> Result<Vec2, MovingObstacleError> {
    if v[0].is_finite() && v[1].is_finite() {
        Ok(Vec2::new(v[0], v[1]))
    } else {
        Err(MovingObstacleError::NotFinite { field, value: v })
    }
}

impl MovingObstacle {
    /// Validates `spec`: radius > 0 and finite, all coordinates, velocities
    /// and times finite, a waypoint loop needs ≥ 2 distinct waypoints and a
    /// speed ≥ 0, a bounce region needs `region_min < region_max` on both
    /// axes with `start` inside it. Errors name the offending field.
    pub fn new(spec: &MovingObstacleSpec) -> Result<MovingObstacle, MovingObstacleError> {
        if !(spec.radius_m.is_finite() && spec.radius_m > 0.0) {
            return Err(MovingObstacleError::Radius {
                radius_m: spec.radius_m,
            });
        }
        let law = match &spec.motion {
            MotionSpec::ConstantVelocity {
                start,
                velocity_mps,
                start_time_s,
            } => {
                if !start_time_s.is_finite() {
                    return Err(MovingObstacleError::StartTime {
                        start_time_s: *start_time_s,
                    });
                }
                Law::ConstantVelocity {
                    start: finite2(*start, PointField::Start)?,
                    velocity_mps: finite2(*velocity_mps, PointField::VelocityMps)?,
                    start_time_s: *start_time_s,
                }
            }
            MotionSpec::WaypointLoop { waypoints, speed_mps } => {
                if !(speed_mps.is_finite() && *speed_mps >= 0.0) {
                    return Err(MovingObstacleError::Speed { speed_mps: *speed_mps });
                }
                let points = waypoints
                    .iter()
                    .enumerate()
                    .map(|(i, w)| finite2(*w, PointField::Waypoint(i)))
                    .collect::<Result<Vec<_>, _>>()?;
                let n = points.len();
                let mut cum_m = Vec::with_capacity(n);
                let mut acc = 0.0;
                for i in 0..n {
                    cum_m.push(acc);
                    acc += (points[(i + 1) % n] - points[i]).norm();
                }
                if !(acc > 0.0 && acc.is_finite()) {
                    return Err(MovingObstacleError::Waypoints {
                        points: n,
                        loop_length_m: acc,
                    });
                }
                Law::WaypointLoop {
                    points,
                    cum_m,
                    perimeter_m: acc,
                    speed_mps: *speed_mps,
                }
            }
            MotionSpec::Bounce {
                start,
                velocity_mps,
                region_min,
                region_max,
            } => {
                let start = finite2(*start, PointField::Start)?;
                let velocity_mps = finite2(*velocity_mps, PointField::VelocityMps)?;
                let min = finite2(*region_min, PointField::RegionMin)?;
                let max = finite2(*region_max, PointField::RegionMax)?;
                if !(min.x < max.x && min.y < max.y) {
                    return Err(MovingObstacleError::EmptyRegion {
                        region_min: *region_min,
                        region_max: *region_max,
                    });
                }
                if !(min.x <= start.x && start.x <= max.x && min.y <= start.y && start.y <= max.y) {
                    return Err(MovingObstacleError::StartOutside {
                        start: [start.x, start.y],
                        region_min: *region_min,
                        region_max: *region_max,
                    });
                }
                Law::Bounce {
                    start,
                    velocity_mps,
                    min,
                    max,
                }
            }
        };
        Ok(MovingObstacle {
            radius_m: spec.radius_m,
            name: spec.name.clone(),
            law,
        })
    }

    /// Disc radius (m).
    pub fn radius_m(&self) -> f64 {
        self.radius_m
    }

    /// The label from the spec, if any.
    pub fn name(&self) -> Option<&str> {
        self.name.as_deref()
    }

    /// Centre position at time `t_s` (s), world frame (m). Closed form, so the
    /// result depends on `t_s` only. Negative times extrapolate the law
    /// backwards (a constant-velocity obstacle holds still before its start
    /// time).
    pub fn position_at(&self, t_s: f64) -> Vec2 {
        match &self.law {
            Law::ConstantVelocity {
                start,
                velocity_mps,
                start_time_s,
            } => {
                if t_s <= *start_time_s {
                    *start
                } else {
                    start + velocity_mps * (t_s - start_time_s)
                }
            }
            Law::WaypointLoop {
                points,
                cum_m,
                perimeter_m,
                speed_mps,
            } => {
                let (i, along_m) = loop_leg(cum_m, *perimeter_m, speed_mps * t_s);
                let a = points[i];
                let b = points[(i + 1) % points.len()];
                let len = cum_m.get(i + 1).copied().unwrap_or(*perimeter_m) - cum_m[i];
                if len > 0.0 {
                    a + (b - a) * (along_m / len).min(1.0)
                } else {
                    a
                }
            }
            Law::Bounce {
                start,
                velocity_mps,
                min,
                max,
            } => Vec2::new(
                fold(start.x, velocity_mps.x, min.x, max.x, t_s).0,
                fold(start.y, velocity_mps.y, min.y, max.y, t_s).0,
            ),
        }
    }

    /// Centre velocity at time `t_s` (s), world frame (m/s). At an instant
    /// where the law switches (start time, waypoint, wall contact) the
    /// velocity *after* the switch is returned.
    pub fn velocity_at(&self, t_s: f64) -> Vec2 {
        match &self.law {
            Law::ConstantVelocity {
                velocity_mps,
                start_time_s,
                ..
            } => {
                if t_s >= *start_time_s {
                    *velocity_mps
                } else {
                    Vec2::zeros()
                }
            }
            Law::WaypointLoop {
                points,
                cum_m,
                perimeter_m,
                speed_mps,
            } => {
                let (i, _) = loop_leg(cum_m, *perimeter_m, speed_mps * t_s);
                let d = points[(i + 1) % points.len()] - points[i];
                let len = d.norm();
                if len > 0.0 {
                    d * (speed_mps / len)
                } else {
                    Vec2::zeros()
                }
            }
            Law::Bounce {
                start,
                velocity_mps,
                min,
                max,
            } => Vec2::new(
                fold(start.x, velocity_mps.x, min.x, max.x, t_s).1,
                fold(start.y, velocity_mps.y, min.y, max.y, t_s).1,
            ),
        }
    }
}

/// For a loop with cumulative leg starts `cum_m` and length `perimeter_m`,
/// returns the leg index and the distance travelled along that leg (m) after
/// a total path length `s_m` (any sign: wraps modulo the perimeter). Legs of
/// zero length are skipped.
fn loop_leg(cum_m: &[f64], perimeter_m: f64, s_m: f64) -> (usize, f64) {
    let mut s = s_m.rem_euclid(perimeter_m);
    if !s.is_finite() || s >= perimeter_m {
        // Non-finite time, or rounding of rem_euclid for tiny negative s.
        s = 0.0;
    }
    // Last leg whose start is ≤ s (cum_m[0] = 0 ≤ s, so the index is ≥ 0).
    let i = cum_m.partition_point(|&c| c <= s).saturating_sub(1);
    (i, s - cum_m[i])
}

/// Triangle-wave folding of the unbounded motion `x0 + v t` into [lo, hi]:
/// the position and velocity of a point reflecting elastically off both ends.
/// With width w = hi − lo and u = (x0 − lo) + v t, m = u mod 2w:
/// position lo + m if m ≤ w, else lo + 2w − m; velocity +v on the rising half
/// and −v on the falling half. Exactly at a wall the outgoing velocity is
/// returned (pointing into the box).
fn fold(x0: f64, v: f64, lo: f64, hi: f64, t_s: f64) -> (f64, f64) {
    let w = hi - lo;
    let m = ((x0 - lo) + v * t_s).rem_euclid(2.0 * w);
    if !m.is_finite() {
        return (x0, v);
    }
    let pos = if m <= w { lo + m } else { lo + 2.0 * w - m };
    let vel = if m == 0.0 {
        v.abs()
    } else if m == w {
        -v.abs()
    } else if m < w {
        v
    } else {
        -v
    };
    (pos.clamp(lo, hi), vel)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn near(a: Vec2, x: f64, y: f64) -> bool {
        (a - Vec2::new(x, y)).norm() < 1e-9
    }

    fn obstacle(motion: MotionSpec) -> MovingObstacle {
        MovingObstacle::new(&MovingObstacleSpec {
            radius_m: 0.2,
            motion,
            name: Some("o".into()),
        })
        .expect("valid spec")
    }

    #[test]
    fn constant_velocity_waits_then_moves() {
        let o = obstacle(MotionSpec::ConstantVelocity {
            start: [1.0, 2.0],
            velocity_mps: [0.5, -0.25],
            start_time_s: 2.0,
        });
        assert!(near(o.position_at(0.0), 1.0, 2.0));
        assert!(near(o.position_at(1.999), 1.0, 2.0));
        assert!(near(o.velocity_at(1.0), 0.0, 0.0));
        // t = 6: 4 s of motion → (1 + 2, 2 − 1).
        assert!(near(o.position_at(6.0), 3.0, 1.0));
        assert!(near(o.velocity_at(6.0), 0.5, -0.25));
        assert!(near(o.velocity_at(2.0), 0.5, -0.25));
        assert_eq!(o.radius_m(), 0.2);
        assert_eq!(o.name(), Some("o"));
    }

    #[test]
    fn waypoint_loop_positions_and_wraparound() {
        // Square 2 m × 1 m: legs 2, 1, 2, 1 → perimeter 6 m; speed 0.5 → 12 s period.
        let o = obstacle(MotionSpec::WaypointLoop {
            waypoints: vec![[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]],
            speed_mps: 0.5,
        });
        assert!(near(o.position_at(0.0), 0.0, 0.0));
        assert!(near(o.position_at(1.0), 0.5, 0.0));
        assert!(near(o.velocity_at(1.0), 0.5, 0.0));
        // 5 s → 2.5 m: 0.5 m up the second leg.
        assert!(near(o.position_at(5.0), 2.0, 0.5));
        assert!(near(o.velocity_at(5.0), 0.0, 0.5));
        // 8 s → 4 m: 1 m along the third leg (leftwards).
        assert!(near(o.position_at(8.0), 1.0, 1.0));
        assert!(near(o.velocity_at(8.0), -0.5, 0.0));
        // 11 s → 5.5 m: closing leg w3 → w0, half way down.
        assert!(near(o.position_at(11.0), 0.0, 0.5));
        assert!(near(o.velocity_at(11.0), 0.0, -0.5));
        // Wrap-around: 12 s back at w0, 13 s = 1 s.
        assert!(near(o.position_at(12.0), 0.0, 0.0));
        assert!(near(o.position_at(13.0), 0.5, 0.0));
        assert!(near(o.position_at(12.0 * 7.0 + 5.0), 2.0, 0.5));
        // Negative time runs the loop backwards: −1 s = 11 s.
        assert!(near(o.position_at(-1.0), 0.0, 0.5));
    }

    #[test]
    fn waypoint_loop_of_two_points_goes_back_and_forth() {
        let o = obstacle(MotionSpec::WaypointLoop {
            waypoints: vec![[0.0, 0.0], [0.0, 3.0]],
            speed_mps: 1.0,
        });
        assert!(near(o.position_at(2.0), 0.0, 2.0));
        assert!(near(o.position_at(4.0), 0.0, 2.0));
        assert!(near(o.velocity_at(4.0), 0.0, -1.0));
    }

    #[test]
    fn bounce_reflects_at_hand_computed_times() {
        // Box x ∈ [0, 4], y ∈ [0, 2]; start (1, 1), v = (1, 0.5).
        let o = obstacle(MotionSpec::Bounce {
            start: [1.0, 1.0],
            velocity_mps: [1.0, 0.5],
            region_min: [0.0, 0.0],
            region_max: [4.0, 2.0],
        });
        // t = 1: free flight (2, 1.5).
        assert!(near(o.position_at(1.0), 2.0, 1.5));
        assert!(near(o.velocity_at(1.0), 1.0, 0.5));
        // y hits 2 at t = 2, x hits 4 at t = 3.
        // t = 2.5: x = 3.5, y = 2 − 0.25 = 1.75, vy flipped.
        assert!(near(o.position_at(2.5), 3.5, 1.75));
        assert!(near(o.velocity_at(2.5), 1.0, -0.5));
        // t = 4: x = 4 − 1 = 3 (vx flipped), y = 2 − 1 = 1.
        assert!(near(o.position_at(4.0), 3.0, 1.0));
        assert!(near(o.velocity_at(4.0), -1.0, -0.5));
        // y hits 0 at t = 6: t = 7 → y = 0.5, vy = +0.5; x = 4 − 4 = 0 at t = 7 → vx = +1.
        assert!(near(o.position_at(7.0), 0.0, 0.5));
        assert!(near(o.velocity_at(7.0), 1.0, 0.5));
        // Period: x 8 s, y 8 s → back at the start at t = 8.
        assert!(near(o.position_at(8.0), 1.0, 1.0));
        // At the wall contact the outgoing velocity is reported.
        assert!(near(o.velocity_at(3.0), -1.0, -0.5));
    }

    #[test]
    fn bounce_with_negative_velocity_and_long_times_stays_inside() {
        let o = obstacle(MotionSpec::Bounce {
            start: [0.5, 0.5],
            velocity_mps: [-0.3, 0.7],
            region_min: [-1.0, 0.0],
            region_max: [1.0, 1.0],
        });
        // x: 0.5 − 0.3·5 = −1.0 at t = 5 (wall), then 0.3 m back: t = 6 → −0.7.
        assert!((o.position_at(6.0).x + 0.7).abs() < 1e-9);
        assert!((o.velocity_at(6.0).x - 0.3).abs() < 1e-12);
        for k in 0..10_000 {
            let p = o.position_at(k as f64 * 0.731 + 1.0e5);
            assert!((-1.0..=1.0).contains(&p.x) && (0.0..=1.0).contains(&p.y), "{p:?}");
        }
    }

    #[test]
    fn bad_specs_are_rejected_with_field_names() {
        let mk = |radius_m: f64, motion: MotionSpec| {
            MovingObstacle::new(&MovingObstacleSpec {
                radius_m,
                motion,
                name: None,
            })
        };
        let cv = MotionSpec::ConstantVelocity {
            start: [0.0, 0.0],
            velocity_mps: [1.0, 0.0],
            start_time_s: 0.0,
        };
        assert!(mk(0.0, cv.clone()).unwrap_err().to_string().contains("radius_m"));
        assert!(mk(f64::NAN, cv).unwrap_err().to_string().contains("radius_m"));
        let e = mk(
            0.1,
            MotionSpec::ConstantVelocity {
                start: [0.0, 0.0],
                velocity_mps: [f64::INFINITY, 0.0],
                start_time_s: 0.0,
            },
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("velocity_mps"), "{e}");
        let e = mk(
            0.1,
            MotionSpec::WaypointLoop {
                waypoints: vec![[1.0, 1.0], [1.0, 1.0]],
                speed_mps: 1.0,
            },
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("waypoints"), "{e}");
        let e = mk(
            0.1,
            MotionSpec::WaypointLoop {
                waypoints: vec![],
                speed_mps: 1.0,
            },
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("waypoints"), "{e}");
        let e = mk(
            0.1,
            MotionSpec::WaypointLoop {
                waypoints: vec![[0.0, 0.0], [1.0, 0.0]],
                speed_mps: -1.0,
            },
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("speed_mps"), "{e}");
        let e = mk(
            0.1,
            MotionSpec::Bounce {
                start: [0.0, 0.0],
                velocity_mps: [1.0, 0.0],
                region_min: [0.0, 0.0],
                region_max: [1.0, 0.0],
            },
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("region_min"), "{e}");
        let e = mk(
            0.1,
            MotionSpec::Bounce {
                start: [2.0, 0.5],
                velocity_mps: [1.0, 0.0],
                region_min: [0.0, 0.0],
                region_max: [1.0, 1.0],
            },
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("motion.start"), "{e}");
    }

    #[test]
    fn yaml_spec_parses_and_rejects_unknown_keys() {
        let y = "radius_m: 0.3\nmotion:\n  kind: bounce\n  start: [0, 0]\n  velocity_mps: [1, 1]\n  region_min: [-1, -1]\n  region_max: [1, 1]\n";
        let s: MovingObstacleSpec = serde_yaml::from_str(y).expect("parses");
        assert_eq!(s.radius_m, 0.3);
        assert!(matches!(s.motion, MotionSpec::Bounce { .. }));
        let y = "radius_m: 0.3\nmotion:\n  kind: constant_velocity\n  start: [0, 0]\n  velocity_mps: [1, 1]\n";
        let s: MovingObstacleSpec = serde_yaml::from_str(y).expect("parses");
        assert!(matches!(
            s.motion,
            MotionSpec::ConstantVelocity { start_time_s, .. } if start_time_s == 0.0
        ));
        let bad =
            "radius_m: 0.3\nmotion:\n  kind: constant_velocity\n  start: [0, 0]\n  velocity_mps: [1, 1]\n  speed: 2\n";
        assert!(serde_yaml::from_str::<MovingObstacleSpec>(bad).is_err());
        let bad =
            "radius_m: 0.3\ncolour: red\nmotion:\n  kind: constant_velocity\n  start: [0, 0]\n  velocity_mps: [1, 1]\n";
        assert!(serde_yaml::from_str::<MovingObstacleSpec>(bad).is_err());
    }
}
