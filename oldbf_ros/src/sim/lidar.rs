//! A ray-cast 2-D LiDAR that produces `sensor_msgs/LaserScan`-style ranges.
//!
//! Why: the safety filter consumes raw scans, so the simulator must produce
//! them with the same conventions and the same failure modes as the real
//! sensor — beams centred on the laser's +x, `+inf` for "nothing within
//! range", Gaussian range noise, and dropouts as NaN or `+inf`. Defaults match
//! a TurtleBot3 LDS-01-like sensor (360 beams over 360°, 0.12–3.5 m, 10 Hz).
//!
//! Readings are *not* cleaned here: a noisy value below `range_min_m`, at or
//! above `range_max_m`, or negative, is passed on unchanged; rejecting it is
//! the consumer's job (`algo::scan`). Units: m, rad, s; `fov_deg` is degrees
//! in YAML. Randomness comes from a seeded `StdRng`, so a scan sequence is
//! reproducible for a given seed.

use super::world::{ScanScratch, World};
use crate::algo::geometry::{Pose2, Vec2};
use oldbf::config::{Checker, Interval, ParamError, Validate};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// What a dropped-out beam reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DropoutKind {
    /// NaN (a failed measurement).
    #[default]
    Nan,
    /// `+inf` (no return, as from a black or glassy surface).
    Inf,
    /// NaN or `+inf` with equal probability.
    Mixed,
}

/// LiDAR parameters (YAML); every key is optional, defaults as documented.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LidarSpec {
    /// Number of beams per scan, in [1, 16384]. Default 360.
    pub beams: usize,
    /// Field of view (degrees), in (0, 360], centred on the laser's +x.
    /// Default 360.
    pub fov_deg: f64,
    /// Minimum valid range (m), reported in the scan. Default 0.12.
    pub range_min_m: f64,
    /// Maximum range (m): no hit closer than this reads `+inf`. Default 3.5.
    pub range_max_m: f64,
    /// Standard deviation of the additive Gaussian range noise (m). Default 0.
    pub noise_std_m: f64,
    /// Probability that a beam is dropped out, in [0, 1]. Default 0.
    pub dropout_prob: f64,
    /// What a dropped-out beam reads. Default `nan`.
    pub dropout: DropoutKind,
    /// Scan rate (Hz), in (0, 1000]. Default 10.
    pub rate_hz: f64,
}

impl Default for LidarSpec {
    fn default() -> Self {
        Self {
            beams: 360,
            fov_deg: 360.0,
            range_min_m: 0.12,
            range_max_m: 3.5,
            noise_std_m: 0.0,
            dropout_prob: 0.0,
            dropout: DropoutKind::Nan,
            rate_hz: 10.0,
        }
    }
}

/// Largest accepted `beams`.
pub const MAX_BEAMS: usize = 16384;

/// Why a [`Lidar`] cannot be built: its spec's values (each with its key
/// as data), or a noise the distribution refuses.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LidarError {
    /// Values outside what their keys allow (`lidar.beams`, ...).
    #[error("{}", .0.iter().map(ToString::to_string).collect::<Vec<_>>().join("; "))]
    Invalid(Vec<ParamError>),
    /// The noise distribution refused the standard deviation.
    #[error("lidar.noise_std_m: {source}")]
    Noise {
        #[source]
        source: rand_distr::NormalError,
    },
}

/// Beams per scan.
const BEAMS: Interval = Interval::closed(1.0, MAX_BEAMS as f64);

