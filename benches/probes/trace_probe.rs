//! Probe for the scalar closest-hit loop: the camera rays of `benches/bvh.rs` traced once
//! (or `passes` times) in `trace_all`, with a checksum of every `(t, id)` so variants can
//! be checked bit for bit. For instruction counts:
//!
//! ```sh
//! cargo build --release --example trace_probe
//! valgrind --tool=callgrind --toggle-collect=trace_probe::trace_all \
//!     target/release/examples/trace_probe bunny-closeup
//! ```
//!
//! Arguments: scene (`bunny`, `bunny-closeup`), subdivision levels (default 0), passes
//! (default 1).

#[path = "../common/mod.rs"]
mod common;
use common::camera_rays;
use raytracer::accel::{Accel, AccelKind, Context, TraversalStats};
use raytracer::geometry::Ray;
use raytracer::integrator::T_MIN;
use raytracer::scene::{Overrides, Scene, SceneSource};
use std::borrow::Cow;
use std::time::Instant;

fn subdivided(name: &str, levels: u32) -> Scene {
    let base = SceneSource::resolve(name).unwrap();
    let text = base.text.replace(
        "path = \"../assets/bunny.obj\"",
        &format!("path = \"../assets/bunny.obj\"\nsubdivide = {levels}"),
    );
    let source = SceneSource {
        text: Cow::Owned(text),
        ..base
    };
    raytracer::scene::compile(&source, &source.parse().unwrap(), Overrides::default()).unwrap()
}

#[inline(never)]
fn trace_all(accel: &Accel, scene: &Scene, rays: &[Ray], stats: &mut TraversalStats) -> u64 {
    let mut sum = 0u64;
    for r in rays {
        if let Some(h) = accel.closest_hit(Context::new(scene, stats), r, T_MIN, f32::INFINITY) {
            sum = sum
                .wrapping_mul(0x100000001b3)
                .wrapping_add(((h.t.to_bits() as u64) << 32) | h.id as u64);
        } else {
            sum = sum.wrapping_mul(0x100000001b3).wrapping_add(1);
        }
    }
    sum
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("bunny-closeup", |s| s.as_str());
    let levels: u32 = args.get(2).map_or(0, |s| s.parse().unwrap());
    let passes: u32 = args.get(3).map_or(1, |s| s.parse().unwrap());
    let scene = if levels == 0 {
        Scene::load(name, Overrides::default()).unwrap()
    } else {
        subdivided(name, levels)
    };
    let rays = camera_rays(&scene, scene.spp);
    let mut scene = scene;
    let accel = Accel::build(&mut scene, AccelKind::Bvh);
    let mut stats = TraversalStats::default();
    let mut sum = 0;
    let start = Instant::now();
    for _ in 0..passes {
        stats = TraversalStats::default();
        sum = trace_all(&accel, &scene, &rays, &mut stats);
    }
    let secs = start.elapsed().as_secs_f64();
    let n = rays.len() as f64;
    println!(
        "{name} x{levels}: {} rays, checksum {sum:016x}, {:.3} nodes/ray, {:.3} prims/ray, {:.2} Mrays/s",
        rays.len(),
        stats.nodes as f64 / n,
        stats.prims as f64 / n,
        n * passes as f64 / secs / 1e6
    );
}
