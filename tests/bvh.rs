//! The BVH against the brute-force scan: same primitive and same t, bit for bit, for
//! closest hits, shadow visibility and any-hit; a deterministic tree; degenerate input.

mod support;

use glam::Vec3;
use raytracer::accel::packet::{RayPacket, ShadowLanes};
use raytracer::accel::{Accel, AccelKind, Context, ShadowQuery, TraversalStats};
use raytracer::geometry::{Aabb, Hit, Ray};
use raytracer::integrator::T_MIN;
use raytracer::lanes::{F32x16, MAX_WIDTH};
use raytracer::scene::Scene;
use support::{bits, builtin, obj_text, render_with, scene_with_files, Rng};
use wide::f32x8;

/// Both accelerators over (their own copies of) one scene.
struct Pair {
    linear: (Scene, Accel),
    bvh: (Scene, Accel),
}

impl Pair {
    fn new(scene: &Scene) -> Pair {
        let mut l = scene.clone();
        let la = Accel::build(&mut l, AccelKind::Linear);
        let mut b = scene.clone();
        let ba = Accel::build(&mut b, AccelKind::Bvh);
        assert!(ba.bvh().is_some());
        Pair {
            linear: (l, la),
            bvh: (b, ba),
        }
    }

    fn closest(&self, ray: &Ray, t_max: f32) -> (Option<Hit>, Option<Hit>) {
        let mut s = TraversalStats::default();
        (
            self.linear
                .1
                .closest_hit(Context::new(&self.linear.0, &mut s), ray, T_MIN, t_max),
            self.bvh
                .1
                .closest_hit(Context::new(&self.bvh.0, &mut s), ray, T_MIN, t_max),
        )
    }
}

/// (t bits, id, object): what must agree; the pool index differs after reordering.
fn key(h: Option<Hit>) -> Option<(u32, u32, u32)> {
    h.map(|h| (h.t.to_bits(), h.id, h.object))
}

/// Random rays: from around the bounds in random directions, aimed at random points of
/// the bounds, and axis-parallel (with ±0 components).
fn rays(bounds: Aabb, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng(seed);
    let (lo, hi) = (bounds.min, bounds.max);
    // Flat bounds (a single triangle) still get origins off their plane.
    let ext = (hi - lo).max(Vec3::splat(0.5 * (hi - lo).max_element()));
    let point = |rng: &mut Rng, grow: f32| {
        Vec3::new(
            rng.range(lo.x - grow * ext.x, hi.x + grow * ext.x),
            rng.range(lo.y - grow * ext.y, hi.y + grow * ext.y),
            rng.range(lo.z - grow * ext.z, hi.z + grow * ext.z),
        )
    };
    (0..n)
        .map(|i| match i % 3 {
            0 => Ray::new(point(&mut rng, 0.5), rng.unit_vector()),
            1 => {
                let o = point(&mut rng, 1.0);
                let target = point(&mut rng, 0.0);
                Ray::new(o, (target - o).normalize_or(Vec3::X))
            }
            _ => {
                // Signed zeros on the other axes.
                let d = rng.axis_direction();
                Ray::new(point(&mut rng, 0.2), d)
            }
        })
        .collect()
}

fn assert_same_closest_hits(scene: &Scene, n: usize, seed: u64) {
    assert_same_closest_hits_in(scene, scene.bounds, n, seed)
}

/// `assert_same_closest_hits` with the rays made around `bounds`.
fn assert_same_closest_hits_in(scene: &Scene, bounds: Aabb, n: usize, seed: u64) {
    let pair = Pair::new(scene);
    let mut hits = 0;
    for (i, ray) in rays(bounds, n, seed).iter().enumerate() {
        let (l, b) = pair.closest(ray, f32::INFINITY);
        assert_eq!(key(l), key(b), "ray {i}: {ray:?}");
        hits += l.is_some() as usize;
        // A bounded query as well (culling with t_max).
        if let Some(h) = l {
            let (l2, b2) = pair.closest(ray, h.t * 1.5);
            assert_eq!(key(l2), key(b2), "bounded ray {i}");
        }
    }
    assert!(
        hits > n / 10,
        "only {hits} of {n} rays hit: the test rays miss the scene"
    );
}

