//! The view's web server: `axum` on a one-thread `tokio` runtime (the cores are the
//! renderer's). Its routes are the page's own: the page (`/`), the frames and camera
//! moves (`/ws`, a WebSocket), the image so far (`/image.png`, `/image.exr`) and the
//! camera's `[camera]` table (`/camera.toml`); anything else is 404.
//!
//! Safe by default: on a loopback address, a request must name the host as
//! `127.0.0.1:PORT`, `localhost:PORT` or `[::1]:PORT` (another name is a web site
//! reaching the port through its own DNS name), and a request from a page must come from
//! the view's own origin (another web site's script cannot open the WebSocket). A
//! malformed or unexpected message closes its WebSocket and nothing else.

use super::{Frame, Move, Shared};
use axum::body::Bytes;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Request, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use raytracer::output::ImageFormat;
use std::sync::Arc;
use std::time::Instant;
use tokio::sync::watch;

/// The page: plain HTML and JavaScript, embedded, nothing fetched from elsewhere.
const PAGE: &str = include_str!("page.html");

/// A camera move is a few dozen bytes; anything longer is not one.
const MAX_MESSAGE: usize = 1024;

/// What the handlers share.
#[derive(Clone)]
pub struct Site {
    pub shared: Arc<Shared>,
    pub frames: Arc<watch::Sender<Option<Arc<Frame>>>>,
    /// The scene's name, for the page's title and the saved files' names.
    pub name: String,
    /// Listening on a loopback address: only the loopback host names are accepted.
    pub loopback_only: bool,
    pub port: u16,
}

/// Serve on `listener` until the process ends; an error if the runtime cannot start.
pub fn serve(listener: std::net::TcpListener, site: Site) -> anyhow::Result<()> {
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_io()
        .enable_time()
        .build()?;
    runtime.block_on(async move {
        listener.set_nonblocking(true)?;
        let listener = tokio::net::TcpListener::from_std(listener)?;
        let app = Router::new()
            .route("/", get(page))
            .route("/ws", get(socket))
            .route("/image.png", get(image_png))
            .route("/image.exr", get(image_exr))
            .route("/camera.toml", get(camera_toml))
            .layer(middleware::from_fn_with_state(site.clone(), same_site))
            .with_state(site);
        axum::serve(listener, app).await?;
        Ok(())
    })
}

/// Refuse a request for another host name (on loopback) or from another origin.
async fn same_site(State(site): State<Site>, request: Request, next: Next) -> Response {
    let headers = request.headers();
    let host = headers
        .get(header::HOST)
        .and_then(|h| h.to_str().ok())
        .unwrap_or("");
    let port = site.port;
    let known = [
        format!("127.0.0.1:{port}"),
        format!("localhost:{port}"),
        format!("[::1]:{port}"),
    ];
    if site.loopback_only && !known.iter().any(|k| k == host) {
        return (StatusCode::FORBIDDEN, "unknown host").into_response();
    }
    if let Some(origin) = headers.get(header::ORIGIN) {
        if origin.to_str().ok() != Some(format!("http://{host}").as_str()) {
            return (StatusCode::FORBIDDEN, "another origin").into_response();
        }
    }
    next.run(request).await
}

async fn page(State(site): State<Site>) -> Response {
    let body = PAGE.replace("SCENE_NAME", &html_escape(&site.name));
    (
        [
            (header::CONTENT_TYPE, "text/html; charset=utf-8"),
            (header::CACHE_CONTROL, "no-store"),
        ],
        body,
    )
        .into_response()
}

fn html_escape(s: &str) -> String {
    s.chars()
        .map(|c| match c {
            '<' => "&lt;".into(),
            '>' => "&gt;".into(),
            '&' => "&amp;".into(),
            '"' => "&quot;".into(),
            '\'' => "&#39;".into(),
            c => c.to_string(),
        })
        .collect()
}

