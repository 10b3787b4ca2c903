//! Bernstein nets of the squared distance to a Bezier sub-patch: the certificate that a
//! closest point is the global one.
//!
//! For a rational Bezier patch `S = A / w` (homogeneous `A`, weight `w`, both of degree
//! `(p, q)`) and a query `P`, the polynomial
//!
//! ```text
//! g(u, v) = |A - P w|^2 - f* w^2  =  w^2 (|S - P|^2 - f*)
//! ```
//!
//! has degree `(2p, 2q)`, and `g < 0` exactly where the surface is closer to `P` than
//! `sqrt(f*)`. Its Bernstein coefficients come from three products of Bernstein
//! polynomials that depend only on the patch (`|A|^2`, `A w`, `w^2`; Farouki and Rajan,
//! "Algorithms for polynomials in Bernstein form", 1988), so a query costs one dot
//! product per coefficient:
//!
//! ```text
//! g_k = (|A|^2)_k - 2 P . (A w)_k + (|P|^2 - f*) (w^2)_k
//! ```
//!
//! Three properties of Bernstein nets make the certificate (used by
//! [`super::invert::SurfaceInverter`]):
//! - **bound**: `g` is at least its smallest coefficient on the patch (the basis is a
//!   partition of unity), so a net with no negative coefficient proves that no point of
//!   the patch is closer than `sqrt(f*)`;
//! - **convexity**: the second derivatives of `g` are nets of second differences; when
//!   `g_uu >= a > 0`, `g_vv >= c > 0` and `|g_uv| <= b` with `a c > b^2` everywhere, `g`
//!   is convex on the patch and has one minimum there;
//! - **subdivision**: de Casteljau halves a net into the nets of the two halves, whose
//!   bounds converge quadratically to `g`.
//!
//! Coordinates are taken relative to the patch's centroid, so the cancellation in `g_k`
//! is of the patch's size, not of the distance from the display frame's origin.

// The kernels index nets by their Bernstein indices, as the formulas do.
#![allow(clippy::needless_range_loop)]

use glam::{DVec3, DVec4};

/// Largest net side the certificate handles (degree 5 per direction, as the power form:
/// `2 * 5 + 1`). Surfaces of higher degree are answered without the certificate.
pub(crate) const MAX_SIDE: usize = 11;

/// The query-independent nets of every leaf of a surface, stored flat.
#[derive(Debug, Clone)]
pub(crate) struct DistanceNets {
    /// Net size `(2p + 1) x (2q + 1)`, row-major with `i` along `u`.
    m1: usize,
    n1: usize,
    /// Centroid of each leaf's control points (the origin of its nets).
    origins: Vec<DVec3>,
    /// Coefficients of `|A'|^2`, `A' w` and `w^2` (`A' = A - origin w`), leaf after leaf;
    /// `A' w` by coordinate (`x` of every coefficient of a leaf, then `y`, then `z`), so
    /// a query's loop runs on whole vectors.
    aa: Vec<f64>,
    aw: Vec<f64>,
    ww: Vec<f64>,
    /// Smallest `w^2` coefficient per leaf (a lower bound of `w^2` on the leaf).
    ww_min: Vec<f64>,
    /// Largest `|(|A'|^2)_k|`, `|(A' w)_k|` and `(w^2)_k` per leaf: the scale of the
    /// rounding error of a query's coefficients.
    scales: Vec<[f64; 3]>,
    /// Query-independent bounds of the second differences of each leaf's nets, for
    /// [`Self::leaf_is_convex`].
    curvature: Vec<CurvatureBounds>,
}

/// Ranges of the second differences of a leaf's three nets (`aa`, `aw`, `ww`), along
/// `u`, along `v` and across (the twist): `aa` and `ww` as `[min, max]`, `aw` as a box.
#[derive(Debug, Clone, Copy)]
struct CurvatureBounds {
    diffs: [DiffRange; 3],
}

/// The range of one kind of second difference over a leaf's nets.
#[derive(Debug, Clone, Copy)]
struct DiffRange {
    aa: [f64; 2],
    aw: (DVec3, DVec3),
    ww: [f64; 2],
}

impl DiffRange {
    const EMPTY: Self = Self {
        aa: [f64::INFINITY, f64::NEG_INFINITY],
        aw: (DVec3::INFINITY, DVec3::NEG_INFINITY),
        ww: [f64::INFINITY, f64::NEG_INFINITY],
    };

    fn add(&mut self, aa: f64, aw: DVec3, ww: f64) {
        self.aa = [self.aa[0].min(aa), self.aa[1].max(aa)];
        self.aw = (self.aw.0.min(aw), self.aw.1.max(aw));
        self.ww = [self.ww[0].min(ww), self.ww[1].max(ww)];
    }

    /// The range of `D(aa) - 2 q . D(aw) + c D(ww)` (interval arithmetic).
    fn of_g(&self, q: DVec3, c: f64) -> [f64; 2] {
        let (x, y) = (q * self.aw.0 * -2.0, q * self.aw.1 * -2.0);
        let (lo, hi) = (x.min(y).element_sum(), x.max(y).element_sum());
        let (w0, w1) = (c * self.ww[0], c * self.ww[1]);
        [self.aa[0] + lo + w0.min(w1), self.aa[1] + hi + w0.max(w1)]
    }
}

