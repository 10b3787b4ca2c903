//! The document's tessellation: meshing its targets and strokes into sinks, at each
//! detail, alone or as a conforming patch network.

use super::*;

/// The patch network of the targets at one detail and what of it is in the sink.
#[derive(Debug, Clone)]
pub(super) struct ConformState {
    /// The targets (ids, in order) the network was found among.
    pub(super) ids: Vec<TargetId>,
    pub(super) network: Network,
    pub(super) plan: NetworkPlan,
    /// Per target index, the triangles of its conforming patch in the sink (`None`:
    /// not written).
    pub(super) written: Vec<Option<usize>>,
    /// The shared sides' vertices as last written (empty before the first pass).
    pub(super) sides: Vec<SharedSide>,
    /// Per target index, whether it was carved (meshed by its own tessellation, with
    /// fixed shared sides) in the last pass.
    pub(super) carved: Vec<bool>,
}

/// The key of a target's one patch when it is tessellated as part of a network (its
/// index in the high bits, as every patch key of a target, and a root no grid has).
pub fn conform_key(target: usize) -> u64 {
    ((target as u64) << 32) | u64::from(u32::MAX)
}

impl Document {
    /// Brings `sink` up to date at `detail`: the first call writes every patch, later
    /// calls only the patches changed since (strokes applied, undone or redone; targets
    /// added or removed). Use one sink per detail.
    pub fn tessellate(&mut self, detail: Detail, sink: &mut dyn MeshSink) -> TessStats {
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
        let conformal = self.conform_pass(detail, sink, &mut stats);
        for (k, t) in self.targets.iter().enumerate() {
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
            if !fresh && changed.is_none() {
                stats.triangles_total += self.views[&key].triangle_count();
                continue;
            }
            let plan = grid_of(&self.grids, t, detail);
            let view = self.views.entry(key).or_insert_with(|| {
                TargetTessellation::with_grid(&t.surface, k as u32, detail, &plan)
            });
            let strokes = strokes_at(&self.strokes, &self.built, &self.preview, t.id, detail);
            let s = view.update_strokes(&t.surface, &strokes, sink);
            stats.patches_written += s.patches_written;
            stats.triangles_written += s.triangles_written;
            stats.triangles_total += s.triangles_total;
        }
        stats
    }

    /// The UV vector map sculpting uses for `target` at `detail`: the quadtree of the
    /// target's tessellation view (its grid planned for the detail's tolerance of the
    /// surface's extent, wrapped on closed sides, updated with the strokes' footprints),
    /// the one the renderer's mesh and the quadtree overlay show. `None` before the
    /// document was tessellated at `detail`, and for a target drawn as one patch of a
    /// conforming network (uncarved: it has no quadtree).
    pub fn uv_map(&self, target: TargetId, detail: Detail) -> Option<&super::super::uvmap::UvMap> {
        self.views
            .get(&(target, detail))
            .filter(|v| !v.is_fresh())
            .map(TargetTessellation::map)
    }

    /// Forgets what was written to the sinks so far: the next [`Document::tessellate`]
    /// at each detail writes every patch again, as into new, empty sinks.
    pub fn forget_sinks(&mut self) {
        self.views.clear();
        self.conform.clear();
        self.dirty.clear();
        self.removed.clear();
    }

    /// Forgets what was written to the sink of `detail` only (see
    /// [`Self::forget_sinks`]): the next [`Document::tessellate`] at `detail` writes
    /// every patch again; the other detail's sink stays as it is. A renderer that drew
    /// something else into that sink (the live lattice preview) puts the document back
    /// this way.
    pub fn forget_sink(&mut self, detail: Detail) {
        self.views.retain(|&(_, d), _| d != detail);
        self.conform.remove(&detail);
        self.dirty.retain(|&(_, d), _| d != detail);
        self.removed.retain(|(d, _)| *d != detail);
    }

    /// The number of patches a full tessellation at `detail` writes (for progress).
    pub fn patch_count(&self, detail: Detail) -> usize {
        let conformal = self.conformal(&self.network(), detail);
        self.targets
            .iter()
            .enumerate()
            .map(|(k, t)| {
                if conformal.get(k) == Some(&true) {
                    return 1;
                }
                let n = self.grid(t, detail).n;
                (n * n) as usize
            })
            .sum()
    }

    /// The patch network the targets form ([`Network::of`]; empty when no two share a
    /// side, as for every document of one target).
    pub fn network(&self) -> Network {
        let surfaces: Vec<&NurbsSurface> = self.targets.iter().map(|t| &t.surface).collect();
        Network::of(&surfaces)
    }

    /// Per target index, whether it is tessellated as part of `network` at `detail`:
    /// it shares a side and carries no stroke (nor, at interactive detail, the
    /// preview). Empty when the network is.
    pub(super) fn conformal(&self, network: &Network, detail: Detail) -> Vec<bool> {
        if network.is_empty() {
            return Vec::new();
        }
        self.targets
            .iter()
            .enumerate()
            .map(|(k, t)| {
                let previewed = detail == Detail::Interactive
                    && self
                        .preview
                        .as_ref()
                        .is_some_and(|(_, b)| b.targets.contains(&t.id));
                network.holds(k)
                    && !previewed
                    && pieces_on(&self.strokes, &self.built, t.id).next().is_none()
            })
            .collect()
    }

