//! Patches the polygonal model pinches, split round the thin part they wrap.
//!
//! A patch is a vertex of the polygonal model ([`super::polygon`]); on a closed surface
//! the faces round it form one fan, a disc. Where a patch wraps a thin part (a tube
//! such as the kitten's tail), its points form a ring and the faces round it form two
//! fans, one at each end of the ring, which meet only at the patch: the model, its
//! quads and the meshed network are pinched there (one vertex joining two sheets, the
//! Euler characteristic one off), and the quads of the smaller fan turn over (folds).
//!
//! [`split_pinched`] cuts every such patch into three sectors round the axis of the
//! ring (the line from the middle of one fan's rim to the middle of the other's): three
//! patches round a tube meet three at a time where their sides reach the rims, so the
//! model holds the tube as a tube, with the genus of the scan. A split is kept only when
//! the model it gives has fewer pinched patches and no more open edges.

use glam::DVec3;

use super::kmeans::{adjacency, make_connected};
use super::normals::symmetric;
use super::polygon::{PolygonModel, polygon_model};
use super::segment::Segmentation;

/// Sectors a pinched patch is cut into: three is the fewest that meet three at a time
/// round a tube (two would meet along two separate lines, with no face between them).
pub const SECTORS: usize = 3;

/// Rounds of splitting at most (each split may pinch a neighbour in turn).
const ROUNDS: usize = 4;

/// The fans of faces round `patch` in `model`: the faces holding it, grouped by the
/// connected pieces of its link (two faces are in one fan when they share a model edge
/// at the patch). One fan for a patch inside a closed surface; two or more where it is
/// pinched. Each fan is a list of face indices.
pub fn fans(model: &PolygonModel, patch: usize) -> Vec<Vec<usize>> {
    // Each face at the patch joins the two patches beside it there.
    let mut link: Vec<(usize, [usize; 2])> = Vec::new();
    for (f, face) in model.faces.iter().enumerate() {
        let n = face.len();
        for k in 0..n {
            if face[k] == patch {
                link.push((f, [face[(k + n - 1) % n], face[(k + 1) % n]]));
            }
        }
    }
    // Union-find over the link entries: two entries sharing a neighbour are one fan.
    let mut parent: Vec<usize> = (0..link.len()).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for a in 0..link.len() {
        for b in a + 1..link.len() {
            if link[a].1.iter().any(|v| link[b].1.contains(v)) {
                let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
                parent[ra] = rb;
            }
        }
    }
    let mut groups: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for (i, (face, _)) in link.iter().enumerate() {
        let r = root(&mut parent, i);
        groups.entry(r).or_default().push(*face);
    }
    groups.into_values().collect()
}

/// The patches of `model` (of `patches` in all) whose faces form two or more fans.
pub fn pinched(model: &PolygonModel, patches: usize) -> Vec<usize> {
    (0..patches).filter(|&v| fans(model, v).len() > 1).collect()
}

/// Model edges (adjacent pairs) not held by exactly two faces.
fn open_edges(model: &PolygonModel, seg: &Segmentation) -> usize {
    let uses = model.edge_uses();
    seg.adjacency
        .iter()
        .filter(|e| uses.get(&(e.0, e.1)) != Some(&2))
        .count()
}

/// Splits the patches the polygonal model pinches (see the module docs) until none is
/// left, a split does not help, or after a few rounds; returns the split patches (each
/// keeps its index for one sector, the others are appended) and updates the labels,
/// centres and adjacency of `seg` (`min_votes` as for [`adjacency`]).
pub fn split_pinched(seg: &mut Segmentation, min_votes: usize) -> Vec<usize> {
    let graph = symmetric(&seg.neighbours);
    let mut split = Vec::new();
    for _ in 0..ROUNDS {
        let model = polygon_model(&seg.clusters.labels, &seg.neighbours, &seg.adjacency);
        let count = seg.clusters.centres.len();
        let pinches = pinched(&model, count);
        if pinches.is_empty() {
            break;
        }
        let mut labels = seg.clusters.labels.clone();
        let mut next = count;
        let mut pocket_edges: Vec<(usize, usize)> = Vec::new();
        for &v in &pinches {
            if let Some(edges) = pocket(&model, v) {
                pocket_edges.extend(edges);
                continue;
            }
            let Some(axis) = ring_axis(&model, seg, v) else {
                continue;
            };
            for (s, sector) in sectors(seg, v, axis).into_iter().enumerate().skip(1) {
                for i in sector {
                    labels[i] = next + s - 1;
                }
            }
            next += SECTORS - 1;
        }
        make_connected(&mut labels, &graph);
        let mut candidate = relabelled(seg, labels, next, min_votes);
        let mut dropped = seg.dropped_adjacency.clone();
        dropped.extend(pocket_edges);
        dropped.sort_unstable();
        dropped.dedup();
        candidate
            .adjacency
            .retain(|e| dropped.binary_search(&(e.0, e.1)).is_err());
        candidate.dropped_adjacency = dropped;
        let model_after = polygon_model(
            &candidate.clusters.labels,
            &candidate.neighbours,
            &candidate.adjacency,
        );
        let better = pinched(&model_after, next).len() < pinches.len()
            && open_edges(&model_after, &candidate) <= open_edges(&model, seg);
        if !better {
            break;
        }
        *seg = candidate;
        split.extend(pinches);
    }
    split
}

