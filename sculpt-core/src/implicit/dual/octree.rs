//! Octree simplification of the dual-contouring mesh ([`super`]): cells whose
//! surface is flat enough are collapsed into one vertex per octree node, bottom up,
//! bounded by the error of the quadric (QEF) of their Hermite data, as in Ju,
//! Losasso, Schaefer and Warren, *Dual Contouring of Hermite Data* (2002), sec. 3
//! ("Polygon simplification", the octree collapse of sec. 3.1 and its error bound),
//! and kept closed and 2-manifold by construction, the property Schaefer, Ju and
//! Warren's *Manifold Dual Contouring* (2007) adds and Fidget's manifold mesher keeps.
//!
//! 1. **Octree collapse.** At level `k` (nodes of `2^k` cells per axis, `k = 1 ..
//!    levels`, by default up to nodes as wide as the grid: [`OCTREE_LEVELS`]) the
//!    marching-tetrahedra triangles of a node split into connected patches. A patch collapses into one fan around one vertex when:
//!    - every triangle of it lay in a collapsed patch one level down (Ju et al.'s
//!      bottom-up rule: a node collapses only where all its children did);
//!    - it is a disk (Euler characteristic 1, one simple boundary loop): the
//!      topological safety test, here exact, so the fan that replaces it has the same
//!      boundary and the mesh stays closed and manifold (Manifold Dual Contouring's
//!      aim, reached without its vertex clustering);
//!    - its QEF (Ju et al. sec. 2.3) has rank 1 (a smooth piece; sharp edges and
//!      corners stay at cell resolution, where [`super`] placed and joined them);
//!    - the QEF minimiser lies in the node's box and within
//!      [`OctreeSimplify::qef_error`] cells of every tangent plane of the patch (the
//!      QEF error bound of Ju et al. sec. 3.1, as a largest plane distance rather than
//!      a sum, so it reads in cells);
//!    - no fan triangle turns against the surface's normals at its boundary edge;
//!    - every sample of the fan (its vertex, each triangle's centroid, each spoke's
//!      midpoint) is within [`OctreeSimplify::distance`] cells of the surface, proven
//!      by a sign change of the tape along the sample's normal over that distance
//!      either side.
//! 2. **Boundary chains.** The boundary loops of collapsed nodes still follow the
//!    cells. Where a boundary vertex `w` has exactly four triangles, two of them
//!    around each of two smooth fan vertices on opposite sides (a chain between two
//!    fans), `w` is collapsed into a chain neighbour `u` (a half-edge collapse; Hoppe,
//!    *Progressive Meshes*, 1996, sec. 4) when the link condition holds (the chain's
//!    other neighbour `z` is not yet joined to `u`; Dey, Edelsbrunner et al.,
//!    *Topology Preserving Edge Contraction*, 1999), each fan keeps three triangles
//!    or more, neither new triangle turns against the one it replaces, and the new
//!    triangles' samples pass the same sign-change test. Chains shrink in passes until
//!    none changes.
//!
//! Vertices never move, so the surface stays where dual contouring put it; only
//! smooth regions lose triangles.

use nalgebra::Vector3;

use super::{disk_boundary, patches, qef_solve};
use crate::implicit::contour::par_map;
use crate::implicit::tape::Tape;
use crate::mesh::MeshVertex;
use crate::tolerance::{DUAL_OCTREE_QEF_CELL_FRAC, DUAL_OCTREE_SAMPLE_CELL_FRAC};

/// Octree levels above the cells that [`OctreeSimplify::default`] may collapse: nodes
/// of up to 2^10 = 1024 cells per axis, more than any grid the tools mesh, so a node
/// stops growing where its patch fails a check (the QEF error bound first, on curved
/// parts), not at a fixed size. The collapse stops early at the first level where no
/// node patch is left alive, or whose nodes cover the grid.
pub const OCTREE_LEVELS: usize = 10;

/// Passes of boundary-chain collapse at most (each removes about a third of the
/// vertices of every chain; a chain along an 8-cell node face is gone in about 6).
pub const CHAIN_PASSES: usize = 24;

