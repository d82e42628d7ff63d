//! Compare two EXR renders (linear f32) pixel by pixel: how many pixels differ in any
//! channel's bits, and by how much.
//!
//! ```sh
//! cargo run --release --example exr_diff -- before.exr after.exr
//! ```

use raytracer::output::read_exr;
use std::path::Path;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [a, b] = args.as_slice() else {
        eprintln!("usage: exr_diff A.exr B.exr");
        std::process::exit(2);
    };
    let read = |p: &str| {
        read_exr(Path::new(p)).unwrap_or_else(|e| {
            eprintln!("exr_diff: {e}");
            std::process::exit(2);
        })
    };
    let (a, b) = (read(a), read(b));
    if (a.width, a.height) != (b.width, b.height) {
        eprintln!(
            "exr_diff: the sizes differ: {}x{} and {}x{}",
            a.width, a.height, b.width, b.height
        );
        std::process::exit(2);
    }
    let (mut changed, mut max, mut sum, mut max_at) = (0usize, 0.0f32, 0.0f64, (0, 0));
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        let same = (0..3).all(|c| p[c].to_bits() == q[c].to_bits());
        if same {
            continue;
        }
        changed += 1;
        let d = (*p - *q).abs().max_element();
        sum += d as f64;
        if d > max {
            max = d;
            max_at = (i as u32 % a.width, i as u32 / a.width);
        }
    }
    let n = a.pixels.len();
    let mean_all: f64 = a.pixels.iter().map(|p| p.max_element() as f64).sum::<f64>() / n as f64;
    println!(
        "{changed} of {n} pixels differ; largest channel difference {max:e} at {max_at:?}; \
         mean over differing pixels {:e}; mean pixel max channel {mean_all:.4}",
        if changed > 0 {
            sum / changed as f64
        } else {
            0.0
        }
    );
}
