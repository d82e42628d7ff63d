//! `--stats`: what the acceleration structure holds, the rays and the traversal work, what
//! the scene needs and what specialisation skipped, packet occupancy, non-finite pixels.

use super::run::Run;

/// Print the statistics of `run` on stderr, one `stats:` line each.
pub fn print(run: &Run) {
    let (scene, counts) = (run.renderer.scene(), run.counts);
    let settings = &run.options.settings;
    let t = counts.traversal;
    let per_ray = |x: u64| x as f64 / counts.total().max(1) as f64;
    to_stderr!("stats: {}", run.renderer.accel().describe(scene));
    to_stderr!(
        "stats: build {:.3} ms",
        run.timings.build.as_secs_f64() * 1e3
    );
    to_stderr!(
        "stats: rays: {} camera, {} shadow, {} secondary; per ray {:.2} boxes visited, {:.2} primitives tested",
        counts.camera,
        counts.shadow,
        counts.secondary,
        per_ray(t.nodes),
        per_ray(t.prims)
    );
    let f = scene.features;
    let yes_no = |b: bool| if b { "yes" } else { "no" };
    to_stderr!(
        "stats: scene needs: path-traced bounces {}, mirror rays {}, shadow rays {} ({} point, {} area lights)",
        yes_no(f.has_path_traced),
        yes_no(f.has_mirror),
        yes_no(f.has_lights()),
        scene.lights.iter().filter(|l| l.is_point()).count(),
        scene.lights.iter().filter(|l| !l.is_point()).count(),
    );
    let w = settings.packet_width.rays();
    if !settings.specialize {
        to_stderr!("stats: specialisation off (--no-specialize)");
    } else {
        to_stderr!(
            "stats: skipped: {} shadow rays (their light sample adds nothing, lit or not), {} packets that miss everything (the scene's box, or their tile's cone; at width 1 one a camera ray)",
            counts.shadow_culled, counts.packets_outside
        );
        if w > 1 {
            to_stderr!(
                "stats: skipped by the tiles' camera cones: {} primitive tests beside the tree (lanes), {} camera packets' tree traversals",
                counts.cone_prims, counts.cone_trees
            );
        }
    }
    if w > 1 {
        let pct = |x: Option<f64>| x.map_or("-".to_string(), |x| format!("{:.1}%", x * 100.0));
        let nodes = (t.packet_nodes > 0)
            .then(|| t.packet_lanes as f64 / (t.packet_nodes * w as u64) as f64);
        to_stderr!(
            "stats: {w}-wide packets ({} build): lane occupancy camera {}, shadow {}, secondary {}; at node visits {}",
            raytracer::lanes::ISA,
            pct(counts.camera_packets.occupancy(w)),
            pct(counts.shadow_packets.occupancy(w)),
            pct(counts.secondary_packets.occupancy(w)),
            pct(nodes),
        );
        let packet_rays = counts.total().max(1);
        to_stderr!(
            "stats: lanes that went single: {} ({:.1}% of the rays; subtrees entered by one lane, shadow rays to a light of many primitives)",
            t.single_lanes,
            t.single_lanes as f64 * 100.0 / packet_rays as f64,
        );
    }
    to_stderr!("stats: non-finite pixels: {}", run.non_finite);
}
