//! f64 oracles of the intersection kernels, on their exact f32 inputs: f64 vector maths,
//! the sphere's roots, the quad's and the triangle's plane hits, the slab test's entry and
//! exit, grazing directions, and the bounds on the f32 kernels' error that the tests
//! allow (`planar_tol`, `sphere_tol`).
//!
//! The inputs are widened to f64 and run through the textbook formulas, so the answers are
//! the exact answers for the f32 geometry to far better than the f32 tolerances the tests
//! use.

use glam::Vec3;
use raytracer::geometry::{Aabb, Ray};

/// f32's machine epsilon, in f64.
pub const EPS: f64 = f32::EPSILON as f64;

/// Relative tolerance on t for well-conditioned cases.
pub const REL_TOL: f64 = 1e-5;

pub type D3 = [f64; 3];

pub fn d3(v: Vec3) -> D3 {
    [v.x as f64, v.y as f64, v.z as f64]
}

pub fn sub(a: D3, b: D3) -> D3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub fn add(a: D3, b: D3) -> D3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub fn scale(a: D3, s: f64) -> D3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

pub fn dot(a: D3, b: D3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn cross(a: D3, b: D3) -> D3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub fn norm(a: D3) -> f64 {
    dot(a, a).sqrt()
}

/// `a` scaled to unit length.
pub fn unit(a: D3) -> D3 {
    scale(a, 1.0 / norm(a))
}

/// |v|₁ of an f32 vector, in f64: the scale of its coordinates' rounding errors.
pub fn l1(v: Vec3) -> f64 {
    d3(v).iter().map(|x| x.abs()).sum()
}

/// |t − reference| / |reference|.
pub fn rel_err(t: f32, reference: f64) -> f64 {
    (t as f64 - reference).abs() / reference.abs()
}

/// The direction making angle `theta` with a plane: `cos θ · along + sin θ · normal`
/// (`along` a unit vector in the plane, `normal` the unit normal), in f64, then rounded and
/// renormalised in f32 (as every renderer ray).
pub fn grazing_dir(along: D3, normal: D3, theta: f64) -> Vec3 {
    let d = add(scale(along, theta.cos()), scale(normal, theta.sin()));
    Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32).normalize()
}

/// Bound on the relative error of t where a ray from `origin` meets a plane through
/// `anchor` (a quad corner or triangle vertex) at angle θ, sin θ = `sin`.
///
/// The planar kernels round positions before anything else: the quad subtracts n · o from
/// its f32 plane offset n · Q, the triangle subtracts the origin from each vertex. So their
/// t is the exact answer for points moved by a few ulps of the coordinates, and moving a
/// point by δ across the plane moves the hit by δ / sin θ along the ray. The bound takes
/// δ = 2 · f32::EPSILON · (|o|₁ + |Q|₁ + t), and is never below `REL_TOL`. It exceeds
/// `REL_TOL` only for oblique rays or origins close to the plane compared with their
/// distance from the world origin: in `tests/primitives.rs`'s random comparisons, for
/// about one hit in ten (up to ~200 times `REL_TOL` just above their 1e-3 rad cut-off).
pub fn planar_tol(origin: Vec3, anchor: Vec3, t: f64, sin: f64) -> f64 {
    REL_TOL.max(2.0 * EPS * (1.0 + (l1(origin) + l1(anchor)) / t.abs()) / sin)
}

/// Bound on the relative error of a sphere hit at distance `t` (`dist` = |o − c|, sin θ the
/// angle between the ray and the surface). The kernel's squared distance between the centre
/// and the ray's line carries an absolute error of a few ulps of |o − c|, which the square
/// root of the discriminant divides by sin θ near tangency. Above `REL_TOL` only for rays
/// within a few degrees of tangency.
pub fn sphere_tol(dist: f64, t: f64, sin: f64) -> f64 {
    REL_TOL.max(2.0 * EPS * dist / (t.abs() * sin))
}

/// The roots of |o + t d − c|² = r² along a ray that meets the sphere.
#[derive(Clone, Copy, Debug)]
pub struct SphereRoots {
    /// The near and the far root, t0 ≤ t1.
    pub t0: f64,
    pub t1: f64,
    /// Sine of the angle between the ray and the surface at the hits.
    pub sin: f64,
    /// Distance of the ray's line from the centre, relative to r (< 1 for a hit, 1 at
    /// tangency).
    pub off: f64,
}

impl SphereRoots {
    /// The first root in front of the origin (t > 0).
    pub fn first(&self) -> f64 {
        if self.t0 > 0.0 {
            self.t0
        } else {
            self.t1
        }
    }
}

