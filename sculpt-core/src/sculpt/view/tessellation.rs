//! A view's tessellation of its document into sinks, at each detail, alone or as a
//! conforming patch network: only what changed since the last call is written.

use super::DocumentView;
use crate::mesh::MeshSink;
use crate::nurbs::NurbsSurface;
use crate::sculpt::conform::{NetworkPlan, write_network_with};
use crate::sculpt::document::{
    ConformState, Document, TargetId, conform_key, fixed_sides, grid_of,
};
use crate::sculpt::tessellate::{Detail, TargetTessellation, TessStats};

impl DocumentView {
    /// Brings `sink` up to date at `detail`: the first call writes every patch, later
    /// calls only the patches changed since (strokes applied, undone or redone; targets
    /// added or removed, deformed; the preview), as `doc` records them. Use one sink per
    /// detail.
    pub fn tessellate(
        &mut self,
        doc: &Document,
        detail: Detail,
        sink: &mut dyn MeshSink,
    ) -> TessStats {
        self.sync(doc, detail);
        let mut stats = TessStats::default();
        self.removed.retain(|(d, keys)| {
            if *d == detail {
                for &k in keys {
                    sink.remove_patch(k);
                }
                false
            } else {
                true
            }
        });
        let conformal = self.conform_pass(doc, detail, sink, &mut stats);
        for (k, t) in doc.targets().iter().enumerate() {
            if conformal.get(k) == Some(&true) {
                continue;
            }
            let key = (t.id, detail);
            let changed = self.dirty.remove(&key);
            // A carved network patch's view is made by the conform pass: fresh until
            // its first update.
            let fresh = self
                .views
                .get(&key)
                .is_none_or(TargetTessellation::is_fresh);
            if !fresh && !changed {
                stats.triangles_total += self.views[&key].triangle_count();
                continue;
            }
            let plan = grid_of(&self.grids, t, detail);
            let view = self.views.entry(key).or_insert_with(|| {
                TargetTessellation::with_grid(&t.surface, k as u32, detail, &plan)
            });
            let strokes = doc.strokes_at(&self.preview, t.id, detail);
            let s = view.update_strokes(&t.surface, &strokes, sink);
            stats.patches_written += s.patches_written;
            stats.triangles_written += s.triangles_written;
            stats.triangles_total += s.triangles_total;
        }
        stats
    }

    /// Writes the network's patches that need it ([`Document::conformal`] targets not yet
    /// in the sink), removes the per-target patches of targets that became conformal
    /// and the conforming patches of those that no longer are. Returns
    /// [`Document::conformal`].
    pub(crate) fn conform_pass(
        &mut self,
        doc: &Document,
        detail: Detail,
        sink: &mut dyn MeshSink,
        stats: &mut TessStats,
    ) -> Vec<bool> {
        let ids: Vec<(TargetId, u64)> = doc
            .targets()
            .iter()
            .map(|t| (t.id, doc.target_revision(t.id).map_or(0, |r| r.geometry)))
            .collect();
        if self.conform.get(&detail).is_none_or(|c| c.ids != ids) {
            if let Some(old) = self.conform.remove(&detail) {
                for (k, w) in old.written.iter().enumerate() {
                    if w.is_some() {
                        sink.remove_patch(conform_key(k));
                    }
                }
            }
            let network = doc.network();
            let plan = if network.is_empty() {
                NetworkPlan {
                    cells: Vec::new(),
                    side_cells: Vec::new(),
                }
            } else {
                let surfaces: Vec<&NurbsSurface> =
                    doc.targets().iter().map(|t| &t.surface).collect();
                NetworkPlan::new(&surfaces, &network, detail)
            };
            let written = vec![None; ids.len()];
            self.conform.insert(
                detail,
                ConformState {
                    ids,
                    network,
                    plan,
                    written,
                    sides: Vec::new(),
                    carved: Vec::new(),
                },
            );
        }
        let Some(mut state) = self.conform.remove(&detail) else {
            return Vec::new();
        };
        let conformal = doc.conformal(&state.network, detail, &self.preview);
        self.carve_sides(doc, detail, &mut state, &conformal);
        let mut to_write = Vec::new();
        for (k, t) in doc.targets().iter().enumerate() {
            if conformal.get(k) == Some(&true) {
                if let Some(view) = self.views.remove(&(t.id, detail)) {
                    let n = view.map().n();
                    for r in 0..n * n {
                        sink.remove_patch(view.patch_key(r));
                    }
                }
                self.dirty.remove(&(t.id, detail));
                match state.written[k] {
                    Some(tris) => stats.triangles_total += tris,
                    None => to_write.push(k),
                }
            } else if state.written[k].take().is_some() {
                sink.remove_patch(conform_key(k));
            }
        }
        if !to_write.is_empty() {
            let surfaces: Vec<&NurbsSurface> = doc.targets().iter().map(|t| &t.surface).collect();
            let tris = write_network_with(
                &surfaces,
                &state.network,
                &state.plan,
                &state.sides,
                &to_write,
                conform_key,
                sink,
            );
            for (k, n) in to_write.into_iter().zip(tris) {
                state.written[k] = Some(n);
                stats.patches_written += 1;
                stats.triangles_written += n;
                stats.triangles_total += n;
            }
        }
        self.conform.insert(detail, state);
        conformal
    }

