//! The robot's footprint as a polygon (issue 26): a simple polygon in the
//! robot frame (x forward, y left; costmap_2d's `footprint: [[x, y], ...]`),
//! grown by a padding, and the exact geometry the filter's checks need of it.
//!
//! The padded footprint is every point within `padding_m` of the polygon
//! (the polygon grown by a disc: its corners rounded), so "clear of the
//! padded footprint by c" is one number, the signed distance from the
//! polygon minus the padding.
//!
//! Two questions every check asks, answered exactly (no circle in place of
//! the polygon), by one method: along a one-parameter motion of a point in
//! the robot frame, the parameters where the point comes closer than `c` to
//! the footprint. The signed distance is continuous along the motion, so it
//! can cross `c` only where the point is exactly `|c|` from some edge: at a
//! disc of radius |c| round a vertex or on a line |c| off an edge, within the
//! edge's span. Those crossings are solved in closed form (a quadratic or a
//! linear equation per edge), the motion is cut there, and each piece is
//! classified by the signed distance at its midpoint.
//!   - A straight line, `a + t d` (a point's relative motion over one step
//!     at a fixed yaw rate is a line in the speed: the DTCBF's forbidden
//!     speeds, §5).
//!   - A rotation about the origin, `R(−α) p` (turning in place: a rotating
//!     rectangle sweeps its corners, ALGORITHM §5).
//!
//! Cost: O(E) per event search and O(E) per classified piece, E edges; a
//! rectangle gives at most a few dozen pieces per point.

use super::geometry::Vec2;
use std::f64::consts::PI;
use std::fmt;

/// Why a list of vertices is not a footprint.
#[derive(Debug, Clone, PartialEq)]
pub enum PolygonError {
    /// Fewer than three vertices.
    TooFewVertices(usize),
    /// A coordinate is NaN or infinite (vertex index).
    NotFinite(usize),
    /// Vertex `index` repeats the one before it (the last one the first).
    RepeatedVertex(usize),
    /// Edges `a` and `b` (edge i runs from vertex i to i + 1) cross or touch
    /// where they should not: the polygon is not simple.
    SelfIntersecting(usize, usize),
    /// The vertices enclose no area (all on one line).
    ZeroArea,
}

impl fmt::Display for PolygonError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::TooFewVertices(n) => write!(f, "a polygon needs at least 3 vertices, got {n}"),
            Self::NotFinite(i) => write!(f, "vertex {i} is not finite"),
            Self::RepeatedVertex(i) => write!(f, "vertex {i} repeats the one before it"),
            Self::SelfIntersecting(a, b) => write!(
                f,
                "edges {a} and {b} intersect: the polygon crosses itself (edge i runs from vertex i to i + 1)"
            ),
            Self::ZeroArea => write!(f, "the vertices enclose no area"),
        }
    }
}

impl std::error::Error for PolygonError {}

/// A simple polygon (convex or not), vertices counter-clockwise.
#[derive(Debug, Clone, PartialEq)]
pub struct Polygon {
    vertices: Vec<Vec2>,
    /// Edge i runs from vertex i to vertex i + 1 (the last back to the first).
    edges: Vec<Edge>,
    /// The farthest vertex's distance from the origin (m).
    radius_m: f64,
}

/// One edge, with what every distance to it needs computed once.
#[derive(Debug, Clone, PartialEq)]
struct Edge {
    a: Vec2,
    b: Vec2,
    /// b − a.
    ab: Vec2,
    /// ‖b − a‖².
    len2: f64,
}

impl Edge {
    /// Whether the ray from `q` towards +x crosses this edge (the even-odd
    /// rule's count; an edge's lower end counts, its upper end does not).
    #[inline]
    fn crossed_rightwards_from(&self, q: Vec2) -> bool {
        let (a, b) = (self.a, self.b);
        (a.y > q.y) != (b.y > q.y) && q.x < a.x + (q.y - a.y) / (b.y - a.y) * (b.x - a.x)
    }
}

