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
pub mod lighttrace;
pub mod math;
pub mod options;
pub mod packet;
pub mod quality;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod setup;
#[cfg(feature = "view")]
pub mod view;

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
