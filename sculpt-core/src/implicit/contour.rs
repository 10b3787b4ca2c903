//! Meshing an implicit solid: marching tetrahedra on a regular grid.
//!
//! Each grid cube is split into the six tetrahedra of its Kuhn (Freudenthal)
//! triangulation, all sharing the cube's main diagonal; neighbouring cubes split their
//! shared faces the same way, so the pieces meet exactly. In each tetrahedron the
//! zero set of the linear interpolant of the corner values is one triangle or one
//! quad (Doi and Koide, *An Efficient Method of Triangulating Equi-Valued Surfaces by
//! Using Tetrahedral Cells*, 1991). Unlike marching cubes there is no ambiguous case,
//! and the result is a closed, 2-manifold, consistently oriented triangle mesh:
//!
//! - a vertex lies on a grid edge with one inside and one outside corner and is shared
//!   by every triangle that uses that edge;
//! - a corner value of exactly 0 (or NaN) counts as outside, so no vertex sits on a
//!   corner, and vertices stay [`CONTOUR_EDGE_T_MIN`] of an edge away from its ends,
//!   so distinct vertices never coincide;
//! - corners on the grid's outer layer count as outside, so a solid that leaves the
//!   box is closed off at its faces;
//! - orientation follows from the tetrahedra's (positive) orientation: normals point
//!   from inside to outside.
//!
//! Sharp features are not kept: a vertex lies on a grid edge, so an edge of the solid
//! is cut to within a cell. The tape must be negative inside.

use std::collections::HashMap;

use super::ImplicitError;
use super::tape::{Grid, Tape};
use crate::mesh::{MeshVertex, WeldedMesh};
use crate::tolerance::CONTOUR_EDGE_T_MIN;

/// The six tetrahedra of a cube as corner bit masks (x = 1, y = 2, z = 4), each
/// positively oriented: the path 0 -> e_a -> e_a + e_b -> 7 for every axis order
/// (a, b, c), with the two middle corners swapped for odd orders.
const TETS: [[usize; 4]; 6] = [
    [0, 1, 3, 7], // x y z (even)
    [0, 2, 6, 7], // y z x (even)
    [0, 4, 5, 7], // z x y (even)
    [0, 5, 1, 7], // x z y (odd): 0 1 5 7 with 1 and 5 swapped
    [0, 3, 2, 7], // y x z (odd)
    [0, 6, 4, 7], // z y x (odd)
];

/// The mesh of the zero set of `tape` (negative inside) sampled at the corners of a
/// grid with `n` cells per axis on the box `lo`..`hi`.
pub fn contour(
    tape: &Tape,
    n: [usize; 3],
    lo: [f64; 3],
    hi: [f64; 3],
) -> Result<WeldedMesh, ImplicitError> {
    Ok(contour_cells(tape, n, lo, hi)?.0)
}

/// What [`contour_cells`] gives besides the mesh.
#[derive(Debug, Clone, Default)]
pub struct ContourCells {
    /// The grid cell of each triangle (`i + n[0] (j + n[1] k)`).
    pub cells: Vec<usize>,
    /// The ends of the grid edge (or cell diagonal) each vertex lies on.
    pub edges: Vec<[[f64; 3]; 2]>,
}

