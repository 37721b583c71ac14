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
use pathtracer::io::image::Image;
use pathtracer::options::{self, Choices, Value};
use pathtracer::render::{self, Cell, Control, RenderOptions};
use pathtracer::setup::{self, FileView, Loaded, View};
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

/// The choices of `load`'s option keywords (`(name, value)`; `None`: the table's default),
/// checked as the command line checks them.
fn load_choices(py: Python<'_>, given: &[(&str, &Bound<'_, PyAny>)]) -> PyResult<Choices> {
    let mut c = Choices::default();
    for (name, v) in given {
        if let Some(value) = value_of(v)? {
            c.set(name, &value).map_err(|e| option_err(py, e))?;
        }
    }
    Ok(c)
}

/// A camera: where the scene's camera is moved to (`--lookat`), its vertical field of view
/// (`--fov`), lens radius (`-b`) and focal distance (`-d`). Read from `Scene.camera`, change,
/// and assign back; or make one with `Camera(position, target, up, fov=...)`.
#[pyclass(module = "pathtracer")]
#[derive(Clone)]
struct Camera {
    /// The scene's camera the choices apply to (`None` for a camera made from scratch).
    base: Option<RsCamera>,
    /// The file camera's view for the image (glTF, pbrt-v4 fields of view, framed models), as in `setup::Loaded`.
    file_view: Option<FileView>,
    view: View,
}

impl Camera {
    /// The camera these choices give for a `width × height` image.
    fn resolve(&self, width: u32, height: u32) -> PyResult<RsCamera> {
        let base = match &self.base {
            Some(b) => b.clone(),
            None => RsCamera::look_at(glam::Vec3::Z, glam::Vec3::ZERO, 50.0, 40.0),
        };
        self.view
            .camera(&base, self.file_view, width, height)
            .map_err(|e| PyValueError::new_err(e.to_string()))
    }

    fn lookat(&self) -> PyResult<[glam::Vec3; 3]> {
        if let Some(l) = self.view.lookat {
            return Ok(l);
        }
        let c = self.resolve(480, 360)?;
        Ok([c.pos, c.target, c.up])
    }