/// The two model edges at patch `v` of a pocket, if `v` has one: a fan of two faces
/// that share both their edges at `v` (a triangle `[v, a, b]` accepted by votes and
/// the hole face that runs `a, v, b` round it). The two faces are one face with `v`
/// inside it, held by two sides only; without those two adjacencies the model closes
/// over it (`(a, b)` pairs, smaller first).
fn pocket(model: &PolygonModel, v: usize) -> Option<[(usize, usize); 2]> {
    fans(model, v).into_iter().find_map(|fan| {
        let [f, g] = fan[..] else {
            return None;
        };
        let at = |face: &Vec<usize>| {
            let n = face.len();
            let k = face.iter().position(|&p| p == v)?;
            let mut pair = [face[(k + n - 1) % n], face[(k + 1) % n]];
            pair.sort_unstable();
            Some(pair)
        };
        let (a, b) = (at(&model.faces[f])?, at(&model.faces[g])?);
        (a == b).then(|| a.map(|w| (v.min(w), v.max(w))))
    })
}

/// The axis of the ring patch `v` forms: from the mean centre of the rim patches of its
/// largest fan to that of its second largest (`None` when it has one fan or the rims'
/// middles coincide).
fn ring_axis(model: &PolygonModel, seg: &Segmentation, v: usize) -> Option<DVec3> {
    let mut fans = fans(model, v);
    fans.sort_by_key(|f| std::cmp::Reverse(f.len()));
    let rim_middle = |fan: &Vec<usize>| {
        let mut rim: Vec<usize> = fan
            .iter()
            .flat_map(|&f| model.faces[f].iter().copied())
            .filter(|&p| p != v)
            .collect();
        rim.sort_unstable();
        rim.dedup();
        let sum: DVec3 = rim.iter().map(|&p| seg.clusters.centres[p]).sum();
        sum / rim.len().max(1) as f64
    };
    let (a, b) = (fans.first()?, fans.get(1)?);
    (rim_middle(b) - rim_middle(a)).try_normalize()
}

/// The points of patch `v` cut into [`SECTORS`] arcs of equal counts by their angle
/// round `axis` through the patch's centre, the arcs starting after the widest empty
/// angle (so a ring that is not closed is cut along its length, not across its gap).
fn sectors(seg: &Segmentation, v: usize, axis: DVec3) -> Vec<Vec<usize>> {
    let centre = seg.clusters.centres[v];
    let (e1, e2) = axis.any_orthonormal_pair();
    let mut by_angle: Vec<(f64, usize)> = seg
        .clusters
        .labels
        .iter()
        .enumerate()
        .filter(|(_, l)| **l == v)
        .map(|(i, _)| {
            let d = seg.points[i] - centre;
            (d.dot(e2).atan2(d.dot(e1)), i)
        })
        .collect();
    by_angle.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let n = by_angle.len();
    if n < SECTORS {
        return vec![by_angle.into_iter().map(|(_, i)| i).collect()];
    }
    // The widest gap between angles next to each other (round the circle).
    let gap = |k: usize| {
        let (a, b) = (by_angle[k].0, by_angle[(k + 1) % n].0);
        if k + 1 == n {
            b + std::f64::consts::TAU - a
        } else {
            b - a
        }
    };
    let widest = (0..n)
        .max_by(|&x, &y| gap(x).total_cmp(&gap(y)))
        .unwrap_or(0);
    by_angle.rotate_left((widest + 1) % n);
    (0..SECTORS)
        .map(|s| {
            by_angle[s * n / SECTORS..(s + 1) * n / SECTORS]
                .iter()
                .map(|&(_, i)| i)
                .collect()
        })
        .collect()
}

