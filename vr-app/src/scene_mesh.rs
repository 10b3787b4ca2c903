//! Turns the scene document into triangles through [`MeshSink`]: each target surface
//! and each stroke is one patch, so an edit rewrites only its own patch.
//!
//! Targets are tessellated from their point grids, refined by Catmull-Rom
//! interpolation through the grid points (`refine` segments per grid cell), with
//! normals from the interpolant's partial derivatives. Strokes are drawn as their tool
//! footprint: a ribbon `width` wide along the wand path, lifted off the target by half
//! the tool depth for emboss and sunk by it for carve.

use glam::DVec3;
use sculpt_core::interaction::{StrokeEdit, StrokeMode};
use sculpt_core::mesh::{MeshSink, MeshVertex, PatchKey};

/// Patch keys of targets start here; strokes use `STROKE_KEY_BASE + index`.
pub const TARGET_KEY_BASE: PatchKey = 0;
/// First stroke patch key.
pub const STROKE_KEY_BASE: PatchKey = 1 << 32;

fn catmull_rom(p0: DVec3, p1: DVec3, p2: DVec3, p3: DVec3, t: f64) -> (DVec3, DVec3) {
    let t2 = t * t;
    let t3 = t2 * t;
    let pos = 0.5
        * ((2.0 * p1)
            + (-p0 + p2) * t
            + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t2
            + (-p0 + 3.0 * p1 - 3.0 * p2 + p3) * t3);
    let d = 0.5
        * ((-p0 + p2)
            + 2.0 * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t
            + 3.0 * (-p0 + 3.0 * p1 - 3.0 * p2 + p3) * t2);
    (pos, d)
}

/// Interpolates one row (or column) of points at parameter `s` in `[0, n-1]`.
fn curve(points: &[DVec3], s: f64) -> (DVec3, DVec3) {
    let n = points.len();
    if n == 1 {
        return (points[0], DVec3::ZERO);
    }
    let i = (s.floor() as usize).min(n - 2);
    let t = s - i as f64;
    let at = |k: isize| points[k.clamp(0, n as isize - 1) as usize];
    let i = i as isize;
    catmull_rom(at(i - 1), at(i), at(i + 1), at(i + 2), t)
}

/// Writes a point-grid surface as patch `key`, `refine` segments per grid cell.
/// Grids with fewer than 2 rows or columns, ragged rows or non-finite points are
/// skipped (the patch is removed).
pub fn write_grid_surface(
    grid: &[Vec<DVec3>],
    refine: u32,
    key: PatchKey,
    sink: &mut dyn MeshSink,
) {
    let rows = grid.len();
    let cols = grid.first().map_or(0, Vec::len);
    let ok = rows >= 2
        && cols >= 2
        && grid
            .iter()
            .all(|r| r.len() == cols && r.iter().all(|p| p.is_finite()));
    if !ok {
        sink.remove_patch(key);
        return;
    }
    let refine = refine.clamp(1, 16) as usize;
    let (nu, nv) = ((cols - 1) * refine + 1, (rows - 1) * refine + 1);
    sink.begin_patch(key);
    for iv in 0..nv {
        let sv = iv as f64 / refine as f64;
        // Interpolate each grid column at sv, then along the resulting row.
        let column_points: Vec<(DVec3, DVec3)> = (0..cols)
            .map(|c| {
                let col: Vec<DVec3> = grid.iter().map(|r| r[c]).collect();
                curve(&col, sv)
            })
            .collect();
        let row: Vec<DVec3> = column_points.iter().map(|p| p.0).collect();
        let row_dv: Vec<DVec3> = column_points.iter().map(|p| p.1).collect();
        for iu in 0..nu {
            let su = iu as f64 / refine as f64;
            let (p, du) = curve(&row, su);
            let (dv, _) = curve(&row_dv, su);
            let n = du.cross(dv);
            let n = if n.length_squared() > 1e-24 {
                n.normalize()
            } else {
                DVec3::Z
            };
            sink.push_vertex(MeshVertex {
                position: p.as_vec3().to_array(),
                normal: n.as_vec3().to_array(),
                uv: [
                    (iu as f64 / (nu - 1) as f64) as f32,
                    (iv as f64 / (nv - 1) as f64) as f32,
                ],
            });
        }
    }
    for iv in 0..nv - 1 {
        for iu in 0..nu - 1 {
            let a = (iv * nu + iu) as u32;
            let b = a + 1;
            let c = a + nu as u32;
            let d = c + 1;
            sink.push_triangle(a, b, c);
            sink.push_triangle(b, d, c);
        }
    }
    sink.end_patch();
}