impl DistanceNets {
    /// Zero nets for `leaves` patches of `p1 x q1` control points (filled by
    /// [`Self::set`]), or `None` when the degree is beyond [`MAX_SIDE`].
    pub(crate) fn new(p1: usize, q1: usize, leaves: usize) -> Option<Self> {
        let (m1, n1) = (2 * p1 - 1, 2 * q1 - 1);
        (m1 <= MAX_SIDE && n1 <= MAX_SIDE).then(|| Self {
            m1,
            n1,
            origins: vec![DVec3::ZERO; leaves],
            aa: vec![0.0; leaves * m1 * n1],
            aw: vec![0.0; 3 * leaves * m1 * n1],
            ww: vec![0.0; leaves * m1 * n1],
            ww_min: vec![0.0; leaves],
            scales: vec![[0.0; 3]; leaves],
            curvature: vec![
                CurvatureBounds {
                    diffs: [DiffRange::EMPTY; 3]
                };
                leaves
            ],
        })
    }

    /// Net size `(rows, columns)`.
    pub(crate) fn size(&self) -> (usize, usize) {
        (self.m1, self.n1)
    }

    /// Sets the nets of leaf `leaf` from its `p1 x q1` Bezier piece in homogeneous form
    /// (row-major, `i` along `u`), by the product rule for Bernstein polynomials:
    /// `(a b)_{I,J} = sum_{i+k=I, j+l=J} C(p,i) C(p,k) C(q,j) C(q,l) / (C(2p,I) C(2q,J)) a_ij b_kl`.
    pub(crate) fn set(&mut self, leaf: usize, piece: &[DVec4]) {
        let (m1, n1) = (self.m1, self.n1);
        let (p1, q1) = (m1.div_ceil(2), n1.div_ceil(2));
        let (p, q) = (p1 - 1, q1 - 1);
        let origin = piece.iter().map(|h| h.truncate() / h.w).sum::<DVec3>() / piece.len() as f64;
        let a: Vec<DVec3> = piece.iter().map(|h| h.truncate() - origin * h.w).collect();
        let w: Vec<f64> = piece.iter().map(|h| h.w).collect();
        let len = m1 * n1;
        let base = leaf * len;
        let (mut aa, mut aw, mut ww) = (vec![0.0; len], vec![DVec3::ZERO; len], vec![0.0; len]);
        let factors = |d: usize| -> Vec<f64> {
            let mut f = vec![0.0; (d + 1) * (d + 1)];
            for i in 0..=d {
                for k in 0..=d {
                    f[i * (d + 1) + k] = binomial(d, i) * binomial(d, k) / binomial(2 * d, i + k);
                }
            }
            f
        };
        let (fu, fv) = (factors(p), factors(q));
        for i in 0..p1 {
            for k in 0..p1 {
                let cu = fu[i * p1 + k];
                for j in 0..q1 {
                    for l in 0..q1 {
                        let c = cu * fv[j * q1 + l];
                        let (x, y) = (i * q1 + j, k * q1 + l);
                        let at = (i + k) * n1 + (j + l);
                        aa[at] += c * a[x].dot(a[y]);
                        aw[at] += c * a[x] * w[y];
                        ww[at] += c * w[x] * w[y];
                    }
                }
            }
        }
        self.aa[base..base + len].copy_from_slice(&aa);
        self.ww[base..base + len].copy_from_slice(&ww);
        for (axis, coords) in self.aw[3 * base..3 * (base + len)]
            .chunks_exact_mut(len)
            .enumerate()
        {
            for (c, v) in coords.iter_mut().zip(&aw) {
                *c = v[axis];
            }
        }
        self.ww_min[leaf] = net_min(&ww);
        let max = |it: &mut dyn Iterator<Item = f64>| it.fold(0.0, f64::max);
        self.scales[leaf] = [
            max(&mut aa.iter().map(|x| x.abs())),
            max(&mut aw.iter().map(|x| x.length())),
            max(&mut ww.iter().copied()),
        ];
        self.origins[leaf] = origin;
        let mut bounds = CurvatureBounds {
            diffs: [DiffRange::EMPTY; 3],
        };
        let at = |i: usize, j: usize| i * n1 + j;
        for i in 0..m1 {
            for j in 0..n1 {
                let mut second = |kind: usize, x: usize, y: usize, z: usize| {
                    bounds.diffs[kind].add(
                        aa[z] - 2.0 * aa[y] + aa[x],
                        aw[z] - 2.0 * aw[y] + aw[x],
                        ww[z] - 2.0 * ww[y] + ww[x],
                    );
                };
                if i + 2 < m1 {
                    second(0, at(i, j), at(i + 1, j), at(i + 2, j));
                }
                if j + 2 < n1 {
                    second(1, at(i, j), at(i, j + 1), at(i, j + 2));
                }
                if i + 1 < m1 && j + 1 < n1 {
                    let (x, y, z, w) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
                    bounds.diffs[2].add(
                        aa[w] - aa[y] - aa[z] + aa[x],
                        aw[w] - aw[y] - aw[z] + aw[x],
                        ww[w] - ww[y] - ww[z] + ww[x],
                    );
                }
            }
        }
        self.curvature[leaf] = bounds;
    }

