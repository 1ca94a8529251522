//! The `rlpt` command line.

use anyhow::{bail, Context as _, Result};
use clap::{Parser, Subcommand, ValueEnum};
use rlpt::cpu::CpuRenderer;
use rlpt::gpu::{Context, ContextOptions};
use rlpt::guide::{Bins, GuidingMode};
use rlpt::image::Image;
use rlpt::metrics;
use rlpt::options::{Counters, RenderOptions};
use rlpt::prepared::PreparedScene;
use rlpt::render::GpuRenderer;
use rlpt::scene::Scene;
use rlpt::session::{Budget, Renderer, Session, Stop};
use rlpt::shared;
use rlpt::stats::RenderStats;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

#[derive(Parser)]
#[command(name = "rlpt", version, about = "A Vulkan compute path tracer that learns where light comes from")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to a PNG (clamped, sRGB) or an EXR (linear float).
    ///
    /// Ctrl-C stops the render once the frame in flight ends and writes what was rendered
    /// (the image, and --variance and --stats where asked), its true samples per pixel in
    /// the summary; rlpt then exits with status 130, as a shell reports a command that
    /// Ctrl-C ended, so that a script does not take the image for the render it asked for.
    /// A second Ctrl-C quits at once, writing nothing.
    Render(RenderArgs),
    /// Open a window that shows the render converge; move around, switch guiding and NEE.
    View(ViewArgs),
    /// List the Vulkan devices, their drivers and subgroup sizes, and what rlpt needs that they lack.
    Devices,
    /// Print relMSE, RMSE and MAPE of an image against a reference (EXR or PNG).
    Compare {
        image: PathBuf,
        reference: PathBuf,
        /// The reference's per-pixel variance (EXR, from `render --variance`): also print
        /// the relMSE less the reference's own noise, the error against the true image.
        #[arg(long)]
        reference_variance: Option<PathBuf>,
        /// The image's per-pixel variance (EXR, from `render --variance`). With the
        /// reference's too, and two independent renders, also print whether their means
        /// agree: over the whole image and 16 regions, per channel, as z-scores.
        #[arg(long, requires = "reference_variance")]
        image_variance: Option<PathBuf>,
        /// Fail when a mean differs by more than Z standard deviations (needs both variances).
        #[arg(long, value_name = "Z", requires = "image_variance")]
        max_z: Option<f64>,
        /// The relative difference the agreement does not resolve, added to each mean's
        /// deviation (f32 rounding along a path; 0: the noise alone).
        #[arg(long, value_name = "F", default_value_t = 1e-4, requires = "image_variance")]
        floor: f64,
    },
    /// Time every GPU pass of every frame (timestamp queries): a table, JSON, a Chrome trace.
    Bench(BenchArgs),
    /// Plot relMSE against time from `render --stats` files (log-log PNG).
    Plot {
        /// Statistics files written by `rlpt render --stats`.
        #[arg(required = true)]
        stats: Vec<PathBuf>,
        #[arg(short, long)]
        output: PathBuf,
        /// Plot the relMSE less the reference's variance (`render --reference-variance`)
        /// instead of the plain relMSE.
        #[arg(long)]
        debiased: bool,
    },
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

/// What a frame is: size, bounces, seed, device, NEE and guiding (`render` and `bench`).
#[derive(clap::Args)]
struct Settings {
    /// Image width in pixels (default: the scene's).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=rlpt::layout::MAX_IMAGE_SIDE as i64))]
    width: Option<u32>,
    /// Image height in pixels (default: the scene's).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=rlpt::layout::MAX_IMAGE_SIDE as i64))]
    height: Option<u32>,
    /// Scattering events per path (default: the scene's).
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=rlpt::layout::MAX_BOUNCES as i64))]
    max_bounces: Option<u32>,
    /// Random seed; the same seed gives the same image on the same device (with
    /// guiding, to rounding only: learning adds its targets in the order threads finish).
    #[arg(long, default_value_t = 0, value_parser = parse_seed)]
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
    /// MIS heuristic for combining light and BSDF sampling (with NEE) [default: power].
    #[arg(long, value_enum)]
    mis: Option<Heuristic>,
    /// Learned guiding: off, octant (the seed's 8 octants) or sphere (finer bins, see --bins).
    #[arg(long, value_enum, default_value_t = GuidingMode::Off)]
    guiding: GuidingMode,
    /// Direction bins of --guiding sphere, ROWSxCOLS (rows uniform in cos theta, columns in
    /// phi) [default: 20x40 in scenes with Russian roulette, where every vertex records
    /// targets; 8x16 without].
    #[arg(long, value_parser = parse_bins)]
    bins: Option<Bins>,
    /// Probability of sampling a guided direction at a non-delta vertex (the rest: BSDF
    /// sampling): `learned` (each cell learns its own, starting at 0.5, within [0.1, 0.9]),
    /// or a fixed number in [0, 1) [default: learned].
    #[arg(long, value_parser = parse_fraction, allow_negative_numbers = true)]
    guided_fraction: Option<FractionArg>,
    /// Guided sampling at the first N vertices of each path (1: the camera ray's hit
    /// alone); deeper vertices sample the BSDF alone. Default: every vertex in scenes
    /// with Russian roulette (which look up every vertex's cell anyway); without
    /// roulette 2 with NEE, every vertex without (where only guided sampling aims at
    /// the lights).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    guided_vertices: Option<u32>,
    /// Exponent W of the Q-learning rate 1/i^W for an entry's i-th target, in (0.5, 1]:
    /// 1 is Dahm & Keller's running mean; below 1 forgets the first targets, learned from
    /// a table that knew little, sooner, and converges to the same values (it did not pay
    /// at equal time on the shipped scenes, see BENCHMARKS.md) [default: 1].
    #[arg(long, value_name = "W", value_parser = parse_rate_exponent, allow_negative_numbers = true)]
    learning_rate_exponent: Option<f32>,
    /// Exploration floor F of guided sampling: a bin is drawn in proportion to its Q plus
    /// F times its cell's mean Q (both weighted by the cosine), so that bins whose light
    /// was not found yet keep a share F / (1 + F) of the guided draws; 0 draws by Q alone
    /// (BSDF sampling still reaches every direction) [default: 0.1].
    #[arg(long, value_name = "F", value_parser = parse_floor, allow_negative_numbers = true)]
    exploration_floor: Option<f32>,
    /// Frames at the start of a guided render that teach the table and are then left out
    /// of the image, which starts after them (learned roulette's estimate still counts
    /// them). `--spp` counts the image's samples; `--time` counts the learning frames'
    /// time too [default: 4 in scenes with Russian roulette, the frames before learned
    /// roulette starts; 0 without].
    #[arg(long, value_name = "N", value_parser = parse_learning_frames, allow_negative_numbers = true)]
    learning_frames: Option<u32>,
    /// What a Q-learning target counts of the light its ray meets, with NEE on: `mis`
    /// counts the emission met with the MIS weight the image gives it and adds the light
    /// sample at the vertex met, so that guided directions seek what light sampling
    /// misses; `full` is Dahm & Keller's target, the emission met in full. Without NEE
    /// the two are the same [default: mis].
    #[arg(long, value_enum)]
    q_targets: Option<rlpt::guide::QTargets>,
}