/// Samples evaluated together in one batch (one call of [`Tape::eval_points`]).
const SAMPLE_BATCH: usize = 2048;

/// Settings of the octree simplification (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OctreeSimplify {
    /// Octree levels above the cells: nodes of up to `2^levels` cells per axis.
    pub levels: usize,
    /// Largest distance, in cells (the smallest cell edge), from a node's vertex to
    /// any tangent plane of its patch.
    pub qef_error: f64,
    /// Largest distance, in cells, from any sample of a new triangle to the surface.
    pub distance: f64,
    /// Whether boundary chains between fans are collapsed (step 2).
    pub chains: bool,
}

impl Default for OctreeSimplify {
    fn default() -> Self {
        Self {
            levels: OCTREE_LEVELS,
            qef_error: DUAL_OCTREE_QEF_CELL_FRAC,
            distance: DUAL_OCTREE_SAMPLE_CELL_FRAC,
            chains: true,
        }
    }
}

/// A fan around one vertex of a collapsed octree node.
pub(crate) struct NodeFan {
    /// The vertex (the QEF minimiser).
    pub(crate) x: [f64; 3],
    /// The QEF's rank (1: collapsed nodes are smooth).
    pub(crate) rank: usize,
    /// The node's octree level: `2^level` cells per axis.
    pub(crate) level: usize,
    /// The patch's boundary loop, as directed edges in order.
    pub(crate) boundary: Vec<(u32, u32)>,
}

/// The node fan owning each triangle (`u32::MAX`: none) and the fans.
pub(crate) struct Collapsed {
    /// Per marching-tetrahedra triangle: its coarsest collapsed node's fan.
    pub(crate) owner: Vec<u32>,
    /// The fans of collapsed nodes.
    pub(crate) fans: Vec<NodeFan>,
}

/// A point to test against the surface, with the unit normal to test along.
type Sample = ([f64; 3], [f64; 3]);

/// A node patch that passed the checks before sampling.
struct Candidate {
    tris: Vec<usize>,
    fan: NodeFan,
    /// Sample points with their unit normals.
    samples: Vec<Sample>,
}

/// What one node patch came to before sampling.
enum Outcome {
    /// Not collapsible: its triangles are out of every coarser node.
    Dead(Vec<usize>),
    /// Collapsible if its samples pass.
    Maybe(Candidate),
}

fn pos(v: &MeshVertex) -> Vector3<f64> {
    Vector3::from(v.position.map(f64::from))
}

fn nrm(v: &MeshVertex) -> Vector3<f64> {
    Vector3::from(v.normal.map(f64::from))
}

