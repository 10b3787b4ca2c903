//! Stages 3 (positions) and 4 of the reconstruction: the quads placed on the data,
//! each quad's grid by recursive subdivision, and the sides and boundary points the
//! quads share (what the patch network in [`network`](super::network) and its joint
//! refit in `joint` are built on).
//!
//! - [`DataSnap`]: moves a point onto the data along the averaged normal of its
//!   nearest points (where the line through it meets a local quadric fitted to them).
//! - [`place_corners`]: patch centres, edge midpoints and face centres snapped to the
//!   data; quads oriented so that `du x dv` points along the data normals (outward).
//! - [`quad_grids`]: each quad's `(2^L + 1)^2` grid (3x3, 5x5, 9x9, 17x17): a side's
//!   points are made once and read by both quads of that side, so neighbours share
//!   them exactly; inner points are midpoints (and cell centres) snapped to the data.

use std::collections::BTreeMap;

use glam::{DVec2, DVec3};
use nalgebra::{SMatrix, SVector};
use rstar::RTree;

use super::normals::{IndexedPoint, point_tree};
use super::polygon::{PolygonModel, QuadCorner};

/// Maps `f` over `items`, on the rayon pool when the `parallel` feature is on.
pub(super) fn par_map<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync + Send) -> Vec<R> {
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        items.par_iter().map(f).collect()
    }
    #[cfg(not(feature = "parallel"))]
    {
        items.iter().map(f).collect()
    }
}

/// Snaps points onto the data: the points, their unit normals and an R*-tree.
#[derive(Debug)]
pub struct DataSnap<'a> {
    points: &'a [DVec3],
    normals: &'a [DVec3],
    tree: RTree<IndexedPoint>,
    neighbours: usize,
}

impl<'a> DataSnap<'a> {
    /// A snapper over `points` with unit `normals`, using the `neighbours` nearest
    /// points of a query (at least 6 are needed for the quadric).
    pub fn new(points: &'a [DVec3], normals: &'a [DVec3], neighbours: usize) -> Self {
        Self {
            points,
            normals,
            tree: point_tree(points),
            neighbours: neighbours.max(6),
        }
    }

    /// The point where the line through `q` along the averaged normal of its nearest
    /// data points meets the quadric `h(x, y)` fitted to them (least squares in the
    /// frame of that normal), and that normal. Nearest points facing away from the
    /// nearest one (the far side of a thin part) are left out. Two rounds: the second
    /// starts from the first one's answer, with the same nearest points (looking them
    /// up again cost a third of the torus's grid time and moved the answers by less
    /// than the fit's error).
    pub fn snap(&self, q: DVec3) -> (DVec3, DVec3) {
        let mut q = q;
        let mut n = DVec3::Z;
        let near: Vec<usize> = self
            .tree
            .nearest_neighbor_iter(&q.to_array())
            .take(self.neighbours)
            .map(|g| g.data)
            .collect();
        for _ in 0..2 {
            let Some(&first) = near.first() else {
                return (q, n);
            };
            let reference = self.normals[first];
            let same: Vec<DVec3> = near
                .iter()
                .filter(|&&i| self.normals[i].dot(reference) > 0.0)
                .map(|&i| self.points[i])
                .collect();
            let sum: DVec3 = near
                .iter()
                .filter(|&&i| self.normals[i].dot(reference) > 0.0)
                .map(|&i| self.normals[i])
                .sum();
            n = sum.try_normalize().unwrap_or(reference);
            q += n * height_at(q, n, &same);
        }
        (q, n)
    }
}

