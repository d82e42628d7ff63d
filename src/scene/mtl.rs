//! MTL material libraries (`materials = "mtl"` on a mesh): read line by line, every
//! value checked with its line, and mapped onto this renderer's materials by the table
//! in `scenes/README.md` ("Materials from the OBJ file"). A statement the mapping cannot
//! use is named once in a warning, never silently dropped.

use super::limits;
use crate::error::{Error, Result};
use crate::material::{Material, Phong};
use glam::Vec3;

/// One `newmtl` block: the statements the mapping reads, as the file gives them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MtlMaterial {
    pub name: String,
    /// The library that defines it, as messages name it.
    pub library: String,
    /// 1-based line of its `newmtl`.
    pub line: usize,
    pub ka: Option<Vec3>,
    pub kd: Option<Vec3>,
    pub ks: Option<Vec3>,
    pub ke: Option<Vec3>,
    pub ns: Option<f32>,
    pub ni: Option<f32>,
    /// Dissolve `d` (1 opaque), or 1 − `Tr`.
    pub dissolve: Option<f32>,
    pub illum: Option<u32>,
}

/// A material library: its materials in file order, and what it says that the mapping
/// does not use (one message each).
#[derive(Clone, Debug, Default)]
pub struct MtlLibrary {
    pub materials: Vec<MtlMaterial>,
    pub warnings: Vec<String>,
}

/// The statements the mapping reads.
const READ: [&str; 10] = [
    "newmtl", "Ka", "Kd", "Ks", "Ke", "Ns", "Ni", "d", "Tr", "illum",
];

/// Parse MTL text; `path` is only used in messages.
pub fn parse_mtl(path: &str, text: &str) -> Result<MtlLibrary> {
    let fail = |line: usize, message: String| Error::Obj {
        path: path.to_string(),
        line,
        message,
    };
    let mut library = MtlLibrary::default();
    let mut unused: Vec<(String, usize)> = Vec::new();
    let mut illum_read_as: Vec<(u32, usize, u32)> = Vec::new();
    let mut current: Option<MtlMaterial> = None;
    for (n, line) in text.split(['\n', '\r']).enumerate() {
        let n = n + 1;
        let line = line.split('#').next().unwrap_or("");
        let mut words = line.split_whitespace();
        let Some(statement) = words.next() else {
            continue;
        };
        let rest: Vec<&str> = words.collect();
        if statement == "newmtl" {
            let name = line.trim_start()["newmtl".len()..].trim();
            if name.is_empty() {
                return Err(fail(n, "newmtl needs a material name".into()));
            }
            if let Some(m) = current.take() {
                library.materials.push(m);
            }
            if let Some(other) = library.materials.iter().find(|m| m.name == name) {
                return Err(fail(
                    n,
                    format!(
                        "material '{name}' is defined twice (lines {} and {n})",
                        other.line
                    ),
                ));
            }
            current = Some(MtlMaterial {
                name: name.to_string(),
                library: path.to_string(),
                line: n,
                ..MtlMaterial::default()
            });
            continue;
        }
        if !READ.contains(&statement) {
            if !unused.iter().any(|(s, _)| s == statement) {
                unused.push((statement.to_string(), n));
            }
            continue;
        }
        let Some(m) = current.as_mut() else {
            return Err(fail(
                n,
                format!("'{statement}' before any newmtl: it belongs to no material"),
            ));
        };
        let at = |message: String| fail(n, format!("{statement}: {message}"));
        let number = |word: &str| -> Result<f32> {
            let x: f64 = word
                .parse()
                .map_err(|_| at(format!("'{word}' is not a number")))?;
            limits::number(statement, x).map_err(at)
        };
        let one = || -> Result<f32> {
            match rest[..] {
                [x] => number(x),
                _ => Err(at(format!("expected one number, got {} words", rest.len()))),
            }
        };
        match statement {
            "Ka" | "Kd" | "Ks" | "Ke" => {
                // `Kd r [g b]` (a grey when one number); `Kd spectral ...` and
                // `Kd xyz ...` are not RGB.
                let c = match rest[..] {
                    [r] => Vec3::splat(number(r)?),
                    [r, g, b] => Vec3::new(number(r)?, number(g)?, number(b)?),
                    _ => {
                        return Err(at(format!(
                            "expected an RGB colour (one or three numbers), got '{}'",
                            rest.join(" ")
                        )))
                    }
                };
                limits::colour(statement, super::desc::V3(c.as_dvec3().to_array())).map_err(at)?;
                let slot = match statement {
                    "Ka" => &mut m.ka,
                    "Kd" => &mut m.kd,
                    "Ks" => &mut m.ks,
                    _ => &mut m.ke,
                };
                *slot = Some(c);
            }
            "Ns" => m.ns = Some(non_negative(one()?).map_err(at)?),
            "Ni" => {
                let x = one()?;
                if x <= 0.0 {
                    return Err(at(format!(
                        "the index of refraction must be positive, got {x}"
                    )));
                }
                m.ni = Some(x);
            }
            "d" | "Tr" => {
                let x = one()?;
                if !(0.0..=1.0).contains(&x) {
                    return Err(at(format!("must be 0 to 1, got {x}")));
                }
                m.dissolve = Some(if statement == "d" { x } else { 1.0 - x });
            }
            _ => {
                let illum: u32 = match rest[..] {
                    [x] => x.parse().ok().filter(|&i| i <= 10),
                    _ => None,
                }
                .ok_or_else(|| at(format!("expected 0 to 10, got '{}'", rest.join(" "))))?;
                let read_as = match illum {
                    0..=3 => illum,
                    _ => 2,
                };
                if read_as != illum {
                    illum_read_as.push((illum, n, read_as));
                }
                m.illum = Some(read_as);
            }
        }
    }
    if let Some(m) = current {
        library.materials.push(m);
    }
    if !unused.is_empty() {
        let list: Vec<String> = unused
            .iter()
            .map(|(s, line)| format!("{s} (line {line})"))
            .collect();
        library.warnings.push(format!(
            "{path}: not used by the renderer: {}",
            list.join(", ")
        ));
    }
    for (illum, line, read_as) in illum_read_as {
        library.warnings.push(format!(
            "{path}:{line}: illum {illum} is read as illum {read_as}"
        ));
    }
    Ok(library)
}

