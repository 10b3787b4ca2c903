//! Volumetric NURBS (`sculpt_core::volume`) against independent references: a slow
//! direct Cox-de Boor sum written here, finite differences, and analytic geometry.

// The references index by direction and attribute as the formulas do.
#![allow(clippy::needless_range_loop)]

use proptest::prelude::*;
use sculpt_core::assert_near;
use sculpt_core::tolerance::{
    FD_EPS, FD_STEP, FIT_EPS, VOLUME_EVAL_REL, VOLUME_EXACT_REL, VOLUME_GRID_INTERP_EPS,
    VOLUME_INVERSE_PARAM_EPS, VOLUME_QUADRATURE_REL, VOLUME_REFINE_REL,
};
use sculpt_core::volume::integrate::span_rule;
use sculpt_core::volume::{Volume, VolumeError};

/// A small deterministic generator (xorshift64*), so the random volumes are the same
/// on every run.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next()
    }
}

/// A clamped knot vector of degree `p` with `count` control points on `[a, b]`, with
/// random interior knots (one of them doubled when there is room).
fn random_knots(rng: &mut Rng, p: usize, count: usize, a: f64, b: f64) -> Vec<f64> {
    let mut inner: Vec<f64> = (0..count - p - 1)
        .map(|_| rng.range(a + 0.05, b - 0.05))
        .collect();
    if inner.len() >= 2 && p >= 2 {
        inner[1] = inner[0];
    }
    inner.sort_by(f64::total_cmp);
    let mut k = vec![a; p + 1];
    k.extend(inner);
    k.extend(vec![b; p + 1]);
    k
}

struct Spec {
    degrees: Vec<usize>,
    knots: Vec<Vec<f64>>,
    values: Vec<f64>,
    weights: Vec<f64>,
    k: usize,
}

fn random_spec(rng: &mut Rng, degrees: &[usize], extra: &[usize], k: usize) -> Spec {
    let mut knots = Vec::new();
    let mut total = 1;
    for (d, (&p, &e)) in degrees.iter().zip(extra).enumerate() {
        let count = p + 1 + e;
        let a = -1.0 + d as f64 * 0.5;
        knots.push(random_knots(rng, p, count, a, a + 2.0 + d as f64));
        total *= count;
    }
    let values = (0..total * k).map(|_| rng.range(-2.0, 2.0)).collect();
    let weights = (0..total).map(|_| rng.range(0.3, 3.0)).collect();
    Spec {
        degrees: degrees.to_vec(),
        knots,
        values,
        weights,
        k,
    }
}

fn build(s: &Spec) -> Volume {
    let names = (0..s.k).map(|c| format!("a{c}")).collect();
    Volume::new(
        s.degrees.clone(),
        s.knots.clone(),
        names,
        s.values.clone(),
        Some(s.weights.clone()),
    )
    .unwrap()
}

/// The `order`-th derivative of `N_{i,p}` at `u` by the Cox-de Boor recursion
/// (P&T eq. 2.5) and the derivative recursion (P&T eq. 2.7), straight from the
/// definitions. At the right end of the domain the last non-empty span is closed.
fn cox_de_boor(knots: &[f64], i: usize, p: usize, u: f64, order: usize) -> f64 {
    if order > 0 {
        if p == 0 {
            return 0.0;
        }
        let mut v = 0.0;
        let d0 = knots[i + p] - knots[i];
        if d0 > 0.0 {
            v += cox_de_boor(knots, i, p - 1, u, order - 1) / d0;
        }
        let d1 = knots[i + p + 1] - knots[i + 1];
        if d1 > 0.0 {
            v -= cox_de_boor(knots, i + 1, p - 1, u, order - 1) / d1;
        }
        return p as f64 * v;
    }
    if p == 0 {
        let end = *knots.last().unwrap();
        let last_span = knots.iter().rposition(|&k| k < end).unwrap();
        return if (knots[i] <= u && u < knots[i + 1]) || (u == end && i == last_span) {
            1.0
        } else {
            0.0
        };
    }
    let mut v = 0.0;
    let d0 = knots[i + p] - knots[i];
    if d0 > 0.0 {
        v += (u - knots[i]) / d0 * cox_de_boor(knots, i, p - 1, u, 0);
    }
    let d1 = knots[i + p + 1] - knots[i + 1];
    if d1 > 0.0 {
        v += (knots[i + p + 1] - u) / d1 * cox_de_boor(knots, i + 1, p - 1, u, 0);
    }
    v
}

/// The slow reference: sums over every control point of the net (not only the local
/// ones) of the homogeneous values times the product of the basis derivatives of
/// orders `alpha`; returns `(S_alpha, W_alpha)` (`k` numerator values and the
/// denominator).
fn slow_sums(s: &Spec, u: &[f64], alpha: &[usize]) -> (Vec<f64>, f64) {
    let n = s.degrees.len();
    let counts: Vec<usize> = s
        .knots
        .iter()
        .zip(&s.degrees)
        .map(|(k, p)| k.len() - p - 1)
        .collect();
    let total: usize = counts.iter().product();
    let mut num = vec![0.0; s.k];
    let mut den = 0.0;
    for flat in 0..total {
        let mut rest = flat;
        let mut idx = vec![0; n];
        for d in (0..n).rev() {
            idx[d] = rest % counts[d];
            rest /= counts[d];
        }
        let mut b = 1.0;
        for d in 0..n {
            b *= cox_de_boor(&s.knots[d], idx[d], s.degrees[d], u[d], alpha[d]);
        }
        let h = s.weights[flat];
        for c in 0..s.k {
            num[c] += b * h * s.values[flat * s.k + c];
        }
        den += b * h;
    }
    (num, den)
}

/// The value, the first derivatives `[d][c]` and the second `[a][b][c]`.
type SlowDerivatives = (Vec<f64>, Vec<Vec<f64>>, Vec<Vec<Vec<f64>>>);

