//! The original program's camera: a pinhole, or a thin lens (`docs/seed-semantics.md`,
//! "Camera").
//!
//! Scene keys (`[camera]`): `width`, `aspect_ratio`, `samples_per_pixel`, `max_depth`,
//! `vfov`, `look_from`, `look_at`, `up`, `defocus_angle`, `focus_dist`. The set-up is
//! computed in f64, as the original program did, and stored as f32 for the tracers.
//!
//! The viewport lies `focus_dist` in front of `look_from` and is sized by it. With a
//! `defocus_angle` above zero, each camera sample starts at a uniform point of the lens
//! disk, of radius `focus_dist · tan(defocus_angle / 2)` in the camera's u, v plane, and
//! is aimed at its point of the viewport: points at `focus_dist` are sharp, the others
//! spread over a disk (the circle of confusion). With `defocus_angle = 0` every ray
//! starts at `look_from`, and `focus_dist` only scales the viewport, not the picture.

use crate::geometry::Ray;
use crate::lanes::math::sin_cos_turns;
use crate::lanes::{Lane, V3};
use glam::{DVec3, Vec3};

/// The original program's lens settings: where the viewport lies, and the lens's opening.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lens {
    /// Distance from `look_from` to the plane in focus, which holds the viewport (> 0).
    pub focus_dist: f64,
    /// Angle in degrees of the cone from a point of the focus plane to the lens disk
    /// (0: a pinhole).
    pub defocus_angle: f64,
}

impl Lens {
    /// The original program's default: a pinhole, the viewport one unit away.
    pub const PINHOLE: Lens = Lens {
        focus_dist: 1.0,
        defocus_angle: 0.0,
    };
}

/// Where the camera stands and how it sees: the `[camera]` keys that place it, in the
/// scene file's units (degrees for the angles). [`Renderer::camera_pose`] and
/// [`Renderer::set_camera_pose`] read and move a compiled scene's camera, and
/// [`CameraPose::to_toml`] writes the table back for the scene file.
///
/// [`Renderer::camera_pose`]: crate::Renderer::camera_pose
/// [`Renderer::set_camera_pose`]: crate::Renderer::set_camera_pose
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraPose {
    /// The pinhole, or the lens's centre.
    pub look_from: [f64; 3],
    /// The point the camera looks at.
    pub look_at: [f64; 3],
    /// The direction that is up in the picture (not parallel to the view).
    pub up: [f64; 3],
    /// Vertical field of view in degrees (0 to 180).
    pub vfov: f64,
    /// The lens's opening in degrees (0: a pinhole).
    pub defocus_angle: f64,
    /// Distance of the plane in focus (> 0).
    pub focus_dist: f64,
}

