//! The commands besides `render` as a user meets them: `bench` (passes, counters,
//! traces, rays), `compare` and `plot`, and the reference variances that take a
//! reference's noise out of the relMSE.

mod common;

use common::cli::*;

#[test]
fn bench_times_every_pass_and_writes_json_and_a_trace() {
    let json = tmp("bench.json");
    let trace = tmp("bench-trace.json");
    let o = rlpt()
        .args([
            "bench",
            "scenes/seed-exp2.toml",
            "--width",
            "16",
            "--height",
            "16",
            "--frames",
            "3",
            "--warmup",
            "1",
            "--guiding",
            "sphere",
            "--json",
        ])
        .arg(&json)
        .arg("--trace")
        .arg(&trace)
        .checked_output();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for pass in ["pathtrace", "learn: fold targets", "learn: build sampling rows", "frame", "GPU timestamps"] {
        assert!(stdout.contains(pass), "table names {pass}: {stdout}");
    }
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let frames = report["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 3, "every measured frame, none of the warm-up");
    assert_eq!(frames[0]["frame"], 2);
    assert_eq!(report["guided_fraction"], "learned", "the default guided fraction is learned per cell");
    assert_eq!(report["learning_rate_exponent"], 1.0, "the default exponent of Q's learning rate");
    assert_eq!(report["q_targets"], "mis", "Q-learning targets weighed by MIS by default");
    assert_eq!(report["exploration_floor"].as_f64(), Some(0.1), "the default exploration floor");
    assert!(stdout.contains("guiding sphere (fraction learned, rate exponent 1, floor 0.1), mis targets"), "{stdout}");
    for f in frames {
        let sum = f["pathtrace_ms"].as_f64().unwrap()
            + f["learn_fold_ms"].as_f64().unwrap()
            + f["learn_rows_ms"].as_f64().unwrap();
        assert!(f["pathtrace_ms"].as_f64().unwrap() > 0.0 && f["learn_rows_ms"].as_f64().unwrap() > 0.0, "{f}");
        assert!((f["total_ms"].as_f64().unwrap() - sum).abs() < 1e-6 * sum.max(1.0), "passes add up to the frame: {f}");
        assert!(f["segments"].as_u64().unwrap() >= 16 * 16 * 64, "at least one segment per path: {f}");
    }
    let t: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&trace).unwrap()).unwrap();
    let spans: Vec<&serde_json::Value> =
        t["traceEvents"].as_array().unwrap().iter().filter(|e| e["ph"] == "X").collect();
    assert_eq!(spans.len(), 9, "three passes of three frames");
    for w in spans.windows(2) {
        let end = w[0]["ts"].as_f64().unwrap() + w[0]["dur"].as_f64().unwrap();
        assert!(w[1]["ts"].as_f64().unwrap() >= end - 1e-3, "spans do not overlap on the queue: {w:?}");
    }
}

