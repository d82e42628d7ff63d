//! Shading at each width, in one run so the ratios can be read:
//!
//! - `shading/phong/W`: the Phong kernel (`Tracer::phong_lanes`) over a fixed batch of
//!   4096 surface points on `cornell`'s floor, each with its view direction, lit by the
//!   quad light's 10 samples (light sample points, shadow rays and the specular `pow`
//!   included), W lanes at a time;
//! - `shading/render/SCENE/W`: a whole small render (200 px wide, 2 samples a pixel, one
//!   thread) of the shading-bound scenes of the original program.
//!
//! Before timing, every width is checked to give the same bits. `cargo bench --bench
//! shading`; throughput is in surface points (Phong) and camera samples (renders) per
//! second.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::{Vec3, Vec4};
use raytracer::accel::{Accel, AccelKind};
use raytracer::integrator::{PhongLanes, RayCounts, SurfaceLanes, Tracer};
use raytracer::lanes::{F32x16, Lane, MAX_WIDTH, V3};
use raytracer::material::Material;
use raytracer::render::render;
use raytracer::sampling::{KeyLanes, Sampler, SamplerKind};
use raytracer::scene::{Overrides, Scene};
use raytracer::{PacketWidth, RenderSettings};
use std::hint::black_box;
use wide::f32x8;

/// Points on `cornell`'s floor (y = 0, inside the room), seen from the camera.
const POINTS: usize = 4096;

fn load(name: &str, width: u32, spp: u32) -> (Scene, Accel) {
    let overrides = Overrides {
        width: Some(width),
        spp: Some(spp),
        max_depth: None,
    };
    let mut scene = Scene::load(name, overrides).expect("a built-in scene");
    let accel = Accel::build(&mut scene, AccelKind::Bvh);
    (scene, accel)
}

/// Phong over the batch, `L` lanes at a time: the colours' bits, summed per point.
fn phong_batch<L: Lane>(tracer: &Tracer, points: &[(Vec3, Vec3)]) -> Vec<[u32; 3]> {
    let scene = tracer.scene;
    let white = scene
        .materials
        .iter()
        .find_map(|m| match m {
            Material::Phong(p) if p.shininess == 100.0 => Some(*p),
            _ => None,
        })
        .expect("cornell's white Phong");
    let sampler = Sampler::new(SamplerKind::Independent, 0, 1);
    let mut out = Vec::with_capacity(points.len());
    let mut counts = RayCounts::default();
    for (c, chunk) in points.chunks(L::WIDTH).enumerate() {
        let at = |k: usize| chunk[k.min(chunk.len() - 1)];
        let xs: [u32; MAX_WIDTH] = std::array::from_fn(|k| (c * L::WIDTH + k) as u32 % 800);
        let keys: KeyLanes = sampler.key_lanes(L::WIDTH, xs, [7; MAX_WIDTH], 0);
        let s = SurfaceLanes::<L>::flat(
            V3::from_fn(|k| at(k).0),
            V3::splat(Vec3::splat(1e-4)),
            V3::splat(Vec3::Y),
            (1 << L::WIDTH) - 1,
        );
        let view = V3::from_fn(|k| at(k).1);
        let lanes = (1u32 << chunk.len()) - 1;
        let colour = tracer.phong_lanes(
            &PhongLanes::splat(&white),
            &s,
            view,
            &keys,
            0,
            lanes,
            &mut counts,
        );
        for k in 0..chunk.len() {
            out.push(colour.lane(k).to_array().map(f32::to_bits));
        }
    }
    out
}

fn bench_shading(c: &mut Criterion) {
    eprintln!("lanes: {}", raytracer::lanes::COMPILED);
    // The Phong kernel.
    let (scene, accel) = load("cornell", 200, 1);
    let tracer = Tracer::new(&scene, &accel, 0);
    let eye = scene.camera.origin;
    let points: Vec<(Vec3, Vec3)> = (0..POINTS)
        .map(|i| {
            let (u, v) = ((i % 64) as f32 / 64.0, (i / 64) as f32 / 64.0);
            let p = Vec3::new(20.0 + 515.0 * u, 0.0, 20.0 + 515.0 * v);
            (p, (eye - p).normalize())
        })
        .collect();
    let scalar = phong_batch::<f32>(&tracer, &points);
    assert_eq!(
        scalar,
        phong_batch::<Vec4>(&tracer, &points),
        "4 wide differs"
    );
    assert_eq!(
        scalar,
        phong_batch::<f32x8>(&tracer, &points),
        "8 wide differs"
    );
    assert_eq!(
        scalar,
        phong_batch::<F32x16>(&tracer, &points),
        "16 wide differs"
    );
    let mut group = c.benchmark_group("shading/phong");
    group.throughput(Throughput::Elements(POINTS as u64));
    group.bench_function("1", |b| {
        b.iter(|| phong_batch::<f32>(&tracer, black_box(&points)))
    });
    group.bench_function("4", |b| {
        b.iter(|| phong_batch::<Vec4>(&tracer, black_box(&points)))
    });
    group.bench_function("8", |b| {
        b.iter(|| phong_batch::<f32x8>(&tracer, black_box(&points)))
    });
    group.bench_function("16", |b| {
        b.iter(|| phong_batch::<F32x16>(&tracer, black_box(&points)))
    });
    group.finish();

    // Whole small renders.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a one-thread pool");
    for name in ["quads", "spheres", "mixed", "cornell"] {
        let (scene, accel) = load(name, 200, 2);
        let settings = |packet_width: u32| RenderSettings {
            packet_width: PacketWidth::try_from(packet_width).expect("1, 4, 8 or 16"),
            sampler: SamplerKind::Independent,
            ..RenderSettings::new(0)
        };
        let bits = |w: u32| -> Vec<u32> {
            let r = pool.install(|| render(&scene, &accel, &settings(w), &|| {}));
            let film = r.expect("the render").film;
            film.pixels
                .iter()
                .flat_map(|p| p.to_array().map(f32::to_bits))
                .collect()
        };
        let one = bits(1);
        assert!(
            one == bits(4) && one == bits(8) && one == bits(16),
            "{name}: widths differ"
        );
        let mut group = c.benchmark_group(format!("shading/render/{name}"));
        group.sample_size(10);
        let samples = scene.camera.width as u64 * scene.camera.height as u64 * scene.spp as u64;
        group.throughput(Throughput::Elements(samples));
        for w in [1, 4, 8, 16] {
            let s = settings(w);
            group.bench_function(w.to_string(), |b| {
                b.iter(|| pool.install(|| render(&scene, &accel, &s, &|| {}).expect("the render")))
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench_shading);
criterion_main!(benches);
