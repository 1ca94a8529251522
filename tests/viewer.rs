//! `rlpt view` in a real window: under a virtual X server (Xvfb) that the tests
//! start themselves, on whatever Vulkan device is present (lavapipe in CI), with
//! the validation layer on.

mod common;

use common::cli::{rlpt, tmp, Checked};
use common::*;
use rlpt::image::Image;
use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Output, Stdio};

/// A virtual X server for one test, stopped when dropped. Xvfb picks a free
/// display number itself (`-displayfd`) and says it on its stdout once ready.
struct Xvfb {
    display: String,
    child: Child,
}

impl Xvfb {
    fn start() -> Xvfb {
        let mut child = Command::new("Xvfb")
            .args(["-displayfd", "1", "-screen", "0", "1024x768x24", "-nolisten", "tcp"])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("Xvfb starts (apt install xvfb): the viewer tests need a virtual X server");
        let mut line = String::new();
        let stdout = child.stdout.take().unwrap();
        BufReader::new(stdout).read_line(&mut line).expect("Xvfb reports its display");
        let n: u32 = line.trim().parse().unwrap_or_else(|_| panic!("Xvfb did not start: it said {line:?}"));
        Xvfb { display: format!(":{n}"), child }
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Runs `rlpt view ARGS` on the virtual display with validation on.
fn view(args: &[&str]) -> Output {
    view_with(args, &[])
}

/// `view` with environment variables `env` set (test hooks).
fn view_with(args: &[&str], env: &[(&str, &str)]) -> Output {
    let x = Xvfb::start();
    rlpt()
        .arg("view")
        .args(args)
        .envs(env.iter().copied())
        .env("DISPLAY", &x.display)
        .env_remove("WAYLAND_DISPLAY")
        .checked_output()
}

/// The PNG bytes the viewer would show for linear value `l` (clamped, sRGB, 8 bits).
fn srgb8(l: f32) -> i32 {
    let c = if l.is_nan() { 0.0 } else { l.clamp(0.0, 1.0) };
    (rlpt::image::srgb_encode(c) * 255.0 + 0.5).floor() as i32
}

#[test]
fn the_screenshot_is_the_scene() {
    let (w, h, frames) = (48u32, 36u32, 8u32);
    let shot = tmp("seed-exp1.png");
    let out = view(&[
        "scenes/seed-exp1.toml",
        "--width",
        &w.to_string(),
        "--height",
        &h.to_string(),
        "--seed",
        "7",
        "--frames",
        &frames.to_string(),
        "--screenshot",
        shot.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "rlpt view failed:\n{stderr}");
    assert!(stderr.contains("render in a 48x36 window"), "the window opened at the render size: {stderr}");
    let png = Image::load(&shot).expect("the screenshot PNG");
    let exr = Image::load(&shot.with_extension("exr")).expect("the screenshot EXR");
    assert_eq!((png.width, png.height, exr.width, exr.height), (w, h, w, h));

    // What the window shows is the accumulation, encoded as `rlpt render` encodes PNGs
    // (the GPU's pow may round the last bit differently from the host's).
    let png_bytes = image::open(&shot).unwrap().into_rgb8();
    let mut worst = 0;
    for (i, p) in png_bytes.pixels().enumerate() {
        for c in 0..3 {
            worst = worst.max((p.0[c] as i32 - srgb8(exr.pixels[i][c])).abs());
        }
    }
    assert!(worst <= 1, "the shown bytes differ from the sRGB encoding of the image by up to {worst} steps");

    // And the image agrees, block by block within noise, with a headless render of the
    // same scene, size and sample count (another seed: independent noise).
    let ctx = gpu();
    let scene = scene("seed-exp1.toml");
    let opts = options(&scene, w, h, frames * 64);
    let headless = render_gpu(&ctx, &scene, &opts);
    let (mean, var) = (headless.mean(), headless.variance_of_mean().unwrap());
    // The viewer's render has the headless one's variance (same estimator and spp).
    let worst_z = assert_means_agree(
        &exr,
        &mean,
        |i, c| 2.0 * var.pixels[i][c] as f64,
        |i, c| 2.0 * rounding_bound(&headless, mean.pixels[i][c]),
        6,
        5.0,
        "seed-exp1: viewer vs headless",
    );
    eprintln!("viewer vs headless: worst block {worst_z:.2} sigma; shown bytes within {worst} step(s)");
}

#[test]
fn a_resize_recreates_the_swapchain_and_the_render_goes_on() {
    let shot = tmp("resized.png");
    let out = view(&[
        "scenes/smallpt.toml",
        "--width",
        "40",
        "--height",
        "30",
        "--frames",
        "3",
        "--resize",
        "130x50",
        "--screenshot",
        shot.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "rlpt view failed:\n{stderr}");
    assert!(stderr.contains("swapchain recreated at 130x50"), "the swapchain followed the window: {stderr}");
    let img = Image::load(&shot).unwrap();
    assert_eq!((img.width, img.height), (40, 30), "the render keeps its size; the window scales it");
    let mean: f32 = img.pixels.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / (3.0 * img.pixels.len() as f32);
    assert!(mean > 0.05, "the image is not black after the resize (mean {mean})");
}

#[test]
fn guided_view_runs_clean() {
    let shot = tmp("door.png");
    let out = view(&[
        "scenes/door.toml",
        "--width",
        "36",
        "--height",
        "24",
        "--guiding",
        "sphere",
        "--frames",
        "4",
        "--screenshot",
        shot.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "rlpt view failed:\n{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("256 spp, guiding sphere, NEE on"), "{stdout}");
}

#[test]
fn bad_view_arguments_are_sentences() {
    // A directory named like a PNG: refused before the window opens, as the CLI's outputs are.
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("rlpt-view-shot-dir.png");
    std::fs::create_dir_all(&dir).unwrap();
    for (args, expect) in [
        (vec!["--frames", "2", "--screenshot", "x.jpg"], "must end in .png"),
        (vec!["--frames", "1", "--screenshot", dir.to_str().unwrap()], "is a directory; give a file name"),
        (vec!["--frames", "2"], "--frames and --screenshot go together"),
        (vec!["--device", "cpu"], "renders on the GPU"),
        (vec!["--resize", "0x10"], "not a size"),
        (vec!["--frames", "1", "--screenshot", "/nonexistent-dir/x.png"], "does not exist"),
        (vec!["--gpus", "0,0"], "device 0 is named twice"),
        (vec!["--gpus", "4096"], "there is no device 4096"),
        (vec!["--gpus", "0,x"], "`x` is not a device index"),
        (vec!["--gpu", "0", "--gpus", "0"], "both pick GPUs"),
    ] {
        let o = rlpt().arg("view").arg("scenes/smallpt.toml").args(&args).checked_output();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} was accepted");
        assert!(stderr.contains(expect), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
    // Several GPUs trace every frame guided: the race of kernels is refused, before the window opens.
    let o = rlpt()
        .args(["view", "scenes/door.toml", "--gpus", "0,0", "--guiding", "sphere", "--unguided-frames", "auto"])
        .env("RLPT_TEST_DUPLICATE_GPUS", "1")
        .checked_output();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && stderr.contains("chooses each frame's kernel on one GPU"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    // No display at all: a sentence, not a crash.
    let o = rlpt()
        .args(["view", "scenes/smallpt.toml"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .checked_output();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(stderr.contains("cannot open a window") && stderr.contains("DISPLAY"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// `view --guide-in` starts the viewer's guided mode from a field that `render
/// --guide-out` wrote; a field of another scene is refused before the window
/// opens.
#[test]
fn the_viewer_starts_from_a_saved_field() {
    let (field, img) = (tmp("door.qtab"), tmp("field-render.png"));
    let render = rlpt()
        .args(["render", "scenes/door.toml", "--width", "24", "--height", "16", "--spp", "128"])
        .args(["--guiding", "sphere", "--device", "cpu", "-o"])
        .arg(&img)
        .arg("--guide-out")
        .arg(&field)
        .checked_output();
    assert!(render.status.success(), "{}", String::from_utf8_lossy(&render.stderr));
    let shot = tmp("field-view.png");
    let f = field.to_str().unwrap();
    let o = view(
        &["scenes/door.toml", "--width", "32", "--height", "24", "--guiding", "sphere"]
            .iter()
            .copied()
            .chain(["--frames", "2", "--guide-in", f, "--screenshot", shot.to_str().unwrap()])
            .collect::<Vec<_>>(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains(&format!("guiding sphere: starts from the learned field {f}")), "{stdout}");
    assert!(Image::load(&shot).is_ok(), "the screenshot of the guided view");
    let o = view(&["scenes/smallpt.toml", "--frames", "1", "--guide-in", f]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && stderr.contains("another scene") && stderr.contains(f), "{stderr}");
}

/// `view --gpus 0,0` (two contexts on the test machine's one device, which stand
/// for two GPUs: the first presents, both render): frame k draws the same random
/// numbers on either context, so the window shows what the one-GPU viewer shows
/// for the same seed, to the rounding of the order the frames' sums are added in;
/// the bytes shown to one step of the PNG's encoding.
#[test]
fn two_gpus_show_what_one_shows() {
    let (w, h, frames) = (48u32, 36u32, 8u32);
    let args = |shot: &PathBuf| -> Vec<String> {
        ["scenes/seed-exp1.toml", "--width", "48", "--height", "36", "--seed", "7", "--frames", "8", "--screenshot"]
            .iter()
            .map(|a| a.to_string())
            .chain([shot.to_str().unwrap().to_string()])
            .collect()
    };
    let (one, two) = (tmp("one-gpu.png"), tmp("two-gpus.png"));
    let a = args(&one);
    let out = view(&a.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(out.status.success(), "one GPU:\n{}", String::from_utf8_lossy(&out.stderr));
    let mut b = args(&two);
    b.extend(["--gpus".to_string(), "0,0".to_string()]);
    let out = view_with(&b.iter().map(String::as_str).collect::<Vec<_>>(), &[("RLPT_TEST_DUPLICATE_GPUS", "1")]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "two GPUs:\n{stderr}");
    assert!(stderr.contains("rendering on 2 GPUs"), "both contexts render: {stderr}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains(&format!("({} spp,", frames * 64)), "the screenshot holds every frame: {stdout}");

    let (ea, eb) = (Image::load(&one.with_extension("exr")).unwrap(), Image::load(&two.with_extension("exr")).unwrap());
    assert_eq!((ea.width, ea.height, eb.width, eb.height), (w, h, w, h));
    // Sums of 8 nonnegative frame sums added in another order, each divided once.
    let u = f32::EPSILON as f64 / 2.0;
    let bound = (2.0 * frames as f64 + 2.0) * u;
    for (i, (p, q)) in ea.pixels.iter().zip(&eb.pixels).enumerate() {
        for c in 0..3 {
            let (x, y) = (p[c] as f64, q[c] as f64);
            assert!((x - y).abs() <= bound * x.abs().max(y.abs()), "pixel {i} channel {c}: {x} vs {y}");
        }
    }
    let (pa, pb) = (image::open(&one).unwrap().into_rgb8(), image::open(&two).unwrap().into_rgb8());
    let worst = pa.pixels().zip(pb.pixels()).flat_map(|(p, q)| (0..3).map(|c| (p.0[c] as i32 - q.0[c] as i32).abs()));
    assert!(worst.max().unwrap() <= 1, "the bytes shown differ by more than one step");
}

/// Guided, on two contexts that learn one table (their sums added at each
/// learning pass), the viewer's image agrees within noise with the one-GPU
/// viewer's of another seed; the noise is that of a headless guided render of
/// the same frames (the Cornell box: the door's fireflies make 12 frames' spread
/// a poor measure of its noise, for one GPU against one as for two).
#[test]
fn a_guided_view_on_two_gpus_agrees_with_one() {
    let (w, h, frames) = (32u32, 24u32, 12u32);
    let run = |shot: &PathBuf, seed: &str, extra: &[&str], env: &[(&str, &str)]| {
        let mut args = vec!["scenes/cornell-box.toml", "--width", "32", "--height", "24", "--guiding", "sphere"];
        args.extend(["--seed", seed, "--frames", "12", "--screenshot", shot.to_str().unwrap()]);
        args.extend(extra);
        let out = view_with(&args, env);
        assert!(out.status.success(), "{extra:?}:\n{}", String::from_utf8_lossy(&out.stderr));
        Image::load(&shot.with_extension("exr")).unwrap()
    };
    let one = run(&tmp("guided-one.png"), "3", &[], &[]);
    let two = run(&tmp("guided-two.png"), "7", &["--gpus", "0,0"], &[("RLPT_TEST_DUPLICATE_GPUS", "1")]);
    let ctx = gpu();
    let scene = scene("cornell-box.toml");
    let mut opts = options(&scene, w, h, frames * 64);
    opts.guiding = rlpt::guide::GuidingMode::Sphere;
    let headless = render_gpu(&ctx, &scene, &opts);
    let var = headless.variance_of_mean().unwrap();
    let mean = headless.mean();
    let z = assert_means_agree(
        &two,
        &one,
        |i, c| 2.0 * var.pixels[i][c] as f64,
        |i, c| 2.0 * rounding_bound(&headless, mean.pixels[i][c]),
        4,
        K,
        "guided Cornell box: two GPUs against one",
    );
    eprintln!("guided view, two GPUs against one: worst block {z:.2} sigma");
}