    /// Applies `change` to the view choices when the camera they then give is valid, and
    /// leaves them as they were otherwise.
    fn update(&mut self, change: impl FnOnce(&mut View)) -> PyResult<()> {
        let old = self.view;
        change(&mut self.view);
        if let Err(e) = self.resolve(480, 360) {
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
            file_view: None,
            view: View {
                lookat: Some([vec3(position), vec3(target), vec3(up)]),
                fov,
                lens_radius,
                focal_distance,
            },
        };
        c.resolve(480, 360)?;
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
        Ok(self.resolve(480, 360)?.lens_radius)
    }
    #[setter]
    fn set_lens_radius(&mut self, v: f32) -> PyResult<()> {
        self.update(|view| view.lens_radius = Some(v))
    }
    /// Distance to the plane of focus along the view, scene units.
    #[getter]
    fn focal_distance(&self) -> PyResult<f32> {
        Ok(self.resolve(480, 360)?.focal_distance)
    }
    #[setter]
    fn set_focal_distance(&mut self, v: f32) -> PyResult<()> {
        self.update(|view| view.focal_distance = Some(v))
    }
    /// The vertical field of view in degrees over an image `height` pixels high.
    #[pyo3(signature = (height = 360))]
    fn field_of_view(&self, height: u32) -> PyResult<f64> {
        let c = self.resolve(height, height)?;
        Ok(2.0
            * (height as f64 / (2.0 * c.focal_px as f64))
                .atan()
                .to_degrees())
    }
    fn __repr__(&self) -> PyResult<String> {
        let c = self.resolve(480, 360)?;
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
    /// What the loader chose for the user (the studio light for a model without lights),
    /// each naming its file.
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.loaded.notes.clone()
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
            file_view: self.loaded.file_view,
            view: self.view(),
        }
    }
    #[setter]
    fn set_camera(&self, cam: PyRef<'_, Camera>) -> PyResult<()> {
        // A camera made from scratch without `fov` keeps the scene's, as --lookat does.
        let v = cam.view;
        let c = Camera {
            base: Some(self.loaded.scene.camera.clone()),
            file_view: self.loaded.file_view,
            view: v,
        };
        c.resolve(480, 360)?;
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
/// `.glb`, `.pbrt`, Mitsuba `.xml`; `None`: the built-in Cornell box), with an optional
/// environment map (`-e`), its sampling (`--env-sampling`), a CS184 camera file (`-c`), a
/// Mitsuba scene's parameters (`defines`, a dict: `-D name=value`) and `no_default_light`
/// (`--no-default-light`: a model file without lights stays unlit). What the loader chose
/// (the studio light) is printed on stderr and kept in `Scene.notes`.
#[pyfunction]
#[pyo3(signature = (path = None, env = None, env_sampling = None, camera_file = None, defines = None, no_default_light = None))]
fn load(
    py: Python<'_>,
    path: Option<PathBuf>,
    env: Option<PathBuf>,
    env_sampling: Option<Bound<'_, PyAny>>,
    camera_file: Option<PathBuf>,
    defines: Option<std::collections::BTreeMap<String, String>>,
    no_default_light: Option<Bound<'_, PyAny>>,
) -> PyResult<Scene> {
    let none = py.None().into_bound(py);
    let choices = load_choices(
        py,
        &[
            ("env_sampling", env_sampling.as_ref().unwrap_or(&none)),
            (
                "no_default_light",
                no_default_light.as_ref().unwrap_or(&none),
            ),
        ],
    )?;
    let defines: Vec<(String, String)> = defines.unwrap_or_default().into_iter().collect();
    let loaded = py
        .detach(|| -> pathtracer::Result<Loaded> {
            let opts = setup::LoadOptions {
                env: env.as_deref(),
                env_sampling: choices.env_sampling(),
                defines: &defines,
                default_light: choices.default_light(),
            };
            let mut l = setup::load_with(path.as_deref(), &opts)?;
            if let Some(c) = &camera_file {
                l.use_camera_file(c)?;
            }
            Ok(l)
        })
        .map_err(err)?;
    for note in &loaded.notes {
        eprintln!("note: {note}");
    }
    Ok(Scene {
        loaded: Arc::new(loaded),
        view: std::sync::Mutex::new(View::default()),
    })
}

/// `pathtracer.OptionError`: a render option out of its range or of the wrong type; both a
/// `pathtracer.Error` and a `ValueError`. Made at import (see [`option_error_type`]).
static OPTION_ERROR: pyo3::sync::PyOnceLock<Py<pyo3::types::PyType>> =
    pyo3::sync::PyOnceLock::new();

/// Makes `OptionError(Error, ValueError)` (a class of two bases, which `create_exception!`
/// cannot declare).
fn option_error_type(py: Python<'_>) -> PyResult<Py<pyo3::types::PyType>> {
    let ns = PyDict::new(py);
    ns.set_item("Error", py.get_type::<Error>())?;
    py.run(
        c"class OptionError(Error, ValueError):\n    \"\"\"A render option out of its range or of the wrong type; the message names the option and its allowed values.\"\"\"\n",
        Some(&ns),
        None,
    )?;
    let t = ns
        .get_item("OptionError")?
        .ok_or_else(|| PyRuntimeError::new_err("OptionError was not made"))?;
    Ok(t.cast_into::<pyo3::types::PyType>()?.unbind())
}

/// The library's error about an option as `OptionError`.
fn option_err(py: Python<'_>, e: pathtracer::Error) -> PyErr {
    match OPTION_ERROR.get(py) {
        Some(t) => PyErr::from_type(t.bind(py).clone(), e.to_string()),
        None => Error::new_err(e.to_string()),
    }
}

/// A Python value as a value of the option vocabulary (`None` for `None`: the option unset).
/// Nested sequences are flattened (`lookat=(eye, target, up)`).
fn value_of(v: &Bound<'_, PyAny>) -> PyResult<Option<Value>> {
    use pyo3::types::{PyBool, PyFloat, PyInt, PyString};
    if v.is_none() {
        return Ok(None);
    }
    let value = if v.is_instance_of::<PyBool>() {
        Value::Bool(v.extract()?)
    } else if v.is_instance_of::<PyInt>() {
        // Larger than any option allows: out of range, reported by the check (beyond 128
        // bits, as the largest 128-bit integer).
        Value::Int(v.extract::<i128>().unwrap_or(i128::MAX))
    } else if v.is_instance_of::<PyFloat>() {
        Value::Real(v.extract()?)
    } else if v.is_instance_of::<PyString>() {
        Value::Text(v.extract()?)
    } else if let Ok(items) = v.try_iter() {
        let mut list = Vec::new();
        for item in items {
            match value_of(&item?)? {
                Some(Value::List(inner)) => list.extend(inner),
                Some(x) => list.push(x),
                None => list.push(Value::Text("None".into())),
            }
        }
        Value::List(list)
    } else {
        Value::Text(v.repr()?.to_string())
    };
    Ok(Some(value))
}

/// Whether `render` takes option `s` as a keyword (render and camera options; not `load`'s).
fn render_keyword(s: &options::Spec) -> bool {
    matches!(
        s.python,
        Some(options::Place::Render | options::Place::Camera)
    )
}

/// Options given by name, with their values.
type Given = Vec<(String, Value)>;

/// The options given as keywords: `(name, value)` of every keyword with a value, and the
/// names of those given as `None` (unset). Unknown keywords and keywords of `load` are a
/// `TypeError`, as Python's own unknown keywords are.
fn given_of(kw: Option<&Bound<'_, PyDict>>) -> PyResult<(Given, Vec<String>)> {
    let (mut given, mut unset) = (Vec::new(), Vec::new());
    let Some(kw) = kw else {
        return Ok((given, unset));
    };
    for (k, v) in kw.iter() {
        let key: String = k.extract()?;
        if !options::spec(&key).is_some_and(render_keyword) {
            let names: Vec<&str> = options::OPTIONS
                .iter()
                .filter(|s| render_keyword(s))
                .map(|s| s.name)
                .collect();
            return Err(PyTypeError::new_err(format!(
                "unknown render option '{key}' ({})",
                names.join(", ")
            )));
        }
        match value_of(&v)? {
            Some(value) => given.push((key, value)),
            None => unset.push(key),
        }
    }
    Ok((given, unset))
}

/// The choices of keyword arguments over the scene's (file values, then the Camera set on the
/// Scene, then the keywords), checked.
fn choices_of(
    py: Python<'_>,
    loaded: Option<&Loaded>,
    view: View,
    kw: Option<&Bound<'_, PyDict>>,
) -> PyResult<Choices> {
    let (given, unset) = given_of(kw)?;
    let file = loaded.map_or(&[][..], |l| &l.file_options[..]);
    let mut c = Choices::resolve(file, &[]).map_err(|e| option_err(py, e))?;
    for (name, v) in view_values(&view) {
        c.set(name, &v).map_err(|e| option_err(py, e))?;
    }
    for (name, v) in &given {
        c.set(name, v).map_err(|e| option_err(py, e))?;
    }
    for name in &unset {
        c.unset(name).map_err(|e| option_err(py, e))?;
    }
    c.render_options()
        .validate()
        .map_err(|e| option_err(py, e))?;
    Ok(c)
}

/// The camera choices of a `View` as option values.
fn view_values(v: &View) -> Vec<(&'static str, Value)> {
    let mut out = Vec::new();
    if let Some(l) = v.lookat {
        let nums = l
            .iter()
            .flat_map(|p| p.to_array())
            .map(|x| Value::Real(x as f64));
        out.push(("lookat", Value::List(nums.collect())));
    }
    if let Some(f) = v.fov {
        out.push(("fov", Value::Real(f)));
    }
    if let Some(r) = v.lens_radius {
        out.push(("lens_radius", Value::Real(r as f64)));
    }
    if let Some(d) = v.focal_distance {
        out.push(("focal_distance", Value::Real(d as f64)));
    }
    out
}

/// The scene with its camera for the options, and the options.
fn prepared(py: Python<'_>, scene: &Scene, kw: Option<&Bound<'_, PyDict>>) -> PyResult<Prepared> {
    let choices = choices_of(py, Some(&scene.loaded), scene.view(), kw)?;
    let opts = choices.render_options();
    let cam = choices
        .view()
        .camera(
            &scene.loaded.scene.camera,
            scene.loaded.file_view,
            opts.width,
            opts.height,
        )
        .map_err(|e| option_err(py, e))?;
    Ok((scene.loaded.clone(), cam, opts))
}

/// A scene, the camera and the options of a render.
type Prepared = (Arc<Loaded>, RsCamera, RenderOptions);

/// Renders into `film` (taken out of its Python object for the render and put back after),
/// which carries the render's identity: a film of another render is refused.
fn render_film_into(
    py: Python<'_>,
    (loaded, cam, opts): Prepared,
    film: &mut RsFilm,
) -> PyResult<()> {
    let identity = setup::identity(&loaded, &cam, &opts).map_err(err)?;
    if film.identity().is_empty() && film.samples() == 0 {
        film.set_identity(identity);
    } else if let Some(d) = film.identity_differences(&identity, ("in the film", "here")) {
        return Err(Error::new_err(format!(
            "the film belongs to another render: {d}"
        )));
    }
    let result = interruptible(py, |stop| -> pathtracer::Result<()> {
        let quiet = |_: usize, _: usize| {};
        let ctl = Control::new(stop, &quiet);
        render::render_camera_into(&loaded.scene, &cam, &opts, film, ctl)?;
        Ok(())
    })?;
    result.map_err(err)
}

/// Renders `scene` and returns the image as a float32 array (height, width, 3), linear RGB.
/// The keywords are the render options of `option_table()` (the command line's flags under
/// their option names: `spp`, `max_depth`, `width`, `lookat`, ...); `None` leaves one unset.
#[pyfunction]
#[pyo3(name = "render", signature = (scene, **kw))]
fn render_image<'py>(
    py: Python<'py>,
    scene: &Scene,
    kw: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let prep = prepared(py, scene, kw)?;
    // OIDN is found before rendering, as the command line does.
    let denoiser = if prep.2.denoise {
        Some(denoiser(py)?)
    } else {
        None
    };
    let mut film = render::new_film(&prep.2).map_err(err)?;
    render_film_into(py, prep, &mut film)?;
    let image = film.develop();
    let Some(d) = denoiser else {
        return Ok(array(py, &image));
    };
    let features = film.feature_images();
    let denoised = py
        .detach(|| {
            d.denoise_image(
                &image,
                features.as_ref(),
                pathtracer::denoise::Quality::Final,
            )
        })
        .map_err(Error::new_err)?;
    Ok(array(py, &denoised))
}

