//! Point readers from bytes: `.xyz`, `.pwn`, PLY (ASCII and binary, with or without
//! normals) and the vertices of OBJ and OFF meshes. No I/O: the caller reads the file.
//!
//! ```
//! use sculpt_core::reconstruct::read::{read_points, PointFormat};
//! let cloud = read_points(b"0 0 0\n1 0 0 # comment\n\n0 1 0\n", PointFormat::Xyz)?;
//! assert_eq!(cloud.points.len(), 3);
//! assert!(cloud.normals.is_none());
//! # Ok::<(), sculpt_core::reconstruct::ReconstructError>(())
//! ```
//!
//! Rules shared by the text formats: `#` starts a comment, blank lines are skipped,
//! fields are separated by whitespace. Every coordinate must be finite; a NaN or an
//! infinity is an error naming its line (a scan with holes has no NaN rows; a NaN row is
//! a broken export). PLY's own reader is here rather than a crate: `ply-rs`, the
//! common one, has had no release since 2019, and the subset needed (one `vertex`
//! element, scalar properties, list properties of other elements skipped) is small.

use glam::DVec3;

use super::error::ReconstructError;
use crate::error::Excerpt;

/// Points, with a normal per point when the file had them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PointCloud {
    /// Positions, in the file's units (metres for our scans).
    pub points: Vec<DVec3>,
    /// One normal per point (unit length not required), when the file had them.
    pub normals: Option<Vec<DVec3>>,
}

/// The point formats, chosen from a file extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PointFormat {
    /// `x y z` per line (or `x y z nx ny nz` on every line).
    Xyz,
    /// `x y z nx ny nz` per line (CGAL's points with normals); an optional first line
    /// with the point count.
    Pwn,
    /// PLY, ASCII or binary (either byte order); the `vertex` element's `x y z` and,
    /// when present, `nx ny nz`.
    Ply,
    /// Wavefront OBJ: the `v` lines.
    Obj,
    /// OFF (and `NOFF`): the vertices; normals when the header is `NOFF`.
    Off,
}

impl PointFormat {
    /// The format for a file extension (case-insensitive, without the dot).
    pub fn from_extension(ext: &str) -> Result<Self, ReconstructError> {
        match ext.to_ascii_lowercase().as_str() {
            "xyz" | "txt" => Ok(Self::Xyz),
            "pwn" => Ok(Self::Pwn),
            "ply" => Ok(Self::Ply),
            "obj" => Ok(Self::Obj),
            "off" => Ok(Self::Off),
            other => Err(ReconstructError::UnknownFormat(Excerpt::new(other))),
        }
    }
}

/// Reads the points of `bytes` in `format`. Never panics; a file without points is
/// [`ReconstructError::NoPoints`].
pub fn read_points(bytes: &[u8], format: PointFormat) -> Result<PointCloud, ReconstructError> {
    let cloud = match format {
        PointFormat::Xyz => read_columns(bytes, false)?,
        PointFormat::Pwn => read_columns(bytes, true)?,
        PointFormat::Ply => read_ply(bytes)?,
        PointFormat::Obj => read_obj(bytes)?,
        PointFormat::Off => read_off(bytes)?,
    };
    if cloud.points.is_empty() {
        return Err(ReconstructError::NoPoints);
    }
    Ok(cloud)
}

/// The lines of `bytes` with their 1-based numbers, comments cut and blank lines
/// skipped, split into fields.
fn text_lines(
    bytes: &[u8],
) -> impl Iterator<Item = Result<(usize, Vec<&str>), ReconstructError>> + '_ {
    bytes
        .split(|&b| b == b'\n')
        .enumerate()
        .filter_map(|(i, raw)| {
            let line = i + 1;
            let text = match std::str::from_utf8(raw) {
                Ok(t) => t,
                Err(_) => return Some(Err(ReconstructError::NotText { line })),
            };
            let text = text.split('#').next().unwrap_or("");
            let fields: Vec<&str> = text.split_whitespace().collect();
            if fields.is_empty() {
                None
            } else {
                Some(Ok((line, fields)))
            }
        })
}

