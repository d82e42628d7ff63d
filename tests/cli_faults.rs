//! The command line under faults of its surroundings: a closed or full standard output
//! or error, a process limit that refuses threads, an address-space limit or a
//! `--max-memory` below the estimate, unwritable output directories, and a report that
//! cannot be written. Each ends with exit code 0 or 2, never a panic or an abort, and
//! leaves no temporary file and no clobbered output.
//!
//! Cases that need a tool (`prlimit`, `setpriv`) or a device (`/dev/full`) the machine
//! lacks are skipped with a printed reason. Limits on processes and permissions do not
//! bind root: run as root, those cases run the binary as the user `nobody`.
#![cfg(unix)]

use std::os::unix::fs::PermissionsExt;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use tempfile::TempDir;

const BIN: &str = env!("CARGO_BIN_EXE_raytracer");

/// A scene of one sphere, a 16:1 image: at `width = 65536` it is 65536x4096 pixels.
const WIDE: &str = r#"background = [0.5, 0.5, 0.5]
[camera]
width = 16
aspect_ratio = "16:1"
samples_per_pixel = 1
look_from = [0, 0, 0]
look_at = [0, 0, -1]

[materials.grey]
type = "phong"
albedo = [0.5, 0.5, 0.5]
shininess = 10

[[objects]]
type = "sphere"
center = [0, 0, -2]
radius = 0.5
material = "grey"
"#;

/// A directory that the user `nobody` may write too (for the cases run as `nobody`).
fn shared_dir() -> TempDir {
    let dir = TempDir::new().unwrap();
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o777)).unwrap();
    dir
}

fn has_tool(name: &str) -> bool {
    Command::new(name)
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

fn is_root() -> bool {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            let line = s.lines().find(|l| l.starts_with("Uid:"))?.to_string();
            Some(line.split_whitespace().nth(2)? == "0")
        })
        .unwrap_or(false)
}

/// `nobody`'s user id, which the unprivileged runs take.
const NOBODY: u32 = 65534;

/// A user id of no account and of no other test's process, for the run under a process
/// limit: the limit counts every process and thread of its user, so a test running as
/// `nobody` beside it (they run in parallel) would take the room it leaves.
const LIMITED_USER: u32 = 65533;

/// The binary with `args` in `dir`, as `nobody` when this test runs as root (`None`
/// where that needs `setpriv` and there is none), after `limit` (a `prlimit` option).
fn unprivileged(dir: &Path, limit: Option<&str>, args: &[&str]) -> Option<Command> {
    unprivileged_as(NOBODY, dir, limit, args)
}

/// `unprivileged` as user `uid` (and group of the same number) when run as root.
fn unprivileged_as(uid: u32, dir: &Path, limit: Option<&str>, args: &[&str]) -> Option<Command> {
    let mut words: Vec<String> = Vec::new();
    if is_root() {
        if !has_tool("setpriv") {
            return None;
        }
        words.extend([
            "setpriv".to_string(),
            format!("--reuid={uid}"),
            format!("--regid={uid}"),
            "--clear-groups".to_string(),
        ]);
    }
    if let Some(limit) = limit {
        words.extend(["prlimit".to_string(), limit.to_string()]);
    }
    words.push(BIN.to_string());
    words.extend(args.iter().map(|a| a.to_string()));
    let mut command = Command::new(&words[0]);
    command
        .args(&words[1..])
        .current_dir(dir)
        .stdin(Stdio::null());
    Some(command)
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Exit code 2 with every piece of `expected` on stderr.
fn assert_refused(out: &Output, expected: &[&str]) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(2), "{}: {err}", out.status);
    for piece in expected {
        assert!(err.contains(piece), "'{piece}' not in: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn list_into_a_closed_pipe_ends_quietly() {
    for _ in 0..3 {
        // A pipe whose reader has ended: every write to it fails with a broken pipe.
        let mut reader = Command::new("true").stdin(Stdio::piped()).spawn().unwrap();
        let write_end = reader.stdin.take().unwrap();
        reader.wait().unwrap();
        let out = Command::new(BIN)
            .arg("--list")
            .stdout(write_end)
            .stderr(Stdio::piped())
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
        assert_eq!(stderr(&out), "");
    }
}

#[test]
fn list_into_a_full_device_is_an_error() {
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
        eprintln!("skipped: no /dev/full here");
        return;
    };
    let out = Command::new(BIN)
        .arg("--list")
        .stdout(full)
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    assert_refused(&out, &["cannot write to standard output", "No space left"]);
}

