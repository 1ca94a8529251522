//! Shapes, area lights and lights: placed in the space rlpt renders
//! in (pbrt's camera space mirrored in x), each turned the way pbrt turns it.

use std::collections::HashMap;
use std::path::PathBuf;

use glam::{DMat3, DMat4, DVec3, Vec3};

use super::images;
use super::lexer::Loc;
use super::params::Params;
use super::{AreaLight, Importer, Pending};
use crate::scene::mesh::{self, Builder, MeshFile, PlaceError};
use crate::scene::SphereUv;
use crate::scene::{Material, Mesh, SceneError, Sphere};

/// Largest coordinate magnitude (as the TOML loader's).
const LIMIT: f64 = 1e12;

/// pbrt's shapes rlpt does not draw: skipped with a note.
const SKIPPED_SHAPES: &[&str] =
    &["disk", "cylinder", "cone", "paraboloid", "hyperboloid", "curve", "loopsubdiv", "nurbs", "heightfield"];

/// What the import has made so far.
#[derive(Default)]
pub(super) struct Output {
    pub materials: Vec<Material>,
    pub spheres: Vec<Sphere>,
    pub meshes: Vec<Mesh>,
    pub environment: Vec3,
    /// The first `infinite` light's equirectangular image, where it maps.
    pub environment_map: Option<crate::scene::EnvironmentMap>,
    /// (pbrt material, emission bits, two-sided) -> index into `materials`.
    pub keys: HashMap<(usize, [u32; 3], bool), u32>,
    /// PLY files read, by resolved path (instances read theirs once).
    pub files: HashMap<PathBuf, MeshFile>,
    /// `distant`, `point` and `spot` lights, in rlpt's space.
    pub delta_lights: Vec<crate::scene::DeltaLight>,
}

impl Importer {
    /// The scene material for pbrt material `m` with `area`'s emission; a mix's
    /// materials become scene materials too (without the emission, which is the
    /// surface's, the mix's own).
    fn scene_material(&mut self, m: usize, area: Option<&AreaLight>) -> u32 {
        let (emission, two_sided) = area.map_or((Vec3::ZERO, false), |a| (a.radiance, a.two_sided));
        let key = (m, emission.to_array().map(f32::to_bits), two_sided);
        if let Some(&i) = self.out.keys.get(&key) {
            return i;
        }
        let mut material = self.materials[m].material.clone();
        if let Some([a, b]) = material.mix {
            material.mix = Some([self.scene_material(a as usize, None), self.scene_material(b as usize, None)]);
        }
        if area.is_some() {
            material.emission = emission;
            material.two_sided = two_sided;
            material.name = format!("{} + area light {}", material.name, self.out.materials.len());
        }
        self.out.materials.push(material);
        let i = (self.out.materials.len() - 1) as u32;
        self.out.keys.insert(key, i);
        i
    }

    /// One `Shape`; `instance` is the `ObjectInstance`'s transform (identity outside one).
    pub(super) fn shape(&mut self, s: &Pending, instance: &DMat4, instanced: bool) -> Result<(), SceneError> {
        let (p, loc) = (&s.params, &s.loc);
        let m = self.bake * *instance * s.state.ctm;
        let mut area = s.state.area.clone();
        if instanced && area.is_some() {
            self.notes
                .approximated(loc, "an area light on a shape of an object instance ignored, as pbrt-v4 does".into())?;
            area = None;
        }
        let kind = s.kind.as_str();
        if SKIPPED_SHAPES.contains(&kind) {
            return self.notes.approximated(loc, format!("Shape \"{kind}\" skipped (rlpt does not render it)"));
        }
        let material = self.scene_material(s.state.material, area.as_ref());
        match kind {
            "sphere" => self.sphere(p, loc, &m, s.state.reverse, material)?,
            "trianglemesh" | "bilinearmesh" | "plymesh" => {
                let (file, source) = if kind == "plymesh" {
                    self.ply(p, loc)?
                } else {
                    (inline_mesh(kind, p, loc)?, PathBuf::from(&*loc.file))
                };
                let placed = mesh::place(&file, &m, file.normals.is_some(), LIMIT).map_err(|e| match e {
                    PlaceError::OutOfRange { vertex, position } => loc.error(format!(
                        "Shape \"{kind}\": vertex {vertex} lies at {position} in rlpt's space; expected within +-1e12"
                    )),
                    PlaceError::AllDegenerate { triangles } => loc.error(format!(
                        "Shape \"{kind}\": all {triangles} triangles have zero area after the transform"
                    )),
                })?;
                let mut triangles = placed.triangles;
                let mut normals = placed.normals;
                orient(&mut triangles, normals.as_mut(), &placed.positions, s.state.reverse, file.normals.is_some());
                let n = triangles.len();
                self.out.meshes.push(Mesh {
                    source,
                    positions: placed.positions,
                    normals,
                    triangles,
                    materials: vec![material; n],
                    uvs: file.uvs.clone(),
                });
            }
            _ => {
                return Err(loc.error(format!(
                    "unknown shape \"{kind}\"; rlpt reads plymesh, trianglemesh, bilinearmesh and sphere \
                     (and skips {} with a note)",
                    SKIPPED_SHAPES.join(", ")
                )))
            }
        }
        let unused: Vec<String> = p.unused().map(|q| q.label()).collect();
        if !unused.is_empty() {
            self.notes.approximated(loc, format!("Shape \"{kind}\": ignored {}", unused.join(", ")))?;
        }
        Ok(())
    }

