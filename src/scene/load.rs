//! Reading and validating scene files (`SCENE_FORMAT.md`).
//!
//! The TOML text is parsed into a span-carrying tree ([`toml::de::DeTable`]) and
//! walked by hand, so every refusal can name the file, the 1-based line and
//! column of the offending key or value, and what was expected there.
//!
//! Numbers are checked as `f64` (finite, in range) and then converted to `f32`,
//! which must be finite too.

use std::fmt::Display;
use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::Vec3;
use toml::de::{DeTable, DeValue};
use toml::Spanned;

use super::mesh::MeshError;
use super::{Camera, GridKind, GuidingSettings, Material, MaterialKind, Quad, RenderSettings, Scene, Sphere};

mod material;
mod mesh_table;
mod reader;
use material::*;
use reader::*;

/// Why a scene was refused. The `Display` text is the whole message: the file,
/// where in it (`line:column`, 1-based, when known), and what was expected.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read (missing, unreadable, not UTF-8).
    #[error("{}: cannot read the scene file: {error}", path.display())]
    Io { path: PathBuf, error: std::io::Error },
    /// The text is not valid TOML.
    #[error("{file}:{line}:{column}: not valid TOML: {message}")]
    Syntax { file: String, line: usize, column: usize, message: String },
    /// Valid TOML that is not a valid scene.
    #[error("{}: {message}", location(file, *position))]
    Invalid {
        file: String,
        /// 1-based line and column of the offending key or value, when known.
        position: Option<(usize, usize)>,
        message: String,
    },
    /// A `[[mesh]]` whose file was refused: where the scene names the file
    /// (its `file` value), the table (`[[mesh]] #2`), and the file's error,
    /// which names the mesh file and where in it.
    #[error("{}: {table}: {error}", location(file, *position))]
    Mesh { file: String, position: Option<(usize, usize)>, table: String, error: Box<MeshError> },
}

impl SceneError {
    /// The 1-based `(line, column)` the error points at, if any.
    pub fn position(&self) -> Option<(usize, usize)> {
        match self {
            SceneError::Io { .. } => None,
            SceneError::Syntax { line, column, .. } => Some((*line, *column)),
            SceneError::Invalid { position, .. } | SceneError::Mesh { position, .. } => *position,
        }
    }
}

fn location(file: &str, position: Option<(usize, usize)>) -> String {
    match position {
        Some((line, column)) => format!("{file}:{line}:{column}"),
        None => file.to_string(),
    }
}

/// Reads and validates the scene file at `path`.
pub(super) fn load_file(path: &Path) -> Result<Scene, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|error| {
        // An image or other binary file given as the scene: say what a scene is.
        let error = if error.kind() == std::io::ErrorKind::InvalidData {
            std::io::Error::new(error.kind(), format!("{error}: a scene is a TOML text file (SCENE_FORMAT.md)"))
        } else {
            error
        };
        SceneError::Io { path: path.to_path_buf(), error }
    })?;
    let base = path.parent().unwrap_or(Path::new(""));
    let mut scene = parse_named(&text, &path.display().to_string(), base)?;
    scene.source = path.to_path_buf();
    Ok(scene)
}

/// Parses and validates scene text; `name` stands for the file in messages.
/// Mesh files are found relative to the current directory.
pub(super) fn parse_str(text: &str, name: &str) -> Result<Scene, SceneError> {
    parse_named(text, name, Path::new(""))
}

// ---------------------------------------------------------------------------
// Limits.

