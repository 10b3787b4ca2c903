//! Flat tapes: the part of a graph reachable from a root, as straight-line code.
//!
//! Slot `i` of a [`Tape`] holds the result of instruction `i`, whose arguments are
//! earlier slots; the last instruction is the value. Tapes evaluate
//!
//! - one point in f32 ([`Tape::eval_point`]);
//! - many points and grids ([`Tape::eval_points`], [`Tape::eval_grid`]): instruction
//!   by instruction over blocks of [`LANES`] points, so each op is a tight loop the
//!   compiler vectorises, on a register file reused as values die, with operands that
//!   are the same in every lane (constants; on a grid row, what depends on y and z
//!   only, evaluated once per row) folded in as immediates; rows of a grid run on the
//!   rayon pool with the `parallel` feature;
//! - intervals ([`Tape::eval_interval`]);
//! - gradients by forward-mode automatic differentiation ([`Tape::eval_grad`]);
//!
//! and simplify themselves for a region ([`Tape::simplify`]): where interval
//! arithmetic shows one side of a `min`, `max`, `and` or `or` always wins, the op
//! becomes that side and what only the other side used is dropped (Fidget's interval
//! pruning; Keeter, *Massively Parallel Rendering of Complex Closed-Form Implicit
//! Surfaces*, 2020, sec. 3).

use std::cell::OnceCell;
use std::ops::Range;

use super::expr::{Binary, Graph, Node, NodeId, Unary, Var};
use super::interval::Interval;
use super::rfunc::MonotoneR;
use super::{GridProblem, ImplicitError, MAX_GRID_CELLS};

/// Runs `$e` with `$p` bound to `$op` as a constant, one match arm per variant of
/// `$ty`, so each arm's lane loop is specialised to its op.
macro_rules! per_op {
    ($ty:ident [$($v:ident),*], $op:expr, $p:ident => $e:expr) => {
        match $op {
            $($ty::$v => {
                const $p: $ty = $ty::$v;
                $e
            })*
        }
    };
}

/// [`per_op!`] over the unary ops.
macro_rules! per_unary {
    ($op:expr, $p:ident => $e:expr) => {
        per_op!(Unary [Neg, Abs, Recip, Sqrt, Square, Floor, Ceil, Round, Sin, Cos, Tan,
            Asin, Acos, Atan, Exp, Ln, Not], $op, $p => $e)
    };
}

/// [`per_op!`] over the binary ops.
macro_rules! per_binary {
    ($op:expr, $p:ident => $e:expr) => {
        per_op!(Binary [Add, Sub, Mul, Div, Min, Max, Atan2, Compare, Mod, And, Or],
            $op, $p => $e)
    };
}

/// Points per block of the batch evaluator.
pub const LANES: usize = 64;

/// One tape instruction; arguments are slots of earlier instructions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Instr {
    /// A coordinate.
    Var(Var),
    /// A constant.
    Const(f32),
    /// A one-argument op.
    Unary(Unary, u32),
    /// A two-argument op.
    Binary(Binary, u32, u32),
}

/// Straight-line code for one expression.
#[derive(Debug, Clone, PartialEq)]
pub struct Tape {
    instrs: Vec<Instr>,
    /// Slots holding monotone R-functions of two other slots, by root slot: the
    /// interval pass bounds them at their arguments' corners
    /// ([`MonotoneR::corner_interval`]).
    bounds: Vec<TapeBound>,
}

/// A monotone R-function on a tape: `root` is `op` of the slots `args`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct TapeBound {
    root: u32,
    args: [u32; 2],
    op: MonotoneR,
}

/// Which nodes of `graph` the node `root` depends on (itself included).
pub fn reachable(graph: &Graph, root: NodeId) -> Vec<bool> {
    let mut live = vec![false; root.index() + 1];
    live[root.index()] = true;
    for i in (0..=root.index()).rev() {
        if !live[i] {
            continue;
        }
        match graph.node(NodeId(i as u32)) {
            Node::Unary(_, a) => live[a.index()] = true,
            Node::Binary(_, a, b) => {
                live[a.index()] = true;
                live[b.index()] = true;
            }
            Node::Var(_) | Node::Const(_) => {}
        }
    }
    live
}

/// Which way an interval evaluation decided a choice op.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Choice {
    Left,
    Right,
    Both,
}

/// Tile edges (cells) of [`Tape::eval_grid`]'s pruning levels on grids one cell
/// deep, coarse to fine (Fidget's JIT uses 128 and 16 for images).
pub const GRID_TILES_2D: [usize; 2] = [128, 16];
/// Tile edges (cells) of [`Tape::eval_grid`]'s pruning levels on 3D grids (Fidget's
/// JIT uses 64, 16 and 8 for voxels).
pub const GRID_TILES_3D: [usize; 3] = [64, 16, 8];

/// Where [`Tape::eval_grid`]'s tiles write: cell centres per axis, and the index
/// in the slab's chunk of cell `(i, j, k)`, `i + stride[1] j + stride[2] k - base`.
struct TileTarget<'a> {
    coords: &'a [Vec<f32>; 3],
    stride: [usize; 3],
    base: usize,
}

/// Buffers reused by the leaves of one thread.
#[derive(Default)]
struct LeafScratch {
    regs: Vec<[f32; LANES]>,
}

/// Calls `f` with each sub-box of `bx` (cell index ranges per axis) of at most
/// `size` cells per axis, x fastest: the tiling of [`Tape::eval_grid`].
pub fn for_each_tile(bx: &[Range<usize>; 3], size: usize, mut f: impl FnMut([Range<usize>; 3])) {
    let steps = |r: &Range<usize>| {
        let r = r.clone();
        r.clone()
            .step_by(size)
            .map(move |a| a..(a + size).min(r.end))
    };
    for z in steps(&bx[2]) {
        for y in steps(&bx[1]) {
            for x in steps(&bx[0]) {
                f([x.clone(), y.clone(), z.clone()]);
            }
        }
    }
}

/// A regular grid of cell centres: cell `(i, j, k)` is at
/// `lo + (i + 0.5) (hi - lo) / n` per axis, x varying fastest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// Cells per axis (1 on unused axes).
    pub n: [usize; 3],
    /// Lower corner.
    pub lo: [f64; 3],
    /// Upper corner.
    pub hi: [f64; 3],
}

