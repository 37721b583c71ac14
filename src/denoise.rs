//! Denoising with Intel Open Image Denoise 2 (OIDN), loaded when it is first asked for: its
//! `RT` filter on a linear HDR image, with albedo and normal features that it denoises first
//! (OIDN's "prefiltered auxiliaries", its recommended mode for final frames).
//!
//! The library is not linked in, so that the renderer builds and runs where OIDN is not
//! installed; [`Denoiser::load`] looks for it, in this order, where
//! - `PATHTRACER_OIDN` names it (the library file, or a folder holding it; where it is set,
//!   nowhere else is tried);
//! - `OIDN_DIR` names an OIDN installation (its `lib` folder);
//! - the `pyoidn` Python package (`pip install pyoidn`) is installed: in the active virtual
//!   environment, or wherever `python3` imports it from;
//! - the system's library path has it.
//!
//! Inputs are made safe before OIDN sees them: non-finite values become 0, colours are
//! clamped to `[0, MAX_INPUT]`, albedos to `[0, 1]` and normals to `[−1, 1]`; the output's
//! non-finite values (none are expected) become 0.

use crate::io::image::Image;
use glam::Vec3;
use std::ffi::{c_char, c_void, CStr};
use std::path::{Path, PathBuf};

/// Largest colour value passed to OIDN (its HDR mode takes values up to about 65504·2¹⁰).
pub const MAX_INPUT: f32 = 1.0e7;

/// What to do where OIDN cannot be found, for messages.
pub const HOW_TO_GET: &str = "install it with `pip install pyoidn`, or set PATHTRACER_OIDN to \
     the path of libOpenImageDenoise";

type NewDevice = unsafe extern "C" fn(i32) -> *mut c_void;
type DeviceFn = unsafe extern "C" fn(*mut c_void);
type DeviceError = unsafe extern "C" fn(*mut c_void, *mut *const c_char) -> i32;
type NewFilter = unsafe extern "C" fn(*mut c_void, *const c_char) -> *mut c_void;
type FilterFn = unsafe extern "C" fn(*mut c_void);
type SetImage = unsafe extern "C" fn(
    *mut c_void,
    *const c_char,
    *mut c_void,
    i32,
    usize,
    usize,
    usize,
    usize,
    usize,
);
type SetBool = unsafe extern "C" fn(*mut c_void, *const c_char, bool);
type SetInt = unsafe extern "C" fn(*mut c_void, *const c_char, i32);

/// OIDN's C functions this module calls (OIDN 2's `oidn.h`).
struct Api {
    new_device: NewDevice,
    commit_device: DeviceFn,
    release_device: DeviceFn,
    device_error: DeviceError,
    new_filter: NewFilter,
    set_image: SetImage,
    set_bool: SetBool,
    set_int: SetInt,
    commit_filter: FilterFn,
    execute_filter: FilterFn,
    release_filter: FilterFn,
}

/// `OIDN_DEVICE_TYPE_CPU`, `OIDN_FORMAT_FLOAT3`, `OIDN_QUALITY_BALANCED` and
/// `OIDN_QUALITY_HIGH`.
const DEVICE_CPU: i32 = 1;
const FORMAT_FLOAT3: i32 = 3;
const QUALITY_BALANCED: i32 = 5;
const QUALITY_HIGH: i32 = 6;

/// How thoroughly to denoise, as OIDN's documentation recommends for each use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Quality {
    /// Final frames: high quality, with the features prefiltered first (three filter runs).
    #[default]
    Final,
    /// Interactive previews: balanced quality, with the features used as they are (one run).
    Interactive,
}

/// A loaded OIDN library and a committed CPU device of it.
pub struct Denoiser {
    api: Api,
    device: *mut c_void,
    /// Where the library was found.
    pub library: PathBuf,
    // Last, so that it is unloaded after the device is released.
    _lib: libloading::Library,
}

// OIDN's API is thread-safe ("all API calls are thread-safe; operations that use the same
// device are serialized"), and the device is only released on drop.
unsafe impl Send for Denoiser {}
unsafe impl Sync for Denoiser {}

impl Drop for Denoiser {
    fn drop(&mut self) {
        // SAFETY: the device was made by this library, which is still loaded.
        unsafe { (self.api.release_device)(self.device) };
    }
}

