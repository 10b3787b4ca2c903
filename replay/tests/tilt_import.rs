//! The two real Open Brush recordings become pose logs: one press per stroke at the
//! recorded timing, every pose finite and on the default surface.

use std::path::PathBuf;

use replay::import::{DefaultSurface, ImportOptions, wand_track};
use sculpt_core::assert_near;
use sculpt_core::tolerance::POINT_EPS;
use tracking::poselog::PoseLog;

fn tilt(name: &str) -> replay::tilt::Tilt {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/data/openbrush")
        .join(name);
    replay::tilt::read_tilt(&std::fs::read(path).unwrap()).unwrap()
}

#[test]
fn real_recordings_become_pose_logs_with_one_press_per_stroke() {
    for (name, strokes) in [("sketch.tilt", 161), ("untitled_2.tilt", 77)] {
        let t = tilt(name);
        let options = ImportOptions {
            rate_hz: 60.0,
            max_gap_s: 0.3,
            ..ImportOptions::default()
        };
        let track = wand_track(&t.sketch, &options, Some(&DefaultSurface)).unwrap();
        assert_eq!(track.strokes.len() + track.skipped_empty, strokes, "{name}");
        let bytes = track.write_pose_log(Vec::new(), name, &options).unwrap();
        let log = PoseLog::from_bytes(&bytes).unwrap();
        let (frames, bad) = log.frames();
        assert!(bad.is_empty() && log.corrupt.is_empty(), "{name}");
        assert_eq!(frames.len(), track.samples.len());
        let presses = frames
            .windows(2)
            .filter(|w| !w[0].wands[0].button(0) && w[1].wands[0].button(0))
            .count();
        assert_eq!(presses, track.strokes.len(), "{name}");
        for f in &frames {
            let p = f.wands[0].pose.position_mm;
            assert!(
                p.is_finite() && f.wands[0].is_tracked(),
                "{name}: frame {}",
                f.number
            );
        }
        // Every placed point lies on the default surface, within the fit box.
        for s in &track.strokes {
            for p in &s.points_m {
                let on = replay::import::default_surface_point(p.x, p.y);
                assert_near!(p.z, on.z, POINT_EPS);
                assert!(
                    p.x.abs() <= 0.4 + POINT_EPS && (p.y - 1.17).abs() <= 0.225 + POINT_EPS,
                    "{p}"
                );
            }
        }
        // Deterministic: the same input gives the same bytes.
        let again = wand_track(&t.sketch, &options, Some(&DefaultSurface)).unwrap();
        assert_eq!(
            again.write_pose_log(Vec::new(), name, &options).unwrap(),
            bytes
        );
    }
}
