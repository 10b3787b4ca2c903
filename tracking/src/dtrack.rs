//! ART DTrack2 ASCII: a pure codec, bytes in, [`Frame`]s out (and back).
//!
//! One frame is a group of CR/LF-terminated lines:
//!
//! ```text
//! fr 21753
//! ts 39596.024831
//! 6dcal 2
//! 6d 1 [0 1.000][326.848 -187.216 109.503][-0.940508 0.339238 -0.019310 ...]
//! 6df2 1 1 [0 1.000 6 2][333.724 -188.909 104.992][b0 .. b8][1 0.00 0.00]
//! ```
//!
//! * `6d <n>` then per tracked body `[id qu][sx sy sz]` (or `[sx sy sz η θ φ]`, the
//!   angles being ignored) and `[b0..b8]`, the column-major `tracker_from_body` matrix.
//! * `6df2 <ncal> <n>` then per Flystick `[id qu nbt nct][sx sy sz][b0..b8]` and
//!   `[bt.. ct..]`: ⌈nbt/32⌉ integers of button bits, then `nct` analog values.
//! * Unknown line types (`3d`, `gl`, `6dmt`, ...) are ignored.
//!
//! Framing on a byte stream ([`DTrackDecoder`]): a frame starts at an `fr` line and ends
//! at an empty line, at the next `fr` line, or at the end of a datagram. The encoder
//! ends every frame with an empty line so a stream receiver can hand the frame on at
//! once rather than waiting for the next one. Lines and frames are size-capped; lines
//! outside a frame are counted and dropped; a frame with any malformed line is dropped
//! whole and reported, never half-applied.
//!
//! ```
//! use tracking::dtrack::{parse_frame, encode_frame};
//! let text = b"fr 12\r\nts 1.5\r\n6d 1 [3 1.000][10.0 20.0 30.0][1 0 0 0 1 0 0 0 1]\r\n\r\n";
//! let frame = parse_frame(text).unwrap();
//! assert_eq!(frame.number, 12);
//! assert_eq!(frame.body(3).unwrap().pose.position_mm.z, 30.0);
//! let mut again = Vec::new();
//! encode_frame(&frame, &mut again);
//! assert_eq!(parse_frame(&again).unwrap().number, 12);
//! ```

use crate::error::{Result, TrackingError};
use crate::frame::{Body, Frame, Pose, Wand};
use glam::{DMat3, DVec3};
use std::io::Write as _;

/// Caps that keep a decoder's memory bounded whatever arrives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct DecoderLimits {
    /// Longest accepted line in bytes; longer lines are discarded and reported.
    pub max_line: usize,
    /// Largest accepted frame in bytes; larger frames are discarded and reported.
    pub max_frame: usize,
    /// Most bodies plus wands in one frame.
    pub max_devices: usize,
}

impl Default for DecoderLimits {
    fn default() -> Self {
        Self {
            max_line: 16 * 1024,
            max_frame: 256 * 1024,
            max_devices: 256,
        }
    }
}

/// Counters a decoder keeps (for logs and tests).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DecoderStats {
    /// Bytes pushed in.
    pub bytes: u64,
    /// Frames handed out.
    pub frames: u64,
    /// Frames dropped because a line in them was malformed or a cap was hit.
    pub bad_frames: u64,
    /// Lines seen outside any frame (garbage before the first `fr`), dropped.
    pub orphan_lines: u64,
    /// Lines longer than the cap, dropped.
    pub long_lines: u64,
    /// Frames cut short by [`DTrackDecoder::reset`] (a disconnect mid-frame).
    pub truncated_frames: u64,
}

/// What a decoder hands out.
#[derive(Debug)]
pub enum Decoded {
    /// A complete, valid frame, with its exact bytes when the decoder keeps them.
    Frame(Frame, Option<Vec<u8>>),
    /// A frame that was dropped, and why.
    Dropped(TrackingError),
}

#[derive(Debug)]
struct Pending {
    frame: Frame,
    raw: Vec<u8>,
    size: usize,
    error: Option<TrackingError>,
}

