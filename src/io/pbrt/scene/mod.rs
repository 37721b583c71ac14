//! pbrt-v4's graphics state and directives, interpreted into a [`SceneDesc`].
//!
//! - Transforms: `Translate`, `Scale`, `Rotate`, `LookAt`, `Transform`, `ConcatTransform`,
//!   `Identity`, `CoordinateSystem`/`CoordSysTransform` post-multiply the current transform
//!   (CTM), as pbrt's do; `Transform`'s 16 numbers are the matrix column by column.
//! - `Camera` takes the CTM as camera-from-world. pbrt's camera space looks down +Z with +Y
//!   up and +X to the image's right (left-handed when the CTM is a proper rotation), so the
//!   description's camera is `inverse(CTM) · scale(1, 1, −1)` with its right along +X.
//!   `fov` spans the shorter image axis.
//! - `WorldBegin` resets the CTM; `AttributeBegin`/`AttributeEnd` save and restore the whole
//!   graphics state (CTM, material, area light, `ReverseOrientation`).
//! - A shape under an `AreaLightSource "diffuse"` emits `L · scale` (one-sided unless
//!   `twosided`) from the side its normal faces: a triangle's winding normal turned to agree
//!   with its `N` where given, flipped by `ReverseOrientation` and by transforms that swap
//!   handedness otherwise (the description's winding is arranged so).
//! - `Film`, `Sampler` and `Integrator` become render options (width, height, spp,
//!   max_depth) that the user's flags override.
//! - What is not rendered yet is one warning naming file, line and the stand-in.

mod materials;
mod media;
mod shapes;

use super::params::Params;
use super::{read_file, Arg, Directive};
use crate::error::{Error, Loc, Result};
use crate::filter::{FilterKind, GAUSSIAN_SIGMA};
use crate::io::desc::{
    CameraDesc, FovAxis, InstanceDesc, LightDesc, LightKind, MediumInterfaceDesc, ObjectDesc,
    SceneDesc, ShapeDesc,
};
use crate::light::infinite::InfiniteLight;
use crate::math::Rgb;
use crate::options::Value;
use glam::{Mat3, Mat4, Vec3, Vec4};
use materials::Materials;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

/// An area light of the graphics state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct AreaLight {
    /// Emitted radiance (`L · scale`).
    pub radiance: Rgb,
    /// Emits from both sides.
    pub two_sided: bool,
    /// pbrt-v4's `power`: the radiance is rescaled per shape to emit this (luminous) power.
    pub power: Option<f32>,
}

impl AreaLight {
    /// The radiance of a shape of `area` (world space) under this light.
    pub fn radiance_for(&self, area: f32) -> Rgb {
        let sides = if self.two_sided { 2.0 } else { 1.0 };
        photometric(
            self.radiance,
            self.power,
            sides * area * std::f32::consts::PI,
        )
    }
}

/// The graphics state `AttributeBegin` saves.
#[derive(Clone, Debug)]
pub(super) struct State {
    /// The current transform (object to world, or camera from world before `WorldBegin`).
    pub ctm: Mat4,
    /// `ReverseOrientation` is in effect.
    pub reverse: bool,
    /// The current material: an index of the description's materials, or `None` for
    /// pbrt's `interface` (a surface that only bounds a medium).
    pub material: Option<u32>,
    /// The current area light.
    pub area: Option<AreaLight>,
    /// The current `MediumInterface`: the names of the media inside and outside (`""` is
    /// vacuum).
    pub media: (String, String),
}

/// The interpreter.
pub(super) struct Interp {
    pub desc: SceneDesc,
    pub state: State,
    stack: Vec<(State, PathBuf, Loc)>,
    named_coords: HashMap<String, Mat4>,
    materials: Materials,
    /// Object definitions: shapes in object space, by name.
    objects: HashMap<String, u32>,
    /// The object being defined.
    object: Option<(String, Vec<ShapeDesc>)>,
    /// Warnings already given, by kind (one per kind and file).
    warned: HashSet<String>,
    world: bool,
    /// Named media: indices into the description's media.
    pub media: HashMap<String, u32>,
    /// The camera's medium (the outside medium current at `Camera`), by name.
    camera_medium: Option<(String, Loc, PathBuf)>,
    /// The `Integrator` ignores media (pbrt-v4's `path`), where it says so.
    media_ignored_at: Option<(Loc, PathBuf)>,
}

