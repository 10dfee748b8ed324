use super::search::{CELL_CLAMP, clamped_floor, must_clamp};
use super::*;
use crate::geometry::Segment;

#[test]
fn the_clamped_floor_is_the_floor_then_the_clamp() {
    let clamp = CELL_CLAMP as f64;
    let cases = [
        -2.5,
        -2.0,
        -0.5,
        -0.0,
        0.0,
        0.5,
        2.0,
        2.5,
        1e30,
        -1e30,
        clamp,
        clamp + 0.5,
        -clamp - 0.5,
        1e-300,
        -1e-300,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    // Whole numbers, halves (ties of the rounding) and values a hair either side of them.
    let near = (-4000..=4000).flat_map(|i| {
        [f64::from(i) * 0.25, f64::from(i) * 262_144.5]
            .map(|v| [v, v.next_up(), v.next_down(), v + 1e-9, v - 1e-9])
    });
    let near = near.flatten();
    for v in cases.into_iter().chain(near) {
        let want = crate::geometry::floor_i64(v).clamp(-CELL_CLAMP, CELL_CLAMP);
        assert_eq!(clamped_floor(v, clamp) as i64, want, "{v}");
    }
}

#[test]
fn the_cells_of_a_rotation_are_those_of_the_raster() {
    let raster = ScoreRaster::new(Vec2::new(-3.1, -2.7), Vec2::new(4.3, 5.9), 0.1, 0.2);
    let mut points: Vec<Vec2> = (0..97)
        .map(|i| {
            let a = i as f64 * 0.37;
            Vec2::new(7.9 * a.cos() * (i as f64 / 97.0), 7.9 * a.sin())
        })
        .collect();
    let near = points.clone();
    // Points far beyond any raster, or not finite, need the clamp; the others not.
    points.extend([Vec2::new(1e12, -1e12), Vec2::new(f64::NAN, 0.5)]);
    for (points, clamps) in [(near, false), (points, true)] {
        let xs: Vec<f64> = points.iter().map(|p| p.x).collect();
        let ys: Vec<f64> = points.iter().map(|p| p.y).collect();
        for pose in [Pose2::new(0.3, -0.2, 0.7), Pose2::new(-1.05, 2.35, -2.9)] {
            let clamped = must_clamp(&xs, &ys, &pose, raster.origin(), 0.1);
            assert_eq!(clamped, clamps);
            // Either way where the clamp changes nothing.
            for clamped in [clamped, true] {
                let mut cells = vec![(7, 7)];
                let turn = pose.theta_rad.sin_cos();
                let (t, origin) = (pose.translation(), raster.origin());
                cells_into(&xs, &ys, turn, t, origin, 0.1, clamped, &mut cells);
                assert_eq!(cells.len(), points.len() + 1, "appended");
                for (p, &(x, y)) in points.iter().zip(&cells[1..]) {
                    let (wx, wy) = raster.cell_of(pose.transform_point(*p));
                    let clamp = |v: i64| v.clamp(-CELL_CLAMP, CELL_CLAMP);
                    assert_eq!((x as i64, y as i64), (clamp(wx), clamp(wy)), "{p:?}");
                }
            }
        }
    }
    // A heading that is not finite, or a window far from the raster, needs the clamp.
    let (xs, ys) = ([1.0], [2.0]);
    let far = Pose2::new(1e9, 0.0, 0.0);
    assert!(must_clamp(&xs, &ys, &far, raster.origin(), 0.1));
    let turned = Pose2::new(0.0, 0.0, f64::NAN);
    assert!(must_clamp(&xs, &ys, &turned, raster.origin(), 0.1));
    assert!(!must_clamp(
        &xs,
        &ys,
        &Pose2::IDENTITY,
        raster.origin(),
        0.1
    ));
}

/// A room with a pillar and a doorway: asymmetric enough for one best pose.
fn room() -> (Vec<Segment>, Vec<Vec2>) {
    let p = |x, y| Vec2::new(x, y);
    let segs = vec![
        Segment::new(p(-3.0, -2.0), p(5.0, -2.0)),
        Segment::new(p(5.0, -2.0), p(5.0, 3.0)),
        Segment::new(p(5.0, 3.0), p(1.0, 3.0)),
        Segment::new(p(0.0, 3.0), p(-3.0, 3.0)),
        Segment::new(p(-3.0, 3.0), p(-3.0, -2.0)),
    ];
    let pillar = (0..12)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / 12.0;
            p(2.0 + 0.15 * a.cos(), 1.0 + 0.15 * a.sin())
        })
        .collect();
    (segs, pillar)
}

