//! `pathtracer`: the command line. Flags follow the CS184 PathTracer.

use clap::{Args, Parser, Subcommand};
use pathtracer::error::{Error, Result};
use pathtracer::film::Film;
use pathtracer::integrator::{Direct, IntegratorSettings, LightSelection, RR_START_DEPTH};
use pathtracer::io::image::{diff, Image};
use pathtracer::light::env::EnvSampling;
use pathtracer::render::{
    new_film, render, render_into, Adaptive, Cell, Control, RenderOptions, RenderStats,
};
use pathtracer::sampling::sampler::SamplerKind;
use pathtracer::{bench, builtin, info, io, light, scene, setup};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::Mutex;
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(
    name = "pathtracer",
    version,
    about = "Physically based path tracer for the CS184 COLLADA scenes",
    args_conflicts_with_subcommands = true
)]
struct Cli {
    #[command(subcommand)]
    cmd: Option<Cmd>,
    #[command(flatten)]
    render: RenderArgs,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Compare an image against a reference: RMSE, relative MSE, ratio of means, block metric.
    Diff {
        /// Test image (.exr or .png).
        a: PathBuf,
        /// Reference image (.exr or .png).
        b: PathBuf,
    },
    /// BVH build time and Mrays/s for closest-hit and any-hit queries on a scene's triangles.
    Bench {
        /// Scene file (.dae); the built-in scene when absent.
        scene: Option<PathBuf>,
        /// Threads of the multi-threaded runs (default: all cores).
        #[arg(short = 't', value_parser = clap::value_parser!(u32).range(1..=1024))]
        threads: Option<u32>,
        /// Benchmark a generated displaced sphere of about N triangles instead of a scene.
        #[arg(long, value_name = "N", conflicts_with = "scene", value_parser = clap::value_parser!(u64).range(8..=100_000_000))]
        synthetic: Option<u64>,
        /// Also write the triangles and both ray sets as .npy files into DIR
        /// (for benches/compare_embree.py).
        #[arg(long, value_name = "DIR")]
        npy: Option<PathBuf>,
    },
    /// Render a scene at several maximum depths (-m) and write a labelled contact sheet.
    Sequence(SequenceArgs),
    /// The interactive renderer in the browser: serves the page and prints its URL.
    #[cfg(feature = "view")]
    View(Box<ViewArgs>),
    /// Noise per second: render every scene with a reference in SHARED/refs for a fixed time
    /// and print its relative MSE against the reference.
    BenchQuality {
        /// The shared test-data folder.
        #[arg(long, default_value = "../shared")]
        shared: PathBuf,
        /// Seconds per scene.
        #[arg(long, default_value_t = 20.0, value_parser = positive)]
        budget: f32,
        /// Threads (default: all cores).
        #[arg(short = 't', value_parser = clap::value_parser!(u32).range(1..=1024))]
        threads: Option<u32>,
        /// Light samples per vertex.
        #[arg(short = 'l', default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100_000))]
        light_samples: u32,
        /// Direct-light estimator.
        #[arg(long, value_enum, default_value_t = DirectArg::Mis)]
        direct: DirectArg,
        /// How lights are chosen for light sampling.
        #[arg(long, value_enum, default_value_t = SelectionArg::Power)]
        light_selection: SelectionArg,
    },
}

#[cfg(feature = "view")]
#[derive(Args, Debug)]
struct ViewArgs {
    /// Address to listen on (default loopback; anything else is reachable from the network).
    #[arg(long, default_value = "127.0.0.1")]
    host: std::net::IpAddr,
    /// Port (0: a free one).
    #[arg(long, default_value_t = 0)]
    port: u16,
    /// Directory where the page's `s` saves images and camera files (names chosen here).
    #[arg(long, value_name = "DIR", default_value = ".")]
    out_dir: PathBuf,
    /// Open the page in the default browser.
    #[arg(long)]
    open: bool,
    #[command(flatten)]
    render: RenderArgs,
}

#[derive(Args, Debug)]
struct SequenceArgs {
    /// Scene file (.dae); the built-in scene when absent.
    scene: Option<PathBuf>,
    /// Maximum depths to render, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "0,1,2,3,4,5,100")]
    depths: Vec<u32>,
    /// Camera samples per pixel.
    #[arg(short = 's', value_name = "N", default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    spp: u32,
    /// Samples per area light.
    #[arg(short = 'l', value_name = "N", default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    light_samples: u32,
    /// Worker threads (default: all cores).
    #[arg(short = 't', value_name = "N", value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
    /// Seed of the random streams.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Contact sheet output (.png or .exr); the renders go beside it as NAME_mK.exr and .png.
    #[arg(short = 'f', value_name = "FILE", default_value = "depth_sequence.png")]
    sheet: PathBuf,
    /// Direct-light estimator.
    #[arg(long, value_enum, default_value_t = DirectArg::Mis)]
    direct: DirectArg,
}

