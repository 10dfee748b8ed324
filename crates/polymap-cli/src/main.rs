//! `polymap`: map a laser log (CARMEN or ROS) or a simulated world into a few polylines and a trajectory,
//! simulate worlds, and evaluate results. Thin: argument parsing, progress, and calls into the
//! library crates.

/// Prints a line to standard output. A closed stdout (`polymap … | head`) ends the output
/// quietly instead of panicking, as Unix tools do.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

/// [`say!`] without the newline.
macro_rules! say_raw {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stdout(), $($arg)*);
    }};
}

mod args;
mod config_file;
mod eval_cmd;
mod export_cmd;
mod info_cmd;
mod interrupt;
mod map_cmd;
mod merge_cmd;
mod old_keys;
mod outputs;
mod quote;
#[cfg(feature = "ros2")]
mod ros2_cmd;
mod saved_map;
mod sim_cmd;
mod warnings;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let cli = args::Cli::parse();
    let result = match cli.command {
        args::Command::Map(a) => map_cmd::run(&a),
        args::Command::Info(a) => info_cmd::run(&a),
        args::Command::Simulate(a) => sim_cmd::run(&a),
        args::Command::Eval(a) => eval_cmd::run(&a),
        args::Command::Export(a) => export_cmd::run(&a),
        args::Command::Localize(a) => map_cmd::localize(&a),
        args::Command::Merge(a) => merge_cmd::run(&a),
        #[cfg(feature = "ros2")]
        args::Command::Ros2(a) => ros2_cmd::run(&a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.downcast_ref::<interrupt::Interrupted>().is_some() => {
            ExitCode::from(interrupt::EXIT_INTERRUPTED)
        }
        Err(e) => {
            // Messages may quote a log's bytes: escape control characters (a binary log must
            // not move the cursor or change the terminal's colours).
            eprintln!("polymap: error: {}", quote::quoted(&one_line(&e)));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes on one line, leaving out a cause whose text the message before it
/// already carries (several error types print their source in their own message).
fn one_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain().map(|c| c.to_string()) {
        if !line.contains(&cause) {
            if !line.is_empty() {
                line.push_str(": ");
            }
            line.push_str(&cause);
        }
    }
    line
}
