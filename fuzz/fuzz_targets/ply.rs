//! The PLY loader and the scene build on arbitrary bytes: errors, never panics.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(desc) = pathtracer::io::ply::parse(data, "fuzz.ply", "fuzz") {
        let _ = pathtracer::scene::build::build(&desc);
    }
});
