//! Bad input quoted in errors, kept short: an [`Excerpt`] of a line or token, a
//! [`JsonError`] cut to a bounded message, and [`Chain`] for printing a cause chain.

use std::fmt;
use std::sync::Arc;

/// The most characters of bad input an error quotes: longer input is cut to this many
/// characters and marked with `...`, so a 200 MB line gives a short message.
pub const MAX_QUOTED_CHARS: usize = 64;

/// A short quoted prefix of bad input (at most [`MAX_QUOTED_CHARS`] characters), kept
/// in an error as data. Displays as a Rust string literal, with `...` after the
/// closing quote when the input was cut.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Excerpt {
    /// The first characters of the input.
    pub prefix: String,
    /// Characters of the input left out (0 when it was quoted whole).
    pub cut_chars: usize,
}

impl Excerpt {
    /// The excerpt of `input`.
    pub fn new(input: &str) -> Self {
        let end = input
            .char_indices()
            .nth(MAX_QUOTED_CHARS)
            .map_or(input.len(), |(i, _)| i);
        Self {
            prefix: input[..end].to_string(),
            cut_chars: input[end..].chars().count(),
        }
    }

    /// True when the input was longer than the excerpt.
    pub fn is_cut(&self) -> bool {
        self.cut_chars > 0
    }
}

impl fmt::Display for Excerpt {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", self.prefix)?;
        if self.is_cut() {
            write!(f, "... ({} more characters)", self.cut_chars)?;
        }
        Ok(())
    }
}

/// A JSON syntax or schema error with its position, shared so that [`Error`](enum@super::Error) stays
/// `Clone`; two are equal when they say the same thing at the same place.
#[derive(Debug, Clone)]
pub struct JsonError(Arc<serde_json::Error>);

impl JsonError {
    /// 1-based line of the error (0 when serde could not tell).
    pub fn line(&self) -> usize {
        self.0.line()
    }
    /// 1-based column of the error (0 when serde could not tell).
    pub fn column(&self) -> usize {
        self.0.column()
    }
    /// Syntax, data, end of file or I/O.
    pub fn classify(&self) -> serde_json::error::Category {
        self.0.classify()
    }
    /// The underlying serde error.
    pub fn inner(&self) -> &serde_json::Error {
        &self.0
    }
}

impl From<serde_json::Error> for JsonError {
    fn from(e: serde_json::Error) -> Self {
        Self(Arc::new(e))
    }
}

impl PartialEq for JsonError {
    fn eq(&self, other: &Self) -> bool {
        self.0.to_string() == other.0.to_string()
    }
}

/// The most characters of a JSON error's message that [`JsonError`] prints (before
/// its position): serde quotes bad values whole, and a value may be megabytes long.
pub const MAX_JSON_MESSAGE_CHARS: usize = 2 * MAX_QUOTED_CHARS + 32;

impl fmt::Display for JsonError {
    /// serde's message cut to [`MAX_JSON_MESSAGE_CHARS`] (with `...`), then its
    /// position (`at line L column C`).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let text = self.0.to_string();
        let position = format!(" at line {} column {}", self.0.line(), self.0.column());
        let (message, position) = match text.strip_suffix(&position) {
            Some(message) if self.0.line() > 0 => (message, position.as_str()),
            _ => (text.as_str(), ""),
        };
        match message.char_indices().nth(MAX_JSON_MESSAGE_CHARS) {
            Some((end, _)) => write!(f, "{}...{position}", &message[..end]),
            None => write!(f, "{message}{position}"),
        }
    }
}

impl std::error::Error for JsonError {}

/// Displays an error and every [`source`](std::error::Error::source) below it on one
/// line, separated by `": "` (as `anyhow` does with `{:#}`), for libraries that log.
pub struct Chain<'a>(pub &'a (dyn std::error::Error + 'static));

impl fmt::Display for Chain<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)?;
        let mut next = self.0.source();
        while let Some(e) = next {
            write!(f, ": {e}")?;
            next = e.source();
        }
        Ok(())
    }
}
