//! Tolerances, in one place for the workspace.
//!
//! A tolerance only one other crate uses (its code or its tests) lives next to its
//! users, in that crate's own `src/tolerance.rs` (`tracking::tolerance`,
//! `vr_app::tolerance`, `sculpt-tools`' and the `tests` crate's); the guard
//! `tests/tolerance_literals.rs` accepts each crate's own module. Every comparison of floating-point results in Wandsculpt, in code and in tests,
//! names one of these constants and, in tests, goes through [`assert_near!`](crate::assert_near).
//! Lengths are metres in the display frame unless a name says otherwise.

// ---------------------------------------------------------------------------------
// Geometry: distances in metres.
// ---------------------------------------------------------------------------------

/// Two points closer than this (metres) are the same point (P&T's epsilon 1).
pub const POINT_EPS: f64 = 1e-9;
/// Point inversion stops once the residual's component along the tangents is below
/// this (metres): a thousandth of [`POINT_EPS`], so a converged foot is exact to it.
pub const RESIDUAL_EPS: f64 = 1e-3 * POINT_EPS;
/// Distance (metres) by which a point must beat an answer for the certificate of a
/// point inversion to look for it: closer points within this are not worth the search.
pub const CERTIFY_TOL: f64 = 1e-10;
/// A ray hit nearer than this (metres along a unit ray) is the ray's own start.
pub const RAY_T_MIN: f64 = 1e-12;
/// A ray whose direction's dot product with a triangle's edge normal is below this is
/// parallel to the triangle (units of `|e|^2`; far below any real mesh's edges).
pub const RAY_PARALLEL_EPS: f64 = 1e-18;
/// A cosine between a ray's unit direction and a plane's unit normal below this is a
/// ray parallel to the plane (no hit).
pub const PARALLEL_COS_EPS: f64 = 1e-12;
/// Vertices closer than this (metres) are welded in exported meshes.
pub const EXPORT_WELD_EPS: f32 = 1e-6;
/// Vertices closer than this (metres) are welded where a test checks watertightness:
/// far below any mesh spacing, above rounding of f32 coordinates near a metre.
pub const TEST_WELD_EPS: f32 = 1e-7;
/// Vertices closer than this (metres, f32 coordinates) are welded where a test wants
/// only coincident points merged.
pub const POINT_WELD_EPS: f32 = 1e-9;
/// A surface grid whose opposite edges agree to this fraction of its diagonal is
/// closed in that direction (a seam).
pub const SEAM_REL: f64 = 1e-7;
/// Default chord tolerance (metres) when none (or a non-positive one) is given: a
/// millimetre, the display's resolution at arm's length.
pub const DEFAULT_CHORD_TOL: f64 = 1e-3;
/// A sketch row counts as moved from the previous kept one when some point moved
/// more than this (metres): a tenth of a millimetre, below the tracker's jitter.
pub const ROW_MOVED_EPS: f64 = 1e-4;
/// A stroke shorter than this fraction of its tool's width has zero length.
pub const MIN_STROKE_LEN_REL: f64 = 1e-3;
/// The smallest resampling spacing of a stroke (metres; zero would never advance).
pub const MIN_SPACING: f64 = 1e-12;
/// A stroke surface's fitting tolerance: this fraction of the tool's depth ...
pub const FIT_TOL_DEPTH_REL: f64 = 0.075;
/// ... plus this fraction of its width.
pub const FIT_TOL_WIDTH_REL: f64 = 1e-3;

// ---------------------------------------------------------------------------------
// Parameter space.
// ---------------------------------------------------------------------------------

/// Distance (in normalised parameter units) within which a point counts as on an edge.
pub const ON_EDGE_EPS: f64 = 1e-12;
/// A parameter within this fraction of the domain's size of an open edge of the domain
/// is on the boundary.
pub const DOMAIN_EDGE_REL: f64 = 1e-12;
/// Barycentric coordinates may stray this far outside `[0, 1]` for a ray to still hit
/// a triangle: rays through a shared edge hit one of its two triangles.
pub const BARYCENTRIC_EPS: f64 = 1e-9;
/// Bounding rectangles in parameter space are padded by this, so points on their
/// edges are inside.
pub const UV_PAD: f64 = 1e-9;
/// A component of the hidden region (`sculpt::hidden`) takes part in a union or a
/// query when its bounds come within this of the footprint or query rectangle (in
/// parameter units): wider than the polygon boolean's snapping grid (a few 1e-9 over
/// `[-1, 2]^2`) and than [`ON_EDGE_EPS`], so no component that could meet is left out.
pub const HIDDEN_COMPONENT_MARGIN: f64 = 1e-6;
/// The smallest parameter extent of a grid's cells (a zero extent would divide by 0).
pub const UV_EXTENT_MIN: f64 = 1e-12;
/// A polygon in parameter space with a smaller signed area than this is degenerate.
pub const UV_AREA_EPS: f64 = 1e-18;
/// Two-sided margin (parameter units) of properties that classify points as inside or
/// outside a loop: points nearer the loop than this are not classified.
pub const CLASSIFY_MARGIN: f64 = 1e-9;

