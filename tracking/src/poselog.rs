//! Pose logs: every raw frame with its receive time, the stand-in for the hardware.
//!
//! A versioned, append-only, line-per-record text format (full description in
//! `docs/formats/pose-log.md`):
//!
//! ```text
//! wandsculpt-poselog 1
//! header {"source":"tcp-listen 127.0.0.1:5001","calibration":{...},"config":{...}}
//! d 0.008333333 5a1f03c2 fr 1\r\nts 0.008333\r\n6d 1 [0 1.000][...][...]\r\n\r\n
//! s 0.010000000 0b7e44d1 $WAND,1,0003,...*8F1C2A3B\r\n
//! ```
//!
//! Each record is `<kind> <seconds> <crc32> <payload>`: kind `d` (DTrack2 ASCII bytes)
//! or `s` (serial wand line bytes); the receive time in seconds since the recording
//! started, with exactly nine decimals; the CRC-32 (IEEE) of the payload bytes as eight
//! lower-case hex digits; the payload's exact bytes, escaped so the record fits one
//! line (`\\`, `\r`, `\n`, `\t`, `\xHH` for other bytes outside printable ASCII).
//! Unescaping gives back the bytes as received, so a log can be re-sent byte for byte.
//!
//! The reader tolerates a truncated last line (a crash mid-write) and reports corrupt
//! lines with their line numbers, carrying on after them.
//!
//! ```
//! use tracking::poselog::{PoseLogHeader, PoseLogWriter, PoseLogReader, RecordKind};
//! use std::time::Duration;
//! let mut bytes = Vec::new();
//! let mut w = PoseLogWriter::new(&mut bytes, &PoseLogHeader::new("doc")).unwrap();
//! w.write(RecordKind::DTrack, Duration::from_millis(5), b"fr 1\r\n\r\n").unwrap();
//! drop(w);
//! let mut r = PoseLogReader::new(bytes.as_slice()).unwrap();
//! let rec = r.next().unwrap().unwrap();
//! assert_eq!(rec.bytes, b"fr 1\r\n\r\n");
//! assert_eq!(rec.time, Duration::from_millis(5));
//! ```

use crate::dtrack;
use crate::error::{PoseLogHeaderError, PoseLogLineError, Result, TrackingError};
use crate::frame::Frame;
use serde::{Deserialize, Serialize};
use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::Path;
use std::time::Duration;

/// The first line of every pose log, without the version.
pub const MAGIC: &str = "wandsculpt-poselog";
/// The format version this crate writes and reads.
pub const VERSION: u32 = 1;
/// Longest line the reader accepts (longer lines are reported as corrupt).
pub const MAX_LINE: usize = 4 * 1024 * 1024;
/// Largest pose log the programs read (bytes, 1 GiB: over an hour of two 120 Hz bodies
/// with room to spare). A larger file is refused from its size before it is read, so
/// memory is bounded by this cap, not by the file.
pub const MAX_LOG_BYTES: u64 = 1 << 30;

/// The log header: where the data came from and the calibration and config in force.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct PoseLogHeader {
    /// Where the records came from (e.g. `tcp-listen 127.0.0.1:5001`, `sim seed=7`).
    pub source: String,
    /// Milliseconds since the Unix epoch when recording started (informational; an
    /// integer so the header round-trips exactly).
    pub started_unix_ms: u64,
    /// The calibration in force ([`crate::calibration::Calibration`] as JSON).
    pub calibration: serde_json::Value,
    /// The tracking config in force ([`crate::config::TrackingConfig`] as JSON).
    pub config: serde_json::Value,
    /// The solid target the session sculpts, when it sculpts one (`replay` starts
    /// from it); absent from the header otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub solid: Option<SessionSolid>,
}

/// A solid target named by a pose log's header: its model (a JSON solid document or
/// a `.vm` model, as text) and its grid cells along the longest side.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SessionSolid {
    /// A name for people.
    pub name: String,
    /// The model's text.
    pub model: String,
    /// Grid cells along the solid's longest side.
    pub cells: usize,
}