impl Grid {
    /// A grid, checked: every axis has cells, bounds are finite with `lo < hi`, and
    /// there are at most [`MAX_GRID_CELLS`] cells.
    pub fn new(n: [usize; 3], lo: [f64; 3], hi: [f64; 3]) -> Result<Self, ImplicitError> {
        let err = |reason| ImplicitError::Grid { n, lo, hi, reason };
        if n.contains(&0) {
            return Err(err(GridProblem::NoCells));
        }
        if (0..3).any(|a| !(lo[a].is_finite() && hi[a].is_finite() && lo[a] < hi[a])) {
            return Err(err(GridProblem::Bounds));
        }
        let cells = n.iter().try_fold(1u64, |acc, &k| acc.checked_mul(k as u64));
        if cells.is_none_or(|c| c > MAX_GRID_CELLS) {
            return Err(err(GridProblem::TooMany));
        }
        Ok(Self { n, lo, hi })
    }

    /// The number of cells.
    pub fn len(&self) -> usize {
        self.n.iter().product()
    }

    /// Whether the grid has no cells (never, once checked).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The centre of cell `i` along `axis`.
    pub fn centre(&self, axis: usize, i: usize) -> f64 {
        self.lo[axis] + (i as f64 + 0.5) * (self.hi[axis] - self.lo[axis]) / self.n[axis] as f64
    }
}

impl Tape {
    /// Compiles the part of `graph` that `root` depends on.
    pub fn compile(graph: &Graph, root: NodeId) -> Self {
        let live = reachable(graph, root);
        let mut slot = vec![u32::MAX; live.len()];
        let mut instrs = Vec::new();
        for (i, &alive) in live.iter().enumerate() {
            if !alive {
                continue;
            }
            let ins = match graph.node(NodeId(i as u32)) {
                Node::Var(v) => Instr::Var(v),
                Node::Const(bits) => Instr::Const(f64::from_bits(bits) as f32),
                Node::Unary(op, a) => Instr::Unary(op, slot[a.index()]),
                Node::Binary(op, a, b) => Instr::Binary(op, slot[a.index()], slot[b.index()]),
            };
            slot[i] = instrs.len() as u32;
            instrs.push(ins);
        }
        let mut bounds: Vec<TapeBound> = graph
            .monotone_ops()
            .iter()
            .filter(|b| live[b.root.index()])
            .map(|b| TapeBound {
                root: slot[b.root.index()],
                args: b.args.map(|a| slot[a.index()]),
                op: b.op,
            })
            .collect();
        bounds.sort_by_key(|b| b.root);
        Self { instrs, bounds }
    }

    /// This tape without its R-function corner bounds: intervals from the formulas'
    /// ops alone (what pruning had before them; the comparison of
    /// docs/implicit.md, "Interval bounds of R-functions").
    pub fn without_r_bounds(&self) -> Tape {
        Tape {
            instrs: self.instrs.clone(),
            bounds: Vec::new(),
        }
    }

    /// How many slots hold monotone R-functions bounded at their corners.
    pub fn r_bounds(&self) -> usize {
        self.bounds.len()
    }

    /// The instructions.
    pub fn instrs(&self) -> &[Instr] {
        &self.instrs
    }

    /// The number of instructions.
    pub fn len(&self) -> usize {
        self.instrs.len()
    }

    /// Whether the tape is empty (never: a tape has at least its root).
    pub fn is_empty(&self) -> bool {
        self.instrs.is_empty()
    }

    /// Whether the value depends on `var`.
    pub fn uses(&self, var: Var) -> bool {
        self.instrs.contains(&Instr::Var(var))
    }

    /// The value at one point, in f32.
    pub fn eval_point(&self, p: [f32; 3]) -> f32 {
        let mut scratch = Vec::with_capacity(self.instrs.len());
        self.eval_point_with(p, &mut scratch)
    }

    /// [`eval_point`](Self::eval_point) with a reusable scratch buffer.
    pub fn eval_point_with(&self, p: [f32; 3], scratch: &mut Vec<f32>) -> f32 {
        scratch.clear();
        for ins in &self.instrs {
            let v = match *ins {
                Instr::Var(v) => p[v.index()],
                Instr::Const(c) => c,
                Instr::Unary(op, a) => op.apply(scratch[a as usize]),
                Instr::Binary(op, a, b) => op.apply(scratch[a as usize], scratch[b as usize]),
            };
            scratch.push(v);
        }
        *scratch.last().expect("a tape has a root")
    }

    /// The block program of this tape for points whose coordinates `varying` change
    /// from point to point (the others are fixed per call or per grid row).
    fn block_program(&self, varying: [bool; 3]) -> BlockProgram {
        BlockProgram::new(&self.instrs, varying)
    }

    /// Values at many points, written into `out` (one per point).
    ///
    /// # Panics
    /// When `out` and `points` differ in length.
    pub fn eval_points(&self, points: &[[f32; 3]], out: &mut [f32]) {
        assert_eq!(points.len(), out.len(), "one output per point");
        let prog = self.block_program([true; 3]);
        let mut known = vec![0.0f32; self.instrs.len()];
        prog.fill_uniform(&self.instrs, [0.0; 3], &mut known);
        let mut regs = prog.registers();
        for (pts, vals) in points.chunks(LANES).zip(out.chunks_mut(LANES)) {
            for (l, p) in pts.iter().enumerate() {
                for (a, reg) in regs[..3].iter_mut().enumerate() {
                    reg[l] = p[a];
                }
            }
            prog.run(&known, &mut regs, vals);
        }
    }

