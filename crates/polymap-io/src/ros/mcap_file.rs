//! MCAP files (ROS 2's default storage since Iron): a streaming reader over the `mcap` crate's
//! sans-I/O linear reader, and a writer.

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::fs::File;
use std::io::{BufWriter, Read};
use std::path::{Path, PathBuf};

use mcap::McapError;
use mcap::records::{MessageHeader, op};
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};

use super::error::RosError;
use super::mcap_chunk::{ChunkPlace, ChunkRecord, chunk_records, chunk_span_ns, owned};
use super::messages::RosTime;
use super::source::{Connection, Encoding, MessageSource, Place, RawMessage, ReadLimits};
use super::typedefs::ros2_definition;

/// The first bytes of an MCAP file.
pub const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";
/// Largest read handed to the linear reader at once, bytes.
const READ_BYTES: usize = 1 << 20;

/// A streaming MCAP reader: records in file order, chunks decompressed one at a time (zstd
/// and lz4), memory bounded by the largest record ([`ReadLimits`]).
///
/// Each chunk's CRC, when it has one, is checked before any of its messages is handed out: a
/// damaged chunk is an error, or with `skip_bad` a counted skip naming the chunk and the time
/// span lost. A file that ends early (no footer, as a crashed recorder leaves it, or inside a
/// record) yields what comes before the cut, with a warning saying where the file ends.
///
/// Messages of types polymap does not decode (anything but `LaserScan`, `Odometry` and
/// `TFMessage`, [`Connection::is_decoded`]) are counted but not copied: their
/// [`RawMessage::data`] is empty.
pub struct McapReader {
    file: File,
    path: PathBuf,
    reader: LinearReader,
    limit: usize,
    skip_bad: bool,
    position: u64,
    /// Where the next record starts: the end of the last whole record read.
    records_end: u64,
    connections: Vec<Connection>,
    channels: HashMap<u16, usize>,
    schemas: HashMap<u16, String>,
    /// Records of the chunk being read, not yet handed out.
    pending: VecDeque<ChunkRecord>,
    chunks: u64,
    data: Vec<u8>,
    done: bool,
    skipped: (u64, Vec<String>),
    warnings: Vec<String>,
    /// The current message: connection, log time, offset of its record (or chunk).
    found: Option<(usize, i128, u64)>,
    /// Offset of the chunk whose records are pending.
    chunk_offset: u64,
    /// Whether the file ends with the magic bytes, as a whole file does: then a record that
    /// runs past the end is damage, not a cut.
    ends_with_magic: bool,
    /// The opcode of the last whole record read.
    last_opcode: u8,
    /// Whether the data section's end was read (what follows is the summary: no messages).
    data_ended: bool,
}

impl McapReader {
    /// Opens an MCAP file; `skip_bad` skips damaged chunks and records instead of failing.
    pub fn open(path: &Path, limits: ReadLimits, skip_bad: bool) -> Result<Self, RosError> {
        let mut file = crate::input_file::open_regular(path).map_err(|e| RosError::io(path, e))?;
        let ends_with_magic =
            ends_with(&mut file, MCAP_MAGIC).map_err(|e| RosError::io(path, e))?;
        let limit = usize::try_from(limits.max_record_bytes).unwrap_or(usize::MAX);
        // Chunks come whole and are checked on their own (`mcap_chunk`), so that a bad one can
        // be skipped and its messages are never handed out.
        let options = LinearReaderOptions::default()
            .with_record_length_limit(limit)
            .with_emit_chunks(true);
        Ok(McapReader {
            file,
            path: path.to_path_buf(),
            reader: LinearReader::new_with_options(options),
            limit,
            skip_bad,
            position: 0,
            records_end: MCAP_MAGIC.len() as u64,
            connections: Vec::new(),
            channels: HashMap::new(),
            schemas: HashMap::new(),
            pending: VecDeque::new(),
            chunks: 0,
            data: Vec::new(),
            done: false,
            skipped: (0, Vec::new()),
            warnings: Vec::new(),
            found: None,
            chunk_offset: 0,
            ends_with_magic,
            last_opcode: 0,
            data_ended: false,
        })
    }

    /// Adds a warning for the user (what was found odd before reading, such as a damaged
    /// summary read past).
    pub fn warn(&mut self, warning: String) {
        self.warnings.push(warning);
    }