/// Reads the pbrt-v4 scene at `path` (and the files it includes) into a description.
pub fn load_file(path: &Path) -> Result<SceneDesc> {
    interpret(&read_file(path)?, path)
}

/// Interprets the text of one pbrt-v4 file named `path` (its `Include`s are not followed;
/// files it names are read relative to `path`'s folder): the fuzz target's entry.
pub fn load_text(text: &str, path: &Path) -> Result<SceneDesc> {
    interpret(&super::parse(text, path)?, path)
}

/// The description of `directives`, read from `path`.
fn interpret(directives: &[Directive], path: &Path) -> Result<SceneDesc> {
    let file = path.display().to_string();
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    let mut it = Interp::new(&file, &name);
    for d in directives {
        it.directive(d)?;
    }
    it.finish(directives)
}

/// A light's colour `c`, rescaled when a photometric quantity `q` (power, illuminance) is
/// given to have luminance `q / measure` (pbrt-v4 divides by the spectrum's photometric
/// value, then multiplies by the quantity over the light's measure).
fn photometric(c: Rgb, q: Option<f32>, measure: f32) -> Rgb {
    match q {
        Some(q) if crate::math::luminance(c) > 0.0 => c / crate::math::luminance(c) * q / measure,
        _ => c,
    }
}

/// An error at directive `d`.
pub(super) fn error_at(d: &Directive, msg: String) -> Error {
    Error::At {
        file: d.file.display().to_string(),
        loc: d.loc,
        msg,
    }
}

/// The numbers of `d`'s arguments (their count is checked by the parser).
fn numbers(d: &Directive) -> Vec<f32> {
    d.args
        .iter()
        .flat_map(|a| match a {
            Arg::Number(x) => vec![*x as f32],
            Arg::Numbers(v) => v.iter().map(|&x| x as f32).collect(),
            Arg::Str(_) => vec![],
        })
        .collect()
}

/// The `i`-th string argument of `d`.
pub(super) fn string(d: &Directive, i: usize) -> &str {
    d.args
        .iter()
        .filter_map(|a| match a {
            Arg::Str(s) => Some(s.as_str()),
            _ => None,
        })
        .nth(i)
        .unwrap_or("")
}

/// pbrt's `LookAt`: the camera-from-world matrix of an eye at `eye` looking at `at`.
fn look_at(eye: Vec3, at: Vec3, up: Vec3) -> Option<Mat4> {
    let dir = (at - eye).normalize_or_zero();
    let right = up.normalize_or_zero().cross(dir).normalize_or_zero();
    if dir == Vec3::ZERO || right == Vec3::ZERO {
        return None;
    }
    let new_up = dir.cross(right);
    let world_from_camera = Mat4::from_cols(
        right.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        eye.extend(1.0),
    );
    Some(world_from_camera.inverse())
}

impl Interp {
    fn new(file: &str, name: &str) -> Interp {
        let mut desc = SceneDesc {
            name: name.to_string(),
            file: file.to_string(),
            ..Default::default()
        };
        let materials = Materials::new(&mut desc);
        Interp {
            state: State {
                ctm: Mat4::IDENTITY,
                reverse: false,
                material: Some(materials.default_material),
                area: None,
                media: (String::new(), String::new()),
            },
            desc,
            stack: Vec::new(),
            named_coords: HashMap::new(),
            materials,
            objects: HashMap::new(),
            object: None,
            warned: HashSet::new(),
            world: false,
            media: HashMap::new(),
            camera_medium: None,
            media_ignored_at: None,
        }
    }

    /// A warning at `d`, given once per `kind`.
    pub(super) fn warn_once(&mut self, d: &Directive, kind: &str, msg: String) {
        if self.warned.insert(kind.to_string()) {
            self.desc
                .warnings
                .push(format!("{}:{}: {msg}", d.file.display(), d.loc));
        }
    }

    /// The unused-parameter warnings of `p`.
    pub(super) fn report_unused(&mut self, p: &Params) {
        self.desc.warnings.extend(p.unused());
    }