impl PoseLogHeader {
    /// A header naming its source, stamped with the current wall-clock time.
    pub fn new(source: impl Into<String>) -> Self {
        let started_unix_ms = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_millis() as u64);
        Self {
            source: source.into(),
            started_unix_ms,
            ..Self::default()
        }
    }
}

/// What a record's payload is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RecordKind {
    /// DTrack2 ASCII bytes of one frame (`d`).
    DTrack,
    /// One serial wand line (`s`).
    Serial,
}

impl RecordKind {
    fn tag(self) -> u8 {
        match self {
            RecordKind::DTrack => b'd',
            RecordKind::Serial => b's',
        }
    }
}

/// One record of a pose log.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Record {
    /// 1-based line number in the log.
    pub line: usize,
    /// What the payload is.
    pub kind: RecordKind,
    /// Receive time since the recording started.
    pub time: Duration,
    /// The payload bytes exactly as received.
    pub bytes: Vec<u8>,
}

impl Record {
    /// Parses a DTrack record into a frame stamped with the record's receive time.
    pub fn frame(&self) -> Result<Frame> {
        if self.kind != RecordKind::DTrack {
            return Err(TrackingError::PoseLogLine {
                line: self.line,
                reason: PoseLogLineError::NotDTrack,
            });
        }
        let mut f = dtrack::parse_frame(&self.bytes).map_err(|e| TrackingError::PoseLogLine {
            line: self.line,
            reason: PoseLogLineError::DTrack(Box::new(e)),
        })?;
        f.receive_time = self.time;
        Ok(f)
    }
}

/// Escapes payload bytes into `out` (see the module docs).
pub fn escape(bytes: &[u8], out: &mut Vec<u8>) {
    const HEX: &[u8; 16] = b"0123456789ABCDEF";
    for &b in bytes {
        match b {
            b'\\' => out.extend_from_slice(b"\\\\"),
            b'\r' => out.extend_from_slice(b"\\r"),
            b'\n' => out.extend_from_slice(b"\\n"),
            b'\t' => out.extend_from_slice(b"\\t"),
            0x20..=0x7e => out.push(b),
            _ => out.extend_from_slice(&[
                b'\\',
                b'x',
                HEX[usize::from(b >> 4)],
                HEX[usize::from(b & 15)],
            ]),
        }
    }
}

/// Undoes [`escape`]; `Err` names the first bad escape.
pub fn unescape(text: &[u8]) -> std::result::Result<Vec<u8>, PoseLogLineError> {
    let mut out = Vec::with_capacity(text.len());
    let mut i = 0;
    while i < text.len() {
        let b = text[i];
        if b != b'\\' {
            if !(0x20..=0x7e).contains(&b) {
                return Err(PoseLogLineError::RawByte {
                    byte: b,
                    column: i + 1,
                });
            }
            out.push(b);
            i += 1;
            continue;
        }
        match text.get(i + 1) {
            Some(b'\\') => out.push(b'\\'),
            Some(b'r') => out.push(b'\r'),
            Some(b'n') => out.push(b'\n'),
            Some(b't') => out.push(b'\t'),
            Some(b'x') => {
                let hex = text
                    .get(i + 2..i + 4)
                    .and_then(|h| std::str::from_utf8(h).ok())
                    .and_then(|h| u8::from_str_radix(h, 16).ok())
                    .ok_or(PoseLogLineError::BadEscape {
                        hex: true,
                        column: i + 1,
                    })?;
                out.push(hex);
                i += 2;
            }
            _ => {
                return Err(PoseLogLineError::BadEscape {
                    hex: false,
                    column: i + 1,
                });
            }
        }
        i += 2;
    }
    Ok(out)
}

fn format_time(t: Duration) -> String {
    format!("{}.{:09}", t.as_secs(), t.subsec_nanos())
}

