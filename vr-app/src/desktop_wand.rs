//! The emulated wand of desktop mode: the mouse pointer, seen from the (fixed) head,
//! picks a ray; the wand tip is where that ray meets a plane parallel to the screen,
//! `depth` metres in front of it. The scroll wheel moves the plane; the left button is
//! the action button.
//!
//! ```
//! use glam::DVec3;
//! use vr_app::desktop_wand::EmulatedWand;
//! use vr_app::projection::Screen;
//! let screen = Screen::new(DVec3::new(-0.3, 1.0, 0.0), DVec3::new(0.3, 1.0, 0.0), DVec3::new(-0.3, 1.34, 0.0))?;
//! let eye = DVec3::new(0.0, 1.17, 0.6);
//! let wand = EmulatedWand { depth: 0.0, ..Default::default() };
//! // The window centre on the screen plane is the screen centre.
//! let tip = wand.tip(&screen, eye, (400.0, 300.0), (800, 600)).unwrap();
//! assert!((tip - screen.center()).length() < sculpt_core::tolerance::EXACT_EPS);
//! # Ok::<(), vr_app::VrError>(())
//! ```

use glam::DVec3;

use crate::projection::Screen;

/// Mouse-driven wand state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmulatedWand {
    /// Distance of the wand plane in front of the screen (metres; negative is behind).
    pub depth: f64,
    /// Depth change per scroll line (metres).
    pub scroll_step: f64,
    /// Bounds for `depth`.
    pub depth_range: (f64, f64),
}

impl Default for EmulatedWand {
    fn default() -> Self {
        Self {
            depth: -0.1,
            scroll_step: 0.005,
            depth_range: (-0.5, 0.4),
        }
    }
}

impl EmulatedWand {
    /// Moves the wand plane by `lines` scroll lines, within the bounds.
    pub fn scroll(&mut self, lines: f64) {
        if lines.is_finite() {
            self.depth = (self.depth + lines * self.scroll_step)
                .clamp(self.depth_range.0, self.depth_range.1);
        }
    }

    /// The wand tip for a pointer at `pixel` in a window of `size` pixels that shows
    /// `screen`, seen from `eye`. `None` if the ray is parallel to the plane or the
    /// plane is behind the eye.
    pub fn tip(
        &self,
        screen: &Screen,
        eye: DVec3,
        pixel: (f64, f64),
        size: (u32, u32),
    ) -> Option<DVec3> {
        let (w, h) = (f64::from(size.0.max(1)), f64::from(size.1.max(1)));
        let (sx, sy) = (pixel.0 / w, 1.0 - pixel.1 / h);
        if !(sx.is_finite() && sy.is_finite() && eye.is_finite()) {
            return None;
        }
        let (vr, vu, vn) = screen.basis();
        let on_screen = screen.lower_left + vr * screen.width() * sx + vu * screen.height() * sy;
        let dir = on_screen - eye;
        let plane_point = screen.lower_left + vn * self.depth;
        let denom = dir.dot(vn);
        if denom.abs() < sculpt_core::tolerance::PARALLEL_COS_EPS {
            return None;
        }
        let s = (plane_point - eye).dot(vn) / denom;
        (s > 0.0).then(|| eye + dir * s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::assert_near;
    use sculpt_core::tolerance::EXACT_EPS;

    #[test]
    fn tip_lies_on_the_wand_plane_along_the_eye_ray() {
        let screen = Screen::new(
            DVec3::new(-0.3, 1.0, 0.0),
            DVec3::new(0.3, 1.0, 0.0),
            DVec3::new(-0.3, 1.34, 0.0),
        )
        .unwrap();
        let eye = DVec3::new(0.0, 1.17, 0.6);
        let mut wand = EmulatedWand {
            depth: 0.3,
            ..Default::default()
        };
        // Upper-left pixel corner maps to the screen's upper-left, halfway to the eye.
        let tip = wand.tip(&screen, eye, (0.0, 0.0), (800, 600)).unwrap();
        let expected = eye.lerp(DVec3::new(-0.3, 1.34, 0.0), 0.5);
        assert_near!(tip.to_array(), expected.to_array(), EXACT_EPS);
        wand.scroll(1000.0);
        assert_near!(wand.depth, 0.4, EXACT_EPS);
        wand.scroll(f64::NAN);
        assert_near!(wand.depth, 0.4, EXACT_EPS);
        // A plane behind the eye gives no tip.
        wand.depth_range = (-1.0, 1.0);
        wand.depth = 0.9;
        assert!(wand.tip(&screen, eye, (0.0, 0.0), (800, 600)).is_none());
        assert!(
            wand.tip(&screen, eye, (f64::NAN, 0.0), (800, 600))
                .is_none()
        );
    }
}
