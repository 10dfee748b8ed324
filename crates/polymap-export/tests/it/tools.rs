//! External programs some tests need (Chromium, rsvg-convert): found on PATH, or the test is
//! skipped with a visible message — except in CI (`CI=true`), where a missing tool fails it.

use std::path::PathBuf;

/// The first of `names` on PATH; `None` (after printing why) when missing outside CI.
///
/// # Panics
/// When none is installed and `CI` is `true`: CI must not pass with the check skipped.
pub fn required(names: &[&str], installs: &str) -> Option<PathBuf> {
    let found = std::env::var_os("PATH").and_then(|path| {
        std::env::split_paths(&path)
            .flat_map(|dir| names.iter().map(move |name| dir.join(name)))
            .find(|p| p.is_file())
    });
    if found.is_none() {
        let message = format!("{} not installed ({installs})", names.join(" / "));
        if std::env::var("CI").is_ok_and(|v| v == "true") {
            panic!("{message}: CI=true requires it");
        }
        println!("SKIPPED: {message}");
    }
    found
}
