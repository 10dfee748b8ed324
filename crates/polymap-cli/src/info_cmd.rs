//! `polymap info`: what a log holds, before mapping it.

use std::collections::BTreeMap;

use anyhow::Result;
use polymap::scan::RangeScan;
use polymap_io::carmen::{CarmenReader, CarmenRecord, ReaderOptions};
use polymap_io::log::LogKind;
use polymap_io::ros::{ReadLimits, TopicSummary, open_source, survey};

use crate::args::InfoArgs;
use crate::quote::quoted;

pub fn run(a: &InfoArgs) -> Result<()> {
    let kind = LogKind::of(&a.log)?;
    let size = std::fs::metadata(&a.log).map(|m| m.len()).unwrap_or(0);
    say!(
        "{}: {} ({size} bytes)",
        quoted(&a.log.display().to_string()),
        kind.name()
    );
    match kind {
        // `LogKind::of` never tells a path to be live.
        LogKind::Carmen | LogKind::Live => carmen_info(a),
        LogKind::Ros(format) => {
            let mut source = open_source(&a.log, format, ReadLimits::default(), false)?;
            let topics = survey(source.as_mut())?;
            ros_info(&topics);
            for w in source.warnings() {
                say!("warning: {}", quoted(w));
            }
            Ok(())
        }
    }
}

fn ros_info(topics: &[TopicSummary]) {
    let total: u64 = topics.iter().map(|t| t.messages).sum();
    let span = topics
        .iter()
        .filter_map(|t| t.span_ns)
        .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)));
    match span {
        Some((a, b)) => say!(
            "{} topics, {total} messages over {:.3} s (receive times {} to {})",
            topics.len(),
            (b - a) as f64 * 1e-9,
            seconds(a),
            seconds(b)
        ),
        None => say!("{} topics, no messages", topics.len()),
    }
    for t in topics {
        say!(
            "  {}  {}  {}  {} messages",
            quoted(&t.connection.topic),
            quoted(&t.connection.type_name),
            quoted(&encoding_name(&t.connection.encoding)),
            t.messages
        );
    }
    let lasers: Vec<&TopicSummary> = topics
        .iter()
        .filter(|t| t.connection.is_laser_scan())
        .collect();
    if lasers.is_empty() {
        say!("laser: no sensor_msgs/LaserScan topic");
    }
    for t in lasers {
        laser_info(t);
    }
    let odom: Vec<String> = topics
        .iter()
        .filter(|t| t.connection.is_odometry())
        .map(|t| format!("{} ({} messages)", quoted(&t.connection.topic), t.messages))
        .collect();
    let tf: Vec<String> = topics
        .iter()
        .filter(|t| {
            let name = t.connection.topic.as_str();
            t.connection.is_tf()
                && matches!(name.strip_prefix('/').unwrap_or(name), "tf" | "tf_static")
        })
        .map(|t| format!("{} ({} messages)", quoted(&t.connection.topic), t.messages))
        .collect();
    if odom.is_empty() && !tf.is_empty() {
        say!(
            "odometry: no topic; tf's odom → base_link, where tf has it, tracks with --odometry \
             and otherwise witnesses the tracked steps"
        );
    } else if odom.is_empty() {
        say!("odometry: none (map without --odometry)");
    } else {
        say!(
            "odometry: {} (map with --odometry to track from it; without, it witnesses the \
             tracked steps: the only topic, or --odom-topic's)",
            odom.join(", ")
        );
    }
    if tf.is_empty() {
        say!("tf: none (the laser is taken at the robot's origin)");
    } else {
        say!(
            "tf: {} (the laser is placed by the transform from base_link, or --base-frame, to \
             its frame)",
            tf.join(", ")
        );
    }
}

