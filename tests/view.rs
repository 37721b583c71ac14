//! `pathtracer view`'s server against real HTTP on an ephemeral port: the token, the settings
//! API and its refusals, the image after N passes against a batch render, vanished clients.
#![cfg(feature = "view")]

use pathtracer::io::image::Image;
use pathtracer::render::{render, RenderOptions};
use pathtracer::scene::build::build;
use pathtracer::view::{start, ViewConfig, Viewer};
use std::io::{Read, Write};
use std::time::{Duration, Instant};

fn opts(spp: u32) -> RenderOptions {
    RenderOptions {
        width: 48,
        height: 36,
        spp,
        threads: Some(2),
        seed: 4,
        ..Default::default()
    }
}

fn viewer(spp: u32) -> Viewer {
    let scene = build(&pathtracer::builtin::cornell_box());
    let cfg = ViewConfig {
        host: Some("127.0.0.1".parse().unwrap()),
        out_dir: std::env::temp_dir(),
        ..Default::default()
    };
    start(scene, opts(spp), &cfg).unwrap()
}

fn url(v: &Viewer, path: &str) -> String {
    format!("http://{}{path}", v.addr)
}

fn status(r: Result<ureq::Response, ureq::Error>) -> u16 {
    match r {
        Ok(r) => r.status(),
        Err(ureq::Error::Status(code, _)) => code,
        Err(e) => panic!("{e}"),
    }
}

/// The state, flattened: the settings' fields beside the others.
struct St(serde_json::Value);

impl St {
    fn num(&self, key: &str) -> f64 {
        self.0
            .get(key)
            .or_else(|| self.0["settings"].get(key))
            .and_then(|v| v.as_f64())
            .unwrap_or_else(|| panic!("{key} in {}", self.0))
    }
}

fn state(v: &Viewer) -> St {
    let body = ureq::get(&url(v, "/api/state"))
        .query("token", &v.token)
        .call()
        .unwrap()
        .into_string()
        .unwrap();
    St(serde_json::from_str(&body).unwrap())
}

