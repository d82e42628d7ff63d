//! Regions of a frame: the whole frame, a crop window, or part I of N, and the pixel
//! rectangles each one covers. A pixel's value does not depend on the region it is
//! rendered in, so regions rendered anywhere put together give the frame's bits.

use crate::error::{Error, Result};
use std::fmt;

/// Tile edge in pixels: the unit of parallel work, and of the parts a frame is split
/// into (`Region::Part`). A multiple of the packet footprints (4x2 and 2x2).
pub const TILE: u32 = 16;

/// A rectangle of pixels, `[x0, x1) × [y0, y1)`, in pixel coordinates from the top-left
/// corner of the frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Rect {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Rect {
    /// The rectangle `[x0, x1) × [y0, y1)`.
    pub const fn new(x0: u32, y0: u32, x1: u32, y1: u32) -> Self {
        Self { x0, y0, x1, y1 }
    }

    /// Columns (0 if `x1 <= x0`).
    pub fn width(&self) -> u32 {
        self.x1.saturating_sub(self.x0)
    }

    /// Rows (0 if `y1 <= y0`).
    pub fn height(&self) -> u32 {
        self.y1.saturating_sub(self.y0)
    }

    /// Pixels.
    pub fn pixel_count(&self) -> u64 {
        self.width() as u64 * self.height() as u64
    }

    /// Whether the pixel (x, y) is inside.
    pub fn contains(&self, x: u32, y: u32) -> bool {
        (self.x0..self.x1).contains(&x) && (self.y0..self.y1).contains(&y)
    }
}

/// Writes `X0,Y0,X1,Y1`.
impl fmt::Display for Rect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{},{},{},{}", self.x0, self.y0, self.x1, self.y1)
    }
}

/// Which pixels of a frame a render computes.
///
/// A part holds the frame's 16x16 tiles (tx, ty) with (tx + k·ty) mod `count` = `index`,
/// for the row shift k that keeps a part's tiles farthest apart, so every part gets about
/// one tile in `count` of any patch of the frame: the parts take about the same time
/// whatever the picture (a split by rows would put all of a mesh into a few parts).
///
/// ```
/// use raytracer::{Rect, Region};
///
/// // A 100x56 frame is 7x4 tiles: four parts hold 8, 6, 8 and 6 of them, every pixel once.
/// let mut pixels = 0;
/// for index in 0..4 {
///     let rects = Region::Part { index, count: 4 }.rects(100, 56)?;
///     assert_eq!(rects.len(), [8, 6, 8, 6][index as usize]);
///     pixels += rects.iter().map(Rect::pixel_count).sum::<u64>();
/// }
/// assert_eq!(pixels, 100 * 56);
/// assert!(Region::Crop(Rect::new(0, 0, 101, 10)).rects(100, 56).is_err());
/// # Ok::<(), raytracer::Error>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Region {
    /// The whole frame.
    Frame,
    /// Part `index` of `count` (0-based, `count` at most [`Region::MAX_PARTS`]).
    Part {
        /// Which part, from 0.
        index: u32,
        /// How many parts the frame is split into.
        count: u32,
    },
    /// A window of the frame.
    Crop(Rect),
}

impl Region {
    /// The most parts a frame can be split into.
    pub const MAX_PARTS: u32 = 65_536;

    /// The rectangles of this region of a `width` x `height` frame, in the order their
    /// pixels are stored (each rectangle row by row, then the next): the frame or the
    /// crop as one rectangle, a part as its tiles in row-major order.
    /// [`Error::Options`] for a crop that is empty or leaves the frame, or a part that
    /// does not exist.
    pub fn rects(&self, width: u32, height: u32) -> Result<Vec<Rect>> {
        match *self {
            Region::Frame => Ok(vec![Rect::new(0, 0, width, height)]),
            Region::Crop(r) => {
                if r.x0 >= r.x1 || r.y0 >= r.y1 || r.x1 > width || r.y1 > height {
                    return Err(Error::Options(format!(
                        "crop window {r} is not a non-empty window of the {width}x{height} \
                         image (X0,Y0,X1,Y1 with X0 < X1 <= {width} and Y0 < Y1 <= {height})"
                    )));
                }
                Ok(vec![r])
            }
            Region::Part { index, count } => {
                if !(1..=Self::MAX_PARTS).contains(&count) || index >= count {
                    return Err(Error::Options(format!(
                        "part {index}/{count} does not exist: parts are I/N with \
                         0 <= I < N <= {}",
                        Self::MAX_PARTS
                    )));
                }
                let stride = part_stride(count);
                let (tiles_x, tiles_y) = (width.div_ceil(TILE), height.div_ceil(TILE));
                let mut rects = Vec::new();
                for ty in 0..tiles_y {
                    for tx in 0..tiles_x {
                        if part_of_tile(tx, ty, count, stride) == index {
                            let (x0, y0) = (tx * TILE, ty * TILE);
                            let (x1, y1) = ((x0 + TILE).min(width), (y0 + TILE).min(height));
                            rects.push(Rect::new(x0, y0, x1, y1));
                        }
                    }
                }
                Ok(rects)
            }
        }
    }
}

