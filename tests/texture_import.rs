//! Textures the scene readers take from other formats (docs/pbrt.md,
//! docs/SCENE_FORMAT.md "Textures"): pbrt float `imagemap`s read as roughness
//! with pbrt's remaps, pbrt spheres' UVs, and glTF images embedded in a `.glb`
//! or a `data:` uri. The GPU against the CPU twin, and a constant roughness
//! texture against the constant itself.

mod common;

use common::cli::fresh_dir;
use common::files::{base64, png_bytes, srgb};
use common::*;
use glam::{Vec2, Vec3};
use rlpt::prepared::PreparedScene;
use rlpt::scene::texture::{find, Channel, Factor, Remap, TextureUse};
use rlpt::scene::{Material, Scene};

fn grey(g: u8) -> [u8; 4] {
    [g, g, g, 255]
}

fn material<'a>(s: &'a Scene, name: &str) -> &'a Material {
    s.materials.iter().find(|m| m.name == name).unwrap_or_else(|| panic!("no material {name}"))
}

/// The roughness bytes of material `name`'s roughness texture, by texel.
fn roughness_texels(s: &Scene, name: &str) -> Vec<u8> {
    let r = material(s, name).roughness_texture.as_ref().unwrap_or_else(|| panic!("{name}: no roughness texture"));
    s.textures[find(&s.textures, r).unwrap()].texels.iter().map(|w| w.to_le_bytes()[0]).collect()
}

/// A quad [-1, 1]^2 at z = 0 with UVs, facing -z (towards the camera), in pbrt.
const PBRT_QUAD: &str = "Shape \"trianglemesh\" \"point3 P\" [-1 -1 0 1 -1 0 1 1 0 -1 1 0] \
                         \"integer indices\" [0 2 1 0 3 2] \"point2 uv\" [0 0 1 0 1 1 0 1]\n";

/// pbrt's roughness texture mapped to alpha, then rlpt's roughness sqrt(alpha).
fn pbrt_v3_roughness(v: f32) -> f32 {
    let x = v.max(1e-3).ln();
    let alpha = 1.62142 + 0.819955 * x + 0.1734 * x * x + 0.0171201 * x.powi(3) + 0.000640711 * x.powi(4);
    alpha.clamp(0.0, 1.0).sqrt()
}

