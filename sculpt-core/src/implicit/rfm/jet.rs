//! Second-order jets in the plane: a value with its gradient and Hessian in (x, y),
//! carried through an expression graph by the chain rule (forward-mode automatic
//! differentiation of second order).
//!
//! The solution structure of the R-function method (Shin, Kim and Sheen 2007, eq. 8)
//! contains `grad omega . grad Phi`, so the energy's integrand (eq. 11) needs the
//! Hessian of omega; [`JetProgram`] evaluates the models' graph once per point for
//! every field the structure uses.

use std::cmp::Ordering;
use std::ops::{Add, Div, Mul, Neg, Sub};

use crate::implicit::expr::{Graph, Node, NodeId, Scalar, Var};
use crate::implicit::tape::reachable;

/// A value `v` with its derivatives in x and y up to the second order.
#[derive(Debug, Clone, Copy, Default)]
pub struct Jet2 {
    /// The value.
    pub v: f64,
    /// d/dx.
    pub dx: f64,
    /// d/dy.
    pub dy: f64,
    /// d2/dx2.
    pub dxx: f64,
    /// d2/dxdy.
    pub dxy: f64,
    /// d2/dy2.
    pub dyy: f64,
}

impl Jet2 {
    /// A constant.
    pub const fn constant(v: f64) -> Self {
        Self {
            v,
            dx: 0.0,
            dy: 0.0,
            dxx: 0.0,
            dxy: 0.0,
            dyy: 0.0,
        }
    }

    /// The coordinate `var` at the point `p` (z is a constant: the plane problems are in
    /// x and y).
    pub fn var(var: Var, p: [f64; 2]) -> Self {
        match var {
            Var::X => Self {
                dx: 1.0,
                ..Self::constant(p[0])
            },
            Var::Y => Self {
                dy: 1.0,
                ..Self::constant(p[1])
            },
            Var::Z => Self::constant(0.0),
        }
    }

    /// The gradient `[d/dx, d/dy]`.
    pub fn grad(&self) -> [f64; 2] {
        [self.dx, self.dy]
    }

    /// `f(self)` for a function with value `f0`, first derivative `f1` and second `f2`
    /// at `self.v` (the chain rule: `grad f = f1 grad g`, `H f = f1 H g + f2 grad g grad g^T`).
    fn chain(self, f0: f64, f1: f64, f2: f64) -> Self {
        Self {
            v: f0,
            dx: f1 * self.dx,
            dy: f1 * self.dy,
            dxx: f1 * self.dxx + f2 * self.dx * self.dx,
            dxy: f1 * self.dxy + f2 * self.dx * self.dy,
            dyy: f1 * self.dyy + f2 * self.dy * self.dy,
        }
    }

    /// The derivatives of `d` with the value `v`.
    fn with_value(d: Self, v: f64) -> Self {
        Self { v, ..d }
    }
}

impl PartialEq for Jet2 {
    fn eq(&self, other: &Self) -> bool {
        self.v == other.v
    }
}

impl PartialOrd for Jet2 {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        self.v.partial_cmp(&other.v)
    }
}

impl Add for Jet2 {
    type Output = Self;
    fn add(self, b: Self) -> Self {
        Self {
            v: self.v + b.v,
            dx: self.dx + b.dx,
            dy: self.dy + b.dy,
            dxx: self.dxx + b.dxx,
            dxy: self.dxy + b.dxy,
            dyy: self.dyy + b.dyy,
        }
    }
}

impl Sub for Jet2 {
    type Output = Self;
    fn sub(self, b: Self) -> Self {
        self + (-b)
    }
}

impl Neg for Jet2 {
    type Output = Self;
    fn neg(self) -> Self {
        Self {
            v: -self.v,
            dx: -self.dx,
            dy: -self.dy,
            dxx: -self.dxx,
            dxy: -self.dxy,
            dyy: -self.dyy,
        }
    }
}

impl Mul for Jet2 {
    type Output = Self;
    fn mul(self, b: Self) -> Self {
        let a = self;
        Self {
            v: a.v * b.v,
            dx: a.v * b.dx + a.dx * b.v,
            dy: a.v * b.dy + a.dy * b.v,
            dxx: a.v * b.dxx + 2.0 * a.dx * b.dx + a.dxx * b.v,
            dxy: a.v * b.dxy + a.dx * b.dy + a.dy * b.dx + a.dxy * b.v,
            dyy: a.v * b.dyy + 2.0 * a.dy * b.dy + a.dyy * b.v,
        }
    }
}

