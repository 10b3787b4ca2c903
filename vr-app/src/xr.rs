//! OpenXR, the pure parts: XR view poses and fields of view to the renderer's eye
//! cameras (here), the session lifecycle ([`state`]), the action set, its bindings
//! and controllers as tracker frames ([`actions`]), and the controller as the
//! session's wand, with its pose log ([`wand`]). These are always built and
//! unit-tested; the runtime glue (`xr_runtime`, feature `openxr`) uses them.
//!
//! OpenXR reports each eye as a pose in a reference space (`stage`: +Y up, -Z forward,
//! metres) and four half-angles of an asymmetric frustum. The renderer works in the
//! display frame, related to the stage by a rigid `display_from_stage` transform.
//!
//! ```
//! use glam::{DQuat, DVec3};
//! use vr_app::xr::{XrFov, XrPose, eye_camera};
//! let fov = XrFov { angle_left: -0.8, angle_right: 0.8, angle_up: 0.7, angle_down: -0.7 };
//! let pose = XrPose { position: DVec3::new(0.0, 1.6, 0.0), orientation: DQuat::IDENTITY };
//! let cam = eye_camera(&pose, &fov, &XrPose::IDENTITY, 0.05, 100.0).unwrap();
//! // A point straight ahead of the eye lands in the middle of the image.
//! let ndc = cam.project(DVec3::new(0.0, 1.6, -2.0)).unwrap();
//! assert!(ndc.length() < sculpt_core::tolerance::EXACT_EPS);
//! ```

use glam::{DMat4, DQuat, DVec3};

use crate::error::{VrError, VrResult, XrError};
use crate::projection::{EyeCamera, frustum_rh_zo};
use crate::scene::Views;

pub mod actions;
pub mod depth;
#[cfg(all(test, feature = "openxr"))]
pub mod monado_remote;
pub mod state;
pub mod timing;
pub mod wand;

/// A rigid pose (`space_from_object`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct XrPose {
    /// Position, metres.
    pub position: DVec3,
    /// Orientation.
    pub orientation: DQuat,
}

impl XrPose {
    /// The identity pose.
    pub const IDENTITY: Self = Self {
        position: DVec3::ZERO,
        orientation: DQuat::IDENTITY,
    };

    /// The pose as a matrix.
    pub fn matrix(&self) -> DMat4 {
        DMat4::from_rotation_translation(self.orientation.normalize(), self.position)
    }

    /// `self * other` (apply `other` first).
    pub fn compose(&self, other: &XrPose) -> XrPose {
        let q = self.orientation.normalize();
        XrPose {
            position: self.position + q * other.position,
            orientation: q * other.orientation.normalize(),
        }
    }

    /// Whether the pose is finite with a non-zero quaternion.
    pub fn is_valid(&self) -> bool {
        self.position.is_finite()
            && self.orientation.is_finite()
            && self.orientation.length_squared() > sculpt_core::tolerance::ZERO_QUAT_LEN2
    }
}

/// An OpenXR field of view: signed half-angles in radians (left and down negative).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct XrFov {
    /// Left edge angle (negative to the left).
    pub angle_left: f64,
    /// Right edge angle.
    pub angle_right: f64,
    /// Top edge angle.
    pub angle_up: f64,
    /// Bottom edge angle (negative downwards).
    pub angle_down: f64,
}

/// The projection for an OpenXR field of view, depth range [0, 1]:
/// `frustum(n tan(left), n tan(right), n tan(down), n tan(up), n, f)`.
pub fn projection_from_fov(fov: &XrFov, near: f64, far: f64) -> VrResult<DMat4> {
    let half_pi = std::f64::consts::FRAC_PI_2 - crate::tolerance::POLE_ANGLE_MARGIN;
    let angles = [
        fov.angle_left,
        fov.angle_right,
        fov.angle_up,
        fov.angle_down,
    ];
    if angles.iter().any(|a| !a.is_finite() || a.abs() >= half_pi)
        || fov.angle_right <= fov.angle_left
        || fov.angle_up <= fov.angle_down
    {
        return Err(VrError::Xr(XrError::Fov([
            fov.angle_left,
            fov.angle_right,
            fov.angle_up,
            fov.angle_down,
        ])));
    }
    if !(near > 0.0 && far > near && far.is_finite()) {
        return Err(VrError::Xr(XrError::ClipPlanes));
    }
    Ok(frustum_rh_zo(
        near * fov.angle_left.tan(),
        near * fov.angle_right.tan(),
        near * fov.angle_down.tan(),
        near * fov.angle_up.tan(),
        near,
        far,
    ))
}

