//! How many lane operations a second this CPU runs at each packet width: independent
//! chains (`CHAINS`) of one `Lane` operation (multiply-add as a multiply then an add,
//! as the renderer computes; a division; a square root) at 1, 4, 8 and 16 lanes, one
//! thread, the best of five passes. Wider lanes pay in arithmetic only where a wider
//! register runs as many instructions a second: where a 16-lane operation runs at half
//! the rate of an 8-lane one (a CPU that executes 512-bit operations as two 256-bit
//! halves), sixteen lanes gain only in the work that is not lane arithmetic (the
//! traversal's and the shading's decisions, masks, loads and loops).
//!
//! ```sh
//! cargo run --release --example lane_rate            # the build for this CPU
//! taskset -c 1 target/release/examples/lane_rate     # pinned, on a quiet core
//! ```
use raytracer::lanes::{F32x16, Lane, AVX512, COMPILED};
use std::hint::black_box;
use std::time::Instant;
use wide::f32x8;

/// Independent chains a pass: enough to hide each operation's latency in the registers
/// there are (32 vector registers with AVX-512, 16 without).
const CHAINS: usize = if AVX512 { 24 } else { 12 };

/// The operations timed, each `x ↦ op(x)` with constants that keep the chains finite.
#[derive(Clone, Copy)]
enum Op {
    MulAdd,
    Div,
    Sqrt,
}

impl Op {
    fn name(self) -> &'static str {
        match self {
            Op::MulAdd => "multiply, add",
            Op::Div => "divide",
            Op::Sqrt => "square root",
        }
    }

    /// Steps a pass: fewer for the slow operations, so that each pass takes about as long.
    fn steps(self) -> usize {
        match self {
            Op::MulAdd => 20_000_000,
            Op::Div | Op::Sqrt => 2_000_000,
        }
    }

    #[inline(always)]
    fn apply<L: Lane>(self, x: L, m: L, c: L) -> L {
        match self {
            Op::MulAdd => x * m + c,
            Op::Div => x / m,
            Op::Sqrt => x.sqrt() + c,
        }
    }
}

/// Lane operations a second (10⁹) of `op` at `L`'s width: the best of five passes of
/// `CHAINS` chains of `op.steps()` steps (a multiply and an add count as two; a square
/// root counts as one, the add that keeps its chain in range not at all).
fn rate<L: Lane>(op: Op) -> f64 {
    let (m, c) = (
        black_box(L::splat(0.999_999)),
        black_box(L::splat(match op {
            Op::MulAdd => 1e-7,
            _ => 0.5,
        })),
    );
    let steps = op.steps();
    let per_step = match op {
        Op::MulAdd => 2.0,
        Op::Div | Op::Sqrt => 1.0,
    };
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let mut x: [L; CHAINS] = std::array::from_fn(|i| L::splat(1.0 + i as f32 * 0.01));
        x = black_box(x);
        let start = Instant::now();
        for _ in 0..steps {
            for v in x.iter_mut() {
                *v = op.apply(*v, m, c);
            }
        }
        let seconds = start.elapsed().as_secs_f64();
        black_box(x);
        best = best.min(seconds);
    }
    (CHAINS * steps * L::WIDTH) as f64 * per_step / best / 1e9
}

fn main() {
    println!("lanes compiled as: {COMPILED}");
    println!("| operation | 1 lane | 4 lanes | 8 lanes | 16 lanes | 16 over 8 |");
    println!("|---|---|---|---|---|---|");
    for op in [Op::MulAdd, Op::Div, Op::Sqrt] {
        let r = [
            rate::<f32>(op),
            rate::<glam::Vec4>(op),
            rate::<f32x8>(op),
            rate::<F32x16>(op),
        ];
        println!(
            "| {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2}x |",
            op.name(),
            r[0],
            r[1],
            r[2],
            r[3],
            r[3] / r[2]
        );
    }
    println!("(10⁹ lane operations a second, one thread, best of five passes)");
}
