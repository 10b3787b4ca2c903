//! Why a mesh or CAD file could not be read or written ([`Error::Format`](super::Error::Format)).

use std::fmt;

use thiserror::Error;

use super::text::{Excerpt, JsonError};

/// A file format of [`crate::formats`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileFormat {
    /// Wavefront OBJ.
    Obj,
    /// Binary STL.
    Stl,
    /// glTF 2.0 binary.
    Gltf,
    /// IGES 5.3.
    Iges,
    /// Stanford PLY (ASCII, with vertex colours).
    Ply,
}

impl fmt::Display for FileFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FileFormat::Obj => "OBJ",
            FileFormat::Stl => "STL",
            FileFormat::Gltf => "glTF",
            FileFormat::Iges => "IGES",
            FileFormat::Ply => "PLY",
        })
    }
}

/// Which number a writer refused to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WrittenValue {
    /// A mesh vertex position.
    Position,
    /// A mesh vertex normal.
    Normal,
    /// A mesh vertex texture coordinate.
    TexCoord,
    /// A surface knot (u or v).
    Knot,
    /// A surface weight.
    Weight,
    /// A surface control point.
    ControlPoint,
    /// A trimming loop's point in the surface's parameter range.
    TrimPoint,
    /// A mesh vertex colour.
    Colour,
}

impl fmt::Display for WrittenValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            WrittenValue::Position => "vertex position",
            WrittenValue::Normal => "vertex normal",
            WrittenValue::TexCoord => "vertex texture coordinate",
            WrittenValue::Knot => "knot",
            WrittenValue::Weight => "weight",
            WrittenValue::ControlPoint => "control point",
            WrittenValue::TrimPoint => "trimming loop point",
            WrittenValue::Colour => "vertex colour",
        })
    }
}

/// A part of a glTF file the reader needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GltfPart {
    /// The JSON chunk.
    JsonChunk,
    /// An attribute's accessor index.
    Accessor,
    /// An accessor's `count`.
    AccessorCount,
    /// An accessor's `bufferView`.
    AccessorView,
    /// The primitive's `indices`.
    Indices,
}

impl fmt::Display for GltfPart {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            GltfPart::JsonChunk => "JSON chunk",
            GltfPart::Accessor => "accessor index",
            GltfPart::AccessorCount => "accessor count",
            GltfPart::AccessorView => "accessor bufferView",
            GltfPart::Indices => "indices",
        })
    }
}

