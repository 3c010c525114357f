//! Points → clearances (ALGORITHM.md §2, paper III.A and IV.D).
//!
//! Clearance of a point: c = ‖P‖ − r, its distance from the robot centre minus
//! the robot radius. The left hemisphere is y > 0, the right y < 0, each
//! restricted to the sector |bearing| ≤ hemisphere_fov/2 (default 180°: the
//! front half). d_min is over every valid point (the full scan), because the
//! safe set S = { d_min ≥ d_safe } must hold all around the robot.
//!
//! Departure (ALGORITHM.md §4b, smooth steering): with a positive
//! `barrier.side_fade_deg` the sides have no hard edges ([`SideFade`]). With
//! fade φ = min(side_fade, hemisphere_fov/2, 90°), hemisphere half-angle
//! H = min(hemisphere_fov/2, 180°) and d_act = d_safe + Γ^(2/σ) (1.2 m by
//! default), a point at bearing b (left positive) counts for a side with its
//! clearance raised by the penalty f · d_act, where f is the larger of
//! * the cross-side ramp, sin b / sin φ for the right side and −sin b / sin φ
//!   for the left: negative (no penalty) on the side's own half, 0 dead
//!   ahead, growing linearly in sin(bearing) to 1 at φ into the other half;
//! * the rear ramp (only when H < 180°), max(0, (cos(H − φ) − cos b) /
//!   (cos(H − φ) − cos H)): 0 up to |b| = H − φ, growing linearly in
//!   cos(bearing) to 1 at the hemisphere's edge |b| = H.
//!
//! Where f ≥ 1 the point does not count for that side at all (nor in its
//! crowding): the penalty ranges over [0, d_act), approaching its supremum
//! d_act at the end of either ramp, where the point drops out. With the
//! defaults (φ = 30°, H = 90°) a point counts without penalty on its own side
//! up to 60° of bearing, with a penalty rising to d_act (linearly in cos) from
//! 60° to 90°, and on the other side with a penalty rising to d_act (linearly
//! in sin) from 0° to 30°. Near the end of a ramp a point's penalised clearance
//! is close to c + d_act, so (for c ≥ 0) its B_d is at or next to its floor of
//! 1 when it drops out: a point that crosses bearing 0 (or the hemisphere edge)
//! moves B_l and B_r continuously, dead ahead it counts the same on both sides,
//! and the steering term k (B_r − B_l) passes through 0 instead of jumping from
//! one sign to the other. d_min and the front sector are not faded. A fade of 0
//! gives the hard sectors.

use super::footprint::PaddedPolygon;
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
    /// Closest point in the left sector, robot frame (m).
    pub closest_left: Option<Vec2>,
    /// Closest point in the right sector, robot frame (m).
    pub closest_right: Option<Vec2>,
    /// Closest point overall, robot frame (m).
    pub closest: Option<Vec2>,
    /// Σ 1/‖P‖ over the left hemisphere sector (1/m): how cluttered a side is; breaks ties.
    /// With faded sides it is filled only when the sides tie, the only time the
    /// steering reads it ([`side_crowding`]); 0 otherwise.
    pub crowding_left: f64,
    /// The same over the right hemisphere sector (1/m).
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

/// How the side clearances fade near bearing 0 and the hemisphere's edge.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SideFade {
    /// Penalty at full fade (m): d_act, so a fully faded point (clearance ≥ 0)
    /// sits at or beyond d_act, where it no longer raises the barrier.
    penalty_m: f64,
    /// 1 / sin(fade angle): the cross-side ramp, on sin(bearing).
    inv_sin_fade: f64,
    /// cos of the bearing where the rear ramp starts, and 1 / its width in cos;
    /// None for a full-circle hemisphere.
    rear: Option<(f64, f64)>,
}

