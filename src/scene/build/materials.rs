//! Materials: the BSDF of each material description, and the textures attached to the
//! materials they fit.

use super::Builder;
use crate::bsdf::conductor::Conductor;
use crate::bsdf::dielectric::clamp_ior;
use crate::bsdf::facets::Facets;
use crate::bsdf::interface::Interface;
use crate::bsdf::layered::{Base, ConductorBase, Layered};
use crate::bsdf::microfacet::{Distribution, Microfacet};
use crate::bsdf::plastic::Plastic;
use crate::bsdf::principled::Principled;
use crate::bsdf::tr::TrowbridgeReitz;
use crate::bsdf::{Bsdf, Param};
use crate::io::desc::{CoatedBase, MaterialDesc, MaterialKind, TextureSlot};
use crate::math::Rgb;
use crate::medium::MediumInterface;
use crate::scene::{texture, Material, MaterialTextures, Mix};
use glam::Vec3;
use std::collections::BTreeMap;

impl Builder<'_> {
    /// The materials, then the textures: base colour textures attach to diffuse and
    /// metallic-roughness materials (those with an albedo or base colour to multiply),
    /// metallic-roughness textures to the latter, normal maps to any that scatter, emission
    /// textures to emitters; a texture that fits nothing is a warning.
    pub(super) fn materials(&mut self) {
        let desc = self.desc;
        let interfaces: Vec<_> = desc
            .materials
            .iter()
            .map(|m| self.interface(m.interface))
            .collect();
        self.materials = desc
            .materials
            .iter()
            .zip(interfaces)
            .map(|(m, interface)| material_of(m, interface, &desc.materials))
            .collect();
        self.attach_textures();
        let mut by_type: BTreeMap<String, usize> = BTreeMap::new();
        for m in &desc.materials {
            *by_type.entry(m.kind.type_name().to_string()).or_default() += 1;
        }
        self.stats.materials_by_type = by_type.into_iter().collect();
        for m in &mut self.materials {
            m.scalar_only = m.one_sided
                || m.sides.is_some()
                || m.textures.normal_mitsuba
                || m.textures.bump.is_some();
        }
        self.stats.plugins = desc.plugins.clone();
    }

    /// Builds each description texture and attaches it to its material where it fits; a
    /// texture without texels or that fits nothing is a warning and is dropped.
    fn attach_textures(&mut self) {
        let desc = self.desc;
        for t in &desc.textures {
            let emits = desc
                .materials
                .get(t.material as usize)
                .is_some_and(|m| m.emission.max_element() > 0.0);
            let Some(tex) = texture::Texture::new(t) else {
                self.warnings.push(format!(
                    "{}: texture '{}' holds no texels; ignored",
                    desc.file, t.name
                ));
                continue;
            };
            let id = Some(self.textures.len() as u32);
            let fits = match self.materials.get_mut(t.material as usize) {
                Some(m) => attach_texture(m, t.slot, id, emits),
                None => false,
            };
            if fits {
                self.textures.push(tex);
            } else {
                self.warnings.push(format!(
                    "{}: texture '{}' does not fit its material; ignored",
                    desc.file, t.name
                ));
            }
        }
    }
}

/// The scene material of a description material, with its medium interface; `all` is every
/// description material, against which the ids of sides and mixes are checked.
fn material_of(
    m: &MaterialDesc,
    interface: Option<MediumInterface>,
    all: &[MaterialDesc],
) -> Material {
    Material {
        name: m.name.clone(),
        bsdf: bsdf_of(&m.kind),
        one_sided: m.one_sided,
        scalar_only: false,
        interface,
        null: m.kind == MaterialKind::Null,
        sides: sides_of(&m.kind, all),
        textures: MaterialTextures::default(),
        mix: mix_of(&m.kind, all.len()),
    }
}

/// The front and back materials of a two-sided description, where both exist and neither
/// is itself two-sided.
fn sides_of(kind: &MaterialKind, all: &[MaterialDesc]) -> Option<(u32, u32)> {
    let count = all.len();
    match *kind {
        MaterialKind::Sided { front, back }
            if (front as usize) < count
                && (back as usize) < count
                && !matches!(all[front as usize].kind, MaterialKind::Sided { .. })
                && !matches!(all[back as usize].kind, MaterialKind::Sided { .. }) =>
        {
            Some((front, back))
        }
        _ => None,
    }
}

