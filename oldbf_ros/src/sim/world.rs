//! The simulated world: static walls (segments, closed polygons, boxes),
//! static circles and moving discs, with a clock.
//!
//! Why flat: the LiDAR asks this module for hundreds of rays per scan and the
//! collision check for an exact distance every step, so every static shape is
//! lowered once, at construction, to one of two primitives kept in flat
//! `Vec`s ([`Segment`], [`Circle`]); the moving discs' current positions are
//! cached whenever the clock moves. Queries allocate nothing.
//!
//! For scans, [`World::prepare_scan`] copies into a reusable [`ScanScratch`]
//! only the shapes that can be hit within the sensor's range — an exact cull
//! (a shape farther than `max_range_m` from the sensor cannot give a hit
//! below `max_range_m`), so [`ScanScratch::ray_cast`] returns the same value
//! as [`World::ray_cast`], only faster in large worlds.
//!
//! Units: m, s; box yaw in degrees in YAML only (`yaw_deg`).

use super::motion::{MovingObstacle, MovingObstacleSpec};
use super::shapes::{Circle, Segment};
use crate::algo::geometry::Vec2;
use serde::{Deserialize, Serialize};

/// A single wall from `from` to `to` (m).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallSpec {
    pub from: [f64; 2],
    pub to: [f64; 2],
}

/// A rectangular obstacle: centre (m), full size [length along its x, width
/// along its y] (m), rotated by `yaw_deg` (degrees, CCW).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxSpec {
    pub center: [f64; 2],
    pub size: [f64; 2],
    #[serde(default)]
    pub yaw_deg: f64,
}

/// A static post: centre (m), radius (m).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CircleSpec {
    pub center: [f64; 2],
    pub radius_m: f64,
}

/// The world as written in a scenario file; every list may be omitted.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorldSpec {
    #[serde(default)]
    pub walls: Vec<WallSpec>,
    /// Closed polygon outlines (≥ 3 vertices, m); the last vertex connects
    /// back to the first. Only the outline is an obstacle (the LiDAR sees the
    /// edges; the inside is not "solid" for the distance query).
    #[serde(default)]
    pub polygons: Vec<Vec<[f64; 2]>>,
    #[serde(default)]
    pub boxes: Vec<BoxSpec>,
    #[serde(default)]
    pub circles: Vec<CircleSpec>,
    #[serde(default)]
    pub moving: Vec<MovingObstacleSpec>,
}

/// The built world. See the module docs.
#[derive(Debug, Clone)]
pub struct World {
    segments: Vec<Segment>,
    circles: Vec<Circle>,
    moving: Vec<MovingObstacle>,
    /// Moving discs at `time_s` (same order as `moving`).
    moving_now: Vec<Circle>,
    /// Discs placed from outside (other robots in a multi-robot world), part
    /// of every query until replaced.
    agents: Vec<Circle>,
    time_s: f64,
    bounds: Option<(Vec2, Vec2)>,
}

fn point(v: [f64; 2], what: &str) -> Result<Vec2, String> {
    if v[0].is_finite() && v[1].is_finite() {
        Ok(Vec2::new(v[0], v[1]))
    } else {
        Err(format!("{what}: coordinates must be finite (got {v:?})"))
    }
}

