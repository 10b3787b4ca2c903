//! The root cells as a set: which roots a stroke or segment touches, their
//! neighbours across sides and seams, and masks grown by rings of neighbours.

use super::TargetTessellation;
use super::poles::pole_of;
use crate::sculpt::jordan::Rect;
use crate::sculpt::stroke::Stroke;
use crate::tolerance::UV_PAD;
use glam::DVec2;

impl TargetTessellation {
    /// The roots a stroke touches: those meeting one of its pieces' bounds.
    pub(super) fn roots_touched(&self, s: &Stroke) -> Vec<u32> {
        let n = self.map.n();
        let mut mask = vec![false; (n * n) as usize];
        for r in s.piece_bounds() {
            let r = Rect::new(r.min - DVec2::splat(UV_PAD), r.max + DVec2::splat(UV_PAD));
            for root in self.roots_near(&r) {
                if self.map.node(root).rect.touches(&r) {
                    mask[root as usize] = true;
                }
            }
        }
        (0..n * n).filter(|&r| mask[r as usize]).collect()
    }

    /// Calls `f` for every root whose closed rectangle meets the segment.
    pub(super) fn for_roots_meeting(&self, s: [DVec2; 2], mut f: impl FnMut(u32)) {
        for root in self.roots_near(&Rect::of_segment(s[0], s[1])) {
            if self.map.node(root).rect.meets_segment(s[0], s[1]) {
                f(root);
            }
        }
    }

    /// The roots of the grid cells under `r`, widened by one cell (a rectangle ending
    /// on a cell side belongs to both cells).
    pub(super) fn roots_near(&self, r: &Rect) -> impl Iterator<Item = u32> + '_ {
        let n = self.map.n();
        let cell = |x: f64| ((x * n as f64).floor().max(0.0) as u32).min(n - 1);
        let (i0, i1) = (
            cell(r.min.x).saturating_sub(1),
            (cell(r.max.x) + 1).min(n - 1),
        );
        let (j0, j1) = (
            cell(r.min.y).saturating_sub(1),
            (cell(r.max.y) + 1).min(n - 1),
        );
        (j0..=j1).flat_map(move |j| (i0..=i1).map(move |i| self.map.root(i, j)))
    }

    /// The rectangles a classification of root `root`'s nodes may ask about: the root
    /// widened by two root cells (more than [`super::uvmap::GRADING_REACH`] of its
    /// largest node), with its copies one period over on a closed surface.
    pub(super) fn reach_of(&self, root: u32) -> Vec<Rect> {
        let rect = self.map.node(root).rect;
        let reach = (rect.max - rect.min) * 2.0;
        let wide = Rect::new(rect.min - reach, rect.max + reach);
        let shifts = |closed: bool| {
            if closed {
                vec![-1.0, 0.0, 1.0]
            } else {
                vec![0.0]
            }
        };
        let mut out = Vec::new();
        for dv in shifts(self.extent.closed_v) {
            for du in shifts(self.extent.closed_u) {
                let d = DVec2::new(du, dv);
                out.push(Rect::new(wide.min + d, wide.max + d));
            }
        }
        out
    }

    /// The mask grown by one ring of neighbours (across the seams of closed surfaces).
    pub(super) fn grow(&self, mask: &[bool]) -> Vec<bool> {
        let mut out = mask.to_vec();
        for (r, _) in mask.iter().enumerate().filter(|(_, m)| **m) {
            for side in 0..4 {
                if let Some((nb, _)) = self.neighbour(r as u32, side) {
                    out[nb as usize] = true;
                }
            }
        }
        out
    }

    /// The mask grown by the eight surrounding roots (across the seams of closed
    /// surfaces).
    pub(super) fn grow_with_corners(&self, mask: &[bool]) -> Vec<bool> {
        let mut out = mask.to_vec();
        for (r, _) in mask.iter().enumerate().filter(|(_, m)| **m) {
            let r = r as u32;
            let row = [
                Some(r),
                self.neighbour(r, 0).map(|x| x.0),
                self.neighbour(r, 1).map(|x| x.0),
            ];
            for c in row.into_iter().flatten() {
                out[c as usize] = true;
                for side in [2, 3] {
                    if let Some((nb, _)) = self.neighbour(c, side) {
                        out[nb as usize] = true;
                    }
                }
            }
        }
        out
    }

    /// True when root cell `root` lies along side `side` of the square (0 u-min, 1 u-max,
    /// 2 v-min, 3 v-max).
    pub(super) fn root_on_side(&self, root: u32, side: usize) -> bool {
        let n = self.map.n();
        let (i, j) = (root % n, root / n);
        match side {
            0 => i == 0,
            1 => i + 1 == n,
            2 => j == 0,
            _ => j + 1 == n,
        }
    }

    /// True when the segment lies on a pole (a side of the square that is one point).
    pub(super) fn on_pole(&self, s: &[DVec2; 2]) -> bool {
        let [a, b] = s.map(|p| pole_of(self.poles, p));
        a.is_some() && a == b
    }
    /// The neighbour root across `side` (0 u-min, 1 u-max, 2 v-min, 3 v-max), wrapping
    /// across the seam of a closed surface.
    pub(super) fn neighbour(&self, root: u32, side: u8) -> Option<(u32, u8)> {
        let n = self.map.n();
        let (i, j) = (root % n, root / n);
        let (cu, cv) = (self.extent.closed_u, self.extent.closed_v);
        let r = match side {
            0 if i > 0 => (i - 1, j),
            0 if cu => (n - 1, j),
            1 if i + 1 < n => (i + 1, j),
            1 if cu => (0, j),
            2 if j > 0 => (i, j - 1),
            2 if cv => (i, n - 1),
            3 if j + 1 < n => (i, j + 1),
            3 if cv => (i, 0),
            _ => return None,
        };
        Some((self.map.root(r.0, r.1), side ^ 1))
    }
}