/// The height along `n` above `q` of the quadric `h = a + b x + c y + d x^2 + e x y +
/// f y^2` fitted to `pts` in the frame `(x, y, n)` at `q`, or of their mean plane when
/// the quadric is undetermined or leaves the band the points span.
fn height_at(q: DVec3, n: DVec3, pts: &[DVec3]) -> f64 {
    if pts.is_empty() {
        return 0.0;
    }
    let (e1, e2) = n.any_orthonormal_pair();
    let mut ata = SMatrix::<f64, 6, 6>::zeros();
    let mut atb = SVector::<f64, 6>::zeros();
    let (mut lo, mut hi, mut mean) = (f64::INFINITY, f64::NEG_INFINITY, 0.0);
    for p in pts {
        let d = *p - q;
        let (x, y, h) = (d.dot(e1), d.dot(e2), d.dot(n));
        let row = SVector::<f64, 6>::from([1.0, x, y, x * x, x * y, y * y]);
        ata += row * row.transpose();
        atb += row * h;
        lo = lo.min(h);
        hi = hi.max(h);
        mean += h;
    }
    let plane = mean / pts.len() as f64;
    if pts.len() < 9 {
        return plane;
    }
    let band = hi - lo;
    match ata.cholesky().map(|c| c.solve(&atb)[0]) {
        Some(a) if a.is_finite() && a >= lo - band && a <= hi + band => a,
        _ => plane,
    }
}

/// The quads with positions: each corner's point on the data and its data normal.
#[derive(Debug, Clone, PartialEq)]
pub struct QuadMesh {
    /// Point and unit normal of every corner.
    pub corners: BTreeMap<QuadCorner, (DVec3, DVec3)>,
    /// Quads, oriented: `(c1 - c0) x (c3 - c0)` points along the data normals.
    pub quads: Vec<[QuadCorner; 4]>,
}

/// Stage 3, positions: patch centres, then model edge midpoints (between the snapped
/// patch points), then face centres (the mean of the face's snapped patch points), each
/// snapped to the data; every quad oriented along the data normals.
pub fn place_corners(model: &PolygonModel, centres: &[DVec3], snap: &DataSnap<'_>) -> QuadMesh {
    let mut corners: BTreeMap<QuadCorner, (DVec3, DVec3)> = BTreeMap::new();
    let used: std::collections::BTreeSet<QuadCorner> =
        model.quads.iter().flatten().copied().collect();
    let patch = |v: usize| centres.get(v).copied().unwrap_or(DVec3::ZERO);
    for c in &used {
        if let QuadCorner::Patch(v) = c {
            corners.insert(*c, snap.snap(patch(*v)));
        }
    }
    let at = |corners: &BTreeMap<QuadCorner, (DVec3, DVec3)>, v: usize| {
        corners
            .get(&QuadCorner::Patch(v))
            .map_or_else(|| patch(v), |c| c.0)
    };
    for c in &used {
        match c {
            QuadCorner::Edge(a, b) => {
                let mid = (at(&corners, *a) + at(&corners, *b)) * 0.5;
                corners.insert(*c, snap.snap(mid));
            }
            QuadCorner::Face(f) => {
                let face = &model.faces[*f];
                let sum: DVec3 = face.iter().map(|&v| at(&corners, v)).sum();
                corners.insert(*c, snap.snap(sum / face.len().max(1) as f64));
            }
            QuadCorner::Patch(_) => {}
        }
    }
    let quads = orient(&model.quads, &corners);
    QuadMesh { corners, quads }
}

