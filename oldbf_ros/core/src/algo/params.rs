//! Every tunable of the pipeline, grouped as in `config/oldbf.yaml`.
//!
//! The defaults here are the paper's values where it gives them (TurtleBot3
//! scale) and are the same numbers `config/oldbf.yaml` documents; a test keeps
//! the two equal. `validate` checks every value against its allowed range and
//! names the offending key, so the CLI, the ROS node and the tests reject a bad
//! configuration the same way.

use serde::{Deserialize, Serialize};
use std::fmt;

/// All algorithm parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct Params {
    pub control: ControlParams,
    pub footprint: FootprintParams,
    pub laser: LaserParams,
    pub barrier: BarrierParams,
    pub doaa: DoaaParams,
    pub dtcbf: DtcbfParams,
    pub tracking: TrackingParams,
    pub obstacles: ObstacleParams,
    pub passive: PassiveParams,
    pub unstuck: UnstuckParams,
    pub baselines: BaselineParams,
}

/// Control loop and input box.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControlParams {
    /// Control loop rate (Hz); the DTCBF step is Δt = 1 / rate_hz.
    pub rate_hz: f64,
    /// Nominal forward speed when neither a reference nor an upstream command is given (m/s).
    pub v_nom_mps: f64,
    /// Largest forward speed ever commanded (m/s).
    pub v_max_mps: f64,
    /// Largest yaw rate ever commanded (rad/s); the paper's hardware limit is 0.3.
    pub omega_max_radps: f64,
    /// Whether the filter may command negative linear speed (backing up). It
    /// does so only on scans that cover the robot's rear (a 360° LiDAR): a
    /// robot never backs into what it cannot see.
    pub allow_reverse: bool,
    /// Largest reverse speed when `allow_reverse` (m/s, given as a positive number).
    pub v_reverse_max_mps: f64,
}

impl Default for ControlParams {
    fn default() -> Self {
        Self {
            rate_hz: 10.0,
            v_nom_mps: 0.15,
            v_max_mps: 0.22,
            omega_max_radps: 0.3,
            allow_reverse: true,
            v_reverse_max_mps: 0.15,
        }
    }
}

impl ControlParams {
    /// Control period Δt (s).
    pub fn dt_s(&self) -> f64 {
        1.0 / self.rate_hz
    }
}

/// Robot footprint: r = max(l1, l2) + b/2 (paper III.A) unless overridden.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FootprintParams {
    /// l1: first semi-axis of the robot (m).
    pub semi_axis_1_m: f64,
    /// l2: second semi-axis of the robot (m).
    pub semi_axis_2_m: f64,
    /// b: the robot's overall dimension in the paper's formula (m).
    pub overall_dimension_m: f64,
    /// If set, used as r instead of the formula (m). Absent rather than null in
    /// YAML: ROS parameters travel over XML-RPC, which has no null.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius_override_m: Option<f64>,
}

impl Default for FootprintParams {
    fn default() -> Self {
        // TurtleBot3 burger: 178 mm long, 138 mm wide.
        Self {
            semi_axis_1_m: 0.089,
            semi_axis_2_m: 0.069,
            overall_dimension_m: 0.178,
            radius_override_m: None,
        }
    }
}

impl FootprintParams {
    /// Robot radius r (m).
    pub fn radius_m(&self) -> f64 {
        self.radius_override_m
            .unwrap_or_else(|| self.semi_axis_1_m.max(self.semi_axis_2_m) + self.overall_dimension_m / 2.0)
    }
}

/// The laser's static mount pose in the robot frame and scan acceptance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LaserParams {
    /// Laser origin x in the robot frame (m, forward).
    pub mount_x_m: f64,
    /// Laser origin y in the robot frame (m, left).
    pub mount_y_m: f64,
    /// Laser yaw in the robot frame (deg, CCW).
    pub mount_yaw_deg: f64,
    /// A scan older than this, or stamped this far in the future, is rejected (s).
    pub scan_timeout_s: f64,
    /// Scans with more beams than this are rejected (bounds memory and time).
    pub max_beams: usize,
    /// How invalid readings are read (ALGORITHM.md §1): REP 117 (unknown is
    /// not free), or the paper method's "every invalid reading is free".
    pub range_semantics: RangeSemantics,
    /// The driver writes 0.0 for "no return" (TurtleBot3's LDS): 0.0 then
    /// means free. Off by default: 0.0 is below range_min, i.e. unknown.
    pub zero_is_no_return: bool,
    /// An unknown beam keeps its last valid reading this long (s); 0 = no hold.
    pub unknown_hold_s: f64,
    /// Full angle of the front sector watched for a blinded sensor (deg).
    pub blind_sector_deg: f64,
    /// The sensor is blind when more than this fraction of that sector's beams
    /// read unknown…
    pub blind_fraction: f64,
    /// …for longer than this (s): stop and report `sensor_blind`.
    pub blind_timeout_s: f64,
}

