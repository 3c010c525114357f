//! One world with one or more simulated robots: the physics shared by the
//! closed-loop runner (`oldbf sim`) and the ROS sim node.
//!
//! Every robot is its body in the other robots' LiDAR scans and collision
//! checks (a disc of its radius, or its polygon's edges, posed), so robots
//! in one world see and avoid each other. Collisions are checked exactly
//! (the robot's circle, or its body polygon, against segments and circles)
//! after every physics step; a contact counts once when it begins. Each
//! contact is classified at its onset (ALGORITHM.md §5b): *closing* when the
//! robot's own velocity towards the touched point exceeds
//! [`CLOSING_SPEED_MPS`] (it drove in), else *passive* (it was at rest, or
//! turning, or moving away: the obstacle came to it). For a polygon body the
//! velocity is that of the body's point at the contact (v plus ω × the
//! point, [`super::body::Touch`]) along the direction to the shape: a turn
//! alone swings a corner into a wall. For a disc the rim's turning velocity
//! is tangential, so the centre's velocity gives the same number.

use super::body::BodyPolygon;
use super::lidar::{Lidar, LidarError, LidarSpec};
use super::robot::SimRobot;
use super::scenario::Scenario;
use super::shapes::{Circle, Segment};
use super::world::{World, WorldError};
use crate::algo::geometry::{Pose2, Twist, Vec2};

/// A contact is closing when the robot moved towards the touched point
/// faster than this at its onset (m/s); the figure of merit of §5b.
/// Fixed on purpose, independent of the tunable `passive.closing_speed_mps`,
/// so that contact figures stay comparable across configurations.
pub const CLOSING_SPEED_MPS: f64 = 0.02;

/// One contact, at its onset.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Contact {
    /// Simulated time (s).
    pub t_s: f64,
    /// Robot position (m, world).
    #[serde(serialize_with = "xy")]
    pub position: Vec2,
    /// Robot speed towards the touched point (m/s; negative: moving away).
    pub closing_speed_mps: f64,
    /// Where the body touched (m, world): the nearest surface point to a
    /// disc's centre, or the body polygon's point nearest the shape.
    #[serde(serialize_with = "xy")]
    pub touched_m: Vec2,
}

fn xy<S: serde::Serializer>(p: &Vec2, s: S) -> Result<S::Ok, S::Error> {
    serde::Serialize::serialize(&[p.x, p.y], s)
}

impl Contact {
    pub fn closing(&self) -> bool {
        self.closing_speed_mps > CLOSING_SPEED_MPS
    }
}

/// One simulated robot and what happened to it.
#[derive(Debug, Clone)]
pub struct SimAgent {
    /// Namespace (empty for a single robot).
    pub name: String,
    pub robot: SimRobot,
    /// Its LiDARs: the scenario's `lidar`, or each of `lidars`.
    lidars: Vec<Lidar>,
    /// The command being executed (m/s, rad/s).
    pub cmd: Twist,
    /// Distinct contacts so far.
    pub collisions: usize,
    pub in_collision: bool,
    /// Least body-to-obstacle distance so far (m; < 0 = penetration).
    pub min_clearance_m: f64,
    /// Distance travelled (m).
    pub path_length_m: f64,
    /// Each contact at its onset.
    pub contacts: Vec<Contact>,
}

