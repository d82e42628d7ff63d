//! The command line: clap arguments → validated options → load, build, render, write.
//!
//! Every error ends here as one message on stderr and exit code 2.

use crate::accel::{Accel, AccelKind};
use crate::integrator::RayCounts;
use crate::output::{self, ImageFormat};
use crate::render::{self, RenderSettings};
use crate::rng::SamplerKind;
use crate::scene::{builtin, Overrides, Scene, SceneSource};
use anyhow::Context;
use clap::Parser;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

#[derive(Debug, Parser)]
#[command(
    name = "raytracer",
    version,
    about = "A data-oriented SIMD packet ray tracer"
)]
pub struct Args {
    /// A built-in scene name (see --list) or a path to a .toml scene file.
    #[arg(required_unless_present = "list")]
    pub scene: Option<String>,

    /// Output image: .png or .ppm (8-bit, gamma 2), .exr (linear f32) [default: <scene>.png]
    #[arg(short, long)]
    pub output: Option<PathBuf>,

    /// Samples per pixel (overrides the scene).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1 << 20))]
    pub spp: Option<u32>,

    /// Image width in pixels; the height follows the scene's aspect ratio.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub width: Option<u32>,

    /// Maximum path depth (overrides the scene).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=10000))]
    pub max_depth: Option<u32>,

    /// Worker threads [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<u32>,

    /// Seed of the random numbers.
    #[arg(long, default_value_t = 0)]
    pub seed: u32,

    /// How pixel jitter, light samples and bounces are spread: independent random numbers
    /// (the seed's), stratified (correlated multi-jittered) or Owen-scrambled Sobol.
    #[arg(long, value_enum, default_value_t = SamplerKind::Independent)]
    pub sampler: SamplerKind,

    /// Rays per packet: 1 (scalar), 4 or 8.
    #[arg(long, default_value_t = 1, value_parser = parse_packet_width)]
    pub packet_width: u32,

    /// Acceleration structure.
    #[arg(long, value_enum, default_value_t = AccelKind::Bvh)]
    pub accel: AccelKind,

    /// Print what the acceleration structure holds, its build time, and the boxes
    /// visited and primitives tested per ray.
    #[arg(long)]
    pub stats: bool,

    /// List the built-in scenes and exit.
    #[arg(long)]
    pub list: bool,

    /// No progress bar and no summary line.
    #[arg(short, long)]
    pub quiet: bool,

    /// Write a JSON report of sizes, timings and ray counts to this file.
    #[arg(long)]
    pub report: Option<PathBuf>,
}

fn parse_packet_width(s: &str) -> Result<u32, String> {
    match s {
        "1" => Ok(1),
        "4" => Ok(4),
        "8" => Ok(8),
        _ => Err(format!("must be 1, 4 or 8, got '{s}'")),
    }
}

/// The `--report` JSON.
#[derive(Debug, serde::Serialize)]
pub struct Report {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub packet_width: u32,
    pub threads: usize,
    pub accel: AccelKind,
    pub seconds: Seconds,
    pub rays: Rays,
}

#[derive(Debug, Default, serde::Serialize)]
pub struct Seconds {
    pub load: f64,
    pub build: f64,
    pub render: f64,
    pub write: f64,
    pub total: f64,
}

#[derive(Debug, serde::Serialize)]
pub struct Rays {
    pub camera: u64,
    pub shadow: u64,
    pub secondary: u64,
    pub total: u64,
}

impl From<RayCounts> for Rays {
    fn from(c: RayCounts) -> Self {
        Rays {
            camera: c.camera,
            shadow: c.shadow,
            secondary: c.secondary,
            total: c.total(),
        }
    }
}

