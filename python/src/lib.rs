//! `pathtracer._core`: the Python binding of the pathtracer library (pyo3, abi3).
//!
//! A thin shell: scenes are set up by `pathtracer::setup` and rendered by
//! `pathtracer::render::render_into`, exactly as the command line does, so the same options
//! give the same bits. Images are `numpy.float32` arrays of shape (height, width, 3), linear
//! RGB, row 0 at the top. Renders release the GIL and poll for Ctrl-C every 20 ms: the
//! render stops and `KeyboardInterrupt` is raised.

use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray2, PyArray3, PyReadonlyArray3};
use pathtracer::camera::Camera as RsCamera;
use pathtracer::film::Film as RsFilm;
use pathtracer::integrator::{Direct, LightSelection};
use pathtracer::io::image::Image;
use pathtracer::light::env::EnvSampling;
use pathtracer::render::{self, Adaptive, Cell, Control, RenderOptions};
use pathtracer::sampling::sampler::SamplerKind;
use pathtracer::setup::{self, Loaded, View};
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

create_exception!(
    _core,
    Error,
    PyException,
    "A scene, image or film that cannot be read or written, or invalid options; the message is \
     the command line's (file and line where there is one)."
);

/// The library's error as a Python exception with the command line's text.
fn err(e: pathtracer::Error) -> PyErr {
    Error::new_err(e.to_string())
}

/// Runs `job` on a thread of its own while the caller's thread, without the GIL, waits for it
/// and checks for signals every 20 ms; on `KeyboardInterrupt` (or any exception a signal
/// handler raises) `job`'s stop flag is set, the job finishes its current samples, and the
/// exception is raised.
fn interruptible<T: Send>(
    py: Python<'_>,
    job: impl FnOnce(&AtomicBool) -> T + Send,
) -> PyResult<T> {
    let stop = AtomicBool::new(false);
    let (tx, rx) = std::sync::mpsc::sync_channel(1);
    std::thread::scope(|s| {
        let stop = &stop;
        s.spawn(move || {
            // A panic drops `tx` unsent: the receiver sees the disconnection.
            let _ = tx.send(job(stop));
        });
        let mut rx = rx;
        loop {
            let (got, back) = py.detach(move || {
                let got = rx.recv_timeout(Duration::from_millis(20));
                (got, rx)
            });
            rx = back;
            match got {
                Ok(v) => return Ok(v),
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                    return Err(PyRuntimeError::new_err("the render thread panicked"))
                }
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
            }
            if let Err(e) = py.check_signals() {
                stop.store(true, Ordering::SeqCst);
                // The scope joins the job, which stops after its current samples.
                return Err(e);
            }
        }
    })
}

/// An image as a float32 array (height, width, 3).
fn array<'py>(py: Python<'py>, img: &Image) -> Bound<'py, PyArray3<f32>> {
    let data: Vec<f32> = img.pixels.iter().flat_map(|p| p.to_array()).collect();
    Array3::from_shape_vec((img.height, img.width, 3), data)
        .expect("an image holds width × height pixels")
        .into_pyarray(py)
}

/// A 3-vector from Python.
fn vec3(v: [f32; 3]) -> glam::Vec3 {
    glam::Vec3::from_array(v)
}

fn env_sampling(name: &str) -> PyResult<EnvSampling> {
    match name {
        "importance" => Ok(EnvSampling::Importance),
        "uniform" => Ok(EnvSampling::Uniform),
        _ => Err(PyValueError::new_err(format!(
            "env_sampling '{name}' is not one of 'importance', 'uniform'"
        ))),
    }
}

/// A camera: where the scene's camera is moved to (`--lookat`), its vertical field of view
/// (`--fov`), lens radius (`-b`) and focal distance (`-d`). Read from `Scene.camera`, change,
/// and assign back; or make one with `Camera(position, target, up, fov=...)`.
#[pyclass(module = "pathtracer")]
#[derive(Clone)]
struct Camera {
    /// The scene's camera the choices apply to (`None` for a camera made from scratch).
    base: Option<RsCamera>,
    /// The file camera's exact vertical field of view (glTF), as in `setup::Loaded`.
    file_vfov: Option<f64>,
    view: View,
}

