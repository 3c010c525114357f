//! Points → clearances (ALGORITHM.md §2, paper III.A and IV.D).
//!
//! Clearance of a point: c = ‖P‖ − r, its distance from the robot centre minus
//! the robot radius. The left hemisphere is y > 0, the right y < 0, each
//! restricted to the sector |bearing| ≤ hemisphere_fov/2 (default 180°: the
//! front half). d_min is over every valid point (the full scan), because the
//! safe set S = { d_min ≥ d_safe } must hold all around the robot.

use super::geometry::Vec2;

/// Sector half-angle encoded as a cosine so membership needs no atan2:
/// |bearing(P)| ≤ half ⟺ P.x ≥ ‖P‖·cos(half).
#[derive(Debug, Clone, Copy)]
pub struct Sector {
    cos_half: f64,
    full: bool,
}

impl Sector {
    /// A sector of `fov_rad` full angle centred on +x.
    pub fn new(fov_rad: f64) -> Self {
        let half = fov_rad / 2.0;
        Self {
            cos_half: half.min(std::f64::consts::PI).cos(),
            full: half >= std::f64::consts::PI,
        }
    }

    /// Whether a point at distance `norm` (precomputed) lies in the sector.
    #[inline]
    pub fn contains(&self, p: Vec2, norm: f64) -> bool {
        self.full || p.x >= norm * self.cos_half
    }
}

/// Minimum clearances around the robot, with the points that realise them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Clearances {
    /// d_l: least clearance in the left hemisphere sector (m); +inf if empty.
    pub d_left_m: f64,
    /// d_r: least clearance in the right hemisphere sector (m); +inf if empty.
    pub d_right_m: f64,
    /// d_min: least clearance over all valid points (m); +inf if none.
    pub d_min_m: f64,
    /// Least clearance in the front sector (m); +inf if empty.
    pub d_front_m: f64,
    /// Closest left / right / overall point, robot frame (m).
    pub closest_left: Option<Vec2>,
    pub closest_right: Option<Vec2>,
    pub closest: Option<Vec2>,
    /// Σ 1/‖P‖ over each hemisphere sector (1/m): how cluttered a side is; breaks ties.
    pub crowding_left: f64,
    pub crowding_right: f64,
}

impl Clearances {
    /// No obstacle seen anywhere.
    pub const OPEN: Clearances = Clearances {
        d_left_m: f64::INFINITY,
        d_right_m: f64::INFINITY,
        d_min_m: f64::INFINITY,
        d_front_m: f64::INFINITY,
        closest_left: None,
        closest_right: None,
        closest: None,
        crowding_left: 0.0,
        crowding_right: 0.0,
    };
}

/// Points per batch in `compute_clearances`.
const BATCH: usize = 8;

/// Computes every clearance in one pass over the points.
pub fn compute_clearances(points: &[Vec2], robot_radius_m: f64, hemisphere: Sector, front: Sector) -> Clearances {
    let mut c = Clearances::OPEN;
    // The square root and the reciprocal of every point's distance are the costly
    // part, and each waits on the divider; taken a batch at a time over a fixed
    // number of independent lanes, the compiler issues them two by two. The
    // bookkeeping then runs point by point, in order, as before.
    for chunk in points.chunks(BATCH) {
        let mut norm2 = [0.0; BATCH];
        for (n2, p) in norm2.iter_mut().zip(chunk) {
            *n2 = p.norm_squared();
        }
        // ‖P‖ as nalgebra computes it: the root of the squared norm.
        let norms = norm2.map(f64::sqrt);
        let reciprocals = norms.map(|n| 1.0 / n);
        for (k, &p) in chunk.iter().enumerate() {
            let norm = norms[k];
            let clearance = norm - robot_radius_m;
            if clearance < c.d_min_m {
                c.d_min_m = clearance;
                c.closest = Some(p);
            }
            if front.contains(p, norm) && clearance < c.d_front_m {
                c.d_front_m = clearance;
            }
            if p.y != 0.0 && hemisphere.contains(p, norm) {
                let crowd = if norm > 0.0 { reciprocals[k] } else { f64::INFINITY };
                if p.y > 0.0 {
                    c.crowding_left += crowd;
                    if clearance < c.d_left_m {
                        c.d_left_m = clearance;
                        c.closest_left = Some(p);
                    }
                } else {
                    c.crowding_right += crowd;
                    if clearance < c.d_right_m {
                        c.d_right_m = clearance;
                        c.closest_right = Some(p);
                    }
                }
            }
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    fn deg(d: f64) -> f64 {
        d.to_radians()
    }

    #[test]
    fn hemispheres_and_minimum() {
        let pts = [
            Vec2::new(1.0, 0.5),  // left, ‖‖ = 1.118
            Vec2::new(0.5, -0.5), // right, 0.7071
            Vec2::new(-0.3, 0.0), // behind: only d_min
            Vec2::new(2.0, 0.0),  // dead ahead: front only, neither side
        ];
        let c = compute_clearances(&pts, 0.1, Sector::new(deg(180.0)), Sector::new(deg(60.0)));
        assert!((c.d_left_m - (1.25f64.sqrt() - 0.1)).abs() < 1e-12);
        assert!((c.d_right_m - (0.5f64.sqrt() - 0.1)).abs() < 1e-12);
        assert!((c.d_min_m - 0.2).abs() < 1e-12);
        assert_eq!(c.closest, Some(Vec2::new(-0.3, 0.0)));
        // Front (±30°): (1, 0.5) is at 26.6°, (0.5, -0.5) at -45° (outside), (2, 0) at 0°.
        assert!((c.d_front_m - (1.25f64.sqrt() - 0.1)).abs() < 1e-12);
    }

    #[test]
    fn hemisphere_sector_excludes_points_behind() {
        // 180° hemisphere = front half: a point at 135° left is outside it.
        let pts = [Vec2::new(-1.0, 1.0)];
        let c = compute_clearances(&pts, 0.0, Sector::new(deg(180.0)), Sector::new(deg(60.0)));
        assert_eq!(c.d_left_m, f64::INFINITY);
        let c = compute_clearances(&pts, 0.0, Sector::new(deg(360.0)), Sector::new(deg(60.0)));
        assert!((c.d_left_m - 2f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn empty_scan_is_open() {
        let c = compute_clearances(&[], 0.2, Sector::new(deg(180.0)), Sector::new(deg(60.0)));
        assert_eq!(c, Clearances::OPEN);
    }

    #[test]
    fn sector_boundary_is_inclusive() {
        let s = Sector::new(deg(90.0));
        let p = Vec2::new(1.0, 1.0); // exactly 45°
        assert!(s.contains(p * (1.0 - 1e-12), p.norm()) || s.contains(p, p.norm() * (1.0 - 1e-12)));
        assert!(!s.contains(Vec2::new(1.0, 1.01), Vec2::new(1.0, 1.01).norm()));
    }
}
