//! Inputs shared by the benchmarks: a room with people walking through it,
//! ray-cast by the simulator's LiDAR into a cycle of realistic scans.
//!
//! Why pre-generated and periodic: the benchmarks must time the pipeline,
//! not the ray cast, and a tracker must see continuous motion. Everything
//! here repeats with the period [`FRAMES`] × [`SCAN_PERIOD_S`] (the people
//! walk back and forth a whole number of times, the robot drives one whole
//! circle), so cycling through the scans never makes anything jump.
#![allow(dead_code)]

use oldbf_ros::algo::geometry::{Pose2, Vec2};
use oldbf_ros::sim::{BoxSpec, CircleSpec, Lidar, LidarSpec, MotionSpec, MovingObstacleSpec, World, WorldSpec};
use std::f64::consts::PI;

/// Scans per cycle.
pub const FRAMES: usize = 128;
/// Time between scans (s): a 10 Hz LiDAR.
pub const SCAN_PERIOD_S: f64 = 0.1;
/// The cycle's length (s).
pub const CYCLE_S: f64 = FRAMES as f64 * SCAN_PERIOD_S;
/// People walking through the room.
pub const PEOPLE: usize = 10;
/// Centre of the robot's circle (m) and its radius (m): the robot drives at
/// 2π · 0.5 / 12.8 ≈ 0.25 m/s.
pub const ROBOT_CIRCLE_CENTRE: [f64; 2] = [4.0, 3.0];
pub const ROBOT_CIRCLE_RADIUS_M: f64 = 0.5;

/// An 8 × 6 m room with two boxes and two posts, and [`PEOPLE`] people-sized
/// discs (radius 0.2-0.25 m) walking back and forth along lines across the
/// room at 0.9-2.4 m from the robot's circle centre, one or two round trips
/// per cycle (0.4-1.3 m/s).
pub fn room_with_people() -> WorldSpec {
    let c = Vec2::new(ROBOT_CIRCLE_CENTRE[0], ROBOT_CIRCLE_CENTRE[1]);
    let offsets = [0.9, -1.0, 1.2, -1.3, 1.6, -1.7, 2.0, -2.1, 2.4, -2.4];
    let moving = (0..PEOPLE)
        .map(|j| {
            let a = j as f64 * PI / PEOPLE as f64 + 0.1;
            let dir = Vec2::new(a.cos(), a.sin());
            let normal = Vec2::new(-dir.y, dir.x);
            let mid = c + normal * offsets[j];
            // Half-length: as long as the room allows (0.35 m from the walls), at most 3 m.
            let half = [3.0, 2.0 - 0.01, 1.0]
                .into_iter()
                .find(|h| {
                    [mid + dir * *h, mid - dir * *h]
                        .iter()
                        .all(|p| p.x > 0.35 && p.x < 7.65 && p.y > 0.35 && p.y < 5.65)
                })
                .unwrap_or(0.5);
            let (a_end, b_end) = (mid - dir * half, mid + dir * half);
            let trips = 1 + j % 2;
            let (w0, w1) = if j % 3 == 0 { (b_end, a_end) } else { (a_end, b_end) };
            MovingObstacleSpec {
                radius_m: 0.2 + 0.05 * (j % 2) as f64,
                motion: MotionSpec::WaypointLoop {
                    waypoints: vec![[w0.x, w0.y], [w1.x, w1.y]],
                    speed_mps: 4.0 * half * trips as f64 / CYCLE_S,
                },
                name: Some(format!("person_{j}")),
            }
        })
        .collect();
    WorldSpec {
        polygons: vec![vec![[0.0, 0.0], [8.0, 0.0], [8.0, 6.0], [0.0, 6.0]]],
        boxes: vec![
            BoxSpec {
                center: [1.2, 4.8],
                size: [0.8, 0.5],
                yaw_deg: 15.0,
            },
            BoxSpec {
                center: [6.8, 1.0],
                size: [0.6, 0.6],
                yaw_deg: 0.0,
            },
        ],
        circles: vec![
            CircleSpec {
                center: [6.5, 4.8],
                radius_m: 0.15,
            },
            CircleSpec {
                center: [1.5, 1.2],
                radius_m: 0.2,
            },
        ],
        moving,
        ..WorldSpec::default()
    }
}

/// The robot's pose at time `t_s` (s): counter-clockwise on its circle,
/// heading along it, one lap per cycle.
pub fn robot_pose(t_s: f64) -> Pose2 {
    let a = 2.0 * PI * t_s / CYCLE_S;
    let (s, co) = a.sin_cos();
    Pose2::new(
        ROBOT_CIRCLE_CENTRE[0] + ROBOT_CIRCLE_RADIUS_M * co,
        ROBOT_CIRCLE_CENTRE[1] + ROBOT_CIRCLE_RADIUS_M * s,
        a + PI / 2.0,
    )
}

/// The robot's forward speed on its circle (m/s).
pub fn robot_speed_mps() -> f64 {
    2.0 * PI * ROBOT_CIRCLE_RADIUS_M / CYCLE_S
}

/// A full-circle LiDAR of `beams` beams, 0.12-8 m, 1 cm range noise.
pub fn lidar_spec(beams: usize) -> LidarSpec {
    LidarSpec {
        beams,
        fov_deg: 360.0,
        range_min_m: 0.12,
        range_max_m: 8.0,
        noise_std_m: 0.01,
        ..LidarSpec::default()
    }
}

/// One cycle of scans of [`room_with_people`] from the circling robot.
pub struct ScanCycle {
    pub spec: LidarSpec,
    /// `FRAMES` scans, one range per beam (m).
    pub ranges: Vec<Vec<f32>>,
    /// The robot's pose at each scan (the odometry a real robot would give).
    pub poses: Vec<Pose2>,
}

impl ScanCycle {
    pub fn generate(beams: usize) -> ScanCycle {
        let mut world = World::new(&room_with_people()).expect("the benchmark world is valid");
        let spec = lidar_spec(beams);
        let mut lidar = Lidar::new(spec.clone(), 7).expect("the benchmark LiDAR is valid");
        let mut ranges = Vec::with_capacity(FRAMES);
        let mut poses = Vec::with_capacity(FRAMES);
        for k in 0..FRAMES {
            let t = k as f64 * SCAN_PERIOD_S;
            world.set_time(t);
            let pose = robot_pose(t);
            ranges.push(lidar.scan(&world, pose));
            poses.push(pose);
        }
        ScanCycle { spec, ranges, poses }
    }
}