impl Camera {
    /// The camera these choices give for an image `height` pixels high.
    fn resolve(&self, height: u32) -> PyResult<RsCamera> {
        let base = match &self.base {
            Some(b) => b.clone(),
            None => RsCamera::look_at(glam::Vec3::Z, glam::Vec3::ZERO, 50.0, 40.0),
        };
        self.view
            .camera(&base, self.file_vfov, height)
            .map_err(|e| PyValueError::new_err(e.to_string()))
    }

    fn lookat(&self) -> PyResult<[glam::Vec3; 3]> {
        if let Some(l) = self.view.lookat {
            return Ok(l);
        }
        let c = self.resolve(360)?;
        Ok([c.pos, c.target, c.up])
    }

    /// Applies `change` to the view choices when the camera they then give is valid, and
    /// leaves them as they were otherwise.
    fn update(&mut self, change: impl FnOnce(&mut View)) -> PyResult<()> {
        let old = self.view;
        change(&mut self.view);
        if let Err(e) = self.resolve(360) {
            self.view = old;
            return Err(e);
        }
        Ok(())
    }

    fn set_lookat(&mut self, i: usize, v: [f32; 3]) -> PyResult<()> {
        let mut l = self.lookat()?;
        l[i] = vec3(v);
        self.view.lookat = Some(l);
        Ok(())
    }
}

#[pymethods]
impl Camera {
    /// A camera at `position` looking at `target` with `up` as up, with a vertical field of
    /// view of `fov` degrees over the image's height (the scene's own when it is assigned to
    /// a scene without `fov`).
    #[new]
    #[pyo3(signature = (position, target, up = [0.0, 1.0, 0.0], fov = None, lens_radius = None, focal_distance = None))]
    fn new(
        position: [f32; 3],
        target: [f32; 3],
        up: [f32; 3],
        fov: Option<f64>,
        lens_radius: Option<f32>,
        focal_distance: Option<f32>,
    ) -> PyResult<Self> {
        let c = Camera {
            base: None,
            file_vfov: None,
            view: View {
                lookat: Some([vec3(position), vec3(target), vec3(up)]),
                fov,
                lens_radius,
                focal_distance,
            },
        };
        c.resolve(360)?;
        Ok(c)
    }

    /// Eye position, world space.
    #[getter]
    fn position(&self) -> PyResult<[f32; 3]> {
        Ok(self.lookat()?[0].to_array())
    }
    #[setter]
    fn set_position(&mut self, v: [f32; 3]) -> PyResult<()> {
        self.set_lookat(0, v)
    }
    /// The point looked at, world space.
    #[getter]
    fn target(&self) -> PyResult<[f32; 3]> {
        Ok(self.lookat()?[1].to_array())
    }
    #[setter]
    fn set_target(&mut self, v: [f32; 3]) -> PyResult<()> {
        self.set_lookat(1, v)
    }
    /// The up direction (any vector not along the view).
    #[getter]
    fn up(&self) -> PyResult<[f32; 3]> {
        Ok(self.lookat()?[2].to_array())
    }
    #[setter]
    fn set_up(&mut self, v: [f32; 3]) -> PyResult<()> {
        self.set_lookat(2, v)
    }
    /// Vertical field of view in degrees over the image's height, as set (`--fov`); `None`
    /// keeps the scene's (see `field_of_view`).
    #[getter]
    fn fov(&self) -> Option<f64> {
        self.view.fov
    }
    #[setter]
    fn set_fov(&mut self, v: Option<f64>) -> PyResult<()> {
        self.update(|view| view.fov = v)
    }
    /// Thin-lens radius in scene units (0: pinhole).
    #[getter]
    fn lens_radius(&self) -> PyResult<f32> {
        Ok(self.resolve(360)?.lens_radius)
    }
    #[setter]
    fn set_lens_radius(&mut self, v: f32) -> PyResult<()> {
        self.update(|view| view.lens_radius = Some(v))
    }
    /// Distance to the plane of focus along the view, scene units.
    #[getter]
    fn focal_distance(&self) -> PyResult<f32> {
        Ok(self.resolve(360)?.focal_distance)
    }
    #[setter]
    fn set_focal_distance(&mut self, v: f32) -> PyResult<()> {
        self.update(|view| view.focal_distance = Some(v))
    }
    /// The vertical field of view in degrees over an image `height` pixels high.
    #[pyo3(signature = (height = 360))]
    fn field_of_view(&self, height: u32) -> PyResult<f64> {
        let c = self.resolve(height)?;
        Ok(2.0
            * (height as f64 / (2.0 * c.focal_px as f64))
                .atan()
                .to_degrees())
    }
    fn __repr__(&self) -> PyResult<String> {
        let c = self.resolve(360)?;
        Ok(format!(
            "Camera(position={:?}, target={:?}, up={:?}, fov={:?}, lens_radius={}, focal_distance={})",
            self.position()?,
            self.target()?,
            self.up()?,
            self.view.fov,
            c.lens_radius,
            c.focal_distance
        ))
    }
}

