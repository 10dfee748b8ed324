//! The node: its subscriptions on a receiving thread that feeds the scan queue, and its
//! publishers, which the mapping run drives scan by scan ([`Ros2Node::on_scan`]); the
//! occupancy grid is built and published on a thread of its own, so a large grid never holds
//! up a scan's pose.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use polymap::geometry::Segment;
use polymap::mapper::{Mapper, Update};
use polymap::scan::Stamp;
use polymap_io::ros::tf::{TfBuffer, TfLimits};
use ros2_client::dds::rustdds::Topic;
use ros2_client::qos::{Durability, History, Reliability, WhenFull};
use ros2_client::{
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions as RclOptions, Publisher,
    QosProfile, Subscription,
};
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::dds::{DdsError, DdsSettings};
use crate::grid::{GridJob, GridThread};
use crate::live::{LiveSource, RayStore, ScanQueue};
use crate::msgs::{
    LaserScan, MarkerArray, Odometry, PoseWithCovarianceStamped, RosMessage, TfMessage, Time,
};
use crate::outputs::{Status, markers_message, pose_message, status_message, tf_message};
use crate::receive::Receiving;

/// How the node is set up.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeOptions {
    /// The node's name (`polymap`).
    pub node_name: String,
    /// The `LaserScan` topic (`scan`, relative to the node's namespace `/`).
    pub scan_topic: String,
    /// The `Odometry` topic, when odometry is read from one.
    pub odom_topic: Option<String>,
    /// Attach the odometry to the scans (the mapper's `--odometry`).
    pub odometry: bool,
    /// The global frame (`map`).
    pub map_frame: String,
    /// The robot's frame; `None`: the odometry's `child_frame_id`, else the scan's frame.
    pub base_frame: Option<String>,
    /// Scans waiting for the mapper, at most; beyond, the oldest is dropped.
    pub queue_scans: usize,
    /// The occupancy grid and the markers are published at most this often, seconds.
    pub map_period_s: f64,
    /// The occupancy grid's cell size, metres.
    pub resolution_m: f64,
    /// Scans whose rays the occupancy grid keeps, at most (spread evenly over the run).
    pub grid_ray_scans: usize,
}

impl Default for NodeOptions {
    fn default() -> Self {
        NodeOptions {
            node_name: "polymap".into(),
            scan_topic: "scan".into(),
            odom_topic: None,
            odometry: false,
            map_frame: "map".into(),
            base_frame: None,
            queue_scans: 8,
            map_period_s: 2.0,
            resolution_m: 0.05,
            grid_ray_scans: 2000,
        }
    }
}

/// Why the node could not start.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    /// The environment or the DDS participant.
    #[error(transparent)]
    Dds(#[from] DdsError),
    /// A name the node cannot use, or a topic, reader or writer RustDDS refused.
    #[error("{what}: {message}")]
    Setup {
        /// What was being made (`topic scan`).
        what: String,
        /// The cause.
        message: String,
    },
}

pub(crate) fn setup(what: impl Into<String>) -> impl FnOnce(String) -> NodeError {
    let what = what.into();
    move |message| NodeError::Setup { what, message }
}

/// Sensor data: best effort, volatile, the last few (as `rclcpp::SensorDataQoS`).
fn sensor_qos(depth: usize) -> QosProfile {
    QosProfile::subscription_default()
        .reliability(Reliability::BestEffort)
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth })
}

/// Reliable and volatile; a full send window fails at once rather than hold up a scan.
fn reliable_qos(depth: usize) -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Fail)
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth })
}

/// What tf2's listener subscribes with: reliable, the last 100.
fn tf_qos(durability: Durability) -> QosProfile {
    QosProfile::subscription_default()
        .reliability_reliable(WhenFull::DEFAULT)
        .durability(durability)
        .history(History::KeepLast { depth: 100 })
}

/// Reliable and transient local, the last one kept for late subscribers (a latched topic).
fn latched_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::DEFAULT)
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

fn topic_name(name: &str) -> Result<Name, NodeError> {
    let parsed = if name.starts_with('/') {
        Name::parse(name)
    } else {
        Name::parse(&format!("/{name}"))
    };
    parsed.map_err(|e| setup(format!("topic name {name:?}"))(format!("{e:?}")))
}

/// The topic `name` of message type `M`.
fn topic<M: RosMessage>(node: &mut Node, name: &str, qos: &QosProfile) -> Result<Topic, NodeError> {
    node.create_topic(
        &topic_name(name)?,
        MessageTypeName::new(M::PACKAGE, M::NAME),
        qos,
    )
    .map_err(|e| setup(format!("topic {name}"))(e.to_string()))
}

