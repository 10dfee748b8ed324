//! The node's occupancy grid thread: builds the grid as the PGM export does from the latest
//! job only, and publishes it on `/map`.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;

use polymap::geometry::{Pose2, Segment, Vec2};
use polymap_export::pgm::{GridParams, OccupancyGrid as Grid};
use ros2_client::Publisher;

use crate::msgs::{OccupancyGrid, Time};
use crate::node::{NodeError, NodeOptions, setup};
use crate::outputs::grid_message;

/// An occupancy grid to build and publish.
pub(crate) struct GridJob {
    pub(crate) time: Time,
    pub(crate) segments: Vec<Segment>,
    pub(crate) rays: Vec<(Pose2, Arc<Vec<Vec2>>)>,
}

#[derive(Default)]
struct GridSlot {
    job: Option<GridJob>,
    stop: bool,
}

/// The thread that builds occupancy grids and publishes them; a job submitted while one is
/// being built replaces any job still waiting (only the newest map matters).
pub(crate) struct GridThread {
    slot: Arc<(Mutex<GridSlot>, Condvar)>,
    handle: Option<JoinHandle<u64>>,
}

impl GridThread {
    pub(crate) fn start(
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

    pub(crate) fn submit(&self, job: GridJob) {
        let (lock, cv) = &*self.slot;
        lock.lock().unwrap_or_else(|e| e.into_inner()).job = Some(job);
        cv.notify_one();
    }

    /// Builds what is waiting, then stops; the grids published.
    pub(crate) fn finish(&mut self) -> u64 {
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
