//! Image textures (docs/SCENE_FORMAT.md, "Textures"): the lookup against
//! hand-computed values, a textured quad in a furnace (its image's mean is the
//! texture's mean albedo times the sky), the GPU against the CPU twin, UVs read
//! from OBJ, PLY, glTF and pbrt files written here, and the errors.

mod common;

use common::cli::fresh_dir;
use common::files::{png_bytes, srgb};
use common::*;
use glam::Vec2;
use rlpt::math::texture::texture_lookup;
use rlpt::prepared::PreparedScene;
use rlpt::scene::Scene;
use std::path::{Path, PathBuf};

/// Writes an RGBA8 PNG of `w` x `h` texels, rows from the top.
fn png(path: &Path, w: u32, h: u32, texel: impl Fn(u32, u32) -> [u8; 4]) {
    std::fs::write(path, png_bytes(w, h, texel)).unwrap();
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

#[test]
fn bilinear_lookup_and_srgb_decode_match_hand_computed_values() {
    let d = fresh_dir("lookup");
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

/// A checker of two colours, `n` x `n` texels.
fn checker(path: &Path, n: u32, a: [u8; 4], b: [u8; 4]) {
    png(path, n, n, |x, y| if (x + y) % 2 == 0 { a } else { b });
}

#[test]
fn checker_quad_in_a_furnace_renders_its_mean_albedo_alike_on_gpu_and_cpu() {
    let d = fresh_dir("furnace");
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

/// The furnace quad as two triangles of a mesh file (`mesh`, in `d`), its UVs
/// the quad's, under the checker's material: the same image as the quad's.
fn mesh_scene(d: &Path, mesh: &str, material: &str) -> PathBuf {
    let text = quad_scene(material);
    let text = text.split("[[quad]]").next().unwrap().to_string();
    write_scene(d, &format!("{text}[[mesh]]\nfile = \"{mesh}\"\nmaterial = \"tex\"\n"))
}

const TEX_MATERIAL: &str =
    "[[material]]\nname = \"tex\"\ntype = \"diffuse\"\nalbedo = [1.0, 1.0, 1.0]\nalbedo_texture = \"checker.png\"";

/// The corners of the quad [-1, 1]^2 and their UVs, counter-clockwise from (-1, -1).
const CORNERS: [([f32; 3], [f32; 2]); 4] = [
    ([-1.0, -1.0, 0.0], [0.0, 0.0]),
    ([1.0, -1.0, 0.0], [1.0, 0.0]),
    ([1.0, 1.0, 0.0], [1.0, 1.0]),
    ([-1.0, 1.0, 0.0], [0.0, 1.0]),
];

/// Each vertex's UV is its corner's.
fn assert_corner_uvs(scene: &Scene, what: &str) {
    let m = &scene.meshes[0];
    let uvs = m.uvs.as_ref().unwrap_or_else(|| panic!("{what}: no UVs read"));
    for (p, uv) in m.positions.iter().zip(uvs) {
        let (_, want) = CORNERS.iter().find(|(c, _)| glam::Vec3::from(*c).distance(*p) < 1e-6).expect("a corner");
        assert!(Vec2::from(*want).distance(*uv) < 1e-6, "{what}: vertex {p} has UV {uv}, expected {want:?}");
    }
}

#[test]
fn uvs_are_read_from_obj_ply_gltf_and_pbrt_files() {
    let d = fresh_dir("uvs");
    checker(&d.join("checker.png"), 4, [255, 255, 255, 255], [0, 0, 0, 255]);
    // OBJ: v/vt corners, the vt order differing from the v order.
    std::fs::write(
        d.join("q.obj"),
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 1\nvt 0 0\nvt 1 0\nvt 1 1\nf 1/2 2/3 3/4\nf 1/2 3/4 4/1\n",
    )
    .unwrap();
    assert_corner_uvs(&Scene::load(mesh_scene(&d, "q.obj", TEX_MATERIAL)).unwrap(), "OBJ");
    // PLY: s t.
    let mut ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
                   property float s\nproperty float t\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
        .to_string();
    for (p, uv) in CORNERS {
        ply += &format!("{} {} {} {} {}\n", p[0], p[1], p[2], uv[0], uv[1]);
    }
    ply += "3 0 1 2\n3 0 2 3\n";
    std::fs::write(d.join("q.ply"), ply).unwrap();
    assert_corner_uvs(&Scene::load(mesh_scene(&d, "q.ply", TEX_MATERIAL)).unwrap(), "PLY");
    // glTF: TEXCOORD_0, v down the image (flipped on reading).
    let mut bin: Vec<u8> = Vec::new();
    for (p, _) in CORNERS {
        p.iter().for_each(|x| bin.extend(x.to_le_bytes()));
    }
    for (_, uv) in CORNERS {
        [uv[0], 1.0 - uv[1]].iter().for_each(|x| bin.extend(x.to_le_bytes()));
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend(i.to_le_bytes());
    }
    std::fs::write(d.join("q.bin"), &bin).unwrap();
    let gltf = r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
 "meshes":[{"primitives":[{"attributes":{"POSITION":0,"TEXCOORD_0":1},"indices":2,"material":0}]}],
 "materials":[{"name":"m","pbrMetallicRoughness":{"baseColorFactor":[0.5,0.5,0.5,1],"metallicFactor":0,
   "baseColorTexture":{"index":0}}}],
 "textures":[{"source":0}],"images":[{"uri":"checker.png"}],
 "buffers":[{"uri":"q.bin","byteLength":92}],
 "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":32},
   {"buffer":0,"byteOffset":80,"byteLength":12}],
 "accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[-1,-1,0],"max":[1,1,0]},
   {"bufferView":1,"componentType":5126,"count":4,"type":"VEC2"},
   {"bufferView":2,"componentType":5123,"count":6,"type":"SCALAR"}]}"#;
    std::fs::write(d.join("q.gltf"), gltf).unwrap();
    let toml = quad_scene("").split("[[quad]]").next().unwrap().to_string() + "[[mesh]]\nfile = \"q.gltf\"\n";
    let s = Scene::load(write_scene(&d, &toml)).unwrap();
    assert_corner_uvs(&s, "glTF");
    // Its material reads baseColorTexture times the factor.
    let m = &s.materials[s.meshes[0].materials[0] as usize];
    assert_eq!(m.albedo, glam::Vec3::splat(0.5));
    assert!(m.albedo_texture.as_ref().unwrap().path.ends_with("checker.png"), "{m:?}");
    // pbrt: trianglemesh "point2 uv", and an imagemap with uscale.
    let pbrt = "LookAt 0 0 1  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 90\nWorldBegin\n\
                Texture \"c\" \"spectrum\" \"imagemap\" \"string filename\" \"checker.png\" \"float uscale\" 2\n\
                Material \"diffuse\" \"texture reflectance\" \"c\"\n\
                Shape \"trianglemesh\" \"point3 P\" [-1 -1 0 1 -1 0 1 1 0 -1 1 0] \"integer indices\" [0 1 2 0 2 3]\n\
                \"point2 uv\" [0 0 1 0 1 1 0 1]\n";
    std::fs::write(d.join("q.pbrt"), pbrt).unwrap();
    let s = Scene::load(d.join("q.pbrt")).unwrap_or_else(|e| panic!("{e}"));
    let uvs = s.meshes[0].uvs.as_ref().expect("pbrt UVs");
    assert_eq!(uvs.len(), 4);
    assert_eq!(uvs.iter().map(|u| u.x + u.y).sum::<f32>(), 4.0);
    let m = &s.materials[s.meshes[0].materials[0] as usize];
    assert_eq!(m.albedo_texture.as_ref().unwrap().transform, [2.0, 1.0, 0.0, 0.0]);
}

