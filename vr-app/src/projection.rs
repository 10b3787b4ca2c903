//! Head-tracked off-axis stereo: Kooima's generalized perspective projection.
//!
//! A physical screen is a rectangle in the display frame (metres), given by three
//! corners: lower-left `pa`, lower-right `pb` and upper-left `pc`. For an eye at `pe`
//! the view frustum is the pyramid from the eye through the screen's edges; it is
//! asymmetric whenever the eye is not centred in front of the screen, and it changes as
//! the head moves, which is what keeps the picture right as the sculptor walks.
//!
//! ```
//! use glam::{DQuat, DVec3};
//! use vr_app::projection::{HeadPose, Screen, StereoRig};
//! // A 2 m x 1.5 m wall whose lower-left corner is at the origin.
//! let wall = Screen::new(
//!     DVec3::new(-1.0, 0.0, 0.0),
//!     DVec3::new(1.0, 0.0, 0.0),
//!     DVec3::new(-1.0, 1.5, 0.0),
//! ).unwrap();
//! let head = HeadPose { position: DVec3::new(0.0, 0.75, 2.0), orientation: DQuat::IDENTITY };
//! let rig = StereoRig::default();
//! let (left, right) = rig.eye_cameras(&wall, &head).unwrap();
//! // A point on the screen plane has zero parallax: both eyes see it at the same place.
//! let p = DVec3::new(0.3, 0.5, 0.0);
//! let (l, r) = (left.project(p).unwrap(), right.project(p).unwrap());
//! assert!((l - r).length() < sculpt_core::tolerance::POINT_EPS);
//! ```

use glam::{DMat4, DQuat, DVec2, DVec3, DVec4};
use serde::{Deserialize, Serialize};

use crate::error::{ProjectionError, ScreenError, VrError, VrResult};
use crate::tolerance::{MIN_EYE_DISTANCE, MIN_SCREEN_EDGE, SQUARE_COS_TOL};

/// A planar rectangular screen in the display frame (metres).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Screen {
    /// Lower-left corner `pa`.
    pub lower_left: DVec3,
    /// Lower-right corner `pb`.
    pub lower_right: DVec3,
    /// Upper-left corner `pc`.
    pub upper_left: DVec3,
}

impl Screen {
    /// A screen from its lower-left, lower-right and upper-left corners.
    ///
    /// Fails when a corner is not finite, an edge is shorter than 0.1 mm, or the two
    /// edges are not perpendicular (the projection assumes a rectangle).
    pub fn new(lower_left: DVec3, lower_right: DVec3, upper_left: DVec3) -> VrResult<Self> {
        let s = Self {
            lower_left,
            lower_right,
            upper_left,
        };
        s.validate()?;
        Ok(s)
    }

    /// Checks the corners (see [`Screen::new`]).
    pub fn validate(&self) -> VrResult<()> {
        let bad = |why: ScreenError| Err(VrError::Screen(why));
        if !(self.lower_left.is_finite()
            && self.lower_right.is_finite()
            && self.upper_left.is_finite())
        {
            return bad(ScreenError::CornerNotFinite);
        }
        let right = self.lower_right - self.lower_left;
        let up = self.upper_left - self.lower_left;
        if right.length() < MIN_SCREEN_EDGE || up.length() < MIN_SCREEN_EDGE {
            return bad(ScreenError::EdgeTooShort);
        }
        if right.normalize().dot(up.normalize()).abs() > SQUARE_COS_TOL {
            return bad(ScreenError::NotRectangular);
        }
        Ok(())
    }

    /// Width (metres).
    pub fn width(&self) -> f64 {
        (self.lower_right - self.lower_left).length()
    }

    /// Height (metres).
    pub fn height(&self) -> f64 {
        (self.upper_left - self.lower_left).length()
    }

    /// The screen's orthonormal basis `(vr, vu, vn)`: right, up, and the normal pointing
    /// towards the viewer.
    pub fn basis(&self) -> (DVec3, DVec3, DVec3) {
        let vr = (self.lower_right - self.lower_left).normalize();
        let vu = (self.upper_left - self.lower_left).normalize();
        let vn = vr.cross(vu).normalize();
        (vr, vu, vn)
    }

    /// The centre of the screen.
    pub fn center(&self) -> DVec3 {
        self.lower_left
            + 0.5 * (self.lower_right - self.lower_left)
            + 0.5 * (self.upper_left - self.lower_left)
    }
}

/// The tracked head: position in the display frame (metres) and orientation
/// (`display_from_head`); the head's +X axis points to the viewer's right.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HeadPose {
    /// Mid-point between the eyes, metres in the display frame.
    pub position: DVec3,
    /// Rotation from head axes to the display frame.
    pub orientation: DQuat,
}

