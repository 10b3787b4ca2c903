//! GPU-side mesh storage: a [`MeshSink`] that keeps each patch on the CPU and packs
//! patches into GPU batches, so that re-tessellating a patch re-uploads only its batch
//! and a frame needs one draw call per batch, not per patch.
//!
//! A batch holds the patches whose keys share all but the low [`BATCH_SHIFT`] bits (the
//! tessellator numbers a target's root cells consecutively, so a batch is up to 64
//! neighbouring cells). Writes only mark batches dirty; [`GpuMeshStore::flush`] (called
//! by the renderer before drawing) rebuilds the dirty ones.

use std::collections::{BTreeMap, BTreeSet};

use bytemuck::{Pod, Zeroable};
use sculpt_core::mesh::{MeshSink, MeshVertex, PatchKey, Tint};
use wgpu::util::DeviceExt;

pub use crate::scene::BATCH_SHIFT;

fn batch_of(key: PatchKey) -> u64 {
    key >> BATCH_SHIFT
}

/// The GPU vertex layout (same fields as [`MeshVertex`], 32 bytes).
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct GpuVertex {
    /// Position, display frame metres.
    pub position: [f32; 3],
    /// Unit normal.
    pub normal: [f32; 3],
    /// Surface parameter.
    pub uv: [f32; 2],
}

impl GpuVertex {
    /// The vertex buffer layout for the mesh pipelines.
    pub const LAYOUT: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<GpuVertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x2],
    };
}

/// One uploaded batch of patches.
#[derive(Debug)]
pub struct GpuPatch {
    /// Vertex buffer.
    pub vertices: wgpu::Buffer,
    /// Triangle index buffer (u32).
    pub triangles: wgpu::Buffer,
    /// Number of triangle indices.
    pub triangle_index_count: u32,
    /// Edge index buffer (u32 pairs) for the wireframe.
    pub edges: wgpu::Buffer,
    /// Number of edge indices.
    pub edge_index_count: u32,
}

/// Upload counters, to check that only changed patches reach the GPU.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct UploadStats {
    /// Patches written since creation (each marks its batch for re-upload).
    pub patch_uploads: u64,
    /// Batches uploaded since creation.
    pub batch_uploads: u64,
    /// Bytes uploaded since creation.
    pub bytes: u64,
}

#[derive(Debug, Default)]
struct CpuPatch {
    vertices: Vec<GpuVertex>,
    triangles: Vec<[u32; 3]>,
}

/// A set of patches on the GPU, written through [`MeshSink`].
#[derive(Debug)]
pub struct GpuMeshStore {
    device: wgpu::Device,
    patches: BTreeMap<PatchKey, CpuPatch>,
    batches: BTreeMap<u64, GpuPatch>,
    dirty: BTreeSet<u64>,
    current: Option<(PatchKey, Vec<GpuVertex>, Vec<[u32; 3]>)>,
    stats: UploadStats,
    /// The paint drawn over these patches ([`super::paint_texture`]).
    tint: Option<Tint>,
}

impl GpuMeshStore {
    /// An empty store on `device`.
    pub fn new(device: &wgpu::Device) -> Self {
        Self {
            device: device.clone(),
            patches: BTreeMap::new(),
            batches: BTreeMap::new(),
            dirty: BTreeSet::new(),
            current: None,
            stats: UploadStats::default(),
            tint: None,
        }
    }

    /// The uploaded batches, for drawing (call [`Self::flush`] first).
    pub fn batches(&self) -> impl Iterator<Item = &GpuPatch> {
        self.batches.values()
    }

    /// The uploaded batches with their batch numbers (a patch key shifted right by
    /// [`BATCH_SHIFT`]), in key order.
    pub fn keyed_batches(&self) -> impl Iterator<Item = (u64, &GpuPatch)> {
        self.batches.iter().map(|(&k, p)| (k, p))
    }

