//! A progressive render: passes of one sample a pixel, each added to the sums of the
//! passes before, so that the image can be shown after every pass. Pass k renders sample
//! index k of every pixel with `render::accumulate_tile`, the adaptive render's loop, and
//! a pixel sums its samples in sample order: after N passes the film is the bits of a
//! render of N samples a pixel.

use crate::accel::Accel;
use crate::error::{Error, Result};
use crate::farm::region::{Rect, TILE};
use crate::film::Film;
use crate::integrator::{RayCounts, Tracer};
use crate::output::quantize;
use crate::render::accumulate_tile;
use crate::sampling::Sampler;
use crate::scene::Scene;
use crate::settings::RenderSettings;
use glam::Vec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// The sums of a progressive render's passes, made by
/// [`Renderer::progressive`](crate::Renderer::progressive) and advanced one sample a
/// pixel at a time by [`Renderer::render_pass`](crate::Renderer::render_pass).
///
/// After N passes, [`Progressive::film`] is the same bits as
/// [`Renderer::render`](crate::Renderer::render) at N samples a pixel with the same
/// settings (for the stratified sampler, whose draws depend on the sample count, when N
/// is the count the render was started for).
#[derive(Clone, Debug)]
pub struct Progressive {
    width: u32,
    height: u32,
    spp: u32,
    passes: u32,
    /// The frame's tiles, row by row.
    tiles: Vec<Rect>,
    /// Each tile's pixel sums, row by row, one tile after another.
    sums: Vec<Vec3>,
    /// Where each tile's sums start in `sums`.
    offsets: Vec<usize>,
    counts: RayCounts,
    /// A pass was stopped part way: some tiles have a sample more than others.
    interrupted: bool,
}

impl Progressive {
    pub(crate) fn new(width: u32, height: u32, spp: u32) -> Result<Self> {
        if spp == 0 {
            return Err(Error::Options(
                "a progressive render needs at least one sample a pixel".into(),
            ));
        }
        let mut tiles = Vec::new();
        let mut offsets = Vec::new();
        let mut n = 0usize;
        for y0 in (0..height).step_by(TILE as usize) {
            for x0 in (0..width).step_by(TILE as usize) {
                let tile = Rect::new(x0, y0, (x0 + TILE).min(width), (y0 + TILE).min(height));
                offsets.push(n);
                n += tile.pixel_count() as usize;
                tiles.push(tile);
            }
        }
        let sums = crate::film::zeroed_pixels(n).map_err(|_| Error::ImageTooLarge {
            width,
            height,
            bytes: n as u128 * std::mem::size_of::<Vec3>() as u128,
        })?;
        Ok(Self {
            width,
            height,
            spp,
            passes: 0,
            tiles,
            sums,
            offsets,
            counts: RayCounts::default(),
            interrupted: false,
        })
    }

    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Image height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The passes rendered so far: the samples each pixel has.
    pub fn passes(&self) -> u32 {
        self.passes
    }

    /// The samples a pixel the render was started for: its last pass.
    pub fn spp(&self) -> u32 {
        self.spp
    }

    /// Every pass is rendered.
    pub fn is_done(&self) -> bool {
        self.passes >= self.spp
    }

    /// The rays traced by the passes so far.
    pub fn counts(&self) -> &RayCounts {
        &self.counts
    }

    /// A pass was stopped part way ([`Renderer::render_pass_unless`]): the tiles
    /// differ in samples until [`Progressive::restart`].
    ///
    /// [`Renderer::render_pass_unless`]: crate::Renderer::render_pass_unless
    pub fn is_interrupted(&self) -> bool {
        self.interrupted
    }

    /// Forget the passes (after the camera moved): the next pass is sample 0 again.
    pub fn restart(&mut self) {
        self.sums.fill(Vec3::ZERO);
        self.passes = 0;
        self.counts = RayCounts::default();
        self.interrupted = false;
    }

    /// The image so far: each pixel the mean of its samples (black before the first
    /// pass).
    pub fn film(&self) -> Result<Film> {
        let mut film = Film::new(self.width, self.height)?;
        let n = self.passes.max(1) as f32;
        let width = self.width as usize;
        for (tile, &offset) in self.tiles.iter().zip(&self.offsets) {
            let sums = &self.sums[offset..offset + tile.pixel_count() as usize];
            for (row, line) in sums.chunks_exact(tile.width() as usize).enumerate() {
                let start = (tile.y0 as usize + row) * width + tile.x0 as usize;
                for (pixel, sum) in film.pixels[start..start + line.len()].iter_mut().zip(line) {
                    *pixel = *sum / n;
                }
            }
        }
        Ok(film)
    }

