//! Reading well-formed logs, and writing logs that read back.

use std::f64::consts::{FRAC_PI_2, PI};

use polymap::geometry::Pose2;
use polymap::scan::{RangeScan, Stamp};

use super::*;

pub(super) fn reader(text: &str, options: ReaderOptions) -> CarmenReader<&[u8]> {
    CarmenReader::from_reader(text.as_bytes(), "test.clf", options)
}

pub(super) fn read_all(text: &str) -> (Vec<RangeScan>, CarmenStats) {
    let mut r = reader(text, ReaderOptions::default());
    let scans: Vec<RangeScan> = (&mut r).collect::<Result<_, _>>().unwrap();
    (scans, r.stats().clone())
}

/// A FLASER line with `n` readings of `range`, poses and stamp.
pub(super) fn flaser(n: usize, range: &str, stamp: &str) -> String {
    let ranges = vec![range; n].join(" ");
    format!("FLASER {n} {ranges} 1.5 2.5 0.1 1.0 2.0 0.1 {stamp} nohost 0.5\n")
}

fn bearing_deg(scan: &RangeScan, i: usize) -> f64 {
    (scan.angle_min_rad + i as f64 * scan.angle_increment_rad).to_degrees()
}

#[test]
fn flaser_bearings_follow_carmen() {
    // (n, step in degrees, bearing of the last beam in degrees)
    for (n, step, last) in [
        (180, 1.0, 89.0),
        (181, 1.0, 90.0),
        (360, 0.5, 89.5),
        (361, 0.5, 90.0),
    ] {
        let (scans, _) = read_all(&flaser(n, "1.0", "10.0"));
        let scan = &scans[0];
        assert_eq!(scan.ranges_m.len(), n);
        assert_eq!(scan.angle_min_rad, -FRAC_PI_2, "n = {n}");
        assert!(
            (scan.angle_increment_rad.to_degrees() - step).abs() < 1e-12,
            "n = {n}"
        );
        assert!((bearing_deg(scan, n - 1) - last).abs() < 1e-9, "n = {n}");
    }
    let (scans, _) = read_all(&flaser(5, "1.0", "10.0"));
    assert!((scans[0].angle_increment_rad - PI / 4.0).abs() < 1e-15);
    let (scans, _) = read_all(&flaser(0, "1.0", "10.0"));
    assert!(scans[0].ranges_m.is_empty());
}

#[test]
fn flaser_fields_land_in_the_scan() {
    let (scans, stats) = read_all(&flaser(180, "2.5", "976052857.337530"));
    let scan = &scans[0];
    assert_eq!(scan.stamp.text, "976052857.337530");
    assert_eq!(scan.stamp.seconds, 976052857.33753);
    assert_eq!(scan.odom_from_robot, Some(Pose2::new(1.0, 2.0, 0.1)));
    assert_eq!(scan.robot_from_laser, Pose2::IDENTITY);
    assert_eq!(scan.max_range_m, 50.0);
    assert_eq!(
        (stats.scans, stats.valid_readings, stats.no_return_readings),
        (1, 180, 0)
    );
}

#[test]
fn frontlaser_offset_applies_to_later_scans() {
    let text = format!(
        "{}PARAM robot_frontlaser_offset -0.04 1071078718.46 merci 1071078718.46\n{}",
        flaser(180, "1", "1"),
        flaser(180, "1", "2")
    );
    let (scans, stats) = read_all(&text);
    assert_eq!(scans[0].robot_from_laser, Pose2::IDENTITY);
    assert_eq!(scans[1].robot_from_laser, Pose2::new(-0.04, 0.0, 0.0));
    assert_eq!(stats.params, 1);
}

#[test]
fn front_laser_max_param_sets_the_flaser_max_range() {
    let text = format!(
        "PARAM robot_front_laser_max 80.99 1 merci 1\n{}",
        flaser(3, "81.91", "1")
    );
    let (scans, stats) = read_all(&text);
    assert_eq!(scans[0].max_range_m, 80.99);
    assert_eq!(stats.no_return_readings, 3);
}

#[test]
fn robotlaser1_uses_its_own_geometry() {
    // Robot at (1, 2) facing +y; laser 0.2 m ahead of it (so at (1, 2.2)), facing the same way.
    let text = "ROBOTLASER1 0 -1.5 3.0 0.75 30.0 0.01 0 5 1 2 3 30 nan 2 7 8 \
                1.0 2.2 1.5707963267948966 1.0 2.0 1.5707963267948966 0.1 0.2 0.3 0.4 0.5 \
                123.456 host 0.1\n";
    let (scans, stats) = read_all(text);
    let scan = &scans[0];
    assert_eq!(scan.ranges_m[..4], [1.0, 2.0, 3.0, 30.0]);
    assert!(scan.ranges_m[4].is_nan());
    assert_eq!(
        (
            scan.angle_min_rad,
            scan.angle_increment_rad,
            scan.max_range_m
        ),
        (-1.5, 0.75, 30.0)
    );
    let mount = scan.robot_from_laser;
    assert!(
        (mount.x_m - 0.2).abs() < 1e-12 && mount.y_m.abs() < 1e-12 && mount.theta_rad.abs() < 1e-12
    );
    assert_eq!(scan.odom_from_robot, Some(Pose2::new(1.0, 2.0, FRAC_PI_2)));
    assert_eq!(scan.stamp.text, "123.456");
    assert_eq!((stats.valid_readings, stats.no_return_readings), (3, 2));
}

