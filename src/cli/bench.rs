//! `rlpt bench`: GPU timestamps of every pass of every frame.

use crate::*;
use rlpt::bench::{Profiled, ProfiledDevice};

#[derive(clap::Args)]
pub(crate) struct BenchArgs {
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
    /// Time the traversal alone instead of frames: a camera ray per pixel, a diffuse
    /// bounce ray from each hit, and an any-hit ray along it, each kind N times
    /// (the median's rays per second; GPU only).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=10_000))]
    rays: Option<u32>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum AblateArg {
    /// Recording Q-learning targets (the subgroup-aggregated atomics).
    Record,
    /// Guided sampling and the guided pdf (paths sample the BSDF only).
    GuidedSampling,
}

pub(crate) fn bench(args: BenchArgs) -> Result<()> {
    check_gpu_flags(&args.settings)?;
    if args.settings.gpus.is_some() && args.settings.device == DeviceKind::Gpu {
        // Each of these has one device's timeline or counters in mind.
        for (given, flag) in
            [(args.trace.is_some(), "--trace"), (!args.ablate.is_empty(), "--ablate"), (args.rays.is_some(), "--rays")]
        {
            if given {
                bail!("{flag} measures one GPU: bench it with --gpu N, not --gpus");
            }
        }
    }
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
            "note: --learning-frames sets how many of the first frames teach the table before the image; rlpt \
             bench writes no image, and times those frames as a render traces them"
        );
    }
    let scene = Scene::load_with(&args.scene, args.settings.strict)?;
    warn_before_render(&args.settings, &scene);
    let mut opts = args.settings.options(&scene);
    opts.counters = args.counters;
    let prepared = PreparedScene::new(&scene, &opts)?;
    warn_grid(&scene, &prepared);
    warn_memory(&opts, args.settings.device);
    if let Some(repeats) = args.rays {
        if args.settings.device == DeviceKind::Cpu {
            bail!("--rays times GPU dispatches: it needs --device gpu");
        }
        let ctx = Context::new(&ContextOptions::from_env(args.settings.gpu))?;
        let r = rlpt::render::raycast::measure_ray_rates(&ctx, &prepared, repeats)?;
        println!(
            "{} on {} ({}x{}), median of {repeats}:",
            args.scene.display(),
            ctx.info.name,
            opts.width,
            opts.height
        );
        println!("  camera rays {:>10}: {:8.3} ms, {:8.1} Mrays/s", r.camera_rays, r.camera_ms, r.camera_mrays_per_s);
        println!(
            "  bounce rays {:>10}: {:8.3} ms, {:8.1} Mrays/s ({:.0} % hit)",
            r.bounce_rays,
            r.bounce_ms,
            r.bounce_mrays_per_s,
            100.0 * r.bounce_hit_share
        );
        println!(
            "  any-hit rays {:>9}: {:8.3} ms, {:8.1} Mrays/s ({:.0} % blocked)",
            r.bounce_rays,
            r.shadow_ms,
            r.shadow_mrays_per_s,
            100.0 * r.shadow_blocked_share
        );
        if let Some(p) = &args.json {
            std::fs::write(p, serde_json::to_string_pretty(&r)?).with_context(|| format!("writing {}", p.display()))?;
        }
        return Ok(());
    }
    let samples_per_frame = opts.width as u64 * opts.height as u64 * shared::SAMPLES_PER_FRAME as u64;
    let paths_per_frame = samples_per_frame as f64;
    let (ctx, mut profiled, ablate) = match args.settings.device {
        DeviceKind::Gpu => {
            let mut contexts = open_gpus(&args.settings)?;
            if contexts.len() > 1 {
                return bench_gpus(&args, &contexts, &prepared, samples_per_frame);
            }
            let ctx = contexts.remove(0);
            let r = GpuRenderer::new(&ctx, &prepared)?;
            let ablate = args.ablate.iter().fold(0, |bits, a| {
                bits | match a {
                    AblateArg::Record => shared::ABLATE_RECORD,
                    AblateArg::GuidedSampling => shared::ABLATE_GUIDED_SAMPLING,
                }
            });
            (Some(ctx), Profiled::new(ProfiledDevice::Gpu(Box::new(r))), ablate)
        }
        DeviceKind::Cpu => (None, Profiled::new(ProfiledDevice::Cpu(Box::new(CpuRenderer::new(&prepared)))), 0),
    };
    // The warm-up learns as usual; the measured frames leave out what --ablate names.
    run_frames(&mut profiled, args.warmup, paths_per_frame)?;
    if let ProfiledDevice::Gpu(r) = &mut profiled.device {
        r.ablate = ablate;
    }
    profiled.times.clear();
    run_frames(&mut profiled, args.frames, paths_per_frame)?;
    let times = std::mem::take(&mut profiled.times);
    let (device, driver, clock, pipelines) = match (&ctx, &profiled.device) {
        (Some(ctx), ProfiledDevice::Gpu(r)) => {
            let pipelines = r
                .pipeline_statistics()?
                .into_iter()
                .map(|(pipeline, statistics)| rlpt::bench::PipelineReport { pipeline, statistics })
                .collect();
            (ctx.info.name.clone(), ctx.info.driver.clone(), "GPU timestamps", pipelines)
        }
        _ => (profiled.device_name(), "rlpt CPU renderer".into(), "wall clock", Vec::new()),
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
        sampler: opts.sampler.name().to_string(),
        glossy_product: opts.glossy_product_if_guided(),
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

/// `rlpt bench --gpus`: the frames of several GPUs in one render, in the rounds
/// of `MultiGpuRenderer`; per device its frames and GPU time, and for all of them
/// the frames over the rounds' time (`rlpt::bench::MultiBenchReport`).
fn bench_gpus(
    args: &BenchArgs,
    contexts: &[std::sync::Arc<Context>],
    prepared: &PreparedScene,
    samples_per_frame: u64,
) -> Result<()> {
    super::gpus::refuse_race_on_several(prepared)?;
    let mut r = rlpt::render::MultiGpuRenderer::new(contexts, prepared)?;
    let paths_per_frame = samples_per_frame as f64;
    run_frames(&mut r, args.warmup, paths_per_frame)?;
    let before = r.device_stats();
    let start = Instant::now();
    let gpu_ms = run_frames(&mut r, args.frames, paths_per_frame)?;
    let wall_s = start.elapsed().as_secs_f64();
    let devices: Vec<rlpt::bench::DeviceBench> = r
        .device_stats()
        .into_iter()
        .map(|d| {
            let (f0, ms0) = before.iter().find(|b| b.slot == d.slot).map_or((0, 0.0), |b| (b.frames, b.gpu_ms));
            let (frames, ms) = (d.frames - f0, d.gpu_ms - ms0);
            rlpt::bench::DeviceBench {
                index: d.index,
                name: d.name,
                frames,
                gpu_ms: ms,
                frames_per_second: frames as f64 / (ms / 1e3),
                lost: d.lost,
            }
        })
        .collect();
    let s = &args.settings;
    let opts = &prepared.params;
    let setup = rlpt::bench::BenchSetup {
        scene: args.scene.display().to_string(),
        device: r.device_name(),
        driver: contexts[0].info.driver.clone(),
        clock: "GPU timestamps, the busiest device's per round".into(),
        width: opts.width,
        height: opts.height,
        samples_per_frame,
        guiding: s.guiding.name().to_string(),
        guided_fraction: None,
        learning_rate_exponent: None,
        exploration_floor: None,
        q_targets: None,
        nee: s.nee == OnOff::On,
        sampler: s.sampler.name().to_string(),
        glossy_product: None,
        warmup_frames: args.warmup,
    };
    let report = rlpt::bench::MultiBenchReport {
        setup,
        gpus: contexts.len(),
        devices,
        frames: args.frames,
        gpu_ms,
        frames_per_second: args.frames as f64 / (gpu_ms / 1e3),
        msamples_per_s: args.frames as f64 * samples_per_frame as f64 / (gpu_ms / 1e3) / 1e6,
        wall_s,
        wall_frames_per_second: args.frames as f64 / wall_s,
    };
    print!("{}", report.table());
    if let Some(p) = &args.json {
        std::fs::write(p, serde_json::to_string_pretty(&report)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}

/// Renders `frames` more frames of `renderer` in a session of its own (no time
/// budget; a lost device is an error): its time, GPU time where the renderer has
/// timestamps (with several GPUs, the busiest device's per round), else wall clock.
fn run_frames(renderer: &mut dyn Renderer, frames: u32, paths_per_frame: f64) -> Result<f64> {
    let mut session = Session::new(Box::new(renderer), None, paths_per_frame);
    let (stop, _) = session.run(Budget { frames, time_ms: None }, &AtomicBool::new(false))?;
    if let Stop::DeviceLost(detail) = stop {
        return Err(rlpt::gpu::GpuError::DeviceLost(detail).into());
    }
    Ok(session.elapsed_ms)
}
