//! The expression graph: variables x, y, z, constants and Fidget's `.vm` op set.
//!
//! A [`Graph`] is an arena of [`Node`]s that is hash-consed (building a node that
//! exists returns the existing one, so common subexpressions are merged) and
//! constant-folded (an op whose arguments are all constants becomes a constant, in
//! f64). Nodes are only ever appended and refer to earlier nodes, so the arena order
//! is a topological order.
//!
//! The op semantics follow Fidget's (`fidget` 0.5, `Context::from_text`): `compare`
//! is -1, 0 or 1 (NaN when either side is NaN); `mod` is the least non-negative
//! remainder; `and(a, b)` is `a` when `a` is zero and `b` otherwise; `or(a, b)` is `a`
//! when `a` is non-zero and `b` otherwise; `not(a)` is 1 when `a` is zero and 0
//! otherwise.

use std::collections::HashMap;

use super::rsystem::MonotoneR;

/// A coordinate variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Var {
    /// x.
    X,
    /// y.
    Y,
    /// z.
    Z,
}

impl Var {
    /// The axis index (0, 1, 2).
    pub fn index(self) -> usize {
        self as usize
    }
}

/// A one-argument op.
#[allow(missing_docs)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Unary {
    Neg,
    Abs,
    Recip,
    Sqrt,
    Square,
    Floor,
    Ceil,
    Round,
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Exp,
    Ln,
    Not,
}

/// A two-argument op.
#[allow(missing_docs)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Binary {
    Add,
    Sub,
    Mul,
    Div,
    Min,
    Max,
    Atan2,
    Compare,
    Mod,
    And,
    Or,
}

impl Unary {
    /// Every unary op, in `.vm` spelling order.
    pub const ALL: [Unary; 17] = [
        Unary::Neg,
        Unary::Abs,
        Unary::Recip,
        Unary::Sqrt,
        Unary::Square,
        Unary::Floor,
        Unary::Ceil,
        Unary::Round,
        Unary::Sin,
        Unary::Cos,
        Unary::Tan,
        Unary::Asin,
        Unary::Acos,
        Unary::Atan,
        Unary::Exp,
        Unary::Ln,
        Unary::Not,
    ];

    /// The `.vm` spelling.
    pub fn name(self) -> &'static str {
        match self {
            Unary::Neg => "neg",
            Unary::Abs => "abs",
            Unary::Recip => "recip",
            Unary::Sqrt => "sqrt",
            Unary::Square => "square",
            Unary::Floor => "floor",
            Unary::Ceil => "ceil",
            Unary::Round => "round",
            Unary::Sin => "sin",
            Unary::Cos => "cos",
            Unary::Tan => "tan",
            Unary::Asin => "asin",
            Unary::Acos => "acos",
            Unary::Atan => "atan",
            Unary::Exp => "exp",
            Unary::Ln => "ln",
            Unary::Not => "not",
        }
    }

    /// The op applied to a number.
    pub fn apply<T: Scalar>(self, a: T) -> T {
        match self {
            Unary::Neg => -a,
            Unary::Abs => a.abs(),
            Unary::Recip => T::ONE / a,
            Unary::Sqrt => a.sqrt(),
            Unary::Square => a * a,
            Unary::Floor => a.floor(),
            Unary::Ceil => a.ceil(),
            Unary::Round => a.round(),
            Unary::Sin => a.sin(),
            Unary::Cos => a.cos(),
            Unary::Tan => a.tan(),
            Unary::Asin => a.asin(),
            Unary::Acos => a.acos(),
            Unary::Atan => a.atan(),
            Unary::Exp => a.exp(),
            Unary::Ln => a.ln(),
            Unary::Not => {
                if a.is_nan() {
                    a
                } else if a == T::ZERO {
                    T::ONE
                } else {
                    T::ZERO
                }
            }
        }
    }
}

impl Binary {
    /// Every binary op.
    pub const ALL: [Binary; 11] = [
        Binary::Add,
        Binary::Sub,
        Binary::Mul,
        Binary::Div,
        Binary::Min,
        Binary::Max,
        Binary::Atan2,
        Binary::Compare,
        Binary::Mod,
        Binary::And,
        Binary::Or,
    ];

