//! The library's public surface, as a user calls it: scenes from text, files and names,
//! options, renders and films. Each render is checked against the internal path it wraps,
//! bit for bit.

mod support;

use raytracer::accel::Accel;
use raytracer::scene::{Overrides, Scene};
use raytracer::{
    AccelKind, Error, Film, PacketWidth, RenderSettings, Renderer, SamplerKind, SceneFile,
    SceneOptions,
};
use support::bits;

const TOML: &str = r#"description = "one lit sphere"
[camera]
width = 20
aspect_ratio = "2:1"
samples_per_pixel = 3

[materials.red]
type = "phong"
albedo = [0.8, 0.1, 0.1]
shininess = 10

[materials.lamp]
type = "light"
color = [1, 1, 1]

[[objects]]
type = "sphere"
center = [0, 0, -2]
radius = 0.5
material = "red"

[[objects]]
type = "sphere"
center = [1, 1, -1]
radius = 0.1
material = "lamp"
"#;

/// The internal path: compile, build, render.
fn internal(scene: &str, overrides: Overrides, accel: AccelKind, s: &RenderSettings) -> Film {
    let mut scene = Scene::load(scene, overrides).unwrap();
    let accel = Accel::build(&mut scene, accel);
    raytracer::render::render(&scene, &accel, s, &|| {})
        .unwrap()
        .film
}

/// A built-in scene through `SceneFile::builtin` and `Renderer` gives the bits of the
/// internal path, for every option the renderer takes and both acceleration structures.
#[test]
fn renderer_renders_the_internal_path_bit_for_bit() {
    for (name, accel) in [("cornell", AccelKind::Bvh), ("mixed", AccelKind::Linear)] {
        let options = SceneOptions {
            width: Some(24),
            spp: Some(2),
            max_depth: Some(3),
            accel,
            max_memory: None,
        };
        let renderer = Renderer::new(&SceneFile::builtin(name).unwrap(), &options).unwrap();
        assert_eq!(renderer.name(), name);
        assert_eq!((renderer.width(), renderer.spp()), (24, 2));
        let overrides = Overrides {
            width: Some(24),
            spp: Some(2),
            max_depth: Some(3),
        };
        for settings in [
            RenderSettings::default(),
            RenderSettings::original_sampling(5),
            RenderSettings {
                sampler: SamplerKind::Stratified,
                packet_width: PacketWidth::Four,
                ..RenderSettings::new(9)
            },
        ] {
            let film = renderer.render(&settings).unwrap();
            let expected = internal(name, overrides, accel, &settings);
            assert_eq!(
                (film.width, film.height),
                (renderer.width(), renderer.height())
            );
            assert!(bits(&film) == bits(&expected), "{name} {settings:?}");
        }
    }
}

/// Text and a file of the same text compile to the same scene and image.
#[test]
fn scene_text_and_scene_file_agree() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("one-sphere.toml");
    std::fs::write(&path, TOML).unwrap();
    let from_file = SceneFile::from_path(&path).unwrap();
    let from_text = SceneFile::from_toml(TOML).unwrap();
    assert_eq!(from_file.name(), "one-sphere");
    assert_eq!(from_text.description(), "one lit sphere");
    let options = SceneOptions::default();
    let a = Renderer::new(&from_file, &options).unwrap();
    let b = Renderer::new(&from_text, &options).unwrap();
    assert_eq!((a.width(), a.height(), a.spp()), (20, 10, 3));
    let settings = RenderSettings::default();
    let (fa, fb) = (a.render(&settings).unwrap(), b.render(&settings).unwrap());
    assert!(bits(&fa) == bits(&fb));
    assert!(fa.get(10, 5).x > 0.0, "the sphere is lit");
    // The progress callback runs once a tile (20x10 pixels: 2 tiles of 16).
    let calls = std::sync::atomic::AtomicU32::new(0);
    let rendered = a
        .render_with_progress(&settings, &|| {
            calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        })
        .unwrap();
    assert_eq!(calls.into_inner(), a.tiles());
    assert_eq!(a.tiles(), 2);
    assert_eq!(rendered.counts.camera, 20 * 10 * 3);
}

/// Errors name the line and column of the text, or list the built-in scenes.
#[test]
fn errors_name_the_place() {
    let bad = TOML.replace("radius = 0.5", "radius = -0.5");
    let file = SceneFile::from_toml(&bad).unwrap();
    match Renderer::new(&file, &SceneOptions::default()) {
        Err(Error::Scene { line, message, .. }) => {
            assert_eq!(line, 16, "{message}"); // the object's header
            assert!(message.contains("radius"), "{message}");
        }
        other => panic!("expected a scene error, got {other:?}"),
    }
    match SceneFile::from_toml("[camera]\nwidht = 3\n") {
        Err(Error::Scene { line, column, .. }) => assert_eq!((line, column), (2, 1)),
        other => panic!("expected a scene error, got {other:?}"),
    }
    match SceneFile::builtin("no-such-scene") {
        Err(e @ Error::UnknownScene { .. }) => assert!(e.to_string().contains("cornell")),
        other => panic!("expected an unknown scene, got {other:?}"),
    }
    let options = SceneOptions {
        width: Some(0),
        ..SceneOptions::default()
    };
    let file = SceneFile::from_toml(TOML).unwrap();
    assert!(matches!(
        Renderer::new(&file, &options),
        Err(Error::Scene { .. })
    ));
}

/// `max_memory` caps what a renderer may take: the image and the scene are estimated
/// before they are made, and a larger estimate is `OutOfMemory`, naming it.
#[test]
fn a_memory_cap_refuses_a_scene_before_it_is_made() {
    use raytracer::budget;
    let file = SceneFile::from_toml(TOML).unwrap();
    let at = |max_memory: u64| {
        let options = SceneOptions {
            width: Some(4096),
            max_memory: Some(max_memory),
            ..SceneOptions::default()
        };
        Renderer::new(&file, &options)
    };
    // The program and a 4096x2048 image, without the two spheres: refused.
    let image = budget::BASE_BYTES + 4096 * 2048 * budget::RENDER_BYTES_PER_PIXEL;
    match at(image) {
        Err(e @ Error::OutOfMemory { .. }) => {
            let message = e.to_string();
            assert!(message.contains("4096x2048 image"), "{message}");
            let limit = format!("the limit is {}", budget::human(image));
            assert!(message.contains(&limit), "{message}");
        }
        other => panic!("expected OutOfMemory, got {other:?}"),
    }
    // With a kilobyte for the spheres and their tree: made.
    let renderer = at(image + 1024).unwrap();
    assert_eq!((renderer.width(), renderer.height()), (4096, 2048));
}

/// `Film::write` writes what `to_rgb8` gives (PPM) and the linear values bit for bit
/// (EXR).
#[test]
fn film_writes_its_bytes_and_its_linear_values() {
    let renderer = Renderer::from_toml(TOML).unwrap();
    let film = renderer.render(&RenderSettings::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    film.write(dir.path().join("f.exr")).unwrap();
    let back = raytracer::output::read_exr(&dir.path().join("f.exr")).unwrap();
    assert!(bits(&back) == bits(&film));
    film.write(dir.path().join("f.ppm")).unwrap();
    let ppm = std::fs::read(dir.path().join("f.ppm")).unwrap();
    let header = format!("P6\n{} {}\n255\n", film.width, film.height);
    assert_eq!(&ppm[..header.len()], header.as_bytes());
    assert_eq!(&ppm[header.len()..], film.to_rgb8().as_slice());
    assert!(matches!(
        film.write(dir.path().join("f.jpg")),
        Err(Error::Output { .. })
    ));
}
