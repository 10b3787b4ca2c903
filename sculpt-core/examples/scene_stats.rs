//! Prints triangle counts, memory and tessellation times of the scene files.
//!
//! `cargo run --release -p sculpt-core --example scene_stats -- tests/data/scenes/*.json`
use sculpt_core::mesh::PatchMesh;
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::tessellate::Detail;
use sculpt_core::sculpt::view::DocumentView;
use std::time::Instant;

fn main() {
    for path in std::env::args().skip(1) {
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("{path}: {e}");
                continue;
            }
        };
        let t0 = Instant::now();
        let doc = match Document::from_json(&bytes) {
            Ok(d) => d,
            Err(e) => {
                eprintln!("{path}: {e}");
                continue;
            }
        };
        let load = t0.elapsed();
        let mut view = DocumentView::new();
        for detail in [Detail::Interactive, Detail::Final] {
            let t = Instant::now();
            let mut mesh = PatchMesh::new();
            let stats = view.tessellate(&doc, detail, &mut mesh);
            println!(
                "{path}: {detail:?}: {} triangles, {} patches, {:.1} ms (load {:.1} ms), derived state {} KiB",
                stats.triangles_total,
                stats.patches_written,
                t.elapsed().as_secs_f64() * 1e3,
                load.as_secs_f64() * 1e3,
                (doc.memory_bytes() + view.memory_bytes()) / 1024
            );
        }
    }
}
