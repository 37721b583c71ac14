//! BSDF plugins as description materials, with Mitsuba's definitions and defaults:
//! `diffuse`, `twosided`, `conductor`/`roughconductor` (named `material`s from Mitsuba's
//! table, or `eta`/`k`; `specular_reflectance`; Beckmann or GGX, isotropic or not),
//! `dielectric`/`roughdielectric`/`thindielectric` (indices as numbers or names),
//! `plastic`/`roughplastic` ([`crate::bsdf::plastic`]), `principled`
//! ([`crate::bsdf::principled`]), `blendbsdf` (a mix), `mask` (an alpha cut-out),
//! `normalmap`, `bumpmap`, `null` (a cut-out that lets everything through), and Mitsuba's
//! default diffuse with a warning for anything else.
//!
//! A BSDF that is not inside `twosided` (other than the dielectrics and a transmitting
//! `principled`) scatters only on the front side, as in Mitsuba: its material is one-sided.

use super::xml::{Node, Value};
use super::Interp;
use crate::bsdf::microfacet::Distribution;
use crate::bsdf::principled::Principled;
use crate::bsdf::Param;
use crate::error::Result;
use crate::io::desc::{MaterialDesc, MaterialKind, TextureDesc, TextureSlot};
use crate::math::Rgb;

/// Mitsuba 3's conductor `material` names and their `(eta, k)` in its RGB variants (read
/// from Mitsuba 3.9.1: `mi.traverse(mi.load_dict({"type": "conductor", "material": NAME}))`
/// under `scalar_rgb`).
const METALS: &[(&str, [f32; 3], [f32; 3])] = &[
    (
        "a-C",
        [2.94405, 2.22714, 1.96816],
        [0.887465, 0.799299, 0.81529],
    ),
    (
        "Ag",
        [0.155276, 0.116728, 0.138388],
        [4.82835, 3.12222, 2.1469],
    ),
    ("Al", [1.6575, 0.880405, 0.521244], [9.22381, 6.2695, 4.837]),
    (
        "AlAs",
        [3.6053, 3.23294, 2.21632],
        [0.000679437, 0.0, 0.00751271],
    ),
    ("AlSb", [0.0, 4.13937, 4.66925], [0.0, 0.0940091, 1.30057]),
    (
        "Au",
        [0.143036, 0.375307, 1.44205],
        [3.983, 2.38556, 1.60336],
    ),
    (
        "Be",
        [4.18501, 3.18503, 2.78406],
        [3.83547, 3.01012, 2.86899],
    ),
    ("Cr", [4.36967, 2.91651, 1.6549], [5.20655, 4.23131, 3.7547]),
    ("CsI", [2.1449, 1.70232, 1.66243], [0.0, 0.0, 0.0]),
    (
        "Cu",
        [0.201005, 0.92375, 1.10222],
        [3.91326, 2.45305, 2.14209],
    ),
    (
        "Cu2O",
        [3.55177, 2.94987, 2.75188],
        [0.114207, 0.193897, 0.606134],
    ),
    (
        "CuO",
        [3.24754, 2.44781, 2.21022],
        [0.52109, 0.570031, 0.722179],
    ),
    ("d-C", [2.70872, 2.31883, 2.2289], [0.0, 0.0, 0.0]),
    (
        "Hg",
        [2.39894, 1.44003, 0.90957],
        [6.32759, 4.37192, 3.42176],
    ),
    (
        "HgTe",
        [4.77904, 3.2312, 2.6599],
        [1.63161, 1.58081, 1.72929],
    ),
    (
        "Ir",
        [3.0863, 2.08219, 1.61791],
        [5.59215, 4.06709, 3.26731],
    ),
    (
        "K",
        [0.0640432, 0.0464098, 0.0381849],
        [2.1042, 1.34894, 0.913126],
    ),
    (
        "Li",
        [0.265791, 0.195618, 0.220949],
        [3.54015, 2.31112, 1.66861],
    ),
    (
        "MgO",
        [2.08958, 1.65072, 1.59488],
        [4.3327e-12, 0.0, 2.49865e-11],
    ),
    (
        "Mo",
        [4.48397, 3.52513, 2.77631],
        [4.11144, 3.42083, 3.15061],
    ),
    (
        "Na_palik",
        [0.0602694, 0.0561409, 0.0619884],
        [3.17927, 2.11249, 1.57904],
    ),
    (
        "Nb",
        [3.42007, 2.79009, 2.39563],
        [3.44139, 2.73767, 2.57975],
    ),
    (
        "Ni_palik",
        [2.3673, 1.66337, 1.46708],
        [4.49881, 3.05015, 2.34544],
    ),
    (
        "Rh",
        [2.58579, 1.86022, 1.55426],
        [6.78226, 4.70299, 3.97607],
    ),
    (
        "Se",
        [4.05831, 2.84294, 2.82085],
        [0.75405, 0.638444, 0.521808],
    ),
    (
        "SiC",
        [3.17234, 2.52597, 2.47937],
        [7.53766e-07, 0.0, 1.01925e-05],
    ),
    ("SnTe", [4.52425, 1.98164, 1.28159], [0.0, 0.0, 0.0]),
    (
        "Ta",
        [2.06272, 2.39294, 2.62793],
        [2.40836, 1.74149, 1.94703],
    ),
    (
        "Te",
        [7.39023, 4.4821, 2.63711],
        [3.25602, 3.52706, 3.29205],
    ),
    ("ThF4", [1.83071, 1.44223, 1.38765], [0.0, 0.0, 0.0]),
    (
        "TiC",
        [3.70053, 2.83742, 2.58229],
        [3.26564, 2.35159, 2.17279],
    ),
    (
        "TiN",
        [1.64845, 1.15052, 1.37982],
        [3.36833, 1.9435, 1.10207],
    ),
    (
        "TiO2",
        [3.45661, 2.80174, 2.90517],
        [0.000105265, 0.0, 0.000652887],
    ),
    (
        "VC",
        [3.65757, 2.75274, 2.53267],
        [3.0683, 2.19869, 1.96319],
    ),
    (
        "V_palik",
        [4.27758, 3.51295, 2.76107],
        [3.4913, 2.88945, 3.11152],
    ),
    (
        "VN",
        [2.8656, 2.11919, 1.94009],
        [3.03224, 2.05612, 1.61631],
    ),
    (
        "W",
        [4.37082, 3.30025, 2.99841],
        [3.50064, 2.60487, 2.27323],
    ),
];

