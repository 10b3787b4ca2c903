//! `sculpt-tools mesh`: tessellate a scene (a wandsculpt document) and write the sculpted
//! mesh as OBJ, binary STL or glTF binary, chosen by the output's extension. `--part`
//! picks what is written: the sculpted target (the default), the visible parts of the
//! stroke surfaces, or both.

use crate::progress::Progress;
use anyhow::{Context, Result, bail};
use clap::Args;
use sculpt_core::formats::MeshFormat;
use sculpt_core::mesh::{MeshSink, MeshVertex, PatchKey, PatchMesh};
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::tessellate::{Detail, TargetTessellation};
use sculpt_core::sculpt::view::DocumentView;
use std::path::{Path, PathBuf};

/// Arguments of `mesh`.
#[derive(Debug, Args)]
pub struct MeshArgs {
    /// Scene or document file (wandsculpt-document JSON).
    #[arg(long)]
    pub scene: PathBuf,
    /// Level of detail: `interactive` (coarse, as while sculpting) or `final`.
    #[arg(long, value_enum, default_value_t = DepthArg::Final)]
    pub depth: DepthArg,
    /// Output file: `.obj`, `.stl` or `.glb`.
    #[arg(long)]
    pub out: PathBuf,
    /// What to write: `target` (the sculpted target, grooves and ridges included),
    /// `strokes` (each stroke surface's visible part, trimmed where other strokes
    /// remove it) or `all` (both).
    #[arg(long, value_enum, default_value_t = PartArg::Target)]
    pub part: PartArg,
    /// Mesh every target on its own grid, also where targets share sides (a
    /// reconstructed patch network is otherwise meshed as one watertight surface).
    #[arg(long)]
    pub apart: bool,
}

/// The `--part` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PartArg {
    /// The sculpted target mesh (as rendered).
    Target,
    /// The stroke surfaces' visible parts.
    Strokes,
    /// Both.
    All,
}

/// The `--depth` values.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum DepthArg {
    /// The interactive depth cap.
    Interactive,
    /// The final depth cap.
    Final,
}

impl From<DepthArg> for Detail {
    fn from(d: DepthArg) -> Self {
        match d {
            DepthArg::Interactive => Detail::Interactive,
            DepthArg::Final => Detail::Final,
        }
    }
}

/// Reads a scene file.
pub fn load_scene(path: &Path) -> Result<Document> {
    // Refused from its size before it is read: memory stays bounded by the cap.
    let bytes = fsio::read_capped(
        path,
        sculpt_core::sculpt::document::MAX_DOCUMENT_BYTES as u64,
    )?;
    Document::from_json(&bytes).with_context(|| format!("loading {}", path.display()))
}

/// A sink that collects patches and ticks the progress per patch.
struct Ticking<'a> {
    mesh: &'a mut PatchMesh,
    progress: &'a mut Progress,
}

impl MeshSink for Ticking<'_> {
    fn begin_patch(&mut self, key: PatchKey) {
        self.mesh.begin_patch(key);
    }
    fn push_vertex(&mut self, vertex: MeshVertex) -> u32 {
        self.mesh.push_vertex(vertex)
    }
    fn push_triangle(&mut self, a: u32, b: u32, c: u32) {
        self.mesh.push_triangle(a, b, c);
    }
    fn end_patch(&mut self) {
        self.mesh.end_patch();
        self.progress.inc(1);
    }
    fn remove_patch(&mut self, key: PatchKey) {
        self.mesh.remove_patch(key);
    }
}

/// Tessellates a document, reporting progress per patch (see [`crate::progress`]).
pub fn tessellate_with_progress(
    doc: &Document,
    view: &mut DocumentView,
    detail: Detail,
    progress: &mut Progress,
) -> PatchMesh {
    progress.set_length(doc.patch_count(detail) as u64);
    progress.set_message("tessellating patches");
    let mut mesh = PatchMesh::new();
    view.tessellate(
        doc,
        detail,
        &mut Ticking {
            mesh: &mut mesh,
            progress,
        },
    );
    mesh
}

/// Runs `mesh`.
pub fn run(args: MeshArgs) -> Result<()> {
    let Some(format) = MeshFormat::from_extension(&args.out.to_string_lossy()) else {
        bail!(
            "--out must end in .obj, .stl or .glb: {}",
            args.out.display()
        );
    };
    let mut progress = Progress::new("mesh", 0);
    progress.set_message("reading the scene");
    let doc = load_scene(&args.scene)?;
    let mut view = DocumentView::new();
    let detail = Detail::from(args.depth);
    let mut mesh = if args.part == PartArg::Strokes {
        PatchMesh::new()
    } else if args.apart {
        let mut mesh = PatchMesh::new();
        for (k, t) in doc.targets().iter().enumerate() {
            let mut view = TargetTessellation::new(&t.surface, k as u32, detail);
            view.update_strokes(&t.surface, &doc.strokes_on(t.id), &mut mesh);
        }
        mesh
    } else {
        tessellate_with_progress(&doc, &mut view, detail, &mut progress)
    };
    if args.part != PartArg::Target {
        progress.set_message("stroke surfaces");
        view.stroke_surfaces_mesh(&doc, detail, &mut mesh);
    }
    progress.set_message("welding and writing");
    let size = doc
        .targets()
        .iter()
        .map(|t| t.surface.size())
        .fold(0.0, f64::max);
    let welded = mesh.welded(
        (size * crate::tolerance::MESH_WELD_REL).max(crate::tolerance::MESH_WELD_MIN) as f32,
    );
    let bytes = format.write(&welded).context("writing the mesh")?;
    super::io::write_file(&args.out, &bytes)?;
    let report = welded.edge_report();
    progress.finish();
    println!(
        "{}: {} triangles, {} vertices, {} bytes; open edges {}, watertight {}, bodies {}, Euler characteristic {}",
        args.out.display(),
        welded.triangles.len(),
        welded.vertices.len(),
        bytes.len(),
        report.boundary,
        report.is_watertight(),
        welded.bodies(),
        welded.euler_characteristic()
    );
    Ok(())
}
