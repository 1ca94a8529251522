//! The field's pbrt scenes of `../shared/assets/` (Bitterli's veach-ajar, the BMW
//! M6; other people's data, never copied in), imported and rendered small on the
//! GPU (lavapipe in CI) and the CPU: the two agree within noise, and the image
//! is lit.

mod common;

use common::*;
use rlpt::scene::Scene;

/// Renders `file` on both devices; returns the number of image textures the
/// render read.
fn render_both(file: &str, width: u32, height: u32, spp: u32) -> usize {
    let path = common::files::assets().join(file);
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let o = options(&scene, width, height, spp);
    let textures = rlpt::prepared::PreparedScene::new(&scene, &o).unwrap().textures.len();
    let ctx = gpu();
    let g = render_gpu(&ctx, &scene, &o);
    let c = render_cpu(&scene, &o);
    let lit = |f: &rlpt::film::Film| f.mean().pixels.iter().filter(|p| p.iter().any(|&v| v > 0.0)).count();
    let pixels = (width * height) as usize;
    assert!(lit(&g) * 2 > pixels && lit(&c) * 2 > pixels, "{file}: most pixels are black");
    let z = assert_films_agree(&g, &c, 8, K, &format!("{file}: GPU vs CPU"));
    eprintln!("{file}: worst block |z| {z:.2}");
    textures
}

#[test]
fn veach_ajar_renders_alike_on_the_gpu_and_the_cpu() {
    // With its three image textures (the painting, the table, the door), read on both devices.
    assert_eq!(render_both("veach_ajar_pbrt/scene.pbrt", 32, 16, 1024), 3);
}

#[test]
fn the_bmw_renders_alike_on_the_gpu_and_the_cpu() {
    assert_eq!(render_both("bmw_m6_pbrt/bmw-m6.pbrt", 32, 24, 512), 0);
}
