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
//! below `max_range_m`) — and files each under the bearings it covers as
//! seen from the sensor (angular bins). A ray then tests only the shapes of
//! its bearing's bin, which hold every shape it can hit, so
//! [`ScanScratch::ray_cast`] returns exactly the value of
//! [`World::ray_cast`], an order of magnitude faster in cluttered worlds.
//!
//! Units: m, s; box yaw in degrees in YAML only (`yaw_deg`).

use super::motion::{MovingObstacle, MovingObstacleError, MovingObstacleSpec};
use super::shapes::{Circle, Segment};
use crate::algo::geometry::Vec2;
use crate::config::ConfigError;
use serde::{Deserialize, Serialize};
use std::fmt;

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
    /// of every query until replaced…
    agents: Vec<Circle>,
    /// …and the edges of the polygon bodies among them.
    agent_segments: Vec<Segment>,
    time_s: f64,
    bounds: Option<(Vec2, Vec2)>,
}

/// A static item of a [`WorldSpec`], as named in messages (`world.walls[2]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WorldItem {
    Wall(usize),
    Polygon(usize),
    Box(usize),
    Circle(usize),
}

impl fmt::Display for WorldItem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Wall(i) => write!(f, "world.walls[{i}]"),
            Self::Polygon(i) => write!(f, "world.polygons[{i}]"),
            Self::Box(i) => write!(f, "world.boxes[{i}]"),
            Self::Circle(i) => write!(f, "world.circles[{i}]"),
        }
    }
}

/// Why [`World::new`] rejected a spec: the item (and field) as data, so that
/// a scenario error can name the key without parsing the message.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WorldError {
    #[error("{item}: coordinates must be finite (got {value:?})")]
    NotFinite { item: WorldItem, value: [f64; 2] },
    #[error("world.walls[{index}]: zero length")]
    ZeroLengthWall { index: usize },
    #[error("world.polygons[{index}]: needs at least 3 vertices (got {vertices})")]
    TooFewVertices { index: usize, vertices: usize },
    /// Edge `edge` runs from vertex `edge` to vertex `next`.
    #[error("world.polygons[{index}]: edge {edge} (vertex {edge} to vertex {next}) has zero length")]
    ZeroLengthEdge { index: usize, edge: usize, next: usize },
    #[error("world.boxes[{index}]: size must be > 0 and finite (got {size:?})")]
    BoxSize { index: usize, size: [f64; 2] },
    #[error("world.boxes[{index}]: yaw_deg must be finite")]
    BoxYaw { index: usize, yaw_deg: f64 },
    #[error("world.circles[{index}]: radius_m must be > 0 and finite (got {radius_m})")]
    CircleRadius { index: usize, radius_m: f64 },
    #[error("world.moving[{index}]: {source}")]
    Moving {
        index: usize,
        #[source]
        source: MovingObstacleError,
    },
}

impl WorldError {
    /// The dotted key: the item, or its field when the message names one
    /// (`world.walls[2]`, `world.circles[0].radius_m`).
    pub fn key(&self) -> String {
        match self {
            Self::NotFinite { item, .. } => item.to_string(),
            Self::ZeroLengthWall { index } => WorldItem::Wall(*index).to_string(),
            Self::TooFewVertices { index, .. } | Self::ZeroLengthEdge { index, .. } => {
                WorldItem::Polygon(*index).to_string()
            }
            Self::BoxSize { index, .. } => WorldItem::Box(*index).to_string(),
            Self::BoxYaw { index, .. } => format!("{}.yaw_deg", WorldItem::Box(*index)),
            Self::CircleRadius { index, .. } => format!("{}.radius_m", WorldItem::Circle(*index)),
            Self::Moving { index, source } => match source.field() {
                Some(field) => format!("world.moving[{index}].{field}"),
                None => format!("world.moving[{index}]"),
            },
        }
    }

