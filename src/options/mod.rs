//! The render options' vocabulary, written once: every option's name, command-line flag,
//! Python keyword, viewer JSON field, default, allowed range or values and one line of help
//! ([`OPTIONS`]). The command line ([`args`]), the Python module, the viewer's settings and the
//! farm derive their options from this table or are checked against it, so that every shell
//! accepts the same names, defaults and ranges and refuses a bad value with the same message,
//! which names the option (not a flag).
//!
//! Values come in as [`Value`]s (each shell converts its own: text from the command line,
//! Python objects, JSON) and are checked by [`check`]. [`Choices`] holds one value per option
//! and resolves them with one precedence: built-in default < value from the scene file < value
//! the user gives ([`Choices::resolve`]); it then gives the typed `RenderOptions`, the
//! camera choices (`View`) and the environment sampling.

pub mod args;

use crate::error::{Error, Result};
use crate::filter::{FilterKind, PixelFilter};
pub use crate::io::desc::Value;
use crate::light::env::EnvSampling;
use crate::sampling::sampler::SamplerKind;
use std::fmt;

/// What values an option takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// An integer in `min..=max`.
    Int {
        /// Smallest value.
        min: i128,
        /// Largest value.
        max: i128,
    },
    /// A finite number above `min` (or equal to it when `closed`) and below `max`, if any.
    Real {
        /// Lower bound.
        min: f64,
        /// Whether `min` itself is allowed.
        closed: bool,
        /// Upper bound (excluded), if any.
        max: Option<f64>,
    },
    /// On or off; on the command line a flag without a value (`-H`).
    Switch,
    /// On or off; on the command line `0` or `1` (`-o`).
    Bit,
    /// One of these names.
    Choice(&'static [&'static str]),
    /// A fixed number of values, each with its name and kind (`-a BATCH TOL`).
    Tuple(&'static [(&'static str, Kind)]),
}

/// Where the Python module takes an option.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Place {
    /// A keyword of `render`, `render_film` and `aux`.
    Render,
    /// A keyword of `render` and an attribute of `Camera` (it moves the scene's camera).
    Camera,
    /// A keyword of `load` (it changes how the scene is built).
    Load,
}

/// A built-in default.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Default {
    /// This value.
    Is(Const),
    /// No value: what then happens, in words ("all cores", "the scene's").
    Unset(&'static str),
}

/// A constant value of the table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Const {
    /// An integer.
    Int(i128),
    /// On or off.
    Bool(bool),
    /// A name.
    Text(&'static str),
    /// A number.
    Real(f64),
}

impl From<Const> for Value {
    fn from(c: Const) -> Value {
        match c {
            Const::Int(i) => Value::Int(i),
            Const::Bool(b) => Value::Bool(b),
            Const::Text(t) => Value::Text(t.to_string()),
            Const::Real(r) => Value::Real(r),
        }
    }
}

/// One option of the vocabulary.
#[derive(Clone, Copy, Debug)]
pub struct Spec {
    /// The option's name, in messages and as the Python keyword (`max_depth`).
    pub name: &'static str,
    /// The command-line flag (`-m`, `--rr-depth`); `None`: not on the command line.
    pub flag: Option<&'static str>,
    /// The names of the flag's values (`N`); empty for a switch.
    pub values: &'static [&'static str],
    /// `Some(i)`: the option is value `i` of a flag shared with others (`-r W H`).
    pub part: Option<usize>,
    /// Whether and where Python takes it (its keyword is [`Spec::name`]).
    pub python: Option<Place>,
    /// The field of the viewer's `POST /api/settings`, if the viewer can change it.
    pub json: Option<&'static str>,
    /// The built-in default.
    pub default: Default,
    /// The values it takes.
    pub kind: Kind,
    /// One line of help.
    pub help: &'static str,
}

const U32: i128 = u32::MAX as i128;

/// Default hit index from which Russian roulette may end a path (`rr_depth`).
pub const RR_START_DEPTH: u32 = 5;

