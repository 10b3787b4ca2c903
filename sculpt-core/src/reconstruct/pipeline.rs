//! The whole method, points to patch network, with its error figures: what
//! `sculpt-tools reconstruct` and the bench run.

use super::error::ReconstructError;
use super::network::{
    DataSnap, NetworkSettings, PatchNetwork, SideAngle, fit_network, g1_angles, network_distances,
    place_corners, quad_grids,
};
use super::normals::point_tree;
use super::pinch::split_pinched;
use super::polygon::{PolygonModel, polygon_model};
use super::read::PointCloud;
use super::segment::{SegmentSettings, Segmentation, bbox_diagonal, segment};
use glam::DVec3;

/// The stages, in order, as [`reconstruct`] reports them to its progress callback.
pub const STAGES: [&str; 9] = [
    "neighbours",
    "normals",
    "clustering",
    "adjacency",
    "polygonal model",
    "corners",
    "local grids",
    "fitting",
    "errors",
];

/// Samples per shared side for the G1 angles.
pub const ANGLE_SAMPLES: usize = 16;

/// Error figures of a network against its points.
#[derive(Debug, Clone, PartialEq)]
pub struct Figures {
    /// Bounding-box diagonal of the points, metres.
    pub bbox_diagonal: f64,
    /// Mean distance of the points to the network over the diagonal (E_avg).
    pub e_avg: f64,
    /// Largest distance over the diagonal (E_max).
    pub e_max: f64,
    /// The largest angle between normals along each shared side.
    pub angles: Vec<SideAngle>,
    /// The fraction of the network's area that faces against the data
    /// ([`folded_area`]).
    pub folded_area: f64,
}

impl Figures {
    /// The worst G1 angle over all shared sides, degrees (0 without shared sides).
    pub fn worst_angle(&self) -> f64 {
        self.angles
            .iter()
            .map(|a| a.max_degrees)
            .fold(0.0, f64::max)
    }
}

/// Everything [`reconstruct`] made.
#[derive(Debug, Clone)]
pub struct Reconstruction {
    /// Stages 1 and 2.
    pub segmentation: Segmentation,
    /// Stage 3 (combinatorics).
    pub model: PolygonModel,
    /// Stages 3 to 5.
    pub network: PatchNetwork,
    /// The measurements.
    pub figures: Figures,
}

/// Runs the method on `cloud`: segmentation, polygonal model, corners, local grids,
/// the fitted network and its figures. `progress` is called with each stage name of
/// [`STAGES`] as it starts ("normals" only when they are estimated).
pub fn reconstruct(
    cloud: &PointCloud,
    segment_settings: &SegmentSettings,
    settings: &NetworkSettings,
    mut progress: impl FnMut(&'static str),
) -> Result<Reconstruction, ReconstructError> {
    settings.validate()?;
    let mut seg = segment(cloud, segment_settings, &mut progress)?;
    progress("polygonal model");
    split_pinched(&mut seg, segment_settings.min_votes);
    let model = polygon_model(&seg.clusters.labels, &seg.neighbours, &seg.adjacency);
    if model.quads.is_empty() {
        return Err(ReconstructError::NoQuads);
    }
    progress("corners");
    let snap = DataSnap::new(&seg.points, &seg.normals, settings.snap_neighbours);
    let mesh = place_corners(&model, &seg.clusters.centres, &snap);
    progress("local grids");
    let grids = quad_grids(&mesh, settings.levels, &snap);
    progress("fitting");
    let network = fit_network(&mesh, grids, &seg.points, settings)?;
    progress("errors");
    let figures = figures(&network, &seg);
    Ok(Reconstruction {
        segmentation: seg,
        model,
        network,
        figures,
    })
}

/// The error figures of `network` against the points of `seg`.
pub fn figures(network: &PatchNetwork, seg: &Segmentation) -> Figures {
    let diag = bbox_diagonal(&seg.points);
    let d = network_distances(network, &seg.points);
    let scale = if diag > 0.0 { diag } else { 1.0 };
    Figures {
        bbox_diagonal: diag,
        e_avg: d.iter().sum::<f64>() / d.len().max(1) as f64 / scale,
        e_max: d.iter().copied().fold(0.0, f64::max) / scale,
        angles: g1_angles(network, ANGLE_SAMPLES),
        folded_area: folded_area(network, &seg.points, &seg.normals),
    }
}

/// The fraction of the network's area that faces against the data: its conforming
/// mesh at final detail ([`crate::sculpt::conform`], as `sculpt-tools mesh` writes it),
/// each triangle's area counted against when its normal points away from the normal
/// of the data point nearest its centroid (issue 30: at most 0.1 %). 0 without area
/// or points.
pub fn folded_area(network: &PatchNetwork, points: &[DVec3], normals: &[DVec3]) -> f64 {
    use crate::mesh::PatchMesh;
    use crate::sculpt::conform::{Network, NetworkPlan, write_network};
    use crate::sculpt::tessellate::Detail;
    if points.is_empty() || points.len() != normals.len() {
        return 0.0;
    }
    let surfaces: Vec<&crate::nurbs::NurbsSurface> = network.surfaces.iter().collect();
    let net = Network::of(&surfaces);
    let plan = NetworkPlan::new(&surfaces, &net, Detail::Final);
    let all: Vec<usize> = (0..surfaces.len()).collect();
    let mut mesh = PatchMesh::new();
    write_network(&surfaces, &net, &plan, &all, |k| k as u64, &mut mesh);
    let tree = point_tree(points);
    let (mut against, mut total) = (0.0, 0.0);
    for (_, patch) in mesh.patches() {
        for t in &patch.triangles {
            let [a, b, c] =
                t.map(|i| DVec3::from(patch.vertices[i as usize].position.map(f64::from)));
            let n = (b - a).cross(c - a);
            let area = 0.5 * n.length();
            total += area;
            let centre = (a + b + c) / 3.0;
            if let Some(near) = tree.nearest_neighbor(&centre.to_array())
                && n.dot(normals[near.data]) < 0.0
            {
                against += area;
            }
        }
    }
    if total > 0.0 { against / total } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reconstruct::sample::torus;

    #[test]
    fn stages_run_in_order_and_bad_settings_fail_first() {
        let cloud = PointCloud {
            points: torus(2000, 0.2, 0.08, 5),
            normals: None,
        };
        let settings = NetworkSettings {
            levels: 2,
            control: 4,
            ..NetworkSettings::new()
        };
        let mut seen = Vec::new();
        let r = reconstruct(&cloud, &SegmentSettings::new(16), &settings, |s| {
            seen.push(s)
        })
        .unwrap();
        assert_eq!(seen, STAGES);
        assert_eq!(r.network.surfaces.len(), r.model.quads.len());
        assert!(r.figures.e_avg > 0.0 && r.figures.e_avg <= r.figures.e_max);
        let bad = NetworkSettings {
            degree: 5,
            ..settings
        };
        let mut called = false;
        assert_eq!(
            reconstruct(&cloud, &SegmentSettings::new(16), &bad, |_| called = true).err(),
            Some(ReconstructError::Degree { degree: 5 })
        );
        assert!(!called);
    }
}
