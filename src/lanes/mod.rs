//! Lanes: the small vector trait every geometric kernel is written over, so the scalar
//! reference and the packet tracers run the same operations (ARCHITECTURE.md, "Lanes").
//!
//! Implemented for `f32` (one ray, the reference), `glam::Vec4` with `BVec4A` masks
//! (4 wide) and `wide::f32x8` (8 wide; without AVX, `wide` runs it as two 4-wide halves).
//!
//! Rules that keep the widths bit-identical:
//! - only `+ − × ÷` and `sqrt`, which IEEE 754 rounds exactly in every width; no fused
//!   multiply-add, no approximate reciprocal;
//! - one NaN rule for `min`/`max`, the SSE one: `a.min(b)` is `if a < b { a } else { b }`,
//!   so a NaN in either operand yields `b` (the box test relies on it to drop 0·∞);
//! - the same operand order everywhere (`V3::dot` is `(x·x + y·y) + z·z`, as glam's).
//!
//! The trait and its three implementations are one file, though long: they must keep
//! the rules above together, operation by operation; split, a difference between the
//! widths would hide in the seam. Their tests are in `tests.rs`.

pub mod math;
mod sixteen;

pub use sixteen::{F32x16, Mask16, AVX512};

use glam::{BVec4A, Vec4};
use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Not, Sub};
use wide::{f32x8, i32x8, CmpEq, CmpGe, CmpGt, CmpLe, CmpLt};

/// Whether the 8-wide lanes run as one AVX register (else as two SSE halves).
pub const AVX2: bool = cfg!(target_feature = "avx2");

/// The vector instruction set the lanes were compiled for (`.cargo/config.toml`):
/// `"AVX-512"` (16 lanes a register), `"AVX2"` (8), `"SSE2"` (4) or `"portable"`.
pub const ISA: &str = if AVX512 {
    "AVX-512"
} else if AVX2 {
    "AVX2"
} else if cfg!(target_feature = "sse2") {
    "SSE2"
} else {
    "portable"
};

/// What the lanes compiled to, in a phrase for `--version`, reports and benchmarks.
pub const COMPILED: &str = if AVX512 {
    "AVX-512: packets of 4, 8 and 16 rays in one register each; default width 16"
} else if AVX2 {
    "AVX2: packets of 4 and 8 rays in one register, 16 as two halves; default width 8"
} else {
    "without AVX2: packets of 4 rays in one register, 8 and 16 in halves; default width 4"
};

/// The most lanes of any `Lane` (`F32x16`): the size of the per-lane arrays that
/// every width shares.
pub const MAX_WIDTH: usize = 16;

/// The lanes set in the bit mask `mask`, in lane order.
#[inline(always)]
pub fn set_lanes(mask: u32) -> impl Iterator<Item = usize> {
    let mut rest = mask;
    std::iter::from_fn(move || {
        (rest != 0).then(|| {
            let k = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            k
        })
    })
}

/// The lanes of `mask` for which `f(lane)` holds, as a bit mask (asked in lane order).
#[inline(always)]
pub fn lanes_where(mask: u32, mut f: impl FnMut(usize) -> bool) -> u32 {
    set_lanes(mask).fold(0, |m, k| if f(k) { m | 1 << k } else { m })
}

/// Whether the first `width` entries of `xs` are all equal: an OR of differences, with
/// no branch per entry (`width` ≥ 1).
#[inline(always)]
pub fn all_equal<T>(xs: &[T], width: usize) -> bool
where
    T: Copy + Default + PartialEq + std::ops::BitXor<Output = T> + std::ops::BitOr<Output = T>,
{
    let first = xs[0];
    let zero = T::default();
    xs[..width].iter().fold(zero, |d, &x| d | (x ^ first)) == zero
}

/// A lane mask: one bit per lane.
pub trait Mask: Copy + BitAnd<Output = Self> + BitOr<Output = Self> + Not<Output = Self> {
    /// Bit `i` set when lane `i` is set.
    fn bits(self) -> u32;
    /// Lanes `i` with bit `i` of `bits` set.
    fn from_bits(bits: u32) -> Self;
    #[inline(always)]
    fn any(self) -> bool {
        self.bits() != 0
    }
}

