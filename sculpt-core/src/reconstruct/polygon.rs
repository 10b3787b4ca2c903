//! Stage 3 (combinatorics): the initial polygonal model from the patch adjacency and
//! its split into quadrilaterals.
//!
//! Patches are the vertices of the model, adjacent patches its edges, and the places
//! where three or more patches meet its faces. A point whose neighbourhood holds
//! exactly three patches votes for that triangle; triangles are accepted by votes
//! (most first) while all three edges are adjacencies and no edge gets a third face.
//! Where four or more patches meet, the triangles would need a diagonal that is no
//! adjacency, so a hole remains; each hole's boundary loop becomes one polygon face.
//!
//! Quadrilaterals: every face with `n` corners is split into `n` quads through its
//! edge midpoints and its centre (one Catmull-Clark step). This is the quad-only
//! result the paper's parity subgraphs aim at, with the same guarantee and no case
//! analysis: each quad edge is half of a model edge (shared by the two quads on either
//! side of it, one per face of that edge) or joins an edge midpoint to a face centre
//! (shared by the two quads of that face at that midpoint). So on a closed model where
//! every edge has two faces, every quad edge has exactly two quads.

use std::collections::{BTreeMap, BTreeSet};

/// A corner of a quad: a patch (model vertex), the midpoint of a model edge, or the
/// centre of a face.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum QuadCorner {
    /// A model vertex (a patch index).
    Patch(usize),
    /// The midpoint of the model edge `(a, b)`, `a < b`.
    Edge(usize, usize),
    /// The centre of face `i` of [`PolygonModel::faces`].
    Face(usize),
}

/// The polygonal model and its quads.
#[derive(Debug, Clone, PartialEq)]
pub struct PolygonModel {
    /// Faces as loops of patch indices (three or more).
    pub faces: Vec<Vec<usize>>,
    /// Quads, corners in loop order: patch, edge midpoint, face centre, edge midpoint.
    pub quads: Vec<[QuadCorner; 4]>,
}

fn edge(a: usize, b: usize) -> (usize, usize) {
    (a.min(b), a.max(b))
}

/// Builds the model from point `labels`, the (directed) `neighbours` of each point and
/// the `adjacency` pairs.
pub fn polygon_model(
    labels: &[usize],
    neighbours: &[Vec<usize>],
    adjacency: &[(usize, usize, usize)],
) -> PolygonModel {
    let adjacent: BTreeSet<(usize, usize)> = adjacency.iter().map(|e| (e.0, e.1)).collect();
    let mut votes: BTreeMap<[usize; 3], usize> = BTreeMap::new();
    for (i, list) in neighbours.iter().enumerate() {
        let mut set: Vec<usize> = std::iter::once(labels[i])
            .chain(list.iter().map(|&j| labels[j]))
            .collect();
        set.sort_unstable();
        set.dedup();
        if let [a, b, c] = set[..] {
            *votes.entry([a, b, c]).or_default() += 1;
        }
    }
    let mut ranked: Vec<([usize; 3], usize)> = votes.into_iter().collect();
    ranked.sort_by(|x, y| y.1.cmp(&x.1).then(x.0.cmp(&y.0)));
    let mut uses: BTreeMap<(usize, usize), usize> = BTreeMap::new();
    let mut faces: Vec<Vec<usize>> = Vec::new();
    for ([a, b, c], _) in ranked {
        let edges = [edge(a, b), edge(b, c), edge(a, c)];
        if edges
            .iter()
            .all(|e| adjacent.contains(e) && uses.get(e).copied().unwrap_or(0) < 2)
        {
            for e in edges {
                *uses.entry(e).or_default() += 1;
            }
            faces.push(vec![a, b, c]);
        }
    }
    // Holes: edges with fewer than two faces, split into loops.
    let open: BTreeSet<(usize, usize)> = adjacent
        .iter()
        .copied()
        .filter(|e| uses.get(e).copied().unwrap_or(0) == 1)
        .collect();
    faces.extend(hole_loops(&open));
    let mut quads = Vec::new();
    for (f, face) in faces.iter().enumerate() {
        let n = face.len();
        for k in 0..n {
            let (prev, v, next) = (face[(k + n - 1) % n], face[k], face[(k + 1) % n]);
            let e1 = edge(v, next);
            let e0 = edge(prev, v);
            quads.push([
                QuadCorner::Patch(v),
                QuadCorner::Edge(e1.0, e1.1),
                QuadCorner::Face(f),
                QuadCorner::Edge(e0.0, e0.1),
            ]);
        }
    }
    merge_two_quad_fans(&mut quads);
    PolygonModel { faces, quads }
}

