//! The safety node's logic without ROS: what oldbf_node decides every
//! control tick from the latest scan, odometry and upstream command. The
//! rosrust binary only converts messages and calls this, so every rule here
//! (stale scan → stop, e-stop latch, filter toggle, nominal source) is unit
//! tested in microseconds.
//!
//! Nominal command, in order of precedence (`nominal_source: auto`):
//! 1. `cmd_vel_in` (teleop, a planner). Once one has arrived the node stays in
//!    this mode: if it goes stale the nominal is zero. A silent planner must
//!    never turn into "drive straight at v_nom".
//! 2. The configured reference trajectory, tracked with odometry (stop
//!    without fresh odometry).
//! 3. Straight ahead at `control.v_nom_mps` (the paper's line test).

use crate::algo::geometry::{Pose2, Twist};
use crate::algo::pipeline::SafetyPipeline;
use crate::algo::record::{StepRecord, StopCause};
use crate::algo::reference::{ReferenceProgress, ReferenceTrajectory};
use crate::algo::scan::LaserScan;
use crate::algo::tracking::{track, TrackingError};
use crate::algo::Params;
use serde::{Deserialize, Serialize};
use std::fmt;

/// Where the nominal command comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NominalSource {
    /// cmd_vel_in if one has ever arrived, else the reference, else v_nom.
    Auto,
    /// Only cmd_vel_in (zero while none is fresh).
    CmdVelIn,
    /// Only the reference trajectory (zero without fresh odometry).
    Reference,
    /// Straight ahead at control.v_nom_mps.
    Constant,
}

/// Node settings beyond the algorithm parameters (`config/oldbf_node.yaml`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeSettings {
    /// Frame of the robot base, for markers and the state header.
    pub base_frame: String,
    pub nominal_source: NominalSource,
    /// An upstream command older than this is stale (s).
    pub cmd_in_timeout_s: f64,
    /// Odometry older than this is ignored (s).
    pub odom_timeout_s: f64,
    /// Publish ~markers for rviz.
    pub publish_markers: bool,
    /// Scenario file whose nominal command (and `oldbf:` overrides) this node
    /// uses, as in the simulator; empty for none.
    pub scenario: String,
    /// Robot in a multi-robot scenario (empty: the scenario's single robot).
    pub robot: String,
}

impl Default for NodeSettings {
    fn default() -> Self {
        Self {
            base_frame: "base_link".into(),
            nominal_source: NominalSource::Auto,
            cmd_in_timeout_s: 0.5,
            odom_timeout_s: 0.5,
            publish_markers: true,
            scenario: String::new(),
            robot: String::new(),
        }
    }
}

impl NodeSettings {
    /// Range checks, naming the key (under `node.`).
    pub fn validate(&self) -> Result<(), String> {
        for (key, v) in [
            ("node.cmd_in_timeout_s", self.cmd_in_timeout_s),
            ("node.odom_timeout_s", self.odom_timeout_s),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= 60.0) {
                return Err(format!("key `{key}` = {v} is out of range; allowed: (0, 60] s"));
            }
        }
        if self.base_frame.is_empty() {
            return Err("key `node.base_frame` must not be empty".into());
        }
        Ok(())
    }
}

/// Latest odometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdomSample {
    pub pose: Pose2,
    pub twist: Twist,
    /// When it arrived (s, node clock).
    pub received_s: f64,
}

/// The latest scan, owned (buffers reused: no allocation in steady state).
#[derive(Debug, Clone, Default)]
struct OwnedScan {
    stamp_s: f64,
    angle_min_rad: f32,
    angle_increment_rad: f32,
    range_min_m: f32,
    range_max_m: f32,
    ranges_m: Vec<f32>,
    intensities: Vec<f32>,
}

/// Header fields of an incoming scan (the ranges are passed separately).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanMeta {
    pub stamp_s: f64,
    pub angle_min_rad: f32,
    pub angle_increment_rad: f32,
    pub range_min_m: f32,
    pub range_max_m: f32,
}

