//! The robot's body as a polygon (`robot.body_polygon_m`, issue 26): the
//! exact signed distance between the posed body and every shape of the
//! world, and the contact point and direction a contact is classified by.
//!
//! Why a file of its own: the disc body needs one point distance; a polygon
//! needs distances between its edges and the world's segments, containment
//! tests for overlap, and a depth when they overlap. Each shape is brought
//! into the robot frame (two points per segment, one per disc), where the
//! polygon is fixed, so a query allocates nothing.
//!
//! The value for a shape (m):
//! * **disjoint**: the least distance between the filled polygon and the
//!   shape: edge-to-segment distances (a wall, a polygon or box edge), or
//!   the disc centre's distance from the polygon minus the radius;
//! * **overlapping** (a segment crossing an edge or lying inside; a disc
//!   reaching in): negative, minus the penetration depth. For a disc,
//!   signed distance of the centre minus the radius; for a segment, the
//!   least translation that separates it from the body's convex hull
//!   (separating axes: the hull's edge normals and the segment's normal),
//!   exact for a convex body and never less than the true depth otherwise.
//!   Whether it overlaps is decided on the polygon itself.
//!
//! Units: m, rad; robot frame x forward, y left.

use super::shapes::{Circle, Segment};
use super::world::World;
use crate::algo::footprint::{closest_on_segment, cross, segment_distance, segments_meet, Polygon, PolygonError};
use crate::algo::geometry::{Pose2, Vec2};

/// The nearest pair (on `p0 p1`, on `q0 q1`) of two segments that do not
/// meet: it has an endpoint of one of them.
fn closest_pair(p0: Vec2, p1: Vec2, q0: Vec2, q1: Vec2) -> (Vec2, Vec2) {
    let candidates = [
        (p0, closest_on_segment(p0, q0, q1)),
        (p1, closest_on_segment(p1, q0, q1)),
        (closest_on_segment(q0, p0, p1), q0),
        (closest_on_segment(q1, p0, p1), q1),
    ];
    let mut best = candidates[0];
    for c in &candidates[1..] {
        if (c.0 - c.1).norm() < (best.0 - best.1).norm() {
            best = *c;
        }
    }
    best
}

/// One chain of the convex hull of `points` taken in order: each point
/// kept only while the chain turns left (Andrew's monotone chain).
fn half_hull(points: impl Iterator<Item = Vec2>) -> Vec<Vec2> {
    let mut chain: Vec<Vec2> = Vec::new();
    for q in points {
        while chain.len() >= 2
            && cross(
                chain[chain.len() - 1] - chain[chain.len() - 2],
                q - chain[chain.len() - 2],
            ) <= 0.0
        {
            chain.pop();
        }
        chain.push(q);
    }
    chain
}

/// Convex hull of `points`, counter-clockwise, without collinear points.
pub(crate) fn convex_hull(points: &[Vec2]) -> Vec<Vec2> {
    let mut p = points.to_vec();
    p.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let mut lower = half_hull(p.iter().copied());
    let mut upper = half_hull(p.iter().rev().copied());
    // Each chain's last point starts the other.
    lower.pop();
    upper.pop();
    lower.extend(upper);
    lower
}

/// Where a contact touches, in the robot frame: a point of the body and the
/// unit direction from the body towards the shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Touch {
    /// The point of the body (m, robot frame).
    pub point: Vec2,
    /// Unit direction from the body towards the shape (robot frame).
    pub normal: Vec2,
}

/// A world shape, as [`BodyPolygon::clearance_m`] found it.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Shape {
    Segment(Segment),
    Circle(Circle),
}

/// The robot's body: a simple polygon in the robot frame.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyPolygon {
    polygon: Polygon,
    /// Its convex hull, counter-clockwise (for the penetration depth).
    hull: Vec<Vec2>,
    /// The hull's outward unit edge normals (edge i: hull[i] to hull[i + 1]).
    hull_normals: Vec<Vec2>,
}