/// Writes a stroke's footprint ribbon as patch `key`. `facing` is the direction the
/// target faces (towards the viewer).
pub fn write_stroke(stroke: &StrokeEdit, facing: DVec3, key: PatchKey, sink: &mut dyn MeshSink) {
    let pts: Vec<DVec3> = stroke
        .samples
        .iter()
        .map(|s| s.position)
        .filter(|p| p.is_finite())
        .collect();
    let facing = if facing.is_finite() && facing.length_squared() > 0.0 {
        facing.normalize()
    } else {
        DVec3::Z
    };
    if pts.len() < 2 || !(stroke.tool.width.is_finite() && stroke.tool.width > 0.0) {
        sink.remove_patch(key);
        return;
    }
    let half = 0.5 * stroke.tool.width;
    let lift = match stroke.mode {
        StrokeMode::Carve => -0.5 * stroke.tool.depth,
        StrokeMode::Emboss => 0.5 * stroke.tool.depth,
    };
    sink.begin_patch(key);
    let mut across_prev = DVec3::X;
    for (i, p) in pts.iter().enumerate() {
        let tangent = pts[(i + 1).min(pts.len() - 1)] - pts[i.saturating_sub(1)];
        let across = tangent.cross(facing);
        let across = if across.length_squared() > 1e-18 {
            across.normalize()
        } else {
            across_prev
        };
        across_prev = across;
        let c = *p + facing * lift;
        for side in [-1.0, 1.0] {
            sink.push_vertex(MeshVertex {
                position: (c + across * side * half).as_vec3().to_array(),
                normal: facing.as_vec3().to_array(),
                uv: [i as f32 / (pts.len() - 1) as f32, (side as f32 + 1.0) * 0.5],
            });
        }
    }
    for i in 0..pts.len() as u32 - 1 {
        let a = i * 2;
        sink.push_triangle(a, a + 2, a + 1);
        sink.push_triangle(a + 1, a + 2, a + 3);
    }
    sink.end_patch();
}

/// Mesh state of a document: which patches exist, so changes write only what changed.
#[derive(Debug, Clone, Default)]
pub struct SceneMesher {
    targets_written: Vec<[u64; 3]>,
    strokes_written: Vec<[u64; 3]>,
    /// Catmull-Rom segments per grid cell.
    pub refine: u32,
}

/// A cheap identity for a target or stroke: point count and two coordinates' bits.
fn fingerprint(points: impl ExactSizeIterator<Item = DVec3> + Clone) -> [u64; 3] {
    let n = points.len() as u64;
    let first = points.clone().next().unwrap_or(DVec3::ZERO);
    let last = points.last().unwrap_or(DVec3::ZERO);
    [
        n,
        (first.x + first.y * 3.0 + first.z * 7.0).to_bits(),
        (last.x + last.y * 3.0 + last.z * 7.0).to_bits(),
    ]
}

fn sync<T>(
    items: &[T],
    written: &mut Vec<[u64; 3]>,
    key_base: PatchKey,
    sink: &mut dyn MeshSink,
    print: impl Fn(&T) -> [u64; 3],
    mut write: impl FnMut(&T, PatchKey, &mut dyn MeshSink),
) -> usize {
    let mut count = 0;
    for (i, item) in items.iter().enumerate() {
        let fp = print(item);
        if written.get(i) != Some(&fp) {
            write(item, key_base + i as PatchKey, sink);
            count += 1;
            if i < written.len() {
                written[i] = fp;
            } else {
                written.push(fp);
            }
        }
    }
    for i in items.len()..written.len() {
        sink.remove_patch(key_base + i as PatchKey);
    }
    written.truncate(items.len());
    count
}

impl SceneMesher {
    /// A mesher with `refine` segments per grid cell.
    pub fn new(refine: u32) -> Self {
        Self {
            refine,
            ..Default::default()
        }
    }