/// The JSON report of `rlpt bench` on a 16x8 door, two frames without warm-up,
/// with `--counters COUNTERS`.
fn bench_report(counters: &str) -> serde_json::Value {
    let json = tmp(&format!("bench-counters-{counters}.json"));
    let (ok, err) = run(&[
        "bench",
        "scenes/door.toml",
        "--width",
        "16",
        "--height",
        "8",
        "--frames",
        "2",
        "--warmup",
        "0",
        "--counters",
        counters,
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap()
}

/// `bench --counters off` times the kernel `render` runs, compiled without the
/// frame counters: the JSON then has no counts (null, not zero), and the table
/// says they were not counted; the render's own summary (no --stats) needs none.
#[test]
fn bench_without_counters_reports_no_counts() {
    let report = bench_report("off");
    for key in ["msegments_per_s", "segments_per_path", "zero_fraction", "lane_utilization"] {
        assert!(report[key].is_null(), "{key}: {}", report[key]);
    }
    for f in report["frames"].as_array().unwrap() {
        assert!(f["segments"].is_null() && f["zero_paths"].is_null(), "{f}");
    }
    assert!(report["msamples_per_s"].as_f64().unwrap() > 0.0);
    let o = rlpt()
        .args(["bench", "scenes/door.toml", "--width", "16", "--height", "8", "--frames", "1", "--warmup", "0"])
        .args(["--counters", "off"])
        .checked_output();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success() && stdout.contains("not counted (--counters off)"), "{stdout}");
}

/// `bench --counters paths` times the kernel `render --stats` runs: the paths
/// that carried nothing counted, no rays (null in the JSON); `--counters on`
/// counts both and the lane utilization, a share of the lanes in (0, 1].
#[test]
fn bench_counts_paths_alone_or_everything() {
    let paths = bench_report("paths");
    for key in ["msegments_per_s", "segments_per_path", "lane_utilization"] {
        assert!(paths[key].is_null(), "{key}: {}", paths[key]);
    }
    let zero = paths["zero_fraction"].as_f64().expect("zero fraction counted");
    for f in paths["frames"].as_array().unwrap() {
        assert!(f["segments"].is_null() && f["subgroup_segments"].is_null() && f["zero_paths"].is_u64(), "{f}");
    }
    let on = bench_report("on");
    // The same paths: the same number of them carried nothing.
    assert_eq!(on["zero_fraction"].as_f64(), Some(zero));
    let u = on["lane_utilization"].as_f64().expect("lane utilization");
    assert!(u > 0.0 && u <= 1.0, "lane utilization {u}");
    for f in on["frames"].as_array().unwrap() {
        let (rays, subgroups) = (f["segments"].as_u64().unwrap(), f["subgroup_segments"].as_u64().unwrap());
        assert!(rays > 0 && subgroups >= rays, "{f}");
    }
}

#[test]
fn bench_refuses_a_trace_without_gpu_timestamps() {
    let o = rlpt()
        .args([
            "bench",
            "scenes/smallpt.toml",
            "--device",
            "cpu",
            "--width",
            "8",
            "--height",
            "8",
            "--frames",
            "1",
            "--warmup",
            "0",
            "--trace",
        ])
        .arg(tmp("cpu-trace.json"))
        .checked_output();
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("--trace") && stderr.contains("--device cpu"), "{stderr}");
}

#[test]
fn bench_ablate_needs_gpu_guiding() {
    let o = rlpt()
        .args(["bench", "scenes/smallpt.toml", "--width", "8", "--height", "8", "--frames", "1", "--ablate", "record"])
        .checked_output();
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("--ablate") && stderr.contains("--guiding"), "{stderr}");
}

#[test]
fn images_are_compared_like_with_like_and_only_when_finite() {
    use rlpt::image::Image;
    let mut a = Image::new(4, 3);
    a.pixels.iter_mut().for_each(|p| *p = [0.5, 0.25, 1.0]);
    let (exr, png) = (tmp("a.exr"), tmp("a.png"));
    a.save(&exr).unwrap();
    a.save(&png).unwrap();
    let mut nan = a.clone();
    nan.pixels[2 * 4 + 1] = [0.5, f32::NAN, 1.0];
    let nan_path = tmp("nan.exr");
    nan.save(&nan_path).unwrap();
    let p = |x: &std::path::PathBuf| x.to_str().unwrap().to_owned();

    let (ok, out) = run(&["compare", &p(&exr), &p(&exr)]);
    assert!(ok, "{out}");
    // Linear against 8-bit sRGB measured the clamping and the rounding, not the render.
    let (ok, err) = run(&["compare", &p(&exr), &p(&png)]);
    assert!(!ok && err.contains("is an EXR (linear float)") && err.contains("is a PNG"), "{err}");
    // relMSE NaN read like a measurement.
    let (ok, err) = run(&["compare", &p(&nan_path), &p(&exr)]);
    assert!(!ok && err.contains("the image has a NaN or infinite value at pixel (1, 2)"), "{err}");
    let (ok, err) = run(&["compare", &p(&exr), &p(&nan_path)]);
    assert!(!ok && err.contains("the reference has a NaN or infinite value at pixel (1, 2)"), "{err}");

    let render = |reference: &str| {
        run(&[
            "render",
            "scenes/furnace-open.toml",
            "--width",
            "4",
            "--height",
            "3",
            "--spp",
            "64",
            "--device",
            "cpu",
            "-o",
            &p(&tmp("r.exr")),
            "--reference",
            reference,
        ])
    };
    let (ok, err) = render(&p(&png));
    assert!(!ok && err.contains("is a PNG") && err.contains("linear EXR"), "{err}");
    let (ok, err) = render(&p(&nan_path));
    assert!(!ok && err.contains("NaN or infinite value at pixel (1, 2)"), "{err}");
}

