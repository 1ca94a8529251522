//! Image textures (docs/SCENE_FORMAT.md, "Textures"): the lookup against
//! hand-computed values, a textured quad in a furnace (its image's mean is the
//! texture's mean albedo times the sky), the GPU against the CPU twin, UVs read
//! from OBJ, PLY, glTF and pbrt files written here, and the errors.

mod common;

use common::*;
use glam::Vec2;
use rlpt::math::texture::texture_lookup;
use rlpt::prepared::PreparedScene;
use rlpt::scene::Scene;
use std::path::{Path, PathBuf};

/// A fresh directory for one test's files.
fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rlpt-textures-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes an RGBA8 PNG of `w` x `h` texels, rows from the top.
fn png(path: &Path, w: u32, h: u32, texel: impl Fn(u32, u32) -> [u8; 4]) {
    let img = image::RgbaImage::from_fn(w, h, |x, y| image::Rgba(texel(x, y)));
    img.save(path).unwrap();
}

/// The TOML of a camera one unit in front of the quad [-1, 1]^2 (z = 0) with a
/// 90 degree view, so that the image covers the quad exactly: u along +x (to
/// the right), v along +y (up). The sky is uniform radiance 1, and a diffuse
/// quad of albedo a there reflects a: every bounce escapes.
fn quad_scene(material: &str) -> String {
    format!(
        r#"
[camera]
position = [0.0, 0.0, 1.0]
look_at = [0.0, 0.0, 0.0]
vfov = 90.0

[render]
width = 32
height = 32
spp = 64
max_bounces = 4

[environment]
radiance = [1.0, 1.0, 1.0]

{material}

[[quad]]
origin = [-1.0, -1.0, 0.0]
edge_u = [2.0, 0.0, 0.0]
edge_v = [0.0, 2.0, 0.0]
material = "tex"
"#
    )
}

fn write_scene(d: &Path, text: &str) -> PathBuf {
    let p = d.join("scene.toml");
    std::fs::write(&p, text).unwrap();
    p
}

