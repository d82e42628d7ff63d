//! The command line as clap parses it: flags, their ranges and help texts. Nothing here
//! is checked beyond what clap checks; `options` turns these into validated options.

use clap::{Parser, Subcommand, ValueEnum};
use raytracer::accel::AccelKind;
use raytracer::output::ImageFormat;
use raytracer::sampling::SamplerKind;
use raytracer::{PacketWidth, Rect, Region};
use std::path::PathBuf;

/// `--version` names the instruction set compiled in (`.cargo/config.toml`) and the
/// packet widths it holds in one register (`raytracer::lanes::COMPILED`).
fn version() -> String {
    format!(
        "{} ({})",
        env!("CARGO_PKG_VERSION"),
        raytracer::lanes::COMPILED
    )
}

#[derive(Debug, Parser)]
#[command(
    name = "raytracer",
    version = version(),
    about = "A data-oriented SIMD packet ray tracer",
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true
)]
pub struct Args {
    /// Error against time (`reference`, `sweep`); putting part files together (`merge`).
    #[command(subcommand)]
    pub command: Option<Command>,

    /// A built-in scene name (see --list) or a path to a .toml scene file.
    #[arg(required_unless_present = "list")]
    pub scene: Option<String>,

    /// Output image: .png or .ppm (8-bit, gamma 2), .exr (linear f32), or - for standard
    /// output (in --format) [default: <scene>.png]
    #[arg(short, long)]
    pub output: Option<PathBuf>,

    /// The image format of -o - (standard output) [default: ppm]; a file's format is its
    /// extension.
    #[arg(long, value_enum)]
    pub format: Option<Format>,

    /// Samples per pixel (overrides the scene); every pixel takes them all.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1 << 20))]
    pub spp: Option<u32>,

    /// Render adaptively to this relative error (relative RMSE against the converged
    /// image, as `raytracer sweep` measures it: 0.01 or 1%): tiles stop when their
    /// estimated error reaches it, or at --max-spp.
    #[arg(long, value_name = "E", value_parser = parse_target_error,
          allow_hyphen_values = true, conflicts_with = "spp")]
    pub target_error: Option<f32>,

    /// The most samples a pixel takes when rendering adaptively [default: 1024].
    #[arg(long, value_name = "N", conflicts_with = "spp",
          value_parser = clap::value_parser!(u32).range(4..=1 << 20))]
    pub max_spp: Option<u32>,

    /// Render adaptively for at most this long (90s, 5m, 1h, 1.5m): passes until the
    /// next would end past it. The summary and the report give the --passes that
    /// reproduces the image without the clock.
    #[arg(long, value_name = "DURATION", value_parser = parse_duration,
          allow_hyphen_values = true, conflicts_with = "spp")]
    pub time_limit: Option<std::time::Duration>,

    /// Render adaptively for at most this many passes (the first takes 4 samples a
    /// pixel, each later one doubles the tiles still above the target).
    #[arg(long, value_name = "P", conflicts_with = "spp",
          value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub passes: Option<u32>,

    /// Write the samples each pixel took in an adaptive render to this image: .png or
    /// .ppm (grey, log2(samples) / log2(--max-spp)), or .exr (the counts).
    #[arg(long, value_name = "FILE")]
    pub spp_map: Option<PathBuf>,

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

    /// How pixel jitter, light samples and bounces are spread: Owen-scrambled Sobol (the
    /// lowest error at equal time), stratified (correlated multi-jittered) or independent
    /// random numbers (the original program's sampling, at any packet width).
    #[arg(long, value_enum, default_value_t = Sampler::Sobol)]
    pub sampler: Sampler,

    /// Rays per packet: 1 (the scalar reference), 4, 8 or 16; the image is the same bits
    /// [default: the widest that pays on the ISA compiled in: 16 with AVX-512,
    /// 8 with AVX2, else 4].
    #[arg(long, default_value_t = PacketWidth::widest(), hide_default_value = true)]
    pub packet_width: PacketWidth,

    /// Trace everything, even what cannot change the image (shadow rays of light
    /// samples that add nothing, packets outside the scene): to measure what the
    /// specialisation saves. The image is the same.
    #[arg(long)]
    pub no_specialize: bool,

    /// Acceleration structure.
    #[arg(long, value_enum, default_value_t = Accel::Bvh)]
    pub accel: Accel,

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

    /// Write a JSON report of sizes, timings and ray counts to this file, or to standard
    /// output for -.
    #[arg(long)]
    pub report: Option<PathBuf>,

    /// Render part I of N (0-based) of the frame and write it as a part file
    /// (-o NAME.part, default <scene>-<I>of<N>.part); `raytracer merge` puts the parts
    /// together. Each part gets every N-th tile of the frame, spread over all of it.
    #[arg(long, value_name = "I/N", value_parser = parse_region, conflicts_with = "crop")]
    pub region: Option<Region>,

    /// Render only the pixels [X0, X1) x [Y0, Y1) of the frame, as a part file
    /// (-o NAME.part, default <scene>-crop-X0-Y0-X1-Y1.part).
    #[arg(long, value_name = "X0,Y0,X1,Y1", value_parser = parse_crop)]
    pub crop: Option<Rect>,

    /// The memory the run may use, in bytes or with a unit (K, M, G, T: powers of 1024),
    /// e.g. 4G or 1.5G: a scene and image estimated to need more are refused before the
    /// memory is taken [default: the machine's available memory].
    #[arg(long, value_parser = parse_bytes)]
    pub max_memory: Option<u64>,
}

