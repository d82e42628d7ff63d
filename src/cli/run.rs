//! What a render run made (its options, renderer, counts and timings): the record that
//! `render` fills in and `report` and `stats` print.

use super::options::RenderOptions;
use raytracer::{RayCounts, Renderer};
use std::time::{Duration, Instant};

/// What each phase of a run took.
#[derive(Clone, Copy, Debug)]
pub struct Timings {
    /// Reading, parsing and compiling the scene (meshes included).
    pub load: Duration,
    /// Building the acceleration structure.
    pub build: Duration,
    pub render: Duration,
    pub write: Duration,
    /// When the run started (the total is up to when it is printed).
    pub start: Instant,
}

/// What a run made, for the report and the printers.
pub struct Run<'a> {
    pub options: &'a RenderOptions,
    pub renderer: &'a Renderer,
    pub counts: RayCounts,
    /// Pixels with a NaN or infinite channel.
    pub non_finite: usize,
    pub threads: usize,
    pub timings: Timings,
    /// What an adaptive render did.
    pub adaptive: Option<raytracer::Outcome>,
}

/// A relative error as a percentage with two significant digits or more.
pub fn percent(e: f64) -> String {
    let p = e * 100.0;
    if p >= 10.0 {
        format!("{p:.1}%")
    } else if p >= 1.0 {
        format!("{p:.2}%")
    } else {
        format!("{p:.3}%")
    }
}

/// Why an adaptive run stopped, in the summary's words: the target reached, the sample
/// budget hit, or the passes (the clock's, with the flag that reproduces the image).
pub fn stop_text(o: &RenderOptions, a: &raytracer::Outcome) -> String {
    let target = o.adaptive.and_then(|s| s.target_error);
    let max = o.adaptive.map_or(0, |s| s.max_spp);
    match a.stop {
        raytracer::Stop::Target => match target {
            Some(t) => format!("target {} reached everywhere", percent(t as f64)),
            None => "every tile converged".into(),
        },
        raytracer::Stop::MaxSpp { above } => match target {
            Some(t) => format!(
                "--max-spp {max} reached in {above} tiles above the target {}",
                percent(t as f64)
            ),
            None => format!("--max-spp {max} reached"),
        },
        raytracer::Stop::Passes if o.adaptive.and_then(|s| s.passes) == Some(a.passes) => {
            format!("--passes {} done", a.passes)
        }
        raytracer::Stop::Passes => format!(
            "--time-limit reached; --passes {} gives this image without the clock",
            a.passes
        ),
    }
}