    /// The message without the key: `zero length`.
    pub fn detail(&self) -> String {
        match self {
            Self::NotFinite { value, .. } => format!("coordinates must be finite (got {value:?})"),
            Self::ZeroLengthWall { .. } => "zero length".into(),
            Self::TooFewVertices { vertices, .. } => format!("needs at least 3 vertices (got {vertices})"),
            Self::ZeroLengthEdge { edge, next, .. } => {
                format!("edge {edge} (vertex {edge} to vertex {next}) has zero length")
            }
            Self::BoxSize { size, .. } => format!("size must be > 0 and finite (got {size:?})"),
            Self::BoxYaw { .. } => "must be finite".into(),
            Self::CircleRadius { radius_m, .. } => format!("must be > 0 and finite (got {radius_m})"),
            Self::Moving { source, .. } => source.detail(),
        }
    }

    /// As an error of the scenario `file`, naming the key.
    pub fn in_file(&self, file: &str) -> ConfigError {
        ConfigError::at(file, self.key(), self.detail())
    }
}

fn point(v: [f64; 2], item: WorldItem) -> Result<Vec2, WorldError> {
    if v[0].is_finite() && v[1].is_finite() {
        Ok(Vec2::new(v[0], v[1]))
    } else {
        Err(WorldError::NotFinite { item, value: v })
    }
}

