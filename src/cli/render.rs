//! `pathtracer [FLAGS] [SCENE]`: loads the scene, resolves the options (built-in defaults <
//! the scene file's < the flags), renders with progress, checkpoints and tev, and writes the
//! image and its companions.

use super::checkpoint::{film_for, install_signal_handler, render_rounds};
use super::progress::Progress;
use pathtracer::error::{Error, Result};
use pathtracer::film::{Cell, Film, FilmPixel, Tile};
use pathtracer::options::args::RenderArgs;
use pathtracer::render::{RenderOptions, RenderStats, TileFn};
use pathtracer::setup::{self, Loaded};
use pathtracer::{info, io, light};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::Ordering;
use std::time::Instant;

/// A scene ready to render: loaded, with the resolved options and its camera set for them.
pub struct Prepared {
    /// The scene (its camera is the render's) and what it was read from.
    pub loaded: Loaded,
    /// The resolved render options.
    pub opts: RenderOptions,
}

/// Prints each warning on stderr.
pub fn print_warnings(w: &[String]) {
    for line in w {
        eprintln!("warning: {line}");
    }
}

/// Loads the scene and resolves the render options and camera of the flags; `None` when
/// `--info` or `--dry-run` printed what was asked instead.
pub fn prepare(a: &RenderArgs) -> Result<Option<Prepared>> {
    let t = Instant::now();
    let f = &a.files;
    if f.env_pdf_image.is_some() && f.env.is_none() {
        return Err(Error::Usage(
            "--env-pdf-image needs an environment map (-e MAP)".into(),
        ));
    }
    // The load-time options are chosen before loading (they shape the scene's lights).
    let load_choices = pathtracer::options::Choices::resolve(&[], &a.given)?;
    let load_opts = setup::LoadOptions {
        env: f.env.as_deref(),
        env_sampling: load_choices.env_sampling(),
        defines: &f.define,
        default_light: load_choices.default_light(),
    };
    let mut loaded = setup::load_with(f.scene.as_deref(), &load_opts)?;
    print_warnings(&loaded.warnings);
    for note in &loaded.notes {
        eprintln!("note: {note}");
    }
    if let (Some(out), Some(light::Light::Environment(env))) =
        (&f.env_pdf_image, loaded.scene.lights.last())
    {
        env.pdf_image().save(out)?;
        eprintln!(
            "wrote the environment's sampling density to {}",
            out.display()
        );
    }
    if f.info {
        print!("{}", info::summary(&loaded.scene));
        println!(
            "loading      {:.2} s, peak memory {}",
            t.elapsed().as_secs_f64(),
            info::peak_rss_text()
        );
        return Ok(None);
    }
    if let Some(path) = &f.camera {
        loaded.use_camera_file(path)?;
    }
    let choices = loaded.choices(&a.given)?;
    let opts = choices.render_options();
    opts.validate()?;
    print_warnings(&setup::unused_options(&loaded.scene, &opts));
    loaded.scene.camera = choices.view().camera(
        &loaded.scene.camera,
        loaded.file_view,
        opts.width,
        opts.height,
    )?;
    let scene = &loaded.scene;
    eprintln!(
        "loaded {} ({} primitives) in {:.2} s",
        scene.name,
        scene.tris.len() + scene.spheres.len(),
        t.elapsed().as_secs_f64()
    );
    if f.dry_run {
        for (name, value) in choices.describe() {
            println!("{name} = {value}");
        }
        return Ok(None);
    }
    Ok(Some(Prepared { loaded, opts }))
}

/// The output image of the flags (`-f`, or SCENENAME.png), refused unless .png or .exr.
fn output_of(a: &RenderArgs, name: &str) -> Result<PathBuf> {
    let out = a
        .files
        .output
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{name}.png")));
    match out
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .as_deref()
    {
        Some("png") | Some("exr") => Ok(out),
        _ => Err(Error::Usage(format!(
            "{}: unsupported output format (use .png or .exr)",
            out.display()
        ))),
    }
}

/// Renders the scene of the flags and writes the image (and on interruption the checkpoint);
/// exit status 130 when interrupted.
pub fn run_render(a: &RenderArgs) -> Result<ExitCode> {
    let Some(Prepared { loaded, opts }) = prepare(a)? else {
        return Ok(ExitCode::SUCCESS);
    };
    let scene = &loaded.scene;
    // Output places are checked before any rendering.
    let out = output_of(a, &scene.name)?;
    let checkpoint = a
        .files
        .checkpoint
        .clone()
        .unwrap_or_else(|| out.with_extension("ckpt"));
    io::atomic::check_writable(&out)?;
    io::atomic::check_writable(&checkpoint)?;
    if let Some(p) = &a.files.save_camera {
        io::atomic::check_writable(p)?;
    }
    // OIDN is found before rendering, so that a missing library costs no render.
    let denoiser = if opts.denoise {
        let d = pathtracer::denoise::Denoiser::load()
            .map_err(|e| Error::Usage(format!("--denoise: {e}")))?;
        Some(d)
    } else {
        None
    };
    let identity = setup::identity(&loaded, &scene.camera, &opts)?;
    let mut film = film_for(&opts, a.files.resume.as_deref(), identity)?;
    let interrupted = install_signal_handler();
    let progress = Progress::new(opts.time_limit);
    let tev = a
        .files
        .display_server
        .as_deref()
        .map(|addr| tev_stream(addr, &out, &opts, &film));
    let to_tev = |c: Cell, t: &Tile, px: &[FilmPixel]| {
        if let Some(tev) = &tev {
            tev.tile(c, t, px);
        }
    };
    let tile_done: Option<&TileFn<'_>> = tev.as_ref().map(|_| &to_tev as _);
    let stats = render_rounds(
        scene,
        &opts,
        &mut film,
        a.files.checkpoint_every,
        &checkpoint,
        &progress,
        tile_done,
    )?;
    progress.finish();
    if let Some(t) = tev {
        t.finish();
    }
    let img = film.develop();
    write_image(&film, &img, denoiser.as_ref(), &out)?;
    if interrupted.load(Ordering::SeqCst) && !stats.complete {
        film.save(&checkpoint)?;
        report_interrupted(&stats, &opts, &out, &checkpoint);
        return Ok(ExitCode::from(130));
    }
    if a.files.checkpoint.is_some() {
        film.save(&checkpoint)?;
    }
    report(&stats, &opts, (img.width, img.height), &out);
    write_companions(a, &loaded, &opts, &stats, &out)?;
    Ok(ExitCode::SUCCESS)
}

