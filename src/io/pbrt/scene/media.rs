//! `MakeNamedMedium`: pbrt-v4's `homogeneous`, `uniformgrid` and `rgbgrid` media, with its
//! defaults and conventions (`media.cpp`):
//! - `homogeneous`: `sigma_a`, `sigma_s` (default 1 each), times `scale`; emission `Le`
//!   times `Lescale`.
//! - `uniformgrid`: `σ = sigma · scale · density(p)` from `density` (`nx·ny·nz` floats,
//!   x fastest) over the box `p0`–`p1` of the medium's space (the CTM at the directive);
//!   emission `Le · Lescale(p)`, where a missing `Lescale` is pbrt-v4's one-voxel grid (so
//!   emission fades towards the box's faces).
//! - `rgbgrid`: `σa = scale · sigma_a(p)`, `σs = scale · sigma_s(p)` from RGB grids (a missing
//!   one is 1); emission `Lescale · Le(p)`.
//!
//! - `nanovdb`: `σ = sigma · scale · density(p)` from the float grid `gridname` (default
//!   `density`) of the NanoVDB file `filename` ([`crate::io::nvdb`]), whose voxels sit at
//!   integer index coordinates under the file's map, within the grid's world box (the
//!   active voxels' box, `min` to `max + 1` in index space, mapped); the CTM places it.
//!
//! Grids interpolate trilinearly between voxel centres and fade to 0 beyond them
//! ([`GridEdge::Zero`]). Negative or non-finite values, and grids whose sizes disagree with
//! their data, are errors at the directive.

use super::{error_at, string, Interp};
use crate::error::Result;
use crate::io::desc::{GridMediumDesc, MediumCoefficients, MediumDesc};
use crate::io::nvdb;
use crate::io::pbrt::params::Params;
use crate::io::pbrt::Directive;
use crate::math::Rgb;
use crate::medium::grid::{voxel_count, Field, GridEdge, GridFilter, VoxelGrid};
use glam::{Mat4, Vec3};
use std::sync::Arc;

impl Interp {
    /// `MakeNamedMedium`: the medium, recorded under its name (kinds not rendered with a
    /// warning, their space left empty).
    pub(super) fn medium(&mut self, d: &Directive) -> Result<()> {
        let p = Params::new(d);
        let name = string(d, 0).to_string();
        let kind = p.string("type")?.unwrap_or("").to_string();
        let g = p.float("g", 0.0)?;
        if !(g > -1.0 && g < 1.0) {
            return Err(error_at(
                d,
                format!("medium '{name}': g = {g} must lie in (-1, 1)"),
            ));
        }
        let coefficients = match kind.as_str() {
            "homogeneous" => Some(self.homogeneous(d, &p)?),
            "uniformgrid" => Some(self.uniform_grid(d, &p)?),
            "rgbgrid" => Some(self.rgb_grid(d, &p)?),
            "nanovdb" => Some(self.nanovdb(d, &p)?),
            _ => {
                self.warn_once(
                    d,
                    &format!("medium {kind}"),
                    format!(
                        "media of type \"{kind}\" are not rendered yet; their space is left empty"
                    ),
                );
                None
            }
        };
        p.ignore(&d.params.iter().map(|q| q.name.as_str()).collect::<Vec<_>>());
        self.media
            .insert(name.clone(), self.desc.media.len() as u32);
        self.desc.media.push(MediumDesc {
            name,
            kind,
            g,
            coefficients,
            loc: d.loc,
        });
        Ok(())
    }

    /// A colour parameter that must be finite and not negative.
    fn coefficient(&self, d: &Directive, p: &Params, name: &str, default: Rgb) -> Result<Rgb> {
        let c = self.materials.rgb_param(p, name, default)?;
        if !(c.is_finite() && c.min_element() >= 0.0) {
            return Err(error_at(
                d,
                format!(
                    "medium '{}': {name} {c} must be finite and not negative",
                    string(d, 0)
                ),
            ));
        }
        Ok(c)
    }