    fn directive(&mut self, d: &Directive) -> Result<()> {
        match d.name.as_str() {
            "Translate" | "Scale" | "Rotate" | "LookAt" | "Transform" | "ConcatTransform"
            | "Identity" | "CoordinateSystem" | "CoordSysTransform" => self.transform(d)?,
            "AttributeBegin" | "TransformBegin" => {
                self.stack.push((self.state.clone(), d.file.clone(), d.loc));
            }
            "AttributeEnd" | "TransformEnd" => {
                let Some((saved, _, _)) = self.stack.pop() else {
                    return Err(error_at(d, format!("{} without a matching begin", d.name)));
                };
                if d.name == "TransformEnd" {
                    self.state.ctm = saved.ctm;
                } else {
                    self.state = saved;
                }
            }
            "ReverseOrientation" => self.state.reverse = !self.state.reverse,
            "WorldBegin" => {
                self.world = true;
                self.state.ctm = Mat4::IDENTITY;
                self.named_coords.insert("world".into(), Mat4::IDENTITY);
            }
            "WorldEnd" => {}
            "Camera" => self.camera(d)?,
            "Film" | "Sampler" | "Integrator" | "PixelFilter" | "Accelerator" | "ColorSpace"
            | "Option" => self.render_setting(d)?,
            "Material" | "MakeNamedMaterial" | "NamedMaterial" | "Texture" => {
                self.material_directive(d)?
            }
            "AreaLightSource" => self.area_light(d)?,
            "LightSource" => self.light(d)?,
            "Shape" => self.shape(d)?,
            "ObjectBegin" => self.object_begin(d)?,
            "ObjectEnd" => match (self.object.take(), self.stack.pop()) {
                (Some((name, shapes)), Some((saved, _, _))) => {
                    self.objects
                        .insert(name.clone(), self.desc.objects.len() as u32);
                    self.desc.objects.push(ObjectDesc { name, shapes });
                    self.state = saved;
                }
                _ => return Err(error_at(d, "ObjectEnd without ObjectBegin".into())),
            },
            "ObjectInstance" => self.object_instance(d)?,
            "MakeNamedMedium" => self.medium(d)?,
            "MediumInterface" => {
                let inside = string(d, 0).to_string();
                let outside = if d.args.len() > 1 {
                    string(d, 1).to_string()
                } else {
                    inside.clone()
                };
                self.state.media = (inside, outside);
            }
            "Attribute" => self.warn_once(
                d,
                "Attribute",
                "Attribute (shared parameter defaults) is not supported yet; ignored".into(),
            ),
            "TransformTimes" | "ActiveTransform" => self.warn_once(
                d,
                "motion",
                format!(
                    "{} (motion blur) is not supported; the start transform is used",
                    d.name
                ),
            ),
            "Include" | "Import" => {}
            other => {
                return Err(error_at(d, format!("unknown directive '{other}'")));
            }
        }
        Ok(())
    }

    fn transform(&mut self, d: &Directive) -> Result<()> {
        let v = numbers(d);
        let ctm = &mut self.state.ctm;
        match d.name.as_str() {
            "Translate" => *ctm *= Mat4::from_translation(Vec3::new(v[0], v[1], v[2])),
            "Scale" => *ctm *= Mat4::from_scale(Vec3::new(v[0], v[1], v[2])),
            "Rotate" => {
                let axis = Vec3::new(v[1], v[2], v[3]).normalize_or_zero();
                if axis == Vec3::ZERO {
                    return Err(error_at(d, "Rotate about a zero axis".into()));
                }
                *ctm *= Mat4::from_axis_angle(axis, v[0].to_radians());
            }
            "LookAt" => {
                let p = |i: usize| Vec3::new(v[i], v[i + 1], v[i + 2]);
                let m = look_at(p(0), p(3), p(6)).ok_or_else(|| {
                    error_at(
                        d,
                        "LookAt: the eye is at the target or up is along the view".into(),
                    )
                })?;
                *ctm *= m;
            }
            "Transform" | "ConcatTransform" => {
                if v.len() != 16 {
                    return Err(error_at(
                        d,
                        format!("{} needs 16 numbers, not {}", d.name, v.len()),
                    ));
                }
                let m = Mat4::from_cols_slice(&v);
                if d.name == "Transform" {
                    *ctm = m;
                } else {
                    *ctm *= m;
                }
            }
            "Identity" => *ctm = Mat4::IDENTITY,
            "CoordinateSystem" => {
                self.named_coords.insert(string(d, 0).to_string(), *ctm);
            }
            _ => {
                let name = string(d, 0);
                match self.named_coords.get(name) {
                    Some(m) => *ctm = *m,
                    None => {
                        return Err(error_at(d, format!("unknown coordinate system '{name}'")));
                    }
                }
            }
        }
        Ok(())
    }

