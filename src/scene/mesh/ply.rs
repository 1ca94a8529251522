//! PLY (ASCII, binary little and big endian) through `ply-rs-bw`: its header
//! parser, and its per-element decoders driven one element at a time here, so
//! every refusal names the element and its index ("face 12"). Read: `vertex`
//! `x y z` (float or double) with optional `nx ny nz`, and `face`
//! `vertex_indices` (or `vertex_index`), a list of integers, n-gons
//! fan-triangulated; texture coordinates `u v` (or `s t`, `texture_u
//! texture_v`, `texture_s texture_t`). Other elements and properties are ignored (vertex colours
//! and texture files named in the note).

use std::fs::File;
use std::io::{BufRead, BufReader, ErrorKind};
use std::path::Path;

use glam::Vec3;
use ply_rs_bw::parser::{ParseError, Parser, Reader};
use ply_rs_bw::ply::{ElementDef, Encoding, Header, PropertyAccess, PropertyAccessResult, PropertyType, ScalarType};

use super::{number, Builder, Ignored, Location, MeshError, MeshFile};

#[derive(Default)]
struct Vertex {
    p: [f64; 3],
    n: [f64; 3],
    uv: [f64; 2],
}

/// The names of a vertex's texture coordinates, u then v, in the order tried.
const UV_NAMES: [[&str; 2]; 4] = [["u", "v"], ["s", "t"], ["texture_u", "texture_v"], ["texture_s", "texture_t"]];

impl Vertex {
    fn set(&mut self, name: &str, x: f64) -> PropertyAccessResult {
        let slot = match name {
            "x" => &mut self.p[0],
            "y" => &mut self.p[1],
            "z" => &mut self.p[2],
            "nx" => &mut self.n[0],
            "ny" => &mut self.n[1],
            "nz" => &mut self.n[2],
            "u" | "s" | "texture_u" | "texture_s" => &mut self.uv[0],
            "v" | "t" | "texture_v" | "texture_t" => &mut self.uv[1],
            _ => return PropertyAccessResult::Ignored,
        };
        *slot = x;
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Self::default()
    }
    fn set_float(&mut self, name: &str, x: f32) -> PropertyAccessResult {
        self.set(name, f64::from(x))
    }
    fn set_double(&mut self, name: &str, x: f64) -> PropertyAccessResult {
        self.set(name, x)
    }
}

#[derive(Default)]
struct Face {
    indices: Vec<i64>,
}

impl Face {
    fn set<T: Into<i64>>(&mut self, name: &str, list: Vec<T>) -> PropertyAccessResult {
        if name == "vertex_indices" || name == "vertex_index" {
            self.indices = list.into_iter().map(Into::into).collect();
            return PropertyAccessResult::Set;
        }
        PropertyAccessResult::Ignored
    }
}

impl PropertyAccess for Face {
    fn new() -> Self {
        Self::default()
    }
    fn set_list_char(&mut self, name: &str, list: Vec<i8>) -> PropertyAccessResult {
        self.set(name, list)
    }
    fn set_list_uchar(&mut self, name: &str, list: Vec<u8>) -> PropertyAccessResult {
        self.set(name, list)
    }
    fn set_list_short(&mut self, name: &str, list: Vec<i16>) -> PropertyAccessResult {
        self.set(name, list)
    }
    fn set_list_ushort(&mut self, name: &str, list: Vec<u16>) -> PropertyAccessResult {
        self.set(name, list)
    }
    fn set_list_int(&mut self, name: &str, list: Vec<i32>) -> PropertyAccessResult {
        self.set(name, list)
    }
    fn set_list_uint(&mut self, name: &str, list: Vec<u32>) -> PropertyAccessResult {
        self.set(name, list)
    }
}

/// Any other element: every property ignored.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

/// The type as the header writes it: "float", "list of float (counted by uchar)".
fn type_text(t: &PropertyType) -> String {
    let scalar = |s: &ScalarType| {
        match s {
            ScalarType::Char => "char",
            ScalarType::UChar => "uchar",
            ScalarType::Short => "short",
            ScalarType::UShort => "ushort",
            ScalarType::Int => "int",
            ScalarType::UInt => "uint",
            ScalarType::Float => "float",
            ScalarType::Double => "double",
        }
        .to_string()
    };
    match t {
        PropertyType::Scalar(s) => scalar(s),
        PropertyType::List(count, item) => format!("list of {} (counted by {})", scalar(item), scalar(count)),
    }
}

