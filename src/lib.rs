//! A physically based path tracer for the CS184 PathTracer scenes and OBJ, PLY and glTF files.
//!
//! Data flow: scene file → [`io::desc::SceneDesc`] (one loader per format, [`io::load_scene`])
//! → [`scene::Scene`] ([`scene::build`], with its BVHs, [`accel`]) → a render session
//! ([`render::Session`]: the options of [`options`], a camera, threads, the integrator
//! [`integrator`]) → [`film::Film`] (exact sums: resume, merge, checkpoints) →
//! [`io::image::Image`] → PNG/EXR. Every shell (the command line, the viewer `view`, the
//! Python module, the farm) goes through [`setup`] and [`render`]; see `docs/architecture.md`.
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
pub mod denoise;
pub mod error;
pub mod features;
pub mod film;
pub mod filter;
pub mod geometry;
pub mod guide;
pub mod info;
pub mod integrator;
pub mod io;
pub mod lanes;
pub mod light;
pub mod lighttrace;
pub mod math;
pub mod medium;
pub mod memory;
pub mod options;
pub mod quality;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod setup;
pub mod vertex;
#[cfg(feature = "view")]
pub mod view;
pub mod vollight;
pub mod volpath;

pub use error::{Error, Result};

/// Why this build cannot run on this CPU: the features it was compiled to assume
/// (`.cargo/config.toml` targets x86-64-v3) that the CPU lacks, and how to rebuild; `None`
/// when it has them all. Front ends call it first, before any work could execute such an
/// instruction.
pub fn unsupported_cpu() -> Option<String> {
    #[allow(unused_mut)]
    let mut missing: Vec<&str> = Vec::new();
    #[cfg(target_arch = "x86_64")]
    {
        macro_rules! check {
            ($($f:tt),*) => {$(
                #[cfg(target_feature = $f)]
                if !std::arch::is_x86_feature_detected!($f) {
                    missing.push($f);
                }
            )*};
        }
        check!("avx", "avx2", "fma", "bmi1", "bmi2", "lzcnt", "movbe", "f16c");
    }
    (!missing.is_empty()).then(|| {
        format!(
            "this build of pathtracer needs the CPU features {} (x86-64-v3, see \
             .cargo/config.toml); rebuild with RUSTFLAGS=\"-C target-cpu=x86-64\" for this CPU",
            missing.join(", ")
        )
    })
}
