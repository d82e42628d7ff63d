//! Instances: a mesh stored once, in its own space (`Prototype`, a `[meshes.NAME]`
//! table), and placed many times (`Instance`, an object of `type = "instance"`).
//!
//! A ray meets an instance in the mesh's space. `ToObject::apply` moves it there, in
//! f32 by one fixed sequence of operations on every lane, so every packet width and
//! the scalar tracer test the same object-space ray; the mesh's own tree answers, and
//! its hit comes back with the instance's ids, objects and the world's `t`. The shading
//! then rebuilds the hit triangle in world space exactly as a mesh object's transform
//! places its vertices at load (`Instance::world_triangle`), so the surface, its normal
//! and the next ray's origin are those of the same triangle flattened into the scene.
//! An instance whose transform is the identity is traced without moving the ray: it
//! gives the bits of the same mesh as a mesh object.
//!
//! Moving the ray rounds its origin. The error is bounded (γ₄ times the sum of the
//! magnitudes of the terms), and the origin is advanced along the ray past that bound
//! before the mesh is tested (the method of pbrt's `Transform` of a ray): a ray leaving
//! an instance's surface does not find that surface again at a tiny `t`.

use super::transform::Transform;
use super::Scene;
use crate::geometry::{Aabb, Hit, Ray};
use crate::lanes::{Lane, V3};
use glam::{Vec3, Vec3A, Vec4};

/// A mesh stored once: its triangles in the mesh's own space, in a scene of their own
/// (ids `0..n` in file order, object `g` for the triangles of material group `g`: 0 the
/// mesh's `material`, `1 + k` its MTL library's material `k`).
#[derive(Clone, Debug)]
pub struct Prototype {
    /// The `[meshes.NAME]` table's name.
    pub name: String,
    pub scene: Scene,
    /// The material of each group, indices into the enclosing scene's materials.
    pub group_materials: Vec<u32>,
    /// Whether each group has triangles (an MTL library may define materials the mesh
    /// does not use).
    pub group_used: Vec<bool>,
}

impl Prototype {
    /// Material groups: objects of each instance.
    pub fn groups(&self) -> u32 {
        self.group_materials.len() as u32
    }
}

/// `γₙ = nε / (1 − nε)` for n = 4, ε = 2⁻²⁴: a bound of the relative rounding error of
/// a sum of four products (`ToObject::apply`'s origin), with a spare term for the
/// rounding of the bound itself.
const GAMMA4: f32 = 4.0 * (f32::EPSILON * 0.5) / (1.0 - 4.0 * (f32::EPSILON * 0.5));

/// The map from world to a mesh's space, in f32: rows `[a, b, c, t]`, a point `p` goes
/// to `((a·x + b·y) + c·z) + t` in each row, a direction without `t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToObject {
    rows: [Vec4; 3],
}

impl ToObject {
    /// The inverse of `to_world`, rounded once to f32.
    pub fn new(to_world: &Transform) -> ToObject {
        let inverse = to_world.affine().inverse();
        let m = inverse.matrix3;
        let t = inverse.translation;
        let row = |r: usize| {
            let c = m.row(r);
            Vec4::new(c.x as f32, c.y as f32, c.z as f32, t[r] as f32)
        };
        ToObject {
            rows: [row(0), row(1), row(2)],
        }
    }

    /// Rays with lanes `origin`, `dir` in the mesh's space: their origins, advanced past
    /// the rounding of the map, their directions (not of unit length), and the distance
    /// `dt` the origins were advanced by, in units of the ray (a hit at `t` of the moved
    /// ray is at `t + dt` of the world's).
    #[inline(always)]
    pub fn apply<L: Lane>(&self, origin: V3<L>, dir: V3<L>) -> (V3<L>, V3<L>, L) {
        let linear =
            |r: Vec4, v: V3<L>| (L::splat(r.x) * v.x + L::splat(r.y) * v.y) + L::splat(r.z) * v.z;
        let size = |r: Vec4, v: V3<L>| {
            let a = r.abs();
            ((L::splat(a.x) * v.x.abs() + L::splat(a.y) * v.y.abs()) + L::splat(a.z) * v.z.abs())
                + L::splat(a.w)
        };
        let [r0, r1, r2] = self.rows;
        let o = V3::new(
            linear(r0, origin) + L::splat(r0.w),
            linear(r1, origin) + L::splat(r1.w),
            linear(r2, origin) + L::splat(r2.w),
        );
        let d = V3::new(linear(r0, dir), linear(r1, dir), linear(r2, dir));
        let gamma = L::splat(GAMMA4);
        let error = V3::new(
            size(r0, origin) * gamma,
            size(r1, origin) * gamma,
            size(r2, origin) * gamma,
        );
        let reach = (d.x.abs() * error.x + d.y.abs() * error.y) + d.z.abs() * error.z;
        let dt = reach / d.dot(d);
        (o + d.scale(dt), d, dt)
    }

