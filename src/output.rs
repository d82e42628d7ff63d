//! Writing images: PNG (8-bit), binary PPM (P6) or OpenEXR (linear f32 RGB, the film's
//! values bit for bit), chosen by the file extension.
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
    /// OpenEXR, linear f32 RGB: no gamma, no clamp, no quantisation.
    Exr,
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
            Some("exr") => Ok(ImageFormat::Exr),
            _ => Err(Error::Output {
                path: path.to_path_buf(),
                message: "unsupported image format (use .png or .ppm, or .exr for linear f32)"
                    .into(),
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
    if format == ImageFormat::Exr {
        return write_exr(film, path);
    }
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
        ImageFormat::Exr => unreachable!("written by write_exr"),
    })
}

/// Write the film as OpenEXR with three f32 channels (linear RGB), atomically.
pub fn write_exr(film: &Film, path: &Path) -> Result<()> {
    let floats: Vec<f32> = film.pixels.iter().flat_map(|p| p.to_array()).collect();
    write_atomically(path, |out| {
        image::write_buffer_with_format(
            out,
            bytemuck::cast_slice(&floats),
            film.width,
            film.height,
            image::ExtendedColorType::Rgb32F,
            image::ImageFormat::OpenExr,
        )
        .map_err(std::io::Error::other)
    })
}

/// Read an OpenEXR image (any channel layout `image` can decode) into a film of linear
/// RGB; f32 channels come back bit for bit.
pub fn read_exr(path: &Path) -> Result<Film> {
    let fail = |message: String| Error::Output {
        path: path.to_path_buf(),
        message,
    };
    let reader = image::ImageReader::open(path)
        .map_err(|e| fail(e.to_string()))?
        .with_guessed_format()
        .map_err(|e| fail(e.to_string()))?;
    if reader.format() != Some(image::ImageFormat::OpenExr) {
        return Err(fail("not an OpenEXR file".into()));
    }
    let rgb = reader
        .decode()
        .map_err(|e| fail(e.to_string()))?
        .into_rgb32f();
    let (width, height) = rgb.dimensions();
    let pixels = rgb.pixels().map(|p| glam::Vec3::from_array(p.0)).collect();
    Ok(Film {
        width,
        height,
        pixels,
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

    #[test]
    fn exr_round_trip_is_bit_exact() {
        // Values a PNG would clamp or round away: above 1, tiny, negative zero, subnormal,
        // many mantissa bits, and a non-square size.
        let (width, height) = (5, 3);
        let values = [
            0.0,
            -0.0,
            1.0,
            17.25,
            1e-30,
            f32::MIN_POSITIVE / 4.0,
            0.1,
            std::f32::consts::PI,
            65504.5,
            1.0e10,
        ];
        let pixels = (0..width * height)
            .map(|i| {
                let v = |k: u32| values[((3 * i + k) as usize * 7) % values.len()];
                glam::Vec3::new(v(0), v(1) * 1.000_001, v(2) + i as f32 * 1e-3)
            })
            .collect();
        let film = Film {
            width,
            height,
            pixels,
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("film.exr");
        write_image(&film, &path).unwrap();
        let back = read_exr(&path).unwrap();
        assert_eq!((back.width, back.height), (width, height));
        let bits = |f: &Film| -> Vec<u32> {
            f.pixels
                .iter()
                .flat_map(|p| p.to_array().map(f32::to_bits))
                .collect()
        };
        assert_eq!(bits(&back), bits(&film));
        // Only the image is left in the directory (the temporary file was renamed).
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
