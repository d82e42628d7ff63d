//! A signal during a write: SIGINT and SIGTERM remove the temporary files
//! (`output::install_signal_cleanup`) and the process ends by the signal; SIGKILL leaves
//! them, and `output::remove_stale_temporaries` removes them once the process is gone.
//!
//! The child is this test binary again, running `signal_child` (ignored in a normal run)
//! with the directory in an environment variable.
#![cfg(unix)]

use raytracer::output::{self, OutputSet};
use std::io::Write;
use std::os::unix::process::ExitStatusExt;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

const DIR_VAR: &str = "RAYTRACER_SIGNAL_TEST_DIR";

/// The child: start a two-file output set, say so, and wait (for the signal).
#[test]
#[ignore = "run by the signal tests as their child process"]
fn signal_child() {
    let dir = std::path::PathBuf::from(std::env::var(DIR_VAR).expect("run by a signal test"));
    output::install_signal_cleanup().unwrap();
    let mut set = OutputSet::default();
    set.add(&dir.join("image.ppm"), |out| out.write_all(&[7; 4096]))
        .unwrap();
    set.add(&dir.join("report.json"), |out| {
        out.write_all(b"{")?;
        out.flush()?;
        std::fs::write(dir.join("ready"), b"")?;
        loop {
            std::thread::sleep(Duration::from_secs(1));
        }
    })
    .unwrap();
}

/// Names in `dir` other than `ready`, sorted.
fn left_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != "ready")
        .collect();
    v.sort();
    v
}

/// Run the child, send `signal` once it is writing, and return its status and what it
/// left in its directory.
fn interrupt(signal: &str) -> (std::process::ExitStatus, Vec<String>, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let mut child = Command::new(std::env::current_exe().unwrap())
        .args([
            "signal_child",
            "--exact",
            "--ignored",
            "--nocapture",
            "--test-threads",
            "1",
        ])
        .env(DIR_VAR, dir.path())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while !dir.path().join("ready").exists() {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the child never got ready"
        );
        if let Some(status) = child.try_wait().unwrap() {
            panic!("the child ended early: {status}");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    // Both temporary files exist now: the image's, complete, and the report's, open.
    assert_eq!(left_in(dir.path()).len(), 2, "{:?}", left_in(dir.path()));
    let sent = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    let status = child.wait().unwrap();
    let left = left_in(dir.path());
    (status, left, dir)
}

#[test]
fn sigint_and_sigterm_remove_the_temporary_files() {
    for (name, number) in [("-INT", 2), ("-TERM", 15)] {
        let (status, left, _dir) = interrupt(name);
        assert_eq!(status.signal(), Some(number), "{status}");
        assert!(left.is_empty(), "left behind after {name}: {left:?}");
    }
}

#[test]
fn sigkill_leaves_temporaries_that_a_later_run_removes() {
    let (status, left, dir) = interrupt("-KILL");
    assert_eq!(status.signal(), Some(9));
    assert_eq!(left.len(), 2, "{left:?}");
    assert!(left
        .iter()
        .all(|n| n.starts_with(".raytracer-") && n.ends_with(".tmp")));
    let removed = output::remove_stale_temporaries(dir.path());
    assert_eq!(removed.len(), 2);
    assert!(left_in(dir.path()).is_empty());
}
