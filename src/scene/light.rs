//! Lights: the shape a light is sampled on and its own nearest hit, which a shadow ray
//! compares with the nearest hit of anything else.

use super::{AREA_LIGHT_SAMPLES, AREA_LIGHT_STRATA};
use crate::geometry::quad::Quad;
use crate::geometry::sphere::sphere_intersect;
use crate::geometry::triangle::WatertightRay;
use crate::geometry::{beats, Ray};
use crate::lanes::{Lane, V3};
use crate::sampling::ONE_MINUS_EPSILON;
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

    /// Sample `k` of the light's `samples()` from uniform numbers in [0, 1): the pick and
    /// the point moved into cell `k` (`AREA_LIGHT_STRATA`). With several primitives the
    /// pick is stratified, `(k + pick) / n`, and the point on the primitive is not; with
    /// one, the point is, in a 5 by 2 grid of the face. Each cell holds a tenth of the
    /// light's measure, so the mean of the ten samples is the same estimate as of ten
    /// independent ones, with less variance; and sample `k` of every lane of a packet
    /// aims at the same cell, so its shadow rays stay together.
    #[inline(always)]
    pub fn stratum<L: Lane>(&self, k: u32, pick: L, xi1: L, xi2: L) -> (L, L, L) {
        if self.is_point() {
            return (pick, xi1, xi2);
        }
        debug_assert!(k < AREA_LIGHT_SAMPLES);
        // (i + x) / n rounds to at most 1: the largest number below 1 keeps the cell.
        let cell = |i: u32, n: u32, x: L| {
            ((L::splat(i as f32) + x) / L::splat(n as f32)).min(L::splat(ONE_MINUS_EPSILON))
        };
        if self.primitives() > 1 {
            return (cell(k, AREA_LIGHT_SAMPLES, pick), xi1, xi2);
        }
        let (nu, nv) = AREA_LIGHT_STRATA;
        (pick, cell(k % nu, nu, xi1), cell(k / nu, nv, xi2))
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

#[cfg(test)]
mod tests {
    use super::*;

    fn light(shape: LightShape) -> Light {
        Light {
            object: 0,
            radiance: Vec3::ONE,
            shape,
            first_id: 0,
        }
    }

    fn quad(corner: Vec3, u: Vec3, v: Vec3) -> Quad {
        Quad::new(corner, u, v).unwrap()
    }

    /// Sample k of one face lies in cell (k mod 5, k div 5) of the 5 by 2 grid, at the
    /// cell's edges too (0 and the largest number below 1); a point light's numbers
    /// pass unchanged.
    #[test]
    fn samples_fill_their_cells() {
        let one = light(LightShape::Quads(vec![quad(Vec3::ZERO, Vec3::X, Vec3::Z)]));
        let (nu, nv) = AREA_LIGHT_STRATA;
        let within = |x: f32, i: u32, n: u32| {
            (i as f32 / n as f32) <= x && x <= (i + 1) as f32 / n as f32 && x < 1.0
        };
        for k in 0..AREA_LIGHT_SAMPLES {
            for xi in [0.0, 0.25, 0.5, 0.75, ONE_MINUS_EPSILON] {
                let (pick, a, b) = one.stratum(k, 0.3f32, xi, 1.0 - xi.max(0.5));
                assert_eq!(pick, 0.3);
                assert!(within(a, k % nu, nu) && within(b, k / nu, nv), "{k} {xi}");
                let (pick, a, b) = light(LightShape::Triangles(vec![[Vec3::ZERO; 3]; 2]))
                    .stratum(k, xi, 0.4f32, 0.6);
                assert!(within(pick, k, AREA_LIGHT_SAMPLES) && (a, b) == (0.4, 0.6));
            }
        }
        let point = light(LightShape::Point {
            center: Vec3::ONE,
            radius: 0.1,
        });
        assert_eq!(point.stratum(3, 0.1f32, 0.2, 0.9), (0.1, 0.2, 0.9));
    }

    /// The ten cells share the light evenly: over an even grid of numbers in each, the
    /// points of a quad average to its centre (f64), and a box's faces are picked
    /// equally often.
    #[test]
    fn cells_share_the_light_evenly() {
        let (corner, u, v) = (
            Vec3::new(-1.0, 2.0, 0.5),
            Vec3::new(0.5, 0.0, 0.25),
            Vec3::Y,
        );
        let one = light(LightShape::Quads(vec![quad(corner, u, v)]));
        let m = 16;
        let mut sum = [0.0f64; 3];
        for k in 0..AREA_LIGHT_SAMPLES {
            for i in 0..m {
                for j in 0..m {
                    let x = |i: u32| (i as f32 + 0.5) / m as f32;
                    let (pick, a, b) = one.stratum(k, 0.0f32, x(i), x(j));
                    let p = one.sample(pick, a, b);
                    for (s, c) in sum.iter_mut().zip(p.to_array()) {
                        *s += c as f64;
                    }
                }
            }
        }
        let n = (AREA_LIGHT_SAMPLES * m * m) as f64;
        let centre = corner + 0.5 * u + 0.5 * v;
        for (s, c) in sum.iter().zip(centre.to_array()) {
            assert!((s / n - c as f64).abs() < 1e-6, "{} {c}", s / n);
        }
        let faces: Vec<Quad> = (0..6)
            .map(|f| quad(Vec3::splat(f as f32), Vec3::X, Vec3::Y))
            .collect();
        let boxed = light(LightShape::Quads(faces));
        let mut picked = [0u32; 6];
        let m = 60;
        for k in 0..AREA_LIGHT_SAMPLES {
            for i in 0..m {
                let x = (i as f32 + 0.5) / m as f32;
                let (pick, a, b) = boxed.stratum(k, x, 0.5f32, 0.5);
                picked[boxed.sample(pick, a, b).z as usize] += 1;
            }
        }
        assert_eq!(picked, [100; 6]);
    }
}
