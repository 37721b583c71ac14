//! From files and flags to a scene ready to render: the scene file (or the built-in scene), an
//! environment map, a camera file, and the view choices of the command line (`--lookat`,
//! `--fov`, `-b`, `-d`). The CLI, the viewer and the Python module all set scenes up here, so
//! the same choices give the same camera, bit for bit.

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::io::desc::{FovAxis, SceneDesc};
use crate::light::env::EnvSampling;
use crate::math::Aabb;
use crate::options::{check, Choices, Value};
use crate::render::RenderOptions;
use crate::scene::Scene;
use crate::{builtin, io, scene};
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// A built scene and what its file said about the camera.
#[derive(Clone, Debug)]
pub struct Loaded {
    /// The scene, with its file's camera (or CS184's placement) and any environment light.
    pub scene: Scene,
    /// What the file's camera, or its lack, makes of the render's size, applied by
    /// [`View::camera`]; `None` for CS184's 800×600-window convention, or once a camera file
    /// replaced the camera.
    pub file_view: Option<FileView>,
    /// Non-fatal problems of the scene and the environment map, each naming its file.
    pub warnings: Vec<String>,
    /// What the loader chose for the user and says on stderr (the studio light), each naming
    /// the file.
    pub notes: Vec<String>,
    /// The files read: the scene's ([`crate::io::desc::SceneDesc::sources`]), then the
    /// environment map and the camera file, if any. Empty for the built-in scene.
    pub files: Vec<PathBuf>,
    /// The scene file (`None`: the built-in scene).
    pub scene_file: Option<PathBuf>,
    /// The environment map, if any.
    pub env_file: Option<PathBuf>,
    /// How the environment map is sampled.
    pub env_sampling: EnvSampling,
    /// Whether the built-in studio light was added ([`LoadOptions::default_light`]).
    pub studio_light: bool,
    /// The CS184 camera file that replaced the scene's camera, if any.
    pub camera_file: Option<PathBuf>,
    /// Render options the scene file gives (resolution, samples, …), `(name, value)`; they
    /// override the built-in defaults and yield to the user's ([`Choices::resolve`]).
    pub file_options: Vec<(String, Value)>,
    /// The identity lines of the files read ([`Loaded::file_identity`]), hashed once.
    file_identity: OnceLock<Vec<(String, String)>>,
}

/// How a scene is loaded: the files given beside it and the load-time options
/// ([`crate::options::Place::Load`]).
#[derive(Clone, Copy, Debug)]
pub struct LoadOptions<'a> {
    /// An environment map to add as a light (`-e`).
    pub env: Option<&'a Path>,
    /// How the environment map is sampled (`env_sampling`).
    pub env_sampling: EnvSampling,
    /// A Mitsuba scene's parameters (`-D name=value`).
    pub defines: &'a [(String, String)],
    /// Whether a model file (OBJ, PLY, glTF) without lights gets the built-in studio light
    /// (not `no_default_light`).
    pub default_light: bool,
}

impl std::default::Default for LoadOptions<'_> {
    /// No files, and the option table's defaults.
    fn default() -> Self {
        let table = Choices::default();
        LoadOptions {
            env: None,
            env_sampling: table.env_sampling(),
            defines: &[],
            default_light: table.default_light(),
        }
    }
}

/// Loads `scene` (the built-in Cornell box when `None`), builds it and adds the environment
/// map `env`, if any, sampled as `sampling`.
pub fn load(scene: Option<&Path>, env: Option<&Path>, sampling: EnvSampling) -> Result<Loaded> {
    load_with(
        scene,
        &LoadOptions {
            env,
            env_sampling: sampling,
            ..LoadOptions::default()
        },
    )
}