impl SideFade {
    /// `fade_rad` > 0, for a hemisphere of `hemisphere_fov_rad`, activation
    /// distance `d_act_m`; None for a fade of 0 (hard sectors).
    pub fn new(fade_rad: f64, hemisphere_fov_rad: f64, d_act_m: f64) -> Option<Self> {
        if fade_rad <= 0.0 {
            return None;
        }
        let half = (hemisphere_fov_rad / 2.0).min(std::f64::consts::PI);
        let fade = fade_rad.min(half).min(std::f64::consts::FRAC_PI_2);
        let rear = (half < std::f64::consts::PI).then(|| {
            let start = (half - fade).cos();
            (start, 1.0 / (start - half.cos()).max(1e-12))
        });
        Some(Self {
            penalty_m: d_act_m,
            inv_sin_fade: 1.0 / fade.sin().max(1e-12),
            rear,
        })
    }

    /// Penalties (m) of a point with cos and sin of its bearing for the left
    /// and the right side; +inf where it does not count at all.
    #[inline]
    pub fn penalties(&self, cos_b: f64, sin_b: f64) -> (f64, f64) {
        let back = match self.rear {
            Some((start, inv)) => ((start - cos_b) * inv).max(0.0),
            None => 0.0,
        };
        let left = (-sin_b * self.inv_sin_fade).max(back);
        let right = (sin_b * self.inv_sin_fade).max(back);
        let scale = |f: f64| if f < 1.0 { f * self.penalty_m } else { f64::INFINITY };
        (scale(left), scale(right))
    }
}

/// Points per batch in the clearance passes.
const BATCH: usize = 8;

/// ‖P‖ and 1/‖P‖ of up to `BATCH` points (lanes past the chunk are 0 and +inf,
/// never read). The square root and the reciprocal are the costly part, and
/// each waits on the divider; taken a batch at a time over a fixed number of
/// independent lanes, the compiler issues them two by two. The bookkeeping
/// then runs point by point, in order. ‖P‖ as nalgebra computes it: the root
/// of the squared norm.
#[inline]
fn norms_and_reciprocals(chunk: &[Vec2]) -> ([f64; BATCH], [f64; BATCH]) {
    let mut norm2 = [0.0; BATCH];
    for (n2, p) in norm2.iter_mut().zip(chunk) {
        *n2 = p.norm_squared();
    }
    let norms = norm2.map(f64::sqrt);
    (norms, norms.map(|n| 1.0 / n))
}

/// The side penalties ([`SideFade::penalties`]) of up to `BATCH` points with
/// reciprocal norms `reciprocals`, left and right; lanes past the chunk, and
/// points at the origin, get garbage that is never read. Over a fixed number
/// of lanes, apart from the in-order bookkeeping, the compiler can take them
/// two at a time.
#[inline]
fn penalties_batch(chunk: &[Vec2], reciprocals: &[f64; BATCH], fade: &SideFade) -> ([f64; BATCH], [f64; BATCH]) {
    let (mut x, mut y) = ([0.0; BATCH], [0.0; BATCH]);
    for (k, p) in chunk.iter().enumerate() {
        (x[k], y[k]) = (p.x, p.y);
    }
    let (mut left, mut right) = ([0.0; BATCH], [0.0; BATCH]);
    for k in 0..BATCH {
        let inv = reciprocals[k];
        (left[k], right[k]) = fade.penalties(x[k] * inv, y[k] * inv);
    }
    (left, right)
}

/// Margins of the pruning in [`compute_clearances_faded`]: relative on the
/// radii, absolute on the cosines and sines of bearings. Far beyond the
/// rounding of a root or a division, so no point that can reach or tie a
/// minimum is skipped.
const PRUNE_MARGIN: f64 = 1e-9;

/// Whether x/‖P‖ ≥ `c` for a coordinate `x` of a point with squared norm
/// `n2`, without the root.
#[inline]
fn ratio_at_least(x: f64, n2: f64, c: f64) -> bool {
    if c <= 0.0 {
        x >= 0.0 || x * x <= n2 * c * c
    } else {
        x >= 0.0 && x * x >= n2 * c * c
    }
}

