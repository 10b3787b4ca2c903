//! Mesh sinks: where tessellation writes its triangles.
//!
//! Like lyon's `GeometryBuilder`, the core never owns GPU buffers. Tessellators write
//! indexed triangles, patch by patch, into a [`MeshSink`]. A patch is one independently
//! re-tessellated piece (for example one quadtree region of one surface), named by a
//! [`PatchKey`], so that after an edit only the patches that changed are written again
//! and a GPU-side sink can upload only those.

/// Identifies one patch of output geometry across re-tessellations.
pub type PatchKey = u64;

/// One mesh vertex, in the display frame (metres), with a unit normal and the surface
/// parameter it came from.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[repr(C)]
pub struct MeshVertex {
    /// Position in the display frame, metres.
    pub position: [f32; 3],
    /// Unit outward normal.
    pub normal: [f32; 3],
    /// Surface parameter (u, v) of the owning surface, normalised to [0, 1].
    pub uv: [f32; 2],
}

/// Receives tessellated geometry, one patch at a time.
///
/// The protocol: `begin_patch(key)`, then any number of `push_vertex` and
/// `push_triangle` calls whose indices are local to the patch, then `end_patch()`.
/// Beginning a key that already exists replaces that patch. `remove_patch(key)` drops
/// a patch that no longer exists.
pub trait MeshSink {
    /// Starts (or restarts, replacing its old contents) the patch `key`.
    fn begin_patch(&mut self, key: PatchKey);
    /// Adds a vertex to the current patch and returns its patch-local index.
    fn push_vertex(&mut self, vertex: MeshVertex) -> u32;
    /// Adds a triangle of patch-local vertex indices, counter-clockwise seen from the
    /// side the normals point to.
    fn push_triangle(&mut self, a: u32, b: u32, c: u32);
    /// Finishes the current patch.
    fn end_patch(&mut self);
    /// Removes a patch that is no longer part of the output.
    fn remove_patch(&mut self, key: PatchKey);
    /// Tints every vertex written into this sink, now and later, by `tint` of its
    /// position (`None`: no tint, the surface's own colour). A sink without colours
    /// ignores it (the default).
    fn set_tint(&mut self, tint: Option<Tint>) {
        let _ = tint;
    }
}

/// A tint as [`MeshSink::set_tint`] takes it: a box of the display frame and a
/// function of position (display frame metres) to `[r, g, b, a]`, linear RGB blended
/// over the surface's own albedo by `a` in `[0, 1]`, zero outside the box (e.g. the
/// painted colour fields, `sculpt_core::paint::PaintShading::into_tint`). Clones
/// share the function ([`Tint::same`]).
#[derive(Clone)]
pub struct Tint {
    /// The box's least corner.
    pub lo: [f32; 3],
    /// Its greatest corner.
    pub hi: [f32; 3],
    /// The tint at a point of the box.
    pub at: std::sync::Arc<dyn Fn([f32; 3]) -> [f32; 4] + Send + Sync>,
}

impl Tint {
    /// Whether `self` and `other` are clones of one tint.
    pub fn same(&self, other: &Tint) -> bool {
        std::sync::Arc::ptr_eq(&self.at, &other.at)
    }
}

impl std::fmt::Debug for Tint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Tint")
            .field("lo", &self.lo)
            .field("hi", &self.hi)
            .finish_non_exhaustive()
    }
}

/// A plain indexed triangle mesh, one entry per patch, that collects what a
/// tessellator writes. Useful for export and tests.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PatchMesh {
    patches: std::collections::BTreeMap<PatchKey, Patch>,
    current: Option<PatchKey>,
}

/// The geometry of one patch.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Patch {
    /// Vertices of this patch.
    pub vertices: Vec<MeshVertex>,
    /// Triangles as patch-local vertex indices.
    pub triangles: Vec<[u32; 3]>,
}

impl PatchMesh {
    /// An empty mesh.
    pub fn new() -> Self {
        Self::default()
    }

    /// The patches, ordered by key.
    pub fn patches(&self) -> impl Iterator<Item = (PatchKey, &Patch)> {
        self.patches.iter().map(|(k, p)| (*k, p))
    }

    /// Total triangle count over all patches.
    pub fn triangle_count(&self) -> usize {
        self.patches.values().map(|p| p.triangles.len()).sum()
    }

