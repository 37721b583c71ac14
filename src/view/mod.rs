//! `pathtracer view`: the interactive renderer, served to a browser by the renderer itself.
//!
//! A render thread owns the scene and a [`Film`]: it adds passes of one sample per pixel
//! (through [`render_into`], the one render path) until the target, and starts a new film
//! whenever the settings change (the running pass is stopped through the stop flag). The
//! HTTP server (axum on tokio, only with the `view` feature) reads the latest developed image
//! and changes the settings.
//!
//! Security: the server binds loopback unless told otherwise; every request needs the access
//! token (128 random bits, hex) as `?token=` or `Authorization: Bearer`, compared in constant
//! time; request bodies are capped at [`MAX_BODY`] bytes; settings are range-checked (a bad
//! one is a 4xx and changes nothing); no request names a file.
//!
//! API (all under the token):
//! - `GET /` the page; `GET /api/state` JSON: settings, passes done, frame number, image size,
//!   samples per second, elapsed seconds since the last restart;
//! - `POST /api/settings` JSON with any of the settings' fields: applies them and restarts;
//! - `GET /api/image.png`, `GET /api/image.exr`: the latest image (503 before the first pass).

use crate::error::{Error, Result};
use crate::film::Film;
use crate::io::image::Image;
use crate::render::{new_film, render_into, Control, RenderOptions};
use crate::scene::Scene;
use axum::extract::{DefaultBodyLimit, Query, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::net::{IpAddr, SocketAddr};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Instant;

/// Largest request body accepted, bytes.
pub const MAX_BODY: usize = 16 * 1024;

/// What the user can change while viewing. Every field is range-checked by [`Settings::apply`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    /// Target samples per pixel (CS184 keys `]` and `[`).
    pub spp: u32,
    /// Maximum ray depth (`.` and `,`).
    pub max_depth: u32,
    /// Light samples (`=` and `-`).
    pub light_samples: u32,
    /// Hemisphere sampling for direct light (`h`).
    pub hemisphere: bool,
    /// Thin-lens radius (`k` and `l`).
    pub lens_radius: f32,
    /// Focal distance (`;` and `'`).
    pub focal_distance: f32,
}

/// A partial update of [`Settings`] as a client sends it.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SettingsUpdate {
    spp: Option<u32>,
    max_depth: Option<u32>,
    light_samples: Option<u32>,
    hemisphere: Option<bool>,
    lens_radius: Option<f32>,
    focal_distance: Option<f32>,
}

impl Settings {
    /// The settings with `u` applied, or the reason it is out of range.
    pub fn apply(&self, u: &SettingsUpdate) -> std::result::Result<Settings, String> {
        let mut s = self.clone();
        let range = |name: &str, v: u32, lo: u32, hi: u32| {
            if (lo..=hi).contains(&v) {
                Ok(v)
            } else {
                Err(format!("{name} must be in {lo}..={hi}, not {v}"))
            }
        };
        if let Some(v) = u.spp {
            s.spp = range("spp", v, 1, 1 << 20)?;
        }
        if let Some(v) = u.max_depth {
            s.max_depth = range("max_depth", v, 0, 10_000)?;
        }
        if let Some(v) = u.light_samples {
            s.light_samples = range("light_samples", v, 1, 1024)?;
        }
        if let Some(v) = u.hemisphere {
            s.hemisphere = v;
        }
        if let Some(v) = u.lens_radius {
            if !(v.is_finite() && (0.0..=1e6).contains(&v)) {
                return Err(format!("lens_radius must be in 0..=1e6, not {v}"));
            }
            s.lens_radius = v;
        }
        if let Some(v) = u.focal_distance {
            if !(v.is_finite() && v > 0.0 && v <= 1e9) {
                return Err(format!("focal_distance must be in (0, 1e9], not {v}"));
            }
            s.focal_distance = v;
        }
        Ok(s)
    }
}

