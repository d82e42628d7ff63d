//! Cheap misses for rays from one point: a cone from the camera through a tile's pixels
//! rules out the primitives beside the tree, and the tree itself, that none of the
//! tile's camera rays can reach. Cheap misses matter as much as fast triangle tests:
//! about half of `bunny`'s camera rays hit nothing (ARCHITECTURE.md, "Specialisation").
//!
//! Only misses are skipped: a primitive whose bounding sphere lies outside the cone, by
//! a margin far above the f32 rounding of the traced rays, cannot be hit by any of them,
//! so its test would have reported nothing. The image is the same bits.

use super::Accel;
use crate::geometry::Aabb;
use crate::scene::Scene;
use glam::DVec3;

/// What a bundle of rays may hit: bit i of `beside[k]` is the i-th primitive of kind k
/// beside the tree (`Bvh::linear[k]`; those past the 32nd are always tested), and
/// `tree` the tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cull {
    pub beside: [u32; 3],
    pub tree: bool,
    /// Nothing at all can be hit (every primitive ruled out).
    pub nothing: bool,
    /// Camera packets may take the frustum traversal; a tile whose rays share little
    /// turns it off (`render::accumulate_tile`).
    pub frustum: bool,
}

impl Cull {
    /// Test everything.
    pub const ALL: Cull = Cull {
        beside: [u32::MAX; 3],
        tree: true,
        nothing: false,
        frustum: true,
    };

    /// The primitive tests and the tree this leaves out, for `--stats`: (primitives
    /// beside the tree, tree) skipped.
    pub fn skipped(&self, accel: &Accel) -> (u64, bool) {
        match accel.bvh() {
            None => (0, false),
            Some(b) => {
                let prims = (0..3)
                    .map(|k| {
                        let n = b.linear[k].len().min(32) as u32;
                        let all = if n == 32 { u32::MAX } else { (1 << n) - 1 };
                        (all & !self.beside[k]).count_ones() as u64
                    })
                    .sum();
                (prims, b.root.is_some() && !self.tree)
            }
        }
    }
}

/// Angular margin (radians) added to a cone's half-angle: the traced rays' directions
/// are f32 (relative error ~1e-7, so ~1e-7 rad) and a sphere test accepts rays passing
/// a few ulps outside; 1e-5 rad is a hundred times that, and costs nothing measurable.
const MARGIN: f64 = 1e-5;

/// A circular cone of rays from `apex`, of half-angle `angle` (margin included)
/// around the unit `axis`.
#[derive(Clone, Copy, Debug)]
pub struct Cone {
    apex: DVec3,
    axis: DVec3,
    angle: f64,
}

impl Cone {
    /// A cone from `apex` holding every direction that is a non-negative combination
    /// of `dirs` (a cone is convex, so it holds them if it holds each `dir`). `None` when
    /// a direction is zero or not finite, or when the directions span half a space or
    /// more (no useful cone).
    pub fn through(apex: DVec3, dirs: &[DVec3]) -> Option<Cone> {
        let mut sum = DVec3::ZERO;
        let mut units = Vec::with_capacity(dirs.len());
        for d in dirs {
            let u = d.try_normalize()?;
            sum += u;
            units.push(u);
        }
        let axis = sum.try_normalize()?;
        let cos = units
            .iter()
            .map(|u| axis.dot(*u))
            .fold(f64::INFINITY, f64::min);
        // (`cos` is NaN for NaN input: no cone then either.)
        if cos.is_nan() || cos <= 0.0 || !apex.is_finite() {
            return None;
        }
        Some(Cone {
            apex,
            axis,
            angle: cos.min(1.0).acos() + MARGIN,
        })
    }

    /// A cone holding every ray that starts within `lens` of `centre` and passes within
    /// `spread` of a point of the convex hull of `targets`: a camera's rays from its lens
    /// disk (any point, f32 rounding included, lies within `lens` of the lens's centre)
    /// through a rectangle of the viewport (each point's f32 rounding within `spread`).
    /// `None` as for `through`, or when the widened directions span half a space.
    ///
    /// Why it holds them: with the cone `through` the target directions (axis a), a
    /// direction t − l = (t − centre) + b, |b| ≤ lens + spread = r, lies within
    /// asin(r / |t − centre|) of its target's direction, so within θ = max over the
    /// targets of that plus the target's angle to a; a convex combination of such
    /// directions (the hull's) is inside the cone of half-angle θ too. Moving the apex
    /// back along the axis by lens / sin θ puts the whole lens ball inside that cone, so
    /// every ray (a point of the cone plus a direction of it) stays in it. With `lens`
    /// zero the apex is `centre`.
    pub fn through_lens(centre: DVec3, lens: f64, targets: &[DVec3], spread: f64) -> Option<Cone> {
        let dirs: Vec<DVec3> = targets.iter().map(|t| *t - centre).collect();
        let inner = Cone::through(centre, &dirs)?;
        let r = lens + spread;
        let mut angle = 0.0f64;
        for d in &dirs {
            let len = d.length();
            if !(r.is_finite() && r < len) {
                return None;
            }
            let own = (inner.axis.dot(*d) / len).clamp(-1.0, 1.0).acos();
            angle = angle.max(own + (r / len).asin());
        }
        if angle.is_nan() || angle >= std::f64::consts::FRAC_PI_2 {
            return None;
        }
        let back = if lens > 0.0 { lens / angle.sin() } else { 0.0 };
        let apex = centre - inner.axis * back;
        if !apex.is_finite() {
            return None;
        }
        Some(Cone {
            apex,
            axis: inner.axis,
            angle: angle + MARGIN,
        })
    }