/// How a scan's invalid readings are interpreted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RangeSemantics {
    /// ROS REP 117: +inf / ≥ range_max free, −inf an obstacle at range_min,
    /// NaN and below range_min unknown (held, and blindness detected).
    Rep117,
    /// The paper method (and this project before REP 117 semantics): every
    /// invalid reading is free space.
    AllInvalidFree,
}

impl Default for LaserParams {
    fn default() -> Self {
        Self {
            mount_x_m: 0.0,
            mount_y_m: 0.0,
            mount_yaw_deg: 0.0,
            scan_timeout_s: 0.5,
            max_beams: 16384,
            range_semantics: RangeSemantics::Rep117,
            zero_is_no_return: false,
            unknown_hold_s: 2.0,
            blind_sector_deg: 180.0,
            blind_fraction: 0.5,
            blind_timeout_s: 0.3,
        }
    }
}

/// OLDBF barrier B = B_d + B_v (paper III.B).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BarrierParams {
    /// d_safe: clearance (beyond r) that defines the safe set h = d_min − d_safe ≥ 0 (m).
    pub d_safe_m: f64,
    /// Γ: barrier scale; the activation band is Γ^(2/σ) metres wide.
    pub big_gamma: f64,
    /// σ: exponent on the proximity Δd in B_d.
    pub sigma: f64,
    /// ζ: weight of the speed term B_v.
    pub zeta: f64,
    /// β: exponent on |v| in the denominator of B_v.
    pub beta: f64,
    /// B values are saturated here (B_d is +inf at d ≤ d_safe).
    pub barrier_max: f64,
    /// Full angle of the left/right hemisphere sector, centred ahead (deg).
    pub hemisphere_fov_deg: f64,
    /// Full angle of the front sector used by the both-sides rule (deg). The
    /// default 30° is the robot's swept width at activation range:
    /// 2·asin((r + d_safe) / (r + d_act)) = 2·asin(0.378 / 1.378) ≈ 32°, so a
    /// corridor wall beside the robot does not count as "ahead".
    pub front_fov_deg: f64,
    /// Fade angle of the side sectors (deg): a point's contribution to a side
    /// fades out over this much bearing past bearing 0 and before the
    /// hemisphere's edge, so B_l and B_r change continuously (§4b); 0 = the
    /// hard sectors of the definition.
    pub side_fade_deg: f64,
}

impl Default for BarrierParams {
    fn default() -> Self {
        Self {
            d_safe_m: 0.20,
            big_gamma: 1.0,
            sigma: 2.0,
            zeta: 0.5,
            beta: 2.0,
            barrier_max: 1000.0,
            hemisphere_fov_deg: 180.0,
            front_fov_deg: 30.0,
            side_fade_deg: 30.0,
        }
    }
}

impl BarrierParams {
    /// d_act = d_safe + Γ^(2/σ): clearance below which B_d exceeds 1 (m).
    pub fn d_act_m(&self) -> f64 {
        self.d_safe_m + self.big_gamma.powf(2.0 / self.sigma)
    }
}