/// The value, first and second derivatives of the rational map `S / W`, from the
/// slow sums, by differentiating the quotient directly:
/// `(S/W)_a = S_a / W - S W_a / W^2` and
/// `(S/W)_ab = S_ab / W - (S_a W_b + S_b W_a + S W_ab) / W^2 + 2 S W_a W_b / W^3`.
fn slow_derivatives(s: &Spec, u: &[f64]) -> SlowDerivatives {
    let n = s.degrees.len();
    let unit = |dirs: &[usize]| {
        let mut a = vec![0; n];
        for &d in dirs {
            a[d] += 1;
        }
        slow_sums(s, u, &a)
    };
    let (s0, w0) = unit(&[]);
    let value: Vec<f64> = s0.iter().map(|x| x / w0).collect();
    let first: Vec<(Vec<f64>, f64)> = (0..n).map(|d| unit(&[d])).collect();
    let d1: Vec<Vec<f64>> = first
        .iter()
        .map(|(sa, wa)| {
            (0..s.k)
                .map(|c| sa[c] / w0 - s0[c] * wa / (w0 * w0))
                .collect()
        })
        .collect();
    let d2 = (0..n)
        .map(|a| {
            (0..n)
                .map(|b| {
                    let (sab, wab) = unit(&[a, b]);
                    let (sa, wa) = &first[a];
                    let (sb, wb) = &first[b];
                    (0..s.k)
                        .map(|c| {
                            sab[c] / w0 - (sa[c] * wb + sb[c] * wa + s0[c] * wab) / (w0 * w0)
                                + 2.0 * s0[c] * wa * wb / (w0 * w0 * w0)
                        })
                        .collect()
                })
                .collect()
        })
        .collect();
    (value, d1, d2)
}

/// A volume with the knots and weights of `base` and new values and names.
fn rebuild(base: &Volume, names: &[&str], values: Vec<f64>, weights: Vec<f64>) -> Volume {
    let knots = base
        .knot_vectors()
        .iter()
        .map(|k| k.knots().to_vec())
        .collect();
    let names = names.iter().map(|n| n.to_string()).collect();
    Volume::new(base.degrees(), knots, names, values, Some(weights)).unwrap()
}

