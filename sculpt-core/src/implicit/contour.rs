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
use std::ops::Range;

use super::interval::Interval;
use super::tape::{Grid, Tape, for_each_tile};
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
    let sparse = contour_sparse(tape, n, lo, hi)?;
    Ok((sparse.mesh, sparse.cells))
}

/// Cell edges of the levels on which [`contour_cells`] classifies the grid by
/// interval arithmetic, coarse to fine; the last is the block whose corners are
/// evaluated (Fidget's voxel tile sizes, as [`Tape::eval_grid`] uses).
pub const CONTOUR_TILES: [usize; 3] = [64, 16, 8];

/// How much of the grid [`contour_cells`] evaluated.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContourStats {
    /// Blocks of the last level of [`CONTOUR_TILES`] that the grid has.
    pub blocks: usize,
    /// Blocks whose corners were evaluated (the others lie inside or outside the
    /// solid by interval arithmetic).
    pub evaluated_blocks: usize,
    /// Instructions of the full tape.
    pub tape_len: usize,
    /// Mean instructions of the evaluated blocks' pruned tapes.
    pub mean_block_tape_len: f64,
}

/// A block of cells whose corners were evaluated, with its pruned tape.
pub(crate) struct Block {
    /// Cell index ranges per axis.
    cells: [Range<usize>; 3],
    /// The tape simplified over the block's corner box: equal to the full tape there.
    pub(crate) tape: Tape,
    /// Corner values (one more than cells per axis, x fastest), NaN and outer-layer
    /// non-positive values forced outside.
    values: Vec<f32>,
}

/// The sparse marching-tetrahedra mesh and where each piece came from.
pub(crate) struct SparseContour {
    pub(crate) mesh: WeldedMesh,
    pub(crate) cells: ContourCells,
    /// The evaluated blocks.
    pub(crate) blocks: Vec<Block>,
    /// The block of each vertex (whose tape holds on the vertex's edge).
    pub(crate) vertex_block: Vec<u32>,
    /// The block of each triangle (whose tape holds on the triangle's cell).
    pub(crate) triangle_block: Vec<u32>,
    pub(crate) stats: ContourStats,
}

/// The corners of the grid: f32 coordinates as the tape sees them.
struct Corners {
    n: [usize; 3],
    lo: [f64; 3],
    h: [f64; 3],
}

impl Corners {
    fn at(&self, c: [usize; 3]) -> [f64; 3] {
        [0, 1, 2].map(|a| self.lo[a] + c[a] as f64 * self.h[a])
    }

    fn coord(&self, axis: usize, c: usize) -> f32 {
        (self.lo[axis] + c as f64 * self.h[axis]) as f32
    }

    /// Whether corner `c` lies on the grid's outer layer.
    fn on_outer_layer(&self, c: [usize; 3]) -> bool {
        (0..3).any(|a| c[a] == 0 || c[a] == self.n[a])
    }
}

/// Maps `f` over `items`, on the rayon pool with the `parallel` feature.
pub(crate) fn par_map<T: Sync, U: Send>(items: &[T], f: impl Fn(&T) -> U + Sync + Send) -> Vec<U> {
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        items.par_iter().map(f).collect()
    }
    #[cfg(not(feature = "parallel"))]
    {
        items.iter().map(f).collect()
    }
}

/// The leaf blocks under `bx` that may hold the surface, with their pruned tapes:
/// each level simplifies its parent's tape over the box of its corners (Keeter 2020,
/// sec. 3), and a box whose interval is all negative (inside) or all non-negative
/// (outside; 0 counts as outside) is dropped, unless it is inside and touches the
/// grid's outer layer (whose corners are forced outside, which makes a surface there).
fn classify(
    tape: &Tape,
    bx: [Range<usize>; 3],
    tiles: &[usize],
    corners: &Corners,
    out: &mut Vec<([Range<usize>; 3], Tape)>,
) {
    let region = [0, 1, 2]
        .map(|a| Interval::new(corners.coord(a, bx[a].start), corners.coord(a, bx[a].end)));
    let (range, sub) = tape.simplify(region);
    let outer = (0..3).any(|a| bx[a].start == 0 || bx[a].end == corners.n[a]);
    if !range.nan && (range.lo >= 0.0 || (range.hi < 0.0 && !outer)) {
        return;
    }
    match tiles.split_first() {
        Some((&size, rest)) => for_each_tile(&bx, size, |b| classify(&sub, b, rest, corners, out)),
        None => out.push((bx, sub)),
    }
}

