//! The command line as a user meets it.

use std::process::{Command, Output};

/// `rlpt` with the Khronos validation layer on (synchronization validation included)
/// for every GPU it touches; run it with [`Checked::checked_output`].
fn rlpt() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_rlpt"));
    c.current_dir(env!("CARGO_MANIFEST_DIR")).env("RLPT_VALIDATION", "1");
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        c.env("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    c
}

/// How every test here runs `rlpt`: the run fails the test if the validation layer
/// said anything, whatever the exit status the test expects.
trait Checked {
    fn checked_output(&mut self) -> Output;
}

impl Checked for Command {
    fn checked_output(&mut self) -> Output {
        let o = self.output().expect("rlpt runs");
        assert_no_validation_messages(&String::from_utf8_lossy(&o.stderr));
        assert_no_validation_messages(&String::from_utf8_lossy(&o.stdout));
        o
    }
}

/// rlpt prints each message the layer sends it as "vulkan validation (...)", and ends
/// with "the Vulkan validation layer reported N problem(s)" and a failure status when
/// any was counted, those at a context's destruction included; where no messenger of
/// rlpt's is registered the layer prints its own "Validation Error" / "Validation Warning".
fn assert_no_validation_messages(output: &str) {
    for sign in ["vulkan validation", "validation layer reported", "Validation Error", "Validation Warning"] {
        assert!(!output.contains(sign), "the validation layer spoke:\n{output}");
    }
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
            .checked_output();
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
        // Without validation: with it the loader's own complaint about the missing driver
        // reaches the messenger, and that is what this test provokes.
        .env_remove("RLPT_VALIDATION")
        .checked_output();
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
    let o = rlpt().args(["render"]).arg(&scene).args(["-o"]).arg(tmp("bad.png")).checked_output();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(stderr.contains("bad.toml:4:"), "{stderr}");
    assert!(!tmp("bad.png").exists(), "nothing is rendered from a scene that did not load");
}

#[test]
fn bad_output_is_refused_before_rendering() {
    let o = rlpt().args(["render", "scenes/smallpt.toml", "-o", "out.jpg"]).checked_output();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains(".png or .exr"));
    let o = rlpt().args(["render", "scenes/smallpt.toml", "-o", "/nonexistent-dir/out.png"]).checked_output();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("does not exist"));
}

#[test]
fn devices_lists_the_subgroup_size() {
    let o = rlpt().arg("devices").checked_output();
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
fn guided_vertices_must_be_at_least_one() {
    let o = rlpt()
        .args(["render", "scenes/smallpt.toml", "-o", "x.png", "--guiding", "sphere", "--guided-vertices", "0"])
        .checked_output();
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("--guided-vertices") && stderr.contains("0"), "{stderr}");
}

/// `rlpt render` with guiding on refuses each value of `flag` in `cases`, without
/// a panic, naming the flag and saying what the case expects.
fn refuses(flag: &str, cases: &[(&str, &str)]) {
    for (arg, says) in cases {
        let o = rlpt()
            .args(["render", "scenes/smallpt.toml", "-o", "x.png", "--guiding", "sphere", flag, arg])
            .checked_output();
        assert!(!o.status.success(), "{flag} {arg} was accepted");
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!stderr.contains("panicked"), "{flag} {arg}: {stderr}");
        assert!(stderr.contains(flag) && stderr.contains(says), "{flag} {arg}: {stderr}");
    }
}

#[test]
fn guided_fraction_is_learned_or_a_probability_below_one() {
    refuses(
        "--guided-fraction",
        &[
            ("1", "[0, 1)"),
            ("1.5", "[0, 1)"),
            ("-0.1", "[0, 1)"),
            ("nan", "[0, 1)"),
            ("half", "neither a number nor `learned`"),
        ],
    );
}