/// Default survival scale of Russian roulette (`rr_survival`): a path continues with
/// probability `min(1, RR_SURVIVAL · max(throughput) · η²)`. Mitsuba's and pbrt-v4's rule is
/// 1; 3 keeps more paths alive for a lower error per ray on the CS184 scenes (the measurement
/// is in `docs/performance.md`).
pub const RR_SURVIVAL: f32 = 3.0;

/// The vocabulary: every render option, in the order of the command line's help.
pub const OPTIONS: &[Spec] = &[
    Spec {
        name: "spp",
        flag: Some("-s"),
        values: &["N"],
        part: None,
        python: Some(Place::Render),
        json: Some("spp"),
        default: Default::Is(Const::Int(16)),
        kind: Kind::Int {
            min: 1,
            max: 1_000_000,
        },
        help: "Camera samples per pixel (the mean with --adaptive-budget, the most with -a)",
    },
    Spec {
        name: "light_samples",
        flag: Some("-l"),
        values: &["N"],
        part: None,
        python: Some(Place::Render),
        json: Some("light_samples"),
        default: Default::Is(Const::Int(1)),
        kind: Kind::Int {
            min: 1,
            max: 100_000,
        },
        help: "Samples per area light for direct lighting",
    },
    Spec {
        name: "max_depth",
        flag: Some("-m"),
        values: &["N"],
        part: None,
        python: Some(Place::Render),
        json: Some("max_depth"),
        default: Default::Is(Const::Int(5)),
        kind: Kind::Int {
            min: 0,
            max: 100_000,
        },
        help: "Maximum ray depth: 0 emitters only, 1 direct light, each step one more bounce",
    },
    Spec {
        name: "accumulate",
        flag: Some("-o"),
        values: &["0|1"],
        part: None,
        python: Some(Place::Render),
        json: None,
        default: Default::Is(Const::Bool(true)),
        kind: Kind::Bit,
        help: "1: accumulate all bounces up to -m; 0: only the -m-th bounce",
    },
    Spec {
        name: "hemisphere",
        flag: Some("-H"),
        values: &[],
        part: None,
        python: Some(Place::Render),
        json: Some("hemisphere"),
        default: Default::Is(Const::Bool(false)),
        kind: Kind::Switch,
        help: "Estimate direct light by uniform hemisphere sampling (overrides --direct)",
    },
    Spec {
        name: "direct",
        flag: Some("--direct"),
        values: &["mis|light|bsdf"],
        part: None,
        python: Some(Place::Render),
        json: Some("estimator"),
        default: Default::Is(Const::Text("mis")),
        kind: Kind::Choice(&["mis", "light", "bsdf"]),
        help: "Direct-light estimator: light and BSDF sampling by MIS, light only, BSDF only",
    },
    Spec {
        name: "light_selection",
        flag: Some("--light-selection"),
        values: &["power|all"],
        part: None,
        python: Some(Place::Render),
        json: None,
        default: Default::Is(Const::Text("power")),
        kind: Kind::Choice(&["power", "all"]),
        help: "Each light sample picks one light by power, or every light gets -l samples",
    },
    Spec {
        name: "sampler",
        flag: Some("--sampler"),
        values: &["sobol|zsobol|independent"],
        part: None,
        python: Some(Place::Render),
        json: Some("sampler"),
        default: Default::Is(Const::Text("sobol")),
        kind: Kind::Choice(&["sobol", "zsobol", "independent"]),
        help: "Point set of the camera samples (Owen-scrambled Sobol, its Morton order, random)",
    },
    Spec {
        name: "filter",
        flag: Some("--filter"),
        values: &["box|triangle|gaussian"],
        part: None,
        python: Some(Place::Render),
        json: None,
        default: Default::Is(Const::Text("box")),
        kind: Kind::Choice(&["box", "triangle", "gaussian"]),
        help: "Pixel filter (pbrt-v4's shapes; a pbrt-v4 file's PixelFilter, a Mitsuba film's \
               rfilter)",
    },
    Spec {
        name: "filter_radius",
        flag: Some("--filter-radius"),
        values: &["PIXELS"],
        part: None,
        python: Some(Place::Render),
        json: None,
        default: Default::Unset("the filter's own: box 0.5, triangle 2, gaussian 1.5"),
        kind: Kind::Real {
            min: 0.0,
            closed: false,
            max: Some(16.0),
        },
        help: "Radius of the pixel filter in pixels",
    },
    Spec {
        name: "filter_sampling",
        flag: Some("--filter-sampling"),
        values: &["importance|splat"],
        part: None,
        python: Some(Place::Render),
        json: None,
        default: Default::Is(Const::Text("importance")),
        kind: Kind::Choice(&["importance", "splat"]),
        help: "How the filter applies: offsets drawn from it, each sample in its own pixel \
               (pbrt-v4), or samples splatted into the pixels it reaches (Mitsuba's files)",
    },
    Spec {
        name: "caustics",
        flag: Some("--caustics"),
        values: &["light|path"],
        part: None,
        python: Some(Place::Render),
        json: None,
        default: Default::Is(Const::Text("light")),
        kind: Kind::Choice(&["light", "path"]),
        help: "Caustics through mirrors, glass and smooth metal: traced from the lights, or by \
               path tracing only",
    },
    Spec {
        name: "rr_depth",
        flag: Some("--rr-depth"),
        values: &["N"],
        part: None,
        python: Some(Place::Render),
        json: None,
        default: Default::Is(Const::Int(RR_START_DEPTH as i128)),
        kind: Kind::Int { min: 1, max: U32 },
        help: "Hit index from which Russian roulette may end paths",
    },
    Spec {
        name: "rr_survival",
        flag: Some("--rr-survival"),
        values: &["S"],
        part: None,
        python: Some(Place::Render),
        json: None,
        default: Default::Is(Const::Real(RR_SURVIVAL as f64)),
        kind: Kind::Real {
            min: 0.0,
            closed: false,
            max: None,
        },
        help: "Russian roulette continues a path with probability min(1, S x throughput); \
               1 is pbrt-v4's and Mitsuba's rule (shorter paths, more noise per sample)",
    },
    Spec {
        name: "seed",
        flag: Some("--seed"),
        values: &["N"],
        part: None,
        python: Some(Place::Render),
        json: None,
        default: Default::Is(Const::Int(0)),
        kind: Kind::Int {
            min: 0,
            max: u64::MAX as i128,
        },
        help: "Seed of the random streams; the same seed gives the same image on any thread count",
    },
    Spec {
        name: "threads",
        flag: Some("-t"),
        values: &["N"],
        part: None,
        python: Some(Place::Render),
        json: None,
        default: Default::Unset("all cores"),
        kind: Kind::Int { min: 1, max: 1024 },
        help: "Worker threads",
    },
    Spec {
        name: "width",
        flag: Some("-r"),
        values: &["W", "H"],
        part: Some(0),
        python: Some(Place::Render),
        json: None,
        default: Default::Is(Const::Int(480)),
        kind: Kind::Int {
            min: 1,
            max: 65_536,
        },
        help: "Image width in pixels",
    },
    Spec {
        name: "height",
        flag: Some("-r"),
        values: &["W", "H"],
        part: Some(1),
        python: Some(Place::Render),
        json: None,
        default: Default::Is(Const::Int(360)),
        kind: Kind::Int {
            min: 1,
            max: 65_536,
        },
        help: "Image height in pixels",
    },
    Spec {
        name: "time_limit",
        flag: Some("--time-limit"),
        values: &["SECONDS"],
        part: None,
        python: Some(Place::Render),
        json: None,
        default: Default::Unset("none"),
        kind: Kind::Real {
            min: 0.0,
            closed: false,
            max: None,
        },
        help: "Render passes of one sample per pixel until this many seconds have passed (or -s \
               is reached); N passes equal an N-spp render",
    },
    Spec {
        name: "adaptive",
        flag: Some("-a"),
        values: &["BATCH", "TOL"],
        part: None,
        python: Some(Place::Render),
        json: None,
        default: Default::Unset("off"),
        kind: Kind::Tuple(&[
            ("BATCH", Kind::Int { min: 1, max: U32 }),
            (
                "TOL",
                Kind::Real {
                    min: 0.0,
                    closed: false,
                    max: None,
                },
            ),
        ]),
        help: "CS184 adaptive sampling: check every BATCH samples, stop when 1.96·σ/√n ≤ TOL·μ",
    },
    Spec {
        name: "adaptive_budget",
        flag: Some("--adaptive-budget"),
        values: &[],
        part: None,
        python: Some(Place::Render),
        json: None,
        default: Default::Is(Const::Bool(false)),
        kind: Kind::Switch,
        help: "-s is the mean samples per pixel, spent where it lowers the mean relative MSE; \
               writes NAME_rate.png",
    },
    Spec {
        name: "cell",
        flag: Some("-p"),
        values: &["X", "Y", "DX", "DY"],
        part: None,
        python: Some(Place::Render),
        json: Some("cell"),
        default: Default::Unset("the whole frame"),
        kind: Kind::Tuple(&[
            ("X", COUNT_U32),
            ("Y", COUNT_U32),
            ("DX", POSITIVE_U32),
            ("DY", POSITIVE_U32),
        ]),
        help: "Render only the DX×DY cell whose top-left pixel is (X, Y)",
    },
    Spec {
        name: "sample_range",
        flag: None,
        values: &["FIRST", "COUNT"],
        part: None,
        python: Some(Place::Render),
        json: None,
        default: Default::Unset("all samples"),
        kind: Kind::Tuple(&[("FIRST", COUNT_U32), ("COUNT", POSITIVE_U32)]),
        help: "Only the samples [FIRST, FIRST + COUNT) of every pixel (films of adjacent ranges \
               merge)",
    },
    Spec {
        name: "lens_radius",
        flag: Some("-b"),
        values: &["RADIUS"],
        part: None,
        python: Some(Place::Camera),
        json: Some("lens_radius"),
        default: Default::Unset("the scene's (0: pinhole)"),
        kind: Kind::Real {
            min: 0.0,
            closed: true,
            max: Some(1e6),
        },
        help: "Thin-lens radius in scene units (0: pinhole)",
    },
    Spec {
        name: "focal_distance",
        flag: Some("-d"),
        values: &["DIST"],
        part: None,
        python: Some(Place::Camera),
        json: Some("focal_distance"),
        default: Default::Unset("the distance to the scene centre"),
        kind: Kind::Real {
            min: 0.0,
            closed: false,
            max: Some(1e9),
        },
        help: "Focal distance in scene units along the viewing direction",
    },
    Spec {
        name: "fov",
        flag: Some("--fov"),
        values: &["DEGREES"],
        part: None,
        python: Some(Place::Camera),
        json: None,
        default: Default::Unset("the scene's"),
        kind: Kind::Real {
            min: 0.0,
            closed: false,
            max: Some(180.0),
        },
        help: "Vertical field of view in degrees over the image's height (pbrt/Mitsuba convention)",
    },
    Spec {
        name: "lookat",
        flag: Some("--lookat"),
        values: &["EX", "EY", "EZ", "TX", "TY", "TZ", "UX", "UY", "UZ"],
        part: None,
        python: Some(Place::Camera),
        json: None,
        default: Default::Unset("the scene's camera"),
        kind: Kind::Tuple(&[
            ("EX", ANY_REAL),
            ("EY", ANY_REAL),
            ("EZ", ANY_REAL),
            ("TX", ANY_REAL),
            ("TY", ANY_REAL),
            ("TZ", ANY_REAL),
            ("UX", ANY_REAL),
            ("UY", ANY_REAL),
            ("UZ", ANY_REAL),
        ]),
        help: "Camera at EYE looking at TARGET with UP as up; the field of view stays the scene's",
    },
    Spec {
        name: "env_sampling",
        flag: Some("--env-sampling"),
        values: &["importance|uniform"],
        part: None,
        python: Some(Place::Load),
        json: None,
        default: Default::Is(Const::Text("importance")),
        kind: Kind::Choice(&["importance", "uniform"]),
        help: "How the environment light is sampled: by luminance, or uniformly",
    },
    Spec {
        name: "env_guiding",
        flag: Some("--env-guiding"),
        values: &["on|off"],
        part: None,
        python: Some(Place::Render),
        json: None,
        default: Default::Is(Const::Text("on")),
        kind: Kind::Choice(&["on", "off"]),
        help: "Environment light samples learned per region of the scene in a short training \
               run before the render, so that they go through windows and openings rather than \
               at walls; off: the map's own importance sampling everywhere",
    },
    Spec {
        name: "features",
        flag: Some("--features"),
        values: &[],
        part: None,
        python: Some(Place::Render),
        json: None,
        default: Default::Is(Const::Bool(false)),
        kind: Kind::Switch,
        help: "Record denoising features in the film: per pixel the mean albedo and normal at \
               the first surface past mirrors and smooth glass (written beside the image as \
               NAME_albedo.exr and NAME_normal.exr)",
    },
    Spec {
        name: "denoise",
        flag: Some("--denoise"),
        values: &[],
        part: None,
        python: Some(Place::Render),
        json: Some("denoise"),
        default: Default::Is(Const::Bool(false)),
        kind: Kind::Switch,
        help: "Denoise the image with Open Image Denoise 2 (pip install pyoidn) on its albedo \
               and normal features; the noisy image is written beside it as NAME_noisy.exr (the \
               viewer denoises its latest pass in the background)",
    },
    Spec {
        name: "no_default_light",
        flag: Some("--no-default-light"),
        values: &[],
        part: None,
        python: Some(Place::Load),
        json: None,
        default: Default::Is(Const::Bool(false)),
        kind: Kind::Switch,
        help: "Leave an OBJ, PLY or glTF file without lights unlit (not lit by the studio light)",
    },
];

