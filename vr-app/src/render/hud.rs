//! HUD text as pixel quads: each lit pixel of an 8x8 bitmap glyph (`font8x8`) becomes
//! one quad, so the HUD needs no texture and no font rasteriser.
//!
//! ```
//! use vr_app::render::hud::{text_quads, HudVertex};
//! let mut out: Vec<HudVertex> = Vec::new();
//! text_quads("A", [0.0, 0.0], 1.0, [1.0; 4], &mut out);
//! assert!(!out.is_empty() && out.len() % 6 == 0);
//! ```

use bytemuck::{Pod, Zeroable};
use font8x8::UnicodeFonts;

/// One HUD vertex in output pixels (origin top-left, y down).
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct HudVertex {
    /// Position in output pixels.
    pub pixel: [f32; 2],
    /// Linear RGBA colour.
    pub color: [f32; 4],
}

/// Width and height of one glyph cell at scale 1 (pixels).
pub const GLYPH: f32 = 8.0;

/// Appends a filled rectangle (two triangles).
pub fn rect(min: [f32; 2], max: [f32; 2], color: [f32; 4], out: &mut Vec<HudVertex>) {
    let v = |x: f32, y: f32| HudVertex {
        pixel: [x, y],
        color,
    };
    out.extend_from_slice(&[
        v(min[0], min[1]),
        v(max[0], min[1]),
        v(max[0], max[1]),
        v(min[0], min[1]),
        v(max[0], max[1]),
        v(min[0], max[1]),
    ]);
}

/// Appends the quads for `text` starting at `origin` (top-left, pixels), each glyph
/// pixel `scale` output pixels wide. Characters without a glyph show as `?`.
/// Returns the width drawn, in pixels.
pub fn text_quads(
    text: &str,
    origin: [f32; 2],
    scale: f32,
    color: [f32; 4],
    out: &mut Vec<HudVertex>,
) -> f32 {
    let mut x = origin[0];
    for ch in text.chars() {
        let glyph = font8x8::BASIC_FONTS
            .get(ch)
            .or_else(|| font8x8::BASIC_FONTS.get('?'))
            .unwrap_or([0; 8]);
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..8 {
                if bits & (1 << col) != 0 {
                    let px = x + col as f32 * scale;
                    let py = origin[1] + row as f32 * scale;
                    rect([px, py], [px + scale, py + scale], color, out);
                }
            }
        }
        x += GLYPH * scale;
    }
    x - origin[0]
}

/// Lays out HUD lines in the top-left corner of a region `[x0, x0 + width)` of an
/// output `height` pixels tall, on a translucent dark panel.
pub fn hud_panel(lines: &[String], x0: f32, height: u32, out: &mut Vec<HudVertex>) {
    if lines.is_empty() {
        return;
    }
    let scale = (height as f32 / 360.0).floor().max(1.0);
    let line_h = (GLYPH + 3.0) * scale;
    let pad = 4.0 * scale;
    let widest = lines.iter().map(|l| l.chars().count()).max().unwrap_or(0) as f32 * GLYPH * scale;
    rect(
        [x0 + pad * 0.5, pad * 0.5],
        [
            x0 + pad * 1.5 + widest,
            pad * 1.5 + line_h * lines.len() as f32,
        ],
        [0.0, 0.0, 0.0, 0.55],
        out,
    );
    for (i, line) in lines.iter().enumerate() {
        text_quads(
            line,
            [x0 + pad, pad + i as f32 * line_h],
            scale,
            [0.95, 0.95, 0.85, 1.0],
            out,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glyph_pixels_become_quads() {
        let mut out = Vec::new();
        let w = text_quads("I", [10.0, 20.0], 2.0, [1.0; 4], &mut out);
        assert_eq!(w, 16.0);
        // font8x8 'I' has 18 lit pixels (a 6-wide serif top and bottom bar, 2 columns stem).
        let lit: u32 = font8x8::BASIC_FONTS
            .get('I')
            .unwrap()
            .iter()
            .map(|b| b.count_ones())
            .sum();
        assert_eq!(out.len(), lit as usize * 6);
        assert!(
            out.iter()
                .all(|v| v.pixel[0] >= 10.0 && v.pixel[0] <= 26.0 && v.pixel[1] >= 20.0)
        );
        // Unknown characters fall back to '?', not nothing and not a panic.
        let mut q = Vec::new();
        text_quads("\u{1F600}", [0.0, 0.0], 1.0, [1.0; 4], &mut q);
        assert!(!q.is_empty());
    }

    #[test]
    fn empty_panel_draws_nothing() {
        let mut out = Vec::new();
        hud_panel(&[], 0.0, 480, &mut out);
        assert!(out.is_empty());
        hud_panel(&["mode carve".into()], 0.0, 480, &mut out);
        assert!(out.len() > 6);
    }
}
