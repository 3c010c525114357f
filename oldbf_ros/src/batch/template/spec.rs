//! What a batch template file says: the YAML types, with their defaults.
//! Units: m, s, m/s; box yaw in degrees.

use super::*;

/// A room side (m): one number, the same in every world, or `[least, most]`,
/// drawn uniformly per world.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum Extent {
    Fixed(f64),
    Range([f64; 2]),
}

impl Extent {
    /// The least and the most this side can be (m).
    pub fn bounds(self) -> [f64; 2] {
        match self {
            Extent::Fixed(x) => [x, x],
            Extent::Range(r) => r,
        }
    }
    pub fn least(self) -> f64 {
        self.bounds()[0]
    }
    pub fn most(self) -> f64 {
        self.bounds()[1]
    }
}

/// The rectangular room [0, width] × [0, height] (m); its outline is a wall.
/// A side given as `[least, most]` is drawn per world (width first).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoomSpec {
    pub width_m: Extent,
    pub height_m: Extent,
}

impl RoomSpec {
    /// The shortest side any world can have (m).
    pub fn least_side_m(&self) -> f64 {
        self.width_m.least().min(self.height_m.least())
    }
    /// The longest diagonal any world can have (m).
    pub fn most_diagonal_m(&self) -> f64 {
        self.width_m.most().hypot(self.height_m.most())
    }
}

pub(super) fn default_wall_margin() -> f64 {
    0.8
}

/// The nominal command: a straight line, tracked at `v_mps`, from a start
/// `wall_margin_m` from one wall (drawn at random among the four) to a goal
/// `wall_margin_m` from the opposite wall; both at random positions along
/// their walls.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LineNominalSpec {
    /// The robot's nominal speed v_nom (m/s); movers' speeds are fractions of it.
    pub v_mps: f64,
    /// Distance of the start and the goal from their walls (m).
    #[serde(default = "default_wall_margin")]
    pub wall_margin_m: f64,
}

/// How many static discs, and how large.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CirclesSpec {
    /// [least, most] discs per world (inclusive).
    pub count: [usize; 2],
    /// [least, most] radius (m), uniform.
    pub radius_m: [f64; 2],
}

impl Default for CirclesSpec {
    fn default() -> Self {
        Self {
            count: [0, 0],
            radius_m: [0.1, 0.3],
        }
    }
}

/// How many static boxes, and how large; yaw uniform in [0°, 180°).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxesSpec {
    /// [least, most] boxes per world (inclusive).
    pub count: [usize; 2],
    /// [least, most] side length (m), uniform, drawn for each side.
    pub size_m: [f64; 2],
}

impl Default for BoxesSpec {
    fn default() -> Self {
        Self {
            count: [0, 0],
            size_m: [0.3, 0.8],
        }
    }
}

/// Benches (and other long boxes): length and width drawn separately, yaw
/// uniform in [0°, 180°).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BenchesSpec {
    /// [least, most] benches per world (inclusive).
    pub count: [usize; 2],
    /// [least, most] length (m), uniform.
    pub length_m: [f64; 2],
    /// [least, most] width (m), uniform.
    pub width_m: [f64; 2],
}

pub(super) fn default_near_line_m() -> f64 {
    0.35
}

/// Static obstacles, placed uniformly in the room away from start and goal;
/// `near_line_fraction` of them (rounded to the nearest count, chosen at
/// random) with their centre within ±`near_line_m` of the start→goal line
/// (one that does not fit there clear of the start and the goal, as on a
/// short line, is placed anywhere instead).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StaticObstaclesSpec {
    #[serde(default)]
    pub circles: CirclesSpec,
    #[serde(default)]
    pub boxes: BoxesSpec,
    /// Absent: none (and nothing drawn for them).
    #[serde(default)]
    pub benches: Option<BenchesSpec>,
    /// Fraction in [0, 1] of all static obstacles placed near the line.
    #[serde(default)]
    pub near_line_fraction: f64,
    /// Half-width of the band around the line their centres lie in (m).
    #[serde(default = "default_near_line_m")]
    pub near_line_m: f64,
    /// Redraw the static obstacles until a path from the start to the goal
    /// keeps the robot's centre r + d_safe from every static obstacle and
    /// wall (`path_exists` of each world says whether one does).
    #[serde(default)]
    pub require_path: bool,
}

impl Default for StaticObstaclesSpec {
    fn default() -> Self {
        Self {
            circles: CirclesSpec::default(),
            boxes: BoxesSpec::default(),
            benches: None,
            near_line_fraction: 0.0,
            near_line_m: default_near_line_m(),
            require_path: false,
        }
    }
}

/// A wall across the room, perpendicular to the robot's line, with one
/// doorway in it: a doorway narrower than 2 (r + d_safe) has no path through
/// it at d_safe, and the robot must refuse it safely.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DoorwaySpec {
    /// [least, most] width of the doorway (m).
    pub width_m: [f64; 2],
    /// [least, most] where the wall crosses the line, as a fraction of its length.
    #[serde(default = "default_doorway_along")]
    pub along: [f64; 2],
    /// [least, most] offset of the doorway's centre from the line, along the wall (m).
    #[serde(default = "default_doorway_offset")]
    pub offset_m: [f64; 2],
    /// [least, most] angle of the partition from perpendicular to the line
    /// (degrees, CCW). Absent: 0 (perpendicular), nothing drawn.
    #[serde(default)]
    pub tilt_deg: Option<[f64; 2]>,
    /// [least, most] thickness of the partition (m): solid boxes either side
    /// of the doorway. Absent: a thin wall (segments), as before.
    #[serde(default)]
    pub thickness_m: Option<[f64; 2]>,
    /// [least, most] length of the passage (m): two thin side walls,
    /// perpendicular to the partition and centred on it, along the doorway's
    /// edges, so the doorway is a corridor of its width and this length.
    /// Absent: no side walls (the passage is the partition's thickness).
    #[serde(default)]
    pub passage_m: Option<[f64; 2]>,
}

