//! Counter-based random numbers: every number is a pure function of
//! `(seed, pixel x, pixel y, sample index, path vertex, slot)`.
//!
//! Nothing is drawn "from a stream", so the image cannot depend on the thread count, the
//! tile order or the packet width, and the scalar and packet tracers consume exactly the
//! same numbers (ARCHITECTURE.md, "Determinism"). The hash is Wellons' `lowbias32`:
//! fixed shifts and multiplies only, so the packet tracers can evaluate it lane-wise.
//!
//! A [`Sampler`] (`--sampler`) decides how the numbers are spread: independent (the
//! original program's), stratified (correlated multi-jittered) or Owen-scrambled Sobol.
//! The tracer asks `sampler.key(x, y, sample)` once per camera sample and then
//! `key.uniform(vertex, slot)` wherever it needs a number, whatever the kind.
//!
//! One file past 700 lines, more than half of it the tests of the three samplers'
//! distributions: the hash, the slot table and the samplers are one addressing scheme.

use crate::lanes::Lane;

/// An integer hash with good avalanche (Chris Wellons, "lowbias32").
#[inline]
pub fn hash_u32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// Map 32 random bits to a float in [0, 1) with 24 bits of precision.
#[inline]
pub fn to_unit(bits: u32) -> f32 {
    (bits >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Which numbers a render uses for pixel jitter, light samples and bounces (`--sampler`).
///
/// Every kind is a pure function of (seed, pixel, sample index, dimension) — the
/// stratified one also of the sample count — so images stay the same for any thread count,
/// tile order or packet width, and a packet tracer can evaluate it per lane.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SamplerKind {
    /// Independent hashed numbers: the original program's plain random sampling.
    Independent,
    /// Correlated multi-jittered sampling (Kensler 2013): per pixel and per pair of
    /// dimensions, the N = spp points are jittered in an m × n grid and stratified in N
    /// strata along one axis.
    Stratified,
    /// Owen-scrambled Sobol (0,2)-sequence, padded: every pair of dimensions gets its own
    /// scramble and its own shuffle of the sample index (Burley 2020), per pixel. The
    /// default: the lowest error at equal time in the error-against-time sweeps.
    #[default]
    Sobol,
}

impl SamplerKind {
    /// The lowercase name (`independent`, `stratified`, `sobol`).
    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Independent => "independent",
            SamplerKind::Stratified => "stratified",
            SamplerKind::Sobol => "sobol",
        }
    }

    /// Every kind.
    pub const ALL: [SamplerKind; 3] = [
        SamplerKind::Independent,
        SamplerKind::Stratified,
        SamplerKind::Sobol,
    ];
}

/// A sampler of one render: its kind, seed and samples per pixel. The tracer asks it for
/// the [`SampleKey`] of each camera sample and then draws numbers from the key by
/// (path vertex, slot), whatever the kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sampler {
    pub kind: SamplerKind,
    pub seed: u32,
    /// Samples per pixel (the stratified sampler divides the pixel's draws among them).
    pub spp: u32,
}

impl Sampler {
    pub fn new(kind: SamplerKind, seed: u32, spp: u32) -> Self {
        Self {
            kind,
            seed,
            spp: spp.max(1),
        }
    }

    /// The independent sampler (the original program's behaviour).
    pub fn independent(seed: u32) -> Self {
        Self::new(SamplerKind::Independent, seed, 1)
    }

    /// The key of camera sample `sample` of pixel (x, y).
    #[inline]
    pub fn key(&self, x: u32, y: u32, sample: u32) -> SampleKey {
        let pixel = pixel_hash(self.seed, x, y);
        SampleKey {
            hash: hash_u32(pixel.wrapping_add(sample)),
            pixel,
            sample,
            spp: self.spp,
            kind: self.kind,
        }
    }
}

#[inline]
fn pixel_hash(seed: u32, x: u32, y: u32) -> u32 {
    let h = hash_u32(hash_u32(seed).wrapping_add(x));
    hash_u32(h.wrapping_add(y))
}

/// The key of one camera sample of one pixel: what [`SampleKey::uniform`] needs to give
/// every (path vertex, slot) its number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleKey {
    /// hash(seed, x, y, sample): the independent sampler's key.
    pub hash: u32,
    /// hash(seed, x, y).
    pixel: u32,
    sample: u32,
    spp: u32,
    kind: SamplerKind,
}