/// Why a mesh or CAD file could not be read or written ([`Error::Format`](super::Error::Format)).
///
/// Line numbers are 1-based; quoted input is an [`Excerpt`]. The underlying parse
/// error, where there is one, is kept typed and printed as part of the message (the
/// convention of [`Error`](enum@super::Error)).
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum FormatError {
    // Any text format.
    /// The bytes are not UTF-8 (OBJ) or ASCII (IGES) text.
    #[error("not text: {error}")]
    NotText {
        /// Where decoding stopped.
        error: std::str::Utf8Error,
    },

    // Writers.
    /// A number to write is NaN or infinite; nothing was written.
    #[error("{what} {index} is not finite")]
    NonFinite {
        /// Which kind of number.
        what: WrittenValue,
        /// The vertex or control point (in writing order) it belongs to.
        index: usize,
    },

    /// A number of a surface to write is NaN or infinite; nothing was written.
    #[error("surface {surface}: {what} {index} is not finite")]
    SurfaceNonFinite {
        /// The surface, in the order given to the writer.
        surface: usize,
        /// Which kind of number.
        what: WrittenValue,
        /// Its index: in `knots_u` followed by `knots_v`, in the net (`i * rows + j`
        /// for weights and control points), or in the face's loops.
        index: usize,
    },

    /// A mesh writer was given a different number of vertex colours than vertices;
    /// nothing was written.
    #[error("{got} vertex colours for {need} vertices")]
    ColourCount {
        /// Colours given.
        got: usize,
        /// Vertices of the mesh.
        need: usize,
    },

    // OBJ.
    /// A token is not a number.
    #[error("line {line}: {token} is not a number: {error}")]
    Number {
        /// The line.
        line: usize,
        /// The token.
        token: Excerpt,
        /// The parse error.
        error: std::num::ParseFloatError,
    },
    /// A statement has too few numbers, or one that is not finite.
    #[error("line {line}: expected {expected} finite numbers, found {finite} of {found}")]
    NumberCount {
        /// The line.
        line: usize,
        /// Numbers needed.
        expected: usize,
        /// Numbers given (up to `expected`).
        found: usize,
        /// Of those, finite ones.
        finite: usize,
    },
    /// A face's vertex reference is not an integer.
    #[error("line {line}: bad index {token}: {error}")]
    Index {
        /// The line.
        line: usize,
        /// The reference.
        token: Excerpt,
        /// The parse error.
        error: std::num::ParseIntError,
    },
    /// A face's vertex reference points at no element.
    #[error("line {line}: index {index} out of range ({count} defined)")]
    IndexOutOfRange {
        /// The line.
        line: usize,
        /// The index as written.
        index: i64,
        /// Elements defined before the line.
        count: usize,
    },
    /// A face's vertex has no position reference.
    #[error("line {line}: face without a position")]
    FaceWithoutPosition {
        /// The line.
        line: usize,
    },
    /// A face has fewer than three vertices.
    #[error("line {line}: a face needs 3 vertices, found {found}")]
    FaceTooSmall {
        /// The line.
        line: usize,
        /// Vertices given.
        found: usize,
    },

    // STL.
    /// The file is shorter than the header.
    #[error("{bytes} bytes is shorter than the {header}-byte header")]
    Truncated {
        /// File size.
        bytes: usize,
        /// Header size.
        header: usize,
    },
    /// The file size does not match the triangle count in the header.
    #[error("header says {triangles} triangles but the file has {bytes} bytes")]
    TriangleCount {
        /// Triangles in the header.
        triangles: usize,
        /// File size.
        bytes: usize,
    },
    /// A triangle corner is NaN or infinite.
    #[error("triangle {triangle} has a non-finite corner")]
    NonFiniteCorner {
        /// The triangle.
        triangle: usize,
    },

    // glTF binary.
    /// The first word is not `glTF`.
    #[error("not a GLB file (bad magic)")]
    BadMagic,
    /// The container version is not 2.
    #[error("container version {found:?} is not supported (only glTF 2.0)")]
    GltfVersion {
        /// The version (`None`: the file ends first).
        found: Option<u32>,
    },
    /// The header's length is not the file's.
    #[error("header length {header:?} does not match the file size {bytes}")]
    Length {
        /// The header's length.
        header: Option<u32>,
        /// File size.
        bytes: usize,
    },
    /// A chunk header or body runs past the end of the file.
    #[error("chunk at byte {at} runs past the end of the file")]
    Chunk {
        /// Offset of the chunk header.
        at: usize,
    },
    /// A part the reader needs is missing.
    #[error("no {0}")]
    Missing(GltfPart),
    /// The JSON chunk is not JSON.
    #[error("bad JSON chunk: {0}")]
    GltfJson(JsonError),
    /// An accessor's component type is not one the reader knows.
    #[error("accessor {accessor}: unsupported component type {component_type}")]
    ComponentType {
        /// The accessor.
        accessor: usize,
        /// Its `componentType`.
        component_type: u64,
    },
    /// An accessor reaches beyond the binary chunk.
    #[error("accessor {accessor} runs past the binary chunk ({bytes} bytes)")]
    AccessorRange {
        /// The accessor.
        accessor: usize,
        /// Size of the binary chunk.
        bytes: usize,
    },
    /// Attribute arrays have different vertex counts.
    #[error("attribute counts differ: {positions} positions, {normals} normals, {uvs} uvs")]
    AttributeCounts {
        /// Positions.
        positions: usize,
        /// Normals.
        normals: usize,
        /// Texture coordinates.
        uvs: usize,
    },
    /// The index count is not a multiple of 3 or exceeds the buffer.
    #[error("bad index count {count}")]
    IndexCount {
        /// Indices given.
        count: usize,
    },
    /// A triangle index points past the vertices.
    #[error("index {index} out of range ({vertices} vertices)")]
    VertexIndex {
        /// The index.
        index: u32,
        /// Vertices.
        vertices: usize,
    },

    // IGES.
    /// A non-blank line is shorter than the 73 columns of a section line.
    #[error("line {line}: {columns} columns, shorter than 73")]
    ShortLine {
        /// The line.
        line: usize,
        /// Its length, bytes.
        columns: usize,
    },
    /// A parameter data line's directory pointer (columns 65 to 72) is not a number.
    #[error("line {line}: bad directory pointer {token}")]
    DirectoryPointer {
        /// The line.
        line: usize,
        /// Columns 65 to 72.
        token: Excerpt,
    },
    /// Column 73 names no section.
    #[error("line {line}: unknown section {section}")]
    Section {
        /// The line.
        line: usize,
        /// Column 73.
        section: Excerpt,
    },
    /// The directory entry section has an odd number of lines.
    #[error("odd number of directory entry lines ({lines})")]
    OddDirectory {
        /// Lines.
        lines: usize,
    },
    /// A directory entry's entity type is not a number.
    #[error("directory entry {de}: bad entity type {token}")]
    EntityType {
        /// The entry's sequence number.
        de: usize,
        /// Columns 1 to 8.
        token: Excerpt,
    },
    /// A directory entry has no parameter data.
    #[error("directory entry {de}: no parameter data")]
    NoParameters {
        /// The entry's sequence number.
        de: usize,
    },
    /// A directory entry's parameter data starts with another entity type.
    #[error("directory entry {de}: parameter data is for another entity ({found}, not {kind})")]
    OtherEntity {
        /// The entry's sequence number.
        de: usize,
        /// The entry's type.
        kind: u32,
        /// The parameter data's first token.
        found: Excerpt,
    },
    /// A parameter is missing or not a finite number.
    #[error("entity {kind} at {de}: parameter {index} missing or not a number")]
    Parameter {
        /// The entity type.
        kind: u32,
        /// Its directory entry.
        de: usize,
        /// The parameter's position.
        index: usize,
    },
    /// A parameter that must be a count is not a whole number in range.
    #[error("entity {kind} at {de}: parameter {index} = {value} is not a count")]
    NotACount {
        /// The entity type.
        kind: u32,
        /// Its directory entry.
        de: usize,
        /// The parameter's position.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// An entity has fewer parameters than its counts need.
    #[error("entity {kind} at {de}: {found} parameters, {need} needed")]
    ParameterCount {
        /// The entity type.
        kind: u32,
        /// Its directory entry.
        de: usize,
        /// Parameters given.
        found: usize,
        /// Parameters needed.
        need: usize,
    },
    /// A trimmed surface's base surface is not an entity 128.
    #[error("entity 144 at {de}: base surface {pointer} is not an entity 128")]
    BaseSurface {
        /// The 144's directory entry.
        de: usize,
        /// Its base surface pointer.
        pointer: usize,
    },
}