/// Step 1 of the module docs. `triangles` are the marching-tetrahedra triangles,
/// `cells` their cells (`i + n[0] (j + n[1] k)`), `vertices` their Hermite samples,
/// `alive` the triangles in smooth cell fans (rank 1 or less); `h` the cell edges.
#[allow(clippy::too_many_arguments)]
pub(crate) fn collapse_nodes(
    tape: &Tape,
    triangles: &[[u32; 3]],
    cells: &[usize],
    vertices: &[MeshVertex],
    mut alive: Vec<bool>,
    n: [usize; 3],
    lo: [f64; 3],
    h: [f64; 3],
    settings: &OctreeSimplify,
) -> Collapsed {
    let hmin = h[0].min(h[1]).min(h[2]);
    let mut owner = vec![u32::MAX; triangles.len()];
    let mut fans: Vec<NodeFan> = Vec::new();
    let ijk = |c: usize| [c % n[0], (c / n[0]) % n[1], c / (n[0] * n[1])];
    for level in 1..=settings.levels {
        // Nodes wider than the grid on every axis hold the same patches as the level
        // below; nothing alive, nothing to collapse.
        if (0..3).all(|a| (1usize << (level - 1)) >= n[a]) || !alive.iter().any(|&a| a) {
            break;
        }
        let m = [0, 1, 2].map(|a| (n[a] >> level) + 1);
        let mut keyed: Vec<(usize, usize)> = (0..triangles.len())
            .map(|t| {
                let c = ijk(cells[t]).map(|i| i >> level);
                (c[0] + m[0] * (c[1] + m[1] * c[2]), t)
            })
            .collect();
        keyed.sort_unstable();
        let mut nodes: Vec<(usize, Vec<usize>)> = Vec::new();
        for (key, t) in keyed {
            match nodes.last_mut() {
                Some((k, ts)) if *k == key => ts.push(t),
                _ => nodes.push((key, vec![t])),
            }
        }
        // Nodes with nothing alive have nothing to collapse.
        nodes.retain(|(_, ts)| ts.iter().any(|&t| alive[t]));
        let outcomes: Vec<Vec<Outcome>> = par_map(&nodes, |(key, tris)| {
            let node = [key % m[0], (key / m[0]) % m[1], key / (m[0] * m[1])];
            let node_lo: [f64; 3] = [0, 1, 2].map(|a| lo[a] + ((node[a] << level) as f64) * h[a]);
            let node_hi: [f64; 3] = [0, 1, 2].map(|a| {
                let end = ((node[a] + 1) << level).min(n[a]);
                lo[a] + end as f64 * h[a]
            });
            patches(triangles, tris)
                .into_iter()
                .map(|patch| {
                    if patch.iter().any(|&t| !alive[t]) {
                        return Outcome::Dead(patch);
                    }
                    match node_candidate(
                        triangles, vertices, &patch, node_lo, node_hi, hmin, settings,
                    ) {
                        Some((mut fan, samples)) => {
                            fan.level = level;
                            Outcome::Maybe(Candidate {
                                tris: patch,
                                fan,
                                samples,
                            })
                        }
                        None => Outcome::Dead(patch),
                    }
                })
                .collect()
        });
        let mut candidates: Vec<Candidate> = Vec::new();
        for o in outcomes.into_iter().flatten() {
            match o {
                Outcome::Dead(tris) => tris.iter().for_each(|&t| alive[t] = false),
                Outcome::Maybe(c) => candidates.push(c),
            }
        }
        let samples: Vec<Sample> = candidates
            .iter()
            .flat_map(|c| c.samples.iter().copied())
            .collect();
        let near = near_surface(tape, &samples, settings.distance * hmin);
        let mut at = 0;
        for c in candidates {
            let ok = near[at..at + c.samples.len()].iter().all(|&b| b);
            at += c.samples.len();
            if ok {
                let id = fans.len() as u32;
                c.tris.iter().for_each(|&t| owner[t] = id);
                fans.push(c.fan);
            } else {
                c.tris.iter().for_each(|&t| alive[t] = false);
            }
        }
    }
    Collapsed { owner, fans }
}

/// The checks of step 1 that need no evaluation, and the samples for the one that
/// does; `None` when the patch cannot collapse.
fn node_candidate(
    triangles: &[[u32; 3]],
    vertices: &[MeshVertex],
    patch: &[usize],
    node_lo: [f64; 3],
    node_hi: [f64; 3],
    hmin: f64,
    settings: &OctreeSimplify,
) -> Option<(NodeFan, Vec<Sample>)> {
    let faces: Vec<[u32; 3]> = patch.iter().map(|&t| triangles[t]).collect();
    let boundary = disk_boundary(&faces)?;
    let mut used: Vec<u32> = faces.iter().flatten().copied().collect();
    used.sort_unstable();
    used.dedup();
    let (x, rank) = qef_solve(vertices, &used);
    if rank > 1 || (0..3).any(|a| !(node_lo[a] <= x[a] && x[a] <= node_hi[a])) {
        return None;
    }
    let xv = Vector3::from(x);
    let bound = settings.qef_error * hmin;
    let mut mean_normal = Vector3::zeros();
    for &i in &used {
        let v = &vertices[i as usize];
        if nrm(v).dot(&(xv - pos(v))).abs() > bound {
            return None;
        }
        mean_normal += nrm(v);
    }
    let mut samples = vec![(x, unit3(mean_normal)?)];
    for &(a, b) in &boundary {
        let (va, vb) = (&vertices[a as usize], &vertices[b as usize]);
        let face = (pos(va) - xv).cross(&(pos(vb) - xv));
        if face.dot(&(nrm(va) + nrm(vb))) <= 0.0 {
            return None;
        }
        let fn_unit = unit3(face)?;
        samples.push((((xv + pos(va) + pos(vb)) / 3.0).into(), fn_unit));
        samples.push((((xv + pos(va)) * 0.5).into(), fn_unit));
    }
    Some((
        NodeFan {
            x,
            rank,
            // The caller's level.
            level: 0,
            boundary,
        },
        samples,
    ))
}

