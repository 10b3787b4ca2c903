//! The recorded paint session (`tests/data/sessions/paint.poselog`) drawn by the
//! renderer (vr-app's headless renderer on lavapipe): the painted colour where the
//! attribute volume says paint is, the material elsewhere, and a painted scalar as a
//! heat map when the heat map is on.
//!
//! - **Pixel checks.** The expected colour of each pixel is computed here from the
//!   attribute volume itself (`AttributeField::eval` at the exact surface point under
//!   the pixel, found by the CPU ray caster `vr-app/tests/support/raycast.rs`), not
//!   through the renderer's tints. The lighting is linear in the albedo (`fs_mesh`:
//!   `albedo (hemi + diffuse) + specular`, then the composition's cavity factor `k`),
//!   so a pixel of albedo `A` is `z + (u - z) A / base` per channel in linear light,
//!   `u = k (base L + s)` the same frame unpainted (the stores' tint cleared) and
//!   `z = k s` the frame painted black all over.
//! - **Goldens**: `tests/golden/paint-final.png` (final detail) and
//!   `paint-live.png` (interactive detail, as the live view shows it), within the
//!   picture tests' tolerance (`WANDSCULPT_BLESS=1` rewrites them).

#[allow(dead_code)]
#[path = "../../vr-app/tests/support/golden_image.rs"]
mod golden_image;
#[allow(dead_code)]
#[path = "../../vr-app/tests/support/raycast.rs"]
mod raycast;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::DVec3;
use replay::config::ReplayConfig;
use replay::pipeline;
use sculpt_core::editor::default_surface_point;
use sculpt_core::mesh::{MeshSink, Tint};
use sculpt_core::paint::{COLOUR, PaintEdit, blend, heat};
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::surface::ParamSurface;
use sculpt_core::sculpt::tessellate::Detail;
use vr_app::app::AppState;
use vr_app::config::Config;
use vr_app::output::OutputMode;
use vr_app::render::material::srgb_to_linear;
use vr_app::render::{FrameInput, Gpu, Renderer, SurfaceClass};

/// Size of the pictures.
const SIZE: (u32, u32) = (320, 180);
/// Coverage above which a pixel counts as painted.
const PAINTED_MIN: f64 = 0.9;
/// Coverage below which a pixel counts as bare.
const BARE_MAX: f64 = 0.02;
/// Largest difference (linear light, per channel) between a painted pixel and its
/// prediction: 8-bit quantisation of the three pictures and of the paint texture, and
/// the texture's trilinear filter against the exact field.
const PAINTED_TOL: f64 = 0.03;
/// A predicted channel (linear) above this may have been clipped to 1 by the eye pass
/// before the composition darkened it by its cavity factor (about 0.9 on a smooth
/// surface, less in grooves), so it is only checked to be at least this bright.
const SATURATED: f64 = 0.7;
/// Largest difference (8-bit levels) of a bare pixel from the unpainted picture:
/// the tint is interpolated between vertices, so a bare pixel next to the paint may
/// take a trace of it.
const BARE_TOL: u8 = 3;
/// Fraction of painted (bare) pixels that must be within [`PAINTED_TOL`]
/// ([`BARE_TOL`]); the rest lie at the band's edges, where the per-vertex tint and the
/// exact field differ most.
const AGREE_MIN: f64 = 0.95;
/// Pixels this far (px) from the silhouette are checked: the outline and the cavity
/// term's reach near it are not linear in the albedo.
const EDGE_PX: i64 = 3;

fn session() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data/sessions/paint.poselog")
}

fn lavapipe() -> Gpu {
    match Gpu::headless_named(Some("llvmpipe")) {
        Ok(gpu) => gpu,
        Err(e) => panic!("these tests need lavapipe: {e}"),
    }
}

/// The paint session's document at its end, replayed as `replay` replays it.
fn painted_document() -> Document {
    let log = std::fs::read(session()).unwrap();
    let mut doc = None;
    // Any time past the end: the document at the last frame.
    let end = [1.0e9];
    pipeline::replay_log_rendering(
        &log,
        &ReplayConfig::default(),
        pipeline::default_document(),
        "paint",
        &end,
        &mut |_, r| {
            doc = Some(r.document().clone());
            Ok(())
        },
    )
    .unwrap();
    let doc = doc.unwrap();
    assert_eq!(doc.paints().len(), 3, "the session's three sweeps");
    doc
}

/// A desktop session in `dir` (the view framing the default sheet) showing `doc`.
fn app_showing(doc: Document, dir: &Path) -> AppState {
    let mut config = Config::default();
    config.files.dir = dir.to_path_buf();
    let mut app = AppState::new(config).unwrap();
    app.session.replace_document(doc);
    app.session.forget_sinks();
    app
}