    /// The `.vm` spelling.
    pub fn name(self) -> &'static str {
        match self {
            Binary::Add => "add",
            Binary::Sub => "sub",
            Binary::Mul => "mul",
            Binary::Div => "div",
            Binary::Min => "min",
            Binary::Max => "max",
            Binary::Atan2 => "atan2",
            Binary::Compare => "compare",
            Binary::Mod => "mod",
            Binary::And => "and",
            Binary::Or => "or",
        }
    }

    /// Whether `op(a, b) == op(b, a)` (operands are then sorted for merging).
    pub fn commutes(self) -> bool {
        matches!(self, Binary::Add | Binary::Mul | Binary::Min | Binary::Max)
    }

    /// The op applied to numbers (`atan2(a, b)` is the angle of the point `(b, a)`).
    pub fn apply<T: Scalar>(self, a: T, b: T) -> T {
        match self {
            Binary::Add => a + b,
            Binary::Sub => a - b,
            Binary::Mul => a * b,
            Binary::Div => a / b,
            Binary::Min => a.min_nan(b),
            Binary::Max => a.max_nan(b),
            Binary::Atan2 => a.atan2(b),
            Binary::Compare => {
                if a.is_nan() || b.is_nan() {
                    T::NAN
                } else if a < b {
                    -T::ONE
                } else if a > b {
                    T::ONE
                } else {
                    T::ZERO
                }
            }
            Binary::Mod => a.rem_euclid(b),
            Binary::And => {
                if a == T::ZERO {
                    a
                } else {
                    b
                }
            }
            Binary::Or => {
                if a != T::ZERO {
                    a
                } else {
                    b
                }
            }
        }
    }
}

/// The floating-point types the ops are evaluated in (f32 on tapes, f64 in tree walks
/// and constant folding).
pub trait Scalar:
    Copy
    + PartialOrd
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
    + std::ops::Neg<Output = Self>
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// NaN.
    const NAN: Self;
    #[allow(missing_docs)]
    fn abs(self) -> Self;
    #[allow(missing_docs)]
    fn sqrt(self) -> Self;
    #[allow(missing_docs)]
    fn floor(self) -> Self;
    #[allow(missing_docs)]
    fn ceil(self) -> Self;
    #[allow(missing_docs)]
    fn round(self) -> Self;
    #[allow(missing_docs)]
    fn sin(self) -> Self;
    #[allow(missing_docs)]
    fn cos(self) -> Self;
    #[allow(missing_docs)]
    fn tan(self) -> Self;
    #[allow(missing_docs)]
    fn asin(self) -> Self;
    #[allow(missing_docs)]
    fn acos(self) -> Self;
    #[allow(missing_docs)]
    fn atan(self) -> Self;
    #[allow(missing_docs)]
    fn exp(self) -> Self;
    #[allow(missing_docs)]
    fn ln(self) -> Self;
    #[allow(missing_docs)]
    fn atan2(self, x: Self) -> Self;
    #[allow(missing_docs)]
    fn rem_euclid(self, b: Self) -> Self;
    #[allow(missing_docs)]
    fn is_nan(self) -> bool;
    /// The smaller, NaN when either is NaN (unlike `f64::min`).
    fn min_nan(self, b: Self) -> Self;
    /// The larger, NaN when either is NaN.
    fn max_nan(self, b: Self) -> Self;
}