#[test]
fn learning_rate_exponent_is_above_one_half_and_at_most_one() {
    refuses(
        "--learning-rate-exponent",
        &[("0.5", "(0.5, 1]"), ("-1", "(0.5, 1]"), ("1.25", "(0.5, 1]"), ("nan", "(0.5, 1]"), ("fast", "not a number")],
    );
}

#[test]
fn exploration_floor_is_a_number_from_zero_to_the_limit() {
    refuses(
        "--exploration-floor",
        &[
            ("-0.1", "[0, 10000]"),
            ("nan", "[0, 10000]"),
            ("inf", "[0, 10000]"),
            ("1e5", "[0, 10000]"),
            ("wide", "not a number"),
        ],
    );
}

#[test]
fn learning_frames_are_a_whole_number_up_to_the_limit() {
    refuses(
        "--learning-frames",
        &[
            ("65537", "0 to 65536 frames"),
            ("-1", "not a whole number"),
            ("2.5", "not a whole number"),
            ("many", "not a whole number"),
        ],
    );
}

/// The image starts after the learning frames: door has Russian roulette, so 4 by
/// default; `--spp` counts the image's samples, and the stats give each frame the
/// samples of the image it would write.
#[test]
fn the_image_starts_after_the_learning_frames() {
    let (o, stats) = (tmp("learning.png"), tmp("learning.json"));
    let (o, stats) = (o.to_str().unwrap(), stats.to_str().unwrap());
    let read = |scene: &str, extra: &[&str]| {
        let base = ["render", scene, "--width", "16", "--height", "8", "--spp", "128", "--device", "cpu"];
        let args: Vec<&str> = base.iter().chain(["-o", o, "--stats", stats].iter()).chain(extra).copied().collect();
        let out = rlpt().args(&args).checked_output();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let s = serde_json::from_str::<serde_json::Value>(&std::fs::read_to_string(stats).unwrap()).unwrap();
        let spp: Vec<u64> = s["frames"].as_array().unwrap().iter().map(|f| f["spp"].as_u64().unwrap()).collect();
        (s["learning_frames"].as_u64(), spp, String::from_utf8_lossy(&out.stdout).into_owned())
    };
    let door = "scenes/door.toml";
    let (n, spp, out) = read(door, &["--guiding", "sphere"]);
    assert_eq!((n, spp.as_slice()), (Some(4), [64, 128, 192, 256, 64, 128].as_slice()), "{out}");
    assert!(out.contains("128 spp after 4 learning frames"), "{out}");
    let (n, spp, _) = read(door, &["--guiding", "octant", "--learning-frames", "1"]);
    assert_eq!((n, spp.as_slice()), (Some(1), [64, 64, 128].as_slice()));
    let (n, spp, out) = read(door, &["--guiding", "sphere", "--learning-frames", "0"]);
    assert_eq!((n, spp.as_slice()), (Some(0), [64, 128].as_slice()));
    assert!(out.contains("128 spp, guiding sphere"), "{out}");
    // Without roulette (seed-exp1) no frame is left out by default; without guiding none at all.
    let (n, spp, _) = read("scenes/seed-exp1.toml", &["--guiding", "sphere"]);
    assert_eq!((n, spp.as_slice()), (Some(0), [64, 128].as_slice()));
    let (n, spp, _) = read(door, &[]);
    assert_eq!((n, spp.as_slice()), (None, [64, 128].as_slice()));
}