/// Squared radii within which a point may still change each faded minimum.
#[derive(Debug, Clone, Copy)]
struct Reach {
    min2: f64,
    front2: f64,
    left2: f64,
    right2: f64,
    /// The largest of the four.
    any2: f64,
}

impl Reach {
    /// From upper bounds of the final minima (+inf: unbounded).
    fn new(bound: &Clearances, robot_radius_m: f64) -> Self {
        let r2 = |u: f64| {
            if u.is_finite() {
                // ‖P‖ − r > u for every point beyond this (‖P‖ ≥ 0, so u + r ≥ 0).
                let reach = (u + robot_radius_m).max(0.0) * (1.0 + PRUNE_MARGIN) + f64::MIN_POSITIVE;
                reach * reach
            } else {
                f64::INFINITY
            }
        };
        let (min2, front2, left2, right2) = (
            r2(bound.d_min_m),
            r2(bound.d_front_m),
            r2(bound.d_left_m),
            r2(bound.d_right_m),
        );
        Self {
            min2,
            front2,
            left2,
            right2,
            any2: min2.max(front2).max(left2).max(right2),
        }
    }
}

/// Every clearance of a faded filter but the crowding sums, which stay 0
/// ([`side_crowding`] gives them; the steering reads them only when the sides
/// tie, [`super::doaa::sides_tie`]).
///
/// Exact, and most points cost a squared norm and a comparison or two. A
/// first pass, without roots, finds the nearest point overall, the nearest
/// in the front sector and the nearest on each side's penalty-free part (own
/// half, bearing within the hemisphere less the fade). Their exact values
/// bound the final minima from above (each is a candidate of the minimum it
/// bounds). A point is then skipped when, for each minimum it may count in
/// (by bearing, decided without roots and with [`PRUNE_MARGIN`] to spare),
/// its clearance is beyond that minimum's bound: penalised or not, it can
/// be neither a minimum nor tie one. The others are taken in beam order
/// with the same arithmetic as every point was before, so values and the
/// points that realise them are the same bit for bit.
pub fn compute_clearances_faded(points: &[Vec2], robot_radius_m: f64, front: Sector, fade: &SideFade) -> Clearances {
    let bound = seed_bounds(points, robot_radius_m, front, fade);
    faded_within(points, robot_radius_m, front, fade, &bound).0
}

/// Which points realise a step's faded minima (indices into its points):
/// overall, in front, left, right; `usize::MAX` where a minimum has none.
pub type Minimisers = [usize; 4];

/// No minimiser.
pub const NO_MINIMISERS: Minimisers = [usize::MAX; 4];

/// [`compute_clearances_faded`], the same values bit for bit, with the
/// bounds taken from `seeds` (indices into `points`; out-of-range ones are
/// ignored) instead of a first pass over every point: any point's exact
/// values bound the minima it counts in from above, and the points that
/// realised the last scan's minima are next to this scan's. Where a minimum
/// gets no bound from a seed but `seeds` names one for it, the first pass
/// runs after all. Also returns this scan's minimisers, the next scan's seeds.
pub fn compute_clearances_faded_seeded(
    points: &[Vec2],
    robot_radius_m: f64,
    front: Sector,
    fade: &SideFade,
    seeds: &Minimisers,
) -> (Clearances, Minimisers) {
    let mut bound = Clearances::OPEN;
    for &i in seeds {
        if let Some(p) = points.get(i) {
            add_faded(&mut bound, *p, robot_radius_m, front, fade);
        }
    }
    let bounds = [bound.d_min_m, bound.d_front_m, bound.d_left_m, bound.d_right_m];
    if seeds
        .iter()
        .zip(bounds)
        .any(|(&i, b)| i != usize::MAX && b == f64::INFINITY)
    {
        bound = seed_bounds(points, robot_radius_m, front, fade);
    }
    faded_within(points, robot_radius_m, front, fade, &bound)
}

