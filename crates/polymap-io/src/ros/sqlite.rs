//! rosbag2's sqlite3 storage (`.db3`): tables `topics(id, name, type, serialization_format)`
//! and `messages(id, topic_id, timestamp, data)`, read in insertion order a page at a time.

use std::collections::{HashMap, VecDeque};
use std::path::{Path, PathBuf};

use rusqlite::{OpenFlags, params};

use super::error::RosError;
use super::source::{Connection, Encoding, MessageSource, Place, RawMessage, ReadLimits};

/// The first bytes of an SQLite database.
pub const SQLITE_MAGIC: &[u8] = b"SQLite format 3\0";
/// Rows fetched per query.
const PAGE_ROWS: i64 = 16;

/// One fetched row: id, connection, timestamp, data (empty unless of a decodable type).
type Row = (i64, usize, i64, Vec<u8>);

/// A reader of one rosbag2 `.db3` file, in message id (recording) order.
///
/// Only messages of `LaserScan`, `Odometry` and `TFMessage` topics
/// ([`Connection::is_decoded`](super::Connection::is_decoded)) have their data fetched; others are
/// counted with empty [`RawMessage::data`].
pub struct SqliteReader {
    db: rusqlite::Connection,
    path: PathBuf,
    connections: Vec<Connection>,
    topic_index: HashMap<i64, usize>,
    /// `CASE` expression that yields the data of decodable topics only.
    data_expr: String,
    limits: ReadLimits,
    page: VecDeque<Row>,
    last_id: i64,
    current: Vec<u8>,
    /// Connection and timestamp of the current message.
    found: (usize, i128),
    done: bool,
}

impl SqliteReader {
    /// Opens a `.db3` file read-only and reads its topics.
    pub fn open(path: &Path, limits: ReadLimits) -> Result<Self, RosError> {
        let flags = OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX;
        let db =
            rusqlite::Connection::open_with_flags(path, flags).map_err(|e| db_error(path, e))?;
        let mut connections = Vec::new();
        let mut topic_index = HashMap::new();
        {
            let mut stmt = db
                .prepare("SELECT id, name, type, serialization_format FROM topics ORDER BY id")
                .map_err(|e| db_error(path, e))?;
            let rows = stmt
                .query_map([], |r| {
                    Ok((
                        r.get::<_, i64>(0)?,
                        r.get::<_, String>(1)?,
                        r.get::<_, String>(2)?,
                        r.get::<_, String>(3)?,
                    ))
                })
                .map_err(|e| db_error(path, e))?;
            for row in rows {
                let (id, topic, type_name, format) = row.map_err(|e| db_error(path, e))?;
                topic_index.insert(id, connections.len());
                connections.push(Connection {
                    topic,
                    type_name,
                    encoding: Encoding::from_name(&format),
                });
            }
        }
        let decodable: Vec<String> = topic_index
            .iter()
            .filter(|&(_, &i)| connections[i].is_decoded())
            .map(|(id, _)| id.to_string())
            .collect();
        let data_expr = if decodable.is_empty() {
            "NULL".to_owned()
        } else {
            format!(
                "CASE WHEN topic_id IN ({}) THEN data END",
                decodable.join(",")
            )
        };
        Ok(SqliteReader {
            db,
            path: path.to_path_buf(),
            connections,
            topic_index,
            data_expr,
            limits,
            page: VecDeque::new(),
            last_id: i64::MIN,
            current: Vec::new(),
            found: (0, 0),
            done: false,
        })
    }

    fn fetch_page(&mut self) -> Result<(), RosError> {
        let sql = format!(
            "SELECT id, topic_id, timestamp, length(data), \
             CASE WHEN length(data) <= ?3 THEN {} END \
             FROM messages WHERE id > ?1 ORDER BY id LIMIT ?2",
            self.data_expr
        );
        let limit = i64::try_from(self.limits.max_record_bytes).unwrap_or(i64::MAX);
        let path = self.path.clone();
        let mut stmt = self.db.prepare(&sql).map_err(|e| db_error(&path, e))?;
        let rows = stmt
            .query_map(params![self.last_id, PAGE_ROWS, limit], |r| {
                Ok((
                    r.get::<_, i64>(0)?,
                    r.get::<_, i64>(1)?,
                    r.get::<_, i64>(2)?,
                    r.get::<_, Option<i64>>(3)?,
                    r.get::<_, Option<Vec<u8>>>(4)?,
                ))
            })
            .map_err(|e| db_error(&path, e))?;
        for row in rows {
            let (id, topic_id, stamp, len, data) = row.map_err(|e| db_error(&path, e))?;
            let &connection = self.topic_index.get(&topic_id).ok_or_else(|| {
                RosError::row(
                    &path,
                    id,
                    format!("message row {id} has unknown topic id {topic_id}"),
                )
            })?;
            if len.unwrap_or(0) > limit {
                return Err(RosError::row(
                    &path,
                    id,
                    format!(
                        "message row {id} holds {} bytes, more than the limit of {limit}",
                        len.unwrap_or(0)
                    ),
                ));
            }
            self.page
                .push_back((id, connection, stamp, data.unwrap_or_default()));
        }
        Ok(())
    }
}

impl MessageSource for SqliteReader {
    fn advance(&mut self) -> Result<bool, RosError> {
        if self.page.is_empty() && !self.done {
            self.fetch_page()?;
            self.done = self.page.is_empty();
        }
        let Some((id, connection, stamp, data)) = self.page.pop_front() else {
            return Ok(false);
        };
        self.last_id = id;
        self.current = data;
        self.found = (connection, i128::from(stamp));
        Ok(true)
    }

    fn current(&self) -> RawMessage<'_> {
        RawMessage {
            connection: self.found.0,
            data: &self.current,
            place: Place::Row(self.last_id),
            log_time_ns: self.found.1,
        }
    }

    fn connections(&self) -> &[Connection] {
        &self.connections
    }

    fn position(&self) -> u64 {
        0
    }

    fn skipped(&self) -> (u64, &[String]) {
        (0, &[])
    }
}

fn db_error(path: &Path, e: rusqlite::Error) -> RosError {
    RosError::Container {
        path: path.to_path_buf(),
        at: "database".into(),
        problem: format!("sqlite3: {e}"),
    }
}
