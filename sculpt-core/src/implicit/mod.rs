//! Implicit solids: expression graphs, R-functions and their evaluation (Shin, Kim and
//! Sheen, *Geometric Implicit Function Modeling and Analysis Using R-functions*, 2007).
//!
//! A shape is a real function of the point. Two sign conventions meet here, and every
//! crossing between them is an explicit negation:
//!
//! - **the paper's** ([`Convention::PositiveInside`]): omega >= 0 inside, = 0 on the
//!   boundary (Shin et al. 2007, sec. 2.1.2); R-functions ([`rfunc`]) and the solid
//!   documents ([`solid`]) work in it;
//! - **Fidget's** ([`Convention::NegativeInside`]): negative inside, as the `.vm`
//!   models ([`vm`]) are; the command-line tools read and write values in it.
//!
//! The pipeline: a reader builds an [`expr::Graph`] (hash-consed, so common
//! subexpressions are merged, and constant-folded as it is built); [`tape::Tape`]
//! flattens the part reachable from the root into straight-line code that evaluates
//! points (f32), batches and grids (on the rayon pool with the `parallel` feature),
//! intervals and gradients (forward-mode automatic differentiation), and simplifies
//! itself per region by interval pruning.
//!
//! ```
//! use sculpt_core::implicit::Model;
//! let model = Model::from_vm("# unit circle\nx var-x\ny var-y\nxx square x\nyy square y\n\
//!     s add xx yy\nr sqrt s\none const 1\nd sub r one\n").unwrap();
//! let tape = model.tape_negative_inside();
//! assert!(tape.eval_point([0.0, 0.0, 0.0]) < 0.0); // inside
//! assert!(tape.eval_point([2.0, 0.0, 0.0]) > 0.0); // outside
//! ```

pub mod contour;
pub mod dual;
pub mod expr;
pub mod interval;
pub mod material;
pub use dual::octree;
pub mod rfm;
pub mod rfunc;
mod rsystem;
pub mod solid;
pub mod tape;
pub mod vm;

use thiserror::Error;

pub use expr::{Binary, Graph, NodeId, Unary, Var};
pub use tape::Tape;

/// Which side of the zero set a model calls inside.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Convention {
    /// omega >= 0 inside (Shin et al. 2007, the R-function literature).
    PositiveInside,
    /// Negative inside (Fidget's `.vm` models, signed distance fields).
    NegativeInside,
}

/// Everything that can go wrong reading, building or meshing an implicit model.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ImplicitError {
    /// A `.vm` clause names an op that is not in the op set.
    #[error("line {line}: unknown op `{op}`")]
    UnknownOp {
        /// 1-based line number.
        line: usize,
        /// The op as written.
        op: String,
    },
    /// A `.vm` clause uses a name that no earlier clause defined.
    #[error("line {line}: `{name}` is used before it is defined")]
    Undefined {
        /// 1-based line number.
        line: usize,
        /// The name used.
        name: String,
    },
    /// A `.vm` clause uses its own result: a cycle.
    #[error("line {line}: `{name}` uses itself (a cycle)")]
    Cycle {
        /// 1-based line number.
        line: usize,
        /// The clause's name.
        name: String,
    },
    /// Two `.vm` clauses define the same name.
    #[error("line {line}: `{name}` is defined again (first on line {first})")]
    Redefined {
        /// 1-based line number of the second definition.
        line: usize,
        /// The name.
        name: String,
        /// Line of the first definition.
        first: usize,
    },
    /// A `.vm` constant does not parse as a number.
    #[error("line {line}: constant `{text}` is not a number")]
    BadConstant {
        /// 1-based line number.
        line: usize,
        /// The text as written.
        text: String,
        /// The parser's complaint.
        #[source]
        source: std::num::ParseFloatError,
    },
    /// A `.vm` constant is NaN.
    #[error("line {line}: constant is NaN")]
    NanConstant {
        /// 1-based line number.
        line: usize,
    },
    /// A `.vm` clause has the wrong number of arguments (or a line has a name and no op).
    #[error("line {line}: `{op}` takes {expected} argument(s), found {found}")]
    Arity {
        /// 1-based line number.
        line: usize,
        /// The op (empty when the line has no op).
        op: String,
        /// Arguments the op takes.
        expected: usize,
        /// Arguments found.
        found: usize,
    },
    /// A `.vm` model has no clauses.
    #[error("the model has no clauses")]
    Empty,
    /// A model has more clauses than [`MAX_CLAUSES`].
    #[error("the model has more than {max} clauses")]
    TooLong {
        /// The limit.
        max: usize,
    },
    /// A solid document is not valid JSON or does not follow the schema.
    #[error("solid document")]
    Json(#[source] serde_json::Error),
    /// A solid document has a parameter out of its range.
    #[error("solid document at {at}: `{name}` = {value} must be {expected}")]
    Parameter {
        /// Where in the document (a path like `solid.and[1].circle`).
        at: String,
        /// The parameter.
        name: &'static str,
        /// Its value.
        value: f64,
        /// What it must be.
        expected: &'static str,
    },
    /// A solid document's vector has the wrong number of components.
    #[error("solid document at {at}: `{name}` has {found} components, expected 2 or 3")]
    Dimension {
        /// Where in the document.
        at: String,
        /// The parameter.
        name: &'static str,
        /// Components found.
        found: usize,
    },
    /// A sampling grid is empty, too large or has bounds that are not finite and
    /// increasing.
    #[error("grid {n:?} on [{lo:?}, {hi:?}]: {reason}")]
    Grid {
        /// Cells per axis.
        n: [usize; 3],
        /// Lower corner.
        lo: [f64; 3],
        /// Upper corner.
        hi: [f64; 3],
        /// What is wrong.
        reason: GridProblem,
    },
}

