//! Error of a render against a reference, on linear values (`docs/performance.md`,
//! "Error against time").
//!
//! Every metric averages over all pixels and the three channels, in f64.
//! - **MSE / RMSE**: mean of (a − b)², and its square root.
//! - **relMSE**: mean of (a − b)² / (b² + ε) with ε = [`REL_MSE_EPSILON`] = 0.01, b the
//!   reference: a squared error relative to the reference's brightness, so dark and bright
//!   regions weigh alike; ε keeps black reference pixels from dividing by zero (Rousselle
//!   et al. 2011 use the same form).
//! - **PSNR**: 10·log10(1 / MSE) on values clamped to [0, 1] first (peak 1), in dB;
//!   infinite for identical images.

use crate::film::Film;
use glam::Vec3;

/// The ε of relMSE's denominator b² + ε.
pub const REL_MSE_EPSILON: f64 = 0.01;

/// The error of one image against a reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Errors {
    pub mse: f64,
    pub rmse: f64,
    pub rel_mse: f64,
    pub psnr: f64,
}

fn channels(p: &[Vec3]) -> impl Iterator<Item = f64> + '_ {
    p.iter().flat_map(|v| v.to_array()).map(f64::from)
}

fn mean_of(a: &[Vec3], b: &[Vec3], f: impl Fn(f64, f64) -> f64) -> f64 {
    assert_eq!(a.len(), b.len(), "images of different sizes");
    let n = 3 * a.len();
    if n == 0 {
        return 0.0;
    }
    channels(a)
        .zip(channels(b))
        .map(|(x, y)| f(x, y))
        .sum::<f64>()
        / n as f64
}

/// Mean squared error over pixels and channels.
pub fn mse(a: &[Vec3], reference: &[Vec3]) -> f64 {
    mean_of(a, reference, |x, y| (x - y) * (x - y))
}

pub fn rmse(a: &[Vec3], reference: &[Vec3]) -> f64 {
    mse(a, reference).sqrt()
}

/// Mean of (a − b)² / (b² + 0.01), b the reference.
pub fn rel_mse(a: &[Vec3], reference: &[Vec3]) -> f64 {
    mean_of(a, reference, |x, y| {
        (x - y) * (x - y) / (y * y + REL_MSE_EPSILON)
    })
}

/// PSNR in dB of the images clamped to [0, 1], peak 1.
pub fn psnr(a: &[Vec3], reference: &[Vec3]) -> f64 {
    let clamp = |x: f64| if x > 0.0 { x.min(1.0) } else { 0.0 }; // NaN → 0
    let m = mean_of(a, reference, |x, y| {
        let d = clamp(x) - clamp(y);
        d * d
    });
    -10.0 * m.log10()
}

/// All metrics of `image` against `reference` (same size, else a panic).
pub fn errors(image: &Film, reference: &Film) -> Errors {
    assert_eq!(
        (image.width, image.height),
        (reference.width, reference.height),
        "image and reference differ in size"
    );
    let mse = mse(&image.pixels, &reference.pixels);
    Errors {
        mse,
        rmse: mse.sqrt(),
        rel_mse: rel_mse(&image.pixels, &reference.pixels),
        psnr: psnr(&image.pixels, &reference.pixels),
    }
}

