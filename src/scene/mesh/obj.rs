//! Wavefront OBJ, read by hand: `v` (with optional `w` or colour), `vn`, `vt`,
//! `f` (n-gons fan-triangulated from their first corner; `v`, `v/vt`, `v//vn`,
//! `v/vt/vn`; negative indices count back from the last vertex so far),
//! `usemtl`, `mtllib` (MTL files relative to the OBJ, `mtl.rs`), `o`, `g`, `s`.
//!
//! Not `tobj`: its errors carry no line, it finds an out-of-range index only
//! when an object ends (so no line can be named), it panics on `Kd 1 1`, and it
//! loads NaN coordinates and a `usemtl` of an undefined material without a word.
//! The tests check this reader against `tobj` on the valid files.

use std::collections::HashMap;
use std::path::Path;

use glam::{Vec2, Vec3};

use super::mtl::{self, MtlMaterial};
use super::{read_file, Builder, Ignored, Location, MeshError, MeshFile, NO_MATERIAL};

/// A corner's normal (or texture coordinate) where the face gives none.
const NO_NORMAL: u64 = u64::MAX;

/// The faces as written: corners flat, each face's first corner, line and `usemtl`.
#[derive(Default)]
struct Faces {
    /// 0-based vertex index of each corner (positive indices are checked at
    /// the end, so faces may come before their vertices).
    corner_v: Vec<u64>,
    corner_n: Vec<u64>,
    /// 0-based texture-coordinate index of each corner, or NO_NORMAL.
    corner_t: Vec<u64>,
    start: Vec<usize>,
    line: Vec<usize>,
    /// Index into the `usemtl` names, or NO_MATERIAL.
    usemtl: Vec<u32>,
}

