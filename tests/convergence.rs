//! Error against spp: the independent sampler's MSE falls as spp⁻¹, and the structured
//! samplers beat it at equal spp where they should (soft shadows of an area light).
//!
//! Small images (32x32 of `cornell-area-light`: a quad light sampled 10 times per camera
//! sample, Phong surfaces, no path tracing) so the whole file runs in seconds.

mod support;

use raytracer::accel::{Accel, AccelKind};
use raytracer::metrics;
use raytracer::metrics::log_log_slope;
use raytracer::render::{render, Film, RenderSettings};
use raytracer::sampling::SamplerKind;
use raytracer::scene::Scene;
use support::builtin;

const WIDTH: u32 = 32;

fn render_at(scene: &Scene, accel: &Accel, sampler: SamplerKind, seed: u32, spp: u32) -> Film {
    let mut scene = scene.clone();
    scene.spp = spp;
    render(
        &scene,
        accel,
        &RenderSettings {
            seed,
            sampler,
            ..RenderSettings::default()
        },
        &|| {},
    )
    .unwrap()
    .film
}

fn prepared() -> (Scene, Accel) {
    let mut scene = builtin("cornell-area-light", WIDTH, 1);
    let accel = Accel::build(&mut scene, AccelKind::Bvh);
    (scene, accel)
}

/// A reference of `spp` samples: Sobol with a seed no render below uses, so its numbers
/// are independent of theirs.
fn reference(scene: &Scene, accel: &Accel, spp: u32) -> Film {
    render_at(scene, accel, SamplerKind::Sobol, 0xfeed, spp)
}

/// MSE of the independent sampler at spp = 1, 2, 4, …, 64: the log-log slope is −1.
///
/// Why the bound ±0.15: each pixel is an average of spp independent, identically
/// distributed samples, so its variance is σ²/spp exactly and the expected MSE against the
/// true image is Σσ²/(N·spp): slope −1. What the measurement adds:
/// - The reference's own error (2048 Sobol spp, measured below to be a small fraction of
///   the 64-spp error) adds a constant that flattens the end of the line: it enters each
///   MSE as +ε and shifts the slope by about +ε/MSE(64) ≈ +0.001.
/// - Each MSE is an average over 32·32·3 = 3072 channel errors with heavy tails (pixels
///   on the shadow edges and the light's border carry most of the variance), so one MSE
///   scatters by several percent and the fitted slope by a few hundredths. Measured:
///   −0.91 on 24x24 pixels with 3 seeds, −1.04 on 32x32 with 4 seeds (the setting
///   kept). ±0.15 is about 1.5 times the largest deviation seen: it still
///   fails on a wrong exponent (a sampler with correlated samples gives about −0.5 or
///   flattens against a bias), not on noise. Averaging four seeds keeps one unlucky draw
///   from deciding it.
#[test]
fn independent_mse_falls_as_one_over_spp() {
    let (scene, accel) = prepared();
    let reference = reference(&scene, &accel, 2048);
    let spps = [1, 2, 4, 8, 16, 32, 64];
    let seeds = [0, 1, 2, 3];
    let points: Vec<(f64, f64)> = spps
        .iter()
        .map(|&spp| {
            let mse = seeds
                .iter()
                .map(|&seed| {
                    let film = render_at(&scene, &accel, SamplerKind::Independent, seed, spp);
                    metrics::mse(&film.pixels, &reference.pixels)
                })
                .sum::<f64>()
                / seeds.len() as f64;
            (spp as f64, mse)
        })
        .collect();
    let slope = log_log_slope(&points);
    assert!(
        (slope + 1.0).abs() < 0.15,
        "slope {slope}, points {points:?}"
    );
}

/// At equal spp the stratified and Sobol samplers have a lower MSE than the independent
/// one on soft shadows: the light's 10 samples of every camera sample are spread over the
/// light by the same low-discrepancy points as the pixel's other samples.
#[test]
fn structured_samplers_beat_independent_at_equal_spp() {
    let (scene, accel) = prepared();
    let reference = reference(&scene, &accel, 2048);
    for spp in [4, 16] {
        let mse = |k| {
            let film = render_at(&scene, &accel, k, 3, spp);
            metrics::mse(&film.pixels, &reference.pixels)
        };
        let independent = mse(SamplerKind::Independent);
        for k in [SamplerKind::Stratified, SamplerKind::Sobol] {
            let m = mse(k);
            assert!(
                m < 0.8 * independent,
                "{k:?} at {spp} spp: MSE {m} not below 0.8 × independent {independent}"
            );
        }
    }
}

/// The reference used above is good enough: its own MSE (two halves with different
/// seeds: E|A − B|² / 4) is under 1/10 of the independent sampler's MSE at 64 spp.
#[test]
fn the_reference_noise_is_small() {
    let (scene, accel) = prepared();
    let a = render_at(&scene, &accel, SamplerKind::Sobol, 0xfeed, 1024);
    let b = render_at(&scene, &accel, SamplerKind::Sobol, 0xbeef, 1024);
    let reference_mse = metrics::mse(&a.pixels, &b.pixels) / 4.0;
    let ind = render_at(&scene, &accel, SamplerKind::Independent, 0, 64);
    let mean: Vec<_> = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(x, y)| (*x + *y) * 0.5)
        .collect();
    let mse64 = metrics::mse(&ind.pixels, &mean);
    assert!(
        reference_mse < 0.1 * mse64,
        "reference MSE {reference_mse:.3e}, independent 64 spp {mse64:.3e}"
    );
}

/// Every sampler renders the same bits on one and two threads.
#[test]
fn samplers_are_deterministic_across_thread_counts() {
    let scene = builtin("cornell", 16, 3);
    for sampler in SamplerKind::ALL {
        let film = |threads| {
            let mut scene = scene.clone();
            let accel = Accel::build(&mut scene, AccelKind::Bvh);
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                render(
                    &scene,
                    &accel,
                    &RenderSettings {
                        seed: 5,
                        sampler,
                        ..RenderSettings::default()
                    },
                    &|| {},
                )
                .unwrap()
            })
            .film
        };
        assert_eq!(
            support::bits(&film(1)),
            support::bits(&film(2)),
            "{sampler:?}"
        );
    }
}
