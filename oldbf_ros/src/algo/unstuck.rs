//! Unstuck (ALGORITHM.md §4b): getting round an obstacle when reactive
//! steering alone has stalled.
//!
//! DOAA is reactive: with the reference behind an obstacle, the tracking law
//! pulls the robot at it and the barriers push it away, and it can stand
//! there for the rest of the run (no contact, no progress). This module
//! watches progress towards the reference and, when it has stalled, replaces
//! the nominal command with one that follows a free direction:
//!
//! * **Progress** is the reference's arc length minus the robot's distance to
//!   the (governed) reference point, in m: it grows while the reference runs
//!   and while the robot closes in on it; a robot held up by an obstacle,
//!   with the governor holding the reference 2 R_c ahead, makes none.
//! * **Stalled**: the nominal asks to move, and progress has grown by less
//!   than `unstuck.progress_m` for `unstuck.stall_s`.
//! * **Free directions**: a bearing is free when the robot could travel
//!   `unstuck.look_m` along it keeping its centre r + d_safe + 5 cm from
//!   every point (each point blocks the bearings within asin(ρ/‖P‖) of its
//!   own; bins of 5°). A run of free bins is a gap at least 2 (r + d_safe)
//!   wide at that range, by construction.
//! * **Follow**: pick the free bearing nearest the reference's bearing,
//!   searching from it towards one side (the side the DOAA has committed
//!   to, else the nearer free bearing, else the right), and keep that side:
//!   the chosen bearing slides along the obstacle's boundary as the robot
//!   goes round it (the bug family's boundary following). The nominal
//!   becomes a turn towards that bearing at up to the nominal speed.
//! * **Release**: progress has grown by `unstuck.progress_m` since the
//!   stall and the reference's own bearing is free, or the reference is
//!   reached. Following for `unstuck.switch_s` without progress switches
//!   the side. With no free bearing at all (a cul-de-sac) the nominal is a
//!   turn in place, the paper's ω_0 case.
//!
//! Everything still goes through DOAA, the DTCBF and the passive checks.

use super::doaa::TurnDirection;
use super::geometry::{wrap_angle, Twist, Vec2};
use super::params::Params;
use std::f64::consts::PI;

/// Bins of the free-direction histogram over the full circle.
pub const BINS: usize = 72;
const BIN_RAD: f64 = 2.0 * PI / BINS as f64;
/// Extra clearance of a free direction beyond r + d_safe (m).
const FREE_MARGIN_M: f64 = 0.0;

/// Where the nominal command is heading: the governed reference point and
/// how far along its path it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Guidance {
    /// The reference point in the robot frame now (m).
    pub target: Vec2,
    /// The reference's arc length so far (m).
    pub along_m: f64,
}

/// Following a free direction round an obstacle.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Follow {
    side: TurnDirection,
    /// Progress when following began (m).
    entry_progress_m: f64,
    /// When this side was chosen (s).
    since_s: f64,
}

/// What the unstuck logic decided this step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnstuckDecision {
    /// The nominal to use instead of the given one, while following.
    pub nominal: Option<Twist>,
    /// The side being followed.
    pub side: Option<TurnDirection>,
}

/// The progress monitor and the follow state.
#[derive(Debug, Clone, Default)]
pub struct Unstuck {
    /// Best progress so far (m), and when it last grew by `progress_m` (s).
    best_progress_m: Option<f64>,
    last_gain_s: Option<f64>,
    follow: Option<Follow>,
    /// Free bins of the last step the histogram was built.
    free: Vec<bool>,
}

impl Unstuck {
    pub fn reset(&mut self) {
        self.best_progress_m = None;
        self.last_gain_s = None;
        self.follow = None;
    }

    /// Whether the robot is following a free direction round an obstacle.
    pub fn following(&self) -> Option<TurnDirection> {
        self.follow.map(|f| f.side)
    }

