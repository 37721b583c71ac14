//! Participating media: `homogeneous` and `heterogeneous` (`albedo`, default 0.75; `sigma_t`,
//! default 1; `scale`) with their `phase` (`isotropic`, the default, or `hg` with `g`, default
//! 0.8), a shape's `interior` and `exterior` media, and the sensor's medium.
//!
//! As in Mitsuba 3: `σs = albedo·σt·scale`, `σa = (1 − albedo)·σt·scale`. A heterogeneous
//! medium's properties are volumes: constants (`constvolume`, or a number, which Mitsuba makes
//! a constant volume over the unit cube) or `gridvolume`s read from `.vol` files
//! ([`crate::io::vol`]; trilinear or nearest lookups, clamped at the faces); the medium fills
//! the box of its `sigma_t` volume, the unit cube under that volume's `to_world`. A shape whose two
//! media differ is a boundary, its exterior on the side its normal faces (`flip_normals`
//! turns it); a shape with a medium and no BSDF is diffuse (Mitsuba's default), and media
//! are bounded without scattering by `<bsdf type="null"/>`. Only the volumetric integrators
//! (`volpath`, `volpathmis`) render media: under `path` they are left out with a warning.

use super::xml::Node;
use super::Interp;
use crate::error::Result;
use crate::io::desc::{
    GridMediumDesc, MaterialDesc, MaterialKind, MediumCoefficients, MediumDesc, MediumInterfaceDesc,
};
use crate::math::Rgb;
use crate::medium::grid::{Factor, Field, GridEdge, GridFilter, VoxelGrid};
use glam::{Mat4, Vec3};
use std::sync::Arc;

/// A heterogeneous medium's property: a constant or a grid, over the unit cube under
/// `to_world`.
struct VolumeProp {
    /// The grid; `None` for a constant.
    grid: Option<Arc<VoxelGrid>>,
    /// The constant, or the grid's scale (1).
    value: Rgb,
    /// Where its unit cube is.
    to_world: Mat4,
}

impl<'a> Interp<'a> {
    /// The description index of medium object `index`, read once.
    pub(super) fn medium(&mut self, index: usize) -> Result<u32> {
        if let Some(&m) = self.media.get(&index) {
            return Ok(m);
        }
        let node = self.node(index);
        self.count(node);
        let coefficients = match node.plugin.as_str() {
            "homogeneous" => {
                let (sigma_a, sigma_s) = self.homogeneous(node)?;
                Some(MediumCoefficients::Homogeneous {
                    sigma_a,
                    sigma_s,
                    le: Rgb::ZERO,
                })
            }
            "heterogeneous" => Some(self.heterogeneous(node)?),
            _ => {
                self.unsupported(node, "its space is left empty");
                None
            }
        };
        let g = self.phase(node)?;
        let id = self.desc.media.len() as u32;
        self.desc.media.push(MediumDesc {
            name: node.id.clone().unwrap_or_else(|| node.plugin.clone()),
            kind: node.plugin.clone(),
            g,
            coefficients,
            loc: node.loc,
        });
        self.media.insert(index, id);
        Ok(id)
    }

    /// `homogeneous`: `σa` and `σs`, checked (an error at the medium for negative or
    /// non-finite values, or an albedo outside [0, 1]).
    fn homogeneous(&mut self, node: &'a Node) -> Result<(Rgb, Rgb)> {
        let albedo = self.volume(node, "albedo")?.unwrap_or(Rgb::splat(0.75));
        let sigma_t = self.volume(node, "sigma_t")?.unwrap_or(Rgb::ONE);
        let scale = self.float(node, "scale", 1.0)?;
        for flag in ["sample_emitters", "has_spectral_extinction"] {
            self.bool(node, flag, true)?;
        }
        let sigma_t = sigma_t * scale;
        self.check_coefficients(node, albedo, sigma_t)?;
        Ok((sigma_t * (Rgb::ONE - albedo), sigma_t * albedo))
    }

    /// An error at medium `node` unless `albedo` lies in [0, 1] and `sigma_t` (after the
    /// scale) is finite and not negative.
    fn check_coefficients(&self, node: &Node, albedo: Rgb, sigma_t: Rgb) -> Result<()> {
        let valid_albedo =
            albedo.is_finite() && albedo.min_element() >= 0.0 && albedo.max_element() <= 1.0;
        if valid_albedo && sigma_t.is_finite() && sigma_t.min_element() >= 0.0 {
            return Ok(());
        }
        Err(self.doc.error(
            node,
            node.loc,
            format!(
                "medium \"{}\": albedo {albedo} must lie in [0, 1] and sigma_t × scale {sigma_t} \
                 must be finite and not negative",
                node.plugin
            ),
        ))
    }

