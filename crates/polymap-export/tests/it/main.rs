//! Integration tests: each export is read back by a real consumer (a YAML parser and a PGM
//! reader, the `dxf` crate, the `png` decoder, headless Chromium, librsvg's `rsvg-convert`).
//! A test whose program is missing is skipped with a message, and fails when `CI=true`.

mod dxf_readback;
mod pgm_readback;
mod png_readback;
mod report_browser;
mod room;
mod svg_rsvg;
mod tools;