impl SampleKey {
    /// The independent sampler's key of camera sample `sample` of pixel (x, y).
    #[inline]
    pub fn new(seed: u32, x: u32, y: u32, sample: u32) -> Self {
        Sampler::independent(seed).key(x, y, sample)
    }

    /// An independent key from its hash directly (tests: many keys cheaply).
    pub fn from_hash(hash: u32) -> Self {
        Self {
            hash,
            pixel: 0,
            sample: 0,
            spp: 1,
            kind: SamplerKind::Independent,
        }
    }

    pub fn kind(self) -> SamplerKind {
        self.kind
    }

    /// The uniform number in [0, 1) for `slot` at path vertex `vertex` (0 = the surface the
    /// camera ray hits; a mirror reflection or a bounce moves to the next vertex).
    #[inline(always)]
    pub fn uniform(self, vertex: u32, slot: u32) -> f32 {
        match self.kind {
            SamplerKind::Independent => to_unit(hash_u32(self.hash ^ dimension_hash(vertex, slot))),
            // Out of line: inlining the structured samplers into every call site kept
            // the independent sampler's few instructions from being inlined at all.
            _ => self.structured_uniform(vertex, slot),
        }
    }

    #[inline(never)]
    fn structured_uniform(self, vertex: u32, slot: u32) -> f32 {
        let d = Dimension::of(slot);
        // One scramble per pixel and pair of dimensions.
        let pair = dimension_hash(vertex, d.pair);
        let seed = hash_u32(self.pixel ^ pair);
        if self.kind == SamplerKind::Sobol {
            to_unit(sobol_owen(self.sample, seed, d.component))
        } else {
            cmj(self.sample % self.spp, self.spp, seed, d.component)
        }
    }
}

/// The keys of one camera sample (one sample index) of up to eight pixels, one a lane
/// of a packet: [`SampleKey`]s in lanes, so that [`KeyLanes::uniform`] gives every lane
/// its number at once. Lane k's numbers are those of `key(k)`, bit for bit.
#[derive(Clone, Copy, Debug)]
pub struct KeyLanes {
    /// Each lane's `SampleKey::hash` and `SampleKey::pixel`.
    hash: [u32; MAX_LANES],
    pixel: [u32; MAX_LANES],
    sample: u32,
    spp: u32,
    kind: SamplerKind,
}

/// The widest packet.
const MAX_LANES: usize = crate::lanes::MAX_WIDTH;

impl Sampler {
    /// The keys of camera sample `sample` of pixels (x\[k\], y\[k\]), k < `width`:
    /// `key(x[k], y[k], sample)` in lane k, the hashes made lane-wise.
    #[inline(always)]
    pub fn key_lanes(
        &self,
        width: usize,
        x: [u32; MAX_LANES],
        y: [u32; MAX_LANES],
        sample: u32,
    ) -> KeyLanes {
        self.key_lanes_of(width, &self.pixel_hashes(width, x, y), sample)
    }

    /// hash(seed, x\[k\], y\[k\]) in lane k < `width` (0 in the others): what every key
    /// of pixel (x\[k\], y\[k\]) starts from, the same for all its samples, so a tile
    /// makes it once a pixel (`key_lanes_of`).
    #[inline(always)]
    pub fn pixel_hashes(
        &self,
        width: usize,
        x: [u32; MAX_LANES],
        y: [u32; MAX_LANES],
    ) -> [u32; MAX_LANES] {
        let h0 = hash_u32(self.seed);
        let mut pixel = [0; MAX_LANES];
        for i in 0..width {
            pixel[i] = hash_u32(hash_u32(h0.wrapping_add(x[i])).wrapping_add(y[i]));
        }
        pixel
    }

    /// `key_lanes` of the pixels whose `pixel_hashes` are `pixel`.
    #[inline(always)]
    pub fn key_lanes_of(&self, width: usize, pixel: &[u32; MAX_LANES], sample: u32) -> KeyLanes {
        let mut hash = [0; MAX_LANES];
        for i in 0..width {
            hash[i] = hash_u32(pixel[i].wrapping_add(sample));
        }
        KeyLanes {
            hash,
            pixel: *pixel,
            sample,
            spp: self.spp,
            kind: self.kind,
        }
    }
}

