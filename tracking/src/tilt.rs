//! Reading (and writing) Open Brush / Tilt Brush `.tilt` sketches.
//!
//! A `.tilt` file is a 16-byte header (`tilT`, u16 header size, u16 version, 8 reserved
//! bytes) followed by an uncompressed zip archive holding `data.sketch`,
//! `metadata.json` and `thumbnail.png`. `data.sketch` is little-endian:
//!
//! ```text
//! u32 sentinel, u32 version, u32 reserved, u32 n + n extra header bytes, i32 stroke count
//! per stroke:  i32 brush index, 4 f32 colour, f32 size,
//!              u32 stroke-extension mask, u32 control-point-extension mask,
//!              stroke extensions (bit 0 flags u32, bit 1 scale f32, bit 2 group u32,
//!              bit 3 seed u32; other bits of the low 16 carry one u32 each, bits of the
//!              high 16 carry a u32 byte count and that many bytes),
//!              i32 control-point count
//! per point:   3 f32 position (decimetres, Y up), 4 f32 rotation (x, y, z, w),
//!              one 4-byte value per set bit of the control-point mask
//!              (bit 0 f32 pressure, bit 1 u32 timestamp in ms)
//! ```
//!
//! The reader is total: any byte string gives either a [`Tilt`] or a clear
//! [`TrackingError`](crate::TrackingError), never a panic. Counts are checked against the bytes that are
//! left before anything is allocated, so memory stays bounded by the input size.
//! Non-finite positions, rotations or pressures are rejected.
//!
//! ```
//! use tracking::tilt::{self, Sketch, TiltStroke, ControlPoint};
//! let sketch = Sketch {
//!     version: 5,
//!     strokes: vec![TiltStroke {
//!         points: vec![ControlPoint::at([0.0, 1.0, 2.0], 10), ControlPoint::at([0.5, 1.0, 2.0], 21)],
//!         ..TiltStroke::default()
//!     }],
//! };
//! let bytes = tilt::write_tilt(&sketch, None).unwrap();
//! let back = tilt::read_tilt(&bytes).unwrap();
//! assert_eq!(back.sketch, sketch);
//! ```

use std::io::{Cursor, Read, Write};

use glam::{DQuat, DVec3};

use crate::error::{Result, SketchError, TiltContainerError, TrackingError as Error};

/// The magic at the start of every `.tilt` file.
pub const TILT_MAGIC: &[u8; 4] = b"tilT";
/// The sentinel at the start of `data.sketch`.
pub const SKETCH_SENTINEL: u32 = 0xc576_a5cd;
/// The largest `data.sketch` (bytes) this reader accepts once decompressed.
pub const MAX_SKETCH_BYTES: u64 = 256 << 20;
/// The largest `metadata.json` (bytes) this reader accepts.
pub const MAX_METADATA_BYTES: u64 = 1 << 20;

/// Stroke-extension bit: a u32 of flags.
pub const STROKE_EXT_FLAGS: u32 = 1 << 0;
/// Stroke-extension bit: an f32 scale.
pub const STROKE_EXT_SCALE: u32 = 1 << 1;
/// Stroke-extension bit: a u32 group id.
pub const STROKE_EXT_GROUP: u32 = 1 << 2;
/// Stroke-extension bit: a u32 random seed.
pub const STROKE_EXT_SEED: u32 = 1 << 3;
/// Control-point-extension bit: an f32 pressure.
pub const POINT_EXT_PRESSURE: u32 = 1 << 0;
/// Control-point-extension bit: a u32 timestamp in milliseconds.
pub const POINT_EXT_TIMESTAMP: u32 = 1 << 1;

/// Bytes of a stroke with no extensions and no points.
const MIN_STROKE_BYTES: usize = 4 + 16 + 4 + 4 + 4 + 4;
/// Bytes of a control point with no extensions.
const BASE_POINT_BYTES: usize = 7 * 4;

