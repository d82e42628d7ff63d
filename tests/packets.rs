//! Packets against the scalar path: the same image bits at every packet width and
//! thread count, and the same per-lane answers (t, primitive id, visibility) for random
//! packets with random active masks.

mod support;

use glam::{Vec3, Vec4};
use proptest::prelude::*;
use raytracer::accel::packet::{RayPacket, ShadowLanes};
use raytracer::accel::{Accel, AccelKind, Context, TraversalStats};
use raytracer::geometry::{Hit, Ray};
use raytracer::integrator::T_MIN;
use raytracer::integrator::{RayCounts, Tracer};
use raytracer::lanes::{F32x16, Lane, MAX_WIDTH};
use raytracer::render::{render, RenderSettings};
use raytracer::sampling::SamplerKind;
use raytracer::scene::builtin::SCENES;
use raytracer::scene::Scene;
use raytracer::PacketWidth;
use std::sync::OnceLock;
use support::{bits, builtin, builtin_with_camera, scene_with_files, Rng};
use wide::f32x8;

fn render_counts(
    scene: &Scene,
    accel: &Accel,
    width: u32,
    threads: usize,
    specialize: bool,
) -> (Vec<[u32; 3]>, RayCounts) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let settings = RenderSettings {
        seed: 7,
        packet_width: PacketWidth::try_from(width).unwrap(),
        specialize,
        sampler: SamplerKind::Independent,
    };
    let rendered = pool
        .install(|| render(scene, accel, &settings, &|| {}))
        .unwrap();
    (bits(&rendered.film), rendered.counts)
}

fn render_bits(scene: &Scene, accel: &Accel, width: u32, threads: usize) -> Vec<[u32; 3]> {
    render_counts(scene, accel, width, threads, true).0
}

/// `scene` rendered with `sampler` (seed 3) gives the scalar image's bits at widths 4,
/// 8 and 16.
fn same_bits_at_every_width(scene: &Scene, accel: &Accel, sampler: SamplerKind, name: &str) {
    let film = |packet_width| {
        let settings = RenderSettings {
            packet_width,
            sampler,
            ..RenderSettings::new(3)
        };
        bits(&render(scene, accel, &settings, &|| {}).unwrap().film)
    };
    let reference = film(PacketWidth::Scalar);
    assert!(
        film(PacketWidth::Four) == reference,
        "{name}, {sampler:?}: 4-wide"
    );
    assert!(
        film(PacketWidth::Eight) == reference,
        "{name}, {sampler:?}: 8-wide"
    );
    assert!(
        film(PacketWidth::Sixteen) == reference,
        "{name}, {sampler:?}: 16-wide"
    );
}

/// The structured samplers, whose numbers the packet tracer draws lane by lane, give the
/// same bits at every width too.
#[test]
fn every_sampler_same_bits_at_every_width() {
    for sampler in [SamplerKind::Stratified, SamplerKind::Sobol] {
        for name in ["cornell-area-light", "mixed", "bunny"] {
            let mut scene = builtin(name, 21, 3);
            let accel = Accel::build(&mut scene, AccelKind::Bvh);
            same_bits_at_every_width(&scene, &accel, sampler, name);
        }
    }
}

