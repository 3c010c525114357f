//! The per-scan pipeline: scan → points → clearances → barriers → DOAA →
//! DTCBF check → passive-safety check → command (ALGORITHM.md §1-5b).
//!
//! `SafetyPipeline` owns every buffer it needs and reuses them, so after the
//! first scan of a given size a step does not allocate. The simulator, the
//! CLI, the ROS node and the tests all call `step`.
//!
//! Order of a step:
//! 1. the scan is checked (rejected: stop), the robot's pose in the tracking
//!    frame found (odometry, else dead-reckoned), and the scan read into
//!    points under REP 117: unknown beams keep their last valid reading;
//! 2. a front sector mostly unknown for longer than the timeout: stop,
//!    `sensor_blind`;
//! 3. clearances, clusters and tracks, barriers, DOAA, the DTCBF filter;
//! 4. passive motion safety (§5b): if the DTCBF's command could not brake to
//!    rest without driving into a predicted occupancy, the closest command
//!    that meets both checks (or, when none does, the least bad one that
//!    drives into nothing); and when a mover closes on a robot that cannot
//!    go forward, the admissible command with the latest predicted contact.

use super::barrier::compute_barriers;
use super::beam_average::BeamAverage;
use super::beam_memory::BeamMemory;
use super::blind::BlindDetector;
use super::clearance::{Clearances, Sector, SideFade};
use super::clusters::{Cluster, Clusters};
use super::doaa::{Doaa, DoaaState};
use super::dtcbf::{DtcbfFilter, InputBox};
use super::geometry::Pose2;
use super::geometry::{Twist, Vec2};
use super::obstacle_tracker::ObstacleTracker;
use super::params::Params;
use super::passive::{ClosingContact, Mover, PassiveSafety};
use super::record::{Infeasibility, StepRecord, StopCause};
use super::scan::{LaserMount, LaserScan, ScanPoints, ScanRejection};
use super::seen_free::SeenFree;
use super::select::{CriticCosts, Selector, Tier};
use super::unstuck::{Guidance, Unstuck};
use super::way_round::{MapScan, RouteAsk, RouteUpdate, WayRound};

mod paper;
mod perceive;
mod predict;
mod selection;
use perceive::Perceived;

/// The goal is short of what is ahead when nearer by this (m).
const GOAL_SHORT_M: f64 = 0.05;
/// A mover on a collision course this near (beyond r, m) suspends going round obstacles.
const MOVER_NEAR_M: f64 = 2.0;
/// Half-angle of the rear sector a reversing robot must see (rad).
const REAR_HALF_ANGLE_RAD: f64 = std::f64::consts::FRAC_PI_4;

/// Geometry derived from the parameters once.
#[derive(Debug, Clone, Copy)]
struct Derived {
    robot_radius_m: f64,
    mount: LaserMount,
    hemisphere: Sector,
    front: Sector,
    fade: Option<SideFade>,
}

impl Derived {
    fn new(p: &Params) -> Self {
        Self {
            robot_radius_m: p.robot_radius_m(),
            mount: LaserMount::from_params(&p.laser),
            hemisphere: Sector::new(p.barrier.hemisphere_fov_deg.to_radians()),
            front: Sector::new(p.barrier.front_fov_deg.to_radians()),
            fade: SideFade::new(
                p.barrier.side_fade_deg.to_radians(),
                p.barrier.hemisphere_fov_deg.to_radians(),
                p.barrier.d_act_m(),
            ),
        }
    }
}