/// DOAA steering law (paper III.C, sign-corrected eq. 5).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DoaaParams {
    /// k: yaw rate per unit of barrier difference, ω = sat(ω_nom + k (B_r − B_l)) (rad/s).
    pub gain_k_radps: f64,
    /// ω_0: fixed turn rate when obstacles block both sides and the front (rad/s).
    pub omega_0_radps: f64,
    /// The both-sides turn is released when the front clearance exceeds d_act by this (m).
    pub both_sides_release_m: f64,
    /// In the both-sides turn, linear speed is 0 when the front clearance is below d_safe + this (m).
    pub front_stop_margin_m: f64,
    /// The both-sides turn starts only when the nominal forward speed exceeds this
    /// (m/s); it is released when the nominal has no forward speed.
    pub both_sides_min_speed_mps: f64,
    /// The both-sides turn needs the front obstacle to be the nearest: d_front ≤ min(d_l, d_r) + this (m).
    pub front_nearest_tolerance_m: f64,
    /// The avoidance term k (B_r − B_l) has full weight at nominal forward speeds ≥ this,
    /// and falls linearly to 0 at a standstill (m/s).
    pub full_gain_speed_mps: f64,
    /// Commit to the side an obstacle ahead is passed on until the front is
    /// clear (§4b); false = the differential law alone, whose sign follows the
    /// nearest point across bearing 0.
    pub commit_turns: bool,
    /// While committed and the front is blocked, turn at least this fraction
    /// of ω_max the committed way (scaled like the avoidance term by speed).
    pub commit_min_turn: f64,
    /// Largest change of the DOAA's yaw rate from the last command sent, per
    /// control step (rad/s); the DTCBF then judges the command actually sent.
    /// 0 = no limit.
    pub max_omega_change_radps: f64,
}

impl Default for DoaaParams {
    fn default() -> Self {
        Self {
            gain_k_radps: 0.5,
            omega_0_radps: 0.3,
            both_sides_release_m: 0.1,
            front_stop_margin_m: 0.05,
            both_sides_min_speed_mps: 0.02,
            front_nearest_tolerance_m: 0.05,
            full_gain_speed_mps: 0.1,
            commit_turns: true,
            commit_min_turn: 0.5,
            max_omega_change_radps: 0.25,
        }
    }
}

/// How the one-step prediction z(k+1) = F(z(k), u(k)) integrates the unicycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PredictionModel {
    /// Paper eq. 6 with Δt explicit: x+ = x + Δt v cos θ, θ+ = θ + Δt ω.
    Euler,
    /// Exact zero-order-hold solution: the robot moves along an arc.
    Arc,
}

/// The discrete-time CBF filter (paper II.E, eq. 3-4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DtcbfParams {
    /// γ in h(k+1) ≥ (1 − γ) h(k); 1 only asks h(k+1) ≥ 0, small values approach more slowly.
    pub gamma: f64,
    /// Inside the unsafe set (h < 0) a command must raise h by at least this per step (m).
    pub escape_epsilon_m: f64,
    /// δ: the filter first enforces the condition on h − δ, so sensor noise up to δ does not
    /// push the measured h of a robot resting near the boundary below 0 (m). 0 = the definition.
    pub noise_margin_m: f64,
    /// Integration of the one-step prediction.
    pub prediction: PredictionModel,
    /// Number of yaw rates tried across [−ω_max, ω_max] when ω must change too (odd).
    pub omega_candidates: usize,
    /// w in the cost (v − v_d)² + w (ω − ω_d)² for picking the closest safe command (m²/rad²).
    pub omega_weight_m2_per_rad2: f64,
}

impl Default for DtcbfParams {
    fn default() -> Self {
        Self {
            gamma: 0.2,
            escape_epsilon_m: 0.001,
            noise_margin_m: 0.03,
            prediction: PredictionModel::Euler,
            omega_candidates: 21,
            omega_weight_m2_per_rad2: 0.05,
        }
    }
}

/// Kanayama tracking gains (paper IV.C; eq. 8 completed).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackingParams {
    /// k_x: along-track error gain (1/s).
    pub k_x_per_s: f64,
    /// k_y: cross-track error gain (1/m²).
    pub k_y_per_m2: f64,
    /// k_θ: heading error gain (1/m).
    pub k_theta_per_m: f64,
    /// Within this distance of the reference point Kanayama's law applies alone;
    /// beyond twice it, the go-to-point law does (m).
    pub capture_radius_m: f64,
    /// k_β: yaw rate per radian of bearing to the reference point in go-to-point mode (1/s).
    pub k_bearing_per_s: f64,
    /// Once the reference has ended, the command is zero within this distance of the goal (m).
    pub arrive_radius_m: f64,
}

impl Default for TrackingParams {
    fn default() -> Self {
        Self {
            k_x_per_s: 1.0,
            k_y_per_m2: 10.0,
            k_theta_per_m: 4.0,
            capture_radius_m: 0.5,
            k_bearing_per_s: 1.0,
            arrive_radius_m: 0.05,
        }
    }
}