fn number(line: usize, text: &str) -> Result<f64, ReconstructError> {
    text.parse::<f64>()
        .map_err(|cause| ReconstructError::Number {
            line,
            text: Excerpt::new(text),
            cause,
        })
}

fn vec3(line: usize, fields: &[&str]) -> Result<DVec3, ReconstructError> {
    let v = DVec3::new(
        number(line, fields[0])?,
        number(line, fields[1])?,
        number(line, fields[2])?,
    );
    if v.is_finite() {
        Ok(v)
    } else {
        Err(ReconstructError::NotFinite { line })
    }
}

/// `.xyz` (`with_normals == false`: 3 columns, or 6 on every line) and `.pwn` (6
/// columns, optional count line first).
fn read_columns(bytes: &[u8], with_normals: bool) -> Result<PointCloud, ReconstructError> {
    let mut points = Vec::new();
    let mut normals = Vec::new();
    let mut width: Option<usize> = None;
    for (k, item) in text_lines(bytes).enumerate() {
        let (line, fields) = item?;
        if with_normals && k == 0 && fields.len() == 1 && fields[0].parse::<usize>().is_ok() {
            continue; // the point count some writers put first
        }
        let expected = if with_normals { "6" } else { "3 or 6" };
        let ok = matches!((with_normals, fields.len()), (true, 6) | (false, 3 | 6));
        if !ok || width.is_some_and(|w| w != fields.len()) {
            return Err(ReconstructError::FieldCount {
                line,
                got: fields.len(),
                expected,
            });
        }
        width = Some(fields.len());
        points.push(vec3(line, &fields[..3])?);
        if fields.len() == 6 {
            normals.push(vec3(line, &fields[3..6])?);
        }
    }
    let normals = (!normals.is_empty()).then_some(normals);
    Ok(PointCloud { points, normals })
}

fn read_obj(bytes: &[u8]) -> Result<PointCloud, ReconstructError> {
    let mut points = Vec::new();
    for item in text_lines(bytes) {
        let (line, fields) = item?;
        if fields[0] != "v" {
            continue;
        }
        if fields.len() < 4 {
            return Err(ReconstructError::FieldCount {
                line,
                got: fields.len() - 1,
                expected: "3 or more",
            });
        }
        points.push(vec3(line, &fields[1..4])?);
    }
    Ok(PointCloud {
        points,
        normals: None,
    })
}

fn read_off(bytes: &[u8]) -> Result<PointCloud, ReconstructError> {
    let mut lines = text_lines(bytes);
    let header = |line: usize, reason: &'static str| ReconstructError::Header { line, reason };
    let (line, first) = lines.next().ok_or(ReconstructError::NoPoints)??;
    let keyword = first[0];
    let with_normals = match keyword {
        "OFF" | "COFF" => false,
        "NOFF" | "CNOFF" => true,
        _ => return Err(header(line, "expected OFF, COFF or NOFF")),
    };
    // The counts may follow the keyword on the same line.
    let counts: Vec<&str> = if first.len() > 1 {
        first[1..].to_vec()
    } else {
        let (_, c) = lines
            .next()
            .ok_or_else(|| header(line + 1, "missing vertex and face counts"))??;
        c
    };
    let count = counts
        .first()
        .and_then(|c| c.parse::<usize>().ok())
        .ok_or_else(|| header(line, "the vertex count is not a whole number"))?;
    let mut points = Vec::with_capacity(count.min(1 << 24));
    let mut normals = Vec::new();
    for index in 0..count {
        let (line, fields) = lines.next().ok_or_else(|| ReconstructError::Truncated {
            what: "vertex".into(),
            index,
            count,
        })??;
        let need = if with_normals { 6 } else { 3 };
        if fields.len() < need {
            return Err(ReconstructError::FieldCount {
                line,
                got: fields.len(),
                expected: if with_normals { "6" } else { "3" },
            });
        }
        points.push(vec3(line, &fields[..3])?);
        if with_normals {
            normals.push(vec3(line, &fields[3..6])?);
        }
    }
    let normals = with_normals.then_some(normals);
    Ok(PointCloud { points, normals })
}