impl Settings {
    /// The scene's render settings with these overrides.
    fn options(&self, scene: &Scene) -> RenderOptions {
        let mut opts = RenderOptions::from_scene(scene);
        if let Some(w) = self.width {
            opts.width = w;
        }
        if let Some(h) = self.height {
            opts.height = h;
        }
        if let Some(b) = self.max_bounces {
            opts.max_bounces = b;
        }
        opts.seed = self.seed;
        opts.nee = self.nee == OnOff::On;
        opts.power_heuristic = self.mis.unwrap_or(Heuristic::Power) == Heuristic::Power;
        opts.guiding = self.guiding_mode();
        opts.bins = self.bins;
        match self.guided_fraction.unwrap_or(FractionArg::Learned) {
            FractionArg::Fixed(f) => {
                opts.guided_fraction = f;
                opts.learn_fraction = false;
            }
            FractionArg::Learned => opts.learn_fraction = true,
        }
        opts.guided_vertices = self.guided_vertices;
        opts.learning_rate_exponent = self.learning_rate_exponent.unwrap_or(rlpt::guide::DEFAULT_RATE_EXPONENT);
        opts.guide_floor = self.exploration_floor.unwrap_or(rlpt::guide::DEFAULT_FLOOR);
        opts.learning_frames = self.learning_frames;
        opts.q_targets = self.q_targets.unwrap_or(rlpt::guide::QTargets::Mis);
        opts
    }

    fn guiding_mode(&self) -> GuidingMode {
        self.guiding
    }

    /// The options given that the other settings leave without effect, as notes
    /// for stderr: a flag that changes nothing should not pass without a word.
    fn ignored(&self) -> Vec<String> {
        let mut notes = Vec::new();
        let guiding = self.guiding_mode().name();
        if self.bins.is_some() && self.guiding != GuidingMode::Sphere {
            notes.push(format!("--bins sets the bins of --guiding sphere; ignored with --guiding {guiding}"));
        }
        if self.guiding == GuidingMode::Off {
            let given = [
                ("--guided-fraction", self.guided_fraction.is_some()),
                ("--guided-vertices", self.guided_vertices.is_some()),
                ("--learning-rate-exponent", self.learning_rate_exponent.is_some()),
                ("--exploration-floor", self.exploration_floor.is_some()),
                ("--learning-frames", self.learning_frames.is_some()),
                ("--q-targets", self.q_targets.is_some()),
            ];
            for (flag, _) in given.iter().filter(|(_, g)| *g) {
                notes.push(format!("{flag} is a setting of learned guiding; ignored with --guiding off"));
            }
        }
        if self.mis.is_some() && self.nee == OnOff::Off {
            notes.push("--mis weighs light sampling against BSDF sampling; ignored with --nee off".into());
        }
        if self.q_targets.is_some() && self.nee == OnOff::Off && self.guiding != GuidingMode::Off {
            notes.push(
                "--q-targets weighs the light met against light sampling; the same either way with --nee off".into(),
            );
        }
        if self.gpu.is_some() && self.device == DeviceKind::Cpu {
            notes.push("--gpu picks a Vulkan device; ignored with --device cpu".into());
        }
        notes
    }

    /// Prints [`Settings::ignored`]'s notes.
    fn note_ignored(&self) {
        for n in self.ignored() {
            eprintln!("note: {n}");
        }
    }
}

