//! Sixteen lanes: `F32x16` and its `Mask16`, the `Lane` rules of `mod.rs` on 16 f32.
//!
//! Built with AVX-512F, an `F32x16` is one 512-bit register and its mask one `k`
//! register (a `u16`: bits and masks are the same thing there). Without it, it is two
//! `f32x8` halves and two `Mask8`s, every operation the 8-wide one on each half, so the
//! two builds give the same bits by the same rules.
//!
//! Each operation is the one the 8-wide lanes use: `vminps`/`vmaxps` (a NaN in either
//! operand yields the second), ordered compares (false on NaN) but for `ne`, `-` as
//! 0 − x (as `wide`'s), and no fused multiply-add.

use super::{math, widen, Lane, Mask};
use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Not, Sub};
use wide::f32x8;

/// Whether `F32x16` runs as one AVX-512 register (else as two 8-wide halves).
pub const AVX512: bool = cfg!(all(target_arch = "x86_64", target_feature = "avx512f"));

#[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
mod imp {
    use super::*;
    use std::arch::x86_64::*;

    /// Sixteen f32 in one AVX-512 register.
    #[derive(Clone, Copy, Debug)]
    #[repr(transparent)]
    pub struct F32x16(pub(super) __m512);

    /// A mask of sixteen lanes: an AVX-512 `k` register, bit i for lane i.
    #[derive(Clone, Copy, Debug)]
    pub struct Mask16(pub(super) u16);

    // SAFETY (every `unsafe` block of this module): AVX-512F is enabled for the whole
    // build (the `cfg` of this module), and these are register operations, or a
    // transmute between `__m512` and `[f32; 16]`, which have the same size and any bit
    // pattern is valid in either.
    macro_rules! avx512 {
        ($e:expr) => {
            unsafe { $e }
        };
    }

    impl F32x16 {
        #[inline(always)]
        pub(super) fn to_array(self) -> [f32; 16] {
            avx512!(std::mem::transmute::<__m512, [f32; 16]>(self.0))
        }
        #[inline(always)]
        pub(super) fn from_array(a: [f32; 16]) -> Self {
            F32x16(avx512!(std::mem::transmute::<[f32; 16], __m512>(a)))
        }
        /// The low and high eight lanes.
        #[inline(always)]
        pub(super) fn halves(self) -> [f32x8; 2] {
            let lo: __m256 = avx512!(_mm512_castps512_ps256(self.0));
            let hi = avx512!(_mm256_castpd_ps(_mm512_extractf64x4_pd::<1>(
                _mm512_castps_pd(self.0)
            )));
            [bytemuck::cast(lo), bytemuck::cast(hi)]
        }
        #[inline(always)]
        fn cmp<const P: i32>(self, o: Self) -> Mask16 {
            Mask16(avx512!(_mm512_cmp_ps_mask::<P>(self.0, o.0)))
        }
        #[inline(always)]
        pub(super) fn splat(x: f32) -> Self {
            F32x16(avx512!(_mm512_set1_ps(x)))
        }
        #[inline(always)]
        pub(super) fn lane(self, i: usize) -> f32 {
            self.to_array()[i]
        }
        /// One `vpermps`.
        #[inline(always)]
        pub(super) fn broadcast(self, i: usize) -> Self {
            F32x16(avx512!(_mm512_permutexvar_ps(
                _mm512_set1_epi32(i as i32 & 15),
                self.0
            )))
        }
        #[inline(always)]
        pub(super) fn select(m: Mask16, a: Self, b: Self) -> Self {
            F32x16(avx512!(_mm512_mask_blend_ps(m.0, b.0, a.0)))
        }
        #[inline(always)]
        pub(super) fn lt(self, o: Self) -> Mask16 {
            self.cmp::<_CMP_LT_OQ>(o)
        }
        #[inline(always)]
        pub(super) fn le(self, o: Self) -> Mask16 {
            self.cmp::<_CMP_LE_OQ>(o)
        }
        #[inline(always)]
        pub(super) fn gt(self, o: Self) -> Mask16 {
            self.cmp::<_CMP_GT_OQ>(o)
        }
        #[inline(always)]
        pub(super) fn ge(self, o: Self) -> Mask16 {
            self.cmp::<_CMP_GE_OQ>(o)
        }
        #[inline(always)]
        pub(super) fn eq(self, o: Self) -> Mask16 {
            self.cmp::<_CMP_EQ_OQ>(o)
        }
        /// Unordered: true where either lane is NaN, as `f32`'s `!=`.
        #[inline(always)]
        pub(super) fn ne(self, o: Self) -> Mask16 {
            self.cmp::<_CMP_NEQ_UQ>(o)
        }
        #[inline(always)]
        pub(super) fn min(self, o: Self) -> Self {
            F32x16(avx512!(_mm512_min_ps(self.0, o.0)))
        }
        #[inline(always)]
        pub(super) fn max(self, o: Self) -> Self {
            F32x16(avx512!(_mm512_max_ps(self.0, o.0)))
        }
        #[inline(always)]
        pub(super) fn sqrt(self) -> Self {
            F32x16(avx512!(_mm512_sqrt_ps(self.0)))
        }
        /// The sign bits cleared (an integer AND: `vandps` on 512 bits needs AVX-512DQ).
        #[inline(always)]
        pub(super) fn abs(self) -> Self {
            let keep = avx512!(_mm512_set1_epi32(i32::MAX));
            F32x16(avx512!(_mm512_castsi512_ps(_mm512_and_si512(
                _mm512_castps_si512(self.0),
                keep
            ))))
        }
        #[inline(always)]
        pub(super) fn flip_sign(self) -> Self {
            let sign = avx512!(_mm512_set1_epi32(i32::MIN));
            F32x16(avx512!(_mm512_castsi512_ps(_mm512_xor_si512(
                _mm512_castps_si512(self.0),
                sign
            ))))
        }
        #[inline(always)]
        pub(super) fn add_bits(self, delta: i32) -> Self {
            F32x16(avx512!(_mm512_castsi512_ps(_mm512_add_epi32(
                _mm512_castps_si512(self.0),
                _mm512_set1_epi32(delta)
            ))))
        }
    }

