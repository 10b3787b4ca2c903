//! The solid document: a JSON description of an implicit solid built from
//! distance-like primitives, transforms, offsets and R-function operators.
//!
//! Values follow the paper's convention: omega >= 0 inside, 0 on the boundary, and
//! every primitive is first-order normalised, |grad omega| = 1 on its boundary (Shin,
//! Kim and Sheen 2007, sec. 2.1.3, eq. 1). Vectors have 2 or 3 components (a missing
//! z is 0); 2D models ignore z. The format is documented in `docs/implicit.md`:
//!
//! ```json
//! {"version": 1, "solid": {"and": {"system": {"r0": {"m": 0}}, "solids": [
//!     {"circle": {"center": [0.5, 0.5], "radius": 0.4}},
//!     {"not": {"solid": {"circle": {"center": [0.7, 0.5], "radius": 0.1}}}}]}}}
//! ```
//!
//! | key | fields | omega |
//! |---|---|---|
//! | `half_space` | `normal`, `offset` | `(offset - n.p) / |n|`, inside where `n.p <= offset` |
//! | `circle` | `center`, `radius` | `(r^2 - |p - c|^2) / 2r` in the xy plane (the paper's, Fig. 12) |
//! | `sphere` | `center`, `radius` | `(r^2 - |p - c|^2) / 2r` |
//! | `box` | `min`, `max` | `R_0` conjunction of slabs `(h^2 - (p_i - c_i)^2) / 2h` |
//! | `cylinder` | `base`, `axis`, `radius`, `height` | side `(r^2 - q^2) / 2r` AND caps slab |
//! | `torus` | `center`, `axis`, `major`, `minor` | `(r^2 - d^2) / 2r`, `d` to the core circle |
//! | `capsule` | `a`, `b`, `radius` | `(r^2 - d^2) / 2r`, `d` to the segment |
//! | `translate` | `by`, `solid` | `omega(p - by)` |
//! | `rotate` | `axis`, `degrees`, `solid` | `omega(R^-1 p)` |
//! | `scale` | `factor`, `solid` | `s omega(p / s)` |
//! | `offset` | `distance`, `solid` | `omega + distance` (grows the solid) |
//! | `and`, `or` | `system` (default `{"r0": {"m": 0}}`), `solids` | R-function chain |
//! | `not` | `solid` | `-omega` |
//! | `normalize` | `solid` | `f / sqrt(f^2 + |grad f|^2)` |

use serde::{Deserialize, Serialize};

use super::ImplicitError;
use super::expr::{Graph, NodeId};
use super::rfunc::{self, RSystem};

/// A solid document: a version and the root solid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolidDocument {
    /// Format version; 1.
    #[serde(default = "one")]
    pub version: u32,
    /// The solid.
    pub solid: Solid,
}

fn one() -> u32 {
    1
}

/// One node of a solid document.
#[allow(missing_docs)]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Solid {
    /// Inside where `normal . p <= offset`.
    HalfSpace { normal: Vec<f64>, offset: f64 },
    /// A disc in the xy plane (a cylinder along z in 3D).
    Circle { center: Vec<f64>, radius: f64 },
    /// A ball.
    Sphere { center: Vec<f64>, radius: f64 },
    /// An axis-aligned box (2 components: a rectangle in the xy plane).
    #[serde(rename = "box")]
    Cuboid { min: Vec<f64>, max: Vec<f64> },
    /// A finite cylinder from `base` along `axis` (any length; its direction counts).
    Cylinder {
        base: Vec<f64>,
        axis: Vec<f64>,
        radius: f64,
        height: f64,
    },
    /// A torus around `axis` through `center`.
    Torus {
        center: Vec<f64>,
        axis: Vec<f64>,
        major: f64,
        minor: f64,
    },
    /// The points within `radius` of the segment `a`-`b`.
    Capsule {
        a: Vec<f64>,
        b: Vec<f64>,
        radius: f64,
    },
    /// `solid` moved by `by`.
    Translate { by: Vec<f64>, solid: Box<Solid> },
    /// `solid` turned by `degrees` about `axis` (right hand) through the origin.
    Rotate {
        axis: Vec<f64>,
        degrees: f64,
        solid: Box<Solid>,
    },
    /// `solid` scaled by `factor` about the origin.
    Scale { factor: f64, solid: Box<Solid> },
    /// `solid` grown by `distance` (shrunk when negative).
    Offset { distance: f64, solid: Box<Solid> },
    /// The intersection of `solids` by an R-function conjunction.
    And {
        #[serde(default)]
        system: RSystem,
        solids: Vec<Solid>,
    },
    /// The union of `solids` by an R-function disjunction.
    Or {
        #[serde(default)]
        system: RSystem,
        solids: Vec<Solid>,
    },
    /// The complement.
    Not { solid: Box<Solid> },
    /// The first-order normalised function (sec. 2.1.4).
    Normalize { solid: Box<Solid> },
}

