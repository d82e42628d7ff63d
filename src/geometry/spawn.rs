//! Robust secondary-ray origins (pbrt-v4 style): instead of the original program's fixed
//! t_min = 1e-4, each hit point is recomputed from the primitive's own parameters, bounded
//! in its floating-point error, and a new ray starts just outside that error box, on the
//! side it leaves to. This avoids self-intersection at any distance from the origin (a
//! fixed epsilon causes acne far away) and keeps contact shadows at small scales (a fixed
//! epsilon eats them).

use super::Ray;
use crate::lanes::{Lane, V3};
use glam::Vec3;

/// γₙ = nε / (1 − nε), ε = 2⁻²⁴: the bound on the relative error of n f32 operations.
#[inline]
pub const fn gamma(n: u32) -> f32 {
    let e = f32::EPSILON * 0.5;
    (n as f32 * e) / (1.0 - n as f32 * e)
}

/// A hit point and a componentwise bound on its rounding error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorPoint {
    pub point: Vec3,
    pub error: Vec3,
}

/// The points of a sphere that rays hit, pushed back onto the sphere (C + f · r/|f|, f the
/// hit point's offset from the centre), their error bounds and the outward unit normals
/// there; the scalar tracer runs it at `f32`.
///
/// The normal is f / |f|, a unit vector within a few ulps wherever the sphere is, and
/// not (P − C) / r: P's rounding error, up to half an ulp of its coordinates, is no
/// smaller for a small sphere far from the origin, and (P − C) / r then strays from
/// unit length by as much as that error over r (3e-4 for r = 0.1 at x = 1000), which a
/// high shininess turns into a wrong highlight (`integrator::specular_cosine`). +y where
/// there is no direction (f = 0, or r not positive).
#[inline(always)]
pub fn sphere_point_lanes<L: Lane>(center: V3<L>, radius: L, hit: V3<L>) -> (V3<L>, V3<L>, V3<L>) {
    let f = hit - center;
    let len = f.dot(f).sqrt();
    let zero = L::splat(0.0);
    let away = len.gt(zero);
    let normal = V3::select(
        away & radius.gt(zero),
        f.scale(L::splat(1.0) / len),
        V3::splat(Vec3::Y),
    );
    let f = V3::select(away, f.scale(radius / len), f);
    (
        center + f,
        (f.abs() + center.abs()).scale(L::splat(gamma(6))),
        normal,
    )
}

/// The point of a plane through `q` spanned by `u`, `v` (a quad, or a triangle with
/// u = b − a, v = c − a) nearest to `hit`, rebuilt as Q + α u + β v so that its error no
/// longer depends on the ray's length. `w` = (u × v) / |u × v|².
#[inline]
pub fn planar_point(q: Vec3, u: Vec3, v: Vec3, w: Vec3, hit: Vec3) -> ErrorPoint {
    let (point, error) = planar_point_lanes::<f32>(
        V3::splat(q),
        V3::splat(u),
        V3::splat(v),
        V3::splat(w),
        V3::splat(hit),
    );
    ErrorPoint {
        point: point.lane(0),
        error: error.lane(0),
    }
}

/// `planar_point` over lanes (the scalar one is this kernel at `f32`).
#[inline(always)]
pub fn planar_point_lanes<L: Lane>(
    q: V3<L>,
    u: V3<L>,
    v: V3<L>,
    w: V3<L>,
    hit: V3<L>,
) -> (V3<L>, V3<L>) {
    let hp = hit - q;
    let alpha = w.dot(hp.cross(v));
    let beta = w.dot(u.cross(hp));
    let (au, bv) = (u.scale(alpha), v.scale(beta));
    (
        q + au + bv,
        (q.abs() + au.abs() + bv.abs()).scale(L::splat(gamma(7))),
    )
}

/// A ray from `p` along `dir` whose origin is moved off the surface with unit normal `n`
/// by the error bound, to the side `dir` points to, and rounded away from the surface.
#[inline]
pub fn spawn_ray(p: &ErrorPoint, n: Vec3, dir: Vec3) -> Ray {
    let o = spawn_origin::<f32>(
        V3::splat(p.point),
        V3::splat(p.error),
        V3::splat(n),
        V3::splat(dir),
    );
    Ray::new(o.lane(0), dir)
}