/// Loads `scene` (the built-in Cornell box when `None`) as `opts` say: builds it, adds the
/// environment map, if any, and lights a model file that has no lights with the studio light.
pub fn load_with(scene: Option<&Path>, opts: &LoadOptions) -> Result<Loaded> {
    let scene_path = scene;
    let desc = match scene {
        Some(p) => io::load_scene_with(p, opts.defines)?,
        None => builtin::cornell_box(),
    };
    let mut scene = scene::build::build(&desc);
    let mut warnings = scene.warnings.clone();
    let env = opts.env;
    if let Some(map) = env {
        warnings.extend(scene.add_environment(map, opts.env_sampling)?);
    }
    let notes: Vec<String> = add_studio_light(&mut scene, &desc, opts)
        .into_iter()
        .collect();
    let studio_light = !notes.is_empty();
    if scene.lights.is_empty() && !scene.media.iter().any(|m| m.emits()) {
        warnings.push(format!(
            "{}: the scene has no lights, no emissive materials or media (and no environment map: \
             `-e MAP`, or `env=` in Python); the image will be black",
            desc.file
        ));
    }
    let file_view = file_view(&desc, &scene.bounds);
    let file_options = desc.options;
    let mut files = desc.sources;
    files.extend(env.map(Path::to_path_buf));
    Ok(Loaded {
        scene,
        file_view,
        warnings,
        notes,
        files,
        scene_file: scene_path.map(Path::to_path_buf),
        env_file: env.map(Path::to_path_buf),
        env_sampling: opts.env_sampling,
        studio_light,
        camera_file: None,
        file_options,
        file_identity: OnceLock::new(),
    })
}

/// Lights `scene`, a model file's (OBJ, PLY, glTF) without lights, with the built-in studio
/// light unless `opts` say not to; the note saying so, if it did.
fn add_studio_light(scene: &mut Scene, desc: &SceneDesc, opts: &LoadOptions) -> Option<String> {
    if !(scene.lights.is_empty() && desc.format.is_model() && opts.default_light) {
        return None;
    }
    scene.add_light(crate::light::Light::Environment(
        crate::light::studio::light(opts.env_sampling),
    ));
    Some(format!(
        "{}: the model has no lights; it is lit by the built-in studio light \
         (--no-default-light, or no_default_light=True in Python, leaves it unlit; \
         -e MAP lights it with an environment map)",
        desc.file
    ))
}

/// What the file's camera, or its lack, says of the view: its exact field of view, a framing
/// of the scene's `bounds`, or nothing (CS184's convention).
fn file_view(desc: &SceneDesc, bounds: &Aabb) -> Option<FileView> {
    match &desc.camera {
        Some(c) if c.exact => c.yfov_deg.map(|deg| {
            FileView::Fov(FileFov {
                deg: deg as f64,
                axis: c.fov_axis,
            })
        }),
        None if desc.format.frames_camera_less() => Some(FileView::Fit(*bounds)),
        _ => None,
    }
}

impl Loaded {
    /// Replaces the scene's camera by the CS184 camera file at `path` (`-c`).
    pub fn use_camera_file(&mut self, path: &Path) -> Result<()> {
        self.scene.camera = Camera::load_cs184(path)?;
        self.file_view = None;
        self.files.push(path.to_path_buf());
        self.camera_file = Some(path.to_path_buf());
        self.file_identity = OnceLock::new();
        Ok(())
    }

    /// What the files read contribute to a render's identity: the scene, environment map and
    /// camera file (each its name and SHA-256 prefix), the environment sampling and the
    /// studio light where it was added. Hashed on the first call and kept, so that renders
    /// after the first (Python, the farm's chunks) do not read and hash every file again.
    pub fn file_identity(&self) -> Result<&[(String, String)]> {
        if let Some(lines) = self.file_identity.get() {
            return Ok(lines);
        }
        let file_or = |p: Option<&PathBuf>, none: &str| -> Result<String> {
            p.map_or(Ok(none.to_string()), |p| hash_file(p))
        };
        let mut lines = vec![
            (
                "scene".into(),
                file_or(self.scene_file.as_ref(), "built-in")?,
            ),
            (
                "environment".into(),
                file_or(self.env_file.as_ref(), "none")?,
            ),
            ("env-sampling".into(), format!("{:?}", self.env_sampling)),
            (
                "camera-file".into(),
                file_or(self.camera_file.as_ref(), "none")?,
            ),
        ];
        // Only where it lights the scene, so that other films' identities stay as they were.
        if self.studio_light {
            lines.push(("default-light".into(), "studio".into()));
        }
        Ok(self.file_identity.get_or_init(|| lines))
    }

    /// The render choices for this scene: built-in defaults, then the scene file's values,
    /// then the user's `given` ones.
    pub fn choices(&self, given: &[(String, Value)]) -> Result<Choices> {
        Choices::resolve(&self.file_options, given)
    }
}

