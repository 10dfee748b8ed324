//! MCAP through its summary: only the chunks that hold the topics asked for are read and
//! decompressed (the chunk indexes say which), in file order, each checked by its CRC.

use std::collections::{HashMap, VecDeque};
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use mcap::records::{ChunkIndex, op};
use mcap::sans_io::summary_reader::{SummaryReadEvent, SummaryReader, SummaryReaderOptions};

use mcap::Summary;

use super::error::RosError;
use super::mcap_chunk::{ChunkPlace, ChunkRecord, chunk_records};
use super::source::{Connection, Encoding, MessageSource, Place, RawMessage, ReadLimits};
use super::survey::TopicSummary;

/// Reads the messages of some topics of an indexed MCAP file, skipping every chunk that holds
/// none of them without reading or decompressing it. Each chunk read has its CRC checked (when
/// it has one) before any of its messages is handed out (module `mcap_chunk`).
pub struct McapIndexedReader {
    file: File,
    path: PathBuf,
    /// The chunks to read, in file order, with their number among all the file's chunks.
    chunks: VecDeque<(u64, ChunkIndex)>,
    connections: Vec<Connection>,
    channels: HashMap<u16, usize>,
    pending: VecDeque<ChunkRecord>,
    chunk_offset: u64,
    limit: usize,
    skip_bad: bool,
    skipped: (u64, Vec<String>),
    data: Vec<u8>,
    found: Option<(usize, i128)>,
    /// Bytes of chunks read so far.
    position: u64,
}

impl McapIndexedReader {
    /// Opens `path` for the messages of `topics`; [`Indexed::Linear`] when the file has no
    /// summary with chunk indexes, or a damaged one (then only a linear read finds its
    /// messages). `skip_bad` skips damaged chunks (counted and named) instead of failing.
    pub fn open(
        path: &Path,
        limits: ReadLimits,
        skip_bad: bool,
        topics: &[String],
    ) -> Result<Indexed, RosError> {
        let (summary, file) = match read_summary(path, limits)? {
            SummaryRead::Found(summary, file) => (summary, file),
            SummaryRead::Missing => return Ok(Indexed::Linear(None)),
            SummaryRead::Damaged(problem) => return Ok(Indexed::Linear(Some(problem))),
        };
        let limit = usize::try_from(limits.max_record_bytes).unwrap_or(usize::MAX);
        if summary.chunk_indexes.is_empty() {
            return Ok(Indexed::Linear(None));
        }
        let (ids, connections) = summary_connections(&summary);
        let channels: HashMap<u16, usize> =
            ids.iter().enumerate().map(|(i, &id)| (id, i)).collect();
        let wanted: Vec<u16> = ids
            .iter()
            .zip(&connections)
            .filter(|(_, c)| topics.contains(&c.topic))
            .map(|(&id, _)| id)
            .collect();
        let mut all = summary.chunk_indexes.clone();
        all.sort_by_key(|c| c.chunk_start_offset);
        // A chunk without message indexes may hold anything: it is read.
        let chunks = (1u64..)
            .zip(all)
            .filter(|(_, c)| {
                c.message_index_offsets.is_empty()
                    || c.message_index_offsets.keys().any(|id| wanted.contains(id))
            })
            .collect();
        Ok(Indexed::Reader(Box::new(McapIndexedReader {
            file,
            path: path.to_path_buf(),
            chunks,
            connections,
            channels: wanted
                .iter()
                .filter_map(|id| channels.get(id).map(|&i| (*id, i)))
                .collect(),
            pending: VecDeque::new(),
            chunk_offset: 0,
            limit,
            skip_bad,
            skipped: (0, Vec::new()),
            data: Vec::new(),
            found: None,
            position: 0,
        })))
    }

