//! DTrack2 ASCII codec: golden lines, round trips, stream splitting and garbage.

use glam::{DMat3, DQuat, DVec3};
use proptest::prelude::*;
use sculpt_core::assert_near;
use sculpt_core::tolerance::{EXACT_EPS, TIME_EPS};
use tracking::dtrack::{
    DTrackDecoder, Decoded, DecoderLimits, encode_frame, parse_frame, parse_line,
};
use tracking::tolerance::{DTRACK_ANALOG_EPS, DTRACK_MM_EPS, DTRACK_ROT_EPS, QUAT_GEN_MIN_LEN};
use tracking::{Body, Frame, Pose, Wand};

const GOLDEN: &[u8] = include_bytes!("golden/dtrack_manual.txt");

fn decode_all(decoder: &mut DTrackDecoder, chunks: &[&[u8]]) -> (Vec<Frame>, usize) {
    let mut frames = Vec::new();
    let mut dropped = 0;
    for c in chunks {
        decoder.push(c, &mut |d| match d {
            Decoded::Frame(f, _) => frames.push(f),
            Decoded::Dropped(_) => dropped += 1,
        });
    }
    (frames, dropped)
}

#[test]
fn golden_manual_frame() {
    let f = parse_frame(GOLDEN).unwrap();
    assert_eq!(f.number, 21753);
    assert_near!(f.tracker_time.unwrap(), 39596.024831, TIME_EPS);
    assert_eq!(f.calibrated_bodies, Some(2));
    assert_eq!(f.bodies.len(), 1);
    let b = f.body(0).unwrap();
    assert_near!(b.quality, 1.0, 0.0);
    assert_near!(
        b.pose.position_mm.to_array(),
        [326.848, -187.216, 109.503],
        EXACT_EPS
    );
    // Column-major: b0 b1 b2 is the first column (the body's x axis in tracker axes).
    assert_near!(
        b.pose.tracker_from_body.x_axis.to_array(),
        [-0.940508, 0.339238, -0.019310],
        EXACT_EPS
    );
    assert_near!(
        b.pose.tracker_from_body.z_axis.to_array(),
        [-0.066403, -0.127574, 0.989604],
        EXACT_EPS
    );
    let w = f.wand(0).unwrap();
    assert_eq!(w.button_count, 6);
    assert_eq!(w.buttons, 5);
    assert!(w.button(0) && !w.button(1) && w.button(2));
    assert_near!(w.analog.as_slice(), [0.5, -1.0].as_slice(), 0.0);
    assert_near!(
        w.pose.position_mm.to_array(),
        [333.724, -188.909, 104.992],
        EXACT_EPS
    );
    assert!(w.is_tracked());
    // `3d` and `gl` lines are ignored.
}

#[test]
fn golden_encoding_is_stable() {
    let mut f = Frame::new(3);
    f.tracker_time = Some(12.5);
    f.calibrated_bodies = Some(1);
    f.bodies.push(Body {
        id: 1,
        quality: 1.0,
        pose: Pose::from_position_mm(DVec3::new(1.0, -2.5, 300.0)),
    });
    let mut w = Wand::tracked(0, Pose::ZERO);
    w.quality = -1.0;
    w.buttons = 0b10;
    f.wands.push(w);
    let mut out = Vec::new();
    encode_frame(&f, &mut out);
    let want = "fr 3\r\nts 12.500000\r\n6dcal 1\r\n\
        6d 1 [1 1.000][1.000 -2.500 300.000][1.000000 0.000000 0.000000 0.000000 1.000000 0.000000 0.000000 0.000000 1.000000]\r\n\
        6df2 1 1 [0 -1.000 6 2][0.000 0.000 0.000][0.000000 0.000000 0.000000 0.000000 0.000000 0.000000 0.000000 0.000000 0.000000][2 0.00 0.00]\r\n\r\n";
    assert_eq!(String::from_utf8(out).unwrap(), want);
}

#[test]
fn untracked_flystick_keeps_buttons_but_not_pose() {
    let f =
        parse_frame(b"fr 1\r\n6df2 1 1 [0 -1.000 8 0][0 0 0][0 0 0 0 0 0 0 0 0][129]\r\n").unwrap();
    let w = f.wand(0).unwrap();
    assert!(!w.is_tracked());
    assert!(w.button(0) && w.button(7));
}

#[test]
fn six_number_position_block_and_missing_bodies() {
    let mut f = Frame::default();
    parse_line(b"6d 0", &mut f).unwrap();
    assert!(f.bodies.is_empty());
    parse_line(b"6d 1 [4 1.0][1 2 3 10 20 30][1 0 0 0 1 0 0 0 1]", &mut f).unwrap();
    assert_eq!(f.bodies[0].id, 4);
}