    /// Writes the network's patches that need it ([`Self::conformal`] targets not yet
    /// in the sink), removes the per-target patches of targets that became conformal
    /// and the conforming patches of those that no longer are. Returns
    /// [`Self::conformal`].
    pub(super) fn conform_pass(
        &mut self,
        detail: Detail,
        sink: &mut dyn MeshSink,
        stats: &mut TessStats,
    ) -> Vec<bool> {
        let ids: Vec<TargetId> = self.targets.iter().map(|t| t.id).collect();
        if self.conform.get(&detail).is_none_or(|c| c.ids != ids) {
            if let Some(old) = self.conform.remove(&detail) {
                for (k, w) in old.written.iter().enumerate() {
                    if w.is_some() {
                        sink.remove_patch(conform_key(k));
                    }
                }
            }
            let network = self.network();
            let plan = if network.is_empty() {
                NetworkPlan {
                    cells: Vec::new(),
                    side_cells: Vec::new(),
                }
            } else {
                let surfaces: Vec<&NurbsSurface> =
                    self.targets.iter().map(|t| &t.surface).collect();
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
        let conformal = self.conformal(&state.network, detail);
        self.carve_sides(detail, &mut state, &conformal);
        let mut to_write = Vec::new();
        for (k, t) in self.targets.iter().enumerate() {
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
            let surfaces: Vec<&NurbsSurface> = self.targets.iter().map(|t| &t.surface).collect();
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
    pub(super) fn carve_sides(
        &mut self,
        detail: Detail,
        state: &mut ConformState,
        conformal: &[bool],
    ) {
        let count = self.targets.len();
        let carved: Vec<bool> = (0..count)
            .map(|k| state.network.holds(k) && conformal.get(k) == Some(&false))
            .collect();
        for (k, t) in self.targets.iter().enumerate().filter(|(k, _)| carved[*k]) {
            let plan = grid_of(&self.grids, t, detail);
            self.views.entry((t.id, detail)).or_insert_with(|| {
                TargetTessellation::with_grid(&t.surface, k as u32, detail, &plan)
            });
        }
        let first = state.sides.len() != state.network.sides.len();
        let set_changed = carved != state.carved;
        let stirred = |k: usize| {
            (carved[k] || state.carved.get(k) == Some(&true))
                && (set_changed || self.dirty.contains_key(&(self.targets[k].id, detail)))
        };
        let surfaces: Vec<&NurbsSurface> = self.targets.iter().map(|t| &t.surface).collect();
        let mut changed = vec![false; count];
        for id in 0..state.network.sides.len() {
            let [(a, _), (b, _)] = state.network.sides[id];
            if !(first || stirred(a) || stirred(b)) {
                continue;
            }
            let side = self.side_of(&surfaces, state, &carved, id, Some(detail), |k| {
                self.views.get(&(self.targets[k].id, detail))
            });
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
                let id = self.targets[k].id;
                let sides = fixed_sides(&state.sides, &state.network, k);
                if let Some(view) = self.views.get_mut(&(id, detail))
                    && view.set_fixed_sides(sides)
                {
                    self.dirty.entry((id, detail)).or_insert(None);
                }
            } else if conformal.get(k) == Some(&true) && state.written[k].is_some() {
                // Rewritten below, with the new sides (the sink replaces it by key).
                state.written[k] = None;
            }
        }
        state.carved = carved;
    }

    /// Shared side `id` for the carved set `carved`: the carved holders' side parameters
    /// ([`TargetTessellation::side_params`], from `view_of`) added, displaced by both
    /// holders' strokes (with the preview where `preview_at` names the detail).
    pub(super) fn side_of<'v>(
        &self,
        surfaces: &[&NurbsSurface],
        state: &ConformState,
        carved: &[bool],
        id: usize,
        preview_at: Option<Detail>,
        view_of: impl Fn(usize) -> Option<&'v TargetTessellation>,
    ) -> SharedSide {
        let on = |k: usize| -> Vec<StrokeRef<'_>> {
            let id = self.targets[k].id;
            match preview_at {
                Some(detail) => strokes_at(&self.strokes, &self.built, &self.preview, id, detail),
                None => pieces_on(&self.strokes, &self.built, id).collect(),
            }
        };
        let extra = holder_params(&state.network, id, |p, k| {
            carved[p]
                .then(|| view_of(p).map(|v| v.side_params(k, &on(p))))
                .flatten()
        });
        let [(a, _), (b, _)] = state.network.sides[id];
        let strokes: Vec<StrokeRef<'_>> = [a, b]
            .into_iter()
            .filter(|&k| carved[k])
            .flat_map(on)
            .collect();
        shared_side(surfaces, &state.network, &state.plan, id, &extra, |p| {
            if strokes.is_empty() {
                0.0
            } else {
                pole_height(&strokes, p)
            }
        })
    }

    /// The root grid of a target at a detail (chosen when the target was added).
    pub(super) fn grid(&self, t: &TargetRecord, detail: Detail) -> std::borrow::Cow<'_, GridPlan> {
        grid_of(&self.grids, t, detail)
    }