/// Specialisation skips work, never changes a bit: every built-in scene with and
/// without it, scalar, 8- and 16-wide. And it does skip: shadow rays in every scene with
/// Phong and lights, packets that miss everything where the background shows.
#[test]
fn specialisation_skips_work_and_keeps_the_bits() {
    for (name, _) in SCENES {
        let mut scene = builtin(name, 37, 2);
        let accel = Accel::build(&mut scene, AccelKind::Bvh);
        let (reference, general) = render_counts(&scene, &accel, 1, 2, false);
        assert_eq!(general.shadow_culled + general.packets_outside, 0);
        assert_eq!(general.cone_prims + general.cone_trees, 0);
        let (scalar, c1) = render_counts(&scene, &accel, 1, 2, true);
        let (packets, c8) = render_counts(&scene, &accel, 8, 2, true);
        let (packets_general, _) = render_counts(&scene, &accel, 8, 2, false);
        let (sixteen, c16) = render_counts(&scene, &accel, 16, 2, true);
        let (sixteen_general, _) = render_counts(&scene, &accel, 16, 2, false);
        assert!(scalar == reference, "{name}: scalar, specialised");
        assert!(packets == reference, "{name}: 8-wide, specialised");
        assert!(packets_general == reference, "{name}: 8-wide, general");
        assert!(sixteen == reference, "{name}: 16-wide, specialised");
        assert!(sixteen_general == reference, "{name}: 16-wide, general");
        assert_eq!(c16.shadow + c16.shadow_culled, general.shadow, "{name}");
        assert_eq!(c1.shadow_culled, c16.shadow_culled, "{name}");
        // Culled shadow rays are not traced: the same total either way.
        assert_eq!(c1.shadow + c1.shadow_culled, general.shadow, "{name}");
        assert_eq!(c8.shadow + c8.shadow_culled, general.shadow, "{name}");
        assert_eq!(c1.shadow_culled, c8.shadow_culled, "{name}");
        assert!(c8.shadow_culled > 0, "{name}: no shadow ray was culled");
        // Every scene has a primitive beside the tree that some tile cannot see.
        assert!(
            c8.cone_prims > 0,
            "{name}: no test ruled out by a tile's cone"
        );
        assert_eq!(
            c1.cone_prims + c1.cone_trees,
            0,
            "{name}: the scalar path skips only whole tiles by their cones"
        );
        if *name == "quads" {
            // The scalar tiles too: the corners of `quads` show only the background.
            assert!(
                c1.packets_outside > 0,
                "{name}: no scalar tile left at once"
            );
        }
        if name.starts_with("cornell") || *name == "quads" {
            assert!(c8.packets_outside > 0, "{name}: no packet left at once");
        }
        // Camera packets skip the test against the scene's box only when the camera is
        // inside it: `bunny`'s camera is inside its 100-unit ground sphere, `cornell`'s
        // looks into the room from outside.
        if let Some(b) = accel.bvh() {
            // The mesh is small in `bunny`'s scene, the room is all of `cornell`'s.
            match *name {
                "bunny" | "bunny-closeup" => assert!(b.tree_box_first, "{name}"),
                n if n.starts_with("cornell") => assert!(!b.tree_box_first, "{name}"),
                _ => {}
            }
        }
        let inside = Tracer::new(&scene, &accel, 1).camera_inside;
        let o = scene.camera.origin;
        assert_eq!(
            inside,
            scene.bounds.min.cmplt(o).all() && o.cmplt(scene.bounds.max).all(),
            "{name}"
        );
        match *name {
            "bunny" | "bunny-closeup" => assert!(inside, "{name}"),
            n if n.starts_with("cornell") => assert!(!inside, "{name}"),
            _ => {}
        }
    }
}

/// Every built-in scene, 37 pixels wide (so packets straddle the right edge and the
/// bottom rows), gives the same linear f32 bits at widths 1, 4, 8 and 16 and on 1 and 2
/// threads; and with the linear scan under the packets too.
#[test]
fn every_scene_same_bits_at_every_width_and_thread_count() {
    for (name, _) in SCENES {
        let mut scene = builtin(name, 37, 2);
        let accel = Accel::build(&mut scene, AccelKind::Bvh);
        let reference = render_bits(&scene, &accel, 1, 1);
        for (width, threads) in [(1, 2), (4, 1), (4, 2), (8, 1), (8, 2), (16, 1), (16, 2)] {
            assert!(
                render_bits(&scene, &accel, width, threads) == reference,
                "{name}: width {width}, {threads} threads differs from the scalar image"
            );
        }
        let mut linear_scene = builtin(name, 37, 2);
        let linear = Accel::build(&mut linear_scene, AccelKind::Linear);
        for width in [8, 16] {
            assert!(
                render_bits(&linear_scene, &linear, width, 2) == reference,
                "{name}: {width}-wide over the linear scan differs"
            );
        }
    }
}

