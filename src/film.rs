//! The film: what a render computes, linear RGB per pixel. Its ways out, 8-bit bytes
//! ([`Film::to_rgb8`]) and image files ([`Film::write`]), are defined in `output`, which
//! owns the file formats and is written over the film.

use crate::error::{Error, Result};
use glam::Vec3;

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
        let pixels = zeroed_pixels(n).map_err(|_| Error::ImageTooLarge {
            width,
            height,
            bytes: n as u128 * std::mem::size_of::<Vec3>() as u128,
        })?;
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
}

/// `n` black pixels, allocated zeroed: the pages are mapped zero by the system where they
/// are first written, by the tiles that render them in parallel. Zeroed by `resize`, the
/// whole image was written on one thread before the render began (a 7.7 MB memset and
/// its page faults, 4–5 ms of `cornell-point-light`'s two-thread render).
pub(crate) fn zeroed_pixels(n: usize) -> std::result::Result<Vec<Vec3>, ()> {
    bytemuck::allocation::try_zeroed_vec(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A new film is black to the bit (+0 in every channel), at any size, and a size
    /// past what memory can hold is an error, not an abort.
    #[test]
    fn a_new_film_is_black() {
        for (w, h) in [(1, 1), (3, 2), (1024, 768)] {
            let film = Film::new(w, h).unwrap();
            assert_eq!(film.pixels.len(), (w * h) as usize);
            assert!(film
                .pixels
                .iter()
                .all(|p| p.to_array().map(f32::to_bits) == [0; 3]));
        }
        assert!(matches!(
            Film::new(u32::MAX, u32::MAX),
            Err(Error::ImageTooLarge { .. })
        ));
    }
}
