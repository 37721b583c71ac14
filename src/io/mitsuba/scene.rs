//! The scene's top level: sensor (camera, film, sampler), integrator, emitters, and the
//! shapes and groups handed to [`super::shapes`].
//!
//! - Mitsuba's camera space looks down +Z with +Y up and +X to the image's *left*; the
//!   description's camera is `to_world · diag(−1, 1, −1)` with its right along +X (so a
//!   mirroring `to_world` mirrors the image as in Mitsuba). `fov` spans `fov_axis` (`x`, the
//!   default, `y`, `diagonal`, `smaller`, `larger`); `focal_length` (35 mm film) stands for it.
//! - `hdrfilm`'s size and crop become the `width`, `height` and `cell` options; its
//!   `rfilter` the `filter` options (`box` ½, `tent` 1, `gaussian` σ ½ radius 2 pixels; the
//!   film's default is the Gaussian).
//! - The sampler's `sample_count` becomes `spp`; the integrator's `max_depth` (Mitsuba
//!   counts path vertices: 1 is emitters only, −1 unlimited, its default) becomes
//!   `max_depth` minus one, and `rr_depth` the option of that name.
//! - Emitters: `point` (`intensity`, `position` or `to_world`), `spot` (`intensity`,
//!   `cutoff_angle`, `beam_width`, around `to_world`'s +Z), `directional` (`irradiance`,
//!   `direction`), `constant` (`radiance`), `envmap` (`filename`, `scale`, `to_world`;
//!   Mitsuba's latitude-longitude mapping), and `area` inside shapes.

use super::xml::Node;
use super::Interp;
use crate::error::Result;
use crate::filter::FilterKind;
use crate::io::desc::{CameraDesc, FovAxis, LightDesc, LightKind};
use crate::math::Rgb;
use crate::options::Value;
use glam::{Mat4, Vec3, Vec4};

/// The integrator types rendered as Mitsuba's `path`.
const PATH_LIKE: [&str; 3] = ["path", "volpath", "volpathmis"];

impl<'a> Interp<'a> {
    /// The root's objects, in file order.
    pub(super) fn scene(&mut self) -> Result<()> {
        let root = self.node(0);
        let mut sensors = 0;
        let mut integrator = false;
        for c in &root.children {
            let node = self.node(c.node);
            match node.tag.as_str() {
                "sensor" => {
                    sensors += 1;
                    if sensors == 1 {
                        self.sensor(node)?;
                    } else {
                        self.warn_once(
                            node,
                            node.loc,
                            "sensors",
                            "only the first sensor is rendered",
                        );
                    }
                }
                "integrator" => {
                    integrator = true;
                    if node.plugin == "path" {
                        self.media_ignored_by = Some(c.node);
                    }
                    self.integrator(node)?;
                }
                "shape" => self.shape(node, None)?,
                "emitter" => self.emitter(node)?,
                "bsdf" | "texture" => {}
                "medium" => {
                    self.medium(c.node)?;
                }
                "phase" | "volume" => self.unsupported(node, "ignored outside a medium"),
                _ => self.unsupported(node, "ignored"),
            }
        }
        if !integrator {
            self.media_ignored_by = Some(0);
            self.set_option(root, "max_depth", Value::Int(100_000))?;
        }
        if sensors == 0 {
            self.warn_once(
                root,
                root.loc,
                "no sensor",
                "the scene has no sensor (Mitsuba 3 refuses to render it); it is framed whole \
                 from its front, as a model file without a camera is",
            );
        }
        Ok(())
    }

    /// Sets render option `name`, checked against its range.
    fn set_option(&mut self, node: &Node, name: &str, v: Value) -> Result<()> {
        crate::options::check(name, &v).map_err(|e| {
            self.doc.error(
                node,
                node.loc,
                format!("{} \"{}\": {e}", node.tag, node.plugin),
            )
        })?;
        self.desc.options.retain(|(n, _)| n != name);
        self.desc.options.push((name.to_string(), v));
        Ok(())
    }