#[derive(clap::Args)]
struct RenderArgs {
    /// Scene file (TOML, see SCENE_FORMAT.md).
    scene: PathBuf,
    /// Output image: .png or .exr.
    #[arg(short, long)]
    output: PathBuf,
    /// Samples per pixel, rounded up to a multiple of 64 (default: the scene's).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=rlpt::layout::MAX_SPP as i64))]
    spp: Option<u32>,
    #[command(flatten)]
    settings: Settings,
    /// Reference image (EXR) to measure relMSE against, frame by frame, for --stats.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// The reference's per-pixel variance (EXR, from `render --variance`): --stats then
    /// also records the relMSE less the reference's own noise, the error against the
    /// true image (`rel_mse_debiased`).
    #[arg(long, requires = "reference")]
    reference_variance: Option<PathBuf>,
    /// Also write the variance of each pixel's estimate (linear EXR), from the spread of
    /// its frames' 64-sample means (at least 2 frames): a reference's, for --reference-variance.
    #[arg(long)]
    variance: Option<PathBuf>,
    /// Write per-frame statistics (time, relMSE, zero-radiance paths) as JSON.
    #[arg(long)]
    stats: Option<PathBuf>,
    /// Stop once this much render time has passed (GPU time from timestamps on the GPU,
    /// wall clock on the CPU): equal-time comparisons. --spp is then the upper bound.
    #[arg(long, value_parser = parse_seconds)]
    time: Option<f64>,
}

#[derive(clap::Args)]
struct ViewArgs {
    /// Scene file (TOML, see SCENE_FORMAT.md).
    scene: PathBuf,
    #[command(flatten)]
    settings: Settings,
    /// Scripted mode: render this many frames (64 spp each), save --screenshot, exit.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    frames: Option<u32>,
    /// Scripted mode: where to save what the window shows (.png; the linear image is
    /// written beside it as .exr).
    #[arg(long)]
    screenshot: Option<PathBuf>,
    /// Scripted mode: resize the window to WxH after the first frame (exercises
    /// swapchain recreation).
    #[arg(long, value_parser = parse_size)]
    resize: Option<(u32, u32)>,
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("`{s}`: expected WIDTHxHEIGHT, e.g. 800x600"))?;
    let parse = |v: &str| match v.trim().parse::<u32>() {
        Ok(n) if (1..=16384).contains(&n) => Ok(n),
        _ => Err(format!("`{s}`: `{v}` is not a size from 1 to 16384")),
    };
    Ok((parse(w)?, parse(h)?))
}

#[derive(clap::Args)]
struct BenchArgs {
    /// Scene file (TOML, see SCENE_FORMAT.md).
    scene: PathBuf,
    /// Frames (64 spp each) to measure.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    frames: u32,
    /// Frames rendered first and not measured (warm-up: clocks, caches, and guiding's learning).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(0..=100_000))]
    warmup: u32,
    #[command(flatten)]
    settings: Settings,
    /// Write the report (per-pass summary, every frame, pipeline statistics) as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write the frames as a Chrome trace-event file (Perfetto, chrome://tracing).
    #[arg(long)]
    trace: Option<PathBuf>,
    /// Profiling: leave parts of guiding out of the measured frames (the warm-up
    /// learns as usual), to see what each costs. The image is then not rlpt's.
    #[arg(long, value_enum, value_delimiter = ',')]
    ablate: Vec<AblateArg>,
    /// Count the rays traced, the lane utilization and the paths that carried nothing
    /// (on, the default); the paths alone (paths: the kernel `render --stats` runs,
    /// which leaves the counting of rays out of its path loop); or nothing (off: the
    /// kernel that `render` and `view` run).
    #[arg(long, value_enum, default_value_t = Counters::All)]
    counters: Counters,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum AblateArg {
    /// Recording Q-learning targets (the subgroup-aggregated atomics).
    Record,
    /// Guided sampling and the guided pdf (paths sample the BSDF only).
    GuidedSampling,
}

fn parse_seed(s: &str) -> Result<u32, String> {
    s.trim().parse().map_err(|_| format!("`{s}` is not a seed: an integer from 0 to {}", u32::MAX))
}

fn parse_seconds(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("`{s}` is not a positive number of seconds")),
    }
}

fn parse_bins(s: &str) -> Result<Bins, String> {
    Bins::parse(s)
}

/// `--guided-fraction`: a fixed probability, or learned per cell.
#[derive(Clone, Copy, Debug, PartialEq)]
enum FractionArg {
    Fixed(f32),
    Learned,
}

fn parse_fraction(s: &str) -> Result<FractionArg, String> {
    if s == "learned" {
        return Ok(FractionArg::Learned);
    }
    let v: f32 = s.parse().map_err(|_| format!("`{s}` is neither a number nor `learned`"))?;
    rlpt::options::check_guided_fraction(v).map_err(|e| format!("`{s}`: expected {e}"))?;
    Ok(FractionArg::Fixed(v))
}

/// A number that `check` accepts; its message says what was expected.
fn parse_checked(s: &str, check: fn(f32) -> Result<(), String>) -> Result<f32, String> {
    let v: f32 = s.parse().map_err(|_| format!("`{s}` is not a number"))?;
    check(v).map_err(|e| format!("`{s}`: expected {e}"))?;
    Ok(v)
}

fn parse_rate_exponent(s: &str) -> Result<f32, String> {
    parse_checked(s, rlpt::guide::check_rate_exponent)
}

fn parse_floor(s: &str) -> Result<f32, String> {
    parse_checked(s, rlpt::guide::check_floor)
}

fn parse_learning_frames(s: &str) -> Result<u32, String> {
    let v: u32 = s.parse().map_err(|_| format!("`{s}` is not a whole number of frames"))?;
    rlpt::guide::check_learning_frames(v).map_err(|e| format!("`{s}`: expected {e}"))?;
    Ok(v)
}

