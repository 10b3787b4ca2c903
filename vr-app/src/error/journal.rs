//! Why the operation journal is unreadable or could not be written.

use thiserror::Error;

/// Why the operation journal is unreadable or could not be written.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum JournalError {
    /// A line is longer than the cap.
    #[error("line {line} is longer than {max} bytes")]
    LineTooLong {
        /// 1-based line.
        line: usize,
        /// The cap.
        max: usize,
    },
    /// A line is not UTF-8.
    #[error("line {line} is not UTF-8")]
    NotUtf8 {
        /// 1-based line.
        line: usize,
    },
    /// A version 1 journal (targets named by position) was appended to before it was
    /// upgraded.
    #[error("a version {version} journal must be upgraded before it is appended to")]
    NotUpgraded {
        /// The file's version.
        version: u32,
    },
    /// The first line is not the journal header.
    #[error("not a wandsculpt journal (line 1 is {found:?})")]
    NotAJournal {
        /// The first line (truncated).
        found: String,
    },
    /// A line is not a journal entry.
    #[error("line {line}: {error}")]
    Entry {
        /// 1-based line.
        line: usize,
        /// The JSON error.
        error: sculpt_core::error::JsonError,
    },
    /// An entry's sequence number is out of order.
    #[error("line {line}: sequence {found} where {expected} was expected")]
    Sequence {
        /// 1-based line.
        line: usize,
        /// The sequence number read.
        found: u64,
        /// The one expected.
        expected: u64,
    },
    /// An entry could not be encoded.
    #[error("encoding an entry: {0}")]
    Encode(sculpt_core::error::JsonError),
    /// The journal names another document than this run's base scene. The file is
    /// left as it is.
    #[error(
        "belongs to another document (journal {found}, this run's base scene {expected}); \
         the file was left as it is: give the --scene it was recorded with, or another --out"
    )]
    OtherDocument {
        /// The document id in the journal's header.
        found: String,
        /// The id of this run's base scene.
        expected: String,
    },
    /// An entry names a target the base scene does not have: the journal was recorded
    /// on another document. The file is left as it is.
    #[error(
        "line {line} names target {target}, which this run's base scene does not have \
         ({targets} targets): the journal was recorded on another document; the file was \
         left as it is: give the --scene it was recorded with, or another --out"
    )]
    UnknownTarget {
        /// 1-based line.
        line: usize,
        /// The target as the entry names it (a position in a version 1 journal, an id
        /// in version 2).
        target: u64,
        /// The base scene's target count.
        targets: usize,
    },
    /// The last line is neither a whole line nor the start of one cut off by a crash
    /// (binary data, NUL bytes). The file is left as it is.
    #[error(
        "line {line}: {bytes} bytes that are not a journal line (nor one cut off by a crash); \
         the file was left as it is"
    )]
    Garbage {
        /// 1-based line.
        line: usize,
        /// Its length.
        bytes: usize,
    },
}
