//! What the user can change while viewing: the viewer's settings, their JSON form
//! (`POST /api/settings`, `GET /api/state`) and their checks, which are the option table's
//! ([`crate::options`]): the same names, ranges and messages as every other shell.

use crate::film::Cell;
use crate::integrator::Direct;
use crate::options::{self, Kind, Value};
use crate::render::RenderOptions;
use crate::sampling::sampler::SamplerKind;
use serde::{Deserialize, Serialize};

/// The settings; each field is an option of the table whose `json` field is its name.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    /// Target samples per pixel (CS184 keys `]` and `[`).
    pub spp: u32,
    /// Maximum ray depth (`.` and `,`).
    pub max_depth: u32,
    /// Light samples (`=` and `-`).
    pub light_samples: u32,
    /// Hemisphere sampling for direct light (`h`); it overrides `estimator`.
    pub hemisphere: bool,
    /// Thin-lens radius (`k` and `l`).
    pub lens_radius: f32,
    /// Focal distance (`;` and `'`).
    pub focal_distance: f32,
    /// The sampler: `sobol`, `zsobol` or `independent`.
    pub sampler: String,
    /// The direct-light estimator (the option `direct`): `mis`, `light` or `bsdf`.
    pub estimator: String,
    /// The cell rendered (`C`): left, top, width, height in pixels; `None` is the whole frame.
    pub cell: Option<[u32; 4]>,
    /// Record denoising features and denoise the latest pass in the background (`n`).
    pub denoise: bool,
}

/// The JSON fields of [`Settings`], in its order (each the `json` field of an option).
pub const FIELDS: [&str; 10] = [
    "spp",
    "max_depth",
    "light_samples",
    "hemisphere",
    "lens_radius",
    "focal_distance",
    "sampler",
    "estimator",
    "cell",
    "denoise",
];

/// A partial update of [`Settings`] as a client sends it: a JSON object of some of its
/// fields. A `cell` of zero width or height means the whole frame.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(transparent)]
pub struct SettingsUpdate(serde_json::Map<String, serde_json::Value>);

impl SettingsUpdate {
    /// Whether the update sets the switch `field` to true.
    pub fn turns_on(&self, field: &str) -> bool {
        self.0.get(field) == Some(&serde_json::Value::Bool(true))
    }
}

/// Why an update was refused.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// An unknown field, or a value of the wrong type (HTTP 400).
    Malformed(String),
    /// A value out of its option's range (HTTP 422).
    OutOfRange(String),
}

/// A JSON value as an option value of kind `kind`, or `None` when its type does not fit.
fn json_value(kind: &Kind, j: &serde_json::Value) -> Option<Value> {
    use serde_json::Value as J;
    match (kind, j) {
        (Kind::Int { .. }, J::Number(n)) => n
            .as_i64()
            .map(i128::from)
            .or_else(|| n.as_u64().map(i128::from))
            // An integer beyond 64 bits arrives as a float: out of range, shown as given (a
            // float of small magnitude is a wrong type, as before).
            .or_else(|| {
                n.as_f64()
                    .filter(|x| x.fract() == 0.0 && x.abs() >= 2f64.powi(63))
                    .map(|x| x as i128)
            })
            .map(Value::Int),
        (Kind::Real { .. }, J::Number(n)) => n.as_f64().map(Value::Real),
        (Kind::Switch | Kind::Bit, J::Bool(b)) => Some(Value::Bool(*b)),
        (Kind::Choice(_), J::String(s)) => Some(Value::Text(s.clone())),
        (Kind::Tuple(parts), J::Array(items)) => items
            .iter()
            .zip(parts.iter())
            .map(|(x, (_, k))| json_value(k, x))
            .collect::<Option<Vec<_>>>()
            .filter(|l| l.len() == items.len())
            .map(Value::List),
        _ => None,
    }
}

impl Settings {
    /// The settings of the command line's options `opts` and the scene's lens.
    pub fn new(opts: &RenderOptions, lens_radius: f32, focal_distance: f32) -> Settings {
        let direct = match opts.integrator.direct {
            Direct::Hemisphere => Direct::Mis,
            d => d,
        };
        Settings {
            spp: opts.spp,
            max_depth: opts.integrator.max_depth,
            light_samples: opts.integrator.light_samples,
            hemisphere: opts.integrator.direct == Direct::Hemisphere,
            lens_radius,
            focal_distance,
            sampler: opts.sampler.to_string(),
            estimator: direct.to_string(),
            cell: opts.cell.map(|c| [c.x, c.y, c.w, c.h]),
            denoise: opts.denoise,
        }
    }

