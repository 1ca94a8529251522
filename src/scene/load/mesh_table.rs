//! `[[mesh]]` tables (`SCENE_FORMAT.md`, "Meshes"): a mesh file, placed by
//! `translate`/`rotate`/`scale` or a `transform` matrix, made of a scene
//! material or of the file's own (appended to the scene's materials as
//! `<file stem>/<name>`).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{DMat4, DVec3};
use toml::de::DeValue;

use super::{table_array, SceneError, Source, Table, Value, MAX_MAGNITUDE};
use crate::scene::mesh::{self, compose_transform, load_mesh_file, FileMaterial, MeshFile, PlaceError, NO_MATERIAL};
use crate::scene::{Material, Mesh};

const MESH_KEYS: &[&str] = &["file", "material", "translate", "rotate", "scale", "transform", "smooth"];

/// The `[[mesh]]` tables' meshes, the files' notes, and how their materials were mapped.
pub(super) struct ParsedMeshes {
    pub meshes: Vec<Mesh>,
    pub notes: Vec<String>,
    pub mappings: Vec<String>,
}

/// Every `[[mesh]]` table, in order, and the notes on their files (each file's
/// once, prefixed by the file). A file named by several tables is read once.
pub(super) fn parse_meshes(
    src: &Source<'_>,
    value: Option<&Value<'_>>,
    materials: &mut Vec<Material>,
    base: &Path,
) -> Result<ParsedMeshes, SceneError> {
    let mut files: HashMap<PathBuf, MeshFile> = HashMap::new();
    let mut meshes = Vec::new();
    let mut notes = Vec::new();
    let mut mappings = Vec::new();
    for table in table_array(src, "mesh", value)? {
        meshes.push(parse_mesh(&table, materials, base, &mut files, &mut notes, &mut mappings)?);
    }
    Ok(ParsedMeshes { meshes, notes, mappings })
}

fn parse_mesh(
    t: &Table<'_, '_, '_>,
    materials: &mut Vec<Material>,
    base: &Path,
    files: &mut HashMap<PathBuf, MeshFile>,
    notes: &mut Vec<String>,
    mappings: &mut Vec<String>,
) -> Result<Mesh, SceneError> {
    t.check_keys(MESH_KEYS, "")?;
    let expected = "the path of a .obj, .ply, .gltf or .glb file, relative to the scene file";
    let file_value = t.required("file", expected)?;
    let file = t.string("file", file_value, expected)?;
    if file.is_empty() {
        return Err(t.error_at(file_value.span(), format!("key `file` must be {expected}, found \"\"")));
    }
    let path = base.join(file);
    let override_material = match t.get("material") {
        None => None,
        Some(v) => Some(scene_material(t, v, materials)?),
    };
    let matrix = transform(t)?;
    let smooth = match t.get("smooth") {
        None => false,
        Some(v) => t.boolean("smooth", v)?,
    };

    if !files.contains_key(&path) {
        let loaded = load_mesh_file(&path).map_err(|error| SceneError::Mesh {
            file: t.src.file.to_string(),
            position: Some(t.src.line_col(file_value.span().start)),
            table: t.label.clone(),
            error: Box::new(error),
        })?;
        notes.extend(loaded.notes.iter().map(|note| format!("{}: {note}", path.display())));
        files.insert(path.clone(), loaded);
    }
    let f = &files[&path];
    let shown = path.display();

    let per_file_triangle: Vec<u32> = match override_material {
        Some(m) => vec![m; f.triangles.len()],
        None => {
            if f.triangle_materials.is_empty() {
                return Err(t.error_here(format!(
                    "{shown} gives its triangles no material; give `material`, the name of a [[material]]"
                )));
            }
            let lacking = f.triangle_materials.iter().filter(|&&m| m == NO_MATERIAL).count();
            if lacking > 0 {
                return Err(t.error_here(format!(
                    "{lacking} of the {} triangles of {shown} have no material in the file (faces before any \
                     `usemtl` or after one that names no material of its `mtllib`, or glTF primitives without \
                     `material`); give `material`, the name of a [[material]], for the whole mesh",
                    f.triangles.len()
                )));
            }
            let stem = path.file_stem().map_or_else(|| "mesh".to_string(), |s| s.to_string_lossy().into_owned());
            let indices: Vec<u32> =
                f.materials.iter().map(|m| add_file_material(materials, mappings, &stem, m)).collect();
            f.triangle_materials.iter().map(|&m| indices[m as usize]).collect()
        }
    };

    let placed = mesh::place(f, &matrix, smooth, MAX_MAGNITUDE).map_err(|e| match e {
        PlaceError::OutOfRange { vertex, position } => t.error_here(format!(
            "vertex {vertex} of {shown} lies at [{}, {}, {}] after the transform; expected every vertex within \
             +-1e12 (a smaller `scale` or `translate`)",
            position.x, position.y, position.z
        )),
        PlaceError::AllDegenerate { triangles } => t.error_here(format!(
            "all {triangles} triangles of {shown} have zero area in 32-bit floats after the transform; \
             expected a `scale` or `transform` that keeps them apart"
        )),
    })?;
    if placed.skipped_degenerate > 0 {
        notes.push(format!(
            "{shown} ({}): skipped {} of its triangles, whose area is zero in 32-bit floats after the transform",
            t.label, placed.skipped_degenerate
        ));
    }
    let materials = placed.file_triangles.iter().map(|&k| per_file_triangle[k as usize]).collect();
    Ok(Mesh {
        source: path,
        positions: placed.positions,
        normals: placed.normals,
        triangles: placed.triangles,
        materials,
        uvs: f.uvs.clone(),
    })
}