impl World {
    /// Lowers `spec` to segments and circles, rejecting non-finite numbers,
    /// zero-length walls or polygon edges, polygons with fewer than 3
    /// vertices, non-positive box sizes and radii. The message names the
    /// item, e.g. `"world.walls[2]: zero length"`. The clock starts at 0 s.
    pub fn new(spec: &WorldSpec) -> Result<World, WorldError> {
        let mut segments = Vec::new();
        for (i, w) in spec.walls.iter().enumerate() {
            let item = WorldItem::Wall(i);
            let s = Segment::new(point(w.from, item)?, point(w.to, item)?);
            if s.length_m() <= 0.0 {
                return Err(WorldError::ZeroLengthWall { index: i });
            }
            segments.push(s);
        }
        for (i, poly) in spec.polygons.iter().enumerate() {
            if poly.len() < 3 {
                return Err(WorldError::TooFewVertices {
                    index: i,
                    vertices: poly.len(),
                });
            }
            let pts = poly
                .iter()
                .map(|v| point(*v, WorldItem::Polygon(i)))
                .collect::<Result<Vec<_>, _>>()?;
            for k in 0..pts.len() {
                let s = Segment::new(pts[k], pts[(k + 1) % pts.len()]);
                if s.length_m() <= 0.0 {
                    return Err(WorldError::ZeroLengthEdge {
                        index: i,
                        edge: k,
                        next: (k + 1) % pts.len(),
                    });
                }
                segments.push(s);
            }
        }
        for (i, b) in spec.boxes.iter().enumerate() {
            let c = point(b.center, WorldItem::Box(i))?;
            if !(b.size[0].is_finite() && b.size[1].is_finite() && b.size[0] > 0.0 && b.size[1] > 0.0) {
                return Err(WorldError::BoxSize { index: i, size: b.size });
            }
            if !b.yaw_deg.is_finite() {
                return Err(WorldError::BoxYaw {
                    index: i,
                    yaw_deg: b.yaw_deg,
                });
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
            let center = point(c.center, WorldItem::Circle(i))?;
            if !(c.radius_m.is_finite() && c.radius_m > 0.0) {
                return Err(WorldError::CircleRadius {
                    index: i,
                    radius_m: c.radius_m,
                });
            }
            circles.push(Circle::new(center, c.radius_m));
        }
        let moving = spec
            .moving
            .iter()
            .enumerate()
            .map(|(i, m)| MovingObstacle::new(m).map_err(|source| WorldError::Moving { index: i, source }))
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
            agent_segments: Vec::new(),
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

    /// Replaces the externally placed shapes (other robots, seen by the one
    /// being queried): disc bodies, and the edges of polygon bodies.
    /// Allocates only while the buffers grow.
    pub fn set_agents(&mut self, discs: impl Iterator<Item = Circle>, edges: impl Iterator<Item = Segment>) {
        self.agents.clear();
        self.agents.extend(discs);
        self.agent_segments.clear();
        self.agent_segments.extend(edges);
    }

    /// The externally placed discs.
    pub fn agents(&self) -> &[Circle] {
        &self.agents
    }

    /// The externally placed polygon bodies' edges.
    pub fn agent_segments(&self) -> &[Segment] {
        &self.agent_segments
    }

    /// Exact distance from `p` (m) to the nearest obstacle surface: segments,
    /// static circles and moving circles at the current time. Negative inside
    /// a circle (minus the penetration depth); `+inf` for an empty world.
    pub fn distance_to_nearest(&self, p: Vec2) -> f64 {
        let mut best = f64::INFINITY;
        for s in self.segments.iter().chain(&self.agent_segments) {
            best = best.min(s.distance_to(p));
        }
        for c in self.circles.iter().chain(&self.moving_now).chain(&self.agents) {
            best = best.min(c.signed_distance_to(p));
        }
        best
    }

    /// The point of the nearest obstacle surface to `p` (m), the one
    /// [`Self::distance_to_nearest`] measures to; `None` for an empty world.
    /// From the centre of a circle any point of it is as near: +x is taken.
    pub fn nearest_surface_point(&self, p: Vec2) -> Option<Vec2> {
        let mut best: Option<(f64, Vec2)> = None;
        let mut consider = |d: f64, q: Vec2| {
            if best.is_none_or(|(b, _)| d < b) {
                best = Some((d, q));
            }
        };
        for s in self.segments.iter().chain(&self.agent_segments) {
            let e = s.b - s.a;
            let ee = e.dot(&e);
            let t = if ee > 0.0 {
                ((p - s.a).dot(&e) / ee).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let q = s.a + e * t;
            consider((p - q).norm(), q);
        }
        for c in self.circles.iter().chain(&self.moving_now).chain(&self.agents) {
            let d = p - c.center;
            let n = d.norm();
            let dir = if n > 0.0 { d / n } else { Vec2::new(1.0, 0.0) };
            consider(c.signed_distance_to(p), c.center + dir * c.radius_m);
        }
        best.map(|(_, q)| q)
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
        let agents = ray_cast_shapes(&self.agent_segments, &self.agents, &[], origin, dir_unit, max_range_m);
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
        scratch.segments.extend(
            self.segments
                .iter()
                .chain(&self.agent_segments)
                .filter(|s| s.distance_to(origin) < max_range_m),
        );
        scratch.circles.extend(
            self.circles
                .iter()
                .chain(&self.moving_now)
                .chain(&self.agents)
                .filter(|c| c.signed_distance_to(origin) < max_range_m),
        );
        scratch.origin = origin;
        scratch
            .segment_bins
            .fill(scratch.segments.iter().map(|s| BearingSpan::of_segment(s, origin)));
        scratch
            .circle_bins
            .fill(scratch.circles.iter().map(|c| BearingSpan::of_circle(c, origin)));
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
    /// The sensor position the bins were built for (m).
    origin: Vec2,
    /// Indices into `segments` / `circles` by bearing from `origin`.
    segment_bins: BearingBins,
    circle_bins: BearingBins,
}

impl ScanScratch {
    /// Like [`World::ray_cast`], over the culled shapes only. Gives the same
    /// answer as the world for rays from the `origin` given to
    /// [`World::prepare_scan`] with `max_range_m` no larger than there. Rays
    /// from that origin test only the shapes filed under their bearing;
    /// rays from elsewhere test every culled shape.
    pub fn ray_cast(&self, origin: Vec2, dir_unit: Vec2, max_range_m: f64) -> Option<f64> {
        if origin != self.origin {
            return ray_cast_shapes(&self.segments, &self.circles, &[], origin, dir_unit, max_range_m);
        }
        let bin = BearingBins::bin_of(dir_unit);
        let mut best = max_range_m;
        for &i in self.segment_bins.items(bin) {
            if let Some(t) = self.segments[i as usize].ray_hit(origin, dir_unit) {
                if t < best {
                    best = t;
                }
            }
        }
        for &i in self.circle_bins.items(bin) {
            if let Some(t) = self.circles[i as usize].ray_hit(origin, dir_unit) {
                if t < best {
                    best = t;
                }
            }
        }
        // As in `ray_cast_shapes`: only an improving hit gives a value.
        (best < max_range_m).then_some(best)
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

/// Number of bearing bins over the full circle (0.9° to 1.8° each): about
/// one beam per bin at 256 beams; a people-sized disc 2 m away covers 4-8.
const BEARING_BINS: usize = 256;

/// Width by which every shape's bearing interval is widened (rad), so that
/// rounding in the bearings can never drop a shape from a ray's bin (the
/// rounding is ~1e-15 rad).
const BEARING_MARGIN_RAD: f64 = 1e-6;

/// The bearings a shape covers seen from the sensor: `count` bins from
/// `first` (wrapping past the last bin), or all of them.
#[derive(Debug, Clone, Copy, PartialEq)]
struct BearingSpan {
    first: usize,
    count: usize,
}

impl BearingSpan {
    const ALL: BearingSpan = BearingSpan {
        first: 0,
        count: BEARING_BINS,
    };

    /// Bins covering the bearings [`lo_rad`, `lo_rad + width_rad`], widened
    /// by `margin_rad` on both sides; all of them from half a turn on.
    fn covering(lo_rad: f64, width_rad: f64, margin_rad: f64) -> BearingSpan {
        let (a, b) = (lo_rad - margin_rad, lo_rad + width_rad + margin_rad);
        // (NaN, e.g. from an infinite bound, also takes the safe branch.)
        if (b - a).is_nan() || b - a >= std::f64::consts::PI {
            return Self::ALL;
        }
        let first = BearingBins::bin_of(Vec2::new(a.cos(), a.sin()));
        let last = BearingBins::bin_of(Vec2::new(b.cos(), b.sin()));
        let count = if last >= first {
            last - first + 1
        } else {
            BEARING_BINS - first + last + 1
        };
        BearingSpan { first, count }
    }

    /// The bins, in order.
    fn bins(self) -> impl Iterator<Item = usize> {
        (0..self.count).map(move |j| (self.first + j) % BEARING_BINS)
    }

    /// Every bearing at which a ray from `origin` can hit the segment: the
    /// angle it subtends, widened for the endpoint tolerance of
    /// [`Segment::ray_hit`]; all bearings if the origin is on it.
    fn of_segment(s: &Segment, origin: Vec2) -> BearingSpan {
        let (a, b) = (s.a - origin, s.b - origin);
        let near = a.norm().min(b.norm());
        if s.distance_to(origin) <= 1e-9 || near <= 1e-9 {
            return Self::ALL;
        }
        // Signed angle from a to b, in (−π, π]: the short way round (the
        // segment misses the origin, so it subtends less than π).
        let sweep = (a.x * b.y - a.y * b.x).atan2(a.dot(&b));
        let (lo, width) = if sweep >= 0.0 {
            (a.y.atan2(a.x), sweep)
        } else {
            (b.y.atan2(b.x), -sweep)
        };
        // `ray_hit` accepts the segment extended by 2e-9 of its length at each end.
        let tolerance = 4.0 * 1e-9 * s.length_m() / near;
        Self::covering(lo, width, BEARING_MARGIN_RAD + tolerance)
    }

    /// Every bearing at which a ray from `origin` can hit the disc (its
    /// tangents), or all bearings if the origin is inside or on it.
    fn of_circle(c: &Circle, origin: Vec2) -> BearingSpan {
        let d = c.center - origin;
        let dist = d.norm();
        if dist.is_nan() || dist <= c.radius_m * (1.0 + 1e-9) + 1e-12 {
            return Self::ALL;
        }
        let half = (c.radius_m / dist).asin();
        Self::covering(d.y.atan2(d.x) - half, 2.0 * half, BEARING_MARGIN_RAD)
    }
}

/// Shape indices filed by bearing bin (compressed rows: bin k holds
/// `items[start[k]..start[k + 1]]`). Reused across scans: allocates only
/// while it grows.
#[derive(Debug, Clone, Default)]
struct BearingBins {
    start: Vec<u32>,
    items: Vec<u32>,
    spans: Vec<BearingSpan>,
}

impl BearingBins {
    /// The bin of direction `d`'s bearing. Bins are uniform not in the
    /// angle but in a pseudo-angle that grows with it (from 0 at −π to 4 at
    /// +π, piecewise d.y / (|d.x| + |d.y|)): the same order of bearings with
    /// no trigonometry per ray. A NaN direction falls in bin 0.
    fn bin_of(d: Vec2) -> usize {
        let p = d.y / (d.x.abs() + d.y.abs());
        let q = if d.x >= 0.0 {
            2.0 + p
        } else if d.y >= 0.0 {
            4.0 - p
        } else {
            -p
        };
        ((q * (BEARING_BINS as f64 / 4.0)) as usize).min(BEARING_BINS - 1)
    }

    /// Files shape i under every bin of the i-th span.
    fn fill(&mut self, spans: impl Iterator<Item = BearingSpan>) {
        self.spans.clear();
        self.spans.extend(spans);
        self.start.clear();
        self.start.resize(BEARING_BINS + 1, 0);
        for s in &self.spans {
            for k in s.bins() {
                self.start[k + 1] += 1;
            }
        }
        for k in 0..BEARING_BINS {
            self.start[k + 1] += self.start[k];
        }
        let total = self.start[BEARING_BINS] as usize;
        self.items.clear();
        self.items.resize(total, 0);
        // Fill each bin from its end down (start[k + 1] is its end), leaving start[k + 1] at the bin's start...
        for (i, s) in self.spans.iter().enumerate() {
            for k in s.bins() {
                self.start[k + 1] -= 1;
                self.items[self.start[k + 1] as usize] = i as u32;
            }
        }
        // ...so now start[k + 1] is bin k's start: shift back by one bin.
        self.start.copy_within(1..=BEARING_BINS, 0);
        self.start[BEARING_BINS] = total as u32;
    }

    fn items(&self, bin: usize) -> &[u32] {
        if self.start.len() != BEARING_BINS + 1 {
            return &[];
        }
        &self.items[self.start[bin] as usize..self.start[bin + 1] as usize]
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

    /// Directions that probe the bin edges: uniform ones, ±x (bearing ±π),
    /// and rays aimed exactly at every vertex and along every disc's tangents.
    fn probe_directions(o: Vec2, spec: &WorldSpec) -> Vec<Vec2> {
        let mut dirs: Vec<Vec2> = (0..1024)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 1024.0 + 0.0003;
                v(a.cos(), a.sin())
            })
            .collect();
        dirs.extend([v(-1.0, 0.0), v(-1.0, -0.0), v(1.0, 0.0), v(0.0, 1.0), v(0.0, -1.0)]);
        for w in &spec.walls {
            for p in [w.from, w.to] {
                dirs.push(v(p[0], p[1]) - o);
            }
        }
        for c in &spec.circles {
            let d = v(c.center[0], c.center[1]) - o;
            if d.norm() > c.radius_m {
                let half = (c.radius_m / d.norm()).asin();
                let a = d.y.atan2(d.x);
                dirs.extend([a - half, a + half].map(|b| v(b.cos(), b.sin())));
            }
        }
        dirs.into_iter()
            .filter(|d| d.norm() > 0.0)
            .map(|d| d.normalize())
            .collect()
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig {
            cases: 200,
            rng_seed: proptest::test_runner::RngSeed::Fixed(0x5CA7),
            failure_persistence: None,
            ..proptest::prelude::ProptestConfig::default()
        })]

        /// The bearing bins never change a ray's answer: the binned cast equals
        /// the brute-force cast over the whole world, also from origins on a
        /// wall, at a vertex or inside a disc.
        #[test]
        fn binned_scan_casts_equal_brute_force(
            walls in proptest::collection::vec(((-5.0..5.0f64, -5.0..5.0f64), (-5.0..5.0f64, -5.0..5.0f64)), 0..12),
            circles in proptest::collection::vec(((-5.0..5.0f64, -5.0..5.0f64), 0.01..2.0f64), 0..12),
            origin in (-5.0..5.0f64, -5.0..5.0f64),
            origin_kind in 0usize..4,
            range in proptest::prop_oneof![proptest::strategy::Just(100.0f64), 0.5..6.0f64],
        ) {
            let spec = WorldSpec {
                walls: walls
                    .iter()
                    .filter(|(a, b)| a != b)
                    .map(|&(a, b)| WallSpec { from: [a.0, a.1], to: [b.0, b.1] })
                    .collect(),
                circles: circles
                    .iter()
                    .map(|&(c, r)| CircleSpec { center: [c.0, c.1], radius_m: r })
                    .collect(),
                ..WorldSpec::default()
            };
            let w = World::new(&spec).expect("valid");
            // The origin: free, at a wall's vertex, on a wall, or at a disc's centre.
            let o = match (origin_kind, spec.walls.first(), spec.circles.first()) {
                (1, Some(wall), _) => v(wall.from[0], wall.from[1]),
                (2, Some(wall), _) => (v(wall.from[0], wall.from[1]) + v(wall.to[0], wall.to[1])) * 0.5,
                (3, _, Some(c)) => v(c.center[0], c.center[1]),
                _ => v(origin.0, origin.1),
            };
            let mut sc = ScanScratch::default();
            w.prepare_scan(o, range, &mut sc);
            for d in probe_directions(o, &spec) {
                proptest::prop_assert_eq!(sc.ray_cast(o, d, range), w.ray_cast(o, d, range), "direction {:?}", d);
            }
        }
    }

    #[test]
    fn bearing_bins_hold_each_shape_where_it_is_seen() {
        // A post due east of the sensor is filed under the bins around bearing 0
        // only, a wall around the sensor under every bin.
        let mut bins = BearingBins::default();
        let east = BearingSpan::of_circle(&Circle::new(v(2.0, 0.0), 0.1), v(0.0, 0.0));
        let around = BearingSpan::of_segment(&Segment::new(v(-1.0, 0.0), v(1.0, 0.0)), v(0.0, 0.0));
        assert_eq!(around, BearingSpan::ALL);
        bins.fill([east, around].into_iter());
        let zero = BearingBins::bin_of(v(1.0, 0.0));
        assert_eq!(bins.items(zero).len(), 2);
        assert_eq!(bins.items(BearingBins::bin_of(v(0.0, 1.0))), [1]);
        // The post subtends ±asin(0.1 / 2) ≈ ±2.9°; bins near bearing 0 are 0.9° wide.
        let covered: Vec<usize> = (0..BEARING_BINS).filter(|&k| bins.items(k).contains(&0)).collect();
        assert!(covered.len() >= 7 && covered.len() <= 10, "{covered:?}");
        assert!(covered.contains(&zero) && covered.contains(&(zero - 1)), "{covered:?}");
        // Bearings ±π share the wrap-around: a post due west is in the first and last bins.
        let west = BearingSpan::of_circle(&Circle::new(v(-2.0, 0.0), 0.1), v(0.0, 0.0));
        bins.fill(std::iter::once(west));
        assert_eq!(bins.items(BearingBins::bin_of(v(-1.0, 0.0))), [0]);
        assert_eq!(bins.items(BearingBins::bin_of(v(-1.0, -1e-12))), [0]);
        assert_eq!(BearingBins::bin_of(v(-1.0, -1e-12)), 0);
        assert_eq!(BearingBins::bin_of(v(-1.0, 0.0)), BEARING_BINS - 1);
        // The bins follow the bearing round the circle, each used, none out of order.
        let seen: Vec<usize> = (0..=100_000)
            .map(|k| {
                let a = -std::f64::consts::PI + k as f64 * std::f64::consts::TAU / 100_000.0;
                BearingBins::bin_of(v(a.cos(), a.sin()))
            })
            .collect();
        assert!(seen
            .windows(2)
            .all(|w| w[0] <= w[1] || (w[0] == BEARING_BINS - 1 && w[1] == 0)));
        assert_eq!(
            seen.iter().collect::<std::collections::BTreeSet<_>>().len(),
            BEARING_BINS
        );
        assert!(bins.items(zero).is_empty());
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
        let err = |s: &WorldSpec| World::new(s).unwrap_err().to_string();
        assert_eq!(err(&s), "world.walls[2]: zero length");
        s.walls[2].to = [f64::NAN, 1.0];
        assert!(err(&s).starts_with("world.walls[2]"));
        s.walls.truncate(2);
        s.polygons = vec![vec![[0.0, 0.0], [1.0, 0.0]]];
        assert!(err(&s).starts_with("world.polygons[0]"));
        s.polygons = vec![vec![[0.0, 0.0], [1.0, 0.0], [1.0, 0.0]]];
        assert!(err(&s).contains("edge 1"));
        s.polygons.clear();
        s.boxes = vec![BoxSpec {
            center: [0.0, 0.0],
            size: [1.0, 0.0],
            yaw_deg: 0.0,
        }];
        assert!(err(&s).starts_with("world.boxes[0]: size"));
        s.boxes.clear();
        s.circles = vec![CircleSpec {
            center: [0.0, 0.0],
            radius_m: -1.0,
        }];
        assert!(err(&s).starts_with("world.circles[0]: radius_m"));
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
        assert!(err(&s).starts_with("world.moving[0]: radius_m"));
    }

    #[test]
    fn agents_are_seen_by_every_query_until_replaced() {
        let mut w = World::new(&WorldSpec::default()).unwrap();
        w.set_agents([Circle::new(v(2.0, 0.0), 0.5)].into_iter(), std::iter::empty());
        assert!((w.distance_to_nearest(v(0.0, 0.0)) - 1.5).abs() < 1e-12);
        assert_eq!(w.ray_cast(v(0.0, 0.0), v(1.0, 0.0), 10.0), Some(1.5));
        let mut scratch = ScanScratch::default();
        w.prepare_scan(v(0.0, 0.0), 10.0, &mut scratch);
        assert_eq!(scratch.ray_cast(v(0.0, 0.0), v(1.0, 0.0), 10.0), Some(1.5));
        // A polygon body's edge, 1.2 m ahead across the ray: seen by every query too.
        let edge = Segment::new(v(1.2, -0.2), v(1.2, 0.2));
        w.set_agents(std::iter::empty(), std::iter::once(edge));
        assert!((w.distance_to_nearest(v(0.0, 0.0)) - 1.2).abs() < 1e-12);
        assert_eq!(w.nearest_surface_point(v(0.0, 0.0)), Some(v(1.2, 0.0)));
        assert_eq!(w.ray_cast(v(0.0, 0.0), v(1.0, 0.0), 10.0), Some(1.2));
        w.prepare_scan(v(0.0, 0.0), 10.0, &mut scratch);
        assert_eq!(scratch.ray_cast(v(0.0, 0.0), v(1.0, 0.0), 10.0), Some(1.2));
        w.set_agents(std::iter::empty(), std::iter::empty());
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

    #[test]
    fn world_errors_name_the_key_in_their_message() {
        use crate::sim::motion::{MovingObstacleError as M, PointField};
        use crate::sim::world::WorldItem;
        use crate::sim::WorldError as W;
        let moving = |source: M| W::Moving { index: 1, source };
        let cases: Vec<(W, &str)> = vec![
            (
                W::NotFinite {
                    item: WorldItem::Wall(0),
                    value: [f64::NAN, 0.0],
                },
                "key `world.walls[0]`: coordinates must be finite (got [NaN, 0.0])",
            ),
            (
                W::NotFinite {
                    item: WorldItem::Polygon(4),
                    value: [f64::NAN, 0.0],
                },
                "key `world.polygons[4]`: coordinates must be finite (got [NaN, 0.0])",
            ),
            (
                W::NotFinite {
                    item: WorldItem::Circle(0),
                    value: [0.0, f64::NAN],
                },
                "key `world.circles[0]`: coordinates must be finite (got [0.0, NaN])",
            ),
            (
                moving(M::NotFinite {
                    field: PointField::Start,
                    value: [f64::NAN, 0.0],
                }),
                "key `world.moving[1].motion.start`: must be finite (got [NaN, 0.0])",
            ),
            (
                moving(M::NotFinite {
                    field: PointField::VelocityMps,
                    value: [f64::INFINITY, 0.0],
                }),
                "key `world.moving[1].motion.velocity_mps`: must be finite (got [inf, 0.0])",
            ),
            (
                moving(M::NotFinite {
                    field: PointField::RegionMin,
                    value: [f64::NAN, 0.0],
                }),
                "key `world.moving[1].motion.region_min`: must be finite (got [NaN, 0.0])",
            ),
            (W::ZeroLengthWall { index: 2 }, "key `world.walls[2]`: zero length"),
            (
                W::NotFinite {
                    item: WorldItem::Box(0),
                    value: [f64::INFINITY, 0.0],
                },
                "key `world.boxes[0]`: coordinates must be finite (got [inf, 0.0])",
            ),
            (
                W::TooFewVertices { index: 0, vertices: 2 },
                "key `world.polygons[0]`: needs at least 3 vertices (got 2)",
            ),
            (
                W::ZeroLengthEdge {
                    index: 0,
                    edge: 2,
                    next: 0,
                },
                "key `world.polygons[0]`: edge 2 (vertex 2 to vertex 0) has zero length",
            ),
            (
                W::BoxSize {
                    index: 1,
                    size: [-1.0, 0.3],
                },
                "key `world.boxes[1]`: size must be > 0 and finite (got [-1.0, 0.3])",
            ),
            (
                W::BoxYaw {
                    index: 1,
                    yaw_deg: f64::NAN,
                },
                "key `world.boxes[1].yaw_deg`: must be finite",
            ),
            (
                W::CircleRadius {
                    index: 3,
                    radius_m: -0.1,
                },
                "key `world.circles[3].radius_m`: must be > 0 and finite (got -0.1)",
            ),
            (
                moving(M::Radius { radius_m: 0.0 }),
                "key `world.moving[1].radius_m`: must be > 0 and finite (got 0)",
            ),
            (
                moving(M::NotFinite {
                    field: PointField::RegionMax,
                    value: [0.0, f64::INFINITY],
                }),
                "key `world.moving[1].motion.region_max`: must be finite (got [0.0, inf])",
            ),
            (
                moving(M::NotFinite {
                    field: PointField::Waypoint(2),
                    value: [f64::NAN, 0.0],
                }),
                "key `world.moving[1]`: motion.waypoints[2] must be finite (got [NaN, 0.0])",
            ),
            (
                moving(M::StartTime {
                    start_time_s: f64::NAN,
                }),
                "key `world.moving[1].motion.start_time_s`: must be finite (got NaN)",
            ),
            (
                moving(M::Speed { speed_mps: -0.1 }),
                "key `world.moving[1].motion.speed_mps`: must be >= 0 and finite (got -0.1)",
            ),
            (
                moving(M::Waypoints {
                    points: 1,
                    loop_length_m: 0.0,
                }),
                "key `world.moving[1]`: motion.waypoints needs at least 2 distinct points (got 1 point(s), loop length 0 m)",
            ),
            (
                moving(M::EmptyRegion {
                    region_min: [0.0, 0.0],
                    region_max: [1.0, 0.0],
                }),
                "key `world.moving[1].motion.region_min`: must be < motion.region_max on both axes (got [0.0, 0.0], [1.0, 0.0])",
            ),
            (
                moving(M::StartOutside {
                    start: [2.0, 0.5],
                    region_min: [0.0, 0.0],
                    region_max: [1.0, 1.0],
                }),
                "key `world.moving[1]`: motion.start [2.0, 0.5] must lie inside the region [[0.0, 0.0], [1.0, 1.0]]",
            ),
        ];
        for (e, want) in &cases {
            assert_eq!(e.in_file("s.yaml").to_string(), format!("s.yaml: {want}"));
            assert_eq!(e.in_file("s.yaml").keys(), [e.key()]);
        }
    }
}