    /// The whole sculpted mesh at `detail`, freshly tessellated.
    pub fn mesh(&self, detail: Detail) -> PatchMesh {
        let mut mesh = PatchMesh::new();
        let network = self.network();
        let conformal = self.conformal(&network, detail);
        let carved: Vec<bool> = (0..self.targets.len())
            .map(|k| network.holds(k) && conformal.get(k) == Some(&false))
            .collect();
        let mut views: HashMap<usize, TargetTessellation> = HashMap::new();
        for (k, t) in self.targets.iter().enumerate() {
            if conformal.get(k) == Some(&true) {
                continue;
            }
            let plan = self.grid(t, detail);
            views.insert(
                k,
                TargetTessellation::with_grid(&t.surface, k as u32, detail, &plan),
            );
        }
        if !network.is_empty() {
            let surfaces: Vec<&NurbsSurface> = self.targets.iter().map(|t| &t.surface).collect();
            let state = ConformState {
                ids: Vec::new(),
                plan: NetworkPlan::new(&surfaces, &network, detail),
                network,
                written: Vec::new(),
                sides: Vec::new(),
                carved: Vec::new(),
            };
            let sides: Vec<SharedSide> = (0..state.network.sides.len())
                .map(|id| self.side_of(&surfaces, &state, &carved, id, None, |k| views.get(&k)))
                .collect();
            let which: Vec<usize> = (0..conformal.len()).filter(|&k| conformal[k]).collect();
            write_network_with(
                &surfaces,
                &state.network,
                &state.plan,
                &sides,
                &which,
                conform_key,
                &mut mesh,
            );
            for (k, view) in views.iter_mut() {
                if carved[*k] {
                    view.set_fixed_sides(fixed_sides(&sides, &state.network, *k));
                }
            }
        }
        for (k, t) in self.targets.iter().enumerate() {
            if conformal.get(k) == Some(&true) {
                continue;
            }
            if let Some(view) = views.get_mut(&k) {
                view.update_strokes(&t.surface, &self.strokes_on(t.id), &mut mesh);
            }
        }
        mesh
    }
}

/// The patch key of a stroke piece's surface mesh (by the piece's key, see
/// [`Document::strokes_on`]): the high bit set, so it never meets a target patch's key
/// (a later piece's key, from [`PIECE_KEYS`], has it set already).
pub fn stroke_patch_key(stroke: u64) -> u64 {
    (1 << 63) | stroke
}

/// True when two strokes' parameter bounds meet, also across the seams of closed
/// directions.
pub(super) fn bounds_meet(a: &Rect, b: &Rect, closed: [bool; 2]) -> bool {
    let shift = |c: bool| if c { vec![-1.0, 0.0, 1.0] } else { vec![0.0] };
    shift(closed[0]).into_iter().any(|dx| {
        shift(closed[1]).into_iter().any(|dy| {
            let d = DVec2::new(dx, dy);
            Rect::new(a.min + d, a.max + d).touches(b)
        })
    })
}

/// A kernel surface in the IGES writer's layout.
pub(super) fn patch_of(s: &NurbsSurface) -> NurbsPatch {
    NurbsPatch {
        degree_u: s.degree_u(),
        degree_v: s.degree_v(),
        knots_u: s.knots_u().knots().to_vec(),
        knots_v: s.knots_v().knots().to_vec(),
        control_points: s.control_points(),
        weights: s.is_rational().then(|| s.weights()),
    }
}

/// The planned grid of a target, or a fresh plan when none was made.
pub(super) fn grid_of<'a>(
    grids: &'a HashMap<(TargetId, Detail), GridPlan>,
    t: &TargetRecord,
    detail: Detail,
) -> std::borrow::Cow<'a, GridPlan> {
    match grids.get(&(t.id, detail)) {
        Some(plan) => std::borrow::Cow::Borrowed(plan),
        None => std::borrow::Cow::Owned(plan_grid(&t.surface, detail)),
    }
}

/// The grid of a target at a detail's stated tolerance.
pub(super) fn plan_grid(surface: &NurbsSurface, detail: Detail) -> GridPlan {
    GridPlan::new(surface, detail.tolerance(extent(surface).diagonal()))
}

/// The domain minus the hidden region, as faces with holes.
pub(super) fn visible_faces(hidden: &crate::sculpt::jordan::Region) -> Vec<Face> {
    use i_overlay::core::overlay_rule::OverlayRule;
    let square = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let holes = crate::sculpt::stroke::region_to_contours(hidden);
    let shapes = crate::sculpt::stroke::domain_overlay(&[square], &holes, OverlayRule::Difference);
    let to = |c: &Vec<[f64; 2]>| c.iter().map(|p| DVec2::new(p[0], p[1])).collect::<Vec<_>>();
    shapes
        .iter()
        .filter(|s| !s.is_empty())
        .map(|s| Face {
            outer: to(&s[0]),
            holes: s[1..].iter().map(to).collect(),
        })
        .collect()
}
