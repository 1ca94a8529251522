//! `rlpt render`: a scene to an image, by one render session.

use crate::*;

#[derive(clap::Args)]
pub(crate) struct RenderArgs {
    /// Scene file (TOML, see SCENE_FORMAT.md, or pbrt, see docs/pbrt.md).
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
    /// Start guiding from the learned field FILE that a render of the same scene wrote with
    /// --guide-out (the same bins; its grid is used whatever the camera): a preview's
    /// learning serves the final render. Learning frames are then 0 unless asked for.
    #[arg(long, value_name = "FILE")]
    guide_in: Option<PathBuf>,
    /// Write the learned field to FILE once the render ends (after the image), for --guide-in.
    #[arg(long, value_name = "FILE")]
    guide_out: Option<PathBuf>,
    /// Stop at this much render time (GPU time from timestamps on the GPU, wall clock on
    /// the CPU). On the CPU the last frame is cut short at it, in passes of one sample per
    /// pixel, and its samples counted exactly. On one GPU no whole frame starts that would
    /// end past it, each judged to last as long as the frame before (the first always
    /// runs; a slower frame ends past it by the difference), and the last is cut short to
    /// the samples per pixel that fit, in whole subgroups. --spp is then the upper bound.
    #[arg(long, value_parser = parse_seconds)]
    time: Option<f64>,
    /// Render part K (from 0) of N of the render that --spp asks for: its K-th of N
    /// disjoint ranges of frames, into an EXR whose header `rlpt merge` reads (docs/cluster.md).
    #[arg(long, value_name = "K/N", value_parser = rlpt::parts::Part::parse)]
    part: Option<Part>,
}