/// Which nominal source produced this tick's nominal command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NominalUsed {
    CmdVelIn,
    CmdVelInStale,
    Reference,
    ReferenceNoOdom,
    Constant,
}

impl fmt::Display for NominalUsed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::CmdVelIn => "cmd_vel_in",
            Self::CmdVelInStale => "cmd_vel_in (stale: zero)",
            Self::Reference => "reference",
            Self::ReferenceNoOdom => "reference (no odometry: zero)",
            Self::Constant => "constant v_nom",
        })
    }
}

/// One control tick's result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tick {
    /// The command to publish on cmd_vel: finite, always.
    pub cmd: Twist,
    /// The pipeline's record (monitoring even when the filter is disabled).
    pub record: StepRecord,
    pub nominal_used: NominalUsed,
    pub filter_enabled: bool,
    pub e_stop: bool,
    /// Stamp of the scan used (NaN if none).
    pub scan_stamp_s: f64,
}

/// The node's state between ticks.
#[derive(Debug, Clone)]
pub struct NodeCore {
    pipeline: SafetyPipeline,
    settings: NodeSettings,
    scan: OwnedScan,
    have_scan: bool,
    odom: Option<OdomSample>,
    cmd_in: Option<(Twist, f64)>,
    upstream_seen: bool,
    e_stop_latched: bool,
    e_stop_input: bool,
    enabled: bool,
    reference: Option<(ReferenceTrajectory, ReferenceProgress)>,
    /// The constant nominal command (default: v_nom straight ahead).
    constant: Twist,
    last_tick_s: Option<f64>,
}

impl NodeCore {
    /// The tracked obstacles on a collision course at the last tick (robot frame).
    pub fn threats(&self) -> &[crate::algo::pipeline::Threat] {
        self.pipeline.threats()
    }

    pub fn new(params: Params, settings: NodeSettings, reference: Option<ReferenceTrajectory>) -> Self {
        let constant = Twist::new(params.control.v_nom_mps, 0.0);
        Self {
            constant,
            pipeline: SafetyPipeline::new(params),
            settings,
            scan: OwnedScan::default(),
            have_scan: false,
            odom: None,
            cmd_in: None,
            upstream_seen: false,
            e_stop_latched: false,
            e_stop_input: false,
            enabled: true,
            reference: reference.map(|r| (r, ReferenceProgress::default())),
            last_tick_s: None,
        }
    }

    /// Replaces the constant nominal command (a scenario's `kind: constant`).
    pub fn with_constant(mut self, constant: Twist) -> Self {
        self.constant = constant;
        self
    }

    pub fn params(&self) -> &Params {
        self.pipeline.params()
    }

    pub fn settings(&self) -> &NodeSettings {
        &self.settings
    }

    /// Valid points of the last accepted scan (robot frame), for markers.
    pub fn points(&self) -> &[nalgebra::Vector2<f64>] {
        self.pipeline.points()
    }

    pub fn reference(&self) -> Option<&ReferenceTrajectory> {
        self.reference.as_ref().map(|(r, _)| r)
    }

    /// Whether the reference trajectory has been run to its end.
    pub fn reference_finished(&self) -> bool {
        self.reference.as_ref().is_some_and(|(r, p)| p.finished(r))
    }

    /// Stores a scan (copied into reused buffers).
    pub fn on_scan(&mut self, meta: ScanMeta, ranges_m: &[f32], intensities: &[f32]) {
        let s = &mut self.scan;
        s.stamp_s = meta.stamp_s;
        s.angle_min_rad = meta.angle_min_rad;
        s.angle_increment_rad = meta.angle_increment_rad;
        s.range_min_m = meta.range_min_m;
        s.range_max_m = meta.range_max_m;
        s.ranges_m.clear();
        s.ranges_m.extend_from_slice(ranges_m);
        s.intensities.clear();
        s.intensities.extend_from_slice(intensities);
        self.have_scan = true;
    }