/// The mix of a mix description whose two materials exist, its amount clamped to [0, 1].
fn mix_of(kind: &MaterialKind, count: usize) -> Option<Mix> {
    match *kind {
        MaterialKind::Mix { a, b, amount } if (a as usize) < count && (b as usize) < count => {
            Some(Mix {
                a,
                b,
                amount: amount.clamp(0.0, 1.0),
            })
        }
        _ => None,
    }
}

/// Attaches texture `id` to material `m` in `slot` where the slot fits its BSDF (emission
/// only where the material `emits`); whether it did.
fn attach_texture(m: &mut Material, slot: TextureSlot, id: Option<u32>, emits: bool) -> bool {
    match slot {
        TextureSlot::BaseColor
            if matches!(
                m.bsdf,
                Bsdf::Diffuse { .. }
                    | Bsdf::Pbr(_)
                    | Bsdf::Plastic(_)
                    | Bsdf::Principled(_)
                    | Bsdf::Microfacet(_)
                    | Bsdf::Conductor(_)
                    | Bsdf::DiffuseTransmission { .. }
                    | Bsdf::Layered(Layered {
                        base: Base::Diffuse(_),
                        ..
                    })
            ) =>
        {
            m.textures.base = id;
            true
        }
        TextureSlot::MetallicRoughness if matches!(m.bsdf, Bsdf::Pbr(_)) => {
            m.textures.metallic_roughness = id;
            true
        }
        TextureSlot::Normal { scale, mitsuba } if !m.bsdf.is_black() => {
            m.textures.normal = id.map(|i| (i, scale));
            m.textures.normal_mitsuba = mitsuba;
            true
        }
        TextureSlot::Bump { scale } if !m.bsdf.is_black() => {
            m.textures.bump = id.map(|i| (i, scale));
            true
        }
        TextureSlot::Transmittance if matches!(m.bsdf, Bsdf::DiffuseTransmission { .. }) => {
            m.textures.transmittance = id;
            true
        }
        TextureSlot::Displacement if !m.bsdf.is_black() => {
            m.textures.displacement = id;
            true
        }
        TextureSlot::Alpha {
            per_crossing,
            blocks_light,
        } => {
            m.textures.alpha = id;
            m.textures.alpha_per_crossing = per_crossing;
            m.textures.alpha_blocks_light = blocks_light;
            true
        }
        TextureSlot::Emission if emits => {
            m.textures.emission = id;
            true
        }
        TextureSlot::Number(param)
            if m.bsdf.takes(param) || (param == Param::Weight && m.mix.is_some()) =>
        {
            let free = m.textures.numbers.iter_mut().find(|n| n.is_none());
            free.map(|entry| *entry = id.map(|i| (i, param))).is_some()
        }
        _ => false,
    }
}

