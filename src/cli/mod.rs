//! The command line, in the binary only (the library knows nothing of it): `args` (clap's
//! flags) → `options` (validated, defaults filled in) → `render`, `merge`, `sweep` or `view`
//! (the run), with the `report` (JSON) and `stats` printers apart; a render's record, which
//! both print, is `run`, and the sweep's chart is drawn by `chart`.
//!
//! Messages on stderr (notes, warnings, statistics, the summary line, errors) are best
//! effort: a closed or full stderr never fails a run whose files are written. What a
//! command prints on stdout (`--list`, a sweep's summary, the image of `-o -`, the report
//! of `--report -`) is its product: a failure to write it is an error, but for a reader
//! that went away (a broken pipe), which ends the run as a success, as `head` expects.

/// `eprintln!` that ignores a failure to write (see the module's documentation).
macro_rules! to_stderr {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

pub mod args;
pub mod chart;
pub mod merge;
pub mod options;
pub mod render;
pub mod report;
pub mod run;
pub mod stats;
pub mod sweep;
pub mod sweep_summary;
pub mod view;

use anyhow::Context;
use raytracer::output::ImageFormat;
use raytracer::SceneFile;
use std::io::Write;
use std::path::Path;

/// The worker threads of every command (rayon's global pool is never used), and their
/// number: `threads`, or all cores. Where the system refuses threads (a process limit),
/// a run without `--threads` falls back to fewer (images do not depend on the thread
/// count) and says so; a run with `--threads`, or one that gets no thread at all, is an
/// error, before any work.
pub fn thread_pool(threads: Option<u32>) -> anyhow::Result<(rayon::ThreadPool, usize)> {
    let build = |n: usize| rayon::ThreadPoolBuilder::new().num_threads(n).build();
    if let Some(n) = threads {
        let n = n as usize;
        // rayon's error already ends with the system's reason.
        let pool = build(n)
            .map_err(|e| anyhow::anyhow!("cannot start {n} worker threads (--threads): {e}"))?;
        return Ok((pool, n));
    }
    let all = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut n = all;
    let mut attempt = 0;
    loop {
        match build(n) {
            Ok(pool) => {
                if n < all {
                    to_stderr!("note: the system refused {all} worker threads: running on {n}");
                }
                return Ok((pool, n));
            }
            Err(_) if n > 1 => n /= 2,
            // The threads of a refused pool end on their own, and count until they do.
            Err(_) if attempt < 4 => {
                std::thread::sleep(std::time::Duration::from_millis(10 << attempt));
                attempt += 1;
            }
            Err(e) => anyhow::bail!("cannot start a worker thread: {e}"),
        }
    }
}

/// Standard output was closed by its reader (a broken pipe): the run ends with exit code
/// 0 and no message.
#[derive(Debug, thiserror::Error)]
#[error("standard output was closed")]
pub struct StdoutClosed;

/// Write `text` to standard output: a broken pipe is `StdoutClosed`, any other failure
/// (a full disk, `> /dev/full`) an error.
pub fn print_stdout(text: &str) -> anyhow::Result<()> {
    write_stdout(|out| out.write_all(text.as_bytes()))
}

/// Write an image to standard output (`-o -`), as `print_stdout` writes text.
pub fn image_to_stdout(film: &raytracer::Film, format: ImageFormat) -> anyhow::Result<()> {
    write_stdout(|out| raytracer::output::encode_to_stream(film, format, out))
}

/// Run `write` on standard output, buffered, and flush it: a broken pipe is
/// `StdoutClosed`, any other failure an error.
fn write_stdout(
    write: impl FnOnce(&mut std::io::BufWriter<std::io::StdoutLock>) -> std::io::Result<()>,
) -> anyhow::Result<()> {
    let mut out = std::io::BufWriter::with_capacity(1 << 16, std::io::stdout().lock());
    match write(&mut out).and_then(|()| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Err(StdoutClosed.into()),
        Err(e) => Err(anyhow::Error::new(e).context("cannot write to standard output")),
    }
}

/// How a message names an output: its path, or standard output for `-`.
pub fn output_name(path: &Path) -> String {
    if options::is_stdout(path) {
        "standard output".into()
    } else {
        path.display().to_string()
    }
}

/// `--list`: every built-in scene with its description.
pub fn list() -> anyhow::Result<()> {
    let mut text = String::new();
    for name in SceneFile::builtin_names() {
        let description = SceneFile::builtin(name)?.description().to_string();
        text += &format!("{name:<22} {description}\n");
    }
    print_stdout(&text)
}

/// The scene argument: a built-in scene name, or a path to a scene file. An argument
/// without `.toml`, `/` or `\` is a built-in name, unless no built-in scene has it and a
/// file does.
pub fn scene_file(arg: &str) -> raytracer::Result<SceneFile> {
    match scene_path(arg) {
        None => SceneFile::builtin(arg),
        Some(path) => SceneFile::from_path(path),
    }
}

/// The scene argument's file, or `None` for a built-in scene name (`scene_file`).
pub fn scene_path(arg: &str) -> Option<&Path> {
    let looks_like_path = arg.ends_with(".toml") || arg.contains('/') || arg.contains('\\');
    let is_builtin = SceneFile::builtin_names().contains(&arg);
    let builtin = !looks_like_path && (is_builtin || !Path::new(arg).is_file());
    (!builtin).then_some(Path::new(arg))
}

/// The default output name: the scene name, or a scene file's stem.
pub fn scene_stem(arg: &str) -> String {
    Path::new(arg)
        .file_stem()
        .map_or_else(|| "render".into(), |s| s.to_string_lossy().into_owned())
}

/// Make the directory of a default output path (under `target/`).
pub fn create_parent(path: &Path) -> anyhow::Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create directory {}", dir.display()))?;
    }
    Ok(())
}

/// A library error for the command line: a refusal by the `--max-memory` cap names the
/// flag.
pub fn name_the_memory_cap(e: raytracer::Error) -> anyhow::Error {
    match e {
        raytracer::Error::OutOfMemory {
            limited_by: raytracer::budget::Limit::Cap,
            ..
        } => anyhow::Error::new(e).context("--max-memory"),
        e => e.into(),
    }
}
