//! NanoVDB files on arbitrary bytes: the density grid, checked and looked up in its tree (and
//! copied dense where it is small), or an error; never a panic, a read out of bounds or an
//! allocation the file does not pay for.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::sync::Arc;

fuzz_target!(|data: &[u8]| {
    let _ = pathtracer::io::nvdb::grid_names(data);
    let Ok(Some(g)) = pathtracer::io::nvdb::read_grid(data, "density") else {
        return;
    };
    let g = Arc::new(g);
    let Ok((first, res)) = g.extent() else {
        return;
    };
    if let Ok(sparse) = g.sparse_over(first, res) {
        for p in [0.0, 0.3, 0.5, 1.0] {
            let _ = sparse.lookup(glam::Vec3::splat(p));
        }
    }
    if res.iter().map(|&n| u64::from(n)).product::<u64>() <= 1 << 16 {
        let _ = g.dense_over(first, res);
    }
});
