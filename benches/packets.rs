//! Packets against single rays, one thread, on the same rays: the camera rays of `bunny`
//! and `bunny-closeup` (800x450, 10 jittered samples a pixel, grouped as the renderer
//! groups them: 4x4 pixels at one sample index for 16 lanes, 4x2 for 8, 2x2 for 4), and
//! the shadow rays from the `bunny` camera rays' Phong hits to its point light.
//!
//! The packets are handed over with their rays already in lanes (`common::in_lanes`),
//! as the renderer makes them and as `rtcIntersect8` takes them; the timed loop makes
//! each `RayPacket` (`from_lanes`: reciprocals, signs, sphere constants) and traces it.
//! It does not time a transpose of eight `Ray`s into lanes (`RayPacket::new`), which the
//! renderer never runs and which would be ~10% of a `bunny` camera packet's
//! instructions.
//!
//! `cargo bench --bench packets`; throughput is in rays (elements) per second. Before
//! timing, every width's answers are checked against the scalar ones (same t, same
//! primitive, same visibility).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use raytracer::accel::packet::RayPacket;
use raytracer::accel::{Accel, AccelKind, Context, TraversalStats};
use raytracer::geometry::Ray;
use raytracer::integrator::T_MIN;
use raytracer::lanes::{set_lanes, F32x16, Lane};
use raytracer::scene::{Overrides, Scene};
use wide::f32x8;

mod common;
use common::{camera_packets, flatten, in_lanes, shadow_packets, LanePacket, Packet};

fn closest_packets<L: Lane>(scene: &Scene, accel: &Accel, packets: &[LanePacket<L>]) -> Vec<u64> {
    let mut stats = TraversalStats::default();
    let mut out = Vec::new();
    for lp in packets {
        let p = RayPacket::<L>::from_lanes(lp.origin, lp.dir, lp.active);
        let hits = accel.closest_hit_packet(Context::new(scene, &mut stats), &p, T_MIN);
        for k in set_lanes(lp.active) {
            let h = hits.hit(k);
            out.push(h.map_or(u64::MAX, |h| (h.t.to_bits() as u64) << 32 | h.id as u64));
        }
    }
    out
}

fn closest_scalar(scene: &Scene, accel: &Accel, rays: &[Ray]) -> Vec<u64> {
    let mut stats = TraversalStats::default();
    let mut out = Vec::with_capacity(rays.len());
    for r in rays {
        let h = accel.closest_hit(Context::new(scene, &mut stats), r, T_MIN, f32::INFINITY);
        out.push(h.map_or(u64::MAX, |h| (h.t.to_bits() as u64) << 32 | h.id as u64));
    }
    out
}

fn visible_packets<L: Lane>(scene: &Scene, accel: &Accel, packets: &[LanePacket<L>]) -> Vec<bool> {
    let mut stats = TraversalStats::default();
    let light = &scene.lights[0];
    let mut out = Vec::new();
    for lp in packets {
        let p = RayPacket::<L>::from_lanes(lp.origin, lp.dir, lp.active);
        let v = accel.light_visible_packet(
            Context::new(scene, &mut stats),
            &p,
            T_MIN,
            light,
            lp.active,
            None,
        );
        out.extend(
            (0..L::WIDTH)
                .filter(|k| lp.active >> k & 1 != 0)
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
        out.push(accel.light_visible(Context::new(scene, &mut stats), r, T_MIN, light));
    }
    out
}

/// `packets` in lanes of `L`, checked first: their closest hits are the scalar path's
/// for the same rays in the same order.
fn camera_lanes<L: Lane>(
    name: &str,
    scene: &Scene,
    accel: &Accel,
    packets: &[Packet],
) -> Vec<LanePacket<L>> {
    let lanes = in_lanes::<L>(packets);
    assert_eq!(
        closest_scalar(scene, accel, &flatten(packets)),
        closest_packets::<L>(scene, accel, &lanes),
        "{}-wide camera rays of {name}",
        L::WIDTH
    );
    lanes
}

/// `camera_lanes` for shadow rays: what they see of the light is the scalar path's.
fn shadow_lanes<L: Lane>(scene: &Scene, accel: &Accel, packets: &[Packet]) -> Vec<LanePacket<L>> {
    let lanes = in_lanes::<L>(packets);
    assert_eq!(
        visible_scalar(scene, accel, &flatten(packets)),
        visible_packets::<L>(scene, accel, &lanes),
        "{}-wide shadow rays",
        L::WIDTH
    );
    lanes
}

fn bench_packets(c: &mut Criterion) {
    eprintln!("lanes: {}", raytracer::lanes::COMPILED);
    for name in ["bunny", "bunny-closeup"] {
        let mut scene = Scene::load(name, Overrides::default()).unwrap();
        let accel = Accel::build(&mut scene, AccelKind::Bvh);
        let p4 = camera_packets(&scene, 4);
        let p8 = camera_packets(&scene, 8);
        let p16 = camera_packets(&scene, 16);
        // The scalar path traces the 8-wide packets' rays, in their order.
        let r1 = flatten(&p8);
        // Every width gives the scalar answers (4-wide packets order the rays
        // differently: each width is checked against its own flattening).
        let l4 = camera_lanes::<glam::Vec4>(name, &scene, &accel, &p4);
        let l8 = camera_lanes::<f32x8>(name, &scene, &accel, &p8);
        let l16 = camera_lanes::<F32x16>(name, &scene, &accel, &p16);

        let mut group = c.benchmark_group(format!("camera_rays/{name}"));
        group.sample_size(10);
        group.throughput(Throughput::Elements(r1.len() as u64));
        group.bench_function("scalar", |b| {
            b.iter(|| closest_scalar(&scene, &accel, &r1).len())
        });
        group.bench_function("4-wide", |b| {
            b.iter(|| closest_packets::<glam::Vec4>(&scene, &accel, &l4).len())
        });
        group.bench_function("8-wide", |b| {
            b.iter(|| closest_packets::<f32x8>(&scene, &accel, &l8).len())
        });
        group.bench_function("16-wide", |b| {
            b.iter(|| closest_packets::<F32x16>(&scene, &accel, &l16).len())
        });
        group.finish();

        if name != "bunny" {
            continue;
        }
        let s8 = shadow_packets(&scene, &accel, &p8);
        let s1 = flatten(&s8);
        let t4 = shadow_lanes::<glam::Vec4>(&scene, &accel, &shadow_packets(&scene, &accel, &p4));
        let t8 = shadow_lanes::<f32x8>(&scene, &accel, &s8);
        let t16 = shadow_lanes::<F32x16>(&scene, &accel, &shadow_packets(&scene, &accel, &p16));
        let mut group = c.benchmark_group(format!("shadow_rays/{name}"));
        group.sample_size(10);
        group.throughput(Throughput::Elements(s1.len() as u64));
        group.bench_function("scalar", |b| {
            b.iter(|| visible_scalar(&scene, &accel, &s1).len())
        });
        group.bench_function("4-wide", |b| {
            b.iter(|| visible_packets::<glam::Vec4>(&scene, &accel, &t4).len())
        });
        group.bench_function("8-wide", |b| {
            b.iter(|| visible_packets::<f32x8>(&scene, &accel, &t8).len())
        });
        group.bench_function("16-wide", |b| {
            b.iter(|| visible_packets::<F32x16>(&scene, &accel, &t16).len())
        });
        group.finish();
    }
}

criterion_group!(benches, bench_packets);
criterion_main!(benches);
