//! The command line, in the binary only (the library knows nothing of it): `args` (clap's
//! flags) → `options` (validated, defaults filled in) → `render`, `merge` or `sweep` (the
//! run), with the `report` (JSON) and `stats` printers apart.

pub mod args;
pub mod merge;
pub mod options;
pub mod render;
pub mod report;
pub mod stats;
pub mod sweep;

use anyhow::Context;
use raytracer::SceneFile;
use std::path::Path;

/// The worker threads of every command (rayon's global pool is never used), and their
/// number: `threads`, or all cores.
pub fn thread_pool(threads: Option<u32>) -> anyhow::Result<(rayon::ThreadPool, usize)> {
    let threads = threads.map_or_else(
        || std::thread::available_parallelism().map_or(1, |n| n.get()),
        |t| t as usize,
    );
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start the worker threads")?;
    Ok((pool, threads))
}

/// `--list`: every built-in scene with its description.
pub fn list() -> anyhow::Result<()> {
    for name in SceneFile::builtin_names() {
        println!("{name:<22} {}", SceneFile::builtin(name)?.description());
    }
    Ok(())
}

/// The scene argument: a built-in scene name, or a path to a scene file. An argument
/// without `.toml`, `/` or `\` is a built-in name, unless no built-in scene has it and a
/// file does.
pub fn scene_file(arg: &str) -> raytracer::Result<SceneFile> {
    let looks_like_path = arg.ends_with(".toml") || arg.contains('/') || arg.contains('\\');
    let is_builtin = SceneFile::builtin_names().contains(&arg);
    if !looks_like_path && (is_builtin || !Path::new(arg).is_file()) {
        SceneFile::builtin(arg)
    } else {
        SceneFile::from_path(arg)
    }
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
