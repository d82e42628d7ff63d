//! Error against run time: high-spp reference images, and sweeps that
//! render a scene at spp = 1, 2, 4, …, for each sampler and packet width, time every
//! render (median of several runs), measure its error against the reference, and write a
//! CSV and a log-log SVG chart of error against seconds (drawn with `plotters`).

use super::options::{ReferenceOptions, SweepOptions};
use super::sweep_summary::{dedup, median, own_settings, series_name, summary};
pub use super::sweep_summary::{AdaptivePoint, Point};
use anyhow::{bail, Context};
use raytracer::accel::{Accel, AccelKind};
use raytracer::metrics;
use raytracer::output;
use raytracer::render::{self, Film, RenderSettings};
use raytracer::sampling::SamplerKind;
use raytracer::scene::{Overrides, Scene};
use raytracer::PacketWidth;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `raytracer reference`: make a reference on the current pool of `threads` threads.
pub fn reference(o: &ReferenceOptions, threads: usize) -> anyhow::Result<()> {
    if o.output_is_default {
        super::create_parent(&o.output)?;
    }
    let info = make_reference(&o.scene, Some(o.width), o.spp, o.sampler, &o.output)?;
    to_stderr!(
        "reference {}: {}x{}, {} spp {}, {:.1} s on {threads} threads, estimated own RMSE {:.3e} -> {}",
        info.scene,
        info.width,
        info.height,
        info.spp,
        info.sampler,
        info.seconds,
        info.estimated_mse.sqrt(),
        o.output.display()
    );
    Ok(())
}

/// `raytracer sweep`: make the reference if it is missing, sweep, write the CSV, the chart
/// and the summary.
pub fn sweep(o: &SweepOptions, threads: usize) -> anyhow::Result<()> {
    std::fs::create_dir_all(&o.out)
        .with_context(|| format!("cannot create directory {}", o.out.display()))?;
    let stem = super::scene_stem(&o.scene);
    let csv_path = o.out.join(format!("{stem}.csv"));
    let svg_path = o.out.join(format!("{stem}.svg"));
    let txt_path = o.out.join(format!("{stem}.txt"));
    for p in [&csv_path, &svg_path, &txt_path] {
        output::check_writable(p)?;
    }
    if !o.reference.exists() {
        super::create_parent(&o.reference)?;
        to_stderr!(
            "making the reference {} ({} spp)",
            o.reference.display(),
            o.reference_spp
        );
        let info = make_reference(
            &o.scene,
            Some(o.width),
            o.reference_spp,
            SamplerKind::Sobol,
            &o.reference,
        )?;
        to_stderr!(
            "reference: {:.1} s, estimated own RMSE {:.3e}",
            info.seconds,
            info.estimated_mse.sqrt()
        );
    }
    let (reference, info) = load_reference(&o.reference)?;
    let (mut scene, accel) = prepare(&o.scene, Some(o.width))?;
    let plan = SweepPlan {
        spp_max: o.spp_max,
        runs: o.runs,
        samplers: o.samplers.clone(),
        packet_widths: o.packet_widths.clone(),
        seed: o.seed,
        targets: o.targets.clone(),
        adaptive_samplers: o.adaptive_samplers.clone(),
        max_spp: o.max_spp,
    };
    let own_spp = scene.spp;
    to_stderr!(
        "sweep {}: {}x{}, {threads} threads, {} runs a point; reference {} spp, estimated own RMSE {:.3e}",
        scene.name,
        scene.camera.width,
        scene.camera.height,
        o.runs,
        info.spp,
        info.estimated_mse.sqrt()
    );
    let points = run_sweep(&mut scene, &accel, &reference, &plan, &mut |p| {
        if let Some(a) = p.adaptive {
            to_stderr!(
                "  {:<11} x{} target {:.2}%: {:.1} spp  {:>8.4} s ({:.4}–{:.4})  relative RMSE {:.3}%, estimate {:.3}%",
                series_name(p.sampler, true),
                p.packet_width,
                a.target * 100.0,
                a.spp_mean,
                p.seconds,
                p.seconds_min,
                p.seconds_max,
                p.rel_rmse() * 100.0,
                a.estimate * 100.0
            );
            return;
        }
        to_stderr!(
            "  {:<11} x{} {:>5} spp  {:>8.4} s ({:.4}–{:.4})  RMSE {:.4e}  relMSE {:.4e}  PSNR {:.2} dB",
            p.sampler.name(),
            p.packet_width,
            p.spp,
            p.seconds,
            p.seconds_min,
            p.seconds_max,
            p.errors.rmse,
            p.errors.rel_mse,
            p.errors.psnr
        )
    })?;
    let csv = csv(&scene, &info, threads, &points);
    let svg = chart(&scene.name, &points, &info)?;
    let summary = summary(&points) + &own_settings(&points, own_spp);
    // The three files together, all or nothing.
    let mut files = output::OutputSet::default();
    for (path, text) in [(&csv_path, &csv), (&svg_path, &svg), (&txt_path, &summary)] {
        files.add(path, |out| {
            use std::io::Write;
            out.write_all(text.as_bytes())
        })?;
    }
    files.commit()?;
    super::print_stdout(&summary)?;
    to_stderr!(
        "wrote {}, {}, {}",
        csv_path.display(),
        svg_path.display(),
        txt_path.display()
    );
    Ok(())
}