/// `--direct` values.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum DirectArg {
    /// Light and BSDF sampling combined by multiple importance sampling.
    Mis,
    /// Light sampling only (CS184's `-l`).
    Light,
    /// BSDF sampling only.
    Bsdf,
}

impl DirectArg {
    fn direct(self) -> Direct {
        match self {
            DirectArg::Mis => Direct::Mis,
            DirectArg::Light => Direct::Light,
            DirectArg::Bsdf => Direct::Bsdf,
        }
    }
}

impl SelectionArg {
    fn selection(self) -> LightSelection {
        match self {
            SelectionArg::Power => LightSelection::Power,
            SelectionArg::All => LightSelection::All,
        }
    }
}

/// `--light-selection` values.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum SelectionArg {
    /// Each light sample picks one light in proportion to its power.
    Power,
    /// Every light gets `-l` samples (CS184).
    All,
}

/// `--sampler` values.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum SamplerArg {
    /// Independent uniform random numbers.
    Independent,
    /// Owen-scrambled Sobol points, stratified within each pixel.
    Sobol,
    /// Owen-scrambled Sobol points in Morton order: stratified within each pixel, error
    /// spread as blue noise across pixels.
    Zsobol,
}

impl SamplerArg {
    fn kind(self) -> SamplerKind {
        match self {
            SamplerArg::Independent => SamplerKind::Independent,
            SamplerArg::Sobol => SamplerKind::Sobol,
            SamplerArg::Zsobol => SamplerKind::ZSobol,
        }
    }
}

/// `--caustics` values.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum CausticsArg {
    /// Paths from a non-caustic first hit that reach a light through a caustic surface
    /// (mirror, glass, smooth metal) are traced from the light and joined to the camera
    /// (pinhole cameras, not with `-a`; elsewhere path tracing does it all).
    Light,
    /// Path tracing only.
    Path,
}

/// `--env-sampling` values.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum EnvSamplingArg {
    /// Uniform over the sphere.
    Uniform,
    /// Proportional to luminance × sin θ.
    Importance,
}

