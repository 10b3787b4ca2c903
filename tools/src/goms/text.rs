//! Text for the PNG plots, laid out from the font's own metrics.
//!
//! plotters' `ab_glyph` text drawing places each glyph's bitmap at the pen position
//! without the glyph's left side bearing (the outline's offset from its origin), so a
//! glyph with a large bearing after a kerned pair slides under its neighbour: "Tr" in
//! "Trimming" read as "Ti". [`Kerned`] wraps a drawing backend and draws text itself:
//! the pen advances by each glyph's advance width plus the pair kerning of the font
//! (`kern` table), and each outline is drawn at its own pixel bounds. Everything else
//! goes to the wrapped backend unchanged. Every label is DejaVu Sans (the only font the
//! plots use).

use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingBackend, DrawingErrorKind,
};

/// The plots' font.
pub static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

/// One glyph of a laid-out line: its character, pen position (pixels from the line
/// start) and advance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placed {
    /// The character.
    pub c: char,
    /// Pen position of the glyph's origin.
    pub x: f32,
    /// Advance width (without kerning).
    pub advance: f32,
}

/// A line of text laid out at `size` pixels (the em height plotters uses): the glyphs,
/// the line's width (last pen position plus its advance), ascent and descent.
#[derive(Debug, Clone, PartialEq)]
pub struct Line {
    /// Glyphs in order.
    pub glyphs: Vec<Placed>,
    /// Width in pixels.
    pub width: f32,
    /// Ascent above the baseline, pixels.
    pub ascent: f32,
    /// Descent below the baseline (negative), pixels.
    pub descent: f32,
}

fn font() -> Option<FontRef<'static>> {
    FontRef::try_from_slice(FONT).ok()
}

/// Lays out `text` at `size` pixels: each pen position is the previous one plus its
/// advance and the pair's kerning.
pub fn layout(text: &str, size: f32) -> Line {
    let Some(f) = font() else {
        return Line {
            glyphs: Vec::new(),
            width: 0.0,
            ascent: 0.0,
            descent: 0.0,
        };
    };
    let f = f.as_scaled(PxScale::from(size));
    let mut pen = 0.0f32;
    let mut prev = None;
    let mut glyphs = Vec::new();
    for c in text.chars() {
        let id = f.glyph_id(c);
        if let Some(p) = prev {
            pen += f.kern(p, id);
        }
        let advance = f.h_advance(id);
        glyphs.push(Placed { c, x: pen, advance });
        pen += advance;
        prev = Some(id);
    }
    Line {
        glyphs,
        width: pen,
        ascent: f.ascent(),
        descent: f.descent(),
    }
}

/// Rasterises a line: calls `pixel(x, y, coverage)` for each covered pixel, `x` from
/// the pen start, `y` down from the line's top (the ascent above the baseline).
pub fn rasterise(text: &str, size: f32, mut pixel: impl FnMut(i32, i32, f32)) {
    let Some(f) = font() else { return };
    let line = layout(text, size);
    let scale = PxScale::from(size);
    for g in &line.glyphs {
        let glyph = f
            .glyph_id(g.c)
            .with_scale_and_position(scale, point(g.x, line.ascent));
        if let Some(outline) = f.outline_glyph(glyph) {
            let b = outline.px_bounds();
            outline.draw(|x, y, c| {
                pixel(b.min.x as i32 + x as i32, b.min.y as i32 + y as i32, c);
            });
        }
    }
}

/// A drawing backend whose text is laid out with the font's advances, bearings and
/// kerning (see the module docs); everything else is the wrapped backend's.
pub struct Kerned<DB>(pub DB);