impl Validate for LidarSpec {
    fn check(&self, c: &mut Checker) {
        c.range("lidar.beams", self.beams as f64, BEAMS);
        c.range(
            "lidar.fov_deg",
            self.fov_deg,
            Interval::open_closed(0.0, 360.0).unit("deg"),
        );
        c.rule(
            self.range_min_m.is_finite() && self.range_min_m >= 0.0,
            "lidar.range_min_m",
            self.range_min_m,
            ">= 0 and finite",
        );
        c.rule(
            self.range_max_m.is_finite() && self.range_max_m > self.range_min_m,
            "lidar.range_max_m",
            self.range_max_m,
            format!("finite and above lidar.range_min_m = {}", self.range_min_m),
        );
        c.rule(
            self.noise_std_m.is_finite() && self.noise_std_m >= 0.0,
            "lidar.noise_std_m",
            self.noise_std_m,
            ">= 0 and finite",
        );
        c.range("lidar.dropout_prob", self.dropout_prob, Interval::closed(0.0, 1.0));
        c.range(
            "lidar.rate_hz",
            self.rate_hz,
            Interval::open_closed(0.0, 1000.0).unit("Hz"),
        );
    }
}

impl LidarSpec {
    fn fov_rad(&self) -> f64 {
        self.fov_deg.to_radians()
    }

    /// Angle of beam 0 relative to the laser's +x (rad): −fov/2, or 0 for a
    /// single beam. As `f32`, like `LaserScan.angle_min`.
    pub fn angle_min_rad(&self) -> f32 {
        if self.beams <= 1 {
            0.0
        } else if self.fov_deg >= 360.0 {
            -PI as f32
        } else {
            (-0.5 * self.fov_rad()) as f32
        }
    }

    /// Angle between consecutive beams (rad), as `f32` like
    /// `LaserScan.angle_increment`: 2π/beams for a full circle (no duplicated
    /// beam at +π), fov/(beams − 1) otherwise so the last beam is at +fov/2.
    /// A single beam reports fov (any non-zero value would do).
    pub fn angle_increment_rad(&self) -> f32 {
        let n = self.beams.max(1) as f64;
        if self.fov_deg >= 360.0 {
            (2.0 * PI / n) as f32
        } else if self.beams <= 1 {
            self.fov_rad() as f32
        } else {
            (self.fov_rad() / (n - 1.0)) as f32
        }
    }

    /// Angle of beam `i` relative to the laser's +x (rad), computed from the
    /// `f32` angle_min and increment exactly as a scan consumer would.
    pub fn beam_angle_rad(&self, i: usize) -> f64 {
        self.angle_min_rad() as f64 + i as f64 * self.angle_increment_rad() as f64
    }

    /// Time between scans (s).
    pub fn period_s(&self) -> f64 {
        1.0 / self.rate_hz
    }
}

/// The simulated sensor: a validated spec, its beam directions, a seeded RNG
/// and a reusable cull buffer.
#[derive(Debug, Clone)]
pub struct Lidar {
    spec: LidarSpec,
    rng: StdRng,
    noise: Option<Normal<f64>>,
    /// Unit beam directions in the laser frame.
    beam_dirs: Vec<Vec2>,
    scratch: ScanScratch,
    /// The true range of each beam of the last scan, before noise and
    /// dropouts (m; +inf: nothing within range_max): what a metric needs to
    /// tell a reading that hid something from one that did not.
    truth: Vec<f32>,
}

impl Lidar {
    /// Validates `spec` and seeds the noise/dropout generator with `seed`.
    pub fn new(spec: LidarSpec, seed: u64) -> Result<Lidar, LidarError> {
        spec.validate().map_err(LidarError::Invalid)?;
        let noise = if spec.noise_std_m > 0.0 {
            Some(Normal::new(0.0, spec.noise_std_m).map_err(|source| LidarError::Noise { source })?)
        } else {
            None
        };
        let beam_dirs = (0..spec.beams)
            .map(|i| {
                let (s, c) = spec.beam_angle_rad(i).sin_cos();
                Vec2::new(c, s)
            })
            .collect();
        Ok(Lidar {
            spec,
            rng: StdRng::seed_from_u64(seed),
            noise,
            beam_dirs,
            scratch: ScanScratch::default(),
            truth: Vec::new(),
        })
    }

    pub fn spec(&self) -> &LidarSpec {
        &self.spec
    }

