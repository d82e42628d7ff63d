//! The brute-force scan, the original program's algorithm, kept to measure the BVH
//! against.

use super::bvh::{Closest, RayQuery};
use super::Context;
use crate::geometry::aabb::SlabRay;
use crate::geometry::{Aabb, Hit, PrimKind, Ray};
use crate::scene::Scene;
use std::ops::Range;

/// Triangles grouped by object: a mesh (more than one triangle) is tested only when its
/// bounding box is hit, as the original program did.
#[derive(Clone, Debug)]
pub struct LinearScan {
    groups: Vec<TriangleGroup>,
}

/// An object's triangles: the runs of consecutive pool indices they fill (one for a
/// mesh as the scene compiles it), their number (the runs' lengths summed, kept so a
/// ray does not sum them) and their box.
#[derive(Clone, Debug)]
struct TriangleGroup {
    runs: Vec<Range<usize>>,
    count: usize,
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
                    runs: Vec::new(),
                    count: 0,
                    bounds: Aabb::EMPTY,
                });
                groups.len() - 1
            });
            let g = &mut groups[g];
            match g.runs.last_mut() {
                Some(run) if run.end == i => run.end += 1,
                _ => g.runs.push(i..i + 1),
            }
            g.count += 1;
            g.bounds = g.bounds.union(tri.bounds(i));
        }
        LinearScan { groups }
    }

    /// Every sphere and quad, then every triangle of each object whose box the ray
    /// meets, through the BVH's leaf loops (`Closest::range`), which keep the smallest
    /// `(t, id)` whatever the order.
    pub fn closest_hit(&self, cx: Context<'_>, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        let scene = cx.scene;
        let mut c = Closest::new(t_max, &None);
        let (mut rq, _) = RayQuery::with_reciprocals(cx, ray);
        for (kind, n) in [
            (PrimKind::Sphere, scene.spheres.len()),
            (PrimKind::Quad, scene.quads.len()),
        ] {
            rq.stats.prims += n as u64;
            c.range(&mut rq, kind, 0..n, t_min);
        }
        if !self.groups.is_empty() {
            let slab = SlabRay::new(ray);
            for g in &self.groups {
                if g.count > 1 {
                    rq.stats.nodes += 1;
                    if g.bounds.hit(&slab, t_min, c.t_max).is_none() {
                        continue;
                    }
                }
                rq.stats.prims += g.count as u64;
                for run in &g.runs {
                    c.range(&mut rq, PrimKind::Triangle, run.clone(), t_min);
                }
            }
        }
        c.hit(scene)
    }
}