macro_rules! impl_scalar {
    ($t:ty) => {
        impl Scalar for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const NAN: Self = <$t>::NAN;
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            fn floor(self) -> Self {
                <$t>::floor(self)
            }
            fn ceil(self) -> Self {
                <$t>::ceil(self)
            }
            fn round(self) -> Self {
                <$t>::round(self)
            }
            fn sin(self) -> Self {
                <$t>::sin(self)
            }
            fn cos(self) -> Self {
                <$t>::cos(self)
            }
            fn tan(self) -> Self {
                <$t>::tan(self)
            }
            fn asin(self) -> Self {
                <$t>::asin(self)
            }
            fn acos(self) -> Self {
                <$t>::acos(self)
            }
            fn atan(self) -> Self {
                <$t>::atan(self)
            }
            fn exp(self) -> Self {
                <$t>::exp(self)
            }
            fn ln(self) -> Self {
                <$t>::ln(self)
            }
            fn atan2(self, x: Self) -> Self {
                <$t>::atan2(self, x)
            }
            fn rem_euclid(self, b: Self) -> Self {
                <$t>::rem_euclid(self, b)
            }
            fn is_nan(self) -> bool {
                <$t>::is_nan(self)
            }
            fn min_nan(self, b: Self) -> Self {
                if self.is_nan() || b.is_nan() {
                    <$t>::NAN
                } else {
                    self.min(b)
                }
            }
            fn max_nan(self, b: Self) -> Self {
                if self.is_nan() || b.is_nan() {
                    <$t>::NAN
                } else {
                    self.max(b)
                }
            }
        }
    };
}
impl_scalar!(f32);
impl_scalar!(f64);

/// A node's index in its [`Graph`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeId(pub u32);

impl NodeId {
    /// The arena index.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// One node of the graph. Constants are kept as f64 bit patterns so that nodes hash.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Node {
    /// A coordinate.
    Var(Var),
    /// A constant (the bits of an f64).
    Const(u64),
    /// A one-argument op.
    Unary(Unary, NodeId),
    /// A two-argument op.
    Binary(Binary, NodeId, NodeId),
}

/// A node known to be a monotone R-function of two other nodes (recorded by
/// [`RSystem::and`](super::rfunc::RSystem::and) and `or`): the interval pass bounds it
/// by its values at the corners of its arguments' box instead of by its formula's ops
/// ([`MonotoneR`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RBound {
    /// The node holding the R-function's value.
    pub root: NodeId,
    /// Its two arguments.
    pub args: [NodeId; 2],
    /// Which R-function.
    pub op: MonotoneR,
}

/// A hash-consed, constant-folded expression graph.
#[derive(Debug, Clone, Default)]
pub struct Graph {
    nodes: Vec<Node>,
    index: HashMap<Node, NodeId>,
    bounds: Vec<RBound>,
}

impl Graph {
    /// An empty graph.
    pub fn new() -> Self {
        Self::default()
    }

    /// The number of distinct nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether the graph has no nodes.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Records that `root` is the monotone R-function `op` of `args` ([`RBound`]).
    pub fn mark_monotone(&mut self, root: NodeId, args: [NodeId; 2], op: MonotoneR) {
        let b = RBound { root, args, op };
        if !self.bounds.contains(&b) {
            self.bounds.push(b);
        }
    }

    /// The nodes recorded by [`mark_monotone`](Self::mark_monotone).
    pub fn monotone_ops(&self) -> &[RBound] {
        &self.bounds
    }

    /// The node behind an id.
    pub fn node(&self, id: NodeId) -> Node {
        self.nodes[id.index()]
    }

    /// The constant value of a node, if it is one.
    pub fn const_value(&self, id: NodeId) -> Option<f64> {
        match self.node(id) {
            Node::Const(bits) => Some(f64::from_bits(bits)),
            _ => None,
        }
    }

    fn intern(&mut self, node: Node) -> NodeId {
        if let Some(&id) = self.index.get(&node) {
            return id;
        }
        let id = NodeId(self.nodes.len() as u32);
        self.nodes.push(node);
        self.index.insert(node, id);
        id
    }

    /// The coordinate `v`.
    pub fn var(&mut self, v: Var) -> NodeId {
        self.intern(Node::Var(v))
    }

    /// x, y and z.
    pub fn xyz(&mut self) -> [NodeId; 3] {
        [self.var(Var::X), self.var(Var::Y), self.var(Var::Z)]
    }

    /// A constant (NaN is allowed here; the readers refuse it in their input).
    pub fn constant(&mut self, value: f64) -> NodeId {
        self.intern(Node::Const(value.to_bits()))
    }

