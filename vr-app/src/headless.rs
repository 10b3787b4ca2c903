//! Headless runs: inputs in, journal, document, operator log and stereo PNGs out, with
//! no window (`wandsculpt --headless`).

use std::path::PathBuf;
use std::time::Duration;

use serde::Serialize;

use crate::app::AppState;
use crate::error::{VrError, VrResult};
use crate::feeder::Feeder;
/// The inputs of a run (defined with the other session inputs in [`crate::input`]).
pub use crate::input::Input;
use crate::journal::Journal;
use crate::output::OutputMode;
use crate::render::{FrameInput, Gpu, OffscreenFrame, OutputContent, OutputTarget, Renderer};
use crate::session::{JOURNAL_FILE, OPLOG_FILE};

/// Options of a headless run.
#[derive(Debug, Clone, PartialEq)]
pub struct HeadlessOptions {
    /// Output width per image (pixels).
    pub width: u32,
    /// Output height (pixels).
    pub height: u32,
    /// Composition of `frame.png`.
    pub mode: OutputMode,
    /// Also render a frame every this many wand events (0: only the final frame), to
    /// measure frame time along the way.
    pub render_every: usize,
    /// Pace wand events by their timestamps (real time) instead of as fast as possible.
    pub realtime: bool,
}

/// What a headless run did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeadlessReport {
    /// The adapter used.
    pub adapter: String,
    /// Inputs consumed.
    pub inputs: usize,
    /// Operations in the journal after the run.
    pub operations: u64,
    /// Operations recovered from an earlier run's journal.
    pub recovered: usize,
    /// Target surfaces in the document.
    pub targets: usize,
    /// Strokes in the document.
    pub strokes: usize,
    /// Frames rendered.
    pub frames: usize,
    /// Median CPU time per frame (update + encode, both eyes), microseconds.
    pub frame_cpu_median_us: f64,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// Files that could not be written in full, each with why (the operator log on a
    /// full disk): the run lost data, and `wandsculpt` exits non-zero.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub failed: Vec<String>,
}