fn is_float(t: &PropertyType) -> bool {
    matches!(t, PropertyType::Scalar(ScalarType::Float | ScalarType::Double))
}

fn is_integer(s: &ScalarType) -> bool {
    !matches!(s, ScalarType::Float | ScalarType::Double)
}

/// What the header says: which properties are read, and what is noted.
struct Layout {
    normals: bool,
    uvs: bool,
    face_list: Option<String>,
}

fn check_header(path: &Path, header: &Header, ignored: &mut Ignored) -> Result<Layout, MeshError> {
    let unsupported = |element: &str, property: &str, found: String, expected: &str| MeshError::UnsupportedProperty {
        path: path.to_path_buf(),
        element: element.to_string(),
        property: property.to_string(),
        found,
        expected: expected.to_string(),
    };
    let malformed =
        |message: String| MeshError::Malformed { path: path.to_path_buf(), location: Location::File, message };
    let Some(vertex) = header.elements.get("vertex") else {
        return Err(malformed("the header declares no `vertex` element; expected `element vertex N`".to_string()));
    };
    for axis in ["x", "y", "z"] {
        match vertex.properties.get(axis) {
            None => {
                return Err(malformed(format!(
                    "element `vertex` has no property `{axis}`; expected `property float {axis}` (or double)"
                )))
            }
            Some(p) if !is_float(&p.data_type) => {
                return Err(unsupported("vertex", axis, type_text(&p.data_type), "float or double"))
            }
            Some(_) => {}
        }
    }
    let normal_props: Vec<_> = ["nx", "ny", "nz"].iter().filter_map(|n| vertex.properties.get(*n)).collect();
    for p in &normal_props {
        if !is_float(&p.data_type) {
            return Err(unsupported("vertex", &p.name, type_text(&p.data_type), "float or double"));
        }
    }
    let normals = normal_props.len() == 3;
    // Texture coordinates: the first pair of UV_NAMES the vertex has, both floats.
    let mut uvs = false;
    for pair in UV_NAMES {
        let props: Vec<_> = pair.iter().filter_map(|n| vertex.properties.get(*n)).collect();
        if let Some(p) = props.iter().find(|p| !is_float(&p.data_type)) {
            return Err(unsupported("vertex", &p.name, type_text(&p.data_type), "float or double"));
        }
        if props.len() == 2 {
            uvs = true;
            break;
        }
    }
    if !normal_props.is_empty() && !normals {
        ignored.add("partial vertex normals (not all of nx, ny, nz)", "");
    }
    if vertex.properties.keys().any(|k| {
        matches!(k.as_str(), "red" | "green" | "blue" | "alpha" | "r" | "g" | "b")
            || k.starts_with("diffuse_")
            || k.starts_with("specular_")
    }) {
        ignored.add("vertex colours", "");
    }
    let face_list = match header.elements.get("face") {
        None => None,
        Some(face) => {
            let list = ["vertex_indices", "vertex_index"].iter().find_map(|n| face.properties.get(*n));
            match list {
                None => {
                    return Err(malformed(
                        "element `face` has no property `vertex_indices`; expected \
                         `property list uchar int vertex_indices`"
                            .to_string(),
                    ))
                }
                Some(p) => match &p.data_type {
                    PropertyType::List(count, item) if is_integer(count) && is_integer(item) => Some(p.name.clone()),
                    other => {
                        return Err(unsupported(
                            "face",
                            &p.name,
                            type_text(other),
                            "a list of integers counted by an integer",
                        ));
                    }
                },
            }
        }
    };
    for name in header.elements.keys() {
        if name != "vertex" && name != "face" {
            ignored.add("elements other than vertex and face", format!("`{name}`"));
        }
    }
    for comment in &header.comments {
        let mut words = comment.split_whitespace();
        if words.next().is_some_and(|w| w.eq_ignore_ascii_case("TextureFile")) {
            ignored.add("textures", words.collect::<Vec<_>>().join(" "));
        }
    }
    Ok(Layout { normals, uvs, face_list })
}

