//! The `.vm` reader and writer: Fidget's plain SSA text format.
//!
//! One clause a line, `name op args...`: `name` is any token naming the clause's
//! result, `op` one of `var-x var-y var-z const` and the ops of [`Unary`] and
//! [`Binary`] (`neg abs recip sqrt square floor ceil round sin cos tan asin acos atan
//! exp ln not add sub mul div min max atan2 compare mod and or`), and the arguments
//! are names of earlier clauses (or, for `const`, a number). Blank lines and lines
//! starting with `#` are skipped. The last clause is the model's value; Fidget's
//! models are negative inside.
//!
//! ```
//! use sculpt_core::implicit::vm;
//! let p = vm::parse("a var-x\nb const 2\nc mul a b\n").unwrap();
//! sculpt_core::assert_near!(p.eval_f64([3.0, 0.0, 0.0]), 6.0, sculpt_core::tolerance::IMPLICIT_F64_EPS);
//! assert!(vm::parse("c mul a a\n").is_err()); // `a` is not defined
//! ```

use std::collections::HashMap;
use std::fmt::Write as _;

use super::expr::{Binary, Graph, Node, NodeId, Unary, Var};
use super::{ImplicitError, MAX_CLAUSES};

/// What a clause computes; arguments are indices of earlier clauses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ClauseOp {
    /// A coordinate.
    Var(Var),
    /// A constant.
    Const(f64),
    /// A one-argument op.
    Unary(Unary, usize),
    /// A two-argument op.
    Binary(Binary, usize, usize),
}

/// One parsed clause.
#[derive(Debug, Clone, PartialEq)]
pub struct Clause {
    /// The name it defines.
    pub name: String,
    /// Its 1-based line.
    pub line: usize,
    /// What it computes.
    pub op: ClauseOp,
}

/// A parsed `.vm` model, clause by clause as written (nothing merged or folded).
#[derive(Debug, Clone, PartialEq)]
pub struct VmProgram {
    /// The clauses in file order; the last is the value.
    pub clauses: Vec<Clause>,
}

fn unary_by_name(op: &str) -> Option<Unary> {
    Unary::ALL.into_iter().find(|u| u.name() == op)
}

fn binary_by_name(op: &str) -> Option<Binary> {
    Binary::ALL.into_iter().find(|b| b.name() == op)
}

/// Parses a `.vm` model.
pub fn parse(text: &str) -> Result<VmProgram, ImplicitError> {
    let mut clauses: Vec<Clause> = Vec::new();
    let mut names: HashMap<&str, (usize, usize)> = HashMap::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let trimmed = raw.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        if clauses.len() >= MAX_CLAUSES {
            return Err(ImplicitError::TooLong { max: MAX_CLAUSES });
        }
        let mut tokens = trimmed.split_whitespace();
        let name = tokens.next().unwrap_or_default();
        let Some(op) = tokens.next() else {
            return Err(ImplicitError::Arity {
                line,
                op: String::new(),
                expected: 1,
                found: 0,
            });
        };
        let args: Vec<&str> = tokens.collect();
        let arity = |expected: usize| {
            if args.len() == expected {
                Ok(())
            } else {
                Err(ImplicitError::Arity {
                    line,
                    op: op.to_owned(),
                    expected,
                    found: args.len(),
                })
            }
        };
        let lookup = |arg: &str| -> Result<usize, ImplicitError> {
            if arg == name {
                return Err(ImplicitError::Cycle {
                    line,
                    name: name.to_owned(),
                });
            }
            names
                .get(arg)
                .map(|&(idx, _)| idx)
                .ok_or_else(|| ImplicitError::Undefined {
                    line,
                    name: arg.to_owned(),
                })
        };
        let clause_op = match op {
            "var-x" | "var-y" | "var-z" => {
                arity(0)?;
                ClauseOp::Var(match op {
                    "var-x" => Var::X,
                    "var-y" => Var::Y,
                    _ => Var::Z,
                })
            }
            "const" => {
                arity(1)?;
                let value: f64 = args[0]
                    .parse()
                    .map_err(|source| ImplicitError::BadConstant {
                        line,
                        text: args[0].to_owned(),
                        source,
                    })?;
                if value.is_nan() {
                    return Err(ImplicitError::NanConstant { line });
                }
                ClauseOp::Const(value)
            }
            _ => {
                if let Some(u) = unary_by_name(op) {
                    arity(1)?;
                    ClauseOp::Unary(u, lookup(args[0])?)
                } else if let Some(b) = binary_by_name(op) {
                    arity(2)?;
                    ClauseOp::Binary(b, lookup(args[0])?, lookup(args[1])?)
                } else {
                    return Err(ImplicitError::UnknownOp {
                        line,
                        op: op.to_owned(),
                    });
                }
            }
        };
        if let Some(&(_, first)) = names.get(name) {
            return Err(ImplicitError::Redefined {
                line,
                name: name.to_owned(),
                first,
            });
        }
        names.insert(name, (clauses.len(), line));
        clauses.push(Clause {
            name: name.to_owned(),
            line,
            op: clause_op,
        });
    }
    if clauses.is_empty() {
        return Err(ImplicitError::Empty);
    }
    Ok(VmProgram { clauses })
}