/// A loaded scene: geometry, materials, lights, its camera and any environment light.
#[pyclass(module = "pathtracer", frozen)]
struct Scene {
    loaded: Arc<Loaded>,
    view: std::sync::Mutex<View>,
}

impl Scene {
    fn view(&self) -> View {
        *self.view.lock().unwrap_or_else(|e| e.into_inner())
    }
}

#[pymethods]
impl Scene {
    /// The scene's name (its file's stem; "cornell" for the built-in scene).
    #[getter]
    fn name(&self) -> String {
        self.loaded.scene.name.clone()
    }
    /// The summary `pathtracer --info` prints: triangles, spheres, lights, materials, camera.
    #[getter]
    fn summary(&self) -> String {
        pathtracer::info::summary(&self.loaded.scene)
    }
    /// Non-fatal problems found while loading, each naming its file (and line).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.loaded.warnings.clone()
    }
    /// The files the scene was read from: the scene file, the files it names (MTL, glTF
    /// buffers), the environment map and the camera file; empty for the built-in scene.
    #[getter]
    fn files(&self) -> Vec<PathBuf> {
        self.loaded.files.clone()
    }
    /// The camera (a copy: change it and assign it back).
    #[getter]
    fn camera(&self) -> Camera {
        Camera {
            base: Some(self.loaded.scene.camera.clone()),
            file_vfov: self.loaded.file_vfov,
            view: self.view(),
        }
    }
    #[setter]
    fn set_camera(&self, cam: PyRef<'_, Camera>) -> PyResult<()> {
        // A camera made from scratch without `fov` keeps the scene's, as --lookat does.
        let v = cam.view;
        let c = Camera {
            base: Some(self.loaded.scene.camera.clone()),
            file_vfov: self.loaded.file_vfov,
            view: v,
        };
        c.resolve(360)?;
        *self.view.lock().unwrap_or_else(|e| e.into_inner()) = v;
        Ok(())
    }
    fn __repr__(&self) -> String {
        let s = &self.loaded.scene;
        format!(
            "Scene('{}', {} triangles, {} spheres, {} lights)",
            s.name,
            s.tris.len(),
            s.spheres.len(),
            s.lights.len()
        )
    }
}

