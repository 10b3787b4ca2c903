//! The serial wand protocol: a pure codec for wands whose buttons (and optionally whole
//! pose) come over a serial line.
//!
//! One record per line, ASCII, CR/LF terminated:
//!
//! ```text
//! $WAND,<seq>,<buttons>[,<x>,<y>,<z>,<qw>,<qx>,<qy>,<qz>]*<crc>\r\n
//! ```
//!
//! * `seq`: decimal sequence number (u32, wraps);
//! * `buttons`: the button mask in hexadecimal (1–16 digits, bit 0 = trigger);
//! * the optional pose: position in millimetres in the tracker frame, then the unit
//!   quaternion `tracker_from_body` as w x y z (decimal numbers);
//! * `crc`: CRC-32/IEEE of every byte after `$` and before `*`, 8 hex digits.
//!
//! The decoder resynchronises after line noise and half lines: it discards bytes until
//! a `$`, restarts at any `$` inside a line, caps lines at [`MAX_LINE`] bytes and drops
//! records whose checksum fails.
//!
//! ```
//! use tracking::serial::{SerialDecoder, SerialRecord, encode_serial};
//! let rec = SerialRecord { seq: 7, buttons: 0b101, pose: None };
//! let mut line = Vec::new();
//! encode_serial(&rec, &mut line);
//! let mut noisy = b"\x00\xffgarbage$WAND,1,".to_vec(); // noise and a half line
//! noisy.extend_from_slice(&line);
//! let mut got = Vec::new();
//! SerialDecoder::default().push(&noisy, &mut |r, _| got.push(r));
//! assert_eq!(got.into_iter().filter_map(Result::ok).collect::<Vec<_>>(), vec![rec]);
//! ```

use crate::error::{Result, SerialLineError, TrackingError};
use crate::frame::{Frame, Pose, Wand};
use glam::{DQuat, DVec3};
use std::io::Write as _;

/// Longest accepted serial line, bytes.
pub const MAX_LINE: usize = 256;

/// One serial wand record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SerialRecord {
    /// Sequence number.
    pub seq: u32,
    /// Button mask, bit `i` = button `i`.
    pub buttons: u64,
    /// The pose, when the wand sends one (mm, tracker frame).
    pub pose: Option<Pose>,
}

impl SerialRecord {
    /// A one-wand frame for the merge layer: tracked with the pose when the record has
    /// one, else untracked (quality −1) so only its buttons count.
    pub fn to_frame(&self, wand_id: u32, button_count: u8) -> Frame {
        let mut f = Frame::new(u64::from(self.seq));
        f.wands.push(Wand {
            id: wand_id,
            quality: if self.pose.is_some() { 1.0 } else { -1.0 },
            pose: self.pose.unwrap_or(Pose::ZERO),
            button_count,
            buttons: self.buttons,
            analog: Vec::new(),
        });
        f
    }
}

/// Appends one record as a line.
pub fn encode_serial(rec: &SerialRecord, out: &mut Vec<u8>) {
    let start = out.len();
    out.push(b'$');
    let _ = write!(out, "WAND,{},{:X}", rec.seq, rec.buttons);
    if let Some(p) = rec.pose {
        let q = p.orientation().unwrap_or(DQuat::IDENTITY);
        let v = p.position_mm;
        let _ = write!(
            out,
            ",{:.3},{:.3},{:.3},{:.6},{:.6},{:.6},{:.6}",
            v.x, v.y, v.z, q.w, q.x, q.y, q.z
        );
    }
    let crc = crc32fast::hash(&out[start + 1..]);
    let _ = write!(out, "*{crc:08X}\r\n");
}