/// [`contour_cells`], keeping the blocks: the grid is classified by interval
/// arithmetic ([`CONTOUR_TILES`]); only blocks that may hold the surface evaluate
/// their corners, each with its own pruned tape, which also gives its vertices'
/// normals. Pruned tapes equal the full one in their box bit for bit, so the mesh is
/// the one a dense evaluation of every corner gives.
pub(crate) fn contour_sparse(
    tape: &Tape,
    n: [usize; 3],
    lo: [f64; 3],
    hi: [f64; 3],
) -> Result<SparseContour, ImplicitError> {
    // Checks the sizes (and that corners fit): the corner grid has one more per axis.
    Grid::new(n.map(|k| k + 1), lo, hi)?;
    Grid::new(n, lo, hi)?;
    let h: [f64; 3] = [0, 1, 2].map(|a| (hi[a] - lo[a]) / n[a] as f64);
    let corners = Corners { n, lo, h };
    let outside = h.iter().copied().fold(f64::INFINITY, f64::min) as f32;
    // Top-level tiles, classified in parallel.
    let mut tops = Vec::new();
    for_each_tile(&[0..n[0], 0..n[1], 0..n[2]], CONTOUR_TILES[0], |b| {
        tops.push(b)
    });
    let found = par_map(&tops, |b| {
        let mut out = Vec::new();
        classify(tape, b.clone(), &CONTOUR_TILES[1..], &corners, &mut out);
        out
    });
    let leaves: Vec<([Range<usize>; 3], Tape)> = found.into_iter().flatten().collect();
    let blocks: Vec<Block> = par_map(&leaves, |(cells, sub)| {
        let m = [0, 1, 2].map(|a| cells[a].len() + 1);
        let mut points = Vec::with_capacity(m[0] * m[1] * m[2]);
        let mut ids = Vec::with_capacity(points.capacity());
        for k in cells[2].start..=cells[2].end {
            for j in cells[1].start..=cells[1].end {
                for i in cells[0].start..=cells[0].end {
                    points.push([0, 1, 2].map(|a| corners.coord(a, [i, j, k][a])));
                    ids.push([i, j, k]);
                }
            }
        }
        let mut values = vec![0.0f32; points.len()];
        sub.eval_points(&points, &mut values);
        for (v, &c) in values.iter_mut().zip(&ids) {
            // NaN anywhere and non-positive values on the outer layer go outside.
            if v.is_nan() || (*v <= 0.0 && corners.on_outer_layer(c)) {
                *v = outside;
            }
        }
        Block {
            cells: cells.clone(),
            tape: sub.clone(),
            values,
        }
    });

    let (cx, cy) = (n[0] + 1, n[1] + 1);
    let id = |c: [usize; 3]| (c[0] + cx * (c[1] + cy * c[2])) as u64;
    let mut mesh = WeldedMesh::default();
    let mut cells_of = Vec::new();
    let mut triangle_block = Vec::new();
    // Vertices to make: block, edge ends (corner indices), fraction along the edge.
    let mut pending: Vec<(u32, [usize; 3], [usize; 3], f64)> = Vec::new();
    let mut edge_vertex: HashMap<(u64, u64), u32> = HashMap::new();
    for (bi, block) in blocks.iter().enumerate() {
        let c0 = block.cells.clone().map(|r| r.start);
        let m = [0, 1, 2].map(|a| block.cells[a].len() + 1);
        let local = |c: [usize; 3]| {
            f64::from(
                block.values[(c[0] - c0[0]) + m[0] * ((c[1] - c0[1]) + m[1] * (c[2] - c0[2]))],
            )
        };
        for k in block.cells[2].clone() {
            for j in block.cells[1].clone() {
                for i in block.cells[0].clone() {
                    let cs: [[usize; 3]; 8] = std::array::from_fn(|b| {
                        [i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1)]
                    });
                    let vals = cs.map(local);
                    let before = mesh.triangles.len();
                    march_cube(
                        &cs,
                        &vals,
                        &id,
                        &mut edge_vertex,
                        &mut mesh.triangles,
                        |a, b, s| {
                            pending.push((bi as u32, a, b, s));
                            Ok::<u32, std::convert::Infallible>((pending.len() - 1) as u32)
                        },
                    )
                    .unwrap_or_else(|never| match never {});
                    let new = mesh.triangles.len() - before;
                    cells_of.extend(std::iter::repeat_n(i + n[0] * (j + n[1] * k), new));
                    triangle_block.extend(std::iter::repeat_n(bi as u32, new));
                }
            }
        }
    }
    let made = par_map(&pending, |&(bi, a, b, s)| {
        let (pa, pb) = (corners.at(a), corners.at(b));
        let p = [0, 1, 2].map(|c| pa[c] + s * (pb[c] - pa[c]));
        let pf = p.map(|c| c as f32);
        let (_, g) = blocks[bi as usize].tape.eval_grad(pf);
        (
            MeshVertex {
                position: pf,
                normal: unit(g),
                uv: [0.0; 2],
            },
            [pa, pb],
        )
    });
    let vertex_block = pending.iter().map(|p| p.0).collect();
    let (vertices, edges): (Vec<MeshVertex>, Vec<[[f64; 3]; 2]>) = made.into_iter().unzip();
    mesh.vertices = vertices;
    let total: usize = (0..3)
        .map(|a| n[a].div_ceil(CONTOUR_TILES[CONTOUR_TILES.len() - 1]))
        .product();
    let mean = if blocks.is_empty() {
        0.0
    } else {
        blocks.iter().map(|b| b.tape.len()).sum::<usize>() as f64 / blocks.len() as f64
    };
    let stats = ContourStats {
        blocks: total,
        evaluated_blocks: blocks.len(),
        tape_len: tape.len(),
        mean_block_tape_len: mean,
    };
    Ok(SparseContour {
        mesh,
        cells: ContourCells {
            cells: cells_of,
            edges,
        },
        blocks,
        vertex_block,
        triangle_block,
        stats,
    })
}

