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
/// it has one) before any of its messages is handed out ([`super::mcap_chunk`]).
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
    /// Opens `path` for the messages of `topics`; `Ok(None)` when the file has no summary with
    /// chunk indexes (then only a linear read finds its messages). `skip_bad` skips damaged
    /// chunks (counted and named) instead of failing.
    pub fn open(
        path: &Path,
        limits: ReadLimits,
        skip_bad: bool,
        topics: &[String],
    ) -> Result<Option<Self>, RosError> {
        let Some((summary, file)) = read_summary(path, limits)? else {
            return Ok(None);
        };
        let limit = usize::try_from(limits.max_record_bytes).unwrap_or(usize::MAX);
        if summary.chunk_indexes.is_empty() {
            return Ok(None);
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
        Ok(Some(McapIndexedReader {
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
        }))
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

/// Reads an MCAP file's summary section; `None` when it has none or it cannot be read. Returns
/// the open file too.
fn read_summary(path: &Path, limits: ReadLimits) -> Result<Option<(Summary, File)>, RosError> {
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
            return Ok(None);
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
    Ok(reader.finish().map(|summary| (summary, file)))
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
    let Some((summary, _)) = read_summary(path, limits)? else {
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
