//! Validated options: what the parsed flags mean, checked before any long work (the
//! output's format, that every output file can be written, that no output replaces a
//! file the run reads or another output), with defaults filled in.

use super::args::{self, Args};
use super::scene_stem;
use raytracer::output::{self, ImageFormat};
use raytracer::{PacketWidth, Region, RenderSettings, SamplerKind, SceneOptions};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

/// What the command line asks for.
#[derive(Debug)]
pub enum Options {
    /// `--list`: the built-in scenes.
    List,
    Render(RenderOptions),
    Reference(ReferenceOptions),
    Sweep(SweepOptions),
    Merge(MergeOptions),
    View(super::view::ViewOptions),
}

/// Render one scene to an image.
#[derive(Debug)]
pub struct RenderOptions {
    /// The scene argument: a built-in name or a path (`cli::scene_file`).
    pub scene: String,
    pub scene_options: SceneOptions,
    pub settings: RenderSettings,
    /// `Some`: render this region into a part file (`--region`, `--crop`, or the whole
    /// frame for `-o NAME.part`); `None`: render the frame into an image.
    pub region: Option<Region>,
    /// The image or part file, or `-` for standard output (an image only).
    pub output: PathBuf,
    /// The image's format (`None` for a part file).
    pub format: Option<ImageFormat>,
    /// The report's file, or `-` for standard output.
    pub report: Option<PathBuf>,
    pub stats: bool,
    /// Progress bar, notes and the summary line (off with `--quiet`).
    pub notes: bool,
    /// `Some`: render adaptively (`--target-error`, `--max-spp`, `--time-limit` or
    /// `--passes` given).
    pub adaptive: Option<raytracer::Adaptive>,
    /// `--time-limit`: no pass starts that would end past it.
    pub time_limit: Option<std::time::Duration>,
    /// `--spp-map`: the samples each pixel took, as an image.
    pub spp_map: Option<PathBuf>,
}

/// `raytracer reference`.
#[derive(Debug)]
pub struct ReferenceOptions {
    pub scene: String,
    pub width: u32,
    pub spp: u32,
    pub sampler: SamplerKind,
    pub output: PathBuf,
    /// The output is the default one under `target/`, whose directory may be made.
    pub output_is_default: bool,
}

/// `raytracer sweep`.
#[derive(Debug)]
pub struct SweepOptions {
    pub scene: String,
    pub width: u32,
    pub spp_max: u32,
    pub runs: u32,
    pub samplers: Vec<SamplerKind>,
    pub packet_widths: Vec<PacketWidth>,
    pub seed: u32,
    pub out: PathBuf,
    pub reference: PathBuf,
    pub reference_spp: u32,
    /// Adaptive series: targets, samplers and the sample budget.
    pub targets: Vec<f32>,
    pub adaptive_samplers: Vec<SamplerKind>,
    pub max_spp: u32,
}

