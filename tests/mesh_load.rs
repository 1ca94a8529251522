//! Mesh files (`rlpt::scene::mesh`) from small files written here: OBJ and MTL,
//! PLY and glTF load as they say, and every refusal names the file and the line,
//! element or JSON path. The real assets, in `tests/mesh_assets.rs`; the
//! `[[mesh]]` tables of scenes in `tests/mesh_scene.rs`.

mod common;

use common::files::{base64, write};
use std::path::{Path, PathBuf};

use glam::Vec3;
use rlpt::scene::mesh::{load_mesh_file, Location, MeshError};
use rlpt::scene::MaterialKind;

/// The file must be refused with a message that starts with `{path}{at}` and
/// holds every phrase; returns the error.
#[track_caller]
fn refuse(path: &Path, at: &str, phrases: &[&str]) -> MeshError {
    let error = match load_mesh_file(path) {
        Ok(file) => panic!("{} loaded ({} triangles), expected a refusal", path.display(), file.triangles.len()),
        Err(e) => e,
    };
    let message = error.to_string();
    let prefix = format!("{}{at}", path.display());
    assert!(message.starts_with(&prefix), "{message:?} does not start with {prefix:?}");
    for phrase in phrases {
        assert!(message.contains(phrase), "{message:?} lacks {phrase:?}");
    }
    assert!(!message.contains('\n'), "{message:?} is more than one line");
    error
}

// ---------------------------------------------------------------------------
// OBJ and MTL refusals.

const TRIANGLE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

#[test]
fn obj_missing_file() {
    let dir = common::cli::fresh_dir("obj-missing");
    let e = refuse(&dir.join("nowhere.obj"), ": cannot read the mesh file: ", &["No such file"]);
    assert!(matches!(e, MeshError::Io { .. }));
}

#[test]
fn obj_malformed_lines() {
    let dir = common::cli::fresh_dir("obj-malformed");
    for (text, line, phrase) in [
        ("v 0 0\n", 1, "expected `v x y z` (with an optional w, or r g b), found 2 values"),
        ("v 0 0 0\nv 1 x 0\n", 2, "expected a number for the vertex coordinate y, found `x`"),
        ("v 0 0 0\nvn 1 0\n", 2, "expected `vn x y z`, found 2 values"),
        ("v 0 0 0\nv 1 0 0\n\n# comment\nf 1 2\n", 5, "a face needs at least 3 vertices, found 2"),
        ("v 0 0 0\nf 1/1/1/1 1 1\n", 2, "expected a face corner `v`, `v/vt`, `v//vn` or `v/vt/vn`, found `1/1/1/1`"),
        ("v 0 0 0\nf 1 a 1\n", 2, "expected an integer vertex index in the face corner `a`, found `a`"),
        ("v 0 0 0\nf 0 1 1\n", 2, "vertex index 0 in the face corner `0`; OBJ indices count from 1"),
        ("v 0 0 0\nusemtl\n", 2, "`usemtl` without a name"),
        ("mtllib\n", 1, "`mtllib` without a file name"),
    ] {
        let path = write(&dir, "bad.obj", text);
        let e = refuse(&path, &format!(":{line}: "), &[phrase]);
        assert_eq!(e.location(), Location::Line(line));
        assert!(matches!(e, MeshError::Malformed { .. }), "{e:?}");
    }
}