    /// `op(a)`, folded when `a` is a constant.
    pub fn unary(&mut self, op: Unary, a: NodeId) -> NodeId {
        if let Some(c) = self.const_value(a) {
            return self.constant(op.apply(c));
        }
        if op == Unary::Neg
            && let Node::Unary(Unary::Neg, inner) = self.node(a)
        {
            return inner;
        }
        self.intern(Node::Unary(op, a))
    }

    /// `op(a, b)`, folded when both are constants; `a - 0`, `a * 1`, `a / 1`,
    /// `min(a, a)` and `max(a, a)` are `a` (identities exact in IEEE arithmetic, signed
    /// zeros included; `a + 0` is not one: `-0 + 0 = +0`); commutative ops sort their
    /// operands so that `a + b` and `b + a` merge.
    pub fn binary(&mut self, op: Binary, a: NodeId, b: NodeId) -> NodeId {
        let (ca, cb) = (self.const_value(a), self.const_value(b));
        if let (Some(x), Some(y)) = (ca, cb) {
            return self.constant(op.apply(x, y));
        }
        match (op, ca, cb) {
            (Binary::Sub, _, Some(0.0)) => return a,
            (Binary::Mul, _, Some(o)) | (Binary::Div, _, Some(o)) if o == 1.0 => return a,
            (Binary::Mul, Some(1.0), _) => return b,
            (Binary::Min | Binary::Max, _, _) if a == b => return a,
            _ => {}
        }
        let (a, b) = if op.commutes() && b < a {
            (b, a)
        } else {
            (a, b)
        };
        self.intern(Node::Binary(op, a, b))
    }

    /// `a + b`.
    pub fn add(&mut self, a: NodeId, b: NodeId) -> NodeId {
        self.binary(Binary::Add, a, b)
    }
    /// `a - b`.
    pub fn sub(&mut self, a: NodeId, b: NodeId) -> NodeId {
        self.binary(Binary::Sub, a, b)
    }
    /// `a * b`.
    pub fn mul(&mut self, a: NodeId, b: NodeId) -> NodeId {
        self.binary(Binary::Mul, a, b)
    }
    /// `a / b`.
    pub fn div(&mut self, a: NodeId, b: NodeId) -> NodeId {
        self.binary(Binary::Div, a, b)
    }
    /// `a * a`.
    pub fn square(&mut self, a: NodeId) -> NodeId {
        self.unary(Unary::Square, a)
    }
    /// `sqrt(a)`.
    pub fn sqrt(&mut self, a: NodeId) -> NodeId {
        self.unary(Unary::Sqrt, a)
    }
    /// `-a`.
    pub fn neg(&mut self, a: NodeId) -> NodeId {
        self.unary(Unary::Neg, a)
    }
    /// `a * c` for a constant `c`.
    pub fn scale(&mut self, a: NodeId, c: f64) -> NodeId {
        let c = self.constant(c);
        self.mul(a, c)
    }
    /// `a + c` for a constant `c`.
    pub fn offset(&mut self, a: NodeId, c: f64) -> NodeId {
        let c = self.constant(c);
        self.add(a, c)
    }
    /// The sum of squares of `v`.
    pub fn norm2(&mut self, v: &[NodeId]) -> NodeId {
        let squares: Vec<NodeId> = v.iter().map(|&c| self.square(c)).collect();
        self.sum(&squares)
    }
    /// The sum of `v` (0 when empty).
    pub fn sum(&mut self, v: &[NodeId]) -> NodeId {
        match v.split_first() {
            None => self.constant(0.0),
            Some((&first, rest)) => rest.iter().fold(first, |acc, &t| self.add(acc, t)),
        }
    }
    /// The dot product of node vector `v` with constant vector `c`; terms whose
    /// coefficient is 0 are left out (exact for finite coordinates).
    pub fn dot_const(&mut self, v: &[NodeId], c: &[f64]) -> NodeId {
        let terms: Vec<NodeId> = v
            .iter()
            .zip(c)
            .filter(|&(_, &k)| k != 0.0)
            .map(|(&n, &k)| self.scale(n, k))
            .collect();
        self.sum(&terms)
    }

