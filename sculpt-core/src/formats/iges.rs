//! IGES 5.3 export of NURBS surfaces: rational B-spline surfaces (entity 128), and
//! trimmed surfaces (entity 144) whose boundaries are curves on the surface (entity 142)
//! given by parameter-space B-spline curves (entity 126).
//!
//! The file has the five fixed-column sections (Start, Global, Directory Entry,
//! Parameter Data, Terminate), 80 columns per line, units metres. A sculpted target is
//! written as one 144 per visible face (the domain minus the strokes' footprints), each
//! with its outer loop and holes as degree-1 parameter-space curves; stroke surfaces are
//! written as plain 128 entities. [`read`] parses the entities back for checking.
//!
//! Loops are cleaned before writing (repeated points and an explicit closing point
//! dropped, loops enclosing no area skipped) and oriented as readers expect: outer
//! counter-clockwise, holes clockwise in parameter space. Parameter-space curves carry
//! entity use flag 05 (2D parametric). The files are checked by an independent CAD
//! kernel, OpenCASCADE, in `tests/tests/iges_occt.rs` (see `tools/occt-iges-check/`).
//!
//! ```
//! use glam::DVec3;
//! use sculpt_core::formats::iges::{self, IgesSurface, NurbsPatch};
//! let patch = NurbsPatch {
//!     degree_u: 1, degree_v: 1,
//!     knots_u: vec![0.0, 0.0, 1.0, 1.0], knots_v: vec![0.0, 0.0, 1.0, 1.0],
//!     control_points: vec![vec![DVec3::ZERO, DVec3::Y], vec![DVec3::X, DVec3::ONE]],
//!     weights: None,
//! };
//! let bytes = iges::write(&[IgesSurface { name: "plane".into(), patch: patch.clone(), faces: None }])?;
//! let model = iges::read(&bytes)?;
//! assert_eq!(model.surfaces[0], patch);
//! # Ok::<(), sculpt_core::Error>(())
//! ```

use crate::Result;
use crate::error::{Error, Excerpt, FileFormat, FormatError, WrittenValue};
use glam::{DVec2, DVec3};

/// A NURBS surface in the kernel's JSON layout: `control_points[i][j]` with `i` along u.
#[derive(Debug, Clone, PartialEq)]
pub struct NurbsPatch {
    /// Degree in u.
    pub degree_u: usize,
    /// Degree in v.
    pub degree_v: usize,
    /// Clamped knot vector in u.
    pub knots_u: Vec<f64>,
    /// Clamped knot vector in v.
    pub knots_v: Vec<f64>,
    /// Control net, `[i][j]`.
    pub control_points: Vec<Vec<DVec3>>,
    /// Weights `[i][j]`; `None` means all 1 (polynomial).
    pub weights: Option<Vec<Vec<f64>>>,
}

impl NurbsPatch {
    /// The parameter domain `[(u0, v0), (u1, v1)]` of the clamped knots.
    pub fn domain(&self) -> (DVec2, DVec2) {
        let (p, q) = (self.degree_u, self.degree_v);
        let ku = |i: usize| self.knots_u.get(i).copied().unwrap_or(0.0);
        let kv = |i: usize| self.knots_v.get(i).copied().unwrap_or(0.0);
        (
            DVec2::new(ku(p), kv(q)),
            DVec2::new(
                ku(self.knots_u.len().saturating_sub(p + 1)),
                kv(self.knots_v.len().saturating_sub(q + 1)),
            ),
        )
    }
}

/// One visible face of a trimmed surface, in normalised `[0, 1]^2` parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct Face {
    /// Outer loop (written counter-clockwise, whichever way it is given).
    pub outer: Vec<DVec2>,
    /// Holes (written clockwise).
    pub holes: Vec<Vec<DVec2>>,
}

/// A surface to export: untrimmed when `faces` is `None`, otherwise one entity 144 per
/// face.
#[derive(Debug, Clone, PartialEq)]
pub struct IgesSurface {
    /// Entity label (up to 8 characters are written).
    pub name: String,
    /// The surface.
    pub patch: NurbsPatch,
    /// Visible faces, or `None` for the whole surface.
    pub faces: Option<Vec<Face>>,
}

/// What [`read`] found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct IgesModel {
    /// Every entity 128, in file order.
    pub surfaces: Vec<NurbsPatch>,
    /// For every entity 144: the index in `surfaces` of its base surface and its number
    /// of boundary loops (outer plus holes).
    pub trimmed: Vec<(usize, usize)>,
    /// For every entity 126: its control points (x, y, z).
    pub curves: Vec<Vec<DVec3>>,
}

