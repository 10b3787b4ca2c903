//! Solid targets in the display server (issue 35 item 3): `--solid MODEL` loads an
//! implicit solid, the wand carves it through, and the renderer draws its watertight
//! mesh, on lavapipe.
//!
//! - **Goldens** `tests/golden/solid-final.png` (after the stroke, final detail) and
//!   `solid-live.png` (mid-stroke, the live view with the stroke's ribbon).
//! - **Independent reference**: the GPU's coverage of the carved plate (its depth read
//!   back, one sample per pixel) against a CPU ray march of the solid's exact field
//!   (`SolidTarget::eval`: the model and the stroke's tool combined by R-functions,
//!   no mesh involved). They must agree away from the silhouette's edges, and both must
//!   see through the slot the stroke cut.
//! - **CLI**: `wandsculpt --solid` with a bad file is one error line and exit 1.
//!
//! These tests need Mesa's lavapipe: a missing adapter is a failure, never a skip.

#[path = "support/frames.rs"]
mod frames;
#[path = "support/golden_image.rs"]
mod golden_image;

use frames::{lavapipe, render_at};

use std::path::Path;

use glam::{DQuat, DVec3, DVec4};
use sculpt_core::interaction::{WandEvent, WandSample};
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::tessellate::Detail;
use vr_app::app::AppState;
use vr_app::config::Config;
use vr_app::projection::EyeCamera;
use vr_app::render::Renderer;

/// The plate: 30 cm x 20 cm, 3 mm thick, its top face at z = 5 cm.
const PLATE: &str =
    r#"{"version": 1, "solid": {"box": {"min": [-0.15, 1.07, 0.047], "max": [0.15, 1.27, 0.05]}}}"#;
/// The plate's top face (display z, metres).
const TOP: f64 = 0.05;
/// Size of the goldens.
const GOLDEN_SIZE: (u32, u32) = (320, 180);
/// Size of the coverage comparison.
const COVER_SIZE: (u32, u32) = (240, 135);
/// Ray-march step of the reference (metres): a tenth of the plate's thickness.
const MARCH_STEP: f64 = 0.0003;
/// The coverage masks may differ this many pixels from an edge of either: the mesh's
/// cell (2.4 mm, 128 cells over 30 cm) is about 1.3 px at this size.
const EDGE_PX: i64 = 2;

/// A desktop session in `dir` on an empty scene with the plate loaded as `--solid`
/// does, and a 2 cm x 1 cm V tool (its groove cuts through the 3 mm plate, leaving a
/// slot 14 mm wide on the far face).
fn plate_app(dir: &Path) -> AppState {
    let scene = dir.join("empty.json");
    std::fs::write(&scene, Document::new().to_json()).unwrap();
    let model = dir.join("plate.json");
    std::fs::write(&model, PLATE).unwrap();
    let mut config = Config::default();
    config.files.dir = dir.join("session");
    config.files.scene = Some(scene);
    config.files.solid = Some(model);
    config.tool.width = 0.02;
    config.tool.depth = 0.01;
    AppState::new(config).unwrap()
}

/// The wand events of a stroke across the plate at y = 1.17: hover, press, 40 samples
/// from x = -0.1 to 0.1 on the top face, and (when `release`) let go.
fn stroke_events(release: bool) -> Vec<WandEvent> {
    let at = |t: f64, p: DVec3, buttons: u32| {
        WandEvent::sample(t, WandSample::tracked(p, DQuat::IDENTITY, buttons))
    };
    let point = |i: usize| DVec3::new(-0.1 + 0.2 * i as f64 / 40.0, 1.17, TOP);
    let mut events = vec![at(0.0, point(0) + DVec3::Z * 0.05, 0)];
    let mut t = 0.5;
    for i in 0..=40 {
        events.push(at(t, point(i), 1));
        t += 1.0 / 60.0;
    }
    if release {
        events.push(at(t, point(40), 0));
    }
    events
}

fn play(app: &mut AppState, events: &[WandEvent]) {
    for ev in events {
        app.session.handle(ev).unwrap();
    }
}

