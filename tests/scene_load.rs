//! Scenes that must load, and what they load to.

use std::path::{Path, PathBuf};

use glam::Vec3;
use rlpt::scene::{GuidingSettings, MaterialKind, RenderSettings, Scene};

fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes")
}

fn load(name: &str) -> Scene {
    let path = scenes_dir().join(name);
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

fn close(a: Vec3, b: Vec3, tolerance: f32) -> bool {
    (a - b).abs().max_element() <= tolerance
}

#[test]
fn every_scene_in_the_scenes_directory_loads() {
    let mut loaded = Vec::new();
    for entry in std::fs::read_dir(scenes_dir()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("toml") {
            continue;
        }
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(scene.source, path);
        assert!(!scene.materials.is_empty());
        assert!(!scene.spheres.is_empty() || !scene.quads.is_empty() || !scene.meshes.is_empty());
        assert!((scene.camera.forward.length() - 1.0).abs() < 1e-6);
        let n = scene.materials.len() as u32;
        assert!(scene.spheres.iter().all(|s| s.material < n));
        assert!(scene.quads.iter().all(|q| q.material < n));
        for mesh in &scene.meshes {
            assert_eq!(mesh.materials.len(), mesh.triangles.len());
            assert!(mesh.materials.iter().all(|&m| m < n));
            assert!(mesh.triangles.iter().flatten().all(|&i| (i as usize) < mesh.positions.len()));
        }
        // A [guiding] table, where a scene has one, keeps its promises.
        let g = &scene.guiding;
        assert_eq!(g.bounds_min.is_some(), g.bounds_max.is_some());
        if let (Some(min), Some(max)) = (g.bounds_min, g.bounds_max) {
            assert!(max.cmpgt(min).all() && (max - min).is_finite(), "{g:?}");
        }
        if let Some(r) = g.resolution {
            assert!(r.iter().all(|&n| (1..=256).contains(&n)) && r.iter().product::<u32>() <= 262_144, "{g:?}");
        }
        loaded.push(path.file_name().unwrap().to_string_lossy().into_owned());
    }
    for expected in ["smallpt.toml", "door.toml", "furnace-open.toml", "furnace-closed.toml"] {
        assert!(loaded.iter().any(|name| name == expected), "{expected} not among {loaded:?}");
    }
}

#[test]
fn smallpt() {
    let scene = load("smallpt.toml");
    assert_eq!(scene.spheres.len(), 9);
    assert!(scene.quads.is_empty());
    for wall in &scene.spheres[..6] {
        assert_eq!(wall.radius, 1e5);
    }
    assert_eq!(scene.spheres[0].center, Vec3::new(100001.0, 40.8, 81.6));
    assert_eq!(scene.spheres[8].radius, 600.0);

    let camera = &scene.camera;
    assert_eq!(camera.position, Vec3::new(50.0, 52.0, 295.6));
    assert_eq!(camera.near, 140.0);
    assert_eq!(camera.vfov_deg, 28.7993);
    assert_eq!(camera.up, Vec3::Y);
    assert!((camera.forward.length() - 1.0).abs() < 1e-6);
    let expected = Vec3::new(0.0, -0.042612, -1.0).normalize();
    assert!(close(camera.forward, expected, 1e-6), "{:?}", camera.forward);

    assert_eq!(
        scene.render,
        RenderSettings { width: 640, height: 480, spp: 64, max_bounces: 64, russian_roulette_depth: Some(5) }
    );
    assert_eq!(scene.environment, Vec3::ZERO);

    let names: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["red", "blue", "white", "black", "mirror", "glass", "light"]);
    // Spheres refer to materials by index.
    let material_of = |i: usize| scene.materials[scene.spheres[i].material as usize].name.as_str();
    assert_eq!(material_of(0), "red");
    assert_eq!(material_of(1), "blue");
    assert_eq!(material_of(7), "glass");
    assert_eq!(material_of(8), "light");

    let glass = &scene.materials[5];
    assert_eq!(glass.kind, MaterialKind::Dielectric);
    assert_eq!(glass.ior, 1.5);
    assert_eq!(glass.albedo, Vec3::splat(0.999));
    assert_eq!(glass.roughness, 1.0);

    let light = &scene.materials[6];
    assert_eq!(light.kind, MaterialKind::Emissive);
    assert_eq!(light.emission, Vec3::splat(12.0));
    assert_eq!(light.albedo, Vec3::ZERO);
    assert_eq!(light.roughness, 1.0);
    assert_eq!(light.ior, 1.0);
    assert!(!light.two_sided);

    let mirror = &scene.materials[4];
    assert_eq!(mirror.kind, MaterialKind::Specular);
    assert_eq!(mirror.ior, 1.0);
    assert_eq!(mirror.roughness, 1.0);
}

