//! Ray sets shared by the benches and the examples: a scene's camera rays one at a time
//! in pixel order (`benches/bvh.rs`), and in packets as the renderer groups them; the
//! shadow rays from their hits to the first light; and the packets' rays in lanes
//! (`in_lanes`), the form the renderer makes them in and the form Embree's
//! `rtcIntersect8` is handed (SoA).
//! Each bench and example that includes this module uses part of it.
#![allow(dead_code)]

use raytracer::accel::packet::RayPacket;
use raytracer::accel::{Accel, AccelKind};
use raytracer::geometry::spawn::spawn_ray;
use raytracer::geometry::Ray;
use raytracer::integrator::{footprint, Tracer};
use raytracer::lanes::MAX_WIDTH;
use raytracer::lanes::{Lane, V3};
use raytracer::sampling::{slot, SampleKey};
use raytracer::scene::{Overrides, Scene};

/// Built-in scene `name` at 400 px wide and 2 samples a pixel, with its BVH: the small
/// size of `benches/probes/packet_probe.rs` and `benches/render.rs`.
pub fn small_scene(name: &str) -> (Scene, Accel) {
    let overrides = Overrides {
        width: Some(400),
        spp: Some(2),
        max_depth: None,
    };
    let mut scene = Scene::load(name, overrides).expect("a built-in scene");
    let accel = Accel::build(&mut scene, AccelKind::Bvh);
    (scene, accel)
}

/// The camera rays of `scene` one at a time, pixel by pixel with the `spp` samples of a
/// pixel together (`benches/bvh.rs`'s order).
pub fn camera_rays(scene: &Scene, spp: u32) -> Vec<Ray> {
    let cam = &scene.camera;
    let mut rays = Vec::with_capacity((cam.width * cam.height * spp) as usize);
    for y in 0..cam.height {
        for x in 0..cam.width {
            for s in 0..spp {
                let key = SampleKey::new(0, x, y, s);
                rays.push(cam.ray(
                    x,
                    y,
                    key.uniform(0, slot::JITTER_X),
                    key.uniform(0, slot::JITTER_Y),
                    key.uniform(0, slot::LENS_X),
                    key.uniform(0, slot::LENS_Y),
                ));
            }
        }
    }
    rays
}

/// Rays of a packet (unused lanes hold a copy) and its active mask.
pub type Packet = ([Ray; MAX_WIDTH], u32);

/// The camera rays of `scene`, in packets of `width` lanes (1: one ray a packet).
pub fn camera_packets(scene: &Scene, width: usize) -> Vec<Packet> {
    let cam = &scene.camera;
    let (fw, fh) = footprint(width);
    let mut out = Vec::new();
    for py in (0..cam.height).step_by(fh as usize) {
        for px in (0..cam.width).step_by(fw as usize) {
            for s in 0..scene.spp {
                let mut rays = [Ray::new(cam.origin, glam::Vec3::X); MAX_WIDTH];
                let mut active = 0;
                for k in 0..width as u32 {
                    let (x, y) = (px + k % fw, py + k / fw);
                    if x < cam.width && y < cam.height {
                        let key = SampleKey::new(0, x, y, s);
                        rays[k as usize] = cam.ray(
                            x,
                            y,
                            key.uniform(0, slot::JITTER_X),
                            key.uniform(0, slot::JITTER_Y),
                            key.uniform(0, slot::LENS_X),
                            key.uniform(0, slot::LENS_Y),
                        );
                        active |= 1 << k;
                    }
                }
                out.push((rays, active));
            }
        }
    }
    out
}

/// For each camera packet, the shadow rays from its lanes' hits towards light 0 (lanes
/// that hit nothing, or the light itself, stay inactive).
pub fn shadow_packets(scene: &Scene, accel: &Accel, camera: &[Packet]) -> Vec<Packet> {
    let tracer = Tracer::new(scene, accel, 0);
    let mut counts = Default::default();
    let mut out = Vec::new();
    for (rays, active) in camera {
        let mut shadow = *rays;
        let mut m = 0;
        for k in 0..MAX_WIDTH {
            if active >> k & 1 == 0 {
                continue;
            }
            let Some(hit) = tracer.closest_hit(&rays[k], &mut counts) else {
                continue;
            };
            if hit.object == scene.lights[0].object {
                continue;
            }
            let s = tracer.surface(&rays[k], &hit);
            if let Some((_, r)) = tracer.shadow_ray(&s, SampleKey::from_hash(0), 0, 0, 0) {
                shadow[k] = spawn_ray(&s.point, s.normal, r.dir);
                m |= 1 << k;
            }
        }
        if m != 0 {
            out.push((shadow, m));
        }
    }
    out
}

/// The rays of the active lanes, in order: the scalar path traces these (a plain array,
/// so it does not pay for copying packets).
pub fn flatten(packets: &[Packet]) -> Vec<Ray> {
    packets
        .iter()
        .flat_map(|(rays, active)| {
            (0..MAX_WIDTH)
                .filter(move |k| active >> k & 1 != 0)
                .map(move |k| rays[k])
        })
        .collect()
}

/// A packet's rays in lanes, inactive lanes holding a copy of the first active ray (as
/// `RayPacket::new` fills them), and its active mask.
pub struct LanePacket<L> {
    pub origin: V3<L>,
    pub dir: V3<L>,
    pub active: u32,
}

/// `packets` transposed into lanes once, before any timing (by `RayPacket::new`, whose
/// lanes these are): the renderer never builds a packet from an array of rays (it makes
/// rays in lanes and calls `RayPacket::from_lanes`), and Embree's packet calls take
/// their rays as SoA arrays.
pub fn in_lanes<L: Lane>(packets: &[Packet]) -> Vec<LanePacket<L>> {
    packets
        .iter()
        .map(|(rays, active)| {
            let p = RayPacket::<L>::new(rays, *active);
            LanePacket {
                origin: p.origin(),
                dir: p.dir(),
                active: *active,
            }
        })
        .collect()
}
