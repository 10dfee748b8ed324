//! Reading a bag record by record in file order, chunk by chunk, never through its index.

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use super::fields::{Fields, op};
use crate::ros::error::RosError;
use crate::ros::source::{Connection, Encoding, MessageSource, Place, RawMessage, ReadLimits};

/// The first bytes of a format 2.0 bag.
pub const BAG_MAGIC: &[u8] = b"#ROSBAG V2.0\n";

/// Largest record header accepted, bytes (headers hold a few short fields).
const MAX_HEADER_BYTES: u32 = 1 << 20;
/// How many skipped-part messages are kept.
const MAX_SKIP_MESSAGES: usize = 10;

/// A streaming reader of a ROS 1 bag (format 2.0): one record, or one decompressed chunk, in
/// memory at a time.
///
/// The index at the end of the file is never read: records are taken in file order, so a bag
/// whose index is wrong or missing (an unfinished recording) reads in full. Chunks may be
/// uncompressed, `bz2` or `lz4`.
pub struct BagReader {
    input: BufReader<File>,
    path: PathBuf,
    size: u64,
    /// File offset of the next record outside a chunk.
    offset: u64,
    /// The current decompressed chunk and the next position in it.
    chunk: Vec<u8>,
    chunk_pos: usize,
    /// File offset of the current chunk record.
    chunk_offset: u64,
    /// A message record read outside a chunk.
    loose: Vec<u8>,
    connections: Vec<Connection>,
    ids: HashMap<u32, usize>,
    limits: ReadLimits,
    skip_bad: bool,
    skipped: u64,
    /// What was read past: the file cut off, and where.
    warnings: Vec<String>,
    /// Where the bag header places the index (0 while a recorder writes the bag; `None`
    /// before the header is read).
    index_pos: Option<u64>,
    skip_messages: Vec<String>,
    /// The message the last `advance` found.
    found: Option<Found>,
}

/// Where the message found by one step is.
enum Found {
    InChunk {
        range: std::ops::Range<usize>,
        connection: usize,
        time_ns: i128,
    },
    Loose {
        connection: usize,
        offset: u64,
        time_ns: i128,
    },
}

/// One record header, as read.
struct RecordHead {
    offset: u64,
    header: Vec<u8>,
    data_len: u64,
}

impl BagReader {
    /// Opens a bag and checks its magic line; `skip_bad` skips damaged chunks (counted).
    pub fn open(path: &Path, limits: ReadLimits, skip_bad: bool) -> Result<Self, RosError> {
        let file = File::open(path).map_err(|e| RosError::io(path, e))?;
        let size = file.metadata().map_err(|e| RosError::io(path, e))?.len();
        let mut input = BufReader::with_capacity(1 << 16, file);
        let mut magic = [0u8; 13];
        input
            .read_exact(&mut magic)
            .map_err(|_| RosError::container(path, 0, "not a ROS bag (too short)"))?;
        if magic != BAG_MAGIC {
            return Err(RosError::Unsupported {
                path: path.to_path_buf(),
                what: "not a ROS 1 bag of format 2.0 (`#ROSBAG V2.0`)".into(),
            });
        }
        Ok(BagReader {
            input,
            path: path.to_path_buf(),
            size,
            offset: 13,
            chunk: Vec::new(),
            chunk_pos: 0,
            chunk_offset: 0,
            loose: Vec::new(),
            connections: Vec::new(),
            ids: HashMap::new(),
            limits,
            skip_bad,
            skipped: 0,
            warnings: Vec::new(),
            index_pos: None,
            skip_messages: Vec::new(),
            found: None,
        })
    }

    fn step(&mut self) -> Result<Option<Found>, RosError> {
        loop {
            if self.chunk_pos < self.chunk.len() {
                match self.chunk_record() {
                    Ok(Some(found)) => return Ok(Some(found)),
                    Ok(None) => {}
                    Err(e) => {
                        self.chunk_pos = self.chunk.len();
                        self.skip_or_fail(e)?;
                    }
                }
                continue;
            }
            let Some(head) = self.read_head()? else {
                return Ok(None);
            };
            if let Some(found) = self.file_record(head)? {
                return Ok(Some(found));
            }
        }
    }

