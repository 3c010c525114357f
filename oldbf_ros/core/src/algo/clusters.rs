//! Scan points → clusters (ALGORITHM.md §6): runs of consecutive valid beams
//! (up to [`BRIDGED_BEAMS`] lost returns between two of them) whose points
//! are closer than `cluster_gap_m` to their neighbour. Each
//! cluster is summarised by a circle: the centroid of its points and the
//! largest distance from it (m), and by where the centre of the round object
//! it sees probably is (behind the centroid: [`Cluster::centre`]), where the
//! tracker puts a mover's disc. The robot is not added here; the collision
//! cone adds r.
//!
//! On a full 360° scan the last and the first beam are neighbours, so a
//! cluster spanning the scan's seam is one cluster, not two.

use super::geometry::{max_distance_squared, min_distance_squared, Vec2};

/// Beams without a point (a return lost: `+inf` for one scan, a dropout)
/// that may lie between two neighbours of a cluster, when the two points are
/// still within the gap: a wall with a lost return is one wall, not two
/// short pieces whose centroids jump as the loss moves along it (which the
/// tracker would take for movers).
pub const BRIDGED_BEAMS: u32 = 2;

/// One cluster: points `start..end` of the scan's valid points (in beam
/// order; when it wraps round the seam, `start > end` and it is
/// `start..len` followed by `0..end`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cluster {
    /// Index of its first point.
    pub start: usize,
    /// One past its last point (wraps: see above).
    pub end: usize,
    /// Number of points.
    pub len: usize,
    /// Centroid of the points, robot frame (m).
    pub centroid: Vec2,
    /// Largest distance from the centroid to a point (m).
    pub radius_m: f64,
    /// Where the centre of the round object it sees probably is (robot frame,
    /// m): on the centroid's bearing, `radius_m` beyond the nearest point.
    /// The centroid of the visible arc of a disc of radius R lies about
    /// 0.7 R nearer the robot than the disc's centre, so a disc round
    /// the centroid reaches that much nearer the robot than the person does.
    pub centre: Vec2,
    /// Maybe only part of what it sees (cut off by the range limit, or
    /// hidden at an end by something nearer): its centroid slides as the
    /// view changes, so it may keep a track alive but neither starts one nor
    /// proves that one moves.
    pub partial: bool,
}

impl Cluster {
    /// The indices of its points.
    pub fn indices(&self, n_points: usize) -> impl Iterator<Item = usize> {
        let (a, b) = if self.start < self.end {
            (self.start..self.end, 0..0)
        } else {
            (self.start..n_points, 0..self.end)
        };
        a.chain(b)
    }
}

/// Clusters of one scan, rebuilt every scan in a reused buffer.
#[derive(Debug, Default, Clone)]
pub struct Clusters {
    clusters: Vec<Cluster>,
}

impl Clusters {
    /// Room for the clusters of a scan of `max_points` points without reallocating.
    pub fn with_capacity(max_points: usize) -> Self {
        Self {
            clusters: Vec::with_capacity(max_points),
        }
    }

    /// The clusters of the last scan, in beam order.
    pub fn as_slice(&self) -> &[Cluster] {
        &self.clusters
    }

    /// How many clusters the last scan had.
    pub fn len(&self) -> usize {
        self.clusters.len()
    }

    /// The last scan had no cluster (no valid point).
    pub fn is_empty(&self) -> bool {
        self.clusters.is_empty()
    }

    /// No clusters (a scan whose clusters nobody needs).
    pub fn clear(&mut self) {
        self.clusters.clear();
    }

    /// Marks cluster `k` as no measurement of anything (its point count set to
    /// 0, so the tracker never takes it as a candidate); its points stay.
    pub fn exclude(&mut self, k: usize) {
        self.clusters[k].len = 0;
    }

    /// Marks cluster `k` as maybe only part of what it sees ([`Cluster::partial`]).
    pub fn mark_partial(&mut self, k: usize) {
        self.clusters[k].partial = true;
    }

