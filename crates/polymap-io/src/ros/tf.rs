//! A tf buffer without ROS: the transforms of `/tf` and `/tf_static`, kept as a tree of frames
//! and asked for the transform between two frames at a time.
//!
//! Each frame has at most one parent: a `TransformStamped` with `header.frame_id = P` and
//! `child_frame_id = C` says where `C` is in `P` at `header.stamp`, `P_from_C`. Static
//! transforms (`/tf_static`) hold at every time; dynamic ones (`/tf`) are kept per edge over a
//! time window and interpolated between their stamps: translation linearly, rotation along the
//! shorter arc (spherical interpolation of the quaternions; for rotations about z alone this is
//! the yaw along the shorter arc). A lookup walks from both frames up to their common ancestor
//! and composes the edges in 3D, then projects the result to the plane.
//!
//! **The plane.** [`TfLookup::pose`] is x and y of the 3D translation and the heading of the
//! rotated x axis (the yaw, `atan2(2(wz + xy), 1 - 2(y² + z²))`); z, roll and pitch are
//! dropped. Links tilted against each other are composed exactly before the projection, so a
//! chain that tilts and levels again (a mast, a levelled laser) projects right. A frame that
//! stays tilted against the target (a laser pitched down to see the floor, one mounted upside
//! down) cannot be a planar scan: [`TfLookup::tilt_rad`] says by how much its z axis leans
//! from the target's, for the caller to warn; an upside-down laser (tilt near π) would need its
//! beams mirrored, which a [`Pose2`] cannot say.
//!
//! **Names** are normalized as tf2 does: one leading `/` is stripped (`/base_link` is
//! `base_link`).
//!
//! **Memory** is bounded ([`TfLimits`]): dynamic transforms older than the window before their
//! edge's newest stamp are dropped (tf2's default cache is 10 s, and so is this one's); all
//! edges together hold at most [`TfLimits::max_samples`] (beyond, the oldest transform of the
//! fullest edge goes); frames are at most [`TfLimits::max_frames`], and their names at most
//! [`TfLimits::max_frame_name_bytes`] long. What does not fit is refused with an error, never
//! grown into.
//!
//! ```
//! use polymap::geometry::Pose2;
//! use polymap_io::ros::tf::{TfBuffer, TfLimits};
//! use polymap_io::ros::{RosTime, TransformStampedMsg};
//! let t = |s: i64| RosTime { sec: s, nanosec: 0 };
//! let mut tf = TfBuffer::new(TfLimits::default());
//! // The laser 0.25 m ahead of the base, for good; the base moving 1 m/s along x in odom.
//! let mount = Pose2::new(0.25, 0.0, 0.0);
//! tf.insert(&TransformStampedMsg::from_pose(t(0), "base_link", "/laser", &mount), true).unwrap();
//! for s in 0..3 {
//!     let odom = Pose2::new(s as f64, 0.0, 0.0);
//!     let moved = TransformStampedMsg::from_pose(t(s), "odom", "base_link", &odom);
//!     tf.insert(&moved, false).unwrap();
//! }
//! let at = 1_500_000_000; // nanoseconds: 1.5 s
//! let robot_from_laser = tf.lookup("base_link", "laser", at).unwrap().pose;
//! assert_eq!(robot_from_laser, mount);
//! let odom_from_laser = tf.lookup("odom", "laser", at).unwrap().pose;
//! assert!((odom_from_laser.x_m - 1.75).abs() < 1e-12);
//! // 3 s is beyond the last transform of odom → base_link (2 s): refused.
//! assert!(tf.lookup("odom", "laser", 3_000_000_000).is_err());
//! ```

use std::collections::{HashMap, VecDeque};

use glam::{DQuat, DVec3};
use polymap::geometry::Pose2;

use super::messages::{RosTime, TfMessage, TransformStampedMsg};

/// Bounds and tolerances of a [`TfBuffer`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TfLimits {
    /// How long the dynamic transforms of an edge are kept, counted back from that edge's newest
    /// stamp, nanoseconds. Default 10 s (tf2's default cache).
    pub cache_ns: i128,
    /// How far beyond the first or last stamp of an edge a lookup may reach, nanoseconds; it
    /// then takes that edge's nearest transform. Beyond it a lookup is refused
    /// ([`TfError::Extrapolation`]). Default 50 ms.
    pub extrapolation_ns: i128,
    /// Most frames held; a transform naming a frame beyond them is refused. Default 1,000.
    pub max_frames: usize,
    /// Most dynamic transforms held over all edges (about 100 bytes each). Default 262,144.
    pub max_samples: usize,
    /// Longest frame name accepted, bytes. Default 256.
    pub max_frame_name_bytes: usize,
}

