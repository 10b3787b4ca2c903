//! Controllers as the wand, the pure parts: the OpenXR action set and its suggested
//! bindings (binding paths as data, checked for well-formedness), and the mapping from
//! one controller's state to what a tracked wand produces.
//!
//! A controller sample becomes a [`tracking::Frame`] with one wand (DTrack2 `6df2`
//! numbering: tracker millimetres, `tracker_from_body`, the button mask in the
//! interaction's [`ButtonMap`] bits, the thumbstick as the wand's two analog axes) and
//! the head as body 0. The tracker space is the OpenXR reference space (the stage);
//! [`stage_calibration`] is the calibration that places it in the display frame. So a
//! headset session is recorded in a pose log and runs through the same
//! [`FrameStage`](tracking::stage::FrameStage), interaction, edit loop, journal and
//! operator log as a tracked wand, and `replay` replays it.
//!
//! The thumbstick changes the tool's width (left/right) and depth (up/down) at a rate,
//! through the interaction's [`Command::SetWidth`](sculpt_core::interaction::Command::SetWidth) / [`Command::SetDepth`](sculpt_core::interaction::Command::SetDepth)
//! ([`ThumbstickTool`]).
//!
//! ```
//! use glam::{DQuat, DVec3};
//! use vr_app::xr::XrPose;
//! use vr_app::xr::actions::{ControllerState, WandMapper};
//! let mut mapper = WandMapper::default();
//! let state = ControllerState {
//!     grip: Some(XrPose { position: DVec3::new(0.1, 1.2, -0.3), orientation: DQuat::IDENTITY }),
//!     trigger: 0.9,
//!     ..ControllerState::default()
//! };
//! let frame = mapper.frame(1, 0.5, &state, None);
//! let wand = frame.wand(0).unwrap();
//! assert!(wand.is_tracked() && wand.button(0)); // trigger: the action button
//! ```

use std::collections::BTreeSet;

use glam::{DQuat, DVec3};
use sculpt_core::interaction::ButtonMap;
use tracking::calibration::Calibration;
use tracking::{Body, Frame, Pose, Wand};

use super::XrPose;

/// What an action reads or writes (`XrActionType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ActionKind {
    /// A pose (`XR_ACTION_TYPE_POSE_INPUT`).
    Pose,
    /// A value in [0, 1] (`XR_ACTION_TYPE_FLOAT_INPUT`).
    Float,
    /// A button (`XR_ACTION_TYPE_BOOLEAN_INPUT`).
    Bool,
    /// A 2D axis (`XR_ACTION_TYPE_VECTOR2F_INPUT`).
    Vector2,
    /// Haptic output (`XR_ACTION_TYPE_VIBRATION_OUTPUT`).
    Haptic,
}

/// The wand's actions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum WandAction {
    /// The wand pose (grip).
    GripPose,
    /// The pointing pose (aim).
    AimPose,
    /// Draw: strokes and sketches (the action button).
    Draw,
    /// Cycle the mode.
    Mode,
    /// Toggle the profile.
    Profile,
    /// Undo.
    Undo,
    /// Redo.
    Redo,
    /// Select the next target.
    NextTarget,
    /// Width (x) and depth (y) of the tool.
    Thumbstick,
    /// Lattice mode on and off (issue 35 item 1): in lattice mode the draw action
    /// grabs the cage's control point at the wand tip, with the group within the
    /// grab radius, and the wand drags it.
    Lattice,
    /// Paint mode on and off (issue 35 item 2): in paint mode the draw action sweeps
    /// the brush, depositing colour on the surface under it.
    Paint,
    /// The haptic pulse on stroke applied or rejected.
    Haptic,
}

impl WandAction {
    /// Every action, in the order the action set creates them.
    pub const ALL: [WandAction; 12] = [
        WandAction::GripPose,
        WandAction::AimPose,
        WandAction::Draw,
        WandAction::Mode,
        WandAction::Profile,
        WandAction::Undo,
        WandAction::Redo,
        WandAction::NextTarget,
        WandAction::Thumbstick,
        WandAction::Lattice,
        WandAction::Paint,
        WandAction::Haptic,
    ];