/// Moving obstacles: clustering, tracking and the collision cone (ALGORITHM.md §6).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObstacleParams {
    /// Track clusters and use their motion in the DTCBF prediction and the barriers.
    pub enabled: bool,
    /// Neighbouring points closer than this belong to one cluster (m).
    pub cluster_gap_m: f64,
    /// Clusters with fewer points are not tracked.
    pub min_cluster_points: usize,
    /// Clusters wider than this (walls, furniture) are not tracked (m).
    pub max_cluster_diameter_m: f64,
    /// A cluster is associated with a track within this distance of its prediction (m).
    pub gate_m: f64,
    /// Associations in a row that confirm a track.
    pub confirm_hits: u32,
    /// A confirmed track coasts this many missed scans before it is deleted.
    pub max_misses: u32,
    /// Process noise: white acceleration standard deviation (m/s²).
    pub accel_noise_mps2: f64,
    /// Centroid measurement noise standard deviation (m).
    pub measurement_noise_m: f64,
    /// A confirmed track faster than this is moving (m/s)…
    pub moving_speed_mps: f64,
    /// …once it has been this far from where it was first seen (m; kept when it turns round).
    pub min_travel_m: f64,
    /// Horizon over which an obstacle on a collision course raises its side's barrier (s).
    pub lookahead_s: f64,
    /// At most this many tracks (bounds memory and time).
    pub max_tracks: usize,
}

impl Default for ObstacleParams {
    fn default() -> Self {
        Self {
            enabled: true,
            cluster_gap_m: 0.15,
            min_cluster_points: 3,
            max_cluster_diameter_m: 0.7,
            gate_m: 0.5,
            confirm_hits: 3,
            max_misses: 5,
            accel_noise_mps2: 1.0,
            measurement_noise_m: 0.05,
            moving_speed_mps: 0.02,
            min_travel_m: 0.3,
            lookahead_s: 2.0,
            max_tracks: 32,
        }
    }
}

/// The comparison controllers (ALGORITHM.md §8; `--controller dcbf|vo`).
/// Not used by the OLDBF filter or the ROS node.
/// Getting round an obstacle when steering alone has stalled (ALGORITHM.md §4b).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UnstuckParams {
    /// Follow free directions when progress stalls; false = reactive steering only.
    pub enabled: bool,
    /// Progress stalled: less than `progress_m` gained for this long (s).
    pub stall_s: f64,
    /// Progress that counts (m of the reference's arc length minus distance to it).
    pub progress_m: f64,
    /// Width of the square window round the robot the way round is planned in (m).
    pub window_m: f64,
    /// The way round keeps r + d_safe + this from every point (m).
    pub margin_m: f64,
    /// The way round heads for the point this far further along the
    /// reference's path than the (governed) reference point (m).
    pub ahead_m: f64,
}

impl Default for UnstuckParams {
    fn default() -> Self {
        Self {
            enabled: true,
            stall_s: 6.0,
            progress_m: 0.15,
            window_m: 5.0,
            margin_m: 0.05,
            ahead_m: 1.5,
        }
    }
}

/// Passive motion safety and evasion (ALGORITHM.md §5b).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PassiveParams {
    /// The braking check and evasion; false = the paper's one-step condition only.
    pub enabled: bool,
    /// Deceleration the robot can always achieve when braking to rest (m/s²).
    pub brake_decel_mps2: f64,
    /// A moving obstacle's predicted disc is inflated by this at once (m)…
    pub mover_margin_m: f64,
    /// …and grows by this per second of prediction (m/s): unmodelled turns
    /// and accelerations of people.
    pub mover_growth_mps: f64,
    /// Robot speed towards an obstacle above which a contact is "closing" (m/s).
    pub closing_speed_mps: f64,
    /// Evasion scores a command by the predicted time to contact with the
    /// command held this long (s).
    pub evasion_horizon_s: f64,
    /// Evasion replaces the filter's command only if it gains at least this
    /// much predicted time to contact (s): no dithering between near-equals.
    pub evasion_min_gain_s: f64,
}