/// The faded minima over `points`, given upper `bound`s of them, and the
/// indices of the points that realise them.
fn faded_within(
    points: &[Vec2],
    robot_radius_m: f64,
    front: Sector,
    fade: &SideFade,
    bound: &Clearances,
) -> (Clearances, Minimisers) {
    let reach = Reach::new(bound, robot_radius_m);
    // Bearing tests, widened by the margin: a point failing one cannot count there.
    let in_front = |p: &Vec2, n2: f64| front.full || ratio_at_least(p.x, n2, front.cos_half - PRUNE_MARGIN);
    let sin_fade = -(1.0 / fade.inv_sin_fade) - PRUNE_MARGIN;
    let in_hemisphere = |p: &Vec2, n2: f64| match fade.rear {
        Some((start, inv)) => ratio_at_least(p.x, n2, start - 1.0 / inv - PRUNE_MARGIN),
        None => true,
    };
    let mut c = Clearances::OPEN;
    let mut at = NO_MINIMISERS;
    // Indexed: an `enumerate` count is overflow-checked and a zip with a range
    // is not flattened here, each a few instructions per point.
    #[allow(clippy::needless_range_loop)]
    for i in 0..points.len() {
        let p = &points[i];
        let n2 = p.norm_squared();
        if n2 > reach.any2 {
            continue;
        }
        let keep = n2 <= reach.min2
            || (n2 <= reach.front2 && in_front(p, n2))
            || (n2 <= reach.left2 && ratio_at_least(p.y, n2, sin_fade) && in_hemisphere(p, n2))
            || (n2 <= reach.right2 && ratio_at_least(-p.y, n2, sin_fade) && in_hemisphere(p, n2));
        if keep {
            let lowered = add_faded(&mut c, *p, robot_radius_m, front, fade);
            if lowered != 0 {
                for (k, slot) in at.iter_mut().enumerate() {
                    if lowered & (1 << k) != 0 {
                        *slot = i;
                    }
                }
            }
        }
    }
    (c, at)
}

/// One point into the faded minima (not the crowding sums). Returns which it
/// lowered, as bits: 1 overall, 2 front, 4 left, 8 right ([`Minimisers`]' order).
#[inline]
fn add_faded(c: &mut Clearances, p: Vec2, robot_radius_m: f64, front: Sector, fade: &SideFade) -> u8 {
    // ‖P‖ as nalgebra computes it: the root of the squared norm.
    let norm = p.norm_squared().sqrt();
    add_faded_at(c, p, norm, norm - robot_radius_m, front, fade)
}

/// [`add_faded`] with the point's `clearance` from the body given (the
/// circle's ‖P‖ − r, or a polygon's signed distance); `norm` = ‖P‖.
#[inline]
fn add_faded_at(c: &mut Clearances, p: Vec2, norm: f64, clearance: f64, front: Sector, fade: &SideFade) -> u8 {
    let mut lowered = 0;
    if clearance < c.d_min_m {
        c.d_min_m = clearance;
        c.closest = Some(p);
        lowered |= 1;
    }
    if front.contains(p, norm) && clearance < c.d_front_m {
        c.d_front_m = clearance;
        lowered |= 2;
    }
    if norm == 0.0 {
        return lowered;
    }
    let inv = 1.0 / norm;
    let (pl, pr) = fade.penalties(p.x * inv, p.y * inv);
    if pl.is_finite() && clearance + pl < c.d_left_m {
        c.d_left_m = clearance + pl;
        c.closest_left = Some(p);
        lowered |= 4;
    }
    if pr.is_finite() && clearance + pr < c.d_right_m {
        c.d_right_m = clearance + pr;
        c.closest_right = Some(p);
        lowered |= 8;
    }
    lowered
}

