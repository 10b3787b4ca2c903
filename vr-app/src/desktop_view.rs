//! The desktop camera: orbit, pan and zoom of the view in desktop mode, and the start
//! view that frames the whole document.
//!
//! The configured screen, head and emulated wand form a *rig* (the rig frame is the
//! display frame as configured). The view moves the whole rig by a similarity
//! transform, `p_in_display = pivot + scale * R * (p_in_rig - anchor_in_rig)`, where
//! `anchor_in_rig` is the point on the view axis at the wand plane's starting depth
//! and `R` turns by `yaw` about the screen's up axis and then `pitch` about its right
//! axis. Because the wand tip is computed in the rig and mapped through the same
//! transform, the mouse keeps aiming where it points whatever the view; the wand plane
//! stays parallel to the (moved) screen. Orbiting turns about the pivot, panning moves
//! the pivot in the view plane, zooming scales the rig about the pivot (the pivot stays
//! on the wand plane, so the wand keeps reaching the surface there).
//!
//! ```
//! use glam::DVec3;
//! use vr_app::desktop_view::DesktopView;
//! use vr_app::projection::Screen;
//! let screen = Screen::new(DVec3::new(-0.3, 1.0, 0.0), DVec3::new(0.3, 1.0, 0.0), DVec3::new(-0.3, 1.34, 0.0))?;
//! let mut view = DesktopView::new(&screen, DVec3::new(0.0, 1.17, 0.6), -0.1);
//! // A 1 m x 0.6 m sheet: the view backs off until all of it fits.
//! view.frame(DVec3::new(-0.5, 0.87, -0.3), DVec3::new(0.5, 1.47, -0.1));
//! assert!(view.scale > 1.0);
//! # Ok::<(), vr_app::VrError>(())
//! ```

use glam::{DQuat, DVec3};

use sculpt_core::tolerance::POINT_EPS;

use crate::error::VrResult;
use crate::projection::{HeadPose, Screen, StereoRig};

/// Fraction of the window the framed document fills (in its larger direction).
pub const FRAME_FILL: f64 = 0.85;
/// Radians of orbit per pixel dragged.
pub const ORBIT_PER_PIXEL: f64 = 0.008;
/// Zoom factor per wheel line (scale is divided by it when zooming in).
pub const ZOOM_PER_LINE: f64 = 1.15;
/// How far the zoom goes from the framed view, either way (a factor).
pub const ZOOM_RANGE: f64 = 1e3;
/// Largest pitch (radians): the view never turns over the top.
pub const MAX_PITCH: f64 = 1.5;

/// The desktop camera (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DesktopView {
    /// Turn about the screen's up axis (radians).
    pub yaw: f64,
    /// Turn about the screen's right axis (radians, within +-[`MAX_PITCH`]).
    pub pitch: f64,
    /// Display metres per rig metre.
    pub scale: f64,
    /// Where the anchor lies in the display frame.
    pub pivot: DVec3,
    anchor_in_rig: DVec3,
    basis: (DVec3, DVec3, DVec3),
    /// Half the visible width and height at the anchor's depth (rig metres).
    half_extent: (f64, f64),
    home: (f64, f64, f64, DVec3),
}

impl DesktopView {
    /// The identity view for a rig of `screen`, the head at `head_in_rig` and the wand
    /// plane `wand_depth` metres in front of the screen (negative: behind).
    pub fn new(screen: &Screen, head_in_rig: DVec3, wand_depth: f64) -> Self {
        let basis = screen.basis();
        let vn = basis.2;
        let centre = screen.center();
        let anchor_in_rig = centre + vn * wand_depth;
        let head_to_screen = (head_in_rig - centre).dot(vn).abs().max(POINT_EPS);
        let head_to_anchor = (head_in_rig - anchor_in_rig).dot(vn).abs().max(POINT_EPS);
        let grow = head_to_anchor / head_to_screen;
        let half_extent = (0.5 * screen.width() * grow, 0.5 * screen.height() * grow);
        Self {
            yaw: 0.0,
            pitch: 0.0,
            scale: 1.0,
            pivot: anchor_in_rig,
            anchor_in_rig,
            basis,
            half_extent,
            home: (0.0, 0.0, 1.0, anchor_in_rig),
        }
    }

