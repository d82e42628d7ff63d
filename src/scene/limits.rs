//! Where scene values meet f32: the rules that keep every ray, distance and pixel sum
//! finite. A scene file's numbers are f64 (TOML's); the renderer works in f32, so a
//! value finite in the file can overflow f32 itself (`1e39`), or overflow in what the
//! renderer computes from it (a squared radius, an intersection test's products, the sum
//! of a pixel's samples). `scene::compile` refuses such values with their line; the rules
//! are documented in `scenes/README.md` ("Ranges").

use super::desc::V3;
use crate::material::Phong;
use glam::Vec3;

/// Every point of the scene's geometry (sphere centre ± radius, quad, triangle, box and
/// mesh vertices) lies within ±`MAX_COORDINATE` on every axis. The watertight triangle
/// test multiplies three coordinate differences (its distance numerator, about 42·D³ for
/// differences up to D); with D up to 2·√3·1e10 that is below 2e33, far from f32's
/// 3.4e38, and a squared distance or radius (1.2e21) is finite too.
pub const MAX_COORDINATE: f64 = 1e10;

/// The camera's position and its image plane (one unit in front of `look_from`, as wide
/// and high as `vfov` and the aspect ratio make it) lie within ±`MAX_CAMERA_COORDINATE`.
/// A camera ray's direction is `p − look_from` for a point `p` of the image plane, both
/// f32: below 2²⁰ their spacing is at most 1/16, so the difference (at least one unit
/// long) can never round to zero or to a direction more than a few degrees off. Beyond
/// it, directions round to zero (NaN rays) or to a handful of values.
pub const MAX_CAMERA_COORDINATE: f64 = 1e6;

/// `x` as an f32 (a number the file gives in f64), or why not.
pub fn number(key: &str, x: f64) -> Result<f32, String> {
    if !x.is_finite() {
        return Err(format!("{key} must be finite, got {x}"));
    }
    if x.abs() > f32::MAX as f64 {
        return Err(format!(
            "{key} = {x:e} is too large: it does not fit in f32 (at most {:e})",
            f32::MAX
        ));
    }
    Ok(x as f32)
}

/// `x` ≥ 0 as an f32 (−1e-300, which rounds to −0 in f32, is negative).
pub fn non_negative(key: &str, x: f64) -> Result<f32, String> {
    match number(key, x) {
        Ok(v) if x >= 0.0 => Ok(v),
        _ => Err(not_in_range(key, x, "finite and non-negative")),
    }
}

/// `x` > 0 as an f32 (1e-50, which rounds to 0 in f32, is not).
pub fn positive(key: &str, x: f64) -> Result<f32, String> {
    match number(key, x) {
        Ok(v) if v > 0.0 => Ok(v),
        _ => Err(not_in_range(key, x, "finite and positive")),
    }
}

fn not_in_range(key: &str, x: f64, what: &str) -> String {
    if x.is_finite() && x.abs() > f32::MAX as f64 {
        format!(
            "{key} = {x:e} is too large: it does not fit in f32 (at most {:e})",
            f32::MAX
        )
    } else {
        format!("{key} must be {what}, got {x}")
    }
}

/// A colour: three finite, non-negative numbers that fit in f32.
pub fn colour(key: &str, c: V3) -> Result<Vec3, String> {
    let fits = c.0.iter().all(|x| x.is_finite() && *x >= 0.0);
    if !fits {
        return Err(format!(
            "{key} must be finite and non-negative, got {:?}",
            c.0
        ));
    }
    if let Some(x) = c.0.iter().find(|x| **x > f32::MAX as f64) {
        return Err(format!(
            "{key} {:?}: {x:e} is too large: it does not fit in f32 (at most {:e})",
            c.0,
            f32::MAX
        ));
    }
    Ok(Vec3::new(c.0[0] as f32, c.0[1] as f32, c.0[2] as f32))
}

/// A point of the scene's geometry, or an edge vector: finite and within
/// ±`MAX_COORDINATE`.
pub fn point(key: &str, p: V3) -> Result<Vec3, String> {
    if !p.0.iter().all(|x| x.is_finite()) {
        return Err(format!("{key} must be finite, got {:?}", p.0));
    }
    if let Some(x) = p.0.iter().find(|x| x.abs() > MAX_COORDINATE) {
        return Err(format!(
            "{key} {:?}: {x:e} is too large: the scene must lie within ±{MAX_COORDINATE:e} on every axis (f32 intersection tests overflow beyond)",
            p.0
        ));
    }
    Ok(Vec3::new(p.0[0] as f32, p.0[1] as f32, p.0[2] as f32))
}