fn wait_for_passes(v: &Viewer, n: f64) {
    let t = Instant::now();
    while state(v).num("passes") < n {
        assert!(t.elapsed() < Duration::from_secs(60), "passes stuck");
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn every_request_needs_the_token() {
    let v = viewer(2);
    for path in ["/", "/api/state", "/api/image.png", "/api/image.exr"] {
        assert_eq!(status(ureq::get(&url(&v, path)).call()), 401, "{path}");
        assert_eq!(
            status(ureq::get(&url(&v, path)).query("token", "0123").call()),
            401
        );
        let wrong = format!("{}x", &v.token[..v.token.len() - 1]);
        assert_eq!(
            status(ureq::get(&url(&v, path)).query("token", &wrong).call()),
            401
        );
    }
    assert_eq!(
        status(ureq::post(&url(&v, "/api/settings")).send_string("{\"spp\":4}")),
        401
    );
    assert_eq!(
        status(ureq::get(&url(&v, "/")).query("token", &v.token).call()),
        200
    );
    let bearer = format!("Bearer {}", v.token);
    assert_eq!(
        status(
            ureq::get(&url(&v, "/api/state"))
                .set("Authorization", &bearer)
                .call()
        ),
        200
    );
    assert!(v.token.len() >= 32, "at least 128 bits");
}

#[test]
fn settings_change_the_state_and_bad_ones_change_nothing() {
    let v = viewer(2);
    let post = |body: &str| {
        status(
            ureq::post(&url(&v, "/api/settings"))
                .query("token", &v.token)
                .send_string(body),
        )
    };
    assert_eq!(
        post(r#"{"spp": 8, "max_depth": 3, "light_samples": 2}"#),
        204
    );
    let s = state(&v);
    assert_eq!(
        (s.num("spp"), s.num("max_depth"), s.num("light_samples")),
        (8.0, 3.0, 2.0)
    );
    assert_eq!(post(r#"{"lens_radius": 0.05, "focal_distance": 3.5}"#), 204);
    let s = state(&v);
    assert_eq!((s.num("lens_radius"), s.num("focal_distance")), (0.05, 3.5));
    // Refused, and nothing changes.
    for (body, code) in [
        ("{\"spp\": 0}", 422),
        ("{\"max_depth\": 100001}", 422),
        ("{\"focal_distance\": -1}", 422),
        ("{\"lens_radius\": 1e30}", 422),
        ("{\"spp\": \"many\"}", 400),
        ("{\"path\": \"/etc/passwd\"}", 400),
        ("not json", 400),
        ("", 400),
    ] {
        assert_eq!(post(body), code, "{body}");
    }
    // An oversized body is refused from its announced length, before it is read (a client
    // still writing it when the answer comes would see a broken pipe, so send only the head).
    let mut c = std::net::TcpStream::connect(v.addr).unwrap();
    c.set_read_timeout(Some(std::time::Duration::from_secs(10)))
        .unwrap();
    write!(
        c,
        "POST /api/settings?token={} HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n\
         Content-Length: 100000\r\n\r\n{{\"spp\": 4, ",
        v.token
    )
    .unwrap();
    let mut head = [0u8; 12];
    c.read_exact(&mut head).unwrap();
    assert_eq!(&head, b"HTTP/1.1 413", "{}", String::from_utf8_lossy(&head));
    drop(c);
    let s = state(&v);
    assert_eq!(
        (s.num("spp"), s.num("max_depth"), s.num("light_samples")),
        (8.0, 3.0, 2.0)
    );
    assert_eq!((s.num("lens_radius"), s.num("focal_distance")), (0.05, 3.5));
}

#[test]
fn the_image_after_n_passes_equals_the_batch_render() {
    let v = viewer(6);
    wait_for_passes(&v, 6.0);
    let bytes = {
        let mut b = Vec::new();
        ureq::get(&url(&v, "/api/image.exr"))
            .query("token", &v.token)
            .call()
            .unwrap()
            .into_reader()
            .read_to_end(&mut b)
            .unwrap();
        b
    };
    let served = Image::from_bytes(&bytes, "exr", "served.exr").unwrap();
    let scene = build(&pathtracer::builtin::cornell_box());
    let (batch, _) = render(&scene, &opts(6), &|_, _| {}).unwrap();
    assert_eq!(served, batch, "identical pixels");
    // A new target restarts and converges to the batch render of that target.
    status(
        ureq::post(&url(&v, "/api/settings"))
            .query("token", &v.token)
            .send_string("{\"spp\": 3}"),
    );
    wait_for_passes(&v, 3.0);
    let png = ureq::get(&url(&v, "/api/image.png"))
        .query("token", &v.token)
        .call()
        .unwrap();
    assert_eq!(png.header("content-type"), Some("image/png"));
}

/// Media scenes (a grid; water in glass, whose volumetric caustics are traced from the
/// light) serve the batch render's pixels too.
#[test]
fn media_scenes_serve_the_batch_render() {
    for name in ["media_smoke", "media_glass"] {
        let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join(format!("tests/mitsuba/scenes/{name}.xml"));
        let load = || {
            pathtracer::setup::load(
                Some(&file),
                None,
                pathtracer::light::env::EnvSampling::Importance,
            )
            .unwrap()
        };
        let loaded = load();
        let o = RenderOptions {
            width: 48,
            height: 36,
            spp: 4,
            threads: Some(2),
            seed: 4,
            ..loaded.choices(&[]).unwrap().render_options()
        };
        let cfg = ViewConfig {
            host: Some("127.0.0.1".parse().unwrap()),
            out_dir: std::env::temp_dir(),
            ..Default::default()
        };
        let v = start(load().scene, o.clone(), &cfg).unwrap();
        wait_for_passes(&v, 4.0);
        let mut bytes = Vec::new();
        ureq::get(&url(&v, "/api/image.exr"))
            .query("token", &v.token)
            .call()
            .unwrap()
            .into_reader()
            .read_to_end(&mut bytes)
            .unwrap();
        let served = Image::from_bytes(&bytes, "exr", "served.exr").unwrap();
        let (batch, _) = render(&loaded.scene, &o, &|_, _| {}).unwrap();
        assert_eq!(served, batch, "{name}: identical pixels");
    }
}

#[test]
fn a_vanished_client_harms_nobody() {
    let v = viewer(2);
    // Half a request, then gone; a request line with no end; a connection never used.
    for junk in [
        format!("GET /api/state?token={} HTTP/1.1\r\nHost: x\r\n", v.token),
        "POST /api/settings HTTP/1.1\r\nContent-Length: 1000\r\n\r\n{\"sp".to_string(),
        String::new(),
    ] {
        let mut c = std::net::TcpStream::connect(v.addr).unwrap();
        c.write_all(junk.as_bytes()).unwrap();
        drop(c);
    }
    // Several clients at once, one of which stops reading an image half-way.
    let mut c = std::net::TcpStream::connect(v.addr).unwrap();
    write!(
        c,
        "GET /api/image.exr?token={} HTTP/1.1\r\nHost: x\r\n\r\n",
        v.token
    )
    .unwrap();
    let mut first = [0u8; 16];
    let _ = c.read(&mut first);
    drop(c);
    let others: Vec<_> = (0..4)
        .map(|_| {
            let (u, t) = (url(&v, "/api/state"), v.token.clone());
            std::thread::spawn(move || status(ureq::get(&u).query("token", &t).call()))
        })
        .collect();
    for h in others {
        assert_eq!(h.join().unwrap(), 200);
    }
    wait_for_passes(&v, 2.0);
}

fn post(v: &Viewer, path: &str, body: &str) -> (u16, String) {
    match ureq::post(&url(v, path))
        .query("token", &v.token)
        .send_string(body)
    {
        Ok(r) => (r.status(), r.into_string().unwrap_or_default()),
        Err(ureq::Error::Status(code, r)) => (code, r.into_string().unwrap_or_default()),
        Err(e) => panic!("{e}"),
    }
}

fn image(v: &Viewer) -> Image {
    let mut b = Vec::new();
    ureq::get(&url(v, "/api/image.exr"))
        .query("token", &v.token)
        .call()
        .unwrap()
        .into_reader()
        .read_to_end(&mut b)
        .unwrap();
    Image::from_bytes(&b, "exr", "served.exr").unwrap()
}

#[test]
fn camera_moves_autofocus_restart_and_save() {
    let v = viewer(2);
    wait_for_passes(&v, 2.0);
    let before = image(&v);
    // Orbit, then back home with Space: the first image again.
    assert_eq!(post(&v, "/api/camera", r#"{"orbit": [30, 10]}"#).0, 204);
    std::thread::sleep(Duration::from_millis(50));
    wait_for_passes(&v, 2.0);
    let orbited = image(&v);
    assert_ne!(orbited, before, "the view moved");
    for body in [r#"{"pan": [0.1, -0.05]}"#, r#"{"zoom": 1.2}"#] {
        assert_eq!(post(&v, "/api/camera", body).0, 204, "{body}");
    }
    for (body, code) in [
        (r#"{"zoom": 0}"#, 422),
        (r#"{"orbit": [1e9, 0]}"#, 422),
        (r#"{"orbit": [1]}"#, 400),
        (r#"{"fly": true}"#, 400),
    ] {
        assert_eq!(post(&v, "/api/camera", body).0, code, "{body}");
    }
    assert_eq!(post(&v, "/api/camera", r#"{"reset": true}"#).0, 204);
    std::thread::sleep(Duration::from_millis(50));
    wait_for_passes(&v, 2.0);
    assert_eq!(image(&v), before, "Space returns to the start");
    // Right-click autofocus: the focal distance becomes the depth under the pixel, and a
    // pixel outside the image is refused.
    let (code, body) = post(&v, "/api/autofocus", r#"{"x": 24, "y": 18}"#);
    assert_eq!(code, 200, "{body}");
    let f: serde_json::Value = serde_json::from_str(&body).unwrap();
    let depth = f["focal_distance"].as_f64().unwrap();
    assert!(depth > 0.5 && depth < 20.0, "{depth}");
    assert!((state(&v).num("focal_distance") - depth).abs() < 1e-6);
    assert_eq!(post(&v, "/api/autofocus", r#"{"x": 480, "y": 18}"#).0, 422);
    assert_eq!(post(&v, "/api/autofocus", r#"{"x": -1, "y": 1}"#).0, 422);
    // `r` restarts: the passes start again from zero.
    wait_for_passes(&v, 2.0);
    let frame = state(&v).num("frame");
    assert_eq!(post(&v, "/api/restart", "").0, 204);
    wait_for_passes(&v, 2.0);
    assert!(state(&v).num("frame") > frame);
    // `s` and `d` save under names the server chooses, into the directory it was given:
    // without a body everything, else the image (PNG, EXR, rate image) or the camera.
    for (body, suffixes) in [
        ("", vec![".png", ".exr", "_rate.png", ".cam.txt"]),
        (r#"{"only": "image"}"#, vec![".png", ".exr", "_rate.png"]),
        (r#"{"only": "camera"}"#, vec![".cam.txt"]),
    ] {
        let (code, text) = post(&v, "/api/save", body);
        assert_eq!(code, 200, "{text}");
        let files: serde_json::Value = serde_json::from_str(&text).unwrap();
        let names: Vec<String> = files["files"]
            .as_array()
            .unwrap()
            .iter()
            .map(|f| f.as_str().unwrap().to_string())
            .collect();
        assert_eq!(names.len(), suffixes.len(), "{names:?}");
        for (n, suffix) in names.iter().zip(&suffixes) {
            assert!(!n.contains('/') && n.starts_with("cornell_"), "{n}");
            assert!(n.ends_with(suffix), "{n} {suffix}");
            let p = std::env::temp_dir().join(n);
            assert!(p.is_file(), "{n}");
            if n.ends_with(".cam.txt") {
                // A camera file the CLI loads with -c.
                pathtracer::camera::Camera::load_cs184(&p).unwrap();
            }
            std::fs::remove_file(p).unwrap();
        }
    }
    assert_eq!(post(&v, "/api/save", r#"{"only": "all"}"#).0, 400);
    assert_eq!(post(&v, "/api/save", r#"{"path": "/tmp/x"}"#).0, 400);
}

fn png_size(v: &Viewer, query: &[(&str, &str)]) -> Result<(u32, u32), u16> {
    let mut r = ureq::get(&url(v, "/api/image.png")).query("token", &v.token);
    for (k, val) in query {
        r = r.query(k, val);
    }
    match r.call() {
        Ok(r) => {
            let mut b = Vec::new();
            r.into_reader().read_to_end(&mut b).unwrap();
            let d = image::load_from_memory(&b).unwrap();
            Ok((d.width(), d.height()))
        }
        Err(ureq::Error::Status(code, _)) => Err(code),
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn raising_the_target_keeps_the_film() {
    let v = viewer(2);
    wait_for_passes(&v, 2.0);
    // The film's age (`elapsed` restarts with every new film) tells a kept film from a new
    // one, however fast the tiny image renders.
    std::thread::sleep(Duration::from_millis(300));
    let age = state(&v).num("elapsed");
    assert_eq!(post(&v, "/api/settings", r#"{"spp": 6}"#).0, 204);
    wait_for_passes(&v, 6.0);
    assert!(state(&v).num("elapsed") >= age, "the film was kept");
    let scene = build(&pathtracer::builtin::cornell_box());
    let (batch, _) = render(&scene, &opts(6), &|_, _| {}).unwrap();
    assert_eq!(
        image(&v),
        batch,
        "2 passes, then 4 more, equal a 6-spp render"
    );
    // Lowering it below the passes done restarts (3 passes, not 6); so does another sampler.
    std::thread::sleep(Duration::from_millis(300));
    let age = state(&v).num("elapsed");
    assert_eq!(post(&v, "/api/settings", r#"{"spp": 3}"#).0, 204);
    wait_for_passes(&v, 3.0);
    let st = state(&v);
    assert!(st.num("elapsed") < age, "a new film");
    assert_eq!(st.num("passes"), 3.0);
    assert_eq!(post(&v, "/api/settings", r#"{"sampler": "zsobol"}"#).0, 204);
    wait_for_passes(&v, 3.0);
    let scene = build(&pathtracer::builtin::cornell_box());
    let o = RenderOptions {
        sampler: pathtracer::sampling::sampler::SamplerKind::ZSobol,
        ..opts(3)
    };
    assert_eq!(image(&v), render(&scene, &o, &|_, _| {}).unwrap().0);
    for (body, code) in [
        (r#"{"sampler": "halton"}"#, 422),
        (r#"{"estimator": "light"}"#, 204),
        (r#"{"estimator": "photons"}"#, 422),
    ] {
        assert_eq!(post(&v, "/api/settings", body).0, code, "{body}");
    }
    assert_eq!(state(&v).0["settings"]["estimator"], "light");
}

#[test]
fn previews_while_dragging_then_full_resolution_at_release() {
    let v = viewer(4);
    wait_for_passes(&v, 4.0);
    let t = Instant::now();
    // Moves marked as a drag's: previews (smaller images, passes 0) while they come.
    let mut small = false;
    while t.elapsed() < Duration::from_secs(20) && !small {
        assert_eq!(
            post(&v, "/api/camera", r#"{"orbit": [2, 0], "preview": true}"#).0,
            204
        );
        std::thread::sleep(Duration::from_millis(30));
        let st = state(&v);
        if st.0["preview"] == true {
            let (w, h) = png_size(&v, &[]).unwrap();
            small = w < 48 && h < 36;
        }
    }
    assert!(small, "no preview while dragging");
    // The release renders at full resolution at once.
    assert_eq!(post(&v, "/api/camera", r#"{"preview": false}"#).0, 204);
    wait_for_passes(&v, 4.0);
    assert_eq!(state(&v).0["preview"], false);
    assert_eq!(png_size(&v, &[]), Ok((48, 36)));
}

#[test]
fn cell_mode_renders_only_the_cell() {
    let v = viewer(2);
    wait_for_passes(&v, 2.0);
    let whole = image(&v);
    assert_eq!(
        post(&v, "/api/settings", r#"{"cell": [8, 4, 16, 12]}"#).0,
        204
    );
    wait_for_passes(&v, 2.0);
    let celled = image(&v);
    let scene = build(&pathtracer::builtin::cornell_box());
    let o = RenderOptions {
        cell: Some(pathtracer::render::Cell {
            x: 8,
            y: 4,
            w: 16,
            h: 12,
        }),
        ..opts(2)
    };
    let (cell, _) = render(&scene, &o, &|_, _| {}).unwrap();
    for y in 0..36 {
        for x in 0..48 {
            let inside = (8..24).contains(&x) && (4..16).contains(&y);
            let want = if inside {
                cell.get(x - 8, y - 4)
            } else {
                whole.get(x, y)
            };
            assert_eq!(celled.get(x, y), want, "{x} {y}");
        }
    }
    for body in [r#"{"cell": [40, 0, 16, 12]}"#, r#"{"cell": [0, 30, 4, 7]}"#] {
        assert_eq!(post(&v, "/api/settings", body).0, 422, "{body}");
    }
    assert_eq!(
        post(&v, "/api/settings", r#"{"cell": [0, 0, 0, 0]}"#).0,
        204
    );
    assert!(state(&v).0["settings"]["cell"].is_null());
    wait_for_passes(&v, 2.0);
    assert_eq!(image(&v), whole, "the whole frame again");
}

#[test]
fn the_bvh_view_walks_the_tree() {
    let v = viewer(2);
    let get = |q: &str| -> (u16, serde_json::Value) {
        match ureq::get(&format!(
            "{}&{q}",
            url(&v, &format!("/api/bvh?token={}", v.token))
        ))
        .call()
        {
            Ok(r) => (
                200,
                serde_json::from_str(&r.into_string().unwrap()).unwrap(),
            ),
            Err(ureq::Error::Status(code, _)) => (code, serde_json::Value::Null),
            Err(e) => panic!("{e}"),
        }
    };
    let scene = build(&pathtracer::builtin::cornell_box());
    let total = (scene.tris.len() + scene.spheres.len()) as u64;
    let (code, root) = get("node=0");
    assert_eq!(code, 200);
    assert_eq!(root["prims"].as_u64(), Some(total));
    assert!(root["parent"].is_null());
    assert_eq!(
        root["lines"].as_array().unwrap().len(),
        12,
        "the root box is in view"
    );
    let kids: Vec<u64> = root["children"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.as_u64().unwrap())
        .collect();
    assert_eq!(kids.len(), 2);
    let counts: Vec<u64> = root["child_prims"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.as_u64().unwrap())
        .collect();
    assert_eq!(counts.iter().sum::<u64>(), total);
    for (k, n) in kids.iter().zip(&counts) {
        let (code, child) = get(&format!("node={k}"));
        assert_eq!(code, 200);
        assert_eq!(child["parent"].as_u64(), Some(0));
        assert_eq!(child["prims"].as_u64(), Some(*n));
    }
    assert_eq!(get("node=99999999").0, 404);
    assert_eq!(get("node=left").0, 400);
}

#[test]
fn display_options_are_checked_and_change_only_the_png() {
    let v = viewer(2);
    wait_for_passes(&v, 2.0);
    let before = image(&v);
    assert_eq!(png_size(&v, &[("mode", "rate")]), Ok((48, 36)));
    assert_eq!(
        png_size(&v, &[("mode", "variance"), ("exposure", "1.5")]),
        Ok((48, 36))
    );
    assert_eq!(png_size(&v, &[("mode", "heat")]), Err(400));
    assert_eq!(png_size(&v, &[("exposure", "NaN")]), Err(400));
    assert_eq!(png_size(&v, &[("exposure", "99")]), Err(400));
    assert_eq!(image(&v), before);
}

fn ws_request(
    v: &Viewer,
    token: &str,
    origin: Option<&str>,
) -> tungstenite::handshake::client::Request {
    use tungstenite::client::IntoClientRequest;
    let mut r = format!("ws://{}/api/stream?token={token}", v.addr)
        .into_client_request()
        .unwrap();
    if let Some(o) = origin {
        r.headers_mut().insert("Origin", o.parse().unwrap());
    }
    r
}

fn ws_refusal(v: &Viewer, token: &str, origin: Option<&str>) -> u16 {
    match tungstenite::connect(ws_request(v, token, origin)) {
        Err(tungstenite::Error::Http(r)) => r.status().as_u16(),
        Ok(_) => 101,
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn the_websocket_streams_frames_to_its_own_origin_only() {
    use tungstenite::Message;
    let v = viewer(8);
    assert_eq!(ws_refusal(&v, "nope", None), 401);
    assert_eq!(ws_refusal(&v, &v.token, Some("http://evil.example")), 403);
    let own = format!("http://{}", v.addr);
    let (mut ws, _) = tungstenite::connect(ws_request(&v, &v.token, Some(&own))).unwrap();
    // Text (the state) then binary (the PNG of that frame), frame after frame.
    let mut frames = 0;
    let mut last_text = serde_json::Value::Null;
    let t = Instant::now();
    while frames < 3 {
        assert!(t.elapsed() < Duration::from_secs(60));
        match ws.read().unwrap() {
            Message::Text(t) => last_text = serde_json::from_str(t.as_str()).unwrap(),
            Message::Binary(b) => {
                assert!(last_text["frame"].is_u64(), "state before each image");
                let img = image::load_from_memory(&b).unwrap();
                assert_eq!((img.width(), img.height()), (48, 36));
                frames += 1;
            }
            _ => {}
        }
    }
    // A malformed display request is answered with an error and changes nothing.
    ws.send(Message::Text(r#"{"exposure": "bright"}"#.into()))
        .unwrap();
    let mut saw_error = false;
    while !saw_error {
        assert!(t.elapsed() < Duration::from_secs(60));
        if let Message::Text(t) = ws.read().unwrap() {
            let m: serde_json::Value = serde_json::from_str(t.as_str()).unwrap();
            saw_error = m.get("error").is_some();
        }
    }
    // An oversized message ends that connection only.
    let _ = ws.send(Message::Text("x".repeat(100_000).into()));
    drop(ws);
    assert_eq!(
        status(
            ureq::get(&url(&v, "/api/state"))
                .query("token", &v.token)
                .call()
        ),
        200
    );
    // A client that vanishes without reading harms nobody.
    let (quiet, _) = tungstenite::connect(ws_request(&v, &v.token, None)).unwrap();
    std::thread::sleep(Duration::from_millis(200));
    drop(quiet);
    wait_for_passes(&v, 8.0);
}

fn exr(v: &Viewer, query: &[(&str, &str)]) -> Result<Image, (u16, String)> {
    let mut req = ureq::get(&url(v, "/api/image.exr")).query("token", &v.token);
    for (k, val) in query {
        req = req.query(k, val);
    }
    match req.call() {
        Ok(r) => {
            let mut b = Vec::new();
            r.into_reader().read_to_end(&mut b).unwrap();
            Ok(Image::from_bytes(&b, "exr", "served.exr").unwrap())
        }
        Err(ureq::Error::Status(code, r)) => Err((code, r.into_string().unwrap_or_default())),
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn the_denoise_setting_serves_the_latest_pass_denoised() {
    let v = viewer(4);
    wait_for_passes(&v, 4.0);
    // Off: no denoised image, and the film records no features.
    let off = exr(&v, &[("denoised", "true")]).unwrap_err();
    assert_eq!(off.0, 503);
    assert!(off.1.contains("denoising is off"), "{}", off.1);
    assert_eq!(exr(&v, &[("denoised", "maybe")]).unwrap_err().0, 400);
    let denoiser = match pathtracer::denoise::Denoiser::load() {
        Ok(d) => d,
        Err(e) => {
            assert!(
                std::env::var_os("PATHTRACER_REQUIRE_OIDN").is_none(),
                "PATHTRACER_REQUIRE_OIDN is set but OIDN does not load: {e}"
            );
            // Without OIDN, turning denoising on is refused with how to get it.
            let (code, body) = post(&v, "/api/settings", r#"{"denoise": true}"#);
            assert_eq!(code, 422);
            assert!(body.contains("pyoidn"), "{body}");
            assert_eq!(state(&v).0["settings"]["denoise"], false);
            eprintln!("NOTICE: skipping the denoised image (Open Image Denoise not found: {e})");
            return;
        }
    };
    std::thread::sleep(Duration::from_millis(300));
    let age = state(&v).num("elapsed");
    assert_eq!(post(&v, "/api/settings", r#"{"denoise": true}"#).0, 204);
    let t = Instant::now();
    while state(&v).num("denoised_passes") < 4.0 {
        assert!(t.elapsed() < Duration::from_secs(60), "no denoised image");
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(
        state(&v).num("elapsed") < age,
        "a film without features starts again"
    );
    // The served images: the noisy one is the batch render's, and the denoised one is OIDN's
    // interactive denoise of it with the batch render's features.
    let scene = build(&pathtracer::builtin::cornell_box());
    let o = RenderOptions {
        features: true,
        ..opts(4)
    };
    let mut film = pathtracer::render::new_film(&o).unwrap();
    let stop = std::sync::atomic::AtomicBool::new(false);
    let ctl = pathtracer::render::Control::new(&stop, &|_, _| {});
    pathtracer::render::render_into(&scene, &o, &mut film, ctl).unwrap();
    let noisy = exr(&v, &[]).unwrap();
    assert_eq!(noisy, render(&scene, &opts(4), &|_, _| {}).unwrap().0);
    let features = film.feature_images().unwrap();
    let quality = pathtracer::denoise::Quality::Interactive;
    let expected = denoiser
        .denoise_image(&noisy, Some(&features), quality)
        .unwrap();
    let served = exr(&v, &[("denoised", "true")]).unwrap();
    let (mut err, mut sum) = (0.0f64, 0.0f64);
    for (a, b) in served.pixels.iter().zip(&expected.pixels) {
        assert!(a.is_finite() && a.min_element() >= 0.0);
        err += (*a - *b).abs().element_sum() as f64;
        sum += b.element_sum() as f64;
    }
    assert!(
        err <= 1e-4 * sum,
        "served and expected differ: {err} of {sum}"
    );
    assert_ne!(served, noisy);
    assert!(png_size(&v, &[("denoised", "true")]).is_ok());
    // Off again keeps the film and serves no denoised image.
    let age = state(&v).num("elapsed");
    assert_eq!(post(&v, "/api/settings", r#"{"denoise": false}"#).0, 204);
    assert_eq!(exr(&v, &[("denoised", "true")]).unwrap_err().0, 503);
    assert!(state(&v).num("elapsed") >= age, "the film was kept");
}