    /// The shared sides of the network for this pass (issue 30, watertight after
    /// strokes). A network patch that carries strokes (or the preview) is *carved*: it
    /// is meshed by its own tessellation with its shared sides fixed to the network's
    /// vertices, to which its cells' corners along them are added, displaced by the
    /// strokes of both holders ([`pole_height`]: the depth from the 3D point). The sides
    /// of carved patches (now or in the last pass) are recomputed when the carved set
    /// changed or one of their holders is dirty; the conformal patches along a side that
    /// changed are rewritten, the carved ones take their sides
    /// ([`TargetTessellation::set_fixed_sides`]) and are marked dirty when they changed.
    pub(crate) fn carve_sides(
        &mut self,
        doc: &Document,
        detail: Detail,
        state: &mut ConformState,
        conformal: &[bool],
    ) {
        let count = doc.targets().len();
        let carved: Vec<bool> = (0..count)
            .map(|k| state.network.holds(k) && conformal.get(k) == Some(&false))
            .collect();
        for (k, t) in doc.targets().iter().enumerate().filter(|(k, _)| carved[*k]) {
            let plan = grid_of(&self.grids, t, detail);
            self.views.entry((t.id, detail)).or_insert_with(|| {
                TargetTessellation::with_grid(&t.surface, k as u32, detail, &plan)
            });
        }
        let first = state.sides.len() != state.network.sides.len();
        let set_changed = carved != state.carved;
        let stirred = |k: usize| {
            (carved[k] || state.carved.get(k) == Some(&true))
                && (set_changed || self.dirty.contains(&(doc.targets()[k].id, detail)))
        };
        let surfaces: Vec<&NurbsSurface> = doc.targets().iter().map(|t| &t.surface).collect();
        let mut changed = vec![false; count];
        for id in 0..state.network.sides.len() {
            let [(a, _), (b, _)] = state.network.sides[id];
            if !(first || stirred(a) || stirred(b)) {
                continue;
            }
            let side = doc.side_of(
                &surfaces,
                state,
                &carved,
                id,
                &self.preview,
                Some(detail),
                |k| self.views.get(&(doc.targets()[k].id, detail)),
            );
            if state.sides.get(id) != Some(&side) {
                changed[a] = true;
                changed[b] = true;
                match state.sides.get_mut(id) {
                    Some(s) => *s = side,
                    None => state.sides.push(side),
                }
            }
        }
        for k in 0..count {
            if !changed[k] {
                continue;
            }
            if carved[k] {
                let id = doc.targets()[k].id;
                let sides = fixed_sides(&state.sides, &state.network, k);
                if let Some(view) = self.views.get_mut(&(id, detail))
                    && view.set_fixed_sides(sides)
                {
                    self.dirty.insert((id, detail));
                }
            } else if conformal.get(k) == Some(&true) && state.written[k].is_some() {
                // Rewritten below, with the new sides (the sink replaces it by key).
                state.written[k] = None;
            }
        }
        state.carved = carved;
    }
}
