//! Adaptive sampling: a render in passes that spends its samples where the error is.
//!
//! Every 16x16 tile of the frame's tile lattice (`render::TILE`) keeps the running sum of
//! its pixels' samples and the sum of their first half, and estimates its own error from
//! the two halves (below). Pass 0 takes [`FIRST_PASS_SPP`] samples a pixel everywhere;
//! each later pass doubles the samples of the tiles whose estimate is still above the
//! pass's threshold, up to `max_spp`. Everything a tile decides depends on its own
//! samples alone, so the image is the same bits on any thread count, packet width, tile
//! order and region split, and a tile that took n samples has the bits of the same tile
//! rendered with `--spp n` (the samples are summed in sample order either way).
//!
//! **The error.** The target is the relative RMSE that `raytracer sweep` measures against
//! a converged reference: the square root of relMSE, the mean over pixels and channels
//! of (x − r)² / (r² + ε), ε = 0.01 (`metrics`). A tile stops when its estimated relMSE
//! is at most the target's square.
//!
//! **The estimate.** After n samples a pixel's mean M splits into the mean A of its first
//! a = n/2 samples and the mean B of the other b (Dammertz et al. 2010 and Rousselle et
//! al. 2011 split a pixel's samples into two half-images the same way). With independent
//! samples of variance σ², E[(A − B)²] = σ²(1/a + 1/b), so (M − A)²·a/b, which equals
//! (A − B)²·ab/n², estimates σ²/n, the squared error of M, without bias. The first and
//! second halves of a pixel's samples, not its even and odd ones, because a half must be
//! a good sample set of its own: the Sobol sampler's even-numbered points all lie in one
//! half of the pixel, its first 2^k points form a (0, k, 2)-net and so do the next 2^k.
//!
//! Stratified samples are not independent: the two halves' errors partly cancel, and
//! (M − A)² overestimates the squared error of M. If a tile's squared error falls as
//! n^κ (κ = −1 for independent numbers, about −1.5 for Sobol at edges and soft shadows),
//! each half has 2^−κ times the error of the whole and the estimate is (2^−κ − 1) times
//! the truth. A tile measures its own rate at each doubling, r = est(n) / est(n/2) = 2^κ,
//! bounded to [1/4, 1/2] (κ from −2 to −1), keeps the geometric mean of its measures and
//! divides by (1/r − 1). The first doubling, from 2 to 4 samples, counts as 2^−1.5 rather
//! than its measure, which compares single samples at 2 (`FIRST_RATE`). The independent
//! sampler keeps r = 1/2: its estimate needs no correction.
//!
//! A tile stops when its estimate is low, so a noisy estimate is biased low at the stop:
//! the tiles that stop first are those whose estimate came out low. The estimate a tile
//! decides on is therefore the mean of two looks: this doubling's, and the last one
//! carried forward by the rate (r times the estimate at n/2); at 4 samples a Sobol or
//! stratified tile's own look alone.
//!
//! **Passes.** Pass p ≥ 1 doubles the tiles whose estimate is above
//! max(target², `RAMP_START` · 2^(1−p)): the worst tiles first, the threshold halving a
//! pass until it reaches the target, so that a run cut short (by a time limit) has about
//! the same error everywhere. The ramp orders the work; the tiles' final sample counts
//! are those of doubling every tile above the target, pass after pass.

use crate::error::{Error, Result};
use crate::farm::region::{Rect, TILE};
use crate::integrator::RayCounts;
use crate::lanes::{Lane, Mask, V3};
use crate::metrics::REL_MSE_EPSILON;
use crate::sampling::SamplerKind;
use glam::Vec3;

/// Samples a pixel that pass 0 takes everywhere (with estimates at 2 and 4 samples, so
/// that the first decision knows the tile's rate).
pub const FIRST_PASS_SPP: u32 = 4;

/// The threshold of pass 1, in relMSE (a relative RMSE of 1/8); it halves every pass.
pub const RAMP_START: f64 = 1.0 / 64.0;

/// A structured sampler's rate before its first doubling from 4 samples: 2^−1.5, the
/// rate of Owen-scrambled nets at edges and smooth soft shadows (κ = −1.5). With it
/// the estimate at the stop is within 1.25x of the truth in 64 of 68 runs of the
/// built-in and corpus scenes (docs/adaptive.md), against 61 with est(4) / est(2).
const FIRST_RATE: f64 = 0.353_553_390_593_273_8;

