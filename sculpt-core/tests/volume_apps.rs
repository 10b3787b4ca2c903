//! The applications of volumetric NURBS (Park 2005, sec. 5.2 to 5.4) against analytic
//! references: streamlines of a rigid rotation close, critical points of fields with
//! known zeros and linearisations, the isosurface of a sphere's distance field is a
//! watertight sphere, and the morph's end frames are its images.

// The references index by direction and attribute as the formulas do.
#![allow(clippy::needless_range_loop)]

use std::collections::HashMap;
use std::f64::consts::PI;

use glam::DVec3;
use proptest::prelude::*;
use sculpt_core::assert_near;
use sculpt_core::tolerance::{
    CRITICAL_DOUBLE_ROOT_EPS, CRITICAL_POSITION_EPS, STREAMLINE_CLOSURE_EPS, VOLUME_EVAL_REL,
};
use sculpt_core::volume::morph::{FeatureLine, FeatureLines, ImageMorph, MorphError};
use sculpt_core::volume::{
    CriticalKind, FlowField, PointArray, StreamlineEnd, StreamlineOptions, StructuredGrid, Volume,
    VolumeError,
};

/// Uniform clamped cubic knots on `[0, 1]` with `c` control points.
fn cubic_knots(c: usize) -> Vec<f64> {
    let spans = c - 3;
    let mut k = vec![0.0; 4];
    k.extend((1..spans).map(|i| i as f64 / spans as f64));
    k.extend([1.0; 4]);
    k
}

/// The Greville abscissae of those knots.
fn greville(knots: &[f64], c: usize) -> Vec<f64> {
    (0..c)
        .map(|i| (knots[i + 1] + knots[i + 2] + knots[i + 3]) / 3.0)
        .collect()
}

/// A cubic volume over `[-1, 1]^3` with `c^3` control points: the affine map of the
/// Greville points, with the interior control points moved by up to `bend` and given
/// weights `1 + rational * (..)` (so the map is curved and rational, the boundary
/// faces stay planar). The attributes are `x, y, z`, then `fields(B_I, blossom)` at
/// every control point (`B_I` the control point, `blossom` the Greville knots of the
/// point, for fields given by their blossoms).
fn curved_box(
    c: usize,
    bend: f64,
    rational: f64,
    names: &[&str],
    fields: impl Fn(DVec3, [[f64; 3]; 3]) -> Vec<f64>,
) -> Volume {
    let knots = cubic_knots(c);
    let g = greville(&knots, c);
    let mut values = Vec::new();
    let mut weights = Vec::new();
    for i in 0..c {
        for j in 0..c {
            for l in 0..c {
                let s = DVec3::new(g[i], g[j], g[l]) * 2.0 - DVec3::ONE;
                let interior = [i, j, l].iter().all(|&a| a > 0 && a < c - 1);
                let b = if interior {
                    s + bend
                        * DVec3::new(
                            (2.0 * s.y + 0.3).sin(),
                            (1.7 * s.z - 0.2).sin(),
                            (2.3 * s.x + 0.1).sin(),
                        )
                } else {
                    s
                };
                weights.push(if interior {
                    1.0 + rational * (1.3 * s.x + 2.1 * s.y - s.z).sin()
                } else {
                    1.0
                });
                let blossom = [i, j, l].map(|a| [knots[a + 1], knots[a + 2], knots[a + 3]]);
                values.extend([b.x, b.y, b.z]);
                values.extend(fields(b, blossom));
            }
        }
    }
    let mut attrs: Vec<String> = ["x", "y", "z"].map(String::from).to_vec();
    attrs.extend(names.iter().map(|s| s.to_string()));
    Volume::new(
        vec![3, 3, 3],
        vec![knots.clone(), knots.clone(), knots],
        attrs,
        values,
        Some(weights),
    )
    .unwrap()
}

/// A volume whose velocity is the affine field `m (x - x0)`: exact, since the rational
/// basis sums to one.
fn affine_flow(m: [[f64; 3]; 3], x0: DVec3) -> Volume {
    curved_box(7, 0.08, 0.2, &["vx", "vy", "vz"], |b, _| {
        let d = b - x0;
        (0..3)
            .map(|r| m[r][0] * d.x + m[r][1] * d.y + m[r][2] * d.z)
            .collect()
    })
}

