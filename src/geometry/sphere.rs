//! Spheres: pool, bounds, intersection, normal.
//!
//! Scene keys (read in `scene::desc`): `center`, `radius`.

use super::{Aabb, Ray};
use crate::lanes::{Lane, Mask, V3};
use glam::{Vec3, Vec3A, Vec4};

/// Spheres, structure-of-arrays. The columns are private and always of one length
/// (`push`, `permute` and `set` keep them so), so the accessors of sphere `i` check `i`
/// once, not once a column: a bounds check a column cost `spheres`' 8-wide render 2.8%
/// more instructions and `mixed`'s 3.6% (callgrind).
#[derive(Clone, Debug, Default)]
pub struct SpherePool {
    cx: Vec<f32>,
    cy: Vec<f32>,
    cz: Vec<f32>,
    radius: Vec<f32>,
    /// Scene-wide primitive id (closest-hit tie-breaker).
    id: Vec<u32>,
    /// The scene object each sphere belongs to.
    object: Vec<u32>,
}

impl SpherePool {
    pub fn len(&self) -> usize {
        self.radius.len()
    }

    pub fn is_empty(&self) -> bool {
        self.radius.is_empty()
    }

    pub fn push(&mut self, center: Vec3, radius: f32, id: u32, object: u32) {
        self.cx.push(center.x);
        self.cy.push(center.y);
        self.cz.push(center.z);
        self.radius.push(radius);
        self.id.push(id);
        self.object.push(object);
    }

    /// Reorder (see `geometry::permute`).
    pub fn permute(&mut self, order: &[u32]) {
        for v in [&mut self.cx, &mut self.cy, &mut self.cz, &mut self.radius] {
            super::permute(v, order);
        }
        super::permute(&mut self.id, order);
        super::permute(&mut self.object, order);
    }

    /// Move and resize sphere `i`.
    pub fn set(&mut self, i: usize, center: Vec3, radius: f32) {
        (self.cx[i], self.cy[i], self.cz[i]) = (center.x, center.y, center.z);
        self.radius[i] = radius;
    }

    /// Entry `i` of one of the pool's columns, checked against the pool's length only.
    #[inline(always)]
    fn at<T: Copy>(&self, column: &[T], i: usize) -> T {
        assert!(i < self.len());
        debug_assert_eq!(column.len(), self.len());
        // SAFETY: every column has `len()` entries (the type's invariant, above).
        unsafe { *column.get_unchecked(i) }
    }

    #[inline]
    pub fn center(&self, i: usize) -> Vec3 {
        Vec3::new(
            self.at(&self.cx, i),
            self.at(&self.cy, i),
            self.at(&self.cz, i),
        )
    }

    #[inline]
    pub fn radius(&self, i: usize) -> f32 {
        self.at(&self.radius, i)
    }

    /// Sphere `i`'s scene-wide primitive id.
    #[inline]
    pub fn id(&self, i: usize) -> u32 {
        self.at(&self.id, i)
    }

    /// The object sphere `i` belongs to.
    #[inline]
    pub fn object(&self, i: usize) -> u32 {
        self.at(&self.object, i)
    }

    /// The columns: cx, cy, cz and radius; id; object. (Destructured: the fingerprint
    /// of a scene, `farm::part`, hashes what this returns, and a new column cannot be
    /// left out of it unseen.)
    pub fn columns(&self) -> ([&[f32]; 4], &[u32], &[u32]) {
        let SpherePool {
            cx,
            cy,
            cz,
            radius,
            id,
            object,
        } = self;
        ([cx, cy, cz, radius], id, object)
    }

    /// The ids column.
    pub fn ids(&self) -> &[u32] {
        &self.id
    }

    /// The objects column.
    pub fn objects(&self) -> &[u32] {
        &self.object
    }

    pub fn bounds(&self, i: usize) -> Aabb {
        let r = Vec3::splat(self.radius(i));
        Aabb::new(self.center(i) - r, self.center(i) + r)
    }