/// One eye's camera for one screen: the combined `clip_from_display` matrix and the
/// frustum extents at the near plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EyeCamera {
    /// Eye position in the display frame.
    pub eye: DVec3,
    /// Projection (clip from eye-aligned screen space), depth range [0, 1].
    pub clip_from_view: DMat4,
    /// View (eye-aligned screen space from the display frame): `M^T * T(-pe)`.
    pub view_from_display: DMat4,
    /// Frustum extents `(left, right, bottom, top)` at the near plane.
    pub extents: [f64; 4],
    /// Near and far distances.
    pub near_far: [f64; 2],
}

impl EyeCamera {
    /// `clip_from_display = P * M^T * T(-pe)`.
    pub fn clip_from_display(&self) -> DMat4 {
        self.clip_from_view * self.view_from_display
    }

    /// Projects a display-frame point to normalised device coordinates (x right, y up,
    /// both in [-1, 1] on the screen). `None` when the point is at or behind the eye.
    pub fn project(&self, p_in_display: DVec3) -> Option<DVec2> {
        let c = self.clip_from_display() * DVec4::from((p_in_display, 1.0));
        (c.w > 0.0).then(|| DVec2::new(c.x / c.w, c.y / c.w))
    }

    /// Depth in [0, 1] of a display-frame point (0 at the near plane, 1 at far).
    pub fn depth(&self, p_in_display: DVec3) -> Option<f64> {
        let c = self.clip_from_display() * DVec4::from((p_in_display, 1.0));
        (c.w > 0.0).then(|| c.z / c.w)
    }
}

/// An off-axis perspective frustum (right-handed, looking down -Z, depth [0, 1]).
///
/// Maps the view-space point `(x, y, z)` with `z = -near` to depth 0 and `z = -far` to
/// depth 1, and the near-plane rectangle `[l, r] x [b, t]` to NDC `[-1, 1]^2`.
pub fn frustum_rh_zo(l: f64, r: f64, b: f64, t: f64, near: f64, far: f64) -> DMat4 {
    let (w, h) = (r - l, t - b);
    DMat4::from_cols(
        DVec4::new(2.0 * near / w, 0.0, 0.0, 0.0),
        DVec4::new(0.0, 2.0 * near / h, 0.0, 0.0),
        DVec4::new((r + l) / w, (t + b) / h, far / (near - far), -1.0),
        DVec4::new(0.0, 0.0, near * far / (near - far), 0.0),
    )
}

/// Kooima's generalized perspective projection ("Generalized Perspective Projection",
/// 2008): the camera for an eye at `pe` looking through `screen`.
///
/// With `vr, vu, vn` the screen basis, `va = pa - pe`, `vb = pb - pe`, `vc = pc - pe`
/// and `d = -va·vn` the eye-to-plane distance, the near-plane extents are
/// `l = (vr·va) n/d`, `r = (vr·vb) n/d`, `b = (vu·va) n/d`, `t = (vu·vc) n/d`; the
/// result is `P(l, r, b, t, n, f) * M^T * T(-pe)` where `M = [vr vu vn]`.
///
/// Fails when the eye is not finite, is within 1 mm of the screen plane or behind it,
/// or when `0 < near < far` does not hold.
pub fn kooima(screen: &Screen, pe: DVec3, near: f64, far: f64) -> VrResult<EyeCamera> {
    if !pe.is_finite() {
        return Err(VrError::Projection(ProjectionError::EyeNotFinite));
    }
    if !(near > 0.0 && far > near && far.is_finite()) {
        return Err(VrError::Projection(ProjectionError::ClipPlanes {
            near,
            far,
        }));
    }
    let (vr, vu, vn) = screen.basis();
    let va = screen.lower_left - pe;
    let vb = screen.lower_right - pe;
    let vc = screen.upper_left - pe;
    let d = -va.dot(vn);
    if d < MIN_EYE_DISTANCE {
        return Err(VrError::Projection(ProjectionError::EyeTooClose {
            distance_m: d,
            min_m: MIN_EYE_DISTANCE,
        }));
    }
    let s = near / d;
    let (l, r, b, t) = (
        vr.dot(va) * s,
        vr.dot(vb) * s,
        vu.dot(va) * s,
        vu.dot(vc) * s,
    );
    let clip_from_view = frustum_rh_zo(l, r, b, t, near, far);
    let m_t = DMat4::from_cols(
        DVec4::new(vr.x, vu.x, vn.x, 0.0),
        DVec4::new(vr.y, vu.y, vn.y, 0.0),
        DVec4::new(vr.z, vu.z, vn.z, 0.0),
        DVec4::W,
    );
    let view_from_display = m_t * DMat4::from_translation(-pe);
    Ok(EyeCamera {
        eye: pe,
        clip_from_view,
        view_from_display,
        extents: [l, r, b, t],
        near_far: [near, far],
    })
}