#[derive(Args, Debug)]
struct RenderArgs {
    /// Scene file (.dae). Without one, the built-in Cornell box is rendered.
    scene: Option<PathBuf>,
    /// Camera samples per pixel.
    #[arg(short = 's', value_name = "N", default_value_t = 16, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    spp: u32,
    /// Samples per area light for direct lighting.
    #[arg(short = 'l', value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    light_samples: u32,
    /// Worker threads (default: all cores).
    #[arg(short = 't', value_name = "N", value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
    /// Maximum ray depth: 0 emitters only, 1 direct light, each step one more bounce.
    #[arg(short = 'm', value_name = "N", default_value_t = 5, value_parser = clap::value_parser!(u32).range(0..=100_000))]
    max_depth: u32,
    /// 1: accumulate all bounces up to -m; 0: only the -m-th bounce.
    #[arg(short = 'o', value_name = "0|1", default_value_t = 1, value_parser = clap::value_parser!(u8).range(0..=1))]
    accumulate: u8,
    /// Estimate direct light by uniform hemisphere sampling instead of light sampling.
    #[arg(short = 'H')]
    hemisphere: bool,
    /// Direct-light estimator (`-H` overrides it with hemisphere sampling).
    #[arg(long, value_enum, default_value_t = DirectArg::Mis)]
    direct: DirectArg,
    /// How lights are chosen for light sampling.
    #[arg(long, value_enum, default_value_t = SelectionArg::Power)]
    light_selection: SelectionArg,
    /// The point set of the camera samples.
    #[arg(long, value_enum, default_value_t = SamplerArg::Sobol)]
    sampler: SamplerArg,
    /// How caustics (light reaching a light through mirrors, glass and smooth metal) are found.
    #[arg(long, value_enum, default_value_t = CausticsArg::Light)]
    caustics: CausticsArg,
    /// Hit index from which Russian roulette may end paths.
    #[arg(long, value_name = "N", default_value_t = RR_START_DEPTH, value_parser = clap::value_parser!(u32).range(1..))]
    rr_depth: u32,
    /// Render in passes of one sample per pixel until this many seconds have passed (or -s is
    /// reached); N passes equal an N-spp render with the same seed.
    #[arg(long, value_name = "SECONDS", value_parser = positive)]
    time_limit: Option<f32>,
    /// Environment map (.exr or .hdr, latitude-longitude) lighting the scene from infinity.
    #[arg(short = 'e', value_name = "MAP")]
    env: Option<PathBuf>,
    /// How the environment light is sampled.
    #[arg(long, value_enum, default_value_t = EnvSamplingArg::Importance)]
    env_sampling: EnvSamplingArg,
    /// Write the environment's sampling density (relative to its maximum) as an image.
    #[arg(long, value_name = "FILE.png")]
    env_pdf_image: Option<PathBuf>,
    /// Thin-lens radius in scene units (0: pinhole).
    #[arg(short = 'b', value_name = "RADIUS", value_parser = non_negative)]
    lens_radius: Option<f32>,
    /// Focal distance in scene units along the viewing direction (default: the distance to the
    /// scene centre).
    #[arg(short = 'd', value_name = "DIST", value_parser = positive)]
    focal_distance: Option<f32>,
    /// Load the camera from a CS184 camera file (flags given here win over it).
    #[arg(short = 'c', value_name = "FILE")]
    camera: Option<PathBuf>,
    /// Write the camera the render used as a CS184 camera file.
    #[arg(long, value_name = "FILE")]
    save_camera: Option<PathBuf>,
    /// Adaptive sampling: check every BATCH samples, stop when 1.96·σ/√n ≤ TOL·μ.
    #[arg(short = 'a', num_args = 2, value_names = ["BATCH", "TOL"], allow_negative_numbers = true)]
    adaptive: Option<Vec<String>>,
    /// Adaptive budget: -s is the mean samples per pixel, spent where it lowers the mean
    /// relative MSE (variance and ray cost estimated per pixel in rounds); writes NAME_rate.png.
    #[arg(long, conflicts_with = "adaptive")]
    adaptive_budget: bool,
    /// Render only the DX×DY cell whose top-left pixel is (X, Y).
    #[arg(short = 'p', num_args = 4, value_names = ["X", "Y", "DX", "DY"], allow_negative_numbers = true, value_parser = clap::value_parser!(u32))]
    cell: Option<Vec<u32>>,
    /// Image size in pixels.
    #[arg(short = 'r', num_args = 2, allow_negative_numbers = true, value_names = ["W", "H"], value_parser = clap::value_parser!(u32).range(1..=65_536))]
    resolution: Option<Vec<u32>>,
    /// Output image: .png (8-bit sRGB) or .exr (linear float). Default: SCENENAME.png here.
    #[arg(short = 'f', value_name = "FILE")]
    output: Option<PathBuf>,
    /// Seed of the random streams; the same seed gives the same image for any thread count.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Print a summary of the scene and exit.
    #[arg(long)]
    info: bool,
    /// Checkpoint file: written every --checkpoint-every seconds, when the render is
    /// interrupted (Ctrl-C, SIGTERM) and when it ends. Default on interruption: OUTPUT.ckpt.
    #[arg(long, value_name = "FILE")]
    checkpoint: Option<PathBuf>,
    /// Seconds between periodic checkpoints (needs --checkpoint).
    #[arg(long, value_name = "SECONDS", value_parser = positive, requires = "checkpoint")]
    checkpoint_every: Option<f32>,
    /// Continue the render saved in this checkpoint (same scene and flags) to its -s target;
    /// the result equals the uninterrupted render bit for bit.
    #[arg(long, value_name = "FILE")]
    resume: Option<PathBuf>,
    /// Camera at EYE looking at TARGET with UP as up (9 numbers), for any scene; the field of
    /// view stays the scene's unless --fov is given.
    #[arg(long, num_args = 9, value_names = ["EX", "EY", "EZ", "TX", "TY", "TZ", "UX", "UY", "UZ"], allow_negative_numbers = true)]
    lookat: Option<Vec<f32>>,
    /// Vertical field of view in degrees over the image's height (pbrt/Mitsuba convention).
    #[arg(long, value_name = "DEGREES", value_parser = fov_degrees)]
    fov: Option<f64>,
    /// Stream the image as it renders to the tev viewer listening at HOST:PORT (tev's
    /// default port is 14158); reconnects when tev comes back.
    #[arg(long, value_name = "HOST:PORT")]
    display_server: Option<String>,
}

/// A field of view in degrees, in (0, 180).
fn fov_degrees(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v < 180.0 => Ok(v),
        _ => Err(format!("{s} is not a field of view in (0, 180) degrees")),
    }
}

fn load(path: Option<&Path>) -> Result<io::desc::SceneDesc> {
    match path {
        Some(p) => io::load_scene(p),
        None => Ok(builtin::cornell_box()),
    }
}

fn print_warnings(w: &[String]) {
    for line in w {
        eprintln!("warning: {line}");
    }
}

fn number(s: &str) -> std::result::Result<f32, String> {
    s.parse::<f32>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| format!("'{s}' is not a finite number"))
}

fn non_negative(s: &str) -> std::result::Result<f32, String> {
    number(s).and_then(|v| {
        if v >= 0.0 {
            Ok(v)
        } else {
            Err(format!("{v} is negative"))
        }
    })
}

fn positive(s: &str) -> std::result::Result<f32, String> {
    number(s).and_then(|v| {
        if v > 0.0 {
            Ok(v)
        } else {
            Err(format!("{v} is not positive"))
        }
    })
}

