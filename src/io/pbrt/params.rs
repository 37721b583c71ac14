//! Typed access to a directive's parameters, as pbrt-v4's `ParameterDictionary`: each lookup
//! checks the declared type and the number of values, marks the parameter used, and
//! [`Params::unused`] reports the ones no lookup asked for (pbrt-v4's `ReportUnused`).

use super::{Directive, Param, Values};
use crate::error::{Error, Result};
use crate::math::Rgb;
use glam::Vec3;
use std::cell::Cell;

/// The parameters of one directive.
pub struct Params<'a> {
    directive: &'a Directive,
    used: Vec<Cell<bool>>,
}

/// A colour parameter's value.
pub enum Colour {
    /// Linear RGB.
    Rgb(Rgb),
    /// A named texture (`"texture name"`).
    Texture(String),
}

impl<'a> Params<'a> {
    /// The parameters of `directive`, none used yet.
    pub fn new(directive: &'a Directive) -> Self {
        Params {
            directive,
            used: directive.params.iter().map(|_| Cell::new(false)).collect(),
        }
    }

    /// An error at parameter `p`.
    pub fn error(&self, p: &Param, msg: String) -> Error {
        Error::At {
            file: self.directive.file.display().to_string(),
            loc: p.loc,
            msg,
        }
    }

