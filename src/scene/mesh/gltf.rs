//! glTF 2.0 (`.gltf` with its buffers, and `.glb`) through the `gltf` crate's
//! document and validation; the buffers and accessors are read here, every
//! range checked, so a refusal names the JSON path. The default scene (else the
//! first, else every root node) is flattened: each node's matrix applied to
//! positions, its inverse transpose to normals; a node that mirrors reverses
//! its triangles' order (glTF's rule). TRIANGLES primitives are read, indexed
//! or not (u8, u16, u32 indices); strips and fans are turned into triangles;
//! points and lines are named in the note. TEXCOORD_0 gives the UVs (v
//! flipped: glTF's v runs down the image, rlpt's up).
//!
//! Materials (`docs/SCENE_FORMAT.md`, "Meshes"): `baseColorFactor` is the
//! albedo; `emissiveFactor` x `KHR_materials_emissive_strength` the emission
//! (two-sided where `doubleSided`); `KHR_materials_transmission` above 0.5 a
//! dielectric with `KHR_materials_ior` (default 1.5); else `metallicFactor` >=
//! 0.5 glossy with `roughnessFactor` (specular below 0.05); else diffuse.

use std::path::Path;

use glam::{DMat3, DMat4, Vec2, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use gltf::{Accessor, Document, Semantic};

use super::gltf_material::{embedded_images, map_material};
use super::{number, read_file, vec_text, Builder, Ignored, Location, MeshError, MeshFile, NO_MATERIAL};

/// Deepest node hierarchy followed (a deeper one is a cycle or a mistake).
const MAX_DEPTH: usize = 1024;

pub(super) fn load(path: &Path) -> Result<MeshFile, MeshError> {
    let bytes = read_file(path, path, Location::File, "the mesh file")?;
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| document_error(path, e))?;
    validate(path, gltf.document.as_json())?;
    let mut reader = GltfReader {
        path,
        dir: path.parent().unwrap_or(Path::new("")),
        doc: &gltf.document,
        blob: gltf.blob.as_deref(),
        buffers: vec![None; gltf.document.buffers().len()],
        builder: Builder::default(),
        material_of: vec![None; gltf.document.materials().len()],
        normals_missing: false,
        uvs_missing: false,
        ignored: Ignored::default(),
    };
    reader.note_document();
    let roots: Vec<usize> = match gltf.document.default_scene().or_else(|| gltf.document.scenes().next()) {
        Some(scene) => scene.nodes().map(|n| n.index()).collect(),
        None => {
            let mut is_child = vec![false; gltf.document.nodes().len()];
            for node in gltf.document.nodes() {
                node.children().for_each(|c| is_child[c.index()] = true);
            }
            (0..is_child.len()).filter(|&i| !is_child[i]).collect()
        }
    };
    for root in roots {
        reader.node(root, DMat4::IDENTITY, 0)?;
    }
    let GltfReader { mut builder, normals_missing, uvs_missing, mut ignored, .. } = reader;
    if uvs_missing {
        if builder.uvs.is_some() {
            ignored.add("the texture coordinates of some primitives, as others have none", "");
        }
        builder.uvs = None;
    }
    if normals_missing {
        if builder.normals.is_some() {
            ignored.add("the normals of some primitives, as others have none (`smooth` computes them all)", "");
        }
        builder.normals = None;
    }
    builder.ignored = ignored;
    builder.finish(path)
}

/// The crate's validation of the document, after the one check it needs
/// before it (gltf-json 1.4.1 indexes the POSITION accessor unchecked, and
/// panics where it does not exist).
fn validate(path: &Path, root: &gltf::json::Root) -> Result<(), MeshError> {
    use gltf::json::validation::{Checked, Validate};
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            for (semantic, index) in &primitive.attributes {
                if index.value() >= root.accessors.len() {
                    let name = match semantic {
                        Checked::Valid(s) => s.to_string(),
                        Checked::Invalid => "?".to_string(),
                    };
                    return Err(MeshError::Malformed {
                        path: path.to_path_buf(),
                        location: Location::Json(format!("meshes[{m}].primitives[{p}].attributes.{name}")),
                        message: format!(
                            "accessor {} does not exist (the file has {} accessors); expected the index of an existing accessor",
                            index.value(),
                            root.accessors.len()
                        ),
                    });
                }
            }
        }
    }
    let mut errors = Vec::new();
    root.validate(root, gltf::json::Path::new, &mut |json, error| errors.push((json(), error)));
    if errors.is_empty() {
        Ok(())
    } else {
        Err(document_error(path, gltf::Error::Validation(errors)))
    }
}

