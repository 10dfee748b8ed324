//! Writing a ROS 1 bag (format 2.0) with chunks and a full index, as `rosbag` writes it.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use super::fields::{op, push_field, push_record};
use super::reader::BAG_MAGIC;
use crate::ros::error::RosError;
use crate::ros::messages::RosTime;
use crate::ros::typedefs::definition;

/// How a [`BagWriter`] compresses its chunks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BagCompression {
    /// Uncompressed chunks.
    None,
    /// bzip2 chunks.
    Bz2,
    /// LZ4 frame chunks.
    Lz4,
}

impl BagCompression {
    fn name(self) -> &'static str {
        match self {
            BagCompression::None => "none",
            BagCompression::Bz2 => "bz2",
            BagCompression::Lz4 => "lz4",
        }
    }
}

/// The bag header record is padded to this many bytes, so it can be rewritten in place.
const BAG_HEADER_BYTES: usize = 4096;
/// A chunk is closed once its uncompressed records reach this size, bytes.
const CHUNK_BYTES: usize = 768 * 1024;

/// One connection: topic and type.
struct Conn {
    topic: String,
    type_name: String,
}

/// What the index needs of a written chunk.
struct ChunkInfo {
    position: u64,
    start: RosTime,
    end: RosTime,
    counts: BTreeMap<u32, u32>,
}

/// Writes a ROS 1 bag: messages go into chunks (compressed as asked), each chunk followed by
/// its index data, and the file ends with the connection and chunk info records that readers
/// such as `rosbag` and `rosbags` need.
pub struct BagWriter {
    out: BufWriter<File>,
    path: PathBuf,
    compression: BagCompression,
    position: u64,
    conns: Vec<Conn>,
    conn_in_chunk: Vec<bool>,
    chunk: Vec<u8>,
    chunk_index: BTreeMap<u32, Vec<(RosTime, u32)>>,
    chunk_span: Option<(RosTime, RosTime)>,
    infos: Vec<ChunkInfo>,
}

impl BagWriter {
    /// Creates (or truncates) a bag file.
    pub fn create(path: &Path, compression: BagCompression) -> Result<Self, RosError> {
        let file = File::create(path).map_err(|e| RosError::io(path, e))?;
        let mut w = BagWriter {
            out: BufWriter::new(file),
            path: path.to_path_buf(),
            compression,
            position: 0,
            conns: Vec::new(),
            conn_in_chunk: Vec::new(),
            chunk: Vec::new(),
            chunk_index: BTreeMap::new(),
            chunk_span: None,
            infos: Vec::new(),
        };
        w.emit(BAG_MAGIC)?;
        let header = w.bag_header(0);
        w.emit(&header)?;
        Ok(w)
    }

    /// Declares a topic of a type polymap knows (`sensor_msgs/LaserScan`, `nav_msgs/Odometry`
    /// or `tf2_msgs/TFMessage`); returns its connection id.
    pub fn add_connection(&mut self, topic: &str, type_name: &str) -> u32 {
        self.conns.push(Conn {
            topic: topic.to_owned(),
            type_name: type_name.to_owned(),
        });
        self.conn_in_chunk.push(false);
        (self.conns.len() - 1) as u32
    }

    /// Writes one message (ROS 1 serialized) of connection `conn` received at `time`.
    pub fn write(&mut self, conn: u32, time: RosTime, data: &[u8]) -> Result<(), RosError> {
        let index = conn as usize;
        if index >= self.conns.len() {
            return Err(RosError::container(
                &self.path,
                self.position,
                format!("unknown connection {conn}"),
            ));
        }
        if !self.conn_in_chunk[index] {
            let record = self.connection_record(conn);
            self.chunk.extend_from_slice(&record);
            self.conn_in_chunk[index] = true;
        }
        let offset = self.chunk.len() as u32;
        let mut header = Vec::new();
        push_field(&mut header, "op", &[op::MESSAGE_DATA]);
        push_field(&mut header, "conn", &conn.to_le_bytes());
        push_field(&mut header, "time", &time_bytes(time));
        push_record(&mut self.chunk, &header, data);
        self.chunk_index
            .entry(conn)
            .or_default()
            .push((time, offset));
        self.chunk_span = Some(match self.chunk_span {
            None => (time, time),
            Some((a, b)) => (a.min(time), b.max(time)),
        });
        if self.chunk.len() >= CHUNK_BYTES {
            self.flush_chunk()?;
        }
        Ok(())
    }

