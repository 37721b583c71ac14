//! Live preview in the [tev](https://github.com/Tom94/tev) image viewer over its TCP protocol,
//! as pbrt-v4's `--display-server`: on connecting, a `CreateImage` packet (channels R, G, B),
//! then `UpdateImageV3` packets with the tiles that changed, about four times a second, from a
//! background thread. When tev goes away the stream keeps the latest pixels and reconnects
//! (sending the whole image again) once tev comes back.
//!
//! Packets: a little-endian `u32` with the packet's whole length (these four bytes included),
//! a type byte, then the fields: booleans as one byte, strings NUL-terminated, integers and
//! floats little-endian. Pixel values are the linear radiance means of the film.

use crate::film::{Cell, FilmPixel, Tile};
use crate::io::image::Image;
use std::collections::BTreeSet;
use std::io::Write;
use std::net::{TcpStream, ToSocketAddrs};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// tev packet type of `CreateImage`.
pub const CREATE_IMAGE: u8 = 4;
/// tev packet type of `UpdateImageV3` (explicit channel offsets and strides).
pub const UPDATE_IMAGE_V3: u8 = 6;
/// Time between two sends of the changed tiles.
pub const INTERVAL: Duration = Duration::from_millis(250);
/// Time between two connection attempts while tev is away.
const RETRY: Duration = Duration::from_secs(1);

/// A packet under construction.
struct Packet(Vec<u8>);

