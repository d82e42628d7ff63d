//! Packets against single rays, one thread, on the same rays: the camera rays of `bunny`
//! and `bunny-closeup` (800x450, 10 jittered samples a pixel, grouped as the renderer
//! groups them: 4x2 pixels at one sample index for 8 lanes, 2x2 for 4), and the shadow
//! rays from the `bunny` camera rays' Phong hits to its point light.
//!
//! `cargo bench --bench packets`; throughput is in rays (elements) per second. Before
//! timing, every width's answers are checked against the scalar ones (same t, same
//! primitive, same visibility).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use raytracer::accel::packet::{RayPacket, MAX_WIDTH};
use raytracer::accel::{Accel, AccelKind, TraversalStats};
use raytracer::geometry::spawn::spawn_ray;
use raytracer::geometry::Ray;
use raytracer::integrator::{footprint, Tracer, T_MIN};
use raytracer::lanes::Lane;
use raytracer::rng::{slot, SampleKey};
use raytracer::scene::{Overrides, Scene};
use wide::f32x8;

/// Rays of a packet (unused lanes hold a copy) and its active mask.
type Packet = ([Ray; MAX_WIDTH], u32);

/// The camera rays of `scene`, in packets of `width` lanes (1: one ray a packet).
fn camera_packets(scene: &Scene, width: usize) -> Vec<Packet> {
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
fn shadow_packets(scene: &Scene, accel: &Accel, camera: &[Packet]) -> Vec<Packet> {
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

fn closest_packets<L: Lane>(scene: &Scene, accel: &Accel, packets: &[Packet]) -> Vec<u64> {
    let mut stats = TraversalStats::default();
    let mut out = Vec::new();
    for (rays, active) in packets {
        let p = RayPacket::<L>::new(rays, *active);
        let hits = accel.closest_hit_packet(scene, &p, T_MIN, &mut stats);
        for (k, h) in hits.iter().enumerate().take(L::WIDTH) {
            if active >> k & 1 != 0 {
                out.push(h.map_or(u64::MAX, |h| (h.t.to_bits() as u64) << 32 | h.id as u64));
            }
        }
    }
    out
}

/// The rays of the active lanes, in order: the scalar path traces these (a plain array,
/// so it does not pay for copying packets).
fn flatten(packets: &[Packet]) -> Vec<Ray> {
    packets
        .iter()
        .flat_map(|(rays, active)| {
            (0..MAX_WIDTH)
                .filter(move |k| active >> k & 1 != 0)
                .map(move |k| rays[k])
        })
        .collect()
}

fn closest_scalar(scene: &Scene, accel: &Accel, rays: &[Ray]) -> Vec<u64> {
    let mut stats = TraversalStats::default();
    let mut out = Vec::with_capacity(rays.len());
    for r in rays {
        let h = accel.closest_hit(scene, r, T_MIN, f32::INFINITY, &mut stats);
        out.push(h.map_or(u64::MAX, |h| (h.t.to_bits() as u64) << 32 | h.id as u64));
    }
    out
}

fn visible_packets<L: Lane>(scene: &Scene, accel: &Accel, packets: &[Packet]) -> Vec<bool> {
    let mut stats = TraversalStats::default();
    let light = &scene.lights[0];
    let mut out = Vec::new();
    for (rays, active) in packets {
        let p = RayPacket::<L>::new(rays, *active);
        let v = accel.light_visible_packet(scene, &p, T_MIN, light, *active, &mut stats);
        out.extend(
            (0..L::WIDTH)
                .filter(|k| active >> k & 1 != 0)
                .map(|k| v >> k & 1 != 0),
        );
    }
    out
}

fn visible_scalar(scene: &Scene, accel: &Accel, rays: &[Ray]) -> Vec<bool> {
    let mut stats = TraversalStats::default();
    let light = &scene.lights[0];
    let mut out = Vec::with_capacity(rays.len());
    for r in rays {
        out.push(accel.light_visible(scene, r, T_MIN, light, &mut stats));
    }
    out
}

fn bench_packets(c: &mut Criterion) {
    eprintln!(
        "AVX2 compiled in: {} (8-wide lanes run as {})",
        raytracer::lanes::AVX2,
        if raytracer::lanes::AVX2 {
            "one AVX register"
        } else {
            "two SSE halves"
        }
    );
    for name in ["bunny", "bunny-closeup"] {
        let mut scene = Scene::load(name, Overrides::default()).unwrap();
        let accel = Accel::build(&mut scene, AccelKind::Bvh);
        let (p4, p8) = (camera_packets(&scene, 4), camera_packets(&scene, 8));
        // The scalar path traces the 8-wide packets' rays, in their order.
        let r1 = flatten(&p8);
        // Validate: every width gives the scalar answers (4-wide packets order the rays
        // differently: compare those with their own flattening).
        assert_eq!(
            closest_scalar(&scene, &accel, &r1),
            closest_packets::<f32x8>(&scene, &accel, &p8),
            "8-wide camera rays of {name}"
        );
        assert_eq!(
            closest_scalar(&scene, &accel, &flatten(&p4)),
            closest_packets::<glam::Vec4>(&scene, &accel, &p4),
            "4-wide camera rays of {name}"
        );

        let mut group = c.benchmark_group(format!("camera_rays/{name}"));
        group.sample_size(10);
        group.throughput(Throughput::Elements(r1.len() as u64));
        group.bench_function("scalar", |b| {
            b.iter(|| closest_scalar(&scene, &accel, &r1).len())
        });
        group.bench_function("4-wide", |b| {
            b.iter(|| closest_packets::<glam::Vec4>(&scene, &accel, &p4).len())
        });
        group.bench_function("8-wide", |b| {
            b.iter(|| closest_packets::<f32x8>(&scene, &accel, &p8).len())
        });
        group.finish();

        if name != "bunny" {
            continue;
        }
        let (s4, s8) = (
            shadow_packets(&scene, &accel, &p4),
            shadow_packets(&scene, &accel, &p8),
        );
        let s1 = flatten(&s8);
        assert_eq!(
            visible_scalar(&scene, &accel, &s1),
            visible_packets::<f32x8>(&scene, &accel, &s8)
        );
        assert_eq!(
            visible_scalar(&scene, &accel, &flatten(&s4)),
            visible_packets::<glam::Vec4>(&scene, &accel, &s4)
        );
        let mut group = c.benchmark_group(format!("shadow_rays/{name}"));
        group.sample_size(10);
        group.throughput(Throughput::Elements(s1.len() as u64));
        group.bench_function("scalar", |b| {
            b.iter(|| visible_scalar(&scene, &accel, &s1).len())
        });
        group.bench_function("4-wide", |b| {
            b.iter(|| visible_packets::<glam::Vec4>(&scene, &accel, &s4).len())
        });
        group.bench_function("8-wide", |b| {
            b.iter(|| visible_packets::<f32x8>(&scene, &accel, &s8).len())
        });
        group.finish();
    }
}

criterion_group!(benches, bench_packets);
criterion_main!(benches);
