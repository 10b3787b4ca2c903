//! Stages 1 and 2 together: normals (read or estimated) and the K patches with their
//! adjacency, as `sculpt-tools reconstruct` runs them.

use glam::DVec3;

use super::error::ReconstructError;
use super::kmeans::{Clusters, adjacency, kmeans, make_connected};
use super::normals::{estimate_normals, knn, symmetric};
use super::read::PointCloud;

/// Settings of [`segment`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentSettings {
    /// Patches K.
    pub patches: usize,
    /// Neighbours per point for normals and adjacency.
    pub neighbours: usize,
    /// Weight of normals in the clustering distance, as a fraction of the bounding-box
    /// diagonal per unit of normal change.
    pub normal_weight_rel: f64,
    /// Lloyd iterations at most.
    pub max_iterations: usize,
    /// Neighbour pairs across two patches needed to call them adjacent.
    pub min_votes: usize,
}

impl SegmentSettings {
    /// The defaults for `patches` patches.
    pub fn new(patches: usize) -> Self {
        Self {
            patches,
            neighbours: 10,
            normal_weight_rel: 0.05,
            max_iterations: 100,
            min_votes: 2,
        }
    }
}

/// Points, normals and patches.
#[derive(Debug, Clone, PartialEq)]
pub struct Segmentation {
    /// The points.
    pub points: Vec<DVec3>,
    /// A unit normal per point.
    pub normals: Vec<DVec3>,
    /// True when the normals were estimated (the file had none).
    pub normals_estimated: bool,
    /// The patches.
    pub clusters: Clusters,
    /// Adjacent patch pairs `(a, b, votes)`, `a < b`.
    pub adjacency: Vec<(usize, usize, usize)>,
    /// The `k` nearest neighbours of each point.
    pub neighbours: Vec<Vec<usize>>,
    /// Adjacent pairs left out of [`Self::adjacency`]: the two sides of a pocket at a
    /// patch the polygonal model pinched ([`super::pinch::split_pinched`]).
    pub dropped_adjacency: Vec<(usize, usize)>,
}

/// The diagonal of the axis-aligned bounding box of `points` (0 when empty).
pub fn bbox_diagonal(points: &[DVec3]) -> f64 {
    let lo = points.iter().copied().reduce(DVec3::min);
    let hi = points.iter().copied().reduce(DVec3::max);
    match (lo, hi) {
        (Some(lo), Some(hi)) => lo.distance(hi),
        _ => 0.0,
    }
}

