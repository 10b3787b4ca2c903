//! What the picture must show, measured on lavapipe renders: anti-aliased edges,
//! darker groove bottoms (cavity shading), sRGB-encoded PNG values, the cursor through
//! a surface, the selected and sketched targets told apart, and headless output files
//! (no HUD, one image in mono).
//!
//! These tests need Mesa's lavapipe (`apt-get install mesa-vulkan-drivers libvulkan1`):
//! a missing adapter is a failure, never a skip.

use glam::DVec3;
use sculpt_core::mesh::{MeshSink, MeshVertex};
use vr_app::projection::{HeadPose, Screen, StereoRig};
use vr_app::render::{
    EYE_FORMAT, FrameInput, Gpu, LineVertex, OutputMode, Renderer, SurfaceClasses, Views,
};

fn lavapipe() -> Gpu {
    match Gpu::headless_named(Some("llvmpipe")) {
        Ok(gpu) => gpu,
        Err(e) => panic!("these tests need lavapipe: {e}"),
    }
}

/// A 0.4 m x 0.225 m screen at z = 0, the eye 0.5 m in front of its centre.
fn views() -> Views {
    let screen = Screen::new(
        DVec3::new(-0.2, -0.1125, 0.0),
        DVec3::new(0.2, -0.1125, 0.0),
        DVec3::new(-0.2, 0.1125, 0.0),
    )
    .unwrap();
    let head = HeadPose {
        position: DVec3::new(0.0, 0.0, 0.5),
        orientation: glam::DQuat::IDENTITY,
    };
    Views::new(&StereoRig::default(), &screen, &head).unwrap()
}

/// Pixel of a display-frame point in a `w` x `h` mono frame.
fn pixel_of(views: &Views, p: DVec3, w: u32, h: u32) -> (u32, u32) {
    let ndc = views.center.project(p).unwrap();
    (
        ((ndc.x * 0.5 + 0.5) * f64::from(w)) as u32,
        ((0.5 - ndc.y * 0.5) * f64::from(h)) as u32,
    )
}

fn luma(p: &image::Rgba<u8>) -> f64 {
    0.299 * f64::from(p[0]) + 0.587 * f64::from(p[1]) + 0.114 * f64::from(p[2])
}

/// A patch of quads facing +z, every normal +z: `quads` as (x0, x1, y0, y1, z) with a
/// vertical wall joining neighbours at different z along x.
fn facing_quads(sink: &mut impl MeshSink, key: u64, quads: &[(f32, f32, f32, f32, f32)]) {
    sink.begin_patch(key);
    let n = [0.0, 0.0, 1.0];
    let push = |sink: &mut dyn MeshSink, c: [[f32; 3]; 4]| {
        let ids: Vec<u32> = c
            .iter()
            .map(|&position| {
                sink.push_vertex(MeshVertex {
                    position,
                    normal: n,
                    uv: [0.0, 0.0],
                })
            })
            .collect();
        sink.push_triangle(ids[0], ids[1], ids[2]);
        sink.push_triangle(ids[0], ids[2], ids[3]);
    };
    for (i, &(x0, x1, y0, y1, z)) in quads.iter().enumerate() {
        push(sink, [[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]]);
        if let Some(&(nx0, _, _, _, nz)) = quads.get(i + 1)
            && nz != z
        {
            push(
                sink,
                [[x1, y0, z], [nx0, y0, nz], [nx0, y1, nz], [x1, y1, z]],
            );
        }
    }
    sink.end_patch();
}

fn mono(
    renderer: &mut Renderer,
    views: &Views,
    lines: &[LineVertex],
    w: u32,
    h: u32,
) -> image::RgbaImage {
    renderer
        .render_offscreen(
            &FrameInput {
                views,
                lines,
                hud: &[],
            },
            OutputMode::Mono,
            w,
            h,
        )
        .unwrap()
        .composite
}

