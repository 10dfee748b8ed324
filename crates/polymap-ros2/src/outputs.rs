//! The node's outgoing messages, built from what the mapper says (pure functions, so each is
//! tested without DDS).

use polymap::geometry::{Pose2, Segment};
use polymap_export::pgm::{Cell, OccupancyGrid as Grid};
use polymap_io::ros::RosTime;

use crate::msgs::{
    ColorRgba, Covariance, DiagnosticArray, DiagnosticStatus, Header, KeyValue, MapMetaData,
    Marker, MarkerArray, OccupancyGrid, Point, Pose, PoseWithCovariance, PoseWithCovarianceStamped,
    Quaternion, TfMessage, Time, Transform, TransformStamped, Vector3,
};

/// The ROS time of a stamp in seconds (the scans' own header stamps, as mapped).
pub fn ros_time(stamp_s: f64) -> Time {
    let t = RosTime::from_stamp(&polymap::scan::Stamp::from_seconds(stamp_s))
        .unwrap_or(RosTime { sec: 0, nanosec: 0 });
    Time {
        sec: i32::try_from(t.sec).unwrap_or(i32::MAX),
        nanosec: t.nanosec,
    }
}

/// A plane pose as a ROS pose (z = 0).
pub fn pose_of(p: &Pose2) -> Pose {
    Pose {
        position: Point {
            x: p.x_m,
            y: p.y_m,
            z: 0.0,
        },
        orientation: Quaternion::from_yaw(p.theta_rad),
    }
}

/// A plane pose as a ROS transform (parent from child).
pub fn transform_of(p: &Pose2) -> Transform {
    Transform {
        translation: Vector3 {
            x: p.x_m,
            y: p.y_m,
            z: 0.0,
        },
        rotation: Quaternion::from_yaw(p.theta_rad),
    }
}

/// The plane part (x, y, yaw) of a ROS pose.
pub fn plane_pose(p: &Pose) -> Pose2 {
    Pose2::new(p.position.x, p.position.y, p.orientation.yaw())
}

/// A 6×6 ROS covariance (x, y, z, roll, pitch, yaw) from the plane's 3×3; z, roll and pitch
/// are fixed by the plane (0).
pub fn covariance_6(c: &[[f64; 3]; 3]) -> Covariance {
    let mut out = [0.0; 36];
    let idx = [0usize, 1, 5];
    for (i, &r) in idx.iter().enumerate() {
        for (j, &k) in idx.iter().enumerate() {
            out[r * 6 + k] = c[i][j];
        }
    }
    Covariance(out)
}

/// The pose message for a scan: `map_from_base` in `map_frame` at `stamp`.
pub fn pose_message(
    map_frame: &str,
    stamp: Time,
    map_from_base: &Pose2,
    covariance: &[[f64; 3]; 3],
) -> PoseWithCovarianceStamped {
    PoseWithCovarianceStamped {
        header: Header {
            stamp,
            frame_id: map_frame.to_owned(),
        },
        pose: PoseWithCovariance {
            pose: pose_of(map_from_base),
            covariance: covariance_6(covariance),
        },
    }
}

/// One tf transform: `child` in `parent`.
pub fn tf_message(parent: &str, child: &str, stamp: Time, parent_from_child: &Pose2) -> TfMessage {
    TfMessage {
        transforms: vec![TransformStamped {
            header: Header {
                stamp,
                frame_id: parent.to_owned(),
            },
            child_frame_id: child.to_owned(),
            transform: transform_of(parent_from_child),
        }],
    }
}

/// Line width of the map's polylines in RViz, metres.
const LINE_WIDTH_M: f64 = 0.05;

