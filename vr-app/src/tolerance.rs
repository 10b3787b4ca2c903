//! The named tolerances used only by `vr-app` (its code and its tests), next to their
//! users; the workspace-wide ones stay in `sculpt_core::tolerance`. Each says what it
//! compares and in what unit. A float literal with a negative exponent outside a
//! crate's tolerance module fails `sculpt-core/tests/tolerance_literals.rs`.

// ---------------------------------------------------------------------------------
// The display: scenes, previews, cameras, screens, the cursor, materials.
// ---------------------------------------------------------------------------------

/// A direction's squared length (`|a x b|^2` of unit vectors, a squared sine) below
/// this means the two are parallel and their cross product is no direction.
pub const PARALLEL_SIN2_EPS: f64 = 1e-12;
/// A squared length (metres^2) below this is a zero vector: the cross product of a
/// polyline tangent with the view direction that has no direction.
pub const ZERO_LEN2_EPS: f64 = 1e-18;
/// The pitch of a camera stays this far (radians) from a quarter turn, where the
/// projection degenerates.
pub const POLE_ANGLE_MARGIN: f64 = 1e-6;
/// Largest |cos| between a screen's right and up edges that still counts as a
/// rectangle (about 0.6 degrees off square).
pub const SQUARE_COS_TOL: f64 = 1e-2;
/// Smallest screen edge (metres).
pub const MIN_SCREEN_EDGE: f64 = 1e-4;
/// Smallest distance (metres) from an eye to the screen plane.
pub const MIN_EYE_DISTANCE: f64 = 1e-3;
/// The cursor ring's points lie at their radius from the foot to this (metres, f32
/// vertices).
pub const CURSOR_RING_TOL: f64 = 1e-4;
/// The cursor ring's points lie on the surface to this (metres): the ring is lifted
/// 1 mm and the surface curves under its chords.
pub const CURSOR_RING_Z_TOL: f64 = 2e-3;
/// Values published to six decimal digits (a standard's table) agree to this.
pub const SIX_DIGITS_EPS: f64 = 1e-6;

// ---------------------------------------------------------------------------------
// GPU evaluation of implicit tapes (`gpu_eval`, issue 34) and of volumes (`gpu_volume`, issue 33).
// ---------------------------------------------------------------------------------

/// GPU and CPU values of one correctly rounded op (`add sub mul neg abs square floor
/// ceil round min max compare and or not`) agree to this many f32 ulps of the CPU
/// value: none, IEEE 754 fixes these results bit for bit (WGSL sec. 15.7.4).
pub const GPU_EVAL_EXACT_ULPS: f64 = 0.0;
/// GPU and CPU values of `div`, `recip`, `sqrt` and `mod` agree to this many f32 ulps
/// (of the CPU value; of the larger argument for `mod`, whose WGSL form
/// `a - b trunc(a / b)` rounds the product): WGSL allows 2.5 ulps for division and
/// inherits `sqrt` from `1 / inverseSqrt` (2 + 2.5 ulps), sec. 15.7.4. Lavapipe rounds
/// them correctly (0 ulps measured; `mod` 0.45).
pub const GPU_EVAL_ULPS: f64 = 5.0;
/// GPU and CPU values of `sin cos tan exp ln` agree to this fraction of
/// max(|value|, 1) on the test domains (vr-app/tests/gpu_eval.rs): the largest
/// difference measured on lavapipe, 4.6e-7 (`exp` on [-10, 10]), with a margin of 4.
/// WGSL itself allows more (2^-11 absolute for `sin` and `cos`, sec. 15.7.4), so other
/// drivers may need a looser bound.
pub const GPU_EVAL_TRANSCENDENTAL_REL: f64 = 2e-6;
/// The same for `atan atan2 asin acos` (the last two computed through `atan2`):
/// measured on lavapipe 3.4e-6, with a margin of 4 (WGSL allows 4096 ulps).
pub const GPU_EVAL_ARC_REL: f64 = 1.5e-5;
/// A whole tape on the GPU agrees with the CPU's f32 tape to this fraction of the
/// largest intermediate magnitude (plus one): the per-op differences above (a final
/// `atan`'s, and a few ulps where a driver fuses a multiply and an add) carried through
/// tapes of tens of ops. Measured on lavapipe: 1.6e-6 on random programs ending in
/// `atan`, 3.7e-7 on the shipped models.
pub const GPU_EVAL_MODEL_REL: f64 = 1e-5;
/// The GPU's f32 evaluation of a volume on a parameter grid agrees with the CPU's f64
/// one rounded to f32 to this, relative to the largest absolute control value of the
/// attribute (the convex hull property bounds the values by it): the basis functions
/// (P&T A2.2 in f32, a few roundings each), a sum over up to `(p + 1)^n` products and
/// the division by the weight, each a few f32 ulps (`2^-24`, about `6e-8`).
pub const VOLUME_GPU_REL: f64 = 4e-6;