/// What [`contour_cells`] evaluated: [`ContourStats`] of the mesh of `tape`.
pub fn contour_stats(
    tape: &Tape,
    n: [usize; 3],
    lo: [f64; 3],
    hi: [f64; 3],
) -> Result<ContourStats, ImplicitError> {
    Ok(contour_sparse(tape, n, lo, hi)?.stats)
}

/// `g` scaled to unit length, or zero where it has no direction.
pub(crate) fn unit(g: [f32; 3]) -> [f32; 3] {
    let len = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
    if len.is_finite() && len > 0.0 {
        g.map(|c| c / len)
    } else {
        [0.0; 3]
    }
}

/// [`contour_cells`] with every corner of the grid evaluated on the full tape, layer
/// by layer (no interval classification): the reference the sparse mesher must equal.
pub fn contour_cells_dense(
    tape: &Tape,
    n: [usize; 3],
    lo: [f64; 3],
    hi: [f64; 3],
) -> Result<(WeldedMesh, ContourCells), ImplicitError> {
    Grid::new(n.map(|k| k + 1), lo, hi)?;
    Grid::new(n, lo, hi)?;
    let h: [f64; 3] = [0, 1, 2].map(|a| (hi[a] - lo[a]) / n[a] as f64);
    let corners = Corners { n, lo, h };
    let outside = f64::from(h.iter().copied().fold(f64::INFINITY, f64::min) as f32);
    let (cx, cy) = (n[0] + 1, n[1] + 1);
    let layer = |k: usize| -> Result<Vec<f64>, ImplicitError> {
        let mut points = Vec::with_capacity(cx * cy);
        for j in 0..cy {
            for i in 0..cx {
                points.push([0, 1, 2].map(|a| corners.coord(a, [i, j, k][a])));
            }
        }
        let mut values = vec![0.0f32; points.len()];
        tape.eval_points(&points, &mut values);
        Ok(values.into_iter().map(f64::from).collect())
    };
    let mut edges = Vec::new();
    let vertex = |a: [usize; 3], b: [usize; 3], t: f64| -> Result<MeshVertex, ImplicitError> {
        let (pa, pb) = (corners.at(a), corners.at(b));
        edges.push([pa, pb]);
        let p = [0, 1, 2].map(|c| pa[c] + t * (pb[c] - pa[c]));
        let pf = p.map(|c| c as f32);
        Ok(MeshVertex {
            position: pf,
            normal: unit(tape.eval_grad(pf).1),
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
                let before = mesh.triangles.len();
                march_cube(
                    &cs,
                    &vals,
                    &id,
                    &mut edge_vertex,
                    &mut mesh.triangles,
                    |a, b, s| {
                        mesh.vertices.push(vertex(a, b, s)?);
                        Ok((mesh.vertices.len() - 1) as u32)
                    },
                )?;
                cells.extend((before..mesh.triangles.len()).map(|_| i + n[0] * (j + n[1] * k)));
            }
        }
        below = above;
    }
    Ok((mesh, cells))
}

/// Marching tetrahedra in one cube (the module docs' rules): corners `cs` (integer
/// indices, bit order x = 1, y = 2, z = 4) with values `vals`; pushes its triangles
/// to `triangles`, taking each edge's vertex from `edge_vertex` (keyed by the corner
/// ids `id` of its ends) or making it with `make(a, b, t)` at fraction `t` from `a`.
fn march_cube<E>(
    cs: &[[usize; 3]; 8],
    vals: &[f64; 8],
    id: &impl Fn([usize; 3]) -> u64,
    edge_vertex: &mut HashMap<(u64, u64), u32>,
    triangles: &mut Vec<[u32; 3]>,
    mut make: impl FnMut([usize; 3], [usize; 3], f64) -> Result<u32, E>,
) -> Result<(), E> {
    if vals.iter().all(|&v| v < 0.0) || vals.iter().all(|&v| v >= 0.0) {
        return Ok(());
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
                        let s =
                            (va / (va - vb)).clamp(CONTOUR_EDGE_T_MIN, 1.0 - CONTOUR_EDGE_T_MIN);
                        let v = make(cs[ca], cs[cb], s)?;
                        edge_vertex.insert(key, v);
                        v
                    }
                };
            }
            triangles.push(t);
        }
    }
    Ok(())
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
