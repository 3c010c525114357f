//! Moving-obstacle tracking against the simulator's ground truth (issue 5):
//! a mover's velocity is estimated within 10% after 1 s; the tracks of the
//! shipped crossing scenario never swap identities; a static wall never
//! yields a moving track. The robot is driven by the filter as in the
//! closed-loop runner; the simulator's pose stands in for odometry, so tracks
//! live in the world frame.

mod common;

use oldbf_ros::algo::{LaserScan, SafetyPipeline, ScanHeader, Twist, Vec2};
use oldbf_ros::sim::fleet::Fleet;
use oldbf_ros::sim::scenario::Scenario;
use std::collections::HashMap;

/// Runs `scenario` for `seconds`, calling `check(t, fleet, pipeline)` after every control step.
fn drive(s: &Scenario, seconds: f64, nominal: Twist, mut check: impl FnMut(f64, &Fleet, &SafetyPipeline)) {
    let mut fleet = Fleet::new(s, 1).unwrap();
    let mut pipe = SafetyPipeline::new(s.params.clone());
    let lidar = fleet.lidar_spec().clone();
    let dt = s.params.control.dt_s();
    let mut ranges = Vec::new();
    for k in 0..(seconds / dt).round() as usize {
        let t = k as f64 * dt;
        fleet.scan(0, &mut ranges);
        let scan = LaserScan {
            header: ScanHeader {
                stamp_s: t,
                angle_min_rad: lidar.angle_min_rad(),
                angle_increment_rad: lidar.angle_increment_rad(),
                range_min_m: lidar.range_min_m as f32,
                range_max_m: lidar.range_max_m as f32,
            },
            ranges_m: &ranges,
            intensities: &[],
        };
        let pose = fleet.agents()[0].robot.pose;
        let rec = pipe.step_with_pose(&scan, t, nominal, fleet.agents()[0].robot.twist.v_mps, Some(pose));
        fleet.set_cmd(0, rec.cmd);
        for _ in 0..10 {
            fleet.step(dt / 10.0);
        }
        check(t, &fleet, &pipe);
    }
}

const ONE_MOVER: &str = "
name: one_mover
duration_s: 10
robot: {preset: turtlebot3_burger}
start: {x_m: 0, y_m: 0, theta_deg: 0}
lidar: {beams: 360, noise_std_m: 0.01}
nominal: {kind: constant, v_mps: 0.0, omega_radps: 0.0}
world:
  moving:
    - {radius_m: 0.15, motion: {kind: constant_velocity, start: [2.0, -1.0], velocity_mps: [0.05, 0.2]}}
";

#[test]
fn a_mover_is_tracked_within_ten_percent_after_one_second() {
    let s = Scenario::from_str(ONE_MOVER, "one_mover.yaml", None).unwrap();
    let truth = Vec2::new(0.05, 0.2);
    let mut estimate = None;
    drive(&s, 1.05, Twist::ZERO, |t, fleet, pipe| {
        if (t - 1.0).abs() < 1e-9 {
            let mover = fleet.world().moving_circles().next().unwrap().center;
            let track = pipe
                .tracker()
                .tracks()
                .iter()
                .min_by(|a, b| (a.position() - mover).norm().total_cmp(&(b.position() - mover).norm()));
            estimate = track.map(|tr| (tr.velocity(), (tr.position() - mover).norm()));
        }
    });
    let (v, dist) = estimate.expect("a track after 1 s");
    let err = (v - truth).norm() / truth.norm();
    println!(
        "after 1 s: velocity {v:?} (truth {truth:?}), {:.1}% off, track {dist:.3} m from the mover",
        100.0 * err
    );
    assert!(dist < 0.2, "track {dist} m from the mover");
    assert!(err < 0.1, "velocity {v:?} vs {truth:?}: {:.1}% off", 100.0 * err);
}

