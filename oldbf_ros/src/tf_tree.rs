//! A small tf buffer: the transforms heard on `/tf_static` and `/tf`, and
//! the transform between two frames at a stamp (tf2's `lookupTransform`,
//! for what the node needs: where a scan's frame sits in the base frame).
//!
//! Pure: the ROS glue feeds it `tf2_msgs/TFMessage` contents; tests feed it
//! by hand. Frames are named as tf2 names them, a leading `/` ignored. Each
//! child frame has one parent (a tree, as tf requires); a transform that
//! would close a loop, or give a frame a second parent, replaces the edge,
//! as tf2 does, and a lookup that walks into a loop fails instead of hanging.
//!
//! Static transforms hold forever. A dynamic edge keeps its last
//! [`HISTORY`] samples; a lookup inside their span interpolates (linear in
//! translation, slerp in rotation), and outside it takes the nearest end
//! only within the caller's tolerance, else the edge is stale: a laser
//! pose that may have changed since is not known.

use crate::algo::LaserMount;
use crate::node_core::{LaserPoseSource, PoseFault};
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use std::collections::{HashMap, VecDeque};
use std::fmt;

/// Samples kept per dynamic edge (at 50 Hz, 0.64 s of history).
pub const HISTORY: usize = 32;
/// Longest parent chain walked (frames): a deeper tree is a loop or garbage.
const MAX_DEPTH: usize = 64;

/// Why a transform cannot be given.
#[derive(Debug, Clone, PartialEq)]
pub enum TfError {
    /// No transform names this frame (as child or parent).
    UnknownFrame { frame: String },
    /// Both frames are known, but in trees that do not connect.
    NotConnected { target: String, source: String },
    /// The edge `parent → child` has no sample within the tolerance of the
    /// stamp: the nearest is `age_s` away (s).
    Stale { parent: String, child: String, age_s: f64 },
    /// The parent chain from this frame does not end (a loop).
    Loop { frame: String },
}

impl fmt::Display for TfError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::UnknownFrame { frame } => write!(f, "no transform names frame \"{frame}\" on /tf or /tf_static"),
            Self::NotConnected { target, source } => {
                write!(f, "frames \"{source}\" and \"{target}\" are not connected by tf")
            }
            Self::Stale { parent, child, age_s } => write!(
                f,
                "the transform \"{parent}\" → \"{child}\" is {age_s:.3} s away from the scan's stamp"
            ),
            Self::Loop { frame } => write!(f, "tf's parent chain from \"{frame}\" loops"),
        }
    }
}

impl std::error::Error for TfError {}

/// Why a transform message was not taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refused {
    /// A frame name is empty, or parent and child are the same frame.
    BadFrames,
    /// A component is not finite, or the quaternion is far from unit length.
    BadTransform,
}

#[derive(Debug, Clone)]
struct Edge {
    parent: String,
    /// From `/tf_static`: one sample, valid at every stamp.
    fixed: bool,
    /// (stamp (s), the child frame in the parent frame), oldest first.
    samples: VecDeque<(f64, Isometry3<f64>)>,
}

/// The transforms heard so far, by child frame.
#[derive(Debug, Clone, Default)]
pub struct TfTree {
    edges: HashMap<String, Edge>,
}

/// A frame name as tf2 keys it (no leading `/`).
fn frame(name: &str) -> &str {
    name.trim_start_matches('/')
}