    /// Whether a ray of the cone can meet the ball of `center` and `radius`: the
    /// direction to the centre is within the half-angle plus the ball's angular radius.
    pub fn may_meet(&self, center: DVec3, radius: f64) -> bool {
        let v = center - self.apex;
        let dist = v.length();
        // The apex inside (or on) the ball, or a ball too wide to bound by angles.
        if !dist.is_finite() || !radius.is_finite() || dist <= radius * (1.0 + 1e-9) {
            return true;
        }
        let alpha = (radius / dist).asin();
        let beta = (self.axis.dot(v) / dist).clamp(-1.0, 1.0).acos();
        beta <= self.angle + alpha + MARGIN
    }

    /// `may_meet` for the ball around a box (`ball`); an empty box meets nothing.
    pub fn may_meet_box(&self, b: &Aabb) -> bool {
        ball(b).is_some_and(|(center, radius)| self.may_meet(center, radius))
    }
}

/// The ball around `b` widened on every side by 1e-5 of its largest coordinate
/// magnitude: centre and half-diagonal, in f64. The widening is far above the rounding
/// of a hit point (~1e-7 relative), so a ray that hits a primitive in `b` meets the ball.
/// `None` for an empty box.
pub fn ball(b: &Aabb) -> Option<(DVec3, f64)> {
    let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
    if !lo.cmple(hi).all() {
        return None;
    }
    let pad = DVec3::splat(lo.abs().max(hi.abs()).max_element() * 1e-5 + 1e-30);
    let (lo, hi) = (lo - pad, hi + pad);
    Some(((lo + hi) * 0.5, (hi - lo).length() * 0.5 * (1.0 + 1e-9)))
}

/// The bounding balls the cull tests: those of the primitives beside the tree (by kind,
/// the first 32) and of the tree's primitives.
#[derive(Clone, Debug, Default)]
pub struct CullTargets {
    beside: [Vec<(DVec3, f64)>; 3],
    /// `Aabb::EMPTY` without a tree (never met).
    tree: Aabb,
    /// Some kind has more than 32 primitives beside the tree (those are always tested).
    more: bool,
}

impl CullTargets {
    /// `None` for the linear scan (it has no tree to skip, and is kept as the original
    /// program's algorithm).
    pub fn new(scene: &Scene, accel: &Accel) -> Option<CullTargets> {
        // Nor for instances: the cones rule out only the pools' primitives.
        let b = accel.bvh().filter(|_| scene.instances.is_empty())?;
        // A box is never empty here (a zero-area primitive's is still a point); an empty
        // one would get an infinite ball, never ruled out.
        let balls = |range: std::ops::Range<usize>, bounds: fn(&Scene, usize) -> Aabb| {
            range
                .take(32)
                .map(|i| ball(&bounds(scene, i)).unwrap_or((DVec3::ZERO, f64::INFINITY)))
                .collect()
        };
        let s = &scene.spheres;
        let beside = [
            // A sphere is its own ball.
            b.linear[0]
                .clone()
                .take(32)
                .map(|i| (s.center(i).as_dvec3(), s.radius(i).abs() as f64))
                .collect(),
            balls(b.linear[1].clone(), |s, i| s.quads.bounds(i)),
            balls(b.linear[2].clone(), |s, i| s.triangles.bounds(i)),
        ];
        let tree = b.tree_box;
        let more = b.linear.iter().any(|r| r.len() > 32);
        Some(CullTargets { beside, tree, more })
    }