    /// Values at the cell centres of `grid`, x fastest, then y, then z: the bits
    /// single-point evaluation ([`eval_point`](Self::eval_point)) gives there.
    ///
    /// A tape with choices (`min`, `max`, `and`, `or`) is pruned per region, as
    /// Fidget renders (Keeter 2020, sec. 3): the grid is cut into tiles
    /// ([`GRID_TILES_2D`] on grids one cell deep, else [`GRID_TILES_3D`]); each tile
    /// simplifies its parent's tape over the box of its cell centres, and the
    /// smallest tiles evaluate their tape in blocks of [`LANES`] points. Interval
    /// bounds are sound (outward-rounded), so a pruned choice never wins at a cell
    /// centre of its tile and the values are unchanged. Slabs of top-level tiles run
    /// on the rayon pool with the `parallel` feature. A tape without choices is
    /// evaluated as [`eval_grid_unpruned`](Self::eval_grid_unpruned) does.
    pub fn eval_grid(&self, grid: &Grid) -> Vec<f32> {
        if !self.has_choices() {
            return self.eval_grid_unpruned(grid);
        }
        let n = grid.n;
        let tiles: &[usize] = if n[2] == 1 {
            &GRID_TILES_2D
        } else {
            &GRID_TILES_3D
        };
        let coords: [Vec<f32>; 3] =
            [0, 1, 2].map(|a| (0..n[a]).map(|i| grid.centre(a, i) as f32).collect());
        let stride = [1, n[0], n[0] * n[1]];
        // Slabs of one top-level tile along the outermost axis with more than one
        // cell; each is a contiguous run of `out`.
        let axis = if n[2] > 1 { 2 } else { 1 };
        let top = tiles[0];
        let mut out = vec![0.0f32; grid.len()];
        let slab = |scratch: &mut LeafScratch, (s, chunk): (usize, &mut [f32])| {
            let mut bx = [0..n[0], 0..n[1], 0..n[2]];
            bx[axis] = s * top..((s + 1) * top).min(n[axis]);
            let target = TileTarget {
                coords: &coords,
                stride,
                base: bx[axis].start * stride[axis],
            };
            let prog = OnceCell::new();
            for_each_tile(&bx, tiles[0], |tile| {
                self.fill_tile(&prog, tile, &tiles[1..], &target, chunk, scratch);
            });
        };
        let slab_len = top * stride[axis];
        #[cfg(feature = "parallel")]
        {
            use rayon::prelude::*;
            out.par_chunks_mut(slab_len)
                .enumerate()
                .for_each_init(LeafScratch::default, slab);
        }
        #[cfg(not(feature = "parallel"))]
        {
            let mut scratch = LeafScratch::default();
            out.chunks_mut(slab_len)
                .enumerate()
                .for_each(|item| slab(&mut scratch, item));
        }
        out
    }

    /// Whether the tape has an op that interval pruning can decide.
    fn has_choices(&self) -> bool {
        self.instrs.iter().any(|i| {
            matches!(
                i,
                Instr::Binary(Binary::Min | Binary::Max | Binary::And | Binary::Or, _, _)
            )
        })
    }

    /// Simplifies this tape over the cell centres of `bx` and fills them: through
    /// the next levels of `tiles`, or (at the last, or once no choice is left to
    /// decide) in blocks. `prog` is this tape's block program, built on first use
    /// and shared with every sub-tile whose interval pass decides nothing new (their
    /// tape is this one: no copy, no second program).
    fn fill_tile(
        &self,
        prog: &OnceCell<LeafProgram>,
        bx: [Range<usize>; 3],
        tiles: &[usize],
        target: &TileTarget<'_>,
        out: &mut [f32],
        scratch: &mut LeafScratch,
    ) {
        let region = [0, 1, 2].map(|a| {
            let c = &target.coords[a];
            Interval::new(c[bx[a].start], c[bx[a].end - 1])
        });
        let (_, choices) = self.interval_pass(region);
        if choices.iter().all(|&c| c == Choice::Both) {
            return self.fill_pruned(prog, bx, tiles, target, out, scratch);
        }
        let tape = self.prune(&choices);
        if tape.instrs.iter().all(|i| !matches!(i, Instr::Var(_))) {
            // No coordinate left: one value for the whole tile, the bits every
            // cell's evaluation gives (the same ops on the same constants).
            let v = tape.eval_point([0.0; 3]);
            return fill_box(&bx, target, out, v);
        }
        tape.fill_pruned(&OnceCell::new(), bx, tiles, target, out, scratch);
    }

    /// [`fill_tile`](Self::fill_tile) after pruning: this tape is already
    /// simplified for `bx`; sub-tiles follow while it has choices to decide.
    fn fill_pruned(
        &self,
        prog: &OnceCell<LeafProgram>,
        bx: [Range<usize>; 3],
        tiles: &[usize],
        target: &TileTarget<'_>,
        out: &mut [f32],
        scratch: &mut LeafScratch,
    ) {
        match tiles.split_first() {
            Some((&size, rest)) if self.has_choices() => for_each_tile(&bx, size, |sub| {
                self.fill_tile(prog, sub, rest, target, out, scratch);
            }),
            _ => {
                let prog = prog.get_or_init(|| LeafProgram::new(self));
                fill_leaf(prog, &bx, target, out, scratch);
            }
        }
    }

    /// [`eval_grid`](Self::eval_grid) without interval pruning: row by row.
    ///
    /// Along a row only x changes: what depends on y, z and constants alone is
    /// evaluated once per row (point by point, as [`eval_point`](Self::eval_point)
    /// does, so the values are the same bits) and enters the block program as
    /// immediate operands.
    pub fn eval_grid_unpruned(&self, grid: &Grid) -> Vec<f32> {
        let nx = grid.n[0];
        let mut out = vec![0.0f32; grid.len()];
        let xs: Vec<f32> = (0..nx).map(|i| grid.centre(0, i) as f32).collect();
        let prog = self.block_program([true, false, false]);
        let init = || (vec![0.0f32; self.instrs.len()], prog.registers());
        let row = |(known, regs): &mut (Vec<f32>, Vec<[f32; LANES]>),
                   (r, vals): (usize, &mut [f32])| {
            let (j, k) = (r % grid.n[1], r / grid.n[1]);
            let (y, z) = (grid.centre(1, j) as f32, grid.centre(2, k) as f32);
            prog.fill_uniform(&self.instrs, [0.0, y, z], known);
            for (xc, vc) in xs.chunks(LANES).zip(vals.chunks_mut(LANES)) {
                regs[0][..xc.len()].copy_from_slice(xc);
                prog.run(known, regs, vc);
            }
        };
        #[cfg(feature = "parallel")]
        {
            use rayon::prelude::*;
            out.par_chunks_mut(nx).enumerate().for_each_init(init, row);
        }
        #[cfg(not(feature = "parallel"))]
        {
            let mut scratch = init();
            out.chunks_mut(nx)
                .enumerate()
                .for_each(|item| row(&mut scratch, item));
        }
        out
    }

