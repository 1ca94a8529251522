//! Mesh files of `[[mesh]]` tables: OBJ (with its MTL), PLY and glTF 2.0 (`.gltf`
//! with its buffers, and `.glb`), read into object-space triangles and rlpt
//! materials ([`load_mesh_file`]), and placed into the world ([`place`]).
//!
//! A file that cannot be read whole is refused with a [`MeshError`] that names
//! the file and where in it: the line (OBJ, MTL), the element and its index
//! (PLY, "face 12") or the JSON path (glTF, `meshes[0].primitives[1].indices`).
//! What a file asks for that rlpt does not render (textures, alpha, vertex
//! colours, a second layer of a material) is named in [`MeshFile::notes`], one
//! line per file; zero-area triangles are skipped and counted in another.
//! The material mapping rules are in `docs/SCENE_FORMAT.md` ("Meshes").

mod gltf;
mod gltf_material;
mod mtl;
mod obj;
mod place;
mod ply;

use std::fmt;
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use super::Material;

pub use place::{compose_transform, place, PlaceError, Placed};

/// [`MeshFile::triangle_materials`] of a triangle the file gives no material
/// (an OBJ face before any `usemtl`, or after one that names no material of its
/// `mtllib`; a glTF primitive without `material`).
pub const NO_MATERIAL: u32 = u32::MAX;

/// GGX roughness below which a reflective material of a file becomes a perfect
/// mirror (`specular`): the smallest roughness rlpt's GGX is tested at.
pub const SPECULAR_BELOW_ROUGHNESS: f32 = 0.05;

/// A mesh file as read: object space, triangles only.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshFile {
    pub positions: Vec<Vec3>,
    /// Per vertex (aligned with `positions`), where the file gives a normal for
    /// every vertex of every triangle; not normalised.
    pub normals: Option<Vec<Vec3>>,
    /// Texture coordinates per vertex (aligned with `positions`, v up), where
    /// the file gives them for every vertex of every triangle.
    pub uvs: Option<Vec<Vec2>>,
    /// Vertex indices; none has zero area in f32 (such triangles are skipped).
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle, the index into `materials` (or [`NO_MATERIAL`]); empty
    /// where the file gives no triangle a material.
    pub triangle_materials: Vec<u32>,
    /// The materials the triangles use, mapped onto rlpt's.
    pub materials: Vec<FileMaterial>,
    /// What the file asks for that rlpt does not do, and the skipped triangles:
    /// one line each, without the file's name.
    pub notes: Vec<String>,
    /// Zero-area triangles skipped.
    pub skipped_degenerate: usize,
}

/// A material of a mesh file, mapped onto one of rlpt's.
#[derive(Clone, Debug, PartialEq)]
pub struct FileMaterial {
    /// The name in the file (glTF's unnamed materials: `material<index>`).
    pub name: String,
    /// `material.name` is `name`; the scene renames it `<file stem>/<name>`.
    pub material: Material,
    /// One line: how the file's values became `material`.
    pub mapping: String,
}

/// Where in a file a [`MeshError`] is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Location {
    /// The file as a whole.
    File,
    /// A 1-based line (OBJ, MTL, a PLY header).
    Line(usize),
    /// A PLY element by name and 0-based index ("face 12"), with its 1-based
    /// line in an ASCII file.
    Element { name: String, index: usize, line: Option<usize> },
    /// A glTF JSON path (`meshes[0].primitives[1].indices`).
    Json(String),
}

impl Location {
    fn element(name: &str, index: usize) -> Location {
        Location::Element { name: name.to_string(), index, line: None }
    }
}

/// `file:line`, `file: face 12 (line 40)`, `file: meshes[0].primitives[1]`.
fn at(path: &Path, location: &Location) -> String {
    let p = path.display();
    match location {
        Location::File => format!("{p}"),
        Location::Line(line) => format!("{p}:{line}"),
        Location::Element { name, index, line: None } => format!("{p}: {name} {index}"),
        Location::Element { name, index, line: Some(line) } => format!("{p}: {name} {index} (line {line})"),
        Location::Json(json) => format!("{p}: {json}"),
    }
}

