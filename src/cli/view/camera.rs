//! The camera moves a tab sends (JSON text messages), and what each does to the pose:
//! orbit around `look_at`, pan across the view, move closer or away. In f64 on the
//! pose's own numbers; the library checks the result (`Renderer::set_camera_pose`).

use raytracer::CameraPose;
use serde::Deserialize;

/// One mouse move, in CSS pixels of the picture (the page scales its events to the
/// image's pixels). Any other message, or a value that is not a finite number within
/// `MAX_PIXELS`, closes the connection that sent it.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "lowercase")]
pub enum Move {
    /// Drag: turn the camera around `look_at`, `dx` pixels across, `dy` down.
    Orbit([f64; 2]),
    /// Shift-drag or right-drag: move `look_from` and `look_at` together, so that the
    /// point at `look_at` follows the mouse.
    Pan([f64; 2]),
    /// Wheel: `look_from` toward `look_at` (negative) or away, by a factor of
    /// `2^(delta / 500)`.
    Zoom(f64),
}

/// The largest move a message may carry, in pixels.
pub const MAX_PIXELS: f64 = 1e5;

/// A turn of this many pixels is 180 degrees.
const PIXELS_PER_HALF_TURN: f64 = 600.0;

/// The view direction stays this far (radians) from `up`, so the basis never degenerates.
const POLE_MARGIN: f64 = 1e-3;

type V = [f64; 3];