impl Default for PassiveParams {
    fn default() -> Self {
        Self {
            enabled: true,
            brake_decel_mps2: 1.0,
            mover_margin_m: 0.05,
            mover_growth_mps: 0.1,
            closing_speed_mps: 0.02,
            evasion_horizon_s: 4.0,
            evasion_min_gain_s: 0.2,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct BaselineParams {
    pub dcbf: DcbfParams,
    pub vo: VoParams,
}

/// The standard discrete-time CBF-QP safety filter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DcbfParams {
    /// Distance of the controlled point ahead of the axle centre (m): through
    /// it, ω enters the (otherwise v-only) unicycle constraints.
    pub lookahead_m: f64,
    /// One constraint per angular sector of this width: the sector's nearest point (deg).
    pub sector_deg: f64,
    /// Cost weight of (ω − ω_nom)² relative to (v − v_nom)² ((m/s)²/(rad/s)²).
    pub omega_weight: f64,
    /// Linear penalty on the one slack that keeps the QP feasible (per m);
    /// the slack is zero whenever the hard-constrained QP is feasible.
    pub slack_penalty: f64,
}

impl Default for DcbfParams {
    fn default() -> Self {
        Self {
            lookahead_m: 0.1,
            sector_deg: 10.0,
            omega_weight: 1.0,
            slack_penalty: 1000.0,
        }
    }
}

/// The ORCA velocity-obstacle avoider (dodgy_2d) mapped to the unicycle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VoParams {
    /// Collisions with moving obstacles are avoided this far ahead (s).
    pub time_horizon_s: f64,
    /// Collisions with static geometry are avoided this far ahead (s).
    pub static_time_horizon_s: f64,
    /// Yaw rate per radian between heading and the chosen velocity (1/s).
    pub heading_gain_per_s: f64,
    /// Static scan outlines are simplified to vertices at least this far apart (m).
    pub vertex_spacing_m: f64,
}

impl Default for VoParams {
    fn default() -> Self {
        Self {
            time_horizon_s: 2.0,
            static_time_horizon_s: 1.0,
            heading_gain_per_s: 2.0,
            vertex_spacing_m: 0.05,
        }
    }
}

/// A parameter outside its allowed range.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamError {
    /// Dotted path of the key, as in the YAML file, e.g. `barrier.d_safe_m`.
    pub key: &'static str,
    /// The offending value, printed.
    pub value: String,
    /// The allowed range or rule, e.g. `(0, 1]`.
    pub allowed: &'static str,
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "key `{}` = {} is out of range; allowed: {}",
            self.key, self.value, self.allowed
        )
    }
}

impl std::error::Error for ParamError {}

/// Parses an interval written as in the messages, e.g. `(0, 1]` or
/// `[-5, 5] m` (a unit may follow), into (lo, lo_open, hi, hi_open).
fn parse_interval(allowed: &str) -> Option<(f64, bool, f64, bool)> {
    let lo_open = allowed.starts_with('(');
    let close = allowed.find([']', ')'])?;
    let hi_open = allowed[close..].starts_with(')');
    let (lo, hi) = allowed[1..close].split_once(',')?;
    Some((lo.trim().parse().ok()?, lo_open, hi.trim().parse().ok()?, hi_open))
}

/// Collects every failed check.
struct Check {
    errors: Vec<ParamError>,
}

impl Check {
    /// `allowed` is the interval the message shows, and what is checked.
    fn range(&mut self, key: &'static str, v: f64, allowed: &'static str) {
        let (lo, lo_open, hi, hi_open) = parse_interval(allowed).expect("interval literal is well formed");
        let ok = v.is_finite() && (if lo_open { v > lo } else { v >= lo }) && (if hi_open { v < hi } else { v <= hi });
        self.rule(ok, key, format!("{v}"), allowed);
    }

    /// `v` may not exceed another key's value (NaN is reported by its own range check).
    fn at_most(&mut self, key: &'static str, v: f64, limit: f64, allowed: &'static str) {
        self.rule(v <= limit || v.is_nan(), key, format!("{v}"), allowed);
    }

    fn rule(&mut self, ok: bool, key: &'static str, value: String, allowed: &'static str) {
        if !ok {
            self.errors.push(ParamError { key, value, allowed });
        }
    }
}

impl Params {
    /// Robot radius r (m).
    pub fn robot_radius_m(&self) -> f64 {
        self.footprint.radius_m()
    }