    /// Brings the sinks up to date with the document: writes patches for new or
    /// replaced targets and strokes and removes patches for undone ones. Returns the
    /// number of patches written.
    pub fn update(
        &mut self,
        doc: &crate::session::SceneDoc,
        facing: DVec3,
        targets: &mut dyn MeshSink,
        strokes: &mut dyn MeshSink,
    ) -> usize {
        let refine = self.refine;
        let t = sync(
            &doc.targets,
            &mut self.targets_written,
            TARGET_KEY_BASE,
            targets,
            |t| {
                fingerprint(
                    t.grid
                        .iter()
                        .flatten()
                        .copied()
                        .collect::<Vec<_>>()
                        .into_iter(),
                )
            },
            |t, key, sink| write_grid_surface(&t.grid, refine, key, sink),
        );
        let s = sync(
            &doc.strokes,
            &mut self.strokes_written,
            STROKE_KEY_BASE,
            strokes,
            |s| fingerprint(s.samples.iter().map(|p| p.position)),
            |s, key, sink| write_stroke(s, facing, key, sink),
        );
        t + s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::session::{SceneDoc, default_target};
    use sculpt_core::assert_near;
    use sculpt_core::interaction::{Edit, StrokeSample, Tool};
    use sculpt_core::mesh::PatchMesh;

    #[test]
    fn grid_surface_interpolates_its_points() {
        let t = default_target(DVec3::new(0.0, 1.0, -0.1));
        let mut m = PatchMesh::new();
        write_grid_surface(&t.grid, 4, 7, &mut m);
        let (v, tris) = m.merged();
        assert_eq!(v.len(), 33 * 33);
        assert_eq!(tris.len(), 32 * 32 * 2);
        // Every 4th vertex is a grid point.
        let p = v[4 * 33 * 2 + 4 * 3].position;
        assert_near!(
            p.map(f64::from).to_vec(),
            t.grid[2][3].to_array().to_vec(),
            1e-6
        );
        // Normals face the viewer (+Z) at the centre.
        let n = v[16 * 33 + 16].normal;
        assert!(n[2] > 0.9, "{n:?}");
        assert!(
            v.iter()
                .all(|x| x.position.iter().chain(&x.normal).all(|c| c.is_finite()))
        );
    }

    #[test]
    fn bad_grids_write_nothing() {
        let mut m = PatchMesh::new();
        write_grid_surface(&[vec![DVec3::ZERO]], 4, 1, &mut m);
        write_grid_surface(&[vec![DVec3::ZERO, DVec3::X], vec![DVec3::Y]], 4, 1, &mut m);
        write_grid_surface(
            &[vec![DVec3::ZERO, DVec3::X], vec![DVec3::Y, DVec3::NAN]],
            4,
            1,
            &mut m,
        );
        assert_eq!(m.triangle_count(), 0);
    }

    fn stroke_edit(n: usize) -> StrokeEdit {
        StrokeEdit {
            target: 0,
            mode: StrokeMode::Carve,
            tool: Tool::default(),
            samples: (0..n)
                .map(|i| StrokeSample {
                    t: i as f64,
                    position: DVec3::new(i as f64 * 0.01, 0.0, 0.0),
                })
                .collect(),
        }
    }

    #[test]
    fn mesher_writes_only_new_patches_and_removes_undone() {
        let mut doc = SceneDoc::new(default_target(DVec3::ZERO));
        let (mut t, mut s) = (PatchMesh::new(), PatchMesh::new());
        let mut mesher = SceneMesher::new(2);
        assert_eq!(mesher.update(&doc, DVec3::Z, &mut t, &mut s), 1);
        doc.apply(&Edit::Stroke(stroke_edit(5)));
        assert_eq!(
            mesher.update(&doc, DVec3::Z, &mut t, &mut s),
            1,
            "only the new stroke"
        );
        assert_eq!(s.triangle_count(), 8);
        doc.apply(&Edit::Undo);
        assert_eq!(mesher.update(&doc, DVec3::Z, &mut t, &mut s), 0);
        assert_eq!(s.triangle_count(), 0);
        // Regression: undo followed by a different stroke at the same index, seen in one
        // update, must rewrite the patch (it was keyed by position only).
        let mut other = stroke_edit(3);
        doc.apply(&Edit::Stroke(other.clone()));
        mesher.update(&doc, DVec3::Z, &mut t, &mut s);
        doc.apply(&Edit::Undo);
        other.samples.push(StrokeSample {
            t: 9.0,
            position: DVec3::new(0.5, 0.0, 0.0),
        });
        doc.apply(&Edit::Stroke(other));
        assert_eq!(mesher.update(&doc, DVec3::Z, &mut t, &mut s), 1);
        assert_eq!(s.triangle_count(), 6);
    }
}