    /// `heterogeneous`: its fields over the box of its `sigma_t` volume (an error for an
    /// albedo outside [0, 1], a negative or non-finite scale, or a volume file that does not
    /// read).
    fn heterogeneous(&mut self, node: &'a Node) -> Result<MediumCoefficients> {
        let unit = |value| VolumeProp {
            grid: None,
            value,
            to_world: Mat4::IDENTITY,
        };
        let sigma_t = self.volume_prop(node, "sigma_t")?.unwrap_or(unit(Rgb::ONE));
        let albedo = self
            .volume_prop(node, "albedo")?
            .unwrap_or(unit(Rgb::splat(0.75)));
        let scale = self.float(node, "scale", 1.0)?;
        for flag in ["sample_emitters", "has_spectral_extinction"] {
            self.bool(node, flag, true)?;
        }
        let a = albedo.value;
        let to_unit = sigma_t.to_world.inverse();
        let sigma_scale = sigma_t.value * scale;
        self.check_coefficients(node, a, sigma_scale)?;
        if !to_unit.is_finite() {
            return Err(self.doc.error(
                node,
                node.loc,
                "medium \"heterogeneous\": the sigma_t volume's to_world has no inverse",
            ));
        }
        // σt's own grid, or a one-voxel grid of 1 for a constant (Mitsuba's constant volume).
        let one = VoxelGrid::new([1; 3], 1, vec![1.0], GridEdge::Clamp, GridFilter::Nearest);
        let density = match sigma_t.grid {
            Some(g) => g,
            None => Arc::new(one.map_err(|e| self.doc.error(node, node.loc, e))?),
        };
        let mut grids = vec![density];
        let factor = |grid, complement| Some(Factor { grid, complement });
        let (sigma_a, sigma_s) = match albedo.grid {
            None => (
                Field::grid(sigma_scale * (Rgb::ONE - a), 0),
                Field::grid(sigma_scale * a, 0),
            ),
            Some(g) => {
                if albedo.to_world != sigma_t.to_world {
                    self.warn_once(
                        node,
                        node.loc,
                        "albedo volume placement",
                        "an albedo volume placed differently from sigma_t's is read in \
                         sigma_t's box",
                    );
                }
                grids.push(g);
                let field = |complement| Field {
                    scale: sigma_scale,
                    factors: [factor(0, false), factor(1, complement)],
                };
                (field(true), field(false))
            }
        };
        Ok(MediumCoefficients::Grid(GridMediumDesc {
            to_unit,
            grids,
            sigma_a,
            sigma_s,
            emission: Field::constant(Vec3::ZERO),
            bounds: (Vec3::ZERO, Vec3::ONE),
            temperature: None,
        }))
    }

    /// A heterogeneous medium's property `name`: a colour, a `constvolume` or a `gridvolume`;
    /// `None` where absent (or a volume not rendered yet, with a warning).
    fn volume_prop(&mut self, node: &'a Node, name: &str) -> Result<Option<VolumeProp>> {
        if let Some(c) = self.colour_opt(node, name)? {
            return Ok(Some(VolumeProp {
                grid: None,
                value: c,
                to_world: Mat4::IDENTITY,
            }));
        }
        let Some(v) = self
            .named_child(node, name)
            .filter(|&c| self.node(c).tag == "volume")
        else {
            return Ok(None);
        };
        let v = self.node(v);
        self.count(v);
        let to_world = self.to_world(v)?;
        match v.plugin.as_str() {
            "constvolume" => Ok(Some(VolumeProp {
                grid: None,
                value: self.colour_opt(v, "value")?.unwrap_or(Rgb::ONE),
                to_world,
            })),
            "gridvolume" => self.grid_volume(v, to_world).map(Some),
            _ => {
                self.unsupported(v, "the property's default stands in");
                Ok(None)
            }
        }
    }

    /// A `gridvolume`: its `.vol` file's grid (an error naming the file where it does not
    /// read) and where its unit cube is (the file's box under `use_grid_bbox`).
    fn grid_volume(&mut self, v: &'a Node, to_world: Mat4) -> Result<VolumeProp> {
        let at = |this: &Self, msg: String| this.doc.error(v, v.loc, msg);
        let filter = match self.string(v, "filter_type")?.unwrap_or("trilinear") {
            "trilinear" => GridFilter::Trilinear,
            "nearest" => GridFilter::Nearest,
            other => {
                return Err(at(
                    self,
                    format!("gridvolume: unknown filter_type \"{other}\""),
                ))
            }
        };
        match self.string(v, "wrap_mode")?.unwrap_or("clamp") {
            "clamp" => {}
            "repeat" | "mirror" => self.warn_once(
                v,
                v.loc,
                "gridvolume wrap_mode",
                "gridvolume wrap modes other than \"clamp\" are not supported yet; clamp stands in",
            ),
            other => {
                return Err(at(
                    self,
                    format!("gridvolume: unknown wrap_mode \"{other}\""),
                ))
            }
        }
        for flag in ["raw", "accel"] {
            self.bool(v, flag, false)?;
        }
        let use_bbox = self.bool(v, "use_grid_bbox", false)?;
        let Some(file) = self.string(v, "filename")? else {
            return Err(at(self, "gridvolume needs a \"filename\"".into()));
        };
        let path = self.doc.folder(v).join(file);
        let vol = crate::io::vol::read_file(&path, GridEdge::Clamp, filter)
            .map_err(|e| at(self, format!("gridvolume: {e}")))?;
        if !self.desc.sources.contains(&path) {
            self.desc.sources.push(path);
        }
        let (lo, hi) = vol.bbox;
        let to_world = if use_bbox {
            to_world * Mat4::from_translation(lo) * Mat4::from_scale(hi - lo)
        } else {
            to_world
        };
        Ok(VolumeProp {
            grid: Some(Arc::new(vol.grid)),
            value: Rgb::ONE,
            to_world,
        })
    }

