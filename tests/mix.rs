//! The mix material (pbrt's `mix`): one of two materials per hit, the second
//! with chance `amount`, by a hash of the hit point and wo. Its choices against
//! their chances (nested and textured), renders against the blend they must
//! average to (a furnace's blended albedo; a lit scene against the renders of
//! its two materials alone), the GPU against the CPU twin, and the refusals of
//! bad mixes in TOML and pbrt files with their lines.

mod common;
mod pbrt_support;

use common::scene_pieces::{expect, with_material};
use common::*;
use glam::{Vec2, Vec3};
use rlpt::cpu::resolve_mix;
use rlpt::film::Film;
use rlpt::prepared::PreparedScene;
use rlpt::scene::{MaterialKind, Scene};
use rlpt::shared;

/// The materials of the choice tests: three concrete ones, a mix of two and a
/// mix of that mix and the third, and a mix by a grey 2x1 image (black, white)
/// times 0.8. `amount_png` is the image's path.
fn choice_scene(amount_png: &str) -> String {
    format!(
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nvfov = 45\n\
         [[material]]\nname = \"a\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\
         [[material]]\nname = \"b\"\ntype = \"glossy\"\nalbedo = [0.5, 0.5, 0.5]\nroughness = 0.3\n\
         [[material]]\nname = \"c\"\ntype = \"conductor\"\neta = [0.2, 0.9, 1.1]\nk = [3.9, 2.4, 2.1]\nroughness = 0.2\n\
         [[material]]\nname = \"ab\"\ntype = \"mix\"\nmaterials = [\"a\", \"b\"]\namount = 0.3\n\
         [[material]]\nname = \"abc\"\ntype = \"mix\"\nmaterials = [\"ab\", \"c\"]\namount = 0.6\n\
         [[material]]\nname = \"textured\"\ntype = \"mix\"\nmaterials = [\"a\", \"c\"]\namount = 0.8\n\
         amount_texture = \"{amount_png}\"\n\
         [[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"abc\"\n\
         [[sphere]]\ncenter = [3, 0, 0]\nradius = 1\nmaterial = \"textured\"\n"
    )
}

