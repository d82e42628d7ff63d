//! The scalar reference tracer: one ray at a time, with the seed's shading semantics
//! (`seed-scenes.md` §3–§5).
//!
//! - Phong and PhongMirror return a final colour; Light returns its plain colour.
//! - Diffuse, Metal and Dielectric scatter and the path continues, up to `max_depth`.
//! - Every random number comes from `rng::SampleKey`, addressed by path vertex and slot.
//! - `packet`: the same tracer over 4- and 8-wide packets, image for image the same bits.

mod packet;

pub use packet::footprint;

use crate::accel::cull::{Cone, Cull, CullTargets};
use crate::accel::packet::{PacketHits, MAX_WIDTH};
use crate::accel::{Accel, TraversalStats};
use crate::geometry::spawn::{
    planar_point, planar_point_lanes, spawn_ray, sphere_point, sphere_point_lanes, ErrorPoint,
};
use crate::geometry::sphere::{sphere_normal, SpherePool};
use crate::geometry::{Hit, PrimKind, Ray};
use crate::lanes::{all_equal, set_lanes, Lane, Mask, V3};
use crate::material::{
    random_unit_vector, reflect, reflect_lanes, refract, schlick, schlick_lanes, Material, Phong,
};
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
    /// Camera rays (one a pixel sample).
    pub camera: u64,
    /// Shadow rays traced (one a light sample that is not culled).
    pub shadow: u64,
    /// Mirror reflections and path-traced bounces.
    pub secondary: u64,
    /// Boxes visited and primitives tested by all of them.
    pub traversal: TraversalStats,
    /// Work skipped by specialisation: shadow rays not traced because their light sample
    /// adds nothing whether lit or not, and packets answered at once (they miss the
    /// scene's box, or their tile's camera cone meets nothing).
    pub shadow_culled: u64,
    /// Packets answered without a traversal (see `shadow_culled`).
    pub packets_outside: u64,
    /// Camera rays' tests skipped by their tile's cone (`Tracer::camera_cull`):
    /// primitive tests beside the tree (one a lane), and packets kept out of the tree.
    pub cone_prims: u64,
    /// Camera packets kept out of the tree by their tile's cone (see `cone_prims`).
    pub cone_trees: u64,
    /// Packets traced, by kind, and their active lanes (zero on the scalar path).
    pub camera_packets: LaneUse,
    /// Shadow packets (see `camera_packets`).
    pub shadow_packets: LaneUse,
    /// Mirror packets (see `camera_packets`).
    pub mirror_packets: LaneUse,
}

/// Packets of one ray kind and the lanes that held a ray.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LaneUse {
    /// Packets traced.
    pub packets: u64,
    /// Their active lanes, summed.
    pub lanes: u64,
}

impl LaneUse {
    /// Count one packet with the lanes of `active`.
    #[inline]
    pub fn record(&mut self, active: u32) {
        self.packets += 1;
        self.lanes += active.count_ones() as u64;
    }

    /// Add `o`'s counts to these.
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
    /// Rays of every kind.
    pub fn total(&self) -> u64 {
        self.camera + self.shadow + self.secondary
    }