// ---------------------------------------------------------------------------------
// Angles, cosines and unit quantities.
// ---------------------------------------------------------------------------------

/// A cosine smaller than this counts as zero (P&T's epsilon 2, for point inversion).
pub const COSINE_EPS: f64 = 1e-9;
/// The looser cosine test accepting a point inversion that found no descent left.
pub const LOOSE_COSINE_EPS: f64 = 1e-6;
/// Angles (radians) within this of a quarter-turn multiple take the smaller arc count.
pub const ANGLE_EPS: f64 = 1e-12;
/// A quaternion (or direction) shorter than this is zero: input, not a rotation.
pub const ZERO_QUAT_LEN: f64 = 1e-6;
/// A quaternion whose squared length is below this is zero (an untracked pose).
pub const ZERO_QUAT_LEN2: f64 = 1e-6;
/// A quaternion shorter than this cannot be normalised.
pub const NORMALISABLE_LEN: f64 = 1e-12;

// ---------------------------------------------------------------------------------
// Relative bounds and solvers.
// ---------------------------------------------------------------------------------

/// Exact constructions (rational conics, knot insertion) reproduce shapes to this.
pub const EXACT_EPS: f64 = 1e-12;
/// Two quantities differing by less than this fraction of their size are equal (a few
/// thousand ulps: above the rounding of any evaluation here).
pub const REL_EPS: f64 = 1e-12;
/// A matrix whose smallest singular value, eigenvalue or curvature is below this
/// fraction of its largest is singular (solves drop or shift that direction).
pub const SINGULAR_REL: f64 = 1e-12;
/// Points spanning an area below this fraction of their extent squared are collinear.
pub const COLLINEAR_AREA_REL: f64 = 1e-12;
/// A 2x2 Hessian with `det > POS_DEF_REL tr^2` is clearly positive definite
/// (`lmin / lmax > 1e-11`, as `det = lmin lmax` and `tr = lmin + lmax`).
pub const POS_DEF_REL: f64 = 1e-11;
/// A Hessian that is not positive definite is shifted to have this fraction of its
/// largest eigenvalue as its smallest.
pub const HESSIAN_SHIFT_REL: f64 = 1e-6;
/// A bilinear patch's Jacobian determinant below this fraction of `|a| |c|` is
/// singular: its inversion stops.
pub const BILINEAR_SINGULAR_REL: f64 = 1e-14;
/// A net is certified convex when `a c` beats `twist^2` by this fraction.
pub const CONVEX_MARGIN_REL: f64 = 1e-9;
/// A squared normal below this fraction of `(|S_u|^2 max |S_v|^2)^2` is undefined.
pub const NORMAL_DEGENERATE_REL2: f64 = 1e-24;
/// A normal shorter than this fraction of `|S_u| |S_v|` is undefined.
pub const NORMAL_DEGENERATE_REL: f64 = 1e-9;
/// Guard against division by zero or the logarithm of zero: a divisor (or argument)
/// is clamped to at least this.
pub const DIVISOR_MIN: f64 = 1e-300;
/// The smallest aspect ratio a stroke surface's parameter scaling takes.
pub const ASPECT_MIN: f64 = 1e-3;

// ---------------------------------------------------------------------------------
// Finite steps and differences.
// ---------------------------------------------------------------------------------

/// Finite-difference derivative checks agree to this (relative to the derivative's size).
pub const FD_EPS: f64 = 1e-5;
/// The step of central finite differences in tests.
pub const FD_STEP: f64 = 1e-6;
/// First derivatives by central differences with [`FD_STEP`] agree to this.
pub const FD_D1_EPS: f64 = 1e-6;
/// Fractions of the way to the domain's centre at which a NURBS normal at a pole is
/// taken instead, nearest first.
pub const POLE_NORMAL_STEPS: [f64; 3] = [1e-7, 1e-5, 1e-3];
/// Fractions of the way to the domain's centre at which a surface's normal at a
/// degenerate point is taken instead, nearest first.
pub const DEGENERATE_NORMAL_STEPS: [f64; 3] = [1e-6, 1e-4, 1e-2];
/// Fraction of the way to the centre at which a stroke surface's normal at a
/// degenerate (tapered) point is taken instead.
pub const DEGENERATE_NORMAL_INSET: f64 = 1e-3;

// ---------------------------------------------------------------------------------
// Time (seconds).
// ---------------------------------------------------------------------------------

/// Times closer than this (seconds) are the same time; also the margin by which an
/// end time passes a timeout so the timeout has fired.
pub const TIME_EPS: f64 = 1e-9;
/// Speeds are estimated over at least this interval (seconds).
pub const MIN_SPEED_DT: f64 = 1e-3;

// ---------------------------------------------------------------------------------
// Test comparisons.
// ---------------------------------------------------------------------------------

