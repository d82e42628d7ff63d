//! The pinhole camera of the seed (`docs/seed-semantics.md`, "Camera").
//!
//! Scene keys (`[camera]`): `width`, `aspect_ratio`, `samples_per_pixel`, `max_depth`,
//! `vfov`, `look_from`, `look_at`, `up`. The set-up is computed in f64, as the seed did,
//! and stored as f32 for the tracers.

use crate::geometry::Ray;
use crate::lanes::{Lane, V3};
use glam::{DVec3, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub width: u32,
    pub height: u32,
    pub origin: Vec3,
    /// Upper-left corner of the viewport (a corner, not a pixel centre).
    pub corner: Vec3,
    /// One pixel step to the right (+u) and one down (−v).
    pub pixel_du: Vec3,
    pub pixel_dv: Vec3,
}

impl Camera {
    /// `None` if the basis is degenerate (look-from = look-at, or up parallel to the view).
    pub fn new(
        width: u32,
        height: u32,
        vfov_degrees: f64,
        look_from: DVec3,
        look_at: DVec3,
        up: DVec3,
    ) -> Option<Self> {
        let h = (vfov_degrees.to_radians() / 2.0).tan();
        let viewport_height = 2.0 * h; // focus distance 1
        let viewport_width = viewport_height * (width as f64 / height as f64);
        let w = (look_from - look_at).try_normalize()?;
        let u = up.cross(w).try_normalize()?;
        let v = w.cross(u);
        let corner = look_from - w - u * (viewport_width / 2.0) + v * (viewport_height / 2.0);
        Some(Self {
            width,
            height,
            origin: look_from.as_vec3(),
            corner: corner.as_vec3(),
            pixel_du: (u * (viewport_width / width as f64)).as_vec3(),
            pixel_dv: (-v * (viewport_height / height as f64)).as_vec3(),
        })
    }

    /// The ray through the point (x + jx, y + jy) of the pixel grid, jx and jy in [0, 1).
    #[inline]
    pub fn ray(&self, x: u32, y: u32, jx: f32, jy: f32) -> Ray {
        let p = self.corner + self.pixel_du * (x as f32 + jx) + self.pixel_dv * (y as f32 + jy);
        Ray::new(self.origin, (p - self.origin).normalize())
    }
}

impl Camera {
    /// `ray` for lanes of pixels: the unit directions (the origin is `self.origin`), the
    /// same operations lane by lane (glam's `normalize` is `v · (1 / √(v·v))`).
    #[inline]
    pub fn directions<L: Lane>(&self, x: L, y: L, jx: L, jy: L) -> V3<L> {
        let (sx, sy) = (x + jx, y + jy);
        let p = V3::splat(self.corner) + V3::splat(self.pixel_du).scale(sx);
        let p = p + V3::splat(self.pixel_dv).scale(sy);
        let v = p - V3::splat(self.origin);
        v.scale(L::splat(1.0) / v.dot(v).sqrt())
    }
}

/// Image height from width and aspect ratio: `trunc(width / aspect)`, at least 1 (the
/// seed's rule: 800 at 16:9 gives 450).
pub fn image_height(width: u32, aspect: f64) -> u32 {
    ((width as f64 / aspect) as u32).max(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cornell_basis_puts_x555_on_the_left() {
        let cam = Camera::new(
            400,
            400,
            40.0,
            DVec3::new(278.0, 278.0, -800.0),
            DVec3::new(278.0, 278.0, 0.0),
            DVec3::Y,
        )
        .unwrap();
        // Screen-right is −x for this camera.
        assert!(cam.pixel_du.x < 0.0 && cam.pixel_dv.y < 0.0);
        // The centre of the image looks straight down +z.
        let r = cam.ray(200, 200, 0.0, 0.0);
        assert!((r.dir - Vec3::Z).length() < 1e-6, "{:?}", r.dir);
    }

    #[test]
    fn heights() {
        assert_eq!(image_height(800, 16.0 / 9.0), 450);
        assert_eq!(image_height(400, 16.0 / 9.0), 225);
        assert_eq!(image_height(1, 16.0 / 9.0), 1);
    }

    #[test]
    fn degenerate_basis_is_rejected() {
        assert!(Camera::new(10, 10, 90.0, DVec3::ZERO, DVec3::ZERO, DVec3::Y).is_none());
        assert!(Camera::new(10, 10, 90.0, DVec3::ZERO, DVec3::Y, DVec3::Y).is_none());
    }
}
