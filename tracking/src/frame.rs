//! The [`Frame`]: one tracker measurement of every body and wand, in tracker units.
//!
//! Positions are millimetres in the tracker's room frame, rotations are
//! `tracker_from_body` matrices, exactly as DTrack2 sends them. Conversion to metres in
//! the display frame happens at the edge, in [`crate::calibration`].
//!
//! ```
//! use tracking::frame::{Frame, Pose, Wand};
//! use glam::DVec3;
//! let mut frame = Frame::new(7);
//! frame.wands.push(Wand::tracked(0, Pose::from_position_mm(DVec3::new(10.0, 0.0, 0.0))));
//! assert!(frame.wand(0).unwrap().is_tracked());
//! ```

use glam::{DMat3, DQuat, DVec3};
use serde::{Deserialize, Serialize};
use std::time::Duration;

/// Frame counters this far behind the newest are out of order; further means a reset
/// (the rule of the [`stage`](crate::stage) and of the tokio hub).
pub const REORDER_WINDOW: u64 = 1_000;
/// A tracker whose clock (`ts`) went back this far may restart its frame counter (the
/// [`stage`](crate::stage)); the hub, which watches arrival, also lets a source quiet
/// for this long restart it.
pub const COUNTER_RESET_AFTER: Duration = Duration::from_secs(1);

/// A rigid pose in tracker space: position in millimetres, orientation as the
/// `tracker_from_body` rotation matrix.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Body origin in the tracker frame, millimetres.
    pub position_mm: DVec3,
    /// Rotation taking body axes into tracker axes (columns are the body axes).
    pub tracker_from_body: DMat3,
}

impl Default for Pose {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Pose {
    /// The origin with identity rotation.
    pub const IDENTITY: Pose = Pose {
        position_mm: DVec3::ZERO,
        tracker_from_body: DMat3::IDENTITY,
    };
    /// All zeros, as DTrack2 reports an untracked Flystick.
    pub const ZERO: Pose = Pose {
        position_mm: DVec3::ZERO,
        tracker_from_body: DMat3::ZERO,
    };

    /// A pose at `position_mm` with identity rotation.
    pub fn from_position_mm(position_mm: DVec3) -> Self {
        Self {
            position_mm,
            tracker_from_body: DMat3::IDENTITY,
        }
    }

    /// A pose from a position (mm) and a unit quaternion.
    pub fn from_quat(position_mm: DVec3, tracker_from_body: DQuat) -> Self {
        Self {
            position_mm,
            tracker_from_body: DMat3::from_quat(tracker_from_body.normalize()),
        }
    }

    /// The orientation as a unit quaternion, or `None` when the matrix is not close to
    /// a rotation (zeros, NaN, shear). A slightly non-orthonormal matrix (rounding on the
    /// wire) is re-orthonormalised first.
    pub fn orientation(&self) -> Option<DQuat> {
        let m = self.tracker_from_body;
        if !m.is_finite() {
            return None;
        }
        let det = m.determinant();
        if !(0.5..=1.5).contains(&det) {
            return None;
        }
        // Gram-Schmidt on the columns, then the quaternion of the result.
        let x = m.x_axis.normalize_or_zero();
        let y = (m.y_axis - x * x.dot(m.y_axis)).normalize_or_zero();
        if x == DVec3::ZERO || y == DVec3::ZERO {
            return None;
        }
        let z = x.cross(y);
        let q = DQuat::from_mat3(&DMat3::from_cols(x, y, z)).normalize();
        q.is_finite().then_some(q)
    }

    /// True when the position is finite and the rotation is a proper rotation.
    pub fn is_valid(&self) -> bool {
        self.position_mm.is_finite() && self.orientation().is_some()
    }
}

/// Identifies a device across sources: its kind and its tracker id.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum DeviceId {
    /// A standard 6DOF body (`6d`), e.g. the head target on the glasses.
    Body(u32),
    /// A wand with buttons (`6df2` Flystick, or a serial wand).
    Wand(u32),
}