const VEL: [usize; 3] = [3, 4, 5];

#[test]
fn a_rigid_rotation_orbit_closes_after_one_period() {
    // V = e_z x (x - (0.1, -0.05, 0)): rotation at unit rate about a vertical axis.
    let axis = DVec3::new(0.1, -0.05, 0.0);
    let vol = affine_flow([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]], axis);
    let inv = vol.inverter().unwrap();
    let field = FlowField::new(&vol, VEL).unwrap();
    let seed = DVec3::new(0.6, -0.05, 0.2);
    let u0 = inv.invert(seed).unwrap();
    let line = field.trace(u0, &StreamlineOptions::new(2.0 * PI)).unwrap();
    assert_eq!(line.end, StreamlineEnd::Time);
    assert_near!(line.time, 2.0 * PI, 0.0);
    assert!(line.points.len() > 20, "{} points", line.points.len());
    let last = *line.points.last().unwrap();
    assert!(
        last.distance(seed) <= STREAMLINE_CLOSURE_EPS,
        "the orbit misses its seed by {:e}",
        last.distance(seed)
    );
    // Every point lies on the circle of radius 0.5 at height 0.2.
    for p in &line.points {
        let r = (*p - axis).truncate().length();
        assert_near!(r, 0.5, STREAMLINE_CLOSURE_EPS);
        assert_near!(p.z, 0.2, STREAMLINE_CLOSURE_EPS);
    }
    // Half a period lands on the opposite side; backwards likewise.
    for t in [PI, -PI] {
        let half = field.trace(u0, &StreamlineOptions::new(t)).unwrap();
        let p = *half.points.last().unwrap();
        assert_near!(p, DVec3::new(-0.4, -0.05, 0.2), STREAMLINE_CLOSURE_EPS);
    }
}

#[test]
fn a_uniform_flow_ends_on_the_boundary_where_the_line_meets_it() {
    let vol = curved_box(6, 0.1, 0.3, &["vx", "vy", "vz"], |_, _| vec![1.0, 0.3, 0.0]);
    let inv = vol.inverter().unwrap();
    let field = FlowField::new(&vol, VEL).unwrap();
    let seed = DVec3::new(0.2, 0.1, -0.3);
    let u0 = inv.invert(seed).unwrap();
    let fwd = field.trace(u0, &StreamlineOptions::new(10.0)).unwrap();
    assert_eq!(fwd.end, StreamlineEnd::Boundary);
    assert_near!(
        *fwd.points.last().unwrap(),
        DVec3::new(1.0, 0.1 + 0.3 * 0.8, -0.3),
        STREAMLINE_CLOSURE_EPS
    );
    assert_near!(fwd.time, 0.8, STREAMLINE_CLOSURE_EPS);
    for p in &fwd.points {
        assert_near!(p.y - 0.1, 0.3 * (p.x - 0.2), STREAMLINE_CLOSURE_EPS);
    }
    let back = field.trace(u0, &StreamlineOptions::new(-10.0)).unwrap();
    assert_eq!(back.end, StreamlineEnd::Boundary);
    assert_near!(
        *back.points.last().unwrap(),
        DVec3::new(-1.0, 0.1 - 0.3 * 1.2, -0.3),
        STREAMLINE_CLOSURE_EPS
    );
    // A seed outside the volume is refused by the inverse map.
    assert!(matches!(
        inv.invert(DVec3::new(1.5, 0.0, 0.0)),
        Err(VolumeError::OutsideVolume { .. })
    ));
}

/// The single critical point of `m (x - x0)`, checked against `x0`, `m`'s
/// eigenvalues `want` and the kind.
fn check_linear(m: [[f64; 3]; 3], want: [[f64; 2]; 3], kind: CriticalKind) {
    let x0 = DVec3::new(0.3, -0.2, 0.1);
    let vol = affine_flow(m, x0);
    let cps = vol.critical_points(VEL).unwrap();
    assert_eq!(cps.len(), 1, "{cps:?}");
    let c = &cps[0];
    assert_near!(c.point, x0, CRITICAL_POSITION_EPS);
    assert_eq!(c.kind, kind, "{:?}", c.eigenvalues);
    for (got, want) in c.eigenvalues.iter().zip(want) {
        assert_near!(got[0], want[0], CRITICAL_POSITION_EPS);
        assert_near!(got[1], want[1], CRITICAL_POSITION_EPS);
    }
    // The physical velocity gradient is m itself (eqs. 46, 47).
    for r in 0..3 {
        for s in 0..3 {
            assert_near!(c.gradient[r][s], m[r][s], CRITICAL_POSITION_EPS);
        }
    }
}

