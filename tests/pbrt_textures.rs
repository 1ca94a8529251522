//! pbrt's procedural textures (`checkerboard`, `scale`, `mix` over constants
//! and images) and a conductor's `reflectance` image, as docs/pbrt.md maps them:
//! the CPU's lookup against hand-computed values, furnace renders against the
//! albedo each region must have, the GPU against the CPU twin, and the notes
//! and refusals of what is not evaluated.

mod common;

use common::*;
use glam::{Vec2, Vec3};
use rlpt::math::texture::colour_texture;
use rlpt::prepared::PreparedScene;
use rlpt::scene::procedural::Combine;
use rlpt::scene::{Material, Scene};
use std::path::PathBuf;

/// A fresh directory for one test's files.
fn dir(name: &str) -> PathBuf {
    let d = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("rlpt-pbrt-textures-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes an RGBA8 PNG of `w` x `h` texels, rows from the top.
fn png(d: &std::path::Path, name: &str, w: u32, h: u32, texel: impl Fn(u32, u32) -> [u8; 4]) {
    image::RgbaImage::from_fn(w, h, |x, y| image::Rgba(texel(x, y))).save(d.join(name)).unwrap();
}

fn srgb(b: u8) -> f32 {
    rlpt::scene::texture::srgb_to_linear(b as f32 / 255.0)
}

fn load(d: &std::path::Path, text: &str) -> Scene {
    let p = d.join("scene.pbrt");
    std::fs::write(&p, text).unwrap();
    Scene::load(&p).unwrap_or_else(|e| panic!("{e}"))
}

fn material<'a>(s: &'a Scene, name: &str) -> &'a Material {
    s.materials.iter().find(|m| m.name == name).unwrap_or_else(|| panic!("no material {name}"))
}

/// A furnace (uniform sky of 1) with the camera one unit in front of the quad
/// [-1, 1]^2 (UVs (0, 0) at (-1, -1), u along +x, v along +y) and a 90 degree
/// view: the image covers the quad exactly, pixel column i at u = (i + 0.5) / w,
/// row j (from the top) at v = 1 - (j + 0.5) / h; each pixel is its albedo.
fn furnace_quad(textures: &str, material: &str) -> String {
    format!(
        "LookAt 0 0 -1  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 90\n\
         Film \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 32\nWorldBegin\n\
         LightSource \"infinite\" \"rgb L\" [1 1 1]\n{textures}\n{material}\n\
         Shape \"trianglemesh\" \"point3 P\" [-1 -1 0 1 -1 0 1 1 0 -1 1 0] \
         \"integer indices\" [0 2 1 0 3 2] \"point2 uv\" [0 0 1 0 1 1 0 1]\n"
    )
}

/// Asserts the mean of the pixels `select` picks lies within K sigma of `want`.
fn assert_region(film: &rlpt::film::Film, want: f64, what: &str, select: impl Fn(u32, u32) -> bool) {
    let (mean, var, _) = region_stats(film, select);
    let z = (mean - want) / var.sqrt();
    assert!(z.abs() < K, "{what}: mean {mean} vs {want} ({z:.2} sigma)");
}