    /// The settings with `u` applied, or why it is refused (naming the option); `frame` is
    /// the image size that a cell must lie in.
    pub fn apply(&self, u: &SettingsUpdate, frame: (u32, u32)) -> Result<Settings, Refusal> {
        let mut s = self.clone();
        for (field, json) in &u.0 {
            let spec = FIELDS
                .contains(&field.as_str())
                .then(|| options::spec_of_json(field))
                .flatten()
                .ok_or_else(|| {
                    Refusal::Malformed(format!(
                        "unknown setting '{field}' (the settings are {})",
                        FIELDS.join(", ")
                    ))
                })?;
            if field == "cell" && cell_is_whole_frame(json) {
                s.cell = None;
                continue;
            }
            let v = json_value(&spec.kind, json).ok_or_else(|| {
                Refusal::Malformed(format!(
                    "{} must be {}, not {json}",
                    spec.name,
                    spec.kind.describe()
                ))
            })?;
            let v = spec
                .kind
                .check(spec.name, &v)
                .map_err(Refusal::OutOfRange)?;
            s.set(field, &v, frame)?;
        }
        Ok(s)
    }

    /// Sets field `field` to the checked value `v`.
    fn set(&mut self, field: &str, v: &Value, frame: (u32, u32)) -> Result<(), Refusal> {
        let int = || v.as_int().unwrap_or(0) as u32;
        let real = || v.as_real().unwrap_or(0.0) as f32;
        let text = || v.as_text().unwrap_or("").to_string();
        match field {
            "spp" => self.spp = int(),
            "max_depth" => self.max_depth = int(),
            "light_samples" => self.light_samples = int(),
            "hemisphere" => self.hemisphere = v.as_bool().unwrap_or(false),
            "denoise" => self.denoise = v.as_bool().unwrap_or(false),
            "lens_radius" => self.lens_radius = real(),
            "focal_distance" => self.focal_distance = real(),
            "sampler" => self.sampler = text(),
            "estimator" => self.estimator = text(),
            _ => {
                let c: Vec<u32> = v
                    .as_list()
                    .unwrap_or(&[])
                    .iter()
                    .map(|x| x.as_int().unwrap_or(0) as u32)
                    .collect();
                let [x, y, w, h] = [c[0], c[1], c[2], c[3]];
                if x as u64 + w as u64 > frame.0 as u64 || y as u64 + h as u64 > frame.1 as u64 {
                    return Err(Refusal::OutOfRange(format!(
                        "cell {x} {y} {w} {h} is not inside the {}x{} frame",
                        frame.0, frame.1
                    )));
                }
                self.cell = Some([x, y, w, h]);
            }
        }
        Ok(())
    }

    /// The render options of these settings over the command line's `base`.
    pub fn options(&self, base: &RenderOptions) -> RenderOptions {
        let mut o = base.clone();
        o.spp = self.spp;
        o.integrator.max_depth = self.max_depth;
        o.integrator.light_samples = self.light_samples;
        o.integrator.direct = if self.hemisphere {
            Direct::Hemisphere
        } else {
            self.estimator.parse().unwrap_or(Direct::Mis)
        };
        o.sampler = self.sampler.parse().unwrap_or(SamplerKind::Sobol);
        o.cell = self.cell.map(|[x, y, w, h]| Cell { x, y, w, h });
        o.features = self.denoise;
        o.denoise = self.denoise;
        // The viewer renders uniform passes of the whole sample range.
        o.adaptive = None;
        o.adaptive_budget = false;
        o.time_limit = None;
        o.sample_range = None;
        o
    }
}

/// A `cell` of zero width or height: the whole frame.
fn cell_is_whole_frame(j: &serde_json::Value) -> bool {
    j.as_array()
        .is_some_and(|a| a.len() == 4 && (a[2].as_u64() == Some(0) || a[3].as_u64() == Some(0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_are_the_option_tables() {
        // Every JSON field of the table is a field of Settings, and the other way round.
        let table: Vec<&str> = options::OPTIONS.iter().filter_map(|s| s.json).collect();
        let mut sorted = FIELDS.to_vec();
        sorted.sort();
        let mut t = table.clone();
        t.sort();
        assert_eq!(sorted, t);
        let s = Settings::new(&RenderOptions::default(), 0.0, 1.0);
        let json = serde_json::to_value(&s).unwrap();
        let keys: Vec<&str> = json
            .as_object()
            .unwrap()
            .keys()
            .map(|k| k.as_str())
            .collect();
        let mut keys = keys.clone();
        keys.sort();
        assert_eq!(keys, sorted);
    }
}