fn scale(v: &[f64]) -> f64 {
    1.0 + v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn random_params(rng: &mut Rng, vol: &Volume) -> Vec<f64> {
    vol.domain().iter().map(|&(a, b)| rng.range(a, b)).collect()
}

/// The configurations the random checks run: every number of directions, mixed
/// degrees, several attributes.
fn configs() -> Vec<(Vec<usize>, Vec<usize>, usize)> {
    vec![
        (vec![3], vec![3], 2),
        (vec![2, 3], vec![2, 1], 3),
        (vec![3, 3, 3], vec![2, 1, 2], 5),
        (vec![2, 1, 3], vec![1, 2, 0], 4),
        (vec![1, 2, 2, 1], vec![1, 1, 1, 1], 2),
        (vec![3, 3, 3], vec![1, 1, 1], 10),
        // The all-cubic trivariate SIMD path takes 3 to 7 attributes (4 to 8 values a
        // homogeneous point): its narrowest and widest.
        (vec![3, 3, 3], vec![1, 2, 1], 3),
        (vec![3, 3, 3], vec![2, 1, 3], 7),
    ]
}

#[test]
fn random_rational_volumes_match_a_slow_cox_de_boor_sum() {
    let mut rng = Rng(0x5EED_0033);
    for (degrees, extra, k) in configs() {
        let spec = random_spec(&mut rng, &degrees, &extra, k);
        let vol = build(&spec);
        let n = degrees.len();
        let mut params: Vec<Vec<f64>> = (0..12).map(|_| random_params(&mut rng, &vol)).collect();
        // The domain's corners (right ends included) and a repeated interior knot.
        params.push(vol.domain().iter().map(|d| d.0).collect());
        params.push(vol.domain().iter().map(|d| d.1).collect());
        params.push(
            spec.knots
                .iter()
                .zip(&degrees)
                .map(|(k, p)| k[p + 1])
                .collect(),
        );
        for u in &params {
            let (value, d1, d2) = slow_derivatives(&spec, u);
            let tol = VOLUME_EVAL_REL * scale(&value).max(scale(&d1.concat()));
            let got = vol.derivatives(u, 2).unwrap();
            assert_near!(got.value(), value.as_slice(), tol, "value at {u:?}");
            assert_near!(vol.point(u).unwrap(), value, tol, "point at {u:?}");
            for d in 0..n {
                assert_near!(got.d1(d), d1[d].as_slice(), tol, "d/du{d} at {u:?}");
                for e in 0..n {
                    let t2 = VOLUME_EVAL_REL * scale(&d2[d][e]) * 100.0;
                    assert_near!(
                        got.d2(d, e),
                        d2[d][e].as_slice(),
                        t2,
                        "d2 ({d},{e}) at {u:?}"
                    );
                }
            }
            // The allocation-free first-derivative path (the trivariate fast path for
            // n = 3) agrees with the slow sum too.
            let mut row = vec![0.0; k * (n + 1)];
            vol.eval_d1_into(u, &mut row).unwrap();
            let mut want = value.clone();
            for d in &d1 {
                want.extend(d);
            }
            assert_near!(row, want, tol, "eval_d1_into at {u:?}");
        }
    }
}

#[test]
fn derivatives_match_central_differences() {
    let mut rng = Rng(0xFD_0033);
    for (degrees, extra, k) in configs() {
        let vol = build(&random_spec(&mut rng, &degrees, &extra, k));
        let n = degrees.len();
        for _ in 0..6 {
            // Inside the domain, away from its ends, so both steps stay in it.
            let u: Vec<f64> = vol
                .domain()
                .iter()
                .map(|&(a, b)| rng.range(a + 0.1 * (b - a), b - 0.1 * (b - a)))
                .collect();
            let got = vol.derivatives(&u, 2).unwrap();
            for d in 0..n {
                let shifted = |h: f64| {
                    let mut v = u.clone();
                    v[d] += h;
                    vol.derivatives(&v, 1).unwrap()
                };
                let (plus, minus) = (shifted(FD_STEP), shifted(-FD_STEP));
                // Near a knot (C^{p-1} there) a difference across it is still accurate
                // for the first derivative of these C^1 and smoother volumes.
                let fd1: Vec<f64> = (0..k)
                    .map(|c| (plus.value()[c] - minus.value()[c]) / (2.0 * FD_STEP))
                    .collect();
                assert_near!(
                    got.d1(d),
                    fd1.as_slice(),
                    FD_EPS * scale(&fd1),
                    "d/du{d} at {u:?}"
                );
                for e in 0..n {
                    let fd2: Vec<f64> = (0..k)
                        .map(|c| (plus.d1(e)[c] - minus.d1(e)[c]) / (2.0 * FD_STEP))
                        .collect();
                    // Second derivatives jump at knots of degree-1 directions and
                    // multiplicity p - 1: compare only where both steps share a span.
                    let kv = vol.knots(d);
                    if kv.find_span(u[d] + FD_STEP) == kv.find_span(u[d] - FD_STEP) {
                        assert_near!(
                            got.d2(d, e),
                            fd2.as_slice(),
                            FD_EPS * scale(&fd2),
                            "d2 ({d},{e}) at {u:?}"
                        );
                    }
                }
            }
        }
    }
}

/// The allocation-free first derivatives ([`Volume::eval_d1_into`]) of all-cubic
/// trivariate volumes, every width its SIMD path takes (3 to 7 attributes) and one
/// beyond, against central differences of the values alone ([`Volume::eval_into`]) and
/// against the general evaluator ([`Volume::derivatives`]).
#[test]
fn cubic_first_derivatives_match_central_differences_and_the_general_path() {
    let mut rng = Rng(0xC0B1_C033);
    for k in 3..=8 {
        let spec = random_spec(&mut rng, &[3, 3, 3], &[2, 1, 3], k);
        let vol = build(&spec);
        for _ in 0..8 {
            let u: Vec<f64> = vol
                .domain()
                .iter()
                .map(|&(a, b)| rng.range(a + 0.1 * (b - a), b - 0.1 * (b - a)))
                .collect();
            let mut row = vec![0.0; 4 * k];
            vol.eval_d1_into(&u, &mut row).unwrap();
            let general = vol.derivatives(&u, 1).unwrap();
            let tol = VOLUME_EVAL_REL * scale(&row);
            assert_near!(&row[..k], general.value(), tol, "k {k}: value at {u:?}");
            let mut value = vec![0.0; k];
            vol.eval_into(&u, &mut value).unwrap();
            assert_near!(
                &row[..k],
                value.as_slice(),
                tol,
                "k {k}: eval_into at {u:?}"
            );
            for d in 0..3 {
                let d1 = &row[(1 + d) * k..(2 + d) * k];
                assert_near!(d1, general.d1(d), tol, "k {k}: d/du{d} at {u:?}");
                let at = |h: f64| {
                    let mut v = u.clone();
                    v[d] += h;
                    let mut out = vec![0.0; k];
                    vol.eval_into(&v, &mut out).unwrap();
                    out
                };
                let (plus, minus) = (at(FD_STEP), at(-FD_STEP));
                let fd: Vec<f64> = (0..k)
                    .map(|c| (plus[c] - minus[c]) / (2.0 * FD_STEP))
                    .collect();
                assert_near!(
                    d1,
                    fd.as_slice(),
                    FD_EPS * scale(&fd),
                    "k {k}: FD d/du{d} at {u:?}"
                );
            }
        }
    }
}

/// The rational quarter cylindrical shell: angle `0..pi/2` (degree 2, the exact
/// rational quarter circle), radius `r0..r1` (degree 1), height `0..h` (degree 1),
/// carrying `x, y, z` and a density `rho = a + b z`.
fn quarter_shell(r0: f64, r1: f64, h: f64, a: f64, b: f64) -> Volume {
    let arc = [(1.0, 0.0), (1.0, 1.0), (0.0, 1.0)];
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let arc_w = [1.0, s, 1.0];
    let mut values = Vec::new();
    let mut weights = Vec::new();
    for (i, (cx, cy)) in arc.iter().enumerate() {
        for r in [r0, r1] {
            for z in [0.0, h] {
                values.extend([r * cx, r * cy, z, a + b * z]);
                weights.push(arc_w[i]);
            }
        }
    }
    Volume::new(
        vec![2, 1, 1],
        vec![
            vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
            vec![0.0, 0.0, 1.0, 1.0],
            vec![0.0, 0.0, 1.0, 1.0],
        ],
        ["x", "y", "z", "rho"].map(String::from).to_vec(),
        values,
        Some(weights),
    )
    .unwrap()
}

#[test]
fn quarter_cylindrical_shell_has_the_analytic_volume_and_mass() {
    let (r0, r1, h, a, b) = (1.0, 2.5, 3.0, 0.7, 1.3);
    let vol = quarter_shell(r0, r1, h, a, b);
    // Points lie on the cylinder of their radius.
    let p = vol.point(&[0.37, 0.0, 0.5]).unwrap();
    assert_near!(p[0].hypot(p[1]), r0, VOLUME_EXACT_REL);
    let quarter = std::f64::consts::FRAC_PI_4 * (r1 * r1 - r0 * r0);
    let volume = quarter * h;
    let mass = quarter * (a * h + b * h * h / 2.0);
    let got = vol.integrate(16);
    assert!(got.physical);
    assert_near!(got.measure / volume, 1.0, VOLUME_EXACT_REL);
    assert_near!(got.integrals[3] / mass, 1.0, VOLUME_EXACT_REL);
    // The refined and elevated shell is the same solid.
    let fine = vol
        .refine_knots(0, &[0.3, 0.6])
        .unwrap()
        .elevate_degree(1, 2)
        .unwrap();
    let got = fine.integrate(16);
    assert_near!(got.measure / volume, 1.0, VOLUME_EXACT_REL);
    assert_near!(got.integrals[3] / mass, 1.0, VOLUME_EXACT_REL);
}

fn assert_same_map(a: &Volume, b: &Volume, rng: &mut Rng, what: &str) {
    assert_eq!(a.domain(), b.domain(), "{what}");
    for _ in 0..40 {
        let u = random_params(rng, a);
        let (da, db) = (a.derivatives(&u, 1).unwrap(), b.derivatives(&u, 1).unwrap());
        let tol = VOLUME_REFINE_REL * scale(da.as_slice()) * 10.0;
        assert_near!(da.as_slice(), db.as_slice(), tol, "{what} at {u:?}");
    }
}

#[test]
fn insertion_refinement_and_elevation_leave_the_map_unchanged() {
    let mut rng = Rng(0xE1E7_0033);
    for (degrees, extra, k) in configs() {
        let vol = build(&random_spec(&mut rng, &degrees, &extra, k));
        for d in 0..degrees.len() {
            let (a, b) = vol.knots(d).domain();
            let t = a + 0.4 * (b - a);
            let ins = vol.insert_knot(d, t, 1).unwrap();
            assert_eq!(ins.counts()[d], vol.counts()[d] + 1);
            assert_same_map(&vol, &ins, &mut rng, &format!("insert in {d}"));
            // A doubled knot where the degree allows it.
            let mut x = vec![a + 0.1 * (b - a), a + 0.55 * (b - a), a + 0.9 * (b - a)];
            if degrees[d] >= 2 {
                x.insert(1, a + 0.55 * (b - a));
            }
            let refined = vol.refine_knots(d, &x).unwrap();
            assert_eq!(refined.counts()[d], vol.counts()[d] + x.len());
            assert_same_map(&vol, &refined, &mut rng, &format!("refine in {d}"));
            for t in 1..=2 {
                let up = vol.elevate_degree(d, t).unwrap();
                assert_eq!(up.degrees()[d], degrees[d] + t);
                let spans = vol
                    .knots(d)
                    .knots()
                    .windows(2)
                    .filter(|w| w[1] > w[0])
                    .count();
                // Each distinct knot (interior ones once per span boundary) gains t.
                let interior: usize = vol.knots(d).interior_breaks().len();
                assert_eq!(
                    up.counts()[d],
                    vol.counts()[d] + t * (interior + 1),
                    "{spans}"
                );
                assert_same_map(&vol, &up, &mut rng, &format!("elevate {d} by {t}"));
            }
        }
    }
}

#[test]
fn json_round_trips_and_nests_as_documented() {
    let vol = quarter_shell(1.0, 2.0, 1.0, 1.0, 0.5);
    let text = vol.to_json();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["format"], "wandsculpt-volume");
    assert_eq!(v["version"], 1);
    // control_points[i1][i2][i3]: i1 along the arc. [2][1][1] is (0, r1, h).
    assert_near!(
        v["control_points"][2][1][1][1].as_f64().unwrap(),
        2.0,
        VOLUME_EXACT_REL
    );
    assert_near!(
        v["control_points"][2][1][1][0].as_f64().unwrap(),
        0.0,
        VOLUME_EXACT_REL
    );
    assert_near!(
        v["weights"][1][0][0].as_f64().unwrap(),
        std::f64::consts::FRAC_1_SQRT_2,
        VOLUME_EXACT_REL
    );
    let back = Volume::from_json(&text).unwrap();
    let mut rng = Rng(7);
    assert_same_map(&vol, &back, &mut rng, "round trip");
    // A non-rational volume has no weights in its file.
    let flat = Volume::from_json(&text.replace("0.7071067811865476", "1.0")).unwrap();
    assert!(!flat.is_rational());
    assert!(!flat.to_json().contains("weights"));
}