fn main() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        // The Vulkan loader complains on stderr without it.
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render(args).map(|outcome| {
            if outcome == Outcome::Interrupted {
                // 128 + SIGINT, as a shell reports a command that Ctrl-C stopped: a script
                // must not take the image for the render it asked for.
                std::process::exit(EXIT_INTERRUPTED);
            }
        }),
        Command::View(args) => view(args),
        Command::Bench(args) => bench(args),
        Command::Devices => devices(),
        Command::Compare { image, reference, reference_variance, image_variance, max_z, floor } => {
            compare(&image, &reference, reference_variance.as_deref()).and_then(|()| {
                match (image_variance, reference_variance) {
                    (Some(iv), Some(rv)) => agree(&image, &iv, &reference, &rv, max_z, floor),
                    _ => Ok(()),
                }
            })
        }
        Command::Plot { stats, output, debiased } => plot(&stats, &output, debiased),
    };
    if let Err(e) = result {
        eprintln!("rlpt: error: {e:#}");
        std::process::exit(if INTERRUPTED.load(Ordering::SeqCst) { EXIT_INTERRUPTED } else { 1 });
    }
    // Every context is gone by now, so this counts what the layer said at their
    // destruction too: with validation on, any message fails the run (and the tests).
    let messages = rlpt::gpu::validation_messages_total();
    if messages > 0 {
        eprintln!("rlpt: error: the Vulkan validation layer reported {messages} problem(s) (printed above)");
        std::process::exit(1);
    }
}

/// The exit status of a render that Ctrl-C stopped: 128 + SIGINT, what a shell
/// reports for a command the signal ended, whether or not the image was written.
const EXIT_INTERRUPTED: i32 = 130;

/// Set by the first Ctrl-C (SIGINT) during `rlpt render`: the render stops after
/// the frame in flight and writes what it has, as [`catch_interrupt`] says.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Makes Ctrl-C stop a render instead of ending the process: the first sets
/// [`INTERRUPTED`], which the frame loop reads between frames; a second, before
/// the outputs are written, ends the process at once, writing nothing.
fn catch_interrupt() {
    let set = ctrlc::set_handler(|| {
        if INTERRUPTED.swap(true, Ordering::SeqCst) {
            eprintln!("\nrlpt: interrupted again: quitting without writing anything");
            std::process::exit(EXIT_INTERRUPTED);
        }
        eprintln!(
            "\nrlpt: interrupted: writing what is rendered once the frame in flight ends \
             (Ctrl-C again quits at once, writing nothing)"
        );
    });
    if let Err(e) = set {
        eprintln!("warning: Ctrl-C will end the render without writing what it rendered: {e}");
    }
}

/// How a render that wrote its outputs ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Outcome {
    /// Every frame asked for (or all that --time allowed).
    Complete,
    /// Ctrl-C stopped it before the frames asked for: the outputs hold fewer.
    Interrupted,
}

/// The sentence of a render whose device was lost after `frames` frames (the
/// learning frames counted): whether the image so far went to `output` (`written`:
/// its spp), or why it could not.
fn device_lost_message(detail: &str, frames: u32, output: &Path, written: Option<u32>) -> String {
    let when = match frames {
        0 => "before the first frame ended".to_string(),
        1 => "after 1 frame".to_string(),
        n => format!("after {n} frames"),
    };
    let outcome = match written {
        Some(spp) => format!("the image so far ({spp} spp) was written to {}", output.display()),
        None if frames == 0 => format!("nothing was rendered, and nothing written to {}", output.display()),
        None => format!(
            "what it rendered cannot be read back from a lost device, so nothing was written to {}",
            output.display()
        ),
    };
    format!(
        "the GPU stopped responding (device lost: {detail}) {when}; {outcome}: render again, and if it recurs \
         render a smaller image, update the GPU driver, or render on the CPU (--device cpu)"
    )
}

/// What render, bench and view say on stderr before they start: the options the
/// other settings leave without effect, and a scene where nothing gives light.
fn warn_before_render(settings: &Settings, scene: &Scene) {
    settings.note_ignored();
    if let Some(w) = rlpt::scene::no_light_warning(scene) {
        eprintln!("warning: {w}");
    }
}

/// The warning of a render that would hold more host memory than is available
/// (`film::memory_warning`).
fn warn_memory(opts: &RenderOptions, device: DeviceKind) {
    let pixels = opts.width as u64 * opts.height as u64;
    let gpu = matches!(device, DeviceKind::Gpu);
    if let Some(w) = rlpt::film::available_memory().and_then(|a| rlpt::film::memory_warning(pixels, gpu, a)) {
        eprintln!("warning: {}x{}: {w}", opts.width, opts.height);
    }
}

/// The warning of a `[guiding]` box that misses what the camera sees
/// (`guide::grid_warning`), where `prepared` is guided.
fn warn_grid(scene: &Scene, prepared: &PreparedScene) {
    if let Some(w) = rlpt::guide::grid_warning(prepared, prepared.guide.as_ref(), &scene.guiding) {
        eprintln!("warning: {}: {w}", scene.source.display());
    }
}

/// Refuses an output path before any work ([`rlpt::output::check_output_path`]).
fn check_output(flag: &str, path: &Path, extensions: Option<&[&str]>) -> Result<()> {
    rlpt::output::check_output_path(flag, path, extensions).map_err(anyhow::Error::msg)
}

/// Refuses two outputs of one command at the same path (one would overwrite
/// the other): `outputs` are (flag, path) pairs, absent ones left out.
fn check_distinct(outputs: &[(&str, &Path)]) -> Result<()> {
    let key = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    for (i, (a, pa)) in outputs.iter().enumerate() {
        for (b, pb) in &outputs[i + 1..] {
            if key(pa) == key(pb) {
                bail!("{a} and {b} both name {}: one would overwrite the other", pa.display());
            }
        }
    }
    Ok(())
}