/// Which eye.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Eye {
    /// The left eye.
    Left,
    /// The right eye.
    Right,
}

/// Stereo parameters: interpupillary distance and clip planes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StereoRig {
    /// Interpupillary distance (metres). Default 0.064.
    pub ipd: f64,
    /// Near clip distance (metres).
    pub near: f64,
    /// Far clip distance (metres).
    pub far: f64,
}

impl Default for StereoRig {
    fn default() -> Self {
        Self {
            ipd: 0.064,
            near: 0.05,
            far: 100.0,
        }
    }
}

impl StereoRig {
    /// The two eye positions: the head position -/+ IPD/2 along the head's right axis.
    pub fn eye_positions(&self, head: &HeadPose) -> (DVec3, DVec3) {
        let q = if head.orientation.is_finite() && head.orientation.length_squared() > 0.0 {
            head.orientation.normalize()
        } else {
            DQuat::IDENTITY
        };
        let half = q * DVec3::X * (0.5 * self.ipd);
        (head.position - half, head.position + half)
    }

    /// Both eyes' cameras for one screen.
    pub fn eye_cameras(
        &self,
        screen: &Screen,
        head: &HeadPose,
    ) -> VrResult<(EyeCamera, EyeCamera)> {
        let (l, r) = self.eye_positions(head);
        Ok((
            kooima(screen, l, self.near, self.far)?,
            kooima(screen, r, self.near, self.far)?,
        ))
    }

    /// One eye's camera.
    pub fn eye_camera(&self, screen: &Screen, head: &HeadPose, eye: Eye) -> VrResult<EyeCamera> {
        let (l, r) = self.eye_positions(head);
        let pe = match eye {
            Eye::Left => l,
            Eye::Right => r,
        };
        kooima(screen, pe, self.near, self.far)
    }
}

