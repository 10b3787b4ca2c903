//! Scan to sculpt: NURBS patches from unorganised range data (Park, Yun and Lee 2000).
//! Pure: the readers take bytes; files are read by `sculpt-tools reconstruct`.
//!
//! Stages (see `docs/reconstruct.md`):
//! 1. [`read`]: points from `.xyz`, `.pwn`, PLY, OBJ and OFF bytes;
//!    [`normals`]: k nearest neighbours, PCA normals, consistent orientation.
//! 2. [`kmeans`]: generalised Lloyd clustering into K patches and their adjacency;
//!    [`segment`] runs stages 1 and 2 together.
//! 3. [`polygon`]: the polygonal model (faces where patches meet) and its quads;
//!    `quads` places their corners on the data and makes each quad's local grid
//!    (stage 4); [`network`] (which re-exports those) fits stages 5 and 6: the NURBS
//!    patch network with G1 across sides, refitted to the data as one least-squares
//!    system by `joint`, errors, the document;
//!    [`pipeline`] runs everything.
//!
//! [`sample`] makes seeded point sets with known surfaces (the paper's torus).

pub mod error;
mod joint;
pub mod kmeans;
pub mod network;
pub mod normals;
pub mod pinch;
pub mod pipeline;
pub mod polygon;
mod quads;
pub mod read;
pub mod sample;
pub mod segment;

pub use error::ReconstructError;
