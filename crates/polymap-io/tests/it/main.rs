//! Integration tests of polymap-io, in one test binary.

mod real_logs;