/// A streaming DTrack2 ASCII decoder for TCP streams and UDP datagrams.
///
/// Feed bytes with [`push`](Self::push) (any split: one byte at a time or many frames
/// per read); call [`end_datagram`](Self::end_datagram) after each UDP datagram and
/// [`reset`](Self::reset) when a stream disconnects.
#[derive(Debug)]
pub struct DTrackDecoder {
    limits: DecoderLimits,
    keep_raw: bool,
    line: Vec<u8>,
    discarding: bool,
    pending: Option<Pending>,
    stats: DecoderStats,
}

impl Default for DTrackDecoder {
    fn default() -> Self {
        Self::new(DecoderLimits::default())
    }
}

impl DTrackDecoder {
    /// A decoder with the given caps that does not keep raw bytes.
    pub fn new(limits: DecoderLimits) -> Self {
        Self {
            limits,
            keep_raw: false,
            line: Vec::new(),
            discarding: false,
            pending: None,
            stats: DecoderStats::default(),
        }
    }

    /// Keep each frame's exact bytes (for pose-log recording).
    pub fn keep_raw(mut self, keep: bool) -> Self {
        self.keep_raw = keep;
        self
    }

    /// The counters so far.
    pub fn stats(&self) -> DecoderStats {
        self.stats
    }

    /// Bytes currently buffered (a partial line plus a partial frame's raw bytes).
    pub fn buffered(&self) -> usize {
        self.line.capacity() + self.pending.as_ref().map_or(0, |p| p.raw.capacity())
    }

    /// Feeds bytes; complete frames and drop reports go to `out`, in order.
    pub fn push(&mut self, mut bytes: &[u8], out: &mut impl FnMut(Decoded)) {
        self.stats.bytes += bytes.len() as u64;
        while !bytes.is_empty() {
            match memchr::memchr(b'\n', bytes) {
                Some(nl) => {
                    let (head, rest) = bytes.split_at(nl + 1);
                    bytes = rest;
                    if self.discarding {
                        self.discarding = false;
                        continue;
                    }
                    if self.line.is_empty() {
                        if head.len() > self.limits.max_line {
                            self.long_line();
                            continue;
                        }
                        self.line_done(head, out);
                    } else {
                        if self.line.len() + head.len() > self.limits.max_line {
                            self.line.clear();
                            self.long_line();
                            continue;
                        }
                        let mut line = std::mem::take(&mut self.line);
                        line.extend_from_slice(head);
                        self.line_done(&line, out);
                        line.clear();
                        self.line = line;
                    }
                }
                None => {
                    if !self.discarding {
                        if self.line.len() + bytes.len() > self.limits.max_line {
                            self.line = Vec::new();
                            self.discarding = true;
                            self.long_line();
                        } else {
                            self.line.extend_from_slice(bytes);
                        }
                    }
                    bytes = &[];
                }
            }
        }
    }

    /// Ends a datagram: a last line without CR/LF counts, and the frame is complete.
    pub fn end_datagram(&mut self, out: &mut impl FnMut(Decoded)) {
        if !self.line.is_empty() && !self.discarding {
            let line = std::mem::take(&mut self.line);
            self.line_done(&line, out);
        }
        self.line.clear();
        self.discarding = false;
        self.emit(out);
    }

    /// Forgets a partial line and frame (the stream broke); returns whether a frame was
    /// cut short. A cut frame is never handed out.
    pub fn reset(&mut self) -> bool {
        self.line.clear();
        self.discarding = false;
        let cut = self.pending.take().is_some();
        if cut {
            self.stats.truncated_frames += 1;
        }
        cut
    }

    /// A too-long line poisons the frame it is in (outside a frame it is just counted).
    fn long_line(&mut self) {
        self.stats.long_lines += 1;
        let cap = self.limits.max_line;
        if let Some(p) = self.pending.as_mut() {
            p.error.get_or_insert(TrackingError::LineTooLong { cap });
        }
    }

