//! Quads (parallelograms): pool, bounds, intersection, normal, light sampling.
//!
//! Scene keys (read in `scene::desc`): `corner`, `u`, `v` for a quad; a box (`min`, `max`)
//! compiles to six quads.

use super::{Aabb, Ray};
use crate::lanes::{Lane, V3};
use glam::Vec3;

/// The seed's parallel-ray threshold on `|n · d|`.
pub const PARALLEL_EPSILON: f32 = 1e-8;

/// Quads, structure-of-arrays. Each holds the corner Q, edges u and v, the unit normal
/// n = normalise(u × v), the plane offset D = n · Q and w = (u × v) / |u × v|², which turns a
/// point on the plane into its (α, β) coordinates along u and v.
#[derive(Clone, Debug, Default)]
pub struct QuadPool {
    pub qx: Vec<f32>,
    pub qy: Vec<f32>,
    pub qz: Vec<f32>,
    pub ux: Vec<f32>,
    pub uy: Vec<f32>,
    pub uz: Vec<f32>,
    pub vx: Vec<f32>,
    pub vy: Vec<f32>,
    pub vz: Vec<f32>,
    pub nx: Vec<f32>,
    pub ny: Vec<f32>,
    pub nz: Vec<f32>,
    pub plane_d: Vec<f32>,
    pub wx: Vec<f32>,
    pub wy: Vec<f32>,
    pub wz: Vec<f32>,
    /// Scene-wide primitive id (closest-hit tie-breaker).
    pub id: Vec<u32>,
    /// The scene object each quad belongs to (the six faces of a box share one).
    pub object: Vec<u32>,
}

/// The per-quad constants, gathered (used by the scalar path and by light sampling).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quad {
    pub corner: Vec3,
    pub u: Vec3,
    pub v: Vec3,
    pub normal: Vec3,
    pub plane_d: f32,
    pub w: Vec3,
}

impl Quad {
    /// Precompute the plane. `None` for a degenerate (zero-area or non-finite) quad.
    pub fn new(corner: Vec3, u: Vec3, v: Vec3) -> Option<Self> {
        let n = u.cross(v);
        let nn = n.dot(n);
        if nn <= 0.0 || !nn.is_finite() {
            return None;
        }
        let normal = n / nn.sqrt();
        Some(Self {
            corner,
            u,
            v,
            normal,
            plane_d: normal.dot(corner),
            w: n / nn,
        })
    }

    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(&[
            self.corner,
            self.corner + self.u,
            self.corner + self.v,
            self.corner + self.u + self.v,
        ])
    }

    /// The seed's plane test: t from the plane equation, then 0 ≤ α, β ≤ 1 (inclusive).
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<f32> {
        let (t, hit) = quad_distance(
            V3::splat(self.corner),
            V3::splat(self.u),
            V3::splat(self.v),
            V3::splat(self.normal),
            self.plane_d,
            V3::splat(self.w),
            V3::splat(ray.origin),
            V3::splat(ray.dir),
            t_min,
            t_max,
        );
        hit.then_some(t)
    }

    /// A point uniform over the quad's area from two uniform numbers in [0, 1).
    #[inline]
    pub fn sample(&self, xi1: f32, xi2: f32) -> Vec3 {
        self.corner + self.u * xi1 + self.v * xi2
    }
}

impl QuadPool {
    pub fn len(&self) -> usize {
        self.id.len()
    }

    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    pub fn push(&mut self, q: &Quad, id: u32, object: u32) {
        self.qx.push(q.corner.x);
        self.qy.push(q.corner.y);
        self.qz.push(q.corner.z);
        self.ux.push(q.u.x);
        self.uy.push(q.u.y);
        self.uz.push(q.u.z);
        self.vx.push(q.v.x);
        self.vy.push(q.v.y);
        self.vz.push(q.v.z);
        self.nx.push(q.normal.x);
        self.ny.push(q.normal.y);
        self.nz.push(q.normal.z);
        self.plane_d.push(q.plane_d);
        self.wx.push(q.w.x);
        self.wy.push(q.w.y);
        self.wz.push(q.w.z);
        self.id.push(id);
        self.object.push(object);
    }

    /// Reorder (see `geometry::permute`).
    pub fn permute(&mut self, order: &[u32]) {
        for v in [
            &mut self.qx,
            &mut self.qy,
            &mut self.qz,
            &mut self.ux,
            &mut self.uy,
            &mut self.uz,
            &mut self.vx,
            &mut self.vy,
            &mut self.vz,
            &mut self.nx,
            &mut self.ny,
            &mut self.nz,
            &mut self.plane_d,
            &mut self.wx,
            &mut self.wy,
            &mut self.wz,
        ] {
            super::permute(v, order);
        }
        super::permute(&mut self.id, order);
        super::permute(&mut self.object, order);
    }