fn bunny_mesh_scene(subdivide: u32) -> Scene {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/bunny.toml"))
        .unwrap()
        .replace(
            "path = \"../assets/bunny.obj\"",
            &format!("path = \"bunny.obj\"\nsubdivide = {subdivide}"),
        );
    let obj =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/bunny.obj")).unwrap();
    scene_with_files(&text, &[("bunny.obj", obj)])
}

/// The mesh alone, so that random rays aimed at the scene bounds meet triangles.
fn mesh_only(triangles: &[[Vec3; 3]]) -> Scene {
    let text = r#"
[materials.m]
type = "phong"
albedo = [0.5, 0.5, 0.5]
shininess = 10
[[objects]]
type = "mesh"
path = "m.obj"
material = "m"
"#;
    scene_with_files(text, &[("m.obj", obj_text(triangles))])
}

fn bunny_triangles(scene: &Scene) -> Vec<[Vec3; 3]> {
    (0..scene.triangles.len())
        .map(|i| scene.triangles.vertices(i))
        .collect()
}

#[test]
fn bunny_100k_rays_match_brute_force() {
    let scene = bunny_mesh_scene(0);
    // The whole scene (ground sphere, mirror, light beside the tree) ...
    assert_same_closest_hits(&scene, 20_000, 1);
    // ... and rays aimed at the mesh itself.
    let mesh = mesh_only(&bunny_triangles(&scene));
    assert_same_closest_hits(&mesh, 100_000, 2);
}

#[test]
fn subdivided_bunny_rays_match_brute_force() {
    let scene = bunny_mesh_scene(1);
    assert_eq!(scene.triangles.len(), 19_872);
    let mesh = mesh_only(&bunny_triangles(&scene));
    assert_same_closest_hits(&mesh, 20_000, 3);
}

/// More than `LINEAR_LIMIT` of every kind, so all three kinds are in the tree together.
fn mixed_scene() -> Scene {
    with_icosphere(&mixed_scene_text())
}

/// The mixed scene's file, whose mesh is `ico.obj` (`with_icosphere`).
fn mixed_scene_text() -> String {
    let mut rng = Rng(9);
    let mut text = String::from(
        "[materials.m]\ntype = \"phong\"\nalbedo = [0.5, 0.5, 0.5]\nshininess = 10\n\
         [materials.l]\ntype = \"light\"\ncolor = [1, 1, 1]\n",
    );
    let p = |rng: &mut Rng| {
        [
            rng.range(-5.0, 5.0),
            rng.range(-5.0, 5.0),
            rng.range(-5.0, 5.0),
        ]
    };
    for i in 0..60 {
        let c = p(&mut rng);
        let m = if i % 7 == 0 { "l" } else { "m" };
        text += &format!(
            "[[objects]]\ntype = \"sphere\"\ncenter = {c:?}\nradius = {}\nmaterial = \"{m}\"\n",
            rng.range(0.05, 0.8)
        );
    }
    for i in 0..40 {
        let c = p(&mut rng);
        let u = [
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        ];
        let v = [
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        ];
        if i % 2 == 0 {
            text += &format!("[[objects]]\ntype = \"quad\"\ncorner = {c:?}\nu = {u:?}\nv = {v:?}\nmaterial = \"m\"\n");
        } else {
            let d = [c[0] + 0.5, c[1] + 0.7, c[2] + 0.3];
            text += &format!(
                "[[objects]]\ntype = \"box\"\ncorners = [{c:?}, {d:?}]\nmaterial = \"m\"\n"
            );
        }
    }
    for _ in 0..80 {
        let a = p(&mut rng);
        let b = [
            a[0] + rng.range(-1.0, 1.0),
            a[1] + rng.range(-1.0, 1.0),
            a[2],
        ];
        let c = [
            a[0],
            a[1] + rng.range(-1.0, 1.0),
            a[2] + rng.range(-1.0, 1.0),
        ];
        text += &format!(
            "[[objects]]\ntype = \"triangle\"\na = {a:?}\nb = {b:?}\nc = {c:?}\nmaterial = \"m\"\n"
        );
    }
    text += "[[objects]]\ntype = \"mesh\"\npath = \"ico.obj\"\nmaterial = \"l\"\n";
    text
}

