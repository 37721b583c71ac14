//! `pathtracer view`: the interactive renderer, served to a browser by the renderer itself.
//!
//! A render thread owns the scene and a [`Film`]: it adds passes of one sample per pixel
//! (through [`render_into`], the one render path) until the target, and starts a new film
//! whenever the settings change (the running pass is stopped through the stop flag); raising
//! only the target keeps the film. While the user drags the camera, it renders fast previews
//! instead (one sample per pixel, at most [`PREVIEW_DEPTH`] bounces, at a resolution scaled so
//! that a frame takes about [`PREVIEW_FRAME`]). The HTTP server (axum on tokio, only with the
//! `view` feature) reads the latest image, streams frames over a WebSocket and changes the
//! settings.
//!
//! Security: the server binds loopback unless told otherwise; every request needs the access
//! token (128 random bits, hex) as `?token=` or `Authorization: Bearer`, compared in constant
//! time; WebSocket upgrades must come from the page's own origin (or carry no `Origin`, as
//! non-browser clients); request bodies and WebSocket messages are capped at [`MAX_BODY`]
//! bytes; settings are range-checked (a bad one is a 4xx and changes nothing); no request
//! names a file.
//!
//! The API is listed in the README (`GET /api/state`, `/api/image.png`, `/api/image.exr`,
//! `/api/bvh`, `/api/stream`; `POST /api/settings`, `/api/camera`, `/api/autofocus`,
//! `/api/restart`, `/api/save`).

pub mod display;

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::film::{Cell, Film, FilmPixel, Tile};
use crate::integrator::Direct;
use crate::io::image::Image;
use crate::io::tev::TevStream;
use crate::render::{new_film, render, render_into, Control, RenderOptions};
use crate::sampling::sampler::SamplerKind;
use crate::scene::Scene;
use axum::body::Bytes;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{DefaultBodyLimit, Query, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use display::{BvhView, Display, Figures, Mode};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::net::{IpAddr, SocketAddr};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// Largest request body or WebSocket message accepted, bytes.
pub const MAX_BODY: usize = 16 * 1024;
/// How long after the latest camera move marked `preview` the viewer keeps rendering previews.
pub const PREVIEW_HOLD: Duration = Duration::from_millis(300);
/// Time a preview frame should take to render; the preview resolution adapts to it.
pub const PREVIEW_FRAME: Duration = Duration::from_millis(50);
/// Most bounces of a preview.
pub const PREVIEW_DEPTH: u32 = 2;
/// Time between two displays of a pass in progress.
pub const REFRESH: Duration = Duration::from_millis(250);
/// Largest factor by which a preview's resolution is divided.
const PREVIEW_MAX_SCALE: u32 = 16;

/// What the user can change while viewing. Every field is range-checked by [`Settings::apply`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    /// Target samples per pixel (CS184 keys `]` and `[`).
    pub spp: u32,
    /// Maximum ray depth (`.` and `,`).
    pub max_depth: u32,
    /// Light samples (`=` and `-`).
    pub light_samples: u32,
    /// Hemisphere sampling for direct light (`h`); it overrides `estimator`.
    pub hemisphere: bool,
    /// Thin-lens radius (`k` and `l`).
    pub lens_radius: f32,
    /// Focal distance (`;` and `'`).
    pub focal_distance: f32,
    /// The sampler: `sobol`, `zsobol` or `independent`.
    pub sampler: String,
    /// The direct-light estimator: `mis`, `light` or `bsdf`.
    pub estimator: String,
    /// The cell rendered (`C`): left, top, width, height in pixels; `None` is the whole frame.
    pub cell: Option<[u32; 4]>,
}

/// A partial update of [`Settings`] as a client sends it. A `cell` of zero width or height
/// means the whole frame.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SettingsUpdate {
    spp: Option<u32>,
    max_depth: Option<u32>,
    light_samples: Option<u32>,
    hemisphere: Option<bool>,
    lens_radius: Option<f32>,
    focal_distance: Option<f32>,
    sampler: Option<String>,
    estimator: Option<String>,
    cell: Option<[u32; 4]>,
}

/// The estimator names of [`Settings::estimator`].
const ESTIMATORS: [(&str, Direct); 3] = [
    ("mis", Direct::Mis),
    ("light", Direct::Light),
    ("bsdf", Direct::Bsdf),
];