/// The renderer's camera for one XR eye: `eye_in_stage` is the view pose OpenXR
/// reports, `display_from_stage` places the stage in the display frame.
pub fn eye_camera(
    eye_in_stage: &XrPose,
    fov: &XrFov,
    display_from_stage: &XrPose,
    near: f64,
    far: f64,
) -> VrResult<EyeCamera> {
    if !eye_in_stage.is_valid() || !display_from_stage.is_valid() {
        return Err(VrError::Xr(XrError::EyePose));
    }
    let eye_in_display = display_from_stage.compose(eye_in_stage);
    let clip_from_view = projection_from_fov(fov, near, far)?;
    let view_from_display = eye_in_display.matrix().inverse();
    Ok(EyeCamera {
        eye: eye_in_display.position,
        clip_from_view,
        view_from_display,
        extents: [
            near * fov.angle_left.tan(),
            near * fov.angle_right.tan(),
            near * fov.angle_down.tan(),
            near * fov.angle_up.tan(),
        ],
        near_far: [near, far],
    })
}

/// The renderer's cameras for the two views `xrLocateViews` reports (left, right:
/// pose in the stage space and field of view): each eye through [`eye_camera`]; the
/// head-centre camera (used only by mono outputs) sits midway between the eyes with
/// the left eye's orientation and the union of both fields of view.
pub fn xr_views(
    views: &[(XrPose, XrFov); 2],
    display_from_stage: &XrPose,
    near: f64,
    far: f64,
) -> VrResult<Views> {
    let [(left_pose, left_fov), (right_pose, right_fov)] = views;
    let left = eye_camera(left_pose, left_fov, display_from_stage, near, far)?;
    let right = eye_camera(right_pose, right_fov, display_from_stage, near, far)?;
    let centre_pose = XrPose {
        position: (left_pose.position + right_pose.position) * 0.5,
        orientation: left_pose.orientation,
    };
    let union = XrFov {
        angle_left: left_fov.angle_left.min(right_fov.angle_left),
        angle_right: left_fov.angle_right.max(right_fov.angle_right),
        angle_up: left_fov.angle_up.max(right_fov.angle_up),
        angle_down: left_fov.angle_down.min(right_fov.angle_down),
    };
    let center = eye_camera(&centre_pose, &union, display_from_stage, near, far)?;
    Ok(Views {
        left,
        right,
        center,
    })
}

/// Vulkan formats (`VkFormat`) the swapchain may use, with their wgpu twins, best
/// first: sRGB formats let the runtime read linear colour without a conversion.
pub const SWAPCHAIN_FORMATS: [(i64, wgpu::TextureFormat); 4] = [
    // VK_FORMAT_R8G8B8A8_SRGB
    (43, wgpu::TextureFormat::Rgba8UnormSrgb),
    // VK_FORMAT_B8G8R8A8_SRGB
    (50, wgpu::TextureFormat::Bgra8UnormSrgb),
    // VK_FORMAT_R8G8B8A8_UNORM
    (37, wgpu::TextureFormat::Rgba8Unorm),
    // VK_FORMAT_B8G8R8A8_UNORM
    (44, wgpu::TextureFormat::Bgra8Unorm),
];