fn render(args: RenderArgs) -> Result<Outcome> {
    // Ctrl-C from here on stops the render after the frame in flight and writes what it
    // has; during the set-up (scene, device, kernels) it stops after the first frame.
    catch_interrupt();
    check_output("output", &args.output, Some(&["png", "exr"]))?;
    if let Some(stats) = &args.stats {
        check_output("--stats", stats, None)?;
    }
    if let Some(variance) = &args.variance {
        check_output("--variance", variance, Some(&["exr"]))?;
    }
    let mut outputs = vec![("--output", args.output.as_path())];
    outputs.extend(args.stats.as_deref().map(|p| ("--stats", p)));
    outputs.extend(args.variance.as_deref().map(|p| ("--variance", p)));
    outputs.extend(args.reference.as_deref().map(|p| ("--reference", p)));
    outputs.extend(args.reference_variance.as_deref().map(|p| ("--reference-variance", p)));
    check_distinct(&outputs)?;
    let scene = Scene::load(&args.scene)?;
    warn_before_render(&args.settings, &scene);
    let mut opts = args.settings.options(&scene);
    if let Some(s) = args.spp {
        opts.spp = s;
    }
    // The zero-radiance fraction of --stats comes from the kernel's counters;
    // it counts no rays, which would cost time in the loop that --stats times.
    opts.counters = if args.stats.is_some() { Counters::ZeroPaths } else { Counters::Off };
    let reference = match &args.reference {
        Some(path) => {
            let r = load_exr(
                path,
                "the reference",
                "reference",
                "relMSE is measured against a linear EXR (render one with -o REF.exr)",
            )?;
            if (r.width, r.height) != (opts.width, opts.height) {
                bail!(
                    "reference {} is {}x{} but the render is {}x{}: render the reference at the same size",
                    path.display(),
                    r.width,
                    r.height,
                    opts.width,
                    opts.height
                );
            }
            let r = metrics::Reference::new(r).map_err(|m| {
                anyhow::anyhow!("--reference {}: {m}: every relMSE against it would be NaN", path.display())
            })?;
            Some(match &args.reference_variance {
                Some(v) => with_reference_variance(r, v)?,
                None => r,
            })
        }
        None => None,
    };
    let frames = opts.frames();
    if args.variance.is_some() && frames < 2 {
        bail!(
            "--variance needs at least 2 frames ({} samples per pixel): a pixel's variance is measured \
             from the spread of its frames",
            2 * shared::SAMPLES_PER_FRAME
        );
    }
    let rounded = frames * shared::SAMPLES_PER_FRAME;
    if rounded != opts.spp && args.time.is_none() {
        eprintln!(
            "note: {} samples per pixel rounded up to {rounded}: rlpt renders frames of {} samples per pixel",
            opts.spp,
            shared::SAMPLES_PER_FRAME
        );
    }
    let prepared = PreparedScene::new(&scene, &opts)?;
    warn_grid(&scene, &prepared);
    warn_memory(&opts, args.settings.device);
    // The learning frames come first, and the image's frames after them.
    let learning_frames = prepared.learning_frames();
    let traced_frames = frames + learning_frames;

    let start = Instant::now();
    let renderer: Box<dyn Renderer> = match args.settings.device {
        DeviceKind::Cpu => Box::new(CpuRenderer::new(&prepared)),
        DeviceKind::Gpu => {
            let ctx = Context::new(&ContextOptions::from_env(args.settings.gpu))?;
            Box::new(GpuRenderer::new(&ctx, &prepared)?)
        }
    };
    let device_name = renderer.device_name();
    let mut stats = RenderStats {
        label: format!(
            "{} guiding={}{}{}{}{} nee={}",
            file_name(&args.scene),
            opts.guiding.name(),
            opts.guided_fraction_name().filter(|f| f != "learned").map_or(String::new(), |f| format!(" fraction={f}")),
            opts.learning_rate_exponent_if_guided()
                .filter(|&w| w != rlpt::guide::DEFAULT_RATE_EXPONENT)
                .map_or(String::new(), |w| format!(" rate=1/i^{w}")),
            opts.exploration_floor_if_guided()
                .filter(|&f| f != rlpt::guide::DEFAULT_FLOOR)
                .map_or(String::new(), |f| format!(" floor={f}")),
            opts.q_targets_if_guided().filter(|&t| t != "mis").map_or(String::new(), |t| format!(" targets={t}")),
            opts.nee
        ),
        scene: args.scene.display().to_string(),
        device: device_name.clone(),
        width: opts.width,
        height: opts.height,
        guiding: opts.guiding.name().into(),
        guided_fraction: opts.guided_fraction_name(),
        learning_rate_exponent: opts.learning_rate_exponent_if_guided(),
        exploration_floor: opts.exploration_floor_if_guided(),
        q_targets: opts.q_targets_if_guided().map(String::from),
        nee: opts.nee,
        learning_frames: prepared.guide.as_ref().map(|g| g.learning_frames),
        frames: Vec::new(),
    };
    let paths_per_frame = (opts.width as u64 * opts.height as u64 * shared::SAMPLES_PER_FRAME as u64) as f64;
    let mut session = Session::new(renderer, reference.as_ref(), paths_per_frame);
    let budget = Budget { frames: traced_frames, time_ms: args.time.map(|t| t * 1e3) };
    let (stop, film) = session.run(budget, &INTERRUPTED)?;
    let traced = session.traced();
    let gpu_ms_total = session.elapsed_ms;
    let spp = session.renderer.image_frames() * shared::SAMPLES_PER_FRAME;
    stats.frames = std::mem::take(&mut session.frames);
    let renderer = &session.renderer;
    let film = match (film, &stop) {
        (Some(f), _) => f,
        (None, Stop::DeviceLost(detail)) => match renderer.film() {
            Ok(f) => f,
            Err(_) => bail!(device_lost_message(detail, traced, &args.output, None)),
        },
        (None, _) => renderer.film()?,
    };
    if traced == 0 {
        // Lost at the first frame, and the film read back: nothing to write.
        if let Stop::DeviceLost(detail) = &stop {
            bail!(device_lost_message(detail, 0, &args.output, None));
        }
    }
    let elapsed = start.elapsed().as_secs_f64();
    let image = film.mean();
    image.save(&args.output).with_context(|| format!("writing {}", args.output.display()))?;
    if let Some(path) = &args.variance {
        let v = film.variance_of_mean().ok_or_else(|| {
            let why = match stop {
                Stop::Finished => "give --time more",
                Stop::Interrupted => "it was interrupted",
                Stop::DeviceLost(_) => "the GPU stopped responding",
            };
            anyhow::anyhow!(
                "--variance {}: the render stopped after {} frame(s), and a pixel's variance is measured from the \
                 spread of at least 2 ({why}); the image was written to {}",
                path.display(),
                film.frames,
                args.output.display()
            )
        })?;
        v.save(path).with_context(|| format!("writing {}", path.display()))?;
    }
    if image.pixels.iter().all(|p| *p == [0.0; 3]) && scene.emits_light() {
        eprintln!(
            "warning: every pixel of {} is black: no path found light (is the camera inside a closed object, \
             or facing away from every lit surface? or were there too few samples for a dim scene?)",
            args.output.display()
        );
    }
    if let Some(path) = &args.stats {
        stats.save(path)?;
    }
    // Samples traced, the learning frames' included.
    let samples = opts.width as f64 * opts.height as f64 * (traced * shared::SAMPLES_PER_FRAME) as f64;
    let gpu = match renderer.timestamps() {
        true => {
            format!(", GPU time {gpu_ms_total:.1} ms, {:.3} ms per frame", gpu_ms_total / traced as f64)
        }
        _ => String::new(),
    };
    // Whether the image started after the learning frames.
    let learned = if learning_frames > 0 && traced > learning_frames {
        format!(" after {learning_frames} learning frames")
    } else {
        String::new()
    };
    let last_frame = stats.frames.last();
    let rel = last_frame.and_then(|f| f.rel_mse).map(|e| format!(", relMSE {e:.3e}")).unwrap_or_default();
    let rel = match last_frame.and_then(|f| f.rel_mse_debiased) {
        Some(d) => format!("{rel} ({d:.3e} less the reference's variance)"),
        None => rel,
    };
    // The samples per pixel of an image cut short, and why, beside those asked for.
    let asked = frames * shared::SAMPLES_PER_FRAME;
    let cut = match stop {
        Stop::Interrupted => format!(" (interrupted: {asked} asked)"),
        Stop::DeviceLost(_) => format!(" (the GPU stopped responding: {asked} asked)"),
        Stop::Finished => String::new(),
    };
    println!(
        "{}: {}x{}, {} spp{cut}{learned}, guiding {}, NEE {} in {:.2} s on {} ({:.1} Msamples/s{gpu}{rel}) -> {}",
        args.scene.display(),
        opts.width,
        opts.height,
        spp,
        opts.guiding.name(),
        if opts.nee { "on" } else { "off" },
        elapsed,
        device_name,
        samples / elapsed / 1e6,
        args.output.display()
    );
    match stop {
        Stop::Finished => Ok(Outcome::Complete),
        Stop::Interrupted => Ok(Outcome::Interrupted),
        Stop::DeviceLost(detail) => bail!(device_lost_message(&detail, traced, &args.output, Some(spp))),
    }
}