fn with_icosphere(text: &str) -> Scene {
    let ico = raytracer::generate::icosphere(2, Vec3::new(1.0, 2.0, -1.0), 1.5);
    scene_with_files(text, &[("ico.obj", obj_text(&ico))])
}

#[test]
fn mixed_scene_100k_rays_match_brute_force() {
    let scene = mixed_scene();
    let pair = Pair::new(&scene);
    let Some(b) = pair.bvh.1.bvh() else {
        unreachable!()
    };
    assert!(
        b.linear.iter().all(|r| r.is_empty()),
        "every primitive must be in the tree"
    );
    assert_same_closest_hits(&scene, 100_000, 4);
}

/// The mixed scene with `extra` objects added.
fn mixed_scene_with(extra: &[&str]) -> Scene {
    let mut text = mixed_scene_text();
    for object in extra {
        text += &format!("[[objects]]\n{object}\nmaterial = \"m\"\n");
    }
    let scene = with_icosphere(&text);
    assert_eq!(
        scene.primitive_count(),
        mixed_scene().primitive_count() + extra.len()
    );
    scene
}

/// The mixed scene on a huge ground: a sphere of radius 1000, or a quad and a triangle
/// 1000 units wide. Each has more than half the surface area of the scene's bounds
/// (`HUGE_FRACTION`), so it is tested beside the tree while the rest of its kind is in it.
#[test]
fn huge_primitives_beside_the_tree_match_brute_force() {
    let sphere = "type = \"sphere\"\ncenter = [0, -1006, 0]\nradius = 1000";
    let quad = "type = \"quad\"\ncorner = [-500, -6.5, -500]\nu = [1000, 0, 0]\nv = [0, 0, 1000]";
    let triangle =
        "type = \"triangle\"\na = [-600, -7, -600]\nb = [600, -7, -600]\nc = [0, -7, 600]";
    for (extra, beside) in [
        (&[sphere][..], [1, 0, 0]),
        (&[quad, triangle][..], [0, 1, 1]),
    ] {
        let scene = mixed_scene_with(extra);
        let pair = Pair::new(&scene);
        let Some(b) = pair.bvh.1.bvh() else {
            unreachable!()
        };
        assert_eq!(b.linear.clone().map(|r| r.len()), beside);
        // Rays around the mixed scene's own objects, down to the ground.
        let around = Aabb::new(Vec3::new(-6.0, -8.0, -6.0), Vec3::new(6.0, 6.0, 6.0));
        assert_same_closest_hits_in(&scene, around, 40_000, 6);
        assert_shadows_agree(&scene, 20_000);
    }
}

/// A scene of the "one weekend" kind, 484 small spheres on a ground sphere of radius
/// 1000 (tests/data/many-spheres.toml): the ground is tested beside the tree, every
/// other sphere is in it, and the image is the scan's, bit for bit.
#[test]
fn many_spheres_on_a_huge_ground_sphere() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/many-spheres.toml");
    let scene = builtin(path, 48, 2);
    assert_eq!(scene.spheres.len(), 486);
    let mut tree_scene = scene.clone();
    let Some(b) = Accel::build(&mut tree_scene, AccelKind::Bvh).bvh().cloned() else {
        unreachable!()
    };
    assert_eq!(b.linear.clone().map(|r| r.len()), [1, 0, 0]);
    assert_eq!(tree_scene.spheres.radius(b.linear[0].start), 1000.0);
    let l = render_with(&scene, AccelKind::Linear, 2, 3);
    let t = render_with(&scene, AccelKind::Bvh, 2, 3);
    assert_eq!(bits(&l.film), bits(&t.film));
}

#[test]
fn shadow_visibility_and_any_hit_agree_with_closest_hit() {
    assert_shadows_agree(&mixed_scene(), 50_000);
}