/// `-o -` and `--report -` into a pipe whose reader has ended, or into a full device:
/// the image (or report) goes nowhere, and the run ends as `--list` does, with no
/// file left (the report's file not made when the image did not go out).
#[test]
fn standard_output_closed_or_full() {
    let cases: [&[&str]; 3] = [
        &["-o", "-", "--report", "r.json"],
        &["-o", "-", "--format", "exr"],
        &["-o", "out.png", "--report", "-"],
    ];
    for args in cases {
        let image_to_stdout = args[1] == "-";
        let dir = TempDir::new().unwrap();
        let mut reader = Command::new("true").stdin(Stdio::piped()).spawn().unwrap();
        let write_end = reader.stdin.take().unwrap();
        reader.wait().unwrap();
        let out = Command::new(BIN)
            .args(["spheres", "--width", "64", "--spp", "1", "--quiet"])
            .args(args)
            .current_dir(dir.path())
            .stdout(write_end)
            .stderr(Stdio::piped())
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(0), "{args:?}: {}", stderr(&out));
        assert_eq!(stderr(&out), "", "{args:?}");
        // The image file is written before the report goes to standard output.
        let expected: &[&str] = if image_to_stdout { &[] } else { &["out.png"] };
        assert_eq!(names(dir.path()), expected, "{args:?}");

        let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
            eprintln!("skipped: no /dev/full here");
            continue;
        };
        let dir = TempDir::new().unwrap();
        let out = Command::new(BIN)
            .args(["spheres", "--width", "64", "--spp", "1", "--quiet"])
            .args(args)
            .current_dir(dir.path())
            .stdout(full)
            .stderr(Stdio::piped())
            .output()
            .unwrap();
        assert_refused(&out, &["cannot write to standard output", "No space left"]);
        assert_eq!(names(dir.path()), expected, "{args:?}");
    }
}

/// `-o -` on a terminal is refused before the render (the image's bytes would garble
/// it), and writes nothing. The terminal is `script`'s.
#[test]
fn image_to_a_terminal_is_refused() {
    if !has_tool("script") {
        eprintln!("skipped: no script(1) here");
        return;
    }
    let dir = TempDir::new().unwrap();
    let out = Command::new("script")
        .args([
            "-qec",
            &format!("{BIN} spheres --width 8 -o -"),
            "/dev/null",
        ])
        .current_dir(dir.path())
        .stdin(Stdio::null())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(2), "{text}");
    assert!(
        text.contains("-o -: standard output is a terminal"),
        "{text}"
    );
    assert_eq!(names(dir.path()), Vec::<String>::new());
}

#[test]
fn a_full_stderr_does_not_fail_a_render() {
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
        eprintln!("skipped: no /dev/full here");
        return;
    };
    let dir = TempDir::new().unwrap();
    let status = Command::new(BIN)
        .args(["spheres", "--width", "16", "--spp", "1", "--stats"])
        .args(["-o", "out.png", "--report", "r.json"])
        .current_dir(dir.path())
        .stderr(full)
        .status()
        .unwrap();
    assert_eq!(status.code(), Some(0), "{status}");
    assert_eq!(names(dir.path()), ["out.png", "r.json"]);
}

