//! Reading scene and mesh files: regular files only, no larger than a limit, both
//! checked before a byte is read (a path like `/dev/zero` or a FIFO would otherwise be
//! read until memory runs out, or block); UTF-8, with the line and column of the first
//! byte that is not.

use std::fs::File;
use std::io::Read;
use std::path::Path;

/// The largest scene file read: 64 MiB (about 300 000 objects); the built-in scenes
/// are 1–3 KiB.
pub const MAX_SCENE_BYTES: u64 = 64 << 20;

/// The largest OBJ file read: 2 GiB, about 30 million triangles. (Its triangles must
/// also fit the memory budget.)
pub const MAX_MESH_BYTES: u64 = 2 << 30;

#[derive(Debug)]
pub enum ReadError {
    /// Cannot open or read, not a regular file, or too large (the reason in the error).
    Io(std::io::Error),
    /// Not UTF-8 at this 1-based line and column (in characters); `byte` is the first
    /// offending byte.
    Utf8 {
        line: usize,
        column: usize,
        byte: u8,
    },
}

impl From<std::io::Error> for ReadError {
    fn from(e: std::io::Error) -> Self {
        ReadError::Io(e)
    }
}

impl ReadError {
    /// The message of a UTF-8 error (without its place).
    pub fn utf8_message(byte: u8) -> String {
        format!("invalid UTF-8 (byte 0x{byte:02X}): the file must be UTF-8 text")
    }
}

/// The size of `path` if it is a regular file of at most `limit` bytes; `what` names
/// the kind of file in the message ("scene file", "mesh").
pub fn check_file(path: &Path, limit: u64, what: &str) -> std::io::Result<u64> {
    let meta = std::fs::metadata(path)?;
    check_metadata(&meta, limit, what)
}

fn check_metadata(meta: &std::fs::Metadata, limit: u64, what: &str) -> std::io::Result<u64> {
    if !meta.is_file() {
        return Err(std::io::Error::other(format!(
            "not a regular file ({}): a {what} must be a file",
            file_kind(meta)
        )));
    }
    if meta.len() > limit {
        return Err(too_large(meta.len(), limit, what));
    }
    Ok(meta.len())
}

fn too_large(bytes: u64, limit: u64, what: &str) -> std::io::Error {
    std::io::Error::other(format!(
        "{bytes} bytes is larger than the {what} limit of {limit} bytes ({} MiB)",
        limit >> 20
    ))
}

fn file_kind(meta: &std::fs::Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if meta.is_dir() {
        "a directory"
    } else {
        "not a plain file"
    }
}

/// Read `path` as UTF-8 text, if it is a regular file of at most `limit` bytes. The
/// type and size are checked before opening (opening a FIFO blocks) and again on the
/// open file, and at most `limit` bytes are read whatever the file does meanwhile.
pub fn read_text(path: &Path, limit: u64, what: &str) -> Result<String, ReadError> {
    check_file(path, limit, what)?;
    let file = File::open(path)?;
    let size = check_metadata(&file.metadata()?, limit, what)?;
    let mut bytes = Vec::new();
    bytes.try_reserve_exact(size as usize).map_err(|_| {
        std::io::Error::new(
            std::io::ErrorKind::OutOfMemory,
            format!("cannot allocate {size} bytes to read it"),
        )
    })?;
    file.take(limit + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(too_large(bytes.len() as u64, limit, what).into());
    }
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        let (line, column) = utf8_place(bytes, at);
        ReadError::Utf8 {
            line,
            column,
            byte: bytes[at],
        }
    })
}

/// 1-based line and column (in characters) of byte `at`, everything before it being
/// valid UTF-8.
fn utf8_place(bytes: &[u8], at: usize) -> (usize, usize) {
    let before = &bytes[..at];
    let line_start = before
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |i| i + 1);
    let line = 1 + before.iter().filter(|&&b| b == b'\n').count();
    let column = 1 + std::str::from_utf8(&before[line_start..]).map_or(0, |s| s.chars().count());
    (line, column)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utf8_errors_name_line_and_column_in_characters() {
        assert_eq!(utf8_place(b"ab\ncd", 4), (2, 2));
        // "é" is two bytes and one column: the byte after it is in column 2.
        assert_eq!(utf8_place("x\n\u{e9}z".as_bytes(), 4), (2, 2));
        assert_eq!(utf8_place(b"", 0), (1, 1));
    }

    #[test]
    fn refuses_devices_directories_and_large_files() {
        let dir = tempfile::tempdir().unwrap();
        let e = read_text(dir.path(), 100, "scene file").unwrap_err();
        assert!(
            matches!(&e, ReadError::Io(e) if e.to_string().contains("directory")),
            "{e:?}"
        );
        #[cfg(unix)]
        {
            let e = read_text(Path::new("/dev/zero"), 100, "scene file").unwrap_err();
            let ReadError::Io(e) = e else { panic!("{e:?}") };
            assert!(e.to_string().contains("character device"), "{e}");
        }
        let path = dir.path().join("big.toml");
        std::fs::write(&path, [b'#'; 101]).unwrap();
        let ReadError::Io(e) = read_text(&path, 100, "scene file").unwrap_err() else {
            panic!()
        };
        assert!(e.to_string().contains("101 bytes"), "{e}");
        assert_eq!(read_text(&path, 101, "scene file").unwrap().len(), 101);
        std::fs::write(&path, b"a = 1\nb = \"\xff\"\n").unwrap();
        match read_text(&path, 100, "scene file").unwrap_err() {
            ReadError::Utf8 { line, column, byte } => {
                assert_eq!((line, column, byte), (2, 6, 0xff))
            }
            e => panic!("{e:?}"),
        }
    }
}
