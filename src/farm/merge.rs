//! Merging part files (`part`) into a frame: every part must come from the same program,
//! scene and pixel settings, and together they must hold every pixel of the frame
//! exactly once. The frame then has the bits of a one-process render.
//!
//! Two passes: the headers first (program, settings, scene, overlaps, missing pixels:
//! checked from the first bytes of each file, before the frame is allocated), then each
//! file whole (its pixels' length and checksum) into the frame, one at a time, so the
//! memory is the frame, one bit a pixel and one part.

use crate::budget::{Budget, MemoryEstimate};
use crate::error::{Error, Result};
use crate::farm::part::{self, PartHeader, MAGIC, MAX_HEADER};
use crate::farm::region::{Rect, Region};
use crate::film::Film;
use crate::scene::{input, MAX_PIXELS};
use std::io::Read;
use std::path::{Path, PathBuf};

/// A frame put together from part files ([`merge_parts`]).
#[derive(Debug)]
pub struct Merged {
    /// The frame: the bits of a one-process render with the parts' settings.
    pub film: Film,
    /// The name of the scene the parts were rendered from.
    pub scene: String,
    /// Their samples per pixel.
    pub spp: u32,
}

/// Read, check and put together the part files at `paths` ([`Part::write`]) into the
/// frame. They must come from one program, scene (the same digest) and pixel settings,
/// and hold every pixel of the frame exactly once; otherwise the error names the part
/// file and what is wrong: a missing region ("missing region 2/4"), an overlap, a part
/// from another scene, setting or program version, a truncated or corrupt file.
///
/// Every header is checked before the frame is allocated; then the parts are read one at
/// a time, so the memory is the frame, one bit a pixel and one part. That memory must fit
/// the machine's free memory ([`Budget::machine`]); [`merge_parts_within`] takes another
/// budget.
///
/// [`Part::write`]: crate::Part::write
pub fn merge_parts<P: AsRef<Path>>(paths: &[P]) -> Result<Merged> {
    merge_parts_within(paths, Budget::machine())
}

/// The largest part file: a header and 12 bytes a pixel of the largest frame.
const MAX_PART_BYTES: u64 = (MAGIC.len() + MAX_HEADER + 1) as u64 + 12 * MAX_PIXELS;

/// [`merge_parts`] within `budget`: a merge estimated to need more memory (the frame,
/// the coverage bits and the largest part file) is refused with
/// [`Error::OutOfMemory`] before the frame is allocated.
pub fn merge_parts_within<P: AsRef<Path>>(paths: &[P], budget: Budget) -> Result<Merged> {
    let paths: Vec<PathBuf> = paths.iter().map(|p| p.as_ref().to_path_buf()).collect();
    let paths = &paths[..];
    let Some(first_path) = paths.first() else {
        return Err(Error::Merge("no part files given".into()));
    };
    let io_error = |path: &Path, source| Error::Io {
        path: path.display().to_string(),
        source,
    };

    // The headers.
    let mut headers: Vec<part::Header> = Vec::with_capacity(paths.len());
    let mut coverage: Option<Coverage> = None;
    let mut largest = 0;
    for path in paths {
        // A regular file, checked before it is opened (opening a FIFO blocks).
        let size =
            input::check_file(path, MAX_PART_BYTES, "part file").map_err(|e| io_error(path, e))?;
        largest = largest.max(size);
        let mut start = Vec::new();
        std::fs::File::open(path)
            .and_then(|f| {
                f.take((MAGIC.len() + MAX_HEADER + 1) as u64)
                    .read_to_end(&mut start)
            })
            .map_err(|e| io_error(path, e))?;
        let h = part::parse_header(&start).map_err(|m| part::part_error(path, m))?;
        if let Some(first) = headers.first() {
            same_source(path, &h.header, first_path, &first.header)?;
        }
        let s = &h.header.settings;
        let coverage = coverage.get_or_insert_with(|| Coverage::new(s.width, s.height));
        for rect in &h.rects {
            if let Some((x, y)) = coverage.first_covered(rect) {
                return Err(overlap(paths, &headers, path, &h, x, y));
            }
            coverage.cover(rect);
        }
        headers.push(h);
    }
    let Some(coverage) = coverage else {
        return Err(Error::Merge("no part files given".into()));
    };
    if let Some(missing) = coverage.missing() {
        let regions: Vec<Region> = headers.iter().map(|h| h.region).collect();
        return Err(Error::Merge(missing_message(&regions, &missing)));
    }

    // The pixels.
    let first = &headers[0].header;
    let (width, height) = (first.settings.width, first.settings.height);
    let pixels = width as u64 * height as u64;
    let estimate = MemoryEstimate {
        image: pixels * 12 + pixels.div_ceil(8),
        loading: largest,
        ..Default::default()
    };
    budget.check(
        &estimate,
        &format!(
            "merging {} parts into a {width}x{height} frame",
            paths.len()
        ),
    )?;
    let mut film = Film::new(width, height)?;
    for (path, h) in paths.iter().zip(&headers) {
        let mut bytes = Vec::new();
        input::check_file(path, MAX_PART_BYTES, "part file")
            .and_then(|_| std::fs::File::open(path))
            .and_then(|f| f.take(MAX_PART_BYTES + 1).read_to_end(&mut bytes))
            .map_err(|e| io_error(path, e))?;
        let part = part::parse_part(&bytes).map_err(|m| part::part_error(path, m))?;
        if part.header != h.header {
            return Err(part::part_error(path, "changed while it was being merged"));
        }
        let mut pixels = part.pixels();
        for rect in &part.rects {
            for y in rect.y0..rect.y1 {
                let start = (y * width + rect.x0) as usize;
                let row = &mut film.pixels[start..start + rect.width() as usize];
                for (dst, src) in row.iter_mut().zip(pixels.by_ref()) {
                    *dst = src;
                }
            }
        }
    }
    let first = headers.swap_remove(0).header;
    Ok(Merged {
        film,
        scene: first.scene.name,
        spp: first.settings.spp,
    })
}

