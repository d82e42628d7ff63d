//! The packet tracer: the scalar tracer's semantics over 4- or 8-wide packets.
//!
//! An 8-wide packet covers 4x2 pixels (a 4-wide one 2x2), all at the same sample index.
//! Camera rays, shadow rays (one packet per light sample) and PhongMirror reflections
//! travel as packets through `Accel::closest_hit_packet` / `light_visible_packet`, whose
//! per-lane answers are the scalar ones. Shading runs over lanes through the kernels the
//! scalar tracer runs at `f32` (`Tracer::surface_lanes`, `direction_to`,
//! `adds_nothing_lanes`, `spawn_origin`, `phong_lanes`, `mirror_direction`,
//! `mirror_fresnel`), and the rays they make go straight into the next packet
//! (`RayPacket::from_active_lanes`); quad and triangle hit points are rebuilt lane by
//! lane, and path-traced bounces leave the packet for `Tracer::trace_from`. So every
//! lane computes exactly what the scalar tracer computes for its pixel: the image is the
//! same bits at every width (tests/packets.rs).

use super::{
    adds_nothing_lanes, direction_to, mirror_direction, mirror_fresnel, scatter, PhongLanes,
    RayCounts, Tracer, T_MIN,
};
use crate::accel::cull::Cull;
use crate::accel::packet::{PacketHits, RayPacket, MAX_WIDTH};
use crate::geometry::spawn::{spawn_origin, spawn_ray};
use crate::geometry::Ray;
use crate::lanes::V3;
use crate::lanes::{set_lanes, Lane, Mask};
use crate::material::{Material, Phong};
use crate::rng::{keys_lanes, slot, uniform_lanes, SampleKey, SamplerKind};
use crate::scene::{LightShape, Scene};
use glam::Vec3;

/// Shading classes of `ShadeTables::class`.
const MISS: usize = 0;
const LIGHT: usize = 1;
const PHONG: usize = 2;
const MIRROR: usize = 3;
/// Diffuse, Metal, Dielectric: a bounce at the camera vertex, a plain colour below it.
const PATH: usize = 4;
const CLASSES: usize = 5;
/// A lane past the packet's width: in no class (its bit stays inside its byte).
const NO_LANE: u8 = 7;
/// `shade_packet`'s Phong material while no Phong lane is seen, and once two differ.
const NO_PHONG: u32 = u32::MAX;
const MIXED_PHONG: u32 = u32::MAX - 1;
/// Up to this many objects, `shade_packet` sorts its lanes by one lane compare per
/// object rather than a table lookup per lane (`ShadeTables::few`).
const FEW_OBJECTS: usize = 8;

/// The lanes of each class, from the lanes' classes. Byte k of `onehot` is
/// 1 << (lane k's class); class c's lanes are bit c of each byte, gathered into the top
/// byte by one multiply (its partial products land on distinct bits, so nothing
/// carries). All in registers: `by_class[class] |= 1 << k` went through memory and
/// failed its store-to-load forwarding when the mask was read back (perf).
#[inline(always)]
fn lanes_by_class(classes: [u8; MAX_WIDTH]) -> [u32; CLASSES] {
    let mut onehot = 0u64;
    for (k, &c) in classes.iter().enumerate() {
        onehot |= (1u64 << c) << (8 * k);
    }
    std::array::from_fn(|c| {
        ((onehot >> c & 0x0101_0101_0101_0101).wrapping_mul(0x0102_0408_1020_4080) >> 56) as u32
    })
}

/// What the packet tracer needs of a hit's object, indexed by object + 1 (entry 0: no
/// hit), so `shade_packet` sorts its lanes by table lookups instead of a `match` per
/// lane (perf: that match's jump and branches were ~15% of `shade_packet`'s time on
/// `bunny`, where a packet's lanes mix sky, ground and mirror).
#[derive(Clone, Debug)]
pub(crate) struct ShadeTables {
    class: Vec<u8>,
    /// PhongMirror's Schlick index (0 elsewhere).
    mirror_index: Vec<f32>,
    /// Phong parameters by material index (default for the others).
    phong: Vec<Phong>,
    /// The index into `phong` of the object's material (0 for entry 0).
    phong_of: Vec<u32>,
    /// At most `FEW_OBJECTS` objects (`bunny`: four).
    few: bool,
}