impl KeyLanes {
    /// Lane k holds `keys[k]` (keys of one sample index, sample count and kind).
    pub fn from_keys(keys: &[SampleKey]) -> Self {
        let first = keys[0];
        debug_assert!(keys.len() <= MAX_LANES);
        debug_assert!(keys
            .iter()
            .all(|k| (k.sample, k.spp, k.kind) == (first.sample, first.spp, first.kind)));
        let (mut hash, mut pixel) = ([0; MAX_LANES], [0; MAX_LANES]);
        for (i, k) in keys.iter().enumerate() {
            (hash[i], pixel[i]) = (k.hash, k.pixel);
        }
        Self {
            hash,
            pixel,
            sample: first.sample,
            spp: first.spp,
            kind: first.kind,
        }
    }

    /// Lane k's key.
    #[inline]
    pub fn key(&self, k: usize) -> SampleKey {
        SampleKey {
            hash: self.hash[k],
            pixel: self.pixel[k],
            sample: self.sample,
            spp: self.spp,
            kind: self.kind,
        }
    }

    /// `key(k).uniform(vertex, slot)` in every lane k. The independent and Sobol
    /// samplers are integer multiplies, shifts and xors on every lane (vector code); the
    /// stratified one walks a permutation cycle of its own length per lane.
    #[inline(always)]
    pub fn uniform<L: Lane>(&self, vertex: u32, slot: u32) -> L {
        let mut u = [0.0f32; MAX_LANES];
        match self.kind {
            SamplerKind::Independent => {
                let dim = dimension_hash(vertex, slot);
                for (u, &h) in u.iter_mut().zip(&self.hash).take(L::WIDTH) {
                    *u = to_unit(hash_u32(h ^ dim));
                }
            }
            SamplerKind::Sobol => {
                let d = Dimension::of(slot);
                let pair = dimension_hash(vertex, d.pair);
                for (u, &p) in u.iter_mut().zip(&self.pixel).take(L::WIDTH) {
                    *u = to_unit(sobol_owen(self.sample, hash_u32(p ^ pair), d.component));
                }
            }
            SamplerKind::Stratified => self.stratified(vertex, slot, &mut u[..L::WIDTH]),
        }
        L::from_fn(|i| u[i])
    }

    /// `(uniform(vertex, slot), uniform(vertex, slot + 1))`, bit for bit, for the first
    /// slot of a pair: the Sobol sampler makes the pair's shuffled index and the pixel's
    /// scramble once for both. An area light's sample points take it (their slots are
    /// known only at run time; `cornell` with Sobol renders 7% fewer instructions). At
    /// the fixed slots (jitter, lens, bounce) two `uniform` calls already compile to the
    /// shared work: the pair measured 0.3–0.6% more instructions there (callgrind).
    #[inline(always)]
    pub fn uniform_pair<L: Lane>(&self, vertex: u32, slot: u32) -> (L, L) {
        if self.kind != SamplerKind::Sobol {
            return (self.uniform(vertex, slot), self.uniform(vertex, slot + 1));
        }
        let d = Dimension::of(slot);
        debug_assert!(d.component == 0 && Dimension::of(slot + 1).pair == d.pair);
        let pair = dimension_hash(vertex, d.pair);
        let (mut u, mut v) = ([0.0f32; MAX_LANES], [0.0f32; MAX_LANES]);
        for k in 0..L::WIDTH {
            let [a, b] = sobol_owen_pair(self.sample, hash_u32(self.pixel[k] ^ pair));
            (u[k], v[k]) = (to_unit(a), to_unit(b));
        }
        (L::from_fn(|i| u[i]), L::from_fn(|i| v[i]))
    }

    /// The stratified sampler's numbers, lane by lane (out of line: its permutations
    /// loop).
    #[inline(never)]
    fn stratified(&self, vertex: u32, slot: u32, u: &mut [f32]) {
        for (i, u) in u.iter_mut().enumerate() {
            *u = self.key(i).structured_uniform(vertex, slot);
        }
    }
}

/// The hash of (path vertex, slot) that the independent sampler xors into a key.
#[inline(always)]
fn dimension_hash(vertex: u32, slot: u32) -> u32 {
    hash_u32(hash_u32(vertex).wrapping_add(slot))
}

/// Where a slot sits among the pairs of dimensions the structured samplers stratify.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Dimension {
    /// The first slot of the pair (its identity).
    pair: u32,
    /// 0 or 1 within the pair (a one-dimensional slot is component 0 of its own pair).
    component: u32,
}