/// Warnings about render options `opts` that `scene` does not use: the volumetric path tracer
/// ([`crate::volpath`]) takes one light sample per vertex, chosen by power, and sums every
/// bounce.
pub fn unused_options(scene: &Scene, opts: &RenderOptions) -> Vec<String> {
    let it = &opts.integrator;
    let mut unused = Vec::new();
    if scene.volumetric {
        use crate::integrator::{Direct, LightSelection};
        for (used, what) in [
            (it.light_samples != 1, "-l (light samples per vertex)"),
            (it.selection == LightSelection::All, "--light-selection all"),
            (it.direct == Direct::Hemisphere, "-H (hemisphere sampling)"),
            (!it.accumulate, "-o 0 (only the last bounce)"),
        ] {
            if used {
                unused.push(format!(
                    "{what} is not used in scenes with media: their path tracer takes one light \
                     sample per vertex, chosen by power, and sums every bounce"
                ));
            }
        }
    }
    unused
}

/// What a film rendered from `loaded` through `camera` with `opts` belongs to: the program's
/// version, hashes of the scene, environment map and camera files, the environment sampling,
/// the camera, and [`RenderOptions::identity`]. A checkpoint resumed, or a film merged, under
/// another identity is refused, naming each difference ([`crate::film::Film::identity_mismatch`]).
pub fn identity(
    loaded: &Loaded,
    camera: &Camera,
    opts: &RenderOptions,
) -> Result<Vec<(String, String)>> {
    let c = camera;
    let mut id = vec![("version".to_string(), env!("CARGO_PKG_VERSION").to_string())];
    id.extend_from_slice(loaded.file_identity()?);
    let projection = if c.orthographic { " orthographic" } else { "" };
    id.push((
        "camera".into(),
        format!(
            "{:?} {:?} {:?} {} {} {}{projection}",
            c.pos, c.target, c.up, c.hfov_deg, c.lens_radius, c.focal_distance
        ),
    ));
    id.extend(opts.identity());
    for (_, v) in &mut id {
        *v = v.replace(['\n', '\r'], " ");
    }
    Ok(id)
}

/// A file's name and the first 8 bytes of its SHA-256, as identity lines show it.
fn hash_file(p: &Path) -> Result<String> {
    use sha2::{Digest, Sha256};
    let bytes = std::fs::read(p).map_err(|source| Error::Io {
        path: p.display().to_string(),
        what: "cannot read",
        source,
    })?;
    let name = p.file_name().map(|n| n.to_string_lossy().into_owned());
    let hex: String = Sha256::digest(&bytes)[..8]
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    Ok(format!("{} (sha256 {hex}…)", name.unwrap_or_default()))
}

/// What a scene file says of the view for the image requested.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FileView {
    /// Its camera's exact field of view (glTF, pbrt-v4, Mitsuba).
    Fov(FileFov),
    /// No camera in a file of a format that frames it ([`io::desc::Format::frames_camera_less`]):
    /// the scene's front (looking down −Z, +Y up), its bounds framed whole for the image
    /// ([`FIT_VFOV_DEG`], [`FIT_FILL`]).
    Fit(Aabb),
}

/// The vertical field of view of a framed model, degrees.
pub const FIT_VFOV_DEG: f64 = 40.0;
/// The share of each image axis that a framed model's bounding box may span.
pub const FIT_FILL: f32 = 0.9;

/// A scene file's exact field of view: degrees over one axis of the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FileFov {
    /// The angle in degrees.
    pub deg: f64,
    /// The axis it spans.
    pub axis: FovAxis,
}

impl FileFov {
    /// The vertical field of view in degrees of a `width × height` image.
    pub fn vertical(&self, width: u32, height: u32) -> f64 {
        let (w, h) = (width.max(1) as f64, height.max(1) as f64);
        let spanned = match self.axis {
            FovAxis::Height => h,
            FovAxis::Shorter => w.min(h),
            FovAxis::Longer => w.max(h),
            FovAxis::Width => w,
            FovAxis::Diagonal => w.hypot(h),
        };
        if spanned == h {
            return self.deg;
        }
        2.0 * ((self.deg.to_radians() / 2.0).tan() * h / spanned)
            .atan()
            .to_degrees()
    }
}

/// The view choices applied on top of a scene's camera, as the command line's flags.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct View {
    /// Eye, target and up vector (`--lookat`); the field of view stays the scene's unless
    /// `fov` is given.
    pub lookat: Option<[Vec3; 3]>,
    /// Vertical field of view in degrees over the image's height (`--fov`), in (0, 180).
    pub fov: Option<f64>,
    /// Thin-lens radius in scene units (`-b`), ≥ 0.
    pub lens_radius: Option<f32>,
    /// Focal distance in scene units along the viewing direction (`-d`), > 0.
    pub focal_distance: Option<f32>,
}

