//! The built-in demo session (`wandsculpt --demo`): a scripted, deterministic wand
//! performance over the default surface. It carves three wavy grooves, switches to
//! emboss and raises a ridge, undoes and redoes it, loses tracking mid-stroke once,
//! and saves, exercising the whole pipeline with no tracker.

use glam::{DQuat, DVec3};
use sculpt_core::editor;
use sculpt_core::interaction::{Command, WandEvent, WandSample};

use crate::projection::Screen;

/// The wand sample rate of the demo (Hz).
pub const DEMO_RATE: f64 = 60.0;

/// A point on the shared default surface ([`editor::default_surface`]) at
/// normalised `(u, v)` in `[-0.5, 0.5]^2`.
pub fn surface_point(u: f64, v: f64) -> DVec3 {
    let c = editor::DEFAULT_SURFACE_CENTER;
    editor::default_surface_point(c.x + u, c.y + 0.6 * v)
}

struct Script {
    events: Vec<WandEvent>,
    t: f64,
    last: DVec3,
}

impl Script {
    fn sample(&mut self, p: DVec3, buttons: u32) {
        self.events.push(WandEvent::sample(
            self.t,
            WandSample::tracked(p, DQuat::IDENTITY, buttons),
        ));
        self.last = p;
        self.t += 1.0 / DEMO_RATE;
    }

    fn lost(&mut self, buttons: u32) {
        self.events
            .push(WandEvent::sample(self.t, WandSample::lost(buttons)));
        self.t += 1.0 / DEMO_RATE;
    }

    fn command(&mut self, c: Command) {
        self.events.push(WandEvent::command(self.t, c));
        self.t += 0.25;
    }

    /// Moves to `to` over `secs` with `buttons` held (a P operator), then dwells.
    fn move_to(&mut self, to: DVec3, secs: f64, buttons: u32) {
        let from = self.last;
        let n = (secs * DEMO_RATE).ceil().max(1.0) as usize;
        for i in 1..=n {
            let s = i as f64 / n as f64;
            let s = s * s * (3.0 - 2.0 * s);
            self.sample(from.lerp(to, s), buttons);
        }
    }

    /// A stroke along `path` with the action button held.
    fn stroke(&mut self, path: &[DVec3], lose_tracking_at: Option<usize>) {
        self.move_to(path[0], 0.6, 0);
        self.sample(path[0], 1);
        for (i, p) in path.iter().enumerate().skip(1) {
            if lose_tracking_at == Some(i) {
                for _ in 0..6 {
                    self.lost(1);
                }
            }
            self.sample(*p, 1);
        }
        let end = path.last().copied().unwrap_or(self.last);
        self.sample(end, 0);
    }
}

/// The demo's events for a session on `screen` starting from the default document.
pub fn demo_events(screen: &Screen) -> Vec<WandEvent> {
    let (_, _, vn) = screen.basis();
    let surface_center = editor::DEFAULT_SURFACE_CENTER;
    let lift = vn * 0.002;
    let mut s = Script {
        events: Vec::new(),
        t: 0.0,
        last: surface_center + vn * 0.2,
    };
    let start = s.last;
    s.sample(start, 0);
    let groove = |v0: f64, phase: f64| -> Vec<DVec3> {
        (0..=60)
            .map(|i| {
                let u = -0.35 + 0.7 * i as f64 / 60.0;
                let v = v0 + 0.04 * (u * 12.0 + phase).sin();
                surface_point(u, v) + lift
            })
            .collect()
    };
    s.stroke(&groove(0.25, 0.0), None);
    s.stroke(&groove(0.0, 1.0), Some(30));
    s.stroke(&groove(-0.25, 2.0), None);
    s.command(Command::SetMode {
        mode: sculpt_core::interaction::InteractionMode::EMBOSS,
    });
    s.command(Command::SetWidth { width: 0.03 });
    let ridge: Vec<DVec3> = (0..=40)
        .map(|i| surface_point(0.3 - 0.6 * i as f64 / 40.0, -0.4 + 0.8 * i as f64 / 40.0) + lift)
        .collect();
    s.stroke(&ridge, None);
    s.command(Command::Undo);
    s.command(Command::Redo);
    s.move_to(surface_center + vn * 0.25, 0.8, 0);
    s.command(Command::Save);
    s.events
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;
    use crate::session::Session;

    #[test]
    fn demo_carves_embosses_and_saves() {
        let dir = tempfile::tempdir().unwrap();
        let mut cfg = Config::default();
        cfg.files.dir = dir.path().to_path_buf();
        let screen = cfg.screen.screen().unwrap();
        let mut session = Session::open(&cfg).unwrap();
        let events = demo_events(&screen);
        assert!(events.windows(2).all(|w| w[1].t >= w[0].t));
        for e in &events {
            session.handle(e).unwrap();
        }
        assert_eq!(session.doc.strokes().len(), 4);
        assert_eq!(
            session.doc.strokes()[3].input.tool.mode,
            sculpt_core::sculpt::stroke::Mode::Emboss
        );
        assert_eq!(session.rejected, 0, "every demo stroke lies on the surface");
        assert!(dir.path().join(crate::session::DOCUMENT_FILE).exists());
        // 4 strokes + 2 mode/tool commands are not edits; undo, redo and save are.
        assert_eq!(session.operations(), 7);
    }
}
