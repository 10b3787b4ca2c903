//! Calibration: tracker millimetres to display metres, and the wand's tool point.
//!
//! `display_from_tracker` maps a tracker position `p` (mm) to the display frame (m):
//!
//! ```text
//! p_in_display = R · (A · (s · p_in_tracker_mm)) + t
//! display_from_body = R · A · tracker_from_body
//! ```
//!
//! with `s` the unit scale (0.001: mm → m), `A` a signed axis remap (a proper rotation,
//! e.g. DTrack's Z-up room to a Y-up display: `["x", "z", "-y"]`), `R` a rotation and
//! `t` an offset in metres. A per-device tip offset (metres, in body axes) moves the
//! tool point from the marker target to the wand tip.
//!
//! [`fit`] estimates `R`, `t` (and optionally the scale) from three or more measured
//! point pairs by Umeyama's method (Kabsch with an optional scale), with nalgebra's SVD,
//! and reports the residuals.
//!
//! ```
//! use tracking::calibration::{fit, Calibration, FitOptions};
//! use glam::{DQuat, DVec3};
//! let truth = Calibration { rotation: DQuat::from_rotation_y(0.5).to_array(), translation_m: [0.1, 0.0, -2.0], ..Calibration::default() };
//! let tracker_mm = [DVec3::ZERO, DVec3::X * 1000.0, DVec3::Y * 500.0, DVec3::new(300.0, 200.0, 900.0)];
//! let pairs: Vec<_> = tracker_mm.iter().map(|&p| (p, truth.point_in_display(p))).collect();
//! let got = fit(&pairs, &FitOptions::default()).unwrap();
//! assert!(got.rms_residual_m < sculpt_core::tolerance::POINT_EPS);
//! assert!(got.calibration.point_in_display(DVec3::ONE).distance(truth.point_in_display(DVec3::ONE)) < sculpt_core::tolerance::POINT_EPS);
//! ```

use crate::error::{CalibrationError, Degeneracy, Result, TrackingError};
use crate::frame::{DeviceId, Pose};
use glam::{DMat3, DQuat, DVec3};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A pose in the display frame: metres and a unit quaternion.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DisplayPose {
    /// The marker target's origin, metres in the display frame.
    pub position_m: DVec3,
    /// `display_from_body`.
    pub orientation: DQuat,
    /// The tool point (marker origin plus the device's tip offset), metres.
    pub tool_m: DVec3,
}

/// The tracker-to-display transform and per-device tip offsets.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Calibration {
    /// Tracker units to metres (0.001 for DTrack millimetres).
    pub scale: f64,
    /// Display axes in terms of tracker axes: e.g. `["x", "z", "-y"]` means display x =
    /// tracker x, display y = tracker z, display z = −tracker y. Must be a rotation.
    pub axes: [String; 3],
    /// The rotation `R` applied after the remap, as a quaternion `[x, y, z, w]`.
    pub rotation: [f64; 4],
    /// The offset `t`, metres.
    pub translation_m: [f64; 3],
    /// Tip offsets, metres in body axes, by device (`"wand0"`, `"body1"`).
    pub tips: BTreeMap<String, [f64; 3]>,
}

impl Default for Calibration {
    fn default() -> Self {
        Self {
            scale: 0.001,
            axes: ["x".into(), "y".into(), "z".into()],
            rotation: [0.0, 0.0, 0.0, 1.0],
            translation_m: [0.0; 3],
            tips: BTreeMap::new(),
        }
    }
}

fn axis(spec: &str) -> Option<DVec3> {
    let (sign, name) = match spec.trim().strip_prefix('-') {
        Some(n) => (-1.0, n),
        None => (1.0, spec.trim().trim_start_matches('+')),
    };
    let v = match name {
        "x" | "X" => DVec3::X,
        "y" | "Y" => DVec3::Y,
        "z" | "Z" => DVec3::Z,
        _ => return None,
    };
    Some(v * sign)
}

