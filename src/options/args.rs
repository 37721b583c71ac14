//! The command line's render arguments: the flags of [`super::OPTIONS`] (built with clap's
//! builder from the table, with its defaults and help) and the file flags of a render. The
//! `pathtracer` command line and the farm (through the Python module's `parse_args`) parse
//! render arguments here, so both take the same flags with the same meanings.

use super::{Kind, Spec, Value, OPTIONS};
use clap::parser::ValueSource;
use clap::{Arg, ArgAction, ArgMatches, Args, Command, FromArgMatches};
use std::path::PathBuf;

/// The file flags of a render (what to read and write; not render options).
#[derive(clap::Args, Clone, Debug, Default)]
pub struct Files {
    /// Scene file (.dae, .obj, .ply, .gltf, .glb, .pbrt, Mitsuba .xml). Without one, the
    /// built-in Cornell box.
    pub scene: Option<PathBuf>,
    /// Set a Mitsuba scene's parameter: `$NAME` in the file becomes VALUE (over its
    /// `<default>`); repeatable.
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = define)]
    pub define: Vec<(String, String)>,
    /// Output image: .png (8-bit sRGB) or .exr (linear float). Default: SCENENAME.png here.
    #[arg(short = 'f', value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Environment map (latitude-longitude; OpenEXR, Radiance .hdr or PFM) lighting the scene
    /// from infinity.
    #[arg(short = 'e', value_name = "MAP")]
    pub env: Option<PathBuf>,
    /// Write the environment's sampling density (relative to its maximum) as an image.
    #[arg(long, value_name = "FILE.png")]
    pub env_pdf_image: Option<PathBuf>,
    /// Load the camera from a CS184 camera file (flags given here win over it).
    #[arg(short = 'c', value_name = "FILE")]
    pub camera: Option<PathBuf>,
    /// Write the camera the render used as a CS184 camera file.
    #[arg(long, value_name = "FILE")]
    pub save_camera: Option<PathBuf>,
    /// Print a summary of the scene and exit.
    #[arg(long)]
    pub info: bool,
    /// Check the scene and the flags, print every render option's value and exit.
    #[arg(long)]
    pub dry_run: bool,
    /// Checkpoint file: written every --checkpoint-every seconds, when the render is
    /// interrupted (Ctrl-C, SIGTERM) and when it ends. Default on interruption: OUTPUT.ckpt.
    #[arg(long, value_name = "FILE")]
    pub checkpoint: Option<PathBuf>,
    /// Seconds between periodic checkpoints (needs --checkpoint).
    #[arg(long, value_name = "SECONDS", value_parser = positive_seconds, requires = "checkpoint")]
    pub checkpoint_every: Option<f64>,
    /// Continue the render saved in this checkpoint (same scene and flags) to its -s target;
    /// the result equals the uninterrupted render bit for bit.
    #[arg(long, value_name = "FILE")]
    pub resume: Option<PathBuf>,
    /// Stream the image as it renders to the tev viewer listening at HOST:PORT (tev's
    /// default port is 14158); reconnects when tev comes back.
    #[arg(long, value_name = "HOST:PORT")]
    pub display_server: Option<String>,
}

/// `NAME=VALUE` with a non-empty name.
fn define(s: &str) -> std::result::Result<(String, String), String> {
    match s.split_once('=') {
        Some((k, v)) if !k.is_empty() => Ok((k.to_string(), v.to_string())),
        _ => Err(format!("'{s}' is not NAME=VALUE")),
    }
}

/// A positive, finite number of seconds.
fn positive_seconds(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("'{s}' is not a positive number of seconds")),
    }
}

/// A render's arguments: its files and the options the user gave (only those: defaults and a
/// scene file's values are applied by [`super::Choices::resolve`]).
#[derive(Clone, Debug, Default)]
pub struct RenderArgs {
    /// What to read and write.
    pub files: Files,
    /// The options given on the command line, `(name, checked value)`, in table order.
    pub given: Vec<(String, Value)>,
}

/// The clap id of a flag: the name of its option, or of its group for a shared flag.
fn arg_id(s: &Spec) -> &'static str {
    match (s.flag, s.part) {
        (Some("-r"), Some(_)) => "resolution",
        _ => s.name,
    }
}

/// The options that share `s`'s flag (itself alone unless it is part of a group).
fn group(s: &Spec) -> impl Iterator<Item = &'static Spec> + '_ {
    OPTIONS.iter().filter(move |o| o.flag == s.flag)
}

/// A value as the command line writes it (`1` for a true `-o`).
fn cli_text(kind: &Kind, v: &Value) -> String {
    match (kind, v) {
        (Kind::Bit, Value::Bool(b)) => (*b as u8).to_string(),
        _ => v.to_string(),
    }
}

/// The clap argument of the flag of `s` (the first option of its group).
fn arg_of(s: &'static Spec, flag: &'static str) -> Arg {
    let id = arg_id(s);
    let mut arg = Arg::new(id);
    arg = match flag.strip_prefix("--") {
        Some(long) => arg.long(long),
        None => arg.short(flag.chars().nth(1).unwrap_or('?')),
    };
    if s.kind == Kind::Switch {
        return arg.action(ArgAction::SetTrue).help(s.help);
    }
    let defaults: Vec<String> = group(s)
        .filter_map(|o| match o.default {
            super::Default::Is(c) => Some(cli_text(&o.kind, &c.into())),
            super::Default::Unset(_) => None,
        })
        .collect();
    let help = if s.part.is_some() {
        "Image size in pixels".to_string()
    } else {
        match s.default {
            super::Default::Unset(what) => format!("{} [default: {what}]", s.help),
            super::Default::Is(_) => s.help.to_string(),
        }
    };
    arg = arg
        .action(ArgAction::Set)
        .num_args(s.values.len())
        .value_names(s.values)
        .allow_negative_numbers(true)
        .help(help);
    if defaults.len() == s.values.len() {
        arg = arg.default_values(defaults);
    }
    arg
}

