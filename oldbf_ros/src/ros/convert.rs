//! Message ↔ core type conversions (no decisions here).

use super::msg::{geometry_msgs, nav_msgs, sensor_msgs};
use crate::algo::geometry::{Pose2, Twist};
use crate::algo::scan::ScanHeader;

pub fn twist_from_msg(t: &geometry_msgs::Twist) -> Twist {
    Twist::new(t.linear.x, t.angular.z)
}

/// A planar twist as geometry_msgs/Twist (only linear.x and angular.z set).
pub fn twist_to_msg(t: Twist) -> geometry_msgs::Twist {
    let mut m = geometry_msgs::Twist::default();
    m.linear.x = t.v_mps;
    m.angular.z = t.omega_radps;
    m
}

pub fn time_to_s(t: rosrust::Time) -> f64 {
    t.seconds()
}

pub fn time_from_s(s: f64) -> rosrust::Time {
    if s.is_finite() && s > 0.0 {
        rosrust::Time::from_nanos((s * 1e9) as i64)
    } else {
        rosrust::Time::default()
    }
}

/// The header of a ROS scan, for the node logic (the ranges are passed as they are).
pub fn scan_header(m: &sensor_msgs::LaserScan) -> ScanHeader {
    ScanHeader {
        stamp_s: time_to_s(m.header.stamp),
        angle_min_rad: m.angle_min,
        angle_increment_rad: m.angle_increment,
        range_min_m: m.range_min,
        range_max_m: m.range_max,
    }
}

/// Yaw (rad) of a quaternion.
pub fn yaw_of(q: &geometry_msgs::Quaternion) -> f64 {
    (2.0 * (q.w * q.z + q.x * q.y)).atan2(1.0 - 2.0 * (q.y * q.y + q.z * q.z))
}

pub fn quaternion_from_yaw(yaw: f64) -> geometry_msgs::Quaternion {
    let (s, c) = (0.5 * yaw).sin_cos();
    geometry_msgs::Quaternion {
        x: 0.0,
        y: 0.0,
        z: s,
        w: c,
    }
}

/// The planar pose and body twist in an Odometry message.
pub fn odom_from_msg(m: &nav_msgs::Odometry) -> (Pose2, Twist) {
    let p = &m.pose.pose;
    (
        Pose2::new(p.position.x, p.position.y, yaw_of(&p.orientation)),
        Twist::new(m.twist.twist.linear.x, m.twist.twist.angular.z),
    )
}

/// A frame name under `prefix` (tf_prefix style; empty prefix: unchanged).
pub fn prefixed(prefix: &str, frame: &str) -> String {
    if prefix.is_empty() {
        frame.to_string()
    } else {
        format!("{}/{}", prefix.trim_matches('/'), frame)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaw_round_trips_through_a_quaternion() {
        for yaw in [-3.0, -1.0, 0.0, 0.5, 3.1] {
            assert!((yaw_of(&quaternion_from_yaw(yaw)) - yaw).abs() < 1e-12);
        }
    }

    #[test]
    fn times_convert_both_ways() {
        let t = time_from_s(1234.5);
        assert_eq!((t.sec, t.nsec), (1234, 500_000_000));
        assert!((time_to_s(t) - 1234.5).abs() < 1e-9);
        assert_eq!(time_from_s(f64::NAN), rosrust::Time::default());
    }

    #[test]
    fn frames_get_prefixed() {
        assert_eq!(prefixed("", "base_link"), "base_link");
        assert_eq!(prefixed("/robot1/", "base_link"), "robot1/base_link");
    }
}
