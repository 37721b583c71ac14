//! Mitsuba 3 XML scene files on arbitrary text: the XML reader (defaults, references,
//! properties, transforms), the plugins, then the built scene; errors with a place, never
//! panics. A second target input, the bytes after a NUL, is read as a `.serialized` mesh.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let (xml, mesh) = match data.iter().position(|&b| b == 0) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[][..]),
    };
    let _ = pathtracer::io::mitsuba::serialized::read(mesh, 0);
    let _ = pathtracer::io::mitsuba::serialized::read(mesh, 1);
    let text = String::from_utf8_lossy(xml);
    let path = std::path::Path::new("fuzz.xml");
    if let Ok(desc) = pathtracer::io::mitsuba::load_text(&text, path) {
        let _ = pathtracer::scene::build::build(&desc);
    }
});