impl Default for TfLimits {
    fn default() -> Self {
        TfLimits {
            cache_ns: 10_000_000_000,
            extrapolation_ns: 50_000_000,
            max_frames: 1_000,
            max_samples: 1 << 18,
            max_frame_name_bytes: 256,
        }
    }
}

/// Why a transform was refused or a lookup could not be answered.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TfError {
    /// A frame no transform names.
    #[error("frame {frame:?} is not in tf")]
    UnknownFrame {
        /// The frame (normalized).
        frame: String,
    },
    /// Two frames in different trees.
    #[error(
        "frames {target_frame:?} and {source_frame:?} are not connected in tf (their roots are \
         {target_root:?} and {source_root:?})"
    )]
    NotConnected {
        /// The frame asked for as target.
        target_frame: String,
        /// The frame asked for as source.
        source_frame: String,
        /// The root of the target's tree.
        target_root: String,
        /// The root of the source's tree.
        source_root: String,
    },
    /// A lookup beyond the time span of a dynamic edge, by more than the tolerance.
    #[error("{}", extrapolation(.parent, .child, *.time_ns, *.earliest_ns, *.latest_ns))]
    Extrapolation {
        /// The edge's parent frame.
        parent: String,
        /// The edge's child frame.
        child: String,
        /// The time asked for, nanoseconds since the epoch.
        time_ns: i128,
        /// The edge's first stamp held, nanoseconds since the epoch.
        earliest_ns: i128,
        /// The edge's last stamp held, nanoseconds since the epoch.
        latest_ns: i128,
    },
    /// A transform that cannot be inserted.
    #[error("tf {parent:?} → {child:?} refused: {reason}")]
    Refused {
        /// Its parent frame, as written.
        parent: String,
        /// Its child frame, as written.
        child: String,
        /// Why.
        reason: String,
    },
}

fn secs(ns: i128) -> String {
    RosTime {
        sec: ns.div_euclid(1_000_000_000) as i64,
        nanosec: ns.rem_euclid(1_000_000_000) as u32,
    }
    .to_stamp()
    .text
}

fn extrapolation(parent: &str, child: &str, t: i128, earliest: i128, latest: i128) -> String {
    let (d, side) = match t < earliest {
        true => (earliest - t, "before"),
        false => (t - latest, "after"),
    };
    format!(
        "tf {parent} → {child} is known from {} to {} s: {} s is {:.3} s {side} that \
         (beyond the tolerance)",
        secs(earliest),
        secs(latest),
        secs(t),
        d as f64 * 1e-9
    )
}

/// The answer to a lookup: the transform `target_from_source` in the plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TfLookup {
    /// Where the source frame is in the target frame, projected to the plane: x, y (metres) and
    /// yaw (radians) of the 3D transform; z, roll and pitch dropped.
    pub pose: Pose2,
    /// How far the source frame's z axis leans from the target's, radians (0: level with each
    /// other; π: upside down).
    pub tilt_rad: f64,
    /// The widest time between the two transforms of one edge interpolated between,
    /// nanoseconds (0 when only static transforms or exact stamps were used).
    pub widest_gap_ns: i128,
}

/// What a [`TfBuffer`] has taken in and let go, for the reader's counts.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TfCounts {
    /// Transforms inserted.
    pub inserted: u64,
    /// Transforms refused ([`TfBuffer::insert`] returned an error).
    pub refused: u64,
    /// Transforms that gave a frame another parent than it had (its old edge was dropped).
    pub reparented: u64,
    /// Dynamic transforms dropped to keep [`TfLimits::max_samples`].
    pub evicted: u64,
}

/// A rigid transform in 3D: rotation, then translation.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Rigid {
    rotation: DQuat,
    translation: DVec3,
}

impl Rigid {
    const IDENTITY: Rigid = Rigid {
        rotation: DQuat::IDENTITY,
        translation: DVec3::ZERO,
    };

    /// `self ∘ other`: `a_from_b ∘ b_from_c = a_from_c`.
    fn compose(&self, other: &Rigid) -> Rigid {
        Rigid {
            rotation: self.rotation * other.rotation,
            translation: self.translation + self.rotation * other.translation,
        }
    }

    fn inverse(&self) -> Rigid {
        let r = self.rotation.conjugate();
        Rigid {
            rotation: r,
            translation: -(r * self.translation),
        }
    }

    fn interpolate(&self, other: &Rigid, f: f64) -> Rigid {
        Rigid {
            rotation: self.rotation.slerp(other.rotation, f).normalize(),
            translation: self.translation.lerp(other.translation, f),
        }
    }

    /// x, y and yaw, and the tilt of the z axis.
    fn planar(&self) -> (Pose2, f64) {
        let DQuat { x, y, z, w } = self.rotation;
        let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
        let tilt = (1.0 - 2.0 * (x * x + y * y)).clamp(-1.0, 1.0).acos();
        let t = self.translation;
        (Pose2::new(t.x, t.y, yaw), tilt)
    }
}