const COUNT_U32: Kind = Kind::Int { min: 0, max: U32 };
const POSITIVE_U32: Kind = Kind::Int { min: 1, max: U32 };
const ANY_REAL: Kind = Kind::Real {
    min: f64::NEG_INFINITY,
    closed: false,
    max: None,
};

/// The option called `name`.
pub fn spec(name: &str) -> Option<&'static Spec> {
    OPTIONS.iter().find(|s| s.name == name)
}

/// The option whose viewer JSON field is `field`.
pub fn spec_of_json(field: &str) -> Option<&'static Spec> {
    OPTIONS.iter().find(|s| s.json == Some(field))
}

impl Kind {
    /// The value of command-line text for an option of this kind (one value of a tuple:
    /// the element's kind), unchecked beyond its syntax.
    pub fn parse(&self, text: &str) -> std::result::Result<Value, String> {
        match self {
            Kind::Int { .. } | Kind::Bit => text
                .trim()
                .parse::<i128>()
                .map(Value::Int)
                .map_err(|_| format!("'{text}' is not an integer")),
            Kind::Real { .. } => text
                .trim()
                .parse::<f64>()
                .map(Value::Real)
                .map_err(|_| format!("'{text}' is not a number")),
            Kind::Switch => match text {
                "true" | "1" => Ok(Value::Bool(true)),
                "false" | "0" => Ok(Value::Bool(false)),
                _ => Err(format!("'{text}' is not true or false")),
            },
            Kind::Choice(_) => Ok(Value::Text(text.to_string())),
            Kind::Tuple(_) => Err("a tuple is given as several values".into()),
        }
    }