/// Points made from the file's values (a sphere's box, a quad's far corners) must lie
/// within ±`MAX_COORDINATE` too; `what` names the values they come from.
pub fn derived_points(what: &str, points: &[Vec3]) -> Result<(), String> {
    for p in points {
        for x in p.to_array() {
            if !(x.is_finite() && (x as f64).abs() <= MAX_COORDINATE) {
                return Err(format!(
                    "{what} reach {:.3e}, which is too large: the scene must lie within ±{MAX_COORDINATE:e} on every axis (f32 intersection tests overflow beyond)",
                    x as f64
                ));
            }
        }
    }
    Ok(())
}

/// The largest magnitude of a camera's position and image-plane corners, in f64 from
/// the f32 values the renderer uses, against `MAX_CAMERA_COORDINATE`.
pub fn camera_extent(camera: &crate::camera::Camera) -> f64 {
    let d = |v: Vec3| v.as_dvec3();
    let (w, h) = (camera.width as f64, camera.height as f64);
    let corner = d(camera.corner);
    let corners = [
        corner,
        corner + d(camera.pixel_du) * w,
        corner + d(camera.pixel_dv) * h,
        corner + d(camera.pixel_du) * w + d(camera.pixel_dv) * h,
        d(camera.origin),
        // The farthest point of the lens disk (the origin for a pinhole).
        d(camera.origin).abs() + d(camera.lens_u).abs() + d(camera.lens_v).abs(),
    ];
    corners
        .iter()
        .map(|p| p.abs().max_element())
        .fold(0.0, f64::max)
}

/// One term of a sample's largest value, with where it comes from (for the message).
#[derive(Clone, Debug)]
pub struct Term {
    pub value: f64,
    /// Byte offset in the scene file of the table that sets it.
    pub offset: usize,
    pub what: String,
}

/// An upper bound of the value of one camera sample, and of the pixel sums, from the
/// colours, light intensities, Phong weights, path-traced albedos and `max_depth`.
///
/// How the tracers combine them (`integrator`): a sample is the path's throughput (the
/// product of the Diffuse and Metal albedos met, at most `max_depth` of them) times what
/// the path ends on: the background, a light's colour, an albedo or white (seen by a
/// mirror), or Phong, albedo ⊙ (ka·ambient + kd·Σ diffuse + ks·Σ specular), each light's
/// terms summed over its samples (before the division by their count) from its radiance
/// times N·L or (R·V)^shininess. N·L and R·V are dot products of unit vectors, at most
/// 1 + 1e-6 after rounding, so (R·V)^shininess ≤ (1 + 1e-6)^shininess. A mirror mixes
/// Phong and its reflection by Schlick's F, within rounding a convex mix: 1.25 covers a
/// chain of 10 000. A pixel sums its samples before dividing by their count.
#[derive(Clone, Debug, Default)]
pub struct SampleBound {
    /// What a path can end on (the largest of them is the bound's base).
    pub ends: Vec<Term>,
    /// Σ over lights of radiance · samples (the diffuse sum before Phong's weights).
    pub light_sum: f64,
    /// The largest albedo component of a Diffuse or Metal material, and where it is.
    pub path_albedo: Option<Term>,
}

/// How far above 1 a dot product of two unit f32 vectors can round.
const UNIT_DOT_SLACK: f64 = 1e-6;
/// A mirror chain's mix, F·reflected + (1 − F)·Phong, with rounding.
const MIRROR_SLACK: f64 = 1.25;

impl SampleBound {
    pub fn end(&mut self, value: f64, offset: usize, what: impl Into<String>) {
        self.ends.push(Term {
            value,
            offset,
            what: what.into(),
        });
    }

    /// A light of `radiance` sampled `samples` times a Phong evaluation.
    pub fn light(&mut self, radiance: f64, samples: u32) {
        self.light_sum += radiance * samples as f64 * (1.0 + UNIT_DOT_SLACK);
    }

    /// A Phong material's largest value under the scene's largest `ambient` channel: the
    /// sum inside the albedo, and the albedo applied (whichever is larger, since both are
    /// computed).
    pub fn phong(&mut self, ambient: f64, phong: &Phong, offset: usize, what: &str) {
        let albedo = phong.albedo.max_element() as f64;
        let shininess = phong.shininess as f64;
        let (ka, kd, ks) = (phong.ka as f64, phong.kd as f64, phong.ks as f64);
        let specular = (1.0 + UNIT_DOT_SLACK).powf(shininess);
        let sum = ka * ambient + kd * self.light_sum + ks * specular * self.light_sum;
        self.end(sum * albedo.max(1.0), offset, what);
    }

    pub fn path_albedo(&mut self, albedo: f64, offset: usize, what: &str) {
        if self.path_albedo.as_ref().is_none_or(|t| albedo > t.value) {
            self.path_albedo = Some(Term {
                value: albedo,
                offset,
                what: what.to_string(),
            });
        }
    }

