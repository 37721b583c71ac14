//! The typed render options of the option table's choices, and back: what the render
//! session takes from [`Choices`], checked as a whole ([`RenderOptions::validate`]).

use super::{Adaptive, RenderOptions};
use crate::error::{Error, Result};
use crate::film::Cell;
use crate::options::{check, Choices, Value};
use crate::vertex::Direct;

impl Choices {
    /// The render options these choices give.
    pub fn render_options(&self) -> RenderOptions {
        let u32_of = |name: &str| self.int(name).unwrap_or(0) as u32;
        let ints = |name: &str| -> Option<Vec<u32>> {
            self.list(name)
                .map(|l| l.iter().map(|v| v.as_int().unwrap_or(0) as u32).collect())
        };
        RenderOptions {
            width: u32_of("width"),
            height: u32_of("height"),
            spp: u32_of("spp"),
            threads: self.int("threads").map(|t| t as usize),
            seed: self.int("seed").unwrap_or(0) as u64,
            integrator: self.integrator_settings(),
            sampler: self.text("sampler").parse().unwrap_or_default(),
            filter: self.filter(),
            adaptive: self.list("adaptive").map(|l| Adaptive {
                batch: l[0].as_int().unwrap_or(1) as u32,
                tolerance: l[1].as_real().unwrap_or(0.0) as f32,
            }),
            adaptive_budget: self.flag("adaptive_budget"),
            cell: ints("cell").map(|c| Cell {
                x: c[0],
                y: c[1],
                w: c[2],
                h: c[3],
            }),
            time_limit: self.real("time_limit"),
            sample_range: ints("sample_range").map(|r| (r[0], r[1])),
            env_guiding: self.text("env_guiding") == "on",
            features: self.flag("features") || self.flag("denoise"),
            denoise: self.flag("denoise"),
        }
    }
}

impl RenderOptions {
    /// The options as `(name, value)` pairs of the vocabulary (unset ones left out).
    pub fn values(&self) -> Vec<(&'static str, Value)> {
        let int = |v: u32| Value::Int(v as i128);
        let it = &self.integrator;
        let mut out = vec![
            ("spp", int(self.spp)),
            ("light_samples", int(it.light_samples)),
            ("max_depth", int(it.max_depth)),
            ("accumulate", Value::Bool(it.accumulate)),
            ("hemisphere", Value::Bool(it.direct == Direct::Hemisphere)),
            ("light_selection", Value::Text(it.selection.to_string())),
            ("sampler", Value::Text(self.sampler.to_string())),
            ("filter", Value::Text(self.filter.kind.to_string())),
            (
                "filter_sampling",
                Value::Text(
                    if self.filter.splat {
                        "splat"
                    } else {
                        "importance"
                    }
                    .into(),
                ),
            ),
            (
                "caustics",
                Value::Text(if it.light_tracing { "light" } else { "path" }.into()),
            ),
            ("rr_depth", int(it.rr_depth)),
            ("rr_survival", Value::Real(it.rr_survival as f64)),
            ("seed", Value::Int(self.seed as i128)),
            ("width", int(self.width)),
            ("height", int(self.height)),
            ("adaptive_budget", Value::Bool(self.adaptive_budget)),
            (
                "env_guiding",
                Value::Text(if self.env_guiding { "on" } else { "off" }.into()),
            ),
            ("features", Value::Bool(self.features)),
            ("denoise", Value::Bool(self.denoise)),
        ];
        if it.direct != Direct::Hemisphere {
            out.push(("direct", Value::Text(it.direct.to_string())));
        }
        if self.filter.radius != self.filter.kind.default_radius() {
            out.push(("filter_radius", Value::Real(self.filter.radius as f64)));
        }
        if let Some(t) = self.threads {
            out.push(("threads", Value::Int(t as i128)));
        }
        if let Some(t) = self.time_limit {
            out.push(("time_limit", Value::Real(t)));
        }
        if let Some(a) = self.adaptive {
            out.push((
                "adaptive",
                Value::List(vec![int(a.batch), Value::Real(a.tolerance as f64)]),
            ));
        }
        if let Some(c) = self.cell {
            out.push(("cell", Value::List([c.x, c.y, c.w, c.h].map(int).to_vec())));
        }
        if let Some((first, count)) = self.sample_range {
            out.push(("sample_range", Value::List(vec![int(first), int(count)])));
        }
        out
    }

