//! Shared helpers of the integration tests: scenes from TOML text, renders on a given
//! number of threads.
#![allow(dead_code)]

use raytracer::accel::{Accel, AccelKind};
use raytracer::render::{render, Film, RenderSettings, Rendered};
use raytracer::scene::{Overrides, Scene};

/// Compile a scene from TOML text (written to a temporary file, so relative mesh paths
/// resolve next to it).
pub fn scene_from_toml(text: &str) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).unwrap();
    Scene::load(path.to_str().unwrap(), Overrides::default()).unwrap()
}

/// A built-in scene at a small size.
pub fn builtin(name: &str, width: u32, spp: u32) -> Scene {
    let o = Overrides {
        width: Some(width),
        spp: Some(spp),
        max_depth: None,
    };
    Scene::load(name, o).unwrap()
}

/// Render on a pool of `threads` threads.
pub fn render_with(scene: &Scene, accel: AccelKind, threads: usize, seed: u32) -> Rendered {
    let mut scene = scene.clone();
    let accel = Accel::build(&mut scene, accel);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| render(&scene, &accel, &RenderSettings { seed }, &|| {}))
        .unwrap()
}

pub fn render_film(scene: &Scene, threads: usize) -> Film {
    render_with(scene, AccelKind::Bvh, threads, 0).film
}

/// The bit patterns of a film, for exact comparisons (NaN-safe).
pub fn bits(film: &Film) -> Vec<[u32; 3]> {
    film.pixels
        .iter()
        .map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
        .collect()
}