/// The swapchain format to use among those the runtime offers (`VkFormat` values,
/// in the runtime's order of preference): the first of [`SWAPCHAIN_FORMATS`] that is
/// offered.
pub fn swapchain_format(offered: &[i64]) -> Option<(i64, wgpu::TextureFormat)> {
    SWAPCHAIN_FORMATS
        .iter()
        .copied()
        .find(|(vk, _)| offered.contains(vk))
}

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::assert_near;
    use sculpt_core::tolerance::EXACT_EPS;

    #[test]
    fn symmetric_fov_matches_a_hand_computed_frustum() {
        let a = std::f64::consts::FRAC_PI_4;
        let p = projection_from_fov(
            &XrFov {
                angle_left: -a,
                angle_right: a,
                angle_up: a,
                angle_down: -a,
            },
            0.1,
            10.0,
        )
        .unwrap();
        // tan 45 = 1: l = -0.1, r = 0.1, so x scale 2n/(r-l) = 1.
        assert_near!(p.x_axis.x, 1.0, EXACT_EPS);
        assert_near!(p.y_axis.y, 1.0, EXACT_EPS);
        assert_near!(p.z_axis.x, 0.0, EXACT_EPS);
    }

    #[test]
    fn asymmetric_fov_puts_its_edges_on_the_ndc_border() {
        let fov = XrFov {
            angle_left: -0.9,
            angle_right: 0.6,
            angle_up: 0.7,
            angle_down: -0.8,
        };
        let cam = eye_camera(&XrPose::IDENTITY, &fov, &XrPose::IDENTITY, 0.1, 50.0).unwrap();
        // A point at depth 2 along the right edge direction projects to x = +1.
        let p = DVec3::new(2.0 * 0.6f64.tan(), 0.0, -2.0);
        assert_near!(cam.project(p).unwrap().x, 1.0, EXACT_EPS);
        let q = DVec3::new(0.0, -2.0 * 0.8f64.tan(), -2.0);
        assert_near!(cam.project(q).unwrap().y, -1.0, EXACT_EPS);
    }

    #[test]
    fn eye_pose_and_stage_transform_compose() {
        let fov = XrFov {
            angle_left: -0.5,
            angle_right: 0.5,
            angle_up: 0.5,
            angle_down: -0.5,
        };
        // Eye turned 90 degrees left (looking along -X), stage shifted 1 m along +Z.
        let eye = XrPose {
            position: DVec3::new(0.0, 1.6, 0.0),
            orientation: DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2),
        };
        let stage = XrPose {
            position: DVec3::new(0.0, 0.0, 1.0),
            orientation: DQuat::IDENTITY,
        };
        let cam = eye_camera(&eye, &fov, &stage, 0.1, 50.0).unwrap();
        assert_near!(cam.eye.to_array(), [0.0, 1.6, 1.0], EXACT_EPS);
        let ndc = cam.project(DVec3::new(-3.0, 1.6, 1.0)).unwrap();
        assert_near!(ndc.to_array(), [0.0, 0.0], EXACT_EPS);
        assert!(
            cam.project(DVec3::new(3.0, 1.6, 1.0)).is_none(),
            "behind the eye"
        );
    }

    #[test]
    fn bad_fov_and_poses_are_errors() {
        let ok = XrFov {
            angle_left: -0.5,
            angle_right: 0.5,
            angle_up: 0.5,
            angle_down: -0.5,
        };
        let bad = [
            XrFov {
                angle_left: 0.6,
                ..ok
            },
            XrFov {
                angle_up: f64::NAN,
                ..ok
            },
            XrFov {
                angle_right: 1.6,
                ..ok
            },
        ];
        for fov in bad {
            assert!(projection_from_fov(&fov, 0.1, 1.0).is_err(), "{fov:?}");
        }
        assert!(projection_from_fov(&ok, 1.0, 0.1).is_err());
        let nan = XrPose {
            position: DVec3::NAN,
            orientation: DQuat::IDENTITY,
        };
        assert!(eye_camera(&nan, &ok, &XrPose::IDENTITY, 0.1, 1.0).is_err());
    }

    #[test]
    fn two_xr_views_give_eye_cameras_and_a_centre_between_them() {
        let fov = |l: f64, r: f64| XrFov {
            angle_left: l,
            angle_right: r,
            angle_up: 0.7,
            angle_down: -0.8,
        };
        let eye = |x: f64| XrPose {
            position: DVec3::new(x, 1.6, 0.0),
            orientation: DQuat::IDENTITY,
        };
        let stage = XrPose {
            position: DVec3::new(0.0, 0.0, 0.5),
            orientation: DQuat::IDENTITY,
        };
        let views = [(eye(-0.032), fov(-0.9, 0.7)), (eye(0.032), fov(-0.7, 0.9))];
        let v = xr_views(&views, &stage, 0.05, 50.0).unwrap();
        assert_near!(v.left.eye.to_array(), [-0.032, 1.6, 0.5], EXACT_EPS);
        assert_near!(v.right.eye.to_array(), [0.032, 1.6, 0.5], EXACT_EPS);
        assert_near!(v.center.eye.to_array(), [0.0, 1.6, 0.5], EXACT_EPS);
        // Each eye's own frustum edge maps to its NDC border.
        let edge = DVec3::new(-0.032 + 2.0 * 0.7f64.tan(), 1.6, 0.5 - 2.0);
        assert_near!(v.left.project(edge).unwrap().x, 1.0, EXACT_EPS);
        // The centre's frustum is the union: from -0.9 to 0.9.
        let c_edge = DVec3::new(2.0 * 0.9f64.tan(), 1.6, 0.5 - 2.0);
        assert_near!(v.center.project(c_edge).unwrap().x, 1.0, EXACT_EPS);
        // A bad view is an error, not a camera.
        let bad = [(eye(0.0), fov(0.5, 0.4)), views[1]];
        assert!(xr_views(&bad, &stage, 0.05, 50.0).is_err());
    }

    #[test]
    fn swapchain_format_prefers_srgb_among_the_offered() {
        // Offered UNORM first and SRGB later: SRGB wins.
        assert_eq!(
            swapchain_format(&[37, 50, 126]),
            Some((50, wgpu::TextureFormat::Bgra8UnormSrgb))
        );
        assert_eq!(
            swapchain_format(&[44]),
            Some((44, wgpu::TextureFormat::Bgra8Unorm))
        );
        assert_eq!(swapchain_format(&[126, 130]), None, "depth formats only");
    }
}
