//! What can go wrong reading a ROS recording.

use std::path::PathBuf;

/// An error of a ROS reader or writer, naming the file and where in it.
#[derive(Debug, thiserror::Error)]
pub enum RosError {
    /// The file could not be opened, read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The container is damaged or not what it claims (a truncated record, a corrupt chunk).
    #[error("{}: {at}: {problem}", path.display())]
    Container {
        /// The file.
        path: PathBuf,
        /// Where: `byte N` (offset of the record), or `row N` in a database.
        at: String,
        /// What is wrong.
        problem: String,
    },
    /// One message cannot be decoded.
    #[error("{}: topic {topic}, message {index} ({at}): {problem}", path.display())]
    Message {
        /// The file.
        path: PathBuf,
        /// The message's topic.
        topic: String,
        /// 1-based index of the message on its topic.
        index: u64,
        /// Where: `byte N` (its record, or its chunk's), or `row N` in a database.
        at: String,
        /// What is wrong.
        problem: MessageProblem,
    },
    /// The topics do not allow the run asked for (none, several, or a missing one).
    #[error("{}: {problem}", path.display())]
    Topics {
        /// The file.
        path: PathBuf,
        /// What is wrong, with the topics found.
        problem: String,
    },
    /// Not a recording this reader understands.
    #[error("{}: {what}", path.display())]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// What is not supported.
        what: String,
    },
}

impl RosError {
    /// A container problem at `offset`.
    pub(crate) fn container(
        path: &std::path::Path,
        offset: u64,
        problem: impl Into<String>,
    ) -> Self {
        RosError::Container {
            path: path.to_path_buf(),
            at: format!("byte {offset}"),
            problem: problem.into(),
        }
    }

    /// A problem at database row `row`.
    pub(crate) fn row(path: &std::path::Path, row: i64, problem: impl Into<String>) -> Self {
        RosError::Container {
            path: path.to_path_buf(),
            at: format!("row {row}"),
            problem: problem.into(),
        }
    }

    /// An I/O error on `path`.
    pub(crate) fn io(path: &std::path::Path, source: std::io::Error) -> Self {
        RosError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// What is wrong with one serialized message.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MessageProblem {
    /// The message ends inside a field.
    #[error("the message ends inside `{field}` (at byte {offset})")]
    Truncated {
        /// The field.
        field: &'static str,
        /// Byte offset in the message.
        offset: usize,
    },
    /// A sequence or string length does not fit in the message.
    #[error("`{field}` claims {count} elements, more than the {remaining} bytes left hold")]
    CountTooLarge {
        /// The field.
        field: &'static str,
        /// The count in the message.
        count: u32,
        /// Bytes left in the message.
        remaining: usize,
    },
    /// The CDR encapsulation is not plain CDR (`00 00` or `00 01`).
    #[error("unsupported CDR encapsulation {:02x} {:02x} (only plain CDR, either byte order)", .0[0], .0[1])]
    Encapsulation([u8; 2]),
    /// A string is not UTF-8, or (CDR) lacks its terminating NUL.
    #[error("`{field}` is not a valid string")]
    BadString {
        /// The field.
        field: &'static str,
    },
    /// Bytes are left after the last field: the message is of another type or definition.
    #[error("{bytes} bytes left after the last field: not this message type")]
    TrailingBytes {
        /// Bytes left over.
        bytes: usize,
    },
    /// A value makes no sense (a non-finite angle, a non-positive maximum range).
    #[error("`{field}` = {value} is not valid")]
    BadValue {
        /// The field.
        field: &'static str,
        /// The value.
        value: f64,
    },
    /// The laser's geometry cannot be a laser's (the CARMEN reader refuses the same).
    #[error("`{field}`: {reason}")]
    BadGeometry {
        /// The field.
        field: &'static str,
        /// Why, with the figures.
        reason: String,
    },
    /// The message's encoding is not one polymap decodes.
    #[error("message encoding `{0}` is not supported (only `cdr` and `ros1`)")]
    Encoding(String),
}