/// A byte count: a number, optionally with a unit (`K`, `M`, `G`, `T`, powers of 1024,
/// also written `KiB`, `MB`, …). `1.5G` is 1.5 · 2³⁰ bytes, rounded down.
pub fn parse_bytes(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let shift = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 0,
        "k" | "kb" | "kib" => 10,
        "m" | "mb" | "mib" => 20,
        "g" | "gb" | "gib" => 30,
        "t" | "tb" | "tib" => 40,
        _ => return Err(format!("unknown unit '{unit}' (use K, M, G or T)")),
    };
    let value: f64 = number
        .parse()
        .map_err(|_| format!("'{text}' is not a number of bytes"))?;
    let bytes = value * (1u64 << shift) as f64;
    // Up to 2^63: beyond any machine's memory, and exact in u64.
    if !(1.0..=9.2e18).contains(&bytes) {
        return Err(format!(
            "'{text}' must be at least 1 byte and at most 8 EiB"
        ));
    }
    Ok(bytes as u64)
}

/// `--target-error`: a positive relative error, as a fraction (`0.02`) or a percentage
/// (`2%`).
pub fn parse_target_error(text: &str) -> Result<f32, String> {
    let t = text.trim();
    let (number, scale) = match t.strip_suffix('%') {
        Some(n) => (n.trim(), 0.01),
        None => (t, 1.0),
    };
    let value = number
        .parse::<f64>()
        .ok()
        .map(|v| v * scale)
        .filter(|v| v.is_finite() && *v > 0.0 && *v <= 1e3)
        .ok_or_else(|| {
            format!("'{text}' is not a positive relative error (a fraction such as 0.02, or 2%)")
        })?;
    Ok(value as f32)
}

/// `--time-limit`: a positive duration with a unit (`ms`, `s`, `m`, `h`), or seconds
/// alone: `90s`, `5m`, `1.5h`, `250ms`, `30`.
pub fn parse_duration(text: &str) -> Result<std::time::Duration, String> {
    let t = text.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let bad = || format!("'{text}' is not a duration (a number with s, m or h: 90s, 5m, 1.5h)");
    let seconds = match unit.trim() {
        "" | "s" | "sec" => 1.0,
        "ms" => 1e-3,
        "m" | "min" => 60.0,
        "h" => 3600.0,
        _ => return Err(bad()),
    };
    let value: f64 = number.parse().map_err(|_| bad())?;
    let total = value * seconds;
    // Up to a year: beyond any render, and exact in a Duration.
    if !(total > 0.0 && total <= 3.2e7) {
        return Err(format!("'{text}' must be more than 0 and at most a year"));
    }
    Ok(std::time::Duration::from_secs_f64(total))
}