/// Orients the quads: across every side held by two quads they run it in opposite
/// directions (propagated breadth first over each connected piece), and each piece
/// turns so that most of its area faces along the data normals.
fn orient(
    quads: &[[QuadCorner; 4]],
    corners: &BTreeMap<QuadCorner, (DVec3, DVec3)>,
) -> Vec<[QuadCorner; 4]> {
    let flip = |q: [QuadCorner; 4]| [q[0], q[3], q[2], q[1]];
    let mut out = quads.to_vec();
    let mut by_side: BTreeMap<(QuadCorner, QuadCorner), Vec<usize>> = BTreeMap::new();
    for (qi, q) in quads.iter().enumerate() {
        for k in 0..4 {
            let (a, b) = (q[k], q[(k + 1) % 4]);
            by_side.entry((a.min(b), a.max(b))).or_default().push(qi);
        }
    }
    let runs = |q: &[QuadCorner; 4], a: QuadCorner, b: QuadCorner| {
        (0..4).any(|k| q[k] == a && q[(k + 1) % 4] == b)
    };
    let mut seen = vec![false; quads.len()];
    for start in 0..quads.len() {
        if seen[start] {
            continue;
        }
        seen[start] = true;
        let mut piece = vec![start];
        let mut queue = std::collections::VecDeque::from([start]);
        while let Some(qi) = queue.pop_front() {
            let q = out[qi];
            for k in 0..4 {
                let (a, b) = (q[k], q[(k + 1) % 4]);
                for &other in &by_side[&(a.min(b), a.max(b))] {
                    if seen[other] {
                        continue;
                    }
                    seen[other] = true;
                    if runs(&out[other], a, b) {
                        out[other] = flip(out[other]);
                    }
                    piece.push(other);
                    queue.push_back(other);
                }
            }
        }
        let facing: f64 = piece
            .iter()
            .map(|&qi| {
                let p = out[qi].map(|c| corners[&c].0);
                let along: DVec3 = out[qi].iter().map(|c| corners[c].1).sum();
                (p[2] - p[0]).cross(p[3] - p[1]).dot(along)
            })
            .sum();
        if facing < 0.0 {
            for &qi in &piece {
                out[qi] = flip(out[qi]);
            }
        }
    }
    out
}

/// One side of a quad on a grid (or control net) whose last index is `m`.
#[derive(Debug, Clone, PartialEq)]
pub struct Side {
    /// The corner it starts from.
    pub from: QuadCorner,
    /// The corner it ends at.
    pub to: QuadCorner,
    /// Grid indices `(i, j)` along the side, from `from` to `to`.
    pub on: Vec<(usize, usize)>,
    /// Grid indices of the row next to the side, inside the quad.
    pub inner: Vec<(usize, usize)>,
    /// Parameters of `from` and `to` on the quad's domain `[0, 1]^2`.
    pub uv: [DVec2; 2],
}

impl Side {
    /// The side's key (its corners, smaller first) and whether it runs that way.
    pub fn key(&self) -> ((QuadCorner, QuadCorner), bool) {
        if self.from < self.to {
            ((self.from, self.to), true)
        } else {
            ((self.to, self.from), false)
        }
    }

    /// The side run in its key's direction.
    pub fn canonical(&self) -> Self {
        if self.key().1 {
            return self.clone();
        }
        Self {
            from: self.to,
            to: self.from,
            on: self.on.iter().rev().copied().collect(),
            inner: self.inner.iter().rev().copied().collect(),
            uv: [self.uv[1], self.uv[0]],
        }
    }
}

/// The four sides of quad `q = [c0, c1, c2, c3]` on a grid with last index `m`: `u`
/// runs from `c0` to `c1` (`j = 0`), `v` from `c0` to `c3` (`i = 0`).
pub fn sides(q: &[QuadCorner; 4], m: usize) -> [Side; 4] {
    let r = 0..=m;
    let side = |from, to, on: Vec<_>, inner: Vec<_>, a: [f64; 2], b: [f64; 2]| Side {
        from,
        to,
        on,
        inner,
        uv: [DVec2::from(a), DVec2::from(b)],
    };
    [
        side(
            q[0],
            q[1],
            r.clone().map(|k| (k, 0)).collect(),
            r.clone().map(|k| (k, 1)).collect(),
            [0.0, 0.0],
            [1.0, 0.0],
        ),
        side(
            q[1],
            q[2],
            r.clone().map(|k| (m, k)).collect(),
            r.clone().map(|k| (m - 1, k)).collect(),
            [1.0, 0.0],
            [1.0, 1.0],
        ),
        side(
            q[3],
            q[2],
            r.clone().map(|k| (k, m)).collect(),
            r.clone().map(|k| (k, m - 1)).collect(),
            [0.0, 1.0],
            [1.0, 1.0],
        ),
        side(
            q[0],
            q[3],
            r.clone().map(|k| (0, k)).collect(),
            r.map(|k| (1, k)).collect(),
            [0.0, 0.0],
            [0.0, 1.0],
        ),
    ]
}