/// Shadow rays from around the scene to its lights: visibility is the same with the BVH
/// and the scan, and any-hit before t_max agrees with a closest hit before it.
fn assert_shadows_agree(scene: &Scene, n: usize) {
    assert!(scene.lights.len() > 5);
    let pair = Pair::new(scene);
    let mut rng = Rng(5);
    let mut s = TraversalStats::default();
    let (mut visible, mut blocked) = (0, 0);
    for i in 0..n {
        let light = &scene.lights[i % scene.lights.len()];
        let o = Vec3::new(
            rng.range(-6.0, 6.0),
            rng.range(-6.0, 6.0),
            rng.range(-6.0, 6.0),
        );
        let target = light.sample(rng.f32(), rng.f32(), rng.f32());
        let ray = Ray::new(o, (target - o).normalize_or(Vec3::Y));
        let l =
            pair.linear
                .1
                .light_visible(Context::new(&pair.linear.0, &mut s), &ray, T_MIN, light);
        let b = pair
            .bvh
            .1
            .light_visible(Context::new(&pair.bvh.0, &mut s), &ray, T_MIN, light);
        assert_eq!(l, b, "ray {i} to light {}", light.object);
        if l {
            visible += 1
        } else {
            blocked += 1
        }
        // Any-hit with no light excluded: occluded before t_max ⇔ a closest hit before it.
        let Some(bvh) = pair.bvh.1.bvh() else {
            unreachable!()
        };
        let t_max = rng.range(0.0, 12.0);
        let query = ShadowQuery {
            t_min: T_MIN,
            t_light: t_max,
            id_light: u32::MAX,
            object: u32::MAX,
        };
        let any = bvh.occluded(Context::new(&pair.bvh.0, &mut s), &ray, query);
        let closest = pair.closest(&ray, t_max).0.is_some();
        assert_eq!(any, closest, "any-hit ray {i}, t_max {t_max}");
    }
    assert!(
        visible > 1000 && blocked > 1000,
        "visible {visible}, blocked {blocked}"
    );
}

#[test]
fn tree_is_the_same_for_one_and_two_threads() {
    // 79 488 triangles: above the parallel-build threshold.
    let scene = bunny_mesh_scene(2);
    let build = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut s = scene.clone();
            let a = Accel::build(&mut s, AccelKind::Bvh);
            let Some(b) = a.bvh().cloned() else {
                unreachable!()
            };
            (b, s.triangles.id.clone(), s.triangles.a[0].clone())
        })
    };
    let (one, ids1, ax1) = build(1);
    let (two, ids2, ax2) = build(2);
    assert!(one.nodes.len() > 1000);
    assert_eq!(
        bytemuck::cast_slice::<_, u8>(&one.nodes),
        bytemuck::cast_slice::<_, u8>(&two.nodes)
    );
    assert!(one.nodes8.len() > 500);
    assert_eq!(
        bytemuck::cast_slice::<_, u8>(&one.nodes8),
        bytemuck::cast_slice::<_, u8>(&two.nodes8)
    );
    assert_eq!(
        (one.root, one.root8, one.depth, one.leaves),
        (two.root, two.root8, two.depth, two.leaves)
    );
    assert_eq!(ids1, ids2);
    assert_eq!(
        ax1.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
        ax2.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
    );
}

/// A child's box as (min, max) corners.
type ChildBox<N> = dyn Fn(&N, usize) -> ([f32; 3], [f32; 3]);

/// The leaves of a tree (`nodes`, `node_box` and `children` of one width) under
/// `code`, each with the box its parent gives it, checking that every child's box
/// holds its own children's.
fn leaves_under<N>(
    nodes: &[N],
    code: u32,
    node_box: &ChildBox<N>,
    children: &dyn Fn(&N) -> &[u32],
    out: &mut Vec<u32>,
) {
    use raytracer::accel::bvh::{EMPTY, LEAF};
    if code & LEAF != 0 {
        out.push(code);
        return;
    }
    let n = &nodes[code as usize];
    for (i, &c) in children(n).iter().enumerate() {
        if c == EMPTY {
            continue;
        }
        let (lo, hi) = node_box(n, i);
        if c & LEAF == 0 {
            let kid = &nodes[c as usize];
            for (j, &g) in children(kid).iter().enumerate() {
                if g != EMPTY {
                    let (glo, ghi) = node_box(kid, j);
                    assert!((0..3).all(|a| lo[a] <= glo[a] && ghi[a] <= hi[a]));
                }
            }
        }
        leaves_under(nodes, c, node_box, children, out);
    }
}