fn parse_time(s: &[u8]) -> Option<Duration> {
    let s = std::str::from_utf8(s).ok()?;
    let (secs, frac) = s.split_once('.')?;
    if secs.is_empty()
        || frac.len() != 9
        || !secs.bytes().chain(frac.bytes()).all(|b| b.is_ascii_digit())
    {
        return None;
    }
    Some(Duration::new(secs.parse().ok()?, frac.parse().ok()?))
}

/// Appends records to a pose log, flushing after each one.
#[derive(Debug)]
pub struct PoseLogWriter<W: Write> {
    w: W,
    last: Duration,
    line: Vec<u8>,
}

impl PoseLogWriter<BufWriter<File>> {
    /// Creates (or truncates) a log file and writes its header.
    pub fn create(path: impl AsRef<Path>, header: &PoseLogHeader) -> Result<Self> {
        let path = path.as_ref();
        let f = File::create(path).map_err(|e| TrackingError::io_path(path, e))?;
        Self::new(BufWriter::new(f), header)
    }

    /// Opens an existing log to append to it, after checking its header. Times of new
    /// records must not go back before the last record already there. A truncated last
    /// line (a crash) is closed off first, so it stays a single reported corrupt line.
    pub fn append(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let io = |e| TrackingError::io_path(path, e);
        let mut last = Duration::ZERO;
        {
            let mut reader = PoseLogReader::open(path)?;
            for rec in reader.by_ref().flatten() {
                last = last.max(rec.time);
            }
        }
        let mut f = OpenOptions::new()
            .read(true)
            .append(true)
            .open(path)
            .map_err(io)?;
        let len = f.metadata().map_err(io)?.len();
        if len > 0 {
            f.seek(SeekFrom::Start(len - 1)).map_err(io)?;
            let mut b = [0u8];
            f.read_exact(&mut b).map_err(io)?;
            if b[0] != b'\n' {
                f.write_all(b"\n").map_err(io)?;
            }
        }
        Ok(Self {
            w: BufWriter::new(f),
            last,
            line: Vec::new(),
        })
    }
}

impl<W: Write> PoseLogWriter<W> {
    /// Writes the magic line and the header to `w`.
    pub fn new(mut w: W, header: &PoseLogHeader) -> Result<Self> {
        let json = serde_json::to_string(header)?;
        let io = |e| TrackingError::io("pose log", e);
        write!(w, "{MAGIC} {VERSION}\nheader {json}\n").map_err(io)?;
        w.flush().map_err(io)?;
        Ok(Self {
            w,
            last: Duration::ZERO,
            line: Vec::new(),
        })
    }

    /// Appends one record and flushes it. A time earlier than the previous record's is
    /// clamped to it (the receive clock is monotonic; this guards against misuse).
    pub fn write(&mut self, kind: RecordKind, time: Duration, bytes: &[u8]) -> Result<()> {
        let time = time.max(self.last);
        self.last = time;
        self.line.clear();
        self.line.push(kind.tag());
        self.line.push(b' ');
        self.line.extend_from_slice(format_time(time).as_bytes());
        self.line.push(b' ');
        self.line
            .extend_from_slice(format!("{:08x}", crc32fast::hash(bytes)).as_bytes());
        self.line.push(b' ');
        escape(bytes, &mut self.line);
        self.line.push(b'\n');
        let io = |e| TrackingError::io("pose log", e);
        self.w.write_all(&self.line).map_err(io)?;
        self.w.flush().map_err(io)
    }

    /// Encodes a frame as DTrack2 ASCII and appends it with its receive time.
    pub fn write_frame(&mut self, frame: &Frame) -> Result<()> {
        let mut bytes = Vec::with_capacity(256);
        dtrack::encode_frame(frame, &mut bytes);
        self.write(RecordKind::DTrack, frame.receive_time, &bytes)
    }

    /// The underlying writer.
    pub fn into_inner(self) -> W {
        self.w
    }
}

/// Reads a pose log record by record. Iterating yields `Ok(record)` or, for a corrupt
/// line, `Err(TrackingError::PoseLogLine { line, .. })`, and carries on after it.
#[derive(Debug)]
pub struct PoseLogReader<R: BufRead> {
    r: R,
    header: PoseLogHeader,
    line_no: usize,
    last: Duration,
    truncated_tail: bool,
    buf: Vec<u8>,
}