/// The seeds of the two halves of a reference; no sweep uses them, so a reference never
/// shares numbers with the renders measured against it.
pub const REFERENCE_SEEDS: [u32; 2] = [0x5eed_0001, 0x5eed_0002];

/// What a reference image is and how noisy it is, stored beside it as JSON.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct ReferenceInfo {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel of the whole reference (two halves of spp / 2).
    pub spp: u32,
    pub sampler: String,
    pub seeds: [u32; 2],
    /// The reference's own MSE, estimated as MSE(half A, half B) / 4: the halves are
    /// independent and unbiased, so E|A − B|² = 2σ²(half) and the mean has σ²(half) / 2.
    pub estimated_mse: f64,
    pub seconds: f64,
}

fn info_path(exr: &Path) -> PathBuf {
    exr.with_extension("json")
}

/// Load a scene at a width and build its BVH.
pub fn prepare(scene: &str, width: Option<u32>) -> anyhow::Result<(Scene, Accel)> {
    let overrides = Overrides {
        width,
        spp: None,
        max_depth: None,
    };
    let mut scene = Scene::load(scene, overrides)?;
    let accel = Accel::build(&mut scene, AccelKind::Bvh);
    Ok((scene, accel))
}

/// Render with a sampler, seed and spp on the current rayon pool; returns the film and the
/// render time in seconds.
pub fn render_timed(
    scene: &mut Scene,
    accel: &Accel,
    sampler: SamplerKind,
    seed: u32,
    spp: u32,
    packet_width: PacketWidth,
) -> anyhow::Result<(Film, f64, u64)> {
    scene.spp = spp;
    let settings = RenderSettings {
        seed,
        sampler,
        packet_width,
        ..RenderSettings::default()
    };
    let start = Instant::now();
    let r = render::render(scene, accel, &settings, &|| {})?;
    Ok((r.film, start.elapsed().as_secs_f64(), r.counts.total()))
}

/// Render adaptively to `target` with a sampler and seed on the current rayon pool;
/// returns the film, the render time in seconds, the rays and the outcome.
pub fn render_adaptive_timed(
    scene: &Scene,
    accel: &Accel,
    sampler: SamplerKind,
    seed: u32,
    adaptive: &raytracer::Adaptive,
    packet_width: PacketWidth,
) -> anyhow::Result<(Film, f64, u64, raytracer::Outcome)> {
    let settings = RenderSettings {
        seed,
        sampler,
        packet_width,
        ..RenderSettings::default()
    };
    let start = Instant::now();
    let r = render::render_adaptive(scene, accel, &settings, adaptive, &|| {}, &mut |_| {
        std::ops::ControlFlow::Continue(())
    })?;
    let seconds = start.elapsed().as_secs_f64();
    let outcome = r.adaptive.context("an adaptive render has an outcome")?;
    Ok((r.film, seconds, r.counts.total(), outcome))
}