/// Where and how the server runs.
#[derive(Clone, Debug)]
pub struct ViewConfig {
    /// Address to bind (loopback unless the user says otherwise).
    pub host: IpAddr,
    /// Port; 0 picks a free one.
    pub port: u16,
}

/// The state the render thread publishes and the server reads.
struct Published {
    settings: Settings,
    /// Bumped by every settings change; the render thread restarts when it differs.
    generation: u64,
    /// Passes (samples per pixel) in the latest image.
    passes: u32,
    /// Images published since the start.
    frame: u64,
    image: Option<Arc<Image>>,
    /// Samples per second of the latest pass.
    samples_per_sec: f64,
    /// When the current film was started.
    started: Instant,
    quit: bool,
}

struct Shared {
    token: String,
    state: Mutex<Published>,
    wake: Condvar,
    /// Stops the running pass (a settings change or shutdown).
    stop: AtomicBool,
}

impl Shared {
    fn lock(&self) -> std::sync::MutexGuard<'_, Published> {
        // A panic while holding the lock cannot leave Published inconsistent (plain fields).
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// A running viewer: its URL (with the token) and a way to stop it.
pub struct Viewer {
    /// The address the server listens on.
    pub addr: SocketAddr,
    /// The access token.
    pub token: String,
    shared: Arc<Shared>,
    server: Option<std::thread::JoinHandle<()>>,
    render: Option<std::thread::JoinHandle<()>>,
    shutdown: Option<tokio::sync::oneshot::Sender<()>>,
}

impl Viewer {
    /// The URL to open (with the token).
    pub fn url(&self) -> String {
        format!("http://{}/?token={}", self.addr, self.token)
    }

