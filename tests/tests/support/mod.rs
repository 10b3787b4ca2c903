//! Helpers shared by the end-to-end test binaries that include them (`mod support;`).

use std::path::Path;

use glam::{DQuat, DVec3};
use vr_app::app::AppState;
use vr_app::xr::XrPose;
use vr_app::xr::actions::{PoseSource, ReferenceSpace, display_from_stage};
use vr_app::xr::wand::XrWand;

/// A scripted headset wand writing into `dir`, its stage centred on `app`'s document,
/// and the grip pose (held at `orientation`) that puts the wand at a point of the
/// display frame.
pub fn scripted_headset(
    app: &AppState,
    dir: &Path,
    orientation: DQuat,
) -> (XrWand, impl Fn(DVec3) -> XrPose + use<>) {
    let (lo, hi) = app.document_bounds().unwrap();
    let display_from = display_from_stage(ReferenceSpace::Stage, (lo + hi) * 0.5);
    let wand = XrWand::create(
        dir,
        "scripted",
        &display_from,
        app.config.interaction.buttons,
        PoseSource::Grip,
    )
    .unwrap();
    let grip_at = move |p_in_display: DVec3| XrPose {
        position: display_from.orientation.inverse() * (p_in_display - display_from.position),
        orientation,
    };
    (wand, grip_at)
}
