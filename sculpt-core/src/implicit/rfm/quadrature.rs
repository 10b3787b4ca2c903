//! Quadrature adapted to an implicit domain `omega >= 0`: the Ritz method's area
//! integrals (eq. 11) and the film term's boundary integrals (eq. 12) with no mesh.
//!
//! The knot-span cells of the basis are classified by interval arithmetic on the
//! domain's tape: a cell wholly inside gets a tensor Gauss rule, a cell wholly outside
//! nothing, and a cell that may be cut is split in four, down to `depth` levels. A cut
//! cell at the last level is clipped by the zero contour (Sutherland-Hodgman against
//! `omega > 0`, each crossing found on its edge by regula falsi in f64), the clipped
//! polygon is integrated by a triangle rule, and its edges that run along the contour
//! carry a Gauss-Legendre rule for the boundary, each point projected onto `omega = 0`
//! by Newton steps along `grad omega`.

use crate::implicit::Tape;
use crate::implicit::interval::Interval;
use crate::tolerance::RFM_ROOT_REL;

use super::jet::Jet2;

/// A weighted point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WeightedPoint {
    /// The point.
    pub p: [f64; 2],
    /// Its weight (area or arc length).
    pub w: f64,
}

/// The points and weights of a domain's area and boundary integrals.
#[derive(Debug, Clone, Default)]
pub struct Quadrature {
    /// Area rule: `integral f dA ~ sum w f(p)`.
    pub interior: Vec<WeightedPoint>,
    /// Boundary rule: `integral f ds ~ sum w f(p)` over `omega = 0`.
    pub boundary: Vec<WeightedPoint>,
}

/// Gauss-Legendre nodes and weights on `[0, 1]`, 4 points (exact to degree 7).
const GAUSS4: [(f64, f64); 4] = [
    (0.069_431_844_202_973_71, 0.173_927_422_568_726_93),
    (0.330_009_478_207_571_87, 0.326_072_577_431_273_07),
    (0.669_990_521_792_428_1, 0.326_072_577_431_273_07),
    (0.930_568_155_797_026_3, 0.173_927_422_568_726_93),
];

/// Gauss-Legendre on `[0, 1]`, 3 points (exact to degree 5), for boundary segments and
/// the smaller cells of split ones.
const GAUSS3: [(f64, f64); 3] = [
    (0.112_701_665_379_258_31, 0.277_777_777_777_777_8),
    (0.5, 0.444_444_444_444_444_4),
    (0.887_298_334_620_741_7, 0.277_777_777_777_777_8),
];

/// Dunavant's 7-point rule on a triangle (barycentric coordinates, weights summing to
/// 1; exact to degree 5).
const TRIANGLE7: [([f64; 3], f64); 7] = {
    const A1: f64 = 0.059_715_871_789_769_82;
    const B1: f64 = 0.470_142_064_105_115_1;
    const A2: f64 = 0.797_426_985_353_087_3;
    const B2: f64 = 0.101_286_507_323_456_34;
    const W0: f64 = 0.225;
    const W1: f64 = 0.132_394_152_788_506_2;
    const W2: f64 = 0.125_939_180_544_827_1;
    [
        ([1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0], W0),
        ([A1, B1, B1], W1),
        ([B1, A1, B1], W1),
        ([B1, B1, A1], W1),
        ([A2, B2, B2], W2),
        ([B2, A2, B2], W2),
        ([B2, B2, A2], W2),
    ]
};

/// Newton steps that move a boundary Gauss point onto `omega = 0`.
const PROJECTION_STEPS: usize = 3;
/// Regula falsi iterations on an edge (each at least halves the bracket's worse side).
const ROOT_ITERATIONS: usize = 60;

/// Builds the rule for the domain `omega >= 0` over the cells `xs x ys` (their edges
/// per axis). `tape` bounds omega over boxes (f32 intervals); `omega` evaluates it in
/// f64 with its gradient.
pub fn build(
    tape: &Tape,
    omega: &mut dyn FnMut([f64; 2]) -> Jet2,
    xs: &[f64],
    ys: &[f64],
    depth: u32,
) -> Quadrature {
    let mut q = Quadrature::default();
    for wy in ys.windows(2) {
        for wx in xs.windows(2) {
            cell(
                tape,
                omega,
                [wx[0], wy[0]],
                [wx[1], wy[1]],
                depth,
                depth,
                &mut q,
            );
        }
    }
    q
}