    /// All patches merged into one vertex list and one index list (patch order by key).
    pub fn merged(&self) -> (Vec<MeshVertex>, Vec<[u32; 3]>) {
        let mut vertices = Vec::new();
        let mut triangles = Vec::new();
        for patch in self.patches.values() {
            let base = vertices.len() as u32;
            vertices.extend_from_slice(&patch.vertices);
            triangles.extend(patch.triangles.iter().map(|t| t.map(|i| i + base)));
        }
        (vertices, triangles)
    }
}

impl MeshSink for PatchMesh {
    fn begin_patch(&mut self, key: PatchKey) {
        self.patches.insert(key, Patch::default());
        self.current = Some(key);
    }

    fn push_vertex(&mut self, vertex: MeshVertex) -> u32 {
        let patch = self.current_patch();
        patch.vertices.push(vertex);
        (patch.vertices.len() - 1) as u32
    }

    fn push_triangle(&mut self, a: u32, b: u32, c: u32) {
        self.current_patch().triangles.push([a, b, c]);
    }

    fn end_patch(&mut self) {
        self.current = None;
    }

    fn remove_patch(&mut self, key: PatchKey) {
        self.patches.remove(&key);
    }
}

impl PatchMesh {
    /// The patch being written; writing outside `begin_patch`/`end_patch` goes to
    /// patch key `u64::MAX` rather than being lost.
    fn current_patch(&mut self) -> &mut Patch {
        let key = *self.current.get_or_insert(PatchKey::MAX);
        self.patches.entry(key).or_default()
    }
}

/// A mesh with coincident vertices merged, for export and topology checks.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct WeldedMesh {
    /// Unique vertices (the first vertex seen at each position keeps its normal and uv).
    pub vertices: Vec<MeshVertex>,
    /// Triangles; those that collapsed to a line or point are dropped.
    pub triangles: Vec<[u32; 3]>,
}

/// The edge topology of a welded mesh.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EdgeReport {
    /// Undirected edges.
    pub edges: usize,
    /// Edges used by one triangle only (holes and cracks).
    pub boundary: usize,
    /// Edges used by three or more triangles.
    pub non_manifold: usize,
    /// Interior edges whose two triangles run it the same way (flipped orientation).
    pub misoriented: usize,
}

impl EdgeReport {
    /// Every edge shared by exactly two triangles, consistently oriented.
    pub fn is_watertight(&self) -> bool {
        self.boundary == 0 && self.non_manifold == 0 && self.misoriented == 0
    }
}

impl PatchMesh {
    /// Merges vertices closer than `tol` (a grid hash with neighbour lookup) and drops
    /// triangles that collapse.
    pub fn welded(&self, tol: f32) -> WeldedMesh {
        let (verts, tris) = self.merged();
        weld(&verts, &tris, tol)
    }

    /// The nearest hit of the ray `origin + t dir` (`t > 0`) with any triangle
    /// (Moller-Trumbore), as `t`.
    pub fn first_hit(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<f64> {
        let mut best: Option<f64> = None;
        for patch in self.patches.values() {
            for t in &patch.triangles {
                let p = t.map(|i| {
                    let v = patch.vertices[i as usize].position;
                    [f64::from(v[0]), f64::from(v[1]), f64::from(v[2])]
                });
                if let Some(d) = ray_triangle(origin, dir, p)
                    && best.is_none_or(|b| d < b)
                {
                    best = Some(d);
                }
            }
        }
        best
    }
}

/// Merges vertices of an indexed mesh closer than `tol`, dropping collapsed triangles.
pub fn weld(verts: &[MeshVertex], tris: &[[u32; 3]], tol: f32) -> WeldedMesh {
    use std::collections::HashMap;
    let tol = tol.max(f32::MIN_POSITIVE);
    let cell = |p: [f32; 3]| p.map(|x| (x / tol).floor() as i64);
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    let mut out = WeldedMesh::default();
    let mut remap = Vec::with_capacity(verts.len());
    for v in verts {
        let c = cell(v.position);
        let mut found = None;
        'search: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(list) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) {
                        for &k in list {
                            let q = out.vertices[k as usize].position;
                            let d2: f32 = (0..3).map(|i| (q[i] - v.position[i]).powi(2)).sum();
                            if d2 <= tol * tol {
                                found = Some(k);
                                break 'search;
                            }
                        }
                    }
                }
            }
        }
        let k = found.unwrap_or_else(|| {
            out.vertices.push(*v);
            let k = (out.vertices.len() - 1) as u32;
            grid.entry(c).or_default().push(k);
            k
        });
        remap.push(k);
    }
    for t in tris {
        let [a, b, c] = t.map(|i| remap[i as usize]);
        if a != b && b != c && a != c {
            out.triangles.push([a, b, c]);
        }
    }
    out
}