    /// Writes the last chunk and the index, and rewrites the bag header to point at it.
    pub fn finish(mut self) -> Result<(), RosError> {
        self.flush_chunk()?;
        let index_pos = self.position;
        for conn in 0..self.conns.len() as u32 {
            let record = self.connection_record(conn);
            self.emit(&record)?;
        }
        let infos = std::mem::take(&mut self.infos);
        for info in &infos {
            let mut header = Vec::new();
            push_field(&mut header, "op", &[op::CHUNK_INFO]);
            push_field(&mut header, "ver", &1u32.to_le_bytes());
            push_field(&mut header, "chunk_pos", &info.position.to_le_bytes());
            push_field(&mut header, "start_time", &time_bytes(info.start));
            push_field(&mut header, "end_time", &time_bytes(info.end));
            push_field(
                &mut header,
                "count",
                &(info.counts.len() as u32).to_le_bytes(),
            );
            let mut data = Vec::new();
            for (conn, count) in &info.counts {
                data.extend_from_slice(&conn.to_le_bytes());
                data.extend_from_slice(&count.to_le_bytes());
            }
            let mut record = Vec::new();
            push_record(&mut record, &header, &data);
            self.emit(&record)?;
        }
        self.infos = infos;
        let header = self.bag_header(index_pos);
        self.out
            .seek(SeekFrom::Start(BAG_MAGIC.len() as u64))
            .and_then(|_| self.out.write_all(&header))
            .and_then(|_| self.out.flush())
            .map_err(|e| RosError::io(&self.path, e))
    }

    fn flush_chunk(&mut self) -> Result<(), RosError> {
        let Some((start, end)) = self.chunk_span.take() else {
            return Ok(());
        };
        let raw = std::mem::take(&mut self.chunk);
        let data = compress(&raw, self.compression).map_err(|e| RosError::io(&self.path, e))?;
        let mut header = Vec::new();
        push_field(&mut header, "op", &[op::CHUNK]);
        push_field(
            &mut header,
            "compression",
            self.compression.name().as_bytes(),
        );
        push_field(&mut header, "size", &(raw.len() as u32).to_le_bytes());
        let mut record = Vec::new();
        push_record(&mut record, &header, &data);
        let position = self.position;
        self.emit(&record)?;
        let index = std::mem::take(&mut self.chunk_index);
        let mut counts = BTreeMap::new();
        for (conn, entries) in &index {
            let mut header = Vec::new();
            push_field(&mut header, "op", &[op::INDEX_DATA]);
            push_field(&mut header, "ver", &1u32.to_le_bytes());
            push_field(&mut header, "conn", &conn.to_le_bytes());
            push_field(&mut header, "count", &(entries.len() as u32).to_le_bytes());
            let mut data = Vec::new();
            for (time, offset) in entries {
                data.extend_from_slice(&time_bytes(*time));
                data.extend_from_slice(&offset.to_le_bytes());
            }
            let mut record = Vec::new();
            push_record(&mut record, &header, &data);
            self.emit(&record)?;
            counts.insert(*conn, entries.len() as u32);
        }
        self.infos.push(ChunkInfo {
            position,
            start,
            end,
            counts,
        });
        self.conn_in_chunk.iter_mut().for_each(|c| *c = false);
        Ok(())
    }

    fn connection_record(&self, conn: u32) -> Vec<u8> {
        let c = &self.conns[conn as usize];
        let mut header = Vec::new();
        push_field(&mut header, "op", &[op::CONNECTION]);
        push_field(&mut header, "conn", &conn.to_le_bytes());
        push_field(&mut header, "topic", c.topic.as_bytes());
        let (md5, text) = definition(&c.type_name);
        let mut data = Vec::new();
        push_field(&mut data, "topic", c.topic.as_bytes());
        push_field(&mut data, "type", c.type_name.as_bytes());
        push_field(&mut data, "md5sum", md5.as_bytes());
        push_field(&mut data, "message_definition", text.as_bytes());
        let mut record = Vec::new();
        push_record(&mut record, &header, &data);
        record
    }

    fn bag_header(&self, index_pos: u64) -> Vec<u8> {
        let mut header = Vec::new();
        push_field(&mut header, "op", &[op::BAG_HEADER]);
        push_field(&mut header, "index_pos", &index_pos.to_le_bytes());
        push_field(
            &mut header,
            "conn_count",
            &(self.conns.len() as u32).to_le_bytes(),
        );
        push_field(
            &mut header,
            "chunk_count",
            &(self.infos.len() as u32).to_le_bytes(),
        );
        let padding = vec![b' '; BAG_HEADER_BYTES - header.len() - 8];
        let mut record = Vec::new();
        push_record(&mut record, &header, &padding);
        record
    }

    fn emit(&mut self, bytes: &[u8]) -> Result<(), RosError> {
        self.out
            .write_all(bytes)
            .map_err(|e| RosError::io(&self.path, e))?;
        self.position += bytes.len() as u64;
        Ok(())
    }
}

fn time_bytes(t: RosTime) -> [u8; 8] {
    let mut b = [0u8; 8];
    b[..4].copy_from_slice(&(t.sec as u32).to_le_bytes());
    b[4..].copy_from_slice(&t.nanosec.to_le_bytes());
    b
}

fn compress(raw: &[u8], compression: BagCompression) -> std::io::Result<Vec<u8>> {
    match compression {
        BagCompression::None => Ok(raw.to_vec()),
        BagCompression::Bz2 => {
            let mut e = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::default());
            e.write_all(raw)?;
            e.finish()
        }
        BagCompression::Lz4 => {
            let mut e = lz4::EncoderBuilder::new().build(Vec::new())?;
            e.write_all(raw)?;
            let (out, result) = e.finish();
            result.map(|_| out)
        }
    }
}
