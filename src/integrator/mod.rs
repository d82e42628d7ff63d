//! The scalar reference tracer: one ray at a time, with the seed's shading semantics
//! (`seed-scenes.md` §3–§5).
//!
//! - Phong and PhongMirror return a final colour; Light returns its plain colour.
//! - Diffuse, Metal and Dielectric scatter and the path continues, up to `max_depth`.
//! - Every random number comes from `rng::SampleKey`, addressed by path vertex and slot.
//! - `packet`: the same tracer over 4- and 8-wide packets, image for image the same bits.

mod packet;

pub use packet::footprint;

use crate::accel::packet::MAX_WIDTH;
use crate::accel::{Accel, TraversalStats};
use crate::geometry::spawn::{planar_point, spawn_ray, sphere_point, ErrorPoint};
use crate::geometry::{Hit, PrimKind, Ray};
use crate::lanes::{Lane, Mask, V3};
use crate::material::{random_unit_vector, reflect, refract, schlick, Material, Phong};
use crate::rng::{slot, SampleKey, Sampler};
use crate::scene::{LightShape, Scene};
use glam::Vec3;

/// Rays accept hits at t > 0 (the smallest positive normal float; the tests compare with
/// `>=`): secondary rays start off their surface by the hit point's error bound
/// (`geometry::spawn`) instead of the seed's t_min = 1e-4. A surface whose error bound is
/// zero (a wall in the plane x = 0) yields t = 0 for its own spawned rays, excluded here.
pub const T_MIN: f32 = f32::MIN_POSITIVE;

/// Rays traced, by kind, and the traversal work they took.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    pub camera: u64,
    pub shadow: u64,
    /// Mirror reflections and path-traced bounces.
    pub secondary: u64,
    pub traversal: TraversalStats,
    /// Work skipped by specialisation: shadow rays not traced because their light sample
    /// adds nothing whether lit or not, and packets answered by the scene-bounds test.
    pub shadow_culled: u64,
    pub packets_outside: u64,
    /// Packets traced, by kind, and their active lanes (zero on the scalar path).
    pub camera_packets: LaneUse,
    pub shadow_packets: LaneUse,
    pub mirror_packets: LaneUse,
}

/// Packets of one ray kind and the lanes that held a ray.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LaneUse {
    pub packets: u64,
    pub lanes: u64,
}

impl LaneUse {
    #[inline]
    pub fn record(&mut self, active: u32) {
        self.packets += 1;
        self.lanes += active.count_ones() as u64;
    }

    pub fn add(&mut self, o: &LaneUse) {
        self.packets += o.packets;
        self.lanes += o.lanes;
    }

    /// Active lanes / lanes, for packets `width` wide (`None` without packets).
    pub fn occupancy(&self, width: u32) -> Option<f64> {
        (self.packets > 0).then(|| self.lanes as f64 / (self.packets * width as u64) as f64)
    }
}

impl RayCounts {
    pub fn total(&self) -> u64 {
        self.camera + self.shadow + self.secondary
    }

    pub fn add(&mut self, o: &RayCounts) {
        self.camera += o.camera;
        self.shadow += o.shadow;
        self.secondary += o.secondary;
        self.shadow_culled += o.shadow_culled;
        self.packets_outside += o.packets_outside;
        self.traversal.add(&o.traversal);
        self.camera_packets.add(&o.camera_packets);
        self.shadow_packets.add(&o.shadow_packets);
        self.mirror_packets.add(&o.mirror_packets);
    }
}

/// Where a ray met a surface.
#[derive(Clone, Copy, Debug)]
pub struct Surface {
    /// The hit point, recomputed from the primitive, with its error bound.
    pub point: ErrorPoint,
    /// Unit geometric normal flipped to face the incoming ray (surfaces are two-sided).
    pub normal: Vec3,
    /// The ray arrived on the side the outward normal points to.
    pub front_face: bool,
    pub object: u32,
}

/// The scalar tracer over one scene and its acceleration structure.
pub struct Tracer<'a> {
    pub scene: &'a Scene,
    pub accel: &'a Accel,
    /// Where every random number comes from (`--sampler`, `--seed`).
    pub sampler: Sampler,
    /// Skip work that cannot change the image (`design.md` §6; `--no-specialize` turns
    /// it off): shadow rays of light samples that add nothing lit or not, and packets
    /// that miss the scene's bounds. The image is the same bits either way.
    pub specialize: bool,
}

