//! Path-traced tiles with their paths regrouped: after each vertex, the lanes of a
//! tile's packets whose paths go on are gathered into full packets, so the traversal and
//! shading of bounces run on full packets rather than on half-empty ones.
//!
//! A diffuse, metal or glass bounce ends many paths (to the sky, or black) and scatters
//! the others: in `benches/corpus/sphere-field.toml` the packets of bounces held 47% of
//! their lanes in place. Every lane computes exactly what it computes in place (each
//! kernel is lane by lane, the random numbers are those of the lane's own key, every
//! lane is at the same vertex), and each lane's colour goes back to its pixel, which
//! sums its samples in sample order: the image is the same bits.

use super::shade::{PacketPixels, Paths};
use super::{RayCounts, Tracer};
use crate::accel::cull::Cull;
use crate::lanes::MAX_WIDTH;
use crate::lanes::{set_lanes, Lane, Mask, V3};
use crate::sampling::KeyLanes;

/// A packet of paths, the keys of its lanes, and where each lane's colour goes: lane k
/// holds the path of lane `home[k] % MAX_WIDTH` of the tile's packet
/// `home[k] / MAX_WIDTH`, for the lanes of `members`; `in_place`: the tile's packet
/// whose lanes it holds in their own places, when it does.
#[derive(Clone, Copy)]
struct Group<L: Lane> {
    paths: Paths<L>,
    keys: KeyLanes,
    members: u32,
    home: [u32; MAX_WIDTH],
    in_place: Option<usize>,
}

/// What a tile keeps between its samples: the packets of paths of the vertex being
/// traced, and the next vertex's (made once a tile, reused by every sample).
pub struct Regrouping<L: Lane> {
    groups: Vec<Group<L>>,
    next: Vec<Group<L>>,
}

/// What `Tracer::sample_tile` saved: of the packets it would have traced past the
/// camera's vertex in place (`traces + saved`), those it did not trace; `every`: it
/// regrouped every packet that lost a lane (`Tracer::regroups_every_lane`).
#[derive(Clone, Copy, Debug)]
pub struct Regrouped {
    pub traces: u32,
    pub saved: u32,
    pub every: bool,
}

impl Regrouped {
    /// Whether regrouping pays in a tile where it saved this: at least a tenth of the
    /// packets' traces. Below, gathering costs more than it saves: in `mixed` most
    /// tiles' paths end at the camera's vertex (Phong, the background), and those that
    /// go on are mostly a glass or metal sphere's full, coherent packets. Always where
    /// every packet that lost a lane regroups.
    pub fn pays(self) -> bool {
        self.every || self.saved > 0 && self.saved * 10 >= self.traces + self.saved
    }
}

impl<L: Lane> Regrouping<L> {
    /// Room for a tile of `packets` packets: a tile never holds more groups than it has
    /// packets, so its samples grow no vector.
    pub fn with_capacity(packets: usize) -> Self {
        Self {
            groups: Vec::with_capacity(packets),
            next: Vec::with_capacity(packets),
        }
    }
}