    /// Blocks until the server ends (it runs until the process is stopped).
    pub fn wait(mut self) {
        if let Some(s) = self.server.take() {
            let _ = s.join();
        }
    }
}

impl Drop for Viewer {
    fn drop(&mut self) {
        self.shared.lock().quit = true;
        self.shared.stop.store(true, Ordering::SeqCst);
        self.shared.wake.notify_all();
        if let Some(tx) = self.shutdown.take() {
            let _ = tx.send(());
        }
        for h in [self.server.take(), self.render.take()]
            .into_iter()
            .flatten()
        {
            let _ = h.join();
        }
    }
}

/// 128 random bits as 32 hex digits.
fn new_token() -> Result<String> {
    let mut b = [0u8; 16];
    getrandom::fill(&mut b)
        .map_err(|e| Error::Usage(format!("no random numbers for the access token: {e}")))?;
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
}

/// Equality that takes the same time wherever the first difference is.
fn constant_time_eq(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// Starts the render thread and the server; returns once the server listens.
pub fn start(scene: Scene, opts: RenderOptions, cfg: &ViewConfig) -> Result<Viewer> {
    let settings = Settings {
        spp: opts.spp,
        max_depth: opts.integrator.max_depth,
        light_samples: opts.integrator.light_samples,
        hemisphere: opts.integrator.direct == crate::integrator::Direct::Hemisphere,
        lens_radius: scene.camera.lens_radius,
        focal_distance: scene.camera.focal_distance,
    };
    let shared = Arc::new(Shared {
        token: new_token()?,
        state: Mutex::new(Published {
            settings,
            generation: 0,
            passes: 0,
            frame: 0,
            image: None,
            samples_per_sec: 0.0,
            started: Instant::now(),
            quit: false,
        }),
        wake: Condvar::new(),
        stop: AtomicBool::new(false),
    });
    let render = {
        let shared = shared.clone();
        std::thread::Builder::new()
            .name("view-render".into())
            .spawn(move || render_loop(scene, opts, &shared))
            .map_err(|e| Error::Usage(format!("cannot start the render thread: {e}")))?
    };
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .map_err(|e| Error::Usage(format!("cannot start the server runtime: {e}")))?;
    let addr = SocketAddr::new(cfg.host, cfg.port);
    let listener = rt
        .block_on(tokio::net::TcpListener::bind(addr))
        .map_err(|e| Error::Usage(format!("cannot listen on {addr}: {e}")))?;
    let addr = listener
        .local_addr()
        .map_err(|e| Error::Usage(format!("cannot listen on {addr}: {e}")))?;
    let app = Router::new()
        .route("/", get(page))
        .route("/api/state", get(state))
        .route("/api/settings", post(settings_post))
        .route("/api/image.png", get(image_png))
        .route("/api/image.exr", get(image_exr))
        .layer(DefaultBodyLimit::max(MAX_BODY))
        .with_state(shared.clone());
    let (tx, rx) = tokio::sync::oneshot::channel::<()>();
    let server = std::thread::Builder::new()
        .name("view-server".into())
        .spawn(move || {
            rt.block_on(async move {
                let _ = axum::serve(listener, app)
                    .with_graceful_shutdown(async {
                        let _ = rx.await;
                    })
                    .await;
            });
        })
        .map_err(|e| Error::Usage(format!("cannot start the server thread: {e}")))?;
    Ok(Viewer {
        addr,
        token: shared.token.clone(),
        shared,
        server: Some(server),
        render: Some(render),
        shutdown: Some(tx),
    })
}

/// The render thread: passes into a film until the target, a new film on every change.
fn render_loop(mut scene: Scene, base: RenderOptions, shared: &Shared) {
    let mut seen = u64::MAX;
    let mut film: Option<Film> = None;
    let mut opts = base.clone();
    loop {
        let (settings, generation) = {
            let mut st = shared.lock();
            loop {
                if st.quit {
                    return;
                }
                let done = film.as_ref().is_some_and(|f| {
                    st.generation == seen && st.passes >= st.settings.spp && f.samples() > 0
                });
                if !done {
                    break;
                }
                st = shared.wake.wait(st).unwrap_or_else(|e| e.into_inner());
            }
            (st.settings.clone(), st.generation)
        };
        if generation != seen || film.is_none() {
            seen = generation;
            shared.stop.store(false, Ordering::SeqCst);
            opts = base.clone();
            opts.spp = settings.spp;
            opts.integrator.max_depth = settings.max_depth;
            opts.integrator.light_samples = settings.light_samples;
            if settings.hemisphere {
                opts.integrator.direct = crate::integrator::Direct::Hemisphere;
            } else if base.integrator.direct == crate::integrator::Direct::Hemisphere {
                opts.integrator.direct = crate::integrator::Direct::Mis;
            }
            scene.camera.lens_radius = settings.lens_radius;
            scene.camera.focal_distance = settings.focal_distance;
            film = new_film(&opts).ok();
            shared.lock().started = Instant::now();
        }
        let Some(f) = film.as_mut() else {
            return;
        };
        // One pass: a time limit of zero stops after the first pass of one sample per pixel.
        let mut pass = opts.clone();
        pass.time_limit = Some(0.0);
        let ctl = Control {
            stop: &shared.stop,
            progress: &|_, _| {},
        };
        let Ok(stats) = render_into(&scene, &pass, f, ctl) else {
            return;
        };
        let passes = f.pixels().iter().map(|p| p.n).min().unwrap_or(0);
        let img = Arc::new(f.develop());
        let mut st = shared.lock();
        if st.generation == seen {
            st.image = Some(img);
            st.passes = passes;
            st.frame += 1;
            st.samples_per_sec = stats.samples as f64 / stats.seconds.max(1e-9);
        }
    }
}

type Shd = State<Arc<Shared>>;

/// The token check of every request.
fn authorized(shared: &Shared, q: &HashMap<String, String>, h: &HeaderMap) -> bool {
    let given = q.get("token").cloned().or_else(|| {
        h.get(header::AUTHORIZATION)
            .and_then(|v| v.to_str().ok())
            .and_then(|v| v.strip_prefix("Bearer "))
            .map(str::to_string)
    });
    given.is_some_and(|t| constant_time_eq(t.as_bytes(), shared.token.as_bytes()))
}

fn unauthorized() -> Response {
    (StatusCode::UNAUTHORIZED, "missing or wrong access token\n").into_response()
}

async fn page(State(s): Shd, Query(q): Query<HashMap<String, String>>, h: HeaderMap) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    Html(PAGE).into_response()
}

/// The state as JSON.
#[derive(Serialize)]
struct StateJson {
    settings: Settings,
    passes: u32,
    frame: u64,
    width: usize,
    height: usize,
    samples_per_sec: f64,
    elapsed: f64,
}

async fn state(State(s): Shd, Query(q): Query<HashMap<String, String>>, h: HeaderMap) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    let st = s.lock();
    let (width, height) = st.image.as_ref().map_or((0, 0), |i| (i.width, i.height));
    Json(StateJson {
        settings: st.settings.clone(),
        passes: st.passes,
        frame: st.frame,
        width,
        height,
        samples_per_sec: st.samples_per_sec,
        elapsed: st.started.elapsed().as_secs_f64(),
    })
    .into_response()
}