    /// `apply` for one ray, its three rows at once: the columns of the rows, each
    /// component the same operations in the same order, so the same bits.
    #[inline]
    pub fn ray(&self, ray: &Ray) -> (Ray, f32) {
        let [r0, r1, r2] = self.rows;
        let column = |f: fn(Vec4) -> f32| Vec3A::new(f(r0), f(r1), f(r2));
        let c = [
            column(|r| r.x),
            column(|r| r.y),
            column(|r| r.z),
            column(|r| r.w),
        ];
        let (o, d) = (Vec3A::from(ray.origin), Vec3A::from(ray.dir));
        let linear = |v: Vec3A| (c[0] * v.x + c[1] * v.y) + c[2] * v.z;
        let moved = linear(o) + c[3];
        let dir = linear(d);
        let a = o.abs();
        let size = ((c[0].abs() * a.x + c[1].abs() * a.y) + c[2].abs() * a.z) + c[3].abs();
        let error = size * GAMMA4;
        let p = dir.abs() * error;
        let reach = (p.x + p.y) + p.z;
        let q = dir * dir;
        let dt = reach / ((q.x + q.y) + q.z);
        (Ray::new((moved + dir * dt).into(), dir.into()), dt)
    }
}

/// A placed mesh: an object (or one an MTL material group) of the scene.
#[derive(Clone, Debug)]
pub struct Instance {
    /// Index into `Scene::prototypes`.
    pub prototype: u32,
    /// The object of the prototype's group 0; group `g` is object `first_object + g`.
    pub first_object: u32,
    /// The scene-wide id of the prototype's triangle 0 (its ids follow in file order).
    pub first_id: u32,
    /// The mesh's space to the world's, in f64, as a mesh object's transform.
    pub to_world: Transform,
    /// The world to the mesh's space; `None` for the identity (rays are not moved).
    pub to_object: Option<ToObject>,
    /// The instance's box in the world, widened past the rounding of every map: a ray
    /// that meets the mesh in its space meets this box.
    pub bounds: Aabb,
}

impl Instance {
    /// The world's hit of `hit` (a hit of the prototype's scene, at `t` of the ray moved
    /// by `dt`).
    #[inline]
    pub fn world_hit(&self, hit: Hit, dt: f32) -> Hit {
        Hit {
            t: hit.t + dt,
            id: self.first_id + hit.id,
            kind: hit.kind,
            index: hit.index,
            object: self.first_object + hit.object,
        }
    }

    /// A prototype triangle in the world: each vertex moved in f64 and rounded once,
    /// as a mesh object's transform places it at load.
    #[inline]
    pub fn world_triangle(&self, v: [Vec3; 3]) -> [Vec3; 3] {
        if self.to_object.is_none() {
            return v;
        }
        v.map(|p| self.to_world.point(p).as_vec3())
    }

    /// A prototype triangle's corner normals in the world (the inverse transpose,
    /// normalised in f64), as a mesh object's transform maps them at load.
    #[inline]
    pub fn world_normals(&self, n: [Vec3; 3]) -> [Vec3; 3] {
        if self.to_object.is_none() {
            return n;
        }
        n.map(|n| self.to_world.normal(n).as_vec3())
    }
}

/// The world box of `bounds` (a prototype's, in its space) placed by `to_world`: the
/// box of its eight corners moved in f64, widened by a relative 2⁻¹⁶ of its size and
/// position (far more than the f32 rounding of the rays moved into the mesh's space) and
/// rounded outwards.
pub fn world_bounds(bounds: &Aabb, to_world: &Transform) -> (glam::DVec3, glam::DVec3) {
    let (lo, hi) = (bounds.min, bounds.max);
    let mut min = glam::DVec3::INFINITY;
    let mut max = glam::DVec3::NEG_INFINITY;
    for k in 0..8 {
        let corner = Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        let p = to_world.point(corner);
        min = min.min(p);
        max = max.max(p);
    }
    let pad = ((max - min) + min.abs().max(max.abs())) * (1.0 / 65536.0);
    (min - pad, max + pad)
}

/// `world_bounds` as an f32 box, rounded outwards.
pub fn outward(min: glam::DVec3, max: glam::DVec3) -> Aabb {
    let down = |x: f64| {
        let f = x as f32;
        if f as f64 > x {
            f.next_down()
        } else {
            f
        }
    };
    let up = |x: f64| {
        let f = x as f32;
        if (f as f64) < x {
            f.next_up()
        } else {
            f
        }
    };
    Aabb::new(
        Vec3::new(down(min.x), down(min.y), down(min.z)),
        Vec3::new(up(max.x), up(max.y), up(max.z)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn finite() -> impl Strategy<Value = f32> {
        prop_oneof![-1e3f32..1e3, -1.0f32..1.0, Just(0.0), Just(-0.0)]
    }

    fn vec4() -> impl Strategy<Value = Vec4> {
        (finite(), finite(), finite(), finite()).prop_map(|(x, y, z, w)| Vec4::new(x, y, z, w))
    }

    fn vec3() -> impl Strategy<Value = Vec3> {
        (finite(), finite(), finite()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
    }

    proptest! {
        /// One ray's move (columns at once) is the lanes' move (row by row), bit for bit.
        #[test]
        fn one_ray_moves_as_the_lanes_do(
            rows in [vec4(), vec4(), vec4()],
            origin in vec3(),
            dir in vec3(),
        ) {
            prop_assume!(dir != Vec3::ZERO);
            let m = ToObject { rows };
            let (ray, dt) = m.ray(&Ray::new(origin, dir));
            let (o, d, t) = m.apply::<f32>(V3::splat(origin), V3::splat(dir));
            let bits = |v: Vec3| v.to_array().map(f32::to_bits);
            prop_assert_eq!(bits(ray.origin), bits(o.lane(0)));
            prop_assert_eq!(bits(ray.dir), bits(d.lane(0)));
            prop_assert_eq!(dt.to_bits(), t.to_bits());
        }
    }
}