/// The map's polylines as LINE_STRIP markers in `map_frame` (namespace `polymap`), after a
/// DELETEALL that clears the markers of the previous map: segments chained in the order
/// `polylines` gives (indices into `segments`); a gap between consecutive segments is drawn
/// as a line.
pub fn markers_message(
    map_frame: &str,
    stamp: Time,
    segments: &[Segment],
    polylines: &[Vec<usize>],
) -> MarkerArray {
    let header = Header {
        stamp,
        frame_id: map_frame.to_owned(),
    };
    let mut markers = vec![Marker {
        header: header.clone(),
        ns: "polymap".into(),
        action: Marker::DELETEALL,
        ..Marker::default()
    }];
    let point = |v: polymap::geometry::Vec2| Point {
        x: v.x,
        y: v.y,
        z: 0.0,
    };
    for (id, line) in polylines.iter().enumerate() {
        let mut points = Vec::with_capacity(line.len() + 1);
        for (k, &i) in line.iter().enumerate() {
            let Some(s) = segments.get(i) else { continue };
            if k == 0 {
                points.push(point(s.start));
            }
            points.push(point(s.end));
        }
        if points.len() < 2 {
            continue;
        }
        markers.push(Marker {
            header: header.clone(),
            ns: "polymap".into(),
            id: i32::try_from(id).unwrap_or(i32::MAX),
            kind: Marker::LINE_STRIP,
            action: Marker::ADD,
            pose: pose_of(&Pose2::IDENTITY),
            scale: Vector3 {
                x: LINE_WIDTH_M,
                y: 0.0,
                z: 0.0,
            },
            color: ColorRgba {
                r: 0.1,
                g: 0.3,
                b: 0.9,
                a: 1.0,
            },
            points,
            ..Marker::default()
        });
    }
    MarkerArray { markers }
}

/// The occupancy grid as `nav_msgs/OccupancyGrid` in `map_frame`: 100 occupied, 0 free, -1
/// unknown; row 0 at the lowest y, as both lay it out.
pub fn grid_message(map_frame: &str, stamp: Time, grid: &Grid) -> OccupancyGrid {
    let (w, h) = (grid.width(), grid.height());
    let mut data = Vec::with_capacity(w * h);
    for row in 0..h {
        for col in 0..w {
            data.push(match grid.cell(col, row) {
                Some(Cell::Occupied) => 100,
                Some(Cell::Free) => 0,
                _ => -1,
            });
        }
    }
    let origin = grid.origin_m();
    OccupancyGrid {
        header: Header {
            stamp,
            frame_id: map_frame.to_owned(),
        },
        info: MapMetaData {
            map_load_time: stamp,
            resolution: grid.resolution_m() as f32,
            width: u32::try_from(w).unwrap_or(u32::MAX),
            height: u32::try_from(h).unwrap_or(u32::MAX),
            origin: pose_of(&Pose2::new(origin.x, origin.y, 0.0)),
        },
        data,
    }
}

/// What the status topic reports.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Status {
    /// The last scan's verdict (`ok`, `weak`, `lost`) and its reason.
    pub verdict: String,
    /// The reason, snake case.
    pub reason: String,
    /// Scans mapped.
    pub scans: u64,
    /// Verdict counts.
    pub ok: u64,
    /// Weak scans.
    pub weak: u64,
    /// Lost scans.
    pub lost: u64,
    /// Scans dropped by the full queue.
    pub dropped: u64,
    /// Bad scan messages skipped.
    pub bad_messages: u64,
    /// Loop closures accepted.
    pub loop_closures: u64,
    /// Map segments.
    pub map_segments: u64,
    /// The last scan's latency from arrival to its pose published, milliseconds.
    pub latency_ms: f64,
}