    /// The range of values over the box `region` (one interval per axis).
    pub fn eval_interval(&self, region: [Interval; 3]) -> Interval {
        self.interval_pass(region).0
    }

    fn interval_pass(&self, region: [Interval; 3]) -> (Interval, Vec<Choice>) {
        let mut v: Vec<Interval> = Vec::with_capacity(self.instrs.len());
        let mut choices = vec![Choice::Both; self.instrs.len()];
        let mut bounds = self.bounds.iter().peekable();
        for (i, ins) in self.instrs.iter().enumerate() {
            let mut r = match *ins {
                Instr::Var(var) => region[var.index()],
                Instr::Const(c) => Interval::point(c),
                Instr::Unary(op, a) => v[a as usize].unary(op),
                Instr::Binary(op, a, b) => {
                    let (ia, ib) = (v[a as usize], v[b as usize]);
                    choices[i] = choose(op, ia, ib);
                    ia.binary(op, ib)
                }
            };
            // A monotone R-function: its formula's interval meets its corner bound
            // (both hold every value, so their intersection does).
            while let Some(b) = bounds.next_if(|b| b.root as usize <= i) {
                if b.root as usize == i
                    && let Some(c) =
                        b.op.corner_interval(v[b.args[0] as usize], v[b.args[1] as usize])
                {
                    r = r.intersect(c);
                }
            }
            v.push(r);
        }
        (*v.last().expect("a tape has a root"), choices)
    }

    /// The range over `region` and a tape that equals this one everywhere in it, with
    /// the choices interval arithmetic decided removed (and what only the losing
    /// sides used).
    pub fn simplify(&self, region: [Interval; 3]) -> (Interval, Tape) {
        let (range, choices) = self.interval_pass(region);
        (range, self.prune(&choices))
    }

    /// This tape with the choices an interval pass decided (`choices`, one per
    /// slot) removed, and what only their losing sides used.
    fn prune(&self, choices: &[Choice]) -> Tape {
        // alias[i]: the slot whose value slot i takes.
        let mut alias: Vec<u32> = (0..self.instrs.len() as u32).collect();
        for (i, ins) in self.instrs.iter().enumerate() {
            if let Instr::Binary(_, a, b) = *ins {
                match choices[i] {
                    Choice::Left => alias[i] = alias[a as usize],
                    Choice::Right => alias[i] = alias[b as usize],
                    Choice::Both => {}
                }
            }
        }
        let n = self.instrs.len();
        let mut live = vec![false; n];
        live[alias[n - 1] as usize] = true;
        for i in (0..n).rev() {
            if !live[i] || alias[i] != i as u32 {
                continue;
            }
            match self.instrs[i] {
                Instr::Unary(_, a) => live[alias[a as usize] as usize] = true,
                Instr::Binary(_, a, b) => {
                    live[alias[a as usize] as usize] = true;
                    live[alias[b as usize] as usize] = true;
                }
                Instr::Var(_) | Instr::Const(_) => {}
            }
        }
        let mut slot = vec![u32::MAX; n];
        let mut instrs = Vec::new();
        for i in 0..n {
            if !live[i] || alias[i] != i as u32 {
                continue;
            }
            let s = |a: u32| slot[alias[a as usize] as usize];
            let ins = match self.instrs[i] {
                Instr::Unary(op, a) => Instr::Unary(op, s(a)),
                Instr::Binary(op, a, b) => Instr::Binary(op, s(a), s(b)),
                other => other,
            };
            slot[i] = instrs.len() as u32;
            instrs.push(ins);
        }
        // The bounds whose root survives as itself; their arguments are live through
        // the root (read through the aliases).
        let bounds = self
            .bounds
            .iter()
            .filter(|b| live[b.root as usize] && alias[b.root as usize] == b.root)
            .map(|b| TapeBound {
                root: slot[b.root as usize],
                args: b.args.map(|a| slot[alias[a as usize] as usize]),
                op: b.op,
            })
            .collect();
        Tape { instrs, bounds }
    }

    /// The value and gradient at `p`, by forward-mode automatic differentiation in
    /// f32 (dual numbers carrying d/dx, d/dy, d/dz). Where the function has a kink,
    /// the same one-sided or averaged rule as [`Graph::deriv`] applies.
    pub fn eval_grad(&self, p: [f32; 3]) -> (f32, [f32; 3]) {
        let mut v: Vec<Dual> = Vec::with_capacity(self.instrs.len());
        for ins in &self.instrs {
            let r = match *ins {
                Instr::Var(var) => {
                    let mut d = [0.0; 3];
                    d[var.index()] = 1.0;
                    Dual {
                        v: p[var.index()],
                        d,
                    }
                }
                Instr::Const(c) => Dual { v: c, d: [0.0; 3] },
                Instr::Unary(op, a) => dual_unary(op, v[a as usize]),
                Instr::Binary(op, a, b) => dual_binary(op, v[a as usize], v[b as usize]),
            };
            v.push(r);
        }
        let r = v.last().expect("a tape has a root");
        (r.v, r.d)
    }
}