    fn camera(&mut self, d: &Directive) -> Result<()> {
        let p = Params::new(d);
        let outside = &self.state.media.1;
        self.camera_medium =
            (!outside.is_empty()).then(|| (outside.clone(), d.loc, d.file.clone()));
        let camera_from_world = self.state.ctm;
        if camera_from_world.determinant().abs() < 1e-12 || !camera_from_world.is_finite() {
            return Err(error_at(
                d,
                "Camera: the current transform is singular".into(),
            ));
        }
        let world_from_camera = camera_from_world.inverse();
        self.named_coords.insert("camera".into(), world_from_camera);
        let ty = string(d, 0);
        if ty != "perspective" && ty != "orthographic" {
            self.warn_once(
                d,
                "camera type",
                format!("camera \"{ty}\" is not supported; a perspective camera stands in"),
            );
        }
        let fov = p.float("fov", 90.0)?;
        if !(fov > 0.0 && fov < 180.0) {
            let at = p.find("fov", &["float"])?.map_or(d.loc, |q| q.loc);
            return Err(Error::At {
                file: d.file.display().to_string(),
                loc: at,
                msg: format!("Camera: fov must be in (0, 180) degrees, not {fov}"),
            });
        }
        let lens_radius = p.float("lensradius", 0.0)?.max(0.0);
        let focal = p.float("focaldistance", 1e6)?;
        for unsupported in ["screenwindow", "frameaspectratio"] {
            if p.find(unsupported, &["float"])?.is_some() {
                self.warn_once(
                    d,
                    unsupported,
                    format!(
                        "Camera \"{unsupported}\" is not supported yet; the full frame is used"
                    ),
                );
            }
        }
        p.ignore(&["shutteropen", "shutterclose"]);
        self.report_unused(&p);
        let mut cam = camera_desc(world_from_camera, fov, d.loc);
        cam.name = ty.to_string();
        cam.lens = (lens_radius > 0.0).then_some((lens_radius, focal.max(1e-6)));
        cam.orthographic = ty == "orthographic";
        self.desc.camera = Some(cam);
        Ok(())
    }

    /// Sets render option `name` from parameter `param` of `p`, checked against the option's
    /// range with the parameter's position in the message.
    fn option(
        &mut self,
        p: &Params,
        d: &Directive,
        name: &str,
        value: i64,
        param: &str,
    ) -> Result<()> {
        self.option_value(p, d, name, Value::Int(value as i128), param)
    }

    /// [`Interp::option`] for any value.
    fn option_value(
        &mut self,
        _p: &Params,
        d: &Directive,
        name: &str,
        v: Value,
        param: &str,
    ) -> Result<()> {
        crate::options::check(name, &v).map_err(|e| {
            let loc = d
                .params
                .iter()
                .find(|q| q.name == param)
                .map_or(d.loc, |q| q.loc);
            Error::At {
                file: d.file.display().to_string(),
                loc,
                msg: format!("{} \"{param}\": {e}", d.name),
            }
        })?;
        self.desc.options.retain(|(n, _)| n != name);
        self.desc.options.push((name.to_string(), v));
        Ok(())
    }