fn scan_of(segs: &[Segment], pillar: &[Vec2], map_from_robot: Pose2) -> Vec<Vec2> {
    let robot_from_map = map_from_robot.inverse();
    let mut pts: Vec<Vec2> = segs
        .iter()
        .flat_map(|s| (0..=20).map(move |i| s.start + s.vector() * (i as f64 / 20.0)))
        .collect();
    pts.extend_from_slice(pillar);
    pts.iter()
        .map(|p| robot_from_map.transform_point(*p))
        .collect()
}

/// Within 0.15 m and 0.03 rad of the truth: a cell and a rotation step or so.
fn assert_near(truth: &Pose2, found: &Candidate) {
    let d = truth.between(&found.map_from_robot);
    assert!(
        d.translation().length() < 0.15 && d.theta_rad.abs() < 0.03,
        "{found:?}"
    );
}

#[test]
fn branch_and_bound_finds_the_brute_force_best() {
    let (segs, pillar) = room();
    let matcher = CorrelativeMatcher::new(ScoreRaster::of(&segs, &pillar, 0.1, 0.2));
    let truth = Pose2::new(0.4, -0.3, 0.35);
    let points = scan_of(&segs, &pillar, truth);
    for (center, half_xy, half_deg) in [
        (Pose2::IDENTITY, 0.6, 30.0),
        (Pose2::new(0.1, 0.2, 0.1), 1.0, 45.0),
        (Pose2::new(-0.5, 0.5, -1.0), 0.3, 10.0), // truth outside: best of the window
    ] {
        let window = SearchWindow {
            center,
            half_xy_m: half_xy,
            half_theta_rad: f64::to_radians(half_deg),
        };
        let fast = matcher.best(&points, &window, 0.0, &[]).unwrap();
        let slow = matcher.best_brute_force(&points, &window, &[]).unwrap();
        assert_eq!(fast.score, slow.score, "window {window:?}");
    }
    let window = SearchWindow {
        center: Pose2::IDENTITY,
        half_xy_m: 1.0,
        half_theta_rad: 0.6,
    };
    let found = matcher.best(&points, &window, 0.0, &[]).unwrap();
    assert_near(&truth, &found);
}

#[test]
fn the_whole_circle_recovers_a_turned_scan() {
    let (segs, pillar) = room();
    let matcher = CorrelativeMatcher::new(ScoreRaster::of(&segs, &pillar, 0.1, 0.2));
    let truth = Pose2::new(1.0, 0.5, 2.6);
    let points = scan_of(&segs, &pillar, truth);
    let window = SearchWindow {
        center: Pose2::new(0.5, 0.0, -0.4),
        half_xy_m: 1.0,
        half_theta_rad: std::f64::consts::PI,
    };
    let found = matcher.best(&points, &window, 0.5, &[]).unwrap();
    assert_near(&truth, &found);
}

/// The rival of `found` and the brute force's best pose `apart` from its best, scoring at
/// least its `rival_above` share of the best's score (the floor is rounded to f32: allow
/// that rounding).
fn rival_and_brute_force(
    matcher: &CorrelativeMatcher,
    points: &[Vec2],
    found: &WindowBest,
    apart: (f64, f64),
) -> (Option<Candidate>, Option<Candidate>) {
    let exclusion = [Exclusion {
        center: found.best.map_from_robot,
        radius_m: apart.0,
        radius_rad: apart.1,
    }];
    let brute = matcher
        .best_brute_force(points, &found.window, &exclusion)
        .filter(|c| c.score >= found.rival_above * found.best.score - 1e-6);
    (matcher.rival(found, apart), brute)
}