impl Dimension {
    #[inline]
    fn of(s: u32) -> Self {
        let one = |pair, component| Dimension { pair, component };
        match s {
            slot::JITTER_X | slot::JITTER_Y => one(slot::JITTER_X, s - slot::JITTER_X),
            slot::SCATTER_A | slot::SCATTER_B => one(slot::SCATTER_A, s - slot::SCATTER_A),
            slot::LENS_X | slot::LENS_Y => one(slot::LENS_X, s - slot::LENS_X),
            _ if s < slot::LIGHT_BASE => one(s, 0),
            // slot::light(light, k, c): c = 0 picks the primitive (one dimension), c = 1,
            // 2 are the point on it (a pair). Sample k of an area light lies in its own
            // cell of the light (`Light::stratum`), so each k is a pair of its own,
            // spread over the pixel's samples within that cell.
            _ => {
                let c = (s - slot::LIGHT_BASE) % 3;
                one(s + c.min(1) - c, c.saturating_sub(1))
            }
        }
    }
}

/// The Laine–Karras-style permutation with Vegdahl's constants: an Owen scramble of the
/// bits of `x` read from the least significant one (each output bit depends only on the
/// input bits below it).
#[inline(always)]
fn lk_permutation(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3d20_adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6c56);
    x ^= x.wrapping_mul(0x53a2_2864);
    x
}

/// Owen scrambling of the bits of `x` read from the most significant one (a base-2 digit
/// expansion of x / 2³²): the permutation on the reversed bits (Burley 2020, "Practical
/// hash-based Owen scrambling").
#[cfg(test)]
fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    lk_permutation(x.reverse_bits(), seed).reverse_bits()
}

/// reverse(sobol₁(reverse(r))), where sobol₁ is the second Sobol dimension: the xor of
/// the direction numbers v₀ = 2³¹, vᵢ₊₁ = vᵢ ^ (vᵢ >> 1) of the index's set bits. reverse(vᵢ)
/// has bit m set when the binomial C(i, m) is odd, which by Lucas' theorem is when m's
/// bits are a subset of i's. So with s = reverse(r), bit m of the result is the xor of
/// the bits sᵢ over the i that contain m: a superset sum over the five bits of a bit
/// position, one shift-and-xor step per bit (vector code, where a table lookup a byte
/// was a gather). `tests::dim1_reversed_is_the_direction_numbers` checks it.
#[inline(always)]
fn dim1_reversed(r: u32) -> u32 {
    let mut y = r.reverse_bits();
    y ^= (y >> 1) & 0x5555_5555;
    y ^= (y >> 2) & 0x3333_3333;
    y ^= (y >> 4) & 0x0f0f_0f0f;
    y ^= (y >> 8) & 0x00ff_00ff;
    y ^= (y >> 16) & 0x0000_ffff;
    y
}

/// Component `component` (0 or 1) of point `index` of the shuffled, Owen-scrambled 2D
/// Sobol sequence with scramble `seed`, as 32 bits of a fraction. The shuffle is itself an
/// Owen scramble of the index, so the first 2^k points are still a (0, k, 2)-net.
///
/// Computed in the bit-reversed domain, where the scrambles need no reversal: with
/// r = lk(reverse(index)) the shuffled index is reverse(r); component 0 is
/// reverse(lk(reverse(r))) and component 1 reverse(lk(reverse(sobol₁(reverse(r))))), the
/// inner part a table lookup. `tests::sobol_owen_is_the_plain_construction` checks it
/// against the construction written out.
#[inline(always)]
pub fn sobol_owen(index: u32, seed: u32, component: u32) -> u32 {
    sobol_owen_of(shuffled(index, seed), seed, component)
}

/// Both components of `sobol_owen`'s point `index`, which share the shuffled index.
#[inline(always)]
pub fn sobol_owen_pair(index: u32, seed: u32) -> [u32; 2] {
    let r = shuffled(index, seed);
    [sobol_owen_of(r, seed, 0), sobol_owen_of(r, seed, 1)]
}

/// `sobol_owen`'s shuffled index, bit-reversed: r = lk(reverse(index)).
#[inline(always)]
fn shuffled(index: u32, seed: u32) -> u32 {
    lk_permutation(index.reverse_bits(), seed)
}

/// Component `component` of the point whose shuffled index is `r` (`shuffled`).
#[inline(always)]
fn sobol_owen_of(r: u32, seed: u32, component: u32) -> u32 {
    let (bits_reversed, salt) = if component == 0 {
        (r.reverse_bits(), 0x9e37_79b9)
    } else {
        (dim1_reversed(r), 0x7f4a_7c15)
    };
    lk_permutation(bits_reversed, hash_u32(seed ^ salt)).reverse_bits()
}

