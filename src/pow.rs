//! `x^s` for the Phong specular term, the same bits at every lane width.
//!
//! The tracers raised `max(R·V, 0)` to the shininess with libm's `powf`, one scalar call
//! per lane (callgrind: 7% of the `bunny` render's instructions with the per-lane loop
//! around it). `powf_n` computes the power of `N` lanes at once in `f64` with only
//! `+ − × ÷`, comparisons and bit operations, which IEEE 754 rounds the same whether
//! the compiler vectorises the loop or not, so the scalar tracer (`N = 1`) and the
//! packets (`N = 4`, `8`) get the same bits (`lanes.rs`' rules; no fused multiply-add).
//!
//! Accuracy: `log2` by `2·atanh` on a mantissa in [√½, √2) to about 5e-16, `exp2` by
//! its Taylor series on [−½, ½] to about 3e-16 relative; the `f64` result is within
//! about 1e-13 relative of `x^s` for `|s·log2 x| ≤ 200`, so the `f32` it rounds to is
//! the correctly rounded power except when the exact value lies within that distance of
//! a rounding boundary (tests: at most 1 ulp from the `f64` oracle, and equal to its
//! rounding in all but a few of a million cases).

/// 2 / ((2i + 1)·ln 2): log2(m) = z·Σ LOG[i]·z^(2i), z = (m − 1)/(m + 1).
const LOG: [f64; 9] = [
    2.885_390_081_777_926_8,
    0.961_796_693_925_975_6,
    0.577_078_016_355_585_3,
    0.412_198_583_111_132_4,
    0.320_598_897_975_325_2,
    0.262_308_189_252_538_8,
    0.221_953_083_213_686_67,
    0.192_359_338_785_195_12,
    0.169_728_828_339_878_04,
];

/// (ln 2)^k / k!: 2^f = Σ EXP[k]·f^k.
const EXP: [f64; 13] = [
    1.0,
    std::f64::consts::LN_2,
    0.240_226_506_959_100_72,
    0.055_504_108_664_821_58,
    0.009_618_129_107_628_477,
    0.001_333_355_814_642_844_3,
    0.000_154_035_303_933_816_1,
    1.525_273_380_405_984_1e-5,
    1.321_548_679_014_431e-6,
    1.017_808_600_923_97e-7,
    7.054_911_620_801_123e-9,
    4.445_538_271_870_811_6e-10,
    2.567_843_599_348_820_6e-11,
];

/// 1.5·2^52: `y + ROUND − ROUND` is `y` rounded to an integer (ties to even), and the
/// low bits of `y + ROUND` hold that integer.
const ROUND: f64 = 6_755_399_441_055_744.0;

/// 2^52 + 1023: an 11-bit biased exponent `k` or-ed into the mantissa of 2^52 gives
/// 2^52 + k, and subtracting this leaves `k − 1023` exactly.
const EXPONENT_BIAS: f64 = 4_503_599_627_371_519.0;

