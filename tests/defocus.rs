//! The thin-lens camera (`defocus_angle`, `focus_dist`): its blur against thin-lens
//! geometry, the plane in focus, `focus_dist` as a scale of the viewport only, and the
//! defaults, which leave every built-in scene's camera as it was.

mod support;

use raytracer::accel::AccelKind;
use raytracer::render::{Film, RenderSettings};
use raytracer::scene::builtin::SCENES;
use raytracer::scene::Scene;
use support::{bits, builtin_with_camera, mean_abs_diff, render_settings, scene_from_toml};

/// Pixels of the test image (square), an odd count so that the view axis passes through
/// the centre pixel's centre; its vertical field of view, degrees.
const SIZE: u32 = 101;
const VFOV: f64 = 14.4;
/// The plane in focus, the lens's angle (degrees) and the small sphere's radius.
const FOCUS: f64 = 4.0;
const ANGLE: f64 = 6.0;
const RHO: f64 = 0.02;

/// A lone sphere of light colour 1 (a light seen directly shows its plain colour) on
/// the view axis at `depth`, before a black background, through a lens of `angle`.
fn lone_sphere(depth: f64, angle: f64, spp: u32) -> Scene {
    scene_from_toml(&format!(
        r#"
[camera]
width = {SIZE}
aspect_ratio = 1.0
samples_per_pixel = {spp}
vfov = {VFOV}
look_from = [0, 0, 0]
look_at = [0, 0, -1]
focus_dist = {FOCUS}
defocus_angle = {angle}

[materials.glow]
type = "light"
color = [1, 1, 1]

[[objects]]
type = "sphere"
center = [0, 0, {z}]
radius = {RHO}
material = "glow"
"#,
        z = -depth
    ))
}

/// One viewport pixel's side, in the focus plane's units.
fn pixel_size() -> f64 {
    2.0 * FOCUS * (VFOV.to_radians() / 2.0).tan() / SIZE as f64
}

/// Thin-lens geometry, in pixels: a sphere at `depth` seen from a lens point l lands on
/// the focus plane centred l·(1 − focus/depth) off the axis, as a disk of radius
/// focus·tan(asin(ρ/depth)) (its silhouette's cone); over the lens disk of radius
/// focus·tan(angle/2) the centres fill the circle of confusion, of radius
/// lens·|depth − focus|/depth. The footprint is that circle widened by the disk.
fn predicted_radius(depth: f64, angle: f64) -> (f64, f64) {
    let lens = FOCUS * (angle.to_radians() / 2.0).tan();
    let confusion = lens * (depth - FOCUS).abs() / depth;
    let own = FOCUS * (RHO / depth).asin().tan();
    (confusion / pixel_size(), own / pixel_size())
}

fn render(scene: &Scene) -> Film {
    render_settings(scene, AccelKind::Bvh, 2, &RenderSettings::new(5)).film
}

/// Per pixel: its value (all channels are equal), the distances from the axis (the
/// image's centre) to its nearest and farthest points and to its centre, in pixels, and
/// its corner nearest the top left, relative to the axis.
struct Pixel {
    value: f64,
    near: f64,
    far: f64,
    centre: f64,
    corner: (f64, f64),
}

fn pixels(film: &Film) -> Vec<Pixel> {
    let c = SIZE as f64 / 2.0;
    let mut out = Vec::new();
    for y in 0..SIZE {
        for x in 0..SIZE {
            let (x0, y0) = (x as f64 - c, y as f64 - c);
            let (x1, y1) = (x0 + 1.0, y0 + 1.0);
            let near = |a: f64, b: f64| {
                if a > 0.0 {
                    a
                } else if b < 0.0 {
                    -b
                } else {
                    0.0
                }
            };
            let far = |a: f64, b: f64| a.abs().max(b.abs());
            out.push(Pixel {
                value: film.pixels[(y * SIZE + x) as usize].x as f64,
                near: near(x0, x1).hypot(near(y0, y1)),
                far: far(x0, x1).hypot(far(y0, y1)),
                centre: (x0 + 0.5).hypot(y0 + 0.5),
                corner: (x0, y0),
            });
        }
    }
    out
}

/// The area where disks of radii `a` and `b`, centres `d` apart, overlap.
fn overlap(d: f64, a: f64, b: f64) -> f64 {
    use std::f64::consts::PI;
    if d >= a + b {
        0.0
    } else if d <= (a - b).abs() {
        PI * a.min(b).powi(2)
    } else {
        let ca = ((d * d + a * a - b * b) / (2.0 * d * a)).clamp(-1.0, 1.0);
        let cb = ((d * d + b * b - a * a) / (2.0 * d * b)).clamp(-1.0, 1.0);
        let k = (-d + a + b) * (d + a - b) * (d - a + b) * (d + a + b);
        a * a * ca.acos() + b * b * cb.acos() - 0.5 * k.max(0.0).sqrt()
    }
}

