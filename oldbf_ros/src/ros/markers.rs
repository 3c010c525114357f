//! ~markers for rviz: the robot footprint (and, with `footprint.polygon_m`,
//! the polygon and its d_safe outline), the d_safe and d_act circles, the
//! hemisphere and front sectors, the closest left/right points, the command
//! a label with B_l, B_r and the DOAA state, and each tracked obstacle on a
//! collision course (its circle, its velocity over 1 s, its time to
//! collision). All in the base frame. The way round (§4c): the route, its
//! waypoint and the local map, in the odometry frame ([`route_markers`]).

use super::msg::{
    geometry_msgs::Point, std_msgs::ColorRGBA, visualization_msgs::Marker, visualization_msgs::MarkerArray,
};
use crate::algo::pipeline::Threat;
use crate::algo::way_round::RouteUpdate;
use crate::algo::{Params, Vec2};
use crate::node_core::Tick;

const NS: &str = "oldbf";

fn color(r: f32, g: f32, b: f32, a: f32) -> ColorRGBA {
    ColorRGBA { r, g, b, a }
}

fn point(x: f64, y: f64) -> Point {
    Point { x, y, z: 0.02 }
}

fn marker(frame: &str, stamp: rosrust::Time, id: i32, kind: i32) -> Marker {
    let mut m = Marker::default();
    m.header.frame_id = frame.to_string();
    m.header.stamp = stamp;
    m.ns = NS.into();
    m.id = id;
    m.type_ = kind;
    m.action = Marker::ADD as i32;
    m.pose.orientation.w = 1.0;
    m.frame_locked = true;
    m
}

fn circle(frame: &str, stamp: rosrust::Time, id: i32, radius: f64, c: ColorRGBA) -> Marker {
    let mut m = marker(frame, stamp, id, Marker::LINE_STRIP as i32);
    m.scale.x = 0.02;
    m.color = c;
    m.points = (0..=72)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / 72.0;
            point(radius * a.cos(), radius * a.sin())
        })
        .collect();
    m
}

/// Two rays from the origin at ±half angle (rad), `length` m long.
fn sector(frame: &str, stamp: rosrust::Time, id: i32, half: f64, length: f64, c: ColorRGBA) -> Marker {
    let mut m = marker(frame, stamp, id, Marker::LINE_LIST as i32);
    m.scale.x = 0.008;
    m.color = c;
    for s in [-1.0, 1.0] {
        m.points.push(point(0.0, 0.0));
        m.points
            .push(point(length * (s * half).cos(), length * (s * half).sin()));
    }
    m
}

/// The footprint polygon (`footprint.polygon_m`) as a closed line, and its
/// outline grown by padding_m + d_safe (ids 9, 10); deleted without one.
const POLYGON_ID: i32 = 9;
const POLYGON_SAFE_ID: i32 = 10;

/// The closed outline of the polygon `vertices` (counter-clockwise) with
/// every edge moved outward by `offset_m`: each vertex moves along the
/// bisector of its two edges' outward normals by offset / cos(half the angle
/// between them), where the moved edges meet. The corners stay sharp
/// (mitred), so at a convex corner the outline lies a little outside the
/// rounded set "within offset of the polygon"; the edges are exact. The
/// first point is repeated at the end.
pub fn offset_outline(vertices: &[Vec2], offset_m: f64) -> Vec<Vec2> {
    let n = vertices.len();
    let normal = |i: usize| {
        let e = vertices[(i + 1) % n] - vertices[i];
        // Outward: the right of a counter-clockwise edge.
        Vec2::new(e.y, -e.x).try_normalize(0.0).unwrap_or(Vec2::zeros())
    };
    let mut out: Vec<Vec2> = (0..n)
        .map(|i| {
            let (n_in, n_out) = (normal((i + n - 1) % n), normal(i));
            let bisector = (n_in + n_out).try_normalize(0.0).unwrap_or(n_out);
            let cos_half = bisector.dot(&n_out);
            // A simple polygon never folds an edge back on the last (cos_half > 0).
            let scale = if cos_half > 1e-9 { offset_m / cos_half } else { offset_m };
            vertices[i] + bisector * scale
        })
        .collect();
    if let Some(&first) = out.first() {
        out.push(first);
    }
    out
}