impl VmProgram {
    /// Evaluates the model at `p` in f64, clause by clause as written: the reference
    /// the compiled tapes are tested against.
    pub fn eval_f64(&self, p: [f64; 3]) -> f64 {
        self.eval_f64_with_scale(p).0
    }

    /// Like [`eval_f64`](Self::eval_f64), also returning the largest magnitude of any
    /// finite intermediate value (the scale f32 rounding errors are relative to).
    pub fn eval_f64_with_scale(&self, p: [f64; 3]) -> (f64, f64) {
        let mut values: Vec<f64> = Vec::with_capacity(self.clauses.len());
        let mut scale: f64 = 0.0;
        for c in &self.clauses {
            let v = match c.op {
                ClauseOp::Var(v) => p[v.index()],
                ClauseOp::Const(k) => k,
                ClauseOp::Unary(op, a) => op.apply(values[a]),
                ClauseOp::Binary(op, a, b) => op.apply(values[a], values[b]),
            };
            if v.is_finite() {
                scale = scale.max(v.abs());
            }
            values.push(v);
        }
        (values.last().copied().unwrap_or(f64::NAN), scale)
    }

    /// The model as a graph (merged and folded) and its root.
    pub fn to_graph(&self) -> (Graph, NodeId) {
        let mut g = Graph::new();
        let mut ids: Vec<NodeId> = Vec::with_capacity(self.clauses.len());
        for c in &self.clauses {
            let id = match c.op {
                ClauseOp::Var(v) => g.var(v),
                ClauseOp::Const(k) => g.constant(k),
                ClauseOp::Unary(op, a) => g.unary(op, ids[a]),
                ClauseOp::Binary(op, a, b) => g.binary(op, ids[a], ids[b]),
            };
            ids.push(id);
        }
        let root = *ids.last().expect("parse refuses empty models");
        (g, root)
    }
}