impl DoorwaySpec {
    /// Whether any of the tilted / thick / passage keys is given: the
    /// doorway is then drawn by the newer geometry (absent, exactly as before).
    pub fn is_extended(&self) -> bool {
        self.tilt_deg.is_some() || self.thickness_m.is_some() || self.passage_m.is_some()
    }
}

pub(super) fn default_doorway_along() -> [f64; 2] {
    [0.35, 0.65]
}
pub(super) fn default_doorway_offset() -> [f64; 2] {
    [-0.5, 0.5]
}

/// How a generated mover moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MoverKind {
    /// Walks back and forth, wall to wall, across the robot's line (within
    /// ±30° of perpendicular) at constant speed, timed to cross it 20-80 %
    /// of the way along about when the robot's nominal motion gets there
    /// (×0.9 to ×1.3 of that time).
    Crossing,
    /// Bounces elastically inside the room, in a random direction.
    Bounce,
    /// Loops through 2 to 4 random waypoints in the room.
    WaypointLoop,
    /// Walks back and forth along the robot's line (up to 0.15 m to one side
    /// of it), timed to meet the robot head-on 20-80 % of the way along.
    HeadOn,
    /// Comes up from behind the robot going its way, converging on its line
    /// at 15-35°, timed to pass it 20-80 % of the way along: it overtakes
    /// when it is faster, is caught up otherwise. (Along the line itself it
    /// would have to start inside the start's free zone.)
    Overtaking,
}

/// Moving discs: how many, how large, how fast relative to the robot, and
/// how they move (each draws its kind uniformly from `kinds`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MovingObstaclesSpec {
    /// [least, most] movers per world (inclusive).
    pub count: [usize; 2],
    /// [least, most] speed as a fraction of `nominal.v_mps`; above 1 the
    /// movers are faster than the robot.
    pub speed_fraction: [f64; 2],
    /// [least, most] disc radius (m).
    pub radius_m: [f64; 2],
    pub kinds: Vec<MoverKind>,
}

impl Default for MovingObstaclesSpec {
    fn default() -> Self {
        Self {
            count: [0, 0],
            speed_fraction: [0.5, 0.5],
            radius_m: [0.15, 0.15],
            kinds: vec![MoverKind::Crossing],
        }
    }
}

pub(super) fn default_goal_tolerance() -> f64 {
    0.2
}
pub(super) fn default_start_clearance() -> f64 {
    0.3
}

/// The template file as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TemplateSpec {
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// Longest simulated time per world (s); a run also ends at the goal.
    pub duration_s: f64,
    pub room: RoomSpec,
    pub robot: RobotSpec,
    #[serde(default)]
    pub lidar: LidarSpec,
    pub nominal: LineNominalSpec,
    /// The goal counts as reached within this distance of the line's end (m).
    #[serde(default = "default_goal_tolerance")]
    pub goal_tolerance_m: f64,
    /// Free space around the start and the goal beyond r + d_safe (m).
    #[serde(default = "default_start_clearance")]
    pub start_clearance_m: f64,
    #[serde(default)]
    pub static_obstacles: StaticObstaclesSpec,
    #[serde(default)]
    pub moving_obstacles: MovingObstaclesSpec,
    /// A wall with a doorway across the robot's line.
    #[serde(default)]
    pub doorway: Option<DoorwaySpec>,
    /// When given, each world also records whether the goal was reached within
    /// this factor × the nominal line time (line length / v_nom).
    #[serde(default)]
    pub time_budget_factor: Option<f64>,
    /// Overrides of `config/oldbf.yaml`, as in a scenario file.
    #[serde(default)]
    pub oldbf: Option<Value>,
}

/// A loaded, validated template.
#[derive(Debug, Clone)]
pub struct Template {
    /// Where it came from, for messages.
    pub file: String,
    pub spec: TemplateSpec,
    /// Filter parameters after the template's overrides.
    pub params: Params,
    /// The base parameter document the worlds' `oldbf:` is merged over.
    pub(super) base: Value,
}

/// One generated world, ready to run.
#[derive(Debug, Clone)]
pub struct GeneratedWorld {
    /// Index within the batch (0-based).
    pub index: usize,
    /// Seed of the LiDAR noise and dropouts, the same for every controller.
    pub sensor_seed: u64,
    pub scenario: Scenario,
    /// The world as a scenario file; `oldbf sim` on it reruns this world
    /// (with the same `--config`).
    pub yaml: String,
    /// Whether a path from the start to the goal keeps the robot's centre
    /// r + d_safe from every static obstacle and wall (movers aside).
    pub path_exists: bool,
    /// What kind of world: `room`, `wide_doorway` or `narrow_doorway`.
    pub label: &'static str,
    /// The room drawn for this world, [width, height] (m).
    pub room_m: [f64; 2],
    /// `time_budget_factor` × line length / v_nom (s), when the template sets it.
    pub time_budget_s: Option<f64>,
}