    fn render_setting(&mut self, d: &Directive) -> Result<()> {
        let p = Params::new(d);
        let ty = string(d, 0).to_string();
        match d.name.as_str() {
            "Film" => {
                let (w, h) = (p.int("xresolution", 1280)?, p.int("yresolution", 720)?);
                self.option(&p, d, "width", w, "xresolution")?;
                self.option(&p, d, "height", h, "yresolution")?;
                self.crop(d, &p, w, h)?;
                p.ignore(&["filename"]);
            }
            "Sampler" => {
                let spp = p.int("pixelsamples", 16)?;
                self.option(&p, d, "spp", spp, "pixelsamples")?;
                p.ignore(&["seed", "randomization", "jitter", "xsamples", "ysamples"]);
            }
            "Integrator" => {
                let depth = p.int("maxdepth", 5)?;
                self.option(&p, d, "max_depth", depth, "maxdepth")?;
                if ty == "path" {
                    self.media_ignored_at = Some((d.loc, d.file.clone()));
                }
                if !matches!(ty.as_str(), "path" | "volpath") {
                    self.warn_once(
                        d,
                        "integrator",
                        format!(
                            "integrator \"{ty}\" is not supported; the path integrator stands in"
                        ),
                    );
                }
                p.ignore(&["regularize", "lightsampler"]);
            }
            "PixelFilter" => self.pixel_filter(d, &p, &ty)?,
            "ColorSpace" if ty != "srgb" => {
                self.warn_once(
                    d,
                    "colorspace",
                    format!("colour space \"{ty}\" is not supported; sRGB is used"),
                );
            }
            "Option" => self.warn_once(d, "Option", "Option directives are ignored".into()),
            _ => {}
        }
        self.report_unused(&p);
        Ok(())
    }

    /// `Film`'s `cropwindow` (fractions `x0 x1 y0 y1`, each edge at the ceiling of its
    /// fraction of the resolution, as pbrt-v4 rounds) or `pixelbounds` (pixels): the `cell`
    /// option, which renders only that region of the frame.
    fn crop(&mut self, d: &Directive, p: &Params, w: i64, h: i64) -> Result<()> {
        let bounds = if let Some(c) = p.numbers("cropwindow", "float")? {
            if c.len() != 4 {
                return Err(error_at(d, "Film \"cropwindow\" needs 4 numbers".into()));
            }
            let at = |f: f64, n: i64| (f.clamp(0.0, 1.0) * n as f64).ceil() as i64;
            [at(c[0], w), at(c[1], w), at(c[2], h), at(c[3], h)]
        } else if let Some(b) = p.numbers("pixelbounds", "integer")? {
            if b.len() != 4 {
                return Err(error_at(d, "Film \"pixelbounds\" needs 4 integers".into()));
            }
            [b[0] as i64, b[1] as i64, b[2] as i64, b[3] as i64]
        } else {
            return Ok(());
        };
        let [x0, x1, y0, y1] = bounds;
        let int = |v: i64| Value::Int(v as i128);
        let cell = Value::List(vec![int(x0), int(y0), int(x1 - x0), int(y1 - y0)]);
        self.option_value(p, d, "cell", cell, "cropwindow")
    }

    /// `PixelFilter`: box, triangle and gaussian become the `filter` options (the mean of the
    /// x and y radii); others are a warning with the Gaussian standing in.
    fn pixel_filter(&mut self, d: &Directive, p: &Params, ty: &str) -> Result<()> {
        let kind = match ty.parse::<FilterKind>() {
            Ok(k) => k,
            Err(_) => {
                self.warn_once(
                    d,
                    "filter",
                    format!(
                        "pixel filter \"{ty}\" is not supported; the gaussian filter stands in"
                    ),
                );
                p.ignore(&["B", "C", "tau"]);
                FilterKind::Gaussian
            }
        };
        let own = if ty == kind.to_string() {
            kind.default_radius()
        } else {
            FilterKind::Gaussian.default_radius()
        };
        let (x, y) = (p.float("xradius", own)?, p.float("yradius", own)?);
        if x != y {
            self.warn_once(
                d,
                "filter radii",
                format!("different filter radii ({x}, {y}) are not supported; their mean is used"),
            );
        }
        let sigma = p.float("sigma", GAUSSIAN_SIGMA)?;
        if sigma != GAUSSIAN_SIGMA {
            self.warn_once(d, "filter sigma", format!("a Gaussian sigma other than {GAUSSIAN_SIGMA} is not supported yet; {GAUSSIAN_SIGMA} is used"));
        }
        self.option_value(p, d, "filter", Value::Text(kind.to_string()), "")?;
        self.option_value(
            p,
            d,
            "filter_radius",
            Value::Real(0.5 * (x + y) as f64),
            "xradius",
        )
    }