/// Largest accepted image width or height, in pixels.
const MAX_IMAGE_SIDE: i64 = crate::layout::MAX_IMAGE_SIDE as i64;
/// Largest accepted `max_bounces`.
const MAX_BOUNCES: i64 = crate::layout::MAX_BOUNCES as i64;
/// Largest magnitude of a coordinate, an edge component or a radius. The
/// renderers work in f32: squared distances, areas and light densities of a
/// scene this size stay far inside its range (about 3.4e38), where at 1e19 they
/// overflow and light sampling fails without a word.
const MAX_MAGNITUDE: f64 = 1e12;
/// Largest component of an emission or of the environment's radiance: with the
/// sums of many frames of samples, larger values overflow f32 to infinity.
const MAX_RADIANCE: f64 = 1e12;
/// Two directions whose angle has a sine below this count as parallel
/// (camera `up` against the view direction, quad edges against each other).
const PARALLEL_SINE: f64 = 1e-6;
/// Largest accepted guiding-grid cell count along one axis.
const MAX_GUIDING_CELLS_PER_AXIS: i64 = 256;
/// Largest accepted guiding-grid cell count in all (64^3).
const MAX_GUIDING_CELLS: u64 = 262_144;

const TOP_LEVEL: &[&str] = &["camera", "render", "environment", "guiding", "material", "sphere", "quad", "mesh"];
const CAMERA_KEYS: &[&str] = &["position", "look_at", "direction", "up", "vfov", "near"];
const RENDER_KEYS: &[&str] = &["width", "height", "spp", "max_bounces", "russian_roulette_depth"];
const ENVIRONMENT_KEYS: &[&str] = &["radiance", "file", "scale", "rotate"];
const GUIDING_KEYS: &[&str] = &["bounds_min", "bounds_max", "resolution", "grid"];
const SPHERE_KEYS: &[&str] = &["center", "radius", "material"];
const QUAD_KEYS: &[&str] = &["origin", "edge_u", "edge_v", "material"];
// ---------------------------------------------------------------------------
// The scene.

/// `base`: the directory that mesh files' relative paths start from.
fn parse_named(text: &str, name: &str, base: &Path) -> Result<Scene, SceneError> {
    let src = Source::new(name, text);
    let root = DeTable::parse(text).map_err(|e| {
        let (line, column) = src.line_col(e.span().map_or(0, |s| s.start));
        SceneError::Syntax { file: name.to_string(), line, column, message: e.message().trim().to_string() }
    })?;
    let root = root.get_ref();

    // Unknown top-level keys and tables.
    for (key, value) in entries_in_order(root) {
        if !TOP_LEVEL.contains(&key.get_ref().as_ref()) {
            let what = match value.get_ref() {
                DeValue::Table(_) => format!("unknown table `[{}]`", key.get_ref()),
                DeValue::Array(a) if a.iter().all(|e| e.get_ref().is_table()) && !a.is_empty() => {
                    format!("unknown table `[[{}]]`", key.get_ref())
                }
                _ => format!("unknown top-level key `{}`", key.get_ref()),
            };
            return Err(src.error(
                Some(key.span()),
                format!(
                    "{what}; expected the tables [camera], [render], [environment], \
                     [guiding], [[material]], [[sphere]], [[quad]] and [[mesh]]"
                ),
            ));
        }
    }

    let camera = match root.get("camera") {
        None => {
            return Err(src
                .error(None, "missing table [camera] (it needs position, look_at or direction, and vfov)".to_string()))
        }
        Some(v) => parse_camera(&single_table(&src, "camera", v)?)?,
    };
    let render = match root.get("render") {
        None => RenderSettings::default(),
        Some(v) => parse_render(&single_table(&src, "render", v)?)?,
    };
    let (environment, environment_map) = match root.get("environment") {
        None => (Vec3::ZERO, None),
        Some(v) => parse_environment(&single_table(&src, "environment", v)?, base)?,
    };
    let guiding = match root.get("guiding") {
        None => GuidingSettings::default(),
        Some(v) => parse_guiding(&single_table(&src, "guiding", v)?)?,
    };

    // Materials first, so geometry may name materials declared after it.
    let mut materials: Vec<Material> = Vec::new();
    let mut name_lines: Vec<usize> = Vec::new();
    for table in table_array(&src, "material", root.get("material"))? {
        let (material, name_span) = parse_material(&table, &materials, &name_lines, base)?;
        name_lines.push(src.line_col(name_span.start).0);
        materials.push(material);
    }
    // A scene of meshes may take every material from the mesh files.
    if materials.is_empty() && root.get("mesh").is_none() {
        return Err(src.error(None, "the scene defines no material; add at least one [[material]] table".to_string()));
    }

    let mut spheres = Vec::new();
    for table in table_array(&src, "sphere", root.get("sphere"))? {
        spheres.push(parse_sphere(&table, &materials)?);
    }
    let mut quads = Vec::new();
    for table in table_array(&src, "quad", root.get("quad"))? {
        quads.push(parse_quad(&table, &materials)?);
    }
    let mesh_table::ParsedMeshes { meshes, notes, mappings: material_mappings } =
        mesh_table::parse_meshes(&src, root.get("mesh"), &mut materials, base)?;
    if spheres.is_empty() && quads.is_empty() && meshes.is_empty() {
        return Err(src.error(
            None,
            "the scene has no geometry; add at least one [[sphere]] or [[quad]] table, or a [[mesh]] table".to_string(),
        ));
    }

    let mut scene = Scene {
        source: PathBuf::from("<string>"),
        camera,
        render,
        environment,
        environment_map,
        materials,
        spheres,
        quads,
        meshes,
        notes,
        material_mappings,
        guiding,
        textures: Vec::new(),
        delta_lights: Vec::new(),
    };
    super::texture::load_textures(&mut scene)?;
    Ok(scene)
}