fn file_name(p: &Path) -> String {
    p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| p.display().to_string())
}

/// The image at `path`, which must be an EXR: `what` names it where reading
/// fails, `label` where it is another format, and `why` says why it must be one.
fn load_exr(path: &Path, what: &str, label: &str, why: &str) -> Result<Image> {
    let (image, format) = Image::load_format(path).with_context(|| format!("reading {what} {}", path.display()))?;
    if format != rlpt::image::Format::Exr {
        bail!("{label} {} is {}: {why}", path.display(), format.describe());
    }
    Ok(image)
}

/// The reference with its variance read from `path` (`render --variance`), checked.
fn with_reference_variance(reference: metrics::Reference, path: &Path) -> Result<metrics::Reference> {
    let v = load_exr(
        path,
        "the reference's variance",
        "--reference-variance",
        "a variance is a linear EXR (`rlpt render --variance VAR.exr`)",
    )?;
    reference.with_variance(v).map_err(|m| anyhow::anyhow!("--reference-variance {}: {m}", path.display()))
}

fn compare(image: &Path, reference: &Path, reference_variance: Option<&Path>) -> Result<()> {
    let (a, fa) = Image::load_format(image).with_context(|| format!("reading {}", image.display()))?;
    let (b, fb) = Image::load_format(reference).with_context(|| format!("reading {}", reference.display()))?;
    if fa != fb {
        bail!(
            "{} is {} and {} is {}: compare two EXRs (linear; what rendering papers measure) or two PNGs",
            image.display(),
            fa.describe(),
            reference.display(),
            fb.describe()
        );
    }
    if let (Some(v), rlpt::image::Format::Png) = (reference_variance, fa) {
        bail!(
            "--reference-variance {} is the variance of linear values: compare two EXRs with it, not PNGs",
            v.display()
        );
    }
    let against = |m: String| anyhow::anyhow!("{} against {}: {m}", image.display(), reference.display());
    let e = match reference_variance {
        Some(v) => {
            let r = metrics::Reference::new(b).map_err(against)?;
            with_reference_variance(r, v)?.compare(&a).map_err(against)?
        }
        None => metrics::compare(&a, &b).map_err(against)?,
    };
    let debiased = e.rel_mse_debiased.map(|d| format!("  relMSE less the reference's variance {d:.6e}"));
    println!("relMSE {:.6e}  RMSE {:.6e}  MAPE {:.6e}{}", e.rel_mse, e.rmse, e.mape, debiased.unwrap_or_default());
    Ok(())
}

