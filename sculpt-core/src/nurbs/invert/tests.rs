//! Unit tests of the surface inverter: against exhaustive search, dense sampling and
//! known closest points, and the bounds of the tree walk.

use super::hierarchy::{MAX_LEAVES, STACK_LEN};
use super::*;
use crate::nurbs::NurbsSurface;
use crate::tolerance::{EXACT_EPS, FIT_EPS, INVERSION_EPS, POINT_EPS, within};

/// SplitMix64, so the stress test needs no extra crates.
struct Rng(u64);
impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn in_range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.unit()
    }
}

/// A wavy patch of degree 2 or 3 with random interior knots, random heights, and
/// random weights when `rational`.
fn wavy(rng: &mut Rng, rational: bool) -> NurbsSurface {
    let degree = |rng: &mut Rng| if rng.unit() < 0.5 { 2 } else { 3 };
    let (p, q) = (degree(rng), degree(rng));
    let count = |rng: &mut Rng, d: usize| d + 1 + (rng.unit() * 5.0) as usize;
    let (nu, nv) = (count(rng, p), count(rng, q));
    let knots = |rng: &mut Rng, d: usize, n: usize| {
        let mut inner: Vec<f64> = (0..n - d - 1).map(|_| rng.in_range(0.05, 0.95)).collect();
        inner.sort_by(f64::total_cmp);
        let mut k = vec![0.0; d + 1];
        k.extend(inner);
        k.extend(vec![1.0; d + 1]);
        k
    };
    let (ku, kv) = (knots(rng, p, nu), knots(rng, q, nv));
    let net = (0..nu)
        .map(|i| {
            (0..nv)
                .map(|j| {
                    let jitter =
                        DVec3::new(rng.in_range(-0.05, 0.05), rng.in_range(-0.05, 0.05), 0.0);
                    DVec3::new(
                        i as f64 / (nu - 1) as f64,
                        j as f64 / (nv - 1) as f64,
                        rng.in_range(-0.4, 0.4),
                    ) + jitter
                })
                .collect()
        })
        .collect();
    let weights = rational.then(|| {
        (0..nu)
            .map(|_| (0..nv).map(|_| rng.in_range(0.4, 2.5)).collect())
            .collect()
    });
    NurbsSurface::new(p, q, ku, kv, net, weights).expect("valid surface")
}

/// Query points where pruning is riskiest: just off the surface at leaf borders and
/// corners (several leaves tie on their bounds), just outside the domain edges and
/// corners (edge runs, side boxes), anywhere around the patch, and far away.
fn hard_query(rng: &mut Rng, s: &NurbsSurface, inv: &SurfaceInverter) -> DVec3 {
    let leaf = &inv.leaves[(rng.unit() * inv.leaves.len() as f64) as usize];
    let pick = |rng: &mut Rng, k: usize| match (rng.unit() * 3.0) as u32 {
        0 => leaf.uv_lo[k],
        1 => leaf.uv_hi[k],
        _ => rng.in_range(leaf.uv_lo[k], leaf.uv_hi[k]),
    };
    let uv = DVec2::new(pick(rng, 0), pick(rng, 1))
        + DVec2::new(rng.in_range(-1e-7, 1e-7), rng.in_range(-1e-7, 1e-7)); // not a tolerance: a random perturbation of the query
    let uv = s.clamp_uv(uv);
    let d = s.derivatives(uv.x, uv.y);
    let n = s.normal(uv.x, uv.y);
    match (rng.unit() * 5.0) as u32 {
        0 => d.point + n * rng.in_range(-1e-6, 1e-6), // not a tolerance: a random offset of the query
        1 => d.point + n * rng.in_range(-0.3, 0.3),
        2 => {
            // Beyond the domain edge the point lies on, or beside it.
            let out = DVec2::new(
                if uv.x <= 0.0 {
                    -1.0
                } else if uv.x >= 1.0 {
                    1.0
                } else {
                    0.0
                },
                if uv.y <= 0.0 {
                    -1.0
                } else if uv.y >= 1.0 {
                    1.0
                } else {
                    0.0
                },
            );
            let tangent = d.du.normalize_or_zero() * out.x + d.dv.normalize_or_zero() * out.y;
            d.point + tangent * rng.in_range(0.0, 0.3) + n * rng.in_range(-0.2, 0.2)
        }
        3 => DVec3::new(
            rng.in_range(-0.6, 1.6),
            rng.in_range(-0.6, 1.6),
            rng.in_range(-0.8, 0.8),
        ),
        _ => {
            let dir = DVec3::new(
                rng.in_range(-1.0, 1.0),
                rng.in_range(-1.0, 1.0),
                rng.in_range(-1.0, 1.0),
            );
            DVec3::splat(0.5) + dir.normalize_or(DVec3::Z) * rng.in_range(3.0, 300.0)
        }
    }
}