    /// One step at `now_s` (s): `guidance` (None: nothing to make progress
    /// towards, nothing to do), the nominal command, the points (robot frame,
    /// m) and the side the DOAA has committed to, if any.
    pub fn step(
        &mut self,
        now_s: f64,
        guidance: Option<Guidance>,
        nominal: Twist,
        points: &[Vec2],
        committed: Option<TurnDirection>,
        p: &Params,
    ) -> UnstuckDecision {
        let none = UnstuckDecision {
            nominal: None,
            side: None,
        };
        let Some(g) = guidance.filter(|g| g.target.x.is_finite() && g.target.y.is_finite() && g.along_m.is_finite()) else {
            self.reset();
            return none;
        };
        let u = &p.unstuck;
        let dist = g.target.norm();
        let progress = g.along_m - dist;
        let gained = match (self.best_progress_m, self.last_gain_s) {
            (Some(best), Some(t)) => progress >= best + u.progress_m || now_s < t, // or the clock went back
            _ => true,
        };
        if gained {
            self.best_progress_m = Some(self.best_progress_m.map_or(progress, |b| b.max(progress)));
            self.last_gain_s = Some(now_s);
        }
        let last_gain = self.last_gain_s.unwrap_or(now_s);
        let arrived = dist <= p.tracking.capture_radius_m;
        if let Some(f) = self.follow {
            let gained = progress >= f.entry_progress_m + u.progress_m;
            self.histogram(points, p);
            let target_free = self.free[bin_of(bearing(g.target))];
            if arrived || (gained && target_free) {
                self.follow = None;
                self.last_gain_s = Some(now_s);
                self.best_progress_m = Some(progress);
                return none;
            }
            if now_s - f.since_s >= u.switch_s && !gained {
                self.follow = Some(Follow {
                    side: opposite(f.side),
                    entry_progress_m: progress,
                    since_s: now_s,
                });
            }
        } else {
            let wants_to_move = nominal.v_mps > 0.0 || nominal.omega_radps != 0.0;
            if !u.enabled || arrived || !wants_to_move || now_s - last_gain < u.stall_s {
                return none;
            }
            self.histogram(points, p);
            let side = committed.unwrap_or_else(|| self.nearer_side(bearing(g.target)));
            self.follow = Some(Follow {
                side,
                entry_progress_m: progress,
                since_s: now_s,
            });
            log::debug!("t {now_s:.1}: no progress for {:.1} s: following the {side:?} side", now_s - last_gain);
        }
        let f = self.follow.expect("following");
        let target = bearing(g.target);
        let nominal = match self.first_free(target, f.side) {
            Some(b) => {
                let v = p.control.v_nom_mps * b.cos().max(0.0).powi(2);
                let w = (p.tracking.k_bearing_per_s.max(1.0) * b).clamp(-p.control.omega_max_radps, p.control.omega_max_radps);
                Twist::new(v, w)
            }
            // A cul-de-sac: turn in place, the way of the side followed.
            None => Twist::new(0.0, f.side.sign() * p.doaa.omega_0_radps),
        };
        log::trace!(
            "t {now_s:.1}: following {:?}: target bearing {:.2} rad, nominal {nominal:?}",
            f.side,
            target
        );
        UnstuckDecision {
            nominal: Some(nominal),
            side: Some(f.side),
        }
    }

    /// Marks the free bins for the points (robot frame).
    fn histogram(&mut self, points: &[Vec2], p: &Params) {
        self.free.clear();
        self.free.resize(BINS, true);
        let rho = p.robot_radius_m() + p.barrier.d_safe_m + FREE_MARGIN_M;
        let look = p.unstuck.look_m + rho;
        for q in points {
            let d = q.norm();
            if d > look {
                continue;
            }
            let half = if d <= rho { PI / 2.0 } else { (rho / d).asin() };
            let centre = bearing(*q);
            let lo = ((centre - half) / BIN_RAD).floor() as i64;
            let hi = ((centre + half) / BIN_RAD).ceil() as i64;
            for k in lo..=hi {
                // Bin k covers [k, k + 1) · BIN_RAD; mark it if it overlaps the blocked arc.
                let (a, b) = (k as f64 * BIN_RAD, (k + 1) as f64 * BIN_RAD);
                if b > centre - half && a < centre + half {
                    self.free[k.rem_euclid(BINS as i64) as usize] = false;
                }
            }
        }
    }

    /// The side with the free bearing nearer to `target` (rad); right on a tie.
    fn nearer_side(&self, target: f64) -> TurnDirection {
        let steps = |dir: f64| (0..BINS).find(|&k| self.free[bin_of(target + dir * k as f64 * BIN_RAD)]);
        match (steps(1.0), steps(-1.0)) {
            (Some(l), Some(r)) if l < r => TurnDirection::Left,
            (Some(_), None) => TurnDirection::Left,
            _ => TurnDirection::Right,
        }
    }

    /// The first free bearing from `target` (rad) turning towards `side`, as a
    /// bearing in (−π, π] (the centre of its bin); None when nothing is free.
    fn first_free(&self, target: f64, side: TurnDirection) -> Option<f64> {
        (0..BINS).map(|k| target + side.sign() * k as f64 * BIN_RAD).find_map(|b| {
            let k = bin_of(b);
            self.free[k].then(|| wrap_angle((k as f64 + 0.5) * BIN_RAD))
        })
    }
}

fn bearing(v: Vec2) -> f64 {
    v.y.atan2(v.x)
}

fn bin_of(bearing_rad: f64) -> usize {
    ((bearing_rad.rem_euclid(2.0 * PI) / BIN_RAD) as usize).min(BINS - 1)
}