fn non_negative(x: f32) -> Result<f32, String> {
    if x >= 0.0 {
        Ok(x)
    } else {
        Err(format!("must be non-negative, got {x}"))
    }
}

/// Default `Kd`, where a material gives none (the common exporters' default).
pub const DEFAULT_KD: Vec3 = Vec3::splat(0.8);
/// Default `Ns`.
pub const DEFAULT_NS: f32 = 10.0;
/// Default `Ni`, for glass and mirrors.
pub const DEFAULT_NI: f32 = 1.5;

/// The renderer's material for `m` (`scenes/README.md`, "Materials from the OBJ file"):
/// an emitter (`Ke` not black) is a light; a transparent one (`d` < 1 or `Tr` > 0) is
/// glass of index `Ni`; `illum 3` is a Phong mirror of index `Ni`; any other is Phong
/// with albedo `Kd`, shininess `Ns`, kd = 1, and ka, ks the mean of `Ka`, `Ks` over the
/// mean of `Kd` (Phong's terms are tinted by the albedo, so ks · Kd ≈ Ks).
pub fn to_material(m: &MtlMaterial) -> Material {
    if let Some(ke) = m.ke.filter(|ke| ke.max_element() > 0.0) {
        return Material::Light {
            color: ke,
            intensity: 1.0,
        };
    }
    let index = m.ni.unwrap_or(DEFAULT_NI);
    if m.dissolve.is_some_and(|d| d < 1.0) {
        return Material::Dielectric { index };
    }
    let albedo = m.kd.unwrap_or(DEFAULT_KD);
    let mean = |c: Vec3| (c.x as f64 + c.y as f64 + c.z as f64) / 3.0;
    let ratio = |c: Vec3| {
        let kd = mean(albedo);
        if kd > 0.0 {
            // Within f32: a colour and a Kd mean both fit, and the quotient is
            // bounded by the sample-value check at compile.
            (mean(c) / kd).min(f32::MAX as f64) as f32
        } else {
            0.0
        }
    };
    let phong = Phong {
        albedo,
        shininess: m.ns.unwrap_or(DEFAULT_NS),
        ka: m.ka.map_or(0.5, ratio),
        kd: 1.0,
        ks: match m.illum {
            Some(0 | 1) => 0.0,
            _ => m.ks.map_or(0.0, ratio),
        },
    };
    match m.illum {
        Some(3) => Material::PhongMirror { phong, index },
        _ => Material::Phong(phong),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statements_map_by_the_table() {
        let text = "# a library\nnewmtl red\nKd 0.8 0.1 0.1\nKs 0.4\nNs 50\nmap_Kd red.png\n\
                    newmtl glass\nd 0.2\nNi 1.33\nnewmtl lamp\nKe 4 4 3\nnewmtl chrome\n\
                    illum 3\nKd 0.9 0.9 0.9\nmap_Kd x.png\nbump b.png\nillum 7\n";
        let lib = parse_mtl("m.mtl", text).unwrap();
        let names: Vec<&str> = lib.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["red", "glass", "lamp", "chrome"]);
        match to_material(&lib.materials[0]) {
            Material::Phong(p) => {
                assert_eq!(p.albedo, Vec3::new(0.8, 0.1, 0.1));
                assert_eq!(p.shininess, 50.0);
                assert_eq!(p.kd, 1.0);
                assert_eq!(p.ka, 0.5);
                // mean(Ks) / mean(Kd) = 0.4 / (1 / 3).
                assert!((p.ks - 1.2).abs() < 1e-6, "{}", p.ks);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(
            to_material(&lib.materials[1]),
            Material::Dielectric { index: 1.33 }
        );
        let lamp = Material::Light {
            color: Vec3::new(4.0, 4.0, 3.0),
            intensity: 1.0,
        };
        assert_eq!(to_material(&lib.materials[2]), lamp);
        // The last illum (7) is read as 2: Phong.
        assert!(matches!(to_material(&lib.materials[3]), Material::Phong(_)));
        // Each unused statement named once, at its first line; the illum read otherwise.
        assert_eq!(
            lib.warnings,
            [
                "m.mtl: not used by the renderer: map_Kd (line 6), bump (line 16)",
                "m.mtl:17: illum 7 is read as illum 2",
            ]
        );
        let mirror = parse_mtl("m.mtl", "newmtl m\nillum 3\n").unwrap();
        assert!(matches!(
            to_material(&mirror.materials[0]),
            Material::PhongMirror { index: 1.5, .. }
        ));
    }

    #[test]
    fn bad_statements_are_refused_at_their_line() {
        for (text, line, words) in [
            ("newmtl a\nKd 1 nan 0\n", 2, "Kd"),
            ("newmtl a\nKd 1 2\n", 2, "RGB"),
            ("newmtl a\nKd -1 0 0\n", 2, "non-negative"),
            ("newmtl a\nNs -3\n", 2, "non-negative"),
            ("newmtl a\nd 2\n", 2, "0 to 1"),
            ("newmtl a\nNi 0\n", 2, "positive"),
            ("newmtl a\nillum x\n", 2, "0 to 10"),
            ("Kd 1 1 1\n", 1, "before any newmtl"),
            ("newmtl a\n\nnewmtl a\n", 3, "defined twice"),
            ("newmtl\n", 1, "name"),
            ("newmtl a\nKd 1e39 0 0\n", 2, "f32"),
        ] {
            match parse_mtl("m.mtl", text) {
                Err(Error::Obj {
                    line: l, message, ..
                }) => {
                    assert_eq!(l, line, "{text}: {message}");
                    assert!(message.contains(words), "{text}: {message}");
                }
                other => panic!("{text}: {other:?}"),
            }
        }
    }
}