/// A header line that the parser refused: its number and text.
fn header_error(path: &Path, error: ParseError) -> MeshError {
    let line = error.line();
    let text = line.and_then(|l| {
        let file = File::open(path).ok()?;
        BufReader::new(file).split(b'\n').nth(l - 1)?.ok().map(|b| String::from_utf8_lossy(&b).trim().to_string())
    });
    let message = match (error.kind(), text) {
        (ErrorKind::UnexpectedEof, _) => "the file ends inside the header; expected `end_header`".to_string(),
        (_, Some(text)) if text.starts_with("property") => format!(
            "cannot read the header line `{text}`; expected `property TYPE NAME` or `property list TYPE TYPE NAME` \
             with a TYPE of char, uchar, short, ushort, int, uint, float, double (or int8 to float64)"
        ),
        (_, Some(text)) => format!(
            "cannot read the header line `{text}`; expected `ply`, `format ascii|binary_little_endian|\
             binary_big_endian 1.0`, `element`, `property`, `comment` or `end_header`"
        ),
        (_, None) => {
            format!("cannot read the PLY header; expected a PLY file ({})", error.to_string().replace('\n', " "))
        }
    };
    MeshError::Malformed { path: path.to_path_buf(), location: line.map_or(Location::File, Location::Line), message }
}

pub(super) fn load(path: &Path) -> Result<MeshFile, MeshError> {
    let file = File::open(path).map_err(|error| MeshError::Io {
        path: path.to_path_buf(),
        location: Location::File,
        what: "the mesh file".to_string(),
        error,
    })?;
    let mut reader = Reader::new(BufReader::new(file));
    let header = Parser::<Skip>::new().read_header(&mut reader).map_err(|e| header_error(path, e))?;
    let mut ignored = Ignored::default();
    let layout = check_header(path, &header, &mut ignored)?;

    let mut vertices: Vec<Vertex> = Vec::new();
    let mut faces: Vec<(usize, Vec<i64>)> = Vec::new();
    let mut line = reader.line();
    let (vertex_parser, face_parser, skip_parser) =
        (Parser::<Vertex>::new(), Parser::<Face>::new(), Parser::<Skip>::new());
    let input = reader.get_mut();
    let mut text = String::new();
    for (name, def) in &header.elements {
        for index in 0..def.count {
            let location = |line: Option<usize>| Location::Element { name: name.clone(), index, line };
            let ascii_line = (header.encoding == Encoding::Ascii).then_some(line);
            let read = match header.encoding {
                Encoding::Ascii => {
                    text.clear();
                    let n = input.read_line(&mut text).map_err(|error| MeshError::Io {
                        path: path.to_path_buf(),
                        location: location(ascii_line),
                        what: "the mesh file".to_string(),
                        error,
                    })?;
                    line += 1;
                    if n == 0 {
                        return Err(truncated(path, location(ascii_line), def));
                    }
                    match name.as_str() {
                        "vertex" => vertex_parser.read_ascii_element(&text, def).map(|v| vertices.push(v)),
                        "face" => face_parser.read_ascii_element(&text, def).map(|f| faces.push((index, f.indices))),
                        _ => skip_parser.read_ascii_element(&text, def).map(|_| ()),
                    }
                    .map_err(|_| ascii_error(path, location(ascii_line), def, &text))
                }
                Encoding::BinaryLittleEndian | Encoding::BinaryBigEndian => {
                    let little = header.encoding == Encoding::BinaryLittleEndian;
                    match name.as_str() {
                        "vertex" => binary(&vertex_parser, input, def, little).map(|v| vertices.push(v)),
                        "face" => binary(&face_parser, input, def, little).map(|f| faces.push((index, f.indices))),
                        _ => binary(&skip_parser, input, def, little).map(|_| ()),
                    }
                    .map_err(|e| match e.kind() {
                        ErrorKind::UnexpectedEof => truncated(path, location(None), def),
                        _ => MeshError::Malformed {
                            path: path.to_path_buf(),
                            location: location(None),
                            message: format!("cannot read the element: {}", e.to_string().replace(['\n', '\t'], " ")),
                        },
                    })
                }
            };
            read?;
        }
    }

    let mut builder = Builder { ignored, ..Default::default() };
    builder.positions.reserve(vertices.len());
    let mut normals = Vec::with_capacity(if layout.normals { vertices.len() } else { 0 });
    for (index, v) in vertices.iter().enumerate() {
        let location = Location::element("vertex", index);
        builder.positions.push(finite(path, &location, "xyz", v.p)?);
        if layout.normals {
            normals.push(finite(path, &location, &["nx", "ny", "nz"].join(" "), v.n)?);
        }
    }
    if layout.normals {
        builder.normals = Some(normals);
    }
    if layout.uvs {
        let mut uvs = Vec::with_capacity(vertices.len());
        for (index, v) in vertices.iter().enumerate() {
            let [u, w] = v.uv;
            let uv = finite(path, &Location::element("vertex", index), "u v", [u, w, 0.0])?;
            uvs.push(uv.truncate());
        }
        builder.uvs = Some(uvs);
    }
    let count = vertices.len();
    let list = layout.face_list.as_deref().unwrap_or("vertex_indices");
    for (index, indices) in &faces {
        let location = Location::element("face", *index);
        if indices.len() < 3 {
            return Err(MeshError::Malformed {
                path: path.to_path_buf(),
                location,
                message: format!("a face needs at least 3 vertices in `{list}`, found {}", indices.len()),
            });
        }
        for &i in indices {
            if i < 0 || i as usize >= count {
                return Err(MeshError::IndexOutOfRange {
                    path: path.to_path_buf(),
                    location,
                    what: "vertex index",
                    index: i,
                    expected: match count {
                        0 => "a vertex (the file has none)".to_string(),
                        n => format!("0 to {} (the file has {n} vertices)", n - 1),
                    },
                });
            }
        }
        for k in 1..indices.len() - 1 {
            builder.triangles.push([indices[0] as u32, indices[k] as u32, indices[k + 1] as u32]);
        }
    }
    builder.finish(path)
}