/// A tilted square on black: with 4x multisampling its edges have pixels between the
/// background and the square's shade; with one sample none do. (Outlines off, so only
/// the sampling makes intermediate values.)
#[test]
fn multisampling_gives_edge_pixels_intermediate_values() {
    let gpu = lavapipe();
    let views = views();
    let mut counts = Vec::new();
    for samples in [4, 1] {
        let mut r = Renderer::with_samples(&gpu, wgpu::TextureFormat::Rgba8Unorm, samples);
        assert_eq!(r.sample_count(), samples, "lavapipe supports 4x");
        r.background = [0.0, 0.0, 0.0];
        r.effects = false;
        r.targets.begin_patch(0);
        let a = 0.3f64;
        let ids: Vec<u32> = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .iter()
            .map(|&(x, y): &(f64, f64)| {
                let (c, s) = (a.cos(), a.sin());
                r.targets.push_vertex(MeshVertex {
                    position: [
                        (0.04 * (x * c - y * s)) as f32,
                        (0.04 * (x * s + y * c)) as f32,
                        -0.05,
                    ],
                    normal: [0.0, 0.0, 1.0],
                    uv: [0.0, 0.0],
                })
            })
            .collect();
        r.targets.push_triangle(ids[0], ids[1], ids[2]);
        r.targets.push_triangle(ids[0], ids[2], ids[3]);
        r.targets.end_patch();
        let img = mono(&mut r, &views, &[], 320, 180);
        let (cx, cy) = pixel_of(&views, DVec3::new(0.0, 0.0, -0.05), 320, 180);
        let inside = luma(img.get_pixel(cx, cy));
        assert!(inside > 60.0, "the square is lit: {inside}");
        let between = img
            .pixels()
            .filter(|p| {
                let l = luma(p);
                l > 0.15 * inside && l < 0.85 * inside
            })
            .count();
        counts.push(between);
    }
    // The square's outline is about 4 * 45 pixels long; many edge pixels are partial.
    assert!(counts[0] > 60, "4x: {} intermediate pixels", counts[0]);
    assert_eq!(counts[1], 0, "1x: no intermediate pixels");
}

/// A U groove 8 mm wide and 3 mm deep in a flat sheet, every normal the same (+z), so
/// the lighting alone cannot tell bottom from top: the cavity term makes the bottom
/// darker; with effects off they match.
#[test]
fn a_groove_bottom_is_darker_than_the_flat_surface_at_the_same_normal() {
    let gpu = lavapipe();
    let views = views();
    let (w, h) = (640, 360);
    let mut shades = Vec::new();
    for effects in [true, false] {
        let mut r = Renderer::new(&gpu, wgpu::TextureFormat::Rgba8Unorm);
        r.effects = effects;
        facing_quads(
            &mut r.targets,
            0,
            &[
                (-0.15, -0.004, -0.08, 0.08, -0.05),
                (-0.004, 0.004, -0.08, 0.08, -0.053),
                (0.004, 0.15, -0.08, 0.08, -0.05),
            ],
        );
        let img = mono(&mut r, &views, &[], w, h);
        let bottom = pixel_of(&views, DVec3::new(0.0, 0.0, -0.053), w, h);
        let flat = pixel_of(&views, DVec3::new(0.03, 0.0, -0.05), w, h);
        shades.push((
            luma(img.get_pixel(bottom.0, bottom.1)),
            luma(img.get_pixel(flat.0, flat.1)),
        ));
    }
    let (bottom, flat) = shades[0];
    assert!(
        bottom < 0.9 * flat,
        "cavity: bottom {bottom} vs flat {flat}"
    );
    let (bottom, flat) = shades[1];
    assert!(
        (bottom - flat).abs() < 0.05 * flat,
        "without the cavity term the same normal gives the same shade: {bottom} vs {flat}"
    );
}

/// The eye images are sRGB targets and the offscreen output is encoded by hand, so a
/// background of display value 0.5 reads back as 128 in the PNG bytes.
#[test]
fn png_values_are_srgb_encoded() {
    assert!(EYE_FORMAT.is_srgb());
    let gpu = lavapipe();
    let mut r = Renderer::new(&gpu, wgpu::TextureFormat::Rgba8Unorm);
    r.background = [0.5, 0.25, 0.75];
    let img = mono(&mut r, &views(), &[], 64, 36);
    for p in img.pixels() {
        for (c, want) in [(p[0], 128u8), (p[1], 64), (p[2], 191)] {
            assert!(c.abs_diff(want) <= 1, "{p:?}");
        }
    }
}

/// A red line behind a surface still shows (fainter), not hidden by it; in front it is
/// drawn as it is.
#[test]
fn the_cursor_shows_through_a_surface_in_front_of_it() {
    let gpu = lavapipe();
    let views = views();
    let (w, h) = (320, 180);
    let mut r = Renderer::new(&gpu, wgpu::TextureFormat::Rgba8Unorm);
    r.effects = false;
    facing_quads(&mut r.targets, 0, &[(-0.15, 0.15, -0.08, 0.08, -0.05)]);
    let red = [1.0, 0.0, 0.0, 1.0];
    let mut redness = |z: f64| {
        // A band of lines 4 mm tall, so whole pixels are covered.
        let lines: Vec<LineVertex> = (0..=10)
            .flat_map(|i| {
                let y = -0.002 + 0.0004 * f64::from(i);
                [
                    LineVertex::new(DVec3::new(-0.05, y, z), red),
                    LineVertex::new(DVec3::new(0.05, y, z), red),
                ]
            })
            .collect();
        let img = mono(&mut r, &views, &lines, w, h);
        let (x, y) = pixel_of(&views, DVec3::new(0.0, 0.0, z), w, h);
        let p = img.get_pixel(x, y);
        f64::from(p[0]) - f64::from(p[1])
    };
    let behind = redness(-0.1);
    let front = redness(0.0);
    let surface = {
        let img = mono(&mut r, &views, &[], w, h);
        let (x, y) = pixel_of(&views, DVec3::new(0.0, 0.0, -0.05), w, h);
        let p = img.get_pixel(x, y);
        f64::from(p[0]) - f64::from(p[1])
    };
    assert!(
        behind > surface + 40.0,
        "behind: {behind}, surface {surface}"
    );
    assert!(front > behind + 20.0, "front {front} vs behind {behind}");
}