    /// Reads the chunk record `index` describes and takes in its records; a damaged chunk is
    /// an error, or with `skip_bad` counted and named.
    fn load_chunk(&mut self, number: u64, index: &ChunkIndex) -> Result<(), RosError> {
        let offset = index.chunk_start_offset;
        let place = ChunkPlace {
            number,
            offset,
            span_ns: (index.message_start_time, index.message_end_time),
        };
        let length = usize::try_from(index.chunk_length).unwrap_or(usize::MAX);
        if length > self.limit.saturating_add(1 << 10) || length < 9 {
            return self.bad(offset, &place, &format!("a chunk record of {length} bytes"));
        }
        let mut record = Vec::with_capacity(length);
        self.file
            .seek(SeekFrom::Start(offset))
            .map_err(|e| RosError::io(&self.path, e))?;
        (&mut self.file)
            .take(length as u64)
            .read_to_end(&mut record)
            .map_err(|e| RosError::io(&self.path, e))?;
        self.position += record.len() as u64;
        if record.len() < length {
            return self.bad(offset, &place, "the file ends inside the chunk (truncated)");
        }
        if record[0] != op::CHUNK {
            return self.bad(offset, &place, "the chunk index points at no chunk");
        }
        match chunk_records(&record[9..], self.limit) {
            Ok(records) => {
                self.pending = records.into();
                self.chunk_offset = offset;
                Ok(())
            }
            Err(problem) => self.bad(offset, &place, &problem),
        }
    }

    fn bad(&mut self, offset: u64, place: &ChunkPlace, problem: &str) -> Result<(), RosError> {
        let message = format!("{}: {problem}", place.describe());
        if !self.skip_bad {
            return Err(RosError::container(&self.path, offset, message));
        }
        self.skipped.0 += 1;
        if self.skipped.1.len() < 10 {
            self.skipped
                .1
                .push(format!("{}: {message}: skipped", self.path.display()));
        }
        Ok(())
    }
}

/// What [`McapIndexedReader::open`] found.
pub enum Indexed {
    /// The reader of the chunks that hold the topics.
    Reader(Box<McapIndexedReader>),
    /// No usable summary: the file is to be read linearly; with the problem found in a
    /// damaged summary, for a warning.
    Linear(Option<String>),
}

impl Indexed {
    /// The indexed reader, if the summary allows one.
    pub fn reader(self) -> Option<McapIndexedReader> {
        match self {
            Indexed::Reader(r) => Some(*r),
            Indexed::Linear(_) => None,
        }
    }
}

/// What [`read_summary`] found.
enum SummaryRead {
    /// The summary, checked, and the open file.
    Found(Box<Summary>, File),
    /// No summary (an unfinished recording, or one written without).
    Missing,
    /// A summary that fails its CRC or does not agree with itself: what is wrong.
    Damaged(String),
}

/// Size of the footer record (opcode, length, summary start, summary offset start, CRC).
const FOOTER_RECORD_BYTES: u64 = 1 + 8 + 8 + 8 + 4;

/// Reads an MCAP file's summary section and checks it: the footer's summary CRC where it has
/// one, and the statistics' chunk count against the chunk indexes. The `mcap` crate's summary
/// reader checks neither and passes over records it does not know, so one flipped bit in an
/// opcode would drop a chunk index, and with it a chunk, in silence.
fn read_summary(path: &Path, limits: ReadLimits) -> Result<SummaryRead, RosError> {
    let mut file = File::open(path).map_err(|e| RosError::io(path, e))?;
    let size = file.metadata().map_err(|e| RosError::io(path, e))?.len();
    let limit = usize::try_from(limits.max_record_bytes).unwrap_or(usize::MAX);
    let options = SummaryReaderOptions::default()
        .with_file_size(size)
        .with_record_length_limit(limit);
    let mut reader = SummaryReader::new_with_options(options);
    while let Some(event) = reader.next_event() {
        // A damaged or missing summary (an unfinished recording): the linear reader takes over.
        let Ok(event) = event else {
            return Ok(SummaryRead::Missing);
        };
        match event {
            SummaryReadEvent::ReadRequest(n) => {
                let buf = reader.insert(n.min(limit));
                let read = file.read(buf).map_err(|e| RosError::io(path, e))?;
                reader.notify_read(read);
            }
            SummaryReadEvent::SeekRequest(to) => {
                let at = file.seek(to).map_err(|e| RosError::io(path, e))?;
                reader.notify_seeked(at);
            }
        }
    }
    let Some(summary) = reader.finish() else {
        return Ok(SummaryRead::Missing);
    };
    if let Some(problem) =
        summary_crc_problem(&mut file, size).map_err(|e| RosError::io(path, e))?
    {
        return Ok(SummaryRead::Damaged(problem));
    }
    if let Some(stats) = &summary.stats
        && u64::from(stats.chunk_count) != summary.chunk_indexes.len() as u64
    {
        return Ok(SummaryRead::Damaged(format!(
            "the summary's statistics count {} chunks, its chunk indexes list {}",
            stats.chunk_count,
            summary.chunk_indexes.len()
        )));
    }
    Ok(SummaryRead::Found(Box::new(summary), file))
}

