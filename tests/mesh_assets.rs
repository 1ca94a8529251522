//! Mesh files (`rlpt::scene::mesh`): the real assets of `../shared/assets/`
//! load with the triangle counts their SOURCE.md files give, their materials
//! map as `SCENE_FORMAT.md` says, and the Cornell boxes' OBJ files hold the
//! triangles the reference reader (tobj) finds. Small files written by the tests, and every
//! refusal, in `tests/mesh_load.rs`; the `[[mesh]]` tables of scenes in
//! `tests/mesh_scene.rs`.

mod common;

use std::path::Path;

use common::files::assets;
use glam::Vec3;
use rlpt::scene::mesh::{load_mesh_file, MeshFile};
use rlpt::scene::MaterialKind;

fn load(relative: &str) -> MeshFile {
    let path = assets().join(relative);
    load_mesh_file(&path).unwrap_or_else(|e| panic!("{e}"))
}

fn material<'a>(file: &'a MeshFile, name: &str) -> &'a rlpt::scene::Material {
    &file.materials.iter().find(|m| m.name == name).unwrap_or_else(|| panic!("no material {name}")).material
}

/// Each triangle's corners and its material's name, sorted: a reader-neutral
/// picture of a mesh.
fn triangle_set(triangles: impl Iterator<Item = ([Vec3; 3], String)>) -> Vec<String> {
    let mut out: Vec<String> = triangles.map(|(v, m)| format!("{v:?} {m}")).collect();
    out.sort();
    out
}

fn ours(file: &MeshFile) -> Vec<String> {
    triangle_set(file.triangles.iter().enumerate().map(|(t, tri)| {
        let name = file.materials[file.triangle_materials[t] as usize].name.clone();
        (tri.map(|i| file.positions[i as usize]), name)
    }))
}

fn tobj_reference(path: &Path) -> Vec<String> {
    let options = tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() };
    let (models, materials) = tobj::load_obj(path, &options).unwrap();
    let materials = materials.unwrap();
    triangle_set(models.iter().flat_map(|model| {
        let m = &model.mesh;
        let name = materials[m.material_id.unwrap()].name.clone();
        let p = |i: u32| Vec3::from_slice(&m.positions[3 * i as usize..3 * i as usize + 3]);
        m.indices.chunks(3).map(move |c| ([p(c[0]), p(c[1]), p(c[2])], name.clone())).collect::<Vec<_>>()
    }))
}

// ---------------------------------------------------------------------------
// The assets.

#[test]
fn cornell_box_mcguire_and_its_lamp() {
    let path = assets().join("cornell_box_mcguire/CornellBox-Original.obj");
    let file = load("cornell_box_mcguire/CornellBox-Original.obj");
    assert_eq!(file.triangles.len(), 36);
    assert_eq!(file.skipped_degenerate, 0);
    assert_eq!(file.normals, None);
    assert_eq!(file.materials.len(), 8);
    let light = material(&file, "light");
    assert_eq!(light.kind, MaterialKind::Diffuse);
    assert_eq!(light.emission, Vec3::new(17.0, 12.0, 4.0));
    assert_eq!(light.albedo, Vec3::splat(0.78));
    let left = material(&file, "leftWall");
    assert_eq!(
        (left.kind, left.albedo, left.emission),
        (MaterialKind::Diffuse, Vec3::new(0.63, 0.065, 0.05), Vec3::ZERO)
    );
    // Ka equals Kd throughout, Ks is 0: nothing to note.
    assert!(file.notes.is_empty(), "{:?}", file.notes);
    // The lamp is the two triangles of material light, facing down.
    let lamp: Vec<_> =
        (0..36).filter(|&t| file.materials[file.triangle_materials[t] as usize].name == "light").collect();
    assert_eq!(lamp.len(), 2);
    for t in lamp {
        let [a, b, c] = file.triangles[t].map(|i| file.positions[i as usize]);
        assert!((b - a).cross(c - a).normalize().y < -0.999);
    }
    assert_eq!(ours(&file), tobj_reference(&path));
}

#[test]
fn cornell_box_tinyobjloader_lamp_is_ambient_only() {
    let path = assets().join("cornell_box_tinyobjloader/cornell_box.obj");
    let file = load("cornell_box_tinyobjloader/cornell_box.obj");
    assert_eq!(file.triangles.len(), 36);
    // The front wall's face is commented out: `blue` is used by no triangle.
    let mut names: Vec<&str> = file.materials.iter().map(|m| m.name.as_str()).collect();
    names.sort();
    assert_eq!(names, ["green", "light", "red", "white"]);
    assert_eq!(material(&file, "red").albedo, Vec3::new(1.0, 0.0, 0.0));
    // Its lamp is written as `Ka 20 20 20`: rlpt reads emission from Ke only, and says so.
    assert_eq!(material(&file, "light").emission, Vec3::ZERO);
    assert_eq!(file.notes.len(), 1, "{:?}", file.notes);
    assert!(file.notes[0].contains("ambient colour Ka (rlpt reads emission from Ke) (`light`)"), "{:?}", file.notes);
    assert_eq!(ours(&file), tobj_reference(&path));
}