impl Div for Jet2 {
    type Output = Self;
    fn div(self, b: Self) -> Self {
        let r = 1.0 / b.v;
        self * b.chain(r, -r * r, 2.0 * r * r * r)
    }
}

impl Scalar for Jet2 {
    const ZERO: Self = Self::constant(0.0);
    const ONE: Self = Self::constant(1.0);
    const NAN: Self = Self {
        v: f64::NAN,
        dx: f64::NAN,
        dy: f64::NAN,
        dxx: f64::NAN,
        dxy: f64::NAN,
        dyy: f64::NAN,
    };
    fn abs(self) -> Self {
        if self.v < 0.0 { -self } else { self }
    }
    fn sqrt(self) -> Self {
        let s = self.v.sqrt();
        self.chain(s, 0.5 / s, -0.25 / (s * self.v))
    }
    fn floor(self) -> Self {
        Self::constant(self.v.floor())
    }
    fn ceil(self) -> Self {
        Self::constant(self.v.ceil())
    }
    fn round(self) -> Self {
        Self::constant(self.v.round())
    }
    fn sin(self) -> Self {
        let (s, c) = self.v.sin_cos();
        self.chain(s, c, -s)
    }
    fn cos(self) -> Self {
        let (s, c) = self.v.sin_cos();
        self.chain(c, -s, -c)
    }
    fn tan(self) -> Self {
        let t = self.v.tan();
        let d = 1.0 + t * t;
        self.chain(t, d, 2.0 * t * d)
    }
    fn asin(self) -> Self {
        let q = 1.0 - self.v * self.v;
        self.chain(self.v.asin(), 1.0 / q.sqrt(), self.v / (q * q.sqrt()))
    }
    fn acos(self) -> Self {
        let q = 1.0 - self.v * self.v;
        self.chain(self.v.acos(), -1.0 / q.sqrt(), -self.v / (q * q.sqrt()))
    }
    fn atan(self) -> Self {
        let q = 1.0 + self.v * self.v;
        self.chain(self.v.atan(), 1.0 / q, -2.0 * self.v / (q * q))
    }
    fn exp(self) -> Self {
        let e = self.v.exp();
        self.chain(e, e, e)
    }
    fn ln(self) -> Self {
        let r = 1.0 / self.v;
        self.chain(self.v.ln(), r, -r * r)
    }
    fn atan2(self, x: Self) -> Self {
        // The angle differs from atan(y / x) (or -atan(x / y)) by a constant, so the
        // derivatives are those of whichever quotient is bounded.
        let d = if x.v.abs() >= self.v.abs() {
            (self / x).atan()
        } else {
            -(x / self).atan()
        };
        Self::with_value(d, self.v.atan2(x.v))
    }
    fn rem_euclid(self, b: Self) -> Self {
        let r = self.v.rem_euclid(b.v);
        let q = ((self.v - r) / b.v).round();
        Self::with_value(self - b * Self::constant(q), r)
    }
    fn is_nan(self) -> bool {
        self.v.is_nan()
    }
    fn min_nan(self, b: Self) -> Self {
        if self.v.is_nan() || b.v.is_nan() {
            Self::NAN
        } else if b.v < self.v {
            b
        } else {
            self
        }
    }
    fn max_nan(self, b: Self) -> Self {
        if self.v.is_nan() || b.v.is_nan() {
            Self::NAN
        } else if b.v > self.v {
            b
        } else {
            self
        }
    }
}

/// One instruction of a [`JetProgram`]: a graph node with its arguments renumbered into
/// the program's slots.
#[derive(Debug, Clone, Copy)]
enum Op {
    Var(Var),
    Const(f64),
    Unary(crate::implicit::expr::Unary, u32),
    Binary(crate::implicit::expr::Binary, u32, u32),
}

/// The part of a graph reachable from some roots, as straight-line code over [`Jet2`]
/// slots.
#[derive(Debug, Clone)]
pub struct JetProgram {
    ops: Vec<Op>,
    roots: Vec<u32>,
}