/// The closed parameter range of a motion (t or α).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Span {
    /// Start.
    pub lo: f64,
    /// End, ≥ `lo`.
    pub hi: f64,
}

/// Twice the signed area (positive counter-clockwise).
fn twice_area(v: &[Vec2]) -> f64 {
    (0..v.len())
        .map(|i| {
            let (a, b) = (v[i], v[(i + 1) % v.len()]);
            a.x * b.y - a.y * b.x
        })
        .sum()
}

/// 2-D cross product (z of the 3-D one).
pub fn cross(a: Vec2, b: Vec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Whether closed segments `p0 p1` and `q0 q1` share a point (touching
/// counts), by the signs of the four orientation tests.
pub fn segments_meet(p0: Vec2, p1: Vec2, q0: Vec2, q1: Vec2) -> bool {
    let d1 = cross(p1 - p0, q0 - p0);
    let d2 = cross(p1 - p0, q1 - p0);
    let d3 = cross(q1 - q0, p0 - q0);
    let d4 = cross(q1 - q0, p1 - q0);
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0)) {
        return true;
    }
    let on = |a: Vec2, b: Vec2, p: Vec2, d: f64| {
        d == 0.0 && p.x >= a.x.min(b.x) && p.x <= a.x.max(b.x) && p.y >= a.y.min(b.y) && p.y <= a.y.max(b.y)
    };
    on(p0, p1, q0, d1) || on(p0, p1, q1, d2) || on(q0, q1, p0, d3) || on(q0, q1, p1, d4)
}

/// Distance from `q` to the closed segment `a b`.
pub fn segment_distance(q: Vec2, a: Vec2, b: Vec2) -> f64 {
    (q - closest_on_segment(q, a, b)).norm()
}

