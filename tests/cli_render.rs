//! Rendering from the command line as a user meets it: images and the summary,
//! devices, a missing driver, Ctrl-C, device memory, a lost device, `info`, the
//! sampler and a learned field carried from one render to the next.

mod common;

use common::cli::*;
use std::process::Command;

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
        if spp == 64 {
            // A loaded machine may finish one frame only: no variance from one, said so.
            assert!(stderr.contains("the render stopped after 1 frame(s)") && !var.exists(), "{device}: {stderr}");
        } else {
            let v = rlpt::image::Image::load(&var).unwrap();
            assert_eq!((v.width, v.height), (32, 24), "{device}");
        }
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
        e.contains("the render needs about 61 MB of GPU memory (36 MB for the 1024x768 image, 24 MB to read it back)")
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
fn info_prints_the_meshes_lights_and_bvh_of_a_scene() {
    let o = rlpt().args(["info", "scenes/cornell-box.toml"]).output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The OBJ's 16 quads, fanned into 32 triangles; the lamp's two are the lights.
    assert!(text.contains("cornell-box.obj: 32 triangles, 64 vertices, flat"), "{text}");
    assert!(text.contains("lights: 2 (0 spheres, 0 quads, 2 triangles, 0 distant, 0 point, 0 spot)"), "{text}");
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