    macro_rules! arithmetic {
        ($($trait:ident $method:ident $intrinsic:ident),*) => {$(
            impl $trait for F32x16 {
                type Output = Self;
                #[inline(always)]
                fn $method(self, o: Self) -> Self {
                    F32x16(avx512!($intrinsic(self.0, o.0)))
                }
            }
        )*};
    }
    arithmetic!(Add add _mm512_add_ps, Sub sub _mm512_sub_ps, Mul mul _mm512_mul_ps,
        Div div _mm512_div_ps);

    /// 0 − x, as `wide`'s `-` on `f32x8` (+0 for +0); `flip_sign` is the sign flip.
    impl Neg for F32x16 {
        type Output = Self;
        #[inline(always)]
        fn neg(self) -> Self {
            F32x16(avx512!(_mm512_sub_ps(_mm512_setzero_ps(), self.0)))
        }
    }

    impl BitAnd for Mask16 {
        type Output = Self;
        #[inline(always)]
        fn bitand(self, o: Self) -> Self {
            Mask16(self.0 & o.0)
        }
    }

    impl BitOr for Mask16 {
        type Output = Self;
        #[inline(always)]
        fn bitor(self, o: Self) -> Self {
            Mask16(self.0 | o.0)
        }
    }

    impl Not for Mask16 {
        type Output = Self;
        #[inline(always)]
        fn not(self) -> Self {
            Mask16(!self.0)
        }
    }

    impl Mask for Mask16 {
        #[inline(always)]
        fn bits(self) -> u32 {
            self.0 as u32
        }
        #[inline(always)]
        fn from_bits(bits: u32) -> Self {
            Mask16(bits as u16)
        }
    }
}

#[cfg(not(all(target_arch = "x86_64", target_feature = "avx512f")))]
mod imp {
    use super::*;
    use crate::lanes::Mask8;

    /// Sixteen f32 as two 8-wide halves (AVX2 registers, or SSE quarters).
    #[derive(Clone, Copy, Debug)]
    pub struct F32x16(pub(super) [f32x8; 2]);

    /// A mask of sixteen lanes: the masks of the two halves.
    #[derive(Clone, Copy, Debug)]
    pub struct Mask16(pub(super) [Mask8; 2]);

