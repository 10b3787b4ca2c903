//! A sparse grid of blocks, meshed block by block and welded into one watertight mesh.
//!
//! The solid's box is a regular grid of cubic cells, cut into blocks of [`BLOCK`]
//! cells per axis. Each block samples the corners of its own cells, including those on
//! its faces: a corner is computed from its integer grid index alone (its position
//! `lo + index h`, rounded to f32 once, and the same field), so two blocks sharing a
//! face read the same values there, bit for bit. Each cube is split into the six
//! tetrahedra of its Kuhn triangulation (all along the cube's `0 -> 7` diagonal, so
//! neighbouring cubes, in the same block or not, split their common faces alike), and
//! marching tetrahedra (Doi and Koide 1991) cut the zero set out of each. A vertex lies
//! on a grid edge and is named by that edge's two corner indices; its position is
//! computed from the edge's two values in a fixed order. Welding by that name joins the
//! blocks' pieces with no crack: the mesh is closed and 2-manifold wherever the blocks
//! meet, and a block can be re-meshed alone when the field changes inside its box.
//!
//! Like [`crate::implicit::contour`], corners on the grid's outer layer count as
//! outside (a solid leaving its box is closed at the box), a value of 0 or NaN counts as
//! outside, and vertices keep [`CONTOUR_EDGE_T_MIN`] of an edge from its ends.

use std::collections::HashMap;

use glam::DVec3;

use crate::mesh::{MeshVertex, WeldedMesh};
use crate::tolerance::CONTOUR_EDGE_T_MIN;

/// Cells per block edge.
pub const BLOCK: usize = 16;

/// Triangles of one block: vertices named by their grid edge, triangles as indices
/// into them, wound outward.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BlockMesh {
    /// `(edge key, position)` of each vertex.
    pub vertices: Vec<(u64, [f32; 3])>,
    /// Triangles (indices into `vertices`).
    pub triangles: Vec<[u32; 3]>,
}

/// The regular grid over a solid's box.
#[derive(Debug, Clone, PartialEq)]
pub struct GridFrame {
    /// The box's low corner (metres).
    pub lo: DVec3,
    /// Cell edge (metres).
    pub h: f64,
    /// Cells per axis.
    pub n: [usize; 3],
}

impl GridFrame {
    /// Blocks per axis.
    pub fn blocks(&self) -> [usize; 3] {
        self.n.map(|k| k.div_ceil(BLOCK))
    }

    /// The position of corner `c` as the field reads it.
    pub fn corner(&self, c: [usize; 3]) -> [f32; 3] {
        [0, 1, 2].map(|a| (self.lo[a] + c[a] as f64 * self.h) as f32)
    }

    /// The corner index range `[lo, hi]` (inclusive) of block `b`.
    pub fn block_corners(&self, b: [usize; 3]) -> ([usize; 3], [usize; 3]) {
        let lo = b.map(|k| k * BLOCK);
        let hi = [0, 1, 2].map(|a| (lo[a] + BLOCK).min(self.n[a]));
        (lo, hi)
    }

    /// The blocks whose boxes meet the box `lo..hi` (metres): `(first, last)` inclusive
    /// per axis, or `None` when it misses the grid.
    pub fn blocks_in(&self, lo: DVec3, hi: DVec3) -> Option<([usize; 3], [usize; 3])> {
        let nb = self.blocks();
        let mut first = [0; 3];
        let mut last = [0; 3];
        for a in 0..3 {
            let top = self.n[a] as f64 * self.h;
            let (l, u) = (lo[a] - self.lo[a], hi[a] - self.lo[a]);
            if u < 0.0 || l > top {
                return None;
            }
            let cell = |x: f64| ((x / self.h).floor().max(0.0) as usize).min(self.n[a] - 1);
            first[a] = cell(l) / BLOCK;
            last[a] = (cell(u) / BLOCK).min(nb[a] - 1);
        }
        Some((first, last))
    }

    /// Global id of a corner.
    fn corner_id(&self, c: [usize; 3]) -> u64 {
        let (cx, cy) = ((self.n[0] + 1) as u64, (self.n[1] + 1) as u64);
        c[0] as u64 + cx * (c[1] as u64 + cy * c[2] as u64)
    }

    /// Whether a corner is on the grid's outer layer.
    fn on_boundary(&self, c: [usize; 3]) -> bool {
        (0..3).any(|a| c[a] == 0 || c[a] == self.n[a])
    }