#[test]
fn obj_index_out_of_range() {
    let dir = common::cli::fresh_dir("obj-range");
    let path = write(&dir, "bad.obj", format!("{TRIANGLE_OBJ}f 1 2 3\nf 1 2 9\n"));
    let e = refuse(&path, ":5: ", &["vertex index 9 is out of range: expected 1 to 3 (the file has 3 vertices)"]);
    assert!(matches!(e, MeshError::IndexOutOfRange { index: 9, .. }));
    let path = write(&dir, "bad.obj", format!("{TRIANGLE_OBJ}f -1 -2 -4\n"));
    refuse(
        &path,
        ":4: ",
        &["relative vertex index -4 is out of range: expected -1 to -3 (the file has 3 vertices by this line)"],
    );
    let path = write(&dir, "bad.obj", format!("{TRIANGLE_OBJ}vn 0 0 1\nf 1//1 2//1 3//2\n"));
    refuse(&path, ":5: ", &["normal index 2 is out of range: expected 1 (the file has 1 normal)"]);
    // A face may name vertices that come after it (the index is checked at the end).
    let path = write(&dir, "late.obj", format!("f 1 2 3\n{TRIANGLE_OBJ}"));
    assert_eq!(load_mesh_file(&path).unwrap().triangles, vec![[0, 1, 2]]);
}

#[test]
fn obj_non_finite_coordinates() {
    let dir = common::cli::fresh_dir("obj-nan");
    for (text, line, phrase) in [
        ("v 0 0 0\nv 1 nan 0\n", 2, "vertex coordinate y is `nan` (NaN); expected a finite number"),
        ("v 0 0 inf\n", 1, "vertex coordinate z is `inf` (inf)"),
        ("v 0 0 0\nv 1e39 0 0\n", 2, "vertex coordinate x is `1e39` (inf)"),
        ("v 0 0 0\nvn 0 NaN 1\n", 2, "normal component y is `NaN` (NaN)"),
    ] {
        let path = write(&dir, "bad.obj", text);
        let e = refuse(&path, &format!(":{line}: "), &[phrase]);
        assert!(matches!(e, MeshError::NotFinite { .. }), "{e:?}");
    }
}

#[test]
fn obj_missing_and_malformed_mtl() {
    let dir = common::cli::fresh_dir("obj-mtl");
    let path = write(&dir, "box.obj", format!("# box\nmtllib box.mtl\n{TRIANGLE_OBJ}usemtl a\nf 1 2 3\n"));
    let e = refuse(&path, ":2: ", &["cannot read the material library `box.mtl`", "No such file"]);
    assert!(matches!(e, MeshError::Io { .. }));
    // An error in the MTL names the MTL and its line.
    let mtl = write(&dir, "box.mtl", "newmtl a\nKd 0.5 0.5 0.5\nKs 1 1\n");
    let e = load_mesh_file(&path).unwrap_err();
    assert_eq!(e.path(), mtl);
    assert_eq!(
        e.to_string(),
        format!("{}:3: expected `Ks r g b` (or `Ks r` for a grey), found 2 values", mtl.display())
    );
    write(&dir, "box.mtl", "newmtl a\nKd 0.5 0.5 0.5\n");
    let file = load_mesh_file(&path).unwrap();
    assert_eq!(file.materials[0].material.albedo, Vec3::splat(0.5));
}

#[test]
fn obj_faces_without_a_material() {
    let dir = common::cli::fresh_dir("obj-no-material");
    write(&dir, "m.mtl", "newmtl a\nKd 1 0 0\n");
    // Faces before any `usemtl`, and a `usemtl` of an undefined material: noted,
    // and those triangles have none (the scene then asks for `material`).
    let path = write(
        &dir,
        "m.obj",
        format!("mtllib m.mtl\n{TRIANGLE_OBJ}v 1 1 0\nf 1 2 3\nusemtl a\nf 2 4 3\nusemtl nothing\nf 1 2 4\n"),
    );
    let file = load_mesh_file(&path).unwrap();
    assert_eq!(file.triangle_materials, vec![u32::MAX, 0, u32::MAX]);
    assert!(
        file.notes[0]
            .contains("`usemtl` of materials no `mtllib` defines (their faces have no material) (`nothing` (line 9))"),
        "{:?}",
        file.notes
    );
    // Without materials at all, none is given.
    let path = write(&dir, "plain.obj", format!("{TRIANGLE_OBJ}f 1 2 3\n"));
    let file = load_mesh_file(&path).unwrap();
    assert!(file.materials.is_empty() && file.triangle_materials.is_empty() && file.notes.is_empty());
}