#[test]
fn golden_pictures_of_a_carved_solid_final_and_live() {
    let gpu = lavapipe();
    let dir = tempfile::tempdir().unwrap();
    let mut app = plate_app(dir.path());
    assert!(
        app.hud_lines()[0].contains("target 1/1 solid plate"),
        "{:?}",
        app.hud_lines()
    );
    let mut renderer = Renderer::new(&gpu, wgpu::TextureFormat::Rgba8Unorm);
    // The uncut plate, from an app of its own: the pictures below are of an app that
    // drew nothing before the stroke.
    let other = tempfile::tempdir().unwrap();
    let uncut = render_at(
        &mut plate_app(other.path()),
        &mut Renderer::new(&gpu, wgpu::TextureFormat::Rgba8Unorm),
        Detail::Interactive,
        GOLDEN_SIZE.0,
        GOLDEN_SIZE.1,
    );
    play(&mut app, &stroke_events(false));
    assert!(app.session.interaction.gesture_active(), "a live stroke");
    let live = render_at(
        &mut app,
        &mut renderer,
        Detail::Interactive,
        GOLDEN_SIZE.0,
        GOLDEN_SIZE.1,
    );
    golden_image::compare_or_bless("solid-live.png", &live.composite);
    play(&mut app, &stroke_events(true)[42..]);
    app.session.tick(10.0).unwrap();
    assert_eq!(app.session.doc.solids()[0].solid.cuts().len(), 1, "carved");
    let done = render_at(
        &mut app,
        &mut renderer,
        Detail::Final,
        GOLDEN_SIZE.0,
        GOLDEN_SIZE.1,
    );
    golden_image::compare_or_bless("solid-final.png", &done.composite);
    // The slot shows while the stroke is drawn (the live groove, issue 35 item 3) and
    // after it: each picture differs from the uncut plate's in the slot's pixels.
    let changed = |a: &image::RgbaImage, b: &image::RgbaImage| {
        a.pixels().zip(b.pixels()).filter(|(a, b)| a != b).count()
    };
    let (while_drawn, carved) = (
        changed(&uncut.composite, &live.composite),
        changed(&uncut.composite, &done.composite),
    );
    assert!(
        while_drawn > 100 && carved > 100,
        "the slot shows: {while_drawn} pixels changed while drawn, {carved} after"
    );
}

/// Whether the ray through pixel `(x, y)` of `cam` (a `w` x `h` image) meets the
/// inside of the solid: marched in [`MARCH_STEP`] steps through the solid's grid box,
/// the field read exactly ([`sculpt_core::solid::SolidTarget::eval`]).
fn ray_hits(
    solid: &sculpt_core::solid::SolidTarget,
    cam: &EyeCamera,
    (x, y): (u32, u32),
    (w, h): (u32, u32),
) -> bool {
    let ndc_x = (f64::from(x) + 0.5) / f64::from(w) * 2.0 - 1.0;
    let ndc_y = 1.0 - (f64::from(y) + 0.5) / f64::from(h) * 2.0;
    let far = cam.clip_from_display().inverse() * DVec4::new(ndc_x, ndc_y, 0.5, 1.0);
    let dir = (far.truncate() / far.w - cam.eye).normalize();
    let f = solid.frame();
    let (lo, hi) = (f.lo, f.lo + DVec3::from(f.n.map(|k| k as f64)) * f.h);
    // The ray's stretch inside the box (slabs).
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for a in 0..3 {
        let (ta, tb) = ((lo[a] - cam.eye[a]) / dir[a], (hi[a] - cam.eye[a]) / dir[a]);
        t0 = t0.max(ta.min(tb));
        t1 = t1.min(ta.max(tb));
    }
    let mut t = t0;
    while t <= t1 {
        if solid.eval(cam.eye + dir * t) > 0.0 {
            return true;
        }
        t += MARCH_STEP;
    }
    false
}