    /// `root` with x, y and z replaced by the nodes `xyz` (a change of coordinates).
    pub fn substitute(&mut self, root: NodeId, xyz: [NodeId; 3]) -> NodeId {
        let mut map: Vec<NodeId> = Vec::with_capacity(root.index() + 1);
        for i in 0..=root.index() {
            let m = match self.nodes[i] {
                Node::Var(v) => xyz[v.index()],
                Node::Const(_) => NodeId(i as u32),
                Node::Unary(op, a) => self.unary(op, map[a.index()]),
                Node::Binary(op, a, b) => self.binary(op, map[a.index()], map[b.index()]),
            };
            map.push(m);
        }
        // The R-functions below `root` stay R-functions of the substituted arguments.
        let marked: Vec<RBound> = self
            .bounds
            .iter()
            .filter(|b| b.root.index() <= root.index())
            .copied()
            .collect();
        for b in marked {
            let args = b.args.map(|a| map[a.index()]);
            self.mark_monotone(map[b.root.index()], args, b.op);
        }
        map[root.index()]
    }

    /// Evaluates `root` at `p` in f64 over the graph (every node up to the root, in
    /// order).
    pub fn eval_f64(&self, root: NodeId, p: [f64; 3]) -> f64 {
        let mut values = Vec::with_capacity(root.index() + 1);
        for node in &self.nodes[..=root.index()] {
            let v = match *node {
                Node::Var(v) => p[v.index()],
                Node::Const(bits) => f64::from_bits(bits),
                Node::Unary(op, a) => op.apply(values[a.index()]),
                Node::Binary(op, a, b) => op.apply(values[a.index()], values[b.index()]),
            };
            values.push(v);
        }
        values[root.index()]
    }

    /// The symbolic partial derivative of `root` with respect to `var`, as a node of
    /// this graph. Non-differentiable points take a one-sided or averaged value:
    /// `abs` uses the sign (0 at 0), `min`/`max` average the two sides at a tie, and
    /// the step ops (`floor`, `compare`, `not`, ...) have derivative 0.
    pub fn deriv(&mut self, root: NodeId, var: Var) -> NodeId {
        let mut d: Vec<NodeId> = Vec::with_capacity(root.index() + 1);
        for i in 0..=root.index() {
            let node = self.nodes[i];
            let id = NodeId(i as u32);
            let di = match node {
                Node::Var(v) => self.constant(if v == var { 1.0 } else { 0.0 }),
                Node::Const(_) => self.constant(0.0),
                Node::Unary(op, a) => self.deriv_unary(op, a, id, d[a.index()]),
                Node::Binary(op, a, b) => self.deriv_binary(op, a, b, d[a.index()], d[b.index()]),
            };
            d.push(di);
        }
        d[root.index()]
    }

    fn deriv_unary(&mut self, op: Unary, a: NodeId, out: NodeId, da: NodeId) -> NodeId {
        let zero = self.constant(0.0);
        let one = self.constant(1.0);
        let factor = match op {
            Unary::Neg => self.constant(-1.0),
            Unary::Abs => self.binary(Binary::Compare, a, zero),
            Unary::Recip => {
                let s = self.square(a);
                let r = self.div(one, s);
                self.neg(r)
            }
            Unary::Sqrt => {
                let two = self.scale(out, 2.0);
                self.div(one, two)
            }
            Unary::Square => self.scale(a, 2.0),
            Unary::Floor | Unary::Ceil | Unary::Round | Unary::Not => zero,
            Unary::Sin => self.unary(Unary::Cos, a),
            Unary::Cos => {
                let s = self.unary(Unary::Sin, a);
                self.neg(s)
            }
            Unary::Tan => {
                let c = self.unary(Unary::Cos, a);
                let c2 = self.square(c);
                self.div(one, c2)
            }
            Unary::Asin | Unary::Acos => {
                let s = self.square(a);
                let m = self.sub(one, s);
                let r = self.sqrt(m);
                let f = self.div(one, r);
                if op == Unary::Acos { self.neg(f) } else { f }
            }
            Unary::Atan => {
                let s = self.square(a);
                let p = self.add(one, s);
                self.div(one, p)
            }
            Unary::Exp => out,
            Unary::Ln => self.div(one, a),
        };
        self.mul(factor, da)
    }

