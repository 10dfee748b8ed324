//! The README's commands, run as a reader would run them, so that the guide cannot rot.
//!
//! Every line of every `sh` block runs, block after block, in one scratch folder, with the
//! built `polymap` first on the `PATH` (as `cargo install` would put it), under `bash -e -o
//! pipefail`. `cargo run --release -p polymap-cli --` is the same binary and runs as
//! `polymap`; `cargo install` and `cargo test` are the only lines not run (this test is part of
//! the latter). Blocks fenced `sh datasets` need the shared benchmark logs, which they name as
//! `../shared/datasets/…` from the repository's folder: the scratch folder gets the same
//! `../shared` beside it, and they print `SKIPPED` when `../shared/datasets` is absent. The
//! README's Rust example is compiled as a doctest of `polymap-pipeline`.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::support::datasets;

/// Lines of the README that are not run, with the reason.
const NOT_RUN: &[(&str, &str)] = &[
    (
        "cargo install --path crates/polymap-cli",
        "builds the binary this test runs",
    ),
    (
        "cargo test --workspace --release -- --show-output",
        "runs this test",
    ),
];

/// What `cargo run` of the binary becomes: the binary itself.
const CARGO_RUN: &str = "cargo run --release -p polymap-cli --";

/// A fenced block of the README.
struct Block {
    /// The fence's info string (`sh`, `sh datasets`, `rust,no_run`, …).
    info: String,
    /// Line number of the opening fence, 1-based.
    line: usize,
    /// The lines between the fences.
    lines: Vec<String>,
}

fn readme() -> (PathBuf, String) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../README.md");
    let text = fs::read_to_string(&path).expect("README.md reads");
    (path, text)
}

fn blocks(text: &str) -> Vec<Block> {
    let mut out = Vec::new();
    let mut open: Option<Block> = None;
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        if let Some(info) = trimmed.strip_prefix("```") {
            match open.take() {
                Some(b) => out.push(b),
                None => {
                    open = Some(Block {
                        info: info.trim().to_string(),
                        line: i + 1,
                        lines: Vec::new(),
                    })
                }
            }
        } else if let Some(b) = open.as_mut() {
            b.lines.push(line.to_string());
        }
    }
    assert!(open.is_none(), "README.md: a code fence is not closed");
    out
}

/// The command of a line without its trailing comment, trimmed.
fn command_of(line: &str) -> &str {
    let code = match line.find(" #") {
        Some(i) => &line[..i],
        None => line,
    };
    let code = code.trim();
    if code.starts_with('#') { "" } else { code }
}

/// The script of one `sh` block: each line as written, `cargo run` as the binary, the lines
/// not run turned into comments. Returns the script and the number of commands it runs.
fn script_of(block: &Block) -> (String, usize) {
    let mut script = String::from("set -x\n");
    let mut commands = 0;
    for line in &block.lines {
        let command = command_of(line);
        if command.is_empty() {
            continue;
        }
        if let Some((_, why)) = NOT_RUN.iter().find(|(c, _)| *c == command) {
            println!("README line `{command}`: not run ({why})");
            continue;
        }
        assert!(
            !command.starts_with("cargo ") || command.starts_with(CARGO_RUN),
            "README.md block at line {}: `{command}` is a cargo command this test does not know \
             how to run; run it here or list it in NOT_RUN with the reason",
            block.line
        );
        let command = match command.strip_prefix(CARGO_RUN) {
            Some(rest) => format!("polymap{rest}"),
            None => command.to_string(),
        };
        script.push_str(&command);
        script.push('\n');
        commands += 1;
    }
    (script, commands)
}