#[derive(Debug, Clone)]
struct Sample {
    stamp_ns: i128,
    transform: Rigid,
}

#[derive(Debug, Clone)]
enum Link {
    Static(Rigid),
    Dynamic(VecDeque<Sample>),
}

#[derive(Debug, Clone)]
struct Edge {
    parent: usize,
    link: Link,
}

/// The tf tree: frames, each with at most one parent edge, static or dynamic. See the module
/// documentation for the rules.
#[derive(Debug, Clone)]
pub struct TfBuffer {
    limits: TfLimits,
    names: Vec<String>,
    index: HashMap<String, usize>,
    /// The edge to each frame's parent, by frame.
    edges: Vec<Option<Edge>>,
    samples: usize,
    counts: TfCounts,
}

/// A frame name as tf2 normalizes it: one leading `/` stripped.
///
/// ```
/// use polymap_io::ros::tf::frame_name;
/// assert_eq!(frame_name("/base_link"), "base_link");
/// assert_eq!(frame_name("laser"), "laser");
/// ```
pub fn frame_name(name: &str) -> &str {
    name.strip_prefix('/').unwrap_or(name)
}

impl TfBuffer {
    /// An empty buffer.
    pub fn new(limits: TfLimits) -> Self {
        TfBuffer {
            limits,
            names: Vec::new(),
            index: HashMap::new(),
            edges: Vec::new(),
            samples: 0,
            counts: TfCounts::default(),
        }
    }

    /// The limits it was made with.
    pub fn limits(&self) -> &TfLimits {
        &self.limits
    }

    /// Inserts one transform, static (valid at every time, replacing the frame's edge) or
    /// dynamic (kept with the others of its edge for [`TfLimits::cache_ns`]). A transform that
    /// gives its child another parent replaces the child's edge. Refused, with the frames named:
    /// an empty or overlong frame name, a frame its own parent, a non-finite value, a
    /// quaternion whose squared norm is off 1 by more than 0.01 (tf2's rule), a transform
    /// that would close a loop of frames, a new frame beyond [`TfLimits::max_frames`], and a
    /// dynamic transform older than its edge's window.
    pub fn insert(&mut self, t: &TransformStampedMsg, is_static: bool) -> Result<(), TfError> {
        let result = self.try_insert(t, is_static);
        match &result {
            Ok(()) => self.counts.inserted += 1,
            Err(_) => self.counts.refused += 1,
        }
        result
    }

    /// Inserts every transform of a message; returns the refusals (the others are inserted).
    pub fn insert_message(&mut self, msg: &TfMessage, is_static: bool) -> Vec<TfError> {
        msg.transforms
            .iter()
            .filter_map(|t| self.insert(t, is_static).err())
            .collect()
    }

    fn try_insert(&mut self, t: &TransformStampedMsg, is_static: bool) -> Result<(), TfError> {
        let refuse = |reason: String| TfError::Refused {
            parent: t.parent_frame.clone(),
            child: t.child_frame.clone(),
            reason,
        };
        let (parent, child) = (frame_name(&t.parent_frame), frame_name(&t.child_frame));
        for name in [parent, child] {
            if name.is_empty() {
                return Err(refuse("an empty frame name".into()));
            }
            if name.len() > self.limits.max_frame_name_bytes {
                return Err(refuse(format!(
                    "a frame name of {} bytes, more than {}",
                    name.len(),
                    self.limits.max_frame_name_bytes
                )));
            }
        }
        if parent == child {
            return Err(refuse("a frame cannot be its own parent".into()));
        }
        let values = t.translation_m.iter().chain(&t.rotation);
        if !values.clone().all(|v| v.is_finite()) {
            return Err(refuse("a value is not finite".into()));
        }
        let [qx, qy, qz, qw] = t.rotation;
        let q = DQuat::from_xyzw(qx, qy, qz, qw);
        if (q.length_squared() - 1.0).abs() > 0.01 {
            return Err(refuse(format!(
                "the rotation's quaternion has squared norm {}, not 1",
                q.length_squared()
            )));
        }
        let transform = Rigid {
            rotation: q.normalize(),
            translation: DVec3::from_array(t.translation_m),
        };
        let new_frames = [parent, child]
            .iter()
            .filter(|n| !self.index.contains_key(**n))
            .count();
        if self.names.len() + new_frames > self.limits.max_frames {
            return Err(refuse(format!(
                "tf already holds {} frames, the most it keeps",
                self.limits.max_frames
            )));
        }
        let p = self.frame_id(parent);
        let c = self.frame_id(child);
        // A loop: the child is already an ancestor of the parent.
        if self.ancestors(p).contains(&c) {
            return Err(refuse(format!(
                "{child:?} is already above {parent:?} in tf: the tree would have a loop"
            )));
        }
        let stamp_ns = t.stamp.nanos();
        let old = self.edges[c].take();
        if let Some(Edge {
            link: Link::Dynamic(samples),
            ..
        }) = &old
        {
            self.samples -= samples.len();
        }
        let reparented = old.as_ref().is_some_and(|e| e.parent != p);
        self.counts.reparented += u64::from(reparented);
        let link = match (old, is_static) {
            (_, true) => Link::Static(transform),
            (
                Some(Edge {
                    parent,
                    link: Link::Dynamic(samples),
                }),
                false,
            ) if parent == p => Link::Dynamic(samples),
            (_, false) => Link::Dynamic(VecDeque::new()),
        };
        let mut edge = Edge { parent: p, link };
        let mut result = Ok(());
        if let Link::Dynamic(samples) = &mut edge.link {
            result = insert_sample(samples, stamp_ns, transform, self.limits.cache_ns, &refuse);
            self.samples += samples.len();
        }
        // A dynamic edge holds at least one transform.
        let empty = matches!(&edge.link, Link::Dynamic(s) if s.is_empty());
        self.edges[c] = (!empty).then_some(edge);
        self.evict();
        result
    }