    /// The action's name (lower case, as `xrCreateAction` requires).
    pub fn name(self) -> &'static str {
        match self {
            WandAction::GripPose => "grip_pose",
            WandAction::AimPose => "aim_pose",
            WandAction::Draw => "draw",
            WandAction::Mode => "mode",
            WandAction::Profile => "profile",
            WandAction::Undo => "undo",
            WandAction::Redo => "redo",
            WandAction::NextTarget => "next_target",
            WandAction::Thumbstick => "thumbstick",
            WandAction::Lattice => "lattice",
            WandAction::Paint => "paint",
            WandAction::Haptic => "haptic",
        }
    }

    /// The name shown to the user by the runtime.
    pub fn localized(self) -> &'static str {
        match self {
            WandAction::GripPose => "Wand pose",
            WandAction::AimPose => "Pointing pose",
            WandAction::Draw => "Draw",
            WandAction::Mode => "Mode",
            WandAction::Profile => "Profile",
            WandAction::Undo => "Undo",
            WandAction::Redo => "Redo",
            WandAction::NextTarget => "Next target",
            WandAction::Thumbstick => "Tool width and depth",
            WandAction::Lattice => "Lattice mode",
            WandAction::Paint => "Paint mode",
            WandAction::Haptic => "Stroke feedback",
        }
    }

    /// What the action reads or writes.
    pub fn kind(self) -> ActionKind {
        match self {
            WandAction::GripPose | WandAction::AimPose => ActionKind::Pose,
            WandAction::Draw => ActionKind::Float,
            WandAction::Thumbstick => ActionKind::Vector2,
            WandAction::Haptic => ActionKind::Haptic,
            _ => ActionKind::Bool,
        }
    }
}

/// The action set's name.
pub const ACTION_SET: &str = "wand";
/// The action set's localized name.
pub const ACTION_SET_LOCALIZED: &str = "Wand";

/// Suggested bindings for one interaction profile.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ProfileBindings<'a> {
    /// The profile path.
    pub profile: &'a str,
    /// The input and output components the profile has (OpenXR 1.0, section 6.4,
    /// "Interaction Profile Paths"), per hand.
    pub components: &'a [&'a str],
    /// Action and binding path, in order.
    pub bindings: &'a [(WandAction, &'a str)],
}

/// The right hand holds the wand; the left hand's buttons undo and redo, and (where the
/// controller has spare ones) turn lattice mode (the left thumbstick or squeeze) and
/// paint mode (the left menu button or trigger) on and off.
pub const PROFILES: [ProfileBindings<'static>; 4] = [
    ProfileBindings {
        profile: "/interaction_profiles/khr/simple_controller",
        components: &[
            "input/select/click",
            "input/menu/click",
            "input/grip/pose",
            "input/aim/pose",
            "output/haptic",
        ],
        bindings: &[
            (WandAction::GripPose, "/user/hand/right/input/grip/pose"),
            (WandAction::AimPose, "/user/hand/right/input/aim/pose"),
            (WandAction::Draw, "/user/hand/right/input/select/click"),
            (WandAction::Mode, "/user/hand/right/input/menu/click"),
            (WandAction::Undo, "/user/hand/left/input/select/click"),
            (WandAction::Redo, "/user/hand/left/input/menu/click"),
            (WandAction::Haptic, "/user/hand/right/output/haptic"),
        ],
    },
    ProfileBindings {
        profile: "/interaction_profiles/oculus/touch_controller",
        components: &[
            "input/x/click",
            "input/x/touch",
            "input/y/click",
            "input/y/touch",
            "input/menu/click",
            "input/a/click",
            "input/a/touch",
            "input/b/click",
            "input/b/touch",
            "input/system/click",
            "input/squeeze/value",
            "input/trigger/value",
            "input/trigger/touch",
            "input/thumbstick",
            "input/thumbstick/x",
            "input/thumbstick/y",
            "input/thumbstick/click",
            "input/thumbstick/touch",
            "input/thumbrest/touch",
            "input/grip/pose",
            "input/aim/pose",
            "output/haptic",
        ],
        bindings: &[
            (WandAction::GripPose, "/user/hand/right/input/grip/pose"),
            (WandAction::AimPose, "/user/hand/right/input/aim/pose"),
            (WandAction::Draw, "/user/hand/right/input/trigger/value"),
            (WandAction::Mode, "/user/hand/right/input/a/click"),
            (
                WandAction::Profile,
                "/user/hand/right/input/thumbstick/click",
            ),
            (WandAction::NextTarget, "/user/hand/right/input/b/click"),
            (WandAction::Undo, "/user/hand/left/input/x/click"),
            (WandAction::Redo, "/user/hand/left/input/y/click"),
            (
                WandAction::Lattice,
                "/user/hand/left/input/thumbstick/click",
            ),
            (WandAction::Paint, "/user/hand/left/input/menu/click"),
            (WandAction::Thumbstick, "/user/hand/right/input/thumbstick"),
            (WandAction::Haptic, "/user/hand/right/output/haptic"),
        ],
    },
    ProfileBindings {
        profile: "/interaction_profiles/valve/index_controller",
        components: &[
            "input/system/click",
            "input/system/touch",
            "input/a/click",
            "input/a/touch",
            "input/b/click",
            "input/b/touch",
            "input/squeeze/value",
            "input/squeeze/force",
            "input/trigger/click",
            "input/trigger/value",
            "input/trigger/touch",
            "input/thumbstick",
            "input/thumbstick/x",
            "input/thumbstick/y",
            "input/thumbstick/click",
            "input/thumbstick/touch",
            "input/trackpad",
            "input/trackpad/x",
            "input/trackpad/y",
            "input/trackpad/force",
            "input/trackpad/touch",
            "input/grip/pose",
            "input/aim/pose",
            "output/haptic",
        ],
        bindings: &[
            (WandAction::GripPose, "/user/hand/right/input/grip/pose"),
            (WandAction::AimPose, "/user/hand/right/input/aim/pose"),
            (WandAction::Draw, "/user/hand/right/input/trigger/value"),
            (WandAction::Mode, "/user/hand/right/input/a/click"),
            (
                WandAction::Profile,
                "/user/hand/right/input/thumbstick/click",
            ),
            (WandAction::NextTarget, "/user/hand/right/input/b/click"),
            (WandAction::Undo, "/user/hand/left/input/a/click"),
            (WandAction::Redo, "/user/hand/left/input/b/click"),
            (
                WandAction::Lattice,
                "/user/hand/left/input/thumbstick/click",
            ),
            (WandAction::Paint, "/user/hand/left/input/trigger/click"),
            (WandAction::Thumbstick, "/user/hand/right/input/thumbstick"),
            (WandAction::Haptic, "/user/hand/right/output/haptic"),
        ],
    },
    ProfileBindings {
        profile: "/interaction_profiles/htc/vive_controller",
        components: &[
            "input/system/click",
            "input/squeeze/click",
            "input/menu/click",
            "input/trigger/click",
            "input/trigger/value",
            "input/trackpad",
            "input/trackpad/x",
            "input/trackpad/y",
            "input/trackpad/click",
            "input/trackpad/touch",
            "input/grip/pose",
            "input/aim/pose",
            "output/haptic",
        ],
        bindings: &[
            (WandAction::GripPose, "/user/hand/right/input/grip/pose"),
            (WandAction::AimPose, "/user/hand/right/input/aim/pose"),
            (WandAction::Draw, "/user/hand/right/input/trigger/value"),
            (WandAction::Mode, "/user/hand/right/input/menu/click"),
            (WandAction::Profile, "/user/hand/right/input/trackpad/click"),
            (
                WandAction::NextTarget,
                "/user/hand/right/input/squeeze/click",
            ),
            (WandAction::Undo, "/user/hand/left/input/menu/click"),
            (WandAction::Redo, "/user/hand/left/input/trackpad/click"),
            (WandAction::Lattice, "/user/hand/left/input/squeeze/click"),
            (WandAction::Paint, "/user/hand/left/input/trigger/click"),
            (WandAction::Thumbstick, "/user/hand/right/input/trackpad"),
            (WandAction::Haptic, "/user/hand/right/output/haptic"),
        ],
    },
];

