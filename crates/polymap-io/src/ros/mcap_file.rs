//! MCAP files (ROS 2's default storage since Iron): a streaming reader over the `mcap` crate's
//! sans-I/O linear reader, and a writer.

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufWriter, Read};
use std::path::{Path, PathBuf};

use mcap::records::{MessageHeader, Record};
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};

use super::error::RosError;
use super::messages::RosTime;
use super::source::{Connection, Encoding, MessageSource, Place, RawMessage, ReadLimits};
use super::typedefs::ros2_definition;

/// The first bytes of an MCAP file.
pub const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";
/// Largest read handed to the linear reader at once, bytes.
const READ_BYTES: usize = 1 << 20;

/// A streaming MCAP reader: records in file order, chunks decompressed one piece at a time
/// (zstd and lz4), memory bounded by the largest record ([`ReadLimits`]).
///
/// Messages of types polymap does not decode (anything but `LaserScan` and `Odometry`) are
/// counted but not copied: their [`RawMessage::data`] is empty.
pub struct McapReader {
    file: File,
    path: PathBuf,
    reader: LinearReader,
    position: u64,
    connections: Vec<Connection>,
    channels: HashMap<u16, usize>,
    schemas: HashMap<u16, String>,
    data: Vec<u8>,
    done: bool,
    /// The current message: connection, log time, bytes read before it was found.
    found: Option<(usize, i128, u64)>,
}

impl McapReader {
    /// Opens an MCAP file.
    pub fn open(path: &Path, limits: ReadLimits) -> Result<Self, RosError> {
        let file = File::open(path).map_err(|e| RosError::io(path, e))?;
        let limit = usize::try_from(limits.max_record_bytes).unwrap_or(usize::MAX);
        let options = LinearReaderOptions::default()
            .with_record_length_limit(limit)
            .with_validate_chunk_crcs(true);
        Ok(McapReader {
            file,
            path: path.to_path_buf(),
            reader: LinearReader::new_with_options(options),
            position: 0,
            connections: Vec::new(),
            channels: HashMap::new(),
            schemas: HashMap::new(),
            data: Vec::new(),
            done: false,
            found: None,
        })
    }

    /// The next message record: its channel and log time, its data in `self.data`.
    fn step(&mut self) -> Result<Option<(usize, i128)>, RosError> {
        loop {
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
                    return Err(RosError::container(
                        &self.path,
                        self.position,
                        format!("{e} (in the data read up to this byte)"),
                    ));
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
                    let record = mcap::parse_record(opcode, data).map_err(|e| {
                        RosError::container(&self.path, self.position, format!("bad record: {e}"))
                    });
                    let found = match record {
                        Ok(r) => handle_record(
                            r,
                            &mut self.schemas,
                            &mut self.channels,
                            &mut self.connections,
                            &mut self.data,
                        ),
                        Err(e) => {
                            self.done = true;
                            return Err(e);
                        }
                    };
                    if let Some(found) = found {
                        return Ok(Some(found));
                    }
                }
            }
        }
    }
}

/// Takes in one record; returns the channel and log time of a message.
fn handle_record(
    record: Record<'_>,
    schemas: &mut HashMap<u16, String>,
    channels: &mut HashMap<u16, usize>,
    connections: &mut Vec<Connection>,
    data: &mut Vec<u8>,
) -> Option<(usize, i128)> {
    match record {
        Record::Schema { header, .. } => {
            schemas.entry(header.id).or_insert(header.name);
            None
        }
        Record::Channel(c) => {
            if let std::collections::hash_map::Entry::Vacant(e) = channels.entry(c.id) {
                e.insert(connections.len());
                connections.push(Connection {
                    topic: c.topic,
                    type_name: schemas.get(&c.schema_id).cloned().unwrap_or_default(),
                    encoding: Encoding::from_name(&c.message_encoding),
                });
            }
            None
        }
        Record::Message {
            header,
            data: bytes,
        } => {
            // A message of an undeclared channel is not ours to guess: it is counted nowhere.
            let &index = channels.get(&header.channel_id)?;
            let c = &connections[index];
            data.clear();
            if c.is_laser_scan() || c.is_odometry() {
                data.extend_from_slice(&bytes);
            }
            Some((index, i128::from(header.log_time)))
        }
        _ => None,
    }
}

impl MessageSource for McapReader {
    fn advance(&mut self) -> Result<bool, RosError> {
        let offset = self.position;
        self.found = self.step()?.map(|(c, t)| (c, t, offset));
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
        (0, &[])
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
        })
    }

    /// Declares a topic of `sensor_msgs/msg/LaserScan` or `nav_msgs/msg/Odometry`; returns its
    /// channel id.
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
        self.sequence += 1;
        let header = MessageHeader {
            channel_id: channel,
            sequence: self.sequence,
            log_time: nanos,
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