impl Settings {
    /// The settings with `u` applied, or the reason it is out of range; `frame` is the image
    /// size that a cell must lie in.
    pub fn apply(
        &self,
        u: &SettingsUpdate,
        frame: (u32, u32),
    ) -> std::result::Result<Settings, String> {
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
        if let Some(v) = &u.sampler {
            if !SamplerKind::ALL.iter().any(|k| k.name() == v) {
                return Err("sampler must be sobol, zsobol or independent".into());
            }
            s.sampler = v.clone();
        }
        if let Some(v) = &u.estimator {
            if !ESTIMATORS.iter().any(|(n, _)| n == v) {
                return Err("estimator must be mis, light or bsdf".into());
            }
            s.estimator = v.clone();
        }
        if let Some([x, y, w, h]) = u.cell {
            s.cell = if w == 0 || h == 0 {
                None
            } else if x as u64 + w as u64 <= frame.0 as u64 && y as u64 + h as u64 <= frame.1 as u64
            {
                Some([x, y, w, h])
            } else {
                return Err(format!(
                    "the cell {x} {y} {w} {h} is not inside the {}x{} frame",
                    frame.0, frame.1
                ));
            };
        }
        Ok(s)
    }

    /// The render options of these settings over the command line's `base`.
    fn options(&self, base: &RenderOptions) -> RenderOptions {
        let mut o = base.clone();
        o.spp = self.spp;
        o.integrator.max_depth = self.max_depth;
        o.integrator.light_samples = self.light_samples;
        o.integrator.direct = if self.hemisphere {
            Direct::Hemisphere
        } else {
            ESTIMATORS
                .iter()
                .find(|(n, _)| *n == self.estimator)
                .map_or(Direct::Mis, |e| e.1)
        };
        o.sampler = SamplerKind::ALL
            .into_iter()
            .find(|k| k.name() == self.sampler)
            .unwrap_or_default();
        o.cell = self.cell.map(|[x, y, w, h]| Cell { x, y, w, h });
        // The viewer renders uniform passes of the whole sample range.
        o.adaptive = None;
        o.adaptive_budget = false;
        o.time_limit = None;
        o.sample_range = None;
        o
    }
}

/// Where and how the server runs.
#[derive(Clone, Debug, Default)]
pub struct ViewConfig {
    /// Address to bind (loopback unless the user says otherwise).
    pub host: Option<IpAddr>,
    /// Port; 0 picks a free one.
    pub port: u16,
    /// Directory where `s` and `d` save files (under names the server chooses).
    pub out_dir: std::path::PathBuf,
    /// tev to stream every full-resolution image to (`HOST:PORT`), if any.
    pub display_server: Option<String>,
}

/// The state the render thread publishes and the server reads.
struct Published {
    settings: Settings,
    /// The camera (its lens fields follow `settings`).
    camera: Camera,
    /// The camera at start (Space returns to it).
    home: Camera,
    /// Bumped by every change that needs a new film; the render thread restarts when it differs.
    generation: u64,
    /// Passes (samples per pixel) in the latest image.
    passes: u32,
    /// Images published since the start.
    frame: u64,
    image: Option<Arc<Image>>,
    /// Per-pixel figures of the latest full-resolution image (none for a preview).
    figures: Option<Arc<Figures>>,
    /// Whether the latest image is a preview (lower resolution, shallower paths).
    preview: bool,
    /// Previews are rendered until then (set by camera moves marked `preview`).
    preview_until: Option<Instant>,
    /// Samples per second of the latest pass.
    samples_per_sec: f64,
    /// When the current film was started.
    started: Instant,
    quit: bool,
}

/// A PNG already encoded for a frame and a display.
type CachedPng = (u64, (Mode, u32), Bytes);