/// Two targets side by side: the selected one gets an amber outline, a sketched one a
/// bluer shade.
#[test]
fn the_selected_target_is_outlined_and_a_sketched_one_tinted() {
    let gpu = lavapipe();
    let views = views();
    let (w, h) = (320, 180);
    let mut r = Renderer::new(&gpu, wgpu::TextureFormat::Rgba8Unorm);
    facing_quads(&mut r.targets, 0, &[(-0.15, -0.01, -0.08, 0.08, -0.05)]);
    facing_quads(&mut r.targets, 1 << 32, &[(0.01, 0.15, -0.08, 0.08, -0.05)]);
    let amber = |img: &image::RgbaImage| {
        img.pixels()
            .filter(|p| p[0] > 200 && p[1] > 100 && p[1] < 220 && p[2] < 80)
            .count()
    };
    let plain = mono(&mut r, &views, &[], w, h);
    r.classes = SurfaceClasses {
        selected: Some(1),
        sketched: Vec::new(),
    };
    let selected = mono(&mut r, &views, &[], w, h);
    assert_eq!(amber(&plain), 0);
    // Around the right target (about 2 * (125 + 100) pixels of outline).
    assert!(amber(&selected) > 200, "{}", amber(&selected));
    let left = pixel_of(&views, DVec3::new(-0.08, 0.0, -0.05), w, h);
    let right = pixel_of(&views, DVec3::new(0.08, 0.0, -0.05), w, h);
    let centre = pixel_of(&views, DVec3::new(0.0, 0.0, -0.05), w, h);
    assert!(
        selected
            .enumerate_pixels()
            .filter(|(_, _, p)| p[0] > 200 && p[1] > 100 && p[1] < 220 && p[2] < 80)
            .all(|(x, _, _)| x > centre.0),
        "the outline is around the selected target only"
    );
    r.classes = SurfaceClasses {
        selected: None,
        sketched: vec![1],
    };
    let sketched = mono(&mut r, &views, &[], w, h);
    let blueness = |img: &image::RgbaImage, (x, y): (u32, u32)| {
        let p = img.get_pixel(x, y);
        f64::from(p[2]) - f64::from(p[0])
    };
    assert!(
        blueness(&sketched, right) > blueness(&sketched, left) + 40.0,
        "sketched {:?} vs target {:?}",
        sketched.get_pixel(right.0, right.1),
        sketched.get_pixel(left.0, left.1)
    );
}

/// Headless pictures: no HUD whatever `display.hud` says, one `frame.png` in mono and
/// the two eyes besides it in the stereo modes.
#[test]
fn headless_writes_one_image_in_mono_and_no_hud() {
    use vr_app::app::AppState;
    use vr_app::config::Config;
    use vr_app::headless::{HeadlessOptions, run_headless};
    let gpu = lavapipe();
    let run = |mode: OutputMode, hud: bool| {
        let dir = tempfile::tempdir().unwrap();
        let mut cfg = Config::default();
        cfg.files.dir = dir.path().to_path_buf();
        cfg.display.hud = hud;
        let mut app = AppState::new(cfg).unwrap();
        let opts = HeadlessOptions {
            width: 160,
            height: 90,
            mode,
            render_every: 0,
            realtime: false,
        };
        run_headless(&mut app, &gpu, std::iter::empty(), &opts).unwrap();
        let read = |name: &str| {
            let p = dir.path().join(name);
            p.exists().then(|| image::open(p).unwrap().to_rgba8())
        };
        (read("frame.png"), read("left.png"), read("right.png"))
    };
    let (frame, left, right) = run(OutputMode::Mono, true);
    assert!(frame.is_some());
    assert!(left.is_none() && right.is_none(), "mono writes one image");
    let (plain, ..) = run(OutputMode::Mono, false);
    assert_eq!(
        frame, plain,
        "the HUD setting does not change a headless picture"
    );
    let (frame, left, right) = run(OutputMode::Anaglyph, true);
    let (left, right) = (left.unwrap(), right.unwrap());
    assert_eq!(frame.unwrap().dimensions(), (160, 90));
    assert_eq!(left.dimensions(), (160, 90));
    assert_ne!(left, right, "the eyes differ");
}