#[test]
fn linear_fields_in_curved_geometry_give_saddle_node_focus_and_centre() {
    check_linear(
        [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -2.0]],
        [[-2.0, 0.0], [-1.0, 0.0], [1.0, 0.0]],
        CriticalKind::Saddle,
    );
    // A non-symmetric node: eigenvalues -1, -2, -3 (upper triangular).
    check_linear(
        [[-1.0, 0.5, 0.2], [0.0, -2.0, 0.4], [0.0, 0.0, -3.0]],
        [[-3.0, 0.0], [-2.0, 0.0], [-1.0, 0.0]],
        CriticalKind::Node,
    );
    check_linear(
        [[-0.2, -1.0, 0.0], [1.0, -0.2, 0.0], [0.0, 0.0, -0.5]],
        [[-0.5, 0.0], [-0.2, -1.0], [-0.2, 1.0]],
        CriticalKind::Focus,
    );
    check_linear(
        [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -0.5]],
        [[-0.5, 0.0], [0.0, -1.0], [0.0, 1.0]],
        CriticalKind::Center,
    );
}

/// The blossom of `(2u - 1)^2` (as a cubic) at the knots `k`: its control value.
fn blossom_square(k: [f64; 3]) -> f64 {
    let (a, b, c) = (k[0], k[1], k[2]);
    4.0 * (a * b + b * c + c * a) / 3.0 - 4.0 * (a + b + c) / 3.0 + 1.0
}

/// An affine (uncurved, non-rational) cubic box whose velocity is
/// `(x^2 - shift, -y, -z)`, exactly, through the blossom of `x^2`.
fn quadratic_flow(shift: f64) -> Volume {
    curved_box(6, 0.0, 0.0, &["vx", "vy", "vz"], |b, bl| {
        vec![blossom_square(bl[0]) - shift, -b.y, -b.z]
    })
}

#[test]
fn every_zero_of_a_quadratic_field_is_found_and_classified() {
    let vol = quadratic_flow(0.25);
    // The field is what it claims to be.
    let p = vol.point(&[0.8, 0.3, 0.6]).unwrap();
    assert_near!(p[3], p[0] * p[0] - 0.25, CRITICAL_POSITION_EPS);
    let mut cps = vol.critical_points(VEL).unwrap();
    cps.sort_by(|a, b| a.point.x.total_cmp(&b.point.x));
    assert_eq!(cps.len(), 2, "{cps:?}");
    // x = -1/2: gradient diag(-1, -1, -1), a node; x = 1/2: diag(1, -1, -1), a saddle.
    assert_near!(
        cps[0].point,
        DVec3::new(-0.5, 0.0, 0.0),
        CRITICAL_POSITION_EPS
    );
    assert_eq!(cps[0].kind, CriticalKind::Node);
    assert_near!(
        cps[1].point,
        DVec3::new(0.5, 0.0, 0.0),
        CRITICAL_POSITION_EPS
    );
    assert_eq!(cps[1].kind, CriticalKind::Saddle);
    // A double root: x^2 vanishes to second order at x = 0.
    let cps = quadratic_flow(0.0).critical_points(VEL).unwrap();
    assert_eq!(cps.len(), 1, "{cps:?}");
    assert_near!(cps[0].point, DVec3::ZERO, CRITICAL_DOUBLE_ROOT_EPS);
    assert_eq!(cps[0].kind, CriticalKind::Degenerate);
    // No zero at all: x^2 + 0.25 > 0.
    assert!(
        quadratic_flow(-0.25)
            .critical_points(VEL)
            .unwrap()
            .is_empty()
    );
}

#[test]
fn a_velocity_that_vanishes_on_a_plane_gives_degenerate_points_on_it() {
    // V = (0, 0, z): zero on the whole plane z = 0, sampled span by span.
    let vol = curved_box(5, 0.0, 0.0, &["vx", "vy", "vz"], |b, _| vec![0.0, 0.0, b.z]);
    let cps = vol.critical_points(VEL).unwrap();
    assert!(cps.len() >= 16, "{} points", cps.len());
    for c in &cps {
        assert_near!(c.point.z, 0.0, CRITICAL_POSITION_EPS);
        assert_eq!(c.kind, CriticalKind::Degenerate);
    }
}