impl World {
    /// Lowers `spec` to segments and circles, rejecting non-finite numbers,
    /// zero-length walls or polygon edges, polygons with fewer than 3
    /// vertices, non-positive box sizes and radii. The message names the
    /// item, e.g. `"world.walls[2]: zero length"`. The clock starts at 0 s.
    pub fn new(spec: &WorldSpec) -> Result<World, String> {
        let mut segments = Vec::new();
        for (i, w) in spec.walls.iter().enumerate() {
            let what = format!("world.walls[{i}]");
            let s = Segment::new(point(w.from, &what)?, point(w.to, &what)?);
            if s.length_m() <= 0.0 {
                return Err(format!("{what}: zero length"));
            }
            segments.push(s);
        }
        for (i, poly) in spec.polygons.iter().enumerate() {
            let what = format!("world.polygons[{i}]");
            if poly.len() < 3 {
                return Err(format!("{what}: needs at least 3 vertices (got {})", poly.len()));
            }
            let pts = poly.iter().map(|v| point(*v, &what)).collect::<Result<Vec<_>, _>>()?;
            for k in 0..pts.len() {
                let s = Segment::new(pts[k], pts[(k + 1) % pts.len()]);
                if s.length_m() <= 0.0 {
                    return Err(format!(
                        "{what}: edge {k} (vertex {k} to vertex {}) has zero length",
                        (k + 1) % pts.len()
                    ));
                }
                segments.push(s);
            }
        }
        for (i, b) in spec.boxes.iter().enumerate() {
            let what = format!("world.boxes[{i}]");
            let c = point(b.center, &what)?;
            if !(b.size[0].is_finite() && b.size[1].is_finite() && b.size[0] > 0.0 && b.size[1] > 0.0) {
                return Err(format!("{what}: size must be > 0 and finite (got {:?})", b.size));
            }
            if !b.yaw_deg.is_finite() {
                return Err(format!("{what}: yaw_deg must be finite"));
            }
            let (s, co) = b.yaw_deg.to_radians().sin_cos();
            let (hx, hy) = (0.5 * b.size[0], 0.5 * b.size[1]);
            let corner = |x: f64, y: f64| c + Vec2::new(co * x - s * y, s * x + co * y);
            let k = [corner(hx, hy), corner(-hx, hy), corner(-hx, -hy), corner(hx, -hy)];
            for j in 0..4 {
                segments.push(Segment::new(k[j], k[(j + 1) % 4]));
            }
        }
        let mut circles = Vec::with_capacity(spec.circles.len());
        for (i, c) in spec.circles.iter().enumerate() {
            let what = format!("world.circles[{i}]");
            let center = point(c.center, &what)?;
            if !(c.radius_m.is_finite() && c.radius_m > 0.0) {
                return Err(format!("{what}: radius_m must be > 0 and finite (got {})", c.radius_m));
            }
            circles.push(Circle::new(center, c.radius_m));
        }
        let moving = spec
            .moving
            .iter()
            .enumerate()
            .map(|(i, m)| MovingObstacle::new(m).map_err(|e| format!("world.moving[{i}]: {e}")))
            .collect::<Result<Vec<_>, _>>()?;

        let mut bounds: Option<(Vec2, Vec2)> = None;
        let mut grow = |lo: Vec2, hi: Vec2| {
            bounds = Some(match bounds {
                None => (lo, hi),
                Some((a, b)) => (a.inf(&lo), b.sup(&hi)),
            });
        };
        for s in &segments {
            grow(s.a.inf(&s.b), s.a.sup(&s.b));
        }
        for c in &circles {
            let r = Vec2::repeat(c.radius_m);
            grow(c.center - r, c.center + r);
        }

        let mut world = World {
            segments,
            circles,
            moving_now: Vec::with_capacity(moving.len()),
            agents: Vec::new(),
            moving,
            time_s: 0.0,
            bounds,
        };
        world.refresh_moving();
        Ok(world)
    }

    fn refresh_moving(&mut self) {
        let t = self.time_s;
        self.moving_now.clear();
        self.moving_now
            .extend(self.moving.iter().map(|m| Circle::new(m.position_at(t), m.radius_m())));
    }

    /// Simulation time (s).
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// Moves the clock forward by `dt_s` (s) and the moving obstacles to
    /// their positions at the new time. A negative or non-finite `dt_s` is
    /// ignored (the clock never runs backwards or becomes NaN).
    pub fn advance(&mut self, dt_s: f64) {
        if dt_s.is_finite() && dt_s > 0.0 {
            self.time_s += dt_s;
            self.refresh_moving();
        }
    }

    /// Sets the clock to `t_s` (s); non-finite values are ignored.
    pub fn set_time(&mut self, t_s: f64) {
        if t_s.is_finite() {
            self.time_s = t_s;
            self.refresh_moving();
        }
    }

    /// All static segments: walls, then polygon edges, then box edges.
    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    /// Static circles.
    pub fn circles(&self) -> &[Circle] {
        &self.circles
    }