    fn emit(&mut self, out: &mut impl FnMut(Decoded)) {
        if let Some(p) = self.pending.take() {
            match p.error {
                Some(e) => {
                    self.stats.bad_frames += 1;
                    out(Decoded::Dropped(e));
                }
                None => {
                    self.stats.frames += 1;
                    out(Decoded::Frame(p.frame, self.keep_raw.then_some(p.raw)));
                }
            }
        }
    }

    fn line_done(&mut self, raw: &[u8], out: &mut impl FnMut(Decoded)) {
        let line = raw.trim_ascii();
        if line.is_empty() {
            if let Some(p) = self.pending.as_mut()
                && self.keep_raw
            {
                p.raw.extend_from_slice(raw);
            }
            self.emit(out);
            return;
        }
        if line_kind(line) == b"fr" {
            self.emit(out);
            let mut frame = Frame::new(0);
            let error = parse_line(line, &mut frame).err();
            self.pending = Some(Pending {
                frame,
                raw: Vec::new(),
                size: 0,
                error,
            });
        } else if self.pending.is_none() {
            self.stats.orphan_lines += 1;
            return;
        }
        let limits = self.limits;
        let keep_raw = self.keep_raw;
        let Some(p) = self.pending.as_mut() else {
            return;
        };
        p.size += raw.len();
        if p.size > limits.max_frame {
            p.error.get_or_insert(TrackingError::FrameTooLarge {
                cap: limits.max_frame,
            });
            p.raw = Vec::new();
            return;
        }
        if keep_raw && p.error.is_none() {
            p.raw.extend_from_slice(raw);
        }
        if p.error.is_some() || line_kind(line) == b"fr" {
            return;
        }
        if let Err(e) = parse_line(line, &mut p.frame) {
            p.error = Some(e);
        } else if p.frame.bodies.len() + p.frame.wands.len() > limits.max_devices {
            p.error = Some(TrackingError::FrameTooLarge {
                cap: limits.max_frame,
            });
        }
    }
}

/// Parses one complete frame (a UDP datagram, a pose-log record).
///
/// Errors when the bytes hold no `fr` line, a malformed line, or more than one frame.
pub fn parse_frame(bytes: &[u8]) -> Result<Frame> {
    let mut decoder = DTrackDecoder::default();
    let mut result: Option<Result<Frame>> = None;
    let mut extra = false;
    let mut sink = |d: Decoded| {
        let r = match d {
            Decoded::Frame(f, _) => Ok(f),
            Decoded::Dropped(e) => Err(e),
        };
        if result.is_some() {
            extra = true;
        } else {
            result = Some(r);
        }
    };
    decoder.push(bytes, &mut sink);
    decoder.end_datagram(&mut sink);
    if extra {
        return Err(line_error("fr", "more than one frame"));
    }
    if decoder.stats().orphan_lines > 0 && result.is_none() {
        return Err(line_error("fr", "no `fr` line"));
    }
    result.unwrap_or_else(|| Err(line_error("fr", "no frame")))
}

fn line_kind(line: &[u8]) -> &[u8] {
    let end = line
        .iter()
        .position(|b| b.is_ascii_whitespace())
        .unwrap_or(line.len());
    &line[..end]
}

fn line_error(kind: &str, reason: &'static str) -> TrackingError {
    TrackingError::DTrackLine {
        kind: kind.to_string(),
        reason,
    }
}

/// Which line a successfully parsed line was.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineKind {
    /// `fr`: the frame counter.
    FrameCounter,
    /// `ts`: the timestamp.
    Timestamp,
    /// `6dcal`: calibrated body count.
    BodyCount,
    /// `6d`: standard bodies.
    Bodies,
    /// `6df2`: Flysticks.
    Wands,
    /// Any other line type, ignored.
    Ignored,
}