impl Tracer<'_> {
    /// Whether a render at `L`'s width may regroup its paths (`sample_tile`): packets of
    /// several lanes, in a scene whose surfaces are all path-traced (Diffuse, Metal,
    /// Dielectric; lights). Where Phong surfaces end most paths at their first vertex
    /// the paths stay in their packets: in `mixed` the few that go on are mostly a
    /// glass or metal sphere's full, coherent packets, and tracing a tile's packets
    /// together cost 6.8% more render instructions even where each tile's first sample
    /// found no gain and the rest went on in place. Mirror rays stay coherent; after
    /// the first vertex of the built-in Whitted scenes a regrouping could save at most
    /// 2.4% (docs/performance.md).
    pub fn regroups<L: Lane>(&self) -> bool {
        let f = self.scene.features;
        L::WIDTH > 1 && f.has_path_traced && !f.has_phong
    }

    /// Whether a regrouping render gathers the paths of every packet that lost a lane,
    /// in every tile: where every ray tests every primitive (`Tree::tests_everything`,
    /// no instances), a packet's coherence saves nothing and only its idle lanes cost.
    /// `glass-cornell` (thirteen quads and two spheres beside an empty tree) ends few
    /// paths a vertex, so its packets lose a lane or two and stay more than half full:
    /// gathered, its 8-wide render takes 12% fewer instructions. Where a tree is
    /// traversed, a packet more than half full keeps its lanes (the metal bunny of
    /// `benches/corpus/metal-bunny.toml` took more with them gathered: docs/performance.md,
    /// "Secondary rays").
    pub fn regroups_every_lane(&self) -> bool {
        self.accel.tree.tests_everything() && self.accel.prototypes.is_empty()
    }

    /// Sample `sample` of the packets `packets` of one tile (`cull`: the tile's camera
    /// cull), their paths regrouped after each vertex: packet i's colours in `out[i]`, in
    /// the lanes traced (the others as they were), the bits `sample_pixels` gives.
    /// Returns what regrouping saved.
    pub fn sample_tile<L: Lane>(
        &self,
        packets: &[PacketPixels],
        sample: u32,
        cull: Cull,
        out: &mut [V3<L>],
        work: &mut Regrouping<L>,
        counts: &mut RayCounts,
    ) -> Regrouped {
        debug_assert!(out.len() >= packets.len());
        // Packets traced past the camera's vertex, and the traces regrouping saved.
        let (mut traces, mut saved) = (0u32, 0u32);
        let every = self.regroups_every_lane();
        let Regrouping { groups, next } = work;
        groups.clear();
        // The camera rays, in their packets (coherent: they take the frustum traversal).
        for (i, at) in packets.iter().enumerate() {
            let (x0, y0, active, pixels) = (at.x0, at.y0, at.active, &at.pixels);
            if let Some(seen) = self.camera_seen(active, cull, counts) {
                out[i] = seen;
                continue;
            }
            let (mut paths, keys) = self.camera_rays::<L>(x0, y0, active, pixels, sample);
            if self.scene.max_depth > 0 {
                let hits = self.closest_hits(&paths, Some(cull), counts);
                self.shade_vertex(&mut paths, &hits, &keys, 0, counts);
            }
            let group = Group {
                paths,
                keys,
                members: active,
                home: std::array::from_fn(|k| (i * MAX_WIDTH + k) as u32),
                in_place: Some(i),
            };
            if paths.active == 0 {
                // Every path ended at the camera's vertex.
                send_home(&group, active, out);
            } else {
                groups.push(group);
            }
        }
        let mut vertex = 1;
        while vertex < self.scene.max_depth {
            // The packets at most half full give up their paths, gathered into full
            // packets; the fuller ones keep theirs in place, where they stay as
            // coherent as they came (a glass or metal sphere's packet). Where every ray
            // tests every primitive, coherence saves nothing: every packet that lost a
            // lane gives its paths up.
            let sparse = |g: &Group<L>| g.paths.active != 0 && sparse::<L>(g.paths.active, every);
            let pooled: usize = groups
                .iter()
                .filter(|g| sparse(g))
                .map(|g| g.paths.active.count_ones() as usize)
                .sum();
            if pooled == 0 && groups.iter().all(|g| g.paths.active == 0) {
                break;
            }
            let holding = groups.iter().filter(|g| sparse(g)).count();
            if pooled.div_ceil(L::WIDTH) < holding {
                let fewer = holding - pooled.div_ceil(L::WIDTH);
                saved += fewer as u32;
                // `shade_vertex` counted the packets as they came out of it; the same
                // lanes now travel in fewer.
                counts.secondary_packets.packets -= fewer as u64;
                regroup(groups, next, out, every);
                std::mem::swap(groups, next);
            }
            traces += groups.iter().filter(|g| g.paths.active != 0).count() as u32;
            for g in groups.iter_mut().filter(|g| g.paths.active != 0) {
                let hits = self.closest_hits(&g.paths, None, counts);
                self.shade_vertex(&mut g.paths, &hits, &g.keys, vertex, counts);
            }
            vertex += 1;
        }
        for g in groups.iter() {
            send_home(g, g.members, out);
        }
        Regrouped {
            traces,
            saved,
            every,
        }
    }
}