fn opposite(side: TurnDirection) -> TurnDirection {
    match side {
        TurnDirection::Left => TurnDirection::Right,
        TurnDirection::Right => TurnDirection::Left,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> Params {
        Params::default() // r = 0.178, d_safe = 0.2: ρ = 0.428 m; stall 6 s, progress 0.15 m
    }

    /// A wall of points across x = `x` from y = `y0` to `y1`, 2 cm apart.
    fn wall(x: f64, y0: f64, y1: f64) -> Vec<Vec2> {
        let n = ((y1 - y0) / 0.02) as usize;
        (0..=n).map(|i| Vec2::new(x, y0 + 0.02 * i as f64)).collect()
    }

    #[test]
    fn a_post_blocks_the_bearings_within_asin_rho_over_d() {
        let p = params();
        let mut u = Unstuck::default();
        // A point 1 m ahead blocks asin(0.428) = 25.3° either side: bins 0..5 and 67..71.
        u.histogram(&[Vec2::new(1.0, 0.0)], &p);
        let blocked: Vec<usize> = (0..BINS).filter(|&k| !u.free[k]).collect();
        assert_eq!(blocked, [0, 1, 2, 3, 4, 5, 66, 67, 68, 69, 70, 71]);
        // Beyond look_m + ρ it blocks nothing.
        u.histogram(&[Vec2::new(3.0, 0.0)], &p);
        assert!(u.free.iter().all(|&f| f));
    }

    #[test]
    fn no_progress_for_the_stall_time_starts_following_and_progress_ends_it() {
        let p = params();
        let mut u = Unstuck::default();
        // A wall 0.8 m ahead from y = −0.6 to 2: the reference 1.5 m ahead, behind it.
        let pts = wall(0.8, -0.6, 2.0);
        let g = Guidance {
            target: Vec2::new(1.5, 0.0),
            along_m: 3.0,
        };
        let nominal = Twist::new(0.15, 0.0);
        for k in 0..60 {
            let d = u.step(k as f64 * 0.1, Some(g), nominal, &pts, None, &p);
            assert_eq!(d.nominal, None, "no stall before 6 s");
        }
        let d = u.step(6.0, Some(g), nominal, &pts, None, &p);
        // The wall ends 0.6 m to the right: the free bearings are to the right.
        assert_eq!(d.side, Some(TurnDirection::Right));
        let cmd = d.nominal.unwrap();
        assert!(cmd.omega_radps < 0.0, "{cmd:?}");
        // The chosen bearing clears the wall's end by ρ: atan(−0.6/0.8) − asin(0.428/1.0) ≈ −62°.
        let b = cmd.omega_radps / p.tracking.k_bearing_per_s.max(1.0);
        assert!(b <= -0.3 || cmd.omega_radps == -0.3, "{cmd:?}");
        // Progress (the reference moved on 0.2 m and its bearing is free): released.
        let g2 = Guidance {
            target: Vec2::new(1.2, -1.2),
            along_m: 3.4,
        };
        let d = u.step(8.0, Some(g2), nominal, &[], None, &p);
        assert_eq!((d.nominal, u.following()), (None, None));
    }

    #[test]
    fn a_committed_side_is_kept_and_a_cul_de_sac_turns_in_place() {
        let p = params();
        let mut u = Unstuck::default();
        let g = Guidance {
            target: Vec2::new(1.5, 0.0),
            along_m: 3.0,
        };
        // Points all round at 0.5 m: nothing free.
        let ring: Vec<Vec2> = (0..72)
            .map(|k| {
                let a = k as f64 * BIN_RAD;
                Vec2::new(0.5 * a.cos(), 0.5 * a.sin())
            })
            .collect();
        u.step(0.0, Some(g), Twist::new(0.15, 0.0), &ring, None, &p);
        let d = u.step(7.0, Some(g), Twist::new(0.15, 0.0), &ring, Some(TurnDirection::Left), &p);
        assert_eq!(d.side, Some(TurnDirection::Left));
        assert_eq!(d.nominal, Some(Twist::new(0.0, p.doaa.omega_0_radps)));
        // No guidance: nothing to do, and the state is dropped.
        let d = u.step(7.1, None, Twist::new(0.15, 0.0), &ring, None, &p);
        assert_eq!((d.nominal, u.following()), (None, None));
    }

    #[test]
    fn following_without_progress_switches_sides() {
        let mut p = params();
        p.unstuck.switch_s = 10.0;
        let mut u = Unstuck::default();
        let g = Guidance {
            target: Vec2::new(1.5, 0.0),
            along_m: 3.0,
        };
        let pts = wall(0.8, -0.6, 2.0);
        u.step(0.0, Some(g), Twist::new(0.15, 0.0), &pts, None, &p);
        assert_eq!(u.step(6.0, Some(g), Twist::new(0.15, 0.0), &pts, None, &p).side, Some(TurnDirection::Right));
        assert_eq!(u.step(15.9, Some(g), Twist::new(0.15, 0.0), &pts, None, &p).side, Some(TurnDirection::Right));
        assert_eq!(u.step(16.0, Some(g), Twist::new(0.15, 0.0), &pts, None, &p).side, Some(TurnDirection::Left));
    }
}