#[test]
fn tracks_in_the_crossing_scenario_do_not_swap() {
    let s = common::scenario("crossing");
    // track id -> the mover (index) it followed; every confirmed track must follow one mover only.
    let mut owner: HashMap<u32, usize> = HashMap::new();
    let mut followed = vec![0usize; s.spec.world.moving.len()];
    drive(&s, 40.0, Twist::new(0.12, 0.0), |_, fleet, pipe| {
        let movers: Vec<_> = fleet.world().moving_circles().collect();
        for tr in pipe
            .tracker()
            .tracks()
            .iter()
            .filter(|t| t.is_confirmed() && t.misses == 0)
        {
            let (i, d) = movers
                .iter()
                .enumerate()
                .map(|(i, m)| (i, (tr.position() - m.center).norm()))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap();
            if d < 0.3 {
                let first = *owner.entry(tr.id).or_insert(i);
                assert_eq!(first, i, "track {} followed mover {first}, now mover {i}", tr.id);
                followed[i] += 1;
            }
        }
    });
    // Each mover that came into view was followed for a while.
    let seen = followed.iter().filter(|&&n| n > 10).count();
    println!("steps each mover was followed: {followed:?}; tracks: {}", owner.len());
    assert!(seen >= 3, "movers followed: {followed:?}");
}

#[test]
fn a_static_wall_never_yields_a_moving_track() {
    let s = common::scenario("corridor");
    let mut clusters_seen = 0;
    drive(&s, 40.0, Twist::new(0.15, 0.0), |t, _, pipe| {
        let o = &pipe.params().obstacles;
        clusters_seen += pipe.clusters().len();
        for tr in pipe.tracker().tracks() {
            assert!(
                !tr.is_moving(o),
                "t = {t}: moving track {:?} at {:?}",
                tr.velocity(),
                tr.position()
            );
        }
    });
    // Not vacuous: the tracker was given clusters (walls, cabinets, their pieces).
    println!("cluster-steps in the corridor: {clusters_seen}");
    assert!(clusters_seen > 0);
}

const A_DRIFTER: &str = "
name: a_drifter
duration_s: 20
robot: {preset: turtlebot3_burger}
start: {x_m: 0, y_m: 0, theta_deg: 0}
lidar: {beams: 360, noise_std_m: 0.01}
nominal: {kind: constant, v_mps: 0.0, omega_radps: 0.0}
world:
  moving:
    - {radius_m: 0.2, motion: {kind: constant_velocity, start: [1.2, -0.3], velocity_mps: [0.0, 0.03]}}
";

/// A person drifting at 0.03 m/s (the soak's movers walk at 0.015-0.045 m/s)
/// is a mover for the braking check once it stands where earlier scans saw
/// free (ALGORITHM §6, `seen_free`), long before it has travelled
/// `obstacles.min_travel_m` (0.75 m, 25 s), and is faster than
/// `obstacles.moving_speed_mps` (0.02). At the earlier 0.05 such people
/// counted as static and pinned robots against walls (soak: 10 passive
/// contacts, now 2).
#[test]
fn a_person_drifting_at_three_centimetres_a_second_is_a_mover() {
    let s = Scenario::from_str(A_DRIFTER, "a_drifter.yaml", None).unwrap();
    assert_eq!(s.params.obstacles.moving_speed_mps, 0.02);
    let mut first_mover_s = None;
    let mut last_speed = 0.0;
    drive(&s, 15.0, Twist::ZERO, |t, _, pipe| {
        if let Some(m) = pipe.movers().first() {
            first_mover_s.get_or_insert(t);
            last_speed = m.velocity.norm();
        }
    });
    let t = first_mover_s.expect("the drifter never became a mover in 15 s");
    println!("a mover after {t:.1} s, speed {last_speed:.3} m/s (truth 0.03)");
    // Snapshots 1 s apart; two must have seen its leading edge's place free on five
    // beams (±4 cm at 1.2 m), so it must have drifted clear of where it was at the
    // second (1 s): a few seconds at 0.03 m/s, and the filter's speed estimate must
    // pass 0.02 m/s. By travel alone it would take 25 s.
    assert!((3.0..8.0).contains(&t), "first a mover at {t} s");
    assert!((last_speed - 0.03).abs() < 0.015, "speed {last_speed} m/s");
}