/// Parses `-a BATCH TOL`.
fn adaptive_of(v: &[String]) -> Result<Adaptive> {
    let bad = |m: String| Error::Usage(format!("invalid value for '-a <BATCH> <TOL>': {m}"));
    let batch: u32 = v[0]
        .parse()
        .ok()
        .filter(|&b| b > 0)
        .ok_or_else(|| bad(format!("BATCH '{}' must be a positive integer", v[0])))?;
    let tolerance = positive(&v[1]).map_err(|e| bad(format!("TOL {e}")))?;
    Ok(Adaptive { batch, tolerance })
}

/// Progress on stderr: a bar with ETA on a terminal, plain lines every few seconds otherwise.
/// Under a time limit (seconds) the fraction done is at least the fraction of the limit
/// spent, so the ETA never passes the limit.
struct Progress {
    bar: Option<indicatif::ProgressBar>,
    start: Instant,
    last: Mutex<f64>,
    limit: Option<f64>,
}

/// Steps of the terminal bar: it shows a fraction, not a sample count.
const BAR_STEPS: u64 = 1000;

impl Progress {
    fn new(limit: Option<f64>) -> Self {
        let bar = std::io::stderr().is_terminal().then(|| {
            let b = indicatif::ProgressBar::new(0);
            if let Ok(style) = indicatif::ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] [{wide_bar}] {percent:>3}% ETA {eta}",
            ) {
                b.set_style(style);
            }
            b
        });
        Progress {
            bar,
            start: Instant::now(),
            last: Mutex::new(0.0),
            limit,
        }
    }

    fn update(&self, done: usize, total: usize) {
        let t = self.start.elapsed().as_secs_f64();
        let mut frac = done as f64 / total.max(1) as f64;
        if let Some(limit) = self.limit.filter(|&l| l > 0.0) {
            frac = frac.max((t / limit).min(1.0));
        }
        if let Some(b) = &self.bar {
            b.set_length(BAR_STEPS);
            b.set_position((frac * BAR_STEPS as f64) as u64);
            return;
        }
        let Ok(mut last) = self.last.lock() else {
            return;
        };
        if t - *last >= 5.0 && done < total {
            *last = t;
            let eta = if frac > 0.0 { t / frac - t } else { f64::NAN };
            eprintln!(
                "progress: {:5.1}% after {:.1} s, ETA {:.1} s",
                frac * 100.0,
                t,
                eta
            );
        }
    }

    fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

/// Loads the scene and builds the render options of the render flags; `None` when `--info`
/// printed the summary instead.
fn prepare(a: &RenderArgs) -> Result<Option<(scene::Scene, RenderOptions)>> {
    let t = Instant::now();
    let sampling = match a.env_sampling {
        EnvSamplingArg::Uniform => EnvSampling::Uniform,
        EnvSamplingArg::Importance => EnvSampling::Importance,
    };
    if a.env_pdf_image.is_some() && a.env.is_none() {
        return Err(Error::Usage(
            "--env-pdf-image needs an environment map (-e MAP)".into(),
        ));
    }
    let mut loaded = setup::load(a.scene.as_deref(), a.env.as_deref(), sampling)?;
    print_warnings(&loaded.warnings);
    if let (Some(out), Some(light::Light::Environment(env))) =
        (&a.env_pdf_image, loaded.scene.lights.last())
    {
        env.pdf_image().save(out)?;
        eprintln!(
            "wrote the environment's sampling density to {}",
            out.display()
        );
    }
    if a.info {
        print!("{}", info::summary(&loaded.scene));
        return Ok(None);
    }
    if let Some(path) = &a.camera {
        loaded.use_camera_file(path)?;
    }
    let (width, height) = match a.resolution.as_deref() {
        Some([w, h]) => (*w, *h),
        _ => (480, 360),
    };
    let view = setup::View {
        lookat: a.lookat.as_deref().map(|l| {
            let v = |i: usize| glam::Vec3::new(l[i], l[i + 1], l[i + 2]);
            [v(0), v(3), v(6)]
        }),
        fov: a.fov,
        lens_radius: a.lens_radius,
        focal_distance: a.focal_distance,
    };
    let mut scene = loaded.scene;
    scene.camera = view.camera(&scene.camera, loaded.file_vfov, height)?;
    let adaptive = a.adaptive.as_deref().map(adaptive_of).transpose()?;
    let cell = a.cell.as_deref().map(|p| Cell {
        x: p[0],
        y: p[1],
        w: p[2],
        h: p[3],
    });
    eprintln!(
        "loaded {} ({} primitives) in {:.2} s",
        scene.name,
        scene.tris.len() + scene.spheres.len(),
        t.elapsed().as_secs_f64()
    );
    let opts = RenderOptions {
        width,
        height,
        spp: a.spp,
        threads: a.threads.map(|t| t as usize),
        seed: a.seed,
        integrator: IntegratorSettings {
            max_depth: a.max_depth,
            accumulate: a.accumulate == 1,
            light_samples: a.light_samples,
            direct: if a.hemisphere {
                Direct::Hemisphere
            } else {
                a.direct.direct()
            },
            selection: a.light_selection.selection(),
            rr_depth: a.rr_depth,
            light_tracing: a.caustics == CausticsArg::Light,
        },
        sampler: a.sampler.kind(),
        adaptive,
        adaptive_budget: a.adaptive_budget,
        cell,
        time_limit: a.time_limit.map(f64::from),
        sample_range: None,
    };
    Ok(Some((scene, opts)))
}