/// The polygon footprint's two line strips (the polygon, its d_safe
/// outline), or their deletions when `p` has no valid polygon.
fn polygon_markers(frame: &str, stamp: rosrust::Time, p: &Params) -> [Marker; 2] {
    let mut body = marker(frame, stamp, POLYGON_ID, Marker::LINE_STRIP as i32);
    let mut safe = marker(frame, stamp, POLYGON_SAFE_ID, Marker::LINE_STRIP as i32);
    match p.footprint.polygon() {
        Some(Ok(fp)) => {
            body.scale.x = 0.02;
            body.color = color(0.2, 0.2, 0.2, 0.9);
            body.points = offset_outline(fp.polygon.vertices(), 0.0)
                .iter()
                .map(|q| point(q.x, q.y))
                .collect();
            safe.scale.x = 0.02;
            safe.color = color(0.9, 0.1, 0.1, 0.9);
            safe.points = offset_outline(fp.polygon.vertices(), fp.padding_m + p.barrier.d_safe_m)
                .iter()
                .map(|q| point(q.x, q.y))
                .collect();
        }
        _ => {
            // A DELETE carries the ADD's scale and colour: rviz checks those on
            // every marker, and a zero scale put the whole display in error.
            body.action = Marker::DELETE as i32;
            safe.action = Marker::DELETE as i32;
            for m in [&mut body, &mut safe] {
                m.scale.x = 0.02;
                m.color = color(0.2, 0.2, 0.2, 0.9);
            }
        }
    }
    [body, safe]
}

/// Threat markers use ids from here, three per threat.
const THREAT_ID0: i32 = 100;
/// At most this many threats are drawn.
const MAX_THREATS_DRAWN: usize = 16;

/// Where the B_l / B_r / state label goes, in the base frame: beyond the
/// d_act circle, "up" in a top-down view of the odometry frame (+y there)
/// when the robot's yaw in it is known, so the label stays level above the
/// robot in a view that follows the robot, whatever its heading; without
/// odometry, to the robot's left.
pub fn label_position(p: &Params, odom_yaw: Option<f64>) -> (f64, f64) {
    let up = p.robot_radius_m() + p.barrier.d_act_m() + LABEL_CLEARANCE_M;
    // The world's +y expressed in the base frame: rotated by −yaw.
    let a = std::f64::consts::FRAC_PI_2 - odom_yaw.filter(|y| y.is_finite()).unwrap_or(0.0);
    (up * a.cos(), up * a.sin())
}

/// The label's colour (tests/ros/check_screenshot.py looks for it).
pub const LABEL_RGB: [f32; 3] = [0.55, 0.9, 1.0];

/// Gap between the d_act circle and the label's centre line (m).
const LABEL_CLEARANCE_M: f64 = 0.3;

