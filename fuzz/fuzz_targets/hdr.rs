//! HDR environment maps on arbitrary bytes: decoding and building the light's sampling
//! distribution give errors, never panics or unbounded memory.
#![no_main]
use libfuzzer_sys::fuzz_target;
use pathtracer::light::env::{EnvLight, EnvSampling};

fuzz_target!(|data: &[u8]| {
    if let Ok(img) = pathtracer::io::image::Image::from_bytes(data, "hdr", "fuzz.hdr") {
        // Keep the distribution build small enough to stay fast.
        if img.width * img.height <= 1 << 16 {
            let env = EnvLight::new(img, EnvSampling::Importance);
            let _ = env.sample(glam::Vec2::new(0.3, 0.7));
        }
    }
});