fn shell_json() -> serde_json::Value {
    serde_json::from_str(&quarter_shell(1.0, 2.0, 1.0, 1.0, 0.5).to_json()).unwrap()
}

#[test]
fn bad_files_get_typed_errors_naming_the_entry() {
    let bad = |edit: &dyn Fn(&mut serde_json::Value)| {
        let mut v = shell_json();
        edit(&mut v);
        Volume::from_json(&v.to_string()).unwrap_err()
    };
    let e = bad(&|v| v["knots"][1] = serde_json::json!([0.0, 0.0, 1.0, 0.5, 1.0]));
    assert!(matches!(e, VolumeError::Knots { direction: 1, .. }), "{e}");
    assert!(e.to_string().contains("decrease"), "{e}");
    let e = bad(&|v| v["knots"][2] = serde_json::json!([0.0, 0.0, 0.5, 1.0, 1.0]));
    assert!(
        matches!(
            e,
            VolumeError::NestedLength {
                direction: 2,
                got: 2,
                need: 3,
                ..
            }
        ),
        "{e}"
    );
    let e = bad(&|v| v["weights"][1][1][0] = serde_json::json!(0.0));
    assert!(matches!(e, VolumeError::Weight { .. }), "{e}");
    assert!(e.to_string().contains("[1][1][0]"), "{e}");
    let e = bad(&|v| v["weights"][0][0][1] = serde_json::json!(-2.0));
    assert!(
        matches!(e, VolumeError::Weight { weight, .. } if weight == -2.0),
        "{e}"
    );
    let e = bad(&|v| v["control_points"][0][1][0] = serde_json::json!([1.0, 2.0]));
    assert!(
        matches!(
            e,
            VolumeError::LeafLength {
                got: 2,
                need: 4,
                ..
            }
        ),
        "{e}"
    );
    let e = bad(&|v| v["control_points"][0][1][0][2] = serde_json::json!("z"));
    assert!(matches!(e, VolumeError::NestedShape { .. }), "{e}");
    let e = bad(&|v| v["format"] = serde_json::json!("wandsculpt-surface"));
    assert!(matches!(e, VolumeError::FormatTag { .. }), "{e}");
    let e = bad(&|v| v["weight"] = serde_json::json!(1.0));
    assert!(matches!(e, VolumeError::Json(_)), "{e}");
    let e = bad(&|v| v["knots"][0] = serde_json::json!([0.0, 0.0, 0.5, 1.0, 1.0, 1.0]));
    assert!(
        matches!(e, VolumeError::NotClamped { direction: 0, .. }),
        "{e}"
    );
    let e = bad(&|v| v["control_points"][0][0][0][0] = serde_json::json!(1e300));
    assert!(matches!(e, VolumeError::ControlValue { .. }), "{e}");
    // NaN cannot be written in JSON; the constructor refuses it.
    let e = Volume::new(
        vec![1],
        vec![vec![0.0, 0.0, 1.0, 1.0]],
        vec!["f".into()],
        vec![0.0, f64::NAN],
        None,
    )
    .unwrap_err();
    assert!(
        matches!(e, VolumeError::ControlValue { attribute: 0, .. }),
        "{e}"
    );
    let vol = quarter_shell(1.0, 2.0, 1.0, 1.0, 0.5);
    assert!(matches!(
        vol.point(&[0.5, f64::NAN, 0.0]),
        Err(VolumeError::ParamNotFinite { direction: 1, .. })
    ));
    assert!(matches!(
        vol.point(&[0.5]),
        Err(VolumeError::ParamCount { got: 1, need: 3 })
    ));
    assert!(matches!(
        vol.derivatives(&[0.5, 0.5, 0.5], 3),
        Err(VolumeError::DerivativeOrder { .. })
    ));
    assert!(matches!(
        vol.insert_knot(0, 2.0, 1),
        Err(VolumeError::Insertion { direction: 0, .. })
    ));
    assert!(matches!(
        vol.elevate_degree(3, 1),
        Err(VolumeError::NoSuchDirection { got: 3, .. })
    ));
    assert!(matches!(
        vol.elevate_degree(0, 8),
        Err(VolumeError::ElevationTooHigh { .. })
    ));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Any text: an error or a volume, never a panic.
    #[test]
    fn reader_never_panics_on_arbitrary_text(text in ".{0,400}") {
        let _ = Volume::from_json(&text);
    }

    /// A valid file with one number replaced by anything: an error or a volume that
    /// writes back and reads again, never a panic.
    #[test]
    fn reader_never_panics_on_mutated_files(pos in 0usize..2000, junk in "[-0-9.eE\\[\\],\"a-z]{0,6}") {
        let text = shell_json().to_string();
        let cut = pos.min(text.len());
        let cut = (0..=cut).rev().find(|&i| text.is_char_boundary(i)).unwrap_or(0);
        let end = (cut + junk.len().min(3)).min(text.len());
        let end = (end..=text.len()).find(|&i| text.is_char_boundary(i)).unwrap_or(text.len());
        let mutated = format!("{}{}{}", &text[..cut], junk, &text[end..]);
        if let Ok(v) = Volume::from_json(&mutated) {
            let again = Volume::from_json(&v.to_json());
            prop_assert!(again.is_ok());
        }
    }

    /// Random valid volumes of every shape round-trip through the file format.
    #[test]
    fn random_volumes_round_trip(seed in any::<u64>(), n in 1usize..=4, k in 1usize..=5) {
        let mut rng = Rng(seed | 1);
        let degrees: Vec<usize> = (0..n).map(|d| 1 + (seed as usize >> (3 * d)) % 3).collect();
        let extra: Vec<usize> = (0..n).map(|d| (seed as usize >> (2 * d + 9)) % 3).collect();
        let vol = build(&random_spec(&mut rng, &degrees, &extra, k));
        let back = Volume::from_json(&vol.to_json()).unwrap();
        prop_assert_eq!(back.degrees(), vol.degrees());
        prop_assert_eq!(back.counts(), vol.counts());
        let u = random_params(&mut rng, &vol);
        let (a, b) = (vol.point(&u).unwrap(), back.point(&u).unwrap());
        for (x, y) in a.iter().zip(&b) {
            prop_assert!((x - y).abs() <= VOLUME_EVAL_REL * scale(&a));
        }
    }
}