impl<'a> Tracer<'a> {
    /// A tracer with the independent sampler (the seed's random numbers).
    pub fn new(scene: &'a Scene, accel: &'a Accel, seed: u32) -> Self {
        Self::with_sampler(scene, accel, Sampler::independent(seed))
    }

    pub fn with_sampler(scene: &'a Scene, accel: &'a Accel, sampler: Sampler) -> Self {
        Self {
            scene,
            accel,
            sampler,
            specialize: true,
        }
    }

    /// The colour of camera sample `sample` of pixel (x, y).
    pub fn sample(&self, x: u32, y: u32, sample: u32, counts: &mut RayCounts) -> Vec3 {
        let key = self.sampler.key(x, y, sample);
        let jx = key.uniform(0, slot::JITTER_X);
        let jy = key.uniform(0, slot::JITTER_Y);
        let ray = self.scene.camera.ray(x, y, jx, jy);
        counts.camera += 1;
        self.trace(ray, key, counts)
    }

    #[inline]
    pub fn closest_hit(&self, ray: &Ray, counts: &mut RayCounts) -> Option<Hit> {
        self.accel
            .closest_hit(self.scene, ray, T_MIN, f32::INFINITY, &mut counts.traversal)
    }

    /// Position, facing normal and side of a hit.
    pub fn surface(&self, ray: &Ray, hit: &Hit) -> Surface {
        let on_ray = ray.at(hit.t);
        let i = hit.index as usize;
        let scene = self.scene;
        let (point, outward) = match hit.kind {
            PrimKind::Sphere => {
                let (c, r) = (scene.spheres.center(i), scene.spheres.radius[i]);
                let p = sphere_point(c, r, on_ray);
                (p, scene.spheres.normal(i, p.point))
            }
            PrimKind::Quad => {
                let q = scene.quads.get(i);
                (planar_point(q.corner, q.u, q.v, q.w, on_ray), q.normal)
            }
            PrimKind::Triangle => {
                let [a, b, c] = scene.triangles.vertices(i);
                let (u, v) = (b - a, c - a);
                let n = u.cross(v);
                let p = planar_point(a, u, v, n / n.dot(n), on_ray);
                (p, scene.triangles.normal(i))
            }
        };
        let front_face = ray.dir.dot(outward) < 0.0;
        Surface {
            point,
            normal: if front_face { outward } else { -outward },
            front_face,
            object: hit.object,
        }
    }

    /// The colour a camera ray sees; path-traced materials continue the path up to
    /// `max_depth`.
    pub fn trace(&self, ray: Ray, key: SampleKey, counts: &mut RayCounts) -> Vec3 {
        self.trace_from(ray, key, Vec3::ONE, 0, self.scene.max_depth, counts)
    }

    /// `trace` from path vertex `vertex` with `depth` bounces left and the path's
    /// `throughput` so far (the packet tracer hands path-traced lanes over here).
    pub fn trace_from(
        &self,
        mut ray: Ray,
        key: SampleKey,
        mut throughput: Vec3,
        mut vertex: u32,
        mut depth: u32,
        counts: &mut RayCounts,
    ) -> Vec3 {
        let scene = self.scene;
        loop {
            if depth == 0 {
                return Vec3::ZERO;
            }
            let Some(hit) = self.closest_hit(&ray, counts) else {
                return throughput * scene.background;
            };
            let surface = self.surface(&ray, &hit);
            let material = scene.material_of(hit.object);
            let next_dir = match *material {
                Material::Light { color, .. } => return throughput * color,
                Material::Phong(ref phong) => {
                    return throughput * self.phong(phong, &ray, &surface, key, vertex, counts)
                }
                Material::PhongMirror { ref phong, index } => {
                    let c =
                        self.phong_mirror(phong, index, &ray, &surface, key, vertex, depth, counts);
                    return throughput * c;
                }
                _ => match scatter(material, &ray, &surface, key, vertex) {
                    Some((attenuation, dir)) => {
                        throughput *= attenuation;
                        dir
                    }
                    // Absorbed by Metal: black (the seed returned the albedo here).
                    None => return Vec3::ZERO,
                },
            };
            ray = spawn_ray(&surface.point, surface.normal, next_dir);
            counts.secondary += 1;
            depth -= 1;
            vertex += 1;
        }
    }