    /// Maps every cluster's centroid and centre by `f` (the points moved into
    /// another robot frame).
    pub fn map_points(&mut self, f: impl Fn(Vec2) -> Vec2) {
        for c in &mut self.clusters {
            c.centroid = f(c.centroid);
            c.centre = f(c.centre);
        }
    }

    /// Moves cluster `k`'s centroid and centre by `shift` (m).
    pub fn shift(&mut self, k: usize, shift: Vec2) {
        let c = &mut self.clusters[k];
        c.centroid += shift;
        c.centre += shift;
    }

    /// Rebuilds the clusters of `points` (robot frame, beam order) whose beam
    /// indices are `beam_index`, out of a scan of `beams` beams;
    /// `full_circle` tells whether beam `beams − 1` neighbours beam 0.
    pub fn build(&mut self, points: &[Vec2], beam_index: &[u32], beams: usize, full_circle: bool, gap_m: f64) {
        self.clusters.clear();
        self.clusters.reserve(points.len());
        let n = points.len();
        if n == 0 {
            return;
        }
        let gap2 = gap_m * gap_m;
        let joined = |i: usize, j: usize| (points[j] - points[i]).norm_squared() <= gap2;
        // Points i and i + 1 of each pair are neighbours when their beams are and
        // they are close enough; a cluster ends at every pair that is not.
        let mut start = 0;
        for (i, (p, b)) in points.windows(2).zip(beam_index.windows(2)).enumerate() {
            let neighbours = b[1] <= b[0] + 1 + BRIDGED_BEAMS && (p[1] - p[0]).norm_squared() <= gap2;
            if !neighbours {
                self.clusters.push(summarise(points, start, i + 1, n));
                start = i + 1;
            }
        }
        self.clusters.push(summarise(points, start, n, n));
        // The seam of a 360° scan: beam beams−1 next to beam 0.
        if full_circle && self.clusters.len() > 1 {
            let first = self.clusters[0];
            let last = *self.clusters.last().expect("more than one cluster");
            let adjacent = beam_index[0] == 0 && beam_index[n - 1] as usize == beams - 1;
            if adjacent && joined(n - 1, 0) {
                self.clusters.pop();
                self.clusters[0] = summarise(points, last.start, first.end, n);
            }
        }
    }
}