impl JetProgram {
    /// Compiles the nodes that `roots` reach.
    pub fn new(graph: &Graph, roots: &[NodeId]) -> Self {
        let mut live = vec![false; graph.len()];
        for &r in roots {
            for (l, r) in live.iter_mut().zip(reachable(graph, r)) {
                *l |= r;
            }
        }
        let mut slot = vec![u32::MAX; graph.len()];
        let mut ops = Vec::new();
        for (i, _) in live.iter().enumerate().filter(|(_, l)| **l) {
            let op = match graph.node(NodeId(i as u32)) {
                Node::Var(v) => Op::Var(v),
                Node::Const(bits) => Op::Const(f64::from_bits(bits)),
                Node::Unary(op, a) => Op::Unary(op, slot[a.index()]),
                Node::Binary(op, a, b) => Op::Binary(op, slot[a.index()], slot[b.index()]),
            };
            slot[i] = ops.len() as u32;
            ops.push(op);
        }
        let roots = roots.iter().map(|r| slot[r.index()]).collect();
        Self { ops, roots }
    }

    /// The number of roots.
    pub fn roots(&self) -> usize {
        self.roots.len()
    }

    /// The roots' jets at `p`, into `out` (one per root); `scratch` is reused.
    pub fn eval(&self, p: [f64; 2], scratch: &mut Vec<Jet2>, out: &mut [Jet2]) {
        scratch.clear();
        for op in &self.ops {
            let v = match *op {
                Op::Var(var) => Jet2::var(var, p),
                Op::Const(c) => Jet2::constant(c),
                Op::Unary(op, a) => op.apply(scratch[a as usize]),
                Op::Binary(op, a, b) => op.apply(scratch[a as usize], scratch[b as usize]),
            };
            scratch.push(v);
        }
        for (o, &r) in out.iter_mut().zip(&self.roots) {
            *o = scratch[r as usize];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assert_near;
    use crate::implicit::Model;
    use crate::tolerance::{IMPLICIT_FD_EPS, RFM_FD_STEP, RFM_JET_FD_REL};

    /// Every op's jet against central differences of the graph's own f64 walk, on a
    /// model that uses them all in their smooth ranges.
    #[test]
    fn jets_match_finite_differences() {
        let text = "x var-x\ny var-y\nh const 0.5\nq const 3\n\
            a mul x y\nb div a q\nc sin b\nd cos x\ne add c d\nf tan b\ng atan y\n\
            s square x\nt add s q\nu sqrt t\nv ln t\nw exp b\nk atan2 y t\n\
            l mul h s\nm asin l\nn acos l\no abs y\np min x y\nr max d g\n\
            z neg e\n\
            s1 add z f\ns2 add s1 g\ns3 add s2 u\ns4 add s3 v\ns5 add s4 w\ns6 add s5 k\n\
            s7 add s6 m\ns8 add s7 n\ns9 add s8 o\nsa add s9 p\nsb mul sa r\n\
            md mod t q\nsc add sb md\n";
        let model = Model::from_vm(text).unwrap();
        let prog = JetProgram::new(&model.graph, &[model.root]);
        let f = |p: [f64; 2]| model.graph.eval_f64(model.root, [p[0], p[1], 0.0]);
        let h = RFM_FD_STEP;
        let mut scratch = Vec::new();
        for p in [[0.3, 0.7], [-0.4, 0.2], [0.9, -0.6]] {
            let mut out = [Jet2::default()];
            prog.eval(p, &mut scratch, &mut out);
            let j = out[0];
            assert_near!(j.v, f(p), IMPLICIT_FD_EPS);
            let d = |dx: f64, dy: f64| f([p[0] + dx, p[1] + dy]);
            let fx = (d(h, 0.0) - d(-h, 0.0)) / (2.0 * h);
            let fy = (d(0.0, h) - d(0.0, -h)) / (2.0 * h);
            let fxx = (d(h, 0.0) - 2.0 * j.v + d(-h, 0.0)) / (h * h);
            let fyy = (d(0.0, h) - 2.0 * j.v + d(0.0, -h)) / (h * h);
            let fxy = (d(h, h) - d(h, -h) - d(-h, h) + d(-h, -h)) / (4.0 * h * h);
            let rel = |v: f64| RFM_JET_FD_REL * (1.0 + v.abs());
            assert_near!(j.dx, fx, rel(fx));
            assert_near!(j.dy, fy, rel(fy));
            assert_near!(j.dxx, fxx, rel(fxx));
            assert_near!(j.dxy, fxy, rel(fxy));
            assert_near!(j.dyy, fyy, rel(fyy));
        }
    }
}