/// The colours of the lanes `lanes` of `g` to their pixels' places in `out`.
fn send_home<L: Lane>(g: &Group<L>, lanes: u32, out: &mut [V3<L>]) {
    let color = g.paths.color;
    if let Some(i) = g.in_place {
        out[i] = V3::select(L::Mask::from_bits(lanes), color, out[i]);
        return;
    }
    for k in set_lanes(lanes) {
        let home = g.home[k] as usize;
        let (i, lane) = (home / MAX_WIDTH, home % MAX_WIDTH);
        out[i] = V3::select(
            L::Mask::from_bits(1 << lane),
            V3::splat(color.lane(k)),
            out[i],
        );
    }
}

/// The paths of the packets of `groups` that are `sparse` (`every`: every packet that
/// lost a lane), gathered in order into full packets in `next` (the last one partly
/// full), after the others as they are; the colours of the paths that ended sent home.
fn regroup<L: Lane>(groups: &[Group<L>], next: &mut Vec<Group<L>>, out: &mut [V3<L>], every: bool) {
    next.clear();
    let mut lanes = [(0, 0); MAX_WIDTH];
    let mut n = 0;
    for (gi, g) in groups.iter().enumerate() {
        if g.paths.active == 0 {
            send_home(g, g.members, out);
            continue;
        }
        if !sparse::<L>(g.paths.active, every) {
            next.push(*g);
            continue;
        }
        send_home(g, g.members & !g.paths.active, out);
        for k in set_lanes(g.paths.active) {
            lanes[n] = (gi, k);
            n += 1;
            if n == L::WIDTH {
                next.push(gather(groups, &lanes[..n]));
                n = 0;
            }
        }
    }
    if n > 0 {
        next.push(gather(groups, &lanes[..n]));
    }
}

/// A packet whose paths are pooled for regrouping: at most half its lanes go on, or
/// with `every` (`Tracer::regroups_every_lane`) any lane ended.
#[inline(always)]
fn sparse<L: Lane>(active: u32, every: bool) -> bool {
    let n = active.count_ones() as usize;
    if every {
        n < L::WIDTH
    } else {
        n * 2 <= L::WIDTH
    }
}

