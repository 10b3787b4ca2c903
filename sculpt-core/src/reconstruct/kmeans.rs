//! K-means clustering of the points into patches (the generalised Lloyd algorithm,
//! Park, Yun and Lee 2000, step 1) and the patch adjacency it implies.
//!
//! Seeding is deterministic: farthest-point sampling from the point nearest the
//! centroid of all points, so the same file always gives the same patches. Each
//! iteration assigns every point to its nearest centre (a scan over the centres)
//! and moves each centre to the mean of its points; a centre left with no points is
//! moved to the point farthest from its own centre in the largest cluster. It stops when
//! no assignment changes or after `max_iterations`.

use glam::DVec3;

use super::error::ReconstructError;

/// The result of clustering.
#[derive(Debug, Clone, PartialEq)]
pub struct Clusters {
    /// The cluster of each point.
    pub labels: Vec<usize>,
    /// The centre of each cluster (the mean of its points).
    pub centres: Vec<DVec3>,
    /// Lloyd iterations run.
    pub iterations: usize,
}

impl Clusters {
    /// The number of points in each cluster.
    pub fn sizes(&self) -> Vec<usize> {
        let mut s = vec![0; self.centres.len()];
        for &l in &self.labels {
            s[l] += 1;
        }
        s
    }
}

/// The number of distinct points (bitwise equal coordinates count once).
pub fn distinct_count(points: &[DVec3]) -> usize {
    let mut keys: Vec<[u64; 3]> = points
        .iter()
        .map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
        .collect();
    keys.sort_unstable();
    keys.dedup();
    keys.len()
}

/// A point's clustering feature: its position and its normal scaled by `weight`.
type Feature = [f64; 6];

fn feature(p: DVec3, n: DVec3, weight: f64) -> Feature {
    [p.x, p.y, p.z, weight * n.x, weight * n.y, weight * n.z]
}

fn dist2(a: &Feature, b: &Feature) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// Clusters `points` into `k` patches. With `normals`, the distance also counts the
/// normals' difference scaled by `normal_weight` (metres per unit of normal change):
/// faces meeting at a crease and the two sides of a thin part then fall into different
/// patches. Errors when `k` is zero or larger than the number of distinct points.
pub fn kmeans(
    points: &[DVec3],
    normals: Option<&[DVec3]>,
    normal_weight: f64,
    k: usize,
    max_iterations: usize,
) -> Result<Clusters, ReconstructError> {
    if points.is_empty() {
        return Err(ReconstructError::NoPoints);
    }
    if k == 0 {
        return Err(ReconstructError::NoPatches);
    }
    if let Some(n) = normals
        && n.len() != points.len()
    {
        return Err(ReconstructError::NormalCount {
            points: points.len(),
            normals: n.len(),
        });
    }
    let distinct = distinct_count(points);
    if k > distinct {
        return Err(ReconstructError::TooManyPatches {
            patches: k,
            points: distinct,
        });
    }
    let features: Vec<Feature> = points
        .iter()
        .enumerate()
        .map(|(i, p)| feature(*p, normals.map_or(DVec3::ZERO, |n| n[i]), normal_weight))
        .collect();
    let mut centres = seed(&features, k);
    let mut labels = vec![usize::MAX; points.len()];
    let mut iterations = 0;
    while iterations < max_iterations {
        iterations += 1;
        let nearest = nearest_centres(&features, &centres);
        let mut changed = false;
        for (l, c) in labels.iter_mut().zip(nearest) {
            if *l != c {
                *l = c;
                changed = true;
            }
        }
        if !changed {
            break;
        }
        let mut sum = vec![[0.0; 6]; k];
        let mut count = vec![0usize; k];
        for (&l, f) in labels.iter().zip(&features) {
            sum[l].iter_mut().zip(f).for_each(|(s, x)| *s += x);
            count[l] += 1;
        }
        for c in 0..k {
            if count[c] > 0 {
                centres[c] = sum[c].map(|s| s / count[c] as f64);
            }
        }
        for c in 0..k {
            if count[c] == 0 {
                // Move the empty centre to the worst-fitting point of the largest cluster.
                let big = (0..k)
                    .max_by_key(|&i| (count[i], usize::MAX - i))
                    .unwrap_or(0);
                let far = (0..points.len())
                    .filter(|&i| labels[i] == big)
                    .max_by(|&a, &b| {
                        dist2(&features[a], &centres[big])
                            .total_cmp(&dist2(&features[b], &centres[big]))
                            .then(b.cmp(&a))
                    });
                if let Some(far) = far {
                    centres[c] = features[far];
                    labels[far] = c;
                    count[big] -= 1;
                    count[c] = 1;
                }
            }
        }
    }
    let mut sum = vec![DVec3::ZERO; k];
    let mut count = vec![0usize; k];
    for (&l, p) in labels.iter().zip(points) {
        sum[l] += *p;
        count[l] += 1;
    }
    let centres = (0..k).map(|c| sum[c] / count[c].max(1) as f64).collect();
    Ok(Clusters {
        labels,
        centres,
        iterations,
    })
}