/// Results of a handful of flops on values of order one agree to this (a few ulps).
pub const ULP_EPS: f64 = 1e-15;
/// Results of tens of flops on values of order one agree to this.
pub const ROUNDING_EPS: f64 = 1e-14;
/// Sums of B-spline basis functions (a partition of unity) equal one to this.
pub const SUM_EPS: f64 = 1e-13;
/// Conversions between forms (knot refinement, power basis) agree to this,
/// relative to the values' size.
pub const CONVERSION_REL: f64 = 1e-11;
/// Least-squares fits and interpolations reproduce their data to this (metres).
pub const FIT_EPS: f64 = 1e-10;
/// Relative residual at which the conjugate gradients of a joint network fit stop.
pub const CG_REL_TOL: f64 = 1e-5;
/// The most conjugate gradient iterations of a joint network fit.
pub const CG_MAX_ITERATIONS: usize = 2000;
/// Distances found by a point inversion agree with a brute-force reference to this
/// (metres); converged answers farther apart are distinct minima.
pub const INVERSION_EPS: f64 = 1e-8;
/// A foot point is determined only to about the square root of the distance
/// tolerance (the distance is stationary there): feet agree to this (metres).
pub const STATIONARY_FOOT_EPS: f64 = 1e-6;
/// A local Newton run that ends farther than this (metres) beyond the true distance
/// lost track of the stroke's foot.
pub const LOST_TRACK_EPS: f64 = 1e-4;
/// A parameter within this of the domain's edge is on the boundary (tests).
pub const ON_BOUNDARY_EPS: f64 = 1e-9;
/// A mesh's centreline reproduces the carved surface to this fraction of the target's
/// size (the stated `Detail::Final` tolerance, 0.1 %).
pub const CENTRELINE_TOL_REL: f64 = 1e-3;
/// Basis function derivatives by two algorithms agree to this, relative to their size.
pub const BASIS_DERIV_REL: f64 = 1e-9;
/// A least-squares approximation of a wavy test grid stays within this (metres).
pub const APPROX_FIT_TOL: f64 = 5e-3;
/// A stroke's polygonal footprint has the area of its exact outline to this (m^2:
/// its round ends are polygons).
pub const FOOTPRINT_AREA_TOL: f64 = 1e-4;
/// Footprint areas of the same stroke drawn at two places with the same
/// parametrisation agree to this (m^2).
pub const AREA_SYMMETRY_EPS: f64 = 1e-6;
/// A bound checked in a test may be exceeded by rounding up to this (in the bound's
/// units).
pub const BOUND_MARGIN: f64 = 1e-9;
/// A carved depth (metres) reproduces the tool's depth to this at a parameter seam,
/// where the stroke is split: a tenth of a millimetre.
pub const SEAM_DEPTH_TOL: f64 = 1e-4;
/// Areas and widths carried through f32 mesh coordinates agree to this.
pub const F32_EPS: f64 = 1e-6;
/// Lengths along a carved arc agree with the arc to this fraction.
pub const ARC_LEN_REL: f64 = 1e-3;
/// Areas of the same stroke carved at two places on a sphere agree to this fraction.
pub const AREA_SYMMETRY_REL: f64 = 1e-6;
/// A drawn stroke's foot reproduces the wand position to this (metres): the wand's
/// surface hit goes through a coarse mesh.
pub const MESH_HIT_EPS: f64 = 1e-3;
/// The final-detail mesh reproduces the groove bottom to within this (metres): a tenth
/// of the 5 mm tool depth, for the V profile's sharp bottom between mesh samples.
pub const GROOVE_TOL: f64 = 0.5e-3;

// ---------------------------------------------------------------------------------
// Tessellation of sculpted targets.
// ---------------------------------------------------------------------------------

