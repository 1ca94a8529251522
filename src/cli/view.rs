//! `rlpt view`: the window on the GPU renderer, on one GPU or several (`--gpus`).

use crate::*;

#[derive(clap::Args)]
pub(crate) struct ViewArgs {
    /// Scene file (TOML, see SCENE_FORMAT.md, or pbrt, see docs/pbrt.md).
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
    /// Start guiding from the learned field FILE that `rlpt render --guide-out` wrote
    /// for this scene: each guided mode of its bins starts from it.
    #[arg(long, value_name = "FILE")]
    guide_in: Option<PathBuf>,
}

pub(crate) fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("`{s}`: expected WIDTHxHEIGHT, e.g. 800x600"))?;
    let parse = |v: &str| match v.trim().parse::<u32>() {
        Ok(n) if (1..=16384).contains(&n) => Ok(n),
        _ => Err(format!("`{s}`: `{v}` is not a size from 1 to 16384")),
    };
    Ok((parse(w)?, parse(h)?))
}

pub(crate) fn view(args: ViewArgs) -> Result<()> {
    if args.settings.device == DeviceKind::Cpu {
        bail!("`rlpt view` renders on the GPU: --device cpu is for `rlpt render` and `rlpt bench`");
    }
    // The first GPU of --gpus presents, and all render; without it, --gpu's one does both.
    let contexts: Vec<ContextOptions> = match gpu_indices(&args.settings)? {
        None => vec![ContextOptions::from_env(args.settings.gpu)],
        Some(indices) => indices.into_iter().map(|i| ContextOptions::from_env(Some(i))).collect(),
    };
    let scene = Scene::load_with(&args.scene, args.settings.strict)?;
    warn_before_render(&args.settings, &scene);
    let render = args.settings.options(&scene);
    // The viewer switches guiding on and off as it runs: the box is checked as
    // for a guided render, whatever mode it starts in.
    let guided = RenderOptions { guiding: GuidingMode::Sphere, ..render.clone() };
    let prepared = PreparedScene::new(&scene, &guided)?;
    if contexts.len() > 1 {
        refuse_race_on_several(&prepared)?;
    }
    warn_grid(&scene, &prepared);
    // A field of another scene is refused before the window opens; its bins are
    // matched mode by mode as the viewer switches.
    let guide_in = match args.guide_in {
        Some(path) => {
            let field = GuideField::load(&path)?;
            field.check(&path, scene_hash(&prepared), field.bins)?;
            Some((path, field))
        }
        None => None,
    };
    rlpt::viewer::run(rlpt::viewer::ViewOptions {
        scene_path: args.scene,
        scene,
        render,
        contexts,
        frames: args.frames,
        screenshot: args.screenshot,
        resize: args.resize,
        guide_in,
    })
}