struct Shared {
    token: String,
    /// The scene's geometry, for autofocus queries (the render thread has its own copy).
    scene: Arc<Scene>,
    /// CS184's BVH view over the scene.
    bvh: BvhView,
    /// The frame size, pixels.
    size: (u32, u32),
    out_dir: std::path::PathBuf,
    state: Mutex<Published>,
    wake: Condvar,
    /// Stops the running pass (a settings change or shutdown).
    stop: AtomicBool,
    /// The number of the latest frame, for the WebSocket streams.
    frames: tokio::sync::watch::Sender<u64>,
    /// Set when the viewer shuts down (ends the WebSocket streams).
    shutdown: tokio::sync::watch::Sender<bool>,
    png: Mutex<Option<CachedPng>>,
    tev: Option<TevStream>,
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
        self.shared.shutdown.send_replace(true);
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
    let estimator = ESTIMATORS
        .iter()
        .find(|(_, d)| *d == opts.integrator.direct)
        .map_or("mis", |e| e.0);
    let settings = Settings {
        spp: opts.spp,
        max_depth: opts.integrator.max_depth,
        light_samples: opts.integrator.light_samples,
        hemisphere: opts.integrator.direct == Direct::Hemisphere,
        lens_radius: scene.camera.lens_radius,
        focal_distance: scene.camera.focal_distance,
        sampler: opts.sampler.name().to_string(),
        estimator: estimator.to_string(),
        cell: opts.cell.map(|c| [c.x, c.y, c.w, c.h]),
    };
    let size = (opts.width, opts.height);
    if size.0 == 0 || size.1 == 0 || opts.spp == 0 {
        return Err(Error::Usage(
            "image size and sample count must be positive".into(),
        ));
    }
    let shared = Arc::new(Shared {
        token: new_token()?,
        bvh: BvhView::new(&scene),
        scene: Arc::new(scene.clone()),
        size,
        out_dir: cfg.out_dir.clone(),
        state: Mutex::new(Published {
            settings,
            camera: scene.camera.clone(),
            home: scene.camera.clone(),
            generation: 0,
            passes: 0,
            frame: 0,
            image: None,
            figures: None,
            preview: false,
            preview_until: None,
            samples_per_sec: 0.0,
            started: Instant::now(),
            quit: false,
        }),
        wake: Condvar::new(),
        stop: AtomicBool::new(false),
        frames: tokio::sync::watch::Sender::new(0),
        shutdown: tokio::sync::watch::Sender::new(false),
        png: Mutex::new(None),
        tev: cfg
            .display_server
            .as_deref()
            .map(|a| TevStream::start(a, &scene.name, size.0, size.1)),
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
    let addr = SocketAddr::new(cfg.host.unwrap_or([127, 0, 0, 1].into()), cfg.port);
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
        .route("/api/camera", post(camera_post))
        .route("/api/autofocus", post(autofocus_post))
        .route("/api/restart", post(restart_post))
        .route("/api/save", post(save_post))
        .route("/api/bvh", get(bvh_get))
        .route("/api/stream", get(stream))
        .layer(DefaultBodyLimit::max(MAX_BODY))
        .layer(axum::middleware::from_fn(refuse_long_bodies))
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

/// The frame-sized image of `film` over `backdrop` (what the frame showed before a cell was
/// chosen; black without one), with its per-pixel figures.
fn compose(film: &Film, backdrop: Option<&Image>, (w, h): (u32, u32)) -> (Image, Figures) {
    let (w, h) = (w as usize, h as usize);
    let cell = film.cell();
    let mut img = backdrop
        .filter(|b| (b.width, b.height) == (w, h))
        .cloned()
        .unwrap_or_else(|| Image::new(w, h));
    let mut fig = Figures {
        rate: vec![0; w * h],
        variance: vec![0.0; w * h],
    };
    for (p, px) in film.row_major() {
        let (x, y) = (
            cell.x as usize + p % cell.w as usize,
            cell.y as usize + p / cell.w as usize,
        );
        let q = y * w + x;
        img.pixels[q] = px.mean() + film.light_mean(p);
        fig.rate[q] = px.n;
        fig.variance[q] = if px.n > 0 {
            (px.rel_variance() / px.n as f64) as f32
        } else {
            0.0
        };
    }
    (img, fig)
}

/// The render thread: previews while the camera is dragged, otherwise passes into a film
/// until the target, a new film on every change that needs one.
fn render_loop(mut scene: Scene, base: RenderOptions, shared: &Shared) {
    let mut seen = u64::MAX;
    let mut preview_seen = u64::MAX;
    let mut scale = 4u32;
    let mut film: Option<Film> = None;
    let mut opts = base.clone();
    // The latest whole-frame image, shown around a cell.
    let mut backdrop: Option<Arc<Image>> = None;
    loop {
        let (settings, generation, camera, previewing) = {
            let mut st = shared.lock();
            loop {
                if st.quit {
                    return;
                }
                let now = Instant::now();
                if let Some(until) = st.preview_until.filter(|&t| t > now) {
                    if st.generation != preview_seen {
                        break;
                    }
                    st = shared
                        .wake
                        .wait_timeout(st, until - now)
                        .unwrap_or_else(|e| e.into_inner())
                        .0;
                    continue;
                }
                let done = film.as_ref().is_some_and(|f| {
                    st.generation == seen && st.passes >= st.settings.spp && f.samples() > 0
                });
                if !done {
                    break;
                }
                st = shared.wake.wait(st).unwrap_or_else(|e| e.into_inner());
            }
            let previewing = st.preview_until.is_some_and(|t| t > Instant::now());
            (
                st.settings.clone(),
                st.generation,
                st.camera.clone(),
                previewing,
            )
        };
        let mut cam = camera;
        cam.lens_radius = settings.lens_radius;
        cam.focal_distance = settings.focal_distance;
        if previewing {
            preview_seen = generation;
            // A preview: the whole frame at 1/scale of the resolution (the same view: the
            // image plane's distance in pixels scales with it), one sample, short paths.
            let mut p = settings.options(&base);
            p.cell = None;
            p.width = base.width.div_ceil(scale).max(1);
            p.height = base.height.div_ceil(scale).max(1);
            p.spp = 1;
            p.integrator.max_depth = p.integrator.max_depth.min(PREVIEW_DEPTH);
            p.integrator.light_samples = 1;
            cam.focal_px *= p.width as f32 / base.width as f32;
            scene.camera = cam;
            let t0 = Instant::now();
            let Ok((img, _)) = render(&scene, &p, &|_, _| {}) else {
                return;
            };
            let took = t0.elapsed();
            if took > PREVIEW_FRAME && scale < PREVIEW_MAX_SCALE {
                scale *= 2;
            } else if took * 5 < PREVIEW_FRAME && scale > 1 {
                scale /= 2;
            }
            // Shown even if the camera has moved on meanwhile (it is the latest preview; the
            // next one follows at once), but not over a full pass of a later release.
            let mut st = shared.lock();
            if st.generation == generation || st.preview_until.is_some() {
                st.image = Some(Arc::new(img));
                st.figures = None;
                st.preview = true;
                st.passes = 0;
                st.frame += 1;
                let f = st.frame;
                drop(st);
                shared.frames.send_replace(f);
            }
            continue;
        }
        if generation != seen || film.is_none() {
            seen = generation;
            shared.stop.store(false, Ordering::SeqCst);
            opts = settings.options(&base);
            if opts.cell.is_none() {
                backdrop = None;
            }
            scene.camera = cam;
            film = new_film(&opts).ok();
            shared.lock().started = Instant::now();
        }
        // Only the target may have changed since the film was started (raising it keeps the
        // film: each pixel's samples do not depend on the target with these samplers).
        opts.spp = settings.spp;
        let Some(f) = film.as_mut() else {
            return;
        };
        // One pass: a time limit of zero stops after the first pass of one sample per pixel.
        let mut pass = opts.clone();
        pass.time_limit = Some(0.0);
        // While the pass runs, its finished tiles are shown every REFRESH over the image of
        // the passes before (a long pass still refreshes the display).
        let before = {
            let st = shared.lock();
            st.image
                .clone()
                .filter(|_| st.generation == seen && !st.preview)
        };
        let start = match before {
            Some(img)
                if (img.width, img.height) == (shared.size.0 as usize, shared.size.1 as usize) =>
            {
                (*img).clone()
            }
            _ => compose(f, backdrop.as_deref(), shared.size).0,
        };
        let live = Mutex::new((start, Instant::now()));
        let on_tile = |c: Cell, t: &Tile, px: &[FilmPixel]| {
            let mut g = live.lock().unwrap_or_else(|e| e.into_inner());
            let w = shared.size.0 as usize;
            for (i, p) in px.iter().enumerate().take((t.w * t.h) as usize) {
                let (x, y) = t.frame_xy(c, i);
                if let Some(q) = g.0.pixels.get_mut(y as usize * w + x as usize) {
                    *q = p.mean();
                }
            }
            if g.1.elapsed() >= REFRESH {
                g.1 = Instant::now();
                let img = Arc::new(g.0.clone());
                drop(g);
                let mut st = shared.lock();
                if st.generation == seen {
                    st.image = Some(img);
                    st.preview = false;
                    st.frame += 1;
                    let f = st.frame;
                    drop(st);
                    shared.frames.send_replace(f);
                }
            }
        };
        let ctl = Control {
            tile_done: Some(&on_tile),
            ..Control::new(&shared.stop, &|_, _| {})
        };
        let Ok(stats) = render_into(&scene, &pass, f, ctl) else {
            return;
        };
        let passes = f.pixels().iter().map(|p| p.n).min().unwrap_or(0);
        let (img, fig) = compose(f, backdrop.as_deref(), shared.size);
        let img = Arc::new(img);
        if opts.cell.is_none() {
            backdrop = Some(img.clone());
            if let Some(t) = &shared.tev {
                t.image(&img);
            }
        }
        let mut st = shared.lock();
        if st.generation == seen {
            st.image = Some(img);
            st.figures = Some(Arc::new(fig));
            st.preview = false;
            st.passes = passes;
            st.frame += 1;
            st.samples_per_sec = stats.samples as f64 / stats.seconds.max(1e-9);
            let f = st.frame;
            drop(st);
            shared.frames.send_replace(f);
        }
    }
}

type Shd = State<Arc<Shared>>;
type Q = Query<HashMap<String, String>>;

/// Answers 413 at once to a request whose announced length is over [`MAX_BODY`], before any
/// of its body is read (bodies without a length are cut off by the body limit instead).
async fn refuse_long_bodies(req: axum::extract::Request, next: axum::middleware::Next) -> Response {
    let announced = req
        .headers()
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.trim().parse::<u64>().ok());
    if announced.is_some_and(|n| n > MAX_BODY as u64) {
        return (StatusCode::PAYLOAD_TOO_LARGE, "request body too large\n").into_response();
    }
    next.run(req).await
}

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

fn refuse(code: StatusCode, msg: impl std::fmt::Display) -> Response {
    (code, format!("{msg}\n")).into_response()
}

async fn page(State(s): Shd, Query(q): Q, h: HeaderMap) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    Html(PAGE).into_response()
}

/// The state as JSON.
#[derive(Serialize)]
struct StateJson {
    scene: String,
    settings: Settings,
    passes: u32,
    frame: u64,
    /// The frame size (a preview image is smaller).
    width: u32,
    height: u32,
    preview: bool,
    /// The size of the latest image: the frame's, or a preview's.
    image_size: [usize; 2],
    samples_per_sec: f64,
    elapsed: f64,
    bvh_nodes: usize,
    /// The camera: `position`, `target` and `up`, world space.
    camera: serde_json::Value,
}

fn state_json(s: &Shared) -> StateJson {
    let st = s.lock();
    StateJson {
        scene: s.scene.name.clone(),
        settings: st.settings.clone(),
        passes: st.passes,
        frame: st.frame,
        width: s.size.0,
        height: s.size.1,
        preview: st.preview,
        image_size: st.image.as_ref().map_or([0, 0], |i| [i.width, i.height]),
        samples_per_sec: st.samples_per_sec,
        elapsed: st.started.elapsed().as_secs_f64(),
        bvh_nodes: s.bvh.len(),
        camera: serde_json::json!({
            "position": st.camera.pos.to_array(),
            "target": st.camera.target.to_array(),
            "up": st.camera.up.to_array(),
        }),
    }
}

async fn state(State(s): Shd, Query(q): Q, h: HeaderMap) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    Json(state_json(&s)).into_response()
}

