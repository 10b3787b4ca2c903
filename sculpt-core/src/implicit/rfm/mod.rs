//! Mesh-free analysis by the R-function method (Shin, Kim and Sheen 2007, sec. 3):
//! steady heat conduction on a plane domain given by implicit boundary pieces, solved
//! with the solution structure of eqs. 7-8 on a B-spline basis by the Ritz method.
//!
//! - [`jet`]: second-order forward-mode differentiation of the models' graphs;
//! - [`basis`]: the tensor-product B-spline basis;
//! - [`quadrature`]: area and boundary rules adapted to the implicit domain;
//! - [`heat`]: the solution structure, assembly and solve;
//! - [`spec`]: the problem file (`sculpt-tools rfm heat SPEC.toml`).
//!
//! ```
//! use sculpt_core::implicit::Model;
//! use sculpt_core::implicit::rfm::heat::{solve, HeatSettings, Piece};
//! // A disc of radius 1 in air at 300 K: the whole disc settles at 300 K.
//! let disc = Model::from_vm("x var-x\ny var-y\nx2 square x\ny2 square y\n\
//!     s add x2 y2\nr sqrt s\none const 1\nd sub r one\n").unwrap();
//! let settings = HeatSettings { conductivity: 10.0, count: [6, 6], ..Default::default() };
//! let sol = solve(&settings, &[Piece { model: disc, ambient: 300.0, film: 20.0 }]).unwrap();
//! assert!((sol.temperature([0.2, 0.1]) - 300.0).abs() < 0.01);
//! ```

pub mod basis;
pub mod heat;
pub mod jet;
pub mod quadrature;
pub mod spec;

use thiserror::Error;

/// Everything that can go wrong setting up or solving a mesh-free problem.
#[derive(Debug, Error, PartialEq)]
#[non_exhaustive]
pub enum RfmError {
    /// The pieces' conjunction has no interior (no point with omega > 0 was found).
    #[error("the domain has no interior")]
    NoInterior,
    /// The Ritz system is singular to working precision.
    #[error("the system is singular")]
    Singular,
    /// The basis degree is out of range.
    #[error("basis degree {degree} must be 2 to 9")]
    Degree {
        /// The degree asked for.
        degree: usize,
    },
    /// The basis counts are out of range.
    #[error("basis count {count:?} must be degree + 1 ({degree} + 1) to 48 per direction")]
    Count {
        /// Functions per direction asked for.
        count: [usize; 2],
        /// The degree.
        degree: usize,
    },
    /// The conductivity is not a positive number.
    #[error("conductivity {value} must be positive")]
    Conductivity {
        /// The value.
        value: f64,
    },
    /// There are no boundary pieces, or too many.
    #[error("{count} boundary pieces: expected 1 to 64")]
    Pieces {
        /// How many were given.
        count: usize,
    },
    /// A piece's ambient temperature is not a positive number of kelvin.
    #[error("boundary {piece}: ambient {value} K must be positive")]
    Ambient {
        /// 0-based piece.
        piece: usize,
        /// The value.
        value: f64,
    },
    /// A piece's film coefficient is negative or not finite.
    #[error("boundary {piece}: film {value} W/m2K must be 0 or more")]
    Film {
        /// 0-based piece.
        piece: usize,
        /// The value.
        value: f64,
    },
    /// Every film coefficient is 0: the temperature is then fixed only up to a constant.
    #[error("every film coefficient is 0: the temperature is not determined")]
    Insulated,
    /// The R-function system's parameter is out of range.
    #[error("the conjunction's parameter is out of range")]
    System,
    /// The quadrature depth is too large.
    #[error("quadrature depth {depth} must be at most 8")]
    Depth {
        /// The depth.
        depth: u32,
    },
}
