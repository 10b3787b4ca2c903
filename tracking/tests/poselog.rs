//! Pose logs: byte-exact round trips, truncation, corruption with line numbers, append.

use glam::DVec3;
use proptest::prelude::*;
use std::time::Duration;
use tracking::TrackingError;
use tracking::error::PoseLogHeaderError;
use tracking::poselog::{PoseLog, PoseLogHeader, PoseLogReader, PoseLogWriter, RecordKind};
use tracking::sim::{Script, SimConfig, Simulator};

fn session() -> Vec<u8> {
    let script = Script::new(DVec3::new(0.0, 1.2, 0.3))
        .move_to(DVec3::new(0.1, 1.2, 0.3), 0.2)
        .click(0, 0.05);
    let sim = Simulator::new(&script, SimConfig::default()).unwrap();
    sim.write_pose_log(Vec::new(), &PoseLogHeader::new("test"))
        .unwrap()
}

#[test]
fn records_re_send_byte_for_byte() {
    let raw = [
        b"fr 1\r\n6d 0\r\n\r\n".to_vec(),
        (0..=255u8).collect::<Vec<u8>>(),
        b"\\x41 \\".to_vec(),
    ];
    let mut header = PoseLogHeader::new("unit");
    header.config = serde_json::json!({"rate": 120});
    let mut w = PoseLogWriter::new(Vec::new(), &header).unwrap();
    for (i, r) in raw.iter().enumerate() {
        w.write(
            RecordKind::DTrack,
            Duration::from_nanos(1_000_000_007 * i as u64),
            r,
        )
        .unwrap();
    }
    let bytes = w.into_inner();
    let log = PoseLog::from_bytes(&bytes).unwrap();
    assert_eq!(log.header, header);
    assert!(log.corrupt.is_empty());
    assert_eq!(
        log.records
            .iter()
            .map(|r| r.bytes.clone())
            .collect::<Vec<_>>(),
        raw
    );
    assert_eq!(log.records[2].time, Duration::from_nanos(2_000_000_014));
    assert_eq!(log.records[0].line, 3);
}

#[test]
fn simulated_session_reads_back_with_timing() {
    let bytes = session();
    let log = PoseLog::from_bytes(&bytes).unwrap();
    let (frames, bad) = log.frames();
    assert!(bad.is_empty());
    assert_eq!(frames.len(), 31);
    assert_eq!(frames[12].receive_time, Duration::from_nanos(100_000_000));
    assert!(frames.windows(2).all(|w| w[1].number == w[0].number + 1));
}

#[test]
fn truncated_last_line_is_tolerated() {
    let bytes = session();
    let cut = &bytes[..bytes.len() - 40];
    let log = PoseLog::from_bytes(cut).unwrap();
    assert!(log.truncated_tail);
    assert!(log.corrupt.is_empty());
    assert_eq!(log.records.len(), 30);
}

#[test]
fn corrupt_lines_are_reported_with_line_numbers() {
    let text = String::from_utf8(session()).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    lines[4] = "d 0.0x garbage".into(); // line 5: bad time
    lines[6] = lines[6].replace("6df2", "6df2 x"); // line 7: payload damaged, CRC fails
    lines[8] = "zz 1.000000000 hi".into(); // line 9: unknown kind
    let joined = lines.join("\n") + "\n";
    let log = PoseLog::from_bytes(joined.as_bytes()).unwrap();
    let lines_of = |errs: &[TrackingError]| {
        errs.iter()
            .map(|e| match e {
                TrackingError::PoseLogLine { line, .. } => *line,
                other => panic!("{other}"),
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(lines_of(&log.corrupt), vec![5, 7, 9]);
    let (frames, bad) = log.frames();
    assert!(bad.is_empty());
    assert_eq!(frames.len(), 28);

    // A record whose checksum is right but whose DTrack payload is not.
    let mut w = PoseLogWriter::new(Vec::new(), &PoseLogHeader::new("t")).unwrap();
    w.write(RecordKind::DTrack, Duration::ZERO, b"fr 1\r\n\r\n")
        .unwrap();
    w.write(
        RecordKind::DTrack,
        Duration::ZERO,
        b"fr 2\r\n6d 1 [0 1.0]\r\n",
    )
    .unwrap();
    let log = PoseLog::from_bytes(&w.into_inner()).unwrap();
    let (frames, bad) = log.frames();
    assert_eq!(frames.len(), 1);
    assert_eq!(lines_of(&bad), vec![4]);
}

#[test]
fn bad_headers_are_refused() {
    assert!(matches!(
        PoseLogReader::new(&b"hello\n"[..]),
        Err(TrackingError::PoseLogHeader(PoseLogHeaderError::FirstLine(
            _
        )))
    ));
    assert!(matches!(
        PoseLogReader::new(&b"wandsculpt-poselog 2\nheader {}\n"[..]),
        Err(TrackingError::PoseLogHeader(PoseLogHeaderError::Version {
            found: 2,
            supported: 1
        }))
    ));
    assert!(matches!(
        PoseLogReader::new(&b"wandsculpt-poselog 1\nheader {nope\n"[..]),
        Err(TrackingError::PoseLogHeader(PoseLogHeaderError::Json(_)))
    ));
    assert!(PoseLogReader::new(&b"wandsculpt-poselog 1\nheader {}\n"[..]).is_ok());
}

#[test]
fn append_after_a_crash_keeps_earlier_records() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.wslog");
    let bytes = session();
    std::fs::write(&path, &bytes[..bytes.len() - 10]).unwrap();
    let mut w = PoseLogWriter::append(&path).unwrap();
    w.write(RecordKind::Serial, Duration::from_secs(9), b"$WAND...\r\n")
        .unwrap();
    drop(w);
    let log = PoseLog::read(&path).unwrap();
    assert_eq!(log.records.len(), 31);
    assert_eq!(log.corrupt.len(), 1, "the crashed line is one corrupt line");
    assert_eq!(log.records.last().unwrap().kind, RecordKind::Serial);
}

proptest! {
    #[test]
    fn reader_survives_arbitrary_bytes(data in prop::collection::vec(any::<u8>(), 0..2048)) {
        let mut bytes = b"wandsculpt-poselog 1\nheader {}\n".to_vec();
        bytes.extend_from_slice(&data);
        let log = PoseLog::from_bytes(&bytes).unwrap();
        let _ = log.frames();
        let _ = PoseLog::from_bytes(&data);
    }
}
