//! Triangles: pool, bounds, watertight intersection, normal, light sampling.
//!
//! Scene keys (read in `scene::desc`): `a`, `b`, `c` for a triangle; a mesh (`path`)
//! compiles to triangles.

use super::{Aabb, Ray};
use glam::Vec3;

/// Triangles, structure-of-arrays, stored as their three vertices, each vertex as one
/// array per axis: `a[axis][i]`. The watertight test reads the axes in the order its ray
/// permutation gives, so it indexes `a[kx]` directly instead of building vectors.
#[derive(Clone, Debug, Default)]
pub struct TrianglePool {
    pub a: [Vec<f32>; 3],
    pub b: [Vec<f32>; 3],
    pub c: [Vec<f32>; 3],
    /// Scene-wide primitive id (closest-hit tie-breaker).
    pub id: Vec<u32>,
    /// The scene object each triangle belongs to (all triangles of a mesh share one).
    pub object: Vec<u32>,
}

impl TrianglePool {
    pub fn len(&self) -> usize {
        self.id.len()
    }

    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    pub fn push(&mut self, [a, b, c]: [Vec3; 3], id: u32, object: u32) {
        for axis in 0..3 {
            self.a[axis].push(a[axis]);
            self.b[axis].push(b[axis]);
            self.c[axis].push(c[axis]);
        }
        self.id.push(id);
        self.object.push(object);
    }

    /// Reorder (see `geometry::permute`).
    pub fn permute(&mut self, order: &[u32]) {
        for v in self
            .a
            .iter_mut()
            .chain(self.b.iter_mut())
            .chain(self.c.iter_mut())
        {
            super::permute(v, order);
        }
        super::permute(&mut self.id, order);
        super::permute(&mut self.object, order);
    }

    #[inline]
    pub fn vertices(&self, i: usize) -> [Vec3; 3] {
        let v = |p: &[Vec<f32>; 3]| Vec3::new(p[0][i], p[1][i], p[2][i]);
        [v(&self.a), v(&self.b), v(&self.c)]
    }

    pub fn bounds(&self, i: usize) -> Aabb {
        Aabb::from_points(&self.vertices(i))
    }

    /// Unit geometric normal, normalise((b − a) × (c − a)), as in the seed (flat shading).
    #[inline]
    pub fn normal(&self, i: usize) -> Vec3 {
        let [a, b, c] = self.vertices(i);
        (b - a).cross(c - a).normalize_or(Vec3::Y)
    }

    /// The watertight test on triangle `i`, reading the pool in the ray's axis order.
    #[inline(always)]
    pub fn intersect(&self, i: usize, ray: &WatertightRay, t_min: f32, t_max: f32) -> Option<f32> {
        let [kx, ky, kz] = ray.axes;
        let (a, b, c) = (&self.a, &self.b, &self.c);
        ray.intersect_permuted(
            [a[kx][i], a[ky][i], a[kz][i]],
            [b[kx][i], b[ky][i], b[kz][i]],
            [c[kx][i], c[ky][i], c[kz][i]],
            t_min,
            t_max,
        )
    }
}

/// Is the triangle usable: finite and of non-zero area?
pub fn is_proper_triangle([a, b, c]: [Vec3; 3]) -> bool {
    let n = (b - a).cross(c - a);
    a.is_finite() && b.is_finite() && c.is_finite() && n.length_squared() > 0.0
}

/// A point uniform over the triangle from two uniform numbers in [0, 1): fold the unit
/// square onto the triangle (if ξ1 + ξ2 > 1 use 1 − ξ1, 1 − ξ2), as in the seed.
#[inline]
pub fn sample_triangle([a, b, c]: [Vec3; 3], xi1: f32, xi2: f32) -> Vec3 {
    let (s, t) = if xi1 + xi2 > 1.0 {
        (1.0 - xi1, 1.0 - xi2)
    } else {
        (xi1, xi2)
    };
    a + (b - a) * s + (c - a) * t
}

/// Per-ray constants of the watertight ray/triangle test (Woop, Benthin, Wald, "Watertight
/// Ray/Triangle Intersection", JCGT 2013): the axis permutation that makes z the dominant
/// direction axis, the origin in that order, and the shear that maps the ray onto +z.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    /// [kx, ky, kz].
    pub axes: [usize; 3],
    /// The origin's components in `axes` order.
    pub origin: [f32; 3],
    pub sx: f32,
    pub sy: f32,
    pub sz: f32,
}