#[test]
fn pbrt_float_imagemaps_are_roughness_textures_remapped_as_pbrt_does() {
    let d = fresh_dir("float");
    let greys = [10u8, 64, 128, 255];
    std::fs::write(d.join("rough.png"), png_bytes(4, 1, |x, _| grey(greys[x as usize]))).unwrap();
    let pbrt = format!(
        "LookAt 0 0 -4  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\nWorldBegin\n\
         LightSource \"infinite\" \"rgb L\" [1 1 1]\n\
         Texture \"r\" \"float\" \"imagemap\" \"string filename\" \"rough.png\"\n\
         Texture \"lin\" \"float\" \"imagemap\" \"string filename\" \"rough.png\" \"string encoding\" \"linear\" \
         \"float scale\" 0.5\n\
         Texture \"inv\" \"float\" \"imagemap\" \"string filename\" \"rough.png\" \"bool invert\" true\n\
         Texture \"c\" \"float\" \"constant\" \"float value\" 0.09\n\
         MakeNamedMaterial \"v4\" \"string type\" \"conductor\" \"texture roughness\" \"r\"\n\
         MakeNamedMaterial \"raw\" \"string type\" \"dielectric\" \"texture roughness\" \"lin\" \
         \"bool remaproughness\" false\n\
         MakeNamedMaterial \"v3\" \"string type\" \"metal\" \"texture roughness\" \"r\"\n\
         MakeNamedMaterial \"inverted\" \"string type\" \"coateddiffuse\" \"texture roughness\" \"inv\"\n\
         MakeNamedMaterial \"const\" \"string type\" \"conductor\" \"texture roughness\" \"c\"\n\
         MakeNamedMaterial \"aniso\" \"string type\" \"conductor\" \"texture uroughness\" \"r\" \
         \"float vroughness\" 0.2\n\
         NamedMaterial \"v4\"\n{PBRT_QUAD}NamedMaterial \"raw\"\n{PBRT_QUAD}NamedMaterial \"v3\"\n{PBRT_QUAD}\
         NamedMaterial \"inverted\"\n{PBRT_QUAD}NamedMaterial \"const\"\n{PBRT_QUAD}NamedMaterial \"aniso\"\n{PBRT_QUAD}"
    );
    std::fs::write(d.join("scene.pbrt"), pbrt).unwrap();
    let s = Scene::load(d.join("scene.pbrt")).unwrap_or_else(|e| panic!("{e}"));
    let quantized = |r: f32| (r * 255.0).round() as u8;
    // pbrt-v4: a PNG is sRGB-encoded by default; alpha = sqrt(v), roughness = v^(1/4).
    let v4 = material(&s, "v4");
    assert_eq!(v4.roughness, 1.0);
    let usage = TextureUse::Roughness {
        channel: Channel::Average,
        srgb: true,
        scale: Factor(1.0),
        invert: false,
        remap: Remap::PbrtV4,
    };
    assert_eq!(v4.roughness_texture.as_ref().unwrap().usage, usage);
    let want: Vec<u8> = greys.iter().map(|&g| quantized(srgb(g).sqrt().sqrt())).collect();
    assert_eq!(roughness_texels(&s, "v4"), want);
    // encoding linear, scale 0.5, remaproughness false: v is alpha.
    let raw = material(&s, "raw");
    assert_eq!(raw.kind, rlpt::scene::MaterialKind::RoughDielectric);
    let want: Vec<u8> = greys.iter().map(|&g| quantized((0.5 * g as f32 / 255.0).sqrt())).collect();
    assert_eq!(roughness_texels(&s, "raw"), want);
    // pbrt-v3's metal: its polynomial RoughnessToAlpha.
    let want: Vec<u8> = greys.iter().map(|&g| quantized(pbrt_v3_roughness(srgb(g)))).collect();
    assert_eq!(roughness_texels(&s, "v3"), want);
    // invert: 1 - v, then the v4 remap.
    let want: Vec<u8> = greys.iter().map(|&g| quantized((1.0 - srgb(g)).sqrt().sqrt())).collect();
    assert_eq!(roughness_texels(&s, "inverted"), want);
    // A constant float texture is its value: alpha sqrt(0.09) = 0.3.
    let c = material(&s, "const");
    assert!(c.roughness_texture.is_none() && (c.roughness - 0.3f32.sqrt()).abs() < 1e-6, "{c:?}");
    // u from a texture, v a number: the texture is read for both, noted.
    assert!(material(&s, "aniso").roughness_texture.is_some());
    assert!(s.notes.iter().any(|n| n.contains("vroughness") && n.contains("isotropic")), "{:#?}", s.notes);
    // With --strict that approximation is refused; the rest loads.
    assert!(Scene::load_with(d.join("scene.pbrt"), true).unwrap_err().to_string().contains("vroughness"));
}

/// A conductor sphere (pbrt's UVs) under an area light, its roughness the
/// float texture `texture` (a `Texture` line naming "r") or `float roughness`.
fn lit_sphere(roughness: &str, texture: &str) -> String {
    format!(
        "LookAt 0 0 -4  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\nWorldBegin\n\
         LightSource \"infinite\" \"rgb L\" [0.2 0.2 0.2]\n{texture}\n\
         AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [6 6 6] \"bool twosided\" true\n\
         Shape \"trianglemesh\" \"point3 P\" [-3 2 -3 3 2 -3 3 2 0 -3 2 0] \"integer indices\" [0 1 2 0 2 3]\n\
         AttributeEnd\n\
         Material \"conductor\" {roughness}\nAttributeBegin\nRotate 90 1 0 0\nShape \"sphere\"\nAttributeEnd\n"
    )
}

#[test]
fn a_pbrt_roughness_texture_renders_alike_on_gpu_and_cpu_and_a_constant_one_as_its_constant() {
    let d = fresh_dir("render");
    // A ramp in u (phi around the sphere), linear: roughness from 0.03 to 0.6.
    std::fs::write(d.join("ramp.png"), png_bytes(16, 2, |x, _| grey(8 + 15 * x as u8))).unwrap();
    std::fs::write(d.join("flat.png"), png_bytes(4, 4, |_, _| grey(40))).unwrap();
    let tex = |file: &str| {
        format!("Texture \"r\" \"float\" \"imagemap\" \"string filename\" \"{file}\" \"string encoding\" \"linear\"")
    };
    let load = |name: &str, text: String| {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        Scene::load(&p).unwrap_or_else(|e| panic!("{e}"))
    };
    let ramp = load("ramp.pbrt", lit_sphere("\"texture roughness\" \"r\"", &tex("ramp.png")));
    let flat = load("flat.pbrt", lit_sphere("\"texture roughness\" \"r\"", &tex("flat.png")));
    let constant = load("constant.pbrt", lit_sphere(&format!("\"float roughness\" {}", 40.0 / 255.0), ""));
    assert_eq!((ramp.textures.len(), flat.textures.len(), constant.textures.len()), (1, 1, 0));
    let opts = options(&ramp, 24, 24, 256);
    let ctx = gpu();
    let g = render_gpu(&ctx, &ramp, &opts);
    let c = render_cpu(&ramp, &opts);
    assert_films_agree(&g, &c, 4, K, "pbrt roughness texture on a sphere, GPU vs CPU");
    // The ramp is seen: the highlight's peak differs from the constant's.
    let g_flat = render_gpu(&ctx, &flat, &opts);
    let c_constant = render_cpu(&constant, &opts);
    assert_films_agree(&g_flat, &c_constant, 4, K, "constant roughness texture (GPU) vs its constant (CPU)");
}