#[test]
fn a_textured_obj_mesh_renders_as_the_textured_quad_on_gpu_and_cpu() {
    let d = fresh_dir("obj-render");
    let (a, b) = ([230u8, 60, 20, 255], [20u8, 90, 200, 255]);
    checker(&d.join("checker.png"), 8, a, b);
    std::fs::write(
        d.join("q.obj"),
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n",
    )
    .unwrap();
    let mesh = Scene::load(mesh_scene(&d, "q.obj", TEX_MATERIAL)).unwrap();
    let quad = Scene::load(write_scene(&d, &quad_scene(TEX_MATERIAL))).unwrap();
    let opts = options(&mesh, 32, 32, 256);
    let ctx = gpu();
    let g = render_gpu(&ctx, &mesh, &opts);
    let c = render_cpu(&mesh, &opts);
    assert_films_agree(&g, &c, 4, K, "textured OBJ quad, GPU vs CPU");
    // The triangles' UVs give the quad's image (the quad traced on the CPU).
    assert_films_agree(&g, &render_cpu(&quad, &opts), 4, K, "textured OBJ quad (GPU) vs the textured quad (CPU)");
}

#[test]
fn a_missing_or_unreadable_texture_is_refused_with_its_path_as_written_and_resolved() {
    let d = fresh_dir("errors");
    let material = |file: &str| {
        format!(
            "[[material]]\nname = \"tex\"\ntype = \"diffuse\"\nalbedo = [1.0, 1.0, 1.0]\nalbedo_texture = \"{file}\""
        )
    };
    let e = Scene::load(write_scene(&d, &quad_scene(&material("img/none.png")))).unwrap_err().to_string();
    let resolved = d.join("img/none.png");
    assert!(e.contains("scene.toml:") && e.contains("\"img/none.png\""), "{e}");
    assert!(e.contains(&format!("resolved to {}", resolved.display())) && e.contains("does not exist"), "{e}");
    std::fs::write(d.join("bad.png"), b"not a png at all").unwrap();
    let e = Scene::load(write_scene(&d, &quad_scene(&material("bad.png")))).unwrap_err().to_string();
    assert!(e.contains("\"bad.png\"") && e.contains("cannot be read"), "{e}");
    // A texture on a material that has no albedo (an emissive one) is refused by key.
    let text = quad_scene(
        "[[material]]\nname = \"tex\"\ntype = \"emissive\"\nemission = [1, 1, 1]\nalbedo_texture = \"x.png\"",
    );
    let e = Scene::load(write_scene(&d, &text)).unwrap_err().to_string();
    assert!(e.contains("albedo_texture"), "{e}");
}

