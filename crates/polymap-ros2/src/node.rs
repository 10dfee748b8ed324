//! The node: its subscriptions on a receiving thread that feeds the scan queue, and its
//! publishers, which the mapping run drives scan by scan ([`Ros2Node::on_scan`]); the
//! occupancy grid is built and published on a thread of its own, so a large grid never holds
//! up a scan's pose.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use polymap::geometry::{Pose2, Segment, Vec2};
use polymap::mapper::{Mapper, Update};
use polymap::scan::Stamp;
use polymap_export::pgm::{GridParams, OccupancyGrid as Grid};
use polymap_io::ros::tf::{TfBuffer, TfLimits, frame_name};
use polymap_io::ros::{BASE_FOOTPRINT, BASE_LINK, ODOM_FRAME};
use polymap_io::ros::{LaserScanMsg, RosTime, TransformStampedMsg};
use ros2_client::dds::rustdds::DomainParticipant;
use ros2_client::dds::rustdds::mio1::{Events, Interest, Poll, Token};
use ros2_client::qos::{Durability, History, Reliability, WhenFull};
use ros2_client::{
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions as RclOptions, Publisher,
    QosProfile, Subscription,
};
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::dds::{DdsError, DdsSettings};
use crate::live::{LiveSource, RayStore, ScanQueue};
use crate::msgs::{
    LaserScan, MarkerArray, OccupancyGrid, Odometry, PoseWithCovarianceStamped, RosMessage,
    TfMessage, Time,
};
use crate::outputs::{
    Status, covariance_xy_yaw, grid_message, markers_message, plane_pose, pose_message,
    status_message, tf_message,
};

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

fn setup(what: impl Into<String>) -> impl FnOnce(String) -> NodeError {
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

fn publisher<M: RosMessage + Serialize>(
    node: &mut Node,
    name: &str,
    qos: QosProfile,
) -> Result<Publisher<M>, NodeError> {
    let topic = node
        .create_topic(
            &topic_name(name)?,
            MessageTypeName::new(M::PACKAGE, M::NAME),
            &qos,
        )
        .map_err(|e| setup(format!("topic {name}"))(e.to_string()))?;
    node.create_publisher(&topic, Some(qos))
        .map_err(|e| setup(format!("publisher on {name}"))(e.to_string()))
}

fn subscription<M: RosMessage + DeserializeOwned + 'static>(
    node: &mut Node,
    name: &str,
    qos: QosProfile,
) -> Result<Subscription<M>, NodeError> {
    let topic = node
        .create_topic(
            &topic_name(name)?,
            MessageTypeName::new(M::PACKAGE, M::NAME),
            &qos,
        )
        .map_err(|e| setup(format!("topic {name}"))(e.to_string()))?;
    node.create_subscription(&topic, Some(qos))
        .map_err(|e| setup(format!("subscription to {name}"))(e.to_string()))
}