/// The markers for one tick. `odom_yaw`: the robot's heading in the odometry
/// frame, if known (places the label, see [`label_position`]).
pub fn markers(
    frame: &str,
    stamp: rosrust::Time,
    tick: &Tick,
    threats: &[Threat],
    p: &Params,
    odom_yaw: Option<f64>,
) -> MarkerArray {
    let rec = &tick.record;
    let r = p.robot_radius_m();
    let d_act = p.barrier.d_act_m();
    let mut v = Vec::with_capacity(9);

    let mut body = marker(frame, stamp, 0, Marker::CYLINDER as i32);
    body.scale.x = 2.0 * r;
    body.scale.y = 2.0 * r;
    body.scale.z = 0.05;
    body.color = if tick.e_stop || rec.stop_cause.is_some() {
        color(0.9, 0.1, 0.1, 0.6)
    } else {
        color(0.5, 0.5, 0.5, 0.6)
    };
    v.push(body);
    v.push(circle(
        frame,
        stamp,
        1,
        r + p.barrier.d_safe_m,
        color(0.9, 0.1, 0.1, 0.9),
    ));
    v.push(circle(frame, stamp, 2, r + d_act, color(0.95, 0.75, 0.1, 0.8)));
    v.push(sector(
        frame,
        stamp,
        3,
        p.barrier.hemisphere_fov_deg.to_radians() / 2.0,
        r + d_act,
        color(0.3, 0.6, 0.9, 0.6),
    ));
    v.push(sector(
        frame,
        stamp,
        4,
        p.barrier.front_fov_deg.to_radians() / 2.0,
        r + d_act,
        color(0.9, 0.4, 0.1, 0.8),
    ));

    for (id, closest, c) in [
        (5, rec.closest_left, color(0.1, 0.8, 0.2, 1.0)),
        (6, rec.closest_right, color(0.1, 0.3, 0.9, 1.0)),
    ] {
        let mut m = marker(frame, stamp, id, Marker::SPHERE as i32);
        m.scale.x = 0.08;
        m.scale.y = 0.08;
        m.scale.z = 0.08;
        m.color = c;
        match closest {
            Some(pt) => {
                m.pose.position = point(pt.x, pt.y);
            }
            None => m.action = Marker::DELETE as i32,
        }
        v.push(m);
    }

    let mut arrow = marker(frame, stamp, 7, Marker::ARROW as i32);
    arrow.scale.x = 0.03;
    arrow.scale.y = 0.06;
    arrow.scale.z = 0.06;
    arrow.color = color(0.1, 0.9, 0.9, 1.0);
    let len = 2.0 * tick.cmd.v_mps; // 1 s of travel at half scale
    let heading = 0.5 * tick.cmd.omega_radps; // where the robot heads in 0.5 s
    arrow.points = vec![point(0.0, 0.0), point(len * heading.cos(), len * heading.sin())];
    v.push(arrow);

    let mut label = marker(frame, stamp, 8, Marker::TEXT_VIEW_FACING as i32);
    label.scale.z = 0.2;
    let (lx, ly) = label_position(p, odom_yaw);
    label.pose.position = point(lx, ly);
    label.pose.position.z = 0.5;
    // Light blue: apart from the white scan points, and findable in a screenshot.
    label.color = color(LABEL_RGB[0], LABEL_RGB[1], LABEL_RGB[2], 1.0);
    label.text = match rec.stop_cause {
        Some(_) if tick.e_stop_silence.is_some() => "STOP: e_stop silent".to_string(),
        Some(cause) if !rec.measured() || tick.e_stop => format!("STOP: {cause}"),
        _ => format!("B_l {:.2}  B_r {:.2}  {}", rec.b_left, rec.b_right, rec.state),
    };
    v.push(label);
    v.extend(polygon_markers(frame, stamp, p));
    v.extend(threat_markers(frame, stamp, threats));
    MarkerArray { markers: v }
}

/// Per threat: a disc of its fitted radius, an arrow of its velocity over
/// 1 s, and its time to collision. The slots of threats that are gone are
/// deleted, so rviz never shows a stale one.
fn threat_markers(frame: &str, stamp: rosrust::Time, threats: &[Threat]) -> Vec<Marker> {
    let mut out = Vec::with_capacity(3 * MAX_THREATS_DRAWN);
    for k in 0..MAX_THREATS_DRAWN {
        let id = THREAT_ID0 + 3 * k as i32;
        let mut disc = marker(frame, stamp, id, Marker::CYLINDER as i32);
        let mut arrow = marker(frame, stamp, id + 1, Marker::ARROW as i32);
        let mut text = marker(frame, stamp, id + 2, Marker::TEXT_VIEW_FACING as i32);
        match threats.get(k) {
            Some(t) => {
                let c = color(0.95, 0.2, 0.6, 0.7);
                disc.pose.position = point(t.position.x, t.position.y);
                disc.scale.x = 2.0 * t.radius_m.max(0.02);
                disc.scale.y = disc.scale.x;
                disc.scale.z = 0.1;
                disc.color = c.clone();
                arrow.scale.x = 0.02;
                arrow.scale.y = 0.05;
                arrow.scale.z = 0.05;
                arrow.color = c;
                let tip = t.position + t.velocity;
                arrow.points = vec![point(t.position.x, t.position.y), point(tip.x, tip.y)];
                text.pose.position = point(t.position.x, t.position.y);
                text.pose.position.z = 0.3;
                text.scale.z = 0.1;
                text.color = color(1.0, 0.6, 0.8, 1.0);
                text.text = format!("TTC {:.1} s", t.time_to_collision_s);
            }
            None => {
                for m in [&mut disc, &mut arrow, &mut text] {
                    m.action = Marker::DELETE as i32;
                }
            }
        }
        out.extend([disc, arrow, text]);
    }
    out
}

/// Namespace of the way round's markers (§4c): the route (id 0), the
/// waypoint followed (id 1) and the local map's occupied cells (id 2), in the
/// odometry frame the route is planned in.
pub const ROUTE_NS: &str = "oldbf_route";