    /// Frames the box `lo`..`hi` (display frame) from the front: the pivot on the
    /// box's front face at its centre (so the wand plane passes through the front of
    /// the document), the scale such that the box fills [`FRAME_FILL`] of the view in
    /// its larger direction. This becomes the view [`Self::reset`] returns to. A box
    /// that is not finite is ignored.
    pub fn frame(&mut self, lo: DVec3, hi: DVec3) {
        if !(lo.is_finite() && hi.is_finite()) {
            return;
        }
        let (vr, vu, vn) = self.basis;
        let half = (hi - lo).abs() * 0.5;
        let along = |axis: DVec3| half.dot(axis.abs());
        let centre = (lo + hi) * 0.5;
        self.yaw = 0.0;
        self.pitch = 0.0;
        self.pivot = centre + vn * along(vn);
        let need = (along(vr) / self.half_extent.0).max(along(vu) / self.half_extent.1);
        self.scale = if need > 0.0 { need / FRAME_FILL } else { 1.0 };
        self.home = (self.yaw, self.pitch, self.scale, self.pivot);
    }

    /// Back to the framed start view.
    pub fn reset(&mut self) {
        (self.yaw, self.pitch, self.scale, self.pivot) = self.home;
    }

    /// The rig's rotation into the display frame.
    pub fn rotation(&self) -> DQuat {
        let (vr, vu, _) = self.basis;
        DQuat::from_axis_angle(vu, self.yaw) * DQuat::from_axis_angle(vr, self.pitch)
    }

    /// A rig point in the display frame.
    pub fn display_from_rig(&self, p_in_rig: DVec3) -> DVec3 {
        self.pivot + self.rotation() * (p_in_rig - self.anchor_in_rig) * self.scale
    }

    /// Turns the view as if the document were dragged by `(dx, dy)` pixels: right
    /// turns its front to the right, down tips its top towards the viewer.
    pub fn orbit(&mut self, dx: f64, dy: f64) {
        if dx.is_finite() && dy.is_finite() {
            self.yaw -= dx * ORBIT_PER_PIXEL;
            self.pitch = (self.pitch - dy * ORBIT_PER_PIXEL).clamp(-MAX_PITCH, MAX_PITCH);
        }
    }

    /// Moves the view so that the document at the pivot's depth follows a drag of
    /// `(dx, dy)` pixels in a window of `size` pixels.
    pub fn pan(&mut self, dx: f64, dy: f64, size: (u32, u32)) {
        if !(dx.is_finite() && dy.is_finite()) {
            return;
        }
        let (w, h) = (f64::from(size.0.max(1)), f64::from(size.1.max(1)));
        let (vr, vu, _) = self.basis;
        let q = self.rotation();
        let right = dx / w * 2.0 * self.half_extent.0;
        let up = dy / h * 2.0 * self.half_extent.1;
        self.pivot += (q * (-vr * right + vu * up)) * self.scale;
    }

    /// Zooms in by `lines` wheel lines (negative zooms out), about the pivot; within
    /// a factor of 1000 of the framed view either way.
    pub fn zoom(&mut self, lines: f64) {
        if lines.is_finite() {
            let home = self.home.2;
            self.scale = (self.scale / ZOOM_PER_LINE.powf(lines))
                .clamp(home / ZOOM_RANGE, home * ZOOM_RANGE);
        }
    }

    /// The screen moved with the view.
    pub fn screen(&self, screen: &Screen) -> VrResult<Screen> {
        Screen::new(
            self.display_from_rig(screen.lower_left),
            self.display_from_rig(screen.lower_right),
            self.display_from_rig(screen.upper_left),
        )
    }

    /// The head moved with the view.
    pub fn head(&self, head: &HeadPose) -> HeadPose {
        HeadPose {
            position: self.display_from_rig(head.position),
            orientation: self.rotation() * head.orientation,
        }
    }