impl RenderOptions {
    /// Refuse an output (`-o`, `--report`) that is one of the files the scene reads
    /// (`SceneFile::input_files`: its meshes and their material libraries), before they
    /// are loaded.
    pub fn check_outputs_against(&self, inputs: &[(&'static str, PathBuf)]) -> anyhow::Result<()> {
        let inputs: Vec<(&str, &Path)> = inputs
            .iter()
            .map(|(what, p)| (*what, p.as_path()))
            .collect();
        let outputs = std::iter::once(("-o", &self.output))
            .chain(self.report.iter().map(|r| ("--report", r)));
        for (flag, path) in outputs.filter(|(_, p)| !is_stdout(p)) {
            output::check_not_an_input(flag, path, &inputs)?;
        }
        Ok(())
    }
}

impl Options {
    /// The directories the command writes files into, where a killed run may have left
    /// temporary files (`output::remove_stale_temporaries`).
    pub fn output_dirs(&self) -> Vec<PathBuf> {
        let mut dirs: Vec<PathBuf> = match self {
            Options::List | Options::View(_) => Vec::new(),
            Options::Merge(o) => std::iter::once(&o.output)
                .filter(|p| !is_stdout(p))
                .map(|p| output::directory_of(p))
                .collect(),
            Options::Render(o) => std::iter::once(&o.output)
                .chain(&o.report)
                .filter(|p| !is_stdout(p))
                .map(|p| output::directory_of(p))
                .collect(),
            Options::Reference(o) => vec![output::directory_of(&o.output)],
            Options::Sweep(o) => vec![output::directory_of(&o.reference), o.out.clone()],
        };
        dirs.dedup();
        dirs
    }
}

/// `raytracer merge`.
#[derive(Debug)]
pub struct MergeOptions {
    pub parts: Vec<PathBuf>,
    /// The frame's file, or `-` for standard output.
    pub output: PathBuf,
    pub format: ImageFormat,
    /// `--max-memory` (`None`: the machine's free memory).
    pub max_memory: Option<u64>,
    /// The summary line (off with `--quiet`).
    pub notes: bool,
}

/// The options and the worker threads they ask for (`None`: all cores).
pub fn from_args(args: Args) -> anyhow::Result<(Options, Option<u32>)> {
    match args.command {
        Some(args::Command::Reference(r)) => {
            let threads = r.threads;
            Ok((Options::Reference(reference(r)?), threads))
        }
        Some(args::Command::Sweep(s)) => {
            let threads = s.threads;
            Ok((Options::Sweep(sweep(s)), threads))
        }
        Some(args::Command::Merge(m)) => Ok((Options::Merge(merge(m)?), None)),
        Some(args::Command::View(v)) => {
            let threads = v.threads;
            Ok((Options::View(super::view::ViewOptions::from(v)), threads))
        }
        None if args.list => Ok((Options::List, None)),
        None => {
            let threads = args.threads;
            Ok((Options::Render(render(args)?), threads))
        }
    }
}

fn render(args: Args) -> anyhow::Result<RenderOptions> {
    let scene = args.scene.unwrap_or_default();
    let region = args.region.or(args.crop.map(Region::Crop));
    let output = args
        .output
        .unwrap_or_else(|| default_output(&scene_stem(&scene), region));
    // A part file for a region, or for the whole frame when -o names one.
    let region = match region {
        Some(r) if !is_part(&output) => anyhow::bail!(
            "{} writes a part file: -o must end in .part, got {}",
            if matches!(r, Region::Crop(_)) {
                "--crop"
            } else {
                "--region"
            },
            output.display()
        ),
        None if is_part(&output) => Some(Region::Frame),
        r => r,
    };
    let format = match region {
        None => Some(image_format(&output, args.format)?),
        Some(_) if args.format.is_some() => {
            anyhow::bail!("--format sets an image's format: a part file has its own")
        }
        Some(_) => None,
    };
    // No output may replace the scene file (its meshes are checked once it is read).
    let inputs: Vec<(&str, &Path)> = super::scene_path(&scene)
        .map(|path| ("scene file", path))
        .into_iter()
        .collect();
    let image_to_stdout = is_stdout(&output);
    if !image_to_stdout {
        output::check_not_an_input("-o", &output, &inputs)?;
        output::check_writable(&output)?;
    }
    let adaptive = if args.target_error.is_some()
        || args.max_spp.is_some()
        || args.time_limit.is_some()
        || args.passes.is_some()
    {
        let max_spp = args.max_spp.unwrap_or(raytracer::Adaptive::DEFAULT_MAX_SPP);
        Some(raytracer::Adaptive::new(
            args.target_error,
            max_spp,
            args.passes,
        )?)
    } else {
        None
    };
    if let Some(map) = &args.spp_map {
        if adaptive.is_none() {
            anyhow::bail!(
                "--spp-map maps an adaptive render: give --target-error, --time-limit, \
                 --max-spp or --passes (with --spp every pixel takes the same samples)"
            );
        }
        if region.is_some() {
            anyhow::bail!("--spp-map maps a whole frame, not a part file");
        }
        ImageFormat::for_path(map).map_err(|e| anyhow::anyhow!("--spp-map: {e}"))?;
        output::check_not_an_input("--spp-map", map, &inputs)?;
        output::check_writable(map)?;
        if same_path(map, &output) || args.report.as_deref().is_some_and(|r| same_path(map, r)) {
            anyhow::bail!(
                "--spp-map {} names the image or the report: give it a file of its own",
                map.display()
            );
        }
    }
    if let Some(report) = &args.report {
        if is_stdout(report) {
            if image_to_stdout {
                anyhow::bail!("-o - and --report - would both write to standard output");
            }
        } else {
            output::check_not_an_input("--report", report, &inputs)?;
            output::check_writable(report)?;
            if !image_to_stdout {
                output::check_distinct_outputs(&output, report)?;
            }
        }
    }
    Ok(RenderOptions {
        scene,
        scene_options: SceneOptions {
            width: args.width,
            spp: args.spp,
            max_depth: args.max_depth,
            accel: args.accel.into(),
            max_memory: args.max_memory,
        },
        settings: RenderSettings {
            seed: args.seed,
            packet_width: args.packet_width,
            specialize: !args.no_specialize,
            sampler: args.sampler.into(),
        },
        region,
        output,
        format,
        report: args.report,
        stats: args.stats,
        notes: !args.quiet,
        adaptive,
        time_limit: args.time_limit,
        spp_map: args.spp_map,
    })
}

/// `-`, which names standard output.
pub fn is_stdout(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// The format of an image written to `output`: for standard output `--format`, PPM by
/// default (as the original program wrote it); for a file its extension, which
/// `--format`, if given, must agree with.
fn image_format(output: &Path, given: Option<args::Format>) -> anyhow::Result<ImageFormat> {
    if is_stdout(output) {
        if std::io::stdout().is_terminal() {
            anyhow::bail!("-o -: standard output is a terminal; redirect it to a file or a pipe");
        }
        return Ok(given.map_or(ImageFormat::Ppm, Into::into));
    }
    let format = ImageFormat::for_path(output)?;
    if given.is_some_and(|g| ImageFormat::from(g) != format) {
        anyhow::bail!(
            "--format does not match -o {}: a file's format is its extension",
            output.display()
        );
    }
    Ok(format)
}

/// Do `a` and `b` name the same file (by their absolute paths, whether they exist)?
fn same_path(a: &Path, b: &Path) -> bool {
    let absolute = |p: &Path| std::path::absolute(p).ok();
    a == b || absolute(a).is_some_and(|x| Some(x) == absolute(b))
}

fn is_part(path: &Path) -> bool {
    path.extension().is_some_and(|e| e == "part")
}

/// The default output: `<stem>.png`, or a part file `bunny-3of16.part`,
/// `bunny-crop-0-0-64-64.part`.
fn default_output(stem: &str, region: Option<Region>) -> PathBuf {
    PathBuf::from(match region {
        None => format!("{stem}.png"),
        Some(Region::Part { index, count }) => format!("{stem}-{index}of{count}.part"),
        Some(Region::Crop(r)) => format!("{stem}-crop-{}-{}-{}-{}.part", r.x0, r.y0, r.x1, r.y1),
        Some(Region::Frame) => format!("{stem}.part"),
    })
}

fn merge(m: args::MergeArgs) -> anyhow::Result<MergeOptions> {
    let format = image_format(&m.output, m.format)?;
    if !is_stdout(&m.output) {
        // The frame must not replace one of its parts.
        let parts: Vec<(&str, &Path)> =
            m.parts.iter().map(|p| ("part file", p.as_path())).collect();
        output::check_not_an_input("-o", &m.output, &parts)?;
        output::check_writable(&m.output)?;
    }
    Ok(MergeOptions {
        parts: m.parts,
        output: m.output,
        format,
        max_memory: m.max_memory,
        notes: !m.quiet,
    })
}

fn reference(r: args::ReferenceArgs) -> anyhow::Result<ReferenceOptions> {
    let (output, output_is_default) = match r.output {
        Some(p) => (p, false),
        None => (default_reference(&r.scene, r.width, r.spp), true),
    };
    if ImageFormat::for_path(&output)? != ImageFormat::Exr {
        anyhow::bail!("{}: a reference is written as .exr", output.display());
    }
    Ok(ReferenceOptions {
        scene: r.scene,
        width: r.width,
        spp: r.spp,
        sampler: r.sampler.into(),
        output,
        output_is_default,
    })
}

fn sweep(s: args::SweepArgs) -> SweepOptions {
    let reference = s
        .reference
        .unwrap_or_else(|| default_reference(&s.scene, s.width, s.reference_spp));
    SweepOptions {
        scene: s.scene,
        width: s.width,
        spp_max: s.spp_max,
        runs: s.runs,
        samplers: s.samplers.into_iter().map(Into::into).collect(),
        packet_widths: s.packet_widths,
        seed: s.seed,
        out: s.out,
        reference,
        reference_spp: s.reference_spp,
        targets: s.targets,
        adaptive_samplers: s.adaptive_samplers.into_iter().map(Into::into).collect(),
        max_spp: s.max_spp,
    }
}

/// The default path of a reference: `target/reference/<scene>-w<width>-<spp>spp.exr`.
fn default_reference(scene: &str, width: u32, spp: u32) -> PathBuf {
    let stem = Path::new(scene)
        .file_stem()
        .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    Path::new("target/reference").join(format!("{stem}-w{width}-{spp}spp.exr"))
}
