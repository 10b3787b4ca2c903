//! The emulated wand of desktop mode.
//!
//! The mouse pointer, seen from the (fixed) head, picks a ray. In the stroke modes
//! (carve, emboss) the wand tip follows the surface under the pointer
//! ([`DesktopPointer::aim`]): the ray is cast against the document's targets
//! ([`sculpt_core::sculpt::ray::cast_document`]) and the tip is the first hit, moved
//! along the ray by the hover (towards the eye) or press (into the surface) offset the
//! wheel sets. Off every target the tip lies on the plane through the last surface
//! point hit, parallel to the screen as seen, so a drag that leaves the surface goes on
//! in the air (the stroke keeps what lies on the surface). In sketch mode, and before
//! the pointer has met a surface, the tip is where the ray meets the *wand plane*, a
//! plane parallel to the screen `depth` metres in front of it; there the wheel moves
//! the plane. The left button is the action button.
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
use sculpt_core::sculpt::document::{Document, TargetId, snap_distance};
use sculpt_core::sculpt::ray::{DocumentHit, Ray, cast_document};
use sculpt_core::sculpt::stroke::Tool;

use crate::desktop_view::DesktopView;
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
    /// The tip's offset from the surface under the pointer, along the pointer's ray
    /// (metres, display frame): positive hovers towards the eye, negative presses into
    /// the surface.
    pub offset: f64,
    /// Offset change per scroll line (metres).
    pub offset_step: f64,
    /// Bounds for `offset`.
    pub offset_range: (f64, f64),
}

impl Default for EmulatedWand {
    fn default() -> Self {
        Self {
            depth: -0.1,
            scroll_step: 0.005,
            depth_range: (-0.5, 0.4),
            offset: 0.0,
            offset_step: 0.005,
            offset_range: (-0.05, 0.25),
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

    /// Moves the hover / press offset by `lines` scroll lines (up hovers higher),
    /// within the bounds.
    pub fn scroll_offset(&mut self, lines: f64) {
        if lines.is_finite() {
            self.offset = (self.offset + lines * self.offset_step)
                .clamp(self.offset_range.0, self.offset_range.1);
        }
    }

    /// The pointer's ray in the rig: from `eye` through the point of `screen` under
    /// the pointer at `pixel` in a window of `size` pixels. `None` for a non-finite
    /// pointer or eye, or an eye on the screen.
    pub fn ray(
        &self,
        screen: &Screen,
        eye: DVec3,
        pixel: (f64, f64),
        size: (u32, u32),
    ) -> Option<Ray> {
        let (w, h) = (f64::from(size.0.max(1)), f64::from(size.1.max(1)));
        let (sx, sy) = (pixel.0 / w, 1.0 - pixel.1 / h);
        if !(sx.is_finite() && sy.is_finite()) {
            return None;
        }
        let (vr, vu, _) = screen.basis();
        let on_screen = screen.lower_left + vr * screen.width() * sx + vu * screen.height() * sy;
        Ray::through(eye, on_screen)
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
        let ray = self.ray(screen, eye, pixel, size)?;
        let vn = screen.basis().2;
        let plane_point = screen.lower_left + vn * self.depth;
        plane_hit(&ray, plane_point, vn)
    }
}

/// Where `ray` meets the plane through `point` with unit normal `normal`; `None` when
/// it runs parallel to the plane or the plane is behind it.
pub(crate) fn plane_hit(ray: &Ray, point: DVec3, normal: DVec3) -> Option<DVec3> {
    let denom = ray.dir.dot(normal);
    if denom.abs() < sculpt_core::tolerance::PARALLEL_COS_EPS {
        return None;
    }
    let s = (point - ray.origin).dot(normal) / denom;
    (s > 0.0).then(|| ray.at(s))
}

/// Where the desktop pointer put the wand tip (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Aim {
    /// On a target: the tip is the hit moved `offset` metres along the ray towards
    /// the eye (negative: into the surface).
    Surface {
        /// The wand tip (display frame).
        tip: DVec3,
        /// The first hit of the pointer's ray.
        hit: DocumentHit,
        /// The hover (positive) or press (negative) offset used (metres).
        offset: f64,
    },
    /// Off every target (or sketching): the tip in the air, on the plane through the
    /// last surface point hit or on the wand plane.
    Air {
        /// The wand tip (display frame).
        tip: DVec3,
    },
    /// No tip: the pointer's ray is undefined (the pointer outside any sensible
    /// place, or a plane seen edge on).
    Lost,
}

impl Aim {
    /// The wand tip, if any.
    pub fn tip(&self) -> Option<DVec3> {
        match *self {
            Aim::Surface { tip, .. } | Aim::Air { tip } => Some(tip),
            Aim::Lost => None,
        }
    }