/// An image of `width × height` RGB pixels, row-major from the top left.
#[derive(Clone, Copy, Debug)]
pub struct Frame<'a> {
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// The noisy linear radiance.
    pub color: &'a [Vec3],
    /// The albedo feature (`[0, 1]`), if any.
    pub albedo: Option<&'a [Vec3]>,
    /// The normal feature (components in `[−1, 1]`), if any; only with an albedo.
    pub normal: Option<&'a [Vec3]>,
}

impl Denoiser {
    /// Loads OIDN from the first place the module's list gives that has it and makes a CPU
    /// device; an error naming what was tried and how to get OIDN where none loads.
    pub fn load() -> Result<Denoiser, String> {
        Denoiser::load_with(None)
    }

    /// [`Denoiser::load`], trying the folder `pyoidn_lib` (the `oidn/lib` folder of a
    /// `pyoidn` package the caller found, as the Python module does) right after
    /// `PATHTRACER_OIDN`.
    pub fn load_with(pyoidn_lib: Option<&Path>) -> Result<Denoiser, String> {
        let mut tried = Vec::new();
        for candidate in candidates(pyoidn_lib) {
            // SAFETY: loading runs the library's initialisers; OIDN's have no preconditions.
            match unsafe { libloading::Library::new(&candidate) } {
                Ok(lib) => return Denoiser::with_library(lib, candidate),
                Err(e) => tried.push(format!("{}: {e}", candidate.display())),
            }
        }
        Err(format!(
            "Open Image Denoise 2 was not found ({HOW_TO_GET}); tried {}",
            tried.join("; ")
        ))
    }

    fn with_library(lib: libloading::Library, library: PathBuf) -> Result<Denoiser, String> {
        let missing = |e: libloading::Error| {
            format!(
                "{} is not Open Image Denoise 2 ({e}); {HOW_TO_GET}",
                library.display()
            )
        };
        // SAFETY: each symbol is declared with its type in OIDN 2's `oidn.h`.
        let api = unsafe {
            Api {
                new_device: *lib.get(b"oidnNewDevice\0").map_err(missing)?,
                commit_device: *lib.get(b"oidnCommitDevice\0").map_err(missing)?,
                release_device: *lib.get(b"oidnReleaseDevice\0").map_err(missing)?,
                device_error: *lib.get(b"oidnGetDeviceError\0").map_err(missing)?,
                new_filter: *lib.get(b"oidnNewFilter\0").map_err(missing)?,
                set_image: *lib.get(b"oidnSetSharedFilterImage\0").map_err(missing)?,
                set_bool: *lib.get(b"oidnSetFilterBool\0").map_err(missing)?,
                set_int: *lib.get(b"oidnSetFilterInt\0").map_err(missing)?,
                commit_filter: *lib.get(b"oidnCommitFilter\0").map_err(missing)?,
                execute_filter: *lib.get(b"oidnExecuteFilter\0").map_err(missing)?,
                release_filter: *lib.get(b"oidnReleaseFilter\0").map_err(missing)?,
            }
        };
        // SAFETY: a device is made and committed as `oidn.h` documents.
        let device = unsafe { (api.new_device)(DEVICE_CPU) };
        if device.is_null() {
            return Err("Open Image Denoise could not make a CPU device".into());
        }
        let d = Denoiser {
            api,
            device,
            library,
            _lib: lib,
        };
        // SAFETY: `device` is live.
        unsafe { (d.api.commit_device)(d.device) };
        d.check("making its CPU device")?;
        Ok(d)
    }

    /// The device's pending error, if any, as a message.
    fn check(&self, doing: &str) -> Result<(), String> {
        let mut message: *const c_char = std::ptr::null();
        // SAFETY: `device` is live; OIDN leaves a NUL-terminated message or null.
        let code = unsafe { (self.api.device_error)(self.device, &mut message) };
        if code == 0 {
            return Ok(());
        }
        let text = if message.is_null() {
            String::new()
        } else {
            // SAFETY: non-null messages are NUL-terminated and live until the next call.
            unsafe { CStr::from_ptr(message) }
                .to_string_lossy()
                .into_owned()
        };
        Err(format!(
            "Open Image Denoise failed {doing} (error {code}): {text}"
        ))
    }