/// The whole safety filter, with its state (DOAA latch, tracks, beam memory)
/// and buffers.
#[derive(Debug, Clone)]
pub struct SafetyPipeline {
    params: Params,
    derived: Derived,
    /// The mount set by [`Self::set_laser_mount`], which new parameters keep.
    mount_given: Option<LaserMount>,
    points: ScanPoints,
    memory: BeamMemory,
    /// Static returns averaged per beam over the last few scans (§1, `laser.range_noise_m`).
    beam_average: BeamAverage,
    blind: BlindDetector,
    doaa: Doaa,
    unstuck: Unstuck,
    /// Where the nominal is heading this step ([`Self::set_guidance`]).
    guidance: Option<Guidance>,
    filter: DtcbfFilter,
    passive: PassiveSafety,
    selector: Selector,
    /// The command last sent, when (s; NaN before the first), and the
    /// change it made from the one sent before it.
    last_cmd: Twist,
    last_sent_s: f64,
    last_change: Twist,
    last_clearances: Clearances,
    last_box: InputBox,
    clusters: Clusters,
    /// Build clusters even with tracking off (a consumer such as the VO
    /// baseline reads them); with tracking on they are always built.
    keep_clusters: bool,
    tracker: ObstacleTracker,
    /// Recent scans' free space: proof that a track moves (§6).
    seen_free: SeenFree,
    /// Scratch: the tracks proven to move this scan.
    seen_through: Vec<usize>,
    /// Where the points will be after one step (moving clusters advanced),
    /// when [`Self::any_advanced`]; else they are the scan's points.
    points_next: Vec<Vec2>,
    /// Whether a cluster was advanced this step: only then is `points_next`
    /// filled (a copy of the points, then the movers moved).
    any_advanced: bool,
    /// Beams of the points that realised the last step's faded minima
    /// (overall, front, left, right; `u32::MAX` none): this step's seeds.
    minimiser_beams: [u32; 4],
    /// Robot pose in the tracking frame, whether it came from odometry, and its stamp (s).
    ego: Option<(Pose2, bool, f64)>,
    /// What the last scan gave: nothing yet, a reason to stop, or a perception.
    perceived: Perceived,
    /// Unknown fraction of the front sector of the last scan (blind watch).
    blind_fraction: f64,
    threats: Vec<Threat>,
    /// Scratch for a polygon's time to collision with a track (events, and
    /// the spans of the track's line within its radius of the polygon).
    cone_events: Vec<f64>,
    cone_entries: Vec<(f64, f64)>,
    /// The last steps' unexplained changes of h: measured h minus the h(k+1)
    /// predicted a step before for the command sent (m), a ring.
    surprise: [f64; SURPRISE_STEPS],
    surprise_next: usize,
    /// h(k+1) predicted for the last command sent (m; NaN: none).
    last_h_next: f64,
    /// The points the unstuck planner sees: the scan's, less those of moving
    /// tracks (a person is not a wall to plan round, §4b), and a per-point
    /// mark of the moving ones; scratch, reused every step.
    plan_points: Vec<Vec2>,
    /// The points of moving tracks slower than [`PLAN_THROUGH_SPEED_MPS`]:
    /// planned round where they are now, forgotten soon (§4c).
    slow_points: Vec<Vec2>,
    on_mover: Vec<u8>,
    /// The way-round planner, when it runs in step with the scans (§4c).
    way_round: WayRound,
    /// The planner runs beside the safety path (the node): the pipeline only
    /// hands out [`Self::take_map_scan`] and [`Self::route_ask`] and takes
    /// [`Self::offer_route`].
    route_beside: bool,
    /// A caller's clock (µs, any epoch) timing the way-round work done in
    /// step, and the time it has counted so far (µs).
    planner_clock: Option<fn() -> f64>,
    planner_us_total: f64,
    /// The last scan for the map, and whether it has not been taken yet.
    map_scan: MapScan,
    map_scan_new: bool,
    /// What the route is planned for now, and the latest route.
    route_ask: Option<RouteAsk>,
    route: Option<RouteUpdate>,
    /// This step's way-round decision (for the record).
    way: crate::algo::unstuck::UnstuckDecision,
}

/// Steps over which unexplained falls of h add up (1 s at 10 Hz).
const SURPRISE_STEPS: usize = 10;
/// Room for a polygon's time-to-collision events without reallocating: 4
/// per edge and 2 more (a footprint of up to 32 vertices; more only grows
/// the buffer once).
const CONE_EVENTS: usize = 4 * 32 + 2;

/// The unstuck planner leaves out the points of movers at least this fast
/// (m/s). A slower one moves less than 0.5 m, about a person's width, in
/// the 5 s it takes the robot to drive a metre round it: it is still in the
/// way, and is planned round like an obstacle (docs/DECISIONS.md).
const PLAN_THROUGH_SPEED_MPS: f64 = 0.1;

/// A tracked obstacle on a collision course this step (robot frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Threat {
    /// The track's id ([`Track::id`](super::obstacle_tracker::Track)).
    pub track_id: u32,
    /// Centre, robot frame (m).
    pub position: Vec2,
    /// Velocity, robot frame (m/s).
    pub velocity: Vec2,
    /// Radius of its circle (m).
    pub radius_m: f64,
    /// When it would touch the robot's disc on their present motions (s).
    pub time_to_collision_s: f64,
    /// Half-angle of its collision cone (rad).
    pub cone_half_angle_rad: f64,
}

impl SafetyPipeline {
    /// `params` must have passed `Params::validate`.
    pub fn new(params: Params) -> Self {
        let derived = Derived::new(&params);
        let cap = 1024;
        let selector = Selector::with_capacity(cap, &params);
        let max_tracks = params.obstacles.max_tracks;
        let last_box = InputBox::from_params(&params);
        let way_round = WayRound::new(&params);
        let filter = DtcbfFilter::with_capacity(cap).with_footprint(&params);
        let mut passive = PassiveSafety::with_capacity(max_tracks, cap);
        passive.set_footprint(params.footprint.polygon().and_then(Result::ok));
        Self {
            params,
            derived,
            mount_given: None,
            points: ScanPoints::with_capacity(cap),
            memory: BeamMemory::with_capacity(cap),
            beam_average: BeamAverage::with_capacity(cap),
            blind: BlindDetector::default(),
            doaa: Doaa::new(),
            unstuck: Unstuck::default(),
            guidance: None,
            filter,
            passive,
            selector,
            last_cmd: Twist::ZERO,
            last_sent_s: f64::NAN,
            last_change: Twist::ZERO,
            last_clearances: Clearances::OPEN,
            last_box,
            clusters: Clusters::with_capacity(cap),
            keep_clusters: false,
            tracker: ObstacleTracker::with_capacity(max_tracks, cap),
            seen_free: SeenFree::with_capacity(cap),
            seen_through: Vec::with_capacity(max_tracks),
            points_next: Vec::with_capacity(cap),
            any_advanced: false,
            minimiser_beams: [u32::MAX; 4],
            ego: None,
            perceived: Perceived::Nothing,
            blind_fraction: f64::NAN,
            threats: Vec::with_capacity(max_tracks),
            cone_events: Vec::with_capacity(CONE_EVENTS),
            cone_entries: Vec::with_capacity(CONE_EVENTS),
            surprise: [0.0; SURPRISE_STEPS],
            surprise_next: 0,
            last_h_next: f64::NAN,
            plan_points: Vec::with_capacity(cap),
            slow_points: Vec::with_capacity(cap),
            on_mover: Vec::with_capacity(cap),
            way_round,
            route_beside: false,
            planner_clock: None,
            planner_us_total: 0.0,
            map_scan: MapScan {
                points: Vec::with_capacity(cap),
                transient: Vec::with_capacity(cap),
                open_ends: Vec::with_capacity(cap),
                ..MapScan::default()
            },
            map_scan_new: false,
            route_ask: None,
            route: None,
            way: Default::default(),
        }
    }

