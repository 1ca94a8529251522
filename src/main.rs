//! The `rlpt` command line.

use anyhow::{bail, Context as _, Result};
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rlpt::film::Film;
use rlpt::gpu::{Context, ContextOptions};
use rlpt::prepared::{PreparedScene, RenderOptions};
use rlpt::render::GpuRenderer;
use rlpt::scene::Scene;
use rlpt::shared;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

#[derive(Parser)]
#[command(name = "rlpt", version, about = "A Vulkan compute path tracer that learns where light comes from")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to a PNG (clamped, sRGB) or an EXR (linear float).
    Render(RenderArgs),
    /// List the Vulkan devices, their drivers and subgroup sizes, and what rlpt needs that they lack.
    Devices,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum DeviceKind {
    Gpu,
    Cpu,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum OnOff {
    On,
    Off,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Heuristic {
    Power,
    Balance,
}

#[derive(clap::Args)]
struct RenderArgs {
    /// Scene file (TOML, see SCENE_FORMAT.md).
    scene: PathBuf,
    /// Output image: .png or .exr.
    #[arg(short, long)]
    output: PathBuf,
    /// Image width in pixels (default: the scene's).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    width: Option<u32>,
    /// Image height in pixels (default: the scene's).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    height: Option<u32>,
    /// Samples per pixel, rounded up to a multiple of 64 (default: the scene's).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    spp: Option<u32>,
    /// Scattering events per path (default: the scene's).
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=1024))]
    max_bounces: Option<u32>,
    /// Random seed; the same seed gives the same image on the same device.
    #[arg(long, default_value_t = 0)]
    seed: u32,
    /// Render on the GPU (Vulkan) or on the CPU (all cores).
    #[arg(long, value_enum, default_value_t = DeviceKind::Gpu)]
    device: DeviceKind,
    /// Vulkan device index from `rlpt devices` (default: the first discrete GPU).
    #[arg(long)]
    gpu: Option<usize>,
    /// Next-event estimation: sample lights and combine with BSDF sampling by MIS.
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    nee: OnOff,
    /// MIS heuristic for combining light and BSDF sampling.
    #[arg(long, value_enum, default_value_t = Heuristic::Power)]
    mis: Heuristic,
}

fn main() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        // The Vulkan loader complains on stderr without it.
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render(args),
        Command::Devices => devices(),
    };
    if let Err(e) = result {
        eprintln!("rlpt: error: {e:#}");
        std::process::exit(1);
    }
}

fn check_output(path: &Path) -> Result<()> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    if !matches!(ext.as_deref(), Some("png") | Some("exr")) {
        bail!("output {}: the file name must end in .png or .exr", path.display());
    }
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        if !parent.is_dir() {
            bail!("output {}: directory {} does not exist", path.display(), parent.display());
        }
    }
    Ok(())
}

fn render(args: RenderArgs) -> Result<()> {
    check_output(&args.output)?;
    let scene = Scene::load(&args.scene)?;
    let mut opts = RenderOptions::from_scene(&scene);
    if let Some(w) = args.width {
        opts.width = w;
    }
    if let Some(h) = args.height {
        opts.height = h;
    }
    if let Some(s) = args.spp {
        opts.spp = s;
    }
    if let Some(b) = args.max_bounces {
        opts.max_bounces = b;
    }
    opts.seed = args.seed;
    opts.nee = args.nee == OnOff::On;
    opts.power_heuristic = args.mis == Heuristic::Power;
    let frames = opts.frames();
    let spp = frames * shared::SAMPLES_PER_FRAME;
    if spp != opts.spp {
        eprintln!(
            "note: {} samples per pixel rounded up to {spp}: rlpt renders frames of {} samples per pixel",
            opts.spp,
            shared::SAMPLES_PER_FRAME
        );
    }
    let prepared = PreparedScene::new(&scene, &opts);

    let bar = ProgressBar::with_draw_target(Some(frames as u64), ProgressDrawTarget::hidden());
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} frames ({eta} left)")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let start = Instant::now();
    let mut shown = false;
    let mut tick = |done: u32| {
        if !shown && start.elapsed() > Duration::from_secs(1) {
            bar.set_draw_target(ProgressDrawTarget::stderr());
            shown = true;
        }
        bar.set_position(done as u64);
    };

    let (film, device_name, gpu_ms): (Film, String, Option<f64>) = match args.device {
        DeviceKind::Cpu => {
            let mut film = Film::new(opts.width, opts.height);
            rlpt::cpu::render(&prepared, &mut film, frames, |f| tick(f.frames));
            (film, format!("CPU ({} threads)", rayon::current_num_threads()), None)
        }
        DeviceKind::Gpu => {
            let ctx = Context::new(&ContextOptions::from_env(args.gpu))?;
            let mut renderer = GpuRenderer::new(&ctx, &prepared)?;
            let mut gpu_ms = Some(0.0);
            for f in 0..frames {
                let ms = renderer.render_frames(1)?;
                gpu_ms = gpu_ms.zip(ms).map(|(a, b)| a + b);
                tick(f + 1);
            }
            let film = renderer.film()?;
            (film, ctx.info.name.clone(), gpu_ms)
        }
    };
    bar.finish_and_clear();
    let elapsed = start.elapsed().as_secs_f64();
    film.mean().save(&args.output).with_context(|| format!("writing {}", args.output.display()))?;
    let samples = opts.width as f64 * opts.height as f64 * spp as f64;
    let gpu = gpu_ms.map(|ms| format!(", GPU time {:.1} ms", ms)).unwrap_or_default();
    println!(
        "{}: {}x{}, {} spp in {:.2} s on {} ({:.1} Msamples/s{}) -> {}",
        args.scene.display(),
        opts.width,
        opts.height,
        spp,
        elapsed,
        device_name,
        samples / elapsed / 1e6,
        gpu,
        args.output.display()
    );
    Ok(())
}

fn devices() -> Result<()> {
    let devices = rlpt::gpu::list_devices()?;
    for d in devices {
        println!("[{}] {} ({}), Vulkan {}", d.index, d.name, d.device_type, d.api_version);
        println!("    driver: {}", d.driver);
        println!("    subgroup size {}: {}", d.subgroup_size, d.subgroup_operations.join(", "));
        println!(
            "    float atomic add: {}; subgroup partition (NV): {}; timestamps: {}",
            yes_no(d.float_atomic_add),
            yes_no(d.subgroup_partitioned),
            yes_no(d.timestamps)
        );
        if d.missing.is_empty() {
            println!("    usable by rlpt");
        } else {
            println!("    NOT usable by rlpt: lacks {}", d.missing.join(", "));
        }
    }
    Ok(())
}

fn yes_no(b: bool) -> &'static str {
    if b {
        "yes"
    } else {
        "no"
    }
}