    /// Reads the record header at `self.offset`; `None` at the end of the file, also where
    /// the file ends inside the record and the bag is unfinished (a recording cut off: said
    /// in [`Self::warnings`]; see [`Self::ran_off`]).
    fn read_head(&mut self) -> Result<Option<RecordHead>, RosError> {
        let offset = self.offset;
        if offset >= self.size {
            return Ok(None);
        }
        if offset + 4 > self.size {
            return self.ran_off(offset);
        }
        let header_len = self.read_u32(offset, "record header length")?;
        if header_len > MAX_HEADER_BYTES {
            return Err(self.truncated(offset, format!("record header of {header_len} bytes")));
        }
        if offset + 8 + u64::from(header_len) > self.size {
            return self.ran_off(offset);
        }
        let header = self.read_vec(offset, u64::from(header_len), "record header")?;
        let data_len = u64::from(self.read_u32(offset, "record data length")?);
        let end = offset + 8 + u64::from(header_len) + data_len;
        if end > self.size {
            return self.ran_off(offset);
        }
        self.offset = end;
        Ok(Some(RecordHead {
            offset,
            header,
            data_len,
        }))
    }

    /// Handles a record outside chunks.
    fn file_record(&mut self, head: RecordHead) -> Result<Option<Found>, RosError> {
        let fields = Fields::parse(&head.header)
            .map_err(|p| RosError::container(&self.path, head.offset, p))?;
        let opcode = fields
            .u8("op")
            .map_err(|p| RosError::container(&self.path, head.offset, p))?;
        match opcode {
            op::CHUNK => {
                let compression = fields.text("compression");
                let size = fields.u32("size");
                let (compression, size) = match (compression, size) {
                    (Ok(c), Ok(s)) => (c, s),
                    (Err(p), _) | (_, Err(p)) => {
                        return Err(RosError::container(&self.path, head.offset, p));
                    }
                };
                match self.read_chunk(&head, &compression, u64::from(size)) {
                    Ok(()) => {}
                    Err(e) => {
                        self.seek(self.offset)?;
                        self.skip_or_fail(e)?;
                    }
                }
                Ok(None)
            }
            op::CONNECTION => {
                let data = self.read_vec(head.offset, head.data_len, "connection")?;
                self.add_connection(&fields, &data, head.offset)?;
                Ok(None)
            }
            op::MESSAGE_DATA => {
                let (connection, time_ns) = self.message_head(&fields, head.offset)?;
                self.loose = self.read_vec(head.offset, head.data_len, "message")?;
                Ok(Some(Found::Loose {
                    connection,
                    offset: head.offset,
                    time_ns,
                }))
            }
            op::INDEX_DATA => {
                self.resync_after_index(&head, &fields)?;
                self.seek(self.offset)?;
                Ok(None)
            }
            op::BAG_HEADER => {
                let index_pos = fields
                    .require("index_pos")
                    .ok()
                    .and_then(|v| <[u8; 8]>::try_from(v).ok().map(u64::from_le_bytes));
                self.index_pos = Some(index_pos.unwrap_or(0));
                self.seek(self.offset)?;
                Ok(None)
            }
            // Chunk info and unknown records: not needed.
            _ => {
                self.seek(self.offset)?;
                Ok(None)
            }
        }
    }

    /// Index data records (version 1) hold `count` entries of 12 bytes. Some writers got the
    /// record's data length wrong (the Hokuyo demo bag says 20 bytes an entry): when the stated
    /// length leads nowhere and `count · 12` leads to a record, the reader continues there.
    fn resync_after_index(
        &mut self,
        head: &RecordHead,
        fields: &Fields<'_>,
    ) -> Result<(), RosError> {
        let (Ok(1), Ok(count)) = (fields.u32("ver"), fields.u32("count")) else {
            return Ok(());
        };
        let expected = u64::from(count) * 12;
        if expected == head.data_len {
            return Ok(());
        }
        let data_start = head.offset + 8 + head.header.len() as u64;
        let candidate = data_start + expected;
        if !self.looks_like_record(self.offset)? && self.looks_like_record(candidate)? {
            self.offset = candidate;
        }
        Ok(())
    }