fn run_render(a: &RenderArgs) -> Result<ExitCode> {
    let Some((scene, opts)) = prepare(a)? else {
        return Ok(ExitCode::SUCCESS);
    };
    let (adaptive, width, height) = (opts.adaptive, opts.width, opts.height);
    let out = a
        .output
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{}.png", scene.name)));
    // Fail on a bad output format before spending time on the render.
    match out
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .as_deref()
    {
        Some("png") | Some("exr") => {}
        _ => {
            return Err(Error::Usage(format!(
                "{}: unsupported output format (use .png or .exr)",
                out.display()
            )))
        }
    }
    // Output places are checked before any rendering.
    let checkpoint = a
        .checkpoint
        .clone()
        .unwrap_or_else(|| out.with_extension("ckpt"));
    io::atomic::check_writable(&out)?;
    io::atomic::check_writable(&checkpoint)?;
    if let Some(p) = &a.save_camera {
        io::atomic::check_writable(p)?;
    }
    let ident = identity(a, &opts, &scene)?;
    let mut film = match &a.resume {
        Some(path) => {
            let film = Film::load(path)?;
            if let Some(d) = film.identity_mismatch(&ident) {
                return Err(Error::Usage(format!(
                    "{}: the checkpoint belongs to another render: {d}",
                    path.display()
                )));
            }
            eprintln!(
                "resuming {} with {:.1} samples per pixel done",
                path.display(),
                film.samples() as f64 / film.pixels().len() as f64
            );
            film
        }
        None => {
            let mut film = new_film(&opts)?;
            film.set_identity(ident);
            film
        }
    };
    let interrupted = install_signal_handler();
    let progress = Progress::new(opts.time_limit);
    let tev = a.display_server.as_deref().map(|addr| {
        let name = out
            .file_name()
            .map_or("pathtracer".into(), |n| n.to_string_lossy());
        let t = io::tev::TevStream::start(addr, &name, opts.width, opts.height);
        if film.cell()
            == (Cell {
                x: 0,
                y: 0,
                w: opts.width,
                h: opts.height,
            })
        {
            // A resumed render starts from the samples it has.
            t.image(&film.develop());
        }
        t
    });
    let to_tev = |c: Cell, t: &pathtracer::film::Tile, px: &[pathtracer::film::FilmPixel]| {
        if let Some(tev) = &tev {
            tev.tile(c, t, px);
        }
    };
    let tile_done: Option<&pathtracer::render::TileFn<'_>> = tev.as_ref().map(|_| &to_tev as _);
    let stats = render_rounds(
        &scene,
        &opts,
        &mut film,
        a,
        &checkpoint,
        &progress,
        tile_done,
    )?;
    progress.finish();
    if let Some(t) = tev {
        t.finish();
    }
    let img = film.develop();
    img.save(&out)?;
    if interrupted.load(Ordering::SeqCst) && !stats.complete {
        film.save(&checkpoint)?;
        let counts = &stats.samples_per_pixel;
        eprintln!(
            "interrupted after {:.1} s: wrote {} holding {:.2} samples per pixel on average \
             (min {}, max {}) of -s {}, and the checkpoint {}; continue with --resume {}",
            stats.seconds,
            out.display(),
            stats.mean_spp(),
            counts.iter().min().copied().unwrap_or(0),
            counts.iter().max().copied().unwrap_or(0),
            opts.spp,
            checkpoint.display(),
            checkpoint.display()
        );
        return Ok(ExitCode::from(130));
    }
    if a.checkpoint.is_some() {
        film.save(&checkpoint)?;
    }
    let shown = std::path::absolute(&out).unwrap_or(out.clone());
    if stats.non_finite > 0 {
        eprintln!(
            "warning: {} samples with NaN/Inf radiance were counted as black",
            stats.non_finite
        );
    }
    let (ow, oh) = (img.width, img.height);
    eprintln!(
        "rendered {}x{} at {} spp on {} threads in {:.2} s: {:.2} M samples/s, {:.2} M rays/s",
        ow,
        oh,
        if adaptive.is_some() {
            format!(
                "{:.1} (mean, adaptive, at most {})",
                stats.mean_spp(),
                opts.spp
            )
        } else if opts.adaptive_budget {
            format!(
                "{:.1} (mean, adaptive budget, at most {} per pixel)",
                stats.mean_spp(),
                opts.spp.saturating_mul(pathtracer::render::ADAPTIVE_CAP)
            )
        } else if opts.time_limit.is_some() {
            format!(
                "{} (passes done within the time limit, at most {})",
                stats.mean_spp().round(),
                opts.spp
            )
        } else {
            opts.spp.to_string()
        },
        stats.threads,
        stats.seconds,
        stats.samples as f64 / stats.seconds / 1e6,
        stats.rays as f64 / stats.seconds / 1e6
    );
    eprintln!("wrote {}", shown.display());
    if adaptive.is_some() || opts.adaptive_budget {
        let stem = out
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| scene.name.clone());
        let rate = out.with_file_name(format!("{stem}_rate.png"));
        io::image::sample_rate_image(&stats.samples_per_pixel, ow, oh).save(&rate)?;
        eprintln!(
            "mean samples per pixel {:.1}; wrote the sample rate image {}",
            stats.mean_spp(),
            rate.display()
        );
    }
    if let Some(path) = &a.save_camera {
        scene.camera.save_cs184(path, width, height)?;
        eprintln!("wrote the camera to {}", path.display());
    }
    Ok(ExitCode::SUCCESS)
}