/// Regression for the pruned search (leaf-corner bounds, nearest-bound-first order
/// with its early stop, side boxes that skip edge runs) and for seeded queries: on
/// 9,600 hard queries neither may ever be farther than the unpruned reference that
/// runs Newton in every leaf and along every domain edge. (An earlier attempt to skip
/// the sub-patch holding the seed failed once in 9,600 such queries.)
/// The piecewise bilinear surface through a grid, with uniform clamped knots.
fn degree_one(pts: Vec<Vec<DVec3>>) -> NurbsSurface {
    let knots = |n: usize| {
        let mut k = vec![0.0];
        k.extend((0..n).map(|i| i as f64 / (n - 1) as f64));
        k.push(1.0);
        k
    };
    let (nu, nv) = (pts.len(), pts[0].len());
    NurbsSurface::new(1, 1, knots(nu), knots(nv), pts, None).expect("valid grid")
}

/// Regression: a surface with more Bezier patches than `MAX_LEAVES` hung the build
/// (the leaf size kept doubling while every patch was already one leaf).
#[test]
fn more_patches_than_the_leaf_cap_build_and_invert() {
    let n = 130; // 129 x 129 = 16,641 bilinear patches
    let pts: Vec<Vec<DVec3>> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| {
                    let (x, y) = (i as f64 / (n - 1) as f64, j as f64 / (n - 1) as f64);
                    DVec3::new(x, y, 0.05 * (9.0 * x).sin() * (7.0 * y).cos())
                })
                .collect()
        })
        .collect();
    let s = degree_one(pts);
    let inv = s.inverter();
    assert!(inv.leaf_count() > MAX_LEAVES);
    for (u, v) in [(0.1, 0.2), (0.5, 0.5), (0.93, 0.71)] {
        let on = s.point(u, v);
        let pr = inv.closest_point(on + DVec3::Z * 0.001);
        assert!(pr.distance <= 0.001 + EXACT_EPS, "{pr:?}");
    }
}

/// The walks' fixed stacks hold one entry per tree level plus one: the deepest
/// trees (a long strip, and a grid at the leaf cap) must fit, or a dropped push would
/// skip part of the surface.
#[test]
fn the_deepest_trees_fit_the_walk_stacks() {
    fn depth(inv: &SurfaceInverter, entry: u32) -> usize {
        if entry & LEAF != 0 {
            return 0;
        }
        let node = inv.nodes[entry as usize];
        1 + depth(inv, node.child[0]).max(depth(inv, node.child[1]))
    }
    for (nu, nv) in [(2000, 2), (130, 130)] {
        let pts: Vec<Vec<DVec3>> = (0..nu)
            .map(|i| {
                (0..nv)
                    .map(|j| DVec3::new(i as f64, j as f64, ((i * j) % 3) as f64))
                    .collect()
            })
            .collect();
        let inv = degree_one(pts).inverter();
        let d = depth(&inv, inv.root);
        // A balanced bisection: at most two levels over log2 of the leaf count.
        let balanced = inv.leaf_count().next_power_of_two().ilog2() as usize + 2;
        assert!(d <= balanced, "depth {d}, {} leaves", inv.leaf_count());
        assert!(d < STACK_LEN, "depth {d}");
    }
}

