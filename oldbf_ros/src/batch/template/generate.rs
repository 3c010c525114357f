//! World `i` of seed `S`: obstacles and movers placed by an RNG seeded by
//! (S, i) alone, a start and a goal checked for a safe path, the scenario
//! text that `oldbf sim` reruns.

use super::*;

/// SplitMix64: decorrelates nearby seeds (0, 1, 2…) before they seed the RNG.
pub(super) fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The robot's nominal line.
#[derive(Debug, Clone, Copy)]
pub(super) struct Line {
    pub(super) start: Vec2,
    pub(super) goal: Vec2,
    pub(super) heading_rad: f64,
    pub(super) length_m: f64,
}

impl Line {
    pub(super) fn direction(&self) -> Vec2 {
        Vec2::new(self.heading_rad.cos(), self.heading_rad.sin())
    }
}

/// Exact distance (m) from `p` to a filled, rotated rectangle (0 inside).
pub(super) fn distance_to_box(p: Vec2, b: &BoxSpec) -> f64 {
    let (s, c) = b.yaw_deg.to_radians().sin_cos();
    let d = p - Vec2::new(b.center[0], b.center[1]);
    let local = Vec2::new(c * d.x + s * d.y, -s * d.x + c * d.y);
    let dx = (local.x.abs() - 0.5 * b.size[0]).max(0.0);
    let dy = (local.y.abs() - 0.5 * b.size[1]).max(0.0);
    dx.hypot(dy)
}

pub(super) fn distance_to_circle(p: Vec2, c: &CircleSpec) -> f64 {
    ((p - Vec2::new(c.center[0], c.center[1])).norm() - c.radius_m).max(0.0)
}

/// Distance along `origin + t·dir` (unit `dir`, origin inside) to the edge of
/// the box [lo, hi] (m).
pub(super) fn exit_distance(origin: Vec2, dir: Vec2, lo: Vec2, hi: Vec2) -> f64 {
    let axis = |o: f64, d: f64, lo: f64, hi: f64| {
        if d > 0.0 {
            (hi - o) / d
        } else if d < 0.0 {
            (lo - o) / d
        } else {
            f64::INFINITY
        }
    };
    axis(origin.x, dir.x, lo.x, hi.x)
        .min(axis(origin.y, dir.y, lo.y, hi.y))
        .max(0.0)
}

/// Draws one world's contents from the template.
pub(super) struct Generator<'a> {
    pub(super) t: &'a Template,
    pub(super) rng: StdRng,
    pub(super) index: usize,
    pub(super) free_radius_m: f64,
    /// This world's room (width, height) (m).
    pub(super) room_m: (f64, f64),
}

