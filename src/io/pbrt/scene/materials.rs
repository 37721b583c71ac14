//! pbrt-v4's materials and textures: `Material`, `MakeNamedMaterial`, `NamedMaterial`,
//! `Texture`, with pbrt-v4's parameter names and defaults.
//!
//! - Roughness: `roughness` (or `uroughness`/`vroughness`) becomes Trowbridge-Reitz α by
//!   `α = √roughness` unless `remaproughness` is false.
//! - `conductor`: `eta`/`k` (default copper) or `reflectance` (then `eta = 1`,
//!   `k = 2√r / √(1 − r)`, as pbrt-v4).
//! - `coatedconductor`: the conductor's index is divided by the coating's.
//! - Colour textures: an `imagemap` on the `reflectance` of `diffuse`, `coateddiffuse` and
//!   `diffusetransmission` and on the latter's `transmittance` is its texture; `constant`
//!   and `scale` textures of constants are their values; anything else is a warning and the
//!   parameter's default stands in.
//! - `displacement` (any material but `mix` and `interface`): a float `imagemap` bump-maps
//!   the shading normal as pbrt-v4's `BumpMap` (see `src/scene/bump.rs`).

use super::{error_at, Interp};
use crate::error::{Error, Loc, Result};
use crate::io::desc::{
    CoatedBase, MaterialDesc, MaterialKind, MediumInterfaceDesc, SceneDesc, TextureDesc,
    TextureSlot, Wrap,
};
use crate::io::pbrt::params::{Colour, Params};
use crate::io::pbrt::{Directive, Values};
use crate::math::Rgb;
use glam::Vec3;
use std::collections::HashMap;

/// A named texture.
#[derive(Clone, Debug)]
enum TextureDef {
    /// A constant value.
    Constant(Rgb),
    /// An image, its texels multiplied by `scale`.
    Image(TextureDesc),
    /// A texture this renderer does not evaluate yet (its class).
    Unsupported(String),
}

/// Materials and textures defined so far.
pub(super) struct Materials {
    /// pbrt's default material (`diffuse`, reflectance 0.5).
    pub default_material: u32,
    /// Named materials (`None`: `interface`).
    named: HashMap<String, Option<u32>>,
    /// Named textures.
    textures: HashMap<String, TextureDef>,
    /// Emitting copies of materials, by material and radiance.
    emitting: HashMap<(u32, [u32; 3]), u32>,
    /// Cut-out copies of materials, by material and alpha texture.
    cut_outs: HashMap<(u32, String), u32>,
    /// Copies of materials (`None`: `interface`) bounding media, by material and interface.
    bounding: HashMap<(Option<u32>, MediumInterfaceDesc), u32>,
}

/// A material's image textures, waiting for the material's index.
type Pending = Vec<TextureDesc>;

impl Materials {
    /// The table, with pbrt's default material added to `desc`.
    pub fn new(desc: &mut SceneDesc) -> Materials {
        desc.materials.push(MaterialDesc {
            name: "default (pbrt diffuse)".into(),
            kind: MaterialKind::Diffuse {
                albedo: Rgb::splat(0.5),
            },
            emission: Vec3::ZERO,
            loc: Loc::default(),
            one_sided: false,
            interface: None,
        });
        Materials {
            default_material: 0,
            named: HashMap::new(),
            textures: HashMap::new(),
            emitting: HashMap::new(),
            cut_outs: HashMap::new(),
            bounding: HashMap::new(),
        }
    }

