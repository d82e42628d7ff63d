//! The memory budget: what a render will need, estimated before the memory is taken, and
//! checked against what the machine has free (`MemAvailable` in `/proc/meminfo`) or a
//! cap the user gives. A refused estimate is an error that names it, instead of an abort
//! when an allocation fails halfway (a 65536x4096 image under a 2 GiB limit, or
//! `subdivide = 6` on a million-triangle mesh: 4 billion triangles).
//!
//! Bytes a pixel and a primitive, at the peak of a run (measured with `/usr/bin/time
//! -f %M`, the maximum resident size, on scenes that differ in one count):
//!
//! | what | bytes | where |
//! |---|---|---|
//! | pixel, while rendering | 12 | the film, linear f32 RGB; tiles are copied into it a batch of 4096 at a time (12 MB); 12.1 measured on a 16384x16384 render (below) |
//! | pixel, while writing | 12 | the film: PNG and PPM are encoded a row at a time, EXR a 64x64 tile at a time |
//! | sphere, quad, triangle in a pool | 24, 120, 44 | `SpherePool`, `QuadPool`, `TrianglePool` |
//! | primitive in the BVH | 112 | the build's references (32) and binary nodes (about 17), the 4-wide (about 17) and 8-wide (about 23) nodes, the reordering (8), and slack: a triangle in the tree costs 155 measured (bunny subdivided 3 and 4 times: 317 952 and 1 271 808 triangles, 73.3 and 217.8 MB) against 156 estimated |
//! | triangle of a mesh light | 36 | the light's copy of its triangles |
//! | byte of an OBJ file | 3 | its text, tobj's arrays and the triangles read from it, while it loads |
//!
//! The largest image (2^28 pixels) of a one-sphere scene at 1 spp peaks at 3.03 GiB,
//! 12.1 bytes a pixel, written as PNG or EXR alike:
//!
//! ```text
//! /usr/bin/time -v raytracer tiny.toml --width 16384 -o big.exr   # "Maximum resident set size"
//! ```
//!
//! where `tiny.toml` is a square camera (`aspect_ratio = 1.0`, `samples_per_pixel = 1`)
//! and one sphere.
//!
//! The budget is written over byte counts alone: what a scene or a merge will need is
//! counted where they are made (`Scene::memory_estimate`, `merge_parts_within`).

/// Bytes a pixel while rendering: the film.
pub const RENDER_BYTES_PER_PIXEL: u64 = 12;
/// Bytes a pixel while writing: the film (every format is encoded from it a few rows or
/// tiles at a time).
pub const WRITE_BYTES_PER_PIXEL: u64 = 12;
pub const SPHERE_BYTES: u64 = 24;
pub const QUAD_BYTES: u64 = 120;
pub const TRIANGLE_BYTES: u64 = 44;
/// A primitive in the BVH's tree (any kind), on top of its pool.
pub const BVH_BYTES_PER_PRIMITIVE: u64 = 112;
/// A triangle of a mesh used as a light (the light's copy).
pub const LIGHT_TRIANGLE_BYTES: u64 = 36;
/// A triangle's shading normals (three `Vec3`), on a smooth mesh.
pub const TRIANGLE_NORMAL_BYTES: u64 = 36;
/// A byte of an OBJ file while it loads.
pub const OBJ_BYTES_PER_FILE_BYTE: u64 = 3;
/// The program, its threads' stacks and the allocator's slack: the resident size of a
/// run without geometry at 8x8 pixels is 11 MB.
pub const BASE_BYTES: u64 = 32 << 20;

/// What a render will need, in bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryEstimate {
    /// The image: the larger of rendering and writing (`pixels` times their bytes a pixel).
    pub image: u64,
    /// The primitive pools and light copies.
    pub geometry: u64,
    /// Both trees of the BVH and their build.
    pub bvh: u64,
    /// A file being loaded (an OBJ's text and what tobj makes of it).
    pub loading: u64,
}

impl MemoryEstimate {
    /// For an image of `pixels` pixels, rendered and written.
    pub fn image(pixels: u64) -> Self {
        MemoryEstimate {
            image: pixels.saturating_mul(RENDER_BYTES_PER_PIXEL.max(WRITE_BYTES_PER_PIXEL)),
            ..Default::default()
        }
    }