/// `compare --image-variance`: whether two independent renders' means agree
/// (`metrics::agreement`), printed; with `max_z`, an error where one differs by more.
fn agree(
    image: &Path,
    image_var: &Path,
    reference: &Path,
    reference_var: &Path,
    max_z: Option<f64>,
    floor: f64,
) -> Result<()> {
    if !(0.0..1.0).contains(&floor) {
        bail!("--floor {floor}: a relative difference in [0, 1)");
    }
    let hint = "a variance is a linear EXR (`rlpt render --variance VAR.exr`)";
    let a = load_exr(image, "the image", "IMAGE", "agreement compares linear EXRs")?;
    let b = load_exr(reference, "the reference", "REFERENCE", "agreement compares linear EXRs")?;
    let va = load_exr(image_var, "the image's variance", "--image-variance", hint)?;
    let vb = load_exr(reference_var, "the reference's variance", "--reference-variance", hint)?;
    let ag = metrics::agreement(&a, &va, &b, &vb, floor)
        .map_err(|m| anyhow::anyhow!("{} against {}: {m}", image.display(), reference.display()))?;
    let pct = |d: &metrics::MeanDiff| format!("{:+.4}%", 100.0 * d.relative());
    println!(
        "mean difference (R G B): {} {} {}  z {:+.2} {:+.2} {:+.2}",
        pct(&ag.global[0]),
        pct(&ag.global[1]),
        pct(&ag.global[2]),
        ag.global[0].z,
        ag.global[1].z,
        ag.global[2].z
    );
    let worst_region = ag.regions.iter().max_by(|a, b| a.z.abs().total_cmp(&b.z.abs()));
    if let Some(r) = worst_region {
        println!(
            "16 regions: worst z {:+.2} ({}) in columns {}..{}, rows {}..{}, channel {}",
            r.z,
            pct(r),
            r.x0,
            r.x1,
            r.y0,
            r.y1,
            ["R", "G", "B"][r.channel]
        );
    }
    println!(
        "per pixel: mean z^2 {:.3}, Kolmogorov-Smirnov distance from the normal {:.4} over {} values",
        ag.pixel_mean_z2, ag.pixel_ks, ag.pixels
    );
    let worst = ag.worst();
    println!("worst |z| {:.2}", worst.z.abs());
    if let Some(limit) = max_z {
        if worst.z.abs() > limit || worst.z.is_nan() {
            bail!(
                "{} and {} disagree: a mean differs by {:.2} standard deviations ({}), more than --max-z {limit}",
                image.display(),
                reference.display(),
                worst.z.abs(),
                pct(worst)
            );
        }
    }
    Ok(())
}

fn plot(stats: &[PathBuf], output: &Path, debiased: bool) -> Result<()> {
    let metric = if debiased { rlpt::plot::Metric::RelMseDebiased } else { rlpt::plot::Metric::RelMse };
    // One curve per file, however its path is written: `a.json` and `./a.json`,
    // or a link and its target, are the same file.
    let key =
        |p: &Path| std::fs::canonicalize(p).or_else(|_| std::path::absolute(p)).unwrap_or_else(|_| p.to_path_buf());
    for (i, p) in stats.iter().enumerate() {
        if let Some(q) = stats[..i].iter().find(|q| key(q) == key(p)) {
            if q == p {
                bail!("{} is given twice: each statistics file is one curve", p.display());
            }
            bail!("{} and {} are the same file: each statistics file is one curve", q.display(), p.display());
        }
    }
    let runs = stats.iter().map(|p| RenderStats::load(p)).collect::<Result<Vec<_>>>()?;
    rlpt::plot::plot_convergence(&runs, output, metric)?;
    for n in rlpt::plot::plot_notes(&runs, metric) {
        eprintln!("note: {n}");
    }
    println!("wrote {}", output.display());
    Ok(())
}

