//! The OBJ/MTL loader and the scene build on arbitrary bytes: errors, never panics. The first
//! half of the input is the OBJ, the second the MTL its `mtllib` lines (and textures) read.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let (obj, mtl) = data.split_at(data.len() / 2);
    let obj = String::from_utf8_lossy(obj);
    // Every file the OBJ names (MTL libraries, textures) reads as the second half.
    let mut read = |_: &str| Ok(("fuzz.mtl".to_string(), mtl.to_vec()));
    if let Ok(desc) = pathtracer::io::obj::parse(&obj, "fuzz.obj", "fuzz", &mut read) {
        let _ = pathtracer::scene::build::build(&desc);
    }
});