#[test]
fn door() {
    let scene = load("door.toml");
    assert_eq!(scene.quads.len(), 10);
    assert!(scene.spheres.is_empty());
    assert_eq!(scene.render.russian_roulette_depth, Some(5));
    assert_eq!(scene.render.max_bounces, 16);
    assert_eq!((scene.render.width, scene.render.height), (480, 320));
    assert_eq!(scene.render.spp, 256);
    let lamp = &scene.quads[9];
    assert_eq!(lamp.origin, Vec3::new(7.0, 2.99, 3.5));
    assert_eq!(scene.materials[lamp.material as usize].name, "lamp");
    // look_at = [6.0, 1.0, 3.5] from [1.0, 1.6, 0.8]
    let expected = Vec3::new(5.0, -0.6, 2.7).normalize();
    assert!(close(scene.camera.forward, expected, 1e-6));
}

#[test]
fn furnaces() {
    let open = load("furnace-open.toml");
    assert_eq!(open.environment, Vec3::ONE);
    assert_eq!(open.render.russian_roulette_depth, None);

    let closed = load("furnace-closed.toml");
    let m = &closed.materials[0];
    assert_eq!(m.kind, MaterialKind::Diffuse);
    assert_eq!(m.albedo, Vec3::splat(0.5));
    assert_eq!(m.emission, Vec3::splat(0.5));
    assert!(m.two_sided);
    assert_eq!(closed.render.max_bounces, 64);
}

const MINIMAL: &str = "\
[camera]
position = [0, 0, 5]
look_at = [0, 0, 0]
vfov = 45

[[material]]
name = \"grey\"
type = \"diffuse\"
albedo = [0.5, 0.5, 0.5]

[[sphere]]
center = [0, 0, 0]
radius = 1
material = \"grey\"
";

#[test]
fn defaults_are_filled_in() {
    let scene = Scene::parse(MINIMAL, "minimal").unwrap();
    assert_eq!(scene.source, PathBuf::from("<string>"));
    assert_eq!(scene.render, RenderSettings::default());
    assert_eq!(
        scene.render,
        RenderSettings { width: 640, height: 480, spp: 64, max_bounces: 8, russian_roulette_depth: None }
    );
    assert_eq!(scene.environment, Vec3::ZERO);
    assert_eq!(scene.guiding, GuidingSettings::default());
    assert_eq!(scene.camera.up, Vec3::Y);
    assert_eq!(scene.camera.near, 0.0);
    assert_eq!(scene.camera.forward, Vec3::NEG_Z);
    let m = &scene.materials[0];
    assert_eq!(m.emission, Vec3::ZERO);
    assert!(!m.two_sided);
    assert_eq!(m.roughness, 1.0);
    assert_eq!(m.ior, 1.0);
}

#[test]
fn empty_render_and_environment_tables_mean_defaults() {
    let text = format!("[render]\n[environment]\n{MINIMAL}");
    let scene = Scene::parse(&text, "t").unwrap();
    assert_eq!(scene.render, RenderSettings::default());
    assert_eq!(scene.environment, Vec3::ZERO);
}

#[test]
fn dielectric_albedo_defaults_to_one() {
    let text = MINIMAL.replace("type = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]", "type = \"dielectric\"\nior = 1.33");
    let scene = Scene::parse(&text, "t").unwrap();
    let m = &scene.materials[0];
    assert_eq!(m.kind, MaterialKind::Dielectric);
    assert_eq!(m.albedo, Vec3::ONE);
    assert_eq!(m.ior, 1.33);
    assert_eq!(m.roughness, 1.0);
}

#[test]
fn dielectric_roughness_zero_is_the_smooth_dielectric_and_above_zero_the_rough_one() {
    for (key, kind, roughness) in [
        ("", MaterialKind::Dielectric, 1.0),
        ("\nroughness = 0", MaterialKind::Dielectric, 1.0),
        ("\nroughness = 0.3", MaterialKind::RoughDielectric, 0.3),
    ] {
        let text = MINIMAL
            .replace("type = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]", &format!("type = \"dielectric\"\nior = 1.5{key}"));
        let m = &Scene::parse(&text, "t").unwrap().materials[0];
        assert_eq!((m.kind, m.roughness, m.ior), (kind, roughness, 1.5), "{key:?}");
    }
}