/// Why a binding is not well formed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BindingError {
    /// The path is not `/user/hand/{left,right}/<component>`.
    #[error("{path}: not /user/hand/left|right/input|output/...")]
    Shape {
        /// The binding path.
        path: String,
    },
    /// The profile has no such component.
    #[error("{profile} has no component {component}")]
    Component {
        /// The profile.
        profile: String,
        /// The component.
        component: String,
    },
    /// The component's type does not fit the action's.
    #[error("{path} cannot drive {action} ({kind:?})")]
    Kind {
        /// The binding path.
        path: String,
        /// The action's name.
        action: &'static str,
        /// The action's kind.
        kind: ActionKind,
    },
    /// The same action is bound twice, or two actions to one component.
    #[error("{profile}: {what} bound twice")]
    Duplicate {
        /// The profile.
        profile: String,
        /// The action or path.
        what: String,
    },
}

/// Checks one profile's bindings: every path is `/user/hand/{left,right}/` followed
/// by one of the profile's components, in lower-case path characters; each
/// component's type fits its action (`.../pose` for poses, `.../value` or `.../click`
/// for a float, `.../click` for a button, a bare 2D component for the thumbstick,
/// `output/haptic` for the pulse); no action or path is bound twice.
pub fn check_profile(p: &ProfileBindings<'_>) -> Result<(), BindingError> {
    let mut actions = BTreeSet::new();
    let mut paths = BTreeSet::new();
    for &(action, path) in p.bindings {
        let shape = || BindingError::Shape {
            path: path.to_string(),
        };
        if !path
            .bytes()
            .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b"/_-.".contains(&b))
        {
            return Err(shape());
        }
        let component = path
            .strip_prefix("/user/hand/left/")
            .or_else(|| path.strip_prefix("/user/hand/right/"))
            .ok_or_else(shape)?;
        if !p.components.contains(&component) {
            return Err(BindingError::Component {
                profile: p.profile.to_string(),
                component: component.to_string(),
            });
        }
        let last = component.rsplit('/').next().unwrap_or_default();
        let fits = match action.kind() {
            ActionKind::Pose => last == "pose",
            ActionKind::Float => last == "value" || last == "click",
            ActionKind::Bool => last == "click",
            ActionKind::Vector2 => {
                component.starts_with("input/")
                    && component.matches('/').count() == 1
                    && (last == "thumbstick" || last == "trackpad")
            }
            ActionKind::Haptic => component == "output/haptic",
        };
        if !fits {
            return Err(BindingError::Kind {
                path: path.to_string(),
                action: action.name(),
                kind: action.kind(),
            });
        }
        let dup = |what: String| BindingError::Duplicate {
            profile: p.profile.to_string(),
            what,
        };
        if !actions.insert(action) {
            return Err(dup(action.name().to_string()));
        }
        if !paths.insert(path) {
            return Err(dup(path.to_string()));
        }
    }
    let profile_ok = p
        .profile
        .strip_prefix("/interaction_profiles/")
        .is_some_and(|rest| rest.split('/').count() == 2 && !rest.contains("//"));
    if !profile_ok {
        return Err(BindingError::Shape {
            path: p.profile.to_string(),
        });
    }
    Ok(())
}