/// Upper bounds of the faded minima: their exact values over a few seed
/// points (the nearest overall, in front, and on each side's penalty-free
/// part; see [`compute_clearances_faded`]). Zones are told without roots and
/// may be off at their edges, which is harmless: a seed's values are exact.
fn seed_bounds(points: &[Vec2], robot_radius_m: f64, front: Sector, fade: &SideFade) -> Clearances {
    let free = |p: &Vec2, n2: f64| match fade.rear {
        Some((start, _)) => ratio_at_least(p.x, n2, start),
        None => true,
    };
    // Nearest overall, in front, left, right: squared norm and index, in locals so
    // that the running minima stay in registers.
    let (mut n_all, mut n_front, mut n_left, mut n_right) =
        (f64::INFINITY, f64::INFINITY, f64::INFINITY, f64::INFINITY);
    let (mut i_all, mut i_front, mut i_left, mut i_right) = (usize::MAX, usize::MAX, usize::MAX, usize::MAX);
    // Indices from a range, not `enumerate` (whose count is overflow-checked).
    for (i, p) in (0..points.len()).zip(points) {
        let n2 = p.norm_squared();
        if n2 < n_all {
            (n_all, i_all) = (n2, i);
        }
        if n2 < n_front && (front.full || ratio_at_least(p.x, n2, front.cos_half)) {
            (n_front, i_front) = (n2, i);
        }
        if (n2 < n_left || n2 < n_right) && free(p, n2) {
            if p.y >= 0.0 && n2 < n_left {
                (n_left, i_left) = (n2, i);
            }
            if p.y <= 0.0 && n2 < n_right {
                (n_right, i_right) = (n2, i);
            }
        }
    }
    let seeds = [i_all, i_front, i_left, i_right];
    let mut bound = Clearances::OPEN;
    for i in seeds.into_iter().filter(|&i| i != usize::MAX) {
        add_faded(&mut bound, points[i], robot_radius_m, front, fade);
    }
    bound
}

/// Σ 1/‖P‖ over the points counting for the left and the right side (those
/// with a finite penalty, own half only): the tie-breaker of the faded
/// steering, in beam order as [`reference_clearances_faded`] sums them.
pub fn side_crowding(points: &[Vec2], fade: &SideFade) -> (f64, f64) {
    let (mut left, mut right) = (0.0, 0.0);
    for chunk in points.chunks(BATCH) {
        let (norms, reciprocals) = norms_and_reciprocals(chunk);
        let (pl, pr) = penalties_batch(chunk, &reciprocals, fade);
        for (k, p) in chunk.iter().enumerate() {
            if norms[k] == 0.0 {
                continue;
            }
            if pl[k].is_finite() {
                left += if p.y > 0.0 { reciprocals[k] } else { 0.0 };
            }
            if pr[k].is_finite() {
                right += if p.y < 0.0 { reciprocals[k] } else { 0.0 };
            }
        }
    }
    (left, right)
}

/// Computes every clearance in one pass over the points.
pub fn compute_clearances(points: &[Vec2], robot_radius_m: f64, hemisphere: Sector, front: Sector) -> Clearances {
    clearances_with(points, hemisphere, front, |_, norm| norm - robot_radius_m)
}

/// [`compute_clearances`] of a polygon body (`footprint.polygon_m`, issue
/// 26): a point's clearance is its signed distance from the padded polygon;
/// the sectors are told by its bearing from the robot's origin, as for the
/// circle.
pub fn compute_clearances_polygon(
    points: &[Vec2],
    fp: &PaddedPolygon,
    hemisphere: Sector,
    front: Sector,
) -> Clearances {
    clearances_with(points, hemisphere, front, |p, _| fp.signed_distance(p))
}