#[test]
fn obj_polygons_normals_and_notes() {
    let dir = common::cli::fresh_dir("obj-features");
    // A quad fan-triangulated from its first corner, negative indices, normals
    // per corner (one vertex with two normals becomes two), colours and lines noted.
    let text = "o quad\ns 1\nv 0 0 0 1 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nvn 0 0 -1\n\
                f -4/1/1 -3/1/1 -2/1/1 -1/1/1\nf 1//2 3//2 2//2\nl 1 2\ncurv 0 1 1 2\n";
    let path = write(&dir, "quad.obj", text);
    let file = load_mesh_file(&path).unwrap();
    assert_eq!(file.triangles.len(), 3);
    assert_eq!(file.positions.len(), 7);
    let normals = file.normals.as_ref().unwrap();
    let [a, b, c] = file.triangles[0];
    assert_eq!([a, b, c].map(|i| file.positions[i as usize]), [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)]);
    assert_eq!(normals[a as usize], Vec3::Z);
    assert_eq!(normals[file.triangles[2][0] as usize], -Vec3::Z);
    let note = &file.notes[0];
    for phrase in ["vertex colours", "lines and points (l, p) (line 12)", "OBJ statements rlpt does not read (`curv`)"]
    {
        assert!(note.contains(phrase), "{note}");
    }
}

#[test]
fn obj_empty_meshes() {
    let dir = common::cli::fresh_dir("obj-empty");
    let path = write(&dir, "none.obj", TRIANGLE_OBJ);
    let e = refuse(&path, ": the mesh has no triangles; ", &["expected at least one triangle of non-zero area"]);
    assert!(matches!(e, MeshError::Empty { skipped_degenerate: 0, .. }));
    let path = write(&dir, "flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\nf 1 1 2\n");
    let e = refuse(&path, ": the mesh has no triangles (all 2 of its triangles have zero area)", &[]);
    assert!(matches!(e, MeshError::Empty { skipped_degenerate: 2, .. }));
    // Some degenerate, some not: skipped and counted in one note.
    let path = write(&dir, "some.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\nf 4 4 4\n");
    let file = load_mesh_file(&path).unwrap();
    assert_eq!((file.triangles.len(), file.skipped_degenerate), (1, 2));
    assert_eq!(file.notes, vec!["skipped 2 zero-area triangles of 3".to_string()]);
}

#[test]
fn unknown_extension() {
    let dir = common::cli::fresh_dir("unknown");
    let path = write(&dir, "mesh.stl", "solid x\n");
    let e = refuse(&path, ": not a mesh file rlpt reads: expected a name ending in .obj, .ply, .gltf or .glb", &[]);
    assert!(matches!(e, MeshError::UnknownFormat { .. }));
}

// ---------------------------------------------------------------------------
// PLY refusals.

const PLY_HEADER: &str =
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                          element face 2\nproperty list uchar int vertex_indices\nend_header\n";
const PLY_VERTICES: &str = "0 0 0\n1 0 0\n0 1 0\n";

/// A binary PLY of float x y z and uchar-counted int vertex_indices.
fn binary_ply(big: bool, vertices: &[[f32; 3]], faces: &[&[i32]], declared_faces: usize) -> Vec<u8> {
    let order = if big { "big" } else { "little" };
    let mut out = format!(
        "ply\nformat binary_{order}_endian 1.0\ncomment made by a test\nelement vertex {}\nproperty float x\n\
         property float y\nproperty float z\nelement face {declared_faces}\nproperty list uchar int vertex_indices\nend_header\n",
        vertices.len()
    )
    .into_bytes();
    let f32_bytes = |x: f32| if big { x.to_be_bytes() } else { x.to_le_bytes() };
    let i32_bytes = |x: i32| if big { x.to_be_bytes() } else { x.to_le_bytes() };
    for v in vertices {
        v.iter().for_each(|&x| out.extend(f32_bytes(x)));
    }
    for f in faces {
        out.push(f.len() as u8);
        f.iter().for_each(|&i| out.extend(i32_bytes(i)));
    }
    out
}

