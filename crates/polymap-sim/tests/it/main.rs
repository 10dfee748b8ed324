//! Integration tests of polymap-sim, linked into one test binary.

mod raycast;
mod simulate;
mod worlds;
