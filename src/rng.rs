//! Counter-based random numbers: every number is a pure function of
//! `(seed, pixel x, pixel y, sample index, path vertex, slot)`.
//!
//! Nothing is drawn "from a stream", so the image cannot depend on the thread count, the
//! tile order or the packet width, and the scalar and packet tracers consume exactly the
//! same numbers (`design.md` §4). The hash is Wellons' `lowbias32`: fixed shifts and
//! multiplies only, so the packet tracers can evaluate it lane-wise.

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

/// The key of one camera sample of one pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleKey(pub u32);

impl SampleKey {
    #[inline]
    pub fn new(seed: u32, x: u32, y: u32, sample: u32) -> Self {
        let h = hash_u32(hash_u32(seed).wrapping_add(x));
        let h = hash_u32(h.wrapping_add(y));
        Self(hash_u32(h.wrapping_add(sample)))
    }

    /// The uniform number in [0, 1) for `slot` at path vertex `vertex` (0 = the surface the
    /// camera ray hits; a mirror reflection or a bounce moves to the next vertex).
    #[inline]
    pub fn uniform(self, vertex: u32, slot: u32) -> f32 {
        let dim = hash_u32(hash_u32(vertex).wrapping_add(slot));
        to_unit(hash_u32(self.0 ^ dim))
    }
}

/// `SampleKey::new` for lanes of pixels (one sample index): lane i is
/// `SampleKey::new(seed, x[i], y[i], sample)`. Plain element-wise loops over arrays,
/// which the compiler turns into SIMD multiplies, shifts and xors: the same bits.
#[inline]
pub fn keys_lanes<const N: usize>(seed: u32, x: [u32; N], y: [u32; N], sample: u32) -> [u32; N] {
    let h0 = hash_u32(seed);
    let h = hash_lanes(x.map(|x| h0.wrapping_add(x)));
    let mut h2 = [0; N];
    for i in 0..N {
        h2[i] = h[i].wrapping_add(y[i]);
    }
    let h = hash_lanes(h2);
    hash_lanes(h.map(|h| h.wrapping_add(sample)))
}

/// `SampleKey::uniform` for lanes of keys.
#[inline]
pub fn uniform_lanes<const N: usize>(keys: [u32; N], vertex: u32, slot: u32) -> [f32; N] {
    let dim = hash_u32(hash_u32(vertex).wrapping_add(slot));
    hash_lanes(keys.map(|k| k ^ dim)).map(to_unit)
}

/// `hash_u32` on every element.
#[inline(always)]
pub fn hash_lanes<const N: usize>(mut x: [u32; N]) -> [u32; N] {
    for v in &mut x {
        *v ^= *v >> 16;
    }
    for v in &mut x {
        *v = v.wrapping_mul(0x7feb_352d);
    }
    for v in &mut x {
        *v ^= *v >> 15;
    }
    for v in &mut x {
        *v = v.wrapping_mul(0x846c_a68b);
    }
    for v in &mut x {
        *v ^= *v >> 16;
    }
    x
}

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
    /// Light samples: three numbers (primitive choice, two surface coordinates) for
    /// sample `k` of light `light`, starting at this slot.
    pub const LIGHT_BASE: u32 = 8;

    #[inline]
    pub fn light(light: u32, k: u32, component: u32) -> u32 {
        LIGHT_BASE + (light * super::MAX_LIGHT_SAMPLES + k) * 3 + component
    }
}

/// The most samples any light takes (area lights take 10, as in the seed).
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

    #[test]
    fn lanes_give_the_scalar_keys_and_numbers() {
        let xs: [u32; 8] = std::array::from_fn(|i| 100 + i as u32 % 4);
        let ys: [u32; 8] = std::array::from_fn(|i| 7 + i as u32 / 4);
        let keys = keys_lanes(9, xs, ys, 3);
        let us = uniform_lanes(keys, 2, slot::JITTER_Y);
        for i in 0..8 {
            let k = SampleKey::new(9, xs[i], ys[i], 3);
            assert_eq!(keys[i], k.0);
            assert_eq!(us[i].to_bits(), k.uniform(2, slot::JITTER_Y).to_bits());
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
}