    /// `scale`, which must be finite and not negative.
    fn sigma_scale(&self, d: &Directive, p: &Params) -> Result<f32> {
        let scale = p.float("scale", 1.0)?;
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(error_at(
                d,
                format!(
                    "medium '{}': scale {scale} must be finite and not negative",
                    string(d, 0)
                ),
            ));
        }
        Ok(scale)
    }

    fn homogeneous(&mut self, d: &Directive, p: &Params) -> Result<MediumCoefficients> {
        let scale = self.sigma_scale(d, p)?;
        let sigma_a = self.coefficient(d, p, "sigma_a", Rgb::ONE)? * scale;
        let sigma_s = self.coefficient(d, p, "sigma_s", Rgb::ONE)? * scale;
        let le = self.coefficient(d, p, "Le", Rgb::ZERO)? * p.float("Lescale", 1.0)?.max(0.0);
        if p.string("preset")?.is_some() {
            self.warn_once(
                d,
                "medium preset",
                "named scattering presets are not supported yet; sigma_a and sigma_s are used"
                    .into(),
            );
        }
        Ok(MediumCoefficients::Homogeneous {
            sigma_a,
            sigma_s,
            le,
        })
    }

    /// `nx`, `ny`, `nz` (default 1 each), which must be positive.
    fn grid_size(&self, d: &Directive, p: &Params) -> Result<[u32; 3]> {
        let mut res = [1u32; 3];
        for (r, axis) in res.iter_mut().zip(["nx", "ny", "nz"]) {
            let n = p.int(axis, 1)?;
            *r = u32::try_from(n).ok().filter(|&n| n > 0).ok_or_else(|| {
                error_at(
                    d,
                    format!("medium '{}': {axis} = {n} must be positive", string(d, 0)),
                )
            })?;
        }
        Ok(res)
    }

    /// The grid of parameter `name` (type `ty`, `channels` numbers per voxel) over `res`
    /// voxels, if given; an error where its length or values are wrong.
    fn grid(
        &self,
        d: &Directive,
        p: &Params,
        (name, ty, channels): (&str, &str, u32),
        res: [u32; 3],
    ) -> Result<Option<Arc<VoxelGrid>>> {
        let Some(values) = p.numbers(name, ty)? else {
            return Ok(None);
        };
        let expected = voxel_count(res).and_then(|n| n.checked_mul(channels as usize));
        if expected != Some(values.len()) {
            return Err(error_at(
                d,
                format!(
                    "medium '{}': \"{name}\" has {} values; nx·ny·nz = {}×{}×{}{} needs {}",
                    string(d, 0),
                    values.len(),
                    res[0],
                    res[1],
                    res[2],
                    if channels == 3 { " RGB triples" } else { "" },
                    expected.map_or("more than can be stored".into(), |n| n.to_string()),
                ),
            ));
        }
        let values = values.iter().map(|&v| v as f32).collect();
        VoxelGrid::new(res, channels, values, GridEdge::Zero, GridFilter::Trilinear)
            .map(|g| Some(Arc::new(g)))
            .map_err(|e| error_at(d, format!("medium '{}': \"{name}\": {e}", string(d, 0))))
    }

    /// World space → the unit cube of the box `p0`–`p1` of the medium's space.
    fn grid_box(&self, d: &Directive, p: &Params) -> Result<Mat4> {
        let p0 = p.vec3("p0", "point3")?.unwrap_or(Vec3::ZERO);
        let p1 = p.vec3("p1", "point3")?.unwrap_or(Vec3::ONE);
        let size = p1 - p0;
        let inverse = self.state.ctm.inverse();
        if !(size.min_element() > 0.0 && size.is_finite() && inverse.is_finite()) {
            return Err(error_at(
                d,
                format!(
                    "medium '{}': the box p0 {p0} – p1 {p1} must have positive size (and the \
                     transform an inverse)",
                    string(d, 0)
                ),
            ));
        }
        Ok(Mat4::from_scale(size.recip()) * Mat4::from_translation(-p0) * inverse)
    }

    /// `uniformgrid`: a density grid times constant coefficients.
    fn uniform_grid(&mut self, d: &Directive, p: &Params) -> Result<MediumCoefficients> {
        let res = self.grid_size(d, p)?;
        let density = self
            .grid(d, p, ("density", "float", 1), res)?
            .ok_or_else(|| {
                error_at(
                    d,
                    format!(
                        "medium '{}': a uniformgrid needs \"density\" values",
                        string(d, 0)
                    ),
                )
            })?;
        let scale = self.sigma_scale(d, p)?;
        let sigma_a = self.coefficient(d, p, "sigma_a", Rgb::ONE)? * scale;
        let sigma_s = self.coefficient(d, p, "sigma_s", Rgb::ONE)? * scale;
        let le = self.coefficient(d, p, "Le", Rgb::ZERO)?;
        let temperature = self.grid(d, p, ("temperature", "float", 1), res)?;
        if temperature.is_some() && le.max_element() > 0.0 {
            return Err(error_at(
                d,
                format!(
                    "medium '{}': both \"Le\" and \"temperature\" are given",
                    string(d, 0)
                ),
            ));
        }
        let mut grids = vec![density];
        let (emission, temperature) = if le.max_element() > 0.0 || temperature.is_some() {
            // pbrt-v4's stand-in for a missing Lescale: a one-voxel grid of 1.
            let one =
                || VoxelGrid::new([1; 3], 1, vec![1.0], GridEdge::Zero, GridFilter::Trilinear);
            let scale = match self.grid(d, p, ("Lescale", "float", 1), res)? {
                Some(g) => g,
                None => Arc::new(one().map_err(|e| error_at(d, e))?),
            };
            grids.push(scale);
            let blackbody = match temperature {
                Some(t) => {
                    grids.push(t);
                    Some(Self::blackbody(p, 2)?)
                }
                None => None,
            };
            let radiance = if blackbody.is_some() { Rgb::ONE } else { le };
            (Field::grid(radiance, 1), blackbody)
        } else {
            (Field::constant(Vec3::ZERO), None)
        };
        Ok(MediumCoefficients::Grid(GridMediumDesc {
            to_unit: self.grid_box(d, p)?,
            grids,
            sigma_a: Field::grid(sigma_a, 0),
            sigma_s: Field::grid(sigma_s, 0),
            emission,
            bounds: (Vec3::ZERO, Vec3::ONE),
            temperature,
        }))
    }

    /// Blackbody emission from temperature grid `grid`: the grid, `temperatureoffset` (or
    /// its older name `temperaturecutoff`) and `temperaturescale`.
    fn blackbody(p: &Params, grid: u8) -> Result<(u8, f32, f32)> {
        let cutoff = p.float("temperaturecutoff", 0.0)?;
        let offset = p.float("temperatureoffset", cutoff)?;
        Ok((grid, offset, p.float("temperaturescale", 1.0)?))
    }

    /// `rgbgrid`: RGB grids of `sigma_a`, `sigma_s` and `Le`.
    fn rgb_grid(&mut self, d: &Directive, p: &Params) -> Result<MediumCoefficients> {
        let res = self.grid_size(d, p)?;
        let scale = self.sigma_scale(d, p)?;
        let mut grids = Vec::new();
        let mut field = |grid: Option<Arc<VoxelGrid>>, scale: f32| match grid {
            Some(g) => {
                grids.push(g);
                Field::grid(Vec3::splat(scale), grids.len() as u8 - 1)
            }
            None => Field::constant(Vec3::splat(scale)),
        };
        let a = self.grid(d, p, ("sigma_a", "rgb", 3), res)?;
        let s = self.grid(d, p, ("sigma_s", "rgb", 3), res)?;
        let le = self.grid(d, p, ("Le", "rgb", 3), res)?;
        if le.is_some() && a.is_none() {
            return Err(error_at(
                d,
                format!(
                    "medium '{}': an rgbgrid with \"Le\" needs \"sigma_a\" values",
                    string(d, 0)
                ),
            ));
        }
        if a.is_none() && s.is_none() {
            return Err(error_at(
                d,
                format!(
                    "medium '{}': an rgbgrid needs \"sigma_a\" or \"sigma_s\" values",
                    string(d, 0)
                ),
            ));
        }
        let sigma_a = field(a, scale);
        let sigma_s = field(s, scale);
        let emission = match le {
            Some(g) => field(Some(g), p.float("Lescale", 1.0)?.max(0.0)),
            None => Field::constant(Vec3::ZERO),
        };
        Ok(MediumCoefficients::Grid(GridMediumDesc {
            to_unit: self.grid_box(d, p)?,
            grids,
            sigma_a,
            sigma_s,
            emission,
            bounds: (Vec3::ZERO, Vec3::ONE),
            temperature: None,
        }))
    }

    /// `nanovdb`: the file's density grid over its active box, copied dense or looked up in
    /// its tree (an error naming the file where it does not read or has no such grid).
    fn nanovdb(&mut self, d: &Directive, p: &Params) -> Result<MediumCoefficients> {
        let at = |msg: String| error_at(d, format!("medium '{}': {msg}", string(d, 0)));
        let Some(file) = p.string("filename")? else {
            return Err(at("a nanovdb medium needs a \"filename\"".into()));
        };
        let path = Interp::folder(d).join(file);
        let bytes = std::fs::read(&path).map_err(|e| at(format!("{}: {e}", path.display())))?;
        let in_file = |e: String| at(format!("{}: {e}", path.display()));
        let name = p.string("gridname")?.unwrap_or("density");
        let grid = nvdb::read_grid(&bytes, name)
            .map_err(in_file)?
            .ok_or_else(|| in_file(format!("no grid named \"{name}\"")))?;
        let grid = Arc::new(grid);
        let in_grid = |name: &str, e: String| in_file(format!("grid \"{name}\": {e}"));
        let (first, res) = grid.extent().map_err(|e| in_grid(name, e))?;
        let density = grid.voxels_over(first, res).map_err(|e| in_grid(name, e))?;
        let mut grids = vec![Arc::new(density)];
        let temperature_name = p.string("temperaturename")?.unwrap_or("temperature");
        let temperature = nvdb::read_grid(&bytes, temperature_name).map_err(in_file)?;
        let blackbody = match temperature {
            Some(t) if t.to_index == grid.to_index && t.origin == grid.origin => {
                let voxels = Arc::new(t)
                    .voxels_over(first, res)
                    .map_err(|e| in_grid(temperature_name, e))?;
                grids.push(Arc::new(voxels));
                Some(Self::blackbody(p, 1)?)
            }
            Some(_) => {
                self.warn_once(
                    d,
                    "medium temperature map",
                    format!(
                        "the \"{temperature_name}\" grid is placed differently from \"{name}\"; \
                         its emission is not rendered"
                    ),
                );
                None
            }
            None => None,
        };
        let le_scale = p.float("Lescale", 1.0)?.max(0.0);
        let emission = match blackbody {
            Some(_) => Field::constant(Vec3::splat(le_scale)),
            None => Field::constant(Vec3::ZERO),
        };
        let scale = self.sigma_scale(d, p)?;
        let sigma_a = self.coefficient(d, p, "sigma_a", Rgb::ONE)? * scale;
        let sigma_s = self.coefficient(d, p, "sigma_s", Rgb::ONE)? * scale;
        // Medium space → index space → the grid's unit cube, whose voxel v is index voxel
        // first + v, centred at (v + ½)/n.
        let n = Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32);
        let to_index = Mat4::from_mat3(grid.to_index) * Mat4::from_translation(-grid.origin);
        let to_cube = Mat4::from_scale(n.recip())
            * Mat4::from_translation(Vec3::splat(0.5) - first.as_vec3())
            * to_index;
        let inverse = self.state.ctm.inverse();
        if !inverse.is_finite() {
            return Err(at("the transform has no inverse".into()));
        }
        let (lo, hi) = grid.world_bbox;
        let corners = (0..8).map(|i| {
            let pick = |bit: usize, a: f64, b: f64| if i >> bit & 1 == 0 { a } else { b };
            let c = glam::DVec3::new(
                pick(0, lo.x, hi.x),
                pick(1, lo.y, hi.y),
                pick(2, lo.z, hi.z),
            );
            to_cube.transform_point3(c.as_vec3())
        });
        let bounds = corners.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), c| {
            (a.min(c), b.max(c))
        });
        if !self.desc.sources.contains(&path) {
            self.desc.sources.push(path);
        }
        Ok(MediumCoefficients::Grid(GridMediumDesc {
            to_unit: to_cube * inverse,
            grids,
            sigma_a: Field::grid(sigma_a, 0),
            sigma_s: Field::grid(sigma_s, 0),
            emission,
            bounds,
            temperature: blackbody,
        }))
    }
}