/// The index of the scene material a `material` key names.
fn scene_material(t: &Table<'_, '_, '_>, v: &Value<'_>, materials: &[Material]) -> Result<u32, SceneError> {
    let name = t.string("material", v, "the name of a [[material]]")?;
    materials.iter().position(|m| m.name == name).map(|i| i as u32).ok_or_else(|| {
        let names: Vec<&str> = materials.iter().map(|m| m.name.as_str()).collect();
        let defined = if names.is_empty() { "none".to_string() } else { names.join(", ") };
        t.error_at(v.span(), format!("material \"{name}\" is not defined (defined: {defined})"))
    })
}

/// Appends a file's material as `<stem>/<name>`, or finds the same material
/// already there (a file used twice); a different one of that name becomes
/// `<stem>/<name> (2)`. A new one's mapping goes to `mappings` (`Scene::material_mappings`).
fn add_file_material(materials: &mut Vec<Material>, mappings: &mut Vec<String>, stem: &str, m: &FileMaterial) -> u32 {
    let base = format!("{stem}/{}", m.name);
    let mut material = m.material.clone();
    let mut name = base.clone();
    for k in 2.. {
        material.name = name.clone();
        match materials.iter().position(|x| x.name == name) {
            Some(i) if materials[i] == material => return i as u32,
            Some(_) => name = format!("{base} ({k})"),
            None => break,
        }
    }
    mappings.push(format!("{name}: {}", m.mapping));
    materials.push(material);
    (materials.len() - 1) as u32
}

