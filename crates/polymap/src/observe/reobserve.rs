//! The finished map against every second scan that observed: a third check of the map as a
//! whole.
//!
//! [`observe_scan`](super::observe_scan) counts what a scan says about the map as it is when
//! the scan comes, so a wall is tested only by the scans after it. Walls a run places wrongly
//! near its end (a stretch tracked turned, merged across the rooms it passed before) stand in
//! the free space of every scan before them, and no later scan is there to see through them:
//! the running count stays low while the map is wrong. So the rays of every second observing
//! scan are kept ([`Sightings`], robot frame) and, when the run is done, cast again at the poses
//! the run ended with (loop corrections applied) against the finished map, under the same tests
//! ([`walls_seen_through`]).
//!
//! Only walls of at least [`WALL_MIN_M`] count: what stands in a corridor for a moment (a
//! person, a door, a cart) is short, and the rays of every scan before and after it pass
//! through it; such clutter makes up most of what is seen through on an accurate run (the
//! dense ACES runs: 0.13–0.19 of all sightings, at most 0.043 of the walls').

use rustc_hash::FxHashMap;
use serde::{Deserialize, Serialize};

use super::crossed::ranges;
use super::{Crossings, ObserveParams, cast, covered, thin_by_bearing};
use crate::geometry::{Pose2, Vec2};
use crate::map::{GlobalMap, SegmentId};

/// Map segments shorter than this are left out of [`walls_seen_through`], metres.
pub const WALL_MIN_M: f64 = 1.0;

/// A wall seen through by at least this many sightings, and by at least half as many as saw
/// it, is named by [`walls_seen_through`] (its scans): on a run whose poses held, a wall of the
/// map is seen through by a few sightings in a hundred.
pub const NAMED_MIN_THROUGH: u32 = 5;

/// Of the observing scans, every this many is kept by [`Sightings`] (the first, then every
/// one after so many): a ray cast again costs what it cost when the scan observed, and half of
/// them tell the same share (the check's cost on a sparse run: 2.5 % of its instructions with
/// every one kept).
const KEEP_EVERY: u32 = 2;

/// The most rays [`Sightings`] keeps (8 bytes each, 16 MiB): a sighting that would go beyond
/// first drops every other sighting kept, and from then on every other scan that observes is
/// kept of those it kept (twice as sparse each time).
const MAX_RAYS: usize = 1 << 21;

/// The thinned rays of the scans that observed (robot frame, `f32` metres), by scan: every
/// second observing scan, fewer past a budget of rays.
#[derive(Debug, Clone, Default)]
pub struct Sightings {
    /// The map's scan number of each sighting.
    scans: Vec<u32>,
    /// Where each sighting's rays end in `rays` (exclusive).
    ends: Vec<usize>,
    rays: Vec<[f32; 2]>,
    /// One observing scan in this many is kept ([`KEEP_EVERY`] times a power of two).
    keep_every: u32,
    /// Observing scans offered so far.
    offered: u32,
    /// Keeps nothing: for a mapper whose map is not checked.
    off: bool,
}

impl Sightings {
    /// Keeps the rays of scan `t` (the map's numbering) that observed: its points
    /// (`points_in_robot`, metres, robot frame) thinned as [`observe_scan`](super::observe_scan)
    /// thins them.
    pub fn record(&mut self, t: u32, points_in_robot: &[Vec2], params: &ObserveParams) {
        if self.off {
            return;
        }
        let n = self.offered;
        self.offered = n.wrapping_add(1);
        self.keep_every = self.keep_every.max(KEEP_EVERY);
        if !n.is_multiple_of(self.keep_every) {
            return;
        }
        let rays = thin_by_bearing(points_in_robot, params.ray_spacing_deg.to_radians());
        if self.rays.len() + rays.len() > MAX_RAYS {
            self.halve();
            // This scan stays on the sparser grid only where it lies on it.
            if !n.is_multiple_of(self.keep_every) || rays.len() > MAX_RAYS - self.rays.len() {
                return;
            }
        }
        // Grown by doubling up to the budget, never past it.
        let needed = self.rays.len() + rays.len();
        if needed > self.rays.capacity() {
            let grown = (2 * self.rays.capacity()).clamp(needed, MAX_RAYS);
            self.rays.reserve_exact(grown - self.rays.len());
        }
        self.rays
            .extend(rays.iter().map(|p| [p.x as f32, p.y as f32]));
        self.scans.push(t);
        self.ends.push(self.rays.len());
    }