    /// The parameter called `name`, marked used, if its type is one of `types`; an error if
    /// it has another type.
    pub fn find(&self, name: &str, types: &[&str]) -> Result<Option<&'a Param>> {
        let Some(i) = self.directive.params.iter().rposition(|p| p.name == name) else {
            return Ok(None);
        };
        let p = &self.directive.params[i];
        self.used[i].set(true);
        if !types.contains(&p.ty.as_str()) {
            return Err(self.error(
                p,
                format!(
                    "parameter '{name}' of {} has type '{}'; expected {}",
                    self.directive.name,
                    p.ty,
                    types.join(" or ")
                ),
            ));
        }
        Ok(Some(p))
    }

    /// The numbers of parameter `name` of type `ty`, if given.
    pub fn numbers(&self, name: &str, ty: &str) -> Result<Option<&'a [f64]>> {
        match self.find(name, &[ty])? {
            None => Ok(None),
            Some(p) => match &p.values {
                Values::Numbers(v) => Ok(Some(v)),
                _ => Err(self.error(p, format!("parameter '{name}' needs numbers"))),
            },
        }
    }

    /// The numbers of `name` (type `ty`), which must come in groups of `group`.
    pub fn tuples(&self, name: &str, ty: &str, group: usize) -> Result<Option<&'a [f64]>> {
        let v = self.numbers(name, ty)?;
        if let (Some(v), Some(p)) = (v, self.find(name, &[ty])?) {
            if v.len() % group != 0 {
                return Err(self.error(
                    p,
                    format!(
                        "parameter '{name}' has {} values, not a multiple of {group}",
                        v.len()
                    ),
                ));
            }
        }
        Ok(v)
    }

    /// The single number of `name` (type `ty`), if given.
    fn one_number(&self, name: &str, ty: &str) -> Result<Option<f64>> {
        let Some(v) = self.numbers(name, ty)? else {
            return Ok(None);
        };
        if v.len() != 1 {
            let p = self.find(name, &[ty])?.expect("found above");
            return Err(self.error(
                p,
                format!("parameter '{name}' needs one value, not {}", v.len()),
            ));
        }
        Ok(Some(v[0]))
    }

    /// The `float` called `name`, or `default`.
    pub fn float(&self, name: &str, default: f32) -> Result<f32> {
        Ok(self
            .one_number(name, "float")?
            .map_or(default, |x| x as f32))
    }

    /// The `float` called `name`, if given.
    pub fn float_opt(&self, name: &str) -> Result<Option<f32>> {
        Ok(self.one_number(name, "float")?.map(|x| x as f32))
    }

    /// The `integer` called `name`, or `default`; an error if it is not a whole number.
    pub fn int(&self, name: &str, default: i64) -> Result<i64> {
        match self.one_number(name, "integer")? {
            None => Ok(default),
            Some(x) if x.fract() == 0.0 && x.abs() < 9.0e15 => Ok(x as i64),
            Some(x) => {
                let p = self.find(name, &["integer"])?.expect("found above");
                Err(self.error(p, format!("parameter '{name}' must be an integer, not {x}")))
            }
        }
    }

    /// The integers of `name`, each checked to be whole and in `0..limit`.
    pub fn indices(&self, name: &str, limit: usize) -> Result<Option<Vec<u32>>> {
        let Some(v) = self.numbers(name, "integer")? else {
            return Ok(None);
        };
        let p = self.find(name, &["integer"])?.expect("found above");
        v.iter()
            .map(|&x| {
                if x.fract() == 0.0 && x >= 0.0 && (x as usize) < limit {
                    Ok(x as u32)
                } else {
                    Err(self.error(
                        p,
                        format!("parameter '{name}': index {x} is not in 0..{limit}"),
                    ))
                }
            })
            .collect::<Result<Vec<u32>>>()
            .map(Some)
    }

    /// The `bool` called `name`, or `default`.
    pub fn bool(&self, name: &str, default: bool) -> Result<bool> {
        match self.find(name, &["bool"])? {
            None => Ok(default),
            Some(p) => match &p.values {
                Values::Bools(b) if b.len() == 1 => Ok(b[0]),
                _ => Err(self.error(p, format!("parameter '{name}' needs one true or false"))),
            },
        }
    }

    /// The string called `name` of type `ty` (`string`, `texture`), if given.
    pub fn text(&self, name: &str, ty: &str) -> Result<Option<&'a str>> {
        match self.find(name, &[ty])? {
            None => Ok(None),
            Some(p) => match &p.values {
                Values::Strings(s) if s.len() == 1 => Ok(Some(&s[0])),
                _ => Err(self.error(p, format!("parameter '{name}' needs one string"))),
            },
        }
    }

    /// The `string` called `name`, if given.
    pub fn string(&self, name: &str) -> Result<Option<&'a str>> {
        self.text(name, "string")
    }

    /// Three numbers of `name` (type `ty`) as a vector, if given.
    pub fn vec3(&self, name: &str, ty: &str) -> Result<Option<Vec3>> {
        let Some(v) = self.numbers(name, ty)? else {
            return Ok(None);
        };
        if v.len() != 3 {
            let p = self.find(name, &[ty])?.expect("found above");
            return Err(self.error(
                p,
                format!("parameter '{name}' needs 3 values, not {}", v.len()),
            ));
        }
        Ok(Some(Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)))
    }

    /// A colour parameter (`rgb`, `spectrum`, `blackbody`, or `texture`), if given; spectra
    /// become RGB ([`super::spectra`]).
    pub fn colour(&self, name: &str) -> Result<Option<Colour>> {
        let Some(p) = self.find(name, &["rgb", "spectrum", "blackbody", "texture", "float"])?
        else {
            return Ok(None);
        };
        let at = |msg: String| self.error(p, msg);
        let colour = match (p.ty.as_str(), &p.values) {
            ("rgb", Values::Numbers(v)) if v.len() == 3 => {
                Rgb::new(v[0] as f32, v[1] as f32, v[2] as f32)
            }
            ("float", Values::Numbers(v)) if v.len() == 1 => Rgb::splat(v[0] as f32),
            ("blackbody", Values::Numbers(v)) if v.len() == 1 => {
                super::spectra::blackbody_rgb(v[0]).ok_or_else(|| {
                    at(format!(
                        "parameter '{name}': blackbody temperature {} is not positive",
                        v[0]
                    ))
                })?
            }
            ("spectrum", Values::Numbers(v)) => super::spectra::sampled_rgb(v)
                .map_err(|e| at(format!("parameter '{name}': {e}")))?,
            ("spectrum", Values::Strings(s)) if s.len() == 1 => {
                match super::spectra::named_rgb(&s[0]) {
                    Some(c) => c,
                    None => {
                        return Err(at(format!(
                            "parameter '{name}': unknown named spectrum '{}'",
                            s[0]
                        )))
                    }
                }
            }
            ("texture", Values::Strings(s)) if s.len() == 1 => {
                return Ok(Some(Colour::Texture(s[0].clone())))
            }
            (ty, _) => return Err(at(format!("parameter '{name}': malformed {ty} value"))),
        };
        Ok(Some(Colour::Rgb(colour)))
    }

    /// One warning per parameter no lookup used, naming file, line and directive.
    pub fn unused(&self) -> Vec<String> {
        self.directive
            .params
            .iter()
            .zip(&self.used)
            .filter(|(_, u)| !u.get())
            .map(|(p, _)| {
                format!(
                    "{}:{}: parameter \"{} {}\" of {} is not used",
                    self.directive.file.display(),
                    p.loc,
                    p.ty,
                    p.name,
                    self.directive.name
                )
            })
            .collect()
    }

    /// Marks `names` used without reading them (parameters that are deliberately ignored,
    /// such as the output file name).
    pub fn ignore(&self, names: &[&str]) {
        for (p, u) in self.directive.params.iter().zip(&self.used) {
            if names.contains(&p.name.as_str()) {
                u.set(true);
            }
        }
    }
}