#[test]
fn procedural_textures_evaluate_as_pbrt_defines_them() {
    let d = dir("eval");
    // A 2x1 image: texel 0 red-ish, texel 1 blue-ish (sRGB); a grey one; a float ramp.
    let (a, b) = ([200u8, 40, 10, 255], [10u8, 60, 220, 255]);
    png(&d, "two.png", 2, 1, |x, _| if x == 0 { a } else { b });
    png(&d, "grey.png", 1, 1, |_, _| [128, 128, 128, 255]);
    png(&d, "amount.png", 2, 1, |x, _| if x == 0 { [0, 0, 0, 255] } else { [255, 255, 255, 255] });
    let pbrt = "LookAt 0 0 -1  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\n\
        Texture \"img\" \"spectrum\" \"imagemap\" \"string filename\" \"two.png\"\n\
        Texture \"grey\" \"spectrum\" \"imagemap\" \"string filename\" \"grey.png\"\n\
        Texture \"amt\" \"float\" \"imagemap\" \"string filename\" \"amount.png\" \"string encoding\" \"linear\"\n\
        Texture \"check\" \"spectrum\" \"checkerboard\" \"float uscale\" 4 \"float vscale\" 2 \"float udelta\" 0.5 \
        \"rgb tex1\" [0.8 0.5 0.2] \"texture tex2\" \"img\"\n\
        Texture \"v4scale\" \"spectrum\" \"scale\" \"texture tex\" \"img\" \"texture scale\" \"amt\"\n\
        Texture \"v3scale\" \"color\" \"scale\" \"texture tex1\" \"img\" \"texture tex2\" \"grey\"\n\
        Texture \"mixed\" \"spectrum\" \"mix\" \"rgb tex1\" [0.9 0.1 0.1] \"texture tex2\" \"img\" \"texture amount\" \"amt\"\n\
        Texture \"folded\" \"spectrum\" \"scale\" \"texture tex\" \"grey\" \"float scale\" 0.5\n\
        Texture \"const\" \"spectrum\" \"mix\" \"rgb tex1\" [1 0 0] \"rgb tex2\" [0 0 1] \"float amount\" 0.25\n\
        MakeNamedMaterial \"check\" \"string type\" \"diffuse\" \"texture reflectance\" \"check\"\n\
        MakeNamedMaterial \"v4scale\" \"string type\" \"diffuse\" \"texture reflectance\" \"v4scale\"\n\
        MakeNamedMaterial \"v3scale\" \"string type\" \"matte\" \"texture Kd\" \"v3scale\"\n\
        MakeNamedMaterial \"mixed\" \"string type\" \"coateddiffuse\" \"texture reflectance\" \"mixed\"\n\
        MakeNamedMaterial \"folded\" \"string type\" \"diffuse\" \"texture reflectance\" \"folded\"\n\
        MakeNamedMaterial \"const\" \"string type\" \"diffuse\" \"texture reflectance\" \"const\"\n\
        MakeNamedMaterial \"wood\" \"string type\" \"diffuse\" \"texture reflectance\" \"img\"\n\
        MakeNamedMaterial \"dark\" \"string type\" \"diffuse\" \"rgb reflectance\" [0.1 0.2 0.3]\n\
        MakeNamedMaterial \"blend\" \"string type\" \"mix\" \"string materials\" [\"wood\" \"dark\"] \"float amount\" 0.25\n\
        ";
    let triangle = "Shape \"trianglemesh\" \"point3 P\" [-1 -1 0 1 -1 0 1 1 0] \"integer indices\" [0 1 2] \
                    \"point2 uv\" [0 0 1 0 1 1]\n";
    let mut pbrt = pbrt.to_string();
    for m in ["check", "v4scale", "v3scale", "mixed", "folded", "const", "blend"] {
        pbrt += &format!("NamedMaterial \"{m}\"\n{triangle}");
    }
    let s = load(&d, &pbrt);
    // Constant operands fold as pbrt folds them: into a constant, or an image's scale.
    assert!(material(&s, "const").albedo_procedural.is_none() && material(&s, "const").albedo_texture.is_none());
    assert!((material(&s, "const").albedo - Vec3::new(0.75, 0.0, 0.25)).abs().max_element() < 1e-6);
    let folded = material(&s, "folded");
    assert!(folded.albedo_procedural.is_none() && folded.albedo_texture.is_some() && folded.albedo == Vec3::splat(0.5));
    let check = material(&s, "check").albedo_procedural.as_ref().expect("a procedural checkerboard");
    assert_eq!(check.combine, Combine::Checker([4.0, 2.0, 0.5, 0.0]));
    let p = PreparedScene::new(&s, &options(&s, 8, 8, 64)).unwrap();
    let index = |name: &str| {
        let i = s.materials.iter().position(|m| m.name == name).unwrap();
        p.materials[i].albedo_texture - 1
    };
    let eval = |name: &str, u: f32, v: f32| colour_texture(&p, index(name), Vec2::new(u, v));
    let lin = |t: [u8; 4]| Vec3::new(srgb(t[0]), srgb(t[1]), srgb(t[2]));
    let close = |got: Vec3, want: Vec3, what: &str| {
        assert!((got - want).abs().max_element() < 2e-3, "{what}: {got} vs {want}");
    };
    // The 2x1 image at u = 0.25 (texel 0's centre) and 0.75 (texel 1's).
    let (ta, tb) = (lin(a), lin(b));
    close(eval("v3scale", 0.25, 0.5), ta * srgb(128), "v3 scale: tex1 times tex2 at texel 0");
    close(eval("v3scale", 0.75, 0.5), tb * srgb(128), "v3 scale at texel 1");
    // v4 scale by a float image: amount 0 at u = 0.25, 1 at 0.75, 0.5 between.
    close(eval("v4scale", 0.25, 0.5), Vec3::ZERO, "v4 scale by 0");
    close(eval("v4scale", 0.75, 0.5), tb, "v4 scale by 1");
    close(eval("v4scale", 0.5, 0.5), 0.5 * (0.5 * (ta + tb)), "v4 scale by 0.5, image half-way");
    // Mix: (1 - amount) tex1 + amount tex2.
    close(eval("mixed", 0.25, 0.5), Vec3::new(0.9, 0.1, 0.1), "mix at amount 0");
    close(eval("mixed", 0.75, 0.5), tb, "mix at amount 1");
    close(eval("mixed", 0.5, 0.5), 0.5 * Vec3::new(0.9, 0.1, 0.1) + 0.5 * (0.5 * (ta + tb)), "mix at 0.5");
    // A mix material of two diffuse ones, one textured: their albedos blended per hit.
    close(eval("blend", 0.25, 0.5), 0.75 * ta + 0.25 * Vec3::new(0.1, 0.2, 0.3), "mix material at texel 0");
    // Checkerboard: s = 4u + 0.5, t = 2v; tex1 where floor(s) + floor(t) is even.
    let tex1 = Vec3::new(0.8, 0.5, 0.2);
    close(eval("check", 0.05, 0.1), tex1, "s 0.7, t 0.2: even");
    close(eval("check", 0.2, 0.1), eval("v3scale", 0.2, 0.1) / srgb(128), "s 1.3, t 0.2: odd, the image");
    close(eval("check", 0.2, 0.6), tex1, "s 1.3, t 1.2: even");
    close(eval("check", 0.05, 0.6), eval("v3scale", 0.05, 0.6) / srgb(128), "s 0.7, t 1.2: odd");
    close(eval("check", -0.2, 0.1), eval("v3scale", -0.2, 0.1) / srgb(128), "s -0.3: floor -1, odd");
}