fn run_block(block: &Block, dir: &Path, bin: &Path) -> usize {
    let (script, commands) = script_of(block);
    if commands == 0 {
        return 0;
    }
    let path = std::env::var_os("PATH").unwrap_or_default();
    let mut paths = vec![bin.to_path_buf()];
    paths.extend(std::env::split_paths(&path));
    let output = Command::new("bash")
        .args(["-e", "-o", "pipefail", "-c", &script])
        .current_dir(dir)
        .env("PATH", std::env::join_paths(paths).expect("a PATH"))
        .output()
        .expect("bash runs");
    assert!(
        output.status.success(),
        "README.md block at line {} failed ({:?}):\n{}\nstdout:\n{}\nstderr:\n{}",
        block.line,
        output.status,
        script,
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    commands
}

#[test]
fn every_command_in_the_readme_runs() {
    let (_, text) = readme();
    let blocks = blocks(&text);
    let work = tempfile::tempdir().expect("a temp dir");
    let bin = work.path().join("bin");
    fs::create_dir(&bin).expect("bin folder");
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_polymap"), bin.join("polymap"))
        .expect("a symlink to the binary");
    let dir = work.path().join("work");
    fs::create_dir(&dir).expect("work folder");

    // `../shared/datasets` from the scratch folder is the datasets folder, as it is from the
    // repository's folder.
    let data = datasets();
    if let Some(root) = &data {
        fs::create_dir(work.path().join("shared")).expect("shared folder");
        std::os::unix::fs::symlink(root, work.path().join("shared/datasets"))
            .expect("a symlink to the datasets");
    }
    let mut run = 0;
    for block in &blocks {
        match block.info.as_str() {
            "sh" => run += run_block(block, &dir, &bin),
            "sh datasets" => match &data {
                Some(_) => run += run_block(block, &dir, &bin),
                None => println!(
                    "SKIPPED: README.md block at line {} needs ../shared/datasets",
                    block.line
                ),
            },
            "" => panic!(
                "README.md block at line {}: give the fence a language (sh, rust, toml, text)",
                block.line
            ),
            _ => {}
        }
    }
    println!("README.md: {run} commands ran");
    assert!(run >= 20, "only {run} commands of the README ran");
    // What the guide says comes out of a run is there.
    for file in [
        "map.json",
        "trajectory.tum",
        "map.svg",
        "summary.json",
        "loop_nodes.json",
        "history.json",
        "map.png",
        "report.html",
    ] {
        assert!(
            dir.join("out-bag").join(file).is_file(),
            "out-bag/{file} is missing after the README's commands"
        );
    }
}

#[test]
fn the_guide_and_the_design_stay_short() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    for (file, most, why) in [
        ("README.md", 350, "a guide; figures go to docs/RESULTS.md"),
        (
            "docs/ARCHITECTURE.md",
            800,
            "the design; reasons go to docs/decisions/",
        ),
    ] {
        let text = fs::read_to_string(root.join(file)).expect("the file reads");
        let lines = text.lines().count();
        assert!(
            lines <= most,
            "{file} has {lines} lines, at most {most}: {why}"
        );
    }
}

/// Places in `text` where it speaks of the project's own making: the words "session(s)" or
/// "issue(s)" followed by a number (history is git's, not the documents').
fn history_words(text: &str) -> Vec<String> {
    let lower = text.to_lowercase();
    let mut found = Vec::new();
    for word in ["session ", "sessions ", "issue ", "issues "] {
        let mut from = 0;
        while let Some(i) = lower[from..].find(word) {
            let at = from + i;
            let after = &lower[at + word.len()..];
            let starts_word = at == 0 || !lower[..at].ends_with(|c: char| c.is_alphanumeric());
            if starts_word && after.starts_with(|c: char| c.is_ascii_digit()) {
                let end = (at + word.len() + 12).min(lower.len());
                let end = (end..=lower.len())
                    .find(|&e| lower.is_char_boundary(e))
                    .unwrap_or(lower.len());
                found.push(text[at..end].to_string());
            }
            from = at + word.len();
        }
    }
    found
}

fn text_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if name.starts_with('.') || name == "target" {
            continue;
        }
        if path.is_dir() {
            text_files(&path, out);
        } else if [".rs", ".md", ".toml", ".py"]
            .iter()
            .any(|e| name.ends_with(e))
            || path.parent().is_some_and(|p| p.ends_with("scripts"))
        {
            out.push(path);
        }
    }
}

#[test]
fn the_tree_speaks_of_the_software_not_of_its_making() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut files = Vec::new();
    for part in ["README.md", "CHANGELOG.md", "docs", "crates", "scripts"] {
        let path = root.join(part);
        if path.is_dir() {
            text_files(&path, &mut files);
        } else {
            files.push(path);
        }
    }
    assert!(files.len() > 50, "only {} files found", files.len());
    let mut places = Vec::new();
    for file in &files {
        let Ok(text) = fs::read_to_string(file) else {
            continue;
        };
        for words in history_words(&text) {
            places.push(format!("{}: \"{words}\"", file.display()));
        }
    }
    assert!(
        places.is_empty(),
        "say what the code does and why; history is git's:\n{}",
        places.join("\n")
    );
}

#[test]
fn history_words_are_found_and_plain_words_are_not() {
    // Put together here so that this file does not hold the words it looks for.
    assert_eq!(
        history_words(&format!("since Session {} the window", 12)).len(),
        1
    );
    assert_eq!(history_words(&format!("(issue {} item 4)", 10)).len(), 1);
    assert!(history_words("a session of mapping; issue: none; tissue 3").is_empty());
}