/// Loads a scene file of any format the command line reads (`.dae`, `.obj`, `.ply`, `.gltf`,
/// `.glb`; `None`: the built-in Cornell box), with an optional environment map (`-e`), its
/// sampling (`--env-sampling`) and a CS184 camera file (`-c`).
#[pyfunction]
#[pyo3(signature = (path = None, env = None, env_sampling = "importance", camera_file = None))]
fn load(
    py: Python<'_>,
    path: Option<PathBuf>,
    env: Option<PathBuf>,
    env_sampling: &str,
    camera_file: Option<PathBuf>,
) -> PyResult<Scene> {
    let sampling = self::env_sampling(env_sampling)?;
    let loaded = py
        .detach(|| -> pathtracer::Result<Loaded> {
            let mut l = setup::load(path.as_deref(), env.as_deref(), sampling)?;
            if let Some(c) = &camera_file {
                l.use_camera_file(c)?;
            }
            Ok(l)
        })
        .map_err(err)?;
    Ok(Scene {
        loaded: Arc::new(loaded),
        view: std::sync::Mutex::new(View::default()),
    })
}

/// The render options of keyword arguments; names follow the command line's flags.
fn options(kw: Option<&Bound<'_, PyDict>>) -> PyResult<RenderOptions> {
    let mut o = RenderOptions::default();
    let Some(kw) = kw else {
        return Ok(o);
    };
    let positive = |name: &str, v: u32| {
        if v == 0 {
            Err(PyValueError::new_err(format!("{name} must be positive")))
        } else {
            Ok(v)
        }
    };
    for (k, v) in kw.iter() {
        let key: String = k.extract()?;
        if v.is_none() {
            match key.as_str() {
                "threads" | "time_limit" | "cell" | "sample_range" | "adaptive" => continue,
                _ => return Err(PyTypeError::new_err(format!("{key} cannot be None"))),
            }
        }
        match key.as_str() {
            "spp" => o.spp = positive("spp", v.extract()?)?,
            "light_samples" => {
                o.integrator.light_samples = positive("light_samples", v.extract()?)?
            }
            "max_depth" => o.integrator.max_depth = v.extract()?,
            "accumulate" => o.integrator.accumulate = v.extract()?,
            "hemisphere" => {
                if v.extract()? {
                    o.integrator.direct = Direct::Hemisphere;
                }
            }
            "direct" => {
                let s: String = v.extract()?;
                if o.integrator.direct != Direct::Hemisphere {
                    o.integrator.direct = match s.as_str() {
                        "mis" => Direct::Mis,
                        "light" => Direct::Light,
                        "bsdf" => Direct::Bsdf,
                        _ => {
                            return Err(PyValueError::new_err(format!(
                                "direct '{s}' is not one of 'mis', 'light', 'bsdf'"
                            )))
                        }
                    }
                }
            }
            "light_selection" => {
                let s: String = v.extract()?;
                o.integrator.selection = match s.as_str() {
                    "power" => LightSelection::Power,
                    "all" => LightSelection::All,
                    _ => {
                        return Err(PyValueError::new_err(format!(
                            "light_selection '{s}' is not one of 'power', 'all'"
                        )))
                    }
                }
            }
            "sampler" => {
                let s: String = v.extract()?;
                o.sampler = match s.as_str() {
                    "sobol" => SamplerKind::Sobol,
                    "zsobol" => SamplerKind::ZSobol,
                    "independent" => SamplerKind::Independent,
                    _ => {
                        return Err(PyValueError::new_err(format!(
                            "sampler '{s}' is not one of 'sobol', 'zsobol', 'independent'"
                        )))
                    }
                }
            }
            "rr_depth" => o.integrator.rr_depth = positive("rr_depth", v.extract()?)?,
            "caustics" => {
                let s: String = v.extract()?;
                o.integrator.light_tracing = match s.as_str() {
                    "light" => true,
                    "path" => false,
                    _ => {
                        return Err(PyValueError::new_err(format!(
                            "caustics '{s}' is not one of 'light', 'path'"
                        )))
                    }
                }
            }
            "seed" => o.seed = v.extract()?,
            "width" => o.width = positive("width", v.extract()?)?,
            "height" => o.height = positive("height", v.extract()?)?,
            "threads" => o.threads = Some(positive("threads", v.extract()?)? as usize),
            "time_limit" => {
                let t: f64 = v.extract()?;
                if !(t > 0.0 && t.is_finite()) {
                    return Err(PyValueError::new_err(
                        "time_limit must be a positive number",
                    ));
                }
                o.time_limit = Some(t);
            }
            "cell" => {
                let (x, y, w, h): (u32, u32, u32, u32) = v.extract()?;
                o.cell = Some(Cell { x, y, w, h });
            }
            "sample_range" => {
                let (first, count): (u32, u32) = v.extract()?;
                o.sample_range = Some((first, count));
            }
            "adaptive" => {
                let (batch, tolerance): (u32, f32) = v.extract()?;
                o.adaptive = Some(Adaptive { batch, tolerance });
            }
            "adaptive_budget" => o.adaptive_budget = v.extract()?,
            _ => {
                return Err(PyTypeError::new_err(format!(
                    "unknown render option '{key}' (spp, light_samples, max_depth, accumulate, \
                     hemisphere, direct, light_selection, sampler, rr_depth, caustics, seed, width, height, \
                     threads, time_limit, cell, sample_range, adaptive, adaptive_budget)"
                )))
            }
        }
    }
    Ok(o)
}

