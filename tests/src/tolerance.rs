//! The named tolerances used only by the end-to-end tests (`tests/tests/`), next to
//! their users; the workspace-wide ones stay in `sculpt_core::tolerance`. Each says
//! what it compares and in what unit. A float literal with a negative exponent outside
//! a crate's tolerance module fails `sculpt-core/tests/tolerance_literals.rs`.

// ---------------------------------------------------------------------------------
// IGES read back by OpenCASCADE (`tests/tests/iges_occt.rs`).
// ---------------------------------------------------------------------------------

/// OCCT's face area against ours (Green's theorem over the same loops, 8-point Gauss
/// per knot span): relative. Ours is converged to 1e-14; OCCT's adaptive integration
/// is asked for 1e-8 (`--area-eps`) but on cubic stroke surfaces stays up to 2.4e-6 off
/// while reporting 2e-7 to 1.3e-6, so this is 5e-6 plus twice the error it reports. A
/// misread loop or surface changes an area by far more.
pub const OCCT_AREA_REL: f64 = 5e-6;
/// The same for stroke surfaces. Since strokes wrap across the sphere's seam, the
/// wrapped stroke of `sphere-overlaps.json` is a longer, more curved cubic surface on
/// which OCCT's integration ends 1.8e-5 off (reporting 2.9e-7). Still far below what a
/// misread loop or surface changes.
pub const OCCT_STROKE_AREA_REL: f64 = 5e-5;
/// The OCCT area tolerance's floor for sliver faces, m^2 (a square micrometre).
pub const OCCT_AREA_ABS: f64 = 1e-12;
/// OCCT's surface points against our kernel's, relative to the surface's size.
pub const OCCT_POINT_REL: f64 = 1e-9;
