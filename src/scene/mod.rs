//! Scenes: the TOML format of `SCENE_FORMAT.md`, its validation, and the
//! in-memory [`Scene`] both renderers read.
//!
//! Everything here is validated: a `Scene` that exists is renderable
//! (finite numbers, values in range, material indices in bounds).

mod envmap;
mod load;
pub mod mesh;
mod pbrt;
pub mod procedural;
pub mod texture;

use glam::{Vec2, Vec3};
use std::path::PathBuf;

pub use envmap::EnvironmentMap;
pub use procedural::Procedural;
pub use texture::{TextureImage, TextureRef, TextureUse};

pub use load::SceneError;

/// Pinhole camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Eye point.
    pub position: Vec3,
    /// Unit view direction (from `direction`, or `look_at - position`).
    pub forward: Vec3,
    /// The `up` hint as written (default +y); not necessarily orthogonal to `forward`.
    pub up: Vec3,
    /// Vertical field of view in degrees, 0 < vfov < 180.
    pub vfov_deg: f32,
    /// Primary rays start this far from the eye along the ray (spherical near clip).
    pub near: f32,
}

/// The `[render]` table, defaults filled in.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub max_bounces: u32,
    /// Bounce count after which Russian roulette may end a path; `None` = off.
    pub russian_roulette_depth: Option<u32>,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self { width: 640, height: 480, spp: 64, max_bounces: 8, russian_roulette_depth: None }
    }
}

/// Material types; the discriminants are the values the GPU sees (`glsl/common.glsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum MaterialKind {
    Diffuse = 0,
    Specular = 1,
    Glossy = 2,
    Dielectric = 3,
    Emissive = 4,
    /// GGX conductor, Fresnel of the complex index eta + i k; a mirror at roughness 0.
    Conductor = 5,
    /// A dielectric of roughness > 0 (GGX reflection and transmission); the
    /// scene file's `dielectric` with a `roughness` key above 0.
    RoughDielectric = 6,
    /// A GGX dielectric coat (smooth at roughness 0) over a Lambertian base, or over
    /// a GGX conductor ([`Material::base_roughness`]); an approximation, docs/SCENE_FORMAT.md.
    Coated = 7,
    /// Two materials, one of them chosen at each hit ([`Material::mix`]).
    Mix = 8,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub kind: MaterialKind,
    /// Reflectance in [0, 1]^3 (diffuse, specular, glossy, dielectric; zero for emissive).
    pub albedo: Vec3,
    /// GGX roughness (alpha = roughness^2): in (0, 1] for glossy and rough dielectric,
    /// in [0, 1] for conductor (0 a mirror) and coated (its coat; 0 smooth); 1 otherwise.
    pub roughness: f32,
    /// Index of refraction >= 1 for dielectric, rough dielectric and coated; 1 otherwise.
    pub ior: f32,
    /// A conductor's complex index of refraction eta + i k per channel (eta > 0,
    /// k >= 0); (1, 0) otherwise.
    pub eta: Vec3,
    pub k: Vec3,
    /// Emitted radiance, components >= 0 and finite.
    pub emission: Vec3,
    /// Emission leaves both sides (default: the front side only).
    pub two_sided: bool,
    /// An image whose RGB multiplies `albedo` at each hit (`docs/SCENE_FORMAT.md`).
    pub albedo_texture: Option<TextureRef>,
    /// An image whose value times `roughness` is the roughness at each hit.
    pub roughness_texture: Option<TextureRef>,
    /// A procedural texture whose RGB multiplies `albedo` at each hit, in place of
    /// `albedo_texture` (pbrt's checkerboard, scale and mix).
    pub albedo_procedural: Option<Procedural>,
    /// A conductor whose albedo (times its texture) is pbrt-v4's `reflectance` r
    /// at each hit: eta 1 and k = [`conductor_k`] of r there, the Fresnel untinted.
    pub reflectance_conductor: bool,
    /// A mix's two materials (indices into `Scene::materials`; kind `Mix`): at each
    /// hit the second with chance `albedo.x` (its amount), times the red of its
    /// albedo texture (image or procedural, grey) where it has one, else the first.
    pub mix: Option<[u32; 2]>,
    /// A coated material's conductor base: its GGX roughness in (0, 1] (its index
    /// `eta` + i `k`, tinted by `albedo`; a roughness texture scales this one, not
    /// the coat's). None: the Lambertian base of reflectance `albedo`.
    pub base_roughness: Option<f32>,
}