/// Through a thin lens, camera packets' rays start at different points (no frustum
/// traversal; tile cones widened to hold the lens): every built-in scene with a lens
/// added, 37 pixels wide, gives the same bits at widths 1, 4, 8 and 16 and on 1 and 2
/// threads, with every sampler.
#[test]
fn every_scene_through_a_lens_same_bits_at_every_width_and_thread_count() {
    for (name, _) in SCENES {
        let mut scene = if name.ends_with("-defocus") {
            builtin(name, 37, 2)
        } else {
            builtin_with_camera(name, "defocus_angle = 10\nfocus_dist = 2", 37, 2)
        };
        assert!(scene.camera.has_lens(), "{name}");
        let accel = Accel::build(&mut scene, AccelKind::Bvh);
        let reference = render_bits(&scene, &accel, 1, 1);
        for (width, threads) in [(1, 2), (4, 1), (4, 2), (8, 1), (8, 2), (16, 1), (16, 2)] {
            assert!(
                render_bits(&scene, &accel, width, threads) == reference,
                "{name}: width {width}, {threads} threads differs from the scalar image"
            );
        }
        for sampler in [SamplerKind::Stratified, SamplerKind::Sobol] {
            same_bits_at_every_width(&scene, &accel, sampler, name);
        }
    }
}

/// A scene with every kind both inside the BVH (more than 16 of a kind) and beside it:
/// 40 small spheres, 3 big ones (the ground sphere beside the tree, being huge), 24 quads (four boxes), the bunny, a point light and a
/// quad light.
fn mixed_scene() -> &'static (Scene, Accel) {
    static SCENE: OnceLock<(Scene, Accel)> = OnceLock::new();
    SCENE.get_or_init(|| {
        let mut text = String::from(
            r#"
[camera]
width = 8
aspect_ratio = "1:1"
look_from = [0, 0.1, 1]
look_at = [0, 0.1, 0]
[materials.m]
type = "phong"
albedo = [0.5, 0.5, 0.5]
shininess = 10
[materials.lamp]
type = "light"
color = [1, 1, 1]
intensity = 1
[[objects]]
type = "mesh"
path = "bunny.obj"
material = "m"
[[objects]]
type = "sphere"
center = [0.05, 0.3, 0.1]
radius = 0.01
material = "lamp"
[[objects]]
type = "quad"
corner = [-0.2, 0.35, -0.2]
u = [0.4, 0, 0]
v = [0, 0, 0.4]
material = "lamp"
[[objects]]
type = "sphere"
center = [0, -100.0, 0]
radius = 99.97
material = "m"
"#,
        );
        let mut rng = Rng(99);
        for _ in 0..40 {
            let c = Vec3::new(
                rng.range(-0.2, 0.2),
                rng.range(-0.05, 0.3),
                rng.range(-0.2, 0.2),
            );
            text += &format!(
                "[[objects]]\ntype = \"sphere\"\ncenter = [{}, {}, {}]\nradius = {}\nmaterial = \"m\"\n",
                c.x,
                c.y,
                c.z,
                rng.range(0.002, 0.03)
            );
        }
        for k in 0..4 {
            let lo = Vec3::new(-0.25 + 0.12 * k as f32, -0.03, -0.25);
            text += &format!(
                "[[objects]]\ntype = \"box\"\ncorners = [[{}, {}, {}], [{}, {}, {}]]\nmaterial = \"m\"\n",
                lo.x,
                lo.y,
                lo.z,
                lo.x + 0.05,
                lo.y + 0.04,
                lo.z + 0.07
            );
        }
        let obj = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/bunny.obj"))
            .unwrap();
        let mut scene = scene_with_files(&text, &[("bunny.obj", obj)]);
        let accel = Accel::build(&mut scene, AccelKind::Bvh);
        let Some(b) = accel.bvh() else { unreachable!() };
        assert_eq!(
            b.linear.clone().map(|r| r.len()),
            [1, 0, 0],
            "the ground sphere is beside the tree (`HUGE_FRACTION`), every other primitive in it"
        );
        assert!(b.tree_box_first, "packets test the small tree's box first");
        (scene, accel)
    })
}