/// The frames the node has learnt from the messages.
#[derive(Debug, Clone, Default)]
struct Frames {
    /// The scans' `header.frame_id`.
    scan: Option<String>,
    /// The odometry's `header.frame_id` and `child_frame_id`.
    odom: Option<(String, String)>,
    /// The robot's frame the poses are of, once the scans' frame is decided: the base frame
    /// tf placed the laser on, else the scans' own frame.
    robot: Option<String>,
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
        let cov = covariance_xy_yaw(&update.diagnostics, 5.0);
        let r = self
            .pose
            .publish(pose_message(&map_frame, time, &map_from_base, &cov));
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

/// The receiving thread's state.
struct Receiving {
    /// For what discovery saw: publishers of another type on the scan topic.
    participant: DomainParticipant,
    /// The scan topic's DDS name (`rt/scan`).
    scan_dds_topic: String,
    /// When the publishers on the scan topic were last looked at.
    checked_writers: Option<Instant>,
    scans: Subscription<LaserScan>,
    odometry: Option<Subscription<Odometry>>,
    tf: Subscription<TfMessage>,
    tf_static: Subscription<TfMessage>,
    /// Every transform received (bounded by its limits).
    buffer: TfBuffer,
    /// The robot's frame once found: `base_option`, else `base_link`, else `base_footprint`.
    base: Option<String>,
    base_option: Option<String>,
    /// Per scan frame, once decided: its last mounting from tf, or `None` (taken as the robot).
    mounts: std::collections::HashMap<String, Option<Pose2>>,
    /// Scans whose frame is not decided yet, oldest first.
    waiting: std::collections::VecDeque<(polymap::scan::RangeScan, String, RosTime, Instant)>,
    queue: Arc<ScanQueue>,
    frames: Arc<Mutex<Frames>>,
    stop: Arc<AtomicBool>,
    topic: String,
}

const SCANS: Token = Token(0);
const ODOMETRY: Token = Token(1);
const TF: Token = Token(2);
const TF_STATIC: Token = Token(3);
/// How often the receiving thread looks at its stop flag.
const RECEIVE_POLL: Duration = Duration::from_millis(50);

impl Receiving {
    fn run(mut self) {
        let Ok(mut poll) = Poll::new() else {
            self.queue
                .warn_once("cannot start polling the subscriptions: no scan is received".into());
            return;
        };
        let registered = poll
            .registry()
            .register(&mut self.scans, SCANS, Interest::READABLE)
            .is_ok()
            && self.odometry.as_mut().is_none_or(|o| {
                poll.registry()
                    .register(o, ODOMETRY, Interest::READABLE)
                    .is_ok()
            })
            && poll
                .registry()
                .register(&mut self.tf, TF, Interest::READABLE)
                .is_ok()
            && poll
                .registry()
                .register(&mut self.tf_static, TF_STATIC, Interest::READABLE)
                .is_ok();
        if !registered {
            self.queue
                .warn_once("cannot poll the subscriptions: no scan is received".into());
            return;
        }
        let mut events = Events::with_capacity(8);
        while !self.stop.load(Ordering::SeqCst) {
            // Edge-triggered: after any event (or the timeout) take everything there is.
            let _ = poll.poll(&mut events, Some(RECEIVE_POLL));
            self.take_tf();
            self.take_odometry();
            self.take_scans();
            self.release_waiting();
            if self
                .checked_writers
                .is_none_or(|t| t.elapsed() >= WRITER_CHECK)
            {
                self.check_writers();
                self.checked_writers = Some(Instant::now());
            }
        }
        if !self.waiting.is_empty() {
            let n = self.waiting.len();
            self.waiting.clear();
            self.queue.bad_message(format!(
                "{}: {n} scan(s) still waiting for tf when the node stopped were not mapped",
                self.topic
            ));
        }
    }

    /// Names, once each, a publisher on the scan topic whose type is not `LaserScan`: DDS does
    /// not connect it to the node, so its messages would otherwise vanish without a word.
    fn check_writers(&self) {
        let expected = MessageTypeName::new(LaserScan::PACKAGE, LaserScan::NAME).dds_msg_type();
        for w in self.participant.discovered_writers() {
            let p = &w.publication_topic_data;
            if p.topic_name == self.scan_dds_topic && p.type_name != expected {
                let warning = format!(
                    "a publisher of {} on {} is ignored: the node reads {}/msg/{} there",
                    ros_type_name(&p.type_name),
                    self.topic,
                    LaserScan::PACKAGE,
                    LaserScan::NAME
                );
                if self.queue.warn_once(warning.clone()) {
                    eprintln!("polymap: warning: {warning}");
                }
            }
        }
    }

    fn take_tf(&mut self) {
        for is_static in [true, false] {
            loop {
                let sub = if is_static { &self.tf_static } else { &self.tf };
                match sub.take() {
                    Ok(Some((msg, _))) => self.insert_tf(&msg, is_static),
                    Ok(None) => break,
                    Err(e) => {
                        self.queue
                            .warn_once(format!("a tf message could not be read: {e:?}"));
                        break;
                    }
                }
            }
        }
    }

