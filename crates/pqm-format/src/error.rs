//! Error types, split by fault as in the `png` crate: the input is bad
//! ([`FormatError`]), reading failed (`Io`), the input asks for more than the
//! caller's [`crate::Limits`] allow, the caller misused the API, or this
//! crate has a bug (`Internal`).

use std::fmt;

/// Where in the file a problem is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Section {
    /// The fixed header.
    Header,
    /// The chunk table.
    ChunkTable,
    /// The base mesh section.
    BaseMesh,
    /// Record chunk `i` (0-based).
    Chunk(u32),
    /// Optional section `i` (0-based) after the chunks.
    Optional(u32),
    /// Bytes after the last section.
    Trailer,
}

impl fmt::Display for Section {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Section::Header => write!(f, "header"),
            Section::ChunkTable => write!(f, "chunk table"),
            Section::BaseMesh => write!(f, "base mesh section"),
            Section::Chunk(i) => write!(f, "chunk {i}"),
            Section::Optional(i) => write!(f, "optional section {i}"),
            Section::Trailer => write!(f, "end of file"),
        }
    }
}

/// The input is not a valid `.pqm` file.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FormatError {
    /// The first 8 bytes are not the `.pqm` signature.
    #[error("bad magic bytes: not a .pqm file")]
    BadMagic,
    /// A major version this decoder cannot read.
    #[error("unsupported .pqm version {major}.{minor} (this decoder reads 1.x to {supported}.x)")]
    UnsupportedVersion {
        /// Major version in the file.
        major: u16,
        /// Minor version in the file.
        minor: u16,
        /// Newest major version this decoder reads (it reads 1 to this).
        supported: u16,
    },
    /// Stored and computed CRC-32 differ.
    #[error("CRC mismatch in {section}: stored {stored:#010x}, computed {computed:#010x}")]
    CrcMismatch {
        /// Section whose bytes are damaged.
        section: Section,
        /// CRC stored in the file.
        stored: u32,
        /// CRC of the bytes received.
        computed: u32,
    },
    /// A structural problem in a section.
    #[error("{section}: {message}")]
    Invalid {
        /// Section with the problem.
        section: Section,
        /// What is wrong.
        message: String,
    },
    /// A record that cannot be decoded or applied.
    #[error("record {record} (chunk {chunk}): {message}")]
    BadRecord {
        /// Chunk holding the record.
        chunk: u32,
        /// Record index in the whole file (level `record + 1` needs it).
        record: u32,
        /// What is wrong.
        message: String,
    },
    /// The input ended before the file was complete (only from the
    /// whole-file helpers; the push decoder just waits for more bytes).
    #[error("truncated file: {0}")]
    Truncated(String),
}

/// Errors of the decoder.
#[derive(Debug, thiserror::Error)]
pub enum DecodeError {
    /// The input is not a valid `.pqm` file.
    #[error("invalid .pqm data: {0}")]
    Format(#[from] FormatError),
    /// Reading the input failed.
    #[error("I/O error while reading .pqm data: {0}")]
    Io(#[from] std::io::Error),
    /// The file claims more than the [`crate::Limits`] allow (checked from
    /// the header and chunk table, before allocating).
    #[error("limits exceeded: {0}")]
    LimitsExceeded(String),
    /// The caller asked for something the decoder cannot do in its state.
    #[error("invalid decoder use: {0}")]
    Parameter(String),
    /// A bug in this crate (please report it).
    #[error("internal error (bug in pqm-format): {0}")]
    Internal(String),
}

impl DecodeError {
    /// The same error again (`std::io::Error` is not `Clone`: an I/O error
    /// keeps its kind and message).
    pub(crate) fn duplicate(&self) -> DecodeError {
        match self {
            DecodeError::Format(e) => DecodeError::Format(e.clone()),
            DecodeError::Io(e) => DecodeError::Io(std::io::Error::new(e.kind(), e.to_string())),
            DecodeError::LimitsExceeded(m) => DecodeError::LimitsExceeded(m.clone()),
            DecodeError::Parameter(m) => DecodeError::Parameter(m.clone()),
            DecodeError::Internal(m) => DecodeError::Internal(m.clone()),
        }
    }

    pub(crate) fn invalid(section: Section, message: impl Into<String>) -> Self {
        DecodeError::Format(FormatError::Invalid {
            section,
            message: message.into(),
        })
    }
}

/// Errors of the encoder.
#[derive(Debug, thiserror::Error)]
pub enum EncodeError {
    /// The progressive mesh does not validate (see `ProgressiveMesh::validate`)
    /// or cannot be represented (counts beyond `u32`, non-finite extent).
    #[error("cannot encode this progressive mesh: {0}")]
    InvalidMesh(String),
    /// Bad [`crate::EncodeOptions`].
    #[error("invalid encode options: {0}")]
    InvalidOptions(String),
    /// Writing failed, or zstd reported an error.
    #[error("I/O error while writing .pqm data: {0}")]
    Io(#[from] std::io::Error),
    /// The encoder contradicted itself: a bug in this crate, not in the
    /// input.
    #[error("internal error in the .pqm encoder (please report it): {0}")]
    Internal(String),
}