// Directory-entry status numbers (IGES 5.3 section 2.2.4.3.9): blank, subordinate,
// entity use, hierarchy, two digits each.

/// An independent geometry entity (a root: untrimmed 128, trimmed 144).
const STATUS_INDEPENDENT: &str = "00000000";
/// Physically dependent geometry (a 128 under its 144, a 142 under its 144).
const STATUS_DEPENDENT: &str = "00010000";
/// Physically dependent, entity use 05 "2D parametric": a boundary curve in a surface's
/// parameter space (the 126 under a 142).
const STATUS_PARAMETRIC: &str = "00010500";

struct Entity {
    kind: u32,
    form: u32,
    status: &'static str,
    label: String,
    params: Vec<String>,
}

fn err(reason: FormatError) -> Error {
    super::err(FileFormat::Iges, reason)
}

/// Checks that every number of a surface the writer writes (knots, weights, control
/// points) is finite.
fn check_patch(surface: usize, p: &NurbsPatch) -> Result<()> {
    let bad = |what, index| {
        err(FormatError::SurfaceNonFinite {
            surface,
            what,
            index,
        })
    };
    if let Some(k) = p
        .knots_u
        .iter()
        .chain(&p.knots_v)
        .position(|k| !k.is_finite())
    {
        return Err(bad(WrittenValue::Knot, k));
    }
    let rows = p.control_points.first().map_or(0, Vec::len);
    for (i, row) in p.control_points.iter().enumerate() {
        if let Some(j) = row.iter().position(|c| !c.is_finite()) {
            return Err(bad(WrittenValue::ControlPoint, i * rows + j));
        }
    }
    for (i, row) in p.weights.iter().flatten().enumerate() {
        if let Some(j) = row.iter().position(|w| !w.is_finite()) {
            return Err(bad(WrittenValue::Weight, i * rows + j));
        }
    }
    Ok(())
}

/// A real in IGES form: shortest round-trip digits, always with a decimal point before
/// the exponent (IGES 5.3 section 2.2.2.2: `1.E0`, `-2.5E-3`, never `1E0`).
fn real(x: f64) -> String {
    let x = if x.is_finite() { x } else { 0.0 };
    let s = format!("{x:E}");
    match s.split_once('E') {
        Some((mantissa, exp)) if !mantissa.contains('.') => format!("{mantissa}.E{exp}"),
        _ => s,
    }
}