/// A whole `.tilt` file: the sketch and the raw metadata.
#[derive(Debug, Clone, PartialEq)]
pub struct Tilt {
    /// The strokes (`data.sketch`).
    pub sketch: Sketch,
    /// The raw `metadata.json` text, when the archive has one.
    pub metadata: Option<String>,
}

/// The decoded `data.sketch`.
#[derive(Debug, Clone, PartialEq)]
pub struct Sketch {
    /// The format version written in the header (5 for current Open Brush files).
    pub version: u32,
    /// The strokes, in drawing order.
    pub strokes: Vec<TiltStroke>,
}

/// One brush stroke.
#[derive(Debug, Clone, PartialEq)]
pub struct TiltStroke {
    /// Index into the sketch's brush list.
    pub brush_index: i32,
    /// Linear RGBA colour.
    pub color: [f32; 4],
    /// Brush size (Open Brush units).
    pub size: f32,
    /// Stroke flags (extension bit 0), when present.
    pub flags: Option<u32>,
    /// Stroke scale (extension bit 1), when present.
    pub scale: Option<f32>,
    /// Group id (extension bit 2), when present.
    pub group: Option<u32>,
    /// Random seed (extension bit 3), when present.
    pub seed: Option<u32>,
    /// The control points, in drawing order.
    pub points: Vec<ControlPoint>,
}

impl Default for TiltStroke {
    fn default() -> Self {
        Self {
            brush_index: 0,
            color: [1.0; 4],
            size: 0.1,
            flags: None,
            scale: None,
            group: None,
            seed: None,
            points: Vec::new(),
        }
    }
}

impl TiltStroke {
    /// The stroke-extension mask that encodes this stroke's optional fields.
    pub fn stroke_extension_mask(&self) -> u32 {
        let mut mask = 0;
        if self.flags.is_some() {
            mask |= STROKE_EXT_FLAGS;
        }
        if self.scale.is_some() {
            mask |= STROKE_EXT_SCALE;
        }
        if self.group.is_some() {
            mask |= STROKE_EXT_GROUP;
        }
        if self.seed.is_some() {
            mask |= STROKE_EXT_SEED;
        }
        mask
    }

    /// The control-point-extension mask for this stroke: a field is written when the
    /// first point has it (a stroke's points all share one mask).
    pub fn point_extension_mask(&self) -> u32 {
        let Some(first) = self.points.first() else {
            return POINT_EXT_PRESSURE | POINT_EXT_TIMESTAMP;
        };
        let mut mask = 0;
        if first.pressure.is_some() {
            mask |= POINT_EXT_PRESSURE;
        }
        if first.timestamp_ms.is_some() {
            mask |= POINT_EXT_TIMESTAMP;
        }
        mask
    }
}

/// One control point of a stroke.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlPoint {
    /// Position in Open Brush units (decimetres), Y up.
    pub position: [f32; 3],
    /// Orientation quaternion as stored: x, y, z, w.
    pub rotation: [f32; 4],
    /// Pen pressure in [0, 1], when recorded.
    pub pressure: Option<f32>,
    /// Milliseconds since the start of the sketching session, when recorded.
    pub timestamp_ms: Option<u32>,
}

impl ControlPoint {
    /// A point at `position` with identity rotation, full pressure and a timestamp.
    pub fn at(position: [f32; 3], timestamp_ms: u32) -> Self {
        Self {
            position,
            rotation: [0.0, 0.0, 0.0, 1.0],
            pressure: Some(1.0),
            timestamp_ms: Some(timestamp_ms),
        }
    }

    /// The position in Open Brush units (decimetres), as `f64`.
    pub fn position_dm(&self) -> DVec3 {
        DVec3::new(
            self.position[0] as f64,
            self.position[1] as f64,
            self.position[2] as f64,
        )
    }

    /// The orientation as a unit quaternion; a zero quaternion reads as identity.
    pub fn rotation(&self) -> DQuat {
        let [x, y, z, w] = self.rotation.map(|c| c as f64);
        let q = DQuat::from_xyzw(x, y, z, w);
        let len = q.length();
        if len.is_finite() && len > sculpt_core::tolerance::NORMALISABLE_LEN {
            q / len
        } else {
            DQuat::IDENTITY
        }
    }
}