#[test]
fn malformed_lines_are_errors_not_panics() {
    for line in [
        "6d 2 [0 1.0][1 2 3][1 0 0 0 1 0 0 0 1]",
        "6d 1 [0 1.0][1 2][1 0 0 0 1 0 0 0 1]",
        "6d 1 [0 1.0][1 2 3][1 0 0 0 1 0 0 0]",
        "6d 1 [0 1.0][1 2 3][0 0 0 0 0 0 0 0 0]",
        "6d 1 [0 1.0][1 2 NaN][1 0 0 0 1 0 0 0 1]",
        "6df2 1 1 [0 1.0 65 0][1 2 3][1 0 0 0 1 0 0 0 1][]",
        "6df2 1 1 [0 1.0 2 1][1 2 3][1 0 0 0 1 0 0 0 1][1]",
        "fr -3",
        "fr 99999999999999999999999",
        "ts",
        "6d 1 [0 1.0][1 2 3][1 0 0 0 1 0 0 0 1] junk",
    ] {
        let mut f = Frame::default();
        assert!(parse_line(line.as_bytes(), &mut f).is_err(), "{line}");
    }
}

fn rotation(q: [f64; 4]) -> DMat3 {
    let q = DQuat::from_array(q);
    if q.length() < QUAT_GEN_MIN_LEN {
        DMat3::IDENTITY
    } else {
        DMat3::from_quat(q.normalize())
    }
}

fn arb_frame() -> impl Strategy<Value = Frame> {
    let pos = prop::array::uniform3(-5000.0..5000.0f64);
    let quat = prop::array::uniform4(-1.0..1.0f64);
    let body = (0u32..50, pos.clone(), quat.clone()).prop_map(|(id, p, q)| Body {
        id,
        quality: 1.0,
        pose: Pose {
            position_mm: DVec3::from_array(p),
            tracker_from_body: rotation(q),
        },
    });
    let wand = (
        0u32..8,
        any::<bool>(),
        pos,
        quat,
        0u8..=64,
        any::<u64>(),
        prop::collection::vec(-1.0..1.0f64, 0..4),
    )
        .prop_map(|(id, tracked, p, q, nbt, bits, analog)| Wand {
            id,
            quality: if tracked { 0.5 } else { -1.0 },
            pose: if tracked {
                Pose {
                    position_mm: DVec3::from_array(p),
                    tracker_from_body: rotation(q),
                }
            } else {
                Pose::ZERO
            },
            button_count: nbt,
            buttons: if nbt >= 64 {
                bits
            } else {
                bits & ((1u64 << nbt) - 1)
            },
            analog,
        });
    (
        any::<u32>(),
        prop::option::of(0.0..86400.0f64),
        prop::collection::vec(body, 0..4),
        prop::collection::vec(wand, 0..3),
    )
        .prop_map(|(n, ts, bodies, wands)| Frame {
            number: u64::from(n),
            tracker_time: ts,
            bodies,
            wands,
            ..Frame::default()
        })
}