/// Least-squares slope of ln y against ln x.
pub fn log_log_slope(xy: &[(f64, f64)]) -> f64 {
    let n = xy.len() as f64;
    let (lx, ly): (Vec<f64>, Vec<f64>) = xy.iter().map(|&(x, y)| (x.ln(), y.ln())).unzip();
    let mx = lx.iter().sum::<f64>() / n;
    let my = ly.iter().sum::<f64>() / n;
    let sxy: f64 = lx.iter().zip(&ly).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = lx.iter().map(|x| (x - mx) * (x - mx)).sum();
    sxy / sxx
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * b.abs().max(1.0)
    }

    #[test]
    fn identical_images() {
        let a = vec![Vec3::new(0.2, 3.0, 0.0); 4];
        assert_eq!(mse(&a, &a), 0.0);
        assert_eq!(rel_mse(&a, &a), 0.0);
        assert_eq!(psnr(&a, &a), f64::INFINITY);
    }

    #[test]
    fn constant_offset() {
        // Every channel off by 0.5: MSE 0.25, RMSE 0.5.
        let b = vec![Vec3::splat(0.25); 6];
        let a = vec![Vec3::splat(0.75); 6];
        assert!(close(mse(&a, &b), 0.25));
        assert!(close(rmse(&a, &b), 0.5));
        // relMSE = 0.25 / (0.0625 + 0.01) = 0.25 / 0.0725.
        assert!(close(rel_mse(&a, &b), 0.25 / 0.0725));
        // PSNR = 10 log10(1 / 0.25) = 20 log10(2).
        assert!(close(psnr(&a, &b), 20.0 * 2f64.log10()));
    }

    #[test]
    fn per_channel_mean() {
        // One pixel, errors (1, 0, 0) against a black reference: MSE 1/3,
        // relMSE (1/0.01)/3 = 100/3 (ε is what a black reference divides by).
        let a = [Vec3::new(1.0, 0.0, 0.0)];
        let b = [Vec3::ZERO];
        assert!(close(mse(&a, &b), 1.0 / 3.0));
        assert!(close(rel_mse(&a, &b), 100.0 / 3.0));
        assert!(close(psnr(&a, &b), 10.0 * 3f64.log10()));
    }

    #[test]
    fn rel_mse_is_relative_to_the_reference() {
        // The same absolute error weighs 100 times less on a reference of 10 than on 1
        // (up to ε): (0.1)² / (100 + 0.01) against (0.1)² / (1 + 0.01).
        let (a1, b1) = ([Vec3::splat(1.1)], [Vec3::splat(1.0)]);
        let (a10, b10) = ([Vec3::splat(10.1)], [Vec3::splat(10.0)]);
        let d1 = 1.1f32 as f64 - 1.0;
        let d10 = 10.1f32 as f64 - 10.0;
        assert!(close(rel_mse(&a1, &b1), d1 * d1 / 1.01));
        assert!(close(rel_mse(&a10, &b10), d10 * d10 / 100.01));
    }

    #[test]
    fn psnr_clamps_to_the_unit_range() {
        // 5 and 2 both clamp to 1; −1 clamps to 0: the only error is 1 − 0.5 in one of
        // three channels → MSE 0.25 / 3.
        let a = [Vec3::new(5.0, -1.0, 1.0)];
        let b = [Vec3::new(2.0, 0.0, 0.5)];
        assert!(close(psnr(&a, &b), 10.0 * (3.0f64 / 0.25).log10()));
        // RMSE does not clamp.
        assert!(close(mse(&a, &b), (9.0 + 1.0 + 0.25) / 3.0));
    }

    #[test]
    fn film_errors_agree_with_the_functions() {
        let f = |v: f32| Film {
            width: 2,
            height: 1,
            pixels: vec![Vec3::splat(v), Vec3::new(v, 0.0, 1.0)],
        };
        let e = errors(&f(0.5), &f(0.25));
        assert!(close(e.mse, (3.0 + 1.0) * 0.0625 / 6.0));
        assert!(close(e.rmse, e.mse.sqrt()));
        assert!(close(e.rel_mse, 4.0 * 0.0625 / 0.0725 / 6.0));
        assert!(close(e.psnr, -10.0 * e.mse.log10()));
    }

    #[test]
    fn slope_of_a_power_law() {
        let xy: Vec<(f64, f64)> = (0..6)
            .map(|i| (2f64.powi(i), 3.0 * 2f64.powi(i).powf(-1.5)))
            .collect();
        assert!((log_log_slope(&xy) + 1.5).abs() < 1e-12);
    }
}
