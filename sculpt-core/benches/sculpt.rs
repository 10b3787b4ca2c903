//! Sculpting benches (targets in `docs/benchmarks.md`):
//! - `stroke_interactive`: one 200-sample stroke on a bicubic 16 x 16 target at
//!   interactive depth, including the incremental re-tessellation (target <= 2 ms);
//! - `scene4_final`: final-depth tessellation of the mask-face scene (target <= 100 ms);
//! - `scene4_stroke_surfaces`: building the 7 stroke surfaces of the mask-face scene
//!   (fit, trim against the overlapping strokes, UV maps), as the first export does;
//! - `ray_default_sheet_100`: 100 pointer rays from the desktop eye across the default
//!   sheet and past its edges (`sculpt::ray::cast_document`, once per frame in the
//!   desktop window).
//!
//! Run: `cargo bench -p sculpt-core --bench sculpt`. Triangle counts and memory per
//! stroke are printed once at start-up.

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use glam::DVec3;
use sculpt_core::mesh::PatchMesh;
use sculpt_core::nurbs::NurbsSurface;
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::ray::{Ray, cast_document};
use sculpt_core::sculpt::stroke::{Mode, Profile, StrokeInput, Tool};
use sculpt_core::sculpt::tessellate::Detail;
use sculpt_core::sculpt::view::DocumentView;
use std::hint::black_box;
use std::time::Duration;

fn bicubic_16() -> NurbsSurface {
    let n = 16;
    let knots = {
        let mut k = vec![0.0; 4];
        k.extend((1..n - 3).map(|i| i as f64 / (n - 3) as f64));
        k.extend([1.0; 4]);
        k
    };
    let cps = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| {
                    let (x, y) = (i as f64 / (n - 1) as f64, j as f64 / (n - 1) as f64);
                    DVec3::new(x, y, 0.05 * (3.0 * x).sin() * (2.0 * y).cos())
                })
                .collect()
        })
        .collect();
    NurbsSurface::new(3, 3, knots.clone(), knots, cps, None).expect("valid surface")
}

fn stroke_200() -> StrokeInput {
    let samples = (0..200)
        .map(|k| {
            let s = k as f64 / 199.0;
            let (x, y) = (0.15 + 0.7 * s, 0.5 + 0.2 * (3.0 * s).sin());
            (
                k as f64 / 90.0,
                DVec3::new(x, y, 0.05 * (3.0 * x).sin() * (2.0 * y).cos() + 0.002),
            )
        })
        .collect();
    StrokeInput {
        samples,
        tool: Tool {
            profile: Profile::V,
            width: 0.04,
            depth: 0.01,
            mode: Mode::Carve,
            taper: 0.03,
        },
    }
}

fn scene4() -> Document {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/scenes/mask-face.json"
    );
    Document::from_json(&std::fs::read(path).expect("scene file")).expect("scene loads")
}

fn report() {
    let mut doc = Document::new();
    let t = doc.add_target("bicubic", bicubic_16());
    for detail in [Detail::Interactive, Detail::Final] {
        let mut d = doc.clone();
        let mut view = DocumentView::new();
        let mut sink = PatchMesh::new();
        let before = view.tessellate(&d, detail, &mut sink).triangles_total;
        let mem_before = d.memory_bytes() + view.memory_bytes();
        d.apply_stroke(t, stroke_200()).expect("stroke applies");
        let after = view.tessellate(&d, detail, &mut sink);
        println!(
            "bicubic 16x16, one 200-sample stroke, {detail:?}: {} -> {} triangles ({} rewritten in {} patches), derived memory +{} KiB",
            before,
            after.triangles_total,
            after.triangles_written,
            after.patches_written,
            (d.memory_bytes() + view.memory_bytes() - mem_before) / 1024
        );
    }
    let doc = scene4();
    let mut view = DocumentView::new();
    for detail in [Detail::Interactive, Detail::Final] {
        let stats = view.tessellate(&doc, detail, &mut PatchMesh::new());
        let memory = doc.memory_bytes() + view.memory_bytes();
        println!(
            "scene 4 (mask face, {} strokes), {detail:?}: {} triangles, derived memory {} KiB ({} KiB per stroke)",
            doc.strokes().len(),
            stats.triangles_total,
            memory / 1024,
            memory / 1024 / doc.strokes().len().max(1)
        );
    }
    let target = doc.targets()[0].id;
    let surfaces = view.stroke_surfaces(&doc, target);
    for detail in [Detail::Interactive, Detail::Final] {
        let triangles = view.stroke_surfaces_mesh(&doc, detail, &mut PatchMesh::new());
        println!(
            "scene 4 stroke surfaces, {detail:?}: {} surfaces, {triangles} triangles, {} KiB",
            surfaces.len(),
            surfaces
                .iter()
                .map(|(_, s)| s.memory_bytes())
                .sum::<usize>()
                / 1024
        );
    }
}

fn benches(c: &mut Criterion) {
    report();
    let mut view = DocumentView::new();
    let mut base = Document::new();
    let target = base.add_target("bicubic", bicubic_16());
    let mut base_sink = PatchMesh::new();
    view.tessellate(&base, Detail::Interactive, &mut base_sink);
    let input = stroke_200();
    c.bench_function("stroke_interactive", |b| {
        b.iter_batched(
            || (base.clone(), view.clone(), base_sink.clone()),
            |(mut doc, mut view, mut sink)| {
                doc.apply_stroke(target, input.clone())
                    .expect("stroke applies");
                black_box(view.tessellate(&doc, Detail::Interactive, &mut sink));
                (doc, view, sink)
            },
            BatchSize::LargeInput,
        )
    });
    let sheet = sculpt_core::editor::default_document();
    let eye = DVec3::new(0.0, 1.17, 0.6);
    let rays: Vec<Ray> = (0..100)
        .filter_map(|k| {
            let (i, j) = (f64::from(k % 10), f64::from(k / 10));
            let through = DVec3::new(-0.6 + 0.13 * i, 0.8 + 0.08 * j, -0.2);
            Ray::through(eye, through)
        })
        .collect();
    c.bench_function("ray_default_sheet_100", |b| {
        b.iter(|| {
            rays.iter()
                .filter(|r| cast_document(&sheet, r).is_some())
                .count()
        })
    });
    let doc = scene4();
    c.bench_function("scene4_final", |b| {
        b.iter(|| black_box(doc.mesh(Detail::Final)))
    });
    // A fresh view has no stroke surfaces yet: each iteration builds all of them.
    let target = doc.targets()[0].id;
    c.bench_function("scene4_stroke_surfaces", |b| {
        b.iter_batched(
            DocumentView::new,
            |mut view| {
                black_box(view.stroke_surfaces(&doc, target).len());
                view
            },
            BatchSize::LargeInput,
        )
    });
}

criterion_group! {
    name = sculpt;
    config = Criterion::default()
        .sample_size(20)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    targets = benches
}
criterion_main!(sculpt);