    /// The same parameters with what this project added beyond the paper switched
    /// off: `laser.range_semantics: all_invalid_free` (every invalid range is
    /// free space: no hold, no blindness check), `barrier.side_fade_deg: 0` (hard
    /// side sectors), `doaa.commit_turns: false`, `doaa.max_omega_change_radps:
    /// 0` (no yaw-rate step limit), `unstuck.enabled: false`, `passive.enabled:
    /// false` (no braking check or evasion) and `control.allow_reverse: false`.
    /// Everything else, obstacle tracking included, is left as given. This is the
    /// filter as it was before REP 117 semantics, passive motion safety and the
    /// liveness additions. It is the `oldbf-paper` controller (`oldbf batch
    /// --controllers oldbf-paper`, also `oldbf compare` and `oldbf sim
    /// --controller`), kept so the tables can measure the difference on the same
    /// worlds (ALGORITHM.md §8). There is no YAML file for it.
    pub fn paper_method(mut self) -> Self {
        self.laser.range_semantics = RangeSemantics::AllInvalidFree;
        self.barrier.side_fade_deg = 0.0;
        self.doaa.commit_turns = false;
        self.doaa.max_omega_change_radps = 0.0;
        self.unstuck.enabled = false;
        self.passive.enabled = false;
        self.control.allow_reverse = false;
        self
    }