    /// The next message record: its channel and log time, its data in `self.data`.
    fn step(&mut self) -> Result<Option<(usize, i128, u64)>, RosError> {
        loop {
            while let Some(record) = self.pending.pop_front() {
                let found = handle_record(
                    record,
                    &mut self.schemas,
                    &mut self.channels,
                    &mut self.connections,
                    &mut self.data,
                );
                if let Some((c, t)) = found {
                    return Ok(Some((c, t, self.chunk_offset)));
                }
            }
            if self.done {
                return Ok(None);
            }
            let event = match self.reader.next_event() {
                None => {
                    self.done = true;
                    return Ok(None);
                }
                Some(Err(e)) => {
                    self.done = true;
                    self.ended_early(e)?;
                    return Ok(None);
                }
                Some(Ok(event)) => event,
            };
            match event {
                LinearReadEvent::ReadRequest(n) => {
                    let buf = self.reader.insert(n.clamp(1, READ_BYTES));
                    let read = self
                        .file
                        .read(buf)
                        .map_err(|e| RosError::io(&self.path, e))?;
                    self.reader.notify_read(read);
                    self.position += read as u64;
                }
                LinearReadEvent::Record { data, opcode } => {
                    let offset = self.records_end;
                    self.records_end += 9 + data.len() as u64;
                    self.last_opcode = opcode;
                    self.data_ended |= opcode == op::DATA_END;
                    let records = if opcode == op::CHUNK {
                        self.chunks += 1;
                        let place = ChunkPlace {
                            number: self.chunks,
                            offset,
                            span_ns: chunk_span_ns(data),
                        };
                        chunk_records(data, self.limit).map_err(|e| (place.describe(), e))
                    } else {
                        mcap::parse_record(opcode, data)
                            .map(|r| owned(r).into_iter().collect())
                            .map_err(|e| (format!("the record at byte {offset}"), e.to_string()))
                    };
                    match records {
                        Ok(records) => {
                            self.pending = records.into();
                            self.chunk_offset = offset;
                        }
                        Err((what, problem)) => self.bad(offset, &what, &problem)?,
                    }
                }
            }
        }
    }

    /// A chunk or record that cannot be read: an error, or with `skip_bad` counted and named.
    fn bad(&mut self, offset: u64, what: &str, problem: &str) -> Result<(), RosError> {
        let message = format!("{what}: {problem}");
        if !self.skip_bad {
            return Err(RosError::container(&self.path, offset, message));
        }
        self.skipped.0 += 1;
        if self.skipped.1.len() < MAX_SKIP_MESSAGES {
            self.skipped
                .1
                .push(format!("{}: {message}: skipped", self.path.display()));
        }
        Ok(())
    }

    /// The reader stopped on `error`: a file that ends early (a recording cut off: it does not
    /// end with the magic bytes) ends the messages with a warning; anything else, a record
    /// that runs past the end of a whole file included, is an error (with `skip_bad`, a
    /// counted skip of the rest of the file).
    fn ended_early(&mut self, error: McapError) -> Result<(), RosError> {
        let size = self.position;
        let at = self.records_end;
        let rest = size.saturating_sub(at);
        let message = match error {
            McapError::UnexpectedEof if self.ends_with_magic => {
                let what = format!("the record at byte {at}");
                let problem = format!(
                    "it runs past the end of the file (byte {size}), though the file ends with \
                     MCAP's magic bytes as a whole file does: a damaged length; the rest of the \
                     file ({rest} bytes) cannot be read"
                );
                return self.bad(at, &what, &problem);
            }
            McapError::UnexpectedEof if at >= size && self.last_opcode == op::FOOTER => format!(
                "the file ends at byte {size} right after its footer, without the closing magic \
                 bytes: cut off after its last message; every message read"
            ),
            McapError::UnexpectedEof if at >= size => format!(
                "the file ends at byte {size} without its footer: a recording cut off (as a \
                 crashed recorder leaves it); read up to there"
            ),
            McapError::UnexpectedEof if self.data_ended => format!(
                "the file ends at byte {size}, inside its summary section (the record that \
                 starts at byte {at}): cut off after its last message; every message read"
            ),
            McapError::UnexpectedEof => format!(
                "the file ends at byte {size}, inside the record that starts at byte {at}: a \
                 recording cut off; read up to that record ({rest} bytes lost)"
            ),
            other if self.skip_bad => {
                let what = format!("the data after byte {at}");
                let problem = format!("{other}; the rest of the file ({rest} bytes) is not read");
                return self.bad(at, &what, &problem);
            }
            other => {
                return Err(RosError::container(
                    &self.path,
                    at,
                    format!("{other} (in the data read up to byte {size})"),
                ));
            }
        };
        self.warnings
            .push(format!("{}: {message}", self.path.display()));
        Ok(())
    }
}

/// Whether `file` ends with `magic` (its read position is left at the start).
fn ends_with(file: &mut File, magic: &[u8]) -> std::io::Result<bool> {
    use std::io::{Seek, SeekFrom};
    let size = file.metadata()?.len();
    let n = magic.len() as u64;
    let mut tail = vec![0u8; magic.len()];
    let whole = size >= 2 * n && {
        file.seek(SeekFrom::Start(size - n))?;
        file.read_exact(&mut tail)?;
        tail == magic
    };
    file.seek(SeekFrom::Start(0))?;
    Ok(whole)
}

/// Messages of skipped chunks and records kept for the report.
const MAX_SKIP_MESSAGES: usize = 10;

