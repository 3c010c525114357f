//! The per-step record: everything the pipeline decided, for logs, CSV,
//! the ROS `~state` topic and the tests. Plain `Copy` data, so producing it
//! does not allocate.

use super::doaa::DoaaState;
use super::geometry::{Twist, Vec2};
use super::scan::ScanRejection;
use super::select::{CriticCosts, Tier};
use std::fmt;

/// Why the command is a stop (when it is).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StopCause {
    /// The scan was rejected.
    Rejected(ScanRejection),
    /// No scan has arrived yet (or none since `scan_timeout`).
    NoScan,
    /// The nominal command was not finite.
    BadNominal,
    /// No command in the input box satisfies the DTCBF condition.
    Infeasible,
    /// An e-stop is latched.
    EStop,
    /// The front of the scan has been mostly unknown for longer than
    /// `laser.blind_timeout_s` (a blinded or failing sensor).
    SensorBlind,
}

/// Why no command satisfied the checks this step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Infeasibility {
    /// h < 0 and no command raises h: inside the unsafe set (something walked
    /// in, or range noise near the boundary).
    UnsafeSet,
    /// h ≥ 0 but standing still breaks the condition too: an obstacle is
    /// approaching faster than the robot can get away.
    Approaching,
    /// The one-step condition can be met, but only by commands that would
    /// drive into a predicted occupancy (§5b).
    NoPassiveCommand,
}

impl Infeasibility {
    /// Short machine-readable name (CSV `infeasible` column, `~state`).
    pub fn code(&self) -> &'static str {
        match self {
            Self::UnsafeSet => "unsafe_set",
            Self::Approaching => "approaching",
            Self::NoPassiveCommand => "no_passive_command",
        }
    }
}

impl fmt::Display for Infeasibility {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::UnsafeSet => "inside the unsafe set, no command raises h",
            Self::Approaching => "an obstacle approaches faster than any command gets away",
            Self::NoPassiveCommand => "every command meeting the condition drives into a predicted occupancy",
        })
    }
}

impl fmt::Display for StopCause {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Rejected(r) => write!(f, "scan rejected: {r}"),
            Self::NoScan => write!(f, "no recent scan"),
            Self::BadNominal => write!(f, "nominal command not finite"),
            Self::Infeasible => write!(f, "no admissible command (DTCBF infeasible)"),
            Self::EStop => write!(f, "e-stop latched"),
            Self::SensorBlind => write!(f, "sensor blind: the front of the scan reads unknown"),
        }
    }
}

impl StopCause {
    /// Short machine-readable name (diagnostics, `~state`, logs).
    pub fn code(&self) -> &'static str {
        match self {
            Self::Rejected(r) => r.code(),
            Self::NoScan => "no_scan",
            Self::BadNominal => "bad_nominal",
            Self::Infeasible => "infeasible",
            Self::EStop => "e_stop",
            Self::SensorBlind => "sensor_blind",
        }
    }
}

