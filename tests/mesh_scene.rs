//! `[[mesh]]` tables of scene files: files found relative to the scene, placed
//! by scale/rotate/translate or a `transform`, normals by the inverse
//! transpose, the files' materials appended to the scene's, notes prefixed by
//! the file, and every refusal naming the scene file's line and column.

mod common;

use std::fs;
use std::path::{Path, PathBuf};

use glam::Vec3;
use rlpt::scene::{no_light_warning, MaterialKind, Scene, SceneError};

/// Lines 1-4.
const CAMERA: &str = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nvfov = 45\n";
/// Lines 5-8; a `[[mesh]]` written after it starts on line 9.
const MATERIAL: &str = "[[material]]\nname = \"red\"\ntype = \"diffuse\"\nalbedo = [0.5, 0, 0]\n";

/// A square in z = 0 of two triangles, one white (with a texture), one a lamp.
const BOX_OBJ: &str =
    "mtllib box.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nusemtl white\nf 1 2 3\nusemtl lamp\nf 1 3 4\n";
const BOX_MTL: &str = "newmtl white\nKd 0.8 0.8 0.8\nmap_Kd wood.png\nnewmtl lamp\nKe 4 4 4\n";
/// One triangle in the plane x + y = 1 with its normal (1, 1, 0) at every vertex.
const SLOPE_PLY: &str =
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                         property float nx\nproperty float ny\nproperty float nz\nelement face 1\n\
                         property list uchar int vertex_indices\nend_header\n\
                         1 0 0 1 1 0\n0 1 0 1 1 0\n1 0 1 1 1 0\n3 0 1 2\n";

/// A folder with box.obj, box.mtl and slope.ply.
fn meshes_dir(name: &str) -> PathBuf {
    let dir = common::cli::fresh_dir(&format!("mesh-scene-{name}"));
    fs::write(dir.join("box.obj"), BOX_OBJ).unwrap();
    fs::write(dir.join("box.mtl"), BOX_MTL).unwrap();
    fs::write(dir.join("slope.ply"), SLOPE_PLY).unwrap();
    dir
}

/// Writes `scene.toml` (camera, the material `red`, then `meshes`) and loads it.
fn load(dir: &Path, meshes: &str) -> (PathBuf, Result<Scene, SceneError>) {
    let path = dir.join("scene.toml");
    fs::write(&path, format!("{CAMERA}{MATERIAL}{meshes}")).unwrap();
    let scene = Scene::load(&path);
    (path, scene)
}

fn ok(dir: &Path, meshes: &str) -> Scene {
    load(dir, meshes).1.unwrap_or_else(|e| panic!("{e}"))
}

/// The scene must be refused with a message starting `scene.toml:{at}: ` and
/// holding every phrase.
#[track_caller]
fn refuse(dir: &Path, meshes: &str, at: &str, phrases: &[&str]) -> SceneError {
    let (path, result) = load(dir, meshes);
    let error = match result {
        Ok(_) => panic!("accepted, expected a refusal:\n{meshes}"),
        Err(e) => e,
    };
    let message = error.to_string();
    let prefix = format!("{}:{at}: ", path.display());
    assert!(message.starts_with(&prefix), "{message:?} does not start with {prefix:?}");
    for phrase in phrases {
        assert!(message.contains(phrase), "{message:?} lacks {phrase:?}");
    }
    assert!(!message.contains('\n'), "{message:?}");
    error
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() < 1e-5
}