    /// The net of `g` for leaf `leaf`, query `p` and squared distance `f_star`, written
    /// into `out` (`rows x columns` long). Returns the threshold below which a
    /// coefficient shows a point closer than `sqrt(f_star) - tol` for certain: `-(tol's
    /// share of g + the rounding error of the coefficients)`.
    pub(crate) fn query(
        &self,
        leaf: usize,
        p: DVec3,
        f_star: f64,
        tol: f64,
        out: &mut [f64],
    ) -> f64 {
        let terms = self.terms(leaf, p, f_star);
        let out = &mut out[..terms.aa.len()];
        for (k, g) in out.iter_mut().enumerate() {
            *g = terms.at(k);
        }
        self.threshold(leaf, &terms, f_star, tol)
    }

    /// The smallest coefficient of the net [`Self::query`] would write, and its
    /// threshold, without writing the net: the test that clears a whole leaf.
    pub(crate) fn query_min(&self, leaf: usize, p: DVec3, f_star: f64, tol: f64) -> (f64, f64) {
        let terms = self.terms(leaf, p, f_star);
        let len = terms.aa.len();
        // Two running minima, one per SSE2 lane.
        let mut low = [f64::INFINITY; 2];
        for k in (0..len.saturating_sub(1)).step_by(2) {
            low[0] = lesser(low[0], terms.at(k));
            low[1] = lesser(low[1], terms.at(k + 1));
        }
        if len % 2 == 1 {
            low[0] = lesser(low[0], terms.at(len - 1));
        }
        (
            lesser(low[0], low[1]),
            self.threshold(leaf, &terms, f_star, tol),
        )
    }

    /// The slices of leaf `leaf` and the query's factors, for [`NetTerms::at`].
    #[inline(always)]
    fn terms(&self, leaf: usize, p: DVec3, f_star: f64) -> NetTerms<'_> {
        let len = self.m1 * self.n1;
        let base = leaf * len;
        let q = p - self.origins[leaf];
        let aw = &self.aw[3 * base..3 * (base + len)];
        NetTerms {
            q,
            q2: q.length_squared() - f_star,
            aa: &self.aa[base..base + len],
            ww: &self.ww[base..base + len],
            ax: &aw[..len],
            ay: &aw[len..2 * len],
            az: &aw[2 * len..3 * len],
        }
    }

    /// See [`Self::query`]: `-(tol's share of g + the rounding error of the net)`.
    #[inline(always)]
    fn threshold(&self, leaf: usize, terms: &NetTerms<'_>, f_star: f64, tol: f64) -> f64 {
        let [s_aa, s_aw, s_ww] = self.scales[leaf];
        let noise = s_aa + 2.0 * terms.q.length() * s_aw + (terms.q2.abs() + f_star) * s_ww;
        // f < f* - tol  <=>  g < -(2 sqrt(f*) tol - tol^2) w^2, and w^2 >= ww_min.
        let sqrt_f = f_star.sqrt();
        let gap = (2.0 * sqrt_f * tol - tol * tol).max(0.0);
        -(gap * self.ww_min[leaf] + 64.0 * f64::EPSILON * noise)
    }
}

/// One leaf's precomputed products and one query's factors: coefficient `k` of the net
/// of `g` is `|A|^2 - 2 q . (A w) + (|q|^2 - f*) w^2` (slices of one length, so the
/// loops over them have no bounds checks and vectorise).
struct NetTerms<'a> {
    q: DVec3,
    q2: f64,
    aa: &'a [f64],
    ww: &'a [f64],
    ax: &'a [f64],
    ay: &'a [f64],
    az: &'a [f64],
}

impl NetTerms<'_> {
    #[inline(always)]
    fn at(&self, k: usize) -> f64 {
        let q = self.q;
        self.aa[k] - 2.0 * (q.x * self.ax[k] + q.y * self.ay[k] + q.z * self.az[k])
            + self.q2 * self.ww[k]
    }
}

impl DistanceNets {
    /// True when `g` (query `p`, squared distance `f_star`) is convex on the whole leaf,
    /// from the leaf's precomputed second-difference bounds: each second difference of
    /// `g` is `D(aa) - 2 P' . D(aw) + (|P'|^2 - f*) D(ww)`, bounded with `|P'|` in O(1).
    /// More conservative than [`is_convex`] on the query's net, and far cheaper.
    pub(crate) fn leaf_is_convex(&self, leaf: usize, p: DVec3, f_star: f64) -> bool {
        let (m1, n1) = (self.m1, self.n1);
        if m1 < 3 || n1 < 3 {
            return false;
        }
        let q = p - self.origins[leaf];
        let c = q.length_squared() - f_star;
        let [uu, vv, uv] = self.curvature[leaf].diffs.map(|d| d.of_g(q, c));
        let (m, n) = ((m1 - 1) as f64, (n1 - 1) as f64);
        let a = m * (m - 1.0) * uu[0];
        let cc = n * (n - 1.0) * vv[0];
        let twist = m * n * uv[0].abs().max(uv[1].abs());
        a > 0.0 && cc > 0.0 && a * cc > twist * twist * (1.0 + crate::tolerance::CONVEX_MARGIN_REL)
    }
}

/// `C(n, k)` as a float (exact for the small degrees used here).
fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