/// Chord tolerance of a target tessellated while sculpting, as a fraction of its size
/// (bounding-box diagonal): 0.2 %.
pub const INTERACTIVE_CHORD_FRACTION: f64 = 2e-3;
/// Chord tolerance of a target tessellated for the final render and export, as a
/// fraction of its size: 0.1 %.
pub const FINAL_CHORD_FRACTION: f64 = 1e-3;
/// Corner normals of one vertex closer than this (unit vectors) are one normal, written
/// once: the same smooth sheet seen from two triangles differs only by rounding (a
/// crease of under a micro-radian would not show).
pub const NORMAL_MERGE: f64 = 1e-6;
/// Distance (normalised parameter units) below which a mesher vertex counts as lying on
/// a constraint segment, and a crossing as lying on a segment's end.
pub const MESH_SNAP_EPS: f64 = 1e-12;
/// Distance (normalised parameter units) below which two points of a mesher cell are
/// one vertex. Crossings of nearly parallel outline segments beside a shared outline
/// vertex come out a few [`MESH_SNAP_EPS`] apart; kept apart, they make sliver
/// triangles whose welded edges are shared by four triangles (a round-ended U stroke
/// on the sphere).
pub const MESH_MERGE_EPS: f64 = 1e-10;
/// Parameter coordinates smaller than this are written as 0.0 before triangulation:
/// the triangulator merges -0.0 with 0.0 and rejects subnormal-scale coordinates.
pub const MESH_ZERO_COORD: f64 = 1e-30;
/// The points of a side of the parameter square that coincide within this fraction of
/// the target's size make a pole (a sphere's).
pub const POLE_SIDE_REL: f64 = 1e-9;
/// Distance (normalised parameter units) from a pole of the ring whose normals average
/// to the pole's normal (at the pole a derivative vanishes).
pub const POLE_RING_PARAM: f64 = 1e-4;
/// How far short of the rim (fraction of the half-width) a U profile's slope is taken
/// for normals: at the rim itself the wall is vertical and the slope infinite.
pub const PROFILE_EDGE: f64 = 1e-6;
/// Below this distance from the centreline (fraction of the half-width) a point counts
/// as on it: the depth's gradient there is taken on the side of the shaded triangle
/// (a V groove's bottom is a crease).
pub const CREASE_FRACTION: f64 = 1e-3;
/// A carved depth read from a mesh between its samples reproduces the tool's profile
/// to this (metres) in tests: a tenth of a millimetre.
pub const MESH_DEPTH_TOL: f64 = 1e-4;

// ---------------------------------------------------------------------------------
// Stroke splitting.
// ---------------------------------------------------------------------------------

/// Consecutive feet of a stroke's samples farther apart along the surface than this
/// many sample spacings jumped to another basin of the distance (see
/// [`crate::sculpt::stroke`]): the stroke is split there.
pub const BASIN_JUMP_RATIO: f64 = 4.0;

// ---------------------------------------------------------------------------------
// Reconstruction (scan to sculpt).
// ---------------------------------------------------------------------------------

/// How far a point snapped onto sampled data may lie from the sampled surface,
/// relative to the surface's size (the local quadric fit's error, far below the point
/// spacing of the test clouds).
pub const SNAP_REL_TOL: f64 = 1e-4;

/// Largest cosine deficit between a snap's line and the true normal.
pub const SNAP_NORMAL_COS_TOL: f64 = 1e-3;

// ---------------------------------------------------------------------------------
// Ray casting (the desktop pointer on the document, `sculpt::ray`).
// ---------------------------------------------------------------------------------

/// Sphere tracing hands over to Newton's method once the ray is this close to the
/// target, as a fraction of the target's size (a micrometre on a 1 m sheet).
pub const RAY_POLISH_REL: f64 = 1e-6;
/// A ray hit agrees with an analytic one (plane, sphere, quadratic sheet) to this
/// (metres along the ray): Newton stops at a residual of [`POINT_EPS`], seen along a
/// ray at a slant.
pub const RAY_HIT_TOL: f64 = 1e-7;
/// A ray hit agrees with the first hit on a fine (512 x 512) triangle grid of the
/// surface to this (metres along the ray): the grid's chord error at a slant.
pub const RAY_MESH_TOL: f64 = 1e-4;
// Implicit solids (sculpt_core::implicit).
// ---------------------------------------------------------------------------------

/// Two f64 evaluations of the same implicit function by different routes (a tree walk
/// and a folded graph) agree to this (absolute, function units near 1).
pub const IMPLICIT_F64_EPS: f64 = 1e-12;
/// An f32 tape agrees with an f64 tree walk to this fraction of the largest
/// intermediate magnitude (plus one): f32 rounding over tapes of tens of ops.
pub const IMPLICIT_F32_REL: f64 = 1e-4;
/// Step of the central differences that check derivatives (function units).
pub const IMPLICIT_FD_STEP: f64 = 1e-6;
/// A symbolic derivative agrees with a central difference to this.
pub const IMPLICIT_FD_EPS: f64 = 1e-6;
/// A normalised (distance-like) primitive has |grad| = 1 on its boundary to this
/// (Shin et al. 2007, eq. 1), evaluated in f64.
pub const IMPLICIT_UNIT_GRAD_EPS: f64 = 1e-9;
/// Forward-mode f32 gradients agree with f64 symbolic ones to this fraction of the
/// gradient's size (plus one).
pub const IMPLICIT_GRAD_F32_REL: f64 = 1e-3;
/// Contour vertices stay at least this fraction of a grid edge from its ends, so two
/// edges never give coincident vertices (a weld would then pinch the mesh).
pub const CONTOUR_EDGE_T_MIN: f64 = 1e-3;