#[test]
fn a_checkerboard_and_a_mix_in_a_furnace_render_their_albedos_alike_on_gpu_and_cpu() {
    let d = dir("furnace");
    png(&d, "grey.png", 1, 1, |_, _| [128, 128, 128, 255]);
    png(&d, "amount.png", 2, 1, |x, _| if x == 0 { [0, 0, 0, 255] } else { [255, 255, 255, 255] });
    let (w, h) = (32u32, 32u32);
    let ctx = gpu();
    // Checkerboard: tex1 a grey constant, tex2 the grey image at half scale (a
    // `scale` texture, folded). s = 4u + 1, t = 2v: pixel (i, j) lies in one square
    // whole, floor(s) = i / 8 + 1, floor(t) = 1 - j / 16: tex1 where i / 8 + j / 16 is even.
    let check = load(
        &d,
        &furnace_quad(
            "Texture \"g\" \"spectrum\" \"imagemap\" \"string filename\" \"grey.png\"\n\
             Texture \"half\" \"spectrum\" \"scale\" \"texture tex\" \"g\" \"float scale\" 0.5\n\
             Texture \"c\" \"spectrum\" \"checkerboard\" \"float uscale\" 4 \"float vscale\" 2 \"float udelta\" 1 \
             \"rgb tex1\" [0.7 0.7 0.7] \"texture tex2\" \"half\"",
            "Material \"diffuse\" \"texture reflectance\" \"c\"",
        ),
    );
    let opts = options(&check, w, h, 128);
    let g = render_gpu(&ctx, &check, &opts);
    let c = render_cpu(&check, &opts);
    let even = |i: u32, j: u32| (i / 8 + j / 16).is_multiple_of(2);
    for (film, dev) in [(&g, "GPU"), (&c, "CPU")] {
        assert_region(film, 0.7, &format!("{dev}: checkerboard tex1 squares"), even);
        assert_region(film, 0.5 * srgb(128) as f64, &format!("{dev}: tex2 squares"), |i, j| !even(i, j));
    }
    assert_films_agree(&g, &c, 4, K, "checkerboard, GPU vs CPU");
    // Mix of a constant and the grey image by a float image: amount(u) = 1 -
    // 2 |u - 0.75| (bilinear between texel centres 0.25 and 0.75, wrapped), linear
    // over each pixel column, so a column's mean is the mix at its centre.
    let mix = load(
        &d,
        &furnace_quad(
            "Texture \"g\" \"spectrum\" \"imagemap\" \"string filename\" \"grey.png\"\n\
             Texture \"a\" \"float\" \"imagemap\" \"string filename\" \"amount.png\" \"string encoding\" \"linear\"\n\
             Texture \"m\" \"spectrum\" \"mix\" \"rgb tex1\" [0.9 0.9 0.9] \"texture tex2\" \"g\" \"texture amount\" \"a\"",
            "Material \"diffuse\" \"texture reflectance\" \"m\"",
        ),
    );
    let g = render_gpu(&ctx, &mix, &opts);
    let c = render_cpu(&mix, &opts);
    for col in [2u32, 12, 23, 24, 30] {
        let u = (col as f64 + 0.5) / w as f64;
        let du = (u - 0.75).abs();
        let amount = 1.0 - 2.0 * du.min(1.0 - du);
        let want = 0.9 * (1.0 - amount) + srgb(128) as f64 * amount;
        for (film, dev) in [(&g, "GPU"), (&c, "CPU")] {
            assert_region(film, want, &format!("{dev}: mix, column {col} (amount {amount})"), |i, _| i == col);
        }
    }
    assert_films_agree(&g, &c, 4, K, "mix, GPU vs CPU");
}

