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
    pool.install(|| {
        render(
            &scene,
            &accel,
            &RenderSettings {
                seed,
                ..Default::default()
            },
            &|| {},
        )
    })
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

/// OBJ text for a triangle soup (one vertex line per corner, full f32 precision).
pub fn obj_text(triangles: &[[glam::Vec3; 3]]) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    for t in triangles {
        for p in t {
            writeln!(s, "v {:?} {:?} {:?}", p.x, p.y, p.z).unwrap();
        }
    }
    for i in 0..triangles.len() {
        writeln!(s, "f {} {} {}", 3 * i + 1, 3 * i + 2, 3 * i + 3).unwrap();
    }
    s
}

/// Compile a scene whose mesh objects may name files given here (name, text), written
/// next to the scene file.
pub fn scene_with_files(text: &str, files: &[(&str, String)]) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    for (name, body) in files {
        std::fs::write(dir.path().join(name), body).unwrap();
    }
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).unwrap();
    Scene::load(path.to_str().unwrap(), Overrides::default()).unwrap()
}

/// A small deterministic generator (splitmix64) for test rays.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }

    pub fn unit_vector(&mut self) -> glam::Vec3 {
        let z = self.range(-1.0, 1.0);
        let phi = self.range(0.0, std::f32::consts::TAU);
        let r = (1.0 - z * z).max(0.0).sqrt();
        glam::Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}
