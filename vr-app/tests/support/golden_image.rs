//! Golden images shared by the picture tests (`golden.rs`, `documents.rs`): compare a
//! rendered image with its PNG in `tests/golden/`, or bless it.

use std::path::Path;

/// Per-channel tolerance of the goldens (8-bit values).
pub const GOLDEN_TOL: u8 = 2;

/// Compares `img` with the golden `tests/golden/NAME` within [`GOLDEN_TOL`] per channel
/// (saving the actual image to the temporary directory when it differs), or with
/// `WANDSCULPT_BLESS` set writes it as the new golden.
pub fn compare_or_bless(name: &str, img: &image::RgbaImage) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden")
        .join(name);
    if std::env::var_os("WANDSCULPT_BLESS").is_some() {
        img.save(&path).unwrap();
        eprintln!("blessed {}", path.display());
        return;
    }
    let golden = image::open(&path)
        .unwrap_or_else(|e| {
            panic!(
                "golden {}: {e} (regenerate with scripts/bless-goldens)",
                path.display()
            )
        })
        .to_rgba8();
    assert_eq!(golden.dimensions(), img.dimensions(), "{name}: size");
    let mut worst = 0u8;
    let mut bad = 0usize;
    for (a, b) in golden.as_raw().iter().zip(img.as_raw()) {
        let d = a.abs_diff(*b);
        worst = worst.max(d);
        if d > GOLDEN_TOL {
            bad += 1;
        }
    }
    if bad > 0 {
        let out = std::env::temp_dir().join(format!("wandsculpt-actual-{name}"));
        img.save(&out).unwrap();
        panic!(
            "{name}: {bad} bytes differ by more than {GOLDEN_TOL} (worst {worst}); actual \
             image at {} (bless with scripts/bless-goldens if the change is deliberate)",
            out.display()
        );
    }
}
