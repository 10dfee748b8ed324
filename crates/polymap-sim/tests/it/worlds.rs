//! The built-in worlds and their tours: free space, visibility, the features each promises.

use std::f64::consts::{FRAC_PI_4, PI, TAU};

use polymap::geometry::{Segment, angle_between_directions_rad};
use polymap_sim::raycast::RayCaster;
use polymap_sim::{SimRun, World, simulate};

/// The worlds built to be bare in places: their scans may see only two parallel walls.
const BARE: [&str; 1] = ["corridor"];

fn run(w: &World) -> SimRun {
    simulate(w, &w.sim_params(), 11)
}

/// Distinct undirected wall directions, degrees, rounded to 0.1°.
fn directions_deg(walls: &[Segment]) -> Vec<f64> {
    let mut d: Vec<f64> = walls
        .iter()
        .map(|w| (w.direction_rad().to_degrees() * 10.0).round() / 10.0 % 180.0)
        .collect();
    d.sort_by(f64::total_cmp);
    d.dedup();
    d
}

#[test]
fn path_stays_in_free_space() {
    for w in World::catalogue() {
        let r = run(&w);
        let clearance = r
            .true_poses
            .iter()
            .map(|p| w.clearance_m(p.translation()))
            .fold(f64::MAX, f64::min);
        assert!(
            clearance > 0.2,
            "{}: a pose {clearance:.2} m from a wall",
            w.name
        );
        assert!(
            clearance > 0.6,
            "{}: clearance {clearance:.2} m is tighter than designed",
            w.name
        );
    }
}

#[test]
fn every_pose_is_enclosed() {
    for w in World::catalogue() {
        let caster = RayCaster::new(&w);
        for p in run(&w).true_poses.iter().step_by(25) {
            for k in 0..72 {
                let hit = caster.cast(p.translation(), k as f64 * TAU / 72.0, 1000.0);
                assert!(hit.is_some(), "{}: ray {k} from {:?} escapes", w.name, p);
            }
        }
    }
}

#[test]
fn scans_have_a_good_share_of_valid_returns() {
    for w in World::catalogue() {
        let r = run(&w);
        let beams: usize = r.scans.iter().map(|s| s.ranges_m.len()).sum();
        let valid: usize = r.scans.iter().map(|s| s.valid_count()).sum();
        let worst = r.scans.iter().map(|s| s.valid_count()).min().unwrap_or(0);
        // The corridor's 10 m laser looks down a 42 m corridor: the beams along it miss.
        let share = if BARE.contains(&w.name.as_str()) {
            0.9
        } else {
            0.95
        };
        assert!(
            valid as f64 > share * beams as f64,
            "{}: {valid}/{beams}",
            w.name
        );
        assert!(worst > 150, "{}: a scan with only {worst} returns", w.name);
    }
}

#[test]
fn tours_are_long_and_return_near_the_start() {
    for w in World::catalogue() {
        let r = run(&w);
        let (first, last) = (r.true_poses[0], r.true_poses[r.true_poses.len() - 1]);
        assert!(
            r.path_length_m() > 55.0 && r.path_length_m() < 130.0,
            "{}: {}",
            w.name,
            r.path_length_m()
        );
        assert!(
            (last.translation() - first.translation()).length() < 3.5,
            "{}",
            w.name
        );
        assert!(r.scans.len() > 1000, "{}: {}", w.name, r.scans.len());
    }
}

#[test]
fn hallway45_passes_the_45_degree_stretch_and_closes_the_loop() {
    let w = World::hallway45();
    let r = run(&w);
    let diagonal: Vec<usize> = (0..w.walls.len())
        .filter(|&i| {
            angle_between_directions_rad(w.walls[i].direction_rad(), FRAC_PI_4) < 1e-9
                && w.walls[i].length() > 5.0
        })
        .collect();
    assert_eq!(diagonal.len(), 2, "inner and outer 45° walls");
    assert!(diagonal.iter().all(|i| r.walls_seen.contains(i)));
    let on_diagonal = r.true_poses.iter().filter(|p| {
        (p.theta_rad - FRAC_PI_4).abs() < 1e-6
            && diagonal
                .iter()
                .all(|&i| w.walls[i].distance_to_point(p.translation()) < 1.1)
    });
    assert!(
        on_diagonal.count() > 50,
        "the robot drives along the 45° stretch"
    );
    // Once round: the heading turns through a full circle, and the tour ends behind the start.
    let turned: f64 = r
        .true_poses
        .windows(2)
        .map(|p| p[0].between(&p[1]).theta_rad)
        .sum();
    assert!((turned - TAU).abs() < 1e-6, "{turned}");
    let last = r.true_poses[r.true_poses.len() - 1];
    assert!(last.x_m > r.true_poses[0].x_m && last.y_m.abs() < 0.01);
}

#[test]
fn hallway45_has_only_0_45_90_degree_walls_and_is_the_default() {
    assert_eq!(
        directions_deg(&World::hallway45().walls),
        vec![0.0, 45.0, 90.0]
    );
    assert_eq!(World::default().name, "hallway45");
}