/// Signals received (SIGINT, SIGTERM, SIGHUP) since the handler was installed.
static SIGNALS: AtomicU32 = AtomicU32::new(0);
/// Set by the first signal: the render stops and keeps what it has.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Installs the handler of Ctrl-C and SIGTERM: the first stops the render (which then writes
/// its image and checkpoint), a second ends the process at once (status 130; every file is
/// written under a temporary name and renamed, so none is left half-written).
fn install_signal_handler() -> &'static AtomicBool {
    let result = ctrlc::set_handler(|| {
        if SIGNALS.fetch_add(1, Ordering::SeqCst) > 0 {
            #[cfg(target_os = "linux")]
            // SAFETY: _exit ends the process without running any user-space code; it is
            // async-signal-safe and has no preconditions.
            unsafe {
                libc::_exit(130)
            };
            #[cfg(not(target_os = "linux"))]
            std::process::exit(130);
        }
        INTERRUPTED.store(true, Ordering::SeqCst);
        eprintln!("\ninterrupted: stopping and saving (interrupt again to quit at once)");
    });
    if let Err(e) = result {
        eprintln!("warning: cannot handle Ctrl-C ({e}); an interrupted render will be lost");
    }
    &INTERRUPTED
}

/// What a render belongs to, for its checkpoint: hashes of the scene, environment map and
/// camera files and every option that changes pixels. Resuming with any of them different is
/// an error naming it.
fn identity(
    a: &RenderArgs,
    opts: &RenderOptions,
    scene: &scene::Scene,
) -> Result<Vec<(String, String)>> {
    use sha2::{Digest, Sha256};
    let hash_file = |p: &Path| -> Result<String> {
        let bytes = std::fs::read(p).map_err(|source| Error::Io {
            path: p.display().to_string(),
            what: "cannot read",
            source,
        })?;
        let name = p.file_name().map(|n| n.to_string_lossy().into_owned());
        let hex: String = Sha256::digest(&bytes)[..8]
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        Ok(format!("{} (sha256 {hex}…)", name.unwrap_or_default()))
    };
    let file_or = |p: Option<&PathBuf>, none: &str| -> Result<String> {
        p.map_or(Ok(none.to_string()), |p| hash_file(p))
    };
    let it = &opts.integrator;
    let c = &scene.camera;
    let mut id = vec![
        ("version".to_string(), env!("CARGO_PKG_VERSION").to_string()),
        ("scene".into(), file_or(a.scene.as_ref(), "built-in")?),
        ("environment".into(), file_or(a.env.as_ref(), "none")?),
        ("env-sampling".into(), format!("{:?}", a.env_sampling)),
        ("camera-file".into(), file_or(a.camera.as_ref(), "none")?),
        (
            "camera".into(),
            format!(
                "{:?} {:?} {:?} {} {} {}",
                c.pos, c.target, c.up, c.hfov_deg, c.lens_radius, c.focal_distance
            ),
        ),
        ("size".into(), format!("{}x{}", opts.width, opts.height)),
        (
            "cell".into(),
            opts.cell.map_or("none".into(), |c| {
                format!("{} {} {} {}", c.x, c.y, c.w, c.h)
            }),
        ),
        ("spp".into(), opts.spp.to_string()),
        ("seed".into(), opts.seed.to_string()),
        ("sampler".into(), opts.sampler.name().to_string()),
        ("max-depth".into(), it.max_depth.to_string()),
        ("accumulate".into(), it.accumulate.to_string()),
        ("light-samples".into(), it.light_samples.to_string()),
        ("direct".into(), format!("{:?}", it.direct)),
        ("light-selection".into(), format!("{:?}", it.selection)),
        ("rr-depth".into(), it.rr_depth.to_string()),
        ("light-tracing".into(), it.light_tracing.to_string()),
        (
            "adaptive".into(),
            opts.adaptive
                .map_or("none".into(), |a| format!("{} {}", a.batch, a.tolerance)),
        ),
        ("adaptive-budget".into(), opts.adaptive_budget.to_string()),
    ];
    for (_, v) in &mut id {
        *v = v.replace(['\n', '\r'], " ");
    }
    Ok(id)
}

