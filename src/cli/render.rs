//! Render one scene: load, build, render on the current pool (with a progress bar on a
//! terminal), write the image (or the part file of a region) and the report together
//! (all or nothing), then the statistics and the summary line.

use super::options::{is_stdout, RenderOptions};
use super::run::{percent, stop_text, Run, Timings};
use super::{report, stats};
use anyhow::Context;
use raytracer::output::OutputSet;
use raytracer::{PacketWidth, Part, Region, Rendered, Renderer};
use std::io::IsTerminal;
use std::time::{Duration, Instant};

/// The pixels of a run: the frame, or a region of it for a part file.
enum Pixels {
    Frame(Rendered),
    Part(Part),
}

/// Render `o` on the current rayon pool of `threads` threads.
pub fn run(o: &RenderOptions, threads: usize) -> anyhow::Result<()> {
    let start = Instant::now();
    if o.notes {
        let halves = match o.settings.packet_width {
            PacketWidth::Eight if !raytracer::lanes::AVX2 => Some(("AVX2", 8, 4)),
            PacketWidth::Sixteen if !raytracer::lanes::AVX512 => Some(("AVX-512", 16, 8)),
            _ => None,
        };
        if let Some((isa, wide, half)) = halves {
            to_stderr!(
                "note: built without {isa}: {wide}-wide packets run as two {half}-wide halves"
            );
        }
    }
    let file = super::scene_file(&o.scene)?;
    o.check_outputs_against(&file.input_files())?;
    let renderer = Renderer::new(&file, &o.scene_options).map_err(super::name_the_memory_cap)?;
    for warning in &renderer.scene().warnings {
        to_stderr!("warning: {warning}");
    }
    let built = Instant::now();
    // The region's tiles; a crop outside the image is refused here, before the render.
    let tiles = match o.region {
        None => renderer.tiles() as u64,
        Some(region) => {
            let rects = region
                .rects(renderer.width(), renderer.height())
                .with_context(|| match region {
                    Region::Crop(r) => format!("--crop {r}"),
                    Region::Part { index, count } => format!("--region {index}/{count}"),
                    Region::Frame => "the whole frame".into(),
                })?;
            raytracer::render::tile_count(&rects)
        }
    };

    let bar = o.notes.then(|| progress_bar(tiles)).flatten();
    let on_tile = || {
        if let Some(b) = &bar {
            b.inc(1)
        }
    };
    let pixels = match (o.region, &o.adaptive) {
        (None, None) => Pixels::Frame(renderer.render_with_progress(&o.settings, &on_tile)?),
        (Some(region), None) => {
            Pixels::Part(renderer.render_part_with_progress(&o.settings, region, &on_tile)?)
        }
        (region, Some(adaptive)) => {
            let mut clock = PassClock::new(o.time_limit);
            let mut on_pass = |p: &raytracer::PassProgress| clock.after_pass(p, bar.as_ref());
            match region {
                None => Pixels::Frame(renderer.render_adaptive(
                    &o.settings,
                    adaptive,
                    &on_tile,
                    &mut on_pass,
                )?),
                Some(region) => Pixels::Part(renderer.render_part_adaptive(
                    &o.settings,
                    adaptive,
                    region,
                    &on_tile,
                    &mut on_pass,
                )?),
            }
        }
    };
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let rendered_at = Instant::now();

    // The image (or part) and the report are written to temporary files, then renamed
    // into place together: a failure leaves neither, and no earlier file is replaced.
    // Standard output takes the image last, after every file is written and checked,
    // and the report after the files are in place.
    let mut files = OutputSet::default();
    let image_to_stdout = is_stdout(&o.output);
    let report_to_stdout = o.report.as_deref().is_some_and(is_stdout);
    let (counts, non_finite, adaptive) = match &pixels {
        Pixels::Frame(rendered) => {
            if !image_to_stdout {
                files.add_image(&rendered.film, &o.output)?;
            }
            if let (Some(map), Some(outcome)) = (&o.spp_map, &rendered.adaptive) {
                let max = o.adaptive.map_or(1, |a| a.max_spp);
                files.add_image(&spp_map(&rendered.film, outcome, max, map)?, map)?;
            }
            (
                rendered.counts,
                rendered.film.non_finite_count(),
                rendered.adaptive.clone(),
            )
        }
        Pixels::Part(part) => {
            part.add_to(&mut files, &o.output)?;
            (
                part.counts(),
                part.non_finite_count(),
                part.adaptive().cloned(),
            )
        }
    };
    let mut run = Run {
        options: o,
        renderer: &renderer,
        counts,
        non_finite,
        threads,
        adaptive,
        timings: Timings {
            load: (built - start).saturating_sub(renderer.build_time()),
            build: renderer.build_time(),
            render: rendered_at - built,
            write: rendered_at.elapsed(),
            start,
        },
    };
    let json = o.report.as_ref().map(|_| report::json(&run)).transpose()?;
    if let (Some(path), Some(json), false) = (&o.report, &json, report_to_stdout) {
        files.add(path, |out| {
            use std::io::Write;
            writeln!(out, "{json}")
        })?;
    }
    if let (Pixels::Frame(rendered), true, Some(format)) = (&pixels, image_to_stdout, o.format) {
        super::image_to_stdout(&rendered.film, format)?;
    }
    files.commit()?;
    if let (Some(json), true) = (&json, report_to_stdout) {
        super::print_stdout(&format!("{json}\n"))?;
    }
    run.timings.write = rendered_at.elapsed();
    if o.stats {
        stats::print(&run);
    }
    if o.notes {
        summary(&run);
    }
    Ok(())
}

