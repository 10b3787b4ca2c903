//! `sculpt-tools reconstruct POINTS --patches K [--degree 2|3] [--control N] [--out
//! scan.json] [--igs X.igs] [--obj X.obj] [--report R.json] [--layout L.ply]`: scan
//! reconstruction (docs/reconstruct.md): reads the points, estimates normals when the
//! file has none, clusters them into K patches, builds the polygonal model and its
//! quads, places them on the data, fits one NURBS patch per quad with G1 across the
//! sides and measures the result. Writes the patches as a `wandsculpt-document` (one
//! target per patch), IGES (one type 128 entity per patch) and an OBJ mesh. The report
//! gives the counts, the error figures and the time; the layout is an ASCII PLY of the
//! points with their normals, coloured by patch (open it in any mesh viewer).
//!
//! `POINTS` is a `.xyz`, `.pwn`, `.ply`, `.obj` or `.off` file, or `torus:N[:SEED]` for
//! the paper's torus (N points, seeded).

use crate::progress::Progress;
use anyhow::{Context, Result, bail};
use clap::Args;
use sculpt_core::formats::{iges, obj};
use sculpt_core::nurbs::surface::MAX_JSON_COORDINATE_M;
use sculpt_core::reconstruct::network::{NetworkSettings, shared_sides, to_document};
use sculpt_core::reconstruct::pipeline::{Reconstruction, STAGES, reconstruct as run_method};
use sculpt_core::reconstruct::read::{PointCloud, PointFormat, read_points};
use sculpt_core::reconstruct::sample::torus;
use sculpt_core::reconstruct::segment::{SegmentSettings, Segmentation};
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::tessellate::Detail;
use sculpt_core::sculpt::view::DocumentView;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The torus of `torus:N`: major and tube radius, metres.
pub const TORUS_RADII: (f64, f64) = (0.2, 0.08);

/// Largest point file `reconstruct` reads (bytes, 1 GiB: over 10 million points with
/// normals as text). A larger file is refused from its size before it is read, so
/// memory is bounded by this cap, not by the file.
pub const MAX_POINT_FILE_BYTES: u64 = 1 << 30;

/// Arguments of `reconstruct`.
#[derive(Debug, Args)]
pub struct ReconstructArgs {
    /// Point file (`.xyz`, `.pwn`, `.ply`, `.obj`, `.off`) or `torus:N[:SEED]`.
    pub points: String,
    /// Number of patches K.
    #[arg(long)]
    pub patches: usize,
    /// Neighbours per point for normals and adjacency.
    #[arg(long, default_value_t = 10)]
    pub neighbours: usize,
    /// Degree of the patches in both directions (2 or 3).
    #[arg(long, default_value_t = 3)]
    pub degree: usize,
    /// Control points per direction of each patch (degree < N <= 17).
    #[arg(long, default_value_t = 8)]
    pub control: usize,
    /// Rounds of refitting the patches to the data points (0: to their grids only).
    #[arg(long, default_value_t = 3)]
    pub refit: usize,
    /// Write the patches here as a `wandsculpt-document` (one target per patch).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write the patches here as IGES (one type 128 entity per patch).
    #[arg(long)]
    pub igs: Option<PathBuf>,
    /// Write the tessellated patches here as an OBJ mesh.
    #[arg(long)]
    pub obj: Option<PathBuf>,
    /// Write the report (JSON) here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write the patch layout here: an ASCII PLY of the points with normals, coloured by
    /// patch, with a `patch` property.
    #[arg(long)]
    pub layout: Option<PathBuf>,
}

/// The report of `reconstruct`.
#[derive(Debug, Serialize)]
pub struct Report {
    /// The input as given.
    pub input: String,
    /// Points read.
    pub points: usize,
    /// Bounding-box diagonal of the points.
    pub bbox_diagonal: f64,
    /// `"file"` or `"estimated"`.
    pub normals: &'static str,
    /// K.
    pub patches: usize,
    /// Patches after the ones the polygonal model pinched were split (K plus two per
    /// split; `sculpt_core::reconstruct::pinch`).
    pub patches_after_split: usize,
    /// Lloyd iterations.
    pub iterations: usize,
    /// Smallest and largest patch, in points.
    pub patch_points_min: usize,
    /// Largest patch, in points.
    pub patch_points_max: usize,
    /// Adjacent patch pairs.
    pub adjacent_pairs: usize,
    /// Fewest neighbouring patches of any patch.
    pub patch_degree_min: usize,
    /// Most neighbouring patches of any patch.
    pub patch_degree_max: usize,
    /// Patches in more than one piece (0 after clean-up).
    pub patches_in_pieces: usize,
    /// Faces of the polygonal model (where three or more patches meet).
    pub model_faces: usize,
    /// Euler characteristic `V - E + F` of the model (2 for a sphere, 0 for a torus).
    pub euler_characteristic: i64,
    /// Model edges not shared by exactly two faces (0 on a closed object).
    pub open_model_edges: usize,
    /// Quads (each face split through its edge midpoints and centre).
    pub quads: usize,
    /// Quad edges not shared by exactly two quads (0 on a closed object).
    pub open_quad_edges: usize,
    /// Degree of the patches.
    pub degree: usize,
    /// Control points per direction of each patch.
    pub control: usize,
    /// Points per direction of each quad's local grid.
    pub grid: usize,
    /// Rounds of refitting to the data points.
    pub refit_rounds: usize,
    /// NURBS patches fitted (one per quad).
    pub nurbs_patches: usize,
    /// Patch sides shared by two patches.
    pub shared_sides: usize,
    /// Mean distance of the points to the network over the bounding-box diagonal.
    pub e_avg: f64,
    /// Largest distance of a point to the network over the bounding-box diagonal.
    pub e_max: f64,
    /// Largest angle between the two patches' normals along any shared side, degrees.
    pub g1_max_degrees: f64,
    /// Mean over shared sides of each side's largest angle, degrees.
    pub g1_mean_degrees: f64,
    /// Fraction of the network's area (its mesh at final detail) facing against the
    /// normals of the nearest data points (folds; issue 30 asks at most 0.001).
    pub folded_area: f64,
    /// Seconds for reading and the whole method, figures included (not writing).
    pub seconds: f64,
}