/// A parse or validation error of the document, with its JSON path where the
/// crate gives one.
fn document_error(path: &Path, error: gltf::Error) -> MeshError {
    let malformed = |location, message| MeshError::Malformed { path: path.to_path_buf(), location, message };
    match error {
        gltf::Error::Validation(errors) => {
            let (json, what) = &errors[0];
            let more = match errors.len() {
                1 => String::new(),
                n => format!(" (and {} more problems)", n - 1),
            };
            let expected = match what {
                gltf::json::validation::Error::IndexOutOfBounds => "expected the index of an existing object",
                gltf::json::validation::Error::Missing => "expected it to be present",
                gltf::json::validation::Error::Unsupported => "expected no extension rlpt cannot read to be required",
                gltf::json::validation::Error::Invalid => "expected a value glTF 2.0 allows",
                gltf::json::validation::Error::Oversize => "expected a size this machine can hold",
            };
            malformed(Location::Json(json.to_string()), format!("{what}{more}; {expected}"))
        }
        gltf::Error::Deserialize(e) => {
            malformed(Location::Line(e.line()), format!("not valid glTF JSON: {e}; expected a glTF 2.0 document"))
        }
        gltf::Error::Binary(e) => {
            malformed(Location::File, format!("not a valid GLB file: {e}; expected a binary glTF 2.0 file"))
        }
        other => malformed(Location::File, format!("cannot read the glTF file: {other}")),
    }
}

struct GltfReader<'a> {
    path: &'a Path,
    dir: &'a Path,
    doc: &'a Document,
    blob: Option<&'a [u8]>,
    /// Each buffer's bytes, read on first use.
    buffers: Vec<Option<Vec<u8>>>,
    builder: Builder,
    /// glTF material index -> index into `builder.materials`.
    material_of: Vec<Option<u32>>,
    /// Some primitive read had no NORMAL (TEXCOORD_0).
    normals_missing: bool,
    uvs_missing: bool,
    ignored: Ignored,
}