    /// The material `m` (`None`: pbrt's `interface`, a null surface) as the boundary
    /// `interface` between two media: a copy of it made once per material and interface.
    pub fn bounding(
        &mut self,
        desc: &mut SceneDesc,
        m: Option<u32>,
        interface: MediumInterfaceDesc,
        loc: Loc,
    ) -> u32 {
        if let Some(&id) = self.bounding.get(&(m, interface)) {
            return id;
        }
        let id = match m {
            Some(m) => desc.copy_material(m, "medium boundary", |c| c.interface = Some(interface)),
            None => {
                desc.materials.push(MaterialDesc {
                    name: "interface".into(),
                    kind: MaterialKind::Null,
                    emission: Vec3::ZERO,
                    loc,
                    one_sided: false,
                    interface: Some(interface),
                });
                desc.materials.len() as u32 - 1
            }
        };
        self.bounding.insert((m, interface), id);
        id
    }

    /// A colour parameter that must be a constant (lights), or `default`.
    pub fn rgb_param(&self, p: &Params, name: &str, default: Rgb) -> Result<Rgb> {
        match p.colour(name)? {
            None => Ok(default),
            Some(Colour::Rgb(c)) => Ok(c),
            Some(Colour::Texture(t)) => {
                let q = p.find(name, &["texture"])?.expect("found");
                Err(p.error(
                    q,
                    format!("parameter '{name}' cannot be a texture ('{t}') here"),
                ))
            }
        }
    }

    /// The material `m` emitting `radiance`: a copy of it with that emission, made once.
    pub fn emitting(&mut self, desc: &mut SceneDesc, m: u32, radiance: Rgb) -> u32 {
        let key = (m, radiance.to_array().map(f32::to_bits));
        if let Some(&id) = self.emitting.get(&key) {
            return id;
        }
        let id = desc.copy_material(m, "emitting", |c| c.emission = radiance);
        self.emitting.insert(key, id);
        id
    }

    /// The material `m` cut out by the alpha texture `alpha` (its red channel), made once per
    /// material and texture (`key` names the texture or constant).
    pub fn cut_out(
        &mut self,
        desc: &mut SceneDesc,
        m: u32,
        key: String,
        alpha: TextureDesc,
    ) -> u32 {
        if let Some(&id) = self.cut_outs.get(&(m, key.clone())) {
            return id;
        }
        let id = desc.copy_material(m, "cut out", |_| {});
        desc.textures.push(TextureDesc {
            material: id,
            slot: TextureSlot::Alpha {
                per_crossing: false,
                blocks_light: false,
            },
            ..alpha
        });
        self.cut_outs.insert((m, key), id);
        id
    }
}

impl Interp {
    /// `Material`, `MakeNamedMaterial`, `NamedMaterial` and `Texture`.
    pub(super) fn material_directive(&mut self, d: &Directive) -> Result<()> {
        let name = d.args.iter().find_map(|a| match a {
            crate::io::pbrt::Arg::Str(s) => Some(s.clone()),
            _ => None,
        });
        let name = name.unwrap_or_default();
        match d.name.as_str() {
            "NamedMaterial" => match self.materials.named.get(&name) {
                Some(m) => self.state.material = *m,
                None => return Err(error_at(d, format!("unknown named material '{name}'"))),
            },
            "Texture" => self.texture(d)?,
            _ => {
                let p = Params::new(d);
                let ty = if d.name == "Material" {
                    name.clone()
                } else {
                    p.string("type")?
                        .ok_or_else(|| {
                            error_at(d, format!("named material '{name}' has no \"string type\""))
                        })?
                        .to_string()
                };
                let m = self.make_material(d, &p, &ty, &name)?;
                self.report_unused(&p);
                if d.name == "Material" {
                    self.state.material = m;
                } else {
                    self.materials.named.insert(name, m);
                }
            }
        }
        Ok(())
    }

