//! The shading control flow, written once over lanes: the scalar tracer runs it at `f32`
//! (one ray), the packet tracer at 4 and 8 lanes (2x2 and 4x2 pixels, one sample index).
//!
//! A path is a loop over its vertices, not a recursion. At each vertex the lanes'
//! rays are traced together and every lane either ends (adding the light it sees,
//! times its path weight, to its colour) or goes on with a new ray:
//! - a miss sees the background, a light its plain colour, Phong its local shading;
//! - PhongMirror adds (1 − F) · Phong and goes on along the mirror direction with its
//!   weight times F (Schlick's F); from then on the lane sees what a mirror sees;
//! - Diffuse, Metal and Dielectric scatter (weight times the attenuation) while the
//!   lane sees what a camera sees; what a mirror sees of them is their albedo (white
//!   for Dielectric), as in the original program; Metal absorbing a ray ends it black.
//!
//! The vertex number is the same for every lane (each iteration is one vertex), so the
//! random numbers of lane k are those of the scalar path of its pixel, and the budget
//! of bounces and reflections is `max_depth − vertex` for all. Every lane computes what
//! the scalar tracer computes for its pixel: the image is the same bits at every width.
//!
//! One file of just over 700 lines (40 of them tests): the one shading control flow,
//! read from top to bottom.

use super::scatter::{scatter_lanes, ScatterLanes};
use super::{
    direction_to, mirror_direction, mirror_fresnel, onto_side, own_or_first, pow_is_zero,
    specular_cosine, PhongLanes, RayCounts, SurfaceLanes, Tracer, T_MIN,
};
use crate::accel::cull::Cull;
use crate::accel::packet::{PacketHits, RayPacket};
use crate::accel::shadow::{origins_box, Among};
use crate::accel::Context;
use crate::geometry::spawn::{spawn_origin, spawn_origins};
use crate::geometry::Ray;
use crate::lanes::math::pow;
use crate::lanes::MAX_WIDTH;
use crate::lanes::{Lane, Mask, V3};
use crate::material::{Material, Phong};
use crate::sampling::{slot, KeyLanes};
use crate::scene::{Light, Scene};
use glam::Vec3;

/// Shading classes of `ShadeTables::class`.
pub(super) const MISS: usize = 0;
pub(super) const LIGHT: usize = 1;
pub(super) const PHONG: usize = 2;
pub(super) const MIRROR: usize = 3;
pub(super) const DIFFUSE: usize = 4;
pub(super) const METAL: usize = 5;
pub(super) const DIELECTRIC: usize = 6;
const CLASSES: usize = 7;
/// A lane past the packet's width: in no class (its bit stays inside its byte).
const NO_LANE: u8 = 7;
/// The Phong material of a packet while no Phong lane is seen, and once two differ.
const NO_PHONG: u32 = u32::MAX;
const MIXED_PHONG: u32 = u32::MAX - 1;
/// Up to this many objects, the lanes are sorted by one lane compare per object rather
/// than a table lookup per lane (`ShadeTables::few`).
const FEW_OBJECTS: usize = 8;

/// The lanes of each class, from the classes of the first `width` lanes, eight lanes
/// a word. Byte k of `onehot` is 1 << (lane k's class); class c's lanes are bit c of
/// each byte, gathered into the top byte by one multiply (its partial products land on
/// distinct bits, so nothing carries). All in registers: `by_class[class] |= 1 << k`
/// went through memory and failed its store-to-load forwarding when the mask was read
/// back (perf).
#[inline(always)]
fn lanes_by_class(classes: [u8; MAX_WIDTH], width: usize) -> [u32; CLASSES] {
    let onehot = |eight: &[u8]| {
        let mut onehot = 0u64;
        for (k, &c) in eight.iter().enumerate() {
            onehot |= (1u64 << c) << (8 * k);
        }
        onehot
    };
    let gather = |onehot: u64, c: usize| {
        ((onehot >> c & 0x0101_0101_0101_0101).wrapping_mul(0x0102_0408_1020_4080) >> 56) as u32
    };
    let low = onehot(&classes[..8]);
    if width <= 8 {
        std::array::from_fn(|c| gather(low, c))
    } else {
        let high = onehot(&classes[8..16]);
        std::array::from_fn(|c| gather(low, c) | gather(high, c) << 8)
    }
}