/// The head position used when no head tracker is configured: centred on the screen,
/// `distance` metres in front of it, looking at it.
pub fn fixed_head(screen: &Screen, distance: f64) -> HeadPose {
    let (vr, vu, vn) = screen.basis();
    let orientation = DQuat::from_mat3(&glam::DMat3::from_cols(vr, vu, vn));
    HeadPose {
        position: screen.center() + vn * distance,
        orientation,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::assert_near;
    use sculpt_core::tolerance::EXACT_EPS;

    fn wall() -> Screen {
        // 2 m x 1.5 m, lower-left at (-1, 0, 0), normal +Z.
        Screen::new(
            DVec3::new(-1.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(-1.0, 1.5, 0.0),
        )
        .unwrap()
    }

    #[test]
    fn centred_eye_gives_hand_computed_extents() {
        // Eye 2 m in front of the wall, level with its bottom edge and centred
        // horizontally: l = -1 * n / 2, r = 1 * n / 2, b = 0, t = 1.5 * n / 2.
        let cam = kooima(&wall(), DVec3::new(0.0, 0.0, 2.0), 0.5, 10.0).unwrap();
        assert_near!(
            cam.extents.to_vec(),
            vec![-0.25, 0.25, 0.0, 0.375],
            EXACT_EPS
        );
        // Screen corners land on the NDC corners.
        let ll = cam.project(DVec3::new(-1.0, 0.0, 0.0)).unwrap();
        let ur = cam.project(DVec3::new(1.0, 1.5, 0.0)).unwrap();
        assert_near!(ll.to_array(), [-1.0, -1.0], EXACT_EPS);
        assert_near!(ur.to_array(), [1.0, 1.0], EXACT_EPS);
        // Depth range [0, 1].
        assert_near!(
            cam.depth(DVec3::new(0.0, 0.0, 1.5)).unwrap(),
            0.0,
            EXACT_EPS
        );
        assert_near!(
            cam.depth(DVec3::new(0.0, 0.0, -8.0)).unwrap(),
            1.0,
            EXACT_EPS
        );
    }

    #[test]
    fn off_axis_eye_matches_hand_computed_frustum() {
        // Eye at (0.5, 1.0, 1.0): l = (-1 - 0.5) n/1, r = (1 - 0.5) n, b = -1 n, t = 0.5 n.
        let cam = kooima(&wall(), DVec3::new(0.5, 1.0, 1.0), 0.1, 10.0).unwrap();
        assert_near!(
            cam.extents.to_vec(),
            vec![-0.15, 0.05, -0.1, 0.05],
            EXACT_EPS
        );
        let expected = frustum_rh_zo(-0.15, 0.05, -0.1, 0.05, 0.1, 10.0)
            * DMat4::from_translation(DVec3::new(-0.5, -1.0, -1.0));
        assert_near!(
            cam.clip_from_display().to_cols_array().to_vec(),
            expected.to_cols_array().to_vec(),
            EXACT_EPS
        );
    }

    #[test]
    fn rotated_screen_uses_its_own_basis() {
        // A side wall in the plane x = -1 facing +X: lower-left at z = 1, lower-right at z = -1.
        let side = Screen::new(
            DVec3::new(-1.0, 0.0, 1.0),
            DVec3::new(-1.0, 0.0, -1.0),
            DVec3::new(-1.0, 2.0, 1.0),
        )
        .unwrap();
        let (_, _, vn) = side.basis();
        assert_near!(vn.to_array(), [1.0, 0.0, 0.0], EXACT_EPS);
        let cam = kooima(&side, DVec3::new(0.0, 1.0, 0.0), 0.5, 10.0).unwrap();
        // d = 1, so l = -1 * 0.5, r = 0.5, b = -0.5, t = 0.5.
        assert_near!(cam.extents.to_vec(), vec![-0.5, 0.5, -0.5, 0.5], EXACT_EPS);
        let c = cam.project(DVec3::new(-1.0, 1.0, 0.0)).unwrap();
        assert_near!(c.to_array(), [0.0, 0.0], EXACT_EPS);
    }

    #[test]
    fn stereo_parallax_matches_similar_triangles() {
        // Head 2 m in front of the screen, IPD 64 mm. A point D metres behind the screen
        // shows uncrossed parallax ipd * D / (2 + D) on the screen; in front, crossed.
        let rig = StereoRig::default();
        let screen = wall();
        let head = HeadPose {
            position: DVec3::new(0.0, 0.75, 2.0),
            orientation: DQuat::IDENTITY,
        };
        let (l, r) = rig.eye_cameras(&screen, &head).unwrap();
        for depth_behind in [0.0, 0.5, 1.0, -0.5] {
            let p = DVec3::new(0.2, 0.9, -depth_behind);
            let (pl, pr) = (l.project(p).unwrap(), r.project(p).unwrap());
            let parallax_m = (pr.x - pl.x) * 0.5 * screen.width();
            let expected = rig.ipd * depth_behind / (2.0 + depth_behind);
            assert_near!(parallax_m, expected, EXACT_EPS, "depth {depth_behind}");
            assert_near!(pl.y, pr.y, EXACT_EPS, "no vertical parallax");
        }
    }

    #[test]
    fn eyes_follow_head_rotation() {
        let rig = StereoRig::default();
        let head = HeadPose {
            position: DVec3::new(0.0, 1.0, 2.0),
            orientation: DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2),
        };
        let (l, r) = rig.eye_positions(&head);
        // Turned 90 degrees left: the right axis now points along -Z.
        assert_near!(l.to_array(), [0.0, 1.0, 2.032], EXACT_EPS);
        assert_near!(r.to_array(), [0.0, 1.0, 1.968], EXACT_EPS);
        // A NaN orientation falls back to identity rather than producing NaN eyes.
        let bad = HeadPose {
            orientation: DQuat::from_xyzw(f64::NAN, 0.0, 0.0, 1.0),
            ..head
        };
        let (l, _) = rig.eye_positions(&bad);
        assert!(l.is_finite());
    }

    #[test]
    fn bad_screens_and_eyes_are_rejected() {
        assert!(matches!(
            Screen::new(DVec3::ZERO, DVec3::ZERO, DVec3::Y),
            Err(VrError::Screen(ScreenError::EdgeTooShort))
        ));
        assert!(matches!(
            Screen::new(DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0)),
            Err(VrError::Screen(ScreenError::NotRectangular))
        ));
        assert!(matches!(
            Screen::new(DVec3::ZERO, DVec3::X * f64::NAN, DVec3::Y),
            Err(VrError::Screen(ScreenError::CornerNotFinite))
        ));
        let s = wall();
        assert!(
            matches!(
                kooima(&s, DVec3::new(0.0, 0.5, -1.0), 0.1, 10.0),
                Err(VrError::Projection(ProjectionError::EyeTooClose { distance_m, .. })) if distance_m < 0.0
            ),
            "behind the screen"
        );
        assert!(
            kooima(&s, DVec3::new(0.0, 0.5, 0.0), 0.1, 10.0).is_err(),
            "in the plane"
        );
        assert!(kooima(&s, DVec3::new(0.0, f64::NAN, 1.0), 0.1, 10.0).is_err());
        assert!(kooima(&s, DVec3::new(0.0, 0.5, 1.0), 1.0, 0.5).is_err());
    }

    #[test]
    fn fixed_head_is_centred_in_front() {
        let s = wall();
        let h = fixed_head(&s, 2.0);
        assert_near!(h.position.to_array(), [0.0, 0.75, 2.0], EXACT_EPS);
        let (l, r) = StereoRig::default().eye_positions(&h);
        assert_near!((r - l).to_array(), [0.064, 0.0, 0.0], EXACT_EPS);
    }
}