impl TfTree {
    /// Takes one transform: `child` in `parent` at `stamp_s`, translation (m)
    /// and rotation (quaternion x, y, z, w). `fixed`: from `/tf_static`.
    pub fn set(
        &mut self,
        parent: &str,
        child: &str,
        stamp_s: f64,
        translation_m: [f64; 3],
        rotation_xyzw: [f64; 4],
        fixed: bool,
    ) -> Result<(), Refused> {
        let (parent, child) = (frame(parent), frame(child));
        if parent.is_empty() || child.is_empty() || parent == child {
            return Err(Refused::BadFrames);
        }
        let finite = translation_m.iter().chain(&rotation_xyzw).all(|v| v.is_finite());
        let [x, y, z, w] = rotation_xyzw;
        let norm = (x * x + y * y + z * z + w * w).sqrt();
        if !finite || (norm - 1.0).abs() > 0.01 || (!fixed && !stamp_s.is_finite()) {
            return Err(Refused::BadTransform);
        }
        let iso = Isometry3::from_parts(
            Translation3::new(translation_m[0], translation_m[1], translation_m[2]),
            UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z)),
        );
        let edge = self.edges.entry(child.to_string()).or_insert_with(|| Edge {
            parent: parent.to_string(),
            fixed,
            samples: VecDeque::with_capacity(HISTORY),
        });
        // A new parent, or static turned dynamic or back: the old history no longer applies.
        if edge.parent != parent || edge.fixed != fixed {
            edge.parent = parent.to_string();
            edge.fixed = fixed;
            edge.samples.clear();
        }
        if fixed {
            edge.samples.clear();
            edge.samples.push_back((stamp_s, iso));
            return Ok(());
        }
        // Kept in stamp order; an older stamp than the newest is slotted in.
        let at = edge.samples.partition_point(|(s, _)| *s <= stamp_s);
        if at > 0 && edge.samples[at - 1].0 == stamp_s {
            edge.samples[at - 1].1 = iso;
        } else {
            edge.samples.insert(at, (stamp_s, iso));
        }
        if edge.samples.len() > HISTORY {
            edge.samples.pop_front();
        }
        Ok(())
    }

    /// Whether any transform names `name` (as child or parent).
    pub fn knows(&self, name: &str) -> bool {
        let name = frame(name);
        self.edges.contains_key(name) || self.edges.values().any(|e| e.parent == name)
    }

    /// The `source` frame in the `target` frame at `stamp_s` (tf2's
    /// `lookupTransform(target, source, stamp)`): a point `p` in `source` is
    /// `iso * p` in `target`. Dynamic edges must have a sample within
    /// `tolerance_s` of the stamp, or span it.
    pub fn lookup(
        &self,
        target: &str,
        source: &str,
        stamp_s: f64,
        tolerance_s: f64,
    ) -> Result<Isometry3<f64>, TfError> {
        let (target, source) = (frame(target), frame(source));
        if target == source {
            return Ok(Isometry3::identity());
        }
        for f in [target, source] {
            if !self.knows(f) {
                return Err(TfError::UnknownFrame { frame: f.to_string() });
            }
        }
        let up_from_source = self.chain(source, stamp_s, tolerance_s)?;
        let up_from_target = self.chain(target, stamp_s, tolerance_s)?;
        // The lowest common ancestor: only the edges below it count.
        for (f, target_in) in &up_from_target {
            if let Some((_, source_in)) = up_from_source.iter().find(|(g, _)| g == f) {
                return Ok(target_in.clone()?.inverse() * source_in.clone()?);
            }
        }
        Err(TfError::NotConnected {
            target: target.to_string(),
            source: source.to_string(),
        })
    }

    /// `from` and each of its ancestors, with `from` in that frame (an
    /// error from the first edge that could not be sampled on up).
    #[allow(clippy::type_complexity)]
    fn chain<'a>(
        &'a self,
        from: &'a str,
        stamp_s: f64,
        tolerance_s: f64,
    ) -> Result<Vec<(&'a str, Result<Isometry3<f64>, TfError>)>, TfError> {
        let mut up = vec![(from, Ok(Isometry3::identity()))];
        let mut f = from;
        while let Some(edge) = self.edges.get(f) {
            if up.len() > MAX_DEPTH {
                return Err(TfError::Loop {
                    frame: from.to_string(),
                });
            }
            let below = up
                .last()
                .map(|(_, iso)| iso.clone())
                .unwrap_or(Ok(Isometry3::identity()));
            let here = below.and_then(|b| Ok(self.sample(f, edge, stamp_s, tolerance_s)? * b));
            f = edge.parent.as_str();
            up.push((f, here));
        }
        Ok(up)
    }

    /// The edge's transform at `stamp_s`.
    fn sample(&self, child: &str, edge: &Edge, stamp_s: f64, tolerance_s: f64) -> Result<Isometry3<f64>, TfError> {
        let stale = |age_s: f64| TfError::Stale {
            parent: edge.parent.clone(),
            child: child.to_string(),
            age_s,
        };
        let (Some(first), Some(last)) = (edge.samples.front(), edge.samples.back()) else {
            return Err(stale(f64::INFINITY));
        };
        if edge.fixed {
            return Ok(first.1);
        }
        if stamp_s <= first.0 {
            let age_s = first.0 - stamp_s;
            return if age_s <= tolerance_s {
                Ok(first.1)
            } else {
                Err(stale(age_s))
            };
        }
        if stamp_s >= last.0 {
            let age_s = stamp_s - last.0;
            return if age_s <= tolerance_s {
                Ok(last.1)
            } else {
                Err(stale(age_s))
            };
        }
        let at = edge.samples.partition_point(|(s, _)| *s <= stamp_s);
        let ((s0, a), (s1, b)) = (edge.samples[at - 1], edge.samples[at]);
        let t = (stamp_s - s0) / (s1 - s0);
        Ok(a.lerp_slerp(&b, t))
    }
}

