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
}
