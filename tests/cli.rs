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