    /// A material of type `ty` added to the description (`None` for `interface`).
    fn make_material(
        &mut self,
        d: &Directive,
        p: &Params,
        ty: &str,
        name: &str,
    ) -> Result<Option<u32>> {
        let mut pending: Pending = Vec::new();
        let Some(kind) = self.material_kind(d, p, ty, &mut pending)? else {
            return Ok(None);
        };
        if ty != "mix" {
            self.displacement(d, p, &mut pending)?;
        }
        if p.find("normalmap", &["string"])?.is_some() {
            self.warn_once(
                d,
                "normalmap",
                "material \"normalmap\" is not supported yet; ignored".into(),
            );
        }
        let desc = &mut self.desc;
        desc.materials.push(MaterialDesc {
            name: if name.is_empty() {
                ty.to_string()
            } else {
                name.to_string()
            },
            kind,
            emission: Vec3::ZERO,
            loc: d.loc,
            one_sided: false,
            interface: None,
        });
        let id = desc.materials.len() as u32 - 1;
        for mut t in pending {
            t.material = id;
            desc.textures.push(t);
        }
        Ok(Some(id))
    }

    /// A material's `displacement` (a float texture, pbrt-v4's bump map) as a texture of
    /// the material in `pending`; a constant displacement moves no normal and is dropped.
    fn displacement(&mut self, d: &Directive, p: &Params, pending: &mut Pending) -> Result<()> {
        let Some(q) = p.find("displacement", &["texture", "float"])? else {
            return Ok(());
        };
        let name = match &q.values {
            Values::Strings(v) if v.len() == 1 => v[0].clone(),
            Values::Numbers(v) if v.len() == 1 => return Ok(()),
            _ => return Err(p.error(q, "parameter 'displacement' needs one value".into())),
        };
        match self.materials.textures.get(&name).cloned() {
            Some(TextureDef::Image(img)) => pending.push(TextureDesc {
                slot: TextureSlot::Displacement,
                ..img
            }),
            Some(TextureDef::Constant(_)) => {}
            Some(TextureDef::Unsupported(class)) => {
                self.warn_once(
                    d,
                    &format!("texture class {class}"),
                    format!(
                        "texture class \"{class}\" is not supported yet; 'displacement' is ignored"
                    ),
                );
            }
            None => return Err(p.error(q, format!("unknown texture '{name}'"))),
        }
        Ok(())
    }

    /// The scattering model of a material of type `ty` (`None` for `interface`); an image
    /// texture of a diffuse reflectance goes to `pending`.
    fn material_kind(
        &mut self,
        d: &Directive,
        p: &Params,
        ty: &str,
        pending: &mut Pending,
    ) -> Result<Option<MaterialKind>> {
        Ok(Some(match ty {
            "interface" | "" | "none" => return Ok(None),
            "diffuse" => MaterialKind::Diffuse {
                albedo: self.colour(d, p, "reflectance", Rgb::splat(0.5), Some(pending))?,
            },
            "conductor" => {
                let (eta, k) = self.conductor_index(d, p, "")?;
                MaterialKind::Conductor {
                    eta,
                    k,
                    alpha: self.alpha(d, p, "")?,
                    tint: Rgb::ONE,
                    distribution: crate::bsdf::microfacet::Distribution::Ggx,
                }
            }
            "dielectric" | "thindielectric" => MaterialKind::Dielectric {
                ior: self.ior(d, p, "eta")?,
                alpha: if ty == "dielectric" {
                    self.alpha(d, p, "")?
                } else {
                    [0.0; 2]
                },
                distribution: crate::bsdf::microfacet::Distribution::Ggx,
                thin: ty == "thindielectric",
            },
            "coateddiffuse" => {
                let reflectance =
                    self.colour(d, p, "reflectance", Rgb::splat(0.5), Some(pending))?;
                self.coated(d, p, "", CoatedBase::Diffuse { reflectance })?
            }
            "coatedconductor" => {
                let ior = self.ior(d, p, "interface.eta")?;
                let (eta, k) = self.conductor_index(d, p, "conductor.")?;
                let base = CoatedBase::Conductor {
                    eta: eta / ior,
                    k: k / ior,
                    alpha: self.alpha(d, p, "conductor.")?,
                };
                self.coated(d, p, "interface.", base)?
            }
            "diffusetransmission" => self.diffuse_transmission(d, p, pending)?,
            "mix" => self.mix(d, p)?,
            other => {
                self.warn_once(
                    d,
                    &format!("material {other}"),
                    format!("material \"{other}\" is not supported yet; a diffuse stand-in (reflectance 0.5) is used"),
                );
                p.ignore(&all_names(d));
                MaterialKind::Diffuse {
                    albedo: Rgb::splat(0.5),
                }
            }
        }))
    }