fn binary<E: PropertyAccess>(
    parser: &Parser<E>,
    input: &mut impl BufRead,
    def: &ElementDef,
    little: bool,
) -> Result<E, ParseError> {
    if little {
        parser.read_little_endian_element(input, def)
    } else {
        parser.read_big_endian_element(input, def)
    }
}

fn truncated(path: &Path, location: Location, def: &ElementDef) -> MeshError {
    MeshError::Malformed {
        path: path.to_path_buf(),
        location,
        message: format!(
            "the file ends inside the element; expected {} `{}` elements as the header declares",
            def.count, def.name
        ),
    }
}

/// An ASCII element line the decoder refused: a non-finite number, or what
/// the header said the line holds.
fn ascii_error(path: &Path, location: Location, def: &ElementDef, text: &str) -> MeshError {
    let line = text.trim();
    if let Some(word) = line.split_whitespace().find(|w| w.parse::<f64>().is_ok_and(|x| !x.is_finite())) {
        return MeshError::NotFinite {
            path: path.to_path_buf(),
            location,
            what: "a value".to_string(),
            value: format!("`{word}`"),
        };
    }
    let expected: Vec<String> = def
        .properties
        .values()
        .map(|p| match p.data_type {
            PropertyType::Scalar(_) => p.name.clone(),
            PropertyType::List(..) => format!("the count of {} and that many values", p.name),
        })
        .collect();
    let shown: String = line.chars().take(60).collect();
    let shown = if shown.len() < line.len() { format!("{shown}...") } else { shown };
    MeshError::Malformed {
        path: path.to_path_buf(),
        location,
        message: format!("expected {} on one line, as numbers, found `{shown}`", expected.join(", ")),
    }
}

/// A finite f32 vector, or [`MeshError::NotFinite`] naming the properties.
fn finite(path: &Path, location: &Location, names: &str, v: [f64; 3]) -> Result<Vec3, MeshError> {
    let out = Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32);
    if out.is_finite() {
        return Ok(out);
    }
    let names: Vec<&str> = if names == "xyz" { vec!["x", "y", "z"] } else { names.split(' ').collect() };
    let k = (0..3).find(|&k| !out[k].is_finite()).unwrap_or(0);
    let value = if v[k].is_finite() { format!("{}, beyond a 32-bit float", number(v[k])) } else { number(v[k]) };
    Err(MeshError::NotFinite {
        path: path.to_path_buf(),
        location: location.clone(),
        what: format!("`{}`", names[k]),
        value,
    })
}
