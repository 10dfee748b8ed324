//! MCAP through its summary: only the chunks that hold the topics asked for are read and
//! decompressed (the chunk indexes say which), in file order.

use std::collections::HashMap;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use mcap::sans_io::indexed_reader::{
    IndexedReadEvent, IndexedReader, IndexedReaderOptions, ReadOrder,
};
use mcap::sans_io::summary_reader::{SummaryReadEvent, SummaryReader, SummaryReaderOptions};

use mcap::Summary;

use super::error::RosError;
use super::source::{Connection, Encoding, MessageSource, Place, RawMessage, ReadLimits};
use super::survey::TopicSummary;

/// Reads the messages of some topics of an indexed MCAP file, skipping every chunk that holds
/// none of them without reading or decompressing it.
pub struct McapIndexedReader {
    file: File,
    path: PathBuf,
    reader: IndexedReader,
    connections: Vec<Connection>,
    channels: HashMap<u16, usize>,
    chunk: Vec<u8>,
    chunk_offset: u64,
    limit: usize,
    data: Vec<u8>,
    found: Option<(usize, i128)>,
    /// Bytes of chunks read so far.
    position: u64,
}

impl McapIndexedReader {
    /// Opens `path` for the messages of `topics`; `Ok(None)` when the file has no summary with
    /// chunk indexes (then only a linear read finds its messages).
    pub fn open(
        path: &Path,
        limits: ReadLimits,
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
        let channels = ids.iter().enumerate().map(|(i, &id)| (id, i)).collect();
        let options = IndexedReaderOptions::new()
            .with_order(ReadOrder::File)
            .include_topics(topics.to_vec())
            .with_record_length_limit(limit);
        let reader = IndexedReader::new_with_options(&summary, options)
            .map_err(|e| RosError::container(path, 0, format!("chunk indexes: {e}")))?;
        Ok(Some(McapIndexedReader {
            file,
            path: path.to_path_buf(),
            reader,
            connections,
            channels,
            chunk: Vec::new(),
            chunk_offset: 0,
            limit,
            data: Vec::new(),
            found: None,
            position: 0,
        }))
    }

    fn load_chunk(&mut self, offset: u64, length: usize) -> Result<(), RosError> {
        if length > self.limit {
            return Err(RosError::container(
                &self.path,
                offset,
                format!("a chunk of {length} bytes exceeds the limit"),
            ));
        }
        self.chunk.clear();
        self.file
            .seek(SeekFrom::Start(offset))
            .map_err(|e| RosError::io(&self.path, e))?;
        (&mut self.file)
            .take(length as u64)
            .read_to_end(&mut self.chunk)
            .map_err(|e| RosError::io(&self.path, e))?;
        if self.chunk.len() < length {
            return Err(RosError::container(
                &self.path,
                offset,
                "the file ends inside a chunk (truncated)",
            ));
        }
        self.chunk_offset = offset;
        self.position += length as u64;
        self.reader
            .insert_chunk_record_data(offset, &self.chunk)
            .map_err(|e| RosError::container(&self.path, offset, format!("bad chunk: {e}")))
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
            let event = match self.reader.next_event() {
                None => {
                    self.found = None;
                    return Ok(false);
                }
                Some(Err(e)) => {
                    return Err(RosError::container(
                        &self.path,
                        self.chunk_offset,
                        format!("{e}"),
                    ));
                }
                Some(Ok(event)) => event,
            };
            match event {
                IndexedReadEvent::ReadChunkRequest { offset, length } => {
                    self.load_chunk(offset, length)?;
                }
                IndexedReadEvent::Message { header, data } => {
                    let Some(&index) = self.channels.get(&header.channel_id) else {
                        continue;
                    };
                    self.data.clear();
                    self.data.extend_from_slice(data);
                    self.found = Some((index, i128::from(header.log_time)));
                    return Ok(true);
                }
            }
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
        (0, &[])
    }
}
