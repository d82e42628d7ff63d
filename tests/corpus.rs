//! The benchmark corpus (`benches/corpus/*.toml`): every scene gives the same image bits
//! at widths 1, 4, 8 and 16, on 1 and 2 threads, with every sampler, and no pixel that is not
//! finite. The scenes are rendered small (37 pixels wide, so packets straddle the edges)
//! at 2 samples a pixel, where every path they take is still taken.

mod support;

use raytracer::accel::{Accel, AccelKind};
use raytracer::render::{render, RenderSettings};
use raytracer::sampling::SamplerKind;
use raytracer::scene::{Overrides, Scene};
use raytracer::PacketWidth;
use support::bits;

const CORPUS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/benches/corpus");

fn corpus_scenes() -> Vec<std::path::PathBuf> {
    let mut paths: Vec<_> = std::fs::read_dir(CORPUS)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    paths.sort();
    paths
}

fn film(
    scene: &Scene,
    accel: &Accel,
    sampler: SamplerKind,
    width: PacketWidth,
    threads: usize,
) -> Vec<[u32; 3]> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let settings = RenderSettings {
        packet_width: width,
        sampler,
        ..RenderSettings::new(5)
    };
    let rendered = pool.install(|| render(scene, accel, &settings, &|| {}).unwrap());
    assert!(
        rendered.film.pixels.iter().all(|p| p.is_finite()),
        "a pixel is not finite"
    );
    bits(&rendered.film)
}

#[test]
fn corpus_lists_its_scenes() {
    let names: Vec<_> = corpus_scenes()
        .iter()
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    let runner = std::fs::read_to_string(format!("{CORPUS}/run.py")).unwrap();
    for name in &names {
        assert!(
            runner.contains(&format!("\"{name}\"")),
            "benches/corpus/run.py does not measure {name}"
        );
    }
    assert!(names.len() >= 8, "{names:?}");
}

#[test]
fn every_corpus_scene_same_bits_at_every_width_thread_count_and_sampler() {
    for path in corpus_scenes() {
        let name = path.display().to_string();
        let overrides = Overrides {
            width: Some(37),
            spp: Some(2),
            max_depth: None,
        };
        let mut scene = Scene::load(&name, overrides).unwrap();
        let accel = Accel::build(&mut scene, AccelKind::Bvh);
        // The original program's scan answers a shadow ray by a closest-hit query; the
        // tree by the light's own nearest hit and an occluder search, or for a light of
        // many primitives by its own closest-hit query: the same bits (the scan is too
        // slow for the 1.27M-triangle meshes).
        if scene.primitive_count() < 100_000 {
            let mut linear_scene = Scene::load(&name, overrides).unwrap();
            let linear = Accel::build(&mut linear_scene, AccelKind::Linear);
            let independent = SamplerKind::Independent;
            assert!(
                film(&linear_scene, &linear, independent, PacketWidth::Eight, 2)
                    == film(&scene, &accel, independent, PacketWidth::Scalar, 1),
                "{name}: the linear scan differs from the tree"
            );
        }
        for sampler in [
            SamplerKind::Independent,
            SamplerKind::Stratified,
            SamplerKind::Sobol,
        ] {
            let reference = film(&scene, &accel, sampler, PacketWidth::Scalar, 1);
            for (width, threads) in [
                (PacketWidth::Four, 1),
                (PacketWidth::Eight, 1),
                (PacketWidth::Eight, 2),
                (PacketWidth::Sixteen, 1),
                (PacketWidth::Sixteen, 2),
            ] {
                assert!(
                    film(&scene, &accel, sampler, width, threads) == reference,
                    "{name}, {sampler:?}: {width:?} on {threads} threads differs from the scalar image"
                );
            }
        }
    }
}