/// The way round for rviz, in `odom_frame`: the route held as a line (blue
/// while followed, grey otherwise), the waypoint as a sphere, and, when a new
/// snapshot is given, the map's occupied cells as 5 cm cubes. No route (or
/// none yet): the line and the sphere are deleted.
pub fn route_markers(
    odom_frame: &str,
    stamp: rosrust::Time,
    route: Option<&RouteUpdate>,
    following: bool,
    map_cells: Option<&[Vec2]>,
) -> MarkerArray {
    let ns = |m: &mut Marker| m.ns = ROUTE_NS.into();
    let mut v = Vec::with_capacity(3);
    let mut line = marker(odom_frame, stamp, 0, Marker::LINE_STRIP as i32);
    ns(&mut line);
    let mut aim = marker(odom_frame, stamp, 1, Marker::SPHERE as i32);
    ns(&mut aim);
    match route.and_then(|u| u.route.as_ref().map(|r| (r, u.carrot))) {
        Some((r, carrot)) => {
            line.scale.x = 0.03;
            line.color = if following {
                color(0.1, 0.4, 0.95, 0.9)
            } else {
                color(0.6, 0.6, 0.6, 0.6)
            };
            line.points = r.points.iter().map(|q| point(q.x, q.y)).collect();
            match carrot {
                Some(c) => {
                    aim.pose.position = point(c.x, c.y);
                    aim.scale.x = 0.1;
                    aim.scale.y = 0.1;
                    aim.scale.z = 0.1;
                    aim.color = color(0.1, 0.4, 0.95, 0.9);
                }
                None => aim.action = Marker::DELETE as i32,
            }
        }
        None => {
            line.action = Marker::DELETE as i32;
            aim.action = Marker::DELETE as i32;
        }
    }
    v.push(line);
    v.push(aim);
    if let Some(cells) = map_cells {
        let mut map = marker(odom_frame, stamp, 2, Marker::CUBE_LIST as i32);
        ns(&mut map);
        let cell = crate::algo::local_map::MAP_CELL_M;
        map.scale.x = cell;
        map.scale.y = cell;
        map.scale.z = 0.02;
        map.color = color(0.3, 0.3, 0.3, 0.7);
        map.points = cells.iter().map(|q| point(q.x, q.y)).collect();
        v.push(map);
    }
    MarkerArray { markers: v }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::route::{Route, RouteChange};

    #[test]
    fn the_route_its_waypoint_and_the_map_are_drawn_in_the_odometry_frame() {
        let u = RouteUpdate {
            route: Some(Route {
                points: vec![Vec2::new(1.0, 2.0), Vec2::new(1.05, 2.0)],
                reaches_goal: true,
                reaches_target: true,
                cost: 0.05,
                unknown_m: 0.0,
                goal: Vec2::new(1.05, 2.0),
                made_s: 3.0,
            }),
            change: RouteChange::New,
            direct_margin_m: -0.1,
            carrot: Some(Vec2::new(1.05, 2.0)),
            made_s: 3.0,
            plan_us: 0.0,
        };
        let cells = [Vec2::new(2.0, 2.0)];
        let m = route_markers("odom", rosrust::Time::default(), Some(&u), true, Some(&cells)).markers;
        assert_eq!(m.len(), 3);
        assert!(m.iter().all(|k| k.header.frame_id == "odom" && k.ns == ROUTE_NS));
        assert_eq!(
            m[0].points.iter().map(|p| (p.x, p.y)).collect::<Vec<_>>(),
            vec![(1.0, 2.0), (1.05, 2.0)]
        );
        assert_eq!((m[1].pose.position.x, m[1].action), (1.05, Marker::ADD as i32));
        assert_eq!((m[2].type_, m[2].points.len()), (Marker::CUBE_LIST as i32, 1));
        // No route: the line and the waypoint are deleted; no snapshot, no map marker.
        let m = route_markers("odom", rosrust::Time::default(), None, false, None).markers;
        assert_eq!(m.len(), 2);
        assert!(m.iter().all(|k| k.action == Marker::DELETE as i32));
    }

    #[test]
    fn the_label_sits_above_the_d_act_circle_in_the_odometry_frame_whatever_the_heading() {
        let p = Params::default();
        let up = p.robot_radius_m() + p.barrier.d_act_m() + LABEL_CLEARANCE_M;
        for yaw in [0.0, 0.7, -2.0, 3.1] {
            let (x, y) = label_position(&p, Some(yaw));
            // Back into the odometry frame: straight "up" from the robot.
            let (c, s) = (yaw.cos(), yaw.sin());
            let (wx, wy) = (c * x - s * y, s * x + c * y);
            assert!(wx.abs() < 1e-9 && (wy - up).abs() < 1e-9, "yaw {yaw}: ({wx}, {wy})");
        }
        let (x, y) = label_position(&p, None);
        assert!(x.abs() < 1e-9 && (y - up).abs() < 1e-9);
        assert_eq!(label_position(&p, Some(f64::NAN)), label_position(&p, None));
    }

    #[test]
    fn a_polygon_footprint_is_drawn_with_its_d_safe_outline_and_deleted_without_one() {
        let mut p = Params::default();
        p.footprint.polygon_m = vec![[0.3, 0.2], [-0.3, 0.2], [-0.3, -0.2], [0.3, -0.2]];
        p.footprint.padding_m = 0.05;
        p.barrier.d_safe_m = 0.1;
        let [body, safe] = polygon_markers("base_link", rosrust::Time::default(), &p);
        let xy = |m: &Marker| m.points.iter().map(|q| (q.x, q.y)).collect::<Vec<_>>();
        assert_eq!((body.id, body.type_), (POLYGON_ID, Marker::LINE_STRIP as i32));
        // Counter-clockwise from the first vertex of the validated polygon, closed.
        let b = xy(&body);
        assert_eq!(b.len(), 5);
        assert_eq!(b[0], b[4]);
        for corner in [(0.3, 0.2), (-0.3, 0.2), (-0.3, -0.2), (0.3, -0.2)] {
            assert!(b.contains(&corner), "{corner:?} in {b:?}");
        }
        // Grown by 0.05 + 0.1 m: a rectangle's corners move 0.15 m out in x and in y.
        let s = xy(&safe);
        assert_eq!(s.len(), 5);
        for (i, &(x, y)) in b.iter().enumerate() {
            let (sx, sy) = s[i];
            assert!(
                (sx - (x + 0.15 * x.signum())).abs() < 1e-12 && (sy - (y + 0.15 * y.signum())).abs() < 1e-12,
                "{:?} → {:?}",
                (x, y),
                (sx, sy)
            );
        }
        // A triangle: the right-angle corner at the origin moves along its
        // bisector by 0.1 / cos 45° = 0.1414 m, to (−0.1, −0.1).
        let tri = offset_outline(&[Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)], 0.1);
        assert!((tri[0] - Vec2::new(-0.1, -0.1)).norm() < 1e-12, "{tri:?}");
        assert!((tri[1].y + 0.1).abs() < 1e-12 && (tri[2].x + 0.1).abs() < 1e-12);
        // No polygon: both deleted.
        let [body, safe] = polygon_markers("base_link", rosrust::Time::default(), &Params::default());
        assert_eq!(
            (body.action, safe.action),
            (Marker::DELETE as i32, Marker::DELETE as i32)
        );
    }

    #[test]
    fn each_threat_gets_a_disc_an_arrow_and_its_time_to_collision_and_gone_ones_are_deleted() {
        let t = Threat {
            track_id: 7,
            position: Vec2::new(1.0, 0.5),
            velocity: Vec2::new(-0.3, 0.0),
            radius_m: 0.2,
            time_to_collision_s: 1.25,
            cone_half_angle_rad: 0.3,
        };
        let m = threat_markers("base_link", rosrust::Time::default(), &[t]);
        assert_eq!(m.len(), 3 * MAX_THREATS_DRAWN);
        let (disc, arrow, text) = (&m[0], &m[1], &m[2]);
        assert_eq!((disc.id, disc.action), (THREAT_ID0, Marker::ADD as i32));
        assert_eq!((disc.pose.position.x, disc.pose.position.y), (1.0, 0.5));
        assert!((disc.scale.x - 0.4).abs() < 1e-12);
        // The arrow spans one second of the obstacle's motion.
        assert_eq!((arrow.points[1].x, arrow.points[1].y), (0.7, 0.5));
        assert_eq!(text.text, "TTC 1.2 s");
        assert!(m[3..].iter().all(|k| k.action == Marker::DELETE as i32));
        let ids: Vec<i32> = m.iter().map(|k| k.id).collect();
        assert_eq!(
            ids,
            (THREAT_ID0..THREAT_ID0 + 3 * MAX_THREATS_DRAWN as i32).collect::<Vec<_>>()
        );
    }
}
