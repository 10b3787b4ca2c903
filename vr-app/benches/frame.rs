//! Frame CPU time: the per-frame update (mesh sync with the document) plus uniform and
//! buffer updates and command encoding for both eyes (`..._update_encode`, the issue's
//! measure), and the same including the queue submission (`..._with_submit`: on
//! lavapipe the submission runs part of the software rasteriser on this thread). The
//! GPU's own work is waited for outside the measurement.
//!
//! Scene: paper scene 4 (`tests/data/scenes/mask-face.json`: a mask-like face with
//! embossed wrinkles, a carved brow and two crossing grooves), tessellated at final
//! detail, at 1920x1080 per eye, dual output, HUD and cursor on, head-tracked stereo
//! from 0.6 m, with the renderer's defaults (4x multisampling where the adapter allows,
//! cavity shading and outlines). Besides criterion's estimates it prints the median
//! and 99th percentile of every frame it timed.
//! Run: `cargo bench -p vr-app --bench frame -- --quick`.

use std::path::Path;
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use sculpt_core::sculpt::tessellate::Detail;
use vr_app::app::AppState;
use vr_app::config::Config;
use vr_app::render::{FrameInput, Gpu, OutputContent, OutputTarget, Renderer};

fn frame(c: &mut Criterion) {
    let gpu =
        Gpu::headless().expect("a GPU adapter (lavapipe: apt-get install mesa-vulkan-drivers)");
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/scenes/mask-face.json");
    // A 0.4 m x 0.3 m screen just behind the face (which is centred at the origin and
    // faces +z), the viewer 0.6 m in front.
    let mut config = Config::from_toml_str(
        "[screen]\nlower_left = [-0.2, -0.15, -0.1]\nlower_right = [0.2, -0.15, -0.1]\n\
         upper_left = [-0.2, 0.15, -0.1]\n[head]\nposition = [0.0, 0.0, 0.6]\n",
    )
    .expect("config");
    config.files.dir = dir.path().to_path_buf();
    config.files.scene = Some(scene);
    config.files.autosave_every = 0;
    let mut app = AppState::new(config).expect("session");
    let mut renderer = Renderer::new(&gpu, wgpu::TextureFormat::Rgba8Unorm);
    let tess_start = Instant::now();
    let sync = renderer.sync_with(|sinks| app.sync_meshes(sinks));
    assert_eq!(sync.shown, Detail::Final);
    renderer.targets.flush();
    let (w, h) = (1920, 1080);
    let make = || renderer.output_texture(w, h);
    let (ta, tb) = (make(), make());
    let (va, vb) = (
        ta.create_view(&Default::default()),
        tb.create_view(&Default::default()),
    );
    let views = app.views().expect("views");
    let lines = app.overlay_lines();
    let hud = app.hud_lines();
    eprintln!(
        "adapter: {}; strokes: {}; final-detail patches: {} in {} batches (draw calls per \
         eye); triangles per eye: {}; first sync \
         (both details tessellated and uploaded): {:.1} ms",
        gpu.describe(),
        app.session.doc.strokes().len(),
        renderer.document_store().len(),
        renderer.document_store().batches().count(),
        renderer.document_store().triangle_count(),
        tess_start.elapsed().as_secs_f64() * 1e3,
    );
    let mut g = c.benchmark_group("frame");
    g.sample_size(20)
        .measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_secs(1));
    let mut report = Vec::new();
    for (name, with_submit) in [
        ("mask_face_final_dual_1920x1080_update_encode", false),
        ("mask_face_final_dual_1920x1080_with_submit", true),
    ] {
        let mut frames: Vec<Duration> = Vec::new();
        g.bench_function(name, |b| {
            b.iter_custom(|iters| {
                let mut total = Duration::ZERO;
                for _ in 0..iters {
                    let start = Instant::now();
                    renderer.sync_with(|sinks| app.sync_meshes(sinks));
                    let update = start.elapsed();
                    let stats = renderer.render(
                        &FrameInput {
                            views: &views,
                            lines: &lines,
                            hud: &hud,
                        },
                        &[
                            OutputTarget {
                                view: &va,
                                size: (w, h),
                                content: OutputContent::LeftEye,
                            },
                            OutputTarget {
                                view: &vb,
                                size: (w, h),
                                content: OutputContent::RightEye,
                            },
                        ],
                    );
                    let frame = if with_submit {
                        start.elapsed()
                    } else {
                        update + stats.encode
                    };
                    frames.push(frame);
                    total += frame;
                    // The GPU's work is not part of the CPU frame time.
                    let _ = renderer.device().poll(wgpu::PollType::wait_indefinitely());
                }
                total
            })
        });
        if frames.is_empty() {
            continue; // filtered out on the command line
        }
        frames.sort();
        let at = |q: f64| sculpt_core::percentile::quantile(&frames, q).unwrap_or_default();
        report.push(format!(
            "{name}: {} frames, median {:.3} ms, p99 {:.3} ms",
            frames.len(),
            at(0.5).as_secs_f64() * 1e3,
            at(0.99).as_secs_f64() * 1e3
        ));
    }
    // The update alone (nothing changed: the document reports no dirty patch).
    g.bench_function("mask_face_sync_only", |b| {
        b.iter(|| renderer.sync_with(|sinks| app.sync_meshes(sinks)))
    });
    g.finish();
    eprintln!(
        "renderer: {} samples per pixel\n{}",
        renderer.sample_count(),
        report.join("\n")
    );
}

criterion_group!(benches, frame);
criterion_main!(benches);