async fn settings_post(
    State(s): Shd,
    Query(q): Query<HashMap<String, String>>,
    h: HeaderMap,
    body: axum::body::Bytes,
) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    let update: SettingsUpdate = match serde_json::from_slice(&body) {
        Ok(u) => u,
        Err(e) => return (StatusCode::BAD_REQUEST, format!("bad settings: {e}\n")).into_response(),
    };
    let mut st = s.lock();
    match st.settings.apply(&update) {
        Ok(new) => {
            if new != st.settings {
                st.settings = new;
                st.generation += 1;
                st.passes = 0;
                s.stop.store(true, Ordering::SeqCst);
                s.wake.notify_all();
            }
            StatusCode::NO_CONTENT.into_response()
        }
        Err(msg) => (StatusCode::UNPROCESSABLE_ENTITY, format!("{msg}\n")).into_response(),
    }
}

fn image_as(s: &Shared, ext: &str, mime: &'static str) -> Response {
    let img = s.lock().image.clone();
    let Some(img) = img else {
        return (StatusCode::SERVICE_UNAVAILABLE, "no image yet\n").into_response();
    };
    match img.encode(ext) {
        Ok(bytes) => ([(header::CONTENT_TYPE, mime)], bytes).into_response(),
        Err(e) => (StatusCode::INTERNAL_SERVER_ERROR, format!("{e}\n")).into_response(),
    }
}

async fn image_png(
    State(s): Shd,
    Query(q): Query<HashMap<String, String>>,
    h: HeaderMap,
) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    image_as(&s, "png", "image/png")
}

async fn image_exr(
    State(s): Shd,
    Query(q): Query<HashMap<String, String>>,
    h: HeaderMap,
) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    image_as(&s, "exr", "image/x-exr")
}

/// The page: the image refreshed four times a second and a status line.
const PAGE: &str = r#"<!doctype html>
<html><head><meta charset="utf-8"><title>pathtracer view</title>
<style>body{background:#222;color:#ddd;font:14px sans-serif;margin:1em}img{display:block;image-rendering:pixelated}</style>
</head><body>
<img id="img" alt="render">
<div id="status">starting…</div>
<script>
const token = new URLSearchParams(location.search).get("token");
const img = document.getElementById("img"), status = document.getElementById("status");
let frame = -1;
async function tick() {
  try {
    const r = await fetch("/api/state?token=" + token);
    if (r.ok) {
      const s = await r.json();
      status.textContent = `${s.passes} / ${s.settings.spp} spp · ${(s.samples_per_sec / 1e6).toFixed(2)} M samples/s · ${s.elapsed.toFixed(1)} s · depth ${s.settings.max_depth} · light samples ${s.settings.light_samples} · lens ${s.settings.lens_radius} · focus ${s.settings.focal_distance.toFixed(2)}`;
      if (s.frame !== frame) { frame = s.frame; img.src = "/api/image.png?token=" + token + "&frame=" + frame; }
    }
  } catch (e) { status.textContent = "disconnected"; }
  setTimeout(tick, 250);
}
tick();
</script></body></html>
"#;
