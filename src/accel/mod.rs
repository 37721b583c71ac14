//! Acceleration structures.

pub mod bvh;
pub mod bvh4;
pub mod tribvh;