/// The scene with its camera for the options' image height, and the options.
fn prepared(
    scene: &Scene,
    kw: Option<&Bound<'_, PyDict>>,
) -> PyResult<(Arc<Loaded>, RsCamera, RenderOptions)> {
    let opts = options(kw)?;
    let cam = scene
        .view()
        .camera(
            &scene.loaded.scene.camera,
            scene.loaded.file_vfov,
            opts.height,
        )
        .map_err(err)?;
    Ok((scene.loaded.clone(), cam, opts))
}

/// Renders into `film` (taken out of its Python object for the render and put back after).
fn render_film_into(
    py: Python<'_>,
    scene: &Scene,
    film: &mut RsFilm,
    kw: Option<&Bound<'_, PyDict>>,
) -> PyResult<()> {
    let (loaded, cam, opts) = prepared(scene, kw)?;
    let result = interruptible(py, |stop| -> pathtracer::Result<()> {
        let scene = scene_with(&loaded, cam);
        let quiet = |_: usize, _: usize| {};
        render::render_into(&scene, &opts, film, Control::new(stop, &quiet))?;
        Ok(())
    })?;
    result.map_err(err)
}

/// The scene of `loaded` with camera `cam`; clones it only when the camera differs.
fn scene_with(loaded: &Loaded, cam: RsCamera) -> std::borrow::Cow<'_, pathtracer::scene::Scene> {
    let same = {
        let c = &loaded.scene.camera;
        c.pos == cam.pos
            && c.forward == cam.forward
            && c.right == cam.right
            && c.up == cam.up
            && c.focal_px == cam.focal_px
            && c.lens_radius == cam.lens_radius
            && c.focal_distance == cam.focal_distance
    };
    if same {
        std::borrow::Cow::Borrowed(&loaded.scene)
    } else {
        let mut s = loaded.scene.clone();
        s.camera = cam;
        std::borrow::Cow::Owned(s)
    }
}

/// Renders `scene` and returns the image as a float32 array (height, width, 3), linear RGB.
/// Keyword options follow the command line: `spp=16`, `max_depth=5`, `light_samples=1`,
/// `accumulate=True`, `hemisphere=False`, `direct='mis'`, `light_selection='power'`,
/// `sampler='sobol'`, `rr_depth=5`, `caustics='light'`, `seed=0`, `width=480`, `height=360`,
/// `cell=(x, y, w, h)`,
/// `threads=None` (all cores), `time_limit=None` (seconds), `sample_range=(first, count)`,
/// `adaptive=(batch, tolerance)`, `adaptive_budget=False`.
#[pyfunction]
#[pyo3(name = "render", signature = (scene, **kw))]
fn render_image<'py>(
    py: Python<'py>,
    scene: &Scene,
    kw: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let opts = options(kw)?;
    let mut film = render::new_film(&opts).map_err(err)?;
    render_film_into(py, scene, &mut film, kw)?;
    Ok(array(py, &film.develop()))
}