pub(super) fn load(path: &Path) -> Result<MeshFile, MeshError> {
    let bytes = read_file(path, path, Location::File, "the mesh file")?;
    let text = String::from_utf8_lossy(&bytes);
    let dir = path.parent().unwrap_or(Path::new(""));

    let mut positions: Vec<Vec3> = Vec::new();
    let mut normals: Vec<Vec3> = Vec::new();
    let mut texcoords: Vec<Vec2> = Vec::new();
    let mut faces = Faces::default();
    let mut usemtl_names: Vec<(String, usize)> = Vec::new();
    let mut current_usemtl = NO_MATERIAL;
    let mut library: Vec<MtlMaterial> = Vec::new();
    let mut ignored = Ignored::default();

    for (line, content, keyword, rest) in super::keyword_lines(&text) {
        let malformed = |message: String| MeshError::Malformed {
            path: path.to_path_buf(),
            location: Location::Line(line),
            message,
        };
        match keyword {
            "v" => {
                if !matches!(rest.len(), 3 | 4 | 6 | 7) {
                    return Err(malformed(format!(
                        "expected `v x y z` (with an optional w, or r g b), found {} values",
                        rest.len()
                    )));
                }
                let c = |k: usize, axis: &str| coordinate(path, line, rest[k], &format!("vertex coordinate {axis}"));
                positions.push(Vec3::new(c(0, "x")?, c(1, "y")?, c(2, "z")?));
                if rest.len() >= 6 {
                    ignored.add("vertex colours", "");
                }
            }
            "vn" => {
                if rest.len() != 3 {
                    return Err(malformed(format!("expected `vn x y z`, found {} values", rest.len())));
                }
                let c = |k: usize, axis: &str| coordinate(path, line, rest[k], &format!("normal component {axis}"));
                normals.push(Vec3::new(c(0, "x")?, c(1, "y")?, c(2, "z")?));
            }
            "vt" => {
                if !matches!(rest.len(), 1..=3) {
                    return Err(malformed(format!(
                        "expected `vt u v` (v and w optional), found {} values",
                        rest.len()
                    )));
                }
                let u = coordinate(path, line, rest[0], "texture coordinate u")?;
                let v = if rest.len() > 1 { coordinate(path, line, rest[1], "texture coordinate v")? } else { 0.0 };
                texcoords.push(Vec2::new(u, v));
            }
            // Free-form parameter vertices; groups and smoothing groups
            // (`smooth` in the scene decides the shading).
            "vp" | "o" | "g" | "s" => {}
            "f" | "fo" => {
                if rest.len() < 3 {
                    return Err(malformed(format!("a face needs at least 3 vertices, found {}", rest.len())));
                }
                faces.start.push(faces.corner_v.len());
                faces.line.push(line);
                faces.usemtl.push(current_usemtl);
                for token in &rest {
                    let (v, t, n) = corner(path, line, token, [positions.len(), texcoords.len(), normals.len()])?;
                    faces.corner_v.push(v);
                    faces.corner_t.push(t);
                    faces.corner_n.push(n);
                }
            }
            "l" | "p" => ignored.add("lines and points (l, p)", format!("line {line}")),
            "mtllib" => {
                let names = content.trim_start()["mtllib".len()..].trim();
                if names.is_empty() {
                    return Err(malformed("`mtllib` without a file name; expected `mtllib FILE.mtl`".to_string()));
                }
                // One name with spaces, or several names.
                let list: Vec<&str> =
                    if dir.join(names).is_file() { vec![names] } else { names.split_whitespace().collect() };
                for name in list {
                    let mtl_path = dir.join(name);
                    let what = format!("the material library `{name}` ({})", mtl_path.display());
                    let bytes = read_file(&mtl_path, path, Location::Line(line), &what)?;
                    for m in mtl::parse(&mtl_path, &String::from_utf8_lossy(&bytes))? {
                        if library.iter().any(|l| l.name == m.name) {
                            ignored
                                .add("second definitions of a material (the first is used)", format!("`{}`", m.name));
                        } else {
                            library.push(m);
                        }
                    }
                }
            }
            "usemtl" => {
                let name = content.trim_start()["usemtl".len()..].trim();
                if name.is_empty() {
                    return Err(malformed("`usemtl` without a name; expected `usemtl NAME`".to_string()));
                }
                current_usemtl = match usemtl_names.iter().position(|(n, _)| n == name) {
                    Some(k) => k as u32,
                    None => {
                        usemtl_names.push((name.to_string(), line));
                        (usemtl_names.len() - 1) as u32
                    }
                };
            }
            other => ignored.add("OBJ statements rlpt does not read", format!("`{other}`")),
        }
    }

    check_indices(path, &faces, [positions.len(), texcoords.len(), normals.len()])?;

    // Per-vertex normals (texture coordinates) where every corner has one: a
    // vertex per (v, vt, vn) triple of the attributes kept.
    let all = |c: &[u64]| !c.is_empty() && c.iter().all(|&n| n != NO_NORMAL);
    let (use_n, use_t) = (all(&faces.corner_n), all(&faces.corner_t));
    if !use_n && faces.corner_n.iter().any(|&n| n != NO_NORMAL) {
        ignored.add("the normals (vn) of some faces, as others have none (`smooth` computes them all)", "");
    }
    if !use_t && faces.corner_t.iter().any(|&t| t != NO_NORMAL) {
        ignored.add("the texture coordinates (vt) of some faces, as others have none", "");
    }
    let (corners, positions, normals, uvs) = if use_n || use_t {
        let mut map: HashMap<(u64, u64, u64), u32> = HashMap::new();
        let (mut p, mut n, mut t) = (Vec::new(), Vec::new(), Vec::new());
        let mut corners = Vec::with_capacity(faces.corner_v.len());
        for k in 0..faces.corner_v.len() {
            let v = faces.corner_v[k];
            let vn = if use_n { faces.corner_n[k] } else { NO_NORMAL };
            let vt = if use_t { faces.corner_t[k] } else { NO_NORMAL };
            corners.push(*map.entry((v, vt, vn)).or_insert_with(|| {
                p.push(positions[v as usize]);
                if use_n {
                    n.push(normals[vn as usize]);
                }
                if use_t {
                    t.push(texcoords[vt as usize]);
                }
                (p.len() - 1) as u32
            }));
        }
        (corners, p, use_n.then_some(n), use_t.then_some(t))
    } else {
        (faces.corner_v.iter().map(|&v| v as u32).collect(), positions, None, None)
    };

    // The materials: each `usemtl` name that faces use, mapped once.
    let mut builder = Builder { positions, normals, uvs, ..Default::default() };
    let mut name_to_material: Vec<Option<u32>> = vec![None; usemtl_names.len()];
    for (k, (name, first_line)) in usemtl_names.iter().enumerate() {
        if !faces.usemtl.contains(&(k as u32)) {
            continue;
        }
        match library.iter().find(|m| &m.name == name) {
            Some(m) => {
                name_to_material[k] = Some(builder.materials.len() as u32);
                builder.materials.push(mtl::map(m, &mut ignored));
            }
            None => ignored.add(
                "`usemtl` of materials no `mtllib` defines (their faces have no material)",
                format!("`{name}` (line {first_line})"),
            ),
        }
    }

    for (f, &start) in faces.start.iter().enumerate() {
        let end = faces.start.get(f + 1).copied().unwrap_or(corners.len());
        let material = match faces.usemtl[f] {
            NO_MATERIAL => NO_MATERIAL,
            k => name_to_material[k as usize].unwrap_or(NO_MATERIAL),
        };
        for k in start + 1..end - 1 {
            builder.triangles.push([corners[start], corners[k], corners[k + 1]]);
            builder.triangle_materials.push(material);
        }
    }
    builder.ignored = ignored;
    builder.finish(path)
}

