//! Scan to sculpt: NURBS patches from unorganised range data (Park, Yun and Lee 2000).
//! Pure: the readers take bytes; files are read by `sculpt-tools reconstruct`.
//!
//! Stages (see `docs/reconstruct.md`):
//! 1. [`read`]: points from `.xyz`, `.pwn`, PLY, OBJ and OFF bytes;
//!    [`normals`]: k nearest neighbours, PCA normals, consistent orientation.
//! 2. [`kmeans`]: generalised Lloyd clustering into K patches and their adjacency;
//!    [`segment`] runs stages 1 and 2 together.
//! 3. [`polygon`]: the polygonal model (faces where patches meet) and its quads;
//!    [`network`]: their corners on the data, then stages 4 to 6 (local grids,
//!    the NURBS patch network with G1 across sides, refitted to the data as one
//!    least-squares system by `joint`, errors, the document);
//!    [`pipeline`] runs everything.
//!
//! [`sample`] makes seeded point sets with known surfaces (the paper's torus).

pub mod error;
mod joint;
pub mod kmeans;
pub mod network;
pub mod normals;
pub mod pipeline;
pub mod polygon;
pub mod read;
pub mod sample;
pub mod segment;

pub use error::ReconstructError;