/// Why a mesh file was refused. The `Display` text is one sentence: the file,
/// where in it, and what was expected.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// The file (or a file it names: MTL, glTF buffer) could not be read.
    #[error("{}: cannot read {what}: {error}", at(path, location))]
    Io { path: PathBuf, location: Location, what: String, error: std::io::Error },
    /// Not a name ending in a format rlpt reads.
    #[error("{}: not a mesh file rlpt reads: expected a name ending in .obj, .ply, .gltf or .glb", path.display())]
    UnknownFormat { path: PathBuf },
    /// A line, element or JSON value that is not what the format allows.
    #[error("{}: {message}", at(path, location))]
    Malformed { path: PathBuf, location: Location, message: String },
    /// A vertex (or normal) index outside the vertices the file has.
    #[error("{}: {what} {index} is out of range: expected {expected}", at(path, location))]
    IndexOutOfRange { path: PathBuf, location: Location, what: &'static str, index: i64, expected: String },
    /// A coordinate or normal that is NaN or infinite (or beyond a 32-bit float).
    #[error("{}: {what} is {value}; expected a finite number", at(path, location))]
    NotFinite { path: PathBuf, location: Location, what: String, value: String },
    /// A PLY property of a type rlpt does not read where it is.
    #[error(
        "{}: property `{property}` of element `{element}` has type {found}; expected {expected}",
        path.display()
    )]
    UnsupportedProperty { path: PathBuf, element: String, property: String, found: String, expected: String },
    /// A glTF buffer that is not there (a missing `.bin`, a GLB without its BIN
    /// chunk, a `uri` that is no file) or shorter than it says.
    #[error("{}: {message}", at(path, location))]
    MissingBuffer { path: PathBuf, location: Location, message: String },
    /// A glTF accessor (or buffer view) reaching past the data it reads.
    #[error("{}: {message}", at(path, location))]
    AccessorOutOfBounds { path: PathBuf, location: Location, message: String },
    /// No triangles, or none left after the zero-area ones were skipped.
    #[error("{}: the mesh has no triangles{}; expected at least one triangle of non-zero area", path.display(), empty_detail(*skipped_degenerate))]
    Empty { path: PathBuf, skipped_degenerate: usize },
}

fn empty_detail(skipped: usize) -> String {
    match skipped {
        0 => String::new(),
        1 => " (its 1 triangle has zero area)".to_string(),
        n => format!(" (all {n} of its triangles have zero area)"),
    }
}

impl MeshError {
    /// The file the error is about (the OBJ's MTL where the MTL is wrong).
    pub fn path(&self) -> &Path {
        match self {
            MeshError::Io { path, .. }
            | MeshError::UnknownFormat { path }
            | MeshError::Malformed { path, .. }
            | MeshError::IndexOutOfRange { path, .. }
            | MeshError::NotFinite { path, .. }
            | MeshError::UnsupportedProperty { path, .. }
            | MeshError::MissingBuffer { path, .. }
            | MeshError::AccessorOutOfBounds { path, .. }
            | MeshError::Empty { path, .. } => path,
        }
    }

    /// Where in [`MeshError::path`] it is.
    pub fn location(&self) -> Location {
        match self {
            MeshError::Io { location, .. }
            | MeshError::Malformed { location, .. }
            | MeshError::IndexOutOfRange { location, .. }
            | MeshError::NotFinite { location, .. }
            | MeshError::MissingBuffer { location, .. }
            | MeshError::AccessorOutOfBounds { location, .. } => location.clone(),
            MeshError::UnknownFormat { .. } | MeshError::UnsupportedProperty { .. } | MeshError::Empty { .. } => {
                Location::File
            }
        }
    }
}

/// Reads a mesh file by its extension (case-insensitive): `.obj`, `.ply`,
/// `.gltf` or `.glb`.
pub fn load_mesh_file(path: &Path) -> Result<MeshFile, MeshError> {
    let extension = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match extension.as_deref() {
        Some("obj") => obj::load(path),
        Some("ply") => ply::load(path),
        Some("gltf") | Some("glb") => gltf::load(path),
        _ => Err(MeshError::UnknownFormat { path: path.to_path_buf() }),
    }
}

/// The whole of `file`, or [`MeshError::Io`] at `location` of `path` (the
/// mesh file itself, or the one that names `file`), saying `what` it is.
fn read_file(file: &Path, path: &Path, location: Location, what: &str) -> Result<Vec<u8>, MeshError> {
    std::fs::read(file).map_err(|error| MeshError::Io {
        path: path.to_path_buf(),
        location,
        what: what.to_string(),
        error,
    })
}