/// Mitsuba 3's named indices of refraction.
const IORS: &[(&str, f32)] = &[
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

/// A material being made: its scattering model and textures (material index unset).
type Made = (MaterialKind, Vec<TextureDesc>);

impl<'a> Interp<'a> {
    /// The material of a shape: its BSDF object (`None`: Mitsuba's default, a diffuse of
    /// reflectance ½) emitting `emission`; made once per pair.
    pub(super) fn material(&mut self, bsdf: Option<usize>, emission: Rgb) -> Result<u32> {
        let one_sided = self.two_sided_depth == 0 && bsdf.is_none_or(|b| self.one_sided(b, 0));
        let key = (
            bsdf.unwrap_or(usize::MAX),
            emission.to_array().map(f32::to_bits),
            one_sided,
        );
        if let Some(&m) = self.materials.get(&key) {
            return Ok(m);
        }
        let (made, name, loc) = match bsdf {
            Some(b) => {
                let node = self.node(b);
                let made = self.bsdf(b)?;
                (
                    made,
                    node.id.clone().unwrap_or_else(|| node.plugin.clone()),
                    node.loc,
                )
            }
            None => (
                (
                    MaterialKind::Diffuse {
                        albedo: Rgb::splat(0.5),
                    },
                    Vec::new(),
                ),
                "default".into(),
                Default::default(),
            ),
        };
        let m = self.push_material(name, made, emission, one_sided, loc);
        self.materials.insert(key, m);
        Ok(m)
    }

    /// Whether BSDF object `b` scatters on its front side only in Mitsuba: everything but
    /// `twosided`, the dielectrics and `null`; wrappers as what they wrap.
    fn one_sided(&self, b: usize, depth: usize) -> bool {
        let node = self.node(b);
        let nested = || self.children(node, "bsdf").map(|c| c.0).collect::<Vec<_>>();
        match node.plugin.as_str() {
            "twosided" | "dielectric" | "roughdielectric" | "thindielectric" | "null" => false,
            // Mitsuba's principled scatters from inside too when it transmits.
            "principled" => !self.principled_transmits(node),
            "mask" | "normalmap" | "bumpmap" | "blendbsdf" if depth < super::MAX_BSDF_DEPTH => {
                nested().iter().any(|&c| self.one_sided(c, depth + 1))
            }
            _ => true,
        }
    }

    /// Mitsuba's `get_flag("spec_trans")` of a `principled`: the property is given, as a
    /// texture or a number other than 0.
    fn principled_transmits(&self, node: &Node) -> bool {
        self.named_child(node, "spec_trans").is_some()
            || node.props.iter().any(|p| {
                p.name == "spec_trans"
                    && !matches!(p.value, Value::Float(v) if v == 0.0)
                    && !matches!(p.value, Value::Integer(0))
            })
    }

    fn push_material(
        &mut self,
        name: String,
        made: Made,
        emission: Rgb,
        one_sided: bool,
        loc: crate::error::Loc,
    ) -> u32 {
        let (kind, textures) = made;
        let id = self.desc.materials.len() as u32;
        self.desc.materials.push(MaterialDesc {
            name,
            kind,
            emission,
            one_sided,
            interface: None,
            loc,
        });
        self.desc.textures.extend(
            textures
                .into_iter()
                .map(|t| TextureDesc { material: id, ..t }),
        );
        id
    }

    /// The model of BSDF object `b` and its textures.
    fn bsdf(&mut self, b: usize) -> Result<Made> {
        let node = self.node(b);
        if node.tag != "bsdf" {
            return Err(self.doc.error(
                node,
                node.loc,
                format!("expected a <bsdf>, found <{}>", node.tag),
            ));
        }
        self.depth += 1;
        if self.depth > super::MAX_BSDF_DEPTH {
            return Err(self.doc.error(
                node,
                node.loc,
                "BSDFs nested too deeply (or referring to each other in a cycle)",
            ));
        }
        self.count(node);
        let made = self.bsdf_plugin(node);
        self.depth -= 1;
        made
    }

    fn bsdf_plugin(&mut self, node: &'a Node) -> Result<Made> {
        let base = TextureSlot::BaseColor;
        Ok(match node.plugin.as_str() {
            "diffuse" => {
                let (albedo, tex) =
                    self.colour_or_texture(node, "reflectance", Rgb::splat(0.5), base)?;
                (MaterialKind::Diffuse { albedo }, tex.into_iter().collect())
            }
            "twosided" => {
                self.two_sided_depth += 1;
                let made = self.twosided(node);
                self.two_sided_depth -= 1;
                made?
            }
            "conductor" | "roughconductor" => self.conductor(node)?,
            "dielectric" | "roughdielectric" | "thindielectric" => self.dielectric(node)?,
            "plastic" | "roughplastic" => self.plastic(node)?,
            "blendbsdf" => self.blend(node)?,
            "mask" => self.mask(node)?,
            "normalmap" => self.normal_map(node)?,
            "bumpmap" => self.bump_map(node)?,
            "null" => {
                let none = MaterialKind::Diffuse { albedo: Rgb::ZERO };
                (
                    none,
                    vec![constant_texture(
                        "null",
                        0.0,
                        TextureSlot::Alpha {
                            per_crossing: true,
                            blocks_light: true,
                        },
                    )],
                )
            }
            "principled" => self.principled(node)?,
            _ => {
                self.unsupported(
                    node,
                    "Mitsuba's default diffuse (reflectance 0.5) stands in",
                );
                (
                    MaterialKind::Diffuse {
                        albedo: Rgb::splat(0.5),
                    },
                    Vec::new(),
                )
            }
        })
    }

    /// `twosided`: its nested BSDF on both sides, or its first on the front and its second
    /// behind.
    fn twosided(&mut self, node: &'a Node) -> Result<Made> {
        let inner: Vec<usize> = self.children(node, "bsdf").map(|c| c.0).collect();
        match inner[..] {
            [one] => self.bsdf(one),
            [front, back] => {
                let front = self.material(Some(front), Rgb::ZERO)?;
                let back = self.material(Some(back), Rgb::ZERO)?;
                Ok((MaterialKind::Sided { front, back }, Vec::new()))
            }
            _ => Err(self
                .doc
                .error(node, node.loc, "twosided needs one or two nested BSDFs")),
        }
    }

    /// The one nested BSDF of a wrapper (`bumpmap`, `mask`, `normalmap`).
    fn only_nested(&mut self, node: &'a Node) -> Result<Made> {
        let inner: Vec<usize> = self.children(node, "bsdf").map(|c| c.0).collect();
        match inner[..] {
            [one] => self.bsdf(one),
            _ => Err(self.doc.error(
                node,
                node.loc,
                format!("{} needs exactly one nested <bsdf>", node.plugin),
            )),
        }
    }

    /// An index of refraction: a number or one of Mitsuba's names.
    fn ior(&self, node: &'a Node, name: &str, default: &str) -> Result<f32> {
        let named = node
            .props
            .iter()
            .any(|p| p.name == name && matches!(p.value, super::xml::Value::Str(_)));
        if !named {
            if let Some(v) = self.float_opt(node, name)? {
                return Ok(v);
            }
        }
        let s = self
            .string(node, name)?
            .unwrap_or(default)
            .to_ascii_lowercase();
        IORS.iter()
            .find(|(n, _)| *n == s)
            .map(|&(_, v)| v)
            .ok_or_else(|| {
                self.doc.error(
                    node,
                    node.loc,
                    format!(
                        "unknown index of refraction \"{s}\" (use a number or one of: {})",
                        IORS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
                    ),
                )
            })
    }

    /// `distribution` and `alpha` (or `alpha_u`/`alpha_v`) of a rough plugin.
    /// A rough plugin's distribution and α along u and v, with the textures that set them
    /// (the α of a textured one is its mean).
    fn roughness(&mut self, node: &'a Node) -> Result<(Distribution, [f32; 2], Vec<TextureDesc>)> {
        let dist = match self
            .string(node, "distribution")?
            .unwrap_or("beckmann")
            .to_ascii_lowercase()
            .as_str()
        {
            "beckmann" => Distribution::Beckmann,
            "ggx" => Distribution::Ggx,
            other => {
                return Err(self.doc.error(
                    node,
                    node.loc,
                    format!("distribution \"{other}\": must be beckmann or ggx"),
                ))
            }
        };
        self.bool(node, "sample_visible", true)?;
        let has =
            |n: &str| node.props.iter().any(|p| p.name == n) || self.named_child(node, n).is_some();
        let (alpha, texture) = if has("alpha_u") || has("alpha_v") {
            if has("alpha") {
                return Err(self
                    .doc
                    .error(node, node.loc, "give either alpha or alpha_u/alpha_v"));
            }
            let (u, u_texture) = self.number_or_texture(node, "alpha_u", 0.1, Param::AlphaU)?;
            let (v, v_texture) = self.number_or_texture(node, "alpha_v", 0.1, Param::AlphaV)?;
            ([u, v], u_texture.into_iter().chain(v_texture).collect())
        } else {
            let (alpha, texture) = self.number_or_texture(node, "alpha", 0.1, Param::Alpha)?;
            ([alpha; 2], texture.into_iter().collect())
        };
        let alpha = alpha.map(|a| if a.is_finite() { a.max(1e-4) } else { 0.1 });
        Ok((dist, alpha, texture))
    }

    fn conductor(&mut self, node: &'a Node) -> Result<Made> {
        let name = self.string(node, "material")?;
        let (mut eta, mut k) = match name {
            None | Some("none") => (Rgb::ZERO, Rgb::ONE),
            Some(n) => {
                let Some(&(_, e, k)) = METALS.iter().find(|m| m.0 == n) else {
                    return Err(self.doc.error(
                        node,
                        node.loc,
                        format!("unknown conductor material \"{n}\""),
                    ));
                };
                (Rgb::from_array(e), Rgb::from_array(k))
            }
        };
        if let Some(e) = self.colour_opt(node, "eta")? {
            eta = e;
        }
        if let Some(v) = self.colour_opt(node, "k")? {
            k = v;
        }
        let ext = self.ior(node, "ext_ior", "air")?;
        let (tint, tint_texture) = self.colour_or_texture(
            node,
            "specular_reflectance",
            Rgb::ONE,
            TextureSlot::BaseColor,
        )?;
        let (distribution, alpha, mut textures) = if node.plugin == "roughconductor" {
            self.roughness(node)?
        } else {
            (Distribution::Ggx, [0.0; 2], Vec::new())
        };
        let kind = MaterialKind::Conductor {
            eta: eta / ext,
            k: k / ext,
            alpha,
            tint,
            distribution,
        };
        textures.extend(tint_texture);
        Ok((kind, textures))
    }

    /// A specular tint (1 unless given; a texture's mean with a warning).
    fn tint(&mut self, node: &'a Node, name: &str) -> Result<Rgb> {
        let (c, tex) = self.colour_or_texture(node, name, Rgb::ONE, TextureSlot::BaseColor)?;
        Ok(match tex {
            Some(t) => {
                self.warn_once(
                    node,
                    node.loc,
                    &format!("{name} texture"),
                    format!("a texture for \"{name}\" is not supported yet; its mean stands in"),
                );
                t.texels.iter().copied().sum::<Rgb>() / t.texels.len().max(1) as f32
            }
            None => c,
        })
    }

    fn dielectric(&mut self, node: &'a Node) -> Result<Made> {
        let ior = self.ior(node, "int_ior", "bk7")? / self.ior(node, "ext_ior", "air")?;
        for name in ["specular_reflectance", "specular_transmittance"] {
            if self.tint(node, name)? != Rgb::ONE {
                self.warn_once(
                    node,
                    node.loc,
                    name,
                    format!("\"{name}\" other than 1 is not supported yet; 1 is used"),
                );
            }
        }
        let (distribution, alpha, textures) = if node.plugin == "roughdielectric" {
            self.roughness(node)?
        } else {
            (Distribution::Ggx, [0.0; 2], Vec::new())
        };
        let kind = MaterialKind::Dielectric {
            ior,
            alpha,
            distribution,
            thin: node.plugin == "thindielectric",
        };
        Ok((kind, textures))
    }

    fn plastic(&mut self, node: &'a Node) -> Result<Made> {
        let ior = self.ior(node, "int_ior", "polypropylene")? / self.ior(node, "ext_ior", "air")?;
        let (diffuse, tex) = self.colour_or_texture(
            node,
            "diffuse_reflectance",
            Rgb::splat(0.5),
            TextureSlot::BaseColor,
        )?;
        let specular = self.tint(node, "specular_reflectance")?;
        let nonlinear = self.bool(node, "nonlinear", false)?;
        let (distribution, alpha) = if node.plugin == "roughplastic" {
            let (d, a, textures) = self.roughness(node)?;
            if !textures.is_empty() {
                self.warn_once(
                    node,
                    node.loc,
                    "texture alpha",
                    format!(
                        "a texture for a roughplastic's \"alpha\" is not supported yet; its mean {} stands in",
                        a[0]
                    ),
                );
            }
            if a[0] != a[1] {
                return Err(self.doc.error(
                    node,
                    node.loc,
                    "roughplastic does not support anisotropic roughness (as in Mitsuba)",
                ));
            }
            (d, a[0])
        } else {
            (Distribution::Beckmann, 0.0)
        };
        Ok((
            MaterialKind::Plastic {
                diffuse,
                specular,
                ior,
                alpha,
                distribution,
                nonlinear,
            },
            tex.into_iter().collect(),
        ))
    }

    /// `blendbsdf`: the second nested BSDF with probability `weight`, else the first.
    fn blend(&mut self, node: &'a Node) -> Result<Made> {
        let inner: Vec<usize> = self.children(node, "bsdf").map(|c| c.0).collect();
        let [first, second] = inner[..] else {
            return Err(self
                .doc
                .error(node, node.loc, "blendbsdf needs exactly two nested BSDFs"));
        };
        let (amount, texture) = self.number_or_texture(node, "weight", 0.5, Param::Weight)?;
        let (a, b) = (
            self.material(Some(first), Rgb::ZERO)?,
            self.material(Some(second), Rgb::ZERO)?,
        );
        Ok((
            MaterialKind::Mix { a, b, amount },
            texture.into_iter().collect(),
        ))
    }

    /// `mask`: the nested BSDF cut out by `opacity` (a number or a texture's red channel).
    fn mask(&mut self, node: &'a Node) -> Result<Made> {
        let alpha = match self.named_child(node, "opacity") {
            Some(t) => self.texture(
                self.node(t),
                TextureSlot::Alpha {
                    per_crossing: true,
                    blocks_light: true,
                },
            )?,
            None => Some(constant_texture(
                "opacity",
                self.float(node, "opacity", 0.5)?,
                TextureSlot::Alpha {
                    per_crossing: true,
                    blocks_light: true,
                },
            )),
        };
        let (kind, mut textures) = self.only_nested(node)?;
        textures.extend(alpha);
        Ok((kind, textures))
    }

    /// `normalmap`: the nested BSDF with a tangent-space normal map (`normalmap`, raw).
    fn normal_map(&mut self, node: &'a Node) -> Result<Made> {
        let Some(t) = self.named_child(node, "normalmap") else {
            return Err(self
                .doc
                .error(node, node.loc, "normalmap needs a \"normalmap\" texture"));
        };
        let map = self.texture(
            self.node(t),
            TextureSlot::Normal {
                scale: 1.0,
                mitsuba: true,
            },
        )?;
        let (kind, mut textures) = self.only_nested(node)?;
        textures.extend(map);
        Ok((kind, textures))
    }

    /// `bumpmap`: the nested BSDF with its shading normal bent by a height texture
    /// (`scale` × its gradient).
    fn bump_map(&mut self, node: &'a Node) -> Result<Made> {
        let scale = self.float(node, "scale", 1.0)?;
        let textures: Vec<usize> = self.children(node, "texture").map(|c| c.0).collect();
        let [t] = textures[..] else {
            return Err(self
                .doc
                .error(node, node.loc, "bumpmap needs one nested texture"));
        };
        let map = self.texture(self.node(t), TextureSlot::Bump { scale })?;
        let (kind, mut textures) = self.only_nested(node)?;
        textures.extend(map);
        Ok((kind, textures))
    }

    /// `principled` with Mitsuba's definition ([`crate::bsdf::principled`]); any colour or
    /// number may be a texture, and `eta` or `specular` (not both) gives the index.
    fn principled(&mut self, node: &'a Node) -> Result<Made> {
        let (base, tex) =
            self.colour_or_texture(node, "base_color", Rgb::splat(0.5), TextureSlot::BaseColor)?;
        let mut textures: Vec<TextureDesc> = tex.into_iter().collect();
        let mut p = Principled {
            base,
            ..Default::default()
        };
        for (name, param) in [
            ("roughness", Param::Roughness),
            ("anisotropic", Param::Anisotropic),
            ("metallic", Param::Metallic),
            ("spec_trans", Param::SpecTrans),
            ("spec_tint", Param::SpecTint),
            ("sheen", Param::Sheen),
            ("sheen_tint", Param::SheenTint),
            ("flatness", Param::Flatness),
            ("clearcoat", Param::Clearcoat),
            ("clearcoat_gloss", Param::ClearcoatGloss),
        ] {
            let default = match param {
                Param::Roughness => Principled::default().roughness,
                _ => 0.0,
            };
            let (value, texture) = self.number_or_texture(node, name, default, param)?;
            p = p.with(param, value);
            textures.extend(texture);
        }
        // Only the noise depends on Mitsuba's sampling rates: this renderer's are its own.
        for rate in [
            "main_specular_sampling_rate",
            "clearcoat_sampling_rate",
            "diffuse_reflectance_sampling_rate",
        ] {
            self.float(node, rate, 1.0)?;
        }
        let transmits = self.principled_transmits(node);
        p.eta = match (
            self.float_opt(node, "eta")?,
            self.float_opt(node, "specular")?,
        ) {
            (Some(_), Some(_)) => {
                return Err(self.doc.error(
                    node,
                    node.loc,
                    "bsdf \"principled\" takes \"eta\" or \"specular\", not both",
                ))
            }
            (Some(eta), None) if transmits && eta == 1.0 => 1.001,
            (Some(eta), None) => eta,
            (None, specular) => {
                let specular = match specular.unwrap_or(0.5) {
                    s if transmits && s == 0.0 => 1e-3,
                    s => s,
                };
                2.0 / (1.0 - (0.08 * specular).max(0.0).sqrt()) - 1.0
            }
        };
        Ok((MaterialKind::Principled(p), textures))
    }
}

/// A one-texel texture of value `v` (alpha cut-outs).
fn constant_texture(name: &str, v: f32, slot: TextureSlot) -> TextureDesc {
    TextureDesc {
        name: name.into(),
        material: 0,
        slot,
        width: 1,
        height: 1,
        texels: vec![Rgb::splat(v)],
        wrap: Default::default(),
        nearest: false,
        uv_transform: None,
    }
}
