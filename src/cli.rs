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
use clap::{Parser, Subcommand};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

/// `--version` says whether the AVX2 lanes were compiled in (`.cargo/config.toml`).
const VERSION: &str = if cfg!(target_feature = "avx2") {
    concat!(env!("CARGO_PKG_VERSION"), " (AVX2 compiled in)")
} else {
    concat!(
        env!("CARGO_PKG_VERSION"),
        " (without AVX2: 8-wide packets run as two halves)"
    )
};

#[derive(Debug, Parser)]
#[command(
    name = "raytracer",
    version = VERSION,
    about = "A data-oriented SIMD packet ray tracer",
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true
)]
pub struct Args {
    /// Error against time: `reference` and `sweep` (see `raytracer sweep --help`).
    #[command(subcommand)]
    pub command: Option<Command>,

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

    /// Trace everything, even what cannot change the image (shadow rays of light
    /// samples that add nothing, packets outside the scene): to measure what the
    /// specialisation saves. The image is the same.
    #[arg(long)]
    pub no_specialize: bool,

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

/// The error-against-time commands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a high-spp reference image (EXR, linear f32) for `sweep`.
    Reference(ReferenceArgs),
    /// Render a scene at spp = 1, 2, 4, …, --spp-max for each sampler, time each render and
    /// measure its error against the reference; write a CSV and an SVG chart.
    Sweep(SweepArgs),
}

#[derive(Debug, clap::Args)]
pub struct ReferenceArgs {
    /// A built-in scene name or a .toml scene file.
    pub scene: String,
    /// Image width (keep it small: the sweep renders at the same width).
    #[arg(long, default_value_t = 128, value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub width: u32,
    /// Samples per pixel of the reference (two halves with different seeds).
    #[arg(long, default_value_t = 4096, value_parser = clap::value_parser!(u32).range(2..=1 << 20))]
    pub spp: u32,
    /// Sampler of the reference.
    #[arg(long, value_enum, default_value_t = SamplerKind::Sobol)]
    pub sampler: SamplerKind,
    /// Output EXR [default: target/reference/<scene>-w<width>-<spp>spp.exr].
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<u32>,
}

#[derive(Debug, clap::Args)]
pub struct SweepArgs {
    /// A built-in scene name or a .toml scene file.
    pub scene: String,
    /// Image width (the reduced size that keeps a sweep to minutes).
    #[arg(long, default_value_t = 128, value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub width: u32,
    /// The largest spp of the sweep (spp = 1, 2, 4, … up to it).
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=1 << 20))]
    pub spp_max: u32,
    /// Renders per point; the time is their median.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub runs: u32,
    /// Samplers to sweep.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = SamplerKind::ALL)]
    pub samplers: Vec<SamplerKind>,
    /// Packet widths to sweep: 1, 4 or 8.
    #[arg(long, value_delimiter = ',', default_values_t = [1u32], value_parser = parse_packet_width)]
    pub packet_widths: Vec<u32>,
    /// Seed of the swept renders.
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Directory of the CSV (<scene>.csv), chart (<scene>.svg) and summary (<scene>.txt).
    #[arg(long, default_value = "target/sweep")]
    pub out: PathBuf,
    /// Reference EXR (with its .json note beside it); made first if it does not exist
    /// [default: target/reference/<scene>-w<width>-<reference-spp>spp.exr].
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Samples per pixel of a reference made by the sweep.
    #[arg(long, default_value_t = 4096, value_parser = clap::value_parser!(u32).range(2..=1 << 20))]
    pub reference_spp: u32,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<u32>,
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
    pub specialize: bool,
    pub seconds: Seconds,
    pub rays: Rays,
    /// Pixels with a NaN or infinite channel (`Film::non_finite_count`).
    pub non_finite_pixels: usize,
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
    /// Skipped by specialisation: shadow rays whose sample adds nothing lit or not,
    /// and packets answered at once (outside the scene's box, or a tile's camera cone
    /// that meets nothing).
    pub shadow_culled: u64,
    pub packets_outside: u64,
    /// Camera packets' tests ruled out by their tile's cone: primitive tests beside the
    /// tree (one a lane), and tree traversals.
    pub cone_prims: u64,
    pub cone_trees: u64,
}