/// True when `a` and `b` differ by at most `tol`, counting NaN as never near.
#[inline]
pub fn near(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

/// True when a difference `d` is within tolerance `t`; a NaN difference never is.
#[inline]
pub fn within(d: f64, t: f64) -> bool {
    d <= t
}

/// Asserts that two values are within a tolerance of each other.
///
/// Works on anything that implements [`Near`]: `f64`, `f32`, arrays and slices of
/// them, tuples of two, and glam's vectors and quaternions (compared component-wise). The message prints both sides, the difference and the
/// tolerance.
///
/// ```
/// use sculpt_core::assert_near;
/// assert_near!(0.1 + 0.2, 0.3, 1e-15);
/// assert_near!([1.0, 2.0], [1.0, 2.0 + 1e-13], sculpt_core::tolerance::EXACT_EPS);
/// ```
#[macro_export]
macro_rules! assert_near {
    ($left:expr, $right:expr, $tol:expr $(,)?) => {
        $crate::assert_near!($left, $right, $tol, "")
    };
    ($left:expr, $right:expr, $tol:expr, $($msg:tt)+) => {{
        let (l, r, t) = (&$left, &$right, $tol as f64);
        let d = $crate::tolerance::Near::max_abs_diff(l, r);
        if !$crate::tolerance::within(d, t) {
            panic!(
                "assert_near failed: {} vs {}\n  left:  {:?}\n  right: {:?}\n  max |diff| = {:e} > tol {:e}\n  {}",
                stringify!($left), stringify!($right), l, r, d, t, format!($($msg)+)
            );
        }
    }};
}

/// Values that can be compared within a tolerance.
pub trait Near: std::fmt::Debug {
    /// The largest absolute component difference (NaN or infinity when incomparable).
    fn max_abs_diff(&self, other: &Self) -> f64;
}

impl Near for f64 {
    fn max_abs_diff(&self, other: &Self) -> f64 {
        let d = (self - other).abs();
        if d.is_nan() { f64::INFINITY } else { d }
    }
}

impl Near for f32 {
    fn max_abs_diff(&self, other: &Self) -> f64 {
        f64::from(*self).max_abs_diff(&f64::from(*other))
    }
}

impl<T: Near> Near for [T] {
    fn max_abs_diff(&self, other: &Self) -> f64 {
        if self.len() != other.len() {
            return f64::INFINITY;
        }
        self.iter()
            .zip(other)
            .map(|(a, b)| a.max_abs_diff(b))
            .fold(0.0, f64::max)
    }
}

impl<T: Near, const N: usize> Near for [T; N] {
    fn max_abs_diff(&self, other: &Self) -> f64 {
        self.as_slice().max_abs_diff(other.as_slice())
    }
}

impl<T: Near> Near for Vec<T> {
    fn max_abs_diff(&self, other: &Self) -> f64 {
        self.as_slice().max_abs_diff(other.as_slice())
    }
}

impl<A: Near, B: Near> Near for (A, B) {
    fn max_abs_diff(&self, other: &Self) -> f64 {
        self.0
            .max_abs_diff(&other.0)
            .max(self.1.max_abs_diff(&other.1))
    }
}

/// glam's vectors and quaternions compare component-wise, like their arrays.
macro_rules! near_by_array {
    ($($t:ty),*) => {$(
        impl Near for $t {
            fn max_abs_diff(&self, other: &Self) -> f64 {
                self.to_array().max_abs_diff(&other.to_array())
            }
        }
    )*};
}
near_by_array!(
    glam::DVec2,
    glam::DVec3,
    glam::DVec4,
    glam::DQuat,
    glam::Vec2,
    glam::Vec3
);

impl<T: Near + ?Sized> Near for &T {
    fn max_abs_diff(&self, other: &Self) -> f64 {
        (**self).max_abs_diff(*other)
    }
}

// ---------------------------------------------------------------------------------
// Volumes (VNURBS, Park 2005): sculpt_core::volume.
// ---------------------------------------------------------------------------------

/// Exact volume geometry (the rational quarter cylindrical shell's volume and mass)
/// agrees with the analytic value to this fraction (the issue's bound).
pub const VOLUME_EXACT_REL: f64 = 1e-12;
/// Volume evaluation agrees with a slow direct Cox-de Boor sum to this, relative to
/// the size of the values (a few hundred flops of rounding).
pub const VOLUME_EVAL_REL: f64 = 1e-12;
/// Relative residual `|N^T P - N^T N A| / |N^T P|` at which the conjugate gradients of
/// a volume's least-squares fit stop (per attribute).
pub const VOLUME_CG_REL: f64 = 1e-12;
/// The inverse map (physical point to parameters) stops when the mapped point is this
/// fraction of the volume's size from the query; farther, the point is outside.
pub const VOLUME_INVERT_REL: f64 = 1e-12;
/// A Jacobian `sqrt(g)` below this fraction of `|B_u| |B_v| |B_w|` is singular.
pub const VOLUME_SINGULAR_REL: f64 = 1e-12;
/// The divergence theorem on a curved volume holds to this (relative) with a 12-point
/// Gauss rule per knot span: the quadrature's accuracy on rational integrands.
pub const VOLUME_QUADRATURE_REL: f64 = 1e-10;
/// Parameters recovered by the inverse map agree with the true ones to this.
pub const VOLUME_INVERSE_PARAM_EPS: f64 = 1e-10;
/// A cubic interpolation of a 9 x 6 x 5 curvilinear grid reproduces its smooth field
/// between the nodes to this (absolute, field values of order one).
pub const VOLUME_GRID_INTERP_EPS: f64 = 1e-2;
/// Refinement and degree elevation leave the map unchanged to this, relative to the
/// size of the values.
pub const VOLUME_REFINE_REL: f64 = 1e-12;

// ---------------------------------------------------------------------------------
// Conforming tessellation of patch networks (`sculpt::conform`, issue 30 item 2).
// ---------------------------------------------------------------------------------

/// Largest difference of two patches' knots along a side (normalised to `[0, 1]`) for
/// the side to count as shared: the knots of a reversed side are `1 - t`, which may
/// differ from the other patch's `t` by rounding.
pub const CONFORM_KNOT_EPS: f64 = 1e-12;

/// Largest area fraction of a reconstructed network that may face against the data's
/// normals (issue 30: at most 0.1 %).
pub const FOLD_AREA_FRACTION: f64 = 1e-3;

// ---------------------------------------------------------------------------------
// Carved patches of a network (fixed sides, `sculpt::tessellate::sides`, issue 30).
// ---------------------------------------------------------------------------------

/// Distance (normalised parameter units) within which a stroke's point (a constraint's
/// end) counts as lying on a fixed side of its patch: the projection of a stroke that
/// runs up to a patch's side clamps its feet onto the side only up to the inverter's
/// convergence, and a point left a few `1e-8` inside would make a sliver whose corners
/// are one vertex in `f32`. Such a point is moved onto the side.
pub const FIXED_SIDE_SNAP: f64 = 1e-6;

// ---------------------------------------------------------------------------------
// Dual contouring of implicit solids (sculpt_core::implicit::dual, issue 34).
// ---------------------------------------------------------------------------------

/// Singular values of a cell's QEF matrix A (one row per tangent plane) below this
/// fraction of the largest are dropped (Lindstrom 2000; Ju et al. 2002 sec. 2.3):
/// normals that differ by less than about 15 degrees count as one plane, so smooth
/// patches get rank 1, and an edge is seen even where one face has ten times the
/// other's points in the cell.
pub const DUAL_QEF_SVD_REL: f64 = 0.25;
/// Dual contouring reproduces a box's edges to this fraction of a grid cell: a vertex
/// on them within every cell along them, and the mesh through every point of them
/// (both measured 2.3e-7 of 0.05), where marching tetrahedra keep their vertices on
/// grid edges and cut the box's edges by two thirds of a cell.
pub const DUAL_EDGE_CELL_FRAC: f64 = 0.05;

// ---------------------------------------------------------------------------------
// Corner bounds of monotone R-functions (sculpt_core::implicit::rfunc::MonotoneR,
// issue 34).
// ---------------------------------------------------------------------------------

/// Factor on the first-order f32 error bound of an R-function formula (a few units
/// of roundoff per op, see `MonotoneR::corner_interval`) before it widens the corner
/// values: covers the second-order terms and the f32 rounding of the constants
/// `-2 alpha` and `1 / (1 + alpha)`.
pub const RFUNC_INTERVAL_ERR_MARGIN: f64 = 4.0;
/// Absolute widening of R-function corner bounds: squares of arguments below 1e-19
/// underflow in f32 (spacing 1.4e-45), which moves a root by at most 1e-22.
pub const RFUNC_INTERVAL_ABS: f64 = 1e-20;
/// Largest argument magnitude sum for which R-function corner bounds are used: the
/// f32 squares stay below f32::MAX (3.4e38), so the formula is monotone up to rounding.
pub const RFUNC_INTERVAL_MAX_ARG: f64 = 1e18;
/// Smallest argument magnitude sum for which R-function corner bounds are used: above
/// it the larger square is a normal f32 (>= 2.5e-31), so underflow in the smaller
/// cannot push `R_alpha`'s radicand below zero when |alpha| < 1 - 1e-5.
pub const RFUNC_INTERVAL_MIN_ARG: f64 = 1e-15;
/// `R_alpha` with |alpha| within this of 1 may take the root of a radicand rounded
/// below zero (NaN): its corner bound keeps the "may be NaN" flag.
pub const RFUNC_INTERVAL_NAN_ALPHA: f64 = 1e-5;

// Volume applications (Park 2005, sec. 5; issue 33): streamlines, critical points,
// isosurfaces, image morphing.
// ---------------------------------------------------------------------------------

/// Default local error per Dormand-Prince step of a streamline, relative to the
/// parameter domain's width in each direction.
pub const STREAMLINE_STEP_REL: f64 = 1e-10;
/// A streamline ends on the boundary when its point is within this fraction of the
/// domain's width of a face (the last step is shortened until it is).
pub const STREAMLINE_BOUNDARY_REL: f64 = 1e-9;
/// A closed orbit of a rigid rotation traced for one period comes back to its seed
/// within this (absolute, orbit radius of order one; the issue's bound).
pub const STREAMLINE_CLOSURE_EPS: f64 = 1e-6;
/// Newton's method for a zero of the velocity stops when `|V|` is this fraction of the
/// largest control velocity (a few roundings of a cubic evaluation).
pub const CRITICAL_ZERO_REL: f64 = 1e-13;
/// An eigenvalue (or a real part) of the velocity gradient within this fraction of
/// the largest eigenvalue's modulus counts as zero when classifying a critical point.
/// At a double root Newton stops `sqrt(CRITICAL_ZERO_REL)` away, where the vanishing
/// eigenvalue is about `2e-7` of the others: this must lie above that.
pub const CRITICAL_EIGEN_REL: f64 = 1e-5;
/// Two zeros of the velocity closer than this fraction of the parameter domain are
/// one critical point (a double root is found to about `3e-7`).
pub const CRITICAL_SAME_REL: f64 = 1e-5;
/// A double root (a degenerate critical point) is located to this (absolute).
pub const CRITICAL_DOUBLE_ROOT_EPS: f64 = 1e-5;
/// Critical points found in a test lie this close (absolute, field of size one) to
/// the analytic ones.
pub const CRITICAL_POSITION_EPS: f64 = 1e-9;

// Mesh-free heat analysis and heterogeneous material (R-function method, Shin, Kim
// and Sheen 2007, sec. 2.3 and 3): sculpt_core::implicit::rfm, implicit::material.
// ---------------------------------------------------------------------------------

/// Step of the central differences that check second-order jets (a compromise between
/// truncation, O(h^2), and rounding, O(eps / h^2), for second derivatives).
pub const RFM_FD_STEP: f64 = 1e-3;
/// Second-order jets agree with central differences of step [`RFM_FD_STEP`] to this,
/// relative to the size of the derivative.
pub const RFM_JET_FD_REL: f64 = 1e-4;
/// A boundary crossing on a quadrature cell's edge is located to this fraction of the
/// edge (regula falsi, Illinois variant).
pub const RFM_ROOT_REL: f64 = 1e-12;
/// A basis function whose energy (the stiffness diagonal) is below this fraction of the
/// largest is left out of the system: its support barely meets the domain, and keeping
/// it would only add rounding (the extended B-spline idea of Hoellig's web-splines).
pub const RFM_DROP_REL: f64 = 1e-10;
/// The ring's probes agree with the exact solution `C + D ln r` to this with the
/// paper's 10 x 10 bicubic basis (the issue's bound, kelvin).
pub const RFM_RING_PROBE_K: f64 = 1.0;
/// Transfinite and inverse-distance interpolation reproduce the given values on their
/// boundaries and points, and the weights sum to one, to this (relative).
pub const MATERIAL_EXACT_REL: f64 = 1e-12;
/// After Jacobi scaling, a Cholesky pivot below this fraction of the largest means the
/// Ritz system is singular to working precision (the solve is refused).
pub const RFM_SINGULAR_REL: f64 = 1e-14;

// ---------------------------------------------------------------------------
// Lattice deformation (sculpt_core::lattice).

/// The test bend of `docs/lattice.md` (the default sheet, a 0.1 m pull of a 4 x 4 x 4
/// lattice) stays this fraction of the pull from the exact composition `F(S(u, v))`:
/// mapping control points approximates the composition (measured: see that page).
pub const LATTICE_BEND_MAX_REL: f64 = 0.1;

// ---------------------------------------------------------------------------------
// Painted attributes (sculpt_core::paint, issue 35 item 2).
// ---------------------------------------------------------------------------------

/// Below this fitted coverage an attribute field holds no paint: the quotient
/// `value x coverage / coverage` is noise there (`AttributeField::eval`).
pub const PAINT_COVERAGE_MIN: f64 = 0.05;
/// A painted spot's fitted colour (or scalar, relative to its value) within the brush
/// is the painted value to this: the least-squares fit (Park 2005, sec. 3.1) smooths
/// the spot's rim, not its middle.
pub const PAINT_VALUE_TOL: f64 = 0.1;

// ---------------------------------------------------------------------------------
// Solid targets carved through (sculpt_core::solid, issue 35 item 3).
// ---------------------------------------------------------------------------------

/// Newton steps that move a stroke sample onto a solid's surface (for a first-order
/// normalised omega the first step lands within the curvature error; the rest polish).
pub const SOLID_NEWTON_STEPS: usize = 6;
/// Grid cells kept between a solid's box and the grid's outer layer, and the width (in
/// cells) of the band past a tool's reach in which its function is still evaluated.
pub const SOLID_MARGIN_CELLS: usize = 2;
/// Half the side of the cube (metres, around the origin) searched for a solid's box.
pub const SOLID_SEARCH_HALF_SIZE: f64 = 4.0;
/// Octree levels of that search (cells of 8 m / 2^7 = 6.25 cm at the end).
pub const SOLID_BOUNDS_DEPTH: usize = 7;
/// Points a side of the sampling grid that tightens the searched box.
pub const SOLID_BOUNDS_SAMPLES: usize = 65;
/// Step (in grid cells) of the central differences that give a solid's drawn vertex
/// normals from its combined field (half a cell: below the mesh's own resolution, far
/// above f32 rounding of the field).
pub const SOLID_NORMAL_STEP_CELLS: f64 = 0.5;
/// Step (in grid cells) of the ray march that finds where a ray enters a solid (the
/// desktop pointer): half a cell, so no wall the mesh shows is stepped over.
pub const SOLID_RAY_STEP_CELLS: f64 = 0.5;
/// Bisections that refine a solid's ray hit once its step is found (a half-cell step
/// halved 40 times: far below f32 rounding of the field).
pub const SOLID_RAY_BISECTIONS: usize = 40;
/// Slack (metres) added to the radius within which a stroke's tool piece can change a
/// solid's field (`sculpt_core::solid::tool`, the bound that lets a stroke skip corners):
/// the bound is exact in real arithmetic and its f64 evaluation errs by a few ulps of a
/// metre-sized distance (about 1e-16 m), so a nanometre covers it with room to spare.
pub const SOLID_TOOL_BOUND_SLACK: f64 = 1e-9;

// ---------------------------------------------------------------------------------
// Octree simplification of dual contouring (sculpt_core::implicit::octree, issue 34).
// ---------------------------------------------------------------------------------

/// An octree node's vertex lies within this fraction of a cell of every tangent plane
/// of its patch, or the node does not collapse (the QEF error bound of Ju et al. 2002,
/// sec. 3.1, as a largest plane distance in cells).
pub const DUAL_OCTREE_QEF_CELL_FRAC: f64 = 0.25;
/// Every sample of a triangle the octree simplification makes (vertex, centroids,
/// edge midpoints) lies within this fraction of a cell of the surface (a sign change
/// of the function along the normal over this distance either side), leaving a
/// margin to the half cell the meshes must keep for the points between the samples.
pub const DUAL_OCTREE_SAMPLE_CELL_FRAC: f64 = 0.4;

// ---------------------------------------------------------------------------------
// Local refits of attribute volumes (sculpt_core::volume::fit::local, issue 35 item 2:
// the paint sample update).
// ---------------------------------------------------------------------------------
/// A local refit of a volume to the very samples it was fitted to moves its free
/// control points by less than this: both solves stop at [`VOLUME_CG_REL`].
pub const LOCAL_REFIT_SOLVED: f64 = 1e-8;
/// A local refit of a smooth bump of height 1 (free points two knot spans beyond it)
/// is the whole refit's to this at the raised samples
/// (`volume::fit::local::tests`).
pub const LOCAL_REFIT_BUMP: f64 = 0.01;
/// A paint stroke's local refit (`AttributeField::painted`) and the whole volume's
/// refit to the same samples (`painted_whole`) agree to this at the stroke's samples,
/// in value and coverage (measured 0.0085 to 0.028 on the paint bench's strokes).
pub const PAINT_LOCAL_REFIT_AGREE: f64 = 0.03;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_within_tolerance() {
        assert_near!(1.0, 1.0 + 1e-10, 1e-9);
        assert_near!(vec![1.0f32, 2.0], vec![1.0f32, 2.0], 0.0);
    }

    #[test]
    #[should_panic(expected = "assert_near failed")]
    fn fails_outside_tolerance() {
        assert_near!(1.0, 1.1, 1e-3);
    }

    #[test]
    #[should_panic(expected = "assert_near failed")]
    fn nan_is_never_near() {
        assert_near!(f64::NAN, f64::NAN, 1.0);
    }

    #[test]
    #[should_panic(expected = "assert_near failed")]
    fn length_mismatch_fails() {
        assert_near!(vec![1.0], vec![1.0, 2.0], 1.0);
    }

    #[test]
    fn glam_vectors_compare_component_wise() {
        let a = glam::DVec3::new(1.0, 2.0, 3.0);
        assert_near!(
            a,
            a + glam::DVec3::new(0.0, 0.5 * EXACT_EPS, 0.0),
            EXACT_EPS
        );
        assert_near!(glam::DVec2::ONE.max_abs_diff(&glam::DVec2::ZERO), 1.0, 0.0);
        assert_eq!(
            glam::DVec3::NAN.max_abs_diff(&glam::DVec3::ZERO),
            f64::INFINITY
        );
    }

    #[test]
    #[should_panic(expected = "assert_near failed")]
    fn glam_vectors_fail_outside_tolerance() {
        assert_near!(glam::DVec3::X, glam::DVec3::Y, POINT_EPS);
    }

    #[test]
    fn near_fn() {
        assert!(near(1.0, 1.5, 0.5));
        assert!(!near(f64::NAN, 0.0, 1.0));
    }
}
