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