/// Evaluates a tape (its leaf program) at every cell centre of `bx`, [`LANES`] at a time.
fn fill_leaf(
    leaf: &LeafProgram,
    bx: &[Range<usize>; 3],
    target: &TileTarget<'_>,
    out: &mut [f32],
    scratch: &mut LeafScratch,
) {
    let prog = &leaf.prog;
    scratch.regs.resize(prog.registers, [0.0; LANES]);
    let mut index = [0usize; LANES];
    let mut vals = [0.0f32; LANES];
    let mut lanes = 0;
    let c = target.coords;
    let flush = |lanes: usize, index: &[usize; LANES], s: &mut LeafScratch, out: &mut [f32]| {
        let vals = &mut vals[..lanes];
        prog.run(&leaf.known, &mut s.regs, vals);
        for (&i, &v) in index[..lanes].iter().zip(vals.iter()) {
            out[i] = v;
        }
    };
    let mut flush = flush;
    for k in bx[2].clone() {
        for j in bx[1].clone() {
            let row = j * target.stride[1] + k * target.stride[2] - target.base;
            for i in bx[0].clone() {
                scratch.regs[0][lanes] = c[0][i];
                scratch.regs[1][lanes] = c[1][j];
                scratch.regs[2][lanes] = c[2][k];
                index[lanes] = row + i;
                lanes += 1;
                if lanes == LANES {
                    flush(lanes, &index, scratch, out);
                    lanes = 0;
                }
            }
        }
    }
    if lanes > 0 {
        flush(lanes, &index, scratch, out);
    }
}

/// Writes `v` at every cell of `bx`.
fn fill_box(bx: &[Range<usize>; 3], target: &TileTarget<'_>, out: &mut [f32], v: f32) {
    for k in bx[2].clone() {
        for j in bx[1].clone() {
            let row = j * target.stride[1] + k * target.stride[2] - target.base;
            out[row + bx[0].start..row + bx[0].end].fill(v);
        }
    }
}

/// A tape's block program for points varying in x, y and z, with the values of its
/// uniform slots (its constants), built once and shared by the leaves that
/// evaluate the same tape.
struct LeafProgram {
    prog: BlockProgram,
    known: Vec<f32>,
}

impl LeafProgram {
    fn new(tape: &Tape) -> Self {
        let prog = tape.block_program([true; 3]);
        let mut known = vec![0.0f32; tape.instrs.len()];
        prog.fill_uniform(&tape.instrs, [0.0; 3], &mut known);
        Self { prog, known }
    }
}

fn choose(op: Binary, a: Interval, b: Interval) -> Choice {
    if a.nan || b.nan {
        return Choice::Both;
    }
    match op {
        Binary::Min if a.hi < b.lo => Choice::Left,
        Binary::Min if b.hi < a.lo => Choice::Right,
        Binary::Max if a.lo > b.hi => Choice::Left,
        Binary::Max if b.lo > a.hi => Choice::Right,
        // and(a, b): b where a is never 0; or(a, b): a where a is never 0.
        Binary::And if !a.contains(0.0) => Choice::Right,
        Binary::And if a.lo == 0.0 && a.hi == 0.0 => Choice::Left,
        Binary::Or if !a.contains(0.0) => Choice::Left,
        Binary::Or if a.lo == 0.0 && a.hi == 0.0 => Choice::Right,
        _ => Choice::Both,
    }
}

/// An operand of a block instruction.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Src {
    /// A register: one value per lane.
    Reg(u32),
    /// The tape slot whose value is the same in every lane (a constant, or what
    /// depends only on the fixed coordinates), read from the per-call table.
    Imm(u32),
}

/// One instruction of a [`BlockProgram`]; the last field is the output register,
/// never one of the input registers.
#[derive(Debug, Clone, Copy, PartialEq)]
enum BlockOp {
    Unary(Unary, u32, u32),
    /// Register op register.
    Rr(Binary, u32, u32, u32),
    /// Register op immediate.
    Ri(Binary, u32, u32, u32),
    /// Immediate op register.
    Ir(Binary, u32, u32, u32),
}

/// A tape compiled for blocks of [`LANES`] points: the instructions that vary from
/// lane to lane, on a small register file reused as values die (so the working set
/// stays in L1), with operands that are the same in every lane folded in as
/// immediates. Registers 0, 1, 2 hold x, y, z.
#[derive(Debug, Clone, PartialEq)]
struct BlockProgram {
    /// Per tape slot: whether its value is the same in every lane.
    uniform: Vec<bool>,
    ops: Vec<BlockOp>,
    registers: usize,
    result: Src,
}

impl BlockProgram {
    fn new(instrs: &[Instr], varying: [bool; 3]) -> Self {
        let n = instrs.len();
        let mut uniform = vec![true; n];
        let mut last_use = vec![0usize; n];
        for (i, ins) in instrs.iter().enumerate() {
            match *ins {
                Instr::Var(v) => uniform[i] = !varying[v.index()],
                Instr::Const(_) => {}
                Instr::Unary(_, a) => {
                    uniform[i] = uniform[a as usize];
                    last_use[a as usize] = i;
                }
                Instr::Binary(_, a, b) => {
                    uniform[i] = uniform[a as usize] && uniform[b as usize];
                    last_use[a as usize] = i;
                    last_use[b as usize] = i;
                }
            }
        }
        let mut reg = vec![u32::MAX; n];
        let mut free: Vec<u32> = Vec::new();
        let mut registers = 3u32;
        let mut ops = Vec::new();
        for (i, ins) in instrs.iter().enumerate() {
            if uniform[i] {
                continue;
            }
            let (op, args) = match *ins {
                Instr::Var(v) => {
                    reg[i] = v.index() as u32;
                    continue;
                }
                Instr::Const(_) => continue,
                Instr::Unary(op, a) => (BlockOp::Unary(op, reg[a as usize], 0), [a, a]),
                Instr::Binary(op, a, b) => {
                    let (ua, ub) = (uniform[a as usize], uniform[b as usize]);
                    let (ra, rb) = (reg[a as usize], reg[b as usize]);
                    let op = match (ua, ub) {
                        (false, false) => BlockOp::Rr(op, ra, rb, 0),
                        (false, true) => BlockOp::Ri(op, ra, b, 0),
                        _ => BlockOp::Ir(op, a, rb, 0),
                    };
                    (op, [a, b])
                }
            };
            // The output register is taken before the inputs are freed, so it is
            // never an input.
            let out = free.pop().unwrap_or_else(|| {
                registers += 1;
                registers - 1
            });
            reg[i] = out;
            ops.push(match op {
                BlockOp::Unary(op, a, _) => BlockOp::Unary(op, a, out),
                BlockOp::Rr(op, a, b, _) => BlockOp::Rr(op, a, b, out),
                BlockOp::Ri(op, a, c, _) => BlockOp::Ri(op, a, c, out),
                BlockOp::Ir(op, c, b, _) => BlockOp::Ir(op, c, b, out),
            });
            for (k, &s) in args.iter().enumerate() {
                let s = s as usize;
                let dup = k == 1 && args[0] == args[1];
                if !dup && !uniform[s] && last_use[s] == i && reg[s] >= 3 {
                    free.push(reg[s]);
                }
            }
        }
        let root = n - 1;
        let result = if uniform[root] {
            Src::Imm(root as u32)
        } else {
            Src::Reg(reg[root])
        };
        Self {
            uniform,
            ops,
            registers: registers as usize,
            result,
        }
    }