/// `app` drawn in mono at [`SIZE`] with its document at `detail`.
fn render(app: &mut AppState, renderer: &mut Renderer, detail: Detail) -> image::RgbaImage {
    renderer.sync_with(|sinks| app.sync_meshes(sinks));
    renderer.shown = detail;
    renderer.classes = app.surface_classes();
    let views = app.views().unwrap();
    let input = FrameInput {
        views: &views,
        lines: &[],
        hud: &[],
    };
    renderer
        .render_offscreen(&input, OutputMode::Mono, SIZE.0, SIZE.1)
        .unwrap()
        .composite
}

/// The same frame with the stores' tint replaced by `tint` (the document and the
/// paint view are untouched, so the next sync does not tint them again).
fn render_tinted(
    app: &mut AppState,
    renderer: &mut Renderer,
    tint: Option<Tint>,
) -> image::RgbaImage {
    renderer.targets.set_tint(tint.clone());
    renderer.interactive.set_tint(tint);
    render(app, renderer, Detail::Final)
}

/// The two reference pictures of the frame: without paint, and painted black all
/// over (albedo 0: what is left is the specular term).
struct References {
    unpainted: image::RgbaImage,
    black: image::RgbaImage,
}

fn references(app: &mut AppState, renderer: &mut Renderer) -> References {
    let black = Tint {
        lo: [-100.0; 3],
        hi: [100.0; 3],
        at: Arc::new(|_| [0.0, 0.0, 0.0, 1.0]),
    };
    References {
        unpainted: render_tinted(app, renderer, None),
        black: render_tinted(app, renderer, Some(black)),
    }
}

/// What [`check_pixels`] found.
#[derive(Debug, Default)]
struct PaintCheck {
    /// Pixels of coverage above [`PAINTED_MIN`].
    painted: usize,
    /// Of those, pixels within [`PAINTED_TOL`] of their prediction.
    painted_ok: usize,
    /// Mean difference (linear) of a painted pixel from its prediction.
    painted_err: f64,
    /// Mean difference (linear) of a painted pixel's prediction from the unpainted
    /// pixel: what a renderer ignoring the paint would be off by.
    painted_change: f64,
    /// Pixels of coverage below [`BARE_MAX`].
    bare: usize,
    /// Of those, pixels within [`BARE_TOL`] of the unpainted picture.
    bare_ok: usize,
}

/// Compares `shown` pixel by pixel with the prediction from the references and
/// `expected`: the colour and coverage at a point of a target (by the target's id),
/// `None` where nothing is painted.
fn check_pixels(
    app: &AppState,
    shown: &image::RgbaImage,
    refs: &References,
    expected: impl Fn(u64, DVec3) -> Option<([f64; 3], f64)>,
) -> PaintCheck {
    let unpainted = &refs.unpainted;
    let doc = &app.session.doc;
    let cam = app.views().unwrap().center;
    let exact = raycast::cast(doc, &cam, SIZE.0, SIZE.1);
    let base = app
        .config
        .render
        .material
        .albedo(SurfaceClass::Target)
        .map(f64::from);
    let linear = |img: &image::RgbaImage, x: u32, y: u32| {
        let p = img.get_pixel(x, y).0;
        [0, 1, 2].map(|c| srgb_to_linear(f64::from(p[c]) / 255.0))
    };
    let interior = |x: u32, y: u32| {
        (-EDGE_PX..=EDGE_PX).all(|dy| {
            (-EDGE_PX..=EDGE_PX).all(|dx| {
                let (nx, ny) = (i64::from(x) + dx, i64::from(y) + dy);
                nx >= 0 && ny >= 0 && exact.hit(nx as u32, ny as u32).is_some()
            })
        })
    };
    let mut c = PaintCheck::default();
    for y in 0..SIZE.1 {
        for x in 0..SIZE.0 {
            let Some(hit) = exact.hit(x, y) else { continue };
            if !interior(x, y) {
                continue;
            }
            let target = &doc.targets()[hit.target];
            let p = target.target_surface().eval(hit.uv).p;
            let (colour, a) = expected(target.id, p).unwrap_or(([0.0; 3], 0.0));
            if a < BARE_MAX {
                c.bare += 1;
                let (s, u) = (shown.get_pixel(x, y).0, unpainted.get_pixel(x, y).0);
                if (0..3).all(|k| s[k].abs_diff(u[k]) <= BARE_TOL) {
                    c.bare_ok += 1;
                }
            } else if a > PAINTED_MIN {
                c.painted += 1;
                let albedo = blend(base.map(|v| v as f32), &colour, a).map(f64::from);
                let (s, u) = (linear(shown, x, y), linear(unpainted, x, y));
                let z = linear(&refs.black, x, y);
                let predicted =
                    [0, 1, 2].map(|k| (z[k] + (u[k] - z[k]) * albedo[k] / base[k]).min(1.0));
                // A channel predicted brighter than SATURATED may have been clipped
                // before the composition's cavity factor: it need only be as bright.
                let err = (0..3)
                    .map(|k| {
                        if predicted[k] > SATURATED {
                            (SATURATED - s[k]).max(0.0)
                        } else {
                            (s[k] - predicted[k]).abs()
                        }
                    })
                    .fold(0.0, f64::max);
                let change = (0..3)
                    .map(|k| (u[k] - predicted[k]).abs())
                    .fold(0.0, f64::max);
                c.painted_err += err;
                c.painted_change += change;
                if err <= PAINTED_TOL {
                    c.painted_ok += 1;
                }
            }
        }
    }
    if c.painted > 0 {
        c.painted_err /= c.painted as f64;
        c.painted_change /= c.painted as f64;
    }
    c
}

