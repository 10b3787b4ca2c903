//! Golden-image tests of the headless renderer on lavapipe.
//!
//! The goldens in `tests/golden/` are compared byte by byte with a tolerance of ±2.
//! Regenerate them (after a deliberate rendering change) with `scripts/bless-goldens`
//! (which also regenerates the sculpted documents' goldens of `documents.rs`) and
//! review the PNGs.
//!
//! These tests need Mesa's lavapipe (`apt-get install mesa-vulkan-drivers libvulkan1`):
//! a missing adapter is a failure, never a skip.

use glam::DVec3;
use sculpt_core::mesh::{MeshSink, MeshVertex};
use vr_app::projection::{HeadPose, Screen, StereoRig};
use vr_app::render::{FrameInput, Gpu, LineVertex, OutputMode, Renderer, Views, cursor_lines};

#[path = "support/golden_image.rs"]
mod golden_image;

use golden_image::compare_or_bless;

fn lavapipe() -> Gpu {
    match Gpu::headless_named(Some("llvmpipe")) {
        Ok(gpu) => gpu,
        Err(e) => panic!("the golden tests need lavapipe: {e}"),
    }
}

fn screen() -> Screen {
    Screen::new(
        DVec3::new(-0.8, 0.3, 0.0),
        DVec3::new(0.8, 0.3, 0.0),
        DVec3::new(-0.8, 1.2, 0.0),
    )
    .unwrap()
}

fn head() -> HeadPose {
    HeadPose {
        position: DVec3::new(0.1, 0.8, 1.6),
        orientation: glam::DQuat::IDENTITY,
    }
}

/// A UV sphere split into `bands` patches by latitude band.
fn sphere(sink: &mut impl MeshSink, key0: u64, center: DVec3, radius: f64, bands: u32) {
    let (rings_per_band, segs) = (6, 32);
    for band in 0..bands {
        sink.begin_patch(key0 + u64::from(band));
        let index = |ring: u32, seg: u32, sink: &mut dyn MeshSink| {
            let v = ring as f64 / (bands * rings_per_band) as f64;
            let u = seg as f64 / segs as f64;
            let (theta, phi) = (v * std::f64::consts::PI, u * std::f64::consts::TAU);
            let n = DVec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            sink.push_vertex(MeshVertex {
                position: (center + n * radius).as_vec3().to_array(),
                normal: n.as_vec3().to_array(),
                uv: [u as f32, v as f32],
            })
        };
        let r0 = band * rings_per_band;
        let mut ids = Vec::new();
        for ring in r0..=r0 + rings_per_band {
            for seg in 0..=segs {
                ids.push(index(ring, seg, sink));
            }
        }
        let w = segs + 1;
        for r in 0..rings_per_band {
            for s in 0..segs {
                let (a, b) = (ids[(r * w + s) as usize], ids[(r * w + s + 1) as usize]);
                let (c, d) = (
                    ids[((r + 1) * w + s) as usize],
                    ids[((r + 1) * w + s + 1) as usize],
                );
                sink.push_triangle(a, c, b);
                sink.push_triangle(b, c, d);
            }
        }
        sink.end_patch();
    }
}

/// A flat ribbon standing in for a stroke surface.
fn ribbon(sink: &mut impl MeshSink, key: u64) {
    sink.begin_patch(key);
    let n = [0.0, 0.0, 1.0];
    for i in 0..=10 {
        let x = -0.6 + i as f32 * 0.04;
        for y in [0.45f32, 0.5] {
            sink.push_vertex(MeshVertex {
                position: [x, y, 0.25],
                normal: n,
                uv: [0.0, 0.0],
            });
        }
    }
    for i in 0..10 {
        let a = i * 2;
        sink.push_triangle(a, a + 2, a + 1);
        sink.push_triangle(a + 1, a + 2, a + 3);
    }
    sink.end_patch();
}

fn scene(renderer: &mut Renderer) {
    sphere(
        &mut renderer.targets,
        0,
        DVec3::new(0.0, 0.75, -0.1),
        0.3,
        3,
    );
    ribbon(&mut renderer.preview, 100);
}

#[test]
fn golden_frames_in_every_output_mode() {
    let gpu = lavapipe();
    let mut renderer = Renderer::new(&gpu, wgpu::TextureFormat::Rgba8Unorm);
    scene(&mut renderer);
    renderer.wireframe = true;
    let views = Views::new(&StereoRig::default(), &screen(), &head()).unwrap();
    let mut lines: Vec<LineVertex> = Vec::new();
    let ring: Vec<DVec3> = (0..=16)
        .map(|i| {
            let a = i as f64 / 16.0 * std::f64::consts::TAU;
            DVec3::new(0.2 + 0.03 * a.cos(), 0.8 + 0.03 * a.sin(), 0.2)
        })
        .collect();
    cursor_lines(
        DVec3::new(0.2, 0.8, 0.25),
        DVec3::new(0.0, 0.0, -1.0),
        &ring,
        true,
        &mut lines,
    );
    let hud = vec![
        "carve  V 8.0x3.0 mm".to_string(),
        "tracking ok  90 fps".to_string(),
    ];
    let input = FrameInput {
        views: &views,
        lines: &lines,
        hud: &hud,
    };
    for (mode, name) in [
        (OutputMode::Mono, "mono.png"),
        (OutputMode::SideBySide, "side-by-side.png"),
        (OutputMode::Anaglyph, "anaglyph.png"),
        (OutputMode::Dual, "dual.png"),
    ] {
        let frame = renderer.render_offscreen(&input, mode, 320, 180).unwrap();
        compare_or_bless(name, &frame.composite);
        if mode == OutputMode::Dual {
            compare_or_bless("dual-left-eye.png", &frame.left);
            compare_or_bless("dual-right-eye.png", &frame.right);
            // The eyes differ (stereo), and the composite is the two projector outputs.
            assert_ne!(frame.left.as_raw(), frame.right.as_raw());
            assert_eq!(frame.composite.dimensions(), (640, 180));
        }
    }
    // Eye swap exchanges the two outputs.
    let plain = renderer
        .render_offscreen(&input, OutputMode::Dual, 160, 90)
        .unwrap();
    renderer.swap_eyes = true;
    let swapped = renderer
        .render_offscreen(&input, OutputMode::Dual, 160, 90)
        .unwrap();
    assert_eq!(plain.left.as_raw(), swapped.right.as_raw());
    assert_eq!(plain.right.as_raw(), swapped.left.as_raw());
}