    pub fn on_odom(&mut self, pose: Pose2, twist: Twist, now_s: f64) {
        if pose.is_finite() && twist.is_finite() {
            self.odom = Some(OdomSample {
                pose,
                twist,
                received_s: now_s,
            });
        }
    }

    /// An upstream command (non-finite ones are stored as they are: the
    /// pipeline turns a non-finite nominal into a reported stop).
    pub fn on_cmd_in(&mut self, twist: Twist, now_s: f64) {
        self.cmd_in = Some((twist, now_s));
        self.upstream_seen = true;
    }

    /// The e-stop input. `true` latches; the latch stays after the input
    /// returns to `false` until `reset_e_stop`.
    pub fn on_e_stop(&mut self, active: bool) {
        self.e_stop_input = active;
        if active {
            if !self.e_stop_latched {
                log::warn!("e-stop latched");
            }
            self.e_stop_latched = true;
        }
    }

    /// Releases a latched e-stop, if its input is no longer active.
    pub fn reset_e_stop(&mut self) -> Result<(), &'static str> {
        if self.e_stop_input {
            return Err("the e-stop input is still active");
        }
        if self.e_stop_latched {
            log::info!("e-stop released");
        }
        self.e_stop_latched = false;
        self.pipeline.reset();
        Ok(())
    }

    pub fn e_stop_latched(&self) -> bool {
        self.e_stop_latched
    }

    /// Enables or disables the filter (disabled: the nominal command passes
    /// through unchanged, still monitored and reported).
    pub fn set_enabled(&mut self, enabled: bool) {
        if enabled != self.enabled {
            log::warn!(
                "safety filter {}",
                if enabled { "ENABLED" } else { "DISABLED: pass-through" }
            );
            self.pipeline.reset();
        }
        self.enabled = enabled;
    }

    pub fn enabled(&self) -> bool {
        self.enabled
    }

    fn fresh_odom(&self, now_s: f64) -> Option<OdomSample> {
        self.odom
            .filter(|o| now_s - o.received_s <= self.settings.odom_timeout_s)
    }

    fn nominal(&mut self, now_s: f64, dt_s: f64) -> (Twist, NominalUsed) {
        let use_upstream = match self.settings.nominal_source {
            NominalSource::CmdVelIn => true,
            NominalSource::Auto => self.upstream_seen,
            _ => false,
        };
        if use_upstream {
            return match self.cmd_in {
                Some((t, at)) if now_s - at <= self.settings.cmd_in_timeout_s => (t, NominalUsed::CmdVelIn),
                _ => (Twist::ZERO, NominalUsed::CmdVelInStale),
            };
        }
        let use_reference = matches!(
            self.settings.nominal_source,
            NominalSource::Reference | NominalSource::Auto
        ) && self.reference.is_some();
        if use_reference {
            let odom = self.fresh_odom(now_s);
            let params = self.pipeline.params().tracking.clone();
            let (reference, progress) = self.reference.as_mut().expect("checked above");
            return match odom {
                Some(o) => {
                    let e = TrackingError::between(o.pose, reference.pose_at(progress.t_s)).distance_m();
                    let rate = ReferenceProgress::rate(e, params.capture_radius_m);
                    let (ref_pose, ref_twist) = progress.reference(reference, rate);
                    progress.advance(dt_s, rate);
                    (track(o.pose, ref_pose, ref_twist, &params), NominalUsed::Reference)
                }
                None => (Twist::ZERO, NominalUsed::ReferenceNoOdom),
            };
        }
        (
            Twist::new(self.pipeline.params().control.v_nom_mps, 0.0),
            NominalUsed::Constant,
        )
    }

    /// One control tick at time `now_s` (the node's clock, same as scan stamps).
    pub fn tick(&mut self, now_s: f64) -> Tick {
        let dt = match self.last_tick_s {
            Some(t) if now_s > t => (now_s - t).min(1.0),
            _ => self.pipeline.params().control.dt_s(),
        };
        self.last_tick_s = Some(now_s);
        let (nominal, nominal_used) = self.nominal(now_s, dt);
        let odom = self.fresh_odom(now_s);
        let v_now = odom.map_or(f64::NAN, |o| o.twist.v_mps);

        let record = if !self.have_scan {
            self.pipeline.stop(now_s, nominal, StopCause::NoScan)
        } else {
            let s = &self.scan;
            let scan = LaserScan {
                stamp_s: s.stamp_s,
                angle_min_rad: s.angle_min_rad,
                angle_increment_rad: s.angle_increment_rad,
                range_min_m: s.range_min_m,
                range_max_m: s.range_max_m,
                ranges_m: &s.ranges_m,
                intensities: &s.intensities,
            };
            self.pipeline
                .step_with_pose(&scan, now_s, nominal, v_now, odom.map(|o| o.pose))
        };
        let scan_stamp_s = if self.have_scan { self.scan.stamp_s } else { f64::NAN };

        let (cmd, record) = if self.e_stop_latched {
            (
                Twist::ZERO,
                StepRecord {
                    stop_cause: Some(StopCause::EStop),
                    cmd: Twist::ZERO,
                    ..record
                },
            )
        } else if !self.enabled {
            // Pass-through, but a robot that receives garbage still stops.
            (if nominal.is_finite() { nominal } else { Twist::ZERO }, record)
        } else {
            (record.cmd, record)
        };
        Tick {
            cmd,
            record,
            nominal_used,
            filter_enabled: self.enabled,
            e_stop: self.e_stop_latched,
            scan_stamp_s,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::doaa::DoaaState;
    use crate::algo::scan::ScanRejection;
    use std::f32::consts::PI;

    fn meta(stamp: f64) -> ScanMeta {
        ScanMeta {
            stamp_s: stamp,
            angle_min_rad: -PI,
            angle_increment_rad: 2.0 * PI / 360.0,
            range_min_m: 0.12,
            range_max_m: 3.5,
        }
    }

    fn open() -> Vec<f32> {
        vec![f32::INFINITY; 360]
    }

    fn node(source: NominalSource) -> NodeCore {
        let settings = NodeSettings {
            nominal_source: source,
            ..NodeSettings::default()
        };
        NodeCore::new(Params::default(), settings, None)
    }

    #[test]
    fn no_scan_yet_means_stop() {
        let mut n = node(NominalSource::Constant);
        let t = n.tick(1.0);
        assert_eq!(t.cmd, Twist::ZERO);
        assert_eq!(t.record.stop_cause, Some(StopCause::NoScan));
        assert_eq!(t.record.state, DoaaState::Stop);
    }

    #[test]
    fn constant_nominal_in_free_space_then_stale_scan_stops() {
        let mut n = node(NominalSource::Constant);
        n.on_scan(meta(1.0), &open(), &[]);
        let t = n.tick(1.05);
        assert_eq!(t.cmd, Twist::new(0.15, 0.0));
        assert_eq!(t.nominal_used, NominalUsed::Constant);
        // No new scan: at 1.5 s still fresh (timeout 0.5 s), at 1.51 s stale.
        assert_eq!(n.tick(1.5).cmd, Twist::new(0.15, 0.0));
        let t = n.tick(1.51);
        assert_eq!(t.cmd, Twist::ZERO);
        assert!(matches!(
            t.record.stop_cause,
            Some(StopCause::Rejected(ScanRejection::Stale { .. }))
        ));
        // A fresh scan resumes.
        n.on_scan(meta(1.6), &open(), &[]);
        assert_eq!(n.tick(1.62).cmd, Twist::new(0.15, 0.0));
    }

    #[test]
    fn upstream_command_is_filtered_and_never_replaced_by_v_nom() {
        let mut n = node(NominalSource::Auto);
        n.on_scan(meta(1.0), &open(), &[]);
        assert_eq!(n.tick(1.0).nominal_used, NominalUsed::Constant);
        n.on_cmd_in(Twist::new(0.1, 0.2), 1.0);
        let t = n.tick(1.1);
        assert_eq!((t.cmd, t.nominal_used), (Twist::new(0.1, 0.2), NominalUsed::CmdVelIn));
        // The planner goes silent: zero, not v_nom.
        n.on_scan(meta(1.7), &open(), &[]);
        let t = n.tick(1.7);
        assert_eq!((t.cmd, t.nominal_used), (Twist::ZERO, NominalUsed::CmdVelInStale));
    }

    #[test]
    fn e_stop_latches_until_reset_after_release() {
        let mut n = node(NominalSource::Constant);
        n.on_scan(meta(1.0), &open(), &[]);
        n.on_e_stop(true);
        assert_eq!(n.tick(1.0).cmd, Twist::ZERO);
        assert!(n.reset_e_stop().is_err(), "input still active");
        n.on_e_stop(false);
        let t = n.tick(1.1);
        assert_eq!(t.cmd, Twist::ZERO, "still latched after the input is released");
        assert_eq!(t.record.stop_cause, Some(StopCause::EStop));
        assert!(t.e_stop);
        n.reset_e_stop().unwrap();
        assert_eq!(n.tick(1.2).cmd, Twist::new(0.15, 0.0));
    }

    #[test]
    fn disabled_filter_passes_through_but_still_monitors() {
        let mut n = node(NominalSource::CmdVelIn);
        // A wall 0.3 m ahead: the filter would stop forward motion.
        let mut ranges = open();
        for r in &mut ranges[170..=190] {
            *r = 0.3;
        }
        n.on_scan(meta(1.0), &ranges, &[]);
        n.on_cmd_in(Twist::new(0.2, 0.0), 1.0);
        assert!(n.tick(1.0).cmd.v_mps <= 0.0);
        n.set_enabled(false);
        let t = n.tick(1.1);
        assert_eq!(t.cmd, Twist::new(0.2, 0.0));
        assert!(!t.filter_enabled);
        assert!(t.record.h_m < 0.0, "still measured: {:?}", t.record);
        // Garbage still stops.
        n.on_cmd_in(Twist::new(f64::NAN, 0.0), 1.1);
        assert_eq!(n.tick(1.15).cmd, Twist::ZERO);
    }

    #[test]
    fn reference_needs_odometry() {
        let r = ReferenceTrajectory::line(Pose2::default(), 0.15, 2.0);
        let mut n = NodeCore::new(Params::default(), NodeSettings::default(), Some(r));
        n.on_scan(meta(1.0), &open(), &[]);
        let t = n.tick(1.0);
        assert_eq!((t.cmd, t.nominal_used), (Twist::ZERO, NominalUsed::ReferenceNoOdom));
        n.on_odom(Pose2::default(), Twist::ZERO, 1.0);
        let t = n.tick(1.1);
        assert_eq!(t.nominal_used, NominalUsed::Reference);
        assert!((t.cmd.v_mps - 0.15).abs() < 1e-9, "{t:?}");
        // Odometry goes stale: zero.
        n.on_scan(meta(1.8), &open(), &[]);
        assert_eq!(n.tick(1.8).nominal_used, NominalUsed::ReferenceNoOdom);
    }

    #[test]
    fn settings_are_range_checked() {
        let s = NodeSettings {
            cmd_in_timeout_s: 0.0,
            ..NodeSettings::default()
        };
        assert!(s.validate().unwrap_err().contains("node.cmd_in_timeout_s"));
        assert!(NodeSettings::default().validate().is_ok());
    }
}