#[test]
fn the_rival_is_the_best_pose_apart_from_the_best() {
    let (segs, pillar) = room();
    let matcher = CorrelativeMatcher::new(ScoreRaster::of(&segs, &pillar, 0.1, 0.2));
    let points = scan_of(&segs, &pillar, Pose2::new(0.2, 0.1, 0.05));
    let window = SearchWindow {
        center: Pose2::IDENTITY,
        half_xy_m: 0.6,
        half_theta_rad: 0.4,
    };
    let apart = (0.3, 0.1);
    let mut both_kinds = [false, false];
    for rival_above in [0.1, 0.3, 0.5, 0.7, 0.8, 0.9, 0.95, 0.99] {
        let found = matcher
            .window_best(&points, &window, 0.0, None, rival_above)
            .unwrap();
        let best = matcher.best_brute_force(&points, &window, &[]).unwrap();
        assert_eq!(found.best.score, best.score);
        // The search goes on from the queue the best's search left: the same score as
        // scoring every pose apart from the best.
        let (rival, brute) = rival_and_brute_force(&matcher, &points, &found, apart);
        assert_eq!(
            rival.map(|c| c.score),
            brute.map(|c| c.score),
            "{rival_above}"
        );
        both_kinds[rival.is_some() as usize] = true;
        if let Some(r) = rival {
            let d = best.map_from_robot.between(&r.map_from_robot);
            assert!(d.translation().length() > apart.0 || d.theta_rad.abs() > apart.1);
        }
    }
    assert_eq!(
        both_kinds,
        [true, true],
        "some floors find a rival, some do not"
    );
    // A seed scoring above every pose of the window is the best, and has no rival here.
    let seed = Candidate {
        map_from_robot: Pose2::new(0.2, 0.1, 0.05),
        score: 2.0,
    };
    let found = matcher
        .window_best(&points, &window, 2.0, Some(seed), 0.95)
        .unwrap();
    assert_eq!((found.best, matcher.rival(&found, apart)), (seed, None));
    // A seed scoring under the search's floor (nothing reached it): its rival is searched
    // afresh, down to its own floor.
    let low = Candidate {
        map_from_robot: Pose2::new(0.2, 0.1, 0.05),
        score: 0.3,
    };
    let found = matcher
        .window_best(&points, &window, 2.0, Some(low), 0.95)
        .unwrap();
    let rival = matcher.rival(&found, apart).expect("a pose above 0.3");
    assert!(rival.score >= 0.95 * 0.3 - 1e-6, "{rival:?}");
}

/// A queue of at most a few blocks: every search goes on depth first from it, and finds
/// the same scores as the brute force (the best, the rival apart from it, the peaks).
#[test]
fn a_full_queue_goes_on_depth_first_with_the_same_scores() {
    let (segs, pillar) = room();
    let raster = ScoreRaster::of(&segs, &pillar, 0.1, 0.2);
    let queued = CorrelativeMatcher::new(raster.clone());
    let small = CorrelativeMatcher::new(raster).with_max_queued(4);
    let points = scan_of(&segs, &pillar, Pose2::new(0.2, 0.1, 0.05));
    let window = SearchWindow {
        center: Pose2::IDENTITY,
        half_xy_m: 0.6,
        half_theta_rad: 0.4,
    };
    let best = small.best(&points, &window, 0.0, &[]).unwrap();
    let brute = small.best_brute_force(&points, &window, &[]).unwrap();
    assert_eq!(best.score, brute.score);
    let apart = (0.3, 0.1);
    for rival_above in [0.5, 0.8, 0.9] {
        let found = small
            .window_best(&points, &window, 0.0, None, rival_above)
            .unwrap();
        assert!(found.frontier.spent, "the queue overflowed");
        let (rival, brute) = rival_and_brute_force(&small, &points, &found, apart);
        assert_eq!(rival.map(|c| c.score), brute.map(|c| c.score));
    }
    let score = |peaks: Vec<Candidate>| peaks.iter().map(|c| c.score).collect::<Vec<_>>();
    assert_eq!(
        score(small.peaks(&points, &window, 0.0, 3, 0.3, 0.1)),
        score(queued.peaks(&points, &window, 0.0, 3, 0.3, 0.1))
    );
}

/// A window centred far off a long, thin raster: cells whose flat index would overflow
/// an `i32` at zero offset, brought onto the raster by the window's offsets, are summed
/// with checks (once an index out of bounds).
#[test]
fn a_window_far_off_a_wide_raster_is_searched_with_checks() {
    let segs = [Segment::new(Vec2::new(0.0, 0.0), Vec2::new(6000.0, 0.0))];
    let raster = ScoreRaster::of(&segs, &[], 0.1, 0.2);
    let matcher = CorrelativeMatcher::new(raster);
    let points = [
        Vec2::new(0.0, 0.0),
        Vec2::new(1.0, 0.0),
        Vec2::new(2.0, 0.0),
    ];
    let window = SearchWindow {
        center: Pose2::new(3000.0, -4000.0, 0.0),
        half_xy_m: 4100.0,
        half_theta_rad: 0.0,
    };
    let found = matcher.best(&points, &window, 0.5, &[]).expect("the wall");
    assert!(found.score > 0.9, "{found:?}");
    assert!(found.map_from_robot.y_m.abs() < 0.2, "{found:?}");
}

