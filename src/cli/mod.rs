//! The `pathtracer` command line: a thin shell over the library. Its render flags are the
//! option table's ([`pathtracer::options::args`]); this module adds the subcommands, progress,
//! checkpoints and the output files.

mod checkpoint;
mod progress;
mod render;

use clap::{Args, Parser, Subcommand};
use pathtracer::error::{Error, Result};
use pathtracer::integrator::{Direct, IntegratorSettings, LightSelection};
use pathtracer::io::image::{diff, Image};
use pathtracer::options::args::{u32_option, RenderArgs};
use pathtracer::render::{render, RenderOptions};
use pathtracer::sampling::sampler::SamplerKind;
use pathtracer::{bench, builtin, io, scene};
use progress::Progress;
use render::print_warnings;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(
    name = "pathtracer",
    version,
    about = "Physically based path tracer for the CS184 COLLADA scenes and OBJ, PLY, glTF and pbrt-v4 files",
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
        #[arg(short = 't', value_parser = u32_option("threads"))]
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
        budget: f64,
        /// Threads (default: all cores).
        #[arg(short = 't', value_parser = u32_option("threads"))]
        threads: Option<u32>,
        /// Light samples per vertex.
        #[arg(short = 'l', default_value_t = 1, value_parser = u32_option("light_samples"))]
        light_samples: u32,
        /// Direct-light estimator (mis, light or bsdf).
        #[arg(long, default_value_t = Direct::Mis)]
        direct: Direct,
        /// How lights are chosen for light sampling (power or all).
        #[arg(long, default_value_t = LightSelection::Power)]
        light_selection: LightSelection,
    },
}

#[cfg(feature = "view")]
#[derive(Args, Debug)]
pub struct ViewArgs {
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
pub struct SequenceArgs {
    /// Scene file (.dae); the built-in scene when absent.
    scene: Option<PathBuf>,
    /// Maximum depths to render, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "0,1,2,3,4,5,100")]
    depths: Vec<u32>,
    /// Camera samples per pixel.
    #[arg(short = 's', value_name = "N", default_value_t = 64, value_parser = u32_option("spp"))]
    spp: u32,
    /// Samples per area light.
    #[arg(short = 'l', value_name = "N", default_value_t = 4, value_parser = u32_option("light_samples"))]
    light_samples: u32,
    /// Worker threads (default: all cores).
    #[arg(short = 't', value_name = "N", value_parser = u32_option("threads"))]
    threads: Option<u32>,
    /// Seed of the random streams.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Contact sheet output (.png or .exr); the renders go beside it as NAME_mK.exr and .png.
    #[arg(short = 'f', value_name = "FILE", default_value = "depth_sequence.png")]
    sheet: PathBuf,
    /// Direct-light estimator (mis, light or bsdf).
    #[arg(long, default_value_t = Direct::Mis)]
    direct: Direct,
}

/// A positive, finite number.
fn positive(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("'{s}' is not a positive number")),
    }
}

fn load(path: Option<&Path>) -> Result<io::desc::SceneDesc> {
    match path {
        Some(p) => io::load_scene(p),
        None => Ok(builtin::cornell_box()),
    }
}

/// `pathtracer diff A B`: the error metrics of A against the reference B.
fn run_diff(a: &Path, b: &Path) -> Result<ExitCode> {
    let (ia, ib) = (Image::load(a)?, Image::load(b)?);
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

/// `pathtracer bench`: BVH build time and ray throughput.
fn run_bench(
    scene: Option<&Path>,
    threads: Option<u32>,
    synthetic: Option<u64>,
    npy: Option<&Path>,
) -> Result<ExitCode> {
    let desc = match synthetic {
        Some(n) => bench::synthetic(n as usize),
        None => load(scene)?,
    };
    if let Some(dir) = npy {
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

/// `pathtracer view`: starts the viewer and serves until the process is stopped.
#[cfg(feature = "view")]
fn run_view(a: &ViewArgs) -> Result<ExitCode> {
    let Some(render::Prepared { loaded, opts }) = render::prepare(&a.render)? else {
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
        display_server: a.render.files.display_server.clone(),
    };
    let viewer = pathtracer::view::start(loaded.scene, opts, &cfg)?;
    println!("open {}", viewer.url());
    if a.open {
        if let Err(e) = webbrowser::open(&viewer.url()) {
            eprintln!("warning: cannot open a browser ({e}); open the URL above");
        }
    }
    viewer.wait();
    Ok(ExitCode::SUCCESS)
}

/// `pathtracer bench-quality`: relMSE against every reference after a fixed time.
fn run_bench_quality(
    shared: &Path,
    budget: f64,
    threads: Option<u32>,
    settings: IntegratorSettings,
) -> Result<ExitCode> {
    eprintln!(
        "rendering {} scenes for {budget} s each (sampler {}, roulette from hit {} with \
         survival min(1, {} x throughput), -l {}, {:?} direct light, {:?} light selection) ...",
        pathtracer::quality::SCENES.len(),
        SamplerKind::default().name(),
        settings.rr_depth,
        settings.rr_survival,
        settings.light_samples,
        settings.direct,
        settings.selection
    );
    print!(
        "{}",
        pathtracer::quality::run(shared, budget, threads.map(|t| t as usize), settings, 0)?
    );
    Ok(ExitCode::SUCCESS)
}

fn run() -> Result<ExitCode> {
    let cli = Cli::parse();
    match cli.cmd {
        Some(Cmd::Diff { a, b }) => run_diff(&a, &b),
        Some(Cmd::Bench {
            scene,
            threads,
            synthetic,
            npy,
        }) => run_bench(scene.as_deref(), threads, synthetic, npy.as_deref()),
        Some(Cmd::Sequence(a)) => run_sequence(&a).map(|()| ExitCode::SUCCESS),
        #[cfg(feature = "view")]
        Some(Cmd::View(a)) => run_view(&a),
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
                direct,
                selection: light_selection,
                ..Default::default()
            };
            run_bench_quality(&shared, budget, threads, settings)
        }
        None => render::run_render(&cli.render),
    }
}

/// The command line: runs it and maps an error to its message and exit status 2.
pub fn main() -> ExitCode {
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

/// Renders each depth, writes every render (EXR and PNG) beside the sheet, then the sheet.
pub fn run_sequence(a: &SequenceArgs) -> Result<()> {
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
                direct: a.direct,
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