impl Generator<'_> {
    pub(super) fn uniform(&mut self, range: [f64; 2]) -> f64 {
        self.rng.gen_range(range[0]..=range[1])
    }

    pub(super) fn count(&mut self, range: [usize; 2]) -> usize {
        self.rng.gen_range(range[0]..=range[1])
    }

    pub(super) fn room(&self) -> (f64, f64) {
        self.room_m
    }

    /// A room side: drawn when the template gives a range, else fixed (no draw).
    pub(super) fn extent(&mut self, e: Extent) -> f64 {
        match e {
            Extent::Fixed(x) => x,
            Extent::Range(r) => self.uniform(r),
        }
    }

    pub(super) fn line(&mut self) -> Line {
        let (w, h) = self.room();
        let m = self.t.spec.nominal.wall_margin_m;
        let side = self.rng.gen_range(0..4);
        let (ya, yb) = (self.rng.gen_range(m..=h - m), self.rng.gen_range(m..=h - m));
        let (xa, xb) = (self.rng.gen_range(m..=w - m), self.rng.gen_range(m..=w - m));
        let (start, goal) = match side {
            0 => (Vec2::new(m, ya), Vec2::new(w - m, yb)),
            1 => (Vec2::new(w - m, ya), Vec2::new(m, yb)),
            2 => (Vec2::new(xa, m), Vec2::new(xb, h - m)),
            _ => (Vec2::new(xa, h - m), Vec2::new(xb, m)),
        };
        let d = goal - start;
        Line {
            start,
            goal,
            heading_rad: d.y.atan2(d.x),
            length_m: d.norm(),
        }
    }

    pub(super) fn crowded(&self, key: &str, what: &str, i: usize) -> ConfigError {
        invalid(
            &self.t.file,
            key,
            format!(
                "could not place {what} {i} of world {} clear of the start and the goal \
                 ({:.3} m) after {PLACEMENT_ATTEMPTS} attempts: the room is too small for \
                 these counts and sizes",
                self.index, self.free_radius_m
            ),
        )
    }

    /// A centre for an obstacle reaching `extent_m` from it: uniform in the
    /// room, or (`near`) within ±`near_line_m` of the line, anywhere along it.
    fn centre(&mut self, line: &Line, extent_m: f64, near: bool) -> Option<[f64; 2]> {
        let (w, h) = self.room();
        if !near {
            return Some([
                self.rng.gen_range(extent_m..=w - extent_m),
                self.rng.gen_range(extent_m..=h - extent_m),
            ]);
        }
        let band = self.t.spec.static_obstacles.near_line_m;
        let along = self.rng.gen_range(0.0..=line.length_m);
        let off = self.rng.gen_range(-band..=band);
        let n = Vec2::new(-line.direction().y, line.direction().x);
        let c = line.start + line.direction() * along + n * off;
        let inside = c.x >= extent_m && c.x <= w - extent_m && c.y >= extent_m && c.y <= h - extent_m;
        inside.then_some([c.x, c.y])
    }

    pub(super) fn static_obstacles(&mut self, line: &Line, world: &mut WorldSpec) -> Result<(), ConfigError> {
        let spec = self.t.spec.static_obstacles;
        let free = self.free_radius_m;
        let keeps_free = |dist: &dyn Fn(Vec2) -> f64| dist(line.start) >= free && dist(line.goal) >= free;
        // Without near-line placement the counts are drawn kind by kind, as
        // they always were (old templates draw the same worlds); with it, all
        // counts first, then which obstacles (by index over all kinds) go near.
        let mut near = Vec::new();
        let mut counts = None;
        if spec.near_line_fraction > 0.0 {
            let c = [
                self.count(spec.circles.count),
                self.count(spec.boxes.count),
                spec.benches.map_or(0, |b| self.count(b.count)),
            ];
            let total = c.iter().sum::<usize>();
            near = near_line_choice(&mut self.rng, total, spec.near_line_fraction);
            counts = Some(c);
        }
        let is_near = |k: usize| near.get(k).copied().unwrap_or(false);
        let mut k = 0;
        let n = match counts {
            Some(c) => c[0],
            None => self.count(spec.circles.count),
        };
        for i in 0..n {
            let radius_m = self.uniform(spec.circles.radius_m);
            let near_k = is_near(k);
            let mut draw = |near: bool| {
                (0..PLACEMENT_ATTEMPTS).find_map(|_| {
                    let c = CircleSpec {
                        center: self.centre(line, radius_m, near)?,
                        radius_m,
                    };
                    keeps_free(&|p| distance_to_circle(p, &c)).then_some(c)
                })
            };
            // Near the line if it fits there (a short line may leave no room), else anywhere.
            let placed = draw(near_k).or_else(|| if near_k { draw(false) } else { None });
            world
                .circles
                .push(placed.ok_or_else(|| self.crowded("static_obstacles.circles", "circle", i))?);
            k += 1;
        }
        let n = match counts {
            Some(c) => c[1],
            None => self.count(spec.boxes.count),
        };
        for i in 0..n {
            let size = [self.uniform(spec.boxes.size_m), self.uniform(spec.boxes.size_m)];
            let b = self.place_box(line, size, is_near(k), "static_obstacles.boxes", "box", i)?;
            world.boxes.push(b);
            k += 1;
        }
        if let Some(benches) = spec.benches {
            let n = match counts {
                Some(c) => c[2],
                None => self.count(benches.count),
            };
            for i in 0..n {
                let size = [self.uniform(benches.length_m), self.uniform(benches.width_m)];
                let b = self.place_box(line, size, is_near(k), "static_obstacles.benches", "bench", i)?;
                world.boxes.push(b);
                k += 1;
            }
        }
        Ok(())
    }

    /// A box of `size` at a yaw uniform in [0°, 180°), inside the room and
    /// clear of the start and the goal (near the line if `near` and it fits
    /// there in [`PLACEMENT_ATTEMPTS`] draws, else anywhere).
    fn place_box(
        &mut self,
        line: &Line,
        size: [f64; 2],
        near: bool,
        key: &str,
        what: &str,
        i: usize,
    ) -> Result<BoxSpec, ConfigError> {
        let free = self.free_radius_m;
        let yaw_deg = self.rng.gen_range(0.0..180.0);
        let half_diag = 0.5 * size[0].hypot(size[1]);
        let mut draw = |near: bool| {
            (0..PLACEMENT_ATTEMPTS).find_map(|_| {
                let b = BoxSpec {
                    center: self.centre(line, half_diag, near)?,
                    size,
                    yaw_deg,
                };
                (distance_to_box(line.start, &b) >= free && distance_to_box(line.goal, &b) >= free).then_some(b)
            })
        };
        // Near the line if it fits there (a short line may leave no room), else anywhere.
        let placed = draw(near).or_else(|| if near { draw(false) } else { None });
        placed.ok_or_else(|| self.crowded(key, what, i))
    }

    /// Adds a wall across the room through the line with a doorway (tilted,
    /// thick and with a passage if the template says so); returns the
    /// doorway's width (m), measured across the passage.
    pub(super) fn doorway(&mut self, line: &Line, d: &DoorwaySpec, world: &mut WorldSpec) -> Result<f64, ConfigError> {
        if !d.is_extended() {
            return Ok(self.thin_doorway(line, d, world));
        }
        for _ in 0..PLACEMENT_ATTEMPTS {
            if let Some((width, parts)) = self.extended_doorway(line, d) {
                world.walls.extend(parts.walls);
                world.boxes.extend(parts.boxes);
                return Ok(width);
            }
        }
        Err(invalid(
            &self.t.file,
            "doorway",
            format!(
                "could not place the doorway of world {} inside the room and clear of the start and the goal \
                 ({:.3} m) after {PLACEMENT_ATTEMPTS} attempts: the passage is too long or the room too small",
                self.index, self.free_radius_m
            ),
        ))
    }

    /// One draw of a tilted / thick doorway with a passage; None if a part
    /// leaves the room or comes within the free radius of the start or goal.
    ///
    /// Geometry: the partition crosses the line at `along`, its direction `u`
    /// is the line's normal turned by `tilt_deg`; the passage runs along `a`,
    /// the line's direction turned by the same angle (perpendicular to the
    /// partition). The partition is a thin wall from room edge to room edge
    /// (as before) with a gap of the door's width along `u`; when thick, a
    /// solid box of that thickness covers each side of it (ending where its
    /// corners meet the room's outline); when there is a passage, two thin
    /// side walls along `a`, `passage_m` long and centred on the partition,
    /// continue the gap's edges: a corridor as wide as the door.
    pub(super) fn extended_doorway(&mut self, line: &Line, d: &DoorwaySpec) -> Option<(f64, DoorwayParts)> {
        let (w, h) = self.room();
        let width = self.uniform(d.width_m);
        let along = self.uniform(d.along) * line.length_m;
        let offset = self.uniform(d.offset_m);
        let tilt = d.tilt_deg.map_or(0.0, |r| self.uniform(r)).to_radians();
        let thickness = d.thickness_m.map_or(0.0, |r| self.uniform(r));
        let passage = d.passage_m.map_or(0.0, |r| self.uniform(r));
        let p = line.start + line.direction() * along;
        let a = Vec2::new((line.heading_rad + tilt).cos(), (line.heading_rad + tilt).sin());
        let u = Vec2::new(-a.y, a.x);
        let parts = doorway_parts(p, a, u, width, offset, thickness, passage, (w, h))?;
        let free = self.free_radius_m;
        let clear = |q: Vec2| {
            parts.walls.iter().all(|s| {
                crate::sim::Segment::new(Vec2::new(s.from[0], s.from[1]), Vec2::new(s.to[0], s.to[1])).distance_to(q)
                    >= free
            }) && parts.boxes.iter().all(|b| distance_to_box(q, b) >= free)
        };
        (clear(line.start) && clear(line.goal)).then_some((width, parts))
    }

    /// The doorway as it always was: a thin wall perpendicular to the line.
    fn thin_doorway(&mut self, line: &Line, d: &DoorwaySpec, world: &mut WorldSpec) -> f64 {
        let (w, h) = self.room();
        let width = self.uniform(d.width_m);
        let along = self.uniform(d.along) * line.length_m;
        let offset = self.uniform(d.offset_m);
        let p = line.start + line.direction() * along;
        let n = Vec2::new(-line.direction().y, line.direction().x);
        let (lo, hi) = (Vec2::new(0.0, 0.0), Vec2::new(w, h));
        // The wall from room edge to room edge, along n through p.
        let (s_min, s_max) = (-exit_distance(p, -n, lo, hi), exit_distance(p, n, lo, hi));
        let centre = offset.clamp(s_min + 0.5 * width, s_max - 0.5 * width);
        let at = |s: f64| {
            let q = p + n * s;
            [q.x, q.y]
        };
        world.walls.push(WallSpec {
            from: at(s_min),
            to: at(centre - 0.5 * width),
        });
        world.walls.push(WallSpec {
            from: at(centre + 0.5 * width),
            to: at(s_max),
        });
        width
    }

    /// True if a mover of `radius_m` at `p` at t = 0 keeps the start free and
    /// does not sit inside a static obstacle.
    pub(super) fn mover_start_ok(&self, p: Vec2, radius_m: f64, line: &Line, world: &WorldSpec) -> bool {
        let off_robot = (p - line.start).norm() - radius_m >= self.free_radius_m;
        let off_static = world.circles.iter().all(|c| distance_to_circle(p, c) >= radius_m)
            && world.boxes.iter().all(|b| distance_to_box(p, b) >= radius_m);
        off_robot && off_static
    }

    pub(super) fn movers(&mut self, line: &Line, world: &mut WorldSpec) -> Result<(), ConfigError> {
        let spec = self.t.spec.moving_obstacles.clone();
        let v_nom = self.t.spec.nominal.v_mps;
        let n = self.count(spec.count);
        for i in 0..n {
            let radius_m = self.uniform(spec.radius_m);
            let speed_mps = self.uniform(spec.speed_fraction) * v_nom;
            let kind = spec.kinds[self.rng.gen_range(0..spec.kinds.len())];
            let placed = (0..PLACEMENT_ATTEMPTS).find_map(|_| {
                let motion = match kind {
                    MoverKind::Crossing => self.crossing(line, radius_m, speed_mps)?,
                    MoverKind::Bounce => self.bounce(radius_m, speed_mps),
                    MoverKind::WaypointLoop => self.waypoint_loop(radius_m, speed_mps)?,
                    MoverKind::HeadOn => self.along_line(line, radius_m, speed_mps, false)?,
                    MoverKind::Overtaking => self.along_line(line, radius_m, speed_mps, true)?,
                };
                let start = match &motion {
                    MotionSpec::ConstantVelocity { start, .. } | MotionSpec::Bounce { start, .. } => *start,
                    MotionSpec::WaypointLoop { waypoints, .. } => waypoints[0],
                };
                self.mover_start_ok(Vec2::new(start[0], start[1]), radius_m, line, world)
                    .then_some(motion)
            });
            let motion = placed.ok_or_else(|| self.crowded("moving_obstacles", "mover", i))?;
            let label = match kind {
                MoverKind::Crossing => "crossing",
                MoverKind::Bounce => "bounce",
                MoverKind::WaypointLoop => "loop",
                MoverKind::HeadOn => "headon",
                MoverKind::Overtaking => "overtaking",
            };
            world.moving.push(MovingObstacleSpec {
                radius_m,
                motion,
                name: Some(format!("{label}_{i}")),
            });
        }
        Ok(())
    }

    /// The box a mover's centre may visit (m).
    pub(super) fn inner_region(&self, radius_m: f64) -> (Vec2, Vec2) {
        let (w, h) = self.room();
        let e = radius_m + WALL_GAP_M;
        (Vec2::new(e, e), Vec2::new(w - e, h - e))
    }

    /// Paces back and forth across the robot's line, wall to wall, phased to
    /// pass the crossing point (moving forward) at the chosen time.
    pub(super) fn crossing(&mut self, line: &Line, radius_m: f64, speed_mps: f64) -> Option<MotionSpec> {
        let v_nom = self.t.spec.nominal.v_mps;
        let along = self.rng.gen_range(0.2..=0.8) * line.length_m;
        let cross = line.start + line.direction() * along;
        let t_cross_s = along / v_nom * self.rng.gen_range(0.9..=1.3);
        let side = if self.rng.gen::<bool>() { 1.0 } else { -1.0 };
        let angle = line.heading_rad + side * PI / 2.0 + self.rng.gen_range(-PI / 6.0..=PI / 6.0);
        let dir = Vec2::new(angle.cos(), angle.sin());
        self.pace_through(cross, dir, t_cross_s, radius_m, speed_mps)
    }

    /// Paces back and forth through the point where the robot's nominal
    /// motion puts it 20-80 % of the way along (up to 0.15 m to one side),
    /// phased to be there with the robot: against it along the line
    /// (head-on), or going its way converging at 15-35° (`from_behind`).
    pub(super) fn along_line(
        &mut self,
        line: &Line,
        radius_m: f64,
        speed_mps: f64,
        from_behind: bool,
    ) -> Option<MotionSpec> {
        let v_nom = self.t.spec.nominal.v_mps;
        let along = self.rng.gen_range(0.2..=0.8) * line.length_m;
        let offset = self.rng.gen_range(-0.15..=0.15);
        let normal = Vec2::new(-line.direction().y, line.direction().x);
        let meet = line.start + line.direction() * along + normal * offset;
        let t_meet_s = along / v_nom * self.rng.gen_range(0.9..=1.1);
        let heading = if from_behind {
            let side = if self.rng.gen::<bool>() { 1.0 } else { -1.0 };
            line.heading_rad + side * self.rng.gen_range(15f64.to_radians()..=35f64.to_radians())
        } else {
            line.heading_rad + PI
        };
        let dir = Vec2::new(heading.cos(), heading.sin());
        self.pace_through(meet, dir, t_meet_s, radius_m, speed_mps)
    }

    /// Paces back and forth through `cross` along `dir` (unit), wall to wall,
    /// phased to pass `cross` going along `dir` at `t_cross_s`.
    pub(super) fn pace_through(
        &mut self,
        cross: Vec2,
        dir: Vec2,
        t_cross_s: f64,
        radius_m: f64,
        speed_mps: f64,
    ) -> Option<MotionSpec> {
        let (lo, hi) = self.inner_region(radius_m);
        if cross.x < lo.x || cross.x > hi.x || cross.y < lo.y || cross.y > hi.y {
            return None;
        }
        // The walk's ends A (behind the crossing point) and B (ahead), on the region's edge.
        let behind_m = exit_distance(cross, -dir, lo, hi);
        let ahead_m = exit_distance(cross, dir, lo, hi);
        let span_m = behind_m + ahead_m;
        if span_m < MIN_LOOP_M {
            return None;
        }
        let (a, b) = (cross - dir * behind_m, cross + dir * ahead_m);
        // Loop coordinate u ∈ [0, 2·span): A → B for u ≤ span, then back. At t = 0 the
        // mover is at u0 such that u(t_cross) = behind (at the crossing point, moving A → B).
        let u0 = (behind_m - speed_mps * t_cross_s).rem_euclid(2.0 * span_m);
        let waypoints = if u0 <= span_m {
            vec![a + dir * u0, b, a]
        } else {
            vec![a + dir * (2.0 * span_m - u0), a, b]
        };
        Some(MotionSpec::WaypointLoop {
            waypoints: waypoints.iter().map(|p| [p.x, p.y]).collect(),
            speed_mps,
        })
    }

    pub(super) fn bounce(&mut self, radius_m: f64, speed_mps: f64) -> MotionSpec {
        let (lo, hi) = self.inner_region(radius_m);
        let start = [self.rng.gen_range(lo.x..=hi.x), self.rng.gen_range(lo.y..=hi.y)];
        let a = self.rng.gen_range(0.0..2.0 * PI);
        MotionSpec::Bounce {
            start,
            velocity_mps: [a.cos() * speed_mps, a.sin() * speed_mps],
            region_min: [lo.x, lo.y],
            region_max: [hi.x, hi.y],
        }
    }

    pub(super) fn waypoint_loop(&mut self, radius_m: f64, speed_mps: f64) -> Option<MotionSpec> {
        let (lo, hi) = self.inner_region(radius_m);
        let n = self.rng.gen_range(2..=4);
        let waypoints: Vec<[f64; 2]> = (0..n)
            .map(|_| [self.rng.gen_range(lo.x..=hi.x), self.rng.gen_range(lo.y..=hi.y)])
            .collect();
        let perimeter_m: f64 = (0..n)
            .map(|k| {
                let (a, b) = (waypoints[k], waypoints[(k + 1) % n]);
                (a[0] - b[0]).hypot(a[1] - b[1])
            })
            .sum();
        (perimeter_m >= MIN_LOOP_M).then_some(MotionSpec::WaypointLoop { waypoints, speed_mps })
    }
}

