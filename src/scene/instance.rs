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
    /// Points whose hull holds the mesh (`hull_points`): what its instances' boxes are
    /// made from.
    pub hull: Vec<Vec3>,
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
    /// The rows' columns `a`, `b`, `c`, `t` (`ToObject::ray` moves one ray by them),
    /// and their absolute values.
    columns: [Vec3A; 4],
    abs_columns: [Vec3A; 4],
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
        ToObject::from_rows([row(0), row(1), row(2)])
    }

    fn from_rows(rows: [Vec4; 3]) -> ToObject {
        let [r0, r1, r2] = rows;
        let column = |f: fn(Vec4) -> f32| Vec3A::new(f(r0), f(r1), f(r2));
        let columns = [
            column(|r| r.x),
            column(|r| r.y),
            column(|r| r.z),
            column(|r| r.w),
        ];
        ToObject {
            rows,
            columns,
            abs_columns: columns.map(Vec3A::abs),
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
        let (c, a) = (&self.columns, &self.abs_columns);
        let (o, d) = (Vec3A::from(ray.origin), Vec3A::from(ray.dir));
        let linear = |v: Vec3A| (c[0] * v.x + c[1] * v.y) + c[2] * v.z;
        let moved = linear(o) + c[3];
        let dir = linear(d);
        let p = o.abs();
        let size = ((a[0] * p.x + a[1] * p.y) + a[2] * p.z) + a[3];
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

/// Cells a side of the grid `hull_points` bins a prototype's vertices in.
const HULL_GRID: usize = 16;

/// Points whose convex hull holds every triangle of `triangles` (whose box is
/// `bounds`): the corners of the box of the vertices in each cell of a grid of
/// `HULL_GRID`³ over `bounds`. A placed mesh's world box is the box of these points
/// moved (`world_bounds`): within a cell of the moved vertices' own box, where the
/// moved corners of `bounds` make a turned mesh's box up to √2 as wide on each axis
/// (a ray that enters a box but misses the mesh costs an instance entry). At most 4 096
/// points whatever the mesh's size.
pub fn hull_points(triangles: &[[Vec3; 3]], bounds: &Aabb) -> Vec<Vec3> {
    let n = HULL_GRID as f32;
    let extent = bounds.max - bounds.min;
    let scale = Vec3::select(extent.cmpgt(Vec3::ZERO), n / extent, Vec3::ZERO);
    let mut cells = vec![Aabb::EMPTY; HULL_GRID * HULL_GRID * HULL_GRID];
    for &v in triangles.iter().flatten() {
        let c = ((v - bounds.min) * scale)
            .min(Vec3::splat(n - 1.0))
            .as_uvec3();
        let at = (c.z as usize * HULL_GRID + c.y as usize) * HULL_GRID + c.x as usize;
        cells[at] = cells[at].grow(v);
    }
    let corners = |b: &Aabb| {
        let (lo, hi) = (b.min, b.max);
        (0..8).map(move |k| {
            let pick = |bit: usize, lo: f32, hi: f32| if k & bit == 0 { lo } else { hi };
            Vec3::new(
                pick(1, lo.x, hi.x),
                pick(2, lo.y, hi.y),
                pick(4, lo.z, hi.z),
            )
        })
    };
    cells
        .iter()
        .filter(|b| b.min.cmple(b.max).all())
        .flat_map(corners)
        .collect()
}

/// The world box of a prototype (in its space, the box of `hull`, its `hull_points`)
/// placed by `to_world`: the box of those points moved in f64, widened by a relative
/// 2⁻¹⁶ of its size and position (far more than the f32 rounding of the rays moved into
/// the mesh's space) and rounded outwards. No point: an empty box of infinite bounds.
pub fn world_bounds(hull: &[Vec3], to_world: &Transform) -> (glam::DVec3, glam::DVec3) {
    let mut min = glam::DVec3::INFINITY;
    let mut max = glam::DVec3::NEG_INFINITY;
    for &p in hull {
        let p = to_world.point(p);
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
    use crate::scene::desc::{RotationDesc, V3 as V3d};
    use proptest::prelude::*;
    use std::f32::consts::PI;

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
            let m = ToObject::from_rows(rows);
            let (ray, dt) = m.ray(&Ray::new(origin, dir));
            let (o, d, t) = m.apply::<f32>(V3::splat(origin), V3::splat(dir));
            let bits = |v: Vec3| v.to_array().map(f32::to_bits);
            prop_assert_eq!(bits(ray.origin), bits(o.lane(0)));
            prop_assert_eq!(bits(ray.dir), bits(d.lane(0)));
            prop_assert_eq!(dt.to_bits(), t.to_bits());
        }

        /// A placed mesh's box holds every moved vertex, and is no wider than the box
        /// of its moved corners.
        #[test]
        fn the_hull_box_holds_the_moved_mesh(
            vertices in proptest::collection::vec(vec3(), 3..40),
            m in proptest::collection::vec(-3.0f64..3.0, 12),
        ) {
            let rows: Vec<Vec<f64>> = (0..3)
                .map(|r| m[4 * r..4 * r + 4].to_vec())
                .chain([vec![0.0, 0.0, 0.0, 1.0]])
                .collect();
            let Ok(to_world) = Transform::from_keys(None, &[], None, Some(&rows)) else {
                return Ok(()); // singular
            };
            let triangles: Vec<[Vec3; 3]> = vertices.windows(3).map(|w| [w[0], w[1], w[2]]).collect();
            let bounds = Aabb::from_points(&vertices);
            let (min, max) = world_bounds(&hull_points(&triangles, &bounds), &to_world);
            for &v in &vertices {
                let p = to_world.point(v);
                prop_assert!(p.cmpge(min).all() && p.cmple(max).all(), "{p} outside {min}..{max}");
            }
            let corners: Vec<Vec3> = (0..8)
                .map(|k| Vec3::select(glam::BVec3::new(k & 1 != 0, k & 2 != 0, k & 4 != 0), bounds.max, bounds.min))
                .collect();
            let (cmin, cmax) = world_bounds(&corners, &to_world);
            prop_assert!(min.cmpge(cmin).all() && max.cmple(cmax).all());
        }
    }

    /// A sphere of triangles turned 45° about y: its box stays within a grid cell of
    /// the sphere's (the turned corners of its box would make it √2 as wide).
    #[test]
    fn a_turned_mesh_keeps_a_tight_box() {
        let point = |i: usize, j: usize| {
            let (theta, phi) = (i as f32 * PI / 16.0, j as f32 * PI / 16.0);
            Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            )
        };
        let mut triangles = Vec::new();
        for i in 0..16 {
            for j in 0..32 {
                let [a, b, c, d] = [
                    point(i, j),
                    point(i + 1, j),
                    point(i, j + 1),
                    point(i + 1, j + 1),
                ];
                triangles.extend([[a, b, c], [c, b, d]]);
            }
        }
        let bounds = Aabb::from_points(&triangles.concat());
        let turn = [RotationDesc {
            axis: V3d([0.0, 1.0, 0.0]),
            degrees: 45.0,
        }];
        let to_world = Transform::from_keys(None, &turn, None, None).unwrap();
        let (min, max) = world_bounds(&hull_points(&triangles, &bounds), &to_world);
        let cell = 2.0 / HULL_GRID as f64;
        assert!((max - min).max_element() < 2.0 + 2.0 * cell, "{min}..{max}");
        assert!((max - min).min_element() > 1.99);
    }
}