/// The bounds of a tile's measured rate r = est(n) / est(n/2).
const RATE_BOUNDS: (f64, f64) = (0.25, 0.5);

/// What an adaptive render aims at: a relative error, a sample budget per pixel and a
/// number of passes. The image depends on these (and on the render's settings) only.
#[derive(Clone, Copy, Debug)]
pub struct Adaptive {
    /// The relative RMSE each tile renders to (`None`: every tile goes on to `max_spp`,
    /// or until the passes run out).
    pub target_error: Option<f32>,
    /// The most samples a pixel takes.
    pub max_spp: u32,
    /// The most passes (`None`: until every tile stops).
    pub passes: Option<u32>,
}

/// Compares the target by its bits.
impl PartialEq for Adaptive {
    fn eq(&self, other: &Self) -> bool {
        self.target_error.map(f32::to_bits) == other.target_error.map(f32::to_bits)
            && self.max_spp == other.max_spp
            && self.passes == other.passes
    }
}

impl Eq for Adaptive {}

impl Adaptive {
    /// The default sample budget a pixel.
    pub const DEFAULT_MAX_SPP: u32 = 1024;

    /// Checked settings: a target that is a positive finite number, `max_spp` of at
    /// least 4 (the first pass's samples) and at most 2^20, at least one pass.
    pub fn new(target_error: Option<f32>, max_spp: u32, passes: Option<u32>) -> Result<Self> {
        if let Some(e) = target_error {
            if !(e.is_finite() && e > 0.0) {
                return Err(Error::Options(format!(
                    "the target error must be a positive number, got {e}"
                )));
            }
        }
        if !(FIRST_PASS_SPP..=1 << 20).contains(&max_spp) {
            return Err(Error::Options(format!(
                "the most samples a pixel must be from {FIRST_PASS_SPP} to {}, got {max_spp}",
                1 << 20
            )));
        }
        if passes == Some(0) {
            return Err(Error::Options(
                "an adaptive render takes at least one pass".into(),
            ));
        }
        Ok(Self {
            target_error,
            max_spp,
            passes,
        })
    }

    /// The target's square: the relMSE a tile stops at (0 without a target).
    pub fn target_rel_mse(&self) -> f64 {
        self.target_error.map_or(0.0, |e| e as f64 * e as f64)
    }

    /// The relMSE estimate above which a tile takes pass `pass` (≥ 1).
    pub fn threshold(&self, pass: u32) -> f64 {
        let ramp = RAMP_START * 0.5f64.powi(pass.saturating_sub(1).min(1000) as i32);
        ramp.max(self.target_rel_mse())
    }
}

/// Where an adaptive render stands after a pass, for a progress display.
#[derive(Clone, Copy, Debug)]
pub struct PassProgress {
    /// The pass just finished, from 0.
    pub pass: u32,
    /// The estimated relative RMSE of the image so far.
    pub estimate: f64,
    /// Samples a pixel, the mean over the image so far.
    pub spp_mean: f64,
    /// Camera samples the pass took.
    pub samples: u64,
    /// Camera samples the next pass will take.
    pub next_samples: u64,
    /// Tiles the next pass will render.
    pub next_tiles: usize,
    /// Whether the render is over (every tile stopped).
    pub done: bool,
}

/// Why an adaptive render ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// Every tile reached the target.
    Target,
    /// Every tile reached the target or `max_spp`; `above` tiles are at `max_spp` with
    /// their estimate above the target (all of them, without a target).
    MaxSpp {
        /// Tiles stopped by `max_spp` before reaching the target.
        above: usize,
    },
    /// The passes ran out (`Adaptive::passes`, or the caller stopped after a pass).
    Passes,
}

/// What an adaptive render did: passes, why it stopped, the estimated error and the
/// samples each pixel took.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    /// Passes run (the image is that of `Adaptive::passes = Some(passes)`).
    pub passes: u32,
    /// Why it ended.
    pub stop: Stop,
    /// The estimated relative RMSE of the image (of the region's pixels).
    pub estimate: f64,
    /// Samples a pixel, the fewest.
    pub spp_min: u32,
    /// Samples a pixel, the most.
    pub spp_max: u32,
    /// Samples a pixel, the mean.
    pub spp_mean: f64,
    /// Samples of each pixel, in the order of the render's pixels.
    pub spp: Vec<u32>,
}

