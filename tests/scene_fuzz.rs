//! The fuzzing campaign's check on the stable toolchain, fast enough for every `cargo
//! test`: proptest makes scene text (the built-in scenes with numbers replaced by hostile
//! ones, and scenes written from a grammar of every key with hostile values, vectors of
//! two to five elements, unknown materials) and each is either refused with an error that
//! names the file and line, or renders an 8-pixel-wide image whose pixels are finite and
//! the same bits at packet widths 1, 4 and 8. The cargo-fuzz targets (`fuzz/`) run the
//! same check on mutated bytes, for millions of inputs.

mod support;

use proptest::prelude::*;
use raytracer::accel::{Accel, AccelKind};
use raytracer::render::render;
use raytracer::scene::{builtin, compile, Overrides, SceneSource};
use raytracer::{PacketWidth, RenderSettings};
use std::borrow::Cow;
use support::bits;

/// Numbers a hostile user writes: zeros, subnormals, the limits and just past them,
/// f32's largest and beyond, NaN and infinities, and ordinary ones.
const NUMBERS: &[&str] = &[
    "0",
    "-0.0",
    "1",
    "-1",
    "0.5",
    "2",
    "80",
    "278",
    "-800",
    "1e-45",
    "1e-50",
    "1e6",
    "1.0001e6",
    "1e10",
    "1.0000001e10",
    "1.9e19",
    "1e30",
    "3e38",
    "3.5e38",
    "1e39",
    "1e300",
    "nan",
    "inf",
    "-inf",
    "100000",
    "10000",
    "65536",
    "-5",
    "179.9999",
    "1e9",
];

/// Mostly ordinary numbers, one in four hostile.
fn number() -> impl Strategy<Value = String> {
    prop_oneof![
        3 => (-20.0f64..20.0).prop_map(|x| format!("{x:.3}")),
        1 => prop::sample::select(NUMBERS).prop_map(str::to_string),
    ]
}

/// Mostly three numbers, one in forty of two to five (a scene has dozens of vectors).
fn vector() -> impl Strategy<Value = String> {
    prop_oneof![
        39 => prop::collection::vec(number(), 3),
        1 => prop::collection::vec(number(), 2..=5),
    ]
    .prop_map(|v| format!("[{}]", v.join(", ")))
}

/// Check one scene text: refused with a placed message, or a finite, width-independent
/// render.
fn check(text: &str) -> Result<(), TestCaseError> {
    let source = SceneSource {
        display: "fuzz.toml".into(),
        name: "fuzz".into(),
        text: Cow::Owned(text.to_string()),
        dir: None,
    };
    let overrides = Overrides {
        width: Some(8),
        spp: Some(1),
        max_depth: Some(4),
    };
    let scene = match source.parse().and_then(|d| compile(&source, &d, overrides)) {
        Ok(scene) => scene,
        Err(e) => {
            let message = e.to_string();
            prop_assert!(message.starts_with("fuzz.toml"), "{message}");
            return Ok(());
        }
    };
    if scene.camera.height > 64 {
        return Ok(());
    }
    let mut scene = scene;
    let accel = Accel::build(&mut scene, AccelKind::Bvh);
    let films: Vec<_> = PacketWidth::ALL
        .into_iter()
        .map(|packet_width| {
            let settings = RenderSettings {
                packet_width,
                ..RenderSettings::new(0)
            };
            render(&scene, &accel, &settings, &|| {}).unwrap().film
        })
        .collect();
    for film in &films {
        prop_assert_eq!(film.non_finite_count(), 0, "{}", text);
    }
    prop_assert!(
        bits(&films[0]) == bits(&films[1]),
        "width 4 differs:\n{}",
        text
    );
    prop_assert!(
        bits(&films[0]) == bits(&films[2]),
        "width 8 differs:\n{}",
        text
    );
    Ok(())
}