impl Calibration {
    /// Checks the scale, the remap (a proper rotation), the quaternion and the numbers.
    pub fn validate(&self) -> Result<()> {
        let bad = |e: CalibrationError| Err(TrackingError::Calibration(e));
        if !(self.scale.is_finite() && self.scale > 0.0) {
            return bad(CalibrationError::Scale(self.scale));
        }
        let rows: Option<Vec<DVec3>> = self.axes.iter().map(|a| axis(a)).collect();
        let Some(rows) = rows else {
            return bad(CalibrationError::AxisName(self.axes.clone()));
        };
        let det = DMat3::from_cols(rows[0], rows[1], rows[2]).determinant();
        if (det - 1.0).abs() > crate::tolerance::ROTATION_DET_EPS {
            return bad(CalibrationError::NotARotation(self.axes.clone()));
        }
        let q = DQuat::from_array(self.rotation);
        if !q.is_finite() || q.length() < sculpt_core::tolerance::ZERO_QUAT_LEN {
            return bad(CalibrationError::Rotation);
        }
        if !self.translation_m.iter().all(|v| v.is_finite()) {
            return bad(CalibrationError::Translation);
        }
        for (dev, tip) in &self.tips {
            if let Err(TrackingError::Config(e)) = dev.parse::<DeviceId>() {
                return bad(CalibrationError::TipDevice(e));
            }
            if !tip.iter().all(|v| v.is_finite()) {
                return bad(CalibrationError::Tip(dev.clone()));
            }
        }
        Ok(())
    }

    /// The remap `A` (rows are the display axes in tracker axes); identity if invalid.
    fn remap(&self) -> DMat3 {
        let rows: Option<Vec<DVec3>> = self.axes.iter().map(|a| axis(a)).collect();
        rows.map_or(DMat3::IDENTITY, |r| {
            DMat3::from_cols(r[0], r[1], r[2]).transpose()
        })
    }

    /// The rotation part of `display_from_tracker`: `R · A`.
    pub fn display_from_tracker_rotation(&self) -> DMat3 {
        DMat3::from_quat(DQuat::from_array(self.rotation).normalize()) * self.remap()
    }

    /// A tracker position (mm) in the display frame (m).
    pub fn point_in_display(&self, p_in_tracker_mm: DVec3) -> DVec3 {
        self.display_from_tracker_rotation() * (p_in_tracker_mm * self.scale)
            + DVec3::from_array(self.translation_m)
    }

    /// The tip offset of `device` (metres, body axes); zero when none is configured.
    pub fn tip(&self, device: DeviceId) -> DVec3 {
        self.tips
            .get(&device.to_string())
            .map_or(DVec3::ZERO, |t| DVec3::from_array(*t))
    }

    /// A tracker pose in the display frame, with the device's tool point. `None` when
    /// the pose is not a valid rigid pose.
    pub fn pose_in_display(&self, device: DeviceId, pose: &Pose) -> Option<DisplayPose> {
        let q_tracker = pose.orientation()?;
        if !pose.position_mm.is_finite() {
            return None;
        }
        let r = DQuat::from_mat3(&self.display_from_tracker_rotation()).normalize();
        let orientation = (r * q_tracker).normalize();
        let position_m = self.point_in_display(pose.position_mm);
        let tool_m = position_m + orientation * self.tip(device);
        Some(DisplayPose {
            position_m,
            orientation,
            tool_m,
        })
    }
}

/// Options for [`fit`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FitOptions {
    /// Axis remap and scale to apply before fitting (taken from this calibration, along
    /// with its tips); `rotation` and `translation_m` are what gets fitted.
    pub base: Calibration,
    /// Also fit the scale (Umeyama), instead of keeping `base.scale`.
    pub fit_scale: bool,
}

/// A fitted calibration and how well it fits.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// The calibration.
    pub calibration: Calibration,
    /// Root-mean-square distance between mapped tracker points and display-frame points, m.
    pub rms_residual_m: f64,
    /// Largest such distance, m.
    pub max_residual_m: f64,
    /// Each pair's residual, m, in input order.
    pub residuals_m: Vec<f64>,
}

fn na(v: DVec3) -> Vector3<f64> {
    Vector3::new(v.x, v.y, v.z)
}