/// A bar over the tiles, on a terminal only.
fn progress_bar(tiles: u64) -> Option<indicatif::ProgressBar> {
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = indicatif::ProgressBar::new(tiles);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} {msg} {wide_bar} {percent}% {elapsed}/{duration}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    Some(bar)
}

/// The warning for non-finite pixels and the one summary line.
fn summary(run: &Run) {
    let (r, counts) = (run.renderer, run.counts);
    if run.non_finite > 0 {
        to_stderr!(
            "warning: {} pixels had a NaN or infinite value",
            run.non_finite
        );
    }
    let render_s = run.timings.render.as_secs_f64();
    let sampling = match &run.adaptive {
        None => format!("{} spp", r.spp()),
        Some(a) => format!(
            "{:.1} spp (min {}, max {}), est. error {}, {} passes: {}",
            a.spp_mean,
            a.spp_min,
            a.spp_max,
            percent(a.estimate),
            a.passes,
            stop_text(run.options, a)
        ),
    };
    to_stderr!(
        "{}: {}{}x{}, {}, {:.3} s render ({:.3} s total), {:.2} M rays, {:.1} Mrays/s -> {}",
        r.name(),
        run.options
            .region
            .map_or_else(String::new, |region| format!("{region} of ")),
        r.width(),
        r.height(),
        sampling,
        render_s,
        run.timings.start.elapsed().as_secs_f64(),
        counts.total() as f64 / 1e6,
        counts.total() as f64 / 1e6 / render_s.max(1e-9),
        super::output_name(&run.options.output)
    );
}

/// The samples each pixel took as an image: for PNG and PPM a grey level of
/// log2(samples) / log2(max_spp) (the film holds its square, which the gamma-2 encoding
/// takes back), for EXR the counts themselves.
fn spp_map(
    film: &raytracer::Film,
    outcome: &raytracer::Outcome,
    max_spp: u32,
    path: &std::path::Path,
) -> anyhow::Result<raytracer::Film> {
    let exr =
        raytracer::output::ImageFormat::for_path(path)? == raytracer::output::ImageFormat::Exr;
    let mut map = raytracer::Film::new(film.width, film.height)?;
    let top = (max_spp as f32).log2();
    for (pixel, &n) in map.pixels.iter_mut().zip(&outcome.spp) {
        let v = if exr {
            n as f32
        } else {
            let g = (n as f32).log2() / top;
            g * g
        };
        *pixel = raytracer::Vec3::splat(v);
    }
    Ok(map)
}

/// The clock of an adaptive run: the progress bar's pass and estimate, and the time
/// limit (no pass starts that its predecessor's rate says would end past it).
struct PassClock {
    limit: Option<Duration>,
    start: Instant,
    pass_start: Instant,
    /// Camera samples a second in the last pass that took any.
    rate: Option<f64>,
}

impl PassClock {
    fn new(limit: Option<Duration>) -> Self {
        let now = Instant::now();
        Self {
            limit,
            start: now,
            pass_start: now,
            rate: None,
        }
    }

    fn after_pass(
        &mut self,
        p: &raytracer::PassProgress,
        bar: Option<&indicatif::ProgressBar>,
    ) -> std::ops::ControlFlow<()> {
        let now = Instant::now();
        let took = (now - self.pass_start).as_secs_f64();
        self.pass_start = now;
        if let Some(b) = bar {
            b.set_message(format!(
                "pass {} · est. error {} · {:.1} spp",
                p.pass + 1,
                percent(p.estimate),
                p.spp_mean
            ));
            b.set_position(0);
            b.set_length(p.next_tiles.max(1) as u64);
        }
        if p.samples > 0 {
            self.rate = Some(p.samples as f64 / took.max(1e-9));
        }
        if let (Some(limit), Some(rate)) = (self.limit, self.rate) {
            let next = p.next_samples as f64 / rate;
            if (now - self.start).as_secs_f64() + next > limit.as_secs_f64() {
                return std::ops::ControlFlow::Break(());
            }
        }
        std::ops::ControlFlow::Continue(())
    }
}