#[test]
fn hex60_walls_lie_on_the_60_degree_lattice() {
    assert_eq!(
        directions_deg(&World::hex60().walls),
        vec![0.0, 60.0, 120.0]
    );
}

#[test]
fn clutter_has_no_dominant_direction() {
    let w = World::clutter();
    let dirs = directions_deg(&w.walls);
    assert!(dirs.len() >= 15, "{dirs:?}");
    // No direction carries more than a fifth of the wall length.
    let total = w.total_wall_length_m();
    for d in dirs {
        let along: f64 = w
            .walls
            .iter()
            .filter(|s| (s.direction_rad().to_degrees() - d).abs() < 0.1)
            .map(Segment::length)
            .sum();
        assert!(
            along < 0.2 * total,
            "{d}° carries {along:.1} of {total:.1} m"
        );
    }
    assert!(w.pillars.len() >= 5);
}

#[test]
fn office_has_collinear_walls_across_doorways() {
    let w = World::office();
    let same_line = |a: &Segment, b: &Segment| {
        let u = a.vector().normalize();
        u.perp_dot(b.start - a.start).abs() < 1e-9 && u.perp_dot(b.end - a.start).abs() < 1e-9
    };
    let mut doorways = 0;
    for (i, a) in w.walls.iter().enumerate() {
        for b in &w.walls[i + 1..] {
            if same_line(a, b) && (a.distance_to_segment(b) - 0.9).abs() < 1e-9 {
                doorways += 1;
            }
        }
    }
    assert!(doorways >= 18, "{doorways} doorways");
}

#[test]
fn walls_seen_are_sensible() {
    for w in World::catalogue() {
        let r = run(&w);
        let truth_len: f64 = r.walls.iter().map(Segment::length).sum();
        assert_eq!(r.walls.len(), w.truth_walls().len());
        assert!(
            r.walls_seen.len() * 2 >= r.walls.len(),
            "{}: most walls are seen",
            w.name
        );
        assert!(r.seen_wall_length_m <= truth_len + 1e-9);
        assert!(r.observed_wall_length_m <= r.seen_wall_length_m + 1.0);
        assert!(r.observed_wall_length_m > 0.5 * truth_len, "{}", w.name);
        for &i in &r.walls_seen {
            assert!(r.wall_hits[i] >= r.params.min_hits_seen);
            let nearest = r
                .true_poses
                .iter()
                .map(|p| r.walls[i].distance_to_point(p.translation()))
                .fold(f64::MAX, f64::min);
            assert!(
                nearest < r.params.laser.max_range_m,
                "{}: wall {i} seen from afar",
                w.name
            );
        }
        let unseen = (0..r.walls.len()).filter(|i| !r.walls_seen.contains(i));
        assert!(
            unseen
                .clone()
                .all(|i| r.wall_hits[i] < r.params.min_hits_seen)
        );
    }
}

#[test]
fn every_world_has_structure_in_every_scan() {
    // A scan sees corners or short walls, not just two parallel lines: in each scan, the
    // returned beams hit at least three distinct walls. Not so in the bare worlds.
    for w in World::catalogue() {
        if BARE.contains(&w.name.as_str()) {
            continue;
        }
        let r = run(&w);
        let caster = RayCaster::new(&w);
        for p in r.true_poses.iter().step_by(10) {
            let mut hit: Vec<_> = (0..180)
                .filter_map(|k| {
                    caster.cast(
                        p.translation(),
                        p.theta_rad - PI / 2.0 + k as f64 * PI / 180.0,
                        30.0,
                    )
                })
                .map(|h| h.obstacle)
                .collect();
            hit.sort_by_key(|o| format!("{o:?}"));
            hit.dedup();
            assert!(hit.len() >= 3, "{} at {:?}: {} walls", w.name, p, hit.len());
        }
    }
}

#[test]
fn the_corridor_middle_shows_only_two_walls_within_laser_range() {
    let w = World::corridor();
    let r = run(&w);
    let caster = RayCaster::new(&w);
    let range = r.params.laser.max_range_m;
    let walls_seen_at = |p: &polymap::geometry::Pose2| {
        let mut hit: Vec<_> = (0..180)
            .filter_map(|k| {
                caster.cast(
                    p.translation(),
                    p.theta_rad - PI / 2.0 + k as f64 * PI / 180.0,
                    range,
                )
            })
            .map(|h| format!("{:?}", h.obstacle))
            .collect();
        hit.sort();
        hit.dedup();
        hit.len()
    };
    let bare = r
        .true_poses
        .iter()
        .filter(|p| walls_seen_at(p) == 2)
        .count();
    // Over 20 m each way at 0.05 m per scan: several hundred bare scans.
    assert!(
        bare > 500,
        "{bare} of {} scans see two walls",
        r.scans.len()
    );
}

#[test]
fn catalogue_lookup_by_name() {
    for name in World::names() {
        assert_eq!(
            polymap_sim::world_by_name(name).map(|w| w.name),
            Some(name.to_string())
        );
    }
    assert!(polymap_sim::world_by_name("").is_none());
}