/// A curved map of `[-1, 1]^3` for the isosurface grid.
fn bend(s: DVec3) -> DVec3 {
    let k = 0.06;
    s + k * DVec3::new(
        (PI * s.y).sin() * (1.0 - s.x * s.x),
        (PI * s.z).sin() * (1.0 - s.y * s.y),
        (PI * s.x).sin() * (1.0 - s.z * s.z),
    )
}

#[test]
fn the_isosurface_of_a_spheres_distance_field_is_a_watertight_sphere() {
    sphere_isosurface(false);
}

/// Regression guard for the orientation fix-up: a mirrored (left-handed, sqrt(g) < 0)
/// map turns the parameter-space triangles inside out unless they are flipped back.
#[test]
fn a_left_handed_map_still_gives_outward_triangles() {
    sphere_isosurface(true);
}

/// The checks of the sphere isosurface, on a right- or left-handed (`mirror`) map.
fn sphere_isosurface(mirror: bool) {
    // A curvilinear grid of a bent cube carrying the distance from c, interpolated
    // (sec. 3.2) by a cubic volume.
    let flip = if mirror {
        DVec3::new(-1.0, 1.0, 1.0)
    } else {
        DVec3::ONE
    };
    let c = DVec3::new(0.05, -0.1, 0.02) * flip;
    let r = 0.55;
    let n = 15;
    let mut points = Vec::new();
    let mut dist = Vec::new();
    for l in 0..n {
        for j in 0..n {
            for i in 0..n {
                let s =
                    DVec3::new(i as f64, j as f64, l as f64) * (2.0 / (n - 1) as f64) - DVec3::ONE;
                let p = bend(s) * flip;
                points.push(p.to_array());
                dist.push(p.distance(c));
            }
        }
    }
    let grid = StructuredGrid {
        dims: [n, n, n],
        points,
        arrays: vec![PointArray {
            name: "d".into(),
            components: 1,
            values: dist,
        }],
    };
    let (vol, _) = Volume::interpolate_grid(&grid, &[3, 3, 3]).unwrap();
    assert_eq!(vol.frame(&[0.5; 3]).unwrap().jacobian < 0.0, mirror);
    let res = 28;
    let mesh = vol.isosurface(3, r, [res; 3]).unwrap();
    assert!(
        mesh.triangles.len() > 500,
        "{} triangles",
        mesh.triangles.len()
    );

    // Watertight, by half-edges: every directed edge is used once, and so is its twin.
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    for t in &mesh.triangles {
        for e in 0..3 {
            *directed.entry((t[e], t[(e + 1) % 3])).or_default() += 1;
        }
    }
    for (&(a, b), &uses) in &directed {
        assert_eq!(uses, 1, "half-edge {a}->{b} used {uses} times");
        assert_eq!(
            directed.get(&(b, a)),
            Some(&1),
            "half-edge {a}->{b} has no twin"
        );
    }
    // A sphere: Euler characteristic 2.
    let (v, e, f) = (
        mesh.vertices.len() as i64,
        directed.len() as i64 / 2,
        mesh.triangles.len() as i64,
    );
    assert_eq!(v - e + f, 2);

    // Within half a cell of the sphere; a cell's physical size from the map's arc
    // elements.
    // Only cells near the sphere count (the map stretches near the ends, where the
    // Greville parameters bunch up).
    let mut cell = 0.0f64;
    let dom = vol.domain();
    for i in 0..=16 {
        for j in 0..=16 {
            for l in 0..=16 {
                let u: [f64; 3] = std::array::from_fn(|d| {
                    dom[d].0 + (dom[d].1 - dom[d].0) * [i, j, l][d] as f64 / 16.0
                });
                let f = vol.frame(&u).unwrap();
                if (f.point.distance(c) - r).abs() > 0.25 {
                    continue;
                }
                for d in 0..3 {
                    let width = dom[d].1 - dom[d].0;
                    cell = cell.max(f.arc_elements()[d] * width / res as f64);
                }
            }
        }
    }
    assert!(cell < 0.1, "cell {cell}");
    let mut worst = 0.0f64;
    for vtx in &mesh.vertices {
        let p = DVec3::from_array(vtx.position.map(f64::from));
        worst = worst.max((p.distance(c) - r).abs());
        // The normals point out of the sphere.
        let n = DVec3::from_array(vtx.normal.map(f64::from));
        assert!(n.dot(p - c) > 0.0);
    }
    assert!(
        worst <= cell / 2.0,
        "a vertex is {worst} off the sphere (cell {cell})"
    );
    // Outward orientation: the enclosed signed volume is positive, near 4/3 pi r^3.
    let mut volume = 0.0;
    for t in &mesh.triangles {
        let [a, b, d] =
            t.map(|i| DVec3::from_array(mesh.vertices[i as usize].position.map(f64::from)) - c);
        volume += a.dot(b.cross(d)) / 6.0;
    }
    let sphere = 4.0 / 3.0 * PI * r * r * r;
    assert!(
        (volume - sphere).abs() < 0.05 * sphere,
        "volume {volume} vs {sphere}"
    );
}