/// The lines of an OBJ or MTL text that hold a keyword: the 1-based line, its
/// content before any `#`, the keyword and the words after it.
fn keyword_lines(text: &str) -> impl Iterator<Item = (usize, &str, &str, Vec<&str>)> {
    text.lines().enumerate().filter_map(|(i, raw)| {
        let content = raw.split('#').next().unwrap_or("");
        let mut words = content.split_whitespace();
        let keyword = words.next()?;
        Some((i + 1, content, keyword, words.collect()))
    })
}

/// A finite f32 from `word` on `line` of a text file (OBJ, MTL): NotFinite where
/// it parses to NaN or infinity, Malformed ("expected a number for
/// {article}{what}") where it does not parse.
fn line_f32(path: &Path, line: usize, word: &str, article: &str, what: &str) -> Result<f32, MeshError> {
    match word.parse::<f32>() {
        Ok(x) if x.is_finite() => Ok(x),
        Ok(x) => Err(MeshError::NotFinite {
            path: path.to_path_buf(),
            location: Location::Line(line),
            what: what.to_string(),
            value: format!("`{word}` ({})", number(f64::from(x))),
        }),
        Err(_) => Err(MeshError::Malformed {
            path: path.to_path_buf(),
            location: Location::Line(line),
            message: format!("expected a number for {article}{what}, found `{word}`"),
        }),
    }
}

