//! Part files: the pixels of a region of a frame ([`Region`]) together with what
//! produced them, so that `merge` can check a set of parts before it puts a frame
//! together.
//!
//! A part file is two lines of text and the pixels (ARCHITECTURE.md, "Farming a frame"):
//!
//! ```text
//! raytracer-part 1
//! {"program":"raytracer 0.1.0","scene":{...},"settings":{...},"region":{...},...}
//! <pixels: linear RGB, three little-endian f32 a pixel, in `Region::rects` order>
//! ```
//!
//! `head -n 2 FILE` shows everything but the pixels. The readers take bytes:
//! `parse_header` checks the header alone, `parse_part` the header and the pixels'
//! length and SHA-256; neither trusts a length it has not checked against the data.
//!
//! One file past 700 lines (a sixth of it tests): the writer and the checking readers
//! of one format, kept together so they cannot drift apart.

use crate::adaptive::Adaptive;
use crate::error::{Error, Result};
use crate::farm::region::{Rect, Region, TILE};
use crate::integrator::RayCounts;
use crate::output::OutputSet;
use crate::render::RenderedRegion;
use crate::scene::{LightShape, Scene, MAX_PIXELS};
use crate::settings::RenderSettings;
use glam::Vec3;
use sha2::{Digest, Sha256};
use std::io::Write;
use std::path::Path;

/// The first line of every part file: the magic and the format version.
pub const MAGIC: &[u8] = b"raytracer-part 1\n";

/// The longest header line accepted (the header of a real part is a few hundred bytes).
pub const MAX_HEADER: usize = 64 * 1024;

/// Bytes of one pixel in a part file.
pub const PIXEL_BYTES: usize = 12;

/// The program that writes and reads parts; parts of different programs are not merged.
pub const PROGRAM: &str = concat!("raytracer ", env!("CARGO_PKG_VERSION"));

/// The header line of a part file.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PartHeader {
    /// `PROGRAM` of the writer.
    pub program: String,
    pub scene: SceneId,
    pub settings: PixelSettings,
    pub region: RegionDesc,
    /// Pixels in the file: the area of the region's rectangles.
    pub pixels: u64,
    /// SHA-256 of the pixel bytes, lowercase hex.
    pub pixels_sha256: String,
}

/// The scene a part was rendered from.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneId {
    /// The name the user gave (for messages; not compared).
    pub name: String,
    /// `scene_digest` of the compiled scene, lowercase hex.
    pub digest: String,
}

/// The settings that change pixels: the image size, samples per pixel, path depth, seed
/// and sampler. Packet width, accelerator, thread count and specialisation do not (the
/// images are the same bits), so parts made with different ones merge.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PixelSettings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub max_depth: u32,
    pub seed: u32,
    /// `SamplerKind::name`.
    pub sampler: String,
    /// The adaptive settings of an adaptive render (absent for `spp` samples a pixel).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub adaptive: Option<AdaptiveSettings>,
}

/// An adaptive render's settings, as a part file records them: the target, the sample
/// budget and the passes (those given, or those run when the run was cut short).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdaptiveSettings {
    /// The relative RMSE target (written as the shortest decimal that reads back to the
    /// same f32).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub target_error: Option<f32>,
    pub max_spp: u32,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub passes: Option<u32>,
}

/// The target is a checked finite number, never NaN.
impl Eq for AdaptiveSettings {}

impl AdaptiveSettings {
    fn describe(s: &Option<AdaptiveSettings>) -> String {
        match s {
            None => "uniform sampling".into(),
            Some(a) => format!(
                "adaptive (target {}, max spp {}, passes {})",
                a.target_error.map_or("none".into(), |e| e.to_string()),
                a.max_spp,
                a.passes.map_or("until done".into(), |p| p.to_string())
            ),
        }
    }
}

