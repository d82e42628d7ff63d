//! The library's error type. Every variant names what the user has to fix: the file and
//! line of a scene or OBJ, the setting, or the output path.

use crate::budget::{human, Limit, MemoryEstimate, Refusal};
use std::path::PathBuf;

/// What went wrong, with the file, line and column where there is one. `{}` prints one
/// line; `{:#}` (with `anyhow`) adds the cause of an [`Error::Io`].
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A scene name that is neither built in nor a file.
    #[error("unknown scene '{name}': not a built-in scene and no such file (built-in scenes: {available})")]
    UnknownScene {
        /// The name asked for.
        name: String,
        /// The built-in scenes, comma-separated.
        available: String,
    },

    /// A file that cannot be read. The reason is the source, which `{:#}` prints after
    /// the path.
    #[error("cannot read {path}")]
    Io {
        /// The file.
        path: String,
        /// Why it cannot be read.
        #[source]
        source: std::io::Error,
    },

    /// A scene file problem at a position (TOML syntax, unknown key, invalid value).
    #[error("{path}:{line}:{column}: {message}")]
    Scene {
        /// The scene file (or the built-in scene's name).
        path: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong there.
        message: String,
    },

    /// An OBJ or MTL problem; `line` is 0 when the problem has no single line.
    #[error("{}: {message}", if *line > 0 { format!("{path}:{line}") } else { path.clone() })]
    Obj {
        /// The OBJ or MTL file.
        path: String,
        /// 1-based line, or 0.
        line: usize,
        /// What is wrong there.
        message: String,
    },

    /// An invalid setting.
    #[error("{0}")]
    Options(String),

    /// A packet width other than 1, 4, 8 or 16.
    #[error("packet width must be 1, 4, 8 or 16, got '{0}'")]
    PacketWidth(String),

    /// An image whose film cannot be allocated.
    #[error("cannot allocate a {width}x{height} image ({bytes} bytes)")]
    ImageTooLarge {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
        /// The bytes the film needs.
        bytes: u128,
    },

    /// An image or report that cannot be written (nothing was written).
    #[error("cannot write {path}: {message}")]
    Output {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },

    /// A part file that cannot be used: malformed, truncated, corrupt, or from another
    /// scene, setting or program than the parts it is merged with, or overlapping one.
    #[error("{}: {message}", path.display())]
    Part {
        /// The part file.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },

    /// Part files that together do not make a frame (pixels that no part holds).
    #[error("{0}")]
    Merge(String),

    /// The memory budget refused an estimate before the memory was taken.
    #[error(
        "not enough memory for {what}: it needs about {} (image {}, geometry {}, BVH {}, loading {}), and {}",
        human(estimate.total()),
        human(estimate.image),
        human(estimate.geometry),
        human(estimate.bvh),
        human(estimate.loading),
        limited_by.describe(*limit)
    )]
    OutOfMemory {
        /// What was being made ("the scene", "the image").
        what: String,
        /// The bytes it would take, by part.
        estimate: MemoryEstimate,
        /// The bytes allowed.
        limit: u64,
        /// What sets the limit: the machine's free memory, a cgroup, `ulimit -v`, or a
        /// cap the caller gave.
        limited_by: Limit,
    },
}

impl From<Refusal> for Error {
    fn from(r: Refusal) -> Self {
        Error::OutOfMemory {
            what: r.what,
            estimate: r.estimate,
            limit: r.limit,
            limited_by: r.limited_by,
        }
    }
}

/// `Result` with the library's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// `message` with its control characters escaped (a newline as `\n`, ESC as `\u{1b}`):
/// text that a bad file quotes into an error stays on one line and sends a terminal no
/// command.
pub fn one_line(message: &str) -> String {
    let mut out = String::with_capacity(message.len());
    for c in message.chars() {
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}
