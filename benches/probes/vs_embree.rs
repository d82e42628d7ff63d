//! Our side of the comparison with Embree (`benches/embree/run.sh`). Writes a scene's
//! geometry and the benchmarks' ray sets to a binary file, for
//! `benches/embree/embree_bench.c` to trace with Embree, and times our own tracing of the
//! same sets the same way (one thread, an untimed pass, then `passes` timed ones and their
//! median), so the two can run alternately, in the same minutes of a shared machine.
//!
//! ```sh
//! cargo run --release --example vs_embree -- bunny /tmp/bunny.rays 5
//! cargo run --release --example vs_embree -- benches/embree/bunny-mesh.toml /tmp/m.rays 5 bunny
//! ```
//!
//! Arguments: the scene traced, the output file, passes (default 5, 0: write only), the
//! scene the rays are made in (default the same), and the one set to time (default all): `bunny-mesh.toml` is `bunny` with
//! only its mesh and its light, traced with `bunny`'s rays (its shadow rays start on the
//! ground too). The set `build` writes the geometry alone and times the tree's build
//! instead, on one thread and on two (`embree_bench` times `rtcCommitScene` on the same
//! file):
//!
//! ```sh
//! cargo run --release --example vs_embree -- benches/embree/big-mesh-far.toml /tmp/b.rays 5 - build
//! ```
//!
//! The sets, with our own answer (hits, or visible lanes) for the C side to check against:
//! - `camera1`: the camera rays one at a time (`Accel::closest_hit`), in the order of
//!   `benches/bvh.rs` (pixel by pixel, the samples of a pixel together);
//! - `camera8`: the camera rays in 8-wide packets (4x2 pixels, one sample index), in the
//!   order of `benches/packets.rs` (`closest_hit_packet`, rays already in lanes), through
//!   the frustum traversal;
//! - `camera8-lanes`: the same packets through the lane-wise traversal, which a render
//!   takes in the tiles where the frustum's leaves hold few of the lanes
//!   (`render::frustum_pays`: triangles smaller than a pixel);
//! - `shadow8` (when the rays' scene is `bunny`): the shadow rays from those packets' hits
//!   to light 0, as `benches/packets.rs` makes them (`light_visible_packet`); for Embree
//!   each ends just short of the light's own nearest hit (`Light::nearest_hit`).
//!
//! Format (little-endian): `u32` triangle count, then per triangle nine `f32` (a, b, c);
//! `u32` sphere count, then per sphere centre and radius (four `f32`); `f32` t_min;
//! `u32` set count; per set a 16-byte name, `u32` kind (0 closest hit, 1 occlusion),
//! `u32` width, `u32` packet count, `u32` our answer, then per packet a `u32` active mask
//! and `width` rays of seven `f32` (origin, direction, t_far).

#[path = "../common/mod.rs"]
mod common;

use common::{camera_packets, camera_rays, in_lanes, shadow_packets, LanePacket, Packet};
use raytracer::accel::cull::Cull;
use raytracer::accel::packet::RayPacket;
use raytracer::accel::{Accel, AccelKind, Context, TraversalStats};
use raytracer::geometry::Ray;
use raytracer::integrator::T_MIN;
use raytracer::scene::{Overrides, Scene};
use std::io::Write;
use std::time::Instant;
use wide::f32x8;

struct Set {
    name: &'static str,
    occlusion: bool,
    width: usize,
    packets: Vec<(u32, Vec<(Ray, f32)>)>,
    answer: u32,
    /// The same rays as we trace them.
    rays: Rays,
    /// Packets take the lane-wise traversal, not the frustum (`Cull::frustum`).
    lane_wise: bool,
}

enum Rays {
    Single(Vec<Ray>),
    Lanes(Vec<LanePacket<f32x8>>),
}

