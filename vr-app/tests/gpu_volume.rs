//! The GPU path of volumes (`vr_app::gpu_volume`, `wandsculpt --gpu-volume-eval`)
//! against the CPU's f64 evaluation rounded to f32 (`Volume::eval_grid_f32`, the
//! values `sculpt-tools volume grid --f32` writes), on lavapipe.
//!
//! The adapter is the one `WANDSCULPT_ADAPTER` names, lavapipe (`llvmpipe`) otherwise.
//! Without it a test says so and passes on a developer machine; in CI (a non-empty
//! `CI`) a missing adapter is a failure. The CPU reference is sculpt-core's evaluation,
//! itself checked against a direct Cox-de Boor sum and finite differences
//! (sculpt-core/tests/volume.rs); the GPU shader is independent code (WGSL).

use std::path::Path;
use std::process::Command;

use sculpt_core::volume::Volume;
use vr_app::gpu_volume::{GpuVolume, GpuVolumeError};
use vr_app::render::Gpu;
use vr_app::tolerance::VOLUME_GPU_REL;

/// The adapter named by `WANDSCULPT_ADAPTER`, else lavapipe; `None` (the test skips)
/// only outside CI.
fn adapter_name() -> String {
    std::env::var(vr_app::render::gpu::ADAPTER_ENV)
        .ok()
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "llvmpipe".into())
}

fn gpu() -> Option<Gpu> {
    let name = adapter_name();
    match Gpu::headless_named(Some(&name)) {
        Ok(gpu) => Some(gpu),
        Err(e) => {
            assert!(
                std::env::var_os("CI").is_none_or(|v| v.is_empty()),
                "the GPU volume tests need an adapter in CI ({name}): {e}"
            );
            eprintln!("skipped: no adapter {name:?}: {e}");
            None
        }
    }
}

/// A random rational volume: `degrees` per direction, `counts` control points,
/// `k` attributes, random interior knots on `[-1, 2]`, weights in `[0.5, 2]`.
fn random_volume(seed: u64, degrees: &[usize], counts: &[usize], k: usize) -> Volume {
    let mut rng = fastrand::Rng::with_seed(seed);
    let knots: Vec<Vec<f64>> = degrees
        .iter()
        .zip(counts)
        .map(|(&p, &c)| {
            let mut inner: Vec<f64> = (0..c - p - 1).map(|_| -1.0 + 3.0 * rng.f64()).collect();
            inner.sort_by(f64::total_cmp);
            let mut kv = vec![-1.0; p + 1];
            kv.extend(inner);
            kv.extend(std::iter::repeat_n(2.0, p + 1));
            kv
        })
        .collect();
    let total: usize = counts.iter().product();
    let values: Vec<f64> = (0..total * k).map(|_| -3.0 + 6.0 * rng.f64()).collect();
    let weights: Vec<f64> = (0..total).map(|_| 0.5 + 1.5 * rng.f64()).collect();
    let names = (0..k).map(|c| format!("a{c}")).collect();
    Volume::new(degrees.to_vec(), knots, names, values, Some(weights)).unwrap()
}

/// The largest absolute control value of every attribute.
fn scales(vol: &Volume) -> Vec<f64> {
    let k = vol.components();
    let mut out = vec![0.0f64; k];
    for i in 0..vol.point_count() {
        for (s, v) in out.iter_mut().zip(vol.control_values(i)) {
            *s = s.max(v.abs());
        }
    }
    out
}

/// Asserts the GPU values equal the CPU's to [`VOLUME_GPU_REL`] of each attribute's
/// scale; returns the largest relative difference.
fn assert_matches_cpu(vol: &Volume, res: &[usize], gpu_values: &[f32]) -> f64 {
    let cpu = vol.eval_grid_f32(res).unwrap();
    assert_eq!(gpu_values.len(), cpu.len());
    let k = vol.components();
    let scale = scales(vol);
    let mut worst = 0.0f64;
    for (i, (g, c)) in gpu_values.iter().zip(&cpu).enumerate() {
        let rel = (f64::from(*g) - f64::from(*c)).abs() / scale[i % k];
        worst = worst.max(rel);
        assert!(
            rel <= VOLUME_GPU_REL,
            "point {} attribute {}: gpu {g} cpu {c} (relative {rel:e})",
            i / k,
            i % k
        );
    }
    worst
}