/// `compare --image-variance`: two images with their variances give the mean
/// differences as z-scores (the worst a 2x1 region of an 8x4 image, a green pixel
/// 0.1 darker over a variance of 0.01 per pixel: 0.05 / 0.1 = 0.5 deviations);
/// `--max-z` fails below it and passes above; a floor outside [0, 1) and a variance
/// without the reference's are refused.
#[test]
fn compare_says_whether_two_renders_agree() {
    use rlpt::image::Image;
    let mut a = Image::new(8, 4);
    a.pixels.iter_mut().for_each(|p| *p = [1.0, 2.0, 3.0]);
    let mut b = a.clone();
    b.pixels[0][1] -= 0.1;
    let mut v = Image::new(8, 4);
    v.pixels.iter_mut().for_each(|p| *p = [0.01; 3]);
    let (pa, pb, pv) = (tmp("agree-a.exr"), tmp("agree-b.exr"), tmp("agree-v.exr"));
    a.save(&pa).unwrap();
    b.save(&pb).unwrap();
    v.save(&pv).unwrap();
    let p = |x: &std::path::PathBuf| x.to_str().unwrap().to_owned();
    let (a, b, v) = (p(&pa), p(&pb), p(&pv));
    let agree = ["compare", &a, &b, "--image-variance", &v, "--reference-variance", &v];
    let o = rlpt().args(agree).checked_output();
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{out}{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        out.contains("16 regions: worst z +0.50") && out.contains("in columns 0..2, rows 0..1, channel G"),
        "{out}"
    );
    assert!(out.contains("worst |z| 0.50"), "{out}");
    let with = |extra: &[&str]| run(&agree.iter().copied().chain(extra.iter().copied()).collect::<Vec<_>>());
    let (ok, err) = with(&["--max-z", "0.4"]);
    assert!(!ok && err.contains("disagree: a mean differs by 0.50 standard deviations"), "{err}");
    let (ok, out) = with(&["--max-z", "0.6"]);
    assert!(ok, "{out}");
    let (ok, err) = with(&["--floor", "2"]);
    assert!(!ok && err.contains("--floor 2: a relative difference in [0, 1)"), "{err}");
    let (ok, err) = run(&["compare", &a, &b, "--image-variance", &v]);
    assert!(!ok && err.contains("--reference-variance"), "{err}");
}

#[test]
fn plot_says_what_it_cannot_draw() {
    // A bench report is not render statistics.
    let bench_json = tmp("bench-for-plot.json");
    let line = format!(
        "bench scenes/furnace-open.toml --width 8 --height 8 --frames 1 --warmup 0 --device cpu --json {}",
        bench_json.display()
    );
    let (ok, err) = run(&line.split(' ').collect::<Vec<_>>());
    assert!(ok, "{err}");
    let (ok, err) = run(&["plot", bench_json.to_str().unwrap(), "-o", tmp("p.png").to_str().unwrap()]);
    assert!(!ok && err.contains("is a `rlpt bench --json` report, not render statistics"), "{err}");
}