#[test]
fn a_conductor_reflectance_image_sets_its_index_per_hit_as_pbrt_v4_does() {
    let d = dir("conductor");
    let (a, b) = ([230u8, 180, 60, 255], [40u8, 120, 240, 255]);
    png(&d, "tint.png", 8, 8, |x, y| if (x + y) % 2 == 0 { a } else { b });
    png(&d, "flat.png", 1, 1, |_, _| a);
    let scene = |reflectance: &str| {
        load(
            &d,
            &furnace_quad(
                "Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"tint.png\"\n\
                 Texture \"f\" \"spectrum\" \"imagemap\" \"string filename\" \"flat.png\"",
                &format!("Material \"conductor\" {reflectance} \"float roughness\" 0.3"),
            ),
        )
    };
    let tinted = scene("\"texture reflectance\" \"t\"");
    let m = &tinted.materials[0];
    assert!(m.reflectance_conductor && m.albedo_texture.is_some() && m.albedo == Vec3::ONE, "{m:?}");
    let opts = options(&tinted, 16, 16, 256);
    let ctx = gpu();
    let g = render_gpu(&ctx, &tinted, &opts);
    let c = render_cpu(&tinted, &opts);
    assert_films_agree(&g, &c, 4, K, "reflectance texture conductor, GPU vs CPU");
    // A one-texel image is its colour everywhere: the conductor of that constant
    // reflectance (k from it at import), which the import has long rendered.
    let flat = scene("\"texture reflectance\" \"f\"");
    let want = (0..3).map(|k| srgb(a[k])).collect::<Vec<_>>();
    let constant = scene(&format!("\"rgb reflectance\" [{} {} {}]", want[0], want[1], want[2]));
    assert!(!constant.materials[0].reflectance_conductor);
    let g_flat = render_gpu(&ctx, &flat, &opts);
    let c_constant = render_cpu(&constant, &opts);
    assert_films_agree(&g_flat, &c_constant, 4, K, "reflectance image (GPU) vs its constant (CPU)");
    // The image's texture is seen: the checker differs from the flat colour.
    let (mt, mf) = (g.mean(), g_flat.mean());
    let blue = |m: &rlpt::image::Image| m.pixels.iter().map(|p| p[2] as f64).sum::<f64>() / m.pixels.len() as f64;
    assert!(blue(&mt) > 1.5 * blue(&mf), "checker blue {} vs flat {}", blue(&mt), blue(&mf));
}