    /// `diffusetransmission`: its `reflectance` and `transmittance` (constants, or image
    /// textures put in `pending`) times `scale`; a texture takes the scale into its texels,
    /// as pbrt-v4 clamps `scale × texture` to [0, 1].
    fn diffuse_transmission(
        &mut self,
        d: &Directive,
        p: &Params,
        pending: &mut Pending,
    ) -> Result<MaterialKind> {
        let scale = self.float_value(d, p, "scale", 1.0)?;
        let mut reflected = Vec::new();
        let mut transmitted = Vec::new();
        let default = Rgb::splat(0.25);
        let reflectance = self.colour(d, p, "reflectance", default, Some(&mut reflected))?;
        let transmittance = self.colour(d, p, "transmittance", default, Some(&mut transmitted))?;
        let constant = |c: Rgb, textures: &Pending| if textures.is_empty() { c * scale } else { c };
        let kind = MaterialKind::DiffuseTransmission {
            reflectance: constant(reflectance, &reflected),
            transmittance: constant(transmittance, &transmitted),
        };
        let slots = [TextureSlot::BaseColor, TextureSlot::Transmittance];
        for (textures, slot) in [reflected, transmitted].into_iter().zip(slots) {
            pending.extend(textures.into_iter().map(|mut t| {
                t.texels.iter_mut().for_each(|c| *c *= scale);
                TextureDesc { slot, ..t }
            }));
        }
        Ok(kind)
    }

    /// `mix`: two named materials and the probability `amount` of the second.
    fn mix(&mut self, d: &Directive, p: &Params) -> Result<MaterialKind> {
        let names = match p.find("materials", &["string"])? {
            Some(q) => match &q.values {
                Values::Strings(v) if v.len() == 2 => v.clone(),
                _ => return Err(p.error(q, "mix \"materials\" needs two names".into())),
            },
            None => return Err(error_at(d, "mix needs \"string materials\" [ a b ]".into())),
        };
        let mut ids = [0u32; 2];
        for (id, n) in ids.iter_mut().zip(&names) {
            *id = match self.materials.named.get(n) {
                Some(Some(m)) => *m,
                Some(None) => self.materials.default_material,
                None => return Err(error_at(d, format!("mix: unknown named material '{n}'"))),
            };
        }
        Ok(MaterialKind::Mix {
            a: ids[0],
            b: ids[1],
            amount: self.float_value(d, p, "amount", 0.5)?,
        })
    }

    /// The coating's parameters (names after `prefix`) over `base`.
    fn coated(
        &mut self,
        d: &Directive,
        p: &Params,
        prefix: &str,
        base: CoatedBase,
    ) -> Result<MaterialKind> {
        let ior = if prefix.is_empty() {
            self.ior(d, p, "eta")?
        } else {
            self.ior(d, p, "interface.eta")?
        };
        let albedo = self.colour(d, p, "albedo", Rgb::ZERO, None)?;
        let g = self.float_value(d, p, "g", 0.0)?;
        if albedo.max_element() > 0.0 || g != 0.0 {
            self.warn_once(d, "coating albedo", "a scattering coating (\"albedo\", \"g\") is not supported yet; the coating only absorbs".into());
        }
        let max_depth = p.int("maxdepth", 10)?;
        let samples = p.int("nsamples", 1)?;
        if !(0..=1000).contains(&max_depth) || !(1..=1000).contains(&samples) {
            return Err(error_at(d, format!("maxdepth must be in 0..=1000 and nsamples in 1..=1000, not {max_depth} and {samples}")));
        }
        Ok(MaterialKind::Coated {
            base,
            ior,
            alpha: self.alpha(d, p, prefix)?,
            thickness: self.float_value(d, p, "thickness", 0.01)?,
            max_depth: max_depth as u32,
            samples: samples as u32,
        })
    }

