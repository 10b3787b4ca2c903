//! The named tolerances used only by `tracking` (its code and its tests), next to
//! their users; the workspace-wide ones stay in `sculpt_core::tolerance`. Each says
//! what it compares and in what unit. A float literal with a negative exponent outside
//! a crate's tolerance module fails `sculpt-core/tests/tolerance_literals.rs`.

/// Fixed-point iterations on a parameter stop when a step is below this.
pub const FIXED_POINT_EPS: f64 = 1e-13;
/// A rotation matrix's determinant must be within this of one.
pub const ROTATION_DET_EPS: f64 = 1e-9;
/// The smallest singular value ratio of a calibration's system that is still a
/// solvable (non-degenerate) set of poses.
pub const CALIBRATION_COND_MIN: f64 = 1e-6;
/// Positions through the serial wire format, millimetres: it keeps micrometres.
pub const WIRE_MM_EPS: f64 = 1e-3;
/// Positions through a wire format that keeps micrometres (metres).
pub const WIRE_M_EPS: f64 = 1e-6;
/// Positions scaled from metres to millimetres agree to this (mm).
pub const MM_ROUNDING_EPS: f64 = 1e-6;
/// A freshly normalised quaternion has length one to this.
pub const NORMALISED_EPS: f64 = 1e-9;
/// A filtered (interpolated, renormalised) quaternion has length one to this.
pub const FILTERED_UNIT_EPS: f64 = 1e-6;
/// Rotations agree to this angle (radians).
pub const ROTATION_EPS: f64 = 1e-9;
/// Random test quaternions shorter than this are replaced by the identity
/// (normalising them would magnify rounding).
pub const QUAT_GEN_MIN_LEN: f64 = 1e-3;
/// A calibration fit to noisy poses leaves at least this rms residual (metres): the
/// noise is seen.
pub const NOISY_RMS_FLOOR: f64 = 1e-5;
/// ... and at most this (metres): the noise is half a millimetre.
pub const NOISY_RMS_CEIL: f64 = 0.001;
/// A simulated session's filtered tip ends at the script's end point to this
/// (metres): the simulator's tremor and the filter's lag.
pub const SIM_END_TOL: f64 = 0.01;
/// The time step (seconds) of a forward-difference velocity in tests.
pub const VELOCITY_FD_STEP: f64 = 1e-4;
/// A velocity by [`VELOCITY_FD_STEP`] that should be zero is below this (m/s).
pub const VELOCITY_EPS: f64 = 1e-6;
/// Orientations through the serial wire format (radians).
pub const WIRE_ANGLE_EPS: f64 = 1e-5;
/// Positions (mm) through the DTrack2 ASCII format, which keeps 3 decimals.
pub const DTRACK_MM_EPS: f64 = 5e-4;
/// Rotation matrix entries through the DTrack2 ASCII format, which keeps 6 decimals.
pub const DTRACK_ROT_EPS: f64 = 5e-7;
/// Analog values through the DTrack2 ASCII format, which keeps 2 decimals.
pub const DTRACK_ANALOG_EPS: f64 = 5e-3;
/// Poses replayed from a recording, through wire rounding (micrometres) and slerp
/// between keyframes: far below a millimetre (metres).
pub const REPLAY_POSE_EPS: f64 = 1e-3;