/// The sentence of a render whose device was lost after `frames` frames (the
/// learning frames counted): whether the image so far went to `output` (`written`:
/// its spp), or why it could not.
pub(crate) fn device_lost_message(detail: &str, frames: u32, output: &Path, written: Option<u32>) -> String {
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

pub(crate) fn render(args: RenderArgs) -> Result<Outcome> {
    // Ctrl-C from here on stops the render after the frame in flight and writes what it
    // has; during the set-up (scene, device, kernels) it stops after the first frame.
    catch_interrupt();
    check_gpu_flags(&args.settings)?;
    check_output("output", &args.output, Some(&["png", "exr"]))?;
    if let Some(part) = args.part {
        if !args.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
            bail!(
                "--part {part} writes an EXR whose header `rlpt merge` reads, and {} is not .exr: name the output .exr",
                args.output.display()
            );
        }
    }
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
    let scene = Scene::load_with(&args.scene, args.settings.strict)?;
    warn_before_render(&args.settings, &scene);
    let mut opts = args.settings.options(&scene);
    if let Some(s) = args.spp {
        opts.spp = s;
    }
    // `--gpus`' devices, resolved once: the default of --unguided-frames and the render read them.
    let gpus = match args.settings.device {
        DeviceKind::Gpu => gpu_indices(&args.settings)?,
        DeviceKind::Cpu => None,
    };
    if args.settings.unguided_frames.is_none() {
        let several = gpus.as_ref().is_some_and(|g| g.len() > 1);
        let roulette = opts.russian_roulette_depth.is_some();
        opts.unguided_frames = rlpt::guide::default_unguided_frames(args.time.is_some(), roulette, several);
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
    // The image's frames: all of them, or the part's range of them.
    let total_frames = opts.frames();
    let range = args.part.map_or(0..total_frames, |p| p.frames(total_frames));
    if let (Some(part), true) = (args.part, range.is_empty()) {
        bail!(
            "--part {part}: a render of {total_frames} frame(s) ({} samples per pixel) cannot be split into {} \
             parts, each of at least one frame of {}: ask for at least {} samples per pixel",
            total_frames * shared::SAMPLES_PER_FRAME,
            part.count,
            shared::SAMPLES_PER_FRAME,
            part.count * shared::SAMPLES_PER_FRAME
        );
    }
    let frames = range.len() as u32;
    if args.variance.is_some() && frames < 2 {
        bail!(
            "--variance needs at least 2 frames ({} samples per pixel): a pixel's variance is measured \
             from the spread of its frames",
            2 * shared::SAMPLES_PER_FRAME
        );
    }
    let rounded = total_frames * shared::SAMPLES_PER_FRAME;
    if rounded != opts.spp && args.time.is_none() {
        eprintln!(
            "note: {} samples per pixel rounded up to {rounded}: rlpt renders frames of {} samples per pixel",
            opts.spp,
            shared::SAMPLES_PER_FRAME
        );
    }
    let mut prepared = PreparedScene::new(&scene, &opts)?;
    let mut guide_in = None;
    if let Some(path) = &args.guide_in {
        prepared.start_from(GuideField::load(path)?, path, &opts)?;
        use rlpt::scene::GridKind;
        let grid = prepared.guide.map(|g| if g.grid.adaptive() { GridKind::Adaptive } else { GridKind::Uniform });
        if let (Some(asked), Some(has)) = (opts.guide_grid, grid) {
            if asked != has {
                eprintln!(
                    "note: {} was learned on a {} grid, which it keeps: --guide-grid {} ignored",
                    path.display(),
                    has.name(),
                    asked.name()
                );
            }
        }
        let file = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
        guide_in = Some(rlpt::parts::field_hash(&file));
    }
    if prepared.guide.is_none() {
        if let Some(path) = &args.guide_out {
            bail!("--guide-out {} needs guiding on (--guiding sphere or octant)", path.display());
        }
    }
    warn_grid(&scene, &prepared);
    warn_memory(&opts, args.settings.device);
    // The learning frames come first, and the image's frames after them.
    let learning_frames = prepared.learning_frames();
    let traced_frames = frames + learning_frames;

    let start = Instant::now();
    // A part's image frames draw the random numbers of its range's frames, and
    // leave out the learning frames, which every part repeats.
    let learned = rlpt::film::Learned::for_render(args.part.is_some());
    let renderer: Box<dyn Renderer> = match args.settings.device {
        DeviceKind::Cpu => {
            let mut r = CpuRenderer::new(&prepared);
            r.set_frame_offset(range.start);
            r.set_learned(learned);
            Box::new(r)
        }
        DeviceKind::Gpu => gpu_renderer(&open_gpus_at(&args.settings, gpus)?, &prepared, range.start, learned)?,
    };
    let device_name = renderer.device_name();
    let mut stats = RenderStats {
        label: format!(
            "{} guiding={}{}{}{}{}{}{} nee={}{}",
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
            opts.glossy_product_if_guided()
                .filter(|&g| g != rlpt::guide::DEFAULT_GLOSSY_PRODUCT)
                .map_or(String::new(), |g| format!(" glossy-product={}", if g { "on" } else { "off" })),
            if opts.guiding != GuidingMode::Off && opts.adaptive_directions { " adaptive-directions=on" } else { "" },
            opts.nee,
            if opts.sampler == SamplerKind::Sobol { " sampler=sobol" } else { "" }
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
    let spp = session.renderer.image_spp();
    stats.frames = std::mem::take(&mut session.frames);
    // A saved field holds every frame's targets, those after the last pass too.
    if args.guide_out.is_some() && !matches!(stop, Stop::DeviceLost(_)) {
        session.renderer.learn_pending()?;
    }
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
    match args.part {
        Some(part) => {
            let info = PartInfo {
                part,
                scene_hash: scene_hash(&prepared),
                settings_hash: rlpt::parts::settings_hash(&prepared.params),
                seed: opts.seed,
                total_frames,
                first_frame: range.start,
                // Cut short within the learning frames, the film holds no image frame.
                frames: if traced > learning_frames { film.frames } else { 0 },
                spp: if traced > learning_frames { film.samples_per_pixel() } else { 0 },
                guiding: opts.guiding.name().into(),
                guide_in,
            };
            let variance = film.variance_of_mean();
            if variance.is_none() {
                eprintln!(
                    "note: {} holds {} frame(s), and no variance: a pixel's variance is measured from the spread \
                     of at least 2",
                    args.output.display(),
                    info.frames
                );
            }
            PartImage { info, mean: image.clone(), variance }.save(&args.output)?;
        }
        None => image.save(&args.output).with_context(|| format!("writing {}", args.output.display()))?,
    }
    // A variance that cannot be measured fails the render, but only once the
    // statistics, the field and the summary are written too.
    let mut variance_error = None;
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
        });
        match v {
            Ok(v) => v.save(path).with_context(|| format!("writing {}", path.display()))?,
            Err(e) => variance_error = Some(e),
        }
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
    // The learned table, where it is saved or its adaptive grid's cells are told.
    let adaptive = prepared.guide.is_some_and(|g| g.grid.adaptive());
    let table = match &prepared.guide {
        Some(_) if args.guide_out.is_some() => renderer.table()?,
        // For the summary alone: a failed read leaves the count out.
        Some(_) if adaptive => renderer.table().ok().flatten(),
        _ => None,
    };
    if let (Some(path), Some(cfg), Some(table)) = (&args.guide_out, &prepared.guide, &table) {
        GuideField::of_table(table, cfg, scene_hash(&prepared)).save(path)?;
    }
    let grid = match (&prepared.guide, &table) {
        (Some(cfg), Some(t)) if adaptive => {
            format!(" (adaptive grid: {} of {} cells in use)", t.used_cells, cfg.cells())
        }
        _ => String::new(),
    };
    // Samples traced, the learning frames' included, less what a last frame cut short lacks.
    let samples = opts.width as f64 * opts.height as f64 * rlpt::film::samples_in(traced, film.partial_spp) as f64;
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
    let part = args.part.map_or(String::new(), |p| {
        format!(" (part {p}: frames {}..{} of {total_frames})", range.start, range.start + film.frames)
    });
    let cut = match stop {
        Stop::Interrupted => format!(" (interrupted: {asked} asked)"),
        Stop::DeviceLost(_) => format!(" (the GPU stopped responding: {asked} asked)"),
        Stop::Finished => String::new(),
    };
    println!(
        "{}: {}x{}, {} spp{part}{cut}{learned}, guiding {}{grid}, NEE {}, {} sampler in {:.2} s on {} ({:.1} Msamples/s{gpu}{rel}) -> {}",
        args.scene.display(),
        opts.width,
        opts.height,
        spp,
        opts.guiding.name(),
        if opts.nee { "on" } else { "off" },
        opts.sampler.name(),
        elapsed,
        device_name,
        samples / elapsed / 1e6,
        args.output.display()
    );
    if let Some(e) = variance_error {
        return Err(e);
    }
    match stop {
        Stop::Finished => Ok(Outcome::Complete),
        Stop::Interrupted => Ok(Outcome::Interrupted),
        Stop::DeviceLost(detail) => bail!(device_lost_message(&detail, traced, &args.output, Some(spp))),
    }
}