    /// A conductor's `eta` and `k` (or `reflectance`), names after `prefix`.
    fn conductor_index(&mut self, d: &Directive, p: &Params, prefix: &str) -> Result<(Rgb, Rgb)> {
        let reflectance = format!("{prefix}reflectance");
        if p.find(&reflectance, &["rgb", "spectrum", "texture", "float"])?
            .is_some()
        {
            let r = self.colour(d, p, &reflectance, Rgb::ZERO, None)?;
            let r = r.clamp(Vec3::ZERO, Vec3::splat(0.9999));
            let k = 2.0 * r.map(f32::sqrt) / (Vec3::ONE - r).map(f32::sqrt);
            return Ok((Rgb::ONE, k));
        }
        let named = |n: &str| crate::io::pbrt::spectra::named_rgb(n).unwrap_or(Rgb::ONE);
        let eta = self.colour(d, p, &format!("{prefix}eta"), named("metal-Cu-eta"), None)?;
        let k = self.colour(d, p, &format!("{prefix}k"), named("metal-Cu-k"), None)?;
        Ok((eta, k))
    }

    /// A dielectric's index of refraction (`float`, or a spectrum reduced to its value at
    /// the middle of the visible range, with a warning: dispersion is not rendered).
    fn ior(&mut self, d: &Directive, p: &Params, name: &str) -> Result<f32> {
        let Some(q) = p.find(name, &["float", "spectrum", "texture"])? else {
            return Ok(1.5);
        };
        match (&q.values, q.ty.as_str()) {
            (Values::Numbers(v), "float") if v.len() == 1 => Ok(v[0] as f32),
            (Values::Strings(s), "spectrum") if s.len() == 1 => {
                match crate::io::pbrt::spectra::named_ior(&s[0]) {
                    Some(n) => {
                        self.warn_once(d, "dispersion", format!("\"{}\": dispersion is not rendered; the index at 550 nm ({n}) is used", s[0]));
                        Ok(n)
                    }
                    None => {
                        Err(p.error(q, format!("unknown named spectrum '{}' for '{name}'", s[0])))
                    }
                }
            }
            (Values::Numbers(v), "spectrum") if v.len() >= 2 && v.len() % 2 == 0 => {
                self.warn_once(
                    d,
                    "dispersion",
                    "a spectral index of refraction: dispersion is not rendered; its mean is used"
                        .into(),
                );
                let values: Vec<f64> = v.chunks(2).map(|c| c[1]).collect();
                Ok((values.iter().sum::<f64>() / values.len() as f64) as f32)
            }
            _ => {
                self.warn_once(
                    d,
                    "ior texture",
                    format!("'{name}' as a texture is not supported; 1.5 is used"),
                );
                Ok(1.5)
            }
        }
    }

