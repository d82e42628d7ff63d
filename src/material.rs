//! Materials and their scattering rules (`docs/seed-semantics.md`).
//!
//! Scene keys (`[materials.NAME]`, `type = ...`): `phong` (albedo, shininess, ka, kd, ks),
//! `phong_mirror` (albedo, shininess, index, ka, kd, ks), `diffuse` (albedo), `metal`
//! (albedo, fuzz), `dielectric` (index), `light` (color, intensity).

use crate::lanes::{Lane, V3};
use glam::Vec3;

/// Phong coefficients. The original program's defaults are ka = kd = ks = 0.5.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Phong {
    pub albedo: Vec3,
    pub shininess: f32,
    pub ka: f32,
    pub kd: f32,
    pub ks: f32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Material {
    Phong(Phong),
    /// Phong mixed with a mirror reflection by Schlick's approximation at `index`.
    PhongMirror {
        phong: Phong,
        index: f32,
    },
    Diffuse {
        albedo: Vec3,
    },
    /// `fuzz` is capped at 1 when compiled.
    Metal {
        albedo: Vec3,
        fuzz: f32,
    },
    Dielectric {
        index: f32,
    },
    /// An emitter: seen as `color`; shades others with `color · intensity`.
    Light {
        color: Vec3,
        intensity: f32,
    },
}

impl Material {
    pub fn is_path_traced(&self) -> bool {
        matches!(
            self,
            Material::Diffuse { .. } | Material::Metal { .. } | Material::Dielectric { .. }
        )
    }
}

/// Schlick's approximation of Fresnel reflectance: r0 + (1 − r0)(1 − cos θ)⁵ with
/// r0 = ((1 − n) / (1 + n))².
#[inline]
pub fn schlick(cosine: f32, index: f32) -> f32 {
    schlick_lanes::<f32>(cosine, index)
}

/// `schlick` over lanes (the scalar one is this kernel at `f32`).
#[inline(always)]
pub fn schlick_lanes<L: Lane>(cosine: L, index: L) -> L {
    let one = L::splat(1.0);
    let r0 = (one - index) / (one + index);
    let r0 = r0 * r0;
    let m = one - cosine;
    r0 + (one - r0) * (m * m * m * m * m)
}

/// Mirror reflection of `d` about the unit normal `n`.
#[inline]
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    reflect_lanes::<f32>(V3::splat(d), V3::splat(n)).lane(0)
}

/// `reflect` over lanes (the scalar one is this kernel at `f32`).
#[inline(always)]
pub fn reflect_lanes<L: Lane>(d: V3<L>, n: V3<L>) -> V3<L> {
    d - n.scale(L::splat(2.0) * d.dot(n))
}

/// GLSL-style refraction of the unit `d` through the unit `n` (facing `d`) with relative
/// index `eta`; `None` on total internal reflection.
#[inline]
pub fn refract(d: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = -d.dot(n);
    let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    if k < 0.0 {
        return None;
    }
    Some(d * eta + n * (eta * cos_i - k.sqrt()))
}

/// A uniform random unit vector from two uniform numbers (z uniform in [−1, 1], azimuth
/// uniform in [0, 2π)), as in the original program.
#[inline]
pub fn random_unit_vector(xi1: f32, xi2: f32) -> Vec3 {
    let z = 1.0 - 2.0 * xi1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * xi2;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schlick_r0_matches_the_original_table() {
        // docs/seed-semantics.md, "PhongMirror": n = 0.02, 0.1, 0.2 give r₀ = 0.9231,
        // 0.6694, 0.4444.
        for (n, r0) in [(0.02, 0.9231), (0.1, 0.6694), (0.2, 0.4444)] {
            assert!((schlick(1.0, n) - r0).abs() < 5e-5, "{n}");
        }
        assert_eq!(schlick(0.0, 1.5), 1.0);
    }

    #[test]
    fn refraction_obeys_snell() {
        let n = Vec3::Y;
        let theta_i = 0.5f32;
        let d = Vec3::new(theta_i.sin(), -theta_i.cos(), 0.0);
        let t = refract(d, n, 1.0 / 1.5).unwrap();
        let sin_t = t.x / t.length();
        assert!((sin_t - theta_i.sin() / 1.5).abs() < 1e-6);
        assert!((t.length() - 1.0).abs() < 1e-6);
        // Total internal reflection from glass at a steep angle.
        let steep = Vec3::new(0.9f32.sin(), -0.9f32.cos(), 0.0);
        assert!(refract(steep, n, 1.5).is_none());
    }

    #[test]
    fn random_unit_vectors_are_unit() {
        for (a, b) in [(0.0, 0.0), (0.5, 0.25), (0.999, 0.7)] {
            assert!((random_unit_vector(a, b).length() - 1.0).abs() < 1e-6);
        }
    }
}