    fn integrator(&mut self, node: &'a Node) -> Result<()> {
        self.count(node);
        if !PATH_LIKE.contains(&node.plugin.as_str()) {
            self.unsupported(node, "the path integrator stands in");
        }
        let depth = self.int(node, "max_depth", -1)?;
        let ours = if depth < 0 {
            100_000
        } else {
            (depth - 1).max(0)
        };
        self.set_option(node, "max_depth", Value::Int(ours as i128))?;
        if let Some(p) = node.props.iter().find(|p| p.name == "rr_depth") {
            p.used.set(true);
            let rr = self.int(node, "rr_depth", 5)?;
            self.set_option(node, "rr_depth", Value::Int(rr.max(1) as i128))?;
        }
        for ignored in ["hide_emitters"] {
            if self.bool(node, ignored, false)? {
                self.warn_once(
                    node,
                    node.loc,
                    ignored,
                    format!("\"{ignored}\" is not supported; emitters stay visible"),
                );
            }
        }
        Ok(())
    }

    fn sensor(&mut self, node: &'a Node) -> Result<()> {
        self.count(node);
        self.sensor_medium(node)?;
        let orthographic = node.plugin == "orthographic";
        if !matches!(node.plugin.as_str(), "perspective" | "thinlens") && !orthographic {
            self.unsupported(node, "a perspective camera stands in");
        }
        let to_world = self.to_world(node)?;
        let (fov, axis) = match self.float_opt(node, "fov")? {
            Some(f) => {
                let axis = self
                    .string(node, "fov_axis")?
                    .unwrap_or("x")
                    .to_ascii_lowercase();
                let axis = match axis.as_str() {
                    "x" => FovAxis::Width,
                    "y" => FovAxis::Height,
                    "diagonal" => FovAxis::Diagonal,
                    "smaller" => FovAxis::Shorter,
                    "larger" => FovAxis::Longer,
                    other => {
                        return Err(self.doc.error(
                            node,
                            node.loc,
                            format!(
                                "fov_axis \"{other}\": must be x, y, diagonal, smaller or larger"
                            ),
                        ))
                    }
                };
                (f, axis)
            }
            None => {
                let s = self.string(node, "focal_length")?.unwrap_or("50mm");
                let fov = focal_length_fov(s).ok_or_else(|| {
                    self.doc.error(
                        node,
                        node.loc,
                        format!("focal_length \"{s}\": expected a length such as \"50mm\""),
                    )
                })?;
                (fov, FovAxis::Diagonal)
            }
        };
        if !(fov > 0.0 && fov < 180.0) {
            return Err(self.doc.error(
                node,
                node.loc,
                format!("fov must be in (0, 180), not {fov}"),
            ));
        }
        let lens = if node.plugin == "thinlens" {
            let r = self.float(node, "aperture_radius", 0.03)?;
            let f = self.float(node, "focus_distance", 0.0)?;
            (r > 0.0 && f > 0.0).then_some((r, f))
        } else {
            None
        };
        if orthographic {
            self.warn_once(node, node.loc, "orthographic", "Mitsuba's orthographic sensor spans to_world's unit square; rendered with the shorter axis spanning 2 units");
        }
        self.desc.camera = Some(CameraDesc {
            name: node.id.clone().unwrap_or_else(|| "sensor".into()),
            xfov_deg: None,
            yfov_deg: Some(fov),
            aspect: None,
            znear: self.float(node, "near_clip", 1e-2)?,
            zfar: self.float(node, "far_clip", 1e4)?,
            transform: to_world * Mat4::from_scale(Vec3::new(-1.0, 1.0, -1.0)),
            loc: node.loc,
            exact: true,
            fov_axis: axis,
            right_is_x: true,
            lens,
            orthographic,
        });
        self.float(node, "shutter_open", 0.0)?;
        self.float(node, "shutter_close", 0.0)?;
        let (films, samplers): (Vec<_>, Vec<_>) = (
            self.children(node, "film").collect(),
            self.children(node, "sampler").collect(),
        );
        match films.first() {
            Some(&(f, _)) => self.film(self.node(f))?,
            None => {
                self.set_option(node, "width", Value::Int(768))?;
                self.set_option(node, "height", Value::Int(576))?;
                self.filter(node, None)?;
            }
        }
        let spp = match samplers.first() {
            Some(&(s, _)) => {
                let s = self.node(s);
                self.count(s);
                self.int(s, "seed", 0)?;
                self.int(s, "sample_count", 4)?
            }
            None => 4,
        };
        self.set_option(node, "spp", Value::Int(spp as i128))
    }