fn publisher<M: RosMessage + Serialize>(
    node: &mut Node,
    name: &str,
    qos: QosProfile,
) -> Result<Publisher<M>, NodeError> {
    let topic = topic::<M>(node, name, &qos)?;
    node.create_publisher(&topic, Some(qos))
        .map_err(|e| setup(format!("publisher on {name}"))(e.to_string()))
}

fn subscription<M: RosMessage + DeserializeOwned + 'static>(
    node: &mut Node,
    name: &str,
    qos: QosProfile,
) -> Result<Subscription<M>, NodeError> {
    let topic = topic::<M>(node, name, &qos)?;
    node.create_subscription(&topic, Some(qos))
        .map_err(|e| setup(format!("subscription to {name}"))(e.to_string()))
}

/// The frames the node has learnt from the messages.
#[derive(Debug, Clone, Default)]
pub(crate) struct Frames {
    /// The scans' `header.frame_id`.
    pub(crate) scan: Option<String>,
    /// The odometry's `header.frame_id` and `child_frame_id`.
    pub(crate) odom: Option<(String, String)>,
    /// The robot's frame the poses are of, once the scans' frame is decided: the base frame
    /// tf placed the laser on, else the scans' own frame.
    pub(crate) robot: Option<String>,
}

/// The ROS 2 node: subscriptions on a thread of their own, publishers driven by the run.
pub struct Ros2Node {
    options: NodeOptions,
    /// Kept alive: dropping the context leaves the DDS domain.
    _context: Context,
    _node: Node,
    queue: Arc<ScanQueue>,
    rays: Arc<RayStore>,
    frames: Arc<Mutex<Frames>>,
    stop_receiving: Arc<AtomicBool>,
    receiver: Option<JoinHandle<()>>,
    pose: Publisher<PoseWithCovarianceStamped>,
    tf: Publisher<TfMessage>,
    markers: Publisher<MarkerArray>,
    status_pub: Publisher<crate::msgs::DiagnosticArray>,
    grid: GridThread,
    status: Status,
    last_status: Option<Instant>,
    last_map: Option<Instant>,
    map_dirty: bool,
    loop_closures: usize,
    latencies: Vec<Duration>,
    publish_failures: Arc<AtomicU64>,
    /// The last scan's stamp (the final map's).
    last_time: Option<Time>,
}

/// What the node measured over its run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NodeReport {
    /// Per scan mapped, from its arrival to its pose published.
    pub latencies: Vec<Duration>,
    /// Messages a publisher refused (a full send window), skipped.
    pub publish_failures: u64,
    /// Occupancy grids published.
    pub grids_published: u64,
}

impl Ros2Node {
    /// Joins the domain, subscribes and starts receiving scans into the queue.
    pub fn start(settings: &DdsSettings, options: NodeOptions) -> Result<Ros2Node, NodeError> {
        let context = settings.context()?;
        let name = NodeName::new("/", &options.node_name)
            .map_err(|e| setup(format!("node name {:?}", options.node_name))(format!("{e:?}")))?;
        let mut node = context
            .new_node(name, RclOptions::new().enable_rosout(false))
            .map_err(|e| setup("node")(format!("{e:?}")))?;
        // Odometry rides with every scan, as a recording's does: with `--odometry` it starts
        // the alignment, without it witnesses the step.
        let queue = ScanQueue::new(options.queue_scans, true, !options.odometry);
        let rays = RayStore::new(options.grid_ray_scans);
        let frames = Arc::new(Mutex::new(Frames::default()));
        let scans = subscription::<LaserScan>(
            &mut node,
            &options.scan_topic,
            sensor_qos(options.queue_scans.max(5)),
        )?;
        let odometry = match &options.odom_topic {
            Some(t) => Some(subscription::<Odometry>(&mut node, t, sensor_qos(50))?),
            None => None,
        };
        // As tf2's listener subscribes: /tf reliable and volatile, /tf_static reliable and
        // transient local (a late node still gets the mounting).
        let tf_sub = subscription::<TfMessage>(&mut node, "/tf", tf_qos(Durability::Volatile))?;
        let tf_static =
            subscription::<TfMessage>(&mut node, "/tf_static", tf_qos(Durability::TransientLocal))?;
        let pose = publisher(&mut node, "pose", reliable_qos(10))?;
        let tf = publisher(&mut node, "/tf", reliable_qos(100))?;
        let markers = publisher(
            &mut node,
            "polymap/segments",
            latched_qos().reliability_reliable(WhenFull::Fail),
        )?;
        let status_pub = publisher(&mut node, "polymap/status", reliable_qos(10))?;
        let map = publisher(&mut node, "map", latched_qos())?;
        let publish_failures = Arc::new(AtomicU64::new(0));
        let grid = GridThread::start(map, options.clone(), Arc::clone(&publish_failures))?;
        let stop_receiving = Arc::new(AtomicBool::new(false));
        let receiver = {
            let receiving = Receiving {
                participant: context.domain_participant(),
                scan_dds_topic: format!("rt/{}", options.scan_topic.trim_start_matches('/')),
                checked_writers: None,
                scans,
                odometry,
                tf: tf_sub,
                tf_static,
                buffer: TfBuffer::new(TfLimits::default()),
                base: None,
                base_option: options.base_frame.clone(),
                mounts: Default::default(),
                waiting: Default::default(),
                queue: Arc::clone(&queue),
                frames: Arc::clone(&frames),
                stop: Arc::clone(&stop_receiving),
                topic: options.scan_topic.clone(),
            };
            std::thread::Builder::new()
                .name("polymap-ros2-receive".into())
                .spawn(move || receiving.run())
                .map_err(|e| setup("receiving thread")(e.to_string()))?
        };
        Ok(Ros2Node {
            options,
            _context: context,
            _node: node,
            queue,
            rays,
            frames,
            stop_receiving,
            receiver: Some(receiver),
            pose,
            tf,
            markers,
            status_pub,
            grid,
            status: Status::default(),
            last_status: None,
            last_map: None,
            map_dirty: true,
            loop_closures: 0,
            latencies: Vec::new(),
            publish_failures,
            last_time: None,
        })
    }