    /// The allowed values in words ("an integer in 1..=1000000").
    pub fn describe(&self) -> String {
        match self {
            Kind::Int { min, max } => format!("an integer in {min}..={max}"),
            Kind::Real { min, closed, max } => {
                let low = match (min.is_finite(), closed) {
                    (false, _) => "a finite number".to_string(),
                    (true, true) => format!("a finite number ≥ {min}"),
                    (true, false) => format!("a finite number > {min}"),
                };
                match max {
                    Some(m) => format!("{low} and < {m}"),
                    None => low,
                }
            }
            Kind::Switch | Kind::Bit => "true or false (1 or 0)".into(),
            Kind::Choice(c) => format!("one of {}", c.join(", ")),
            Kind::Tuple(parts) => {
                let names: Vec<&str> = parts.iter().map(|p| p.0).collect();
                format!("{} values ({})", parts.len(), names.join(" "))
            }
        }
    }

    /// Command-line `text` as a checked value of this kind, for an option called `name`.
    pub fn parse_checked(&self, name: &str, text: &str) -> std::result::Result<Value, String> {
        self.parse(text)
            .map_err(|why| format!("{name}: {why}"))
            .and_then(|v| self.check(name, &v))
    }

    /// `v` as a checked value of this kind (an integer for a number, 0 or 1 for a truth
    /// value), or what is wrong with it, for an option called `name`.
    pub fn check(&self, name: &str, v: &Value) -> std::result::Result<Value, String> {
        let bad = || format!("{name} must be {}, not {v}", self.describe());
        match self {
            Kind::Int { min, max } => match v {
                Value::Int(i) if (min..=max).contains(&i) => Ok(Value::Int(*i)),
                _ => Err(bad()),
            },
            Kind::Real { min, closed, max } => {
                let x = v.as_real().ok_or_else(bad)?;
                let above = if *closed { x >= *min } else { x > *min };
                let below = max.is_none_or(|m| x < m);
                if x.is_finite() && above && below {
                    Ok(Value::Real(x))
                } else {
                    Err(bad())
                }
            }
            Kind::Switch | Kind::Bit => match v {
                Value::Bool(b) => Ok(Value::Bool(*b)),
                Value::Int(0) => Ok(Value::Bool(false)),
                Value::Int(1) => Ok(Value::Bool(true)),
                _ => Err(bad()),
            },
            Kind::Choice(names) => match v {
                Value::Text(t) if names.contains(&t.as_str()) => Ok(v.clone()),
                _ => Err(format!(
                    "{name} must be one of {}, not '{v}'",
                    names.join(", ")
                )),
            },
            Kind::Tuple(parts) => {
                let list = v
                    .as_list()
                    .filter(|l| l.len() == parts.len())
                    .ok_or_else(bad)?;
                list.iter()
                    .zip(parts.iter())
                    .map(|(x, (part, kind))| kind.check(&format!("{name} {part}"), x))
                    .collect::<std::result::Result<Vec<_>, _>>()
                    .map(Value::List)
            }
        }
    }
}