/// A deterministic RGBA image.
fn image(w: usize, h: usize, seed: u32) -> Vec<u8> {
    let mut s = seed.wrapping_mul(2_654_435_761).max(1);
    (0..w * h * 4)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            (s >> 24) as u8
        })
        .collect()
}

fn lines() -> FeatureLines {
    FeatureLines {
        lines: vec![
            FeatureLine {
                source: [[1.0, 1.0], [6.0, 2.0]],
                target: [[2.0, 0.5], [7.0, 4.0]],
            },
            FeatureLine {
                source: [[3.0, 5.0], [3.5, 1.0]],
                target: [[1.0, 4.0], [4.0, 2.0]],
            },
        ],
        ..FeatureLines::default()
    }
}

#[test]
fn morph_end_frames_equal_their_images() {
    let (w, h) = (9, 7);
    let (a, b) = (image(w, h, 1), image(w, h, 2));
    for l in [FeatureLines::default(), lines()] {
        let m = ImageMorph::new((&a, w, h), (&b, w, h), l).unwrap();
        assert!(m.frame(0.0) == a, "frame 0 differs from A");
        assert!(m.frame(1.0) == b, "the last frame differs from B");
    }
    // Without lines, the middle frame is the rounded mean of the two.
    let m = ImageMorph::new((&a, w, h), (&b, w, h), FeatureLines::default()).unwrap();
    let mid = m.frame(0.5);
    for i in 0..a.len() {
        let want = ((f64::from(a[i]) + f64::from(b[i])) / 2.0).round() as u8;
        assert_eq!(mid[i], want, "byte {i}");
    }
    // Images of different sizes are refused with both sizes named.
    let err = ImageMorph::new((&a, w, h), (&image(8, 7, 3), 8, 7), lines()).unwrap_err();
    assert!(matches!(err, MorphError::SizeMismatch { .. }));
    assert!(err.to_string().contains("9x7 and 8x7"), "{err}");
}

#[test]
fn a_feature_line_carries_a_bar_halfway_at_the_middle_frame() {
    // A bright column at x = 3 in A and at x = 6 in B, one line along each.
    let (w, h) = (10, 6);
    let bar = |x: usize| -> Vec<u8> {
        (0..w * h)
            .flat_map(|p| {
                let v = if p % w == x { 200 } else { 0 };
                [v, v, v, 255]
            })
            .collect()
    };
    let l = FeatureLines {
        lines: vec![FeatureLine {
            source: [[3.0, 0.0], [3.0, 5.0]],
            target: [[6.0, 0.0], [6.0, 5.0]],
        }],
        ..FeatureLines::default()
    };
    let m = ImageMorph::new((&bar(3), w, h), (&bar(6), w, h), l).unwrap();
    let mid = m.frame(0.5);
    let red = |x: usize, y: usize| mid[(y * w + x) * 4];
    for y in 0..h {
        // The bar sits at x = 4.5: half in columns 4 and 5, none at 3 or 6 (a plain
        // cross-dissolve would put 100 at 3 and 6).
        assert_eq!(
            [red(3, y), red(4, y), red(5, y), red(6, y)],
            [0, 100, 100, 0]
        );
    }
}

