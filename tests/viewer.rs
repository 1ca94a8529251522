//! `rlpt view` in a real window: under a virtual X server (Xvfb) that the tests
//! start themselves, on whatever Vulkan device is present (lavapipe in CI), with
//! the validation layer on.

mod common;

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
    let x = Xvfb::start();
    let out = Command::new(env!("CARGO_BIN_EXE_rlpt"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .arg("view")
        .args(args)
        .env("DISPLAY", &x.display)
        .env_remove("WAYLAND_DISPLAY")
        .env("RLPT_VALIDATION", "1")
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .expect("rlpt runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    // Each message is printed as "vulkan validation (...)"; those at the context's
    // destruction also end the run with "the Vulkan validation layer reported N problem(s)".
    assert!(
        !stderr.contains("vulkan validation") && !stderr.contains("validation layer reported"),
        "the validation layer spoke:\n{stderr}"
    );
    out
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rlpt-viewer-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
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
    let rlpt = || {
        let mut c = Command::new(env!("CARGO_BIN_EXE_rlpt"));
        c.current_dir(env!("CARGO_MANIFEST_DIR")).env("XDG_RUNTIME_DIR", std::env::temp_dir());
        c
    };
    // A directory named like a PNG: refused before the window opens, as the CLI's outputs are.
    let dir = std::env::temp_dir().join("rlpt-view-shot-dir.png");
    std::fs::create_dir_all(&dir).unwrap();
    for (args, expect) in [
        (vec!["--frames", "2", "--screenshot", "x.jpg"], "must end in .png"),
        (vec!["--frames", "1", "--screenshot", dir.to_str().unwrap()], "is a directory; give a file name"),
        (vec!["--frames", "2"], "--frames and --screenshot go together"),
        (vec!["--device", "cpu"], "renders on the GPU"),
        (vec!["--resize", "0x10"], "not a size"),
        (vec!["--frames", "1", "--screenshot", "/nonexistent-dir/x.png"], "does not exist"),
    ] {
        let o = rlpt().arg("view").arg("scenes/smallpt.toml").args(&args).output().unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} was accepted");
        assert!(stderr.contains(expect), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
    // No display at all: a sentence, not a crash.
    let o = rlpt()
        .args(["view", "scenes/smallpt.toml"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
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
    let render = Command::new(env!("CARGO_BIN_EXE_rlpt"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["render", "scenes/door.toml", "--width", "24", "--height", "16", "--spp", "128"])
        .args(["--guiding", "sphere", "--device", "cpu", "-o"])
        .arg(&img)
        .arg("--guide-out")
        .arg(&field)
        .output()
        .unwrap();
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