#[test]
fn the_8_wide_tree_has_the_4_wide_leaves_in_the_same_order() {
    for scene in [bunny_mesh_scene(1), mixed_scene()] {
        let mut s = scene;
        let Some(b) = Accel::build(&mut s, AccelKind::Bvh).bvh().cloned() else {
            unreachable!()
        };
        let (mut four, mut eight) = (Vec::new(), Vec::new());
        leaves_under(
            &b.nodes,
            b.root.unwrap(),
            &|n, i| n.child_box(i),
            &|n| &n.child,
            &mut four,
        );
        leaves_under(
            &b.nodes8,
            b.root8.unwrap(),
            &|n, i| n.child_box(i),
            &|n| &n.child,
            &mut eight,
        );
        assert_eq!(four.len() as u32, b.leaves);
        assert_eq!(four, eight);
        // Fewer, wider nodes: at most 4 − 1 and 8 − 1 new children a node.
        assert!(b.nodes8.len() < b.nodes.len());
        assert!(b.nodes8.len() * 7 + 1 >= b.leaves as usize);
    }
}

#[test]
fn degenerate_inputs() {
    // An empty scene: no tree, every ray misses.
    let empty = scene_with_files("background = [0.2, 0.3, 0.4]\n", &[]);
    let mut e = empty.clone();
    let Some(b) = Accel::build(&mut e, AccelKind::Bvh).bvh().cloned() else {
        unreachable!()
    };
    assert!(b.root.is_none());
    let film = render_with(&empty, AccelKind::Bvh, 2, 0).film;
    // The mean of 10 equal samples, within rounding.
    let bg = Vec3::new(0.2, 0.3, 0.4);
    assert!(film
        .pixels
        .iter()
        .all(|p| (*p - bg).abs().max_element() < 1e-6));

    // One triangle in a mesh; 500 copies of one triangle (all centroids equal: the
    // smallest id wins); zero-area triangles mixed into a mesh.
    let tri = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    let single = mesh_only(&[tri]);
    assert_same_closest_hits(&single, 3_000, 6);
    let copies = mesh_only(&vec![tri; 500]);
    let pair = Pair::new(&copies);
    let ray = Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z);
    let (l, b) = pair.closest(&ray, f32::INFINITY);
    assert_eq!(key(l), key(b));
    assert_eq!(b.unwrap().id, 0);
    assert_same_closest_hits(&copies, 3_000, 7);

    let ico = raytracer::generate::icosphere(2, Vec3::ZERO, 1.0);
    let mut with_degenerate = Vec::new();
    for (i, t) in ico.iter().enumerate() {
        with_degenerate.push(*t);
        if i % 3 == 0 {
            with_degenerate.push([t[0], t[0], t[1]]); // repeated vertex
                                                      // Nearly collinear: the rounded midpoint may leave a needle of tiny area.
            with_degenerate.push([t[0], (t[0] + t[1]) * 0.5, t[1]]);
        }
    }
    let dirty = mesh_only(&with_degenerate);
    // The 107 repeated-vertex faces are dropped at load; needles stay, in the tree.
    assert!(
        dirty.degenerate_triangles >= 107,
        "{}",
        dirty.degenerate_triangles
    );
    assert!(dirty.triangles.len() >= 320);
    assert_same_closest_hits(&dirty, 5_000, 8);
}

#[test]
fn every_builtin_scene_is_the_same_with_bvh_and_linear() {
    for name in raytracer::scene::builtin::names() {
        let scene = builtin(name, 32, 2);
        let l = render_with(&scene, AccelKind::Linear, 2, 3);
        let b = render_with(&scene, AccelKind::Bvh, 2, 3);
        assert_eq!(bits(&l.film), bits(&b.film), "{name}");
        assert_eq!(
            (l.counts.camera, l.counts.shadow, l.counts.secondary),
            (b.counts.camera, b.counts.shadow, b.counts.secondary),
            "{name}"
        );
    }
}