    /// A register file for [`run`](Self::run).
    fn registers(&self) -> Vec<[f32; LANES]> {
        vec![[0.0; LANES]; self.registers]
    }

    /// Writes into `known` the value of every uniform slot, with the fixed
    /// coordinates `p` (entries of varying coordinates are not read), one point as
    /// [`Tape::eval_point`] evaluates it.
    fn fill_uniform(&self, instrs: &[Instr], p: [f32; 3], known: &mut [f32]) {
        for (i, ins) in instrs.iter().enumerate() {
            if !self.uniform[i] {
                continue;
            }
            known[i] = match *ins {
                Instr::Var(v) => p[v.index()],
                Instr::Const(c) => c,
                Instr::Unary(op, a) => op.apply(known[a as usize]),
                Instr::Binary(op, a, b) => op.apply(known[a as usize], known[b as usize]),
            };
        }
    }

    /// Runs the program on the lanes in `regs[0..3]` and writes the first
    /// `out.len()` values into `out`.
    fn run(&self, known: &[f32], regs: &mut [[f32; LANES]], out: &mut [f32]) {
        for &op in &self.ops {
            match op {
                BlockOp::Unary(op, a, o) => {
                    let [a, r] = pair(regs, a, o);
                    per_unary!(op, OP => map1(a, r, |x| lane_unary(OP, x)));
                }
                BlockOp::Rr(op, a, b, o) => {
                    let (before, rest) = regs.split_at_mut(o as usize);
                    let (r, after) = rest.split_first_mut().expect("output register exists");
                    let (before, after): (&[[f32; LANES]], &[[f32; LANES]]) = (before, after);
                    let pick = move |s: u32| {
                        let s = s as usize;
                        if s < before.len() {
                            &before[s]
                        } else {
                            &after[s - before.len() - 1]
                        }
                    };
                    let (a, b) = (pick(a), pick(b));
                    per_binary!(op, OP => map2(a, b, r, |x, y| lane_binary(OP, x, y)));
                }
                BlockOp::Ri(op, a, c, o) => {
                    let c = known[c as usize];
                    let [a, r] = pair(regs, a, o);
                    per_binary!(op, OP => map1(a, r, |x| lane_binary(OP, x, c)));
                }
                BlockOp::Ir(op, c, b, o) => {
                    let c = known[c as usize];
                    let [b, r] = pair(regs, b, o);
                    per_binary!(op, OP => map1(b, r, |y| lane_binary(OP, c, y)));
                }
            }
        }
        match self.result {
            Src::Reg(r) => out.copy_from_slice(&regs[r as usize][..out.len()]),
            Src::Imm(s) => out.fill(known[s as usize]),
        }
    }
}

/// The input register `a` and the distinct output register `o`.
fn pair(regs: &mut [[f32; LANES]], a: u32, o: u32) -> [&mut [f32; LANES]; 2] {
    regs.get_disjoint_mut([a as usize, o as usize])
        .expect("block programs never write an input register")
}

/// [`Unary::apply`] in f32, with the common ops written out so that they inline
/// into the lane loops and vectorise (the same IEEE operations, so the same bits).
#[inline(always)]
fn lane_unary(op: Unary, x: f32) -> f32 {
    match op {
        Unary::Neg => -x,
        Unary::Abs => x.abs(),
        Unary::Sqrt => x.sqrt(),
        Unary::Square => x * x,
        _ => op.apply(x),
    }
}

/// [`Binary::apply`] in f32, with the common ops written out as in [`lane_unary`].
#[inline(always)]
fn lane_binary(op: Binary, x: f32, y: f32) -> f32 {
    match op {
        Binary::Add => x + y,
        Binary::Sub => x - y,
        Binary::Mul => x * y,
        Binary::Div => x / y,
        Binary::Min | Binary::Max if x.is_nan() || y.is_nan() => f32::NAN,
        Binary::Min => x.min(y),
        Binary::Max => x.max(y),
        Binary::And => {
            if x == 0.0 {
                x
            } else {
                y
            }
        }
        Binary::Or => {
            if x != 0.0 {
                x
            } else {
                y
            }
        }
        _ => op.apply(x, y),
    }
}

/// `r[k] = f(a[k])` for every lane: a loop the compiler vectorises once `f` is
/// inlined.
#[inline(always)]
fn map1(a: &[f32; LANES], r: &mut [f32; LANES], f: impl Fn(f32) -> f32) {
    for (r, &a) in r.iter_mut().zip(a) {
        *r = f(a);
    }
}

/// `r[k] = f(a[k], b[k])` for every lane.
#[inline(always)]
fn map2(a: &[f32; LANES], b: &[f32; LANES], r: &mut [f32; LANES], f: impl Fn(f32, f32) -> f32) {
    for ((r, &a), &b) in r.iter_mut().zip(a).zip(b) {
        *r = f(a, b);
    }
}

/// A value with its gradient.
#[derive(Debug, Clone, Copy)]
struct Dual {
    v: f32,
    d: [f32; 3],
}

impl Dual {
    fn chain(v: f32, f: f32, a: Dual) -> Dual {
        Dual {
            v,
            d: a.d.map(|x| f * x),
        }
    }
    fn combine(v: f32, fa: f32, a: Dual, fb: f32, b: Dual) -> Dual {
        Dual {
            v,
            d: [0, 1, 2].map(|k| fa * a.d[k] + fb * b.d[k]),
        }
    }
}