/// `[name]`: one table (a header table or an inline table), not an array of tables.
fn single_table<'s, 'a, 'i>(
    src: &'s Source<'a>,
    name: &str,
    value: &'s Value<'i>,
) -> Result<Table<'s, 'a, 'i>, SceneError> {
    match value.get_ref() {
        DeValue::Table(table) => {
            Ok(Table { src, label: format!("[{name}]"), table, span: Some(value.span()).filter(|s| !s.is_empty()) })
        }
        _ => Err(src.error(
            Some(value.span()),
            format!(
                "`{name}` must be a single table written [{name}], found {}",
                if value.get_ref().is_array() {
                    "an array (written [[...]] or `= [...]`)".to_string()
                } else {
                    src.describe(value)
                }
            ),
        )),
    }
}

/// `[[name]]`: an array of tables (possibly absent or empty).
fn table_array<'s, 'a, 'i>(
    src: &'s Source<'a>,
    name: &str,
    value: Option<&'s Value<'i>>,
) -> Result<Vec<Table<'s, 'a, 'i>>, SceneError> {
    let Some(value) = value else {
        return Ok(Vec::new());
    };
    let DeValue::Array(array) = value.get_ref() else {
        return Err(src.error(
            Some(value.span()),
            format!(
                "`{name}` must be an array of tables, each written [[{name}]], found {}",
                if value.get_ref().is_table() {
                    format!("a single table (write [[{name}]], not [{name}])")
                } else {
                    src.describe(value)
                }
            ),
        ));
    };
    let mut tables = Vec::new();
    for (i, element) in array.iter().enumerate() {
        let DeValue::Table(table) = element.get_ref() else {
            return Err(src.error(
                Some(element.span()),
                format!("[[{name}]] #{}: must be a table, found {}", i + 1, src.describe(element)),
            ));
        };
        tables.push(Table {
            src,
            label: format!("[[{name}]] #{}", i + 1),
            table,
            span: Some(element.span()).filter(|s| !s.is_empty()),
        });
    }
    Ok(tables)
}