    /// Sightings that keep nothing (for a mapper whose map is not checked: a localize run, the
    /// mappers that track a run's scans on a map of their own).
    pub fn off() -> Self {
        Sightings {
            off: true,
            ..Sightings::default()
        }
    }

    /// The sightings kept.
    pub fn len(&self) -> usize {
        self.scans.len()
    }

    /// Whether no sighting is kept.
    pub fn is_empty(&self) -> bool {
        self.scans.is_empty()
    }

    /// Each sighting: its scan and its rays.
    fn iter(&self) -> impl Iterator<Item = (u32, &[[f32; 2]])> {
        let starts = std::iter::once(0).chain(self.ends.iter().copied());
        self.scans
            .iter()
            .zip(starts.zip(self.ends.iter()))
            .map(|(t, (a, b))| (*t, &self.rays[a..*b]))
    }

    /// Keeps every other sighting (the first, the third, …), in place, and every other scan
    /// of those kept from now on.
    fn halve(&mut self) {
        let (mut start, mut written, mut kept) = (0, 0, 0);
        for i in 0..self.scans.len() {
            let end = self.ends[i];
            if i % 2 == 0 {
                self.rays.copy_within(start..end, written);
                written += end - start;
                self.scans[kept] = self.scans[i];
                self.ends[kept] = written;
                kept += 1;
            }
            start = end;
        }
        self.rays.truncate(written);
        self.scans.truncate(kept);
        self.ends.truncate(kept);
        self.keep_every = self.keep_every.saturating_mul(2);
    }
}

/// The finished map's walls as the kept sightings see them ([`walls_seen_through`]).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct WallsSeenThrough {
    /// Σ length × seen through / Σ length × seen over the map's segments of at least
    /// [`WALL_MIN_M`] that the run placed or merged into, counted over every kept sighting, a
    /// wall seen through counting as seen at least once; above 1 where walls are seen through
    /// more often than seen.
    pub share: f64,
    /// How many of those walls were seen through by at least [`NAMED_MIN_THROUGH`] sightings
    /// and by at least half as many as saw them.
    pub contradicted: usize,
    /// The scans that last merged into those walls (their `born_scan`, which every merge
    /// renews; the map's numbering), as inclusive ranges, in order: where to look.
    pub scans: Vec<[u32; 2]>,
}

