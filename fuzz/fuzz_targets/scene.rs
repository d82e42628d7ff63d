//! Scene text → load → compile → both acceleration structures → a tiny render at every
//! packet width. A scene is refused with an error or renders; never a panic. What it
//! renders must be finite (the load-time bounds of `scene::limits`) and the same bits
//! at packet widths 1, 4 and 8 and with the BVH or the linear scan.
#![no_main]

use libfuzzer_sys::fuzz_target;
use raytracer::accel::{Accel, AccelKind};
use raytracer::budget::Budget;
use raytracer::render::{render, Film};
use raytracer::{PacketWidth, RenderSettings};
use raytracer::scene::desc::ObjectDesc;
use raytracer::scene::{compile_within, LightShape, Overrides, SceneSource};
use std::borrow::Cow;
use std::sync::OnceLock;

/// One worker thread: the campaign runs on one core.
fn pool() -> &'static rayon::ThreadPool {
    static POOL: OnceLock<rayon::ThreadPool> = OnceLock::new();
    POOL.get_or_init(|| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("a one-thread pool")
    })
}

fn bits(film: &Film) -> Vec<[u32; 3]> {
    film.pixels
        .iter()
        .map(|p| p.to_array().map(f32::to_bits))
        .collect()
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    // Built-in assets only (`dir: None`): `../assets/bunny.obj`.
    let source = SceneSource {
        display: "fuzz.toml".into(),
        name: "fuzz".into(),
        text: Cow::Owned(text.to_string()),
        dir: None,
    };
    let Ok(desc) = source.parse() else {
        return;
    };
    // Bounded time an input: the bunny subdivided more than once is 80 000 triangles.
    let big_mesh = desc
        .objects
        .iter()
        .any(|o| matches!(o.get_ref(), ObjectDesc::Mesh { subdivide, .. } if *subdivide > 1))
        || desc.meshes.values().any(|m| m.get_ref().subdivide > 1);
    if big_mesh || desc.objects.len() > 2000 {
        return;
    }
    // A tiny image: 8 pixels wide (the file's values are still checked), one sample.
    let overrides = Overrides {
        width: Some(8),
        spp: Some(1),
        max_depth: Some(4),
    };
    // The memory budget keeps an input's memory in bounds (libFuzzer's limit is 2 GiB).
    let Ok(scene) = compile_within(&source, &desc, overrides, Budget::cap(512 << 20)) else {
        return;
    };
    // A mesh used as a light is tested triangle by triangle by every shadow ray (the
    // light's own nearest hit): the bunny as a light took 27 s an input. Known and slow,
    // not wrong; kept small here so the campaign explores the rest.
    let light_triangles: usize = scene
        .lights
        .iter()
        .map(|l| match &l.shape {
            LightShape::Triangles(t) => t.len(),
            _ => 0,
        })
        .sum();
    if scene.camera.height > 64 || light_triangles > 64 {
        return;
    }
    pool().install(|| {
        let mut reference: Option<Vec<[u32; 3]>> = None;
        for kind in [AccelKind::Bvh, AccelKind::Linear] {
            let mut scene = scene.clone();
            let accel = Accel::build(&mut scene, kind);
            for packet_width in PacketWidth::ALL {
                let settings = RenderSettings {
                    packet_width,
                    ..RenderSettings::new(0)
                };
                let film = render(&scene, &accel, &settings, &|| {})
                    .expect("a 8-pixel film")
                    .film;
                assert_eq!(film.non_finite_count(), 0, "non-finite pixels");
                let b = bits(&film);
                match &reference {
                    None => reference = Some(b),
                    Some(r) => assert!(
                        *r == b,
                        "{kind:?} at packet width {packet_width} differs from the BVH at width 1"
                    ),
                }
            }
        }
    });
});