async fn settings_post(State(s): Shd, Query(q): Q, h: HeaderMap, body: Bytes) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    let update: SettingsUpdate = match serde_json::from_slice(&body) {
        Ok(u) => u,
        Err(e) => return refuse(StatusCode::BAD_REQUEST, format!("bad settings: {e}")),
    };
    let mut st = s.lock();
    match st.settings.apply(&update, s.size) {
        Ok(new) => {
            if new != st.settings {
                // Raising the target keeps the film where the samples do not depend on it.
                let only_target = Settings {
                    spp: new.spp,
                    ..st.settings.clone()
                } == new;
                let keep = only_target
                    && new.sampler != SamplerKind::ZSobol.name()
                    && new.spp >= st.passes
                    && !st.preview;
                st.settings = new;
                if keep {
                    s.wake.notify_all();
                } else {
                    restart(&s, &mut st);
                }
            }
            StatusCode::NO_CONTENT.into_response()
        }
        Err(msg) => refuse(StatusCode::UNPROCESSABLE_ENTITY, msg),
    }
}

/// Bumps the generation: the render thread starts a new film.
fn restart(s: &Shared, st: &mut Published) {
    st.generation += 1;
    st.passes = 0;
    s.stop.store(true, Ordering::SeqCst);
    s.wake.notify_all();
}

