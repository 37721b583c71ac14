//! The glTF loader (a `.gltf` JSON with data-URI buffers, or a `.glb`) and the scene build on
//! arbitrary bytes: errors, never panics.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(desc) = pathtracer::io::gltf::parse(data, "fuzz.gltf", "fuzz", None) {
        let _ = pathtracer::scene::build::build(&desc);
    }
});
