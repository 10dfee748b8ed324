//! End-to-end tests of polymap, in one binary (fast links on 2 cores).

mod cli;
mod datasets;
mod fig7;
mod hardening;
mod hardening_folders;
mod hardening_inputs;
mod lifelong;
mod merge;
mod merge_many;
mod observe;
mod readme;
mod ros;
#[cfg(feature = "ros2")]
mod ros2;
mod support;
mod tracking;
mod tracking_support;
mod worlds;
