//! `pathtracer view`: the interactive renderer, served to a browser by the renderer itself.
//!
//! A render thread shares the scene (rendered through its own camera) and owns a `Film`: it adds passes of one sample per pixel
//! (through `render_into`, the one render path) until the target, and starts a new film
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
//! With the `denoise` setting on, the film records denoising features and a third thread
//! denoises the latest finished pass (`denoise_loop`); with it off, the render thread does
//! nothing more than before.
//!
//! The API is listed in `docs/viewer.md` (`GET /api/state`, `/api/image.png`, `/api/image.exr`,
//! `/api/bvh`, `/api/stream`; `POST /api/settings`, `/api/camera`, `/api/autofocus`,
//! `/api/restart`, `/api/save`).

mod denoise_loop;
pub mod display;
mod render_loop;
mod server;
pub mod settings;

pub use settings::{Settings, SettingsUpdate};

use crate::camera::Camera;
use crate::denoise::Denoiser;
use crate::error::{Error, Result};
use crate::io::image::Image;
use crate::io::tev::TevStream;
use crate::render::RenderOptions;
use crate::scene::Scene;
use axum::body::Bytes;
use display::{BvhView, DisplayKey, Figures};
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
    /// The latest finished pass with its features, for the denoise thread (none while the
    /// film records no features).
    to_denoise: Option<Arc<denoise_loop::Input>>,
    /// The denoised image of the current film's latest denoised pass, and its passes.
    denoised: Option<(Arc<Image>, u32)>,
    /// Why denoising failed (OIDN missing or refusing), if it did.
    denoise_error: Option<String>,
    /// When the current film was started.
    started: Instant,
    quit: bool,
}

/// A PNG already encoded for a frame and a display.
type CachedPng = (u64, DisplayKey, Bytes);

struct Shared {
    token: String,
    /// The scene, shared with the render thread (which renders it through its own camera)
    /// and read here for autofocus queries.
    scene: Arc<Scene>,
    /// CS184's BVH view over the scene.
    bvh: BvhView,
    /// The frame size, pixels.
    size: (u32, u32),
    out_dir: std::path::PathBuf,
    state: Mutex<Published>,
    /// Wakes the render thread.
    wake: Condvar,
    /// Wakes the denoise thread.
    denoise_wake: Condvar,
    /// OIDN, loaded the first time denoising is asked for (or why it cannot be).
    denoiser: std::sync::OnceLock<std::result::Result<Denoiser, String>>,
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

    /// OIDN, loaded on first use, or why it cannot be.
    fn denoiser(&self) -> std::result::Result<&Denoiser, String> {
        self.denoiser
            .get_or_init(Denoiser::load)
            .as_ref()
            .map_err(Clone::clone)
    }

    /// Wakes both the render and the denoise thread (the state changed).
    fn notify(&self) {
        self.wake.notify_all();
        self.denoise_wake.notify_all();
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
    denoise: Option<std::thread::JoinHandle<()>>,
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
        self.shared.notify();
        self.shared.shutdown.send_replace(true);
        if let Some(tx) = self.shutdown.take() {
            let _ = tx.send(());
        }
        for h in [self.server.take(), self.render.take(), self.denoise.take()]
            .into_iter()
            .flatten()
        {
            let _ = h.join();
        }
    }
}

/// Starts the render thread, the denoise thread and the server; returns once the server
/// listens. With `opts.denoise`, OIDN must load first.
pub fn start(scene: Scene, opts: RenderOptions, cfg: &ViewConfig) -> Result<Viewer> {
    let scene = Arc::new(scene);
    let settings = Settings::new(&opts, scene.camera.lens_radius, scene.camera.focal_distance);
    let size = (opts.width, opts.height);
    if size.0 == 0 || size.1 == 0 || opts.spp == 0 {
        return Err(Error::Usage(
            "image size and sample count must be positive".into(),
        ));
    }
    let denoiser = std::sync::OnceLock::new();
    if opts.denoise {
        let d = Denoiser::load().map_err(|e| Error::Usage(format!("--denoise: {e}")))?;
        let _ = denoiser.set(Ok(d));
    }
    let shared = Arc::new(Shared {
        token: server::new_token()?,
        bvh: BvhView::new(&scene),
        scene: scene.clone(),
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
            to_denoise: None,
            denoised: None,
            denoise_error: None,
            started: Instant::now(),
            quit: false,
        }),
        wake: Condvar::new(),
        denoise_wake: Condvar::new(),
        denoiser,
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
            .spawn(move || render_loop::render_loop(scene, opts, &shared))
            .map_err(|e| Error::Usage(format!("cannot start the render thread: {e}")))?
    };
    let denoise = {
        let shared = shared.clone();
        std::thread::Builder::new()
            .name("view-denoise".into())
            .spawn(move || denoise_loop::denoise_loop(&shared))
            .map_err(|e| Error::Usage(format!("cannot start the denoise thread: {e}")))?
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
    let app = server::router(shared.clone());
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
        denoise: Some(denoise),
        shutdown: Some(tx),
    })
}
