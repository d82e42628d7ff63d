//! Writing images: PNG (8-bit) or binary PPM (P6), chosen by the file extension.
//!
//! Every file is written to a temporary file in the target directory and renamed into
//! place, so a failed or interrupted run never leaves a half-written or clobbered file.

use crate::error::{Error, Result};
use crate::render::Film;
use std::io::Write;
use std::path::Path;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    Png,
    Ppm,
}

impl ImageFormat {
    /// The format for a path's extension; checked before rendering starts.
    pub fn for_path(path: &Path) -> Result<Self> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("png") => Ok(ImageFormat::Png),
            Some("ppm") => Ok(ImageFormat::Ppm),
            _ => Err(Error::Output {
                path: path.to_path_buf(),
                message: "unsupported image format (use .png or .ppm)".into(),
            }),
        }
    }
}

/// Gamma 2 (square root) and truncation to 8 bits, as the seed; values are clamped to
/// [0, 1] first (the seed wrote values above 1 past the PPM maximum) and NaN becomes 0.
#[inline]
pub fn quantize(c: f32) -> u8 {
    let c = if c > 0.0 { c.min(1.0) } else { 0.0 };
    (255.999 * c.sqrt()) as u8
}

/// 8-bit sRGB-ish bytes (gamma 2), row-major RGB.
pub fn to_bytes(film: &Film) -> Vec<u8> {
    film.pixels
        .iter()
        .flat_map(|p| [quantize(p.x), quantize(p.y), quantize(p.z)])
        .collect()
}

/// Write the film to `path` (format by extension), atomically.
pub fn write_image(film: &Film, path: &Path) -> Result<()> {
    let format = ImageFormat::for_path(path)?;
    let bytes = to_bytes(film);
    write_atomically(path, |out| match format {
        ImageFormat::Ppm => {
            write!(out, "P6\n{} {}\n255\n", film.width, film.height)?;
            out.write_all(&bytes)
        }
        ImageFormat::Png => image::write_buffer_with_format(
            out,
            &bytes,
            film.width,
            film.height,
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(std::io::Error::other),
    })
}

/// Check, before a long render, that `path` can be written: a known extension and an
/// existing directory.
pub fn check_writable(path: &Path) -> Result<()> {
    let dir = parent_dir(path);
    if !dir.is_dir() {
        return Err(Error::Output {
            path: path.to_path_buf(),
            message: format!("directory {} does not exist", dir.display()),
        });
    }
    if path.is_dir() {
        return Err(Error::Output {
            path: path.to_path_buf(),
            message: "is a directory".into(),
        });
    }
    Ok(())
}

fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Write through a temporary file in the same directory, then rename over `path`.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut std::io::BufWriter<&std::fs::File>) -> std::io::Result<()>,
) -> Result<()> {
    let fail = |e: std::io::Error| Error::Output {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let tmp = tempfile::Builder::new()
        .prefix(".raytracer-")
        .suffix(".tmp")
        .tempfile_in(parent_dir(path))
        .map_err(fail)?;
    // tempfile creates 0600; give the result the permissions of the file it replaces, or
    // the usual 0644 for a new file.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let permissions = std::fs::metadata(path)
            .map(|m| m.permissions())
            .unwrap_or_else(|_| std::fs::Permissions::from_mode(0o644));
        tmp.as_file().set_permissions(permissions).map_err(fail)?;
    }
    {
        let mut out = std::io::BufWriter::new(tmp.as_file());
        write(&mut out).map_err(fail)?;
        out.flush().map_err(fail)?;
    }
    tmp.persist(path).map_err(|e| fail(e.error))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantize_clamps_and_takes_the_square_root() {
        assert_eq!(quantize(0.0), 0);
        assert_eq!(quantize(-1.0), 0);
        assert_eq!(quantize(f32::NAN), 0);
        assert_eq!(quantize(1.0), 255);
        assert_eq!(quantize(4.0), 255);
        assert_eq!(quantize(0.25), 127); // 255.999 · 0.5 = 127.99 → 127
        assert_eq!(quantize(0.01), 25); // 255.999 · 0.1 = 25.6 → 25
    }
}
