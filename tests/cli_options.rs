//! What the command line refuses, names or warns about, before rendering where it
//! can: the guiding settings, counts beyond 32 bits, outputs, options that change
//! nothing, scenes that cannot show light, a guiding box away from the scene.

mod common;

use common::cli::*;

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
/// default; `--spp` counts the image's own samples (their mean is one more frame
/// of it), and the stats give each frame the samples of the image it would write.
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
    assert!(!label.contains("adaptive-directions"), "{label}");
    let s = read(&["--guiding", "sphere", "--adaptive-directions", "on"]);
    assert!(s["label"].as_str().unwrap().contains(" adaptive-directions=on"), "{s}");
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
    let (ok, err) = with(&["--adaptive-directions", "on"]);
    assert!(ok && err.contains("note: --adaptive-directions is a setting of learned guiding"), "{err}");
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
    assert!(
        ok && err.contains("no sphere, quad, mesh triangle or delta light emits light and the environment is black"),
        "{err}"
    );
    let (ok, err) = render(&inside);
    assert!(ok && err.contains("every pixel of") && err.contains("is black"), "{err}");
    assert!(!err.contains("emits light and the environment is black"), "{err}");
    let (ok, err) = render(&lit);
    assert!(ok && !err.contains("warning"), "{err}");
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
