//! Command-line arguments.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

/// Geometric robot mapping: 2D laser scans to a compact map of a few polylines.
#[derive(Debug, Parser)]
#[command(name = "polymap", version, about)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Map a log — CARMEN (.clf), ROS 1 bag, MCAP, rosbag2 (.db3 or folder) — or, without
    /// LOG, the built-in simulated 45° hallway.
    Map(MapArgs),
    /// Say what a log holds: topics, types, counts, time span, the laser's geometry and rate.
    Info(InfoArgs),
    /// Simulate a world: a CARMEN log (and, with --ros, an MCAP file and a ROS 1 bag) plus its
    /// ground truth (trajectory and walls).
    Simulate(SimulateArgs),
    /// Measure a trajectory or a map against ground truth or the log.
    Eval(EvalArgs),
    /// Write other formats from a finished `polymap map` run, without mapping again.
    Export(ExportArgs),
    /// Localize a log in a saved map without changing the map: global localization at the
    /// start, then tracking (with recovery when lost); writes the trajectory in the map's frame.
    Localize(LocalizeArgs),
    /// Merge maps of the same place made separately: find where each lies in the first (no
    /// guess needed), refuse maps that do not overlap or fit in two places, merge the others.
    Merge(MergeArgs),
    /// Run as a ROS 2 SLAM node (no ROS installation needed): map the LaserScans of a live
    /// robot, publish /map, /tf, /pose, polymap/segments and polymap/status; on Ctrl-C or
    /// SIGTERM write the run folder as `polymap map` does and exit 0.
    #[cfg(feature = "ros2")]
    Ros2(Ros2Args),
}

#[cfg(feature = "ros2")]
#[derive(Debug, Args)]
pub struct Ros2Args {
    /// The sensor_msgs/LaserScan topic (sensor-data QoS: best effort, volatile).
    #[arg(long, default_value = "scan")]
    pub scan_topic: String,
    /// A nav_msgs/Odometry topic to read the odometry from (used by --odometry, else as a
    /// witness of the tracked steps; its frame becomes `odom`, its child frame the base).
    #[arg(long)]
    pub odom_topic: Option<String>,
    /// Start each scan's alignment from the odometry's step, as `polymap map --odometry`: the
    /// odometry of --odom-topic, else tf `odom → base`.
    #[arg(long)]
    pub odometry: bool,
    /// The global frame published.
    #[arg(long, default_value = "map")]
    pub map_frame: String,
    /// The robot's frame (default: the odometry's child frame, else the scans' frame).
    #[arg(long)]
    pub base_frame: Option<String>,
    /// Scans waiting for the mapper, at most; beyond, the oldest is dropped (counted).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u64).range(1..=10_000))]
    pub queue: u64,
    /// Publish /map (the occupancy grid) and the markers at most this often, seconds, and only
    /// when the map changed.
    #[arg(long, default_value_t = 2.0, value_parser = parse_period)]
    pub map_period: f64,
    /// Output directory, written on Ctrl-C or SIGTERM (created if missing).
    #[arg(short, long, default_value = "out")]
    pub output: PathBuf,
    /// Also write the output directory every this many seconds while mapping (0: only at the
    /// end), so that a crash loses at most that much.
    #[arg(long, default_value_t = 60.0, value_parser = parse_period)]
    pub save_period: f64,
    /// A TOML configuration file (see `polymap map --print-config`); may be repeated.
    #[arg(long)]
    pub config: Vec<PathBuf>,
    /// A named preset: `default` or `paper`.
    #[arg(long, default_value = "default")]
    pub preset: String,
    /// Continue the saved map in DIR (as `polymap map --resume`).
    #[arg(long, value_name = "DIR", conflicts_with = "localize")]
    pub resume: Option<PathBuf>,
    /// Localize in the saved map in DIR without changing it (as `polymap localize`).
    #[arg(long, value_name = "DIR")]
    pub localize: Option<PathBuf>,
    /// With --resume or --localize: where the robot starts in the saved map, `x,y,yaw`.
    #[arg(long, value_name = "X,Y,YAW", value_parser = parse_pose, allow_hyphen_values = true)]
    pub initial_pose: Option<polymap::geometry::Pose2>,
    /// Also write these formats (comma-separated): png, html, dxf (the occupancy grid is
    /// `/map`).
    #[arg(long, value_delimiter = ',')]
    pub export: Vec<polymap_export::formats::Format>,
    /// Cell size of /map, metres.
    #[arg(long, default_value_t = 0.05, value_parser = parse_resolution)]
    pub resolution: f64,
    /// Also write per-scan diagnostics to DIR/diagnostics.jsonl.
    #[arg(long)]
    pub diagnostics: bool,
    /// Quiet: no summary line.
    #[arg(short, long)]
    pub quiet: bool,
}