impl CameraPose {
    /// The `[camera]` table of a `width` x `height` image at `spp` samples a pixel and
    /// `max_depth` bounces with this pose: every number written so that it reads back
    /// as the same `f64`, so the scene file renders the same bits.
    pub fn to_toml(&self, width: u32, height: u32, spp: u32, max_depth: u32) -> String {
        fn gcd(a: u32, b: u32) -> u32 {
            if b == 0 {
                a
            } else {
                gcd(b, a % b)
            }
        }
        let g = gcd(width, height).max(1);
        let v = |v: [f64; 3]| format!("[{:?}, {:?}, {:?}]", v[0], v[1], v[2]);
        format!(
            "[camera]\nwidth = {width}\naspect_ratio = \"{}:{}\"\nsamples_per_pixel = {spp}\n\
             max_depth = {max_depth}\nvfov = {:?}\nlook_from = {}\nlook_at = {}\nup = {}\n\
             defocus_angle = {:?}\nfocus_dist = {:?}\n",
            width / g,
            height / g,
            self.vfov,
            v(self.look_from),
            v(self.look_at),
            v(self.up),
            self.defocus_angle,
            self.focus_dist,
        )
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub width: u32,
    pub height: u32,
    /// `look_from`: the pinhole, or the lens's centre.
    pub origin: Vec3,
    /// Upper-left corner of the viewport (a corner, not a pixel centre).
    pub corner: Vec3,
    /// One pixel step to the right (+u) and one down (−v).
    pub pixel_du: Vec3,
    pub pixel_dv: Vec3,
    /// The lens disk's radius vectors along the camera's u and v (zero for a pinhole).
    pub lens_u: Vec3,
    pub lens_v: Vec3,
    /// `lens_u` or `lens_v` is not zero (`has_lens`), kept so that a camera packet
    /// tests one flag: comparing the vectors cost 0.5% of the instructions of an
    /// 8-wide `bunny` render.
    thin_lens: bool,
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
        lens: Lens,
    ) -> Option<Self> {
        let h = (vfov_degrees.to_radians() / 2.0).tan();
        let focus = lens.focus_dist;
        let viewport_height = 2.0 * h * focus;
        let viewport_width = viewport_height * (width as f64 / height as f64);
        let w = (look_from - look_at).try_normalize()?;
        let u = up.cross(w).try_normalize()?;
        let v = w.cross(u);
        let corner =
            look_from - w * focus - u * (viewport_width / 2.0) + v * (viewport_height / 2.0);
        let radius = focus * (lens.defocus_angle.to_radians() / 2.0).tan();
        let (lens_u, lens_v) = ((u * radius).as_vec3(), (v * radius).as_vec3());
        Some(Self {
            width,
            height,
            origin: look_from.as_vec3(),
            corner: corner.as_vec3(),
            pixel_du: (u * (viewport_width / width as f64)).as_vec3(),
            pixel_dv: (-v * (viewport_height / height as f64)).as_vec3(),
            lens_u,
            lens_v,
            thin_lens: lens_u != Vec3::ZERO || lens_v != Vec3::ZERO,
        })
    }

    /// Rays start at points of a lens disk, not all at `origin`.
    #[inline]
    pub fn has_lens(&self) -> bool {
        self.thin_lens
    }

    /// A radius around `origin` holding every ray origin `lens_points` makes, its f32
    /// rounding included (0 for a pinhole), in f64.
    ///
    /// The disk point (dx, dy) has |(dx, dy)| ≤ 1 + 2⁻²² (sin and cos within an ulp,
    /// each product rounded once) and |lens_u·dx + lens_v·dy|² ≤ (max(|lens_u|²,
    /// |lens_v|²) + |lens_u·lens_v|)(dx² + dy²) (the f32 vectors are nearly, not exactly,
    /// orthogonal and equal). The f32 sum of three terms errs by at most γ₃ < 2⁻²² of
    /// their magnitudes, componentwise.
    pub fn lens_reach(&self) -> f64 {
        if !self.has_lens() {
            return 0.0;
        }
        let (u, v) = (self.lens_u.as_dvec3(), self.lens_v.as_dvec3());
        let disk = (u.length_squared().max(v.length_squared()) + u.dot(v).abs()).sqrt();
        let rounding = (self.origin.as_dvec3().abs() + u.abs() + v.abs()) * ROUNDING;
        disk * (1.0 + 2.0 * ROUNDING) + rounding.length()
    }

    /// A bound of the f32 rounding of `directions`' viewport points
    /// `corner + pixel_du · sx + pixel_dv · sy` (sx ≤ width, sy ≤ height), as a
    /// distance: γ₃ < 2⁻²² of the terms' magnitudes, componentwise.
    pub fn viewport_error(&self) -> f64 {
        let d = |v: Vec3| v.as_dvec3().abs();
        let terms = d(self.corner)
            + d(self.pixel_du) * self.width as f64
            + d(self.pixel_dv) * self.height as f64;
        (terms * ROUNDING).length()
    }