    /// Checks every option against the vocabulary and the rules between options; the error
    /// names the option(s), not a flag.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in self.values() {
            check(name, &v)?;
        }
        if self.adaptive.is_some() && self.time_limit.is_some() {
            return Err(Error::Usage(
                "adaptive (CS184's adaptive sampling) and time_limit cannot be combined".into(),
            ));
        }
        if self.adaptive_budget && self.adaptive.is_some() {
            return Err(Error::Usage(
                "adaptive_budget and adaptive cannot be combined".into(),
            ));
        }
        if self.adaptive_budget && self.spp < 2 {
            return Err(Error::Usage(format!(
                "adaptive_budget needs spp of at least 2, not {}",
                self.spp
            )));
        }
        let (first, count) = self.sample_range.unwrap_or((0, self.spp));
        if count == 0 || first as u64 + count as u64 > self.spp as u64 {
            return Err(Error::Usage(format!(
                "sample_range {first}..{} is empty or beyond spp {}",
                first as u64 + count as u64,
                self.spp
            )));
        }
        if (self.adaptive.is_some() || self.adaptive_budget)
            && self.cell.is_some()
            && self.filter.spreads()
        {
            return Err(Error::Usage(
                "adaptive sampling (adaptive, adaptive_budget) cannot render a cell with splatted \
                 samples (filter_sampling splat): the pixels around the cell would take other \
                 samples than in the whole frame"
                    .into(),
            ));
        }
        if (self.adaptive.is_some() || self.adaptive_budget) && count != self.spp {
            return Err(Error::Usage(
                "adaptive sampling (adaptive, adaptive_budget) cannot render a part of the \
                 sample_range"
                    .into(),
            ));
        }
        if let Some(c) = self.cell {
            if c.x as u64 + c.w as u64 > self.width as u64
                || c.y as u64 + c.h as u64 > self.height as u64
            {
                return Err(Error::Usage(format!(
                    "cell {}x{} at ({}, {}) does not fit in the {}x{} frame",
                    c.w, c.h, c.x, c.y, self.width, self.height
                )));
            }
        }
        Ok(())
    }

    /// What a film rendered with these options belongs to, as far as the options go: every
    /// option that changes pixels (not the thread count, time limit or sample range), as
    /// `(key, value)` lines. [`crate::setup::identity`] adds the scene's files and camera.
    pub fn identity(&self) -> Vec<(String, String)> {
        let it = &self.integrator;
        let line = |k: &str, v: String| (k.to_string(), v);
        let mut lines = vec![
            line("size", format!("{}x{}", self.width, self.height)),
            line(
                "cell",
                self.cell.map_or("none".into(), |c| {
                    format!("{} {} {} {}", c.x, c.y, c.w, c.h)
                }),
            ),
            line("spp", self.spp.to_string()),
            line("seed", self.seed.to_string()),
            line("sampler", self.sampler.name().to_string()),
            line(
                "filter",
                // Splatting only where it is asked for, so that other films keep their identity.
                format!(
                    "{} {}{}",
                    self.filter.kind,
                    self.filter.radius,
                    if self.filter.splat { " splat" } else { "" }
                ),
            ),
            line("max-depth", it.max_depth.to_string()),
            line("accumulate", it.accumulate.to_string()),
            line("light-samples", it.light_samples.to_string()),
            line("direct", format!("{:?}", it.direct)),
            line("light-selection", format!("{:?}", it.selection)),
            line("rr-depth", it.rr_depth.to_string()),
            line("light-tracing", it.light_tracing.to_string()),
            line(
                "adaptive",
                self.adaptive
                    .map_or("none".into(), |a| format!("{} {}", a.batch, a.tolerance)),
            ),
            line("adaptive-budget", self.adaptive_budget.to_string()),
            line("env-guiding", self.env_guiding.to_string()),
        ];
        // Only where they are recorded or not the default, so that other films keep their
        // identity.
        if self.features {
            lines.push(line("features", "true".into()));
        }
        if it.rr_survival != crate::vertex::RR_SURVIVAL {
            lines.push(line("rr-survival", it.rr_survival.to_string()));
        }
        lines
    }
}