impl GltfReader<'_> {
    fn error_at(&self, json: &str, message: String) -> MeshError {
        MeshError::Malformed { path: self.path.to_path_buf(), location: Location::Json(json.to_string()), message }
    }

    /// Notes of the document as a whole: what rlpt does not render.
    fn note_document(&mut self) {
        const READ: &[&str] = &["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_emissive_strength"];
        for ext in self.doc.extensions_used() {
            if !READ.contains(&ext) {
                self.ignored.add("extensions", ext.to_string());
            }
        }
        let counted = [
            ("skins (the bind pose is rendered)", self.doc.skins().len()),
            ("animations", self.doc.animations().len()),
            ("cameras (the scene's camera is used)", self.doc.cameras().len()),
        ];
        for (what, n) in counted {
            if n > 0 {
                self.ignored.add(what, "");
            }
        }
    }

    fn node(&mut self, index: usize, parent: DMat4, depth: usize) -> Result<(), MeshError> {
        let json = format!("nodes[{index}]");
        if depth > MAX_DEPTH {
            return Err(self.error_at(
                &json,
                format!("nodes nest deeper than {MAX_DEPTH}; expected a tree of nodes, not a cycle"),
            ));
        }
        let node = self.doc.nodes().nth(index).expect("validated node index");
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent * local;
        if let Some(mesh) = node.mesh() {
            let linear = DMat3::from_mat4(world);
            let det = linear.determinant();
            if !det.is_finite() || det == 0.0 || !world.is_finite() {
                self.ignored.add("nodes whose transform is singular (their meshes are skipped)", json.clone());
            } else {
                for primitive in mesh.primitives() {
                    self.primitive(&mesh, &primitive, &world, det < 0.0)?;
                }
            }
            if !mesh.primitives().all(|p| p.morph_targets().len() == 0) {
                self.ignored.add("morph targets", format!("meshes[{}]", mesh.index()));
            }
        }
        let children: Vec<usize> = node.children().map(|c| c.index()).collect();
        for child in children {
            self.node(child, world, depth + 1)?;
        }
        Ok(())
    }

    fn primitive(
        &mut self,
        mesh: &gltf::Mesh<'_>,
        primitive: &gltf::Primitive<'_>,
        world: &DMat4,
        mirrored: bool,
    ) -> Result<(), MeshError> {
        let json = format!("meshes[{}].primitives[{}]", mesh.index(), primitive.index());
        let mode = primitive.mode();
        if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
            self.ignored.add("points and lines", format!("{json} (mode {mode:?})"));
            return Ok(());
        }
        let Some(position) = primitive.get(&Semantic::Positions) else {
            return Err(self
                .error_at(&json, "the primitive has no POSITION attribute; expected attributes.POSITION".to_string()));
        };
        let position_json = format!("{json}.attributes.POSITION");
        let positions = self.vec3s(&position, &position_json)?;
        let normals = match primitive.get(&Semantic::Normals) {
            Some(a) => {
                let normal_json = format!("{json}.attributes.NORMAL");
                let n = self.vec3s(&a, &normal_json)?;
                if n.len() != positions.len() {
                    return Err(self.error_at(
                        &normal_json,
                        format!(
                            "{} normals for {} positions; expected one normal per position",
                            n.len(),
                            positions.len()
                        ),
                    ));
                }
                Some(n)
            }
            None => None,
        };
        let uvs = match primitive.get(&Semantic::TexCoords(0)) {
            Some(a) => {
                let uv_json = format!("{json}.attributes.TEXCOORD_0");
                let uv = self.vec2s(&a, &uv_json)?;
                if uv.len() != positions.len() {
                    return Err(self.error_at(
                        &uv_json,
                        format!("{} UVs for {} positions; expected one per position", uv.len(), positions.len()),
                    ));
                }
                Some(uv)
            }
            None => None,
        };
        if primitive.attributes().any(|(s, _)| matches!(s, Semantic::Colors(_))) {
            self.ignored.add("vertex colours", json.clone());
        }
        let corners: Vec<u32> = match primitive.indices() {
            Some(a) => self.indices(&a, &format!("{json}.indices"), positions.len())?,
            None => (0..positions.len() as u32).collect(),
        };
        let mut triangles: Vec<[u32; 3]> = match mode {
            Mode::TriangleStrip => (0..corners.len().saturating_sub(2))
                .map(|i| {
                    let (a, b, c) = (corners[i], corners[i + 1], corners[i + 2]);
                    if i % 2 == 0 {
                        [a, b, c]
                    } else {
                        [b, a, c]
                    }
                })
                .collect(),
            Mode::TriangleFan => {
                (1..corners.len().saturating_sub(1)).map(|i| [corners[0], corners[i], corners[i + 1]]).collect()
            }
            _ => {
                if !corners.len().is_multiple_of(3) {
                    return Err(self.error_at(
                        &json,
                        format!("{} vertices in TRIANGLES mode; expected a multiple of 3", corners.len()),
                    ));
                }
                corners.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
            }
        };
        if mirrored {
            triangles.iter_mut().for_each(|t| t.swap(1, 2));
        }

        let material = self.material(primitive.material());
        let base = self.builder.positions.len() as u32;
        for (k, p) in positions.iter().enumerate() {
            let w = world.transform_point3(p.as_dvec3());
            let wp = w.as_vec3();
            if !wp.is_finite() {
                return Err(MeshError::NotFinite {
                    path: self.path.to_path_buf(),
                    location: Location::Json(format!("{position_json}[{k}]")),
                    what: "the position after the node transforms".to_string(),
                    value: vec_text(wp),
                });
            }
            self.builder.positions.push(wp);
        }
        match normals {
            Some(n) => {
                let normal_matrix = DMat3::from_mat4(*world).inverse().transpose();
                let out = self.builder.normals.get_or_insert_with(Vec::new);
                out.resize(base as usize, Vec3::ZERO);
                out.extend(n.iter().map(|v| (normal_matrix * v.as_dvec3()).as_vec3()));
            }
            None => self.normals_missing = true,
        }
        match uvs {
            // glTF's v runs down the image; rlpt's up.
            Some(uv) => {
                let out = self.builder.uvs.get_or_insert_with(Vec::new);
                out.resize(base as usize, Vec2::ZERO);
                out.extend(uv.iter().map(|t| Vec2::new(t.x, 1.0 - t.y)));
            }
            None => self.uvs_missing = true,
        }
        for t in triangles {
            self.builder.triangles.push(t.map(|i| i + base));
            self.builder.triangle_materials.push(material);
        }
        Ok(())
    }

    /// The builder's index of a primitive's material, mapped on first use;
    /// [`NO_MATERIAL`] where the primitive names none.
    fn material(&mut self, material: gltf::Material<'_>) -> u32 {
        let Some(index) = material.index() else {
            return NO_MATERIAL;
        };
        if let Some(m) = self.material_of[index] {
            return m;
        }
        let embedded = embedded_images(&material, &mut |v| self.view_bytes(v));
        let mapped = map_material(&material, index, self.dir, self.path, &embedded, &mut self.ignored);
        let m = self.builder.materials.len() as u32;
        self.builder.materials.push(mapped);
        self.material_of[index] = Some(m);
        m
    }

    /// The bytes of a bufferView (an embedded image's), the view within its buffer.
    fn view_bytes(&mut self, view: &gltf::buffer::View<'_>) -> Result<Vec<u8>, String> {
        let (start, end, declared) =
            (view.offset(), view.offset().saturating_add(view.length()), view.buffer().length());
        if end > declared {
            return Err(format!(
                "bufferViews[{}] spans bytes {start} to {end} of buffers[{}], whose byteLength is {declared}",
                view.index(),
                view.buffer().index()
            ));
        }
        Ok(self.buffer(view.buffer().index()).map_err(|e| e.to_string())?[start..end].to_vec())
    }

    /// A buffer's bytes: the GLB's BIN chunk, a `data:` URI, or a file beside
    /// the glTF; at least its `byteLength` of them.
    fn buffer(&mut self, index: usize) -> Result<&[u8], MeshError> {
        if self.buffers[index].is_none() {
            let buffer = self.doc.buffers().nth(index).expect("validated buffer index");
            let json = format!("buffers[{index}]");
            let missing = |message: String| MeshError::MissingBuffer {
                path: self.path.to_path_buf(),
                location: Location::Json(json.clone()),
                message,
            };
            let (data, source) = match buffer.source() {
                gltf::buffer::Source::Bin => match self.blob {
                    Some(blob) => (blob.to_vec(), "the GLB's BIN chunk".to_string()),
                    None => {
                        return Err(missing(
                            "the buffer has no uri and the file has no GLB BIN chunk; expected a `uri` or a .glb \
                             with its binary chunk"
                                .to_string(),
                        ))
                    }
                },
                gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                    let data = decode_data_uri(uri).ok_or_else(|| {
                        missing(
                            "cannot decode the `data:` uri; expected `data:...;base64,` and base64 text".to_string(),
                        )
                    })?;
                    (data, "its data: uri".to_string())
                }
                gltf::buffer::Source::Uri(uri) => {
                    if uri.contains("://") {
                        return Err(missing(format!(
                            "the uri `{uri}` is not a file beside the glTF; expected a relative file path"
                        )));
                    }
                    let file = self.dir.join(percent_decode(uri));
                    let data = read_file(
                        &file,
                        self.path,
                        Location::Json(format!("{json}.uri")),
                        &format!("the buffer `{uri}` ({})", file.display()),
                    )
                    .map_err(|e| match e {
                        MeshError::Io { path, location, what, error } => {
                            MeshError::MissingBuffer { path, location, message: format!("cannot read {what}: {error}") }
                        }
                        other => other,
                    })?;
                    (data, format!("`{uri}`"))
                }
            };
            if data.len() < buffer.length() {
                return Err(missing(format!(
                    "byteLength is {} but {source} holds {} bytes; expected at least byteLength bytes",
                    buffer.length(),
                    data.len()
                )));
            }
            self.buffers[index] = Some(data);
        }
        Ok(self.buffers[index].as_deref().expect("just read"))
    }

    /// The bytes of each element of an accessor (tightly packed), every range
    /// checked: accessor within its view, view within its buffer.
    fn elements(&mut self, accessor: &Accessor<'_>, json: &str) -> Result<Vec<u8>, MeshError> {
        let label = format!("{json} (accessors[{}])", accessor.index());
        let out_of_bounds = |message: String| MeshError::AccessorOutOfBounds {
            path: self.path.to_path_buf(),
            location: Location::Json(label.clone()),
            message,
        };
        if accessor.sparse().is_some() {
            return Err(self.error_at(
                &label,
                "the accessor is sparse; expected a plain accessor (rlpt does not read sparse ones)".to_string(),
            ));
        }
        let Some(view) = accessor.view() else {
            return Err(self.error_at(&label, "the accessor has no bufferView; expected one".to_string()));
        };
        let size = accessor.size();
        let stride = view.stride().unwrap_or(size);
        let count = accessor.count();
        // Saturating: a count or offset of absurd size is out of bounds, not an overflow.
        let needed = if count == 0 {
            0
        } else {
            accessor.offset().saturating_add(stride.saturating_mul(count - 1)).saturating_add(size)
        };
        if needed > view.length() {
            return Err(out_of_bounds(format!(
                "{count} elements of {size} bytes from byteOffset {} with stride {stride} need {needed} bytes \
                 of bufferViews[{}], which has {}; expected the accessor within its view",
                accessor.offset(),
                view.index(),
                view.length()
            )));
        }
        let buffer_index = view.buffer().index();
        let declared = view.buffer().length();
        if view.offset().saturating_add(view.length()) > declared {
            return Err(out_of_bounds(format!(
                "bufferViews[{}] spans bytes {} to {} of buffers[{buffer_index}], whose byteLength is {declared}; \
                 expected the view within its buffer",
                view.index(),
                view.offset(),
                view.offset().saturating_add(view.length())
            )));
        }
        let start = view.offset() + accessor.offset();
        let data = self.buffer(buffer_index)?;
        let mut out = Vec::with_capacity(count * size);
        for k in 0..count {
            let at = start + k * stride;
            out.extend_from_slice(&data[at..at + size]);
        }
        Ok(out)
    }

    /// A VEC2 accessor of FLOAT, or of normalized UNSIGNED_BYTE or
    /// UNSIGNED_SHORT (TEXCOORD_n), every value finite.
    fn vec2s(&mut self, accessor: &Accessor<'_>, json: &str) -> Result<Vec<Vec2>, MeshError> {
        let ty = accessor.data_type();
        let ok = match ty {
            DataType::F32 => true,
            DataType::U8 | DataType::U16 => accessor.normalized(),
            _ => false,
        };
        if accessor.dimensions() != Dimensions::Vec2 || !ok {
            return Err(self.error_at(
                json,
                format!(
                    "accessors[{}] is {} of {}{}; expected VEC2 of FLOAT (or normalized UNSIGNED_BYTE or UNSIGNED_SHORT)",
                    accessor.index(),
                    dimensions_name(accessor.dimensions()),
                    type_name(ty),
                    if accessor.normalized() { " (normalized)" } else { "" }
                ),
            ));
        }
        let bytes = self.elements(accessor, json)?;
        let size = accessor.size() / 2;
        let mut out = Vec::with_capacity(accessor.count());
        for (k, c) in bytes.chunks_exact(2 * size).enumerate() {
            let f = |i: usize| match ty {
                DataType::F32 => f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]),
                DataType::U8 => c[i] as f32 / 255.0,
                _ => u16::from_le_bytes([c[i], c[i + 1]]) as f32 / 65535.0,
            };
            let v = Vec2::new(f(0), f(size));
            if !v.is_finite() {
                return Err(MeshError::NotFinite {
                    path: self.path.to_path_buf(),
                    location: Location::Json(format!("{json}[{k}]")),
                    what: format!("a component of element {k}"),
                    value: number(if v.x.is_finite() { v.y } else { v.x } as f64),
                });
            }
            out.push(v);
        }
        Ok(out)
    }

    /// A VEC3 of FLOAT accessor, every value finite.
    fn vec3s(&mut self, accessor: &Accessor<'_>, json: &str) -> Result<Vec<Vec3>, MeshError> {
        if accessor.dimensions() != Dimensions::Vec3 || accessor.data_type() != DataType::F32 {
            return Err(self.error_at(
                json,
                format!(
                    "accessors[{}] is {} of {}; expected VEC3 of FLOAT",
                    accessor.index(),
                    dimensions_name(accessor.dimensions()),
                    type_name(accessor.data_type())
                ),
            ));
        }
        let bytes = self.elements(accessor, json)?;
        let mut out = Vec::with_capacity(accessor.count());
        for (k, c) in bytes.chunks_exact(12).enumerate() {
            let f = |i: usize| f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
            let v = Vec3::new(f(0), f(4), f(8));
            if !v.is_finite() {
                let bad = (0..3).map(|i| v[i]).find(|x| !x.is_finite()).unwrap_or(0.0);
                return Err(MeshError::NotFinite {
                    path: self.path.to_path_buf(),
                    location: Location::Json(format!("{json}[{k}]")),
                    what: format!("a component of element {k}"),
                    value: number(f64::from(bad)),
                });
            }
            out.push(v);
        }
        Ok(out)
    }

    /// A SCALAR accessor of UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT, every
    /// index below `vertices`.
    fn indices(&mut self, accessor: &Accessor<'_>, json: &str, vertices: usize) -> Result<Vec<u32>, MeshError> {
        let width = match (accessor.dimensions(), accessor.data_type()) {
            (Dimensions::Scalar, DataType::U8) => 1,
            (Dimensions::Scalar, DataType::U16) => 2,
            (Dimensions::Scalar, DataType::U32) => 4,
            (d, t) => {
                return Err(self.error_at(
                    json,
                    format!(
                        "accessors[{}] is {} of {}; expected SCALAR of UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT",
                        accessor.index(),
                        dimensions_name(d),
                        type_name(t)
                    ),
                ))
            }
        };
        let bytes = self.elements(accessor, json)?;
        let mut out = Vec::with_capacity(accessor.count());
        for (k, c) in bytes.chunks_exact(width).enumerate() {
            let i = match width {
                1 => u32::from(c[0]),
                2 => u32::from(u16::from_le_bytes([c[0], c[1]])),
                _ => u32::from_le_bytes([c[0], c[1], c[2], c[3]]),
            };
            if i as usize >= vertices {
                return Err(MeshError::IndexOutOfRange {
                    path: self.path.to_path_buf(),
                    location: Location::Json(format!("{json}[{k}]")),
                    what: "vertex index",
                    index: i64::from(i),
                    expected: format!("0 to {} (the primitive has {vertices} vertices)", vertices.saturating_sub(1)),
                });
            }
            out.push(i);
        }
        Ok(out)
    }
}