fn dual_unary(op: Unary, a: Dual) -> Dual {
    let v = op.apply(a.v);
    let x = a.v;
    let f = match op {
        Unary::Neg => -1.0,
        Unary::Abs => Binary::Compare.apply(x, 0.0),
        Unary::Recip => -1.0 / (x * x),
        Unary::Sqrt => 1.0 / (2.0 * v),
        Unary::Square => 2.0 * x,
        Unary::Floor | Unary::Ceil | Unary::Round | Unary::Not => 0.0,
        Unary::Sin => x.cos(),
        Unary::Cos => -x.sin(),
        Unary::Tan => 1.0 / (x.cos() * x.cos()),
        Unary::Asin => 1.0 / (1.0 - x * x).sqrt(),
        Unary::Acos => -1.0 / (1.0 - x * x).sqrt(),
        Unary::Atan => 1.0 / (1.0 + x * x),
        Unary::Exp => v,
        Unary::Ln => 1.0 / x,
    };
    Dual::chain(v, f, a)
}

fn dual_binary(op: Binary, a: Dual, b: Dual) -> Dual {
    let v = op.apply(a.v, b.v);
    let (x, y) = (a.v, b.v);
    let (fa, fb) = match op {
        Binary::Add => (1.0, 1.0),
        Binary::Sub => (1.0, -1.0),
        Binary::Mul => (y, x),
        Binary::Div => (1.0 / y, -x / (y * y)),
        Binary::Min | Binary::Max => {
            let c = Binary::Compare.apply(x, y) * 0.5;
            if op == Binary::Min {
                (0.5 - c, 0.5 + c)
            } else {
                (0.5 + c, 0.5 - c)
            }
        }
        Binary::Atan2 => {
            let s = x * x + y * y;
            (y / s, -x / s)
        }
        Binary::Compare => (0.0, 0.0),
        Binary::Mod => (1.0, -(x / y).floor()),
        Binary::And => {
            if x == 0.0 {
                (1.0, 0.0)
            } else {
                (0.0, 1.0)
            }
        }
        Binary::Or => {
            if x != 0.0 {
                (1.0, 0.0)
            } else {
                (0.0, 1.0)
            }
        }
    };
    Dual::combine(v, fa, a, fb, b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::implicit::vm;
    use crate::tolerance::{IMPLICIT_F32_REL, IMPLICIT_GRAD_F32_REL};
    use proptest::prelude::*;

    /// A random program over the smooth-ish ops, so f32 and f64 stay comparable.
    fn program() -> impl Strategy<Value = String> {
        let ops = [
            "add", "sub", "mul", "min", "max", "neg", "abs", "square", "sin", "cos", "atan", "and",
            "or",
        ];
        let clause = (
            0usize..ops.len() + 1,
            0usize..1000,
            0usize..1000,
            -2.0f64..2.0,
        );
        proptest::collection::vec(clause, 1..30).prop_map(move |cs| {
            let mut text = String::from("v0 var-x\nv1 var-y\nv2 var-z\n");
            for (k, (kind, a, b, c)) in cs.into_iter().enumerate() {
                let n = k + 3;
                let (a, b) = (a % n, b % n);
                let line = match ops.get(kind).copied() {
                    None => format!("v{n} const {c}"),
                    Some(op @ ("neg" | "abs" | "square" | "sin" | "cos" | "atan")) => {
                        format!("v{n} {op} v{a}")
                    }
                    Some(op) => format!("v{n} {op} v{a} v{b}"),
                };
                text.push_str(&line);
                text.push('\n');
            }
            // Keep magnitudes bounded: the value is the atan of the last clause.
            let last = text.lines().count() - 1;
            text.push_str(&format!("out atan v{last}\n"));
            text
        })
    }

    fn point() -> impl Strategy<Value = [f32; 3]> {
        [-2.0f32..2.0, -2.0f32..2.0, -2.0f32..2.0]
    }

    proptest! {
        /// The f32 tape agrees with a direct f64 walk of the clauses as written.
        #[test]
        fn tape_agrees_with_the_clause_walk(text in program(), pts in proptest::collection::vec(point(), 1..20)) {
            let prog = vm::parse(&text).unwrap();
            let (g, root) = prog.to_graph();
            let tape = Tape::compile(&g, root);
            prop_assert!(tape.len() <= prog.clauses.len());
            let mut batch = vec![0.0f32; pts.len()];
            tape.eval_points(&pts, &mut batch);
            for (p, b) in pts.iter().zip(&batch) {
                let (want, scale) = prog.eval_f64_with_scale(p.map(f64::from));
                let got = tape.eval_point(*p);
                prop_assert_eq!(got.to_bits(), b.to_bits(), "batch differs from point");
                if scale > 1e30 {
                    continue; // beyond f32's range: the tape overflows where f64 does not
                }
                prop_assert!((f64::from(got) - want).abs() <= IMPLICIT_F32_REL * (1.0 + scale), "{got} vs {want}");
            }
        }

        /// Grid values, with what depends on y and z alone evaluated once per row, are
        /// the bits single-point evaluation gives at the cell centres.
        #[test]
        fn grid_values_equal_point_values(text in program(), n in [1usize..80, 1usize..4, 1usize..3]) {
            let (g, root) = vm::parse(&text).unwrap().to_graph();
            let tape = Tape::compile(&g, root);
            let grid = Grid::new(n, [-2.0; 3], [2.0; 3]).unwrap();
            let values = tape.eval_grid(&grid);
            prop_assert_eq!(values.len(), grid.len());
            for (idx, got) in values.iter().enumerate() {
                let ijk = [idx % n[0], (idx / n[0]) % n[1], idx / (n[0] * n[1])];
                let p = [0, 1, 2].map(|a| grid.centre(a, ijk[a]) as f32);
                let want = tape.eval_point(p);
                prop_assert!(got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                    "at {:?}: grid {} vs point {}", p, got, want);
            }
        }

        /// A tape simplified for a box equals the full tape everywhere in the box, and
        /// the interval holds every value there.
        #[test]
        fn simplified_tape_agrees_inside_its_region(text in program(), c in point(), w in 0.01f32..1.0,
                pts in proptest::collection::vec([0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0], 1..20)) {
            let (g, root) = vm::parse(&text).unwrap().to_graph();
            let tape = Tape::compile(&g, root);
            let region = [0, 1, 2].map(|a| Interval::new(c[a] - w, c[a] + w));
            let (range, small) = tape.simplify(region);
            prop_assert!(small.len() <= tape.len());
            for s in pts {
                let p = [0, 1, 2].map(|a| (region[a].lo + s[a] * (region[a].hi - region[a].lo)).clamp(region[a].lo, region[a].hi));
                let (full, simple) = (tape.eval_point(p), small.eval_point(p));
                prop_assert_eq!(full.to_bits(), simple.to_bits(), "at {:?}", p);
                prop_assert!(if full.is_nan() { range.nan } else { range.contains(full) }, "{} not in {:?}", full, range);
            }
        }

        /// Forward-mode gradients agree with the symbolic derivative walked in f64.
        #[test]
        fn gradients_agree_with_symbolic_derivatives(text in program(), p in point()) {
            let prog = vm::parse(&text).unwrap();
            let (mut g, root) = prog.to_graph();
            let tape = Tape::compile(&g, root);
            let (_, grad) = tape.eval_grad(p);
            let (_, scale) = prog.eval_f64_with_scale(p.map(f64::from));
            prop_assume!(scale < 1e6, "f32 rounding of large intermediates swamps the gradient");
            for v in [Var::X, Var::Y, Var::Z] {
                let d = g.deriv(root, v);
                let want = g.eval_f64(d, p.map(f64::from));
                let got = f64::from(grad[v.index()]);
                if want.is_finite() {
                    prop_assert!((got - want).abs() <= IMPLICIT_GRAD_F32_REL * (1.0 + want.abs()), "{v:?}: {got} vs {want}");
                }
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        /// Interval-pruned grid values (tiles of several levels, grids that end
        /// mid-tile) are the bits of the unpruned evaluation.
        #[test]
        fn pruned_grid_values_equal_unpruned(text in program(),
                flat in any::<bool>(), a in 1usize..300, b in 1usize..300, c in 1usize..40) {
            // Flat grids span the 2D tiling, deep ones the 3D tiling.
            let n = if flat { [a, b, 1] } else { [a % 70 + 1, b % 40 + 1, c] };
            let (g, root) = vm::parse(&text).unwrap().to_graph();
            let tape = Tape::compile(&g, root);
            let grid = Grid::new(n, [-2.0; 3], [2.0; 3]).unwrap();
            let (pruned, full) = (tape.eval_grid(&grid), tape.eval_grid_unpruned(&grid));
            for (idx, (a, b)) in pruned.iter().zip(&full).enumerate() {
                prop_assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                    "cell {}: pruned {} vs unpruned {}", idx, a, b);
            }
        }
    }

    /// A union of 27 spheres on a 3D grid that spans every tiling level: pruning
    /// drops most spheres per tile, and every value is the bits point evaluation
    /// gives. Regression: intervals once widened `square` and `+` below zero, so
    /// every `sqrt` of a sum of squares "may be NaN" and no distance was pruned.
    #[test]
    fn pruned_sphere_union_equals_point_values() {
        let mut g = Graph::new();
        let [x, y, z] = g.xyz();
        let mut root = None;
        for c in 0..27 {
            let centre = [c % 3, (c / 3) % 3, c / 9].map(|k| k as f64 - 1.0);
            let d: Vec<NodeId> = [x, y, z]
                .iter()
                .zip(centre)
                .map(|(&v, c)| g.offset(v, -c))
                .collect();
            let r2 = g.norm2(&d);
            let r = g.sqrt(r2);
            let s = g.offset(r, -0.4);
            root = Some(match root {
                None => s,
                Some(u) => g.binary(Binary::Min, u, s),
            });
        }
        let tape = Tape::compile(&g, root.unwrap());
        let corner = [-1.0, -1.0, 0.0];
        let (_, small) = tape.simplify(corner.map(|c: f32| Interval::new(c - 0.05, c + 0.05)));
        assert!(
            small.len() * 5 < tape.len(),
            "{} of {}",
            small.len(),
            tape.len()
        );
        let grid = Grid::new([133, 70, 21], [-1.6; 3], [1.6; 3]).unwrap();
        let values = tape.eval_grid(&grid);
        for (idx, got) in values.iter().enumerate() {
            let ijk = [idx % 133, (idx / 133) % 70, idx / (133 * 70)];
            let p = [0, 1, 2].map(|a| grid.centre(a, ijk[a]) as f32);
            assert_eq!(got.to_bits(), tape.eval_point(p).to_bits(), "at {p:?}");
        }
    }

    #[test]
    fn grid_values_are_at_cell_centres_x_fastest() {
        let mut g = Graph::new();
        let [x, y, z] = g.xyz();
        let ty = g.scale(y, 10.0);
        let tz = g.scale(z, 100.0);
        let s = g.add(x, ty);
        let root = g.add(s, tz);
        let tape = Tape::compile(&g, root);
        let grid = Grid::new([70, 3, 2], [0.0, 0.0, 0.0], [70.0, 3.0, 2.0]).unwrap();
        let v = tape.eval_grid(&grid);
        assert_eq!(v.len(), 70 * 3 * 2);
        for (idx, got) in v.iter().enumerate() {
            let (i, j, k) = (idx % 70, (idx / 70) % 3, idx / 210);
            let want = (i as f64 + 0.5) + 10.0 * (j as f64 + 0.5) + 100.0 * (k as f64 + 0.5);
            crate::assert_near!(f64::from(*got), want, IMPLICIT_F32_REL * want);
        }
    }

    #[test]
    fn bad_grids_are_refused() {
        assert!(Grid::new([0, 1, 1], [0.0; 3], [1.0; 3]).is_err());
        assert!(Grid::new([1, 1, 1], [0.0; 3], [0.0, 1.0, 1.0]).is_err());
        assert!(Grid::new([1, 1, 1], [f64::NAN, 0.0, 0.0], [1.0; 3]).is_err());
        assert!(Grid::new([1 << 20, 1 << 20, 1 << 20], [0.0; 3], [1.0; 3]).is_err());
    }
}
