//! The viewer's page in real headless Chromium, driven over WebDriver (chromedriver): the page
//! loads, says what it waits for, the image appears, fits a 1600×1000 window (`1` toggles one
//! image pixel per screen pixel) and converges, `]` doubles the target in the status line, a drag
//! moves the camera, a right-click changes the focal distance, `s` writes the files, `v` shows
//! the BVH boxes, `n` shows the denoised image. Screenshots of the steps go to `target/tmp/browser/`.
//!
//! Skips with a notice where Chromium or chromedriver is absent, unless
//! `PATHTRACER_REQUIRE_BROWSER` is set (CI sets it, after installing them).
#![cfg(feature = "view")]

use pathtracer::render::RenderOptions;
use pathtracer::scene::build::build;
use pathtracer::view::{start, ViewConfig, Viewer};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const ELEMENT: &str = "element-6066-11e4-a52e-4f735466cecf";

fn find(candidates: &[&str]) -> Option<PathBuf> {
    candidates.iter().map(PathBuf::from).find(|p| p.is_file())
}

/// chromedriver on a free port, and a session of headless Chromium.
struct Browser {
    driver: Child,
    base: String,
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = ureq::delete(&self.base).call();
        let _ = self.driver.kill();
        let _ = self.driver.wait();
    }
}