    /// The obstacle tracker (tracks in its tracking frame; see `in_robot_frame`).
    pub fn tracker(&self) -> &ObstacleTracker {
        &self.tracker
    }

    /// The clusters of the last accepted scan (indices into `points`).
    /// With tracking off they are built only after [`Self::keep_clusters`];
    /// empty otherwise.
    pub fn clusters(&self) -> &[Cluster] {
        self.clusters.as_slice()
    }

    /// Builds clusters at every step even with tracking off, for a consumer
    /// of [`Self::clusters`] (the filter needs them only to track).
    pub fn keep_clusters(&mut self, keep: bool) {
        self.keep_clusters = keep;
    }

    /// Where the points will be after one step, as the filter predicted
    /// them (moving clusters on a collision course advanced by v_o Δt).
    pub fn points_next(&self) -> &[Vec2] {
        next_points(self.any_advanced, &self.points_next, &self.points.points)
    }

    /// Tracked obstacles on a collision course at the last step.
    pub fn threats(&self) -> &[Threat] {
        &self.threats
    }

    /// Moving tracks at the last step, robot frame (what §5b predicts).
    pub fn movers(&self) -> &[Mover] {
        self.passive.movers()
    }

    /// The parameters in use.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// Points of the last accepted scan, robot frame (m): valid readings,
    /// −inf at range_min, and held readings of unknown beams.
    pub fn points(&self) -> &[Vec2] {
        &self.points.points
    }

    /// The last accepted scan's points with each beam's status.
    pub fn scan_points(&self) -> &ScanPoints {
        &self.points
    }

    /// Clearances of the last accepted scan.
    pub fn clearances(&self) -> &Clearances {
        &self.last_clearances
    }

    /// The command of the last step (zero before the first).
    pub fn last_command(&self) -> Twist {
        self.last_cmd
    }

    /// The input box of the last accepted scan (no reverse unless its rear was seen).
    pub fn input_box(&self) -> InputBox {
        self.last_box
    }

    /// Forget latched DOAA state, the way round and the side kept (after an
    /// e-stop release or a filter toggle). The command last sent stays: it
    /// is what the base is doing ([`Self::command_sent`]).
    pub fn reset(&mut self) {
        self.doaa.reset();
        self.unstuck.reset();
        self.selector.reset();
        self.last_change = Twist::ZERO;
        self.forget_surprise();
    }

    /// Drops the last scan's perception (the clock jumped: it cannot be
    /// aged): ticks stop for want of a scan until the next one.
    pub fn forget_perception(&mut self) {
        self.perceived = Perceived::Nothing;
    }

    /// Whether the last scan given to [`Self::perceive`] was rejected (it may
    /// be accepted later: one stamped ahead of the clock).
    pub fn scan_rejected(&self) -> bool {
        matches!(self.perceived, Perceived::Unusable(StopCause::Rejected(_)))
    }

    /// The way round's waypoint while one is followed (§4b), in the
    /// tracking frame (odometry's when there is odometry, m): where the
    /// reference follower aims its tracking law, the reference being behind
    /// what blocks the way.
    pub fn aim_point(&self) -> Option<Vec2> {
        self.unstuck.aim()
    }

    /// Runs the way-round planner beside the safety path (the node, §4c):
    /// the caller takes each scan for the map ([`Self::take_map_scan`]) and
    /// what to plan for ([`Self::route_ask`]), plans at its own rate, and
    /// hands back the route ([`Self::offer_route`]). Off (the default): the
    /// pipeline plans in step with the scans, reproducibly.
    pub fn plan_beside(&mut self, beside: bool) {
        self.route_beside = beside;
    }

    /// Times the way-round work done in step (the map taking a scan, a
    /// plan) with `clock` (µs, any epoch), so a caller can time the safety
    /// path alone: the node's, where that work runs in its own thread. The
    /// pipeline never reads a clock of its own; nothing it decides depends
    /// on this.
    pub fn time_planner(&mut self, clock: fn() -> f64) {
        self.planner_clock = Some(clock);
    }

    /// The way-round work done in step so far, by the clock of
    /// [`Self::time_planner`] (µs; 0 without one).
    pub fn planner_us_total(&self) -> f64 {
        self.planner_us_total
    }

    /// The last scan for the map (the scan less walking people, robot
    /// frame at its pose), once; None when taken already or planning in step.
    pub fn take_map_scan(&mut self) -> Option<&MapScan> {
        let new = std::mem::take(&mut self.map_scan_new) && self.route_beside;
        new.then_some(&self.map_scan)
    }

    /// What the route is planned for at the last step (None: no reference).
    pub fn route_ask(&self) -> Option<RouteAsk> {
        self.route_ask
    }

    /// The planner's latest route (planning beside the safety path).
    pub fn offer_route(&mut self, update: RouteUpdate) {
        self.route = Some(update);
    }