fn load(spec: &str) -> Result<PointCloud> {
    if let Some(rest) = spec.strip_prefix("torus:") {
        let mut parts = rest.split(':');
        let n: usize = parts
            .next()
            .and_then(|n| n.parse().ok())
            .with_context(|| format!("{spec}: expected torus:N[:SEED]"))?;
        let seed: u64 = match parts.next() {
            Some(s) => s
                .parse()
                .with_context(|| format!("{spec}: the seed is not a whole number"))?,
            None => 1,
        };
        if n == 0 {
            bail!("{spec}: a torus needs at least one point");
        }
        return Ok(PointCloud {
            points: torus(n, TORUS_RADII.0, TORUS_RADII.1, seed),
            normals: None,
        });
    }
    let path = Path::new(spec);
    let ext = path
        .extension()
        .map_or(String::new(), |e| e.to_string_lossy().into_owned());
    let format = PointFormat::from_extension(&ext).with_context(|| spec.to_string())?;
    // Refused from its size before it is read: memory stays bounded by the cap.
    let bytes = fsio::read_capped(path, MAX_POINT_FILE_BYTES)?;
    read_points(&bytes, format).with_context(|| spec.to_string())
}

/// Refuses, before any work, points that a document cannot hold: every control point
/// of a `wandsculpt-document` lies within [`MAX_JSON_COORDINATE_M`] of the origin on
/// each axis (the reader `mesh` and `wandsculpt --scene` use refuses others), and the
/// fitted patches lie on the points. A scan in a geographic frame (UTM, coordinates
/// near 5e6 m) must be moved near the origin first.
fn check_extent(cloud: &PointCloud, spec: &str) -> Result<()> {
    // The patches may bulge a little past the points; keep a margin inside the cap.
    let limit = MAX_JSON_COORDINATE_M * 0.5;
    if let Some(far) = cloud.points.iter().find(|p| p.abs().max_element() > limit) {
        bail!(
            "{spec}: the point ({}, {}, {}) lies more than {limit} m from the origin; \
             a wandsculpt document holds coordinates up to {MAX_JSON_COORDINATE_M} m, so \
             move the scan near the origin first (subtract its centre, e.g. a UTM \
             easting and northing)",
            far.x,
            far.y,
            far.z
        );
    }
    Ok(())
}

/// Reads the points and runs the method, with a progress bar on a terminal.
pub fn reconstruct(args: &ReconstructArgs) -> Result<(Reconstruction, Report)> {
    let start = Instant::now();
    let mut progress = Progress::new("reconstruct", STAGES.len() as u64 + 1);
    progress.set_message("reading");
    let cloud = load(&args.points)?;
    check_extent(&cloud, &args.points)?;
    let mut settings = SegmentSettings::new(args.patches);
    settings.neighbours = args.neighbours.max(3);
    let network_settings = NetworkSettings {
        degree: args.degree,
        control: args.control,
        refit_rounds: args.refit,
        ..NetworkSettings::new()
    };
    let r = run_method(&cloud, &settings, &network_settings, |stage| {
        let at = STAGES.iter().position(|s| *s == stage).unwrap_or(0);
        progress.set_position(at as u64 + 1);
        progress.set_message(stage);
    })
    .with_context(|| args.points.clone())?;
    progress.finish();
    let seg = &r.segmentation;
    let model = &r.model;
    let edge_uses = model.edge_uses();
    let sizes = seg.clusters.sizes();
    let degrees = seg.degrees();
    let angles: Vec<f64> = r.figures.angles.iter().map(|a| a.max_degrees).collect();
    let report = Report {
        input: args.points.clone(),
        points: seg.points.len(),
        bbox_diagonal: r.figures.bbox_diagonal,
        normals: if seg.normals_estimated {
            "estimated"
        } else {
            "file"
        },
        patches: args.patches,
        patches_after_split: seg.clusters.centres.len(),
        iterations: seg.clusters.iterations,
        patch_points_min: sizes.iter().copied().min().unwrap_or(0),
        patch_points_max: sizes.iter().copied().max().unwrap_or(0),
        adjacent_pairs: seg.adjacency.len(),
        patch_degree_min: degrees.iter().copied().min().unwrap_or(0),
        patch_degree_max: degrees.iter().copied().max().unwrap_or(0),
        patches_in_pieces: seg.pieces_per_patch().iter().filter(|&&p| p > 1).count(),
        model_faces: model.faces.len(),
        euler_characteristic: seg.clusters.centres.len() as i64 - seg.adjacency.len() as i64
            + model.faces.len() as i64,
        open_model_edges: seg
            .adjacency
            .iter()
            .filter(|e| edge_uses.get(&(e.0, e.1)) != Some(&2))
            .count(),
        quads: model.quads.len(),
        open_quad_edges: model.quad_edge_uses().values().filter(|&&u| u != 2).count(),
        degree: args.degree,
        control: args.control,
        grid: (1 << network_settings.levels) + 1,
        refit_rounds: network_settings.refit_rounds,
        nurbs_patches: r.network.surfaces.len(),
        shared_sides: shared_sides(&r.network.quads, 1).len(),
        e_avg: r.figures.e_avg,
        e_max: r.figures.e_max,
        g1_max_degrees: r.figures.worst_angle(),
        g1_mean_degrees: angles.iter().sum::<f64>() / angles.len().max(1) as f64,
        folded_area: r.figures.folded_area,
        seconds: start.elapsed().as_secs_f64(),
    };
    Ok((r, report))
}

