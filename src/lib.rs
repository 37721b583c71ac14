//! A physically based path tracer for the CS184 PathTracer scenes.
//!
//! Data flow: scene file → [`io::desc::SceneDesc`] ([`io::collada`]) → [`scene::Scene`]
//! ([`scene::build`]) → BVH ([`accel::bvh`]) → integrator ([`integrator`]) → tiles and threads
//! ([`render`]) → [`film::Film`] (exact sums: resume, merge, checkpoints) → [`io::image::Image`]
//! → PNG/EXR.
//!
//! ```no_run
//! let desc = pathtracer::io::collada::load_file("scene.dae".as_ref()).unwrap();
//! let scene = pathtracer::scene::build::build(&desc);
//! let opts = pathtracer::render::RenderOptions::default();
//! let (image, _stats) = pathtracer::render::render(&scene, &opts, &|_, _| {}).unwrap();
//! image.save("out.png".as_ref()).unwrap();
//! ```

#![warn(missing_docs)]

pub mod accel;
pub mod bench;
pub mod bsdf;
pub mod builtin;
pub mod camera;
pub mod error;
pub mod film;
pub mod info;
pub mod integrator;
pub mod io;
pub mod light;
pub mod math;
pub mod quality;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod setup;
#[cfg(feature = "view")]
pub mod view;

pub use error::{Error, Result};
