//! What a sweep measured and what it says: its points (`Point`), and the summary of a
//! sweep's series (`summary`): the error each sampler reaches in a given time, how much
//! sooner one reaches another's error, the adaptive series' calibration and their gain
//! at equal error, and the comparison at the scene's own samples a pixel.

use raytracer::metrics::{log_log_slope, Errors};
use raytracer::sampling::SamplerKind;
use raytracer::PacketWidth;
use std::fmt::Write as _;

/// One point of a sweep.
#[derive(Debug, Clone)]
pub struct Point {
    pub sampler: SamplerKind,
    pub packet_width: PacketWidth,
    pub spp: u32,
    /// Median, fastest and slowest of the runs (render only: no load, build or write).
    pub seconds: f64,
    pub seconds_min: f64,
    pub seconds_max: f64,
    pub rays: u64,
    pub errors: Errors,
    /// An adaptive render's target and outcome (`None`: `spp` samples every pixel).
    pub adaptive: Option<AdaptivePoint>,
}

/// What an adaptive point of a sweep aimed at and did.
#[derive(Debug, Clone, Copy)]
pub struct AdaptivePoint {
    /// `--target-error`.
    pub target: f32,
    /// The run's own estimate of its relative RMSE.
    pub estimate: f64,
    /// Samples a pixel, the mean.
    pub spp_mean: f64,
}

impl Point {
    /// The true relative RMSE (against the reference).
    pub fn rel_rmse(&self) -> f64 {
        self.errors.rel_mse.sqrt()
    }
}

/// The name of a series: the sampler, and whether it samples adaptively.
pub(super) fn series_name(sampler: SamplerKind, adaptive: bool) -> String {
    if adaptive {
        format!("{} adaptive", sampler.name())
    } else {
        sampler.name().to_string()
    }
}

pub(super) fn median(sorted: &[f64]) -> f64 {
    let n = sorted.len();
    if n % 2 == 1 {
        sorted[n / 2]
    } else {
        0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
    }
}

/// ln y at ln x on the polyline through `xy` (sorted by x), or `None` outside its range.
fn interpolate_log(xy: &[(f64, f64)], x: f64) -> Option<f64> {
    let lx = x.ln();
    xy.windows(2).find_map(|w| {
        let (x0, y0) = (w[0].0.ln(), w[0].1.ln());
        let (x1, y1) = (w[1].0.ln(), w[1].1.ln());
        (x0 <= lx && lx <= x1 && x1 > x0).then(|| y0 + (y1 - y0) * (lx - x0) / (x1 - x0))
    })
}

/// The summary a reader wants: per sampler the slope of MSE against spp, and against the
/// independent sampler the MSE ratio at equal time and the time ratio at equal MSE.
pub fn summary(points: &[Point]) -> String {
    let mut s = String::new();
    let widths: Vec<PacketWidth> = dedup(points.iter().map(|p| p.packet_width));
    for w in widths {
        let series = |k: SamplerKind| -> Vec<&Point> {
            points
                .iter()
                .filter(|p| p.packet_width == w && p.sampler == k && p.adaptive.is_none())
                .collect()
        };
        let base = series(SamplerKind::Independent);
        let time_mse = |v: &[&Point]| -> Vec<(f64, f64)> {
            let mut xy: Vec<(f64, f64)> = v.iter().map(|p| (p.seconds, p.errors.mse)).collect();
            xy.sort_by(|a, b| a.0.total_cmp(&b.0));
            xy
        };
        let base_tm = time_mse(&base);
        let mut base_mt: Vec<(f64, f64)> = base_tm.iter().map(|&(t, m)| (m, t)).collect();
        base_mt.sort_by(|a, b| a.0.total_cmp(&b.0));
        for k in dedup(
            points
                .iter()
                .filter(|p| p.adaptive.is_none())
                .map(|p| p.sampler),
        ) {
            let v = series(k);
            if v.is_empty() {
                continue;
            }
            let slope = log_log_slope(
                &v.iter()
                    .map(|p| (p.spp as f64, p.errors.mse))
                    .collect::<Vec<_>>(),
            );
            let _ = write!(s, "width {w} {:<11} MSE ∝ spp^{slope:.2}", k.name());
            if k != SamplerKind::Independent && !base.is_empty() {
                // At each of this sampler's points: how much lower its MSE is than the
                // independent sampler's at the same time, and how much less time it takes
                // for the same MSE (where the independent curve covers that time / MSE).
                let mse_gain: Vec<f64> = v
                    .iter()
                    .filter_map(|p| {
                        interpolate_log(&base_tm, p.seconds).map(|l| l.exp() / p.errors.mse)
                    })
                    .collect();
                let time_gain: Vec<f64> = v
                    .iter()
                    .filter_map(|p| {
                        interpolate_log(&base_mt, p.errors.mse).map(|l| l.exp() / p.seconds)
                    })
                    .collect();
                let range = |g: &[f64]| gains(g, "n/a");
                let _ = write!(
                    s,
                    "; vs independent: MSE lower at equal time {}, time shorter at equal MSE {}",
                    range(&mse_gain),
                    range(&time_gain)
                );
            }
            s.push('\n');
        }
        let adaptive_samplers = dedup(
            points
                .iter()
                .filter(|p| p.packet_width == w && p.adaptive.is_some())
                .map(|p| p.sampler),
        );
        for k in adaptive_samplers {
            let v: Vec<&Point> = points
                .iter()
                .filter(|p| p.packet_width == w && p.sampler == k && p.adaptive.is_some())
                .collect();
            adaptive_summary(&mut s, w, k, &v, &series);
        }
    }
    s
}