    fn sphere(&mut self, p: &Params, loc: &Loc, m: &DMat4, reverse: bool, material: u32) -> Result<(), SceneError> {
        let r = p.float_or("radius", 1.0)?;
        if r <= 0.0 {
            return Err(loc.error(format!("Shape \"sphere\": \"float radius\" must be > 0, found {r}")));
        }
        let (zmin, zmax, phimax) = (p.float_or("zmin", -r)?, p.float_or("zmax", r)?, p.float_or("phimax", 360.0)?);
        if zmin > -r || zmax < r || phimax < 360.0 {
            self.notes.approximated(
                loc,
                format!("a partial sphere (zmin {zmin}, zmax {zmax}, phimax {phimax}) rendered whole"),
            )?;
        }
        let linear = DMat3::from_mat4(*m);
        let det = linear.determinant();
        let scale = det.abs().cbrt();
        let gram = linear.transpose() * linear;
        let uniform = (0..3).all(|i| {
            (0..3).all(|j| {
                let want = if i == j { scale * scale } else { 0.0 };
                (gram.col(i)[j] - want).abs() <= 1e-4 * scale * scale
            })
        });
        if !uniform {
            self.notes.approximated(
                loc,
                format!(
                    "a sphere under a non-uniform scale (an ellipsoid in pbrt) rendered as a sphere of radius {}",
                    r * scale
                ),
            )?;
        }
        if reverse != (det < 0.0) {
            self.notes.approximated(loc, "a sphere whose normals pbrt turns inward (ReverseOrientation or a mirroring transform) rendered with outward normals".into())?;
        }
        let center = m.transform_point3(DVec3::ZERO);
        let radius = r * scale;
        if !center.is_finite()
            || center.abs().max_element() > LIMIT
            || !(radius > 0.0 && radius <= LIMIT)
            || (radius as f32).powi(2) == 0.0
        {
            return Err(
                loc.error(format!("Shape \"sphere\": centre {center} or radius {radius} out of range in rlpt's space"))
            );
        }
        // pbrt's UVs: phi and theta in object space, over phimax and zmin..zmax.
        let inverse = linear.inverse() * scale;
        let (zlo, zhi) = (zmin.min(zmax).clamp(-r, r), zmin.max(zmax).clamp(-r, r));
        let (mut theta_min, mut theta_max) = ((zlo / r).acos() as f32, (zhi / r).acos() as f32);
        if (theta_max - theta_min).abs() < 1e-6 {
            (theta_min, theta_max) = (std::f32::consts::PI, 0.0);
        }
        let uv = SphereUv {
            to_object: [0, 1, 2].map(|i| inverse.row(i).as_vec3()),
            phi_max: (phimax.clamp(1e-3, 360.0) as f32).to_radians(),
            theta_min,
            theta_max,
        };
        self.out.spheres.push(Sphere { center: center.as_vec3(), radius: radius as f32, material, uv });
        Ok(())
    }