/// One controller's state, as the actions report it; poses in the stage space.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ControllerState {
    /// Grip pose, if tracked.
    pub grip: Option<XrPose>,
    /// Aim pose, if tracked.
    pub aim: Option<XrPose>,
    /// Trigger value in [0, 1].
    pub trigger: f64,
    /// Mode button.
    pub mode: bool,
    /// Profile button.
    pub profile: bool,
    /// Undo button.
    pub undo: bool,
    /// Redo button.
    pub redo: bool,
    /// Next-target button.
    pub next_target: bool,
    /// Lattice-mode button ([`WandAction::Lattice`]).
    pub lattice: bool,
    /// Paint-mode button ([`WandAction::Paint`]).
    pub paint: bool,
    /// Thumbstick (or trackpad): x right, y up, each in [-1, 1].
    pub thumbstick: [f64; 2],
}

/// Which pose drives the wand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PoseSource {
    /// The grip pose (the controller held like a wand).
    #[default]
    Grip,
    /// The aim pose (pointing).
    Aim,
}

/// Trigger hysteresis: pressed above this.
pub const TRIGGER_PRESS: f64 = 0.6;
/// Trigger hysteresis: released below this.
pub const TRIGGER_RELEASE: f64 = 0.4;

/// Controller states to tracker frames (see the module docs), with hysteresis on the
/// analogue trigger so a trembling finger does not chatter.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WandMapper {
    /// The interaction's button assignment (bits of the wand's button mask).
    pub buttons: ButtonMap,
    /// Which pose drives the wand.
    pub pose: PoseSource,
    trigger_down: bool,
}

/// Buttons of the wand in the frames the mapper writes: the [`ButtonMap`] bits 0 to 7
/// (a frame's reader drops the bits above its count, so the lattice bit, 6, and the
/// paint bit, 7, need more than the Flystick's six).
const BUTTON_COUNT: u8 = 8;
/// The wand's Flystick id in the frames the mapper writes.
pub const WAND_ID: u32 = 0;
/// The head's body id in the frames the mapper writes.
pub const HEAD_ID: u32 = 0;
/// Millimetres per metre: the frames are in DTrack2's tracker units.
const MM_PER_M: f64 = 1000.0;

impl WandMapper {
    /// A mapper for a button assignment.
    pub fn new(buttons: ButtonMap, pose: PoseSource) -> Self {
        Self {
            buttons,
            pose,
            trigger_down: false,
        }
    }

    /// The button mask for a controller state (the trigger with hysteresis).
    pub fn button_mask(&mut self, c: &ControllerState) -> u64 {
        if c.trigger.is_finite() {
            if self.trigger_down && c.trigger < TRIGGER_RELEASE {
                self.trigger_down = false;
            } else if !self.trigger_down && c.trigger > TRIGGER_PRESS {
                self.trigger_down = true;
            }
        }
        let b = self.buttons;
        [
            (self.trigger_down, b.action),
            (c.mode, b.mode),
            (c.profile, b.profile),
            (c.undo, b.undo),
            (c.redo, b.redo),
            (c.next_target, b.select),
            (c.lattice, b.lattice),
            (c.paint, b.paint),
        ]
        .into_iter()
        .filter(|&(down, bit)| down && bit < 64)
        .fold(0u64, |m, (_, bit)| m | 1u64 << bit)
    }

    /// Frame `number` at time `t_s` (seconds since the session began, sent as the
    /// frame's `ts`): the wand (tracked when its pose is valid, quality −1 otherwise),
    /// and the head as body 0 when `head_in_stage` is given.
    pub fn frame(
        &mut self,
        number: u64,
        t_s: f64,
        c: &ControllerState,
        head_in_stage: Option<&XrPose>,
    ) -> Frame {
        let mut frame = Frame::new(number);
        frame.tracker_time = Some(t_s);
        frame.receive_time = std::time::Duration::from_secs_f64(t_s.max(0.0));
        let pose = match self.pose {
            PoseSource::Grip => c.grip,
            PoseSource::Aim => c.aim,
        }
        .filter(XrPose::is_valid);
        let buttons = self.button_mask(c);
        let axis = |v: f64| {
            if v.is_finite() {
                v.clamp(-1.0, 1.0)
            } else {
                0.0
            }
        };
        let mut wand = Wand {
            id: WAND_ID,
            quality: -1.0,
            pose: Pose::from_position_mm(DVec3::ZERO),
            button_count: BUTTON_COUNT,
            buttons,
            analog: vec![axis(c.thumbstick[0]), axis(c.thumbstick[1])],
        };
        if let Some(p) = pose {
            wand.quality = 1.0;
            wand.pose = tracker_pose(&p);
        }
        frame.wands.push(wand);
        frame.calibrated_wands = Some(1);
        if let Some(h) = head_in_stage.filter(|h| h.is_valid()) {
            frame.bodies.push(Body {
                id: HEAD_ID,
                quality: 1.0,
                pose: tracker_pose(h),
            });
        }
        frame
    }
}