/// The process's denoiser (Open Image Denoise, loaded once): where `PATHTRACER_OIDN` is not
/// set, the `pyoidn` package this interpreter imports is tried first. `Error` (with how to
/// get OIDN) where none loads.
fn denoiser(py: Python<'_>) -> PyResult<&'static pathtracer::denoise::Denoiser> {
    static DENOISER: std::sync::OnceLock<pathtracer::denoise::Denoiser> =
        std::sync::OnceLock::new();
    if let Some(d) = DENOISER.get() {
        return Ok(d);
    }
    let spec = py
        .import("importlib.util")?
        .call_method1("find_spec", ("pyoidn",))?;
    let pyoidn_lib = if spec.is_none() {
        None
    } else {
        let origin: PathBuf = spec.getattr("origin")?.extract()?;
        origin.parent().map(|p| p.join("oidn").join("lib"))
    };
    let d = pathtracer::denoise::Denoiser::load_with(pyoidn_lib.as_deref())
        .map_err(|e| Error::new_err(format!("denoise: {e}")))?;
    Ok(DENOISER.get_or_init(|| d))
}

/// The pixels of a float32 array (height, width, 3), row-major, and its size; `ValueError`
/// for another shape (or, with `size`, another size than `size`).
fn pixels_of(
    what: &str,
    image: &PyReadonlyArray3<'_, f32>,
    size: Option<(usize, usize)>,
) -> PyResult<(Vec<glam::Vec3>, (usize, usize))> {
    let a = image.as_array();
    let (h, w, c) = a.dim();
    if c != 3 || w == 0 || h == 0 || size.is_some_and(|s| s != (w, h)) {
        return Err(PyValueError::new_err(format!(
            "{what} must be an array of shape (height, width, 3) matching the image, not {:?}",
            a.shape()
        )));
    }
    let pixels = a
        .rows()
        .into_iter()
        .map(|p| glam::Vec3::new(p[0], p[1], p[2]))
        .collect();
    Ok((pixels, (w, h)))
}

/// Denoises `image` (float32 (height, width, 3), linear HDR radiance) with Open Image
/// Denoise's `RT` filter, on its `albedo` and `normal` features where given (as
/// `Film.features()` returns them; `normal` only with `albedo`), features denoised first.
/// Non-finite inputs count as 0; the result is finite. Raises `Error` where OIDN cannot be
/// found (`pip install pyoidn`).
#[pyfunction]
#[pyo3(signature = (image, albedo = None, normal = None))]
fn denoise<'py>(
    py: Python<'py>,
    image: PyReadonlyArray3<'py, f32>,
    albedo: Option<PyReadonlyArray3<'py, f32>>,
    normal: Option<PyReadonlyArray3<'py, f32>>,
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let (color, (width, height)) = pixels_of("image", &image, None)?;
    let size = Some((width, height));
    let albedo = albedo.map(|a| pixels_of("albedo", &a, size)).transpose()?;
    let normal = normal.map(|a| pixels_of("normal", &a, size)).transpose()?;
    if normal.is_some() && albedo.is_none() {
        return Err(PyValueError::new_err("a normal needs an albedo too"));
    }
    let d = denoiser(py)?;
    let frame = pathtracer::denoise::Frame {
        width,
        height,
        color: &color,
        albedo: albedo.as_ref().map(|a| a.0.as_slice()),
        normal: normal.as_ref().map(|a| a.0.as_slice()),
    };
    let pixels = py.detach(|| d.denoise(&frame)).map_err(Error::new_err)?;
    Ok(array(
        py,
        &Image {
            width,
            height,
            pixels,
        },
    ))
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
    /// Its denoising features (rendered with `features=True` or `denoise=True`): a dict of
    /// float32 arrays (height, width, 3), `albedo` and `normal`, the means over its samples;
    /// `None` where it records none.
    fn features<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some((albedo, normal)) = self.inner.feature_images() else {
            return Ok(None);
        };
        let d = PyDict::new(py);
        d.set_item("albedo", array(py, &albedo))?;
        d.set_item("normal", array(py, &normal))?;
        Ok(Some(d))
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
    let prep = prepared(py, scene, kw)?;
    let film = match film {
        Some(f) => f,
        None => Py::new(
            py,
            Film {
                inner: render::new_film(&prep.2).map_err(err)?,
            },
        )?,
    };
    let placeholder = RsFilm::new(1, 1, None, 0).map_err(err)?;
    let mut inner = std::mem::replace(&mut film.borrow_mut(py).inner, placeholder);
    let result = render_film_into(py, prep, &mut inner);
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
    let (loaded, cam, opts) = prepared(py, scene, kw)?;
    let a = interruptible(py, |_| render::aux_images(&loaded.scene, &cam, &opts))?.map_err(err)?;
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

/// The render options a call with these keywords would use, each as the text
/// `pathtracer --dry-run` prints (`'none'` where unset), without rendering: built-in
/// defaults < the scene file's values and camera (with `scene`) < the keywords. Raises
/// `OptionError` as `render` does.
#[pyfunction]
#[pyo3(signature = (scene = None, **kw))]
fn resolve_options(
    py: Python<'_>,
    scene: Option<&Scene>,
    kw: Option<&Bound<'_, PyDict>>,
) -> PyResult<Vec<(String, String)>> {
    let c = match scene {
        Some(s) => choices_of(py, Some(&s.loaded), s.view(), kw)?,
        None => choices_of(py, None, View::default(), kw)?,
    };
    Ok(c.describe()
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect())
}

/// The option vocabulary: one dict per option with `name`, `flag` (the command line's, or
/// None), `values` (the flag's value names), `python` ('render', 'camera' or 'load': where
/// Python takes it, or None), `json` (the viewer's settings field, or None), `default` (as
/// `resolve_options` prints it; None where unset), `unset` (what happens then), `allowed`
/// (the allowed values in words) and `help`.
#[pyfunction]
fn option_table(py: Python<'_>) -> PyResult<Vec<Bound<'_, PyDict>>> {
    options::OPTIONS
        .iter()
        .map(|s| {
            let d = PyDict::new(py);
            d.set_item("name", s.name)?;
            d.set_item("flag", s.flag)?;
            d.set_item("values", s.values.to_vec())?;
            let place = s.python.map(|p| match p {
                options::Place::Render => "render",
                options::Place::Camera => "camera",
                options::Place::Load => "load",
            });
            d.set_item("python", place)?;
            d.set_item("json", s.json)?;
            let (default, unset) = match s.default {
                options::Default::Is(c) => (Some(Value::from(c).to_string()), None),
                options::Default::Unset(what) => (None, Some(what)),
            };
            d.set_item("default", default)?;
            d.set_item("unset", unset)?;
            d.set_item("allowed", s.kind.describe())?;
            d.set_item("kind", kind_dict(py, &s.kind)?)?;
            d.set_item("help", s.help)?;
            Ok(d)
        })
        .collect()
}

/// An option's kind as a dict: `type` ('int', 'real', 'switch', 'bit', 'choice', 'tuple'),
/// and `min`, `max` (None where unbounded), `closed` (whether `min` is allowed), `choices`,
/// `parts` (the kinds of a tuple's values).
fn kind_dict<'py>(py: Python<'py>, k: &options::Kind) -> PyResult<Bound<'py, PyDict>> {
    use options::Kind;
    let d = PyDict::new(py);
    let finite = |x: f64| x.is_finite().then_some(x);
    match k {
        Kind::Int { min, max } => {
            d.set_item("type", "int")?;
            d.set_item("min", *min)?;
            d.set_item("max", *max)?;
        }
        Kind::Real { min, closed, max } => {
            d.set_item("type", "real")?;
            d.set_item("min", finite(*min))?;
            d.set_item("closed", *closed)?;
            d.set_item("max", *max)?;
        }
        Kind::Switch => d.set_item("type", "switch")?,
        Kind::Bit => d.set_item("type", "bit")?,
        Kind::Choice(c) => {
            d.set_item("type", "choice")?;
            d.set_item("choices", c.to_vec())?;
        }
        Kind::Tuple(parts) => {
            d.set_item("type", "tuple")?;
            let kinds = parts
                .iter()
                .map(|(_, k)| kind_dict(py, k))
                .collect::<PyResult<Vec<_>>>()?;
            d.set_item("parts", kinds)?;
            d.set_item("names", parts.iter().map(|p| p.0).collect::<Vec<_>>())?;
        }
    }
    Ok(d)
}