/// Reads a whole `.tilt` file from its bytes.
pub fn read_tilt(bytes: &[u8]) -> Result<Tilt> {
    let container = Error::TiltContainer;
    if bytes.len() < 16 {
        return Err(container(TiltContainerError::Short(bytes.len())));
    }
    if &bytes[0..4] != TILT_MAGIC {
        let magic = [bytes[0], bytes[1], bytes[2], bytes[3]];
        return Err(container(TiltContainerError::Magic(magic)));
    }
    let header_size = u16::from_le_bytes([bytes[4], bytes[5]]) as usize;
    if header_size < 8 || header_size > bytes.len() {
        return Err(container(TiltContainerError::HeaderSize {
            header: header_size,
            len: bytes.len(),
        }));
    }
    let mut archive = zip::ZipArchive::new(Cursor::new(&bytes[header_size..])).map_err(|e| {
        container(TiltContainerError::Zip {
            what: "zip archive".into(),
            source: e,
        })
    })?;
    let sketch_bytes = read_entry(&mut archive, "data.sketch", MAX_SKETCH_BYTES)?
        .ok_or(container(TiltContainerError::NoSketch))?;
    let metadata = read_entry(&mut archive, "metadata.json", MAX_METADATA_BYTES)?
        .map(|b| String::from_utf8_lossy(&b).into_owned());
    Ok(Tilt {
        sketch: parse_sketch(&sketch_bytes)?,
        metadata,
    })
}

/// Reads one archive entry, at most `cap` bytes; `None` when it is absent.
fn read_entry(
    archive: &mut zip::ZipArchive<Cursor<&[u8]>>,
    name: &str,
    cap: u64,
) -> Result<Option<Vec<u8>>> {
    let mut file = match archive.by_name(name) {
        Ok(f) => f,
        Err(zip::result::ZipError::FileNotFound) => return Ok(None),
        Err(e) => {
            return Err(Error::TiltContainer(TiltContainerError::Zip {
                what: name.into(),
                source: e,
            }));
        }
    };
    let too_large = |size| {
        Error::TiltContainer(TiltContainerError::TooLarge {
            name: name.into(),
            size,
            cap,
        })
    };
    if file.size() > cap {
        return Err(too_large(file.size()));
    }
    let mut out = Vec::new();
    (&mut file)
        .take(cap + 1)
        .read_to_end(&mut out)
        .map_err(|e| {
            Error::TiltContainer(TiltContainerError::Io {
                what: name.into(),
                source: e,
            })
        })?;
    if out.len() as u64 > cap {
        return Err(too_large(out.len() as u64));
    }
    Ok(Some(out))
}

