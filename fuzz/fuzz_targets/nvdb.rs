//! NanoVDB files on arbitrary bytes: the density grid, walked into a dense grid, or an
//! error; never a panic, a read out of bounds or an allocation the file does not pay for.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = pathtracer::io::nvdb::grid_names(data);
    if let Ok(Some(g)) = pathtracer::io::nvdb::read_grid(data, "density") {
        let _ = g.dense();
    }
});