/// One control step. When the scan was rejected (`stop_cause` is `Rejected`
/// or `NoScan`) the barrier and distance fields are NaN: nothing was measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepRecord {
    /// Time of the step (s).
    pub stamp_s: f64,
    /// The command sent: finite, inside the input box.
    pub cmd: Twist,
    /// The nominal command (reference tracking or upstream).
    pub nominal: Twist,
    /// The DOAA command before the DTCBF check.
    pub doaa_cmd: Twist,
    /// The DOAA state this step.
    pub state: DoaaState,
    /// h(k) = d_min − d_safe (m).
    pub h_m: f64,
    /// Predicted h(k+1) for `cmd` (m).
    pub h_next_m: f64,
    /// Whether the DTCBF check changed the DOAA command.
    pub filter_changed: bool,
    /// Whether h(k+1) ≥ (1 − γ) h(k) holds for `cmd`.
    pub condition_held: bool,
    /// Whether `cmd` can brake to rest without a closing contact with any
    /// predicted occupancy (§5b), whether or not the check is enabled.
    pub braking_held: bool,
    /// Whether the passive-safety check or evasion changed the DTCBF's command.
    pub passive_changed: bool,
    /// Why no command met the checks, when none did (`cmd` is then the
    /// fallback: a stop, a turn in place, or the evasive command).
    pub infeasibility: Option<Infeasibility>,
    /// The level of the relaxation order the command came from (§5c);
    /// `None` for a stop without a usable scan and for the paper's decision.
    pub tier: Option<Tier>,
    /// Each critic's weighted cost for the command sent (§5c; zero for the
    /// paper's decision and for stops).
    pub costs: CriticCosts,
    /// The command goes faster than the upstream command or reverses where
    /// it does not: an escape from the unsafe set, or evasion of a tracked
    /// mover (§5c says so).
    pub added_motion: bool,
    /// A tracked mover threatened: the window was opened to the base's own
    /// limits for evasion (`passive.evasion_*accel*`, §5c).
    pub evading: bool,
    /// A way round began or ended at this step, and why (§4c).
    pub route_event: Option<crate::algo::unstuck::RouteEvent>,
    /// No route to the goal: the robot rests (§4c).
    pub no_route: bool,
    /// Barrier of the left side, B_l = B_d,l + B_v (dimensionless).
    pub b_left: f64,
    /// Barrier of the right side, B_r = B_d,r + B_v.
    pub b_right: f64,
    /// The velocity barrier B_v, shared by both sides.
    pub b_velocity: f64,
    /// Least clearance on the left, d_l (m).
    pub d_left_m: f64,
    /// Least clearance on the right, d_r (m).
    pub d_right_m: f64,
    /// d_min = min(d_l, d_r) (m).
    pub d_min_m: f64,
    /// Clearance straight ahead (m).
    pub d_front_m: f64,
    /// Closest point on the left, robot frame (m).
    pub closest_left: Option<Vec2>,
    /// Closest point on the right, robot frame (m).
    pub closest_right: Option<Vec2>,
    /// Beams in the scan.
    pub beams: usize,
    /// Beams with a valid range (a point).
    pub valid_beams: usize,
    /// Beams reading unknown (NaN, below range_min), and of those the ones
    /// whose last valid reading is held as a point.
    pub unknown_beams: usize,
    /// Of the unknown beams, those held at their last valid reading.
    pub held_beams: usize,
    /// Unknown fraction of the front sector watched for blindness.
    pub unknown_front_fraction: f64,
    /// Confirmed moving tracks.
    pub tracked_obstacles: usize,
    /// Of those, on a collision course (their motion entered the prediction).
    pub threats: usize,
    /// Least time to collision among them (s); +inf for none.
    pub min_time_to_collision_s: f64,
    /// Why the pipeline stopped the robot, if it did.
    pub stop_cause: Option<StopCause>,
}

impl StepRecord {
    /// A stop record for a step where no usable scan existed.
    pub fn stop(stamp_s: f64, nominal: Twist, cause: StopCause) -> Self {
        Self {
            stamp_s,
            cmd: Twist::ZERO,
            nominal,
            doaa_cmd: Twist::ZERO,
            state: DoaaState::Stop,
            h_m: f64::NAN,
            h_next_m: f64::NAN,
            filter_changed: false,
            condition_held: false,
            braking_held: true,
            passive_changed: false,
            infeasibility: None,
            tier: None,
            costs: CriticCosts::default(),
            added_motion: false,
            evading: false,
            route_event: None,
            no_route: false,
            b_left: f64::NAN,
            b_right: f64::NAN,
            b_velocity: f64::NAN,
            d_left_m: f64::NAN,
            d_right_m: f64::NAN,
            d_min_m: f64::NAN,
            d_front_m: f64::NAN,
            closest_left: None,
            closest_right: None,
            beams: 0,
            valid_beams: 0,
            unknown_beams: 0,
            held_beams: 0,
            unknown_front_fraction: f64::NAN,
            tracked_obstacles: 0,
            threats: 0,
            min_time_to_collision_s: f64::INFINITY,
            stop_cause: Some(cause),
        }
    }

    /// Whether a usable scan was processed this step.
    pub fn measured(&self) -> bool {
        !matches!(
            self.stop_cause,
            Some(StopCause::Rejected(_) | StopCause::NoScan | StopCause::BadNominal | StopCause::SensorBlind)
        )
    }
}