impl Material {
    /// A material of `kind` and `albedo` with every other field at its default: GGX
    /// roughness 1, index 1, conductor index 1 + 0i, no emission, one-sided. The
    /// scene readers start from it and set what their file says.
    pub fn plain(name: impl Into<String>, kind: MaterialKind, albedo: Vec3) -> Material {
        Material {
            name: name.into(),
            kind,
            albedo,
            roughness: 1.0,
            ior: 1.0,
            eta: Vec3::ONE,
            k: Vec3::ZERO,
            emission: Vec3::ZERO,
            two_sided: false,
            albedo_texture: None,
            roughness_texture: None,
            albedo_procedural: None,
            reflectance_conductor: false,
            mix: None,
            base_roughness: None,
        }
    }

    /// A mix of materials `a` and `b`, `b` at a hit with chance `amount` in [0, 1].
    pub fn mix(name: impl Into<String>, a: u32, b: u32, amount: f32) -> Material {
        Material { mix: Some([a, b]), ..Material::plain(name, MaterialKind::Mix, Vec3::splat(amount)) }
    }

    /// Whether it emits light: the primitives of such materials are the scene's
    /// lights (`PreparedScene::new`).
    pub fn emits(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// Whether it reads a texture at each hit.
    pub fn textured(&self) -> bool {
        self.albedo_texture.is_some() || self.roughness_texture.is_some() || self.albedo_procedural.is_some()
    }
}

/// How many levels of mixes material `m` is (0: not a mix; a mix one more than
/// its deeper material), or None beyond `shared::MIX_MAX_DEPTH` levels (a cycle
/// included): the renderers resolve that many levels and no more.
pub fn mix_depth(materials: &[Material], m: u32) -> Option<u32> {
    fn depth(materials: &[Material], m: u32, left: u32) -> Option<u32> {
        let Some(pair) = materials.get(m as usize).and_then(|x| x.mix) else { return Some(0) };
        let left = left.checked_sub(1)?;
        let (a, b) = (depth(materials, pair[0], left)?, depth(materials, pair[1], left)?);
        Some(1 + a.max(b))
    }
    depth(materials, m, crate::shared::MIX_MAX_DEPTH)
}

/// pbrt-v4's conductor of normal-incidence reflectance `r` (clamped to [0,
/// 0.9999]): eta 1 and this k, `2 sqrt(r) / sqrt(1 - r)`. `glsl/bsdf.glsl`
/// `conductor_k` is its twin.
pub fn conductor_k(r: Vec3) -> Vec3 {
    let r = r.clamp(Vec3::ZERO, Vec3::splat(0.9999));
    2.0 * r.map(f32::sqrt) / (Vec3::ONE - r).map(f32::sqrt)
}

#[derive(Clone, Debug, PartialEq)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
    /// Index into `Scene::materials`.
    pub material: u32,
    /// How its points map to texture coordinates.
    pub uv: SphereUv,
}

/// A sphere's texture coordinates, pbrt's: u = phi / phi_max and v = (theta -
/// theta_min) / (theta_max - theta_min), for the spherical angles (phi from +x
/// towards +y, theta from +z) of the unit normal in the sphere's object space.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereUv {
    /// World directions to object space: the rows of the object-to-world
    /// matrix's inverse, scaled to about unit length (normalized after use).
    pub to_object: [Vec3; 3],
    /// In radians: phi_max, and theta at z_min (pi for a whole sphere) and at z_max (0).
    pub phi_max: f32,
    pub theta_min: f32,
    pub theta_max: f32,
}

impl SphereUv {
    /// The TOML sphere's (`docs/SCENE_FORMAT.md`): object z is world +y and
    /// u = 0.5 at -z, so that u = 0.5 + atan2(x, -z) / 2 pi and v = 1 - acos(y) / pi.
    pub const TOML: SphereUv = SphereUv {
        to_object: [Vec3::Z, Vec3::NEG_X, Vec3::Y],
        phi_max: std::f32::consts::TAU,
        theta_min: std::f32::consts::PI,
        theta_max: 0.0,
    };
}