/// The subcommands: error against time, and merging part files.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a high-spp reference image (EXR, linear f32) for `sweep`.
    Reference(ReferenceArgs),
    /// Render a scene at spp = 1, 2, 4, …, --spp-max for each sampler, time each render and
    /// measure its error against the reference; write a CSV and an SVG chart.
    Sweep(SweepArgs),
    /// Put part files (made with --region or --crop) together into the frame, after
    /// checking that they come from one program, scene and settings and that they hold
    /// every pixel exactly once. The frame has the bits of a one-process render.
    Merge(MergeArgs),
    /// Serve a live view of the scene to a web browser: the render refined pass after
    /// pass, a camera that orbits, pans and zooms with the mouse, and buttons that save
    /// the image and give the camera as a [camera] table for the scene file.
    View(ViewArgs),
}

#[derive(Debug, clap::Args)]
pub struct ViewArgs {
    /// A built-in scene name or a .toml scene file.
    pub scene: String,
    /// The port to listen on [default: a free one]; the URL is printed.
    #[arg(long, default_value_t = 0)]
    pub port: u16,
    /// The address to listen on. Anything but a loopback address lets other machines
    /// see the scene and move its camera.
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1")]
    pub listen: std::net::IpAddr,
    /// Image width; the height follows the scene's aspect ratio.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub width: Option<u32>,
    /// The samples a pixel the view refines to (one a pass), and the sample count the
    /// stratified sampler spreads its draws over.
    #[arg(long, default_value_t = 4096, value_parser = clap::value_parser!(u32).range(1..=1 << 20))]
    pub spp: u32,
    /// Maximum path depth (overrides the scene).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=10000))]
    pub max_depth: Option<u32>,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<u32>,
    /// Seed of the random numbers.
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// How pixel jitter, light samples and bounces are spread.
    #[arg(long, value_enum, default_value_t = Sampler::Sobol)]
    pub sampler: Sampler,
    /// Rays per packet: 1, 4, 8 or 16; the image is the same bits.
    #[arg(long, default_value_t = PacketWidth::widest(), hide_default_value = true)]
    pub packet_width: PacketWidth,
}

#[derive(Debug, clap::Args)]
pub struct MergeArgs {
    /// The part files.
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// Output image: .exr (linear f32, the bits of a one-process render), .png or .ppm,
    /// or - for standard output (in --format).
    #[arg(short, long)]
    pub output: PathBuf,
    /// The image format of -o - (standard output) [default: ppm].
    #[arg(long, value_enum)]
    pub format: Option<Format>,
    /// The memory the merge may use (as for rendering): a frame and part estimated to
    /// need more are refused before the memory is taken [default: the machine's
    /// available memory].
    #[arg(long, value_parser = parse_bytes)]
    pub max_memory: Option<u64>,
    /// No summary line.
    #[arg(short, long)]
    pub quiet: bool,
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
    #[arg(long, value_enum, default_value_t = Sampler::Sobol)]
    pub sampler: Sampler,
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
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = Sampler::ALL)]
    pub samplers: Vec<Sampler>,
    /// Packet widths to sweep: 1, 4, 8 or 16 [default: the widest compiled in].
    #[arg(long, value_delimiter = ',', default_values_t = [PacketWidth::widest()], hide_default_value = true)]
    pub packet_widths: Vec<PacketWidth>,
    /// Seed of the swept renders.
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Adaptive series: render to each of these target errors (relative RMSE, 0.02 or
    /// 2%) with each of --adaptive-samplers [default: none].
    #[arg(long, value_delimiter = ',', value_parser = parse_target_error)]
    pub targets: Vec<f32>,
    /// Samplers of the adaptive series.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [Sampler::Sobol])]
    pub adaptive_samplers: Vec<Sampler>,
    /// The most samples a pixel of an adaptive render.
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(4..=1 << 20))]
    pub max_spp: u32,
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

/// `--region I/N`: part I of N, with 0 <= I < N <= `Region::MAX_PARTS`.
fn parse_region(s: &str) -> Result<Region, String> {
    let bad = || {
        format!(
            "must be I/N with 0 <= I < N <= {}, got '{s}'",
            Region::MAX_PARTS
        )
    };
    let (index, count) = s.split_once('/').ok_or_else(bad)?;
    let index: u32 = index.parse().map_err(|_| bad())?;
    let count: u32 = count.parse().map_err(|_| bad())?;
    if index >= count || count > Region::MAX_PARTS {
        return Err(bad());
    }
    Ok(Region::Part { index, count })
}