    /// The latest route and why it last changed.
    pub fn route(&self) -> Option<&RouteUpdate> {
        self.route.as_ref()
    }

    /// The local map, when the planner runs in step.
    pub fn local_map(&self) -> Option<&crate::algo::local_map::LocalMap> {
        (!self.route_beside).then(|| self.way_round.map())
    }

    /// Where the nominal command is heading, for the next step only: the
    /// governed reference point (robot frame) and its arc length. Without it
    /// (an upstream `cmd_vel_in`, a constant command) there is no progress to
    /// watch and no unstuck behaviour (§4b).
    pub fn set_guidance(&mut self, guidance: Option<Guidance>) {
        self.guidance = guidance;
    }

    /// New parameters while running (dynamic_reconfigure), keeping tracks,
    /// the DOAA latch and buffers. `params` must have passed
    /// `Params::validate`; buffers keep the capacity they were built with.
    pub fn set_params(&mut self, params: Params) {
        self.derived = Derived::new(&params);
        self.filter
            .set_footprint(params.footprint.polygon().and_then(Result::ok));
        // A mount given by [`Self::set_laser_mount`] (tf) outlives new parameters.
        if let Some(mount) = self.mount_given {
            self.derived.mount = mount;
        }
        self.params = params;
    }

    /// The laser's mount for the scans from now on (the node: from tf, per
    /// scan); [`LaserMount::from_params`] until set. Beam memory is per beam
    /// index: a mount that moves only shifts where those beams point.
    pub fn set_laser_mount(&mut self, mount: LaserMount) {
        self.derived.mount = mount;
        self.mount_given = Some(mount);
    }

    /// The laser's mount the scans are placed with.
    pub fn laser_mount(&self) -> LaserMount {
        self.derived.mount
    }

    /// A stop step with no scan processing (missing scan, e-stop…).
    pub fn stop(&mut self, now_s: f64, nominal: Twist, cause: StopCause) -> StepRecord {
        self.doaa.reset();
        self.command_sent(Twist::ZERO, now_s);
        self.last_h_next = f64::NAN;
        StepRecord::stop(now_s, nominal, cause)
    }

    /// One control step.
    ///
    /// `nominal` is the command to make safe (tracking law or upstream);
    /// `current_v_mps` the measured linear speed for B_v (NaN: the last
    /// command is used instead).
    pub fn step(&mut self, scan: &LaserScan<'_>, now_s: f64, nominal: Twist, current_v_mps: f64) -> StepRecord {
        self.step_with_pose(scan, now_s, nominal, current_v_mps, None)
    }

    /// The first closing contact `cmd` would make braking to rest from the
    /// last step's points and movers (§5b); `None`: passively safe.
    pub fn braking_check(&mut self, cmd: Twist) -> Option<ClosingContact> {
        self.passive.closing_contact(cmd, &self.params)
    }

    /// As `step`, with the robot's odometry pose when there is one (tracks
    /// are then kept in the odometry frame): [`Self::perceive`], then
    /// [`Self::decide`].
    pub fn step_with_pose(
        &mut self,
        scan: &LaserScan<'_>,
        now_s: f64,
        nominal: Twist,
        current_v_mps: f64,
        odom_pose: Option<Pose2>,
    ) -> StepRecord {
        self.perceive(scan, now_s, odom_pose);
        self.decide(now_s, nominal, current_v_mps, odom_pose)
    }

    /// One command at `now_s` from the last scan's perception, predicted to
    /// `now_s` (§5c): at a scan's own tick, and at every tick between scans
    /// (an upstream command, an e-stop, the watchdog). `odom_pose` is the
    /// robot's odometry pose now, when there is odometry. The command is
    /// taken as sent; a caller that sends something else says so with
    /// [`Self::command_sent`].
    pub fn decide(&mut self, now_s: f64, nominal: Twist, current_v_mps: f64, odom_pose: Option<Pose2>) -> StepRecord {
        if let Some(stop) = self.unusable(now_s, nominal) {
            return stop;
        }
        let Some(frame) = self.advance_to(now_s, odom_pose) else {
            return self.stop(now_s, nominal, StopCause::NoScan);
        };
        let v_now = if current_v_mps.is_finite() {
            current_v_mps
        } else {
            self.last_cmd.v_mps
        };
        let c = self.measure(&frame, v_now);
        let bx = InputBox::for_scan(&self.params, frame.rear_seen);
        self.last_box = bx;
        let b = compute_barriers(c.d_left_m, c.d_right_m, v_now, &self.params.barrier);
        let nominal_boxed = bx.clamp(nominal);
        // Measured against the last scan's prediction: only a new scan measures anything.
        let closing_in = if frame.fresh {
            self.closing_in_unexplained(c.d_min_m - self.params.barrier.d_safe_m)
        } else {
            self.closing_in_now()
        };
        let d = if self.params.select.enabled {
            self.decide_select(now_s, nominal_boxed, (&c, &b), &bx, &frame, closing_in)
        } else {
            self.decide_paper(nominal_boxed, &c, &b, &bx)
        };
        // Last line of defence: nothing non-finite leaves this function.
        let cmd = if d.cmd.is_finite() {
            bx.clamp(d.cmd)
        } else {
            Twist::ZERO
        };
        let braking_held = self.braking_check(cmd).is_none();
        self.command_sent(cmd, now_s);
        if frame.fresh {
            // The next scan's h is measured against this (one scan period on).
            self.last_h_next = d.h_next_m;
        }
        let way = std::mem::take(&mut self.way);
        let p = &self.params;
        StepRecord {
            stamp_s: now_s,
            cmd,
            nominal,
            doaa_cmd: d.doaa_cmd,
            state: d.state,
            h_m: d.h_m,
            h_next_m: d.h_next_m,
            filter_changed: d.changed,
            condition_held: d.condition_held,
            braking_held,
            passive_changed: d.passive_changed,
            infeasibility: d.infeasibility,
            tier: d.tier,
            costs: d.costs,
            added_motion: d.added_motion,
            evading: d.evading,
            route_event: way.event,
            no_route: way.no_route,
            b_left: b.b_left,
            b_right: b.b_right,
            b_velocity: b.b_velocity,
            d_left_m: c.d_left_m,
            d_right_m: c.d_right_m,
            d_min_m: c.d_min_m,
            d_front_m: c.d_front_m,
            closest_left: c.closest_left,
            closest_right: c.closest_right,
            beams: self.points.beams,
            valid_beams: self.points.valid_count(),
            unknown_beams: self.points.unknown,
            held_beams: self.points.held,
            unknown_front_fraction: frame.unknown_front_fraction,
            tracked_obstacles: self
                .tracker
                .tracks()
                .iter()
                .filter(|t| t.is_moving(&p.obstacles))
                .count(),
            threats: self.threats.len(),
            min_time_to_collision_s: self
                .threats
                .iter()
                .map(|t| t.time_to_collision_s)
                .fold(f64::INFINITY, f64::min),
            stop_cause: d.infeasibility.map(|_| StopCause::Infeasible),
        }
    }