/// Parses render arguments as the command line does (without the program name): a dict of
/// `scene`, `output` (`-f`), `env` (`-e`), `camera_file` (`-c`) (each a path or None),
/// `env_sampling`, `no_default_light`, `other_flags` (the command line's other file flags given, such as
/// `--checkpoint`), and `options`: a dict of the options given (as `render`'s keywords;
/// camera options included). Unknown flags and bad values raise `OptionError` with the
/// command line's message. The farm parses its render flags here.
#[pyfunction]
fn parse_args<'py>(py: Python<'py>, argv: Vec<String>) -> PyResult<Bound<'py, PyDict>> {
    let a = options::args::parse(&argv).map_err(|e| option_err(py, pathtracer::Error::Usage(e)))?;
    let d = PyDict::new(py);
    let f = &a.files;
    d.set_item("scene", f.scene.clone())?;
    d.set_item("output", f.output.clone())?;
    d.set_item("env", f.env.clone())?;
    d.set_item("camera_file", f.camera.clone())?;
    let mut others: Vec<&str> = Vec::new();
    let flags = [
        (f.env_pdf_image.is_some(), "--env-pdf-image"),
        (f.save_camera.is_some(), "--save-camera"),
        (f.info, "--info"),
        (f.dry_run, "--dry-run"),
        (f.checkpoint.is_some(), "--checkpoint"),
        (f.checkpoint_every.is_some(), "--checkpoint-every"),
        (f.resume.is_some(), "--resume"),
        (f.display_server.is_some(), "--display-server"),
    ];
    others.extend(
        flags
            .iter()
            .filter(|(given, _)| *given)
            .map(|(_, flag)| *flag),
    );
    d.set_item("other_flags", others)?;
    let choices = Choices::resolve(&[], &a.given).map_err(|e| option_err(py, e))?;
    d.set_item("env_sampling", choices.env_sampling().to_string())?;
    d.set_item("no_default_light", !choices.default_light())?;
    let opts = PyDict::new(py);
    for (name, v) in &a.given {
        if options::spec(name).is_some_and(|s| s.python == Some(options::Place::Load)) {
            continue;
        }
        opts.set_item(name, python_value(py, v)?)?;
    }
    d.set_item("options", opts)?;
    Ok(d)
}