fn srgb(b: u8) -> f32 {
    let c = b as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[test]
fn bilinear_lookup_and_srgb_decode_match_hand_computed_values() {
    let d = dir("lookup");
    // 2 x 2 texels: (0,0) top-left 255 red, (1,0) 0, (0,1) 128, (1,1) 64 (bottom row).
    let grey = [[255u8, 0], [128, 64]];
    png(&d.join("t.png"), 2, 2, |x, y| {
        let g = grey[y as usize][x as usize];
        [g, g, g, 255]
    });
    let scene = Scene::load(write_scene(
        &d,
        &quad_scene(
            "[[material]]\nname = \"tex\"\ntype = \"diffuse\"\nalbedo = [1.0, 1.0, 1.0]\nalbedo_texture = \"t.png\"",
        ),
    ))
    .unwrap();
    assert_eq!(scene.textures.len(), 1);
    let p = PreparedScene::new(&scene, &options(&scene, 8, 8, 64)).unwrap();
    let at = |u: f32, v: f32| texture_lookup(&p, 0, Vec2::new(u, v)).x;
    let close = |a: f32, b: f32, what: &str| assert!((a - b).abs() < 2e-6, "{what}: {a} vs {b}");
    // Texel centres: top-left texel at (0.25, 0.75) (v up), bottom-right at (0.75, 0.25).
    close(at(0.25, 0.75), 1.0, "top-left centre");
    close(at(0.75, 0.75), 0.0, "top-right centre");
    close(at(0.25, 0.25), srgb(128), "bottom-left centre");
    close(at(0.75, 0.25), srgb(64), "bottom-right centre");
    // Halfway between the two top texels: their linear mean (decoded, then filtered).
    close(at(0.5, 0.75), 0.5, "between the top texels");
    // The middle of all four.
    close(at(0.5, 0.5), (1.0 + srgb(128) + srgb(64)) / 4.0, "centre");
    // Repeat wrap: u = 0 lies halfway between the last column and the first.
    close(at(0.0, 0.75), 0.5, "u = 0 wraps");
    close(at(1.25, -0.25), 1.0, "a period away");
    // A quarter of the way from the top-left centre towards the bottom-left one.
    close(at(0.25, 0.625), 0.75 * 1.0 + 0.25 * srgb(128), "a quarter down");
    // Not finite: taken as 0 (halfway between columns and rows, wrapped).
    assert!(at(f32::NAN, f32::INFINITY).is_finite());
}

#[test]
fn srgb_decode_matches_the_standard() {
    use rlpt::scene::texture::srgb_to_linear;
    assert_eq!(srgb_to_linear(0.0), 0.0);
    assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
    // Below the knee: linear segment c / 12.92.
    assert!((srgb_to_linear(0.04) - 0.04 / 12.92).abs() < 1e-9);
    // 0.5 encoded is 0.21404 linear (IEC 61966-2-1).
    assert!((srgb_to_linear(0.5) - 0.214041).abs() < 1e-5);
}

/// Deviations allowed between two renders' block means (as tests/env_light.rs).
const K: f64 = 5.0;

/// A checker of two colours, `n` x `n` texels.
fn checker(path: &Path, n: u32, a: [u8; 4], b: [u8; 4]) {
    png(path, n, n, |x, y| if (x + y) % 2 == 0 { a } else { b });
}

#[test]
fn checker_quad_in_a_furnace_renders_its_mean_albedo_alike_on_gpu_and_cpu() {
    let d = dir("furnace");
    let (a, b) = ([255u8, 200, 64, 255], [32u8, 128, 255, 255]);
    checker(&d.join("checker.png"), 8, a, b);
    let scene = Scene::load(write_scene(
        &d,
        &quad_scene(
            "[[material]]\nname = \"tex\"\ntype = \"diffuse\"\nalbedo = [0.8, 0.8, 0.8]\nalbedo_texture = \"checker.png\"",
        ),
    ))
    .unwrap();
    let opts = options(&scene, 32, 32, 256);
    let ctx = gpu();
    let g = render_gpu(&ctx, &scene, &opts);
    let c = render_cpu(&scene, &opts);
    // Bilinear filtering keeps a period's mean: the image (which covers the quad
    // exactly) has the texels' mean linear albedo, times 0.8, times the sky's 1.
    let want = (0..3).map(|k| 0.8 * (srgb(a[k]) + srgb(b[k])) as f64 / 2.0).sum::<f64>() / 3.0;
    for (film, what) in [(&g, "GPU"), (&c, "CPU")] {
        let (mean, var, _) = region_stats(film, |_, _| true);
        let z = (mean - want) / var.sqrt();
        assert!(z.abs() < K, "{what}: image mean {mean} vs the mean albedo {want} ({z:.2} sigma)");
    }
    assert_films_agree(&g, &c, 4, K, "checker quad, GPU vs CPU");
    // Upright: the top-left texel (colour a) is at the image's top left. At the
    // centre of texel (0, 0), pixels (0..2, 0..2), the albedo is a's, less the
    // blur of a pixel's footprint (a quarter texel) towards b.
    let m = g.mean();
    let px = m.pixels[(m.width + 1) as usize];
    for k in 0..3 {
        let (ta, tb) = (0.8 * srgb(a[k]), 0.8 * srgb(b[k]));
        assert!((px[k] - ta).abs() < 0.3 * (ta - tb).abs(), "channel {k}: {} vs texel a {ta} (b {tb})", px[k]);
    }
}

#[test]
fn a_scene_without_textures_has_no_texture_data_and_no_texture_code() {
    let scene = scene("furnace-open.toml");
    let p = PreparedScene::new(&scene, &options(&scene, 8, 8, 64)).unwrap();
    assert!(p.textures.is_empty() && p.texels.is_empty() && p.triangle_uvs.is_empty());
    assert!(p.materials.iter().all(|m| m.albedo_texture == 0 && m.roughness_texture == 0));
    let spec = p.geometry_specialization();
    assert_eq!(spec[rlpt::prepared::geometry_index(rlpt::shared::SPEC_TEXTURES)], 0);
}
