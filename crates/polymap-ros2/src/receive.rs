//! The node's receiving thread: it polls the subscriptions (scans, odometry, `/tf`,
//! `/tf_static`), places each scan's frame on the robot through tf, and feeds the scan queue.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use polymap::geometry::Pose2;
use polymap_io::ros::tf::{TfBuffer, frame_name};
use polymap_io::ros::{BASE_FOOTPRINT, BASE_LINK, ODOM_FRAME};
use polymap_io::ros::{LaserScanMsg, RosTime, TransformStampedMsg};
use ros2_client::dds::rustdds::DomainParticipant;
use ros2_client::dds::rustdds::mio1::{Events, Interest, Poll, Token};
use ros2_client::{MessageTypeName, Subscription};

use crate::live::ScanQueue;
use crate::msgs::{LaserScan, Odometry, RosMessage, TfMessage};
use crate::node::Frames;
use crate::outputs::plane_pose;

/// The receiving thread's state.
pub(crate) struct Receiving {
    /// For what discovery saw: publishers of another type on the scan topic.
    pub(crate) participant: DomainParticipant,
    /// The scan topic's DDS name (`rt/scan`).
    pub(crate) scan_dds_topic: String,
    /// When the publishers on the scan topic were last looked at.
    pub(crate) checked_writers: Option<Instant>,
    pub(crate) scans: Subscription<LaserScan>,
    pub(crate) odometry: Option<Subscription<Odometry>>,
    pub(crate) tf: Subscription<TfMessage>,
    pub(crate) tf_static: Subscription<TfMessage>,
    /// Every transform received (bounded by its limits).
    pub(crate) buffer: TfBuffer,
    /// The robot's frame once found: `base_option`, else `base_link`, else `base_footprint`.
    pub(crate) base: Option<String>,
    pub(crate) base_option: Option<String>,
    /// Per scan frame, once decided: its last mounting from tf, or `None` (taken as the robot).
    pub(crate) mounts: std::collections::HashMap<String, Option<Pose2>>,
    /// Scans whose frame is not decided yet, oldest first.
    pub(crate) waiting:
        std::collections::VecDeque<(polymap::scan::RangeScan, String, RosTime, Instant)>,
    pub(crate) queue: Arc<ScanQueue>,
    pub(crate) frames: Arc<Mutex<Frames>>,
    pub(crate) stop: Arc<AtomicBool>,
    pub(crate) topic: String,
}

const SCANS: Token = Token(0);
const ODOMETRY: Token = Token(1);
const TF: Token = Token(2);
const TF_STATIC: Token = Token(3);
/// How often the receiving thread looks at its stop flag.
const RECEIVE_POLL: Duration = Duration::from_millis(50);

impl Receiving {
    pub(crate) fn run(mut self) {
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
}
