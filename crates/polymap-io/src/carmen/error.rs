//! What can go wrong reading or writing a CARMEN log.

use std::path::PathBuf;

/// An error of the CARMEN reader or writer, naming the file (and the 1-based line, if any).
#[derive(Debug, thiserror::Error)]
pub enum CarmenError {
    /// The file could not be opened, read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A value cannot be written so that it reads back (e.g. a non-finite pose).
    #[error("{}: cannot write: {reason}", path.display())]
    Unwritable {
        /// The file.
        path: PathBuf,
        /// What cannot be written.
        reason: String,
    },
    /// A line is not a well-formed message.
    #[error("{}:{line}: {problem}", path.display())]
    Malformed {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: u64,
        /// What is wrong with the line.
        problem: LineProblem,
    },
}

impl CarmenError {
    /// The 1-based line number of a malformed line, `None` for I/O errors.
    pub fn line(&self) -> Option<u64> {
        match self {
            CarmenError::Malformed { line, .. } => Some(*line),
            CarmenError::Io { .. } | CarmenError::Unwritable { .. } => None,
        }
    }
}

/// What is wrong with one line of a CARMEN log.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LineProblem {
    /// The line holds bytes that are not UTF-8.
    #[error("the line is not valid UTF-8")]
    NotUtf8,
    /// The line is longer than [`ReaderOptions::max_line_bytes`](super::ReaderOptions).
    #[error("the line is longer than {limit_bytes} bytes")]
    TooLong {
        /// The limit, bytes.
        limit_bytes: usize,
    },
    /// A field is missing: the line ends early.
    #[error("{message}: field `{field}` is missing (the line ends early)")]
    MissingField {
        /// Message type.
        message: &'static str,
        /// Name of the missing field.
        field: &'static str,
    },
    /// A field that must be a number is not one (or not a finite one where that is required).
    #[error("{message}: field `{field}` is not a valid number: `{token}`")]
    BadNumber {
        /// Message type.
        message: &'static str,
        /// Name of the field.
        field: &'static str,
        /// The offending token (shortened to 40 characters).
        token: String,
    },
    /// A count field (number of readings) is larger than the reader accepts.
    #[error("{message}: `{field}` = {value} exceeds the cap of {cap}")]
    CountTooLarge {
        /// Message type.
        message: &'static str,
        /// Name of the count field.
        field: &'static str,
        /// The value on the line.
        value: u64,
        /// The cap ([`ReaderOptions::max_beams`](super::ReaderOptions)).
        cap: usize,
    },
    /// A field has a value no laser can have.
    #[error("{message}: field `{field}`: {reason}")]
    BadGeometry {
        /// Message type.
        message: &'static str,
        /// Name of the field.
        field: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// The line has a different number of whitespace-separated tokens than its counts imply.
    #[error("{message}: expected {expected} tokens, found {found}")]
    TokenCount {
        /// Message type.
        message: &'static str,
        /// Tokens the message needs, given its counts.
        expected: usize,
        /// Tokens on the line.
        found: usize,
    },
}

/// Shortens a token for an error message, on a character boundary.
/// Control and escape characters are escaped (`\x1b`), so a message never carries them raw.
pub(crate) fn shorten(token: &str) -> String {
    const MAX_CHARS: usize = 40;
    let short = match token.char_indices().nth(MAX_CHARS) {
        Some((cut, _)) => format!("{}…", &token[..cut]),
        None => token.to_owned(),
    };
    crate::printable::printable(&short).into_owned()
}