/// `v` checked as a value of the option `name`: the normalised value, or an error naming the
/// option and its allowed values.
pub fn check(name: &str, v: &Value) -> Result<Value> {
    let s = spec(name).ok_or_else(|| unknown(name))?;
    s.kind.check(s.name, v).map_err(Error::Usage)
}

fn unknown(name: &str) -> Error {
    let names: Vec<&str> = OPTIONS.iter().map(|s| s.name).collect();
    Error::Usage(format!(
        "unknown render option '{name}' (the options are {})",
        names.join(", ")
    ))
}

/// One value per option: the built-in defaults, a scene file's values and the user's, in that
/// order of precedence.
#[derive(Clone, Debug, PartialEq)]
pub struct Choices {
    /// Per [`OPTIONS`] entry, its value; `None` where it is unset (its [`Default::Unset`]).
    values: Vec<Option<Value>>,
}

impl std::default::Default for Choices {
    fn default() -> Self {
        Choices {
            values: OPTIONS
                .iter()
                .map(|s| match s.default {
                    Default::Is(c) => Some(c.into()),
                    Default::Unset(_) => None,
                })
                .collect(),
        }
    }
}

impl Choices {
    /// Defaults, then the scene file's values, then the user's (each `(name, value)`, checked).
    pub fn resolve(file: &[(String, Value)], user: &[(String, Value)]) -> Result<Choices> {
        let mut c = Choices::default();
        for (name, v) in file.iter().chain(user) {
            c.set(name, v)?;
        }
        Ok(c)
    }