/// Why a grid was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum GridProblem {
    /// An axis has no cells.
    #[error("an axis has no cells")]
    NoCells,
    /// More cells than [`MAX_GRID_CELLS`].
    #[error("more than {} cells", MAX_GRID_CELLS)]
    TooMany,
    /// A bound is not finite or `hi <= lo` on some axis.
    #[error("bounds must be finite with lo < hi")]
    Bounds,
}

/// The longest model read (clauses): bounds memory on hostile input, far above real
/// models (Fidget's largest, `prospero.vm`, has about 8,000).
pub const MAX_CLAUSES: usize = 1 << 22;
/// The most cells a grid evaluation or mesh may have (2^31: 8 GiB of f32 values).
pub const MAX_GRID_CELLS: u64 = 1 << 31;

/// A model read from a file: its graph, root and sign convention.
#[derive(Debug, Clone)]
pub struct Model {
    /// The expression graph.
    pub graph: Graph,
    /// The root node.
    pub root: NodeId,
    /// Which sign the root has inside.
    pub convention: Convention,
}

impl Model {
    /// Reads a `.vm` model (negative inside).
    pub fn from_vm(text: &str) -> Result<Self, ImplicitError> {
        let program = vm::parse(text)?;
        let (graph, root) = program.to_graph();
        Ok(Self {
            graph,
            root,
            convention: Convention::NegativeInside,
        })
    }

    /// Reads a solid document (JSON, omega >= 0 inside).
    pub fn from_solid_json(text: &str) -> Result<Self, ImplicitError> {
        let doc = solid::SolidDocument::from_json(text)?;
        let (graph, root) = doc.to_graph()?;
        Ok(Self {
            graph,
            root,
            convention: Convention::PositiveInside,
        })
    }

    /// Reads either format: text whose first non-blank character is `{` is a solid
    /// document, anything else a `.vm` model.
    pub fn from_text(text: &str) -> Result<Self, ImplicitError> {
        if text.trim_start().starts_with('{') {
            Self::from_solid_json(text)
        } else {
            Self::from_vm(text)
        }
    }

    /// The root in the given convention (negated when the model's differs).
    pub fn root_in(&mut self, convention: Convention) -> NodeId {
        if convention == self.convention {
            self.root
        } else {
            self.graph.unary(Unary::Neg, self.root)
        }
    }

    /// The tape in Fidget's convention (negative inside), as the tools write values.
    pub fn tape_negative_inside(&self) -> Tape {
        let mut m = self.clone();
        let root = m.root_in(Convention::NegativeInside);
        Tape::compile(&m.graph, root)
    }

    /// The tape in the paper's convention (omega >= 0 inside).
    pub fn tape_positive_inside(&self) -> Tape {
        let mut m = self.clone();
        let root = m.root_in(Convention::PositiveInside);
        Tape::compile(&m.graph, root)
    }
}