/// One packet of the lanes `lanes` (group, lane) of `groups`, in order; the lanes past
/// their count copy the first (finite rays, never active).
fn gather<L: Lane>(groups: &[Group<L>], lanes: &[(usize, usize)]) -> Group<L> {
    // The lanes' twelve numbers (origin, direction, weight, colour), column by column.
    let mut columns = [[0.0f32; MAX_WIDTH]; 12];
    let mut mirror = 0;
    let mut home = [0; MAX_WIDTH];
    let (g0, k0) = lanes[0];
    let mut keys = [groups[g0].keys.key(k0); MAX_WIDTH];
    for j in 0..L::WIDTH {
        let (g, k) = if j < lanes.len() { lanes[j] } else { (g0, k0) };
        let group = &groups[g];
        let p = &group.paths;
        for (f, v) in [&p.origin, &p.dir, &p.weight, &p.color]
            .into_iter()
            .enumerate()
        {
            columns[3 * f][j] = v.x.lane(k);
            columns[3 * f + 1][j] = v.y.lane(k);
            columns[3 * f + 2][j] = v.z.lane(k);
        }
        if j < lanes.len() {
            mirror |= (p.mirror >> k & 1) << j;
            home[j] = group.home[k];
            keys[j] = group.keys.key(k);
        }
    }
    let v3 = |f: usize| {
        let c = |m: usize| L::from_fn(|j| columns[3 * f + m][j]);
        V3::new(c(0), c(1), c(2))
    };
    let active = (1u32 << lanes.len()) - 1;
    Group {
        paths: Paths {
            origin: v3(0),
            dir: v3(1),
            active,
            mirror,
            weight: v3(2),
            color: v3(3),
        },
        keys: KeyLanes::from_keys(&keys[..lanes.len()]),
        members: active,
        home,
        in_place: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{Accel, AccelKind};
    use crate::lanes::Lane;
    use crate::scene::{Overrides, Scene};
    use wide::f32x8;

    /// One tile of the corpus scene `name`: regrouping saves packets, and every lane's
    /// colour is the bits the packet gives in place (`sample_pixels`), at widths 4, 8
    /// and 16.
    fn regrouped_lanes_give_the_bits_in_place<L: Lane>(name: &str, every: bool) {
        let path = format!("{}/benches/corpus/{name}.toml", env!("CARGO_MANIFEST_DIR"));
        let overrides = Overrides {
            width: Some(64),
            spp: Some(2),
            max_depth: None,
        };
        let mut scene = Scene::load(&path, overrides).unwrap();
        let accel = Accel::build(&mut scene, AccelKind::Bvh);
        let tracer = Tracer::new(&scene, &accel, 3);
        assert!(tracer.regroups::<L>());
        assert_eq!(tracer.regroups_every_lane(), every, "{name}");
        // The tile at the middle of the frame: in the field below the horizon, where
        // every ray meets a sphere or the ground; in the closed box, every ray meets
        // something.
        let (fw, fh) = super::super::footprint(L::WIDTH);
        let (x0, y0, x1, y1) = (16, 16, 32, 32);
        let cull = tracer.camera_cull(x0, y0, x1, y1);
        let packets: Vec<PacketPixels> = (y0..y1)
            .step_by(fh as usize)
            .flat_map(|py| (x0..x1).step_by(fw as usize).map(move |px| (px, py)))
            .map(|(px, py)| PacketPixels {
                x0: px,
                y0: py,
                pixels: tracer.pixel_hashes::<L>(px, py),
                active: (1 << L::WIDTH) - 1,
            })
            .collect();
        let mut out = vec![V3::<L>::splat(glam::Vec3::ZERO); packets.len()];
        let mut work = Regrouping::with_capacity(packets.len());
        let mut counts = RayCounts::default();
        for sample in 0..2 {
            let saved =
                tracer.sample_tile(&packets, sample, cull, &mut out, &mut work, &mut counts);
            assert!(saved.saved > 0, "{saved:?}");
            for (at, got) in packets.iter().zip(&out) {
                let (x, y, pixels) = (at.x0, at.y0, &at.pixels);
                let c = &mut counts;
                let want: V3<L> = tracer.sample_pixels(x, y, pixels, at.active, sample, cull, c);
                for k in 0..L::WIDTH {
                    let bits = |v: glam::Vec3| v.to_array().map(f32::to_bits);
                    assert_eq!(bits(got.lane(k)), bits(want.lane(k)), "({x}, {y}) lane {k}");
                }
            }
        }
    }

    #[test]
    fn regrouped_lanes_give_the_bits_they_give_in_place() {
        // A tree (packets more than half full keep their lanes), and none (every packet
        // that lost a lane gives its paths up).
        for (name, every) in [("sphere-field", false), ("glass-cornell", true)] {
            regrouped_lanes_give_the_bits_in_place::<glam::Vec4>(name, every);
            regrouped_lanes_give_the_bits_in_place::<f32x8>(name, every);
            regrouped_lanes_give_the_bits_in_place::<crate::lanes::F32x16>(name, every);
        }
    }
}