impl PixelSettings {
    /// The settings of a render of `scene` with `settings`, adaptive or not.
    pub fn new(scene: &Scene, settings: &RenderSettings, adaptive: Option<&Adaptive>) -> Self {
        Self {
            width: scene.camera.width,
            height: scene.camera.height,
            spp: scene.spp,
            max_depth: scene.max_depth,
            seed: settings.seed,
            sampler: settings.sampler.name().to_string(),
            adaptive: adaptive.map(|a| AdaptiveSettings {
                target_error: a.target_error,
                max_spp: a.max_spp,
                passes: a.passes,
            }),
        }
    }

    /// The first setting in which `self` differs from `other`: (name, self's, other's).
    pub fn difference(&self, other: &PixelSettings) -> Option<(&'static str, String, String)> {
        let size = |s: &PixelSettings| format!("{}x{}", s.width, s.height);
        let pairs = [
            ("image size", size(self), size(other)),
            ("spp", self.spp.to_string(), other.spp.to_string()),
            (
                "max depth",
                self.max_depth.to_string(),
                other.max_depth.to_string(),
            ),
            ("seed", self.seed.to_string(), other.seed.to_string()),
            ("sampler", self.sampler.clone(), other.sampler.clone()),
            (
                "sampling",
                AdaptiveSettings::describe(&self.adaptive),
                AdaptiveSettings::describe(&other.adaptive),
            ),
        ];
        pairs.into_iter().find(|(_, a, b)| a != b)
    }
}

/// Which pixels a part holds, as written in its header.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum RegionDesc {
    /// The whole frame.
    Frame,
    /// Part `index` of `count`, in tiles of `tile` pixels (`render::part_of_tile`).
    Part { index: u32, count: u32, tile: u32 },
    /// The window `[x0, x1) × [y0, y1)`.
    Crop { x0: u32, y0: u32, x1: u32, y1: u32 },
}

impl RegionDesc {
    /// The header's words for `region`.
    pub fn new(region: Region) -> Self {
        match region {
            Region::Frame => RegionDesc::Frame,
            Region::Part { index, count } => RegionDesc::Part {
                index,
                count,
                tile: TILE,
            },
            Region::Crop(r) => RegionDesc::Crop {
                x0: r.x0,
                y0: r.y0,
                x1: r.x1,
                y1: r.y1,
            },
        }
    }

    /// The region, if this program can produce it (its tile size is `TILE`).
    pub fn region(&self) -> std::result::Result<Region, String> {
        match *self {
            RegionDesc::Frame => Ok(Region::Frame),
            RegionDesc::Part { index, count, tile } => {
                if tile != TILE {
                    return Err(format!(
                        "its region is in tiles of {tile} pixels; this program's are {TILE}"
                    ));
                }
                Ok(Region::Part { index, count })
            }
            RegionDesc::Crop { x0, y0, x1, y1 } => Ok(Region::Crop(Rect::new(x0, y0, x1, y1))),
        }
    }
}

/// A checked part file: its header, its rectangles and its pixel bytes.
#[derive(Debug)]
pub struct ParsedPart<'a> {
    pub header: PartHeader,
    pub region: Region,
    pub rects: Vec<Rect>,
    /// `PIXEL_BYTES` a pixel, the rectangles' pixels one after another, row by row.
    pub payload: &'a [u8],
}

impl ParsedPart<'_> {
    /// The pixels, in the order of `rects`.
    pub fn pixels(&self) -> impl Iterator<Item = Vec3> + '_ {
        self.payload.chunks_exact(PIXEL_BYTES).map(decode_pixel)
    }
}

#[inline]
fn decode_pixel(b: &[u8]) -> Vec3 {
    let f = |i: usize| f32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    Vec3::new(f(0), f(4), f(8))
}

/// A checked header: what `parse_header` returns.
#[derive(Debug)]
pub struct Header {
    pub header: PartHeader,
    pub region: Region,
    pub rects: Vec<Rect>,
    /// Where the pixels start in the file.
    pub payload_start: usize,
}