const QUAD: [[f32; 3]; 4] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];

#[test]
fn ply_missing_file() {
    let dir = common::cli::fresh_dir("ply-missing");
    refuse(&dir.join("nowhere.ply"), ": cannot read the mesh file: ", &["No such file"]);
}

#[test]
fn ply_malformed_elements_name_the_element_and_line() {
    let dir = common::cli::fresh_dir("ply-malformed");
    let path = write(&dir, "bad.ply", format!("{PLY_HEADER}{PLY_VERTICES}3 0 1 2\n3 0 x 2\n"));
    let e = refuse(
        &path,
        ": face 1 (line 14): ",
        &["expected the count of vertex_indices and that many values on one line, as numbers, found `3 0 x 2`"],
    );
    assert_eq!(e.location(), Location::Element { name: "face".into(), index: 1, line: Some(14) });
    let path = write(&dir, "bad.ply", format!("{PLY_HEADER}0 0 0\n1 0\n"));
    refuse(&path, ": vertex 1 (line 11): ", &["expected x, y, z on one line, as numbers, found `1 0`"]);
    let path = write(&dir, "bad.ply", format!("{PLY_HEADER}{PLY_VERTICES}3 0 1 2\n2 0 1\n"));
    refuse(&path, ": face 1: ", &["a face needs at least 3 vertices in `vertex_indices`, found 2"]);
    let path = write(&dir, "bad.ply", PLY_HEADER.replace("property float z\n", "property float z\nbogus line\n"));
    refuse(&path, ":7: ", &["cannot read the header line `bogus line`"]);
    let path = write(&dir, "bad.ply", "ply\nformat ascii 1.0\nelement vertex 3\n");
    refuse(&path, ":4: ", &["the file ends inside the header; expected `end_header`"]);
    // A binary file that ends early.
    let path = write(&dir, "short.ply", binary_ply(false, &QUAD, &[&[0, 1, 2]], 2));
    refuse(
        &path,
        ": face 1: ",
        &["the file ends inside the element; expected 2 `face` elements as the header declares"],
    );
}

#[test]
fn ply_index_out_of_range() {
    let dir = common::cli::fresh_dir("ply-range");
    let path = write(&dir, "bad.ply", format!("{PLY_HEADER}{PLY_VERTICES}3 0 1 2\n3 0 1 3\n"));
    let e = refuse(&path, ": face 1: ", &["vertex index 3 is out of range: expected 0 to 2 (the file has 3 vertices)"]);
    assert!(matches!(e, MeshError::IndexOutOfRange { index: 3, .. }));
    let path = write(&dir, "bad.ply", binary_ply(true, &QUAD, &[&[0, 1, 2], &[0, -1, 2]], 2));
    refuse(&path, ": face 1: ", &["vertex index -1 is out of range"]);
}

#[test]
fn ply_non_finite_coordinates() {
    let dir = common::cli::fresh_dir("ply-nan");
    let mut vertices = QUAD;
    vertices[2][1] = f32::NAN;
    let path = write(&dir, "bad.ply", binary_ply(false, &vertices, &[&[0, 1, 2]], 1));
    let e = refuse(&path, ": vertex 2: ", &["`y` is NaN; expected a finite number"]);
    assert!(matches!(e, MeshError::NotFinite { .. }));
    let path = write(&dir, "bad.ply", format!("{PLY_HEADER}0 0 0\n1 nan 0\n"));
    refuse(&path, ": vertex 1 (line 11): ", &["a value is `nan`; expected a finite number"]);
    let doubles = PLY_HEADER.replace("float x", "double x");
    let path = write(&dir, "bad.ply", format!("{doubles}0 0 0\n1e300 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n"));
    refuse(&path, ": vertex 1: ", &["`x` is 1e300, beyond a 32-bit float; expected a finite number"]);
}

