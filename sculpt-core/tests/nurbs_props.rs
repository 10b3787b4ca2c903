//! Property tests: partition of unity, non-negativity, affine invariance, and the JSON
//! reader never panicking on arbitrary input.

use glam::{DMat3, DVec3};
use proptest::prelude::*;
use sculpt_core::assert_near;
use sculpt_core::nurbs::{KnotVector, NurbsSurface};
use sculpt_core::tolerance::{CONVERSION_REL, SUM_EPS, ULP_EPS};

/// A random valid knot vector: degree 1..=5, clamped or not, with repeated knots.
fn knot_vector() -> impl Strategy<Value = KnotVector> {
    (
        1usize..=5,
        0usize..6,
        any::<bool>(),
        proptest::collection::vec(0.0f64..1.0, 0..8),
    )
        .prop_filter_map("valid", |(p, extra, clamped, mut inner)| {
            inner.truncate(extra + 1);
            inner.sort_by(f64::total_cmp);
            // Repeat some knots (up to the degree).
            let mut k: Vec<f64> = Vec::new();
            for (i, x) in inner.iter().enumerate() {
                for _ in 0..=(i % p) {
                    k.push(*x);
                }
            }
            let mut knots = if clamped {
                vec![0.0; p + 1]
            } else {
                (0..=p).map(|i| -1.0 + i as f64 * 0.1).collect()
            };
            knots.extend(k);
            if clamped {
                knots.extend(vec![1.0; p + 1]);
            } else {
                knots.extend((0..=p).map(|i| 1.0 + i as f64 * 0.1));
            }
            KnotVector::new(p, knots).ok()
        })
}

proptest! {
    #[test]
    fn basis_is_a_partition_of_unity_and_non_negative(kv in knot_vector(), t in 0.0f64..=1.0) {
        let (a, b) = kv.domain();
        let u = a + (b - a) * t;
        let s = kv.find_span(u);
        let n = kv.basis(s, u);
        let p = kv.degree();
        prop_assert!(n[..=p].iter().all(|&x| x >= -ULP_EPS), "{n:?}");
        assert_near!(n[..=p].iter().sum::<f64>(), 1.0, SUM_EPS);
        // Derivatives of a partition of unity sum to zero.
        let d = kv.basis_ders2(s, u);
        let scale = 1.0 + d[1][..=p].iter().map(|x| x.abs()).sum::<f64>();
        assert_near!(d[1][..=p].iter().sum::<f64>(), 0.0, CONVERSION_REL * scale);
        let row = kv.basis_row(u);
        assert_near!(row.iter().sum::<f64>(), 1.0, SUM_EPS);
    }

    #[test]
    fn surfaces_are_affine_invariant(
        heights in proptest::collection::vec(-1.0f64..1.0, 16),
        weights in proptest::collection::vec(0.2f64..3.0, 16),
        m in proptest::array::uniform9(-2.0f64..2.0),
        shift in proptest::array::uniform3(-5.0f64..5.0),
        u in 0.0f64..=1.0, v in 0.0f64..=1.0,
    ) {
        let pts: Vec<Vec<DVec3>> = (0..4).map(|i| (0..4).map(|j| DVec3::new(i as f64, j as f64, heights[i * 4 + j])).collect()).collect();
        let w: Vec<Vec<f64>> = (0..4).map(|i| weights[i * 4..i * 4 + 4].to_vec()).collect();
        let k = vec![0., 0., 0., 0., 1., 1., 1., 1.];
        let s = NurbsSurface::new(3, 3, k.clone(), k.clone(), pts.clone(), Some(w.clone())).unwrap();
        let a = DMat3::from_cols_array(&m);
        let t = DVec3::from_array(shift);
        let moved: Vec<Vec<DVec3>> = pts.iter().map(|r| r.iter().map(|p| a * *p + t).collect()).collect();
        let s2 = NurbsSurface::new(3, 3, k.clone(), k, moved, Some(w)).unwrap();
        let want = a * s.point(u, v) + t;
        assert_near!(s2.point(u, v).to_array(), want.to_array(), CONVERSION_REL * (1.0 + want.abs().max_element()));
    }

    #[test]
    fn json_reader_never_panics(text in "\\PC{0,200}") {
        let _ = NurbsSurface::from_json(&text);
    }

    #[test]
    fn json_reader_survives_mutations(pos in 0usize..400, byte in any::<u8>(), cut in 0usize..400) {
        let base = r#"{"degree_u":2,"degree_v":1,"knots_u":[0,0,0,1,1,1],"knots_v":[0,0,1,1],"control_points":[[[0,0,0],[0,1,0]],[[1,0,1],[1,1,1]],[[2,0,0],[2,1,0]]],"weights":[[1,1],[0.5,2],[1,1]]}"#;
        let mut bytes = base.as_bytes().to_vec();
        let i = pos % bytes.len();
        bytes[i] = byte;
        bytes.truncate(bytes.len() - cut % 50);
        if let Ok(text) = String::from_utf8(bytes)
            && let Ok(s) = NurbsSurface::from_json(&text) {
                // Anything accepted evaluates to finite points.
                prop_assert!(s.point(0.5, 0.5).is_finite());
                prop_assert!(s.inverter().closest_point(DVec3::ONE).distance.is_finite());
            }
    }
}