#[test]
fn a_mesh_brings_its_materials_and_lights_the_scene() {
    let dir = meshes_dir("materials");
    let scene = ok(&dir, "[[mesh]]\nfile = \"box.obj\"\n");
    assert_eq!(scene.meshes.len(), 1);
    let mesh = &scene.meshes[0];
    assert_eq!(mesh.source, dir.join("box.obj"));
    assert_eq!(mesh.triangles.len(), 2);
    assert_eq!(mesh.normals, None);
    let names: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["red", "box/white", "box/lamp"]);
    assert_eq!(mesh.materials, vec![1, 2]);
    assert_eq!(scene.materials[2].kind, MaterialKind::Emissive);
    assert!(scene.emits_light() && no_light_warning(&scene).is_none());
    // One note for the file, prefixed by it.
    assert_eq!(scene.notes.len(), 1, "{:?}", scene.notes);
    assert!(scene.notes[0].starts_with(&format!("{}: rlpt ignores", dir.join("box.obj").display())));
    assert!(scene.notes[0].contains("textures (map_Kd of `white` (line 3: \"wood.png\""), "{:?}", scene.notes);
    assert!(scene.notes[0].contains("wood.png) does not exist"), "{:?}", scene.notes);

    // The file twice: its materials once, its note once.
    let scene = ok(&dir, "[[mesh]]\nfile = \"box.obj\"\n[[mesh]]\nfile = \"box.obj\"\ntranslate = [2, 0, 0]\n");
    assert_eq!(scene.materials.len(), 3);
    assert_eq!(scene.meshes[1].materials, vec![1, 2]);
    assert_eq!(scene.notes.len(), 1);

    // `material` overrides them all: nothing appended, and no light.
    let scene = ok(&dir, "[[mesh]]\nfile = \"box.obj\"\nmaterial = \"red\"\n");
    assert_eq!(scene.materials.len(), 1);
    assert_eq!(scene.meshes[0].materials, vec![0, 0]);
    assert!(!scene.emits_light());
    let warning = no_light_warning(&scene).unwrap();
    assert!(warning.contains("no sphere, quad, mesh triangle or delta light emits light"), "{warning}");
}

#[test]
fn a_mesh_alone_needs_no_material_table() {
    let dir = meshes_dir("alone");
    let path = dir.join("scene.toml");
    fs::write(&path, format!("{CAMERA}[[mesh]]\nfile = \"box.obj\"\n")).unwrap();
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.materials.len(), 2);
    assert!(scene.spheres.is_empty() && scene.quads.is_empty());
}

#[test]
fn scale_then_rotate_then_translate() {
    let dir = meshes_dir("trs");
    let scene = ok(&dir, "[[mesh]]\nfile = \"box.obj\"\nscale = 2\nrotate = [0, 90, 0]\ntranslate = [1, 2, 3]\n");
    let p = &scene.meshes[0].positions;
    // (1, 0, 0) -> (2, 0, 0) -> about y by 90 degrees (0, 0, -2) -> + (1, 2, 3).
    assert!(close(p[1], Vec3::new(1.0, 2.0, 1.0)), "{}", p[1]);
    // (1, 1, 0) -> (2, 2, 0) -> (0, 2, -2) -> (1, 4, 1).
    assert!(close(p[2], Vec3::new(1.0, 4.0, 1.0)), "{}", p[2]);
    // Rotations apply about x, then y, then z: (0, 1, 0) about x by 90 is
    // (0, 0, 1), which z leaves alone; the other order would give (-1, 0, 0).
    let scene = ok(&dir, "[[mesh]]\nfile = \"box.obj\"\nrotate = [90, 0, 90]\n");
    assert!(close(scene.meshes[0].positions[3], Vec3::Z), "{}", scene.meshes[0].positions[3]);
    // Per-axis scale.
    let scene = ok(&dir, "[[mesh]]\nfile = \"box.obj\"\nscale = [1, 2, 3]\n");
    assert!(close(scene.meshes[0].positions[2], Vec3::new(1.0, 2.0, 0.0)));
}

#[test]
fn a_transform_matrix_is_row_major_for_column_vectors() {
    let dir = meshes_dir("matrix");
    let trs = ok(&dir, "[[mesh]]\nfile = \"box.obj\"\nscale = 2\nrotate = [0, 90, 0]\ntranslate = [1, 2, 3]\n");
    // The same transform: rows of [R*S | t].
    let rows = "transform = [[0, 0, 2, 1], [0, 2, 0, 2], [-2, 0, 0, 3], [0, 0, 0, 1]]\n";
    let matrix = ok(&dir, &format!("[[mesh]]\nfile = \"box.obj\"\n{rows}"));
    let flat =
        ok(&dir, "[[mesh]]\nfile = \"box.obj\"\ntransform = [0, 0, 2, 1, 0, 2, 0, 2, -2, 0, 0, 3, 0, 0, 0, 1]\n");
    for (a, b) in trs.meshes[0].positions.iter().zip(&matrix.meshes[0].positions) {
        assert!(close(*a, *b), "{a} vs {b}");
    }
    assert_eq!(matrix.meshes[0].positions, flat.meshes[0].positions);
}

