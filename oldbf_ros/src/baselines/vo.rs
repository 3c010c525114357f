//! The velocity-obstacle baseline (ALGORITHM.md §8, the paper's contribution
//! 2): ORCA from the `dodgy_2d` crate (a port of RVO2) on what the robot
//! perceives, turned into a unicycle command.
//!
//! Everything is in the robot frame at the scan (x ahead, y left):
//! * the robot is an agent at the origin moving at (v_now, 0), of radius
//!   r + d_safe (the same margin the OLDBF and DCBF filters keep), taking
//!   full responsibility for avoidance (obstacles do not reciprocate);
//! * each moving track (obstacle tracker, §6) is an agent with its estimated
//!   velocity and fitted radius;
//! * every other cluster of scan points is static outline: an open polyline
//!   through its points (simplified to `vertex_spacing_m`), solid on the side
//!   away from the robot; a single-point cluster is a static agent.
//!
//! The preferred velocity is the nominal command as a planar velocity: speed
//! v_nom along the heading the nominal ω would reach in 1/k s (k =
//! `heading_gain_per_s`). ORCA's answer u is mapped back by heading towards
//! it: ω = k·∠u, v = ‖u‖·cos∠u (so v ≥ 0 unless reversing is allowed); when
//! ORCA leaves the preferred velocity unchanged, the nominal command passes
//! through exactly.

use crate::algo::clusters::Cluster;
use crate::algo::dtcbf::InputBox;
use crate::algo::geometry::{wrap_angle, Twist, Vec2};
use crate::algo::obstacle_tracker::ObstacleTracker;
use crate::algo::params::Params;
use dodgy_2d::{Agent, AvoidanceOptions, Obstacle};
use std::borrow::Cow;

/// What one VO step decided.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VoOutcome {
    /// The command to send (m/s, rad/s).
    pub cmd: Twist,
    /// Moving agents and static outlines ORCA was given.
    pub agents: usize,
    pub outlines: usize,
    /// Whether ORCA changed the preferred velocity.
    pub changed: bool,
}

/// What VO sees of the scene, robot frame.
pub struct VoScene<'a> {
    /// Scan points (m).
    pub points: &'a [Vec2],
    /// Their clusters (indices into `points`).
    pub clusters: &'a [Cluster],
    /// The tracker, for moving tracks and which cluster belongs to which.
    pub tracker: &'a ObstacleTracker,
    /// The robot's current forward speed (m/s).
    pub v_now_mps: f64,
}

fn glam(v: Vec2) -> dodgy_2d::Vec2 {
    dodgy_2d::Vec2::new(v.x as f32, v.y as f32)
}

/// One ORCA step for the unicycle.
pub fn vo_command(scene: &VoScene<'_>, nominal: Twist, p: &Params) -> VoOutcome {
    let bx = InputBox::from_params(p);
    let nominal = bx.clamp(nominal);
    let q = &p.baselines.vo;
    let margin = p.robot_radius_m() + p.barrier.d_safe_m;
    let robot = Agent {
        position: dodgy_2d::Vec2::ZERO,
        velocity: dodgy_2d::Vec2::new(scene.v_now_mps as f32, 0.0),
        radius: margin as f32,
        avoidance_responsibility: 1.0,
    };

    let mut agents: Vec<Cow<'_, Agent>> = Vec::new();
    let mut outlines: Vec<Cow<'_, Obstacle>> = Vec::new();
    let n = scene.points.len();
    for (ci, c) in scene.clusters.iter().enumerate() {
        let track = scene
            .tracker
            .cluster_track()
            .get(ci)
            .copied()
            .flatten()
            .map(|ti| scene.tracker.tracks()[ti])
            .filter(|t| t.is_moving(&p.obstacles));
        if let Some(t) = track {
            let (pos, vel) = scene.tracker.in_robot_frame(&t);
            agents.push(Cow::Owned(Agent {
                position: glam(pos),
                velocity: glam(vel),
                radius: t.radius_m as f32,
                avoidance_responsibility: 0.0,
            }));
            continue;
        }
        // Static outline, clockwise seen from the robot (ORCA's solid side is
        // the left of each edge): the reverse of beam order.
        let mut vertices: Vec<dodgy_2d::Vec2> = Vec::new();
        let idx: Vec<usize> = c.indices(n).collect();
        for &i in idx.iter().rev() {
            let v = glam(scene.points[i]);
            let far_enough = vertices
                .last()
                .is_none_or(|last| last.distance(v) >= q.vertex_spacing_m as f32);
            if far_enough {
                vertices.push(v);
            }
        }
        if vertices.len() >= 2 {
            outlines.push(Cow::Owned(Obstacle::Open { vertices }));
        } else {
            agents.push(Cow::Owned(Agent {
                position: vertices[0],
                velocity: dodgy_2d::Vec2::ZERO,
                radius: 0.0,
                avoidance_responsibility: 0.0,
            }));
        }
    }

    let k = q.heading_gain_per_s;
    let phi_pref = nominal.omega_radps / k;
    let preferred = dodgy_2d::Vec2::new(
        (nominal.v_mps * phi_pref.cos()) as f32,
        (nominal.v_mps * phi_pref.sin()) as f32,
    );
    let options = AvoidanceOptions {
        obstacle_margin: margin as f32,
        time_horizon: q.time_horizon_s as f32,
        obstacle_time_horizon: q.static_time_horizon_s as f32,
    };
    let max_speed = bx.v_hi.max(-bx.v_lo) as f32;
    let dt = p.control.dt_s() as f32;
    let u = robot.compute_avoiding_velocity(&agents, &outlines, preferred, max_speed, dt, &options);
    let changed = u.distance(preferred) > 1e-6;
    let cmd = if !changed {
        nominal
    } else if !u.is_finite() {
        Twist::ZERO
    } else {
        heading_towards(Vec2::new(u.x as f64, u.y as f64), k, &bx)
    };
    VoOutcome {
        cmd: bx.clamp(cmd),
        agents: agents.len(),
        outlines: outlines.len(),
        changed,
    }
}