/// One pass over a set: our answer (hits, or visible lanes).
#[inline(never)]
fn trace(scene: &Scene, accel: &Accel, set: &Set) -> u32 {
    let mut stats = TraversalStats::default();
    let mut n = 0;
    match &set.rays {
        Rays::Single(rays) => {
            for r in rays {
                n += accel
                    .closest_hit(Context::new(scene, &mut stats), r, T_MIN, f32::INFINITY)
                    .is_some() as u32;
            }
        }
        Rays::Lanes(packets) => {
            for lp in packets {
                let mut p = RayPacket::<f32x8>::from_lanes(lp.origin, lp.dir, lp.active);
                if set.lane_wise {
                    p.set_cull(Cull {
                        frustum: false,
                        ..Cull::ALL
                    });
                }
                if set.occlusion {
                    let light = &scene.lights[0];
                    let v = accel.light_visible_packet(
                        Context::new(scene, &mut stats),
                        &p,
                        T_MIN,
                        light,
                        lp.active,
                        None,
                    );
                    n += v.count_ones();
                } else {
                    let hits = accel.closest_hit_packet(Context::new(scene, &mut stats), &p, T_MIN);
                    n += (hits.found & lp.active).count_ones();
                }
            }
        }
    }
    n
}

fn push_f32s(out: &mut Vec<u8>, v: &[f32]) {
    for x in v {
        out.extend_from_slice(&x.to_le_bytes());
    }
}

fn main() -> std::io::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let usage = || -> ! {
        eprintln!("usage: vs_embree SCENE OUT [PASSES] [RAYS_SCENE] [SET]");
        std::process::exit(2)
    };
    let (Some(name), Some(path)) = (args.get(1), args.get(2)) else {
        usage()
    };
    let passes: usize = match args.get(3).map(|s| s.parse()) {
        None => 5,
        Some(Ok(p)) => p,
        Some(Err(_)) => usage(),
    };
    let rays_from = args.get(4).unwrap_or(name);
    if args.get(5).is_some_and(|s| s == "build") {
        return time_builds(name, path, passes);
    }
    let load = |n: &str| {
        let mut scene = Scene::load(n, Overrides::default()).unwrap_or_else(|e| {
            eprintln!("{e}");
            std::process::exit(2)
        });
        let t = Instant::now();
        let accel = Accel::build(&mut scene, AccelKind::Bvh);
        (scene, accel, t.elapsed())
    };
    let (scene, accel, build) = load(name);
    let (source, source_accel, _) = load(rays_from);

    let single = camera_rays(&source, source.spp);
    let p8 = camera_packets(&source, 8);
    let with_t = |p: &Packet, t_far: &dyn Fn(&Ray) -> f32| {
        (p.1, p.0.iter().map(|r| (*r, t_far(r))).collect::<Vec<_>>())
    };
    let mut sets = vec![
        Set {
            name: "camera1",
            occlusion: false,
            width: 1,
            answer: 0,
            packets: single
                .iter()
                .map(|r| (1, vec![(*r, f32::INFINITY)]))
                .collect(),
            rays: Rays::Single(single),
            lane_wise: false,
        },
        Set {
            name: "camera8",
            occlusion: false,
            width: 8,
            answer: 0,
            packets: p8.iter().map(|p| with_t(p, &|_| f32::INFINITY)).collect(),
            rays: Rays::Lanes(in_lanes(&p8)),
            lane_wise: false,
        },
        Set {
            name: "camera8-lanes",
            occlusion: false,
            width: 8,
            answer: 0,
            packets: p8.iter().map(|p| with_t(p, &|_| f32::INFINITY)).collect(),
            rays: Rays::Lanes(in_lanes(&p8)),
            lane_wise: true,
        },
    ];
    // The shadow rays of `bunny`, traced towards the traced scene's first light (the same
    // point light, in `bunny-mesh-light.toml`).
    if let (true, Some(light)) = (rays_from == "bunny", scene.lights.first()) {
        let s8 = shadow_packets(&source, &source_accel, &p8);
        // Ends just short of the light's own nearest hit (as ours finds it): Embree then
        // reports any occluder.
        let t_far =
            |r: &Ray| light.nearest_hit(r, T_MIN).map_or(f32::INFINITY, |h| h.0) * (1.0 - 1e-4);
        sets.push(Set {
            name: "shadow8",
            occlusion: true,
            width: 8,
            answer: 0,
            packets: s8.iter().map(|p| with_t(p, &t_far)).collect(),
            rays: Rays::Lanes(in_lanes(&s8)),
            lane_wise: false,
        });
    }
    for s in &mut sets {
        s.answer = trace(&scene, &accel, s);
    }
    write(path, &scene, &sets)?;

    println!(
        "ours: {} triangles, {} spheres, build {:.2} ms (lanes: {})",
        scene.triangles.len(),
        scene.spheres.len(),
        build.as_secs_f64() * 1e3,
        raytracer::lanes::COMPILED
    );
    let only = args.get(5);
    for s in sets.iter().filter(|s| only.is_none_or(|o| o == s.name)) {
        let rays: u32 = s.packets.iter().map(|p| p.0.count_ones()).sum();
        if passes == 0 {
            println!("{:<8} {rays} rays, answer {}", s.name, s.answer);
            continue;
        }
        let mut rate: Vec<f64> = (0..passes)
            .map(|_| {
                let t = Instant::now();
                std::hint::black_box(trace(&scene, &accel, s));
                rays as f64 / t.elapsed().as_secs_f64() * 1e-6
            })
            .collect();
        let each: Vec<String> = rate.iter().map(|r| format!("{r:.1}")).collect();
        rate.sort_by(f64::total_cmp);
        let m = passes / 2;
        let median = if passes % 2 == 1 {
            rate[m]
        } else {
            0.5 * (rate[m - 1] + rate[m])
        };
        println!(
            "{:<13} {}, {rays} rays: {}; median {median:.1} Mrays/s; {} {}",
            s.name,
            if s.width == 1 { "single" } else { "8-wide" },
            each.join(" "),
            if s.occlusion { "unoccluded" } else { "hits" },
            s.answer
        );
    }
    Ok(())
}

