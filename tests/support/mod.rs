//! Shared helpers of the integration tests: scenes from TOML text, renders on a given
//! number of threads; `oracle`: the f64 oracles of the intersection kernels.
#![allow(dead_code)]

pub mod oracle;

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

/// A built-in scene at a small size with `keys` (TOML lines) added to its `[camera]`
/// table.
pub fn builtin_with_camera(name: &str, keys: &str, width: u32, spp: u32) -> Scene {
    use raytracer::scene::{compile, SceneSource};
    let mut source = SceneSource::builtin(name).unwrap();
    let text = source
        .text
        .replacen("[camera]\n", &format!("[camera]\n{keys}\n"), 1);
    source.text = std::borrow::Cow::Owned(text);
    let overrides = Overrides {
        width: Some(width),
        spp: Some(spp),
        max_depth: None,
    };
    compile(&source, &source.parse().unwrap(), overrides).unwrap()
}

/// Render with `settings` on a pool of `threads` threads.
pub fn render_settings(
    scene: &Scene,
    accel: AccelKind,
    threads: usize,
    settings: &RenderSettings,
) -> Rendered {
    let mut scene = scene.clone();
    let accel = Accel::build(&mut scene, accel);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| render(&scene, &accel, settings, &|| {}))
        .unwrap()
}

/// Render with the original program's sampling (independent numbers, scalar tracer) and
/// seed `seed` on a pool of `threads` threads.
pub fn render_with(scene: &Scene, accel: AccelKind, threads: usize, seed: u32) -> Rendered {
    render_settings(
        scene,
        accel,
        threads,
        &RenderSettings::original_sampling(seed),
    )
}

/// Render with the default settings (what a user gets) on a pool of `threads` threads.
pub fn render_film(scene: &Scene, threads: usize) -> Film {
    render_settings(scene, AccelKind::Bvh, threads, &RenderSettings::default()).film
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

    /// A random axis direction (±x, ±y or ±z) whose other components are +0 or −0.
    pub fn axis_direction(&mut self) -> glam::Vec3 {
        let axis = (self.next_u64() % 6) as usize;
        let mut d = [0.0f32; 3];
        d[axis % 3] = if axis < 3 { 1.0 } else { -1.0 };
        for (k, c) in d.iter_mut().enumerate() {
            if k != axis % 3 && self.next_u64().is_multiple_of(2) {
                *c = -0.0;
            }
        }
        glam::Vec3::from(d)
    }

    /// +1 or −1.
    pub fn sign(&mut self) -> f32 {
        if self.next_u64().is_multiple_of(2) {
            1.0
        } else {
            -1.0
        }
    }

    pub fn unit_vector(&mut self) -> glam::Vec3 {
        let z = self.range(-1.0, 1.0);
        let phi = self.range(0.0, std::f32::consts::TAU);
        let r = (1.0 - z * z).max(0.0).sqrt();
        glam::Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}

/// The compiled scene moved by x → `scale` · x + `offset` (scale > 0): sphere centres and
/// radii, quads (rebuilt from the moved corner and scaled edges, as `compile` builds them,
/// with their vertices moved, so vertices shared by quads stay shared bit for bit),
/// triangle vertices, the lights' copies of their primitives (moved by the same f32
/// operations, so they keep matching the pools bit for bit) and the camera (origin and
/// viewport corner moved, pixel steps scaled: ray directions stay the same up to the
/// rounding of the moved points). Materials, colours and light intensities are unchanged
/// (lights have no fall-off). Call before `Accel::build`.
pub fn transform_scene(scene: &Scene, scale: f32, offset: glam::Vec3) -> Scene {
    use raytracer::geometry::quad::Quad;
    use raytracer::geometry::{Aabb, QuadPool, TrianglePool};
    use raytracer::scene::LightShape;
    let p = |v: glam::Vec3| v * scale + offset;
    let quad = |q: &Quad| {
        Quad::with_vertices(p(q.corner), q.u * scale, q.v * scale, q.vertices.map(p)).unwrap()
    };
    let mut s = scene.clone();
    for i in 0..s.spheres.len() {
        let (c, r) = (p(s.spheres.center(i)), s.spheres.radius(i) * scale);
        s.spheres.set(i, c, r);
    }
    let quads = std::mem::take(&mut s.quads);
    s.quads = QuadPool::default();
    for i in 0..quads.len() {
        s.quads
            .push(&quad(&quads.get(i)), quads.id[i], quads.object[i]);
    }
    let tris = std::mem::take(&mut s.triangles);
    s.triangles = TrianglePool::default();
    for i in 0..tris.len() {
        s.triangles
            .push(tris.vertices(i).map(p), tris.id[i], tris.object[i]);
    }
    for light in &mut s.lights {
        match &mut light.shape {
            LightShape::Point { center, radius } => {
                *center = p(*center);
                *radius *= scale;
            }
            LightShape::Quads(qs) => qs.iter_mut().for_each(|q| *q = quad(q)),
            LightShape::Triangles(ts) => ts.iter_mut().for_each(|t| *t = t.map(p)),
        }
    }
    let cam = &mut s.camera;
    cam.origin = p(cam.origin);
    cam.corner = p(cam.corner);
    cam.pixel_du *= scale;
    cam.pixel_dv *= scale;
    cam.lens_u *= scale;
    cam.lens_v *= scale;
    s.bounds = Aabb::new(p(s.bounds.min), p(s.bounds.max));
    s
}

/// Mean absolute difference per channel of two films of the same size, each channel
/// clamped to [0, 1] first (what the written image shows).
pub fn mean_abs_diff(a: &Film, b: &Film) -> f64 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let sum: f64 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| {
            let (p, q) = (
                p.clamp(glam::Vec3::ZERO, glam::Vec3::ONE),
                q.clamp(glam::Vec3::ZERO, glam::Vec3::ONE),
            );
            (p - q)
                .abs()
                .to_array()
                .iter()
                .map(|&x| x as f64)
                .sum::<f64>()
        })
        .sum();
    sum / (3 * a.pixels.len()) as f64
}