/// A period in seconds: finite, from 0 to one day.
#[cfg(feature = "ros2")]
fn parse_period(text: &str) -> Result<f64, String> {
    let s: f64 = text.parse().map_err(|_| format!("not a number: {text}"))?;
    if s.is_finite() && (0.0..=86_400.0).contains(&s) {
        Ok(s)
    } else {
        Err(format!("{text} s is outside 0..=86400 s"))
    }
}

#[derive(Debug, Args)]
pub struct LocalizeArgs {
    /// The run folder of the map to localize in (a `polymap map` output with map.json).
    #[arg(long, value_name = "DIR")]
    pub map: PathBuf,
    #[command(flatten)]
    pub run: MapArgs,
}

#[derive(Debug, Args)]
pub struct MergeArgs {
    /// The maps' folders (outputs of `polymap map`, holding map.json), two or more: the merged
    /// map is in the first one's frame; the others join it in the order of their overlap.
    #[arg(required = true, num_args = 2..)]
    pub maps: Vec<PathBuf>,
    /// Output folder: map.json (merged, the first map's frame), merge.json (each map's
    /// transform or why it was refused, scores, overlap), map.svg, and each merged map's
    /// trajectory as laid.
    #[arg(short, long)]
    pub output: PathBuf,
    /// How B is laid onto A: `auto` (one rigid transform when it fits, else B bent onto A by
    /// a joint pose graph of both maps' loop nodes), `rigid` (one transform only) or
    /// `pose-graph` (always the joint pose graph).
    #[arg(long, value_enum, default_value_t = MergeBy::Auto)]
    pub by: MergeBy,
    /// Print nothing but warnings and errors.
    #[arg(short, long)]
    pub quiet: bool,
}

/// How `polymap merge` lays map B onto map A.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MergeBy {
    /// Rigid when the rigid match is accepted, else the joint pose graph.
    Auto,
    /// One rigid transform.
    Rigid,
    /// The joint pose graph, seeded by the rigid match.
    PoseGraph,
}

#[derive(Debug, Args)]
pub struct ExportArgs {
    /// The output directory of `polymap map`.
    pub run: PathBuf,
    /// Formats to write (comma-separated): png, html, pgm, dxf.
    #[arg(long, value_delimiter = ',', required = true)]
    pub format: Vec<polymap_export::formats::Format>,
    /// Cell size of the pgm occupancy grid, metres.
    #[arg(long, default_value_t = 0.05, value_parser = parse_resolution)]
    pub resolution: f64,
    /// The log the run mapped, for the grid's free space (default: the one in summary.json).
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// Skip malformed log lines or undecodable messages when re-reading the log.
    #[arg(long = "skip-bad-input", visible_alias = "skip-bad-lines")]
    pub skip_bad_lines: bool,
}

#[derive(Debug, Args)]
pub struct EvalArgs {
    #[command(subcommand)]
    pub command: EvalCommand,
}