#[test]
fn peaks_are_apart_and_a_high_floor_finds_nothing() {
    let (segs, pillar) = room();
    let matcher = CorrelativeMatcher::new(ScoreRaster::of(&segs, &pillar, 0.1, 0.2));
    let points = scan_of(&segs, &pillar, Pose2::IDENTITY);
    let window = SearchWindow {
        center: Pose2::IDENTITY,
        half_xy_m: 0.8,
        half_theta_rad: 0.3,
    };
    let peaks = matcher.peaks(&points, &window, 0.0, 3, 0.3, 0.1);
    assert_eq!(peaks.len(), 3);
    for (i, a) in peaks.iter().enumerate() {
        for b in &peaks[i + 1..] {
            let d = a.map_from_robot.between(&b.map_from_robot);
            assert!(d.translation().length() > 0.3 || d.theta_rad.abs() > 0.1);
            assert!(a.score >= b.score);
        }
    }
    assert!(matcher.best(&points, &window, 1.01, &[]).is_none());
    assert!(matcher.best(&[], &window, 0.0, &[]).is_none());
}

/// The room's matcher and the rotations of a scan of it within a window around its pose: the
/// blocks the tests of the one-pass sums compare.
fn room_search() -> (CorrelativeMatcher, Rotations) {
    let (segs, pillar) = room();
    let matcher = CorrelativeMatcher::new(ScoreRaster::of(&segs, &pillar, 0.1, 0.2));
    let points = scan_of(&segs, &pillar, Pose2::new(0.3, -0.2, 0.2));
    let window = SearchWindow {
        center: Pose2::new(0.1, 0.1, 0.1),
        half_xy_m: 1.0,
        half_theta_rad: 0.3,
    };
    let rotations = matcher.rotations(&points, &window);
    (matcher, rotations)
}

/// Four neighbouring blocks summed in one pass carry the bit-identical bounds of four
/// separate sums, at every level and rotation; blocks reaching past the raster are left to
/// the sums with checks.
#[test]
fn four_blocks_in_one_pass_are_the_four_sums() {
    let (matcher, rotations) = room_search();
    let (mut summed, mut outside) = (0, 0);
    let len = (matcher.padded_width * matcher.padded_height) as usize;
    for level in 0..=MAX_LEVEL {
        // Both ways: from the level, and from its values beside their siblings'.
        let built = sums::siblings(&matcher.levels[level as usize], len, level);
        let paired = Some(built.as_chunks::<2>().0);
        for r in 0..rotations.len() {
            for (ix, iy) in [(-10, -10), (-3, 4), (0, 0), (200, 0), (-300, -300)] {
                let both = [None, paired].map(|p| matcher.quad(&rotations, r, (ix, iy), level, p));
                let Some(quad) = both[0] else {
                    assert!(both[1].is_none());
                    outside += 1;
                    continue;
                };
                let again = both[1].unwrap();
                for (a, b) in quad.iter().zip(&again) {
                    assert_eq!(
                        (a.ix, a.iy, a.bound.to_bits()),
                        (b.ix, b.iy, b.bound.to_bits())
                    );
                }
                let size = 1i64 << level;
                for (b, (dx, dy)) in quad
                    .iter()
                    .zip([(0, 0), (size, 0), (0, size), (size, size)])
                {
                    let one = matcher.block(&rotations, r, ix + dx, iy + dy, level);
                    assert_eq!(
                        (b.ix, b.iy, b.level, b.rotation),
                        (one.ix, one.iy, level, r)
                    );
                    assert_eq!(b.bound.to_bits(), one.bound.to_bits());
                }
                summed += 1;
            }
        }
    }
    assert!(summed > 0 && outside > 0, "{summed} {outside}");
}