fn parse_camera(t: &Table<'_, '_, '_>) -> Result<Camera, SceneError> {
    t.check_keys(CAMERA_KEYS, "")?;
    let position = t.point("position", t.required("position", "the eye point, an array [x, y, z]")?)?;

    let look_at = t.get("look_at");
    let direction = t.get("direction");
    let (forward, forward_span) = match (look_at, direction) {
        (Some(a), Some(b)) => {
            let second = if a.span().start > b.span().start { a } else { b };
            return Err(t.error_at(second.span(), "give exactly one of `look_at` and `direction`, not both"));
        }
        (None, None) => {
            return Err(t.error_here(
                "missing key `look_at` or `direction` (exactly one is required: \
                 the point looked at, or the view direction)",
            ))
        }
        (Some(v), None) => {
            let target = t.point("look_at", v)?;
            let d = sub(target, position);
            if length(d) == 0.0 {
                return Err(t.error_at(
                    v.span(),
                    format!("key `look_at` must differ from `position` {}, found the same point", format_vec(position)),
                ));
            }
            (d, v.span())
        }
        (None, Some(v)) => {
            let d = t.point("direction", v)?;
            if length(d) == 0.0 {
                return Err(t.error_at(v.span(), "key `direction` must be a non-zero vector, found [0, 0, 0]"));
            }
            (d, v.span())
        }
    };
    let len = length(forward);
    let forward_unit = [forward[0] / len, forward[1] / len, forward[2] / len];

    let up = match t.get("up") {
        None => [0.0, 1.0, 0.0],
        Some(v) => {
            let up = t.point("up", v)?;
            if length(up) == 0.0 {
                return Err(
                    t.error_at(v.span(), "key `up` must be a non-zero vector (default [0, 1, 0]), found [0, 0, 0]")
                );
            }
            up
        }
    };
    if sine_between(forward_unit, up) < PARALLEL_SINE {
        let (span, which) = match t.get("up") {
            Some(v) => (v.span(), format!("`up` {}", t.src.snippet(v.span()))),
            None => (forward_span, "the default `up` [0, 1, 0]".to_string()),
        };
        return Err(t.error_at(
            span,
            format!(
                "the view direction {} is parallel to {which}, which leaves the camera's \
                 orientation undefined; give an `up` that is not parallel to the view direction",
                format_vec(forward_unit),
            ),
        ));
    }

    let vfov = t.ranged(
        "vfov",
        t.required("vfov", "vertical field of view in degrees, 0 < vfov < 180")?,
        |x| x > 0.0 && x < 180.0,
        "a number of degrees with 0 < vfov < 180",
    )?;
    let near = match t.get("near") {
        None => 0.0,
        Some(v) => t.ranged("near", v, |x| (0.0..=MAX_MAGNITUDE).contains(&x), "a number from 0 to 1e12")?,
    };

    Ok(Camera {
        position: to_vec3(position),
        forward: to_vec3(forward_unit).normalize(),
        up: to_vec3(up),
        vfov_deg: vfov,
        near,
    })
}

fn parse_render(t: &Table<'_, '_, '_>) -> Result<RenderSettings, SceneError> {
    t.check_keys(RENDER_KEYS, "")?;
    let mut r = RenderSettings::default();
    let max_u32 = i64::from(u32::MAX);
    if let Some(v) = t.get("width") {
        r.width = t.integer("width", v, 1, MAX_IMAGE_SIDE, "image width in pixels")?;
    }
    if let Some(v) = t.get("height") {
        r.height = t.integer("height", v, 1, MAX_IMAGE_SIDE, "image height in pixels")?;
    }
    if let Some(v) = t.get("spp") {
        r.spp = t.integer("spp", v, 1, crate::layout::MAX_SPP as i64, "samples per pixel")?;
    }
    if let Some(v) = t.get("max_bounces") {
        r.max_bounces = t.integer("max_bounces", v, 0, MAX_BOUNCES, "scattering events per path")?;
    }
    if let Some(v) = t.get("russian_roulette_depth") {
        r.russian_roulette_depth = Some(t.integer(
            "russian_roulette_depth",
            v,
            0,
            max_u32,
            "bounces before Russian roulette may end a path; leave it out to turn it off",
        )?);
    }
    Ok(r)
}