/// Kensler's hash-based permutation of [0, l): element `i` under pattern `p`.
#[inline]
fn permute(mut i: u32, l: u32, p: u32) -> u32 {
    let mut w = l.wrapping_sub(1);
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    loop {
        i ^= p;
        i = i.wrapping_mul(0xe170_893d);
        i ^= p >> 16;
        i ^= (i & w) >> 4;
        i ^= p >> 8;
        i = i.wrapping_mul(0x0929_eb3f);
        i ^= p >> 23;
        i ^= (i & w) >> 1;
        i = i.wrapping_mul(1 | p >> 27);
        i = i.wrapping_mul(0x6935_fa69);
        i ^= (i & w) >> 11;
        i = i.wrapping_mul(0x74dc_b303);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0x9e50_1cc3);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0xc860_a3df);
        i &= w;
        i ^= i >> 5;
        if i < l {
            break;
        }
    }
    i.wrapping_add(p) % l
}

/// Kensler's hashed float in [0, 1).
#[inline]
fn rand_float(mut i: u32, p: u32) -> f32 {
    i ^= p;
    i ^= i >> 17;
    i ^= i >> 10;
    i = i.wrapping_mul(0xb365_34e5);
    i ^= i >> 12;
    i ^= i >> 21;
    i = i.wrapping_mul(0x93fc_4795);
    i ^= 0xdf6e_307f;
    i ^= i >> 17;
    i = i.wrapping_mul(1 | p >> 18);
    to_unit(i)
}

/// Component `component` of point `s` of `n` correlated multi-jittered samples with
/// pattern `p` (Kensler 2013, "Correlated Multi-Jittered Sampling", the version for any
/// n): x jittered in an m × ⌈n/m⌉ grid, y in n strata.
#[inline]
fn cmj(s: u32, n: u32, p: u32, component: u32) -> f32 {
    let m = ((n as f32).sqrt() as u32).max(1);
    let rows = n.div_ceil(m);
    let s = permute(s, n, p.wrapping_mul(0x5163_3e2d));
    let v = if component == 0 {
        let jy = rand_float(s, p.wrapping_mul(0x368c_c8b7));
        (s as f32 + jy) / n as f32
    } else {
        let sx = permute(s % m, m, p.wrapping_mul(0x68bc_21eb));
        let sy = permute(s / m, rows, p.wrapping_mul(0x02e5_be93));
        let jx = rand_float(s, p.wrapping_mul(0x967a_889b));
        (sx as f32 + (sy as f32 + jx) / rows as f32) / m as f32
    };
    v.min(ONE_MINUS_EPSILON)
}

/// The largest f32 below 1.
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// The fixed table of slots: which number is used for what at a path vertex.
pub mod slot {
    /// Pixel jitter (vertex 0 only).
    pub const JITTER_X: u32 = 0;
    pub const JITTER_Y: u32 = 1;
    /// Scattering: the random unit vector of Diffuse and Metal, the reflect-or-refract
    /// choice of Dielectric.
    pub const SCATTER_A: u32 = 2;
    pub const SCATTER_B: u32 = 3;
    pub const SCATTER_CHOICE: u32 = 4;
    /// The point of the lens disk a camera ray starts from (vertex 0 only; a pinhole
    /// camera draws none).
    pub const LENS_X: u32 = 5;
    pub const LENS_Y: u32 = 6;
    /// Light samples: three numbers (primitive choice, two surface coordinates) for
    /// sample `k` of light `light`, starting at this slot.
    pub const LIGHT_BASE: u32 = 8;

    #[inline]
    pub fn light(light: u32, k: u32, component: u32) -> u32 {
        LIGHT_BASE + (light * super::MAX_LIGHT_SAMPLES + k) * 3 + component
    }
}

