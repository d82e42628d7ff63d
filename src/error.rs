//! The library's error type. Every variant names what the user has to fix: the file and
//! line of a scene or OBJ, the flag, or the output path.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("unknown scene '{name}': not a built-in scene and no such file (built-in scenes: {available})")]
    UnknownScene { name: String, available: String },

    /// The reason is the source, which `{:#}` prints after the path.
    #[error("cannot read {path}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },

    /// A scene file problem at a position (TOML syntax, unknown key, invalid value).
    #[error("{path}:{line}:{column}: {message}")]
    Scene {
        path: String,
        line: usize,
        column: usize,
        message: String,
    },

    /// An OBJ problem; `line` is 0 when the problem has no single line.
    #[error("{}: {message}", if *line > 0 { format!("{path}:{line}") } else { path.clone() })]
    Obj {
        path: String,
        line: usize,
        message: String,
    },

    #[error("{0}")]
    Options(String),

    /// A packet width other than 1, 4 or 8.
    #[error("packet width must be 1, 4 or 8, got '{0}'")]
    PacketWidth(String),

    #[error("cannot allocate a {width}x{height} image ({bytes} bytes)")]
    ImageTooLarge {
        width: u32,
        height: u32,
        bytes: u128,
    },

    #[error("cannot write {path}: {message}")]
    Output { path: PathBuf, message: String },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
