//! `raytracer view SCENE`: a live, progressive view of the scene in a web browser. This
//! thread (a worker of the run's pool) renders passes of one sample a pixel with the
//! library's `Renderer::render_pass` and publishes each as 8-bit RGBA; `server` serves
//! the page and streams the passes to every open tab over a WebSocket; the tabs' mouse
//! moves come back as camera moves (`Move`), applied between passes, which restart the
//! accumulation. All tabs share the one render.
//!
//! Nothing is written to disk: the images a tab saves are encoded in memory and
//! downloaded, so Ctrl-C (the run's signal handler) leaves no file.

mod camera;
mod server;

use super::args::ViewArgs;
use anyhow::Context;
use raytracer::{Progressive, RenderSettings, Renderer, SceneOptions};
use std::net::{IpAddr, SocketAddr};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Instant;

pub use camera::Move;

/// What `raytracer view` was asked for.
#[derive(Debug)]
pub struct ViewOptions {
    pub scene: String,
    pub scene_options: SceneOptions,
    pub settings: RenderSettings,
    /// The samples a pixel the view refines to.
    pub spp: u32,
    pub listen: IpAddr,
    pub port: u16,
}

impl From<ViewArgs> for ViewOptions {
    fn from(v: ViewArgs) -> Self {
        Self {
            scene: v.scene,
            scene_options: SceneOptions {
                width: v.width,
                max_depth: v.max_depth,
                ..SceneOptions::default()
            },
            settings: RenderSettings {
                seed: v.seed,
                packet_width: v.packet_width,
                specialize: true,
                sampler: v.sampler.into(),
            },
            spp: v.spp,
            listen: v.listen,
            port: v.port,
        }
    }
}

/// One published pass: the WebSocket message every tab is sent, a header and the RGBA
/// bytes (`Frame::encode`).
pub struct Frame {
    pub message: axum::body::Bytes,
}

/// The frame message's header: little-endian, 8-byte aligned; the page reads it
/// (`page.html`, `readFrame`).
const HEADER_BYTES: usize = 64;

/// The time a pass may take while the camera moves: a scene whose full-size pass takes
/// longer is previewed at a fraction of the size (`preview_size`), so that the first
/// frame of a move comes before the next mouse event (16 ms apart at 60 Hz, the frame's
/// making, sending and drawing included).
const PREVIEW_MS: f64 = 10.0;

/// How long after a preview the view waits for the next move before it starts a full
/// pass: a little more than the time between two mouse events.
const SETTLE: std::time::Duration = std::time::Duration::from_millis(40);

/// The size of a preview: the image divided by the smallest whole factor (up to 8)
/// whose pass takes `PREVIEW_MS` at most, by the full pass's time; the factor.
fn preview_size(width: u32, height: u32, full_pass_ms: f64) -> (u32, u32, u32) {
    let factor = (full_pass_ms / PREVIEW_MS).sqrt().ceil().clamp(1.0, 8.0) as u32;
    let w = width.div_ceil(factor).max(1);
    let h = ((height as u64 * w as u64 + width as u64 / 2) / width as u64).max(1) as u32;
    (w, h.min(height), factor)
}

impl Frame {
    /// The message: width, height, camera generation, passes (u32 each), then the moves
    /// applied, the pass's render time, the time its bytes took to make (ms), its rays,
    /// the samples a pixel the view refines to, and the factor the picture is reduced
    /// by (1, or more for a preview while moving; f64 each), then the RGBA rows.
    #[allow(clippy::too_many_arguments)]
    fn encode(
        progressive: &Progressive,
        generation: u32,
        moves: u64,
        pass_ms: f64,
        rays: u64,
        factor: u32,
        rgba: &mut Vec<u8>,
    ) -> Self {
        let start = Instant::now();
        progressive.rgba8_into(rgba);
        let mut message = Vec::with_capacity(HEADER_BYTES + rgba.len());
        for v in [
            progressive.width(),
            progressive.height(),
            generation,
            progressive.passes(),
        ] {
            message.extend_from_slice(&v.to_le_bytes());
        }
        let encode_ms = start.elapsed().as_secs_f64() * 1e3;
        for v in [
            moves as f64,
            pass_ms,
            encode_ms,
            rays as f64,
            progressive.spp() as f64,
            factor as f64,
        ] {
            message.extend_from_slice(&v.to_le_bytes());
        }
        debug_assert_eq!(message.len(), HEADER_BYTES);
        message.extend_from_slice(rgba);
        Self {
            message: message.into(),
        }
    }
}

