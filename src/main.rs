//! The `rlpt` command line.

use anyhow::{bail, Context as _, Result};
use clap::{Parser, Subcommand, ValueEnum};
use rlpt::cpu::CpuRenderer;
use rlpt::gpu::{Context, ContextOptions};
use rlpt::guide::{scene_hash, Bins, GuideField, GuidingMode};
use rlpt::image::Image;
use rlpt::math::sampler::SamplerKind;
use rlpt::metrics;
use rlpt::options::{Counters, RenderOptions};
use rlpt::parts::{Part, PartImage, PartInfo};
use rlpt::prepared::PreparedScene;
use rlpt::render::GpuRenderer;
use rlpt::scene::Scene;
use rlpt::session::{Budget, Renderer, Session, Stop};
use rlpt::shared;
use rlpt::stats::RenderStats;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

mod cli;
use cli::bench::*;
use cli::gpus::*;
use cli::info::*;
use cli::merge::*;
use cli::render::*;
use cli::tools::*;
use cli::view::*;

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
    /// Merge the parts of a split render (`render --part K/N`) into one image, weighting
    /// each by its samples, after checking that they belong together (docs/cluster.md).
    Merge(MergeArgs),
    /// Open a window that shows the render converge; move around, switch guiding and NEE.
    View(ViewArgs),
    /// List the Vulkan devices, their drivers and subgroup sizes, and what rlpt needs that they lack.
    Devices,
    /// Print what a scene holds: meshes and their triangles, materials, lights, bounds,
    /// the BVH's nodes and depth, and the device memory it takes.
    Info {
        /// Scene file (TOML, see SCENE_FORMAT.md, or pbrt, see docs/pbrt.md).
        scene: PathBuf,
        /// Refuse a pbrt scene's unsupported material or approximated feature
        /// instead of noting it.
        #[arg(long)]
        strict: bool,
    },
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
    /// Refuse a pbrt scene's unsupported material or approximated feature (naming
    /// it, its file and line) instead of noting it and rendering the approximation.
    #[arg(long)]
    strict: bool,
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
    /// Vulkan device index from `rlpt devices` (default: the first discrete GPU): one
    /// GPU. For several, --gpus; not both.
    #[arg(long)]
    gpu: Option<usize>,
    /// Several GPUs in one render, bench or view: `all` (every usable device) or indices
    /// from `rlpt devices`, e.g. 0,2. Each renders frames as it finishes the last, into one
    /// image; with guiding, all learn one table (docs/cluster.md). --gpus N is --gpu N.
    /// In `rlpt view` the first listed presents.
    #[arg(long, value_name = "all|I,J,...", value_parser = parse_gpus)]
    gpus: Option<GpuList>,
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
    /// Frames at the start of a guided render that teach the table; their mean then
    /// counts as one frame of the image (a part of a split render, or a
    /// render on several GPUs, leaves them out). `--spp` counts the image's other samples;
    /// `--time` counts the learning frames' time too [default: 4 in scenes with Russian
    /// roulette, the frames before learned roulette starts; 0 without].
    #[arg(long, value_name = "N", value_parser = parse_learning_frames, allow_negative_numbers = true)]
    learning_frames: Option<u32>,
    /// The fewest frames between learning passes after the first frames, a power of two:
    /// the pass takes as long at any image size, so small images learn less often
    /// [default: auto: 1 from 131072 pixels up, else the fewest frames that trace as many].
    #[arg(long, value_name = "N|auto", value_parser = parse_learning_period)]
    learning_period: Option<LearningPeriod>,
    /// Whether a guided render's image frames may be traced unguided: `auto` traces each
    /// frame with the guided or the unguided kernel, whichever has lately given the image
    /// more for its time (a few frames go to the other, to keep measuring it and teaching
    /// the table; with `--time` each kind's frames weigh the inverse of its variance;
    /// docs/guiding.md, where its measured effects are); `never` guides every
    /// frame [default: auto for `render --time` of a scene without Russian roulette on one
    /// GPU, else never].
    #[arg(long, value_enum)]
    unguided_frames: Option<rlpt::guide::UnguidedFrames>,
    /// The guiding grid's cells: `uniform`, or `adaptive`, half as many along each
    /// axis, each splitting into 8 (three times at most) where paths record many
    /// targets, within the uniform grid's memory (docs/guiding.md, "Adaptive cells")
    /// [default: the scene's `[guiding] grid`, else uniform].
    #[arg(long, value_enum)]
    guide_grid: Option<rlpt::scene::GridKind>,
    /// Adaptive directions: `on` weighs each bin's guided density by the Q of the
    /// smallest block of 1, 2x2 or 4x4 bins around it whose entries have taken 16
    /// targets a bin, so that the directions refine where paths record many
    /// targets and stay coarse where few go (docs/guiding.md, "Adaptive
    /// directions"); `off`, each bin by its own Q [default: off].
    #[arg(long, value_enum)]
    adaptive_directions: Option<OnOff>,
    /// What a Q-learning target counts of the light its ray meets, with NEE on: `mis`
    /// counts the emission met with the MIS weight the image gives it and adds the light
    /// sample at the vertex met, so that guided directions seek what light sampling
    /// misses; `full` is Dahm & Keller's target, the emission met in full. Without NEE
    /// the two are the same [default: mis].
    #[arg(long, value_enum)]
    q_targets: Option<rlpt::guide::QTargets>,
    /// The paths' random numbers: `independent` hashes (camera samples stratified over
    /// the pixel) or `sobol`, Owen-scrambled Sobol points decorrelated between pixels
    /// (docs/sampling.md).
    #[arg(long, value_enum, default_value_t = SamplerKind::Independent)]
    sampler: SamplerKind,
    /// Guided directions at glossy vertices (GGX lobes narrower than the cosine's):
    /// `on` draws them in proportion to Q times the lobe over the bins around its
    /// centre; `off` from the cell's cosine-weighted row, at a share of the guided
    /// fraction that shrinks with the lobe (docs/guiding.md, "Glossy lobes") [default: off].
    #[arg(long, value_enum)]
    glossy_product: Option<OnOff>,
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
        opts.learning_period = self.learning_period.and_then(|p| p.0);
        opts.unguided_frames = self.unguided_frames.unwrap_or_default();
        opts.guide_grid = self.guide_grid;
        opts.adaptive_directions = self.adaptive_directions == Some(OnOff::On);
        opts.q_targets = self.q_targets.unwrap_or(rlpt::guide::QTargets::Mis);
        opts.sampler = self.sampler;
        opts.glossy_product = self.glossy_product.map_or(rlpt::guide::DEFAULT_GLOSSY_PRODUCT, |g| g == OnOff::On);
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
                ("--learning-period", self.learning_period.is_some()),
                ("--unguided-frames", self.unguided_frames.is_some()),
                ("--guide-grid", self.guide_grid.is_some()),
                ("--adaptive-directions", self.adaptive_directions.is_some()),
                ("--q-targets", self.q_targets.is_some()),
                ("--glossy-product", self.glossy_product.is_some()),
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
        if self.gpus.is_some() && self.device == DeviceKind::Cpu {
            notes.push("--gpus picks Vulkan devices; ignored with --device cpu".into());
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

/// `--learning-period`: a number of frames, or None for `auto`.
#[derive(Clone, Copy, Debug)]
struct LearningPeriod(Option<u32>);

fn parse_learning_period(s: &str) -> Result<LearningPeriod, String> {
    if s == "auto" {
        return Ok(LearningPeriod(None));
    }
    let v: u32 = s.parse().map_err(|_| format!("`{s}` is neither `auto` nor a whole number of frames"))?;
    rlpt::guide::check_learning_period(v).map_err(|e| format!("`{s}`: expected {e}"))?;
    Ok(LearningPeriod(Some(v)))
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
        Command::Merge(args) => merge(args),
        Command::View(args) => view(args),
        Command::Bench(args) => bench(args),
        Command::Devices => devices(),
        Command::Info { scene, strict } => info(&scene, strict),
        Command::Compare { image, reference, reference_variance, image_variance, max_z, floor } => {
            let agreement = image_variance.as_deref().map(|v| (v, max_z, floor));
            compare(&image, &reference, reference_variance.as_deref(), agreement)
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

/// What render, bench and view say on stderr before they start: the options the
/// other settings leave without effect, and a scene where nothing gives light.
fn warn_before_render(settings: &Settings, scene: &Scene) {
    settings.note_ignored();
    // What the scene's import approximated or ignored (mesh files, pbrt files).
    for note in &scene.notes {
        eprintln!("note: {note}");
    }
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