impl SolidDocument {
    /// Parses and checks a document.
    pub fn from_json(text: &str) -> Result<Self, ImplicitError> {
        let doc: SolidDocument = serde_json::from_str(text).map_err(ImplicitError::Json)?;
        if doc.version != 1 {
            return Err(ImplicitError::Parameter {
                at: "version".into(),
                name: "version",
                value: f64::from(doc.version),
                expected: "1",
            });
        }
        doc.solid.check("solid")?;
        Ok(doc)
    }

    /// The document as JSON (what [`from_json`](Self::from_json) reads back).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a solid document always serialises")
    }

    /// The document as a graph (omega >= 0 inside) and its root.
    pub fn to_graph(&self) -> Result<(Graph, NodeId), ImplicitError> {
        self.solid.check("solid")?;
        let mut g = Graph::new();
        let p = g.xyz();
        let root = self.solid.build(&mut g, p);
        Ok((g, root))
    }
}

/// A checked 3-vector from 2 or 3 components (z = 0 when missing).
fn vec3(at: &str, name: &'static str, v: &[f64]) -> Result<[f64; 3], ImplicitError> {
    if !(2..=3).contains(&v.len()) {
        return Err(ImplicitError::Dimension {
            at: at.to_owned(),
            name,
            found: v.len(),
        });
    }
    if let Some(&bad) = v.iter().find(|c| !c.is_finite()) {
        return Err(ImplicitError::Parameter {
            at: at.to_owned(),
            name,
            value: bad,
            expected: "finite",
        });
    }
    Ok([v[0], v[1], v.get(2).copied().unwrap_or(0.0)])
}

fn positive(at: &str, name: &'static str, v: f64) -> Result<f64, ImplicitError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(ImplicitError::Parameter {
            at: at.to_owned(),
            name,
            value: v,
            expected: "finite and positive",
        })
    }
}

fn finite(at: &str, name: &'static str, v: f64) -> Result<f64, ImplicitError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(ImplicitError::Parameter {
            at: at.to_owned(),
            name,
            value: v,
            expected: "finite",
        })
    }
}