/// A tab's request for the image so far (`/image.png`, `/image.exr`), answered by the
/// render thread between passes.
pub type ImageRequest = tokio::sync::oneshot::Sender<raytracer::Film>;

/// What the server threads and the render thread share.
#[derive(Default)]
pub struct Shared {
    state: Mutex<State>,
    /// A move is queued: the pass in flight stops (`Renderer::render_pass_unless`).
    move_queued: AtomicBool,
    /// The render thread waits here when it has nothing to do.
    wake: Condvar,
}

#[derive(Default)]
struct State {
    /// Camera moves not yet applied, in arrival order.
    moves: Vec<Move>,
    /// Moves received so far (applied or not): each is acknowledged with its number, and
    /// a frame says how many it shows.
    moves_received: u64,
    images: Vec<ImageRequest>,
    /// Open WebSockets: no tab, no render.
    clients: usize,
    /// Tabs that have drawn their last frame: a pass is made into a frame only for them
    /// (or when it is the last).
    ready: usize,
    /// The `[camera]` table of the camera rendered now.
    camera_toml: String,
}

impl Shared {
    fn lock(&self) -> std::sync::MutexGuard<'_, State> {
        // A panicking thread ends the process (panic = "abort" in release; in tests the
        // state is still consistent: every update is one assignment).
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Queue a camera move; its number.
    pub fn push_move(&self, m: Move) -> u64 {
        let mut state = self.lock();
        state.moves.push(m);
        state.moves_received += 1;
        self.move_queued.store(true, Ordering::Relaxed);
        self.wake.notify_all();
        state.moves_received
    }

    pub fn request_image(&self, request: ImageRequest) {
        self.lock().images.push(request);
        self.wake.notify_all();
    }

    /// A tab opened its WebSocket; it is ready for a frame.
    pub fn add_client(&self) {
        let mut state = self.lock();
        state.clients += 1;
        state.ready += 1;
        self.wake.notify_all();
    }

    /// A tab closed its WebSocket, ready for a frame or not.
    pub fn remove_client(&self, ready: bool) {
        let mut state = self.lock();
        state.clients = state.clients.saturating_sub(1);
        state.ready = state.ready.saturating_sub(ready as usize);
    }

    /// A tab is ready for a frame (`1`), or was sent one (`-1`).
    pub fn ready(&self, delta: isize) {
        let mut state = self.lock();
        state.ready = state.ready.saturating_add_signed(delta);
    }

    pub fn camera_toml(&self) -> String {
        self.lock().camera_toml.clone()
    }
}

