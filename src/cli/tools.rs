//! `rlpt compare`, `plot` and `devices`: measuring images, plotting runs, listing devices.

use crate::*;

/// `rlpt compare`: relMSE, RMSE and MAPE of `image` against `reference`; with
/// `agreement` (the image's variance, `--max-z`, `--floor`), also whether the two
/// renders' means agree ([`agree`]), from the images read once.
pub(crate) fn compare(
    image: &Path,
    reference: &Path,
    reference_variance: Option<&Path>,
    agreement: Option<(&Path, Option<f64>, f64)>,
) -> Result<()> {
    if let Some((_, _, floor)) = agreement {
        if !(0.0..1.0).contains(&floor) {
            bail!("--floor {floor}: a relative difference in [0, 1)");
        }
    }
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
    let (e, checked) = match reference_variance {
        Some(v) => {
            let r = with_reference_variance(metrics::Reference::new(b).map_err(against)?, v)?;
            (r.compare(&a).map_err(against)?, Some(r))
        }
        None => (metrics::compare(&a, &b).map_err(against)?, None),
    };
    let debiased = e.rel_mse_debiased.map(|d| format!("  relMSE less the reference's variance {d:.6e}"));
    println!("relMSE {:.6e}  RMSE {:.6e}  MAPE {:.6e}{}", e.rel_mse, e.rmse, e.mape, debiased.unwrap_or_default());
    match (agreement, checked.as_ref().and_then(|r| Some((r.image(), r.variance()?)))) {
        (Some((image_variance, max_z, floor)), Some((b, vb))) => {
            let hint = "a variance is a linear EXR (`rlpt render --variance VAR.exr`)";
            let va = load_exr(image_variance, "the image's variance", "--image-variance", hint)?;
            agree(image, &a, &va, reference, b, vb, max_z, floor)
        }
        (Some(_), None) => bail!("--image-variance needs the reference's too (--reference-variance)"),
        (None, _) => Ok(()),
    }
}

/// `compare --image-variance`: whether two independent renders' means agree
/// (`metrics::agreement`), printed; with `max_z`, an error where one differs by more.
#[allow(clippy::too_many_arguments)]
fn agree(
    image: &Path,
    a: &Image,
    va: &Image,
    reference: &Path,
    b: &Image,
    vb: &Image,
    max_z: Option<f64>,
    floor: f64,
) -> Result<()> {
    let ag = metrics::agreement(a, va, b, vb, floor)
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

pub(crate) fn plot(stats: &[PathBuf], output: &Path, debiased: bool) -> Result<()> {
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

pub(crate) fn devices() -> Result<()> {
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

pub(crate) fn yes_no(b: bool) -> &'static str {
    if b {
        "yes"
    } else {
        "no"
    }
}