impl PoseLogReader<BufReader<File>> {
    /// Opens a log file and reads its header.
    pub fn open(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let f = File::open(path).map_err(|e| TrackingError::io_path(path, e))?;
        Self::new(BufReader::new(f))
    }
}

/// Reads one line (without the `\n`) into `buf`, at most `cap` bytes kept.
/// Returns `None` at EOF, else `(complete, too_long)`.
fn read_line_capped(
    r: &mut impl BufRead,
    buf: &mut Vec<u8>,
    cap: usize,
) -> std::io::Result<Option<(bool, bool)>> {
    buf.clear();
    let mut too_long = false;
    let mut any = false;
    loop {
        let avail = r.fill_buf()?;
        if avail.is_empty() {
            return Ok(any.then_some((false, too_long)));
        }
        any = true;
        let (chunk, done) = match memchr::memchr(b'\n', avail) {
            Some(i) => (&avail[..i], Some(i + 1)),
            None => (avail, None),
        };
        if buf.len() + chunk.len() <= cap {
            buf.extend_from_slice(chunk);
        } else {
            too_long = true;
        }
        let used = done.unwrap_or(avail.len());
        r.consume(used);
        if done.is_some() {
            return Ok(Some((true, too_long)));
        }
    }
}

impl<R: BufRead> PoseLogReader<R> {
    /// Reads the magic line and header from `r`.
    pub fn new(mut r: R) -> Result<Self> {
        let mut buf = Vec::new();
        let io = |e| TrackingError::io("pose log", e);
        let bad = TrackingError::PoseLogHeader;
        match read_line_capped(&mut r, &mut buf, 256).map_err(io)? {
            Some((true, false)) => {}
            _ => return Err(bad(PoseLogHeaderError::MissingFirstLine)),
        }
        let first = String::from_utf8_lossy(&buf).into_owned();
        let version = first
            .strip_prefix(MAGIC)
            .and_then(|v| v.trim().parse::<u32>().ok())
            .ok_or_else(|| bad(PoseLogHeaderError::FirstLine(first.clone())))?;
        if version != VERSION {
            return Err(bad(PoseLogHeaderError::Version {
                found: version,
                supported: VERSION,
            }));
        }
        match read_line_capped(&mut r, &mut buf, MAX_LINE).map_err(io)? {
            Some((true, false)) => {}
            _ => return Err(bad(PoseLogHeaderError::MissingHeaderLine)),
        }
        let json = buf
            .strip_prefix(b"header ")
            .ok_or(bad(PoseLogHeaderError::NotHeader))?;
        let header: PoseLogHeader =
            serde_json::from_slice(json).map_err(|e| bad(PoseLogHeaderError::Json(e.into())))?;
        Ok(Self {
            r,
            header,
            line_no: 2,
            last: Duration::ZERO,
            truncated_tail: false,
            buf,
        })
    }

    /// The header.
    pub fn header(&self) -> &PoseLogHeader {
        &self.header
    }

    /// True once the reader met a last line without its `\n` (dropped, not an error).
    pub fn truncated_tail(&self) -> bool {
        self.truncated_tail
    }

    fn parse_record(&mut self) -> std::result::Result<Option<Record>, PoseLogLineError> {
        let line = &self.buf;
        if line.is_empty() || line[0] == b'#' {
            return Ok(None);
        }
        let kind = match line.get(..2) {
            Some(b"d ") => RecordKind::DTrack,
            Some(b"s ") => RecordKind::Serial,
            _ => return Err(PoseLogLineError::UnknownKind),
        };
        let rest = &line[2..];
        let sp = memchr::memchr(b' ', rest).ok_or(PoseLogLineError::MissingPayload)?;
        let time = parse_time(&rest[..sp]).ok_or(PoseLogLineError::BadTime)?;
        if time < self.last {
            return Err(PoseLogLineError::TimeBackwards {
                time: format_time(time),
                previous: format_time(self.last),
            });
        }
        let rest = &rest[sp + 1..];
        let crc = rest
            .get(..9)
            .filter(|c| c[8] == b' ')
            .and_then(|c| std::str::from_utf8(&c[..8]).ok())
            .and_then(|c| u32::from_str_radix(c, 16).ok())
            .ok_or(PoseLogLineError::ChecksumField)?;
        let bytes = unescape(&rest[9..])?;
        if crc32fast::hash(&bytes) != crc {
            return Err(PoseLogLineError::ChecksumMismatch);
        }
        self.last = time;
        Ok(Some(Record {
            line: self.line_no,
            kind,
            time,
            bytes,
        }))
    }
}