/// `render --variance` and `--reference-variance`: against a reference as noisy
/// as the image (seed-exp1 at 48x32, 256 spp each, CPU renderer), the plain
/// relMSE counts the reference's noise with the image's, about twice the
/// image's error; less the reference's variance it is the image's own. The same
/// image measured against a render of 16 times the samples, less that render's
/// variance, is a second estimate of the same error: the two agree within 5
/// standard errors of their per-pixel difference, and the plain figure is far
/// above both.
#[test]
fn a_references_variance_takes_its_noise_out_of_the_relmse() {
    use rlpt::image::Image;
    let p = |x: &std::path::PathBuf| x.to_str().unwrap().to_owned();
    let cpu_render = |spp: &str, seed: &str, out: &std::path::PathBuf, extra: &[&str]| {
        let mut args = vec![
            "render",
            "scenes/seed-exp1.toml",
            "--width",
            "48",
            "--height",
            "32",
            "--device",
            "cpu",
            "--spp",
            spp,
            "--seed",
            seed,
        ];
        args.extend_from_slice(extra);
        let out = p(out);
        args.extend_from_slice(&["-o", &out]);
        let o = rlpt().args(&args).checked_output();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let (reference, reference_var) = (tmp("dv-ref.exr"), tmp("dv-ref.var.exr"));
    let (long, long_var) = (tmp("dv-long.exr"), tmp("dv-long.var.exr"));
    let (image, stats) = (tmp("dv-image.exr"), tmp("dv-stats.json"));
    cpu_render("256", "1", &reference, &["--variance", &p(&reference_var)]);
    cpu_render("4096", "2", &long, &["--variance", &p(&long_var)]);
    let summary = cpu_render(
        "256",
        "3",
        &image,
        &["--reference", &p(&reference), "--reference-variance", &p(&reference_var), "--stats", &p(&stats)],
    );
    assert!(summary.contains("less the reference's variance"), "{summary}");
    let last = rlpt::stats::RenderStats::load(&stats).unwrap().frames.pop().unwrap();
    let (plain, debiased) = (last.rel_mse.unwrap(), last.rel_mse_debiased.unwrap());

    // Per-pixel terms against either reference, from the files.
    let load = |f: &std::path::PathBuf| Image::load(f).unwrap();
    let (x, r, rv, l, lv) = (load(&image), load(&reference), load(&reference_var), load(&long), load(&long_var));
    let term = |i: usize, r: &Image, v: &Image| -> f64 {
        (0..3)
            .map(|c| {
                rlpt::metrics::rel_mse_debiased(x.pixels[i][c] as f64, r.pixels[i][c] as f64, v.pixels[i][c] as f64)
            })
            .sum::<f64>()
            / 3.0
    };
    let n = x.pixels.len();
    let against_long: f64 = (0..n).map(|i| term(i, &l, &lv)).sum::<f64>() / n as f64;
    let mean_here: f64 = (0..n).map(|i| term(i, &r, &rv)).sum::<f64>() / n as f64;
    assert!((mean_here - debiased).abs() <= 1e-6 * debiased.abs(), "{mean_here} against the stats' {debiased}");
    let diffs: Vec<f64> = (0..n).map(|i| term(i, &r, &rv) - term(i, &l, &lv)).collect();
    let mean = diffs.iter().sum::<f64>() / n as f64;
    let se = (diffs.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / ((n - 1) * n) as f64).sqrt();
    eprintln!("plain {plain:.4e}, less the reference's variance {debiased:.4e}, against the long render {against_long:.4e} (se {se:.2e})");
    assert!(
        (debiased - against_long).abs() <= 5.0 * se,
        "less the reference's variance {debiased:.4e}, against the long render {against_long:.4e} (se {se:.2e})"
    );
    assert!(plain > 1.5 * against_long, "plain {plain:.4e} against the image's own error {against_long:.4e}");
    // compare says the same.
    let o = rlpt()
        .args(["compare", &p(&image), &p(&reference), "--reference-variance", &p(&reference_var)])
        .checked_output();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success() && stdout.contains(&format!("less the reference's variance {debiased:.6e}")),
        "{stdout}"
    );
}