    /// The throughput bound of a path: the largest albedo to the power `max_depth`.
    pub fn throughput(&self, max_depth: u32) -> f64 {
        self.path_albedo
            .as_ref()
            .map_or(1.0, |t| t.value.max(1.0).powi(max_depth as i32))
    }

    /// Check that `spp` samples of a pixel sum to a finite f32 (with a factor 2 to
    /// spare). `Err` gives the offset to report and the message.
    pub fn check(&self, spp: u32, max_depth: u32) -> Result<(), (usize, String)> {
        let throughput = self.throughput(max_depth);
        let Some(base) = self.ends.iter().max_by(|a, b| a.value.total_cmp(&b.value)) else {
            return Ok(());
        };
        let sample = base.value.max(1.0) * throughput * MIRROR_SLACK;
        let sum = sample * spp as f64;
        let limit = f32::MAX as f64 / 2.0;
        if sum.is_finite() && sum <= limit && sample <= limit {
            return Ok(());
        }
        let mut message = format!(
            "colours too large for f32: {} can reach {:.3e}",
            base.what, base.value
        );
        let mut offset = base.offset;
        if throughput > 1.0 {
            if let Some(a) = &self.path_albedo {
                message += &format!(
                    ", times {throughput:.3e} from {} over max_depth {max_depth} bounces",
                    a.what
                );
                if throughput > base.value {
                    offset = a.offset;
                }
            }
        }
        message += &format!(
            ", and a pixel sums {spp} samples: at most {limit:.3e} (half of f32's largest number) is allowed"
        );
        Err((offset, message))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_beyond_f32_are_refused_with_their_value() {
        assert_eq!(number("radius", 2.5), Ok(2.5));
        let e = number("radius", 1e39).unwrap_err();
        assert!(
            e.contains("1e39") && e.contains("does not fit in f32"),
            "{e}"
        );
        assert!(number("radius", f64::NAN).unwrap_err().contains("finite"));
        assert!(positive("index", 0.0).is_err());
        assert!(non_negative("ka", -1e-300).is_err());
        assert_eq!(non_negative("ka", 0.0), Ok(0.0));
        // A tiny positive number that rounds to f32 zero is not positive.
        assert!(positive("index", 1e-50).is_err());
    }

    #[test]
    fn points_must_lie_within_the_coordinate_limit() {
        assert_eq!(
            point("center", V3([1e10, -1e10, 0.0])),
            Ok(Vec3::new(1e10, -1e10, 0.0))
        );
        let e = point("center", V3([0.0, 0.0, 1.0000001e10])).unwrap_err();
        assert!(e.contains("too large") && e.contains("1e10"), "{e}");
        assert!(derived_points("center ± radius", &[Vec3::splat(2e10)]).is_err());
        assert!(derived_points("corner + u", &[Vec3::INFINITY]).is_err());
    }

    #[test]
    fn the_sample_bound_follows_the_shading_rules() {
        // A background of 3e38 at 2 spp sums past f32.
        let mut b = SampleBound::default();
        b.end(3e38, 7, "background");
        let (at, e) = b.check(2, 10).unwrap_err();
        assert_eq!(at, 7);
        assert!(e.contains("background") && e.contains("2 samples"), "{e}");
        // 1e37 at 1 spp is fine (1.25e37 < 1.7e38), at 16 spp it is not.
        let mut b = SampleBound::default();
        b.end(1e37, 0, "background");
        assert!(b.check(1, 10).is_ok());
        assert!(b.check(16, 10).is_err());
        // Phong: ka·ambient + (kd + ks)·Σ radiance·samples, with the specular slack.
        let mut b = SampleBound::default();
        b.light(1e30, 10);
        let phong = |shininess| Phong {
            albedo: Vec3::new(0.5, 0.25, 0.0),
            shininess,
            ka: 0.5,
            kd: 0.5,
            ks: 0.5,
        };
        b.phong(0.0, &phong(0.0), 3, "material 'm'");
        let want = (0.5 + 0.5) * 1e31 * (1.0 + UNIT_DOT_SLACK);
        assert!((b.ends[0].value - want).abs() <= 1e-12 * want);
        // A huge shininess makes (1 + 1e-6)^n overflow: refused.
        b.phong(0.0, &phong(1e9), 4, "material 'shiny'");
        assert_eq!(b.check(1, 1).unwrap_err().0, 4);
        // An albedo above 1 over many bounces: 2^200 · 1 overflows; named at the albedo.
        let mut b = SampleBound::default();
        b.end(1.0, 0, "background");
        b.path_albedo(2.0, 9, "albedo of material 'hot'");
        assert!(b.check(1, 100).is_ok());
        let (at, e) = b.check(1, 200).unwrap_err();
        assert_eq!(at, 9);
        assert!(e.contains("material 'hot'") && e.contains("200"), "{e}");
    }
}