#[test]
fn conductor_and_coated_keep_their_keys() {
    let text = MINIMAL.replace(
        "type = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]",
        "type = \"conductor\"\neta = [0.2, 0.9, 1.1]\nk = [3.9, 2.5, 2.1]",
    );
    let m = &Scene::parse(&text, "t").unwrap().materials[0];
    assert_eq!((m.kind, m.roughness), (MaterialKind::Conductor, 0.0), "roughness defaults to 0, a mirror");
    assert_eq!((m.eta, m.k), (Vec3::new(0.2, 0.9, 1.1), Vec3::new(3.9, 2.5, 2.1)));
    let text = MINIMAL.replace("type = \"diffuse\"", "type = \"coated\"\nroughness = 0.2");
    let m = &Scene::parse(&text, "t").unwrap().materials[0];
    assert_eq!((m.kind, m.roughness, m.ior, m.albedo), (MaterialKind::Coated, 0.2, 1.5, Vec3::splat(0.5)));
}

#[test]
fn glossy_keeps_its_roughness() {
    let text = MINIMAL.replace("type = \"diffuse\"", "type = \"glossy\"\nroughness = 0.25");
    let scene = Scene::parse(&text, "t").unwrap();
    assert_eq!(scene.materials[0].kind, MaterialKind::Glossy);
    assert_eq!(scene.materials[0].roughness, 0.25);
    assert_eq!(scene.materials[0].ior, 1.0);
}

#[test]
fn look_at_and_direction_agree() {
    let with_look_at =
        MINIMAL.replace("position = [0, 0, 5]\nlook_at = [0, 0, 0]", "position = [1, 2, 3]\nlook_at = [4, 6, 3]");
    let with_direction =
        MINIMAL.replace("position = [0, 0, 5]\nlook_at = [0, 0, 0]", "position = [1, 2, 3]\ndirection = [3, 4, 0]");
    let a = Scene::parse(&with_look_at, "a").unwrap().camera;
    let b = Scene::parse(&with_direction, "b").unwrap().camera;
    assert!(close(a.forward, b.forward, 1e-7), "{:?} vs {:?}", a.forward, b.forward);
    assert!(close(a.forward, Vec3::new(0.6, 0.8, 0.0), 1e-7));
    assert_eq!(a, b);
}

#[test]
fn direction_need_not_be_unit() {
    let text = MINIMAL.replace("look_at = [0, 0, 0]", "direction = [0, 0, -1e-20]");
    let scene = Scene::parse(&text, "t").unwrap();
    assert_eq!(scene.camera.forward, Vec3::NEG_Z);
}

#[test]
fn integers_are_accepted_for_floats() {
    let text = "\
[camera]
position = [0, 1, 0]
direction = [0, 0, -1]
up = [0, 1, 0]
vfov = 90
near = 2

[environment]
radiance = [1, 2, 3]

[[material]]
name = \"a\"
type = \"glossy\"
albedo = [1, 0, 1]
roughness = 1
emission = [4, 5, 6]

[[material]]
name = \"b\"
type = \"dielectric\"
ior = 2

[[sphere]]
center = [1, -2, 3]
radius = 7
material = \"a\"

[[quad]]
origin = [0, 0, 0]
edge_u = [2, 0, 0]
edge_v = [0, 0, -3]
material = \"b\"
";
    let scene = Scene::parse(text, "t").unwrap();
    assert_eq!(scene.camera.position, Vec3::Y);
    assert_eq!(scene.camera.vfov_deg, 90.0);
    assert_eq!(scene.camera.near, 2.0);
    assert_eq!(scene.environment, Vec3::new(1.0, 2.0, 3.0));
    assert_eq!(scene.materials[0].albedo, Vec3::new(1.0, 0.0, 1.0));
    assert_eq!(scene.materials[0].emission, Vec3::new(4.0, 5.0, 6.0));
    assert_eq!(scene.materials[1].ior, 2.0);
    assert_eq!(scene.spheres[0].center, Vec3::new(1.0, -2.0, 3.0));
    assert_eq!(scene.spheres[0].radius, 7.0);
    assert_eq!(scene.quads[0].edge_v, Vec3::new(0.0, 0.0, -3.0));
    assert_eq!(scene.quads[0].material, 1);
}