#[test]
fn pbrt_sphere_uvs_are_phi_over_phimax_and_theta_over_its_range_in_object_space() {
    let d = fresh_dir("sphere-uv");
    std::fs::write(d.join("c.png"), png_bytes(2, 2, |x, y| grey(((x + y) % 2 * 255) as u8))).unwrap();
    // Sphere 0: rotated 90 degrees about x (object +z is world -y, object +y world +z).
    // Sphere 1: phimax 180, z from -0.5 to 1 of radius 1 (rendered whole, noted).
    let pbrt = "LookAt 0 0 -4  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\nWorldBegin\n\
                LightSource \"infinite\" \"rgb L\" [1 1 1]\n\
                Texture \"c\" \"spectrum\" \"imagemap\" \"string filename\" \"c.png\"\n\
                Material \"diffuse\" \"texture reflectance\" \"c\"\n\
                AttributeBegin\nRotate 90 1 0 0\nShape \"sphere\"\nAttributeEnd\n\
                AttributeBegin\nTranslate 3 0 0\nShape \"sphere\" \"float phimax\" 180 \"float zmin\" -0.5\nAttributeEnd\n";
    std::fs::write(d.join("scene.pbrt"), pbrt).unwrap();
    let s = Scene::load(d.join("scene.pbrt")).unwrap_or_else(|e| panic!("{e}"));
    let p = PreparedScene::new(&s, &options(&s, 8, 8, 1)).unwrap();
    let pi = std::f32::consts::PI;
    let object = |phi: f32, theta: f32| Vec3::new(phi.cos() * theta.sin(), phi.sin() * theta.sin(), theta.cos());
    // rlpt's space is pbrt's camera space mirrored in x (docs/pbrt.md); here the
    // camera at pbrt's (0, 0, -4) looks along +z with x unturned.
    let to_rlpt = |w: Vec3| Vec3::new(-w.x, w.y, w.z);
    let rotate = |o: Vec3| to_rlpt(Vec3::new(o.x, -o.z, o.y)); // Rotate 90 about x: y -> z, z -> -y
    for (phi, theta) in [(0.3f32, 1.0f32), (2.0, 0.4), (4.0, 2.5), (5.9, 1.6)] {
        let uv = rlpt::math::texture::sphere_uv(&p, 0, rotate(object(phi, theta)));
        let want = Vec2::new(phi / (2.0 * pi), 1.0 - theta / pi);
        assert!(uv.distance(want) < 1e-5, "sphere 0 at phi {phi} theta {theta}: {uv} vs {want}");
        // A partial sphere: u = phi / pi, v from theta at z = -0.5 (acos -0.5) to theta 0.
        let uv = rlpt::math::texture::sphere_uv(&p, 1, to_rlpt(object(phi, theta)));
        let theta_min = (-0.5f32).acos();
        let want = Vec2::new(phi / pi, (theta - theta_min) / (0.0 - theta_min));
        assert!(uv.distance(want) < 1e-5, "sphere 1 at phi {phi} theta {theta}: {uv} vs {want}");
    }
    assert!(s.notes.iter().any(|n| n.contains("partial sphere")), "{:#?}", s.notes);
    // A hit's UV is its sphere's: the camera's central ray meets sphere 0 at pbrt's
    // (0, 0, -1), object (0, -1, 0) before the rotation: phi 3 pi / 2, theta pi / 2.
    let hit = rlpt::math::geometry::intersect(&p, Vec3::ZERO, Vec3::Z, f32::INFINITY).unwrap();
    assert!(hit.uv.distance(Vec2::new(0.75, 0.5)) < 1e-4, "{}", hit.uv);
    // The TOML sphere keeps its convention: u = 0.5 + atan2(x, -z) / 2 pi, v = 1 - acos(y) / pi.
    std::fs::write(
        d.join("s.toml"),
        "[camera]\nposition = [0, 0, 4]\nlook_at = [0, 0, 0]\nvfov = 40\n[environment]\nradiance = [1, 1, 1]\n\
         [[material]]\nname = \"t\"\ntype = \"diffuse\"\nalbedo = [1, 1, 1]\nalbedo_texture = \"c.png\"\n\
         [[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"t\"\n",
    )
    .unwrap();
    let toml = Scene::load(d.join("s.toml")).unwrap_or_else(|e| panic!("{e}"));
    let p = PreparedScene::new(&toml, &options(&toml, 8, 8, 1)).unwrap();
    for n in [Vec3::new(0.6, 0.0, -0.8), Vec3::new(-0.48, 0.6, 0.64), Vec3::new(0.0, -0.6, 0.8)] {
        let want = Vec2::new(n.x.atan2(-n.z) / (2.0 * pi) + 0.5, 1.0 - n.y.acos() / pi);
        let uv = rlpt::math::texture::sphere_uv(&p, 0, n);
        // u at the seam (-z) may be 0 or 1: the same texels under repeat wrap.
        let du = (uv.x - want.x).rem_euclid(1.0);
        assert!(du.min(1.0 - du) < 1e-5 && (uv.y - want.y).abs() < 1e-5, "TOML sphere at {n}: {uv} vs {want}");
    }
}

