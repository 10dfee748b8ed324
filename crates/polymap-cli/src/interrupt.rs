//! Ctrl-C: the first one asks the mapping run to stop and save what it has mapped; a second one
//! ends the process at once. Either way the exit status is 130 (128 + SIGINT), as shells expect.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

use anyhow::{Context, Result};

/// The exit status of an interrupted run.
pub const EXIT_INTERRUPTED: u8 = 130;

/// The error a command returns after it saved an interrupted run (already reported).
#[derive(Debug)]
pub struct Interrupted;

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("interrupted")
    }
}

impl std::error::Error for Interrupted {}

/// The flag Ctrl-C sets (the handler is installed on the first call).
pub fn flag() -> Result<Arc<AtomicBool>> {
    static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();
    if let Some(flag) = FLAG.get() {
        return Ok(Arc::clone(flag));
    }
    let flag = Arc::new(AtomicBool::new(false));
    let handler_flag = Arc::clone(&flag);
    ctrlc::set_handler(move || {
        if handler_flag.swap(true, Ordering::SeqCst) {
            eprintln!("polymap: interrupted again: stopping without saving");
            std::process::exit(i32::from(EXIT_INTERRUPTED));
        }
        eprintln!("polymap: interrupt: stopping after this scan and saving what was mapped (Ctrl-C again to quit at once)");
    })
    .context("cannot install the Ctrl-C handler")?;
    Ok(Arc::clone(FLAG.get_or_init(|| flag)))
}