    impl F32x16 {
        #[inline(always)]
        fn map(self, f: impl Fn(f32x8) -> f32x8) -> Self {
            F32x16([f(self.0[0]), f(self.0[1])])
        }
        #[inline(always)]
        fn zip(self, o: Self, f: impl Fn(f32x8, f32x8) -> f32x8) -> Self {
            F32x16([f(self.0[0], o.0[0]), f(self.0[1], o.0[1])])
        }
        #[inline(always)]
        fn test(self, o: Self, f: impl Fn(f32x8, f32x8) -> Mask8) -> Mask16 {
            Mask16([f(self.0[0], o.0[0]), f(self.0[1], o.0[1])])
        }
        #[inline(always)]
        pub(super) fn to_array(self) -> [f32; 16] {
            bytemuck::cast(self.0)
        }
        #[inline(always)]
        pub(super) fn from_array(a: [f32; 16]) -> Self {
            F32x16(bytemuck::cast(a))
        }
        #[inline(always)]
        pub(super) fn halves(self) -> [f32x8; 2] {
            self.0
        }
        #[inline(always)]
        pub(super) fn splat(x: f32) -> Self {
            F32x16([f32x8::splat(x); 2])
        }
        #[inline(always)]
        pub(super) fn lane(self, i: usize) -> f32 {
            self.0[i >> 3 & 1].lane(i & 7)
        }
        #[inline(always)]
        pub(super) fn broadcast(self, i: usize) -> Self {
            let b = self.0[i >> 3 & 1].broadcast(i & 7);
            F32x16([b, b])
        }
        #[inline(always)]
        pub(super) fn select(m: Mask16, a: Self, b: Self) -> Self {
            F32x16([
                f32x8::select(m.0[0], a.0[0], b.0[0]),
                f32x8::select(m.0[1], a.0[1], b.0[1]),
            ])
        }
        #[inline(always)]
        pub(super) fn lt(self, o: Self) -> Mask16 {
            self.test(o, Lane::lt)
        }
        #[inline(always)]
        pub(super) fn le(self, o: Self) -> Mask16 {
            self.test(o, Lane::le)
        }
        #[inline(always)]
        pub(super) fn gt(self, o: Self) -> Mask16 {
            self.test(o, Lane::gt)
        }
        #[inline(always)]
        pub(super) fn ge(self, o: Self) -> Mask16 {
            self.test(o, Lane::ge)
        }
        #[inline(always)]
        pub(super) fn eq(self, o: Self) -> Mask16 {
            self.test(o, Lane::eq)
        }
        #[inline(always)]
        pub(super) fn ne(self, o: Self) -> Mask16 {
            self.test(o, Lane::ne)
        }
        #[inline(always)]
        pub(super) fn min(self, o: Self) -> Self {
            self.zip(o, Lane::min)
        }
        #[inline(always)]
        pub(super) fn max(self, o: Self) -> Self {
            self.zip(o, Lane::max)
        }
        #[inline(always)]
        pub(super) fn sqrt(self) -> Self {
            self.map(Lane::sqrt)
        }
        #[inline(always)]
        pub(super) fn abs(self) -> Self {
            self.map(Lane::abs)
        }
        #[inline(always)]
        pub(super) fn flip_sign(self) -> Self {
            self.map(Lane::flip_sign)
        }
        #[inline(always)]
        pub(super) fn add_bits(self, delta: i32) -> Self {
            self.map(|h| h.add_bits(delta))
        }
    }

    macro_rules! arithmetic {
        ($($trait:ident $method:ident),*) => {$(
            impl $trait for F32x16 {
                type Output = Self;
                #[inline(always)]
                fn $method(self, o: Self) -> Self {
                    self.zip(o, $trait::$method)
                }
            }
        )*};
    }
    arithmetic!(Add add, Sub sub, Mul mul, Div div);

    /// `wide`'s `-` on each half: 0 − x.
    impl Neg for F32x16 {
        type Output = Self;
        #[inline(always)]
        fn neg(self) -> Self {
            self.map(Neg::neg)
        }
    }

    impl BitAnd for Mask16 {
        type Output = Self;
        #[inline(always)]
        fn bitand(self, o: Self) -> Self {
            Mask16([self.0[0] & o.0[0], self.0[1] & o.0[1]])
        }
    }

