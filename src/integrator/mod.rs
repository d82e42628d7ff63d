//! The tracer: the original program's shading semantics over lanes, one ray (the scalar
//! reference) or a 4- or 8-wide packet at a time, image for image the same bits.
//!
//! - `shade`: the control flow of a path, vertex by vertex, and Phong with its light
//!   samples and shadow rays; `scatter`: the path-traced materials' bounces.
//! - Here: the tracer, its ray counts, the surfaces of hits, and the geometric kernels
//!   shading runs on (written over `Lane`; the scalar tracer runs them at `f32`).
//! - Every random number comes from `sampling::KeyLanes`, addressed by path vertex and slot.
//!
//! One file past 700 lines (120 of them tests): the tracer's state and the surface
//! kernels every shading path calls.

mod regroup;
mod scatter;
mod shade;

pub use regroup::{Regrouped, Regrouping};
pub use scatter::{random_unit_vector_lanes, scatter};
pub use shade::{footprint, PacketPixels};

use crate::accel::cull::{Cone, Cull, CullTargets};
use crate::accel::packet::PacketHits;
use crate::accel::shadow::ShadowBoxes;
use crate::accel::{Accel, Context, TraversalStats};
use crate::geometry::spawn::{planar_point_lanes, spawn_ray, sphere_point_lanes, ErrorPoint};
use crate::geometry::sphere::SpherePool;
use crate::geometry::QuadPool;
use crate::geometry::{Hit, PrimKind, Ray};
use crate::lanes::MAX_WIDTH;
use crate::lanes::{all_equal, Lane, Mask, V3};
use crate::material::{reflect_lanes, schlick_lanes, Phong};
use crate::sampling::{KeyLanes, SampleKey, Sampler};
use crate::scene::Scene;
use glam::Vec3;

/// Rays accept hits at t > 0 (the smallest positive normal float; the tests compare with
/// `>=`): secondary rays start off their surface by the hit point's error bound
/// (`geometry::spawn`) instead of the original program's t_min = 1e-4. A surface whose
/// error bound is zero (a wall in the plane x = 0) yields t = 0 for its own spawned rays,
/// excluded here.
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
    /// Packets answered without a traversal (see `shadow_culled`). At width 1 a packet
    /// is one ray: each camera sample of a tile whose cone meets nothing counts once.
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
    /// Mirror reflections and path-traced bounces.
    pub secondary_packets: LaneUse,
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
        self.secondary_packets.add(&o.secondary_packets);
    }
}

/// Where a ray met a surface.
#[derive(Clone, Copy, Debug)]
pub struct Surface {
    /// The hit point, recomputed from the primitive, with its error bound.
    pub point: ErrorPoint,
    /// Unit geometric normal flipped to face the incoming ray (surfaces are two-sided):
    /// it decides sides and where spawned rays start.
    pub normal: Vec3,
    /// Unit shading normal on the side of `normal`: `normal` itself but on a smooth
    /// mesh, where it is the interpolated vertex normal.
    pub shading: Vec3,
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
    /// Unit geometric normals facing the rays: they decide sides and where spawned rays
    /// start.
    pub normal: V3<L>,
    /// Unit shading normals, each on the side of its lane's `normal`: the same bits but
    /// in the lanes of `smooth`.
    pub shading: V3<L>,
    /// The lanes on a smooth mesh, whose shading normal is interpolated.
    pub smooth: u32,
    /// The lanes whose ray arrived on the outward side.
    pub front: u32,
}

impl<L: Lane> SurfaceLanes<L> {
    /// Surfaces whose shading normal is their geometric one.
    #[inline(always)]
    pub fn flat(point: V3<L>, error: V3<L>, normal: V3<L>, front: u32) -> Self {
        Self {
            point,
            error,
            normal,
            shading: normal,
            smooth: 0,
            front,
        }
    }