/// The smallest coefficient of a net.
pub(crate) fn net_min(net: &[f64]) -> f64 {
    net.iter().copied().fold(f64::INFINITY, lesser)
}

/// Dispatches on the net size: `by_net_size!(m1, n1, sized[PRE], any(args))` calls
/// `sized::<PRE, M, N>(args)` when the net is `M x N` with `M` and `N` in 3, 5 and 7
/// (degrees 1 to 3 in each direction: the kernels unroll completely), and `any(args)`
/// for any other size.
macro_rules! by_net_size {
    ($m1:expr, $n1:expr, $sized:ident[$($pre:ident),*], $any:ident($($arg:expr),*)) => {
        match ($m1, $n1) {
            (3, 3) => $sized::<$($pre,)* 3, 3>($($arg),*),
            (3, 5) => $sized::<$($pre,)* 3, 5>($($arg),*),
            (3, 7) => $sized::<$($pre,)* 3, 7>($($arg),*),
            (5, 3) => $sized::<$($pre,)* 5, 3>($($arg),*),
            (5, 5) => $sized::<$($pre,)* 5, 5>($($arg),*),
            (5, 7) => $sized::<$($pre,)* 5, 7>($($arg),*),
            (7, 3) => $sized::<$($pre,)* 7, 3>($($arg),*),
            (7, 5) => $sized::<$($pre,)* 7, 5>($($arg),*),
            (7, 7) => $sized::<$($pre,)* 7, 7>($($arg),*),
            _ => $any($($arg),*),
        }
    };
}

/// `min` and `max` by one comparison: the nets hold no NaN, and these compile to single
/// instructions where `f64::min` also tests for NaN.
#[inline(always)]
fn lesser(a: f64, b: f64) -> f64 {
    if b < a { b } else { a }
}

#[inline(always)]
fn greater(a: f64, b: f64) -> f64 {
    if b > a { b } else { a }
}

/// True when the net's polynomial is convex on its whole patch, by bounds of its second
/// derivatives: the Bernstein coefficients of `g_uu`, `g_vv` and `g_uv` are (up to
/// positive factors) the second differences `D_uu`, `D_vv` and the twist `D_uv` of the
/// net. With `a = m (m-1) min D_uu`, `c = n (n-1) min D_vv`, `b = m n max |D_uv|`, the
/// Hessian is positive definite everywhere when `a > 0`, `c > 0` and `a c > b^2`.
pub(crate) fn is_convex(net: &[f64], m1: usize, n1: usize) -> bool {
    by_net_size!(m1, n1, is_convex_sized[], is_convex_any(net, m1, n1))
}

/// [`is_convex`] for an `M x N` net known at compile time (the common degrees 1 to 3):
/// fully unrolled, the same arithmetic as [`is_convex_any`].
fn is_convex_sized<const M: usize, const N: usize>(net: &[f64], _: usize, _: usize) -> bool {
    let rows: &[[f64; N]] = net.as_chunks::<N>().0;
    // Most nets that fail, fail along u already.
    let mut a = f64::INFINITY;
    for i in 0..M - 2 {
        for j in 0..N {
            a = lesser(a, rows[i + 2][j] - 2.0 * rows[i + 1][j] + rows[i][j]);
        }
    }
    if a <= 0.0 {
        return false;
    }
    let mut c = f64::INFINITY;
    let mut b = 0.0f64;
    for i in 0..M {
        for j in 0..N - 2 {
            c = lesser(c, rows[i][j + 2] - 2.0 * rows[i][j + 1] + rows[i][j]);
        }
        if i + 1 < M {
            for j in 0..N - 1 {
                let twist = rows[i + 1][j + 1] - rows[i + 1][j] - rows[i][j + 1] + rows[i][j];
                b = greater(b, twist.abs());
            }
        }
    }
    let (m, n) = ((M - 1) as f64, (N - 1) as f64);
    let (a2, c2, b2) = (m * (m - 1.0) * a, n * (n - 1.0) * c, m * n * b);
    c > 0.0 && a2 * c2 > b2 * b2
}

/// [`is_convex`] for any net size.
fn is_convex_any(net: &[f64], m1: usize, n1: usize) -> bool {
    if m1 < 3 || n1 < 3 {
        return false;
    }
    // Second differences along u: rows i, i + 1, i + 2.
    let mut a = f64::INFINITY;
    for i in 0..m1 - 2 {
        let (r0, r1, r2) = (&net[i * n1..], &net[(i + 1) * n1..], &net[(i + 2) * n1..]);
        for j in 0..n1 {
            a = a.min(r2[j] - 2.0 * r1[j] + r0[j]);
        }
    }
    if a <= 0.0 {
        return false;
    }
    let mut c = f64::INFINITY;
    for row in net.chunks_exact(n1) {
        for w in row.windows(3) {
            c = c.min(w[2] - 2.0 * w[1] + w[0]);
        }
    }
    if c <= 0.0 {
        return false;
    }
    let mut b = 0.0f64;
    for i in 0..m1 - 1 {
        let (r0, r1) = (&net[i * n1..(i + 1) * n1], &net[(i + 1) * n1..(i + 2) * n1]);
        for j in 0..n1 - 1 {
            b = b.max((r1[j + 1] - r1[j] - r0[j + 1] + r0[j]).abs());
        }
    }
    let (m, n) = ((m1 - 1) as f64, (n1 - 1) as f64);
    let (a, c, b) = (m * (m - 1.0) * a, n * (n - 1.0) * c, m * n * b);
    a * c > b * b
}

