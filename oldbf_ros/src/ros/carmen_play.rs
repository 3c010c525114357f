//! `oldbf carmen-play`: a CARMEN log converted to sensor_msgs/LaserScan and
//! published, for replaying real LiDAR data into the node (or into
//! `rosbag record`). Scans are stamped with the time they are published: the
//! log's own stamps are years old and every consumer would reject them as
//! stale.

use super::lifecycle;
use super::msg::sensor_msgs::LaserScan;
use super::RosError;
use crate::carmen::CarmenLog;
use std::time::Duration;

/// What was played.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct PlaySummary {
    pub published: usize,
    pub subscribers_at_end: usize,
}

/// Publishes every scan of `log` on `topic` at `rate_hz`, in frame `frame`.
pub fn play(log: &CarmenLog, topic: &str, frame: &str, rate_hz: f64) -> Result<PlaySummary, RosError> {
    super::logging::init();
    let stop = lifecycle::install_signal_handler();
    if !lifecycle::connect(&lifecycle::node_name("carmen_player"), &stop) {
        return Ok(PlaySummary::default());
    }
    let publisher =
        rosrust::publish::<LaserScan>(topic, 10).map_err(RosError::doing(format!("advertising {topic}")))?;
    // Give subscribers a moment to connect before the first scan.
    let _ = publisher.wait_for_subscribers(Some(Duration::from_secs(5)));
    let rate = rosrust::rate(rate_hz);
    let mut published = 0;
    for s in &log.scans {
        if stop.is_set() || !rosrust::is_ok() {
            break;
        }
        let scan = s.as_laser_scan();
        let n = s.ranges_m.len();
        let mut m = LaserScan {
            angle_min: scan.header.angle_min_rad,
            angle_increment: scan.header.angle_increment_rad,
            angle_max: scan.header.angle_min_rad + scan.header.angle_increment_rad * n.saturating_sub(1) as f32,
            scan_time: (1.0 / rate_hz) as f32,
            range_min: scan.header.range_min_m,
            range_max: scan.header.range_max_m,
            ranges: s.ranges_m.clone(),
            ..Default::default()
        };
        m.header.frame_id = frame.into();
        m.header.stamp = rosrust::now();
        publisher.send(m).map_err(RosError::doing("publishing"))?;
        published += 1;
        rate.sleep();
    }
    let summary = PlaySummary {
        published,
        subscribers_at_end: publisher.subscriber_count(),
    };
    std::thread::sleep(Duration::from_millis(200));
    rosrust::shutdown();
    Ok(summary)
}
