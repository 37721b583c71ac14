//! pbrt-v4 scene files on arbitrary text: the syntax, the graphics state, shapes, materials,
//! lights and options, then the built scene; errors with a place, never panics.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let path = std::path::Path::new("fuzz.pbrt");
    if let Ok(desc) = pathtracer::io::pbrt::load_text(&text, path) {
        let _ = pathtracer::scene::build::build(&desc);
    }
});