/// `[environment]`: the uniform sky's `radiance`, or an image `file` (resolved
/// against `base`) with its optional `scale` and `rotate` (degrees about +y).
fn parse_environment(
    t: &Table<'_, '_, '_>,
    base: &Path,
) -> Result<(Vec3, Option<crate::scene::EnvironmentMap>), SceneError> {
    t.check_keys(ENVIRONMENT_KEYS, "")?;
    let Some(file) = t.get("file") else {
        for key in ["scale", "rotate"] {
            if let Some(v) = t.get(key) {
                return Err(
                    t.error_at(v.span(), format!("key `{key}` applies to an image environment: give `file` too"))
                );
            }
        }
        return match t.get("radiance") {
            None => Ok((Vec3::ZERO, None)),
            Some(v) => {
                Ok((to_vec3(t.vec3("radiance", v, |x| (0.0..=MAX_RADIANCE).contains(&x), "from 0 to 1e12")?), None))
            }
        };
    };
    if let Some(v) = t.get("radiance") {
        return Err(t.error_at(
            v.span(),
            "keys `radiance` and `file` exclude each other: the uniform sky or an image; scale an image with `scale`",
        ));
    }
    let written = t.string("file", file, "a path to an equirectangular .exr or .hdr image")?;
    let scale = match t.get("scale") {
        None => 1.0,
        Some(v) => t.ranged("scale", v, |x| (0.0..=MAX_RADIANCE).contains(&x), "from 0 to 1e12")?,
    };
    let rotate = match t.get("rotate") {
        None => 0.0,
        Some(v) => t.ranged("rotate", v, |x| x.abs() <= 1e6, "an angle in degrees (magnitude at most 1e6)")?,
    };
    let map = crate::scene::EnvironmentMap::read(written, base, scale, rotate)
        .map_err(|message| t.error_at(file.span(), message))?;
    Ok((Vec3::ZERO, Some(map)))
}

/// `[guiding]`: the box and resolution of the guiding grid; what is left out
/// stays `None` (chosen automatically by the renderer).
fn parse_guiding(t: &Table<'_, '_, '_>) -> Result<GuidingSettings, SceneError> {
    t.check_keys(GUIDING_KEYS, "")?;
    let mut g = GuidingSettings::default();

    match (t.get("bounds_min"), t.get("bounds_max")) {
        (None, None) => {}
        (Some(v), None) | (None, Some(v)) => {
            let (given, missing) =
                if t.get("bounds_min").is_some() { ("bounds_min", "bounds_max") } else { ("bounds_max", "bounds_min") };
            // The given one must be well formed before its partner is asked for.
            t.point(given, v)?;
            return Err(t.error_at(
                v.span(),
                format!(
                    "missing key `{missing}`: `{given}` is given without it; give both `bounds_min` and \
                     `bounds_max` (the corners [x, y, z] of the guiding grid's box), or neither to fit the \
                     box automatically"
                ),
            ));
        }
        (Some(min_value), Some(max_value)) => {
            let min64 = t.point("bounds_min", min_value)?;
            let max64 = t.point("bounds_max", max_value)?;
            let (min, max) = (to_vec3(min64), to_vec3(max64));
            // Both are arrays of 3 by now; messages quote the components as written.
            let component = |value: &Value<'_>, axis: usize| match value.get_ref() {
                DeValue::Array(a) => (a[axis].span(), t.src.snippet(a[axis].span())),
                _ => (value.span(), t.src.snippet(value.span())),
            };
            // Compared as the f32 values the grid will use.
            for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
                let (span, max_text) = component(max_value, axis);
                let (_, min_text) = component(min_value, axis);
                if max[axis] <= min[axis] {
                    let note = if max64[axis] > min64[axis] { " (equal as 32-bit floats)" } else { "" };
                    return Err(t.error_at(
                        span,
                        format!(
                            "key `bounds_max` must be greater than `bounds_min` on every axis, \
                             found {max_text} <= {min_text}{note} on the {name} axis"
                        ),
                    ));
                }
            }
            g.bounds_min = Some(min);
            g.bounds_max = Some(max);
        }
    }

    if let Some(v) = t.get("resolution") {
        let shape = "an array of 3 integers [nx, ny, nz] (cells along x, y, z)";
        let array = match v.get_ref() {
            DeValue::Array(a) if a.len() == 3 => a,
            _ => {
                return Err(
                    t.error_at(v.span(), format!("key `resolution` must be {shape}, found {}", t.src.describe(v)))
                )
            }
        };
        let mut cells = [0u32; 3];
        for (i, element) in array.iter().enumerate() {
            cells[i] = t.integer_at(
                element,
                &format!("key `resolution` component {}", i + 1),
                1,
                MAX_GUIDING_CELLS_PER_AXIS,
                "cells along that axis",
            )?;
        }
        let product: u64 = cells.iter().map(|&n| u64::from(n)).product();
        if product > MAX_GUIDING_CELLS {
            return Err(t.error_at(
                v.span(),
                format!(
                    "key `resolution` must have at most {MAX_GUIDING_CELLS} cells in all, \
                     found {} x {} x {} = {product}",
                    cells[0], cells[1], cells[2]
                ),
            ));
        }
        g.resolution = Some(cells);
    }
    if let Some(v) = t.get("grid") {
        let expected = "\"uniform\" or \"adaptive\"";
        g.grid = Some(match t.string("grid", v, expected)? {
            "uniform" => GridKind::Uniform,
            "adaptive" => GridKind::Adaptive,
            other => {
                return Err(t.error_at(v.span(), format!("key `grid` must be {expected}, found \"{other}\"")));
            }
        });
    }
    Ok(g)
}