#[test]
fn other_toml_spellings_are_accepted() {
    // Inline tables, an inline array of tables, hex integers, underscores,
    // exponents and a dotted key are all just TOML.
    let text = "\
camera = { position = [0, 0, 5], look_at = [0, 0, 0], vfov = 4.5e1 }
render.width = 0x100
render.height = 1_000
material = [
  { name = \"grey\", type = \"diffuse\", albedo = [0.5, 0.5, 0.5] },
  { name = \"lamp\", type = \"emissive\", emission = [1e1, 0, 0], two_sided = true },
]
[[quad]]
origin = [0, 0, 0]
edge_u = [1, 0, 0]
edge_v = [0, 1, 0]
material = \"lamp\"
";
    let scene = Scene::parse(text, "t").unwrap();
    assert_eq!(scene.camera.vfov_deg, 45.0);
    assert_eq!((scene.render.width, scene.render.height), (256, 1000));
    assert_eq!(scene.materials.len(), 2);
    assert!(scene.materials[1].two_sided);
    assert_eq!(scene.materials[1].emission, Vec3::new(10.0, 0.0, 0.0));
    assert_eq!(scene.quads[0].material, 1);
}

#[test]
fn materials_may_follow_the_geometry() {
    let text = "\
[[sphere]]
center = [0, 0, 0]
radius = 1
material = \"late\"

[camera]
position = [0, 0, 5]
look_at = [0, 0, 0]
vfov = 45

[[material]]
name = \"late\"
type = \"specular\"
albedo = [0.9, 0.9, 0.9]
";
    let scene = Scene::parse(text, "t").unwrap();
    assert_eq!(scene.spheres[0].material, 0);
    assert_eq!(scene.materials[0].kind, MaterialKind::Specular);
}

#[test]
fn limits_are_inclusive() {
    let text = format!(
        "[render]\nwidth = 16384\nheight = 1\nspp = 1\nmax_bounces = 1024\nrussian_roulette_depth = 0\n{MINIMAL}"
    );
    let scene = Scene::parse(&text, "t").unwrap();
    assert_eq!(
        scene.render,
        RenderSettings { width: 16384, height: 1, spp: 1, max_bounces: 1024, russian_roulette_depth: Some(0) }
    );
    let zero_bounces = format!("[render]\nmax_bounces = 0\n{MINIMAL}");
    assert_eq!(Scene::parse(&zero_bounces, "t").unwrap().render.max_bounces, 0);
    let edges = MINIMAL.replace(
        "type = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]",
        "type = \"dielectric\"\nior = 1\nalbedo = [0, 1, 0.0]",
    );
    let scene = Scene::parse(&edges, "t").unwrap();
    assert_eq!(scene.materials[0].ior, 1.0);
    assert_eq!(scene.materials[0].albedo, Vec3::new(0.0, 1.0, 0.0));
}

#[test]
fn up_is_kept_as_written() {
    let text = MINIMAL.replace("vfov = 45", "vfov = 45\nup = [0, 2, 1]");
    let scene = Scene::parse(&text, "t").unwrap();
    assert_eq!(scene.camera.up, Vec3::new(0.0, 2.0, 1.0));
}

// ---------------------------------------------------------------------------
// The `[guiding]` table (an rlpt extension).

#[test]
fn guiding_table_is_read() {
    let text = format!(
        "{MINIMAL}\n[guiding]\nbounds_min = [-1, -2.5, 0]\nbounds_max = [1e2, 3, 0.25]\nresolution = [8, 16, 0x20]\ngrid = \"adaptive\"\n"
    );
    let scene = Scene::parse(&text, "t").unwrap();
    assert_eq!(
        scene.guiding,
        GuidingSettings {
            bounds_min: Some(Vec3::new(-1.0, -2.5, 0.0)),
            bounds_max: Some(Vec3::new(100.0, 3.0, 0.25)),
            resolution: Some([8, 16, 32]),
            grid: Some(rlpt::scene::GridKind::Adaptive),
        }
    );
    // The rest of the scene is what it was without the table.
    let plain = Scene::parse(MINIMAL, "t").unwrap();
    assert_eq!(Scene { guiding: GuidingSettings::default(), ..scene }, plain);
}

#[test]
fn no_guiding_table_means_all_automatic() {
    let scene = Scene::parse(MINIMAL, "t").unwrap();
    assert_eq!(scene.guiding, GuidingSettings::default());
    assert_eq!(scene.guiding, GuidingSettings { bounds_min: None, bounds_max: None, resolution: None, grid: None });
    let empty = Scene::parse(&format!("[guiding]\n{MINIMAL}"), "t").unwrap();
    assert_eq!(empty.guiding, GuidingSettings::default());
}

#[test]
fn shipped_scenes_have_no_guiding_table_unless_they_say_so() {
    // The shared scenes predate the extension; they must load as they always did.
    for name in ["smallpt.toml", "door.toml", "furnace-open.toml", "furnace-closed.toml"] {
        let path = scenes_dir().join(name);
        let text = std::fs::read_to_string(&path).unwrap();
        let scene = load(name);
        if !text.contains("guiding") {
            assert_eq!(scene.guiding, GuidingSettings::default(), "{name}");
        }
    }
}

#[test]
fn guiding_keys_are_independent() {
    let only_resolution = Scene::parse(&format!("[guiding]\nresolution = [4, 2, 1]\n{MINIMAL}"), "t").unwrap();
    assert_eq!(only_resolution.guiding, GuidingSettings { resolution: Some([4, 2, 1]), ..Default::default() });
    let only_bounds =
        Scene::parse(&format!("[guiding]\nbounds_min = [0, 0, 0]\nbounds_max = [1, 1, 1]\n{MINIMAL}"), "t").unwrap();
    assert_eq!(
        only_bounds.guiding,
        GuidingSettings { bounds_min: Some(Vec3::ZERO), bounds_max: Some(Vec3::ONE), resolution: None, grid: None }
    );
}

#[test]
fn guiding_as_inline_or_dotted_table() {
    let inline = Scene::parse(&format!("guiding = {{ resolution = [2, 3, 4] }}\n{MINIMAL}"), "t").unwrap();
    assert_eq!(inline.guiding.resolution, Some([2, 3, 4]));
    let dotted = Scene::parse(&format!("guiding.resolution = [2, 3, 4]\n{MINIMAL}"), "t").unwrap();
    assert_eq!(dotted.guiding, inline.guiding);
}

#[test]
fn guiding_limits_are_inclusive() {
    for resolution in [[1, 1, 1], [256, 1, 1], [1, 256, 1], [64, 64, 64], [256, 256, 4], [4, 256, 256]] {
        let text = format!("[guiding]\nresolution = {resolution:?}\n{MINIMAL}");
        assert_eq!(Scene::parse(&text, "t").unwrap().guiding.resolution, Some(resolution));
    }
    // Smallpt-sized boxes, and boxes barely wider than a float step, are fine.
    let text = format!("[guiding]\nbounds_min = [-1e5, -1e5, -1e5]\nbounds_max = [1e5, 1e5, 1e5]\n{MINIMAL}");
    assert_eq!(Scene::parse(&text, "t").unwrap().guiding.bounds_max, Some(Vec3::splat(1e5)));
    let text = format!("[guiding]\nbounds_min = [0, 0, 1]\nbounds_max = [1, 1, 1.0000002]\n{MINIMAL}");
    let g = Scene::parse(&text, "t").unwrap().guiding;
    assert!(g.bounds_max.unwrap().z > g.bounds_min.unwrap().z);
}

#[test]
fn guiding_example_of_the_format_document_loads() {
    let doc = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/SCENE_FORMAT.md")).unwrap();
    let extensions = &doc[doc.find("## Extensions (rlpt)").expect("an Extensions section")..];
    let start = extensions.find("```toml\n").expect("a TOML example") + "```toml\n".len();
    let example = &extensions[start..start + extensions[start..].find("```").unwrap()];
    let text = std::fs::read_to_string(scenes_dir().join("smallpt.toml")).unwrap() + "\n" + example;
    let scene = Scene::parse(&text, "smallpt + example").unwrap();
    assert_eq!(
        scene.guiding,
        GuidingSettings {
            bounds_min: Some(Vec3::new(1.0, 0.0, 0.0)),
            bounds_max: Some(Vec3::new(99.0, 81.6, 170.0)),
            resolution: Some([16, 13, 28]),
            grid: None,
        }
    );
}