    impl BitOr for Mask16 {
        type Output = Self;
        #[inline(always)]
        fn bitor(self, o: Self) -> Self {
            Mask16([self.0[0] | o.0[0], self.0[1] | o.0[1]])
        }
    }

    impl Not for Mask16 {
        type Output = Self;
        #[inline(always)]
        fn not(self) -> Self {
            Mask16([!self.0[0], !self.0[1]])
        }
    }

    impl Mask for Mask16 {
        #[inline(always)]
        fn bits(self) -> u32 {
            self.0[0].bits() | self.0[1].bits() << 8
        }
        #[inline(always)]
        fn from_bits(bits: u32) -> Self {
            Mask16([
                Mask8::from_bits(bits & 0xff),
                Mask8::from_bits(bits >> 8 & 0xff),
            ])
        }
    }
}

pub use imp::{F32x16, Mask16};

impl Lane for F32x16 {
    type Mask = Mask16;
    const WIDTH: usize = 16;
    /// Four quarters of four lanes widened to f64, run as two pairs.
    #[inline(always)]
    fn map_f64<K: math::F64Kernel>(k: &K, a: Self, b: Self) -> (Self, Self) {
        let (a, b) = (a.to_array(), b.to_array());
        let quarter = |v: &[f32; 16], q: usize| widen(std::array::from_fn(|i| v[4 * q + i]));
        let mut x = [0.0f32; 16];
        let mut y = [0.0f32; 16];
        for pair in 0..2 {
            let (q0, q1) = (2 * pair, 2 * pair + 1);
            let [(x0, y0), (x1, y1)] = k.eval2(
                [quarter(&a, q0), quarter(&a, q1)],
                [quarter(&b, q0), quarter(&b, q1)],
            );
            for (q, xq, yq) in [(q0, x0, y0), (q1, x1, y1)] {
                x[4 * q..4 * q + 4].copy_from_slice(&super::narrow(xq));
                y[4 * q..4 * q + 4].copy_from_slice(&super::narrow(yq));
            }
        }
        (F32x16::from_array(x), F32x16::from_array(y))
    }
    /// The default tree: its first step (lane i against lane i + 8) is `vminps` on the
    /// halves, the rest the 8-wide tree.
    #[inline(always)]
    fn reduce_min(self) -> f32 {
        let [lo, hi] = self.halves();
        Lane::min(lo, hi).reduce_min()
    }
    #[inline(always)]
    fn reduce_max(self) -> f32 {
        let [lo, hi] = self.halves();
        Lane::max(lo, hi).reduce_max()
    }
    #[inline(always)]
    fn splat(x: f32) -> Self {
        F32x16::splat(x)
    }
    #[inline(always)]
    fn from_fn(f: impl FnMut(usize) -> f32) -> Self {
        F32x16::from_array(std::array::from_fn(f))
    }
    #[inline(always)]
    fn lane(self, i: usize) -> f32 {
        F32x16::lane(self, i)
    }
    #[inline(always)]
    fn broadcast(self, i: usize) -> Self {
        F32x16::broadcast(self, i)
    }
    #[inline(always)]
    fn select(m: Mask16, a: Self, b: Self) -> Self {
        F32x16::select(m, a, b)
    }
    #[inline(always)]
    fn lt(self, o: Self) -> Mask16 {
        F32x16::lt(self, o)
    }
    #[inline(always)]
    fn le(self, o: Self) -> Mask16 {
        F32x16::le(self, o)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Mask16 {
        F32x16::gt(self, o)
    }
    #[inline(always)]
    fn ge(self, o: Self) -> Mask16 {
        F32x16::ge(self, o)
    }
    #[inline(always)]
    fn eq(self, o: Self) -> Mask16 {
        F32x16::eq(self, o)
    }
    #[inline(always)]
    fn ne(self, o: Self) -> Mask16 {
        F32x16::ne(self, o)
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        F32x16::min(self, o)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        F32x16::max(self, o)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        F32x16::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        F32x16::abs(self)
    }
    #[inline(always)]
    fn flip_sign(self) -> Self {
        F32x16::flip_sign(self)
    }
    #[inline(always)]
    fn add_bits(self, delta: i32) -> Self {
        F32x16::add_bits(self, delta)
    }
}