/// `spawn_ray`'s origin over lanes (the scalar one is this kernel at `f32`): `point`
/// with error bound `error`, unit normal `n`, direction `dir`.
#[inline(always)]
pub fn spawn_origin<L: Lane>(point: V3<L>, error: V3<L>, n: V3<L>, dir: V3<L>) -> V3<L> {
    let offset = spawn_offset(error, n);
    let offset = V3::select(dir.dot(n).lt(L::splat(0.0)), -offset, offset);
    step_out(point, offset)
}

/// `spawn_origin`'s two answers, for directions on the side `n` points to and on the
/// other (a direction d takes the second where d · n < 0): the same operations, so the
/// same bits, for the many shadow rays an area light sends from one point.
#[inline(always)]
pub fn spawn_origins<L: Lane>(point: V3<L>, error: V3<L>, n: V3<L>) -> [V3<L>; 2] {
    let offset = spawn_offset(error, n);
    [step_out(point, offset), step_out(point, -offset)]
}

/// The normal scaled by the error bound's extent along it.
#[inline(always)]
fn spawn_offset<L: Lane>(error: V3<L>, n: V3<L>) -> V3<L> {
    n.scale(n.abs().dot(error))
}

/// `point` moved by `offset`, then a further ulp the same way on each axis.
#[inline(always)]
fn step_out<L: Lane>(point: V3<L>, offset: V3<L>) -> V3<L> {
    let o = point + offset;
    V3::new(
        o.x.step_towards(offset.x),
        o.y.step_towards(offset.y),
        o.z.step_towards(offset.z),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::lane_check::{check, out, v3, Kernel};

    #[test]
    fn gamma_values() {
        assert!(gamma(1) > 5.9e-8 && gamma(1) < 6.0e-8);
        assert!(gamma(7) > 7.0 * 5.96e-8);
    }

    #[test]
    fn spawned_origin_is_on_the_requested_side() {
        let p = ErrorPoint {
            point: Vec3::new(1000.0, 0.0, 0.0),
            error: Vec3::splat(1e-3),
        };
        let up = spawn_ray(&p, Vec3::X, Vec3::new(1.0, 1.0, 0.0).normalize());
        assert!(up.origin.x > 1000.001);
        let down = spawn_ray(&p, Vec3::X, Vec3::new(-1.0, 1.0, 0.0).normalize());
        assert!(down.origin.x < 999.999);
    }

    /// `spawn_origins` gives `spawn_origin`'s bits for every direction, the first
    /// where d · n ≥ 0 (d · n = −0 included), the second where d · n < 0; over 8-wide
    /// lanes, with points near and far from the origin, zero error bounds and normals
    /// along an axis.
    #[test]
    fn both_sides_are_the_origins_of_each_direction() {
        use wide::f32x8;
        let mut x = 0x2f6b_9a31u32;
        let mut next = || {
            x = crate::sampling::hash_u32(x);
            x as f32 / u32::MAX as f32 * 2.0 - 1.0
        };
        let (mut front, mut back) = (0, 0);
        for round in 0..4000 {
            let scale = [1e-3f32, 1.0, 1e3, 1e5][round % 4];
            let mut v = |s: f32| V3::<f32x8>::from_fn(|_| Vec3::new(next(), next(), next()) * s);
            let point = v(scale);
            let error = if round % 5 == 0 {
                v(0.0)
            } else {
                v(scale * 1e-6).abs()
            };
            let n: V3<f32x8> = match round % 7 {
                0 => V3::splat(Vec3::Y),
                1 => V3::splat(Vec3::NEG_Z),
                _ => V3::from_fn(|k| v(1.0).lane(k).normalize_or(Vec3::X)),
            };
            let dir = v(1.0);
            let dir = if round % 11 == 0 {
                // Directions in the surface: d · n = ±0.
                V3::new(-n.y, n.x, f32x8::ZERO)
            } else {
                dir
            };
            let [f, b] = spawn_origins(point, error, n);
            let want = spawn_origin(point, error, n, dir);
            let d_dot_n = dir.dot(n);
            for k in 0..8 {
                let side = if d_dot_n.lane(k) < 0.0 { &b } else { &f };
                assert_eq!(
                    side.lane(k).to_array().map(f32::to_bits),
                    want.lane(k).to_array().map(f32::to_bits)
                );
                if d_dot_n.lane(k) < 0.0 {
                    back += 1
                } else {
                    front += 1
                }
            }
        }
        assert!(front > 10_000 && back > 10_000, "{front} {back}");
    }

    /// The normal is a unit vector within 5u (u = 2⁻²⁴) and points from the centre to
    /// the hit within 8u, f64 oracle, for small spheres far from the origin too, where
    /// (P − C) / r strayed from unit length by 1e-4 and more.
    #[test]
    fn sphere_normals_are_unit_far_from_the_origin() {
        let u = f32::EPSILON as f64 / 2.0;
        let mut x = 0x9e37_79b9u32;
        let mut next = || {
            x = crate::sampling::hash_u32(x);
            x as f64 / u32::MAX as f64 * 2.0 - 1.0
        };
        let mut worst_old = 0.0f64;
        for offset in [0.0, 1.0, 1e3, 1e4] {
            for radius in [1e-3f32, 0.1, 1.0, 100.0] {
                for _ in 0..2000 {
                    let c = Vec3::new(offset as f32, -(offset as f32), 0.5 * offset as f32);
                    let d = glam::DVec3::new(next(), next(), next()).normalize();
                    let hit = (c.as_dvec3() + d * radius as f64).as_vec3();
                    let v = V3::<f32>::splat;
                    let (p, _, n) = sphere_point_lanes(v(c), radius, v(hit));
                    let n = n.lane(0).as_dvec3();
                    assert!((n.length() - 1.0).abs() <= 5.0 * u, "|n| = {}", n.length());
                    let want = (hit.as_dvec3() - c.as_dvec3()).normalize();
                    assert!((n - want).length() <= 8.0 * u, "{n} against {want}");
                    let old = (p.lane(0) - c).as_dvec3();
                    worst_old = worst_old.max((old.length() / radius as f64 - 1.0).abs());
                }
            }
        }
        assert!(worst_old > 1e-4, "(P − C) / r strays by {worst_old} only");
    }

    #[test]
    fn sphere_point_and_normal_lanes_match_the_scalar_kernels() {
        struct K;
        impl Kernel for K {
            const IN: usize = 7;
            fn eval<L: Lane>(x: &[L]) -> Vec<L> {
                let (c, r, hit) = (v3(x), x[3], v3(&x[4..]));
                let (p, e, n) = sphere_point_lanes(c, r, hit);
                out(&[p, e, n])
            }
        }
        check::<K>("sphere_point_lanes");
    }

    #[test]
    fn planar_point_lanes_match_the_scalar_kernel() {
        struct K;
        impl Kernel for K {
            const IN: usize = 15;
            fn eval<L: Lane>(x: &[L]) -> Vec<L> {
                let v = |i: usize| v3(&x[3 * i..]);
                let (p, e) = planar_point_lanes(v(0), v(1), v(2), v(3), v(4));
                out(&[p, e])
            }
        }
        check::<K>("planar_point");
    }

    #[test]
    fn spawn_origin_lanes_match_the_scalar_kernel() {
        struct K;
        impl Kernel for K {
            const IN: usize = 12;
            fn eval<L: Lane>(x: &[L]) -> Vec<L> {
                let v = |i: usize| v3(&x[3 * i..]);
                // Error bounds are small and not negative, as the hit points give them.
                let e = v(1);
                let small = L::splat(1e-6);
                let error = V3::new(e.x.abs() * small, e.y.abs() * small, e.z.abs() * small);
                out(&[spawn_origin(v(0), error, v(2), v(3))])
            }
        }
        check::<K>("spawn_origin");
        // The scalar `spawn_ray` is the kernel at f32: its origin moves off the surface.
        let p = ErrorPoint {
            point: Vec3::new(0.5, 0.0, -0.0),
            error: Vec3::new(1e-7, 0.0, 1e-7),
        };
        let r = spawn_ray(&p, Vec3::Z, Vec3::new(0.0, 0.6, 0.8));
        assert_eq!(r.origin.x, 0.5);
        assert!(r.origin.z > 0.0);
    }
}