/// Checks the summary section against the footer's CRC (per the MCAP specification: over the
/// bytes from the summary's start through the footer's `summary_offset_start` field); `None`
/// when it matches or the footer carries none (a CRC of 0).
fn summary_crc_problem(file: &mut File, size: u64) -> std::io::Result<Option<String>> {
    let magic = super::mcap_file::MCAP_MAGIC.len() as u64;
    let Some(footer_at) = size.checked_sub(magic + FOOTER_RECORD_BYTES) else {
        return Ok(None);
    };
    let mut footer = [0u8; FOOTER_RECORD_BYTES as usize];
    file.seek(SeekFrom::Start(footer_at))?;
    file.read_exact(&mut footer)?;
    let u64_at = |at: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&footer[at..at + 8]);
        u64::from_le_bytes(b)
    };
    let summary_start = u64_at(9);
    let mut crc = [0u8; 4];
    crc.copy_from_slice(&footer[25..29]);
    let expected = u32::from_le_bytes(crc);
    if expected == 0 || summary_start == 0 || summary_start > footer_at {
        return Ok(None);
    }
    let end = size - magic - 4;
    file.seek(SeekFrom::Start(summary_start))?;
    let mut hasher = crc32fast::Hasher::new();
    let mut rest = file.take(end - summary_start);
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = rest.read(&mut buf)?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
    }
    let found = hasher.finalize();
    Ok((found != expected).then(|| {
        format!(
            "the summary section (bytes {summary_start} to {end}) fails its CRC (the footer says \
             {expected:08x}, the bytes give {found:08x})"
        )
    }))
}

/// The summary's channels in id order, as connections.
fn summary_connections(summary: &Summary) -> (Vec<u16>, Vec<Connection>) {
    let mut ids: Vec<u16> = summary.channels.keys().copied().collect();
    ids.sort_unstable();
    let connections = ids
        .iter()
        .map(|id| {
            let c = &summary.channels[id];
            Connection {
                topic: c.topic.clone(),
                type_name: c
                    .schema
                    .as_ref()
                    .map(|s| s.name.clone())
                    .unwrap_or_default(),
                encoding: Encoding::from_name(&c.message_encoding),
            }
        })
        .collect();
    (ids, connections)
}

/// The topics and their message counts from the summary's statistics, without reading the
/// data; `None` when the file has no summary or no per-channel counts.
pub fn summary_topics(
    path: &Path,
    limits: ReadLimits,
) -> Result<Option<Vec<TopicSummary>>, RosError> {
    let SummaryRead::Found(summary, _) = read_summary(path, limits)? else {
        return Ok(None);
    };
    let Some(stats) = &summary.stats else {
        return Ok(None);
    };
    if stats.channel_message_counts.is_empty() && stats.message_count > 0 {
        return Ok(None);
    }
    let (ids, connections) = summary_connections(&summary);
    Ok(Some(
        ids.iter()
            .zip(connections)
            .map(|(id, connection)| TopicSummary {
                connection,
                messages: stats.channel_message_counts.get(id).copied().unwrap_or(0),
                span_ns: None,
                stamps: None,
                laser: None,
            })
            .collect(),
    ))
}

impl MessageSource for McapIndexedReader {
    fn advance(&mut self) -> Result<bool, RosError> {
        loop {
            while let Some(record) = self.pending.pop_front() {
                let ChunkRecord::Message {
                    channel_id,
                    log_time,
                    data,
                } = record
                else {
                    continue;
                };
                let Some(&index) = self.channels.get(&channel_id) else {
                    continue;
                };
                self.data = data;
                self.found = Some((index, i128::from(log_time)));
                return Ok(true);
            }
            let Some((number, chunk)) = self.chunks.pop_front() else {
                self.found = None;
                return Ok(false);
            };
            self.load_chunk(number, &chunk)?;
        }
    }

    fn current(&self) -> RawMessage<'_> {
        let (connection, log_time_ns) = self.found.unwrap_or((0, 0));
        RawMessage {
            connection,
            data: &self.data,
            place: Place::Byte(self.chunk_offset),
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
}