#[test]
fn bad_lines_files_get_typed_errors() {
    let ok = r#"{"format": "wandsculpt-morph-lines", "version": 1,
        "lines": [{"source": [[0, 0], [1, 0]], "target": [[0, 1], [2, 1]]}]}"#;
    let l = FeatureLines::from_json(ok).unwrap();
    assert_eq!(l.lines.len(), 1);
    assert_eq!((l.a, l.b, l.p), (1.0, 2.0, 0.5));
    let cases = [
        (ok.replace("\"version\": 1", "\"version\": 2"), "version 2"),
        (
            ok.replace("[[0, 1], [2, 1]]", "[[2, 1], [2, 1]]"),
            "line 0, target",
        ),
        (
            ok.replace("\"version\": 1,", "\"version\": 1, \"a\": 0,"),
            "a = 0",
        ),
        (ok.replace("\"lines\"", "\"lnes\""), "unknown field"),
        (
            ok.replace("[[0, 0], [1, 0]]", "[[0, 0], [1e300, 0]]"),
            "not finite within",
        ),
    ];
    for (text, needle) in cases {
        let err = FeatureLines::from_json(&text).unwrap_err().to_string();
        assert!(err.contains(needle), "expected '{needle}' in: {err}");
    }
}

proptest! {
    /// The lines reader never panics on arbitrary text.
    #[test]
    fn lines_reader_never_panics_on_text(text in ".{0,200}") {
        let _ = FeatureLines::from_json(&text);
    }

    /// Any line set with finite, separated ends reads back; the rest is refused with
    /// an error, never a panic.
    #[test]
    fn lines_reader_accepts_exactly_the_valid_files(
        ends in proptest::collection::vec(proptest::array::uniform8(-2e6f64..2e6), 0..5),
        a in -1.0f64..3.0,
        b in -1.0f64..9.0,
    ) {
        let lines: Vec<String> = ends
            .iter()
            .map(|e| format!(
                "{{\"source\": [[{}, {}], [{}, {}]], \"target\": [[{}, {}], [{}, {}]]}}",
                e[0], e[1], e[2], e[3], e[4], e[5], e[6], e[7]
            ))
            .collect();
        let text = format!(
            "{{\"format\": \"wandsculpt-morph-lines\", \"version\": 1, \"a\": {a}, \"b\": {b}, \"lines\": [{}]}}",
            lines.join(",")
        );
        let valid = a > 0.0
            && (0.0..=8.0).contains(&b)
            && ends.iter().all(|e| {
                e.iter().all(|v| v.abs() <= 1e6)
                    && (e[0] - e[2]).hypot(e[1] - e[3]) >= 0.001
                    && (e[4] - e[6]).hypot(e[5] - e[7]) >= 0.001
            });
        prop_assert_eq!(FeatureLines::from_json(&text).is_ok(), valid);
    }
}

#[test]
fn a_flow_keeps_only_the_attributes_it_reads() {
    // A density before the velocity and an energy after it, as flow data sets carry.
    let vol = curved_box(5, 0.1, 0.2, &["rho", "vx", "vy", "vz", "e"], |b, _| {
        vec![1.0 + b.z, -b.y, b.x, 0.0, b.x * b.y]
    });
    let keep = [0, 1, 2, 4, 5, 6];
    let picked = vol.with_attributes(&keep).unwrap();
    assert_eq!(picked.attributes(), ["x", "y", "z", "vx", "vy", "vz"]);
    for u in [[0.3, 0.6, 0.45], [0.0, 1.0, 0.2]] {
        let (a, b) = (vol.point(&u).unwrap(), picked.point(&u).unwrap());
        for (i, &c) in keep.iter().enumerate() {
            assert_near!(b[i], a[c], VOLUME_EVAL_REL);
        }
    }
    assert_eq!(
        vol.with_attributes(&[3, 3]).unwrap().attributes(),
        ["rho", "rho#2"]
    );
    assert!(vol.with_attributes(&[9]).is_err());
    // The rotation about the z axis through the origin closes with the extra attributes.
    let field = FlowField::new(&vol, [4, 5, 6]).unwrap();
    let seed = DVec3::new(0.4, 0.1, -0.2);
    let u0 = vol.inverter().unwrap().invert(seed).unwrap();
    let line = field.trace(u0, &StreamlineOptions::new(2.0 * PI)).unwrap();
    assert_near!(*line.points.last().unwrap(), seed, STREAMLINE_CLOSURE_EPS);
}