    /// A colour parameter of a material: its constant value, or a texture's (an image
    /// texture goes to `slot`, where the material can take one, and 1 is returned), or
    /// `default`.
    fn colour(
        &mut self,
        d: &Directive,
        p: &Params,
        name: &str,
        default: Rgb,
        slot: Option<&mut Pending>,
    ) -> Result<Rgb> {
        match p.colour(name)? {
            None => Ok(default),
            Some(Colour::Rgb(c)) => Ok(c),
            Some(Colour::Texture(t)) => match self.materials.textures.get(&t).cloned() {
                Some(TextureDef::Constant(c)) => Ok(c),
                Some(TextureDef::Image(img)) if slot.is_some() => {
                    if let Some(s) = slot {
                        s.push(img);
                    }
                    Ok(Rgb::ONE)
                }
                Some(TextureDef::Image(img)) => {
                    self.warn_once(d, &format!("texture use {name}"), format!("an image texture for '{name}' is not supported yet; its mean colour is used"));
                    let n = img.texels.len().max(1) as f32;
                    Ok(img.texels.iter().copied().sum::<Rgb>() / n)
                }
                Some(TextureDef::Unsupported(class)) => {
                    self.warn_once(d, &format!("texture class {class}"), format!("texture class \"{class}\" is not supported yet; '{name}' takes its default"));
                    Ok(default)
                }
                None => {
                    let q = p.find(name, &["texture"])?.expect("found");
                    Err(p.error(q, format!("unknown texture '{t}'")))
                }
            },
        }
    }

    /// A shape's `alpha` (a number or a texture) as a cut-out of `material`: the material
    /// itself when opaque, else a cut-out copy.
    pub(super) fn with_alpha(&mut self, d: &Directive, p: &Params, material: u32) -> Result<u32> {
        let Some(q) = p.find("alpha", &["float", "texture"])? else {
            return Ok(material);
        };
        let (key, alpha) = match &q.values {
            Values::Numbers(v) if v.len() == 1 => (format!("{}", v[0]), Rgb::splat(v[0] as f32)),
            Values::Strings(v) if v.len() == 1 => match self.materials.textures.get(&v[0]).cloned()
            {
                Some(TextureDef::Constant(c)) => (v[0].clone(), c),
                Some(TextureDef::Image(img)) => {
                    let id = self
                        .materials
                        .cut_out(&mut self.desc, material, v[0].clone(), img);
                    return Ok(id);
                }
                Some(TextureDef::Unsupported(class)) => {
                    self.warn_once(d, "alpha class", format!("alpha texture class \"{class}\" is not supported yet; the shape is opaque"));
                    return Ok(material);
                }
                None => return Err(p.error(q, format!("unknown texture '{}'", v[0]))),
            },
            _ => return Err(p.error(q, "parameter 'alpha' needs one value".into())),
        };
        if alpha.x >= 1.0 {
            return Ok(material);
        }
        let constant = TextureDesc {
            name: format!("alpha {key}"),
            material,
            slot: TextureSlot::Alpha {
                per_crossing: false,
                blocks_light: false,
            },
            width: 1,
            height: 1,
            texels: vec![alpha],
            wrap: [Wrap::Repeat; 2],
            nearest: false,
            uv_transform: None,
        };
        Ok(self
            .materials
            .cut_out(&mut self.desc, material, key, constant))
    }

    /// The Trowbridge-Reitz α along u and v of the roughness parameters after `prefix`.
    fn alpha(&mut self, d: &Directive, p: &Params, prefix: &str) -> Result<[f32; 2]> {
        let r = self.float_value(d, p, &format!("{prefix}roughness"), 0.0)?;
        let u = self.float_value(d, p, &format!("{prefix}uroughness"), r)?;
        let v = self.float_value(d, p, &format!("{prefix}vroughness"), r)?;
        let remap = p.bool("remaproughness", true)?;
        Ok([to_alpha(u, remap), to_alpha(v, remap)])
    }