/// The object-to-world matrix: `transform`, or `scale`, `rotate`, `translate`.
fn transform(t: &Table<'_, '_, '_>) -> Result<DMat4, SceneError> {
    let parts: Vec<(&str, &Value<'_>)> =
        ["translate", "rotate", "scale"].into_iter().filter_map(|k| t.get(k).map(|v| (k, v))).collect();
    if let Some(matrix_value) = t.get("transform") {
        if let Some(&(key, v)) = parts.first() {
            let later = if v.span().start > matrix_value.span().start { v } else { matrix_value };
            return Err(t.error_at(
                later.span(),
                format!(
                    "give either `transform` or `translate`/`rotate`/`scale`, not both (found `transform` and `{key}`)"
                ),
            ));
        }
        return matrix(t, matrix_value);
    }
    let translate = match t.get("translate") {
        None => [0.0; 3],
        Some(v) => t.point("translate", v)?,
    };
    let rotate = match t.get("rotate") {
        None => [0.0; 3],
        Some(v) => t.vec3("rotate", v, |_| true, "")?,
    };
    let scale_ok = |x: f64| x != 0.0 && x.abs() <= MAX_MAGNITUDE;
    let scale = match t.get("scale") {
        None => [1.0; 3],
        Some(v) if v.get_ref().is_array() => t.vec3("scale", v, scale_ok, "non-zero and within +-1e12")?,
        Some(v) => {
            let expected = "a non-zero number within +-1e12, or an array [x, y, z] of them";
            let x = t.number_at(v, "key `scale`", expected)?;
            if !scale_ok(x) {
                return Err(
                    t.error_at(v.span(), format!("key `scale` must be {expected}, found {}", t.src.snippet(v.span())))
                );
            }
            [x; 3]
        }
    };
    Ok(compose_transform(DVec3::from(scale), DVec3::from(rotate), DVec3::from(translate)))
}

/// `transform`: a row-major 4x4 matrix for column vectors, as 4 rows of 4
/// numbers or 16 numbers; last row 0 0 0 1; invertible.
fn matrix(t: &Table<'_, '_, '_>, v: &Value<'_>) -> Result<DMat4, SceneError> {
    let shape = "a row-major 4x4 matrix: 4 rows [a, b, c, d] of numbers (or 16 numbers), the last row [0, 0, 0, 1]";
    let wrong = |found: String| t.error_at(v.span(), format!("key `transform` must be {shape}, found {found}"));
    let DeValue::Array(items) = v.get_ref() else {
        return Err(wrong(t.src.describe(v)));
    };
    let mut elements: Vec<&Value<'_>> = Vec::with_capacity(16);
    if items.len() == 4 && items.iter().all(|r| r.get_ref().is_array()) {
        for (r, row) in items.iter().enumerate() {
            let DeValue::Array(row_items) = row.get_ref() else { unreachable!("checked above") };
            if row_items.len() != 4 {
                return Err(t.error_at(
                    row.span(),
                    format!("key `transform` row {} must have 4 numbers, found {}", r + 1, t.src.describe(row)),
                ));
            }
            elements.extend(row_items.iter());
        }
    } else if items.len() == 16 {
        elements.extend(items.iter());
    } else {
        return Err(wrong(t.src.describe(v)));
    }
    let mut rows = [0.0f64; 16];
    for (k, element) in elements.iter().enumerate() {
        let what = format!("key `transform` row {} column {}", k / 4 + 1, k % 4 + 1);
        let x = t.number_at(element, &what, "a number within +-1e12")?;
        if x.abs() > MAX_MAGNITUDE {
            return Err(t.error_at(
                element.span(),
                format!("{what} must be a number within +-1e12, found {}", t.src.snippet(element.span())),
            ));
        }
        rows[k] = x;
    }
    if rows[12..] != [0.0, 0.0, 0.0, 1.0] {
        return Err(t.error_at(
            elements[12].span(),
            format!(
                "key `transform` must have the last row [0, 0, 0, 1] (an affine transform), found [{}, {}, {}, {}]",
                rows[12], rows[13], rows[14], rows[15]
            ),
        ));
    }
    // Row-major in, so the column-major constructor builds the transpose.
    let m = DMat4::from_cols_array(&rows).transpose();
    let det = m.determinant();
    if !det.is_finite() || det == 0.0 {
        return Err(
            t.error_at(v.span(), format!("key `transform` must be invertible, found a matrix of determinant {det}"))
        );
    }
    Ok(m)
}