impl Args for RenderArgs {
    fn augment_args(cmd: Command) -> Command {
        let mut cmd = cmd;
        let mut seen: Vec<&str> = Vec::new();
        for s in OPTIONS {
            let Some(flag) = s.flag else { continue };
            if seen.contains(&flag) {
                continue;
            }
            seen.push(flag);
            cmd = cmd.arg(arg_of(s, flag));
        }
        Files::augment_args(cmd)
    }

    fn augment_args_for_update(cmd: Command) -> Command {
        Self::augment_args(cmd)
    }
}

/// The checked value of option `s` given as `texts` after its flag, or clap's error naming
/// the flag, the text and what is wrong (with the option's name).
fn value_of(s: &Spec, flag: &str, texts: &[String]) -> Result<Value, clap::Error> {
    let invalid = |text: &str, why: String| {
        let names: Vec<String> = s.values.iter().map(|v| format!("<{v}>")).collect();
        clap::Error::raw(
            clap::error::ErrorKind::ValueValidation,
            format!(
                "invalid value '{text}' for '{flag} {}': {why}\n",
                names.join(" ")
            ),
        )
    };
    let one = |kind: &Kind, name: &str, text: &str| {
        kind.parse_checked(name, text)
            .map_err(|why| invalid(text, why))
    };
    match (s.kind, s.part) {
        (Kind::Switch, _) => Ok(Value::Bool(true)),
        (_, Some(i)) => one(&s.kind, s.name, texts.get(i).map_or("", String::as_str)),
        (Kind::Tuple(parts), None) => parts
            .iter()
            .zip(texts)
            .map(|((part, kind), text)| one(kind, &format!("{} {part}", s.name), text))
            .collect::<Result<Vec<_>, _>>()
            .map(Value::List),
        (kind, None) => one(&kind, s.name, texts.first().map_or("", String::as_str)),
    }
}

impl FromArgMatches for RenderArgs {
    fn from_arg_matches(m: &ArgMatches) -> Result<Self, clap::Error> {
        let files = Files::from_arg_matches(m)?;
        let mut given = Vec::new();
        for s in OPTIONS {
            let Some(flag) = s.flag else { continue };
            let id = arg_id(s);
            if m.value_source(id) != Some(ValueSource::CommandLine) {
                continue;
            }
            let texts: Vec<String> = m
                .get_raw(id)
                .map(|v| v.map(|t| t.to_string_lossy().into_owned()).collect())
                .unwrap_or_default();
            given.push((s.name.to_string(), value_of(s, flag, &texts)?));
        }
        Ok(RenderArgs { files, given })
    }

    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

/// A clap value parser of a `u32` option of the table (`spp`, `threads`, ...), checked by
/// the table with its message: for subcommands that take one of its options with a default
/// of their own (`pathtracer sequence -s`).
pub fn u32_option(name: &'static str) -> impl Fn(&str) -> Result<u32, String> + Clone {
    move |text: &str| {
        let spec = super::spec(name).ok_or_else(|| format!("no option {name}"))?;
        spec.kind
            .parse_checked(name, text)?
            .as_int()
            .and_then(|i| u32::try_from(i).ok())
            .ok_or_else(|| format!("{name} must be an integer, not {text}"))
    }
}

/// Parses render arguments (without a program name), as the command line does: the farm's
/// render flags. The error is clap's message.
pub fn parse<I, T>(argv: I) -> std::result::Result<RenderArgs, String>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let cmd = RenderArgs::augment_args(
        Command::new("pathtracer")
            .no_binary_name(true)
            .disable_help_flag(true),
    );
    cmd.try_get_matches_from(argv)
        .and_then(|m| RenderArgs::from_arg_matches(&m))
        .map_err(|e| e.to_string().trim_end().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_become_checked_values_and_only_given_ones_are_kept() {
        let a = parse([
            "-s", "8", "-r", "64", "48", "-H", "--direct", "bsdf", "x.dae",
        ])
        .unwrap();
        let names: Vec<&str> = a.given.iter().map(|g| g.0.as_str()).collect();
        assert_eq!(
            names,
            ["spp", "hemisphere", "direct", "width", "height"],
            "{:?}",
            a.given
        );
        assert_eq!(a.files.scene, Some(PathBuf::from("x.dae")));
        let o = super::super::Choices::resolve(&[], &a.given)
            .unwrap()
            .render_options();
        assert_eq!((o.spp, o.width, o.height), (8, 64, 48));
        assert_eq!(o.integrator.direct, crate::integrator::Direct::Hemisphere);
        let e = parse(["-s", "0"]).unwrap_err();
        assert!(e.contains("'-s <N>'") && e.contains("spp must be"), "{e}");
        let e = parse(["-r", "64", "0"]).unwrap_err();
        assert!(e.contains("height must be"), "{e}");
        let e = parse(["-a", "0", "0.1"]).unwrap_err();
        assert!(e.contains("adaptive BATCH must be"), "{e}");
        let e = parse(["-o", "2"]).unwrap_err();
        assert!(e.contains("accumulate must be"), "{e}");
    }
}
