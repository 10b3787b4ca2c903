//! The serial wand codec: round trips, resynchronisation, and arbitrary bytes.

use glam::{DQuat, DVec3};
use proptest::prelude::*;
use tracking::Pose;
use tracking::config::TrackingConfig;
use tracking::serial::{SerialDecoder, SerialRecord, encode_serial, parse_serial};
use tracking::tolerance::{WIRE_ANGLE_EPS, WIRE_MM_EPS};

fn arb_record() -> impl Strategy<Value = SerialRecord> {
    (
        any::<u32>(),
        any::<u64>(),
        prop::option::of((
            prop::array::uniform3(-1e4..1e4f64),
            prop::array::uniform4(-1.0..1.0f64),
        )),
    )
        .prop_map(|(seq, buttons, pose)| SerialRecord {
            seq,
            buttons,
            pose: pose.and_then(|(p, q)| {
                let q = DQuat::from_array(q);
                (q.length() > 0.1).then(|| Pose::from_quat(DVec3::from_array(p), q))
            }),
        })
}

proptest! {
    #[test]
    fn records_round_trip_through_noise(recs in prop::collection::vec(arb_record(), 1..6), noise in prop::collection::vec(any::<u8>(), 0..64), split in 1usize..40) {
        let mut bytes = Vec::new();
        for r in &recs {
            // Noise without `$` between records: dropped by resynchronisation.
            bytes.extend(noise.iter().map(|&b| if b == b'$' { b'#' } else { b }));
            bytes.extend_from_slice(b"\r\n");
            encode_serial(r, &mut bytes);
        }
        let mut got = Vec::new();
        let mut d = SerialDecoder::default();
        for c in bytes.chunks(split) {
            d.push(c, &mut |r, _| if let Ok(r) = r { got.push(r) });
        }
        prop_assert_eq!(got.len(), recs.len());
        for (a, b) in got.iter().zip(&recs) {
            prop_assert_eq!(a.seq, b.seq);
            prop_assert_eq!(a.buttons, b.buttons);
            prop_assert_eq!(a.pose.is_some(), b.pose.is_some());
            if let (Some(pa), Some(pb)) = (a.pose, b.pose) {
                prop_assert!(pa.position_mm.distance(pb.position_mm) < WIRE_MM_EPS);
                prop_assert!(pa.orientation().unwrap().angle_between(pb.orientation().unwrap()) < WIRE_ANGLE_EPS);
            }
        }
    }

    #[test]
    fn arbitrary_bytes_never_panic(data in prop::collection::vec(any::<u8>(), 0..2048)) {
        let mut d = SerialDecoder::default();
        let mut lines = 0usize;
        d.push(&data, &mut |_, line| {
            assert!(line.len() <= tracking::serial::MAX_LINE);
            lines += 1;
        });
        let _ = parse_serial(&data);
    }

    #[test]
    fn config_parser_never_panics(text in "[a-z_\\[\\]=\"0-9. \n{},-]{0,200}") {
        let _ = TrackingConfig::from_toml_str(&text);
        let _ = toml::from_str::<tracking::sim::Script>(&text);
    }
}
