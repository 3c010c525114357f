//! The safety node's logic without ROS: what oldbf_node decides at every
//! tick from the latest scan, odometry and upstream command. The rosrust
//! binary only converts messages and calls this, so every rule here (stale
//! scan → stop, e-stop latch, filter toggle, nominal source) is unit tested
//! in microseconds.
//!
//! When it ticks: on every scan and every upstream command as it arrives (the
//! command goes out at once, not at the next timer tick), and from a watchdog
//! whenever nothing has gone out for about a control period
//! ([`NodeCore::watchdog_due`]), so cmd_vel keeps coming, and turns into a
//! stop, when the scans do not. Every tick applies the same rules, whatever
//! triggered it.
//!
//! The safety layer never originates motion on a robot (ALGORITHM §5c): with
//! no upstream command the nominal is zero. Nominal command, in order of
//! precedence (`nominal_source: auto`, what the simulator's robots use):
//! 1. `cmd_vel_in` (teleop, a planner). Once one has arrived the node stays in
//!    this mode: if it goes stale the nominal is zero. A silent planner must
//!    never turn into "drive straight at v_nom".
//! 2. The scenario's reference trajectory, tracked with odometry (stop
//!    without fresh odometry), or the scenario's constant command.
//! 3. Zero.
//!
//! `nominal_source: cmd_vel_in` (the shipped default, and what the robot
//! launch files use) takes only 1; `constant` drives straight at the
//! scenario's constant command or `control.v_nom_mps` (the paper's line
//! test), and exists only for an explicit request.
//!
//! Scan order (ours, beyond the pipeline's per-scan checks): a scan whose
//! stamp is not newer than the newest one already taken (the same stamp
//! again: a frozen driver; an older one: out of order) is treated as stale.
//! The node stops, reports [`ScanFault`], and resumes on the next scan newer
//! than every one before. The node's clock going backwards drops the scan
//! in hand and the stamp history (scans from before the jump cannot be
//! aged), stops and reports, and holds the stop for `scan_timeout_s` on the
//! new clock before it takes scans again: the tracker's and odometry's
//! velocities re-acquire, and a LiDAR that keeps publishing cannot turn the
//! stop into a single tick that never shows on the wheels.
//!
//! Locks that lapse (twist_mux's locks, safety_limiter's disable): with
//! `e_stop_timeout_s` above 0 the `e_stop` input must be alive, and a
//! publisher silent for longer than the timeout, or none heard yet, engages
//! the stop until a fresh `false` arrives ([`EStopSilence`]); with
//! `disable_timeout_s` above 0 a `~enable false` lasts that long unless
//! renewed, then the filter is on again. Both at 0 (the shipped default)
//! keep the plain rules: `true` latches until reset, a disable lasts until
//! `~enable true`. A clock jump backwards keeps the age of the last e_stop
//! message and the time a disable has left: both are measured across it.

use crate::algo::geometry::{Pose2, Twist};
use crate::algo::params::ParamError;
use crate::algo::pipeline::SafetyPipeline;
use crate::algo::record::{StepRecord, StopCause};
use crate::algo::reference::{ReferenceProgress, ReferenceTrajectory};
use crate::algo::scan::{LaserMount, LaserScan, ScanHeader, ScanRejection};
use crate::algo::scan_merge::{ScanMerger, ScannerSpec, ScannerState};
use crate::algo::tracking::{towards_point, track};
use crate::algo::unstuck::Guidance;
use crate::algo::Params;
use crate::route_worker::RouteWorker;
use oldbf::config::{Checker, Interval, Validate};
use serde::{Deserialize, Serialize};
use std::fmt;

/// Where the nominal command comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NominalSource {
    /// cmd_vel_in if one has ever arrived, else the scenario's reference or
    /// constant command, else zero.
    Auto,
    /// Only cmd_vel_in (zero while none is fresh): the default on a robot.
    CmdVelIn,
    /// Only the reference trajectory (zero without fresh odometry).
    Reference,
    /// The scenario's constant command, or straight ahead at
    /// control.v_nom_mps: only where explicitly asked for.
    Constant,
}

/// Where a scan's laser sits on the robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LaserPoseSource {
    /// The transform from the scan's `frame_id` to `base_frame` on /tf and
    /// /tf_static at the scan's stamp (a URDF through robot_state_publisher):
    /// none, or a stale one, makes the scan's view unknown and the robot stops.
    Tf,
    /// As `tf`, but while tf has never named the scan's frame the YAML
    /// mount (`laser.mount_*`) places it; a transform once heard always wins,
    /// and a stale one still stops the robot.
    TfElseYaml,
    /// The YAML mount only; the scan's `frame_id` is not looked up (the
    /// simulator, and a robot without tf).
    Yaml,
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
    /// Liveness of the `e_stop` input (s). 0: off, a `true` latches until
    /// reset and silence changes nothing. Above 0: an e_stop publisher
    /// silent for longer than this, or none heard since start-up, engages
    /// the stop; a fresh `false` releases it (no reset needed, a `true`
    /// still latches).
    pub e_stop_timeout_s: f64,
    /// How long a `~enable false` lasts unless renewed by another (s); 0:
    /// until `~enable true`.
    pub disable_timeout_s: f64,
    /// Plan the way round beside the safety path, in a thread of its own
    /// at `unstuck.plan_period_s` (the node); false: in step with the scans
    /// (the simulator, reproducible).
    pub plan_beside: bool,
    /// `hardware_id` of the node's /diagnostics status. Empty: the
    /// `frame_id` of the latest scan (the LiDAR it watches), or the node's
    /// name before the first scan.
    pub hardware_id: String,
    /// The base's limits (`config/base_limits.yaml`) the filter's settings
    /// must not exceed; empty: none checked.
    pub base_limits_file: String,
    /// Where each scan's laser sits: tf (the default on a robot) or the
    /// YAML mount.
    pub laser_pose: LaserPoseSource,
    /// How far a moving transform's newest sample may be from the scan's
    /// stamp (s) before the laser's pose counts as unknown; static
    /// transforms never age.
    pub tf_tolerance_s: f64,
    /// Several scanners (front and rear), each placed by tf, merged into one
    /// scan around the base (`algo::scan_merge`); empty: the one `scan` topic.
    pub scans: Vec<ScanInput>,
    /// Beams of the merged scan over a full turn (several scanners).
    pub merged_beams: usize,
    /// A ROS parameter holding a footprint in costmap_2d's format (a list
    /// of `[x, y]` or its string form), e.g. move_base's
    /// `/move_base/local_costmap/footprint`, read at start-up as
    /// `footprint.polygon_m`; empty: none.
    pub footprint_param: String,
}

/// One scanner of `node.scans`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScanInput {
    /// Its sensor_msgs/LaserScan topic (relative names resolve in the node's namespace).
    pub topic: String,
    /// Its view is unknown once its newest scan is older than this (s).
    pub timeout_s: f64,
    /// Its driver writes 0.0 for "no return" (TurtleBot3's LDS).
    #[serde(default)]
    pub zero_is_no_return: bool,
}

impl Default for NodeSettings {
    fn default() -> Self {
        Self {
            base_frame: "base_link".into(),
            nominal_source: NominalSource::CmdVelIn,
            cmd_in_timeout_s: 0.5,
            odom_timeout_s: 0.5,
            publish_markers: true,
            scenario: String::new(),
            robot: String::new(),
            e_stop_timeout_s: 0.0,
            disable_timeout_s: 0.0,
            plan_beside: true,
            hardware_id: String::new(),
            base_limits_file: String::new(),
            laser_pose: LaserPoseSource::Tf,
            tf_tolerance_s: 0.2,
            scans: Vec::new(),
            merged_beams: 1440,
            footprint_param: String::new(),
        }
    }
}

impl NodeSettings {
    /// The settings of a simulated robot: `auto`, so the scenario's reference
    /// or constant command is the nominal until an upstream command arrives.
    pub fn for_scenario() -> Self {
        Self {
            nominal_source: NominalSource::Auto,
            plan_beside: false,
            laser_pose: LaserPoseSource::Yaml,
            ..Self::default()
        }
    }
}

/// The range of `node.*_timeout_s` (s).
pub const NODE_TIMEOUT_S: Interval = Interval::open_closed(0.0, 60.0).unit("s");

/// The range of `node.tf_tolerance_s` (s).
pub const TF_TOLERANCE_S: Interval = Interval::closed(0.0, 5.0).unit("s");

/// The range of `node.merged_beams`: a quarter degree by default, up to the
/// filter's beam limit's order.
pub const MERGED_BEAMS: Interval = Interval::closed(360.0, 8192.0);

/// The range of `node.e_stop_timeout_s` (s; 0: liveness off).
pub const E_STOP_TIMEOUT_S: Interval = Interval::closed(0.0, 60.0).unit("s");

/// The range of `node.disable_timeout_s` (s; 0: a disable never lapses). An
/// hour bounds a forgotten disable; docking or a longer manoeuvre renews it.
pub const DISABLE_TIMEOUT_S: Interval = Interval::closed(0.0, 3600.0).unit("s");