fn bench(args: BenchArgs) -> Result<()> {
    if let Some(p) = &args.json {
        check_output("--json", p, None)?;
    }
    if let Some(p) = &args.trace {
        if args.settings.device == DeviceKind::Cpu {
            bail!("--trace needs GPU timestamps: it is not available with --device cpu");
        }
        check_output("--trace", p, None)?;
    }
    if let (Some(json), Some(trace)) = (&args.json, &args.trace) {
        check_distinct(&[("--json", json), ("--trace", trace)])?;
    }
    if !args.ablate.is_empty() && (args.settings.guiding == GuidingMode::Off || args.settings.device == DeviceKind::Cpu)
    {
        bail!("--ablate leaves parts of GPU guiding out: it needs --guiding octant or sphere and --device gpu");
    }
    if args.frames == 0 {
        bail!("--frames 0: bench needs at least one measured frame");
    }
    if args.counters != Counters::All && args.settings.device == DeviceKind::Cpu {
        eprintln!(
            "note: --counters off and paths compile the GPU kernel's counters out; the CPU renderer counts always"
        );
    }
    if args.settings.learning_frames.is_some() && args.settings.guiding != GuidingMode::Off {
        eprintln!(
            "note: --learning-frames sets the frames an image leaves out; rlpt bench writes no image, and its \
             frames take the same time either way"
        );
    }
    let scene = Scene::load(&args.scene)?;
    warn_before_render(&args.settings, &scene);
    let mut opts = args.settings.options(&scene);
    opts.counters = args.counters;
    let prepared = PreparedScene::new(&scene, &opts)?;
    warn_grid(&scene, &prepared);
    warn_memory(&opts, args.settings.device);
    let samples_per_frame = opts.width as u64 * opts.height as u64 * shared::SAMPLES_PER_FRAME as u64;
    let mut times = Vec::with_capacity(args.frames as usize);
    let (device, driver, clock, pipelines) = match args.settings.device {
        DeviceKind::Gpu => {
            let ctx = Context::new(&ContextOptions::from_env(args.settings.gpu))?;
            let mut r = GpuRenderer::new(&ctx, &prepared)?;
            let ablate = args.ablate.iter().fold(0, |bits, a| {
                bits | match a {
                    AblateArg::Record => shared::ABLATE_RECORD,
                    AblateArg::GuidedSampling => shared::ABLATE_GUIDED_SAMPLING,
                }
            });
            for f in 0..args.warmup + args.frames {
                r.ablate = if f >= args.warmup { ablate } else { 0 };
                let t = r.render_frame_profiled()?;
                if f >= args.warmup {
                    times.push(t);
                }
            }
            let pipelines = r
                .pipeline_statistics()?
                .into_iter()
                .map(|(pipeline, statistics)| rlpt::bench::PipelineReport { pipeline, statistics })
                .collect();
            (ctx.info.name.clone(), ctx.info.driver.clone(), "GPU timestamps", pipelines)
        }
        DeviceKind::Cpu => {
            let mut r = CpuRenderer::new(&prepared);
            for f in 0..args.warmup + args.frames {
                let start = Instant::now();
                r.render_frame();
                let ms = start.elapsed().as_secs_f64() * 1e3;
                if f >= args.warmup {
                    let c = r.last_counters;
                    times.push(rlpt::render::PassTimes {
                        start_ms: 0.0,
                        pathtrace_ms: ms,
                        zero_paths: Some(c.zero_paths),
                        segments: Some(c.segments),
                        ..Default::default()
                    });
                }
            }
            (
                format!("CPU ({} threads)", rayon::current_num_threads()),
                "rlpt CPU renderer".into(),
                "wall clock",
                Vec::new(),
            )
        }
    };
    let setup = rlpt::bench::BenchSetup {
        scene: args.scene.display().to_string(),
        device: device.clone(),
        driver,
        clock: clock.to_string(),
        width: opts.width,
        height: opts.height,
        samples_per_frame,
        guiding: opts.guiding.name().to_string(),
        guided_fraction: opts.guided_fraction_name(),
        learning_rate_exponent: opts.learning_rate_exponent_if_guided(),
        exploration_floor: opts.exploration_floor_if_guided(),
        q_targets: opts.q_targets_if_guided().map(String::from),
        nee: opts.nee,
        warmup_frames: args.warmup,
    };
    let report = rlpt::bench::BenchReport::new(setup, &times, pipelines);
    print!("{}", report.table());
    if let Some(p) = &args.json {
        std::fs::write(p, serde_json::to_string_pretty(&report)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    if let Some(p) = &args.trace {
        let trace = rlpt::bench::chrome_trace(&device, &times, args.warmup + 1);
        std::fs::write(p, serde_json::to_string(&trace)?).with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}

fn view(args: ViewArgs) -> Result<()> {
    if args.settings.device == DeviceKind::Cpu {
        bail!("`rlpt view` renders on the GPU: --device cpu is for `rlpt render` and `rlpt bench`");
    }
    let scene = Scene::load(&args.scene)?;
    warn_before_render(&args.settings, &scene);
    let render = args.settings.options(&scene);
    // The viewer switches guiding on and off as it runs: the box is checked as
    // for a guided render, whatever mode it starts in.
    let guided = RenderOptions { guiding: GuidingMode::Sphere, ..render.clone() };
    warn_grid(&scene, &PreparedScene::new(&scene, &guided)?);
    rlpt::viewer::run(rlpt::viewer::ViewOptions {
        scene_path: args.scene,
        scene,
        render,
        context: ContextOptions::from_env(args.settings.gpu),
        frames: args.frames,
        screenshot: args.screenshot,
        resize: args.resize,
    })
}

fn devices() -> Result<()> {
    let devices = rlpt::gpu::list_devices()?;
    for d in devices {
        println!("[{}] {} ({}), Vulkan {}", d.index, d.name, d.device_type, d.api_version);
        println!("    driver: {}", d.driver);
        println!("    subgroup size {}: {}", d.subgroup_size, d.subgroup_operations.join(", "));
        println!(
            "    device memory: {} MB{}",
            d.device_memory >> 20,
            if d.unified_memory { " (shared with the host)" } else { "" }
        );
        println!(
            "    float atomic add: {}; subgroup partition (NV): {}; timestamps: {}; pipeline statistics: {}",
            yes_no(d.float_atomic_add),
            yes_no(d.subgroup_partitioned),
            yes_no(d.timestamps),
            yes_no(d.pipeline_statistics)
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
