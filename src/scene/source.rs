//! Where a scene's text comes from (`SceneSource`: a file, or a built-in scene by name)
//! and its parse, with errors that name the file, line and column.

use super::desc::SceneDesc;
use super::input::ReadError;
use super::{builtin, input};
use crate::error::{Error, Result};
use std::borrow::Cow;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Where a scene file came from.
#[derive(Clone, Debug)]
pub struct SceneSource {
    /// The name users see in messages: a path, or `NAME (built-in)`.
    pub display: String,
    /// The scene's name (file stem), used for the default output file.
    pub name: String,
    pub text: Cow<'static, str>,
    /// Directory that relative mesh paths start from; `None` for a built-in scene,
    /// whose meshes are embedded.
    pub dir: Option<PathBuf>,
}

impl SceneSource {
    /// A built-in scene name, or a path to a `.toml` file: a name without `.toml`, `/` or
    /// `\\` is a built-in scene unless no built-in scene has it and a file does.
    pub fn resolve(arg: &str) -> Result<Self> {
        let path = Path::new(arg);
        let looks_like_path = arg.ends_with(".toml") || arg.contains('/') || arg.contains('\\');
        if !looks_like_path && (builtin::scene(arg).is_some() || !path.is_file()) {
            return Self::builtin(arg);
        }
        Self::read(path)
    }

    /// A built-in scene, or `UnknownScene` naming the built-in ones.
    pub fn builtin(name: &str) -> Result<Self> {
        let text = builtin::scene(name).ok_or_else(|| Error::UnknownScene {
            name: name.to_string(),
            available: builtin::names().join(", "),
        })?;
        Ok(Self {
            display: format!("{name} (built-in scenes/{name}.toml)"),
            name: name.to_string(),
            text: Cow::Borrowed(text),
            dir: None,
        })
    }

    /// A scene file; relative mesh paths start from its directory. The file must be a
    /// regular file under the scene size limit, in UTF-8.
    pub fn read(path: &Path) -> Result<Self> {
        let display = path.display().to_string();
        let text =
            input::read_text(path, input::MAX_SCENE_BYTES, "scene file").map_err(|e| match e {
                ReadError::Io(source) => Error::Io {
                    path: display.clone(),
                    source,
                },
                ReadError::Utf8 { line, column, byte } => Error::Scene {
                    path: display.clone(),
                    line,
                    column,
                    message: ReadError::utf8_message(byte),
                },
            })?;
        Ok(Self {
            display,
            name: path
                .file_stem()
                .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned()),
            text: Cow::Owned(text),
            dir: Some(path.parent().unwrap_or(Path::new(".")).to_path_buf()),
        })
    }

    /// Scene text named `scene`; relative mesh paths start from `dir`.
    pub fn from_text(text: &str, dir: &Path) -> Self {
        Self {
            display: "scene".to_string(),
            name: "scene".to_string(),
            text: Cow::Owned(text.to_string()),
            dir: Some(dir.to_path_buf()),
        }
    }

    /// Parse the TOML into a description; syntax errors and unknown keys name line and
    /// column. A file that sets nothing (empty, blank or only comments) is an error: it
    /// is more likely a wrong or truncated file than a wish for a black image.
    pub fn parse(&self) -> Result<SceneDesc> {
        let desc: SceneDesc = toml::from_str(&self.text).map_err(|e| {
            let (line, column) = e.span().map_or((0, 0), |s| {
                let at = unknown_key_offset(&self.text, e.message(), s.clone());
                line_col(&self.text, at.unwrap_or(s.start))
            });
            // toml's syntax messages span several lines ("invalid table header\nexpected ..").
            let message: Vec<&str> = e
                .message()
                .lines()
                .map(str::trim)
                .filter(|l| !l.is_empty())
                .collect();
            Error::Scene {
                path: self.display.clone(),
                line,
                column,
                message: message.join(", "),
            }
        })?;
        if desc.sets_nothing() {
            return Err(self.error_at(
                0,
                "the scene file is empty: it sets no camera, materials or objects",
            ));
        }
        Ok(desc)
    }

    /// The offset of the line inside `span` (a table) that sets `key`, or the table's
    /// start: where an error about the key's value points.
    pub(super) fn key_at(&self, span: Range<usize>, key: &str) -> usize {
        key_offset(&self.text, key, span.clone()).unwrap_or(span.start)
    }

    pub(super) fn error_at(&self, offset: usize, message: impl Into<String>) -> Error {
        let (line, column) = line_col(&self.text, offset);
        Error::Scene {
            path: self.display.clone(),
            line,
            column,
            message: message.into(),
        }
    }
}

/// serde reads a material or object table (internally tagged) as a whole, so toml puts an
/// unknown key at the table's header; this finds the line inside `span` that sets the key.
fn unknown_key_offset(text: &str, message: &str, span: Range<usize>) -> Option<usize> {
    let key = message.strip_prefix("unknown field `")?.split('`').next()?;
    key_offset(text, key, span)
}

/// Where the line inside `span` that sets `key` starts (after its indent).
fn key_offset(text: &str, key: &str, span: Range<usize>) -> Option<usize> {
    let mut offset = span.start;
    for line in text.get(span)?.split_inclusive('\n') {
        let t = line.trim_start();
        let sets_key = t
            .strip_prefix(key)
            .is_some_and(|rest| rest.trim_start().starts_with('='));
        if sets_key {
            return Some(offset + line.len() - t.len());
        }
        offset += line.len();
    }
    None
}

/// 1-based line and column of a byte offset.
fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
    (line, column)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_and_column() {
        assert_eq!(line_col("ab\ncd\nef", 0), (1, 1));
        assert_eq!(line_col("ab\ncd\nef", 4), (2, 2));
        assert_eq!(line_col("ab\ncd\nef", 6), (3, 1));
    }
}