fn sub(a: V, b: V) -> V {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn add(a: V, b: V) -> V {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn scale(a: V, s: f64) -> V {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn dot(a: V, b: V) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: V, b: V) -> V {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn length(a: V) -> f64 {
    dot(a, a).sqrt()
}
fn normalize(a: V) -> Option<V> {
    let l = length(a);
    (l.is_finite() && l > 0.0).then(|| scale(a, 1.0 / l))
}

impl Move {
    /// Parse a message: `None` for anything but a move with finite values within
    /// `MAX_PIXELS`.
    pub fn parse(text: &str) -> Option<Move> {
        let m: Move = serde_json::from_str(text).ok()?;
        let ok = |v: f64| v.is_finite() && v.abs() <= MAX_PIXELS;
        match m {
            Move::Orbit([x, y]) | Move::Pan([x, y]) if ok(x) && ok(y) => Some(m),
            Move::Zoom(d) if ok(d) => Some(m),
            _ => None,
        }
    }

    /// The pose after this move, for an image `height` pixels tall. A move the pose
    /// cannot take (a degenerate basis) leaves it as it is.
    pub fn apply(&self, pose: &CameraPose, height: u32) -> CameraPose {
        self.moved(pose, height).unwrap_or(*pose)
    }

    fn moved(&self, pose: &CameraPose, height: u32) -> Option<CameraPose> {
        let offset = sub(pose.look_from, pose.look_at);
        let distance = length(offset);
        let up = normalize(pose.up)?;
        let back = normalize(offset)?;
        let right = normalize(cross(up, back))?;
        let mut next = *pose;
        match *self {
            Move::Orbit([dx, dy]) => {
                let per_pixel = std::f64::consts::PI / PIXELS_PER_HALF_TURN;
                // Around `up` by dx, then toward or away from `up` by dy, kept off the poles.
                let yaw = -dx * per_pixel;
                let polar = dot(back, up).clamp(-1.0, 1.0).acos();
                let polar =
                    (polar - dy * per_pixel).clamp(POLE_MARGIN, std::f64::consts::PI - POLE_MARGIN);
                // `back` in the basis (right, up, forward-on-the-ground).
                let ground = normalize(cross(right, up))?;
                let (sy, cy) = yaw.sin_cos();
                let turned = add(scale(ground, cy), scale(right, sy));
                let (sp, cp) = polar.sin_cos();
                let direction = add(scale(up, cp), scale(turned, sp));
                next.look_from = add(pose.look_at, scale(direction, distance));
            }
            Move::Pan([dx, dy]) => {
                // A pixel at `look_at`'s distance spans 2·d·tan(vfov/2)/height.
                let pixel = 2.0 * distance * (pose.vfov.to_radians() / 2.0).tan() / height as f64;
                let true_up = cross(back, right);
                let shift = add(scale(right, -dx * pixel), scale(true_up, dy * pixel));
                next.look_from = add(pose.look_from, shift);
                next.look_at = add(pose.look_at, shift);
            }
            Move::Zoom(delta) => {
                let factor = (delta / 500.0).exp2();
                next.look_from = add(pose.look_at, scale(offset, factor));
            }
        }
        let finite = |v: V| v.iter().all(|x| x.is_finite());
        (finite(next.look_from) && finite(next.look_at)).then_some(next)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose() -> CameraPose {
        CameraPose {
            look_from: [0.0, 1.0, 5.0],
            look_at: [0.0, 1.0, 0.0],
            up: [0.0, 1.0, 0.0],
            vfov: 90.0,
            defocus_angle: 0.0,
            focus_dist: 1.0,
        }
    }

    fn close(a: V, b: V) -> bool {
        length(sub(a, b)) < 1e-9
    }

    /// 300 pixels across is a quarter turn around `look_at` (the camera to its left
    /// moves right, so the scene turns with the mouse), at the same distance.
    #[test]
    fn orbit_turns_around_look_at() {
        let p = Move::Orbit([300.0, 0.0]).apply(&pose(), 100);
        assert!(close(p.look_from, [-5.0, 1.0, 0.0]), "{:?}", p.look_from);
        assert_eq!(p.look_at, pose().look_at);
        // Dragging down far past the pole stops short of it.
        let p = Move::Orbit([0.0, 5000.0]).apply(&pose(), 100);
        let back = normalize(sub(p.look_from, p.look_at)).unwrap();
        assert!((dot(back, [0.0, 1.0, 0.0]) - POLE_MARGIN.cos()).abs() < 1e-9);
    }

    /// A pan of the image's height moves both points by the view's height at
    /// `look_at` (2·5·tan 45° = 10); a wheel delta of 500 doubles the distance.
    #[test]
    fn pan_and_zoom() {
        let p = Move::Pan([0.0, 100.0]).apply(&pose(), 100);
        assert!(close(p.look_at, [0.0, 11.0, 0.0]), "{:?}", p.look_at);
        assert!(close(p.look_from, [0.0, 11.0, 5.0]));
        let p = Move::Pan([50.0, 0.0]).apply(&pose(), 100);
        assert!(close(p.look_at, [-5.0, 1.0, 0.0]), "{:?}", p.look_at);
        let p = Move::Zoom(500.0).apply(&pose(), 100);
        assert!(close(p.look_from, [0.0, 1.0, 10.0]));
        let p = Move::Zoom(-500.0).apply(&pose(), 100);
        assert!(close(p.look_from, [0.0, 1.0, 2.5]));
    }

    /// Only the three moves, with finite values in range; anything else is refused.
    #[test]
    fn messages() {
        assert_eq!(
            Move::parse(r#"{"orbit":[1,2]}"#),
            Some(Move::Orbit([1.0, 2.0]))
        );
        assert_eq!(Move::parse(r#"{"zoom":-3.5}"#), Some(Move::Zoom(-3.5)));
        for bad in [
            "",
            "{}",
            "null",
            r#"{"orbit":[1]}"#,
            r#"{"orbit":[1,2,3]}"#,
            r#"{"pan":[1e6,0]}"#,
            r#"{"zoom":1e400}"#,
            r#"{"zoom":"1"}"#,
            r#"{"orbit":[1,2],"zoom":1}"#,
            r#"{"shutdown":true}"#,
        ] {
            assert_eq!(Move::parse(bad), None, "{bad}");
        }
    }
}