/// The parallelogram `origin + s*edge_u + t*edge_v`, s,t in [0, 1];
/// front side = direction of `edge_u x edge_v`.
#[derive(Clone, Debug, PartialEq)]
pub struct Quad {
    pub origin: Vec3,
    pub edge_u: Vec3,
    pub edge_v: Vec3,
    /// Index into `Scene::materials`.
    pub material: u32,
}

/// A triangle mesh of a `[[mesh]]` table, in world space (the file's vertices
/// by the table's transform, every one finite and within the scene's limits).
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// The file it came from, resolved against the scene file's directory (for
    /// messages and `rlpt info`).
    pub source: PathBuf,
    pub positions: Vec<Vec3>,
    /// Unit shading normals per vertex, where the mesh is smooth: the file's,
    /// transformed by the inverse transpose, else computed (area-weighted).
    pub normals: Option<Vec<Vec3>>,
    /// Vertex indices, none of zero area; front side = direction of
    /// `(p1 - p0) x (p2 - p0)`.
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle, the index into `Scene::materials`.
    pub materials: Vec<u32>,
    /// Texture coordinates per vertex, where the file has them (v up: OBJ's and
    /// pbrt's convention; glTF's are flipped on reading).
    pub uvs: Option<Vec<Vec2>>,
}

/// Whether the guiding grid's cells (`crate::guide::Grid`) split where paths
/// teach them (`--guide-grid`, `[guiding] grid`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum GridKind {
    /// Cells of one size.
    #[default]
    #[value(help = "cells of one size")]
    Uniform,
    /// Half the cells along each axis, each splitting into 8 (three times at most)
    /// where paths record many targets, in the table of the uniform grid.
    #[value(help = "coarser cells that split where paths record many targets, in the same memory")]
    Adaptive,
}

impl GridKind {
    pub fn name(self) -> &'static str {
        match self {
            GridKind::Uniform => "uniform",
            GridKind::Adaptive => "adaptive",
        }
    }
}

/// The optional `[guiding]` table: where the guiding grid lies and how fine it is.
/// Every field is optional; `None` means "choose automatically" (see `rlpt::guide`).
///
/// When given, `bounds_min` and `bounds_max` come together, `bounds_max` exceeds
/// `bounds_min` on every axis, and every cell count is in 1..=256 with a product
/// of at most 262144.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GuidingSettings {
    pub bounds_min: Option<Vec3>,
    pub bounds_max: Option<Vec3>,
    /// Cells along x, y, z (of the uniform grid whose memory an adaptive one takes).
    pub resolution: Option<[u32; 3]>,
    /// Uniform or adaptive cells (`grid = "adaptive"`); the command line's
    /// `--guide-grid` overrides it.
    pub grid: Option<GridKind>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// Where the scene was loaded from (for messages); `<string>` when parsed from text.
    pub source: PathBuf,
    pub camera: Camera,
    pub render: RenderSettings,
    /// Uniform environment radiance (default black; black where `environment_map` is given).
    pub environment: Vec3,
    /// The image environment (`[environment] file`), in place of the uniform sky.
    pub environment_map: Option<EnvironmentMap>,
    pub materials: Vec<Material>,
    pub spheres: Vec<Sphere>,
    pub quads: Vec<Quad>,
    pub meshes: Vec<Mesh>,
    /// Notes on the mesh files, each prefixed by the file: what a file asked for
    /// that rlpt does not render (one line per file), and the zero-area
    /// triangles skipped. For the command line to print; nothing is wrong.
    pub notes: Vec<String>,
    /// How each mesh file's material became one of rlpt's, one line each
    /// (`<file stem>/<name>: ...`), for `rlpt info`.
    pub material_mappings: Vec<String>,
    /// The optional `[guiding]` table (all `None` when absent).
    pub guiding: GuidingSettings,
    /// The images the materials' textures read, decoded ([`texture::load_textures`]).
    pub textures: Vec<TextureImage>,
    /// Distant, point and spot lights (from pbrt files; `crate::math::delta`).
    pub delta_lights: Vec<DeltaLight>,
}