/// What shading needs of a hit's object, indexed by object + 1 (entry 0: no hit), so
/// lanes are sorted by table lookups instead of a `match` per lane (a lane's material is
/// a coin toss for the branch predictor).
#[derive(Clone, Debug)]
pub(crate) struct ShadeTables {
    class: Vec<u8>,
    /// The colour a lane adds at this object when its path ends there: a light's plain
    /// colour; the albedo a mirror sees of Diffuse and Metal, white for Dielectric.
    seen: Vec<Vec3>,
    /// PhongMirror's and Dielectric's index, Metal's fuzz (0 elsewhere).
    index: Vec<f32>,
    /// Phong parameters by material index (default for the others).
    phong: Vec<Phong>,
    /// The index into `phong` of the object's material (0 for entry 0).
    phong_of: Vec<u32>,
    /// At most `FEW_OBJECTS` objects (`bunny`: four).
    few: bool,
    /// Some light is sampled more than once.
    area_lights: bool,
}

impl ShadeTables {
    pub(crate) fn new(scene: &Scene) -> Self {
        let objects = scene.object_material.len();
        let mut t = ShadeTables {
            class: vec![MISS as u8; objects + 1],
            seen: vec![Vec3::ZERO; objects + 1],
            index: vec![0.0; objects + 1],
            phong: vec![Phong::default(); scene.materials.len().max(1)],
            phong_of: vec![0; objects + 1],
            few: objects <= FEW_OBJECTS,
            area_lights: scene.lights.iter().any(|l| l.samples() > 1),
        };
        for (i, m) in scene.materials.iter().enumerate() {
            if let Material::Phong(p) | Material::PhongMirror { phong: p, .. } = *m {
                t.phong[i] = p;
            }
        }
        for (o, &mi) in scene.object_material.iter().enumerate() {
            let (class, seen, index) = match scene.materials[mi as usize] {
                Material::Light { color, .. } => (LIGHT, color, 0.0),
                Material::Phong(_) => (PHONG, Vec3::ZERO, 0.0),
                Material::PhongMirror { index, .. } => (MIRROR, Vec3::ZERO, index),
                Material::Diffuse { albedo } => (DIFFUSE, albedo, 0.0),
                Material::Metal { albedo, fuzz } => (METAL, albedo, fuzz),
                Material::Dielectric { index } => (DIELECTRIC, Vec3::ONE, index),
            };
            t.class[o + 1] = class as u8;
            t.seen[o + 1] = seen;
            t.index[o + 1] = index;
            t.phong_of[o + 1] = mi;
        }
        t
    }
}

/// The pixels a packet of `width` lanes covers: 4x4 for 16 lanes, 4x2 for 8, 2x2 for 4,
/// 1x1 for 1.
pub const fn footprint(width: usize) -> (u32, u32) {
    match width {
        16 => (4, 4),
        8 => (4, 2),
        4 => (2, 2),
        _ => (1, 1),
    }
}

/// The paths of a packet's lanes between two vertices.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Paths<L> {
    /// The rays to trace next (finite in every lane; only the `active` ones count).
    pub(super) origin: V3<L>,
    pub(super) dir: V3<L>,
    /// The lanes whose path goes on.
    pub(super) active: u32,
    /// The lanes past a PhongMirror: they see what a mirror sees.
    pub(super) mirror: u32,
    /// What the light the path gathers from here on is multiplied by: the attenuations
    /// of its bounces and the Fresnel weights of its mirrors.
    pub(super) weight: V3<L>,
    /// The light gathered so far.
    pub(super) color: V3<L>,
}

/// The pixels of a packet: lane k is pixel (x0 + k mod w, y0 + k div w) of the
/// footprint (`footprint`), traced if bit k of `active` is set; `pixels`: their hashes
/// (`Tracer::pixel_hashes`).
#[derive(Clone, Copy, Debug)]
pub struct PacketPixels {
    pub x0: u32,
    pub y0: u32,
    pub pixels: [u32; MAX_WIDTH],
    pub active: u32,
}

impl<L: Lane> Paths<L> {
    /// Paths starting with the rays `origin`, `dir` in the lanes of `active`.
    #[inline(always)]
    pub(crate) fn new(origin: V3<L>, dir: V3<L>, active: u32) -> Self {
        Self {
            origin,
            dir,
            active,
            mirror: 0,
            weight: V3::splat(Vec3::ONE),
            color: V3::splat(Vec3::ZERO),
        }
    }
}