/// One tile of the frame's lattice in an adaptive render: its estimate and the sums of
/// its pixels' first halves. The render (`render::render_rects_adaptive`) keeps the sums
/// of all their samples, row by row, where their means go (the output's rows), and adds
/// the samples.
pub(crate) struct TileSums {
    pub tile: Rect,
    /// The sum of each pixel's first `n_half` samples, row by row (allocated by the first
    /// step after pass 0: most tiles of most frames stop there).
    half: Vec<Vec3>,
    pub n: u32,
    n_half: u32,
    /// The uncorrected estimate (relMSE) at `n`.
    raw: f64,
    /// The tile's rate r = est(n) / est(n/2): the geometric mean of `rates` measures,
    /// whose logarithms sum to `log_rates` (1/2 for independent numbers).
    rate: f64,
    rates: u32,
    log_rates: f64,
    /// The corrected relMSE estimate at `n`.
    pub estimate: f64,
    /// Pixels of the render's region inside the tile.
    pub weight: u64,
    pub counts: RayCounts,
}

impl TileSums {
    pub fn new(tile: Rect, weight: u64) -> Self {
        Self {
            tile,
            half: Vec::new(),
            n: 0,
            n_half: 0,
            raw: f64::INFINITY,
            rate: RATE_BOUNDS.1,
            rates: 0,
            log_rates: 0.0,
            estimate: f64::INFINITY,
            weight,
            counts: RayCounts::default(),
        }
    }

    /// Before samples `self.n..`: the sums so far (`rows`, the tile's) become the first
    /// half.
    pub fn start_step(&mut self, rows: &[&mut [Vec3]]) {
        self.half.clear();
        for row in rows {
            self.half.extend_from_slice(row);
        }
        self.n_half = self.n;
    }

    /// Pass 0's estimates, at 2 and at [`FIRST_PASS_SPP`] samples, from their pixels'
    /// terms (`pixel_term`: the sums at 2 against 1 sample, at 4 against 2), taken while
    /// `sums` went to `FIRST_PASS_SPP` samples.
    pub fn first_pass(&mut self, at2: &[f32], at4: &[f32], counts: &RayCounts, kind: SamplerKind) {
        self.counts.add(counts);
        self.update(raw_of_terms(at2, 2, 1), true, kind);
        self.update(raw_of_terms(at4, FIRST_PASS_SPP, 2), true, kind);
        self.n = FIRST_PASS_SPP;
        self.n_half = 2;
    }

    /// After the samples up to `n` were added to the tile's sums (`rows`): the estimate
    /// at `n`.
    pub fn end_step(
        &mut self,
        n: u32,
        rows: &[&mut [Vec3]],
        counts: &RayCounts,
        kind: SamplerKind,
    ) {
        self.counts.add(counts);
        self.n = n;
        if self.n_half > 0 {
            let raw = raw_estimate(rows, &self.half, n, self.n_half);
            self.update(raw, n == 2 * self.n_half, kind);
        }
    }

    /// The estimate from `raw`, this step's uncorrected estimate (`doubled`: the step
    /// doubled the samples, so it measures the rate).
    fn update(&mut self, raw: f64, doubled: bool, kind: SamplerKind) {
        let structured = kind != SamplerKind::Independent;
        let first = structured && self.rates == 0;
        // A doubling measures the rate; the tile's rate is the geometric mean of its
        // measures (one measure is noisy, and a stop would select the low ones). The
        // first, est(4) / est(2), is [`FIRST_RATE`] instead: est(2) compares single
        // samples, so that measure spans the step from 1 to 2 samples too.
        if structured && doubled && self.raw.is_finite() {
            let r = if first {
                FIRST_RATE
            } else if self.raw > 0.0 && raw.is_finite() {
                (raw / self.raw).clamp(RATE_BOUNDS.0, RATE_BOUNDS.1)
            } else {
                RATE_BOUNDS.1
            };
            self.rates += 1;
            self.log_rates += r.ln();
            self.rate = (self.log_rates / self.rates as f64).exp();
        }
        // The mean of this estimate and the last one carried to n by the rate: two
        // half-independent looks, so that a tile does not stop on one low draw; both
        // corrected by the tile's rate as it is now. The first look at n = 2 had no
        // rate, and at 4 its single samples would stand for the step from 1 to 2: a
        // structured sampler's first estimate is its look at 4 alone.
        let looks = if first {
            raw
        } else if doubled && self.raw.is_finite() {
            0.5 * (raw + self.raw * self.rate)
        } else {
            raw
        };
        self.estimate = looks * self.rate / (1.0 - self.rate);
        self.raw = raw;
    }
}