impl<DB: DrawingBackend> DrawingBackend for Kerned<DB> {
    type ErrorType = DB::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.0.get_size()
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.ensure_prepared()
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.present()
    }

    fn draw_pixel(
        &mut self,
        point: BackendCoord,
        color: BackendColor,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_pixel(point, color)
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_line(from, to, style)
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_rect(upper_left, bottom_right, style, fill)
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_path(path, style)
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_circle(center, radius, style, fill)
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.fill_polygon(vert, style)
    }

    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.blit_bitmap(pos, size, src)
    }

    fn estimate_text_size<TStyle: BackendTextStyle>(
        &self,
        text: &str,
        style: &TStyle,
    ) -> Result<(u32, u32), DrawingErrorKind<Self::ErrorType>> {
        let line = layout(text, style.size() as f32);
        Ok((
            line.width.ceil() as u32,
            (line.ascent - line.descent).ceil() as u32,
        ))
    }

    fn draw_text<TStyle: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &TStyle,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let size = style.size() as f32;
        let line = layout(text, size);
        let (width, height) = (
            line.width.round() as i32,
            (line.ascent - line.descent).round() as i32,
        );
        // The anchor as plotters places it: the layout box's corner, edge or centre at
        // `pos`, before the rotation.
        let dx = match style.anchor().h_pos {
            HPos::Left => 0,
            HPos::Right => -width,
            HPos::Center => -width / 2,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0,
            VPos::Center => -height / 2,
            VPos::Bottom => -height,
        };
        let trans = style.transform();
        let (w, h) = self.0.get_size();
        let mut pixels = Vec::new();
        rasterise(text, size, |x, y, c| pixels.push((x, y, c)));
        for (x, y, c) in pixels {
            let (x, y) = trans.transform(x + dx, y + dy);
            let (x, y) = (pos.0 + x, pos.1 + y);
            if x >= 0 && x < w as i32 && y >= 0 && y < h as i32 && c > 0.0 {
                self.0.draw_pixel(
                    (x, y),
                    BackendColor {
                        alpha: color.alpha * f64::from(c.min(1.0)),
                        rgb: color.rgb,
                    },
                )?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tolerance::{GLYPH_ADVANCE_SUM_EPS, GLYPH_INK_PX};
    use plotters::prelude::*;

    const SIZE: f32 = 40.0;

    /// Ink columns of a rendered label: the x of every column with a dark pixel.
    fn ink_columns(text: &str, kerned: bool) -> Vec<u32> {
        let (w, h) = (600u32, 80u32);
        let mut buf = vec![255u8; (w * h * 3) as usize];
        crate::goms::plot::register_font();
        {
            let style = ("sans-serif", f64::from(SIZE)).into_font().color(&BLACK);
            if kerned {
                let root = Kerned(BitMapBackend::with_buffer(&mut buf, (w, h))).into_drawing_area();
                root.draw_text(text, &style, (10, 10)).unwrap();
                root.present().unwrap();
            } else {
                let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
                root.draw_text(text, &style, (10, 10)).unwrap();
                root.present().unwrap();
            }
        }
        (0..w)
            .filter(|&x| (0..h).any(|y| buf[((y * w + x) * 3) as usize] < 128))
            .collect()
    }

    /// The font's own numbers, read independently of [`layout`]: advance, kerning and
    /// left side bearing in pixels at `SIZE`.
    fn metrics(a: char, b: char) -> (f32, f32, f32, f32) {
        let f = FontRef::try_from_slice(FONT).unwrap();
        let s = f.as_scaled(PxScale::from(SIZE));
        let (ia, ib) = (f.glyph_id(a), f.glyph_id(b));
        (
            s.h_advance(ia),
            s.kern(ia, ib),
            s.h_side_bearing(ia),
            s.h_side_bearing(ib),
        )
    }

    /// Regression (issue 19): in the PNGs "Trimming" read as "Timming". The `r` of
    /// "Tr" must sit where the font puts it: its origin at T's origin + T's advance +
    /// the T-r kerning, so its ink ends there + the ink end of an `r` drawn alone (each
    /// within a pixel). plotters' own drawing leaves out each glyph's left side
    /// bearing and puts the `r` about that bearing further left.
    #[test]
    fn regression_the_r_of_tr_sits_at_the_fonts_advance_and_kerning() {
        let (adv_t, kern_tr, lsb_t, lsb_r) = metrics('T', 'r');
        // T alone: its ink starts at its bearing from the origin at x = 10.
        let t = ink_columns("T", true);
        sculpt_core::assert_near!(f64::from(t[0]), f64::from(10.0 + lsb_t), GLYPH_INK_PX);
        // r alone: the same for its bearing; its ink ends `r_end` from its origin.
        let r = ink_columns("r", true);
        sculpt_core::assert_near!(f64::from(r[0]), f64::from(10.0 + lsb_r), GLYPH_INK_PX);
        let r_end = *r.last().unwrap() as f32 - 10.0;
        let want = 10.0 + adv_t + kern_tr + r_end;
        let tr = ink_columns("Tr", true);
        sculpt_core::assert_near!(
            f64::from(*tr.last().unwrap()),
            f64::from(want),
            GLYPH_INK_PX
        );
        // plotters' own rasteriser puts it left of that by about the bearing.
        let plain = ink_columns("Tr", false);
        let short = want - *plain.last().unwrap() as f32;
        assert!(
            short > 0.5 * lsb_r,
            "plotters is {short} px short, r's bearing {lsb_r}"
        );
    }

    /// A whole label is laid out by the sum of its advances and kernings, and its ink
    /// ends where its last glyph's does when drawn alone at that pen position.
    #[test]
    fn a_labels_ink_spans_the_sum_of_advances_and_kerning() {
        let f = FontRef::try_from_slice(FONT).unwrap();
        let s = f.as_scaled(PxScale::from(SIZE));
        let text = "Maya trimming";
        let ids: Vec<_> = text.chars().map(|c| f.glyph_id(c)).collect();
        let sum: f32 = ids.iter().map(|&i| s.h_advance(i)).sum::<f32>()
            + ids.windows(2).map(|w| s.kern(w[0], w[1])).sum::<f32>();
        let line = layout(text, SIZE);
        sculpt_core::assert_near!(f64::from(line.width), f64::from(sum), GLYPH_ADVANCE_SUM_EPS);
        let last = line.glyphs.last().unwrap();
        let alone = ink_columns("g", true);
        let want = last.x + *alone.last().unwrap() as f32;
        let ink = ink_columns(text, true);
        sculpt_core::assert_near!(
            f64::from(*ink.last().unwrap()),
            f64::from(want),
            GLYPH_INK_PX
        );
    }
}
