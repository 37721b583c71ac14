//! Figures of `pathtracer view` on a scene (default: the built-in one), as a script would
//! see them over the API: preview frames per second while a client drags the camera (moves
//! posted as fast as they are answered, frames counted on the WebSocket), the time from the
//! release to the first full-resolution pass, and the render's samples per second with and
//! without a client watching every frame.
//!
//! `cargo run --release --example view_figures -- [SCENE.dae] [SECONDS]`

use pathtracer::render::RenderOptions;
use pathtracer::view::{start, ViewConfig};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let desc = match args.first() {
        Some(p) => pathtracer::io::collada::load_file(std::path::Path::new(p))?,
        None => pathtracer::builtin::cornell_box(),
    };
    let secs: f64 = args.get(1).map_or(Ok(5.0), |s| s.parse())?;
    let scene = pathtracer::scene::build::build(&desc);
    let opts = RenderOptions {
        spp: 1 << 20,
        integrator: pathtracer::integrator::IntegratorSettings {
            max_depth: 100,
            ..Default::default()
        },
        ..Default::default()
    };
    let v = start(scene, opts, &ViewConfig::default())?;
    let base = format!("http://{}", v.addr);
    let state = || -> serde_json::Value {
        let s = ureq::get(&format!("{base}/api/state"))
            .query("token", &v.token)
            .call()
            .unwrap()
            .into_string()
            .unwrap();
        serde_json::from_str(&s).unwrap()
    };
    let post = |body: &str| {
        ureq::post(&format!("{base}/api/camera"))
            .query("token", &v.token)
            .send_string(body)
            .unwrap();
    };
    // Samples per second with nobody watching (the state only).
    std::thread::sleep(Duration::from_secs(1));
    let sps = |secs: f64| {
        let mut v = Vec::new();
        let t = Instant::now();
        while t.elapsed().as_secs_f64() < secs {
            std::thread::sleep(Duration::from_millis(500));
            v.push(state()["samples_per_sec"].as_f64().unwrap());
        }
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let alone = sps(secs);
    // A client that takes every frame.
    let frames = Arc::new(AtomicU64::new(0));
    let previews = Arc::new(AtomicU64::new(0));
    let full_at = Arc::new(std::sync::Mutex::new(None::<Instant>));
    let done = Arc::new(AtomicBool::new(false));
    let watcher = {
        let (frames, previews, full_at, done) = (
            frames.clone(),
            previews.clone(),
            full_at.clone(),
            done.clone(),
        );
        let url = format!("ws://{}/api/stream?token={}", v.addr, v.token);
        std::thread::spawn(move || {
            let (mut ws, _) = tungstenite::connect(url).unwrap();
            let mut preview = false;
            let mut sizes = std::collections::BTreeMap::new();
            while !done.load(Ordering::SeqCst) {
                match ws.read() {
                    Ok(tungstenite::Message::Text(t)) => {
                        let s: serde_json::Value = serde_json::from_str(t.as_str()).unwrap();
                        preview = s["preview"] == true;
                        if preview {
                            *sizes.entry(s["image_size"].to_string()).or_insert(0) += 1;
                        }
                    }
                    Ok(tungstenite::Message::Binary(_)) => {
                        frames.fetch_add(1, Ordering::SeqCst);
                        if preview {
                            previews.fetch_add(1, Ordering::SeqCst);
                        } else {
                            let mut f = full_at.lock().unwrap();
                            if f.is_none() {
                                *f = Some(Instant::now());
                            }
                        }
                    }
                    Ok(_) => {}
                    Err(_) => break,
                }
            }
            sizes
        })
    };
    std::thread::sleep(Duration::from_millis(500));
    let f0 = frames.load(Ordering::SeqCst);
    let t_watch = Instant::now();
    let watched = sps(secs);
    let converging = (frames.load(Ordering::SeqCst) - f0) as f64 / t_watch.elapsed().as_secs_f64();
    // Drag: orbit moves as fast as the server answers them, for `secs` seconds.
    let p0 = previews.load(Ordering::SeqCst);
    let t = Instant::now();
    let mut moves = 0;
    while t.elapsed().as_secs_f64() < secs {
        post(r#"{"orbit": [1.0, 0.2], "preview": true}"#);
        moves += 1;
        std::thread::sleep(Duration::from_millis(15));
    }
    let drag = t.elapsed().as_secs_f64();
    let shown = previews.load(Ordering::SeqCst) - p0;
    *full_at.lock().unwrap() = None;
    let released = Instant::now();
    post(r#"{"preview": false}"#);
    let t = Instant::now();
    let first_full = loop {
        if let Some(f) = *full_at.lock().unwrap() {
            break f.duration_since(released);
        }
        if t.elapsed() > Duration::from_secs(30) {
            return Err("no full-resolution frame after the release".into());
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    done.store(true, Ordering::SeqCst);
    // Wake the watcher's read.
    post(r#"{"orbit": [0.1, 0.0]}"#);
    println!(
        "scene: {} at 480x360, 2 threads where the machine has 2 cores",
        desc.name
    );
    println!(
        "drag: {moves} moves in {drag:.1} s, {shown} preview frames received: {:.1} frames/s",
        shown as f64 / drag
    );
    println!(
        "release to the first full-resolution frame received: {:.0} ms",
        first_full.as_secs_f64() * 1e3
    );
    println!("frames received per second while converging (no drag): {converging:.1}");
    println!(
        "samples/s: {alone:.0} unwatched, {watched:.0} with a client taking every frame ({:.1}% slower)",
        (1.0 - watched / alone) * 100.0
    );
    drop(v);
    println!(
        "preview sizes seen (state messages): {:?}",
        watcher.join().unwrap()
    );
    Ok(())
}