/// Renders `film` to its target in rounds: a round ends when the render completes, runs out
/// of time, is interrupted, or (with `--checkpoint-every`) when a checkpoint is due, which is
/// then written and the next round continues. Returns the figures of all rounds together.
fn render_rounds(
    scene: &scene::Scene,
    opts: &RenderOptions,
    film: &mut Film,
    a: &RenderArgs,
    checkpoint: &Path,
    progress: &Progress,
    tile_done: Option<&pathtracer::render::TileFn<'_>>,
) -> Result<RenderStats> {
    let start = Instant::now();
    let mut total: Option<RenderStats> = None;
    loop {
        let mut round = opts.clone();
        if let Some(limit) = opts.time_limit {
            let left = limit - start.elapsed().as_secs_f64();
            if left <= 0.0 {
                if let Some(t) = total.take() {
                    return Ok(t);
                }
            }
            round.time_limit = Some(left.max(0.0));
        }
        let stop = AtomicBool::new(false);
        // (At most a year between checkpoints: a larger interval means "never".)
        let due = a.checkpoint_every.and_then(|s| {
            Instant::now().checked_add(std::time::Duration::from_secs_f64(
                (s as f64).min(365.0 * 86400.0),
            ))
        });
        let finished = AtomicBool::new(false);
        /// Tells the watcher to end however the render ends (a panic included).
        struct Finish<'a>(&'a AtomicBool);
        impl Drop for Finish<'_> {
            fn drop(&mut self) {
                self.0.store(true, Ordering::SeqCst);
            }
        }
        let stats = std::thread::scope(|sc| {
            sc.spawn(|| {
                while !finished.load(Ordering::SeqCst) {
                    if INTERRUPTED.load(Ordering::SeqCst)
                        || due.is_some_and(|d| Instant::now() >= d)
                    {
                        stop.store(true, Ordering::SeqCst);
                        break;
                    }
                    std::thread::sleep(std::time::Duration::from_millis(20));
                }
            });
            let report = |d, n| progress.update(d, n);
            let ctl = Control {
                tile_done,
                ..Control::new(&stop, &report)
            };
            let _finish = Finish(&finished);
            render_into(scene, &round, film, ctl)
        })?;
        let periodic = stop.load(Ordering::SeqCst) && !INTERRUPTED.load(Ordering::SeqCst);
        let stats = match total.take() {
            None => stats,
            Some(t) => RenderStats {
                seconds: t.seconds + stats.seconds,
                samples: t.samples + stats.samples,
                rays: t.rays + stats.rays,
                non_finite: t.non_finite + stats.non_finite,
                ..stats
            },
        };
        if stats.complete || !periodic {
            return Ok(stats);
        }
        film.save(checkpoint)?;
        total = Some(stats);
    }
}

/// Renders each depth, writes every render (EXR and PNG) beside the sheet, then the sheet.
fn run_sequence(a: &SequenceArgs) -> Result<()> {
    if a.depths.is_empty() {
        return Err(Error::Usage("--depths needs at least one depth".into()));
    }
    let desc = load(a.scene.as_deref())?;
    let scene = scene::build::build(&desc);
    print_warnings(&scene.warnings);
    let dir = a.sheet.parent().map(Path::to_path_buf).unwrap_or_default();
    if !dir.as_os_str().is_empty() {
        std::fs::create_dir_all(&dir).map_err(|source| Error::Io {
            path: dir.display().to_string(),
            what: "cannot create directory",
            source,
        })?;
    }
    let mut items = Vec::new();
    println!("{:>5} {:>9} {:>14}", "m", "wall (s)", "Mrays/s");
    for &m in &a.depths {
        let opts = RenderOptions {
            spp: a.spp,
            threads: a.threads.map(|t| t as usize),
            seed: a.seed,
            integrator: IntegratorSettings {
                max_depth: m,
                accumulate: true,
                light_samples: a.light_samples,
                direct: a.direct.direct(),
                selection: LightSelection::Power,
                ..Default::default()
            },
            ..Default::default()
        };
        let progress = Progress::new(None);
        let (img, stats) = render(&scene, &opts, &|d, n| progress.update(d, n))?;
        progress.finish();
        for ext in ["exr", "png"] {
            img.save(&dir.join(format!("{}_m{m}.{ext}", scene.name)))?;
        }
        println!(
            "{:>5} {:>9.2} {:>14.2}",
            m,
            stats.seconds,
            stats.rays as f64 / stats.seconds / 1e6
        );
        items.push((format!("m={m}"), img));
    }
    let sheet = io::sheet::contact_sheet(&items, 4, 2);
    sheet.save(&a.sheet)?;
    eprintln!(
        "wrote {} and the renders beside it",
        std::path::absolute(&a.sheet)
            .unwrap_or(a.sheet.clone())
            .display()
    );
    Ok(())
}

