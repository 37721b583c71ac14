//! Input and output: scene files to descriptions, images to and from disk.

pub mod atomic;
pub mod collada;
pub mod desc;
pub mod image;
pub mod sheet;
pub mod tev;