/// Render a reference: the mean of two halves of `spp / 2` samples with different seeds,
/// written as EXR with a JSON note of its estimated own error.
pub fn make_reference(
    scene_arg: &str,
    width: Option<u32>,
    spp: u32,
    sampler: SamplerKind,
    path: &Path,
) -> anyhow::Result<ReferenceInfo> {
    output::check_writable(path)?;
    output::check_writable(&info_path(path))?;
    let (mut scene, accel) = prepare(scene_arg, width)?;
    let half = (spp / 2).max(1);
    let start = Instant::now();
    let (a, _, _) = render_timed(
        &mut scene,
        &accel,
        sampler,
        REFERENCE_SEEDS[0],
        half,
        PacketWidth::widest(),
    )?;
    let (b, _, _) = render_timed(
        &mut scene,
        &accel,
        sampler,
        REFERENCE_SEEDS[1],
        half,
        PacketWidth::widest(),
    )?;
    let seconds = start.elapsed().as_secs_f64();
    let estimated_mse = metrics::mse(&a.pixels, &b.pixels) / 4.0;
    let mean = Film {
        width: a.width,
        height: a.height,
        pixels: a
            .pixels
            .iter()
            .zip(&b.pixels)
            .map(|(x, y)| (*x + *y) * 0.5)
            .collect(),
    };
    let info = ReferenceInfo {
        scene: scene.name.clone(),
        width: mean.width,
        height: mean.height,
        spp: 2 * half,
        sampler: sampler.name().into(),
        seeds: REFERENCE_SEEDS,
        estimated_mse,
        seconds,
    };
    // The image and its note together, all or nothing.
    let json = serde_json::to_string_pretty(&info)?;
    let mut files = output::OutputSet::default();
    files.add_image(&mean, path)?;
    files.add(&info_path(path), |out| {
        use std::io::Write;
        writeln!(out, "{json}")
    })?;
    files.commit()?;
    Ok(info)
}

/// Read a reference and its JSON note.
pub fn load_reference(path: &Path) -> anyhow::Result<(Film, ReferenceInfo)> {
    let film = output::read_exr(path)?;
    let info_file = info_path(path);
    let text = std::fs::read_to_string(&info_file)
        .with_context(|| format!("cannot read {}", info_file.display()))?;
    let info: ReferenceInfo = serde_json::from_str(&text)
        .with_context(|| format!("{} is not a reference note", info_file.display()))?;
    Ok((film, info))
}

/// What to sweep.
#[derive(Debug, Clone)]
pub struct SweepPlan {
    pub spp_max: u32,
    pub runs: u32,
    pub samplers: Vec<SamplerKind>,
    pub packet_widths: Vec<PacketWidth>,
    pub seed: u32,
    /// Targets of the adaptive series (`--target-error`; none: no adaptive series).
    pub targets: Vec<f32>,
    /// Samplers of the adaptive series.
    pub adaptive_samplers: Vec<SamplerKind>,
    /// The most samples a pixel of an adaptive render.
    pub max_spp: u32,
}

/// spp = 1, 2, 4, …, up to `max` (and `max` itself if it is not a power of two).
pub fn spp_steps(max: u32) -> Vec<u32> {
    let mut v: Vec<u32> = std::iter::successors(Some(1u32), |&s| s.checked_mul(2))
        .take_while(|&s| s <= max)
        .collect();
    if v.last() != Some(&max) {
        v.push(max);
    }
    v
}