/// `--crop X0,Y0,X1,Y1`: a non-empty window (whether it fits the image is checked once
/// the scene says how large the image is).
fn parse_crop(s: &str) -> Result<Rect, String> {
    let bad = || format!("must be X0,Y0,X1,Y1 with X0 < X1 and Y0 < Y1, got '{s}'");
    let v: Vec<u32> = s
        .split(',')
        .map(|x| x.trim().parse().map_err(|_| bad()))
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x0, y0, x1, y1] if x0 < x1 && y0 < y1 => Ok(Rect::new(x0, y0, x1, y1)),
        _ => Err(bad()),
    }
}

/// `--sampler`: the library's `SamplerKind` as the command line spells it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Sampler {
    /// Independent hashed numbers (the original program's plain random sampling).
    Independent,
    /// Correlated multi-jittered sampling (Kensler 2013).
    Stratified,
    /// Owen-scrambled Sobol (0,2)-sequence (Burley 2020).
    Sobol,
}

impl Sampler {
    const ALL: [Sampler; 3] = [Sampler::Independent, Sampler::Stratified, Sampler::Sobol];
}

impl From<Sampler> for SamplerKind {
    fn from(s: Sampler) -> Self {
        match s {
            Sampler::Independent => SamplerKind::Independent,
            Sampler::Stratified => SamplerKind::Stratified,
            Sampler::Sobol => SamplerKind::Sobol,
        }
    }
}

/// `--format`: an image format, for an image written to standard output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// Binary PPM (P6), 8-bit, gamma 2.
    Ppm,
    /// PNG, 8-bit, gamma 2.
    Png,
    /// OpenEXR, linear f32 RGB.
    Exr,
}

impl From<Format> for ImageFormat {
    fn from(f: Format) -> Self {
        match f {
            Format::Ppm => ImageFormat::Ppm,
            Format::Png => ImageFormat::Png,
            Format::Exr => ImageFormat::Exr,
        }
    }
}

/// `--accel`: the library's `AccelKind` as the command line spells it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Accel {
    /// Brute force, with the mesh bounding-box pre-test (the original program's algorithm).
    Linear,
    /// Bounding volume hierarchy (binned SAH): 4-wide nodes for packets, 8-wide for
    /// single rays.
    Bvh,
}

impl From<Accel> for AccelKind {
    fn from(a: Accel) -> Self {
        match a {
            Accel::Linear => AccelKind::Linear,
            Accel::Bvh => AccelKind::Bvh,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::parse_bytes;

    #[test]
    fn target_errors_and_durations() {
        use super::{parse_duration, parse_target_error};
        use std::time::Duration;
        assert_eq!(parse_target_error("0.02"), Ok(0.02));
        assert_eq!(parse_target_error("2%"), Ok(0.02));
        assert_eq!(parse_target_error(" 10 % "), Ok(0.1));
        for bad in ["", "0", "-0.1", "0%", "x", "nan", "inf", "1e9", "%", "2%%"] {
            assert!(parse_target_error(bad).is_err(), "{bad}");
        }
        assert_eq!(parse_duration("90s"), Ok(Duration::from_secs(90)));
        assert_eq!(parse_duration("5m"), Ok(Duration::from_secs(300)));
        assert_eq!(parse_duration("1.5h"), Ok(Duration::from_secs(5400)));
        assert_eq!(parse_duration("250ms"), Ok(Duration::from_millis(250)));
        assert_eq!(parse_duration("30"), Ok(Duration::from_secs(30)));
        for bad in [
            "",
            "0s",
            "-5s",
            "5 minutes",
            "s",
            "1.2.3s",
            "5d",
            "nan",
            "1e3s",
            "2y",
        ] {
            assert!(parse_duration(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn byte_counts_with_and_without_units() {
        assert_eq!(parse_bytes("1000"), Ok(1000));
        assert_eq!(parse_bytes("4K"), Ok(4096));
        assert_eq!(parse_bytes("512M"), Ok(512 << 20));
        assert_eq!(parse_bytes("512 MiB"), Ok(512 << 20));
        assert_eq!(parse_bytes("1.5G"), Ok(3 << 29));
        assert_eq!(parse_bytes("2t"), Ok(2 << 40));
        for bad in ["", "G", "0", "0.1", "-1G", "1.2.3M", "5X", "1e3", "9E"] {
            assert!(parse_bytes(bad).is_err(), "{bad}");
        }
        assert!(parse_bytes("8388608T").is_err());
    }
}
