//! The command line, in the binary only (the library knows nothing of it): `args` (clap's
//! flags) → `options` (validated, defaults filled in) → `render` or `sweep` (the run),
//! with the `report` (JSON) and `stats` printers apart.

pub mod args;
pub mod options;
pub mod render;
pub mod report;
pub mod stats;
pub mod sweep;

use anyhow::Context;
use raytracer::scene::{builtin, SceneSource};
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
    for name in builtin::names() {
        let desc = SceneSource::resolve(name)?.parse()?;
        println!("{name:<22} {}", desc.description);
    }
    Ok(())
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