/// Check the magic and the header line at the start of a part file's bytes (the pixels
/// may be absent: `bytes` can be the first `MAGIC.len() + MAX_HEADER + 1` bytes): the
/// JSON, the image size, the region and the pixel count. Never panics.
pub fn parse_header(bytes: &[u8]) -> std::result::Result<Header, String> {
    let Some(rest) = bytes.strip_prefix(MAGIC) else {
        let first_line = bytes.split(|&b| b == b'\n').next().unwrap_or_default();
        if let Some(version) = first_line.strip_prefix(b"raytracer-part ") {
            return Err(format!(
                "part file format {}, this program reads format 1",
                String::from_utf8_lossy(version)
            ));
        }
        return Err(
            "not a raytracer part file (it does not start with \"raytracer-part 1\")".into(),
        );
    };
    let Some(end) = rest.iter().take(MAX_HEADER).position(|&b| b == b'\n') else {
        return Err(if rest.len() < MAX_HEADER {
            "truncated: the header line has no end".into()
        } else {
            format!("the header line is longer than {MAX_HEADER} bytes")
        });
    };
    let header: PartHeader = serde_json::from_slice(&rest[..end]).map_err(|e| {
        // The message may quote the file's text (a field name).
        format!(
            "malformed header: {}",
            crate::error::one_line(&e.to_string())
        )
    })?;

    let s = &header.settings;
    if !(1..=65_536).contains(&s.width)
        || !(1..=65_536).contains(&s.height)
        || s.width as u64 * s.height as u64 > MAX_PIXELS
    {
        return Err(format!(
            "header: image size {}x{} out of range (1 to 65536 a side, at most {MAX_PIXELS} pixels)",
            s.width, s.height
        ));
    }
    if s.spp == 0 {
        return Err("header: spp is 0".into());
    }
    if let RegionDesc::Part { count, .. } = header.region {
        if count > Region::MAX_PARTS {
            return Err(format!(
                "header: {count} parts, at most {}",
                Region::MAX_PARTS
            ));
        }
    }
    let region = header.region.region().map_err(|e| format!("header: {e}"))?;
    let rects = region
        .rects(s.width, s.height)
        .map_err(|e| format!("header: {e}"))?;
    let area: u64 = rects.iter().map(Rect::pixel_count).sum();
    if header.pixels != area {
        return Err(format!(
            "header: {} pixels, but {region} of a {}x{} image has {area}",
            header.pixels, s.width, s.height
        ));
    }
    Ok(Header {
        header,
        region,
        rects,
        payload_start: MAGIC.len() + end + 1,
    })
}

/// Check a part file's bytes: `parse_header`, then the pixels' length and checksum.
/// The message says what is wrong (the caller adds the file name). Never panics.
pub fn parse_part(bytes: &[u8]) -> std::result::Result<ParsedPart<'_>, String> {
    let Header {
        header,
        region,
        rects,
        payload_start,
    } = parse_header(bytes)?;
    let payload = &bytes[payload_start..];
    let area = header.pixels;
    let expected = area * PIXEL_BYTES as u64;
    if (payload.len() as u64) < expected {
        return Err(format!(
            "truncated: {} bytes of pixels, {expected} expected ({area} pixels)",
            payload.len()
        ));
    }
    if payload.len() as u64 > expected {
        return Err(format!(
            "{} bytes after its {area} pixels",
            payload.len() as u64 - expected
        ));
    }
    let sum = hex(&Sha256::digest(payload));
    if sum != header.pixels_sha256 {
        return Err(format!(
            "corrupt: the pixels' SHA-256 is {sum}, the header says {}",
            header.pixels_sha256
        ));
    }
    Ok(ParsedPart {
        header,
        region,
        rects,
        payload,
    })
}