#[test]
fn render_stats_record_the_guiding_settings_given() {
    let (o, stats) = (tmp("settings.png"), tmp("settings.json"));
    let (o, stats) = (o.to_str().unwrap(), stats.to_str().unwrap());
    let base = ["render", "scenes/door.toml", "--width", "16", "--height", "8", "--spp", "128", "--device", "cpu"];
    let read = |extra: &[&str]| {
        let args: Vec<&str> = base.iter().chain(["-o", o, "--stats", stats].iter()).chain(extra).copied().collect();
        let (ok, err) = run(&args);
        assert!(ok, "{err}");
        serde_json::from_str::<serde_json::Value>(&std::fs::read_to_string(stats).unwrap()).unwrap()
    };
    let s = read(&["--guiding", "sphere", "--exploration-floor", "0.3", "--q-targets", "full"]);
    assert_eq!(s["exploration_floor"].as_f64(), Some(0.3), "{s}");
    assert_eq!(s["q_targets"], "full", "{s}");
    assert_eq!(s["learning_rate_exponent"], 1.0, "{s}");
    let label = s["label"].as_str().unwrap();
    assert!(label.contains(" floor=0.3") && label.contains(" targets=full"), "{label}");
    // The defaults are recorded, and the label names only what differs from them.
    let s = read(&["--guiding", "octant"]);
    assert_eq!((s["exploration_floor"].as_f64(), &s["q_targets"]), (Some(0.1), &"mis".into()), "{s}");
    assert!(!s["label"].as_str().unwrap().contains("floor="), "{s}");
    // Without guiding there is nothing to record.
    let s = read(&[]);
    assert!(s.get("exploration_floor").is_none() && s.get("q_targets").is_none(), "{s}");
}

#[test]
fn bins_are_rows_by_columns_within_the_limit() {
    // 65536 x 65536 overflows 32 bits to 0: it once passed the check that way, and
    // panicked in debug builds.
    refuses(
        "--bins",
        &[
            ("0x16", "at least 1"),
            ("8x0", "at least 1"),
            ("33x32", "at most 1024 bins"),
            ("65536x65536", "at most 1024 bins"),
            ("4294967295x2", "at most 1024 bins"),
            ("8by16", "expected ROWSxCOLS"),
            ("ax16", "not a positive integer"),
        ],
    );
}

/// Runs `rlpt ARGS` and returns (success, stderr).
fn run(args: &[&str]) -> (bool, String) {
    let o = rlpt().args(args).checked_output();
    (o.status.success(), String::from_utf8_lossy(&o.stderr).into_owned())
}

#[test]
fn sample_and_frame_counts_beyond_32_bits_are_refused_not_overflowed() {
    // u32::MAX samples rounded up to whole frames of 64 overflowed: a panic.
    let (ok, err) = run(&["render", "scenes/smallpt.toml", "-o", "x.png", "--spp", "4294967233"]);
    assert!(!ok && !err.contains("panicked") && err.contains("--spp") && err.contains("4294967232"), "{err}");
    // A warm-up of u32::MAX frames plus the measured ones overflowed too (and
    // without a bound, a large one ran for hours).
    let (ok, err) = run(&["bench", "scenes/smallpt.toml", "--frames", "1", "--warmup", "4294967295"]);
    assert!(!ok && !err.contains("panicked") && err.contains("--warmup") && err.contains("100000"), "{err}");
}

#[test]
fn outputs_are_checked_before_rendering_and_never_share_a_path() {
    let out = tmp("same.exr");
    let same = out.to_str().unwrap();
    let (ok, err) = run(&["render", "scenes/smallpt.toml", "-o", same, "--stats", same]);
    assert!(!ok && err.contains("--output and --stats both name"), "{err}");
    let (ok, err) = run(&["bench", "scenes/smallpt.toml", "--json", same, "--trace", same]);
    assert!(!ok && err.contains("--json and --trace both name"), "{err}");
    // A directory where a file is wanted: refused up front, before the render.
    let dir = tmp("a-directory.png");
    std::fs::create_dir_all(&dir).unwrap();
    let (ok, err) = run(&["render", "scenes/smallpt.toml", "--spp", "100000000", "-o", dir.to_str().unwrap()]);
    assert!(!ok && err.contains("is a directory"), "{err}");
    let (ok, err) = run(&["bench", "scenes/smallpt.toml", "--json", dir.to_str().unwrap()]);
    assert!(!ok && err.contains("--json") && err.contains("is a directory"), "{err}");
}

