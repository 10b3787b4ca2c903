//! Heterogeneous material: property fields interpolated from values given at points and
//! on implicit boundaries (Shin, Kim and Sheen 2007, sec. 2.3).
//!
//! - **Inverse-distance weights** over points (Shepard's method, eq. 2):
//!   `f(x) = sum_i f_i w_i(x)`, `w_i = d_i^-mu_i / sum_j d_j^-mu_j`, `d_i = |x - x_i|`.
//! - **Transfinite interpolation** of values given on curves and surfaces (eq. 2 with the
//!   distance replaced by a distance-like implicit function, the weights of eq. 9):
//!   `w_i = omega_i^-mu_i / sum_j omega_j^-mu_j`. The distance-like `omega_i`
//!   (sec. 2.1.2) is free: no closest-point search.
//!
//! Both kinds of term mix in one field. The weights are built as graph nodes in the
//! product form `w_i = prod_{j != i} d_j^mu_j / sum_k prod_{j != k} d_j^mu_j` (the
//! quotient multiplied through by `prod_j d_j^mu_j`), which is the same function away
//! from the sites and is finite on them: on site `i` every product but the `i`-th
//! vanishes and the field takes `f_i` exactly. A field is an expression like a shape,
//! so it compiles to a tape and evaluates at points, on grids and on the GPU.
//!
//! The material document (JSON) names the sites:
//!
//! ```json
//! {"version": 1, "material": {
//!   "boundaries": [{"solid": {"circle": {"center": [0, 0], "radius": 1}}, "value": 7.0}],
//!   "points": [{"at": [0, 0], "value": 2.0, "mu": 2}]}}
//! ```
//!
//! `mu` defaults to 1 on boundaries (eq. 9) and 2 on points (the field is then smooth
//! at the points; `0 < mu <= 1` gives a cusp there, sec. 2.3.2).

use serde::{Deserialize, Serialize};

use super::expr::{Graph, Node, NodeId, Unary};
use super::solid::{Solid, SolidDocument};
use super::{ImplicitError, Tape};

/// The largest exponent `mu` accepted.
pub const MAX_MU: f64 = 16.0;
/// The most sites (points and boundaries) a material may have.
pub const MAX_SITES: usize = 4096;

/// Copies the part of `src` that `root` reaches into `dst` (hash-consed, so shared
/// subexpressions with `dst` merge) and returns the copy's root.
pub fn import_graph(dst: &mut Graph, src: &Graph, root: NodeId) -> NodeId {
    let mut map: Vec<NodeId> = Vec::with_capacity(root.index() + 1);
    for i in 0..=root.index() {
        let m = match src.node(NodeId(i as u32)) {
            Node::Var(v) => dst.var(v),
            Node::Const(bits) => dst.constant(f64::from_bits(bits)),
            Node::Unary(op, a) => dst.unary(op, map[a.index()]),
            Node::Binary(op, a, b) => dst.binary(op, map[a.index()], map[b.index()]),
        };
        map.push(m);
    }
    map[root.index()]
}

/// `|d|^mu` as nodes: repeated products for whole `mu`, `exp(mu ln |d|)` otherwise
/// (which is 0 at `d = 0`, as `ln 0 = -inf`).
pub fn abs_pow(g: &mut Graph, d: NodeId, mu: f64) -> NodeId {
    let a = g.unary(Unary::Abs, d);
    if mu.fract() == 0.0 && (1.0..=MAX_MU).contains(&mu) {
        let k = mu as u32;
        (1..k).fold(a, |acc, _| g.mul(acc, a))
    } else {
        let l = g.unary(Unary::Ln, a);
        let s = g.scale(l, mu);
        g.unary(Unary::Exp, s)
    }
}

/// The weights `w_i = d_i^-mu_i / sum_j d_j^-mu_j` (eqs. 2 and 9) of the sites given by
/// their distance nodes and exponents, in the product form (finite on the sites). The
/// products leaving one factor out come from prefix and suffix products, so the graph
/// grows linearly with the number of sites.
pub fn weights(g: &mut Graph, sites: &[(NodeId, f64)]) -> Vec<NodeId> {
    let powers: Vec<NodeId> = sites.iter().map(|&(d, mu)| abs_pow(g, d, mu)).collect();
    let n = powers.len();
    let one = g.constant(1.0);
    let mut prefix = vec![one; n + 1];
    for i in 0..n {
        prefix[i + 1] = g.mul(prefix[i], powers[i]);
    }
    let mut suffix = vec![one; n + 1];
    for i in (0..n).rev() {
        suffix[i] = g.mul(suffix[i + 1], powers[i]);
    }
    let others: Vec<NodeId> = (0..n).map(|i| g.mul(prefix[i], suffix[i + 1])).collect();
    let total = g.sum(&others);
    others.iter().map(|&o| g.div(o, total)).collect()
}