/// Run a sweep against a reference film. `progress` receives one line per point.
pub fn run_sweep(
    scene: &mut Scene,
    accel: &Accel,
    reference: &Film,
    plan: &SweepPlan,
    progress: &mut dyn FnMut(&Point),
) -> anyhow::Result<Vec<Point>> {
    if (scene.camera.width, scene.camera.height) != (reference.width, reference.height) {
        bail!(
            "the reference is {}x{} but the sweep renders {}x{}",
            reference.width,
            reference.height,
            scene.camera.width,
            scene.camera.height
        );
    }
    // One untimed render first: page faults and cold caches stay out of the first point.
    render_timed(
        scene,
        accel,
        SamplerKind::Independent,
        plan.seed,
        1,
        PacketWidth::Scalar,
    )?;
    let mut points = Vec::new();
    for &packet_width in &plan.packet_widths {
        for spp in spp_steps(plan.spp_max) {
            // Runs interleave the samplers (run 1 of each, then run 2 of each, …) so a
            // change of load on a shared machine falls on every sampler alike.
            let mut times = vec![Vec::new(); plan.samplers.len()];
            let mut firsts: Vec<Option<(Film, u64)>> = vec![None; plan.samplers.len()];
            for _ in 0..plan.runs.max(1) {
                for (i, &sampler) in plan.samplers.iter().enumerate() {
                    let (film, t, rays) =
                        render_timed(scene, accel, sampler, plan.seed, spp, packet_width)?;
                    times[i].push(t);
                    match &firsts[i] {
                        None => firsts[i] = Some((film, rays)),
                        Some((f, _)) => debug_assert_eq!(f, &film, "renders are deterministic"),
                    }
                }
            }
            for (i, &sampler) in plan.samplers.iter().enumerate() {
                let times = &mut times[i];
                times.sort_by(f64::total_cmp);
                let (film, rays) = firsts[i].take().expect("at least one run");
                let point = Point {
                    sampler,
                    packet_width,
                    spp,
                    seconds: median(times),
                    seconds_min: times[0],
                    seconds_max: times[times.len() - 1],
                    rays,
                    errors: metrics::errors(&film, reference),
                    adaptive: None,
                };
                progress(&point);
                points.push(point);
            }
        }
        for &target in &plan.targets {
            let adaptive = raytracer::Adaptive::new(Some(target), plan.max_spp, None)?;
            let samplers = &plan.adaptive_samplers;
            let mut times = vec![Vec::new(); samplers.len()];
            let mut firsts = vec![None; samplers.len()];
            for _ in 0..plan.runs.max(1) {
                for (i, &sampler) in samplers.iter().enumerate() {
                    let (film, t, rays, outcome) = render_adaptive_timed(
                        scene,
                        accel,
                        sampler,
                        plan.seed,
                        &adaptive,
                        packet_width,
                    )?;
                    times[i].push(t);
                    if firsts[i].is_none() {
                        firsts[i] = Some((film, rays, outcome));
                    }
                }
            }
            for (i, &sampler) in samplers.iter().enumerate() {
                let times = &mut times[i];
                times.sort_by(f64::total_cmp);
                let (film, rays, outcome) = firsts[i].take().expect("at least one run");
                let point = Point {
                    sampler,
                    packet_width,
                    spp: outcome.spp_mean.round() as u32,
                    seconds: median(times),
                    seconds_min: times[0],
                    seconds_max: times[times.len() - 1],
                    rays,
                    errors: metrics::errors(&film, reference),
                    adaptive: Some(AdaptivePoint {
                        target,
                        estimate: outcome.estimate,
                        spp_mean: outcome.spp_mean,
                    }),
                };
                progress(&point);
                points.push(point);
            }
        }
    }
    // Series by series in the CSV: packet width, uniform before adaptive, sampler (in
    // the plan's order), spp or target (the loosest first).
    let order = |k: SamplerKind| plan.samplers.iter().position(|&s| s == k);
    points.sort_by(|a, b| {
        let key = |p: &Point| {
            (
                p.packet_width,
                p.adaptive.is_some(),
                order(p.sampler),
                p.spp,
            )
        };
        key(a).cmp(&key(b)).then_with(|| {
            let target = |p: &Point| p.adaptive.map_or(0.0, |a| -a.target);
            target(a).total_cmp(&target(b))
        })
    });
    Ok(points)
}

/// The CSV of a sweep.
pub fn csv(scene: &Scene, reference: &ReferenceInfo, threads: usize, points: &[Point]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# scene {} {}x{}, reference {} spp {} (estimated own MSE {:.3e}), {} threads, render seconds only",
        scene.name,
        scene.camera.width,
        scene.camera.height,
        reference.spp,
        reference.sampler,
        reference.estimated_mse,
        threads
    );
    s.push_str("sampler,packet_width,spp,seconds_median,seconds_min,seconds_max,rays,mse,rmse,rel_mse,psnr_db,target_error,estimated_rel_rmse,spp_mean\n");
    for p in points {
        let e = p.errors;
        let adaptive = p.adaptive.map_or(",,".to_string(), |a| {
            format!("{},{:.6e},{:.3}", a.target, a.estimate, a.spp_mean)
        });
        let _ = writeln!(
            s,
            "{},{},{},{:.6},{:.6},{:.6},{},{:.6e},{:.6e},{:.6e},{:.3},{adaptive}",
            p.sampler.name(),
            p.packet_width,
            p.spp,
            p.seconds,
            p.seconds_min,
            p.seconds_max,
            p.rays,
            e.mse,
            e.rmse,
            e.rel_mse,
            e.psnr
        );
    }
    s
}