#[test]
fn a_mesh_without_uvs_takes_the_textures_mean_with_a_note() {
    let d = fresh_dir("no-uvs");
    let (a, b) = ([255u8, 255, 255, 255], [0u8, 0, 0, 255]);
    checker(&d.join("checker.png"), 2, a, b);
    std::fs::write(d.join("q.obj"), "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3 4\n").unwrap();
    let s = Scene::load(mesh_scene(&d, "q.obj", TEX_MATERIAL)).unwrap();
    let m = &s.materials[s.meshes[0].materials[0] as usize];
    assert!(m.albedo_texture.is_none() && (m.albedo - glam::Vec3::splat(0.5)).abs().max_element() < 1e-6, "{m:?}");
    assert!(s.notes.iter().any(|n| n.contains("q.obj") && n.contains("has no texture coordinates")), "{:?}", s.notes);
    // --strict refuses what it would note.
    assert!(Scene::load_with(mesh_scene(&d, "q.obj", TEX_MATERIAL), true).is_err());
}

#[test]
fn a_glossy_sphere_with_colour_and_roughness_textures_renders_alike_on_gpu_and_cpu() {
    let d = fresh_dir("sphere");
    checker(&d.join("checker.png"), 8, [250, 180, 40, 255], [40, 120, 250, 255]);
    // Roughness: a grey ramp across u, read linearly.
    png(&d.join("rough.png"), 16, 1, |x, _| {
        let g = 40 + 13 * x as u8;
        [g, g, g, 255]
    });
    let text = "[camera]\nposition = [0.0, 0.0, 4.0]\nlook_at = [0.0, 0.0, 0.0]\nvfov = 40.0\n\
         [render]\nwidth = 24\nheight = 24\nspp = 256\nmax_bounces = 4\n\
         [environment]\nradiance = [1.0, 1.0, 1.0]\n\
         [[material]]\nname = \"floor\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\
         [[material]]\nname = \"tex\"\ntype = \"glossy\"\nalbedo = [0.9, 0.9, 0.9]\nroughness = 0.8\n\
         albedo_texture = \"checker.png\"\nroughness_texture = \"rough.png\"\n\
         [[sphere]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"tex\"\n\
         [[quad]]\norigin = [-3.0, -1.0, 3.0]\nedge_u = [6.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -6.0]\nmaterial = \"floor\"\n";
    let scene = Scene::load(write_scene(&d, text)).unwrap();
    assert_eq!(scene.textures.len(), 2);
    let opts = options(&scene, 24, 24, 256);
    let ctx = gpu();
    let g = render_gpu(&ctx, &scene, &opts);
    let c = render_cpu(&scene, &opts);
    assert_films_agree(&g, &c, 4, K, "textured glossy sphere, GPU vs CPU");
}