/// Writes the developed image `img` of `film` to `out`: as it is, or denoised with its
/// features (the noisy image then goes beside it as `NAME_noisy.exr`); and the features as
/// `NAME_albedo.exr` and `NAME_normal.exr` where the film records them.
fn write_image(
    film: &Film,
    img: &io::image::Image,
    denoiser: Option<&pathtracer::denoise::Denoiser>,
    out: &Path,
) -> Result<()> {
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let beside = |what: &str| out.with_file_name(format!("{stem}_{what}.exr"));
    let features = film.feature_images();
    if let Some((albedo, normal)) = &features {
        albedo.save(&beside("albedo"))?;
        normal.save(&beside("normal"))?;
    }
    let Some(denoiser) = denoiser else {
        return img.save(out);
    };
    img.save(&beside("noisy"))?;
    let t = Instant::now();
    let clean = denoiser
        .denoise_image(img, features.as_ref(), pathtracer::denoise::Quality::Final)
        .map_err(Error::Usage)?;
    eprintln!(
        "denoised in {:.2} s with {}",
        t.elapsed().as_secs_f64(),
        denoiser.library.display()
    );
    clean.save(out)
}

/// The tev stream of a render writing `out`; a resumed render starts from its samples.
fn tev_stream(addr: &str, out: &Path, opts: &RenderOptions, film: &Film) -> io::tev::TevStream {
    let name = out
        .file_name()
        .map_or("pathtracer".into(), |n| n.to_string_lossy());
    let t = io::tev::TevStream::start(addr, &name, opts.width, opts.height);
    let whole = Cell {
        x: 0,
        y: 0,
        w: opts.width,
        h: opts.height,
    };
    if film.cell() == whole {
        t.image(&film.develop());
    }
    t
}

/// The interrupted render's message: what was written and how to continue.
fn report_interrupted(stats: &RenderStats, opts: &RenderOptions, out: &Path, ckpt: &Path) {
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
        ckpt.display(),
        ckpt.display()
    );
}

/// The finished render's summary line: size, samples per pixel, threads, time and rates.
fn report(stats: &RenderStats, opts: &RenderOptions, (w, h): (usize, usize), out: &Path) {
    if stats.non_finite > 0 {
        eprintln!(
            "warning: {} samples with NaN/Inf radiance were counted as black",
            stats.non_finite
        );
    }
    let spp = if opts.adaptive.is_some() {
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
    };
    eprintln!(
        "rendered {w}x{h} at {spp} spp on {} threads in {:.2} s: {:.2} M samples/s, {:.2} M rays/s; peak memory {}",
        stats.threads,
        stats.seconds,
        stats.samples as f64 / stats.seconds / 1e6,
        stats.rays as f64 / stats.seconds / 1e6,
        info::peak_rss_text()
    );
    let shown = std::path::absolute(out).unwrap_or(out.to_path_buf());
    eprintln!("wrote {}", shown.display());
}

/// The sample rate image of adaptive renders (`NAME_rate.png`) and the camera file
/// (`--save-camera`).
fn write_companions(
    a: &RenderArgs,
    loaded: &Loaded,
    opts: &RenderOptions,
    stats: &RenderStats,
    out: &Path,
) -> Result<()> {
    let scene = &loaded.scene;
    if opts.adaptive.is_some() || opts.adaptive_budget {
        let stem = out
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| scene.name.clone());
        let rate = out.with_file_name(format!("{stem}_rate.png"));
        let c = opts.cell.map_or((opts.width, opts.height), |c| (c.w, c.h));
        io::image::sample_rate_image(&stats.samples_per_pixel, c.0 as usize, c.1 as usize)
            .save(&rate)?;
        eprintln!(
            "mean samples per pixel {:.1}; wrote the sample rate image {}",
            stats.mean_spp(),
            rate.display()
        );
    }
    if let Some(path) = &a.files.save_camera {
        scene.camera.save_cs184(path, opts.width, opts.height)?;
        eprintln!("wrote the camera to {}", path.display());
    }
    Ok(())
}
