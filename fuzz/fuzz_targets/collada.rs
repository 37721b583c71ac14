//! The COLLADA loader and the scene build on arbitrary bytes: errors, never panics.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    if let Ok(desc) = pathtracer::io::collada::parse_str(&text, "fuzz.dae", "fuzz") {
        let _ = pathtracer::scene::build::build(&desc);
    }
});