/// Centroid x (pixels) of the pixels brighter than the background in the red channel.
fn marker_centroid_x(img: &image::RgbaImage) -> f64 {
    let (mut sum, mut n) = (0.0, 0.0);
    for (x, _, p) in img.enumerate_pixels() {
        if p[0] > 200 {
            sum += f64::from(x) + 0.5;
            n += 1.0;
        }
    }
    assert!(n > 0.0, "marker not visible");
    sum / n
}

#[test]
fn eye_images_differ_by_the_expected_parallax() {
    // A small bright square 0.5 m behind a 1.6 m wide screen, head 1.6 m in front: the
    // on-screen parallax is ipd * 0.5 / (1.6 + 0.5) metres, i.e. that fraction of the
    // screen width in pixels.
    let gpu = lavapipe();
    let mut renderer = Renderer::new(&gpu, wgpu::TextureFormat::Rgba8Unorm);
    renderer.background = [0.0, 0.0, 0.0];
    let z = -0.5;
    renderer.targets.begin_patch(1);
    for (x, y) in [(-0.02, 0.73), (0.02, 0.73), (-0.02, 0.77), (0.02, 0.77)] {
        renderer.targets.push_vertex(MeshVertex {
            position: [x, y, z],
            normal: [0.35, 0.8, 0.5],
            uv: [0.0, 0.0],
        });
    }
    renderer.targets.push_triangle(0, 1, 2);
    renderer.targets.push_triangle(1, 3, 2);
    renderer.targets.end_patch();
    let s = screen();
    let h = HeadPose {
        position: DVec3::new(0.0, 0.75, 1.6),
        orientation: glam::DQuat::IDENTITY,
    };
    let rig = StereoRig::default();
    let views = Views::new(&rig, &s, &h).unwrap();
    let width = 1600;
    let frame = renderer
        .render_offscreen(
            &FrameInput {
                views: &views,
                lines: &[],
                hud: &[],
            },
            OutputMode::Dual,
            width,
            200,
        )
        .unwrap();
    let parallax_px = marker_centroid_x(&frame.right) - marker_centroid_x(&frame.left);
    let expected_m = rig.ipd * 0.5 / (1.6 + 0.5);
    let expected_px = expected_m / s.width() * f64::from(width);
    sculpt_core::assert_near!(parallax_px, expected_px, 1.0);
}

#[test]
fn only_changed_patches_are_uploaded() {
    let gpu = lavapipe();
    let mut renderer = Renderer::new(&gpu, wgpu::TextureFormat::Rgba8Unorm);
    sphere(&mut renderer.targets, 0, DVec3::ZERO, 1.0, 4);
    // A second object whose keys fall in another batch.
    let other = 1 << vr_app::render::mesh_store::BATCH_SHIFT;
    sphere(&mut renderer.targets, other, DVec3::X * 3.0, 1.0, 2);
    renderer.targets.flush();
    let after_first = renderer.targets.stats();
    assert_eq!(after_first.patch_uploads, 6);
    assert_eq!(after_first.batch_uploads, 2, "one draw batch per key range");
    assert_eq!(renderer.targets.len(), 6);
    assert_eq!(renderer.targets.batches().count(), 2);
    // Re-tessellate one band: that patch is stored and only its batch re-uploaded.
    sphere(&mut renderer.targets, 2, DVec3::ZERO, 1.0, 1);
    renderer.targets.flush();
    assert_eq!(renderer.targets.stats().patch_uploads, 7);
    assert_eq!(renderer.targets.stats().batch_uploads, 3);
    assert_eq!(renderer.targets.len(), 6);
    renderer.targets.remove_patch(3);
    renderer.targets.flush();
    assert_eq!(renderer.targets.len(), 5);
    assert_eq!(renderer.targets.stats().patch_uploads, 7);
    assert_eq!(renderer.targets.stats().batch_uploads, 4);
    // Removing a whole batch's patches removes the batch.
    renderer.targets.remove_patch(other);
    renderer.targets.remove_patch(other + 1);
    renderer.targets.flush();
    assert_eq!(renderer.targets.batches().count(), 1);
    // Bad input is dropped rather than sent to the GPU: out-of-range and NaN vertices.
    renderer.targets.begin_patch(9);
    let a = renderer.targets.push_vertex(MeshVertex {
        position: [f32::NAN, 0.0, 0.0],
        ..Default::default()
    });
    renderer.targets.push_triangle(a, a + 5, a);
    renderer.targets.end_patch();
    assert_eq!(renderer.targets.len(), 3);
    renderer.targets.flush();
    assert_eq!(renderer.targets.batches().count(), 1);
}
