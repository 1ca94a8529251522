//! `rlpt merge`: the parts of a split render (`render --part K/N`) into one image.

use crate::*;
use rlpt::parts::{merge as merge_parts, write_exr};

#[derive(clap::Args)]
pub(crate) struct MergeArgs {
    /// The parts' EXR files, written by `rlpt render --part K/N`.
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// The merged image: .exr (linear float, with the variance and a header, as a
    /// part's) or .png (8-bit sRGB, for viewing).
    #[arg(short, long)]
    output: PathBuf,
    /// Also write the variance of each pixel's merged mean as a linear EXR (for
    /// `rlpt compare --image-variance` or `--reference-variance`).
    #[arg(long)]
    variance: Option<PathBuf>,
    /// Merge the parts given where some of the render's are missing (named on stderr),
    /// instead of refusing.
    #[arg(long)]
    allow_missing: bool,
}

pub(crate) fn merge(args: MergeArgs) -> Result<()> {
    check_output("output", &args.output, Some(&["png", "exr"]))?;
    if let Some(v) = &args.variance {
        check_output("--variance", v, Some(&["exr"]))?;
    }
    // No output may overwrite a part, nor another output (a part given twice is
    // merge's to name).
    let mut outputs = vec![("--output", args.output.as_path())];
    outputs.extend(args.variance.as_deref().map(|p| ("--variance", p)));
    check_distinct(&outputs)?;
    for part in &args.parts {
        for &output in &outputs {
            check_distinct(&[output, ("a part", part)])?;
        }
    }
    let mut parts = Vec::new();
    let mut problems = Vec::new();
    for path in &args.parts {
        match PartImage::load(path) {
            Ok(p) => parts.push((path.clone(), p)),
            Err(e) => problems.push(e),
        }
    }
    if problems.is_empty() {
        match merge_parts(&parts, args.allow_missing) {
            Ok(merged) => return write_merged(&args, &parts, merged),
            Err(p) => problems = p,
        }
    }
    bail!("cannot merge {} file(s), nothing written:\n  {}", args.parts.len(), problems.join("\n  "))
}

fn write_merged(args: &MergeArgs, parts: &[(PathBuf, PartImage)], merged: rlpt::parts::Merged) -> Result<()> {
    for n in &merged.notes {
        eprintln!("note: {n}");
    }
    if let (Some(path), None) = (&args.variance, &merged.variance) {
        bail!("--variance {}: the parts hold no variance to merge, nothing written", path.display());
    }
    let first = &parts[0].1.info;
    let is_exr = args.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if is_exr {
        let mut indices: Vec<u32> = parts.iter().map(|(_, p)| p.info.part.index).collect();
        indices.sort_unstable();
        let list = indices.iter().map(u32::to_string).collect::<Vec<_>>().join(",");
        let attrs = [
            ("rlpt_merged_parts", list),
            ("rlpt_parts", first.part.count.to_string()),
            ("rlpt_scene_hash", format!("{:016x}", first.scene_hash)),
            ("rlpt_settings_hash", format!("{:016x}", first.settings_hash)),
            ("rlpt_seed", first.seed.to_string()),
            ("rlpt_spp", merged.spp.to_string()),
            ("rlpt_total_frames", first.total_frames.to_string()),
            ("rlpt_guiding", first.guiding.clone()),
        ];
        write_exr(&args.output, &merged.mean, merged.variance.as_ref(), &attrs)?;
    } else {
        merged.mean.save(&args.output).with_context(|| format!("writing {}", args.output.display()))?;
    }
    if let (Some(path), Some(v)) = (&args.variance, &merged.variance) {
        v.save(path).with_context(|| format!("writing {}", path.display()))?;
    }
    println!(
        "merged {} part(s) of {}: {}x{}, {} spp -> {}",
        parts.len(),
        first.part.count,
        merged.mean.width,
        merged.mean.height,
        merged.spp,
        args.output.display()
    );
    Ok(())
}