/// A `.glb` of the quad [-1, 1]^2 (z = 0, UVs at its corners): a metal whose
/// baseColorTexture is a PNG in a bufferView and whose metallicRoughnessTexture
/// is a PNG in a `data:` uri.
fn glb(colour: &[u8], roughness: &[u8]) -> Vec<u8> {
    let mut bin: Vec<u8> = Vec::new();
    for p in [[-1.0f32, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]] {
        p.iter().for_each(|x| bin.extend(x.to_le_bytes()));
    }
    for uv in [[0.0f32, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]] {
        uv.iter().for_each(|x| bin.extend(x.to_le_bytes()));
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend(i.to_le_bytes());
    }
    let image_at = bin.len();
    bin.extend_from_slice(colour);
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
 "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"TEXCOORD_0":1}},"indices":2,"material":0}}]}}],
 "materials":[{{"name":"m","pbrMetallicRoughness":{{"baseColorFactor":[1,1,1,1],"metallicFactor":1,
   "roughnessFactor":0.8,"baseColorTexture":{{"index":0}},"metallicRoughnessTexture":{{"index":1}}}}}}],
 "textures":[{{"source":0}},{{"source":1}}],
 "images":[{{"bufferView":3,"mimeType":"image/png"}},{{"uri":"data:image/png;base64,{}"}}],
 "buffers":[{{"byteLength":{}}}],
 "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":32}},
   {{"buffer":0,"byteOffset":80,"byteLength":12}},{{"buffer":0,"byteOffset":{image_at},"byteLength":{}}}],
 "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[-1,-1,0],"max":[1,1,0]}},
   {{"bufferView":1,"componentType":5126,"count":4,"type":"VEC2"}},
   {{"bufferView":2,"componentType":5123,"count":6,"type":"SCALAR"}}]}}"#,
        base64(roughness),
        bin.len(),
        colour.len()
    );
    let mut json = json.into_bytes();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend(((12 + 8 + json.len() + 8 + bin.len()) as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(&json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(&bin);
    out
}

#[test]
fn gltf_images_embedded_in_a_glb_or_a_data_uri_are_read_as_textures_alike_on_gpu_and_cpu() {
    assert_eq!(base64(b"hello"), "aGVsbG8=");
    let d = fresh_dir("glb");
    let (a, b) = ([250u8, 180, 40, 255], [40u8, 120, 250, 255]);
    let colour = png_bytes(4, 4, |x, y| if (x + y) % 2 == 0 { a } else { b });
    // Roughness in green (glTF's channel): a ramp across u; red and blue say otherwise.
    let roughness = png_bytes(8, 1, |x, _| [255, 60 + 25 * x as u8, 0, 255]);
    std::fs::write(d.join("q.glb"), glb(&colour, &roughness)).unwrap();
    let toml = "[camera]\nposition = [0.0, 0.0, 3.0]\nlook_at = [0.0, 0.0, 0.0]\nvfov = 50.0\n\
                [render]\nwidth = 24\nheight = 24\nspp = 256\nmax_bounces = 4\n\
                [environment]\nradiance = [1.0, 1.0, 1.0]\n\
                [[material]]\nname = \"lamp\"\ntype = \"emissive\"\nemission = [5.0, 5.0, 5.0]\n\
                [[quad]]\norigin = [-2.0, 1.5, 2.0]\nedge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -1.0]\nmaterial = \"lamp\"\n\
                [[mesh]]\nfile = \"q.glb\"\n";
    std::fs::write(d.join("scene.toml"), toml).unwrap();
    let s = Scene::load(d.join("scene.toml")).unwrap_or_else(|e| panic!("{e}"));
    let m = &s.materials[s.meshes[0].materials[0] as usize];
    assert_eq!((m.kind, m.roughness), (rlpt::scene::MaterialKind::Glossy, 0.8));
    let (albedo, rough) = (m.albedo_texture.as_ref().unwrap(), m.roughness_texture.as_ref().unwrap());
    assert!(albedo.path.to_string_lossy().ends_with("q.glb#images[0]"), "{albedo:?}");
    assert!(rough.path.to_string_lossy().ends_with("q.glb#images[1]"), "{rough:?}");
    assert!(s.notes.iter().all(|n| !n.contains("texture")), "{:#?}", s.notes);
    // The texels are the images': colour as sRGB bytes, roughness the green, linear.
    let colour_texels = &s.textures[find(&s.textures, albedo).unwrap()].texels;
    assert_eq!(colour_texels[0].to_le_bytes(), a);
    assert_eq!(colour_texels[1].to_le_bytes(), b);
    let rough_texels: Vec<u8> =
        s.textures[find(&s.textures, rough).unwrap()].texels.iter().map(|w| w.to_le_bytes()[0]).collect();
    assert_eq!(rough_texels, (0..8).map(|x| 60 + 25 * x as u8).collect::<Vec<_>>());
    let opts = options(&s, 24, 24, 256);
    let ctx = gpu();
    let g = render_gpu(&ctx, &s, &opts);
    let c = render_cpu(&s, &opts);
    assert_films_agree(&g, &c, 4, K, "glb with embedded textures, GPU vs CPU");
    // An embedded image that is not one: refused when decoded, named by its place in the file.
    std::fs::write(d.join("q.glb"), glb(b"not a png", &roughness)).unwrap();
    let e = Scene::load(d.join("scene.toml")).unwrap_err().to_string();
    assert!(e.contains("images[0]") && e.contains("q.glb") && e.contains("cannot be read"), "{e}");
}

#[test]
fn a_conductor_albedo_texture_tints_its_fresnel_alike_on_gpu_and_cpu() {
    let d = fresh_dir("conductor");
    let (a, b) = ([255u8, 200, 64, 255], [32u8, 128, 255, 255]);
    std::fs::write(d.join("tint.png"), png_bytes(8, 8, |x, y| if (x + y) % 2 == 0 { a } else { b })).unwrap();
    // A mirror conductor facing the camera under a uniform sky of 1: each pixel
    // is the Fresnel reflectance (about 0.96 for eta 1, k 10) times the tint.
    let scene = |texture: &str| {
        let text = format!(
            "[camera]\nposition = [0.0, 0.0, 1.0]\nlook_at = [0.0, 0.0, 0.0]\nvfov = 90.0\n\
             [render]\nwidth = 16\nheight = 16\nspp = 64\nmax_bounces = 4\n\
             [environment]\nradiance = [1.0, 1.0, 1.0]\n\
             [[material]]\nname = \"metal\"\ntype = \"conductor\"\neta = [1, 1, 1]\nk = [10, 10, 10]\n{texture}\n\
             [[quad]]\norigin = [-1.0, -1.0, 0.0]\nedge_u = [2.0, 0.0, 0.0]\nedge_v = [0.0, 2.0, 0.0]\nmaterial = \"metal\"\n"
        );
        std::fs::write(d.join("scene.toml"), text).unwrap();
        Scene::load(d.join("scene.toml")).unwrap_or_else(|e| panic!("{e}"))
    };
    let (tinted, plain) = (scene("albedo_texture = \"tint.png\""), scene(""));
    let opts = options(&tinted, 16, 16, 256);
    let ctx = gpu();
    let g = render_gpu(&ctx, &tinted, &opts);
    let c = render_cpu(&tinted, &opts);
    assert_films_agree(&g, &c, 4, K, "tinted conductor, GPU vs CPU");
    // The checker's mean over the quad, which the image covers exactly.
    let p = render_cpu(&plain, &opts).mean();
    let (gm, pm) = (g.mean(), p);
    for k in 0..3 {
        let tint = (srgb(a[k]) + srgb(b[k])) / 2.0;
        let mean = |f: &rlpt::image::Image| f.pixels.iter().map(|px| px[k] as f64).sum::<f64>() / f.pixels.len() as f64;
        let (t, u) = (mean(&gm), mean(&pm));
        assert!((t / u - tint as f64).abs() < 0.02, "channel {k}: tinted/plain {} vs the mean tint {tint}", t / u);
    }
}
