//! Legacy VTK `STRUCTURED_GRID` files, bytes in and bytes out (the curvilinear grids
//! of Park 2005, sec. 3.2 and 5.1).
//!
//! ```text
//! # vtk DataFile Version 3.0
//! any title
//! ASCII                      (or BINARY: big-endian numbers after each header line)
//! DATASET STRUCTURED_GRID
//! DIMENSIONS 4 3 2
//! POINTS 24 double
//! x y z ...                  (the first index varies fastest)
//! POINT_DATA 24
//! SCALARS rho double 1
//! LOOKUP_TABLE default
//! ...
//! VECTORS velocity double
//! ...
//! FIELD FieldData 1
//! temperature 1 24 double
//! ...
//! ```
//!
//! The reader takes `SCALARS` (1 to 4 components), `VECTORS`, `NORMALS` and `FIELD`
//! arrays of the point data, in any of VTK's numeric types, and skips `METADATA`
//! blocks; it stops at `CELL_DATA`. Every count is checked against the bytes left
//! before anything is allocated, so a hostile header cannot ask for gigabytes.

use thiserror::Error;

/// The most grid points a file may declare (a 256^3 grid).
pub const MAX_VTK_POINTS: usize = 1 << 24;
/// The most point-data arrays a file may carry.
pub const MAX_VTK_ARRAYS: usize = 64;

/// A curvilinear grid with named point data.
#[derive(Debug, Clone, PartialEq)]
pub struct StructuredGrid {
    /// Points per grid direction (`DIMENSIONS`).
    pub dims: [usize; 3],
    /// The points, the first index varying fastest (VTK's order).
    pub points: Vec<[f64; 3]>,
    /// The point-data arrays.
    pub arrays: Vec<PointArray>,
}

/// One point-data array: `components` values per grid point, point after point.
#[derive(Debug, Clone, PartialEq)]
pub struct PointArray {
    /// Its name.
    pub name: String,
    /// Values per point.
    pub components: usize,
    /// `components x points` values.
    pub values: Vec<f64>,
}

/// Why a VTK file could not be read.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum VtkError {
    /// The file does not start with the legacy VTK header.
    #[error("line 1: not a legacy VTK file (expected \"# vtk DataFile Version\")")]
    NotVtk,
    /// The file ends inside its header or data.
    #[error("line {line}: the file ends early (expected {expected})")]
    UnexpectedEnd {
        /// 1-based line where it ended.
        line: usize,
        /// What was expected.
        expected: &'static str,
    },
    /// A line does not say what the format needs there.
    #[error("line {line}: expected {expected}, found {found:?}")]
    Unexpected {
        /// 1-based line.
        line: usize,
        /// What was expected.
        expected: &'static str,
        /// What the line says (cut to 40 characters).
        found: String,
    },
    /// The data set is not a structured grid.
    #[error("line {line}: only DATASET STRUCTURED_GRID is read, found {found:?}")]
    Dataset {
        /// 1-based line.
        line: usize,
        /// The data set type.
        found: String,
    },
    /// A count disagrees with the grid's dimensions or is beyond the caps.
    #[error("line {line}: {what} {got} does not match {need}")]
    Count {
        /// 1-based line.
        line: usize,
        /// What is counted.
        what: &'static str,
        /// Found.
        got: usize,
        /// Needed.
        need: usize,
    },
    /// The grid is empty or beyond [`MAX_VTK_POINTS`].
    #[error("line {line}: dimensions {dims:?} are empty or exceed {max} points")]
    Dimensions {
        /// 1-based line.
        line: usize,
        /// The dimensions.
        dims: [usize; 3],
        /// The cap.
        max: usize,
    },
    /// An unknown numeric type.
    #[error("line {line}: unknown data type {found:?}")]
    DataType {
        /// 1-based line.
        line: usize,
        /// The type.
        found: String,
    },
    /// A number could not be read or is not finite.
    #[error("line {line}: {found:?} is not a finite number")]
    Number {
        /// 1-based line.
        line: usize,
        /// The token.
        found: String,
    },
    /// Binary data runs past the end of the file.
    #[error("line {line}: {need} bytes of binary data, only {have} left")]
    Truncated {
        /// 1-based line of the header before the data.
        line: usize,
        /// Bytes needed.
        need: usize,
        /// Bytes left.
        have: usize,
    },
}