/// The interpolated field `sum_i f_i w_i` of sites `(distance node, exponent, value)`.
pub fn interpolate(g: &mut Graph, sites: &[(NodeId, f64, f64)]) -> NodeId {
    let w = weights(
        g,
        &sites.iter().map(|&(d, mu, _)| (d, mu)).collect::<Vec<_>>(),
    );
    let terms: Vec<NodeId> = w
        .iter()
        .zip(sites)
        .map(|(&w, &(_, _, f))| g.scale(w, f))
        .collect();
    g.sum(&terms)
}

/// A value given on an implicit boundary (the zero set of `solid`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundaryValue {
    /// The boundary: the zero set of a solid (its distance-like omega, sec. 2.1.2).
    pub solid: Solid,
    /// The value on it.
    pub value: f64,
    /// The weight's exponent (eq. 9 uses 1).
    #[serde(default = "mu_boundary")]
    pub mu: f64,
}

/// A value given at a point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointValue {
    /// The point (2 or 3 components; a missing z is 0).
    pub at: Vec<f64>,
    /// The value there.
    pub value: f64,
    /// The weight's exponent (eq. 2).
    #[serde(default = "mu_point")]
    pub mu: f64,
}

fn mu_boundary() -> f64 {
    1.0
}

fn mu_point() -> f64 {
    2.0
}

/// The sites of a material field.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Values on implicit boundaries (transfinite interpolation).
    #[serde(default)]
    pub boundaries: Vec<BoundaryValue>,
    /// Values at points (inverse-distance weights).
    #[serde(default)]
    pub points: Vec<PointValue>,
    /// The shape the material fills (omega >= 0 inside), making a heterogeneous
    /// object with the field (sec. 2.3, Fig. 8); the field itself is defined
    /// everywhere, the shape says where it is shown.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub domain: Option<Solid>,
}

/// A material document: a version and the material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialDocument {
    /// Format version; 1.
    pub version: u32,
    /// The material.
    pub material: Material,
}

/// Whether `text` looks like a material document (a JSON object with a top-level
/// `material` key) rather than a solid document or a `.vm` model.
pub fn is_material_document(text: &str) -> bool {
    text.trim_start().starts_with('{')
        && serde_json::from_str::<serde_json::Map<String, serde_json::Value>>(text)
            .is_ok_and(|m| m.contains_key("material"))
}

impl MaterialDocument {
    /// Parses and checks a document.
    pub fn from_json(text: &str) -> Result<Self, ImplicitError> {
        let doc: MaterialDocument = serde_json::from_str(text).map_err(ImplicitError::Json)?;
        doc.check()?;
        Ok(doc)
    }