#[test]
fn a_reflectance_conductor_without_uvs_takes_its_mean_reflectance() {
    let d = dir("no-uv");
    png(&d, "flat.png", 1, 1, |_, _| [200, 100, 50, 255]);
    let s = load(
        &d,
        "LookAt 0 0 -1  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\n\
         Texture \"f\" \"spectrum\" \"imagemap\" \"string filename\" \"flat.png\"\n\
         Material \"conductor\" \"texture reflectance\" \"f\"\n\
         Shape \"trianglemesh\" \"point3 P\" [-1 -1 0 1 -1 0 1 1 0] \"integer indices\" [0 1 2]\n",
    );
    let m = &s.materials[s.meshes[0].materials[0] as usize];
    let r = Vec3::new(srgb(200), srgb(100), srgb(50));
    assert!(!m.reflectance_conductor && m.albedo_texture.is_none() && m.albedo == Vec3::ONE, "{m:?}");
    assert!((m.k - rlpt::scene::conductor_k(r)).abs().max_element() < 1e-4 && m.eta == Vec3::ONE, "{m:?}");
    assert!(s.notes.iter().any(|n| n.contains("no texture coordinates")), "{:?}", s.notes);
}

#[test]
fn what_is_not_evaluated_is_noted_with_its_line_and_refused_when_strict() {
    let d = dir("notes");
    png(&d, "grey.png", 1, 1, |_, _| [128, 128, 128, 255]);
    let text = furnace_quad(
        "Texture \"g\" \"spectrum\" \"imagemap\" \"string filename\" \"grey.png\"\n\
         Texture \"m\" \"spectrum\" \"mix\" \"texture tex1\" \"g\" \"rgb tex2\" [0 0 1]\n\
         Texture \"nested\" \"spectrum\" \"checkerboard\" \"texture tex1\" \"m\" \"rgb tex2\" [1 1 1]\n\
         Texture \"solid\" \"spectrum\" \"checkerboard\" \"integer dimension\" 3",
        "Material \"diffuse\" \"texture reflectance\" \"nested\"",
    );
    let s = load(&d, &text);
    // The nested mix's mean stands in for it: 0.5 grey + 0.5 blue.
    let note = s.notes.iter().find(|n| n.contains("\"texture tex1\"")).unwrap_or_else(|| panic!("{:?}", s.notes));
    assert!(note.contains("scene.pbrt:8:") && note.contains("procedural texture of a procedural"), "{note}");
    let p = s.materials[0].albedo_procedural.as_ref().unwrap();
    let mean = 0.5 * (Vec3::splat(srgb(128)) + Vec3::new(0.0, 0.0, 1.0));
    assert!((p.a.value - mean).abs().max_element() < 1e-3 && p.a.image.is_none(), "{p:?}");
    assert!(s.notes.iter().any(|n| n.contains("scene.pbrt:9:") && n.contains("3D checkerboard")), "{:?}", s.notes);
    let path = d.join("scene.pbrt");
    let e = Scene::load_with(&path, true).unwrap_err().to_string();
    assert!(e.contains("scene.pbrt:8:") && e.contains("--strict"), "{e}");
    // An amount outside [0, 1]: refused at its line.
    let bad = furnace_quad(
        "Texture \"m\" \"spectrum\" \"mix\" \"float amount\" 1.5",
        "Material \"diffuse\" \"texture reflectance\" \"m\"",
    );
    std::fs::write(&path, bad).unwrap();
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(e.contains("scene.pbrt:6:") && e.contains("amount 1.5"), "{e}");
}