/// Lane k is `table[object + 1]` of its hit's object where the lanes of `lanes` (not
/// empty, all with a hit) read it; one splat when they all hit the same object.
#[inline(always)]
fn gather<L: Lane>(table: &[f32], hits: &PacketHits<L>, lanes: u32) -> L {
    match hits.same_object(lanes) {
        Some(o) => L::splat(table[o as usize + 1]),
        None => {
            let e = entries(hits, lanes);
            L::from_fn(|k| table[e[k] as usize])
        }
    }
}

/// `gather` of a table of colours.
#[inline(always)]
fn gather3<L: Lane>(table: &[Vec3], hits: &PacketHits<L>, lanes: u32) -> V3<L> {
    match hits.same_object(lanes) {
        Some(o) => V3::splat(table[o as usize + 1]),
        None => {
            let e = entries(hits, lanes);
            V3::from_fn(|k| table[e[k] as usize])
        }
    }
}

/// The lanes' table entries (object + 1) where the lanes of `lanes` (not empty) read
/// them, the first of those lanes' entry in the others.
#[inline(always)]
fn entries<L: Lane>(hits: &PacketHits<L>, lanes: u32) -> [u32; MAX_WIDTH] {
    own_or_first(&hits.objects(), lanes).map(|o| o.wrapping_add(1))
}

/// `acc + weight · c` in the lanes of `lanes`, `acc` elsewhere.
#[inline(always)]
fn add_weighted<L: Lane>(acc: V3<L>, weight: V3<L>, c: V3<L>, lanes: u32) -> V3<L> {
    let sum = acc + V3::new(weight.x * c.x, weight.y * c.y, weight.z * c.z);
    V3::select(L::Mask::from_bits(lanes), sum, acc)
}