    /// Sets option `name` to `v` after checking it.
    pub fn set(&mut self, name: &str, v: &Value) -> Result<()> {
        let i = index(name)?;
        let s = &OPTIONS[i];
        self.values[i] = Some(s.kind.check(s.name, v).map_err(Error::Usage)?);
        Ok(())
    }

    /// Unsets option `name` (back to its [`Default::Unset`] behaviour).
    pub fn unset(&mut self, name: &str) -> Result<()> {
        let i = index(name)?;
        self.values[i] = None;
        Ok(())
    }

    /// The value of option `name`, `None` where unset.
    pub fn get(&self, name: &str) -> Option<&Value> {
        index(name).ok().and_then(|i| self.values[i].as_ref())
    }

    /// Every option with its value as text (`none` where unset), in table order.
    pub fn describe(&self) -> Vec<(&'static str, String)> {
        OPTIONS
            .iter()
            .zip(&self.values)
            .map(|(s, v)| (s.name, v.as_ref().map_or("none".into(), |v| v.to_string())))
            .collect()
    }

    pub(crate) fn int(&self, name: &str) -> Option<i128> {
        self.get(name).and_then(Value::as_int)
    }

    pub(crate) fn real(&self, name: &str) -> Option<f64> {
        self.get(name).and_then(Value::as_real)
    }

