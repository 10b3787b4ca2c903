//! The document's tessellation from the model alone: the whole mesh at a detail
//! ([`Document::mesh`]), the patch count, the patch network, and the helpers a
//! [`DocumentView`](crate::sculpt::view::DocumentView) shares to bring its sinks up to
//! date (the conforming network's state, its shared sides).

use super::*;

/// The patch network of the targets at one detail and what of it is in the sink.
#[derive(Debug, Clone)]
pub(crate) struct ConformState {
    /// The targets (ids, in order, with their geometry revisions) the network was found
    /// among.
    pub(crate) ids: Vec<(TargetId, u64)>,
    pub(crate) network: Network,
    pub(crate) plan: NetworkPlan,
    /// Per target index, the triangles of its conforming patch in the sink (`None`:
    /// not written).
    pub(crate) written: Vec<Option<usize>>,
    /// The shared sides' vertices as last written (empty before the first pass).
    pub(crate) sides: Vec<SharedSide>,
    /// Per target index, whether it was carved (meshed by its own tessellation, with
    /// fixed shared sides) in the last pass.
    pub(crate) carved: Vec<bool>,
}

/// The key of a target's one patch when it is tessellated as part of a network (its
/// index in the high bits, as every patch key of a target, and a root no grid has).
pub fn conform_key(target: usize) -> u64 {
    ((target as u64) << 32) | u64::from(u32::MAX)
}

impl Document {
    /// The number of patches a full tessellation at `detail` writes (for progress),
    /// without a preview.
    pub fn patch_count(&self, detail: Detail) -> usize {
        let conformal = self.conformal(&self.network(), detail, &None);
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
    /// `preview`, a view's). Empty when the network is.
    pub(crate) fn conformal(
        &self,
        network: &Network,
        detail: Detail,
        preview: &Option<(TargetId, Built)>,
    ) -> Vec<bool> {
        if network.is_empty() {
            return Vec::new();
        }
        self.targets
            .iter()
            .enumerate()
            .map(|(k, t)| {
                let previewed = detail == Detail::Interactive
                    && preview
                        .as_ref()
                        .is_some_and(|(_, b)| b.targets.contains(&t.id));
                network.holds(k)
                    && !previewed
                    && pieces_on(&self.strokes, &self.built, t.id).next().is_none()
            })
            .collect()
    }

    /// Shared side `id` for the carved set `carved`: the carved holders' side parameters
    /// ([`TargetTessellation::side_params`], from `view_of`) added, displaced by both
    /// holders' strokes (with a view's `preview` where `preview_at` names the detail).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn side_of<'v>(
        &self,
        surfaces: &[&NurbsSurface],
        state: &ConformState,
        carved: &[bool],
        id: usize,
        preview: &Option<(TargetId, Built)>,
        preview_at: Option<Detail>,
        view_of: impl Fn(usize) -> Option<&'v TargetTessellation>,
    ) -> SharedSide {
        let on = |k: usize| -> Vec<StrokeRef<'_>> {
            let id = self.targets[k].id;
            match preview_at {
                Some(detail) => strokes_at(&self.strokes, &self.built, preview, id, detail),
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

    /// The root grid of a target at a detail, planned for its surface (a view keeps
    /// its plans; the model plans afresh).
    pub(crate) fn grid(&self, t: &TargetRecord, detail: Detail) -> GridPlan {
        plan_grid(&t.surface, detail)
    }

    /// The whole sculpted mesh at `detail`, freshly tessellated.
    pub fn mesh(&self, detail: Detail) -> PatchMesh {
        let mut mesh = PatchMesh::new();
        let network = self.network();
        let conformal = self.conformal(&network, detail, &None);
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
                .map(|id| {
                    self.side_of(&surfaces, &state, &carved, id, &None, None, |k| {
                        views.get(&k)
                    })
                })
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
pub(crate) fn bounds_meet(a: &Rect, b: &Rect, closed: [bool; 2]) -> bool {
    let shift = |c: bool| if c { vec![-1.0, 0.0, 1.0] } else { vec![0.0] };
    shift(closed[0]).into_iter().any(|dx| {
        shift(closed[1]).into_iter().any(|dy| {
            let d = DVec2::new(dx, dy);
            Rect::new(a.min + d, a.max + d).touches(b)
        })
    })
}

/// A kernel surface in the IGES writer's layout.
pub(crate) fn patch_of(s: &NurbsSurface) -> NurbsPatch {
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
pub(crate) fn grid_of<'a>(
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
pub(crate) fn plan_grid(surface: &NurbsSurface, detail: Detail) -> GridPlan {
    GridPlan::new(surface, detail.tolerance(extent(surface).diagonal()))
}

/// The domain minus the hidden region, as faces with holes.
pub(crate) fn visible_faces(hidden: &crate::sculpt::jordan::Region) -> Vec<Face> {
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