/// A vector of `WIDTH` f32 lanes.
pub trait Lane:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    type Mask: Mask;
    const WIDTH: usize;
    fn splat(x: f32) -> Self;
    /// Lane `i` is `f(i)`.
    fn from_fn(f: impl FnMut(usize) -> f32) -> Self;
    fn lane(self, i: usize) -> f32;
    /// Every lane set to lane `i`'s value.
    #[inline(always)]
    fn broadcast(self, i: usize) -> Self {
        Self::splat(self.lane(i))
    }
    /// `m ? a : b`, lane by lane.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    fn lt(self, o: Self) -> Self::Mask;
    fn le(self, o: Self) -> Self::Mask;
    fn gt(self, o: Self) -> Self::Mask;
    fn ge(self, o: Self) -> Self::Mask;
    fn eq(self, o: Self) -> Self::Mask;
    /// `!=`: true where either lane is NaN.
    fn ne(self, o: Self) -> Self::Mask;
    /// `if self < o { self } else { o }` (a NaN yields `o`).
    fn min(self, o: Self) -> Self;
    /// `if self > o { self } else { o }` (a NaN yields `o`).
    fn max(self, o: Self) -> Self;
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    /// −x, the sign bit flipped, as `f32`'s `-` (wide's `-` on `f32x8` is 0 − x, which
    /// gives +0 for +0: use this in kernels that must match the scalar bits).
    fn flip_sign(self) -> Self;
    /// The float whose bit pattern is this one's plus `delta` as a wrapping integer, lane
    /// by lane (a bit cast, an integer add, a bit cast).
    fn add_bits(self, delta: i32) -> Self;
    /// `f32::next_up`, lane by lane: the least float above (NaN and +∞ stay, ±0 goes to
    /// the least positive subnormal, −f32::MAX from −∞). `f32` runs the std function; the
    /// wider lanes step the bit pattern, +1 above zero and −1 below.
    #[inline(always)]
    fn next_up(self) -> Self {
        let zero = Self::splat(0.0);
        let step = Self::select(self.lt(zero), self.add_bits(-1), self.add_bits(1));
        let step = Self::select(self.eq(zero), Self::splat(f32::from_bits(1)), step);
        let keep = self.ne(self) | self.eq(Self::splat(f32::INFINITY));
        Self::select(keep, self, step)
    }
    /// `f32::next_down`, lane by lane: the greatest float below (NaN and −∞ stay, ±0 goes
    /// to the greatest negative subnormal, f32::MAX from +∞).
    #[inline(always)]
    fn next_down(self) -> Self {
        let zero = Self::splat(0.0);
        let step = Self::select(self.lt(zero), self.add_bits(1), self.add_bits(-1));
        let step = Self::select(self.eq(zero), Self::splat(-f32::from_bits(1)), step);
        let keep = self.ne(self) | self.eq(Self::splat(f32::NEG_INFINITY));
        Self::select(keep, self, step)
    }
    /// `next_up` where `towards > 0`, `next_down` where `towards < 0`, else unchanged:
    /// one step away from a surface along an offset (`spawn::spawn_origin`). `f32` runs
    /// the branches (one std call at most); the wider lanes select between both steps.
    #[inline(always)]
    fn step_towards(self, towards: Self) -> Self {
        let zero = Self::splat(0.0);
        let down = Self::select(towards.lt(zero), self.next_down(), self);
        Self::select(towards.gt(zero), self.next_up(), down)
    }
    /// `K` on the lanes widened to f64 (exactly), its results rounded to f32: the
    /// transcendental functions of `math`, one kernel for every width.
    fn map_f64<K: math::F64Kernel>(k: &K, a: Self, b: Self) -> (Self, Self);
    /// The smallest lane, for lanes that are not NaN (a NaN lane may or may not be
    /// skipped). A pairwise tree of `a < b ? a : b`, one `minss` each: `f32::min`'s
    /// NaN handling cost three more instructions per lane (callgrind, packet traversal).
    #[inline(always)]
    fn reduce_min(self) -> f32 {
        reduce_tree(self, |a, b| if a < b { a } else { b })
    }
    /// The largest lane, for lanes that are not NaN: the same tree with `>`.
    #[inline(always)]
    fn reduce_max(self) -> f32 {
        reduce_tree(self, |a, b| if a > b { a } else { b })
    }
}