    /// The target under the pointer, if any.
    pub fn target(&self) -> Option<TargetId> {
        match self {
            Aim::Surface { hit, .. } => Some(hit.target),
            _ => None,
        }
    }
}

/// The desktop pointer: the emulated wand and what it last aimed at (see the module
/// docs).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DesktopPointer {
    /// The wand plane and the hover / press offset.
    pub wand: EmulatedWand,
    /// What the last [`DesktopPointer::aim`] gave (`None` before the first).
    pub last: Option<Aim>,
    /// The last surface point hit (display frame): off the surface the tip stays on
    /// the plane through it.
    last_hit: Option<DVec3>,
}

/// The rig and view the pointer is seen through: the configured screen and head
/// (rig frame) and the desktop view that moves them into the display frame.
#[derive(Debug, Clone, Copy)]
pub struct PointerRig<'a> {
    /// The configured screen (rig frame).
    pub screen: &'a Screen,
    /// The eye (rig frame).
    pub eye: DVec3,
    /// The desktop camera, if any (none: the rig is the display frame).
    pub view: Option<&'a DesktopView>,
}

impl PointerRig<'_> {
    fn display_from_rig(&self, p_in_rig: DVec3) -> DVec3 {
        self.view.map_or(p_in_rig, |v| v.display_from_rig(p_in_rig))
    }
}

impl DesktopPointer {
    /// Aims the wand at the pointer `pixel` of a window of `size` pixels: in the
    /// stroke modes (`follow_surface`) at the first target under it, moved by the
    /// offset, else on a plane (see the module docs). Remembers the answer in
    /// [`DesktopPointer::last`].
    pub fn aim(
        &mut self,
        doc: &Document,
        rig: PointerRig<'_>,
        pixel: (f64, f64),
        size: (u32, u32),
        follow_surface: bool,
    ) -> Aim {
        let aim = self.aim_at(doc, rig, pixel, size, follow_surface);
        self.last = Some(aim);
        aim
    }

    /// The pointer's ray in the display frame for the pointer `pixel` of a window of
    /// `size` pixels, and the direction the viewer faces (the screen's normal as seen).
    /// `None` where the ray is undefined.
    pub fn ray(
        &self,
        rig: PointerRig<'_>,
        pixel: (f64, f64),
        size: (u32, u32),
    ) -> Option<(Ray, DVec3)> {
        let ray_in_rig = self.wand.ray(rig.screen, rig.eye, pixel, size)?;
        let ray = Ray::through(
            rig.display_from_rig(ray_in_rig.origin),
            rig.display_from_rig(ray_in_rig.at(1.0)),
        )?;
        let facing = rig.view.map_or(rig.screen.basis().2, |v| {
            v.rotation() * rig.screen.basis().2
        });
        Some((ray, facing))
    }

    fn aim_at(
        &mut self,
        doc: &Document,
        rig: PointerRig<'_>,
        pixel: (f64, f64),
        size: (u32, u32),
        follow_surface: bool,
    ) -> Aim {
        let Some((ray, facing)) = self.ray(rig, pixel, size) else {
            return Aim::Lost;
        };
        if follow_surface {
            if let Some(hit) = cast_document(doc, &ray) {
                self.last_hit = Some(hit.hit.point);
                let offset = self.wand.offset;
                return Aim::Surface {
                    tip: hit.hit.point - ray.dir * offset,
                    hit,
                    offset,
                };
            }
            // The plane through the last hit, facing the viewer.
            if let Some(tip) = self.last_hit.and_then(|p| plane_hit(&ray, p, facing)) {
                return Aim::Air { tip };
            }
        }
        match self.wand.tip(rig.screen, rig.eye, pixel, size) {
            Some(tip) => Aim::Air {
                tip: rig.display_from_rig(tip),
            },
            None => Aim::Lost,
        }
    }

    /// The wheel, `lines` notches: the hover / press offset when the tip follows the
    /// surface, the wand plane when sketching.
    pub fn scroll(&mut self, lines: f64, follow_surface: bool) {
        if follow_surface {
            self.wand.scroll_offset(lines);
        } else {
            self.wand.scroll(lines);
        }
    }

