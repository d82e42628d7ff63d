//! The bounces of the path-traced materials over lanes (the scalar `scatter` is this
//! code at `f32`): Diffuse (normal + a uniform unit vector), Metal (the mirror direction
//! plus fuzz; absorbed when that points into the surface) and Dielectric (reflect on
//! total internal reflection or with Schlick's probability, else refract by Snell's law),
//! as the original program scatters.

use super::{normalize, normalize_or_zero, onto_side, Surface, SurfaceLanes};
use crate::geometry::Ray;
use crate::lanes::math::sin_cos_turns;
use crate::lanes::{Lane, Mask, V3};
use crate::material::{reflect_lanes, schlick_lanes, Material};
use crate::sampling::{slot, KeyLanes, SampleKey};
use glam::Vec3;

/// The path-traced materials of a packet's lanes.
#[derive(Clone, Copy, Debug)]
pub(super) struct ScatterLanes<L> {
    /// Diffuse's and Metal's albedo.
    pub albedo: V3<L>,
    /// Metal's fuzz (at most 1), Dielectric's index.
    pub parameter: L,
    /// The lanes of each material.
    pub diffuse: u32,
    pub metal: u32,
    pub dielectric: u32,
}

/// The lanes' bounces.
#[derive(Clone, Copy, Debug)]
pub(super) struct Bounce<L> {
    pub attenuation: V3<L>,
    /// Unit directions.
    pub dir: V3<L>,
    /// The lanes that scatter (Metal may absorb).
    pub scattered: u32,
}

/// A uniform random unit vector per lane from two uniform numbers: z uniform in
/// [−1, 1], the azimuth uniform in [0, 2π), as the original program draws it.
#[inline(always)]
pub fn random_unit_vector_lanes<L: Lane>(xi1: L, xi2: L) -> V3<L> {
    let one = L::splat(1.0);
    let z = one - L::splat(2.0) * xi1;
    let r = (one - z * z).max(L::splat(0.0)).sqrt();
    let (sin, cos) = sin_cos_turns(xi2);
    V3::new(r * cos, r * sin, z)
}

/// The bounces of the lanes of `m`'s masks off their surfaces `s`, for rays along `dir`,
/// with the random numbers of path vertex `vertex`.
#[inline(always)]
pub(super) fn scatter_lanes<L: Lane>(
    dir: V3<L>,
    s: &SurfaceLanes<L>,
    m: &ScatterLanes<L>,
    keys: &KeyLanes,
    vertex: u32,
) -> Bounce<L> {
    // Directions are made about the shading normal; on a smooth mesh one that crosses
    // the geometric surface is reflected back across it (`onto_side`).
    let n = s.shading;
    let mut out = Bounce {
        attenuation: m.albedo,
        dir: n,
        scattered: m.diffuse,
    };
    if m.diffuse | m.metal != 0 {
        let r = random_unit_vector_lanes(
            keys.uniform::<L>(vertex, slot::SCATTER_A),
            keys.uniform::<L>(vertex, slot::SCATTER_B),
        );
        if m.diffuse != 0 {
            // Diffuse: normal + r, the normal itself if that sum vanishes.
            let d = n + r;
            let tiny = L::splat(1e-8);
            let vanishes = d.x.abs().lt(tiny) & d.y.abs().lt(tiny) & d.z.abs().lt(tiny);
            let d = V3::select(vanishes, n, normalize(d));
            let d = onto_side(d, s.normal, m.diffuse, s.smooth & m.diffuse);
            out.dir = V3::select(L::Mask::from_bits(m.diffuse), d, out.dir);
        }
        if m.metal != 0 {
            // Metal: the mirror direction plus fuzz; absorbed if it points into the
            // surface.
            let reflected = normalize(reflect_lanes(dir, n));
            let d = normalize_or_zero(reflected + r.scale(m.parameter));
            let out_of_surface = d.dot(n).gt(L::splat(0.0)).bits() & m.metal;
            let d = onto_side(d, s.normal, m.metal, s.smooth & out_of_surface);
            out.dir = V3::select(L::Mask::from_bits(m.metal), d, out.dir);
            out.scattered |= out_of_surface;
        }
    }
    if m.dielectric != 0 {
        let one = L::splat(1.0);
        let index = m.parameter;
        let front = L::Mask::from_bits(s.front);
        let ratio = L::select(front, one / index, index);
        let cos_i = dir.dot(n).flip_sign();
        let cosine = cos_i.min(one);
        let sine = (one - cosine * cosine).max(L::splat(0.0)).sqrt();
        let choice = keys.uniform::<L>(vertex, slot::SCATTER_CHOICE);
        // Reflect on total internal reflection or with Schlick's probability (evaluated
        // with the index ratio, as in the original).
        let reflects = (ratio * sine).gt(one) | schlick_lanes(cosine, ratio).gt(choice);
        // Snell's law (GLSL's refract; k < 0 is total internal reflection).
        let k = one - ratio * ratio * (one - cos_i * cos_i);
        let refracted = dir.scale(ratio) + n.scale(ratio * cos_i - k.sqrt());
        let reflect = reflects | k.lt(L::splat(0.0));
        let d = normalize(V3::select(reflect, reflect_lanes(dir, n), refracted));
        let d = onto_side(d, s.normal, reflect.bits(), s.smooth & m.dielectric);
        let lanes = L::Mask::from_bits(m.dielectric);
        out.dir = V3::select(lanes, d, out.dir);
        out.attenuation = V3::select(lanes, V3::splat(Vec3::ONE), out.attenuation);
        out.scattered |= m.dielectric;
    }
    out
}

/// The bounce of a path-traced material (Diffuse, Metal, Dielectric) at path vertex
/// `vertex`: attenuation and new direction, or `None` when Metal absorbs the ray or the
/// material does not scatter. `scatter_lanes` at `f32`.
pub fn scatter(
    material: &Material,
    ray: &Ray,
    s: &Surface,
    key: SampleKey,
    vertex: u32,
) -> Option<(Vec3, Vec3)> {
    let (albedo, parameter, class) = match *material {
        Material::Diffuse { albedo } => (albedo, 0.0, 0),
        Material::Metal { albedo, fuzz } => (albedo, fuzz, 1),
        Material::Dielectric { index } => (Vec3::ONE, index, 2),
        _ => return None,
    };
    let m = ScatterLanes::<f32> {
        albedo: V3::splat(albedo),
        parameter,
        diffuse: (class == 0) as u32,
        metal: (class == 1) as u32,
        dielectric: (class == 2) as u32,
    };
    let surface = SurfaceLanes::from_surface(s);
    let keys = KeyLanes::from_keys(&[key]);
    let b = scatter_lanes(V3::splat(ray.dir), &surface, &m, &keys, vertex);
    (b.scattered != 0).then(|| (b.attenuation.lane(0), b.dir.lane(0)))
}
