//! The pbrt scenes of `../shared/assets/` (other people's data, never copied
//! in) load with the notes they must carry, and an imported scene shows what
//! pbrt shows: left in pbrt's image is left in rlpt's, on the CPU and the GPU.

mod common;
mod pbrt_support;

use common::cli::fresh_dir;
use common::files::{assets, write};
use glam::Vec3;
use pbrt_support::note;
use rlpt::scene::{MaterialKind, Scene};

fn triangles(s: &Scene) -> usize {
    s.meshes.iter().map(|m| m.triangles.len()).sum()
}

/// The zero-area triangles a note says were skipped ("skipped N zero-area triangles").
fn skipped(s: &Scene) -> usize {
    s.notes.iter().filter_map(|n| n.split("skipped ").nth(1)?.split(' ').next()?.parse::<usize>().ok()).sum()
}

#[test]
fn veach_ajar_loads_with_its_instances_and_the_jpeg_textures_named() {
    let s = Scene::load(assets().join("veach_ajar_pbrt/scene.pbrt")).unwrap_or_else(|e| panic!("{e}"));
    let plys = s.meshes.iter().filter(|m| m.source.extension().is_some_and(|e| e == "ply")).count();
    assert_eq!(plys, 21, "21 plymesh references, the teapots' instanced three times");
    // 382,688 triangles after instancing, and the light's quad.
    assert_eq!(triangles(&s) + skipped(&s), 382_688 + 2);
    assert_eq!((s.render.width, s.render.height, s.render.max_bounces), (1280, 720, 13));
    for missing in ["landscape-with-a-lake", "Good Textures_005844"] {
        let n = note(&s, &format!("texture image \"textures/{missing}.tga\""));
        assert!(n.contains("is missing") && n.contains(&format!("textures_jpg_mitsuba_release/{missing}.jpg")), "{n}");
    }
    // The three image textures are read as textures (the door's TGA, the two JPEGs).
    assert_eq!(s.textures.len(), 3);
    let door = s.materials.iter().find(|m| m.name == "Door").unwrap();
    assert!(door.albedo_texture.as_ref().unwrap().path.ends_with("textures/cherry-wood-texture.tga"));
    let light: Vec<_> = s.materials.iter().filter(|m| m.emits()).collect();
    assert_eq!(light.len(), 1);
    assert_eq!((light[0].emission, light[0].two_sided), (Vec3::splat(1000.0), false));
    let floor = s.materials.iter().find(|m| m.name == "Floor").unwrap();
    // Aluminium (pbrt-v3 metal, u/v roughness 0.1 not remapped: alpha 0.1).
    assert_eq!(floor.kind, MaterialKind::Conductor);
    assert!((floor.roughness - 0.1f32.sqrt()).abs() < 1e-6 && floor.k.x > 9.0, "{floor:?}");
    assert!(s.material_mappings.iter().any(|l| l.starts_with("Material: glass -> dielectric")));
}

#[test]
fn bmw_loads_with_a_uniform_sky_for_its_missing_environment_map() {
    let s = Scene::load(assets().join("bmw_m6_pbrt/bmw-m6.pbrt")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.meshes.len(), 114);
    assert_eq!(triangles(&s) + skipped(&s), 792_746);
    let n = note(&s, "the environment image \"textures/sunflowers_equiarea.exr\"");
    assert!(n.contains("does not exist") && n.contains("uniform sky"), "{n}");
    assert_eq!(s.environment, Vec3::ONE);
    let paint = s.materials.iter().find(|m| m.name == "CarPaint").unwrap();
    assert_eq!((paint.kind, paint.ior, paint.albedo), (MaterialKind::Coated, 1.5, Vec3::splat(0.7)));
    // Its smooth coats are smooth, and its wheel rims aluminium under one, without a note.
    assert_eq!(paint.roughness, 0.0);
    let rim = s.materials.iter().find(|m| m.name == "WheelRim").unwrap();
    assert_eq!((rim.kind, rim.roughness, rim.ior), (MaterialKind::Coated, 0.0, 1.5));
    assert_eq!((rim.eta.x, rim.k.x), (1.65746, 9.22387));
    assert!((rim.base_roughness.expect("a conductor base") - 0.05f32.sqrt().sqrt()).abs() < 1e-6);
    assert!(!s.notes.iter().any(|n| n.contains("CarPaint") || n.contains("WheelRim")), "{:#?}", s.notes);
    // Its leather mixes a diffuse and a coated material: one of the two per hit, without a note.
    let leather = s.materials.iter().find(|m| m.name == "LEATHER").unwrap();
    let name = |i: u32| s.materials[i as usize].name.as_str();
    let [a, b] = leather.mix.expect("a mix");
    assert_eq!(
        (leather.kind, name(a), name(b), leather.albedo.x),
        (MaterialKind::Mix, "LEATHER-black", "LEATHER-white", 0.2)
    );
    assert_eq!(s.materials[b as usize].kind, MaterialKind::Coated);
    assert!(!s.notes.iter().any(|n| n.contains("(mix)")), "{:#?}", s.notes);
    assert!((s.camera.vfov_deg - 30.0).abs() < 1e-6, "1400x1000 is landscape: fov is vertical");
}

/// A black scene with one emitting sphere at pbrt camera x = -1 (left in pbrt's
/// image), seen through a plain LookAt, whose camera space is left-handed.
const LEFT_LAMP: &str = "Film \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 16\n\
    LookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\" \"float fov\" 40\nWorldBegin\n\
    AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [4 4 4]\nTranslate -1 0 5\nShape \"sphere\" \"float radius\" 0.6\nAttributeEnd\n\
    Shape \"trianglemesh\" \"point3 P\" [-50 -3 -50  50 -3 -50  50 -3 50  -50 -3 50] \"integer indices\" [0 1 2 0 2 3]\n";

fn halves(film: &rlpt::film::Film) -> (f64, f64) {
    let (left, _, _) = common::region_stats(film, |x, _| x < film.width / 2);
    let (right, _, _) = common::region_stats(film, |x, _| x >= film.width / 2);
    (left, right)
}

#[test]
fn left_in_pbrt_is_left_in_rlpt_on_cpu_and_gpu() {
    let d = fresh_dir("orientation");
    let p = write(&d, "scene.pbrt", LEFT_LAMP);
    let s = Scene::load(&p).unwrap();
    let opts = common::options(&s, 32, 16, 128);
    let cpu = common::render_cpu(&s, &opts);
    let gpu = common::render_gpu(&common::gpu(), &s, &opts);
    for (name, film) in [("cpu", &cpu), ("gpu", &gpu)] {
        let (left, right) = halves(film);
        assert!(left > 4.0 * right && left > 0.0, "{name}: left half {left}, right half {right}");
    }
}
