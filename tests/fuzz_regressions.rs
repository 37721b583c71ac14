//! Inputs the fuzzers (fuzz/) found, or hand-written equivalents of them: each must give a
//! clear error, never a panic, a hang or a huge allocation.

mod common;

use pathtracer::io::image::Image;

/// A small EXR written by the renderer with its data window patched to claim
/// `w × h` pixels (found by the `exr` target: the decoder allocated the claimed window before
/// reading any pixel, 1.2 TB for a 4 KiB input).
fn exr_claiming(w: i32, h: i32) -> Vec<u8> {
    let dir = common::temp_dir("fuzz-exr");
    let p = dir.join("small.exr");
    Image::new(4, 2).save(&p).unwrap();
    let mut bytes = std::fs::read(&p).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    for name in [&b"dataWindow\0box2i\0"[..], &b"displayWindow\0box2i\0"[..]] {
        let at = bytes
            .windows(name.len())
            .position(|x| x == name)
            .expect("the attribute is there")
            + name.len()
            + 4;
        bytes[at + 8..at + 12].copy_from_slice(&(w - 1).to_le_bytes());
        bytes[at + 12..at + 16].copy_from_slice(&(h - 1).to_le_bytes());
    }
    bytes
}

#[test]
fn an_exr_header_claiming_a_huge_window_is_refused_before_allocating() {
    let bytes = exr_claiming(400_000, 300_000);
    let e = Image::from_bytes(&bytes, "exr", "forged.exr")
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("forged.exr: EXR claims 400000x300000 pixels in 3 channel(s)"),
        "{e}"
    );
    // Within the pixel bound but with blocks (tiles of 20000×20000 here) for which the decoder
    // would allocate what a chunk's size field claims (the `exr` target: 2 GB for 851 bytes).
    let mut bytes = exr_claiming(4, 2);
    let name = b"tiles\0tiledesc\0";
    let at = bytes
        .windows(name.len())
        .position(|x| x == name)
        .expect("the renderer writes tiled EXRs")
        + name.len()
        + 4;
    bytes[at..at + 4].copy_from_slice(&20_000u32.to_le_bytes());
    bytes[at + 4..at + 8].copy_from_slice(&20_000u32.to_le_bytes());
    let e = Image::from_bytes(&bytes, "exr", "wide.exr")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("wide.exr: EXR blocks of up to"), "{e}");
    // The unpatched file still reads.
    let ok = exr_claiming(4, 2);
    assert_eq!(Image::from_bytes(&ok, "exr", "ok.exr").unwrap().width, 4);
}

#[test]
fn a_checkpoint_header_claiming_a_huge_film_is_refused_before_allocating() {
    // A valid digest over a header that claims 65536×65536 pixels and holds none.
    use sha2::{Digest, Sha256};
    let header = "frame=65536x65536\ncell=0,0,65536,65536\nfirst=0\nlevel=0\n";
    let mut v = b"PTFILM\r\n".to_vec();
    v.extend_from_slice(&1u32.to_le_bytes());
    v.extend_from_slice(&(header.len() as u32).to_le_bytes());
    v.extend_from_slice(header.as_bytes());
    let d = Sha256::digest(&v);
    v.extend_from_slice(&d);
    let e = pathtracer::film::Film::from_bytes(&v, "big.ckpt")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("big.ckpt: 0 bytes of pixel data, expected"),
        "{e}"
    );
}