/// Removes the corners that only two quads surround (a fan of two quads: both hold the
/// two sides leaving the corner, which happens where two faces share two edges at a
/// patch, a pocket). Two quads round a point cannot both span less than 180 degrees
/// there, so one of them turns over; merged into one quad without that corner
/// (`[v, a, x, b]` and `[v, b, y, a]` become `[a, x, b, y]`), the fold is gone. The
/// merge leaves every other side as it was and the Euler characteristic unchanged
/// (one corner, two sides and one quad fewer).
fn merge_two_quad_fans(quads: &mut Vec<[QuadCorner; 4]>) {
    loop {
        // For each corner, the quads at it with the two corners beside it.
        let mut at: BTreeMap<QuadCorner, Vec<(usize, [QuadCorner; 2])>> = BTreeMap::new();
        for (qi, q) in quads.iter().enumerate() {
            for k in 0..4 {
                let mut beside = [q[(k + 1) % 4], q[(k + 3) % 4]];
                beside.sort();
                at.entry(q[k]).or_default().push((qi, beside));
            }
        }
        let turn = |q: [QuadCorner; 4], v: QuadCorner| {
            let k = q.iter().position(|c| *c == v).unwrap_or(0);
            [q[k], q[(k + 1) % 4], q[(k + 2) % 4], q[(k + 3) % 4]]
        };
        // The first such pair whose far corners differ (two quads closing on each
        // other, a pillow, have nothing to merge into).
        let pair = at.iter().find_map(|(v, uses)| {
            uses.iter().enumerate().find_map(|(i, (qa, sides))| {
                uses[i + 1..].iter().find_map(|(qb, other)| {
                    let [_, a, x, b] = turn(quads[*qa], *v);
                    let [_, _, y, _] = turn(quads[*qb], *v);
                    (other == sides && x != y).then_some((*qa, *qb, [a, x, b, y]))
                })
            })
        });
        let Some((qa, qb, merged)) = pair else {
            return;
        };
        quads[qa] = merged;
        quads.remove(qb);
    }
}

/// Splits the open `edges` (each `(a, b)` with `a < b`) into loops, each edge in at
/// most one: for each edge in order, the shortest way back from its far end to its
/// near end over the edges not yet taken (breadth first, lowest vertex first) closes
/// its loop. Where loops touch (a vertex with four or more open edges) the shortest way
/// stays on the edge's own loop, so touching holes become separate faces; an edge with
/// no way back stays open.
pub fn hole_loops(edges: &BTreeSet<(usize, usize)>) -> Vec<Vec<usize>> {
    let mut graph: BTreeMap<usize, BTreeSet<usize>> = BTreeMap::new();
    for &(a, b) in edges {
        graph.entry(a).or_default().insert(b);
        graph.entry(b).or_default().insert(a);
    }
    let mut loops = Vec::new();
    for &(a, b) in edges {
        if !graph.get(&a).is_some_and(|l| l.contains(&b)) {
            continue; // Taken by an earlier loop.
        }
        // Breadth-first from b to a, not over the edge (a, b) itself.
        let mut came_from: BTreeMap<usize, usize> = BTreeMap::from([(b, b)]);
        let mut frontier = std::collections::VecDeque::from([b]);
        while let Some(v) = frontier.pop_front() {
            if v == a {
                break;
            }
            for &w in &graph[&v] {
                if (v, w) == (b, a) || came_from.contains_key(&w) {
                    continue;
                }
                came_from.insert(w, v);
                frontier.push_back(w);
            }
        }
        if !came_from.contains_key(&a) {
            continue;
        }
        // The loop: a, then the way back reversed (b ... the vertex before a).
        let mut lp = vec![a];
        let mut v = came_from[&a];
        while v != b {
            lp.push(v);
            v = came_from[&v];
        }
        lp.push(b);
        lp[1..].reverse();
        for k in 0..lp.len() {
            let (x, y) = (lp[k], lp[(k + 1) % lp.len()]);
            for (p, q) in [(x, y), (y, x)] {
                if let Some(l) = graph.get_mut(&p) {
                    l.remove(&q);
                }
            }
        }
        loops.push(lp);
    }
    loops
}

