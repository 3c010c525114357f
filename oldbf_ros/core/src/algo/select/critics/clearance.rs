//! Room to the surroundings along the horizon (ALGORITHM.md §5c): the DTCBF
//! condition only looks one step ahead and, with the paper's one-step model,
//! not at the turn at all; this critic follows the candidate held for
//! `select.horizon_s` along its arc and counts the room it gives up within
//! `select.clearance_band_m` beyond d_safe. With the shortfall
//! s(c) = ((band − c)/band)² for a clearance c beyond d_safe (0 with
//! c ≥ band, 1 at d_safe, more inside it, at most 4), its cost is
//! s(least c on the way) − s(c now), when positive: only getting nearer
//! costs, so standing still is never the cheapest way to keep room, and
//! driving along a wall at the same distance costs nothing.
//!
//! With a polygon body the clearance is its signed distance, the polygon
//! placed at each path sample with the heading the arc has there.

use super::{Look, PATH_SAMPLES};
use crate::algo::body::{polygon_clearance_after, polygon_clearance_below};
use crate::algo::footprint::PaddedPolygon;
use crate::algo::geometry::{min_distance_squared, Vec2};
use crate::algo::params::Params;

/// The largest cost (a path deep inside d_safe).
const MAX_COST: f64 = 4.0;

/// The points any candidate's horizon can come near this step.
#[derive(Debug, Clone, Default)]
pub struct Clearance {
    near: Vec<Vec2>,
    /// The polygon body, if the robot has one.
    polygon: Option<PaddedPolygon>,
    /// With a polygon: its least signed distance to the near points now (m).
    polygon_now_m: f64,
}

impl Clearance {
    /// Room for `points` points without reallocating.
    pub fn with_capacity(points: usize) -> Self {
        Self {
            near: Vec::with_capacity(points),
            polygon: None,
            polygon_now_m: f64::INFINITY,
        }
    }

    /// Keeps the points of `points` (robot frame, m) within reach of a
    /// horizon at the box's top speed, nearest first: the only ones that
    /// can count.
    /// `polygon` is the body's footprint if it is one (kept; copied only
    /// when it changes).
    pub fn prepare(&mut self, points: &[Vec2], polygon: Option<&PaddedPolygon>, p: &Params) {
        if self.polygon.as_ref() != polygon {
            self.polygon = polygon.cloned();
        }
        let speed = p.control.v_max_mps.max(p.control.v_reverse_max_mps);
        let reach = p.robot_radius_m() + p.barrier.d_safe_m + p.select.clearance_band_m + speed * p.select.horizon_s;
        let reach2 = reach * reach;
        self.near.clear();
        self.near.extend(points.iter().filter(|q| q.norm_squared() <= reach2));
        self.near
            .sort_unstable_by(|a, b| a.norm_squared().total_cmp(&b.norm_squared()));
        if let Some(fp) = &self.polygon {
            self.polygon_now_m = polygon_clearance_after(fp, &self.near, Vec2::zeros(), (1.0, 0.0));
        }
    }

    /// The points kept by [`Self::prepare`], nearest first.
    pub fn near(&self) -> &[Vec2] {
        &self.near
    }

    /// The unweighted cost of the candidate `look` (0..4).
    pub fn cost(&self, look: &Look, p: &Params) -> f64 {
        let band = p.select.clearance_band_m;
        if let Some(fp) = &self.polygon {
            return self.polygon_cost(fp, look, p);
        }
        let required = p.robot_radius_m() + p.barrier.d_safe_m;
        // Only points within the band of the path count, and the path stays
        // within |v|·horizon of the robot: the nearest points, a prefix.
        let reach = required + band + look.cmd.v_mps.abs() * p.select.horizon_s;
        let n = self.near.partition_point(|q| q.norm_squared() <= reach * reach);
        let near = &self.near[..n];
        if near.is_empty() {
            return 0.0;
        }
        let far2 = (required + band).powi(2);
        let least2 = look
            .path
            .iter()
            .map(|&at| min_distance_squared(near, at))
            .fold(f64::INFINITY, f64::min);
        if least2 >= far2 {
            return 0.0;
        }
        // The nearest point now is the first (sorted by distance).
        let now = near[0].norm() - required;
        (shortfall(least2.sqrt() - required, band) - shortfall(now, band)).max(0.0)
    }

    /// [`Self::cost`] of a polygon body: the least signed distance over the
    /// path samples, the polygon turned by ω t at each.
    fn polygon_cost(&self, fp: &PaddedPolygon, look: &Look, p: &Params) -> f64 {
        let band = p.select.clearance_band_m;
        let d_safe = p.barrier.d_safe_m;
        let reach = fp.circumscribed_radius_m() + d_safe + band + look.cmd.v_mps.abs() * p.select.horizon_s;
        let n = self.near.partition_point(|q| q.norm_squared() <= reach * reach);
        let near = &self.near[..n];
        if near.is_empty() {
            return 0.0;
        }
        // Only clearances below d_safe + band cost, and only the least along the
        // path counts: each sample is measured below the least so far.
        let mut least = d_safe + band;
        for (k, &at) in look.path.iter().enumerate() {
            let t = p.select.horizon_s * (k + 1) as f64 / PATH_SAMPLES as f64;
            let (s, c) = (look.cmd.omega_radps * t).sin_cos();
            least = polygon_clearance_below(fp, near, at, (c, s), least);
        }
        (shortfall(least - d_safe, band) - shortfall(self.polygon_now_m - d_safe, band)).max(0.0)
    }
}