/// [`contour`] with the cell of each triangle and the edge of each vertex.
pub fn contour_cells(
    tape: &Tape,
    n: [usize; 3],
    lo: [f64; 3],
    hi: [f64; 3],
) -> Result<(WeldedMesh, ContourCells), ImplicitError> {
    // Checks the sizes (and that corners fit): the corner grid has one more per axis.
    Grid::new(n.map(|k| k + 1), lo, hi)?;
    Grid::new(n, lo, hi)?;
    let h: [f64; 3] = [0, 1, 2].map(|a| (hi[a] - lo[a]) / n[a] as f64);
    let corner = |c: [usize; 3]| [0, 1, 2].map(|a| lo[a] + c[a] as f64 * h[a]);
    let outside = f64::from(h.iter().copied().fold(f64::INFINITY, f64::min) as f32);
    let (cx, cy) = (n[0] + 1, n[1] + 1);
    // Corner values of layer k, as the tape computes them (f32).
    let layer = |k: usize| -> Result<Vec<f64>, ImplicitError> {
        let z = lo[2] + k as f64 * h[2];
        let g = Grid::new(
            [cx, cy, 1],
            [lo[0] - h[0] / 2.0, lo[1] - h[1] / 2.0, z - 0.5],
            [hi[0] + h[0] / 2.0, hi[1] + h[1] / 2.0, z + 0.5],
        )?;
        Ok(tape.eval_grid(&g).into_iter().map(f64::from).collect())
    };
    let mut edges = Vec::new();
    let vertex = |a: [usize; 3], b: [usize; 3], t: f64| -> Result<MeshVertex, ImplicitError> {
        let (pa, pb) = (corner(a), corner(b));
        edges.push([pa, pb]);
        let p = [0, 1, 2].map(|c| pa[c] + t * (pb[c] - pa[c]));
        let pf = p.map(|c| c as f32);
        let (_, g) = tape.eval_grad(pf);
        let len = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        let normal = if len.is_finite() && len > 0.0 {
            g.map(|c| c / len)
        } else {
            [0.0; 3]
        };
        Ok(MeshVertex {
            position: pf,
            normal,
            uv: [0.0; 2],
        })
    };
    let (mesh, cells) = march_tetrahedra_cells(n, outside, layer, vertex)?;
    Ok((mesh, ContourCells { cells, edges }))
}

/// Marching tetrahedra on a grid of `n` cells per axis (the module docs' rules), for
/// any sampled field: `layer(k)` gives the `(n_x + 1) (n_y + 1)` corner values of
/// layer `k` (x fastest), negative inside; `vertex(a, b, t)` makes the vertex at
/// fraction `t` of the grid edge from corner `a` to corner `b` (integer corner
/// indices). NaN corners, and non-positive ones on the outer layer, are set to
/// `outside` (a positive value) first, so the mesh is closed.
pub fn march_tetrahedra<E>(
    n: [usize; 3],
    outside: f64,
    layer: impl FnMut(usize) -> Result<Vec<f64>, E>,
    vertex: impl FnMut([usize; 3], [usize; 3], f64) -> Result<MeshVertex, E>,
) -> Result<WeldedMesh, E> {
    Ok(march_tetrahedra_cells(n, outside, layer, vertex)?.0)
}

/// [`march_tetrahedra`] with the grid cell of each triangle
/// (`i + n[0] (j + n[1] k)`).
pub fn march_tetrahedra_cells<E>(
    n: [usize; 3],
    outside: f64,
    mut layer: impl FnMut(usize) -> Result<Vec<f64>, E>,
    mut vertex: impl FnMut([usize; 3], [usize; 3], f64) -> Result<MeshVertex, E>,
) -> Result<(WeldedMesh, Vec<usize>), E> {
    let (cx, cy) = (n[0] + 1, n[1] + 1);
    // Corner values of layer k, with the outer layer and NaN forced outside.
    let mut forced = |k: usize| -> Result<Vec<f64>, E> {
        let mut v = layer(k)?;
        for j in 0..cy {
            for i in 0..cx {
                let edge = i == 0 || j == 0 || k == 0 || i == n[0] || j == n[1] || k == n[2];
                let val = &mut v[i + cx * j];
                // NaN anywhere and non-positive values on the outer layer go outside.
                if val.is_nan() || (edge && *val <= 0.0) {
                    *val = outside;
                }
            }
        }
        Ok(v)
    };

    let mut mesh = WeldedMesh::default();
    let mut cells = Vec::new();
    let mut edge_vertex: HashMap<(u64, u64), u32> = HashMap::new();
    let id = |c: [usize; 3]| (c[0] + cx * (c[1] + cy * c[2])) as u64;
    let mut below = forced(0)?;
    for k in 0..n[2] {
        let above = forced(k + 1)?;
        for j in 0..n[1] {
            for i in 0..n[0] {
                let mut cs = [[0usize; 3]; 8];
                let mut vals = [0f64; 8];
                for (b, (c, val)) in cs.iter_mut().zip(vals.iter_mut()).enumerate() {
                    let (di, dj, dk) = (b & 1, (b >> 1) & 1, (b >> 2) & 1);
                    *c = [i + di, j + dj, k + dk];
                    let src = if dk == 0 { &below } else { &above };
                    *val = src[(i + di) + cx * (j + dj)];
                }
                if vals.iter().all(|&v| v < 0.0) || vals.iter().all(|&v| v >= 0.0) {
                    continue;
                }
                for tet in TETS {
                    let inside = tet.map(|c| vals[c] < 0.0);
                    for tri in tet_triangles(inside) {
                        let mut t = [0u32; 3];
                        for (slot, (a, b)) in t.iter_mut().zip(tri) {
                            let (ca, cb) = (tet[a], tet[b]);
                            let key = (id(cs[ca]).min(id(cs[cb])), id(cs[ca]).max(id(cs[cb])));
                            *slot = match edge_vertex.get(&key) {
                                Some(&v) => v,
                                None => {
                                    let (va, vb) = (vals[ca], vals[cb]);
                                    let s = (va / (va - vb))
                                        .clamp(CONTOUR_EDGE_T_MIN, 1.0 - CONTOUR_EDGE_T_MIN);
                                    mesh.vertices.push(vertex(cs[ca], cs[cb], s)?);
                                    let v = (mesh.vertices.len() - 1) as u32;
                                    edge_vertex.insert(key, v);
                                    v
                                }
                            };
                        }
                        mesh.triangles.push(t);
                        cells.push(i + n[0] * (j + n[1] * k));
                    }
                }
            }
        }
        below = above;
    }
    Ok((mesh, cells))
}