/// Runs `inputs` through the [`Feeder`] of `app`'s config into its session,
/// rendering with `gpu`, and writes
/// `frame.png` (the `mode` composition) and, in the stereo modes, `left.png` and
/// `right.png` (each eye as its projector shows it), the saved document, the journal
/// and the operator log into the session directory. The pictures carry no HUD (it is
/// the desktop's status line, not part of the scene).
pub fn run_headless(
    app: &mut AppState,
    gpu: &Gpu,
    inputs: impl IntoIterator<Item = Input>,
    opts: &HeadlessOptions,
) -> VrResult<HeadlessReport> {
    let mut renderer =
        Renderer::with_samples(gpu, wgpu::TextureFormat::Rgba8Unorm, app.config.render.msaa);
    // A new renderer: its meshes are empty, whatever `app` drew before (a windowed
    // cluster node writes its pictures here at the end).
    app.new_sinks();
    renderer.wireframe = app.config.display.wireframe;
    renderer.swap_eyes = app.config.display.swap_eyes;
    renderer.set_material(app.config.render.material);
    let mut frame_times: Vec<Duration> = Vec::new();
    let mut feeder = Feeder::for_config(&app.config)?;
    let mut count = 0usize;
    let mut wand_events = 0usize;
    // The last wand time: a wand event's, or the stage's after a frame.
    let mut last_t = 0.0;
    let started = std::time::Instant::now();
    for input in inputs {
        count += 1;
        if let (true, Input::Wand(ev)) = (opts.realtime, &input)
            && ev.t.is_finite()
            && ev.t >= 0.0
        {
            let due = started + Duration::from_secs_f64(ev.t.min(1e6));
            if let Some(wait) = due.checked_duration_since(std::time::Instant::now()) {
                std::thread::sleep(wait);
            }
        }
        feeder.feed(&input, app)?;
        match &input {
            Input::Wand(ev) => last_t = ev.t,
            Input::Frame(_) => last_t = feeder.stage().time().unwrap_or(last_t),
            _ => {}
        }
        if matches!(input, Input::Wand(_) | Input::Frame(_)) {
            wand_events += 1;
            if opts.render_every > 0 && wand_events.is_multiple_of(opts.render_every) {
                frame_times.push(render_frame(app, &mut renderer, opts)?);
            }
        }
    }
    app.session.tick(last_t + 10.0)?;
    let doc_path = app.session.save_document()?;
    let frame = render_still(app, &mut renderer, opts.mode, opts.width, opts.height)?;
    frame_times.push(renderer.last_frame().cpu);
    let dir = app.session.dir().to_path_buf();
    let mut files = vec![doc_path, dir.join(JOURNAL_FILE)];
    let mut failed = Vec::new();
    match app.session.oplog_failure() {
        None => files.push(dir.join(OPLOG_FILE)),
        Some(e) => failed.push(format!("{}: {e}", dir.join(OPLOG_FILE).display())),
    }
    let mut images = vec![("frame.png", &frame.composite)];
    if opts.mode != OutputMode::Mono {
        images.extend([("left.png", &frame.left), ("right.png", &frame.right)]);
    }
    for (name, img) in images {
        let p = dir.join(name);
        // Encoded in memory, then written through a temporary file and renamed: a
        // full disk never leaves half a PNG behind.
        let mut png = std::io::Cursor::new(Vec::new());
        img.write_to(&mut png, image::ImageFormat::Png)
            .map_err(|source| VrError::Image {
                path: p.display().to_string(),
                source,
            })?;
        crate::session::write_atomic(&p, png.get_ref())?;
        files.push(p);
    }
    // The journal is the record of truth: make sure it reads back.
    let operations = Journal::read(dir.join(JOURNAL_FILE))?.len() as u64;
    frame_times.sort();
    let median = sculpt_core::percentile::median(&frame_times).unwrap_or_default();
    Ok(HeadlessReport {
        adapter: gpu.describe(),
        inputs: count,
        operations,
        recovered: app.session.recovered,
        targets: app.session.doc.targets().len(),
        strokes: app.session.doc.strokes().len(),
        frames: frame_times.len(),
        frame_cpu_median_us: median.as_secs_f64() * 1e6,
        files,
        failed,
    })
}

/// Renders what the display server shows now (the document, the wand cursor and any
/// live preview, from the current view, no HUD) offscreen at `width` x `height` in
/// `mode`, and reads it back: the picture a headless run writes.
pub fn render_still(
    app: &mut AppState,
    renderer: &mut Renderer,
    mode: OutputMode,
    width: u32,
    height: u32,
) -> VrResult<OffscreenFrame> {
    renderer.sync_with(|sinks| app.sync_meshes(sinks));
    renderer.classes = app.surface_classes();
    let views = app.views()?;
    let lines = app.overlay_lines();
    let input = FrameInput {
        views: &views,
        lines: &lines,
        hud: &[],
    };
    renderer.render_offscreen(&input, mode, width, height)
}

/// Renders one offscreen frame (not read back) and returns its CPU time.
fn render_frame(
    app: &mut AppState,
    renderer: &mut Renderer,
    opts: &HeadlessOptions,
) -> VrResult<Duration> {
    renderer.sync_with(|sinks| app.sync_meshes(sinks));
    renderer.classes = app.surface_classes();
    let views = app.views()?;
    let lines = app.overlay_lines();
    let texture = renderer.output_texture(opts.width, opts.height);
    let view = texture.create_view(&Default::default());
    let content = match opts.mode {
        OutputMode::SideBySide => OutputContent::SideBySide,
        OutputMode::Anaglyph => OutputContent::Anaglyph,
        OutputMode::Mono => OutputContent::Mono,
        OutputMode::Dual => OutputContent::LeftEye,
    };
    let stats = renderer.render(
        &FrameInput {
            views: &views,
            lines: &lines,
            hud: &[],
        },
        &[OutputTarget {
            view: &view,
            size: (opts.width, opts.height),
            content,
        }],
    );
    Ok(stats.cpu)
}
