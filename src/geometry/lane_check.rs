//! Lane kernels against their scalar selves: a kernel written once over `Lane` must give,
//! on every lane at widths 4, 8 and 16, the bits it gives at `f32` on that lane's inputs. The
//! geometry kernels' tests and the integrator's shading kernels' tests share it.

use crate::lanes::{F32x16, Lane, V3};
use glam::Vec4;
use wide::f32x8;

/// A kernel over lanes, with `IN` lane inputs and its outputs as lanes.
pub(crate) trait Kernel {
    const IN: usize;
    fn eval<L: Lane>(x: &[L]) -> Vec<L>;
}

/// `IN` × 8·`chunks` inputs: mostly uniform in [−2, 2), one in four an edge value
/// (±0, ±1, a subnormal, huge, ±∞, NaN), so selects and special cases are hit.
fn inputs(n_in: usize, chunks: usize) -> Vec<Vec<f32>> {
    let edges = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        1e-40,
        -1e-40,
        1e30,
        -1e30,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        f32::MIN_POSITIVE,
    ];
    let mut state = 0x9e37_79b9u32;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state
    };
    (0..n_in)
        .map(|_| {
            (0..8 * chunks)
                .map(|_| {
                    let r = next();
                    if r % 4 == 0 {
                        edges[(r >> 8) as usize % edges.len()]
                    } else {
                        (r >> 8) as f32 / (1 << 24) as f32 * 4.0 - 2.0
                    }
                })
                .collect()
        })
        .collect()
}

/// Every output lane of `K` at widths 4, 8 and 16 has the bits of the scalar kernel on
/// that lane's inputs (any NaN matching any NaN).
pub(crate) fn check<K: Kernel>(name: &str) {
    let chunks = 2000;
    let x = inputs(K::IN, chunks);
    let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
    for c in 0..chunks {
        let at = |i: usize| -> Vec<f32> { x.iter().map(|v| v[8 * c + i]).collect() };
        let scalar: Vec<Vec<f32>> = (0..8).map(|i| K::eval::<f32>(&at(i))).collect();
        let eight = K::eval::<f32x8>(
            &x.iter()
                .map(|v| f32x8::from_fn(|i| v[8 * c + i]))
                .collect::<Vec<_>>(),
        );
        for half in 0..2 {
            let four = K::eval::<Vec4>(
                &x.iter()
                    .map(|v| <Vec4 as Lane>::from_fn(|i| v[8 * c + 4 * half + i]))
                    .collect::<Vec<_>>(),
            );
            for (o, (w4, w8)) in four.iter().zip(&eight).enumerate() {
                for i in 0..4 {
                    let k = 4 * half + i;
                    let want = scalar[k][o];
                    assert!(
                        same(w4.lane(i), want) && same(w8.lane(k), want),
                        "{name}: output {o}, lane {k}, inputs {:?}: scalar {want:e}, \
                         4 wide {:e}, 8 wide {:e}",
                        at(k),
                        w4.lane(i),
                        w8.lane(k),
                    );
                }
            }
        }
    }
    for c in 0..chunks / 2 {
        let at = |i: usize| -> Vec<f32> { x.iter().map(|v| v[16 * c + i]).collect() };
        let sixteen = K::eval::<F32x16>(
            &x.iter()
                .map(|v| F32x16::from_fn(|i| v[16 * c + i]))
                .collect::<Vec<_>>(),
        );
        for k in 0..16 {
            let scalar = K::eval::<f32>(&at(k));
            for (o, (w16, want)) in sixteen.iter().zip(scalar).enumerate() {
                assert!(
                    same(w16.lane(k), want),
                    "{name}: output {o}, lane {k}, inputs {:?}: scalar {want:e}, 16 wide {:e}",
                    at(k),
                    w16.lane(k),
                );
            }
        }
    }
}

pub(crate) fn v3<L: Lane>(x: &[L]) -> V3<L> {
    V3::new(x[0], x[1], x[2])
}

pub(crate) fn out<L: Lane>(vs: &[V3<L>]) -> Vec<L> {
    vs.iter().flat_map(|v| [v.x, v.y, v.z]).collect()
}