/// A colour per patch (golden-ratio hues).
fn colour(patch: usize) -> [u8; 3] {
    let h = (patch as f64 * 0.618_033_988_749_895).fract() * 6.0;
    let x = 1.0 - (h % 2.0 - 1.0).abs();
    let (r, g, b) = match h as u32 {
        0 => (1.0, x, 0.0),
        1 => (x, 1.0, 0.0),
        2 => (0.0, 1.0, x),
        3 => (0.0, x, 1.0),
        4 => (x, 0.0, 1.0),
        _ => (1.0, 0.0, x),
    };
    let c = |v: f64| (55.0 + 200.0 * v) as u8;
    [c(r), c(g), c(b)]
}

/// The layout as ASCII PLY.
pub fn layout_ply(seg: &Segmentation) -> String {
    let mut out = format!(
        "ply\nformat ascii 1.0\ncomment sculpt-tools reconstruct patch layout\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\nproperty double nx\nproperty double ny\nproperty double nz\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nproperty int patch\nend_header\n",
        seg.points.len()
    );
    for ((p, n), &l) in seg
        .points
        .iter()
        .zip(&seg.normals)
        .zip(&seg.clusters.labels)
    {
        let [r, g, b] = colour(l);
        let _ = writeln!(
            out,
            "{} {} {} {} {} {} {r} {g} {b} {l}",
            p.x, p.y, p.z, n.x, n.y, n.z
        );
    }
    out
}

/// Every output of a run, built in memory before any is written.
fn outputs(
    args: &ReconstructArgs,
    r: &Reconstruction,
    report: &Report,
) -> Result<Vec<(PathBuf, Vec<u8>)>> {
    let mut files = Vec::new();
    if let Some(path) = &args.layout {
        files.push((path.clone(), layout_ply(&r.segmentation).into_bytes()));
    }
    if args.out.is_some() || args.igs.is_some() || args.obj.is_some() {
        let doc = to_document(&r.network).context("the patch network as a document")?;
        if let Some(path) = &args.out {
            let json = doc.to_json();
            // Read back with the reader `mesh` and `wandsculpt --scene` use: never
            // write a document the tools refuse.
            Document::from_json(&json)
                .context("the reconstructed document would not load (no file was written)")?;
            files.push((path.clone(), json));
        }
        if let Some(path) = &args.igs {
            let bytes =
                iges::write(&DocumentView::new().iges_surfaces(&doc)).context("writing IGES")?;
            files.push((path.clone(), bytes));
        }
        if let Some(path) = &args.obj {
            let size = r.figures.bbox_diagonal;
            let tol = (size * crate::tolerance::MESH_WELD_REL).max(crate::tolerance::MESH_WELD_MIN);
            let bytes =
                obj::write(&doc.mesh(Detail::Final).welded(tol as f32)).context("writing OBJ")?;
            files.push((path.clone(), bytes));
        }
    }
    if let Some(path) = &args.report {
        let json = serde_json::to_string_pretty(report)? + "\n";
        files.push((path.clone(), json.into_bytes()));
    }
    Ok(files)
}

/// Runs `reconstruct`. Every output is built first and then written as one set
/// (fsio): a run that fails (bad input, an export error, a full disk) writes no file.
pub fn run(args: ReconstructArgs) -> Result<()> {
    let (r, report) = reconstruct(&args)?;
    let files = outputs(&args, &r, &report)?;
    fsio::write_all_atomic(&files)?;
    if args.report.is_none() {
        println!("{}", serde_json::to_string_pretty(&report)?);
    }
    Ok(())
}