    /// Add primitives (pools and, as `in_bvh` says, the tree).
    pub fn add_primitives(&mut self, spheres: u64, quads: u64, triangles: u64, in_bvh: bool) {
        let pools = spheres * SPHERE_BYTES + quads * QUAD_BYTES;
        self.geometry = self
            .geometry
            .saturating_add(pools)
            .saturating_add(triangles.saturating_mul(TRIANGLE_BYTES));
        if in_bvh {
            let n = spheres.saturating_add(quads).saturating_add(triangles);
            self.bvh = self
                .bvh
                .saturating_add(n.saturating_mul(BVH_BYTES_PER_PRIMITIVE));
        }
    }

    /// Shading normals of triangles (three unit vectors each, `normals = "smooth"`).
    pub fn add_triangle_normals(&mut self, triangles: u64) {
        self.geometry = self
            .geometry
            .saturating_add(triangles.saturating_mul(TRIANGLE_NORMAL_BYTES));
    }

    pub fn add_light_triangles(&mut self, triangles: u64) {
        self.geometry = self
            .geometry
            .saturating_add(triangles.saturating_mul(LIGHT_TRIANGLE_BYTES));
    }

    pub fn total(&self) -> u64 {
        BASE_BYTES
            .saturating_add(self.image)
            .saturating_add(self.geometry)
            .saturating_add(self.bvh)
            .saturating_add(self.loading)
    }
}

/// What sets a run's memory limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Limit {
    /// The machine's free memory (`MemAvailable` in `/proc/meminfo`).
    Available,
    /// The process's address-space limit (`ulimit -v`, `prlimit --as`), less what the
    /// process already maps.
    AddressSpace,
    /// A cap the caller gave (the command line's `--max-memory`).
    Cap,
}

impl Limit {
    /// The end of a refusal's message: "the machine has 3.5 GiB available".
    pub fn describe(self, bytes: u64) -> String {
        match self {
            Limit::Available => format!("the machine has {} available", human(bytes)),
            Limit::AddressSpace => format!(
                "the address-space limit (ulimit -v) leaves {}",
                human(bytes)
            ),
            Limit::Cap => format!("the limit is {}", human(bytes)),
        }
    }
}

/// The memory a run may use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Budget {
    /// No limit (the system does not say, or the caller does not check).
    Unlimited,
    /// At most `bytes` in all, set by `by`.
    Limited { bytes: u64, by: Limit },
}

impl Budget {
    /// A cap of `bytes` given by the caller.
    pub fn cap(bytes: u64) -> Budget {
        Budget::Limited {
            bytes,
            by: Limit::Cap,
        }
    }

    /// The smaller of the machine's free memory and what the process's address-space
    /// limit leaves (counting the program as [`BASE_BYTES`], as estimates do), or
    /// `Unlimited` where the system says neither.
    pub fn machine() -> Budget {
        let available = std::fs::read_to_string("/proc/meminfo")
            .ok()
            .and_then(|text| mem_available(&text))
            .map(|bytes| (bytes, Limit::Available));
        let address_space = std::fs::read_to_string("/proc/self/limits")
            .ok()
            .and_then(|text| address_space_limit(&text))
            .map(|limit| {
                let mapped = std::fs::read_to_string("/proc/self/status")
                    .ok()
                    .and_then(|text| vm_size(&text))
                    .unwrap_or(0);
                let left = limit.saturating_sub(mapped).saturating_add(BASE_BYTES);
                (left, Limit::AddressSpace)
            });
        match available
            .into_iter()
            .chain(address_space)
            .min_by_key(|&(bytes, _)| bytes)
        {
            Some((bytes, by)) => Budget::Limited { bytes, by },
            None => Budget::Unlimited,
        }
    }

    pub fn limit(&self) -> Option<u64> {
        match *self {
            Budget::Unlimited => None,
            Budget::Limited { bytes, .. } => Some(bytes),
        }
    }

    /// A [`Refusal`] if `estimate` exceeds the budget (the library's `Error::OutOfMemory`
    /// through `?`); `what` says what was being prepared ("a 65536x4096 image", "mesh
    /// bunny.obj subdivided 6 times").
    pub fn check(&self, estimate: &MemoryEstimate, what: &str) -> Result<(), Refusal> {
        match *self {
            Budget::Limited { bytes, by } if estimate.total() > bytes => Err(Refusal {
                what: what.to_string(),
                estimate: *estimate,
                limit: bytes,
                limited_by: by,
            }),
            _ => Ok(()),
        }
    }
}