/// A light without geometry, reached only by next-event estimation
/// (docs/correctness.md, "Delta lights"; `crate::math::delta`).
#[derive(Clone, Debug, PartialEq)]
pub enum DeltaLight {
    /// Light from one direction: `to_light` (unit) points towards it; `radiance`
    /// is pbrt's L, the irradiance on a surface facing it.
    Distant { to_light: Vec3, radiance: Vec3 },
    /// An isotropic point of `intensity` (W/sr per channel).
    Point { position: Vec3, intensity: Vec3 },
    /// A point shining along the unit `axis`: full `intensity` within the cone of
    /// cosine `cos_start`, falling off (pbrt-v4's smoothstep) to 0 at `cos_end`.
    Spot { position: Vec3, axis: Vec3, intensity: Vec3, cos_start: f32, cos_end: f32 },
}

impl DeltaLight {
    /// Whether it gives any light: some channel of its radiance or intensity
    /// above 0, and a spot's cone open.
    pub fn emits(&self) -> bool {
        let some = |c: Vec3| c.max_element() > 0.0;
        match *self {
            DeltaLight::Distant { radiance, .. } => some(radiance),
            DeltaLight::Point { intensity, .. } => some(intensity),
            DeltaLight::Spot { intensity, cos_end, .. } => some(intensity) && cos_end < 1.0,
        }
    }
}

impl Scene {
    /// Reads and validates a scene file: TOML, or a pbrt file (`.pbrt`, see
    /// `docs/pbrt.md`) whose approximations become notes.
    pub fn load(path: impl AsRef<std::path::Path>) -> Result<Scene, SceneError> {
        Scene::load_with(path, false)
    }

    /// [`Scene::load`]; with `strict`, a pbrt file's unsupported material or
    /// approximated feature is refused (naming it, its file and line) instead
    /// of noted; a TOML scene with a note on its mesh files (a texture it
    /// ignores, say) is refused with the first.
    pub fn load_with(path: impl AsRef<std::path::Path>, strict: bool) -> Result<Scene, SceneError> {
        let path = path.as_ref();
        let is_pbrt = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("pbrt"));
        if is_pbrt {
            pbrt::load(path, strict)
        } else {
            let scene = load::load_file(path)?;
            match scene.notes.first() {
                Some(note) if strict => Err(SceneError::Invalid {
                    file: path.display().to_string(),
                    position: None,
                    message: format!("{note} (refused by --strict)"),
                }),
                _ => Ok(scene),
            }
        }
    }

    /// Parses and validates scene text; `name` is used in error messages in place of a path.
    pub fn parse(text: &str, name: &str) -> Result<Scene, SceneError> {
        load::parse_str(text, name)
    }

    /// Whether material `m` emits ([`Material::emits`]): a sphere, quad or mesh
    /// triangle made of it is one of the scene's lights.
    pub fn material_emits(&self, m: u32) -> bool {
        self.materials[m as usize].emits()
    }

    /// Whether anything gives light: a sphere, quad or mesh triangle whose
    /// material emits, a delta light of some intensity, or the environment. A scene without renders black, which
    /// a loader cannot call wrong (a test may want it) but a user should hear about.
    pub fn emits_light(&self) -> bool {
        self.environment.max_element() > 0.0
            || self.environment_map.as_ref().is_some_and(|m| m.texels.iter().any(|t| t.iter().any(|&c| c > 0.0)))
            || self.spheres.iter().any(|s| self.material_emits(s.material))
            || self.quads.iter().any(|q| self.material_emits(q.material))
            || self.meshes.iter().any(|m| m.materials.iter().any(|&i| self.material_emits(i)))
            || self.delta_lights.iter().any(DeltaLight::emits)
    }
}

/// A warning for stderr where nothing in `scene` gives light, else None.
pub fn no_light_warning(scene: &Scene) -> Option<String> {
    (!scene.emits_light()).then(|| {
        format!(
            "{}: no sphere, quad, mesh triangle or delta light emits light and the environment is black: the image will be black",
            scene.source.display()
        )
    })
}
