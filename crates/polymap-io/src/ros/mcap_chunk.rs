//! One MCAP chunk read on its own: its CRC checked before any of its records is handed out,
//! so a damaged chunk is an error (or, skipping bad input, a counted skip) and never a source
//! of changed messages. Both MCAP readers (linear and indexed) read chunks through here.

use mcap::records::{Record, op};
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};

/// A record found inside a chunk, owned.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum ChunkRecord {
    /// A schema: its id and name.
    Schema {
        /// Schema id.
        id: u16,
        /// Type name.
        name: String,
    },
    /// A channel: its id, topic, schema and message encoding.
    Channel {
        /// Channel id.
        id: u16,
        /// Topic.
        topic: String,
        /// Schema id.
        schema_id: u16,
        /// Message encoding (`cdr`).
        encoding: String,
    },
    /// A message: its channel, log time and bytes.
    Message {
        /// Channel id.
        channel_id: u16,
        /// Log time, nanoseconds.
        log_time: u64,
        /// The serialized message.
        data: Vec<u8>,
    },
}

/// Where a chunk lies and what time it covers, for messages about it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ChunkPlace {
    /// 1-based number of the chunk among the file's chunks read so far.
    pub number: u64,
    /// Byte offset of the chunk record.
    pub offset: u64,
    /// Log times of its first and last message, nanoseconds.
    pub span_ns: (u64, u64),
}

impl ChunkPlace {
    /// `chunk 3 (byte 1234, log times 1.000 s to 2.500 s)`.
    pub(crate) fn describe(&self) -> String {
        let s = |ns: u64| ns as f64 * 1e-9;
        format!(
            "chunk {} (byte {}, log times {:.3} s to {:.3} s)",
            self.number,
            self.offset,
            s(self.span_ns.0),
            s(self.span_ns.1)
        )
    }
}

/// The log times a chunk record says it covers, from its header (message start and end
/// times come first in its body); `(0, 0)` when the body is too short to hold them.
pub(crate) fn chunk_span_ns(body: &[u8]) -> (u64, u64) {
    let word = |i: usize| {
        body.get(i..i + 8)
            .and_then(|b| b.try_into().ok())
            .map_or(0, u64::from_le_bytes)
    };
    (word(0), word(8))
}

/// The records of one chunk record (`body`, without its opcode and length), after its CRC
/// (when it has one) is checked; `limit` bounds its compressed and decompressed size.
pub(crate) fn chunk_records(body: &[u8], limit: usize) -> Result<Vec<ChunkRecord>, String> {
    let options = LinearReaderOptions::default()
        .with_skip_start_magic(true)
        .with_skip_end_magic(true)
        .with_prevalidate_chunk_crcs(true)
        .with_record_length_limit(limit);
    let mut reader = LinearReader::new_with_options(options);
    let mut fed = false;
    let mut out = Vec::new();
    while let Some(event) = reader.next_event() {
        match event.map_err(|e| e.to_string())? {
            LinearReadEvent::ReadRequest(_) if !fed => {
                // The chunk record as it stands in a file: opcode, length, body.
                let buf = reader.insert(9 + body.len());
                buf[0] = op::CHUNK;
                buf[1..9].copy_from_slice(&(body.len() as u64).to_le_bytes());
                buf[9..].copy_from_slice(body);
                reader.notify_read(9 + body.len());
                fed = true;
            }
            LinearReadEvent::ReadRequest(_) => reader.notify_read(0),
            LinearReadEvent::Record { data, opcode } => {
                let record = mcap::parse_record(opcode, data).map_err(|e| e.to_string())?;
                out.extend(owned(record));
            }
        }
    }
    Ok(out)
}

/// The parts of a record polymap uses, owned; `None` for other records.
pub(crate) fn owned(record: Record<'_>) -> Option<ChunkRecord> {
    match record {
        Record::Schema { header, .. } => Some(ChunkRecord::Schema {
            id: header.id,
            name: header.name,
        }),
        Record::Channel(c) => Some(ChunkRecord::Channel {
            id: c.id,
            topic: c.topic,
            schema_id: c.schema_id,
            encoding: c.message_encoding,
        }),
        Record::Message { header, data } => Some(ChunkRecord::Message {
            channel_id: header.channel_id,
            log_time: header.log_time,
            data: data.into_owned(),
        }),
        _ => None,
    }
}