impl View {
    /// The camera for a `width × height` image: `base` (the scene's camera) with what the
    /// file says of the view (`file_view`), then these choices.
    pub fn camera(
        &self,
        base: &Camera,
        file_view: Option<FileView>,
        width: u32,
        height: u32,
    ) -> Result<Camera> {
        let mut cam = base.clone();
        match file_view {
            Some(FileView::Fov(fov)) => cam.set_vfov(fov.vertical(width, height), height),
            Some(FileView::Fit(bounds)) => {
                cam = Camera::framing(&bounds, Vec3::NEG_Z, FIT_VFOV_DEG, width, height, FIT_FILL);
            }
            None => {}
        }
        if let Some([eye, target, up]) = self.lookat {
            let mut c = Camera::look_at_up(eye, target, up, 40.0, height).ok_or_else(|| {
                Error::Usage(
                    "lookat: the eye, target and up vector leave no view (eye at the target, \
                     or up along the view)"
                        .into(),
                )
            })?;
            // The scene's field of view, unless `fov` says otherwise.
            c.focal_px = cam.focal_px;
            c.hfov_deg = cam.hfov_deg;
            c.vfov_deg = cam.vfov_deg;
            cam = c;
        }
        if let Some(fov) = self.fov {
            check("fov", &Value::Real(fov))?;
            cam.set_vfov(fov, height);
        }
        if let Some(r) = self.lens_radius {
            check("lens_radius", &Value::Real(r as f64))?;
            cam.lens_radius = r;
        }
        if let Some(d) = self.focal_distance {
            check("focal_distance", &Value::Real(d as f64))?;
            cam.focal_distance = d;
        }
        Ok(cam)
    }
}

impl Choices {
    /// The camera choices (`lookat`, `fov`, `lens_radius`, `focal_distance`).
    pub fn view(&self) -> View {
        View {
            lookat: self.list("lookat").map(|l| {
                let x = |i: usize| l[i].as_real().unwrap_or(0.0) as f32;
                let v = |i: usize| glam::Vec3::new(x(i), x(i + 1), x(i + 2));
                [v(0), v(3), v(6)]
            }),
            fov: self.real("fov"),
            lens_radius: self.real("lens_radius").map(|r| r as f32),
            focal_distance: self.real("focal_distance").map(|d| d as f32),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn view_choices_apply_in_the_command_lines_order() {
        let l = load(None, None, EnvSampling::Importance).unwrap();
        let base = l.scene.camera.clone();
        // No choices: the scene's camera.
        let c = View::default().camera(&base, None, 480, 360).unwrap();
        assert_eq!(
            (c.pos, c.forward, c.focal_px),
            (base.pos, base.forward, base.focal_px)
        );
        // --lookat keeps the field of view; --fov sets it over the image height.
        let v = View {
            lookat: Some([Vec3::new(0.0, 1.0, 3.5), Vec3::new(0.0, 1.0, 0.0), Vec3::Y]),
            ..View::default()
        };
        let c = v.camera(&base, None, 480, 360).unwrap();
        assert_eq!(c.pos, Vec3::new(0.0, 1.0, 3.5));
        assert_eq!(c.focal_px, base.focal_px);
        let c = View {
            fov: Some(40.0),
            ..v
        }
        .camera(&base, None, 480, 360)
        .unwrap();
        let f = 180.0 / (20f64.to_radians().tan());
        assert!((c.focal_px as f64 - f).abs() < 1e-3, "{}", c.focal_px);
        // A file's exact field of view is over the render's height.
        let c = View::default()
            .camera(
                &base,
                Some(FileView::Fov(FileFov {
                    deg: 40.0,
                    axis: FovAxis::Height,
                })),
                960,
                720,
            )
            .unwrap();
        assert!((c.focal_px as f64 - 2.0 * f).abs() < 1e-3);
        // Bad choices are errors, not cameras.
        for bad in [
            View {
                lookat: Some([Vec3::ZERO, Vec3::ZERO, Vec3::Y]),
                ..View::default()
            },
            View {
                fov: Some(180.0),
                ..View::default()
            },
            View {
                lens_radius: Some(-1.0),
                ..View::default()
            },
            View {
                focal_distance: Some(f32::NAN),
                ..View::default()
            },
        ] {
            assert!(bad.camera(&base, None, 480, 360).is_err(), "{bad:?}");
        }
    }
}