/// Parses one line (without its CR/LF) into `frame`. `6d` and `6df2` lines append
/// their devices.
pub fn parse_line(line: &[u8], frame: &mut Frame) -> Result<LineKind> {
    let mut c = Cursor::new(line);
    let kind = c.word();
    let name = || String::from_utf8_lossy(kind).into_owned();
    let fail = |reason: &'static str| TrackingError::DTrackLine {
        kind: name(),
        reason,
    };
    let k = match kind {
        b"fr" => {
            frame.number = c.uint().ok_or_else(|| fail("bad frame counter"))?;
            LineKind::FrameCounter
        }
        b"ts" => {
            let t = c.float().ok_or_else(|| fail("bad timestamp"))?;
            frame.tracker_time = Some(t);
            LineKind::Timestamp
        }
        b"6dcal" => {
            let n = c.uint().ok_or_else(|| fail("bad count"))?;
            frame.calibrated_bodies = Some(u32::try_from(n).map_err(|_| fail("count too large"))?);
            LineKind::BodyCount
        }
        b"6d" => {
            let n = c.uint().ok_or_else(|| fail("bad count"))?;
            for _ in 0..n {
                let body = parse_body(&mut c).map_err(&fail)?;
                frame.bodies.push(body);
            }
            LineKind::Bodies
        }
        b"6df2" => {
            let ncal = c.uint().ok_or_else(|| fail("bad calibrated count"))?;
            frame.calibrated_wands =
                Some(u32::try_from(ncal).map_err(|_| fail("count too large"))?);
            let n = c.uint().ok_or_else(|| fail("bad count"))?;
            for _ in 0..n {
                let wand = parse_wand(&mut c).map_err(&fail)?;
                frame.wands.push(wand);
            }
            LineKind::Wands
        }
        _ => return Ok(LineKind::Ignored),
    };
    if !c.at_end() {
        return Err(fail("trailing characters"));
    }
    Ok(k)
}