/// A stage pose as a tracker pose (millimetres).
fn tracker_pose(p: &XrPose) -> Pose {
    Pose::from_quat(p.position * MM_PER_M, p.orientation.normalize())
}

/// The calibration that takes the frames [`WandMapper::frame`] writes (stage space,
/// millimetres) into the display frame: `display_from_stage`, no tool tip offset.
pub fn stage_calibration(display_from_stage: &XrPose) -> Calibration {
    let q = display_from_stage.orientation.normalize();
    Calibration {
        scale: 1.0 / MM_PER_M,
        rotation: [q.x, q.y, q.z, q.w],
        translation_m: display_from_stage.position.to_array(),
        ..Calibration::default()
    }
}

/// The OpenXR reference space the session draws in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReferenceSpace {
    /// `STAGE`: origin on the floor at the centre of the play area.
    Stage,
    /// `LOCAL`: origin at the head's starting position.
    Local,
}

/// Eye height assumed on a `STAGE` space (metres above the floor).
pub const STANDING_EYE_HEIGHT_M: f64 = 1.6;
/// Distance from the user to the document's centre (metres).
pub const REACH_M: f64 = 0.45;
/// The document's centre sits this far below the eyes (metres): at chest height.
pub const BELOW_EYES_M: f64 = 0.35;

/// Where the stage lies in the display frame: the document's centre `doc_centre`
/// (display frame) ends up [`REACH_M`] in front of the user (along the stage's −Z)
/// and [`BELOW_EYES_M`] below the eyes, the display frame's +Y up.
pub fn display_from_stage(space: ReferenceSpace, doc_centre: DVec3) -> XrPose {
    let eyes_in_stage = match space {
        ReferenceSpace::Stage => DVec3::new(0.0, STANDING_EYE_HEIGHT_M, 0.0),
        ReferenceSpace::Local => DVec3::ZERO,
    };
    let centre_in_stage = eyes_in_stage + DVec3::new(0.0, -BELOW_EYES_M, -REACH_M);
    XrPose {
        position: doc_centre - centre_in_stage,
        orientation: DQuat::IDENTITY,
    }
}

pub use crate::thumbstick::{ThumbstickDriver, ThumbstickError, ThumbstickTool};

/// The haptic pulse that answers a stroke.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Feedback {
    /// A stroke (or sketch) was applied: one short, firm pulse.
    Applied,
    /// The sculpting layer refused it: a longer, softer buzz.
    Rejected,
}

/// One vibration (`XrHapticVibration`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vibration {
    /// Seconds.
    pub duration_s: f64,
    /// Hertz; 0 lets the runtime choose.
    pub frequency_hz: f64,
    /// In [0, 1].
    pub amplitude: f64,
}

impl Feedback {
    /// The vibration for this feedback.
    pub fn vibration(self) -> Vibration {
        match self {
            Feedback::Applied => Vibration {
                duration_s: 0.03,
                frequency_hz: 0.0,
                amplitude: 0.8,
            },
            Feedback::Rejected => Vibration {
                duration_s: 0.15,
                frequency_hz: 60.0,
                amplitude: 0.4,
            },
        }
    }
}