/// Four f32 as four f64 (exact; `vcvtps2pd`).
#[inline(always)]
fn widen(v: [f32; 4]) -> wide::f64x4 {
    wide::f64x4::new(v.map(f64::from))
}

/// Four f64 rounded to f32 (to nearest, as `as` and `vcvtpd2ps` round).
#[inline(always)]
fn narrow(v: wide::f64x4) -> [f32; 4] {
    v.to_array().map(|x| x as f32)
}

/// `pick` over the lanes as a pairwise tree: lane i against lane i + w/2, halving w.
#[inline(always)]
fn reduce_tree<L: Lane>(x: L, pick: impl Fn(f32, f32) -> f32) -> f32 {
    let mut v = [0.0; MAX_WIDTH];
    for (i, s) in v.iter_mut().enumerate().take(L::WIDTH) {
        *s = x.lane(i);
    }
    let mut w = L::WIDTH;
    while w > 1 {
        w /= 2;
        for i in 0..w {
            v[i] = pick(v[i], v[i + w]);
        }
    }
    v[0]
}

/// `reduce_tree` of 8 lanes with `op` on 4-lane halves, then on pairs, then `pick`.
#[inline(always)]
fn reduce8(x: f32x8, op: impl Fn(Vec4, Vec4) -> Vec4, pick: impl Fn(f32, f32) -> f32) -> f32 {
    let a = x.to_array();
    let m4 = op(Vec4::from_slice(&a[..4]), Vec4::from_slice(&a[4..]));
    let m2 = op(m4, glam::Vec4Swizzles::zwzw(m4));
    pick(m2.x, m2.y)
}

impl Mask for bool {
    #[inline(always)]
    fn bits(self) -> u32 {
        self as u32
    }
    #[inline(always)]
    fn from_bits(bits: u32) -> Self {
        bits & 1 != 0
    }
}

