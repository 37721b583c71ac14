//! Acceleration structures.

pub mod bvh;
mod simd;
pub mod tribvh;
pub mod wide;