#[test]
fn ply_unsupported_property_types() {
    let dir = common::cli::fresh_dir("ply-types");
    let path = write(&dir, "bad.ply", format!("{}{PLY_VERTICES}", PLY_HEADER.replace("float y", "int y")));
    let e = refuse(&path, ": property `y` of element `vertex` has type int; expected float or double", &[]);
    assert!(matches!(e, MeshError::UnsupportedProperty { .. }));
    let path = write(&dir, "bad.ply", PLY_HEADER.replace("list uchar int", "list uchar float"));
    refuse(
        &path,
        ": property `vertex_indices` of element `face` has type list of float (counted by uchar); \
         expected a list of integers counted by an integer",
        &[],
    );
    let path = write(&dir, "bad.ply", PLY_HEADER.replace("float z", "int64 z"));
    refuse(&path, ":6: ", &["cannot read the header line `property int64 z`", "TYPE of char, uchar"]);
}

#[test]
fn ply_without_faces_is_empty() {
    let dir = common::cli::fresh_dir("ply-empty");
    let header =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
    let path = write(&dir, "points.ply", format!("{header}{PLY_VERTICES}"));
    refuse(&path, ": the mesh has no triangles; expected at least one triangle of non-zero area", &[]);
}

#[test]
fn ply_both_endians_polygons_normals_and_notes() {
    let dir = common::cli::fresh_dir("ply-good");
    let little = write(&dir, "little.ply", binary_ply(false, &QUAD, &[&[0, 1, 2, 3]], 1));
    let big = write(&dir, "big.ply", binary_ply(true, &QUAD, &[&[0, 1, 2, 3]], 1));
    let (little, big) = (load_mesh_file(&little).unwrap(), load_mesh_file(&big).unwrap());
    assert_eq!(little, big);
    assert_eq!(little.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    // ASCII with normals, colours, the `vertex_index` spelling and another element.
    let text = "ply\nformat ascii 1.0\ncomment TextureFile wood.png\nelement vertex 3\nproperty double x\n\
                property double y\nproperty double z\nproperty float nx\nproperty float ny\nproperty float nz\n\
                property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\n\
                property list uint8 uint32 vertex_index\nelement edge 1\nproperty int vertex1\nproperty int vertex2\n\
                end_header\n0 0 0 0 0 1 255 0 0\n1 0 0 0 0 1 0 255 0\n0 1 0 0 0 1 0 0 255\n3 0 1 2\n0 1\n";
    let path = write(&dir, "rich.ply", text);
    let file = load_mesh_file(&path).unwrap();
    assert_eq!(file.triangles, vec![[0, 1, 2]]);
    assert_eq!(file.normals, Some(vec![Vec3::Z; 3]));
    assert_eq!(
        file.notes,
        vec!["rlpt ignores what it cannot render: vertex colours; elements other than vertex and face (`edge`); \
              textures (wood.png)"
            .to_string()]
    );
}

// ---------------------------------------------------------------------------
// glTF refusals.

/// A one-triangle glTF whose buffer is `tri.bin` (positions, then u16 indices).
fn gltf_triangle(positions: [[f32; 3]; 3], indices: [u16; 3]) -> (serde_json::Value, Vec<u8>) {
    let mut bin = Vec::new();
    positions.iter().flatten().for_each(|x| bin.extend(x.to_le_bytes()));
    indices.iter().for_each(|i| bin.extend(i.to_le_bytes()));
    bin.extend([0, 0]);
    let json = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"uri": "tri.bin", "byteLength": 44}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}
        ]
    });
    (json, bin)
}

const TRIANGLE: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

/// Writes `tri.gltf` (and `tri.bin` unless `bin` is None) after `edit`.
fn write_gltf(dir: &Path, edit: impl FnOnce(&mut serde_json::Value, &mut Vec<u8>), bin: bool) -> PathBuf {
    let (mut json, mut data) = gltf_triangle(TRIANGLE, [0, 1, 2]);
    edit(&mut json, &mut data);
    if bin {
        write(dir, "tri.bin", &data);
    }
    write(dir, "tri.gltf", serde_json::to_vec_pretty(&json).unwrap())
}