impl Browser {
    fn start(chromium: &Path, chromedriver: &Path) -> Browser {
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let driver = Command::new(chromedriver)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("chromedriver starts");
        let root = format!("http://127.0.0.1:{port}");
        let t = Instant::now();
        while ureq::get(&format!("{root}/status")).call().is_err() {
            assert!(t.elapsed() < Duration::from_secs(30), "chromedriver not up");
            std::thread::sleep(Duration::from_millis(100));
        }
        let caps = json!({"capabilities": {"alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": {
                "binary": chromium.to_str().unwrap(),
                "args": ["--headless=new", "--no-sandbox", "--disable-gpu",
                         "--disable-dev-shm-usage", "--window-size=1000,640"]
            }
        }}});
        let r = json_of(
            ureq::post(&format!("{root}/session"))
                .set("Content-Type", "application/json")
                .send_string(&caps.to_string())
                .expect("a browser session"),
        );
        let id = r["value"]["sessionId"].as_str().unwrap().to_string();
        Browser {
            driver,
            base: format!("{root}/session/{id}"),
        }
    }

    fn post(&self, path: &str, body: Value) -> Value {
        let r = ureq::post(&format!("{}{path}", self.base))
            .set("Content-Type", "application/json")
            .send_string(&body.to_string());
        match r {
            Ok(r) => json_of(r)["value"].clone(),
            Err(ureq::Error::Status(code, r)) => {
                panic!("{path}: {code} {}", r.into_string().unwrap_or_default())
            }
            Err(e) => panic!("{path}: {e}"),
        }
    }

    fn js(&self, script: &str) -> Value {
        self.post("/execute/sync", json!({"script": script, "args": []}))
    }

    fn text(&self, id: &str) -> String {
        self.js(&format!(
            "return document.getElementById('{id}').textContent"
        ))
        .as_str()
        .unwrap_or_default()
        .to_string()
    }

    /// Waits until `script` returns true.
    fn until(&self, what: &str, script: &str) {
        let t = Instant::now();
        while self.js(script) != Value::Bool(true) {
            assert!(
                t.elapsed() < Duration::from_secs(60),
                "{what}: status {:?}, note {:?}",
                self.text("status"),
                self.text("note")
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    fn key(&self, k: &str) {
        self.post(
            "/actions",
            json!({"actions": [{"type": "key", "id": "keyboard", "actions": [
                {"type": "keyDown", "value": k}, {"type": "keyUp", "value": k}]}]}),
        );
    }

    /// Pointer actions over the image, positions relative to its centre.
    fn pointer(&self, steps: Vec<Value>) {
        let img = self.post(
            "/element",
            json!({"using": "css selector", "value": "#img"}),
        );
        let eid = img[ELEMENT].as_str().unwrap().to_string();
        let actions: Vec<Value> = steps
            .into_iter()
            .map(|mut s| {
                if s["type"] == "pointerMove" && s.get("origin").is_none() {
                    s["origin"] = json!({ ELEMENT: eid });
                }
                s
            })
            .collect();
        self.post(
            "/actions",
            json!({"actions": [{"type": "pointer", "id": "mouse",
                "parameters": {"pointerType": "mouse"}, "actions": actions}]}),
        );
    }

    fn screenshot(&self, dir: &Path, name: &str) {
        use std::io::Write;
        let b64 = json_of(
            ureq::get(&format!("{}/screenshot", self.base))
                .call()
                .unwrap(),
        )["value"]
            .as_str()
            .unwrap()
            .to_string();
        let bytes = decode_base64(&b64);
        let mut f = std::fs::File::create(dir.join(name)).unwrap();
        f.write_all(&bytes).unwrap();
    }
}

/// Standard base64 (the screenshots WebDriver returns).
fn decode_base64(s: &str) -> Vec<u8> {
    let val = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => panic!("not base64: {c}"),
    };
    let clean: Vec<u8> = s
        .bytes()
        .filter(|&c| c != b'=' && !c.is_ascii_whitespace())
        .collect();
    let mut out = Vec::with_capacity(clean.len() * 3 / 4);
    for chunk in clean.chunks(4) {
        let v: Vec<u32> = chunk.iter().map(|&c| val(c) as u32).collect();
        let n = v.iter().fold(0u32, |a, &x| (a << 6) | x) << (6 * (4 - v.len()));
        let bytes = [(n >> 16) as u8, (n >> 8) as u8, n as u8];
        out.extend_from_slice(&bytes[..v.len().saturating_sub(1)]);
    }
    out
}

fn state(v: &Viewer) -> Value {
    json_of(
        ureq::get(&format!("http://{}/api/state", v.addr))
            .query("token", &v.token)
            .call()
            .unwrap(),
    )
}

fn json_of(r: ureq::Response) -> Value {
    serde_json::from_str(&r.into_string().unwrap()).unwrap()
}

#[test]
fn the_page_in_headless_chromium() {
    let required = std::env::var_os("PATHTRACER_REQUIRE_BROWSER").is_some();
    let chromium = find(&[
        "/usr/bin/chromium",
        "/usr/bin/chromium-browser",
        "/usr/bin/google-chrome",
    ]);
    let driver = find(&["/usr/bin/chromedriver", "/usr/lib/chromium/chromedriver"]);
    let (Some(chromium), Some(driver)) = (chromium, driver) else {
        assert!(
            !required,
            "PATHTRACER_REQUIRE_BROWSER is set but Chromium or chromedriver is missing"
        );
        eprintln!("NOTICE: chromium or chromedriver not found; skipping the browser test (CI installs them)");
        return;
    };
    let shots = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("browser");
    std::fs::create_dir_all(&shots).unwrap();
    let out = shots.join("saved");
    let _ = std::fs::remove_dir_all(&out);
    std::fs::create_dir_all(&out).unwrap();
    let scene = build(&pathtracer::builtin::cornell_box());
    let opts = RenderOptions {
        width: 320,
        height: 240,
        spp: 32,
        threads: Some(2),
        ..Default::default()
    };
    let cfg = ViewConfig {
        out_dir: out.clone(),
        ..Default::default()
    };
    let v = start(scene, opts, &cfg).unwrap();
    let b = Browser::start(&chromium, &driver);
    b.post("/url", json!({ "url": v.url() }));
    // The page loads, the image appears and converges to the target.
    b.until(
        "the image appears",
        "const i = document.getElementById('img'); return i.complete && i.naturalWidth === 320",
    );
    b.screenshot(&shots, "1-loaded.png");
    // Until the first pass arrives the page says what it waits for; then the message goes.
    let page = ureq::get(&v.url()).call().unwrap().into_string().unwrap();
    assert!(
        page.contains("<div id=\"wait\">connecting to the renderer…</div>")
            && page.contains("waiting for the first pass of the"),
        "the page has no waiting message"
    );
    b.until(
        "the waiting message goes with the first image",
        "return getComputedStyle(document.getElementById('wait')).display === 'none'",
    );
    // In a 1600×1000 window the 320×240 image fits the room beside the panel, larger than
    // 480×360, its aspect ratio kept; `1` shows it at one image pixel per screen pixel, and
    // `1` again fits it.
    b.post("/window/rect", json!({"width": 1600, "height": 1000}));
    let size = "const r = document.getElementById('img').getBoundingClientRect(); return [r.width, r.height]";
    b.until(
        "the image fits the larger window",
        "const r = document.getElementById('img').getBoundingClientRect(); \
         return r.width > 480 && r.height > 360 && Math.abs(r.width / r.height - 4 / 3) < 0.01",
    );
    eprintln!("fitted at 1600×1000: {}", b.js(size));
    b.screenshot(&shots, "1-fitted.png");
    b.key("1");
    b.until(
        "1 shows the image at 1:1",
        "const r = document.getElementById('img').getBoundingClientRect(); return r.width === 320 && r.height === 240",
    );
    b.key("1");
    b.until(
        "1 again fits it",
        "return document.getElementById('img').getBoundingClientRect().width > 480",
    );
    b.until(
        "the image converges",
        "return document.getElementById('status').textContent.startsWith('32 / 32 spp')",
    );
    b.screenshot(&shots, "2-converged.png");
    // `]` doubles the target in the status line (and the render goes on to it).
    b.key("]");
    b.until(
        "] doubles the target",
        "return document.getElementById('status').textContent.includes(' / 64 spp')",
    );
    assert_eq!(state(&v)["settings"]["spp"], 64);
    // A left-drag orbits the camera.
    let before = state(&v)["camera"]["position"].clone();
    let mut steps = vec![
        json!({"type": "pointerMove", "duration": 0, "x": 0, "y": 0}),
        json!({"type": "pointerDown", "button": 0}),
    ];
    for i in 1..=8 {
        steps.push(json!({"type": "pointerMove", "duration": 30, "x": i * 10, "y": i * 2}));
    }
    steps.push(json!({"type": "pointerUp", "button": 0}));
    b.pointer(steps);
    let t = Instant::now();
    while state(&v)["camera"]["position"] == before {
        assert!(
            t.elapsed() < Duration::from_secs(30),
            "the drag did not move the camera"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    b.until(
        "a full image after the drag",
        "return document.getElementById('status').textContent.includes(' / 64 spp')",
    );
    b.screenshot(&shots, "3-orbited.png");
    // A right-click focuses where it points.
    let focus = state(&v)["settings"]["focal_distance"].as_f64().unwrap();
    b.pointer(vec![
        json!({"type": "pointerMove", "duration": 0, "x": -40, "y": 40}),
        json!({"type": "pointerDown", "button": 2}),
        json!({"type": "pointerUp", "button": 2}),
    ]);
    let t = Instant::now();
    while state(&v)["settings"]["focal_distance"].as_f64().unwrap() == focus {
        assert!(
            t.elapsed() < Duration::from_secs(30),
            "the right-click did not focus"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    // `s` writes the image files into the output directory.
    b.key("s");
    b.until(
        "s saves",
        "return document.getElementById('note').textContent.startsWith('saved ')",
    );
    let mut saved: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    saved.sort();
    assert_eq!(
        saved,
        ["cornell_1.exr", "cornell_1.png", "cornell_1_rate.png"]
    );
    // `v` shows the BVH boxes: the status names the node, the overlay has lines on it.
    b.key("v");
    b.until(
        "v shows the BVH",
        "return document.getElementById('mode').textContent.startsWith('BVH node 0')",
    );
    let lit = "const c = document.getElementById('overlay'); \
               const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data; \
               let n = 0; for (let i = 3; i < d.length; i += 4) if (d[i] > 0) n++; return n";
    b.until(
        "boxes drawn",
        &format!("const f = () => {{ {lit} }}; return f() > 200;"),
    );
    b.screenshot(&shots, "4-bvh.png");
    // → goes into a child.
    b.key("\u{E014}");
    b.until(
        "→ into a child",
        "return /^BVH node [1-9]/.test(document.getElementById('mode').textContent)",
    );
    b.screenshot(&shots, "5-bvh-child.png");
    b.key("v");
    denoised_display(&b, &v, &shots);
    eprintln!("screenshots in {}", shots.display());
}

/// `n`: with OIDN, the status says which pass is denoised and the image shown is smoother
/// (its mean difference between neighbouring pixels drops); `n` again turns it off. Without
/// OIDN, the note says how to get it and nothing changes.
fn denoised_display(b: &Browser, v: &Viewer, shots: &Path) {
    let roughness =
        "const i = document.getElementById('img'); const c = document.createElement('canvas'); \
         c.width = i.naturalWidth; c.height = i.naturalHeight; const g = c.getContext('2d'); \
         g.drawImage(i, 0, 0); const d = g.getImageData(0, 0, c.width, c.height).data; \
         let s = 0; for (let p = 0; p + 4 < d.length; p += 4) for (let k = 0; k < 3; k++) \
         s += Math.abs(d[p + k] - d[p + 4 + k]); return s / d.length";
    b.until(
        "a full image before denoising",
        "return document.getElementById('status').textContent.startsWith('64 / 64 spp')",
    );
    let noisy = b.js(roughness).as_f64().unwrap();
    b.key("n");
    if let Err(e) = pathtracer::denoise::Denoiser::load() {
        assert!(
            std::env::var_os("PATHTRACER_REQUIRE_OIDN").is_none(),
            "PATHTRACER_REQUIRE_OIDN is set but OIDN does not load: {e}"
        );
        b.until(
            "n without OIDN says how to get it",
            "return document.getElementById('note').textContent.includes('pyoidn')",
        );
        assert_eq!(state(v)["settings"]["denoise"], false);
        eprintln!("NOTICE: Open Image Denoise not found; the denoised display is not checked");
        return;
    }
    b.until(
        "n shows the denoised image",
        "return document.getElementById('status').textContent.includes('denoised (64 spp)') \
         && document.getElementById('denoised').checked",
    );
    b.until(
        "the denoised frame is drawn",
        &format!(
            "const f = () => {{ {roughness} }}; return f() < {};",
            0.8 * noisy
        ),
    );
    eprintln!("roughness: noisy {noisy:.3}, denoised {}", b.js(roughness));
    b.screenshot(shots, "6-denoised.png");
    b.key("n");
    b.until(
        "n again shows the noisy image",
        "return !document.getElementById('status').textContent.includes('denoised')",
    );
    assert_eq!(state(v)["settings"]["denoise"], false);
}