#[test]
fn gpu_coverage_of_a_carved_solid_matches_its_exact_field() {
    let gpu = lavapipe();
    let dir = tempfile::tempdir().unwrap();
    let mut app = plate_app(dir.path());
    play(&mut app, &stroke_events(true));
    app.session.tick(10.0).unwrap();
    let mut renderer = Renderer::with_samples(&gpu, wgpu::TextureFormat::Rgba8Unorm, 1);
    render_at(
        &mut app,
        &mut renderer,
        Detail::Final,
        COVER_SIZE.0,
        COVER_SIZE.1,
    );
    let drawn = renderer.read_view_depth(0).unwrap().unwrap();
    let cam = app.views().unwrap().center;
    let solid = &app.session.doc.solids()[0].solid;
    assert_eq!(solid.cuts().len(), 1, "carved");
    let (w, h) = COVER_SIZE;
    let exact: Vec<bool> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|p| ray_hits(solid, &cam, p, COVER_SIZE))
        .collect();
    let at = |mask: &dyn Fn(u32, u32) -> bool, x: i64, y: i64| {
        x >= 0 && y >= 0 && x < i64::from(w) && y < i64::from(h) && mask(x as u32, y as u32)
    };
    let gpu_mask = |x: u32, y: u32| drawn.at(x, y).is_some();
    let cpu_mask = |x: u32, y: u32| exact[(y * w + x) as usize];
    let (mut both, mut mismatch, mut edge) = (0, 0, 0);
    for y in 0..h {
        for x in 0..w {
            let (g, c) = (gpu_mask(x, y), cpu_mask(x, y));
            both += usize::from(g && c);
            if g != c {
                let (xi, yi) = (i64::from(x), i64::from(y));
                let near_edge = (-EDGE_PX..=EDGE_PX).any(|dy| {
                    (-EDGE_PX..=EDGE_PX).any(|dx| {
                        at(&gpu_mask, xi + dx, yi + dy) != g || at(&cpu_mask, xi + dx, yi + dy) != c
                    })
                });
                if near_edge {
                    edge += 1;
                } else {
                    mismatch += 1;
                }
            }
        }
    }
    assert!(both > 5000, "the plate fills the view: {both} pixels");
    assert_eq!(
        mismatch, 0,
        "{mismatch} pixels away from an edge ({edge} at one)"
    );
    // The slot: on the stroke's line, inside the plate, both see through.
    let mid = |x: f64| -> (u32, u32) {
        let clip = cam.clip_from_display() * DVec3::new(x, 1.17, TOP).extend(1.0);
        let ndc = clip.truncate() / clip.w;
        (
            ((ndc.x * 0.5 + 0.5) * f64::from(w)) as u32,
            ((0.5 - ndc.y * 0.5) * f64::from(h)) as u32,
        )
    };
    let (x, y) = mid(0.0);
    assert!(
        !cpu_mask(x, y) && !gpu_mask(x, y),
        "see-through slot at {x},{y}"
    );
    let (x, y) = mid(0.13);
    assert!(
        cpu_mask(x, y) && gpu_mask(x, y),
        "plate beyond the slot at {x},{y}"
    );
}

/// `wandsculpt --solid` with a file that is missing, or holds no model: one error
/// line naming the file and why, exit status 1, and no session file written.
#[test]
fn a_bad_solid_file_is_one_error_line_and_exit_1() {
    let dir = tempfile::tempdir().unwrap();
    let garbage = dir.path().join("garbage.vm");
    std::fs::write(&garbage, "this is not a model\n").unwrap();
    let missing = dir.path().join("missing.json");
    let session = dir.path().join("session");
    for (file, why, head) in [
        (&garbage, "garbage.vm", "wandsculpt: solid "),
        (&missing, "missing.json", "wandsculpt: "),
    ] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_wandsculpt"))
            .args(["--headless", "--size", "64x36", "--solid"])
            .arg(file)
            .arg("--out")
            .arg(&session)
            .env("WANDSCULPT_ADAPTER", "llvmpipe")
            .env("RUST_LOG", "off")
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{why}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        let lines: Vec<&str> = stderr.lines().collect();
        assert_eq!(lines.len(), 1, "{why}: {stderr}");
        assert!(
            lines[0].starts_with(head) && lines[0].contains(why),
            "{stderr}"
        );
        assert!(!session.exists(), "{why}: the session directory was made");
    }
}