/// An estimate the budget refused, with what it was for and the limit it exceeds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Refusal {
    /// What was being prepared.
    pub what: String,
    /// The bytes it would take, by part.
    pub estimate: MemoryEstimate,
    /// The bytes allowed.
    pub limit: u64,
    /// What sets the limit.
    pub limited_by: Limit,
}

/// The soft `Max address space` of `/proc/self/limits` text, in bytes (`None`:
/// unlimited).
fn address_space_limit(limits: &str) -> Option<u64> {
    let line = limits
        .lines()
        .find(|l| l.starts_with("Max address space"))?;
    line["Max address space".len()..]
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// `VmSize` of `/proc/self/status` text (the bytes the process maps), in bytes.
fn vm_size(status: &str) -> Option<u64> {
    let line = status.lines().find(|l| l.starts_with("VmSize:"))?;
    let mut words = line.split_whitespace().skip(1);
    let kib: u64 = words.next()?.parse().ok()?;
    (words.next() == Some("kB")).then_some(kib * 1024)
}

/// `MemAvailable` of `/proc/meminfo` text, in bytes.
fn mem_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let mut words = line.split_whitespace().skip(1);
    let kib: u64 = words.next()?.parse().ok()?;
    (words.next() == Some("kB")).then_some(kib * 1024)
}

/// Bytes in a short human form: 1.5 GiB, 300 MiB, 12 KiB.
pub fn human(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["bytes", "KiB", "MiB", "GiB", "TiB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} bytes")
    } else {
        format!("{value:.1} {}", UNITS[unit])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_mem_available() {
        let text = "MemTotal:       24683584 kB\nMemFree:         9100108 kB\nMemAvailable:   22532416 kB\n";
        assert_eq!(mem_available(text), Some(22532416 * 1024));
        assert_eq!(mem_available("MemTotal: 5 kB\n"), None);
        assert_eq!(mem_available("MemAvailable: x kB\n"), None);
    }

    #[test]
    fn reads_the_address_space_limit_and_size() {
        let line = |soft: &str| {
            format!("Max stack size            8388608              unlimited            bytes\nMax address space         {soft:<20} unlimited            bytes\n")
        };
        assert_eq!(address_space_limit(&line("unlimited")), None);
        assert_eq!(address_space_limit(&line("3758096384")), Some(3758096384));
        assert_eq!(
            vm_size("Name:\tx\nVmPeak:\t  9000 kB\nVmSize:\t  8000 kB\n"),
            Some(8000 * 1024)
        );
    }

    #[test]
    fn estimates_add_up_and_saturate() {
        let mut e = MemoryEstimate::image(1000);
        assert_eq!(e.image, 1000 * 12);
        e.add_primitives(1, 2, 3, true);
        assert_eq!(e.geometry, 24 + 2 * 120 + 3 * 44);
        assert_eq!(e.bvh, 6 * 112);
        e.add_light_triangles(3);
        assert_eq!(e.geometry, 24 + 2 * 120 + 3 * 44 + 3 * 36);
        assert_eq!(e.total(), BASE_BYTES + e.image + e.geometry + e.bvh);
        e.add_primitives(0, 0, u64::MAX, true);
        assert_eq!(e.total(), u64::MAX);
    }

    #[test]
    fn the_check_names_the_estimate() {
        let e = MemoryEstimate::image(65536 * 4096);
        assert!(Budget::Unlimited.check(&e, "x").is_ok());
        assert!(Budget::cap(e.total()).check(&e, "x").is_ok());
        let err = Budget::cap(2 << 30)
            .check(&e, "a 65536x4096 image")
            .unwrap_err();
        let message = crate::Error::from(err).to_string();
        assert!(message.contains("a 65536x4096 image"), "{message}");
        assert!(message.contains("3.0 GiB"), "{message}");
        assert!(message.contains("the limit is 2.0 GiB"), "{message}");
        assert_eq!(human(1536 << 20), "1.5 GiB");
        assert_eq!(human(12), "12 bytes");
    }
}