    /// Drops the oldest transform of the fullest edge until [`TfLimits::max_samples`] holds.
    fn evict(&mut self) {
        if self.samples <= self.limits.max_samples {
            return;
        }
        while self.samples > self.limits.max_samples {
            let fullest = self
                .edges
                .iter_mut()
                .filter_map(|e| match e {
                    Some(Edge {
                        link: Link::Dynamic(s),
                        ..
                    }) => Some(s),
                    _ => None,
                })
                .max_by_key(|s| s.len());
            match fullest {
                Some(s) if !s.is_empty() => {
                    s.pop_front();
                    self.samples -= 1;
                    self.counts.evicted += 1;
                }
                _ => break,
            }
        }
        for e in &mut self.edges {
            if matches!(e, Some(Edge { link: Link::Dynamic(s), .. }) if s.is_empty()) {
                *e = None;
            }
        }
    }

    fn frame_id(&mut self, name: &str) -> usize {
        if let Some(&i) = self.index.get(name) {
            return i;
        }
        let i = self.names.len();
        self.names.push(name.to_owned());
        self.index.insert(name.to_owned(), i);
        self.edges.push(None);
        i
    }

    /// The frame and its ancestors, up to its tree's root.
    fn ancestors(&self, frame: usize) -> Vec<usize> {
        let mut chain = vec![frame];
        let mut at = frame;
        // Inserts keep the tree free of loops; the bound only guards that.
        while let Some(e) = &self.edges[at] {
            if chain.len() > self.names.len() {
                break;
            }
            chain.push(e.parent);
            at = e.parent;
        }
        chain
    }

    /// The transform `target_from_source` at `time_ns` (nanoseconds since the epoch, as
    /// [`RosTime::nanos`]): where `source` is in `target`, projected to the plane (see the
    /// module documentation). The names are normalized; a frame with itself is the identity.
    pub fn lookup(&self, target: &str, source: &str, time_ns: i128) -> Result<TfLookup, TfError> {
        let (target, source) = (frame_name(target), frame_name(source));
        if target == source {
            return Ok(TfLookup {
                pose: Pose2::IDENTITY,
                tilt_rad: 0.0,
                widest_gap_ns: 0,
            });
        }
        let id = |frame: &str| {
            self.index
                .get(frame)
                .copied()
                .ok_or_else(|| TfError::UnknownFrame {
                    frame: frame.to_owned(),
                })
        };
        let (t, s) = (id(target)?, id(source)?);
        let (up_t, up_s) = (self.ancestors(t), self.ancestors(s));
        let Some(common) = up_s.iter().position(|f| up_t.contains(f)) else {
            let root = |chain: &[usize]| self.names[*chain.last().unwrap_or(&0)].clone();
            return Err(TfError::NotConnected {
                target_frame: target.to_owned(),
                source_frame: source.to_owned(),
                target_root: root(&up_t),
                source_root: root(&up_s),
            });
        };
        let ancestor = up_s[common];
        let mut gap = 0;
        let ancestor_from_source = self.up_to(&up_s, ancestor, time_ns, &mut gap)?;
        let ancestor_from_target = self.up_to(&up_t, ancestor, time_ns, &mut gap)?;
        let (pose, tilt_rad) = ancestor_from_target
            .inverse()
            .compose(&ancestor_from_source)
            .planar();
        Ok(TfLookup {
            pose,
            tilt_rad,
            widest_gap_ns: gap,
        })
    }