/// The most samples any light takes (area lights take 10, as in the original program).
pub const MAX_LIGHT_SAMPLES: u32 = 10;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_range_and_determinism() {
        assert_eq!(to_unit(0), 0.0);
        assert!(to_unit(u32::MAX) < 1.0);
        let k = SampleKey::new(7, 3, 4, 5);
        assert_eq!(k, SampleKey::new(7, 3, 4, 5));
        assert_ne!(k, SampleKey::new(7, 4, 3, 5));
        assert_eq!(k.uniform(1, 2), k.uniform(1, 2));
        assert_ne!(k.uniform(1, 2), k.uniform(2, 1));
    }

    /// Every sampler's lanes hold the scalar keys and give their numbers, bit for bit,
    /// at widths 1, 4, 8 and 16.
    #[test]
    fn lanes_give_the_scalar_keys_and_numbers() {
        fn check<L: Lane>(sampler: &Sampler, x0: u32) {
            let xs: [u32; MAX_LANES] = std::array::from_fn(|i| x0 + i as u32 % 4);
            let ys: [u32; MAX_LANES] = std::array::from_fn(|i| 7 + i as u32 / 4);
            for sample in [0, 3, 17] {
                let lanes = sampler.key_lanes(L::WIDTH, xs, ys, sample);
                for i in 0..L::WIDTH {
                    assert_eq!(lanes.key(i), sampler.key(xs[i], ys[i], sample));
                }
                for (vertex, sl) in [
                    (0, slot::JITTER_Y),
                    (0, slot::LENS_X),
                    (2, slot::SCATTER_B),
                    (1, slot::light(1, 7, 2)),
                ] {
                    let us: L = lanes.uniform(vertex, sl);
                    for i in 0..L::WIDTH {
                        let want = sampler.key(xs[i], ys[i], sample).uniform(vertex, sl);
                        assert_eq!(us.lane(i).to_bits(), want.to_bits(), "{:?}", sampler.kind);
                    }
                }
                // A pair's two numbers at once are the two made apart.
                for (vertex, sl) in [
                    (0, slot::JITTER_X),
                    (0, slot::LENS_X),
                    (2, slot::SCATTER_A),
                    (1, slot::light(1, 7, 1)),
                    (3, slot::light(0, 0, 1)),
                ] {
                    let (a, b): (L, L) = lanes.uniform_pair(vertex, sl);
                    let (ua, ub): (L, L) =
                        (lanes.uniform(vertex, sl), lanes.uniform(vertex, sl + 1));
                    for i in 0..L::WIDTH {
                        assert_eq!(
                            a.lane(i).to_bits(),
                            ua.lane(i).to_bits(),
                            "{:?}",
                            sampler.kind
                        );
                        assert_eq!(
                            b.lane(i).to_bits(),
                            ub.lane(i).to_bits(),
                            "{:?}",
                            sampler.kind
                        );
                    }
                }
            }
        }
        for kind in SamplerKind::ALL {
            let sampler = Sampler::new(kind, 9, 20);
            for x0 in [0, 100, 4000] {
                check::<f32>(&sampler, x0);
                check::<glam::Vec4>(&sampler, x0);
                check::<wide::f32x8>(&sampler, x0);
                check::<crate::lanes::F32x16>(&sampler, x0);
            }
        }
    }

    /// The superset-sum `dim1_reversed` is the xor of the reversed direction numbers of
    /// the set bits, for every single bit and random words.
    #[test]
    fn dim1_reversed_is_the_direction_numbers() {
        let mut v = [0u32; 32];
        v[0] = 1 << 31;
        for i in 1..32 {
            v[i] = v[i - 1] ^ (v[i - 1] >> 1);
        }
        let plain = |r: u32| {
            (0..32)
                .filter(|j| r >> j & 1 != 0)
                .fold(0u32, |acc, j| acc ^ v[31 - j].reverse_bits())
        };
        let mut x = 0x1234_5678u32;
        for _ in 0..100_000 {
            x = hash_u32(x);
            assert_eq!(dim1_reversed(x), plain(x), "{x:#x}");
        }
        for j in 0..32 {
            assert_eq!(dim1_reversed(1 << j), plain(1 << j), "bit {j}");
        }
    }

    #[test]
    fn mean_and_variance_of_uniforms() {
        // 2^16 numbers: mean 1/2 and variance 1/12 within 4 standard errors.
        let n = 1 << 16;
        let xs: Vec<f64> = (0..n)
            .map(|i| SampleKey::new(1, i % 256, i / 256, 0).uniform(0, slot::JITTER_X) as f64)
            .collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        let se = (1.0 / 12.0 / n as f64).sqrt();
        assert!((mean - 0.5).abs() < 4.0 * se, "mean {mean}");
        assert!((var - 1.0 / 12.0).abs() < 0.002, "variance {var}");
    }

    /// The independent sampler's number written out as one chain of hashes: (seed, x, y,
    /// sample) makes the key, (vertex, slot) the dimension, and the hash of their xor the
    /// number.
    fn plain_uniform(seed: u32, x: u32, y: u32, sample: u32, vertex: u32, slot: u32) -> f32 {
        let h = hash_u32(hash_u32(seed).wrapping_add(x));
        let h = hash_u32(h.wrapping_add(y));
        let key = hash_u32(h.wrapping_add(sample));
        let dim = hash_u32(hash_u32(vertex).wrapping_add(slot));
        to_unit(hash_u32(key ^ dim))
    }

    #[test]
    fn independent_sampler_is_the_plain_hash_chain_bit_for_bit() {
        let sampler = Sampler::new(SamplerKind::Independent, 5, 64);
        for (x, y, s, v, sl) in [(0, 0, 0, 0, 0), (3, 9, 17, 2, 41), (799, 449, 49, 7, 4)] {
            let plain = plain_uniform(5, x, y, s, v, sl);
            assert_eq!(
                sampler.key(x, y, s).uniform(v, sl).to_bits(),
                plain.to_bits()
            );
            assert_eq!(
                SampleKey::new(5, x, y, s).uniform(v, sl).to_bits(),
                plain.to_bits()
            );
        }
    }

    #[test]
    fn every_sampler_stays_in_the_unit_interval() {
        for kind in SamplerKind::ALL {
            for spp in [1, 3, 16, 100] {
                let sampler = Sampler::new(kind, 9, spp);
                for s in 0..spp {
                    let key = sampler.key(4, 2, s);
                    for sl in [0, 1, 2, 3, 4, slot::light(0, 9, 2), slot::light(2, 3, 0)] {
                        let u = key.uniform(1, sl);
                        assert!((0.0..1.0).contains(&u), "{kind:?} {spp} {s} {sl}: {u}");
                    }
                }
            }
        }
    }

    #[test]
    fn light_slots_map_to_pairs() {
        let d = |l, k, c| Dimension::of(slot::light(l, k, c));
        assert_eq!(d(0, 0, 0).component, 0);
        assert_eq!((d(1, 7, 1).component, d(1, 7, 2).component), (0, 1));
        assert_eq!(d(1, 7, 1).pair, d(1, 7, 2).pair);
        assert_eq!(d(1, 7, 1).pair, slot::light(1, 7, 1));
        assert_eq!(d(1, 7, 0).pair, slot::light(1, 7, 0));
        assert_ne!(d(1, 7, 1).pair, d(1, 6, 1).pair);
        assert_ne!(d(1, 7, 1).pair, d(2, 7, 1).pair);
        assert_ne!(d(1, 9, 2).pair, d(2, 0, 0).pair);
        assert_eq!(Dimension::of(slot::JITTER_Y).pair, slot::JITTER_X);
        assert_eq!(Dimension::of(slot::SCATTER_CHOICE).component, 0);
        assert_eq!(Dimension::of(slot::LENS_Y).pair, slot::LENS_X);
        assert_eq!(Dimension::of(slot::LENS_Y).component, 1);
        assert_ne!(Dimension::of(slot::LENS_X).pair, slot::JITTER_X);
    }

    /// The points of the pair of slots `pair`, `pair + 1` (jitter or lens) of one pixel,
    /// as grid cells of a `cols` × `rows` grid.
    fn cells_of(pair: u32, kind: SamplerKind, spp: u32, cols: u32, rows: u32) -> Vec<(u32, u32)> {
        let sampler = Sampler::new(kind, 3, spp);
        (0..spp)
            .map(|s| {
                let k = sampler.key(10, 20, s);
                let x = k.uniform(0, pair);
                let y = k.uniform(0, pair + 1);
                ((x * cols as f32) as u32, (y * rows as f32) as u32)
            })
            .collect()
    }

    fn all_distinct(mut v: Vec<(u32, u32)>) -> bool {
        let n = v.len();
        v.sort();
        v.dedup();
        v.len() == n
    }

    #[test]
    fn sobol_prefixes_are_nets() {
        // The first 2^k points of every pair: one point in each elementary interval of
        // area 2^-k (a (0, k, 2)-net), and so on for every k.
        for k in 0..=6 {
            let n = 1u32 << k;
            for j in 0..=k {
                let (cols, rows) = (1 << j, 1 << (k - j));
                for pair in [slot::JITTER_X, slot::LENS_X] {
                    assert!(
                        all_distinct(cells_of(pair, SamplerKind::Sobol, n, cols, rows)),
                        "{k} {j} {pair}"
                    );
                }
            }
        }
        // An area light's sample k (a pair of its own): a pixel's 16 samples are a net,
        // as `uniform_pair` gives them too.
        for k in [0, 3, MAX_LIGHT_SAMPLES - 1] {
            let pair = slot::light(1, k, 1);
            assert!(
                all_distinct(cells_of(pair, SamplerKind::Sobol, 16, 4, 4)),
                "{k}"
            );
            let sampler = Sampler::new(SamplerKind::Sobol, 3, 16);
            for s in 0..16 {
                let key = sampler.key(10, 20, s);
                let (u, v) = KeyLanes::from_keys(&[key]).uniform_pair::<f32>(0, pair);
                assert_eq!((u, v), (key.uniform(0, pair), key.uniform(0, pair + 1)));
            }
        }
    }

    #[test]
    fn stratified_fills_its_strata() {
        for pair in [slot::JITTER_X, slot::LENS_X, slot::light(1, 4, 1)] {
            let cells = |spp, cols, rows| cells_of(pair, SamplerKind::Stratified, spp, cols, rows);
            for n in [1, 2, 7, 10, 16, 25] {
                // Component 0 (x here): one point per 1/n stratum.
                assert!(all_distinct(cells(n, n, 1)), "{n} {pair}");
                // Component 1 (y): one point per cell of the m × ⌈n/m⌉ fine grid.
                let m = (n as f32).sqrt() as u32;
                let fine = m * n.div_ceil(m);
                assert!(all_distinct(cells(n, 1, fine)), "{n} {pair}");
                // x, y: one point per coarse cell of an m × m grid when n = m².
                if m * m == n {
                    assert!(all_distinct(cells(n, m, m)), "{n} {pair}");
                }
            }
        }
    }

    /// The lens pair has its own numbers: not the jitter's, for any sampler.
    #[test]
    fn lens_and_jitter_pairs_differ() {
        for kind in SamplerKind::ALL {
            let sampler = Sampler::new(kind, 5, 16);
            let same = (0..16)
                .filter(|&s| {
                    let k = sampler.key(3, 4, s);
                    k.uniform(0, slot::LENS_X) == k.uniform(0, slot::JITTER_X)
                        || k.uniform(0, slot::LENS_Y) == k.uniform(0, slot::JITTER_Y)
                })
                .count();
            assert_eq!(same, 0, "{kind:?}");
        }
    }

    #[test]
    fn structured_samplers_depend_on_pixel_and_seed() {
        for kind in [SamplerKind::Stratified, SamplerKind::Sobol] {
            let u = |seed, x| Sampler::new(kind, seed, 4).key(x, 0, 1).uniform(0, 0);
            assert_ne!(u(0, 0), u(0, 1));
            assert_ne!(u(0, 0), u(1, 0));
        }
    }

    /// The second Sobol dimension by its direction numbers.
    fn sobol_dim1(mut index: u32) -> u32 {
        let (mut r, mut v) = (0u32, 1u32 << 31);
        while index != 0 {
            if index & 1 != 0 {
                r ^= v;
            }
            index >>= 1;
            v ^= v >> 1;
        }
        r
    }

    #[test]
    fn sobol_owen_is_the_plain_construction() {
        // Burley's listing: shuffle the index, take the Sobol point, scramble each axis.
        let plain = |index: u32, seed: u32, component: u32| {
            let i = nested_uniform_scramble(index, seed);
            if component == 0 {
                nested_uniform_scramble(i.reverse_bits(), hash_u32(seed ^ 0x9e37_79b9))
            } else {
                nested_uniform_scramble(sobol_dim1(i), hash_u32(seed ^ 0x7f4a_7c15))
            }
        };
        // The first points of dimension 1: 0, 1/2, 3/4, 1/4.
        assert_eq!(sobol_dim1(1), 1 << 31);
        assert_eq!(sobol_dim1(2), 3 << 30);
        assert_eq!(sobol_dim1(3), 1 << 30);
        for seed in [0, 1, 0xdead_beef, u32::MAX] {
            for i in (0..2048).chain([u32::MAX, 0x8000_0001, 0x1234_5678]) {
                for c in [0, 1] {
                    assert_eq!(sobol_owen(i, seed, c), plain(i, seed, c), "{i} {seed} {c}");
                }
            }
        }
    }
}