/// `x^s` lane by lane for `x ≥ 0` (a NaN or negative `x` counts as 0, as `max(x, 0)`)
/// and finite `s ≥ 0` (the shininess the scene loader accepts): `s = 0` gives 1 (also
/// for `x = 0`), `x = 0` gives 0, and a power beyond 2^±200 saturates there (0 or ∞ in
/// `f32`). Branch-free per lane, so the loop vectorises.
#[inline(always)]
pub fn powf_n<const N: usize>(x: [f32; N], s: [f32; N]) -> [f32; N] {
    let mut out = [0.0f32; N];
    for i in 0..N {
        let xi = if x[i] > 0.0 { x[i] } else { 0.0 };
        let xd = xi as f64;
        let bits = xd.to_bits();
        // x = m·2^e with m in [1, 2), then in [√½, √2).
        let k = bits >> 52;
        let m = f64::from_bits((bits & 0x000f_ffff_ffff_ffff) | 0x3ff0_0000_0000_0000);
        let high = m > std::f64::consts::SQRT_2;
        let m = if high { m * 0.5 } else { m };
        let e = f64::from_bits(0x4330_0000_0000_0000 | k) - EXPONENT_BIAS;
        let e = if high { e + 1.0 } else { e };
        let z = (m - 1.0) / (m + 1.0);
        // Estrin's scheme: a tree of products instead of Horner's chain, so the power's
        // latency (it feeds the colour sum) is about a third.
        let w = z * z;
        let w2 = w * w;
        let w4 = w2 * w2;
        let l01 = LOG[0] + LOG[1] * w;
        let l23 = LOG[2] + LOG[3] * w;
        let l45 = LOG[4] + LOG[5] * w;
        let l67 = LOG[6] + LOG[7] * w;
        let l03 = l01 + l23 * w2;
        let l47 = l45 + l67 * w2;
        let p = (l03 + l47 * w4) + LOG[8] * (w4 * w4);
        let y = (s[i] as f64) * (e + z * p);
        let y = if y > -200.0 { y } else { -200.0 };
        let y = if y < 200.0 { y } else { 200.0 };
        // y = n + f, n an integer, |f| ≤ ½ (exact).
        let r = y + ROUND;
        let n = r - ROUND;
        let f = y - n;
        let f2 = f * f;
        let f4 = f2 * f2;
        let e01 = EXP[0] + EXP[1] * f;
        let e23 = EXP[2] + EXP[3] * f;
        let e45 = EXP[4] + EXP[5] * f;
        let e67 = EXP[6] + EXP[7] * f;
        let e89 = EXP[8] + EXP[9] * f;
        let e1011 = EXP[10] + EXP[11] * f;
        let e03 = e01 + e23 * f2;
        let e47 = e45 + e67 * f2;
        let e811 = e89 + e1011 * f2;
        let e07 = e03 + e47 * f4;
        let e812 = e811 + EXP[12] * f4;
        let q = e07 + e812 * (f4 * f4);
        let scale = f64::from_bits(
            (r.to_bits().wrapping_sub(ROUND.to_bits()))
                .wrapping_add(1023)
                .wrapping_shl(52),
        );
        let v = (q * scale) as f32;
        let v = if xi == 0.0 { 0.0 } else { v };
        out[i] = if s[i] == 0.0 { 1.0 } else { v };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The `f64` power rounded to `f32`, and the distance in ulps of `v` from the exact
    /// value (as well as `f64` knows it).
    fn ulps(v: f32, x: f32, s: f32) -> (f32, f64) {
        let exact = (x as f64).powf(s as f64);
        let rounded = exact as f32;
        if !rounded.is_finite() || rounded == 0.0 {
            return (rounded, if v == rounded { 0.0 } else { f64::INFINITY });
        }
        let ulp = (rounded.abs().next_up() - rounded.abs()) as f64;
        (rounded, (v as f64 - exact).abs() / ulp)
    }

    fn xorshift(state: &mut u64) -> u64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        *state
    }

    #[test]
    fn special_values() {
        let one = |x: f32, s: f32| powf_n([x], [s])[0];
        assert_eq!(one(0.0, 0.0).to_bits(), 1f32.to_bits());
        assert_eq!(one(0.0, 10.0).to_bits(), 0f32.to_bits());
        assert_eq!(one(-0.0, 3.0).to_bits(), 0f32.to_bits());
        assert_eq!(one(f32::NAN, 3.0).to_bits(), 0f32.to_bits());
        assert_eq!(one(-0.5, 3.0).to_bits(), 0f32.to_bits());
        assert_eq!(one(0.3, 0.0), 1.0);
        assert_eq!(one(1.0, 1000.0), 1.0);
        assert_eq!(one(1.0, 1e30), 1.0);
        assert_eq!(one(0.5, 2.0), 0.25);
        assert_eq!(one(0.5, 149.0), f32::from_bits(1)); // 2^-149, the least subnormal
        assert_eq!(one(0.5, 150.0), 0.0); // 2^-150 rounds (to even) to 0
        assert_eq!(one(0.5, 1e6), 0.0);
        assert_eq!(one(1.0 + f32::EPSILON, 1e30), f32::INFINITY);
        assert_eq!(one(f32::from_bits(1), 1.0), f32::from_bits(1));
        assert_eq!(one(0.25, 0.5), 0.5);
    }

    /// Random bases in (0, 1] (uniform, and log-uniform down to subnormals) and
    /// shininesses of the scenes' range: within 1 ulp of the `f64` oracle, and the
    /// oracle's rounding nearly always.
    #[test]
    fn matches_the_f64_oracle() {
        let mut state = 0x2545_f491_4f6c_dd1d;
        let (mut n, mut misrounded) = (0u32, 0u32);
        let mut worst = 0f64;
        for _ in 0..400_000 {
            let a = xorshift(&mut state);
            let b = xorshift(&mut state);
            let x = if a & 1 == 0 {
                ((a >> 40) as f32 + 1.0) / (1u64 << 24) as f32
            } else {
                f32::from_bits(1 + ((a >> 33) % 0x3f80_0000) as u32)
            };
            let s = match b % 4 {
                0 => (b >> 40) as f32 / (1u64 << 24) as f32 * 2.0,
                1 => ((b >> 40) % 1200) as f32,
                2 => ((b >> 40) as f32 / (1u64 << 24) as f32) * 1000.0,
                _ => 10f32.powf((b >> 40) as f32 / (1u64 << 24) as f32 * 4.0 - 1.0),
            };
            let v = powf_n([x], [s])[0];
            let (rounded, err) = ulps(v, x, s);
            n += 1;
            misrounded += (v != rounded) as u32;
            worst = worst.max(err);
            assert!(
                err <= 1.0,
                "{x:e}^{s} = {v:e}, oracle {rounded:e} ({err} ulp)"
            );
        }
        // Measured: 0.499998 ulp, none misrounded (the oracle's own error is ~1e-9 ulp).
        assert!(worst <= 0.5 + 1e-5, "worst {worst} ulp");
        assert!(
            misrounded * 100_000 <= n,
            "{misrounded} of {n} not correctly rounded"
        );
    }

    /// The widths agree bit for bit (the loop vectorised or not).
    #[test]
    fn widths_agree() {
        let mut state = 0x9e37_79b9_7f4a_7c15;
        for _ in 0..20_000 {
            let x: [f32; 8] = std::array::from_fn(|_| {
                let a = xorshift(&mut state);
                ((a >> 40) as f32 / (1u64 << 24) as f32) * 1.01 - 0.005
            });
            let s: [f32; 8] =
                std::array::from_fn(|_| (xorshift(&mut state) >> 40) as f32 / 16_000.0);
            let eight = powf_n(x, s);
            let four = [powf_n([x[0], x[1], x[2], x[3]], [s[0], s[1], s[2], s[3]])];
            let four2 = powf_n([x[4], x[5], x[6], x[7]], [s[4], s[5], s[6], s[7]]);
            for k in 0..8 {
                let one = powf_n([x[k]], [s[k]])[0];
                assert_eq!(one.to_bits(), eight[k].to_bits());
                let f = if k < 4 { four[0][k] } else { four2[k - 4] };
                assert_eq!(one.to_bits(), f.to_bits());
            }
        }
    }
}
