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

use crate::camera::Camera;
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
    /// Directory where `s` and `d` save files (under names the server chooses).
    pub out_dir: std::path::PathBuf,
}

/// The state the render thread publishes and the server reads.
struct Published {
    settings: Settings,
    /// The camera (its lens fields follow `settings`).
    camera: Camera,
    /// The camera at start (Space returns to it).
    home: Camera,
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
    /// The scene's geometry, for autofocus queries (the render thread has its own copy).
    scene: Arc<Scene>,
    out_dir: std::path::PathBuf,
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
        scene: Arc::new(scene.clone()),
        out_dir: cfg.out_dir.clone(),
        state: Mutex::new(Published {
            settings,
            camera: scene.camera.clone(),
            home: scene.camera.clone(),
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
        .route("/api/camera", post(camera_post))
        .route("/api/autofocus", post(autofocus_post))
        .route("/api/restart", post(restart_post))
        .route("/api/save", post(save_post))
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

/// The render thread: passes into a film until the target, a new film on every change.
fn render_loop(mut scene: Scene, base: RenderOptions, shared: &Shared) {
    let mut seen = u64::MAX;
    let mut film: Option<Film> = None;
    let mut opts = base.clone();
    loop {
        let (settings, generation, camera) = {
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
            (st.settings.clone(), st.generation, st.camera.clone())
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
            scene.camera = camera;
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
        let ctl = Control::new(&shared.stop, &|_, _| {});
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
                restart(&s, &mut st);
            }
            StatusCode::NO_CONTENT.into_response()
        }
        Err(msg) => (StatusCode::UNPROCESSABLE_ENTITY, format!("{msg}\n")).into_response(),
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
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraMove {
    orbit: Option<[f32; 2]>,
    pan: Option<[f32; 2]>,
    zoom: Option<f32>,
    reset: Option<bool>,
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
    let mut out = Camera::look_at(pos, target, c.hfov_deg, c.vfov_deg);
    out.lens_radius = c.lens_radius;
    out.focal_distance = c.focal_distance;
    (out.pos.is_finite() && (out.pos - out.target).length() > 1e-6)
        .then_some(out)
        .ok_or_else(|| "the move leaves no view".to_string())
}

async fn camera_post(
    State(s): Shd,
    Query(q): Query<HashMap<String, String>>,
    h: HeaderMap,
    body: axum::body::Bytes,
) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    let m: CameraMove = match serde_json::from_slice(&body) {
        Ok(m) => m,
        Err(e) => {
            return (StatusCode::BAD_REQUEST, format!("bad camera move: {e}\n")).into_response()
        }
    };
    let mut st = s.lock();
    match moved(&st.camera, &st.home, &m) {
        Ok(c) => {
            st.camera = c;
            restart(&s, &mut st);
            StatusCode::NO_CONTENT.into_response()
        }
        Err(msg) => (StatusCode::UNPROCESSABLE_ENTITY, format!("{msg}\n")).into_response(),
    }
}

/// A pixel of the image (column, row from the top-left corner).
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PixelPos {
    x: f32,
    y: f32,
}

async fn autofocus_post(
    State(s): Shd,
    Query(q): Query<HashMap<String, String>>,
    h: HeaderMap,
    body: axum::body::Bytes,
) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    let p: PixelPos = match serde_json::from_slice(&body) {
        Ok(p) => p,
        Err(e) => return (StatusCode::BAD_REQUEST, format!("bad pixel: {e}\n")).into_response(),
    };
    let mut st = s.lock();
    let (w, hgt) = st.image.as_ref().map_or((0, 0), |i| (i.width, i.height));
    if !(p.x.is_finite() && p.y.is_finite() && p.x >= 0.0 && p.y >= 0.0)
        || p.x >= w as f32
        || p.y >= hgt as f32
    {
        return (
            StatusCode::UNPROCESSABLE_ENTITY,
            "pixel outside the image\n",
        )
            .into_response();
    }
    // CS184's autofocus: the depth along the view direction of what the pixel centre sees.
    let mut cam = st.camera.clone();
    cam.lens_radius = 0.0;
    let ray = cam.ray(
        p.x.floor() + 0.5,
        p.y.floor() + 0.5,
        w as u32,
        hgt as u32,
        glam::Vec2::ZERO,
    );
    let Some(hit) = s.scene.intersect(&ray) else {
        return (
            StatusCode::UNPROCESSABLE_ENTITY,
            "nothing under that pixel\n",
        )
            .into_response();
    };
    let depth = hit.t * ray.d.dot(cam.forward);
    if !(depth.is_finite() && depth > 0.0) {
        return (StatusCode::UNPROCESSABLE_ENTITY, "nothing in front there\n").into_response();
    }
    st.settings.focal_distance = depth;
    restart(&s, &mut st);
    Json(serde_json::json!({ "focal_distance": depth })).into_response()
}

async fn restart_post(
    State(s): Shd,
    Query(q): Query<HashMap<String, String>>,
    h: HeaderMap,
) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    let mut st = s.lock();
    restart(&s, &mut st);
    StatusCode::NO_CONTENT.into_response()
}

/// `s`: the image as PNG and linear EXR, and `d`: the camera as a CS184 camera file, into the
/// output directory under the next free `NAME_N` (the client names nothing).
async fn save_post(
    State(s): Shd,
    Query(q): Query<HashMap<String, String>>,
    h: HeaderMap,
) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    let (img, cam) = {
        let st = s.lock();
        let mut cam = st.camera.clone();
        cam.lens_radius = st.settings.lens_radius;
        cam.focal_distance = st.settings.focal_distance;
        (st.image.clone(), cam)
    };
    let Some(img) = img else {
        return (StatusCode::SERVICE_UNAVAILABLE, "no image yet\n").into_response();
    };
    let name = s.scene.name.replace(
        |c: char| !c.is_ascii_alphanumeric() && c != '_' && c != '-',
        "_",
    );
    let n = (1..100_000)
        .find(|n| !s.out_dir.join(format!("{name}_{n}.png")).exists())
        .unwrap_or(0);
    let stem = s.out_dir.join(format!("{name}_{n}"));
    let files = [
        stem.with_extension("png"),
        stem.with_extension("exr"),
        stem.with_extension("cam.txt"),
    ];
    let result = img
        .save(&files[0])
        .and_then(|()| img.save(&files[1]))
        .and_then(|()| cam.save_cs184(&files[2], img.width as u32, img.height as u32));
    match result {
        Ok(()) => Json(serde_json::json!({
            "files": files.iter().filter_map(|f| f.file_name()).map(|f| f.to_string_lossy()).collect::<Vec<_>>()
        }))
        .into_response(),
        Err(e) => (StatusCode::INTERNAL_SERVER_ERROR, format!("{e}\n")).into_response(),
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

/// The page: the image refreshed four times a second, a status line, CS184's keys and the
/// mouse (left-drag orbits, right-drag pans, right-click focuses, the wheel zooms).
const PAGE: &str = r#"<!doctype html>
<html><head><meta charset="utf-8"><title>pathtracer view</title>
<style>body{background:#222;color:#ddd;font:14px sans-serif;margin:1em}img{display:block;cursor:grab}#help{display:none;white-space:pre}</style>
</head><body>
<img id="img" alt="render" draggable="false">
<div id="status">starting…</div>
<div id="note"></div>
<div id="help">]/[ samples ×2/÷2   =/- light samples ×2/÷2   ./, depth +1/−1   h hemisphere
k/l lens −/+0.05   ;/' focus −/+0.1   r restart   s save image and camera   Space reset camera
left-drag orbit   right-drag pan   right-click focus there   wheel zoom   ? this help</div>
<script>
const token = new URLSearchParams(location.search).get("token");
const q = "?token=" + token;
const img = document.getElementById("img"), status = document.getElementById("status");
const note = document.getElementById("note"), help = document.getElementById("help");
let frame = -1, st = null;
async function post(path, body) {
  const r = await fetch(path + q, {method: "POST", headers: {"Content-Type": "application/json"}, body: JSON.stringify(body || {})});
  if (!r.ok) note.textContent = await r.text();
  return r;
}
async function tick() {
  try {
    const r = await fetch("/api/state" + q);
    if (r.ok) {
      st = await r.json();
      const s = st.settings;
      status.textContent = `${st.passes} / ${s.spp} spp · ${(st.samples_per_sec / 1e6).toFixed(2)} M samples/s · ${st.elapsed.toFixed(1)} s · depth ${s.max_depth} · light samples ${s.light_samples} · hemisphere ${s.hemisphere ? "on" : "off"} · lens ${s.lens_radius.toFixed(2)} · focus ${s.focal_distance.toFixed(2)}`;
      if (st.frame !== frame) { frame = st.frame; img.src = "/api/image.png" + q + "&frame=" + frame; }
    }
  } catch (e) { status.textContent = "disconnected"; }
  setTimeout(tick, 250);
}
document.addEventListener("keydown", async (e) => {
  if (!st) return;
  const s = st.settings;
  const keys = {
    "]": {spp: Math.min(s.spp * 2, 1 << 20)}, "[": {spp: Math.max(1, s.spp >> 1)},
    "=": {light_samples: Math.min(s.light_samples * 2, 1024)}, "-": {light_samples: Math.max(1, s.light_samples >> 1)},
    ".": {max_depth: s.max_depth + 1}, ",": {max_depth: Math.max(0, s.max_depth - 1)},
    "h": {hemisphere: !s.hemisphere},
    "k": {lens_radius: Math.max(0, s.lens_radius - 0.05)}, "l": {lens_radius: s.lens_radius + 0.05},
    ";": {focal_distance: Math.max(0.01, s.focal_distance - 0.1)}, "'": {focal_distance: s.focal_distance + 0.1},
  };
  if (keys[e.key]) { await post("/api/settings", keys[e.key]); }
  else if (e.key === "r") { await post("/api/restart"); }
  else if (e.key === " ") { e.preventDefault(); await post("/api/camera", {reset: true}); }
  else if (e.key === "s") { const r = await post("/api/save"); if (r.ok) note.textContent = "saved " + (await r.json()).files.join(", "); }
  else if (e.key === "?") { help.style.display = help.style.display === "block" ? "none" : "block"; }
});
let drag = null;
img.addEventListener("contextmenu", (e) => e.preventDefault());
img.addEventListener("mousedown", (e) => { drag = {x: e.clientX, y: e.clientY, button: e.button, moved: false}; });
window.addEventListener("mouseup", async (e) => {
  if (drag && drag.button === 2 && !drag.moved) {
    const r = img.getBoundingClientRect();
    await post("/api/autofocus", {x: (e.clientX - r.left) * img.naturalWidth / r.width, y: (e.clientY - r.top) * img.naturalHeight / r.height});
  }
  drag = null;
});
window.addEventListener("mousemove", async (e) => {
  if (!drag) return;
  const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
  if (Math.abs(dx) + Math.abs(dy) < 3) return;
  drag.moved = true; drag.x = e.clientX; drag.y = e.clientY;
  if (drag.button === 0) await post("/api/camera", {orbit: [dx * 0.3, dy * 0.3]});
  else if (drag.button === 2) await post("/api/camera", {pan: [dx / img.width, dy / img.height]});
});
img.addEventListener("wheel", (e) => { e.preventDefault(); post("/api/camera", {zoom: e.deltaY > 0 ? 1.1 : 1 / 1.1}); }, {passive: false});
tick();
</script></body></html>
"#;
