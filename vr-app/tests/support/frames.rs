//! Drawing an [`AppState`] offscreen on lavapipe, shared by the picture tests
//! (`documents.rs`, `solid_view.rs`).

use sculpt_core::sculpt::tessellate::Detail;
use vr_app::app::AppState;
use vr_app::output::OutputMode;
use vr_app::render::{FrameInput, Gpu, OffscreenFrame, Renderer};

/// Mesa's lavapipe; a missing adapter is a failure, never a skip.
pub fn lavapipe() -> Gpu {
    match Gpu::headless_named(Some("llvmpipe")) {
        Ok(gpu) => gpu,
        Err(e) => panic!("these tests need lavapipe: {e}"),
    }
}

/// `app` drawn at 1 eye, mono, `w` x `h`, with its document at `detail`: at
/// [`Detail::Final`] as `headless::render_still` draws it, at [`Detail::Interactive`] as the live
/// view shows it while a gesture is live.
pub fn render_at(
    app: &mut AppState,
    renderer: &mut Renderer,
    detail: Detail,
    w: u32,
    h: u32,
) -> OffscreenFrame {
    renderer.sync_with(|sinks| app.sync_meshes(sinks));
    renderer.shown = detail;
    renderer.classes = app.surface_classes();
    let views = app.views().unwrap();
    let lines = app.overlay_lines();
    let input = FrameInput {
        views: &views,
        lines: &lines,
        hud: &[],
    };
    renderer
        .render_offscreen(&input, OutputMode::Mono, w, h)
        .unwrap()
}