/// A camera move as a client sends it: orbit by degrees (left-drag), pan by fractions of the
/// view (right-drag), zoom by a factor on the distance (wheel), or back to the start (Space).
/// `preview: true` marks a move in a drag: previews are rendered until [`PREVIEW_HOLD`] after
/// the latest such move (or a move without it, such as the release, which renders at once).
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraMove {
    orbit: Option<[f32; 2]>,
    pan: Option<[f32; 2]>,
    zoom: Option<f32>,
    reset: Option<bool>,
    preview: Option<bool>,
}

/// The camera after `m`, or why `m` is out of range.
fn moved(c: &Camera, home: &Camera, m: &CameraMove) -> std::result::Result<Camera, String> {
    use glam::{Quat, Vec3};
    let finite = |v: &[f32]| v.iter().all(|x| x.is_finite() && x.abs() <= 1e4);
    if m.reset == Some(true) {
        return Ok(home.clone());
    }
    let (mut pos, mut target) = (c.pos, c.target);
    if let Some(o) = m.orbit {
        if !finite(&o) {
            return Err("orbit must be two finite angles in degrees".into());
        }
        let off = pos - target;
        let yaw = Quat::from_axis_angle(Vec3::Y, -o[0].to_radians());
        let off = yaw * off;
        let right = off.cross(Vec3::Y).normalize_or(Vec3::X);
        let pitched = Quat::from_axis_angle(right, o[1].to_radians()) * off;
        // Stop short of the poles, where the view would flip.
        let off = if pitched.normalize_or(Vec3::Z).y.abs() < 0.995 {
            pitched
        } else {
            off
        };
        pos = target + off;
    }
    if let Some(p) = m.pan {
        if !finite(&p) {
            return Err("pan must be two finite fractions of the view".into());
        }
        let d = (pos - target).length();
        let shift = c.right * (-p[0] * d) + c.up * (p[1] * d);
        pos += shift;
        target += shift;
    }
    if let Some(z) = m.zoom {
        if !(z.is_finite() && (0.01..=100.0).contains(&z)) {
            return Err("zoom must be a factor in 0.01..=100".into());
        }
        pos = target + (pos - target) * z;
    }
    if (pos, target) == (c.pos, c.target) {
        return Ok(c.clone());
    }
    let mut out = Camera::look_at(pos, target, c.hfov_deg, c.vfov_deg);
    out.lens_radius = c.lens_radius;
    out.focal_distance = c.focal_distance;
    (out.pos.is_finite() && (out.pos - out.target).length() > 1e-6)
        .then_some(out)
        .ok_or_else(|| "the move leaves no view".to_string())
}