/// The exact sums of a render (see the command line's checkpoints): render into it, merge the
/// films of adjacent sample ranges, develop the image, save and load it. Pickles as its bytes.
#[pyclass(module = "pathtracer")]
struct Film {
    inner: RsFilm,
}

#[pymethods]
impl Film {
    /// An empty film for a `width × height` frame (or its `cell`), whose samples start at
    /// `first` of each pixel's sequence.
    #[new]
    #[pyo3(signature = (width = 480, height = 360, cell = None, first = 0))]
    fn new(
        width: u32,
        height: u32,
        cell: Option<(u32, u32, u32, u32)>,
        first: u32,
    ) -> PyResult<Self> {
        let cell = cell.map(|(x, y, w, h)| Cell { x, y, w, h });
        Ok(Film {
            inner: RsFilm::new(width, height, cell, first).map_err(err)?,
        })
    }
    /// The frame's size (width, height) in pixels.
    #[getter]
    fn frame(&self) -> (u32, u32) {
        self.inner.frame()
    }
    /// The part of the frame the film holds: (x, y, width, height).
    #[getter]
    fn cell(&self) -> (u32, u32, u32, u32) {
        let c = self.inner.cell();
        (c.x, c.y, c.w, c.h)
    }
    /// The first sample of each pixel's sequence that the film's range starts at.
    #[getter]
    fn first(&self) -> u32 {
        self.inner.first()
    }
    /// Samples held, all pixels together.
    #[getter]
    fn samples(&self) -> u64 {
        self.inner.samples()
    }
    /// Samples held per pixel, a uint32 array (height, width).
    fn counts<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<u32>> {
        let c = self.inner.cell();
        Array2::from_shape_vec((c.h as usize, c.w as usize), self.inner.counts())
            .expect("a film holds width × height pixels")
            .into_pyarray(py)
    }
    /// The image: the mean of each pixel's samples, float32 (height, width, 3).
    fn develop<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f32>> {
        array(py, &self.inner.develop())
    }
    /// Adds the film of the adjacent sample range `other` (same frame and cell; it starts
    /// where this one's samples end, pixel by pixel). Exact: any split merges to the whole.
    fn merge(&mut self, other: &Film) -> PyResult<()> {
        self.inner.merge(&other.inner).map_err(err)
    }
    /// Writes the film (the command line's checkpoint format) to `path`, atomically.
    fn save(&self, path: PathBuf) -> PyResult<()> {
        self.inner.save(&path).map_err(err)
    }
    /// Reads a film written by `save` (or a command-line checkpoint).
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Film> {
        Ok(Film {
            inner: RsFilm::load(&path).map_err(err)?,
        })
    }
    /// The film's bytes (the file format of `save`).
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.inner.to_bytes())
    }
    /// A film from `to_bytes`' bytes, checked (digest, size, header).
    #[staticmethod]
    fn from_bytes(data: &[u8]) -> PyResult<Film> {
        Ok(Film {
            inner: RsFilm::from_bytes(data, "film bytes").map_err(err)?,
        })
    }
    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
    ) -> PyResult<(Bound<'py, PyAny>, (Bound<'py, PyBytes>,))> {
        let py = slf.py();
        let from = slf.get_type().getattr("from_bytes")?;
        Ok((from, (slf.borrow().to_bytes(py),)))
    }
    fn __repr__(&self) -> String {
        let (w, h) = self.inner.frame();
        let c = self.inner.cell();
        format!(
            "Film({w}x{h}, cell=({}, {}, {}, {}), first={}, samples={})",
            c.x,
            c.y,
            c.w,
            c.h,
            self.inner.first(),
            self.inner.samples()
        )
    }
}