/// Casts every sighting's rays at its scan's pose (`pose_of`, map frame; sightings without a
/// pose are skipped) against `map`, counting per segment the sightings that saw it and those
/// that saw through it under `params` (see the module docs of [`crate::observe`]); `None` when
/// no wall of at least [`WALL_MIN_M`] born from `from_scan` on was seen or seen through.
///
/// Only walls whose `born_scan` is at least `from_scan` count: a run that continues a saved
/// map answers for the walls it placed or merged into, not for the earlier runs' walls it
/// finds gone or sees a few centimetres off. A wall seen through counts as seen at least
/// once: the scan that placed it saw it, kept or not.
pub fn walls_seen_through(
    map: &GlobalMap,
    sightings: &Sightings,
    pose_of: impl Fn(u32) -> Option<Pose2>,
    from_scan: u32,
    params: &ObserveParams,
) -> Option<WallsSeenThrough> {
    let mut counts: FxHashMap<SegmentId, (u32, u32)> = FxHashMap::default();
    let mut found: FxHashMap<SegmentId, Crossings> = FxHashMap::default();
    for (t, rays) in sightings.iter() {
        let Some(pose) = pose_of(t) else {
            continue;
        };
        found.clear();
        let origin = pose.translation();
        for &[x, y] in rays {
            let end = pose.transform_point(Vec2::new(f64::from(x), f64::from(y)));
            cast(map, origin, end, params, &mut found);
        }
        for (&id, c) in &found {
            let count = counts.entry(id).or_default();
            if c.seen {
                count.0 += 1;
            } else if covered(map, id, c, params) {
                count.1 += 1;
            }
        }
    }
    let (mut seen_m, mut through_m) = (0.0, 0.0);
    let mut born = Vec::new();
    for (id, s) in map.iter() {
        let length = s.segment.length();
        let counted = length >= WALL_MIN_M && s.born_scan >= from_scan;
        let Some(&(seen, through)) = counts.get(&id).filter(|_| counted) else {
            continue;
        };
        let seen = if through > 0 { seen.max(1) } else { seen };
        seen_m += length * f64::from(seen);
        through_m += length * f64::from(through);
        if through >= NAMED_MIN_THROUGH && 2 * through >= seen {
            born.push(s.born_scan);
        }
    }
    if seen_m <= 0.0 {
        return None;
    }
    born.sort_unstable();
    Some(WallsSeenThrough {
        share: through_m / seen_m,
        contradicted: born.len(),
        scans: ranges(&born),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Segment;
    use crate::map::{MapSegment, Observations};

    fn map_of(segments: &[(Segment, u32)]) -> GlobalMap {
        let mut map = GlobalMap::default();
        for (s, born) in segments {
            map.insert_observed(
                MapSegment {
                    segment: *s,
                    born_scan: *born,
                },
                Observations::born(*born),
            );
        }
        map
    }

    /// A 360° scan at the origin of a 10 m square room, one return per degree.
    fn room_points() -> Vec<Vec2> {
        (0..360)
            .map(|d| {
                let a = f64::from(d).to_radians();
                let (s, c) = a.sin_cos();
                let r = 5.0 / c.abs().max(s.abs());
                Vec2::new(r * c, r * s)
            })
            .collect()
    }

    fn room() -> Vec<(Segment, u32)> {
        let c = [(-5.0, -5.0), (5.0, -5.0), (5.0, 5.0), (-5.0, 5.0)];
        (0..4)
            .map(|i| {
                let (a, b) = (c[i], c[(i + 1) % 4]);
                (Segment::new(Vec2::new(a.0, a.1), Vec2::new(b.0, b.1)), 3)
            })
            .collect()
    }

    /// The room with a wall at x = 2 from `(end.x, -end.y)` to `end`, placed by scan 90, and the
    /// room's returns from its middle offered 16 times (scans 0-15).
    fn room_seen_from_its_middle_with(end: Vec2) -> (GlobalMap, Sightings) {
        let mut segments = room();
        segments.push((Segment::new(Vec2::new(end.x, -end.y), end), 90));
        let mut sightings = Sightings::default();
        for t in 0..16 {
            sightings.record(t, &room_points(), &ObserveParams::default());
        }
        (map_of(&segments), sightings)
    }

    /// A wall placed across a room that scans before it saw empty is seen through by each of
    /// them and named by the scan that placed it; the room's own walls are seen.
    #[test]
    fn a_wall_across_the_free_space_of_earlier_scans_is_seen_through_and_named() {
        let (map, sightings) = room_seen_from_its_middle_with(Vec2::new(2.0, 3.0));
        let params = ObserveParams::default();
        let found = walls_seen_through(&map, &sightings, |_| Some(Pose2::IDENTITY), 0, &params)
            .expect("walls seen");
        assert_eq!(found.contradicted, 1);
        assert_eq!(found.scans, vec![[90, 90]]);
        // Every other of 16 scans kept: 6 m seen through 8 times over 4 × 10 m seen 8 times
        // and the 6 m seen once, by the scan that placed it.
        assert!((found.share - 48.0 / 326.0).abs() < 1e-9, "{}", found.share);
    }

    /// A run that continues the map from scan 50 answers only for the wall it placed (scan
    /// 90): the room's walls are left out, and the wall that its kept sightings only saw
    /// through still counts as seen once, by the scan that placed it.
    #[test]
    fn a_continued_run_counts_the_walls_it_placed_each_seen_at_least_once() {
        let (map, sightings) = room_seen_from_its_middle_with(Vec2::new(2.0, 3.0));
        let params = ObserveParams::default();
        let found = walls_seen_through(&map, &sightings, |_| Some(Pose2::IDENTITY), 50, &params)
            .expect("the placed wall seen through");
        assert_eq!((found.contradicted, found.scans), (1, vec![[90, 90]]));
        // 6 m seen through 8 times over 6 m seen once.
        assert!((found.share - 8.0).abs() < 1e-9, "{}", found.share);
        assert!(
            walls_seen_through(&map, &sightings, |_| Some(Pose2::IDENTITY), 91, &params).is_none()
        );
    }

    /// The same room without the wall: nothing seen through; sightings without a pose and
    /// walls shorter than [`WALL_MIN_M`] do not count.
    #[test]
    fn a_room_seen_from_inside_is_consistent() {
        let (map, sightings) = room_seen_from_its_middle_with(Vec2::new(2.0, 0.4));
        let params = ObserveParams::default();
        let found = walls_seen_through(&map, &sightings, |_| Some(Pose2::IDENTITY), 0, &params)
            .expect("walls seen");
        assert_eq!((found.share, found.contradicted), (0.0, 0));
        assert!(walls_seen_through(&map, &sightings, |_| None, 0, &params).is_none());
    }

    /// Every other observing scan is kept; a sighting past the ray budget first drops every
    /// other sighting kept, in scan order, and later scans are kept as sparsely.
    #[test]
    fn sightings_beyond_the_budget_are_thinned_evenly() {
        let params = ObserveParams::default();
        let points = room_points();
        let per_scan = thin_by_bearing(&points, params.ray_spacing_deg.to_radians()).len();
        let mut sightings = Sightings::default();
        let offered = KEEP_EVERY * (MAX_RAYS / per_scan + 1) as u32;
        for t in 0..offered {
            sightings.record(t, &points, &params);
        }
        assert!(sightings.rays.len() <= MAX_RAYS);
        assert!(sightings.rays.capacity() <= MAX_RAYS);
        let step = 2 * KEEP_EVERY;
        let scans: Vec<u32> = sightings.iter().map(|(t, _)| t).collect();
        let grid: Vec<u32> = (0..scans.len() as u32).map(|i| i * step).collect();
        assert_eq!(scans, grid);
        assert!(sightings.len() * 2 * per_scan > MAX_RAYS - 2 * per_scan);
        let before = sightings.len();
        for t in offered..offered + 4 * step {
            sightings.record(t, &points, &params);
        }
        assert_eq!(sightings.len(), before + 4);
        let mut off = Sightings::off();
        off.record(0, &points, &params);
        assert!(off.is_empty());
    }

    /// A sighting that sees a wall counts as seeing it, whatever its other rays cross; a wall
    /// seen through at least 5 times and at least half as often as seen is named, one seen
    /// through less is not.
    #[test]
    fn a_wall_is_named_when_seen_through_half_as_often_as_seen() {
        let params = ObserveParams::default();
        // A wall across the room, 6 m long at x = 2, and scans at the origin: the room's
        // returns pass through it; returns on it (bearings within 50°) see it.
        let mut segments = room();
        segments.push((Segment::new(Vec2::new(2.0, -3.0), Vec2::new(2.0, 3.0)), 90));
        let map = map_of(&segments);
        let on_wall = |d: i32| {
            let a = f64::from(d).to_radians();
            Vec2::new(2.0, 2.0 * a.tan())
        };
        let seeing: Vec<Vec2> = (-50..=50).map(on_wall).collect();
        // The room's returns, but those within 10° of ahead end on the wall.
        let mixed: Vec<Vec2> = room_points()
            .into_iter()
            .enumerate()
            .map(|(d, p)| match d <= 10 || d >= 350 {
                true => on_wall(d as i32),
                false => p,
            })
            .collect();
        let count = |scans: &[&[Vec2]]| {
            let mut sightings = Sightings::default();
            for (k, points) in scans.iter().enumerate() {
                sightings.record(KEEP_EVERY * k as u32, points, &params);
                sightings.record(KEEP_EVERY * k as u32 + 1, points, &params);
            }
            walls_seen_through(&map, &sightings, |_| Some(Pose2::IDENTITY), 0, &params)
                .expect("walls seen")
        };
        let room = room_points();
        let through = |n: usize, seen: usize| {
            let mut scans: Vec<&[Vec2]> = vec![&room; n];
            scans.extend(vec![seeing.as_slice(); seen]);
            count(&scans).contradicted
        };
        assert_eq!(through(5, 10), 1);
        assert_eq!(through(4, 10), 0);
        assert_eq!(through(4, 8), 0);
        assert_eq!(through(5, 11), 0);
        let mixed_only = count(&[mixed.as_slice(); 10]);
        assert_eq!((mixed_only.contradicted, mixed_only.share), (0, 0.0));
    }
}