/// A pixel's expected value under thin-lens geometry: the fraction of (point of the
/// pixel, point of the lens) pairs whose ray meets the sphere. From lens point l the
/// sphere covers the focus-plane disk of radius `own` centred at l·(1 − focus/depth),
/// and those centres fill the circle of confusion (radius `confusion`) uniformly, so
/// a point p is covered with probability |disk(p, own) ∩ disk(0, confusion)| /
/// (π confusion²) (in focus: p within `own`). Integrated over the pixel by the midpoint
/// rule on a 64 × 64 grid where the integrand is not constant.
fn expected(p: &Pixel, confusion: f64, own: f64) -> f64 {
    use std::f64::consts::PI;
    let at = |r: f64| {
        if confusion > 0.0 {
            overlap(r, own, confusion) / (PI * confusion * confusion)
        } else {
            f64::from(r <= own)
        }
    };
    // The integrand depends on the distance r only: constant for r ≤ |own − confusion|
    // and for r ≥ own + confusion.
    let (inner, outer) = ((own - confusion).abs(), own + confusion);
    if p.far <= inner || p.near >= outer {
        return at(p.centre);
    }
    let n = 64;
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let x = p.corner.0 + (i as f64 + 0.5) / n as f64;
            let y = p.corner.1 + (j as f64 + 0.5) / n as f64;
            sum += at(x.hypot(y));
        }
    }
    sum / (n * n) as f64
}

/// A sphere in the focus plane keeps its pinhole footprint; one nearer or farther
/// spreads to the circle of confusion of thin-lens geometry:
/// - no pixel wholly outside the predicted footprint's radius plus half a pixel is lit;
/// - the blur's radius, from the image's second moment, is the circle of confusion's
///   within half a pixel (a radius 0.6 px off fails);
/// - ring by ring (pixel centres one pixel apart in distance from the axis), the mean
///   value is the thin-lens expectation (`expected`) within five standard deviations of
///   plain Monte Carlo sampling plus 0.003 (the expectation's integration error);
/// - the light is conserved: the image's sum is the sphere's own disk's area, whatever
///   the blur, within the same five deviations plus 1%.
#[test]
fn blur_is_the_thin_lens_circle_of_confusion() {
    let spp = 512;
    for depth in [FOCUS, FOCUS / 2.0, 2.0 * FOCUS] {
        for angle in [0.0, ANGLE] {
            let film = render(&lone_sphere(depth, angle, spp));
            let (confusion, own) = predicted_radius(depth, angle);
            let radius = confusion + own;
            let px = pixels(&film);
            let reach = px
                .iter()
                .filter(|p| p.value > 0.0)
                .map(|p| p.near)
                .fold(0.0, f64::max);
            assert!(
                reach <= radius + 0.5,
                "depth {depth}, angle {angle}: a pixel {reach:.2} px out is lit, radius {radius:.2}"
            );
            let want: Vec<f64> = px.iter().map(|p| expected(p, confusion, own)).collect();
            let rings = radius.ceil() as usize + 2;
            // Per ring: pixels, sum of values, of expectations, of their variances.
            let mut ring = vec![(0usize, 0.0f64, 0.0f64, 0.0f64); rings];
            for (p, &e) in px.iter().zip(&want) {
                if let Some(r) = ring.get_mut(p.centre as usize) {
                    *r = (
                        r.0 + 1,
                        r.1 + p.value,
                        r.2 + e,
                        r.3 + e * (1.0 - e) / spp as f64,
                    );
                }
            }
            for (k, &(n, got, want, variance)) in ring.iter().enumerate() {
                let n = n as f64;
                let (got, want) = (got / n, want / n);
                let bound = 5.0 * variance.sqrt() / n + 0.003;
                assert!(
                    (got - want).abs() <= bound,
                    "depth {depth}, angle {angle}, ring {k}: mean {got:.4}, thin lens {want:.4} (± {bound:.4})"
                );
            }
            let sum: f64 = px.iter().map(|p| p.value).sum();
            let area = std::f64::consts::PI * own * own;
            let spread: f64 = want.iter().map(|e| e * (1.0 - e) / spp as f64).sum();
            assert!(
                (sum - area).abs() <= 5.0 * spread.sqrt() + 0.01 * area,
                "depth {depth}, angle {angle}: sum {sum:.2}, disk {area:.2}"
            );
            // The blur's radius from its second moment: the sphere's disk (radius
            // `own`) spread over a circle of confusion of radius c has the mean squared
            // distance own²/2 + c²/2 from the axis, so the image's moment less the
            // expected image's (both at pixel centres) is half the difference of the
            // squared radii.
            let moment = |v: &mut dyn Iterator<Item = f64>| {
                let (m, s) = v.zip(&px).fold((0.0, 0.0), |(m, s), (v, p)| {
                    (m + v * p.centre * p.centre, s + v)
                });
                m / s
            };
            let shift = moment(&mut px.iter().map(|p| p.value)) - moment(&mut want.iter().copied());
            let measured = (confusion * confusion + 2.0 * shift).max(0.0).sqrt();
            assert!(
                (measured - confusion).abs() <= 0.5,
                "depth {depth}, angle {angle}: blur radius {measured:.2} px, thin lens {confusion:.2} px"
            );
        }
        // In focus, the lens changes nothing visible: the same lit pixels as the
        // pinhole's but at its rim.
        if depth == FOCUS {
            let pinhole = pixels(&render(&lone_sphere(depth, 0.0, spp)));
            let lens = pixels(&render(&lone_sphere(depth, ANGLE, spp)));
            let (_, own) = predicted_radius(depth, 0.0);
            for (p, q) in pinhole.iter().zip(&lens) {
                if p.far <= own - 0.5 || p.near >= own + 0.5 {
                    assert_eq!(p.value > 0.0, q.value > 0.0, "{} {}", p.value, q.value);
                }
            }
        }
    }
}