/// Writes the part of `graph` reachable from `root` as `.vm` text (clauses named
/// `_<index in hex>`, root last). Constants are written in Rust's shortest round-trip
/// form, so reading the text back gives the same values.
pub fn write(graph: &Graph, root: NodeId) -> String {
    let live = super::tape::reachable(graph, root);
    let mut out = String::from("# written by sculpt-core implicit::vm::write\n");
    for (i, &alive) in live.iter().enumerate() {
        if !alive {
            continue;
        }
        let node = graph.node(NodeId(i as u32));
        if let Node::Const(bits) = node
            && f64::from_bits(bits).is_nan()
        {
            // The reader refuses NaN constants (folding can make one): write 0 / 0.
            let _ = writeln!(
                out,
                "_{i:x}_zero const 0\n_{i:x} div _{i:x}_zero _{i:x}_zero"
            );
            continue;
        }
        let _ = write!(out, "_{i:x} ");
        let _ = match node {
            Node::Var(Var::X) => writeln!(out, "var-x"),
            Node::Var(Var::Y) => writeln!(out, "var-y"),
            Node::Var(Var::Z) => writeln!(out, "var-z"),
            Node::Const(bits) => writeln!(out, "const {:?}", f64::from_bits(bits)),
            Node::Unary(op, a) => writeln!(out, "{} _{:x}", op.name(), a.0),
            Node::Binary(op, a, b) => writeln!(out, "{} _{:x} _{:x}", op.name(), a.0, b.0),
        };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::tolerance::{IMPLICIT_F32_REL, IMPLICIT_F64_EPS};
    use proptest::prelude::*;

    #[test]
    fn reads_fidgets_sphere_shape() {
        // The layout of Fidget's `models/sphere.vm`: hex addresses as names.
        let text = "# a sphere\n0x6000 var-x\n0x6001 square 0x6000\n0x6002 var-y\n\
                    0x6003 square 0x6002\n0x6004 var-z\n0x6005 square 0x6004\n\
                    0x6006 add 0x6001 0x6003\n0x6007 add 0x6006 0x6005\n\
                    0x6008 sqrt 0x6007\n0x6009 const 1\n0x600a sub 0x6008 0x6009\n";
        let p = parse(text).unwrap();
        assert_eq!(p.clauses.len(), 11);
        assert_near!(p.eval_f64([0.0, 3.0, 4.0]), 4.0, IMPLICIT_F64_EPS);
        assert!(p.eval_f64([0.1, 0.2, 0.3]) < 0.0);
    }

    #[test]
    fn typed_errors() {
        let e = parse("a var-x\nb frob a\n").unwrap_err();
        assert!(matches!(e, ImplicitError::UnknownOp { line: 2, ref op } if op == "frob"));
        let e = parse("b add a a\na var-x\n").unwrap_err();
        assert!(matches!(e, ImplicitError::Undefined { line: 1, ref name } if name == "a"));
        let e = parse("a var-x\nb add a b\n").unwrap_err();
        assert!(matches!(e, ImplicitError::Cycle { line: 2, .. }));
        let e = parse("a const NaN\n").unwrap_err();
        assert!(matches!(e, ImplicitError::NanConstant { line: 1 }));
        let e = parse("a const one\n").unwrap_err();
        assert!(matches!(e, ImplicitError::BadConstant { line: 1, .. }));
        let e = parse("a var-x\na var-y\n").unwrap_err();
        assert!(matches!(
            e,
            ImplicitError::Redefined {
                line: 2,
                first: 1,
                ..
            }
        ));
        let e = parse("a var-x\nb add a\n").unwrap_err();
        assert!(matches!(
            e,
            ImplicitError::Arity {
                line: 2,
                expected: 2,
                found: 1,
                ..
            }
        ));
        let e = parse("a\n").unwrap_err();
        assert!(matches!(e, ImplicitError::Arity { line: 1, .. }));
        assert!(matches!(
            parse("# only a comment\n\n").unwrap_err(),
            ImplicitError::Empty
        ));
    }

    /// A random valid program: each clause uses earlier ones.
    fn program() -> impl Strategy<Value = String> {
        let clause = (0usize..6, 0usize..1000, 0usize..1000, -4.0f64..4.0);
        proptest::collection::vec(clause, 1..40).prop_map(|cs| {
            let mut text = String::from("v0 var-x\nv1 var-y\nv2 var-z\n");
            for (k, (kind, a, b, c)) in cs.into_iter().enumerate() {
                let n = k + 3;
                let (a, b) = (a % n, b % n);
                let line = match kind {
                    0 => format!("v{n} const {c}"),
                    1 => format!("v{n} {} v{a}", Unary::ALL[b % Unary::ALL.len()].name()),
                    _ => format!(
                        "v{n} {} v{a} v{b}",
                        Binary::ALL[(c.abs() * 100.0) as usize % Binary::ALL.len()].name()
                    ),
                };
                text.push_str(&line);
                text.push('\n');
            }
            text
        })
    }

    proptest! {
        #[test]
        fn arbitrary_text_never_panics(text in "\\PC{0,200}") {
            let _ = parse(&text);
        }

        #[test]
        fn arbitrary_token_soup_never_panics(tokens in proptest::collection::vec(
            prop_oneof![Just("a"), Just("b"), Just("const"), Just("add"), Just("var-x"),
                        Just("sqrt"), Just("1e999"), Just("nan"), Just("#"), Just("\n")], 0..60)) {
            let _ = parse(&tokens.join(" "));
        }

        #[test]
        fn graph_and_written_text_agree_with_the_clauses(text in program(),
                x in -3.0f64..3.0, y in -3.0f64..3.0, z in -3.0f64..3.0) {
            let p = parse(&text).unwrap();
            let (g, root) = p.to_graph();
            let want = p.eval_f64([x, y, z]);
            let got = g.eval_f64(root, [x, y, z]);
            let again = parse(&write(&g, root)).unwrap().eval_f64([x, y, z]);
            // Folding and reordering may change rounding; NaN must stay NaN.
            prop_assert_eq!(want.is_nan(), got.is_nan());
            prop_assert_eq!(got.is_nan(), again.is_nan());
            if want.is_finite() {
                let tol = IMPLICIT_F32_REL * (1.0 + want.abs());
                prop_assert!((want - got).abs() <= tol, "{want} vs {got}");
                prop_assert!((got - again).abs() <= IMPLICIT_F64_EPS * (1.0 + got.abs()));
            }
        }
    }
}
