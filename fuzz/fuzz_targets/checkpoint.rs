//! Checkpoint (film) files on arbitrary bytes: errors, never panics or unbounded memory.
//! Inputs whose first byte is odd get a valid checksum appended, so that the fuzzer reaches
//! the header and pixel parsing behind the SHA-256 check.
#![no_main]
use libfuzzer_sys::fuzz_target;
use sha2::{Digest, Sha256};

fuzz_target!(|data: &[u8]| {
    let _ = pathtracer::film::Film::from_bytes(data, "fuzz.ckpt");
    if data.first().is_some_and(|b| b & 1 == 1) {
        let mut v = data[1..].to_vec();
        let digest = Sha256::digest(&v);
        v.extend_from_slice(&digest);
        if let Ok(film) = pathtracer::film::Film::from_bytes(&v, "fuzz.ckpt") {
            let _ = film.develop();
        }
    }
});