    /// The keys of the patches held.
    pub fn keys(&self) -> impl Iterator<Item = PatchKey> + '_ {
        self.patches.keys().copied()
    }

    /// Number of patches.
    pub fn len(&self) -> usize {
        self.patches.len()
    }

    /// True when there are no patches.
    pub fn is_empty(&self) -> bool {
        self.patches.is_empty()
    }

    /// Total triangles over all patches.
    pub fn triangle_count(&self) -> u64 {
        self.patches
            .values()
            .map(|p| p.triangles.len() as u64)
            .sum()
    }

    /// The paint drawn over the patches, if any ([`MeshSink::set_tint`]).
    pub fn tint(&self) -> Option<&Tint> {
        self.tint.as_ref()
    }

    /// Upload counters.
    pub fn stats(&self) -> UploadStats {
        self.stats
    }

    /// Removes every patch.
    pub fn clear(&mut self) {
        self.patches.clear();
        self.batches.clear();
        self.dirty.clear();
        self.current = None;
        self.tint = None;
    }

    fn store(&mut self, key: PatchKey, vertices: Vec<GpuVertex>, triangles: Vec<[u32; 3]>) {
        // Drop triangles that index past the patch or touch a non-finite vertex: bad
        // input must not reach the GPU.
        let n = vertices.len() as u32;
        let finite: Vec<bool> = vertices
            .iter()
            .map(|v| v.position.iter().chain(&v.normal).all(|c| c.is_finite()))
            .collect();
        let triangles: Vec<[u32; 3]> = triangles
            .into_iter()
            .filter(|t| t.iter().all(|&i| i < n && finite[i as usize]))
            .collect();
        self.dirty.insert(batch_of(key));
        if triangles.is_empty() {
            self.patches.remove(&key);
            return;
        }
        self.stats.patch_uploads += 1;
        self.patches.insert(
            key,
            CpuPatch {
                vertices,
                triangles,
            },
        );
    }

    /// Rebuilds and uploads the batches whose patches changed since the last flush.
    pub fn flush(&mut self) {
        if let Some((k, v, t)) = self.current.take() {
            self.store(k, v, t);
        }
        for batch in std::mem::take(&mut self.dirty) {
            let lo = batch << BATCH_SHIFT;
            let hi = lo | ((1u64 << BATCH_SHIFT) - 1);
            let mut vertices: Vec<GpuVertex> = Vec::new();
            let mut triangles: Vec<[u32; 3]> = Vec::new();
            for p in self.patches.range(lo..=hi).map(|(_, p)| p) {
                let base = vertices.len() as u32;
                vertices.extend_from_slice(&p.vertices);
                triangles.extend(p.triangles.iter().map(|t| t.map(|i| i + base)));
            }
            if triangles.is_empty() {
                self.batches.remove(&batch);
                continue;
            }
            let mut edges: Vec<[u32; 2]> = triangles
                .iter()
                .flat_map(|t| [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]])
                .map(|[a, b]| if a < b { [a, b] } else { [b, a] })
                .collect();
            edges.sort_unstable();
            edges.dedup();
            let make = |label: &str, bytes: &[u8], usage| {
                self.device
                    .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some(label),
                        contents: bytes,
                        usage,
                    })
            };
            let vb = bytemuck::cast_slice::<GpuVertex, u8>(&vertices);
            let tb = bytemuck::cast_slice::<[u32; 3], u8>(&triangles);
            let eb = bytemuck::cast_slice::<[u32; 2], u8>(&edges);
            let gpu = GpuPatch {
                vertices: make("batch vertices", vb, wgpu::BufferUsages::VERTEX),
                triangles: make("batch triangles", tb, wgpu::BufferUsages::INDEX),
                triangle_index_count: (triangles.len() * 3) as u32,
                edges: make("batch edges", eb, wgpu::BufferUsages::INDEX),
                edge_index_count: (edges.len() * 2) as u32,
            };
            self.stats.batch_uploads += 1;
            self.stats.bytes += (vb.len() + tb.len() + eb.len()) as u64;
            self.batches.insert(batch, gpu);
        }
    }
}

impl MeshSink for GpuMeshStore {
    fn begin_patch(&mut self, key: PatchKey) {
        if let Some((k, v, t)) = self.current.take() {
            self.store(k, v, t);
        }
        self.current = Some((key, Vec::new(), Vec::new()));
    }

    fn push_vertex(&mut self, vertex: MeshVertex) -> u32 {
        let cur = self
            .current
            .get_or_insert_with(|| (PatchKey::MAX, Vec::new(), Vec::new()));
        cur.1.push(GpuVertex {
            position: vertex.position,
            normal: vertex.normal,
            uv: vertex.uv,
        });
        (cur.1.len() - 1) as u32
    }

    fn push_triangle(&mut self, a: u32, b: u32, c: u32) {
        let cur = self
            .current
            .get_or_insert_with(|| (PatchKey::MAX, Vec::new(), Vec::new()));
        cur.2.push([a, b, c]);
    }

    fn end_patch(&mut self) {
        if let Some((k, v, t)) = self.current.take() {
            self.store(k, v, t);
        }
    }

    fn remove_patch(&mut self, key: PatchKey) {
        if self.patches.remove(&key).is_some() {
            self.dirty.insert(batch_of(key));
        }
    }

    fn set_tint(&mut self, tint: Option<Tint>) {
        self.tint = tint;
    }
}