    /// The stop record when this tick has no usable perception: a bad
    /// nominal, no scan, a rejected or stale one, a blind sensor.
    fn unusable(&mut self, now_s: f64, nominal: Twist) -> Option<StepRecord> {
        if !nominal.is_finite() {
            return Some(self.stop(now_s, nominal, StopCause::BadNominal));
        }
        match self.perceived {
            Perceived::Nothing => Some(self.stop(now_s, nominal, StopCause::NoScan)),
            Perceived::Unusable(StopCause::SensorBlind) => {
                let mut rec = self.stop(now_s, nominal, StopCause::SensorBlind);
                rec.beams = self.points.beams;
                rec.valid_beams = self.points.valid_count();
                rec.unknown_beams = self.points.unknown;
                rec.held_beams = self.points.held;
                rec.unknown_front_fraction = self.blind_fraction;
                Some(rec)
            }
            Perceived::Unusable(cause) => Some(self.stop(now_s, nominal, cause)),
            Perceived::Usable(f) => {
                let age_s = now_s - f.stamp_s;
                let timeout_s = self.params.laser.scan_timeout_s;
                (age_s > timeout_s).then(|| {
                    let stale = ScanRejection::Stale { age_s, timeout_s };
                    self.stop(now_s, nominal, StopCause::Rejected(stale))
                })
            }
        }
    }

    /// The command actually sent at `at_s` (s), when it is not the one the
    /// last [`Self::decide`] returned: an e-stop, a disabled filter, a
    /// downstream clamp (§5c). The window, the dead reckoning and the speed
    /// barrier B_v start from it.
    pub fn command_sent(&mut self, cmd: Twist, at_s: f64) {
        let cmd = if cmd.is_finite() { cmd } else { Twist::ZERO };
        self.last_change = Twist::new(
            cmd.v_mps - self.last_cmd.v_mps,
            cmd.omega_radps - self.last_cmd.omega_radps,
        );
        self.last_cmd = cmd;
        self.last_sent_s = at_s;
    }
}

/// What one of the two decisions (the selector, or the paper's) made of a tick.
#[derive(Debug, Clone, Copy)]
struct Decision {
    cmd: Twist,
    doaa_cmd: Twist,
    h_m: f64,
    h_next_m: f64,
    changed: bool,
    condition_held: bool,
    passive_changed: bool,
    infeasibility: Option<Infeasibility>,
    state: DoaaState,
    tier: Option<Tier>,
    costs: CriticCosts,
    added_motion: bool,
    evading: bool,
}

/// Where the points will be after one step: the advanced copy when a cluster
/// was advanced this step, else the points themselves (the same slice, which
/// the filter recognises and does not search twice).
fn next_points<'a>(any_advanced: bool, points_next: &'a [Vec2], points: &'a [Vec2]) -> &'a [Vec2] {
    if any_advanced {
        points_next
    } else {
        points
    }
}