/// A unit vector from a checked non-zero one.
fn unit(at: &str, name: &'static str, v: &[f64]) -> Result<[f64; 3], ImplicitError> {
    let v = vec3(at, name, v)?;
    let len = norm(v);
    positive(at, name, len)?;
    Ok(v.map(|c| c / len))
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The matrix of the rotation by `degrees` about unit `axis` (Rodrigues' formula).
fn rotation(axis: [f64; 3], degrees: f64) -> [[f64; 3]; 3] {
    let (s, c) = degrees.to_radians().sin_cos();
    let [x, y, z] = axis;
    let t = 1.0 - c;
    [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ]
}

/// The distance-like ball function `(r^2 - d2) / 2r` of a squared distance `d2`.
fn ball(r: f64, d2: f64) -> f64 {
    (r * r - d2) / (2.0 * r)
}

/// Builds `(r^2 - d2) / 2r` from a squared-distance node.
fn ball_node(g: &mut Graph, r: f64, d2: NodeId) -> NodeId {
    let s = g.scale(d2, -1.0 / (2.0 * r));
    g.offset(s, r / 2.0)
}

/// Nodes `p - c` per axis.
fn shifted(g: &mut Graph, p: [NodeId; 3], c: [f64; 3]) -> [NodeId; 3] {
    [0, 1, 2].map(|i| g.offset(p[i], -c[i]))
}

/// A checked vector of 2 or 3 components as 3 (z = 0 when missing).
fn v3(v: &[f64]) -> [f64; 3] {
    [v[0], v[1], v.get(2).copied().unwrap_or(0.0)]
}

/// A checked non-zero vector, normalised.
fn u3(v: &[f64]) -> [f64; 3] {
    let v = v3(v);
    let n = norm(v);
    v.map(|c| c / n)
}

/// About the axis through `origin` along unit `axis`: the axial coordinate `t`, `t^2`
/// and the squared distance from the axis `|p - origin|^2 - t^2`, as nodes.
fn axial(
    g: &mut Graph,
    p: [NodeId; 3],
    origin: [f64; 3],
    axis: [f64; 3],
) -> (NodeId, NodeId, NodeId) {
    let q = shifted(g, p, origin);
    let t = g.dot_const(&q, &axis);
    let q2 = g.norm2(&q);
    let t2 = g.square(t);
    (t, t2, g.sub(q2, t2))
}

impl Solid {
    fn children(&self) -> Vec<&Solid> {
        match self {
            Solid::Translate { solid, .. }
            | Solid::Rotate { solid, .. }
            | Solid::Scale { solid, .. }
            | Solid::Offset { solid, .. }
            | Solid::Not { solid }
            | Solid::Normalize { solid } => vec![solid],
            Solid::And { solids, .. } | Solid::Or { solids, .. } => solids.iter().collect(),
            _ => Vec::new(),
        }
    }

    /// The document key of this node.
    pub fn key(&self) -> &'static str {
        match self {
            Solid::HalfSpace { .. } => "half_space",
            Solid::Circle { .. } => "circle",
            Solid::Sphere { .. } => "sphere",
            Solid::Cuboid { .. } => "box",
            Solid::Cylinder { .. } => "cylinder",
            Solid::Torus { .. } => "torus",
            Solid::Capsule { .. } => "capsule",
            Solid::Translate { .. } => "translate",
            Solid::Rotate { .. } => "rotate",
            Solid::Scale { .. } => "scale",
            Solid::Offset { .. } => "offset",
            Solid::And { .. } => "and",
            Solid::Or { .. } => "or",
            Solid::Not { .. } => "not",
            Solid::Normalize { .. } => "normalize",
        }
    }

    /// Checks every parameter; `at` is this node's path in the document.
    pub fn check(&self, at: &str) -> Result<(), ImplicitError> {
        let here = format!("{at}.{}", self.key());
        match self {
            Solid::HalfSpace { normal, offset } => {
                unit(&here, "normal", normal)?;
                finite(&here, "offset", *offset)?;
            }
            Solid::Circle { center, radius } | Solid::Sphere { center, radius } => {
                vec3(&here, "center", center)?;
                positive(&here, "radius", *radius)?;
            }
            Solid::Cuboid { min, max } => {
                let (lo, hi) = (vec3(&here, "min", min)?, vec3(&here, "max", max)?);
                if min.len() != max.len() {
                    return Err(ImplicitError::Dimension {
                        at: here,
                        name: "max",
                        found: max.len(),
                    });
                }
                for i in 0..min.len() {
                    positive(&here, "max - min", hi[i] - lo[i])?;
                }
            }
            Solid::Cylinder {
                base,
                axis,
                radius,
                height,
            } => {
                vec3(&here, "base", base)?;
                unit(&here, "axis", axis)?;
                positive(&here, "radius", *radius)?;
                positive(&here, "height", *height)?;
            }
            Solid::Torus {
                center,
                axis,
                major,
                minor,
            } => {
                vec3(&here, "center", center)?;
                unit(&here, "axis", axis)?;
                positive(&here, "major", *major)?;
                positive(&here, "minor", *minor)?;
            }
            Solid::Capsule { a, b, radius } => {
                vec3(&here, "a", a)?;
                vec3(&here, "b", b)?;
                positive(&here, "radius", *radius)?;
            }
            Solid::Translate { by, .. } => {
                vec3(&here, "by", by)?;
            }
            Solid::Rotate { axis, degrees, .. } => {
                unit(&here, "axis", axis)?;
                finite(&here, "degrees", *degrees)?;
            }
            Solid::Scale { factor, .. } => {
                positive(&here, "factor", *factor)?;
            }
            Solid::Offset { distance, .. } => {
                finite(&here, "distance", *distance)?;
            }
            Solid::And { system, solids } | Solid::Or { system, solids } => {
                system.check(&here)?;
                if solids.is_empty() {
                    return Err(ImplicitError::Parameter {
                        at: here,
                        name: "solids",
                        value: 0.0,
                        expected: "at least one solid",
                    });
                }
            }
            Solid::Not { .. } | Solid::Normalize { .. } => {}
        }
        for (i, child) in self.children().into_iter().enumerate() {
            child.check(&format!("{here}[{i}]"))?;
        }
        Ok(())
    }

    /// Builds omega at the coordinate nodes `p` (parameters checked beforehand).
    fn build(&self, g: &mut Graph, p: [NodeId; 3]) -> NodeId {
        // Parameters were checked: `v3` and `u3` cannot fail.
        match self {
            Solid::HalfSpace { normal, offset } => {
                let n = v3(normal);
                let len = norm(n);
                let d = g.dot_const(&p, &n.map(|c| -c / len));
                g.offset(d, offset / len)
            }
            Solid::Circle { center, radius } => {
                let q = shifted(g, p, v3(center));
                let d2 = g.norm2(&q[..2]);
                ball_node(g, *radius, d2)
            }
            Solid::Sphere { center, radius } => {
                let q = shifted(g, p, v3(center));
                let d2 = g.norm2(&q);
                ball_node(g, *radius, d2)
            }
            Solid::Cuboid { min, max } => {
                let (lo, hi) = (v3(min), v3(max));
                let slabs: Vec<NodeId> = (0..min.len())
                    .map(|i| {
                        let (c, h) = ((lo[i] + hi[i]) / 2.0, (hi[i] - lo[i]) / 2.0);
                        let q = g.offset(p[i], -c);
                        let d2 = g.square(q);
                        ball_node(g, h, d2)
                    })
                    .collect();
                chain(g, RSystem::R0 { m: 0 }, &slabs, true)
            }
            Solid::Cylinder {
                base,
                axis,
                radius,
                height,
            } => {
                let (t, _, r2) = axial(g, p, v3(base), u3(axis));
                let side = ball_node(g, *radius, r2);
                let tc = g.offset(t, -height / 2.0);
                let tc2 = g.square(tc);
                let caps = ball_node(g, height / 2.0, tc2);
                RSystem::R0 { m: 0 }.and(g, side, caps)
            }
            Solid::Torus {
                center,
                axis,
                major,
                minor,
            } => {
                let (_, t2, rho2) = axial(g, p, v3(center), u3(axis));
                let zero = g.constant(0.0);
                let rho2 = g.binary(super::Binary::Max, rho2, zero);
                let rho = g.sqrt(rho2);
                let e = g.offset(rho, -major);
                let e2 = g.square(e);
                let d2 = g.add(e2, t2);
                ball_node(g, *minor, d2)
            }
            Solid::Capsule { a, b, radius } => {
                let (a, b) = (v3(a), v3(b));
                let ab = sub(b, a);
                let l2 = dot(ab, ab);
                let q = shifted(g, p, a);
                let d2 = if l2 > 0.0 {
                    let u = g.dot_const(&q, &ab.map(|c| c / l2));
                    let zero = g.constant(0.0);
                    let onec = g.constant(1.0);
                    let u = g.binary(super::Binary::Max, u, zero);
                    let t = g.binary(super::Binary::Min, u, onec);
                    let r: Vec<NodeId> = (0..3)
                        .map(|i| {
                            let s = g.scale(t, ab[i]);
                            g.sub(q[i], s)
                        })
                        .collect();
                    g.norm2(&r)
                } else {
                    g.norm2(&q)
                };
                ball_node(g, *radius, d2)
            }
            Solid::Translate { by, solid } => {
                let q = shifted(g, p, v3(by));
                solid.build(g, q)
            }
            Solid::Rotate {
                axis,
                degrees,
                solid,
            } => {
                let m = rotation(u3(axis), -degrees);
                let q = m.map(|row| g.dot_const(&p, &row));
                solid.build(g, q)
            }
            Solid::Scale { factor, solid } => {
                let q = p.map(|c| g.scale(c, 1.0 / factor));
                let w = solid.build(g, q);
                g.scale(w, *factor)
            }
            Solid::Offset { distance, solid } => {
                let w = solid.build(g, p);
                g.offset(w, *distance)
            }
            Solid::And { system, solids } | Solid::Or { system, solids } => {
                let parts: Vec<NodeId> = solids.iter().map(|s| s.build(g, p)).collect();
                chain(g, *system, &parts, matches!(self, Solid::And { .. }))
            }
            Solid::Not { solid } => {
                let w = solid.build(g, p);
                rfunc::not(g, w)
            }
            Solid::Normalize { solid } => {
                // Normalised in the child's own frame (the gradient with respect to
                // its coordinates), then moved into the caller's.
                let own = g.xyz();
                let w = solid.build(g, own);
                let n = rfunc::normalize(g, w);
                g.substitute(n, p)
            }
        }
    }

    /// omega at `p` in f64 by a direct walk of the document (no graph, no folding):
    /// the reference the compiled tapes are tested against. The normaliser's gradient
    /// is a central difference with step `fd_step`.
    pub fn eval_f64(&self, p: [f64; 3], fd_step: f64) -> f64 {
        match self {
            Solid::HalfSpace { normal, offset } => {
                let n = v3(normal);
                (offset - dot(n, p)) / norm(n)
            }
            Solid::Circle { center, radius } => {
                let c = v3(center);
                ball(*radius, (p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2))
            }
            Solid::Sphere { center, radius } => {
                let q = sub(p, v3(center));
                ball(*radius, dot(q, q))
            }
            Solid::Cuboid { min, max } => {
                let (lo, hi) = (v3(min), v3(max));
                let sys = RSystem::R0 { m: 0 };
                (0..min.len())
                    .map(|i| {
                        let h = (hi[i] - lo[i]) / 2.0;
                        ball(h, (p[i] - (lo[i] + hi[i]) / 2.0).powi(2))
                    })
                    .reduce(|a, b| sys.and_f64(a, b))
                    .unwrap_or(f64::NAN)
            }
            Solid::Cylinder {
                base,
                axis,
                radius,
                height,
            } => {
                let q = sub(p, v3(base));
                let t = dot(q, u3(axis));
                let side = ball(*radius, dot(q, q) - t * t);
                let caps = ball(height / 2.0, (t - height / 2.0).powi(2));
                RSystem::R0 { m: 0 }.and_f64(side, caps)
            }
            Solid::Torus {
                center,
                axis,
                major,
                minor,
            } => {
                let q = sub(p, v3(center));
                let t = dot(q, u3(axis));
                let rho = (dot(q, q) - t * t).max(0.0).sqrt();
                ball(*minor, (rho - major).powi(2) + t * t)
            }
            Solid::Capsule { a, b, radius } => {
                let (a, b) = (v3(a), v3(b));
                let ab = sub(b, a);
                let q = sub(p, a);
                let l2 = dot(ab, ab);
                let t = if l2 > 0.0 {
                    (dot(q, ab) / l2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let r = [0, 1, 2].map(|i| q[i] - t * ab[i]);
                ball(*radius, dot(r, r))
            }
            Solid::Translate { by, solid } => solid.eval_f64(sub(p, v3(by)), fd_step),
            Solid::Rotate {
                axis,
                degrees,
                solid,
            } => {
                let m = rotation(u3(axis), -degrees);
                solid.eval_f64(m.map(|row| dot(row, p)), fd_step)
            }
            Solid::Scale { factor, solid } => {
                factor * solid.eval_f64(p.map(|c| c / factor), fd_step)
            }
            Solid::Offset { distance, solid } => solid.eval_f64(p, fd_step) + distance,
            Solid::And { system, solids } => solids
                .iter()
                .map(|s| s.eval_f64(p, fd_step))
                .reduce(|a, b| system.and_f64(a, b))
                .unwrap_or(f64::NAN),
            Solid::Or { system, solids } => solids
                .iter()
                .map(|s| s.eval_f64(p, fd_step))
                .reduce(|a, b| system.or_f64(a, b))
                .unwrap_or(f64::NAN),
            Solid::Not { solid } => -solid.eval_f64(p, fd_step),
            Solid::Normalize { solid } => {
                let f = solid.eval_f64(p, fd_step);
                let grad2: f64 = (0..3)
                    .map(|i| {
                        let (mut a, mut b) = (p, p);
                        a[i] += fd_step;
                        b[i] -= fd_step;
                        ((solid.eval_f64(a, fd_step) - solid.eval_f64(b, fd_step))
                            / (2.0 * fd_step))
                            .powi(2)
                    })
                    .sum();
                f / (f * f + grad2).sqrt()
            }
        }
    }
}

/// Folds `parts` left to right with the system's AND (`and = true`) or OR.
fn chain(g: &mut Graph, system: RSystem, parts: &[NodeId], and: bool) -> NodeId {
    let (&first, rest) = parts.split_first().expect("checked: at least one part");
    rest.iter().fold(first, |acc, &b| {
        if and {
            system.and(g, acc, b)
        } else {
            system.or(g, acc, b)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::implicit::Model;
    use crate::implicit::expr::Var;
    use crate::implicit::tape::Tape;
    use crate::tolerance::{IMPLICIT_F32_REL, IMPLICIT_FD_STEP, IMPLICIT_UNIT_GRAD_EPS};
    use proptest::prelude::*;

    fn graph_of(s: &Solid) -> (Graph, NodeId) {
        SolidDocument {
            version: 1,
            solid: s.clone(),
        }
        .to_graph()
        .unwrap()
    }

    /// |grad omega| at `p` by the symbolic derivative, in f64.
    fn grad_norm(g: &mut Graph, root: NodeId, p: [f64; 3]) -> f64 {
        let d = [Var::X, Var::Y, Var::Z].map(|v| g.deriv(root, v));
        d.map(|n| g.eval_f64(n, p))
            .iter()
            .map(|c| c * c)
            .sum::<f64>()
            .sqrt()
    }

    /// Every primitive is zero with |grad| = 1 at points of its boundary built by hand
    /// (Shin et al. 2007, eq. 1): circle, sphere, half-space, cylinder side and caps,
    /// torus, capsule, box faces away from the edges.
    #[test]
    fn primitives_are_normalised_on_their_boundary() {
        let f = std::f64::consts::FRAC_1_SQRT_2;
        let cases: Vec<(Solid, Vec<[f64; 3]>)> = vec![
            (
                Solid::Circle {
                    center: vec![0.5, 0.5],
                    radius: 0.4,
                },
                (0..8)
                    .map(|k| {
                        let t = f64::from(k) * 0.7;
                        [0.5 + 0.4 * t.cos(), 0.5 + 0.4 * t.sin(), 3.0]
                    })
                    .collect(),
            ),
            (
                Solid::Sphere {
                    center: vec![1.0, -2.0, 0.5],
                    radius: 2.0,
                },
                vec![
                    [3.0, -2.0, 0.5],
                    [1.0, -2.0, -1.5],
                    [1.0 + 2.0 * f, -2.0 + 2.0 * f, 0.5],
                ],
            ),
            (
                Solid::HalfSpace {
                    normal: vec![3.0, 4.0, 0.0],
                    offset: 5.0,
                },
                vec![[1.0, 0.5, 7.0], [-1.0, 2.0, 0.0]],
            ),
            (
                Solid::Cylinder {
                    base: vec![0.0, 0.0, 0.0],
                    axis: vec![0.0, 0.0, 2.0],
                    radius: 1.0,
                    height: 3.0,
                },
                vec![
                    [1.0, 0.0, 1.5],
                    [0.0, -1.0, 0.7],
                    [0.2, 0.3, 3.0],
                    [0.1, -0.4, 0.0],
                ],
            ),
            (
                Solid::Torus {
                    center: vec![0.0, 0.0, 0.0],
                    axis: vec![0.0, 0.0, 1.0],
                    major: 1.0,
                    minor: 0.25,
                },
                vec![
                    [1.25, 0.0, 0.0],
                    [0.0, 0.75, 0.0],
                    [f, f, 0.25],
                    [-1.0, 0.0, -0.25],
                ],
            ),
            (
                Solid::Capsule {
                    a: vec![0.0, 0.0, 0.0],
                    b: vec![1.0, 0.0, 0.0],
                    radius: 0.5,
                },
                vec![
                    [0.5, 0.5, 0.0],
                    [-0.5, 0.0, 0.0],
                    [1.0 + 0.5 * f, 0.0, 0.5 * f],
                    [0.2, 0.0, -0.5],
                ],
            ),
            (
                Solid::Cuboid {
                    min: vec![0.0, 0.0, 0.0],
                    max: vec![2.0, 1.0, 1.0],
                },
                vec![
                    [0.0, 0.5, 0.5],
                    [2.0, 0.4, 0.6],
                    [1.0, 1.0, 0.5],
                    [1.3, 0.5, 0.0],
                ],
            ),
        ];
        for (solid, points) in cases {
            let (mut g, root) = graph_of(&solid);
            for p in points {
                assert_near!(
                    g.eval_f64(root, p),
                    0.0,
                    IMPLICIT_UNIT_GRAD_EPS,
                    "{solid:?} at {p:?}"
                );
                assert_near!(
                    grad_norm(&mut g, root, p),
                    1.0,
                    IMPLICIT_UNIT_GRAD_EPS,
                    "{solid:?} at {p:?}"
                );
            }
        }
    }

    #[test]
    fn paper_benchmark_values_match_fig_12() {
        let text = r#"{"solid": {"and": {"system": {"r0": {"m": 0}}, "solids": [
            {"circle": {"center": [0.5, 0.5], "radius": 0.4}},
            {"not": {"solid": {"circle": {"center": [0.7, 0.5], "radius": 0.1}}}}]}}}"#;
        let m = Model::from_solid_json(text).unwrap();
        // The shader of Fig. 12, written out at a few points.
        let fig12 = |x: f64, y: f64| {
            let w0 = (0.4f64.powi(2) - (x - 0.5).powi(2) - (y - 0.5).powi(2)) / 0.8;
            let w1 = -(0.1f64.powi(2) - (x - 0.7).powi(2) - (y - 0.5).powi(2)) / 0.2;
            w0 + w1 - (w0 * w0 + w1 * w1).sqrt()
        };
        for (x, y) in [(0.5, 0.5), (0.7, 0.5), (0.1, 0.1), (0.3, 0.62), (0.95, 0.2)] {
            assert_near!(
                m.graph.eval_f64(m.root, [x, y, 0.0]),
                fig12(x, y),
                crate::tolerance::IMPLICIT_F64_EPS
            );
        }
    }

    #[test]
    fn bad_documents_are_refused() {
        let bad = [
            r#"{"solid": {"circle": {"center": [0, 0], "radius": -1}}}"#,
            r#"{"solid": {"circle": {"center": [0], "radius": 1}}}"#,
            r#"{"solid": {"and": {"solids": []}}}"#,
            r#"{"solid": {"and": {"system": {"r_alpha": {"alpha": 2}}, "solids": [{"sphere": {"center": [0,0,0], "radius": 1}}]}}}"#,
            r#"{"solid": {"half_space": {"normal": [0, 0, 0], "offset": 1}}}"#,
            r#"{"solid": {"sphere": {"center": [0, 0, 0], "radius": 1, "colour": 3}}}"#,
            r#"{"version": 2, "solid": {"sphere": {"center": [0, 0, 0], "radius": 1}}}"#,
            r#"{"solid": {"blob": {}}}"#,
            "{",
        ];
        for text in bad {
            assert!(SolidDocument::from_json(text).is_err(), "{text}");
        }
    }

    fn vecn(n: usize) -> impl Strategy<Value = Vec<f64>> {
        proptest::collection::vec(-1.0f64..1.0, n)
    }

    fn primitive() -> impl Strategy<Value = Solid> {
        prop_oneof![
            (vecn(3), -1.0f64..1.0).prop_map(|(mut n, offset)| {
                n[0] += 2.0;
                Solid::HalfSpace { normal: n, offset }
            }),
            (vecn(2), 0.1f64..1.0).prop_map(|(center, radius)| Solid::Circle { center, radius }),
            (vecn(3), 0.1f64..1.0).prop_map(|(center, radius)| Solid::Sphere { center, radius }),
            (vecn(3), vecn(3)).prop_map(|(min, d)| Solid::Cuboid {
                max: min.iter().zip(&d).map(|(a, b)| a + 1.1 + b).collect(),
                min
            }),
            (vecn(3), vecn(3), 0.1f64..1.0, 0.1f64..2.0).prop_map(
                |(base, mut axis, radius, height)| {
                    axis[2] += 2.0;
                    Solid::Cylinder {
                        base,
                        axis,
                        radius,
                        height,
                    }
                }
            ),
            (vecn(3), vecn(3), 0.5f64..1.0, 0.05f64..0.4).prop_map(
                |(center, mut axis, major, minor)| {
                    axis[1] += 2.0;
                    Solid::Torus {
                        center,
                        axis,
                        major,
                        minor,
                    }
                }
            ),
            (vecn(3), vecn(3), 0.1f64..1.0).prop_map(|(a, b, radius)| Solid::Capsule {
                a,
                b,
                radius
            }),
        ]
    }

    fn system() -> impl Strategy<Value = RSystem> {
        prop_oneof![
            (-0.9f64..=1.0).prop_map(|alpha| RSystem::RAlpha { alpha }),
            (0u32..=2).prop_map(|m| RSystem::R0 { m }),
            (1u32..=3).prop_map(|h| RSystem::Rp { p: 2 * h }),
            Just(RSystem::MinMax),
        ]
    }

    fn solid() -> impl Strategy<Value = Solid> {
        primitive().prop_recursive(3, 12, 3, |inner| {
            prop_oneof![
                (vecn(3), inner.clone()).prop_map(|(by, s)| Solid::Translate {
                    by,
                    solid: Box::new(s)
                }),
                (vecn(3), -180.0f64..180.0, inner.clone()).prop_map(|(mut axis, degrees, s)| {
                    axis[0] += 2.0;
                    Solid::Rotate {
                        axis,
                        degrees,
                        solid: Box::new(s),
                    }
                }),
                (0.5f64..2.0, inner.clone()).prop_map(|(factor, s)| Solid::Scale {
                    factor,
                    solid: Box::new(s)
                }),
                (-0.2f64..0.2, inner.clone()).prop_map(|(distance, s)| Solid::Offset {
                    distance,
                    solid: Box::new(s)
                }),
                (system(), proptest::collection::vec(inner.clone(), 1..4))
                    .prop_map(|(system, solids)| Solid::And { system, solids }),
                (system(), proptest::collection::vec(inner.clone(), 1..4))
                    .prop_map(|(system, solids)| Solid::Or { system, solids }),
                inner
                    .clone()
                    .prop_map(|s| Solid::Not { solid: Box::new(s) }),
                inner.prop_map(|s| Solid::Normalize { solid: Box::new(s) }),
            ]
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// The compiled f32 tape agrees with the direct f64 walk of the document, and
        /// the JSON text round-trips.
        #[test]
        fn tape_agrees_with_the_tree_walk(s in solid(),
                pts in proptest::collection::vec((-1.5f64..1.5, -1.5f64..1.5, -1.5f64..1.5), 8)) {
            let doc = SolidDocument { version: 1, solid: s };
            let text = doc.to_json();
            let back = SolidDocument::from_json(&text).unwrap();
            prop_assert_eq!(&back, &doc);
            let (g, root) = doc.to_graph().unwrap();
            let tape = Tape::compile(&g, root);
            for (x, y, z) in pts {
                let want = doc.solid.eval_f64([x, y, z], IMPLICIT_FD_STEP);
                let graph = g.eval_f64(root, [x, y, z]);
                let got = f64::from(tape.eval_point([x as f32, y as f32, z as f32]));
                if !want.is_finite() { continue; }
                // f32 rounding is relative to the largest intermediate value (the
                // R-functions cancel large terms: regression, an OR of a chain of
                // R_0^1 conjunctions 2^18 in size).
                let scale = 1.0 + (0..=root.index())
                    .map(|i| g.eval_f64(NodeId(i as u32), [x, y, z]).abs())
                    .filter(|v| v.is_finite())
                    .fold(want.abs(), f64::max);
                // The f64 graph differs from the walk only by the normaliser's finite
                // difference; the f32 tape by rounding (inputs rounded to f32 too).
                prop_assert!((graph - want).abs() <= IMPLICIT_F32_REL * scale, "graph {graph} vs walk {want}");
                prop_assert!((got - want).abs() <= 10.0 * IMPLICIT_F32_REL * scale, "tape {got} vs walk {want}");
            }
        }

        #[test]
        fn arbitrary_json_never_panics(text in "\\PC{0,120}") {
            let _ = SolidDocument::from_json(&text);
        }

        #[test]
        fn mangled_documents_never_panic(s in solid(), cut in 0usize..400, junk in "[\\[\\]{}:,0-9a-z\"-]{0,6}") {
            let text = serde_json::to_string(&SolidDocument { version: 1, solid: s }).unwrap();
            let cut = cut.min(text.len());
            let mangled = format!("{}{}{}", &text[..cut], junk, &text[cut..]);
            if let Ok(doc) = SolidDocument::from_json(&mangled) {
                let (g, root) = doc.to_graph().unwrap();
                let _ = Tape::compile(&g, root).eval_point([0.1, 0.2, 0.3]);
            }
        }
    }
}