    /// A `plymesh`'s file, read once per path, and its resolved path.
    fn ply(&mut self, p: &Params, loc: &Loc) -> Result<(MeshFile, PathBuf), SceneError> {
        let f = p.string("filename")?.ok_or_else(|| loc.error("Shape \"plymesh\": missing \"string filename\""))?;
        let path = self.base.join(&f);
        if let Some(file) = self.out.files.get(&path) {
            return Ok((file.clone(), path));
        }
        if !path.is_file() {
            return Err(loc.error(format!(
                "Shape \"plymesh\": the file \"{f}\" does not exist (resolved to {})",
                path.display()
            )));
        }
        let file = mesh::load_mesh_file(&path).map_err(|error| crate::scene::SceneError::Mesh {
            file: loc.file.to_string(),
            position: Some((loc.line, loc.column)),
            table: "Shape \"plymesh\"".into(),
            error: Box::new(error),
        })?;
        for note in &file.notes {
            self.notes.approximated(loc, format!("{}: {note}", path.display()))?;
        }
        self.out.files.insert(path.clone(), file.clone());
        Ok((file, path))
    }

    /// `AreaLightSource "diffuse"`: the emission of the shapes that follow.
    pub(super) fn area_light(&mut self, ty: &str, p: &Params, loc: &Loc) -> Result<(), SceneError> {
        if ty != "diffuse" {
            return Err(loc.error(format!("unknown area light \"{ty}\"; pbrt's only area light is \"diffuse\"")));
        }
        let mut r = self.reader(p, loc, "AreaLightSource \"diffuse\"".into());
        let l = r.colour("L", Vec3::ONE)?;
        let scale = r.colour("scale", Vec3::ONE)?;
        let two_sided = p.bool("twosided")?.unwrap_or(false);
        let radiance = l * scale;
        if radiance.min_element() < 0.0 || radiance.max_element() > 1e12 {
            return Err(loc.error(format!("AreaLightSource: radiance {radiance} must be from 0 to 1e12")));
        }
        let unused: Vec<String> = p.unused().map(|q| q.label()).collect();
        if !unused.is_empty() {
            self.notes.approximated(loc, format!("AreaLightSource \"diffuse\": ignored {}", unused.join(", ")))?;
        }
        self.state.area = Some(AreaLight { radiance, two_sided });
        Ok(())
    }

    /// The image environment of an `infinite` light's `f` times `tint` (L times
    /// scale): pbrt's equirectangular map (pbrt-v3; z up in the light's space,
    /// u = phi / 2 pi from +x towards +y) in rlpt's convention
    /// (`crate::math::envmap`), turned by the light's transform and the bake.
    /// The error says why it stays a uniform sky: a square image (pbrt-v4's
    /// equal-area octahedral map, which rlpt does not read), another shape, a
    /// transform that is not a rotation, a second image, or a file that does not read.
    fn environment_image(&self, f: &str, tint: Vec3) -> Result<crate::scene::EnvironmentMap, String> {
        if self.out.environment_map.is_some() {
            return Err("is a second environment image (rlpt renders one)".into());
        }
        let mut map = crate::scene::EnvironmentMap::read(f, &self.base, 1.0, 0.0)?;
        let (w, h) = (map.width, map.height);
        if w == h {
            return Err("is square, pbrt-v4's equal-area octahedral map, which rlpt does not read".into());
        }
        if w != 2 * h {
            return Err(format!("is {w} x {h}, not an equirectangular map (width twice the height)"));
        }
        // Light space to rlpt's: the light's transform, then the bake; a rotation
        // (or a mirroring one) once its uniform scale is divided out.
        let m = glam::DMat3::from_mat4(self.bake * self.state.ctm);
        let scale = m.determinant().abs().cbrt();
        let r = m * (1.0 / scale);
        if !(scale > 0.0) || !(r.transpose() * r).abs_diff_eq(glam::DMat3::IDENTITY, 1e-4) {
            return Err("has a transform that is not a rotation".into());
        }
        // pbrt's (x, y, z) in rlpt's map frame: (y, z, x) with the columns
        // flipped where the transform keeps handedness, (-y, z, x) where it
        // mirrors (the bake mirrors x), so that the same direction reads the
        // same texel.
        let mirrored = r.determinant() < 0.0;
        let p = if mirrored {
            glam::DMat3::from_cols(glam::DVec3::new(0.0, 0.0, 1.0), glam::DVec3::new(-1.0, 0.0, 0.0), glam::DVec3::Y)
        } else {
            glam::DMat3::from_cols(glam::DVec3::new(0.0, 0.0, 1.0), glam::DVec3::X, glam::DVec3::Y)
        };
        map.to_map = (p * r.transpose()).as_mat3();
        let wu = w as usize;
        for row in map.texels.chunks_mut(wu) {
            if !mirrored {
                row.reverse();
            }
            for t in row {
                *t = [t[0] * tint.x, t[1] * tint.y, t[2] * tint.z];
            }
        }
        Ok(map)
    }

