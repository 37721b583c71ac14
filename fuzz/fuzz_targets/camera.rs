//! CS184 camera files on arbitrary text: errors, never panics.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let _ = pathtracer::camera::Camera::parse_cs184(&text, "fuzz.cam");
});
