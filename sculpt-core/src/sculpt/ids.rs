//! The document's identifiers and its target cap, a leaf below the document and the
//! modules that name targets without needing the document (the lattice, the errors),
//! so none of them imports the other in a circle.

/// Most targets a document holds: the reader refuses more, and an edit that would add
/// one more (a sketch) is rejected
/// ([`DocumentError::TooManyTargets`](crate::error::DocumentError::TooManyTargets)).
/// The paper's scenes and the demo have one; a scanned object (`sculpt-tools
/// reconstruct`) has one per quad of its patch network: the kitten scan at K = 80 has
/// 478.
pub const MAX_TARGETS: usize = 4096;

/// Identifies a target surface in a document: how every part of the program refers to
/// a target (strokes, the editor's results, the live preview, replay metrics).
pub type TargetId = u64;