/// The uncorrected relMSE estimate of a tile whose pixels' sums are `rows` at `n`
/// samples and `half` (row by row) at `a`: the mean over pixels and channels of
/// (M − A)²·a/b over M² + ε (`pixel_term`, `raw_of_terms`).
fn raw_estimate(rows: &[&mut [Vec3]], half: &[Vec3], n: u32, a: u32) -> f64 {
    let mut terms = [0.0f32; (TILE * TILE) as usize];
    let v3 = |v: Vec3| V3::new(v.x, v.y, v.z);
    let sums = rows.iter().flat_map(|row| row.iter());
    for ((term, sum), half) in terms.iter_mut().zip(sums).zip(half) {
        *term = pixel_term::<f32>(v3(*sum), v3(*half), n, a);
    }
    raw_of_terms(&terms[..half.len()], n, a)
}

/// The uncorrected relMSE estimate from a tile's pixels' terms at `n` samples against
/// `a`: their mean over the channels, times a/b. Each group of 16 pixels summed in f32
/// in pixel order, the groups in f64: the same bits at every packet width.
fn raw_of_terms(terms: &[f32], n: u32, a: u32) -> f64 {
    // A whole group as an array, so that its sum is unrolled (the same order).
    let group_sum = |group: &[f32]| match <&[f32; TILE as usize]>::try_from(group) {
        Ok(group) => group.iter().sum::<f32>(),
        Err(_) => group.iter().sum::<f32>(),
    };
    let total: f64 = terms
        .chunks(TILE as usize)
        .map(|group| group_sum(group) as f64)
        .sum();
    total * (a as f64 / (n - a) as f64) / (3 * terms.len()).max(1) as f64
}

/// A pixel's term of its tile's estimate, lane by lane: (M − A)² / (M² + ε) summed over
/// the channels, M = sum / n the mean of its n samples and A = half / a that of the first
/// a; (M − A)² / M² where M² would overflow (ε is below its rounding there). Exact
/// operations only, so a pixel's term has the same bits at every packet width. The
/// packets compute it on their way through pass 0 (2.1M instructions fewer on `quads` at
/// 256 px than copying the sums at 1 and 2 samples out and computing it afterwards).
#[inline(always)]
pub(crate) fn pixel_term<L: Lane>(sum: V3<L>, half: V3<L>, n: u32, a: u32) -> L {
    let (to_mean, to_half_mean) = (L::splat(1.0 / n as f32), L::splat(1.0 / a as f32));
    let (epsilon, huge) = (L::splat(REL_MSE_EPSILON as f32), L::splat(2f32.powi(60)));
    let mean = |sum: L, half: L| {
        let m = sum * to_mean;
        (m, m - half * to_half_mean)
    };
    let (x, y, z) = (
        mean(sum.x, half.x),
        mean(sum.y, half.y),
        mean(sum.z, half.z),
    );
    let term = |(m, d): (L, L)| d * d / (m * m + epsilon);
    // The quotient of the overflow's case only where a lane needs it: the same bits.
    if (x.0.abs().gt(huge) | y.0.abs().gt(huge) | z.0.abs().gt(huge)).any() {
        let term = |(m, d): (L, L)| {
            let r = d / m;
            L::select(m.abs().gt(huge), r * r, term((m, d)))
        };
        term(x) + term(y) + term(z)
    } else {
        term(x) + term(y) + term(z)
    }
}

pub(crate) fn intersect(a: Rect, b: Rect) -> Rect {
    Rect::new(
        a.x0.max(b.x0),
        a.y0.max(b.y0),
        a.x1.min(b.x1),
        a.y1.min(b.y1),
    )
}

/// The estimated relative RMSE of the region: its pixels' mean estimated relMSE.
pub(crate) fn estimate(tiles: &[TileSums]) -> f64 {
    let weight: u64 = tiles.iter().map(|t| t.weight).sum();
    let sum: f64 = tiles.iter().map(|t| t.estimate * t.weight as f64).sum();
    (sum / weight.max(1) as f64).sqrt()
}

/// The region's mean samples a pixel.
pub(crate) fn spp_mean(tiles: &[TileSums]) -> f64 {
    let weight: u64 = tiles.iter().map(|t| t.weight).sum();
    let sum: f64 = tiles.iter().map(|t| t.n as f64 * t.weight as f64).sum();
    sum / weight.max(1) as f64
}
