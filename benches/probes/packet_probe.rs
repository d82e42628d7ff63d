//! A probe for instruction counts (valgrind --tool=callgrind): traces a ray set of a
//! built-in scene at a packet width, one thread, and prints the hits. Arguments: scene
//! (default `bunny-closeup`), width (1, 4 or 8; default 8), ray set (`camera`, default,
//! or `shadow`: the rays from the camera rays' hits to the first light, as
//! `benches/packets.rs` makes them). The image is 400 px wide at 2 samples a pixel. Not a
//! benchmark: compare variants by callgrind's instruction count in `trace_all`, which the
//! shared machine's load does not move.
//!
//! cargo build --release --example packet_probe
//! valgrind --tool=callgrind --toggle-collect=packet_probe::trace_all \
//!     target/release/examples/packet_probe bunny shadow 8

#[path = "../common/mod.rs"]
mod common;

use common::{camera_packets, flatten, in_lanes, shadow_packets, small_scene, LanePacket, Packet};
use raytracer::accel::packet::RayPacket;
use raytracer::accel::{Accel, Context, TraversalStats};
use raytracer::integrator::T_MIN;
use raytracer::lanes::Lane;
use raytracer::scene::Scene;

/// Closest hits (camera) or visible lanes (shadow) of every packet: the count of hits.
/// Width 1 traces the packets' rays one at a time (flattening them is counted); the
/// wider ones take the packets' rays already in lanes, as the bench does.
#[inline(never)]
fn trace_all<L: Lane>(
    scene: &Scene,
    accel: &Accel,
    packets: &[Packet],
    lanes: &[LanePacket<L>],
    shadow: bool,
    stats: &mut TraversalStats,
) -> u64 {
    let mut hits = 0u64;
    if L::WIDTH == 1 {
        for ray in &flatten(packets) {
            hits += if shadow {
                accel.light_visible(Context::new(scene, stats), ray, T_MIN, &scene.lights[0])
            } else {
                accel
                    .closest_hit(Context::new(scene, stats), ray, T_MIN, f32::INFINITY)
                    .is_some()
            } as u64;
        }
        return hits;
    }
    for lp in lanes {
        let p = RayPacket::<L>::from_lanes(lp.origin, lp.dir, lp.active);
        hits += if shadow {
            let v = accel.light_visible_packet(
                Context::new(scene, stats),
                &p,
                T_MIN,
                &scene.lights[0],
                lp.active,
                None,
            );
            v.count_ones() as u64
        } else {
            let h = accel.closest_hit_packet(Context::new(scene, stats), &p, T_MIN);
            (h.found & lp.active).count_ones() as u64
        };
    }
    hits
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("bunny-closeup", |s| s.as_str());
    let width: usize = args.get(2).map_or(8, |s| s.parse().expect("a width"));
    let shadow = match args.get(3).map_or("camera", |s| s.as_str()) {
        "camera" => false,
        "shadow" => true,
        other => panic!("ray set `camera` or `shadow`, not `{other}`"),
    };
    let (scene, accel) = small_scene(name);
    // Width 1 traces the 8-wide packets' rays one at a time.
    let mut packets = camera_packets(&scene, if width == 4 { 4 } else { 8 });
    if shadow {
        packets = shadow_packets(&scene, &accel, &packets);
    }
    let mut stats = TraversalStats::default();
    let hits = match width {
        8 => {
            let lanes = in_lanes(&packets);
            trace_all::<wide::f32x8>(&scene, &accel, &packets, &lanes, shadow, &mut stats)
        }
        4 => {
            let lanes = in_lanes(&packets);
            trace_all::<glam::Vec4>(&scene, &accel, &packets, &lanes, shadow, &mut stats)
        }
        _ => trace_all::<f32>(&scene, &accel, &packets, &[], shadow, &mut stats),
    };
    let rays: u32 = packets.iter().map(|(_, a)| a.count_ones()).sum();
    let set = if shadow { "shadow" } else { "camera" };
    println!("{name} {set} width {width}: {rays} rays, {hits} hits, {stats:?}");
}
