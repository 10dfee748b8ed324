//! What a recording holds: its topics with types, message counts and time spans, and the
//! geometry of each laser topic (from its first decodable message).

use super::error::RosError;
use super::messages::{LaserScanMsg, RosTime};
use super::source::{Connection, MessageSource};

/// The geometry of a laser topic, from its first message.
#[derive(Debug, Clone, PartialEq)]
pub struct LaserGeometry {
    /// `header.frame_id`.
    pub frame_id: String,
    /// Number of beams.
    pub beams: usize,
    /// First and last bearing, radians.
    pub angle_min_rad: f64,
    /// Bearing of the last beam as the message states it, radians.
    pub angle_max_rad: f64,
    /// Bearing step, radians.
    pub angle_increment_rad: f64,
    /// Shortest and longest valid range, metres.
    pub range_min_m: f64,
    /// Longest valid range, metres.
    pub range_max_m: f64,
}

impl LaserGeometry {
    fn of(msg: &LaserScanMsg) -> Self {
        LaserGeometry {
            frame_id: msg.frame_id.clone(),
            beams: msg.ranges.len(),
            angle_min_rad: f64::from(msg.angle_min),
            angle_max_rad: f64::from(msg.angle_max),
            angle_increment_rad: f64::from(msg.angle_increment),
            range_min_m: f64::from(msg.range_min),
            range_max_m: f64::from(msg.range_max),
        }
    }

    /// Angle covered by the beams, `beams · |angle_increment|`, radians (a 360° scanner
    /// covers 2π with no beam counted twice).
    pub fn field_of_view_rad(&self) -> f64 {
        self.beams as f64 * self.angle_increment_rad.abs()
    }
}

/// One topic of a recording.
#[derive(Debug, Clone, PartialEq)]
pub struct TopicSummary {
    /// Topic, type and encoding.
    pub connection: Connection,
    /// Messages on the topic.
    pub messages: u64,
    /// Receive times of the first and last message, nanoseconds since the epoch.
    pub span_ns: Option<(i128, i128)>,
    /// `header.stamp` of the first and last decodable laser scan.
    pub stamps: Option<(RosTime, RosTime)>,
    /// For a laser topic: the geometry of its first decodable message.
    pub laser: Option<LaserGeometry>,
}

/// Reads a whole recording and counts its messages per topic (decoding laser scans only for
/// their geometry and stamps). Topics are in the order the file declares them.
pub fn survey(source: &mut dyn MessageSource) -> Result<Vec<TopicSummary>, RosError> {
    let mut topics: Vec<TopicSummary> = Vec::new();
    while source.advance()? {
        let m = source.current();
        let c = &source.connections()[m.connection];
        let laser = match (c.is_laser_scan(), c.encoding.flavor()) {
            (true, Some(f)) => LaserScanMsg::decode(m.data, f).ok(),
            _ => None,
        };
        let (index, t) = (m.connection, m.log_time_ns);
        let connections = source.connections();
        while topics.len() < connections.len() {
            topics.push(TopicSummary {
                connection: connections[topics.len()].clone(),
                messages: 0,
                span_ns: None,
                stamps: None,
                laser: None,
            });
        }
        let s = &mut topics[index];
        s.messages += 1;
        s.span_ns = Some(s.span_ns.map_or((t, t), |(a, b)| (a.min(t), b.max(t))));
        if let Some(msg) = laser {
            s.stamps = Some(
                s.stamps
                    .map_or((msg.stamp, msg.stamp), |(a, _)| (a, msg.stamp)),
            );
            if s.laser.is_none() {
                s.laser = Some(LaserGeometry::of(&msg));
            }
        }
    }
    let connections = source.connections();
    while topics.len() < connections.len() {
        topics.push(TopicSummary {
            connection: connections[topics.len()].clone(),
            messages: 0,
            span_ns: None,
            stamps: None,
            laser: None,
        });
    }
    Ok(topics)
}
