//! The hidden region of a target (the union of its stroke footprints in UV), kept as
//! separate components so that applying a stroke costs what its neighbourhood costs.
//!
//! Each component is one shape of the polygon boolean (an outer contour and its holes),
//! with its bounding rectangle, indexed in a bucket grid over the UV square. Applying a
//! stroke unions its footprint with the live components whose bounds meet it (the
//! [`domain_overlay`] on its fixed grid, the same boolean as a union of the whole
//! region) and replaces them by the result; the others are untouched. Undo pops the
//! last step, restoring the components it replaced. So time and memory grow with the
//! strokes that overlap one another, not with the square of all strokes: a union of the
//! whole region per stroke, kept for every stroke for undo, cost both (issue 31, item 6).
//!
//! The queries the tessellator asks (the outline segments near some roots, a node's
//! class, grading's outline test) look only at components near the query, through
//! [`HiddenRegion::local`]: a component whose bounds stay clear of a point neither
//! contains it nor puts an edge near it, and a closed contour that does not surround a
//! point crosses a ray from it an even number of times, so the answers equal those of
//! the whole region.
//!
//! ```
//! use glam::DVec2;
//! use sculpt_core::sculpt::hidden::HiddenRegion;
//! use sculpt_core::sculpt::jordan::{Location, Region};
//!
//! let square = |x: f64, y: f64| {
//!     Region::new(vec![vec![
//!         DVec2::new(x, y), DVec2::new(x + 0.1, y),
//!         DVec2::new(x + 0.1, y + 0.1), DVec2::new(x, y + 0.1),
//!     ]])
//! };
//! let mut hidden = HiddenRegion::default();
//! hidden.push(1, &square(0.1, 0.1));
//! hidden.push(2, &square(0.15, 0.15)); // overlaps the first: one component
//! hidden.push(3, &square(0.7, 0.7)); // far away: its own component
//! assert_eq!(hidden.component_count(), 2);
//! assert_eq!(hidden.region().locate(DVec2::new(0.22, 0.22)), Location::Inside);
//! assert_eq!(hidden.pop(), Some(3));
//! assert_eq!(hidden.component_count(), 1);
//! ```

use super::jordan::{Rect, Region};
use super::stroke::{domain_overlay, region_to_contours};
use crate::tolerance::HIDDEN_COMPONENT_MARGIN;
use glam::DVec2;
use i_overlay::core::overlay_rule::OverlayRule;
use std::collections::HashMap;

/// Buckets per side of the UV square in the component index.
const GRID: usize = 64;

/// One shape of the union: an outer contour (counter-clockwise) and its holes
/// (clockwise).
#[derive(Debug, Clone)]
struct Component {
    contours: Vec<Vec<DVec2>>,
    bounds: Rect,
}

impl Component {
    /// The outline segments, as [`Region::new`] makes them (a zero-length edge is none).
    fn segments(&self) -> impl Iterator<Item = [DVec2; 2]> + '_ {
        self.contours.iter().flat_map(|c| {
            (0..c.len())
                .map(move |i| [c[i], c[(i + 1) % c.len()]])
                .filter(|[a, b]| a != b)
        })
    }
}

/// One applied stroke: the components it replaced and those it made.
#[derive(Debug, Clone)]
struct Step {
    id: u64,
    removed: Vec<u32>,
    added: Vec<u32>,
}

/// The union of the footprints of a sequence of strokes, as components, with undo.
/// See the [module docs](self).
#[derive(Debug, Clone, Default)]
pub struct HiddenRegion {
    /// Every component a step still refers to, by slot; `None` is a free slot.
    slots: Vec<Option<Component>>,
    free: Vec<u32>,
    live: Vec<bool>,
    /// Bucket grid over the square: the slots whose bounds meet each bucket.
    buckets: Vec<Vec<u32>>,
    steps: Vec<Step>,
    /// Outline segments that appeared (+1) or disappeared (-1) since the last
    /// [`Self::take_changed`], keyed by their bits; kept only while `tracking`.
    changes: HashMap<[u64; 4], ([DVec2; 2], i32)>,
    tracking: bool,
}

fn bucket(x: f64) -> usize {
    let x = if x.is_finite() { x } else { 0.0 };
    ((x * GRID as f64).floor().max(0.0) as usize).min(GRID - 1)
}

fn widen(r: &Rect, by: f64) -> Rect {
    Rect::new(r.min - DVec2::splat(by), r.max + DVec2::splat(by))
}

