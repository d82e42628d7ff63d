//! A probe for instruction counts (valgrind --tool=callgrind): traces the camera rays of a
//! built-in scene (argument 1, default `bunny-closeup`) at a packet width (argument 2: 1, 4
//! or 8), one thread, and prints the hits. Not a benchmark: compare variants by
//! callgrind's instruction count, which the shared machine's load does not move.
//!
//! cargo build --release --example packet_probe
//! valgrind --tool=callgrind target/release/examples/packet_probe bunny-closeup 8

use raytracer::accel::packet::{RayPacket, MAX_WIDTH};
use raytracer::accel::{Accel, AccelKind, TraversalStats};
use raytracer::geometry::Ray;
use raytracer::integrator::{footprint, T_MIN};
use raytracer::rng::{slot, SampleKey};
use raytracer::scene::{Overrides, Scene};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("bunny-closeup", |s| s.as_str());
    let width: usize = args.get(2).map_or(8, |s| s.parse().expect("a width"));
    let overrides = Overrides {
        width: Some(400),
        spp: Some(2),
        max_depth: None,
    };
    let mut scene = Scene::load(name, overrides).expect("a built-in scene");
    let accel = Accel::build(&mut scene, AccelKind::Bvh);
    let cam = scene.camera;
    let (fw, fh) = footprint(width);
    let mut stats = TraversalStats::default();
    let mut hits = 0u64;
    for py in (0..cam.height).step_by(fh as usize) {
        for px in (0..cam.width).step_by(fw as usize) {
            for s in 0..scene.spp {
                let mut rays = [Ray::new(cam.origin, glam::Vec3::X); MAX_WIDTH];
                let mut active = 0u32;
                for k in 0..width as u32 {
                    let (x, y) = (px + k % fw, py + k / fw);
                    if x < cam.width && y < cam.height {
                        let key = SampleKey::new(0, x, y, s);
                        let (jx, jy) = (
                            key.uniform(0, slot::JITTER_X),
                            key.uniform(0, slot::JITTER_Y),
                        );
                        rays[k as usize] = cam.ray(x, y, jx, jy);
                        active |= 1 << k;
                    }
                }
                hits += match width {
                    8 => {
                        let p = RayPacket::<wide::f32x8>::new(&rays, active);
                        let h = accel.closest_hit_packet(&scene, &p, T_MIN, &mut stats);
                        h.iter().filter(|h| h.is_some()).count() as u64
                    }
                    4 => {
                        let p = RayPacket::<glam::Vec4>::new(&rays, active);
                        let h = accel.closest_hit_packet(&scene, &p, T_MIN, &mut stats);
                        h.iter().filter(|h| h.is_some()).count() as u64
                    }
                    _ => accel
                        .closest_hit(&scene, &rays[0], T_MIN, f32::INFINITY, &mut stats)
                        .is_some() as u64,
                };
            }
        }
    }
    println!("{name} width {width}: {hits} hits, {stats:?}");
}