/// Writes `the whole frame`, `region I/N` or `crop X0,Y0,X1,Y1`.
impl fmt::Display for Region {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Region::Frame => write!(f, "the whole frame"),
            Region::Part { index, count } => write!(f, "region {index}/{count}"),
            Region::Crop(r) => write!(f, "crop {r}"),
        }
    }
}

/// The part that the tile (tx, ty) of the frame's tile grid belongs to, of `count`
/// parts: `(tx + stride · ty) mod count`, with `stride = part_stride(count)`. A part's
/// tiles form a lattice that repeats every `count` tiles along a row, shifted by
/// `stride` tiles from one row to the next.
#[inline]
fn part_of_tile(tx: u32, ty: u32, count: u32, stride: u32) -> u32 {
    ((tx as u64 + stride as u64 * ty as u64) % count as u64) as u32
}

/// The row shift of the part lattice of `count` parts: the one whose lattice keeps a
/// part's tiles farthest apart (its shortest nonzero vector longest; the smallest such
/// shift), so that every part takes about one tile in `count` of any patch of the frame
/// and none gets a whole stripe of it. 16 parts: shift 4 (tiles 4 apart along a row, the
/// next row shifted by 4: no two within 4 tiles); 4 parts: shift 2 (a quincunx).
fn part_stride(count: u32) -> u32 {
    let n = count as u64;
    let mut best = (0, 0);
    for k in 0..n {
        // Lattice vectors (x, y) with y ≥ 0 and x ≡ −k·y (mod n); (n, 0) is one.
        let mut shortest = n * n;
        let mut y = 1;
        while y * y < shortest && y < n {
            let r = (n - k * y % n) % n;
            let x = r.min(n - r);
            shortest = shortest.min(x * x + y * y);
            y += 1;
        }
        if shortest > best.0 {
            best = (shortest, k);
        }
    }
    best.1 as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shortest nonzero vector of the part lattice, by brute force over a window
    /// larger than it can be.
    fn shortest_brute(count: u32, stride: u32) -> u64 {
        let n = count as i64;
        let mut best = u64::MAX;
        for y in -n..=n {
            for x in -n..=n {
                if (x, y) != (0, 0) && (x + stride as i64 * y).rem_euclid(n) == 0 {
                    best = best.min((x * x + y * y) as u64);
                }
            }
        }
        best
    }

    #[test]
    fn part_stride_keeps_the_parts_tiles_farthest_apart() {
        for count in 1..=40 {
            let stride = part_stride(count);
            let got = shortest_brute(count, stride);
            let best = (0..count).map(|k| shortest_brute(count, k)).max().unwrap();
            assert_eq!(got, best, "{count} parts: stride {stride}");
        }
        assert_eq!(part_stride(16), 4);
        assert_eq!(part_stride(4), 2);
        assert_eq!(part_stride(2), 1);
        assert_eq!(part_stride(1), 0);
    }

    #[test]
    fn parts_cover_the_frame_once() {
        for (w, h) in [(1, 1), (37, 21), (800, 450), (16, 16), (17, 33)] {
            for count in [1, 2, 3, 4, 7, 16, 64, 1000] {
                let mut seen = vec![0u8; (w * h) as usize];
                let mut sizes = Vec::new();
                for index in 0..count {
                    let rects = Region::Part { index, count }.rects(w, h).unwrap();
                    sizes.push(rects.len());
                    for r in rects {
                        assert!(r.x1 <= w && r.y1 <= h && r.width() > 0 && r.height() > 0);
                        for y in r.y0..r.y1 {
                            for x in r.x0..r.x1 {
                                seen[(y * w + x) as usize] += 1;
                            }
                        }
                    }
                }
                assert!(seen.iter().all(|&c| c == 1), "{w}x{h} in {count} parts");
                // Tile counts differ by little: at most one tile a row of tiles.
                let rows = h.div_ceil(TILE) as usize;
                let (lo, hi) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
                assert!(hi - lo <= rows, "{w}x{h} in {count} parts: {sizes:?}");
            }
        }
    }

    #[test]
    fn bad_regions_are_errors() {
        let bad = [
            Region::Part { index: 4, count: 4 },
            Region::Part { index: 0, count: 0 },
            Region::Part {
                index: 0,
                count: Region::MAX_PARTS + 1,
            },
            Region::Crop(Rect::new(0, 0, 801, 10)),
            Region::Crop(Rect::new(5, 0, 5, 10)),
            Region::Crop(Rect::new(0, 9, 10, 3)),
            Region::Crop(Rect::new(0, 0, 10, 451)),
        ];
        for region in bad {
            assert!(region.rects(800, 450).is_err(), "{region:?}");
        }
        assert_eq!(
            Region::Crop(Rect::new(0, 0, 800, 450))
                .rects(800, 450)
                .unwrap(),
            Region::Frame.rects(800, 450).unwrap()
        );
    }
}