/// Takes in one record; returns the channel and log time of a message.
fn handle_record(
    record: ChunkRecord,
    schemas: &mut HashMap<u16, String>,
    channels: &mut HashMap<u16, usize>,
    connections: &mut Vec<Connection>,
    data: &mut Vec<u8>,
) -> Option<(usize, i128)> {
    match record {
        ChunkRecord::Schema { id, name } => {
            schemas.entry(id).or_insert(name);
            None
        }
        ChunkRecord::Channel {
            id,
            topic,
            schema_id,
            encoding,
        } => {
            if let std::collections::hash_map::Entry::Vacant(e) = channels.entry(id) {
                e.insert(connections.len());
                connections.push(Connection {
                    topic,
                    type_name: schemas.get(&schema_id).cloned().unwrap_or_default(),
                    encoding: Encoding::from_name(&encoding),
                });
            }
            None
        }
        ChunkRecord::Message {
            channel_id,
            log_time,
            data: bytes,
        } => {
            // A message of an undeclared channel is not ours to guess: it is counted nowhere.
            let &index = channels.get(&channel_id)?;
            let c = &connections[index];
            data.clear();
            if c.is_decoded() {
                data.extend_from_slice(&bytes);
            }
            Some((index, i128::from(log_time)))
        }
    }
}

impl MessageSource for McapReader {
    fn advance(&mut self) -> Result<bool, RosError> {
        self.found = self.step()?;
        Ok(self.found.is_some())
    }

    fn current(&self) -> RawMessage<'_> {
        let (connection, log_time_ns, offset) = self.found.unwrap_or((0, 0, self.position));
        RawMessage {
            connection,
            data: &self.data,
            place: Place::Byte(offset),
            log_time_ns,
        }
    }

    fn connections(&self) -> &[Connection] {
        &self.connections
    }

    fn position(&self) -> u64 {
        self.position
    }

    fn skipped(&self) -> (u64, &[String]) {
        (self.skipped.0, &self.skipped.1)
    }

    fn warnings(&self) -> &[String] {
        &self.warnings
    }
}

/// Chunk compression of an [`McapWriter`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum McapCompression {
    /// Uncompressed chunks.
    None,
    /// zstd chunks (what `ros2 bag record` writes by default when asked to compress).
    Zstd,
    /// LZ4 chunks.
    Lz4,
}

/// Writes a ROS 2 MCAP file (profile `ros2`, schemas `ros2msg`, messages `cdr`).
pub struct McapWriter {
    writer: mcap::Writer<BufWriter<File>>,
    path: PathBuf,
    sequence: u32,
    /// The last message's log time, nanoseconds.
    last_log_time: u64,
}

impl McapWriter {
    /// Creates (or truncates) an MCAP file.
    pub fn create(path: &Path, compression: McapCompression) -> Result<Self, RosError> {
        let file = File::create(path).map_err(|e| RosError::io(path, e))?;
        let compression = match compression {
            McapCompression::None => None,
            McapCompression::Zstd => Some(mcap::Compression::Zstd),
            McapCompression::Lz4 => Some(mcap::Compression::Lz4),
        };
        let writer = mcap::WriteOptions::new()
            .profile("ros2")
            .library("polymap-io")
            .compression(compression)
            .chunk_size(Some(256 * 1024))
            .create(BufWriter::new(file))
            .map_err(|e| mcap_error(path, e))?;
        Ok(McapWriter {
            writer,
            path: path.to_path_buf(),
            sequence: 0,
            last_log_time: 0,
        })
    }

    /// Declares a topic of `sensor_msgs/msg/LaserScan`, `nav_msgs/msg/Odometry` or
    /// `tf2_msgs/msg/TFMessage`; returns its channel id.
    pub fn add_channel(&mut self, topic: &str, type_name: &str) -> Result<u16, RosError> {
        let schema = self
            .writer
            .add_schema(type_name, "ros2msg", ros2_definition(type_name).as_bytes())
            .map_err(|e| mcap_error(&self.path, e))?;
        self.writer
            .add_channel(schema, topic, "cdr", &BTreeMap::new())
            .map_err(|e| mcap_error(&self.path, e))
    }

    /// Writes one CDR message, received (and published) at `time`.
    pub fn write(&mut self, channel: u16, time: RosTime, data: &[u8]) -> Result<(), RosError> {
        let nanos = u64::try_from(time.nanos()).unwrap_or(0);
        // The log time is when the message was recorded, which never goes back: a log whose
        // stamps do (Intel's, in places) keeps its order for readers that sort by log time.
        let log_time = nanos.max(self.last_log_time);
        self.last_log_time = log_time;
        self.sequence += 1;
        let header = MessageHeader {
            channel_id: channel,
            sequence: self.sequence,
            log_time,
            publish_time: nanos,
        };
        self.writer
            .write_to_known_channel(&header, data)
            .map_err(|e| mcap_error(&self.path, e))
    }

    /// Writes the summary and closes the file.
    pub fn finish(mut self) -> Result<(), RosError> {
        self.writer
            .finish()
            .map_err(|e| mcap_error(&self.path, e))?;
        Ok(())
    }
}

fn mcap_error(path: &Path, e: mcap::McapError) -> RosError {
    match e {
        mcap::McapError::Io(source) => RosError::io(path, source),
        other => RosError::container(path, 0, other.to_string()),
    }
}
