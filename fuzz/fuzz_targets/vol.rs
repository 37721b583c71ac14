//! Mitsuba `.vol` grid files on arbitrary bytes: a grid, then lookups and a medium's
//! majorants over it, or an error; never a panic or an allocation the file's length does not
//! pay for.
#![no_main]
use libfuzzer_sys::fuzz_target;
use pathtracer::medium::grid::{Field, GridEdge, GridFilter};

fuzz_target!(|data: &[u8]| {
    let Ok(v) = pathtracer::io::vol::read(data, GridEdge::Clamp, GridFilter::Trilinear) else {
        return;
    };
    let _ = v.grid.lookup(glam::Vec3::splat(0.3));
    let fields = (
        Field::grid(glam::Vec3::ONE, 0),
        Field::grid(glam::Vec3::ONE, 0),
        Field::constant(glam::Vec3::ZERO),
    );
    let grids = vec![std::sync::Arc::new(v.grid)];
    let _ = pathtracer::medium::GridMedium::new(glam::Affine3A::IDENTITY, grids, fields, 0.0);
});