#[test]
fn options_that_change_nothing_are_named() {
    let out = tmp("ignored.exr");
    let o = out.to_str().unwrap();
    let base = ["render", "scenes/furnace-open.toml", "--width", "8", "--height", "8", "--spp", "64"];
    let with = |extra: &[&str]| {
        let args: Vec<&str> = base.iter().chain(["--device", "cpu", "-o", o].iter()).chain(extra).copied().collect();
        run(&args)
    };
    let (ok, err) = with(&["--bins", "4x4", "--guiding", "octant"]);
    assert!(
        ok && err.contains("note: --bins sets the bins of --guiding sphere; ignored with --guiding octant"),
        "{err}"
    );
    let (ok, err) = with(&[
        "--guided-fraction",
        "0.3",
        "--learning-rate-exponent",
        "0.8",
        "--exploration-floor",
        "0",
        "--learning-frames",
        "2",
    ]);
    assert!(ok && err.contains("note: --guided-fraction is a setting of learned guiding"), "{err}");
    assert!(err.contains("note: --learning-frames is a setting of learned guiding"), "{err}");
    assert!(err.contains("note: --learning-rate-exponent is a setting of learned guiding"), "{err}");
    assert!(err.contains("note: --exploration-floor is a setting of learned guiding"), "{err}");
    let (ok, err) = with(&["--q-targets", "full"]);
    assert!(ok && err.contains("note: --q-targets is a setting of learned guiding"), "{err}");
    let (ok, err) = with(&["--q-targets", "full", "--guiding", "octant", "--nee", "off"]);
    assert!(ok && err.contains("note: --q-targets weighs the light met against light sampling"), "{err}");
    let (ok, err) = with(&["--mis", "balance", "--nee", "off", "--gpu", "7"]);
    assert!(ok && err.contains("note: --mis") && err.contains("note: --gpu"), "{err}");
    // Given where they apply, or not given: no note.
    let (ok, err) = with(&["--bins", "4x4", "--guiding", "sphere", "--mis", "balance", "--q-targets", "full"]);
    assert!(ok && !err.contains("note:"), "{err}");
}

