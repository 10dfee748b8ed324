//! The mapper's side of [`crate::observe`]: the segments' observation records and pruning.

use super::Mapper;
use crate::map::Observations;
use crate::observe::{
    CrossedWalls, Sightings, WallsSeenThrough, crossed_walls, prune_contradicted,
    seen_through_share, walls_seen_through,
};

impl Mapper {
    /// The observation record of each segment of [`Mapper::segments`], in the same order (in a
    /// localize run, the saved map's records as given: empty when it had none).
    pub fn observations(&self) -> Vec<Observations> {
        if let Some((_, given)) = &self.saved {
            return given.clone();
        }
        self.map
            .iter()
            .filter_map(|(id, _)| self.map.observations(id))
            .collect()
    }

    /// How often the scans saw through the map for each time they saw it
    /// ([`crate::observe::seen_through_share`]), over every run of the map (a `--resume`d map
    /// keeps the records of the runs before); `None` for an empty map, when the scans do not
    /// observe (`[observe] enabled = false`), and in a localize run (the saved map is not
    /// observed).
    pub fn seen_through_share(&self) -> Option<f64> {
        if self.saved.is_some() || !self.config.observe.enabled {
            return None;
        }
        seen_through_share(&self.map)
    }

    /// The map's walls that cross each other ([`crate::observe::crossed_walls`]), over every
    /// run of the map, with the scans that last merged into them in this run's numbering
    /// (those of the runs before a `--resume`d map are left out); `None` where
    /// [`Mapper::seen_through_share`] is (the map's consistency is not checked).
    pub fn crossed_walls(&self) -> Option<CrossedWalls> {
        if self.saved.is_some() || !self.config.observe.enabled {
            return None;
        }
        let mut crossed = crossed_walls(&self.map)?;
        crossed.scans = in_run_numbering(&crossed.scans, self.first_scan);
        Some(crossed)
    }

    /// The finished map's walls as this run's observing scans see them at the poses of
    /// [`Mapper::trajectory`] ([`crate::observe::walls_seen_through`]; call it after
    /// [`Mapper::finish`]), over the walls this run placed or merged into (a `--resume`d map's
    /// older walls are left out), with the scans that placed the walls most seen through in
    /// this run's numbering; `None` where [`Mapper::seen_through_share`] is.
    pub fn walls_seen_through(&self) -> Option<WallsSeenThrough> {
        if self.saved.is_some() || !self.config.observe.enabled {
            return None;
        }
        let trajectory = self.trajectory();
        let first = self.first_scan;
        let pose_of = |t: u32| trajectory.get(t.checked_sub(first)? as usize).copied();
        let mut found = walls_seen_through(
            &self.map,
            &self.sightings,
            pose_of,
            first,
            &self.config.observe,
        )?;
        found.scans = in_run_numbering(&found.scans, first);
        Some(found)
    }

    /// This mapper with no rays kept for [`Mapper::walls_seen_through`]: for the mappers whose
    /// map is not checked (a run's scans tracked on a map of their own).
    pub(super) fn without_sightings(mut self) -> Self {
        self.sightings = Sightings::off();
        self
    }

    /// Removes the segments that later scans contradict
    /// ([`crate::observe::prune_contradicted`] under the `[observe]` parameters); returns how
    /// many. For the end of a run (after [`Mapper::finish`]).
    pub fn prune_contradicted(&mut self) -> usize {
        prune_contradicted(&mut self.map, &self.config.observe)
    }
}

/// Scan ranges in the map's numbering as this run's (which starts at the map's scan `first`):
/// ranges wholly before the run are left out, one reaching into it starts at its first scan.
fn in_run_numbering(ranges: &[[u32; 2]], first: u32) -> Vec<[u32; 2]> {
    ranges
        .iter()
        .filter(|[_, last]| *last >= first)
        .map(|[a, b]| [a.saturating_sub(first), b - first])
        .collect()
}