async fn camera_post(State(s): Shd, Query(q): Q, h: HeaderMap, body: Bytes) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    let m: CameraMove = match serde_json::from_slice(&body) {
        Ok(m) => m,
        Err(e) => return refuse(StatusCode::BAD_REQUEST, format!("bad camera move: {e}")),
    };
    let mut st = s.lock();
    match moved(&st.camera, &st.home, &m) {
        Ok(c) => {
            st.camera = c;
            st.preview_until = (m.preview == Some(true)).then(|| Instant::now() + PREVIEW_HOLD);
            restart(&s, &mut st);
            StatusCode::NO_CONTENT.into_response()
        }
        Err(msg) => refuse(StatusCode::UNPROCESSABLE_ENTITY, msg),
    }
}

/// A pixel of the image (column, row from the top-left corner).
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PixelPos {
    x: f32,
    y: f32,
}

async fn autofocus_post(State(s): Shd, Query(q): Q, h: HeaderMap, body: Bytes) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    let p: PixelPos = match serde_json::from_slice(&body) {
        Ok(p) => p,
        Err(e) => return refuse(StatusCode::BAD_REQUEST, format!("bad pixel: {e}")),
    };
    let (w, hgt) = s.size;
    if !(p.x.is_finite() && p.y.is_finite() && p.x >= 0.0 && p.y >= 0.0)
        || p.x >= w as f32
        || p.y >= hgt as f32
    {
        return refuse(StatusCode::UNPROCESSABLE_ENTITY, "pixel outside the image");
    }
    let mut st = s.lock();
    // CS184's autofocus: the depth along the view direction of what the pixel centre sees.
    let mut cam = st.camera.clone();
    cam.lens_radius = 0.0;
    let ray = cam.ray(
        p.x.floor() + 0.5,
        p.y.floor() + 0.5,
        w,
        hgt,
        glam::Vec2::ZERO,
    );
    let Some(hit) = s.scene.intersect(&ray) else {
        return refuse(StatusCode::UNPROCESSABLE_ENTITY, "nothing under that pixel");
    };
    let depth = hit.t * ray.d.dot(cam.forward);
    if !(depth.is_finite() && depth > 0.0) {
        return refuse(StatusCode::UNPROCESSABLE_ENTITY, "nothing in front there");
    }
    st.settings.focal_distance = depth;
    restart(&s, &mut st);
    Json(serde_json::json!({ "focal_distance": depth })).into_response()
}

async fn restart_post(State(s): Shd, Query(q): Q, h: HeaderMap) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    let mut st = s.lock();
    restart(&s, &mut st);
    StatusCode::NO_CONTENT.into_response()
}

/// What `POST /api/save` writes: `image` (`s`: PNG, linear EXR and the rate image),
/// `camera` (`d`: the CS184 camera file); both without a body.
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct SaveRequest {
    only: Option<SaveWhat>,
}

#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(rename_all = "lowercase")]
enum SaveWhat {
    Image,
    Camera,
}