impl Validate for NodeSettings {
    /// Range checks, keys under `node.`.
    fn check(&self, c: &mut Checker) {
        c.range("node.cmd_in_timeout_s", self.cmd_in_timeout_s, NODE_TIMEOUT_S);
        c.range("node.odom_timeout_s", self.odom_timeout_s, NODE_TIMEOUT_S);
        c.rule(
            !self.base_frame.is_empty(),
            "node.base_frame",
            format_args!("{:?}", self.base_frame),
            "a frame name, not empty",
        );
        c.range("node.e_stop_timeout_s", self.e_stop_timeout_s, E_STOP_TIMEOUT_S);
        c.range("node.disable_timeout_s", self.disable_timeout_s, DISABLE_TIMEOUT_S);
        c.range("node.tf_tolerance_s", self.tf_tolerance_s, TF_TOLERANCE_S);
        c.range("node.merged_beams", self.merged_beams as f64, MERGED_BEAMS);
        for (i, s) in self.scans.iter().enumerate() {
            c.range(&format!("node.scans[{i}].timeout_s"), s.timeout_s, NODE_TIMEOUT_S);
            c.rule(
                !s.topic.is_empty() && !s.topic.chars().any(char::is_whitespace),
                &format!("node.scans[{i}].topic"),
                format_args!("{:?}", s.topic),
                "a topic name",
            );
        }
        c.rule(
            self.scans.is_empty() || self.laser_pose != LaserPoseSource::Yaml,
            "node.laser_pose",
            "yaml",
            "tf or tf_else_yaml with several scanners (node.scans): each is placed by its own frame",
        );
        c.rule(
            !self
                .footprint_param
                .chars()
                .any(|ch| ch.is_whitespace() || ch.is_control()),
            "node.footprint_param",
            format_args!("{:?}", self.footprint_param),
            "a parameter name (empty: none)",
        );
        // Shown on one line by rqt_robot_monitor and the aggregator.
        c.rule(
            !self.hardware_id.chars().any(char::is_control),
            "node.hardware_id",
            format_args!("{:?}", self.hardware_id),
            "one line of text, no control characters (empty: the scan's frame_id)",
        );
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
    /// `None` until a scan is taken, and again after the clock jumped back.
    header: Option<ScanHeader>,
    /// The pipeline has not perceived this scan yet (or rejected it, and may
    /// take it later): the next tick gives it to the pipeline.
    new: bool,
    ranges_m: Vec<f32>,
    intensities: Vec<f32>,
}

/// Why the node stops on a scan that the pipeline alone would accept: the
/// stamp sequence says the data is not new.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ScanFault {
    /// The newest stamp arrived again (`repeats` times): a frozen sensor or driver.
    Repeated { stamp_s: f64, repeats: u32 },
    /// A scan older than one already taken.
    OutOfOrder { stamp_s: f64, newest_s: f64 },
    /// The node's clock went back by `by_s` seconds; no scan from after the jump yet.
    ClockJumpedBack { by_s: f64 },
    /// The scan stamped `stamp_s` could not be placed on the robot: tf has
    /// no (fresh, level) transform from its frame to the base frame. Its view
    /// is unknown (the frames are in the node's log and diagnostics).
    NoLaserPose { stamp_s: f64, why: PoseFault },
}

/// Why a scan's laser has no pose (`node.laser_pose: tf`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PoseFault {
    /// tf has no transform between the two frames.
    NoTransform,
    /// The newest transform is `age_s` from the scan's stamp.
    Stale { age_s: f64 },
    /// The transform does not place a planar scan (tilted, garbage).
    Mount(crate::algo::MountError),
}

impl fmt::Display for PoseFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoTransform => write!(f, "no transform to the base frame"),
            Self::Stale { age_s } => write!(f, "the transform is {age_s:.3} s from the scan's stamp"),
            Self::Mount(e) => write!(f, "{e}"),
        }
    }
}

impl ScanFault {
    /// Short machine-readable name (diagnostics, logs).
    pub fn code(&self) -> &'static str {
        match self {
            Self::Repeated { .. } => "frozen_stamp",
            Self::OutOfOrder { .. } => "out_of_order",
            Self::ClockJumpedBack { .. } => "clock_jumped_back",
            Self::NoLaserPose { .. } => "no_laser_pose",
        }
    }
}

impl fmt::Display for ScanFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Repeated { stamp_s, repeats } => write!(
                f,
                "scan stamp {stamp_s:.3} s repeated {repeats} time(s): frozen sensor, treated as stale"
            ),
            Self::OutOfOrder { stamp_s, newest_s } => write!(
                f,
                "scan stamped {stamp_s:.3} s arrived after one stamped {newest_s:.3} s: out of order, treated as stale"
            ),
            Self::ClockJumpedBack { by_s } => write!(
                f,
                "clock jumped back {by_s:.3} s: scans from before the jump dropped, waiting for a new one"
            ),
            Self::NoLaserPose { stamp_s, why } => write!(
                f,
                "scan stamped {stamp_s:.3} s has no laser pose ({why}): its view is unknown, treated as stale"
            ),
        }
    }
}

/// Why the `e_stop` input counts as engaged in liveness mode
/// (`e_stop_timeout_s` > 0) without a `true` on it: a lock whose publisher
/// cannot be heard cannot be trusted to say it is released.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EStopSilence {
    /// No e_stop message since the node started: engaged until the first
    /// `false`, so a robot never runs before its e-stop is heard.
    NoneYet { timeout_s: f64 },
    /// The last e_stop message is `age_s` old, more than `timeout_s`.
    Silent { age_s: f64, timeout_s: f64 },
}

impl fmt::Display for EStopSilence {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::NoneYet { timeout_s } => write!(
                f,
                "e_stop not heard yet (liveness timeout {timeout_s:.3} s): stopped until a false arrives"
            ),
            Self::Silent { age_s, timeout_s } => write!(
                f,
                "e_stop silent for {age_s:.3} s (liveness timeout {timeout_s:.3} s): stopped until a fresh false arrives"
            ),
        }
    }
}

/// Why `~reset_e_stop` did not release the e-stop.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum ResetRefused {
    #[error("the e-stop input is still active")]
    InputActive,
    /// Liveness mode: the input is not heard, and silence is not a release.
    #[error("{0}")]
    InputSilent(EStopSilence),
}

/// How often a control period the watchdog checks [`NodeCore::watchdog_due`].
pub const WATCHDOG_POLLS_PER_PERIOD: u32 = 4;

/// Which nominal source produced this tick's nominal command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NominalUsed {
    CmdVelIn,
    CmdVelInStale,
    Reference,
    ReferenceNoOdom,
    Constant,
    /// `auto` with no upstream command, no reference and no constant: zero.
    NoUpstream,
}

impl fmt::Display for NominalUsed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::CmdVelIn => "cmd_vel_in",
            Self::CmdVelInStale => "cmd_vel_in (stale: zero)",
            Self::Reference => "reference",
            Self::ReferenceNoOdom => "reference (no odometry: zero)",
            Self::Constant => "constant",
            Self::NoUpstream => "no upstream command: zero",
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
    /// When a `~enable false` lapses (s, node clock); `None` while the
    /// filter is on, or when a disable lasts until `~enable true`.
    pub disable_lapses_at_s: Option<f64>,
    /// The e-stop is engaged: latched by a `true`, or its input silent.
    pub e_stop: bool,
    /// A `true` latched it (released by `~reset_e_stop`).
    pub e_stop_latched: bool,
    /// Liveness mode: the input is silent (released by a fresh `false`).
    pub e_stop_silence: Option<EStopSilence>,
    /// Stamp of the scan used (NaN if none).
    pub scan_stamp_s: f64,
    /// Set when the stamp sequence stopped the robot (reported with the stop).
    pub scan_fault: Option<ScanFault>,
    /// The (governed) reference pose the tracking law followed this tick;
    /// `None` when the nominal did not come from the reference.
    pub reference_pose: Option<Pose2>,
}

impl Tick {
    /// Why the robot is stopped, with the scan-order fault when that is the
    /// cause; empty when it is not.
    pub fn stop_reason(&self) -> String {
        if let (Some(StopCause::EStop), Some(silence)) = (self.record.stop_cause, self.e_stop_silence) {
            return if self.e_stop_latched {
                format!("e-stop latched, and {silence}")
            } else {
                silence.to_string()
            };
        }
        match (self.record.stop_cause, self.scan_fault) {
            (Some(_), Some(f)) => f.to_string(),
            (Some(c), None) => c.to_string(),
            (None, _) => String::new(),
        }
    }

    /// The log line for this tick's status, saying what was sent: a stop,
    /// or (no admissible command) the least-bad command that moves the robot,
    /// or filtering.
    pub fn status_line(&self) -> String {
        let Twist { v_mps, omega_radps } = self.cmd;
        match self.record.stop_cause {
            Some(_) if self.cmd == Twist::ZERO => format!("commanding a stop: {}", self.stop_reason()),
            Some(_) => format!(
                "{}: sending the least-bad command, v = {v_mps:.3} m/s, ω = {omega_radps:.3} rad/s",
                self.stop_reason()
            ),
            None => format!("filtering ({})", self.nominal_used),
        }
    }
}

/// The node's state between ticks.
#[derive(Debug)]
pub struct NodeCore {
    pipeline: SafetyPipeline,
    /// Several scanners merged into one scan (`node.scans`), or None.
    merger: Option<ScanMerger>,
    /// The way-round planner beside the safety path (`node.plan_beside`).
    route_worker: Option<RouteWorker>,
    settings: NodeSettings,
    scan: OwnedScan,
    odom: Option<OdomSample>,
    cmd_in: Option<(Twist, f64)>,
    upstream_seen: bool,
    e_stop_latched: bool,
    e_stop_input: bool,
    /// When the last e_stop message arrived (s, node clock); `None`: none yet.
    e_stop_heard_s: Option<f64>,
    /// The input's silence engaged the stop at the last tick (logged on change).
    e_stop_was_silent: bool,
    enabled: bool,
    /// When the running `~enable false` lapses (s, node clock).
    disabled_until_s: Option<f64>,
    reference: Option<(ReferenceTrajectory, ReferenceProgress)>,
    /// The constant nominal command; `None`: control.v_nom_mps straight
    /// ahead, read at each tick so a reconfigured v_nom applies at once.
    constant: Option<Twist>,
    /// Ticks come exactly once per control period (a simulator's clock).
    fixed_period: bool,
    last_tick_s: Option<f64>,
    /// Newest scan stamp taken (s): later scans must be newer.
    newest_stamp_s: Option<f64>,
    scan_fault: Option<ScanFault>,
    /// After a clock jump backwards: (stopped until this time on the new
    /// clock (s), the jump (s)).
    settle_after_jump: Option<(f64, f64)>,
}

impl NodeCore {
    /// The tracked obstacles on a collision course at the last tick (robot frame).
    pub fn threats(&self) -> &[crate::algo::pipeline::Threat] {
        self.pipeline.threats()
    }