    fn area_light(&mut self, d: &Directive) -> Result<()> {
        let p = Params::new(d);
        let ty = string(d, 0);
        if ty != "diffuse" {
            return Err(error_at(d, format!("unknown area light \"{ty}\"")));
        }
        let l = self.materials.rgb_param(&p, "L", Rgb::ONE)?;
        let scale = p.float("scale", 1.0)?;
        let two_sided = p.bool("twosided", false)?;
        if p.string("filename")?.is_some() {
            self.warn_once(
                d,
                "area image",
                "area light \"filename\" (an emission image) is not supported yet; \"L\" is used"
                    .into(),
            );
        }
        self.report_unused(&p);
        self.state.area = Some(AreaLight {
            radiance: l * scale,
            two_sided,
            power: p.float_opt("power")?.filter(|&w| w > 0.0),
        });
        Ok(())
    }

    fn light(&mut self, d: &Directive) -> Result<()> {
        let p = Params::new(d);
        let ty = string(d, 0).to_string();
        let ctm = self.state.ctm;
        let scale = p.float("scale", 1.0)?;
        let kind = match ty.as_str() {
            "point" => {
                let from = p.vec3("from", "point3")?.unwrap_or(Vec3::ZERO);
                let i = self.materials.rgb_param(&p, "I", Rgb::ONE)?;
                let i = photometric(i, p.float_opt("power")?, 4.0 * std::f32::consts::PI) * scale;
                Some((
                    LightKind::Point { intensity: i },
                    ctm * Mat4::from_translation(from),
                ))
            }
            "distant" => {
                let from = p.vec3("from", "point3")?.unwrap_or(Vec3::ZERO);
                let to = p.vec3("to", "point3")?.unwrap_or(Vec3::Z);
                let l = photometric(
                    self.materials.rgb_param(&p, "L", Rgb::ONE)?,
                    p.float_opt("illuminance")?,
                    1.0,
                ) * scale;
                let to_light = ctm.transform_vector3(from - to).normalize_or_zero();
                if to_light == Vec3::ZERO {
                    return Err(error_at(d, "distant light: \"from\" equals \"to\"".into()));
                }
                let t = Mat4::from_cols(Vec4::X, Vec4::Y, (-to_light).extend(0.0), Vec4::W);
                Some((LightKind::Directional { irradiance: l }, t))
            }
            "spot" => Some(self.spot(d, &p, scale)?),
            "infinite" => Some(self.infinite(d, &p, scale)?),
            _ => {
                self.warn_once(
                    d,
                    &format!("light {ty}"),
                    format!("light \"{ty}\" is not supported yet; it is left out"),
                );
                None
            }
        };
        if let Some((kind, transform)) = kind {
            self.report_unused(&p);
            self.desc.lights.push(LightDesc {
                name: ty,
                kind,
                transform,
                loc: d.loc,
            });
        }
        Ok(())
    }

    /// A `spot` light: at `from`, its axis towards `to`, full intensity within
    /// `coneangle − conedeltaangle` of the axis and a smoothstep down to none at `coneangle`.
    fn spot(&mut self, d: &Directive, p: &Params, scale: f32) -> Result<(LightKind, Mat4)> {
        let from = p.vec3("from", "point3")?.unwrap_or(Vec3::ZERO);
        let to = p.vec3("to", "point3")?.unwrap_or(Vec3::Z);
        let cone = p.float("coneangle", 30.0)?.clamp(0.0, 180.0);
        let delta = p.float("conedeltaangle", 5.0)?.clamp(0.0, cone);
        let dir = (to - from).normalize_or_zero();
        if dir == Vec3::ZERO {
            return Err(error_at(d, "spot light: \"from\" equals \"to\"".into()));
        }
        let (cos_end, cos_start) = (cone.to_radians().cos(), (cone - delta).to_radians().cos());
        let cone_solid_angle = 2.0 * std::f32::consts::PI * (1.0 - 0.5 * (cos_start + cos_end));
        let i = self.materials.rgb_param(p, "I", Rgb::ONE)?;
        let i = photometric(i, p.float_opt("power")?, cone_solid_angle) * scale;
        let (x, y) = dir.any_orthonormal_pair();
        let aim = Mat4::from_cols(x.extend(0.0), y.extend(0.0), (-dir).extend(0.0), Vec4::W);
        let t = self.state.ctm * Mat4::from_translation(from) * aim;
        Ok((
            LightKind::Spot {
                intensity: i,
                falloff_angle_deg: 2.0 * cone,
                falloff_exponent: 0.0,
                falloff_start_deg: Some(2.0 * (cone - delta)),
                linear_falloff: false,
            },
            t,
        ))
    }