    /// A float parameter of a material: a number, or a texture's constant value (other
    /// textures: a warning and the mean of an image, or `default`).
    fn float_value(&mut self, d: &Directive, p: &Params, name: &str, default: f32) -> Result<f32> {
        let Some(q) = p.find(name, &["float", "texture"])? else {
            return Ok(default);
        };
        if q.ty == "float" {
            return p.float(name, default);
        }
        let Values::Strings(v) = &q.values else {
            return Err(p.error(q, format!("parameter '{name}' needs one texture name")));
        };
        let t = v.first().cloned().unwrap_or_default();
        match self.materials.textures.get(&t).cloned() {
            Some(TextureDef::Constant(c)) => Ok(c.x),
            Some(TextureDef::Image(img)) => {
                self.warn_once(
                    d,
                    &format!("float texture {name}"),
                    format!("an image texture for '{name}' is not supported yet; its mean is used"),
                );
                let n = img.texels.len().max(1) as f32;
                Ok(img.texels.iter().map(|t| t.x).sum::<f32>() / n)
            }
            Some(TextureDef::Unsupported(class)) => {
                self.warn_once(d, &format!("texture class {class}"), format!("texture class \"{class}\" is not supported yet; '{name}' takes its default"));
                Ok(default)
            }
            None => Err(p.error(q, format!("unknown texture '{t}'"))),
        }
    }

    /// `Texture "name" "spectrum"|"float" "class" ...`.
    fn texture(&mut self, d: &Directive) -> Result<()> {
        let args: Vec<&str> = d
            .args
            .iter()
            .filter_map(|a| match a {
                crate::io::pbrt::Arg::Str(s) => Some(s.as_str()),
                _ => None,
            })
            .collect();
        let [name, ty, class] = args[..] else {
            return Err(error_at(
                d,
                "Texture needs a name, a type and a class".into(),
            ));
        };
        if !matches!(ty, "spectrum" | "float" | "color" | "rgb") {
            return Err(error_at(
                d,
                format!("texture type must be \"spectrum\" or \"float\", not \"{ty}\""),
            ));
        }
        let p = Params::new(d);
        let def = match class {
            "constant" => TextureDef::Constant(self.materials.rgb_param(&p, "value", Rgb::ONE)?),
            "scale" => {
                let a = self.texture_value(d, &p, "tex")?;
                let b = self.texture_value(d, &p, "scale")?;
                match (a, b) {
                    (Some(a), Some(b)) => TextureDef::Constant(a * b),
                    _ => TextureDef::Unsupported("scale of a non-constant texture".into()),
                }
            }
            "imagemap" => self.image_texture(d, &p, name, ty == "float")?,
            "checkerboard" => self.checkerboard(d, &p, name)?,
            other => {
                p.ignore(&all_names(d));
                TextureDef::Unsupported(other.to_string())
            }
        };
        self.report_unused(&p);
        self.materials.textures.insert(name.to_string(), def);
        Ok(())
    }