/// The lines of an adaptive series: per target the true and estimated relative RMSE and
/// their ratio, and against uniform series the time to the same relMSE.
fn adaptive_summary<'a>(
    s: &mut String,
    w: PacketWidth,
    k: SamplerKind,
    v: &[&'a Point],
    uniform: &dyn Fn(SamplerKind) -> Vec<&'a Point>,
) {
    let _ = write!(s, "width {w} {} ", series_name(k, true));
    let mut ratios = Vec::new();
    for p in v {
        let a = p.adaptive.expect("an adaptive point");
        let ratio = a.estimate / p.rel_rmse();
        ratios.push(ratio);
        let _ = write!(
            s,
            "| target {:.2}%: true {:.3}%, estimate {:.3}% ({:.2}x), {:.1} spp ",
            a.target * 100.0,
            p.rel_rmse() * 100.0,
            a.estimate * 100.0,
            ratio,
            a.spp_mean
        );
    }
    s.push('\n');
    for base in [SamplerKind::Independent, k] {
        let u = uniform(base);
        if u.is_empty() {
            continue;
        }
        // The uniform series' seconds and rays at each adaptive point's relMSE, over the
        // adaptive point's: how much sooner, and with how much less work.
        let at_error = |f: fn(&Point) -> f64| -> Vec<Option<f64>> {
            let mut xy: Vec<(f64, f64)> = u.iter().map(|p| (p.errors.rel_mse, f(p))).collect();
            xy.sort_by(|a, b| a.0.total_cmp(&b.0));
            v.iter()
                .map(|p| interpolate_log(&xy, p.errors.rel_mse).map(|l| l.exp() / f(p)))
                .collect()
        };
        let times = at_error(|p| p.seconds);
        let rays = at_error(|p| p.rays as f64);
        let per_target: Vec<String> = v
            .iter()
            .zip(times.iter().zip(&rays))
            .filter_map(|(p, (t, r))| {
                Some(format!(
                    "{:.2}%: {:.2}x, rays {:.2}x",
                    p.adaptive?.target * 100.0,
                    (*t)?,
                    (*r)?
                ))
            })
            .collect();
        let _ = writeln!(
            s,
            "width {w} {} vs uniform {}: time shorter at equal relMSE {}; rays fewer {} [{}]",
            series_name(k, true),
            base.name(),
            gain_range(&times.iter().flatten().copied().collect::<Vec<_>>()),
            gain_range(&rays.iter().flatten().copied().collect::<Vec<_>>()),
            per_target.join("; ")
        );
    }
}