/// Counts the materials `mat` resolves to over `n` hashed hits (uniform points
/// and directions, drawn by a PCG stream of the test's own) at `uv`.
fn choices(p: &PreparedScene, mat: u32, uv: Vec2, n: usize) -> Vec<u64> {
    let mut rng = rlpt::math::rng::Rng::new(7, mat, 0, 0);
    let mut counts = vec![0u64; p.materials.len()];
    for _ in 0..n {
        let [x, y] = rng.next_2d();
        let [z, w] = rng.next_2d();
        let point = Vec3::new(x, y, z) * 4.0 - 2.0;
        let wo = Vec3::new(w - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize();
        let chosen = resolve_mix(p, mat, point, wo, uv);
        assert_eq!(chosen, resolve_mix(p, mat, point, wo, uv), "the choice is a function of the hit");
        counts[chosen as usize] += 1;
    }
    counts
}

/// Pearson's chi-square of `counts` against the probabilities `want` (index,
/// probability); every other material must never be chosen. Fails below a
/// p-value of 1e-4.
fn assert_chances(counts: &[u64], want: &[(usize, f64)], what: &str) {
    let n: u64 = counts.iter().sum();
    for (i, &c) in counts.iter().enumerate() {
        if !want.iter().any(|w| w.0 == i) {
            assert_eq!(c, 0, "{what}: material {i} chosen {c} times, never expected");
        }
    }
    let x2: f64 = want
        .iter()
        .map(|&(i, p)| {
            let e = p * n as f64;
            (counts[i] as f64 - e).powi(2) / e
        })
        .sum();
    if want.len() == 1 {
        return;
    }
    let dof = (want.len() - 1) as f64;
    let p_value = rlpt_chi2::gamma_q(dof / 2.0, x2 / 2.0);
    assert!(p_value > 1e-4, "{what}: counts {counts:?} against {want:?}: chi-square {x2:.2}, p {p_value:.2e}");
}

#[test]
fn a_mix_chooses_its_materials_with_their_chances_nested_and_textured() {
    let d = common::cli::fresh_dir("mix-choices");
    let png = common::files::write(&d, "amount.png", common::files::png_bytes(2, 1, |x, _| [255 * x as u8; 4]));
    let scene = Scene::parse(&choice_scene(&png.display().to_string()), "choices.toml").unwrap();
    let p = PreparedScene::new(&scene, &options(&scene, 8, 8, 64)).unwrap();
    let index = |name: &str| scene.materials.iter().position(|m| m.name == name).unwrap();
    let (a, b, c) = (index("a"), index("b"), index("c"));
    assert_eq!(scene.materials[index("abc")].mix, Some([index("ab") as u32, c as u32]));
    assert_ne!(p.params.scene_kinds & 1 << shared::SCENE_KIND_MIX, 0, "the kernel is compiled with resolve_mix");
    let n = 200_000;
    let uv = Vec2::ZERO;
    assert_chances(&choices(&p, index("ab") as u32, uv, n), &[(a, 0.7), (b, 0.3)], "mix of a and b at 0.3");
    // Nested: each level's choice by its own hash, so the chances multiply.
    let nested = choices(&p, index("abc") as u32, uv, n);
    assert_chances(&nested, &[(a, 0.4 * 0.7), (b, 0.4 * 0.3), (c, 0.6)], "mix of (a, b) and c at 0.6");
    // A concrete material resolves to itself.
    assert_chances(&choices(&p, c as u32, uv, 1000), &[(c, 1.0)], "no mix");
    // Textured: amount 0.8 times the image, 0 at texel 0's centre (u 0.25), 0.8 at texel 1's, 0.4 between.
    let t = index("textured") as u32;
    assert_chances(&choices(&p, t, Vec2::new(0.25, 0.5), 20_000), &[(a, 1.0)], "textured amount 0");
    assert_chances(&choices(&p, t, Vec2::new(0.75, 0.5), n), &[(a, 0.2), (c, 0.8)], "textured amount 0.8");
    assert_chances(&choices(&p, t, Vec2::new(0.5, 0.5), n), &[(a, 0.6), (c, 0.4)], "textured amount 0.4");
    // Scenes without a mix keep the kernel without resolve_mix.
    let plain = common::scene("furnace-open.toml");
    let q = PreparedScene::new(&plain, &options(&plain, 8, 8, 64)).unwrap();
    assert_eq!(q.params.scene_kinds & 1 << shared::SCENE_KIND_MIX, 0);
}

/// A furnace sphere (uniform sky of 1, convex: every pixel on it is its albedo)
/// of the mix of two diffuse materials, 0.2 and 0.8, at amount 0.25.
const FURNACE_MIX: &str = "\
[camera]\nposition = [0, 0, 4]\nlook_at = [0, 0, 0]\nvfov = 40\n\
[environment]\nradiance = [1, 1, 1]\n\
[[material]]\nname = \"dark\"\ntype = \"diffuse\"\nalbedo = [0.2, 0.2, 0.2]\n\
[[material]]\nname = \"light\"\ntype = \"diffuse\"\nalbedo = [0.8, 0.8, 0.8]\n\
[[material]]\nname = \"m\"\ntype = \"mix\"\nmaterials = [\"dark\", \"light\"]\namount = 0.25\n\
[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"m\"\n";

#[test]
fn a_mix_of_two_diffuse_materials_in_a_furnace_renders_the_blended_albedo() {
    let scene = Scene::parse(FURNACE_MIX, "furnace-mix.toml").unwrap();
    let opts = options(&scene, 32, 32, 256);
    let ctx = gpu();
    let g = render_gpu(&ctx, &scene, &opts);
    let c = render_cpu(&scene, &opts);
    // The sphere covers the pixels within 11 of the centre; those within 9 are on it whole.
    let on_sphere = |x: u32, y: u32| (x as f64 - 15.5).powi(2) + (y as f64 - 15.5).powi(2) < 81.0;
    for (film, dev) in [(&g, "GPU"), (&c, "CPU")] {
        let (mean, var, _) = region_stats(film, on_sphere);
        let want = 0.75 * 0.2 + 0.25 * 0.8;
        let z = (mean - want) / var.sqrt();
        assert!(z.abs() < K, "{dev}: the mix renders {mean}, the blend is {want} ({z:.2} sigma)");
        // The mix is a per-hit choice, not a blend: its pixels vary (the blend's would not).
        assert!(var > 0.0, "{dev}: no variance");
    }
    assert_films_agree(&g, &c, 4, K, "furnace mix, GPU vs CPU");
}

/// A lit scene: a floor and a sphere of `material`, a small spherical lamp
/// (light sampling and MIS at every vertex) and a dim sky; one bounce, where the
/// image is linear in the BSDF (with more, a path through two vertices of one
/// material alone would weigh f1 f1, and the mix's f1 f2 too).
fn lit(material: &str) -> String {
    format!(
        "[camera]\nposition = [0, 1.2, 4]\nlook_at = [0, 0.3, 0]\nvfov = 45\n\
         [render]\nmax_bounces = 1\n\
         [environment]\nradiance = [0.1, 0.1, 0.1]\n\
         [[material]]\nname = \"matte\"\ntype = \"diffuse\"\nalbedo = [0.7, 0.5, 0.3]\n\
         [[material]]\nname = \"gloss\"\ntype = \"glossy\"\nalbedo = [0.9, 0.9, 0.9]\nroughness = 0.3\n\
         [[material]]\nname = \"mixed\"\ntype = \"mix\"\nmaterials = [\"matte\", \"gloss\"]\namount = 0.3\n\
         [[material]]\nname = \"lamp\"\ntype = \"emissive\"\nemission = [30, 30, 30]\n\
         [[sphere]]\ncenter = [0, 0.5, 0]\nradius = 0.5\nmaterial = \"{material}\"\n\
         [[sphere]]\ncenter = [1, 2, 1]\nradius = 0.15\nmaterial = \"lamp\"\n\
         [[quad]]\norigin = [-3, 0, -3]\nedge_u = [0, 0, 6]\nedge_v = [6, 0, 0]\nmaterial = \"{material}\"\n"
    )
}

/// `a * x + b * y`, pixel by pixel, as a mean image with its variance.
fn blend(x: &Film, y: &Film, a: f32, b: f32) -> (rlpt::image::Image, rlpt::image::Image) {
    let (mx, my) = (x.mean(), y.mean());
    let (vx, vy) = (x.variance_of_mean().unwrap(), y.variance_of_mean().unwrap());
    let mut mean = mx.clone();
    let mut var = vx.clone();
    for i in 0..mean.pixels.len() {
        for ch in 0..3 {
            mean.pixels[i][ch] = a * mx.pixels[i][ch] + b * my.pixels[i][ch];
            var.pixels[i][ch] = a * a * vx.pixels[i][ch] + b * b * vy.pixels[i][ch];
        }
    }
    (mean, var)
}

#[test]
fn a_mix_of_diffuse_and_glossy_renders_as_the_blend_of_their_renders() {
    let (w, h, spp) = (24, 16, 512);
    let load = |m: &str| Scene::parse(&lit(m), "lit.toml").unwrap();
    let (mixed, matte, gloss) = (load("mixed"), load("matte"), load("gloss"));
    let mut opts = options(&mixed, w, h, spp);
    // The expectation over the choice is 0.7 matte + 0.3 gloss, vertex by vertex.
    let cm = render_cpu(&mixed, &opts);
    let (bm, bv) = blend(&render_cpu(&matte, &opts), &render_cpu(&gloss, &opts), 0.7, 0.3);
    let vm = cm.variance_of_mean().unwrap();
    let mm = cm.mean();
    let z = assert_means_agree(
        &mm,
        &bm,
        |i, c| vm.pixels[i][c] as f64 + bv.pixels[i][c] as f64,
        |i, c| rounding_bound(&cm, mm.pixels[i][c]) + rounding_bound(&cm, bm.pixels[i][c]),
        4,
        K,
        "mix vs 0.7 matte + 0.3 gloss (CPU)",
    );
    eprintln!("mix vs blend: worst block {z:.2} sigma");
    // And it is not either one alone: the blend differs from the matte render.
    let matte_only = render_cpu(&matte, &opts).mean();
    let (sum_mix, sum_matte): (f32, f32) =
        (mm.pixels.iter().map(|p| p[2]).sum(), matte_only.pixels.iter().map(|p| p[2]).sum());
    assert!(sum_mix > 1.05 * sum_matte, "blue: mix {sum_mix} vs matte {sum_matte}");
    // The GPU, unguided and guided, against the CPU twin, over longer paths.
    opts.max_bounces = 4;
    gpu_unguided_and_guided_agree_with_cpu(&mixed, &mut opts, [11, 12], "lit mix");
}

#[test]
fn bad_mixes_in_a_toml_scene_are_refused_with_their_line() {
    let base = "[[material]]\nname = \"white\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\
                [[material]]\nname = \"red\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.1, 0.1]\n";
    // The camera takes lines 1-4, `base` 5-12: the mix starts on line 13, its keys on 14 and after.
    let mix = |keys: &str| with_material(&format!("{base}[[material]]\nname = \"m\"\ntype = \"mix\"\n{keys}"));
    expect(&mix("materials = [\"white\", \"blue\"]\n"), "16:23", &["\"blue\"", "not a material defined before"]);
    expect(&mix("materials = [\"white\"]\n"), "16:13", &["two materials", "found 1 names"]);
    expect(&mix("materials = [\"white\", \"red\"]\namount = 1.5\n"), "17:10", &["`amount`", "from 0 to 1"]);
    expect(&mix("materials = [\"white\", \"red\"]\namount = -0.1\n"), "17:10", &["`amount`", "from 0 to 1"]);
    expect(&mix("amount = 0.5\n"), "13:1", &["missing key `materials`"]);
    expect(&mix("materials = [\"white\", \"red\"]\nalbedo = [1, 1, 1]\n"), "17:1", &["albedo"]);
    let lamp = "[[material]]\nname = \"lamp\"\ntype = \"emissive\"\nemission = [1, 1, 1]\n";
    let text = with_material(&format!(
        "{lamp}{base}[[material]]\nname = \"m\"\ntype = \"mix\"\nmaterials = [\"lamp\", \"red\"]\n"
    ));
    expect(&text, "20:14", &["\"lamp\" emits light"]);
    // Five levels of mixes: one more than the renderers resolve.
    let mut deep = base.to_string();
    let mut prev = "white".to_string();
    for level in 1..=shared::MIX_MAX_DEPTH + 1 {
        deep += &format!("[[material]]\nname = \"m{level}\"\ntype = \"mix\"\nmaterials = [\"{prev}\", \"red\"]\n");
        prev = format!("m{level}");
    }
    let line = 5 + 8 + 4 * shared::MIX_MAX_DEPTH as usize + 3;
    expect(&with_material(&deep), &format!("{line}:13"), &["mixes nest at most 4 levels"]);
}

/// A furnace (uniform sky of 1) looking at the quad [-1, 1]^2 with UVs, the
/// camera one unit in front of it, 90 degrees: pixel column i at u = (i + 0.5) / w.
fn furnace_quad(materials: &str) -> String {
    format!(
        "LookAt 0 0 -1  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 90\n\
         Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\nWorldBegin\n\
         LightSource \"infinite\" \"rgb L\" [1 1 1]\n{materials}\n\
         Shape \"trianglemesh\" \"point3 P\" [-1 -1 0 1 -1 0 1 1 0 -1 1 0] \
         \"integer indices\" [0 2 1 0 3 2] \"point2 uv\" [0 0 1 0 1 1 0 1]\n"
    )
}

#[test]
fn a_pbrt_nested_mix_with_a_textured_amount_maps_and_renders_alike_on_gpu_and_cpu() {
    let d = common::cli::fresh_dir("pbrt-mix");
    common::files::write(&d, "amount.png", common::files::png_bytes(2, 1, |x, _| [255 * x as u8; 4]));
    let materials = "\
        Texture \"amt\" \"float\" \"imagemap\" \"string filename\" \"amount.png\" \"string encoding\" \"linear\"\n\
        MakeNamedMaterial \"matte\" \"string type\" \"diffuse\" \"rgb reflectance\" [0.6 0.6 0.6]\n\
        MakeNamedMaterial \"metal\" \"string type\" \"conductor\" \"float roughness\" 0.2\n\
        MakeNamedMaterial \"coat\" \"string type\" \"coateddiffuse\" \"float roughness\" 0.1\n\
        MakeNamedMaterial \"inner\" \"string type\" \"mix\" \"string materials\" [\"matte\" \"metal\"] \
        \"texture amount\" \"amt\"\n\
        MakeNamedMaterial \"outer\" \"string type\" \"mix\" \"string materials\" [\"coat\" \"inner\"] \
        \"float amount\" 0.7\n\
        MakeNamedMaterial \"v3\" \"string type\" \"mix\" \"string namedmaterial1\" \"matte\" \
        \"string namedmaterial2\" \"metal\" \"rgb amount\" [0.25 0.25 0.25]\n\
        NamedMaterial \"outer\"";
    let text = furnace_quad(materials);
    let path = common::files::write(&d, "scene.pbrt", &text);
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let find = |name: &str| scene.materials.iter().position(|m| m.name == name).unwrap();
    let outer = &scene.materials[find("outer")];
    assert_eq!(outer.kind, MaterialKind::Mix);
    assert_eq!(outer.mix, Some([find("coat") as u32, find("inner") as u32]));
    assert_eq!(outer.albedo.x, 0.7);
    let inner = &scene.materials[find("inner")];
    assert_eq!(inner.mix, Some([find("matte") as u32, find("metal") as u32]));
    assert!(inner.albedo_texture.is_some(), "the amount is read per hit from the image");
    assert_eq!(scene.materials[find("metal")].kind, MaterialKind::Conductor);
    assert!(scene.notes.iter().all(|n| !n.contains("(mix)")), "a mix maps without a note: {:#?}", scene.notes);
    let mapping = scene.material_mappings.iter().find(|m| m.starts_with("outer:")).unwrap();
    assert!(mapping.contains("\"coat\" or \"inner\", chosen per hit (amount 0.7)"), "{mapping}");
    assert!(mapping.ends_with(":11]"), "{mapping}");
    // pbrt-v3's namedmaterial1 has chance amount: it is rlpt's second.
    let v3 = pbrt_support::load(
        "pbrt-mix-v3",
        &furnace_quad(&materials.replace("\nNamedMaterial \"outer\"", "\nNamedMaterial \"v3\"")),
    );
    let m = v3.materials.iter().find(|m| m.name == "v3").unwrap();
    let name = |i: u32| v3.materials[i as usize].name.as_str();
    let [x, y] = m.mix.unwrap();
    assert_eq!((name(x), name(y), m.albedo.x), ("metal", "matte", 0.25));
    // Rendered: the GPU against the CPU twin.
    let opts = options(&scene, 16, 16, 512);
    let ctx = gpu();
    let g = render_gpu(&ctx, &scene, &opts);
    let c = render_cpu(&scene, &opts);
    assert_films_agree(&g, &c, 4, K, "pbrt nested mix, GPU vs CPU");
}

#[test]
fn bad_pbrt_mixes_are_refused_with_their_file_and_line() {
    let head = "LookAt 0 0 -1  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\n\
                MakeNamedMaterial \"a\" \"string type\" \"diffuse\"\n\
                MakeNamedMaterial \"b\" \"string type\" \"conductor\"\n";
    let refuse =
        |name: &str, body: &str| pbrt_support::refuse(name, &format!("{head}{body}{}", pbrt_support::TRIANGLE), false);
    let e =
        refuse("mix-unknown", "MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" [\"a\" \"c\"]\n");
    assert!(e.starts_with("DIR/scene.pbrt:6:1: "), "{e}");
    assert!(e.contains("\"c\" is not a named material made before it"), "{e}");
    let e = refuse(
        "mix-amount",
        "MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" [\"a\" \"b\"]\n  \"float amount\" 1.5\n",
    );
    assert!(e.starts_with("DIR/scene.pbrt:7:3: ") && e.contains("amount 1.5 must be from 0 to 1"), "{e}");
    let e = refuse("mix-one", "MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" [\"a\"]\n");
    assert!(e.starts_with("DIR/scene.pbrt:6:1: ") && e.contains("two material names"), "{e}");
    let mut deep = String::new();
    let mut prev = "a".to_string();
    for level in 1..=shared::MIX_MAX_DEPTH + 1 {
        deep += &format!(
            "MakeNamedMaterial \"m{level}\" \"string type\" \"mix\" \"string materials\" [\"{prev}\" \"b\"]\n"
        );
        prev = format!("m{level}");
    }
    let e = refuse("mix-deep", &deep);
    let line = 6 + shared::MIX_MAX_DEPTH;
    assert!(e.starts_with(&format!("DIR/scene.pbrt:{line}:1: ")) && e.contains("nest at most 4 levels"), "{e}");
}