/// A trimming loop ready to write: consecutive repeated points and an explicit closing
/// point dropped (each would be a zero-length span of the degree-1 curve), and turned
/// to the orientation IGES readers expect of a face's boundary in parameter space:
/// counter-clockwise for the outer loop, clockwise for holes. `None` when fewer than
/// three distinct points remain or they enclose no area.
fn clean_loop(points: &[DVec2], outer: bool) -> Option<Vec<DVec2>> {
    let mut pts: Vec<DVec2> = Vec::with_capacity(points.len());
    for &p in points {
        if !p.is_finite() {
            return None;
        }
        if pts.last() != Some(&p) {
            pts.push(p);
        }
    }
    while pts.len() > 1 && pts.first() == pts.last() {
        pts.pop();
    }
    if pts.len() < 3 {
        return None;
    }
    let twice_area: f64 = (0..pts.len())
        .map(|k| pts[k].perp_dot(pts[(k + 1) % pts.len()]))
        .sum();
    // Collinear points enclose no area; rounding leaves a tiny one of either sign.
    let (lo, hi) = pts
        .iter()
        .fold((pts[0], pts[0]), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let size = (hi - lo).max_element();
    if twice_area.is_nan() || twice_area.abs() <= crate::tolerance::COLLINEAR_AREA_REL * size * size
    {
        return None;
    }
    if (twice_area > 0.0) != outer {
        pts.reverse();
    }
    Some(pts)
}

fn patch_params(p: &NurbsPatch, out: &mut Vec<String>) {
    let (nu, nv) = (
        p.control_points.len(),
        p.control_points.first().map_or(0, Vec::len),
    );
    let rational = p.weights.is_some();
    out.extend(
        [
            128,
            nu as i64 - 1,
            nv as i64 - 1,
            p.degree_u as i64,
            p.degree_v as i64,
            0,
            0,
        ]
        .iter()
        .map(i64::to_string),
    );
    out.push(if rational { "0" } else { "1" }.into());
    out.extend(["0".into(), "0".into()]);
    out.extend(p.knots_u.iter().map(|&k| real(k)));
    out.extend(p.knots_v.iter().map(|&k| real(k)));
    for j in 0..nv {
        for i in 0..nu {
            let w = p
                .weights
                .as_ref()
                .and_then(|w| w.get(i)?.get(j).copied())
                .unwrap_or(1.0);
            out.push(real(w));
        }
    }
    for j in 0..nv {
        for i in 0..nu {
            let c = p.control_points[i].get(j).copied().unwrap_or_default();
            out.extend([real(c.x), real(c.y), real(c.z)]);
        }
    }
    let (lo, hi) = p.domain();
    out.extend([real(lo.x), real(hi.x), real(lo.y), real(hi.y)]);
}

fn loop_params(points: &[DVec2], out: &mut Vec<String>) {
    // A closed degree-1 B-spline through the loop's points (first repeated last).
    let mut pts = points.to_vec();
    if let Some(&first) = points.first() {
        pts.push(first);
    }
    let k = pts.len() - 1;
    out.extend([
        "126".into(),
        k.to_string(),
        "1".into(),
        "1".into(),
        "1".into(),
        "1".into(),
        "0".into(),
    ]);
    out.push(real(0.0));
    for t in 0..=k {
        out.push(real(t as f64));
    }
    out.push(real(k as f64));
    out.extend((0..=k).map(|_| real(1.0)));
    for p in &pts {
        out.extend([real(p.x), real(p.y), real(0.0)]);
    }
    out.extend([real(0.0), real(k as f64), real(0.0), real(0.0), real(1.0)]);
}

/// Writes an IGES 5.3 file with the given surfaces. A knot, weight or control point
/// that is NaN or infinite is an error ([`FormatError::SurfaceNonFinite`]) and nothing
/// is written; trimming loop points that are not finite drop their loop (as a loop
/// enclosing no area does).
pub fn write(surfaces: &[IgesSurface]) -> Result<Vec<u8>> {
    for (k, s) in surfaces.iter().enumerate() {
        check_patch(k, &s.patch)?;
    }
    let mut entities: Vec<Entity> = Vec::new();
    let de = |index: usize| (2 * index + 1).to_string();
    for (surface, s) in surfaces.iter().enumerate() {
        let label: String = s
            .name
            .chars()
            .filter(|c| c.is_ascii_graphic())
            .take(8)
            .collect();
        let mut params = Vec::new();
        patch_params(&s.patch, &mut params);
        let surface_index = entities.len();
        entities.push(Entity {
            kind: 128,
            form: 0,
            status: if s.faces.is_some() {
                STATUS_DEPENDENT
            } else {
                STATUS_INDEPENDENT
            },
            label: label.clone(),
            params,
        });
        let (lo, hi) = s.patch.domain();
        for face in s.faces.iter().flatten() {
            let mut boundaries = Vec::new();
            let loops =
                std::iter::once((&face.outer, true)).chain(face.holes.iter().map(|h| (h, false)));
            for (lp, outer) in loops {
                let Some(lp) = clean_loop(lp, outer) else {
                    if outer {
                        break;
                    }
                    continue;
                };
                let in_domain: Vec<DVec2> = lp.iter().map(|q| lo + *q * (hi - lo)).collect();
                if let Some(index) = in_domain.iter().position(|p| !p.is_finite()) {
                    // Finite knots whose span overflows.
                    return Err(err(FormatError::SurfaceNonFinite {
                        surface,
                        what: WrittenValue::TrimPoint,
                        index,
                    }));
                }
                let mut cparams = Vec::new();
                loop_params(&in_domain, &mut cparams);
                entities.push(Entity {
                    kind: 126,
                    form: 0,
                    status: STATUS_PARAMETRIC,
                    label: "TRIMUV".into(),
                    params: cparams,
                });
                let curve = entities.len() - 1;
                let params = vec![
                    "142".into(),
                    "0".into(),
                    de(surface_index),
                    de(curve),
                    "0".into(),
                    "1".into(),
                ];
                entities.push(Entity {
                    kind: 142,
                    form: 0,
                    status: STATUS_DEPENDENT,
                    label: "TRIMLOOP".into(),
                    params,
                });
                boundaries.push(entities.len() - 1);
            }
            if boundaries.is_empty() {
                continue;
            }
            let mut params = vec![
                "144".into(),
                de(surface_index),
                "1".into(),
                (boundaries.len() - 1).to_string(),
            ];
            params.extend(boundaries.iter().map(|&b| de(b)));
            entities.push(Entity {
                kind: 144,
                form: 0,
                status: STATUS_INDEPENDENT,
                label: label.clone(),
                params,
            });
        }
    }
    let mut lines: Vec<String> = Vec::new();
    let push = |lines: &mut Vec<String>, body: &str, section: char, seq: usize| {
        lines.push(format!("{body:<72}{section}{seq:>7}"));
    };
    let start = [
        "Wandsculpt sculpted NURBS surfaces (IGES 5.3).",
        "Trimmed surfaces are entity 144 with parameter-space loops (126/142).",
    ];
    for (k, s) in start.iter().enumerate() {
        push(&mut lines, s, 'S', k + 1);
    }
    let h = |s: &str| format!("{}H{}", s.len(), s);
    let global = [
        h(","),
        h(";"),
        h("wandsculpt"),
        h("sculpture.igs"),
        h("Wandsculpt sculpt-core"),
        h(env!("CARGO_PKG_VERSION")),
        "32".into(),
        "38".into(),
        "6".into(),
        "308".into(),
        "15".into(),
        h("wandsculpt"),
        "1.".into(),
        "6".into(),
        h("M"),
        "1".into(),
        "1.".into(),
        h("20260101.000000"),
        "1.E-9".into(), // not a tolerance: the text of IGES's resolution field (POINT_EPS), fixed bytes
        real(max_coordinate(surfaces)),
        h("wandsculpt"),
        h("wandsculpt"),
        "11".into(),
        "0".into(),
        h("20260101.000000"),
    ];
    let global_lines = pack(&global.join(","), 72);
    let ng = global_lines.len();
    for (k, body) in global_lines.iter().enumerate() {
        let body = if k + 1 == ng {
            format!("{body};")
        } else {
            body.clone()
        };
        push(&mut lines, &body, 'G', k + 1);
    }
    // Parameter data first (to know the line pointers), then directory entries.
    let mut pdata: Vec<String> = Vec::new();
    let mut pointers = Vec::new();
    for (i, e) in entities.iter().enumerate() {
        let text = format!("{};", e.params.join(","));
        let body = pack(&text, 64);
        pointers.push((pdata.len() + 1, body.len()));
        for b in body {
            pdata.push(format!("{b:<64} {:>7}", 2 * i + 1));
        }
    }
    for (i, e) in entities.iter().enumerate() {
        let status = e.status;
        let l1 = format!(
            "{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}",
            e.kind, pointers[i].0, 0, 0, 0, 0, 0, 0, status
        );
        let l2 = format!(
            "{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}{:>8}",
            e.kind, 0, 0, pointers[i].1, e.form, "", "", e.label, 0
        );
        push(&mut lines, &l1, 'D', 2 * i + 1);
        push(&mut lines, &l2, 'D', 2 * i + 2);
    }
    for (k, body) in pdata.iter().enumerate() {
        push(&mut lines, body, 'P', k + 1);
    }
    let term = format!(
        "S{:>7}G{:>7}D{:>7}P{:>7}",
        start.len(),
        ng,
        2 * entities.len(),
        pdata.len()
    );
    push(&mut lines, &term, 'T', 1);
    let mut out = lines.join("\n");
    out.push('\n');
    Ok(out.into_bytes())
}

/// The largest absolute coordinate of any control point (global parameter 20); the
/// surfaces lie in the convex hull of their control points.
fn max_coordinate(surfaces: &[IgesSurface]) -> f64 {
    surfaces
        .iter()
        .flat_map(|s| s.patch.control_points.iter().flatten())
        .map(|p| p.abs().max_element())
        .filter(|m| m.is_finite())
        .fold(0.0, f64::max)
}

/// Splits free-format text into lines of at most `width` columns, breaking after a
/// delimiter so that no number is split.
fn pack(text: &str, width: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut cur = String::new();
    for token in text.split_inclusive([',', ';']) {
        if cur.len() + token.len() > width && !cur.is_empty() {
            lines.push(std::mem::take(&mut cur));
        }
        cur.push_str(token);
    }
    if !cur.is_empty() {
        lines.push(cur);
    }
    lines
}

/// Reads the surfaces and trimming structure back from IGES text.
pub fn read(bytes: &[u8]) -> Result<IgesModel> {
    let text = std::str::from_utf8(bytes).map_err(|error| err(FormatError::NotText { error }))?;
    let mut dir: Vec<&str> = Vec::new();
    let mut params: std::collections::BTreeMap<usize, String> = Default::default();
    for (ln, line) in text.lines().enumerate() {
        let line = line.trim_end_matches('\r');
        if line.len() < 73 || !line.is_char_boundary(72) || !line.is_char_boundary(73) {
            if line.trim().is_empty() {
                continue;
            }
            return Err(err(FormatError::ShortLine {
                line: ln + 1,
                columns: line.len(),
            }));
        }
        match &line[72..73] {
            "D" => dir.push(line),
            "P" => {
                let pointer = line.get(64..72).unwrap_or_default();
                let de: usize = pointer.trim().parse().map_err(|_| {
                    err(FormatError::DirectoryPointer {
                        line: ln + 1,
                        token: Excerpt::new(pointer),
                    })
                })?;
                params
                    .entry(de)
                    .or_default()
                    .push_str(line[..64].trim_end());
            }
            "S" | "G" | "T" => {}
            other => {
                return Err(err(FormatError::Section {
                    line: ln + 1,
                    section: Excerpt::new(other),
                }));
            }
        }
    }
    if !dir.len().is_multiple_of(2) {
        return Err(err(FormatError::OddDirectory { lines: dir.len() }));
    }
    let mut model = IgesModel::default();
    let mut surface_at_de = std::collections::HashMap::new();
    let mut pending_144 = Vec::new();
    for (k, pair) in dir.chunks(2).enumerate() {
        let de = 2 * k + 1;
        let kind_text = pair[0].get(0..8).unwrap_or(pair[0]);
        let kind: u32 = kind_text.trim().parse().map_err(|_| {
            err(FormatError::EntityType {
                de,
                token: Excerpt::new(kind_text),
            })
        })?;
        let p = params
            .get(&de)
            .ok_or_else(|| err(FormatError::NoParameters { de }))?;
        let toks: Vec<&str> = p
            .trim_end_matches(';')
            .split([',', ';'])
            .map(str::trim)
            .collect();
        if toks.first().and_then(|t| t.parse::<u32>().ok()) != Some(kind) {
            return Err(err(FormatError::OtherEntity {
                de,
                kind,
                found: Excerpt::new(toks.first().copied().unwrap_or_default()),
            }));
        }
        let num = |i: usize| -> Result<f64> {
            toks.get(i)
                .and_then(|t| t.replace('D', "E").parse::<f64>().ok())
                .filter(|x| x.is_finite())
                .ok_or_else(|| err(FormatError::Parameter { kind, de, index: i }))
        };
        let int = |i: usize| -> Result<usize> {
            let x = num(i)?;
            if !(0.0..=1e7).contains(&x) || x.fract() != 0.0 {
                return Err(err(FormatError::NotACount {
                    kind,
                    de,
                    index: i,
                    value: x,
                }));
            }
            Ok(x as usize)
        };
        match kind {
            128 => {
                let (k1, k2, m1, m2) = (int(1)?, int(2)?, int(3)?, int(4)?);
                let polynomial = int(7)? == 1;
                let (nu, nv) = (k1 + 1, k2 + 1);
                let (nku, nkv) = (nu + m1 + 1, nv + m2 + 1);
                let need = 10 + nku + nkv + 4 * nu * nv + 4;
                if toks.len() < need {
                    return Err(err(FormatError::ParameterCount {
                        kind,
                        de,
                        found: toks.len(),
                        need,
                    }));
                }
                let mut at = 10;
                let mut take = |n: usize| -> Result<Vec<f64>> {
                    let v = (at..at + n).map(num).collect::<Result<Vec<f64>>>()?;
                    at += n;
                    Ok(v)
                };
                let knots_u = take(nku)?;
                let knots_v = take(nkv)?;
                let w = take(nu * nv)?;
                let c = take(3 * nu * nv)?;
                let control_points = (0..nu)
                    .map(|i| {
                        (0..nv)
                            .map(|j| {
                                let o = 3 * (j * nu + i);
                                DVec3::new(c[o], c[o + 1], c[o + 2])
                            })
                            .collect()
                    })
                    .collect();
                let weights = (!polynomial).then(|| {
                    (0..nu)
                        .map(|i| (0..nv).map(|j| w[j * nu + i]).collect())
                        .collect()
                });
                surface_at_de.insert(de, model.surfaces.len());
                model.surfaces.push(NurbsPatch {
                    degree_u: m1,
                    degree_v: m2,
                    knots_u,
                    knots_v,
                    control_points,
                    weights,
                });
            }
            126 => {
                let (k, m) = (int(1)?, int(2)?);
                let at = 7 + k + m + 2 + k + 1;
                let pts = (0..=k)
                    .map(|i| {
                        Ok(DVec3::new(
                            num(at + 3 * i)?,
                            num(at + 3 * i + 1)?,
                            num(at + 3 * i + 2)?,
                        ))
                    })
                    .collect::<Result<Vec<_>>>()?;
                model.curves.push(pts);
            }
            144 => {
                let (pts, n1, n2) = (int(1)?, int(2)?, int(3)?);
                pending_144.push((de, pts, n1 + n2));
            }
            _ => {}
        }
    }
    for (de, pts, loops) in pending_144 {
        let s = surface_at_de
            .get(&pts)
            .ok_or(err(FormatError::BaseSurface { de, pointer: pts }))?;
        model.trimmed.push((*s, loops));
    }
    Ok(model)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn patch() -> NurbsPatch {
        NurbsPatch {
            degree_u: 2,
            degree_v: 1,
            knots_u: vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
            knots_v: vec![0.0, 0.0, 2.0, 2.0],
            control_points: vec![
                vec![DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0)],
                vec![DVec3::new(0.5, 0.0, 0.3), DVec3::new(0.5, 1.0, 0.3)],
                vec![
                    DVec3::new(1.0, 0.0, 0.0),
                    DVec3::new(1.0, 1.0, 0.123456789012345),
                ],
            ],
            weights: Some(vec![vec![1.0, 1.0], vec![0.5, 0.7], vec![1.0, 1.0]]),
        }
    }

    #[test]
    fn trimmed_surface_round_trip() {
        let sq = |c: f64, h: f64| {
            vec![
                DVec2::new(c - h, c - h),
                DVec2::new(c + h, c - h),
                DVec2::new(c + h, c + h),
                DVec2::new(c - h, c + h),
            ]
        };
        let face = Face {
            outer: sq(0.5, 0.5),
            holes: vec![sq(0.5, 0.1).into_iter().rev().collect()],
        };
        let bytes = write(&[IgesSurface {
            name: "target-with-a-long-name".into(),
            patch: patch(),
            faces: Some(vec![face]),
        }])
        .unwrap();
        let text = std::str::from_utf8(&bytes).unwrap();
        assert!(text.lines().all(|l| l.len() == 80), "80 columns");
        let m = read(&bytes).unwrap();
        assert_eq!(m.surfaces, vec![patch()]);
        assert_eq!(m.trimmed, vec![(0, 2)]);
        // Loops are mapped into the surface's own parameter range (v in [0, 2]).
        assert_eq!(m.curves[1][0], DVec3::new(0.4, 1.2, 0.0));
    }

    fn square(c: f64, h: f64) -> Vec<DVec2> {
        vec![
            DVec2::new(c - h, c - h),
            DVec2::new(c + h, c - h),
            DVec2::new(c + h, c + h),
            DVec2::new(c - h, c + h),
        ]
    }

    fn signed_area(c: &[DVec3]) -> f64 {
        (0..c.len())
            .map(|k| c[k].truncate().perp_dot(c[(k + 1) % c.len()].truncate()))
            .sum::<f64>()
            / 2.0
    }

    /// Regression: `{:E}` writes `1E0`; IGES 5.3 section 2.2.2.2 reals carry a decimal
    /// point (`1.E0`), which strict readers require.
    #[test]
    fn reals_always_have_a_decimal_point() {
        assert_eq!(real(1.0), "1.E0");
        assert_eq!(real(0.0), "0.E0");
        assert_eq!(real(-2.0e-3), "-2.E-3"); // not a tolerance: a value to format
        assert_eq!(real(0.123456789012345), "1.23456789012345E-1"); // not a tolerance: formatted text
        assert_eq!(real(f64::NAN), "0.E0");
        // not a tolerance: values to round-trip
        for x in [1.0, -0.5, 1e-300, 123456.789, 0.1 + 0.2] {
            assert_eq!(real(x).parse::<f64>().unwrap(), x, "round trip of {x}");
        }
        let bytes = write(&[IgesSurface {
            name: "p".into(),
            patch: patch(),
            faces: None,
        }])
        .unwrap();
        let text = std::str::from_utf8(&bytes).unwrap();
        for line in text.lines().filter(|l| &l[72..73] == "P") {
            for token in line[..64].split([',', ';']) {
                let token = token.trim();
                if token.contains('E') {
                    assert!(token.contains('.'), "real without a decimal point: {token}");
                }
            }
        }
    }

    /// Regression: a loop given with its first point repeated at the end, or with a
    /// point repeated, was written with zero-length spans in its degree-1 curve.
    #[test]
    fn loops_drop_repeated_and_closing_points() {
        let mut outer = square(0.5, 0.5);
        outer.insert(2, outer[1]);
        outer.push(outer[0]);
        let face = Face {
            outer,
            holes: vec![vec![DVec2::splat(0.5); 3], square(0.5, 0.1)],
        };
        let m = read(
            &write(&[IgesSurface {
                name: "t".into(),
                patch: patch(),
                faces: Some(vec![face]),
            }])
            .unwrap(),
        )
        .unwrap();
        // The degenerate hole is dropped; the outer loop has 4 corners plus its close.
        assert_eq!(m.trimmed, vec![(0, 2)]);
        assert_eq!(m.curves[0].len(), 5);
        for c in &m.curves {
            for w in c.windows(2) {
                assert_ne!(w[0], w[1], "zero-length span");
            }
        }
    }

    /// Regression: loops were written in whatever orientation the caller gave; IGES
    /// readers expect the outer boundary counter-clockwise in parameter space and holes
    /// clockwise.
    #[test]
    fn loops_are_written_outer_counter_clockwise_holes_clockwise() {
        let face = Face {
            outer: square(0.5, 0.5).into_iter().rev().collect(),
            holes: vec![square(0.5, 0.1)],
        };
        let m = read(
            &write(&[IgesSurface {
                name: "t".into(),
                patch: patch(),
                faces: Some(vec![face]),
            }])
            .unwrap(),
        )
        .unwrap();
        assert!(signed_area(&m.curves[0]) > 0.0, "outer counter-clockwise");
        assert!(signed_area(&m.curves[1]) < 0.0, "hole clockwise");
    }

    /// Regression: the 126 curves under a 142 had entity use flag 00 (geometry); IGES
    /// 5.3 section 2.2.4.3.9 flags parameter-space curves 05 (2D parametric).
    #[test]
    fn parameter_space_curves_are_flagged_2d_parametric() {
        let bytes = write(&[IgesSurface {
            name: "t".into(),
            patch: patch(),
            faces: Some(vec![Face {
                outer: square(0.5, 0.5),
                holes: vec![],
            }]),
        }])
        .unwrap();
        let text = std::str::from_utf8(&bytes).unwrap();
        let status: Vec<(&str, &str)> = text
            .lines()
            .filter(|l| &l[72..73] == "D")
            .step_by(2)
            .map(|l| (l[..8].trim(), &l[64..72]))
            .collect();
        assert_eq!(
            status,
            vec![
                ("128", "00010000"),
                ("126", "00010500"),
                ("142", "00010000"),
                ("144", "00000000"),
            ]
        );
    }

    /// Regression: global parameter 20 (maximum coordinate) was a fixed 1000; it is the
    /// model's largest absolute coordinate.
    #[test]
    fn global_max_coordinate_is_the_models() {
        let mut p = patch();
        p.control_points[2][1].y = -1234.5;
        let bytes = write(&[IgesSurface {
            name: "t".into(),
            patch: p,
            faces: None,
        }])
        .unwrap();
        let global: String = std::str::from_utf8(&bytes)
            .unwrap()
            .lines()
            .filter(|l| &l[72..73] == "G")
            .map(|l| l[..72].trim_end())
            .collect();
        // Parameters 19 (resolution) and 20 follow each other.
        let after_resolution = global.split_once("1.E-9,").map(|(_, rest)| rest); // not a tolerance: the field's text
        let max = after_resolution.and_then(|r| r.split([',', ';']).next());
        assert_eq!(max, Some("1.2345E3"), "global section {global}");
    }

    fn reason(e: Error) -> FormatError {
        match e {
            Error::Format {
                format: FileFormat::Iges,
                reason,
            } => reason,
            other => panic!("not an IGES format error: {other:?}"),
        }
    }

    /// Regression (issue 15): a NaN or infinite knot, weight or control point was
    /// written as `0.E0` (a silently different surface); the writer refuses it.
    #[test]
    fn non_finite_surface_numbers_are_refused_not_written_as_zero() {
        let surface = |patch| IgesSurface {
            name: "p".into(),
            patch,
            faces: None,
        };
        let mut p = patch();
        p.control_points[1][1].z = f64::NAN;
        let ok = surface(patch());
        assert_eq!(
            reason(write(&[ok.clone(), surface(p)]).unwrap_err()),
            FormatError::SurfaceNonFinite {
                surface: 1,
                what: WrittenValue::ControlPoint,
                index: 3
            }
        );
        let mut p = patch();
        p.knots_v[2] = f64::INFINITY;
        assert_eq!(
            reason(write(&[surface(p)]).unwrap_err()),
            FormatError::SurfaceNonFinite {
                surface: 0,
                what: WrittenValue::Knot,
                index: 8
            }
        );
        let mut p = patch();
        p.weights.as_mut().unwrap()[2][0] = f64::NAN;
        assert_eq!(
            reason(write(&[surface(p)]).unwrap_err()),
            FormatError::SurfaceNonFinite {
                surface: 0,
                what: WrittenValue::Weight,
                index: 4
            }
        );
        assert!(read(&write(&[ok]).unwrap()).is_ok());
    }

    #[test]
    fn read_errors_are_typed_and_quote_short() {
        let bytes = write(&[IgesSurface {
            name: "p".into(),
            patch: patch(),
            faces: None,
        }])
        .unwrap();
        let text = String::from_utf8(bytes).unwrap();
        // Regression (issue 15): a 50 MB line gives a short error (quotes are cut).
        let long = text.replacen("128,", &format!("{},", "9".repeat(50 << 20)), 1);
        let e = read(long.as_bytes()).unwrap_err();
        assert!(e.to_string().len() < 200, "{e}");
        let other = text.replacen("128,", "129,", 1);
        match reason(read(other.as_bytes()).unwrap_err()) {
            FormatError::OtherEntity {
                de: 1,
                kind: 128,
                found,
            } => {
                assert_eq!(found, Excerpt::new("129"))
            }
            other => panic!("{other:?}"),
        }
        let bad_section = text.replacen("S      1", "X      1", 1);
        assert!(matches!(
            reason(read(bad_section.as_bytes()).unwrap_err()),
            FormatError::Section { line: 1, .. }
        ));
    }

    proptest! {
        /// Any loops a caller hands in (repeated points, either orientation, NaN,
        /// degenerate) are written as valid boundaries or dropped: the file reads back,
        /// no span has zero length, outer loops turn counter-clockwise and holes clockwise.
        #[test]
        fn any_loops_are_written_clean_and_oriented(
            raw in proptest::collection::vec(
                proptest::collection::vec((0u8..6, 0u8..6, 0u8..20), 0..12), 1..4)
        ) {
            let loops: Vec<Vec<DVec2>> = raw
                .iter()
                .map(|l| {
                    l.iter()
                        .map(|&(x, y, nan)| {
                            if nan == 0 { DVec2::NAN } else { DVec2::new(x as f64 / 5.0, y as f64 / 5.0) }
                        })
                        .collect()
                })
                .collect();
            let face = Face { outer: loops[0].clone(), holes: loops[1..].to_vec() };
            let m = read(&write(&[IgesSurface { name: "p".into(), patch: patch(), faces: Some(vec![face]) }]).unwrap()).unwrap();
            let mut curve = 0;
            for &(_, count) in &m.trimmed {
                for k in 0..count {
                    let c = &m.curves[curve + k];
                    prop_assert!(c.windows(2).all(|w| w[0] != w[1]));
                    let open = &c[..c.len() - 1];
                    let a = signed_area(open);
                    prop_assert!(a != 0.0);
                    prop_assert_eq!(a > 0.0, k == 0, "loop {} area {}", k, a);
                }
                curve += count;
            }
        }

        #[test]
        fn damaged_files_never_panic(cut in 0usize..3000, flip in 0usize..3000, val in 32u8..127) {
            let mut bytes = write(&[IgesSurface { name: "p".into(), patch: patch(), faces: None }]).unwrap();
            if flip < bytes.len() { bytes[flip] = val; }
            bytes.truncate(cut);
            let _ = read(&bytes);
        }
    }
}
