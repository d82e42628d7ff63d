//! Whole renders on one thread: the scalar path, 8-wide packets, and 8-wide packets
//! without specialisation (`--no-specialize`: no camera cones, no shadow-ray cull, no
//! early packets), in one run so their ratios can be read. Each scene at 400 px wide
//! and 2 samples a pixel (a quarter of the pixels and a fifth of the samples of the
//! full `bunny` render), so a sample takes well under a second. Before timing, the three
//! images are checked to be the same bits.
//!
//! `cargo bench --bench render`; throughput is in camera samples (pixels × spp) per
//! second.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use raytracer::render::{render, RenderSettings};
use raytracer::PacketWidth;

mod common;

fn bench_render(c: &mut Criterion) {
    eprintln!("lanes: {}", raytracer::lanes::COMPILED);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a one-thread pool");
    for name in ["bunny", "bunny-closeup", "mixed"] {
        let (scene, accel) = common::small_scene(name);
        let variants = [
            ("scalar", PacketWidth::Scalar, true),
            ("8-wide", PacketWidth::Eight, true),
            ("8-wide-no-specialize", PacketWidth::Eight, false),
            ("16-wide", PacketWidth::Sixteen, true),
        ];
        // The original program's sampling, as the figures quoted for this bench.
        let settings = |packet_width, specialize| RenderSettings {
            packet_width,
            specialize,
            ..RenderSettings::original_sampling(0)
        };
        let films: Vec<Vec<u32>> = variants
            .iter()
            .map(|&(_, w, s)| {
                let r = pool.install(|| render(&scene, &accel, &settings(w, s), &|| {}));
                let film = r.expect("the render").film;
                film.pixels
                    .iter()
                    .flat_map(|p| p.to_array().map(f32::to_bits))
                    .collect()
            })
            .collect();
        assert!(
            films.iter().all(|f| *f == films[0]),
            "{name}: images differ"
        );

        let mut group = c.benchmark_group(format!("render/{name}"));
        group.sample_size(10);
        let samples = scene.camera.width as u64 * scene.camera.height as u64 * scene.spp as u64;
        group.throughput(Throughput::Elements(samples));
        for &(label, width, specialize) in &variants {
            let s = settings(width, specialize);
            group.bench_function(label, |b| {
                b.iter(|| pool.install(|| render(&scene, &accel, &s, &|| {}).expect("the render")))
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench_render);
criterion_main!(benches);