    /// Takes a tf message into the buffer; without an odometry topic, `odom → base` is the
    /// odometry.
    fn insert_tf(&mut self, msg: &TfMessage, is_static: bool) {
        for t in &msg.transforms {
            let m = TransformStampedMsg {
                stamp: RosTime {
                    sec: i64::from(t.header.stamp.sec),
                    nanosec: t.header.stamp.nanosec,
                },
                parent_frame: t.header.frame_id.clone(),
                child_frame: t.child_frame_id.clone(),
                translation_m: [
                    t.transform.translation.x,
                    t.transform.translation.y,
                    t.transform.translation.z,
                ],
                rotation: [
                    t.transform.rotation.x,
                    t.transform.rotation.y,
                    t.transform.rotation.z,
                    t.transform.rotation.w,
                ],
            };
            if let Err(e) = self.buffer.insert(&m, is_static) {
                if self
                    .queue
                    .warn_once(format!("a transform was refused: {e}"))
                {
                    eprintln!("polymap: warning: a transform was refused: {e}");
                }
                continue;
            }
            self.find_base();
            let odom_edge = self.odometry.is_none()
                && !is_static
                && frame_name(&m.parent_frame) == ODOM_FRAME
                && self.base.as_deref() == Some(frame_name(&m.child_frame));
            if odom_edge {
                let pose = crate::outputs::plane_pose(&crate::msgs::Pose {
                    position: crate::msgs::Point {
                        x: m.translation_m[0],
                        y: m.translation_m[1],
                        z: m.translation_m[2],
                    },
                    orientation: t.transform.rotation,
                });
                self.queue.odometry(m.stamp.nanos(), pose);
                let mut f = self.frames.lock().unwrap_or_else(|e| e.into_inner());
                f.odom = Some((ODOM_FRAME.to_owned(), frame_name(&m.child_frame).to_owned()));
            }
        }
    }

    /// Fixes the robot's frame once tf names it.
    fn find_base(&mut self) {
        if self.base.is_some() {
            return;
        }
        let found = match &self.base_option {
            Some(b) => self.buffer.has_frame(b).then(|| frame_name(b).to_owned()),
            None => [BASE_LINK, BASE_FOOTPRINT]
                .into_iter()
                .find(|b| self.buffer.has_frame(b))
                .map(str::to_owned),
        };
        if let Some(b) = found {
            self.base = Some(b);
        }
    }

    /// Where tf puts the scan's frame on the robot at the scan's time, or why it cannot.
    fn lookup_mount(&self, frame: &str, stamp: &RosTime) -> Result<Pose2, String> {
        match &self.base {
            Some(base) => self
                .buffer
                .lookup(base, frame, stamp.nanos())
                .map(|l| l.pose)
                .map_err(|e| e.to_string()),
            None => Err(format!(
                "tf names no robot frame ({})",
                self.base_option
                    .clone()
                    .unwrap_or_else(|| format!("{BASE_LINK} or {BASE_FOOTPRINT}"))
            )),
        }
    }

    /// Hands a scan to the queue with its mounting. Whether tf places a scan frame is decided
    /// once, at its first scan, so that a run never switches between two robot frames: a scan
    /// tf cannot place yet waits (up to [`TF_WAIT`]) for the transforms, which may arrive just
    /// after it; past that, the frame is taken as the robot's for the whole run (warned). A
    /// placed frame whose lookup fails later keeps its last mounting.
    fn place(
        &mut self,
        mut scan: polymap::scan::RangeScan,
        frame: String,
        stamp: RosTime,
        arrived: Instant,
        held: bool,
    ) {
        // Scans let go together after waiting for tf may go beyond the queue's bound (by as
        // many as may wait), so that the run's first scans are not dropped for the wait.
        let push = |q: &ScanQueue, scan, arrived| {
            if held {
                q.push_held(scan, arrived, MAX_WAITING_SCANS)
            } else {
                q.push(scan, arrived)
            }
        };
        match self.mounts.get(&frame) {
            Some(Some(last)) => {
                let mount = self.lookup_mount(&frame, &stamp).unwrap_or(*last);
                self.mounts.insert(frame, Some(mount));
                scan.robot_from_laser = mount;
                push(&self.queue, scan, arrived);
            }
            Some(None) => {
                push(&self.queue, scan, arrived);
            }
            None => {
                if self.waiting.len() >= MAX_WAITING_SCANS {
                    self.waiting.pop_front();
                    self.queue.bad_message(format!(
                        "{}: a scan waiting for tf was dropped (too many waiting)",
                        self.topic
                    ));
                }
                self.waiting.push_back((scan, frame, stamp, arrived));
                self.release_waiting();
            }
        }
    }

    /// Records the robot's frame, the one the poses are of, when the first scan frame is
    /// decided.
    fn decided(&self, robot: String) {
        let mut f = self.frames.lock().unwrap_or_else(|e| e.into_inner());
        if f.robot.is_none() {
            f.robot = Some(robot);
        }
    }