/// The point of the closed segment `a b` nearest to `q`.
#[inline]
pub fn closest_on_segment(q: Vec2, a: Vec2, b: Vec2) -> Vec2 {
    let ab = b - a;
    let len2 = ab.norm_squared();
    let t = if len2 > 0.0 {
        ((q - a).dot(&ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    a + t * ab
}

impl Polygon {
    /// A polygon from its vertices in either winding; refused unless simple
    /// (no edge meets another but at their shared vertex) with area.
    pub fn new(vertices: &[Vec2]) -> Result<Self, PolygonError> {
        let n = vertices.len();
        if n < 3 {
            return Err(PolygonError::TooFewVertices(n));
        }
        if let Some(i) = vertices.iter().position(|v| !(v.x.is_finite() && v.y.is_finite())) {
            return Err(PolygonError::NotFinite(i));
        }
        if let Some(i) = (0..n).find(|&i| vertices[i] == vertices[(i + n - 1) % n]) {
            return Err(PolygonError::RepeatedVertex(i));
        }
        for a in 0..n {
            for b in a + 1..n {
                let (p0, p1) = (vertices[a], vertices[(a + 1) % n]);
                let (q0, q1) = (vertices[b], vertices[(b + 1) % n]);
                let adjacent = b == a + 1 || (a == 0 && b == n - 1);
                if adjacent {
                    // Neighbours share one vertex; they may not fold back
                    // onto each other (collinear and overlapping).
                    let shared = if b == a + 1 { p1 } else { p0 };
                    let (u, w) = if b == a + 1 {
                        (p0 - shared, q1 - shared)
                    } else {
                        (p1 - shared, q0 - shared)
                    };
                    if cross(u, w) == 0.0 && u.dot(&w) > 0.0 {
                        return Err(PolygonError::SelfIntersecting(a, b));
                    }
                } else if segments_meet(p0, p1, q0, q1) {
                    return Err(PolygonError::SelfIntersecting(a, b));
                }
            }
        }
        let area2 = twice_area(vertices);
        if area2 == 0.0 || !area2.is_finite() {
            return Err(PolygonError::ZeroArea);
        }
        let mut v = vertices.to_vec();
        if area2 < 0.0 {
            v.reverse();
        }
        let radius_m = v.iter().map(|p| p.norm_squared()).fold(0.0, f64::max).sqrt();
        let edges = (0..n)
            .map(|i| {
                let (a, b) = (v[i], v[(i + 1) % n]);
                let ab = b - a;
                Edge {
                    a,
                    b,
                    ab,
                    len2: ab.norm_squared(),
                }
            })
            .collect();
        Ok(Self {
            vertices: v,
            edges,
            radius_m,
        })
    }

    /// An axis-aligned rectangle `length_m` x `width_m` centred on
    /// (`center_x_m`, 0) of the robot frame.
    pub fn rectangle(length_m: f64, width_m: f64, center_x_m: f64) -> Result<Self, PolygonError> {
        let (hx, hy) = (0.5 * length_m, 0.5 * width_m);
        Self::new(&[
            Vec2::new(center_x_m - hx, -hy),
            Vec2::new(center_x_m + hx, -hy),
            Vec2::new(center_x_m + hx, hy),
            Vec2::new(center_x_m - hx, hy),
        ])
    }

    /// The vertices, counter-clockwise.
    pub fn vertices(&self) -> &[Vec2] {
        &self.vertices
    }

    fn edges(&self) -> impl Iterator<Item = (Vec2, Vec2)> + '_ {
        self.edges.iter().map(|e| (e.a, e.b))
    }

    /// Whether `q` lies inside (even-odd rule; a point on the boundary may
    /// go either way: its signed distance is 0 both ways).
    pub fn contains(&self, q: Vec2) -> bool {
        self.edges
            .iter()
            .fold(false, |inside, e| inside != e.crossed_rightwards_from(q))
    }

    /// Signed distance from `q` to the polygon (m): positive outside,
    /// negative inside.
    pub fn signed_distance(&self, q: Vec2) -> f64 {
        // One pass over the edges: the least squared distance to an edge (one
        // root at the end, the arithmetic of `closest_on_segment`) and the
        // even-odd crossings of [`Self::contains`].
        let mut least2 = f64::INFINITY;
        let mut inside = false;
        for e in &self.edges {
            let t = if e.len2 > 0.0 {
                ((q - e.a).dot(&e.ab) / e.len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            least2 = least2.min((q - (e.a + t * e.ab)).norm_squared());
            inside = inside != e.crossed_rightwards_from(q);
        }
        let d = least2.sqrt();
        if inside {
            -d
        } else {
            d
        }
    }

    /// The point of the polygon's boundary nearest to `q`.
    pub fn closest_boundary_point(&self, q: Vec2) -> Vec2 {
        let mut best = (f64::INFINITY, self.vertices[0]);
        for (a, b) in self.edges() {
            let at = closest_on_segment(q, a, b);
            let d2 = (q - at).norm_squared();
            if d2 < best.0 {
                best = (d2, at);
            }
        }
        best.1
    }

    /// The least, over the directions normal to its edges, of the polygon's
    /// larger extent from the origin across that direction (m): how far the
    /// body reaches to either side of its origin when it moves along its
    /// narrowest way (for a rectangle centred on the origin, half its
    /// width). A non-convex polygon may be narrower along a direction none
    /// of its edges is normal to; this is then an upper bound, never less.
    pub fn passing_half_width_m(&self) -> f64 {
        passing_half_width_m(self.vertices.iter().copied())
    }

    /// The largest distance of a vertex from the robot frame's origin (m):
    /// the circumscribed circle about the rotation centre.
    pub fn circumscribed_radius_m(&self) -> f64 {
        self.radius_m
    }
}

/// [`Polygon::passing_half_width_m`] of the polygon with `vertices` (in
/// order, either winding; a repeated vertex's empty edge is skipped), without
/// building it: the way round asks on every scan.
pub fn passing_half_width_m(vertices: impl Iterator<Item = Vec2> + Clone) -> f64 {
    let first = vertices.clone().next();
    let next = vertices.clone().skip(1).chain(first);
    vertices
        .clone()
        .zip(next)
        .filter_map(|(a, b)| {
            let e = b - a;
            let len = e.norm();
            (len > 0.0).then(|| {
                let n = Vec2::new(-e.y, e.x) / len;
                vertices.clone().map(|v| v.dot(&n).abs()).fold(0.0, f64::max)
            })
        })
        .fold(f64::INFINITY, f64::min)
}

/// A polygon grown by a padding: what the checks keep clear.
#[derive(Debug, Clone, PartialEq)]
pub struct PaddedPolygon {
    /// The polygon.
    pub polygon: Polygon,
    /// The growth (m, ≥ 0).
    pub padding_m: f64,
}

impl PaddedPolygon {
    /// Signed distance from `q` to the padded footprint (m).
    pub fn signed_distance(&self, q: Vec2) -> f64 {
        self.polygon.signed_distance(q) - self.padding_m
    }

    /// How far the padded footprint reaches from its origin across a line of
    /// unit direction `dir` (its frame), to either side: the larger support
    /// of the vertices along the line's normal, plus the padding (m).
    pub fn half_extent_across_m(&self, dir: Vec2) -> f64 {
        let normal = Vec2::new(-dir.y, dir.x);
        self.polygon
            .vertices()
            .iter()
            .map(|v| v.dot(&normal).abs())
            .fold(0.0, f64::max)
            + self.padding_m
    }

    /// The circumscribed radius of the padded footprint about the origin (m).
    pub fn circumscribed_radius_m(&self) -> f64 {
        self.polygon.circumscribed_radius_m() + self.padding_m
    }

    /// The parameters t in `span` where the point `a + t d` is closer than
    /// `c` to the padded footprint (signed distance < `c`; `c` may be
    /// negative, a depth inside), appended to `out` as sorted disjoint open
    /// intervals. `events` is scratch (no allocation once it has grown to
    /// 4 E + 2).
    pub fn forbidden_on_line(
        &self,
        a: Vec2,
        d: Vec2,
        c: f64,
        span: Span,
        events: &mut Vec<f64>,
        out: &mut Vec<(f64, f64)>,
    ) {
        let level = (c + self.padding_m).abs();
        events.clear();
        for (p0, p1) in self.polygon.edges() {
            // |a + t d − p0| = level: a quadratic in t.
            line_disc_roots(a - p0, d, level, events);
            // n·(a + t d − p0) = ±level, with the foot within the edge.
            let e = p1 - p0;
            let len = e.norm();
            let (u, n) = (e / len, Vec2::new(-e.y, e.x) / len);
            let nd = n.dot(&d);
            if nd != 0.0 {
                for s in [level, -level] {
                    let t = (s - n.dot(&(a - p0))) / nd;
                    let along = u.dot(&(a + t * d - p0));
                    if (0.0..=len).contains(&along) {
                        events.push(t);
                    }
                }
            }
        }
        classify(events, span, |t| self.signed_distance(a + t * d) < c, out);
    }

    /// The angles α in `span` (rad, counter-clockwise turns of the robot
    /// about its origin) at which the world point `p` (robot frame at α = 0)
    /// is closer than `c` to the padded footprint: the robot turned by α
    /// sees it at R(−α) p. Appended to `out` as sorted disjoint open
    /// intervals; `events` is scratch.
    pub fn forbidden_turn(&self, p: Vec2, c: f64, span: Span, events: &mut Vec<f64>, out: &mut Vec<(f64, f64)>) {
        let level = (c + self.padding_m).abs();
        let rho = p.norm();
        let phi_p = p.y.atan2(p.x);
        events.clear();
        // The point at angle ψ on its circle is seen after the turn α = φ_p − ψ;
        // every such α in the span (and its turns by 2π) is an event.
        let push = |psi: f64, events: &mut Vec<f64>| {
            let alpha = phi_p - psi;
            let k0 = ((span.lo - alpha) / (2.0 * PI)).ceil();
            let mut k = k0;
            while alpha + 2.0 * PI * k <= span.hi {
                events.push(alpha + 2.0 * PI * k);
                k += 1.0;
            }
        };
        if rho > 0.0 {
            for (p0, p1) in self.polygon.edges() {
                // The circle |q| = ρ against the disc |q − p0| = level.
                let r0 = p0.norm();
                if r0 > 0.0 {
                    let cos = (rho * rho + r0 * r0 - level * level) / (2.0 * rho * r0);
                    if (-1.0..=1.0).contains(&cos) {
                        let base = p0.y.atan2(p0.x);
                        let w = cos.acos();
                        push(base + w, events);
                        push(base - w, events);
                    }
                }
                // ... against the lines n·(q − p0) = ±level, the foot within the edge.
                let e = p1 - p0;
                let len = e.norm();
                let (u, n) = (e / len, Vec2::new(-e.y, e.x) / len);
                let base = n.y.atan2(n.x);
                for s in [level, -level] {
                    let cos = (s + n.dot(&p0)) / rho;
                    if (-1.0..=1.0).contains(&cos) {
                        let w = cos.acos();
                        for psi in [base + w, base - w] {
                            let q = rho * Vec2::new(psi.cos(), psi.sin());
                            let along = u.dot(&(q - p0));
                            if (0.0..=len).contains(&along) {
                                push(psi, events);
                            }
                        }
                    }
                }
            }
        }
        let seen = |alpha: f64| {
            let (s, co) = alpha.sin_cos();
            Vec2::new(co * p.x + s * p.y, -s * p.x + co * p.y)
        };
        classify(events, span, |alpha| self.signed_distance(seen(alpha)) < c, out);
    }
}

/// Roots t of |w + t d| = level, pushed to `events`.
fn line_disc_roots(w: Vec2, d: Vec2, level: f64, events: &mut Vec<f64>) {
    let a = d.norm_squared();
    if a == 0.0 {
        return;
    }
    let b = w.dot(&d);
    let disc = b * b - a * (w.norm_squared() - level * level);
    if disc >= 0.0 {
        let s = disc.sqrt();
        events.push((-b - s) / a);
        events.push((-b + s) / a);
    }
}

/// Cuts `span` at the `events` inside it, classifies each piece by
/// `forbidden` at its midpoint, and appends the forbidden pieces, merged,
/// to `out`.
fn classify(events: &mut Vec<f64>, span: Span, forbidden: impl Fn(f64) -> bool, out: &mut Vec<(f64, f64)>) {
    let start = out.len();
    events.retain(|t| t.is_finite() && *t > span.lo && *t < span.hi);
    events.push(span.lo);
    events.push(span.hi);
    events.sort_by(f64::total_cmp);
    events.dedup();
    if events.len() == 1 {
        if forbidden(span.lo) {
            out.push((span.lo, span.hi));
        }
        return;
    }
    for w in events.windows(2) {
        let (lo, hi) = (w[0], w[1]);
        if forbidden(0.5 * (lo + hi)) {
            let n = out.len();
            if n > start && out[n - 1].1 == lo {
                out[n - 1].1 = hi;
            } else {
                out.push((lo, hi));
            }
        }
    }
}

#[cfg(test)]
impl PaddedPolygon {
    /// A 0.6 x 0.4 m base centred on its axle, unpadded: the hand values of
    /// the tests.
    pub(crate) fn base_0604() -> Self {
        Self {
            polygon: Polygon::rectangle(0.6, 0.4, 0.0).unwrap(),
            padding_m: 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn v(x: f64, y: f64) -> Vec2 {
        Vec2::new(x, y)
    }

    /// The 0.6 x 0.4 m base, centred on the rotation axis.
    #[test]
    fn bad_polygons_are_refused_with_the_reason() {
        assert_eq!(
            Polygon::new(&[v(0.0, 0.0), v(1.0, 0.0)]),
            Err(PolygonError::TooFewVertices(2))
        );
        assert_eq!(
            Polygon::new(&[v(0.0, 0.0), v(f64::NAN, 0.0), v(0.0, 1.0)]),
            Err(PolygonError::NotFinite(1))
        );
        assert_eq!(
            Polygon::new(&[v(0.0, 0.0), v(1.0, 0.0), v(1.0, 0.0), v(0.0, 1.0)]),
            Err(PolygonError::RepeatedVertex(2))
        );
        // A bow tie: edges 0 (0,0)-(1,1) and 2 (1,0)-(0,1) cross at (0.5, 0.5).
        assert_eq!(
            Polygon::new(&[v(0.0, 0.0), v(1.0, 1.0), v(1.0, 0.0), v(0.0, 1.0)]),
            Err(PolygonError::SelfIntersecting(0, 2))
        );
        // Folding back along an edge: (0,0) → (2,0) → (1,0).
        assert!(matches!(
            Polygon::new(&[v(0.0, 0.0), v(2.0, 0.0), v(1.0, 0.0)]),
            Err(PolygonError::SelfIntersecting(_, _))
        ));
        // All on one line, folding back at the end: edge 3 (2,0)-(0,0) runs back over edge 0.
        assert_eq!(
            Polygon::new(&[v(0.0, 0.0), v(1.0, 0.0), v(3.0, 0.0), v(2.0, 0.0)]).map(|_| ()),
            Err(PolygonError::SelfIntersecting(0, 3))
        );
        // Clockwise is accepted and turned counter-clockwise.
        let cw = Polygon::new(&[v(0.0, 0.0), v(0.0, 1.0), v(1.0, 1.0), v(1.0, 0.0)]).unwrap();
        assert!(twice_area(cw.vertices()) > 0.0);
    }

    #[test]
    fn signed_distance_of_the_0604_base_by_hand() {
        let b = PaddedPolygon::base_0604();
        assert!((b.signed_distance(v(0.0, 0.35)) - 0.15).abs() < 1e-12);
        assert!((b.signed_distance(v(0.5, 0.0)) - 0.2).abs() < 1e-12);
        // Beyond a corner: the distance to the corner (0.3, 0.2).
        assert!((b.signed_distance(v(0.6, 0.6)) - 0.5).abs() < 1e-12);
        // Inside: minus the distance to the nearest side.
        assert!((b.signed_distance(v(0.0, 0.0)) + 0.2).abs() < 1e-12);
        assert!((b.polygon.circumscribed_radius_m() - 0.13f64.sqrt()).abs() < 1e-12);
        // Its narrowest way is along x: 0.2 m to either side.
        assert!((b.polygon.passing_half_width_m() - 0.2).abs() < 1e-12);
        // Off-centre on its axle by 0.1 m: along y still 0.2; along x 0.4 one way.
        let off = Polygon::rectangle(0.6, 0.4, 0.1).unwrap();
        assert!((off.passing_half_width_m() - 0.2).abs() < 1e-12);
        // A padding of 0.05 m: 0.05 m less everywhere.
        let p = PaddedPolygon {
            padding_m: 0.05,
            ..PaddedPolygon::base_0604()
        };
        assert!((p.signed_distance(v(0.6, 0.6)) - 0.45).abs() < 1e-12);
    }

    #[test]
    fn turning_in_place_is_refused_where_a_corner_comes_within_c_and_allowed_where_not() {
        // The 0.6 x 0.4 m base beside a wall point 0.35 m to its left, d_safe 0.1 m.
        // At rest the side is 0.15 m from it. Turning, the corner (0.3, 0.2) at
        // radius √0.13 = 0.3606 m swings out: the point at (0, 0.35) is seen at
        // R(−α)(0, 0.35) = 0.35 (sin α, cos α); the side y = 0.2 comes within
        // 0.1 of it when 0.35 cos α = 0.3, while the point is still beside the
        // long side (0.35 sin α ≤ 0.3): α = acos(0.3/0.35) = 0.5411 rad.
        let b = PaddedPolygon::base_0604();
        let (mut out, mut ev) = (Vec::new(), Vec::new());
        let span = Span { lo: 0.0, hi: 0.5 };
        out.clear();
        b.forbidden_turn(v(0.0, 0.35), 0.1, span, &mut ev, &mut out);
        assert!(out.is_empty(), "half a radian is still clear: {out:?}");
        let span = Span { lo: 0.0, hi: 1.0 };
        out.clear();
        b.forbidden_turn(v(0.0, 0.35), 0.1, span, &mut ev, &mut out);
        assert_eq!(out.len(), 1, "{out:?}");
        assert!((out[0].0 - (0.3f64 / 0.35).acos()).abs() < 1e-12, "{out:?}");
        // Either way round: by symmetry the same angle clockwise.
        let span = Span { lo: -1.0, hi: 0.0 };
        out.clear();
        b.forbidden_turn(v(0.0, 0.35), 0.1, span, &mut ev, &mut out);
        assert_eq!(out.len(), 1, "{out:?}");
        assert!((out[0].1 + (0.3f64 / 0.35).acos()).abs() < 1e-12, "{out:?}");
        // A wall point 0.5 m to the left is beyond the corner's reach
        // (0.3606 + 0.1 < 0.5): a full turn is clear.
        let span = Span { lo: -PI, hi: PI };
        out.clear();
        b.forbidden_turn(v(0.0, 0.5), 0.1, span, &mut ev, &mut out);
        assert!(out.is_empty(), "{out:?}");
        // ... and a point 0.45 m away is reached (0.45 < 0.4606).
        out.clear();
        b.forbidden_turn(v(0.0, 0.45), 0.1, span, &mut ev, &mut out);
        assert!(!out.is_empty());
    }

    #[test]
    fn a_line_through_the_base_is_forbidden_from_c_before_to_c_after() {
        // A point ahead at (1, 0) closing at 1 m per unit t: forbidden from
        // the time it is 0.1 m before the front (x = 0.4: t = 0.6) until it
        // is 0.1 m behind the back (x = −0.4: t = 1.4).
        let b = PaddedPolygon::base_0604();
        let (mut out, mut ev) = (Vec::new(), Vec::new());
        out.clear();
        b.forbidden_on_line(
            v(1.0, 0.0),
            v(-1.0, 0.0),
            0.1,
            Span { lo: 0.0, hi: 2.0 },
            &mut ev,
            &mut out,
        );
        assert_eq!(out.len(), 1, "{out:?}");
        assert!(
            (out[0].0 - 0.6).abs() < 1e-12 && (out[0].1 - 1.4).abs() < 1e-12,
            "{out:?}"
        );
        // A line passing 0.25 m beside the long side (y = 0.45): clear at c = 0.1 ...
        out.clear();
        b.forbidden_on_line(
            v(1.0, 0.45),
            v(-1.0, 0.0),
            0.1,
            Span { lo: 0.0, hi: 2.0 },
            &mut ev,
            &mut out,
        );
        assert!(out.is_empty(), "{out:?}");
        // ... forbidden at c = 0.3 while beside it, plus the rounded corners:
        // |x| < 0.3 + √(0.3² − 0.25²) = 0.3 + 0.1658.
        out.clear();
        b.forbidden_on_line(
            v(1.0, 0.45),
            v(-1.0, 0.0),
            0.3,
            Span { lo: 0.0, hi: 2.0 },
            &mut ev,
            &mut out,
        );
        let w = (0.09f64 - 0.0625).sqrt();
        assert_eq!(out.len(), 1, "{out:?}");
        assert!((out[0].0 - (1.0 - 0.3 - w)).abs() < 1e-12, "{out:?}");
        assert!((out[0].1 - (1.0 + 0.3 + w)).abs() < 1e-12, "{out:?}");
    }

    /// A random simple polygon: a star-shaped one, vertices at sorted angles.
    fn star() -> impl Strategy<Value = Polygon> {
        prop::collection::vec((0.0..1.0f64, 0.1..1.0f64), 3..9).prop_filter_map("simple", |raw| {
            let n = raw.len();
            let v: Vec<Vec2> = raw
                .iter()
                .enumerate()
                .map(|(i, &(jitter, r))| {
                    let a = 2.0 * PI * (i as f64 + 0.8 * jitter) / n as f64;
                    Vec2::new(r * a.cos(), r * a.sin())
                })
                .collect();
            Polygon::new(&v).ok()
        })
    }

    /// The plain reference: a crossing-number inside test written apart, and
    /// the distance to each edge sampled along it.
    fn reference_sd(poly: &Polygon, q: Vec2) -> f64 {
        let vs = poly.vertices();
        let n = vs.len();
        let mut d = f64::INFINITY;
        let mut winding = 0i32;
        for i in 0..n {
            let (a, b) = (vs[i], vs[(i + 1) % n]);
            for k in 0..=2000 {
                let s = k as f64 / 2000.0;
                d = d.min((q - (a + s * (b - a))).norm());
            }
            if a.y <= q.y {
                if b.y > q.y && cross(b - a, q - a) > 0.0 {
                    winding += 1;
                }
            } else if b.y <= q.y && cross(b - a, q - a) < 0.0 {
                winding -= 1;
            }
        }
        if winding != 0 {
            -d
        } else {
            d
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        #[test]
        fn signed_distance_matches_a_plain_reference(poly in star(), x in -1.5..1.5f64, y in -1.5..1.5f64) {
            let q = v(x, y);
            let got = poly.signed_distance(q);
            let want = reference_sd(&poly, q);
            // The reference samples each edge every 1/2000 of its length (≤ 1 mm apart).
            prop_assert!((got.abs() - want.abs()).abs() <= 1e-3, "{got} vs {want}");
            if got.abs() > 1e-9 {
                prop_assert_eq!(got < 0.0, want < 0.0);
            }
        }

        #[test]
        fn forbidden_pieces_are_exactly_where_the_point_is_closer_than_c(
            poly in star(), pad in 0.0..0.1f64,
            ax in -2.0..2.0f64, ay in -2.0..2.0f64, dx in -1.0..1.0f64, dy in -1.0..1.0f64,
            c in -0.2..0.4f64, turn in prop::bool::ANY,
        ) {
            let fp = PaddedPolygon { polygon: poly, padding_m: pad };
            let (mut out, mut ev) = (Vec::new(), Vec::new());
            let span = if turn { Span { lo: -PI, hi: 1.5 * PI } } else { Span { lo: -2.0, hi: 3.0 } };
            let at = |t: f64| if turn {
                let (s, co) = t.sin_cos();
                v(co * ax + s * ay, -s * ax + co * ay)
            } else {
                v(ax, ay) + t * v(dx, dy)
            };
            if turn {
                fp.forbidden_turn(v(ax, ay), c, span, &mut ev, &mut out);
            } else {
                fp.forbidden_on_line(v(ax, ay), v(dx, dy), c, span, &mut ev, &mut out);
            }
            for w in out.windows(2) {
                prop_assert!(w[0].1 < w[1].0, "not sorted and disjoint: {:?}", out);
            }
            // Every sample away from an interval's end agrees with the signed distance.
            for k in 0..=997 {
                let t = span.lo + (span.hi - span.lo) * k as f64 / 997.0;
                if out.iter().any(|&(lo, hi)| (t - lo).abs() < 1e-7 || (t - hi).abs() < 1e-7) {
                    continue;
                }
                let sd = fp.signed_distance(at(t));
                if (sd - c).abs() < 1e-9 {
                    continue;
                }
                let inside = out.iter().any(|&(lo, hi)| t > lo && t < hi);
                prop_assert_eq!(inside, sd < c, "t {} sd {} c {} {:?}", t, sd, c, out);
            }
        }
    }
}