/// The unicycle command that heads towards the planar velocity `u` (robot
/// frame, m/s): turn at k·∠u (or towards −u when backing up) and move at the
/// component of u along the heading.
fn heading_towards(u: Vec2, k: f64, bx: &InputBox) -> Twist {
    if u.norm() < 1e-9 {
        return Twist::ZERO;
    }
    let phi = u.y.atan2(u.x);
    let v = u.norm() * phi.cos();
    let reversing = v < 0.0 && bx.v_lo < 0.0;
    let turn = if reversing {
        wrap_angle(phi - std::f64::consts::PI)
    } else {
        phi
    };
    Twist::new(v, k * turn)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene<'a>(points: &'a [Vec2], clusters: &'a [Cluster], tracker: &'a ObstacleTracker) -> VoScene<'a> {
        VoScene {
            points,
            clusters,
            tracker,
            v_now_mps: 0.15,
        }
    }

    fn one_cluster(n: usize) -> Vec<Cluster> {
        let pts_centroid = Vec2::zeros();
        vec![Cluster {
            start: 0,
            end: n,
            len: n,
            centroid: pts_centroid,
            radius_m: 0.0,
            centre: pts_centroid,
            partial: false,
        }]
    }

    #[test]
    fn free_space_passes_the_nominal_command_exactly() {
        let tr = ObstacleTracker::default();
        let out = vo_command(&scene(&[], &[], &tr), Twist::new(0.15, 0.1), &Params::default());
        assert_eq!(out.cmd, Twist::new(0.15, 0.1));
        assert!(!out.changed);
    }

    #[test]
    fn a_wall_ahead_within_the_horizon_slows_the_robot() {
        // A wall 0.6 m ahead, from y = −1 to 1 in beam (counter-clockwise) order.
        // With margin r + d_safe = 0.378 m and a 1 s horizon, ORCA allows at most
        // (0.6 − 0.378)/1 = 0.222 m/s towards it; the nominal 0.22 is just inside,
        // so take it to 0.5 m: at most 0.122 m/s.
        let pts: Vec<Vec2> = (0..=40).map(|i| Vec2::new(0.5, -1.0 + 0.05 * i as f64)).collect();
        let cl = one_cluster(pts.len());
        let tr = ObstacleTracker::default();
        let out = vo_command(&scene(&pts, &cl, &tr), Twist::new(0.22, 0.0), &Params::default());
        assert!(out.changed, "{out:?}");
        assert_eq!(out.outlines, 1);
        assert!((out.cmd.v_mps - 0.122).abs() < 0.01, "{out:?}");
        assert!(out.cmd.omega_radps.abs() < 1e-3, "{out:?}");
    }

    #[test]
    fn heading_towards_maps_planar_velocities() {
        let mut p = Params::default();
        p.control.allow_reverse = false;
        let bx = InputBox::from_params(&p);
        let t = heading_towards(Vec2::new(0.1, 0.1), 2.0, &bx);
        assert!((t.v_mps - 0.1).abs() < 1e-12);
        assert!((t.omega_radps - 2.0 * std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        // Behind the robot, no reversing: v < 0 is clamped later; the turn is towards u.
        let t = heading_towards(Vec2::new(-0.1, 0.0001), 2.0, &bx);
        assert!(t.v_mps < 0.0 && t.omega_radps > 6.0);
        // With reversing the robot backs towards u, turning its rear to face it.
        p.control.allow_reverse = true;
        let t = heading_towards(Vec2::new(-0.1, 0.0001), 2.0, &InputBox::from_params(&p));
        assert!((t.v_mps + 0.1).abs() < 1e-6 && t.omega_radps.abs() < 1e-2, "{t:?}");
    }
}