/// The error for a part file.
pub fn part_error(path: &Path, message: impl Into<String>) -> Error {
    Error::Part {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// A region of a frame, rendered ([`Renderer::render_part`](crate::Renderer::render_part)),
/// with what made it: the scene's digest and the settings that change pixels. Written to
/// a part file ([`Part::write`]), it is put together with the frame's other parts by
/// [`merge_parts`](crate::merge_parts), which checks that they belong together.
#[derive(Debug)]
pub struct Part {
    rendered: RenderedRegion,
    scene: SceneId,
    settings: PixelSettings,
}

impl Part {
    /// `rendered` from the scene named `name` with digest `digest` (`scene_digest`).
    pub(crate) fn new(
        rendered: RenderedRegion,
        name: &str,
        digest: &str,
        settings: PixelSettings,
    ) -> Self {
        Self {
            rendered,
            scene: SceneId {
                name: name.to_string(),
                digest: digest.to_string(),
            },
            settings,
        }
    }

    /// Which pixels of the frame the part holds.
    pub fn region(&self) -> Region {
        self.rendered.region
    }

    /// The region's rectangles ([`Region::rects`]), in the order of [`Part::pixels`].
    pub fn rects(&self) -> &[Rect] {
        &self.rendered.rects
    }

    /// Linear RGB: the rectangles' pixels one after another, each row by row, the bits
    /// of the same pixels of the whole frame.
    pub fn pixels(&self) -> &[Vec3] {
        &self.rendered.pixels
    }

    /// Rays by kind and the traversal work they took.
    pub fn counts(&self) -> RayCounts {
        self.rendered.counts
    }

    /// Pixels with a NaN or infinite channel.
    pub fn non_finite_count(&self) -> usize {
        self.pixels().iter().filter(|p| !p.is_finite()).count()
    }

    /// What an adaptive render of the part did (`None` for `spp` samples a pixel).
    pub fn adaptive(&self) -> Option<&crate::adaptive::Outcome> {
        self.rendered.adaptive.as_ref()
    }

    /// Write the part file to `path` (any name; `.part` by convention): a temporary file
    /// beside it renamed into place, so a failed or killed run leaves no part behind.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<()> {
        let mut files = OutputSet::default();
        self.add_to(&mut files, path.as_ref())?;
        files.commit()
    }

    /// Write the part file to a temporary file that `files` renames to `path` when it is
    /// committed, with the run's other outputs.
    pub fn add_to(&self, files: &mut OutputSet, path: &Path) -> Result<()> {
        let pixels = &self.rendered.pixels;
        let mut sha = Sha256::new();
        for_each_payload_chunk(pixels, |bytes| {
            sha.update(bytes);
            Ok(())
        })
        .map_err(|e| part_error(path, e.to_string()))?;
        let header = PartHeader {
            program: PROGRAM.to_string(),
            scene: self.scene.clone(),
            settings: self.settings.clone(),
            region: RegionDesc::new(self.rendered.region),
            pixels: pixels.len() as u64,
            pixels_sha256: hex(&sha.finalize()),
        };
        let line = serde_json::to_string(&header).map_err(|e| part_error(path, e.to_string()))?;
        files.add(path, |out| {
            out.write_all(MAGIC)?;
            out.write_all(line.as_bytes())?;
            out.write_all(b"\n")?;
            for_each_payload_chunk(pixels, |bytes| out.write_all(bytes))
        })
    }
}

/// The pixels as part-file bytes, a few thousand pixels at a time (no second copy of
/// the pixels in memory).
fn for_each_payload_chunk(
    pixels: &[Vec3],
    mut f: impl FnMut(&[u8]) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let mut buf = Vec::with_capacity(4096 * PIXEL_BYTES);
    for chunk in pixels.chunks(4096) {
        buf.clear();
        for p in chunk {
            for c in p.to_array() {
                buf.extend_from_slice(&c.to_le_bytes());
            }
        }
        f(&buf)?;
    }
    Ok(())
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// SHA-256 of everything in a compiled scene that reaches a pixel: camera, spp, depth,
/// background and ambient light, every primitive (the meshes' triangles included),
/// their ids and objects, the materials, the objects' materials and the lights. Each
/// pool is hashed in the order of its primitives' ids (the order `compile` makes), so
/// the digest is the same before and after `Accel::build` reorders the pools, for either
/// accelerator. Two scene files that compile to the same scene (comments, key order, a
/// built-in scene and its file) have the same digest.
pub fn scene_digest(scene: &Scene) -> String {
    // Every field is named, so a new one is a compile error here until it is hashed or
    // said to be derived.
    let Scene {
        name: _,
        description: _,
        camera,
        spp,
        max_depth,
        background,
        ambient,
        spheres,
        quads,
        triangles,
        materials,
        object_material,
        lights,
        features: _,             // derived from the primitives and materials
        bounds: _,               // derived from the primitives
        degenerate_triangles: _, // left out of the pools
        warnings: _,             // messages, not pixels
        prototypes,
        instances,
        object_instance: _, // derived from the instances
    } = scene;
    let mut h = Hasher::default();
    // Small values as their Debug text (exact: floats print as the shortest text that
    // reads back to the same bits), large pools as their bits.
    h.text("camera", &format!("{camera:?}"));
    h.u32s("spp, max_depth", 2, [*spp, *max_depth]);
    h.vec3s("background, ambient", 2, [*background, *ambient]);

    let ([cx, cy, cz, radius], id, object) = spheres.columns();
    let order = id_order(id);
    for (label, v) in [
        ("sphere cx", cx),
        ("cy", cy),
        ("cz", cz),
        ("radius", radius),
    ] {
        h.f32s(label, v.len(), in_order(v, &order));
    }
    h.u32s("sphere id", id.len(), in_order(id, &order));
    h.u32s("sphere object", object.len(), in_order(object, &order));

    let crate::geometry::QuadPool {
        qx,
        qy,
        qz,
        ux,
        uy,
        uz,
        vx,
        vy,
        vz,
        wx,
        wy,
        wz,
        vertices,
        // The same vertices as `vertices`, by axis.
        rows: _,
        plane,
        id,
        object,
    } = quads;
    let order = id_order(id);
    for (label, v) in [
        ("quad qx", qx),
        ("qy", qy),
        ("qz", qz),
        ("ux", ux),
        ("uy", uy),
        ("uz", uz),
        ("vx", vx),
        ("vy", vy),
        ("vz", vz),
        ("wx", wx),
        ("wy", wy),
        ("wz", wz),
    ] {
        h.f32s(label, v.len(), in_order(v, &order));
    }
    h.f32s(
        "quad vertices",
        vertices.len() * 12,
        in_order(vertices, &order).flat_map(|q| q.into_iter().flatten()),
    );
    h.f32s(
        "quad plane",
        plane.len() * 4,
        in_order(plane, &order).flatten(),
    );
    h.u32s("quad id", id.len(), in_order(id, &order));
    h.u32s("quad object", object.len(), in_order(object, &order));

    let crate::geometry::TrianglePool {
        a,
        b,
        c,
        id,
        object,
        normals,
    } = triangles;
    let order = id_order(id);
    for (label, axes) in [("triangle a", a), ("b", b), ("c", c)] {
        for v in axes {
            h.f32s(label, v.len(), in_order(v, &order));
        }
    }
    // Only where a mesh is smooth: the digests of other scenes stay as they were.
    if !normals.is_empty() {
        h.vec3s(
            "triangle normals",
            normals.len() * 3,
            in_order(normals, &order).flatten(),
        );
    }
    h.u32s("triangle id", id.len(), in_order(id, &order));
    h.u32s("triangle object", object.len(), in_order(object, &order));

    h.text("materials", &format!("{materials:?}"));
    h.u32s(
        "object materials",
        object_material.len(),
        object_material.iter().copied(),
    );
    for light in lights {
        let crate::scene::Light {
            object,
            radiance,
            shape,
            first_id,
        } = light;
        h.u32s("light", 2, [*object, *first_id]);
        h.vec3s("radiance", 1, [*radiance]);
        match shape {
            LightShape::Point { center, radius } => {
                h.vec3s("point", 1, [*center]);
                h.f32s("radius", 1, [*radius]);
            }
            LightShape::Quads(qs) => h.text("quads", &format!("{qs:?}")),
            LightShape::Triangles(ts) => {
                h.vec3s("triangles", ts.len() * 3, ts.iter().flatten().copied())
            }
        }
    }
    // Only where there are instances: the digests of other scenes stay as they were.
    for p in prototypes {
        h.text("prototype", &p.name);
        h.text("its scene", &scene_digest(&p.scene));
        h.u32s(
            "its materials",
            p.group_materials.len(),
            p.group_materials.iter().copied(),
        );
    }
    for i in instances {
        h.text("instance", &format!("{i:?}"));
    }
    hex(&h.sha.finalize())
}

/// A pool's indices in the order of its ids, or `None` when the pool is in that order.
fn id_order(id: &[u32]) -> Option<Vec<u32>> {
    if id.is_sorted() {
        return None;
    }
    let mut order: Vec<u32> = (0..id.len() as u32).collect();
    order.sort_unstable_by_key(|&i| id[i as usize]);
    Some(order)
}

/// The items of a pool's column in `order` (`id_order`).
fn in_order<'a, T: Copy>(
    v: &'a [T],
    order: &'a Option<Vec<u32>>,
) -> impl ExactSizeIterator<Item = T> + 'a {
    (0..v.len()).map(move |k| v[order.as_ref().map_or(k, |o| o[k] as usize)])
}