/// An option value as a Python object (a tuple for several values).
fn python_value<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    use pyo3::IntoPyObjectExt;
    match v {
        Value::Bool(b) => b.into_bound_py_any(py),
        Value::Int(i) => i.into_bound_py_any(py),
        Value::Real(x) => x.into_bound_py_any(py),
        Value::Text(t) => t.into_bound_py_any(py),
        Value::List(l) => {
            let items = l
                .iter()
                .map(|x| python_value(py, x))
                .collect::<PyResult<Vec<_>>>()?;
            pyo3::types::PyTuple::new(py, items)?.into_bound_py_any(py)
        }
    }
}

/// The pathtracer library's Python module.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    if let Some(why) = pathtracer::unsupported_cpu() {
        return Err(pyo3::exceptions::PyImportError::new_err(why));
    }
    m.add("Error", m.py().get_type::<Error>())?;
    let option_error = OPTION_ERROR.get_or_try_init(m.py(), || option_error_type(m.py()))?;
    m.add("OptionError", option_error.bind(m.py()))?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<Camera>()?;
    m.add_class::<Scene>()?;
    m.add_class::<Film>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(render_image, m)?)?;
    m.add_function(wrap_pyfunction!(render_film, m)?)?;
    m.add_function(wrap_pyfunction!(aux, m)?)?;
    m.add_function(wrap_pyfunction!(denoise, m)?)?;
    m.add_function(wrap_pyfunction!(write_image, m)?)?;
    m.add_function(wrap_pyfunction!(read_image, m)?)?;
    m.add_function(wrap_pyfunction!(resolve_options, m)?)?;
    m.add_function(wrap_pyfunction!(option_table, m)?)?;
    m.add_function(wrap_pyfunction!(parse_args, m)?)?;
    Ok(())
}