/// A bounds-checked little-endian reader over `data.sketch`.
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn err(&self, reason: SketchError) -> Error {
        Error::TiltSketch {
            offset: self.pos,
            stroke: None,
            point: None,
            reason: Box::new(reason),
        }
    }

    fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    fn take(&mut self, n: usize, what: &'static str) -> Result<&'a [u8]> {
        if self.remaining() < n {
            return Err(self.err(SketchError::Truncated {
                what,
                needed: n,
                left: self.remaining(),
            }));
        }
        let s = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn u32(&mut self, what: &'static str) -> Result<u32> {
        let b = self.take(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn i32(&mut self, what: &'static str) -> Result<i32> {
        Ok(self.u32(what)? as i32)
    }

    fn f32(&mut self, what: &'static str) -> Result<f32> {
        Ok(f32::from_bits(self.u32(what)?))
    }

    fn finite_f32(&mut self, what: &'static str) -> Result<f32> {
        let start = self.pos;
        let v = self.f32(what)?;
        if v.is_finite() {
            Ok(v)
        } else {
            self.pos = start;
            Err(self.err(SketchError::NotFinite { what, value: v }))
        }
    }

    /// A non-negative count whose items need at least `min_item_bytes` each.
    fn count(&mut self, what: &'static str, min_item_bytes: usize) -> Result<usize> {
        let start = self.pos;
        let n = self.i32(what)?;
        let fits = usize::try_from(n)
            .ok()
            .filter(|&n| n.saturating_mul(min_item_bytes) <= self.remaining());
        match fits {
            Some(n) => Ok(n),
            None => {
                let left = self.remaining();
                self.pos = start;
                Err(self.err(SketchError::ImpossibleCount {
                    what,
                    count: n,
                    left,
                    per_item: min_item_bytes,
                }))
            }
        }
    }
}

/// Decodes the `data.sketch` stream of a `.tilt` archive.
pub fn parse_sketch(bytes: &[u8]) -> Result<Sketch> {
    let mut r = Reader { bytes, pos: 0 };
    let sentinel = r.u32("sentinel")?;
    if sentinel != SKETCH_SENTINEL {
        r.pos = 0;
        return Err(r.err(SketchError::Sentinel {
            found: sentinel,
            expected: SKETCH_SENTINEL,
        }));
    }
    let version = r.u32("version")?;
    let _reserved = r.u32("reserved")?;
    let extra = r.count("additional header size", 1)?;
    r.take(extra, "additional header")?;
    let stroke_count = r.count("stroke count", MIN_STROKE_BYTES)?;
    let mut strokes = Vec::with_capacity(stroke_count);
    for index in 0..stroke_count {
        strokes.push(parse_stroke(&mut r).map_err(|mut e| {
            if let Error::TiltSketch { stroke, .. } = &mut e {
                *stroke = Some(index);
            }
            e
        })?);
    }
    if r.remaining() != 0 {
        return Err(r.err(SketchError::Trailing(r.remaining())));
    }
    Ok(Sketch { version, strokes })
}

fn parse_stroke(r: &mut Reader<'_>) -> Result<TiltStroke> {
    let brush_index = r.i32("brush index")?;
    let mut color = [0.0; 4];
    for c in &mut color {
        *c = r.f32("colour")?;
    }
    let size = r.f32("brush size")?;
    let stroke_mask = r.u32("stroke-extension mask")?;
    let point_mask = r.u32("control-point-extension mask")?;
    let mut stroke = TiltStroke {
        brush_index,
        color,
        size,
        flags: None,
        scale: None,
        group: None,
        seed: None,
        points: Vec::new(),
    };
    for bit in (0..32).map(|b| 1u32 << b).filter(|b| stroke_mask & b != 0) {
        match bit {
            STROKE_EXT_FLAGS => stroke.flags = Some(r.u32("stroke flags")?),
            STROKE_EXT_SCALE => stroke.scale = Some(r.f32("stroke scale")?),
            STROKE_EXT_GROUP => stroke.group = Some(r.u32("stroke group")?),
            STROKE_EXT_SEED => stroke.seed = Some(r.u32("stroke seed")?),
            b if b & 0xffff != 0 => {
                r.u32("unknown stroke extension")?;
            }
            _ => {
                let n = r.count("unknown stroke extension size", 1)?;
                r.take(n, "unknown stroke extension")?;
            }
        }
    }
    let point_bytes = BASE_POINT_BYTES + 4 * point_mask.count_ones() as usize;
    let point_count = r.count("control-point count", point_bytes)?;
    let mut points = Vec::with_capacity(point_count);
    for index in 0..point_count {
        points.push(parse_point(r, point_mask).map_err(|mut e| {
            if let Error::TiltSketch { point, .. } = &mut e {
                *point = Some(index);
            }
            e
        })?);
    }
    stroke.points = points;
    Ok(stroke)
}

fn parse_point(r: &mut Reader<'_>, mask: u32) -> Result<ControlPoint> {
    let mut position = [0.0; 3];
    for c in &mut position {
        *c = r.finite_f32("position")?;
    }
    let mut rotation = [0.0; 4];
    for c in &mut rotation {
        *c = r.finite_f32("rotation")?;
    }
    let mut point = ControlPoint {
        position,
        rotation,
        pressure: None,
        timestamp_ms: None,
    };
    for bit in (0..32).map(|b| 1u32 << b).filter(|b| mask & b != 0) {
        match bit {
            POINT_EXT_PRESSURE => point.pressure = Some(r.finite_f32("pressure")?),
            POINT_EXT_TIMESTAMP => point.timestamp_ms = Some(r.u32("timestamp")?),
            _ => {
                r.u32("unknown control-point extension")?;
            }
        }
    }
    Ok(point)
}

/// Encodes a sketch as `data.sketch` bytes (the inverse of [`parse_sketch`]).
///
/// Each stroke's control-point mask comes from its first point
/// ([`TiltStroke::point_extension_mask`]); a later point missing a field writes 0 there.
pub fn encode_sketch(sketch: &Sketch) -> Vec<u8> {
    let mut out = Vec::new();
    let put = |out: &mut Vec<u8>, v: u32| out.extend_from_slice(&v.to_le_bytes());
    put(&mut out, SKETCH_SENTINEL);
    put(&mut out, sketch.version);
    put(&mut out, 0);
    put(&mut out, 0);
    put(&mut out, sketch.strokes.len() as u32);
    for s in &sketch.strokes {
        put(&mut out, s.brush_index as u32);
        for c in s.color {
            put(&mut out, c.to_bits());
        }
        put(&mut out, s.size.to_bits());
        put(&mut out, s.stroke_extension_mask());
        let point_mask = s.point_extension_mask();
        put(&mut out, point_mask);
        for v in [s.flags, s.scale.map(f32::to_bits), s.group, s.seed]
            .into_iter()
            .flatten()
        {
            put(&mut out, v);
        }
        put(&mut out, s.points.len() as u32);
        for p in &s.points {
            for c in p.position.iter().chain(&p.rotation) {
                put(&mut out, c.to_bits());
            }
            if point_mask & POINT_EXT_PRESSURE != 0 {
                put(&mut out, p.pressure.unwrap_or(0.0).to_bits());
            }
            if point_mask & POINT_EXT_TIMESTAMP != 0 {
                put(&mut out, p.timestamp_ms.unwrap_or(0));
            }
        }
    }
    out
}

/// Writes a complete `.tilt` file: header, then a stored (uncompressed) zip holding
/// `data.sketch` and, when given, `metadata.json`.
pub fn write_tilt(sketch: &Sketch, metadata: Option<&str>) -> Result<Vec<u8>> {
    let zip_err = |e| {
        Error::TiltContainer(TiltContainerError::Zip {
            what: "writing zip".into(),
            source: e,
        })
    };
    let io_err = |e| {
        Error::TiltContainer(TiltContainerError::Io {
            what: "writing zip".into(),
            source: e,
        })
    };
    let mut out = Vec::with_capacity(16);
    out.extend_from_slice(TILT_MAGIC);
    out.extend_from_slice(&16u16.to_le_bytes());
    out.extend_from_slice(&1u16.to_le_bytes());
    out.extend_from_slice(&[0; 8]);
    let options = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Stored)
        .last_modified_time(zip::DateTime::default());
    let mut writer = zip::ZipWriter::new(Cursor::new(Vec::new()));
    writer.start_file("data.sketch", options).map_err(zip_err)?;
    writer.write_all(&encode_sketch(sketch)).map_err(io_err)?;
    if let Some(meta) = metadata {
        writer
            .start_file("metadata.json", options)
            .map_err(zip_err)?;
        writer.write_all(meta.as_bytes()).map_err(io_err)?;
    }
    out.extend_from_slice(&writer.finish().map_err(zip_err)?.into_inner());
    Ok(out)
}

impl Sketch {
    /// The number of control points over all strokes.
    pub fn point_count(&self) -> usize {
        self.strokes.iter().map(|s| s.points.len()).sum()
    }

    /// The smallest and largest timestamp (ms) over all points, when any has one.
    pub fn time_span_ms(&self) -> Option<(u32, u32)> {
        let mut it = self
            .strokes
            .iter()
            .flat_map(|s| &s.points)
            .filter_map(|p| p.timestamp_ms);
        let first = it.next()?;
        Some(it.fold((first, first), |(lo, hi), t| (lo.min(t), hi.max(t))))
    }

    /// The axis-aligned bounds of all positions (Open Brush units), when any point exists.
    pub fn bounds_dm(&self) -> Option<(DVec3, DVec3)> {
        let mut it = self
            .strokes
            .iter()
            .flat_map(|s| &s.points)
            .map(ControlPoint::position_dm);
        let first = it.next()?;
        Some(it.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn sample() -> Sketch {
        Sketch {
            version: 5,
            strokes: vec![
                TiltStroke {
                    flags: Some(0),
                    seed: Some(42),
                    points: vec![
                        ControlPoint::at([0.0, 1.0, 2.0], 100),
                        ControlPoint::at([0.1, 1.0, 2.0], 111),
                    ],
                    ..TiltStroke::default()
                },
                TiltStroke {
                    scale: Some(1.5),
                    group: Some(7),
                    points: vec![ControlPoint {
                        position: [3.0, 4.0, 5.0],
                        rotation: [0.0, 0.70710677, 0.0, 0.70710677],
                        pressure: Some(0.25),
                        timestamp_ms: Some(500),
                    }],
                    ..TiltStroke::default()
                },
            ],
        }
    }

    #[test]
    fn round_trip_through_a_tilt_file() {
        let bytes = write_tilt(&sample(), Some("{\"a\":1}")).unwrap();
        let back = read_tilt(&bytes).unwrap();
        assert_eq!(back.sketch, sample());
        assert_eq!(back.metadata.as_deref(), Some("{\"a\":1}"));
        assert_eq!(back.sketch.point_count(), 3);
        assert_eq!(back.sketch.time_span_ms(), Some((100, 500)));
    }

    #[test]
    fn rejects_bad_magic_short_files_and_missing_entries() {
        assert!(matches!(read_tilt(b"tilT"), Err(Error::TiltContainer(_))));
        let mut bytes = write_tilt(&sample(), None).unwrap();
        bytes[0] = b'x';
        let e = read_tilt(&bytes).unwrap_err().to_string();
        assert!(e.contains("magic"), "{e}");
        // A valid zip without data.sketch.
        let mut w = zip::ZipWriter::new(Cursor::new(Vec::new()));
        w.start_file("metadata.json", zip::write::SimpleFileOptions::default())
            .unwrap();
        let mut file = b"tilT\x10\x00\x01\x00\0\0\0\0\0\0\0\0".to_vec();
        file.extend(w.finish().unwrap().into_inner());
        let e = read_tilt(&file).unwrap_err().to_string();
        assert!(e.contains("no data.sketch"), "{e}");
    }

    #[test]
    fn truncation_anywhere_is_a_clear_error() {
        let bytes = encode_sketch(&sample());
        for cut in 0..bytes.len() {
            let e = parse_sketch(&bytes[..cut]).unwrap_err();
            assert!(matches!(e, Error::TiltSketch { .. }), "cut {cut}: {e}");
        }
        let e = parse_sketch(&bytes[..bytes.len() - 2])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("stroke 1: control-point count 1 is impossible"),
            "{e}"
        );
    }

    #[test]
    fn huge_counts_are_refused_before_allocating() {
        let mut bytes = encode_sketch(&sample());
        // Stroke count at byte 16.
        bytes[16..20].copy_from_slice(&i32::MAX.to_le_bytes());
        let e = parse_sketch(&bytes).unwrap_err().to_string();
        assert!(e.contains("stroke count 2147483647 is impossible"), "{e}");
        bytes[16..20].copy_from_slice(&(-1i32).to_le_bytes());
        assert!(parse_sketch(&bytes).is_err());
    }

    #[test]
    fn non_finite_positions_are_rejected() {
        let mut s = sample();
        s.strokes[0].points[1].position[2] = f32::NAN;
        let e = parse_sketch(&encode_sketch(&s)).unwrap_err();
        assert!(
            matches!(
                &e,
                Error::TiltSketch { stroke: Some(0), point: Some(1), reason, .. }
                    if matches!(**reason, SketchError::NotFinite { what: "position", value } if value.is_nan())
            ),
            "{e:?}"
        );
        let e = e.to_string();
        assert!(
            e.contains(", stroke 0, point 1: position is not finite"),
            "{e}"
        );
    }

    #[test]
    fn unknown_extensions_are_skipped() {
        let mut bytes = encode_sketch(&Sketch {
            version: 5,
            strokes: vec![],
        });
        bytes[16..20].copy_from_slice(&1u32.to_le_bytes());
        let mut put = |v: u32| bytes.extend_from_slice(&v.to_le_bytes());
        put(3); // brush
        for _ in 0..5 {
            put(1f32.to_bits());
        }
        put((1 << 5) | (1 << 20)); // unknown one-word and sized stroke extensions
        put(POINT_EXT_TIMESTAMP | (1 << 4)); // timestamp and one unknown word
        put(9); // bit 5 word
        put(2); // bit 20 size
        bytes.extend_from_slice(&[0xaa, 0xbb]);
        let mut put = |v: u32| bytes.extend_from_slice(&v.to_le_bytes());
        put(1); // one point
        for c in [1.0f32, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0] {
            put(c.to_bits());
        }
        put(77); // timestamp
        put(5); // unknown
        let s = parse_sketch(&bytes).unwrap();
        assert_eq!(s.strokes[0].brush_index, 3);
        assert_eq!(s.strokes[0].points[0].timestamp_ms, Some(77));
        assert_eq!(s.strokes[0].points[0].pressure, None);
    }

    fn arb_point() -> impl Strategy<Value = ControlPoint> {
        (
            prop::array::uniform3(-1e4f32..1e4),
            prop::array::uniform4(-1f32..1.0),
            0f32..1.0,
            any::<u32>(),
        )
            .prop_map(|(position, rotation, p, t)| ControlPoint {
                position,
                rotation,
                pressure: Some(p),
                timestamp_ms: Some(t),
            })
    }

    fn arb_sketch() -> impl Strategy<Value = Sketch> {
        prop::collection::vec(
            (
                any::<i32>(),
                prop::option::of(any::<u32>()),
                prop::option::of(any::<u32>()),
                prop::collection::vec(arb_point(), 0..6),
            )
                .prop_map(|(brush_index, flags, seed, points)| TiltStroke {
                    brush_index,
                    flags,
                    seed,
                    points,
                    ..TiltStroke::default()
                }),
            0..5,
        )
        .prop_map(|strokes| Sketch {
            version: 5,
            strokes,
        })
    }

    proptest! {
        #[test]
        fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..512)) {
            let _ = parse_sketch(&bytes);
            let mut file = b"tilT\x10\x00\x01\x00\0\0\0\0\0\0\0\0".to_vec();
            file.extend_from_slice(&bytes);
            let _ = read_tilt(&file);
        }

        #[test]
        fn sketches_round_trip(sketch in arb_sketch()) {
            let back = read_tilt(&write_tilt(&sketch, None).unwrap()).unwrap();
            prop_assert_eq!(back.sketch, sketch);
        }

        #[test]
        fn mutated_sketches_never_panic(
            sketch in arb_sketch(),
            flips in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
            cut in any::<prop::sample::Index>(),
        ) {
            let mut bytes = encode_sketch(&sketch);
            for (i, v) in flips {
                let i = i.index(bytes.len());
                bytes[i] = v;
            }
            let keep = cut.index(bytes.len() + 1);
            let _ = parse_sketch(&bytes[..keep]);
            let file = write_tilt(&sketch, None).unwrap();
            let mut broken = file.clone();
            let j = cut.index(broken.len());
            broken[j] ^= 0x5a;
            let _ = read_tilt(&broken);
            let _ = read_tilt(&file[..cut.index(file.len() + 1)]);
        }
    }
}