    /// Distance to sphere `i` in `[t_min, t_max]`: the near root if it is in range, else the
    /// far root (the original program's rule, so a ray starting inside hits the far wall).
    #[inline]
    pub fn intersect(&self, i: usize, ray: &SphereRay, t_min: f32, t_max: f32) -> Option<f32> {
        sphere_intersect_with(self.center(i), self.radius(i), ray, t_min, t_max)
    }
}

impl SpherePool {
    /// Spheres `start..start + n` (n ≤ 4) against one ray in one `Vec4` pass of
    /// `sphere_distance`, lane for lane the scalar test's operations, so the same bits.
    /// Returns the distances and the mask of lanes that hit in `[t_min, t_max]`.
    ///
    /// Tested with one `t_max` for all four where the one-at-a-time loop shrinks it after
    /// each hit: the caller keeps a lane only if its t is still ≤ the current `t_max`,
    /// which gives the loop's answer (a lower `t_max` can only turn the near root into a
    /// miss, never into the far root: the far root is not nearer).
    #[inline(always)]
    pub fn intersect4(
        &self,
        start: usize,
        n: usize,
        ray: &SphereRay,
        t_min: f32,
        t_max: f32,
    ) -> ([f32; 4], u32) {
        use super::triangle::load4;
        let center = V3::new(
            load4(&self.cx, start, n),
            load4(&self.cy, start, n),
            load4(&self.cz, start, n),
        );
        let (t, hit) = sphere_distance(
            center,
            load4(&self.radius, start, n),
            V3::splat(ray.origin.into()),
            V3::splat(ray.dir.into()),
            Vec4::splat(ray.a),
            Vec4::splat(ray.inv_a),
            Vec4::splat(t_min),
            Vec4::splat(t_max),
        );
        (t.to_array(), hit.bitmask() & ((1u32 << n) - 1))
    }
}

/// Per-ray constants of the sphere test: d·d and its reciprocal, computed once per ray
/// instead of a division per sphere.
#[derive(Clone, Copy, Debug)]
pub struct SphereRay {
    /// 16-byte vectors, each stored and loaded whole: as `Vec3`s, stored a float at a
    /// time, the tests' loads of two floats at once missed store-to-load forwarding
    /// (the scalar tracer's shadow and closest-hit tests, perf).
    pub origin: Vec3A,
    pub dir: Vec3A,
    pub a: f32,
    pub inv_a: f32,
}

impl SphereRay {
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let a = ray.dir.dot(ray.dir);
        Self {
            origin: ray.origin.into(),
            dir: ray.dir.into(),
            a,
            inv_a: 1.0 / a,
        }
    }
}

/// Numerically stable ray/sphere intersection (Haines et al., Ray Tracing Gems ch. 7).
///
/// The discriminant is computed from the squared distance between the centre and the
/// ray's line (`r² − |f − (f·d/d·d) d|²`) instead of `b² − 4ac`, which cancels
/// catastrophically for small or distant spheres; the roots come from the stable
/// `q = −(b + sign(b)·√Δ)` form.
#[inline]
pub fn sphere_intersect(
    center: Vec3,
    radius: f32,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
) -> Option<f32> {
    sphere_intersect_with(center, radius, &SphereRay::new(ray), t_min, t_max)
}

/// `sphere_intersect` with the per-ray constants computed once. Requires `t_min ≥ 0`
/// (every ray of the renderer starts at t > 0): the early exit below assumes it.
#[inline]
pub fn sphere_intersect_with(
    center: Vec3,
    radius: f32,
    ray: &SphereRay,
    t_min: f32,
    t_max: f32,
) -> Option<f32> {
    let (t, hit) = sphere_distance(
        V3::splat(center),
        radius,
        V3::splat(ray.origin.into()),
        V3::splat(ray.dir.into()),
        ray.a,
        ray.inv_a,
        t_min,
        t_max,
    );
    hit.then_some(t)
}