    /// A scalar `Surface` as one lane.
    #[inline(always)]
    pub fn from_surface(s: &Surface) -> Self {
        Self {
            point: V3::splat(s.point.point),
            error: V3::splat(s.point.error),
            normal: V3::splat(s.normal),
            shading: V3::splat(s.shading),
            smooth: (s.shading != s.normal) as u32,
            front: s.front_face as u32,
        }
    }
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
            shading: self.shading.lane(k),
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
    /// Skip work that cannot change the image (ARCHITECTURE.md, "Specialisation";
    /// `--no-specialize` turns it off): shadow rays of light samples that add nothing lit
    /// or not, and packets that miss the scene's bounds, camera packets' tests their
    /// tile's cone rules out (`camera_cull`), the rays of a tile (of packets or single
    /// rays) whose cone meets nothing. The image is the same bits either way.
    pub specialize: bool,
    /// The per-object tables shading sorts lanes by (`shade::ShadeTables`).
    pub(crate) tables: shade::ShadeTables,
    /// The bounding balls `camera_cull` tests (`None` for the linear scan).
    cull_targets: Option<CullTargets>,
    /// The primitives' boxes that rule out occluders for a shaded packet's shadow rays
    /// to an area light (`accel::shadow`; `None` for the linear scan, for scenes without
    /// an area light and for scenes of more than `shadow::MAX_PRIMITIVES`).
    pub(crate) shadow_boxes: Option<ShadowBoxes>,
    /// The camera (with a lens, every point of its lens disk) sits strictly inside the
    /// scene's bounds: every camera ray meets them, so camera packets skip that test
    /// (`bunny`'s ground sphere holds the camera).
    /// Skipping an early-out never changes a result, only whether it is taken.
    pub camera_inside: bool,
    /// Packets test boxes (a tree, or the shadow candidates'): their rays need the box
    /// constants (`RayPacket::from_active_lanes_with`). Else the packets skip the test
    /// against the scene's bounds too, an early-out that seldom pays without a tree.
    pub(crate) packet_boxes: bool,
}

impl<'a> Tracer<'a> {
    /// A tracer with the independent sampler (the original program's random numbers).
    pub fn new(scene: &'a Scene, accel: &'a Accel, seed: u32) -> Self {
        Self::with_sampler(scene, accel, Sampler::independent(seed))
    }

    pub fn with_sampler(scene: &'a Scene, accel: &'a Accel, sampler: Sampler) -> Self {
        let shadow_boxes = match accel.bvh() {
            Some(b) if scene.lights.iter().any(|l| !l.is_point()) => ShadowBoxes::new(scene)
                .or_else(|| {
                    let tree = b.root.map(|_| b.tree_box);
                    ShadowBoxes::beside(scene, &b.linear, tree)
                }),
            _ => None,
        };
        Self {
            scene,
            accel,
            sampler,
            specialize: true,
            tables: shade::ShadeTables::new(scene),
            cull_targets: CullTargets::new(scene, accel),
            packet_boxes: accel.packet_boxes() || shadow_boxes.is_some(),
            shadow_boxes,
            camera_inside: {
                // Every lens point: the ball of `lens_reach` around the lens's centre.
                let (o, b) = (scene.camera.origin.as_dvec3(), &scene.bounds);
                let reach = glam::DVec3::splat(scene.camera.lens_reach());
                b.min.as_dvec3().cmplt(o - reach).all() && (o + reach).cmplt(b.max.as_dvec3()).all()
            },
        }
    }