    /// Marching tetrahedra over block `b`, whose corner values (positive inside, x
    /// fastest over the block's corner range) are `values`.
    pub fn march(&self, b: [usize; 3], values: &[f32], table: &TetTable) -> BlockMesh {
        let (lo, hi) = self.block_corners(b);
        let m = [0, 1, 2].map(|a| hi[a] - lo[a] + 1);
        let outside = -(self.h as f32);
        let at = |c: [usize; 3]| -> f32 {
            let v = values[(c[0] - lo[0]) + m[0] * ((c[1] - lo[1]) + m[1] * (c[2] - lo[2]))];
            // NaN and the outer layer are outside (zero is, by the test below).
            if v.is_nan() || (v > 0.0 && self.on_boundary(c)) {
                outside
            } else {
                v
            }
        };
        let mut mesh = BlockMesh::default();
        let mut local: HashMap<u64, u32> = HashMap::new();
        let total = self.corner_id(self.n) + 1;
        for k in lo[2]..hi[2] {
            for j in lo[1]..hi[1] {
                for i in lo[0]..hi[0] {
                    let mut cs = [[0usize; 3]; 8];
                    let mut vals = [0f32; 8];
                    let mut mask = 0usize;
                    for (bit, (c, val)) in cs.iter_mut().zip(vals.iter_mut()).enumerate() {
                        *c = [i + (bit & 1), j + ((bit >> 1) & 1), k + ((bit >> 2) & 1)];
                        *val = at(*c);
                        if *val > 0.0 {
                            mask |= 1 << bit;
                        }
                    }
                    if mask == 0 || mask == 0xff {
                        continue;
                    }
                    for (t, tet) in KUHN.iter().enumerate() {
                        let tmask = (0..4).fold(0, |acc, q| acc | (((mask >> tet[q]) & 1) << q));
                        for tri in &table.cases[t * 16 + tmask] {
                            let mut out = [0u32; 3];
                            for (slot, &(qa, qb)) in out.iter_mut().zip(tri) {
                                let (ca, cb) = (tet[qa], tet[qb]);
                                let (ia, ib) = (self.corner_id(cs[ca]), self.corner_id(cs[cb]));
                                // The lower id first: the same arithmetic in every block.
                                let (ca, cb, ia, ib) = if ia < ib {
                                    (ca, cb, ia, ib)
                                } else {
                                    (cb, ca, ib, ia)
                                };
                                let key = ia * total + ib;
                                *slot = *local.entry(key).or_insert_with(|| {
                                    let (va, vb) = (f64::from(vals[ca]), f64::from(vals[cb]));
                                    let s = (va / (va - vb))
                                        .clamp(CONTOUR_EDGE_T_MIN, 1.0 - CONTOUR_EDGE_T_MIN);
                                    let (pa, pb) = (self.corner(cs[ca]), self.corner(cs[cb]));
                                    let p = [0, 1, 2].map(|a| {
                                        (f64::from(pa[a])
                                            + s * (f64::from(pb[a]) - f64::from(pa[a])))
                                            as f32
                                    });
                                    mesh.vertices.push((key, p));
                                    (mesh.vertices.len() - 1) as u32
                                });
                            }
                            mesh.triangles.push(out);
                        }
                    }
                }
            }
        }
        mesh
    }
}

/// The six tetrahedra of the Kuhn triangulation of a cube, as corner bit masks (x = 1,
/// y = 2, z = 4): `0, e_a, e_a + e_b, 7` for each order `(a, b, c)` of the axes.
const KUHN: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 1, 5, 7],
    [0, 2, 3, 7],
    [0, 2, 6, 7],
    [0, 4, 5, 7],
    [0, 4, 6, 7],
];

/// For each tetrahedron of `KUHN` and each set of inside corners (4 bits), the
/// triangles of the zero set as pairs of tetrahedron corners (one pair per vertex, the
/// edge it lies on), wound so that the normal points from the inside corners to the
/// outside ones.
#[derive(Debug, Clone)]
pub struct TetTable {
    cases: Vec<Vec<[(usize, usize); 3]>>,
}

impl Default for TetTable {
    fn default() -> Self {
        Self::new()
    }
}