/// The BSDF of a material description. Colours that scatter are clamped to [0, 1]; the
/// dielectrics' `roughness` is parsed but, as in CS184, not used.
fn bsdf_of(kind: &MaterialKind) -> Bsdf {
    let unit = |c: Rgb| c.clamp(Vec3::ZERO, Vec3::ONE);
    match *kind {
        MaterialKind::Diffuse { albedo } => Bsdf::Diffuse {
            albedo: unit(albedo),
        },
        MaterialKind::Emission | MaterialKind::Null => Bsdf::Black,
        MaterialKind::Mirror { reflectance } => Bsdf::Mirror {
            reflectance: unit(reflectance),
        },
        MaterialKind::Glass {
            reflectance,
            transmittance,
            ior,
            ..
        } => Bsdf::Glass {
            reflectance: unit(reflectance),
            transmittance: unit(transmittance),
            ior,
        },
        MaterialKind::Refraction {
            transmittance, ior, ..
        } => Bsdf::Refraction {
            transmittance: unit(transmittance),
            ior,
        },
        MaterialKind::Microfacet { alpha, eta, k } => {
            Bsdf::Microfacet(Microfacet::new(alpha, eta, k))
        }
        MaterialKind::MetallicRoughness {
            base,
            metallic,
            roughness,
            transmission,
            ior,
        } => Bsdf::Pbr(
            crate::bsdf::pbr::Pbr::new(base, metallic, roughness)
                .with_transmission(transmission, ior),
        ),
        MaterialKind::Conductor {
            eta,
            k,
            alpha,
            tint,
            distribution: Distribution::Ggx,
        } => Bsdf::Conductor(Conductor {
            tint: tint.max(Vec3::ZERO),
            ..conductor(eta, k, alpha)
        }),
        MaterialKind::Conductor {
            eta,
            k,
            alpha,
            tint,
            distribution: Distribution::Beckmann,
        } => Bsdf::Microfacet(Microfacet {
            alpha_v: alpha[1].max(1e-4),
            tint: tint.max(Vec3::ZERO),
            ..Microfacet::new(alpha[0], eta.max(Vec3::ZERO), k.max(Vec3::ZERO))
        }),
        MaterialKind::Plastic {
            diffuse,
            specular,
            ior,
            alpha,
            distribution,
            nonlinear,
        } => Bsdf::Plastic(Plastic::new(
            unit(diffuse),
            specular.max(Vec3::ZERO),
            clamp_ior(ior),
            if alpha.is_finite() {
                alpha.clamp(0.0, 10.0)
            } else {
                0.0
            },
            distribution,
            nonlinear,
        )),
        MaterialKind::Dielectric {
            ior,
            alpha,
            distribution,
            thin,
        } => Bsdf::Interface(Interface {
            eta: clamp_ior(ior),
            dist: Facets::new(distribution, alpha[0], alpha[1]),
            thin,
        }),
        MaterialKind::Coated { .. } => coated(kind),
        MaterialKind::Principled(p) => Bsdf::Principled(principled(&p)),
        MaterialKind::Mix { .. } | MaterialKind::Sided { .. } => Bsdf::Black,
        MaterialKind::DiffuseTransmission {
            reflectance,
            transmittance,
        } => Bsdf::DiffuseTransmission {
            reflectance: unit(reflectance),
            transmittance: unit(transmittance),
        },
    }
}

/// A principled BSDF with its parameters made usable: weights clamped to [0, 1], a base
/// colour to at least 0, Mitsuba's index of at least 1.001 (10 at most), seen from outside.
fn principled(p: &Principled) -> Principled {
    let unit = |v: f32| {
        if v.is_finite() {
            v.clamp(0.0, 1.0)
        } else {
            0.0
        }
    };
    Principled {
        base: if p.base.is_finite() {
            p.base.max(Vec3::ZERO)
        } else {
            Vec3::ZERO
        },
        roughness: unit(p.roughness),
        anisotropic: unit(p.anisotropic),
        metallic: unit(p.metallic),
        spec_trans: unit(p.spec_trans),
        spec_tint: unit(p.spec_tint),
        sheen: unit(p.sheen),
        sheen_tint: unit(p.sheen_tint),
        flatness: unit(p.flatness),
        clearcoat: unit(p.clearcoat),
        clearcoat_gloss: unit(p.clearcoat_gloss),
        eta: clamp_ior(p.eta),
        front: true,
    }
}

/// The layered BSDF of a [`MaterialKind::Coated`] description.
fn coated(kind: &MaterialKind) -> Bsdf {
    let MaterialKind::Coated {
        base,
        ior,
        alpha,
        thickness,
        max_depth,
        samples,
    } = kind
    else {
        return Bsdf::Black;
    };
    Bsdf::Layered(Layered {
        top: Interface {
            eta: clamp_ior(*ior),
            dist: TrowbridgeReitz::new(alpha[0], alpha[1]).into(),
            thin: false,
        },
        base: match *base {
            CoatedBase::Diffuse { reflectance } => {
                Base::Diffuse(reflectance.clamp(Vec3::ZERO, Vec3::ONE))
            }
            CoatedBase::Conductor { eta, k, alpha } => {
                let c = conductor(eta, k, alpha);
                Base::Conductor(ConductorBase {
                    dist: c.dist,
                    eta: c.eta,
                    k: c.k,
                })
            }
        },
        thickness: if thickness.is_finite() {
            thickness.max(0.0)
        } else {
            0.0
        },
        max_depth: (*max_depth).min(u16::MAX as u32) as u16,
        samples: (*samples).clamp(1, u16::MAX as u32) as u16,
    })
}

/// A conductor of index `eta + i·k` (each clamped to be non-negative) and roughness `alpha`.
fn conductor(eta: Rgb, k: Rgb, alpha: [f32; 2]) -> Conductor {
    Conductor {
        dist: TrowbridgeReitz::new(alpha[0], alpha[1]),
        eta: eta.max(Vec3::ZERO),
        k: k.max(Vec3::ZERO),
        tint: Vec3::ONE,
    }
}
