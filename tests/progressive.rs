//! The progressive render (`Renderer::render_pass`): after N passes of one sample a
//! pixel, the film is the bits of a render of N samples a pixel, on scenes of every kind
//! (Phong with a mesh, area lights, path tracing), every packet width and sampler; a
//! moved camera (`Renderer::set_camera_pose`) renders what its `[camera]` table renders
//! from the scene file.

use raytracer::{
    CameraPose, Error, Film, PacketWidth, RenderSettings, Renderer, SamplerKind, SceneFile,
    SceneOptions,
};

fn renderer(file: &SceneFile, spp: u32) -> Renderer {
    let options = SceneOptions {
        width: Some(40),
        spp: Some(spp),
        max_depth: Some(4),
        ..Default::default()
    };
    Renderer::new(file, &options).unwrap()
}

fn bits(film: &Film) -> Vec<[u32; 3]> {
    film.pixels
        .iter()
        .map(|p| p.to_array().map(f32::to_bits))
        .collect()
}

fn passes(renderer: &Renderer, settings: &RenderSettings, spp: u32, n: u32) -> Film {
    let mut progressive = renderer.progressive(spp).unwrap();
    for k in 0..n {
        assert_eq!(progressive.passes(), k);
        renderer.render_pass(settings, &mut progressive).unwrap();
    }
    progressive.film().unwrap()
}

/// `bunny` (Phong, a mesh, mirror rays), `cornell` (an area light's samples) and
/// `mixed` (path-traced, its packets regrouped): 1, 2 and 5 passes are the bits of
/// `--spp 1`, `2` and `5`, at every packet width, and the 8-bit image too.
#[test]
fn n_passes_are_the_bits_of_n_samples_a_pixel() {
    for name in ["bunny", "cornell", "mixed"] {
        let file = SceneFile::builtin(name).unwrap();
        let at_rest = renderer(&file, 10);
        for width in PacketWidth::ALL {
            let settings = RenderSettings {
                packet_width: width,
                ..RenderSettings::new(7)
            };
            for n in [1, 2, 5] {
                let film = passes(&at_rest, &settings, 1024, n);
                let whole = renderer(&file, n).render(&settings).unwrap();
                assert_eq!(bits(&film), bits(&whole), "{name} {width:?} {n} passes");
            }
        }
        // The bytes the view shows are the film's.
        let settings = RenderSettings::default();
        let mut progressive = at_rest.progressive(16).unwrap();
        at_rest.render_pass(&settings, &mut progressive).unwrap();
        at_rest.render_pass(&settings, &mut progressive).unwrap();
        let mut rgba = Vec::new();
        progressive.rgba8_into(&mut rgba);
        let rgb: Vec<u8> = rgba
            .chunks_exact(4)
            .flat_map(|p| {
                assert_eq!(p[3], 255);
                [p[0], p[1], p[2]]
            })
            .collect();
        assert_eq!(rgb, progressive.film().unwrap().to_rgb8(), "{name}");
    }
}

/// The independent and Sobol samplers' numbers do not depend on the sample count: any
/// number of passes is `--spp N`. The stratified sampler's do: the render started for N
/// samples is `--spp N` after its N passes, and differs from `--spp 2` after 2.
#[test]
fn samplers_and_the_sample_count() {
    let file = SceneFile::builtin("cornell").unwrap();
    let at_rest = renderer(&file, 10);
    for sampler in SamplerKind::ALL {
        let settings = RenderSettings {
            sampler,
            ..RenderSettings::default()
        };
        let film = passes(&at_rest, &settings, 4, 4);
        let whole = renderer(&file, 4).render(&settings).unwrap();
        assert_eq!(bits(&film), bits(&whole), "{sampler:?}");
        let early = passes(&at_rest, &settings, 4, 2);
        let two = renderer(&file, 2).render(&settings).unwrap();
        assert_eq!(
            bits(&early) == bits(&two),
            sampler != SamplerKind::Stratified,
            "{sampler:?}"
        );
    }
}