impl WeldedMesh {
    /// The connected pieces of the mesh (triangles joined through shared vertices).
    pub fn bodies(&self) -> usize {
        let mut parent: Vec<u32> = (0..self.vertices.len() as u32).collect();
        fn root(parent: &mut [u32], x: u32) -> u32 {
            let mut r = x;
            while parent[r as usize] != r {
                parent[r as usize] = parent[parent[r as usize] as usize];
                r = parent[r as usize];
            }
            r
        }
        for t in &self.triangles {
            for k in 0..2 {
                let (a, b) = (root(&mut parent, t[k]), root(&mut parent, t[k + 1]));
                parent[a as usize] = b;
            }
        }
        let mut roots: Vec<u32> = self
            .triangles
            .iter()
            .map(|t| root(&mut parent, t[0]))
            .collect();
        roots.sort_unstable();
        roots.dedup();
        roots.len()
    }

    /// The Euler characteristic `V - E + F` over the vertices the triangles use
    /// (`2 - 2g` for a closed surface of genus `g`, summed over its bodies).
    pub fn euler_characteristic(&self) -> i64 {
        let mut used = vec![false; self.vertices.len()];
        for t in &self.triangles {
            for &k in t {
                used[k as usize] = true;
            }
        }
        let v = used.iter().filter(|&&u| u).count() as i64;
        v - self.edge_report().edges as i64 + self.triangles.len() as i64
    }

    /// Counts boundary, non-manifold and misoriented edges.
    pub fn edge_report(&self) -> EdgeReport {
        use std::collections::HashMap;
        // (min, max) -> (uses, directed uses from min to max)
        let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
        for t in &self.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let e = edges.entry((a.min(b), a.max(b))).or_default();
                e.0 += 1;
                if a < b {
                    e.1 += 1;
                }
            }
        }
        let mut r = EdgeReport {
            edges: edges.len(),
            ..Default::default()
        };
        for (uses, forward) in edges.values() {
            match uses {
                1 => r.boundary += 1,
                2 if *forward != 1 => r.misoriented += 1,
                2 => {}
                _ => r.non_manifold += 1,
            }
        }
        r
    }
}

fn ray_triangle(o: [f64; 3], d: [f64; 3], p: [[f64; 3]; 3]) -> Option<f64> {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let (e1, e2) = (sub(p[1], p[0]), sub(p[2], p[0]));
    let h = cross(d, e2);
    let a = dot(e1, h);
    if a.abs() < crate::tolerance::RAY_PARALLEL_EPS {
        return None;
    }
    let f = 1.0 / a;
    let s = sub(o, p[0]);
    let u = f * dot(s, h);
    if !(-crate::tolerance::BARYCENTRIC_EPS..=1.0 + crate::tolerance::BARYCENTRIC_EPS).contains(&u)
    {
        return None;
    }
    let q = cross(s, e1);
    let v = f * dot(d, q);
    if v < -crate::tolerance::BARYCENTRIC_EPS || u + v > 1.0 + crate::tolerance::BARYCENTRIC_EPS {
        return None;
    }
    let t = f * dot(e2, q);
    (t > crate::tolerance::RAY_T_MIN).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f32) -> MeshVertex {
        MeshVertex {
            position: [x, 0.0, 0.0],
            ..Default::default()
        }
    }

    #[test]
    fn patches_replace_and_merge() {
        let mut m = PatchMesh::new();
        m.begin_patch(1);
        let a = m.push_vertex(v(0.0));
        let b = m.push_vertex(v(1.0));
        let c = m.push_vertex(v(2.0));
        m.push_triangle(a, b, c);
        m.end_patch();
        m.begin_patch(2);
        let a = m.push_vertex(v(3.0));
        m.push_triangle(a, a, a);
        m.end_patch();
        assert_eq!(m.triangle_count(), 2);
        let (verts, tris) = m.merged();
        assert_eq!(verts.len(), 4);
        assert_eq!(tris[1], [3, 3, 3]);
        // Re-beginning a patch replaces it.
        m.begin_patch(1);
        m.end_patch();
        assert_eq!(m.triangle_count(), 1);
        m.remove_patch(2);
        assert_eq!(m.triangle_count(), 0);
    }
}
