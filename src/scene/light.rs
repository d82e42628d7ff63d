//! Lights: the shape a light is sampled on and its own nearest hit, which a shadow ray
//! compares with the nearest hit of anything else.

use super::AREA_LIGHT_SAMPLES;
use crate::geometry::quad::Quad;
use crate::geometry::sphere::sphere_intersect;
use crate::geometry::triangle::WatertightRay;
use crate::geometry::{beats, Ray};
use crate::lanes::{Lane, V3};
use glam::Vec3;

/// The shape a light is sampled on. A sphere light is a point light at its centre.
#[derive(Clone, Debug, PartialEq)]
pub enum LightShape {
    Point {
        center: Vec3,
        radius: f32,
    },
    /// One quad, or the six faces of a box: a face is picked uniformly, then a point on it.
    Quads(Vec<Quad>),
    /// One triangle, or a mesh's triangles: one is picked uniformly by index.
    Triangles(Vec<[Vec3; 3]>),
}

#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// The object that must be the nearest hit of a shadow ray for the sample to count.
    pub object: u32,
    /// colour · intensity (no distance fall-off, as in the original program).
    pub radiance: Vec3,
    /// A copy of the object's primitives (they keep the pools' exact values, so the same
    /// kernels give the same distances as the pools do).
    pub shape: LightShape,
    /// Scene-wide id of the shape's first primitive; the others follow in order.
    pub first_id: u32,
}

impl Light {
    pub fn is_point(&self) -> bool {
        matches!(self.shape, LightShape::Point { .. })
    }

    pub fn samples(&self) -> u32 {
        if self.is_point() {
            1
        } else {
            AREA_LIGHT_SAMPLES
        }
    }

    /// The primitives the light is sampled on (one for a point light).
    pub fn primitives(&self) -> usize {
        match &self.shape {
            LightShape::Point { .. } => 1,
            LightShape::Quads(qs) => qs.len(),
            LightShape::Triangles(ts) => ts.len(),
        }
    }

    /// A point on the light from three uniform numbers: `pick` chooses the face or
    /// triangle, `xi1`, `xi2` the point on it. `sample_lanes` at `f32`.
    #[inline]
    pub fn sample(&self, pick: f32, xi1: f32, xi2: f32) -> Vec3 {
        self.sample_lanes::<f32>(pick, xi1, xi2).lane(0)
    }

    /// `sample` lane by lane: a quad's point corner + u·ξ₁ + v·ξ₂, a triangle's
    /// `sample_triangle`, with one primitive splatted, several gathered per lane.
    #[inline(always)]
    pub fn sample_lanes<L: Lane>(&self, pick: L, xi1: L, xi2: L) -> V3<L> {
        let index = |n: usize| -> [usize; crate::lanes::MAX_WIDTH] {
            std::array::from_fn(|k| {
                if k < L::WIDTH {
                    ((pick.lane(k) * n as f32) as usize).min(n - 1)
                } else {
                    0
                }
            })
        };
        match &self.shape {
            LightShape::Point { center, .. } => V3::splat(*center),
            LightShape::Quads(qs) => {
                let (corner, u, v) = if let [q] = qs.as_slice() {
                    (V3::splat(q.corner), V3::splat(q.u), V3::splat(q.v))
                } else {
                    let i = index(qs.len());
                    (
                        V3::from_fn(|k| qs[i[k]].corner),
                        V3::from_fn(|k| qs[i[k]].u),
                        V3::from_fn(|k| qs[i[k]].v),
                    )
                };
                corner + u.scale(xi1) + v.scale(xi2)
            }
            LightShape::Triangles(ts) => {
                let i = index(ts.len());
                let vertex = |j: usize| V3::from_fn(|k| ts[i[k]][j]);
                crate::geometry::triangle::sample_triangle_lanes(
                    [vertex(0), vertex(1), vertex(2)],
                    xi1,
                    xi2,
                )
            }
        }
    }

    /// The light object's own nearest hit `(t, primitive id)` at t ≥ `t_min`, by the same
    /// kernels and `(t, id)` rule as the acceleration structures.
    pub fn nearest_hit(&self, ray: &Ray, t_min: f32) -> Option<(f32, u32)> {
        match self.shape {
            LightShape::Point { center, radius } => {
                sphere_intersect(center, radius, ray, t_min, f32::INFINITY)
                    .map(|t| (t, self.first_id))
            }
            _ => self.nearest_hit_watertight(ray, &WatertightRay::new(ray), t_min),
        }
    }

    /// `nearest_hit` with the ray's watertight constants `w` already made (unused by a
    /// point light). Inlined into the shadow tests (as a call, with the quad test it
    /// calls, it was a fifth of the scalar shadow rays' instructions on `cornell`).
    #[inline(always)]
    pub fn nearest_hit_watertight(
        &self,
        ray: &Ray,
        w: &WatertightRay,
        t_min: f32,
    ) -> Option<(f32, u32)> {
        let mut best: Option<(f32, u32)> = None;
        let mut keep = |t: f32, id: u32| {
            if best.is_none_or(|b| beats((t, id), b)) {
                best = Some((t, id));
            }
        };
        let far = f32::INFINITY;
        match &self.shape {
            LightShape::Point { center, radius } => {
                if let Some(t) = sphere_intersect(*center, *radius, ray, t_min, far) {
                    keep(t, self.first_id);
                }
            }
            LightShape::Quads(qs) => {
                for (k, q) in qs.iter().enumerate() {
                    if let Some(t) = q.intersect_watertight(ray, w, t_min, far) {
                        keep(t, self.first_id + k as u32);
                    }
                }
            }
            LightShape::Triangles(ts) => {
                for (k, tri) in ts.iter().enumerate() {
                    if let Some(t) = w.intersect(*tri, t_min, far) {
                        keep(t, self.first_id + k as u32);
                    }
                }
            }
        }
        best
    }
}