/// A number for messages: `0.5`, `1e300`, `NaN`.
fn number(x: f64) -> String {
    if x.is_nan() {
        "NaN".to_string()
    } else if x.is_finite() && x != 0.0 && !(1e-4..1e7).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// `[0.5, 0.5, 0.5]` for messages and mappings.
fn vec_text(v: Vec3) -> String {
    format!("[{}, {}, {}]", v.x, v.y, v.z)
}

// ---------------------------------------------------------------------------
// What a file asks for that rlpt does not render: one note per file.

/// Features a file uses that rlpt ignores, each with where it is used
/// (material names, JSON paths, lines), in the order first met.
#[derive(Debug, Default)]
pub(crate) struct Ignored {
    items: Vec<(String, Vec<String>)>,
}

/// Places named per feature in the note; the rest are counted.
const NOTE_PLACES: usize = 4;

impl Ignored {
    /// `feature` is used at `place` ("" where it has no place).
    pub(crate) fn add(&mut self, feature: &str, place: impl Into<String>) {
        let place = place.into();
        let index = match self.items.iter().position(|(f, _)| f == feature) {
            Some(i) => i,
            None => {
                self.items.push((feature.to_string(), Vec::new()));
                self.items.len() - 1
            }
        };
        let places = &mut self.items[index].1;
        if !place.is_empty() && !places.contains(&place) {
            places.push(place);
        }
    }

    /// "rlpt ignores: textures (of `a`, `b`); vertex colours", or None.
    pub(crate) fn note(&self) -> Option<String> {
        if self.items.is_empty() {
            return None;
        }
        let parts: Vec<String> = self
            .items
            .iter()
            .map(|(feature, places)| match places.len() {
                0 => feature.clone(),
                n => {
                    let mut shown = places[..n.min(NOTE_PLACES)].join(", ");
                    if n > NOTE_PLACES {
                        shown += &format!(" and {} more", n - NOTE_PLACES);
                    }
                    format!("{feature} ({shown})")
                }
            })
            .collect();
        Some(format!("rlpt ignores what it cannot render: {}", parts.join("; ")))
    }
}

// ---------------------------------------------------------------------------
// Assembling a MeshFile: zero-area triangles out, unused materials out, notes.

/// A file's triangles before the common checks.
#[derive(Debug, Default)]
pub(crate) struct Builder {
    pub(crate) positions: Vec<Vec3>,
    pub(crate) normals: Option<Vec<Vec3>>,
    pub(crate) uvs: Option<Vec<Vec2>>,
    pub(crate) triangles: Vec<[u32; 3]>,
    /// Per triangle, an index into `materials` or [`NO_MATERIAL`] (may be
    /// empty where no triangle has one).
    pub(crate) triangle_materials: Vec<u32>,
    pub(crate) materials: Vec<FileMaterial>,
    pub(crate) ignored: Ignored,
}

impl Builder {
    /// Skips the zero-area triangles, keeps the materials some triangle uses
    /// (in order of first use), and writes the notes. The indices must be in
    /// range and the positions finite (each reader checks, naming the place).
    pub(crate) fn finish(self, path: &Path) -> Result<MeshFile, MeshError> {
        let Builder { positions, normals, uvs, triangles, triangle_materials, materials, ignored } = self;
        let has_materials = triangle_materials.iter().any(|&m| m != NO_MATERIAL);
        let mut kept = Vec::with_capacity(triangles.len());
        let mut kept_materials = Vec::new();
        let mut remap = vec![NO_MATERIAL; materials.len()];
        let mut used: Vec<FileMaterial> = Vec::new();
        let mut skipped = 0;
        for (t, &[a, b, c]) in triangles.iter().enumerate() {
            let [pa, pb, pc] = [a, b, c].map(|i| positions[i as usize]);
            if (pb - pa).cross(pc - pa) == Vec3::ZERO {
                skipped += 1;
                continue;
            }
            kept.push([a, b, c]);
            if has_materials {
                let m = triangle_materials.get(t).copied().unwrap_or(NO_MATERIAL);
                if m == NO_MATERIAL {
                    kept_materials.push(NO_MATERIAL);
                } else {
                    if remap[m as usize] == NO_MATERIAL {
                        remap[m as usize] = used.len() as u32;
                        used.push(materials[m as usize].clone());
                    }
                    kept_materials.push(remap[m as usize]);
                }
            }
        }
        if kept.is_empty() {
            return Err(MeshError::Empty { path: path.to_path_buf(), skipped_degenerate: skipped });
        }
        let mut notes: Vec<String> = ignored.note().into_iter().collect();
        if skipped > 0 {
            let s = if skipped == 1 { "" } else { "s" };
            notes.push(format!("skipped {skipped} zero-area triangle{s} of {}", triangles.len()));
        }
        Ok(MeshFile {
            positions,
            normals,
            uvs,
            triangles: kept,
            triangle_materials: kept_materials,
            materials: used,
            notes,
            skipped_degenerate: skipped,
        })
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::File => f.write_str("the file"),
            Location::Line(line) => write!(f, "line {line}"),
            Location::Element { name, index, .. } => write!(f, "{name} {index}"),
            Location::Json(json) => f.write_str(json),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ignored_lists_features_once_with_their_places() {
        let mut ignored = Ignored::default();
        assert_eq!(ignored.note(), None);
        ignored.add("textures", "`a`");
        ignored.add("vertex colours", "");
        ignored.add("textures", "`b`");
        ignored.add("textures", "`a`");
        for name in ["c", "d", "e", "f"] {
            ignored.add("textures", format!("`{name}`"));
        }
        assert_eq!(
            ignored.note().unwrap(),
            "rlpt ignores what it cannot render: textures (`a`, `b`, `c`, `d` and 2 more); vertex colours"
        );
    }

    #[test]
    fn finish_skips_zero_area_triangles_and_unused_materials() {
        let material = |name: &str| FileMaterial {
            name: name.to_string(),
            material: Material::plain(name, crate::scene::MaterialKind::Diffuse, Vec3::splat(0.5)),
            mapping: String::new(),
        };
        let builder = Builder {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::X * 2.0],
            triangles: vec![[0, 1, 3], [0, 1, 2], [2, 2, 1]],
            triangle_materials: vec![0, 2, 1],
            materials: vec![material("unused"), material("skipped"), material("kept")],
            ..Default::default()
        };
        let file = builder.finish(Path::new("t.obj")).unwrap();
        assert_eq!(file.triangles, vec![[0, 1, 2]]);
        assert_eq!(file.triangle_materials, vec![0]);
        assert_eq!(file.materials.len(), 1);
        assert_eq!(file.materials[0].name, "kept");
        assert_eq!(file.skipped_degenerate, 2);
        assert_eq!(file.notes, vec!["skipped 2 zero-area triangles of 3".to_string()]);

        let all_flat = Builder {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0],
            triangles: vec![[0, 1, 2]],
            ..Default::default()
        };
        let e = all_flat.finish(Path::new("t.ply")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "t.ply: the mesh has no triangles (its 1 triangle has zero area); \
             expected at least one triangle of non-zero area"
        );
    }
}