/// Bernstein basis values and derivatives of degree `len - 1` at `x`, into the first
/// `len` entries of the arrays (the triangle of de Casteljau, P&T A1.3).
#[inline(always)]
fn basis<const CAP: usize>(len: usize, x: f64) -> ([f64; CAP], [f64; CAP]) {
    let mut b = [0.0; CAP];
    let mut d = [0.0; CAP];
    b[0] = 1.0;
    for r in 1..len {
        if r == len - 1 {
            // B'_i^n = n (B_{i-1}^{n-1} - B_i^{n-1}), from the degree n - 1 values.
            let n = r as f64;
            for i in 0..len {
                let left = if i > 0 { b[i - 1] } else { 0.0 };
                let right = if i < r { b[i] } else { 0.0 };
                d[i] = n * (left - right);
            }
        }
        for i in (0..=r).rev() {
            let left = if i > 0 { b[i - 1] } else { 0.0 };
            b[i] = (1.0 - x) * b[i] + x * left;
        }
    }
    (b, d)
}

/// The net's polynomial and its two partial derivatives at `(s, t)` of its patch.
pub(crate) fn eval_with_gradient(
    net: &[f64],
    m1: usize,
    n1: usize,
    s: f64,
    t: f64,
) -> (f64, f64, f64) {
    by_net_size!(m1, n1, eval_with_gradient_sized[], eval_with_gradient_any(net, m1, n1, s, t))
}

/// [`eval_with_gradient`] for an `M x N` net known at compile time: the sizes reach
/// the inlined kernel as constants, and its loops unroll.
fn eval_with_gradient_sized<const M: usize, const N: usize>(
    net: &[f64],
    _: usize,
    _: usize,
    s: f64,
    t: f64,
) -> (f64, f64, f64) {
    eval_with_gradient_any(net, M, N, s, t)
}

/// [`eval_with_gradient`] for any net size.
#[inline(always)]
fn eval_with_gradient_any(net: &[f64], m1: usize, n1: usize, s: f64, t: f64) -> (f64, f64, f64) {
    let (bs, ds) = basis::<MAX_SIDE>(m1, s);
    let (bt, dt) = basis::<MAX_SIDE>(n1, t);
    let (mut g, mut gs, mut gt) = (0.0, 0.0, 0.0);
    for i in 0..m1 {
        let row = &net[i * n1..(i + 1) * n1];
        let (mut r, mut rt) = (0.0, 0.0);
        for j in 0..n1 {
            r += row[j] * bt[j];
            rt += row[j] * dt[j];
        }
        g += r * bs[i];
        gs += r * ds[i];
        gt += rt * bs[i];
    }
    (g, gs, gt)
}

/// A side of a patch: `u = lo`, `u = hi`, `v = lo` or `v = hi` of its parameter box.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Side {
    ULo,
    UHi,
    VLo,
    VHi,
}

impl Side {
    /// The parameter that runs along the side: `v` (1) on the `u` sides, `u` (0) on the
    /// `v` sides.
    pub(crate) fn along(self) -> usize {
        match self {
            Side::ULo | Side::UHi => 1,
            Side::VLo | Side::VHi => 0,
        }
    }
}

/// The side that holds the minimum of the net's polynomial `g` on its patch, when the
/// net shows `g` monotone across the patch in one direction (a query beyond a domain
/// edge, say). The Bernstein coefficients of `g_u` are `m (c[i+1][j] - c[i][j])`: when
/// none is negative, `g(u, v) >= g(lo, v)` everywhere and the minimum lies on the side
/// `u = lo`; likewise for the other three sides.
pub(crate) fn monotone_side(net: &[f64], m1: usize, n1: usize) -> Option<Side> {
    let (mut up_u, mut down_u, mut up_v, mut down_v) = (true, true, true, true);
    for i in 0..m1 {
        let row = &net[i * n1..(i + 1) * n1];
        if i + 1 < m1 {
            let next = &net[(i + 1) * n1..(i + 2) * n1];
            for j in 0..n1 {
                let d = next[j] - row[j];
                up_u &= d >= 0.0;
                down_u &= d <= 0.0;
            }
        }
        for j in 0..n1 - 1 {
            let d = row[j + 1] - row[j];
            up_v &= d >= 0.0;
            down_v &= d <= 0.0;
        }
    }
    [
        (up_u, Side::ULo),
        (down_u, Side::UHi),
        (up_v, Side::VLo),
        (down_v, Side::VHi),
    ]
    .into_iter()
    .find_map(|(holds, side)| holds.then_some(side))
}

/// The net of `g` restricted to a side: the matching row or column of the patch's net
/// (in the first `len` entries; returns `len`).
pub(crate) fn side_net(
    net: &[f64],
    m1: usize,
    n1: usize,
    side: Side,
    out: &mut [f64; MAX_SIDE],
) -> usize {
    match side {
        Side::ULo | Side::UHi => {
            let i = if side == Side::ULo { 0 } else { m1 - 1 };
            out[..n1].copy_from_slice(&net[i * n1..(i + 1) * n1]);
            n1
        }
        Side::VLo | Side::VHi => {
            let j = if side == Side::VLo { 0 } else { n1 - 1 };
            for i in 0..m1 {
                out[i] = net[i * n1 + j];
            }
            m1
        }
    }
}