/// Entry point of the binary.
pub fn main() -> ExitCode {
    let args = Args::parse();
    match run(&args) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

pub fn run(args: &Args) -> anyhow::Result<ExitCode> {
    if args.list {
        for name in builtin::names() {
            let source = SceneSource::resolve(name)?;
            let desc = source.parse()?;
            println!("{name:<22} {}", desc.description);
        }
        return Ok(ExitCode::SUCCESS);
    }
    let start = Instant::now();
    let scene_arg = args.scene.as_deref().unwrap_or_default();

    // Validate everything the user gave before the long part.
    let output = match &args.output {
        Some(p) => p.clone(),
        None => PathBuf::from(format!("{}.png", scene_stem(scene_arg))),
    };
    ImageFormat::for_path(&output)?;
    output::check_writable(&output)?;
    if let Some(report) = &args.report {
        output::check_writable(report)?;
    }
    let notes = !args.quiet;
    if args.packet_width != 1 && notes {
        eprintln!(
            "note: packet tracing is not built yet; --packet-width {} runs as 1",
            args.packet_width
        );
    }

    let overrides = Overrides {
        width: args.width,
        spp: args.spp,
        max_depth: args.max_depth,
    };
    let mut scene = Scene::load(scene_arg, overrides)?;
    let loaded = Instant::now();
    let accel = Accel::build(&mut scene, args.accel);
    let built = Instant::now();

    let threads = args.threads.map_or_else(num_threads, |t| t as usize);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start the worker threads")?;
    let tiles =
        scene.camera.width.div_ceil(render::TILE) * scene.camera.height.div_ceil(render::TILE);
    let bar = if notes && std::io::stderr().is_terminal() {
        let bar = indicatif::ProgressBar::new(tiles as u64);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} {wide_bar} {percent}% {elapsed}/{duration}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        Some(bar)
    } else {
        None
    };
    let settings = RenderSettings {
        seed: args.seed,
        sampler: args.sampler,
    };
    let on_tile = || {
        if let Some(b) = &bar {
            b.inc(1)
        }
    };
    let rendered = pool.install(|| render::render(&scene, &accel, &settings, &on_tile))?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let rendered_at = Instant::now();

    output::write_image(&rendered.film, &output)?;
    let written = Instant::now();

    let secs = |a: Instant, b: Instant| (b - a).as_secs_f64();
    let render_s = secs(built, rendered_at);
    let counts = rendered.counts;
    if let Some(path) = &args.report {
        let report = Report {
            scene: scene.name.clone(),
            width: scene.camera.width,
            height: scene.camera.height,
            spp: scene.spp,
            packet_width: args.packet_width,
            threads,
            accel: accel.kind(),
            seconds: Seconds {
                load: secs(start, loaded),
                build: secs(loaded, built),
                render: render_s,
                write: secs(rendered_at, written),
                total: secs(start, Instant::now()),
            },
            rays: counts.into(),
        };
        let json = serde_json::to_string_pretty(&report)?;
        output::write_atomically(path, |out| {
            use std::io::Write;
            writeln!(out, "{json}")
        })?;
    }
    if args.stats {
        let t = counts.traversal;
        let per_ray = |x: u64| x as f64 / counts.total().max(1) as f64;
        eprintln!("stats: {}", accel.describe(&scene));
        eprintln!("stats: build {:.3} ms", secs(loaded, built) * 1e3);
        eprintln!(
            "stats: rays: {} camera, {} shadow, {} secondary; per ray {:.2} boxes visited, {:.2} primitives tested",
            counts.camera,
            counts.shadow,
            counts.secondary,
            per_ray(t.nodes),
            per_ray(t.prims)
        );
    }
    if notes {
        let bad = rendered.film.non_finite_count();
        if bad > 0 {
            eprintln!("warning: {bad} pixels had a NaN or infinite value");
        }
        eprintln!(
            "{}: {}x{}, {} spp, {:.3} s render ({:.3} s total), {:.2} M rays, {:.1} Mrays/s -> {}",
            scene.name,
            scene.camera.width,
            scene.camera.height,
            scene.spp,
            render_s,
            secs(start, Instant::now()),
            counts.total() as f64 / 1e6,
            counts.total() as f64 / 1e6 / render_s.max(1e-9),
            output.display()
        );
    }
    Ok(ExitCode::SUCCESS)
}

fn num_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// The default output name: the scene name, or a scene file's stem.
fn scene_stem(arg: &str) -> String {
    std::path::Path::new(arg)
        .file_stem()
        .map_or_else(|| "render".into(), |s| s.to_string_lossy().into_owned())
}