    /// What the camera rays of the pixels `[x0, x1) × [y0, y1)` may hit, any jitter and
    /// any lens point: the cone from the camera through the corners of that rectangle of
    /// the viewport, widened by the f32 rounding of the rays and by the lens (its apex
    /// moved back so that it holds the lens disk), holds every one of their rays
    /// (`cull::Cone::through_lens`). `Cull::ALL` when not specialising.
    pub fn camera_cull(&self, x0: u32, y0: u32, x1: u32, y1: u32) -> Cull {
        let Some(targets) = self.cull_targets.as_ref().filter(|_| self.specialize) else {
            return Cull::ALL;
        };
        let c = &self.scene.camera;
        let corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)].map(|(x, y)| {
            c.corner.as_dvec3()
                + c.pixel_du.as_dvec3() * x as f64
                + c.pixel_dv.as_dvec3() * y as f64
        });
        let cone = Cone::through_lens(
            c.origin.as_dvec3(),
            c.lens_reach(),
            &corners,
            c.viewport_error(),
        );
        match cone {
            Some(cone) => targets.cull(&cone),
            None => Cull::ALL,
        }
    }

    /// The colour of camera sample `sample` of pixel (x, y): `sample_packet` at `f32`.
    pub fn sample(&self, x: u32, y: u32, sample: u32, counts: &mut RayCounts) -> Vec3 {
        self.sample_packet::<f32>(x, y, 1, sample, Cull::ALL, counts)
            .lane(0)
    }

    #[inline]
    pub fn closest_hit(&self, ray: &Ray, counts: &mut RayCounts) -> Option<Hit> {
        let cx = Context::new(self.scene, &mut counts.traversal);
        self.accel
            .closest_hit_inlined(cx, ray, T_MIN, f32::INFINITY)
    }

    /// Position, facing normals and side of a hit (`surface_lanes`' rules).
    pub fn surface(&self, ray: &Ray, hit: &Hit) -> Surface {
        let on_ray = ray.at(hit.t);
        let (point, outward) = self.point_and_outward(hit, on_ray);
        let (normal, front_face) = face_forward::<f32>(V3::splat(ray.dir), V3::splat(outward));
        let i = hit.index as usize;
        let smooth = match hit.kind {
            PrimKind::Triangle => self.scene.triangle_normals(hit.object, i),
            _ => None,
        };
        let shading = match smooth {
            Some(corners) => {
                let n = corners.map(V3::splat);
                let [a, b, c] = (self.scene).triangle_vertices(hit.object, i).map(V3::splat);
                let s = smooth_normal::<f32>(a, b, c, n, V3::splat(on_ray));
                on_side(s, normal)
            }
            None => normal,
        };
        Surface {
            point,
            normal: normal.lane(0),
            shading: shading.lane(0),
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
                let (c, r) = (scene.spheres.center(i), scene.spheres.radius(i));
                let (p, e, n) = sphere_point_lanes::<f32>(V3::splat(c), r, V3::splat(on_ray));
                let p = ErrorPoint {
                    point: p.lane(0),
                    error: e.lane(0),
                };
                (p, n.lane(0))
            }
            PrimKind::Quad => {
                let q = scene.quads.frame(i);
                let v = V3::<f32>::splat;
                let (p, e) = planar_point_lanes(v(q.corner), v(q.u), v(q.v), v(q.w), v(on_ray));
                let p = ErrorPoint {
                    point: p.lane(0),
                    error: e.lane(0),
                };
                (p, q.normal)
            }
            PrimKind::Triangle => {
                let [a, b, c] = scene.triangle_vertices(hit.object, i);
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
    /// with lanes `origin`, `dir`: `surface`'s kernels over lanes, each kind's lanes at
    /// once (one primitive splatted when all its lanes hit the same one).
    pub fn surface_lanes<L: Lane>(
        &self,
        origin: V3<L>,
        dir: V3<L>,
        hits: &PacketHits<L>,
        lanes: u32,
    ) -> SurfaceLanes<L> {
        let scene = self.scene;
        debug_assert!(lanes & !hits.found == 0, "a shaded lane has a hit");
        let spheres = hits.of_kind(PrimKind::Sphere) & lanes;
        let quads = hits.of_kind(PrimKind::Quad) & lanes;
        let triangles = hits.of_kind(PrimKind::Triangle) & lanes;
        let t = L::select(L::Mask::from_bits(lanes), hits.t, L::splat(0.0));
        let on_ray = origin + dir.scale(t);
        let zero = V3::splat(Vec3::ZERO);
        let (mut point, mut error, mut outward) = (zero, zero, zero);
        if spheres != 0 {
            let pool = &scene.spheres;
            // Most packets hit one sphere (a ground, a mirror): then no gathers. Else
            // lanes of other kinds take the first sphere lane's sphere (replaced below).
            let (c, r) = match hits.same_index(spheres) {
                Some(j) => (V3::splat(pool.center(j)), L::splat(pool.radius(j))),
                None => gather_spheres(pool, &own_or_first(&hits.indices(), spheres)),
            };
            (point, error, outward) = sphere_point_lanes(c, r, on_ray);
        }
        if quads != 0 {
            let pool = &scene.quads;
            let (q, u, v, w, n) = match hits.same_index(quads) {
                Some(j) => {
                    let (q, s) = (pool.frame(j), V3::splat);
                    (s(q.corner), s(q.u), s(q.v), s(q.w), s(q.normal))
                }
                None => gather_quads(pool, &own_or_first(&hits.indices(), quads)),
            };
            let (p, e) = planar_point_lanes(q, u, v, w, on_ray);
            let m = L::Mask::from_bits(quads);
            point = V3::select(m, p, point);
            error = V3::select(m, e, error);
            outward = V3::select(m, n, outward);
        }
        if triangles != 0 {
            // Lanes of other kinds take the first triangle lane's triangle (replaced).
            let i = own_or_first(&hits.indices(), triangles);
            let [a, b, c] = if scene.instances.is_empty() {
                let pool = &scene.triangles;
                let vertex = |p: &[Vec<f32>; 3]| {
                    V3::new(
                        L::from_fn(|k| p[0][i[k]]),
                        L::from_fn(|k| p[1][i[k]]),
                        L::from_fn(|k| p[2][i[k]]),
                    )
                };
                [vertex(&pool.a), vertex(&pool.b), vertex(&pool.c)]
            } else {
                world_triangles(scene, &own_or_first(&hits.objects(), triangles), &i)
            };
            let (p, e, n) = triangle_point(a, b, c, on_ray);
            let m = L::Mask::from_bits(triangles);
            point = V3::select(m, p, point);
            error = V3::select(m, e, error);
            outward = V3::select(m, n, outward);
        }
        let (normal, front) = face_forward(dir, outward);
        let mut s = SurfaceLanes::flat(point, error, normal, front.bits());
        if triangles != 0 && scene.has_smooth_triangles() {
            let i = own_or_first(&hits.indices(), triangles);
            let objects = own_or_first(&hits.objects(), triangles);
            let normals: [Option<[Vec3; 3]>; MAX_WIDTH] = std::array::from_fn(|k| {
                (k < L::WIDTH)
                    .then(|| scene.triangle_normals(objects[k], i[k]))
                    .flatten()
            });
            let smooth =
                triangles & (0..L::WIDTH).fold(0, |m, k| m | (normals[k].is_some() as u32) << k);
            if smooth != 0 {
                let [a, b, c] = world_triangles(scene, &objects, &i);
                let corner = |c: usize| V3::from_fn(|k| normals[k].map_or(Vec3::ZERO, |n| n[c]));
                let n = smooth_normal(a, b, c, [corner(0), corner(1), corner(2)], on_ray);
                s.shading = V3::select(L::Mask::from_bits(smooth), on_side(n, normal), normal);
                s.smooth = smooth;
            }
        }
        s
    }

    /// The colour a ray sees, as a camera sees it (path-traced materials continue the
    /// path up to `max_depth`), with the random numbers of `key`.
    pub fn trace(&self, ray: Ray, key: SampleKey, counts: &mut RayCounts) -> Vec3 {
        self.trace_ray(ray, &KeyLanes::from_keys(&[key]), counts)
    }

    /// Phong shading at a surface seen along `ray`, with shadow rays to every light:
    /// one towards a point light's centre, `AREA_LIGHT_SAMPLES` towards random points of
    /// an area light. `Tracer::phong_lanes` at `f32`.
    pub fn phong(
        &self,
        m: &Phong,
        ray: &Ray,
        s: &Surface,
        key: SampleKey,
        vertex: u32,
        counts: &mut RayCounts,
    ) -> Vec3 {
        let surface = SurfaceLanes::from_surface(s);
        let keys = KeyLanes::from_keys(&[key]);
        let view = -V3::<f32>::splat(ray.dir);
        self.phong_lanes(
            &PhongLanes::splat(m),
            &surface,
            view,
            &keys,
            vertex,
            1,
            counts,
        )
        .lane(0)
    }

    /// Sample `k` of light `li` at path vertex `vertex`: a point light's centre, or a
    /// random point of an area light.
    pub fn light_target(&self, key: SampleKey, vertex: u32, li: usize, k: u32) -> Vec3 {
        let keys = KeyLanes::from_keys(&[key]);
        shade::light_targets::<f32>(&self.scene.lights[li], li as u32, k, &keys, vertex).lane(0)
    }

    /// Shadow ray `k` of light `li` from a surface: the unit direction to the light
    /// sample and the spawned ray, or `None` when the sample is the point itself.
    pub fn shadow_ray(
        &self,
        s: &Surface,
        key: SampleKey,
        vertex: u32,
        li: usize,
        k: u32,
    ) -> Option<(Vec3, Ray)> {
        let target = self.light_target(key, vertex, li, k);
        let (l, valid) = direction_to::<f32>(V3::splat(target), V3::splat(s.point.point));
        valid.then(|| (l.lane(0), spawn_ray(&s.point, s.normal, l.lane(0))))
    }
}

/// The lanes where `pow(max(r, 0), n)` is +0 for certain, so the specular term needs
/// no pow: those with n·(1 − r) ≥ 112 (n the lane's shininess, r its R·V). For
/// 0 ≤ r < 1, ln r ≤ r − 1 ≤ −112/n, so rⁿ ≤ e⁻¹¹² < 2⁻¹⁶¹, eleven binades below half
/// the smallest subnormal (2⁻¹⁵⁰): `lanes::math::pow` (within one ulp) rounds it to +0.
/// For r < 0 the base is +0 and n > 0 (the product is positive), so pow gives +0.
/// (112 > 160·ln 2 leaves room for the product's rounding.) n ≤ 0, r ≥ 1 and NaNs never
/// qualify. The shininess of `bunny`'s mesh (500) and mirror (1000) makes most lanes
/// qualify. A multiply, no division.
#[inline(always)]
fn pow_is_zero<L: Lane>(shininess: L, r_dot_v: L) -> u32 {
    (shininess * (L::splat(1.0) - r_dot_v))
        .ge(L::splat(112.0))
        .bits()
}

/// The world vertices of each lane's triangle (`objects[k]`'s triangle `index[k]`:
/// `Scene::triangle_vertices`), as lanes a, b, c.
#[inline(always)]
fn world_triangles<L: Lane>(
    scene: &Scene,
    objects: &[u32; MAX_WIDTH],
    index: &[usize; MAX_WIDTH],
) -> [V3<L>; 3] {
    // Lanes on the triangle of the lane before (a packet's neighbours) reuse its
    // vertices: each is moved in f64 once.
    let mut v = [[Vec3::ZERO; 3]; MAX_WIDTH];
    for k in 0..L::WIDTH {
        v[k] = if k > 0 && objects[k] == objects[k - 1] && index[k] == index[k - 1] {
            v[k - 1]
        } else {
            scene.triangle_vertices(objects[k], index[k])
        };
    }
    [0, 1, 2].map(|c| V3::from_fn(|k| v[k][c]))
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

/// The shading normal of a smooth triangle a, b, c with unit corner normals `n` at
/// `on_ray`: the corner normals weighted by the point's barycentric coordinates
/// (`planar_point`'s α and β) and normalised (`normals = "smooth"`).
#[inline(always)]
pub fn smooth_normal<L: Lane>(a: V3<L>, b: V3<L>, c: V3<L>, n: [V3<L>; 3], on_ray: V3<L>) -> V3<L> {
    let (u, v) = (b - a, c - a);
    let cross = u.cross(v);
    let nn = cross.dot(cross);
    let w = V3::new(cross.x / nn, cross.y / nn, cross.z / nn);
    let hp = on_ray - a;
    let alpha = w.dot(hp.cross(v));
    let beta = w.dot(u.cross(hp));
    let gamma = L::splat(1.0) - alpha - beta;
    let s = n[0].scale(gamma) + n[1].scale(alpha) + n[2].scale(beta);
    // Corner normals that cancel (opposed vertex normals): the geometric one.
    let unit = normalize_or_zero(s);
    let none = unit.dot(unit).eq(L::splat(0.0));
    V3::select(none, cross.scale(L::splat(1.0) / nn.sqrt()), unit)
}

/// `n` flipped, where needed, onto the side of `facing` (a shading normal onto the side
/// of the geometric normal that faces the ray: vertex normals may be wound either way).
#[inline(always)]
pub fn on_side<L: Lane>(n: V3<L>, facing: V3<L>) -> V3<L> {
    V3::select(n.dot(facing).lt(L::splat(0.0)), -n, n)
}

/// `d` reflected across the plane of `normal` where it points to the side `toward`
/// says it must not: a direction made about a shading normal that crossed the geometric
/// surface is brought back to the side it belongs to (energy kept, no leak through the
/// surface). `toward` holds the lanes whose direction must leave on `normal`'s side;
/// the others must go through. Only the lanes of `lanes` change.
#[inline(always)]
pub fn onto_side<L: Lane>(d: V3<L>, normal: V3<L>, toward: u32, lanes: u32) -> V3<L> {
    if lanes == 0 {
        return d;
    }
    let dn = d.dot(normal);
    let out = dn.gt(L::splat(0.0)).bits();
    let wrong = lanes & ((toward & !out) | (!toward & dn.ge(L::splat(0.0)).bits()));
    if wrong == 0 {
        return d;
    }
    V3::select(L::Mask::from_bits(wrong), d - normal.scale(dn + dn), d)
}

/// glam's `Vec3::normalize`, lane-wise: v · (1/√(v·v)).
#[inline(always)]
pub fn normalize<L: Lane>(v: V3<L>) -> V3<L> {
    v.scale(L::splat(1.0) / v.dot(v).sqrt())
}

/// Phong's R·V from N·L, N·V and L·V, at most 1: R = 2 (N·L) N − L is a unit vector
/// already when N and L are, so R·V = 2 (N·L)(N·V) − L·V, without making or normalising
/// R. Rounding can carry that past 1 (by up to about 48u, u = 2⁻²⁴, for vectors within
/// 5u of unit length; by more for a normal that strays further, as one made from a
/// subnormal cross product can), and the shininess would raise the excess to a power:
/// it is clamped to 1, which R·V of unit vectors never passes.
/// `tests::specular_cosine_is_at_most_one` checks it.
#[inline(always)]
pub fn specular_cosine<L: Lane>(n_dot_l: L, n_dot_v: L, l_dot_v: L) -> L {
    (L::splat(2.0) * n_dot_l * n_dot_v - l_dot_v).min(L::splat(1.0))
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
    let c: [Vec3; MAX_WIDTH] = std::array::from_fn(|k| pool.center(i[k]));
    let c = V3::new(
        L::from_fn(|k| c[k].x),
        L::from_fn(|k| c[k].y),
        L::from_fn(|k| c[k].z),
    );
    (c, L::from_fn(|k| pool.radius(i[k])))
}

/// A quad's corner, edges u and v, plane vector w and normal, in lanes.
type QuadVectors<L> = (V3<L>, V3<L>, V3<L>, V3<L>, V3<L>);

/// The corners, edges u and v, plane vectors w and normals of quads `i[k]`, lane by lane
/// (out of line and cold, as `gather_spheres`). Each lane's quad is read once, into
/// fifteen columns: reading it again for each of the five vectors' lanes took 1 718
/// instructions a call at 8 lanes, a quarter of `glass-cornell`'s render.
#[cold]
#[inline(never)]
fn gather_quads<L: Lane>(pool: &QuadPool, i: &[usize; MAX_WIDTH]) -> QuadVectors<L> {
    let mut columns = [[0.0f32; MAX_WIDTH]; 15];
    for (k, &i) in i.iter().enumerate().take(L::WIDTH) {
        let q = pool.frame(i);
        for (v, vector) in [q.corner, q.u, q.v, q.w, q.normal].into_iter().enumerate() {
            columns[3 * v][k] = vector.x;
            columns[3 * v + 1][k] = vector.y;
            columns[3 * v + 2][k] = vector.z;
        }
    }
    let v3 = |v: usize| {
        let c = |m: usize| L::from_fn(|k| columns[3 * v + m][k]);
        V3::new(c(0), c(1), c(2))
    };
    (v3(0), v3(1), v3(2), v3(3), v3(4))
}

/// `index[k]` for the lanes `k` of `lanes` (not empty), the first of those lanes' index
/// for the others, so every lane reads a valid primitive or table entry.
#[inline(always)]
fn own_or_first<T: Copy>(index: &[T; MAX_WIDTH], lanes: u32) -> [T; MAX_WIDTH] {
    let first = index[lanes.trailing_zeros() as usize];
    std::array::from_fn(|k| if lanes >> k & 1 != 0 { index[k] } else { first })
}

/// The Phong parameters of each lane.
pub struct PhongLanes<L> {
    pub albedo: V3<L>,
    pub ka: L,
    pub kd: L,
    pub ks: L,
    pub shininess: L,
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
            shininess: L::splat(m.shininess),
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
            shininess: L::from_fn(|i| m(i).shininess),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::lane_check::{check, out, v3, Kernel};
    use wide::f32x8;

    /// `specular_cosine` is at most 1 and within 18u (u = 2⁻²⁴) of its f64 value below
    /// 1, where it is largest: L the mirror image of V about N, jittered, over a million
    /// random triples of normalised f32 vectors, and with normals up to 1% off unit
    /// length. Unclamped, the same rounding passes 1 (the clamp is not idle).
    #[test]
    fn specular_cosine_is_at_most_one() {
        use crate::sampling::hash_u32;
        let u = f32::EPSILON as f64 / 2.0;
        let mut x = 0x2545_f491u32;
        let mut next = || {
            x = hash_u32(x);
            x as f32 / u32::MAX as f32 * 2.0 - 1.0
        };
        let mut unit = || normalize(V3::<f32>::splat(Vec3::new(next(), next(), next())));
        let d = |a: V3<f32>| a.lane(0).as_dvec3();
        let mut unclamped_past_one = 0;
        for i in 0..1_000_000 {
            let stray = if i % 4 == 0 {
                1.0 + 0.01 * (i % 7) as f32 / 7.0
            } else {
                1.0
            };
            let n = unit().scale(stray);
            let v = unit();
            // The mirror image of V, nudged by up to 2⁻ᵏ.
            let jitter = unit().scale(2f32.powi(-(i % 24)));
            let l = normalize(n.scale(2.0 * n.dot(v)) - v + jitter);
            let (nl, nv, lv) = (n.dot(l), n.dot(v), l.dot(v));
            let r = specular_cosine(nl, nv, lv);
            assert!(r <= 1.0, "R·V = {r}");
            unclamped_past_one += (2.0 * nl * nv - lv > 1.0) as u32;
            let (n, l, v) = (d(n), d(l), d(v));
            let exact = 2.0 * n.dot(l) * n.dot(v) - l.dot(v);
            if stray == 1.0 && exact < 1.0 {
                assert!((r as f64 - exact).abs() <= 18.0 * u, "{r} against {exact}");
            }
        }
        assert!(unclamped_past_one > 0);
    }

    /// Where `pow_is_zero` says so, pow is +0: a grid of shininess (112 to 2e6, ∞,
    /// and small, zero, negative, NaN) and R·V (−2 to 1.5, every float just below 1,
    /// NaN), 8-wide and scalar alike. And it does say so often.
    #[test]
    fn pow_is_zero_only_where_pow_is_plus_zero() {
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
                let bits8 = pow_is_zero::<f32x8>(f32x8::splat(n), f32x8::from(r));
                for (k, &x) in chunk.iter().enumerate() {
                    let zero = pow_is_zero::<f32>(n, x) != 0;
                    assert_eq!(zero, bits8 >> k & 1 != 0, "{x} {n}: 8-wide");
                    if zero {
                        let p = crate::lanes::math::pow(x.max(0.0), n);
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

    fn mask<L: Lane>(m: L::Mask) -> L {
        L::select(m, L::splat(1.0), L::splat(0.0))
    }

    fn bits<L: Lane>(b: u32) -> L {
        L::from_fn(|i| (b >> i & 1) as f32)
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
                o.push(bits::<L>(pow_is_zero(x[8].abs() * L::splat(500.0), x[9])));
                o
            }
        }
        check::<K>("face_forward, direction_to, mirror, schlick, pow_is_zero");
    }

    #[test]
    fn dielectric_at_normal_incidence_passes_straight_through() {
        let s = Surface {
            point: ErrorPoint {
                point: Vec3::ZERO,
                error: Vec3::ZERO,
            },
            normal: Vec3::Z,
            shading: Vec3::Z,
            front_face: true,
            object: 0,
        };
        let ray = Ray::new(Vec3::Z, -Vec3::Z);
        // Schlick at normal incidence for 1/1.5 is 0.04: any choice above it refracts.
        let mut refracted = 0;
        for i in 0..100 {
            let glass = crate::material::Material::Dielectric { index: 1.5 };
            let (_, d) = scatter(&glass, &ray, &s, SampleKey::from_hash(i), 0).unwrap();
            if d == -Vec3::Z {
                refracted += 1;
            } else {
                assert_eq!(d, Vec3::Z);
            }
        }
        assert!(refracted > 80, "{refracted}");
    }
}
