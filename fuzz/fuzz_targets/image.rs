//! Image files of every format the renderer reads, on arbitrary bytes: the first byte picks
//! the file's extension (the format where the bytes have no magic number), the rest is the
//! file. Decoding gives an image or an error naming the file, never a panic, a hang or an
//! allocation beyond the decoder's bound.
#![no_main]
use libfuzzer_sys::fuzz_target;

const NAMES: [&str; 8] = [
    "fuzz.tga", "fuzz.png", "fuzz.jpg", "fuzz.exr", "fuzz.hdr", "fuzz.pfm", "fuzz.bin", "fuzz",
];

fuzz_target!(|data: &[u8]| {
    let Some((&pick, bytes)) = data.split_first() else {
        return;
    };
    let name = NAMES[pick as usize % NAMES.len()];
    match pathtracer::io::image_file::decode(bytes, name) {
        Ok(d) => {
            let n = d.width as usize * d.height as usize;
            assert_eq!(d.rgb.len(), n);
            assert!(d.alpha.as_ref().is_none_or(|a| a.len() == n));
        }
        Err(e) => assert!(e.starts_with(name), "{e}"),
    }
});
