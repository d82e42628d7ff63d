//! Axis-aligned bounding boxes and the robust slab test.

use super::Ray;
use glam::Vec3;

/// An axis-aligned box. The empty box has `min = +inf`, `max = -inf`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// Per-ray values the slab test reuses for every box.
#[derive(Clone, Copy, Debug)]
pub struct SlabRay {
    pub origin: Vec3,
    pub inv_dir: Vec3,
}

impl SlabRay {
    /// `1 / ±0` gives `±inf`, which the slab test below handles (Ize, JCGT 2013).
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        Self {
            origin: ray.origin,
            inv_dir: Vec3::new(1.0 / ray.dir.x, 1.0 / ray.dir.y, 1.0 / ray.dir.z),
        }
    }
}

/// `1 + 2γ₃` with γₙ = nε/(1 − nε), ε = 2⁻²⁴: widening t_far by this keeps the slab test
/// conservative under rounding (Ize, "Robust BVH Ray Traversal", JCGT 2013).
pub const SLAB_FAR_SCALE: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Entry and exit distances of one axis's slab, `lo` and `hi` being the distances to its
/// two planes. Written out (no `f32::min`) so every lane width repeats it exactly.
///
/// A NaN comes from `0 · inf`: a ray with a ±0 direction component whose origin lies
/// exactly on that slab's plane. Such a ray runs inside the plane; the axis is left
/// unconstrained, which is conservative (Ize, JCGT 2013, discusses the case).
#[inline]
pub fn slab_axis(lo: f32, hi: f32) -> (f32, f32) {
    if lo.is_nan() || hi.is_nan() {
        return (f32::NEG_INFINITY, f32::INFINITY);
    }
    if lo <= hi {
        (lo, hi)
    } else {
        (hi, lo)
    }
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn new(min: Vec3, max: Vec3) -> Self {
        Self { min, max }
    }

    pub fn from_points(points: &[Vec3]) -> Self {
        points.iter().fold(Self::EMPTY, |b, &p| b.grow(p))
    }

    #[inline]
    pub fn grow(self, p: Vec3) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    #[inline]
    pub fn union(self, o: Aabb) -> Self {
        Self {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    pub fn centroid(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    pub fn surface_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let d = self.max - self.min;
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }

    /// Robust slab test: does the ray overlap the box anywhere in `[t_min, t_max]`?
    /// Returns the entry distance (clamped to `t_min`) on overlap.
    ///
    /// Flat boxes (a Cornell wall has zero thickness) and axis-parallel rays with ±0
    /// components never lose a hit: the far distance is widened by `SLAB_FAR_SCALE`
    /// and NaNs from `0 · inf` leave their axis unconstrained.
    #[inline]
    pub fn hit(&self, ray: &SlabRay, t_min: f32, t_max: f32) -> Option<f32> {
        let lo = (self.min - ray.origin) * ray.inv_dir;
        let hi = (self.max - ray.origin) * ray.inv_dir;
        let (nx, fx) = slab_axis(lo.x, hi.x);
        let (ny, fy) = slab_axis(lo.y, hi.y);
        let (nz, fz) = slab_axis(lo.z, hi.z);
        let enter = t_min.max(nx).max(ny).max(nz);
        let exit = t_max
            .min(fx * SLAB_FAR_SCALE)
            .min(fy * SLAB_FAR_SCALE)
            .min(fz * SLAB_FAR_SCALE);
        (enter <= exit).then_some(enter)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_box_is_hit_by_perpendicular_ray() {
        // A zero-thickness wall at x = 555, as in the Cornell box.
        let wall = Aabb::new(Vec3::new(555.0, 0.0, 0.0), Vec3::new(555.0, 555.0, 555.0));
        let ray = Ray::new(Vec3::new(0.0, 100.0, 100.0), Vec3::X);
        assert_eq!(
            wall.hit(&SlabRay::new(&ray), 0.0, f32::INFINITY),
            Some(555.0)
        );
    }

    #[test]
    fn axis_parallel_ray_with_signed_zeros() {
        let b = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        for dir in [Vec3::new(0.0, 0.0, -1.0), Vec3::new(-0.0, -0.0, -1.0)] {
            let inside = Ray::new(Vec3::new(0.5, -0.5, 5.0), dir);
            assert_eq!(b.hit(&SlabRay::new(&inside), 0.0, f32::INFINITY), Some(4.0));
            let outside = Ray::new(Vec3::new(1.5, 0.0, 5.0), dir);
            assert_eq!(b.hit(&SlabRay::new(&outside), 0.0, f32::INFINITY), None);
        }
        // Origin exactly on the slab plane of the zero component: 0 · inf = NaN.
        let on_plane = Ray::new(Vec3::new(1.0, 0.0, 5.0), Vec3::new(0.0, 0.0, -1.0));
        assert_eq!(
            b.hit(&SlabRay::new(&on_plane), 0.0, f32::INFINITY),
            Some(4.0)
        );
    }

    #[test]
    fn respects_interval() {
        let b = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        let r = SlabRay::new(&Ray::new(
            Vec3::new(0.0, 0.0, 5.0),
            Vec3::new(0.0, 0.0, -1.0),
        ));
        assert_eq!(b.hit(&r, 0.0, 3.9), None);
        assert_eq!(b.hit(&r, 7.0, 10.0), None);
        assert_eq!(b.hit(&r, 5.0, 10.0), Some(5.0));
    }
}