    /// Phong shading at a surface, with shadow rays to every light: one towards a point
    /// light's centre, `AREA_LIGHT_SAMPLES` towards random points of an area light.
    pub fn phong(
        &self,
        m: &Phong,
        ray: &Ray,
        s: &Surface,
        key: SampleKey,
        vertex: u32,
        counts: &mut RayCounts,
    ) -> Vec3 {
        let view = -ray.dir;
        self.phong_with(m, ray, s, |li, k| {
            let l = self.light_direction(s, key, vertex, li, k)?;
            if self.specialize && adds_nothing(s.normal, l, view, m.shininess) {
                counts.shadow_culled += 1;
                return Some((l, false));
            }
            counts.shadow += 1;
            let shadow_ray = spawn_ray(&s.point, s.normal, l);
            let visible = self.accel.light_visible(
                self.scene,
                &shadow_ray,
                T_MIN,
                &self.scene.lights[li],
                &mut counts.traversal,
            );
            Some((l, visible))
        })
    }

    /// The unit direction from a surface to sample `k` of light `li`, or `None` when
    /// the sample is the point itself.
    #[inline]
    pub fn light_direction(
        &self,
        s: &Surface,
        key: SampleKey,
        vertex: u32,
        li: usize,
        k: u32,
    ) -> Option<Vec3> {
        let light = &self.scene.lights[li];
        let target = match light.shape {
            LightShape::Point { center, .. } => center,
            _ => {
                let u = |c| key.uniform(vertex, slot::light(li as u32, k, c));
                light.sample(u(0), u(1), u(2))
            }
        };
        let l = (target - s.point.point).normalize_or_zero();
        (l != Vec3::ZERO).then_some(l)
    }

    /// Shadow ray `k` of light `li` from a surface: the direction to the light sample
    /// and the spawned ray.
    #[inline]
    pub fn shadow_ray(
        &self,
        s: &Surface,
        key: SampleKey,
        vertex: u32,
        li: usize,
        k: u32,
    ) -> Option<(Vec3, Ray)> {
        let l = self.light_direction(s, key, vertex, li, k)?;
        Some((l, spawn_ray(&s.point, s.normal, l)))
    }

    /// Phong shading with the light samples given by `sample(light, k)`: the unit
    /// direction to the sample and whether the shadow ray reaches it, or `None` when the
    /// sample is the point itself. The scalar tracer traces the shadow ray there.
    pub fn phong_with(
        &self,
        m: &Phong,
        ray: &Ray,
        s: &Surface,
        mut sample: impl FnMut(usize, u32) -> Option<(Vec3, bool)>,
    ) -> Vec3 {
        let c = phong_lanes::<f32>(
            &PhongLanes::from_fn(|_| m),
            self.scene,
            V3::splat(s.normal),
            V3::splat(-ray.dir),
            |li, k| match sample(li, k) {
                Some((l, visible)) => (visible as u32, V3::splat(l)),
                None => (0, V3::splat(Vec3::ZERO)),
            },
        );
        c.lane(0)
    }

    /// Phong mixed with one mirror reflection: (1 − F)·Phong + F·reflected, F by Schlick.
    #[allow(clippy::too_many_arguments)]
    pub fn phong_mirror(
        &self,
        m: &Phong,
        index: f32,
        ray: &Ray,
        s: &Surface,
        key: SampleKey,
        vertex: u32,
        budget: u32,
        counts: &mut RayCounts,
    ) -> Vec3 {
        let local = self.phong(m, ray, s, key, vertex, counts);
        let reflected_ray = spawn_ray(&s.point, s.normal, reflect(ray.dir, s.normal).normalize());
        counts.secondary += 1;
        let reflected = self.evaluate_once(&reflected_ray, key, vertex + 1, budget - 1, counts);
        let cosine = (-ray.dir.dot(s.normal)).min(1.0);
        let f = schlick(cosine, index);
        local * (1.0 - f) + reflected * f
    }

    /// What a mirror sees: the hit surface's material evaluated once, its bounce discarded
    /// (Diffuse and Metal give their albedo, Dielectric white), as in the seed. Mirror
    /// chains stop after `budget` reflections (the seed's recursion had no bound).
    fn evaluate_once(
        &self,
        ray: &Ray,
        key: SampleKey,
        vertex: u32,
        budget: u32,
        counts: &mut RayCounts,
    ) -> Vec3 {
        if budget == 0 {
            return Vec3::ZERO;
        }
        let Some(hit) = self.closest_hit(ray, counts) else {
            return self.scene.background;
        };
        let s = self.surface(ray, &hit);
        match *self.scene.material_of(hit.object) {
            Material::Light { color, .. } => color,
            Material::Phong(ref phong) => self.phong(phong, ray, &s, key, vertex, counts),
            Material::PhongMirror { ref phong, index } => {
                self.phong_mirror(phong, index, ray, &s, key, vertex, budget, counts)
            }
            Material::Diffuse { albedo } | Material::Metal { albedo, .. } => albedo,
            Material::Dielectric { .. } => Vec3::ONE,
        }
    }
}