    /// Hands over the scans waiting for tf once their frame is decided.
    fn release_waiting(&mut self) {
        while let Some((_, frame, stamp, arrived)) = self.waiting.front() {
            if !self.mounts.contains_key(frame) {
                match self.lookup_mount(frame, stamp) {
                    Ok(mount) => {
                        self.mounts.insert(frame.clone(), Some(mount));
                        let robot = self.base.clone();
                        self.decided(robot.unwrap_or_else(|| frame_name(frame).to_owned()));
                    }
                    Err(problem) if arrived.elapsed() >= TF_WAIT => {
                        let warning = format!(
                            "no tf places the scans' frame {frame} on the robot ({problem}): the \
                             scan frame is taken as the robot's"
                        );
                        if self.queue.warn_once(warning.clone()) {
                            eprintln!("polymap: warning: {warning}");
                        }
                        self.mounts.insert(frame.clone(), None);
                        self.decided(frame_name(frame).to_owned());
                    }
                    Err(_) => return,
                }
            }
            let Some((scan, frame, stamp, arrived)) = self.waiting.pop_front() else {
                return;
            };
            self.place(scan, frame, stamp, arrived, true);
        }
    }

    fn take_odometry(&mut self) {
        let Some(sub) = &self.odometry else { return };
        loop {
            match sub.take() {
                Ok(Some((msg, _))) => {
                    let p = &msg.pose.pose;
                    let q = p.orientation;
                    let finite = [p.position.x, p.position.y, q.x, q.y, q.z, q.w]
                        .iter()
                        .all(|v| v.is_finite())
                        && (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w) > 0.5;
                    if !finite {
                        self.queue.warn_once(format!(
                            "odometry messages with a non-finite pose or a zero quaternion \
                             are skipped (first at {}.{:09})",
                            msg.header.stamp.sec, msg.header.stamp.nanosec
                        ));
                        continue;
                    }
                    let stamp_ns = i128::from(msg.header.stamp.sec) * 1_000_000_000
                        + i128::from(msg.header.stamp.nanosec);
                    self.queue.odometry(stamp_ns, plane_pose(&msg.pose.pose));
                    let mut f = self.frames.lock().unwrap_or_else(|e| e.into_inner());
                    if f.odom.is_none() {
                        f.odom = Some((msg.header.frame_id.clone(), msg.child_frame_id.clone()));
                    }
                }
                Ok(None) => break,
                Err(e) => {
                    self.queue
                        .warn_once(format!("an odometry message could not be read: {e:?}"));
                    break;
                }
            }
        }
    }

