//! pbrt-v4 scene syntax on arbitrary text: errors with a place, never panics.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let _ = pathtracer::io::pbrt::parse(&text, std::path::Path::new("fuzz.pbrt"));
});