/// A test volume's shape: degrees, control points per direction, attributes, and
/// the grid evaluated.
type Case<'a> = (&'a [usize], &'a [usize], usize, &'a [usize]);

#[test]
fn grids_match_the_cpu_in_one_to_four_directions() {
    let Some(gpu) = gpu() else { return };
    let cases: [Case<'_>; 4] = [
        // The bench's shape: trivariate cubic, 5 attributes, rational.
        (&[3, 3, 3], &[7, 7, 7], 5, &[13, 11, 9]),
        (&[2], &[6], 3, &[101]),
        (&[1, 4], &[3, 8], 2, &[17, 23]),
        (&[2, 1, 3, 2], &[4, 3, 5, 4], 4, &[5, 4, 6, 3]),
    ];
    for (seed, (degrees, counts, k, res)) in cases.into_iter().enumerate() {
        let vol = random_volume(seed as u64 + 1, degrees, counts, k);
        let compiled = GpuVolume::new(&gpu, &vol).unwrap();
        let (values, timing) = compiled.eval_grid(&gpu, &vol, res, None).unwrap();
        assert_eq!(timing.chunks, 1);
        let worst = assert_matches_cpu(&vol, res, &values);
        eprintln!("degrees {degrees:?}: largest relative difference {worst:e}");
    }
}

#[test]
fn chunked_dispatches_give_the_same_values() {
    let Some(gpu) = gpu() else { return };
    let vol = random_volume(7, &[3, 3, 3], &[6, 5, 7], 5);
    let compiled = GpuVolume::new(&gpu, &vol).unwrap();
    let res = [9, 8, 7]; // 504 points: 8 chunks of 64, the last one short
    let (whole, _) = compiled.eval_grid(&gpu, &vol, &res, None).unwrap();
    let (chunked, timing) = compiled.eval_grid(&gpu, &vol, &res, Some(64)).unwrap();
    assert_eq!(timing.chunks, 8);
    assert_eq!(whole, chunked);
    assert_matches_cpu(&vol, &res, &chunked);
}

#[test]
fn bad_grids_are_typed_errors() {
    let Some(gpu) = gpu() else { return };
    let vol = random_volume(3, &[2, 2], &[4, 4], 2);
    let compiled = GpuVolume::new(&gpu, &vol).unwrap();
    let e = compiled
        .eval_grid(&gpu, &vol, &[4, 4, 4], None)
        .unwrap_err();
    assert!(matches!(e, GpuVolumeError::Grid(_)), "{e}");
    let e = compiled.eval_grid(&gpu, &vol, &[4, 0], None).unwrap_err();
    assert!(
        matches!(e, GpuVolumeError::EmptyDirection { direction: 1 }),
        "{e}"
    );
}

/// Runs `wandsculpt --gpu-volume-eval`.
fn wandsculpt(volume: &Path, res: &str, out: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_wandsculpt"))
        .arg("--gpu-volume-eval")
        .arg(volume)
        .args(["--res", res, "--repeat", "2", "--out"])
        .arg(out)
        .env(vr_app::render::gpu::ADAPTER_ENV, adapter_name())
        .output()
        .unwrap()
}

#[test]
fn the_command_writes_the_cpu_layout_and_reports_the_adapter() {
    let Some(gpu) = gpu() else { return };
    drop(gpu);
    let dir = tempfile::tempdir().unwrap();
    let vol = random_volume(11, &[3, 3, 3], &[7, 7, 7], 5);
    let path = dir.path().join("vol.json");
    std::fs::write(&path, vol.to_json()).unwrap();
    let out = dir.path().join("v.f32");
    let o = wandsculpt(&path, "12,10,8", &out);
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "wandsculpt failed: {stderr}");
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(report["adapter"].as_str().is_some_and(|a| !a.is_empty()));
    assert!(report["gpu_ms"].as_f64().is_some_and(|t| t > 0.0));
    assert_eq!(report["points"], 960);
    let bytes = std::fs::read(&out).unwrap();
    let values: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    assert_eq!(values.len(), 960 * 5);
    assert_matches_cpu(&vol, &[12, 10, 8], &values);
    // Bad input: one clear line and a non-zero exit.
    for (res, want) in [
        ("12,10", "--res needs 3"),
        ("12,0,8", "not a positive count"),
    ] {
        let o = wandsculpt(&path, res, &out);
        let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(!o.status.success(), "{res}");
        assert!(stderr.contains(want), "{res}: {stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    }
}
