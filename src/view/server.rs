//! The HTTP server of the viewer (axum): the token check, the page, the state, settings,
//! camera, autofocus, save, image and BVH endpoints, and the WebSocket stream of frames.

use super::display::{self, Display, Mode};
use super::display::{DisplayKey, Figures};
use super::settings::{Refusal, Settings, SettingsUpdate};
use super::{Published, Shared, MAX_BODY, PREVIEW_HOLD};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::io::image::Image;
use crate::sampling::sampler::SamplerKind;
use axum::body::Bytes;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{DefaultBodyLimit, Query, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The server's routes over the viewer's shared state.
pub(super) fn router(shared: Arc<Shared>) -> Router {
    Router::new()
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
        .with_state(shared)
}

/// 128 random bits as 32 hex digits.
pub(super) fn new_token() -> Result<String> {
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
    /// Passes in the latest denoised image (0: none yet).
    denoised_passes: u32,
    /// Why denoising failed, if it did.
    denoise_error: Option<String>,
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
        denoised_passes: match &st.denoised {
            Some((_, passes)) if st.settings.denoise => *passes,
            _ => 0,
        },
        denoise_error: st.denoise_error.clone(),
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
    // OIDN is loaded (once) before the state is locked: it takes a moment.
    if update.turns_on("denoise") {
        let shared = s.clone();
        let loaded = tokio::task::spawn_blocking(move || shared.denoiser().map(|_| ())).await;
        if let Ok(Err(e)) = loaded {
            return refuse(StatusCode::UNPROCESSABLE_ENTITY, format!("denoise: {e}"));
        }
    }
    let mut st = s.lock();
    match st.settings.apply(&update, s.size) {
        Err(Refusal::Malformed(msg)) => {
            refuse(StatusCode::BAD_REQUEST, format!("bad settings: {msg}"))
        }
        Err(Refusal::OutOfRange(msg)) => refuse(StatusCode::UNPROCESSABLE_ENTITY, msg),
        Ok(new) => {
            if new != st.settings {
                let keep = keeps_film(&st.settings, &new, st.passes) && !st.preview;
                st.settings = new;
                if keep {
                    s.notify();
                } else {
                    restart(&s, &mut st);
                }
            }
            StatusCode::NO_CONTENT.into_response()
        }
    }
}

/// Whether the film of `old` carries on under `new` (with `passes` in it): only the target
/// or the denoise setting changed, and the samples do not depend on the target. (The render
/// thread starts again itself where denoising is turned on over a film without features.)
fn keeps_film(old: &Settings, new: &Settings, passes: u32) -> bool {
    let same_film = Settings {
        spp: new.spp,
        denoise: new.denoise,
        ..old.clone()
    } == *new;
    let target_kept =
        new.spp == old.spp || (new.sampler != SamplerKind::ZSobol.name() && new.spp >= passes);
    same_film && target_kept
}

/// Bumps the generation: the render thread starts a new film (and the denoised image of
/// the old one is dropped).
pub(super) fn restart(s: &Shared, st: &mut Published) {
    st.generation += 1;
    st.passes = 0;
    st.to_denoise = None;
    st.denoised = None;
    s.stop.store(true, Ordering::SeqCst);
    s.notify();
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
    let (img, fig, preview, cam, denoised) = {
        let st = s.lock();
        let mut cam = st.camera.clone();
        cam.lens_radius = st.settings.lens_radius;
        cam.focal_distance = st.settings.focal_distance;
        (
            st.image.clone(),
            st.figures.clone(),
            st.preview,
            cam,
            st.denoised.clone().filter(|_| st.settings.denoise),
        )
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
            if let Some((clean, _)) = &denoised {
                for ext in ["png", "exr"] {
                    let f = s.out_dir.join(format!("{name}_{n}_denoised.{ext}"));
                    clean.save(&f)?;
                    files.push(f);
                }
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

/// The display a client asks for in a query (`exposure`, `mode`, `denoised`), or why it is
/// malformed.
fn display_of(q: &HashMap<String, String>) -> std::result::Result<Display, String> {
    let mut d = Display::default();
    if let Some(v) = q.get("denoised") {
        d.denoised = match v.as_str() {
            "true" | "1" => true,
            "false" | "0" => false,
            _ => return Err(format!("denoised must be true or false, not {v}")),
        };
    }
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

/// An image to show, its figures and the display it is shown with.
type Shown = (Arc<Image>, Option<Arc<Figures>>, Display);

/// The latest image that `d` asks for, with its figures: the denoised one where `d` wants it
/// (the noisy one instead where there is none yet and `fallback`, shown as if `d` were not
/// denoised), or why there is none.
fn latest(st: &Published, d: &Display, fallback: bool) -> std::result::Result<Shown, &'static str> {
    if d.wants_denoised() {
        if let Some((img, _)) = st.denoised.as_ref().filter(|_| st.settings.denoise) {
            return Ok((img.clone(), None, *d));
        }
        if !fallback {
            return Err(if st.settings.denoise {
                "no denoised image yet"
            } else {
                "denoising is off (POST /api/settings {\"denoise\": true})"
            });
        }
    }
    let img = st.image.clone().ok_or("no image yet")?;
    let noisy = Display {
        denoised: false,
        ..*d
    };
    Ok((img, st.figures.clone(), noisy))
}

/// The latest frame as a PNG shown as `d` (see [`latest`]), encoded once per frame and
/// display.
async fn encoded_png(
    s: &Arc<Shared>,
    d: Display,
    fallback: bool,
) -> std::result::Result<(u64, Bytes), &'static str> {
    let (frame, (img, fig, d)) = {
        let st = s.lock();
        (st.frame, latest(&st, &d, fallback)?)
    };
    if let Some((f, k, bytes)) = s.png.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
        if *f == frame && *k == d.key() {
            return Ok((frame, bytes.clone()));
        }
    }
    let bytes =
        tokio::task::spawn_blocking(move || display::shown(&img, fig.as_deref(), &d).encode("png"))
            .await
            .ok()
            .and_then(|r| r.ok())
            .ok_or("the image could not be encoded")?;
    let bytes = Bytes::from(bytes);
    *s.png.lock().unwrap_or_else(|e| e.into_inner()) = Some((frame, d.key(), bytes.clone()));
    Ok((frame, bytes))
}

async fn image_png(State(s): Shd, Query(q): Q, h: HeaderMap) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    let d = match display_of(&q) {
        Ok(d) => d,
        Err(msg) => return refuse(StatusCode::BAD_REQUEST, msg),
    };
    match encoded_png(&s, d, false).await {
        Ok((_, bytes)) => ([(header::CONTENT_TYPE, "image/png")], bytes).into_response(),
        Err(why) => refuse(StatusCode::SERVICE_UNAVAILABLE, why),
    }
}

async fn image_exr(State(s): Shd, Query(q): Q, h: HeaderMap) -> Response {
    if !authorized(&s, &q, &h) {
        return unauthorized();
    }
    // The linear radiance: of the display, only `denoised` applies.
    let d = match display_of(&q) {
        Ok(d) => Display {
            exposure: 0.0,
            mode: Mode::Colour,
            ..d
        },
        Err(msg) => return refuse(StatusCode::BAD_REQUEST, msg),
    };
    let img = match latest(&s.lock(), &d, false) {
        Ok((img, _, _)) => img,
        Err(why) => return refuse(StatusCode::SERVICE_UNAVAILABLE, why),
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
/// "colour"|"rate"|"variance", "denoised": bool}` to change what its frames show (errors
/// come back as `{"error": …}`; a denoised display shows the noisy image until a denoised
/// one is ready).
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
    let mut sent: Option<(u64, DisplayKey)> = None;
    let mut tick = tokio::time::interval(Duration::from_millis(500));
    loop {
        let frame = *rx.borrow_and_update();
        if sent != Some((frame, display.key())) {
            if let Ok((f, png)) = encoded_png(&s, display, true).await {
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