/// Does a light sample add exactly zero to Phong whether it is lit or not? True when
/// N·L ≤ 0 (no diffuse term) and the specular term, computed as `phong_lanes` computes it,
/// is zero. (The seed's specular term is not gated by N·L, so N·L ≤ 0 alone is not
/// enough: a grazing light behind the surface can still add a highlight.) The terms
/// are added to sums that start at +0 and never go negative, so adding +0 or skipping
/// gives the same bits.
#[inline]
pub fn adds_nothing(normal: Vec3, l: Vec3, view: Vec3, shininess: f32) -> bool {
    let n_dot_l = normal.dot(l);
    if n_dot_l > 0.0 {
        return false;
    }
    let r = (normal * (2.0 * n_dot_l) - l).normalize_or_zero();
    r.dot(view).max(0.0).powf(shininess) == 0.0
}

/// The Phong parameters of each lane.
pub struct PhongLanes<L> {
    pub albedo: V3<L>,
    pub ka: L,
    pub kd: L,
    pub ks: L,
    pub shininess: [f32; MAX_WIDTH],
}

impl<L: Lane> PhongLanes<L> {
    /// Lane i shades with `material(i)`.
    #[inline]
    pub fn from_fn<'m>(mut material: impl FnMut(usize) -> &'m Phong) -> Self {
        let mut ms = [Phong::default(); MAX_WIDTH];
        for (i, m) in ms.iter_mut().enumerate().take(L::WIDTH) {
            *m = *material(i);
        }
        Self {
            albedo: V3::from_fn(|i| ms[i].albedo),
            ka: L::from_fn(|i| ms[i].ka),
            kd: L::from_fn(|i| ms[i].kd),
            ks: L::from_fn(|i| ms[i].ks),
            shininess: ms.map(|m| m.shininess),
        }
    }
}

/// glam's `Vec3::normalize_or_zero`, lane-wise: v · (1/√(v·v)) when that reciprocal is
/// finite and positive, else zero.
#[inline(always)]
pub fn normalize_or_zero<L: Lane>(v: V3<L>) -> V3<L> {
    let rcp = L::splat(1.0) / v.dot(v).sqrt();
    let ok = rcp.abs().lt(L::splat(f32::INFINITY)) & rcp.gt(L::splat(0.0));
    V3::select(ok, v.scale(rcp), V3::splat(Vec3::ZERO))
}

/// Phong at the lanes' surfaces (`seed-scenes.md` §3): ambient, plus per light the mean
/// over its samples of the diffuse and specular terms of the samples that see it.
/// `sample(light, k)` gives the lanes lit by sample `k` (a bit mask) and the unit
/// directions to it. The scalar tracer runs it on one lane; `powf` is the same scalar
/// call on every lane. (N·L is clamped by `Lane::max`, which may turn a −0 into +0: the
/// sums it feeds start at +0, so the bits cannot change.)
#[inline]
pub fn phong_lanes<L: Lane>(
    m: &PhongLanes<L>,
    scene: &Scene,
    normal: V3<L>,
    view: V3<L>,
    mut sample: impl FnMut(usize, u32) -> (u32, V3<L>),
) -> V3<L> {
    let zero = V3::splat(Vec3::ZERO);
    let (mut diffuse, mut specular) = (zero, zero);
    for (li, light) in scene.lights.iter().enumerate() {
        let n = light.samples();
        let radiance = V3::<L>::splat(light.radiance);
        let (mut light_diffuse, mut light_specular) = (zero, zero);
        for k in 0..n {
            let (lit, l) = sample(li, k);
            if lit == 0 {
                continue;
            }
            let mask = L::Mask::from_bits(lit);
            let n_dot_l = normal.dot(l);
            let d = light_diffuse + radiance.scale(n_dot_l.max(L::splat(0.0)));
            light_diffuse = V3::select(mask, d, light_diffuse);
            // The seed's specular term is not gated by N·L > 0.
            let r = normalize_or_zero(normal.scale(L::splat(2.0) * n_dot_l) - l);
            let r_dot_v = r.dot(view);
            let spec = L::from_fn(|i| {
                if lit >> i & 1 != 0 {
                    r_dot_v.lane(i).max(0.0).powf(m.shininess[i])
                } else {
                    0.0
                }
            });
            light_specular =
                V3::select(mask, light_specular + radiance.scale(spec), light_specular);
        }
        let n = L::splat(n as f32);
        let mean = |v: V3<L>| V3::new(v.x / n, v.y / n, v.z / n);
        diffuse = diffuse + mean(light_diffuse);
        specular = specular + mean(light_specular);
    }
    let sum = V3::splat(scene.ambient).scale(m.ka) + diffuse.scale(m.kd) + specular.scale(m.ks);
    V3::new(m.albedo.x * sum.x, m.albedo.y * sum.y, m.albedo.z * sum.z)
}

