//! The film: what a render computes, linear RGB per pixel, and its ways out (8-bit bytes
//! or an image file).

use crate::error::{Error, Result};
use glam::Vec3;
use std::path::Path;

/// A rendered image: linear RGB (no gamma, no clamp), one [`Vec3`] per pixel, rows from
/// the top. Each pixel is the mean of its samples, summed in sample order, so the film is
/// the same bits for any thread count and packet width.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height` pixels, row by row from the top-left corner.
    pub pixels: Vec<Vec3>,
}

impl Film {
    /// A black film, or [`Error::ImageTooLarge`] if the memory cannot be had.
    pub fn new(width: u32, height: u32) -> Result<Self> {
        let n = width as usize * height as usize;
        let mut pixels = Vec::new();
        pixels
            .try_reserve_exact(n)
            .map_err(|_| Error::ImageTooLarge {
                width,
                height,
                bytes: n as u128 * std::mem::size_of::<Vec3>() as u128,
            })?;
        pixels.resize(n, Vec3::ZERO);
        Ok(Self {
            width,
            height,
            pixels,
        })
    }

    /// The pixel at column `x`, row `y` (from the top). Panics outside the film.
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) is outside the film"
        );
        self.pixels[(y * self.width + x) as usize]
    }

    /// Pixels with a NaN or infinite channel.
    pub fn non_finite_count(&self) -> usize {
        self.pixels.iter().filter(|p| !p.is_finite()).count()
    }

    /// 8-bit RGB bytes, row by row, as PNG and PPM files hold them: each channel clamped
    /// to [0, 1] (NaN as 0), gamma 2 (its square root), then truncated, as the original
    /// program wrote them.
    pub fn to_rgb8(&self) -> Vec<u8> {
        crate::output::to_bytes(self)
    }

    /// Write the film to `path`: `.png` or `.ppm` (8-bit, [`Film::to_rgb8`]) or `.exr`
    /// (linear f32, bit for bit), chosen by the extension. The file is written to a
    /// temporary file beside it and renamed into place, so a failure never leaves a
    /// partial file or clobbers an existing one.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<()> {
        crate::output::write_image(self, path.as_ref())
    }
}