    /// Every out-of-range value, each naming its key; empty when valid.
    pub fn validate(&self) -> Result<(), Vec<ParamError>> {
        let mut c = Check { errors: Vec::new() };
        let ctl = &self.control;
        c.range("control.rate_hz", ctl.rate_hz, "(0, 1000] Hz");
        c.range("control.v_nom_mps", ctl.v_nom_mps, "[0, 5] m/s");
        c.at_most(
            "control.v_nom_mps",
            ctl.v_nom_mps,
            ctl.v_max_mps,
            "at most control.v_max_mps",
        );
        c.range("control.v_max_mps", ctl.v_max_mps, "(0, 5] m/s");
        c.range("control.omega_max_radps", ctl.omega_max_radps, "(0, 10] rad/s");
        c.range("control.v_reverse_max_mps", ctl.v_reverse_max_mps, "[0, 5] m/s");

        let fp = &self.footprint;
        c.range("footprint.semi_axis_1_m", fp.semi_axis_1_m, "[0, 5] m");
        c.range("footprint.semi_axis_2_m", fp.semi_axis_2_m, "[0, 5] m");
        c.range("footprint.overall_dimension_m", fp.overall_dimension_m, "[0, 10] m");
        if let Some(r) = fp.radius_override_m {
            c.range("footprint.radius_override_m", r, "[0, 5] m");
        }

        let l = &self.laser;
        c.range("laser.mount_x_m", l.mount_x_m, "[-5, 5] m");
        c.range("laser.mount_y_m", l.mount_y_m, "[-5, 5] m");
        c.range("laser.mount_yaw_deg", l.mount_yaw_deg, "[-360, 360] deg");
        c.range("laser.scan_timeout_s", l.scan_timeout_s, "(0, 60] s");
        c.range("laser.max_beams", l.max_beams as f64, "[1, 1000000]");
        c.range("laser.unknown_hold_s", l.unknown_hold_s, "[0, 60] s");
        c.range("laser.blind_sector_deg", l.blind_sector_deg, "(0, 360] deg");
        c.range("laser.blind_fraction", l.blind_fraction, "(0, 1]");
        c.range("laser.blind_timeout_s", l.blind_timeout_s, "[0, 60] s");

        let b = &self.barrier;
        c.range("barrier.d_safe_m", b.d_safe_m, "[0, 10] m");
        c.range("barrier.big_gamma", b.big_gamma, "(0, 100]");
        c.range("barrier.sigma", b.sigma, "[0.1, 10]");
        c.range("barrier.zeta", b.zeta, "[0, 100]");
        c.range("barrier.beta", b.beta, "[0.1, 10]");
        c.range("barrier.barrier_max", b.barrier_max, "(1, 1e12]");
        c.range("barrier.hemisphere_fov_deg", b.hemisphere_fov_deg, "(0, 360] deg");
        c.range("barrier.front_fov_deg", b.front_fov_deg, "(0, 360] deg");
        c.range("barrier.side_fade_deg", b.side_fade_deg, "[0, 90] deg");
        if b.d_safe_m.is_finite() && b.big_gamma.is_finite() && b.sigma.is_finite() {
            let band = b.d_act_m() - b.d_safe_m;
            c.rule(
                band.is_finite() && band <= 100.0,
                "barrier.big_gamma",
                format!("{}", b.big_gamma),
                "Γ^(2/σ) at most 100 m",
            );
        }

        let d = &self.doaa;
        c.range("doaa.gain_k_radps", d.gain_k_radps, "[0, 100] rad/s");
        c.range("doaa.omega_0_radps", d.omega_0_radps, "(0, 10] rad/s");
        c.at_most(
            "doaa.omega_0_radps",
            d.omega_0_radps,
            ctl.omega_max_radps,
            "at most control.omega_max_radps",
        );
        c.range("doaa.both_sides_release_m", d.both_sides_release_m, "[0, 10] m");
        c.range("doaa.front_stop_margin_m", d.front_stop_margin_m, "[0, 10] m");
        c.range(
            "doaa.both_sides_min_speed_mps",
            d.both_sides_min_speed_mps,
            "[0, 5] m/s",
        );
        c.range(
            "doaa.front_nearest_tolerance_m",
            d.front_nearest_tolerance_m,
            "[0, 10] m",
        );
        // Divides the nominal speed: 0 would make the gain weight NaN at a standstill.
        c.range("doaa.full_gain_speed_mps", d.full_gain_speed_mps, "(0, 5] m/s");
        c.range("doaa.commit_min_turn", d.commit_min_turn, "[0, 1]");
        c.range("doaa.max_omega_change_radps", d.max_omega_change_radps, "[0, 20] rad/s");

        let f = &self.dtcbf;
        c.range("dtcbf.gamma", f.gamma, "(0, 1]");
        c.range("dtcbf.escape_epsilon_m", f.escape_epsilon_m, "(0, 0.1] m");
        c.range("dtcbf.noise_margin_m", f.noise_margin_m, "[0, 1] m");
        c.rule(
            (3..=201).contains(&f.omega_candidates) && f.omega_candidates % 2 == 1,
            "dtcbf.omega_candidates",
            format!("{}", f.omega_candidates),
            "odd, in [3, 201]",
        );
        c.range(
            "dtcbf.omega_weight_m2_per_rad2",
            f.omega_weight_m2_per_rad2,
            "[0, 1000] m²/rad²",
        );

        let t = &self.tracking;
        c.range("tracking.k_x_per_s", t.k_x_per_s, "[0, 100] 1/s");
        c.range("tracking.k_y_per_m2", t.k_y_per_m2, "[0, 1000] 1/m²");
        c.range("tracking.k_theta_per_m", t.k_theta_per_m, "[0, 1000] 1/m");
        c.range("tracking.capture_radius_m", t.capture_radius_m, "(0, 100] m");
        c.range("tracking.k_bearing_per_s", t.k_bearing_per_s, "[0, 100] 1/s");
        c.range("tracking.arrive_radius_m", t.arrive_radius_m, "[0, 10] m");

        let o = &self.obstacles;
        c.range("obstacles.cluster_gap_m", o.cluster_gap_m, "(0, 5] m");
        c.range("obstacles.min_cluster_points", o.min_cluster_points as f64, "[1, 1000]");
        c.range(
            "obstacles.max_cluster_diameter_m",
            o.max_cluster_diameter_m,
            "(0, 10] m",
        );
        c.range("obstacles.gate_m", o.gate_m, "(0, 10] m");
        c.range("obstacles.confirm_hits", o.confirm_hits as f64, "[1, 100]");
        c.range("obstacles.max_misses", o.max_misses as f64, "[0, 1000]");
        c.range("obstacles.accel_noise_mps2", o.accel_noise_mps2, "(0, 100] m/s²");
        c.range("obstacles.measurement_noise_m", o.measurement_noise_m, "(0, 10] m");
        c.range("obstacles.moving_speed_mps", o.moving_speed_mps, "[0, 10] m/s");
        c.range("obstacles.min_travel_m", o.min_travel_m, "[0, 100] m");
        c.range("obstacles.lookahead_s", o.lookahead_s, "[0, 60] s");
        c.range("obstacles.max_tracks", o.max_tracks as f64, "[1, 1000]");

        let u = &self.unstuck;
        c.range("unstuck.stall_s", u.stall_s, "(0, 600] s");
        c.range("unstuck.progress_m", u.progress_m, "(0, 10] m");
        c.range("unstuck.window_m", u.window_m, "[1, 20] m");
        c.range("unstuck.margin_m", u.margin_m, "[0, 1] m");
        c.range("unstuck.ahead_m", u.ahead_m, "[0, 20] m");

        let pa = &self.passive;
        c.range("passive.brake_decel_mps2", pa.brake_decel_mps2, "(0, 100] m/s²");
        c.range("passive.mover_margin_m", pa.mover_margin_m, "[0, 2] m");
        c.range("passive.mover_growth_mps", pa.mover_growth_mps, "[0, 10] m/s");
        c.range("passive.closing_speed_mps", pa.closing_speed_mps, "[0, 1] m/s");
        c.range("passive.evasion_horizon_s", pa.evasion_horizon_s, "(0, 10] s");
        c.range("passive.evasion_min_gain_s", pa.evasion_min_gain_s, "[0, 10] s");

        let (dc, vo) = (&self.baselines.dcbf, &self.baselines.vo);
        c.range("baselines.dcbf.lookahead_m", dc.lookahead_m, "(0, 1] m");
        c.range("baselines.dcbf.sector_deg", dc.sector_deg, "(0, 180] deg");
        c.range("baselines.dcbf.omega_weight", dc.omega_weight, "(0, 1000]");
        c.range("baselines.dcbf.slack_penalty", dc.slack_penalty, "(0, 1e9]");
        c.range("baselines.vo.time_horizon_s", vo.time_horizon_s, "(0, 60] s");
        c.range(
            "baselines.vo.static_time_horizon_s",
            vo.static_time_horizon_s,
            "(0, 60] s",
        );
        c.range("baselines.vo.heading_gain_per_s", vo.heading_gain_per_s, "(0, 100] 1/s");
        c.range("baselines.vo.vertex_spacing_m", vo.vertex_spacing_m, "[0, 1] m");

        if c.errors.is_empty() {
            Ok(())
        } else {
            Err(c.errors)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid() {
        assert_eq!(Params::default().validate(), Ok(()));
    }

    #[test]
    fn paper_radius_formula() {
        // r = max(0.089, 0.069) + 0.178 / 2 = 0.178 m.
        assert!((Params::default().robot_radius_m() - 0.178).abs() < 1e-12);
        let mut p = Params::default();
        p.footprint.radius_override_m = Some(0.105);
        assert_eq!(p.robot_radius_m(), 0.105);
    }

    #[test]
    fn activation_distance_is_d_safe_plus_gamma_power() {
        let mut b = BarrierParams::default();
        // Γ = 1: Γ^(2/σ) = 1 whatever σ.
        assert!((b.d_act_m() - 1.2).abs() < 1e-12);
        b.big_gamma = 0.25; // σ = 2: 0.25^(1) = 0.25.
        assert!((b.d_act_m() - 0.45).abs() < 1e-12);
        b.sigma = 4.0; // 0.25^(0.5) = 0.5.
        assert!((b.d_act_m() - 0.7).abs() < 1e-12);
    }

    #[test]
    fn out_of_range_values_name_their_keys() {
        let mut p = Params::default();
        p.dtcbf.gamma = 1.5;
        p.barrier.d_safe_m = f64::NAN;
        p.dtcbf.omega_candidates = 20;
        let keys: Vec<_> = p.validate().unwrap_err().iter().map(|e| e.key).collect();
        assert_eq!(keys, ["barrier.d_safe_m", "dtcbf.gamma", "dtcbf.omega_candidates"]);
    }

    #[test]
    fn interval_literals_parse() {
        assert_eq!(parse_interval("(0, 1]"), Some((0.0, true, 1.0, false)));
        assert_eq!(parse_interval("[-5, 5] m"), Some((-5.0, false, 5.0, false)));
        assert_eq!(parse_interval("(1, 1e12)"), Some((1.0, true, 1e12, true)));
        let mut c = Check { errors: vec![] };
        c.range("k", 0.0, "(0, 1]");
        c.range("k", 1.0, "(0, 1]");
        c.range("k", 1.0, "[0, 1)");
        c.range("k", f64::INFINITY, "[0, 1e12]");
        assert_eq!(c.errors.len(), 3);
    }

    #[test]
    fn cross_field_rules() {
        let mut p = Params::default();
        p.control.v_nom_mps = 0.3; // above v_max 0.22
        p.doaa.omega_0_radps = 0.5; // above omega_max 0.3
        let keys: Vec<_> = p.validate().unwrap_err().iter().map(|e| e.key).collect();
        assert_eq!(keys, ["control.v_nom_mps", "doaa.omega_0_radps"]);
    }
}