impl BodyPolygon {
    /// A body from `[x, y]` vertices (m, robot frame; either winding),
    /// refused unless a simple polygon with area ([`Polygon::new`]).
    pub fn new(vertices_m: &[[f64; 2]]) -> Result<Self, PolygonError> {
        let v: Vec<Vec2> = vertices_m.iter().map(|&[x, y]| Vec2::new(x, y)).collect();
        let polygon = Polygon::new(&v)?;
        let hull = convex_hull(polygon.vertices());
        let hull_normals = (0..hull.len())
            .map(|i| {
                let e = hull[(i + 1) % hull.len()] - hull[i];
                // Counter-clockwise: the outside is on the right of each edge.
                Vec2::new(e.y, -e.x) / e.norm()
            })
            .collect();
        Ok(Self {
            polygon,
            hull,
            hull_normals,
        })
    }

    /// The polygon (robot frame, counter-clockwise).
    pub fn polygon(&self) -> &Polygon {
        &self.polygon
    }

    /// The farthest vertex from the robot's origin (m): the disc other
    /// robots see this one as.
    pub fn circumscribed_radius_m(&self) -> f64 {
        self.polygon.circumscribed_radius_m()
    }

    /// Signed distance (m) between the body at `pose` and the segment `s`
    /// (world frame); see the module docs.
    pub fn distance_to_segment(&self, pose: Pose2, s: &Segment) -> f64 {
        let (a, b) = (pose.inverse_transform_point(s.a), pose.inverse_transform_point(s.b));
        self.segment_in_body_frame(a, b)
    }

    /// Signed distance (m) between the body at `pose` and the disc `c`
    /// (world frame): the centre's signed distance from the polygon minus
    /// the radius.
    pub fn distance_to_circle(&self, pose: Pose2, c: &Circle) -> f64 {
        self.polygon.signed_distance(pose.inverse_transform_point(c.center)) - c.radius_m
    }

    /// Least signed distance (m) between the body at `pose` and every shape
    /// of `world` (static segments and circles, movers now, other robots);
    /// `+inf` for an empty world.
    pub fn clearance_m(&self, pose: Pose2, world: &World) -> f64 {
        self.nearest(pose, world).map_or(f64::INFINITY, |(d, _)| d)
    }

    /// The shape with the least signed distance, and that distance.
    fn nearest(&self, pose: Pose2, world: &World) -> Option<(f64, Shape)> {
        let mut best: Option<(f64, Shape)> = None;
        let mut consider = |d: f64, s: Shape| {
            if best.is_none_or(|(b, _)| d < b) {
                best = Some((d, s));
            }
        };
        for s in world.segments().iter().chain(world.agent_segments()) {
            consider(self.distance_to_segment(pose, s), Shape::Segment(*s));
        }
        for c in world.circles().iter().copied().chain(world.moving_circles()) {
            consider(self.distance_to_circle(pose, &c), Shape::Circle(c));
        }
        for c in world.agents() {
            consider(self.distance_to_circle(pose, c), Shape::Circle(*c));
        }
        best
    }

    /// Where the body at `pose` touches (or comes nearest to) the nearest
    /// shape of `world`: robot frame; `None` for an empty world or when the
    /// direction is undefined (a disc centred on the body's boundary).
    pub fn touch(&self, pose: Pose2, world: &World) -> Option<Touch> {
        match self.nearest(pose, world)?.1 {
            Shape::Segment(s) => {
                let (a, b) = (pose.inverse_transform_point(s.a), pose.inverse_transform_point(s.b));
                Some(self.segment_touch(a, b))
            }
            Shape::Circle(c) => {
                let c = pose.inverse_transform_point(c.center);
                let q = self.nearest_boundary_point(c);
                let n = (c - q).try_normalize(0.0)?;
                Some(Touch { point: q, normal: n })
            }
        }
    }