fn run() -> Result<ExitCode> {
    let cli = Cli::parse();
    match cli.cmd {
        Some(Cmd::Diff { a, b }) => {
            let (ia, ib) = (Image::load(&a)?, Image::load(&b)?);
            let d = diff(&ia, &ib)?;
            let r = d.ratio_of_means;
            println!("size            {}x{}", ia.width, ia.height);
            println!("RMSE            {:.6}", d.rmse);
            println!(
                "relative MSE    {:.6}  (mean of (a-b)^2 / (b^2 + 0.01))",
                d.rel_mse
            );
            println!(
                "ratio of means  {:.5}  (R {:.5}, G {:.5}, B {:.5})",
                d.ratio_of_means_all, r[0], r[1], r[2]
            );
            println!("block metric    {:.5}  (R {:.5}, G {:.5}, B {:.5}; mean over 16x16 blocks of |mA-mB|/(mB+0.01), max channel shown first)", d.block_max(), d.block[0], d.block[1], d.block[2]);
            let nf = ia.count_non_finite() + ib.count_non_finite();
            if nf > 0 {
                println!("non-finite      {nf} pixels");
            }
            Ok(ExitCode::SUCCESS)
        }
        Some(Cmd::Bench {
            scene,
            threads,
            synthetic,
            npy,
        }) => {
            let desc = match synthetic {
                Some(n) => bench::synthetic(n as usize),
                None => load(scene.as_deref())?,
            };
            if let Some(dir) = &npy {
                bench::export_npy(&desc, dir)?;
                eprintln!("wrote the triangles and ray sets to {}", dir.display());
            }
            print_warnings(&desc.warnings);
            let threads = threads.map(|t| t as usize).unwrap_or_else(|| {
                std::thread::available_parallelism()
                    .map(|n| n.get())
                    .unwrap_or(1)
            });
            print!("{}", bench::run(&desc, threads)?);
            Ok(ExitCode::SUCCESS)
        }
        Some(Cmd::Sequence(a)) => run_sequence(&a).map(|()| ExitCode::SUCCESS),
        #[cfg(feature = "view")]
        Some(Cmd::View(a)) => {
            let Some((scene, opts)) = prepare(&a.render)? else {
                return Ok(ExitCode::SUCCESS);
            };
            if !a.host.is_loopback() {
                eprintln!(
                    "warning: listening on {}: anyone who can reach it and has the token can use it",
                    a.host
                );
            }
            if !a.out_dir.is_dir() {
                return Err(Error::Usage(format!(
                    "{}: the output directory does not exist",
                    a.out_dir.display()
                )));
            }
            if opts.adaptive.is_some() || opts.adaptive_budget || opts.time_limit.is_some() {
                eprintln!(
                    "warning: the viewer renders uniform passes: -a, --adaptive-budget and \
                     --time-limit are ignored"
                );
            }
            let cfg = pathtracer::view::ViewConfig {
                host: Some(a.host),
                port: a.port,
                out_dir: a.out_dir.clone(),
                display_server: a.render.display_server.clone(),
            };
            let viewer = pathtracer::view::start(scene, opts, &cfg)?;
            println!("open {}", viewer.url());
            if a.open {
                if let Err(e) = webbrowser::open(&viewer.url()) {
                    eprintln!("warning: cannot open a browser ({e}); open the URL above");
                }
            }
            viewer.wait();
            Ok(ExitCode::SUCCESS)
        }
        Some(Cmd::BenchQuality {
            shared,
            budget,
            threads,
            light_samples,
            direct,
            light_selection,
        }) => {
            let settings = IntegratorSettings {
                light_samples,
                direct: direct.direct(),
                selection: light_selection.selection(),
                ..Default::default()
            };
            eprintln!(
                "rendering {} scenes for {budget} s each (sampler {}, roulette from hit {} with \
                 survival min(1, {} x throughput), -l {}, {:?} direct light, {:?} light selection) ...",
                pathtracer::quality::SCENES.len(),
                SamplerKind::default().name(),
                settings.rr_depth,
                pathtracer::integrator::RR_SURVIVAL,
                settings.light_samples,
                settings.direct,
                settings.selection
            );
            print!(
                "{}",
                pathtracer::quality::run(
                    &shared,
                    budget as f64,
                    threads.map(|t| t as usize),
                    settings,
                    0
                )?
            );
            Ok(ExitCode::SUCCESS)
        }
        None => run_render(&cli.render),
    }
}

fn main() -> ExitCode {
    if let Some(why) = pathtracer::unsupported_cpu() {
        eprintln!("error: {why}");
        return ExitCode::from(2);
    }
    match run() {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