impl<R: BufRead> Iterator for PoseLogReader<R> {
    type Item = Result<Record>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            let (complete, too_long) = match read_line_capped(&mut self.r, &mut self.buf, MAX_LINE)
            {
                Ok(Some(x)) => x,
                Ok(None) => return None,
                Err(e) => return Some(Err(TrackingError::io("pose log", e))),
            };
            self.line_no += 1;
            if !complete {
                self.truncated_tail = true;
                return None;
            }
            let line = self.line_no;
            if too_long {
                return Some(Err(TrackingError::PoseLogLine {
                    line,
                    reason: PoseLogLineError::TooLong { max: MAX_LINE },
                }));
            }
            match self.parse_record() {
                Ok(Some(rec)) => return Some(Ok(rec)),
                Ok(None) => continue,
                Err(reason) => return Some(Err(TrackingError::PoseLogLine { line, reason })),
            }
        }
    }
}

/// A whole pose log in memory: frames with their timing, and what was wrong with it.
#[derive(Debug, Default)]
pub struct PoseLog {
    /// The header.
    pub header: PoseLogHeader,
    /// Every readable record, in order.
    pub records: Vec<Record>,
    /// Corrupt lines (each a [`TrackingError::PoseLogLine`] with its line number).
    pub corrupt: Vec<TrackingError>,
    /// Whether the last line was truncated (and dropped).
    pub truncated_tail: bool,
}

impl PoseLog {
    /// Reads a whole log from a file.
    pub fn read(path: impl AsRef<Path>) -> Result<Self> {
        Self::from_reader(PoseLogReader::open(path)?)
    }

    /// Reads a whole log from bytes.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self> {
        Self::from_reader(PoseLogReader::new(bytes)?)
    }

    fn from_reader<R: BufRead>(mut reader: PoseLogReader<R>) -> Result<Self> {
        let mut log = PoseLog::default();
        for item in reader.by_ref() {
            match item {
                Ok(rec) => log.records.push(rec),
                Err(e @ TrackingError::PoseLogLine { .. }) => log.corrupt.push(e),
                Err(e) => return Err(e),
            }
        }
        log.truncated_tail = reader.truncated_tail();
        log.header = reader.header;
        Ok(log)
    }

    /// The DTrack frames with their receive times; records whose payload does not parse
    /// are added to `corrupt` (with their line numbers) and skipped.
    pub fn frames(&self) -> (Vec<Frame>, Vec<TrackingError>) {
        let mut frames = Vec::new();
        let mut bad = Vec::new();
        for rec in self.records.iter().filter(|r| r.kind == RecordKind::DTrack) {
            match rec.frame() {
                Ok(f) => frames.push(f),
                Err(e) => bad.push(e),
            }
        }
        (frames, bad)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escape_round_trips_every_byte() {
        let all: Vec<u8> = (0..=255u8).collect();
        let mut e = Vec::new();
        escape(&all, &mut e);
        assert!(!e.contains(&b'\n'));
        assert_eq!(unescape(&e).unwrap(), all);
    }

    #[test]
    fn time_format_is_exact() {
        let t = Duration::new(12, 345_678_901);
        assert_eq!(format_time(t), "12.345678901");
        assert_eq!(parse_time(b"12.345678901"), Some(t));
        assert_eq!(parse_time(b"12.34"), None);
        assert_eq!(parse_time(b"-1.000000000"), None);
    }
}