impl Lane for f32 {
    type Mask = bool;
    const WIDTH: usize = 1;
    #[inline(always)]
    fn map_f64<K: math::F64Kernel>(k: &K, a: Self, b: Self) -> (Self, Self) {
        let (x, y) = k.eval(a as f64, b as f64);
        (x as f32, y as f32)
    }
    #[inline(always)]
    fn splat(x: f32) -> Self {
        x
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f32) -> Self {
        f(0)
    }
    #[inline(always)]
    fn lane(self, _: usize) -> f32 {
        self
    }
    #[inline(always)]
    fn select(m: bool, a: Self, b: Self) -> Self {
        if m {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn lt(self, o: Self) -> bool {
        self < o
    }
    #[inline(always)]
    fn le(self, o: Self) -> bool {
        self <= o
    }
    #[inline(always)]
    fn gt(self, o: Self) -> bool {
        self > o
    }
    #[inline(always)]
    fn ge(self, o: Self) -> bool {
        self >= o
    }
    #[inline(always)]
    fn eq(self, o: Self) -> bool {
        self == o
    }
    #[inline(always)]
    fn ne(self, o: Self) -> bool {
        self != o
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        if self < o {
            self
        } else {
            o
        }
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        if self > o {
            self
        } else {
            o
        }
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32::abs(self)
    }
    #[inline(always)]
    fn flip_sign(self) -> Self {
        -self
    }
    #[inline(always)]
    fn add_bits(self, delta: i32) -> Self {
        f32::from_bits(self.to_bits().wrapping_add(delta as u32))
    }
    // The scalar reference: the std functions themselves.
    #[inline(always)]
    fn next_up(self) -> Self {
        f32::next_up(self)
    }
    #[inline(always)]
    fn next_down(self) -> Self {
        f32::next_down(self)
    }
    #[inline(always)]
    fn step_towards(self, towards: Self) -> Self {
        if towards > 0.0 {
            f32::next_up(self)
        } else if towards < 0.0 {
            f32::next_down(self)
        } else {
            self
        }
    }
}

impl Mask for BVec4A {
    #[inline(always)]
    fn bits(self) -> u32 {
        self.bitmask()
    }
    #[inline(always)]
    fn from_bits(bits: u32) -> Self {
        BVec4A::new(bits & 1 != 0, bits & 2 != 0, bits & 4 != 0, bits & 8 != 0)
    }
}

impl Lane for Vec4 {
    type Mask = BVec4A;
    const WIDTH: usize = 4;
    #[inline(always)]
    fn map_f64<K: math::F64Kernel>(k: &K, a: Self, b: Self) -> (Self, Self) {
        let (x, y) = k.eval(widen(a.to_array()), widen(b.to_array()));
        (Vec4::from_array(narrow(x)), Vec4::from_array(narrow(y)))
    }
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Vec4::splat(x)
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f32) -> Self {
        Vec4::new(f(0), f(1), f(2), f(3))
    }
    #[inline(always)]
    fn lane(self, i: usize) -> f32 {
        self[i]
    }
    /// One `vpermilps` with AVX.
    #[inline(always)]
    fn broadcast(self, i: usize) -> Self {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
        {
            use std::arch::x86_64::{__m128, _mm_permutevar_ps, _mm_set1_epi32};
            let v: __m128 = self.into();
            // SAFETY: AVX is enabled (cfg above); a register permute of lanes.
            Vec4::from(unsafe { _mm_permutevar_ps(v, _mm_set1_epi32(i as i32 & 3)) })
        }
        #[cfg(not(all(target_arch = "x86_64", target_feature = "avx")))]
        {
            Vec4::splat(self[i])
        }
    }
    #[inline(always)]
    fn select(m: BVec4A, a: Self, b: Self) -> Self {
        Vec4::select(m, a, b)
    }
    #[inline(always)]
    fn lt(self, o: Self) -> BVec4A {
        self.cmplt(o)
    }
    #[inline(always)]
    fn le(self, o: Self) -> BVec4A {
        self.cmple(o)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> BVec4A {
        self.cmpgt(o)
    }
    #[inline(always)]
    fn ge(self, o: Self) -> BVec4A {
        self.cmpge(o)
    }
    #[inline(always)]
    fn eq(self, o: Self) -> BVec4A {
        self.cmpeq(o)
    }
    #[inline(always)]
    fn ne(self, o: Self) -> BVec4A {
        self.cmpne(o)
    }
    // glam's `Vec4::min`/`max` are SSE `minps`/`maxps`, which have exactly this rule;
    // without SSE, glam's scalar fallback does not, so spell it out there.
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        if cfg!(target_feature = "sse2") {
            Vec4::min(self, o)
        } else {
            Vec4::select(self.cmplt(o), self, o)
        }
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        if cfg!(target_feature = "sse2") {
            Vec4::max(self, o)
        } else {
            Vec4::select(self.cmpgt(o), self, o)
        }
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        Vec4::new(self.x.sqrt(), self.y.sqrt(), self.z.sqrt(), self.w.sqrt())
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Vec4::abs(self)
    }
    // glam's `-` flips the sign bits (an xor with −0).
    #[inline(always)]
    fn flip_sign(self) -> Self {
        -self
    }
    #[inline(always)]
    fn add_bits(self, delta: i32) -> Self {
        #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
        {
            use std::arch::x86_64::{
                __m128, _mm_add_epi32, _mm_castps_si128, _mm_castsi128_ps, _mm_set1_epi32,
            };
            let v: __m128 = self.into();
            // SAFETY: SSE2 is enabled (cfg above); these are plain register operations.
            let r = unsafe {
                _mm_castsi128_ps(_mm_add_epi32(_mm_castps_si128(v), _mm_set1_epi32(delta)))
            };
            Vec4::from(r)
        }
        #[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
        {
            Vec4::new(
                self.x.add_bits(delta),
                self.y.add_bits(delta),
                self.z.add_bits(delta),
                self.w.add_bits(delta),
            )
        }
    }
}

/// The mask of `wide::f32x8` (all bits set in a true lane).
#[derive(Clone, Copy, Debug)]
pub struct Mask8(pub f32x8);

impl BitAnd for Mask8 {
    type Output = Self;
    #[inline(always)]
    fn bitand(self, o: Self) -> Self {
        Mask8(self.0 & o.0)
    }
}

impl BitOr for Mask8 {
    type Output = Self;
    #[inline(always)]
    fn bitor(self, o: Self) -> Self {
        Mask8(self.0 | o.0)
    }
}

impl Not for Mask8 {
    type Output = Self;
    #[inline(always)]
    fn not(self) -> Self {
        Mask8(!self.0)
    }
}

impl Mask for Mask8 {
    #[inline(always)]
    fn bits(self) -> u32 {
        self.0.move_mask() as u32
    }
    #[inline(always)]
    fn from_bits(bits: u32) -> Self {
        // Broadcast, keep bit i in lane i, compare: three instructions.
        let lane_bits = i32x8::new([1, 2, 4, 8, 16, 32, 64, 128]);
        let off = (i32x8::splat(bits as i32) & lane_bits).cmp_eq(i32x8::splat(0));
        Mask8(!bytemuck::cast::<i32x8, f32x8>(off))
    }
}

impl Lane for f32x8 {
    type Mask = Mask8;
    const WIDTH: usize = 8;
    #[inline(always)]
    fn map_f64<K: math::F64Kernel>(k: &K, a: Self, b: Self) -> (Self, Self) {
        let (a, b) = (a.to_array(), b.to_array());
        let half = |v: &[f32; 8], h: usize| widen(std::array::from_fn(|i| v[4 * h + i]));
        let [(x0, y0), (x1, y1)] = k.eval2([half(&a, 0), half(&a, 1)], [half(&b, 0), half(&b, 1)]);
        let join = |lo: wide::f64x4, hi: wide::f64x4| {
            let (lo, hi) = (narrow(lo), narrow(hi));
            f32x8::new(std::array::from_fn(
                |i| if i < 4 { lo[i] } else { hi[i - 4] },
            ))
        };
        (join(x0, x1), join(y0, y1))
    }
    /// The default's tree, step for step, in vector registers: `minps` is the same
    /// `a < b ? a : b` per element.
    #[inline(always)]
    fn reduce_min(self) -> f32 {
        reduce8(self, Vec4::min, |a, b| if a < b { a } else { b })
    }
    /// As `reduce_min`, with `maxps` (`a > b ? a : b`).
    #[inline(always)]
    fn reduce_max(self) -> f32 {
        reduce8(self, Vec4::max, |a, b| if a > b { a } else { b })
    }
    #[inline(always)]
    fn splat(x: f32) -> Self {
        f32x8::splat(x)
    }
    #[inline(always)]
    fn from_fn(f: impl FnMut(usize) -> f32) -> Self {
        f32x8::new(std::array::from_fn(f))
    }
    #[inline(always)]
    fn lane(self, i: usize) -> f32 {
        self.as_array_ref()[i]
    }
    /// One `vpermps` with AVX2 (a variable lane read goes through memory).
    #[inline(always)]
    fn broadcast(self, i: usize) -> Self {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        {
            use std::arch::x86_64::{__m256, _mm256_permutevar8x32_ps, _mm256_set1_epi32};
            let v: __m256 = bytemuck::cast(self);
            // SAFETY: AVX2 is enabled (cfg above); a register permute of lanes.
            let r = unsafe { _mm256_permutevar8x32_ps(v, _mm256_set1_epi32(i as i32 & 7)) };
            bytemuck::cast(r)
        }
        #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
        {
            Self::splat(self.lane(i))
        }
    }
    #[inline(always)]
    fn select(m: Mask8, a: Self, b: Self) -> Self {
        m.0.blend(a, b)
    }
    #[inline(always)]
    fn lt(self, o: Self) -> Mask8 {
        Mask8(self.cmp_lt(o))
    }
    #[inline(always)]
    fn le(self, o: Self) -> Mask8 {
        Mask8(self.cmp_le(o))
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Mask8 {
        Mask8(self.cmp_gt(o))
    }
    #[inline(always)]
    fn ge(self, o: Self) -> Mask8 {
        Mask8(self.cmp_ge(o))
    }
    #[inline(always)]
    fn eq(self, o: Self) -> Mask8 {
        Mask8(self.cmp_eq(o))
    }
    // Not `cmp_ne`: with AVX that is the ordered compare (false when a lane is NaN),
    // without AVX the unordered one; `!=` of `f32` and glam's `cmpne` are true on NaN.
    #[inline(always)]
    fn ne(self, o: Self) -> Mask8 {
        Mask8(!self.cmp_eq(o))
    }
    // `fast_min`/`fast_max` are `vminps`/`vmaxps` (or SSE `minps`/`maxps` per half):
    // the rule above. (`wide`'s `min`/`max` return the other operand of a NaN instead.)
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        self.fast_min(o)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        self.fast_max(o)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f32x8::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32x8::abs(self)
    }
    #[inline(always)]
    fn flip_sign(self) -> Self {
        self ^ f32x8::splat(-0.0)
    }
    #[inline(always)]
    fn add_bits(self, delta: i32) -> Self {
        let bits = bytemuck::cast::<f32x8, i32x8>(self) + i32x8::splat(delta);
        bytemuck::cast::<i32x8, f32x8>(bits)
    }
}

/// Three lanes vectors: x, y and z of `WIDTH` points or directions.
#[derive(Clone, Copy, Debug)]
pub struct V3<L> {
    pub x: L,
    pub y: L,
    pub z: L,
}

impl<L: Lane> V3<L> {
    #[inline(always)]
    pub fn new(x: L, y: L, z: L) -> Self {
        Self { x, y, z }
    }
    #[inline(always)]
    pub fn splat(v: glam::Vec3) -> Self {
        Self::new(L::splat(v.x), L::splat(v.y), L::splat(v.z))
    }
    /// Lane `i` is `f(i)`.
    #[inline(always)]
    pub fn from_fn(mut f: impl FnMut(usize) -> glam::Vec3) -> Self {
        let mut xs = [glam::Vec3::ZERO; MAX_WIDTH];
        for (i, x) in xs.iter_mut().enumerate().take(L::WIDTH) {
            *x = f(i);
        }
        Self::new(
            L::from_fn(|i| xs[i].x),
            L::from_fn(|i| xs[i].y),
            L::from_fn(|i| xs[i].z),
        )
    }
    #[inline(always)]
    pub fn lane(&self, i: usize) -> glam::Vec3 {
        glam::Vec3::new(self.x.lane(i), self.y.lane(i), self.z.lane(i))
    }
    /// `(x·x + y·y) + z·z`, glam's order.
    #[inline(always)]
    pub fn dot(self, o: Self) -> L {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    /// glam's `Vec3::cross`, term for term.
    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        Self::new(
            self.y * o.z - o.y * self.z,
            self.z * o.x - o.z * self.x,
            self.x * o.y - o.x * self.y,
        )
    }
    #[inline(always)]
    pub fn scale(self, s: L) -> Self {
        Self::new(self.x * s, self.y * s, self.z * s)
    }
    #[inline(always)]
    pub fn abs(self) -> Self {
        Self::new(self.x.abs(), self.y.abs(), self.z.abs())
    }
    #[inline(always)]
    pub fn select(m: L::Mask, a: Self, b: Self) -> Self {
        Self::new(
            L::select(m, a.x, b.x),
            L::select(m, a.y, b.y),
            L::select(m, a.z, b.z),
        )
    }
}

impl<L: Lane> Add for V3<L> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

/// `Lane::flip_sign` per component (so −(+0) is −0 in every width).
impl<L: Lane> Neg for V3<L> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self::new(self.x.flip_sign(), self.y.flip_sign(), self.z.flip_sign())
    }
}

impl<L: Lane> Sub for V3<L> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

#[cfg(test)]
mod tests;