    pub(crate) fn flag(&self, name: &str) -> bool {
        self.get(name).and_then(Value::as_bool).unwrap_or(false)
    }

    pub(crate) fn text(&self, name: &str) -> &str {
        self.get(name).and_then(Value::as_text).unwrap_or("")
    }

    pub(crate) fn list(&self, name: &str) -> Option<&[Value]> {
        self.get(name).and_then(Value::as_list)
    }

    /// The pixel filter (`filter`, `filter_radius`, which defaults to the filter's own).
    pub(crate) fn filter(&self) -> PixelFilter {
        let kind: FilterKind = self.text("filter").parse().unwrap_or_default();
        PixelFilter {
            kind,
            radius: self
                .real("filter_radius")
                .map_or(kind.default_radius(), |r| r as f32),
            splat: self.text("filter_sampling") == "splat",
        }
    }

    /// How the environment light is sampled.
    pub fn env_sampling(&self) -> EnvSampling {
        self.text("env_sampling")
            .parse()
            .unwrap_or(EnvSampling::Importance)
    }

    /// Whether a model file without lights gets the built-in studio light.
    pub fn default_light(&self) -> bool {
        !self.flag("no_default_light")
    }
}

fn index(name: &str) -> Result<usize> {
    OPTIONS
        .iter()
        .position(|s| s.name == name)
        .ok_or_else(|| unknown(name))
}

/// A name that is not one of an enumerated option's values.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownName {
    /// The option.
    pub option: &'static str,
    /// The name given.
    pub given: String,
}

impl fmt::Display for UnknownName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names = match spec(self.option).map(|s| s.kind) {
            Some(Kind::Choice(c)) => c.join(", "),
            _ => String::new(),
        };
        write!(
            f,
            "{} must be one of {names}, not '{}'",
            self.option, self.given
        )
    }
}

impl std::error::Error for UnknownName {}

/// `FromStr` and `Display` of an enumerated option from its names; variants after `;` are
/// shown by `Display` but not parsed (`Direct::Hemisphere` is the `hemisphere` option, not a
/// value of `direct`).
macro_rules! names {
    ($ty:ty, $option:literal, $($variant:path => $name:literal),+
        $(; $($shown:path => $shown_name:literal),+)? $(,)?) => {
        impl std::str::FromStr for $ty {
            type Err = $crate::options::UnknownName;
            fn from_str(s: &str) -> std::result::Result<Self, $crate::options::UnknownName> {
                match s {
                    $($name => Ok($variant),)+
                    _ => Err($crate::options::UnknownName { option: $option, given: s.to_string() }),
                }
            }
        }
        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                let name = match self {
                    $($variant => $name,)+
                    $($($shown => $shown_name,)+)?
                };
                f.write_str(name)
            }
        }
    };
}
pub(crate) use names;