// ---------------------------------------------------------------------------------
// Analysis (Park 2005, sec. 4).
// ---------------------------------------------------------------------------------

/// The quarter shell with attributes `F = M x + b` (a linear vector field) and
/// `f = a . x + c`: the rational map reproduces them exactly (partition of unity), so
/// their physical derivatives are known everywhere.
fn shell_with_linear_fields() -> (Volume, [[f64; 3]; 3], [f64; 3]) {
    let m = [[0.3, -1.2, 0.5], [2.0, 0.1, -0.7], [0.4, 0.9, -0.6]];
    let a = [1.5, -0.5, 2.25];
    let base = quarter_shell(1.0, 2.0, 1.5, 0.0, 0.0);
    let mut values = Vec::new();
    let mut weights = Vec::new();
    for i in 0..base.point_count() {
        let p = base.control_values(i);
        let f: Vec<f64> = (0..3)
            .map(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + 0.1 * r as f64)
            .collect();
        values.extend([
            p[0],
            p[1],
            p[2],
            f[0],
            f[1],
            f[2],
            a[0] * p[0] + a[1] * p[1] + a[2] * p[2] - 1.0,
        ]);
        weights.push(base.weight(i));
    }
    let vol = rebuild(
        &base,
        &["x", "y", "z", "fx", "fy", "fz", "f"],
        values,
        weights,
    );
    (vol, m, a)
}