fn laser_info(t: &TopicSummary) {
    let Some(g) = &t.laser else {
        say!(
            "laser {}: {} messages, none decodable",
            quoted(&t.connection.topic),
            t.messages
        );
        return;
    };
    let rate = match t.stamps {
        Some((a, b)) if t.messages > 1 && b.nanos() > a.nanos() => format!(
            "{:.2} Hz",
            (t.messages - 1) as f64 / ((b.nanos() - a.nanos()) as f64 * 1e-9)
        ),
        _ => "rate unknown".into(),
    };
    say!(
        "laser {}: {} beams over {:.1}° (step {:.4}°, first beam {:.2}°, last {:.2}°), \
         range {}–{} m, {rate}, frame {}",
        quoted(&t.connection.topic),
        g.beams,
        g.field_of_view_rad().to_degrees(),
        g.angle_increment_rad.to_degrees(),
        g.angle_min_rad.to_degrees(),
        g.angle_max_rad.to_degrees(),
        g.range_min_m as f32,
        g.range_max_m as f32,
        quoted(&g.frame_id)
    );
    if let Some((a, b)) = t.stamps {
        say!(
            "  header stamps {} to {} ({:.3} s)",
            a.to_stamp().text,
            b.to_stamp().text,
            (b.nanos() - a.nanos()) as f64 * 1e-9
        );
    }
}

fn encoding_name(e: &polymap_io::ros::Encoding) -> String {
    match e {
        polymap_io::ros::Encoding::Ros1 => "ros1".into(),
        polymap_io::ros::Encoding::Cdr => "cdr".into(),
        polymap_io::ros::Encoding::Other(s) => s.clone(),
    }
}

fn seconds(ns: i128) -> String {
    format!("{:.3}", ns as f64 * 1e-9)
}

/// Scans by message type, their geometry, the stamps' span and rate, odometry.
fn carmen_info(a: &InfoArgs) -> Result<()> {
    let mut reader = CarmenReader::open(&a.log, ReaderOptions::default())?;
    let mut first: Option<RangeScan> = None;
    let mut span: Option<(f64, f64)> = None;
    let mut beams = BTreeMap::<usize, u64>::new();
    let mut with_odometry = 0u64;
    while let Some(record) = reader.next_record()? {
        let CarmenRecord::Scan(scan) = record else {
            continue;
        };
        with_odometry += u64::from(scan.odom_from_robot.is_some());
        let t = scan.stamp.seconds;
        span = Some(span.map_or((t, t), |(lo, hi)| (lo.min(t), hi.max(t))));
        *beams.entry(scan.ranges_m.len()).or_insert(0) += 1;
        first.get_or_insert(scan);
    }
    let s = reader.stats();
    say!(
        "{} lines: {} scans, {} ODOM, {} PARAM, {} comments",
        s.lines,
        s.scans,
        s.odometry_messages,
        s.params,
        s.comment_lines
    );
    for (t, n) in &s.skipped_types {
        say!("  skipped type {}: {n} lines", quoted(t));
    }
    let Some(scan) = first else {
        say!("laser: no FLASER or ROBOTLASER1 lines");
        return Ok(());
    };
    let n = scan.ranges_m.len();
    let counts: Vec<String> = beams.iter().map(|(b, c)| format!("{c}×{b}")).collect();
    let (lo, hi) = span.unwrap_or((0.0, 0.0));
    let rate = if hi > lo && s.scans > 1 {
        format!("{:.2} Hz", (s.scans - 1) as f64 / (hi - lo))
    } else {
        "rate unknown".into()
    };
    say!(
        "laser: {n} beams (scans by beams: {}), first beam {:.2}°, step {:.4}°, \
         {:.1}° covered, readings ≥ {} m are no-returns, {rate}",
        counts.join(", "),
        scan.angle_min_rad.to_degrees(),
        scan.angle_increment_rad.to_degrees(),
        (n as f64 * scan.angle_increment_rad.abs()).to_degrees(),
        scan.max_range_m
    );
    say!("  stamps {lo:.6} to {hi:.6} ({:.3} s)", hi - lo);
    let odometry = match with_odometry {
        0 => "none".to_string(),
        n if n == s.scans => "in every scan line (map with --odometry to track from it; \
                              without, it witnesses the tracked steps)"
            .to_string(),
        n => format!(
            "in {n} of {} scan lines (map with --odometry to track from it; without, it \
             witnesses the tracked steps)",
            s.scans
        ),
    };
    say!("odometry: {odometry}");
    // What the reader found odd (stamps going back, stale odometry, ...), as `map` warns.
    for w in s.warnings() {
        say!("  {}", quoted(&w));
    }
    Ok(())
}