/// Load the scene, start the server, print the URL and render for as long as the process
/// lives (Ctrl-C ends it).
pub fn run(options: &ViewOptions) -> anyhow::Result<()> {
    let file = super::scene_file(&options.scene)?;
    let mut renderer =
        Renderer::new(&file, &options.scene_options).map_err(super::name_the_memory_cap)?;
    let mut progressive = renderer.progressive(options.spp)?;
    let addr = SocketAddr::new(options.listen, options.port);
    let listener = std::net::TcpListener::bind(addr)
        .with_context(|| format!("cannot listen on {addr} (--listen, --port)"))?;
    let local = listener.local_addr()?;
    if !options.listen.is_loopback() {
        to_stderr!(
            "warning: listening on {local}: any machine that reaches it sees the scene and moves its camera"
        );
    }
    let shared = Arc::new(Shared::default());
    shared.lock().camera_toml = renderer.camera_toml();
    let (frames, _) = tokio::sync::watch::channel(None::<Arc<Frame>>);
    let frames = Arc::new(frames);
    let site = server::Site {
        shared: shared.clone(),
        frames: frames.clone(),
        name: renderer.name().to_string(),
        loopback_only: options.listen.is_loopback(),
        port: local.port(),
    };
    let server = std::thread::Builder::new()
        .name("view server".into())
        .spawn(move || server::serve(listener, site))
        .context("cannot start the server thread")?;
    super::print_stdout(&format!(
        "{} at http://{local}/ ({}x{}, up to {} samples a pixel; Ctrl-C stops)\n",
        renderer.name(),
        renderer.width(),
        renderer.height(),
        options.spp
    ))?;

    let mut generation = 0u32;
    let mut moves_applied = 0u64;
    let mut rgba = Vec::new();
    let mut preview: Option<Progressive> = None;
    let mut full_pass_ms = 0.0f64;
    let mut settle: Option<Instant> = None;
    loop {
        let (moves, images) = {
            let mut state = shared.lock();
            // After a preview, a moment for the next move before a slow full pass starts
            // (a move during a pass waits for its end).
            while let Some(until) = settle.filter(|_| state.moves.is_empty()) {
                let Some(left) = until.checked_duration_since(Instant::now()) else {
                    break;
                };
                state = shared
                    .wake
                    .wait_timeout(state, left)
                    .map(|(s, _)| s)
                    .unwrap_or_else(|e| e.into_inner().0);
            }
            settle = None;
            // Nothing to do: every pass rendered, or nobody watching.
            while state.moves.is_empty()
                && state.images.is_empty()
                && (progressive.is_done() || state.clients == 0)
            {
                if server.is_finished() {
                    break;
                }
                state = shared
                    .wake
                    .wait_timeout(state, std::time::Duration::from_millis(500))
                    .map(|(s, _)| s)
                    .unwrap_or_else(|e| e.into_inner().0);
            }
            shared.move_queued.store(false, Ordering::Relaxed);
            (
                std::mem::take(&mut state.moves),
                std::mem::take(&mut state.images),
            )
        };
        if server.is_finished() {
            return match server.join() {
                Ok(result) => result,
                Err(_) => Err(anyhow::anyhow!("the server thread failed")),
            };
        }
        for reply in images {
            let _ = reply.send(progressive.film()?);
        }
        let mut moved = false;
        if !moves.is_empty() {
            let mut pose = renderer.camera_pose();
            for m in &moves {
                pose = m.apply(&pose, renderer.height());
                moves_applied += 1;
            }
            // A pose the scene file could not hold (the camera on its target) is no move.
            if renderer.set_camera_pose(&pose).is_ok() {
                progressive.restart();
                generation = generation.wrapping_add(1);
                shared.lock().camera_toml = renderer.camera_toml();
                moved = true;
            }
        }
        // A pass stopped by a move that changed nothing (a pose refused): start again.
        if progressive.is_interrupted() {
            progressive.restart();
        }
        // The camera moves and a full pass is slow: a smaller picture first.
        let (width, height) = (progressive.width(), progressive.height());
        let (pw, ph, factor) = preview_size(width, height, full_pass_ms);
        if moved && factor > 1 && renderer.set_size(pw, ph).is_ok() {
            let mut small = match preview.take() {
                Some(p) if (p.width(), p.height()) == (pw, ph) => p,
                _ => renderer.progressive(options.spp)?,
            };
            small.restart();
            let start = Instant::now();
            let counts = renderer.render_pass(&options.settings, &mut small);
            renderer.set_size(width, height)?;
            let pass_ms = start.elapsed().as_secs_f64() * 1e3;
            let frame = Frame::encode(
                &small,
                generation,
                moves_applied,
                pass_ms,
                counts?.total(),
                factor,
                &mut rgba,
            );
            frames.send_replace(Some(Arc::new(frame)));
            preview = Some(small);
            settle = Some(Instant::now() + SETTLE);
            continue;
        }
        if progressive.is_done() {
            continue;
        }
        let start = Instant::now();
        let queued = || shared.move_queued.load(Ordering::Relaxed);
        let Some(counts) =
            renderer.render_pass_unless(&options.settings, &mut progressive, &queued)?
        else {
            // A move came: its frame first.
            continue;
        };
        let pass_ms = start.elapsed().as_secs_f64() * 1e3;
        // The full pass's time, smoothed over a few passes.
        full_pass_ms = if full_pass_ms == 0.0 {
            pass_ms
        } else {
            0.75 * full_pass_ms + 0.25 * pass_ms
        };
        // A move arrived during the pass: its frame is already old. No tab is ready:
        // it would not be shown (but the last pass is, whenever a tab gets to it).
        let wanted = {
            let state = shared.lock();
            state.moves.is_empty() && (state.ready > 0 || progressive.is_done())
        };
        if !wanted {
            continue;
        }
        let frame = Frame::encode(
            &progressive,
            generation,
            moves_applied,
            pass_ms,
            counts.total(),
            1,
            &mut rgba,
        );
        frames.send_replace(Some(Arc::new(frame)));
    }
}

#[cfg(test)]
mod tests {
    use super::preview_size;

    /// A full pass within the preview's time is no preview; a slower one is divided by
    /// the factor that brings it within, keeping the aspect.
    #[test]
    fn preview_sizes() {
        assert_eq!(preview_size(800, 450, 10.0), (800, 450, 1));
        assert_eq!(preview_size(800, 800, 100.0), (200, 200, 4));
        assert_eq!(preview_size(800, 450, 40.0), (400, 225, 2));
        assert_eq!(preview_size(800, 450, 1e9), (100, 56, 8));
        assert_eq!(preview_size(3, 1, 1e9), (1, 1, 8));
    }
}