/// The sphere test over lanes (the scalar test above is its one-lane case): the near
/// root if it is in `[t_min, t_max]`, else the far root.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn sphere_distance<L: Lane>(
    center: V3<L>,
    radius: L,
    origin: V3<L>,
    dir: V3<L>,
    a: L,
    inv_a: L,
    t_min: L,
    t_max: L,
) -> (L, L::Mask) {
    let zero = L::splat(0.0);
    let f = origin - center;
    let b = f.dot(dir); // half of the usual b
    let c = f.dot(f) - radius * radius;
    // Outside and moving away: both roots are negative.
    let away = c.gt(zero) & b.gt(zero);
    // Every lane away (spheres behind a shadow ray's origin, a ground sphere under the
    // points it lights): no hit, before the perpendicular distance and its products.
    if (!away).bits() == 0 {
        return (zero, L::Mask::from_bits(0));
    }
    let perp = f - dir.scale(b * inv_a);
    let quarter_disc = a * (radius * radius - perp.dot(perp));
    let miss = away | quarter_disc.lt(zero);
    // No lane can hit: skip the square root and the division, the long end of the
    // dependency chain (the sky of `bunny`: every sphere beside the tree misses there).
    if !(!miss).any() {
        return (zero, L::Mask::from_bits(0));
    }
    let root = quarter_disc.sqrt();
    // `flip_sign`, not `-`: wide's `-` on f32x8 is 0 − x (+0 for +0).
    let q = L::select(b.ge(zero), (b + root).flip_sign(), (b - root).flip_sign());
    let x0 = c / q;
    let x1 = q * inv_a;
    let ordered = x0.le(x1);
    // q = 0: origin on the sphere and the ray tangent to it: both roots are 0.
    let tangent = q.eq(zero);
    let t0 = L::select(tangent, zero, L::select(ordered, x0, x1));
    let t1 = L::select(tangent, zero, L::select(ordered, x1, x0));
    let in0 = t0.ge(t_min) & t0.le(t_max);
    let in1 = t1.ge(t_min) & t1.le(t_max);
    let hit = !miss & (in0 | in1);
    (L::select(in0, t0, t1), hit)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The accessors read the columns unchecked after one check against the pool's
    /// length: an index past it panics (never reads past a column), and `set` and
    /// `permute` keep every column in step.
    #[test]
    fn accessors_check_the_index_and_columns_stay_in_step() {
        let mut pool = SpherePool::default();
        pool.push(Vec3::new(1.0, 2.0, 3.0), 0.5, 7, 1);
        pool.push(Vec3::new(4.0, 5.0, 6.0), 2.0, 3, 0);
        pool.set(1, Vec3::new(-1.0, -2.0, -3.0), 4.0);
        pool.permute(&[1, 0]);
        assert_eq!(pool.center(0), Vec3::new(-1.0, -2.0, -3.0));
        assert_eq!((pool.radius(0), pool.id(0), pool.object(0)), (4.0, 3, 0));
        assert_eq!((pool.radius(1), pool.id(1), pool.object(1)), (0.5, 7, 1));
        let ([cx, cy, cz, r], id, object) = pool.columns();
        assert!([cx, cy, cz, r].iter().all(|c| c.len() == 2) && id.len() == 2);
        assert_eq!(object, [0, 1]);
        for read in [
            |p: &SpherePool| p.center(2).x,
            |p: &SpherePool| p.radius(2),
            |p: &SpherePool| p.id(2) as f32,
            |p: &SpherePool| p.object(2) as f32,
        ] {
            let past = std::panic::catch_unwind(|| read(&pool));
            assert!(past.is_err());
        }
    }

    /// Lanes of one `sphere_distance` call at widths 4 and 8 give, lane for lane, the
    /// `f32` call's hit flag and (where it hits) the same bits, for mixes of spheres that
    /// hit and miss: the early exit when no lane can hit must not drop a lane that can.
    #[test]
    fn lanes_match_the_scalar_kernel_when_only_some_spheres_hit() {
        use wide::f32x8;
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut unit = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        // Lanes `k0..k0 + L::WIDTH` of the group in one call.
        fn lanes<L: Lane>(
            centers: &[Vec3; 8],
            radii: &[f32; 8],
            k0: usize,
            origin: Vec3,
            dir: Vec3,
            a: f32,
        ) -> (L, L::Mask) {
            let c = |f: fn(Vec3) -> f32| L::from_fn(|k| f(centers[k0 + k]));
            sphere_distance::<L>(
                V3::new(c(|v| v.x), c(|v| v.y), c(|v| v.z)),
                L::from_fn(|k| radii[k0 + k]),
                V3::splat(origin),
                V3::splat(dir),
                L::splat(a),
                L::splat(1.0 / a),
                L::splat(1e-4),
                L::splat(f32::INFINITY),
            )
        }
        let (mut hits, mut none, mut mixed, mut away) = (0, 0, 0, 0);
        for _ in 0..2000 {
            let origin = Vec3::new(unit(), unit(), unit()) * 4.0 - 2.0;
            let dir = Vec3::new(unit(), unit(), unit()) * 2.0 - 1.0;
            let a = dir.dot(dir);
            let centers: [Vec3; 8] =
                std::array::from_fn(|_| Vec3::new(unit(), unit(), unit()) * 6.0 - 3.0);
            let radii: [f32; 8] = std::array::from_fn(|_| unit() * 3.0);
            let scalar: [(f32, bool); 8] = std::array::from_fn(|k| {
                sphere_distance::<f32>(
                    V3::splat(centers[k]),
                    radii[k],
                    V3::splat(origin),
                    V3::splat(dir),
                    a,
                    1.0 / a,
                    1e-4,
                    f32::INFINITY,
                )
            });
            hits += scalar.iter().filter(|s| s.1).count();
            // Groups of four spheres that are all behind the ray's origin (the exit
            // before the discriminant).
            let behind = |k: usize| {
                let f = origin - centers[k];
                f.dot(f) > radii[k] * radii[k] && f.dot(dir) > 0.0
            };
            away += (0..2).filter(|g| (4 * g..4 * g + 4).all(behind)).count();
            for g in scalar.chunks(4) {
                match g.iter().filter(|s| s.1).count() {
                    0 => none += 1,
                    4 => {}
                    _ => mixed += 1,
                }
            }
            let (t8, m8) = lanes::<f32x8>(&centers, &radii, 0, origin, dir, a);
            for half in 0..2 {
                let k0 = 4 * half;
                let (t4, m4) = lanes::<Vec4>(&centers, &radii, k0, origin, dir, a);
                for k in 0..4 {
                    let (t, hit) = scalar[k0 + k];
                    assert_eq!(m4.bits() >> k & 1 != 0, hit, "4-wide lane {k}");
                    assert_eq!(
                        m8.bits() >> (k0 + k) & 1 != 0,
                        hit,
                        "8-wide lane {}",
                        k0 + k
                    );
                    if hit {
                        assert_eq!(t4.lane(k).to_bits(), t.to_bits());
                        assert_eq!(t8.lane(k0 + k).to_bits(), t.to_bits());
                    }
                }
            }
        }
        // Every case occurs often: groups that all miss (the early exits), of them
        // groups all behind the origin, and hits and misses side by side.
        assert!(
            none > 500 && away > 100 && mixed > 1000,
            "{hits} hits, {none} groups all miss ({away} all behind), {mixed} mixed"
        );
    }

    #[test]
    fn hits_front_and_back() {
        let ray = Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::new(0.0, 0.0, -1.0));
        assert_eq!(
            sphere_intersect(Vec3::ZERO, 1.0, &ray, 1e-4, f32::INFINITY),
            Some(4.0)
        );
        // Starting inside: the far wall.
        let inside = Ray::new(Vec3::ZERO, Vec3::X);
        assert_eq!(
            sphere_intersect(Vec3::ZERO, 2.0, &inside, 1e-4, f32::INFINITY),
            Some(2.0)
        );
        // Behind the origin: no hit.
        let away = Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::Z);
        assert_eq!(
            sphere_intersect(Vec3::ZERO, 1.0, &away, 1e-4, f32::INFINITY),
            None
        );
    }

    #[test]
    fn t_max_excludes_far_hits() {
        let ray = Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::new(0.0, 0.0, -1.0));
        assert_eq!(sphere_intersect(Vec3::ZERO, 1.0, &ray, 1e-4, 3.0), None);
        assert_eq!(
            sphere_intersect(Vec3::ZERO, 1.0, &ray, 4.5, 10.0),
            Some(6.0)
        );
    }
}