#[test]
fn gradient_divergence_and_curl_of_linear_fields_are_exact_in_curved_geometry() {
    let (vol, m, a) = shell_with_linear_fields();
    let mut rng = Rng(0xA7A1_0033);
    for _ in 0..20 {
        let u = random_params(&mut rng, &vol);
        let g = vol.gradient(&u, 6).unwrap();
        assert_near!(g.to_array(), a, VOLUME_EVAL_REL * 10.0, "grad f at {u:?}");
        let vd = vol.vector_derivatives(&u, [3, 4, 5]).unwrap();
        assert_near!(vd.gradient, m, VOLUME_EVAL_REL * 10.0, "grad F at {u:?}");
        assert_near!(
            vd.divergence,
            m[0][0] + m[1][1] + m[2][2],
            VOLUME_EVAL_REL * 10.0
        );
        let curl = [m[2][1] - m[1][2], m[0][2] - m[2][0], m[1][0] - m[0][1]];
        assert_near!(vd.curl.to_array(), curl, VOLUME_EVAL_REL * 10.0);
        // The frame: contravariant vectors are dual to covariant ones, g^ij = (g_ij)^-1.
        let f = vol.frame(&u).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let want = if i == j { 1.0 } else { 0.0 };
                assert_near!(
                    f.covariant[i].dot(f.contravariant[j]),
                    want,
                    VOLUME_EVAL_REL * 10.0
                );
                let gg: f64 = (0..3)
                    .map(|l| f.metric()[i][l] * f.inverse_metric()[l][j])
                    .sum();
                assert_near!(gg, want, VOLUME_EVAL_REL * 100.0);
            }
        }
        // sqrt(g) = sqrt(det g_ij) (eq. 38, both forms).
        let g_ = f.metric();
        let det = g_[0][0] * (g_[1][1] * g_[2][2] - g_[1][2] * g_[2][1])
            - g_[0][1] * (g_[1][0] * g_[2][2] - g_[1][2] * g_[2][0])
            + g_[0][2] * (g_[1][0] * g_[2][1] - g_[1][1] * g_[2][0]);
        assert_near!(f.volume_element() / det.sqrt(), 1.0, VOLUME_EVAL_REL * 10.0);
        // Arc element of the angular direction at radius r: r |dtheta/du|, and the
        // area element of a v = const surface is |B_w x B_u|.
        assert_near!(
            f.area_elements()[1],
            f.covariant[2].cross(f.covariant[0]).length(),
            0.0
        );
    }
}

/// The flux of the field `(fx, fy, fz)` out of the volume's six faces, by Gauss
/// quadrature over each face's knot spans, with the face normals `+-(B_v x B_w)` etc.
fn boundary_flux(vol: &Volume, m: usize) -> f64 {
    let rule = |d: usize| span_rule(vol.knots(d), m);
    let domain = vol.domain();
    let mut flux = 0.0;
    for d in 0..3 {
        let (e1, e2) = ((d + 1) % 3, (d + 2) % 3);
        for (end, sign) in [(domain[d].0, -1.0), (domain[d].1, 1.0)] {
            for &(s, ws) in &rule(e1) {
                for &(t, wt) in &rule(e2) {
                    let mut u = [0.0; 3];
                    u[d] = end;
                    u[e1] = s;
                    u[e2] = t;
                    let f = vol.frame(&u).unwrap();
                    let value = vol.point(&u).unwrap();
                    let field = glam::DVec3::new(value[3], value[4], value[5]);
                    // B_{e1} x B_{e2} points along +grad u_d for a right-handed map.
                    let area = f.covariant[e1].cross(f.covariant[e2]) * f.jacobian.signum();
                    flux += sign * ws * wt * field.dot(area);
                }
            }
        }
    }
    flux
}

#[test]
fn divergence_theorem_holds_on_a_curved_volume_to_quadrature_accuracy() {
    // A curved, non-linear field: the quarter shell, elevated and refined so it has
    // interior control points, with the interior geometry moved and a field whose
    // control values are a non-linear function of position.
    let (lin, _, _) = shell_with_linear_fields();
    let fine = lin
        .elevate_degree(1, 1)
        .unwrap()
        .elevate_degree(2, 2)
        .unwrap()
        .refine_knots(0, &[0.5])
        .unwrap();
    let counts = fine.counts().to_vec();
    let mut values = Vec::new();
    let mut weights = Vec::new();
    for i in 0..fine.point_count() {
        let mut p = fine.control_values(i);
        let (a, rest) = (i / (counts[1] * counts[2]), i % (counts[1] * counts[2]));
        let (b, c) = (rest / counts[2], rest % counts[2]);
        let interior =
            a > 0 && a + 1 < counts[0] && b > 0 && b + 1 < counts[1] && c > 0 && c + 1 < counts[2];
        if interior {
            p[2] += 0.15 * (a as f64 + b as f64).sin();
        }
        let (x, y, z) = (p[0], p[1], p[2]);
        p[3] = x * x - y * z;
        p[4] = (x + z).sin();
        p[5] = y * y * z + x;
        values.extend(&p[..6]);
        weights.push(fine.weight(i));
    }
    let vol = rebuild(&fine, &["x", "y", "z", "fx", "fy", "fz"], values, weights);
    // Integral of div F over the volume: div F |sqrt g|, by the same Gauss rule.
    let m = 12;
    let rules: Vec<Vec<(f64, f64)>> = (0..3).map(|d| span_rule(vol.knots(d), m)).collect();
    let mut div_integral = 0.0;
    for &(a, wa) in &rules[0] {
        for &(b, wb) in &rules[1] {
            for &(c, wc) in &rules[2] {
                let u = [a, b, c];
                let vd = vol.vector_derivatives(&u, [3, 4, 5]).unwrap();
                let f = vol.frame(&u).unwrap();
                div_integral += wa * wb * wc * vd.divergence * f.volume_element();
            }
        }
    }
    let flux = boundary_flux(&vol, m);
    assert!(
        flux.abs() > 0.1,
        "a field with no flux tests nothing: {flux}"
    );
    assert_near!(div_integral / flux, 1.0, VOLUME_QUADRATURE_REL);
}