/// A built-in scene (not the bunny's, whose mesh costs a build an input) with some of
/// its numbers replaced.
fn mutated_builtin() -> impl Strategy<Value = String> {
    let names: Vec<&str> = [
        "cornell",
        "spheres",
        "quads",
        "mixed",
        "cornell-point-light",
    ]
    .to_vec();
    (
        prop::sample::select(names),
        prop::collection::vec((any::<prop::sample::Index>(), number()), 1..4),
    )
        .prop_map(|(name, edits)| {
            let text = builtin::scene(name).unwrap();
            // Byte ranges of the numbers in the text.
            let mut spans = Vec::new();
            let bytes = text.as_bytes();
            let mut i = 0;
            while i < bytes.len() {
                let starts = bytes[i].is_ascii_digit()
                    || (bytes[i] == b'-' && bytes.get(i + 1).is_some_and(u8::is_ascii_digit));
                if starts && (i == 0 || !bytes[i - 1].is_ascii_alphanumeric()) {
                    let start = i;
                    i += 1;
                    while i < bytes.len()
                        && (bytes[i].is_ascii_digit() || b".eE-".contains(&bytes[i]))
                    {
                        i += 1;
                    }
                    spans.push(start..i);
                } else {
                    i += 1;
                }
            }
            let mut chosen: Vec<(std::ops::Range<usize>, String)> = edits
                .into_iter()
                .map(|(at, n)| (spans[at.index(spans.len())].clone(), n))
                .collect();
            chosen.sort_by_key(|(r, _)| std::cmp::Reverse(r.start));
            chosen.dedup_by_key(|(r, _)| r.start);
            let mut text = text.to_string();
            for (range, n) in chosen {
                text.replace_range(range, &n);
            }
            text
        })
}

fn material() -> impl Strategy<Value = String> {
    prop_oneof![
        (vector(), number())
            .prop_map(|(a, s)| format!("type = \"phong\"\nalbedo = {a}\nshininess = {s}\n")),
        (vector(), number(), number(), number()).prop_map(|(a, s, i, k)| format!(
            "type = \"phong_mirror\"\nalbedo = {a}\nshininess = {s}\nindex = {i}\nks = {k}\n"
        )),
        vector().prop_map(|a| format!("type = \"diffuse\"\nalbedo = {a}\n")),
        (vector(), number())
            .prop_map(|(a, f)| format!("type = \"metal\"\nalbedo = {a}\nfuzz = {f}\n")),
        number().prop_map(|i| format!("type = \"dielectric\"\nindex = {i}\n")),
        (vector(), number())
            .prop_map(|(c, i)| format!("type = \"light\"\ncolor = {c}\nintensity = {i}\n")),
    ]
}

fn object() -> impl Strategy<Value = String> {
    let shape = prop_oneof![
        (vector(), number())
            .prop_map(|(c, r)| format!("type = \"sphere\"\ncenter = {c}\nradius = {r}\n")),
        (vector(), vector(), vector())
            .prop_map(|(q, u, v)| format!("type = \"quad\"\ncorner = {q}\nu = {u}\nv = {v}\n")),
        (vector(), vector(), vector())
            .prop_map(|(a, b, c)| format!("type = \"triangle\"\na = {a}\nb = {b}\nc = {c}\n")),
        (vector(), vector()).prop_map(|(p, q)| format!("type = \"box\"\ncorners = [{p}, {q}]\n")),
    ];
    (shape, 0..4usize).prop_map(|(s, m)| format!("[[objects]]\n{s}material = \"m{m}\"\n"))
}

fn grammar_scene() -> impl Strategy<Value = String> {
    (
        vector(),
        vector(),
        (
            prop::option::of(vector().prop_map(|v| format!("look_from = {v}\n"))),
            prop::option::of(vector().prop_map(|v| format!("look_at = {v}\n"))),
            prop::option::of(vector().prop_map(|v| format!("up = {v}\n"))),
            prop::option::of(number().prop_map(|n| format!("vfov = {n}\n"))),
            prop::option::of(number().prop_map(|n| format!("aspect_ratio = {n}\n"))),
        )
            .prop_map(|(a, b, c, d, e)| [a, b, c, d, e].into_iter().flatten().collect::<Vec<_>>()),
        prop::collection::vec(material(), 1..4),
        prop::collection::vec(object(), 1..24),
    )
        .prop_map(|(background, ambient, camera, materials, objects)| {
            let mut text = format!("background = {background}\nambient = {ambient}\n[camera]\n");
            text += &camera.concat();
            for (i, m) in materials.iter().enumerate() {
                text += &format!("[materials.m{i}]\n{m}");
            }
            text + &objects.concat()
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn mutated_builtin_scenes_are_refused_or_render_finite(text in mutated_builtin()) {
        check(&text)?;
    }

    #[test]
    fn generated_scenes_are_refused_or_render_finite(text in grammar_scene()) {
        check(&text)?;
    }
}
