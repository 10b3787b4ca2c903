//! OpenXR, the pure parts: XR view poses and fields of view to the renderer's eye
//! cameras, and controller poses and buttons to wand events. These are always built
//! and unit-tested; the runtime glue (`xr_runtime`, feature `openxr`) uses them.
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
use sculpt_core::interaction::{WandEvent, WandSample};

use crate::error::{VrError, VrResult};
use crate::projection::{EyeCamera, frustum_rh_zo};

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

    fn is_valid(&self) -> bool {
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
    let half_pi = std::f64::consts::FRAC_PI_2 - sculpt_core::tolerance::POLE_ANGLE_MARGIN;
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
        return Err(VrError::Xr(format!("invalid field of view {fov:?}")));
    }
    if !(near > 0.0 && far > near && far.is_finite()) {
        return Err(VrError::Xr("need 0 < near < far".into()));
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
        return Err(VrError::Xr("eye pose is not finite".into()));
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

/// The controller state OpenXR actions give for one hand.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct XrController {
    /// Aim pose in the stage space, if the runtime tracks it.
    pub aim: Option<XrPose>,
    /// Trigger value in [0, 1].
    pub trigger: f64,
    /// Grip (squeeze) value in [0, 1].
    pub squeeze: f64,
    /// Primary face button (A / X).
    pub primary: bool,
    /// Secondary face button (B / Y).
    pub secondary: bool,
    /// Thumbstick click.
    pub thumbstick: bool,
    /// Menu button.
    pub menu: bool,
}

/// Maps controller states to wand events, with hysteresis on the analogue trigger and
/// grip (press above 0.6, release below 0.4) so a trembling finger does not chatter.
///
/// Button bits: 0 trigger (action), 1 grip (mode), 2 thumbstick (profile),
/// 3 secondary (undo), 4 primary (redo), 5 menu (select) — the default
/// [`ButtonMap`](sculpt_core::interaction::ButtonMap).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct XrWandMapper {
    trigger_down: bool,
    squeeze_down: bool,
}

impl XrWandMapper {
    /// The wand event for a controller state at time `t` (seconds).
    pub fn map(&mut self, t: f64, c: &XrController, display_from_stage: &XrPose) -> WandEvent {
        fn hysteresis(down: &mut bool, v: f64) -> bool {
            if v.is_finite() {
                if *down && v < 0.4 {
                    *down = false;
                } else if !*down && v > 0.6 {
                    *down = true;
                }
            }
            *down
        }
        let trigger = hysteresis(&mut self.trigger_down, c.trigger);
        let squeeze = hysteresis(&mut self.squeeze_down, c.squeeze);
        let buttons = u32::from(trigger)
            | u32::from(squeeze) << 1
            | u32::from(c.thumbstick) << 2
            | u32::from(c.secondary) << 3
            | u32::from(c.primary) << 4
            | u32::from(c.menu) << 5;
        let sample = match c.aim.filter(XrPose::is_valid) {
            Some(aim) => {
                let p = display_from_stage.compose(&aim);
                WandSample::tracked(p.position, p.orientation, buttons)
            }
            None => WandSample::lost(buttons),
        };
        WandEvent::sample(t, sample)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::assert_near;
    use sculpt_core::interaction::WandInput;
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
    fn controller_maps_to_wand_with_trigger_hysteresis() {
        let mut m = XrWandMapper::default();
        let mut c = XrController {
            aim: Some(XrPose {
                position: DVec3::new(0.1, 1.2, -0.3),
                orientation: DQuat::IDENTITY,
            }),
            trigger: 0.0,
            squeeze: 0.0,
            primary: false,
            secondary: true,
            thumbstick: false,
            menu: false,
        };
        let stage = XrPose {
            position: DVec3::new(0.0, 0.0, 1.0),
            orientation: DQuat::IDENTITY,
        };
        let buttons = |e: WandEvent| match e.input {
            WandInput::Sample(s) => (s.tracked, s.buttons, s.position),
            WandInput::Command(_) => panic!(),
        };
        let (tracked, b, p) = buttons(m.map(0.0, &c, &stage));
        assert!(tracked);
        assert_eq!(b, 1 << 3);
        assert_near!(p.to_array(), [0.1, 1.2, 0.7], EXACT_EPS);
        for (v, held) in [
            (0.5, false),
            (0.65, true),
            (0.5, true),
            (0.35, false),
            (f64::NAN, false),
        ] {
            c.trigger = v;
            assert_eq!(
                buttons(m.map(0.1, &c, &stage)).1 & 1 == 1,
                held,
                "trigger {v}"
            );
        }
        c.aim = None;
        assert!(!buttons(m.map(0.2, &c, &stage)).0);
    }
}
