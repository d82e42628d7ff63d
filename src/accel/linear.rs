//! The brute-force scan: the seed's algorithm, kept to measure the BVH against.

use crate::geometry::aabb::SlabRay;
use crate::geometry::triangle::WatertightRay;
use crate::geometry::{keep_closest, Hit, PrimKind, Ray};
use crate::scene::Scene;

/// Test every primitive; a mesh's triangles only when its bounding box overlaps
/// `[t_min, closest so far]`.
pub fn closest_hit(scene: &Scene, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    let mut t_max = t_max;
    let s = &scene.spheres;
    for i in 0..s.len() {
        if let Some(t) = s.intersect(i, ray, t_min, t_max) {
            keep_closest(&mut best, hit(t, s.id[i], PrimKind::Sphere, i, s.object[i]));
            t_max = best.map_or(t_max, |b| b.t);
        }
    }
    let q = &scene.quads;
    for i in 0..q.len() {
        if let Some(t) = q.intersect(i, ray, t_min, t_max) {
            keep_closest(&mut best, hit(t, q.id[i], PrimKind::Quad, i, q.object[i]));
            t_max = best.map_or(t_max, |b| b.t);
        }
    }
    if !scene.triangles.is_empty() {
        let tri = &scene.triangles;
        let wray = WatertightRay::new(ray);
        let slab = SlabRay::new(ray);
        for group in &scene.triangle_groups {
            if group.is_mesh && group.bounds.hit(&slab, t_min, t_max).is_none() {
                continue;
            }
            for i in group.range.start as usize..group.range.end as usize {
                if let Some(t) = tri.intersect(i, &wray, t_min, t_max) {
                    keep_closest(
                        &mut best,
                        hit(t, tri.id[i], PrimKind::Triangle, i, tri.object[i]),
                    );
                    t_max = best.map_or(t_max, |b| b.t);
                }
            }
        }
    }
    best
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