#[test]
fn smooth_normals_by_the_inverse_transpose_or_computed() {
    let dir = meshes_dir("normals");
    let scene = ok(&dir, "[[mesh]]\nfile = \"slope.ply\"\nmaterial = \"red\"\nscale = [2, 1, 1]\nsmooth = true\n");
    let expected = Vec3::new(1.0, 2.0, 0.0).normalize();
    for n in scene.meshes[0].normals.as_ref().unwrap() {
        assert!(close(*n, expected), "{n} vs {expected}");
    }
    // Computed where the file has none: the square's faces point along +z,
    // turned by the rotation.
    let scene = ok(&dir, "[[mesh]]\nfile = \"box.obj\"\nrotate = [90, 0, 0]\nsmooth = true\n");
    for n in scene.meshes[0].normals.as_ref().unwrap() {
        assert!(close(*n, -Vec3::Y), "{n}");
    }
    // A mirror keeps each triangle's front side where its normals are.
    let scene = ok(&dir, "[[mesh]]\nfile = \"box.obj\"\nscale = [-1, 1, 1]\nsmooth = true\n");
    let mesh = &scene.meshes[0];
    for (t, &[a, b, c]) in mesh.triangles.iter().enumerate() {
        let [pa, pb, pc] = [a, b, c].map(|i| mesh.positions[i as usize]);
        let face = (pb - pa).cross(pc - pa).normalize();
        assert!(close(face, Vec3::Z) && close(mesh.normals.as_ref().unwrap()[a as usize], Vec3::Z), "triangle {t}");
    }
}

#[test]
fn parse_finds_files_from_the_current_directory() {
    // `cargo test` runs in the package's root, beside which ../shared/assets lies.
    common::files::assets();
    let text = format!("{CAMERA}[[mesh]]\nfile = \"../shared/assets/cornell_box_mcguire/CornellBox-Original.obj\"\n");
    let scene = Scene::parse(&text, "cornell.toml").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.meshes[0].triangles.len(), 36);
    let lamp = scene.materials.iter().find(|m| m.name == "CornellBox-Original/light").unwrap();
    assert_eq!(lamp.emission, Vec3::new(17.0, 12.0, 4.0));
    assert!(scene.emits_light());
}

// ---------------------------------------------------------------------------
// Refusals.

#[test]
fn the_table_and_its_keys() {
    let dir = meshes_dir("keys");
    refuse(&dir, "[[mesh]]\nmaterial = \"red\"\n", "9:1", &["[[mesh]] #1: missing key `file`"]);
    refuse(&dir, "[[mesh]]\nfile = 3\n", "10:8", &["key `file` must be the path of a .obj, .ply, .gltf or .glb file"]);
    refuse(&dir, "[[mesh]]\nfile = \"\"\n", "10:8", &["found \"\""]);
    refuse(
        &dir,
        "[[mesh]]\nfile = \"box.obj\"\nscael = 2\n",
        "11:1",
        &["unknown key `scael`", "expected one of file, material"],
    );
    refuse(&dir, "[mesh]\nfile = \"box.obj\"\n", "9:1", &["`mesh` must be an array of tables, each written [[mesh]]"]);
    refuse(
        &dir,
        "[[mesh]]\nfile = \"box.obj\"\nmaterial = \"blue\"\n",
        "11:12",
        &["material \"blue\" is not defined (defined: red)"],
    );
    refuse(&dir, "[[mesh]]\nfile = \"box.obj\"\nsmooth = \"yes\"\n", "11:10", &["key `smooth` must be true or false"]);
}