/// The nearest centre of every feature (ties to the lower index), by brute force: a
/// 6-dimensional R*-tree over a few dozen centres was slower than scanning them (it
/// was a third of the torus's reconstruction time), and the scan runs on the rayon
/// pool with the `parallel` feature.
fn nearest_centres(features: &[Feature], centres: &[Feature]) -> Vec<usize> {
    let one = |f: &Feature| {
        let mut best = (0, f64::INFINITY);
        for (i, c) in centres.iter().enumerate() {
            let d = dist2(f, c);
            if d < best.1 {
                best = (i, d);
            }
        }
        best.0
    };
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        features.par_iter().map(one).collect()
    }
    #[cfg(not(feature = "parallel"))]
    {
        features.iter().map(one).collect()
    }
}

/// Farthest-point seeds: the point nearest the mean, then repeatedly the point
/// farthest from all seeds so far (ties to the lower index).
fn seed(features: &[Feature], k: usize) -> Vec<Feature> {
    let mut mean = [0.0; 6];
    for f in features {
        mean.iter_mut()
            .zip(f)
            .for_each(|(m, x)| *m += x / features.len() as f64);
    }
    let first = argmax(features.iter().map(|f| -dist2(f, &mean)));
    let mut seeds = vec![features[first]];
    let mut d: Vec<f64> = features.iter().map(|f| dist2(f, &seeds[0])).collect();
    while seeds.len() < k {
        let next = argmax(d.iter().copied());
        let s = features[next];
        seeds.push(s);
        for (di, f) in d.iter_mut().zip(features) {
            *di = di.min(dist2(f, &s));
        }
    }
    seeds
}

fn argmax(values: impl Iterator<Item = f64>) -> usize {
    let mut best = (0, f64::NEG_INFINITY);
    for (i, v) in values.enumerate() {
        if v > best.1 {
            best = (i, v);
        }
    }
    best.0
}

/// Makes every cluster one connected piece of the neighbour graph (`neighbours` must be
/// symmetric, see [`super::normals::symmetric`]): each cluster keeps
/// its largest piece, and the points of its other pieces join the cluster they touch
/// most (repeated until nothing moves; a piece touching nothing else stays). Returns how
/// many points moved.
pub fn make_connected(labels: &mut [usize], neighbours: &[Vec<usize>]) -> usize {
    let n = labels.len();
    let mut moved = 0;
    for _round in 0..n.max(1) {
        // Pieces: flood fill over same-label neighbours.
        let mut piece = vec![usize::MAX; n];
        let mut sizes: Vec<usize> = Vec::new();
        let mut stack = Vec::new();
        for start in 0..n {
            if piece[start] != usize::MAX {
                continue;
            }
            let id = sizes.len();
            sizes.push(0);
            piece[start] = id;
            stack.push(start);
            while let Some(i) = stack.pop() {
                sizes[id] += 1;
                for &j in &neighbours[i] {
                    if piece[j] == usize::MAX && labels[j] == labels[i] {
                        piece[j] = id;
                        stack.push(j);
                    }
                }
            }
        }
        // The largest piece of each label (ties to the first found).
        let labels_count = labels.iter().max().map_or(0, |m| m + 1);
        let mut best = vec![usize::MAX; labels_count];
        for i in 0..n {
            let (l, p) = (labels[i], piece[i]);
            if best[l] == usize::MAX || sizes[p] > sizes[best[l]] {
                best[l] = p;
            }
        }
        // Votes of each stray piece for the labels it touches.
        let mut votes: std::collections::BTreeMap<usize, Vec<(usize, usize)>> =
            std::collections::BTreeMap::new();
        for i in 0..n {
            if best[labels[i]] == piece[i] {
                continue;
            }
            let v = votes.entry(piece[i]).or_default();
            for &j in &neighbours[i] {
                if labels[j] != labels[i] {
                    match v.iter_mut().find(|e| e.0 == labels[j]) {
                        Some(e) => e.1 += 1,
                        None => v.push((labels[j], 1)),
                    }
                }
            }
        }
        let mut changed = 0;
        let target: std::collections::BTreeMap<usize, usize> = votes
            .into_iter()
            .filter_map(|(p, v)| {
                v.into_iter()
                    .max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0)))
                    .map(|(l, _)| (p, l))
            })
            .collect();
        for i in 0..n {
            if let Some(&l) = target.get(&piece[i]) {
                labels[i] = l;
                changed += 1;
            }
        }
        moved += changed;
        if changed == 0 {
            break;
        }
    }
    moved
}