    /// A homogeneous medium's property `name`: a colour or a `constvolume`'s value; `None`
    /// where absent (or a grid, with a warning: the default stands in).
    fn volume(&mut self, node: &'a Node, name: &str) -> Result<Option<Rgb>> {
        let Some(v) = self.volume_prop(node, name)? else {
            return Ok(None);
        };
        if v.grid.is_some() {
            self.warn_once(
                node,
                node.loc,
                "homogeneous grid",
                "a homogeneous medium takes constants; its grid volume is ignored and the \
                 property's default stands in (a heterogeneous medium reads grids)",
            );
            return Ok(None);
        }
        Ok(Some(v.value))
    }

    /// The medium's phase function as a Henyey-Greenstein asymmetry (0: isotropic).
    fn phase(&mut self, node: &'a Node) -> Result<f32> {
        let Some((p, _)) = self.children(node, "phase").next() else {
            return Ok(0.0);
        };
        let p = self.node(p);
        self.count(p);
        match p.plugin.as_str() {
            "isotropic" => Ok(0.0),
            "hg" => {
                let g = self.float(p, "g", 0.8)?;
                if g.is_nan() || g.abs() >= 1.0 {
                    return Err(self.doc.error(
                        p,
                        p.loc,
                        format!("phase \"hg\": g = {g} must lie in (-1, 1)"),
                    ));
                }
                Ok(g)
            }
            _ => {
                self.unsupported(p, "an isotropic phase function stands in");
                Ok(0.0)
            }
        }
    }

    /// The media a shape separates (`interior`, `exterior`; swapped for a sphere whose
    /// normals point inwards), where they differ.
    pub(super) fn shape_media(
        &mut self,
        node: &'a Node,
        inwards: bool,
    ) -> Result<Option<MediumInterfaceDesc>> {
        let mut side = |name: &str| -> Result<Option<u32>> {
            match self.named_child(node, name) {
                Some(c) if self.node(c).tag == "medium" => self.medium(c).map(Some),
                _ => Ok(None),
            }
        };
        let (mut inside, mut outside) = (side("interior")?, side("exterior")?);
        if self
            .children(node, "medium")
            .any(|(_, name)| !matches!(name, Some("interior" | "exterior")))
        {
            self.warn_once(
                node,
                node.loc,
                "shape medium name",
                "a shape's medium needs the name \"interior\" or \"exterior\"; others are ignored",
            );
        }
        if inwards {
            std::mem::swap(&mut inside, &mut outside);
        }
        Ok((inside != outside).then_some(MediumInterfaceDesc { inside, outside }))
    }

    /// Material `m` as the boundary `interface`, made once per material and interface: a
    /// null surface where its BSDF is `null`, else a copy with the interface.
    pub(super) fn bounding(&mut self, m: u32, null: bool, interface: MediumInterfaceDesc) -> u32 {
        if let Some(&id) = self.bounding.get(&(m, interface)) {
            return id;
        }
        let id = if null {
            let base = &self.desc.materials[m as usize];
            let made = MaterialDesc {
                name: base.name.clone(),
                kind: MaterialKind::Null,
                emission: base.emission,
                one_sided: false,
                interface: Some(interface),
                loc: base.loc,
            };
            self.desc.materials.push(made);
            self.desc.materials.len() as u32 - 1
        } else {
            self.desc
                .copy_material(m, "medium boundary", |c| c.interface = Some(interface))
        };
        self.bounding.insert((m, interface), id);
        id
    }

    /// The sensor's medium, if it has one.
    pub(super) fn sensor_medium(&mut self, sensor: &'a Node) -> Result<()> {
        if let Some((c, _)) = self.children(sensor, "medium").next() {
            self.desc.camera_medium = Some(self.medium(c)?);
        }
        Ok(())
    }

    /// Leaves the media out where the integrator does not render them (`path`), with a
    /// warning at it.
    pub(super) fn finish_media(&mut self) {
        let Some(i) = self.media_ignored_by else {
            return;
        };
        if self.desc.media.is_empty() {
            return;
        }
        let node = self.node(i);
        self.warn_once(
            node,
            node.loc,
            "media ignored",
            "Mitsuba's \"path\" integrator (the file's, or the default where it names none) \
             ignores participating media (\"volpath\" renders them); they are left out",
        );
        self.desc.camera_medium = None;
        for m in &mut self.desc.materials {
            m.interface = None;
        }
    }
}
