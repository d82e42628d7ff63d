//! BVH benchmarks: one-thread closest-hit rates on the camera rays of `bunny` and
//! `bunny-closeup` (800x450, 10 jittered samples a pixel, as the renderer makes them), the
//! closeup with the bunny subdivided to 1 271 808 triangles, and build times.
//!
//! `cargo bench --bench bvh`; throughput is in rays (elements) per second.

mod common;
use common::camera_rays;
use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use raytracer::accel::{Accel, AccelKind, Context, TraversalStats};
use raytracer::integrator::T_MIN;
use raytracer::scene::{Overrides, Scene, SceneSource};
use std::borrow::Cow;

/// A built-in scene with its mesh subdivided `levels` times.
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

fn single_thread<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(f)
}

fn bench_camera_rays(c: &mut Criterion) {
    eprintln!("lanes: {}", raytracer::lanes::COMPILED);
    let mut group = c.benchmark_group("camera_rays");
    group.sample_size(10);
    for (label, scene) in [
        ("bunny", Scene::load("bunny", Overrides::default()).unwrap()),
        (
            "bunny-closeup",
            Scene::load("bunny-closeup", Overrides::default()).unwrap(),
        ),
        ("bunny-closeup-1.27M", subdivided("bunny-closeup", 4)),
    ] {
        let rays = camera_rays(&scene, scene.spp);
        let mut scene = scene;
        let accel = Accel::build(&mut scene, AccelKind::Bvh);
        group.throughput(Throughput::Elements(rays.len() as u64));
        group.bench_function(label, |b| {
            b.iter(|| {
                let mut stats = TraversalStats::default();
                let mut hits = 0u32;
                for r in &rays {
                    hits += accel
                        .closest_hit(Context::new(&scene, &mut stats), r, T_MIN, f32::INFINITY)
                        .is_some() as u32;
                }
                hits
            })
        });
    }
    group.finish();
}

fn bench_build(c: &mut Criterion) {
    let mut group = c.benchmark_group("build");
    group.sample_size(10);
    let bunny = Scene::load("bunny", Overrides::default()).unwrap();
    group.bench_function("bunny-4968-1thread", |b| {
        b.iter_batched(
            || bunny.clone(),
            |mut s| single_thread(|| Accel::build(&mut s, AccelKind::Bvh)),
            BatchSize::LargeInput,
        )
    });
    let big = subdivided("bunny", 4);
    assert_eq!(big.triangles.len(), 1_271_808);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    group.bench_function("bunny-1271808-2threads", |b| {
        b.iter_batched(
            || big.clone(),
            |mut s| pool.install(|| Accel::build(&mut s, AccelKind::Bvh)),
            BatchSize::LargeInput,
        )
    });
    group.finish();
}

criterion_group!(benches, bench_camera_rays, bench_build);
criterion_main!(benches);