/// A finite f32 coordinate.
fn coordinate(path: &Path, line: usize, word: &str, what: &str) -> Result<f32, MeshError> {
    super::line_f32(path, line, word, "the ", what)
}

/// One face corner, `v`, `v/vt`, `v//vn` or `v/vt/vn`: 0-based vertex,
/// texture-coordinate and normal indices (`NO_NORMAL` where it gives none),
/// `counts` the three so far. Negative indices are resolved (and checked)
/// against the counts.
fn corner(path: &Path, line: usize, token: &str, counts: [usize; 3]) -> Result<(u64, u64, u64), MeshError> {
    let parts: Vec<&str> = token.split('/').collect();
    if parts.len() > 3 || parts[0].is_empty() {
        return Err(MeshError::Malformed {
            path: path.to_path_buf(),
            location: Location::Line(line),
            message: format!("expected a face corner `v`, `v/vt`, `v//vn` or `v/vt/vn`, found `{token}`"),
        });
    }
    let v = index(path, line, token, parts[0], counts[0], "vertex")?;
    let t = match parts.get(1) {
        Some(p) if !p.is_empty() => index(path, line, token, p, counts[1], "texture-coordinate")?,
        _ => NO_NORMAL,
    };
    let n = match parts.get(2) {
        Some(p) if !p.is_empty() => index(path, line, token, p, counts[2], "normal")?,
        _ => NO_NORMAL,
    };
    Ok((v, t, n))
}

fn index(path: &Path, line: usize, token: &str, word: &str, count: usize, what: &str) -> Result<u64, MeshError> {
    let malformed =
        |message: String| MeshError::Malformed { path: path.to_path_buf(), location: Location::Line(line), message };
    let i: i64 = word.parse().map_err(|_| {
        malformed(format!("expected an integer {what} index in the face corner `{token}`, found `{word}`"))
    })?;
    match i {
        0 => Err(malformed(format!(
            "{what} index 0 in the face corner `{token}`; OBJ indices count from 1 (or back from -1)"
        ))),
        i if i > 0 => Ok(i as u64 - 1),
        i => {
            let resolved = count as i64 + i;
            if resolved < 0 {
                return Err(MeshError::IndexOutOfRange {
                    path: path.to_path_buf(),
                    location: Location::Line(line),
                    what: match what {
                        "vertex" => "relative vertex index",
                        "normal" => "relative normal index",
                        _ => "relative texture-coordinate index",
                    },
                    index: i,
                    expected: match count {
                        0 => format!("a {what} defined before it (there is none by this line)"),
                        1 => format!("-1 (the file has 1 {what} by this line)"),
                        n => format!("-1 to -{n} (the file has {n} {} by this line)", plural(what)),
                    },
                });
            }
            Ok(resolved as u64)
        }
    }
}

fn plural(what: &str) -> &str {
    match what {
        "vertex" => "vertices",
        "normal" => "normals",
        _ => "texture coordinates",
    }
}

/// Every positive index within the file's vertices, texture coordinates and normals.
fn check_indices(path: &Path, faces: &Faces, counts: [usize; 3]) -> Result<(), MeshError> {
    for (f, &start) in faces.start.iter().enumerate() {
        let end = faces.start.get(f + 1).copied().unwrap_or(faces.corner_v.len());
        for k in start..end {
            for (index, count, what) in [
                (faces.corner_v[k], counts[0], "vertex"),
                (faces.corner_t[k], counts[1], "texture-coordinate"),
                (faces.corner_n[k], counts[2], "normal"),
            ] {
                if index != NO_NORMAL && index >= count as u64 {
                    return Err(MeshError::IndexOutOfRange {
                        path: path.to_path_buf(),
                        location: Location::Line(faces.line[f]),
                        what: match what {
                            "vertex" => "vertex index",
                            "normal" => "normal index",
                            _ => "texture-coordinate index",
                        },
                        index: index as i64 + 1,
                        expected: match count {
                            0 => format!("a defined {what} (the file has none)"),
                            1 => format!("1 (the file has 1 {what})"),
                            n => format!("1 to {n} (the file has {n} {})", plural(what)),
                        },
                    });
                }
            }
        }
    }
    Ok(())
}
