//! Render one scene: load, build, render on the current pool (with a progress bar on a
//! terminal), write the image, then the report, the statistics and the summary line.

use super::options::RenderOptions;
use super::{report, stats};
use raytracer::accel::Accel;
use raytracer::output;
use raytracer::render::{self, Rendered};
use raytracer::scene::Scene;
use raytracer::PacketWidth;
use std::io::IsTerminal;
use std::time::Instant;

/// When each phase of a run ended.
#[derive(Clone, Copy, Debug)]
pub struct Timeline {
    pub start: Instant,
    pub loaded: Instant,
    pub built: Instant,
    pub rendered: Instant,
    pub written: Instant,
}

impl Timeline {
    /// Seconds from `a` to `b`.
    pub fn seconds(a: Instant, b: Instant) -> f64 {
        (b - a).as_secs_f64()
    }
}

/// What a run made, for the report and the printers.
pub struct Run<'a> {
    pub options: &'a RenderOptions,
    pub scene: &'a Scene,
    pub accel: &'a Accel,
    pub rendered: &'a Rendered,
    pub threads: usize,
    pub timeline: Timeline,
}

/// Render `o` on the current rayon pool of `threads` threads.
pub fn run(o: &RenderOptions, threads: usize) -> anyhow::Result<()> {
    let start = Instant::now();
    if o.settings.packet_width == PacketWidth::Eight && !raytracer::lanes::AVX2 && o.notes {
        eprintln!("note: built without AVX2: 8-wide packets run as two 4-wide halves");
    }
    let mut scene = Scene::load(&o.scene, o.overrides)?;
    let loaded = Instant::now();
    let accel = Accel::build(&mut scene, o.accel);
    let built = Instant::now();

    let bar = o.notes.then(|| progress_bar(&scene)).flatten();
    let on_tile = || {
        if let Some(b) = &bar {
            b.inc(1)
        }
    };
    let rendered = render::render(&scene, &accel, &o.settings, &on_tile)?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let rendered_at = Instant::now();

    output::write_image(&rendered.film, &o.output)?;
    let run = Run {
        options: o,
        scene: &scene,
        accel: &accel,
        rendered: &rendered,
        threads,
        timeline: Timeline {
            start,
            loaded,
            built,
            rendered: rendered_at,
            written: Instant::now(),
        },
    };
    if let Some(path) = &o.report {
        report::write(path, &run)?;
    }
    if o.stats {
        stats::print(&run);
    }
    if o.notes {
        summary(&run);
    }
    Ok(())
}

/// A bar over the tiles, on a terminal only.
fn progress_bar(scene: &Scene) -> Option<indicatif::ProgressBar> {
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let tiles =
        scene.camera.width.div_ceil(render::TILE) * scene.camera.height.div_ceil(render::TILE);
    let bar = indicatif::ProgressBar::new(tiles as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} {wide_bar} {percent}% {elapsed}/{duration}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    Some(bar)
}

/// The warning for non-finite pixels and the one summary line.
fn summary(run: &Run) {
    let (scene, film, counts) = (run.scene, &run.rendered.film, run.rendered.counts);
    let bad = film.non_finite_count();
    if bad > 0 {
        eprintln!("warning: {bad} pixels had a NaN or infinite value");
    }
    let t = run.timeline;
    let render_s = Timeline::seconds(t.built, t.rendered);
    eprintln!(
        "{}: {}x{}, {} spp, {:.3} s render ({:.3} s total), {:.2} M rays, {:.1} Mrays/s -> {}",
        scene.name,
        scene.camera.width,
        scene.camera.height,
        scene.spp,
        render_s,
        Timeline::seconds(t.start, Instant::now()),
        counts.total() as f64 / 1e6,
        counts.total() as f64 / 1e6 / render_s.max(1e-9),
        run.options.output.display()
    );
}