names!(SamplerKind, "sampler", SamplerKind::Sobol => "sobol", SamplerKind::ZSobol => "zsobol",
    SamplerKind::Independent => "independent");
names!(EnvSampling, "env_sampling", EnvSampling::Importance => "importance",
    EnvSampling::Uniform => "uniform");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::{Adaptive, RenderOptions};
    use crate::vertex::{Direct, IntegratorSettings, LightSelection};

    #[test]
    fn table_defaults_are_the_library_defaults() {
        // RenderOptions::default() is derived from the table; every option it holds reads
        // back as the table's default.
        let o = RenderOptions::default();
        for (name, v) in o.values() {
            let s = spec(name).unwrap();
            match s.default {
                Default::Is(c) => assert_eq!(check(name, &c.into()).unwrap(), v, "{name}"),
                Default::Unset(_) => panic!("{name} is set by default"),
            }
        }
        assert_eq!(
            o.integrator.rr_depth,
            IntegratorSettings::default().rr_depth
        );
    }

    #[test]
    fn every_option_has_a_consistent_entry() {
        for s in OPTIONS {
            // Choice names parse into their enums and print back.
            if let Kind::Choice(names) = s.kind {
                for n in names {
                    let round = match s.name {
                        "direct" => n.parse::<Direct>().map(|d| d.to_string()).ok(),
                        "light_selection" => {
                            n.parse::<LightSelection>().map(|d| d.to_string()).ok()
                        }
                        "sampler" => n.parse::<SamplerKind>().map(|d| d.to_string()).ok(),
                        "env_sampling" => n.parse::<EnvSampling>().map(|d| d.to_string()).ok(),
                        _ => Some(n.to_string()),
                    };
                    assert_eq!(round.as_deref(), Some(*n), "{}", s.name);
                }
            }
            // The default is an allowed value.
            if let Default::Is(c) = s.default {
                assert!(check(s.name, &c.into()).is_ok(), "{}", s.name);
            }
            assert!(!s.help.is_empty());
            assert_eq!(s.values.is_empty(), s.kind == Kind::Switch, "{}", s.name);
        }
    }

    #[test]
    fn bad_values_name_the_option() {
        let cases = [
            ("spp", Value::Int(0)),
            ("spp", Value::Int(1_000_001)),
            ("max_depth", Value::Int(-1)),
            ("direct", Value::Text("path".into())),
            ("accumulate", Value::Int(2)),
            ("time_limit", Value::Real(f64::NAN)),
            ("fov", Value::Real(180.0)),
            (
                "adaptive",
                Value::List(vec![Value::Int(0), Value::Real(0.1)]),
            ),
        ];
        for (name, v) in cases {
            let e = check(name, &v).unwrap_err().to_string();
            assert!(e.starts_with(name), "{e}");
        }
        assert!(check("frobnicate", &Value::Int(1)).is_err());
        let o = RenderOptions {
            spp: 0,
            ..RenderOptions::default()
        };
        assert!(o.validate().unwrap_err().to_string().contains("spp"));
        let o = RenderOptions {
            adaptive: Some(Adaptive {
                batch: 4,
                tolerance: 0.1,
            }),
            time_limit: Some(1.0),
            ..RenderOptions::default()
        };
        let e = o.validate().unwrap_err().to_string();
        assert!(e.contains("adaptive") && e.contains("time_limit"), "{e}");
    }

    #[test]
    fn precedence_is_default_then_file_then_user() {
        let file = [("spp".to_string(), Value::Int(64))];
        let user = [("max_depth".to_string(), Value::Int(9))];
        let c = Choices::resolve(&file, &user).unwrap();
        let o = c.render_options();
        assert_eq!((o.spp, o.integrator.max_depth), (64, 9));
        let user = [("spp".to_string(), Value::Int(8))];
        assert_eq!(
            Choices::resolve(&file, &user).unwrap().render_options().spp,
            8
        );
        assert_eq!(Choices::resolve(&[], &[]).unwrap().render_options().spp, 16);
    }
}