/// The roots of |o + t d − c|² = r², or None when the ray's line misses the sphere. The
/// discriminant comes from the line's perpendicular distance p from the centre,
/// a (r² − p²) with a = d · d, which keeps its precision for small or distant spheres.
pub fn sphere_roots(center: Vec3, radius: f32, ray: &Ray) -> Option<SphereRoots> {
    let (o, d, c, r) = (d3(ray.origin), d3(ray.dir), d3(center), radius as f64);
    let f = sub(o, c);
    let a = dot(d, d);
    let b = dot(f, d);
    let perp = sub(f, d.map(|x| x * b / a));
    let p2 = dot(perp, perp);
    if p2 > r * r {
        return None;
    }
    let h = (a * (r * r - p2)).sqrt();
    Some(SphereRoots {
        t0: (-b - h) / a,
        t1: (-b + h) / a,
        sin: h / (a.sqrt() * r),
        off: p2.sqrt() / r,
    })
}

/// A ray's hit on the plane of a quad or triangle.
#[derive(Clone, Copy, Debug)]
pub struct PlaneHit {
    pub t: f64,
    /// Signed distance to the boundary in parameter space: min(α, 1 − α, β, 1 − β) for a
    /// quad, the smallest barycentric for a triangle. ≥ 0 means inside.
    pub margin: f64,
    /// Sine of the angle between the ray and the plane.
    pub sin: f64,
}

/// The quad Q + α u + β v: the plane's t = n·(Q − o) / n·d with n = u × v, then α, β from
/// the hit point. None for a ray parallel to the plane.
pub fn quad_oracle(corner: Vec3, u: Vec3, v: Vec3, ray: &Ray) -> Option<PlaneHit> {
    let (q, u, v, o, d) = (d3(corner), d3(u), d3(v), d3(ray.origin), d3(ray.dir));
    let n = cross(u, v);
    let nn = dot(n, n);
    let denom = dot(n, d);
    if denom == 0.0 {
        return None;
    }
    let t = dot(n, sub(q, o)) / denom;
    let hp = sub(add(o, scale(d, t)), q);
    let alpha = dot(n, cross(hp, v)) / nn;
    let beta = dot(n, cross(u, hp)) / nn;
    Some(PlaneHit {
        t,
        margin: alpha.min(1.0 - alpha).min(beta).min(1.0 - beta),
        sin: denom.abs() / (nn.sqrt() * norm(d)),
    })
}

/// The triangle (a, b, c): the plane's t, then barycentrics as signed sub-areas over the
/// full area. None for a ray parallel to the plane.
pub fn triangle_oracle([a, b, c]: [Vec3; 3], ray: &Ray) -> Option<PlaneHit> {
    let (a, b, c, o, d) = (d3(a), d3(b), d3(c), d3(ray.origin), d3(ray.dir));
    let n = cross(sub(b, a), sub(c, a));
    let nn = dot(n, n);
    let denom = dot(n, d);
    if denom == 0.0 {
        return None;
    }
    let t = dot(n, sub(a, o)) / denom;
    let p = add(o, scale(d, t));
    let la = dot(n, cross(sub(c, b), sub(p, b))) / nn;
    let lb = dot(n, cross(sub(a, c), sub(p, c))) / nn;
    let lc = dot(n, cross(sub(b, a), sub(p, a))) / nn;
    Some(PlaneHit {
        t,
        margin: la.min(lb).min(lc),
        sin: denom.abs() / (nn.sqrt() * norm(d)),
    })
}

/// The slab test's entry and exit distances in f64, clipped to [t_min, t_max], a zero
/// direction component leaving its axis unconstrained when the origin is within the
/// closed slab and missing otherwise. The ray overlaps the box iff entry ≤ exit.
pub fn slab_oracle(b: &Aabb, ray: &Ray, t_min: f32, t_max: f32) -> (f64, f64) {
    let (lo, hi, o, d) = (d3(b.min), d3(b.max), d3(ray.origin), d3(ray.dir));
    let (mut enter, mut exit) = (t_min as f64, t_max as f64);
    for i in 0..3 {
        if d[i] == 0.0 {
            if o[i] < lo[i] || o[i] > hi[i] {
                return (f64::INFINITY, f64::NEG_INFINITY);
            }
        } else {
            let (t1, t2) = ((lo[i] - o[i]) / d[i], (hi[i] - o[i]) / d[i]);
            enter = enter.max(t1.min(t2));
            exit = exit.min(t1.max(t2));
        }
    }
    (enter, exit)
}