/// `s` and `d`: files into the output directory under the next free `NAME_N` (the client
/// names nothing).
async fn save_post(State(s): Shd, Query(q): Q, h: HeaderMap, body: Bytes) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    let req: SaveRequest = if body.is_empty() {
        SaveRequest::default()
    } else {
        match serde_json::from_slice(&body) {
            Ok(r) => r,
            Err(e) => return refuse(StatusCode::BAD_REQUEST, format!("bad save request: {e}")),
        }
    };
    let (img, fig, preview, cam) = {
        let st = s.lock();
        let mut cam = st.camera.clone();
        cam.lens_radius = st.settings.lens_radius;
        cam.focal_distance = st.settings.focal_distance;
        (st.image.clone(), st.figures.clone(), st.preview, cam)
    };
    let (image, camera) = match req.only {
        None => (true, true),
        Some(SaveWhat::Image) => (true, false),
        Some(SaveWhat::Camera) => (false, true),
    };
    let img = match img {
        Some(img) if !preview => Some(img),
        _ if image => {
            return refuse(
                StatusCode::SERVICE_UNAVAILABLE,
                "no full-resolution image yet",
            )
        }
        _ => None,
    };
    let name = s.scene.name.replace(
        |c: char| !c.is_ascii_alphanumeric() && c != '_' && c != '-',
        "_",
    );
    let taken = |n: u32| {
        ["png", "exr", "cam.txt"]
            .iter()
            .any(|e| s.out_dir.join(format!("{name}_{n}.{e}")).exists())
    };
    let Some(n) = (1..100_000).find(|&n| !taken(n)) else {
        return refuse(StatusCode::CONFLICT, "no free file name left");
    };
    let stem = s.out_dir.join(format!("{name}_{n}"));
    let (w, hgt) = s.size;
    let mut files = Vec::new();
    let result = (|| -> Result<()> {
        if let Some(img) = img.as_ref().filter(|_| image) {
            for ext in ["png", "exr"] {
                let f = stem.with_extension(ext);
                img.save(&f)?;
                files.push(f);
            }
            if let Some(fig) = &fig {
                let f = s.out_dir.join(format!("{name}_{n}_rate.png"));
                crate::io::image::sample_rate_image(&fig.rate, w as usize, hgt as usize)
                    .save(&f)?;
                files.push(f);
            }
        }
        if camera {
            let f = stem.with_extension("cam.txt");
            cam.save_cs184(&f, w, hgt)?;
            files.push(f);
        }
        Ok(())
    })();
    match result {
        Ok(()) => Json(serde_json::json!({
            "files": files.iter().filter_map(|f| f.file_name()).map(|f| f.to_string_lossy()).collect::<Vec<_>>()
        }))
        .into_response(),
        Err(e) => refuse(StatusCode::INTERNAL_SERVER_ERROR, e),
    }
}

/// The display a client asks for in a query (`exposure`, `mode`), or why it is malformed.
fn display_of(q: &HashMap<String, String>) -> std::result::Result<Display, String> {
    let mut d = Display::default();
    if let Some(e) = q.get("exposure") {
        d.exposure = e
            .parse()
            .map_err(|_| format!("exposure is not a number: {e}"))?;
    }
    if let Some(m) = q.get("mode") {
        d.mode = serde_json::from_value(serde_json::Value::String(m.clone()))
            .map_err(|_| "mode must be colour, rate or variance".to_string())?;
    }
    d.validate()?;
    Ok(d)
}

/// The latest frame as a PNG shown as `d`, encoded once per frame and display.
async fn encoded_png(s: &Arc<Shared>, d: Display) -> Option<(u64, Bytes)> {
    let (frame, img, fig) = {
        let st = s.lock();
        (st.frame, st.image.clone()?, st.figures.clone())
    };
    if let Some((f, k, bytes)) = s.png.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
        if *f == frame && *k == d.key() {
            return Some((frame, bytes.clone()));
        }
    }
    let bytes =
        tokio::task::spawn_blocking(move || display::shown(&img, fig.as_deref(), &d).encode("png"))
            .await
            .ok()?
            .ok()?;
    let bytes = Bytes::from(bytes);
    *s.png.lock().unwrap_or_else(|e| e.into_inner()) = Some((frame, d.key(), bytes.clone()));
    Some((frame, bytes))
}

async fn image_png(State(s): Shd, Query(q): Q, h: HeaderMap) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    let d = match display_of(&q) {
        Ok(d) => d,
        Err(msg) => return refuse(StatusCode::BAD_REQUEST, msg),
    };
    match encoded_png(&s, d).await {
        Some((_, bytes)) => ([(header::CONTENT_TYPE, "image/png")], bytes).into_response(),
        None => refuse(StatusCode::SERVICE_UNAVAILABLE, "no image yet"),
    }
}

