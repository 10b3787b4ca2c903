//! Clipping segments to cells: where a segment crosses a cell side, computed so that
//! both cells sharing the side get the same bits.

use crate::sculpt::jordan::Rect;
use glam::DVec2;

pub(super) fn rect_strictly_contains(r: &Rect, p: DVec2) -> bool {
    p.x > r.min.x && p.x < r.max.x && p.y > r.min.y && p.y < r.max.y
}

/// Where segment `s` meets the line `u = fixed` (or `v = fixed` when `along_u`): the
/// other coordinate, computed from the segment's canonical (sorted) end order so that
/// both cells sharing the line get the same bits. Ends lying on the line count too.
pub(super) fn side_crossings(s: [DVec2; 2], fixed: f64, along_u: bool) -> Vec<f64> {
    let (mut a, mut b) = (s[0], s[1]);
    if (b.x, b.y) < (a.x, a.y) {
        std::mem::swap(&mut a, &mut b);
    }
    let (fa, fb, oa, ob) = if along_u {
        (a.y, b.y, a.x, b.x)
    } else {
        (a.x, b.x, a.y, b.y)
    };
    let mut out = Vec::new();
    if fa == fixed {
        out.push(oa);
    }
    if fb == fixed {
        out.push(ob);
    }
    if (fa < fixed && fb > fixed) || (fa > fixed && fb < fixed) {
        out.push(oa + (ob - oa) * (fixed - fa) / (fb - fa));
    }
    out
}

/// The part of segment `s` inside the closed rectangle, with ends on the sides computed
/// by [`side_crossings`] (so they match the side points exactly).
pub(super) fn clip_segment(s: [DVec2; 2], r: &Rect) -> Option<(DVec2, DVec2)> {
    let d = s[1] - s[0];
    let mut cuts: Vec<(f64, DVec2)> = Vec::new();
    if r.contains(s[0]) {
        cuts.push((0.0, s[0]));
    }
    if r.contains(s[1]) {
        cuts.push((1.0, s[1]));
    }
    for (fixed, along_u, lo, hi) in [
        (r.min.x, false, r.min.y, r.max.y),
        (r.max.x, false, r.min.y, r.max.y),
        (r.min.y, true, r.min.x, r.max.x),
        (r.max.y, true, r.min.x, r.max.x),
    ] {
        for o in side_crossings(s, fixed, along_u) {
            if o < lo || o > hi {
                continue;
            }
            let p = if along_u {
                DVec2::new(o, fixed)
            } else {
                DVec2::new(fixed, o)
            };
            let t = if d.length_squared() > 0.0 {
                (p - s[0]).dot(d) / d.length_squared()
            } else {
                0.0
            };
            cuts.push((t, p));
        }
    }
    if cuts.len() < 2 {
        return None;
    }
    cuts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (a, b) = (cuts[0].1, cuts[cuts.len() - 1].1);
    if a == b {
        return None;
    }
    // A convex cell: the piece between the extreme cuts is inside.
    Some((a, b))
}