    /// The ray through the point (x + jx, y + jy) of the pixel grid, jx and jy in [0, 1),
    /// from the lens point of `lx`, `ly` in [0, 1) (`lens_points`; unused by a pinhole):
    /// `lens_points` and `directions` at `f32`.
    #[inline]
    pub fn ray(&self, x: u32, y: u32, jx: f32, jy: f32, lx: f32, ly: f32) -> Ray {
        let origin = if self.has_lens() {
            self.lens_points::<f32>(lx, ly)
        } else {
            V3::splat(self.origin)
        };
        let dir = self.directions(origin, x as f32, y as f32, jx, jy);
        Ray::new(origin.lane(0), dir.lane(0))
    }

    /// Points of the lens disk, lane by lane, from two uniform numbers in [0, 1) each:
    /// `origin + lens_u · dx + lens_v · dy` for the point (dx, dy) of `concentric_disk`.
    #[inline]
    pub fn lens_points<L: Lane>(&self, lx: L, ly: L) -> V3<L> {
        let (dx, dy) = concentric_disk(lx, ly);
        let o = V3::splat(self.origin) + V3::splat(self.lens_u).scale(dx);
        o + V3::splat(self.lens_v).scale(dy)
    }

    /// The unit directions from `origin` to the points (x + jx, y + jy) of the
    /// viewport, lane by lane (glam's `normalize` is `v · (1 / √(v·v))`).
    #[inline]
    pub fn directions<L: Lane>(&self, origin: V3<L>, x: L, y: L, jx: L, jy: L) -> V3<L> {
        let (sx, sy) = (x + jx, y + jy);
        let p = V3::splat(self.corner) + V3::splat(self.pixel_du).scale(sx);
        let p = p + V3::splat(self.pixel_dv).scale(sy);
        let v = p - origin;
        v.scale(L::splat(1.0) / v.dot(v).sqrt())
    }
}

/// Shirley and Chiu's concentric map of [0, 1)² onto the unit disk, lane by lane: the
/// square's concentric squares go to concentric circles, so equal areas stay equal (a
/// uniform point stays uniform) and strata stay compact. The point of (u, v) lies at
/// radius max(|a|, |b|), a = 2u − 1, b = 2v − 1, at the angle (π/4)·(b/a) when |a| > |b|,
/// else π/2 − (π/4)·(a/b). Exact operations and `sin_cos_turns`: the same bits at every
/// width. |dx|, |dy| ≤ 1.
#[inline(always)]
pub fn concentric_disk<L: Lane>(u: L, v: L) -> (L, L) {
    let (one, two) = (L::splat(1.0), L::splat(2.0));
    let (a, b) = (two * u - one, two * v - one);
    let a_major = a.abs().gt(b.abs());
    let r = L::select(a_major, a, b);
    // r = 0 only at the centre (a = b = 0): any finite angle then.
    let den = L::select(r.eq(L::splat(0.0)), one, r);
    let q = L::select(a_major, b, a) / den;
    let eighth = L::splat(0.125);
    let turns = L::select(a_major, q * eighth, L::splat(0.25) - q * eighth);
    let (sin, cos) = sin_cos_turns(turns);
    (r * cos, r * sin)
}

/// 2⁻²², above γ₃ = 3u/(1 − 3u) for f32's unit roundoff u = 2⁻²⁴: the error bound of a
/// sum of three rounded terms, relative to their magnitudes.
const ROUNDING: f64 = 1.0 / (1u64 << 22) as f64;

/// Image height from width and aspect ratio: `trunc(width / aspect)`, at least 1 (the
/// original program's rule: 800 at 16:9 gives 450).
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
            Lens::PINHOLE,
        )
        .unwrap();
        // Screen-right is −x for this camera.
        assert!(cam.pixel_du.x < 0.0 && cam.pixel_dv.y < 0.0);
        // The centre of the image looks straight down +z.
        let r = cam.ray(200, 200, 0.0, 0.0, 0.5, 0.5);
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
        assert!(Camera::new(
            10,
            10,
            90.0,
            DVec3::ZERO,
            DVec3::ZERO,
            DVec3::Y,
            Lens::PINHOLE
        )
        .is_none());
        assert!(
            Camera::new(10, 10, 90.0, DVec3::ZERO, DVec3::Y, DVec3::Y, Lens::PINHOLE).is_none()
        );
    }
}
