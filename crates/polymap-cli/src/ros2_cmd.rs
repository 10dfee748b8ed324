//! `polymap ros2`: the ROS 2 node. The node is a live scan source for the same run as
//! `polymap map` (`map_cmd::run_with`), which writes the run folder when the node is stopped.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use polymap::mapper::{MapRole, Mapper};
use polymap_io::log::LogSource;
use polymap_pipeline::folder::percentiles_ms;
use polymap_pipeline::pipeline::ScanEvent;
use polymap_ros2::dds::DdsSettings;
use polymap_ros2::node::{NodeOptions, Ros2Node};
use serde_json::json;

use crate::args::{MapArgs, Ros2Args};
use crate::map_cmd::{Live, SavedMap, run_with};

/// How often the stop watcher looks at the interrupt flag.
const STOP_POLL: Duration = Duration::from_millis(20);

/// The node as the mapping run's live source.
struct NodeRun {
    node: Option<Ros2Node>,
    topic: String,
    save_period: Option<Duration>,
    last_save: Instant,
}

impl Live for NodeRun {
    fn take_source(&mut self) -> Result<LogSource> {
        let node = self.node.as_ref().context("the node has stopped")?;
        Ok(LogSource::live(&self.topic, Box::new(node.source())))
    }

    fn stop_on(&mut self, stop: Arc<AtomicBool>) {
        let Some(node) = self.node.as_ref() else {
            return;
        };
        let queue = node.queue();
        // A detached watcher: it ends with the process or once the queue is closed.
        std::thread::spawn(move || {
            while !stop.load(Ordering::SeqCst) && !queue.is_closed() {
                std::thread::sleep(STOP_POLL);
            }
            queue.close();
        });
    }

    fn save_due(&mut self) -> bool {
        let Some(period) = self.save_period else {
            return false;
        };
        if self.last_save.elapsed() < period {
            return false;
        }
        self.last_save = Instant::now();
        true
    }

    fn on_scan(&mut self, event: &ScanEvent<'_>) {
        if let Some(node) = self.node.as_mut() {
            node.on_scan(event.stamp, event.update, event.mapper);
        }
    }

    fn finish(&mut self, mapper: &Mapper) -> serde_json::Value {
        let Some(node) = self.node.take() else {
            return serde_json::Value::Null;
        };
        let queue = node.queue();
        let report = node.finish(mapper);
        let received = queue.received();
        let [p50, p99, max] = percentiles_ms(&report.latencies);
        json!({
            "topic": self.topic,
            "scan_messages": received.scan_messages,
            "scans_mapped": received.scans,
            "dropped_scans": received.dropped,
            "bad_messages": received.bad_messages,
            "odometry_messages": received.odometry_messages,
            "latency_ms": { "p50": p50, "p99": p99, "max": max },
            "publish_failures": report.publish_failures,
            "grids_published": report.grids_published,
        })
    }
}

/// `polymap ros2`.
pub fn run(a: &Ros2Args) -> Result<()> {
    // map.pgm needs every scan's rays kept for the whole run (about 1.6 GB an hour at 40 Hz);
    // the node's grid keeps a bounded set and publishes it as /map.
    anyhow::ensure!(
        !a.export.contains(&polymap_export::formats::Format::Pgm),
        "--export pgm is not for a live run, which would keep every scan's rays: the occupancy \
         grid is published on /map (save it with Nav2's map_saver), or run `polymap map` on a \
         recording of the run"
    );
    let (settings, warnings) = DdsSettings::from_env()?;
    for w in warnings {
        eprintln!("polymap: warning: {w}");
    }
    let saved = match (&a.resume, &a.localize) {
        (Some(dir), _) => Some(SavedMap::read(dir, MapRole::Build)?),
        (None, Some(dir)) => Some(SavedMap::read(dir, MapRole::Localize)?),
        (None, None) => None,
    };
    let map_args = MapArgs {
        log: None,
        topic: None,
        odom_topic: None,
        output: a.output.clone(),
        config: a.config.clone(),
        preset: a.preset.clone(),
        odometry: a.odometry,
        skip_bad_lines: true,
        print_config: false,
        svg_points: false,
        prune_contradicted: false,
        max_scans: None,
        every: 1,
        every_offset: 0,
        diagnostics: a.diagnostics,
        export: a.export.clone(),
        resolution: a.resolution,
        timings: false,
        quiet: a.quiet,
        resume: a.resume.clone(),
        initial_pose: a.initial_pose,
        base_frame: a.base_frame.clone(),
    };
    let options = NodeOptions {
        scan_topic: a.scan_topic.clone(),
        odom_topic: a.odom_topic.clone(),
        odometry: a.odometry,
        map_frame: a.map_frame.clone(),
        base_frame: a.base_frame.clone(),
        queue_scans: usize::try_from(a.queue).unwrap_or(usize::MAX),
        map_period_s: a.map_period,
        resolution_m: a.resolution,
        ..NodeOptions::default()
    };
    let node = Ros2Node::start(&settings, options)?;
    if !a.quiet {
        eprintln!(
            "polymap: ROS 2 node `polymap` in domain {}{}: mapping LaserScans on {} until Ctrl-C \
             or SIGTERM, then writing {}",
            settings.domain_id,
            if settings.localhost_only {
                " (this machine only)"
            } else {
                ""
            },
            a.scan_topic,
            a.output.display()
        );
    }
    let mut live = NodeRun {
        node: Some(node),
        topic: a.scan_topic.clone(),
        save_period: (a.save_period > 0.0).then(|| Duration::from_secs_f64(a.save_period)),
        last_save: Instant::now(),
    };
    run_with(&map_args, saved, Some(&mut live))
}