/// The walls and boxes of one doorway.
#[derive(Debug, Clone, Default)]
pub(super) struct DoorwayParts {
    pub(super) walls: Vec<WallSpec>,
    pub(super) boxes: Vec<BoxSpec>,
}

/// The doorway through the partition crossing `p` along `u` (unit; `a`, the
/// passage's direction, is perpendicular to it): a gap `width` wide centred
/// `offset` along `u` from `p` (clamped to fit the partition), thin partition
/// walls from room edge to room edge, boxes `thickness` thick either side
/// of the gap (if > 0), side walls `passage` long along `a` (if > 0). None
/// if the gap does not fit or a side wall leaves the room `(w, h)`.
#[allow(clippy::too_many_arguments)]
pub(super) fn doorway_parts(
    p: Vec2,
    a: Vec2,
    u: Vec2,
    width: f64,
    offset: f64,
    thickness: f64,
    passage: f64,
    (w, h): (f64, f64),
) -> Option<DoorwayParts> {
    let (lo, hi) = (Vec2::new(0.0, 0.0), Vec2::new(w, h));
    let inside = |q: Vec2| q.x >= 0.0 && q.x <= w && q.y >= 0.0 && q.y <= h;
    if !inside(p) {
        return None;
    }
    let (s_min, s_max) = (-exit_distance(p, -u, lo, hi), exit_distance(p, u, lo, hi));
    if s_max - s_min <= width {
        return None;
    }
    let centre = offset.clamp(s_min + 0.5 * width, s_max - 0.5 * width);
    let (left, right) = (centre - 0.5 * width, centre + 0.5 * width);
    let at = |q: Vec2| [q.x, q.y];
    let mut parts = DoorwayParts::default();
    parts.walls.push(WallSpec {
        from: at(p + u * s_min),
        to: at(p + u * left),
    });
    parts.walls.push(WallSpec {
        from: at(p + u * right),
        to: at(p + u * s_max),
    });
    if thickness > 0.0 {
        let half = a * (0.5 * thickness);
        let (fa, fb) = (p + half, p - half);
        if !inside(fa) || !inside(fb) {
            return None;
        }
        // Each box ends where the first of its two long edges meets the room's outline.
        let s_lo = (-exit_distance(fa, -u, lo, hi)).max(-exit_distance(fb, -u, lo, hi));
        let s_hi = exit_distance(fa, u, lo, hi).min(exit_distance(fb, u, lo, hi));
        let yaw_deg = u.y.atan2(u.x).to_degrees().rem_euclid(180.0);
        for (from, to) in [(s_lo, left), (right, s_hi)] {
            if to - from > 1e-6 {
                let c = p + u * (0.5 * (from + to));
                parts.boxes.push(BoxSpec {
                    center: [c.x, c.y],
                    size: [to - from, thickness],
                    yaw_deg,
                });
            }
        }
    }
    if passage > 0.0 {
        for e in [left, right] {
            let (q0, q1) = (p + u * e - a * (0.5 * passage), p + u * e + a * (0.5 * passage));
            if !inside(q0) || !inside(q1) {
                return None;
            }
            parts.walls.push(WallSpec {
                from: at(q0),
                to: at(q1),
            });
        }
    }
    Some(parts)
}