    /// `LightSource`: `infinite` becomes the environment; `distant`, `point` and
    /// `spot` delta lights (lights.rs); goniometric and projection lights are dropped with a note.
    pub(super) fn light(&mut self, ty: &str, p: &Params, loc: &Loc) -> Result<(), SceneError> {
        match ty {
            "infinite" => {
                let mut r = self.reader(p, loc, "LightSource \"infinite\"".into());
                let l = r.colour("L", Vec3::ONE)?;
                let scale = r.colour("scale", Vec3::ONE)?;
                let file = match p.string("filename")? {
                    Some(f) => Some(f),
                    None => p.string("mapname")?,
                };
                let mut radiance = l * scale;
                if let Some(f) = file {
                    let path = self.base.join(&f);
                    // An equirectangular image whose transform turns pbrt's map
                    // (z up) into one of rlpt's frames is rendered as an image;
                    // anything else as a uniform sky of its mean, said so.
                    let why = match self.environment_image(&f, radiance) {
                        Ok(map) => {
                            self.out.environment_map = Some(map);
                            None
                        }
                        Err(why) => Some(why),
                    };
                    // The mean is read only where the image does not map.
                    match why.map(|why| (why, images::mean(&path, None, true))) {
                        None => radiance = Vec3::ZERO,
                        Some((why, Ok(mean))) => {
                            radiance *= mean;
                            self.notes.approximated(
                                loc,
                                format!("the environment image \"{f}\" {why}: a uniform sky of its mean radiance {radiance}"),
                            )?;
                        }
                        Some((_, Err(why))) => self.notes.approximated(
                            loc,
                            format!(
                                "the environment image \"{f}\" ({}) {why}: a uniform sky of radiance {radiance} \
                             (L times scale) stands in",
                                path.display()
                            ),
                        )?,
                    }
                }
                if radiance.min_element() < 0.0 || radiance.max_element() > 1e12 {
                    return Err(
                        loc.error(format!("LightSource \"infinite\": radiance {radiance} must be from 0 to 1e12"))
                    );
                }
                self.out.environment += radiance;
                let unused: Vec<String> = p.unused().map(|q| q.label()).collect();
                if !unused.is_empty() {
                    self.notes.approximated(loc, format!("LightSource \"infinite\": ignored {}", unused.join(", ")))?;
                }
                Ok(())
            }
            "distant" | "point" | "spot" => self.delta_light(ty, p, loc),
            "goniometric" | "projection" => self.notes.approximated(
                loc,
                format!("LightSource \"{ty}\" dropped (rlpt has no goniometric or projection lights)"),
            ),
            _ => Err(loc.error(format!(
                "unknown light \"{ty}\"; expected infinite, distant, point, spot, goniometric or projection"
            ))),
        }
    }
}