/// `v` normalised, or `None` when it has no direction.
fn unit3(v: Vector3<f64>) -> Option<[f64; 3]> {
    let l = v.norm();
    (l.is_finite() && l > 0.0).then(|| (v / l).into())
}

/// Whether the surface crosses the segment `q - t n .. q + t n` of each sample
/// `(q, n)` (its two ends on opposite sides: the surface is within `t` of `q`).
fn near_surface(tape: &Tape, samples: &[Sample], t: f64) -> Vec<bool> {
    let chunks: Vec<&[Sample]> = samples.chunks(SAMPLE_BATCH).collect();
    par_map(&chunks, |chunk| {
        let mut points: Vec<[f32; 3]> = Vec::with_capacity(2 * chunk.len());
        for (q, d) in chunk.iter() {
            for s in [-t, t] {
                points.push([0, 1, 2].map(|a| (q[a] + s * d[a]) as f32));
            }
        }
        let mut values = vec![0.0f32; points.len()];
        tape.eval_points(&points, &mut values);
        values
            .chunks(2)
            .map(|v| (v[0] < 0.0) != (v[1] < 0.0))
            .collect::<Vec<bool>>()
    })
    .into_iter()
    .flatten()
    .collect()
}

/// A candidate chain collapse: `w` into one of its chain neighbours.
struct ChainCandidate {
    w: u32,
    /// The two fans, `[X1, X2]`.
    fans: [u32; 2],
    /// Each choice: the neighbour `w` goes to, the two triangles that die, and the
    /// two that stay with their new corners.
    choices: Vec<ChainChoice>,
}

struct ChainChoice {
    to: u32,
    dies: [u32; 2],
    stays: [(u32, [u32; 3]); 2],
    samples: [Sample; 3],
}