    /// The image so far as 8-bit RGBA bytes, row by row, into `out` (resized to
    /// `width × height × 4`): the bytes of [`Film::to_rgb8`] of [`Progressive::film`],
    /// with an opaque alpha. On the current rayon pool, a band of tiles a task.
    pub fn rgba8_into(&self, out: &mut Vec<u8>) {
        let width = self.width as usize;
        out.resize(width * self.height as usize * 4, 0);
        let n = self.passes.max(1) as f32;
        let per_band = self.width.div_ceil(TILE) as usize;
        out.par_chunks_mut(width * TILE as usize * 4)
            .zip(self.tiles.par_chunks(per_band))
            .zip(self.offsets.par_chunks(per_band))
            .for_each(|((rows, tiles), offsets)| {
                for (tile, &offset) in tiles.iter().zip(offsets) {
                    let sums = &self.sums[offset..offset + tile.pixel_count() as usize];
                    for (row, line) in sums.chunks_exact(tile.width() as usize).enumerate() {
                        let start = (row * width + tile.x0 as usize) * 4;
                        let bytes = &mut rows[start..start + line.len() * 4];
                        for (rgba, sum) in bytes.chunks_exact_mut(4).zip(line) {
                            let mean = *sum / n;
                            rgba[0] = quantize(mean.x);
                            rgba[1] = quantize(mean.y);
                            rgba[2] = quantize(mean.z);
                            rgba[3] = 255;
                        }
                    }
                }
            });
    }
}

/// Render the next pass of `progressive` (sample index `progressive.passes()` of every
/// pixel) on the current rayon pool, a tile a task; the rays it traced. `stop` is asked
/// before each tile: once it says yes, the tiles not yet begun are skipped, the pass is
/// not counted, and the render is interrupted (`None`).
pub fn render_pass(
    scene: &Scene,
    accel: &Accel,
    settings: &RenderSettings,
    progressive: &mut Progressive,
    stop: &(dyn Fn() -> bool + Sync),
) -> Result<Option<RayCounts>> {
    let (width, height) = (scene.camera.width, scene.camera.height);
    if (progressive.width, progressive.height) != (width, height) {
        return Err(Error::Options(format!(
            "a progressive render of a {}x{} image cannot continue at {width}x{height}",
            progressive.width, progressive.height
        )));
    }
    if progressive.interrupted {
        return Err(Error::Options(
            "the progressive render's last pass was stopped: restart it".into(),
        ));
    }
    if progressive.is_done() {
        return Err(Error::Options(format!(
            "the progressive render has all its {} passes",
            progressive.spp
        )));
    }
    // The stratified sampler spreads a pixel's draws over its sample count: the budget.
    let sampler = Sampler::new(settings.sampler, settings.seed, progressive.spp);
    let mut tracer = Tracer::with_sampler(scene, accel, sampler);
    tracer.specialize = settings.specialize;
    let tracer = &tracer;
    let sample = progressive.passes;
    let Progressive {
        tiles,
        sums,
        offsets,
        ..
    } = progressive;
    // Each tile's sums, as its own slice.
    let mut pieces = Vec::with_capacity(tiles.len());
    let mut rest = sums.as_mut_slice();
    for (tile, pair) in tiles.iter().zip(offsets.windows(2).map(Some).chain([None])) {
        let len = match pair {
            Some(pair) => pair[1] - pair[0],
            None => rest.len(),
        };
        let (mine, next) = rest.split_at_mut(len);
        rest = next;
        pieces.push((*tile, mine));
    }
    let stopped = AtomicBool::new(false);
    let counts = pieces
        .into_par_iter()
        .map(|(tile, sums)| {
            if stopped.load(Ordering::Relaxed) || stop() {
                stopped.store(true, Ordering::Relaxed);
                return RayCounts::default();
            }
            let samples = sample..sample + 1;
            accumulate_tile(tracer, settings.packet_width, tile, samples, sums)
        })
        .reduce(RayCounts::default, |mut a, b| {
            a.add(&b);
            a
        });
    if stopped.into_inner() {
        progressive.interrupted = true;
        return Ok(None);
    }
    progressive.passes += 1;
    progressive.counts.add(&counts);
    Ok(Some(counts))
}