    /// The moving obstacles (their laws).
    pub fn moving(&self) -> &[MovingObstacle] {
        &self.moving
    }

    /// The moving obstacles as circles at the current time.
    pub fn moving_circles(&self) -> impl Iterator<Item = Circle> + '_ {
        self.moving_now.iter().copied()
    }

    /// Replaces the externally placed discs (other robots, seen by the one
    /// being queried). Allocates only while the buffer grows.
    pub fn set_agents(&mut self, agents: impl Iterator<Item = Circle>) {
        self.agents.clear();
        self.agents.extend(agents);
    }

    /// The externally placed discs.
    pub fn agents(&self) -> &[Circle] {
        &self.agents
    }

    /// Exact distance from `p` (m) to the nearest obstacle surface: segments,
    /// static circles and moving circles at the current time. Negative inside
    /// a circle (minus the penetration depth); `+inf` for an empty world.
    pub fn distance_to_nearest(&self, p: Vec2) -> f64 {
        let mut best = f64::INFINITY;
        for s in &self.segments {
            best = best.min(s.distance_to(p));
        }
        for c in self.circles.iter().chain(&self.moving_now).chain(&self.agents) {
            best = best.min(c.signed_distance_to(p));
        }
        best
    }

    /// Distance (m) along the ray `origin + t·dir_unit` to the nearest hit
    /// with `t < max_range_m`, `None` if nothing is hit that close. A ray
    /// starting inside a circle hits at 0.
    pub fn ray_cast(&self, origin: Vec2, dir_unit: Vec2, max_range_m: f64) -> Option<f64> {
        let hit = ray_cast_shapes(
            &self.segments,
            &self.circles,
            &self.moving_now,
            origin,
            dir_unit,
            max_range_m,
        );
        let agents = ray_cast_shapes(&[], &self.agents, &[], origin, dir_unit, max_range_m);
        match (hit, agents) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// Fills `scratch` with the shapes (static and moving, at the current
    /// time) closer than `max_range_m` to `origin`; the others cannot be hit
    /// below that range. Allocates only while `scratch` grows.
    pub fn prepare_scan(&self, origin: Vec2, max_range_m: f64, scratch: &mut ScanScratch) {
        scratch.segments.clear();
        scratch.circles.clear();
        scratch
            .segments
            .extend(self.segments.iter().filter(|s| s.distance_to(origin) < max_range_m));
        scratch.circles.extend(
            self.circles
                .iter()
                .chain(&self.moving_now)
                .chain(&self.agents)
                .filter(|c| c.signed_distance_to(origin) < max_range_m),
        );
    }

    /// Axis-aligned bounding box (min, max corners, m) of the static geometry
    /// (segments and static circles), `None` if there is none.
    pub fn bounds(&self) -> Option<(Vec2, Vec2)> {
        self.bounds
    }
}

/// Reusable per-scan buffer of the shapes near the sensor, filled by
/// [`World::prepare_scan`]. Valid until the world's clock moves.
#[derive(Debug, Clone, Default)]
pub struct ScanScratch {
    segments: Vec<Segment>,
    circles: Vec<Circle>,
}

impl ScanScratch {
    /// Like [`World::ray_cast`], over the culled shapes only. Gives the same
    /// answer as the world for rays from the `origin` given to
    /// [`World::prepare_scan`] with `max_range_m` no larger than there.
    pub fn ray_cast(&self, origin: Vec2, dir_unit: Vec2, max_range_m: f64) -> Option<f64> {
        ray_cast_shapes(&self.segments, &self.circles, &[], origin, dir_unit, max_range_m)
    }

    /// Number of (segments, circles) kept by the last cull.
    pub fn len(&self) -> (usize, usize) {
        (self.segments.len(), self.circles.len())
    }

    /// True if the last cull kept nothing.
    pub fn is_empty(&self) -> bool {
        self.segments.is_empty() && self.circles.is_empty()
    }
}

