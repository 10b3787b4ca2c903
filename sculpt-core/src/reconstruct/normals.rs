//! Neighbourhoods and normals of unorganised points: k nearest neighbours from an
//! R*-tree (`rstar`), normals by PCA over each neighbourhood, oriented consistently by
//! propagation along a minimum spanning tree of the neighbour graph (Hoppe et al.
//! 1992): the edge weight is `1 - |n_i . n_j|`, so orientation crosses flat regions
//! first and sharp creases last.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use glam::DVec3;
use nalgebra::{Matrix3, SymmetricEigen};
use rstar::RTree;
use rstar::primitives::GeomWithData;

use crate::tolerance::NORMALISABLE_LEN;

/// A point in the R*-tree, with its index.
pub type IndexedPoint = GeomWithData<[f64; 3], usize>;

/// An R*-tree over `points` (each with its index).
pub fn point_tree(points: &[DVec3]) -> RTree<IndexedPoint> {
    RTree::bulk_load(
        points
            .iter()
            .enumerate()
            .map(|(i, p)| GeomWithData::new(p.to_array(), i))
            .collect(),
    )
}

/// The `k` nearest neighbours of every point (itself excluded), nearest first.
pub fn knn(points: &[DVec3], k: usize) -> Vec<Vec<usize>> {
    let tree = point_tree(points);
    let one = |i: usize| -> Vec<usize> {
        tree.nearest_neighbor_iter(&points[i].to_array())
            .map(|g| g.data)
            .filter(|&j| j != i)
            .take(k)
            .collect()
    };
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        (0..points.len()).into_par_iter().map(one).collect()
    }
    #[cfg(not(feature = "parallel"))]
    {
        (0..points.len()).map(one).collect()
    }
}

/// The unit normal of the least-squares plane through `p` and its neighbours (the
/// eigenvector of the smallest eigenvalue of their covariance); `+z` when the
/// neighbourhood is degenerate (all points equal).
pub fn pca_normal(points: &[DVec3], centre: usize, neighbours: &[usize]) -> DVec3 {
    let all = || std::iter::once(centre).chain(neighbours.iter().copied());
    let n = (neighbours.len() + 1) as f64;
    let mean = all().map(|i| points[i]).sum::<DVec3>() / n;
    let mut cov = Matrix3::<f64>::zeros();
    for i in all() {
        let d = points[i] - mean;
        let d = nalgebra::Vector3::new(d.x, d.y, d.z);
        cov += d * d.transpose();
    }
    let eig = SymmetricEigen::new(cov);
    let k = eig.eigenvalues.imin();
    let v = eig.eigenvectors.column(k);
    let v = DVec3::new(v[0], v[1], v[2]);
    if v.length() > NORMALISABLE_LEN && v.is_finite() {
        v.normalize()
    } else {
        DVec3::Z
    }
}

/// The neighbour graph made symmetric: `j` lists `i` whenever `i` lists `j` (sorted,
/// without repeats).
pub fn symmetric(neighbours: &[Vec<usize>]) -> Vec<Vec<usize>> {
    let mut graph: Vec<Vec<usize>> = neighbours.to_vec();
    for (i, list) in neighbours.iter().enumerate() {
        for &j in list {
            graph[j].push(i);
        }
    }
    for list in &mut graph {
        list.sort_unstable();
        list.dedup();
    }
    graph
}

#[derive(PartialEq)]
struct Edge {
    weight: f64,
    from: usize,
    to: usize,
}

impl Eq for Edge {}

impl Ord for Edge {
    fn cmp(&self, other: &Self) -> Ordering {
        // Min-heap on weight, ties by index for determinism.
        other
            .weight
            .total_cmp(&self.weight)
            .then_with(|| other.to.cmp(&self.to))
            .then_with(|| other.from.cmp(&self.from))
    }
}

impl PartialOrd for Edge {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// Flips `normals` so that neighbours agree: Prim's minimum spanning tree over the
/// symmetric neighbour graph, from the highest point of each connected part (its normal
/// turned to `+z`, outward on a closed object), flipping each new normal to agree with
/// its tree parent.
pub fn orient(points: &[DVec3], normals: &mut [DVec3], neighbours: &[Vec<usize>]) {
    let n = points.len();
    let graph = symmetric(neighbours);
    let mut done = vec![false; n];
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| points[b].z.total_cmp(&points[a].z).then(a.cmp(&b)));
    let mut heap = BinaryHeap::new();
    for &seed in &order {
        if done[seed] {
            continue;
        }
        if normals[seed].z < 0.0 {
            normals[seed] = -normals[seed];
        }
        done[seed] = true;
        let push = |heap: &mut BinaryHeap<Edge>, normals: &[DVec3], i: usize| {
            for &j in &graph[i] {
                heap.push(Edge {
                    weight: 1.0 - normals[i].dot(normals[j]).abs(),
                    from: i,
                    to: j,
                });
            }
        };
        push(&mut heap, normals, seed);
        while let Some(Edge { from, to, .. }) = heap.pop() {
            if done[to] {
                continue;
            }
            done[to] = true;
            if normals[to].dot(normals[from]) < 0.0 {
                normals[to] = -normals[to];
            }
            push(&mut heap, normals, to);
        }
    }
}

/// Unit normals for `points` by PCA over `neighbours`, consistently oriented.
pub fn estimate_normals(points: &[DVec3], neighbours: &[Vec<usize>]) -> Vec<DVec3> {
    let mut normals: Vec<DVec3> = (0..points.len())
        .map(|i| pca_normal(points, i, &neighbours[i]))
        .collect();
    orient(points, &mut normals, neighbours);
    normals
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::tolerance::LOOSE_COSINE_EPS;

    /// Points on a sphere of radius 1 (a Fibonacci lattice).
    pub(crate) fn sphere(n: usize) -> Vec<DVec3> {
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        (0..n)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                let r = (1.0 - z * z).sqrt();
                let t = golden * i as f64;
                DVec3::new(r * t.cos(), r * t.sin(), z)
            })
            .collect()
    }

    #[test]
    fn knn_finds_the_nearest_on_a_line() {
        let pts: Vec<DVec3> = (0..10).map(|i| DVec3::X * f64::from(i)).collect();
        let nn = knn(&pts, 2);
        assert_eq!(nn[0], vec![1, 2]);
        assert_eq!(nn[5].len(), 2);
        assert!(nn[5].contains(&4) && nn[5].contains(&6));
    }

    #[test]
    fn plane_normals_are_z() {
        let pts: Vec<DVec3> = (0..100)
            .map(|i| DVec3::new(f64::from(i % 10), f64::from(i / 10), 0.0))
            .collect();
        let nn = knn(&pts, 8);
        for n in estimate_normals(&pts, &nn) {
            assert_near!(n, DVec3::Z, LOOSE_COSINE_EPS);
        }
    }

    #[test]
    fn sphere_normals_point_outward() {
        let pts = sphere(2000);
        let nn = knn(&pts, 10);
        let normals = estimate_normals(&pts, &nn);
        for (p, n) in pts.iter().zip(&normals) {
            // Outward and close to radial (the lattice is fine enough for 0.99).
            assert!(n.dot(*p) > 0.99, "p {p} n {n}");
        }
    }

    #[test]
    fn duplicate_points_give_a_finite_normal() {
        let pts = vec![DVec3::ONE; 5];
        let nn = knn(&pts, 4);
        assert!(estimate_normals(&pts, &nn).iter().all(|n| n.is_finite()));
    }
}