    #[inline]
    pub fn get(&self, i: usize) -> Quad {
        Quad {
            corner: Vec3::new(self.qx[i], self.qy[i], self.qz[i]),
            u: Vec3::new(self.ux[i], self.uy[i], self.uz[i]),
            v: Vec3::new(self.vx[i], self.vy[i], self.vz[i]),
            normal: Vec3::new(self.nx[i], self.ny[i], self.nz[i]),
            plane_d: self.plane_d[i],
            w: Vec3::new(self.wx[i], self.wy[i], self.wz[i]),
        }
    }

    #[inline]
    pub fn normal(&self, i: usize) -> Vec3 {
        Vec3::new(self.nx[i], self.ny[i], self.nz[i])
    }

    pub fn bounds(&self, i: usize) -> Aabb {
        self.get(i).bounds()
    }

    #[inline]
    pub fn intersect(&self, i: usize, ray: &Ray, t_min: f32, t_max: f32) -> Option<f32> {
        self.get(i).intersect(ray, t_min, t_max)
    }
}

/// The quad test over lanes (`Quad::intersect` is its one-lane case).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn quad_distance<L: Lane>(
    corner: V3<L>,
    u: V3<L>,
    v: V3<L>,
    normal: V3<L>,
    plane_d: L,
    w: V3<L>,
    origin: V3<L>,
    dir: V3<L>,
    t_min: L,
    t_max: L,
) -> (L, L::Mask) {
    let (zero, one) = (L::splat(0.0), L::splat(1.0));
    let denom = normal.dot(dir);
    let parallel = denom.abs().lt(L::splat(PARALLEL_EPSILON));
    let t = (plane_d - normal.dot(origin)) / denom;
    let in_range = t.ge(t_min) & t.le(t_max);
    let hp = (origin + dir.scale(t)) - corner;
    let alpha = w.dot(hp.cross(v));
    let beta = w.dot(u.cross(hp));
    let inside = alpha.ge(zero) & alpha.le(one) & beta.ge(zero) & beta.le(one);
    (t, !parallel & in_range & inside)
}

/// The six outward-facing quads of the box with the given component-wise min and max
/// corners. (The seed's z-min face pointed inward; see the README's differences.)
pub fn box_faces(min: Vec3, max: Vec3) -> [(Vec3, Vec3, Vec3); 6] {
    let dx = Vec3::new(max.x - min.x, 0.0, 0.0);
    let dy = Vec3::new(0.0, max.y - min.y, 0.0);
    let dz = Vec3::new(0.0, 0.0, max.z - min.z);
    [
        (Vec3::new(min.x, min.y, max.z), dx, dy),  // front, +z
        (Vec3::new(max.x, min.y, max.z), -dz, dy), // right, +x
        (Vec3::new(max.x, min.y, min.z), -dx, dy), // back, −z
        (Vec3::new(min.x, min.y, min.z), dz, dy),  // left, −x
        (Vec3::new(min.x, max.y, max.z), dx, -dz), // top, +y
        (Vec3::new(min.x, min.y, min.z), dx, dz),  // bottom, −y
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_faces_point_outward() {
        let (min, max) = (Vec3::new(1.0, 2.0, 3.0), Vec3::new(4.0, 6.0, 8.0));
        let centre = (min + max) * 0.5;
        for (corner, u, v) in box_faces(min, max) {
            let q = Quad::new(corner, u, v).unwrap();
            let face_centre = corner + (u + v) * 0.5;
            assert!(q.normal.dot(face_centre - centre) > 0.0, "{q:?}");
        }
    }

    #[test]
    fn edges_are_inclusive() {
        let q = Quad::new(Vec3::ZERO, Vec3::X, Vec3::Y).unwrap();
        let down = Vec3::new(0.0, 0.0, -1.0);
        for (x, y) in [(0.0, 0.0), (1.0, 1.0), (0.5, 1.0), (0.0, 0.5)] {
            let r = Ray::new(Vec3::new(x, y, 1.0), down);
            assert_eq!(
                q.intersect(&r, 1e-4, f32::INFINITY),
                Some(1.0),
                "({x}, {y})"
            );
        }
        let r = Ray::new(Vec3::new(1.001, 0.5, 1.0), down);
        assert_eq!(q.intersect(&r, 1e-4, f32::INFINITY), None);
    }

    #[test]
    fn degenerate_quads_are_rejected() {
        assert!(Quad::new(Vec3::ZERO, Vec3::X, Vec3::X * 2.0).is_none());
        assert!(Quad::new(Vec3::ZERO, Vec3::ZERO, Vec3::Y).is_none());
    }
}