/// Why a scenario's world or LiDAR could not be built (the text is theirs).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FleetError {
    #[error(transparent)]
    World(#[from] WorldError),
    #[error(transparent)]
    Lidar(#[from] LidarError),
}

/// The world and its robots.
#[derive(Debug, Clone)]
pub struct Fleet {
    world: World,
    agents: Vec<SimAgent>,
    /// Each LiDAR's mount pose on every robot (robot frame).
    mounts: Vec<Pose2>,
}

impl Fleet {
    /// Builds the scenario's world and robots; robot i's LiDAR noise is seeded
    /// from `seed` and i, so runs are reproducible.
    pub fn new(scenario: &Scenario, seed: u64) -> Result<Fleet, FleetError> {
        let world = World::new(&scenario.spec.world)?;
        let l = &scenario.params.laser;
        let (specs, mounts): (Vec<LidarSpec>, Vec<Pose2>) = if scenario.spec.lidars.is_empty() {
            (
                vec![scenario.spec.lidar.clone()],
                vec![Pose2::new(l.mount_x_m, l.mount_y_m, l.mount_yaw_deg.to_radians())],
            )
        } else {
            scenario
                .spec
                .lidars
                .iter()
                .map(|m| {
                    (
                        m.lidar.clone(),
                        Pose2::new(m.mount_x_m, m.mount_y_m, m.mount_yaw_deg.to_radians()),
                    )
                })
                .unzip()
        };
        let mut agents = Vec::with_capacity(scenario.agents.len());
        for (i, plan) in scenario.agents.iter().enumerate() {
            let lidar_seed = seed.wrapping_add((i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
            agents.push(SimAgent {
                name: plan.name.clone(),
                robot: SimRobot::new(plan.start, scenario.robot).with_body(scenario.body.clone()),
                lidars: specs
                    .iter()
                    .enumerate()
                    .map(|(k, spec)| Lidar::new(spec.clone(), lidar_seed.wrapping_add(k as u64 * 0x5851_F42D)))
                    .collect::<Result<_, _>>()?,
                cmd: Twist::ZERO,
                collisions: 0,
                in_collision: false,
                min_clearance_m: f64::INFINITY,
                path_length_m: 0.0,
                contacts: Vec::new(),
            });
        }
        let mut fleet = Fleet { world, agents, mounts };
        fleet.check_contacts();
        Ok(fleet)
    }

    pub fn world(&self) -> &World {
        &self.world
    }

    pub fn agents(&self) -> &[SimAgent] {
        &self.agents
    }

    pub fn time_s(&self) -> f64 {
        self.world.time_s()
    }

    /// The (first) LiDAR's spec.
    pub fn lidar_spec(&self) -> &LidarSpec {
        self.agents[0].lidars[0].spec()
    }

    /// LiDAR `k`'s spec and mount (robot frame).
    pub fn lidar(&self, k: usize) -> (&LidarSpec, Pose2) {
        (self.agents[0].lidars[k].spec(), self.mounts[k])
    }

    /// LiDARs on each robot.
    pub fn lidars(&self) -> usize {
        self.mounts.len()
    }

    /// Sets the command robot `i` executes from now on.
    pub fn set_cmd(&mut self, i: usize, cmd: Twist) {
        self.agents[i].cmd = cmd;
    }

    /// Makes robot `i` move at a measured velocity from now on (e.g. what its
    /// motor drive reports), bypassing the simulated robot's own limits: the
    /// drive has already applied its own.
    pub fn set_measured_velocity(&mut self, i: usize, twist: Twist) {
        let a = &mut self.agents[i];
        a.robot.twist = twist;
        a.cmd = twist;
    }

    /// Places every robot but `i` into the world as a disc.
    fn show_others_to(&mut self, i: usize) {
        let others = || {
            self.agents
                .iter()
                .enumerate()
                .filter(move |(j, _)| *j != i)
                .map(|(_, a)| a)
        };
        // A disc body is a disc; a polygon body is its edges, posed.
        let discs = others()
            .filter(|a| a.robot.body().is_none())
            .map(|a| Circle::new(a.robot.pose.position(), a.robot.limits().body_radius_m));
        let edges = others()
            .filter_map(|a| a.robot.body().map(|b| (a.robot.pose, b)))
            .flat_map(|(pose, b)| {
                let v = b.polygon().vertices();
                (0..v.len())
                    .map(move |k| Segment::new(pose.transform_point(v[k]), pose.transform_point(v[(k + 1) % v.len()])))
            });
        self.world.set_agents(discs, edges);
    }

    /// Moves every robot by its command and the world's obstacles by `dt_s`
    /// (s), then checks every robot for contact.
    pub fn step(&mut self, dt_s: f64) {
        for a in &mut self.agents {
            let before = a.robot.pose.position();
            a.robot.step(a.cmd, dt_s);
            a.path_length_m += (a.robot.pose.position() - before).norm();
        }
        self.world.advance(dt_s);
        self.check_contacts();
    }

    fn check_contacts(&mut self) {
        for i in 0..self.agents.len() {
            self.show_others_to(i);
            let a = &mut self.agents[i];
            let clearance = a.robot.clearance_m(&self.world);
            a.min_clearance_m = a.min_clearance_m.min(clearance);
            let hit = clearance < 0.0;
            if hit && !a.in_collision {
                a.collisions += 1;
                let pose = a.robot.pose;
                let (closing_speed_mps, touched_m) = match a.robot.body() {
                    None => {
                        let velocity = Vec2::new(pose.theta.cos(), pose.theta.sin()) * a.robot.twist.v_mps;
                        match self.world.nearest_surface_point(pose.position()) {
                            Some(q) if q != pose.position() => (velocity.dot(&(q - pose.position()).normalize()), q),
                            _ => (velocity.norm(), pose.position()),
                        }
                    }
                    Some(body) => {
                        let Twist { v_mps, omega_radps } = a.robot.twist;
                        match body.touch(pose, &self.world) {
                            // The body point's velocity in the robot frame: v x̂ + ω ẑ × p.
                            Some(t) => (
                                Vec2::new(v_mps - omega_radps * t.point.y, omega_radps * t.point.x).dot(&t.normal),
                                pose.transform_point(t.point),
                            ),
                            None => (v_mps.abs(), pose.position()),
                        }
                    }
                };
                a.contacts.push(Contact {
                    t_s: self.world.time_s(),
                    position: pose.position(),
                    closing_speed_mps,
                    touched_m,
                });
            }
            a.in_collision = hit;
        }
    }

    /// The (first) laser's pose in the world for robot `i`.
    pub fn laser_pose(&self, i: usize) -> Pose2 {
        self.lidar_pose(i, 0)
    }

    /// LiDAR `k`'s pose in the world for robot `i`.
    pub fn lidar_pose(&self, i: usize, k: usize) -> Pose2 {
        let pose = self.agents[i].robot.pose;
        let mount = self.mounts[k];
        let origin = pose.transform_point(mount.position());
        Pose2::new(origin.x, origin.y, pose.theta + mount.theta)
    }

    /// Robot `i`'s (first) LiDAR scan now (one range per beam, m).
    pub fn scan(&mut self, i: usize, ranges: &mut Vec<f32>) {
        self.scan_with(i, 0, ranges);
    }

    /// Robot `i`'s LiDAR `k` scan now (one range per beam, m).
    pub fn scan_with(&mut self, i: usize, k: usize, ranges: &mut Vec<f32>) {
        let laser = self.lidar_pose(i, k);
        self.show_others_to(i);
        self.agents[i].lidars[k].scan_into(&self.world, laser, ranges);
    }

    /// The true ranges of robot `i`'s last (first LiDAR) scan (m; +inf: no hit).
    pub fn scan_truth(&self, i: usize) -> &[f32] {
        self.agents[i].lidars[0].truth()
    }

    /// Exact distance from robot `i`'s centre to the nearest obstacle surface,
    /// other robots included (m).
    pub fn distance_from_centre(&mut self, i: usize) -> f64 {
        self.show_others_to(i);
        self.world.distance_to_nearest(self.agents[i].robot.pose.position())
    }

    /// Exact signed distance from `body` placed at robot `i`'s pose to the
    /// nearest obstacle surface, other robots included (m): the filter's
    /// footprint polygon on the true geometry.
    pub fn polygon_clearance(&mut self, i: usize, body: &BodyPolygon) -> f64 {
        self.show_others_to(i);
        body.clearance_m(self.agents[i].robot.pose, &self.world)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_robot_at_rest_or_backing_off_when_touched_has_a_passive_contact() {
        // b drives into a (at rest): a's contact is passive, b's closing. Then the
        // same with a backing away slower than b comes: still passive for a.
        for (v_a, a_closing) in [(0.0, false), (-0.05, false), (0.05, true)] {
            let s = Scenario::from_str(TWO, "t.yaml", None).unwrap();
            let mut f = Fleet::new(&s, 1).unwrap();
            f.set_cmd(0, Twist::new(v_a, 0.0));
            f.set_cmd(1, Twist::new(0.2, 0.0));
            for _ in 0..600 {
                f.step(0.01);
            }
            let (a, b) = (&f.agents()[0], &f.agents()[1]);
            assert_eq!((a.contacts.len(), b.contacts.len()), (1, 1), "v_a {v_a}");
            assert_eq!(a.contacts[0].closing(), a_closing, "v_a {v_a}: {:?}", a.contacts[0]);
            assert!(
                (a.contacts[0].closing_speed_mps - v_a).abs() < 1e-9,
                "{:?}",
                a.contacts[0]
            );
            assert!(b.contacts[0].closing());
        }
    }

    #[test]
    fn a_rectangle_turning_in_place_into_a_wall_has_a_closing_contact() {
        // The wall 0.33 m to the left of the 0.6 x 0.4 m body: its side is
        // 0.13 m off, but its corners (0.3606 m from the centre) swing into
        // the wall as it turns. The centre is at rest: only the corner's
        // velocity makes the contact closing.
        let s = Scenario::from_str(TURN, "t.yaml", None).unwrap();
        let mut f = Fleet::new(&s, 1).unwrap();
        assert!((f.agents()[0].min_clearance_m - 0.13).abs() < 1e-12);
        f.set_cmd(0, Twist::new(0.0, 1.0));
        for _ in 0..100 {
            f.step(0.01);
        }
        let a = &f.agents()[0];
        assert_eq!(a.contacts.len(), 1, "{:?}", a.contacts);
        // ω at the onset is about 0.5 rad/s, the corner's speed towards the wall about ω · 0.3 m.
        assert!(
            a.contacts[0].closing() && a.contacts[0].closing_speed_mps > 0.05,
            "{:?}",
            a.contacts[0]
        );
        assert!(a.min_clearance_m < 0.0 && a.path_length_m == 0.0);
    }

    const TURN: &str = "
name: turn
duration_s: 10
robot: {preset: rect_0604}
lidar: {beams: 36, noise_std_m: 0.0}
start: {x_m: 0, y_m: 0, theta_deg: 0}
nominal: {kind: constant, v_mps: 0.0, omega_radps: 0}
world: {walls: [{from: [-1, 0.33], to: [1, 0.33]}]}
";

    const TWO: &str = "
name: two
duration_s: 10
robot: {preset: turtlebot3_burger}
lidar: {beams: 360, noise_std_m: 0.0}
robots:
  - {name: a, start: {x_m: 0, y_m: 0, theta_deg: 0}, nominal: {kind: constant, v_mps: 0.1, omega_radps: 0}}
  - {name: b, start: {x_m: 1.0, y_m: 0, theta_deg: 180}, nominal: {kind: constant, v_mps: 0.1, omega_radps: 0}}
";

    #[test]
    fn robots_see_each_other() {
        let s = Scenario::from_str(TWO, "t.yaml", None).unwrap();
        let mut f = Fleet::new(&s, 1).unwrap();
        let mut ranges = Vec::new();
        f.scan(0, &mut ranges);
        // Beam at 0° (index 180 of a 360° scan from −180°) sees b's disc: 1.0 − 0.105 m.
        assert!((ranges[180] - 0.895).abs() < 1e-5, "{}", ranges[180]);
        assert!((f.distance_from_centre(1) - 0.895).abs() < 1e-12);
    }

    const TWO_RECTS: &str = "
name: two_rects
duration_s: 10
robot: {preset: rect_0604}
lidar: {beams: 360, noise_std_m: 0.0}
robots:
  - {name: a, start: {x_m: 0, y_m: 0, theta_deg: 0}, nominal: {kind: constant, v_mps: 0.1, omega_radps: 0}}
  - {name: b, start: {x_m: 0, y_m: 0.5, theta_deg: 0}, nominal: {kind: constant, v_mps: 0.1, omega_radps: 0}}
";

    #[test]
    fn rectangular_robots_see_and_touch_each_others_polygons() {
        // Side by side, centres 0.5 m apart, 0.6 x 0.4 m each: 0.1 m between the
        // long sides (their circumscribed discs, 0.3606 m, would overlap).
        let s = Scenario::from_str(TWO_RECTS, "t.yaml", None).unwrap();
        let mut f = Fleet::new(&s, 1).unwrap();
        assert!(
            (f.agents()[0].min_clearance_m - 0.1).abs() < 1e-12,
            "{}",
            f.agents()[0].min_clearance_m
        );
        assert!(f.agents().iter().all(|a| a.contacts.is_empty()));
        // a's beam at +90° (index 270) meets b's near side at y = 0.3: 0.3 m.
        let mut ranges = Vec::new();
        f.scan(0, &mut ranges);
        assert!((ranges[270] - 0.3).abs() < 1e-5, "{}", ranges[270]);
        // b turns in place: its corners swing down into a's side, a contact for both.
        f.set_cmd(1, Twist::new(0.0, 1.0));
        for _ in 0..100 {
            f.step(0.01);
        }
        let (a, b) = (&f.agents()[0], &f.agents()[1]);
        assert_eq!(
            (a.contacts.len(), b.contacts.len()),
            (1, 1),
            "{:?} {:?}",
            a.contacts,
            b.contacts
        );
        assert!(
            b.contacts[0].closing() && !a.contacts[0].closing(),
            "{:?} {:?}",
            a.contacts,
            b.contacts
        );
    }

    #[test]
    fn head_on_robots_collide_once() {
        let s = Scenario::from_str(TWO, "t.yaml", None).unwrap();
        let mut f = Fleet::new(&s, 1).unwrap();
        f.set_cmd(0, Twist::new(0.2, 0.0));
        f.set_cmd(1, Twist::new(0.2, 0.0));
        for _ in 0..300 {
            f.step(0.01);
        }
        // They meet when 1.0 − 2·0.105 = 0.79 m has been closed; both count one contact.
        assert_eq!(f.agents()[0].collisions, 1);
        assert_eq!(f.agents()[1].collisions, 1);
        // Both drove in at 0.2 m/s: closing contacts.
        for a in f.agents() {
            assert!((a.contacts[0].closing_speed_mps - 0.2).abs() < 1e-9 && a.contacts[0].closing());
        }
        assert!(f.agents()[0].min_clearance_m < 0.0);
        assert!(
            (f.agents()[0].path_length_m - 0.2 * 3.0).abs() < 0.02,
            "{}",
            f.agents()[0].path_length_m
        );
    }
}