/// Normals (the file's, normalised, or estimated by PCA and oriented), then K-means
/// patches and their adjacency. `progress` is called with a stage name as each starts.
pub fn segment(
    cloud: &PointCloud,
    settings: &SegmentSettings,
    mut progress: impl FnMut(&'static str),
) -> Result<Segmentation, ReconstructError> {
    let points = cloud.points.clone();
    if points.is_empty() {
        return Err(ReconstructError::NoPoints);
    }
    progress("neighbours");
    let neighbours = knn(&points, settings.neighbours);
    let (normals, normals_estimated) = match &cloud.normals {
        Some(n) if n.len() == points.len() => {
            let est = || estimate_normals(&points, &neighbours);
            // Zero-length normals in the file are replaced by estimates.
            let mut fallback: Option<Vec<DVec3>> = None;
            let normals = n
                .iter()
                .enumerate()
                .map(|(i, v)| {
                    v.try_normalize()
                        .unwrap_or_else(|| fallback.get_or_insert_with(est)[i])
                })
                .collect();
            (normals, false)
        }
        Some(n) => {
            return Err(ReconstructError::NormalCount {
                points: points.len(),
                normals: n.len(),
            });
        }
        None => {
            progress("normals");
            (estimate_normals(&points, &neighbours), true)
        }
    };
    progress("clustering");
    let weight = settings.normal_weight_rel * bbox_diagonal(&points);
    let mut clusters = kmeans(
        &points,
        Some(&normals),
        weight,
        settings.patches,
        settings.max_iterations,
    )?;
    make_connected(&mut clusters.labels, &symmetric(&neighbours));
    clusters.centres = centres_of(&points, &clusters.labels, settings.patches);
    progress("adjacency");
    let adjacency = adjacency(&clusters.labels, &neighbours, settings.min_votes);
    Ok(Segmentation {
        points,
        normals,
        normals_estimated,
        clusters,
        adjacency,
        neighbours,
        dropped_adjacency: Vec::new(),
    })
}

/// The mean of each cluster's points (a cluster without points keeps the origin).
fn centres_of(points: &[DVec3], labels: &[usize], k: usize) -> Vec<DVec3> {
    let mut sum = vec![DVec3::ZERO; k];
    let mut count = vec![0usize; k];
    for (&l, p) in labels.iter().zip(points) {
        sum[l] += *p;
        count[l] += 1;
    }
    sum.iter()
        .zip(&count)
        .map(|(s, &c)| *s / c.max(1) as f64)
        .collect()
}

impl Segmentation {
    /// For each patch, the number of connected pieces its points form in the
    /// (symmetric) neighbour graph (1 for a well-formed patch).
    pub fn pieces_per_patch(&self) -> Vec<usize> {
        let labels = &self.clusters.labels;
        let graph = symmetric(&self.neighbours);
        let mut seen = vec![false; self.points.len()];
        let mut pieces = vec![0; self.clusters.centres.len()];
        let mut stack = Vec::new();
        for start in 0..self.points.len() {
            if seen[start] {
                continue;
            }
            pieces[labels[start]] += 1;
            seen[start] = true;
            stack.push(start);
            while let Some(i) = stack.pop() {
                for &j in &graph[i] {
                    if !seen[j] && labels[j] == labels[i] {
                        seen[j] = true;
                        stack.push(j);
                    }
                }
            }
        }
        pieces
    }

    /// For each patch, how many patches it is adjacent to.
    pub fn degrees(&self) -> Vec<usize> {
        let mut d = vec![0; self.clusters.centres.len()];
        for &(a, b, _) in &self.adjacency {
            d[a] += 1;
            d[b] += 1;
        }
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reconstruct::sample::torus;

    #[test]
    fn torus_patches_are_connected_and_surrounded() {
        let pts = torus(4000, 0.2, 0.08, 7);
        let cloud = PointCloud {
            points: pts,
            normals: None,
        };
        let mut stages = Vec::new();
        let s = segment(&cloud, &SegmentSettings::new(30), |st| stages.push(st)).unwrap();
        assert_eq!(stages, ["neighbours", "normals", "clustering", "adjacency"]);
        assert!(s.normals_estimated);
        assert_eq!(s.pieces_per_patch(), vec![1; 30]);
        // On a closed surface every patch is surrounded: at least three neighbours.
        assert!(s.degrees().iter().all(|&d| d >= 3), "{:?}", s.degrees());
        // Estimated normals point away from the tube's core circle (outward).
        for (p, n) in s.points.iter().zip(&s.normals) {
            let core = DVec3::new(p.x, p.y, 0.0).normalize() * 0.2;
            assert!(n.dot(*p - core) > 0.0);
        }
    }

    #[test]
    fn file_normals_are_normalised_and_zero_ones_estimated() {
        let pts = torus(500, 0.2, 0.08, 1);
        let mut normals = vec![DVec3::Z * 3.0; 500];
        normals[0] = DVec3::ZERO;
        let cloud = PointCloud {
            points: pts,
            normals: Some(normals),
        };
        let s = segment(&cloud, &SegmentSettings::new(5), |_| {}).unwrap();
        assert!(!s.normals_estimated);
        assert_eq!(s.normals[1], DVec3::Z);
        assert!((s.normals[0].length() - 1.0).abs() < crate::tolerance::LOOSE_COSINE_EPS);
    }

    #[test]
    fn more_patches_than_points_is_an_error() {
        let cloud = PointCloud {
            points: vec![DVec3::ZERO, DVec3::X],
            normals: None,
        };
        assert!(matches!(
            segment(&cloud, &SegmentSettings::new(3), |_| {}),
            Err(ReconstructError::TooManyPatches { .. })
        ));
    }
}