fn assert_check(what: &str, c: &PaintCheck) {
    eprintln!("{what}: {c:?}");
    assert!(c.painted > 200 && c.bare > 5000, "{what}: {c:?}");
    assert!(
        c.painted_ok as f64 >= AGREE_MIN * c.painted as f64,
        "{what}: painted pixels off their colour: {c:?}"
    );
    assert!(
        c.bare_ok as f64 >= AGREE_MIN * c.bare as f64,
        "{what}: bare pixels changed: {c:?}"
    );
    // The paint is visible: a renderer ignoring it would be off by far more than the
    // renderer is.
    assert!(
        c.painted_change > 4.0 * c.painted_err && c.painted_change > 2.0 * PAINTED_TOL,
        "{what}: {c:?}"
    );
}

#[test]
fn the_paint_session_is_drawn_in_its_painted_colour() {
    let doc = painted_document();
    let dir = tempfile::tempdir().unwrap();
    let mut app = app_showing(doc, dir.path());
    let gpu = lavapipe();
    let mut renderer = Renderer::with_samples(&gpu, wgpu::TextureFormat::Rgba8Unorm, 1);
    let painted = render(&mut app, &mut renderer, Detail::Final);
    let refs = references(&mut app, &mut renderer);
    let fields = |target, p| {
        let (value, a) = app.session.doc.attribute_field(target, COLOUR)?.eval(p);
        Some(([value[0], value[1], value[2]].map(|v| v.clamp(0.0, 1.0)), a))
    };
    let c = check_pixels(&app, &painted, &refs, fields);
    assert_check("colour", &c);
}

#[test]
fn golden_pictures_of_the_paint_session() {
    let doc = painted_document();
    let dir = tempfile::tempdir().unwrap();
    let mut app = app_showing(doc, dir.path());
    let mut renderer = Renderer::new(&lavapipe(), wgpu::TextureFormat::Rgba8Unorm);
    let final_detail = render(&mut app, &mut renderer, Detail::Final);
    golden_image::compare_or_bless("paint-final.png", &final_detail);
    let live = render(&mut app, &mut renderer, Detail::Interactive);
    golden_image::compare_or_bless("paint-live.png", &live);
}

/// The values of the two density strokes, and where they run (y on the sheet).
const DENSITIES: [(f64, f64); 2] = [(100.0, 1.02), (300.0, 1.32)];

/// A density stroke of `value` along y = `y` across the sheet, 5 mm above it.
fn density_stroke(target: u64, value: f64, y: f64) -> PaintEdit {
    PaintEdit {
        target,
        attribute: "density".into(),
        value: vec![value],
        radius: 0.03,
        samples: (0..=40)
            .map(|i| default_surface_point(-0.3 + 0.6 * f64::from(i) / 40.0, y) + DVec3::Z * 0.005)
            .collect(),
    }
}

#[test]
fn the_heat_map_key_shows_a_painted_scalar() {
    let mut doc = painted_document();
    let target = doc.targets()[0].id;
    for (value, y) in DENSITIES {
        doc.apply_paint(&density_stroke(target, value, y)).unwrap();
    }
    let dir = tempfile::tempdir().unwrap();
    let mut app = app_showing(doc, dir.path());
    let gpu = lavapipe();
    let mut renderer = Renderer::with_samples(&gpu, wgpu::TextureFormat::Rgba8Unorm, 1);
    let colour = render(&mut app, &mut renderer, Detail::Final);
    assert!(!app.hud_lines().iter().any(|l| l.starts_with("heat map")));

    app.toggle_heat_map();
    assert!(app.heat_map());
    assert!(
        app.hud_lines().iter().any(|l| l == "heat map: density"),
        "{:?}",
        app.hud_lines()
    );
    let heat_map = render(&mut app, &mut renderer, Detail::Final);
    // Off again: the painted colour, as before.
    app.toggle_heat_map();
    let colour_again = render(&mut app, &mut renderer, Detail::Final);
    assert!(
        colour == colour_again,
        "toggling back shows the colour again"
    );
    let refs = references(&mut app, &mut renderer);
    // The heat colour expected: the painted range 100..300 mapped blue to red.
    let (lo, hi) = (DENSITIES[0].0, DENSITIES[1].0);
    let expected = |target, p| {
        let (value, a) = app.session.doc.attribute_field(target, "density")?.eval(p);
        Some((heat((value[0] - lo) / (hi - lo)).map(f64::from), a))
    };
    let c = check_pixels(&app, &heat_map, &refs, expected);
    assert_check("heat map", &c);
}