/// A moved camera renders, pass after pass, what the scene file with the renderer's
/// `[camera]` table renders; `restart` starts again from sample 0; a pose the file could
/// not hold is refused and leaves the camera where it was.
#[test]
fn a_moved_camera_renders_what_its_camera_table_renders() {
    let text = include_str!("../scenes/cornell.toml");
    let file = SceneFile::from_toml(text).unwrap();
    let mut view = renderer(&file, 5);
    let settings = RenderSettings::default();
    let mut progressive = view.progressive(1024).unwrap();
    view.render_pass(&settings, &mut progressive).unwrap();
    let before = view.camera_pose();
    assert_eq!(before.look_from, [278.0, 278.0, -800.0]);
    let moved = CameraPose {
        look_from: [100.25, 390.0, -700.125],
        look_at: [270.0, 260.5, 10.0],
        vfov: 47.5,
        ..before
    };
    view.set_camera_pose(&moved).unwrap();
    assert_eq!(view.camera_pose(), moved);
    progressive.restart();
    for _ in 0..3 {
        view.render_pass(&settings, &mut progressive).unwrap();
    }
    assert_eq!(progressive.passes(), 3);

    let table = view.camera_toml();
    assert!(table.starts_with("[camera]\nwidth = 40\naspect_ratio = \"1:1\"\n"));
    let start = text.find("[camera]").unwrap();
    let end = start + text[start..].find("\n[materials").unwrap();
    let pasted = format!("{}{}{}", &text[..start], table, &text[end..]);
    let file = SceneFile::from_toml(&pasted).unwrap();
    let whole = Renderer::new(
        &file,
        &SceneOptions {
            spp: Some(3),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(whole.camera_pose(), moved);
    let film = progressive.film().unwrap();
    assert_eq!(bits(&film), bits(&whole.render(&settings).unwrap()));
    let unmoved = renderer(&SceneFile::from_toml(text).unwrap(), 3);
    assert_ne!(bits(&film), bits(&unmoved.render(&settings).unwrap()));

    // Refused: look_from on look_at, and a vfov of 180 degrees.
    for bad in [
        CameraPose {
            look_at: moved.look_from,
            ..moved
        },
        CameraPose {
            vfov: 180.0,
            ..moved
        },
        CameraPose {
            look_from: [f64::NAN, 0.0, 0.0],
            ..moved
        },
    ] {
        assert!(matches!(view.set_camera_pose(&bad), Err(Error::Options(_))));
        assert_eq!(view.camera_pose(), moved);
    }
    let mut again = view.progressive(1024).unwrap();
    for _ in 0..3 {
        view.render_pass(&settings, &mut again).unwrap();
    }
    assert_eq!(bits(&again.film().unwrap()), bits(&film));
}

/// A render with all its passes refuses another; a render of another size is refused.
#[test]
fn a_pass_too_many_or_of_another_size_is_an_error() {
    let file = SceneFile::builtin("spheres").unwrap();
    let small = renderer(&file, 1);
    let settings = RenderSettings::default();
    let mut progressive = small.progressive(2).unwrap();
    small.render_pass(&settings, &mut progressive).unwrap();
    small.render_pass(&settings, &mut progressive).unwrap();
    assert!(progressive.is_done());
    assert!(matches!(
        small.render_pass(&settings, &mut progressive),
        Err(Error::Options(_))
    ));
    let other = Renderer::new(
        &file,
        &SceneOptions {
            width: Some(48),
            ..Default::default()
        },
    )
    .unwrap();
    let mut progressive = small.progressive(2).unwrap();
    assert!(matches!(
        other.render_pass(&settings, &mut progressive),
        Err(Error::Options(_))
    ));
    assert!(small.progressive(0).is_err());
}

/// A smaller picture of the same view (`set_size`) is the render of the scene file at
/// that width, and back at the full size the renderer renders its own bits again; a
/// size past the one it was built for is refused.
#[test]
fn a_smaller_size_is_the_same_view_at_that_width() {
    let file = SceneFile::builtin("bunny").unwrap();
    let mut view = renderer(&file, 2);
    let settings = RenderSettings::default();
    let full = view.render(&settings).unwrap();
    // 40x22 at 16:9; a quarter: 10 wide, 5 high as 16:9 makes it.
    assert_eq!((view.width(), view.height()), (40, 22));
    view.set_size(10, 5).unwrap();
    let small = Renderer::new(
        &file,
        &SceneOptions {
            width: Some(10),
            spp: Some(2),
            max_depth: Some(4),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!((small.width(), small.height()), (10, 5));
    assert_eq!(
        bits(&view.render(&settings).unwrap()),
        bits(&small.render(&settings).unwrap())
    );
    let mut preview = view.progressive(16).unwrap();
    view.render_pass(&settings, &mut preview).unwrap();
    assert_eq!((preview.width(), preview.height()), (10, 5));
    for (w, h) in [(41, 22), (40, 23), (0, 5)] {
        assert!(matches!(view.set_size(w, h), Err(Error::Options(_))));
    }
    view.set_size(40, 22).unwrap();
    assert_eq!(bits(&view.render(&settings).unwrap()), bits(&full));
}

/// A pass stopped before its first tile, or part way, counts for nothing: the render is
/// refused until it restarts, and then renders the bits of a fresh one.
#[test]
fn a_stopped_pass_counts_for_nothing_until_the_restart() {
    let file = SceneFile::builtin("cornell").unwrap();
    let view = renderer(&file, 1);
    let settings = RenderSettings::default();
    let fresh = passes(&view, &settings, 16, 2);
    let tiles = std::sync::atomic::AtomicU32::new(0);
    let after_three = || tiles.fetch_add(1, std::sync::atomic::Ordering::Relaxed) >= 3;
    let always = || true;
    let stops: [&(dyn Fn() -> bool + Sync); 2] = [&always, &after_three];
    for stop in stops {
        let mut progressive = view.progressive(16).unwrap();
        view.render_pass(&settings, &mut progressive).unwrap();
        let pass = view.render_pass_unless(&settings, &mut progressive, stop);
        assert!(pass.unwrap().is_none());
        assert!(progressive.is_interrupted());
        assert_eq!(progressive.passes(), 1);
        assert!(matches!(
            view.render_pass(&settings, &mut progressive),
            Err(Error::Options(_))
        ));
        progressive.restart();
        assert!(!progressive.is_interrupted());
        for _ in 0..2 {
            let pass = view.render_pass_unless(&settings, &mut progressive, &|| false);
            assert!(pass.unwrap().is_some());
        }
        assert_eq!(bits(&progressive.film().unwrap()), bits(&fresh));
    }
}