    /// Casts one scan from `laser_pose_world` (the laser's pose in the world
    /// frame: position m, yaw rad) into `ranges_out`, which is cleared and
    /// filled with one range per beam (m). No allocation once
    /// `ranges_out` has the capacity.
    ///
    /// Per beam: the nearest hit below `range_max_m`, else `+inf`; hits get
    /// N(0, noise_std_m) added (not clipped); then with probability
    /// `dropout_prob` the reading (hit or not) is replaced per
    /// [`DropoutKind`]. A non-finite pose yields an all-NaN scan.
    pub fn scan_into(&mut self, world: &World, laser_pose_world: Pose2, ranges_out: &mut Vec<f32>) {
        ranges_out.clear();
        ranges_out.reserve(self.beam_dirs.len());
        self.truth.clear();
        if !laser_pose_world.is_finite() {
            ranges_out.resize(self.beam_dirs.len(), f32::NAN);
            self.truth.resize(self.beam_dirs.len(), f32::NAN);
            return;
        }
        let origin = laser_pose_world.position();
        let (s, c) = laser_pose_world.theta.sin_cos();
        let range_max_m = self.spec.range_max_m;
        let p_drop = self.spec.dropout_prob;
        world.prepare_scan(origin, range_max_m, &mut self.scratch);
        for d in &self.beam_dirs {
            let dir = Vec2::new(c * d.x - s * d.y, s * d.x + c * d.y);
            let hit = self.scratch.ray_cast(origin, dir, range_max_m);
            self.truth.push(hit.map_or(f32::INFINITY, |t| t as f32));
            let mut r = match hit {
                Some(t) => {
                    let noisy = match &self.noise {
                        Some(n) => t + n.sample(&mut self.rng),
                        None => t,
                    };
                    noisy as f32
                }
                None => f32::INFINITY,
            };
            if p_drop > 0.0 && self.rng.gen::<f64>() < p_drop {
                r = match self.spec.dropout {
                    DropoutKind::Nan => f32::NAN,
                    DropoutKind::Inf => f32::INFINITY,
                    DropoutKind::Mixed => {
                        if self.rng.gen::<bool>() {
                            f32::NAN
                        } else {
                            f32::INFINITY
                        }
                    }
                };
            }
            if r == 0.0 {
                // Normalise a −0.0 to +0.0; negative readings stay negative.
                r = 0.0;
            }
            ranges_out.push(r);
        }
    }

    /// The true range of each beam of the last scan (m; +inf: no hit within
    /// range_max), before noise and dropouts.
    pub fn truth(&self) -> &[f32] {
        &self.truth
    }