#[test]
fn gltf_missing_or_short_buffer() {
    let dir = common::cli::fresh_dir("gltf-buffer");
    let path = write_gltf(&dir, |_, _| {}, false);
    let e = refuse(&path, ": buffers[0].uri: cannot read the buffer `tri.bin` (", &["No such file"]);
    assert!(matches!(e, MeshError::MissingBuffer { .. }));
    let path = write_gltf(&dir, |json, _| json["buffers"][0]["byteLength"] = 100.into(), true);
    refuse(
        &path,
        ": buffers[0]: byteLength is 100 but `tri.bin` holds 44 bytes; expected at least byteLength bytes",
        &[],
    );
    // A GLB without its BIN chunk, whose buffer has no uri.
    let (mut json, _) = gltf_triangle(TRIANGLE, [0, 1, 2]);
    json["buffers"][0] = serde_json::json!({"byteLength": 44});
    let mut text = serde_json::to_vec(&json).unwrap();
    text.resize(text.len().div_ceil(4) * 4, b' ');
    let mut glb = Vec::new();
    glb.extend(b"glTF");
    glb.extend(2u32.to_le_bytes());
    glb.extend((12 + 8 + text.len() as u32).to_le_bytes());
    glb.extend((text.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(&text);
    let path = write(&dir, "nobin.glb", glb);
    refuse(&path, ": buffers[0]: the buffer has no uri and the file has no GLB BIN chunk", &[]);
}

#[test]
fn gltf_accessor_out_of_bounds() {
    let dir = common::cli::fresh_dir("gltf-bounds");
    let path = write_gltf(&dir, |json, _| json["accessors"][0]["count"] = 4.into(), true);
    let e = refuse(
        &path,
        ": meshes[0].primitives[0].attributes.POSITION (accessors[0]): 4 elements of 12 bytes from byteOffset 0 \
         with stride 12 need 48 bytes of bufferViews[0], which has 36",
        &[],
    );
    assert!(matches!(e, MeshError::AccessorOutOfBounds { .. }));
    let path = write_gltf(&dir, |json, _| json["bufferViews"][1]["byteLength"] = 100.into(), true);
    refuse(
        &path,
        ": meshes[0].primitives[0].indices (accessors[1]): bufferViews[1] spans bytes 36 to 136 of buffers[0], \
         whose byteLength is 44",
        &[],
    );
}

#[test]
fn gltf_index_out_of_range_and_non_finite_positions() {
    let dir = common::cli::fresh_dir("gltf-values");
    let path = write_gltf(&dir, |_, bin| bin[40..42].copy_from_slice(&5u16.to_le_bytes()), true);
    let e = refuse(
        &path,
        ": meshes[0].primitives[0].indices[2]: vertex index 5 is out of range: expected 0 to 2 (the primitive has 3 vertices)",
        &[],
    );
    assert!(matches!(e, MeshError::IndexOutOfRange { index: 5, .. }));
    let path = write_gltf(&dir, |_, bin| bin[16..20].copy_from_slice(&f32::NAN.to_le_bytes()), true);
    refuse(&path, ": meshes[0].primitives[0].attributes.POSITION[1]: a component of element 1 is NaN", &[]);
}

#[test]
fn gltf_invalid_documents_name_the_json_path() {
    let dir = common::cli::fresh_dir("gltf-invalid");
    let path = write_gltf(&dir, |json, _| json["meshes"][0]["primitives"][0]["indices"] = 7.into(), true);
    refuse(&path, ": meshes[0].primitives[0].indices: ", &["expected the index of an existing object"]);
    let path = write_gltf(
        &dir,
        |json, _| json["extensionsRequired"] = serde_json::json!(["KHR_draco_mesh_compression"]),
        true,
    );
    refuse(&path, ": extensionsRequired[0]", &["expected no extension rlpt cannot read to be required"]);
    let path = write_gltf(&dir, |json, _| json["accessors"][0]["type"] = "VEC2".into(), true);
    refuse(
        &path,
        ": meshes[0].primitives[0].attributes.POSITION: accessors[0] is VEC2 of FLOAT; expected VEC3 of FLOAT",
        &[],
    );
    let path = write_gltf(&dir, |json, _| json["accessors"][1]["componentType"] = 5126.into(), true);
    refuse(
        &path,
        ": meshes[0].primitives[0].indices: accessors[1] is SCALAR of FLOAT; expected SCALAR of UNSIGNED_BYTE",
        &[],
    );
    // gltf-json's validation indexes POSITION's accessor unchecked: checked first here.
    let path =
        write_gltf(&dir, |json, _| json["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 9.into(), true);
    refuse(
        &path,
        ": meshes[0].primitives[0].attributes.POSITION: accessor 9 does not exist (the file has 2 accessors)",
        &[],
    );
    let path = write(&dir, "broken.gltf", "{\n  \"asset\": {\"version\": \"2.0\"},\n  oops\n}\n");
    refuse(&path, ":3: not valid glTF JSON: ", &["expected a glTF 2.0 document"]);
}

#[test]
fn gltf_nodes_modes_materials_and_embedded_buffers() {
    let dir = common::cli::fresh_dir("gltf-good");
    // The buffer as a data: URI; a parent node that mirrors in x; a strip, a
    // fan and a list of points beside the triangle; a material on one primitive.
    let path = write_gltf(
        &dir,
        |json, bin| {
            let encoded = base64(bin);
            json["buffers"][0]["uri"] = format!("data:application/octet-stream;base64,{encoded}").into();
            json["nodes"] =
                serde_json::json!([{"children": [1], "scale": [-1, 1, 1]}, {"mesh": 0, "translation": [0, 0, 2]}]);
            let tri = json["meshes"][0]["primitives"][0].clone();
            let mut strip = tri.clone();
            strip["mode"] = 5.into();
            strip["material"] = 0.into();
            let mut points = tri.clone();
            points["mode"] = 0.into();
            json["meshes"][0]["primitives"] = serde_json::json!([tri, strip, points]);
            json["materials"] = serde_json::json!([{"name": "gold", "pbrMetallicRoughness": {"baseColorFactor": [1, 0.8, 0.3, 1], "roughnessFactor": 0.02}, "emissiveFactor": [1, 1, 1], "doubleSided": true}]);
        },
        false,
    );
    let file = load_mesh_file(&path).unwrap();
    assert_eq!(file.triangles.len(), 2);
    for p in &file.positions {
        assert!(p.x <= 0.0 && p.z == 2.0, "{p}");
    }
    // Mirrored: the order is reversed, so the front side still faces +z.
    for &[a, b, c] in &file.triangles {
        let [pa, pb, pc] = [a, b, c].map(|i| file.positions[i as usize]);
        assert!((pb - pa).cross(pc - pa).z > 0.0);
    }
    assert_eq!(file.triangle_materials, vec![u32::MAX, 0]);
    let gold = &file.materials[0].material;
    assert_eq!(
        (gold.kind, gold.albedo, gold.emission, gold.two_sided),
        (MaterialKind::Specular, Vec3::new(1.0, 0.8, 0.3), Vec3::ONE, true)
    );
    assert!(file.notes[0].contains("points and lines (meshes[0].primitives[2] (mode Points))"), "{:?}", file.notes);
}

#[test]
fn gltf_with_only_zero_area_triangles_is_empty() {
    let dir = common::cli::fresh_dir("gltf-empty");
    let path = write_gltf(&dir, |_, bin| bin[40..42].copy_from_slice(&1u16.to_le_bytes()), true);
    refuse(&path, ": the mesh has no triangles (its 1 triangle has zero area)", &[]);
}