    /// An `infinite` light: constant `L`, or the equal-area image `filename`; `illuminance`
    /// scales it to that illuminance on a surface facing the light's +Z.
    fn infinite(&mut self, d: &Directive, p: &Params, scale: f32) -> Result<(LightKind, Mat4)> {
        let file = p.string("filename")?;
        let given_l = p.find("L", &["rgb", "spectrum", "blackbody"])?.is_some();
        if file.is_some() && given_l {
            return Err(error_at(
                d,
                "infinite light: give \"L\" or \"filename\", not both".into(),
            ));
        }
        if p.numbers("portal", "point3")?.is_some() {
            self.warn_once(
                d,
                "portal",
                "infinite light \"portal\" is not supported yet; the whole sphere is sampled"
                    .into(),
            );
        }
        let (scale, image) = match file {
            None => (self.materials.rgb_param(p, "L", Rgb::ONE)? * scale, None),
            Some(f) => {
                let path = Interp::folder(d).join(f);
                let encoding = p.string("encoding")?.unwrap_or("sRGB");
                let (w, h, texels) =
                    super::images::read(&path, encoding, false).map_err(|msg| error_at(d, msg))?;
                if w != h {
                    return Err(error_at(d, format!("{f}: an infinite light's image must be square (pbrt-v4's equal-area mapping), not {w}×{h}")));
                }
                if !self.desc.sources.contains(&path) {
                    self.desc.sources.push(path);
                }
                (Rgb::splat(scale), Some((w, texels)))
            }
        };
        let mut kind = LightKind::Infinite { scale, image };
        if let Some(e) = p.float_opt("illuminance")? {
            let LightKind::Infinite { scale, image } = &mut kind else {
                unreachable!()
            };
            let light = match image {
                None => InfiniteLight::constant(*scale),
                Some((n, t)) => {
                    InfiniteLight::image(*n as usize, t.clone(), *scale, Mat3::IDENTITY)
                        .ok_or_else(|| error_at(d, "infinite light: an empty image".into()))?
                }
            };
            let now = light.upper_illuminance();
            if now > 0.0 {
                *scale *= e / now;
            }
        }
        Ok((kind, self.state.ctm))
    }

    /// The description index of the medium named `name` (`""` is vacuum), or an error at `d`.
    fn medium_named(&self, d: &Directive, name: &str) -> Result<Option<u32>> {
        if name.is_empty() {
            return Ok(None);
        }
        match self.media.get(name) {
            Some(&i) => Ok(Some(i)),
            None => Err(error_at(
                d,
                format!("medium '{name}' is not defined (MakeNamedMedium) before it is used"),
            )),
        }
    }

    /// The current `MediumInterface` for a shape at `d`, where it separates two different
    /// media. A sphere's outside is where its normal points, which `ReverseOrientation` and
    /// mirroring transforms turn inwards (meshes have their winding turned instead).
    pub(super) fn medium_interface(
        &self,
        d: &Directive,
        sphere: bool,
    ) -> Result<Option<MediumInterfaceDesc>> {
        let (inside, outside) = &self.state.media;
        if inside == outside {
            return Ok(None);
        }
        let (mut inside, mut outside) = (
            self.medium_named(d, inside)?,
            self.medium_named(d, outside)?,
        );
        if sphere && self.state.reverse ^ (self.state.ctm.determinant() < 0.0) {
            std::mem::swap(&mut inside, &mut outside);
        }
        Ok((inside != outside).then_some(MediumInterfaceDesc { inside, outside }))
    }

