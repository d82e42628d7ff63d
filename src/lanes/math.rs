//! Transcendental functions over lanes: `pow` (Phong's specular term) and `sin_cos_turns`
//! (the azimuth of a random unit vector).
//!
//! Each is made of scalar `f64` kernels of `+ − × ÷` and bit manipulation only, run on
//! every lane (`pow` picks one of two by each lane's exponent). IEEE 754 rounds those
//! operations exactly, so the result does not depend on the width, and the compiler
//! vectorises the lane loop (no libm call, no branch).
//! Working in `f64` makes the `f32` results correctly rounded but for values within about
//! 1e-12 of a rounding boundary: the tests bound the error at one ulp against `f64`
//! references and count how often it is not zero.

use super::{Lane, Mask};
use std::ops::{Add, BitAnd, BitOr, Div, Mul, Shl, Shr, Sub};
use wide::{f64x4, u64x4};

/// `x` raised to `n`, lane by lane, for `x ≥ 0` (`+0` included) and finite `n ≥ 0`: what
/// `powf` gives there, within one ulp (`+0⁰` is 1, `+0ⁿ` is +0, `1ⁿ` is exactly 1, and
/// results below half the smallest subnormal are +0).
///
/// A lane's exponent picks its kernel, so a lane's result depends on its `(x, n)` alone,
/// at any width: an integer `n` up to `SQUARING_MAX` (every shininess of the built-in
/// scenes) by repeated squaring in f64 (`PowInt`: at most 2·16 multiplies, against the
/// logarithm's division and two series), any other by 2^(n·log₂ x) (`Pow`). When every
/// lane has the same integer exponent (a packet on one material), its bits are read
/// once, outside the lanes.
#[inline(always)]
pub fn pow<L: Lane>(x: L, n: L) -> L {
    let all = (1u32 << L::WIDTH) - 1;
    let n0 = n.lane(0);
    if is_squared(n0) && (L::WIDTH == 1 || n.eq(L::splat(n0)).bits() == all) {
        return L::map_f64(&PowInt { n: n0 as u32 }, x, n).0;
    }
    pow_mixed(x, n)
}

/// `pow` of lanes whose exponents differ, or are not all integers up to `SQUARING_MAX`:
/// each lane by its own kernel.
#[inline(never)]
fn pow_mixed<L: Lane>(x: L, n: L) -> L {
    let squared =
        L::Mask::from_bits((0..L::WIDTH).fold(0, |m, k| m | (is_squared(n.lane(k)) as u32) << k));
    let general = L::map_f64(&Pow, x, n).0;
    if squared.bits() == 0 {
        return general;
    }
    let by_squaring = L::map_f64(&PowIntLanes, x, n).0;
    L::select(squared, by_squaring, general)
}

/// The largest exponent `pow` raises to by repeated squaring.
pub const SQUARING_MAX: u32 = 65_535;
/// The bits of an exponent up to `SQUARING_MAX` (`PowIntLanes` reads each).
const SQUARING_BITS: u32 = u32::BITS - SQUARING_MAX.leading_zeros();

/// Whether `pow` raises to `n` by repeated squaring: an integer in [0, SQUARING_MAX].
#[inline(always)]
fn is_squared(n: f32) -> bool {
    (0.0..=SQUARING_MAX as f32).contains(&n) && n == (n as u32) as f32
}

/// `(sin 2πu, cos 2πu)`, lane by lane, for any finite `u` (turns: 1 is a full circle),
/// within one ulp of the exact values.
#[inline(always)]
pub fn sin_cos_turns<L: Lane>(u: L) -> (L, L) {
    L::map_f64(&SinCosTurns, u, u)
}

/// A kernel of two `f64` inputs and two outputs, generic over the lanes it runs on
/// (`Lane::map_f64` runs it on each width's lanes widened to f64).
pub trait F64Kernel {
    fn eval<D: F64Lanes>(&self, a: D, b: D) -> (D, D);
    /// `eval` of two sets of lanes (the halves of eight), which a kernel with a loop of
    /// its own runs in one loop.
    #[inline(always)]
    fn eval2<D: F64Lanes>(&self, a: [D; 2], b: [D; 2]) -> [(D, D); 2] {
        [self.eval(a[0], b[0]), self.eval(a[1], b[1])]
    }
}