#[test]
fn a_refused_mesh_file_names_the_scene_line_and_the_file() {
    let dir = meshes_dir("files");
    let e = refuse(
        &dir,
        "[[mesh]]\nfile = \"gone.obj\"\n",
        "10:8",
        &["[[mesh]] #1: ", "gone.obj: cannot read the mesh file"],
    );
    assert!(matches!(e, SceneError::Mesh { .. }));
    fs::write(dir.join("bad.obj"), "v 0 0 0\nv 1 0\n").unwrap();
    refuse(
        &dir,
        "[[mesh]]\nfile = \"bad.obj\"\n",
        "10:8",
        &[&format!("{}:2: expected `v x y z`", dir.join("bad.obj").display())],
    );
    refuse(&dir, "[[mesh]]\nfile = \"box.stl\"\n", "10:8", &["not a mesh file rlpt reads"]);
}

#[test]
fn a_mesh_without_materials_needs_one() {
    let dir = meshes_dir("no-material");
    refuse(
        &dir,
        "[[mesh]]\nfile = \"slope.ply\"\n",
        "9:1",
        &["slope.ply gives its triangles no material; give `material`"],
    );
    fs::write(dir.join("half.obj"), BOX_OBJ.replace("usemtl white\n", "")).unwrap();
    refuse(
        &dir,
        "[[mesh]]\nfile = \"half.obj\"\n",
        "9:1",
        &["1 of the 2 triangles of", "half.obj have no material in the file", "give `material`"],
    );
    ok(&dir, "[[mesh]]\nfile = \"half.obj\"\nmaterial = \"red\"\n");
}

#[test]
fn transforms_that_are_refused() {
    let dir = meshes_dir("transforms");
    let mesh = "[[mesh]]\nfile = \"box.obj\"\n";
    for (keys, at, phrase) in [
        (
            "translate = [1, 0, 0]\ntransform = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n",
            "12:13",
            "give either `transform` or `translate`/`rotate`/`scale`, not both (found `transform` and `translate`)",
        ),
        ("transform = [1, 0, 0]\n", "11:13", "key `transform` must be a row-major 4x4 matrix"),
        (
            "transform = [[1, 0, 0, 0], [0, 1, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n",
            "11:28",
            "key `transform` row 2 must have 4 numbers",
        ),
        (
            "transform = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 1, 0, 1]]\n",
            "11:57",
            "must have the last row [0, 0, 0, 1] (an affine transform), found [0, 1, 0, 1]",
        ),
        (
            "transform = [[1, 0, 0, 0], [0, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n",
            "11:13",
            "key `transform` must be invertible, found a matrix of determinant 0",
        ),
        (
            "transform = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, \"x\"], [0, 0, 0, 1]]\n",
            "11:52",
            "key `transform` row 3 column 4 must be a number",
        ),
        (
            "transform = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 2e12], [0, 0, 0, 1]]\n",
            "11:52",
            "row 3 column 4 must be a number within +-1e12",
        ),
        (
            "scale = 0\n",
            "11:9",
            "key `scale` must be a non-zero number within +-1e12, or an array [x, y, z] of them, found 0",
        ),
        ("scale = [1, 0, 1]\n", "11:13", "key `scale` must have every component non-zero and within +-1e12"),
        ("scale = \"big\"\n", "11:9", "key `scale` must be a non-zero number"),
        ("rotate = [0, 90]\n", "11:10", "key `rotate` must be an array of 3 numbers"),
        ("translate = [0, 2e12, 0]\n", "11:17", "key `translate` must have every component within +-1e12"),
    ] {
        refuse(&dir, &format!("{mesh}{keys}"), at, &[phrase]);
    }
    // Where the transform takes a vertex, or every triangle, out of range.
    refuse(
        &dir,
        &format!("{mesh}scale = 1e12\ntranslate = [1e12, 0, 0]\n"),
        "9:1",
        &["vertex 1 of", "after the transform; expected every vertex within +-1e12"],
    );
    refuse(
        &dir,
        &format!("{mesh}scale = 1e-30\n"),
        "9:1",
        &["all 2 triangles of", "have zero area in 32-bit floats after the transform"],
    );
}