    fn object_begin(&mut self, d: &Directive) -> Result<()> {
        if self.object.is_some() {
            return Err(error_at(d, "ObjectBegin inside another object".into()));
        }
        self.stack.push((self.state.clone(), d.file.clone(), d.loc));
        self.object = Some((string(d, 0).to_string(), Vec::new()));
        Ok(())
    }

    fn object_instance(&mut self, d: &Directive) -> Result<()> {
        let name = string(d, 0);
        let Some(&object) = self.objects.get(name) else {
            return Err(error_at(d, format!("unknown object '{name}'")));
        };
        if self.object.is_some() {
            return Err(error_at(
                d,
                "ObjectInstance inside an object definition".into(),
            ));
        }
        self.desc.instances.push(InstanceDesc {
            object,
            transform: self.state.ctm,
            loc: d.loc,
        });
        Ok(())
    }

    /// Whether an object is being defined (its shapes must not emit).
    pub(super) fn defining_object(&self) -> bool {
        self.object.is_some()
    }

    /// Adds a shape to the scene, or to the object being defined.
    pub(super) fn add_shape(&mut self, s: ShapeDesc) {
        match &mut self.object {
            Some((_, shapes)) => shapes.push(s),
            None => self.desc.shapes.push(s),
        }
    }

    /// The unclosed `AttributeBegin`s and objects are errors; the description.
    fn finish(mut self, directives: &[Directive]) -> Result<SceneDesc> {
        if let Some((_, file, loc)) = self.stack.last() {
            return Err(Error::At {
                file: file.display().to_string(),
                loc: *loc,
                msg: "AttributeBegin (or ObjectBegin) is never closed".into(),
            });
        }
        if !self.world && !directives.is_empty() {
            self.desc
                .warnings
                .push(format!("{}: no WorldBegin", self.desc.file));
        }
        self.finish_media()?;
        if self.desc.camera.is_none() {
            // pbrt-v4's default: a perspective camera at the origin looking down +z, 90°.
            self.desc.camera = Some(camera_desc(Mat4::IDENTITY, 90.0, Loc::default()));
        }
        let mut files: Vec<PathBuf> = directives.iter().map(|d| d.file.clone()).collect();
        files.dedup();
        for f in files.into_iter().skip(1) {
            if !self.desc.sources.contains(&f) {
                self.desc.sources.push(f);
            }
        }
        Ok(self.desc)
    }

    /// The camera's medium, and no media at all where the integrator ignores them.
    fn finish_media(&mut self) -> Result<()> {
        if let Some((name, loc, file)) = self.camera_medium.take() {
            let Some(&i) = self.media.get(&name) else {
                return Err(Error::At {
                    file: file.display().to_string(),
                    loc,
                    msg: format!("the camera's medium '{name}' is never defined (MakeNamedMedium)"),
                });
            };
            self.desc.camera_medium = Some(i);
        }
        if let Some((loc, file)) = &self.media_ignored_at {
            if !self.desc.media.is_empty() {
                self.desc.warnings.push(format!(
                    "{}:{loc}: the integrator \"path\" ignores participating media, as pbrt-v4's \
                     does (\"volpath\" renders them); they are left out",
                    file.display()
                ));
                self.desc.camera_medium = None;
                for m in &mut self.desc.materials {
                    m.interface = None;
                }
            }
        }
        Ok(())
    }

    /// The folder of the file `d` is in (paths in it are relative to that).
    pub(super) fn folder(d: &Directive) -> PathBuf {
        d.file.parent().map(Path::to_path_buf).unwrap_or_default()
    }
}

/// A pinhole perspective camera placed by `world_from_camera` (pbrt-v4's left-handed camera
/// space: looking down +z, +y up, +x right) with `fov` degrees over the image's shorter axis.
fn camera_desc(world_from_camera: Mat4, fov: f32, loc: Loc) -> CameraDesc {
    CameraDesc {
        name: "perspective".into(),
        xfov_deg: None,
        yfov_deg: Some(fov),
        aspect: None,
        znear: 1e-3,
        zfar: 1e30,
        transform: world_from_camera * Mat4::from_scale(Vec3::new(1.0, 1.0, -1.0)),
        loc,
        exact: true,
        fov_axis: FovAxis::Shorter,
        right_is_x: true,
        lens: None,
        orthographic: false,
    }
}