/// Renders `scene` into `film` (continuing it: each pixel goes on with its own sample
/// sequence) or, when `film` is `None`, into a new film for the options (their `cell` and
/// `sample_range`), and returns the film. Options as `render`.
#[pyfunction]
#[pyo3(signature = (scene, film = None, **kw))]
fn render_film(
    py: Python<'_>,
    scene: &Scene,
    film: Option<Py<Film>>,
    kw: Option<&Bound<'_, PyDict>>,
) -> PyResult<Py<Film>> {
    let film = match film {
        Some(f) => f,
        None => {
            let opts = options(kw)?;
            Py::new(
                py,
                Film {
                    inner: render::new_film(&opts).map_err(err)?,
                },
            )?
        }
    };
    let placeholder = RsFilm::new(1, 1, None, 0).map_err(err)?;
    let mut inner = std::mem::replace(&mut film.borrow_mut(py).inner, placeholder);
    let result = render_film_into(py, scene, &mut inner, kw);
    film.borrow_mut(py).inner = inner;
    result.map(|_| film)
}

/// Auxiliary images for denoisers and analysis, over the same camera samples as `render`
/// with the same options: a dict of float32 arrays (height, width, 3), `albedo` (the first
/// hit's material colour), `normal` (its world-space shading normal, facing the camera) and
/// `depth` (distance along the camera ray, scene units, in all three channels; 0 where the
/// ray escapes).
#[pyfunction]
#[pyo3(signature = (scene, **kw))]
fn aux<'py>(
    py: Python<'py>,
    scene: &Scene,
    kw: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let (loaded, cam, opts) = prepared(scene, kw)?;
    let a = interruptible(py, |_| render::aux_images(&scene_with(&loaded, cam), &opts))?
        .map_err(err)?;
    let d = PyDict::new(py);
    d.set_item("albedo", array(py, &a.albedo))?;
    d.set_item("normal", array(py, &a.normal))?;
    d.set_item("depth", array(py, &a.depth))?;
    Ok(d)
}

/// Writes a float32 array (height, width, 3) of linear RGB to `path`: `.exr` as linear float,
/// `.png` as 8-bit sRGB; atomically (a temporary file renamed). Non-finite values are refused.
#[pyfunction]
fn write_image(py: Python<'_>, path: PathBuf, image: PyReadonlyArray3<'_, f32>) -> PyResult<()> {
    let a = image.as_array();
    let (h, w, c) = a.dim();
    if c != 3 || w == 0 || h == 0 {
        return Err(PyValueError::new_err(format!(
            "an image is an array of shape (height, width, 3), not {:?}",
            a.shape()
        )));
    }
    let mut pixels = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let p = glam::Vec3::new(a[(y, x, 0)], a[(y, x, 1)], a[(y, x, 2)]);
            if !p.is_finite() {
                return Err(PyValueError::new_err(format!(
                    "pixel ({x}, {y}) is not finite: {p}"
                )));
            }
            pixels.push(p);
        }
    }
    let img = Image {
        width: w,
        height: h,
        pixels,
    };
    py.detach(|| img.save(&path)).map_err(err)
}

/// Reads a `.exr` or `.png` image as a float32 array (height, width, 3) of linear RGB.
#[pyfunction]
fn read_image<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let img = py.detach(|| Image::load(&path)).map_err(err)?;
    Ok(array(py, &img))
}

/// The pathtracer library's Python module.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    if let Some(why) = pathtracer::unsupported_cpu() {
        return Err(pyo3::exceptions::PyImportError::new_err(why));
    }
    m.add("Error", m.py().get_type::<Error>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<Camera>()?;
    m.add_class::<Scene>()?;
    m.add_class::<Film>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(render_image, m)?)?;
    m.add_function(wrap_pyfunction!(render_film, m)?)?;
    m.add_function(wrap_pyfunction!(aux, m)?)?;
    m.add_function(wrap_pyfunction!(write_image, m)?)?;
    m.add_function(wrap_pyfunction!(read_image, m)?)?;
    Ok(())
}