/// An accessor's `type` as glTF writes it.
fn dimensions_name(d: Dimensions) -> &'static str {
    match d {
        Dimensions::Scalar => "SCALAR",
        Dimensions::Vec2 => "VEC2",
        Dimensions::Vec3 => "VEC3",
        Dimensions::Vec4 => "VEC4",
        Dimensions::Mat2 => "MAT2",
        Dimensions::Mat3 => "MAT3",
        Dimensions::Mat4 => "MAT4",
    }
}

/// An accessor's `componentType` as glTF names it.
fn type_name(t: DataType) -> &'static str {
    match t {
        DataType::I8 => "BYTE",
        DataType::U8 => "UNSIGNED_BYTE",
        DataType::I16 => "SHORT",
        DataType::U16 => "UNSIGNED_SHORT",
        DataType::U32 => "UNSIGNED_INT",
        DataType::F32 => "FLOAT",
    }
}

/// `%20` and the like in a relative URI.
pub(super) fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            if let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// The bytes of a `data:[<mediatype>];base64,<data>` URI.
pub(super) fn decode_data_uri(uri: &str) -> Option<Vec<u8>> {
    let (header, data) = uri.strip_prefix("data:")?.split_once(',')?;
    if !header.ends_with(";base64") {
        return None;
    }
    let value = |c: u8| match c {
        b'A'..=b'Z' => Some(c - b'A'),
        b'a'..=b'z' => Some(c - b'a' + 26),
        b'0'..=b'9' => Some(c - b'0' + 52),
        b'+' | b'-' => Some(62),
        b'/' | b'_' => Some(63),
        _ => None,
    };
    let mut out = Vec::with_capacity(data.len() * 3 / 4);
    let (mut acc, mut bits) = (0u32, 0);
    for &c in data.as_bytes().iter().filter(|c| !c.is_ascii_whitespace() && **c != b'=') {
        acc = (acc << 6) | u32::from(value(c)?);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_uris_and_percent_escapes_decode() {
        assert_eq!(decode_data_uri("data:application/octet-stream;base64,AAECAw==").unwrap(), vec![0, 1, 2, 3]);
        assert_eq!(decode_data_uri("data:application/octet-stream;base64,aGVsbG8").unwrap(), b"hello".to_vec());
        assert_eq!(decode_data_uri("data:text/plain,hello"), None);
        assert_eq!(decode_data_uri("data:;base64,a*b"), None);
        assert_eq!(percent_decode("my%20mesh.bin"), "my mesh.bin");
        assert_eq!(percent_decode("100%"), "100%");
        assert_eq!(percent_decode("a%2"), "a%2");
    }
}