    pub fn new(params: Params, settings: NodeSettings, reference: Option<ReferenceTrajectory>) -> Self {
        let mut pipeline = SafetyPipeline::new(params);
        // Beside the safety path: a thread of its own; if it cannot start, plan in step.
        let route_worker = settings
            .plan_beside
            .then(|| RouteWorker::start(pipeline.params()))
            .and_then(|w| {
                w.map_err(|e| log::warn!("route planner thread: {e}; planning in step"))
                    .ok()
            });
        pipeline.plan_beside(route_worker.is_some());
        let merger = (!settings.scans.is_empty()).then(|| {
            // The merged scan is around the base's origin.
            pipeline.set_laser_mount(LaserMount::upright(Pose2::default()));
            let specs: Vec<ScannerSpec> = settings
                .scans
                .iter()
                .map(|s| ScannerSpec {
                    timeout_s: s.timeout_s,
                    zero_is_no_return: s.zero_is_no_return,
                })
                .collect();
            ScanMerger::new(&specs, settings.merged_beams)
        });
        Self {
            merger,
            constant: None,
            fixed_period: false,
            pipeline,
            route_worker,
            settings,
            scan: OwnedScan::default(),
            odom: None,
            cmd_in: None,
            upstream_seen: false,
            e_stop_latched: false,
            e_stop_input: false,
            e_stop_heard_s: None,
            e_stop_was_silent: false,
            enabled: true,
            disabled_until_s: None,
            reference: reference.map(|r| (r, ReferenceProgress::default())),
            last_tick_s: None,
            newest_stamp_s: None,
            scan_fault: None,
            settle_after_jump: None,
        }
    }

    /// Replaces the constant nominal command (a scenario's `kind: constant`).
    pub fn with_constant(mut self, constant: Twist) -> Self {
        self.constant = Some(constant);
        self
    }

    /// For a simulated clock that ticks exactly once per control period: the
    /// reference then advances by the period itself, not by the difference
    /// of two float times (k Δt − (k−1) Δt ≠ Δt in floating point), so a
    /// simulated run does not depend on rounding of its own clock.
    pub fn with_fixed_period(mut self) -> Self {
        self.fixed_period = true;
        self
    }

    /// Times the way-round work done in step with `clock` (µs, any epoch;
    /// `SafetyPipeline::time_planner`), so the simulator can time the safety
    /// path alone, as the node runs it.
    pub fn with_planner_clock(mut self, clock: fn() -> f64) -> Self {
        self.pipeline.time_planner(clock);
        self
    }

    /// The way round's latest route, the waypoint followed (tracking frame)
    /// and why it last changed (§4c).
    pub fn route(&self) -> Option<&crate::algo::way_round::RouteUpdate> {
        self.pipeline.route()
    }

    /// The planner's own time of the plans made beside the safety path (µs;
    /// the newest `route_worker::PLAN_TIMES_KEPT`, in no particular order).
    pub fn plan_times_us(&self) -> &[f64] {
        self.route_worker.as_ref().map_or(&[], |w| &w.plan_us)
    }

    /// The newest snapshot of the local map's occupied cells (tracking
    /// frame, m), once, when the planner runs beside the safety path.
    pub fn take_map_cells(&mut self) -> Option<Vec<crate::algo::Vec2>> {
        self.route_worker.as_mut().and_then(RouteWorker::take_map_cells)
    }

    /// Has the pipeline build clusters even with tracking off, for a baseline
    /// that reads them ([`SafetyPipeline::keep_clusters`]).
    pub fn keep_clusters(mut self, keep: bool) -> Self {
        self.pipeline.keep_clusters(keep);
        self
    }

    /// The pipeline, read-only: what it perceived at the last tick (points,
    /// prediction, clusters, tracks), for monitors and the baselines.
    pub fn pipeline(&self) -> &SafetyPipeline {
        &self.pipeline
    }

    /// The braking condition (ALGORITHM.md §5b) for `cmd` on the last tick's
    /// prediction: the closing contact it would lead to, if any. For
    /// monitoring a command the filter did not choose.
    pub fn braking_check(&mut self, cmd: Twist) -> Option<crate::algo::passive::ClosingContact> {
        self.pipeline.braking_check(cmd)
    }

    /// Where the reference trajectory stands now (before the next tick
    /// advances it); `None` without a reference.
    pub fn reference_pose(&self) -> Option<Pose2> {
        self.reference.as_ref().map(|(r, p)| r.pose_at(p.t_s))
    }

    pub fn params(&self) -> &Params {
        self.pipeline.params()
    }

    /// New algorithm parameters while running (dynamic_reconfigure). They are
    /// validated first; when invalid nothing changes and every offending key
    /// is returned. Tracks, the scan in hand and the stamp history are kept.
    pub fn set_params(&mut self, params: Params) -> Result<(), Vec<ParamError>> {
        params.validate()?;
        if let Some(w) = &mut self.route_worker {
            w.set_params(&params);
        }
        self.pipeline.set_params(params);
        Ok(())
    }

    /// Whether the watchdog must tick at `now_s`: nothing has gone out yet,
    /// the clock went back, or the last tick is about a control period old.
    /// The watchdog polls [`WATCHDOG_POLLS_PER_PERIOD`] times a period and
    /// ticks from half a poll before the period is over, so without scans
    /// the node publishes every period, ± half a poll.
    pub fn watchdog_due(&self, now_s: f64) -> bool {
        let period_s = self.pipeline.params().control.dt_s();
        let due_after_s = period_s * (1.0 - 0.5 / f64::from(WATCHDOG_POLLS_PER_PERIOD));
        match self.last_tick_s {
            None => true,
            Some(t) => now_s < t || now_s - t >= due_after_s,
        }
    }

    pub fn settings(&self) -> &NodeSettings {
        &self.settings
    }