#[test]
fn scenes_and_cameras_that_cannot_show_light_are_warned_about() {
    let write = |name: &str, text: &str| {
        let p = tmp(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let camera = "[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\nvfov = 45\n";
    let materials = "[[material]]\nname = \"white\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\
                     [[material]]\nname = \"lamp\"\ntype = \"emissive\"\nemission = [1, 1, 1]\n";
    // Nothing emits: the loader cannot call it wrong, but the user hears of it.
    let dark = write("dark.toml", &format!("{camera}[[material]]\nname = \"white\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n[[sphere]]\ncenter = [0, 0, -5]\nradius = 1\nmaterial = \"white\"\n"));
    // A lamp outside a closed ball that holds the camera: every pixel black.
    let inside = write(
        "inside.toml",
        &format!("{camera}{materials}[[sphere]]\ncenter = [0, 0, 0]\nradius = 2\nmaterial = \"white\"\n[[sphere]]\ncenter = [0, 10, 0]\nradius = 1\nmaterial = \"lamp\"\n"),
    );
    // The same lamp seen: no warning.
    let lit = write(
        "lit.toml",
        &format!("{camera}{materials}[[sphere]]\ncenter = [0, 0, -5]\nradius = 1\nmaterial = \"lamp\"\n"),
    );
    let out = tmp("warned.png");
    let render = |scene: &std::path::Path| {
        run(&[
            "render",
            scene.to_str().unwrap(),
            "--width",
            "8",
            "--height",
            "8",
            "--spp",
            "64",
            "--device",
            "cpu",
            "-o",
            out.to_str().unwrap(),
        ])
    };
    let (ok, err) = render(&dark);
    assert!(ok && err.contains("no sphere, quad or mesh triangle emits light and the environment is black"), "{err}");
    let (ok, err) = render(&inside);
    assert!(ok && err.contains("every pixel of") && err.contains("is black"), "{err}");
    assert!(!err.contains("emits light and the environment is black"), "{err}");
    let (ok, err) = render(&lit);
    assert!(ok && !err.contains("warning"), "{err}");
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
    let bench_json = tmp("bench.json");
    let line = format!(
        "bench scenes/furnace-open.toml --width 8 --height 8 --frames 1 --warmup 0 --device cpu --json {}",
        bench_json.display()
    );
    let (ok, err) = run(&line.split(' ').collect::<Vec<_>>());
    assert!(ok, "{err}");
    let (ok, err) = run(&["plot", bench_json.to_str().unwrap(), "-o", tmp("p.png").to_str().unwrap()]);
    assert!(!ok && err.contains("is a `rlpt bench --json` report, not render statistics"), "{err}");
}

#[test]
fn a_guiding_box_away_from_the_scene_and_other_slips_are_named() {
    let scene = tmp("door-box-away.toml");
    let door = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/door.toml")).unwrap();
    std::fs::write(&scene, format!("{door}\n[guiding]\nbounds_min = [100, 100, 100]\nbounds_max = [101, 101, 101]\n"))
        .unwrap();
    let out = tmp("box.png");
    let render = |scene: &str, guiding: &str| {
        let small = ["--device", "cpu", "--width", "8", "--height", "8", "--spp", "64"];
        let args: Vec<&str> =
            ["render", scene, "--guiding", guiding, "-o", out.to_str().unwrap()].into_iter().chain(small).collect();
        run(&args)
    };
    let (ok, err) = render(scene.to_str().unwrap(), "sphere");
    assert!(ok && err.contains("the [guiding] box from [100, 100, 100] to [101, 101, 101] does not overlap"), "{err}");
    // Without guiding the box means nothing, and nothing is said.
    let (ok, err) = render(scene.to_str().unwrap(), "off");
    assert!(ok && !err.contains("warning"), "{err}");
    // The door's own automatic box: no warning.
    let (ok, err) = render("scenes/door.toml", "sphere");
    assert!(ok && !err.contains("warning"), "{err}");
    // The viewer warns too, whichever guiding it starts with (it switches as it
    // runs), before it opens a window: with or without a display here.
    let shot = tmp("box-view.png");
    let view = ["view", scene.to_str().unwrap(), "--width", "8", "--height", "8", "--frames", "1", "--screenshot"];
    let (_, err) = run(&view.iter().copied().chain([shot.to_str().unwrap()]).collect::<Vec<_>>());
    assert!(err.contains("the [guiding] box from [100, 100, 100] to [101, 101, 101] does not overlap"), "{err}");

    let (ok, err) = run(&["render", "scenes/door.toml", "-o", "x.png", "--seed", "18446744073709551615"]);
    assert!(!ok && err.contains("is not a seed: an integer from 0 to 4294967295"), "{err}");
    let stats = tmp("stats-twice.json");
    let (ok, err) =
        run(&["plot", stats.to_str().unwrap(), stats.to_str().unwrap(), "-o", tmp("twice.png").to_str().unwrap()]);
    assert!(!ok && err.contains("is given twice"), "{err}");
    // The same file under two names: through `..`, and through a link to it.
    std::fs::write(&stats, "{}").unwrap();
    let dir = stats.parent().unwrap();
    let around = dir.join("..").join(dir.file_name().unwrap()).join("stats-twice.json");
    let (ok, err) =
        run(&["plot", stats.to_str().unwrap(), around.to_str().unwrap(), "-o", tmp("twice.png").to_str().unwrap()]);
    assert!(!ok && err.contains("are the same file"), "{err}");
    let link = tmp("stats-link.json");
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink(&stats, &link).unwrap();
    let (ok, err) =
        run(&["plot", link.to_str().unwrap(), stats.to_str().unwrap(), "-o", tmp("twice.png").to_str().unwrap()]);
    assert!(!ok && err.contains("are the same file"), "{err}");
    // Two files: the check passes them, and the first one's content is what fails.
    let other = tmp("stats-other.json");
    std::fs::write(&other, "{}").unwrap();
    let (ok, err) =
        run(&["plot", stats.to_str().unwrap(), other.to_str().unwrap(), "-o", tmp("twice.png").to_str().unwrap()]);
    assert!(!ok && !err.contains("same file") && !err.contains("given twice"), "{err}");
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

/// Sends SIGINT (what Ctrl-C sends) to a child process.
fn interrupt(child: &std::process::Child) {
    let ok = Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap().success();
    assert!(ok, "kill -INT {}", child.id());
}

/// Waits for `child` to end, at most `limit`; kills it and fails past that.
fn wait_at_most(child: &mut std::process::Child, limit: std::time::Duration) -> std::process::ExitStatus {
    let start = std::time::Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        if start.elapsed() > limit {
            child.kill().unwrap();
            panic!("the process did not end within {limit:?} of Ctrl-C");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// The spp a render's summary line names ("WxH, N spp").
fn summary_spp(stdout: &str) -> u32 {
    let (_, after) = stdout.split_once("32x24, ").unwrap_or_else(|| panic!("no summary line: {stdout}"));
    after.split_once(" spp").and_then(|(n, _)| n.parse().ok()).unwrap_or_else(|| panic!("no spp: {stdout}"))
}

#[test]
fn ctrl_c_writes_what_was_rendered_with_its_spp() {
    use std::io::Read;
    let asked = 64_000_000u32;
    for device in ["cpu", "gpu"] {
        let (out, var, stats) =
            (tmp(&format!("int-{device}.png")), tmp(&format!("int-{device}.exr")), tmp(&format!("int-{device}.json")));
        let mut child = rlpt()
            .args(["render", "scenes/smallpt.toml", "--width", "32", "--height", "24", "--device", device])
            .args(["--spp", &asked.to_string(), "-o"])
            .arg(&out)
            .arg("--variance")
            .arg(&var)
            .arg("--stats")
            .arg(&stats)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        // Long enough for frames on either device; a Ctrl-C during the set-up would
        // still write the first frame.
        std::thread::sleep(std::time::Duration::from_millis(2500));
        interrupt(&child);
        let status = wait_at_most(&mut child, std::time::Duration::from_secs(10));
        let (mut stdout, mut stderr) = (String::new(), String::new());
        child.stdout.take().unwrap().read_to_string(&mut stdout).unwrap();
        child.stderr.take().unwrap().read_to_string(&mut stderr).unwrap();
        assert_eq!(status.code(), Some(130), "{device}: 128 + SIGINT: {stderr}");
        assert!(!stderr.contains("panicked") && !stderr.contains("VUID"), "{device}: {stderr}");
        let spp = summary_spp(&stdout);
        assert!(spp > 0 && spp.is_multiple_of(64) && spp < asked, "{device}: {spp} spp: {stdout}");
        assert!(stdout.contains(&format!("(interrupted: {asked} asked)")), "{device}: {stdout}");
        let img = rlpt::image::Image::load(&out).unwrap();
        assert_eq!((img.width, img.height), (32, 24), "{device}");
        assert!(img.pixels.iter().any(|p| p[0] > 0.0), "{device}: the image is not black");
        let v = rlpt::image::Image::load(&var).unwrap();
        assert_eq!((v.width, v.height), (32, 24), "{device}");
        let s = rlpt::stats::RenderStats::load(&stats).unwrap();
        assert_eq!(s.frames.last().map(|f| f.spp), Some(spp), "{device}: the statistics end where the image does");
    }
}

#[test]
fn a_second_ctrl_c_quits_at_once_writing_nothing() {
    // On the CPU at 2048x2048 one frame (268 million paths) takes seconds even on
    // many cores: the first Ctrl-C waits for it, the second does not.
    let out = tmp("int-twice.png");
    let mut child = rlpt()
        .args(["render", "scenes/smallpt.toml", "--width", "2048", "--height", "2048", "--device", "cpu", "-o"])
        .arg(&out)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1000));
    interrupt(&child);
    std::thread::sleep(std::time::Duration::from_millis(300));
    assert!(child.try_wait().unwrap().is_none(), "the first Ctrl-C waits for the frame in flight");
    interrupt(&child);
    let status = wait_at_most(&mut child, std::time::Duration::from_secs(3));
    assert_eq!(status.code(), Some(130));
    assert!(!out.exists(), "nothing is written after a second Ctrl-C");
}

#[test]
fn a_render_larger_than_the_device_memory_says_what_to_do() {
    // lavapipe reports 2 GiB and no render within its 128 MiB buffers comes near it:
    // the hook makes it a device of 16 MiB.
    let run = |args: &[&str]| {
        let out = tmp("oom.png");
        let o = rlpt().args(args).arg("-o").arg(&out).env(rlpt::gpu::DEVICE_MEMORY_HOOK, "16").output().unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(1), "{stderr}");
        assert!(!stderr.contains("panicked") && !out.exists(), "{stderr}");
        assert_eq!(stderr.lines().filter(|l| l.starts_with("rlpt: error")).count(), 1, "{stderr}");
        stderr
    };
    let e = run(&["render", "scenes/smallpt.toml", "--width", "1024", "--height", "768", "--spp", "64"]);
    assert!(
        e.contains("the render needs about 49 MB of GPU memory (24 MB for the 1024x768 image, 24 MB to read it back)")
            && e.contains("has 16 MB: render a smaller image (--width, --height), or on the CPU (--device cpu)"),
        "{e}"
    );
    let e = run(&["render", "scenes/door.toml", "--guiding", "sphere", "--width", "64", "--height", "48"]);
    assert!(e.contains("MB for the guiding table") && e.contains("fewer guiding bins (--bins)"), "{e}");
    // The same image fits with fewer bins.
    let out = tmp("oom-fits.png");
    let o = rlpt()
        .args(["render", "scenes/door.toml", "--guiding", "sphere", "--bins", "4x8", "--width", "64", "--height"])
        .args(["48", "--spp", "64", "-o"])
        .arg(&out)
        .env(rlpt::gpu::DEVICE_MEMORY_HOOK, "16")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn a_mesh_larger_than_the_device_memory_is_refused_before_upload() {
    let out = tmp("oom-mesh.png");
    let o = rlpt()
        .args(["render", "scenes/bmw-m6.toml", "--width", "32", "--height", "24", "--spp", "64", "-o"])
        .arg(&out)
        .env(rlpt::gpu::DEVICE_MEMORY_HOOK, "16")
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(!e.contains("panicked") && !out.exists(), "{e}");
    assert!(
        e.contains("MB for the meshes and the BVH") && e.contains("has 16 MB: render a scene with fewer triangles"),
        "{e}"
    );
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

#[test]
fn info_prints_the_meshes_lights_and_bvh_of_a_scene() {
    let o = rlpt().args(["info", "scenes/cornell-box.toml"]).output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The OBJ's 16 quads, fanned into 32 triangles; the lamp's two are the lights.
    assert!(text.contains("cornell-box.obj: 32 triangles, 64 vertices, flat"), "{text}");
    assert!(text.contains("lights: 2 (0 spheres, 0 quads, 2 triangles)"), "{text}");
    assert!(text.contains("BVH: ") && text.contains("32 primitive refs"), "{text}");
    assert!(text.contains("cornell-box/light: Diffuse") && text.contains("emission [17, 12, 4]"), "{text}");
    assert!(text.contains("mapped cornell-box/light: MTL `light`: diffuse") && text.contains("from Ke"), "{text}");
}

#[test]
fn a_lost_device_is_a_sentence_that_says_what_was_kept() {
    let out = tmp("lost.png");
    let stats = tmp("lost.json");
    let o = rlpt()
        .args(["render", "scenes/smallpt.toml", "--width", "32", "--height", "24", "--spp", "6400", "-o"])
        .arg(&out)
        .arg("--stats")
        .arg(&stats)
        .env(rlpt::render::DEVICE_LOST_HOOK, "3")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("panicked") && !stderr.contains("VUID"), "{stderr}");
    assert!(
        stderr.contains("the GPU stopped responding (device lost: vkQueueSubmit returned ERROR_DEVICE_LOST) after 3 frames; what it rendered cannot be read back from a lost device, so nothing was written to")
            && stderr.contains("render again, and if it recurs render a smaller image, update the GPU driver, or render on the CPU (--device cpu)"),
        "{stderr}"
    );
    assert!(!out.exists() && !stats.exists(), "nothing written from a lost device");
    // bench says the same sentence, from the library's error.
    let o = rlpt()
        .args(["bench", "scenes/smallpt.toml", "--width", "16", "--height", "16", "--frames", "4", "--warmup", "0"])
        .env(rlpt::render::DEVICE_LOST_HOOK, "2")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("the GPU stopped responding (device lost") && !stderr.contains("panicked"), "{stderr}");
}

/// `--guide-out` writes the learned field after the image; `--guide-in` starts a
/// render of the same scene from it (another size and the other device too);
/// `--guide-out` without guiding is refused before anything renders.
#[test]
fn a_learned_field_written_by_one_render_starts_another() {
    let (img, field) = (tmp("field.png"), tmp("door.qtab"));
    let (img, field) = (img.to_str().unwrap(), field.to_str().unwrap());
    let door = ["render", "scenes/door.toml", "--spp", "128", "--guiding", "sphere", "-o", img];
    let (ok, err) = run(&[&door[..], &["--width", "24", "--height", "16", "--guide-out", field]].concat());
    assert!(ok, "{err}");
    assert!(std::fs::metadata(field).unwrap().len() > 64, "the field was written");
    std::fs::remove_file(img).unwrap();
    let (ok, err) =
        run(&[&door[..], &["--width", "32", "--height", "20", "--device", "cpu", "--guide-in", field]].concat());
    assert!(ok, "{err}");
    assert!(std::fs::metadata(img).is_ok(), "the image from the loaded field");
    let (ok, err) =
        run(&["render", "scenes/smallpt.toml", "--spp", "64", "--guiding", "sphere", "-o", img, "--guide-in", field]);
    assert!(!ok && err.contains("another scene") && err.contains(field), "{err}");
    let unguided = tmp("unguided.png");
    let (ok, err) =
        run(&["render", "scenes/door.toml", "--spp", "64", "-o", unguided.to_str().unwrap(), "--guide-out", field]);
    assert!(!ok && err.contains("--guide-out") && err.contains("needs guiding on"), "{err}");
    assert!(std::fs::metadata(&unguided).is_err(), "nothing rendered");
}

/// `--sampler sobol` renders on both devices, the summary names the sampler, and
/// its image differs from the independent sampler's of the same seed; an unknown
/// sampler is refused with the ones there are.
#[test]
fn the_sampler_option_renders_and_is_named() {
    let mut images = Vec::new();
    for (sampler, device) in [("sobol", "gpu"), ("sobol", "cpu"), ("independent", "gpu")] {
        let out = tmp(&format!("door-{sampler}-{device}.exr"));
        let o = rlpt()
            .args(["render", "scenes/door.toml", "--width", "16", "--height", "8", "--spp", "64"])
            .args(["--sampler", sampler, "--device", device, "-o"])
            .arg(&out)
            .checked_output();
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(stdout.contains(&format!("{sampler} sampler")), "{stdout}");
        images.push(std::fs::read(&out).unwrap());
    }
    assert_ne!(images[0], images[2], "Sobol and independent images of one seed differ");
    let (ok, err) = run(&["render", "scenes/door.toml", "-o", "x.png", "--sampler", "halton"]);
    assert!(!ok && err.contains("independent") && err.contains("sobol"), "{err}");
}