/// The feedback for one step of the session: `edits` are the edits it applied and
/// `rejected` how many edits the sculpting layer refused in it
/// ([`Session::rejected`](crate::session::Session::rejected) before and after). A
/// refusal wins over an applied stroke; undo, redo, selection and save give none.
pub fn feedback(edits: &[sculpt_core::interaction::Edit], rejected: usize) -> Option<Feedback> {
    use sculpt_core::interaction::Edit;
    if rejected > 0 {
        Some(Feedback::Rejected)
    } else if edits.iter().any(|e| {
        matches!(
            e,
            Edit::Stroke(_) | Edit::Sketch { .. } | Edit::Deform(_) | Edit::Paint(_)
        )
    }) {
        Some(Feedback::Applied)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::assert_near;
    use sculpt_core::interaction::{Command, Interaction, WandEvent, WandInput};
    use sculpt_core::tolerance::EXACT_EPS;
    use tracking::stage::{FrameStage, StageConfig, StageEvent};

    #[test]
    fn every_profile_binding_is_well_formed() {
        for p in &PROFILES {
            check_profile(p).unwrap_or_else(|e| panic!("{e}"));
            // Every profile drives the wand's pose, draws and gives feedback.
            for a in [WandAction::GripPose, WandAction::Draw, WandAction::Haptic] {
                assert!(p.bindings.iter().any(|&(b, _)| b == a), "{}", p.profile);
            }
        }
        let names: BTreeSet<&str> = PROFILES.iter().map(|p| p.profile).collect();
        assert_eq!(names.len(), 4);
        assert!(names.contains("/interaction_profiles/khr/simple_controller"));
        assert!(names.contains("/interaction_profiles/oculus/touch_controller"));
        assert!(names.contains("/interaction_profiles/valve/index_controller"));
        assert!(names.contains("/interaction_profiles/htc/vive_controller"));
        for a in WandAction::ALL {
            assert!(
                a.name()
                    .bytes()
                    .all(|b| b.is_ascii_lowercase() || b == b'_'),
                "{}",
                a.name()
            );
        }
    }

    #[test]
    fn malformed_bindings_are_rejected() {
        let base = PROFILES[1];
        let bad: [(WandAction, &str); 6] = [
            (WandAction::Draw, "/user/hand/middle/input/trigger/value"),
            (WandAction::Draw, "/user/hand/right/input/Trigger/value"),
            (WandAction::Draw, "/user/hand/right/input/trackpad/click"),
            (WandAction::GripPose, "/user/hand/right/input/trigger/value"),
            (
                WandAction::Thumbstick,
                "/user/hand/right/input/thumbstick/x",
            ),
            (WandAction::Haptic, "/user/hand/right/input/a/click"),
        ];
        for b in bad {
            let bindings = [b];
            let p = ProfileBindings {
                bindings: &bindings,
                ..base
            };
            assert!(check_profile(&p).is_err(), "{b:?}");
        }
        let twice = [
            (WandAction::Undo, "/user/hand/left/input/x/click"),
            (WandAction::Redo, "/user/hand/left/input/x/click"),
        ];
        let p = ProfileBindings {
            bindings: &twice,
            ..base
        };
        assert!(matches!(
            check_profile(&p),
            Err(BindingError::Duplicate { .. })
        ));
    }

    fn state_at(p: DVec3) -> ControllerState {
        ControllerState {
            grip: Some(XrPose {
                position: p,
                orientation: DQuat::IDENTITY,
            }),
            ..ControllerState::default()
        }
    }

    #[test]
    fn buttons_follow_the_button_map_with_trigger_hysteresis() {
        let mut m = WandMapper::default();
        let mut c = state_at(DVec3::ZERO);
        let b = ButtonMap::default();
        c.undo = true;
        c.next_target = true;
        assert_eq!(m.button_mask(&c), 1 << b.undo | 1 << b.select);
        c.undo = false;
        c.next_target = false;
        for (v, held) in [
            (0.5, false),
            (0.65, true),
            (0.5, true),
            (0.35, false),
            (f64::NAN, false),
        ] {
            c.trigger = v;
            assert_eq!(m.button_mask(&c) & 1 << b.action != 0, held, "{v}");
        }
        // A remapped button map moves the bits.
        let mut m = WandMapper::new(
            ButtonMap {
                mode: 7,
                ..ButtonMap::default()
            },
            PoseSource::Grip,
        );
        c.mode = true;
        assert_eq!(m.button_mask(&c), 1 << 7);
    }

    /// The lattice and paint buttons reach the interaction's bits through the frame
    /// the pose log stores. Regression: frames said six buttons, and a reader drops the
    /// bits above the count, so bit 6 (lattice) never reached the session; paint (bit
    /// 7) had no headset action at all.
    #[test]
    fn the_lattice_and_paint_buttons_survive_the_frame_encoding() {
        let b = ButtonMap::default();
        let set_lattice: fn(&mut ControllerState) = |c| c.lattice = true;
        let set_paint: fn(&mut ControllerState) = |c| c.paint = true;
        for (action, bit, press) in [
            (WandAction::Lattice, b.lattice, set_lattice),
            (WandAction::Paint, b.paint, set_paint),
        ] {
            let mut m = WandMapper::default();
            let mut c = state_at(DVec3::new(0.0, 1.2, 0.3));
            press(&mut c);
            assert_eq!(m.button_mask(&c), 1 << bit, "{action:?}");
            let frame = m.frame(3, 0.1, &c, None);
            let mut bytes = Vec::new();
            tracking::dtrack::encode_frame(&frame, &mut bytes);
            let read = tracking::dtrack::parse_frame(&bytes).unwrap();
            assert!(read.wand(WAND_ID).unwrap().button(bit), "{action:?}");
            // Bound on every profile with a spare button, as a button.
            for p in &PROFILES[1..] {
                assert!(
                    p.bindings.iter().any(|&(a, _)| a == action),
                    "{action:?} on {}",
                    p.profile
                );
            }
        }
    }

    #[test]
    fn controller_frames_calibrate_to_the_display_frame_through_the_stage() {
        let display_from_stage = XrPose {
            position: DVec3::new(0.0, -0.2, 1.0),
            orientation: DQuat::from_rotation_y(0.3),
        };
        let config = StageConfig {
            wand_id: WAND_ID,
            head_id: Some(HEAD_ID),
            calibration: stage_calibration(&display_from_stage),
            filter: tracking::filter::FilterConfig {
                enabled: false,
                ..Default::default()
            },
            ..StageConfig::default()
        };
        let mut stage = FrameStage::new(config).unwrap();
        let mut m = WandMapper::default();
        let grip = XrPose {
            position: DVec3::new(0.1, 1.2, -0.3),
            orientation: DQuat::from_rotation_x(0.4),
        };
        let head = XrPose {
            position: DVec3::new(0.0, 1.6, 0.0),
            orientation: DQuat::IDENTITY,
        };
        let mut c = state_at(grip.position);
        c.grip = Some(grip);
        c.trigger = 1.0;
        let mut out = Vec::new();
        // The frame survives a DTrack2 round trip (what the pose log stores).
        let frame = m.frame(1, 0.25, &c, Some(&head));
        let mut bytes = Vec::new();
        tracking::dtrack::encode_frame(&frame, &mut bytes);
        let decoded = tracking::dtrack::parse_frame(&bytes).unwrap();
        stage.push(&decoded, &mut out);
        let wand = out.iter().find_map(StageEvent::wand).unwrap();
        assert!(wand.tracked);
        assert_near!(wand.t, 0.25, EXACT_EPS);
        let expected = display_from_stage.compose(&grip);
        assert_near!(
            wand.tip_m.to_array(),
            expected.position.to_array(),
            sculpt_core::tolerance::POINT_EPS
        );
        let ev = wand.wand_event(0);
        let WandInput::Sample(s) = ev.input else {
            panic!("{ev:?}")
        };
        assert_eq!(s.buttons & 1, 1, "trigger is the action button");
        let head_event = out.iter().find_map(|e| match e {
            StageEvent::Head(h) => Some(h),
            StageEvent::Wand(_) => None,
        });
        assert_near!(
            head_event.unwrap().pose.position_m.to_array(),
            display_from_stage.compose(&head).position.to_array(),
            sculpt_core::tolerance::POINT_EPS
        );
        // No pose: an untracked wand that keeps its buttons.
        c.grip = None;
        let lost = m.frame(2, 0.26, &c, None);
        assert!(!lost.wand(WAND_ID).unwrap().is_tracked());
        assert!(lost.wand(WAND_ID).unwrap().button(0));
        // The aim pose drives it when chosen.
        let mut aim = WandMapper::new(ButtonMap::default(), PoseSource::Aim);
        c.aim = Some(grip);
        assert!(
            aim.frame(3, 0.27, &c, None)
                .wand(WAND_ID)
                .unwrap()
                .is_tracked()
        );
    }

    #[test]
    fn thumbstick_steps_width_and_depth_through_the_interaction() {
        let stick = ThumbstickTool::default();
        let mut interaction = Interaction::default();
        let start = interaction.tool().clone();
        let mut pending = [0.0; 2];
        // Inside the dead zone nothing happens.
        let none = stick.commands(0.0, 1.0, [0.1, -0.15], &start, &mut pending);
        assert!(none.is_empty());
        // Full right and up for one second at 90 Hz.
        let dt = 1.0 / 90.0;
        let mut commands = 0;
        for i in 0..90 {
            let tool = interaction.tool().clone();
            for ev in stick.commands(i as f64 * dt, dt, [1.0, 1.0], &tool, &mut pending) {
                commands += 1;
                interaction.handle(&ev, &mut Vec::new()).unwrap();
            }
        }
        let tool = interaction.tool().clone();
        assert_near!(tool.width - start.width, stick.width_rate, stick.step);
        assert_near!(tool.depth - start.depth, stick.depth_rate, stick.step);
        assert!(commands < 90, "stepped, not one per frame: {commands}");
        // Held far left, the width stops at the range's end.
        for i in 0..1000 {
            let tool = interaction.tool().clone();
            for ev in stick.commands(1.0 + i as f64 * dt, dt, [-1.0, 0.0], &tool, &mut pending) {
                interaction.handle(&ev, &mut Vec::new()).unwrap();
            }
        }
        assert_near!(interaction.tool().width, stick.width_range.0, EXACT_EPS);
        // Non-finite axes and times are ignored.
        let tool = interaction.tool().clone();
        assert!(
            stick
                .commands(50.0, f64::NAN, [1.0, 1.0], &tool, &mut pending)
                .is_empty()
        );
        assert!(
            stick
                .commands(50.0, dt, [f64::NAN, f64::INFINITY], &tool, &mut pending)
                .is_empty()
        );
    }

    #[test]
    fn the_thumbstick_driver_reads_its_wand_and_starts_its_clock_on_the_first_frame() {
        let stick = ThumbstickTool::default();
        let mut driver = ThumbstickDriver::new(stick);
        let tool = Interaction::default().tool().clone();
        let frame = |analog: Vec<f64>, id: u32| {
            let mut f = Frame::new(1);
            f.wands.push(Wand {
                id,
                quality: 1.0,
                pose: Pose::from_position_mm(DVec3::ZERO),
                button_count: 6,
                buttons: 0,
                analog,
            });
            f
        };
        // The first frame has no duration: nothing, however far the stick is pushed.
        assert!(
            driver
                .commands(10.0, &frame(vec![1.0, 1.0], WAND_ID), WAND_ID, &tool)
                .is_empty()
        );
        // One second later, full right: the width grows by the rate (in steps).
        let out = driver.commands(11.0, &frame(vec![1.0, 0.0], WAND_ID), WAND_ID, &tool);
        let [ev] = out.as_slice() else {
            panic!("one command: {out:?}")
        };
        let WandInput::Command(Command::SetWidth { width }) = ev.input else {
            panic!("a width command: {ev:?}")
        };
        assert_eq!(ev.t, 11.0);
        assert_near!(width, tool.width + stick.width_rate, stick.step);
        // Another wand's stick, or a wand without axes, changes nothing.
        assert!(
            driver
                .commands(12.0, &frame(vec![1.0, 1.0], WAND_ID + 1), WAND_ID, &tool)
                .is_empty()
        );
        assert!(
            driver
                .commands(13.0, &frame(Vec::new(), WAND_ID), WAND_ID, &tool)
                .is_empty()
        );
    }

    #[test]
    fn thumbstick_settings_that_cannot_work_are_named() {
        let ok = ThumbstickTool::default();
        assert_eq!(ok.validate(), Ok(()));
        let bad = [
            (
                ThumbstickTool {
                    dead_zone: 1.0,
                    ..ok
                },
                "dead_zone",
            ),
            (
                ThumbstickTool {
                    depth_rate: f64::NAN,
                    ..ok
                },
                "depth_rate",
            ),
            (
                ThumbstickTool {
                    width_range: (0.0, 0.1),
                    ..ok
                },
                "width_range",
            ),
            (ThumbstickTool { step: 0.0, ..ok }, "step"),
        ];
        for (stick, name) in bad {
            let e = stick.validate().unwrap_err();
            assert!(e.to_string().contains(name), "{e}");
        }
    }

    #[test]
    fn the_document_centre_lands_within_reach_below_the_eyes() {
        let centre = DVec3::new(0.0, 1.17, 0.0);
        for (space, eyes) in [
            (
                ReferenceSpace::Stage,
                DVec3::new(0.0, STANDING_EYE_HEIGHT_M, 0.0),
            ),
            (ReferenceSpace::Local, DVec3::ZERO),
        ] {
            let d = display_from_stage(space, centre);
            let eyes_in_display = d.compose(&XrPose {
                position: eyes,
                orientation: DQuat::IDENTITY,
            });
            let to_centre = centre - eyes_in_display.position;
            assert_near!(
                to_centre.to_array(),
                [0.0, -BELOW_EYES_M, -REACH_M],
                EXACT_EPS
            );
        }
    }

    #[test]
    fn strokes_and_refusals_give_their_pulses() {
        use sculpt_core::interaction::Edit;
        assert_eq!(feedback(&[], 0), None);
        assert_eq!(feedback(&[Edit::Undo, Edit::Save], 0), None);
        assert_eq!(feedback(&[Edit::Undo], 1), Some(Feedback::Rejected));
        // A real stroke from the interaction.
        let mut edits = sculpt_core::edit_loop::EditLoop::new(
            Interaction::default(),
            sculpt_core::editor::default_document(),
        );
        let mut applied = Vec::new();
        for i in 0..=10 {
            let tip = sculpt_core::editor::default_surface_point(-0.1 + 0.02 * f64::from(i), 1.15);
            let ev = WandEvent::sample(
                0.01 * f64::from(i),
                sculpt_core::interaction::WandSample::tracked(
                    tip,
                    DQuat::IDENTITY,
                    u32::from(i < 10),
                ),
            );
            let step = edits
                .handle(&ev, &mut sculpt_core::edit_loop::NoHooks)
                .unwrap();
            applied.extend(step.edits().map(|(e, _)| e.clone()));
        }
        assert_eq!(applied.len(), 1);
        assert_eq!(feedback(&applied, 0), Some(Feedback::Applied));
        assert_eq!(feedback(&applied, 1), Some(Feedback::Rejected));
        let (a, r) = (
            Feedback::Applied.vibration(),
            Feedback::Rejected.vibration(),
        );
        assert!(a.duration_s < r.duration_s && a.amplitude > r.amplitude);
    }
}