fn parse_sphere(t: &Table<'_, '_, '_>, materials: &[Material]) -> Result<Sphere, SceneError> {
    t.check_keys(SPHERE_KEYS, "")?;
    let center = t.point("center", t.required("center", "an array [x, y, z]")?)?;
    let radius_value = t.required("radius", "a number > 0")?;
    let radius = t.ranged("radius", radius_value, |x| x > 0.0 && x <= MAX_MAGNITUDE, "a number > 0, at most 1e12")?;
    if radius * radius == 0.0 {
        return Err(t.error_at(
            radius_value.span(),
            format!(
                "key `radius` must be a number > 0 whose square is not 0 in a 32-bit float \
                 (at least about 1e-22), found {}",
                t.src.snippet(radius_value.span())
            ),
        ));
    }
    let material = material_index(t, materials)?;
    Ok(Sphere { center: to_vec3(center), radius, material, uv: super::SphereUv::TOML })
}

fn parse_quad(t: &Table<'_, '_, '_>, materials: &[Material]) -> Result<Quad, SceneError> {
    t.check_keys(QUAD_KEYS, "")?;
    let origin = t.point("origin", t.required("origin", "a corner, an array [x, y, z]")?)?;
    let mut edges = [[0.0; 3]; 2];
    for (i, key) in ["edge_u", "edge_v"].into_iter().enumerate() {
        let v = t.required(key, "an edge vector [x, y, z] from `origin`")?;
        edges[i] = t.point(key, v)?;
        if length(edges[i]) == 0.0 {
            return Err(t.error_at(v.span(), format!("key `{key}` must be a non-zero vector, found [0, 0, 0]")));
        }
    }
    let [u, v] = edges;
    let (u32_, v32) = (to_vec3(u), to_vec3(v));
    let area32 = u32_.cross(v32).length();
    if sine_between(u, v) < PARALLEL_SINE || !area32.is_finite() || area32 == 0.0 {
        let span = t.get("edge_v").map_or(0..0, |v| v.span());
        return Err(t.error_at(
            span,
            format!(
                "the quad is degenerate: `edge_u` {} and `edge_v` {} are parallel or \
                 their area does not fit a 32-bit float; give two non-parallel edges",
                format_vec(u),
                format_vec(v)
            ),
        ));
    }
    let material = material_index(t, materials)?;
    Ok(Quad { origin: to_vec3(origin), edge_u: u32_, edge_v: v32, material })
}