/// Where the laser of a scan from `laser_frame` sits in `base_frame` at
/// `stamp_s`, by `source`: Ok(None) to keep the YAML mount the pipeline
/// has (`yaml`), Ok(Some) a mount to set, or why there is none, with a line
/// naming both frames (for the log and diagnostics).
pub fn place_laser(
    tree: &TfTree,
    source: LaserPoseSource,
    base_frame: &str,
    laser_frame: &str,
    stamp_s: f64,
    tolerance_s: f64,
) -> Result<Option<LaserMount>, (PoseFault, String)> {
    let unknown_to_tf = !tree.knows(laser_frame) && frame(laser_frame) != frame(base_frame);
    match source {
        LaserPoseSource::Yaml => return Ok(None),
        LaserPoseSource::TfElseYaml if unknown_to_tf => return Ok(None),
        _ => {}
    }
    let frames = format!("\"{}\" -> \"{}\"", frame(laser_frame), frame(base_frame));
    let iso = tree
        .lookup(base_frame, laser_frame, stamp_s, tolerance_s)
        .map_err(|e| {
            let fault = match e {
                TfError::Stale { age_s, .. } => PoseFault::Stale { age_s },
                _ => PoseFault::NoTransform,
            };
            (fault, format!("{frames}: {e}"))
        })?;
    let t = iso.translation.vector;
    let q = iso.rotation.quaternion().coords; // (x, y, z, w)
    LaserMount::from_transform([t.x, t.y, t.z], [q.x, q.y, q.z, q.w])
        .map(Some)
        .map_err(|e| (PoseFault::Mount(e), format!("{frames}: {e}")))
}

