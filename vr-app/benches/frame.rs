//! Frame CPU time: uniform/buffer updates plus command encoding and submission for
//! both eyes, excluding the GPU's own work (waited for outside the measurement).
//!
//! Scene: the demo session (default surface, three carved grooves and an embossed
//! ridge) at 1280x720 per eye, dual output, HUD and cursor on.
//! Run: `cargo bench -p vr-app --bench frame -- --quick`.

use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use vr_app::app::AppState;
use vr_app::config::Config;
use vr_app::demo::demo_events;
use vr_app::render::{FrameInput, Gpu, OutputContent, OutputTarget, Renderer};

fn frame(c: &mut Criterion) {
    let gpu =
        Gpu::headless().expect("a GPU adapter (lavapipe: apt-get install mesa-vulkan-drivers)");
    let dir = tempfile::tempdir().expect("temp dir");
    let mut config = Config::default();
    config.files.dir = dir.path().to_path_buf();
    config.files.autosave_every = 0;
    let mut app = AppState::new(config).expect("session");
    for ev in demo_events(&app.screen) {
        app.session.handle(&ev).expect("demo event");
    }
    let mut renderer = Renderer::new(&gpu, wgpu::TextureFormat::Rgba8Unorm);
    renderer.sync(&mut app);
    let (w, h) = (1280, 720);
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
        "adapter: {}; triangles per eye: {}",
        gpu.describe(),
        renderer.document_store().triangle_count()
    );
    let mut g = c.benchmark_group("frame");
    g.sample_size(20)
        .measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_secs(1));
    g.bench_function("demo_scene_dual_1280x720_cpu", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let start = Instant::now();
                renderer.sync(&mut app);
                renderer.render(
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
                total += start.elapsed();
                // The GPU's work is not part of the CPU frame time.
                let _ = renderer.device().poll(wgpu::PollType::wait_indefinitely());
            }
            total
        })
    });
    g.finish();
}

criterion_group!(benches, frame);
criterion_main!(benches);
