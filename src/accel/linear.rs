//! The brute-force scan, the original program's algorithm, kept to measure the BVH
//! against.

use super::TraversalStats;
use crate::geometry::aabb::SlabRay;
use crate::geometry::sphere::SphereRay;
use crate::geometry::triangle::WatertightRay;
use crate::geometry::{keep_closest, Aabb, Hit, PrimKind, Ray};
use crate::scene::Scene;
use std::ops::Range;

/// A ray with the per-ray constants of every primitive test, computed once.
#[derive(Clone, Copy, Debug)]
pub struct PrimRay {
    pub ray: Ray,
    pub sphere: SphereRay,
    pub triangle: WatertightRay,
}

impl PrimRay {
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        Self {
            ray: *ray,
            sphere: SphereRay::new(ray),
            triangle: WatertightRay::new(ray),
        }
    }
}

/// Triangles grouped by object: a mesh (more than one triangle) is tested only when its
/// bounding box is hit, as the original program did.
#[derive(Clone, Debug)]
pub struct LinearScan {
    groups: Vec<TriangleGroup>,
}

#[derive(Clone, Debug)]
struct TriangleGroup {
    indices: Vec<u32>,
    bounds: Aabb,
}

impl LinearScan {
    pub fn build(scene: &Scene) -> LinearScan {
        let mut groups: Vec<TriangleGroup> = Vec::new();
        let tri = &scene.triangles;
        let mut by_object = std::collections::BTreeMap::<u32, usize>::new();
        for i in 0..tri.len() {
            let g = *by_object.entry(tri.object[i]).or_insert_with(|| {
                groups.push(TriangleGroup {
                    indices: Vec::new(),
                    bounds: Aabb::EMPTY,
                });
                groups.len() - 1
            });
            groups[g].indices.push(i as u32);
            groups[g].bounds = groups[g].bounds.union(tri.bounds(i));
        }
        LinearScan { groups }
    }

    pub fn closest_hit(
        &self,
        scene: &Scene,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        stats: &mut TraversalStats,
    ) -> Option<Hit> {
        let mut best = None;
        let mut t_max = t_max;
        let pray = PrimRay::new(ray);
        for kind in [PrimKind::Sphere, PrimKind::Quad] {
            let n = if kind == PrimKind::Sphere {
                scene.spheres.len()
            } else {
                scene.quads.len()
            };
            stats.prims += n as u64;
            intersect_range(scene, kind, 0..n, &pray, t_min, &mut t_max, &mut best);
        }
        if !self.groups.is_empty() {
            let slab = SlabRay::new(ray);
            let tri = &scene.triangles;
            for g in &self.groups {
                if g.indices.len() > 1 {
                    stats.nodes += 1;
                    if g.bounds.hit(&slab, t_min, t_max).is_none() {
                        continue;
                    }
                }
                stats.prims += g.indices.len() as u64;
                for &i in &g.indices {
                    let i = i as usize;
                    if let Some(t) = tri.intersect(i, &pray.triangle, t_min, t_max) {
                        keep_closest(
                            &mut best,
                            hit(t, tri.id[i], PrimKind::Triangle, i, tri.object[i]),
                        );
                        t_max = t;
                    }
                }
            }
        }
        best
    }
}

/// Closest-hit over `range` of one kind's pool, shrinking `t_max` as hits are found.
#[inline]
fn intersect_range(
    scene: &Scene,
    kind: PrimKind,
    range: Range<usize>,
    ray: &PrimRay,
    t_min: f32,
    t_max: &mut f32,
    best: &mut Option<Hit>,
) {
    match kind {
        PrimKind::Sphere => {
            let s = &scene.spheres;
            for i in range {
                if let Some(t) = s.intersect(i, &ray.sphere, t_min, *t_max) {
                    keep_closest(best, hit(t, s.id[i], kind, i, s.object[i]));
                    *t_max = t;
                }
            }
        }
        PrimKind::Quad => {
            let q = &scene.quads;
            for i in range {
                if let Some(t) = q.intersect(i, &ray.ray, &ray.triangle, t_min, *t_max) {
                    keep_closest(best, hit(t, q.id[i], kind, i, q.object[i]));
                    *t_max = t;
                }
            }
        }
        PrimKind::Triangle => {
            // Four triangles a pass (a BVH leaf is at most four), the same bits as one at
            // a time; the hits are then taken in pool order.
            let tri = &scene.triangles;
            let mut start = range.start;
            while start < range.end {
                let n = (range.end - start).min(4);
                let (t, mut mask) = tri.intersect4(start, n, &ray.triangle, t_min, *t_max);
                while mask != 0 {
                    let k = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    if t[k] <= *t_max {
                        let i = start + k;
                        keep_closest(best, hit(t[k], tri.id[i], kind, i, tri.object[i]));
                        *t_max = t[k];
                    }
                }
                start += n;
            }
        }
    }
}

#[inline]
fn hit(t: f32, id: u32, kind: PrimKind, index: usize, object: u32) -> Hit {
    Hit {
        t,
        id,
        kind,
        index: index as u32,
        object,
    }
}