    /// Allocating convenience wrapper around [`Lidar::scan_into`].
    pub fn scan(&mut self, world: &World, laser_pose_world: Pose2) -> Vec<f32> {
        let mut out = Vec::with_capacity(self.beam_dirs.len());
        self.scan_into(world, laser_pose_world, &mut out);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::world::{CircleSpec, WallSpec, WorldSpec};

    fn world(spec: WorldSpec) -> World {
        World::new(&spec).expect("valid world")
    }

    fn wall(from: [f64; 2], to: [f64; 2]) -> WallSpec {
        WallSpec { from, to }
    }

    /// Square room |x|, |y| ≤ 1.5 around the origin: every beam from inside hits.
    fn room() -> World {
        world(WorldSpec {
            polygons: vec![vec![[-1.5, -1.5], [1.5, -1.5], [1.5, 1.5], [-1.5, 1.5]]],
            ..WorldSpec::default()
        })
    }

    #[test]
    fn defaults_match_lds01_and_validate() {
        let s = LidarSpec::default();
        assert_eq!(s.beams, 360);
        assert_eq!(s.range_max_m, 3.5);
        assert_eq!(s.range_min_m, 0.12);
        assert_eq!(s.rate_hz, 10.0);
        assert!(s.validate().is_ok());
        let y: LidarSpec = serde_yaml::from_str("noise_std_m: 0.01\ndropout: mixed\n").expect("ok");
        assert_eq!(y.noise_std_m, 0.01);
        assert_eq!(y.dropout, DropoutKind::Mixed);
        assert_eq!(y.beams, 360);
        assert!(serde_yaml::from_str::<LidarSpec>("range_max: 4\n").is_err());
    }

    #[test]
    fn validate_names_the_key() {
        let bad = |f: fn(&mut LidarSpec), key: &str| {
            let mut s = LidarSpec::default();
            f(&mut s);
            let e = s.validate().unwrap_err();
            assert_eq!(e.len(), 1, "{e:?}");
            let e = e[0].to_string();
            assert!(e.starts_with(key), "{e}");
            assert!(Lidar::new(s, 0).is_err());
        };
        bad(
            |s| s.beams = 0,
            "key `lidar.beams` = 0 is out of range; allowed: [1, 16384]",
        );
        bad(|s| s.beams = 16385, "key `lidar.beams`");
        bad(|s| s.fov_deg = 0.0, "key `lidar.fov_deg`");
        bad(|s| s.fov_deg = 361.0, "key `lidar.fov_deg`");
        bad(|s| s.fov_deg = f64::NAN, "key `lidar.fov_deg`");
        bad(|s| s.range_min_m = -0.1, "key `lidar.range_min_m`");
        bad(|s| s.range_max_m = 0.1, "key `lidar.range_max_m`");
        bad(|s| s.range_max_m = f64::INFINITY, "key `lidar.range_max_m`");
        bad(|s| s.noise_std_m = -0.01, "key `lidar.noise_std_m`");
        bad(|s| s.dropout_prob = 1.5, "key `lidar.dropout_prob`");
        bad(|s| s.dropout_prob = f64::NAN, "key `lidar.dropout_prob`");
        bad(|s| s.rate_hz = 0.0, "key `lidar.rate_hz`");
        bad(|s| s.rate_hz = 1001.0, "key `lidar.rate_hz`");
    }

    #[test]
    fn angle_conventions() {
        let full = LidarSpec::default();
        assert_eq!(full.angle_min_rad(), -std::f32::consts::PI);
        assert_eq!(full.angle_increment_rad(), (2.0 * PI / 360.0) as f32);
        // Last beam one increment short of +π: no duplicate of beam 0.
        assert!((full.beam_angle_rad(359) - (PI - PI / 180.0)).abs() < 1e-5);
        let half = LidarSpec {
            fov_deg: 180.0,
            beams: 181,
            ..LidarSpec::default()
        };
        assert_eq!(half.angle_min_rad(), (-PI / 2.0) as f32);
        assert_eq!(half.angle_increment_rad(), (PI / 180.0) as f32);
        assert!((half.beam_angle_rad(180) - PI / 2.0).abs() < 1e-5);
        assert!(half.beam_angle_rad(90).abs() < 1e-6);
        let one = LidarSpec {
            fov_deg: 90.0,
            beams: 1,
            ..LidarSpec::default()
        };
        assert_eq!(one.angle_min_rad(), 0.0);
        assert!(one.angle_increment_rad() > 0.0);
    }

    #[test]
    fn wall_at_beam_zero_reads_its_distance() {
        // Full circle: beam 0 points backwards (−π). Wall at x = −2.
        let w = world(WorldSpec {
            walls: vec![wall([-2.0, -1.0], [-2.0, 1.0])],
            ..WorldSpec::default()
        });
        let mut l = Lidar::new(LidarSpec::default(), 1).expect("valid");
        let r = l.scan(&w, Pose2::new(0.0, 0.0, 0.0));
        assert_eq!(r.len(), 360);
        assert_eq!(r[0], 2.0);
        // Nothing ahead: beam 180 (angle 0) reads +inf.
        assert_eq!(r[180], f32::INFINITY);
        // 180° scanner on a robot at (1, 1) facing +y: beam 0 (−90°) looks along
        // world +x; a wall at x = 3 is 2 m away. Beam 90 looks along +y: nothing.
        let w = world(WorldSpec {
            walls: vec![wall([3.0, 0.0], [3.0, 2.0])],
            ..WorldSpec::default()
        });
        let spec = LidarSpec {
            fov_deg: 180.0,
            beams: 181,
            ..LidarSpec::default()
        };
        let mut l = Lidar::new(spec, 1).expect("valid");
        let r = l.scan(&w, Pose2::new(1.0, 1.0, PI / 2.0));
        assert_eq!(r.len(), 181);
        assert!((r[0] - 2.0).abs() < 1e-6, "{}", r[0]);
        assert_eq!(r[90], f32::INFINITY);
        assert_eq!(r[180], f32::INFINITY);
    }

    #[test]
    fn circle_and_range_limit() {
        let w = world(WorldSpec {
            circles: vec![CircleSpec {
                center: [3.0, 0.0],
                radius_m: 0.5,
            }],
            walls: vec![wall([-1.0, 4.0], [1.0, 4.0])],
            ..WorldSpec::default()
        });
        let mut l = Lidar::new(LidarSpec::default(), 1).expect("valid");
        let r = l.scan(&w, Pose2::new(0.0, 0.0, 0.0));
        // Beam 180 looks along +x: 3 − 0.5 = 2.5.
        assert!((r[180] - 2.5).abs() < 1e-6, "{}", r[180]);
        // The circle subtends asin(0.5/3) ≈ 9.6°: beam 190 (10°) misses.
        assert!(r[189].is_finite());
        assert_eq!(r[190], f32::INFINITY);
        // Wall 4 m up is beyond range_max 3.5: beam 270 (+90°) reads +inf.
        assert_eq!(r[270], f32::INFINITY);
        let mut far = Lidar::new(
            LidarSpec {
                range_max_m: 5.0,
                ..LidarSpec::default()
            },
            1,
        )
        .expect("valid");
        let r = far.scan(&w, Pose2::new(0.0, 0.0, 0.0));
        assert!((r[270] - 4.0).abs() < 1e-6, "{}", r[270]);
    }

    #[test]
    fn noise_statistics() {
        let w = room();
        let pose = Pose2::new(0.1, -0.2, 0.3);
        let clean = Lidar::new(LidarSpec::default(), 0).expect("valid").scan(&w, pose);
        let sigma = 0.02;
        let mut l = Lidar::new(
            LidarSpec {
                noise_std_m: sigma,
                ..LidarSpec::default()
            },
            42,
        )
        .expect("valid");
        let mut buf = Vec::new();
        let (mut n, mut sum, mut sum2) = (0usize, 0.0f64, 0.0f64);
        for _ in 0..20 {
            l.scan_into(&w, pose, &mut buf);
            for (a, b) in buf.iter().zip(&clean) {
                let e = (*a as f64) - (*b as f64);
                n += 1;
                sum += e;
                sum2 += e * e;
            }
        }
        assert_eq!(n, 7200);
        let mean = sum / n as f64;
        let std = (sum2 / n as f64 - mean * mean).sqrt();
        assert!(mean.abs() < 3.0 * sigma / (n as f64).sqrt(), "mean {mean}");
        assert!((std / sigma - 1.0).abs() < 0.05, "std {std}");
    }

    #[test]
    fn dropout_fraction_and_kinds() {
        let w = room();
        let pose = Pose2::new(0.0, 0.0, 0.0);
        for (kind, p) in [
            (DropoutKind::Nan, 0.1),
            (DropoutKind::Inf, 0.3),
            (DropoutKind::Mixed, 0.2),
        ] {
            let mut l = Lidar::new(
                LidarSpec {
                    dropout_prob: p,
                    dropout: kind,
                    ..LidarSpec::default()
                },
                7,
            )
            .expect("valid");
            let (mut nan, mut inf, mut n) = (0usize, 0usize, 0usize);
            let mut buf = Vec::new();
            for _ in 0..50 {
                l.scan_into(&w, pose, &mut buf);
                n += buf.len();
                nan += buf.iter().filter(|r| r.is_nan()).count();
                inf += buf.iter().filter(|r| r.is_infinite()).count();
            }
            // n = 18000; σ of the fraction ≤ √(0.25/18000) ≈ 0.0037; allow 4σ.
            let frac = (nan + inf) as f64 / n as f64;
            assert!((frac - p).abs() < 0.015, "{kind:?}: {frac}");
            match kind {
                DropoutKind::Nan => assert_eq!(inf, 0),
                DropoutKind::Inf => assert_eq!(nan, 0),
                DropoutKind::Mixed => {
                    let share = nan as f64 / (nan + inf) as f64;
                    assert!((share - 0.5).abs() < 0.05, "NaN share {share}");
                }
            }
        }
        // Probability 1: everything dropped.
        let mut l = Lidar::new(
            LidarSpec {
                dropout_prob: 1.0,
                ..LidarSpec::default()
            },
            7,
        )
        .expect("valid");
        assert!(l.scan(&w, pose).iter().all(|r| r.is_nan()));
    }

    #[test]
    fn same_seed_same_scans_other_seed_differs() {
        let w = room();
        let spec = LidarSpec {
            noise_std_m: 0.05,
            dropout_prob: 0.1,
            dropout: DropoutKind::Mixed,
            ..LidarSpec::default()
        };
        let bits = |seed: u64| -> Vec<u32> {
            let mut l = Lidar::new(spec.clone(), seed).expect("valid");
            let mut out = Vec::new();
            for k in 0..5 {
                out.extend(
                    l.scan(&w, Pose2::new(0.01 * k as f64, 0.0, 0.1))
                        .iter()
                        .map(|r| r.to_bits()),
                );
            }
            out
        };
        assert_eq!(bits(3), bits(3));
        assert_ne!(bits(3), bits(4));
    }

    #[test]
    fn scan_into_reuses_buffer_and_handles_bad_pose() {
        let w = room();
        let mut l = Lidar::new(LidarSpec::default(), 0).expect("valid");
        let mut buf = Vec::with_capacity(360);
        let cap = buf.capacity();
        l.scan_into(&w, Pose2::new(0.0, 0.0, 0.0), &mut buf);
        l.scan_into(&w, Pose2::new(0.0, 0.0, 0.0), &mut buf);
        assert_eq!(buf.len(), 360);
        assert_eq!(buf.capacity(), cap);
        // Facing +x from the centre: beam 180 hits x = 1.5.
        assert!((buf[180] - 1.5).abs() < 1e-6);
        l.scan_into(&w, Pose2::new(f64::NAN, 0.0, 0.0), &mut buf);
        assert_eq!(buf.len(), 360);
        assert!(buf.iter().all(|r| r.is_nan()));
    }

    #[test]
    fn matches_unculled_world_ray_cast() {
        // A moving disc and walls; the per-scan cull must not change any beam.
        let w = world(WorldSpec {
            walls: vec![wall([-3.0, 2.0], [3.0, 2.0]), wall([10.0, -1.0], [10.0, 1.0])],
            circles: vec![CircleSpec {
                center: [1.0, -1.0],
                radius_m: 0.3,
            }],
            ..WorldSpec::default()
        });
        let spec = LidarSpec::default();
        let mut l = Lidar::new(spec.clone(), 0).expect("valid");
        let pose = Pose2::new(0.2, 0.1, 0.7);
        let r = l.scan(&w, pose);
        for (i, ri) in r.iter().enumerate() {
            let a = pose.theta + spec.beam_angle_rad(i);
            let expect = w
                .ray_cast(pose.position(), Vec2::new(a.cos(), a.sin()), spec.range_max_m)
                .map_or(f32::INFINITY, |t| t as f32);
            assert!(
                (ri == &expect) || (ri - expect).abs() < 1e-5,
                "beam {i}: {ri} vs {expect}"
            );
        }
    }
}