/// `seg` with new `labels` over `count` patches: centres and adjacency recomputed.
fn relabelled(
    seg: &Segmentation,
    labels: Vec<usize>,
    count: usize,
    min_votes: usize,
) -> Segmentation {
    let mut sum = vec![DVec3::ZERO; count];
    let mut n = vec![0usize; count];
    for (&l, p) in labels.iter().zip(&seg.points) {
        sum[l] += *p;
        n[l] += 1;
    }
    let mut out = seg.clone();
    out.clusters.centres = sum
        .iter()
        .zip(&n)
        .map(|(s, &c)| *s / c.max(1) as f64)
        .collect();
    out.adjacency = adjacency(&labels, &seg.neighbours, min_votes);
    out.clusters.labels = labels;
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reconstruct::kmeans::Clusters;

    fn model(faces: &[&[usize]]) -> PolygonModel {
        PolygonModel {
            faces: faces.iter().map(|f| f.to_vec()).collect(),
            quads: Vec::new(),
        }
    }

    #[test]
    fn a_patch_between_two_cones_has_two_fans() {
        // Patch 0 is the apex of two cones (1, 2, 3) and (4, 5, 6) meeting only there.
        let m = model(&[
            &[0, 1, 2],
            &[0, 2, 3],
            &[0, 3, 1],
            &[0, 4, 5],
            &[0, 5, 6],
            &[0, 6, 4],
        ]);
        let mut f = fans(&m, 0);
        f.sort();
        assert_eq!(f, vec![vec![0, 1, 2], vec![3, 4, 5]]);
        assert_eq!(fans(&m, 1).len(), 1);
        assert_eq!(pinched(&m, 7), vec![0]);
        // Neither cone is a pocket: each fan has three faces.
        assert_eq!(pocket(&m, 0), None);
    }

    /// Regression (the kitten at K = 80, patches 24 and then 80): a triangle `[v, a,
    /// b]` and a hole face running `a, v, b` were a fan of two faces at `v`, so `v`
    /// pinched the model there and its two quads turned over.
    #[test]
    fn a_triangle_and_a_hole_face_sharing_two_sides_are_a_pocket() {
        let m = model(&[
            &[0, 1, 2],
            &[2, 0, 1, 3],
            &[0, 4, 5],
            &[0, 5, 6],
            &[0, 6, 4],
        ]);
        assert_eq!(fans(&m, 0).len(), 2);
        assert_eq!(pocket(&m, 0), Some([(0, 1), (0, 2)]));
        assert_eq!(pocket(&m, 4), None);
    }

    #[test]
    fn a_ring_is_cut_into_three_arcs_round_its_axis() {
        // A short tube round z: 4 rings of 30 points, one patch.
        let points: Vec<DVec3> = (0..120)
            .map(|i| {
                let a = (i % 30) as f64 / 30.0 * std::f64::consts::TAU;
                DVec3::new(a.cos(), a.sin(), (i / 30) as f64 * 0.2)
            })
            .collect();
        let mean = points.iter().sum::<DVec3>() / points.len() as f64;
        let seg = Segmentation {
            normals: points.iter().map(|p| DVec3::new(p.x, p.y, 0.0)).collect(),
            points,
            normals_estimated: false,
            clusters: Clusters {
                labels: vec![0; 120],
                centres: vec![mean],
                iterations: 0,
            },
            adjacency: Vec::new(),
            neighbours: vec![Vec::new(); 120],
            dropped_adjacency: Vec::new(),
        };
        let arcs = sectors(&seg, 0, DVec3::Z);
        assert_eq!(arcs.len(), SECTORS);
        for arc in &arcs {
            assert_eq!(arc.len(), 40);
            // Every point of an arc lies within 60 degrees (and a step) of its middle
            // direction round the axis: the arc is a third of the ring, along its length.
            let middle = arc
                .iter()
                .map(|&i| DVec3::new(seg.points[i].x, seg.points[i].y, 0.0))
                .sum::<DVec3>()
                .normalize();
            for &i in arc {
                let p = seg.points[i];
                assert!(DVec3::new(p.x, p.y, 0.0).dot(middle) > 0.4, "{p}");
            }
        }
    }
}