impl WatertightRay {
    pub fn new(ray: &Ray) -> Self {
        let d = ray.dir;
        let ad = d.abs();
        let kz = if ad.x > ad.y {
            if ad.x > ad.z {
                0
            } else {
                2
            }
        } else if ad.y > ad.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        // Keep the winding: swap when the dominant component is negative.
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let o = ray.origin;
        Self {
            axes: [kx, ky, kz],
            origin: [o[kx], o[ky], o[kz]],
            sx: d[kx] / d[kz],
            sy: d[ky] / d[kz],
            sz: 1.0 / d[kz],
        }
    }

    /// Two-sided watertight test of the triangle `[a, b, c]`.
    #[inline]
    pub fn intersect(&self, [a, b, c]: [Vec3; 3], t_min: f32, t_max: f32) -> Option<f32> {
        let [kx, ky, kz] = self.axes;
        let p = |v: Vec3| [v[kx], v[ky], v[kz]];
        self.intersect_permuted(p(a), p(b), p(c), t_min, t_max)
    }

    /// The test on vertices already in the ray's axis order. Edges are inclusive, and a
    /// ray through a shared edge or vertex hits at least one of the triangles sharing it:
    /// the edge functions are exact in sign, with an f64 recomputation when one of them
    /// rounds to zero.
    #[inline(always)]
    pub fn intersect_permuted(
        &self,
        a: [f32; 3],
        b: [f32; 3],
        c: [f32; 3],
        t_min: f32,
        t_max: f32,
    ) -> Option<f32> {
        let [ox, oy, oz] = self.origin;
        let (az, bz, cz) = (a[2] - oz, b[2] - oz, c[2] - oz);
        let (ax, ay) = ((a[0] - ox) - self.sx * az, (a[1] - oy) - self.sy * az);
        let (bx, by) = ((b[0] - ox) - self.sx * bz, (b[1] - oy) - self.sy * bz);
        let (cx, cy) = ((c[0] - ox) - self.sx * cz, (c[1] - oy) - self.sy * cz);
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            let (ax, ay, bx, by, cx, cy) = (
                ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64,
            );
            u = (cx * by - cy * bx) as f32;
            v = (ax * cy - ay * cx) as f32;
            w = (bx * ay - by * ax) as f32;
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let t = (u * (self.sz * az) + v * (self.sz * bz) + w * (self.sz * cz)) / det;
        (t >= t_min && t <= t_max).then_some(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRI: [Vec3; 3] = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];

    fn hit(o: Vec3, d: Vec3) -> Option<f32> {
        WatertightRay::new(&Ray::new(o, d.normalize())).intersect(TRI, 1e-4, f32::INFINITY)
    }

    #[test]
    fn hits_both_faces_and_edges() {
        assert_eq!(hit(Vec3::new(0.25, 0.25, 2.0), -Vec3::Z), Some(2.0));
        assert_eq!(hit(Vec3::new(0.25, 0.25, -2.0), Vec3::Z), Some(2.0));
        // Shared edge x + y = 1 and the vertices are inside.
        assert_eq!(hit(Vec3::new(0.5, 0.5, 1.0), -Vec3::Z), Some(1.0));
        assert_eq!(hit(Vec3::new(0.0, 0.0, 1.0), -Vec3::Z), Some(1.0));
        assert_eq!(hit(Vec3::new(0.6, 0.6, 1.0), -Vec3::Z), None);
        assert_eq!(hit(Vec3::new(-0.01, 0.5, 1.0), -Vec3::Z), None);
    }

    #[test]
    fn ray_in_plane_misses() {
        assert_eq!(hit(Vec3::new(-1.0, 0.25, 0.0), Vec3::X), None);
    }

    #[test]
    fn sampling_stays_inside() {
        for (x1, x2) in [(0.0, 0.0), (0.9, 0.9), (0.999, 0.0), (0.3, 0.6)] {
            let p = sample_triangle(TRI, x1, x2);
            assert!(p.x >= 0.0 && p.y >= 0.0 && p.x + p.y <= 1.0, "{p}");
        }
    }
}