/// Triangles spaced in a geometric series along x: each binned SAH split peels off a few,
/// so the tree is as deep as the build allows (`build::MAX_SAH_DEPTH`, then halvings).
/// Rays along the series enter every box beyond their origin, and shadow queries whose
/// light is the mesh itself find no occluder and so visit the whole tree: the deepest
/// stacks the traversals can have here stay within their bounds (`accel::stack`, whose
/// pushes check it), and every answer agrees with the scan.
#[test]
fn a_deep_tree_stays_within_the_traversal_stacks() {
    let x = |i: usize| 1.01f32.powi(i as i32);
    let triangles: Vec<[Vec3; 3]> = (0..2300)
        .map(|i| {
            let s = 0.002 * x(i);
            [
                Vec3::new(x(i), -s, -s),
                Vec3::new(x(i), s, -s),
                Vec3::new(x(i), 0.0, s),
            ]
        })
        .collect();
    let pair = Pair::new(&mesh_only(&triangles));
    let (scene, accel) = &pair.bvh;
    let Some(bvh) = accel.bvh() else {
        unreachable!()
    };
    assert!(bvh.depth >= 20, "4-wide depth {}", bvh.depth);
    let object = scene.triangles.object[0];
    let mut s = TraversalStats::default();
    let rays: Vec<Ray> = (0..2300)
        .step_by(7)
        .flat_map(|i| {
            let o = Vec3::new(0.5 * (x(i) + x(i + 1)), 0.0, 0.0);
            [Ray::new(o, Vec3::X), Ray::new(o, -Vec3::X)]
        })
        .collect();
    for (k, ray) in rays.iter().enumerate() {
        let (l, b) = pair.closest(ray, f32::INFINITY);
        assert!(l.is_some(), "ray {k} misses");
        assert_eq!(key(l), key(b), "ray {k}");
        let query = |object| ShadowQuery {
            t_min: T_MIN,
            t_light: f32::MAX,
            id_light: u32::MAX,
            object,
        };
        assert!(bvh.occluded(Context::new(scene, &mut s), ray, query(u32::MAX)));
        assert!(!bvh.occluded(Context::new(scene, &mut s), ray, query(object)));
    }
    // Packets of 16 lanes, and of 8.
    for group in rays.chunks_exact(16) {
        let rays: [Ray; MAX_WIDTH] = std::array::from_fn(|k| group[k]);
        let p = RayPacket::<F32x16>::new(&rays, 0xffff);
        let hits = bvh
            .closest_hit_packet(Context::new(scene, &mut s), &p, T_MIN)
            .to_array();
        for (k, ray) in group.iter().enumerate() {
            assert_eq!(key(hits[k]), key(pair.closest(ray, f32::INFINITY).1));
        }
        let shadow = ShadowLanes::<F32x16>::from_fn(T_MIN, object, |_| (f32::MAX, u32::MAX));
        assert_eq!(
            bvh.occluded_packet(Context::new(scene, &mut s), &p, shadow, 0xffff),
            0
        );
    }
    for group in rays.chunks_exact(8) {
        let rays: [Ray; MAX_WIDTH] = std::array::from_fn(|k| group[k % 8]);
        let p = RayPacket::<f32x8>::new(&rays, 0xff);
        let hits = bvh
            .closest_hit_packet(Context::new(scene, &mut s), &p, T_MIN)
            .to_array();
        for (k, ray) in group.iter().enumerate() {
            assert_eq!(key(hits[k]), key(pair.closest(ray, f32::INFINITY).1));
        }
        let shadow = ShadowLanes::<f32x8>::from_fn(T_MIN, object, |_| (f32::MAX, u32::MAX));
        assert_eq!(
            bvh.occluded_packet(Context::new(scene, &mut s), &p, shadow, 0xff),
            0
        );
    }
    // Every node of the 4-wide tree was visited by the packets' shadow queries.
    assert!(s.packet_nodes >= bvh.nodes.len() as u64);
}