/// What `--variance` and `--reference-variance` refuse, by name, before rendering
/// where they can: a variance that is not an EXR, or of another size, or negative;
/// a render of one frame; a variance without the reference it belongs to; PNGs.
#[test]
fn reference_variances_are_checked() {
    use rlpt::image::Image;
    let p = |x: &std::path::PathBuf| x.to_str().unwrap().to_owned();
    let mut r = Image::new(4, 3);
    r.pixels.iter_mut().for_each(|px| *px = [0.5, 0.25, 1.0]);
    let (reference, png) = (tmp("rv-ref.exr"), tmp("rv-ref.png"));
    r.save(&reference).unwrap();
    r.save(&png).unwrap();
    let mut v = Image::new(4, 3);
    let good = tmp("rv-good.exr");
    v.save(&good).unwrap();
    v.pixels[5] = [0.0, -1.0, 0.0];
    let negative = tmp("rv-negative.exr");
    v.save(&negative).unwrap();
    let small = tmp("rv-small.exr");
    Image::new(2, 2).save(&small).unwrap();
    let out = p(&tmp("rv-out.exr"));
    let render = |extra: &[&str]| {
        let mut args =
            vec!["render", "scenes/furnace-open.toml", "--width", "4", "--height", "3", "--device", "cpu", "-o", &out];
        args.extend_from_slice(extra);
        run(&args)
    };
    let with = |var: &std::path::PathBuf| {
        render(&["--spp", "128", "--reference", &p(&reference), "--reference-variance", &p(var)])
    };
    assert!(with(&good).0);
    let (ok, err) = with(&negative);
    assert!(!ok && err.contains("--reference-variance") && err.contains("negative value at pixel (1, 1)"), "{err}");
    let (ok, err) = with(&small);
    assert!(!ok && err.contains("variance image is 2x2 but the reference is 4x3"), "{err}");
    let (ok, err) = with(&png);
    assert!(!ok && err.contains("is a PNG") && err.contains("linear EXR"), "{err}");
    let (ok, err) = render(&["--spp", "128", "--reference-variance", &p(&good)]);
    assert!(!ok && err.contains("--reference"), "{err}");
    let (ok, err) = render(&["--spp", "64", "--variance", &p(&tmp("rv-one.exr"))]);
    assert!(!ok && err.contains("--variance needs at least 2 frames"), "{err}");
    // A render that --time stops after its first frame: the image is kept, the variance refused.
    // 1 ns: no frame is that short (at 0.1 ms, a frame of this 4x3 image sometimes
    // was, and two frames rendered).
    let (ok, err) = render(&["--spp", "100000000", "--time", "0.000000001", "--variance", &p(&tmp("rv-timed.exr"))]);
    assert!(!ok && err.contains("stopped after 1 frame") && err.contains("the image was written"), "{err}");
    assert!(!tmp("rv-timed.exr").exists());
    let (ok, err) = render(&["--spp", "128", "--variance", &p(&tmp("rv-var.png"))]);
    assert!(!ok && err.contains("--variance") && err.contains(".exr"), "{err}");
    let (ok, err) = render(&["--spp", "128", "--variance", &out]);
    assert!(!ok && err.contains("--output and --variance both name"), "{err}");
    // The variance written is the film's: 2 frames, a finite non-negative image of the render's size.
    let var_out = tmp("rv-written.exr");
    assert!(render(&["--spp", "128", "--variance", &p(&var_out)]).0);
    let written = Image::load(&var_out).unwrap();
    assert_eq!((written.width, written.height), (4, 3));
    assert!(written.pixels.iter().all(|px| px.iter().all(|&c| c.is_finite() && c >= 0.0)));
    let (ok, err) = run(&["compare", &p(&png), &p(&png), "--reference-variance", &p(&good)]);
    assert!(!ok && err.contains("compare two EXRs with it"), "{err}");
}

#[test]
fn bench_rays_times_the_three_kinds_of_ray_and_needs_the_gpu() {
    let json = tmp("rays.json");
    let o = rlpt()
        .args(["bench", "scenes/cornell-box.toml", "--rays", "2", "--width", "16", "--height", "12", "--json"])
        .arg(&json)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for kind in ["camera rays", "bounce rays", "any-hit rays"] {
        assert!(text.contains(kind) && text.contains("Mrays/s"), "{kind}: {text}");
    }
    let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    // One camera ray per pixel; a bounce ray from each of their hits.
    assert_eq!(r["camera_rays"], 16 * 12, "{r}");
    assert!(r["bounce_rays"].as_u64().unwrap() > 0 && r["camera_mrays_per_s"].as_f64().unwrap() > 0.0, "{r}");
    let o = rlpt().args(["bench", "scenes/cornell-box.toml", "--rays", "2", "--device", "cpu"]).output().unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("--rays times GPU dispatches: it needs --device gpu"), "{e}");
}