    /// `ancestor_from_chain[0]` at `time_ns`, composing the edges of `chain` up to `ancestor`.
    fn up_to(
        &self,
        chain: &[usize],
        ancestor: usize,
        time_ns: i128,
        gap: &mut i128,
    ) -> Result<Rigid, TfError> {
        let mut acc = Rigid::IDENTITY;
        for &frame in chain.iter().take_while(|&&f| f != ancestor) {
            let Some(edge) = &self.edges[frame] else {
                break;
            };
            let (parent_from_frame, g) = self.at(edge, frame, time_ns)?;
            *gap = (*gap).max(g);
            acc = parent_from_frame.compose(&acc);
        }
        Ok(acc)
    }

    /// An edge's transform at `time_ns` and the gap interpolated across.
    fn at(&self, edge: &Edge, child: usize, time_ns: i128) -> Result<(Rigid, i128), TfError> {
        let samples = match &edge.link {
            Link::Static(t) => return Ok((*t, 0)),
            Link::Dynamic(s) => s,
        };
        let (Some(first), Some(last)) = (samples.front(), samples.back()) else {
            // Inserts and evictions keep no empty edge; answered as a frame without parent.
            return Err(TfError::UnknownFrame {
                frame: self.names[child].clone(),
            });
        };
        let tolerance = self.limits.extrapolation_ns;
        let beyond = || TfError::Extrapolation {
            parent: self.names[edge.parent].clone(),
            child: self.names[child].clone(),
            time_ns,
            earliest_ns: first.stamp_ns,
            latest_ns: last.stamp_ns,
        };
        if time_ns <= first.stamp_ns {
            return match first.stamp_ns - time_ns <= tolerance {
                true => Ok((first.transform, 0)),
                false => Err(beyond()),
            };
        }
        if time_ns >= last.stamp_ns {
            return match time_ns - last.stamp_ns <= tolerance {
                true => Ok((last.transform, 0)),
                false => Err(beyond()),
            };
        }
        // first < time < last: a bracket exists.
        let i = samples.partition_point(|s| s.stamp_ns <= time_ns);
        let (a, b) = (&samples[i - 1], &samples[i]);
        if a.stamp_ns == time_ns {
            return Ok((a.transform, 0));
        }
        let span = b.stamp_ns - a.stamp_ns;
        let f = (time_ns - a.stamp_ns) as f64 / span as f64;
        Ok((a.transform.interpolate(&b.transform, f), span))
    }

    /// True when a transform names `frame` (normalized).
    pub fn has_frame(&self, frame: &str) -> bool {
        self.index.contains_key(frame_name(frame))
    }

    /// The parent of `frame` (normalized), if it has one.
    pub fn parent(&self, frame: &str) -> Option<&str> {
        let i = *self.index.get(frame_name(frame))?;
        self.edges[i]
            .as_ref()
            .map(|e| self.names[e.parent].as_str())
    }

    /// The frames, in the order they were first named.
    pub fn frames(&self) -> impl Iterator<Item = &str> {
        self.names.iter().map(String::as_str)
    }

    /// Dynamic transforms held, over all edges.
    pub fn samples_held(&self) -> usize {
        self.samples
    }

    /// What the buffer took in and let go.
    pub fn counts(&self) -> TfCounts {
        self.counts
    }
}

