//! `wandsculpt --gpu-volume-eval VOL.json --res R1,..,Rn --out V.f32`: a volume's
//! attributes on a uniform parameter grid, evaluated on the GPU with no window
//! (docs/volumes.md, "GPU evaluation").
//!
//! The file has the layout `sculpt-tools volume grid VOL.json --res .. --f32` writes:
//! little-endian f32, `k` values per grid point (the attributes in the file's order),
//! the first index fastest. The JSON report on stdout names the adapter and gives the
//! GPU time from submit to the values read back.

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use sculpt_core::volume::Volume;
use serde_json::{Value, json};
use vr_app::gpu_volume::GpuVolume;
use vr_app::render::Gpu;

/// The largest volume file read (bytes).
const MAX_VOLUME_BYTES: u64 = 256 << 20;

/// The arguments of `--gpu-volume-eval`.
pub struct GpuVolumeArgs<'a> {
    /// The volume file (`wandsculpt-volume` JSON).
    pub volume: &'a Path,
    /// Grid points per direction, `R1,..,Rn`.
    pub res: &'a str,
    /// The f32 file written.
    pub out: &'a Path,
    /// Evaluations (timed each).
    pub repeat: usize,
}

/// The counts of `--res`: positive integers separated by commas.
fn parse_res(spec: &str) -> Result<Vec<usize>> {
    spec.split(',')
        .map(|t| match t.trim().parse::<usize>() {
            Ok(r) if r > 0 => Ok(r),
            _ => bail!("--res {spec:?}: {t:?} is not a positive count"),
        })
        .collect()
}

/// Milliseconds.
fn ms(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// Runs `--gpu-volume-eval`; returns the JSON report.
pub fn run(args: &GpuVolumeArgs<'_>) -> Result<Value> {
    let start = Instant::now();
    let size = std::fs::metadata(args.volume)
        .with_context(|| format!("cannot read {}", args.volume.display()))?
        .len();
    if size > MAX_VOLUME_BYTES {
        bail!(
            "{}: {size} bytes, more than the {MAX_VOLUME_BYTES} a volume file may take",
            args.volume.display()
        );
    }
    let text = std::fs::read_to_string(args.volume)
        .with_context(|| format!("cannot read {}", args.volume.display()))?;
    let vol = Volume::from_json(&text)
        .with_context(|| format!("{}: invalid volume", args.volume.display()))?;
    let res = parse_res(args.res)?;
    if res.len() != vol.directions() {
        bail!(
            "--res needs {} counts (one per direction), found {}",
            vol.directions(),
            res.len()
        );
    }
    let gpu = Gpu::headless()?;
    let info = gpu.adapter.get_info();
    let compiled = GpuVolume::new(&gpu, &vol)?;
    let mut runs = Vec::with_capacity(args.repeat);
    let mut values = Vec::new();
    let mut chunks = 0;
    for _ in 0..args.repeat.max(1) {
        let (v, timing) = compiled.eval_grid(&gpu, &vol, &res, None)?;
        runs.push(ms(timing.gpu));
        chunks = timing.chunks;
        values = v;
    }
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    fsio::write_atomic(args.out, &bytes)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    let mut sorted = runs.clone();
    sorted.sort_by(f64::total_cmp);
    Ok(json!({
        "volume": args.volume.display().to_string(),
        "res": res,
        "points": res.iter().product::<usize>(),
        "attributes": vol.attributes(),
        "adapter": info.name,
        "backend": format!("{:?}", info.backend),
        "device_type": format!("{:?}", info.device_type),
        "driver": info.driver_info,
        "setup_ms": ms(compiled.setup),
        "chunks": chunks,
        "gpu_ms": runs[0],
        "gpu_ms_median": sorted[sorted.len() / 2],
        "gpu_ms_min": sorted[0],
        "gpu_ms_runs": runs,
        "out": args.out.display().to_string(),
        "total_ms": ms(start.elapsed()),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn res_parses_positive_counts() {
        assert_eq!(parse_res("4,5,6").unwrap(), vec![4, 5, 6]);
        assert_eq!(parse_res(" 2 ").unwrap(), vec![2]);
        for bad in ["", "4,,5", "4,0", "a", "-1", "4;5"] {
            assert!(parse_res(bad).is_err(), "{bad}");
        }
    }
}