impl Tracer<'_> {
    /// Camera sample `sample` of the pixels of a packet whose lane 0 is pixel (x0, y0):
    /// lane i is pixel (x0 + i mod w, y0 + i div w) of the footprint, traced if bit i
    /// of `active` is set. Lane i's colour is `sample(x, y, sample)` of its pixel (zero
    /// in the lanes not traced).
    /// `cull`: what the packet's rays may hit, from `camera_cull` of a rectangle holding
    /// its pixels (`Cull::ALL` to test everything).
    pub fn sample_packet<L: Lane>(
        &self,
        x0: u32,
        y0: u32,
        active: u32,
        sample: u32,
        cull: Cull,
        counts: &mut RayCounts,
    ) -> V3<L> {
        let pixels = self.pixel_hashes::<L>(x0, y0);
        self.sample_pixels(x0, y0, &pixels, active, sample, cull, counts)
    }

    /// The sampler's hashes of the pixels of a packet whose lane 0 is pixel (x0, y0)
    /// (`Sampler::pixel_hashes`): the same for every sample of those pixels.
    #[inline(always)]
    pub fn pixel_hashes<L: Lane>(&self, x0: u32, y0: u32) -> [u32; MAX_WIDTH] {
        let (fw, _) = footprint(L::WIDTH);
        let xs: [u32; MAX_WIDTH] = std::array::from_fn(|k| x0 + k as u32 % fw);
        let ys: [u32; MAX_WIDTH] = std::array::from_fn(|k| y0 + k as u32 / fw);
        self.sampler.pixel_hashes(L::WIDTH, xs, ys)
    }

    /// `sample_packet` with the pixels' hashes `pixels` made (`pixel_hashes`), so a
    /// tile makes them once for all the samples of its pixels, whatever the compiler
    /// inlines.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn sample_pixels<L: Lane>(
        &self,
        x0: u32,
        y0: u32,
        pixels: &[u32; MAX_WIDTH],
        active: u32,
        sample: u32,
        cull: Cull,
        counts: &mut RayCounts,
    ) -> V3<L> {
        let scene = self.scene;
        counts.camera += active.count_ones() as u64;
        if L::WIDTH > 1 {
            counts.camera_packets.record(active);
        }
        if cull.nothing && scene.max_depth > 0 {
            // No ray of the packet can hit anything: the background, as a miss gives it
            // (0 + 1 · background, the same bits), without making the rays.
            counts.packets_outside += 1;
            return V3::select(
                L::Mask::from_bits(active),
                V3::splat(scene.background),
                V3::splat(Vec3::ZERO),
            );
        }
        let (fw, _) = footprint(L::WIDTH);
        let xs: [u32; MAX_WIDTH] = std::array::from_fn(|k| x0 + k as u32 % fw);
        let ys: [u32; MAX_WIDTH] = std::array::from_fn(|k| y0 + k as u32 / fw);
        let keys = self.sampler.key_lanes_of(L::WIDTH, pixels, sample);
        let camera = &scene.camera;
        // A thin lens: each lane starts at its own point of the lens disk.
        let origin = if camera.has_lens() {
            camera.lens_points(keys.uniform(0, slot::LENS_X), keys.uniform(0, slot::LENS_Y))
        } else {
            V3::splat(camera.origin)
        };
        let dir = camera.directions(
            origin,
            L::from_fn(|k| xs[k] as f32),
            L::from_fn(|k| ys[k] as f32),
            keys.uniform(0, slot::JITTER_X),
            keys.uniform(0, slot::JITTER_Y),
        );
        let paths = Paths::new(origin, dir, active);
        self.trace_paths(paths, &keys, Some(cull), counts)
    }

    /// `sample_pixels`' first steps, for `sample_tile`: counts a packet's camera rays;
    /// when the tile's cull says none can hit anything, the colours they see. Written
    /// twice: `sample_pixels` calling this and `camera_rays` cost `quads` and `mixed`
    /// 2.4% more render instructions (8 wide), in copies of the paths.
    #[inline(always)]
    pub(super) fn camera_seen<L: Lane>(
        &self,
        active: u32,
        cull: Cull,
        counts: &mut RayCounts,
    ) -> Option<V3<L>> {
        let scene = self.scene;
        counts.camera += active.count_ones() as u64;
        if L::WIDTH > 1 {
            counts.camera_packets.record(active);
        }
        if cull.nothing && scene.max_depth > 0 {
            // No ray of the packet can hit anything: the background, as a miss gives it
            // (0 + 1 · background, the same bits), without making the rays.
            counts.packets_outside += 1;
            return Some(V3::select(
                L::Mask::from_bits(active),
                V3::splat(scene.background),
                V3::splat(Vec3::ZERO),
            ));
        }
        None
    }

    /// `sample_pixels`' camera rays, for `sample_tile`: sample `sample` of the pixels as
    /// paths to trace, with their keys.
    #[inline(always)]
    pub(super) fn camera_rays<L: Lane>(
        &self,
        x0: u32,
        y0: u32,
        active: u32,
        pixels: &[u32; MAX_WIDTH],
        sample: u32,
    ) -> (Paths<L>, KeyLanes) {
        let scene = self.scene;
        let (fw, _) = footprint(L::WIDTH);
        let xs: [u32; MAX_WIDTH] = std::array::from_fn(|k| x0 + k as u32 % fw);
        let ys: [u32; MAX_WIDTH] = std::array::from_fn(|k| y0 + k as u32 / fw);
        let keys = self.sampler.key_lanes_of(L::WIDTH, pixels, sample);
        let camera = &scene.camera;
        // A thin lens: each lane starts at its own point of the lens disk.
        let origin = if camera.has_lens() {
            camera.lens_points(keys.uniform(0, slot::LENS_X), keys.uniform(0, slot::LENS_Y))
        } else {
            V3::splat(camera.origin)
        };
        let dir = camera.directions(
            origin,
            L::from_fn(|k| xs[k] as f32),
            L::from_fn(|k| ys[k] as f32),
            keys.uniform(0, slot::JITTER_X),
            keys.uniform(0, slot::JITTER_Y),
        );
        (Paths::new(origin, dir, active), keys)
    }

    /// The colour a ray sees, as a camera sees it: `trace_paths` at `f32`.
    pub fn trace_ray(&self, ray: Ray, keys: &KeyLanes, counts: &mut RayCounts) -> Vec3 {
        let paths = Paths::<f32>::new(V3::splat(ray.origin), V3::splat(ray.dir), 1);
        self.trace_paths(paths, keys, None, counts).lane(0)
    }

    /// Follow the lanes' paths from vertex 0 until each ends or the budget
    /// (`max_depth` vertices) is spent, and return their colours. `camera`: the rays are
    /// camera rays whose packet's tile has this cull.
    #[inline(always)]
    pub(crate) fn trace_paths<L: Lane>(
        &self,
        mut paths: Paths<L>,
        keys: &KeyLanes,
        camera: Option<Cull>,
        counts: &mut RayCounts,
    ) -> V3<L> {
        let mut vertex = 0;
        while paths.active != 0 && vertex < self.scene.max_depth {
            let hits = self.closest_hits(&paths, if vertex == 0 { camera } else { None }, counts);
            // One lane (the scalar reference): shaded inline, in its tile loop. Left to
            // the compiler, that choice flipped with changes elsewhere in the tracing
            // code (out of line, `bunny`'s scalar render took 9.8% more instructions);
            // always inline at every width, `bunny` 8 wide took 4.4% more.
            if L::WIDTH == 1 {
                self.shade_vertex_inline(&mut paths, &hits, keys, vertex, counts);
            } else {
                self.shade_vertex(&mut paths, &hits, keys, vertex, counts);
            }
            vertex += 1;
        }
        paths.color
    }

    /// The closest hits of the active lanes' rays: the scalar traversal for one lane,
    /// the packet traversal for more.
    #[inline(always)]
    pub(super) fn closest_hits<L: Lane>(
        &self,
        paths: &Paths<L>,
        camera: Option<Cull>,
        counts: &mut RayCounts,
    ) -> PacketHits<L> {
        let scene = self.scene;
        if L::WIDTH == 1 {
            let ray = Ray::new(paths.origin.lane(0), paths.dir.lane(0));
            let mut hits = PacketHits::none(paths.active);
            let hit = self.closest_hit(&ray, counts);
            hits.set(0, hit.map_or(f32::INFINITY, |h| h.t), hit);
            return hits;
        }
        let (o, d) = (paths.origin, paths.dir);
        let mut packet = RayPacket::from_active_lanes_with(o, d, paths.active, self.packet_boxes);
        if let Some(cull) = camera {
            packet.set_cull(cull);
        }
        // A camera inside the scene's box (bunny's ground sphere holds it) needs no box
        // test: every ray meets it. Skipping an early-out never changes a result.
        let inside = camera.is_some() && self.camera_inside;
        if self.specialize
            && self.packet_boxes
            && !inside
            && packet.hits_box(&scene.bounds, T_MIN, f32::INFINITY) & paths.active == 0
        {
            counts.packets_outside += 1;
            return PacketHits::none(paths.active);
        }
        let cx = Context::new(scene, &mut counts.traversal);
        // Without instances the tree's hits are the answer, made straight into this
        // call's: through `Accel::closest_hit_packet`, which may add an instance's, they
        // were copied once more (11 instructions a packet, 0.7% of `mixed` 8 wide).
        if scene.instances.is_empty() {
            return self.accel.tree.closest_hit_packet(cx, &packet, T_MIN);
        }
        self.accel.closest_hit_packet(cx, &packet, T_MIN)
    }

    /// Shade the lanes' hits at path vertex `vertex`: add what the lanes whose path ends
    /// here see, and set up the next rays of the others.
    pub(super) fn shade_vertex<L: Lane>(
        &self,
        paths: &mut Paths<L>,
        hits: &PacketHits<L>,
        keys: &KeyLanes,
        vertex: u32,
        counts: &mut RayCounts,
    ) {
        self.shade_vertex_inline(paths, hits, keys, vertex, counts);
    }

    /// `shade_vertex`, always inlined.
    #[inline(always)]
    fn shade_vertex_inline<L: Lane>(
        &self,
        paths: &mut Paths<L>,
        hits: &PacketHits<L>,
        keys: &KeyLanes,
        vertex: u32,
        counts: &mut RayCounts,
    ) {
        let scene = self.scene;
        let t = &self.tables;
        let active = paths.active;
        let found = hits.found & active;
        // The lanes by how their hit is shaded, and the Phong material when every Phong
        // lane has the same one. All hits on one object (one lane; most packets): its
        // class from the table, each class's mask by a compare with it (in registers; a
        // store at the class's index went through memory and every mask was read back
        // from there). Few objects: one lane compare per object. Else a table lookup
        // per lane.
        let one_object = match found {
            0 => Some(0),
            _ => hits.same_object(found).map(|o| o as usize + 1),
        };
        let (by_class, uniform_phong) = if let Some(slot) = one_object {
            let class = t.class[slot] as usize;
            let missed = active & !found;
            let by_class = std::array::from_fn(|c| {
                (if c == class { found } else { 0 }) | (if c == MISS { missed } else { 0 })
            });
            (by_class, t.phong_of[slot])
        } else if t.few {
            let mut by_class = [0u32; CLASSES];
            by_class[MISS] = active & !found;
            let mut phong = NO_PHONG;
            for o in 0..t.class.len() - 1 {
                let lanes = hits.of_object(o as u32) & found;
                if lanes == 0 {
                    continue;
                }
                let class = t.class[o + 1] as usize;
                // Every class's mask at a constant index, so the masks stay in
                // registers (`by_class[class] |= lanes` stored a word at a time and was
                // read back two words at once, past store-to-load forwarding).
                for (c, b) in by_class.iter_mut().enumerate() {
                    *b |= lanes & ((c == class) as u32).wrapping_neg();
                }
                if class == PHONG || class == MIRROR {
                    let p = t.phong_of[o + 1];
                    phong = if phong == NO_PHONG || phong == p {
                        p
                    } else {
                        MIXED_PHONG
                    };
                }
            }
            (by_class, phong)
        } else {
            let object = hits.objects();
            let classes = std::array::from_fn(|k| {
                if k >= L::WIDTH || active >> k & 1 == 0 {
                    NO_LANE
                } else if found >> k & 1 == 0 {
                    MISS as u8
                } else {
                    t.class[object[k] as usize + 1]
                }
            });
            (lanes_by_class(classes, L::WIDTH), MIXED_PHONG)
        };
        let (mut color, mut weight) = (paths.color, paths.weight);

        // Paths that end here without shading: the background, a light's colour, what
        // a mirror sees of a path-traced material.
        if by_class[MISS] != 0 {
            let background = V3::splat(scene.background);
            color = add_weighted(color, weight, background, by_class[MISS]);
        }
        let path_traced = by_class[DIFFUSE] | by_class[METAL] | by_class[DIELECTRIC];
        let seen = by_class[LIGHT] | (path_traced & paths.mirror);
        if seen != 0 {
            color = add_weighted(color, weight, gather3(&t.seen, hits, seen), seen);
        }
        let bounce = path_traced & !paths.mirror;
        let phong_lanes = by_class[PHONG] | by_class[MIRROR];
        let shaded = phong_lanes | bounce;
        if shaded == 0 {
            paths.color = color;
            paths.active = 0;
            return;
        }

        // The surfaces, lane-wise.
        let (origin, dir) = (paths.origin, paths.dir);
        let s = self.surface_lanes::<L>(origin, dir, hits, shaded);
        let (mut next_origin, mut next_dir, mut next) = (origin, dir, 0u32);

        if phong_lanes != 0 {
            // The lanes' Phong parameters. A lane that does not shade with Phong takes
            // the first Phong lane's material (its values are never read), so a packet
            // on one material is recognised and splatted.
            let materials = if uniform_phong < MIXED_PHONG {
                PhongLanes::<L>::splat(&t.phong[uniform_phong as usize])
            } else {
                let entry = entries(hits, phong_lanes);
                let index = entry.map(|e| t.phong_of[e as usize]);
                PhongLanes::<L>::from_indices(&t.phong, &index)
            };
            let local = self.phong_lanes(&materials, &s, -dir, keys, vertex, phong_lanes, counts);
            color = add_weighted(color, weight, local, by_class[PHONG]);
            let mirrors = by_class[MIRROR];
            if mirrors != 0 {
                // PhongMirror: (1 − F) of the local colour now, F of what the mirror
                // direction sees next.
                let f = mirror_fresnel(dir, s.shading, gather(&t.index, hits, mirrors));
                let one_minus_f = L::splat(1.0) - f;
                color = add_weighted(color, weight, local.scale(one_minus_f), mirrors);
                weight = V3::select(L::Mask::from_bits(mirrors), weight.scale(f), weight);
                let mut reflected = mirror_direction(dir, s.shading);
                if s.smooth & mirrors != 0 {
                    reflected = onto_side(reflected, s.normal, mirrors, s.smooth & mirrors);
                }
                let m = L::Mask::from_bits(mirrors);
                next_dir = V3::select(m, reflected, next_dir);
                next_origin = V3::select(
                    m,
                    spawn_origin(s.point, s.error, s.normal, reflected),
                    next_origin,
                );
                next |= mirrors;
            }
        }

        if bounce != 0 {
            // Diffuse, Metal, Dielectric: a bounce, on as a camera sees it.
            let m = ScatterLanes {
                albedo: gather3(&t.seen, hits, bounce),
                parameter: gather(&t.index, hits, bounce),
                diffuse: by_class[DIFFUSE] & bounce,
                metal: by_class[METAL] & bounce,
                dielectric: by_class[DIELECTRIC] & bounce,
            };
            let b = scatter_lanes(dir, &s, &m, keys, vertex);
            let scattered = L::Mask::from_bits(b.scattered);
            weight = V3::select(
                scattered,
                V3::new(
                    weight.x * b.attenuation.x,
                    weight.y * b.attenuation.y,
                    weight.z * b.attenuation.z,
                ),
                weight,
            );
            next_dir = V3::select(scattered, b.dir, next_dir);
            next_origin = V3::select(
                scattered,
                spawn_origin(s.point, s.error, s.normal, b.dir),
                next_origin,
            );
            next |= b.scattered;
        }

        counts.secondary += next.count_ones() as u64;
        if L::WIDTH > 1 && next != 0 {
            counts.secondary_packets.record(next);
        }
        paths.origin = next_origin;
        paths.dir = next_dir;
        paths.active = next;
        paths.mirror |= by_class[MIRROR];
        paths.weight = weight;
        paths.color = color;
    }

    /// Phong at the surfaces of the lanes of `lanes` (the original program's model):
    /// ambient, plus per light the mean over its samples of the diffuse and specular
    /// terms of the samples whose shadow ray reaches the light. Each sample's shadow
    /// rays travel as one packet over the lanes that have a direction to it (not those
    /// whose sample adds nothing lit or not, when specialising). The specular term is
    /// not gated by N·L > 0, as in the original.
    #[allow(clippy::too_many_arguments)]
    pub fn phong_lanes<L: Lane>(
        &self,
        m: &PhongLanes<L>,
        s: &SurfaceLanes<L>,
        view: V3<L>,
        keys: &KeyLanes,
        vertex: u32,
        lanes: u32,
        counts: &mut RayCounts,
    ) -> V3<L> {
        let scene = self.scene;
        let zero = V3::splat(Vec3::ZERO);
        let (mut diffuse, mut specular) = (zero, zero);
        // Where the lanes' shadow rays start, for the candidate occluders of an area
        // light's samples in packets (one point light's sample, or one ray, gains
        // nothing: the tests it saves cost as much as the boxes).
        let boxes = (self.shadow_boxes.as_ref()).filter(|_| self.specialize && L::WIDTH > 1);
        let origins = boxes.map(|_| origins_box(s.point, s.error, lanes));
        let n_dot_v = s.shading.dot(view);
        // The shadow rays' origins on either side of the surfaces, when a light is
        // sampled more than once (`spawn_origins`): then a select per sample, not a
        // spawn. (One lane gains nothing: its spawn is a branch.)
        let sides = (L::WIDTH > 1 && self.tables.area_lights)
            .then(|| spawn_origins(s.point, s.error, s.normal));
        for (li, light) in scene.lights.iter().enumerate() {
            let n = light.samples();
            let radiance = V3::<L>::splat(light.radiance);
            let (mut light_diffuse, mut light_specular) = (zero, zero);
            let among = match (boxes, &origins) {
                (Some(b), Some(o)) if n > 1 => b.candidates(li, o),
                _ => None,
            };
            for k in 0..n {
                let target = light_targets(light, li as u32, k, keys, vertex);
                let (l, ok) = direction_to(target, s.point);
                let candidates = ok.bits() & lanes;
                if candidates == 0 {
                    continue;
                }
                let n_dot_l = s.shading.dot(l);
                // The side of the geometric surface the light sample is on: `n_dot_l`
                // itself where the shading normal is the geometric one.
                let side = if s.smooth != 0 {
                    s.normal.dot(l)
                } else {
                    n_dot_l
                };
                let r_dot_v = specular_cosine(n_dot_l, n_dot_v, l.dot(view));
                // The specular term, made once and only where it can be other than +0
                // (`pow_is_zero`): zero lanes need no pow.
                let base = r_dot_v.max(L::splat(0.0));
                let surely_zero = pow_is_zero(m.shininess, r_dot_v);
                let mut spec = None;
                let mut traced = candidates;
                if self.specialize {
                    // A sample adds nothing, lit or not, where N·L ≤ 0 (no diffuse
                    // term) and the specular term is +0: its shadow ray is not traced.
                    let unlit = (!n_dot_l.gt(L::splat(0.0))).bits() & candidates;
                    let mut nothing = unlit & surely_zero;
                    if unlit & !surely_zero != 0 {
                        let p = pow(base, m.shininess);
                        nothing |= unlit & p.eq(L::splat(0.0)).bits();
                        spec = Some(p);
                    }
                    counts.shadow_culled += nothing.count_ones() as u64;
                    traced &= !nothing;
                }
                // On a smooth mesh a sample behind the geometric surface is in its
                // shadow, whatever the shading normal says: the mesh hides it (the
                // terminator follows the facets), and no shadow ray starts on the far
                // side of an open mesh to see a light the surface faces away from.
                if s.smooth != 0 {
                    traced &= !(s.smooth & (!side.gt(L::splat(0.0))).bits());
                }
                if traced == 0 {
                    continue;
                }
                let origin = match sides {
                    // `spawn_origin`'s side test: l · n is n · l, bit for bit.
                    Some([front, back]) => V3::select(side.lt(L::splat(0.0)), back, front),
                    None => spawn_origin(s.point, s.error, s.normal, l),
                };
                let visible = self.light_visible_lanes(origin, l, traced, light, among, counts);
                if visible == 0 {
                    continue;
                }
                let lit = L::Mask::from_bits(visible);
                let d = light_diffuse + radiance.scale(n_dot_l.max(L::splat(0.0)));
                light_diffuse = V3::select(lit, d, light_diffuse);
                let spec = if visible & !surely_zero == 0 {
                    L::splat(0.0)
                } else {
                    spec.unwrap_or_else(|| pow(base, m.shininess))
                };
                light_specular =
                    V3::select(lit, light_specular + radiance.scale(spec), light_specular);
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

    /// The lanes of `lanes` whose shadow ray from `origin` along `l` reaches `light`:
    /// the scalar test for one lane, a shadow packet for more. `among`: the
    /// only primitives that can occlude a packet's rays, when known (`accel::shadow`).
    #[inline(always)]
    fn light_visible_lanes<L: Lane>(
        &self,
        origin: V3<L>,
        l: V3<L>,
        lanes: u32,
        light: &Light,
        among: Option<Among<'_>>,
        counts: &mut RayCounts,
    ) -> u32 {
        counts.shadow += lanes.count_ones() as u64;
        if L::WIDTH == 1 {
            let ray = Ray::new(origin.lane(0), l.lane(0));
            let cx = Context::new(self.scene, &mut counts.traversal);
            return self.accel.light_visible(cx, &ray, T_MIN, light) as u32;
        }
        counts.shadow_packets.record(lanes);
        let p = RayPacket::<L>::from_active_lanes_with(origin, l, lanes, self.packet_boxes);
        let cx = Context::new(self.scene, &mut counts.traversal);
        self.accel
            .light_visible_packet(cx, &p, T_MIN, light, lanes, among)
    }
}

/// Sample `k` of light `li` at path vertex `vertex` of each lane: a point light's
/// centre, or a point of an area light from the lane's random numbers.
#[inline(always)]
pub(super) fn light_targets<L: Lane>(
    light: &Light,
    li: u32,
    k: u32,
    keys: &KeyLanes,
    vertex: u32,
) -> V3<L> {
    if let crate::scene::LightShape::Point { center, .. } = light.shape {
        return V3::splat(center);
    }
    let u = |c| keys.uniform::<L>(vertex, slot::light(li, k, c));
    // The primitive is picked only when there are several (the pick's number has a
    // slot of its own, so skipping it changes no other number).
    let pick = if light.primitives() > 1 {
        u(0)
    } else {
        L::splat(0.0)
    };
    let (a, b) = keys.uniform_pair::<L>(vertex, slot::light(li, k, 1));
    let (pick, a, b) = light.stratum(k, pick, a, b);
    light.sample_lanes(pick, a, b)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every assignment of classes (and "no lane") to the first five lanes, with the
    /// others cycling: the masks are those of a plain loop, at 8 and at 16 lanes.
    #[test]
    fn lanes_by_class_is_the_plain_loop() {
        let values = [
            MISS,
            LIGHT,
            PHONG,
            MIRROR,
            DIFFUSE,
            METAL,
            DIELECTRIC,
            NO_LANE as usize,
        ];
        let mut n = 0u32;
        for code in 0..values.len().pow(5) {
            let mut c = code;
            let classes: [u8; MAX_WIDTH] = std::array::from_fn(|k| {
                let v = if k < 5 {
                    values[c % values.len()]
                } else {
                    values[(code + k) % values.len()]
                };
                c /= values.len();
                v as u8
            });
            for width in [8, 16] {
                let mut expected = [0u32; CLASSES];
                for (k, &cl) in classes.iter().enumerate().take(width) {
                    if (cl as usize) < CLASSES {
                        expected[cl as usize] |= 1 << k;
                    }
                }
                assert_eq!(lanes_by_class(classes, width), expected, "{classes:?}");
            }
            n += 1;
        }
        assert_eq!(n, 32768);
    }
}