/// Step 2 of the module docs on the final mesh; `smooth` marks the vertices of smooth
/// fans (QEF rank 1 or less). Returns how many vertices it removed.
pub(crate) fn collapse_chains(
    tape: &Tape,
    vertices: &[MeshVertex],
    triangles: &mut Vec<[u32; 3]>,
    smooth: &[bool],
    distance: f64,
) -> usize {
    let mut vt: Vec<Vec<u32>> = vec![Vec::new(); vertices.len()];
    for (k, t) in triangles.iter().enumerate() {
        for &v in t {
            vt[v as usize].push(k as u32);
        }
    }
    let mut alive = vec![true; triangles.len()];
    let p = |i: u32| pos(&vertices[i as usize]);
    let mut removed = 0;
    for _ in 0..CHAIN_PASSES {
        let mut locked = vec![false; vertices.len()];
        let mut candidates: Vec<ChainCandidate> = Vec::new();
        for w in 0..vertices.len() as u32 {
            if smooth[w as usize] || locked[w as usize] || vt[w as usize].len() != 4 {
                continue;
            }
            let Some(ring) = ring4(triangles, &vt[w as usize], w) else {
                continue;
            };
            let is_fan = |v: u32| smooth[v as usize];
            let (x1, x2, u, z) = if is_fan(ring[0]) && is_fan(ring[2]) {
                (ring[0], ring[2], ring[1], ring[3])
            } else if is_fan(ring[1]) && is_fan(ring[3]) {
                (ring[1], ring[3], ring[0], ring[2])
            } else {
                continue;
            };
            if is_fan(u) || is_fan(z) || locked[u as usize] || locked[z as usize] {
                continue;
            }
            // The link condition: u and z not yet joined.
            if vt[u as usize]
                .iter()
                .any(|&k| triangles[k as usize].contains(&z))
            {
                continue;
            }
            if vt[x1 as usize].len() < 4 || vt[x2 as usize].len() < 4 {
                continue;
            }
            let mut choices = Vec::new();
            for (to, other) in [(u, z), (z, u)] {
                let ts = &vt[w as usize];
                let (dies, stays): (Vec<u32>, Vec<u32>) = ts
                    .iter()
                    .partition(|&&k| triangles[k as usize].contains(&to));
                if dies.len() != 2 || stays.len() != 2 {
                    continue;
                }
                let mut ok = true;
                let mut samples = Vec::with_capacity(3);
                let mut new = Vec::with_capacity(2);
                for &k in &stays {
                    let old = triangles[k as usize];
                    let t = old.map(|v| if v == w { to } else { v });
                    let face = |f: [u32; 3]| (p(f[1]) - p(f[0])).cross(&(p(f[2]) - p(f[0])));
                    let (fo, fnew) = (face(old), face(t));
                    let hermite: Vector3<f64> = t
                        .iter()
                        .filter(|&&v| !smooth[v as usize])
                        .map(|&v| nrm(&vertices[v as usize]))
                        .sum();
                    match unit3(fnew) {
                        Some(d) if fnew.dot(&fo) > 0.0 && fnew.dot(&hermite) > 0.0 => {
                            samples.push((((p(t[0]) + p(t[1]) + p(t[2])) / 3.0).into(), d));
                        }
                        _ => ok = false,
                    }
                    new.push((k, t));
                }
                let mid = (p(to) + p(other)) * 0.5;
                let along: Vector3<f64> =
                    nrm(&vertices[to as usize]) + nrm(&vertices[other as usize]);
                match unit3(along) {
                    Some(d) if ok => samples.push((mid.into(), d)),
                    _ => ok = false,
                }
                if ok {
                    choices.push(ChainChoice {
                        to,
                        dies: [dies[0], dies[1]],
                        stays: [new[0], new[1]],
                        samples: [samples[0], samples[1], samples[2]],
                    });
                }
            }
            if choices.is_empty() {
                continue;
            }
            for v in [w, u, z] {
                locked[v as usize] = true;
            }
            candidates.push(ChainCandidate {
                w,
                fans: [x1, x2],
                choices,
            });
        }
        let samples: Vec<Sample> = candidates
            .iter()
            .flat_map(|c| c.choices.iter().flat_map(|ch| ch.samples))
            .collect();
        let near = near_surface(tape, &samples, distance);
        let mut at = 0;
        let mut changed = 0;
        for c in candidates {
            let mut pick = None;
            for ch in &c.choices {
                if pick.is_none() && near[at..at + 3].iter().all(|&b| b) {
                    pick = Some(ch);
                }
                at += 3;
            }
            let Some(ch) = pick else { continue };
            if c.fans.iter().any(|&x| vt[x as usize].len() < 4) {
                continue;
            }
            for &k in &ch.dies {
                alive[k as usize] = false;
                for v in triangles[k as usize] {
                    vt[v as usize].retain(|&j| j != k);
                }
            }
            for &(k, t) in &ch.stays {
                triangles[k as usize] = t;
                vt[ch.to as usize].push(k);
            }
            vt[c.w as usize].clear();
            changed += 1;
        }
        removed += changed;
        if changed == 0 {
            break;
        }
    }
    let mut k = 0;
    triangles.retain(|_| {
        k += 1;
        alive[k - 1]
    });
    removed
}

/// The four neighbours of `w` in order around it, from its four triangles `ts`.
fn ring4(triangles: &[[u32; 3]], ts: &[u32], w: u32) -> Option<[u32; 4]> {
    let mut next: Vec<(u32, u32)> = Vec::with_capacity(4);
    for &k in ts {
        let t = triangles[k as usize];
        let r = t.iter().position(|&v| v == w)?;
        next.push((t[(r + 1) % 3], t[(r + 2) % 3]));
    }
    let mut ring = [next[0].0; 4];
    for i in 1..4 {
        let prev = ring[i - 1];
        ring[i] = next.iter().find(|e| e.0 == prev)?.1;
    }
    let last = next.iter().find(|e| e.0 == ring[3])?.1;
    (last == ring[0]).then_some(ring)
}