/// True when a curve's net (one parameter on `[0, 1]`) proves its polynomial `>=
/// threshold` there: no coefficient below it, or the net convex (no negative second
/// difference) and its tangent line at one of `at` above it at both ends.
pub(crate) fn curve_clears(net: &[f64], threshold: f64, at: impl IntoIterator<Item = f64>) -> bool {
    if net_min(net) >= threshold {
        return true;
    }
    if net.len() < 3 || net.windows(3).any(|w| w[2] - 2.0 * w[1] + w[0] < 0.0) {
        return false;
    }
    at.into_iter().any(|t| {
        let (g, _, gt) = eval_with_gradient(net, 1, net.len(), 0.0, t);
        g + (-gt * t).min(gt * (1.0 - t)) >= threshold
    })
}

/// A lower bound of a convex net's polynomial on its patch from the tangent plane at
/// `(s, t)`: `g(x) >= g(x0) + grad g(x0) . (x - x0)` for a convex `g`, and the plane's
/// minimum over the patch is at a corner. Only valid when [`is_convex`] holds.
pub(crate) fn convex_bound_at(net: &[f64], m1: usize, n1: usize, s: f64, t: f64) -> f64 {
    let (g, gs, gt) = eval_with_gradient(net, m1, n1, s, t);
    g + (-gs * s).min(gs * (1.0 - s)) + (-gt * t).min(gt * (1.0 - t))
}

/// Splits a net at the middle of its patch in both directions (de Casteljau at 1/2)
/// into the nets of the quarters `[u low v low, u high v low, u low v high, u high v
/// high]` (each in the first `m1 * n1` entries of `out`; `L >= m1 * n1`).
pub(crate) fn split4<const L: usize>(net: &[f64], m1: usize, n1: usize, out: &mut [[f64; L]; 4]) {
    by_net_size!(m1, n1, split4_sized[L], split4_any(net, m1, n1, out))
}

/// [`split4`] for an `M x N` net known at compile time: the halving runs on whole rows
/// (along `u`), then on whole rows of the transposed halves (along `v`), so every step
/// is a short fixed-length vector operation. The same arithmetic as [`split4_any`].
fn split4_sized<const L: usize, const M: usize, const N: usize>(
    net: &[f64],
    _: usize,
    _: usize,
    out: &mut [[f64; L]; 4],
) {
    let mut rows = [[0.0; N]; M];
    for (row, src) in rows.iter_mut().zip(net.as_chunks::<N>().0) {
        *row = *src;
    }
    let (u_lo, u_hi) = halve_rows(rows);
    for (half, (q_lo, q_hi)) in [(u_lo, (0, 2)), (u_hi, (1, 3))] {
        let mut cols = [[0.0; M]; N];
        for i in 0..M {
            for j in 0..N {
                cols[j][i] = half[i][j];
            }
        }
        let (v_lo, v_hi) = halve_rows(cols);
        for (q, quarter) in [(q_lo, v_lo), (q_hi, v_hi)] {
            for i in 0..M {
                for j in 0..N {
                    out[q][i * N + j] = quarter[j][i];
                }
            }
        }
    }
}

/// de Casteljau at 1/2 across `R` rows of `C` coefficients each (row `i` is control
/// point `i` of `C` curves at once): the rows of the left and right halves.
fn halve_rows<const R: usize, const C: usize>(
    mut rows: [[f64; C]; R],
) -> ([[f64; C]; R], [[f64; C]; R]) {
    let mut left = [[0.0; C]; R];
    let mut right = [[0.0; C]; R];
    left[0] = rows[0];
    right[R - 1] = rows[R - 1];
    for r in 1..R {
        for i in 0..R - r {
            for c in 0..C {
                rows[i][c] = 0.5 * (rows[i][c] + rows[i + 1][c]);
            }
        }
        left[r] = rows[0];
        right[R - 1 - r] = rows[R - 1 - r];
    }
    (left, right)
}

/// [`split4`] for any net size.
fn split4_any<const L: usize>(net: &[f64], m1: usize, n1: usize, out: &mut [[f64; L]; 4]) {
    let [q0, q1, q2, q3] = out;
    // Along u, column by column, into the quarters' v-low slots; then along v, row by
    // row, from each u half into its v-low and v-high quarter.
    let mut work = [0.0; MAX_SIDE];
    for j in 0..n1 {
        for i in 0..m1 {
            work[i] = net[i * n1 + j];
        }
        halve(
            &mut work[..m1],
            |k, x| q0[k * n1 + j] = x,
            |k, x| q1[k * n1 + j] = x,
        );
    }
    for (v_lo, v_hi) in [(&mut *q0, &mut *q2), (&mut *q1, &mut *q3)] {
        for i in 0..m1 {
            work[..n1].copy_from_slice(&v_lo[i * n1..(i + 1) * n1]);
            halve(
                &mut work[..n1],
                |k, x| v_lo[i * n1 + k] = x,
                |k, x| v_hi[i * n1 + k] = x,
            );
        }
    }
}