#[test]
fn odometry_is_returned_as_a_record_and_counted() {
    let text = format!(
        "ODOM 0.5 -0.25 3.0 0.1 0.2 0.0 976052857.337284 nohost 0.0\n{}",
        flaser(180, "1", "5")
    );
    let mut r = reader(&text, ReaderOptions::default());
    match r.next_record().unwrap() {
        Some(CarmenRecord::Odometry(o)) => {
            assert_eq!(o.odom_from_robot, Pose2::new(0.5, -0.25, 3.0));
            assert_eq!(o.stamp.text, "976052857.337284");
            assert_eq!(
                (o.velocity_m_per_s, o.angular_velocity_rad_per_s),
                (0.1, 0.2)
            );
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        r.next_record().unwrap(),
        Some(CarmenRecord::Scan(_))
    ));
    assert!(r.next_record().unwrap().is_none());
    assert_eq!(r.stats().odometry_messages, 1);
}

#[test]
fn comments_blank_lines_and_unknown_types_are_skipped_and_counted() {
    let text = format!(
        "# CARMEN Logfile\n\n   \n\t# indented comment\nRLASER 1 2 3\nSYNC tag 1 h 2\nRLASER\n\
         NMEA-GGA 1 2\nTRUEPOS 0 0 0 0 0 0 1 h 1\n{}",
        flaser(180, "1", "5")
    );
    let (scans, stats) = read_all(&text);
    assert_eq!(scans.len(), 1);
    assert_eq!(stats.lines, 10);
    assert_eq!(stats.comment_lines, 4);
    let expected: Vec<(&str, u64)> =
        vec![("NMEA-GGA", 1), ("RLASER", 2), ("SYNC", 1), ("TRUEPOS", 1)];
    let got: Vec<(&str, u64)> = stats
        .skipped_types
        .iter()
        .map(|(k, v)| (k.as_str(), *v))
        .collect();
    assert_eq!(got, expected);
    assert_eq!(stats.skipped_lines(), 5);
}

#[test]
fn no_return_values_are_kept_and_counted() {
    let text = "FLASER 8 nan NaN inf -inf -1.0 0 81.83 1.25 0 0 0 0 0 0 1.0 h 1.0\n";
    let (scans, stats) = read_all(text);
    let r = &scans[0].ranges_m;
    assert!(r[0].is_nan() && r[1].is_nan());
    assert_eq!(
        r[2..],
        [f64::INFINITY, f64::NEG_INFINITY, -1.0, 0.0, 81.83, 1.25]
    );
    assert_eq!((stats.valid_readings, stats.no_return_readings), (1, 7));
}

#[test]
fn stamps_keep_file_order_and_text() {
    let text = format!(
        "{}{}{}",
        flaser(2, "1", "5.000100"),
        flaser(2, "1", "4.5"),
        flaser(2, "1", "1e3")
    );
    let (scans, _) = read_all(&text);
    let stamps: Vec<&str> = scans.iter().map(|s| s.stamp.text.as_str()).collect();
    assert_eq!(stamps, ["5.000100", "4.5", "1e3"]);
    assert_eq!(scans[2].stamp.seconds, 1000.0);
}

#[test]
fn crlf_and_missing_final_newline_are_fine() {
    let text = flaser(180, "1", "5").replace('\n', "\r\n") + flaser(180, "1", "6").trim_end();
    let (scans, stats) = read_all(&text);
    assert_eq!(scans.len(), 2);
    assert_eq!(stats.lines, 2);
}

#[test]
fn empty_input_has_no_scans() {
    let (scans, stats) = read_all("");
    assert!(scans.is_empty());
    assert_eq!(stats, CarmenStats::default());
}

fn sample_scan(i: usize, n: usize, odometry: bool) -> RangeScan {
    let g = flaser_beam_geometry(n);
    let mut ranges_m: Vec<f64> = (0..n)
        .map(|b| 0.5 + ((i * 31 + b * 7) % 997) as f64 * 0.013)
        .collect();
    ranges_m[0] = 80.0; // no-return at the max range
    RangeScan {
        stamp: {
            let text = format!("{}.{:06}", 976052857 + i, i * 77);
            Stamp {
                seconds: text.parse().unwrap(),
                text,
            }
        },
        ranges_m,
        angle_min_rad: g.angle_min_rad,
        angle_increment_rad: g.angle_increment_rad,
        max_range_m: 80.0,
        robot_from_laser: Pose2::new(if i < 2 { 0.0 } else { 0.12 }, 0.0, 0.0),
        odom_from_robot: odometry.then(|| Pose2::new(i as f64 * 0.1, -(i as f64), 0.3 * i as f64)),
    }
}