/// SHA-256 over labelled, length-prefixed fields (so no two scenes' fields run together
/// into the same bytes).
#[derive(Default)]
struct Hasher {
    sha: Sha256,
}

impl Hasher {
    fn field(&mut self, label: &str, len: usize) {
        self.sha.update((label.len() as u64).to_le_bytes());
        self.sha.update(label.as_bytes());
        self.sha.update((len as u64).to_le_bytes());
    }

    fn text(&mut self, label: &str, text: &str) {
        self.field(label, text.len());
        self.sha.update(text.as_bytes());
    }

    /// `len` floats (`words`).
    fn f32s(&mut self, label: &str, len: usize, v: impl IntoIterator<Item = f32>) {
        self.words(label, len, v.into_iter().map(f32::to_bits));
    }

    fn u32s(&mut self, label: &str, len: usize, v: impl IntoIterator<Item = u32>) {
        self.words(label, len, v);
    }

    /// `len` vectors.
    fn vec3s(&mut self, label: &str, len: usize, v: impl IntoIterator<Item = Vec3>) {
        self.f32s(label, len * 3, v.into_iter().flat_map(|p| p.to_array()));
    }

    /// A field of `len` words: its label and length, then the words.
    fn words(&mut self, label: &str, len: usize, words: impl IntoIterator<Item = u32>) {
        self.field(label, len);
        let mut buf = [0u8; 4096];
        let (mut n, mut count) = (0, 0);
        for w in words {
            buf[n..n + 4].copy_from_slice(&w.to_le_bytes());
            n += 4;
            count += 1;
            if n == buf.len() {
                self.sha.update(buf);
                n = 0;
            }
        }
        self.sha.update(&buf[..n]);
        debug_assert_eq!(count, len, "{label}: the length given is not the words'");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Overrides;

    fn scene(name: &str, width: u32) -> Scene {
        let o = Overrides {
            width: Some(width),
            spp: Some(1),
            max_depth: None,
        };
        Scene::load(name, o).unwrap()
    }

    #[test]
    fn digest_sees_every_kind_of_change() {
        let base = scene("cornell", 20);
        let d = scene_digest(&base);
        assert_eq!(d.len(), 64);
        assert_eq!(d, scene_digest(&base.clone()));
        // The name and description are not pixels.
        let mut renamed = base.clone();
        renamed.name = "other".into();
        renamed.description = "other".into();
        assert_eq!(scene_digest(&renamed), d);

        let mut changes: Vec<(&str, Scene)> = Vec::new();
        let mut s = base.clone();
        s.camera.origin.x = f32::from_bits(s.camera.origin.x.to_bits() + 1);
        changes.push(("camera origin by one ulp", s));
        let mut s = base.clone();
        s.spp += 1;
        changes.push(("spp", s));
        let mut s = base.clone();
        s.max_depth += 1;
        changes.push(("max depth", s));
        let mut s = base.clone();
        s.ambient.y += 0.5;
        changes.push(("ambient", s));
        let mut s = base.clone();
        s.quads.qx[3] = -s.quads.qx[3] - 1.0;
        changes.push(("a quad corner", s));
        let mut s = base.clone();
        s.quads.object.swap(0, 1);
        changes.push(("quad objects", s));
        let mut s = base.clone();
        s.spheres
            .set(0, s.spheres.center(0), 2.0 * s.spheres.radius(0));
        changes.push(("a sphere radius", s));
        let mut s = base.clone();
        s.materials.swap(0, 1);
        changes.push(("materials", s));
        let mut s = base.clone();
        s.lights[0].radiance.x += 1.0;
        changes.push(("light radiance", s));
        for (what, s) in &changes {
            assert_ne!(scene_digest(s), d, "{what}");
        }

        let bunny = scene("bunny", 20);
        let mut s = bunny.clone();
        let v = &mut s.triangles.b[1][2000];
        *v = f32::from_bits(v.to_bits() ^ 1);
        assert_ne!(
            scene_digest(&s),
            scene_digest(&bunny),
            "one mesh vertex bit"
        );
        // −0 and +0 are different bits, so different scenes.
        let mut s = bunny.clone();
        s.background = Vec3::new(0.0, 0.0, 0.0);
        let mut t = bunny.clone();
        t.background = Vec3::new(-0.0, 0.0, 0.0);
        assert_ne!(scene_digest(&s), scene_digest(&t), "signed zero");
    }

    #[test]
    fn digest_is_the_same_after_the_build_reorders_the_pools() {
        use crate::accel::{Accel, AccelKind};
        let mut reordered = 0;
        for name in crate::scene::builtin::names() {
            let compiled = scene(name, 20);
            let d = scene_digest(&compiled);
            for kind in [AccelKind::Bvh, AccelKind::Linear] {
                let mut built = compiled.clone();
                Accel::build(&mut built, kind);
                assert_eq!(scene_digest(&built), d, "{name} {kind:?}");
                let ids = [built.spheres.ids(), &built.quads.id, &built.triangles.id];
                reordered += ids.iter().filter(|id| !id.is_sorted()).count();
            }
        }
        // The BVH does reorder pools (bunny's triangles, the box scenes' quads).
        assert!(
            reordered >= 2,
            "no pool was reordered: the test checks nothing"
        );

        // Which primitive has which id matters: two triangles swapped, ids kept.
        let bunny = scene("bunny", 20);
        let mut s = bunny.clone();
        for axis in 0..3 {
            s.triangles.a[axis].swap(10, 20);
            s.triangles.b[axis].swap(10, 20);
            s.triangles.c[axis].swap(10, 20);
        }
        assert_ne!(scene_digest(&s), scene_digest(&bunny));
    }

    #[test]
    fn digest_of_a_file_equals_its_builtin_scene() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("spheres.toml");
        let text = crate::scene::builtin::scene("spheres").unwrap();
        std::fs::write(&path, format!("# a comment\n{text}")).unwrap();
        let from_file = Scene::load(path.to_str().unwrap(), Overrides::default()).unwrap();
        let builtin = Scene::load("spheres", Overrides::default()).unwrap();
        assert_eq!(scene_digest(&from_file), scene_digest(&builtin));
    }
}
