//! How many node visits would wider nodes save? Builds the binary SAH tree of a scene's
//! triangles as `Bvh::build` does, collapses it to 2-, 4- and 8-wide nodes the same way
//! (opening the child of largest area), and traces the scene's camera rays (the order of
//! `benches/bvh.rs`) front to back through each, culling with the best t so far. A plain
//! model, not the renderer's traversal (f32 slabs with a small margin; the renderer's
//! watertight triangle test), to count inner-node visits, leaves and triangles a ray. Its
//! 4-wide count matches `--stats` (5.743 against 5.747 nodes a `bunny-closeup` ray).
//!
//! ```sh
//! cargo run --release --example wide_probe -- benches/embree/bunny-closeup-mesh.toml
//! ```
use glam::Vec3;
use raytracer::accel::build::{self, BuildTree, NodeId, PrimRef};
use raytracer::geometry::aabb::Aabb;
use raytracer::geometry::triangle::WatertightRay;
use raytracer::geometry::PrimKind;
use raytracer::integrator::T_MIN;
use raytracer::scene::{Overrides, Scene};

#[path = "../common/mod.rs"]
mod common;

/// A child: an inner node's index, or a leaf's first reference and count.
enum Child {
    Inner(usize),
    Leaf(u32, u32),
}

/// The nodes of one width, each its children's boxes and codes.
struct Wide {
    nodes: Vec<Vec<(Aabb, Child)>>,
}

fn collapse(t: &BuildTree, n: NodeId, width: usize, w: &mut Wide) -> Child {
    let Some(ch) = t.children(n) else {
        let l = t.node(n);
        return Child::Leaf(l.first_or_right, l.count as u32);
    };
    let mut kids: Vec<NodeId> = ch.to_vec();
    while kids.len() < width {
        let mut best: Option<(usize, f32)> = None;
        for (i, &k) in kids.iter().enumerate() {
            if t.children(k).is_some() {
                let a = t.node(k).bounds.surface_area();
                if best.is_none_or(|(_, b)| a >= b) {
                    best = Some((i, a));
                }
            }
        }
        let Some((i, _)) = best else { break };
        let [l, r] = t.children(kids[i]).unwrap();
        kids[i] = l;
        kids.insert(i + 1, r);
    }
    let idx = w.nodes.len();
    w.nodes.push(Vec::new());
    let v = kids
        .iter()
        .map(|&k| (t.node(k).bounds, collapse(t, k, width, w)))
        .collect();
    w.nodes[idx] = v;
    Child::Inner(idx)
}

fn slab(b: &Aabb, o: Vec3, inv: Vec3, tmax: f32) -> Option<f32> {
    let t0 = (b.min - o) * inv;
    let t1 = (b.max - o) * inv;
    let lo = t0.min(t1);
    let hi = t0.max(t1);
    let e = lo.max_element().max(0.0);
    let x = hi.min_element().min(tmax);
    (e <= x * 1.0000002).then_some(e)
}

fn main() {
    let name = std::env::args()
        .nth(1)
        .unwrap_or("benches/embree/bunny-closeup-mesh.toml".into());
    let scene = Scene::load(&name, Overrides::default()).unwrap();
    let tri = &scene.triangles;
    let mut refs: Vec<PrimRef> = (0..tri.len())
        .map(|i| PrimRef::new(tri.bounds(i), PrimKind::Triangle, i as u32))
        .collect();
    let tree = build::build(&mut refs).unwrap();
    let order: Vec<usize> = refs.iter().map(|r| r.index() as usize).collect();
    let rays = common::camera_rays(&scene, scene.spp);
    for width in [2, 4, 8] {
        let mut w = Wide { nodes: Vec::new() };
        let root = collapse(&tree, BuildTree::ROOT, width, &mut w);
        let (mut inner, mut leaves, mut tris, mut hits) = (0u64, 0u64, 0u64, 0u64);
        let mut stack: Vec<(f32, &Child)> = Vec::new();
        for r in &rays {
            let inv = Vec3::ONE / r.dir;
            let wr = WatertightRay::new(r);
            let mut best = f32::INFINITY;
            stack.clear();
            stack.push((0.0, &root));
            while let Some((e, c)) = stack.pop() {
                if e > best {
                    continue;
                }
                match c {
                    Child::Leaf(first, count) => {
                        leaves += 1;
                        for i in *first..first + count {
                            tris += 1;
                            let j = order[i as usize];
                            if let Some(t) = wr.intersect(tri.vertices(j), T_MIN, best) {
                                best = t;
                            }
                        }
                    }
                    Child::Inner(n) => {
                        inner += 1;
                        let mut hit: Vec<(f32, &Child)> = w.nodes[*n]
                            .iter()
                            .filter_map(|(b, ch)| slab(b, r.origin, inv, best).map(|e| (e, ch)))
                            .collect();
                        hit.sort_by(|a, b| b.0.total_cmp(&a.0));
                        stack.extend(hit);
                    }
                }
            }
            hits += best.is_finite() as u64;
        }
        let n = rays.len() as f64;
        println!(
            "width {width}: {} nodes; a ray: {:.3} inner visits, {:.3} leaves, {:.3} triangles; hits {hits}",
            w.nodes.len(),
            inner as f64 / n,
            leaves as f64 / n,
            tris as f64 / n
        );
    }
}