    /// Add `o`'s counts to these.
    pub fn add(&mut self, o: &RayCounts) {
        self.camera += o.camera;
        self.shadow += o.shadow;
        self.secondary += o.secondary;
        self.shadow_culled += o.shadow_culled;
        self.packets_outside += o.packets_outside;
        self.cone_prims += o.cone_prims;
        self.cone_trees += o.cone_trees;
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

/// The surfaces of a packet's lanes (`Tracer::surface_lanes`).
#[derive(Clone, Copy, Debug)]
pub struct SurfaceLanes<L> {
    pub point: V3<L>,
    /// The points' error bounds.
    pub error: V3<L>,
    /// Unit normals facing the rays.
    pub normal: V3<L>,
    /// The lanes whose ray arrived on the outward side.
    pub front: u32,
}

impl<L: Lane> SurfaceLanes<L> {
    /// Lane `k` as a scalar `Surface` of `object`.
    #[inline]
    pub fn lane(&self, k: usize, object: u32) -> Surface {
        Surface {
            point: ErrorPoint {
                point: self.point.lane(k),
                error: self.error.lane(k),
            },
            normal: self.normal.lane(k),
            front_face: self.front >> k & 1 != 0,
            object,
        }
    }
}

/// The scalar tracer over one scene and its acceleration structure.
pub struct Tracer<'a> {
    pub scene: &'a Scene,
    pub accel: &'a Accel,
    /// Where every random number comes from (`--sampler`, `--seed`).
    pub sampler: Sampler,
    /// Skip work that cannot change the image (`design.md` §6; `--no-specialize` turns
    /// it off): shadow rays of light samples that add nothing lit or not, and packets
    /// that miss the scene's bounds, camera packets' tests their tile's cone rules out
    /// (`camera_cull`). The image is the same bits either way.
    pub specialize: bool,
    /// The packet tracer's per-object tables (`packet::ShadeTables`).
    pub(crate) tables: packet::ShadeTables,
    /// The bounding balls `camera_cull` tests (`None` for the linear scan).
    cull_targets: Option<CullTargets>,
    /// The camera sits strictly inside the scene's bounds: every camera ray meets them,
    /// so camera packets skip that test (`bunny`'s ground sphere holds the camera).
    /// Skipping an early-out never changes a result, only whether it is taken.
    pub camera_inside: bool,
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
            tables: packet::ShadeTables::new(scene),
            cull_targets: CullTargets::new(scene, accel),
            camera_inside: {
                let (o, b) = (scene.camera.origin, &scene.bounds);
                b.min.cmplt(o).all() && o.cmplt(b.max).all()
            },
        }
    }

    /// What the camera rays of the pixels `[x0, x1) × [y0, y1)` may hit, any jitter:
    /// the cone from the camera through the corners of that rectangle of the image plane
    /// holds every one of their rays (`cull::Cone`). `Cull::ALL` when not specialising.
    pub fn camera_cull(&self, x0: u32, y0: u32, x1: u32, y1: u32) -> Cull {
        let Some(targets) = self.cull_targets.as_ref().filter(|_| self.specialize) else {
            return Cull::ALL;
        };
        let c = &self.scene.camera;
        let origin = c.origin.as_dvec3();
        let corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)].map(|(x, y)| {
            c.corner.as_dvec3()
                + c.pixel_du.as_dvec3() * x as f64
                + c.pixel_dv.as_dvec3() * y as f64
                - origin
        });
        match Cone::through(origin, &corners) {
            Some(cone) => targets.cull(&cone),
            None => Cull::ALL,
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
        let (point, outward) = self.point_and_outward(hit, ray.at(hit.t));
        let (normal, front_face) = face_forward::<f32>(V3::splat(ray.dir), V3::splat(outward));
        Surface {
            point,
            normal: normal.lane(0),
            front_face,
            object: hit.object,
        }
    }

    /// The hit point of `hit` rebuilt from its primitive (`on_ray` is the ray's point at
    /// the hit's t), and the primitive's outward unit normal there.
    #[inline]
    fn point_and_outward(&self, hit: &Hit, on_ray: Vec3) -> (ErrorPoint, Vec3) {
        let i = hit.index as usize;
        let scene = self.scene;
        match hit.kind {
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
                let v = V3::<f32>::splat;
                let (p, e, n) = triangle_point(v(a), v(b), v(c), v(on_ray));
                let p = ErrorPoint {
                    point: p.lane(0),
                    error: e.lane(0),
                };
                (p, n.lane(0))
            }
        }
    }

    /// The surfaces of the hits of the lanes of `lanes` (each must have a hit), for rays
    /// with lanes `origin`, `dir`: `surface`'s kernels over lanes. Sphere and triangle
    /// lanes are computed lane-wise; quad lanes one at a time by the scalar code.
    pub fn surface_lanes<L: Lane>(
        &self,
        origin: V3<L>,
        dir: V3<L>,
        hits: &PacketHits<L>,
        lanes: u32,
    ) -> SurfaceLanes<L> {
        let scene = self.scene;
        assert!(lanes & !hits.found == 0, "a shaded lane has a hit");
        let spheres = hits.of_kind(PrimKind::Sphere) & lanes;
        let triangles = hits.of_kind(PrimKind::Triangle) & lanes;
        let index = hits.indices();
        let t = L::select(L::Mask::from_bits(lanes), hits.t, L::splat(0.0));
        let on_ray = origin + dir.scale(t);
        let zero = V3::splat(Vec3::ZERO);
        let (mut point, mut error, mut outward) = (zero, zero, zero);
        if spheres != 0 {
            // Lanes of other kinds take the first sphere lane's sphere (replaced below).
            let i = own_or_first(&index, spheres);
            let pool = &scene.spheres;
            // Most packets hit one sphere (a ground, a mirror): then no gathers.
            let (c, r) = if all_equal(&i, L::WIDTH) {
                let j = i[0];
                let c = Vec3::new(pool.cx[j], pool.cy[j], pool.cz[j]);
                (V3::splat(c), L::splat(pool.radius[j]))
            } else {
                gather_spheres(pool, &i)
            };
            (point, error) = sphere_point_lanes(c, r, on_ray);
            outward = sphere_normal(c, r, point);
        }
        if triangles != 0 {
            // Lanes of other kinds take the first triangle lane's triangle (replaced).
            let i = own_or_first(&index, triangles);
            let pool = &scene.triangles;
            let vertex = |p: &[Vec<f32>; 3]| {
                V3::new(
                    L::from_fn(|k| p[0][i[k]]),
                    L::from_fn(|k| p[1][i[k]]),
                    L::from_fn(|k| p[2][i[k]]),
                )
            };
            let (p, e, n) =
                triangle_point(vertex(&pool.a), vertex(&pool.b), vertex(&pool.c), on_ray);
            let m = L::Mask::from_bits(triangles);
            point = V3::select(m, p, point);
            error = V3::select(m, e, error);
            outward = V3::select(m, n, outward);
        }
        let others = lanes & !spheres & !triangles;
        if others != 0 {
            let mut p = [ErrorPoint {
                point: Vec3::ZERO,
                error: Vec3::ZERO,
            }; MAX_WIDTH];
            let mut n = [Vec3::ZERO; MAX_WIDTH];
            for k in set_lanes(others) {
                let hit = hits.hit(k).expect("a shaded lane has a hit");
                (p[k], n[k]) = self.point_and_outward(&hit, on_ray.lane(k));
            }
            let m = L::Mask::from_bits(others);
            point = V3::select(m, V3::from_fn(|k| p[k].point), point);
            error = V3::select(m, V3::from_fn(|k| p[k].error), error);
            outward = V3::select(m, V3::from_fn(|k| n[k]), outward);
        }
        let (normal, front) = face_forward(dir, outward);
        SurfaceLanes {
            point,
            error,
            normal,
            front: front.bits(),
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
        let target = self.light_target(key, vertex, li, k);
        let (l, valid) = direction_to::<f32>(V3::splat(target), V3::splat(s.point.point));
        valid.then(|| l.lane(0))
    }

    /// Sample `k` of light `li`: a point light's centre, or a random point of an area
    /// light.
    #[inline]
    pub fn light_target(&self, key: SampleKey, vertex: u32, li: usize, k: u32) -> Vec3 {
        let light = &self.scene.lights[li];
        match light.shape {
            LightShape::Point { center, .. } => center,
            _ => {
                let u = |c| key.uniform(vertex, slot::light(li as u32, k, c));
                light.sample(u(0), u(1), u(2))
            }
        }
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
            &PhongLanes::splat(m),
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
        let (d, n) = (V3::splat(ray.dir), V3::splat(s.normal));
        let reflected_ray = spawn_ray(&s.point, s.normal, mirror_direction::<f32>(d, n).lane(0));
        counts.secondary += 1;
        let reflected = self.evaluate_once(&reflected_ray, key, vertex + 1, budget - 1, counts);
        let f = mirror_fresnel::<f32>(d, n, index);
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
    let (normal, l, view) = (V3::splat(normal), V3::splat(l), V3::splat(view));
    adds_nothing_lanes::<f32>(normal, l, view, &[shininess; MAX_WIDTH], 1) != 0
}

/// `adds_nothing` over lanes (the scalar one is this kernel at `f32`): the lanes of
/// `lanes` whose sample adds nothing. `powf` is the same scalar call per lane, made only
/// for lanes with N·L ≤ 0.
#[inline(always)]
pub fn adds_nothing_lanes<L: Lane>(
    normal: V3<L>,
    l: V3<L>,
    view: V3<L>,
    shininess: &[f32; MAX_WIDTH],
    lanes: u32,
) -> u32 {
    let n_dot_l = normal.dot(l);
    let unlit = (!n_dot_l.gt(L::splat(0.0))).bits() & lanes;
    if unlit == 0 {
        return 0;
    }
    let r = normalize_or_zero(normal.scale(L::splat(2.0) * n_dot_l) - l);
    let r_dot_v = r.dot(view);
    // Lanes whose specular term is +0 without a powf (`pow_is_zero`), then powf.
    let mut nothing = pow_is_zero(shininess, r_dot_v) & unlit;
    for k in set_lanes(unlit & !nothing) {
        if r_dot_v.lane(k).max(0.0).powf(shininess[k]) == 0.0 {
            nothing |= 1 << k;
        }
    }
    nothing
}

/// The lanes where `max(r, 0).powf(n)` is +0 for certain, so the specular term needs
/// no powf: those with n·(1 − r) ≥ 112 (n the lane's shininess, r its R·V). For
/// 0 ≤ r < 1, ln r ≤ r − 1 ≤ −112/n, so rⁿ ≤ e⁻¹¹² < 2⁻¹⁶¹, eleven binades below half
/// the smallest subnormal (2⁻¹⁵⁰): powf (glibc: under 1 ulp) rounds it to +0. For r < 0
/// the base is +0 and n > 0 (the product is positive), so powf gives +0. (112 > 160·ln 2
/// leaves room for the product's rounding.) n ≤ 0, r ≥ 1 and NaNs never qualify. The
/// shininess of `bunny`'s mesh (500) and mirror (1000) makes most lanes qualify:
/// `phong_lanes` spent a tenth of its time in powf. A multiply, no division.
#[inline(always)]
fn pow_is_zero<L: Lane>(shininess: &[f32; MAX_WIDTH], r_dot_v: L) -> u32 {
    let n = L::from_fn(|i| shininess[i]);
    (n * (L::splat(1.0) - r_dot_v)).ge(L::splat(112.0)).bits()
}

/// The unit normals facing the rays along `dir` and the lanes that arrived on the side
/// the outward normal points to (`Tracer::surface`'s rule).
#[inline(always)]
pub fn face_forward<L: Lane>(dir: V3<L>, outward: V3<L>) -> (V3<L>, L::Mask) {
    let front = dir.dot(outward).lt(L::splat(0.0));
    (V3::select(front, outward, -outward), front)
}

/// A triangle's hit point (`planar_point` with u = b − a, v = c − a, w = n / n·n),
/// its error bound and its unit normal normalise(n), +y if n has no direction
/// (`TrianglePool::normal`'s rule), n = u × v.
#[inline(always)]
pub fn triangle_point<L: Lane>(
    a: V3<L>,
    b: V3<L>,
    c: V3<L>,
    on_ray: V3<L>,
) -> (V3<L>, V3<L>, V3<L>) {
    let (u, v) = (b - a, c - a);
    let n = u.cross(v);
    let nn = n.dot(n);
    let w = V3::new(n.x / nn, n.y / nn, n.z / nn);
    let (p, e) = planar_point_lanes(a, u, v, w, on_ray);
    // glam's `normalize_or(Vec3::Y)`.
    let rcp = L::splat(1.0) / nn.sqrt();
    let ok = rcp.abs().lt(L::splat(f32::INFINITY)) & rcp.gt(L::splat(0.0));
    (p, e, V3::select(ok, n.scale(rcp), V3::splat(Vec3::Y)))
}

/// glam's `Vec3::normalize`, lane-wise: v · (1/√(v·v)).
#[inline(always)]
pub fn normalize<L: Lane>(v: V3<L>) -> V3<L> {
    v.scale(L::splat(1.0) / v.dot(v).sqrt())
}

/// The unit direction from `point` to `target` and the lanes where it is not zero
/// (`Tracer::light_direction`'s rule).
#[inline(always)]
pub fn direction_to<L: Lane>(target: V3<L>, point: V3<L>) -> (V3<L>, L::Mask) {
    let l = normalize_or_zero(target - point);
    let zero = L::splat(0.0);
    (l, l.x.ne(zero) | l.y.ne(zero) | l.z.ne(zero))
}

/// A PhongMirror's reflection direction: `reflect(d, n)` normalised.
#[inline(always)]
pub fn mirror_direction<L: Lane>(d: V3<L>, n: V3<L>) -> V3<L> {
    normalize(reflect_lanes(d, n))
}

/// A PhongMirror's Fresnel weight: Schlick at cos = min(−d·n, 1).
#[inline(always)]
pub fn mirror_fresnel<L: Lane>(d: V3<L>, n: V3<L>, index: L) -> L {
    schlick_lanes(d.dot(n).flip_sign().min(L::splat(1.0)), index)
}

/// The centres and radii of spheres `i[k]`, lane by lane. Out of line (cold): inlined,
/// the compiler computed it beside the splat of one sphere on every packet.
#[cold]
#[inline(never)]
fn gather_spheres<L: Lane>(pool: &SpherePool, i: &[usize; MAX_WIDTH]) -> (V3<L>, L) {
    let c = V3::new(
        L::from_fn(|k| pool.cx[i[k]]),
        L::from_fn(|k| pool.cy[i[k]]),
        L::from_fn(|k| pool.cz[i[k]]),
    );
    (c, L::from_fn(|k| pool.radius[i[k]]))
}

/// `index[k]` for the lanes `k` of `lanes` (not empty), the first of those lanes' index
/// for the others, so every lane reads a valid primitive.
#[inline(always)]
fn own_or_first(index: &[usize; MAX_WIDTH], lanes: u32) -> [usize; MAX_WIDTH] {
    let first = index[lanes.trailing_zeros() as usize];
    std::array::from_fn(|k| if lanes >> k & 1 != 0 { index[k] } else { first })
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
    /// Every lane shades with `m`.
    #[inline]
    pub fn splat(m: &Phong) -> Self {
        Self {
            albedo: V3::splat(m.albedo),
            ka: L::splat(m.ka),
            kd: L::splat(m.kd),
            ks: L::splat(m.ks),
            shininess: [m.shininess; MAX_WIDTH],
        }
    }

    /// Lane i shades with `table[index[i]]`. Lanes that all name one entry are
    /// splatted (compared as integers: no lookup until the lanes differ).
    #[inline]
    pub fn from_indices(table: &[Phong], index: &[u32; MAX_WIDTH]) -> Self {
        if all_equal(index, L::WIDTH) {
            return Self::splat(&table[index[0] as usize]);
        }
        Self::gather(table, index)
    }

    /// `from_indices` when the lanes differ: out of line, so the common splat is not
    /// computed alongside the gathers.
    #[cold]
    #[inline(never)]
    fn gather(table: &[Phong], index: &[u32; MAX_WIDTH]) -> Self {
        let m = |i: usize| &table[index[i] as usize];
        Self {
            albedo: V3::from_fn(|i| m(i).albedo),
            ka: L::from_fn(|i| m(i).ka),
            kd: L::from_fn(|i| m(i).kd),
            ks: L::from_fn(|i| m(i).ks),
            shininess: std::array::from_fn(|i| if i < L::WIDTH { m(i).shininess } else { 0.0 }),
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
            // powf only where it can be other than +0 (`pow_is_zero`).
            let need = lit & !pow_is_zero(&m.shininess, r_dot_v);
            let spec = if need == 0 {
                L::splat(0.0)
            } else {
                L::from_fn(|i| {
                    if need >> i & 1 != 0 {
                        r_dot_v.lane(i).max(0.0).powf(m.shininess[i])
                    } else {
                        0.0
                    }
                })
            };
            light_specular =
                V3::select(mask, light_specular + radiance.scale(spec), light_specular);
        }
        // x / 1 is x, bit for bit (a point light's one sample): no division then.
        let mean = |v: V3<L>| {
            if n == 1 {
                return v;
            }
            let n = L::splat(n as f32);
            V3::new(v.x / n, v.y / n, v.z / n)
        };
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
    use crate::geometry::spawn::{planar_point_lanes, spawn_origin};
    use glam::Vec4;
    use wide::f32x8;

    /// Where `pow_is_zero` says so, powf is +0: a grid of shininess (112 to 2e6, ∞,
    /// and small, zero, negative, NaN) and R·V (−2 to 1.5, every float just below 1,
    /// NaN), 8-wide and scalar alike. And it does say so often.
    #[test]
    fn pow_is_zero_only_where_powf_is_plus_zero() {
        let mut ns: Vec<f32> = (0..500).map(|i| 112.0 * 1.02f32.powi(i)).collect();
        ns.extend([111.9, 60.0, 1.0, 0.0, -0.0, -3.0, -1e4, f32::INFINITY]);
        ns.extend([f32::NEG_INFINITY, f32::NAN, 500.0, 1000.0]);
        let mut rs: Vec<f32> = (0..=3500).map(|j| -2.0 + j as f32 / 1000.0).collect();
        let mut below_one = 1.0f32;
        for _ in 0..200 {
            below_one = below_one.next_down();
            rs.push(below_one);
        }
        rs.extend([f32::NAN, -0.0, f32::MIN_POSITIVE, 1.0]);
        let (mut skipped, mut kept) = (0u64, 0u64);
        for &n in &ns {
            for chunk in rs.chunks(8) {
                let mut r = [f32::NAN; 8];
                r[..chunk.len()].copy_from_slice(chunk);
                let bits8 = pow_is_zero::<f32x8>(&[n; MAX_WIDTH], f32x8::from(r));
                for (k, &x) in chunk.iter().enumerate() {
                    let zero = pow_is_zero::<f32>(&[n; MAX_WIDTH], x) != 0;
                    assert_eq!(zero, bits8 >> k & 1 != 0, "{x} {n}: 8-wide");
                    if zero {
                        let p = x.max(0.0).powf(n);
                        assert!(p == 0.0 && p.is_sign_positive(), "{x}^{n} = {p}");
                        skipped += 1;
                    } else {
                        kept += 1;
                    }
                }
            }
        }
        assert!(skipped > 1_000_000 && kept > 100_000, "{skipped} {kept}");
    }

    /// A shading kernel over lanes, with `IN` lane inputs and its outputs as lanes.
    trait Kernel {
        const IN: usize;
        fn eval<L: Lane>(x: &[L]) -> Vec<L>;
    }

    /// `IN` × 8·`chunks` inputs: mostly uniform in [−2, 2), one in four an edge value
    /// (±0, ±1, a subnormal, huge, ±∞, NaN), so selects and special cases are hit.
    fn inputs(n_in: usize, chunks: usize) -> Vec<Vec<f32>> {
        let edges = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            1e-40,
            -1e-40,
            1e30,
            -1e30,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MIN_POSITIVE,
        ];
        let mut state = 0x9e37_79b9u32;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state
        };
        (0..n_in)
            .map(|_| {
                (0..8 * chunks)
                    .map(|_| {
                        let r = next();
                        if r % 4 == 0 {
                            edges[(r >> 8) as usize % edges.len()]
                        } else {
                            (r >> 8) as f32 / (1 << 24) as f32 * 4.0 - 2.0
                        }
                    })
                    .collect()
            })
            .collect()
    }

    /// Every output lane of `K` at widths 4 and 8 has the bits of the scalar kernel on
    /// that lane's inputs (any NaN matching any NaN).
    fn check<K: Kernel>(name: &str) {
        let chunks = 2000;
        let x = inputs(K::IN, chunks);
        let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
        for c in 0..chunks {
            let at = |i: usize| -> Vec<f32> { x.iter().map(|v| v[8 * c + i]).collect() };
            let scalar: Vec<Vec<f32>> = (0..8).map(|i| K::eval::<f32>(&at(i))).collect();
            let eight = K::eval::<f32x8>(
                &x.iter()
                    .map(|v| f32x8::from_fn(|i| v[8 * c + i]))
                    .collect::<Vec<_>>(),
            );
            for half in 0..2 {
                let four = K::eval::<Vec4>(
                    &x.iter()
                        .map(|v| <Vec4 as Lane>::from_fn(|i| v[8 * c + 4 * half + i]))
                        .collect::<Vec<_>>(),
                );
                for (o, (w4, w8)) in four.iter().zip(&eight).enumerate() {
                    for i in 0..4 {
                        let k = 4 * half + i;
                        let want = scalar[k][o];
                        assert!(
                            same(w4.lane(i), want) && same(w8.lane(k), want),
                            "{name}: output {o}, lane {k}, inputs {:?}: scalar {want:e}, \
                             4 wide {:e}, 8 wide {:e}",
                            at(k),
                            w4.lane(i),
                            w8.lane(k),
                        );
                    }
                }
            }
        }
    }

    fn v3<L: Lane>(x: &[L]) -> V3<L> {
        V3::new(x[0], x[1], x[2])
    }

    fn out<L: Lane>(vs: &[V3<L>]) -> Vec<L> {
        vs.iter().flat_map(|v| [v.x, v.y, v.z]).collect()
    }

    fn mask<L: Lane>(m: L::Mask) -> L {
        L::select(m, L::splat(1.0), L::splat(0.0))
    }

    fn bits<L: Lane>(b: u32) -> L {
        L::from_fn(|i| (b >> i & 1) as f32)
    }

    #[test]
    fn sphere_point_and_normal_lanes_match_the_scalar_kernels() {
        struct K;
        impl Kernel for K {
            const IN: usize = 7;
            fn eval<L: Lane>(x: &[L]) -> Vec<L> {
                let (c, r, hit) = (v3(x), x[3], v3(&x[4..]));
                let (p, e) = sphere_point_lanes(c, r, hit);
                out(&[p, e, sphere_normal(c, r, p)])
            }
        }
        check::<K>("sphere_point, sphere_normal");
    }

    #[test]
    fn triangle_point_lanes_match_the_scalar_kernel() {
        struct K;
        impl Kernel for K {
            const IN: usize = 12;
            fn eval<L: Lane>(x: &[L]) -> Vec<L> {
                let v = |i: usize| v3(&x[3 * i..]);
                let (p, e, n) = triangle_point(v(0), v(1), v(2), v(3));
                out(&[p, e, n])
            }
        }
        check::<K>("triangle_point");
        // The scalar surface's triangle normal is the pool's rule.
        let n = triangle_point::<f32>(
            V3::splat(Vec3::ZERO),
            V3::splat(Vec3::X),
            V3::splat(Vec3::Y),
            V3::splat(Vec3::ZERO),
        )
        .2;
        assert_eq!(n.lane(0), Vec3::Z);
    }

    #[test]
    fn planar_point_lanes_match_the_scalar_kernel() {
        struct K;
        impl Kernel for K {
            const IN: usize = 15;
            fn eval<L: Lane>(x: &[L]) -> Vec<L> {
                let v = |i: usize| v3(&x[3 * i..]);
                let (p, e) = planar_point_lanes(v(0), v(1), v(2), v(3), v(4));
                out(&[p, e])
            }
        }
        check::<K>("planar_point");
    }

    #[test]
    fn spawn_origin_lanes_match_the_scalar_kernel() {
        struct K;
        impl Kernel for K {
            const IN: usize = 12;
            fn eval<L: Lane>(x: &[L]) -> Vec<L> {
                let v = |i: usize| v3(&x[3 * i..]);
                // Error bounds are small and not negative, as the hit points give them.
                let e = v(1);
                let small = L::splat(1e-6);
                let error = V3::new(e.x.abs() * small, e.y.abs() * small, e.z.abs() * small);
                out(&[spawn_origin(v(0), error, v(2), v(3))])
            }
        }
        check::<K>("spawn_origin");
        // The scalar `spawn_ray` is the kernel at f32: its origin moves off the surface.
        let p = ErrorPoint {
            point: Vec3::new(0.5, 0.0, -0.0),
            error: Vec3::new(1e-7, 0.0, 1e-7),
        };
        let r = spawn_ray(&p, Vec3::Z, Vec3::new(0.0, 0.6, 0.8));
        assert_eq!(r.origin.x, 0.5);
        assert!(r.origin.z > 0.0);
    }

    #[test]
    fn facing_light_and_mirror_lanes_match_the_scalar_kernels() {
        struct K;
        impl Kernel for K {
            const IN: usize = 10;
            fn eval<L: Lane>(x: &[L]) -> Vec<L> {
                let (a, b) = (v3(x), v3(&x[3..]));
                let (n, front) = face_forward(a, b);
                let (l, valid) = direction_to(a, b);
                let index = x[6].abs();
                let mut o = out(&[n, l, normalize(a), mirror_direction(a, b)]);
                o.extend([mask::<L>(front), mask::<L>(valid)]);
                o.push(mirror_fresnel(a, b, index));
                o.push(schlick_lanes(x[7], index));
                let shininess: [f32; MAX_WIDTH] =
                    std::array::from_fn(|i| x[8].lane(i.min(L::WIDTH - 1)).abs() * 500.0);
                let view = v3(&x[7..]);
                let lanes = (1u32 << L::WIDTH) - 1;
                o.push(bits::<L>(adds_nothing_lanes(a, b, view, &shininess, lanes)));
                o
            }
        }
        check::<K>("face_forward, direction_to, mirror, schlick, adds_nothing");
    }

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