/// A `trianglemesh` or `bilinearmesh` (two triangles per patch) from its parameters.
fn inline_mesh(kind: &str, p: &Params, loc: &Loc) -> Result<MeshFile, SceneError> {
    let per = if kind == "trianglemesh" { 3 } else { 4 };
    let pp =
        p.get("P", &["point3", "point"]).ok_or_else(|| loc.error(format!("Shape \"{kind}\": missing \"point3 P\"")))?;
    let v = pp.numbers()?;
    if v.is_empty() || v.len() % 3 != 0 {
        return Err(pp
            .loc
            .error(format!("Shape \"{kind}\": \"P\" must hold x y z triples, found {} numbers", v.len())));
    }
    let positions: Vec<Vec3> = v.chunks(3).map(|c| DVec3::new(c[0], c[1], c[2]).as_vec3()).collect();
    let n = positions.len();
    let indices: Vec<u32> = match p.get("indices", &["integer"]) {
        Some(q) => {
            let v = q.numbers()?;
            if v.is_empty() || v.len() % per != 0 {
                return Err(q.loc.error(format!(
                    "Shape \"{kind}\": \"indices\" must hold groups of {per}, found {} numbers",
                    v.len()
                )));
            }
            let mut out = Vec::with_capacity(v.len());
            for (k, x) in v.iter().enumerate() {
                if x.fract() != 0.0 || *x < 0.0 || *x >= n as f64 {
                    return Err(q.values[k].1.error(format!(
                        "Shape \"{kind}\": index {x} (number {} of \"indices\") is out of range: expected an integer from 0 to {}",
                        k + 1,
                        n - 1
                    )));
                }
                out.push(*x as u32);
            }
            out
        }
        None if n == per => (0..per as u32).collect(),
        None => {
            return Err(loc.error(format!("Shape \"{kind}\": missing \"integer indices\" ({n} vertices, not {per})")))
        }
    };
    let normals = match p.get("N", &["normal", "normal3"]) {
        None => None,
        Some(q) => {
            let v = q.numbers()?;
            if v.len() != 3 * n {
                return Err(q.loc.error(format!(
                    "Shape \"{kind}\": \"N\" must have one normal per vertex ({n}), found {} numbers",
                    v.len()
                )));
            }
            Some(v.chunks(3).map(|c| DVec3::new(c[0], c[1], c[2]).as_vec3()).collect())
        }
    };
    // pbrt-v4's "point2 uv", pbrt-v3's "float uv" or "float st": one pair per vertex.
    let uvs = match p.get("uv", &["point2", "float"]).or_else(|| p.get("st", &["point2", "float"])) {
        None => None,
        Some(q) => {
            let v = q.numbers()?;
            if v.len() != 2 * n {
                return Err(q.loc.error(format!(
                    "Shape \"{kind}\": \"{}\" must have one u v pair per vertex ({n}), found {} numbers",
                    q.name,
                    v.len()
                )));
            }
            Some(v.chunks(2).map(|c| glam::DVec2::new(c[0], c[1]).as_vec2()).collect())
        }
    };
    let triangles = if per == 3 {
        indices.chunks(3).map(|c| [c[0], c[1], c[2]]).collect()
    } else {
        // Patch corners p00, p10, p01, p11; both triangles keep the patch's
        // normal, cross(p10 - p00, p01 - p00).
        indices.chunks(4).flat_map(|c| [[c[0], c[1], c[3]], [c[0], c[3], c[2]]]).collect()
    };
    let builder = Builder { positions, normals, uvs, triangles, ..Default::default() };
    builder
        .finish(std::path::Path::new(&*loc.file))
        .map_err(|_| loc.error(format!("Shape \"{kind}\": every triangle has zero area")))
}

/// Turns each triangle as pbrt does: placement kept the transformed front side
/// (pbrt flips where the transform swaps handedness); ReverseOrientation flips
/// it; where the shape has normals, the front faces them (pbrt's normals are
/// authoritative).
fn orient(
    triangles: &mut [[u32; 3]],
    normals: Option<&mut Vec<Vec3>>,
    positions: &[Vec3],
    reverse: bool,
    has_normals: bool,
) {
    match normals {
        Some(ns) if has_normals => {
            if reverse {
                ns.iter_mut().for_each(|n| *n = -*n);
            }
            for t in triangles.iter_mut() {
                let [a, b, c] = t.map(|i| positions[i as usize]);
                let sum: Vec3 = t.iter().map(|&i| ns[i as usize]).sum();
                if (b - a).cross(c - a).dot(sum) < 0.0 {
                    t.swap(1, 2);
                }
            }
        }
        _ => {
            if reverse {
                triangles.iter_mut().for_each(|t| t.swap(1, 2));
            }
        }
    }
}