/// Each answer says how it was obtained: proven on an ordinary patch, and the exit
/// by name where the certificate cannot run (degree 6 has no nets) or was not asked
/// for (local Newton, a non-finite query).
#[test]
fn answers_name_their_certificate() {
    let mut rng = Rng(0x5EED_0014);
    let s = wavy(&mut rng, true);
    let inv = s.inverter();
    let p = DVec3::new(0.4, 0.6, 0.3);
    assert_eq!(inv.closest_point(p).certificate, Certificate::Certified);
    let seeded = inv.closest_point_from(p, DVec2::new(0.9, 0.1));
    assert_eq!(seeded.certificate, Certificate::Certified);
    let local = inv.newton_from(p, DVec2::new(0.9, 0.1));
    assert_eq!(local.certificate, Certificate::Local);
    // The surface's own Newton, without the hierarchy, lands on the same point
    // (the built inverter evaluates through its power form: last bits differ).
    let own = s.newton_closest(p, DVec2::new(0.9, 0.1));
    assert_eq!(own.certificate, Certificate::Local);
    assert!(
        own.uv_in_knots.distance(local.uv_in_knots) < FIT_EPS,
        "{own:?} {local:?}"
    );
    assert!((own.distance - local.distance).abs() < FIT_EPS);
    let bad = inv.closest_point(DVec3::new(f64::NAN, 0.0, 0.0));
    assert_eq!(bad.certificate, Certificate::InvalidQuery);
    // Degree 6 along u: nets of side 13 exceed MAX_SIDE.
    let row = |x: f64| vec![DVec3::new(x, 0.0, 0.0), DVec3::new(x, 1.0, 0.1)];
    let net: Vec<Vec<DVec3>> = (0..7).map(|i| row(i as f64 / 6.0)).collect();
    let mut ku = vec![0.0; 7];
    ku.extend([1.0; 7]);
    let sextic =
        NurbsSurface::new(6, 1, ku, vec![0.0, 0.0, 1.0, 1.0], net, None).expect("valid surface");
    let pr = sextic.inverter().closest_point(p);
    assert_eq!(pr.certificate, Certificate::DegreeAboveFive);
    assert!(pr.converged);
}

#[test]
fn pruned_search_never_loses_to_the_exhaustive_reference() {
    let mut rng = Rng(0x5EED_2026);
    let mut checked = 0;
    for k in 0..40 {
        let s = wavy(&mut rng, k % 2 == 1);
        let inv = s.inverter();
        for _ in 0..240 {
            let p = hard_query(&mut rng, &s, &inv);
            let reference = inv.closest_point_exhaustive(p);
            let got = inv.closest_point(p);
            assert!(
                within(got.distance - reference.distance, POINT_EPS),
                "surface {k}, p = {p:?}: pruned {got:?} vs exhaustive {reference:?}"
            );
            assert!(got.converged, "surface {k}, p = {p:?}: {got:?}");
            let seed = DVec2::new(rng.unit(), rng.unit());
            let seeded = inv.closest_point_from(p, seed);
            assert!(
                within(seeded.distance - reference.distance, POINT_EPS),
                "surface {k}, p = {p:?}, seed {seed:?}: {seeded:?} vs {reference:?}"
            );
            // Seeded from the answer itself (a stroke that stands still).
            let again = inv.closest_point_from(p, got.uv_in_knots);
            assert!(within(again.distance - reference.distance, POINT_EPS));
            checked += 1;
        }
    }
    assert_eq!(checked, 9_600);
}

/// The certificate on its own: started from the farther of two local minima in one
/// sub-patch (the answer a single Newton run gave before the certificate existed),
/// it must find the closer one. Surfaces and queries from the brute-force stress
/// (`tests/nurbs_inversion.rs`, seeds `0x5EED_7777` and `0x5EED_8888`).
#[test]
fn the_certificate_finds_the_closer_of_two_minima_in_one_sub_patch() {
    let cases = [
        (
            include_str!("../../../tests/data/two-minima-7777.json"),
            DVec3::new(0.14254816814439428, 0.7308498353856546, -0.405004002983505),
            DVec2::new(0.029900237998824058, 0.6363834357135493),
            0.18909275928916175,
        ),
        (
            include_str!("../../../tests/data/two-minima-8888.json"),
            DVec3::new(0.5125582972693886, 0.530029542421877, 0.006136924500610902),
            DVec2::new(0.41903973422145674, 0.26001628760683676),
            0.0938234741809953,
        ),
    ];
    for (json, p, wrong_uv, brute_force) in cases {
        let s = NurbsSurface::from_json(json).expect("valid surface");
        let inv = s.inverter();
        let wrong = inv.newton(p, wrong_uv, inv.domain_lo, inv.domain_hi, inv.closed);
        assert!(wrong.converged && wrong.dist2.sqrt() > brute_force + INVERSION_EPS);
        let mut visited = Visited::new();
        visited.overflow = true;
        let (fixed, _) = inv.certify(p, wrong, &visited);
        assert!(
            fixed.dist2.sqrt() <= brute_force + POINT_EPS,
            "{} vs brute force {brute_force}",
            fixed.dist2.sqrt()
        );
    }
}