/// A PLY scalar type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    /// Decodes one value from exactly `self.size()` bytes.
    fn decode(self, b: &[u8], big_endian: bool) -> f64 {
        macro_rules! num {
            ($t:ty, $n:expr) => {{
                let mut a = [0u8; $n];
                a.copy_from_slice(&b[..$n]);
                if big_endian {
                    <$t>::from_be_bytes(a) as f64
                } else {
                    <$t>::from_le_bytes(a) as f64
                }
            }};
        }
        match self {
            Self::I8 => num!(i8, 1),
            Self::U8 => num!(u8, 1),
            Self::I16 => num!(i16, 2),
            Self::U16 => num!(u16, 2),
            Self::I32 => num!(i32, 4),
            Self::U32 => num!(u32, 4),
            Self::F32 => num!(f32, 4),
            Self::F64 => num!(f64, 8),
        }
    }
}

#[derive(Debug, Clone)]
enum Property {
    Scalar(String, Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    Ascii,
    Little,
    Big,
}

/// Parses the PLY header; returns the encoding, the elements and the byte offset of the
/// body.
fn ply_header(bytes: &[u8]) -> Result<(Encoding, Vec<Element>, usize), ReconstructError> {
    let header = |line: usize, reason: &'static str| ReconstructError::Header { line, reason };
    let mut offset = 0;
    let mut line = 0;
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let rest = &bytes[offset..];
        let end = rest
            .iter()
            .position(|&b| b == b'\n')
            .ok_or_else(|| header(line + 1, "the header has no end_header line"))?;
        line += 1;
        offset += end + 1;
        let text = std::str::from_utf8(&rest[..end])
            .map_err(|_| ReconstructError::NotText { line })?
            .trim_end_matches('\r');
        let fields: Vec<&str> = text.split_whitespace().collect();
        if line == 1 {
            if fields != ["ply"] {
                return Err(header(line, "a PLY file starts with the line \"ply\""));
            }
            continue;
        }
        match fields.as_slice() {
            [] => {}
            ["comment", ..] | ["obj_info", ..] => {}
            ["format", kind, _version] => {
                encoding = Some(match *kind {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::Little,
                    "binary_big_endian" => Encoding::Big,
                    _ => return Err(header(line, "unknown format")),
                });
            }
            ["element", name, count] => elements.push(Element {
                name: name.to_string(),
                count: count
                    .parse()
                    .map_err(|_| header(line, "the element count is not a whole number"))?,
                properties: Vec::new(),
            }),
            ["property", "list", count, item, _name] => {
                let (Some(count), Some(item)) = (Scalar::parse(count), Scalar::parse(item)) else {
                    return Err(header(line, "unknown list property type"));
                };
                if matches!(count, Scalar::F32 | Scalar::F64) {
                    return Err(header(line, "a list count must be an integer type"));
                }
                elements
                    .last_mut()
                    .ok_or_else(|| header(line, "property before any element"))?
                    .properties
                    .push(Property::List { count, item });
            }
            ["property", kind, name] => {
                let kind =
                    Scalar::parse(kind).ok_or_else(|| header(line, "unknown property type"))?;
                elements
                    .last_mut()
                    .ok_or_else(|| header(line, "property before any element"))?
                    .properties
                    .push(Property::Scalar(name.to_string(), kind));
            }
            ["end_header"] => break,
            _ => return Err(header(line, "unknown header line")),
        }
    }
    let encoding = encoding.ok_or_else(|| header(line, "no format line"))?;
    Ok((encoding, elements, offset))
}