    /// The latest odometry, fresh or not (markers orient their label by it).
    pub fn odom(&self) -> Option<OdomSample> {
        self.odom
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

    /// Stores a scan (copied into reused buffers), unless its stamp is not
    /// newer than the newest taken: then the scan in hand stays, and the
    /// next tick stops with a [`ScanFault`]. A non-finite stamp is stored
    /// for the pipeline to reject.
    pub fn on_scan(&mut self, meta: ScanHeader, ranges_m: &[f32], intensities: &[f32]) {
        if let Some(newest_s) = self.newest_stamp_s.filter(|_| meta.stamp_s.is_finite()) {
            if meta.stamp_s <= newest_s {
                let fault = match self.scan_fault {
                    Some(ScanFault::Repeated { stamp_s, repeats }) if stamp_s == meta.stamp_s => ScanFault::Repeated {
                        stamp_s,
                        repeats: repeats.saturating_add(1),
                    },
                    _ if meta.stamp_s == newest_s => ScanFault::Repeated {
                        stamp_s: newest_s,
                        repeats: 1,
                    },
                    _ => ScanFault::OutOfOrder {
                        stamp_s: meta.stamp_s,
                        newest_s,
                    },
                };
                if self.scan_fault.map(|f| f.code()) != Some(fault.code()) {
                    log::warn!("{fault}");
                }
                self.scan_fault = Some(fault);
                return;
            }
        }
        if let Some(f) = self.scan_fault.take() {
            log::info!("scans in order again after: {f}");
        }
        if meta.stamp_s.is_finite() {
            self.newest_stamp_s = Some(meta.stamp_s);
        }
        let s = &mut self.scan;
        s.header = Some(meta);
        s.new = true;
        s.ranges_m.clear();
        s.ranges_m.extend_from_slice(ranges_m);
        s.intensities.clear();
        s.intensities.extend_from_slice(intensities);
    }

    /// A scan that arrived but cannot be placed on the robot (tf): its view
    /// is unknown, so the node stops as for a stale scan until a scan with a
    /// pose arrives. The scan in hand is not replaced; its stamp counts as
    /// taken (a later scan must still be newer).
    pub fn on_scan_without_pose(&mut self, meta: ScanHeader, why: PoseFault) {
        let fault = ScanFault::NoLaserPose {
            stamp_s: meta.stamp_s,
            why,
        };
        if self.scan_fault.map(|f| f.code()) != Some(fault.code()) {
            log::warn!("{fault}");
        }
        self.scan_fault = Some(fault);
        if meta.stamp_s.is_finite() && self.newest_stamp_s.is_none_or(|n| meta.stamp_s > n) {
            self.newest_stamp_s = Some(meta.stamp_s);
        }
    }

    /// A scan from scanner `k` of `node.scans`, placed by `mount` (Ok(None):
    /// the YAML mount; Err: no pose, its view unknown), for the next tick's
    /// merge with the others' latest.
    pub fn on_scanner_scan(
        &mut self,
        k: usize,
        scan: &LaserScan<'_>,
        mount: Result<Option<LaserMount>, PoseFault>,
        now_s: f64,
    ) {
        if let Some(merger) = &mut self.merger {
            let yaml = LaserMount::from_params(&self.pipeline.params().laser);
            let mount = match mount {
                Ok(m) => Some(m.unwrap_or(yaml)),
                Err(_) => None,
            };
            merger.update(k, scan, mount.as_ref(), now_s, &self.pipeline.params().laser);
        }
    }

    /// Several scanners: what came since the last merge, merged and stored
    /// as [`Self::on_scan`] does (once per tick).
    fn merge_scanners(&mut self, now_s: f64) {
        let Some(mut merger) = self.merger.take() else {
            return;
        };
        if merger.merge(now_s) {
            let s = merger.scan();
            self.on_scan(s.header, s.ranges_m, s.intensities);
        }
        self.merger = Some(merger);
    }

    /// What each scanner of `node.scans` contributes at `now_s` (empty with one scan topic).
    pub fn scanner_states(&self, now_s: f64) -> Vec<ScannerState> {
        self.merger
            .as_ref()
            .map(|m| (0..m.scanners()).map(|k| m.state(k, now_s)).collect())
            .unwrap_or_default()
    }

    /// Where the next scans' laser sits (`node.laser_pose: tf`, per scan).
    pub fn set_laser_mount(&mut self, mount: LaserMount) {
        if self.merger.is_none() && self.pipeline.laser_mount() != mount {
            self.pipeline.set_laser_mount(mount);
        }
    }

    /// The clock went back: nothing stamped before the jump can be aged
    /// against the new clock, so the scan in hand and the stamp history go.
    fn clock_jumped_back(&mut self, by_s: f64) {
        if let Some(m) = &mut self.merger {
            m.reset();
        }
        let fault = ScanFault::ClockJumpedBack { by_s };
        log::warn!("{fault}");
        self.scan_fault = Some(fault);
        self.newest_stamp_s = None;
        self.scan.header = None;
        self.pipeline.reset();
        self.pipeline.forget_perception();
        // Their receive times are on the old clock too: they would look fresh for too long.
        self.odom = None;
        self.cmd_in = None;
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

    /// The e-stop input, arrived at `now_s`. `true` latches; the latch
    /// stays after the input returns to `false` until `reset_e_stop`. In
    /// liveness mode every message, `true` or `false`, shows the publisher
    /// is alive.
    pub fn on_e_stop(&mut self, active: bool, now_s: f64) {
        self.e_stop_input = active;
        self.e_stop_heard_s = Some(now_s);
        if active {
            if !self.e_stop_latched {
                log::warn!("e-stop latched");
            }
            self.e_stop_latched = true;
        }
    }

    /// Liveness mode: why the e_stop input counts as engaged at `now_s`,
    /// if it does. Silent means older than the timeout (an age of exactly
    /// the timeout is alive); an age that is not a number counts as silent.
    pub fn e_stop_silence(&self, now_s: f64) -> Option<EStopSilence> {
        let timeout_s = self.settings.e_stop_timeout_s;
        if timeout_s <= 0.0 {
            return None;
        }
        match self.e_stop_heard_s {
            None => Some(EStopSilence::NoneYet { timeout_s }),
            Some(at_s) => {
                let age_s = now_s - at_s;
                // Not a number compares false: silent.
                let alive = age_s <= timeout_s;
                (!alive).then_some(EStopSilence::Silent { age_s, timeout_s })
            }
        }
    }

    /// Releases a latched e-stop at `now_s`, if its input is no longer
    /// active and, in liveness mode, is heard.
    pub fn reset_e_stop(&mut self, now_s: f64) -> Result<(), ResetRefused> {
        if self.e_stop_input {
            return Err(ResetRefused::InputActive);
        }
        if let Some(silence) = self.e_stop_silence(now_s) {
            return Err(ResetRefused::InputSilent(silence));
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

    /// Enables or disables the filter at `now_s` (disabled: the nominal
    /// command passes through unchanged, still monitored and reported).
    /// With `disable_timeout_s` above 0 a disable lasts that long from its
    /// latest request; returns when it lapses (s, node clock), `None` when
    /// the filter is on or the disable lasts until `~enable true`.
    pub fn set_enabled(&mut self, enabled: bool, now_s: f64) -> Option<f64> {
        if enabled != self.enabled {
            log::warn!(
                "safety filter {}",
                if enabled { "ENABLED" } else { "DISABLED: pass-through" }
            );
            self.pipeline.reset();
        }
        self.enabled = enabled;
        let timeout_s = self.settings.disable_timeout_s;
        self.disabled_until_s = (!enabled && timeout_s > 0.0).then_some(now_s + timeout_s);
        self.disabled_until_s
    }

    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// A disable whose time is up ends: the filter is on again. Not a
    /// number counts as up.
    fn lapse_disable(&mut self, now_s: f64) {
        // Not a number compares false: up.
        let running = |until_s: f64| now_s < until_s;
        if let Some(until_s) = self.disabled_until_s.filter(|&u| !running(u)) {
            log::warn!(
                "safety filter ENABLED: `~enable false` lapsed at {until_s:.3} s, not renewed within {:.3} s",
                self.settings.disable_timeout_s
            );
            self.enabled = true;
            self.disabled_until_s = None;
            self.pipeline.reset();
        }
    }

    fn fresh_odom(&self, now_s: f64) -> Option<OdomSample> {
        self.odom
            .filter(|o| now_s - o.received_s <= self.settings.odom_timeout_s)
    }

    /// This tick's nominal command, its source, and the reference pose
    /// followed (when the reference gave it).
    fn nominal(&mut self, now_s: f64, dt_s: f64) -> (Twist, NominalUsed, Option<Pose2>) {
        let use_upstream = match self.settings.nominal_source {
            NominalSource::CmdVelIn => true,
            NominalSource::Auto => self.upstream_seen,
            _ => false,
        };
        if use_upstream {
            return match self.cmd_in {
                Some((t, at)) if now_s - at <= self.settings.cmd_in_timeout_s => (t, NominalUsed::CmdVelIn, None),
                _ => (Twist::ZERO, NominalUsed::CmdVelInStale, None),
            };
        }
        let use_reference = matches!(
            self.settings.nominal_source,
            NominalSource::Reference | NominalSource::Auto
        ) && self.reference.is_some();
        if use_reference {
            let odom = self.fresh_odom(now_s);
            let params = self.pipeline.params().tracking.clone();
            let ahead_m = self.pipeline.params().unstuck.ahead_m;
            let omega_max_radps = self.pipeline.params().control.omega_max_radps;
            let (reference, progress) = self.reference.as_mut().expect("checked above");
            return match odom {
                Some(o) => {
                    progress.catch_up(reference, o.pose, params.capture_radius_m);
                    let lag = ReferenceProgress::lag_m(o.pose, reference.pose_at(progress.t_s));
                    let rate = ReferenceProgress::rate(lag, params.capture_radius_m);
                    let (ref_pose, ref_twist) = progress.reference(reference, rate);
                    // Where the reference heads, for the unstuck logic (§4b).
                    let guidance = Guidance::of_reference(reference, progress, o.pose, ahead_m);
                    self.pipeline.set_guidance(Some(guidance));
                    progress.advance(dt_s, rate);
                    // While a way round an obstacle is followed (§4b), the tracking law
                    // aims at its waypoint: the reference is behind what blocks the way.
                    let cmd = match self.pipeline.aim_point() {
                        Some(aim) => towards_point(o.pose, aim, reference.v_mps.abs(), &params),
                        None => track(o.pose, ref_pose, ref_twist, &params, omega_max_radps),
                    };
                    (cmd, NominalUsed::Reference, Some(ref_pose))
                }
                None => (Twist::ZERO, NominalUsed::ReferenceNoOdom, None),
            };
        }
        match (self.settings.nominal_source, self.constant) {
            (NominalSource::Constant, c) => (
                c.unwrap_or_else(|| Twist::new(self.pipeline.params().control.v_nom_mps, 0.0)),
                NominalUsed::Constant,
                None,
            ),
            (NominalSource::Auto, Some(c)) => (c, NominalUsed::Constant, None),
            _ => (Twist::ZERO, NominalUsed::NoUpstream, None),
        }
    }

    /// One control tick at time `now_s` (the node's clock, same as scan stamps).
    pub fn tick(&mut self, now_s: f64) -> Tick {
        if let Some(last_s) = self.last_tick_s.filter(|&t| now_s < t) {
            let by_s = last_s - now_s;
            self.clock_jumped_back(by_s);
            // The e_stop message's age and the disable's time left carry across the jump.
            if let Some(t) = self.e_stop_heard_s.as_mut() {
                *t -= by_s;
            }
            if let Some(t) = self.disabled_until_s.as_mut() {
                *t -= by_s;
            }
            let hold_s = self.pipeline.params().laser.scan_timeout_s;
            self.settle_after_jump = Some((now_s + hold_s, last_s - now_s));
        }
        // Several scanners: what came since the last tick, merged into one scan.
        self.merge_scanners(now_s);
        let settling = self.settle_after_jump.filter(|&(until_s, _)| now_s < until_s);
        if settling.is_none() {
            self.settle_after_jump = None;
        }
        // A stamp far in the future (beyond the pipeline's tolerance) must
        // not hold every later scan back as "out of order".
        let tolerance_s = self.pipeline.params().laser.scan_timeout_s;
        if self.newest_stamp_s.is_some_and(|w| w - now_s > tolerance_s) {
            self.newest_stamp_s = None;
        }
        let dt = match self.last_tick_s {
            Some(t) if now_s > t && !self.fixed_period => (now_s - t).min(1.0),
            _ => self.pipeline.params().control.dt_s(),
        };
        self.last_tick_s = Some(now_s);
        let (nominal, nominal_used, reference_pose) = self.nominal(now_s, dt);
        let odom = self.fresh_odom(now_s);
        let v_now = odom.map_or(f64::NAN, |o| o.twist.v_mps);

        let scan_fault = match settling {
            Some((_, by_s)) => Some(ScanFault::ClockJumpedBack { by_s }),
            None => self.scan_fault,
        };
        let stale_since_s = self.newest_stamp_s.filter(|_| scan_fault.is_some());
        let record = match (self.scan.header.filter(|_| settling.is_none()), stale_since_s) {
            (None, _) => self.pipeline.stop(now_s, nominal, StopCause::NoScan),
            (Some(_), Some(newest_s)) => {
                let stale = ScanRejection::Stale {
                    age_s: now_s - newest_s,
                    timeout_s: tolerance_s,
                };
                self.pipeline.stop(now_s, nominal, StopCause::Rejected(stale))
            }
            (Some(header), None) => {
                // A scan is perceived once; every tick, with or without a new one,
                // decides on that perception predicted to its own time (§5c).
                let pose = odom.map(|o| o.pose);
                if self.scan.new || self.pipeline.scan_rejected() {
                    let scan = LaserScan {
                        header,
                        ranges_m: &self.scan.ranges_m,
                        intensities: &self.scan.intensities,
                    };
                    self.pipeline.perceive(&scan, now_s, pose);
                    self.scan.new = false;
                }
                self.pipeline.decide(now_s, nominal, v_now, pose)
            }
        };
        let scan_stamp_s = self.scan.header.map_or(f64::NAN, |h| h.stamp_s);
        if let Some(w) = &mut self.route_worker {
            w.feed(&mut self.pipeline);
        }

        self.lapse_disable(now_s);
        let e_stop_silence = self.e_stop_silence(now_s);
        if e_stop_silence.is_some() != self.e_stop_was_silent {
            match e_stop_silence {
                Some(s) => log::warn!("{s}"),
                None => log::info!("e_stop heard again: its liveness stop released"),
            }
            self.e_stop_was_silent = e_stop_silence.is_some();
        }
        let e_stop = self.e_stop_latched || e_stop_silence.is_some();
        let computed = record.cmd;
        let (cmd, record) = if e_stop {
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
        // The pipeline's window, dead reckoning and speed barrier start from what was
        // actually sent (§5c), not from what it computed under an e-stop or disable.
        if cmd != computed {
            self.pipeline.command_sent(cmd, now_s);
        }
        Tick {
            cmd,
            record,
            nominal_used,
            filter_enabled: self.enabled,
            disable_lapses_at_s: self.disabled_until_s,
            e_stop,
            e_stop_latched: self.e_stop_latched,
            e_stop_silence,
            scan_stamp_s,
            scan_fault: record.stop_cause.and(scan_fault),
            reference_pose,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::doaa::DoaaState;
    use std::f32::consts::PI;

    fn meta(stamp: f64) -> ScanHeader {
        ScanHeader {
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
        NodeCore::new(agile(), settings, None)
    }

    /// The default parameters for a base that can change its command at once
    /// (the dynamic window holds the whole input box): these tests are about
    /// what the node passes and when, not about how fast the base follows.
    fn agile() -> Params {
        let mut p = Params::default();
        p.control.accel_mps2 = 100.0;
        p.control.decel_mps2 = 100.0;
        p.control.angular_accel_radps2 = 1000.0;
        p.passive.evasion_accel_mps2 = 100.0;
        p.passive.evasion_angular_accel_radps2 = 1000.0;
        p
    }

    /// A front (x 0.2 m) and a rear (x −0.2 m, facing back) 270° scanner of 271 beams.
    fn two_scanners(source: NominalSource) -> NodeCore {
        let input = |topic: &str| ScanInput {
            topic: topic.into(),
            timeout_s: 0.3,
            zero_is_no_return: false,
        };
        let settings = NodeSettings {
            nominal_source: source,
            scans: vec![input("front/scan"), input("rear/scan")],
            ..NodeSettings::default()
        };
        NodeCore::new(agile(), settings, None)
    }

    fn scan_270(stamp: f64, ranges: &[f32]) -> LaserScan<'_> {
        LaserScan {
            header: ScanHeader {
                stamp_s: stamp,
                angle_min_rad: -0.75 * PI,
                angle_increment_rad: 1.5 * PI / 270.0,
                range_min_m: 0.05,
                range_max_m: 10.0,
            },
            ranges_m: ranges,
            intensities: &[],
        }
    }

    #[test]
    fn a_dead_rear_scanner_forbids_backing_up_a_dead_front_one_forward_motion() {
        let open = vec![f32::INFINITY; 271];
        let front = Ok(Some(LaserMount::upright(Pose2::new(0.2, 0.0, 0.0))));
        let rear = Ok(Some(LaserMount::upright(Pose2::new(-0.2, 0.0, std::f64::consts::PI))));
        // Backing up on the upstream's word, both scanners alive.
        let mut n = two_scanners(NominalSource::CmdVelIn);
        let mut t = 1.0;
        let mut cmds = Vec::new();
        for step in 0..20 {
            n.on_cmd_in(Twist::new(-0.1, 0.0), t);
            n.on_scanner_scan(0, &scan_270(t, &open), front, t);
            // The rear falls silent after 1 s.
            if step < 10 {
                n.on_scanner_scan(1, &scan_270(t + 0.01, &open), rear, t + 0.01);
            }
            cmds.push((step, n.tick(t + 0.02).cmd));
            t += 0.1;
        }
        let backing = |c: &Twist| c.v_mps < -0.05;
        assert!(cmds[3..10].iter().all(|(_, c)| backing(c)), "{cmds:?}");
        // 0.3 s after the last rear scan its view is unknown: no backing up.
        assert!(cmds[14..].iter().all(|(_, c)| c.v_mps >= 0.0), "{cmds:?}");
        assert!(matches!(n.scanner_states(t)[1], ScannerState::Silent { .. }));

        // Forward with both; then the front falls silent.
        let mut n = two_scanners(NominalSource::CmdVelIn);
        let mut cmds = Vec::new();
        for step in 0..20 {
            n.on_cmd_in(Twist::new(0.15, 0.0), t);
            if step < 10 {
                n.on_scanner_scan(0, &scan_270(t, &open), front, t);
            }
            n.on_scanner_scan(1, &scan_270(t + 0.01, &open), rear, t + 0.01);
            cmds.push((step, n.tick(t + 0.02).cmd));
            t += 0.1;
        }
        assert!(cmds[3..10].iter().all(|(_, c)| c.v_mps > 0.1), "{cmds:?}");
        // The last front scan at step 9: its view is unknown from step 12
        // (0.31 s > its 0.3 s timeout), and the front unknown for
        // laser.blind_timeout_s (0.3 s) more is the blind-sensor stop.
        assert!(cmds[15..].iter().all(|(_, c)| c.v_mps <= 0.0), "{cmds:?}");
    }

    #[test]
    fn bad_scanner_lists_name_the_key() {
        let keys = |s: NodeSettings| -> Vec<String> {
            s.validate()
                .err()
                .map(|e| e.iter().map(|e| e.key.clone()).collect())
                .unwrap_or_default()
        };
        let good = two_scanners(NominalSource::CmdVelIn).settings.clone();
        assert_eq!(keys(good.clone()), Vec::<String>::new());
        let mut bad = good.clone();
        bad.scans[1].timeout_s = 0.0;
        bad.scans[0].topic = "front scan".into();
        assert_eq!(keys(bad), ["node.scans[0].topic", "node.scans[1].timeout_s"]);
        let bad = NodeSettings {
            laser_pose: LaserPoseSource::Yaml,
            ..good
        };
        assert_eq!(keys(bad), ["node.laser_pose"]);
    }

    #[test]
    fn a_scanner_without_a_pose_is_a_dead_one() {
        let open = vec![f32::INFINITY; 271];
        let front = Ok(Some(LaserMount::upright(Pose2::new(0.2, 0.0, 0.0))));
        let mut n = two_scanners(NominalSource::CmdVelIn);
        let mut t = 1.0;
        let mut last = Twist::ZERO;
        for _ in 0..10 {
            n.on_cmd_in(Twist::new(-0.1, 0.0), t);
            n.on_scanner_scan(0, &scan_270(t, &open), front, t);
            n.on_scanner_scan(1, &scan_270(t + 0.01, &open), Err(PoseFault::NoTransform), t + 0.01);
            last = n.tick(t + 0.02).cmd;
            t += 0.1;
        }
        assert!(last.v_mps >= 0.0, "{last:?}");
        assert_eq!(n.scanner_states(t)[1], ScannerState::NoPose);
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

    /// The safety layer never originates motion (ALGORITHM §5c): in free
    /// space, with no upstream command, every source a robot can be
    /// configured with sends zero; only `constant`, asked for explicitly,
    /// drives at v_nom.
    #[test]
    fn with_no_upstream_command_the_node_sends_zero() {
        for source in [NominalSource::Auto, NominalSource::CmdVelIn, NominalSource::Reference] {
            let mut n = node(source);
            for k in 0..20 {
                let t = 1.0 + 0.1 * f64::from(k);
                n.on_scan(meta(t), &open(), &[]);
                let tick = n.tick(t + 0.01);
                assert_eq!(tick.cmd, Twist::ZERO, "{source:?} at {t} s: {tick:?}");
                assert!(
                    tick.record.stop_cause.is_none(),
                    "{source:?}: a filtered zero, not a fault"
                );
            }
        }
        assert_eq!(NodeSettings::default().nominal_source, NominalSource::CmdVelIn);
        let mut n = node(NominalSource::Constant);
        n.on_scan(meta(1.0), &open(), &[]);
        assert_eq!(n.tick(1.01).cmd, Twist::new(0.15, 0.0));
    }

    #[test]
    fn upstream_command_is_filtered_and_never_replaced_by_v_nom() {
        let mut n = node(NominalSource::Auto);
        n.on_scan(meta(1.0), &open(), &[]);
        assert_eq!(n.tick(1.0).nominal_used, NominalUsed::NoUpstream);
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
        n.on_e_stop(true, 1.0);
        assert_eq!(n.tick(1.0).cmd, Twist::ZERO);
        assert_eq!(
            n.reset_e_stop(1.0),
            Err(ResetRefused::InputActive),
            "input still active"
        );
        n.on_e_stop(false, 1.05);
        let t = n.tick(1.1);
        assert_eq!(t.cmd, Twist::ZERO, "still latched after the input is released");
        assert_eq!(t.record.stop_cause, Some(StopCause::EStop));
        assert!(t.e_stop);
        n.reset_e_stop(1.15).unwrap();
        assert_eq!(n.tick(1.2).cmd, Twist::new(0.15, 0.0));
    }

    fn with_settings(source: NominalSource, e_stop_timeout_s: f64, disable_timeout_s: f64) -> NodeCore {
        let settings = NodeSettings {
            nominal_source: source,
            e_stop_timeout_s,
            disable_timeout_s,
            ..NodeSettings::default()
        };
        NodeCore::new(agile(), settings, None)
    }

    /// Liveness mode, timeout 0.5 s: engaged before the first message, free
    /// while the publisher is heard (silent 0.4 s, and exactly 0.5 s),
    /// engaged when silent 0.6 s, released by a fresh `false` without the
    /// reset service; a `true` still latches until reset.
    #[test]
    fn a_silent_e_stop_publisher_engages_the_stop_in_liveness_mode() {
        let mut n = with_settings(NominalSource::Constant, 0.5, 0.0);
        let free = Twist::new(0.15, 0.0);
        n.on_scan(meta(1.0), &open(), &[]);
        // Start-up: nothing heard yet.
        let t = n.tick(1.0);
        assert_eq!((t.cmd, t.record.stop_cause), (Twist::ZERO, Some(StopCause::EStop)));
        assert_eq!(t.e_stop_silence, Some(EStopSilence::NoneYet { timeout_s: 0.5 }));
        assert!(t.e_stop && !t.e_stop_latched);
        assert!(
            t.stop_reason().starts_with("e_stop not heard yet"),
            "{}",
            t.stop_reason()
        );
        assert!(matches!(n.reset_e_stop(1.0), Err(ResetRefused::InputSilent(_))));
        // The first false releases it; no reset needed.
        n.on_e_stop(false, 1.0);
        let t = n.tick(1.01);
        assert_eq!((t.cmd, t.e_stop, t.e_stop_silence), (free, false, None));
        // Silent 0.4 s, then exactly the timeout: alive.
        n.on_scan(meta(1.4), &open(), &[]);
        assert_eq!(n.tick(1.4).cmd, free);
        assert_eq!(n.tick(1.5).cmd, free);
        // Silent 0.6 s: engaged, and says why.
        n.on_scan(meta(1.6), &open(), &[]);
        let t = n.tick(1.6);
        assert_eq!((t.cmd, t.record.stop_cause), (Twist::ZERO, Some(StopCause::EStop)));
        match t.e_stop_silence {
            Some(EStopSilence::Silent { age_s, timeout_s }) => {
                assert!((age_s - 0.6).abs() < 1e-9 && timeout_s == 0.5, "{age_s} {timeout_s}")
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(
            t.stop_reason(),
            "e_stop silent for 0.600 s (liveness timeout 0.500 s): stopped until a fresh false arrives"
        );
        assert_eq!(t.status_line(), format!("commanding a stop: {}", t.stop_reason()));
        // A fresh false releases it.
        n.on_e_stop(false, 1.65);
        let t = n.tick(1.7);
        assert_eq!((t.cmd, t.e_stop), (free, false));
        // A true latches as ever: the false after it, then silence, then a fresh
        // false leave it latched until reset.
        n.on_e_stop(true, 1.8);
        n.on_e_stop(false, 1.9);
        n.on_scan(meta(2.4), &open(), &[]);
        let t = n.tick(2.45);
        assert!(t.e_stop_latched && t.e_stop_silence.is_some(), "{t:?}");
        assert!(t
            .stop_reason()
            .starts_with("e-stop latched, and e_stop silent for 0.550 s"));
        n.on_e_stop(false, 2.5);
        let t = n.tick(2.5);
        assert_eq!((t.cmd, t.e_stop_latched, t.e_stop_silence), (Twist::ZERO, true, None));
        assert_eq!(t.stop_reason(), "e-stop latched");
        n.reset_e_stop(2.5).unwrap();
        assert_eq!(n.tick(2.55).cmd, free);
    }

    /// Liveness off (timeout 0, the default): today's rules, whatever the silence.
    #[test]
    fn without_liveness_an_e_stop_never_heard_or_silent_changes_nothing() {
        let mut n = node(NominalSource::Constant);
        assert_eq!(n.settings().e_stop_timeout_s, 0.0);
        n.on_scan(meta(1.0), &open(), &[]);
        assert_eq!(n.tick(1.0).cmd, Twist::new(0.15, 0.0), "never heard");
        n.on_e_stop(false, 1.0);
        n.on_scan(meta(100.0), &open(), &[]);
        let t = n.tick(100.0);
        assert_eq!(
            (t.cmd, t.e_stop, t.e_stop_silence),
            (Twist::new(0.15, 0.0), false, None)
        );
        assert_eq!(n.e_stop_silence(100.0), None);
    }

    /// `~enable false` with disable_timeout_s 2 s at 1.0 s lapses at 3.0 s;
    /// renewed at 2.5 s it lapses at 4.5 s: passed through at 4.4 s,
    /// filtered again at 4.5 s. With 0 it never lapses.
    #[test]
    fn a_disable_lapses_unless_renewed() {
        // A wall 0.3 m ahead: the filter allows no forward motion; disabled, 0.2 m/s passes.
        let mut wall = open();
        for r in &mut wall[170..=190] {
            *r = 0.3;
        }
        let step = |n: &mut NodeCore, now: f64| {
            n.on_scan(meta(now), &wall, &[]);
            n.on_cmd_in(Twist::new(0.2, 0.0), now);
            n.tick(now)
        };
        let mut n = with_settings(NominalSource::CmdVelIn, 0.0, 2.0);
        assert!(step(&mut n, 1.0).cmd.v_mps <= 0.0);
        assert_eq!(n.set_enabled(false, 1.0), Some(3.0));
        let t = step(&mut n, 2.0);
        assert_eq!(
            (t.cmd, t.filter_enabled, t.disable_lapses_at_s),
            (Twist::new(0.2, 0.0), false, Some(3.0))
        );
        assert_eq!(n.set_enabled(false, 2.5), Some(4.5), "renewed");
        for now in [3.1, 4.4] {
            let t = step(&mut n, now);
            assert_eq!((t.cmd, t.filter_enabled), (Twist::new(0.2, 0.0), false), "at {now} s");
        }
        let t = step(&mut n, 4.5);
        assert!(t.filter_enabled && t.disable_lapses_at_s.is_none(), "{t:?}");
        assert!(t.cmd.v_mps <= 0.0, "filtered again: {t:?}");
        assert!(n.enabled());
        // `~enable true` ends a disable early, and clears its deadline.
        n.set_enabled(false, 5.0);
        assert_eq!(n.set_enabled(true, 5.5), None);
        assert!(step(&mut n, 8.0).filter_enabled);
        // 0: never lapses.
        let mut n = with_settings(NominalSource::CmdVelIn, 0.0, 0.0);
        assert_eq!(n.set_enabled(false, 1.0), None);
        let t = step(&mut n, 1000.0);
        assert_eq!(
            (t.filter_enabled, t.disable_lapses_at_s, t.cmd),
            (false, None, Twist::new(0.2, 0.0))
        );
    }

    /// A clock jump back by 5 s keeps the last e_stop message's age and the
    /// disable's time left: heard at 10.0 s, ticked at 10.25 s, the clock
    /// goes to 5.25 s: the message is 0.375 s old at 5.375 s (alive),
    /// 0.625 s old at 5.625 s (silent); the disable due at 12.0 s is due at 7.0 s.
    #[test]
    fn a_clock_jump_back_keeps_the_e_stop_age_and_the_disable_time_left() {
        let mut n = with_settings(NominalSource::CmdVelIn, 0.5, 2.0);
        n.on_e_stop(false, 10.0);
        n.set_enabled(false, 10.0);
        n.on_scan(meta(10.0), &open(), &[]);
        assert_eq!(n.tick(10.25).e_stop_silence, None);
        let t = n.tick(5.25);
        assert_eq!((t.e_stop_silence, t.disable_lapses_at_s), (None, Some(7.0)));
        assert_eq!(n.tick(5.375).e_stop_silence, None);
        assert!(matches!(
            n.tick(5.625).e_stop_silence,
            Some(EStopSilence::Silent { age_s, .. }) if (age_s - 0.625).abs() < 1e-9
        ));
        assert!(!n.tick(6.9).filter_enabled);
        assert!(n.tick(7.0).filter_enabled);
    }

    #[test]
    fn the_window_starts_from_the_command_actually_sent() {
        // The default base: 0.5 m/s² up, so 0.05 m/s per 0.1 s tick.
        let settings = NodeSettings {
            nominal_source: NominalSource::CmdVelIn,
            ..NodeSettings::default()
        };
        let mut n = NodeCore::new(Params::default(), settings, None);
        let tick = |n: &mut NodeCore, k: usize| {
            let t = 1.0 + 0.1 * k as f64;
            n.on_scan(meta(t), &open(), &[]);
            n.on_cmd_in(Twist::new(0.2, 0.0), t);
            n.tick(t).cmd
        };
        // The filter ramps up: 0.05, 0.10.
        assert!((tick(&mut n, 0).v_mps - 0.05).abs() < 1e-9);
        assert!((tick(&mut n, 1).v_mps - 0.10).abs() < 1e-9);
        // Disabled, the node passes 0.2 through; the base follows it.
        n.set_enabled(false, 1.2);
        for k in 2..5 {
            assert_eq!(tick(&mut n, k), Twist::new(0.2, 0.0));
        }
        // Enabled again, the window starts from the 0.2 the base was sent: the safe
        // 0.2 goes on. Counted from the pipeline's own (ramping) output it would
        // have fallen back to 0.15 or below.
        n.set_enabled(true, 1.5);
        assert_eq!(tick(&mut n, 5), Twist::new(0.2, 0.0));
        // An e-stop sends zero; released, the filter ramps up again from zero.
        n.on_e_stop(true, 1.6);
        assert_eq!(tick(&mut n, 6), Twist::ZERO);
        n.on_e_stop(false, 1.7);
        n.reset_e_stop(1.7).unwrap();
        assert!((tick(&mut n, 7).v_mps - 0.05).abs() < 1e-9);
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
        n.set_enabled(false, 1.05);
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
        let mut n = NodeCore::new(agile(), NodeSettings::for_scenario(), Some(r));
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
    fn a_robot_ahead_of_its_reference_drives_on_and_is_caught_up_with() {
        // A line along +x at 0.15 m/s. The robot 0.6 m ahead on it, at rest: left behind,
        // the reference would have Kanayama ask 0.15 + 1·(−0.6) < 0, held at 0 (a stop).
        // Caught up with, it stands abreast of the robot (x = 0.6, then one tick on) and
        // the command is v_r.
        let r = ReferenceTrajectory::line(Pose2::default(), 0.15, 3.0);
        let mut n = NodeCore::new(agile(), NodeSettings::for_scenario(), Some(r));
        n.on_scan(meta(1.0), &open(), &[]);
        n.on_odom(Pose2::new(0.6, 0.0, 0.0), Twist::ZERO, 1.0);
        let t = n.tick(1.0);
        assert_eq!(t.nominal_used, NominalUsed::Reference);
        assert!((t.reference_pose.unwrap().x - 0.6).abs() < 1e-12, "{t:?}");
        assert!((t.cmd.v_mps - 0.15).abs() < 1e-9, "{t:?}");
        assert!((n.reference_pose().unwrap().x - 0.615).abs() < 1e-12);
        // 0.8 m aside (beyond R_c = 0.5 m): not caught up with, the reference waits.
        let mut n = NodeCore::new(agile(), NodeSettings::for_scenario(), Some(r));
        n.on_scan(meta(1.0), &open(), &[]);
        n.on_odom(Pose2::new(0.6, 0.8, 0.0), Twist::ZERO, 1.0);
        assert_eq!(n.tick(1.0).reference_pose.unwrap().x, 0.0);
    }

    #[test]
    fn a_scenario_constant_command_is_the_nominal_and_v_nom_only_without_one() {
        // Free space: the filter passes the nominal unchanged.
        let mut n = node(NominalSource::Constant).with_constant(Twist::new(0.1, 0.2));
        n.on_scan(meta(1.0), &open(), &[]);
        let t = n.tick(1.0);
        assert_eq!((t.cmd, t.nominal_used), (Twist::new(0.1, 0.2), NominalUsed::Constant));
        assert_eq!(t.reference_pose, None);
        // Without one: v_nom, read at the tick, so a reconfigured v_nom applies at once.
        let mut n = node(NominalSource::Constant);
        let mut p = agile();
        p.control.v_nom_mps = 0.1;
        n.set_params(p).unwrap();
        n.on_scan(meta(1.0), &open(), &[]);
        assert_eq!(n.tick(1.0).cmd, Twist::new(0.1, 0.0));
    }

    #[test]
    fn a_fixed_period_clock_advances_the_reference_by_the_period() {
        // On the reference (lag 0: rate 1), ticks 0.25 s apart: the node's own
        // clock would advance the reference 0.25 s per tick, a fixed-period
        // (simulated) clock exactly Δt = 0.1 s.
        let r = ReferenceTrajectory::line(Pose2::default(), 0.15, 10.0);
        // Reference time at each tick (s): the first tick advances by Δt.
        for (fixed, t_ref_s) in [(false, [0.0, 0.1, 0.35]), (true, [0.0, 0.1, 0.2])] {
            let mut n = NodeCore::new(agile(), NodeSettings::for_scenario(), Some(r));
            if fixed {
                n = n.with_fixed_period();
            }
            for k in 0..3 {
                let now_s = 1.0 + 0.25 * f64::from(k);
                n.on_scan(meta(now_s), &open(), &[]);
                n.on_odom(n.reference_pose().unwrap(), Twist::ZERO, now_s);
                let t = n.tick(now_s);
                assert_eq!(t.nominal_used, NominalUsed::Reference);
                // The pose followed this tick is where the reference stood before it.
                let expect_x = 0.15 * t_ref_s[k as usize];
                assert!(
                    (t.reference_pose.unwrap().x - expect_x).abs() < 1e-12,
                    "{fixed} {k} {t:?}"
                );
            }
        }
    }

    fn stale_fault(t: &Tick) -> bool {
        t.cmd == Twist::ZERO
            && matches!(
                t.record.stop_cause,
                Some(StopCause::Rejected(ScanRejection::Stale { .. }))
            )
    }

    #[test]
    fn a_repeated_stamp_is_a_frozen_sensor_and_stops_at_once() {
        let mut n = node(NominalSource::Constant);
        n.on_scan(meta(1.0), &open(), &[]);
        assert_eq!(n.tick(1.05).cmd, Twist::new(0.15, 0.0));
        // Well inside scan_timeout (0.5 s), but the same stamp again.
        n.on_scan(meta(1.0), &open(), &[]);
        n.on_scan(meta(1.0), &open(), &[]);
        let t = n.tick(1.1);
        assert!(stale_fault(&t), "{t:?}");
        assert_eq!(
            t.scan_fault,
            Some(ScanFault::Repeated {
                stamp_s: 1.0,
                repeats: 2
            })
        );
        assert!(t.scan_fault.unwrap().to_string().contains("frozen"));
        // Still stopped on the next tick without a new scan.
        assert!(stale_fault(&n.tick(1.2)));
        // A newer stamp resumes.
        n.on_scan(meta(1.2), &open(), &[]);
        let t = n.tick(1.25);
        assert_eq!((t.cmd, t.scan_fault), (Twist::new(0.15, 0.0), None));
    }

    #[test]
    fn an_out_of_order_scan_stops_until_a_newer_one_arrives() {
        let mut n = node(NominalSource::Constant);
        n.on_scan(meta(2.0), &open(), &[]);
        assert_eq!(n.tick(2.05).cmd, Twist::new(0.15, 0.0));
        // Older than the one taken, though young enough for the pipeline.
        n.on_scan(meta(1.9), &open(), &[]);
        let t = n.tick(2.1);
        assert!(stale_fault(&t), "{t:?}");
        assert_eq!(
            t.scan_fault,
            Some(ScanFault::OutOfOrder {
                stamp_s: 1.9,
                newest_s: 2.0
            })
        );
        assert_eq!(t.scan_fault.unwrap().code(), "out_of_order");
        // Newer than 2.0 but older than the out-of-order one is irrelevant: newer than the newest resumes.
        n.on_scan(meta(2.1), &open(), &[]);
        assert_eq!(n.tick(2.15).cmd, Twist::new(0.15, 0.0));
    }

    #[test]
    fn a_clock_jump_backwards_drops_old_scans_stops_and_resumes_on_a_new_one() {
        let mut n = node(NominalSource::Constant);
        n.on_scan(meta(100.0), &open(), &[]);
        assert_eq!(n.tick(100.05).cmd, Twist::new(0.15, 0.0));
        // The clock jumps back 0.3 s: the old scan would look 0.25 s in the
        // future, inside the pipeline's tolerance, and so "fresh" for 0.8 s.
        let t = n.tick(99.75);
        assert_eq!(t.cmd, Twist::ZERO);
        assert_eq!(t.record.stop_cause, Some(StopCause::NoScan));
        assert!(matches!(t.scan_fault, Some(ScanFault::ClockJumpedBack { by_s }) if (by_s - 0.3).abs() < 1e-9));
        // Scans on the new clock keep coming, but the stop holds for
        // scan_timeout_s (0.5 s) after the jump, still reported...
        n.on_scan(meta(99.8), &open(), &[]);
        let t = n.tick(99.85);
        assert_eq!(t.cmd, Twist::ZERO);
        assert!(matches!(t.scan_fault, Some(ScanFault::ClockJumpedBack { .. })));
        n.on_scan(meta(100.2), &open(), &[]);
        assert_eq!(n.tick(100.24).cmd, Twist::ZERO);
        // ...then a scan stamped on the new clock is taken although older than the old one.
        let t = n.tick(100.25);
        assert_eq!((t.cmd, t.scan_fault), (Twist::new(0.15, 0.0), None));
        // A big jump: 30 s back, scans keep coming on the new clock.
        let t = n.tick(70.25);
        assert_eq!(t.cmd, Twist::ZERO);
        n.on_scan(meta(70.3), &open(), &[]);
        assert_eq!(n.tick(70.35).cmd, Twist::ZERO);
        n.on_scan(meta(70.7), &open(), &[]);
        assert_eq!(n.tick(70.75).cmd, Twist::new(0.15, 0.0));
    }

    #[test]
    fn upstream_commands_from_before_a_clock_jump_are_dropped() {
        let mut n = node(NominalSource::CmdVelIn);
        n.on_scan(meta(10.0), &open(), &[]);
        n.on_cmd_in(Twist::new(0.1, 0.0), 10.0);
        assert_eq!(n.tick(10.05).cmd, Twist::new(0.1, 0.0));
        n.tick(5.0);
        n.on_scan(meta(5.05), &open(), &[]);
        let t = n.tick(5.1);
        assert_eq!((t.cmd, t.nominal_used), (Twist::ZERO, NominalUsed::CmdVelInStale));
    }

    #[test]
    fn a_scan_stamped_far_in_the_future_does_not_block_later_ones() {
        let mut n = node(NominalSource::Constant);
        n.on_scan(meta(1000.0), &open(), &[]);
        let t = n.tick(1.0);
        assert!(matches!(
            t.record.stop_cause,
            Some(StopCause::Rejected(ScanRejection::FromFuture { .. }))
        ));
        n.on_scan(meta(1.05), &open(), &[]);
        assert_eq!(n.tick(1.1).cmd, Twist::new(0.15, 0.0));
    }

    #[test]
    fn non_finite_stamps_are_rejected_by_the_pipeline_and_do_not_poison_the_order() {
        let mut n = node(NominalSource::Constant);
        n.on_scan(meta(1.0), &open(), &[]);
        n.on_scan(meta(f64::NAN), &open(), &[]);
        let t = n.tick(1.05);
        assert_eq!(t.record.stop_cause, Some(StopCause::Rejected(ScanRejection::BadStamp)));
        n.on_scan(meta(1.1), &open(), &[]);
        assert_eq!(n.tick(1.15).cmd, Twist::new(0.15, 0.0));
    }

    /// REP 117 (ALGORITHM.md §1): +inf is "nothing in range", free space, so
    /// the nominal passes. NaN and 0.0 (below range_min, under the default
    /// laser convention) are unknown: a scan of nothing else is a blinded
    /// sensor, which stops the robot once it has lasted `laser.blind_timeout_s`
    /// (0.3 s) and lets it go on the first good scan. A driver that declares
    /// `zero_is_no_return` makes all-zero free again. −inf everywhere is an
    /// obstacle at range_min all round: no translation.
    #[test]
    fn all_inf_is_free_space_but_all_nan_or_all_zero_is_a_blind_sensor() {
        let mut n = node(NominalSource::Constant);
        n.on_scan(meta(1.0), &vec![f32::INFINITY; 360], &[]);
        let t = n.tick(1.05);
        assert_eq!((t.cmd, t.record.stop_cause), (Twist::new(0.15, 0.0), None));
        for fill in [f32::NAN, 0.0] {
            let mut n = node(NominalSource::Constant);
            for k in 0..3 {
                let stamp = 1.0 + 0.1 * k as f64;
                n.on_scan(meta(stamp), &vec![fill; 360], &[]);
                let t = n.tick(stamp + 0.05);
                assert!(t.cmd.is_finite() && t.record.stop_cause.is_none(), "fill {fill}, {t:?}");
                assert_eq!((t.record.unknown_beams, t.record.valid_beams), (360, 0));
            }
            n.on_scan(meta(1.3), &vec![fill; 360], &[]);
            let t = n.tick(1.35);
            assert_eq!(
                (t.cmd, t.record.stop_cause),
                (Twist::ZERO, Some(StopCause::SensorBlind)),
                "fill {fill}"
            );
            assert_eq!(t.record.stop_cause.unwrap().code(), "sensor_blind");
            n.on_scan(meta(1.4), &open(), &[]);
            assert_eq!(n.tick(1.45).cmd, Twist::new(0.15, 0.0), "fill {fill}: resumes");
        }
        let mut p = agile();
        p.laser.zero_is_no_return = true;
        let settings = NodeSettings {
            nominal_source: NominalSource::Constant,
            ..NodeSettings::default()
        };
        let mut n = NodeCore::new(p, settings, None);
        for k in 0..5 {
            let stamp = 1.0 + 0.1 * k as f64;
            n.on_scan(meta(stamp), &vec![0.0; 360], &[]);
            assert_eq!(n.tick(stamp + 0.05).cmd, Twist::new(0.15, 0.0));
        }
        let mut n = node(NominalSource::Constant);
        n.on_scan(meta(1.0), &vec![f32::NEG_INFINITY; 360], &[]);
        let t = n.tick(1.05);
        assert!(t.cmd.v_mps == 0.0 && t.record.h_m < 0.0, "{t:?}");
    }

    #[test]
    fn the_watchdog_ticks_about_once_a_period_without_input_and_on_a_clock_jump() {
        let mut n = node(NominalSource::Constant);
        assert!(n.watchdog_due(1.0), "nothing published yet");
        n.on_scan(meta(1.0), &open(), &[]);
        n.tick(1.0); // the scan's own tick
                     // Period 0.1 s, polled every 25 ms: due from 87.5 ms on.
        assert!(!n.watchdog_due(1.05));
        assert!(!n.watchdog_due(1.087));
        assert!(n.watchdog_due(1.088));
        assert!(n.watchdog_due(1.3));
        // A scan tick in between moves the deadline.
        n.on_scan(meta(1.06), &open(), &[]);
        n.tick(1.06);
        assert!(!n.watchdog_due(1.1));
        assert!(n.watchdog_due(1.15));
        // The clock went back: due at once, so the jump is noticed.
        assert!(n.watchdog_due(1.0));
    }

    /// The scan that arrives is the one the next tick uses, whatever ticked before.
    #[test]
    fn a_tick_right_after_a_scan_uses_that_scan() {
        let mut n = node(NominalSource::Constant);
        let mut wall = open();
        for r in &mut wall[170..=190] {
            *r = 0.3;
        }
        for (i, ranges) in [open(), wall.clone(), open(), wall].iter().enumerate() {
            let stamp = 1.0 + 0.01 * i as f64;
            n.on_scan(meta(stamp), ranges, &[]);
            let t = n.tick(stamp + 0.001);
            assert_eq!(t.scan_stamp_s, stamp);
            assert_eq!(t.cmd.v_mps > 0.0, i % 2 == 0, "scan {i}: {t:?}");
        }
    }

    /// 360 beams from −π: free, but for a disc of `radius` m centred at `centre` (robot frame).
    fn disc_scan(centre: (f64, f64), radius: f64) -> Vec<f32> {
        let mut ranges = open();
        for (i, r) in ranges.iter_mut().enumerate() {
            let a = -std::f64::consts::PI + i as f64 * std::f64::consts::TAU / 360.0;
            let along = centre.0 * a.cos() + centre.1 * a.sin();
            let off2 = centre.0 * centre.0 + centre.1 * centre.1 - along * along;
            if along > 0.0 && off2 <= radius * radius {
                *r = (along - (radius * radius - off2).sqrt()) as f32;
            }
        }
        ranges
    }

    /// §5c: a command computed between two scans (here a planner at 50 Hz
    /// beside a 10 Hz LiDAR) sees that scan's whole perception, predicted to
    /// its own time. A person (radius 0.2 m) walks straight at the robot,
    /// which stands at the origin (odometry), at 0.5 m/s from 4 m. Once the
    /// track is a threat, every tick reports it, and 40 ms after a scan the
    /// nearest point is 0.5 · 0.04 = 0.02 m nearer than at the scan's tick:
    /// the person's points were carried along the track.
    #[test]
    fn ticks_between_scans_see_the_movers_predicted_to_their_time() {
        let mut n = node(NominalSource::CmdVelIn);
        let mut first_threat = None;
        let mut checked = 0;
        for k in 0..50 {
            let stamp = 1.0 + 0.1 * f64::from(k);
            let x = 4.0 - 0.5 * 0.1 * f64::from(k);
            n.on_scan(meta(stamp), &disc_scan((x, 0.0), 0.2), &[]);
            let mut at_scan = None;
            for j in 0..5 {
                let now = stamp + 0.02 * f64::from(j);
                n.on_odom(Pose2::default(), Twist::ZERO, now);
                n.on_cmd_in(Twist::new(0.1, 0.0), now);
                let t = n.tick(now);
                if t.record.threats > 0 && first_threat.is_none() {
                    first_threat = Some((k, j));
                }
                if first_threat.is_some() {
                    assert_eq!(t.record.threats, 1, "scan {k}, tick {j}: {:?}", t.record);
                    assert!(t.record.tracked_obstacles >= 1);
                    match (j, at_scan) {
                        (0, _) => at_scan = Some(t.record),
                        (2, Some(s)) => {
                            let nearer = s.d_min_m - t.record.d_min_m;
                            assert!((nearer - 0.02).abs() < 2e-3, "scan {k}: {nearer} m nearer 40 ms on");
                            let sooner = s.min_time_to_collision_s - t.record.min_time_to_collision_s;
                            assert!((sooner - 0.04).abs() < 0.01, "scan {k}: contact {sooner} s sooner");
                            checked += 1;
                        }
                        _ => {}
                    }
                }
            }
        }
        let (k, _) = first_threat.expect("the person became a threat");
        // Confirmed, and moving once it stands where earlier scans saw free (§6).
        assert!(k < 20, "a threat from scan {k} on");
        assert!(checked > 25, "{checked} scans checked");
    }

    #[test]
    fn new_params_apply_to_the_next_tick_and_invalid_ones_change_nothing() {
        let mut n = node(NominalSource::Constant);
        // A wall 0.9 m ahead: outside r + d_safe = 0.378 m and its 0.3 m band, so the
        // robot may approach.
        let mut wall = open();
        for r in &mut wall[170..=190] {
            *r = 0.9;
        }
        n.on_scan(meta(1.0), &wall, &[]);
        assert!(n.tick(1.0).cmd.v_mps > 0.0);
        // d_safe 0.8: r + d_safe = 0.978 m > 0.9 m, inside the unsafe set: no forward motion.
        let mut p = n.params().clone();
        p.barrier.d_safe_m = 0.8;
        n.set_params(p).unwrap();
        n.on_scan(meta(1.1), &wall, &[]);
        let t = n.tick(1.1);
        assert!(t.cmd.v_mps <= 0.0 && t.record.h_m < 0.0, "{t:?}");
        // Out of range: refused naming the key, the running value kept.
        let mut bad = n.params().clone();
        bad.barrier.d_safe_m = 30.0;
        bad.dtcbf.gamma = 0.5;
        let errors = n.set_params(bad).unwrap_err();
        assert_eq!(errors.iter().map(|e| &e.key).collect::<Vec<_>>(), ["barrier.d_safe_m"]);
        assert_eq!((n.params().barrier.d_safe_m, n.params().dtcbf.gamma), (0.8, 0.2));
    }

    #[test]
    fn new_params_keep_the_obstacle_tracks() {
        let mut n = node(NominalSource::Constant);
        // A small object 1 m ahead, seen on a few scans: a confirmed track.
        let mut ranges = open();
        for r in &mut ranges[178..=182] {
            *r = 1.0;
        }
        for i in 0..5 {
            let stamp = 1.0 + 0.1 * f64::from(i);
            n.on_scan(meta(stamp), &ranges, &[]);
            n.tick(stamp);
        }
        let tracks = n.pipeline.tracker().tracks().to_vec();
        assert!(tracks.iter().any(|t| t.is_confirmed()), "{tracks:?}");
        let mut p = n.params().clone();
        p.barrier.d_safe_m = 0.3;
        n.set_params(p).unwrap();
        assert_eq!(n.pipeline.tracker().tracks(), &tracks[..]);
    }

    /// The log's status lines say what was sent: a step without an
    /// admissible command whose least-bad command moves the robot is not "a stop".
    #[test]
    fn the_status_line_says_what_was_sent() {
        let mut n = node(NominalSource::Constant);
        n.on_scan(meta(1.0), &open(), &[]);
        let mut t = n.tick(1.05);
        assert_eq!(t.status_line(), "filtering (constant)");
        t.record.stop_cause = Some(StopCause::Infeasible);
        t.cmd = Twist::new(0.0, -0.3);
        assert_eq!(
            t.status_line(),
            "no admissible command (DTCBF infeasible): sending the least-bad command, v = 0.000 m/s, ω = -0.300 rad/s"
        );
        t.cmd = Twist::ZERO;
        assert_eq!(
            t.status_line(),
            "commanding a stop: no admissible command (DTCBF infeasible)"
        );
        let t = n.tick(1.8); // no scan for 0.75 s: stale
        assert!(
            t.status_line().starts_with("commanding a stop: scan rejected: "),
            "{}",
            t.status_line()
        );
    }

    #[test]
    fn settings_are_range_checked() {
        let s = NodeSettings {
            cmd_in_timeout_s: 0.0,
            odom_timeout_s: 61.0,
            base_frame: String::new(),
            e_stop_timeout_s: -0.1,
            disable_timeout_s: 3601.0,
            hardware_id: "two\nlines".into(),
            ..NodeSettings::default()
        };
        let e = s.validate().unwrap_err();
        let keys: Vec<_> = e.iter().map(|e| e.key.as_str()).collect();
        assert_eq!(
            keys,
            [
                "node.cmd_in_timeout_s",
                "node.odom_timeout_s",
                "node.base_frame",
                "node.e_stop_timeout_s",
                "node.disable_timeout_s",
                "node.hardware_id"
            ]
        );
        assert_eq!(
            e[3].to_string(),
            "key `node.e_stop_timeout_s` = -0.1 is out of range; allowed: [0, 60] s"
        );
        assert_eq!(
            e[4].to_string(),
            "key `node.disable_timeout_s` = 3601 is out of range; allowed: [0, 3600] s"
        );
        let s = NodeSettings {
            e_stop_timeout_s: f64::NAN,
            ..NodeSettings::default()
        };
        assert!(s.validate().is_err(), "NaN refused");
        let s = NodeSettings {
            e_stop_timeout_s: 0.0,
            disable_timeout_s: 3600.0,
            hardware_id: "front lidar".into(),
            ..NodeSettings::default()
        };
        assert!(s.validate().is_ok(), "0 and 3600 s are allowed");
        assert_eq!(
            e[0].to_string(),
            "key `node.cmd_in_timeout_s` = 0 is out of range; allowed: (0, 60] s"
        );
        assert_eq!(
            e[2].to_string(),
            "key `node.base_frame` = \"\" is out of range; allowed: a frame name, not empty"
        );
        assert!(NodeSettings::default().validate().is_ok());
        let s = NodeSettings {
            odom_timeout_s: 60.0,
            ..NodeSettings::default()
        };
        assert!(s.validate().is_ok(), "60 s is allowed");
    }
}