impl HiddenRegion {
    /// The ids of the applied strokes, in order.
    pub fn ids(&self) -> impl Iterator<Item = u64> + '_ {
        self.steps.iter().map(|s| s.id)
    }

    /// The number of applied strokes.
    pub fn len(&self) -> usize {
        self.steps.len()
    }

    /// True when no stroke is applied.
    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }

    /// The number of live components (connected pieces of the union, holes included in
    /// their piece).
    pub fn component_count(&self) -> usize {
        self.live.iter().filter(|&&l| l).count()
    }

    /// Memory held, bytes (components, index and undo log; estimated from lengths).
    pub fn memory_bytes(&self) -> usize {
        let points: usize = self
            .slots
            .iter()
            .flatten()
            .flat_map(|c| &c.contours)
            .map(|c| c.len() * 16 + 24)
            .sum();
        let buckets: usize = self.buckets.iter().map(|b| b.len() * 4 + 24).sum();
        let steps: usize = self
            .steps
            .iter()
            .map(|s| (s.removed.len() + s.added.len()) * 4 + 56)
            .sum();
        points + buckets + steps + self.slots.len() * 64
    }

    /// Unions the footprint of stroke `id` into the region.
    pub fn push(&mut self, id: u64, footprint: &Region) {
        let mut step = Step {
            id,
            removed: Vec::new(),
            added: Vec::new(),
        };
        if let Some(b) = footprint.bounds() {
            step.removed = self.live_near(&widen(&b, HIDDEN_COMPONENT_MARGIN));
            // The replaced components, then the footprint: the order of a union of the
            // whole region (`stroke::union(&[previous, footprint])`).
            let mut subject: Vec<Vec<[f64; 2]>> = Vec::new();
            for &slot in &step.removed {
                if let Some(c) = &self.slots[slot as usize] {
                    subject.extend(
                        c.contours
                            .iter()
                            .map(|c| c.iter().map(|p| [p.x, p.y]).collect()),
                    );
                }
            }
            subject.extend(region_to_contours(footprint));
            for &slot in &step.removed {
                self.set_live(slot, false);
            }
            for shape in domain_overlay(&subject, &[], OverlayRule::Subject) {
                // The same orientation as `region_from_shapes`: outer contour
                // counter-clockwise, holes clockwise.
                let shape = super::stroke::region_from_shapes(vec![shape]);
                let Some(bounds) = shape.bounds() else {
                    continue;
                };
                let contours = shape.contours().to_vec();
                let slot = self.insert(Component { contours, bounds });
                self.set_live(slot, true);
                step.added.push(slot);
            }
        }
        self.steps.push(step);
    }

    /// Undoes the last [`Self::push`]; returns its stroke id (`None` when empty).
    pub fn pop(&mut self) -> Option<u64> {
        let step = self.steps.pop()?;
        for &slot in &step.added {
            self.set_live(slot, false);
            self.remove(slot);
        }
        for &slot in &step.removed {
            self.set_live(slot, true);
        }
        Some(step.id)
    }

    /// Whether to record the outline segments that change (for
    /// [`Self::take_changed`]); off by default. A first build of a view needs no
    /// record, and recording costs a hash entry per segment of every replaced component.
    pub fn set_tracking(&mut self, on: bool) {
        self.tracking = on;
        if !on {
            self.changes.clear();
        }
    }

    /// The outline segments that appeared or disappeared since the last call while
    /// tracking (a segment that went and came back is not listed), in a fixed order.
    pub fn take_changed(&mut self) -> Vec<[DVec2; 2]> {
        let mut out: Vec<([u64; 4], [DVec2; 2])> = self
            .changes
            .drain()
            .filter(|(_, (_, n))| *n != 0)
            .map(|(k, (s, _))| (k, s))
            .collect();
        out.sort_unstable_by_key(|(k, _)| *k);
        out.into_iter().map(|(_, s)| s).collect()
    }

    /// The whole region as one [`Region`] (components in slot order).
    pub fn region(&self) -> Region {
        let slots: Vec<u32> = (0..self.slots.len() as u32)
            .filter(|&s| self.live[s as usize])
            .collect();
        self.region_of(&slots)
    }

    /// The part of the region near some rectangles: every live component whose bounds
    /// come within [`HIDDEN_COMPONENT_MARGIN`] of one of them. For any query inside the
    /// rectangles (location, classification, outline test) it answers as
    /// [`Self::region`] does.
    pub fn local(&self, rects: impl IntoIterator<Item = Rect>) -> Region {
        let mut slots: Vec<u32> = rects
            .into_iter()
            .flat_map(|r| self.live_near(&widen(&r, HIDDEN_COMPONENT_MARGIN)))
            .collect();
        slots.sort_unstable();
        slots.dedup();
        self.region_of(&slots)
    }

    /// Calls `f` with every outline segment of the live components whose bounds pass
    /// `near`.
    pub fn segments_where(&self, near: impl Fn(&Rect) -> bool, mut f: impl FnMut([DVec2; 2])) {
        for (slot, c) in self.slots.iter().enumerate() {
            if let Some(c) = c.as_ref().filter(|c| self.live[slot] && near(&c.bounds)) {
                c.segments().for_each(&mut f);
            }
        }
    }

    fn region_of(&self, slots: &[u32]) -> Region {
        Region::new(
            slots
                .iter()
                .filter_map(|&s| self.slots[s as usize].as_ref())
                .flat_map(|c| c.contours.iter().cloned())
                .collect(),
        )
    }

    /// The live slots whose bounds touch `r`, in slot order.
    fn live_near(&self, r: &Rect) -> Vec<u32> {
        let mut out = Vec::new();
        if self.buckets.is_empty() {
            return out;
        }
        for j in bucket(r.min.y)..=bucket(r.max.y) {
            for i in bucket(r.min.x)..=bucket(r.max.x) {
                for &slot in &self.buckets[j * GRID + i] {
                    let hit = self.live[slot as usize]
                        && self.slots[slot as usize]
                            .as_ref()
                            .is_some_and(|c| c.bounds.touches(r));
                    if hit {
                        out.push(slot);
                    }
                }
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    fn insert(&mut self, c: Component) -> u32 {
        if self.buckets.is_empty() {
            self.buckets = vec![Vec::new(); GRID * GRID];
        }
        let b = c.bounds;
        let slot = match self.free.pop() {
            Some(s) => {
                self.slots[s as usize] = Some(c);
                s
            }
            None => {
                self.slots.push(Some(c));
                self.live.push(false);
                (self.slots.len() - 1) as u32
            }
        };
        for j in bucket(b.min.y)..=bucket(b.max.y) {
            for i in bucket(b.min.x)..=bucket(b.max.x) {
                self.buckets[j * GRID + i].push(slot);
            }
        }
        slot
    }

    fn remove(&mut self, slot: u32) {
        if let Some(c) = self.slots[slot as usize].take() {
            let b = c.bounds;
            for j in bucket(b.min.y)..=bucket(b.max.y) {
                for i in bucket(b.min.x)..=bucket(b.max.x) {
                    self.buckets[j * GRID + i].retain(|&s| s != slot);
                }
            }
            self.free.push(slot);
        }
    }

    fn set_live(&mut self, slot: u32, live: bool) {
        if self.live[slot as usize] == live {
            return;
        }
        self.live[slot as usize] = live;
        let d = if live { 1 } else { -1 };
        if let Some(c) = self.slots[slot as usize].as_ref().filter(|_| self.tracking) {
            for s in c.segments() {
                let key = [s[0].x, s[0].y, s[1].x, s[1].y].map(f64::to_bits);
                self.changes.entry(key).or_insert((s, 0)).1 += d;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sculpt::jordan::Location;
    use crate::sculpt::stroke::union;
    use proptest::prelude::*;

    /// A quadrilateral footprint (counter-clockwise), like a short straight stroke's.
    fn quad(c: DVec2, half: DVec2, angle: f64) -> Region {
        let (s, k) = angle.sin_cos();
        let rot = |x: f64, y: f64| c + DVec2::new(x * k - y * s, x * s + y * k);
        Region::new(vec![vec![
            rot(-half.x, -half.y),
            rot(half.x, -half.y),
            rot(half.x, half.y),
            rot(-half.x, half.y),
        ]])
    }

    fn segment_keys(segments: impl IntoIterator<Item = [DVec2; 2]>) -> Vec<[u64; 4]> {
        let mut keys: Vec<[u64; 4]> = segments
            .into_iter()
            .map(|s| [s[0].x, s[0].y, s[1].x, s[1].y].map(f64::to_bits))
            .collect();
        keys.sort_unstable();
        keys
    }

    fn footprints() -> impl Strategy<Value = Vec<Region>> {
        prop::collection::vec(
            (
                0.05..0.95f64,
                0.05..0.95f64,
                0.01..0.12f64,
                0.005..0.04f64,
                0.0..3.2f64,
            ),
            1..24,
        )
        .prop_map(|v| {
            v.into_iter()
                .map(|(x, y, hx, hy, a)| quad(DVec2::new(x, y), DVec2::new(hx, hy), a))
                .collect()
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// The components hold exactly the outline of the whole-region union made the
        /// way the tessellator made it before (one union of the previous region and each
        /// footprint, kept per stroke), after pushes and after undoing some: same
        /// segments bit for bit, same point locations.
        #[test]
        fn components_equal_the_union_of_the_whole_region(
            fps in footprints(),
            undo in 0usize..6,
            probes in prop::collection::vec((0.0..1.0f64, 0.0..1.0f64), 32),
        ) {
            let mut hidden = HiddenRegion::default();
            let mut reference: Vec<Region> = Vec::new();
            for (k, fp) in fps.iter().enumerate() {
                hidden.push(k as u64, fp);
                let next = match reference.last() {
                    Some(prev) => union(&[prev, fp]),
                    None => union(&[fp]),
                };
                reference.push(next);
            }
            for _ in 0..undo.min(fps.len()) {
                hidden.pop();
                reference.pop();
            }
            let whole = reference.last().cloned().unwrap_or_else(Region::empty);
            let ours = hidden.region();
            prop_assert_eq!(
                segment_keys(ours.segments().iter().copied()),
                segment_keys(whole.segments().iter().copied())
            );
            for (x, y) in probes {
                let p = DVec2::new(x, y);
                let local = hidden.local([Rect::new(p, p)]);
                prop_assert_eq!(local.locate(p), whole.locate(p));
                let r = Rect::new(p, p + DVec2::splat(0.03));
                prop_assert_eq!(hidden.local([r]).classify(r), whole.classify(r));
            }
        }
    }

    /// The outline segments reported as changed are those of the union before and
    /// after, in either but not both (what the tessellator re-checks).
    #[test]
    fn changed_segments_are_the_difference_of_the_outlines() {
        let a = quad(DVec2::new(0.3, 0.3), DVec2::new(0.1, 0.02), 0.3);
        let b = quad(DVec2::new(0.35, 0.3), DVec2::new(0.1, 0.02), 1.2);
        let far = quad(DVec2::new(0.8, 0.8), DVec2::new(0.05, 0.02), 0.0);
        let mut hidden = HiddenRegion::default();
        hidden.push(1, &a);
        hidden.push(2, &far);
        let before = segment_keys(hidden.region().segments().iter().copied());
        hidden.set_tracking(true);
        hidden.push(3, &b);
        let after = segment_keys(hidden.region().segments().iter().copied());
        let mut expected: Vec<[u64; 4]> = before
            .iter()
            .filter(|k| after.binary_search(k).is_err())
            .chain(after.iter().filter(|k| before.binary_search(k).is_err()))
            .copied()
            .collect();
        expected.sort_unstable();
        assert!(!expected.is_empty());
        assert_eq!(segment_keys(hidden.take_changed()), expected);
        // Undo and redo the same stroke: nothing changed in all.
        hidden.pop();
        hidden.push(3, &b);
        assert!(hidden.take_changed().is_empty());
        assert_eq!(hidden.component_count(), 2);
        assert_eq!(
            hidden.region().locate(DVec2::new(0.8, 0.8)),
            Location::Inside
        );
    }

    /// Regression (issue 31, item 6): the view kept the whole union for every stroke,
    /// so memory grew with the square of the strokes. Scattered footprints now hold
    /// memory in proportion to their count.
    #[test]
    fn memory_grows_linearly_with_scattered_strokes() {
        let grid = |n: usize| {
            let mut hidden = HiddenRegion::default();
            let side = (n as f64).sqrt().ceil() as usize;
            for k in 0..n {
                let c = DVec2::new((k % side) as f64 + 0.5, (k / side) as f64 + 0.5) / side as f64;
                hidden.push(k as u64, &quad(c, DVec2::splat(0.2 / side as f64), 0.4));
            }
            hidden.memory_bytes()
        };
        let (small, large) = (grid(100), grid(1600));
        // 16 times the strokes: about 16 times the memory (the whole union per stroke
        // gave about 256 times).
        assert!(
            large < small * 24,
            "{small} bytes for 100, {large} for 1600"
        );
    }
}