/// Against the independent sampler at the scene's own samples a pixel: its relMSE and
/// time (interpolated between the sweep's points), and how much sooner each adaptive
/// series reaches that relMSE; with the samples a pixel each series takes for it
/// (uniform Sobol, and the adaptive series' mean, at least `FIRST_PASS_SPP`), which bound
/// how much sooner any run can be.
pub(super) fn own_settings(points: &[Point], own_spp: u32) -> String {
    let mut s = String::new();
    for w in dedup(points.iter().map(|p| p.packet_width)) {
        let uniform = |k: SamplerKind| -> Vec<&Point> {
            points
                .iter()
                .filter(|p| p.packet_width == w && p.sampler == k && p.adaptive.is_none())
                .collect()
        };
        let base = uniform(SamplerKind::Independent);
        let at = |f: fn(&Point) -> f64| {
            let xy: Vec<(f64, f64)> = base.iter().map(|p| (p.spp as f64, f(p))).collect();
            interpolate_log(&xy, own_spp as f64).map(f64::exp)
        };
        let (Some(error), Some(time)) = (at(|p| p.errors.rel_mse), at(|p| p.seconds)) else {
            continue;
        };
        // The samples a pixel a series takes to that relMSE, where it reaches it.
        let spp_at = |curve: Vec<(f64, f64)>| {
            let mut curve = curve;
            curve.sort_by(|a, b| a.0.total_cmp(&b.0));
            interpolate_log(&curve, error).map(f64::exp)
        };
        let sobol_spp = spp_at(
            uniform(SamplerKind::Sobol)
                .iter()
                .map(|p| (p.errors.rel_mse, p.spp as f64))
                .collect(),
        );
        for k in dedup(
            points
                .iter()
                .filter(|p| p.packet_width == w && p.adaptive.is_some())
                .map(|p| p.sampler),
        ) {
            let series: Vec<&Point> = points
                .iter()
                .filter(|p| p.packet_width == w && p.sampler == k && p.adaptive.is_some())
                .collect();
            let mut curve: Vec<(f64, f64)> = series
                .iter()
                .map(|p| (p.errors.rel_mse, p.seconds))
                .collect();
            curve.sort_by(|a, b| a.0.total_cmp(&b.0));
            let sooner = match interpolate_log(&curve, error) {
                Some(t) => format!("{:.1}x sooner", time / t.exp()),
                // Every adaptive point has less error: its fastest is an upper bound.
                None if curve.last().is_some_and(|&(e, _)| e < error) => format!(
                    "at least {:.1}x sooner (its loosest target is below that error)",
                    time / curve.iter().map(|c| c.1).fold(f64::INFINITY, f64::min)
                ),
                None => "not within the sweep's targets".to_string(),
            };
            let adaptive_spp = spp_at(
                series
                    .iter()
                    .filter_map(|p| Some((p.errors.rel_mse, p.adaptive?.spp_mean)))
                    .collect(),
            );
            let spp = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.1}"));
            let _ = writeln!(
                s,
                "width {w} independent at the scene's own {own_spp} spp: relative RMSE {:.3}% in {:.4} s; {} reaches it {sooner}; spp for that error: uniform sobol {}, {} {} (at least {})",
                error.sqrt() * 100.0,
                time,
                series_name(k, true),
                spp(sobol_spp),
                series_name(k, true),
                spp(adaptive_spp),
                raytracer::FIRST_PASS_SPP
            );
        }
    }
    s
}

/// A list of ratios as its median and range.
fn gain_range(g: &[f64]) -> String {
    gains(g, "n/a (no overlap)")
}

/// The median of the gains `g`, their range and their number; `none` without any.
fn gains(g: &[f64], none: &str) -> String {
    if g.is_empty() {
        return none.to_string();
    }
    let mut g = g.to_vec();
    g.sort_by(f64::total_cmp);
    format!(
        "median {:.2}x (range {:.2}–{:.2}, {} points)",
        median(&g),
        g[0],
        g[g.len() - 1],
        g.len()
    )
}

pub(super) fn dedup<T: PartialEq + Copy>(it: impl Iterator<Item = T>) -> Vec<T> {
    let mut v = Vec::new();
    for x in it {
        if !v.contains(&x) {
            v.push(x);
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolation_in_log_space() {
        let xy = [(1.0, 1.0), (100.0, 0.01)];
        assert!((interpolate_log(&xy, 10.0).unwrap().exp() - 0.1).abs() < 1e-12);
        assert_eq!(interpolate_log(&xy, 1000.0), None);
    }
}
