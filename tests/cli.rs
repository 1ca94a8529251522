//! The command line as a user meets it.

use std::process::Command;

fn rlpt() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_rlpt"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

fn tmp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("rlpt-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

#[test]
fn render_writes_png_and_exr_and_prints_a_summary() {
    for (ext, device) in [("png", "gpu"), ("exr", "cpu")] {
        let out = tmp(&format!("smallpt.{ext}"));
        let o = rlpt()
            .args([
                "render",
                "scenes/smallpt.toml",
                "--width",
                "32",
                "--height",
                "24",
                "--spp",
                "100",
                "--device",
                device,
                "-o",
            ])
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{stderr}");
        assert!(stderr.contains("rounded up to 128"), "the spp rounding is announced: {stderr}");
        assert!(stdout.contains("32x24, 128 spp") && stdout.contains("Msamples/s"), "summary line: {stdout}");
        let img = rlpt::image::Image::load(&out).unwrap();
        assert_eq!((img.width, img.height), (32, 24));
        let mean: f32 = img.pixels.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / (3.0 * img.pixels.len() as f32);
        assert!(mean > 0.05, "{ext} image is not black (mean {mean})");
    }
}

#[test]
fn no_vulkan_driver_is_a_sentence_not_a_crash() {
    // Point the loader at an empty driver list.
    let icd_dir = tmp("no-icd");
    std::fs::create_dir_all(&icd_dir).unwrap();
    let o = rlpt()
        .args(["render", "scenes/furnace-open.toml", "-o"])
        .arg(tmp("x.png"))
        .env("VK_DRIVER_FILES", icd_dir.join("none.json"))
        .env("VK_ICD_FILENAMES", icd_dir.join("none.json"))
        .env_remove("VK_ADD_DRIVER_FILES")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        stderr.contains("no Vulkan device found")
            && stderr.contains("apt install mesa-vulkan-drivers")
            && stderr.contains("--device cpu"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn bad_scene_names_file_and_line() {
    let scene = tmp("bad.toml");
    std::fs::write(&scene, "[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\nvfov = 200\n").unwrap();
    let o = rlpt().args(["render"]).arg(&scene).args(["-o"]).arg(tmp("bad.png")).output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(stderr.contains("bad.toml:4:"), "{stderr}");
    assert!(!tmp("bad.png").exists(), "nothing is rendered from a scene that did not load");
}

#[test]
fn bad_output_is_refused_before_rendering() {
    let o = rlpt().args(["render", "scenes/smallpt.toml", "-o", "out.jpg"]).output().unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains(".png or .exr"));
    let o = rlpt().args(["render", "scenes/smallpt.toml", "-o", "/nonexistent-dir/out.png"]).output().unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("does not exist"));
}

#[test]
fn devices_lists_the_subgroup_size() {
    let o = rlpt().arg("devices").output().unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(stdout.contains("subgroup size") && stdout.contains("driver:"), "{stdout}");
}

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
        .output()
        .unwrap();
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
    assert!(stdout.contains("guiding sphere (fraction learned, rate exponent 1)"), "{stdout}");
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
        .output()
        .unwrap();
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("--trace") && stderr.contains("--device cpu"), "{stderr}");
}

#[test]
fn bench_ablate_needs_gpu_guiding() {
    let o = rlpt()
        .args(["bench", "scenes/smallpt.toml", "--width", "8", "--height", "8", "--frames", "1", "--ablate", "record"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("--ablate") && stderr.contains("--guiding"), "{stderr}");
}

#[test]
fn guided_vertices_must_be_at_least_one() {
    let o = rlpt()
        .args(["render", "scenes/smallpt.toml", "-o", "x.png", "--guiding", "sphere", "--guided-vertices", "0"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("--guided-vertices") && stderr.contains("0"), "{stderr}");
}

#[test]
fn guided_fraction_is_learned_or_a_probability_below_one() {
    for (arg, says) in [
        ("1", "[0, 1)"),
        ("1.5", "[0, 1)"),
        ("-0.1", "[0, 1)"),
        ("nan", "[0, 1)"),
        ("half", "neither a number nor `learned`"),
    ] {
        let o = rlpt()
            .args(["render", "scenes/smallpt.toml", "-o", "x.png", "--guiding", "sphere", "--guided-fraction", arg])
            .output()
            .unwrap();
        assert!(!o.status.success(), "--guided-fraction {arg} was accepted");
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(stderr.contains("--guided-fraction") && stderr.contains(says), "{arg}: {stderr}");
    }
}

#[test]
fn learning_rate_exponent_is_above_one_half_and_at_most_one() {
    for (arg, says) in
        [("0.5", "(0.5, 1]"), ("-1", "(0.5, 1]"), ("1.25", "(0.5, 1]"), ("nan", "(0.5, 1]"), ("fast", "not a number")]
    {
        let o = rlpt()
            .args([
                "render",
                "scenes/smallpt.toml",
                "-o",
                "x.png",
                "--guiding",
                "sphere",
                "--learning-rate-exponent",
                arg,
            ])
            .output()
            .unwrap();
        assert!(!o.status.success(), "--learning-rate-exponent {arg} was accepted");
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(stderr.contains("--learning-rate-exponent") && stderr.contains(says), "{arg}: {stderr}");
    }
}

#[test]
fn bins_are_rows_by_columns_within_the_limit() {
    // 65536 x 65536 overflows 32 bits to 0: it once passed the check that way, and
    // panicked in debug builds.
    for (arg, says) in [
        ("0x16", "at least 1"),
        ("8x0", "at least 1"),
        ("33x32", "at most 1024 bins"),
        ("65536x65536", "at most 1024 bins"),
        ("4294967295x2", "at most 1024 bins"),
        ("8by16", "expected ROWSxCOLS"),
        ("ax16", "not a positive integer"),
    ] {
        let o = rlpt()
            .args(["render", "scenes/smallpt.toml", "-o", "x.png", "--guiding", "sphere", "--bins", arg])
            .output()
            .unwrap();
        assert!(!o.status.success(), "--bins {arg} was accepted");
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!stderr.contains("panicked"), "--bins {arg}: {stderr}");
        assert!(stderr.contains("--bins") && stderr.contains(says), "{arg}: {stderr}");
    }
}
