//! Acceleration structures.

pub mod bvh;
pub mod tribvh;
pub mod wide;