impl PolygonModel {
    /// How many quads hold each quad edge (corner pairs, unordered).
    pub fn quad_edge_uses(&self) -> BTreeMap<(QuadCorner, QuadCorner), usize> {
        let mut m = BTreeMap::new();
        for q in &self.quads {
            for k in 0..4 {
                let (a, b) = (q[k], q[(k + 1) % 4]);
                *m.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        m
    }

    /// How many faces hold each model edge.
    pub fn edge_uses(&self) -> BTreeMap<(usize, usize), usize> {
        let mut m = BTreeMap::new();
        for f in &self.faces {
            for k in 0..f.len() {
                *m.entry(edge(f[k], f[(k + 1) % f.len()])).or_default() += 1;
            }
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reconstruct::kmeans::tests::cube;
    use crate::reconstruct::read::PointCloud;
    use crate::reconstruct::sample::torus;
    use crate::reconstruct::segment::{SegmentSettings, segment};

    /// Regression (the kitten's patch 24, a pocket where two faces share two edges):
    /// the two quads round the patch's corner there turned over, a 180-degree fold.
    #[test]
    fn a_fan_of_two_quads_is_merged_into_one_quad() {
        use QuadCorner::{Edge as E, Face as F, Patch as P};
        // Faces 0 = [0, 1, 2, 3] and 1 = [0, 3, 4, 1] share the edges (0, 1) and
        // (0, 3) at patch 0; four quads round patch 2 (an ordinary corner) stay.
        let fan = vec![
            [P(0), E(0, 1), F(0), E(0, 3)],
            [P(0), E(0, 3), F(1), E(0, 1)],
            [P(2), E(2, 3), F(0), E(1, 2)],
            [P(2), E(1, 2), F(2), E(2, 5)],
            [P(2), E(2, 5), F(3), E(2, 6)],
            [P(2), E(2, 6), F(4), E(2, 3)],
        ];
        let mut quads = fan.clone();
        merge_two_quad_fans(&mut quads);
        assert_eq!(quads.len(), fan.len() - 1);
        assert_eq!(quads[0], [E(0, 1), F(0), E(0, 3), F(1)]);
        assert_eq!(&quads[1..], &fan[2..]);
        assert!(quads.iter().flatten().all(|c| *c != P(0)));
        // Two quads closing on each other (the same far corner) are left.
        let pillow = vec![
            [P(0), E(0, 1), F(0), E(0, 3)],
            [P(0), E(0, 3), F(0), E(0, 1)],
        ];
        let mut same = pillow.clone();
        merge_two_quad_fans(&mut same);
        assert_eq!(same, pillow);
    }

    fn model_of(points: Vec<glam::DVec3>, k: usize) -> (PolygonModel, usize) {
        let cloud = PointCloud {
            points,
            normals: None,
        };
        let s = segment(&cloud, &SegmentSettings::new(k), |_| {}).unwrap();
        (
            polygon_model(&s.clusters.labels, &s.neighbours, &s.adjacency),
            s.adjacency.len(),
        )
    }

    #[test]
    fn cube_model_is_an_octahedron_and_24_quads() {
        // Six face patches meet three at a time at the cube's corners: 8 triangles.
        let (m, edges) = model_of(cube(12), 6);
        assert_eq!(edges, 12);
        assert_eq!(m.faces.len(), 8, "{:?}", m.faces);
        assert!(m.faces.iter().all(|f| f.len() == 3));
        assert_eq!(m.quads.len(), 24);
        assert!(m.edge_uses().values().all(|&u| u == 2));
        assert!(m.quad_edge_uses().values().all(|&u| u == 2));
    }

    /// Regression (the kitten at K = 50 and 60 kept 8 open model edges): two hole loops
    /// that touch at a vertex were skipped, because the walk stopped at any vertex with
    /// more than two open edges. They become two faces now.
    #[test]
    fn touching_hole_loops_become_separate_faces() {
        // A square 0-1-2-3 and a triangle 3-4-5, touching at 3; and a dangling edge 6-7.
        let edges: BTreeSet<(usize, usize)> = [
            (0, 1),
            (1, 2),
            (2, 3),
            (0, 3),
            (3, 4),
            (4, 5),
            (3, 5),
            (6, 7),
        ]
        .into_iter()
        .collect();
        let mut loops = hole_loops(&edges);
        for l in &mut loops {
            let i = l
                .iter()
                .position(|&v| v == *l.iter().min().unwrap())
                .unwrap();
            l.rotate_left(i);
        }
        assert_eq!(loops, vec![vec![0, 1, 2, 3], vec![3, 4, 5]]);
        // A single loop comes out whole, each edge once.
        let ring: BTreeSet<(usize, usize)> = [(0, 1), (1, 2), (2, 3), (3, 4), (0, 4)]
            .into_iter()
            .collect();
        assert_eq!(hole_loops(&ring), vec![vec![0, 1, 2, 3, 4]]);
    }

    #[test]
    fn torus_model_is_closed_with_euler_characteristic_zero() {
        let (m, edges) = model_of(torus(4000, 0.2, 0.08, 7), 30);
        let uses = m.edge_uses();
        assert_eq!(uses.len(), edges, "every adjacency is a model edge");
        assert!(uses.values().all(|&u| u == 2), "{uses:?}");
        // V - E + F = 0 on a torus.
        assert_eq!(30 + m.faces.len(), edges);
        // Every quad edge is shared by exactly two quads.
        assert!(m.quad_edge_uses().values().all(|&u| u == 2));
    }
}