/// A process limit of 2 leaves no room for a worker thread beside the main thread and
/// the signal cleanup's: exit 2 (`--list`, which needs neither, runs under a limit of 1). With 3, a run without `--threads` falls back to one
/// worker and renders the same image; with `--threads 2` it is refused naming the flag.
#[test]
fn a_process_limit_is_an_error_or_fewer_threads() {
    if !has_tool("prlimit") {
        eprintln!("skipped: no prlimit here");
        return;
    }
    if !is_root() {
        eprintln!("skipped: the limit counts every process of this user (run as root)");
        return;
    }
    let dir = shared_dir();
    let render = ["spheres", "--width", "16", "--spp", "2"];
    let run = |limit: &str, extra: &[&str]| {
        let args: Vec<&str> = render.iter().chain(extra).copied().collect();
        unprivileged_as(LIMITED_USER, dir.path(), Some(limit), &args)
            .map(|mut c| c.output().unwrap())
    };
    let Some(out) = run("--nproc=2", &["-o", "two.png"]) else {
        eprintln!("skipped: no setpriv here to drop root");
        return;
    };
    assert_refused(&out, &["cannot start"]);
    // --list needs no thread but the main one.
    let list = unprivileged_as(LIMITED_USER, dir.path(), Some("--nproc=1"), &["--list"])
        .unwrap()
        .output()
        .unwrap();
    assert_eq!(list.status.code(), Some(0), "{}", stderr(&list));
    assert!(String::from_utf8_lossy(&list.stdout).contains("cornell"));
    let out = run("--nproc=3", &["-o", "three.png", "--threads", "2"]).unwrap();
    assert_refused(&out, &["cannot start 2 worker threads (--threads)"]);
    assert!(names(dir.path()).is_empty(), "{:?}", names(dir.path()));

    let out = run("--nproc=3", &["-o", "one.ppm"]).unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let reference = Command::new(BIN)
        .args(render)
        .args(["--threads", "1", "-o", "reference.ppm"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(reference.status.success(), "{}", stderr(&reference));
    let read = |name: &str| std::fs::read(dir.path().join(name)).unwrap();
    assert_eq!(read("one.ppm"), read("reference.ppm"));
}

#[test]
fn an_address_space_limit_refuses_the_image_before_the_render() {
    if !has_tool("prlimit") {
        eprintln!("skipped: no prlimit here");
        return;
    }
    let dir = TempDir::new().unwrap();
    std::fs::write(dir.path().join("wide.toml"), WIDE).unwrap();
    let out = Command::new("prlimit")
        .arg(format!("--as={}", 2u64 << 30))
        .args([BIN, "wide.toml", "--width", "65536", "-o", "wide.png"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_refused(
        &out,
        &[
            "wide.toml: a 65536x4096 image",
            "about 3.0 GiB",
            "address-space limit",
        ],
    );
    assert_eq!(names(dir.path()), ["wide.toml"]);
}

#[test]
fn max_memory_caps_the_estimate() {
    let dir = TempDir::new().unwrap();
    std::fs::write(dir.path().join("wide.toml"), WIDE).unwrap();
    let run = |max: &str, width: &str| {
        Command::new(BIN)
            .args([
                "wide.toml",
                "--width",
                width,
                "--max-memory",
                max,
                "-o",
                "w.png",
            ])
            .current_dir(dir.path())
            .output()
            .unwrap()
    };
    assert_refused(
        &run("2G", "65536"),
        &["--max-memory", "a 65536x4096 image", "the limit is 2.0 GiB"],
    );
    assert_refused(&run("5X", "16"), &["--max-memory", "unknown unit 'X'"]);
    assert_eq!(names(dir.path()), ["wide.toml"]);
    // 16x1 pixels and one sphere fit in 40 MiB (the program counts 32).
    let out = run("40M", "16");
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert_eq!(names(dir.path()), ["w.png", "wide.toml"]);
}

/// An image or report in a directory the user cannot write to is refused before the
/// render: the other output stays as it was and no temporary file is left.
#[test]
fn unwritable_outputs_are_refused_before_the_render() {
    let dir = shared_dir();
    let locked = dir.path().join("locked");
    std::fs::create_dir(&locked).unwrap();
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).unwrap();
    let image = dir.path().join("out.png");
    std::fs::write(&image, b"an earlier image").unwrap();
    std::fs::set_permissions(&image, std::fs::Permissions::from_mode(0o666)).unwrap();
    let render = ["spheres", "--width", "16", "--spp", "1"];
    let cases: [(&[&str], &str); 2] = [
        (&["-o", "locked/out.png"], "cannot write locked/out.png"),
        (
            &["-o", "out.png", "--report", "locked/r.json"],
            "cannot write locked/r.json",
        ),
    ];
    for (extra, expected) in cases {
        let args: Vec<&str> = render.iter().chain(extra).copied().collect();
        let Some(mut command) = unprivileged(dir.path(), None, &args) else {
            eprintln!("skipped: no setpriv here to drop root");
            return;
        };
        let out = command.output().unwrap();
        assert_refused(&out, &[expected, "cannot create a file in locked"]);
        // Refused before the render: no summary line.
        assert!(!stderr(&out).contains("spp"), "{}", stderr(&out));
        assert_eq!(std::fs::read(&image).unwrap(), b"an earlier image");
        assert_eq!(names(dir.path()), ["locked", "out.png"]);
        assert!(names(&locked).is_empty());
    }
}

/// The image and the report are committed together: a report whose write fails (past
/// a file-size limit, after the image was written) leaves the earlier image as it was
/// and no temporary file.
#[test]
fn a_report_that_fails_leaves_the_image_as_it_was() {
    if !has_tool("prlimit") {
        eprintln!("skipped: no prlimit here");
        return;
    }
    let dir = TempDir::new().unwrap();
    std::fs::write(dir.path().join("out.ppm"), b"an earlier image").unwrap();
    // The 8x5 PPM has under 200 bytes, the report over 300.
    let out = Command::new("prlimit")
        .args(["--fsize=300", BIN, "spheres", "--width", "8", "--spp", "1"])
        .args(["-o", "out.ppm", "--report", "r.json"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_refused(&out, &["cannot write r.json", "File too large"]);
    assert_eq!(
        std::fs::read(dir.path().join("out.ppm")).unwrap(),
        b"an earlier image"
    );
    assert_eq!(names(dir.path()), ["out.ppm"]);
}