/// A grid `g[i][j]` of points, `i` along `u`.
pub type Grid = Vec<Vec<DVec3>>;

/// Stage 4: the `(2^levels + 1)^2` grid of every quad by recursive subdivision. Each
/// side's points are made once (midpoints snapped to the data, halving until the
/// spacing is reached) and shared by both quads of the side; inside, each level adds
/// the midpoints of the previous level's cell sides and the cell centres (the mean of
/// the cell's four corners), snapped.
pub fn quad_grids(mesh: &QuadMesh, levels: u32, snap: &DataSnap<'_>) -> Vec<Grid> {
    let n = 1usize << levels;
    let mut side_points: BTreeMap<(QuadCorner, QuadCorner), Vec<DVec3>> = BTreeMap::new();
    for q in &mesh.quads {
        for s in sides(q, n) {
            let (key, _) = s.key();
            side_points.entry(key).or_insert_with(|| {
                let mut pts = vec![DVec3::ZERO; n + 1];
                pts[0] = mesh.corners[&key.0].0;
                pts[n] = mesh.corners[&key.1].0;
                let mut step = n;
                while step > 1 {
                    let h = step / 2;
                    for i in (h..n).step_by(step) {
                        pts[i] = snap.snap((pts[i - h] + pts[i + h]) * 0.5).0;
                    }
                    step = h;
                }
                pts
            });
        }
    }
    par_map(&mesh.quads, |q| {
        let mut g = vec![vec![DVec3::ZERO; n + 1]; n + 1];
        for s in sides(q, n) {
            let c = s.canonical();
            for (k, &(i, j)) in c.on.iter().enumerate() {
                g[i][j] = side_points[&s.key().0][k];
            }
        }
        let mut step = n;
        while step > 1 {
            let h = step / 2;
            for i in (h..n).step_by(h) {
                for j in (h..n).step_by(h) {
                    if i % step == 0 && j % step == 0 {
                        continue;
                    }
                    let guess = match (i % step != 0, j % step != 0) {
                        (true, true) => {
                            (g[i - h][j - h] + g[i + h][j - h] + g[i - h][j + h] + g[i + h][j + h])
                                * 0.25
                        }
                        (true, false) => (g[i - h][j] + g[i + h][j]) * 0.5,
                        _ => (g[i][j - h] + g[i][j + h]) * 0.5,
                    };
                    g[i][j] = snap.snap(guess).0;
                }
            }
            step = h;
        }
        g
    })
}

/// Key of a boundary control point: a corner `(c, c, 0)` or the `k`-th point of a side
/// in its key's direction.
pub(super) type BoundaryKey = (QuadCorner, QuadCorner, usize);

pub(super) fn boundary_key(key: (QuadCorner, QuadCorner), k: usize, last: usize) -> BoundaryKey {
    if k == 0 {
        (key.0, key.0, 0)
    } else if k == last {
        (key.1, key.1, 0)
    } else {
        (key.0, key.1, k)
    }
}

/// The shared sides: for each side key held by exactly two quads, the two quads and
/// their sides run in the key's direction.
pub fn shared_sides(quads: &[[QuadCorner; 4]], m: usize) -> Vec<[(usize, Side); 2]> {
    let mut by_key: BTreeMap<(QuadCorner, QuadCorner), Vec<(usize, Side)>> = BTreeMap::new();
    for (qi, q) in quads.iter().enumerate() {
        for s in sides(q, m) {
            by_key
                .entry(s.key().0)
                .or_default()
                .push((qi, s.canonical()));
        }
    }
    by_key
        .into_values()
        .filter_map(|v| <[(usize, Side); 2]>::try_from(v).ok())
        .collect()
}