    /// The HUD line for the last aim: on which target and how high above it, or off
    /// the surface; `tool` gives the distance within which a stroke's samples count as
    /// on the surface ([`snap_distance`]). When sketching (not `follow_surface`), the
    /// wand plane's depth. `None` before the first aim.
    pub fn hud_line(&self, doc: &Document, tool: &Tool, follow_surface: bool) -> Option<String> {
        let last = self.last?;
        if !follow_surface {
            return Some(format!(
                "sketching on the wand plane, {:.0} mm {} the screen",
                self.wand.depth.abs() * 1000.0,
                if self.wand.depth < 0.0 {
                    "behind"
                } else {
                    "in front of"
                }
            ));
        }
        Some(match last {
            Aim::Surface { hit, .. } => {
                let offset = self.wand.offset;
                let position = doc
                    .stroke_target_ids()
                    .iter()
                    .position(|&id| id == hit.target)
                    .map_or(0, |p| p + 1);
                let size = doc
                    .target(hit.target)
                    .map(|t| t.surface.size())
                    .or_else(|| {
                        doc.solid(hit.target).map(|s| {
                            let f = s.solid.frame();
                            f.h * s.solid.cells() as f64
                        })
                    });
                let snap = size.map_or(f64::INFINITY, |size| snap_distance(tool, size));
                let mm = offset.abs() * 1000.0;
                let height = if offset > 0.0 {
                    format!("hovering {mm:.0} mm")
                } else if offset < 0.0 {
                    format!("pressing {mm:.0} mm")
                } else {
                    "touching".to_string()
                };
                let warn = if offset > snap {
                    "  too high to carve: wheel down"
                } else {
                    ""
                };
                format!("pointer on target {position}, {height}{warn}")
            }
            Aim::Air { .. } => "pointer off the surface: start a drag on it to carve".into(),
            Aim::Lost => "pointer lost".into(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::assert_near;
    use sculpt_core::tolerance::{EXACT_EPS, RAY_HIT_TOL};

    /// A 0.6 m x 0.34 m screen 1 m up, in the plane z = 0.
    fn screen() -> Screen {
        Screen::new(
            DVec3::new(-0.3, 1.0, 0.0),
            DVec3::new(0.3, 1.0, 0.0),
            DVec3::new(-0.3, 1.34, 0.0),
        )
        .unwrap()
    }

    #[test]
    fn tip_lies_on_the_wand_plane_along_the_eye_ray() {
        let screen = screen();
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

    /// Before the pointer meets a surface, and when sketching, the tip is on the wand
    /// plane; a pointer that is not finite has no tip.
    #[test]
    fn off_every_surface_the_tip_is_on_the_wand_plane() {
        let screen = screen();
        let eye = DVec3::new(0.0, 1.17, 0.6);
        let rig = PointerRig {
            screen: &screen,
            eye,
            view: None,
        };
        // A 20 cm square 0.3 m behind the screen's centre.
        let mut doc = Document::new();
        let square = sculpt_core::nurbs::NurbsSurface::plane(
            DVec3::new(-0.1, 1.07, -0.3),
            DVec3::X * 0.2,
            DVec3::Y * 0.2,
        )
        .unwrap();
        doc.add_target("square", square);
        let mut pointer = DesktopPointer::default();
        // The window's corner looks past the square.
        let corner = (0.0, 0.0);
        let aim = pointer.aim(&doc, rig, corner, (800, 600), true);
        let plane = pointer.wand.tip(&screen, eye, corner, (800, 600)).unwrap();
        assert_eq!(aim, Aim::Air { tip: plane });
        assert_near!(plane.z, -0.1, EXACT_EPS);
        // The centre is on the square, unless sketching.
        let centre = (400.0, 300.0);
        let on = pointer.aim(&doc, rig, centre, (800, 600), true);
        assert_near!(on.tip().unwrap().to_array(), [0.0, 1.17, -0.3], RAY_HIT_TOL);
        assert_eq!(on.target(), Some(doc.targets()[0].id));
        // Off the square now, the tip stays on the plane through the last hit.
        let off = pointer.aim(&doc, rig, corner, (800, 600), true);
        assert_near!(off.tip().unwrap().z, -0.3, RAY_HIT_TOL);
        let sketch = pointer.aim(&doc, rig, centre, (800, 600), false);
        assert_eq!(
            sketch.tip(),
            pointer.wand.tip(&screen, eye, centre, (800, 600))
        );
        assert_eq!(
            pointer.aim(&doc, rig, (f64::NAN, 0.0), (800, 600), true),
            Aim::Lost
        );
        assert_eq!(pointer.last, Some(Aim::Lost));
    }
}