/// Two neighbouring blocks (across or up) summed in one pass carry the bit-identical bounds
/// of two separate sums, at every level and rotation, from the level and from its values
/// beside their siblings'; blocks reaching past the raster are left to the sums with checks.
#[test]
fn two_blocks_in_one_pass_are_the_two_sums() {
    let (matcher, rotations) = room_search();
    let (mut summed, mut outside) = (0, 0);
    let len = (matcher.padded_width * matcher.padded_height) as usize;
    for level in 0..=MAX_LEVEL {
        let built = sums::siblings(&matcher.levels[level as usize], len, level);
        let paired = Some(built.as_chunks::<2>().0);
        let size = 1i64 << level;
        for r in 0..rotations.len() {
            for (ix, iy) in [(-10, -10), (-3, 4), (0, 0), (7, -9), (200, 0), (-300, -300)] {
                for across in [true, false] {
                    let both = [None, paired]
                        .map(|p| matcher.pair(&rotations, r, (ix, iy), level, across, p));
                    let Some(two) = both[0] else {
                        assert!(both[1].is_none());
                        outside += 1;
                        continue;
                    };
                    let (dx, dy) = if across { (size, 0) } else { (0, size) };
                    for (b, (bx, by)) in two.iter().chain(&both[1].unwrap()).zip([
                        (ix, iy),
                        (ix + dx, iy + dy),
                        (ix, iy),
                        (ix + dx, iy + dy),
                    ]) {
                        let one = matcher.block(&rotations, r, bx, by, level);
                        assert_eq!(
                            (b.ix, b.iy, b.level, b.rotation),
                            (bx, by, level, r),
                            "{level} {across}"
                        );
                        assert_eq!(b.bound.to_bits(), one.bound.to_bits());
                    }
                    summed += 1;
                }
            }
        }
    }
    assert!(summed > 0 && outside > 0, "{summed} {outside}");
}

/// Every level is as long as a power of two, at least its padded cells: a cell's index
/// masked by the length less one is the index itself. A matcher built on reused buffers
/// holding other values has the same cells.
#[test]
fn levels_are_a_power_of_two_long_and_reused_buffers_give_the_same_cells() {
    let (segs, pillar) = room();
    for (cell, half_xy) in [(0.1, 0.3), (0.1, 2.0), (0.07, 1.0), (0.5, 0.0)] {
        let matcher =
            CorrelativeMatcher::for_window(ScoreRaster::of(&segs, &pillar, cell, 0.2), half_xy);
        let cells = (matcher.padded_width * matcher.padded_height) as usize;
        for values in &matcher.levels {
            assert!(values.len().is_power_of_two() && values.len() >= cells);
            assert!((0..cells).all(|i| i & masked(values) == i));
        }
        let kept: Vec<Vec<f32>> = matcher.levels.iter().map(|l| l[..cells].to_vec()).collect();
        drop(matcher);
        // Every kept buffer taken, filled with another value and given back.
        use super::super::buffers::{Buffer, MAX_KEPT, reused};
        let mut taken: Vec<Buffer> = (0..MAX_KEPT).map(|_| reused(1 << 16)).collect();
        taken.iter_mut().for_each(|b| b.fill(9.0));
        drop(taken);
        let again =
            CorrelativeMatcher::for_window(ScoreRaster::of(&segs, &pillar, cell, 0.2), half_xy);
        for (kept, level) in kept.iter().zip(&again.levels) {
            assert_eq!(&level[..cells], &kept[..]);
        }
    }
}

/// Every cell of every level is the raster's maximum over its block (0 beyond the raster),
/// the padding included.
#[test]
fn every_level_holds_the_maximum_over_its_blocks() {
    let (segs, pillar) = room();
    for (cell, half_xy) in [(0.1, 1.0), (0.07, 0.5), (0.3, 4.0)] {
        let raster = ScoreRaster::of(&segs, &pillar, cell, 0.2);
        let matcher = CorrelativeMatcher::for_window(raster.clone(), half_xy);
        let (pw, ph, pad) = (matcher.padded_width, matcher.padded_height, matcher.pad);
        for (h, values) in matcher.levels.iter().enumerate() {
            let size = 1i64 << h;
            for py in 0..ph {
                for px in 0..pw {
                    let (x, y) = (px - pad, py - pad);
                    let want = (0..size)
                        .flat_map(|dy| (0..size).map(move |dx| (x + dx, y + dy)))
                        .map(|(cx, cy)| raster.cell(cx, cy))
                        .fold(0f32, f32::max);
                    let got = values[(py * pw + px) as usize];
                    assert_eq!(got.to_bits(), want.to_bits(), "level {h} at {x}, {y}");
                }
            }
        }
    }
}