    fn film(&mut self, node: &'a Node) -> Result<()> {
        self.count(node);
        if !matches!(node.plugin.as_str(), "hdrfilm" | "specfilm") {
            self.unsupported(node, "an HDR film stands in");
        }
        let (w, h) = (
            self.int(node, "width", 768)?,
            self.int(node, "height", 576)?,
        );
        self.set_option(node, "width", Value::Int(w as i128))?;
        self.set_option(node, "height", Value::Int(h as i128))?;
        let (cx, cy) = (
            self.int(node, "crop_offset_x", 0)?,
            self.int(node, "crop_offset_y", 0)?,
        );
        let (cw, ch) = (
            self.int(node, "crop_width", w)?,
            self.int(node, "crop_height", h)?,
        );
        if (cx, cy, cw, ch) != (0, 0, w, h) {
            let int = |v: i64| Value::Int(v as i128);
            self.set_option(
                node,
                "cell",
                Value::List(vec![int(cx), int(cy), int(cw), int(ch)]),
            )?;
        }
        for ignored in ["file_format", "pixel_format", "component_format", "banner"] {
            self.string(node, ignored)?;
        }
        for ignored in ["high_quality_edges", "sample_border"] {
            self.bool(node, ignored, false)?;
        }
        let filters: Vec<_> = self.children(node, "rfilter").collect();
        let filter = filters.first().map(|&(f, _)| self.node(f));
        self.filter(node, filter)
    }

    /// The film's reconstruction filter (Mitsuba's default: the Gaussian).
    fn filter(&mut self, film: &'a Node, filter: Option<&'a Node>) -> Result<()> {
        let (kind, radius) = match filter {
            None => (FilterKind::Gaussian, 2.0),
            Some(f) => {
                self.count(f);
                match f.plugin.as_str() {
                    "box" => (FilterKind::Box, 0.5),
                    "tent" => (FilterKind::Triangle, self.float(f, "radius", 1.0)?),
                    "gaussian" => {
                        let sigma = self.float(f, "stddev", 0.5)?;
                        if sigma != 0.5 {
                            self.warn_once(f, f.loc, "stddev", format!("a Gaussian stddev other than 0.5 is not supported yet; 0.5 is used (radius {})", 4.0 * sigma));
                        }
                        (FilterKind::Gaussian, 4.0 * sigma)
                    }
                    _ => {
                        self.unsupported(f, "the gaussian filter stands in");
                        (FilterKind::Gaussian, 2.0)
                    }
                }
            }
        };
        let at = filter.unwrap_or(film);
        self.set_option(at, "filter", Value::Text(kind.to_string()))?;
        // Mitsuba's films splat each sample into the pixels its filter reaches.
        self.set_option(at, "filter_sampling", Value::Text("splat".into()))?;
        self.set_option(at, "filter_radius", Value::Real(radius as f64))
    }