async fn camera_toml(State(site): State<Site>) -> Response {
    (
        [
            (header::CONTENT_TYPE, "text/plain; charset=utf-8"),
            (header::CACHE_CONTROL, "no-store"),
        ],
        site.shared.camera_toml(),
    )
        .into_response()
}

async fn image_png(State(site): State<Site>) -> Response {
    image(site, ImageFormat::Png).await
}

async fn image_exr(State(site): State<Site>) -> Response {
    image(site, ImageFormat::Exr).await
}

/// The image so far, from the render thread between two passes, encoded off the
/// runtime's thread.
async fn image(site: Site, format: ImageFormat) -> Response {
    let (reply, film) = tokio::sync::oneshot::channel();
    site.shared.request_image(reply);
    let failed = || (StatusCode::INTERNAL_SERVER_ERROR, "no image").into_response();
    let Ok(film) = film.await else {
        return failed();
    };
    let encoded = tokio::task::spawn_blocking(move || {
        let mut bytes = Vec::new();
        raytracer::output::encode_to_stream(&film, format, &mut bytes).map(|()| bytes)
    })
    .await;
    let Ok(Ok(bytes)) = encoded else {
        return failed();
    };
    let (kind, extension) = match format {
        ImageFormat::Exr => ("image/x-exr", "exr"),
        _ => ("image/png", "png"),
    };
    let disposition = format!("attachment; filename=\"{}.{extension}\"", site.name);
    let mut headers = HeaderMap::new();
    headers.insert(header::CONTENT_TYPE, kind.parse().expect("a MIME type"));
    headers.insert(header::CACHE_CONTROL, "no-store".parse().expect("a value"));
    if let Ok(value) = disposition.parse() {
        headers.insert(header::CONTENT_DISPOSITION, value);
    }
    (headers, Bytes::from(bytes)).into_response()
}

async fn socket(State(site): State<Site>, upgrade: WebSocketUpgrade) -> Response {
    upgrade
        .max_message_size(MAX_MESSAGE)
        .max_frame_size(MAX_MESSAGE)
        .on_upgrade(move |socket| client(site, socket))
}

/// One tab: the newest frame out whenever the tab is ready for one (it says `ready`
/// once it has drawn the last, at its display's rate: no frame is made or sent that
/// the screen cannot show, and a slow tab skips frames, it never queues them), each
/// followed by the milliseconds its sending took; camera moves in, each acknowledged
/// with its number. Any other message closes the socket.
async fn client(site: Site, mut socket: WebSocket) {
    site.shared.add_client();
    let mut ready = true;
    let mut frames = site.frames.subscribe();
    frames.mark_changed();
    loop {
        tokio::select! {
            changed = frames.changed(), if ready => {
                if changed.is_err() {
                    break;
                }
                let frame = frames.borrow_and_update().clone();
                let Some(frame) = frame else { continue };
                ready = false;
                site.shared.ready(-1);
                let start = Instant::now();
                if socket.send(Message::Binary(frame.message.clone())).await.is_err() {
                    break;
                }
                let send_ms = start.elapsed().as_secs_f64() * 1e3;
                let sent = format!("{{\"sent_ms\":{send_ms}}}");
                if socket.send(Message::Text(sent.into())).await.is_err() {
                    break;
                }
            }
            message = socket.recv() => {
                let Some(Ok(message)) = message else { break };
                match message {
                    Message::Text(text) if text.as_str() == "ready" && !ready => {
                        ready = true;
                        site.shared.ready(1);
                    }
                    Message::Text(text) => {
                        let Some(m) = Move::parse(text.as_str()) else { break };
                        let number = site.shared.push_move(m);
                        let ack = format!("{{\"move\":{number}}}");
                        if socket.send(Message::Text(ack.into())).await.is_err() {
                            break;
                        }
                    }
                    // Answered by the socket itself.
                    Message::Ping(_) | Message::Pong(_) => {}
                    Message::Binary(_) | Message::Close(_) => break,
                }
            }
        }
    }
    let _ = socket.send(Message::Close(None)).await;
    site.shared.remove_client(ready);
}