    /// The stereo rig scaled with the view (eye separation and clip planes), so the
    /// picture is the configured one of a scaled world.
    pub fn rig(&self, rig: &StereoRig) -> StereoRig {
        StereoRig {
            ipd: rig.ipd * self.scale,
            near: rig.near * self.scale,
            far: rig.far * self.scale,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::projection::kooima;
    use sculpt_core::assert_near;

    fn screen() -> Screen {
        Screen::new(
            DVec3::new(-0.3, 1.0, 0.0),
            DVec3::new(0.3, 1.0, 0.0),
            DVec3::new(-0.3, 1.34, 0.0),
        )
        .unwrap()
    }

    const HEAD: DVec3 = DVec3::new(0.0, 1.17, 0.6);
    /// Projected coordinates of exact constructions agree to rounding.
    const NDC_EPS: f64 = sculpt_core::tolerance::POINT_EPS;

    fn centre_ndc(view: &DesktopView, p: DVec3) -> glam::DVec2 {
        let s = view.screen(&screen()).unwrap();
        let cam = kooima(&s, view.display_from_rig(HEAD), 0.01, 100.0).unwrap();
        cam.project(p).unwrap()
    }

    #[test]
    fn the_identity_view_is_the_configured_rig() {
        let view = DesktopView::new(&screen(), HEAD, -0.1);
        let p = DVec3::new(0.1, 1.2, -0.3);
        assert_near!(view.display_from_rig(p).to_array(), p.to_array(), POINT_EPS);
        assert_near!(view.anchor_in_rig.z, -0.1, POINT_EPS);
        // 0.7 m from the head the 0.6 m x 0.34 m screen's view is 7/6 as large.
        assert_near!(view.half_extent.0, 0.35, POINT_EPS);
        assert_near!(view.half_extent.1, 0.17 * 7.0 / 6.0, POINT_EPS);
    }

    #[test]
    fn framing_fits_the_whole_box_and_puts_the_pivot_on_its_front() {
        let mut view = DesktopView::new(&screen(), HEAD, -0.1);
        let (lo, hi) = (DVec3::new(-0.5, 0.87, -0.3), DVec3::new(0.5, 1.47, -0.1));
        view.frame(lo, hi);
        assert_near!(view.pivot.to_array(), [0.0, 1.17, -0.1], POINT_EPS);
        // Every corner of the front face projects inside the view, and the widest
        // direction fills FRAME_FILL of it.
        let mut widest: f64 = 0.0;
        for x in [lo.x, hi.x] {
            for y in [lo.y, hi.y] {
                let ndc = centre_ndc(&view, DVec3::new(x, y, hi.z));
                assert!(ndc.x.abs() < 1.0 && ndc.y.abs() < 1.0, "{ndc}");
                widest = widest.max(ndc.x.abs()).max(ndc.y.abs());
            }
        }
        assert_near!(widest, FRAME_FILL, NDC_EPS);
        // The box centre's front point is in the middle of the view.
        assert_near!(
            centre_ndc(&view, view.pivot).to_array(),
            [0.0, 0.0],
            NDC_EPS
        );
        // A non-finite box changes nothing.
        let before = view;
        view.frame(DVec3::NAN, hi);
        assert_eq!(view, before);
    }

    #[test]
    fn orbit_keeps_the_pivot_in_place_and_reset_returns_home() {
        let mut view = DesktopView::new(&screen(), HEAD, -0.1);
        view.frame(DVec3::new(-0.5, 0.87, -0.3), DVec3::new(0.5, 1.47, -0.1));
        let home = view;
        view.orbit(100.0, -40.0);
        assert_near!(
            centre_ndc(&view, view.pivot).to_array(),
            [0.0, 0.0],
            NDC_EPS
        );
        // Dragging right turns the document's front (+z) to the right: a point in
        // front of the pivot moves right on the screen.
        let front = view.pivot + DVec3::Z * 0.1;
        assert!(centre_ndc(&view, front).x > 0.05);
        // The head stays at its distance from the pivot, scaled.
        let d_home = home.display_from_rig(HEAD).distance(home.pivot);
        let d_now = view.display_from_rig(HEAD).distance(view.pivot);
        assert_near!(d_now, d_home, NDC_EPS);
        view.orbit(0.0, 1e6);
        assert_near!(view.pitch, -MAX_PITCH, POINT_EPS);
        view.orbit(f64::NAN, 0.0);
        assert!(view.yaw.is_finite());
        view.reset();
        assert_eq!(view, home);
    }

    #[test]
    fn pan_follows_the_mouse_and_zoom_scales_about_the_pivot() {
        let mut view = DesktopView::new(&screen(), HEAD, -0.1);
        view.frame(DVec3::new(-0.5, 0.87, -0.3), DVec3::new(0.5, 1.47, -0.1));
        let p = view.pivot;
        let before = centre_ndc(&view, p);
        // Dragging a quarter of the window right moves the point a half NDC unit right.
        view.pan(200.0, 0.0, (800, 600));
        let after = centre_ndc(&view, p);
        assert_near!(after.x - before.x, 0.5, NDC_EPS);
        assert_near!(after.y, before.y, NDC_EPS);
        view.pan(0.0, 150.0, (800, 600));
        assert_near!(centre_ndc(&view, p).y - before.y, -0.5, NDC_EPS);
        view.reset();
        // Zooming in makes a sheet-sized offset look larger; the pivot stays put.
        let q = view.pivot + DVec3::X * 0.2;
        let x0 = centre_ndc(&view, q).x;
        view.zoom(2.0);
        assert_near!(
            centre_ndc(&view, view.pivot).to_array(),
            [0.0, 0.0],
            NDC_EPS
        );
        assert_near!(
            centre_ndc(&view, q).x,
            x0 * ZOOM_PER_LINE * ZOOM_PER_LINE,
            NDC_EPS
        );
        view.zoom(1e9);
        assert_near!(view.scale, view.home.2 / ZOOM_RANGE, POINT_EPS);
    }
}