fn parse_body(c: &mut Cursor<'_>) -> Result<Body, &'static str> {
    c.open().ok_or("expected `[id qu]`")?;
    let id = c.id().ok_or("bad id")?;
    let quality = c.float().ok_or("bad quality")?;
    c.close().ok_or("expected `]` after quality")?;
    let position_mm = parse_position(c, true)?;
    let tracker_from_body = parse_matrix(c)?;
    let pose = Pose {
        position_mm,
        tracker_from_body,
    };
    check_rotation(quality, &pose)?;
    Ok(Body { id, quality, pose })
}

fn parse_wand(c: &mut Cursor<'_>) -> Result<Wand, &'static str> {
    c.open().ok_or("expected `[id qu nbt nct]`")?;
    let id = c.id().ok_or("bad id")?;
    let quality = c.float().ok_or("bad quality")?;
    let nbt = c.uint().ok_or("bad button count")?;
    let nct = c.uint().ok_or("bad analog count")?;
    c.close().ok_or("expected `]` after counts")?;
    if nbt > u64::from(Wand::MAX_BUTTONS) {
        return Err("too many buttons");
    }
    if nct > Wand::MAX_ANALOG as u64 {
        return Err("too many analog axes");
    }
    let position_mm = parse_position(c, false)?;
    let tracker_from_body = parse_matrix(c)?;
    let pose = Pose {
        position_mm,
        tracker_from_body,
    };
    check_rotation(quality, &pose)?;
    c.open().ok_or("expected `[buttons analog]`")?;
    let words = nbt.div_ceil(32);
    let mut buttons = 0u64;
    for w in 0..words {
        let bits = c.uint().ok_or("bad button word")?;
        let bits = u32::try_from(bits).map_err(|_| "button word too large")?;
        buttons |= u64::from(bits) << (32 * w);
    }
    if nbt < 64 {
        buttons &= (1u64 << nbt) - 1;
    }
    let mut analog = Vec::with_capacity(nct as usize);
    for _ in 0..nct {
        let a = c.float().ok_or("bad analog value")?;
        analog.push(a.clamp(-1.0, 1.0));
    }
    c.close().ok_or("expected `]` after analog values")?;
    Ok(Wand {
        id,
        quality,
        pose,
        button_count: nbt as u8,
        buttons,
        analog,
    })
}

fn parse_position(c: &mut Cursor<'_>, allow_angles: bool) -> Result<DVec3, &'static str> {
    c.open().ok_or("expected `[sx sy sz]`")?;
    let x = c.float().ok_or("bad position")?;
    let y = c.float().ok_or("bad position")?;
    let z = c.float().ok_or("bad position")?;
    if allow_angles && !c.peek_close() {
        for _ in 0..3 {
            c.float().ok_or("bad angle")?;
        }
    }
    c.close().ok_or("expected `]` after position")?;
    Ok(DVec3::new(x, y, z))
}

fn parse_matrix(c: &mut Cursor<'_>) -> Result<DMat3, &'static str> {
    c.open().ok_or("expected `[b0..b8]`")?;
    let mut m = [0.0; 9];
    for v in &mut m {
        *v = c.float().ok_or("bad rotation")?;
    }
    c.close().ok_or("expected `]` after rotation")?;
    Ok(DMat3::from_cols_array(&m))
}

/// A tracked device must carry a proper rotation; an untracked one (quality < 0)
/// may send zeros.
fn check_rotation(quality: f64, pose: &Pose) -> Result<(), &'static str> {
    if quality >= 0.0 && pose.orientation().is_none() {
        return Err("rotation matrix is not a rotation");
    }
    Ok(())
}

/// A byte cursor over one line: words, numbers and `[` `]` groups.
struct Cursor<'a> {
    s: &'a [u8],
    i: usize,
}

impl<'a> Cursor<'a> {
    fn new(s: &'a [u8]) -> Self {
        Self { s, i: 0 }
    }

    fn skip_ws(&mut self) {
        while self.i < self.s.len() && self.s[self.i].is_ascii_whitespace() {
            self.i += 1;
        }
    }

    fn at_end(&mut self) -> bool {
        self.skip_ws();
        self.i == self.s.len()
    }

    /// The next token: up to whitespace or a bracket.
    fn word(&mut self) -> &'a [u8] {
        self.skip_ws();
        let start = self.i;
        while self.i < self.s.len() {
            let b = self.s[self.i];
            if b.is_ascii_whitespace() || b == b'[' || b == b']' {
                break;
            }
            self.i += 1;
        }
        &self.s[start..self.i]
    }

    fn punct(&mut self, p: u8) -> Option<()> {
        self.skip_ws();
        (self.s.get(self.i) == Some(&p)).then(|| self.i += 1)
    }

    fn open(&mut self) -> Option<()> {
        self.punct(b'[')
    }

    fn close(&mut self) -> Option<()> {
        self.punct(b']')
    }

    fn peek_close(&mut self) -> bool {
        self.skip_ws();
        self.s.get(self.i) == Some(&b']')
    }

    fn uint(&mut self) -> Option<u64> {
        let w = self.word();
        if w.is_empty() || w.len() > 19 || !w.iter().all(u8::is_ascii_digit) {
            return None;
        }
        Some(w.iter().fold(0u64, |a, d| a * 10 + u64::from(d - b'0')))
    }

    fn id(&mut self) -> Option<u32> {
        self.uint().and_then(|v| u32::try_from(v).ok())
    }

    /// A finite decimal number.
    fn float(&mut self) -> Option<f64> {
        let w = self.word();
        let v = fast_f64(w).or_else(|| std::str::from_utf8(w).ok()?.parse::<f64>().ok())?;
        v.is_finite().then_some(v)
    }
}

/// Exact fast path for plain decimals like `-187.216`: at most 15 significant digits
/// and 22 fraction digits, so the integer mantissa and the power of ten are both exact
/// in `f64` and one division rounds correctly (Clinger's fast path). Anything else
/// (exponents, long digit strings) returns `None` for the full parser.
fn fast_f64(w: &[u8]) -> Option<f64> {
    const POW10: [f64; 23] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
        1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
    ];
    let (neg, digits) = match w.first()? {
        b'-' => (true, &w[1..]),
        b'+' => (false, &w[1..]),
        _ => (false, w),
    };
    if digits.is_empty() || digits.len() > 17 {
        return None;
    }
    let mut mantissa = 0u64;
    let mut frac_digits = 0usize;
    let mut seen_dot = false;
    let mut seen_digit = false;
    for &b in digits {
        match b {
            b'0'..=b'9' => {
                mantissa = mantissa * 10 + u64::from(b - b'0');
                seen_digit = true;
                if seen_dot {
                    frac_digits += 1;
                }
            }
            b'.' if !seen_dot => seen_dot = true,
            _ => return None,
        }
    }
    if !seen_digit || mantissa >= 1 << 53 {
        return None;
    }
    let v = mantissa as f64 / POW10[frac_digits];
    Some(if neg { -v } else { v })
}