/// de Casteljau at 1/2 on one row of coefficients (consumed): writes the left half's
/// `k`-th coefficient with `left(k, x)` and the right half's with `right(k, x)`.
fn halve(work: &mut [f64], mut left: impl FnMut(usize, f64), mut right: impl FnMut(usize, f64)) {
    let n = work.len();
    left(0, work[0]);
    right(n - 1, work[n - 1]);
    for r in 1..n {
        for i in 0..n - r {
            work[i] = 0.5 * (work[i] + work[i + 1]);
        }
        left(r, work[0]);
        right(n - 1 - r, work[n - 1 - r]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::tolerance::{EXACT_EPS, FD_D1_EPS, FD_STEP, ULP_EPS};

    /// Evaluates a net at `(s, t)` in its patch by the Bernstein sum.
    fn eval(net: &[f64], m1: usize, n1: usize, s: f64, t: f64) -> f64 {
        let b = |n: usize, i: usize, x: f64| {
            binomial(n, i) * x.powi(i as i32) * (1.0 - x).powi((n - i) as i32)
        };
        let mut sum = 0.0;
        for i in 0..m1 {
            for j in 0..n1 {
                sum += net[i * n1 + j] * b(m1 - 1, i, s) * b(n1 - 1, j, t);
            }
        }
        sum
    }

    /// A biquadratic rational piece (3 x 3, homogeneous).
    fn piece() -> Vec<DVec4> {
        let mut out = Vec::new();
        for i in 0..3 {
            for j in 0..3 {
                let p = DVec3::new(
                    i as f64 * 0.5,
                    j as f64 * 0.5,
                    ((i + 2 * j) % 3) as f64 * 0.2,
                );
                let w = 1.0 + 0.3 * ((i * j) % 2) as f64;
                out.push((p * w).extend(w));
            }
        }
        out
    }

    /// The patch point by de Casteljau on the homogeneous net.
    fn point(piece: &[DVec4], s: f64, t: f64) -> DVec3 {
        let b = |i: usize, x: f64| binomial(2, i) * x.powi(i as i32) * (1.0 - x).powi(2 - i as i32);
        let mut h = DVec4::ZERO;
        for i in 0..3 {
            for j in 0..3 {
                h += piece[i * 3 + j] * b(i, s) * b(j, t);
            }
        }
        h.truncate() / h.w
    }

    #[test]
    fn the_net_is_w_squared_times_the_distance_excess() {
        let pc = piece();
        let mut nets = DistanceNets::new(3, 3, 1).unwrap();
        nets.set(0, &pc);
        let (m1, n1) = nets.size();
        let p = DVec3::new(0.3, 1.4, 0.7);
        let f_star = 0.2;
        let mut net = vec![0.0; m1 * n1];
        nets.query(0, p, f_star, 0.0, &mut net);
        for (s, t) in [(0.0, 0.0), (0.3, 0.8), (1.0, 0.5), (0.5, 0.5)] {
            let (g, gs, gt) = eval_with_gradient(&net, m1, n1, s, t);
            assert_near!(g, eval(&net, m1, n1, s, t), EXACT_EPS);
            let h = FD_STEP;
            let fd_s = (eval(&net, m1, n1, s + h, t) - eval(&net, m1, n1, s - h, t)) / (2.0 * h);
            let fd_t = (eval(&net, m1, n1, s, t + h) - eval(&net, m1, n1, s, t - h)) / (2.0 * h);
            assert_near!(gs, fd_s, FD_D1_EPS);
            assert_near!(gt, fd_t, FD_D1_EPS);
            let b =
                |i: usize, x: f64| binomial(2, i) * x.powi(i as i32) * (1.0 - x).powi(2 - i as i32);
            let w: f64 = (0..9).map(|k| pc[k].w * b(k / 3, s) * b(k % 3, t)).sum();
            let expect = w * w * (point(&pc, s, t).distance_squared(p) - f_star);
            assert_near!(eval(&net, m1, n1, s, t), expect, EXACT_EPS);
        }
        // The bound: no coefficient is above the polynomial's minimum.
        let lowest = (0..=20)
            .flat_map(|i| (0..=20).map(move |j| (i as f64 / 20.0, j as f64 / 20.0)))
            .map(|(s, t)| eval(&net, m1, n1, s, t))
            .fold(f64::INFINITY, f64::min);
        assert!(net_min(&net) <= lowest);
    }

    #[test]
    fn split_quarters_evaluate_like_the_whole() {
        let pc = piece();
        let mut nets = DistanceNets::new(3, 3, 1).unwrap();
        nets.set(0, &pc);
        let (m1, n1) = nets.size();
        let mut net = vec![0.0; m1 * n1];
        nets.query(0, DVec3::new(0.1, 0.2, 0.9), 0.0, 0.0, &mut net);
        let mut quarters = [[0.0; MAX_SIDE * MAX_SIDE]; 4];
        split4(&net, m1, n1, &mut quarters);
        for (q, (s0, t0)) in [(0.0, 0.0), (0.5, 0.0), (0.0, 0.5), (0.5, 0.5)]
            .iter()
            .enumerate()
        {
            for (s, t) in [(0.0, 0.0), (0.25, 0.7), (1.0, 1.0)] {
                assert_near!(
                    eval(&quarters[q], m1, n1, s, t),
                    eval(&net, m1, n1, s0 + 0.5 * s, t0 + 0.5 * t),
                    EXACT_EPS
                );
            }
        }
    }

    #[test]
    fn sized_kernels_match_the_generic_ones_bit_for_bit() {
        let mut state = 0x9E37_79B9_7F4A_7C15_u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.3
        };
        for m1 in [3, 5, 7] {
            for n1 in [3, 5, 7] {
                for trial in 0..50 {
                    // Mostly convex bowls plus noise, so both answers of the test occur.
                    let net: Vec<f64> = (0..m1 * n1)
                        .map(|k| {
                            let (s, t) = ((k / n1) as f64 - 2.0, (k % n1) as f64 - 3.0);
                            (s * s + t * t) * (trial % 3) as f64 + next()
                        })
                        .collect();
                    assert_eq!(is_convex(&net, m1, n1), is_convex_any(&net, m1, n1));
                    let (s, t) = (next() + 0.3, next() + 0.3);
                    assert_eq!(
                        eval_with_gradient(&net, m1, n1, s, t),
                        eval_with_gradient_any(&net, m1, n1, s, t)
                    );
                    let mut fast = [[0.0; MAX_SIDE * MAX_SIDE]; 4];
                    let mut slow = [[0.0; MAX_SIDE * MAX_SIDE]; 4];
                    split4(&net, m1, n1, &mut fast);
                    split4_any(&net, m1, n1, &mut slow);
                    for q in 0..4 {
                        assert_eq!(fast[q][..m1 * n1], slow[q][..m1 * n1], "{m1}x{n1} q{q}");
                    }
                }
            }
        }
    }

    #[test]
    fn a_net_rising_away_from_a_side_is_decided_on_that_side() {
        // g(s, t) = s + (t - 0.6)^2 - 0.01 on the unit square, biquadratic: its minimum
        // -0.01 lies on the side s = 0, where g is a convex parabola in t.
        let g = |s: f64, t: f64| s + (t - 0.6) * (t - 0.6) - 0.01;
        // Coefficients of s are [0, 1/2, 1], of t^2 are [0, 0, 1], of t are [0, 1/2, 1].
        let net: Vec<f64> = (0..9)
            .map(|k| {
                let (i, j) = (k / 3, k % 3);
                let s = [0.0, 0.5, 1.0][i];
                let (t2, t) = ([0.0, 0.0, 1.0][j], [0.0, 0.5, 1.0][j]);
                s + t2 - 1.2 * t + 0.36 - 0.01
            })
            .collect();
        assert_near!(eval(&net, 3, 3, 0.3, 0.2), g(0.3, 0.2), EXACT_EPS);
        assert_eq!(monotone_side(&net, 3, 3), Some(Side::ULo));
        let mut side = [0.0; MAX_SIDE];
        let len = side_net(&net, 3, 3, Side::ULo, &mut side);
        assert_eq!(len, 3);
        // Below the minimum: cleared by the tangent line at the minimum, not at t = 0.
        assert!(curve_clears(&side[..len], -0.0101, [0.6]));
        assert!(!curve_clears(&side[..len], -0.0101, [0.0]));
        // Above the minimum: never cleared.
        assert!(!curve_clears(&side[..len], -0.0099, [0.6, 0.0, 1.0]));
        // A saddle-free but two-way net has no monotone side.
        let bowl: Vec<f64> = (0..9)
            .map(|k| ((k / 3) as f64 - 1.0).powi(2) + ((k % 3) as f64 - 1.0).powi(2))
            .collect();
        assert_eq!(monotone_side(&bowl, 3, 3), None);
    }

    #[test]
    fn convexity_and_the_corner_bound_hold_for_a_bowl_and_fail_for_a_saddle() {
        // g(s, t) = (s - 0.3)^2 + (t - 0.6)^2 - 0.01 as a biquadratic net: coefficients
        // of s^2 are [0, 0, 1], of s are [0, 1/2, 1], of 1 are [1, 1, 1].
        let bowl: Vec<f64> = (0..9)
            .map(|k| {
                let (i, j) = (k / 3, k % 3);
                let sq = [0.0, 0.0, 1.0];
                let lin = [0.0, 0.5, 1.0];
                sq[i] - 0.6 * lin[i] + 0.09 + sq[j] - 1.2 * lin[j] + 0.36 - 0.01
            })
            .collect();
        assert!(is_convex(&bowl, 3, 3));
        // The tangent-plane bounds never exceed the true minimum (-0.01), and the one at
        // the minimum is tight.
        for (s, t) in [(0.0, 0.0), (1.0, 0.0), (0.5, 1.0), (0.2, 0.9)] {
            assert!(convex_bound_at(&bowl, 3, 3, s, t) <= -0.01 + ULP_EPS);
        }
        assert_near!(convex_bound_at(&bowl, 3, 3, 0.3, 0.6), -0.01, ULP_EPS);
        let saddle: Vec<f64> = bowl
            .iter()
            .enumerate()
            .map(|(k, &c)| {
                let j = k % 3;
                let sq = [0.0, 0.0, 1.0];
                c - 2.0 * sq[j]
            })
            .collect();
        assert!(!is_convex(&saddle, 3, 3));
    }
}
