//! The NURBS kernel: knot vectors, basis functions, rational curves and surfaces, knot
//! insertion, point inversion. Everything follows *The NURBS Book* (Piegl & Tiller, 2nd
//! ed., "P&T") and names its algorithm.
//!
//! - [`KnotVector`]: validated knots; span search (A2.1), basis functions (A2.2) and
//!   their derivatives (A2.3), all into stack arrays (degree <= [`MAX_DEGREE`]).
//! - [`NurbsCurve`], [`NurbsSurface`]: rational, `f64`, `glam::DVec3` control points
//!   stored in homogeneous form. Points, derivatives up to second order (A3.2, A4.2,
//!   A3.6 + A4.4), normals and fundamental forms. Parameters outside the domain are
//!   clamped to it. Evaluation never allocates.
//! - Knot insertion and refinement (A5.1, A5.3, A5.4) in [`refine`].
//! - Constructors ([`construct`]): plane, bilinear patch, exact rational arcs, circles,
//!   spheres, tori and cylinders, revolution (A7.1, A8.1) and extrusion.
//! - Fitting ([`fit`]): grid interpolation (A9.4), grid least squares (A9.7 style),
//!   scattered-point approximation (least squares / minimum-norm pseudo-inverse).
//! - [`SurfaceInverter`]: closest points / point inversion (eqs. 6.5 to 6.7), correct on
//!   domain edges, corners, seams and poles, and proven global by a Bernstein-net
//!   certificate; see [`invert`] for the method.
//!
//! # JSON
//!
//! Surfaces (serde, and [`NurbsSurface::from_json`] / [`NurbsSurface::to_json`]):
//!
//! ```json
//! {"degree_u": 3, "degree_v": 3,
//!  "knots_u": [0,0,0,0,0.5,1,1,1,1], "knots_v": [0,0,0,0,0.5,1,1,1,1],
//!  "control_points": [[[x,y,z], ...], ...],
//!  "weights": [[w, ...], ...]}
//! ```
//!
//! `control_points[i][j]`: `i` runs along `u` (`n_u` rows), `j` along `v`. Knot vectors
//! are full (P&T style): length = count + degree + 1. `weights` is optional (default 1)
//! and only written for rational surfaces. Coordinates are Cartesian, not homogeneous.
//! Unknown fields are rejected, so a misspelt `"weight"` is an error, not a silent
//! default. Curves use `{"degree", "knots", "control_points": [[x,y,z], ...],
//! "weights": [w, ...]}`.
//!
//! # Example
//!
//! ```
//! use glam::{DVec2, DVec3};
//! use sculpt_core::nurbs::NurbsSurface;
//!
//! // A bilinear patch: the unit square in the z = 0 plane.
//! let s = NurbsSurface::new(
//!     1, 1,
//!     vec![0.0, 0.0, 1.0, 1.0], vec![0.0, 0.0, 1.0, 1.0],
//!     vec![vec![DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0)],
//!          vec![DVec3::new(1.0, 0.0, 0.0), DVec3::new(1.0, 1.0, 0.0)]],
//!     None,
//! )?;
//! assert_eq!(s.point(0.5, 0.25), DVec3::new(0.5, 0.25, 0.0));
//! assert_eq!(s.normal(0.5, 0.5), DVec3::Z);
//!
//! // Closest point: build the inverter once, query many times.
//! let inv = s.inverter();
//! let hit = inv.closest_point(DVec3::new(2.0, 0.5, 1.0)); // beyond the u = 1 edge
//! assert!(hit.converged && hit.on_boundary);
//! assert!((hit.uv_in_knots - DVec2::new(1.0, 0.5)).length() < sculpt_core::tolerance::EXACT_EPS);
//! sculpt_core::assert_near!(hit.distance, 2f64.sqrt(), sculpt_core::tolerance::EXACT_EPS);
//!
//! // Points along a stroke: seed each query with the previous answer.
//! let next = inv.closest_point_from(DVec3::new(0.9, 0.5, 0.1), hit.uv_in_knots);
//! assert!((next.point - DVec3::new(0.9, 0.5, 0.0)).length() < sculpt_core::tolerance::EXACT_EPS);
//! # Ok::<(), sculpt_core::Error>(())
//! ```

pub mod construct;
pub mod curve;
mod direction;
mod distance_net;
pub mod fit;
pub mod invert;
pub mod knots;
pub(crate) mod limits;
mod power;
pub mod refine;
pub mod surface;

pub use curve::{CurveDerivs, NurbsCurve};
pub use direction::Direction;
pub use invert::{Certificate, CurveProjection, Projection, SurfaceInverter};
pub use knots::{KnotVector, MAX_DEGREE};
pub use surface::{FundamentalForms, NurbsSurface, SurfaceDerivs};