    /// True when a well-formed record header starts at `at` (or `at` is the end of the file).
    fn looks_like_record(&mut self, at: u64) -> Result<bool, RosError> {
        if at == self.size {
            return Ok(true);
        }
        if at > self.size {
            return Ok(false);
        }
        self.seek(at)?;
        let mut len = [0u8; 4];
        if self.input.read_exact(&mut len).is_err() {
            return Ok(false);
        }
        let header_len = u64::from(u32::from_le_bytes(len));
        if header_len > 64 * 1024 || at + 8 + header_len > self.size {
            return Ok(false);
        }
        let mut header = vec![0u8; header_len as usize];
        if self.input.read_exact(&mut header).is_err() {
            return Ok(false);
        }
        Ok(Fields::parse(&header).is_ok_and(|f| f.u8("op").is_ok()))
    }

    /// Reads and decompresses a chunk record's data into `self.chunk`.
    fn read_chunk(
        &mut self,
        head: &RecordHead,
        compression: &str,
        size: u64,
    ) -> Result<(), RosError> {
        let at = head.offset;
        if size > self.limits.max_record_bytes || head.data_len > self.limits.max_record_bytes {
            return Err(RosError::container(
                &self.path,
                at,
                format!(
                    "a chunk of {size} bytes ({} compressed) exceeds the limit of {} bytes",
                    head.data_len, self.limits.max_record_bytes
                ),
            ));
        }
        self.chunk.clear();
        self.chunk_pos = 0;
        self.chunk_offset = at;
        let raw = (&mut self.input).take(head.data_len);
        let result = match compression {
            "none" => read_up_to(raw, size, &mut self.chunk),
            "bz2" => read_up_to(bzip2::read::BzDecoder::new(raw), size, &mut self.chunk),
            "lz4" => match lz4::Decoder::new(raw) {
                Ok(d) => read_up_to(d, size, &mut self.chunk),
                Err(e) => Err(e),
            },
            other => {
                return Err(RosError::container(
                    &self.path,
                    at,
                    format!("chunk compression `{other}` is not supported (none, bz2, lz4)"),
                ));
            }
        };
        let chunk_len = self.chunk.len() as u64;
        self.seek(self.offset)?;
        match result {
            Ok(()) if chunk_len == size => Ok(()),
            Ok(()) => Err(self.bad_chunk(
                at,
                format!("the chunk holds {chunk_len} bytes, its header says {size}"),
            )),
            Err(e) => Err(self.bad_chunk(at, format!("corrupt {compression} chunk: {e}"))),
        }
    }

    fn bad_chunk(&mut self, at: u64, problem: String) -> RosError {
        self.chunk.clear();
        RosError::container(&self.path, at, problem)
    }

    /// Handles the next record inside the current chunk.
    fn chunk_record(&mut self) -> Result<Option<Found>, RosError> {
        let at = self.chunk_offset;
        let inside = |p: String| format!("inside the chunk: {p}");
        let (header_range, data_range) = split_record(&self.chunk, self.chunk_pos)
            .map_err(|p| RosError::container(&self.path, at, inside(p)))?;
        self.chunk_pos = data_range.end;
        let chunk = std::mem::take(&mut self.chunk);
        let outcome = self.chunk_record_of(&chunk, header_range, data_range);
        self.chunk = chunk;
        outcome.map_err(|p| RosError::container(&self.path, at, inside(p)))
    }