async fn image_exr(State(s): Shd, Query(q): Q, h: HeaderMap) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    let img = s.lock().image.clone();
    let Some(img) = img else {
        return refuse(StatusCode::SERVICE_UNAVAILABLE, "no image yet");
    };
    match img.encode("exr") {
        Ok(bytes) => ([(header::CONTENT_TYPE, "image/x-exr")], bytes).into_response(),
        Err(e) => refuse(StatusCode::INTERNAL_SERVER_ERROR, e),
    }
}

/// CS184's BVH view: node `node` (default the root) with its children, their primitive
/// counts and their boxes projected through the current camera.
async fn bvh_get(State(s): Shd, Query(q): Q, h: HeaderMap) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    let node = match q.get("node").map(|n| n.parse::<u32>()) {
        None => 0,
        Some(Ok(n)) => n,
        Some(Err(_)) => return refuse(StatusCode::BAD_REQUEST, "node must be a node number"),
    };
    let cam = s.lock().camera.clone();
    match s.bvh.node(node, &cam, s.size) {
        Some(v) => Json(v).into_response(),
        None => refuse(StatusCode::NOT_FOUND, format!("no BVH node {node}")),
    }
}

/// Whether a WebSocket upgrade comes from the page's own origin (browsers always send
/// `Origin`; other clients may omit it).
fn same_origin(h: &HeaderMap) -> bool {
    let Some(origin) = h.get(header::ORIGIN) else {
        return true;
    };
    let host = h.get(header::HOST).and_then(|v| v.to_str().ok());
    match (origin.to_str().ok(), host) {
        (Some(o), Some(host)) => o == format!("http://{host}"),
        _ => false,
    }
}

/// `GET /api/stream`: a WebSocket that sends, for each new frame, a text message with the
/// state (as `/api/state`) and a binary message with the PNG; the state alone every half
/// second between frames. The client may send a text message `{"exposure": stops, "mode":
/// "colour"|"rate"|"variance"}` to change what its frames show (errors come back as
/// `{"error": …}`).
async fn stream(
    State(s): Shd,
    Query(q): Q,
    h: HeaderMap,
    ws: std::result::Result<
        WebSocketUpgrade,
        axum::extract::ws::rejection::WebSocketUpgradeRejection,
    >,
) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    if !same_origin(&h) {
        return refuse(StatusCode::FORBIDDEN, "cross-origin WebSocket refused");
    }
    match ws {
        Ok(ws) => ws
            .max_message_size(MAX_BODY)
            .max_frame_size(MAX_BODY)
            .on_upgrade(move |sock| frames(sock, s)),
        Err(e) => e.into_response(),
    }
}

async fn frames(mut sock: WebSocket, s: Arc<Shared>) {
    let mut rx = s.frames.subscribe();
    let mut quit = s.shutdown.subscribe();
    let mut display = Display::default();
    let mut sent: Option<(u64, (Mode, u32))> = None;
    let mut tick = tokio::time::interval(Duration::from_millis(500));
    loop {
        let frame = *rx.borrow_and_update();
        if sent != Some((frame, display.key())) {
            if let Some((f, png)) = encoded_png(&s, display).await {
                let text = serde_json::to_string(&state_json(&s)).unwrap_or_default();
                if sock.send(Message::Text(text.into())).await.is_err()
                    || sock.send(Message::Binary(png)).await.is_err()
                {
                    return;
                }
                sent = Some((f, display.key()));
            }
        }
        tokio::select! {
            r = rx.changed() => if r.is_err() { return },
            _ = quit.changed() => return,
            m = sock.recv() => match m {
                None | Some(Err(_)) | Some(Ok(Message::Close(_))) => return,
                Some(Ok(Message::Text(t))) => {
                    let parsed = serde_json::from_str::<Display>(&t)
                        .map_err(|e| e.to_string())
                        .and_then(|d| d.validate().map(|()| d));
                    match parsed {
                        Ok(d) => display = d,
                        Err(e) => {
                            let msg = serde_json::json!({ "error": e }).to_string();
                            if sock.send(Message::Text(msg.into())).await.is_err() {
                                return;
                            }
                        }
                    }
                }
                Some(Ok(_)) => {}
            },
            _ = tick.tick() => {
                let text = serde_json::to_string(&state_json(&s)).unwrap_or_default();
                if sock.send(Message::Text(text.into())).await.is_err() {
                    return;
                }
            }
        }
    }
}

/// The page (see `page.html`): the image streamed over the WebSocket, a status line, a side
/// panel with every setting, CS184's keys and the mouse.
const PAGE: &str = include_str!("page.html");