#[derive(Debug, Subcommand)]
pub enum EvalCommand {
    /// Relative pose error against a `.relations` file (Kümmerle et al. 2009).
    Relations {
        /// The estimated trajectory (TUM).
        trajectory: PathBuf,
        /// The ground-truth relations.
        relations: PathBuf,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// ATE (after SE(2) alignment) and RPE against a true trajectory (TUM vs TUM).
    Trajectory {
        /// The estimated trajectory (TUM).
        estimate: PathBuf,
        /// The true trajectory (TUM), e.g. from `polymap simulate`.
        truth: PathBuf,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Score a finished run's map against the log's points and/or true walls.
    Map {
        /// The output directory of `polymap map` (holds map.json and trajectory.tum).
        run: PathBuf,
        /// The log that was mapped: scores how much of its points the map explains.
        #[arg(long)]
        log: Option<PathBuf>,
        /// True walls (map.json format, e.g. NAME.walls.json from `polymap simulate`):
        /// precision and recall of the map.
        #[arg(long)]
        walls: Option<PathBuf>,
        /// Use every N-th scan of the log.
        #[arg(long, default_value_t = 1)]
        stride: usize,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// The world to simulate (see --list).
    pub world: Option<String>,
    /// Output directory (created if missing).
    #[arg(short, long, default_value = "out/sim")]
    pub output: PathBuf,
    /// Seed of the noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// List the worlds and exit.
    #[arg(long)]
    pub list: bool,
    /// Also write the world as ROS recordings: NAME.mcap (ROS 2, zstd chunks) and NAME.bag
    /// (ROS 1, lz4 chunks), with the laser on /scan, odometry on /odom, and tf: the laser
    /// mounted 0.25 m ahead of the robot (base_link → laser on /tf_static, also in the CARMEN
    /// log) and odom → base_link on /tf. The truth is the robot's (base_link) trajectory.
    #[arg(long)]
    pub ros: bool,
    /// The laser's field of view, degrees (one beam per degree, centred ahead; e.g. 180, 270,
    /// 360), instead of the world's own laser.
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..=360))]
    pub fov_deg: Option<u16>,
}

#[derive(Debug, Args)]
pub struct InfoArgs {
    /// The log: CARMEN (.clf), ROS 1 bag, MCAP, rosbag2 .db3 or folder.
    pub log: PathBuf,
}