/// Fits `display_from_tracker` to pairs `(p_in_tracker_mm, p_in_display_m)`.
///
/// Umeyama (1991), "Least-squares estimation of transformation parameters between two
/// point patterns": with `a_i = A·s·p_i` (remapped, scaled tracker points) and `b_i` the
/// display-frame points, centroids `ā, b̄`, covariance `Σ = (1/n) Σ (b_i − b̄)(a_i − ā)ᵀ = U D Vᵀ`,
/// `S = diag(1, 1, sign(det U · det V))`, then `R = U S Vᵀ`, `c = tr(D S) / σ²_a` (when
/// fitting the scale) and `t = b̄ − c R ā`. Needs ≥ 3 pairs, not all on one line.
pub fn fit(pairs: &[(DVec3, DVec3)], options: &FitOptions) -> Result<Fit> {
    let bad = |e: CalibrationError| Err(TrackingError::Calibration(e));
    if pairs.len() < 3 {
        return bad(CalibrationError::TooFew {
            needed: 3,
            what: "point pairs",
        });
    }
    if pairs.iter().any(|(a, b)| !a.is_finite() || !b.is_finite()) {
        return bad(CalibrationError::NotFinite("point pairs"));
    }
    let mut base = options.base.clone();
    base.rotation = [0.0, 0.0, 0.0, 1.0];
    base.translation_m = [0.0; 3];
    base.validate()?;
    let a: Vec<Vector3<f64>> = pairs
        .iter()
        .map(|(p, _)| na(base.point_in_display(*p)))
        .collect();
    let b: Vec<Vector3<f64>> = pairs.iter().map(|(_, q)| na(*q)).collect();
    let n = pairs.len() as f64;
    let ca = a.iter().sum::<Vector3<f64>>() / n;
    let cb = b.iter().sum::<Vector3<f64>>() / n;
    let mut cov = Matrix3::zeros();
    let mut var_a = 0.0;
    for (ai, bi) in a.iter().zip(&b) {
        cov += (bi - cb) * (ai - ca).transpose();
        var_a += (ai - ca).norm_squared();
    }
    cov /= n;
    var_a /= n;
    let svd = cov.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return bad(CalibrationError::Solve("SVD failed"));
    };
    let mut sv: Vec<f64> = svd.singular_values.iter().copied().collect();
    sv.sort_by(|x, y| y.total_cmp(x));
    if var_a <= 0.0 || sv[0] <= 0.0 || sv[1] <= sculpt_core::tolerance::SINGULAR_REL * sv[0] {
        return bad(CalibrationError::Degenerate(Degeneracy::Points));
    }
    // The sign flip (a reflection otherwise) goes on the smallest singular value.
    let d = if (u.determinant() * v_t.determinant()) < 0.0 {
        -1.0
    } else {
        1.0
    };
    let smallest = svd.singular_values.imin();
    let mut diag = Vector3::new(1.0, 1.0, 1.0);
    diag[smallest] = d;
    let r = u * Matrix3::from_diagonal(&diag) * v_t;
    let c = if options.fit_scale {
        svd.singular_values.component_mul(&diag).sum() / var_a
    } else {
        1.0
    };
    if !(c.is_finite() && c > 0.0) {
        return bad(CalibrationError::FittedScale);
    }
    let t = cb - c * r * ca;
    let rot = DMat3::from_cols_array(&[
        r[(0, 0)],
        r[(1, 0)],
        r[(2, 0)],
        r[(0, 1)],
        r[(1, 1)],
        r[(2, 1)],
        r[(0, 2)],
        r[(1, 2)],
        r[(2, 2)],
    ]);
    let mut calibration = base;
    calibration.scale *= c;
    calibration.rotation = DQuat::from_mat3(&rot).normalize().to_array();
    calibration.translation_m = [t.x, t.y, t.z];
    let residuals_m: Vec<f64> = pairs
        .iter()
        .map(|(p, q)| calibration.point_in_display(*p).distance(*q))
        .collect();
    let rms_residual_m = (residuals_m.iter().map(|r| r * r).sum::<f64>() / n).sqrt();
    let max_residual_m = residuals_m.iter().copied().fold(0.0, f64::max);
    Ok(Fit {
        calibration,
        rms_residual_m,
        max_residual_m,
        residuals_m,
    })
}