fn cell(
    tape: &Tape,
    omega: &mut dyn FnMut([f64; 2]) -> Jet2,
    lo: [f64; 2],
    hi: [f64; 2],
    depth: u32,
    top: u32,
    q: &mut Quadrature,
) {
    let region = [
        Interval::new((lo[0] as f32).next_down(), (hi[0] as f32).next_up()),
        Interval::new((lo[1] as f32).next_down(), (hi[1] as f32).next_up()),
        Interval::point(0.0),
    ];
    let range = tape.eval_interval(region);
    let (inside, outside) = if range.nan || range.lo <= 0.0 && range.hi >= 0.0 {
        sampled_side(omega, lo, hi)
    } else {
        (range.lo > 0.0, range.hi < 0.0)
    };
    if inside {
        // A whole knot-span cell gets 4 x 4 points; the smaller cells of a split one 3 x 3.
        let rule: &[(f64, f64)] = if depth == top { &GAUSS4 } else { &GAUSS3 };
        let area = (hi[0] - lo[0]) * (hi[1] - lo[1]);
        for &(gy, wy) in rule {
            for &(gx, wx) in rule {
                q.interior.push(WeightedPoint {
                    p: [lo[0] + gx * (hi[0] - lo[0]), lo[1] + gy * (hi[1] - lo[1])],
                    w: area * wx * wy,
                });
            }
        }
        return;
    }
    if outside {
        return;
    }
    if depth > 0 {
        let mid = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
        for (l, h) in [
            ([lo[0], lo[1]], [mid[0], mid[1]]),
            ([mid[0], lo[1]], [hi[0], mid[1]]),
            ([lo[0], mid[1]], [mid[0], hi[1]]),
            ([mid[0], mid[1]], [hi[0], hi[1]]),
        ] {
            cell(tape, omega, l, h, depth - 1, top, q);
        }
        return;
    }
    clip_cell(omega, lo, hi, q);
}

/// Whether a cell is wholly inside or wholly outside, judged from samples where
/// interval arithmetic could not tell (it is loose on deep R-function compositions):
/// the centre's value must exceed [`SAMPLE_MARGIN`] times what its gradient could
/// change over the half diagonal, with the corners on the same side. For a
/// distance-like omega (sec. 2.1.2) the boundary is then farther than the cell reaches.
fn sampled_side(
    omega: &mut dyn FnMut([f64; 2]) -> Jet2,
    lo: [f64; 2],
    hi: [f64; 2],
) -> (bool, bool) {
    let c = omega([0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])]);
    let reach = SAMPLE_MARGIN * c.dx.hypot(c.dy) * 0.5 * (hi[0] - lo[0]).hypot(hi[1] - lo[1]);
    if c.v.is_nan() || reach.is_nan() || c.v.abs() <= reach {
        return (false, false);
    }
    let corners = [
        [lo[0], lo[1]],
        [hi[0], lo[1]],
        [lo[0], hi[1]],
        [hi[0], hi[1]],
    ];
    let same = corners.iter().all(|&p| {
        let v = omega(p).v;
        if c.v > 0.0 { v > 0.0 } else { v < 0.0 }
    });
    (same && c.v > 0.0, same && c.v < 0.0)
}

/// How many times the first-order change over the half diagonal the centre's value must
/// exceed for [`sampled_side`] to call a cell uncut.
const SAMPLE_MARGIN: f64 = 2.0;

/// A vertex of a clipped polygon: a corner inside, or a crossing where the boundary
/// leaves (`exit`) or enters the polygon along the walk.
#[derive(Debug, Clone, Copy)]
struct Vertex {
    p: [f64; 2],
    crossing: Option<bool>,
}

fn clip_cell(
    omega: &mut dyn FnMut([f64; 2]) -> Jet2,
    lo: [f64; 2],
    hi: [f64; 2],
    q: &mut Quadrature,
) {
    let corners = [
        [lo[0], lo[1]],
        [hi[0], lo[1]],
        [hi[0], hi[1]],
        [lo[0], hi[1]],
    ];
    let values = corners.map(|c| omega(c).v);
    let mut poly: Vec<Vertex> = Vec::with_capacity(8);
    for i in 0..4 {
        let (a, b) = (corners[i], corners[(i + 1) % 4]);
        let (fa, fb) = (values[i], values[(i + 1) % 4]);
        let (ina, inb) = (fa > 0.0, fb > 0.0);
        if ina {
            poly.push(Vertex {
                p: a,
                crossing: None,
            });
        }
        if ina != inb {
            poly.push(Vertex {
                p: edge_root(omega, a, b, fa, fb),
                crossing: Some(ina),
            });
        }
    }
    if poly.len() < 3 {
        return;
    }
    // The area: a fan from the first vertex (the clipped square is convex unless the
    // contour is a saddle inside the cell; the fan then still covers the polygon).
    let o = poly[0].p;
    for k in 1..poly.len() - 1 {
        let (a, b) = (poly[k].p, poly[k + 1].p);
        let area = 0.5 * ((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]));
        if area <= 0.0 {
            continue;
        }
        for &(l, w) in &TRIANGLE7 {
            q.interior.push(WeightedPoint {
                p: [
                    l[0] * o[0] + l[1] * a[0] + l[2] * b[0],
                    l[0] * o[1] + l[1] * a[1] + l[2] * b[1],
                ],
                w: area * w,
            });
        }
    }
    // The boundary: from each exit crossing to the entry crossing that follows it.
    for k in 0..poly.len() {
        let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
        if a.crossing == Some(true) && b.crossing == Some(false) {
            let len = (b.p[0] - a.p[0]).hypot(b.p[1] - a.p[1]);
            for &(t, w) in &GAUSS3 {
                let p = [
                    a.p[0] + t * (b.p[0] - a.p[0]),
                    a.p[1] + t * (b.p[1] - a.p[1]),
                ];
                q.boundary.push(WeightedPoint {
                    p: project(omega, p),
                    w: len * w,
                });
            }
        }
    }
}