/// Runs `work` (way-round work done in step), adding its time by `clock`
/// (µs) to `total_us` when there is a clock.
fn timed<R>(clock: Option<fn() -> f64>, total_us: &mut f64, work: impl FnOnce() -> R) -> R {
    let t0 = clock.map(|c| c());
    let r = work();
    if let (Some(c), Some(t0)) = (clock, t0) {
        *total_us += (c() - t0).max(0.0);
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algo::scan::ScanHeader;
    use crate::algo::select::Tier;
    use std::f32::consts::PI;

    #[test]
    fn h_falling_beyond_its_predictions_for_a_second_is_closing_in() {
        // δ = 0.03 m. Each step h comes out 0.004 m below the 1.0 m predicted for it:
        // after the first step (nothing predicted yet) the unexplained fall adds up to
        // 0.004 (k − 1) m, beyond δ from the 9th step on.
        let mut pipe = SafetyPipeline::new(Params::default());
        let mut flags = Vec::new();
        for _ in 0..10 {
            flags.push(pipe.closing_in_unexplained(0.996));
            pipe.last_h_next = 1.0;
        }
        let mut expected = vec![false; 8];
        expected.extend([true, true]);
        assert_eq!(flags, expected);
        // Predictions that come true: the falls leave the 10-step ring, one per step.
        let recovered: Vec<bool> = (0..10).map(|_| pipe.closing_in_unexplained(1.0)).collect();
        assert_eq!(recovered.iter().position(|&f| !f), Some(2), "{recovered:?}");
        // A stop forgets the prediction: its step adds nothing.
        pipe.stop(0.0, Twist::ZERO, StopCause::BadNominal);
        assert!(!pipe.closing_in_unexplained(-5.0));
    }

    /// 360 beams over a full turn starting at −π, all at `far` m, with
    /// `(beam, range)` overrides.
    fn ring(far: f32, overrides: &[(usize, f32)]) -> Vec<f32> {
        let mut r = vec![far; 360];
        for &(i, v) in overrides {
            r[i] = v;
        }
        r
    }

    fn scan(ranges: &[f32]) -> LaserScan<'_> {
        scan_at(ranges, 1.0)
    }

    fn scan_at(ranges: &[f32], stamp_s: f64) -> LaserScan<'_> {
        LaserScan {
            header: ScanHeader {
                stamp_s,
                angle_min_rad: -PI,
                angle_increment_rad: 2.0 * PI / 360.0,
                range_min_m: 0.12,
                range_max_m: 3.5,
            },
            ranges_m: ranges,
            intensities: &[],
        }
    }

    /// Lowers `ranges` (360 beams from −π) to where each beam meets the disc
    /// of `radius` m centred at `centre` (m, robot frame).
    fn add_disc(ranges: &mut [f32], centre: Vec2, radius: f64) {
        for (i, r) in ranges.iter_mut().enumerate() {
            let a = -std::f64::consts::PI + i as f64 * 2.0 * std::f64::consts::PI / 360.0;
            let along = centre.x * a.cos() + centre.y * a.sin();
            let off2 = centre.norm_squared() - along * along;
            if along > 0.0 && off2 <= radius * radius {
                *r = r.min((along - (radius * radius - off2).sqrt()) as f32);
            }
        }
    }

    #[test]
    fn a_person_walking_up_is_seen_where_the_scan_sees_them_not_averaged() {
        // The robot rests at the origin; a person (radius 0.15 m) walks straight at it
        // from 2.5 m at 0.2 m/s: 2 cm a scan, inside the averaging's 3σ gate (σ = 1 cm).
        // Averaged like a wall, their nearest return would lag by 2σ = 2 cm; on a moving
        // track it is the raw return. A post 1.5 m to the left, noise-free, stays put.
        let mut pipe = SafetyPipeline::new(Params::default());
        assert_eq!(pipe.params.laser.range_noise_m, 0.01);
        let post = Vec2::new(0.0, 1.5);
        let mut person = Vec2::zeros();
        for k in 0..40 {
            let t = 1.0 + 0.1 * k as f64;
            person = Vec2::new(2.5 - 0.02 * k as f64, 0.0);
            let mut ranges = vec![f32::INFINITY; 360];
            add_disc(&mut ranges, person, 0.15);
            add_disc(&mut ranges, post, 0.1);
            pipe.step_with_pose(&scan_at(&ranges, t), t, Twist::ZERO, 0.0, Some(Pose2::default()));
        }
        assert_eq!(pipe.movers().len(), 1, "{:?}", pipe.movers());
        let nearest = |c: Vec2, r: f64| {
            pipe.points
                .points
                .iter()
                .filter(|q| (**q - c).norm() < r + 0.1)
                .map(|q| q.norm())
                .fold(f64::INFINITY, f64::min)
        };
        let raw = person.x - 0.15;
        assert!(
            (nearest(person, 0.15) - raw).abs() < 1e-3,
            "{} against {raw}",
            nearest(person, 0.15)
        );
        assert!((nearest(post, 0.1) - 1.4).abs() < 1e-3, "{}", nearest(post, 0.1));
    }

    #[test]
    fn the_way_round_is_planned_without_the_points_of_walking_people() {
        // A person (radius 0.15 m) walks across 1.2 m ahead at 0.3 m/s, a second one
        // shuffles across 1.0 m behind at 0.05 m/s, below PLAN_THROUGH_SPEED_MPS, and a
        // post (radius 0.1 m) stands 1.5 m to the left. The robot stands at the origin.
        let mut pipe = SafetyPipeline::new(Params::default());
        let post = Vec2::new(0.0, 1.5);
        let (mut walker, mut shuffler) = (Vec2::zeros(), Vec2::zeros());
        for k in 0..80 {
            let t = 1.0 + 0.1 * k as f64;
            walker = Vec2::new(1.2, -1.5 + 0.03 * k as f64);
            shuffler = Vec2::new(-1.0, -0.2 + 0.005 * k as f64);
            let mut ranges = vec![f32::INFINITY; 360];
            add_disc(&mut ranges, walker, 0.15);
            add_disc(&mut ranges, shuffler, 0.15);
            add_disc(&mut ranges, post, 0.1);
            let mut s = scan(&ranges);
            s.header.stamp_s = t;
            pipe.step_with_pose(&s, t, Twist::ZERO, 0.0, Some(Pose2::default()));
        }
        // Both people are movers for evasion and the braking check.
        assert_eq!(pipe.movers().len(), 2, "{:?}", pipe.movers());
        pipe.fill_plan_points();
        let near = |c: Vec2| move |q: &&Vec2| (**q - c).norm() < 0.25;
        let seen = |c: Vec2| pipe.points.points.iter().filter(near(c)).count();
        let planned = |c: Vec2| pipe.plan_points.iter().filter(near(c)).count();
        let (w, sh, po) = (seen(walker), seen(shuffler), seen(post));
        assert!(w >= 3 && sh >= 3 && po >= 3, "{w} {sh} {po}");
        // The map takes the post for good and the shuffler for a moment (transient), the
        // walker not at all; nothing else is dropped.
        let slow = |c: Vec2| pipe.slow_points.iter().filter(near(c)).count();
        assert_eq!((planned(walker), slow(walker)), (0, 0));
        assert_eq!((planned(shuffler), slow(shuffler)), (0, sh));
        assert_eq!((planned(post), slow(post)), (po, 0));
        assert_eq!(pipe.plan_points.len(), pipe.points.points.len() - w - sh);
    }

    #[test]
    fn obstacle_close_on_the_left_turns_the_paper_right_and_leaves_a_safe_command_alone() {
        // Beam 180 + 45 = 45° left, 0.6 m away: well outside d_safe, inside d_act.
        let ranges = ring(f32::INFINITY, &[(225, 0.6)]);
        let nominal = Twist::new(0.15, 0.0);
        // The paper's decision: the DOAA's law turns away from the nearer side.
        let mut paper = SafetyPipeline::new(Params::default().paper_method());
        let rec = paper.step(&scan(&ranges), 1.0, nominal, 0.15);
        assert!(rec.cmd.omega_radps < 0.0, "{rec:?}");
        assert_eq!((rec.state, rec.tier), (DoaaState::Avoid, None));
        assert!(rec.b_left > rec.b_right && rec.condition_held);
        // The selector, with the post 0.9 m away at 45° (0.636 m to the side): driving on
        // for the horizon (0.225 m) ends 0.757 m from it, 0.379 m of room beyond
        // r + d_safe = 0.378 m, more than the 0.3 m band: nothing given up. The command
        // is safe as it is and the base is already at it: sent unchanged (§5c), at the
        // strictest level.
        let ranges = ring(f32::INFINITY, &[(225, 0.9)]);
        let mut pipe = SafetyPipeline::new(Params::default());
        pipe.command_sent(nominal, 0.9);
        let rec = pipe.step(&scan(&ranges), 1.0, nominal, 0.15);
        assert_eq!(rec.cmd, nominal, "{rec:?}");
        assert_eq!(rec.tier, Some(Tier::Margin));
        assert!(rec.condition_held && rec.braking_held && !rec.filter_changed);
    }

    #[test]
    fn a_safe_command_heading_into_the_band_is_steered_away_early() {
        // The post 0.6 m away at 45° left: 0.222 m of room now, inside the 0.3 m band
        // (shortfall (0.078/0.3)² = 0.068). Driving straight on at 0.15 m/s for 1.5 s ends
        // 0.468 m from it, 0.09 m of room (shortfall (0.21/0.3)² = 0.49): 0.42 of the band
        // given up, above the heading-in threshold 0.25. The command is safe, but the
        // selector steers it away (right) and keeps driving, at the strictest level.
        let ranges = ring(f32::INFINITY, &[(225, 0.6)]);
        let nominal = Twist::new(0.15, 0.0);
        let mut pipe = SafetyPipeline::new(Params::default());
        pipe.command_sent(nominal, 0.9);
        let rec = pipe.step(&scan(&ranges), 1.0, nominal, 0.15);
        assert!(rec.cmd.omega_radps < 0.0 && rec.cmd.v_mps > 0.0, "{rec:?}");
        assert_eq!(rec.tier, Some(Tier::Margin));
        assert!(rec.condition_held && rec.braking_held && rec.filter_changed);
        assert!(!rec.added_motion, "{rec:?}");
    }

    #[test]
    fn a_robot_at_rest_beside_an_obstacle_sets_off_turning_away() {
        // Something 0.6 m away 35°..55° to the left, the robot at rest, the upstream
        // command 0.15 m/s straight on (heading in: it passes 0.344 m from the nearest
        // point, inside r + d_safe + band). From rest the window holds 0.05 m/s and
        // 0.1 rad/s a step: the DOAA's turn (−0.3 rad/s, away to the right) is out of
        // reach for three steps, which must not make standing still the cheapest
        // command. It sets off at once, turning right, and reaches the law's turn.
        let over: Vec<_> = (215..=235).map(|i| (i, 0.6)).collect();
        let ranges = ring(f32::INFINITY, &over);
        let nominal = Twist::new(0.15, 0.0);
        let mut pipe = SafetyPipeline::new(Params::default());
        pipe.command_sent(Twist::ZERO, 0.9);
        let mut cmds = Vec::new();
        for k in 0..8 {
            let t = 1.0 + 0.1 * f64::from(k);
            let rec = pipe.step(&scan_at(&ranges, t), t, nominal, 0.0);
            assert_eq!(rec.tier, Some(Tier::Margin), "{rec:?}");
            cmds.push(rec.cmd);
        }
        assert!(cmds[0].v_mps > 0.0 && cmds[0].omega_radps < 0.0, "{cmds:?}");
        assert!(cmds.iter().all(|c| c.v_mps > 0.0 && c.v_mps <= 0.15), "{cmds:?}");
        assert!((cmds[7].omega_radps + 0.3).abs() < 1e-9, "{cmds:?}");
    }

    #[test]
    fn a_person_walking_at_a_robot_at_rest_is_evaded_at_the_bases_own_limits() {
        // A person (radius 0.15 m) walks straight at the robot from 2.5 m ahead at
        // 0.3 m/s; the upstream asks the robot to stand (0, 0). Once the track is a
        // mover, standing is reached within the 5 s trigger: threatened. Evasion may
        // then change v by 2.5 × 0.1 = 0.25 m/s and ω by 3.2 × 0.1 = 0.32 rad/s a step
        // (the base's own limits), not 0.05 m/s and 0.1 rad/s (ordinary driving), and
        // its first command uses more than the ordinary window allows.
        let mut pipe = SafetyPipeline::new(Params::default());
        pipe.command_sent(Twist::ZERO, 0.9);
        let mut last = Twist::ZERO;
        let mut first_evading = None;
        for k in 0..40 {
            let t = 1.0 + 0.1 * f64::from(k);
            let mut ranges = vec![f32::INFINITY; 360];
            add_disc(&mut ranges, Vec2::new(2.5 - 0.03 * f64::from(k), 0.0), 0.15);
            let rec = pipe.step_with_pose(&scan_at(&ranges, t), t, Twist::ZERO, last.v_mps, Some(Pose2::default()));
            let (dv, dw) = (rec.cmd.v_mps - last.v_mps, rec.cmd.omega_radps - last.omega_radps);
            if rec.evading {
                assert!(dv.abs() <= 0.25 + 1e-9 && dw.abs() <= 0.32 + 1e-9, "{rec:?}");
                first_evading.get_or_insert((k, dv, dw));
            } else {
                assert!(dv.abs() <= 0.1 + 1e-9 && dw.abs() <= 0.1 + 1e-9, "{rec:?}");
            }
            last = rec.cmd;
        }
        let (k, dv, dw) = first_evading.expect("threatened");
        assert!(dv.abs() > 0.05 + 1e-9 || dw.abs() > 0.1 + 1e-9, "step {k}: {dv} {dw}");
    }

    #[test]
    fn obstacle_dead_ahead_inside_d_safe_stops_forward_motion() {
        // Wall segment ahead at 0.3 m (beams −10°..10°): centre distance 0.3 < r + d_safe = 0.378.
        let over: Vec<_> = (170..=190).map(|i| (i, 0.3)).collect();
        let ranges = ring(f32::INFINITY, &over);
        let mut pipe = SafetyPipeline::new(Params::default());
        let rec = pipe.step(&scan(&ranges), 1.0, Twist::new(0.15, 0.0), 0.15);
        assert!(rec.cmd.v_mps <= 0.0, "{rec:?}");
        assert!(rec.h_m < 0.0);
    }

    #[test]
    fn rejected_scan_stops_with_reason() {
        let ranges = ring(1.0, &[]);
        let mut pipe = SafetyPipeline::new(Params::default());
        let mut s = scan(&ranges);
        s.header.stamp_s = 0.0; // 1 s old, timeout 0.5 s
        let rec = pipe.step(&s, 1.0, Twist::new(0.15, 0.0), 0.0);
        assert_eq!(rec.cmd, Twist::ZERO);
        assert_eq!(rec.state, DoaaState::Stop);
        assert!(matches!(
            rec.stop_cause,
            Some(StopCause::Rejected(crate::algo::scan::ScanRejection::Stale { .. }))
        ));
    }

    #[test]
    fn non_finite_nominal_stops() {
        let ranges = ring(1.0, &[]);
        let mut pipe = SafetyPipeline::new(Params::default());
        let rec = pipe.step(&scan(&ranges), 1.0, Twist::new(f64::NAN, 0.0), 0.0);
        assert_eq!((rec.cmd, rec.stop_cause), (Twist::ZERO, Some(StopCause::BadNominal)));
    }

    #[test]
    fn empty_world_passes_nominal_once_the_base_can_follow_it() {
        let ranges = ring(f32::INFINITY, &[]);
        let nominal = Twist::new(0.15, 0.05);
        // From rest, the window holds 0.5 m/s² × 0.1 s = 0.05 m/s and 0.1 rad/s: the
        // command goes to the window's command nearest the nominal, (0.05, 0.05)...
        let mut pipe = SafetyPipeline::new(Params::default());
        let mut rec = pipe.step(&scan(&ranges), 1.0, nominal, 0.0);
        assert!(
            (rec.cmd.v_mps - 0.05).abs() < 1e-9 && (rec.cmd.omega_radps - 0.05).abs() < 1e-9,
            "{rec:?}"
        );
        for k in 1..3 {
            let mut s = scan(&ranges);
            s.header.stamp_s = 1.0 + 0.1 * k as f64;
            rec = pipe.step(&s, s.header.stamp_s, nominal, rec.cmd.v_mps);
        }
        // ...and in the third step it is the nominal, unchanged.
        assert_eq!(rec.cmd, nominal, "{rec:?}");
        assert_eq!(rec.state, DoaaState::Forward);
        assert_eq!(rec.valid_beams, 0);
        assert!(rec.h_m.is_infinite() && rec.condition_held && !rec.filter_changed);
    }
}