/// The status as one `DiagnosticStatus` named `polymap: tracking`: OK for an `ok` scan, WARN
/// for `weak` or when scans were dropped, ERROR for `lost`.
pub fn status_message(stamp: Time, s: &Status) -> DiagnosticArray {
    let level = match s.verdict.as_str() {
        "lost" => DiagnosticStatus::ERROR,
        "weak" => DiagnosticStatus::WARN,
        _ if s.dropped > 0 => DiagnosticStatus::WARN,
        _ => DiagnosticStatus::OK,
    };
    let message = match s.verdict.as_str() {
        "ok" => "tracking".to_owned(),
        v => format!("tracking {v}: {}", s.reason),
    };
    let kv = |key: &str, value: String| KeyValue {
        key: key.to_owned(),
        value,
    };
    DiagnosticArray {
        header: Header {
            stamp,
            frame_id: String::new(),
        },
        status: vec![DiagnosticStatus {
            level,
            name: "polymap: tracking".into(),
            message,
            hardware_id: String::new(),
            values: vec![
                kv("verdict", s.verdict.clone()),
                kv("reason", s.reason.clone()),
                kv("scans", s.scans.to_string()),
                kv("ok", s.ok.to_string()),
                kv("weak", s.weak.to_string()),
                kv("lost", s.lost.to_string()),
                kv("dropped_scans", s.dropped.to_string()),
                kv("bad_messages", s.bad_messages.to_string()),
                kv("loop_closures", s.loop_closures.to_string()),
                kv("map_segments", s.map_segments.to_string()),
                kv("latency_ms", format!("{:.2}", s.latency_ms)),
            ],
        }],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use polymap::geometry::Vec2;
    use polymap_export::pgm::GridParams;

    #[test]
    fn the_planes_covariance_goes_to_x_y_and_yaw_of_the_six() {
        let c = [[1.0, 0.5, 0.1], [0.5, 2.0, 0.2], [0.1, 0.2, 3.0]];
        let six = covariance_6(&c);
        assert_eq!((six.0[0], six.0[1], six.0[5]), (1.0, 0.5, 0.1));
        assert_eq!((six.0[6], six.0[7], six.0[11]), (0.5, 2.0, 0.2));
        assert_eq!((six.0[30], six.0[31], six.0[35]), (0.1, 0.2, 3.0));
        assert_eq!(six.0.iter().filter(|&&v| v != 0.0).count(), 9);
    }

    #[test]
    fn polylines_become_line_strips_after_a_delete_all() {
        let segs = [
            Segment::new(Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0)),
            Segment::new(Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0)),
            Segment::new(Vec2::new(5.0, 5.0), Vec2::new(6.0, 5.0)),
        ];
        let m = markers_message("map", Time::default(), &segs, &[vec![0, 1], vec![2]]);
        assert_eq!(m.markers[0].action, Marker::DELETEALL);
        assert_eq!(m.markers.len(), 3);
        assert_eq!(m.markers[1].kind, Marker::LINE_STRIP);
        assert_eq!(m.markers[1].points.len(), 3);
        assert_eq!(m.markers[2].points[1].x, 6.0);
        assert_eq!(m.markers[1].header.frame_id, "map");
    }

    #[test]
    fn the_grid_is_row_major_from_the_lowest_y_with_ros_cell_values() {
        let wall = [Segment::new(Vec2::new(2.0, -1.0), Vec2::new(2.0, 1.0))];
        let rays = [(Pose2::IDENTITY, vec![Vec2::new(2.0, 0.0)])];
        let grid = Grid::build(&wall, rays, &GridParams::default()).unwrap();
        let msg = grid_message("map", Time::default(), &grid);
        assert_eq!(msg.data.len(), (msg.info.width * msg.info.height) as usize);
        let at = |x: f64, y: f64| {
            let (c, r) = grid.cell_index(Vec2::new(x, y)).unwrap();
            msg.data[r * grid.width() + c]
        };
        assert_eq!((at(1.0, 0.0), at(2.0, 0.5), at(1.0, 0.8)), (0, 100, -1));
        assert_eq!(msg.info.origin.position.x, grid.origin_m().x);
    }

    #[test]
    fn the_status_level_follows_the_verdict() {
        let mut s = Status {
            verdict: "ok".into(),
            ..Status::default()
        };
        assert_eq!(status_message(Time::default(), &s).status[0].level, 0);
        s.dropped = 3;
        assert_eq!(status_message(Time::default(), &s).status[0].level, 1);
        s.verdict = "lost".into();
        let m = status_message(Time::default(), &s);
        assert_eq!(m.status[0].level, 2);
        assert!(
            m.status[0]
                .values
                .iter()
                .any(|kv| kv.key == "dropped_scans" && kv.value == "3")
        );
    }

    #[test]
    fn stamps_keep_their_nanoseconds() {
        assert_eq!(
            ros_time(12.000_000_5),
            Time {
                sec: 12,
                nanosec: 500
            }
        );
    }
}
