//! `--report FILE`: sizes, timings and ray counts of a run as JSON, written with the
//! image (`cli::render`).

use super::run::Run;
use raytracer::RayCounts;

/// The `--report` JSON.
#[derive(Debug, serde::Serialize)]
struct Report<'a> {
    scene: &'a str,
    width: u32,
    height: u32,
    spp: u32,
    packet_width: u32,
    /// The instruction set compiled in (`raytracer::lanes::ISA`): "AVX-512", "AVX2", ...
    isa: &'static str,
    threads: usize,
    accel: &'static str,
    specialize: bool,
    seconds: Seconds,
    rays: Rays,
    /// The region rendered into a part file ("region 3/16", "crop 0,0,64,64", "the whole
    /// frame"); absent for an image.
    #[serde(skip_serializing_if = "Option::is_none")]
    region: Option<String>,
    /// Pixels with a NaN or infinite channel (`Film::non_finite_count`).
    non_finite_pixels: usize,
    /// An adaptive render's settings and outcome; absent for `--spp`.
    #[serde(skip_serializing_if = "Option::is_none")]
    adaptive: Option<AdaptiveReport>,
}

#[derive(Debug, serde::Serialize)]
struct AdaptiveReport {
    /// `--target-error`, a relative RMSE (absent without one).
    target_error: Option<f32>,
    max_spp: u32,
    /// Passes run; `--passes` with this number renders the same image.
    passes: u32,
    /// `target`, `max_spp` or `passes` (the passes given, or the time limit's).
    stop: &'static str,
    /// The summary line's words for the stop.
    stop_reason: String,
    /// The estimated relative RMSE of the image (of the part, for a part file).
    estimated_error: f64,
    /// Samples a pixel.
    spp: SppStats,
    time_limit_seconds: Option<f64>,
}

#[derive(Debug, serde::Serialize)]
struct SppStats {
    mean: f64,
    min: u32,
    max: u32,
}

#[derive(Debug, serde::Serialize)]
struct Seconds {
    load: f64,
    build: f64,
    render: f64,
    write: f64,
    total: f64,
}

#[derive(Debug, serde::Serialize)]
struct Rays {
    camera: u64,
    shadow: u64,
    secondary: u64,
    total: u64,
    /// Skipped by specialisation: shadow rays whose sample adds nothing lit or not,
    /// and packets answered at once (outside the scene's box, or a tile's camera cone
    /// that meets nothing; at width 1 each camera ray of such a tile counts as one).
    shadow_culled: u64,
    packets_outside: u64,
    /// Camera packets' tests ruled out by their tile's cone: primitive tests beside the
    /// tree (one a lane), and tree traversals.
    cone_prims: u64,
    cone_trees: u64,
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

/// The report of `run`, as JSON. The write time is the image's encoding (the report is
/// written with it).
pub fn json(run: &Run) -> anyhow::Result<String> {
    let (r, t) = (run.renderer, run.timings);
    let report = Report {
        scene: r.name(),
        width: r.width(),
        height: r.height(),
        spp: r.spp(),
        packet_width: run.options.settings.packet_width.rays(),
        isa: raytracer::lanes::ISA,
        threads: run.threads,
        accel: run.options.scene_options.accel.name(),
        specialize: run.options.settings.specialize,
        seconds: Seconds {
            load: t.load.as_secs_f64(),
            build: t.build.as_secs_f64(),
            render: t.render.as_secs_f64(),
            write: t.write.as_secs_f64(),
            total: t.start.elapsed().as_secs_f64(),
        },
        rays: run.counts.into(),
        region: run.options.region.map(|r| r.to_string()),
        non_finite_pixels: run.non_finite,
        adaptive: run.adaptive.as_ref().map(|a| AdaptiveReport {
            target_error: run.options.adaptive.and_then(|s| s.target_error),
            max_spp: run.options.adaptive.map_or(0, |s| s.max_spp),
            passes: a.passes,
            stop: match a.stop {
                raytracer::Stop::Target => "target",
                raytracer::Stop::MaxSpp { .. } => "max_spp",
                raytracer::Stop::Passes => "passes",
            },
            stop_reason: super::run::stop_text(run.options, a),
            estimated_error: a.estimate,
            spp: SppStats {
                mean: a.spp_mean,
                min: a.spp_min,
                max: a.spp_max,
            },
            time_limit_seconds: run.options.time_limit.map(|t| t.as_secs_f64()),
        }),
    };
    Ok(serde_json::to_string_pretty(&report)?)
}