/// The bounce of a path-traced material (Diffuse, Metal, Dielectric): attenuation and new
/// direction, or `None` when Metal absorbs the ray or the material does not scatter.
pub fn scatter(
    m: &Material,
    ray: &Ray,
    s: &Surface,
    key: SampleKey,
    vertex: u32,
) -> Option<(Vec3, Vec3)> {
    match *m {
        Material::Diffuse { albedo } => Some((albedo, diffuse_direction(s.normal, key, vertex))),
        Material::Metal { albedo, fuzz } => {
            metal_direction(ray, s, fuzz, key, vertex).map(|d| (albedo, d))
        }
        Material::Dielectric { index } => {
            Some((Vec3::ONE, dielectric_direction(ray, s, index, key, vertex)))
        }
        _ => None,
    }
}

/// Diffuse bounce: normal + uniform unit vector, the normal itself if that sum vanishes.
fn diffuse_direction(normal: Vec3, key: SampleKey, vertex: u32) -> Vec3 {
    let r = random_unit_vector(
        key.uniform(vertex, slot::SCATTER_A),
        key.uniform(vertex, slot::SCATTER_B),
    );
    let d = normal + r;
    if d.abs().cmplt(Vec3::splat(1e-8)).all() {
        normal
    } else {
        d.normalize()
    }
}

/// Metal bounce: mirror direction plus fuzz; `None` (absorbed) if it points into the surface.
fn metal_direction(ray: &Ray, s: &Surface, fuzz: f32, key: SampleKey, vertex: u32) -> Option<Vec3> {
    let r = random_unit_vector(
        key.uniform(vertex, slot::SCATTER_A),
        key.uniform(vertex, slot::SCATTER_B),
    );
    let d = (reflect(ray.dir, s.normal).normalize() + r * fuzz).normalize_or_zero();
    (d.dot(s.normal) > 0.0).then_some(d)
}

/// Dielectric: reflect on total internal reflection or with Schlick's probability
/// (evaluated with the index ratio, as in the seed), else refract by Snell's law.
fn dielectric_direction(ray: &Ray, s: &Surface, index: f32, key: SampleKey, vertex: u32) -> Vec3 {
    let ratio = if s.front_face { 1.0 / index } else { index };
    let cosine = (-ray.dir.dot(s.normal)).min(1.0);
    let sine = (1.0 - cosine * cosine).max(0.0).sqrt();
    let choice = key.uniform(vertex, slot::SCATTER_CHOICE);
    let reflects = ratio * sine > 1.0 || schlick(cosine, ratio) > choice;
    let refracted = if reflects {
        None
    } else {
        refract(ray.dir, s.normal, ratio)
    };
    refracted
        .unwrap_or_else(|| reflect(ray.dir, s.normal))
        .normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_at_normal_incidence_passes_straight_through() {
        let s = Surface {
            point: ErrorPoint {
                point: Vec3::ZERO,
                error: Vec3::ZERO,
            },
            normal: Vec3::Z,
            front_face: true,
            object: 0,
        };
        let ray = Ray::new(Vec3::Z, -Vec3::Z);
        // Schlick at normal incidence for 1/1.5 is 0.04: any choice above it refracts.
        let mut refracted = 0;
        for i in 0..100 {
            let d = dielectric_direction(&ray, &s, 1.5, SampleKey::from_hash(i), 0);
            if d == -Vec3::Z {
                refracted += 1;
            } else {
                assert_eq!(d, Vec3::Z);
            }
        }
        assert!(refracted > 80, "{refracted}");
    }
}
