//! `--display-server`: a fake tev server on loopback receives the packets of a real render,
//! checks their fields and reassembles exactly the image the render wrote, also when the
//! connection drops during the render and the renderer reconnects.

mod common;

use common::{assert_same_bits, temp_dir};
use pathtracer::io::image::Image;
use std::io::{ErrorKind, Read};
use std::net::{TcpListener, TcpStream};
use std::process::Command;
use std::time::{Duration, Instant};

/// What the fake tev has seen of one image.
#[derive(Default)]
struct Received {
    name: String,
    width: usize,
    height: usize,
    /// Interleaved RGB, as the updates left it.
    rgb: Vec<f32>,
    creates: usize,
    updates: usize,
}

/// A cursor over one packet's payload.
struct Fields<'a>(&'a [u8]);

impl Fields<'_> {
    fn take(&mut self, n: usize) -> &[u8] {
        assert!(self.0.len() >= n, "packet too short");
        let (a, b) = self.0.split_at(n);
        self.0 = b;
        a
    }
    fn u8(&mut self) -> u8 {
        self.take(1)[0]
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take(4).try_into().unwrap())
    }
    fn i64(&mut self) -> i64 {
        i64::from_le_bytes(self.take(8).try_into().unwrap())
    }
    fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take(4).try_into().unwrap())
    }
    fn str(&mut self) -> String {
        let end = self.0.iter().position(|&b| b == 0).expect("NUL-terminated");
        let s = String::from_utf8(self.0[..end].to_vec()).unwrap();
        self.0 = &self.0[end + 1..];
        s
    }
}

/// Reads one packet (`None` at the end of the stream).
fn packet(c: &mut TcpStream) -> Option<Vec<u8>> {
    let mut len = [0u8; 4];
    match c.read_exact(&mut len) {
        Ok(()) => {}
        Err(e) if e.kind() == ErrorKind::UnexpectedEof => return None,
        Err(e) => panic!("{e}"),
    }
    let n = u32::from_le_bytes(len) as usize;
    assert!((5..1 << 28).contains(&n), "packet length {n}");
    let mut body = vec![0u8; n - 4];
    c.read_exact(&mut body).unwrap();
    Some(body)
}

/// Applies one packet as tev would.
fn apply(r: &mut Received, body: &[u8]) {
    let mut f = Fields(body);
    match f.u8() {
        4 => {
            assert_eq!(f.u8(), 0, "grab focus");
            r.name = f.str();
            r.width = f.i32() as usize;
            r.height = f.i32() as usize;
            assert_eq!(f.i32(), 3);
            let names: Vec<String> = (0..3).map(|_| f.str()).collect();
            assert_eq!(names, ["R", "G", "B"]);
            assert!(f.0.is_empty());
            r.rgb = vec![f32::NAN; r.width * r.height * 3];
            r.creates += 1;
        }
        6 => {
            assert!(r.creates > 0, "an update before the image was created");
            assert_eq!(f.u8(), 0);
            assert_eq!(f.str(), r.name);
            assert_eq!(f.i32(), 3);
            let names: Vec<String> = (0..3).map(|_| f.str()).collect();
            assert_eq!(names, ["R", "G", "B"]);
            let (x, y, w, h) = (f.i32(), f.i32(), f.i32(), f.i32());
            let (x, y, w, h) = (x as usize, y as usize, w as usize, h as usize);
            assert!(
                x + w <= r.width && y + h <= r.height,
                "update outside the image"
            );
            let offsets: Vec<i64> = (0..3).map(|_| f.i64()).collect();
            let strides: Vec<i64> = (0..3).map(|_| f.i64()).collect();
            assert_eq!((offsets, strides), (vec![0, 1, 2], vec![3, 3, 3]));
            assert_eq!(f.0.len(), w * h * 3 * 4, "pixel data size");
            for row in y..y + h {
                for col in x..x + w {
                    for c in 0..3 {
                        r.rgb[(row * r.width + col) * 3 + c] = f.f32();
                    }
                }
            }
            r.updates += 1;
        }
        t => panic!("unexpected packet type {t}"),
    }
}

/// The image the fake tev shows.
fn shown(r: &Received) -> Image {
    let mut img = Image::new(r.width, r.height);
    for (i, p) in img.pixels.iter_mut().enumerate() {
        *p = glam::Vec3::from_slice(&r.rgb[i * 3..i * 3 + 3]);
    }
    img
}

fn render_with_tev(tag: &str, extra: &[&str], serve: impl FnOnce(&TcpListener) -> Received + Send) {
    let dir = temp_dir(tag);
    let out = dir.join("live.exr");
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    let received = std::thread::scope(|sc| {
        let server = sc.spawn(|| serve(&listener));
        let mut args = vec![
            "-t",
            "2",
            "-r",
            "64",
            "48",
            "-f",
            out.to_str().unwrap(),
            "--display-server",
            &addr,
        ];
        args.extend_from_slice(extra);
        let o = Command::new(env!("CARGO_BIN_EXE_pathtracer"))
            .args(&args)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        server.join().unwrap()
    });
    assert_eq!(received.name, "live.exr");
    assert!(received.updates > 0);
    assert_same_bits(&shown(&received), &Image::load(&out).unwrap());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Accepts one connection (waiting at most `wait`) and applies its packets to the end.
fn serve_one(l: &TcpListener, r: &mut Received, wait: Duration) -> bool {
    l.set_nonblocking(true).unwrap();
    let t = Instant::now();
    let mut c = loop {
        match l.accept() {
            Ok((c, _)) => break c,
            Err(e) if e.kind() == ErrorKind::WouldBlock && t.elapsed() < wait => {
                std::thread::sleep(Duration::from_millis(10))
            }
            Err(_) => return false,
        }
    };
    c.set_nonblocking(false).unwrap();
    while let Some(p) = packet(&mut c) {
        apply(r, &p);
    }
    true
}

#[test]
fn a_fake_tev_reassembles_exactly_the_rendered_image() {
    render_with_tev("tev-exact", &["-s", "16", "-m", "4"], |l| {
        let mut r = Received::default();
        assert!(serve_one(l, &mut r, Duration::from_secs(60)));
        r
    });
}

#[test]
fn the_stream_reconnects_and_sends_the_whole_image_again() {
    // Passes of one sample for 2.5 s: tiles are sent several times a second. The first
    // connection is closed after the image's creation; the renderer notices at a later send,
    // reconnects and sends everything again.
    render_with_tev(
        "tev-reconnect",
        &["-s", "100000", "--time-limit", "2.5", "-m", "2"],
        |l| {
            let mut r = Received::default();
            l.set_nonblocking(false).unwrap();
            let (mut first, _) = l.accept().unwrap();
            apply(&mut r, &packet(&mut first).expect("a create packet"));
            assert_eq!(r.creates, 1);
            drop(first);
            assert!(
                serve_one(l, &mut r, Duration::from_secs(60)),
                "no second connection"
            );
            assert_eq!(r.creates, 2, "the image is created again on reconnecting");
            r
        },
    );
}