/// The circle summary of points `start..end` (wrapping when start ≥ end).
fn summarise(points: &[Vec2], start: usize, end: usize, n: usize) -> Cluster {
    // The points as one or two slices, in index order.
    let (head, tail) = if start < end {
        (&points[start..end], &points[..0])
    } else {
        (&points[start..n], &points[..end])
    };
    let sum = head.iter().chain(tail).fold(Vec2::zeros(), |sum, p| sum + p);
    let len = head.len() + tail.len();
    let centroid = sum / len as f64;
    // The largest distance is the root of the largest squared distance (the
    // square root is monotonic and correctly rounded): one root per cluster.
    let max2 = max_distance_squared(head, centroid).max(max_distance_squared(tail, centroid));
    let radius_m = max2.sqrt();
    // Pushed back along the centroid's bearing; never pulled in, as ‖centroid‖ ≤
    // nearest + radius (the triangle inequality through the nearest point).
    let near2 = min_distance_squared(head, Vec2::zeros()).min(min_distance_squared(tail, Vec2::zeros()));
    let (d, depth) = (centroid.norm(), near2.sqrt() + radius_m);
    let centre = if d > 0.0 && depth > d {
        centroid * (depth / d)
    } else {
        centroid
    };
    Cluster {
        start,
        end,
        len,
        centroid,
        radius_m,
        centre,
        partial: false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64) -> Vec2 {
        Vec2::new(x, y)
    }

    #[test]
    fn splits_on_distance_and_on_missing_beams() {
        // Beams 0-2 close together, beam 3 far away, beams 5-6 after a missing beam 4.
        let pts = [
            v(1.0, 0.0),
            v(1.0, 0.05),
            v(1.0, 0.1),
            v(3.0, 0.0),
            v(1.0, 0.3),
            v(1.0, 0.35),
        ];
        let idx = [0, 1, 2, 3, 5, 6];
        let mut c = Clusters::default();
        c.build(&pts, &idx, 360, false, 0.15);
        let runs: Vec<(usize, usize)> = c.as_slice().iter().map(|k| (k.start, k.end)).collect();
        assert_eq!(runs, [(0, 3), (3, 4), (4, 6)]);
        let first = c.as_slice()[0];
        assert!((first.centroid - v(1.0, 0.05)).norm() < 1e-12);
        assert!((first.radius_m - 0.05).abs() < 1e-12);
        assert_eq!(c.as_slice()[1].radius_m, 0.0);
    }

    #[test]
    fn a_cluster_across_the_seam_of_a_full_scan_is_one() {
        // Beams 0, 1 and 358, 359 of a 360-beam scan all near (1, 0).
        let pts = [v(1.0, 0.02), v(1.0, 0.05), v(2.0, 2.0), v(1.0, -0.05), v(1.0, -0.02)];
        let idx = [0, 1, 100, 358, 359];
        let mut c = Clusters::default();
        c.build(&pts, &idx, 360, true, 0.15);
        assert_eq!(c.len(), 2);
        let seam = c.as_slice()[0];
        assert_eq!((seam.start, seam.end, seam.len), (3, 2, 4));
        assert!(seam.centroid.y.abs() < 1e-12 && (seam.centroid.x - 1.0).abs() < 1e-12);
        assert_eq!(seam.indices(5).collect::<Vec<_>>(), [3, 4, 0, 1]);
        // Not a full circle: two clusters there.
        c.build(&pts, &idx, 360, false, 0.15);
        assert_eq!(c.len(), 3);
    }

    #[test]
    fn a_round_object_is_centred_behind_the_arc_it_shows() {
        // A disc of radius 0.2 m centred 1 m ahead, seen by beams 1° apart from the
        // origin: beams −11°..11° hit its near side, at t = cos φ − √(0.2² − sin² φ).
        let pts: Vec<Vec2> = (-11..=11)
            .map(|k| {
                let f = (k as f64).to_radians();
                let t = f.cos() - (0.04 - f.sin().powi(2)).sqrt();
                v(t * f.cos(), t * f.sin())
            })
            .collect();
        let idx: Vec<u32> = (0..23).collect();
        let mut c = Clusters::default();
        c.build(&pts, &idx, 360, false, 0.15);
        let k = c.as_slice()[0];
        // By hand (23 points): centroid x = 0.8298, largest distance from it 0.1912 m,
        // nearest point 0.8 m. The centroid is 0.17 m (0.85 R) nearer than the centre;
        // the estimate is 0.8 + 0.1912 = 0.9912 m out, 9 mm short of it.
        assert!((k.centroid - v(0.829_84, 0.0)).norm() < 1e-4, "{k:?}");
        assert!((k.radius_m - 0.191_16).abs() < 1e-4, "{k:?}");
        assert!((k.centre - v(0.991_16, 0.0)).norm() < 1e-4, "{k:?}");
        // Its disc's near edge is the nearest point, not 0.17 m in front of it.
        assert!((k.centre.norm() - k.radius_m - 0.8).abs() < 1e-12);
        // A lone point is its own centre.
        c.build(&[v(0.5, 0.5)], &[0], 360, false, 0.15);
        let k = c.as_slice()[0];
        assert_eq!((k.centre, k.radius_m), (v(0.5, 0.5), 0.0));
    }

    #[test]
    fn empty_scan_has_no_clusters() {
        let mut c = Clusters::default();
        c.build(&[], &[], 360, true, 0.15);
        assert!(c.is_empty());
    }
}