/// Parses one line (from `$` up to, not including, CR/LF).
pub fn parse_serial(line: &[u8]) -> Result<SerialRecord> {
    let bad = TrackingError::SerialLine;
    let body = line
        .strip_prefix(b"$")
        .ok_or(bad(SerialLineError::NoDollar))?;
    let star = memchr::memrchr(b'*', body).ok_or(bad(SerialLineError::NoChecksum))?;
    let (payload, crc) = (&body[..star], &body[star + 1..]);
    let crc = std::str::from_utf8(crc)
        .ok()
        .filter(|c| c.len() == 8)
        .and_then(|c| u32::from_str_radix(c, 16).ok())
        .ok_or(bad(SerialLineError::ChecksumFormat))?;
    let actual = crc32fast::hash(payload);
    if actual != crc {
        return Err(bad(SerialLineError::ChecksumMismatch {
            expected: crc,
            actual,
        }));
    }
    let text = std::str::from_utf8(payload).map_err(|_| bad(SerialLineError::NotAscii))?;
    let fields: Vec<&str> = text.split(',').collect();
    if fields[0] != "WAND" {
        return Err(bad(SerialLineError::UnknownSentence));
    }
    if fields.len() != 3 && fields.len() != 10 {
        return Err(bad(SerialLineError::FieldCount { got: fields.len() }));
    }
    let seq = fields[1]
        .parse()
        .map_err(|_| bad(SerialLineError::Sequence))?;
    if fields[2].is_empty() || fields[2].len() > 16 {
        return Err(bad(SerialLineError::Buttons));
    }
    let buttons = u64::from_str_radix(fields[2], 16).map_err(|_| bad(SerialLineError::Buttons))?;
    let pose = if fields.len() == 10 {
        let mut v = [0.0; 7];
        for (index, (slot, f)) in v.iter_mut().zip(&fields[3..]).enumerate() {
            *slot = f
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or(bad(SerialLineError::PoseNumber { index }))?;
        }
        let q = DQuat::from_xyzw(v[4], v[5], v[6], v[3]);
        if !(0.5..=1.5).contains(&q.length()) {
            return Err(bad(SerialLineError::NotUnitQuaternion));
        }
        Some(Pose::from_quat(DVec3::new(v[0], v[1], v[2]), q))
    } else {
        None
    };
    Ok(SerialRecord { seq, buttons, pose })
}

/// A resynchronising streaming decoder for the serial wand protocol.
#[derive(Debug, Default)]
pub struct SerialDecoder {
    line: Vec<u8>,
    in_line: bool,
    /// Bytes thrown away while resynchronising (noise, half lines, bad records).
    pub skipped_bytes: u64,
}

impl SerialDecoder {
    /// Feeds bytes; each complete line yields a record (or the reason it was dropped)
    /// together with the line's bytes from `$` up to, not including, its CR/LF.
    pub fn push(&mut self, bytes: &[u8], out: &mut impl FnMut(Result<SerialRecord>, &[u8])) {
        for &b in bytes {
            if b == b'$' {
                if self.in_line && !self.line.is_empty() {
                    self.skipped_bytes += self.line.len() as u64;
                }
                self.line.clear();
                self.line.push(b);
                self.in_line = true;
                continue;
            }
            if !self.in_line {
                if b != b'\n' && b != b'\r' {
                    self.skipped_bytes += 1;
                }
                continue;
            }
            if b == b'\n' || b == b'\r' {
                self.in_line = false;
                let rec = parse_serial(&self.line);
                if rec.is_err() {
                    self.skipped_bytes += self.line.len() as u64;
                }
                out(rec, &self.line);
                self.line.clear();
                continue;
            }
            if self.line.len() >= MAX_LINE {
                self.skipped_bytes += self.line.len() as u64 + 1;
                self.line.clear();
                self.in_line = false;
                out(
                    Err(TrackingError::SerialLine(SerialLineError::TooLong {
                        max: MAX_LINE,
                    })),
                    &[],
                );
                continue;
            }
            self.line.push(b);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tolerance::{WIRE_ANGLE_EPS, WIRE_MM_EPS};

    #[test]
    fn pose_round_trip() {
        let rec = SerialRecord {
            seq: 4_000_000_000,
            buttons: u64::MAX,
            pose: Some(Pose::from_quat(
                DVec3::new(1.5, -2.25, 1000.0),
                DQuat::from_rotation_y(0.3),
            )),
        };
        let mut line = Vec::new();
        encode_serial(&rec, &mut line);
        let back = parse_serial(&line[..line.len() - 2]).unwrap();
        assert_eq!(back.seq, rec.seq);
        assert_eq!(back.buttons, rec.buttons);
        let (a, b) = (back.pose.unwrap(), rec.pose.unwrap());
        assert!(a.position_mm.distance(b.position_mm) < WIRE_MM_EPS);
        assert!(
            a.orientation()
                .unwrap()
                .angle_between(b.orientation().unwrap())
                < WIRE_ANGLE_EPS
        );
    }

    #[test]
    fn bad_checksum_is_dropped() {
        let mut line = Vec::new();
        encode_serial(
            &SerialRecord {
                seq: 1,
                buttons: 1,
                pose: None,
            },
            &mut line,
        );
        line[7] = b'3';
        let mut got = Vec::new();
        SerialDecoder::default().push(&line, &mut |r, _| got.push(r));
        assert!(matches!(
            got.as_slice(),
            [Err(TrackingError::SerialLine(
                SerialLineError::ChecksumMismatch { .. }
            ))]
        ));
    }
}