/// The set `build`: the scene's geometry written with no rays, and its tree built
/// `passes` times on one thread and on two (each from a copy of the scene as loaded),
/// after an untimed build; every build's time and their median.
fn time_builds(name: &str, path: &str, passes: usize) -> std::io::Result<()> {
    let scene = Scene::load(name, Overrides::default()).unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(2)
    });
    write(path, &scene, &[])?;
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(std::io::Error::other)?;
        let once = || {
            let mut copy = scene.clone();
            let t = Instant::now();
            let accel = pool.install(|| Accel::build(&mut copy, AccelKind::Bvh));
            let ms = t.elapsed().as_secs_f64() * 1e3;
            drop(accel);
            ms
        };
        once();
        let mut times: Vec<f64> = (0..passes.max(1)).map(|_| once()).collect();
        let each: Vec<String> = times.iter().map(|t| format!("{t:.1}")).collect();
        times.sort_by(f64::total_cmp);
        let m = times.len() / 2;
        let median = if times.len() % 2 == 1 {
            times[m]
        } else {
            0.5 * (times[m - 1] + times[m])
        };
        println!(
            "build    {threads} thread(s), {} triangles: {} ms; median {median:.1} ms",
            scene.triangles.len(),
            each.join(" ")
        );
    }
    Ok(())
}

fn write(path: &str, scene: &Scene, sets: &[Set]) -> std::io::Result<()> {
    let mut out = Vec::new();
    let tri = &scene.triangles;
    out.extend_from_slice(&(tri.len() as u32).to_le_bytes());
    for i in 0..tri.len() {
        for v in [&tri.a, &tri.b, &tri.c] {
            push_f32s(&mut out, &[v[0][i], v[1][i], v[2][i]]);
        }
    }
    let sp = &scene.spheres;
    out.extend_from_slice(&(sp.len() as u32).to_le_bytes());
    for i in 0..sp.len() {
        let c = sp.center(i);
        push_f32s(&mut out, &[c.x, c.y, c.z, sp.radius(i)]);
    }
    push_f32s(&mut out, &[T_MIN]);
    out.extend_from_slice(&(sets.len() as u32).to_le_bytes());
    for s in sets {
        let mut n = [0u8; 16];
        n[..s.name.len()].copy_from_slice(s.name.as_bytes());
        out.extend_from_slice(&n);
        for v in [
            s.occlusion as u32,
            s.width as u32,
            s.packets.len() as u32,
            s.answer,
        ] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for (active, rays) in &s.packets {
            out.extend_from_slice(&active.to_le_bytes());
            for (r, t_far) in rays.iter().take(s.width) {
                push_f32s(&mut out, &r.origin.to_array());
                push_f32s(&mut out, &r.dir.to_array());
                push_f32s(&mut out, &[*t_far]);
            }
        }
    }
    // Written whole to a temporary file, then renamed.
    let tmp = format!("{path}.tmp");
    std::fs::File::create(&tmp)?.write_all(&out)?;
    std::fs::rename(&tmp, path)
}