/// Pairs of clusters that touch: a point and one of its neighbours carry their labels,
/// `votes` times at least (each unordered point pair counted once). Sorted `(a, b)`
/// with `a < b`, with the vote count.
pub fn adjacency(
    labels: &[usize],
    neighbours: &[Vec<usize>],
    min_votes: usize,
) -> Vec<(usize, usize, usize)> {
    let mut pairs: Vec<(usize, usize)> = Vec::new();
    for (i, list) in neighbours.iter().enumerate() {
        for &j in list {
            let (a, b) = (labels[i], labels[j]);
            if a != b && (i < j || !neighbours[j].contains(&i)) {
                pairs.push((a.min(b), a.max(b)));
            }
        }
    }
    pairs.sort_unstable();
    let mut out: Vec<(usize, usize, usize)> = Vec::new();
    for p in pairs {
        match out.last_mut() {
            Some(last) if (last.0, last.1) == p => last.2 += 1,
            _ => out.push((p.0, p.1, 1)),
        }
    }
    out.retain(|e| e.2 >= min_votes);
    out
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::reconstruct::normals::knn;

    /// Points on the six faces of the unit cube, `n x n` per face.
    pub(crate) fn cube(n: usize) -> Vec<DVec3> {
        let mut pts = Vec::new();
        for axis in 0..3 {
            for side in [-1.0, 1.0] {
                for i in 0..n {
                    for j in 0..n {
                        let a = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                        let b = -1.0 + 2.0 * (j as f64 + 0.5) / n as f64;
                        let mut p = [0.0; 3];
                        p[axis] = side;
                        p[(axis + 1) % 3] = a;
                        p[(axis + 2) % 3] = b;
                        pts.push(DVec3::from_array(p));
                    }
                }
            }
        }
        pts
    }

    #[test]
    fn cube_gives_six_face_patches_each_touching_four() {
        let pts = cube(12);
        let nn = knn(&pts, 8);
        let normals = crate::reconstruct::normals::estimate_normals(&pts, &nn);
        let c = kmeans(&pts, Some(&normals), 2.0, 6, 100).unwrap();
        // Each face is one cluster: all 144 points of a face share a label.
        for face in pts.chunks(144).zip(c.labels.chunks(144)) {
            assert!(face.1.iter().all(|&l| l == face.1[0]), "face split");
        }
        let mut sizes = c.sizes();
        sizes.sort_unstable();
        assert_eq!(sizes, vec![144; 6]);
        let adj = adjacency(&c.labels, &nn, 2);
        assert_eq!(adj.len(), 12, "a cube has 12 edges: {adj:?}");
        for p in 0..6 {
            assert_eq!(adj.iter().filter(|e| e.0 == p || e.1 == p).count(), 4);
        }
    }

    #[test]
    fn stray_pieces_join_the_cluster_they_touch() {
        // A chain 0-1-2-3-4-5 labelled a a b a b b: the lone `a` at 3 joins b, the lone
        // `b` at 2 joins a; afterwards each label is one piece.
        let neighbours: Vec<Vec<usize>> = (0..6usize)
            .map(|i| {
                [i.wrapping_sub(1), i + 1]
                    .into_iter()
                    .filter(|&j| j < 6)
                    .collect()
            })
            .collect();
        let mut labels = vec![0, 0, 1, 0, 1, 1];
        let moved = make_connected(&mut labels, &neighbours);
        assert!(moved >= 1);
        let firsts: Vec<usize> = labels
            .windows(2)
            .filter(|w| w[0] != w[1])
            .map(|w| w[0])
            .collect();
        assert_eq!(firsts.len(), 1, "{labels:?}");
    }

    #[test]
    fn clustering_is_deterministic() {
        let pts = cube(8);
        assert_eq!(
            kmeans(&pts, None, 0.0, 10, 50).unwrap(),
            kmeans(&pts, None, 0.0, 10, 50).unwrap()
        );
    }

    #[test]
    fn too_many_patches_counts_distinct_points() {
        let pts = vec![DVec3::ZERO, DVec3::ZERO, DVec3::X];
        assert_eq!(
            kmeans(&pts, None, 0.0, 3, 10),
            Err(ReconstructError::TooManyPatches {
                patches: 3,
                points: 2
            })
        );
        assert_eq!(
            kmeans(&pts, None, 0.0, 0, 10),
            Err(ReconstructError::NoPatches)
        );
        let c = kmeans(&pts, None, 0.0, 2, 10).unwrap();
        assert_ne!(c.labels[0], c.labels[2]);
        assert_eq!(c.labels[0], c.labels[1]);
    }

    #[test]
    fn every_cluster_keeps_a_point() {
        // Two tight groups and K = 5: no empty cluster survives.
        let mut pts: Vec<DVec3> = (0..50).map(|i| DVec3::X * (i as f64 / 1000.0)).collect();
        pts.extend((0..50).map(|i| DVec3::new(10.0, i as f64 / 1000.0, 0.0)));
        let c = kmeans(&pts, None, 0.0, 5, 100).unwrap();
        assert!(c.sizes().iter().all(|&s| s > 0), "{:?}", c.sizes());
    }
}