    /// The denoised image of `frame` for final frames ([`Quality::Final`]: its features
    /// denoised first, then the colour with them, OIDN's `RT` filter in HDR mode, high
    /// quality). An error where the sizes disagree or OIDN reports one.
    pub fn denoise(&self, frame: &Frame) -> Result<Vec<Vec3>, String> {
        self.denoise_with(frame, Quality::Final)
    }

    /// The denoised image of `frame` at `quality`: as [`Denoiser::denoise`], with the
    /// features used as they are for [`Quality::Interactive`].
    pub fn denoise_with(&self, frame: &Frame, quality: Quality) -> Result<Vec<Vec3>, String> {
        let n = frame.width * frame.height;
        let sizes_agree = frame.color.len() == n
            && frame.albedo.is_none_or(|a| a.len() == n)
            && frame.normal.is_none_or(|a| a.len() == n);
        if !sizes_agree || n == 0 {
            return Err(format!(
                "denoising needs {}×{} pixels in every image",
                frame.width, frame.height
            ));
        }
        let mut color: Vec<Vec3> = frame
            .color
            .iter()
            .map(|&c| safe(c, 0.0, MAX_INPUT))
            .collect();
        let mut albedo: Option<Vec<Vec3>> = frame
            .albedo
            .map(|a| a.iter().map(|&c| safe(c, 0.0, 1.0)).collect());
        let mut normal: Option<Vec<Vec3>> = match (&albedo, frame.normal) {
            (Some(_), Some(nm)) => Some(nm.iter().map(|&c| safe(c, -1.0, 1.0)).collect()),
            _ => None,
        };
        let size = (frame.width, frame.height);
        let prefilter = quality == Quality::Final;
        if let Some(a) = albedo.as_mut().filter(|_| prefilter) {
            self.run(size, &mut [("albedo", a)], None)?;
        }
        if let Some(nm) = normal.as_mut().filter(|_| prefilter) {
            self.run(size, &mut [("normal", nm)], None)?;
        }
        let mut output = vec![Vec3::ZERO; n];
        let mut images: Vec<(&str, &mut Vec<Vec3>)> = vec![("color", &mut color)];
        if let Some(a) = albedo.as_mut() {
            images.push(("albedo", a));
        }
        if let Some(nm) = normal.as_mut() {
            images.push(("normal", nm));
        }
        images.push(("output", &mut output));
        self.run(size, &mut images, Some(quality))?;
        Ok(output
            .into_iter()
            .map(|c| {
                if c.is_finite() {
                    c.max(Vec3::ZERO)
                } else {
                    Vec3::ZERO
                }
            })
            .collect())
    }

    /// [`Denoiser::denoise_with`] of a developed image with the film's features, if any (as
    /// [`crate::film::Film::feature_images`] gives them).
    pub fn denoise_image(
        &self,
        image: &Image,
        features: Option<&(Image, Image)>,
        quality: Quality,
    ) -> Result<Image, String> {
        let frame = Frame {
            width: image.width,
            height: image.height,
            color: &image.pixels,
            albedo: features.map(|f| f.0.pixels.as_slice()),
            normal: features.map(|f| f.1.pixels.as_slice()),
        };
        Ok(Image {
            width: image.width,
            height: image.height,
            pixels: self.denoise_with(&frame, quality)?,
        })
    }