/// Whether a permutation of `0..4` is even.
fn even(p: [usize; 4]) -> bool {
    let mut inversions = 0;
    for a in 0..4 {
        for b in a + 1..4 {
            if p[a] > p[b] {
                inversions += 1;
            }
        }
    }
    inversions % 2 == 0
}

/// `first` followed by the rest of `0..4` in order, made an even permutation by
/// swapping the last two when needed.
fn even_order(first: &[usize]) -> [usize; 4] {
    let mut p = [0usize; 4];
    p[..first.len()].copy_from_slice(first);
    let mut k = first.len();
    for v in 0..4 {
        if !first.contains(&v) {
            p[k] = v;
            k += 1;
        }
    }
    if !even(p) {
        p.swap(2, 3);
    }
    p
}

/// The triangles (as pairs of tetrahedron corners, one pair per vertex, on the edge
/// between them) of a positively oriented tetrahedron with the given inside corners,
/// wound so that their normals point outside.
///
/// For an even order `(i, j, k, l)`, the triangle on edges `ij, ik, il` faces away
/// from `i`; the quad on edges `ik, il, jl, jk` faces towards `k` and `l`.
fn tet_triangles(inside: [bool; 4]) -> Vec<[(usize, usize); 3]> {
    let ins: Vec<usize> = (0..4).filter(|&c| inside[c]).collect();
    let outs: Vec<usize> = (0..4).filter(|&c| !inside[c]).collect();
    match ins.len() {
        1 => {
            let [i, j, k, l] = even_order(&ins);
            vec![[(i, j), (i, k), (i, l)]]
        }
        3 => {
            let [i, j, k, l] = even_order(&outs);
            vec![[(i, j), (i, l), (i, k)]]
        }
        2 => {
            let [i, j, k, l] = even_order(&ins);
            vec![[(i, k), (i, l), (j, l)], [(i, k), (j, l), (j, k)]]
        }
        _ => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn corner(b: usize) -> [f64; 3] {
        [(b & 1) as f64, ((b >> 1) & 1) as f64, ((b >> 2) & 1) as f64]
    }

    fn det(t: [usize; 4]) -> f64 {
        let p = t.map(corner);
        let d = |a: usize| [0, 1, 2].map(|c| p[a][c] - p[0][c]);
        let (u, v, w) = (d(1), d(2), d(3));
        u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
            + u[2] * (v[0] * w[1] - v[1] * w[0])
    }

    /// The six tetrahedra are positively oriented and fill the cube (volumes sum to 1).
    #[test]
    fn tets_are_positive_and_fill_the_cube() {
        let mut total = 0.0;
        for t in TETS {
            let d = det(t);
            assert!(d > 0.0, "{t:?} has det {d}");
            total += d / 6.0;
        }
        crate::assert_near!(total, 1.0, crate::tolerance::IMPLICIT_F64_EPS);
    }
}