    fn chunk_record_of(
        &mut self,
        chunk: &[u8],
        header: std::ops::Range<usize>,
        data: std::ops::Range<usize>,
    ) -> Result<Option<Found>, String> {
        let fields = Fields::parse(&chunk[header])?;
        match fields.u8("op")? {
            op::MESSAGE_DATA => {
                let (connection, time_ns) = self
                    .message_head(&fields, self.chunk_offset)
                    .map_err(|e| e.to_string())?;
                Ok(Some(Found::InChunk {
                    range: data,
                    connection,
                    time_ns,
                }))
            }
            op::CONNECTION => {
                self.add_connection(&fields, &chunk[data], self.chunk_offset)
                    .map_err(|e| e.to_string())?;
                Ok(None)
            }
            _ => Ok(None),
        }
    }

    /// The connection index and receive time of a message data record.
    fn message_head(&self, fields: &Fields<'_>, at: u64) -> Result<(usize, i128), RosError> {
        let problem = |p| RosError::container(&self.path, at, p);
        let id = fields.u32("conn").map_err(problem)?;
        let time = fields.require("time").map_err(problem)?;
        let time =
            <[u8; 8]>::try_from(time).map_err(|_| problem("`time` is not 8 bytes".into()))?;
        let sec = u32::from_le_bytes([time[0], time[1], time[2], time[3]]);
        let nsec = u32::from_le_bytes([time[4], time[5], time[6], time[7]]);
        let connection = *self.ids.get(&id).ok_or_else(|| {
            problem(format!(
                "a message of connection {id}, which no record declared before it"
            ))
        })?;
        Ok((
            connection,
            i128::from(sec) * 1_000_000_000 + i128::from(nsec),
        ))
    }

    fn add_connection(
        &mut self,
        fields: &Fields<'_>,
        data: &[u8],
        at: u64,
    ) -> Result<(), RosError> {
        let problem = |p| RosError::container(&self.path, at, p);
        let id = fields.u32("conn").map_err(problem)?;
        if self.ids.contains_key(&id) {
            return Ok(());
        }
        let topic = fields.text("topic").map_err(problem)?;
        let inner = Fields::parse(data).map_err(problem)?;
        let type_name = inner.text("type").map_err(problem)?;
        self.ids.insert(id, self.connections.len());
        self.connections.push(Connection {
            topic,
            type_name,
            encoding: Encoding::Ros1,
        });
        Ok(())
    }

    fn skip_or_fail(&mut self, e: RosError) -> Result<(), RosError> {
        if !self.skip_bad {
            return Err(e);
        }
        self.skipped += 1;
        if self.skip_messages.len() < MAX_SKIP_MESSAGES {
            self.skip_messages.push(e.to_string());
        }
        Ok(())
    }

    fn read_u32(&mut self, at: u64, what: &str) -> Result<u32, RosError> {
        let mut b = [0u8; 4];
        self.input
            .read_exact(&mut b)
            .map_err(|_| self.truncated(at, format!("the file ends inside the {what}")))?;
        Ok(u32::from_le_bytes(b))
    }

    /// Reads `len` bytes, growing the buffer only as bytes arrive.
    fn read_vec(&mut self, at: u64, len: u64, what: &str) -> Result<Vec<u8>, RosError> {
        if len > self.limits.max_record_bytes {
            return Err(RosError::container(
                &self.path,
                at,
                format!(
                    "a {what} of {len} bytes exceeds the limit of {} bytes",
                    self.limits.max_record_bytes
                ),
            ));
        }
        let mut out = Vec::new();
        (&mut self.input)
            .take(len)
            .read_to_end(&mut out)
            .map_err(|e| RosError::io(&self.path, e))?;
        if (out.len() as u64) < len {
            return Err(self.truncated(at, format!("the file ends inside the {what}")));
        }
        Ok(out)
    }

    fn seek(&mut self, to: u64) -> Result<(), RosError> {
        self.input
            .seek(SeekFrom::Start(to))
            .map(drop)
            .map_err(|e| RosError::io(&self.path, e))
    }