impl From<RayCounts> for Rays {
    fn from(c: RayCounts) -> Self {
        Rays {
            camera: c.camera,
            shadow: c.shadow,
            secondary: c.secondary,
            total: c.total(),
            shadow_culled: c.shadow_culled,
            packets_outside: c.packets_outside,
            cone_prims: c.cone_prims,
            cone_trees: c.cone_trees,
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
    match &args.command {
        Some(Command::Reference(r)) => return run_reference(r),
        Some(Command::Sweep(s)) => return run_sweep(s),
        None => {}
    }
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
    if args.packet_width == 8 && !crate::lanes::AVX2 && notes {
        eprintln!("note: built without AVX2: 8-wide packets run as two 4-wide halves");
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
        packet_width: args.packet_width,
        specialize: !args.no_specialize,
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
            specialize: !args.no_specialize,
            seconds: Seconds {
                load: secs(start, loaded),
                build: secs(loaded, built),
                render: render_s,
                write: secs(rendered_at, written),
                total: secs(start, Instant::now()),
            },
            rays: counts.into(),
            non_finite_pixels: rendered.film.non_finite_count(),
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
        let f = scene.features;
        let yes_no = |b: bool| if b { "yes" } else { "no" };
        eprintln!(
            "stats: scene needs: path-traced bounces {}, mirror rays {}, shadow rays {} ({} point, {} area lights)",
            yes_no(f.has_path_traced),
            yes_no(f.has_mirror),
            yes_no(f.has_lights()),
            scene.lights.iter().filter(|l| l.is_point()).count(),
            scene.lights.iter().filter(|l| !l.is_point()).count(),
        );
        if args.no_specialize {
            eprintln!("stats: specialisation off (--no-specialize)");
        } else {
            eprintln!(
                "stats: skipped: {} shadow rays (their light sample adds nothing, lit or not), {} packets that miss everything (the scene's box, or their tile's cone)",
                counts.shadow_culled, counts.packets_outside
            );
            if args.packet_width > 1 {
                eprintln!(
                    "stats: skipped by the tiles' camera cones: {} primitive tests beside the tree (lanes), {} camera packets' tree traversals",
                    counts.cone_prims, counts.cone_trees
                );
            }
        }
        let w = args.packet_width;
        if w > 1 {
            let pct = |x: Option<f64>| x.map_or("-".to_string(), |x| format!("{:.1}%", x * 100.0));
            let nodes = (t.packet_nodes > 0)
                .then(|| t.packet_lanes as f64 / (t.packet_nodes * w as u64) as f64);
            eprintln!(
                "stats: {w}-wide packets (AVX2 {}): lane occupancy camera {}, shadow {}, mirror {}; at node visits {}",
                if crate::lanes::AVX2 { "on" } else { "off" },
                pct(counts.camera_packets.occupancy(w)),
                pct(counts.shadow_packets.occupancy(w)),
                pct(counts.mirror_packets.occupancy(w)),
                pct(nodes),
            );
        }
        eprintln!(
            "stats: non-finite pixels: {}",
            rendered.film.non_finite_count()
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

fn pool(threads: Option<u32>) -> anyhow::Result<(rayon::ThreadPool, usize)> {
    let threads = threads.map_or_else(num_threads, |t| t as usize);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start the worker threads")?;
    Ok((pool, threads))
}

fn default_reference(scene: &str, width: u32, spp: u32) -> PathBuf {
    crate::sweep::reference_path(std::path::Path::new("target/reference"), scene, width, spp)
}

/// Make the directory of a default output path (under `target/`).
fn create_parent(path: &std::path::Path) -> anyhow::Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create directory {}", dir.display()))?;
    }
    Ok(())
}

fn run_reference(r: &ReferenceArgs) -> anyhow::Result<ExitCode> {
    let path = match &r.output {
        Some(p) => p.clone(),
        None => {
            let p = default_reference(&r.scene, r.width, r.spp);
            create_parent(&p)?;
            p
        }
    };
    if ImageFormat::for_path(&path)? != ImageFormat::Exr {
        anyhow::bail!("{}: a reference is written as .exr", path.display());
    }
    let (pool, threads) = pool(r.threads)?;
    let info = pool.install(|| {
        crate::sweep::make_reference(&r.scene, Some(r.width), r.spp, r.sampler, &path)
    })?;
    eprintln!(
        "reference {}: {}x{}, {} spp {}, {:.1} s on {threads} threads, estimated own RMSE {:.3e} -> {}",
        info.scene,
        info.width,
        info.height,
        info.spp,
        info.sampler,
        info.seconds,
        info.estimated_mse.sqrt(),
        path.display()
    );
    Ok(ExitCode::SUCCESS)
}

fn run_sweep(a: &SweepArgs) -> anyhow::Result<ExitCode> {
    use crate::sweep;
    let (pool, threads) = pool(a.threads)?;
    let reference_path = match &a.reference {
        Some(p) => p.clone(),
        None => default_reference(&a.scene, a.width, a.reference_spp),
    };
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create directory {}", a.out.display()))?;
    let stem = scene_stem(&a.scene);
    let csv_path = a.out.join(format!("{stem}.csv"));
    let svg_path = a.out.join(format!("{stem}.svg"));
    let txt_path = a.out.join(format!("{stem}.txt"));
    for p in [&csv_path, &svg_path, &txt_path] {
        output::check_writable(p)?;
    }
    if !reference_path.exists() {
        create_parent(&reference_path)?;
        eprintln!(
            "making the reference {} ({} spp)",
            reference_path.display(),
            a.reference_spp
        );
        let info = pool.install(|| {
            sweep::make_reference(
                &a.scene,
                Some(a.width),
                a.reference_spp,
                SamplerKind::Sobol,
                &reference_path,
            )
        })?;
        eprintln!(
            "reference: {:.1} s, estimated own RMSE {:.3e}",
            info.seconds,
            info.estimated_mse.sqrt()
        );
    }
    let (reference, info) = sweep::load_reference(&reference_path)?;
    let (mut scene, accel) = sweep::prepare(&a.scene, Some(a.width))?;
    let plan = sweep::SweepPlan {
        spp_max: a.spp_max,
        runs: a.runs,
        samplers: a.samplers.clone(),
        packet_widths: a.packet_widths.clone(),
        seed: a.seed,
    };
    eprintln!(
        "sweep {}: {}x{}, {threads} threads, {} runs a point; reference {} spp, estimated own RMSE {:.3e}",
        scene.name,
        scene.camera.width,
        scene.camera.height,
        a.runs,
        info.spp,
        info.estimated_mse.sqrt()
    );
    let points = pool.install(|| {
        sweep::run_sweep(&mut scene, &accel, &reference, &plan, &mut |p| {
            eprintln!(
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
        })
    })?;
    let csv = sweep::csv(&scene, &info, threads, &points);
    let svg = sweep::chart(&scene.name, &points, &info);
    let summary = sweep::summary(&points);
    for (path, text) in [(&csv_path, &csv), (&svg_path, &svg), (&txt_path, &summary)] {
        output::write_atomically(path, |out| {
            use std::io::Write;
            out.write_all(text.as_bytes())
        })?;
    }
    print!("{summary}");
    eprintln!(
        "wrote {}, {}, {}",
        csv_path.display(),
        svg_path.display(),
        txt_path.display()
    );
    Ok(ExitCode::SUCCESS)
}