impl std::fmt::Display for DeviceId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DeviceId::Body(id) => write!(f, "body{id}"),
            DeviceId::Wand(id) => write!(f, "wand{id}"),
        }
    }
}

impl std::str::FromStr for DeviceId {
    type Err = crate::TrackingError;
    fn from_str(s: &str) -> crate::Result<Self> {
        let bad = || crate::TrackingError::Config(format!("device id `{s}`: want bodyN or wandN"));
        if let Some(n) = s.strip_prefix("body") {
            n.parse().map(DeviceId::Body).map_err(|_| bad())
        } else if let Some(n) = s.strip_prefix("wand") {
            n.parse().map(DeviceId::Wand).map_err(|_| bad())
        } else {
            Err(bad())
        }
    }
}

/// A standard 6DOF body: present in a frame only while tracked.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Body {
    /// Tracker id (0-based).
    pub id: u32,
    /// Tracking quality in 0..=1 (DTrack2 sends 1.000 for tracked bodies).
    pub quality: f64,
    /// The pose in tracker space.
    pub pose: Pose,
}

/// A wand (Flystick): always reported, with quality −1 while untracked.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Wand {
    /// Tracker id (0-based).
    pub id: u32,
    /// Tracking quality; negative means untracked (the pose must be ignored).
    pub quality: f64,
    /// The pose in tracker space (meaningless while untracked).
    pub pose: Pose,
    /// Number of buttons the wand has (at most [`Wand::MAX_BUTTONS`]).
    pub button_count: u8,
    /// Button states, bit `i` = button `i` (DTrack2 numbering: 0 is the trigger).
    pub buttons: u64,
    /// Analog axes (joystick), each in −1..=1.
    pub analog: Vec<f64>,
}

impl Wand {
    /// Most buttons a wand may report.
    pub const MAX_BUTTONS: u8 = 64;
    /// Most analog axes a wand may report.
    pub const MAX_ANALOG: usize = 16;

    /// A tracked wand with six buttons, none pressed, and two centred joystick axes.
    pub fn tracked(id: u32, pose: Pose) -> Self {
        Self {
            id,
            quality: 1.0,
            pose,
            button_count: 6,
            buttons: 0,
            analog: vec![0.0, 0.0],
        }
    }

    /// True when the pose may be used (quality ≥ 0 and a valid pose).
    pub fn is_tracked(&self) -> bool {
        self.quality >= 0.0 && self.pose.is_valid()
    }

    /// Whether button `i` is down.
    pub fn button(&self, i: u8) -> bool {
        i < 64 && self.buttons & (1u64 << i) != 0
    }
}

/// One tracker measurement.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Frame {
    /// The tracker's frame counter (`fr`).
    pub number: u64,
    /// The tracker's timestamp in seconds (`ts`), when sent.
    pub tracker_time: Option<f64>,
    /// When this frame was received, on the receiving session's monotonic clock
    /// (zero for frames that were only parsed, never received).
    pub receive_time: Duration,
    /// Number of calibrated standard bodies (`6dcal`), when sent.
    pub calibrated_bodies: Option<u32>,
    /// Tracked standard bodies (`6d`).
    pub bodies: Vec<Body>,
    /// Wands (`6df2`), tracked or not.
    pub wands: Vec<Wand>,
    /// Number of calibrated Flysticks declared by `6df2` (its first field).
    pub calibrated_wands: Option<u32>,
}

impl Frame {
    /// An empty frame with counter `number`.
    pub fn new(number: u64) -> Self {
        Self {
            number,
            ..Self::default()
        }
    }

    /// The body with tracker id `id`, if tracked in this frame.
    pub fn body(&self, id: u32) -> Option<&Body> {
        self.bodies.iter().find(|b| b.id == id)
    }

    /// The wand with tracker id `id`, if reported in this frame.
    pub fn wand(&self, id: u32) -> Option<&Wand> {
        self.wands.iter().find(|w| w.id == id)
    }
}