#[test]
fn inverse_map_returns_the_parameters_and_rejects_outside_points() {
    let (vol, _, _) = shell_with_linear_fields();
    let inv = vol.inverter().unwrap();
    let mut rng = Rng(0x1_0033);
    for _ in 0..50 {
        let u = random_params(&mut rng, &vol);
        let p = vol.point(&u).unwrap();
        let got = inv.invert(glam::DVec3::new(p[0], p[1], p[2])).unwrap();
        assert_near!(
            got,
            [u[0], u[1], u[2]],
            VOLUME_INVERSE_PARAM_EPS,
            "at {u:?}"
        );
    }
    // Inside the inner radius, above the top, and on the other side of the axis.
    for q in [[0.5, 0.5, 0.5], [1.0, 1.0, 2.0], [-1.0, 1.5, 0.5]] {
        let e = inv.invert(glam::DVec3::from_array(q)).unwrap_err();
        assert!(matches!(e, VolumeError::OutsideVolume { .. }), "{e}");
    }
    // A volume without geometry has no inverse map; a collapsed one is singular.
    let field = Volume::new(
        vec![1, 1, 1],
        vec![vec![0.0, 0.0, 1.0, 1.0]; 3],
        vec!["t".into()],
        vec![1.0; 8],
        None,
    )
    .unwrap();
    assert!(matches!(
        field.inverter(),
        Err(VolumeError::NoGeometry { .. })
    ));
    let flat = Volume::new(
        vec![1, 1, 1],
        vec![vec![0.0, 0.0, 1.0, 1.0]; 3],
        ["x", "y", "z"].map(String::from).to_vec(),
        (0..8)
            .flat_map(|i| [(i >> 2) as f64, ((i >> 1) & 1) as f64, 0.0])
            .collect(),
        None,
    )
    .unwrap();
    let e = flat.frame(&[0.5, 0.25, 0.75]).unwrap_err();
    assert!(matches!(e, VolumeError::SingularJacobian { .. }), "{e}");
    assert!(e.to_string().contains("[0.5, 0.25, 0.75]"), "{e}");
}

// ---------------------------------------------------------------------------------
// Construction (Park 2005, sec. 3).
// ---------------------------------------------------------------------------------

/// The least-squares fit (sparse normal equations, preconditioned CG) against the
/// pseudo-inverse of the dense collocation matrix `N` (nalgebra's SVD), built here
/// from the kernel's one-dimensional basis rows. The samples leave a corner of the
/// domain empty, so the control points there are reached by no sample: the
/// minimum-norm least-squares solution is zero on them, and the fit must agree
/// (regression guard for the tensor-product preconditioner, whose scaling has to
/// vanish on such rows).
#[test]
fn scattered_least_squares_matches_the_dense_pseudo_inverse_with_an_empty_corner() {
    let mut rng = Rng(0x5CA7_7E2D);
    let m = 700;
    let mut params = Vec::with_capacity(m * 3);
    // Pins so the knots span [0, 1] in every direction, outside the empty corner.
    params.extend([0.0, 0.0, 0.0, 1.0, 0.5, 1.0, 0.5, 1.0, 0.0]);
    while params.len() < m * 3 {
        let u = [rng.next(), rng.next(), rng.next()];
        if u[0] > 0.6 && u[1] > 0.6 {
            continue;
        }
        params.extend(u);
    }
    let values: Vec<f64> = params
        .chunks(3)
        .flat_map(|u| [(3.0 * u[0]).sin() + u[1] * u[2], (u[0] - u[2]).exp()])
        .collect();
    let names = vec!["a".to_string(), "b".to_string()];
    let counts = [5, 5, 4];
    let vol = Volume::fit_scattered(&params, &values, names, &[2, 2, 2], &counts).unwrap();
    let total: usize = counts.iter().product();
    let n_mat = nalgebra::DMatrix::from_fn(m, total, |s, flat| {
        let u = &params[s * 3..s * 3 + 3];
        let idx = [flat / 20, flat / 4 % 5, flat % 4];
        (0..3)
            .map(|d| vol.knots(d).basis_row(u[d])[idx[d]])
            .product::<f64>()
    });
    let rhs = nalgebra::DMatrix::from_fn(m, 2, |s, c| values[s * 2 + c]);
    let reference = n_mat
        .svd(true, true)
        .solve(&rhs, sculpt_core::tolerance::SINGULAR_REL)
        .unwrap();
    let mut worst: f64 = 0.0;
    for flat in 0..total {
        let got = vol.control_values(flat);
        let want = vec![reference[(flat, 0)], reference[(flat, 1)]];
        worst = worst.max((got[0] - want[0]).abs().max((got[1] - want[1]).abs()));
        assert_near!(got, want, FIT_EPS * 100.0, "control point {flat}");
    }
    eprintln!("largest difference from the dense pseudo-inverse: {worst:e}");
    // The corner column (i1 = 4, i2 = 4) is reached by no sample: exactly zero.
    for l in 0..4 {
        assert_eq!(vol.control_values(4 * 20 + 4 * 4 + l), vec![0.0, 0.0]);
    }
}