    fn deriv_binary(&mut self, op: Binary, a: NodeId, b: NodeId, da: NodeId, db: NodeId) -> NodeId {
        let half = self.constant(0.5);
        match op {
            Binary::Add => self.add(da, db),
            Binary::Sub => self.sub(da, db),
            Binary::Mul => {
                let l = self.mul(da, b);
                let r = self.mul(a, db);
                self.add(l, r)
            }
            Binary::Div => {
                let l = self.mul(da, b);
                let r = self.mul(a, db);
                let n = self.sub(l, r);
                let s = self.square(b);
                self.div(n, s)
            }
            Binary::Min | Binary::Max => {
                // c = compare(a, b); weight of a is (1 - c) / 2 for min, (1 + c) / 2 for max.
                let c = self.binary(Binary::Compare, a, b);
                let hc = self.mul(c, half);
                let (wa, wb) = if op == Binary::Min {
                    (self.sub(half, hc), self.add(half, hc))
                } else {
                    (self.add(half, hc), self.sub(half, hc))
                };
                let l = self.mul(wa, da);
                let r = self.mul(wb, db);
                self.add(l, r)
            }
            Binary::Atan2 => {
                // d atan2(a, b) = (b da - a db) / (a^2 + b^2).
                let l = self.mul(b, da);
                let r = self.mul(a, db);
                let n = self.sub(l, r);
                let s = self.norm2(&[a, b]);
                self.div(n, s)
            }
            Binary::Compare => self.constant(0.0),
            Binary::Mod => {
                let q = self.div(a, b);
                let f = self.unary(Unary::Floor, q);
                let t = self.mul(f, db);
                self.sub(da, t)
            }
            Binary::And | Binary::Or => {
                // and: da where a == 0, else db; or: the other way round.
                let z = self.unary(Unary::Not, a);
                let one = self.constant(1.0);
                let nz = self.sub(one, z);
                let (wa, wb) = if op == Binary::And { (z, nz) } else { (nz, z) };
                let l = self.mul(wa, da);
                let r = self.mul(wb, db);
                self.add(l, r)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::tolerance::IMPLICIT_F64_EPS;

    #[test]
    fn common_subexpressions_merge() {
        let mut g = Graph::new();
        let [x, y, _] = g.xyz();
        let a = g.add(x, y);
        let b = g.add(y, x);
        assert_eq!(a, b);
        let n = g.len();
        let _ = g.add(x, y);
        assert_eq!(g.len(), n);
    }

    #[test]
    fn constants_fold() {
        let mut g = Graph::new();
        let two = g.constant(2.0);
        let three = g.constant(3.0);
        let p = g.mul(two, three);
        assert_eq!(g.const_value(p), Some(6.0));
        let s = g.sqrt(p);
        assert_near!(g.const_value(s).unwrap(), 6f64.sqrt(), IMPLICIT_F64_EPS);
    }

    #[test]
    fn symbolic_derivative_matches_central_difference() {
        let mut g = Graph::new();
        let [x, y, z] = g.xyz();
        let s = g.unary(Unary::Sin, x);
        let m = g.mul(s, y);
        let e = g.unary(Unary::Exp, z);
        let q = g.div(m, e);
        let a = g.binary(Binary::Atan2, q, y);
        let root = g.binary(Binary::Max, a, x);
        let p = [0.3, 0.7, -0.2];
        for v in [Var::X, Var::Y, Var::Z] {
            let d = g.deriv(root, v);
            let h = crate::tolerance::IMPLICIT_FD_STEP;
            let mut pp = p;
            let mut pm = p;
            pp[v.index()] += h;
            pm[v.index()] -= h;
            let fd = (g.eval_f64(root, pp) - g.eval_f64(root, pm)) / (2.0 * h);
            assert_near!(g.eval_f64(d, p), fd, crate::tolerance::IMPLICIT_FD_EPS);
        }
    }
}