proptest! {
    #[test]
    fn encode_parse_round_trip(frame in arb_frame()) {
        let mut bytes = Vec::new();
        encode_frame(&frame, &mut bytes);
        let back = parse_frame(&bytes).unwrap();
        prop_assert_eq!(back.number, frame.number);
        prop_assert_eq!(back.bodies.len(), frame.bodies.len());
        prop_assert_eq!(back.wands.len(), frame.wands.len());
        for (a, b) in back.bodies.iter().zip(&frame.bodies) {
            assert_near!(a.pose.position_mm.to_array(), b.pose.position_mm.to_array(), DTRACK_MM_EPS);
            assert_near!(a.pose.tracker_from_body.to_cols_array(), b.pose.tracker_from_body.to_cols_array(), DTRACK_ROT_EPS);
        }
        for (a, b) in back.wands.iter().zip(&frame.wands) {
            prop_assert_eq!(a.buttons, b.buttons);
            prop_assert_eq!(a.button_count, b.button_count);
            prop_assert_eq!(a.is_tracked(), b.is_tracked());
            assert_near!(a.analog.as_slice(), b.analog.as_slice(), DTRACK_ANALOG_EPS);
        }
        // Re-encoding the parsed frame gives the same bytes.
        let mut again = Vec::new();
        encode_frame(&back, &mut again);
        prop_assert_eq!(again, bytes);
    }

    #[test]
    fn any_split_decodes_the_same(frames in prop::collection::vec(arb_frame(), 1..5), cuts in prop::collection::vec(any::<prop::sample::Index>(), 0..8)) {
        let mut bytes = Vec::new();
        for f in &frames { encode_frame(f, &mut bytes); }
        let mut at: Vec<usize> = cuts.iter().map(|i| i.index(bytes.len())).collect();
        at.sort_unstable();
        let mut chunks = Vec::new();
        let mut prev = 0;
        for a in at { chunks.push(&bytes[prev..a]); prev = a; }
        chunks.push(&bytes[prev..]);
        let (got, dropped) = decode_all(&mut DTrackDecoder::default(), &chunks);
        prop_assert_eq!(dropped, 0);
        prop_assert_eq!(got.iter().map(|f| f.number).collect::<Vec<_>>(), frames.iter().map(|f| f.number).collect::<Vec<_>>());
    }

    #[test]
    fn arbitrary_bytes_never_panic_and_stay_bounded(data in prop::collection::vec(any::<u8>(), 0..4096), split in 1usize..64) {
        let limits = DecoderLimits { max_line: 256, max_frame: 1024, max_devices: 8 };
        let mut d = DTrackDecoder::new(limits).keep_raw(true);
        for chunk in data.chunks(split) {
            d.push(chunk, &mut |_| {});
            prop_assert!(d.buffered() <= 4 * (limits.max_line + limits.max_frame));
        }
        d.end_datagram(&mut |_| {});
        let _ = parse_frame(&data);
        let mut f = Frame::default();
        let _ = parse_line(&data, &mut f);
    }

    #[test]
    fn arbitrary_lines_of_plausible_tokens_never_panic(tokens in prop::collection::vec(prop::sample::select(vec!["fr", "6d", "6df2", "6dcal", "ts", "[", "]", "0", "1", "-1", "1.5", "64", "1e308", " ", "\r\n", "\n", "nan", "99999999999"]), 0..60)) {
        let text: String = tokens.concat();
        let mut d = DTrackDecoder::default();
        d.push(text.as_bytes(), &mut |_| {});
        d.end_datagram(&mut |_| {});
    }
}

#[test]
fn raw_bytes_are_kept_exactly() {
    let mut bytes = b"garbage before\r\n".to_vec();
    bytes.extend_from_slice(GOLDEN);
    bytes.extend_from_slice(b"fr 2\r\n6d 0\r\n\r\n");
    let mut d = DTrackDecoder::default().keep_raw(true);
    let mut raws = Vec::new();
    d.push(&bytes, &mut |x| {
        if let Decoded::Frame(_, Some(raw)) = x {
            raws.push(raw)
        }
    });
    assert_eq!(
        raws,
        vec![GOLDEN.to_vec(), b"fr 2\r\n6d 0\r\n\r\n".to_vec()]
    );
    assert_eq!(d.stats().orphan_lines, 1);
}

#[test]
fn bad_line_drops_the_whole_frame_and_the_next_one_survives() {
    let text = b"fr 1\r\n6d 1 [0 1.0][1 2][1 0 0 0 1 0 0 0 1]\r\n\r\nfr 2\r\n6d 0\r\n\r\n";
    let (frames, dropped) = decode_all(&mut DTrackDecoder::default(), &[text]);
    assert_eq!(dropped, 1);
    assert_eq!(frames.len(), 1);
    assert_eq!(frames[0].number, 2);
}

#[test]
fn frame_closes_at_next_fr_without_blank_line() {
    let text = b"fr 1\r\n6d 0\r\nfr 2\r\n6d 0\r\n";
    let mut d = DTrackDecoder::default();
    let (frames, _) = decode_all(&mut d, &[text]);
    assert_eq!(frames.len(), 1, "frame 2 is still open");
    assert!(d.reset(), "a disconnect cuts the open frame");
    assert_eq!(d.stats().truncated_frames, 1);
}

#[test]
fn long_lines_are_capped() {
    let limits = DecoderLimits {
        max_line: 64,
        ..DecoderLimits::default()
    };
    let mut d = DTrackDecoder::new(limits);
    let mut text = b"fr 1\r\n6d 0 ".to_vec();
    text.extend(std::iter::repeat_n(b'x', 10_000));
    text.extend_from_slice(b"\r\n\r\nfr 2\r\n\r\n");
    let (frames, dropped) = decode_all(&mut d, &[&text[..100], &text[100..]]);
    assert_eq!((frames.len(), dropped), (1, 1));
    assert_eq!(frames[0].number, 2);
    assert_eq!(d.stats().long_lines, 1);
    assert!(d.buffered() < 1024);
}
