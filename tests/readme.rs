//! The README's usage commands run as written: every command of the README's first two
//! `sh` blocks (the opening and "Using it") that runs the program, with
//! `target/release/raytracer` and `cargo run --release --` standing for the binary under
//! test, in an empty directory. Each must exit 0 and leave the files it names (`-o`,
//! `--report`, or the default `<scene>.png`). `cargo build` and `cargo test` lines are
//! the build itself and are not run again; `my-scene.toml` stands for the reader's own
//! scene file, for which the test writes a copy of `scenes/spheres.toml`. The opening
//! block's `cargo test` is the command `.ci/run` runs.

use std::path::Path;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_raytracer");

/// The commands of the first `count` `sh` blocks, comments stripped.
fn sh_commands(readme: &str, count: usize) -> Vec<String> {
    let mut commands = Vec::new();
    let mut blocks = 0;
    let mut inside = false;
    for line in readme.lines() {
        if inside {
            if line.trim_start().starts_with("```") {
                inside = false;
                blocks += 1;
                if blocks == count {
                    break;
                }
            } else {
                let command = line.split(" #").next().unwrap_or("").trim();
                if !command.is_empty() {
                    commands.push(command.to_string());
                }
            }
        } else if line.trim_start().starts_with("```sh") {
            inside = true;
        }
    }
    commands
}

/// The program's arguments of a command that runs it, or `None` for a build command.
fn program_args(command: &str) -> Option<Vec<String>> {
    let words: Vec<String> = command.split_whitespace().map(String::from).collect();
    if let Some(rest) = words.strip_prefix(&["target/release/raytracer".to_string()]) {
        return Some(rest.to_vec());
    }
    let run = ["cargo", "run", "--release", "--"].map(String::from);
    if let Some(rest) = words.strip_prefix(&run) {
        return Some(rest.to_vec());
    }
    let build = words.first().is_some_and(|w| w == "cargo")
        && matches!(words.get(1).map(String::as_str), Some("build" | "test"));
    assert!(build, "a README command the test does not know: {command}");
    None
}

/// The files a run names: `-o`/`--output` and `--report`, or `<scene>.png` by default.
fn files_named(args: &[String]) -> Vec<String> {
    let mut files = Vec::new();
    let mut output = false;
    for pair in args.windows(2) {
        match pair[0].as_str() {
            "-o" | "--output" => {
                files.push(pair[1].clone());
                output = true;
            }
            "--report" => files.push(pair[1].clone()),
            _ => {}
        }
    }
    let lists = args.iter().any(|a| a == "--list");
    if !output && !lists {
        let scene = args.iter().find(|a| !a.starts_with('-')).expect("a scene");
        let stem = Path::new(scene).file_stem().unwrap().to_string_lossy();
        files.push(format!("{stem}.png"));
    }
    files
}

#[test]
fn the_readme_usage_commands_run_as_written() {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md"))
        .expect("README.md");
    let commands = sh_commands(&readme, 2);
    let runs: Vec<(String, Vec<String>)> = commands
        .iter()
        .filter_map(|c| program_args(c).map(|a| (c.clone(), a)))
        .collect();
    assert!(runs.len() >= 4, "too few commands found: {commands:?}");
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(
        concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/spheres.toml"),
        dir.path().join("my-scene.toml"),
    )
    .unwrap();
    for (command, args) in runs {
        let out = Command::new(BIN)
            .args(&args)
            .current_dir(dir.path())
            .output()
            .expect("run the binary");
        assert!(
            out.status.success(),
            "{command}: {:?}\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
        for file in files_named(&args) {
            let len = std::fs::metadata(dir.path().join(&file)).map_or(0, |m| m.len());
            assert!(len > 0, "{command}: {file} was not written");
        }
    }
}

/// The README's test command is the one CI runs: its opening block's `cargo test` line
/// appears, as written, as a line of `.ci/run`.
#[test]
fn ci_runs_the_readme_test_command() {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md"))
        .expect("README.md");
    let ci =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/.ci/run")).expect(".ci/run");
    let test = sh_commands(&readme, 1)
        .into_iter()
        .find(|c| c.starts_with("cargo test"))
        .expect("the README's opening block has a `cargo test` command");
    assert!(
        ci.lines().any(|l| l.trim() == test),
        ".ci/run does not run the README's test command `{test}`"
    );
}