// ---------------------------------------------------------------------------------------
// The chart: its series (`chart` draws them).

/// A series: its sampler, whether it samples adaptively, its packet width.
type SeriesKey = (SamplerKind, bool, PacketWidth);

fn series_keys(points: &[Point]) -> Vec<SeriesKey> {
    dedup(
        points
            .iter()
            .map(|p| (p.sampler, p.adaptive.is_some(), p.packet_width)),
    )
}

/// The label of a series: its name, and the packet width when the sweep has several.
fn series_label(points: &[Point], (sampler, adaptive, width): SeriesKey) -> String {
    if dedup(points.iter().map(|p| p.packet_width)).len() == 1 {
        series_name(sampler, adaptive)
    } else {
        format!("{} ×{width}", series_name(sampler, adaptive))
    }
}

/// The SVG chart of a sweep: RMSE and relMSE against render seconds, log-log, one line
/// per series (sampler, uniform or adaptive, and packet width), points at spp = 1, 2,
/// 4, … or at the adaptive series' targets.
pub fn chart(title: &str, points: &[Point], reference: &ReferenceInfo) -> anyhow::Result<String> {
    let series: Vec<super::chart::Series> = series_keys(points)
        .into_iter()
        .map(|key @ (sampler, adaptive, width)| super::chart::Series {
            label: series_label(points, key),
            points: points
                .iter()
                .filter(|p| {
                    p.sampler == sampler
                        && p.packet_width == width
                        && p.adaptive.is_some() == adaptive
                })
                .map(|p| [p.seconds, p.errors.rmse, p.errors.rel_mse])
                .collect(),
        })
        .collect();
    super::chart::svg(&super::chart::Chart {
        title,
        series: &series,
        reference_rmse: reference.estimated_mse.sqrt(),
        note: format!(
            "points: spp = 1, 2, 4, … (adaptive: target errors); reference {} spp ({})",
            reference.spp, reference.sampler
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use raytracer::metrics::Errors;

    #[test]
    fn steps() {
        assert_eq!(spp_steps(1), vec![1]);
        assert_eq!(spp_steps(8), vec![1, 2, 4, 8]);
        assert_eq!(spp_steps(10), vec![1, 2, 4, 8, 10]);
    }

    /// The chart's series: one per sampler, uniform or adaptive, and width, labelled with
    /// the width only when the sweep has several.
    #[test]
    fn series_and_their_labels() {
        let point = |sampler, packet_width, adaptive: Option<f32>| Point {
            sampler,
            packet_width,
            spp: 1,
            seconds: 0.1,
            seconds_min: 0.1,
            seconds_max: 0.1,
            rays: 1,
            errors: Errors {
                mse: 0.01,
                rmse: 0.1,
                rel_mse: 0.1,
                psnr: 20.0,
            },
            adaptive: adaptive.map(|target| AdaptivePoint {
                target,
                estimate: target as f64,
                spp_mean: 1.0,
            }),
        };
        let (sobol, four, eight) = (SamplerKind::Sobol, PacketWidth::Four, PacketWidth::Eight);
        let points = [
            point(sobol, four, None),
            point(sobol, eight, None),
            point(sobol, eight, Some(0.1)),
            point(sobol, eight, Some(0.05)),
        ];
        let labels: Vec<String> = series_keys(&points)
            .into_iter()
            .map(|key| series_label(&points, key))
            .collect();
        assert_eq!(labels, ["sobol ×4", "sobol ×8", "sobol adaptive ×8"]);
        let one = [point(sobol, eight, None), point(sobol, eight, Some(0.1))];
        let labels: Vec<String> = series_keys(&one)
            .into_iter()
            .map(|key| series_label(&one, key))
            .collect();
        assert_eq!(labels, ["sobol", "sobol adaptive"]);
    }
}