    /// A 2D `checkerboard` of two constants as an image: `tex1` where
    /// `⌊u·uscale + udelta⌋ + ⌊v·vscale + vdelta⌋` is even, `tex2` elsewhere, 8 texels per
    /// check (whole numbers of checks per unit only; others are not supported yet).
    fn checkerboard(&mut self, d: &Directive, p: &Params, name: &str) -> Result<TextureDef> {
        let (a, b) = (
            self.texture_value(d, p, "tex1")?,
            self.texture_value(d, p, "tex2")?,
        );
        let b = if p
            .find(
                "tex2",
                &["rgb", "spectrum", "float", "texture", "blackbody"],
            )?
            .is_none()
        {
            Some(Rgb::ZERO)
        } else {
            b
        };
        let (us, vs) = (p.float("uscale", 1.0)?, p.float("vscale", 1.0)?);
        let (ud, vd) = (p.float("udelta", 0.0)?, p.float("vdelta", 0.0)?);
        let whole = |x: f32| (1.0..=64.0).contains(&x) && x.fract() == 0.0;
        let (Some(a), Some(b)) = (a, b) else {
            return Ok(TextureDef::Unsupported("checkerboard of textures".into()));
        };
        if p.int("dimension", 2)? != 2 || !whole(us) || !whole(vs) {
            p.ignore(&["dimension"]);
            return Ok(TextureDef::Unsupported(
                "checkerboard (3D, or fractional scales)".into(),
            ));
        }
        let (w, h) = (us as u32 * 8, vs as u32 * 8);
        let texels = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| {
                let u = (x as f32 + 0.5) / w as f32;
                let v = 1.0 - (y as f32 + 0.5) / h as f32;
                let parity = ((u * us + ud).floor() + (v * vs + vd).floor()) as i64;
                if parity.rem_euclid(2) == 0 {
                    a
                } else {
                    b
                }
            })
            .collect();
        Ok(TextureDef::Image(TextureDesc {
            name: name.to_string(),
            material: 0,
            slot: TextureSlot::BaseColor,
            width: w,
            height: h,
            texels,
            wrap: [Wrap::Repeat; 2],
            nearest: false,
            uv_transform: None,
        }))
    }

    /// A constant texture parameter's value (`None` where it is a non-constant texture).
    fn texture_value(&mut self, _d: &Directive, p: &Params, name: &str) -> Result<Option<Rgb>> {
        Ok(match p.colour(name)? {
            None => Some(Rgb::ONE),
            Some(Colour::Rgb(c)) => Some(c),
            Some(Colour::Texture(t)) => match self.materials.textures.get(&t) {
                Some(TextureDef::Constant(c)) => Some(*c),
                _ => None,
            },
        })
    }

    /// An `imagemap` texture: its image read (relative to the file's folder), multiplied by
    /// `scale`, inverted if asked.
    fn image_texture(
        &mut self,
        d: &Directive,
        p: &Params,
        name: &str,
        float: bool,
    ) -> Result<TextureDef> {
        let file = p
            .string("filename")?
            .ok_or_else(|| error_at(d, format!("imagemap texture '{name}' has no \"filename\"")))?;
        let path = Interp::folder(d).join(file);
        let encoding = p.string("encoding")?.unwrap_or("sRGB");
        let scale = p.float("scale", 1.0)?;
        let invert = p.bool("invert", false)?;
        let wrap = match p.string("wrap")?.unwrap_or("repeat") {
            "clamp" => Wrap::Clamp,
            "repeat" => Wrap::Repeat,
            other => {
                self.warn_once(
                    d,
                    "wrap",
                    format!("texture wrap \"{other}\" is not supported; \"repeat\" is used"),
                );
                Wrap::Repeat
            }
        };
        for mapping in ["uscale", "vscale", "udelta", "vdelta"] {
            if p.float_opt(mapping)?
                .is_some_and(|v| v != if mapping.ends_with("scale") { 1.0 } else { 0.0 })
            {
                self.warn_once(d, "uv mapping", "texture \"uscale\"/\"vscale\"/\"udelta\"/\"vdelta\" are not supported yet; ignored".into());
            }
        }
        p.ignore(&["filter", "maxanisotropy", "mapping"]);
        let (width, height, mut texels) = crate::io::pbrt::images::read(&path, encoding, float)
            .map_err(|msg| Error::At {
                file: d.file.display().to_string(),
                loc: d.loc,
                msg,
            })?;
        for t in &mut texels {
            *t *= scale;
            if invert {
                *t = (Rgb::ONE - *t).max(Rgb::ZERO);
            }
        }
        if !self.desc.sources.contains(&path) {
            self.desc.sources.push(path);
        }
        Ok(TextureDef::Image(TextureDesc {
            name: name.to_string(),
            material: 0,
            slot: TextureSlot::BaseColor,
            width,
            height,
            texels,
            wrap: [wrap; 2],
            nearest: false,
            uv_transform: None,
        }))
    }
}

/// The names of all of `d`'s parameters.
fn all_names(d: &Directive) -> Vec<&str> {
    d.params.iter().map(|p| p.name.as_str()).collect()
}

/// `α` of a roughness under pbrt-v4's remapping (`remap`) or as given.
fn to_alpha(x: f32, remap: bool) -> f32 {
    if remap {
        crate::bsdf::tr::roughness_to_alpha(x)
    } else {
        x.max(0.0)
    }
}
