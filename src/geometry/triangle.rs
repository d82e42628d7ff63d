//! Triangles: pool, bounds, watertight intersection, normal, light sampling.
//!
//! Scene keys (read in `scene::desc`): `a`, `b`, `c` for a triangle; a mesh (`path`)
//! compiles to triangles.

use super::{Aabb, Ray};
use glam::Vec3;

/// Triangles, structure-of-arrays, stored as their three vertices (the watertight test
/// works on vertices relative to the ray origin).
#[derive(Clone, Debug, Default)]
pub struct TrianglePool {
    pub ax: Vec<f32>,
    pub ay: Vec<f32>,
    pub az: Vec<f32>,
    pub bx: Vec<f32>,
    pub by: Vec<f32>,
    pub bz: Vec<f32>,
    pub cx: Vec<f32>,
    pub cy: Vec<f32>,
    pub cz: Vec<f32>,
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
        self.ax.push(a.x);
        self.ay.push(a.y);
        self.az.push(a.z);
        self.bx.push(b.x);
        self.by.push(b.y);
        self.bz.push(b.z);
        self.cx.push(c.x);
        self.cy.push(c.y);
        self.cz.push(c.z);
        self.id.push(id);
        self.object.push(object);
    }

    /// Reorder (see `geometry::permute`).
    pub fn permute(&mut self, order: &[u32]) {
        for v in [
            &mut self.ax,
            &mut self.ay,
            &mut self.az,
            &mut self.bx,
            &mut self.by,
            &mut self.bz,
            &mut self.cx,
            &mut self.cy,
            &mut self.cz,
        ] {
            super::permute(v, order);
        }
        super::permute(&mut self.id, order);
        super::permute(&mut self.object, order);
    }

    #[inline]
    pub fn vertices(&self, i: usize) -> [Vec3; 3] {
        [
            Vec3::new(self.ax[i], self.ay[i], self.az[i]),
            Vec3::new(self.bx[i], self.by[i], self.bz[i]),
            Vec3::new(self.cx[i], self.cy[i], self.cz[i]),
        ]
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

    #[inline]
    pub fn intersect(&self, i: usize, ray: &WatertightRay, t_min: f32, t_max: f32) -> Option<f32> {
        ray.intersect(self.vertices(i), t_min, t_max)
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
/// direction axis and the shear that maps the ray onto +z.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    pub origin: Vec3,
    pub kx: usize,
    pub ky: usize,
    pub kz: usize,
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
        Self {
            origin: ray.origin,
            kx,
            ky,
            kz,
            sx: d[kx] / d[kz],
            sy: d[ky] / d[kz],
            sz: 1.0 / d[kz],
        }
    }

    /// Two-sided watertight test. Edges are inclusive, and a ray through a shared edge or
    /// vertex hits at least one of the triangles sharing it: the edge functions are exact
    /// in sign, with an f64 recomputation when one of them rounds to zero.
    #[inline]
    pub fn intersect(&self, [a, b, c]: [Vec3; 3], t_min: f32, t_max: f32) -> Option<f32> {
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        let a = a - self.origin;
        let b = b - self.origin;
        let c = c - self.origin;
        let (ax, ay) = (a[kx] - self.sx * a[kz], a[ky] - self.sy * a[kz]);
        let (bx, by) = (b[kx] - self.sx * b[kz], b[ky] - self.sy * b[kz]);
        let (cx, cy) = (c[kx] - self.sx * c[kz], c[ky] - self.sy * c[kz]);
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
        let (az, bz, cz) = (self.sz * a[kz], self.sz * b[kz], self.sz * c[kz]);
        let t = (u * az + v * bz + w * cz) / det;
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