    fn take_scans(&mut self) {
        loop {
            match self.scans.take() {
                Ok(Some((msg, _))) => {
                    let arrived = Instant::now();
                    let stamp = RosTime {
                        sec: i64::from(msg.header.stamp.sec),
                        nanosec: msg.header.stamp.nanosec,
                    };
                    match convert(msg) {
                        Ok((scan, frame)) => {
                            {
                                let mut f = self.frames.lock().unwrap_or_else(|e| e.into_inner());
                                if f.scan.is_none() {
                                    f.scan = Some(frame_name(&frame).to_owned());
                                }
                            }
                            self.place(scan, frame, stamp, arrived, false);
                        }
                        Err(e) => self.queue.bad_message(format!("{}: {e}", self.topic)),
                    }
                }
                Ok(None) => break,
                Err(e) => {
                    self.queue.bad_message(format!(
                        "{}: a message could not be read: {e:?}",
                        self.topic
                    ));
                    break;
                }
            }
        }
    }
}

/// How long a scan frame's first scan waits for tf to place it, at most.
const TF_WAIT: Duration = Duration::from_millis(500);
/// Scans held waiting for tf, at most (beyond, the oldest is dropped and counted).
const MAX_WAITING_SCANS: usize = 400;

/// How often the receiving thread looks at the publishers discovery found.
const WRITER_CHECK: Duration = Duration::from_secs(1);

/// `pkg/msg/Name` for a DDS type name `pkg::msg::dds_::Name_` (other names as they are).
fn ros_type_name(dds: &str) -> String {
    match dds.split("::").collect::<Vec<_>>()[..] {
        [package, kind, "dds_", name] => {
            format!(
                "{package}/{kind}/{}",
                name.strip_suffix('_').unwrap_or(name)
            )
        }
        _ => dds.to_owned(),
    }
}

/// A scan message as the mapper's scan, checked and converted exactly as a recorded one is
/// ([`LaserScanMsg`]), with its frame.
fn convert(msg: LaserScan) -> Result<(polymap::scan::RangeScan, String), String> {
    let m = LaserScanMsg {
        stamp: polymap_io::ros::RosTime {
            sec: i64::from(msg.header.stamp.sec),
            nanosec: msg.header.stamp.nanosec,
        },
        frame_id: msg.header.frame_id,
        angle_min: msg.angle_min,
        angle_max: msg.angle_max,
        angle_increment: msg.angle_increment,
        time_increment: msg.time_increment,
        scan_time: msg.scan_time,
        range_min: msg.range_min,
        range_max: msg.range_max,
        ranges: msg.ranges,
        intensity_count: msg.intensities.len(),
    };
    m.check_geometry().map_err(|e| e.to_string())?;
    let scan = m.to_range_scan();
    Ok((scan, m.frame_id))
}

/// An occupancy grid to build and publish.
struct GridJob {
    time: Time,
    segments: Vec<Segment>,
    rays: Vec<(Pose2, Arc<Vec<Vec2>>)>,
}

#[derive(Default)]
struct GridSlot {
    job: Option<GridJob>,
    stop: bool,
}

/// The thread that builds occupancy grids and publishes them; a job submitted while one is
/// being built replaces any job still waiting (only the newest map matters).
struct GridThread {
    slot: Arc<(Mutex<GridSlot>, Condvar)>,
    handle: Option<JoinHandle<u64>>,
}

impl GridThread {
    fn start(
        publisher: Publisher<OccupancyGrid>,
        options: NodeOptions,
        failures: Arc<AtomicU64>,
    ) -> Result<GridThread, NodeError> {
        let slot: Arc<(Mutex<GridSlot>, Condvar)> = Arc::default();
        let theirs = Arc::clone(&slot);
        let handle = std::thread::Builder::new()
            .name("polymap-ros2-grid".into())
            .spawn(move || {
                let params = GridParams {
                    resolution_m: options.resolution_m,
                    ..GridParams::default()
                };
                let mut published = 0;
                loop {
                    let job = {
                        let (lock, cv) = &*theirs;
                        let mut s = lock.lock().unwrap_or_else(|e| e.into_inner());
                        loop {
                            if let Some(job) = s.job.take() {
                                break Some(job);
                            }
                            if s.stop {
                                break None;
                            }
                            s = cv.wait(s).unwrap_or_else(|e| e.into_inner());
                        }
                    };
                    let Some(job) = job else { return published };
                    let rays = job.rays.iter().map(|(p, pts)| (*p, pts.as_slice()));
                    match Grid::build(&job.segments, rays, &params) {
                        Ok(grid) => {
                            let msg = grid_message(&options.map_frame, job.time, &grid);
                            if publisher.publish(msg).is_err() {
                                failures.fetch_add(1, Ordering::Relaxed);
                            } else {
                                published += 1;
                            }
                        }
                        Err(_) => {
                            failures.fetch_add(1, Ordering::Relaxed);
                        }
                    }
                }
            })
            .map_err(|e| setup("occupancy grid thread")(e.to_string()))?;
        Ok(GridThread {
            slot,
            handle: Some(handle),
        })
    }

    fn submit(&self, job: GridJob) {
        let (lock, cv) = &*self.slot;
        lock.lock().unwrap_or_else(|e| e.into_inner()).job = Some(job);
        cv.notify_one();
    }

    /// Builds what is waiting, then stops; the grids published.
    fn finish(&mut self) -> u64 {
        {
            let (lock, cv) = &*self.slot;
            lock.lock().unwrap_or_else(|e| e.into_inner()).stop = true;
            cv.notify_one();
        }
        self.handle
            .take()
            .map_or(0, |h| h.join().unwrap_or_default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dds_type_names_read_as_ros_names() {
        assert_eq!(
            ros_type_name("std_msgs::msg::dds_::String_"),
            "std_msgs/msg/String"
        );
        assert_eq!(ros_type_name("Custom"), "Custom");
    }

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