/// Appends one frame in DTrack2 ASCII, CR/LF line ends, closed by an empty line.
///
/// Positions are written with 3 decimals (µm), rotations with 6, quality with 3, the
/// timestamp with 6 and analog values with 2, as DTrack2 does.
pub fn encode_frame(frame: &Frame, out: &mut Vec<u8>) {
    // Writing into a Vec cannot fail.
    let _ = write!(out, "fr {}\r\n", frame.number);
    if let Some(ts) = frame.tracker_time {
        let _ = write!(out, "ts {ts:.6}\r\n");
    }
    if let Some(n) = frame.calibrated_bodies {
        let _ = write!(out, "6dcal {n}\r\n");
    }
    if !frame.bodies.is_empty() || frame.calibrated_bodies.is_some() {
        let _ = write!(out, "6d {}", frame.bodies.len());
        for b in &frame.bodies {
            let _ = write!(out, " [{} {:.3}]", b.id, b.quality);
            write_pose(&b.pose, out);
        }
        out.extend_from_slice(b"\r\n");
    }
    if !frame.wands.is_empty() || frame.calibrated_wands.is_some() {
        let ncal = frame.calibrated_wands.unwrap_or(frame.wands.len() as u32);
        let _ = write!(out, "6df2 {ncal} {}", frame.wands.len());
        for w in &frame.wands {
            let nbt = w.button_count.min(Wand::MAX_BUTTONS);
            let _ = write!(
                out,
                " [{} {:.3} {} {}]",
                w.id,
                w.quality,
                nbt,
                w.analog.len()
            );
            write_pose(&w.pose, out);
            out.push(b'[');
            let words = u32::from(nbt).div_ceil(32);
            let mut first = true;
            for k in 0..words {
                let bits = (w.buttons >> (32 * k)) as u32;
                let _ = write!(out, "{}{bits}", if first { "" } else { " " });
                first = false;
            }
            for a in &w.analog {
                let _ = write!(out, "{}{a:.2}", if first { "" } else { " " });
                first = false;
            }
            out.push(b']');
        }
        out.extend_from_slice(b"\r\n");
    }
    out.extend_from_slice(b"\r\n");
}

fn write_pose(pose: &Pose, out: &mut Vec<u8>) {
    let p = pose.position_mm;
    let _ = write!(out, "[{:.3} {:.3} {:.3}][", p.x, p.y, p.z);
    for (k, v) in pose.tracker_from_body.to_cols_array().iter().enumerate() {
        let _ = write!(out, "{}{v:.6}", if k == 0 { "" } else { " " });
    }
    out.push(b']');
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_path_matches_std() {
        for s in [
            "0",
            "-0.5",
            "326.848",
            "-187.216",
            "1.000",
            "39596.024831",
            "+3",
            ".5",
            "5.",
        ] {
            assert_eq!(fast_f64(s.as_bytes()), s.parse::<f64>().ok(), "{s}");
        }
        for s in [
            "1e3",
            "nan",
            "inf",
            "-",
            ".",
            "1.2.3",
            "12345678901234567890",
        ] {
            assert_eq!(fast_f64(s.as_bytes()), None, "{s}");
        }
    }

    #[test]
    fn non_finite_numbers_are_rejected() {
        let mut f = Frame::default();
        assert!(parse_line(b"ts NaN", &mut f).is_err());
        assert!(parse_line(b"ts inf", &mut f).is_err());
        assert!(parse_line(b"ts 1e400", &mut f).is_err());
    }
}