/// Sixteen rays of one kind: 0 random, 1 aimed at the scene, 2 axis-parallel with ±0
/// components, 3 starting exactly on a surface (a hit point, no offset), 4 pointing away
/// from the scene (miss everything); 5 a coherent bundle (like camera rays); 6 one origin,
/// a wide frustum; 7 from origins all around, aimed exactly at points on the boxes'
/// edges (quads' edge functions near zero, with each lane's axes its own); 8 the same at
/// the bunny's vertices and points of its edges (triangles' edge functions near zero).
fn packet_rays(scene: &Scene, accel: &Accel, kind: u8, seed: u64) -> [Ray; MAX_WIDTH] {
    let mut rng = Rng(seed);
    // The small objects' region (the ground sphere's bounds would swallow it).
    let b = raytracer::geometry::Aabb::new(Vec3::new(-0.3, -0.05, -0.3), Vec3::new(0.3, 0.4, 0.3));
    let ext = b.max - b.min;
    let point = |rng: &mut Rng, grow: f32| {
        b.min - ext * grow + Vec3::new(rng.f32(), rng.f32(), rng.f32()) * ext * (1.0 + 2.0 * grow)
    };
    let centre = (b.min + b.max) * 0.5;
    let base = point(&mut rng, 0.5);
    let aim = point(&mut rng, 0.0);
    let octant = Vec3::new(rng.sign(), rng.sign(), rng.sign());
    std::array::from_fn(|_| match kind {
        0 => Ray::new(point(&mut rng, 0.5), rng.unit_vector()),
        1 => {
            let o = point(&mut rng, 1.0);
            Ray::new(o, (point(&mut rng, 0.0) - o).normalize_or(Vec3::X))
        }
        2 => {
            // Signed zeros on the other axes.
            let d = rng.axis_direction();
            Ray::new(point(&mut rng, 0.2), d)
        }
        3 => {
            let o = point(&mut rng, 1.0);
            let r = Ray::new(o, (centre - o).normalize_or(Vec3::X));
            let mut s = TraversalStats::default();
            match accel.closest_hit(Context::new(scene, &mut s), &r, T_MIN, f32::INFINITY) {
                Some(h) => Ray::new(r.at(h.t), rng.unit_vector()),
                None => r,
            }
        }
        4 => {
            let o = b.max + ext * (0.1 + rng.f32());
            let d = Vec3::new(rng.f32(), rng.f32(), rng.f32()) + Vec3::splat(0.01);
            Ray::new(o, d.normalize())
        }
        5 => {
            let jitter = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * ext * 0.05;
            Ray::new(base, (aim + jitter - base).normalize_or(Vec3::X))
        }
        6 => {
            // One origin, directions spread over one octant: a wide frustum
            // (`Frustum` in `accel::packet`).
            let d = rng.unit_vector().abs().max(Vec3::splat(1e-3)) * octant;
            Ray::new(base, d.normalize())
        }
        8 => {
            let n = scene.triangles.len() as u64;
            let v = scene.triangles.vertices((rng.next_u64() % n) as usize);
            let (a, b) = (
                v[(rng.next_u64() % 3) as usize],
                v[(rng.next_u64() % 3) as usize],
            );
            let p = a + (b - a) * rng.f32();
            let o = centre + rng.unit_vector() * 0.6;
            Ray::new(o, (p - o).normalize_or(Vec3::X))
        }
        _ => {
            // A box of `mixed_scene`, its corners as the scene's text has them.
            let k = (rng.next_u64() % 4) as f32;
            let lo = Vec3::new(-0.25 + 0.12 * k, -0.03, -0.25);
            let hi = Vec3::new(lo.x + 0.05, lo.y + 0.04, lo.z + 0.07);
            let along = (rng.next_u64() % 3) as usize;
            let corner = |axis: usize, rng: &mut Rng| {
                if rng.next_u64().is_multiple_of(2) {
                    lo[axis]
                } else {
                    hi[axis]
                }
            };
            let mut p = Vec3::ZERO;
            for axis in 0..3 {
                p[axis] = if axis == along {
                    lo[axis] + rng.f32() * (hi[axis] - lo[axis])
                } else {
                    corner(axis, &mut rng)
                };
            }
            let o = centre + rng.unit_vector() * 0.6;
            Ray::new(o, (p - o).normalize_or(Vec3::X))
        }
    })
}

fn key(h: &Option<Hit>) -> Option<(u32, u32, u32)> {
    h.map(|h| (h.t.to_bits(), h.id, h.object))
}