/// The numeric types of legacy VTK, with their sizes in bytes.
#[derive(Debug, Clone, Copy)]
enum DataType {
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    U64,
    I64,
    F32,
    F64,
}

impl DataType {
    fn parse(s: &str) -> Option<Self> {
        Some(match s.to_ascii_lowercase().as_str() {
            "unsigned_char" | "bit" => Self::U8,
            "char" => Self::I8,
            "unsigned_short" => Self::U16,
            "short" => Self::I16,
            "unsigned_int" => Self::U32,
            "int" => Self::I32,
            "unsigned_long" | "vtktypeuint64" => Self::U64,
            "long" | "vtktypeint64" | "vtkidtype" => Self::I64,
            "float" => Self::F32,
            "double" => Self::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Self::U8 | Self::I8 => 1,
            Self::U16 | Self::I16 => 2,
            Self::U32 | Self::I32 | Self::F32 => 4,
            Self::U64 | Self::I64 | Self::F64 => 8,
        }
    }
    /// A big-endian value of this type.
    fn read_be(self, b: &[u8]) -> f64 {
        let a = |n: usize| {
            let mut x = [0u8; 8];
            x[..n].copy_from_slice(&b[..n]);
            x
        };
        match self {
            Self::U8 => f64::from(b[0]),
            Self::I8 => f64::from(b[0] as i8),
            Self::U16 => f64::from(u16::from_be_bytes([b[0], b[1]])),
            Self::I16 => f64::from(i16::from_be_bytes([b[0], b[1]])),
            Self::U32 => f64::from(u32::from_be_bytes([b[0], b[1], b[2], b[3]])),
            Self::I32 => f64::from(i32::from_be_bytes([b[0], b[1], b[2], b[3]])),
            Self::U64 => u64::from_be_bytes(a(8)) as f64,
            Self::I64 => i64::from_be_bytes(a(8)) as f64,
            Self::F32 => f64::from(f32::from_be_bytes([b[0], b[1], b[2], b[3]])),
            Self::F64 => f64::from_be_bytes(a(8)),
        }
    }
}

/// A cursor over the file's bytes that reads header lines, ASCII tokens and binary
/// blocks, counting lines.
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: usize,
    binary: bool,
}

fn excerpt(s: &str) -> String {
    s.chars().take(40).collect()
}