impl ShadeTables {
    pub(crate) fn new(scene: &Scene) -> Self {
        let objects = scene.object_material.len();
        let mut t = ShadeTables {
            class: vec![MISS as u8; objects + 1],
            mirror_index: vec![0.0; objects + 1],
            phong: vec![Phong::default(); scene.materials.len().max(1)],
            phong_of: vec![0; objects + 1],
            few: objects <= FEW_OBJECTS,
        };
        for (i, m) in scene.materials.iter().enumerate() {
            if let Material::Phong(p) | Material::PhongMirror { phong: p, .. } = *m {
                t.phong[i] = p;
            }
        }
        for (o, &mi) in scene.object_material.iter().enumerate() {
            let (class, index) = match scene.materials[mi as usize] {
                Material::Light { .. } => (LIGHT, 0.0),
                Material::Phong(_) => (PHONG, 0.0),
                Material::PhongMirror { index, .. } => (MIRROR, index),
                Material::Diffuse { .. } | Material::Metal { .. } | Material::Dielectric { .. } => {
                    (PATH, 0.0)
                }
            };
            t.class[o + 1] = class as u8;
            t.mirror_index[o + 1] = index;
            t.phong_of[o + 1] = mi;
        }
        t
    }
}

/// The pixels a packet of `width` lanes covers: 4x2 for 8 lanes, 2x2 for 4, 1x1 for 1.
pub const fn footprint(width: usize) -> (u32, u32) {
    match width {
        8 => (4, 2),
        4 => (2, 2),
        _ => (1, 1),
    }
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
        if cull.nothing && self.scene.max_depth > 0 {
            // No ray of the packet can hit anything: the background, as `shade_packet`
            // gives a lane that misses, without making the rays.
            counts.camera += active.count_ones() as u64;
            counts.camera_packets.record(active);
            counts.packets_outside += 1;
            let background = V3::splat(Vec3::ONE * self.scene.background);
            return V3::select(
                L::Mask::from_bits(active),
                background,
                V3::splat(Vec3::ZERO),
            );
        }
        let (fw, _) = footprint(L::WIDTH);
        let xs: [u32; MAX_WIDTH] = std::array::from_fn(|k| x0 + k as u32 % fw);
        let ys: [u32; MAX_WIDTH] = std::array::from_fn(|k| y0 + k as u32 / fw);
        // The independent sampler lane-wise; the structured ones lane by lane.
        let mut keys = [SampleKey::from_hash(0); MAX_WIDTH];
        let (jx, jy) = if self.sampler.kind == SamplerKind::Independent {
            let hashes = keys_lanes(self.sampler.seed, xs, ys, sample);
            for (key, &h) in keys.iter_mut().zip(&hashes) {
                *key = SampleKey::from_hash(h);
            }
            (
                uniform_lanes(hashes, 0, slot::JITTER_X),
                uniform_lanes(hashes, 0, slot::JITTER_Y),
            )
        } else {
            for (k, key) in keys.iter_mut().enumerate().take(L::WIDTH) {
                *key = self.sampler.key(xs[k], ys[k], sample);
            }
            (
                keys.map(|key| key.uniform(0, slot::JITTER_X)),
                keys.map(|key| key.uniform(0, slot::JITTER_Y)),
            )
        };
        let lane = |v: &[f32; MAX_WIDTH]| L::from_fn(|k| v[k]);
        let dir = self.scene.camera.directions(
            lane(&xs.map(|x| x as f32)),
            lane(&ys.map(|y| y as f32)),
            lane(&jx),
            lane(&jy),
        );
        let origin = V3::splat(self.scene.camera.origin);
        let packet = RayPacket::from_lanes(origin, dir, active).with_cull(cull);
        counts.camera += active.count_ones() as u64;
        counts.camera_packets.record(active);
        self.shade_packet::<L>(packet, active, &keys, 0, self.scene.max_depth, true, counts)
    }

    /// The colours the lanes' rays see at path vertex `vertex`. With `camera`, the
    /// semantics of `trace` (budget = bounces left; path-traced materials continue the
    /// path); without, those of `evaluate_once` (what a mirror sees; budget = mirror
    /// reflections left).
    #[allow(clippy::too_many_arguments)]
    fn shade_packet<L: Lane>(
        &self,
        packet: RayPacket<L>,
        active: u32,
        keys: &[SampleKey; MAX_WIDTH],
        vertex: u32,
        budget: u32,
        camera: bool,
        counts: &mut RayCounts,
    ) -> V3<L> {
        let mut out = V3::splat(Vec3::ZERO);
        if budget == 0 || active == 0 {
            return out;
        }
        let scene = self.scene;
        // `trace` multiplies what it returns by the path throughput, which is one at the
        // camera vertex: keep the multiplication so the bits are the scalar ones.
        let weight = |c: Vec3| if camera { Vec3::ONE * c } else { c };
        let weight_lanes = |v: V3<L>| {
            if camera {
                let one = L::splat(1.0);
                V3::new(one * v.x, one * v.y, one * v.z)
            } else {
                v
            }
        };
        // The lanes shaded one at a time (lights seen, path-traced materials): their
        // colours, merged into `out` on the way out.
        let mut each = [Vec3::ZERO; MAX_WIDTH];
        let mut each_lanes = 0u32;
        let merge = |out: V3<L>, each: &[Vec3; MAX_WIDTH], each_lanes: u32| {
            if each_lanes == 0 {
                out
            } else {
                V3::select(
                    L::Mask::from_bits(each_lanes),
                    V3::from_fn(|k| each[k]),
                    out,
                )
            }
        };
        let (origin, dir) = (packet.origin(), packet.dir());
        let hits = if self.specialize
            && !(camera && self.camera_inside)
            && packet.hits_box(&scene.bounds, T_MIN, f32::INFINITY) & active == 0
        {
            // The whole packet misses the scene: background at once. (A camera packet
            // whose tile's cone meets nothing never gets here: `sample_packet`; nor one
            // from a camera inside the bounds, which every ray meets.)
            counts.packets_outside += 1;
            PacketHits::none(active)
        } else {
            self.accel
                .closest_hit_packet(scene, &packet, T_MIN, &mut counts.traversal)
        };
        // The lanes by how their hit is shaded, from the per-object tables: a lane's
        // material is a coin toss for the branch predictor, so no branch on it here.
        let t = &self.tables;
        let found = hits.found & active;
        // Lane k's entry in the tables: its object + 1, 0 without a hit.
        let slot = |k: usize| {
            if found >> k & 1 != 0 {
                hits.object_of(k) as usize + 1
            } else {
                0
            }
        };
        // The lanes of each class, and the Phong material when every Phong lane has
        // the same one. With few objects, one lane compare per object
        // (`ShadeTables::few`); else one table lookup per lane.
        let (by_class, uniform_phong) = if t.few {
            let mut by_class = [0u32; CLASSES];
            by_class[MISS] = !found;
            let mut phong = NO_PHONG;
            for o in 0..t.class.len() - 1 {
                let lanes = hits.of_object(o as u32) & found;
                if lanes == 0 {
                    continue;
                }
                let class = t.class[o + 1] as usize;
                by_class[class] |= lanes;
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
            let classes = std::array::from_fn(|k| {
                if k < L::WIDTH {
                    t.class[slot(k)]
                } else {
                    NO_LANE
                }
            });
            (lanes_by_class(classes), MIXED_PHONG)
        };
        let background = V3::splat(weight(scene.background));
        out = V3::select(L::Mask::from_bits(by_class[MISS] & active), background, out);
        for k in set_lanes(by_class[LIGHT]) {
            if let Material::Light { color, .. } = *scene.material_of(slot(k) as u32 - 1) {
                each[k] = weight(color);
                each_lanes |= 1 << k;
            }
        }
        let mut path_lanes = 0u32;
        for k in set_lanes(by_class[PATH]) {
            match *scene.material_of(slot(k) as u32 - 1) {
                Material::Diffuse { albedo } | Material::Metal { albedo, .. } if !camera => {
                    each[k] = albedo;
                    each_lanes |= 1 << k;
                }
                Material::Dielectric { .. } if !camera => {
                    each[k] = Vec3::ONE;
                    each_lanes |= 1 << k;
                }
                _ => path_lanes |= 1 << k,
            }
        }
        let mirror_lanes = by_class[MIRROR];
        let phong_lanes = by_class[PHONG] | mirror_lanes;
        if phong_lanes | path_lanes == 0 {
            return merge(out, &each, each_lanes);
        }
        // The surfaces, lane-wise.
        let s = self.surface_lanes::<L>(origin, dir, &hits, phong_lanes | path_lanes);
        for k in set_lanes(path_lanes) {
            // A path-traced bounce: on alone, one ray at a time.
            let hit = hits.hit(k).expect("a path-traced lane has a hit");
            let material = scene.material_of(hit.object);
            let surface = s.lane(k, hit.object);
            let ray = Ray::new(origin.lane(k), dir.lane(k));
            each_lanes |= 1 << k;
            each[k] = match scatter(material, &ray, &surface, keys[k], vertex) {
                Some((attenuation, next_dir)) => {
                    let throughput = Vec3::ONE * attenuation;
                    let next = spawn_ray(&surface.point, surface.normal, next_dir);
                    counts.secondary += 1;
                    self.trace_from(next, keys[k], throughput, vertex + 1, budget - 1, counts)
                }
                None => Vec3::ZERO,
            };
        }
        if phong_lanes == 0 {
            return merge(out, &each, each_lanes);
        }

        // The lanes' Phong parameters. A lane that does not shade with Phong takes the
        // first Phong lane's material (its values are never read), so a packet on one
        // material is recognised by `PhongLanes::from_indices` and splatted.
        let materials = if uniform_phong < MIXED_PHONG {
            PhongLanes::<L>::splat(&t.phong[uniform_phong as usize])
        } else {
            let first = t.phong_of[slot(phong_lanes.trailing_zeros() as usize)];
            let index: [u32; MAX_WIDTH] = std::array::from_fn(|k| {
                if phong_lanes >> k & 1 != 0 {
                    t.phong_of[slot(k)]
                } else {
                    first
                }
            });
            PhongLanes::<L>::from_indices(&t.phong, &index)
        };
        let view = -dir;
        // Phong over the lanes, the same kernel as the scalar tracer's. As there, each
        // light sample's shadow rays are traced when the kernel asks for the sample: one
        // packet over the lanes that shade with Phong and have a direction to it.
        let local = super::phong_lanes(&materials, scene, s.normal, view, |li, j| {
            let light = &scene.lights[li];
            let target = match light.shape {
                LightShape::Point { center, .. } => V3::splat(center),
                _ => V3::from_fn(|k| {
                    if phong_lanes >> k & 1 != 0 {
                        self.light_target(keys[k], vertex, li, j)
                    } else {
                        Vec3::ZERO
                    }
                }),
            };
            let (l, ok) = direction_to(target, s.point);
            let mut traced = ok.bits() & phong_lanes;
            if self.specialize {
                let culled = adds_nothing_lanes(s.normal, l, view, &materials.shininess, traced);
                counts.shadow_culled += culled.count_ones() as u64;
                traced &= !culled;
            }
            if traced == 0 {
                return (0, l);
            }
            counts.shadow += traced.count_ones() as u64;
            counts.shadow_packets.record(traced);
            let o = spawn_origin(s.point, s.error, s.normal, l);
            let p = RayPacket::<L>::from_active_lanes(o, l, traced);
            let visible = self.accel.light_visible_packet(
                scene,
                &p,
                T_MIN,
                light,
                traced,
                &mut counts.traversal,
            );
            (visible, l)
        });
        out = V3::select(
            L::Mask::from_bits(phong_lanes & !mirror_lanes),
            weight_lanes(local),
            out,
        );
        if mirror_lanes == 0 {
            return merge(out, &each, each_lanes);
        }

        // PhongMirror: the reflections as one packet, then the Schlick mix.
        let reflected_dir = mirror_direction(dir, s.normal);
        let reflected_origin = spawn_origin(s.point, s.error, s.normal, reflected_dir);
        counts.secondary += mirror_lanes.count_ones() as u64;
        counts.mirror_packets.record(mirror_lanes);
        let reflected = self.shade_packet::<L>(
            RayPacket::from_active_lanes(reflected_origin, reflected_dir, mirror_lanes),
            mirror_lanes,
            keys,
            vertex + 1,
            budget - 1,
            false,
            counts,
        );
        let f = mirror_fresnel(dir, s.normal, L::from_fn(|k| t.mirror_index[slot(k)]));
        let mixed = local.scale(L::splat(1.0) - f) + reflected.scale(f);
        out = V3::select(L::Mask::from_bits(mirror_lanes), weight_lanes(mixed), out);
        merge(out, &each, each_lanes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every assignment of classes (and "no lane") to the first five lanes, with the
    /// other three cycling: the masks are those of a plain loop.
    #[test]
    fn lanes_by_class_is_the_plain_loop() {
        let values = [MISS, LIGHT, PHONG, MIRROR, PATH, NO_LANE as usize];
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
            let mut expected = [0u32; CLASSES];
            for (k, &cl) in classes.iter().enumerate() {
                if (cl as usize) < CLASSES {
                    expected[cl as usize] |= 1 << k;
                }
            }
            assert_eq!(lanes_by_class(classes), expected, "{classes:?}");
            n += 1;
        }
        assert_eq!(n, 7776);
    }
}