/// One line on a laser mount: where it is and which way up.
pub fn describe_mount(m: &LaserMount) -> String {
    format!(
        "x {:.3} m, y {:.3} m, yaw {:.1}°, {}",
        m.pose.x,
        m.pose.y,
        m.pose.theta.to_degrees(),
        if m.mirrored { "upside down" } else { "upright" }
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Point3, Vector3};
    use std::f64::consts::PI;

    const ID: [f64; 4] = [0.0, 0.0, 0.0, 1.0];

    fn yaw(a: f64) -> [f64; 4] {
        [0.0, 0.0, (a / 2.0).sin(), (a / 2.0).cos()]
    }

    fn at(iso: Isometry3<f64>, p: [f64; 3]) -> [f64; 3] {
        let q = iso * Point3::new(p[0], p[1], p[2]);
        [q.x, q.y, q.z]
    }

    fn near(a: [f64; 3], b: [f64; 3]) -> bool {
        (Vector3::from(a) - Vector3::from(b)).norm() < 1e-9
    }

    /// base_footprint → base_link (z 0.1) → laser (x 0.2, yaw 90°), all static.
    fn robot() -> TfTree {
        let mut t = TfTree::default();
        t.set("base_footprint", "base_link", 0.0, [0.0, 0.0, 0.1], ID, true)
            .unwrap();
        t.set("/base_link", "laser", 0.0, [0.2, 0.0, 0.3], yaw(PI / 2.0), true)
            .unwrap();
        t
    }

    #[test]
    fn a_chain_composes_down_and_across() {
        let t = robot();
        // A point 1 m along the laser's x axis is 1 m to the robot's left of the laser.
        let iso = t.lookup("base_footprint", "laser", 5.0, 0.1).unwrap();
        assert!(near(at(iso, [1.0, 0.0, 0.0]), [0.2, 1.0, 0.4]));
        // The other way round is its inverse.
        let back = t.lookup("laser", "base_footprint", 5.0, 0.1).unwrap();
        assert!(near(at(back, [0.2, 1.0, 0.4]), [1.0, 0.0, 0.0]));
        // Across the tree: a second sensor beside the first.
        let mut t = t;
        t.set("base_link", "rear", 0.0, [-0.2, 0.0, 0.3], yaw(PI), true)
            .unwrap();
        let iso = t.lookup("rear", "laser", 0.0, 0.1).unwrap();
        // The laser's origin is 0.4 m ahead of the rear sensor: −0.4 m along its x.
        assert!(near(at(iso, [0.0, 0.0, 0.0]), [-0.4, 0.0, 0.0]));
        assert_eq!(t.lookup("laser", "laser", 0.0, 0.0), Ok(Isometry3::identity()));
    }

    #[test]
    fn unknown_and_unconnected_frames_are_named() {
        let mut t = robot();
        assert_eq!(
            t.lookup("base_link", "front_laser", 0.0, 0.1),
            Err(TfError::UnknownFrame {
                frame: "front_laser".into()
            })
        );
        t.set("map", "elsewhere", 0.0, [1.0, 0.0, 0.0], ID, true).unwrap();
        assert_eq!(
            t.lookup("base_link", "elsewhere", 0.0, 0.1),
            Err(TfError::NotConnected {
                target: "base_link".into(),
                source: "elsewhere".into()
            })
        );
    }

    #[test]
    fn dynamic_edges_interpolate_inside_and_go_stale_outside() {
        let mut t = TfTree::default();
        t.set("base_link", "laser", 10.0, [0.0, 0.0, 0.0], ID, false).unwrap();
        t.set("base_link", "laser", 11.0, [1.0, 0.0, 0.0], yaw(PI / 2.0), false)
            .unwrap();
        // Halfway: 0.5 m and 45°.
        let iso = t.lookup("base_link", "laser", 10.5, 0.1).unwrap();
        let c = (PI / 4.0).cos();
        assert!(near(at(iso, [1.0, 0.0, 0.0]), [0.5 + c, c, 0.0]));
        // Within the tolerance past the newest: the newest.
        let iso = t.lookup("base_link", "laser", 11.05, 0.1).unwrap();
        assert!(near(at(iso, [0.0, 0.0, 0.0]), [1.0, 0.0, 0.0]));
        // Beyond it: stale, by how much.
        match t.lookup("base_link", "laser", 11.5, 0.1) {
            Err(TfError::Stale { parent, child, age_s }) => {
                assert_eq!((parent.as_str(), child.as_str()), ("base_link", "laser"));
                assert!((age_s - 0.5).abs() < 1e-9);
            }
            other => panic!("{other:?}"),
        }
        // A static edge never goes stale; a stale edge above the common
        // ancestor does not matter, one below it does.
        let mut t = robot();
        assert!(t.lookup("base_link", "laser", 1e6, 0.0).is_ok());
        t.set("odom", "base_footprint", 0.0, [0.0; 3], ID, false).unwrap();
        assert!(t.lookup("base_link", "laser", 100.0, 0.1).is_ok());
        assert!(matches!(
            t.lookup("odom", "laser", 100.0, 0.1),
            Err(TfError::Stale { .. })
        ));
    }

    #[test]
    fn the_history_is_bounded_and_ordered() {
        let mut t = TfTree::default();
        for i in (0..100).rev() {
            t.set("a", "b", f64::from(i), [f64::from(i), 0.0, 0.0], ID, false)
                .unwrap();
        }
        // Arriving newest first, the oldest kept are dropped as they come: only HISTORY stay.
        assert_eq!(t.edges["b"].samples.len(), HISTORY);
        assert!(t.edges["b"]
            .samples
            .iter()
            .zip(t.edges["b"].samples.iter().skip(1))
            .all(|(a, b)| a.0 < b.0));
    }

    #[test]
    fn a_laser_is_placed_by_tf_or_by_yaml_as_configured() {
        use LaserPoseSource::*;
        let mut t = robot();
        // Rolled over under the deck, 0.1 m behind the base's origin.
        t.set(
            "base_link",
            "belly",
            0.0,
            [-0.1, 0.0, -0.05],
            [1.0, 0.0, 0.0, 0.0],
            true,
        )
        .unwrap();
        let m = place_laser(&t, Tf, "base_footprint", "laser", 3.0, 0.1)
            .unwrap()
            .unwrap();
        assert!((m.pose.x, m.pose.y, m.mirrored) == (0.2, 0.0, false) && (m.pose.theta - PI / 2.0).abs() < 1e-12);
        let m = place_laser(&t, Tf, "base_link", "belly", 3.0, 0.1).unwrap().unwrap();
        assert!((m.pose.x, m.pose.y, m.mirrored) == (-0.1, 0.0, true) && m.pose.theta.abs() < 1e-12);
        assert_eq!(describe_mount(&m), "x -0.100 m, y 0.000 m, yaw 0.0°, upside down");
        // A frame tf never named: unknown under tf, the YAML mount under tf_else_yaml, and yaml never asks.
        let (fault, line) = place_laser(&t, Tf, "base_link", "front_laser", 3.0, 0.1).unwrap_err();
        assert_eq!(fault, PoseFault::NoTransform);
        assert!(
            line.starts_with("\"front_laser\" -> \"base_link\": no transform names"),
            "{line}"
        );
        assert_eq!(
            place_laser(&t, TfElseYaml, "base_link", "front_laser", 3.0, 0.1),
            Ok(None)
        );
        assert_eq!(place_laser(&t, Yaml, "base_link", "belly", 3.0, 0.1), Ok(None));
        // Known to tf but stale: unknown even under tf_else_yaml.
        t.set("base_link", "pan", 1.0, [0.0; 3], ID, false).unwrap();
        let (fault, _) = place_laser(&t, TfElseYaml, "base_link", "pan", 3.0, 0.1).unwrap_err();
        assert!(matches!(fault, PoseFault::Stale { age_s } if (age_s - 2.0).abs() < 1e-9));
        // Tilted 20° down: not a planar scan.
        let pitch = [0.0, (0.35f64 / 2.0).sin(), 0.0, (0.35f64 / 2.0).cos()];
        t.set("base_link", "tilted", 0.0, [0.0; 3], pitch, true).unwrap();
        let (fault, _) = place_laser(&t, Tf, "base_link", "tilted", 3.0, 0.1).unwrap_err();
        assert!(matches!(
            fault,
            PoseFault::Mount(crate::algo::MountError::Tilted { .. })
        ));
        // A scan in the base frame itself needs no transform.
        assert_eq!(
            place_laser(&TfTree::default(), Tf, "base_link", "/base_link", 3.0, 0.1),
            Ok(Some(LaserMount::upright(crate::algo::Pose2::default())))
        );
    }

    #[test]
    fn loops_and_garbage_are_refused_not_hung() {
        let mut t = TfTree::default();
        t.set("a", "b", 0.0, [0.0; 3], ID, true).unwrap();
        t.set("b", "c", 0.0, [0.0; 3], ID, true).unwrap();
        t.set("c", "a", 0.0, [0.0; 3], ID, true).unwrap();
        assert!(matches!(
            t.lookup("x", "a", 0.0, 0.1),
            Err(TfError::UnknownFrame { .. })
        ));
        // A frame hanging off the loop: its parent chain never ends.
        t.set("c", "x", 0.0, [0.0; 3], ID, true).unwrap();
        t.set("root", "y", 0.0, [0.0; 3], ID, true).unwrap();
        assert!(matches!(t.lookup("y", "x", 0.0, 0.1), Err(TfError::Loop { .. })));
        // Re-parenting breaks the loop (tf2: the newest parent wins).
        t.set("root", "a", 0.0, [0.0; 3], ID, true).unwrap();
        assert!(t.lookup("y", "x", 0.0, 0.1).is_ok());
        assert_eq!(t.set("a", "a", 0.0, [0.0; 3], ID, true), Err(Refused::BadFrames));
        assert_eq!(t.set("", "a", 0.0, [0.0; 3], ID, true), Err(Refused::BadFrames));
        assert_eq!(
            t.set("a", "d", 0.0, [f64::NAN, 0.0, 0.0], ID, true),
            Err(Refused::BadTransform)
        );
        assert_eq!(
            t.set("a", "d", 0.0, [0.0; 3], [0.0, 0.0, 0.0, 0.0], true),
            Err(Refused::BadTransform)
        );
    }
}