impl<'a> Cursor<'a> {
    /// The next non-blank line, trimmed.
    fn line(&mut self, expected: &'static str) -> Result<&'a str, VtkError> {
        loop {
            if self.pos >= self.bytes.len() {
                return Err(VtkError::UnexpectedEnd {
                    line: self.line,
                    expected,
                });
            }
            let bytes: &'a [u8] = self.bytes;
            let rest = &bytes[self.pos..];
            let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
            self.pos += (end + 1).min(rest.len());
            self.line += 1;
            let text = String::from_utf8_lossy(&rest[..end]);
            let trimmed = text.trim();
            if !trimmed.is_empty() {
                // Re-borrow from the input: header lines are ASCII in valid files.
                let s = std::str::from_utf8(&rest[..end]).map_err(|_| VtkError::Unexpected {
                    line: self.line,
                    expected,
                    found: excerpt(trimmed),
                })?;
                return Ok(s.trim());
            }
        }
    }

    /// The next whitespace-separated ASCII token.
    fn token(&mut self) -> Option<&'a str> {
        while self.pos < self.bytes.len() && self.bytes[self.pos].is_ascii_whitespace() {
            if self.bytes[self.pos] == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
        let start = self.pos;
        while self.pos < self.bytes.len() && !self.bytes[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        let bytes: &'a [u8] = self.bytes;
        (self.pos > start).then(|| std::str::from_utf8(&bytes[start..self.pos]).unwrap_or("?"))
    }

    /// `count` numbers of type `ty`: ASCII tokens, or a big-endian block (followed by
    /// an optional newline).
    fn numbers(&mut self, count: usize, ty: DataType) -> Result<Vec<f64>, VtkError> {
        if self.binary {
            let need = count.saturating_mul(ty.size());
            let have = self.bytes.len() - self.pos;
            if need > have {
                return Err(VtkError::Truncated {
                    line: self.line,
                    need,
                    have,
                });
            }
            let block = &self.bytes[self.pos..self.pos + need];
            self.pos += need;
            if self.bytes.get(self.pos) == Some(&b'\n') {
                self.pos += 1;
            }
            let out: Vec<f64> = block
                .chunks_exact(ty.size())
                .map(|b| ty.read_be(b))
                .collect();
            if let Some(v) = out.iter().find(|v| !v.is_finite()) {
                return Err(VtkError::Number {
                    line: self.line,
                    found: v.to_string(),
                });
            }
            return Ok(out);
        }
        // Each ASCII number takes at least two bytes: a count beyond that is a lie.
        let have = self.bytes.len() - self.pos;
        if count > have / 2 + 1 {
            return Err(VtkError::Truncated {
                line: self.line,
                need: count * 2,
                have,
            });
        }
        let mut out = Vec::with_capacity(count);
        for _ in 0..count {
            let tok = self.token().ok_or(VtkError::UnexpectedEnd {
                line: self.line,
                expected: "more numbers",
            })?;
            match tok.parse::<f64>() {
                Ok(v) if v.is_finite() => out.push(v),
                _ => {
                    // `line` counts the newlines consumed: the token is on the next line.
                    return Err(VtkError::Number {
                        line: self.line + 1,
                        found: excerpt(tok),
                    });
                }
            }
        }
        // Finish the line the last number was on.
        while self.pos < self.bytes.len() && self.bytes[self.pos] != b'\n' {
            self.pos += 1;
        }
        if self.pos < self.bytes.len() {
            self.pos += 1;
            self.line += 1;
        }
        Ok(out)
    }
}

fn parse_usize(
    c: &Cursor<'_>,
    tok: Option<&str>,
    expected: &'static str,
) -> Result<usize, VtkError> {
    let t = tok.ok_or(VtkError::UnexpectedEnd {
        line: c.line,
        expected,
    })?;
    t.parse().map_err(|_| VtkError::Unexpected {
        line: c.line,
        expected,
        found: excerpt(t),
    })
}

fn data_type(c: &Cursor<'_>, tok: Option<&str>) -> Result<DataType, VtkError> {
    let t = tok.unwrap_or("");
    DataType::parse(t).ok_or_else(|| VtkError::DataType {
        line: c.line,
        found: excerpt(t),
    })
}

impl StructuredGrid {
    /// The number of grid points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when the grid has no points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Reads a legacy VTK `STRUCTURED_GRID` file (ASCII or BINARY).
    pub fn from_vtk(bytes: &[u8]) -> Result<Self, VtkError> {
        let mut c = Cursor {
            bytes,
            pos: 0,
            line: 0,
            binary: false,
        };
        let head = c.line("the VTK header").map_err(|_| VtkError::NotVtk)?;
        if !head
            .to_ascii_lowercase()
            .starts_with("# vtk datafile version")
        {
            return Err(VtkError::NotVtk);
        }
        // The title may be blank: take the raw next line.
        let rest = &c.bytes[c.pos..];
        let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
        c.pos += (end + 1).min(rest.len());
        c.line += 1;
        let mode = c.line("ASCII or BINARY")?;
        c.binary = match mode.to_ascii_uppercase().as_str() {
            "ASCII" => false,
            "BINARY" => true,
            _ => {
                return Err(VtkError::Unexpected {
                    line: c.line,
                    expected: "ASCII or BINARY",
                    found: excerpt(mode),
                });
            }
        };
        let ds = c.line("DATASET STRUCTURED_GRID")?;
        let mut it = ds.split_whitespace();
        if !it.next().is_some_and(|w| w.eq_ignore_ascii_case("DATASET")) {
            return Err(VtkError::Unexpected {
                line: c.line,
                expected: "DATASET STRUCTURED_GRID",
                found: excerpt(ds),
            });
        }
        let kind = it.next().unwrap_or("");
        if !kind.eq_ignore_ascii_case("STRUCTURED_GRID") {
            return Err(VtkError::Dataset {
                line: c.line,
                found: excerpt(kind),
            });
        }
        let mut dims = [0usize; 3];
        let mut points: Option<Vec<[f64; 3]>> = None;
        let mut arrays: Vec<PointArray> = Vec::new();
        let mut point_data = false;
        loop {
            let line = match c.line("a section") {
                Ok(l) => l,
                Err(_) if points.is_some() => break,
                Err(e) => return Err(e),
            };
            let mut w = line.split_whitespace();
            let key = w.next().unwrap_or("").to_ascii_uppercase();
            match key.as_str() {
                "DIMENSIONS" => {
                    for d in &mut dims {
                        *d = parse_usize(&c, w.next(), "three dimensions")?;
                    }
                    let total = dims.iter().try_fold(1usize, |a, &d| a.checked_mul(d));
                    if dims.contains(&0) || total.is_none_or(|t| t > MAX_VTK_POINTS) {
                        return Err(VtkError::Dimensions {
                            line: c.line,
                            dims,
                            max: MAX_VTK_POINTS,
                        });
                    }
                }
                "POINTS" => {
                    let n = parse_usize(&c, w.next(), "the point count")?;
                    let need = dims.iter().product();
                    if n != need || need == 0 {
                        return Err(VtkError::Count {
                            line: c.line,
                            what: "POINTS",
                            got: n,
                            need,
                        });
                    }
                    let ty = data_type(&c, w.next())?;
                    let v = c.numbers(3 * n, ty)?;
                    points = Some(v.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect());
                }
                "POINT_DATA" => {
                    let n = parse_usize(&c, w.next(), "the point count")?;
                    let need = dims.iter().product();
                    if n != need {
                        return Err(VtkError::Count {
                            line: c.line,
                            what: "POINT_DATA",
                            got: n,
                            need,
                        });
                    }
                    point_data = true;
                }
                "CELL_DATA" => break,
                "METADATA" => {
                    // Skip to the blank line that ends the block.
                    while c.pos < c.bytes.len() {
                        let rest = &c.bytes[c.pos..];
                        let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
                        c.pos += (end + 1).min(rest.len());
                        c.line += 1;
                        if rest[..end].iter().all(u8::is_ascii_whitespace) {
                            break;
                        }
                    }
                }
                "SCALARS" | "VECTORS" | "NORMALS" if point_data => {
                    let name = w.next().unwrap_or("").to_string();
                    let ty = data_type(&c, w.next())?;
                    let comps = if key == "SCALARS" {
                        match w.next() {
                            Some(t) => parse_usize(&c, Some(t), "1 to 4 components")?,
                            None => 1,
                        }
                    } else {
                        3
                    };
                    if !(1..=4).contains(&comps) {
                        return Err(VtkError::Count {
                            line: c.line,
                            what: "components",
                            got: comps,
                            need: 4,
                        });
                    }
                    if key == "SCALARS" {
                        // LOOKUP_TABLE is optional in some writers.
                        let save = (c.pos, c.line);
                        let next = c.line("LOOKUP_TABLE")?;
                        if !next.to_ascii_uppercase().starts_with("LOOKUP_TABLE") {
                            (c.pos, c.line) = save;
                        }
                    }
                    let n = dims.iter().product::<usize>();
                    let values = c.numbers(comps * n, ty)?;
                    push_array(&mut arrays, &c, name, comps, values)?;
                }
                "FIELD" if point_data => {
                    let count = parse_usize(&c, w.nth(1), "the number of arrays")?;
                    if count > MAX_VTK_ARRAYS {
                        return Err(VtkError::Count {
                            line: c.line,
                            what: "FIELD arrays",
                            got: count,
                            need: MAX_VTK_ARRAYS,
                        });
                    }
                    for _ in 0..count {
                        let head = c.line("a FIELD array")?;
                        let mut h = head.split_whitespace();
                        let name = h.next().unwrap_or("").to_string();
                        let comps = parse_usize(&c, h.next(), "the number of components")?;
                        let tuples = parse_usize(&c, h.next(), "the number of tuples")?;
                        let ty = data_type(&c, h.next())?;
                        let n = dims.iter().product::<usize>();
                        if tuples != n || comps == 0 || comps > 16 {
                            return Err(VtkError::Count {
                                line: c.line,
                                what: "FIELD tuples",
                                got: tuples,
                                need: n,
                            });
                        }
                        let values = c.numbers(comps * n, ty)?;
                        push_array(&mut arrays, &c, name, comps, values)?;
                    }
                }
                _ => {
                    return Err(VtkError::Unexpected {
                        line: c.line,
                        expected: "DIMENSIONS, POINTS, POINT_DATA or a point-data array",
                        found: excerpt(line),
                    });
                }
            }
        }
        let points = points.ok_or(VtkError::UnexpectedEnd {
            line: c.line,
            expected: "POINTS",
        })?;
        // DIMENSIONS may come again after the data: everything must fit the last one.
        let need: usize = dims.iter().product();
        if points.len() != need {
            return Err(VtkError::Count {
                line: c.line,
                what: "POINTS",
                got: points.len(),
                need,
            });
        }
        if let Some(a) = arrays
            .iter()
            .find(|a| a.values.len() != a.components * need)
        {
            return Err(VtkError::Count {
                line: c.line,
                what: "point-data values",
                got: a.values.len(),
                need: a.components * need,
            });
        }
        Ok(Self {
            dims,
            points,
            arrays,
        })
    }

    /// Writes the grid as legacy VTK ASCII (`binary = false`) or BINARY (big-endian
    /// doubles), readable by ParaView.
    pub fn to_vtk(&self, title: &str, binary: bool) -> Vec<u8> {
        let title: String = title.chars().filter(|&c| c != '\n').take(255).collect();
        let n = self.points.len();
        let mut out = format!(
            "# vtk DataFile Version 3.0\n{title}\n{}\nDATASET STRUCTURED_GRID\nDIMENSIONS {} {} {}\nPOINTS {n} double\n",
            if binary { "BINARY" } else { "ASCII" },
            self.dims[0],
            self.dims[1],
            self.dims[2]
        )
        .into_bytes();
        let write = |out: &mut Vec<u8>, values: &mut dyn Iterator<Item = f64>, per_line: usize| {
            if binary {
                for v in values {
                    out.extend_from_slice(&v.to_be_bytes());
                }
                out.push(b'\n');
            } else {
                for (i, v) in values.enumerate() {
                    out.extend_from_slice(v.to_string().as_bytes());
                    out.push(if (i + 1) % per_line == 0 { b'\n' } else { b' ' });
                }
                if out.last() == Some(&b' ') {
                    out.pop();
                    out.push(b'\n');
                }
            }
        };
        write(&mut out, &mut self.points.iter().flatten().copied(), 3);
        if !self.arrays.is_empty() {
            out.extend_from_slice(
                format!("POINT_DATA {n}\nFIELD FieldData {}\n", self.arrays.len()).as_bytes(),
            );
            for a in &self.arrays {
                let name: String = a
                    .name
                    .chars()
                    .map(|c| if c.is_whitespace() { '_' } else { c })
                    .collect();
                out.extend_from_slice(format!("{name} {} {n} double\n", a.components).as_bytes());
                write(&mut out, &mut a.values.iter().copied(), a.components.max(1));
            }
        }
        out
    }
}

fn push_array(
    arrays: &mut Vec<PointArray>,
    c: &Cursor<'_>,
    name: String,
    components: usize,
    values: Vec<f64>,
) -> Result<(), VtkError> {
    if arrays.len() >= MAX_VTK_ARRAYS {
        return Err(VtkError::Count {
            line: c.line,
            what: "arrays",
            got: arrays.len() + 1,
            need: MAX_VTK_ARRAYS,
        });
    }
    arrays.push(PointArray {
        name,
        components,
        values,
    });
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> StructuredGrid {
        let dims = [3, 2, 2];
        let mut points = Vec::new();
        for k in 0..2 {
            for j in 0..2 {
                for i in 0..3 {
                    points.push([i as f64 * 0.5, j as f64 + 0.25 * i as f64, k as f64 * 2.0]);
                }
            }
        }
        let rho = points.iter().map(|p| 1.0 + p[2] / 3.0).collect();
        let vel = points.iter().flat_map(|p| [p[1], -p[0], 0.125]).collect();
        StructuredGrid {
            dims,
            points,
            arrays: vec![
                PointArray {
                    name: "rho".into(),
                    components: 1,
                    values: rho,
                },
                PointArray {
                    name: "velocity".into(),
                    components: 3,
                    values: vel,
                },
            ],
        }
    }

    #[test]
    fn ascii_and_binary_round_trip() {
        let g = grid();
        for binary in [false, true] {
            let bytes = g.to_vtk("test grid", binary);
            assert_eq!(
                StructuredGrid::from_vtk(&bytes).unwrap(),
                g,
                "binary {binary}"
            );
        }
    }

    #[test]
    fn reads_scalars_vectors_and_float_binary_written_by_hand() {
        let mut f = b"# vtk DataFile Version 2.0\n\nBINARY\nDATASET STRUCTURED_GRID\nDIMENSIONS 2 1 1\nPOINTS 2 float\n".to_vec();
        for v in [0.0f32, 1.0, 2.0, 3.0, 4.0, 5.0] {
            f.extend_from_slice(&v.to_be_bytes());
        }
        f.extend_from_slice(b"\nPOINT_DATA 2\nSCALARS p int 1\nLOOKUP_TABLE default\n");
        for v in [7i32, -9] {
            f.extend_from_slice(&v.to_be_bytes());
        }
        f.extend_from_slice(b"\nVECTORS v double\n");
        for v in [1.5f64, 2.5, 3.5, 4.5, 5.5, 6.5] {
            f.extend_from_slice(&v.to_be_bytes());
        }
        let g = StructuredGrid::from_vtk(&f).unwrap();
        assert_eq!(g.points, vec![[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]]);
        assert_eq!(g.arrays[0].values, vec![7.0, -9.0]);
        assert_eq!(g.arrays[1].components, 3);
        assert_eq!(g.arrays[1].values[5], 6.5);
    }

    #[test]
    fn bad_files_name_the_line() {
        let ok = String::from_utf8(grid().to_vtk("t", false)).unwrap();
        let e = StructuredGrid::from_vtk(b"hello").unwrap_err();
        assert_eq!(e, VtkError::NotVtk);
        let e = StructuredGrid::from_vtk(ok.replace("STRUCTURED_GRID", "POLYDATA").as_bytes())
            .unwrap_err();
        assert!(matches!(e, VtkError::Dataset { line: 4, .. }), "{e}");
        let e =
            StructuredGrid::from_vtk(ok.replace("POINTS 12", "POINTS 13").as_bytes()).unwrap_err();
        assert!(
            matches!(
                e,
                VtkError::Count {
                    line: 6,
                    got: 13,
                    need: 12,
                    ..
                }
            ),
            "{e}"
        );
        let e = StructuredGrid::from_vtk(
            ok.replace("DIMENSIONS 3 2 2", "DIMENSIONS 99999 99999 99999")
                .as_bytes(),
        )
        .unwrap_err();
        assert!(matches!(e, VtkError::Dimensions { .. }), "{e}");
        let e = StructuredGrid::from_vtk(ok.replacen("0.5", "nan", 1).as_bytes()).unwrap_err();
        assert!(matches!(e, VtkError::Number { line: 8, .. }), "{e}");
        // Regression (found by reading the fuzz target's round trip): DIMENSIONS given
        // again after the data no longer matched the points, and the written file
        // could not be read back.
        let e = StructuredGrid::from_vtk(format!("{ok}DIMENSIONS 3 2 3\n").as_bytes()).unwrap_err();
        assert!(
            matches!(
                e,
                VtkError::Count {
                    got: 12,
                    need: 18,
                    ..
                }
            ),
            "{e}"
        );
        let bin = grid().to_vtk("t", true);
        let e = StructuredGrid::from_vtk(&bin[..bin.len() / 2]).unwrap_err();
        assert!(
            matches!(
                e,
                VtkError::Truncated { .. } | VtkError::UnexpectedEnd { .. }
            ),
            "{e}"
        );
    }
}