#[inline]
fn ray_cast_shapes(
    segments: &[Segment],
    circles: &[Circle],
    more_circles: &[Circle],
    origin: Vec2,
    dir_unit: Vec2,
    max_range_m: f64,
) -> Option<f64> {
    let mut best = max_range_m;
    for s in segments {
        if let Some(t) = s.ray_hit(origin, dir_unit) {
            if t < best {
                best = t;
            }
        }
    }
    for c in circles.iter().chain(more_circles) {
        if let Some(t) = c.ray_hit(origin, dir_unit) {
            if t < best {
                best = t;
            }
        }
    }
    // `best < max_range_m` only if some hit improved on it (NaN range → None).
    (best < max_range_m).then_some(best)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::motion::MotionSpec;

    fn v(x: f64, y: f64) -> Vec2 {
        Vec2::new(x, y)
    }

    fn mixed_spec() -> WorldSpec {
        WorldSpec {
            walls: vec![WallSpec {
                from: [0.0, -5.0],
                to: [0.0, 5.0],
            }],
            polygons: vec![vec![[4.0, 4.0], [6.0, 4.0], [5.0, 6.0]]],
            boxes: vec![BoxSpec {
                center: [5.0, -3.0],
                size: [2.0, 1.0],
                yaw_deg: 90.0,
            }],
            circles: vec![CircleSpec {
                center: [3.0, 0.0],
                radius_m: 0.5,
            }],
            moving: vec![MovingObstacleSpec {
                radius_m: 0.25,
                motion: MotionSpec::ConstantVelocity {
                    start: [1.5, 2.0],
                    velocity_mps: [0.0, -1.0],
                    start_time_s: 0.0,
                },
                name: None,
            }],
        }
    }

    #[test]
    fn builds_segments_from_walls_polygons_and_boxes() {
        let w = World::new(&mixed_spec()).expect("valid");
        assert_eq!(w.segments().len(), 1 + 3 + 4);
        assert_eq!(w.circles().len(), 1);
        assert_eq!(w.moving().len(), 1);
        // Box rotated 90°: 2 m along y, 1 m along x → x ∈ [4.5, 5.5], y ∈ [−4, −2].
        let (lo, hi) = w.segments()[4..]
            .iter()
            .fold((v(1e9, 1e9), v(-1e9, -1e9)), |(lo, hi), s| {
                (lo.inf(&s.a.inf(&s.b)), hi.sup(&s.a.sup(&s.b)))
            });
        assert!((lo - v(4.5, -4.0)).norm() < 1e-12 && (hi - v(5.5, -2.0)).norm() < 1e-12);
        // Static bounds: x from the wall (0) to the polygon/box (6), y −5..6.
        let (blo, bhi) = w.bounds().expect("non-empty");
        assert!((blo - v(0.0, -5.0)).norm() < 1e-12, "{blo:?}");
        assert!((bhi - v(6.0, 6.0)).norm() < 1e-12, "{bhi:?}");
    }

    #[test]
    fn distance_to_nearest_mixed_shapes() {
        let mut w = World::new(&mixed_spec()).expect("valid");
        // (2, 0): wall 2, circle 3 − 0.5 − 2 = 0.5, moving disc at (1.5, 2): √(0.25 + 4) − 0.25.
        assert!((w.distance_to_nearest(v(2.0, 0.0)) - 0.5).abs() < 1e-12);
        // (1.5, 1.0): moving disc centre 1 m away → 0.75; wall 1.5; circle √(2.25+1) − 0.5 ≈ 1.30.
        assert!((w.distance_to_nearest(v(1.5, 1.0)) - 0.75).abs() < 1e-12);
        // After 1 s the disc is at (1.5, 1.0): inside by its radius.
        w.advance(1.0);
        assert_eq!(w.time_s(), 1.0);
        assert!((w.distance_to_nearest(v(1.5, 1.0)) + 0.25).abs() < 1e-12);
        // Near the box's right edge x = 5.5 at (6, −3): 0.5.
        assert!((w.distance_to_nearest(v(6.0, -3.0)) - 0.5).abs() < 1e-12);
        // Inside the triangle at (5, 4.5): bottom edge 0.5 away, slanted edges
        // farther: line through (4,4),(5,6): 2x − y − 4 = 0 → |10 − 4.5 − 4|/√5 ≈ 0.67.
        assert!((w.distance_to_nearest(v(5.0, 4.5)) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn empty_world_is_infinitely_far() {
        let w = World::new(&WorldSpec::default()).expect("valid");
        assert_eq!(w.distance_to_nearest(v(0.0, 0.0)), f64::INFINITY);
        assert_eq!(w.ray_cast(v(0.0, 0.0), v(1.0, 0.0), 10.0), None);
        assert_eq!(w.bounds(), None);
    }

    #[test]
    fn ray_cast_returns_nearest_hit_below_range() {
        let w = World::new(&mixed_spec()).expect("valid");
        // From (2, 0) along +x: circle at 3 − 0.5 − 2 = 0.5.
        assert_eq!(w.ray_cast(v(2.0, 0.0), v(1.0, 0.0), 10.0), Some(0.5));
        // Along −x: the wall at x = 0 (2 m).
        assert_eq!(w.ray_cast(v(2.0, 0.0), v(-1.0, 0.0), 10.0), Some(2.0));
        // Range limit is strict: a hit exactly at max range is not reported.
        assert_eq!(w.ray_cast(v(2.0, 0.0), v(-1.0, 0.0), 2.0), None);
        assert_eq!(w.ray_cast(v(2.0, 0.0), v(-1.0, 0.0), 1.5), None);
        // From (1.5, 0) up: the moving disc at (1.5, 2) r 0.25 → 1.75.
        let t = w.ray_cast(v(1.5, 0.0), v(0.0, 1.0), 10.0).unwrap();
        assert!((t - 1.75).abs() < 1e-12);
        // From (5, 0) down: box top edge at y = −2 → 2.
        let t = w.ray_cast(v(5.0, 0.0), v(0.0, -1.0), 10.0).unwrap();
        assert!((t - 2.0).abs() < 1e-12);
        // Up from (5, 0): triangle base y = 4 → 4.
        let t = w.ray_cast(v(5.0, 0.0), v(0.0, 1.0), 10.0).unwrap();
        assert!((t - 4.0).abs() < 1e-12);
        // Down from (8, 0): nothing.
        assert_eq!(w.ray_cast(v(8.0, 0.0), v(0.0, -1.0), 100.0), None);
    }

    #[test]
    fn scan_scratch_culls_exactly() {
        let mut w = World::new(&mixed_spec()).expect("valid");
        w.advance(0.5);
        let o = v(2.0, 0.5);
        let mut sc = ScanScratch::default();
        w.prepare_scan(o, 2.0, &mut sc);
        // Within 2 m of (2, 0.5): the wall (2), no: distance 2 is not < 2;
        // the circle (≈0.62), the moving disc at (1.5, 1.5) (≈0.87). Polygon
        // and box are farther.
        assert_eq!(sc.len(), (0, 2));
        for k in 0..720 {
            let a = k as f64 * std::f64::consts::PI / 360.0;
            let d = v(a.cos(), a.sin());
            assert_eq!(sc.ray_cast(o, d, 2.0), w.ray_cast(o, d, 2.0), "beam {k}");
        }
        w.prepare_scan(o, 6.0, &mut sc);
        assert_eq!(sc.len(), (8, 2));
        for k in 0..720 {
            let a = k as f64 * std::f64::consts::PI / 360.0;
            let d = v(a.cos(), a.sin());
            assert_eq!(sc.ray_cast(o, d, 6.0), w.ray_cast(o, d, 6.0), "beam {k}");
        }
    }

    #[test]
    fn polygon_vertex_rays_do_not_leak() {
        // A square room; rays aimed exactly at the corners hit.
        let spec = WorldSpec {
            polygons: vec![vec![[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]],
            ..WorldSpec::default()
        };
        let w = World::new(&spec).expect("valid");
        for (x, y) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
            let d = v(x, y).normalize();
            let t = w.ray_cast(v(0.0, 0.0), d, 5.0).expect("corner hit");
            assert!((t - 2f64.sqrt()).abs() < 1e-12);
        }
    }

    #[test]
    fn bad_items_are_rejected_by_name() {
        let mut s = WorldSpec {
            walls: vec![
                WallSpec {
                    from: [0.0, 0.0],
                    to: [1.0, 0.0],
                },
                WallSpec {
                    from: [0.0, 0.0],
                    to: [1.0, 1.0],
                },
                WallSpec {
                    from: [2.0, 2.0],
                    to: [2.0, 2.0],
                },
            ],
            ..WorldSpec::default()
        };
        assert_eq!(World::new(&s).unwrap_err(), "world.walls[2]: zero length");
        s.walls[2].to = [f64::NAN, 1.0];
        assert!(World::new(&s).unwrap_err().starts_with("world.walls[2]"));
        s.walls.truncate(2);
        s.polygons = vec![vec![[0.0, 0.0], [1.0, 0.0]]];
        assert!(World::new(&s).unwrap_err().starts_with("world.polygons[0]"));
        s.polygons = vec![vec![[0.0, 0.0], [1.0, 0.0], [1.0, 0.0]]];
        assert!(World::new(&s).unwrap_err().contains("edge 1"));
        s.polygons.clear();
        s.boxes = vec![BoxSpec {
            center: [0.0, 0.0],
            size: [1.0, 0.0],
            yaw_deg: 0.0,
        }];
        assert!(World::new(&s).unwrap_err().starts_with("world.boxes[0]: size"));
        s.boxes.clear();
        s.circles = vec![CircleSpec {
            center: [0.0, 0.0],
            radius_m: -1.0,
        }];
        assert!(World::new(&s).unwrap_err().starts_with("world.circles[0]: radius_m"));
        s.circles.clear();
        s.moving = vec![MovingObstacleSpec {
            radius_m: 0.0,
            motion: MotionSpec::ConstantVelocity {
                start: [0.0, 0.0],
                velocity_mps: [0.0, 0.0],
                start_time_s: 0.0,
            },
            name: None,
        }];
        assert!(World::new(&s).unwrap_err().starts_with("world.moving[0]: radius_m"));
    }

    #[test]
    fn agents_are_seen_by_every_query_until_replaced() {
        let mut w = World::new(&WorldSpec::default()).unwrap();
        w.set_agents([Circle::new(v(2.0, 0.0), 0.5)].into_iter());
        assert!((w.distance_to_nearest(v(0.0, 0.0)) - 1.5).abs() < 1e-12);
        assert_eq!(w.ray_cast(v(0.0, 0.0), v(1.0, 0.0), 10.0), Some(1.5));
        let mut scratch = ScanScratch::default();
        w.prepare_scan(v(0.0, 0.0), 10.0, &mut scratch);
        assert_eq!(scratch.ray_cast(v(0.0, 0.0), v(1.0, 0.0), 10.0), Some(1.5));
        w.set_agents(std::iter::empty());
        assert_eq!(w.ray_cast(v(0.0, 0.0), v(1.0, 0.0), 10.0), None);
    }

    #[test]
    fn clock_ignores_bad_steps() {
        let mut w = World::new(&mixed_spec()).expect("valid");
        w.advance(0.25);
        w.advance(-1.0);
        w.advance(f64::NAN);
        assert_eq!(w.time_s(), 0.25);
        let c: Vec<Circle> = w.moving_circles().collect();
        assert!((c[0].center - v(1.5, 1.75)).norm() < 1e-12);
        w.set_time(2.0);
        let c: Vec<Circle> = w.moving_circles().collect();
        assert!((c[0].center - v(1.5, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn yaml_world_parses_with_defaults() {
        let y = "walls:\n  - {from: [0, 0], to: [1, 0]}\nboxes:\n  - {center: [1, 1], size: [1, 2]}\n";
        let s: WorldSpec = serde_yaml::from_str(y).expect("parses");
        assert_eq!(s.boxes[0].yaw_deg, 0.0);
        assert!(s.circles.is_empty() && s.moving.is_empty());
        assert!(serde_yaml::from_str::<WorldSpec>("wall: []\n").is_err());
        assert!(serde_yaml::from_str::<WorldSpec>("circles:\n  - {center: [0, 0], radius: 1}\n").is_err());
    }
}