    /// A top-level emitter.
    fn emitter(&mut self, node: &'a Node) -> Result<()> {
        self.count(node);
        let to_world = self.to_world(node)?;
        let kind = match node.plugin.as_str() {
            "point" => {
                let intensity = self.colour_opt(node, "intensity")?.unwrap_or(Rgb::ONE);
                let mut t = to_world;
                if let Some(p) = self.vector_opt(node, "position")? {
                    t = Mat4::from_translation(p.as_vec3());
                }
                return self.add_light(node, LightKind::Point { intensity }, t);
            }
            "spot" => {
                let intensity = self.colour_opt(node, "intensity")?.unwrap_or(Rgb::ONE);
                let cutoff = self.float(node, "cutoff_angle", 20.0)?;
                let beam = self.float(node, "beam_width", cutoff * 0.75)?;
                if self.named_child(node, "texture").is_some() {
                    self.warn_once(
                        node,
                        node.loc,
                        "spot texture",
                        "a spot light's texture is not supported yet; ignored",
                    );
                }
                let kind = LightKind::Spot {
                    intensity,
                    falloff_angle_deg: 2.0 * cutoff,
                    falloff_exponent: 0.0,
                    falloff_start_deg: Some(2.0 * beam.min(cutoff)),
                    linear_falloff: true,
                };
                // Mitsuba's spot shines along +Z; the description's along −Z.
                let t = to_world * Mat4::from_scale(Vec3::new(1.0, 1.0, -1.0));
                return self.add_light(node, kind, t);
            }
            "directional" => {
                let irradiance = self.colour_opt(node, "irradiance")?.unwrap_or(Rgb::ONE);
                let d = match self.vector_opt(node, "direction")? {
                    Some(d) => d.as_vec3(),
                    None => to_world.transform_vector3(Vec3::Z),
                };
                let d = d.normalize_or_zero();
                if d == Vec3::ZERO {
                    return Err(self.doc.error(
                        node,
                        node.loc,
                        "directional emitter: zero direction",
                    ));
                }
                // The description's light lies along T·(0, 0, −1): opposite the travel direction.
                let t = Mat4::from_cols(Vec4::X, Vec4::Y, d.extend(0.0), Vec4::W);
                return self.add_light(node, LightKind::Directional { irradiance }, t);
            }
            "constant" => LightKind::Infinite {
                scale: self.colour_opt(node, "radiance")?.unwrap_or(Rgb::ONE),
                image: None,
            },
            "envmap" => self.envmap(node)?,
            "area" => {
                return Err(self.doc.error(
                    node,
                    node.loc,
                    "an area emitter must be inside a shape",
                ));
            }
            _ => {
                self.unsupported(node, "ignored");
                return Ok(());
            }
        };
        self.add_light(node, kind, to_world)
    }

    fn add_light(&mut self, node: &Node, kind: LightKind, transform: Mat4) -> Result<()> {
        self.desc.lights.push(LightDesc {
            name: node.id.clone().unwrap_or_else(|| node.plugin.clone()),
            kind,
            transform,
            loc: node.loc,
        });
        Ok(())
    }

    /// `envmap`: a latitude-longitude image in Mitsuba's mapping.
    fn envmap(&mut self, node: &'a Node) -> Result<LightKind> {
        let Some(file) = self.string(node, "filename")? else {
            return Err(self
                .doc
                .error(node, node.loc, "envmap needs a \"filename\""));
        };
        let path = self.doc.folder(node).join(file);
        let image = crate::io::image::Image::load(&path)
            .map_err(|e| self.doc.error(node, node.loc, format!("envmap: {e}")))?;
        if !self.desc.sources.contains(&path) {
            self.desc.sources.push(path);
        }
        let scale = self.float(node, "scale", 1.0)?;
        self.bool(node, "mis_compensation", false)?;
        Ok(LightKind::LatLong {
            scale: Rgb::splat(scale),
            image,
        })
    }
}

/// The diagonal field of view of a focal length on 35 mm film ("50mm"), in degrees.
fn focal_length_fov(s: &str) -> Option<f32> {
    let mm: f32 = s.trim().trim_end_matches("mm").trim().parse().ok()?;
    let diagonal = (36.0f32 * 36.0 + 24.0 * 24.0).sqrt();
    (mm > 0.0 && mm.is_finite()).then(|| 2.0 * (diagonal / (2.0 * mm)).atan().to_degrees())
}