#[test]
fn stanford_bunny_at_every_resolution() {
    for (name, vertices, triangles) in [
        ("bun_zipper.ply", 35_947, 69_451),
        ("bun_zipper_res2.ply", 8_171, 16_301),
        ("bun_zipper_res3.ply", 1_889, 3_851),
        ("bun_zipper_res4.ply", 453, 948),
    ] {
        let file = load(&format!("stanford_bunny/{name}"));
        assert_eq!(file.positions.len(), vertices, "{name}");
        assert_eq!(file.triangles.len() + file.skipped_degenerate, triangles, "{name}");
        assert_eq!(file.normals, None);
        assert!(file.materials.is_empty() && file.triangle_materials.is_empty());
        // About 0.15 m across.
        let (lo, hi) =
            file.positions.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), &p| (l.min(p), h.max(p)));
        assert!((0.1..0.2).contains(&(hi - lo).max_element()), "{name}: {lo} {hi}");
        // `confidence` and `intensity` are ignored without a note; skipped
        // triangles are counted in one.
        assert_eq!(file.notes.len(), usize::from(file.skipped_degenerate > 0), "{name}: {:?}", file.notes);
    }
}

#[test]
fn bmw_m6_all_114_plys() {
    let dir = assets().join("bmw_m6_pbrt/geometry");
    let (mut triangles, mut vertices, mut files) = (0, 0, 0);
    for k in 1..=114 {
        let file = load_mesh_file(&dir.join(format!("mesh_{k:05}.ply"))).unwrap_or_else(|e| panic!("{e}"));
        let normals = file.normals.as_ref().expect("every BMW mesh has nx ny nz");
        assert_eq!(normals.len(), file.positions.len());
        if k == 34 {
            assert_eq!(file.triangles.len() + file.skipped_degenerate, 110_592);
        }
        triangles += file.triangles.len() + file.skipped_degenerate;
        vertices += file.positions.len();
        files += 1;
    }
    assert_eq!((files, vertices, triangles), (114, 525_850, 792_746));
}

#[test]
fn suzanne_gltf_is_rough_white_metal_with_its_textures_read() {
    let file = load("gltf_suzanne/Suzanne.gltf");
    assert_eq!(file.triangles.len() + file.skipped_degenerate, 3_936);
    assert_eq!(file.positions.len(), 11_808);
    assert!(file.normals.is_some());
    assert_eq!(file.materials.len(), 1);
    let m = &file.materials[0];
    assert_eq!(m.name, "Suzanne");
    assert_eq!((m.material.kind, m.material.albedo, m.material.roughness), (MaterialKind::Glossy, Vec3::ONE, 1.0));
    assert!(m.mapping.contains("metallicFactor 1 >= 0.5"), "{}", m.mapping);
    // Its base colour and roughness textures, files beside it, are read.
    assert!(m.material.albedo_texture.as_ref().unwrap().path.ends_with("Suzanne_BaseColor.png"), "{m:?}");
    assert!(m.material.roughness_texture.is_some() && file.uvs.is_some(), "{m:?}");
    assert!(file.notes.is_empty(), "{:?}", file.notes);
}

#[test]
fn box_textured_gltf_and_glb_are_the_same_box_turned_by_its_node() {
    let gltf = load("gltf_box_textured/glTF/BoxTextured.gltf");
    let mut glb = load("gltf_box_textured/glTF-Binary/BoxTextured.glb");
    // The same but for where the texture's image lies: the glTF's in a file, the
    // GLB's in a bufferView; both read, to the same texels.
    let (file, embedded) = (&gltf.materials[0].material.albedo_texture, &glb.materials[0].material.albedo_texture);
    let (file, embedded) = (file.as_ref().unwrap(), embedded.as_ref().unwrap());
    assert!(gltf.notes.is_empty() && glb.notes.is_empty(), "{:?} {:?}", gltf.notes, glb.notes);
    assert!(embedded.path.to_string_lossy().ends_with("BoxTextured.glb#images[0]"), "{embedded:?}");
    let decode = |r| rlpt::scene::texture::decode(r).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(decode(file).texels, decode(embedded).texels);
    glb.materials = gltf.materials.clone();
    assert_eq!(gltf, glb);
    assert_eq!(gltf.triangles.len(), 12);
    assert_eq!(gltf.positions.len(), 24);
    for p in &gltf.positions {
        assert!(p.abs().cmple(Vec3::splat(0.5 + 1e-6)).all() && (p.abs().max_element() - 0.5).abs() < 1e-6);
    }
    // The node's matrix turns z-up into y-up: each vertex normal, transformed
    // with it, still agrees with its triangle's outward normal.
    let normals = gltf.normals.as_ref().unwrap();
    for &[a, b, c] in &gltf.triangles {
        let [pa, pb, pc] = [a, b, c].map(|i| gltf.positions[i as usize]);
        let face = (pb - pa).cross(pc - pa).normalize();
        assert!(face.dot((pa + pb + pc) / 3.0) > 0.0, "counter-clockwise seen from outside");
        for i in [a, b, c] {
            assert!(normals[i as usize].normalize().dot(face) > 0.999, "{} vs {face}", normals[i as usize]);
        }
    }
    let m = &gltf.materials[0];
    assert_eq!((m.name.as_str(), m.material.kind, m.material.albedo), ("Texture", MaterialKind::Diffuse, Vec3::ONE));
    assert!(m.material.albedo_texture.as_ref().unwrap().path.ends_with("CesiumLogoFlat.png"));
}