    fn edges(&self) -> impl Iterator<Item = (Vec2, Vec2)> + '_ {
        let v = self.polygon.vertices();
        (0..v.len()).map(move |i| (v[i], v[(i + 1) % v.len()]))
    }

    fn nearest_boundary_point(&self, q: Vec2) -> Vec2 {
        let mut best = (f64::INFINITY, q);
        for (p0, p1) in self.edges() {
            let c = closest_on_segment(q, p0, p1);
            let d = (q - c).norm();
            if d < best.0 {
                best = (d, c);
            }
        }
        best.1
    }

    /// Whether the segment `a b` (robot frame) meets the filled polygon.
    fn overlaps_segment(&self, a: Vec2, b: Vec2) -> bool {
        self.polygon.contains(a) || self.edges().any(|(p0, p1)| segments_meet(p0, p1, a, b))
    }

    fn segment_in_body_frame(&self, a: Vec2, b: Vec2) -> f64 {
        if self.overlaps_segment(a, b) {
            // 0 − depth: a touch (depth 0) gives +0, not a contact.
            return 0.0 - self.separating_axis(a, b).0;
        }
        self.edges().fold(f64::INFINITY, |best, (p0, p1)| {
            best.min(segment_distance(p0, a, b))
                .min(segment_distance(p1, a, b))
                .min(segment_distance(a, p0, p1))
                .min(segment_distance(b, p0, p1))
        })
    }

    /// The least translation separating the segment `a b` from the convex
    /// hull (≥ 0) and its direction from the body towards the segment.
    fn separating_axis(&self, a: Vec2, b: Vec2) -> (f64, Vec2) {
        let e = b - a;
        let segment_normal = (e.norm() > 0.0).then(|| Vec2::new(-e.y, e.x) / e.norm());
        let mut best = (f64::INFINITY, Vec2::new(1.0, 0.0));
        for u in self.hull_normals.iter().copied().chain(segment_normal) {
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for v in &self.hull {
                lo = lo.min(v.dot(&u));
                hi = hi.max(v.dot(&u));
            }
            let (s_lo, s_hi) = (a.dot(&u).min(b.dot(&u)), a.dot(&u).max(b.dot(&u)));
            // Push the segment out along +u (by hi − s_lo) or −u (by s_hi − lo).
            let (depth, dir) = if hi - s_lo <= s_hi - lo {
                (hi - s_lo, u)
            } else {
                (s_hi - lo, -u)
            };
            if depth < best.0 {
                best = (depth.max(0.0), dir);
            }
        }
        best
    }

    /// The contact point and direction for the segment `a b` (robot frame):
    /// the nearest pair when apart; when overlapping, the separating
    /// direction and the hull's farthest point along it (the middle of an
    /// edge square to it).
    fn segment_touch(&self, a: Vec2, b: Vec2) -> Touch {
        if self.overlaps_segment(a, b) {
            let (_, n) = self.separating_axis(a, b);
            let top = self.hull.iter().map(|v| v.dot(&n)).fold(f64::NEG_INFINITY, f64::max);
            let (sum, count) = self
                .hull
                .iter()
                .filter(|v| v.dot(&n) >= top - 1e-9)
                .fold((Vec2::zeros(), 0.0), |(s, k), v| (s + v, k + 1.0));
            return Touch {
                point: sum / count,
                normal: n,
            };
        }
        let mut best: Option<(f64, Vec2, Vec2)> = None;
        for (p0, p1) in self.edges() {
            let (p, q) = closest_pair(p0, p1, a, b);
            let d = (q - p).norm();
            if best.is_none_or(|(bd, _, _)| d < bd) {
                best = Some((d, p, q));
            }
        }
        // The polygon has edges, so `best` is set; they do not meet, so q ≠ p.
        let (_, p, q) = best.unwrap_or((0.0, Vec2::zeros(), Vec2::new(1.0, 0.0)));
        Touch {
            point: p,
            normal: (q - p).try_normalize(0.0).unwrap_or(Vec2::new(1.0, 0.0)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::world::{CircleSpec, WallSpec, WorldSpec};
    use proptest::prelude::*;
    use std::f64::consts::FRAC_PI_2;

    const RECT: [[f64; 2]; 4] = [[0.3, 0.2], [-0.3, 0.2], [-0.3, -0.2], [0.3, -0.2]];

    fn v(x: f64, y: f64) -> Vec2 {
        Vec2::new(x, y)
    }

    fn rect() -> BodyPolygon {
        BodyPolygon::new(&RECT).expect("a rectangle")
    }

    fn wall(a: Vec2, b: Vec2) -> Segment {
        Segment::new(a, b)
    }

    #[test]
    fn a_rectangle_next_to_a_wall_rotated_and_touching_a_corner() {
        let body = rect();
        // A wall across x = 0.5: the front edge (x = 0.3) is 0.2 m from it.
        let w = wall(v(0.5, -1.0), v(0.5, 1.0));
        let at = |x: f64, y: f64, th: f64| Pose2::new(x, y, th);
        assert!((body.distance_to_segment(at(0.0, 0.0, 0.0), &w) - 0.2).abs() < 1e-12);
        // Turned 90°: the 0.4 m side faces the wall, 0.3 m from it.
        assert!((body.distance_to_segment(at(0.0, 0.0, FRAC_PI_2), &w) - 0.3).abs() < 1e-12);
        // Driven 0.25 m on: 0.05 m in (the front edge crosses the wall).
        assert!((body.distance_to_segment(at(0.25, 0.0, 0.0), &w) + 0.05).abs() < 1e-12);
        // A wall ending at the front-left corner (0.3, 0.2), going on to the
        // upper right: touching, distance 0, no contact.
        let corner = wall(v(0.3, 0.2), v(1.0, 1.0));
        assert_eq!(body.distance_to_segment(at(0.0, 0.0, 0.0), &corner), 0.0);
        // Moved back 1 cm: the corner is the nearest point, 0.01 m.
        assert!((body.distance_to_segment(at(-0.01, 0.0, 0.0), &corner) - 0.01).abs() < 1e-12);
        // A post 0.1 m in radius at 45° off the corner, touching it; then 5 cm nearer.
        let out = v(1.0, 1.0).normalize();
        let post = Circle::new(v(0.3, 0.2) + out * 0.1, 0.1);
        assert!(body.distance_to_circle(at(0.0, 0.0, 0.0), &post).abs() < 1e-12);
        let post = Circle::new(v(0.3, 0.2) + out * 0.05, 0.1);
        assert!((body.distance_to_circle(at(0.0, 0.0, 0.0), &post) + 0.05).abs() < 1e-12);
        // A post 1 m ahead, radius 0.2: 1 − 0.3 − 0.2; turned 90°, 1 − 0.2 − 0.2.
        let post = Circle::new(v(1.0, 0.0), 0.2);
        assert!((body.distance_to_circle(at(0.0, 0.0, 0.0), &post) - 0.5).abs() < 1e-12);
        assert!((body.distance_to_circle(at(0.0, 0.0, FRAC_PI_2), &post) - 0.6).abs() < 1e-12);
        // Turned 45°: the corner (0.3, −0.2) comes farthest forward, to
        // x = (0.3 + 0.2)/√2 = 0.35355 m.
        let d = body.distance_to_segment(at(0.0, 0.0, FRAC_PI_2 / 2.0), &w);
        assert!((d - (0.5 - 0.5 / 2f64.sqrt())).abs() < 1e-12, "{d}");
    }

    #[test]
    fn a_segment_inside_the_body_and_the_world_minimum() {
        let body = rect();
        // Wholly inside, 0.05 m from the left side: overlapping by at least that.
        let inside = wall(v(-0.1, 0.15), v(0.1, 0.15));
        assert!((body.distance_to_segment(Pose2::default(), &inside) + 0.05).abs() < 1e-12);
        let w = World::new(&WorldSpec {
            walls: vec![WallSpec {
                from: [0.5, -1.0],
                to: [0.5, 1.0],
            }],
            circles: vec![CircleSpec {
                center: [-1.0, 0.0],
                radius_m: 0.5,
            }],
            ..WorldSpec::default()
        })
        .expect("valid");
        // Wall 0.2 m, post 1 − 0.3 − 0.5 = 0.2 m: both; moved 0.1 m forward, the wall 0.1.
        assert!((body.clearance_m(Pose2::default(), &w) - 0.2).abs() < 1e-12);
        let p = Pose2::new(0.1, 0.0, 0.0);
        assert!((body.clearance_m(p, &w) - 0.1).abs() < 1e-12);
        let t = body.touch(p, &w).expect("a nearest shape");
        assert!((t.normal - v(1.0, 0.0)).norm() < 1e-12 && t.point.x == 0.3, "{t:?}");
        // Driven into the wall: the front edge's middle, pushing along +x.
        let t = body.touch(Pose2::new(0.25, 0.0, 0.0), &w).expect("a nearest shape");
        assert!((t.normal - v(1.0, 0.0)).norm() < 1e-12 && (t.point - v(0.3, 0.0)).norm() < 1e-12);
        let empty = World::new(&WorldSpec::default()).expect("valid");
        assert_eq!(body.clearance_m(p, &empty), f64::INFINITY);
        assert!(body.touch(p, &empty).is_none());
        assert!(BodyPolygon::new(&[[0.0, 0.0], [1.0, 0.0]]).is_err());
    }

    /// Points every `step` m along the closed polygon's boundary.
    fn boundary_samples(vs: &[Vec2], step: f64) -> Vec<Vec2> {
        let mut out = Vec::new();
        for i in 0..vs.len() {
            let (a, b) = (vs[i], vs[(i + 1) % vs.len()]);
            let n = ((b - a).norm() / step).ceil().max(1.0) as usize;
            out.extend((0..n).map(|k| a + (b - a) * (k as f64 / n as f64)));
        }
        out
    }

    /// A random simple polygon: star-shaped about the origin, vertices at
    /// sorted angles (convex or not).
    fn star() -> impl Strategy<Value = Vec<[f64; 2]>> {
        prop::collection::vec((0.0..1.0f64, 0.1..0.6f64), 3..8).prop_map(|raw| {
            let n = raw.len() as f64;
            raw.iter()
                .enumerate()
                .map(|(i, &(jitter, r))| {
                    let a = (i as f64 + 0.8 * jitter) / n * std::f64::consts::TAU;
                    [r * a.cos(), r * a.sin()]
                })
                .collect()
        })
    }

    proptest! {
        /// Against the plain reference: the body's boundary sampled every
        /// 1 mm, each sample's exact distance to the shape. Apart, the two
        /// agree within the sampling; a segment sample inside the body, or a
        /// boundary sample inside the disc, means overlap (≤ 0).
        #[test]
        fn signed_distance_matches_dense_boundary_sampling(
            verts in star(),
            x in -1.0..1.0f64, y in -1.0..1.0f64, th in -3.2..3.2f64,
            a in (-1.5..1.5f64, -1.5..1.5f64), ab in (-0.8..0.8f64, -0.8..0.8f64),
            r in 0.02..0.4f64,
        ) {
            let Ok(body) = BodyPolygon::new(&verts) else { return Ok(()) };
            let pose = Pose2::new(x, y, th);
            let world: Vec<Vec2> = body.polygon().vertices().iter().map(|&q| pose.transform_point(q)).collect();
            let step = 1e-3;
            let samples = boundary_samples(&world, step);
            // A segment.
            let s = Segment::new(v(a.0, a.1), v(a.0 + ab.0, a.1 + ab.1));
            let d = body.distance_to_segment(pose, &s);
            let reference = samples.iter().map(|&q| s.distance_to(q)).fold(f64::INFINITY, f64::min);
            let n = (s.length_m() / step).ceil().max(1.0) as usize;
            let seg_inside = (0..=n).any(|k| {
                let q = s.a + (s.b - s.a) * (k as f64 / n as f64);
                body.polygon().signed_distance(pose.inverse_transform_point(q)) < 0.0
            });
            if seg_inside {
                prop_assert!(d <= 0.0, "sampled overlap, exact {d}");
            } else if d >= 0.0 {
                prop_assert!(d <= reference + 1e-9 && reference - d <= step, "exact {d} reference {reference}");
            }
            if d > step {
                prop_assert!(!seg_inside);
            }
            // A disc at a.
            let c = Circle::new(v(a.0, a.1), r);
            let d = body.distance_to_circle(pose, &c);
            let centre_inside = body.polygon().contains(pose.inverse_transform_point(c.center));
            let reference = samples.iter().map(|&q| c.signed_distance_to(q)).fold(f64::INFINITY, f64::min);
            if centre_inside || reference < 0.0 {
                prop_assert!(d <= 0.0, "sampled overlap, exact {d}");
            } else {
                prop_assert!(d <= reference + 1e-9 && reference - d <= step, "exact {d} reference {reference}");
            }
        }
    }
}