#[allow(clippy::needless_range_loop)] // lanes index several arrays
fn check_packet<L: Lane>(rays: &[Ray; MAX_WIDTH], active: u32) -> Result<(), TestCaseError> {
    let (scene, accel) = mixed_scene();
    let mut s = TraversalStats::default();
    let p = RayPacket::<L>::new(rays, active);
    let hits = accel
        .closest_hit_packet(Context::new(scene, &mut s), &p, T_MIN)
        .to_array();
    for (light_index, light) in scene.lights.iter().enumerate() {
        let visible =
            accel.light_visible_packet(Context::new(scene, &mut s), &p, T_MIN, light, active, None);
        for k in 0..L::WIDTH {
            let want = active >> k & 1 != 0
                && accel.light_visible(Context::new(scene, &mut s), &rays[k], T_MIN, light);
            prop_assert_eq!(
                visible >> k & 1 != 0,
                want,
                "light {} lane {}",
                light_index,
                k
            );
        }
    }
    for k in 0..L::WIDTH {
        let want = if active >> k & 1 != 0 {
            accel.closest_hit(Context::new(scene, &mut s), &rays[k], T_MIN, f32::INFINITY)
        } else {
            None
        };
        prop_assert_eq!(key(&hits[k]), key(&want), "lane {} of {:?}", k, rays[k]);
    }
    // Any-hit with arbitrary bounds: occluded before (t, id) per lane. In about half the
    // lanes the bound is the lane's own closest hit, so a primitive at exactly the
    // bound's distance is decided by the ids (`beats`).
    let Some(bvh) = accel.bvh() else {
        unreachable!()
    };
    let mut rng = Rng(active as u64);
    let t_light: [f32; MAX_WIDTH] = std::array::from_fn(|k| match hits[k] {
        Some(h) if rng.next_u64().is_multiple_of(2) => h.t,
        _ => rng.range(0.0, 0.6),
    });
    let id_light: [u32; MAX_WIDTH] = std::array::from_fn(|k| match hits[k] {
        Some(h) if rng.next_u64().is_multiple_of(3) => h.id,
        _ => (rng.next_u64() % 5000) as u32,
    });
    let object = scene.lights[0].object;
    let query = ShadowLanes::<L>::from_fn(T_MIN, object, |k| (t_light[k], id_light[k]));
    let occluded = bvh.occluded_packet(Context::new(scene, &mut s), &p, query, active);
    for k in 0..L::WIDTH {
        let want = active >> k & 1 != 0
            && bvh.occluded(Context::new(scene, &mut s), &rays[k], query.lane(k));
        prop_assert_eq!(occluded >> k & 1 != 0, want, "occluded lane {}", k);
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn packets_return_the_scalar_answers(kind in 0u8..9, seed: u64, mask in 1u32..65536) {
        let (scene, accel) = mixed_scene();
        let rays = packet_rays(scene, accel, kind, seed);
        check_packet::<F32x16>(&rays, mask)?;
        let mask8 = if mask & 0xff == 0 { mask >> 8 } else { mask & 0xff };
        check_packet::<f32x8>(&rays, mask8)?;
        let mask4 = if mask8 & 0xf == 0 { mask8 >> 4 } else { mask8 & 0xf };
        check_packet::<Vec4>(&rays, mask4)?;
    }
}

/// The random packets do reach the interesting cases: hits of every kind, misses, and
/// both visible and occluded shadow rays.
#[test]
fn packet_rays_cover_hits_of_every_kind() {
    let (scene, accel) = mixed_scene();
    let mut s = TraversalStats::default();
    let mut kinds = std::collections::HashSet::new();
    let (mut hits, mut misses) = (0, 0);
    for kind in 0..9 {
        for seed in 0..50 {
            for r in packet_rays(scene, accel, kind, seed) {
                match accel.closest_hit(Context::new(scene, &mut s), &r, T_MIN, f32::INFINITY) {
                    Some(h) => {
                        hits += 1;
                        kinds.insert(format!("{:?}", h.kind));
                    }
                    None => misses += 1,
                }
            }
        }
    }
    assert_eq!(kinds.len(), 3, "{kinds:?}");
    assert!(hits > 500 && misses > 500, "{hits} hits, {misses} misses");
}

/// A tile's camera cone never rules out what a camera ray of the tile hits: every
/// built-in scene, 64 pixels wide, each 16-pixel tile (and a few odd rectangles), rays
/// at the pixels' corners from the lens disk's edge (with a lens), and at random jitters
/// and lens points. The primitive each ray hits (scalar
/// closest hit) is kept by the rectangle's `camera_cull`, which never says a rectangle
/// with a hit meets nothing. And the cull is no formality: across the scenes it rules
/// out many tests, and some tiles meet nothing at all.
#[test]
fn a_tiles_cone_keeps_every_primitive_its_camera_rays_hit() {
    let mut rng = Rng(11);
    let (mut checked, mut ruled_out, mut nothing) = (0u64, 0u64, 0u64);
    let mut scenes: Vec<(String, Scene)> = SCENES
        .iter()
        .map(|(name, _)| (name.to_string(), builtin(name, 64, 1)))
        .collect();
    // Lenses with the camera outside the scene's box and inside it.
    for (name, keys) in [
        ("cornell", "defocus_angle = 4\nfocus_dist = 700"),
        ("bunny", "defocus_angle = 20\nfocus_dist = 0.6"),
    ] {
        let scene = builtin_with_camera(name, keys, 64, 1);
        scenes.push((format!("{name} through a lens"), scene));
    }
    for (name, mut scene) in scenes {
        let accel = Accel::build(&mut scene, AccelKind::Bvh);
        let Some(bvh) = accel.bvh() else {
            unreachable!()
        };
        let tracer = raytracer::integrator::Tracer::new(&scene, &accel, 0);
        let (w, h) = (scene.camera.width, scene.camera.height);
        let mut rects = Vec::new();
        for ty in (0..h).step_by(16) {
            for tx in (0..w).step_by(16) {
                rects.push((tx, ty, (tx + 16).min(w), (ty + 16).min(h)));
            }
        }
        rects.extend([
            (0, 0, w, h),
            (3, 5, 4, 6),
            (w - 1, h - 1, w, h),
            (10, 0, 37, 3),
        ]);
        for &(x0, y0, x1, y1) in &rects {
            let cull = tracer.camera_cull(x0, y0, x1, y1);
            ruled_out += (0..3)
                .map(|k| (!cull.beside[k]).count_ones() as u64)
                .sum::<u64>();
            nothing += cull.nothing as u64;
            for y in y0..y1 {
                for x in x0..x1 {
                    // Pixel corners and lens edges, and random points of both.
                    let last = 0.99999994;
                    let samples = [
                        [0.0, 0.0, 0.0, 0.5],
                        [last, last, last, 0.5],
                        [0.0, last, 0.5, last],
                        [last, 0.0, 0.5, 0.0],
                        [rng.f32(), rng.f32(), rng.f32(), rng.f32()],
                    ];
                    for [jx, jy, lx, ly] in samples {
                        let ray = scene.camera.ray(x, y, jx, jy, lx, ly);
                        let mut s = TraversalStats::default();
                        let Some(hit) = accel.closest_hit(
                            Context::new(&scene, &mut s),
                            &ray,
                            T_MIN,
                            f32::INFINITY,
                        ) else {
                            continue;
                        };
                        let k = hit.kind as usize;
                        let range = &bvh.linear[k];
                        let i = hit.index as usize;
                        let kept = !cull.nothing
                            && if range.contains(&i) {
                                i - range.start >= 32
                                    || cull.beside[k] >> (i - range.start) & 1 != 0
                            } else {
                                cull.tree
                            };
                        assert!(
                            kept,
                            "{name}: pixel ({x}, {y}) hits {hit:?}, ruled out by {cull:?}"
                        );
                        checked += 1;
                    }
                }
            }
        }
    }
    assert!(
        checked > 100_000 && ruled_out > 200 && nothing > 0,
        "{checked} {ruled_out} {nothing}"
    );
}

/// A small scene with every kind of primitive and light for the shadow candidates
/// (`accel::shadow`): spheres, boxes, tilted quads and triangles around a tilted quad
/// light, a triangle light and a point light; 58 primitives.
fn candidates_scene() -> (Scene, Accel) {
    let mut text = String::from(
        r#"
[camera]
width = 8
aspect_ratio = "1:1"
look_from = [0, 1, 4]
look_at = [0, 0, 0]
[materials.m]
type = "phong"
albedo = [0.5, 0.5, 0.5]
shininess = 10
[materials.lamp]
type = "light"
color = [1, 1, 1]
intensity = 1
[[objects]]
type = "quad"
corner = [-0.5, 1.5, -0.3]
u = [0.9, 0.1, 0]
v = [0, 0.2, 0.7]
material = "lamp"
[[objects]]
type = "triangle"
a = [1.2, 0.4, -0.8]
b = [1.5, 0.9, -0.6]
c = [1.1, 0.8, -0.2]
material = "lamp"
[[objects]]
type = "sphere"
center = [-1.2, 1.0, 0.6]
radius = 0.05
material = "lamp"
[[objects]]
type = "quad"
corner = [-2, -0.5, -2]
u = [4, 0, 0]
v = [0, 0, 4]
material = "m"
"#,
    );
    let mut rng = Rng(7);
    let point = |rng: &mut Rng| {
        Vec3::new(
            rng.range(-1.2, 1.2),
            rng.range(-0.5, 1.2),
            rng.range(-1.2, 1.2),
        )
    };
    for _ in 0..12 {
        let c = point(&mut rng);
        let r = rng.range(0.05, 0.3);
        text += &format!(
            "[[objects]]\ntype = \"sphere\"\ncenter = [{}, {}, {}]\nradius = {r}\nmaterial = \"m\"\n",
            c.x, c.y, c.z
        );
    }
    for _ in 0..4 {
        let lo = point(&mut rng);
        let hi = lo
            + Vec3::new(
                rng.range(0.1, 0.5),
                rng.range(0.1, 0.5),
                rng.range(0.1, 0.5),
            );
        text += &format!(
            "[[objects]]\ntype = \"box\"\ncorners = [[{}, {}, {}], [{}, {}, {}]]\nmaterial = \"m\"\n",
            lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
        );
    }
    for _ in 0..8 {
        let (a, u, v) = (
            point(&mut rng),
            rng.unit_vector() * 0.4,
            rng.unit_vector() * 0.3,
        );
        text += &format!(
            "[[objects]]\ntype = \"quad\"\ncorner = [{}, {}, {}]\nu = [{}, {}, {}]\nv = [{}, {}, {}]\nmaterial = \"m\"\n",
            a.x, a.y, a.z, u.x, u.y, u.z, v.x, v.y, v.z
        );
        let (b, c) = (a + rng.unit_vector() * 0.3, a + rng.unit_vector() * 0.3);
        text += &format!(
            "[[objects]]\ntype = \"triangle\"\na = [{}, {}, {}]\nb = [{}, {}, {}]\nc = [{}, {}, {}]\nmaterial = \"m\"\n",
            a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z
        );
    }
    let mut scene = scene_with_files(&text, &[]);
    let accel = Accel::build(&mut scene, AccelKind::Bvh);
    (scene, accel)
}

/// The shadow candidates keep every occluder: packets of shadow rays from points on the
/// surfaces (hit points, no offset, as near to the primitives as origins come) and from
/// points in the air, to samples of each light, see their light in exactly the lanes the
/// tree's traversal says, with only the candidates tested: in two small scenes, and in
/// one with a tree (the bunny on a floor quad under three sphere lights and a quad light:
/// the spheres and quads beside the tree, and the tree as one box). And the candidates
/// leave primitives out (else the test would prove nothing).
#[test]
fn shadow_candidates_keep_every_occluder() {
    use raytracer::accel::shadow::{origins_box, Among, ShadowBoxes};
    use raytracer::lanes::V3;
    let (mut tree_kept, mut tree_left) = (0, 0);
    for (name, (scene, accel)) in [
        ("candidates", candidates_scene()),
        ("cornell", {
            let mut s = builtin("cornell", 37, 1);
            let a = Accel::build(&mut s, AccelKind::Bvh);
            (s, a)
        }),
        ("lights-over-bunny", {
            let path = concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/benches/corpus/lights-over-bunny.toml"
            );
            let mut s = Scene::load(path, Default::default()).unwrap();
            let a = Accel::build(&mut s, AccelKind::Bvh);
            (s, a)
        }),
    ] {
        let bvh = accel.bvh().expect("a BVH");
        // The boxes' numbering: every primitive, or those beside the tree and the tree.
        let (boxes, objects): (_, Vec<u32>) = match ShadowBoxes::new(&scene) {
            Some(b) => {
                let objects = (scene.spheres.objects().iter())
                    .chain(&scene.quads.object)
                    .chain(&scene.triangles.object)
                    .copied()
                    .collect();
                (b, objects)
            }
            None => {
                let tree = bvh.root.map(|_| bvh.tree_box);
                let b = ShadowBoxes::beside(&scene, &bvh.linear, tree).expect("few beside");
                let [s, q, t] = bvh.linear.clone();
                let objects = (scene.spheres.objects()[s].iter())
                    .chain(&scene.quads.object[q])
                    .chain(&scene.triangles.object[t])
                    .copied()
                    .chain(tree.map(|_| u32::MAX))
                    .collect();
                (b, objects)
            }
        };
        let n = objects.len();
        let mut s = TraversalStats::default();
        let mut rng = Rng(n as u64);
        let (mut lanes_tested, mut occluded, mut visible, mut left_out) = (0, 0, 0, 0);
        let centre = scene.bounds.centroid();
        let ext = scene.bounds.max - scene.bounds.min;
        for round in 0..20_000 {
            // Eight origins near one another: hit points of a bundle of rays, or points
            // in the air.
            let base = centre + (Vec3::new(rng.f32(), rng.f32(), rng.f32()) - 0.5) * ext * 0.9;
            let aim = rng.unit_vector();
            let origins: [Vec3; 8] = std::array::from_fn(|_| {
                let d = (aim + rng.unit_vector() * 0.05).normalize();
                let r = Ray::new(base, d);
                match accel.closest_hit(Context::new(&scene, &mut s), &r, T_MIN, f32::INFINITY) {
                    Some(h) if round % 4 != 0 => r.at(h.t),
                    _ => base + d * rng.range(0.0, 0.2),
                }
            });
            let active = (rng.next_u64() as u32 & 0xff) | 1;
            let o = V3::<f32x8>::from_fn(|k| origins[k]);
            let region = origins_box(o, V3::splat(Vec3::ZERO), active);
            for (li, light) in scene.lights.iter().enumerate() {
                let Some(among) = boxes.candidates(li, &region) else {
                    continue;
                };
                let own = objects.iter().filter(|&&o| o == light.object).count();
                left_out += n - own - among.len();
                if let Among::Beside { tree, .. } = among {
                    *if tree { &mut tree_kept } else { &mut tree_left } += 1;
                }
                let mut u = || f32x8::from_fn(|_| rng.f32());
                let (a, b, c) = (u(), u(), u());
                let targets = light.sample_lanes(a, b, c);
                let dir =
                    V3::<f32x8>::from_fn(|k| (targets.lane(k) - origins[k]).normalize_or(Vec3::Y));
                let p = RayPacket::<f32x8>::from_active_lanes(o, dir, active);
                let want = accel.light_visible_packet(
                    Context::new(&scene, &mut s),
                    &p,
                    T_MIN,
                    light,
                    active,
                    None,
                );
                let got = accel.light_visible_packet(
                    Context::new(&scene, &mut s),
                    &p,
                    T_MIN,
                    light,
                    active,
                    Some(among),
                );
                assert_eq!(got, want, "{name}, round {round}, light {li}");
                lanes_tested += active.count_ones();
                visible += want.count_ones();
                occluded += (active & !want).count_ones();
            }
        }
        assert!(lanes_tested > 50_000, "{name}: {lanes_tested}");
        assert!(
            visible > 10_000 && occluded > 10_000,
            "{name}: {visible} visible, {occluded} not"
        );
        // Most primitives are ruled out, on average, besides the light's own.
        assert!(
            left_out > lanes_tested as usize / 8 * n / 2,
            "{name}: the candidates left only {left_out} out"
        );
    }
    // The tree is left out of some packets' tests and kept in others'.
    assert!(
        tree_kept > 1000 && tree_left > 1000,
        "tree kept {tree_kept} times, left out {tree_left}"
    );
}