/// `path`'s part must come from the same program, settings and scene as the first.
fn same_source(path: &Path, h: &PartHeader, first_path: &Path, first: &PartHeader) -> Result<()> {
    let first_name = first_path.display();
    let short = |digest: &str| digest.chars().take(16).collect::<String>();
    let message = if h.program != first.program {
        format!(
            "made by {}, {first_name} by {}: parts must come from one program",
            h.program, first.program
        )
    } else if let Some((what, this, other)) = h.settings.difference(&first.settings) {
        format!("rendered with {what} {this}, {first_name} with {what} {other}")
    } else if h.scene.digest != first.scene.digest {
        format!(
            "rendered from another scene than {first_name} ({} with digest {}, against {} with {})",
            h.scene.name,
            short(&h.scene.digest),
            first.scene.name,
            short(&first.scene.digest),
        )
    } else {
        return Ok(());
    };
    Err(part::part_error(path, message))
}

/// The error for `path`'s part, whose pixel (x, y) an earlier part holds too.
fn overlap(
    paths: &[PathBuf],
    earlier: &[part::Header],
    path: &Path,
    h: &part::Header,
    x: u32,
    y: u32,
) -> Error {
    let holds = |e: &part::Header| e.rects.iter().any(|r| r.contains(x, y));
    let other = match paths.iter().zip(earlier).find(|(_, e)| holds(e)) {
        Some((p, e)) if e.region == h.region => {
            format!(
                "{} ({}: the same region given twice)",
                p.display(),
                e.region
            )
        }
        Some((p, e)) => format!("{} ({})", p.display(), e.region),
        None => "another part".into(),
    };
    part::part_error(
        path,
        format!("{} overlaps {other}: both hold pixel ({x}, {y})", h.region),
    )
}

/// Which pixels no part held.
struct Missing {
    count: u64,
    first: (u32, u32),
    bounds: Rect,
}

/// "missing region 2/4" when the parts are parts of one split, else the missing pixels.
fn missing_message(regions: &[Region], missing: &Missing) -> String {
    let counts: Vec<u32> = regions
        .iter()
        .filter_map(|r| match r {
            Region::Part { count, .. } => Some(*count),
            _ => None,
        })
        .collect();
    if counts.len() == regions.len() && counts.iter().all(|&c| c == counts[0]) {
        let count = counts[0];
        let absent: Vec<u32> = (0..count)
            .filter(|&index| !regions.contains(&Region::Part { index, count }))
            .collect();
        if !absent.is_empty() {
            const SHOWN: usize = 16;
            let mut list: Vec<String> = absent
                .iter()
                .take(SHOWN)
                .map(|i| format!("{i}/{count}"))
                .collect();
            if absent.len() > SHOWN {
                list.push(format!("and {} more", absent.len() - SHOWN));
            }
            let (noun, pronoun) = if absent.len() == 1 {
                ("region", "it")
            } else {
                ("regions", "them")
            };
            return format!(
                "missing {noun} {}: {} part files given, none holds {pronoun} ({} pixels)",
                list.join(", "),
                regions.len(),
                missing.count
            );
        }
    }
    format!(
        "{} pixels are in none of the {} part files given: the first is ({}, {}), all lie within {}",
        missing.count,
        regions.len(),
        missing.first.0,
        missing.first.1,
        missing.bounds
    )
}

/// One bit a pixel of the frame: held by a part already.
struct Coverage {
    width: u32,
    height: u32,
    bits: Vec<u64>,
}

impl Coverage {
    fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self {
            width,
            height,
            bits: vec![0; n.div_ceil(64)],
        }
    }

    /// The rows of `r`: (y, first bit, end bit).
    fn rows(&self, r: Rect) -> impl Iterator<Item = (u32, usize, usize)> {
        let width = self.width as usize;
        (r.y0..r.y1).map(move |y| {
            let start = y as usize * width + r.x0 as usize;
            (y, start, start + r.width() as usize)
        })
    }

    fn is_set(&self, i: usize) -> bool {
        self.bits[i / 64] >> (i % 64) & 1 != 0
    }

    /// The first pixel of `r` already covered.
    fn first_covered(&self, r: &Rect) -> Option<(u32, u32)> {
        for (y, start, end) in self.rows(*r) {
            if let Some(i) = (start..end).find(|&i| self.is_set(i)) {
                return Some(((i - y as usize * self.width as usize) as u32, y));
            }
        }
        None
    }

    fn cover(&mut self, r: &Rect) {
        for (_, start, end) in self.rows(*r) {
            for i in start..end {
                self.bits[i / 64] |= 1 << (i % 64);
            }
        }
    }

    fn missing(&self) -> Option<Missing> {
        let width = self.width as usize;
        let n = width * self.height as usize;
        let mut count = 0u64;
        let mut first = None;
        let (mut x0, mut y0, mut x1, mut y1) = (u32::MAX, u32::MAX, 0, 0);
        for (w, &word) in self.bits.iter().enumerate() {
            if word == u64::MAX {
                continue;
            }
            for i in w * 64..(w * 64 + 64).min(n) {
                if !self.is_set(i) {
                    let (x, y) = ((i % width) as u32, (i / width) as u32);
                    count += 1;
                    first.get_or_insert((x, y));
                    (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x + 1), y1.max(y + 1));
                }
            }
        }
        first.map(|first| Missing {
            count,
            first,
            bounds: Rect::new(x0, y0, x1, y1),
        })
    }
}