/// Where the coordinates sit among an element's scalar properties.
fn vertex_slots(element: &Element) -> Result<([usize; 3], Option<[usize; 3]>), ReconstructError> {
    let find = |name: &str| {
        element
            .properties
            .iter()
            .position(|p| matches!(p, Property::Scalar(n, _) if n == name))
    };
    let (Some(x), Some(y), Some(z)) = (find("x"), find("y"), find("z")) else {
        return Err(ReconstructError::Header {
            line: 0,
            reason: "the vertex element has no x, y, z properties",
        });
    };
    let normals = match (find("nx"), find("ny"), find("nz")) {
        (Some(a), Some(b), Some(c)) => Some([a, b, c]),
        _ => None,
    };
    Ok(([x, y, z], normals))
}

fn read_ply(bytes: &[u8]) -> Result<PointCloud, ReconstructError> {
    let (encoding, elements, body) = ply_header(bytes)?;
    let mut points = Vec::new();
    let mut normals = Vec::new();
    let mut has_normals = false;
    let mut ascii_lines = text_lines(&bytes[body..]);
    let mut at = body;
    let mut values: Vec<f64> = Vec::new();
    for element in &elements {
        let is_vertex = element.name == "vertex";
        let slots = if is_vertex {
            Some(vertex_slots(element)?)
        } else {
            None
        };
        has_normals |= slots.is_some_and(|s| s.1.is_some());
        if is_vertex {
            points.reserve(element.count.min(1 << 24));
        }
        for index in 0..element.count {
            let truncated = || ReconstructError::Truncated {
                what: element.name.clone(),
                index,
                count: element.count,
            };
            values.clear();
            let line;
            if encoding == Encoding::Ascii {
                let (l, fields) = ascii_lines.next().ok_or_else(truncated)??;
                line = l;
                let mut f = fields.iter();
                for p in &element.properties {
                    match p {
                        Property::Scalar(..) => {
                            values.push(number(line, f.next().ok_or_else(truncated)?)?);
                        }
                        Property::List { .. } => {
                            let n = number(line, f.next().ok_or_else(truncated)?)?;
                            if !(0.0..=f64::from(u32::MAX)).contains(&n) {
                                return Err(truncated());
                            }
                            for _ in 0..n as usize {
                                f.next().ok_or_else(truncated)?;
                            }
                            values.push(n);
                        }
                    }
                }
            } else {
                line = index + 1;
                let big = encoding == Encoding::Big;
                for p in &element.properties {
                    match *p {
                        Property::Scalar(_, s) => {
                            let b = bytes.get(at..at + s.size()).ok_or_else(truncated)?;
                            values.push(s.decode(b, big));
                            at += s.size();
                        }
                        Property::List { count, item } => {
                            let b = bytes.get(at..at + count.size()).ok_or_else(truncated)?;
                            let n = count.decode(b, big);
                            at += count.size();
                            if n < 0.0 {
                                return Err(truncated());
                            }
                            let skip = (n as usize).checked_mul(item.size());
                            let end = skip.and_then(|s| at.checked_add(s));
                            match end {
                                Some(e) if e <= bytes.len() => at = e,
                                _ => return Err(truncated()),
                            }
                            values.push(n);
                        }
                    }
                }
            }
            if let Some((xyz, n)) = slots {
                let v = DVec3::new(values[xyz[0]], values[xyz[1]], values[xyz[2]]);
                if !v.is_finite() {
                    return Err(ReconstructError::NotFinite { line });
                }
                points.push(v);
                if let Some(n) = n {
                    let v = DVec3::new(values[n[0]], values[n[1]], values[n[2]]);
                    if !v.is_finite() {
                        return Err(ReconstructError::NotFinite { line });
                    }
                    normals.push(v);
                }
            }
        }
    }
    let normals = has_normals.then_some(normals);
    Ok(PointCloud { points, normals })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn ply_binary(big: bool, with_normals: bool) -> Vec<u8> {
        let mut out = format!(
            "ply\nformat {} 1.0\ncomment made by a test\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n{}element face 1\nproperty list uchar int vertex_indices\nend_header\n",
            if big { "binary_big_endian" } else { "binary_little_endian" },
            if with_normals { "property float nx\nproperty float ny\nproperty float nz\n" } else { "" }
        )
        .into_bytes();
        let mut put = |v: f32| {
            out.extend(if big {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            });
        };
        for p in [[1.0f32, 2.0, 3.0], [4.0, 5.0, 6.0]] {
            p.iter().for_each(|&c| put(c));
            if with_normals {
                [0.0f32, 0.0, 1.0].iter().for_each(|&c| put(c));
            }
        }
        out.push(3);
        for i in [0i32, 1, 1] {
            out.extend(if big {
                i.to_be_bytes()
            } else {
                i.to_le_bytes()
            });
        }
        out
    }

    #[test]
    fn xyz_reads_points_and_skips_comments() {
        let c = read_points(b"# scan\n0 0 0\n\n1 2 3\r\n", PointFormat::Xyz).unwrap();
        assert_eq!(c.points, vec![DVec3::ZERO, DVec3::new(1.0, 2.0, 3.0)]);
        assert!(c.normals.is_none());
    }

    #[test]
    fn xyz_with_six_columns_has_normals() {
        let c = read_points(b"0 0 0 0 0 1\n1 0 0 0 0 1\n", PointFormat::Xyz).unwrap();
        assert_eq!(c.normals.unwrap(), vec![DVec3::Z; 2]);
    }

    #[test]
    fn pwn_reads_normals_and_skips_a_count_line() {
        let c = read_points(b"2\n0 0 0 0 1 0\n1 1 1 1 0 0\n", PointFormat::Pwn).unwrap();
        assert_eq!(c.points.len(), 2);
        assert_eq!(c.normals.unwrap()[1], DVec3::X);
    }

    #[test]
    fn nan_line_is_an_error_naming_the_line() {
        let e = read_points(b"0 0 0\n1 nan 0\n", PointFormat::Xyz).unwrap_err();
        assert_eq!(e, ReconstructError::NotFinite { line: 2 });
        assert!(e.to_string().contains("line 2"));
    }

    #[test]
    fn bad_number_names_the_line_and_field() {
        let e = read_points(b"0 0 0\n1 x 0\n", PointFormat::Xyz).unwrap_err();
        assert!(
            matches!(e, ReconstructError::Number { line: 2, ref text, .. } if text.prefix == "x")
        );
    }

    #[test]
    fn ragged_columns_are_an_error() {
        let e = read_points(b"0 0 0\n1 1 1 0 0 1\n", PointFormat::Xyz).unwrap_err();
        assert!(matches!(
            e,
            ReconstructError::FieldCount {
                line: 2,
                got: 6,
                ..
            }
        ));
        let e = read_points(b"0 0 0\n", PointFormat::Pwn).unwrap_err();
        assert!(matches!(
            e,
            ReconstructError::FieldCount {
                line: 1,
                got: 3,
                ..
            }
        ));
    }

    #[test]
    fn empty_file_has_no_points() {
        assert_eq!(
            read_points(b"# nothing\n", PointFormat::Xyz),
            Err(ReconstructError::NoPoints)
        );
    }

    #[test]
    fn obj_reads_vertices_only() {
        let obj = b"o cube\nv 0 0 0\nv 1 0 0 1.0\nvn 0 0 1\nvt 0 0\nv 0 1 0\nf 1 2 3\n";
        let c = read_points(obj, PointFormat::Obj).unwrap();
        assert_eq!(c.points.len(), 3);
        assert_eq!(c.points[1], DVec3::X);
    }

    #[test]
    fn off_reads_vertices_and_noff_normals() {
        let off = b"OFF\n# c\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        assert_eq!(read_points(off, PointFormat::Off).unwrap().points.len(), 3);
        let noff = b"NOFF 1 0 0\n1 2 3 0 0 1\n";
        let c = read_points(noff, PointFormat::Off).unwrap();
        assert_eq!(c.normals.unwrap(), vec![DVec3::Z]);
        let short = b"OFF\n3 0 0\n0 0 0\n";
        assert!(matches!(
            read_points(short, PointFormat::Off),
            Err(ReconstructError::Truncated {
                index: 1,
                count: 3,
                ..
            })
        ));
    }

    #[test]
    fn ply_ascii_with_faces_before_and_after() {
        let ply = b"ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty double y\nproperty double z\nproperty uchar red\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n1 2 3 255\n4 5 6 0\n3 0 1 1\n";
        let c = read_points(ply, PointFormat::Ply).unwrap();
        assert_eq!(
            c.points,
            vec![DVec3::new(1.0, 2.0, 3.0), DVec3::new(4.0, 5.0, 6.0)]
        );
        assert!(c.normals.is_none());
    }

    #[test]
    fn ply_binary_both_byte_orders_with_and_without_normals() {
        for big in [false, true] {
            for with_normals in [false, true] {
                let c = read_points(&ply_binary(big, with_normals), PointFormat::Ply).unwrap();
                assert_eq!(c.points[1], DVec3::new(4.0, 5.0, 6.0), "big {big}");
                assert_eq!(c.normals.is_some(), with_normals);
            }
        }
    }

    #[test]
    fn ply_truncated_body_is_an_error() {
        let mut b = ply_binary(false, true);
        b.truncate(b.len() - 20);
        assert!(matches!(
            read_points(&b, PointFormat::Ply),
            Err(ReconstructError::Truncated { .. })
        ));
    }

    #[test]
    fn ply_header_errors_name_the_line() {
        let e = read_points(
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty quux x\nend_header\n",
            PointFormat::Ply,
        )
        .unwrap_err();
        assert!(matches!(e, ReconstructError::Header { line: 4, .. }));
        let e = read_points(b"plx\n", PointFormat::Ply).unwrap_err();
        assert!(matches!(e, ReconstructError::Header { line: 1, .. }));
    }

    #[test]
    fn extensions_choose_formats() {
        assert_eq!(PointFormat::from_extension("PLY"), Ok(PointFormat::Ply));
        assert!(PointFormat::from_extension("stl").is_err());
    }

    /// Mostly valid files with some bytes changed: no reader panics, some inputs are
    /// accepted and some rejected.
    #[test]
    fn no_input_panics() {
        use std::cell::Cell;
        let accepted = Cell::new(0usize);
        let rejected = Cell::new(0usize);
        let formats = [
            PointFormat::Xyz,
            PointFormat::Pwn,
            PointFormat::Ply,
            PointFormat::Obj,
            PointFormat::Off,
        ];
        let seeds: Vec<(Vec<u8>, usize)> = vec![
            (b"0 0 0\n1 2 3\n4 5 6\n".to_vec(), 0),
            (b"3\n0 0 0 0 0 1\n1 2 3 0 1 0\n".to_vec(), 1),
            (ply_binary(false, true), 2),
            (ply_binary(true, false), 2),
            (b"v 0 0 0\nv 1 1 1\nf 1 2 1\n".to_vec(), 3),
            (b"OFF\n2 0 0\n0 0 0\n1 1 1\n".to_vec(), 4),
        ];
        let config = ProptestConfig {
            cases: 512,
            ..ProptestConfig::default()
        };
        proptest!(config, |(seed in 0..seeds.len(), edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..4), cut in any::<prop::sample::Index>(), truncate in any::<bool>(), other in prop::option::weighted(0.2, 0..formats.len()))| {
            let (mut b, own) = seeds[seed].clone();
            let f = other.unwrap_or(own);
            for (i, v) in &edits {
                let i = i.index(b.len());
                b[i] = *v;
            }
            if truncate {
                b.truncate(cut.index(b.len() + 1));
            }
            match read_points(&b, formats[f]) {
                Ok(c) => {
                    prop_assert!(!c.points.is_empty());
                    prop_assert!(c.points.iter().all(|p| p.is_finite()));
                    if let Some(n) = &c.normals {
                        prop_assert_eq!(n.len(), c.points.len());
                    }
                    accepted.set(accepted.get() + 1);
                }
                Err(e) => {
                    prop_assert!(!e.to_string().is_empty());
                    rejected.set(rejected.get() + 1);
                }
            }
        });
        assert!(accepted.get() > 20, "accepted {}", accepted.get());
        assert!(rejected.get() > 20, "rejected {}", rejected.get());
    }
}