impl TetTable {
    /// Builds the table. The winding is decided geometrically: at the edges' midpoints
    /// the triangle's normal must point along the step from the inside corners' centroid
    /// to the outside ones' (moving vertices along their edges never flips it: the
    /// tetrahedron a triangle spans with an inside corner keeps its sign).
    pub fn new() -> Self {
        let corner =
            |b: usize| DVec3::new((b & 1) as f64, ((b >> 1) & 1) as f64, ((b >> 2) & 1) as f64);
        let mut cases = Vec::with_capacity(6 * 16);
        for tet in KUHN {
            for mask in 0..16usize {
                let ins: Vec<usize> = (0..4).filter(|q| mask >> q & 1 == 1).collect();
                let outs: Vec<usize> = (0..4).filter(|q| mask >> q & 1 == 0).collect();
                let polygon: Vec<(usize, usize)> = match (ins.len(), outs.len()) {
                    (1, 3) => outs.iter().map(|&o| (ins[0], o)).collect(),
                    (3, 1) => ins.iter().map(|&i| (i, outs[0])).collect(),
                    (2, 2) => vec![
                        (ins[0], outs[0]),
                        (ins[0], outs[1]),
                        (ins[1], outs[1]),
                        (ins[1], outs[0]),
                    ],
                    _ => Vec::new(),
                };
                let mut tris: Vec<[(usize, usize); 3]> = (2..polygon.len())
                    .map(|k| [polygon[0], polygon[k - 1], polygon[k]])
                    .collect();
                if let Some(first) = tris.first() {
                    let mid = |(a, b): (usize, usize)| (corner(tet[a]) + corner(tet[b])) / 2.0;
                    let [m0, m1, m2] = first.map(mid);
                    let centroid = |set: &[usize]| {
                        set.iter().map(|&q| corner(tet[q])).sum::<DVec3>() / set.len() as f64
                    };
                    let out = centroid(&outs) - centroid(&ins);
                    if (m1 - m0).cross(m2 - m0).dot(out) < 0.0 {
                        for t in &mut tris {
                            t.swap(1, 2);
                        }
                    }
                }
                cases.push(tris);
            }
        }
        Self { cases }
    }
}

/// Welds block meshes into one mesh (vertices shared by edge key), with area-weighted
/// vertex normals.
pub fn weld<'a>(blocks: impl Iterator<Item = &'a BlockMesh>) -> WeldedMesh {
    let mut mesh = WeldedMesh::default();
    let mut index: HashMap<u64, u32> = HashMap::new();
    let mut normals: Vec<DVec3> = Vec::new();
    for b in blocks {
        let map: Vec<u32> = b
            .vertices
            .iter()
            .map(|&(key, p)| {
                *index.entry(key).or_insert_with(|| {
                    mesh.vertices.push(MeshVertex {
                        position: p,
                        normal: [0.0; 3],
                        uv: [0.0; 2],
                    });
                    normals.push(DVec3::ZERO);
                    (mesh.vertices.len() - 1) as u32
                })
            })
            .collect();
        for t in &b.triangles {
            let tri = t.map(|v| map[v as usize]);
            let [a, b2, c] =
                tri.map(|v| DVec3::from(mesh.vertices[v as usize].position.map(f64::from)));
            let n = (b2 - a).cross(c - a);
            for v in tri {
                normals[v as usize] += n;
            }
            mesh.triangles.push(tri);
        }
    }
    for (v, n) in mesh.vertices.iter_mut().zip(normals) {
        v.normal = n.normalize_or_zero().as_vec3().to_array();
    }
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every cut of every tetrahedron is wound outward and none is degenerate.
    #[test]
    fn every_case_is_wound_from_inside_to_outside() {
        let table = TetTable::new();
        for (t, tet) in KUHN.iter().enumerate() {
            for mask in 1..15usize {
                let tris = &table.cases[t * 16 + mask];
                let expected = if mask.count_ones() == 2 { 2 } else { 1 };
                assert_eq!(tris.len(), expected, "tet {t} mask {mask}");
                let corner = |b: usize| {
                    DVec3::new((b & 1) as f64, ((b >> 1) & 1) as f64, ((b >> 2) & 1) as f64)
                };
                let inside: DVec3 = (0..4)
                    .filter(|q| mask >> q & 1 == 1)
                    .map(|q| corner(tet[q]))
                    .sum();
                for tri in tris {
                    let [m0, m1, m2] = tri.map(|(a, b)| (corner(tet[a]) + corner(tet[b])) / 2.0);
                    let n = (m1 - m0).cross(m2 - m0);
                    assert!(n.length() > 0.0, "tet {t} mask {mask} degenerate");
                    // An inside corner lies behind the triangle.
                    let ins = inside / f64::from(mask.count_ones());
                    assert!(n.dot(m0 - ins) > 0.0, "tet {t} mask {mask} wound inward");
                }
            }
        }
    }
}