    /// The scan queue (its [`ScanQueue::close`] ends the run once the queue is empty).
    pub fn queue(&self) -> Arc<ScanQueue> {
        Arc::clone(&self.queue)
    }

    /// The mapping run's source of scans.
    pub fn source(&self) -> LiveSource {
        LiveSource::new(
            Arc::clone(&self.queue),
            &self.options.scan_topic,
            Arc::clone(&self.rays),
        )
    }

    fn count<T, E>(&self, r: Result<T, E>) {
        if r.is_err() {
            self.publish_failures.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Publishes what scan `update` changed: its pose and tf at once, then (rate limited) the
    /// status, the markers and the occupancy grid.
    pub fn on_scan(&mut self, stamp: &Stamp, update: &Update, mapper: &Mapper) {
        let arrived = self.queue.claim_arrival();
        let time = time_of(stamp);
        let frames = self
            .frames
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone();
        let map_frame = self.options.map_frame.clone();
        self.last_time = Some(time);
        // A run on a saved map says nothing of where the robot is until it is placed.
        if !mapper.placed() {
            self.after_pose(time, update, mapper);
            return;
        }
        let base = frames
            .robot
            .clone()
            .or(frames.scan.clone())
            .unwrap_or_else(|| "base_link".into());
        let map_from_base = update.map_from_robot;
        let cov = &update.diagnostics.pose_covariance;
        let r = self
            .pose
            .publish(pose_message(&map_frame, time, &map_from_base, cov));
        self.count(r);
        // map → odom where the odometry names its frame, so that map → odom → base is one
        // chain; else map → base.
        let odom = frames.odom.as_ref().and_then(|(odom_frame, _)| {
            self.queue
                .odometry_at(crate::live::stamp_ns(stamp))
                .map(|odom_from_base| (odom_frame.clone(), odom_from_base))
        });
        let tf = match odom {
            // Dated ahead, as slam_toolbox does: map → odom holds until the next scan, and a
            // consumer looking up the chain at "now" finds it.
            Some((odom_frame, odom_from_base)) => tf_message(
                &map_frame,
                &odom_frame,
                ahead(time, TRANSFORM_AHEAD),
                &map_from_base.compose(&odom_from_base.inverse()),
            ),
            None => tf_message(&map_frame, &base, time, &map_from_base),
        };
        let r = self.tf.publish(tf);
        self.count(r);
        if let Some(a) = arrived {
            self.latencies.push(a.elapsed());
        }
        self.after_pose(time, update, mapper);
    }

    fn after_pose(&mut self, time: Time, update: &Update, mapper: &Mapper) {
        let d = &update.diagnostics;
        let verdict = format!("{:?}", d.tracking.verdict).to_lowercase();
        let summary = mapper.tracking_summary();
        let received = self.queue.received();
        let closures = mapper.loop_closures();
        let entered = d.tracking.verdict != polymap::tracking::Verdict::Lost
            && mapper.role() == polymap::mapper::MapRole::Build;
        self.map_dirty |= entered || closures != self.loop_closures;
        self.loop_closures = closures;
        let changed_verdict = verdict != self.status.verdict;
        self.status = Status {
            verdict,
            reason: serde_json::to_value(d.tracking.reason)
                .ok()
                .and_then(|v| v.as_str().map(str::to_owned))
                .unwrap_or_default(),
            scans: u64::from(mapper.scans()),
            ok: u64::from(summary.ok),
            weak: u64::from(summary.weak),
            lost: u64::from(summary.lost),
            dropped: received.dropped,
            bad_messages: received.bad_messages,
            loop_closures: closures as u64,
            map_segments: d.map_segments as u64,
            latency_ms: self.latencies.last().map_or(0.0, |l| l.as_secs_f64() * 1e3),
        };
        let now = Instant::now();
        if changed_verdict || self.last_status.is_none_or(|t| now - t >= STATUS_PERIOD) {
            let r = self.status_pub.publish(status_message(time, &self.status));
            self.count(r);
            self.last_status = Some(now);
        }
        let period = Duration::from_secs_f64(self.options.map_period_s.max(0.0));
        if self.map_dirty && self.last_map.is_none_or(|t| now - t >= period) {
            self.publish_map(time, mapper);
            self.last_map = Some(now);
            self.map_dirty = false;
        }
    }

    fn publish_map(&mut self, time: Time, mapper: &Mapper) {
        let segments: Vec<Segment> = mapper.segments().iter().map(|s| s.segment).collect();
        let polylines = mapper.polylines();
        let r = self.markers.publish(markers_message(
            &self.options.map_frame,
            time,
            &segments,
            &polylines,
        ));
        self.count(r);
        let poses = mapper.trajectory();
        let rays = self
            .rays
            .kept()
            .into_iter()
            .filter_map(|(i, points)| poses.get(i).map(|p| (*p, points)))
            .collect();
        self.grid.submit(GridJob {
            time,
            segments,
            rays,
        });
    }

    /// Publishes the final map and status, stops receiving and the grid thread, and says what
    /// was measured. Scans still queued are not taken (close the queue and let the run drain
    /// it first).
    pub fn finish(mut self, mapper: &Mapper) -> NodeReport {
        self.stop_receiving.store(true, Ordering::SeqCst);
        if let Some(h) = self.receiver.take() {
            let _ = h.join();
        }
        let time = self.last_time.unwrap_or_default();
        if self.map_dirty {
            self.publish_map(time, mapper);
        }
        let grids = self.grid.finish();
        NodeReport {
            latencies: std::mem::take(&mut self.latencies),
            publish_failures: self.publish_failures.load(Ordering::Relaxed),
            grids_published: grids,
        }
    }
}

/// How far ahead of its scan map → odom is dated, as slam_toolbox's `transform_timeout`.
const TRANSFORM_AHEAD: Duration = Duration::from_millis(200);

/// `t` moved `by` later.
fn ahead(t: Time, by: Duration) -> Time {
    let nanos = u64::from(t.nanosec) + u64::from(by.subsec_nanos());
    let sec = i64::from(t.sec) + by.as_secs() as i64 + (nanos / 1_000_000_000) as i64;
    Time {
        sec: i32::try_from(sec).unwrap_or(i32::MAX),
        nanosec: (nanos % 1_000_000_000) as u32,
    }
}

/// The status goes out at most this often while the verdict stays the same.
const STATUS_PERIOD: Duration = Duration::from_millis(500);

/// The header stamp of a scan, exactly: from the stamp's text (`sec.nanos`, as the scan was
/// read), else from its seconds.
pub fn time_of(stamp: &Stamp) -> Time {
    let from_text = || -> Option<Time> {
        let (sec, frac) = stamp.text.split_once('.').unwrap_or((&stamp.text, ""));
        if frac.len() > 9 || sec.starts_with('-') {
            return None;
        }
        let sec: i32 = sec.parse().ok()?;
        let nanosec: u32 = if frac.is_empty() {
            0
        } else {
            format!("{frac:0<9}").parse().ok()?
        };
        Some(Time { sec, nanosec })
    };
    from_text().unwrap_or_else(|| crate::outputs::ros_time(stamp.seconds))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stamp_keeps_its_nanoseconds_from_its_text() {
        let s = Stamp {
            seconds: 1_700_000_000.123_456_8,
            text: "1700000000.123456789".into(),
        };
        assert_eq!(
            time_of(&s),
            Time {
                sec: 1_700_000_000,
                nanosec: 123_456_789
            }
        );
        let short = Stamp {
            seconds: 5.25,
            text: "5.25".into(),
        };
        assert_eq!(time_of(&short).nanosec, 250_000_000);
    }
}