/// Which of `total` obstacles go near the line: round(`fraction` × total)
/// of them, chosen uniformly at random.
pub(super) fn near_line_choice(rng: &mut StdRng, total: usize, fraction: f64) -> Vec<bool> {
    let k = ((fraction * total as f64).round() as usize).min(total);
    let mut near = vec![false; total];
    for i in rand::seq::index::sample(rng, total, k) {
        near[i] = true;
    }
    near
}

/// Whether a chain of grid cells (4-connected, [`PATH_GRID_M`] apart) leads
/// from `start` to `goal` through cell centres at least `clearance_m` from
/// every static obstacle and wall of `spec` (its movers are ignored).
pub(super) fn path_exists_in(
    spec: &WorldSpec,
    start: Vec2,
    goal: Vec2,
    clearance_m: f64,
    file: &str,
) -> Result<bool, ConfigError> {
    let statics = WorldSpec {
        moving: Vec::new(),
        ..spec.clone()
    };
    let world = World::new(&statics).map_err(|e| invalid(file, "", e.to_string()))?;
    let Some((lo, hi)) = world.bounds() else {
        return Ok(true);
    };
    let nx = ((hi.x - lo.x) / PATH_GRID_M).ceil() as usize + 1;
    let ny = ((hi.y - lo.y) / PATH_GRID_M).ceil() as usize + 1;
    let cell = |p: Vec2| {
        let i = ((p.x - lo.x) / PATH_GRID_M).round().clamp(0.0, (nx - 1) as f64) as usize;
        let j = ((p.y - lo.y) / PATH_GRID_M).round().clamp(0.0, (ny - 1) as f64) as usize;
        (i, j)
    };
    let centre = |i: usize, j: usize| Vec2::new(lo.x + i as f64 * PATH_GRID_M, lo.y + j as f64 * PATH_GRID_M);
    let free = |i: usize, j: usize| world.distance_to_nearest(centre(i, j)) >= clearance_m;
    let (s, g) = (cell(start), cell(goal));
    let mut seen = vec![false; nx * ny];
    let mut queue = std::collections::VecDeque::new();
    seen[s.1 * nx + s.0] = true;
    queue.push_back(s);
    while let Some((i, j)) = queue.pop_front() {
        if (i, j) == g {
            return Ok(true);
        }
        let next = [(i.wrapping_sub(1), j), (i + 1, j), (i, j.wrapping_sub(1)), (i, j + 1)];
        for (a, b) in next {
            if a < nx && b < ny && !seen[b * nx + a] {
                seen[b * nx + a] = true;
                if free(a, b) {
                    queue.push_back((a, b));
                }
            }
        }
    }
    Ok(false)
}

/// A scenario file as `Scenario` parses it (the keys the batch sets).
#[derive(Serialize)]
pub(super) struct ScenarioOut<'a> {
    pub(super) name: String,
    pub(super) description: String,
    pub(super) duration_s: f64,
    pub(super) seed: u64,
    pub(super) robot: &'a RobotSpec,
    pub(super) start: StartOut,
    pub(super) lidar: &'a LidarSpec,
    pub(super) nominal: NominalOut,
    pub(super) goal_tolerance_m: f64,
    pub(super) world: WorldSpec,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) oldbf: Option<&'a Value>,
}

#[derive(Serialize)]
pub(super) struct StartOut {
    pub(super) x_m: f64,
    pub(super) y_m: f64,
    pub(super) theta_deg: f64,
}

#[derive(Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub(super) enum NominalOut {
    Line { v_mps: f64, length_m: f64 },
}