    /// The record at `offset` runs past the end of the file. That is a cut only where the
    /// bag is unfinished: its header places no index (0, as a recorder leaves it until it
    /// closes the bag) or one beyond the end of the file (a copy cut off); the messages before
    /// it are read and the cut said. A cut inside the index loses no message. In a whole bag
    /// (its index within the file, after this record) a record that runs past the end has a
    /// damaged length: an error, or with `skip_bad` a counted skip of the rest of the file.
    fn ran_off(&mut self, offset: u64) -> Result<Option<RecordHead>, RosError> {
        let (size, path) = (self.size, self.path.display());
        self.offset = size;
        let index_pos = self.index_pos.unwrap_or(0);
        if index_pos == 0 || index_pos >= size {
            self.warnings.push(format!(
                "{path}: the file ends at byte {size}, inside the record that starts at byte \
                 {offset}: a recording cut off (as a crashed recorder leaves it); read up to \
                 that record ({} bytes lost)",
                size - offset
            ));
            return Ok(None);
        }
        if offset >= index_pos {
            self.warnings.push(format!(
                "{path}: the file ends at byte {size}, inside its index (the record that starts \
                 at byte {offset}): cut off after its last message; every message read"
            ));
            return Ok(None);
        }
        let e = RosError::container(
            &self.path,
            offset,
            format!(
                "the record runs past the end of the file (byte {size}), though the bag is \
                 whole (its header places the index at byte {index_pos}): a damaged length; \
                 the rest of the file ({} bytes) cannot be read",
                size - offset
            ),
        );
        self.skip_or_fail(e)?;
        Ok(None)
    }

    fn truncated(&self, at: u64, problem: String) -> RosError {
        RosError::container(
            &self.path,
            at,
            format!("{problem} (truncated or not a bag)"),
        )
    }
}

/// Reads at most `size` bytes from `input` into `out` (a longer stream is cut, and caught by
/// the caller's length check only if shorter).
fn read_up_to(input: impl Read, size: u64, out: &mut Vec<u8>) -> std::io::Result<()> {
    let mut input = input.take(size + 1);
    input.read_to_end(out).map(drop)
}

/// The header and data ranges of the record starting at `pos` in `buf`.
fn split_record(
    buf: &[u8],
    pos: usize,
) -> Result<(std::ops::Range<usize>, std::ops::Range<usize>), String> {
    let u32_at = |at: usize| {
        buf.get(at..at.saturating_add(4))
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
            .ok_or_else(|| format!("a record at byte {pos} of the chunk is cut off"))
    };
    let header_len = u32_at(pos)?;
    let header_start = pos + 4;
    let header_end = header_start.saturating_add(header_len);
    let data_len = u32_at(header_end)?;
    let data_start = header_end + 4;
    let data_end = data_start.saturating_add(data_len);
    if data_end > buf.len() {
        return Err(format!(
            "a record at byte {pos} of the chunk claims {data_len} bytes, more than the chunk holds"
        ));
    }
    Ok((header_start..header_end, data_start..data_end))
}

impl MessageSource for BagReader {
    fn advance(&mut self) -> Result<bool, RosError> {
        self.found = self.step()?;
        Ok(self.found.is_some())
    }

    fn current(&self) -> RawMessage<'_> {
        match &self.found {
            Some(Found::InChunk {
                range,
                connection,
                time_ns,
            }) => RawMessage {
                connection: *connection,
                data: &self.chunk[range.clone()],
                place: Place::Byte(self.chunk_offset),
                log_time_ns: *time_ns,
            },
            Some(Found::Loose {
                connection,
                offset,
                time_ns,
            }) => RawMessage {
                connection: *connection,
                data: &self.loose,
                place: Place::Byte(*offset),
                log_time_ns: *time_ns,
            },
            None => RawMessage {
                connection: 0,
                data: &[],
                place: Place::Byte(self.offset),
                log_time_ns: 0,
            },
        }
    }

    fn connections(&self) -> &[Connection] {
        &self.connections
    }

    fn position(&self) -> u64 {
        self.offset
    }

    fn skipped(&self) -> (u64, &[String]) {
        (self.skipped, &self.skip_messages)
    }

    fn warnings(&self) -> &[String] {
        &self.warnings
    }
}