/// The paper method keeps the proof of motion it had (`oldbf-paper` must
/// behave as it did): travel of 0.3 m alone, no proof by sight. The same
/// drifter is a mover only once its centre estimate has moved 0.3 m, 10 s
/// at 0.03 m/s, not after the 3-8 s sight takes.
#[test]
fn the_paper_method_proves_the_drifter_by_travel_alone() {
    let mut s = Scenario::from_str(A_DRIFTER, "a_drifter.yaml", None).unwrap();
    s.params = s.params.clone().paper_method();
    let mut first_moving_s = None;
    drive(&s, 15.0, Twist::ZERO, |t, _, pipe| {
        let o = &pipe.params().obstacles;
        if pipe.tracker().tracks().iter().any(|tr| tr.is_moving(o)) {
            first_moving_s.get_or_insert(t);
        }
    });
    let t = first_moving_s.expect("the drifter never became a mover in 15 s");
    println!("paper method: a mover after {t:.1} s");
    assert!((9.0..13.0).contains(&t), "first moving at {t} s");
}

/// The disc the braking check keeps clear of is centred where the mover is,
/// not on the centroid of the arc the LiDAR sees of it, which lies about
/// 0.7 R nearer the robot (R sin α / α in front of the centre for an arc of
/// half-angle α; 0.1 m here): a disc there reached that much nearer the
/// robot than the person did and pinned robots that had room (ALGORITHM §6).
#[test]
fn a_movers_disc_is_centred_on_the_mover_not_on_the_arc_seen() {
    let s = Scenario::from_str(ONE_MOVER, "one_mover.yaml", None).unwrap();
    let mut seen = None;
    drive(&s, 3.15, Twist::ZERO, |t, fleet, pipe| {
        if (t - 3.0).abs() < 1e-9 {
            // The robot stands at the origin facing +x: its frame is the world's.
            let truth = fleet.world().moving_circles().next().unwrap().center;
            let disc = pipe.movers().first().map(|m| m.position);
            let centroid = pipe
                .tracker()
                .tracks()
                .iter()
                .map(|t| t.position())
                .min_by(|a, b| (a - truth).norm().total_cmp(&(b - truth).norm()));
            seen = Some((truth, disc, centroid));
        }
    });
    let (truth, disc, centroid) = seen.expect("ran to 3 s");
    let disc = disc.expect("a mover after 3 s (0.6 m travelled)");
    let centroid = centroid.expect("a track");
    println!("truth {truth:?}: disc centre {disc:?}, tracked centroid {centroid:?}");
    assert!((disc - truth).norm() < 0.04, "disc {:.3} m off", (disc - truth).norm());
    assert!((centroid - truth).norm() > 0.07, "the centroid is the near side's");
    assert!(disc.norm() > centroid.norm());
}

/// Slow people who merged into one cluster too wide to track are movers
/// again as soon as their new tracks are confirmed, not after their motion
/// is proven again: each dead track left a ghost (ALGORITHM §6). In this
/// world of `slow_obstacles` (seed 4, world 7) the runs with and without
/// ghosts are the same until one more track counts as moving with them, at
/// 27.1 s, which can only be a track reacquired from a ghost; the robot backs
/// away from it. Without ghosts it counts as static and walks into the robot
/// 6.0 s later. The rule itself is unit-tested in
/// `obstacle_tracker::tests::a_mover_lost_and_seen_again_is_a_mover_again_at_once`.
#[test]
fn slow_people_who_merged_are_movers_again_when_they_part() {
    common::assert_template_worlds_safe("slow_obstacles", &[(4, 7)]);
}