    /// Runs one `RT` filter over `images` (name and pixels; without an `output`, the first
    /// image is denoised in place, as OIDN prefilters features): the colour in HDR mode at
    /// `colour`'s quality (with prefiltered features for [`Quality::Final`]), or a feature at
    /// high quality where `colour` is `None`.
    fn run(
        &self,
        (width, height): (usize, usize),
        images: &mut [(&str, &mut Vec<Vec3>)],
        colour: Option<Quality>,
    ) -> Result<(), String> {
        let api = &self.api;
        // SAFETY: the filter is made, given images that outlive its execution (they are
        // borrowed for this call), run and released, as `oidn.h` documents; every image holds
        // `width × height` pixels of three packed floats.
        unsafe {
            let filter = (api.new_filter)(self.device, c"RT".as_ptr());
            if filter.is_null() {
                self.check("making its filter")?;
                return Err("Open Image Denoise made no filter".into());
            }
            let stride = std::mem::size_of::<Vec3>();
            let set = |name: &CStr, pixels: &mut Vec<Vec3>| {
                (api.set_image)(
                    filter,
                    name.as_ptr(),
                    pixels.as_mut_ptr().cast(),
                    FORMAT_FLOAT3,
                    width,
                    height,
                    0,
                    stride,
                    stride * width,
                )
            };
            let has_output = images.iter().any(|(name, _)| *name == "output");
            for (name, pixels) in images.iter_mut() {
                let c_name = std::ffi::CString::new(*name).unwrap_or_default();
                set(&c_name, pixels);
            }
            if !has_output {
                if let Some((_, pixels)) = images.first_mut() {
                    set(c"output", pixels);
                }
            }
            let mut quality = QUALITY_HIGH;
            if let Some(q) = colour {
                (api.set_bool)(filter, c"hdr".as_ptr(), true);
                (api.set_bool)(filter, c"cleanAux".as_ptr(), q == Quality::Final);
                if q == Quality::Interactive {
                    quality = QUALITY_BALANCED;
                }
            }
            (api.set_int)(filter, c"quality".as_ptr(), quality);
            (api.commit_filter)(filter);
            let committed = self.check("setting up its filter");
            if committed.is_ok() {
                (api.execute_filter)(filter);
            }
            let executed = self.check("denoising");
            (api.release_filter)(filter);
            committed.and(executed)
        }
    }
}

/// `v` with non-finite components 0 and the rest clamped to `[lo, hi]`.
fn safe(v: Vec3, lo: f32, hi: f32) -> Vec3 {
    Vec3::from_array(
        v.to_array()
            .map(|c| if c.is_finite() { c.clamp(lo, hi) } else { 0.0 }),
    )
}

/// The library file names OIDN 2 goes by.
const NAMES: [&str; 2] = ["libOpenImageDenoise.so.2", "libOpenImageDenoise.so"];

/// The places to look for OIDN, in the module's order (`pyoidn_lib` after `PATHTRACER_OIDN`).
fn candidates(pyoidn_lib: Option<&Path>) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let in_folder = |dir: &Path, out: &mut Vec<PathBuf>| {
        for name in NAMES {
            let p = dir.join(name);
            if p.is_file() {
                out.push(p);
                return;
            }
        }
    };
    if let Some(p) = std::env::var_os("PATHTRACER_OIDN").map(PathBuf::from) {
        if p.is_dir() {
            in_folder(&p, &mut out);
        }
        if out.is_empty() {
            out.push(p);
        }
        return out;
    }
    if let Some(dir) = pyoidn_lib {
        in_folder(dir, &mut out);
    }
    if let Some(dir) = std::env::var_os("OIDN_DIR").map(PathBuf::from) {
        in_folder(&dir.join("lib"), &mut out);
    }
    for dir in python_packages() {
        in_folder(&dir.join("pyoidn").join("oidn").join("lib"), &mut out);
    }
    out.extend(NAMES.iter().map(PathBuf::from));
    out
}

/// Folders Python packages may be installed in: the active virtual environment's, and the
/// one `python3` imports `pyoidn` from (asked only where the first has none).
fn python_packages() -> Vec<PathBuf> {
    let mut out = Vec::new();
    if let Some(env) = std::env::var_os("VIRTUAL_ENV").map(PathBuf::from) {
        if let Ok(entries) = std::fs::read_dir(env.join("lib")) {
            for e in entries.flatten() {
                let site = e.path().join("site-packages");
                if site.join("pyoidn").is_dir() {
                    out.push(site);
                }
            }
        }
    }
    if out.is_empty() {
        let asked = std::process::Command::new("python3")
            .args([
                "-c",
                "import importlib.util as u, os; s = u.find_spec('pyoidn'); \
                 print(os.path.dirname(os.path.dirname(s.origin)) if s else '')",
            ])
            .stderr(std::process::Stdio::null())
            .output();
        if let Ok(o) = asked {
            let text = String::from_utf8_lossy(&o.stdout).trim().to_string();
            if !text.is_empty() {
                out.push(PathBuf::from(text));
            }
        }
    }
    out
}