/// Inserts a transform in stamp order (replacing one of the same stamp), then drops those
/// older than the window before the newest.
fn insert_sample(
    samples: &mut VecDeque<Sample>,
    stamp_ns: i128,
    transform: Rigid,
    cache_ns: i128,
    refuse: &dyn Fn(String) -> TfError,
) -> Result<(), TfError> {
    if let Some(newest) = samples.back().map(|s| s.stamp_ns)
        && stamp_ns < newest - cache_ns
    {
        return Err(refuse(format!(
            "stamped {} s, more than the {} s kept before the newest ({} s)",
            secs(stamp_ns),
            cache_ns as f64 * 1e-9,
            secs(newest)
        )));
    }
    let sample = Sample {
        stamp_ns,
        transform,
    };
    match samples.back() {
        Some(last) if last.stamp_ns < stamp_ns => samples.push_back(sample),
        None => samples.push_back(sample),
        _ => {
            let i = samples.partition_point(|s| s.stamp_ns < stamp_ns);
            match samples.get(i) {
                Some(s) if s.stamp_ns == stamp_ns => samples[i] = sample,
                _ => samples.insert(i, sample),
            }
        }
    }
    let newest = samples.back().map_or(stamp_ns, |s| s.stamp_ns);
    while samples
        .front()
        .is_some_and(|s| s.stamp_ns < newest - cache_ns)
    {
        samples.pop_front();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::f64::consts::{FRAC_PI_2, PI};

    use super::*;

    const S: i128 = 1_000_000_000;

    fn time(ns: i128) -> RosTime {
        RosTime {
            sec: ns.div_euclid(S) as i64,
            nanosec: ns.rem_euclid(S) as u32,
        }
    }

    fn planar(
        ns: i128,
        parent: &str,
        child: &str,
        x: f64,
        y: f64,
        yaw: f64,
    ) -> TransformStampedMsg {
        TransformStampedMsg::from_pose(time(ns), parent, child, &Pose2::new(x, y, yaw))
    }

    fn close(a: Pose2, b: Pose2) -> bool {
        (a.x_m - b.x_m).abs() < 1e-9
            && (a.y_m - b.y_m).abs() < 1e-9
            && Pose2::new(0.0, 0.0, a.theta_rad - b.theta_rad)
                .theta_rad
                .abs()
                < 1e-9
    }

    /// odom → base_link (dynamic, 1 m/s along x, turning 0.1 rad/s), base_link → laser and
    /// base_link → camera (static), from 0 to 10 s at 10 Hz.
    fn robot() -> TfBuffer {
        let mut tf = TfBuffer::new(TfLimits::default());
        tf.insert(&planar(0, "base_link", "laser", 0.25, 0.1, 0.3), true)
            .unwrap();
        tf.insert(&planar(0, "base_link", "camera", -0.1, 0.0, PI), true)
            .unwrap();
        for k in 0..=100 {
            let s = k as f64 * 0.1;
            tf.insert(
                &planar(k * S / 10, "odom", "base_link", s, 0.0, 0.1 * s),
                false,
            )
            .unwrap();
        }
        tf
    }

    #[test]
    fn a_chain_is_composed_up_to_the_common_ancestor() {
        let tf = robot();
        let mount = Pose2::new(0.25, 0.1, 0.3);
        let at = 2 * S;
        let base = Pose2::new(2.0, 0.0, 0.2);
        let l = tf.lookup("odom", "laser", at).unwrap();
        assert!(close(l.pose, base.compose(&mount)), "{l:?}");
        assert_eq!(l.tilt_rad, 0.0);
        // The other way round, the inverse.
        let back = tf.lookup("laser", "odom", at).unwrap().pose;
        assert!(close(back, base.compose(&mount).inverse()), "{back:?}");
        // Siblings under base_link: no dynamic edge is needed, so any time answers.
        let camera = Pose2::new(-0.1, 0.0, PI);
        let c = tf.lookup("camera", "laser", 1_000 * S).unwrap().pose;
        assert!(close(c, camera.inverse().compose(&mount)), "{c:?}");
        assert!(close(
            tf.lookup("base_link", "laser", 0).unwrap().pose,
            mount
        ));
        assert_eq!(tf.parent("laser"), Some("base_link"));
        assert_eq!(tf.parent("odom"), None);
    }

    #[test]
    fn dynamic_transforms_interpolate_linearly_and_along_the_shorter_arc() {
        let mut tf = TfBuffer::new(TfLimits::default());
        tf.insert(&planar(0, "odom", "base_link", 0.0, 0.0, 3.0), false)
            .unwrap();
        tf.insert(&planar(S, "odom", "base_link", 2.0, 4.0, -3.0), false)
            .unwrap();
        let mid = tf.lookup("odom", "base_link", S / 2).unwrap();
        assert!((mid.pose.x_m - 1.0).abs() < 1e-12 && (mid.pose.y_m - 2.0).abs() < 1e-12);
        // Through ±π, not through 0.
        assert!((mid.pose.theta_rad.abs() - PI).abs() < 1e-9, "{mid:?}");
        assert_eq!(mid.widest_gap_ns, S);
        let quarter = tf.lookup("odom", "base_link", S / 4).unwrap().pose;
        let expected = 3.0 + 0.25 * (2.0 * PI - 6.0);
        assert!(
            close(quarter, Pose2::new(0.5, 1.0, expected)),
            "{quarter:?}"
        );
        // At a stamp: that transform, no gap.
        let at = tf.lookup("odom", "base_link", S).unwrap();
        assert!(close(at.pose, Pose2::new(2.0, 4.0, -3.0)) && at.widest_gap_ns == 0);
    }

    #[test]
    fn static_transforms_answer_at_every_time() {
        let mut tf = TfBuffer::new(TfLimits::default());
        tf.insert(
            &planar(5 * S, "base_footprint", "base_link", 0.0, 0.0, 0.0),
            true,
        )
        .unwrap();
        tf.insert(
            &planar(5 * S, "base_link", "laser", 0.3, 0.0, FRAC_PI_2),
            true,
        )
        .unwrap();
        for at in [-1_000 * S, 0, 5 * S, 1_000_000 * S] {
            let l = tf.lookup("base_footprint", "laser", at).unwrap();
            assert!(
                close(l.pose, Pose2::new(0.3, 0.0, FRAC_PI_2)),
                "{at}: {l:?}"
            );
            assert_eq!(l.widest_gap_ns, 0);
        }
    }

    #[test]
    fn missing_and_unconnected_frames_are_named() {
        let tf = robot();
        let e = tf.lookup("base_link", "sonar", 0).unwrap_err();
        assert_eq!(
            e,
            TfError::UnknownFrame {
                frame: "sonar".into()
            }
        );
        let mut tf = robot();
        tf.insert(&planar(0, "map", "gps", 1.0, 0.0, 0.0), true)
            .unwrap();
        let e = tf.lookup("laser", "gps", S).unwrap_err().to_string();
        assert!(
            e.contains("\"laser\" and \"gps\" are not connected")
                && e.contains("roots are \"odom\" and \"map\""),
            "{e}"
        );
        // A frame with itself is the identity, known or not.
        assert_eq!(tf.lookup("x", "/x", 0).unwrap().pose, Pose2::IDENTITY);
    }

    #[test]
    fn a_leading_slash_is_stripped() {
        let mut tf = TfBuffer::new(TfLimits::default());
        tf.insert(&planar(0, "/base_link", "/laser", 0.2, 0.0, 0.0), true)
            .unwrap();
        for (target, source) in [("base_link", "laser"), ("/base_link", "/laser")] {
            let p = tf.lookup(target, source, 0).unwrap().pose;
            assert_eq!(p, Pose2::new(0.2, 0.0, 0.0));
        }
        assert!(tf.has_frame("laser") && tf.has_frame("/laser"));
        assert_eq!(tf.frames().collect::<Vec<_>>(), ["base_link", "laser"]);
        // Only one slash goes, as in tf2.
        assert!(!tf.has_frame("//laser"));
    }

    #[test]
    fn extrapolation_beyond_the_tolerance_is_refused() {
        let tf = robot(); // odom → base_link from 0 to 10 s
        let tolerance = TfLimits::default().extrapolation_ns;
        // Within the tolerance: the nearest transform.
        let late = tf.lookup("odom", "base_link", 10 * S + tolerance).unwrap();
        assert!(close(late.pose, Pose2::new(10.0, 0.0, 1.0)), "{late:?}");
        let early = tf.lookup("odom", "base_link", -tolerance).unwrap();
        assert!(close(early.pose, Pose2::IDENTITY), "{early:?}");
        // Beyond it: refused, saying by how much and which edge.
        let e = tf.lookup("odom", "laser", 11 * S).unwrap_err();
        assert!(matches!(e, TfError::Extrapolation { .. }), "{e:?}");
        let text = e.to_string();
        assert!(
            text.contains("tf odom → base_link is known from 0.000000 to 10.000000 s")
                && text.contains("1.000 s after"),
            "{text}"
        );
        let e = tf.lookup("odom", "base_link", -S).unwrap_err().to_string();
        assert!(e.contains("1.000 s before"), "{e}");
        // A lookup that needs no dynamic edge is not refused.
        assert!(tf.lookup("base_link", "laser", 11 * S).is_ok());
    }

    #[test]
    fn memory_is_bounded_by_the_window_the_samples_and_the_frames() {
        // 100 s at 1 kHz on one edge: only the last 10 s are kept.
        let mut tf = TfBuffer::new(TfLimits::default());
        for k in 0..100_000 {
            tf.insert(
                &planar(k * S / 1000, "odom", "base_link", 0.0, 0.0, 0.0),
                false,
            )
            .unwrap();
        }
        assert_eq!(tf.samples_held(), 10_001);
        assert!(tf.lookup("odom", "base_link", 95 * S).is_ok());
        assert!(tf.lookup("odom", "base_link", 80 * S).is_err());
        // Older than the window before the newest: refused.
        let old = planar(50 * S, "odom", "base_link", 0.0, 0.0, 0.0);
        assert!(tf.insert(&old, false).is_err());
        // At most `max_samples` over all edges: the fullest edge gives way.
        let limits = TfLimits {
            max_samples: 1_000,
            max_frames: 20,
            ..TfLimits::default()
        };
        let mut tf = TfBuffer::new(limits);
        for k in 0..5_000 {
            for child in ["a", "b", "c"] {
                tf.insert(&planar(k * S / 1000, "odom", child, 0.0, 0.0, 0.0), false)
                    .unwrap();
            }
        }
        assert_eq!(tf.samples_held(), 1_000);
        assert!(tf.counts().evicted > 0);
        for child in ["a", "b", "c"] {
            assert!(
                tf.lookup("odom", child, 4_999 * S / 1000).is_ok(),
                "{child}"
            );
        }
        // At most `max_frames` frames (odom, a, b, c and 16 more).
        for k in 0..16 {
            tf.insert(&planar(0, "odom", &format!("f{k}"), 0.0, 0.0, 0.0), true)
                .unwrap();
        }
        let e = tf
            .insert(&planar(0, "odom", "one_more", 0.0, 0.0, 0.0), true)
            .unwrap_err();
        assert!(e.to_string().contains("already holds 20 frames"), "{e}");
        assert_eq!(tf.frames().count(), 20);
        // An overlong name is refused.
        let long = "x".repeat(300);
        let e = tf.insert(&planar(0, "odom", &long, 0.0, 0.0, 0.0), true);
        assert!(e.unwrap_err().to_string().contains("300 bytes"));
    }

    #[test]
    fn bad_transforms_are_refused_naming_the_frames() {
        let mut tf = robot();
        let mut bad = planar(0, "base_link", "sonar", 0.0, 0.0, 0.0);
        bad.translation_m[0] = f64::NAN;
        let e = tf.insert(&bad, true).unwrap_err().to_string();
        assert!(
            e.contains("\"base_link\" → \"sonar\"") && e.contains("not finite"),
            "{e}"
        );
        bad.translation_m[0] = 0.0;
        bad.rotation = [0.0, 0.0, 0.0, 0.5];
        let e = tf.insert(&bad, true).unwrap_err().to_string();
        assert!(e.contains("squared norm 0.25"), "{e}");
        let e = tf
            .insert(&planar(0, "laser", "/laser", 0.0, 0.0, 0.0), true)
            .unwrap_err();
        assert!(e.to_string().contains("its own parent"), "{e}");
        // laser → odom would close the loop odom → base_link → laser → odom.
        let e = tf
            .insert(&planar(0, "laser", "odom", 0.0, 0.0, 0.0), true)
            .unwrap_err();
        assert!(e.to_string().contains("loop"), "{e}");
        assert!(tf.lookup("odom", "laser", S).is_ok());
        assert_eq!(tf.counts().refused, 4);
    }

    #[test]
    fn a_new_parent_replaces_the_edge() {
        let mut tf = robot();
        tf.insert(&planar(0, "odom", "laser", 1.0, 0.0, 0.0), true)
            .unwrap();
        assert_eq!(tf.parent("laser"), Some("odom"));
        assert_eq!(tf.counts().reparented, 1);
        let p = tf.lookup("odom", "laser", 5 * S).unwrap().pose;
        assert_eq!(p, Pose2::new(1.0, 0.0, 0.0));
    }

    #[test]
    fn transforms_out_of_order_are_sorted_and_a_repeated_stamp_replaces() {
        let mut tf = TfBuffer::new(TfLimits::default());
        for (k, x) in [(2, 2.0), (0, 0.0), (1, 9.0), (1, 1.0)] {
            tf.insert(&planar(k * S, "odom", "base_link", x, 0.0, 0.0), false)
                .unwrap();
        }
        assert_eq!(tf.samples_held(), 3);
        let p = tf.lookup("odom", "base_link", S / 2).unwrap().pose;
        assert!((p.x_m - 0.5).abs() < 1e-12, "{p:?}");
        let p = tf.lookup("odom", "base_link", 3 * S / 2).unwrap().pose;
        assert!((p.x_m - 1.5).abs() < 1e-12, "{p:?}");
    }

    #[test]
    fn tilt_is_composed_in_3d_and_reported() {
        let mut tf = TfBuffer::new(TfLimits::default());
        // A mast pitched down by 30° at 1 m height, then a laser levelled again on it, 0.5 m
        // along the mast.
        let pitch = 30f64.to_radians();
        let q = DQuat::from_rotation_y(pitch);
        let mast = TransformStampedMsg {
            stamp: time(0),
            parent_frame: "base_link".into(),
            child_frame: "mast".into(),
            translation_m: [0.0, 0.0, 1.0],
            rotation: q.to_array(),
        };
        tf.insert(&mast, true).unwrap();
        let level = TransformStampedMsg {
            child_frame: "laser".into(),
            parent_frame: "mast".into(),
            translation_m: [0.5, 0.0, 0.0],
            rotation: q.inverse().to_array(),
            ..mast.clone()
        };
        tf.insert(&level, true).unwrap();
        let l = tf.lookup("base_link", "laser", 0).unwrap();
        assert!(l.tilt_rad < 1e-9, "{l:?}");
        assert!(
            close(l.pose, Pose2::new(0.5 * pitch.cos(), 0.0, 0.0)),
            "{l:?}"
        );
        let m = tf.lookup("base_link", "mast", 0).unwrap();
        assert!((m.tilt_rad - pitch).abs() < 1e-9, "{m:?}");
        // Upside down (rolled by π): a tilt of π.
        let flipped = TransformStampedMsg {
            child_frame: "flipped".into(),
            parent_frame: "base_link".into(),
            rotation: DQuat::from_rotation_x(PI).to_array(),
            ..mast
        };
        tf.insert(&flipped, true).unwrap();
        let f = tf.lookup("base_link", "flipped", 0).unwrap();
        assert!((f.tilt_rad - PI).abs() < 1e-6, "{f:?}");
    }
}