#[derive(Debug, Args)]
pub struct MapArgs {
    /// The log to map: CARMEN (.clf, or compressed .gz/.bz2; `-` reads standard input), ROS 1
    /// bag (.bag), MCAP (.mcap), rosbag2 sqlite3 (.db3) or rosbag2 folder (with
    /// metadata.yaml); told by content. Without it, the built-in `hallway45` world is
    /// simulated and mapped.
    pub log: Option<PathBuf>,
    /// ROS: the sensor_msgs/LaserScan topic (default: the only one in the file).
    #[arg(long)]
    pub topic: Option<String>,
    /// ROS: the nav_msgs/Odometry topic (default: the only one in the file) that --odometry
    /// tracks from, or that otherwise witnesses the tracked steps. Without one, tf's odom →
    /// base frame is the odometry, where the recording has /tf.
    #[arg(long)]
    pub odom_topic: Option<String>,
    /// ROS: the robot's frame in tf (default: base_link, else base_footprint). Each scan's
    /// laser is placed by tf from it to the scan's frame_id (/tf_static, /tf); without tf the
    /// laser is taken at the robot's origin.
    #[arg(long, value_name = "FRAME")]
    pub base_frame: Option<String>,
    /// Output directory (created if missing).
    #[arg(short, long, default_value = "out")]
    pub output: PathBuf,
    /// A TOML configuration file (see --print-config); it overrides the preset. May be given
    /// more than once: each file overrides the ones before it.
    #[arg(long)]
    pub config: Vec<PathBuf>,
    /// A named preset: `default` or `paper`.
    #[arg(long, default_value = "default")]
    pub preset: String,
    /// Start each ICP from the log's odometry increment (map in odometry's frame); also runs ICP
    /// from every start and keeps the most inliers, which measured best with odometry. ROS:
    /// odometry from nav_msgs/Odometry (--odom-topic), interpolated to each scan's stamp, or,
    /// without an odometry topic, tf's odom → base frame.
    #[arg(long)]
    pub odometry: bool,
    /// Skip bad input — malformed log lines, undecodable messages, corrupt chunks — (counted
    /// and reported) instead of stopping at the first.
    #[arg(long = "skip-bad-input", visible_alias = "skip-bad-lines")]
    pub skip_bad_lines: bool,
    /// Print the effective configuration as TOML and exit.
    #[arg(long)]
    pub print_config: bool,
    /// Also draw the scan points in map.svg.
    #[arg(long)]
    pub svg_points: bool,
    /// At the end of the run, remove the map segments that later scans contradict: seen
    /// through (laser rays passed where they stand) by several scans since any scan saw them
    /// (a moved cupboard, an opened door, people). Rules in the config section `[observe]`.
    #[arg(long)]
    pub prune_contradicted: bool,
    /// Stop after this many scans (counted after --every).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    pub max_scans: Option<u64>,
    /// Use every K-th scan of the log (faster, less accurate; larger steps between scans).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    pub every: u64,
    /// With --every K: start at this scan (0-based, below K), to use another phase of the log.
    #[arg(long, default_value_t = 0)]
    pub every_offset: u64,
    /// Also write per-scan diagnostics (ICP, merge counts, main directions) to
    /// DIR/diagnostics.jsonl, one JSON object per scan.
    #[arg(long)]
    pub diagnostics: bool,
    /// Also write these formats (comma-separated): png, html, pgm, dxf.
    #[arg(long, value_delimiter = ',')]
    pub export: Vec<polymap_export::formats::Format>,
    /// Cell size of the pgm occupancy grid, metres.
    #[arg(long, default_value_t = 0.05, value_parser = parse_resolution)]
    pub resolution: f64,
    /// Print where the time went.
    #[arg(long)]
    pub timings: bool,
    /// Quiet: no progress bar and no summary line (warnings and errors still go to stderr).
    #[arg(short, long)]
    pub quiet: bool,
    /// Continue the map of an earlier run in DIR (its map.json): the log's first scans are
    /// placed by a global search over that map (or near --initial-pose), then mapping goes on
    /// in that map's frame.
    #[arg(long, value_name = "DIR")]
    pub resume: Option<PathBuf>,
    /// With --resume or `localize`: where the robot starts, in the saved map's frame:
    /// `x,y,yaw` in metres, metres, radians (searched within 1 m and 30° of it).
    #[arg(long, value_name = "X,Y,YAW", value_parser = parse_pose, allow_hyphen_values = true)]
    pub initial_pose: Option<polymap::geometry::Pose2>,
}

/// A pose `x,y,yaw` (metres, metres, radians), finite.
fn parse_pose(text: &str) -> Result<polymap::geometry::Pose2, String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("expected x,y,yaw (metres, metres, radians), found {text:?}"))?;
    match values[..] {
        [x, y, yaw] if values.iter().all(|v| v.is_finite()) => {
            Ok(polymap::geometry::Pose2::new(x, y, yaw))
        }
        _ => Err(format!(
            "expected three finite numbers x,y,yaw (metres, metres, radians), found {text:?}"
        )),
    }
}

/// A grid resolution: finite, at least 1 mm, at most 100 m.
fn parse_resolution(text: &str) -> Result<f64, String> {
    let r: f64 = text.parse().map_err(|_| format!("not a number: {text}"))?;
    if r.is_finite() && (0.001..=100.0).contains(&r) {
        Ok(r)
    } else {
        Err(format!("{text} m is outside 0.001..=100 m"))
    }
}