/// The zero of omega on the segment `a`-`b` (`fa`, `fb` of opposite signs), by the
/// Illinois variant of regula falsi.
fn edge_root(
    omega: &mut dyn FnMut([f64; 2]) -> Jet2,
    a: [f64; 2],
    b: [f64; 2],
    fa: f64,
    fb: f64,
) -> [f64; 2] {
    let at = |t: f64| [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
    let (mut t0, mut t1, mut f0, mut f1) = (0.0f64, 1.0f64, fa, fb);
    let mut side = 0i8;
    for _ in 0..ROOT_ITERATIONS {
        if (t1 - t0).abs() <= RFM_ROOT_REL {
            break;
        }
        let t = if f1 != f0 {
            t1 - f1 * (t1 - t0) / (f1 - f0)
        } else {
            0.5 * (t0 + t1)
        };
        let t = if t > t0.min(t1) && t < t0.max(t1) {
            t
        } else {
            0.5 * (t0 + t1)
        };
        let f = omega(at(t)).v;
        if f == 0.0 {
            return at(t);
        }
        if (f > 0.0) == (f1 > 0.0) {
            t1 = t;
            f1 = f;
            if side == -1 {
                f0 *= 0.5;
            }
            side = -1;
        } else {
            t0 = t;
            f0 = f;
            if side == 1 {
                f1 *= 0.5;
            }
            side = 1;
        }
    }
    at(if f0.abs() < f1.abs() { t0 } else { t1 })
}

/// `p` moved onto `omega = 0` by Newton steps along the gradient (kept where a step
/// would fail).
fn project(omega: &mut dyn FnMut([f64; 2]) -> Jet2, mut p: [f64; 2]) -> [f64; 2] {
    for _ in 0..PROJECTION_STEPS {
        let j = omega(p);
        let g2 = j.dx * j.dx + j.dy * j.dy;
        if g2.is_nan() || g2 <= 0.0 || !j.v.is_finite() {
            break;
        }
        let next = [p[0] - j.v * j.dx / g2, p[1] - j.v * j.dy / g2];
        if !(next[0].is_finite() && next[1].is_finite()) {
            break;
        }
        p = next;
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::implicit::Model;
    use crate::implicit::rfm::jet::JetProgram;

    /// The area and perimeter of an annulus (circles of radius 0.3 and 1 joined by the
    /// R_0 conjunction) against pi (R^2 - r^2) and 2 pi (R + r).
    #[test]
    fn annulus_area_and_perimeter() {
        let model = Model::from_solid_json(
            r#"{"solid": {"and": {"solids": [
                {"circle": {"center": [0, 0], "radius": 1}},
                {"not": {"solid": {"circle": {"center": [0, 0], "radius": 0.3}}}}]}}}"#,
        )
        .unwrap();
        let tape = model.tape_positive_inside();
        let prog = JetProgram::new(&model.graph, &[model.root]);
        let mut scratch = Vec::new();
        let mut omega = |p: [f64; 2]| {
            let mut out = [Jet2::default()];
            prog.eval(p, &mut scratch, &mut out);
            out[0]
        };
        let edges: Vec<f64> = (0..=7).map(|i| -1.0 + 2.0 * f64::from(i) / 7.0).collect();
        let mut errors = Vec::new();
        for depth in [2, 4] {
            let q = build(&tape, &mut omega, &edges, &edges, depth);
            let area: f64 = q.interior.iter().map(|w| w.w).sum();
            let length: f64 = q.boundary.iter().map(|w| w.w).sum();
            let pi = std::f64::consts::PI;
            errors.push(((area - pi * 0.91).abs(), (length - 2.0 * pi * 1.3).abs()));
            // Boundary points lie on the circles.
            for b in &q.boundary {
                let r = b.p[0].hypot(b.p[1]);
                assert_near!(
                    (r - 1.0).abs().min((r - 0.3).abs()),
                    0.0,
                    RFM_ROOT_REL * 1e3
                );
            }
        }
        // Second order: four times finer cells cut the perimeter's error by about 16.
        // (The area's chord errors of the outer circle and of the hole have opposite
        // signs and mostly cancel, so the area is only checked to be close.)
        assert!(errors[1].1 < errors[0].1 / 8.0, "{errors:?}");
        assert!(
            errors[0].0 < 0.0001 && errors[1].0 < 0.0001 && errors[1].1 < 0.001,
            "{errors:?}"
        );
    }
}