fn write_then_read(scans: &[RangeScan]) -> (Vec<RangeScan>, CarmenStats) {
    let mut w = CarmenWriter::new(Vec::new(), "out.clf").unwrap();
    for scan in scans {
        w.write_scan(scan).unwrap();
        if let Some(odom) = &scan.odom_from_robot {
            w.write_odometry(&scan.stamp, odom).unwrap();
        }
    }
    let bytes = w.finish().unwrap();
    read_all(std::str::from_utf8(&bytes).unwrap())
}

fn assert_same_scan(a: &RangeScan, b: &RangeScan) {
    assert_eq!(a.stamp, b.stamp);
    assert_eq!(a.ranges_m.len(), b.ranges_m.len());
    for (x, y) in a.ranges_m.iter().zip(&b.ranges_m) {
        let same = x == y || (x.is_nan() && y.is_nan()) || (x - y).abs() <= 5e-4;
        assert!(same, "{x} vs {y}");
        assert_eq!(a.is_valid_range(*x), b.is_valid_range(*y));
    }
    assert!((a.angle_min_rad - b.angle_min_rad).abs() < 1e-12);
    assert!((a.angle_increment_rad - b.angle_increment_rad).abs() < 1e-12);
    assert_eq!(a.max_range_m, b.max_range_m);
    let (ma, mb) = (a.robot_from_laser, b.robot_from_laser);
    assert!(
        (ma.translation() - mb.translation()).length() < 1e-6
            && (ma.theta_rad - mb.theta_rad).abs() < 1e-6
    );
    let oa = a.odom_from_robot.unwrap_or(Pose2::IDENTITY);
    let ob = b.odom_from_robot.unwrap();
    assert!((oa.translation() - ob.translation()).length() < 2e-6);
    assert!(polymap::geometry::normalize_angle_rad(oa.theta_rad - ob.theta_rad).abs() < 2e-6);
}

#[test]
fn flaser_round_trip() {
    let scans: Vec<RangeScan> = (0..5)
        .map(|i| sample_scan(i, [180, 181, 360, 361, 7][i], true))
        .collect();
    let (back, stats) = write_then_read(&scans);
    assert_eq!(back.len(), scans.len());
    assert_eq!(stats.odometry_messages, 5);
    assert!(stats.skipped_types.is_empty());
    for (a, b) in scans.iter().zip(&back) {
        assert_same_scan(a, b);
    }
}

#[test]
fn scans_flaser_cannot_hold_round_trip_as_robotlaser1() {
    let mut odd = sample_scan(3, 100, false);
    odd.angle_min_rad = -2.0;
    odd.angle_increment_rad = 0.04;
    odd.robot_from_laser = Pose2::new(0.1, -0.05, 0.2);
    odd.ranges_m[5] = f64::NAN;
    odd.ranges_m[6] = f64::INFINITY;
    let (back, _) = write_then_read(std::slice::from_ref(&odd));
    assert_same_scan(&odd, &back[0]);
    assert!(back[0].ranges_m[5].is_nan() && back[0].ranges_m[6] == f64::INFINITY);
}

#[test]
fn rounding_never_turns_a_return_into_a_no_return() {
    let mut scan = sample_scan(0, 180, true);
    scan.ranges_m[1] = 79.9996;
    let (back, _) = write_then_read(std::slice::from_ref(&scan));
    assert_eq!(back[0].ranges_m[1], 79.9996);
}

#[test]
fn unwritable_scans_are_errors() {
    let mut w = CarmenWriter::new(Vec::new(), "out.clf").unwrap();
    let mut scan = sample_scan(0, 180, true);
    scan.stamp.text = "12 34".into();
    assert!(matches!(
        w.write_scan(&scan),
        Err(CarmenError::Unwritable { .. })
    ));
    let mut scan = sample_scan(0, 180, true);
    scan.odom_from_robot = Some(Pose2 {
        x_m: f64::NAN,
        y_m: 0.0,
        theta_rad: 0.0,
    });
    assert!(w.write_scan(&scan).is_err());
    let mut scan = sample_scan(0, 180, true);
    scan.max_range_m = f64::INFINITY;
    assert!(w.write_scan(&scan).is_err());
    let odd_stamp = Stamp {
        seconds: 1.0,
        text: "one".into(),
    };
    assert!(w.write_odometry(&odd_stamp, &Pose2::IDENTITY).is_err());
}

#[test]
fn log_file_round_trip() {
    let dir = std::env::temp_dir().join(format!("polymap-io-carmen-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("sim.clf");
    let scans: Vec<RangeScan> = (0..3).map(|i| sample_scan(i, 361, true)).collect();
    write_flaser_log(&path, &scans).unwrap();
    let back: Vec<RangeScan> = CarmenReader::open(&path, ReaderOptions::default())
        .unwrap()
        .collect::<Result<_, _>>()
        .unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(back.len(), 3);
    assert_same_scan(&scans[2], &back[2]);
}