/// Lanes of f64: `f64` (one) and `wide::f64x4` (four), with the operations the kernels
/// use, each exactly rounded by IEEE 754 or exact.
pub trait F64Lanes:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self>
{
    type Bits: Copy
        + Add<Output = Self::Bits>
        + BitAnd<Output = Self::Bits>
        + BitOr<Output = Self::Bits>
        + Shl<u32, Output = Self::Bits>
        + Shr<u32, Output = Self::Bits>;
    fn splat(x: f64) -> Self;
    fn splat_bits(x: u64) -> Self::Bits;
    fn to_bits(self) -> Self::Bits;
    fn from_bits(b: Self::Bits) -> Self;
    /// `if self > o { a } else { b }` per lane (a NaN gives `b`).
    fn gt_select(self, o: Self, a: Self, b: Self) -> Self;
    /// `if self == o { a } else { b }` per lane.
    fn eq_select(self, o: Self, a: Self, b: Self) -> Self;
}

impl F64Lanes for f64 {
    type Bits = u64;
    #[inline(always)]
    fn splat(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn splat_bits(x: u64) -> u64 {
        x
    }
    #[inline(always)]
    fn to_bits(self) -> u64 {
        f64::to_bits(self)
    }
    #[inline(always)]
    fn from_bits(b: u64) -> Self {
        f64::from_bits(b)
    }
    #[inline(always)]
    fn gt_select(self, o: Self, a: Self, b: Self) -> Self {
        if self > o {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn eq_select(self, o: Self, a: Self, b: Self) -> Self {
        if self == o {
            a
        } else {
            b
        }
    }
}

impl F64Lanes for f64x4 {
    type Bits = u64x4;
    #[inline(always)]
    fn splat(x: f64) -> Self {
        f64x4::splat(x)
    }
    #[inline(always)]
    fn splat_bits(x: u64) -> u64x4 {
        u64x4::splat(x)
    }
    #[inline(always)]
    fn to_bits(self) -> u64x4 {
        bytemuck::cast(self)
    }
    #[inline(always)]
    fn from_bits(b: u64x4) -> Self {
        bytemuck::cast(b)
    }
    #[inline(always)]
    fn gt_select(self, o: Self, a: Self, b: Self) -> Self {
        use wide::CmpGt;
        self.cmp_gt(o).blend(a, b)
    }
    #[inline(always)]
    fn eq_select(self, o: Self, a: Self, b: Self) -> Self {
        use wide::CmpEq;
        self.cmp_eq(o).blend(a, b)
    }
}

/// 1.5 · 2⁵²: adding it rounds an f64 of magnitude below 2⁵¹ to an integer (to nearest,
/// ties to even), which its low mantissa bits then hold in two's complement.
const ROUND: f64 = 6_755_399_441_055_744.0;
/// 2⁵²: the bits of 2⁵² + k, for an integer 0 ≤ k < 2⁵², are those of 2⁵² with k added.
const TWO_52: f64 = 4_503_599_627_370_496.0;

/// The small integer held in the low bits `k` (below 2⁵²), as an f64: exact.
#[inline(always)]
fn int_to_f64<D: F64Lanes>(k: D::Bits) -> D {
    D::from_bits(k | D::splat_bits(TWO_52.to_bits())) - D::splat(TWO_52)
}

/// log₂(x) for x > 0 (finite), and −∞ for ±0.
///
/// x = 2ᵉ·m with m in [√½, √2), and ln m = 2·atanh(s) = 2(s + s³/3 + s⁵/5 + …) with
/// s = (m − 1)/(m + 1), |s| ≤ 0.1716: the series to s¹⁵ leaves a relative error under
/// s¹⁶/17 < 4e-14.
#[inline(always)]
fn log2_f64<D: F64Lanes>(x: D) -> D {
    let bits = x.to_bits();
    let biased: D = int_to_f64(bits >> 52);
    let m = D::from_bits(
        (bits & D::splat_bits(0x000f_ffff_ffff_ffff)) | D::splat_bits(0x3ff0_0000_0000_0000),
    );
    let sqrt2 = D::splat(std::f64::consts::SQRT_2);
    let big = |a: D, b: D| m.gt_select(sqrt2, a, b);
    let m = big(m * D::splat(0.5), m);
    let e = biased - big(D::splat(1022.0), D::splat(1023.0));
    let one = D::splat(1.0);
    let s = (m - one) / (m + one);
    let p = estrin(s * s, &LOG_SERIES);
    let log = e + D::splat(2.0 * std::f64::consts::LOG2_E) * s * p;
    x.eq_select(D::splat(0.0), D::splat(f64::NEG_INFINITY), log)
}

/// 1 / (2j + 1), j = 0 to 7: the series of atanh(s) / s in s².
const LOG_SERIES: [f64; 8] = {
    let mut c = [1.0f64; 8];
    let mut j = 1;
    while j < 8 {
        c[j] = 1.0 / (2 * j + 1) as f64;
        j += 1;
    }
    c
};

/// Σ c[j]·zʲ by Estrin's scheme: neighbouring terms paired, c[2j] + c[2j+1]·z, then the
/// pairs paired with z², and so on. The same operations as Horner's rule but in a tree
/// of depth log₂ N instead of a chain of N steps, so one lane's polynomial (the scalar
/// tracer's `pow`) does not wait on a multiply-add latency per coefficient. Only `+`
/// and `×`, in a fixed order: the same bits at every width.
#[inline(always)]
fn estrin<D: F64Lanes, const N: usize>(z: D, c: &[f64; N]) -> D {
    let mut t = [D::splat(0.0); N];
    let mut n = N;
    for (j, tj) in t.iter_mut().enumerate().take(N.div_ceil(2)) {
        *tj = if 2 * j + 1 < N {
            D::splat(c[2 * j]) + D::splat(c[2 * j + 1]) * z
        } else {
            D::splat(c[2 * j])
        };
    }
    n = n.div_ceil(2);
    let mut zz = z * z;
    while n > 1 {
        for j in 0..n.div_ceil(2) {
            t[j] = if 2 * j + 1 < n {
                t[2 * j] + t[2 * j + 1] * zz
            } else {
                t[2 * j]
            };
        }
        n = n.div_ceil(2);
        if n > 1 {
            zz = zz * zz;
        }
    }
    t[0]
}

/// (ln 2)ʲ / j!, j = 0 to 11: the Taylor coefficients of 2ᶠ = e^(f ln 2).
const EXP2_TAYLOR: [f64; 12] = {
    let mut c = [1.0f64; 12];
    let mut j = 1;
    while j < 12 {
        c[j] = c[j - 1] * std::f64::consts::LN_2 / j as f64;
        j += 1;
    }
    c
};

/// (−1)ʲ / (2j + 1)!, j = 0 to 7: sin θ = θ · Σ sⱼ θ²ʲ.
const SIN_TAYLOR: [f64; 8] = {
    let mut s = [1.0f64; 8];
    let mut j = 1;
    while j < 8 {
        s[j] = -s[j - 1] / ((2 * j) as f64 * (2 * j + 1) as f64);
        j += 1;
    }
    s
};

/// (−1)ʲ / (2j)!, j = 0 to 8: cos θ = Σ cⱼ θ²ʲ.
const COS_TAYLOR: [f64; 9] = {
    let mut c = [1.0f64; 9];
    let mut j = 1;
    while j < 9 {
        c[j] = -c[j - 1] / ((2 * j - 1) as f64 * (2 * j) as f64);
        j += 1;
    }
    c
};

/// 2ʸ for y in [−200, 200] (clamped there first: 2⁻²⁰⁰ rounds to +0 in f32 and 2²⁰⁰
/// to +∞; a NaN becomes −200). y = k + f with k an integer and |f| ≤ ½; 2ᶠ = e^(f ln 2)
/// by its Taylor series to degree 11 (relative error under 7e-15); 2ᵏ from its bits.
#[inline(always)]
fn exp2_f64<D: F64Lanes>(y: D) -> D {
    let (lo, hi) = (D::splat(-200.0), D::splat(200.0));
    let y = y.gt_select(lo, y, lo);
    let y = hi.gt_select(y, y, hi);
    let t = y + D::splat(ROUND);
    let k = t - D::splat(ROUND);
    let f = y - k;
    let p = estrin(f, &EXP2_TAYLOR);
    // 2ᵏ: k + 1023 in [823, 1223] is the biased exponent (the low bits of t hold k).
    let scale = D::from_bits((t.to_bits() + D::splat_bits(1023)) << 52);
    p * scale
}

/// `pow` in f64: 2^(n · log₂ x), with x⁰ = 1 for every x (0 · −∞ would be a NaN at
/// x = 0).
struct Pow;

impl F64Kernel for Pow {
    #[inline(always)]
    fn eval<D: F64Lanes>(&self, x: D, n: D) -> (D, D) {
        let y = n * log2_f64(x);
        let zero = D::splat(0.0);
        let r = exp2_f64(n.eq_select(zero, zero, y));
        (r, r)
    }
}

/// `pow` for one integer exponent `n ≤ SQUARING_MAX` in every lane: xⁿ as the product of
/// the squarings x^(2ʲ) over the set bits j of n, ascending, from 1 (so x⁰ = 1, 0ⁿ = +0
/// for n ≥ 1, 1ⁿ = 1 exactly). Each product rounds once in f64, at most 2·16 roundings
/// of 2⁻⁵³: far below an f32 ulp but near a tie, as for `Pow`. Beyond f64's range a
/// squaring gives +∞ or +0, and so does the exact power in f32.
struct PowInt {
    n: u32,
}

impl F64Kernel for PowInt {
    #[inline(always)]
    fn eval<D: F64Lanes>(&self, x: D, _: D) -> (D, D) {
        let (mut acc, mut p, mut n) = (D::splat(1.0), x, self.n);
        while n != 0 {
            if n & 1 != 0 {
                acc = acc * p;
            }
            n >>= 1;
            if n != 0 {
                p = p * p;
            }
        }
        (acc, acc)
    }

    /// The same products as `eval`, both halves in one loop over the exponent's bits.
    #[inline(always)]
    fn eval2<D: F64Lanes>(&self, x: [D; 2], _: [D; 2]) -> [(D, D); 2] {
        let (mut acc, mut p, mut n) = ([D::splat(1.0); 2], x, self.n);
        while n != 0 {
            if n & 1 != 0 {
                acc = [acc[0] * p[0], acc[1] * p[1]];
            }
            n >>= 1;
            if n != 0 {
                p = [p[0] * p[0], p[1] * p[1]];
            }
        }
        [(acc[0], acc[0]), (acc[1], acc[1])]
    }
}

/// `PowInt` with each lane's own exponent (an integer up to `SQUARING_MAX`; others give
/// a value `pow` does not use): the same products in the same order, a lane taking the
/// squaring x^(2ʲ) where bit j of its exponent is set.
struct PowIntLanes;

impl F64Kernel for PowIntLanes {
    #[inline(always)]
    fn eval<D: F64Lanes>(&self, x: D, n: D) -> (D, D) {
        let bits = (n + D::splat(TWO_52)).to_bits();
        let one = D::splat_bits(1);
        let half = D::splat(0.5);
        let (mut acc, mut p) = (D::splat(1.0), x);
        for j in 0..SQUARING_BITS {
            let bit: D = int_to_f64((bits >> j) & one);
            acc = bit.gt_select(half, acc * p, acc);
            p = p * p;
        }
        (acc, acc)
    }
}

/// (sin 2πu, cos 2πu) in f64. u = q/4 + r with q an integer and |r| ≤ ⅛, both exact
/// (u comes from an f32: its 24 bits fit beside q's); θ = 2πr in [−π/4, π/4], where the
/// Taylor series of sin to θ¹⁵ and cos to θ¹⁶ err by under 1e-15; the quadrant q mod 4
/// swaps and negates them.
struct SinCosTurns;

impl F64Kernel for SinCosTurns {
    #[inline(always)]
    fn eval<D: F64Lanes>(&self, u: D, _: D) -> (D, D) {
        let t = u * D::splat(4.0) + D::splat(ROUND);
        let q = t - D::splat(ROUND);
        let r = u - q * D::splat(0.25);
        let theta = r * D::splat(std::f64::consts::TAU);
        let th2 = theta * theta;
        let ps = estrin(th2, &SIN_TAYLOR);
        let pc = estrin(th2, &COS_TAYLOR);
        let (sin, cos) = (theta * ps, pc);
        // The quadrant q mod 4 from t's low bits: 0 (sin, cos), 1 (cos, −sin),
        // 2 (−sin, −cos), 3 (−cos, sin).
        let bits = t.to_bits();
        let one = D::splat_bits(1);
        let odd: D = int_to_f64(bits & one);
        let half = D::splat(0.5);
        let (a, b) = (odd.gt_select(half, cos, sin), odd.gt_select(half, sin, cos));
        let sin_negative: D = int_to_f64((bits >> 1) & one);
        let cos_negative: D = int_to_f64(((bits + one) >> 1) & one);
        let sign = |neg: D, v: D| neg.gt_select(half, D::splat(0.0) - v, v);
        (sign(sin_negative, a), sign(cos_negative, b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec4;
    use wide::f32x8;

    /// The distance in f32 ulps between `got` and the exact value `want` (an f64),
    /// where an ulp is that of the f32 nearest to `want` (2⁻¹⁴⁹ among the subnormals).
    fn ulps(got: f32, want: f64) -> f64 {
        let near = want as f32;
        let ulp = if near == 0.0 || near.is_subnormal() {
            f64::from(f32::from_bits(1))
        } else {
            let e = near.abs().to_bits() >> 23;
            f64::from(f32::from_bits(e << 23)) * f64::from(f32::EPSILON)
        };
        (got as f64 - want).abs() / ulp
    }

    /// Every width gives the scalar bits, on chunks of eight inputs (sixteen for 16).
    fn same_at_every_width(xs: &[f32], ns: &[f32]) {
        for (cx, cn) in xs.chunks(16).zip(ns.chunks(16)) {
            let at = |c: &[f32], i: usize| c[i.min(c.len() - 1)];
            let x16 = crate::lanes::F32x16::from_fn(|i| at(cx, i));
            let n16 = crate::lanes::F32x16::from_fn(|i| at(cn, i));
            let p16 = pow(x16, n16);
            let (s16, c16) = sin_cos_turns(x16);
            for k in 0..16 {
                let (x, n) = (at(cx, k), at(cn, k));
                let (s, c) = sin_cos_turns(x);
                assert_eq!(
                    pow(x, n).to_bits(),
                    p16.lane(k).to_bits(),
                    "pow({x:e}, {n:e}) 16"
                );
                assert_eq!(s.to_bits(), s16.lane(k).to_bits(), "sin({x:e}) 16 wide");
                assert_eq!(c.to_bits(), c16.lane(k).to_bits(), "cos({x:e}) 16 wide");
            }
        }
        for (cx, cn) in xs.chunks(8).zip(ns.chunks(8)) {
            let at = |c: &[f32], i: usize| c[i.min(c.len() - 1)];
            let x8 = <f32x8 as Lane>::from_fn(|i| at(cx, i));
            let n8 = <f32x8 as Lane>::from_fn(|i| at(cn, i));
            let p8 = pow(x8, n8);
            let (s8, c8) = sin_cos_turns(x8);
            for h in 0..2 {
                let x4 = <Vec4 as Lane>::from_fn(|i| at(cx, 4 * h + i));
                let n4 = <Vec4 as Lane>::from_fn(|i| at(cn, 4 * h + i));
                let p4 = pow(x4, n4);
                let (s4, c4) = sin_cos_turns(x4);
                for i in 0..4 {
                    let k = 4 * h + i;
                    let (x, n) = (at(cx, k), at(cn, k));
                    let p = pow(x, n).to_bits();
                    assert_eq!(p, p8.lane(k).to_bits(), "pow({x:e}, {n:e}) 8 wide");
                    assert_eq!(p, p4.lane(i).to_bits(), "pow({x:e}, {n:e}) 4 wide");
                    let (s, c) = sin_cos_turns(x);
                    assert_eq!(s.to_bits(), s8.lane(k).to_bits(), "sin({x:e}) 8 wide");
                    assert_eq!(s.to_bits(), s4.lane(i).to_bits(), "sin({x:e}) 4 wide");
                    assert_eq!(c.to_bits(), c8.lane(k).to_bits(), "cos({x:e}) 8 wide");
                    assert_eq!(c.to_bits(), c4.lane(i).to_bits(), "cos({x:e}) 4 wide");
                }
            }
        }
    }

    /// The bases a scene asks for: [0, 1] on a grid, every float in the last binades
    /// below 1 (the highlights of large shininess), subnormals, exact 0 and 1, and the
    /// few floats above 1 that a rounded R·V gives.
    fn bases() -> Vec<f32> {
        let mut xs: Vec<f32> = (0..=20_000).map(|i| i as f32 / 20_000.0).collect();
        let mut x = 1.0f32;
        for _ in 0..4096 {
            x = x.next_down();
            xs.push(x);
        }
        let mut x = 1.0f32;
        for _ in 0..8 {
            x = x.next_up();
            xs.push(x);
        }
        for b in [1u32, 2, 3, 1000, 0x7f_ffff, 0x80_0000, 0x80_0001] {
            xs.push(f32::from_bits(b));
        }
        for e in -126..0 {
            xs.push(2f32.powi(e));
            xs.push(1.5 * 2f32.powi(e));
        }
        xs
    }

    /// Shininess 0 to 10 000: integers, fractions, and 0, 1 and the extremes exactly.
    fn exponents() -> Vec<f32> {
        let mut ns = vec![0.0, 1.0, 0.5, 1e-30, f32::from_bits(1), 10_000.0];
        ns.extend((1..=200).map(|i| i as f32));
        ns.extend((0..100).map(|i| 1.137f32.powi(i) * 0.01));
        ns.extend([500.0, 1000.0, 2500.5, 4096.0, 9999.9]);
        ns
    }

    /// pow is within one ulp of the exact xⁿ (f64 `powf`, correctly rounded to well
    /// below an f32 ulp) everywhere on the grid, and exact on almost all of it; 0⁰,
    /// x⁰, 0ⁿ and 1ⁿ are exact.
    #[test]
    fn pow_is_within_one_ulp_of_f64_pow() {
        let (xs, ns) = (bases(), exponents());
        let (mut worst, mut inexact, mut total) = (0.0f64, 0u64, 0u64);
        for &n in &ns {
            for &x in &xs {
                let got = pow(x, n);
                let want = (x as f64).powf(n as f64);
                let e = ulps(got, want);
                // The one case a correctly rounded result may differ from: a value
                // within ~1e-12 of a tie between two floats.
                if got != want as f32 {
                    inexact += 1;
                }
                worst = worst.max(e);
                total += 1;
                assert!(
                    e <= 1.0,
                    "pow({x:e}, {n:e}) = {got:e}, f64 {want:e}: {e} ulps"
                );
            }
        }
        assert!(total > 7_000_000, "{total}");
        // Correctly rounded in all but a handful of millions.
        assert!(
            inexact * 100_000 < total,
            "{inexact} of {total} not correctly rounded"
        );
        assert!(worst <= 1.0);
        for n in [0.0, 1.0, 7.5, 1e4] {
            assert_eq!(pow(1.0f32, n).to_bits(), 1f32.to_bits(), "1^{n}");
        }
        for x in [0.0, 0.3, 1.0, f32::from_bits(1)] {
            assert_eq!(pow(x, 0.0).to_bits(), 1f32.to_bits(), "{x}^0");
        }
        for n in [f32::from_bits(1), 1e-3, 1.0, 1e4] {
            assert_eq!(pow(0.0f32, n).to_bits(), 0, "0^{n}");
        }
    }

    /// Estrin's pairing is the polynomial for every length up to the kernels' 12: with
    /// integer coefficients and points every operation is exact, so a term paired
    /// wrongly or dropped changes the value. The four-lane form gives the same values.
    #[test]
    fn estrin_is_the_polynomial() {
        fn check<const N: usize>() {
            let c: [f64; N] = std::array::from_fn(|j| (j as f64 + 1.0) * [1.0, -1.0][j % 2]);
            let zs = [-3.0, -1.0, 0.0, 1.0, 2.0, 5.0];
            for z in zs {
                let want = c.iter().rev().fold(0.0, |acc, &cj| acc * z + cj);
                assert_eq!(estrin(z, &c), want, "N = {N}, z = {z}");
            }
            let four = estrin(f64x4::from([zs[0], zs[1], zs[4], zs[5]]), &c).to_array();
            for (got, z) in four.into_iter().zip([zs[0], zs[1], zs[4], zs[5]]) {
                assert_eq!(got, estrin(z, &c), "N = {N}, z = {z}, four lanes");
            }
        }
        check::<1>();
        check::<2>();
        check::<3>();
        check::<4>();
        check::<5>();
        check::<6>();
        check::<7>();
        check::<8>();
        check::<9>();
        check::<11>();
        check::<12>();
    }

    /// Every lane its own exponent (`pow_mixed`), and every lane one exponent (a
    /// packet on one material: integer exponents read once), give the scalar bits.
    #[test]
    fn pow_gives_the_same_bits_at_every_width() {
        let xs = bases();
        let ns: Vec<f32> = exponents().iter().cycle().take(xs.len()).copied().collect();
        same_at_every_width(&xs, &ns);
        for n in exponents() {
            same_at_every_width(&xs[..2048], &vec![n; 2048]);
        }
    }

    /// sin and cos of 2πu are within one ulp of f64's on a fine grid of [0, 1) (every
    /// sample an azimuth takes is a multiple of 2⁻²⁴ there), beyond it, and at the
    /// quadrant boundaries, where they are exact: 0, ±1.
    #[test]
    fn sin_cos_turns_are_within_one_ulp() {
        let mut us: Vec<f32> = (0..1 << 20).map(|i| i as f32 / (1 << 20) as f32).collect();
        us.extend((0..4096).map(|i| 1.0 - i as f32 * f32::EPSILON / 2.0));
        us.extend([-0.3, -2.75, 3.125, 100.1, 0.125, 0.375]);
        let mut worst = 0.0f64;
        for &u in &us {
            let (s, c) = sin_cos_turns(u);
            // The f64 angle of u's fraction (exact: u − round(u)), whose rounding
            // (1e-16 relative) is far below an f32 ulp except near zeros, which the
            // absolute floor covers.
            let u64 = u as f64;
            let a = (u64 - u64.round()) * std::f64::consts::TAU;
            for (got, want) in [(s, a.sin()), (c, a.cos())] {
                let e = ulps(got, want).min((got as f64 - want).abs() / 1e-15);
                worst = worst.max(e);
                assert!(e <= 1.0, "u = {u:e}: {got:e} against {want:e}");
            }
        }
        for (u, s, c) in [
            (0.0, 0.0, 1.0),
            (0.25, 1.0, 0.0),
            (0.5, 0.0, -1.0),
            (0.75, -1.0, 0.0),
        ] {
            let (gs, gc) = sin_cos_turns(u);
            // `==`: a zero may come out as −0.
            assert!(gs == s && gc == c, "{u}: ({gs}, {gc})");
        }
        same_at_every_width(&us[..4096], &us[..4096]);
    }
}