/// [`compute_clearances_faded`] of a polygon body, every point taken, with
/// the minimisers (as [`compute_clearances_faded_seeded`] returns them).
pub fn compute_clearances_faded_polygon(
    points: &[Vec2],
    fp: &PaddedPolygon,
    front: Sector,
    fade: &SideFade,
) -> (Clearances, Minimisers) {
    let mut c = Clearances::OPEN;
    let mut at = NO_MINIMISERS;
    for (i, &p) in points.iter().enumerate() {
        let norm = p.norm_squared().sqrt();
        let lowered = add_faded_at(&mut c, p, norm, fp.signed_distance(p), front, fade);
        for (k, slot) in at.iter_mut().enumerate() {
            if lowered & (1 << k) != 0 {
                *slot = i;
            }
        }
    }
    (c, at)
}

/// Every clearance in one pass, a point's clearance from the body given by
/// `clearance_of(P, ‖P‖)`.
#[inline]
fn clearances_with(
    points: &[Vec2],
    hemisphere: Sector,
    front: Sector,
    clearance_of: impl Fn(Vec2, f64) -> f64,
) -> Clearances {
    let mut c = Clearances::OPEN;
    for chunk in points.chunks(BATCH) {
        let (norms, reciprocals) = norms_and_reciprocals(chunk);
        for (k, &p) in chunk.iter().enumerate() {
            let norm = norms[k];
            let clearance = clearance_of(p, norm);
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

/// The faded clearances with the crowding sums, every point taken: the plain
/// reference [`compute_clearances_faded`] and [`side_crowding`] are compared with.
#[cfg(test)]
pub(crate) fn reference_clearances_faded(
    points: &[Vec2],
    robot_radius_m: f64,
    front: Sector,
    fade: &SideFade,
) -> Clearances {
    let mut c = Clearances::OPEN;
    for chunk in points.chunks(BATCH) {
        let (norms, reciprocals) = norms_and_reciprocals(chunk);
        for (k, p) in chunk.iter().enumerate() {
            let norm = norms[k];
            let clearance = norm - robot_radius_m;
            if clearance < c.d_min_m {
                c.d_min_m = clearance;
                c.closest = Some(*p);
            }
            if front.contains(*p, norm) && clearance < c.d_front_m {
                c.d_front_m = clearance;
            }
            if norm == 0.0 {
                continue;
            }
            let inv = reciprocals[k];
            let (pl, pr) = fade.penalties(p.x * inv, p.y * inv);
            if pl.is_finite() {
                c.crowding_left += if p.y > 0.0 { inv } else { 0.0 };
                if clearance + pl < c.d_left_m {
                    c.d_left_m = clearance + pl;
                    c.closest_left = Some(*p);
                }
            }
            if pr.is_finite() {
                c.crowding_right += if p.y < 0.0 { inv } else { 0.0 };
                if clearance + pr < c.d_right_m {
                    c.d_right_m = clearance + pr;
                    c.closest_right = Some(*p);
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
    fn a_polygon_body_measures_from_its_sides_not_its_corner_circle() {
        // The 0.6 x 0.4 m base: a point 0.35 m to the left (and 5 cm ahead) is 0.15 m from the long
        // side (the circumscribed circle, √0.13 = 0.3606 m, would say −0.0106); one
        // 0.5 m ahead is 0.2 m from the front; one 0.5 m behind, 0.2 m from the back.
        let fp = PaddedPolygon::base_0604();
        let pts = [Vec2::new(0.05, 0.35), Vec2::new(0.5, 0.0), Vec2::new(-0.5, 0.0)];
        let c = compute_clearances_polygon(&pts, &fp, Sector::new(deg(180.0)), Sector::new(deg(60.0)));
        assert!((c.d_left_m - 0.15).abs() < 1e-12, "{c:?}");
        assert!((c.d_front_m - 0.2).abs() < 1e-12, "{c:?}");
        assert!((c.d_min_m - 0.15).abs() < 1e-12, "{c:?}");
        assert_eq!(c.d_right_m, f64::INFINITY);
        assert_eq!(c.closest, Some(Vec2::new(0.05, 0.35)));
        // Faded sides: the same distances enter with the same penalties as the circle's.
        let fade = SideFade::new(deg(30.0), deg(180.0), 1.2).unwrap();
        let (f, at) = compute_clearances_faded_polygon(&pts, &fp, Sector::new(deg(60.0)), &fade);
        let reference = reference_clearances_faded(&pts, 0.0, Sector::new(deg(60.0)), &fade);
        // With r = 0 the circle's clearance is ‖P‖. Here the point ahead realises both
        // faded sides (bearing 0, no penalty) and the front: 0.5 m less the half-length.
        assert_eq!(reference.closest_left, Some(Vec2::new(0.5, 0.0)));
        assert!(
            (f.d_left_m - (reference.d_left_m - 0.3)).abs() < 1e-12,
            "{f:?} {reference:?}"
        );
        assert!(
            (f.d_right_m - (reference.d_right_m - 0.3)).abs() < 1e-12,
            "{f:?} {reference:?}"
        );
        assert!(
            (f.d_front_m - (reference.d_front_m - 0.3)).abs() < 1e-12,
            "{f:?} {reference:?}"
        );
        assert!((f.d_min_m - 0.15).abs() < 1e-12, "{f:?}");
        assert_eq!(at[0], 0);
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
    fn faded_sides_change_continuously_across_bearing_zero_and_the_rear_edge() {
        // d_act 1.2 m, fade 30°, hemisphere 180°: a point 1 m away, r = 0.
        let fade = SideFade::new(deg(30.0), deg(180.0), 1.2).unwrap();
        let front = Sector::new(deg(30.0));
        let at = |bearing_deg: f64| {
            let b = deg(bearing_deg);
            compute_clearances_faded(&[Vec2::new(b.cos(), b.sin())], 0.0, front, &fade)
        };
        // Dead ahead: the same on both sides, no penalty.
        let c = at(0.0);
        assert!((c.d_left_m - 1.0).abs() < 1e-12 && (c.d_right_m - 1.0).abs() < 1e-12);
        // 15° right: full clearance on the right, half the ramp (sin 15° / sin 30° = 0.5176) on the left.
        let c = at(-15.0);
        assert!((c.d_right_m - 1.0).abs() < 1e-12);
        let ramp = deg(15.0).sin() / deg(30.0).sin();
        assert!((c.d_left_m - (1.0 + 1.2 * ramp)).abs() < 1e-9, "{c:?}");
        // Just either side of 0: nearly equal, not one side jumping to +inf.
        let (a, b) = (at(0.01), at(-0.01));
        assert!((a.d_left_m - b.d_left_m).abs() < 1e-3 && (a.d_right_m - b.d_right_m).abs() < 1e-3);
        // 30° or more right: no longer on the left at all.
        assert_eq!(at(-30.5).d_left_m, f64::INFINITY);
        // Rear edge (90°): the ramp starts at 60°; at 75° half of it.
        let c = at(75.0);
        let half = (deg(60.0).cos() - deg(75.0).cos()) / deg(60.0).cos();
        assert!((c.d_left_m - (1.0 + 1.2 * half)).abs() < 1e-9, "{c:?}");
        assert_eq!(at(91.0).d_left_m, f64::INFINITY);
        // d_min and the front sector are not faded.
        assert!((at(-15.0).d_min_m - 1.0).abs() < 1e-12 && (at(-15.0).d_front_m - 1.0).abs() < 1e-12);
        assert_eq!(SideFade::new(0.0, deg(180.0), 1.2), None);
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

/// The fast path against its plain reference, bit for bit.
#[cfg(test)]
mod fast_path_properties {
    use super::*;
    use proptest::prelude::*;

    fn coordinate() -> impl Strategy<Value = f64> {
        prop_oneof![
            prop::sample::select(vec![0.0, -0.0, 1e-300, -1e-300, 0.2, -0.2, 1.0]),
            -6.0f64..6.0,
            -0.3f64..0.3,
        ]
    }

    fn bits(c: &Clearances) -> Vec<u64> {
        let point = |p: Option<Vec2>| p.map_or([u64::MAX; 2], |p| [p.x.to_bits(), p.y.to_bits()]);
        let mut v = vec![
            c.d_left_m.to_bits(),
            c.d_right_m.to_bits(),
            c.d_min_m.to_bits(),
            c.d_front_m.to_bits(),
            c.crowding_left.to_bits(),
            c.crowding_right.to_bits(),
        ];
        for p in [c.closest_left, c.closest_right, c.closest] {
            v.extend(point(p));
        }
        v
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(3000))]

        #[test]
        fn faded_clearances_match_their_reference(
            points in prop::collection::vec((coordinate(), coordinate()), 0..100),
            radius in prop_oneof![Just(0.0), 0.0f64..0.5],
            front_deg in prop::sample::select(vec![0.0f64, 30.0, 60.0, 360.0, 400.0]),
            fade_deg in prop::sample::select(vec![1.0f64, 30.0, 90.0, 120.0]),
            hemisphere_deg in prop::sample::select(vec![60.0f64, 180.0, 270.0, 360.0, 400.0]),
            d_act in 0.1f64..2.0,
        ) {
            let points: Vec<Vec2> = points.into_iter().map(|(x, y)| Vec2::new(x, y)).collect();
            let front = Sector::new(front_deg.to_radians());
            let fade = SideFade::new(fade_deg.to_radians(), hemisphere_deg.to_radians(), d_act).unwrap();
            let mut fast = compute_clearances_faded(&points, radius, front, &fade);
            (fast.crowding_left, fast.crowding_right) = side_crowding(&points, &fade);
            let reference = reference_clearances_faded(&points, radius, front, &fade);
            prop_assert_eq!(bits(&fast), bits(&reference));
        }

        #[test]
        fn seeded_clearances_match_their_reference_whatever_the_seeds(
            points in prop::collection::vec((coordinate(), coordinate()), 0..100),
            seeds in prop::array::uniform4(prop_oneof![Just(usize::MAX), 0usize..120]),
            radius in prop_oneof![Just(0.0), 0.0f64..0.5],
            front_deg in prop::sample::select(vec![0.0f64, 30.0, 60.0, 360.0]),
            fade_deg in prop::sample::select(vec![1.0f64, 30.0, 90.0, 120.0]),
            hemisphere_deg in prop::sample::select(vec![60.0f64, 180.0, 270.0, 360.0]),
            d_act in 0.1f64..2.0,
        ) {
            let points: Vec<Vec2> = points.into_iter().map(|(x, y)| Vec2::new(x, y)).collect();
            let front = Sector::new(front_deg.to_radians());
            let fade = SideFade::new(fade_deg.to_radians(), hemisphere_deg.to_radians(), d_act).unwrap();
            let reference = reference_clearances_faded(&points, radius, front, &fade);
            // Any seeds, then the minimisers as seeds (the next scan's case).
            let (mut fast, at) = compute_clearances_faded_seeded(&points, radius, front, &fade, &seeds);
            (fast.crowding_left, fast.crowding_right) = side_crowding(&points, &fade);
            prop_assert_eq!(bits(&fast), bits(&reference));
            let (mut again, at_again) = compute_clearances_faded_seeded(&points, radius, front, &fade, &at);
            (again.crowding_left, again.crowding_right) = side_crowding(&points, &fade);
            prop_assert_eq!(bits(&again), bits(&reference));
            prop_assert_eq!(at, at_again);
            // The minimisers are the points the minima name.
            let named = |k: usize| points.get(at[k]).copied();
            prop_assert_eq!(named(0), reference.closest);
            prop_assert_eq!(named(2), reference.closest_left);
            prop_assert_eq!(named(3), reference.closest_right);
            prop_assert_eq!(at[1] == usize::MAX, reference.d_front_m == f64::INFINITY);
        }
    }
}