/// The lens disk is sampled uniformly: out of focus, a point's blur is flat. The ring
/// inside the circle of confusion (less the sphere's own radius) has the mean value
/// (own / confusion)², the same in its inner and outer halves (a map that crowded the
/// disk's centre, such as radius = u instead of √u, would make the inner half brighter).
#[test]
fn blur_is_flat_inside_the_circle_of_confusion() {
    let depth = FOCUS / 2.0;
    let film = render(&lone_sphere(depth, ANGLE, 256));
    let (confusion, own) = predicted_radius(depth, ANGLE);
    let inner = confusion - own - 1.0;
    let mean = |lo: f64, hi: f64| {
        let v: Vec<f64> = pixels(&film)
            .iter()
            .filter(|p| p.near >= lo && p.far <= hi)
            .map(|p| p.value)
            .collect();
        assert!(v.len() > 100, "{lo} {hi}: {} pixels", v.len());
        v.iter().sum::<f64>() / v.len() as f64
    };
    let want = (own / confusion).powi(2);
    let (centre, rim) = (
        mean(0.0, inner / 2.0_f64.sqrt()),
        mean(inner / 2.0_f64.sqrt(), inner),
    );
    for got in [centre, rim] {
        assert!((got / want - 1.0).abs() < 0.1, "{got} against {want}");
    }
}

/// The defaults are the original program's pinhole: every built-in scene without a
/// lens gets the same camera with `defocus_angle = 0` and `focus_dist = 1` written out,
/// and draws no lens numbers (`has_lens`).
#[test]
fn the_defaults_are_a_pinhole_one_unit_away() {
    for (name, _) in SCENES {
        let plain = support::builtin(name, 40, 1);
        if name.ends_with("-defocus") {
            assert!(plain.camera.has_lens(), "{name}");
            continue;
        }
        let written = builtin_with_camera(name, "defocus_angle = 0\nfocus_dist = 1", 40, 1);
        assert_eq!(plain.camera, written.camera, "{name}");
        assert!(!plain.camera.has_lens(), "{name}");
    }
}

/// `focus_dist` alone scales the viewport about the eye and changes nothing else. With
/// `look_from` at the origin and a power of two the f32 rays are the same bits (every
/// step of the viewport scales exactly), so the images are; elsewhere the rays differ by
/// their rounding only, and the picture is the same within noise far below a level of
/// 255.
#[test]
fn focus_dist_alone_only_rescales_the_viewport() {
    let film = |s: &Scene| render(s);
    for name in ["spheres", "mixed"] {
        let reference = bits(&film(&support::builtin(name, 48, 2)));
        for focus in [0.25, 2.0, 8.0] {
            let scaled = builtin_with_camera(name, &format!("focus_dist = {focus}"), 48, 2);
            assert!(
                bits(&film(&scaled)) == reference,
                "{name}: focus_dist {focus}"
            );
        }
    }
    for (name, _) in SCENES {
        if name.ends_with("-defocus") {
            continue;
        }
        let reference = film(&support::builtin(name, 48, 2));
        let scaled = film(&builtin_with_camera(name, "focus_dist = 3.7", 48, 2));
        let diff = mean_abs_diff(&reference, &scaled);
        assert!(diff < 1e-3, "{name}: mean difference {diff}");
    }
}