#[test]
fn scattered_fit_reproduces_a_function_in_the_space_and_interpolates_when_underdetermined() {
    let mut rng = Rng(0xF17_0033);
    // A polynomial of degree <= 2 in each parameter lies in the quadratic spline space.
    let f = |u: &[f64]| {
        [
            u[0] * u[0] - 2.0 * u[1] * u[2],
            1.0 + u[0] * u[1] * u[2] + u[2] * u[2],
        ]
    };
    let m = 600;
    let mut params: Vec<f64> = (0..m * 3).map(|_| rng.range(-1.0, 2.0)).collect();
    // Pin the range so the knots span [-1, 2] in every direction.
    params[..3].copy_from_slice(&[-1.0, -1.0, -1.0]);
    params[3..6].copy_from_slice(&[2.0, 2.0, 2.0]);
    let values: Vec<f64> = params.chunks(3).flat_map(f).collect();
    let names = vec!["a".to_string(), "b".to_string()];
    let vol =
        Volume::fit_scattered(&params, &values, names.clone(), &[2, 2, 2], &[5, 4, 4]).unwrap();
    for _ in 0..30 {
        let u: Vec<f64> = (0..3).map(|_| rng.range(-1.0, 2.0)).collect();
        assert_near!(
            vol.point(&u).unwrap(),
            f(&u).to_vec(),
            FIT_EPS * 10.0,
            "at {u:?}"
        );
    }
    // Fewer samples (90) than control points (6^3): the minimum-norm solution passes
    // through every sample, whatever its values.
    let few = &params[..90 * 3];
    let noisy: Vec<f64> = (0..90 * 2).map(|_| rng.range(-1.0, 1.0)).collect();
    let vol = Volume::fit_scattered(few, &noisy, names.clone(), &[3, 3, 3], &[6, 6, 6]).unwrap();
    for (u, v) in few.chunks(3).zip(noisy.chunks(2)) {
        assert_near!(
            vol.point(u).unwrap(),
            v.to_vec(),
            FIT_EPS * 10.0,
            "at {u:?}"
        );
    }
    // Too few samples for one span, bad shapes and NaN are typed errors.
    let e = Volume::fit_scattered(
        &params[..10 * 3],
        &values[..20],
        names.clone(),
        &[3, 3, 3],
        &[6, 6, 6],
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            sculpt_core::volume::FitError::TooFewSamples {
                samples: 10,
                need: 64
            }
        ),
        "{e}"
    );
    let mut nan = values.clone();
    nan[7] = f64::NAN;
    let e =
        Volume::fit_scattered(&params, &nan, names.clone(), &[2, 2, 2], &[5, 4, 4]).unwrap_err();
    assert!(
        matches!(e, sculpt_core::volume::FitError::NotFinite { sample: 3 }),
        "{e}"
    );
    let e = Volume::fit_scattered(&params, &values, names, &[2, 2, 2], &[2, 4, 4]).unwrap_err();
    assert!(
        matches!(
            e,
            sculpt_core::volume::FitError::CountDegree { direction: 0, .. }
        ),
        "{e}"
    );
}

/// A curvilinear grid from a known analytic map: a bent, twisted shell sector, with a
/// scalar `s` and a vector `vel` attached.
fn analytic_grid(
    dims: [usize; 3],
) -> (
    sculpt_core::volume::StructuredGrid,
    impl Fn([f64; 3]) -> [f64; 3],
) {
    let map = |a: f64, b: f64, c: f64| {
        let (th, r) = (1.2 * a, 1.0 + b);
        [
            r * th.cos(),
            r * th.sin(),
            0.8 * c + 0.1 * (2.0 * th).sin() * r,
        ]
    };
    let scalar = |p: [f64; 3]| [p[0] * p[1] + p[2], p[1], -p[0]];
    let mut points = Vec::new();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let g = |n: usize, d: usize| n as f64 / (dims[d] - 1) as f64;
                points.push(map(g(i, 0), g(j, 1), g(k, 2)));
            }
        }
    }
    let s = points.iter().map(|&p| scalar(p)[0]).collect();
    let vel = points
        .iter()
        .flat_map(|&p| [scalar(p)[1], scalar(p)[2], 0.5])
        .collect();
    let grid = sculpt_core::volume::StructuredGrid {
        dims,
        points,
        arrays: vec![
            sculpt_core::volume::PointArray {
                name: "s".into(),
                components: 1,
                values: s,
            },
            sculpt_core::volume::PointArray {
                name: "vel".into(),
                components: 3,
                values: vel,
            },
        ],
    };
    (grid, scalar)
}

#[test]
fn curvilinear_grid_written_as_vtk_interpolates_exactly_at_nodes_and_closely_between() {
    let dims = [9, 6, 5];
    let (grid, field) = analytic_grid(dims);
    for binary in [false, true] {
        let bytes = grid.to_vtk("analytic shell", binary);
        let back = sculpt_core::volume::StructuredGrid::from_vtk(&bytes).unwrap();
        assert_eq!(back, grid);
        let (vol, params) = Volume::interpolate_grid(&back, &[3, 3, 3]).unwrap();
        assert_eq!(
            vol.attributes(),
            ["x", "y", "z", "s", "vel_0", "vel_1", "vel_2"]
        );
        // Exact at every grid node (first index fastest in the grid).
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let g = i + dims[0] * (j + dims[1] * k);
                    let got = vol
                        .point(&[params[0][i], params[1][j], params[2][k]])
                        .unwrap();
                    assert_near!(
                        got[..3].to_vec(),
                        grid.points[g].to_vec(),
                        FIT_EPS,
                        "node {i} {j} {k}"
                    );
                    assert_near!(
                        got[3],
                        grid.arrays[0].values[g],
                        FIT_EPS,
                        "s at node {i} {j} {k}"
                    );
                }
            }
        }
        // Between nodes: the attribute at the parameters of a physical point (found by
        // the inverse map) is close to the analytic field there.
        let inv = vol.inverter().unwrap();
        let mut rng = Rng(0x6A1D_0033_u64.wrapping_add(binary as u64));
        let mut worst = 0.0f64;
        for _ in 0..40 {
            let u = random_params(&mut rng, &vol);
            let p = vol.point(&u).unwrap();
            let x = [p[0], p[1], p[2]];
            let back = inv.invert(glam::DVec3::from_array(x)).unwrap();
            let v = vol.point(&back).unwrap();
            worst = worst.max((v[3] - field(x)[0]).abs());
        }
        assert!(
            worst < VOLUME_GRID_INTERP_EPS,
            "worst error between nodes {worst}"
        );
    }
}

/// Regression: a value at the reader's cap, divided back out of its homogeneous
/// form `(h A) / h`, could round one ulp past the cap and make the written file
/// unreadable. The writer clamps it back.
#[test]
fn values_at_the_cap_survive_a_write_and_read_with_any_weight() {
    let cap = sculpt_core::volume::MAX_JSON_VALUE;
    for h in [3.0, 0.7, 1.1, 5.3, 0.3] {
        let vol = Volume::new(
            vec![1],
            vec![vec![0.0, 0.0, 1.0, 1.0]],
            vec!["f".into()],
            vec![cap, -cap],
            Some(vec![h, 1.0]),
        )
        .unwrap();
        let back = Volume::from_json(&vol.to_json()).unwrap();
        assert_near!(back.point(&[0.0]).unwrap()[0] / cap, 1.0, VOLUME_EVAL_REL);
    }
}