    /// The document as JSON (what [`from_json`](Self::from_json) reads back).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a material document always serialises")
    }

    fn check(&self) -> Result<(), ImplicitError> {
        let bad = |at: String, name, value, expected| ImplicitError::Parameter {
            at,
            name,
            value,
            expected,
        };
        if self.version != 1 {
            return Err(bad(
                "version".into(),
                "version",
                f64::from(self.version),
                "1",
            ));
        }
        let m = &self.material;
        let n = m.boundaries.len() + m.points.len();
        if n == 0 || n > MAX_SITES {
            return Err(bad(
                "material".into(),
                "sites",
                n as f64,
                "between 1 and 4096",
            ));
        }
        let check_site = |at: String, value: f64, mu: f64| {
            if !value.is_finite() {
                return Err(bad(at, "value", value, "finite"));
            }
            if !(mu > 0.0 && mu <= MAX_MU) {
                return Err(bad(at, "mu", mu, "in (0, 16]"));
            }
            Ok(())
        };
        for (i, b) in m.boundaries.iter().enumerate() {
            let at = format!("material.boundaries[{i}]");
            check_site(at.clone(), b.value, b.mu)?;
            b.solid.check(&format!("{at}.solid"))?;
        }
        if let Some(d) = &m.domain {
            d.check("material.domain")?;
        }
        for (i, p) in m.points.iter().enumerate() {
            let at = format!("material.points[{i}]");
            check_site(at.clone(), p.value, p.mu)?;
            if !(2..=3).contains(&p.at.len()) {
                return Err(ImplicitError::Dimension {
                    at,
                    name: "at",
                    found: p.at.len(),
                });
            }
            if let Some(&c) = p.at.iter().find(|c| !c.is_finite()) {
                return Err(bad(at, "at", c, "finite"));
            }
        }
        Ok(())
    }

    /// The field as a graph and its root.
    pub fn to_graph(&self) -> Result<(Graph, NodeId), ImplicitError> {
        self.check()?;
        let mut g = Graph::new();
        let xyz = g.xyz();
        let mut sites = Vec::new();
        for b in &self.material.boundaries {
            let doc = SolidDocument {
                version: 1,
                solid: b.solid.clone(),
            };
            let (sg, sr) = doc.to_graph()?;
            let omega = import_graph(&mut g, &sg, sr);
            sites.push((omega, b.mu, b.value));
        }
        for p in &self.material.points {
            let c = [p.at[0], p.at[1], p.at.get(2).copied().unwrap_or(0.0)];
            let diffs: Vec<NodeId> = xyz.iter().zip(c).map(|(&v, c)| g.offset(v, -c)).collect();
            let s = g.norm2(&diffs);
            let d = g.sqrt(s);
            sites.push((d, p.mu, p.value));
        }
        let root = interpolate(&mut g, &sites);
        Ok((g, root))
    }

    /// The field's tape (values as they are: a material has no inside).
    pub fn tape(&self) -> Result<Tape, ImplicitError> {
        let (g, root) = self.to_graph()?;
        Ok(Tape::compile(&g, root))
    }

    /// The tape of the shape the material fills (omega >= 0 inside), if it has one.
    pub fn domain_tape(&self) -> Result<Option<Tape>, ImplicitError> {
        let Some(solid) = &self.material.domain else {
            return Ok(None);
        };
        let doc = SolidDocument {
            version: 1,
            solid: solid.clone(),
        };
        let (g, root) = doc.to_graph()?;
        Ok(Some(Tape::compile(&g, root)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::tolerance::MATERIAL_EXACT_REL;
    use proptest::prelude::*;

    fn ring_material(inner: f64, outer: f64) -> MaterialDocument {
        MaterialDocument::from_json(&format!(
            r#"{{"version": 1, "material": {{"boundaries": [
                {{"solid": {{"circle": {{"center": [0, 0], "radius": 1}}}}, "value": {inner}}},
                {{"solid": {{"circle": {{"center": [0, 0], "radius": 2}}}}, "value": {outer}}}]}}}}"#
        ))
        .unwrap()
    }

    proptest! {
        /// On each boundary the field takes that boundary's value (eq. 9), with no
        /// division by zero there.
        #[test]
        fn transfinite_interpolates_on_the_boundaries(
            inner in -1e3f64..1e3, outer in -1e3f64..1e3, t in 0.0f64..std::f64::consts::TAU
        ) {
            let (g, root) = ring_material(inner, outer).to_graph().unwrap();
            for (r, v) in [(1.0, inner), (2.0, outer)] {
                let got = g.eval_f64(root, [r * t.cos(), r * t.sin(), 0.0]);
                // The circle's omega vanishes to rounding on the sampled boundary point,
                // so the other site's weight is of that size.
                prop_assert!((got - v).abs() <= MATERIAL_EXACT_REL.sqrt() * (1.0 + inner.abs() + outer.abs()),
                    "r = {r}: {got} vs {v}");
            }
        }

        /// The weights are a partition of unity and each lies in [0, 1] (eq. 2).
        #[test]
        fn weights_are_a_partition_of_unity(
            sites in proptest::collection::vec(((-3.0f64..3.0, -3.0f64..3.0), 0.5f64..4.0), 1..6),
            x in -3.0f64..3.0, y in -3.0f64..3.0,
        ) {
            let mut g = Graph::new();
            let [vx, vy, _] = g.xyz();
            let d: Vec<(NodeId, f64)> = sites.iter().map(|&((cx, cy), mu)| {
                let dx = g.offset(vx, -cx);
                let dy = g.offset(vy, -cy);
                let s = g.norm2(&[dx, dy]);
                (g.sqrt(s), mu)
            }).collect();
            let w = weights(&mut g, &d);
            let ws: Vec<f64> = w.iter().map(|&w| g.eval_f64(w, [x, y, 0.0])).collect();
            prop_assume!(ws.iter().all(|w| w.is_finite()));
            let sum: f64 = ws.iter().sum();
            prop_assert!((sum - 1.0).abs() <= MATERIAL_EXACT_REL * 100.0, "sum {sum}");
            prop_assert!(ws.iter().all(|&w| (-MATERIAL_EXACT_REL..=1.0 + MATERIAL_EXACT_REL).contains(&w)));
        }
    }

    /// At a point site, inverse-distance weights give the site's value exactly; between
    /// two sites the value lies between theirs; by symmetry, halfway is the mean.
    #[test]
    fn inverse_distance_interpolates_points() {
        let doc = MaterialDocument::from_json(
            r#"{"version": 1, "material": {"points": [
                {"at": [0, 0], "value": 10}, {"at": [2, 0], "value": 30, "mu": 2}]}}"#,
        )
        .unwrap();
        let (g, root) = doc.to_graph().unwrap();
        assert_near!(g.eval_f64(root, [0.0, 0.0, 0.0]), 10.0, MATERIAL_EXACT_REL);
        assert_near!(g.eval_f64(root, [2.0, 0.0, 0.0]), 30.0, MATERIAL_EXACT_REL);
        assert_near!(
            g.eval_f64(root, [1.0, 5.0, 0.0]),
            20.0,
            MATERIAL_EXACT_REL * 20.0
        );
        // Shepard with mu = 2 at x = 0.5: weights 1/0.25 and 1/2.25.
        let (a, b) = (1.0 / 0.25, 1.0 / 2.25);
        let want = (10.0 * a + 30.0 * b) / (a + b);
        assert_near!(
            g.eval_f64(root, [0.5, 0.0, 0.0]),
            want,
            MATERIAL_EXACT_REL * 30.0
        );
        // The document round-trips.
        assert_eq!(MaterialDocument::from_json(&doc.to_json()).unwrap(), doc);
    }

    /// The ring's field between the circles is eq. 9's mix, computed here by hand from
    /// the circles' omegas.
    #[test]
    fn transfinite_matches_eq_9_between_the_boundaries() {
        let (g, root) = ring_material(1073.0, 1573.0).to_graph().unwrap();
        for r in [1.2f64, 1.5, 1.9] {
            let w0 = (1.0 - r * r) / 2.0; // (r^2 - |p|^2) / 2r of the unit circle: negative
            let w1 = (4.0 - r * r) / 4.0;
            let (a, b) = (1.0 / w0.abs(), 1.0 / w1.abs());
            let want = (1073.0 * a + 1573.0 * b) / (a + b);
            assert_near!(
                g.eval_f64(root, [0.0, r, 0.0]),
                want,
                MATERIAL_EXACT_REL * 1573.0
            );
        }
    }

    #[test]
    fn bad_documents_are_refused() {
        for text in [
            r#"{"version": 1, "material": {}}"#,
            r#"{"version": 2, "material": {"points": [{"at": [0, 0], "value": 1}]}}"#,
            r#"{"version": 1, "material": {"points": [{"at": [0], "value": 1}]}}"#,
            r#"{"version": 1, "material": {"points": [{"at": [0, 0], "value": 1, "mu": 0}]}}"#,
            r#"{"version": 1, "material": {"points": [{"at": [0, 0], "value": 1, "mu": 17}]}}"#,
            r#"{"version": 1, "material": {"boundaries": [{"solid": {"circle": {"center": [0, 0], "radius": -1}}, "value": 1}]}}"#,
            r#"{"version": 1, "material": {"points": [], "extra": 1}}"#,
        ] {
            assert!(MaterialDocument::from_json(text).is_err(), "{text}");
        }
        assert!(is_material_document(r#"{"version": 1, "material": {}}"#));
        assert!(!is_material_document(r#"{"version": 1, "solid": {}}"#));
        assert!(!is_material_document("x var-x"));
    }
}