impl Packet {
    fn new(kind: u8) -> Packet {
        let mut p = Packet(vec![0; 4]);
        p.0.push(kind);
        p
    }
    fn bool(&mut self, b: bool) -> &mut Self {
        self.0.push(b as u8);
        self
    }
    fn str(&mut self, s: &str) -> &mut Self {
        // tev reads up to the first NUL: a name cannot contain one.
        self.0.extend(s.bytes().filter(|&b| b != 0));
        self.0.push(0);
        self
    }
    fn i32(&mut self, v: i32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn i64(&mut self, v: i64) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn finish(mut self) -> Vec<u8> {
        let n = self.0.len() as u32;
        self.0[..4].copy_from_slice(&n.to_le_bytes());
        self.0
    }
}

/// The `CreateImage` packet of an RGB image `name` of `w`×`h` pixels.
pub fn create_packet(name: &str, w: u32, h: u32) -> Vec<u8> {
    let mut p = Packet::new(CREATE_IMAGE);
    p.bool(false).str(name).i32(w as i32).i32(h as i32).i32(3);
    for c in ["R", "G", "B"] {
        p.str(c);
    }
    p.finish()
}

/// The `UpdateImageV3` packet of the rectangle `(x, y, w, h)` of an RGB image, its pixels
/// interleaved (`rgb` holds `w·h·3` values, row by row).
pub fn update_packet(name: &str, (x, y, w, h): (u32, u32, u32, u32), rgb: &[f32]) -> Vec<u8> {
    let mut p = Packet::new(UPDATE_IMAGE_V3);
    p.bool(false).str(name).i32(3);
    for c in ["R", "G", "B"] {
        p.str(c);
    }
    p.i32(x as i32).i32(y as i32).i32(w as i32).i32(h as i32);
    for c in 0..3 {
        p.i64(c);
    }
    for _ in 0..3 {
        p.i64(3);
    }
    p.0.reserve(rgb.len() * 4);
    for v in rgb {
        p.0.extend_from_slice(&v.to_le_bytes());
    }
    p.finish()
}

/// A rectangle of the frame: left, top, width, height.
type Rect = (u32, u32, u32, u32);

/// What the render side hands over and the sender thread sends.
struct Pending {
    /// The latest linear RGB of every pixel of the frame, interleaved.
    rgb: Vec<f32>,
    /// Rectangles changed since the last send.
    dirty: BTreeSet<Rect>,
    /// The render has ended: send what is left and stop.
    finish: bool,
}

struct Shared {
    addr: String,
    name: String,
    width: u32,
    height: u32,
    pending: Mutex<Pending>,
    wake: Condvar,
}

impl Shared {
    fn lock(&self) -> std::sync::MutexGuard<'_, Pending> {
        self.pending.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// A running stream of one image to tev (see the module documentation).
pub struct TevStream {
    shared: Arc<Shared>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl TevStream {
    /// Starts streaming an image `name` of `width`×`height` pixels to tev at `addr`
    /// (`HOST:PORT`). Connecting happens in the background: tev need not be running yet.
    pub fn start(addr: &str, name: &str, width: u32, height: u32) -> TevStream {
        let shared = Arc::new(Shared {
            addr: addr.to_string(),
            name: name.to_string(),
            width,
            height,
            pending: Mutex::new(Pending {
                rgb: vec![0.0; width as usize * height as usize * 3],
                dirty: BTreeSet::new(),
                finish: false,
            }),
            wake: Condvar::new(),
        });
        let thread = {
            let shared = shared.clone();
            std::thread::Builder::new()
                .name("tev".into())
                .spawn(move || sender(&shared))
                .ok()
        };
        TevStream { shared, thread }
    }

    /// Takes the means of a film tile that has just been rendered (`tile` within `cell` of
    /// the frame); they go out with the next send.
    pub fn tile(&self, cell: Cell, tile: &Tile, px: &[FilmPixel]) {
        let (fw, fh) = (self.shared.width, self.shared.height);
        let (x0, y0) = (cell.x + tile.x0, cell.y + tile.y0);
        if x0 + tile.w > fw || y0 + tile.h > fh || px.len() < (tile.w * tile.h) as usize {
            return;
        }
        let means: Vec<[f32; 3]> = px.iter().map(|p| p.mean().to_array()).collect();
        let mut p = self.shared.lock();
        for (i, m) in means.iter().enumerate().take((tile.w * tile.h) as usize) {
            let (x, y) = tile.frame_xy(cell, i);
            let at = (y as usize * fw as usize + x as usize) * 3;
            p.rgb[at..at + 3].copy_from_slice(m);
        }
        p.dirty.insert((x0, y0, tile.w, tile.h));
    }

    /// Replaces the whole image (an image of the stream's size; others are ignored).
    pub fn image(&self, img: &Image) {
        let (w, h) = (self.shared.width, self.shared.height);
        if img.width != w as usize || img.height != h as usize {
            return;
        }
        let mut p = self.shared.lock();
        for (i, v) in img.pixels.iter().enumerate() {
            p.rgb[i * 3..i * 3 + 3].copy_from_slice(&v.to_array());
        }
        p.dirty.insert((0, 0, w, h));
    }

    /// Sends what has changed (if tev is there) and ends the stream.
    pub fn finish(mut self) {
        self.end();
    }

    fn end(&mut self) {
        self.shared.lock().finish = true;
        self.shared.wake.notify_all();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for TevStream {
    fn drop(&mut self) {
        self.end();
    }
}

/// Connects to tev, with a short timeout per address.
fn connect(addr: &str) -> Option<TcpStream> {
    let addrs = addr.to_socket_addrs().ok()?;
    for a in addrs {
        if let Ok(s) = TcpStream::connect_timeout(&a, Duration::from_millis(300)) {
            let _ = s.set_nodelay(true);
            let _ = s.set_write_timeout(Some(Duration::from_secs(5)));
            return Some(s);
        }
    }
    None
}

/// The sender thread: every [`INTERVAL`], the changed rectangles; on (re)connecting, the
/// image's creation and all of it.
fn sender(s: &Shared) {
    let mut conn: Option<TcpStream> = None;
    let mut last_try: Option<Instant> = None;
    loop {
        let (rects, rgb, finish) = {
            let mut p = s.lock();
            if !p.finish {
                p = s
                    .wake
                    .wait_timeout(p, INTERVAL)
                    .unwrap_or_else(|e| e.into_inner())
                    .0;
            }
            if conn.is_none() && (p.finish || last_try.is_none_or(|t| t.elapsed() >= RETRY)) {
                last_try = Some(Instant::now());
                conn = connect(&s.addr);
                if let Some(c) = conn.as_mut() {
                    let created = c.write_all(&create_packet(&s.name, s.width, s.height));
                    if created.is_err() {
                        conn = None;
                    } else {
                        // Everything, since tev has not seen any of it.
                        p.dirty.clear();
                        p.dirty.insert((0, 0, s.width, s.height));
                    }
                }
            }
            if conn.is_none() {
                if p.finish {
                    return;
                }
                continue;
            }
            let rects: Vec<Rect> = std::mem::take(&mut p.dirty).into_iter().collect();
            // Copy the rectangles out, so that the render side is not held up by the sends.
            let fw = s.width as usize;
            let rgb: Vec<Vec<f32>> = rects
                .iter()
                .map(|&(x, y, w, h)| {
                    let mut out = Vec::with_capacity(w as usize * h as usize * 3);
                    for row in y as usize..(y + h) as usize {
                        let at = (row * fw + x as usize) * 3;
                        out.extend_from_slice(&p.rgb[at..at + w as usize * 3]);
                    }
                    out
                })
                .collect();
            (rects, rgb, p.finish)
        };
        if let Some(c) = conn.as_mut() {
            for (r, px) in rects.iter().zip(&rgb) {
                if c.write_all(&update_packet(&s.name, *r, px)).is_err() {
                    // tev went away: keep the pixels, send all of them on reconnecting.
                    conn = None;
                    break;
                }
            }
            if let Some(c) = conn.as_mut() {
                let _ = c.flush();
            }
        }
        if finish {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packets_carry_their_length_and_fields() {
        let c = create_packet("a", 3, 2);
        assert_eq!(
            u32::from_le_bytes(c[..4].try_into().unwrap()) as usize,
            c.len()
        );
        assert_eq!(c[4], CREATE_IMAGE);
        assert_eq!(&c[5..8], &[0, b'a', 0]);
        assert_eq!(i32::from_le_bytes(c[8..12].try_into().unwrap()), 3);
        assert_eq!(&c[c.len() - 6..], b"R\0G\0B\0");
        let u = update_packet("a", (1, 0, 1, 1), &[0.5, 1.0, 2.0]);
        assert_eq!(
            u32::from_le_bytes(u[..4].try_into().unwrap()) as usize,
            u.len()
        );
        assert_eq!(u[4], UPDATE_IMAGE_V3);
        assert_eq!(
            f32::from_le_bytes(u[u.len() - 4..].try_into().unwrap()),
            2.0
        );
    }
}