    /// What rays of `cone` may hit.
    pub fn cull(&self, cone: &Cone) -> Cull {
        let mut c = Cull {
            beside: [u32::MAX; 3],
            tree: cone.may_meet_box(&self.tree),
            nothing: false,
            frustum: true,
        };
        let mut kept = 0;
        for (mask, balls) in c.beside.iter_mut().zip(&self.beside) {
            for (i, &(center, radius)) in balls.iter().enumerate() {
                if cone.may_meet(center, radius) {
                    kept += 1;
                } else {
                    *mask &= !(1 << i);
                }
            }
        }
        c.nothing = kept == 0 && !c.tree && !self.more;
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Random unit-ish directions around an axis, and balls near the cone's edge: every
    /// ball that some direction of the cone (sampled densely, in f64) passes through is
    /// kept.
    #[test]
    fn a_ball_a_ray_of_the_cone_meets_is_never_ruled_out() {
        let mut state = 0x2545_f491u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut kept_hits = 0;
        let mut ruled_out = 0;
        for _ in 0..400 {
            let apex = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 10.0;
            let axis = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
            let spread = 0.3 * next();
            let side = axis.any_orthonormal_pair();
            let corners: Vec<DVec3> = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                .iter()
                .map(|&(a, b)| axis + (side.0 * a + side.1 * b) * spread)
                .collect();
            let cone = Cone::through(apex, &corners).unwrap();
            for _ in 0..20 {
                let radius = 0.5 * next() + 1e-3;
                let center =
                    apex + (axis * 5.0 + (side.0 * (next() - 0.5) + side.1 * (next() - 0.5)) * 8.0);
                // Dense rays through the corners' quadrilateral.
                let mut hit = false;
                for i in 0..=40 {
                    for j in 0..=40 {
                        let (a, b) = (i as f64 / 40.0, j as f64 / 40.0);
                        let d = (corners[0] * (1.0 - a) + corners[1] * a) * (1.0 - b)
                            + (corners[3] * (1.0 - a) + corners[2] * a) * b;
                        let d = d.normalize();
                        let oc = center - apex;
                        let t = oc.dot(d);
                        if t > 0.0 && (oc - d * t).length() <= radius {
                            hit = true;
                        }
                    }
                }
                let kept = cone.may_meet(center, radius);
                if hit {
                    assert!(kept, "apex {apex} centre {center} radius {radius}");
                    kept_hits += 1;
                } else if !kept {
                    ruled_out += 1;
                }
            }
        }
        // The test is not vacuous: both cases occur often.
        assert!(
            kept_hits > 500 && ruled_out > 500,
            "{kept_hits} {ruled_out}"
        );
    }

    /// Rays from random points of a lens ball through random points of the targets'
    /// hull widened by `spread` (in f64): every point of every ray, near the lens and
    /// far beyond the targets, is inside the cone without its margin.
    /// And the cone is not wide for nothing: its half-angle is at most the pinhole
    /// cone's plus twice the lens's and spread's angular size.
    #[test]
    fn a_lens_cone_holds_every_ray_from_the_lens_through_the_targets() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut checked = 0;
        for _ in 0..300 {
            let centre = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 20.0;
            let axis = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
            let (s, t) = axis.any_orthonormal_pair();
            let distance = 0.5 + 5.0 * next();
            let (half_w, half_h) = (0.4 * next() + 0.01, 0.4 * next() + 0.01);
            let off = (s * (next() - 0.5) + t * (next() - 0.5)) * distance;
            let mid = centre + axis * distance + off;
            let targets: Vec<DVec3> = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                .iter()
                .map(|&(a, b)| mid + s * (a * half_w) + t * (b * half_h))
                .collect();
            let lens = if next() < 0.2 {
                0.0
            } else {
                0.3 * next() * distance
            };
            let spread = 1e-3 * next();
            let cone = Cone::through_lens(centre, lens, &targets, spread).unwrap();
            let dirs: Vec<DVec3> = targets.iter().map(|p| *p - centre).collect();
            let pinhole = Cone::through(centre, &dirs).unwrap();
            let widening = 2.0 * ((lens + spread) / (distance * 0.5)).asin() + 2.0 * MARGIN;
            assert!(
                cone.angle <= pinhole.angle + widening,
                "{cone:?} {pinhole:?}"
            );
            for _ in 0..50 {
                // A point of the lens ball and one of the widened hull.
                let ball = |r: f64, next: &mut dyn FnMut() -> f64| loop {
                    let v = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 2.0;
                    if v.length() <= 1.0 {
                        break v * r;
                    }
                };
                let l = centre + ball(lens, &mut next);
                let (a, b) = (next(), next());
                let hull = (targets[0] * (1.0 - a) + targets[1] * a) * (1.0 - b)
                    + (targets[3] * (1.0 - a) + targets[2] * a) * b;
                let p = hull + ball(spread, &mut next);
                for k in [0.0, 1e-3, 0.5, 1.0, 3.0, 1e3] {
                    // Inside without the margin: the angle from the apex to the point.
                    let v = l + (p - l) * k - cone.apex;
                    if v.length() == 0.0 {
                        continue;
                    }
                    let beta = (cone.axis.dot(v) / v.length()).clamp(-1.0, 1.0).acos();
                    assert!(
                        beta <= cone.angle - MARGIN + 1e-12,
                        "{cone:?}: {beta} (ray {l} to {p}, at {k})"
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 80_000, "{checked}");
    }

    #[test]
    fn an_apex_inside_the_ball_or_a_wide_cone_rules_nothing_out() {
        let cone = Cone::through(DVec3::ZERO, &[DVec3::Z, DVec3::new(0.1, 0.0, 1.0)]).unwrap();
        assert!(cone.may_meet(DVec3::new(0.0, 0.0, -0.5), 1.0));
        assert!(!cone.may_meet(DVec3::new(0.0, 0.0, -5.0), 1.0));
        assert!(Cone::through(DVec3::ZERO, &[DVec3::Z, -DVec3::Z]).is_none());
        assert!(Cone::through(DVec3::ZERO, &[DVec3::Z, DVec3::ZERO]).is_none());
        assert!(!cone.may_meet_box(&Aabb::EMPTY));
    }
}