/// The shortfall s(c) of a clearance `c` beyond d_safe within `band` (0..4).
fn shortfall(c: f64, band: f64) -> f64 {
    (((band - c.min(band)) / band).powi(2)).min(MAX_COST)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::geometry::Twist;

    impl Clearance {
        fn cost_of(&self, cmd: Twist, p: &Params) -> f64 {
            self.cost(&Look::of(cmd, p), p)
        }
    }

    #[test]
    fn a_polygon_body_pays_for_its_corners_not_its_corner_circle() {
        // The 0.6 x 0.4 m base beside a wall 0.35 m to its left (0.15 m from the
        // long side: d_safe 0.1, so 0.05 m into the 0.3 m band). Points along the
        // wall every 5 cm from 2 m behind to 4 m ahead.
        let mut p = Params::default();
        p.barrier.d_safe_m = 0.1;
        p.footprint.polygon_m = vec![[0.3, 0.2], [-0.3, 0.2], [-0.3, -0.2], [0.3, -0.2]];
        let fp = p.footprint.polygon().unwrap().unwrap();
        let wall: Vec<Vec2> = (-40..=80).map(|k| Vec2::new(0.05 * k as f64, 0.35)).collect();
        let mut c = Clearance::default();
        c.prepare(&wall, Some(&fp), &p);
        // Along the wall at any speed: the same distance all the way, no cost. (The
        // circumscribed circle, 0.3606 m, is already inside the wall.)
        assert_eq!(c.cost_of(Twist::ZERO, &p), 0.0);
        assert_eq!(c.cost_of(Twist::new(0.2, 0.0), &p), 0.0);
        // Turning in place is no longer free: by 0.45 rad over the 1.5 s horizon
        // either way, a left corner swings towards the wall (turning right, the
        // rear-left one reaches (−0.183, 0.311)); the nearest wall sample, (−0.2,
        // 0.35), is then √(0.017² + 0.039²) = 0.04287 m from it, 0.057 m inside
        // d_safe: s = ((0.3 + 0.0571)/0.3)² against ((0.3 − 0.05)/0.3)² now.
        let least: f64 = 0.042_874_630_655;
        let want = ((0.3 - (least - 0.1)) / 0.3).powi(2) - (0.25f64 / 0.3).powi(2);
        let right = c.cost_of(Twist::new(0.0, -0.3), &p);
        let left = c.cost_of(Twist::new(0.0, 0.3), &p);
        assert!(
            (right - want).abs() < 1e-9 && (left - want).abs() < 1e-9,
            "{right} {left} {want}"
        );
        // The circle of the same wall distance turns for free.
        let mut circle = Clearance::default();
        let round = Params::default();
        let wall_r: Vec<Vec2> = wall
            .iter()
            .map(|q| Vec2::new(q.x, round.robot_radius_m() + 0.15))
            .collect();
        circle.prepare(&wall_r, None, &round);
        assert_eq!(circle.cost_of(Twist::new(0.0, -0.3), &round), 0.0);
    }

    #[test]
    fn only_room_given_up_within_the_band_costs() {
        // r + d_safe = 0.378 m, band 0.3 m, horizon 1.5 s. A point 1 m ahead.
        let p = Params::default();
        let mut c = Clearance::default();
        c.prepare(&[Vec2::new(1.0, 0.0)], None, &p);
        // Standing: 1 − 0.378 = 0.622 m of room, beyond the band.
        assert_eq!(c.cost_of(Twist::ZERO, &p), 0.0);
        // 0.1 m/s for 1.5 s: ends 0.85 m from it, 0.472 m of room: still beyond.
        assert_eq!(c.cost_of(Twist::new(0.1, 0.0), &p), 0.0);
        // 0.2 m/s straight at it: ends 0.7 m away, room 0.322 m: nothing yet...
        assert_eq!(c.cost_of(Twist::new(0.2, 0.0), &p), 0.0);
        // ...with the point at 0.8 m: room 0.422 m now, 0.122 m at the end,
        // ((0.3 − 0.122)/0.3)², nothing given up now.
        c.prepare(&[Vec2::new(0.8, 0.0)], None, &p);
        let want = ((0.3f64 - 0.122) / 0.3).powi(2);
        assert!((c.cost_of(Twist::new(0.2, 0.0), &p) - want).abs() < 1e-9);
        // Turning away keeps more room than driving straight at it.
        assert!(c.cost_of(Twist::new(0.2, 0.3), &p) < c.cost_of(Twist::new(0.2, 0.0), &p));
        // Already 0.1 m inside the band (0.578 m away): standing costs nothing, nor does
        // backing off; 0.1 m/s on for 1.5 s ends 0.428 m away, room 0.05 m:
        // ((0.3 − 0.05)/0.3)² − ((0.3 − 0.2)/0.3)².
        c.prepare(&[Vec2::new(0.578, 0.0)], None, &p);
        assert_eq!(c.cost_of(Twist::ZERO, &p), 0.0);
        assert_eq!(c.cost_of(Twist::new(-0.1, 0.0), &p), 0.0);
        let want = (0.25f64 / 0.3).powi(2) - (0.1f64 / 0.3).powi(2);
        assert!((c.cost_of(Twist::new(0.1, 0.0), &p) - want).abs() < 1e-9);
    }
}