/// A fitted tip offset (pivot calibration) and how well it fits.
#[derive(Debug, Clone, PartialEq)]
pub struct TipFit {
    /// The tip in body axes, metres (what goes in [`Calibration::tips`]).
    pub tip_in_body_m: DVec3,
    /// The fixed point the tip pivoted about, metres in the display frame.
    pub pivot_in_display_m: DVec3,
    /// Root-mean-square distance of each pose's tip from the pivot, m.
    pub rms_residual_m: f64,
    /// Largest such distance, m.
    pub max_residual_m: f64,
}

/// Pivot calibration: the wand's tip is held on a fixed point while the wand is
/// turned; every pose `(p_i, R_i)` (display frame, metres) then satisfies
/// `R_i · tip + p_i = pivot`. Stacking `[R_i  −I] · [tip; pivot] = −p_i` gives a
/// 3n × 6 linear least-squares problem, solved by SVD. Needs ≥ 3 poses whose rotations
/// differ about at least two axes; otherwise the system is degenerate and this errors.
pub fn fit_tip(poses: &[(DVec3, DQuat)]) -> Result<TipFit> {
    let bad = |e: CalibrationError| Err(TrackingError::Calibration(e));
    if poses.len() < 3 {
        return bad(CalibrationError::TooFew {
            needed: 3,
            what: "poses (pivot calibration)",
        });
    }
    if poses.iter().any(|(p, q)| {
        !p.is_finite() || !q.is_finite() || q.length() < sculpt_core::tolerance::ZERO_QUAT_LEN
    }) {
        return bad(CalibrationError::NotFinite("poses"));
    }
    let n = poses.len();
    let mut a = nalgebra::DMatrix::<f64>::zeros(3 * n, 6);
    let mut b = nalgebra::DVector::<f64>::zeros(3 * n);
    for (i, (p, q)) in poses.iter().enumerate() {
        let r = DMat3::from_quat(q.normalize());
        for row in 0..3 {
            for col in 0..3 {
                a[(3 * i + row, col)] = r.col(col)[row];
            }
            a[(3 * i + row, 3 + row)] = -1.0;
            b[3 * i + row] = -p[row];
        }
    }
    let svd = a.svd(true, true);
    let smax = svd.singular_values.max();
    let smin = svd.singular_values.min();
    if !smax.is_finite() || smax <= 0.0 || smin < crate::tolerance::CALIBRATION_COND_MIN * smax {
        return bad(CalibrationError::Degenerate(Degeneracy::Poses));
    }
    let x = svd
        .solve(&b, sculpt_core::tolerance::SINGULAR_REL * smax)
        .map_err(|e| TrackingError::Calibration(CalibrationError::Solve(e)))?;
    let tip = DVec3::new(x[0], x[1], x[2]);
    let pivot = DVec3::new(x[3], x[4], x[5]);
    let residuals: Vec<f64> = poses
        .iter()
        .map(|(p, q)| (q.normalize() * tip + *p).distance(pivot))
        .collect();
    let rms_residual_m = (residuals.iter().map(|r| r * r).sum::<f64>() / n as f64).sqrt();
    let max_residual_m = residuals.iter().copied().fold(0.0, f64::max);
    Ok(TipFit {
        tip_in_body_m: tip,
        pivot_in_display_m: pivot,
        rms_residual_m,
        max_residual_m,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::tolerance::EXACT_EPS;

    #[test]
    fn axis_remap_z_up_to_y_up() {
        let c = Calibration {
            axes: ["x".into(), "z".into(), "-y".into()],
            ..Calibration::default()
        };
        c.validate().unwrap();
        // Tracker: 1 m up (z). Display: 1 m up (y).
        let p = c.point_in_display(DVec3::new(0.0, 0.0, 1000.0));
        assert!(p.distance(DVec3::Y) < EXACT_EPS);
        let p = c.point_in_display(DVec3::new(0.0, 1000.0, 0.0));
        assert!(p.distance(-DVec3::Z) < EXACT_EPS);
    }

    #[test]
    fn mirrors_are_refused() {
        let c = Calibration {
            axes: ["x".into(), "y".into(), "-z".into()],
            ..Calibration::default()
        };
        assert!(c.validate().is_err());
        let c = Calibration {
            axes: ["x".into(), "x".into(), "z".into()],
            ..Calibration::default()
        };
        assert!(c.validate().is_err());
    }
}
